"""Session 32 (issue #8, helper h47): ``box_anchor_gap_side_ir``, far box members beyond an x gap from the
members inside or near the anchor box leave the box even where ``box_anchor_far_minority_ir`` would keep
them.  The members are sim ``ir`` 79's at 36.2 s (defaults): the sailboat's cluster 215 holds its features
at x 288, 291, 298 beside its 8 x 11 px box of the frame before (x 288) and three cargo-ship features at
x 332, 375, 388, all moving alike; three far against three near, so the minority rule kept them and the box
went over both boats.  Infrared frames only; the default since session 32's rule P (3 sides, with
``box_anchor_gap_one_ir`` and ``box_anchor_gap_steady_ir``)."""
import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _box_members

X = [288.0, 291.0, 298.0, 332.0, 375.0, 388.0]
VX = [-0.5, -0.7, -0.7, -0.6, -0.6, -1.0]
LAST_BOX = np.array([288.0, 248.0, 8.0, 11.0])  # cluster 215's box at 36.1 s


def _inb(gap_h, ir=True, x=X, last=LAST_BOX, steady=False):
    # the step alone (its two companions off) unless steady: then the defaults, the cluster's box steady
    if steady:
        cl = FeatureClusterer(ClusterParams(box_anchor_gap_side_ir=gap_h))
        cl._cluster_steady = {215}
    else:
        cl = FeatureClusterer(ClusterParams(box_anchor_gap_side_ir=gap_h, box_anchor_gap_one_ir=False,
                                            box_anchor_gap_steady_ir=False))
    cl._ir = ir
    cl._cluster_boxes = {215: last.copy()}
    cl._cluster_boxes_t = cl._cluster_boxes_now = 361
    xy = np.stack([np.array(x), np.full(len(x), 253.0)], axis=1)
    v = np.stack([np.array(VX[:len(x)]), np.zeros(len(x))], axis=1)
    k = np.zeros(len(xy), np.int64)
    s = snap(xy, v, 36.2, 362, shape=(480, 640))
    anchor = cl._box_anchor(s, np.array([215]), k, xy)
    inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
    if cl._ir and cl.params.box_anchor_far_h_ir > 0 and anchor is not None:
        inb = cl._anchor_far_out(k, 1, inb, anchor, cl.params.box_anchor_far_h_ir, xy[:, 0])
    return sorted(xy[inb, 0].tolist())


def test_default():
    p = ClusterParams()
    assert (p.box_anchor_gap_side_ir, p.box_anchor_gap_one_ir, p.box_anchor_gap_steady_ir) == (3.0, True, True)
    assert _inb(p.box_anchor_gap_side_ir, steady=True) == X[:3]  # the defaults drop the cargo's three
    assert _inb(0.0) == X  # off: the minority rule keeps them


def test_far_group_beyond_a_gap_leaves():
    assert _inb(3.0) == X[:3]  # 298 -> 332 is 34 px = 4.25 times the box's 8 px width: the cargo's three leave


def test_gap_bar_wider_than_the_gap_changes_nothing():
    assert _inb(6.0) == X  # gaps 34 and 43 px < 6 x 8 px: one chain, kept as by the minority rule


def test_the_smaller_side_is_the_unit():
    tall = np.array([288.0, 236.0, 8.0, 23.0])  # a box grown tall for a frame (ir 86 at 37.1 s): 8 px still
    assert _inb(3.0, last=tall) == X[:3]


def test_a_chain_along_the_hull_is_kept():
    # the rest of a boat whose last box was a part of it: members every 15-20 px (< 3 x 8 px) from the box on
    x = [288.0, 291.0, 298.0, 318.0, 333.0, 350.0]
    assert _inb(3.0, x=x) == x


def test_visible_frames_unchanged():
    assert _inb(3.0, ir=False) == _inb(0.0, ir=False)


def _inb_one(one):
    cl = FeatureClusterer(ClusterParams(box_anchor_gap_side_ir=3.0, box_anchor_gap_one_ir=one,
                                        box_anchor_gap_steady_ir=False))
    cl._ir = True
    cl._cluster_boxes = {207: np.array([281.0, 243.0, 8.0, 16.0])}  # ir 86 at 43.4 s
    cl._cluster_boxes_t = cl._cluster_boxes_now = 434
    x = [285.0, 325.0, 333.0, 380.0, 384.0]  # one sailboat feature left, four of the cargo ship
    return _members_kept(cl, 207, x, [-0.8] * len(x), 250.0, 43.5, 435)


def _members_kept(cl, cid, x, vx, y, t, frame):
    """The box members of cluster ``cid`` (features at ``x``, row ``y``) that ``_anchor_far_out`` keeps."""
    xy = np.stack([np.array(x), np.full(len(x), y)], axis=1)
    v = np.stack([np.array(vx), np.zeros(len(x))], axis=1)
    k = np.zeros(len(xy), np.int64)
    s = snap(xy, v, t, frame, shape=(480, 640))
    anchor = cl._box_anchor(s, np.array([cid]), k, xy)
    inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
    inb = cl._anchor_far_out(k, 1, inb, anchor, cl.params.box_anchor_far_h_ir, xy[:, 0])
    return sorted(xy[inb, 0].tolist())


def test_one_near_member():
    assert ClusterParams().box_anchor_gap_one_ir is True  # session 32's rule P
    assert _inb_one(False) == [285.0, 325.0, 333.0, 380.0, 384.0]  # one member near: nobody leaves
    assert _inb_one(True) == [285.0]  # 285 -> 325 is 40 px = 5 widths: the cargo's four leave


def _inb_steady(steady):
    cl = FeatureClusterer(ClusterParams(box_anchor_gap_side_ir=3.0, box_anchor_gap_steady_ir=True))
    cl._ir = True
    cl._cluster_boxes = {215: LAST_BOX.copy()}
    cl._cluster_boxes_t = cl._cluster_boxes_now = 361
    cl._cluster_steady = {215} if steady else set()
    return _members_kept(cl, 215, X, VX, 253.0, 36.2, 362)


def test_steady_anchor_only():
    assert ClusterParams().box_anchor_gap_steady_ir is True  # session 32's rule P
    assert _inb_steady(True) == X[:3]  # the anchor box overlapped the box before it: the gap rule acts
    assert _inb_steady(False) == X  # a one-frame jump (ir 82 at 12.0 s): the minority rule's answer
