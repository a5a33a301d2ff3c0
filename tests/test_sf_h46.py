"""Session 32 (issue #8, helper h46): ``box_anchor_far_gap_h_ir``, the far members of a cluster leave its box even
where they are not a minority, when the nearest of them lies more than this many anchor heights outside the anchor
box and that box was grown in the frame before.  The members are sim ``ir`` 68's at 38.0 s (defaults): the
sailboat's cluster 183 holds its features at x 285, 290, 295 beside/inside its grown 11 x 16 px box of the frame
before (x 286) and three of the cargo ship's at x 332, 339, 389, all moving alike (~-1 px/s); 3 against 3 is no
minority and the box widened to 108 x 20 px over both boats.  Off by default, infrared frames only."""
import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _box_members

X = [285.0, 290.0, 295.0, 332.0, 339.0, 389.0]
VX = [-0.8, -1.0, -0.9, -1.2, -0.9, -1.8]
LAST_BOX = np.array([286.0, 243.0, 11.0, 16.0])  # cluster 183's box at 37.9 s


def _inb(gap_h=0.0, ir=True, grown=True, x=X, vx=VX):
    cl = FeatureClusterer(ClusterParams(box_anchor_far_gap_h_ir=gap_h))
    cl._ir = ir
    cl._cluster_boxes = {183: LAST_BOX.copy()}
    cl._cluster_boxes_t = cl._cluster_boxes_now = 379
    if grown:  # grow_boxes found the sailboat there in the frame before
        cl._grown_last = {183: LAST_BOX.copy()}
        cl._grown_last_t = 379
    cids = np.array([183])
    xy = np.stack([np.array(x), np.full(len(x), 251.0)], axis=1)
    v = np.stack([np.array(vx), np.zeros(len(x))], axis=1)
    k = np.zeros(len(xy), np.int64)
    s = snap(xy, v, 38.0, 380, shape=(480, 640))
    anchor = cl._box_anchor(s, cids, k, xy)
    inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
    if cl._ir and cl.params.box_anchor_far_h_ir > 0 and anchor is not None:
        inb = cl._anchor_far_out(k, 1, inb, anchor, cl.params.box_anchor_far_h_ir, xy[:, 0], cids)
    return sorted(xy[inb, 0].tolist())


def test_off_by_default():
    assert ClusterParams().box_anchor_far_gap_h_ir == 0.0
    assert _inb() == X  # 3 far against 3 near: no minority, the box spans both boats


def test_group_apart_leaves():
    assert _inb(2.0) == X[:3]  # the nearest far member (x 332) lies 2.2 heights outside: the cargo's three leave


def test_gap_too_small_changes_nothing():
    assert _inb(2.5) == X  # x 332 is only 2.2 heights out


def test_only_where_the_anchor_was_grown():
    assert _inb(2.0, grown=False) == X  # a members' box may itself lie on the wrong boat (sim ir 42 at 38.3 s)


def test_visible_frames_unchanged():
    assert _inb(2.0, ir=False) == _inb(0.0, ir=False)


def test_minority_still_leaves_without_the_gap():
    # two far members against three near: the minority rule alone drops them, with the step off or on
    assert _inb(0.0, x=X[:5], vx=VX[:5]) == X[:3]
    assert _inb(2.0, x=X[:5], vx=VX[:5]) == X[:3]
