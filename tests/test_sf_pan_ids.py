"""Session 22 (issue #8, one identity per boat on ``pan``, helper H4): a lost identity whose expected
box (carried by the camera) lies far outside the image is not relinked (``relink_view_px``, on by
default since session 22): its boat is out of the view; it waits until the camera points back at it."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

EMPTY = (np.zeros((0, 2)), np.zeros((0, 2)))
# the session-21 relink checks and the other session-22 relink defaults switched off, so that only
# the view check (with the options each test names) acts; a wide gate.  Session 28's relink_retry_s (on by
# default since then) is named off too: with this 200 px gate it would rename the young edge cluster to the
# lost identity as soon as the camera points back (tests/test_sf_h29.py covers the retry)
OFF = dict(relink_min_area=0.0, relink_area_same_zoom=False, relink_alt_s=0.0, relink_appearance=False,
           confirm_s=0.0, relink_s=10.0, coast_s=0.0, relink_px=200.0, relink_dy_h=0.0, relink_iou_tie=False,
           relink_view_zoom_in=False, relink_view_zoom_scale=False, relink_retry_s=0.0)
BOAT = [[100, 60], [130, 70]]  # a 34 x 14 px box, x 98-132
EDGE = [[10, 60], [30, 70]]  # a cluster near the image's left edge, x 8-32


def _pan(dx):
    h = np.eye(3)
    h[0, 2] = dx
    return h


def _lost_off_view(zoom_now=1.0, **kw):
    """A cluster on BOAT is lost at 0.2 s while the camera pans right (its expected box moves 60 px
    left a frame, to x -82..-48: 48 px left of the 240 x 160 image); at 0.5 s, the camera still, a
    cluster appears near the left edge, 56 px from the expected box (within the 200 px gate).
    Returns (the lost identity, the new report's identity, the clusterer)."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap(BOAT, vel, 0.0, 0, ids=[1, 2]))
    c.update(snap(BOAT, vel, 0.1, 1, ids=[1, 2]))
    for k in range(2, 5):
        c.update(snap(*EMPTY, 0.1 * k, k, ids=[], h=_pan(-60.0)))
    lb = c._lost[int(tr.ids[0])][1]
    assert np.isclose(lb[0] + lb[2], -48.0, atol=1.0)  # the expected box, carried by the pan
    _, tr2 = c.update(snap(EDGE, vel, 0.5, 5, ids=[3, 4]), zoom=zoom_now)
    assert len(tr2) == 1
    return int(tr.ids[0]), int(tr2.ids[0]), c


def test_defaults_and_off():
    p = ClusterParams()
    assert (p.relink_view_px, p.relink_view_zoom_in, p.relink_view_zoom_scale) == (120.0, True, True)
    first, now, _ = _lost_off_view(relink_view_px=0.0)
    assert now == first  # off: within the gate, relinked (the old behaviour)
    first, now, _ = _lost_off_view()
    assert now == first  # the default: 48 px out of view is within 120 px (times the zoom)


def test_no_relink_while_the_expected_box_is_out_of_view():
    first, now, c = _lost_off_view(relink_view_px=20.0)
    assert now != first and first in c._lost  # 48 px out of view: refused, still lost
    first, now, _ = _lost_off_view(relink_view_px=60.0)
    assert now == first  # within 60 px of the view: relinked


def test_view_check_only_at_the_same_zoom():
    first, now, _ = _lost_off_view(zoom_now=2.0, relink_view_px=20.0)
    assert now == first  # the zoom changed since the loss: not checked
    first, now, _ = _lost_off_view(zoom_now=2.0, relink_view_px=20.0, relink_view_same_zoom=False)
    assert now != first  # checked whatever the zoom


def test_identity_comes_back_when_the_camera_points_back():
    """The refused identity is relinked to a cluster on its boat once the camera has panned back."""
    first, now, c = _lost_off_view(relink_view_px=20.0)
    vel = [[20.0, 0.0]] * 2
    for k in range(6, 9):  # the camera pans back; the edge cluster goes on
        c.update(snap(EDGE, vel, 0.1 * k, k, ids=[3, 4], h=_pan(60.0)))
    lb = c._lost[first][1]
    assert np.isclose(lb[0], 98.0, atol=1.0)  # expected back at its first place
    vel2 = [[20.0, 0.0]] * 2 + [[-20.0, 0.0]] * 2
    _, tr = c.update(snap(EDGE + BOAT, vel2, 0.9, 9, ids=[3, 4, 5, 6]))
    ids = tr.ids.tolist()
    assert first in ids and now in ids
    assert np.isclose(tr.boxes[ids.index(first)][0], 98.0, atol=2.0)


def test_view_check_zoom_in():
    """``relink_view_zoom_in``: the check also applies after a zoom in, not after a zoom out."""
    first, now, _ = _lost_off_view(zoom_now=2.0, relink_view_px=20.0, relink_view_zoom_in=True)
    assert now != first  # zoomed in since the loss: checked, refused
    first, now, _ = _lost_off_view(zoom_now=0.5, relink_view_px=20.0, relink_view_zoom_in=True)
    assert now == first  # zoomed out: not checked


def test_view_margin_scaled_by_the_zoom():
    """``relink_view_zoom_scale``: the margin is ``relink_view_px`` times the zoom now."""
    first, now, _ = _lost_off_view(zoom_now=2.0, relink_view_px=30.0, relink_view_zoom_in=True)
    assert now != first  # 48 px out of view, margin 30: refused
    first, now, _ = _lost_off_view(zoom_now=2.0, relink_view_px=30.0, relink_view_zoom_in=True,
                                   relink_view_zoom_scale=True)
    assert now == first  # margin 30 x 2 = 60: relinked
