"""Session 25 (issue #8, helper H19): boats the pan takes out of view and brings back.
``coast_edge_seen``: the edge look's window (``coast_edge_s``) is counted from the last frame the
identity's coast was seen, not from the loss; ``coast_edge_dy``: an edge look that sees nothing at
the expected rows (the zoom moved the expected box of a boat far outside the image off its rows) is
tried at rows shifted by half a box height at a time, nearest first."""

from _feature_snap import hull_lost_then_moved
from seawatch.track.feature_clusters import ClusterParams

SHAPE = (160, 240)
HULL = (100, 60, 140, 70)  # x0, y0, x1, y1 (exclusive) of the dark hull, 40 x 10 px


def run(moves, boats, dys=None, dxs=None, **kw):
    """:func:`_feature_snap.hull_lost_then_moved` with this file's hull."""
    return hull_lost_then_moved(moves, boats, dys, dxs, shape=SHAPE, hull=HULL, **kw)


# out of view for three frames, then back 10 px into view at the left edge, 15 px below its rows
MOVES, BOATS, DYS = [-150.0, 0.0, 0.0, 20.0], [False, False, False, True], [0, 0, 0, 15]


def test_coast_edge_dy_off_by_default_and_off_the_boat_below_its_rows_is_not_seen():
    p = ClusterParams()
    assert p.coast_edge_dy == 0.0 and p.coast_edge_seen is True  # coast_edge_seen on by default since session 28
    c, _, out = run(MOVES, BOATS, DYS, coast_edge_dy=0.0)
    assert all(len(tr) == 0 for tr in out)
    assert [e[3] for e in c.coast_log][-1] == "outside"  # looked at its rows: open water, still waits


def test_coast_edge_dy_finds_the_boat_below_its_rows_with_its_identity():
    c, ident, out = run(MOVES, BOATS, DYS, coast_edge_dy=2.0)
    assert all(len(tr) == 0 for tr in out[:3])
    tr = out[3]
    assert tr.ids.tolist() == [ident]
    x, y, w, h = tr.boxes[0]
    assert x == 0 and abs(w - 10) <= 1.5 and abs(y - 75) <= 1 and abs(y + h - 85) <= 1
    assert [e[3] for e in c.coast_log] == ["outside"] * 3 + ["edge"]


def test_coast_edge_dy_is_bounded():
    # 15 px = 1.5 box heights below: a bound of 1.0 box height does not reach it
    _, _, out = run(MOVES, BOATS, DYS, coast_edge_dy=1.0)
    assert all(len(tr) == 0 for tr in out)


def test_coast_edge_dy_open_water_is_not_reported():
    _, _, out = run(MOVES, [False] * 4, DYS, coast_edge_dy=2.0)
    assert all(len(tr) == 0 for tr in out)


# seen at the left edge for two frames (to t 0.7), out of view for two, back 23 px into view at t 1.0
# (its own motion: 20 px right of where the camera carried it): 0.4 s after the loss (t 0.6), 0.3 s
# after its coast was last seen
MOVES2, BOATS2, DXS2 = [-125.0, -2.0, -150.0, 0.0, 140.0], [True, True, False, False, True], [0, 0, 0, 0, 20]


def test_coast_edge_seen_counts_the_window_from_the_last_look_that_saw_the_boat():
    # off: the window ends 0.35 s after the loss
    c, ident, out = run(MOVES2, BOATS2, dxs=DXS2, coast_edge_s=0.35, coast_edge_seen=False)
    assert out[0].ids.tolist() == [ident] and out[1].ids.tolist() == [ident]
    assert len(out[4]) == 0
    c, ident, out = run(MOVES2, BOATS2, dxs=DXS2, coast_edge_s=0.35, coast_edge_seen=True)
    assert out[0].ids.tolist() == [ident] and out[1].ids.tolist() == [ident]
    assert all(len(tr) == 0 for tr in out[2:4])
    assert out[4].ids.tolist() == [ident]
    x, y, w, h = out[4].boxes[0]
    assert x == 0 and abs(w - 23) <= 1.5 and abs(y - 60) <= 1 and abs(y + h - 70) <= 1


def test_coast_edge_seen_still_bounded():
    # 0.25 s from the last look that saw it is less than the 0.3 s the boat was away
    _, _, out = run(MOVES2, BOATS2, dxs=DXS2, coast_edge_s=0.25, coast_edge_seen=True)
    assert len(out[4]) == 0
