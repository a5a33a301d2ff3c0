"""Session 24 (issue #8, helper H7): a coast whose expected box lies left or right of the image is
looked at on the image's edge (``coast_edge``): the boat that straddles the edge (the pan or the zoom
carried it across) is reported with its identity, the part of it in view."""

import numpy as np

from _feature_snap import dark_box_sea, hull_lost_then_moved
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer
from seawatch.types import TrackState

SHAPE = (160, 240)
HULL = (100, 60, 140, 70)  # x0, y0, x1, y1 (exclusive) of the dark hull, 40 x 10 px


def sea(seed, dx=0, boat=True):
    """Grey sea (120, noise 2) with the dark hull (60) moved ``dx`` px (cut by the image's edges)."""
    return dark_box_sea(SHAPE, HULL, seed, dx=dx, boat=boat)


def run(moves, boats=None, **kw):
    """:func:`_feature_snap.hull_lost_then_moved` with this file's hull (session 24's second looks off)."""
    return hull_lost_then_moved(moves, boats, shape=SHAPE, hull=HULL, **kw)


def test_on_by_default_since_session_24_and_off_the_coast_ends_outside():
    assert ClusterParams().coast_edge == 6.0  # the lead's decision U3 (0: off)
    # the pan carries the hull to x -25..15: its expected box's centre lies left of the image
    c, _, out = run([-125.0, -2.0], coast_edge=0.0)
    assert all(len(tr) == 0 for tr in out)
    assert [e[3] for e in c.coast_log] == ["outside"]  # ended at once
    _, ident, out = run([-125.0, -2.0])  # by default the part in view is reported with its identity
    assert all(tr.ids.tolist() == [ident] for tr in out)


def test_the_part_in_view_at_the_left_edge_is_reported_with_the_identity():
    c, ident, out = run([-125.0, -2.0], coast_edge=6.0)
    for tr, vis in zip(out, (15, 13)):
        assert tr.ids.tolist() == [ident]
        assert tr.states.tolist() == [int(TrackState.COASTING)]
        x, y, w, h = tr.boxes[0]
        assert x == 0 and abs(w - vis) <= 1.5 and abs(y - 60) <= 1 and abs(y + h - 70) <= 1
    assert [e[3] for e in c.coast_log] == ["edge", "edge"]


def test_the_right_edge_too():
    # the pan carries the hull to x 225..265 (15 px in view at the right edge)
    c, ident, out = run([125.0], coast_edge=6.0)
    tr = out[0]
    assert tr.ids.tolist() == [ident]
    x, y, w, h = tr.boxes[0]
    assert abs(x - 225) <= 1.5 and abs(x + w - SHAPE[1]) <= 0.5 and abs(y - 60) <= 1 and abs(y + h - 70) <= 1


def test_open_water_at_the_edge_is_not_reported_and_the_coast_waits_for_the_boat():
    # out of view for three frames (open water at the edge), then the hull comes back 10 px into view
    c, ident, out = run([-150.0, 0.0, 0.0, 20.0], boats=[False, False, False, True], coast_edge=6.0)
    assert all(len(tr) == 0 for tr in out[:3])
    tr = out[3]
    assert tr.ids.tolist() == [ident]
    x, y, w, h = tr.boxes[0]
    assert x == 0 and abs(w - 10) <= 1.5
    assert [e[3] for e in c.coast_log] == ["outside"] * 3 + ["edge"]


def test_bounded_by_coast_s():
    # the hull comes back 0.3 s after the loss: beyond coast_s 0.25 it is not looked at
    c, _, out = run([-150.0, 0.0, 0.0, 20.0], boats=[False, False, False, True], coast_edge=6.0, coast_s=0.25)
    assert all(len(tr) == 0 for tr in out)
    assert "edge" not in [e[3] for e in c.coast_log]


def test_bounded_by_the_area_ratio():
    # the whole 40 x 10 hull's part in view (15 x 10) is 0.375 of the expected box: a bound of 0.3
    # (a grown box at most 0.3 times the expected area) refuses it
    c, _, out = run([-125.0], coast_edge=0.3)
    assert len(out[0]) == 0


def test_the_edge_look_cuts_the_box_at_the_edge_on_either_side():
    # 15 px of the hull in view at the left edge; the mirrored image: at the right edge
    c = FeatureClusterer(ClusterParams(coast_edge=6.0))
    img = sea(3, dx=-125)
    g, ct, fd = c._edge_grow(img, np.array([0.0, 60.0, 40.0, 10.0]), True)
    assert fd and ct >= 4.0 and np.allclose(g, [0, 60, 15, 10], atol=1)
    g, ct, fd = c._edge_grow(np.ascontiguousarray(img[:, ::-1]), np.array([200.0, 60.0, 40.0, 10.0]), False)
    assert fd and ct >= 4.0 and np.allclose(g, [225, 60, 15, 10], atol=1)
    # open water: nothing found
    g, ct, fd = c._edge_grow(sea(3, boat=False), np.array([0.0, 60.0, 40.0, 10.0]), True)
    assert not (fd and ct >= 4.0)


def test_coast_edge_s_bounds_the_wait_at_the_edge():
    assert ClusterParams().coast_edge_s == 8.0  # on by default since session 24 (0: within coast_s)
    # the hull comes back 0.3 s after the loss: a bound of 0.25 s ends the wait (no look then), 0.35 s does not
    c, _, out = run([-150.0, 0.0, 0.0, 20.0], boats=[False, False, False, True], coast_edge=6.0, coast_edge_s=0.25)
    assert all(len(tr) == 0 for tr in out)
    assert "edge" not in [e[3] for e in c.coast_log]
    c, ident, out = run([-150.0, 0.0, 0.0, 20.0], boats=[False, False, False, True], coast_edge=6.0, coast_edge_s=0.35)
    assert out[3].ids.tolist() == [ident]
