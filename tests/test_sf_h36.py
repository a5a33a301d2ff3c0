"""Session 30 (h36): a box member far outside its cluster's box of the frame before leaves the box on
infrared frames (``ClusterParams.box_anchor_far_h_ir``).  The members are sim ``ir`` 19's at 2.8 s: the
graph cluster holds the tug (x 83-139) and the ferry (x 173-243); one ferry feature (x 215) moved like
the tug for a frame and drew the box over both boats, after which the anchor took the ferry."""
import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _box_members

TUG_X = [83, 103, 103, 103, 107, 109, 114, 116, 121, 128, 129, 134, 139]
TUG_VX = [3.3, 1.5, 3.0, 3.6, 3.0, 2.7, 3.4, 3.4, 3.4, 3.3, 3.1, 3.0, 3.0]
FERRY_X = [173, 174, 177, 189, 196, 201, 215, 216, 223, 230, 243]
FERRY_VX = [6.8, 6.8, 5.6, 6.6, 6.6, 5.0, 4.1, 6.0, 6.4, 6.0, 6.4]
LAST_BOX = np.array([80.0, 265.0, 59.0, 32.0])  # the tug's box at 2.7 s


def _members():
    x = np.array(TUG_X + FERRY_X, float)
    y = np.r_[np.full(len(TUG_X), 280.0), np.full(len(FERRY_X), 258.0)]
    v = np.stack([np.array(TUG_VX + FERRY_VX), np.zeros(len(x))], axis=1)
    return np.stack([x, y], axis=1), v


def _clusterer(far_h, ir=True, minority=False):
    cl = FeatureClusterer(ClusterParams(box_anchor_far_h_ir=far_h, box_anchor_far_minority_ir=minority))
    cl._ir = ir
    cl._cluster_boxes = {3: LAST_BOX.copy()}
    cl._cluster_boxes_t = cl._cluster_boxes_now = 27
    return cl


def _inb(cl, xy, v):
    k = np.zeros(len(xy), np.int64)
    s = snap(xy, v, 2.8, 28, shape=(480, 640))
    anchor = cl._box_anchor(s, np.array([3]), k, xy)
    inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
    if cl._ir and cl.params.box_anchor_far_h_ir > 0 and anchor is not None:
        inb = cl._anchor_far_out(k, 1, inb, anchor, cl.params.box_anchor_far_h_ir)
    return inb


def test_on_by_default_since_session_30():
    p = ClusterParams()  # rule L, session 30
    assert p.box_anchor_far_h_ir == 1.0 and p.box_anchor_far_minority_ir is True


def test_the_far_member_leaves_the_box_on_infrared():
    xy, v = _members()
    off = _inb(_clusterer(0.0), xy, v)
    assert sorted(xy[off, 0].tolist()) == sorted(TUG_X[:1] + TUG_X[2:] + [215])  # the ferry feature is in
    on = _inb(_clusterer(1.0), xy, v)
    assert sorted(xy[on, 0].tolist()) == sorted(TUG_X[:1] + TUG_X[2:])  # the tug's members alone
    # visible frames: unchanged
    vis = _inb(_clusterer(1.0, ir=False), xy, v)
    np.testing.assert_array_equal(vis, off)
    # a member 76 px (2.4 box heights) outside: a bar above that keeps it
    np.testing.assert_array_equal(_inb(_clusterer(3.0), xy, v), off)


def test_needs_two_members_inside_the_last_box():
    xy, v = _members()
    cl = _clusterer(1.0)
    cl._cluster_boxes = {3: np.array([80.0, 265.0, 4.0, 32.0])}  # only the member at x 83 inside
    k = np.zeros(len(xy), np.int64)
    s = snap(xy, v, 2.8, 28, shape=(480, 640))
    anchor = cl._box_anchor(s, np.array([3]), k, xy)
    inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
    np.testing.assert_array_equal(cl._anchor_far_out(k, 1, inb, anchor, 1.0), inb)


def _run(far_h, ir):
    """A two-group cluster through ``update``: returns how often ``_anchor_far_out`` ran."""
    cl = FeatureClusterer(ClusterParams(box_anchor_far_h_ir=far_h, box_anchor_far_minority_ir=False, confirm_s=0.0,
                                        relink_s=0.0))
    calls = []
    orig = cl._anchor_far_out

    def spy(*a):
        calls.append(1)
        return orig(*a)

    cl._anchor_far_out = spy
    xy0 = np.array([[100.0, 60.0], [104.0, 62.0], [108.0, 60.0], [112.0, 61.0]])
    for fi in range(6):
        xy = xy0 + [0.3 * fi, 0.0]
        cl.update(snap(xy, [[3.0, 0.0]] * 4, 0.1 * fi, fi, shape=(160, 240)), ir=ir)
    return len(calls)


def test_acts_on_infrared_frames_only():
    assert _run(1.0, ir=True) > 0
    assert _run(1.0, ir=False) == 0
    assert _run(0.0, ir=True) == 0


def test_minority_only_keeps_a_box_that_was_a_part_of_the_boat():
    # the last box a sliver over three tug members (4 px tall): most members lie more than a height outside
    xy, v = _members()
    k = np.zeros(len(xy), np.int64)

    def run(minority):
        cl = FeatureClusterer(ClusterParams(box_anchor_far_h_ir=1.0, box_anchor_far_minority_ir=minority))
        cl._ir = True
        cl._cluster_boxes = {3: np.array([100.0, 278.0, 5.0, 4.0])}
        cl._cluster_boxes_t = cl._cluster_boxes_now = 27
        s = snap(xy, v, 2.8, 28, shape=(480, 640))
        anchor = cl._box_anchor(s, np.array([3]), k, xy)
        inb = _box_members(k, v, 1, cl.params.box_dv_px_s, anchor)
        return inb, cl._anchor_far_out(k, 1, inb, anchor, 1.0)

    assert ClusterParams().box_anchor_far_minority_ir is True  # the default since session 30
    inb, out = run(False)
    assert 3 <= out.sum() < inb.sum() // 2  # the box would shrink to the members at and beside the sliver
    inb, out = run(True)
    np.testing.assert_array_equal(out, inb)  # the far members are the majority: they stay
    # the ir 19 case (one far member against twelve inside) is unchanged by the minority rule
    np.testing.assert_array_equal(_inb(_clusterer(1.0, minority=True), *_members()),
                                  _inb(_clusterer(1.0, minority=False), *_members()))
