"""Session 22 (issue #8, identities at ``pan``'s zoom-out, helper H6): through a zoom change, where
``relink_area_same_zoom`` skips the ``relink_min_area`` check, ``relink_area_zoom_min`` (off by default)
still refuses a relink to a cluster much smaller than the lost box (a fragment of another boat, or of
the same boat before its own cluster forms)."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

EMPTY = (np.zeros((0, 2)), np.zeros((0, 2)))
# the other relink checks off except the session-21 area check (relink_min_area 0.3 with
# relink_area_same_zoom, the defaults); a wide gate
OFF = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=10.0, coast_s=0.0,
           relink_px=200.0, relink_dy_h=0.0, relink_iou_tie=False, relink_view_px=0.0)
BOAT = [[100, 60], [130, 70]]  # a 34 x 14 px box
FRAG = [[150, 64], [153, 66]]  # a small cluster beside it: a 7 x 6 px box (area x0.09)
ALIKE = [[150, 60], [178, 70]]  # a cluster of about the boat's size beside it


def _relinked(new_pts, zoom_now, **kw):
    """A cluster on BOAT (zoom 1) is lost at 0.2 s; at 0.5 s, with the camera's zoom ``zoom_now``
    (the expected box is not rescaled: the homographies are the identity), one new cluster on
    ``new_pts`` appears.  Returns whether it took the lost identity, and the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap(BOAT, vel, 0.0, 0, ids=[1, 2]))
    c.update(snap(BOAT, vel, 0.1, 1, ids=[1, 2]))
    for k in range(2, 5):
        c.update(snap(*EMPTY, 0.1 * k, k, ids=[]))
    first = int(tr.ids[0])
    assert first in c._lost
    _, tr2 = c.update(snap(new_pts, vel, 0.5, 5, ids=[3, 4]), zoom=zoom_now)
    assert len(tr2) == 1
    return int(tr2.ids[0]) == first, c


def test_off_by_default_and_off_is_the_old_behaviour():
    assert ClusterParams().relink_area_zoom_min == 0.0
    took, _ = _relinked(FRAG, 2.0)
    assert took  # the zoom changed: relink_area_same_zoom skips the area check, the fragment takes it
    took, _ = _relinked(FRAG, 1.0)
    assert not took  # the same zoom: relink_min_area 0.3 refuses it (unchanged)


def test_fragment_refused_through_a_zoom_change():
    took, c = _relinked(FRAG, 2.0, relink_area_zoom_min=0.15)
    assert not took and len(c._lost) == 1  # refused: still lost, waiting for its boat
    took, _ = _relinked(FRAG, 2.0, relink_area_zoom_min=0.05)
    assert took  # area x0.09 is above a 0.05 limit


def test_boat_sized_cluster_still_relinked_through_a_zoom_change():
    took, _ = _relinked(ALIKE, 2.0, relink_area_zoom_min=0.15)
    assert took


def test_needs_relink_area_same_zoom():
    """Without ``relink_area_same_zoom`` the full ``relink_min_area`` check applies at any zoom; the
    looser one adds nothing."""
    took, _ = _relinked(FRAG, 2.0, relink_area_same_zoom=False, relink_min_area=0.0, relink_area_zoom_min=0.15)
    assert took


WIDE_LOW = [[150, 65], [190, 66]]  # as wide as the boat, low: a 44 x 5 px box (area x0.46, height x0.36)
NARROW = [[150, 60], [152, 70]]  # narrow, as tall: a 6 x 14 px box (area x0.18, height 1.0)


def test_height_check_through_a_zoom_change():
    assert ClusterParams().relink_height_zoom_min == 0.3  # on by default since session 22
    took, _ = _relinked(WIDE_LOW, 2.0, relink_height_zoom_min=0.0)
    assert took  # off: relinked
    took, c = _relinked(WIDE_LOW, 2.0, relink_height_zoom_min=0.5)
    assert not took and len(c._lost) == 1  # height x0.36 < 0.5: refused
    took, _ = _relinked(NARROW, 2.0, relink_height_zoom_min=0.5)
    assert took  # a narrow cluster of the boat's height (a boat entering the view) is relinked
    took, _ = _relinked(NARROW, 2.0, relink_area_zoom_min=0.25)
    assert not took  # the area check refuses it
