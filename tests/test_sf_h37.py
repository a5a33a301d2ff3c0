"""Session 30 (issue #8, helper h37): ``relink_jump_back_iou_ir``.  A known cluster that comes back under its own
lost identity with its box on another lost identity's expected box (the sailboat's cluster back on the cargo ship,
sim ``ir`` 43 at 13.4 s: the boxes below) takes that identity, of any age; its own stays lost where it was.  On
infrared frames only; on by default since session 30 (rule L)."""

import numpy as np

from _feature_snap import COAST_BASE, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SAIL = np.array([315.0, 248.0, 54.0, 10.0])  # the sailboat's identity 4, lost at 12.2 s (its grown box)
CARGO = np.array([371.0, 240.0, 52.0, 11.0])  # the cargo ship's identity 31, lost at 11.7 s
BACK = np.array([[368.0, 240.0, 52.0, 11.0]])  # cluster 4 back at 13.4 s, on the cargo ship


def clusterer(**kw):
    c = FeatureClusterer(ClusterParams(**kw))
    c._known = {4: 2.0, 31: 3.0}
    c._lost = {4: (12.2, SAIL.copy(), np.zeros(2)), 31: (11.7, CARGO.copy(), np.zeros(2))}
    return c


def test_on_by_default_since_session_30():
    p = ClusterParams()
    assert p.relink_jump_back_iou_ir == 0.4 and p.relink_jump_back_own_area == 2.0 and p.relink_area_med_n_ir == 5


def test_back_on_another_lost_box_takes_that_identity_of_any_age():
    c = clusterer(relink_jump_back_iou_ir=0.4)
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), BACK, rep, 13.4)
    assert rep.tolist() == [31]  # the younger identity, which relink_jump_iou would not give
    assert c._alias[4] == 31
    assert 31 not in c._lost and 4 in c._lost  # the sailboat's stays lost at its own box
    assert np.allclose(c._lost[4][1], SAIL)


def test_back_at_its_own_box_or_on_too_little_overlap_keeps_its_identity():
    c = clusterer(relink_jump_back_iou_ir=0.4)
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), SAIL[None, :] + [2.0, 0.0, 0.0, 0.0], rep, 13.4)  # where it was expected
    assert rep.tolist() == [4] and 31 in c._lost
    c = clusterer(relink_jump_back_iou_ir=0.95)  # IoU with the cargo's box ~0.9
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), BACK, rep, 13.4)
    assert rep.tolist() == [4] and 31 in c._lost


def _calls(ir, **kw):
    """Two boats' clusters lost one after the other; counts the calls of ``_jump_back``."""
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, **kw}))
    n = [0]
    orig = c._jump_back

    def spy(*a):
        n[0] += 1
        return orig(*a)

    c._jump_back = spy
    a, b, v, e = [[40, 60], [48, 64]], [[140, 60], [150, 64]], [[3, 0], [3, 0]], np.zeros((0, 2))
    for k in range(6):
        c.update(snap(a + b, v + v, 0.1 * k, k, [1, 2, 3, 4]), None, ir=ir)
    c.update(snap(a, v, 0.6, 6, [1, 2]), None, ir=ir)
    for k in range(7, 10):
        c.update(snap(e, e, 0.1 * k, k, []), None, ir=ir)
    assert len(c._lost) == 2
    return n[0]


def test_acts_on_infrared_frames_only_and_not_when_off():
    assert _calls(True, relink_jump_back_iou_ir=0.4) > 0
    assert _calls(False, relink_jump_back_iou_ir=0.4) == 0
    assert _calls(True, relink_jump_back_iou_ir=0.0) == 0


def test_jump_back_guards_a_box_of_another_size_and_a_long_loss():
    c = clusterer(relink_jump_back_iou_ir=0.4)
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), np.array([[368.0, 240.0, 80.0, 11.0]]), rep, 13.4)  # 1.5x+ the cargo's area
    assert rep.tolist() == [4] and 31 in c._lost
    c = clusterer(relink_jump_back_iou_ir=0.4, relink_jump_back_area=0.0)  # no area check
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), np.array([[368.0, 240.0, 80.0, 11.0]]), rep, 13.4)
    assert rep.tolist() == [31]
    c = clusterer(relink_jump_back_iou_ir=0.4)
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), BACK, rep, 15.3)  # its own lost 3.1 s before: not a drop-out
    assert rep.tolist() == [4] and 31 in c._lost


# relink_area_med_n_ir: a small boat lost at a box grown for one frame keeps its identity for its own new cluster


def _area_run(ir=True, **kw):
    # relink_shape_min_n_ir (40 since session 31's rule O) also relinks this case: off here, to test the median alone
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, "relink_shape_min_n_ir": 0,
                                          **kw}))
    a, v = [[40, 60], [48, 64], [44, 62]], [[3, 0]] * 3
    w = [[30, 52], [70, 70], [40, 60], [48, 64], [44, 62], [56, 66]]  # the last box: 44 x 22 px (12 x 8 before)
    e = np.zeros((0, 2))
    tr = None
    for k in range(8):
        tr = c.update(snap(a, v, 0.1 * k, k, [1, 2, 3]), None, ir=ir)[1]
    own = int(tr.ids[0])
    c.update(snap(w, [[3, 0]] * 6, 0.8, 8, [4, 5, 1, 2, 3, 6]), None, ir=ir)
    for k in range(9, 15):
        c.update(snap(e, e, 0.1 * k, k, []), None, ir=ir)
    assert own in c._lost
    tr = c.update(snap([[41, 61], [47, 64], [44, 62]], v, 1.5, 15, [7, 8, 9]), None, ir=ir)[1]  # 10 x 7 px
    return own, [int(r) for r in tr.ids]


def test_area_med_on_by_default_off_when_0_and_infrared_only():
    assert ClusterParams().relink_area_med_n_ir == 5  # the default since session 30
    own, ids = _area_run(relink_area_med_n_ir=0)
    assert own not in ids  # 70 px < 0.3 of the 968 px box at the loss
    own, ids = _area_run(relink_area_med_n_ir=5)
    assert ids == [own]  # the median of its last 5 boxes: 96 px
    own, ids = _area_run(ir=False, relink_area_med_n_ir=5)
    assert own not in ids


def test_jump_back_own_area_guard():
    assert ClusterParams().relink_jump_back_own_area == 2.0  # the default since session 30
    c = clusterer(relink_jump_back_iou_ir=0.4, relink_jump_back_own_area=2.0)
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), BACK, rep, 13.4)  # its box at the loss (54 x 10) had the cargo's size: 1.06
    assert rep.tolist() == [31]
    c = clusterer(relink_jump_back_iou_ir=0.4, relink_jump_back_own_area=2.0)
    c._lost[4] = (12.2, np.array([315.0, 248.0, 13.0, 12.0]), np.zeros(2))  # a small boat's box at the loss: 3.7x
    rep = np.array([4], np.int64)
    c._jump_back(np.array([4]), BACK, rep, 13.4)
    assert rep.tolist() == [4] and 31 in c._lost
