"""Session 31 (issue #8, helper h44): ``box_anchor_near_h_ir``, box members just outside the anchor box count
towards ``box_anchor_far_h_ir``'s two members.  The members are sim ``ir`` 20's at 11.1 s (Z3's settings): the
sailboat's cluster 6 holds its features at x 308, 312, 319 beside its 8 x 10 px box of the frame before (x 310:
only x 312 inside) and one cargo-ship stern feature at x 361, moving alike; the box widened over both.  Off by
default, infrared frames only."""
import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _box_members

X = [308.0, 312.0, 319.0, 361.0]
VX = [-0.5, -0.6, -0.7, -1.1]
LAST_BOX = np.array([310.0, 249.0, 8.0, 10.0])  # cluster 6's box at 11.0 s


def _inb(near_h, ir=True):
    cl = FeatureClusterer(ClusterParams(box_anchor_near_h_ir=near_h))
    cl._ir = ir
    cl._cluster_boxes = {6: LAST_BOX.copy()}
    cl._cluster_boxes_t = cl._cluster_boxes_now = 110
    xy = np.stack([np.array(X), np.array([253.0, 254.0, 253.0, 252.0])], axis=1)
    v = np.stack([np.array(VX), np.zeros(len(X))], axis=1)
    k = np.zeros(len(xy), np.int64)
    s = snap(xy, v, 11.1, 111, shape=(480, 640))
    anchor = cl._box_anchor(s, np.array([6]), k, xy)
    inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
    if cl._ir and cl.params.box_anchor_far_h_ir > 0 and anchor is not None:
        inb = cl._anchor_far_out(k, 1, inb, anchor, cl.params.box_anchor_far_h_ir)
    return xy[inb, 0].tolist()


def test_on_by_default_since_rule_o():
    assert ClusterParams().box_anchor_near_h_ir == 0.5  # session 31's rule O
    assert 361.0 not in _inb(ClusterParams().box_anchor_near_h_ir)  # the defaults drop the cargo's stern feature


def test_one_member_inside_keeps_the_far_one_when_off():
    assert sorted(_inb(0.0)) == X  # only x 312 inside the last box: the stern feature stays in the box


def test_near_members_count_and_the_far_one_leaves():
    assert sorted(_inb(0.5)) == X[:3]  # x 308 and 319 lie 0.1-0.2 heights outside: three anchor, 361 leaves


def test_visible_frames_unchanged():
    assert sorted(_inb(0.5, ir=False)) == sorted(_inb(0.0, ir=False))


def test_near_bar_too_small_changes_nothing():
    assert sorted(_inb(0.05)) == X  # x 308 (0.2 h) and 319 (0.1 h) are farther than 0.05 heights
