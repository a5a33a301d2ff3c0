"""Session 29 (issue #8, helper h33): ``relink_side_row_margin``.  A level horizon at row 40.  Two boats leave
the view at the image's left edge at two rows (B at rows 98-102 first: its bottom 62 px under the horizon; then
the camera moves the content 50 px left; then A at rows 58-62: 22 px under it); 3 s later a new cluster is born
at the left edge on B's rows (60 px under the horizon).  Its gap to A's expected box (34 px, vertical) is smaller
than to B's (carried 50 px out of the view: 43 px), so the relink's nearest-first pairs give it A's identity;
with the margin, A (38 px off in its row under the horizon, B 2 px) is not its candidate and it takes B's.  The
row check ``relink_dy_h`` is off here (it would refuse A outright at this short loss)."""

import numpy as np

from _feature_snap import COAST_BASE, Level, snap, shift
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

A = [[1, 58], [9, 62]]  # boat A's two features (box [1, 58, 8, 4]), at the left edge
B = [[1, 98], [9, 102]]  # boat B's
V = [[-5, 0], [-5, 0]]
W = [[5, 0], [5, 0]]
NONE = np.zeros((0, 2))


def run(ir=False, horizon=True, new=([[2, 96], [10, 100]]), **kw):
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "relink_dy_h": 0.0, "coast_s": 0.0,
                                          "relink_retry_s": 0.0, "relink_hold_s": 0.0, **kw}))
    hz = Level(40) if horizon else None

    def step(xy, v, k, ids, h=None):
        return c.update(snap(xy, v, 0.1 * k, k, ids, h=h), None, horizon=hz, ir=ir)[1]

    tr = None
    for k in range(6):
        tr = step(A + B, V + W, k, [1, 2, 3, 4])
    assert len(tr) == 2
    order = np.argsort(tr.boxes[:, 1])
    ids = {"A": int(tr.ids[order[0]]), "B": int(tr.ids[order[1]])}
    step(A, V, 6, [1, 2])  # B gone: lost at the left edge
    step(A, V, 7, [1, 2], h=shift(-50))  # the camera moves: B's expected box 50 px out of the view
    step(NONE, NONE, 8, [])  # A gone
    for k in range(9, 38):
        step(NONE, NONE, k, [])
    assert ids["A"] in c._lost and ids["B"] in c._lost
    tr = step(new, [[3, 0], [3, 0]], 38, [5, 6])  # the new cluster on B's rows
    return ids, [int(r) for r in tr.ids]


def test_default_on_and_off_the_nearer_lost_identity_is_taken():
    p = ClusterParams()
    assert p.relink_side_row_margin == 20.0 and p.relink_side_row_ir is False  # on since session 29 (rule K)
    ids, born = run()
    assert born == [ids["B"]]
    ids, born = run(relink_side_row_margin=0.0)  # the step off: the nearer lost identity
    assert born == [ids["A"]]


def test_relink_side_row_margin_takes_the_identity_lost_at_its_row():
    ids, born = run(relink_side_row_margin=20.0)
    assert born == [ids["B"]]


def test_relink_side_row_margin_within_the_margin_or_without_a_horizon_the_nearer_is_taken():
    ids, born = run(relink_side_row_margin=40.0)  # 2 px (B) and 38 px (A): within 40 px of each other
    assert born == [ids["A"]]
    ids, born = run(horizon=False, relink_side_row_margin=20.0)
    assert born == [ids["A"]]


def test_relink_side_row_margin_off_on_infrared_frames_unless_asked():
    ids, born = run(ir=True, relink_side_row_margin=20.0)
    assert born == [ids["A"]]
    ids, born = run(ir=True, relink_side_row_margin=20.0, relink_side_row_ir=True)
    assert born == [ids["B"]]


# relink_app_min_w_px: an identity lost as a sliver at the image's edge keeps no look

from _feature_snap import dark_box_sea  # noqa: E402

SHAPE = (160, 240)
HULL = (0, 60, 4, 72)  # a dark hull cut by the left edge: 4 x 12 px


def run_sliver(**kw):
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, **kw}))
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[1, 62], [3, 70]], [[-5, 0], [-5, 0]], 0.1 * k, k, [1, 2]), dark_box_sea(SHAPE, HULL, k))
    assert len(tr) == 1
    ident = int(tr.ids[0])
    assert 2 <= tr.boxes[0][2] < 4  # a 2 px sliver
    c.update(snap(NONE, NONE, 0.6, 6, []), dark_box_sea(SHAPE, HULL, 6, boat=False))
    assert ident in c._lost
    return c, ident


def test_relink_app_min_w_px_off_by_default_the_sliver_keeps_its_look():
    p = ClusterParams()
    assert p.relink_app_min_w_px == 0.0 and p.relink_app_min_w_ir is False
    c, ident = run_sliver()
    assert c._lost_sig.get(ident) is not None


def test_relink_app_min_w_px_the_sliver_keeps_no_look():
    c, ident = run_sliver(relink_app_min_w_px=4.0)
    assert c._lost_sig.get(ident) is None
    c, ident = run_sliver(relink_app_min_w_px=2.0)  # not under 2 px: kept
    assert c._lost_sig.get(ident) is not None
