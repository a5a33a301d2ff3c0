"""Session 31 (issue #8, helper h42): ``relink_shape_block_s_ir`` and ``relink_shape_min_n_ir``, the relink's
shape checks and a small boat's box widened over a neighbour's feature (sim ``ir`` 53 at 39.4 s, ``ir`` 43 at
25.0 s: the boxes below).  Both on infrared frames only; off until session 31's rule N made them the defaults
(``relink_shape_block_s_ir`` 1 s, ``relink_shape_min_n_ir`` 5, 40 since rule O), so the cases below start from them off."""

import numpy as np

from seawatch.detect.features import FeatureSnapshot
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SAIL8 = np.array([288.0, 245.0, 11.0, 14.0])  # ir 53: the sailboat's identity 8, lost at 38.7 s
CARGO14 = np.array([366.0, 241.0, 52.0, 10.0])  # ir 53: the cargo ship's identity 14, lost at 20.6 s
WIDE = np.array([[287.0, 248.0, 57.0, 11.0]])  # ir 53: new cluster 317 at 39.4 s, over the sailboat and the stern
NARROW = np.array([[290.0, 243.0, 8.0, 16.0]])  # ir 53: cluster 317 at 40.2 s, the sailboat alone
OFF = {"relink_shape_block_s_ir": 0.0, "relink_shape_min_n_ir": 0}  # the steps off, as before rule N


def _snap(t):
    z = np.zeros((0, 2))
    return FeatureSnapshot(t_s=t, frame_index=int(round(t * 10)), ids=np.zeros(0, int), slots=np.zeros(0, int),
                           xy=z, size_px=np.zeros(0), confidence=np.zeros(0, int), stable=np.zeros(0, bool),
                           matched=np.zeros(0, bool), velocity=z, history=np.zeros((0, 4, 2)), image_velocity=z,
                           homography=np.eye(3), dt_s=0.1, n_keypoints=0, n_matched=0, shape=(480, 640))


def _clusterer(ir=True, **kw):
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    c._ir = ir
    c._lost = {8: (38.7, SAIL8.copy(), np.zeros(2)), 14: (20.6, CARGO14.copy(), np.zeros(2))}
    return c


def test_on_by_default_since_rule_n():
    p = ClusterParams()
    assert p.relink_shape_block_s_ir == 1.0 and p.relink_shape_min_n_ir == 40 and p.relink_shape_min_grown_ir == 2.0
    # the defaults give ir 53's case the answer of the step on
    c = FeatureClusterer(ClusterParams())
    c._ir = True
    c._lost = {8: (38.7, SAIL8.copy(), np.zeros(2)), 14: (20.6, CARGO14.copy(), np.zeros(2))}
    assert c._relink(_snap(39.4), np.array([317]), WIDE.copy()).tolist() == [317]


def test_block_keeps_the_far_identity_and_gives_the_covered_one_later():
    c = _clusterer(relink_shape_block_s_ir=1.0)
    rep = c._relink(_snap(39.4), np.array([317]), WIDE.copy())
    assert rep.tolist() == [317]  # neither the sailboat's (refused by the aspect ratio) nor the cargo's
    assert 14 in c._lost and 8 in c._lost
    for t in (39.5, 39.6, 39.7):
        rep = c._relink(_snap(t), np.array([317]), WIDE.copy())
        assert rep.tolist() == [317]
    rep = c._relink(_snap(40.2), np.array([317]), NARROW.copy())  # its box is the sailboat's now
    assert rep.tolist() == [8] and 8 not in c._lost and 14 in c._lost


def test_block_off_or_on_visible_frames_takes_the_far_identity():
    for c in (_clusterer(), _clusterer(ir=False, relink_shape_block_s_ir=1.0)):
        rep = c._relink(_snap(39.4), np.array([317]), WIDE.copy())
        assert rep.tolist() == [14]  # the defaults' answer: the cargo's identity, 22 px away


def test_block_waits_only_its_time():
    c = _clusterer(relink_shape_block_s_ir=0.5)
    rep = c._relink(_snap(39.4), np.array([317]), WIDE.copy())
    assert rep.tolist() == [14]  # the sailboat's lost 0.7 s before: longer than 0.5 s, no block
    c = _clusterer(relink_shape_block_s_ir=0.8)
    assert c._relink(_snap(39.4), np.array([317]), WIDE.copy()).tolist() == [317]
    rep = c._relink(_snap(40.3), np.array([317]), NARROW.copy())  # 0.9 s later: no longer waiting
    assert rep.tolist() == [317]


def _shape_min(ir=True, last=None, **kw):
    """ir 43: the sailboat's boxes 8 x 10 px, widened to 55 x 11 px for its last 3 frames, then lost; 13 s later its
    own new 8 x 10 px cluster beside it."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    c._ir = ir
    boxes = [[314.0, 248.0, 8.0, 11.0], [314.0, 249.0, 8.0, 10.0], [315.0, 248.0, 55.0, 11.0],
             [315.0, 248.0, 54.0, 10.0], [315.0, 248.0, 54.0, 10.0]]
    if last is not None:
        boxes[-1] = last
    t = 11.6
    for b in boxes:
        c._relink(_snap(t), np.array([4]), np.array([b]))
        t += 0.1
    c._relink(_snap(t), np.zeros(0, int), np.zeros((0, 4)))
    assert 4 in c._lost
    return c._relink(_snap(25.0), np.array([190]), np.array([[302.0, 248.0, 8.0, 10.0]])).tolist()


def test_shape_min_gives_the_identity_lost_at_a_widened_box():
    assert _shape_min() == [190]  # refused by the aspect ratio and the size check
    assert _shape_min(relink_shape_min_n_ir=5) == [4]
    assert _shape_min(ir=False, relink_shape_min_n_ir=5) == [190]
    assert _shape_min(relink_shape_min_n_ir=3) == [190]  # its last 3 boxes were all wide


def test_shape_min_only_for_a_box_grown_before_the_loss():
    # its box at the loss 100 x 8 px, 10 times its smallest (8 x 10 px): grown, unless the ratio asked is 20
    c = _shape_min(last=[315.0, 248.0, 100.0, 8.0], relink_shape_min_n_ir=5, relink_shape_min_grown_ir=20.0)
    assert c == [190]  # 800 px < 20 x 80 px: the smallest box is not used
    assert _shape_min(last=[315.0, 248.0, 100.0, 8.0], relink_shape_min_n_ir=5) == [4]


def _any(**kw):
    """ir 42: the cargo ship's boxes 73 x 30 px, then a 12 x 23 px sliver at its loss; its new 53 x 13 px cluster."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    c._ir = True
    t = 5.0
    for b in ([311.0, 229.0, 73.0, 30.0],) * 4 + ([371.0, 229.0, 12.0, 23.0],):
        c._relink(_snap(t), np.array([11]), np.array([b]))
        t += 0.1
    c._relink(_snap(t), np.zeros(0, int), np.zeros((0, 4)))
    assert 11 in c._lost
    return c._relink(_snap(9.9), np.array([84]), np.array([[377.0, 238.0, 53.0, 13.0]])).tolist()


def test_shape_any_passes_against_any_last_box_of_a_like_area():
    assert _any() == [84]  # refused by the aspect ratio against the sliver (7.8)
    assert _any(relink_shape_min_n_ir=5) == [84]  # the sliver is its smallest box: no help
    assert _any(relink_shape_min_n_ir=5, relink_shape_any_ir=True) == [11]  # its 73 x 30 px boxes: 1.7, area 3.2x
    assert _any(relink_shape_min_n_ir=5, relink_shape_any_ir=True, relink_shape_any_area=3.0) == [84]
    assert ClusterParams().relink_shape_any_ir is False
