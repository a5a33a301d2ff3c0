"""The far strip's identities (issue #8, session 26 round 2, helper H25): with
``ClusterParams.far_id_px`` (0: off) an identity does not pass between the far strip (a box whose
bottom lies less than ``far_id_px`` under the horizon, or above it) and the water below it, neither
by the relink nor by the hand-over; ``far_id_ir`` (False) extends it to infrared frames.
``far_cut_deep_px`` (0: off; 24 by default since session 28) with ``far_cut_deep_gap_px``: a deeper band of H22's far cut with a longer
gap (a boat 12-25 px under the horizon is not joined to a boat 35-50 px below it)."""

from __future__ import annotations

import numpy as np

from _feature_snap import Level

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _far_cut

ROW = 100.0  # the horizon's row




def _clusterer(ir=False, **kw):
    fc = FeatureClusterer(ClusterParams(**kw))
    fc._horizon = Level(ROW)
    fc._ir = ir
    fc._zoom = 1.0
    return fc


FAR = np.array([150.0, ROW - 4.0, 20.0, 8.0])  # bottom 4 px under the horizon
BELOW = np.array([150.0, ROW + 6.0, 20.0, 12.0])  # bottom 18 px under it, overlapping the far box's column
BELOW2 = np.array([152.0, ROW, 20.0, 14.0])  # bottom 14 px under it, overlapping both


def _hand(fc, lost_box, new_box):
    """Identity 5 lost at ``lost_box``; cluster 9 (own identity, younger) at ``new_box``: who takes 5."""
    fc._lost = {5: (1.0, lost_box.copy(), None)}
    cids = np.array([9], np.int64)
    rep = cids.copy()
    now = {9: new_box.copy()}
    r = fc._hand_over(5, cids, new_box[None].copy(), rep, now, {})
    return r, int(rep[0])


def test_off_by_default():
    p = ClusterParams()
    assert p.far_id_px == 0 and p.far_id_ir is False
    fc = _clusterer()
    assert fc._far_side(np.array([FAR, BELOW])) is None
    assert not fc._far_apart(FAR, BELOW)
    # the hand-over across the strip's line happens as before (overlap 0.3 of the smaller box)
    big_far = np.array([150.0, ROW - 6.0, 20.0, 16.0])  # bottom 10 px under the horizon
    r, rep = _hand(fc, big_far, BELOW2)
    assert r == 9 and rep == 5


def test_far_side_and_apart():
    fc = _clusterer(far_id_px=12.0)
    side = fc._far_side(np.array([FAR, BELOW, [10.0, ROW - 30.0, 5.0, 5.0]]))
    assert side.tolist() == [True, False, True]
    assert fc._far_apart(FAR, BELOW) and not fc._far_apart(BELOW, BELOW2)
    fc._horizon = None
    assert fc._far_side(np.array([FAR])) is None


def test_hand_over_not_across_the_line():
    big_far = np.array([150.0, ROW - 6.0, 20.0, 16.0])
    fc = _clusterer(far_id_px=12.0)
    r, rep = _hand(fc, big_far, BELOW2)
    assert r is None and rep == 9  # the far ship's identity stays lost
    r, rep = _hand(fc, BELOW, BELOW2)
    assert r == 9 and rep == 5  # below the strip, both: as before


def test_ir_only_with_far_id_ir():
    big_far = np.array([150.0, ROW - 6.0, 20.0, 16.0])
    fc = _clusterer(ir=True, far_id_px=12.0)
    assert fc._far_side(np.array([FAR])) is None
    r, _ = _hand(fc, big_far, BELOW2)
    assert r == 9
    fc = _clusterer(ir=True, far_id_px=12.0, far_id_ir=True)
    r, _ = _hand(fc, big_far, BELOW2)
    assert r is None


def _edges():
    """Features (x, y): a boat 14-24 px under the horizon (0, 1), a boat 40 px under it (2, 3), a tall far
    ship 2-18 px under it (4, 5); edges 0-1, 0-2, 1-3, 4-5."""
    xy = np.array([[100, ROW + 14], [104, ROW + 24], [102, ROW + 55], [108, ROW + 60],
                   [200, ROW + 2], [204, ROW + 18]], float)
    return xy, np.array([0, 0, 1, 4]), np.array([1, 2, 3, 5])


def test_far_cut_deep():
    xy, ei, ej = _edges()
    # on by default since session 28 (24 px, gap 20)
    assert (ClusterParams().far_cut_deep_px, ClusterParams().far_cut_deep_gap_px) == (24.0, 20.0)
    # off: H22's cut alone (12 px, gap 6) drops only the tall far ship's edge 4-5
    keep = _far_cut(xy, ei, ej, Level(ROW), 1.0, ClusterParams(far_cut_px=12.0, far_cut_deep_px=0.0))
    assert keep.tolist() == [True, True, True, False]
    # the deeper band (30 px, gap 20) drops the edges from the near-far boat to the boat below
    p = ClusterParams(far_cut_px=12.0, far_cut_deep_px=30.0, far_cut_deep_gap_px=20.0)
    keep = _far_cut(xy, ei, ej, Level(ROW), 1.0, p)
    assert keep.tolist() == [True, False, False, False]
    # the gap is scaled by the zoom: at zoom 2 (gap 40 px) the 41 px edge 0-2 is dropped, the 36 px one 1-3 kept
    keep = _far_cut(xy, ei, ej, Level(ROW), 2.0, p)
    assert keep.tolist() == [True, False, True, False]  # (4-5: H22's gap 12 px at zoom 2)
    # the deep band alone (far_cut_px off): the tall far ship keeps its 16 px edge
    p = ClusterParams(far_cut_px=0.0, far_cut_deep_px=30.0, far_cut_deep_gap_px=20.0)
    keep = _far_cut(xy, ei, ej, Level(ROW), 1.0, p)
    assert keep.tolist() == [True, False, False, True]
