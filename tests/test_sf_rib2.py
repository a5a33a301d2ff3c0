"""Session 23 (helper H2): ``ClusterParams.box_disp_two_wake_px``: with ``box_disp_two``, the member
of a two-member box that stayed behind leaves the box only when it lies where a wake's foam lies
(behind the moving member, against its displacement, and not above it by more than the setting);
a feature of another boat above, or one ahead, stays in the box."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer


def run_pair(params, other_xy=(80.0, 64.0), other_dx=0.0, n=20, pan=0.0):
    """One feature on a boat moving 5 px/s to the right (0.5 px a frame at 10 frames/s) from
    (100, 60), and a second feature starting at ``other_xy`` that moves ``other_dx`` px a frame
    (both measured at 5 px/s, so the velocity rule cannot tell them apart); the camera pans ``pan``
    px a frame.  Boxes of the one reported cluster, in the scene's pixels."""
    cl = FeatureClusterer(params)
    out = []
    for fi in range(n):
        xy = np.array([[100 + 0.5 * fi, 60.0], [other_xy[0] + other_dx * fi, other_xy[1]]]) - [pan * fi, 0.0]
        h = np.array([[1, 0, -pan], [0, 1, 0], [0, 0, 1.0]]) if fi else np.eye(3)
        _, tr = cl.update(snap(xy, [[5.0, 0.0]] * 2, 0.1 * fi, fi, ids=[10, 11], h=h, shape=(400, 400)))
        assert len(tr) == 1
        out.append(tr.boxes[0] + [pan * fi, 0, 0, 0])
    return np.array(out)


# session 22's box_disp_two with session 23's refinements off (they are on by default since session 23);
# each test names the ones it turns on
BASE = dict(confirm_s=0.0, relink_s=0.0, box_dv_px_s=0.0, box_disp_two=True, box_disp_two_wake_px=0.0,
            box_disp_two_anchor=False, box_disp_two_far_h=0.0)


def P(**kw):
    d = dict(BASE)
    d.update(kw)
    return ClusterParams(**d)
BOAT_ONLY = [100 + 9.5 - 2, 58, 4, 4]  # the moving feature's box at the last frame (radius 2)


def test_off_by_default_and_off_changes_nothing():
    d = ClusterParams()  # on by default since session 23
    assert (d.box_disp_two, d.box_disp_two_wake_px, d.box_disp_two_anchor, d.box_disp_two_far_h) == (True, 2.0, True, 1.0)
    # off: box_disp_two as in session 22 (the static member leaves wherever it lies)
    above = run_pair(P(), other_xy=(80.0, 20.0))
    assert above[-1].tolist() == pytest.approx(BOAT_ONLY)


@pytest.mark.parametrize("pan", [0.0, 3.0])
def test_foam_behind_and_below_leaves_the_box(pan):
    on = run_pair(P(box_disp_two_wake_px=2.0), other_xy=(80.0, 64.0), pan=pan)
    off = run_pair(P(), other_xy=(80.0, 64.0), pan=pan)
    np.testing.assert_allclose(on, off, atol=1e-6)  # a wake's foam: the rule acts as before
    assert on[-1].tolist() == pytest.approx(BOAT_ONLY)


@pytest.mark.parametrize("pan", [0.0, 3.0])
def test_a_still_feature_well_above_stays_in_the_box(pan):
    # 40 px above the boat's feature (another boat, a long hull's far end): not a wake, it stays
    on = run_pair(P(box_disp_two_wake_px=2.0), other_xy=(80.0, 20.0), pan=pan)
    assert on[-1][0] == pytest.approx(78)
    assert on[-1][1] == pytest.approx(18)
    # within the tolerance (1.5 px above) it still leaves
    near = run_pair(P(box_disp_two_wake_px=2.0), other_xy=(80.0, 58.5), pan=pan)
    assert near[-1].tolist() == pytest.approx(BOAT_ONLY)


def test_a_still_feature_ahead_stays_in_the_box():
    # ahead of the moving feature (in its direction of motion): not its wake
    on = run_pair(P(box_disp_two_wake_px=2.0), other_xy=(130.0, 64.0))
    assert on[-1][0] == pytest.approx(100 + 9.5 - 2)
    assert on[-1][0] + on[-1][2] == pytest.approx(132)
    off = run_pair(P(), other_xy=(130.0, 64.0))
    assert off[-1].tolist() == pytest.approx(BOAT_ONLY)  # session 22's rule took it out


def test_the_tolerance_follows_the_zoom():
    # 3 px above: out of a 2 px tolerance at zoom 1, inside it at zoom 2
    params = P(box_disp_two_wake_px=2.0)
    for zoom, left_out in ((1.0, False), (2.0, True)):
        cl = FeatureClusterer(params)
        for fi in range(20):
            xy = np.array([[100 + 0.5 * fi, 60.0], [80.0, 57.0]])
            _, tr = cl.update(snap(xy, [[5.0, 0.0]] * 2, 0.1 * fi, fi, ids=[10, 11], shape=(400, 400)), zoom=zoom)
        if left_out:
            assert tr.boxes[0].tolist() == pytest.approx(BOAT_ONLY)
        else:
            assert tr.boxes[0][0] == pytest.approx(78)


def run_anchor(last_box):
    """The pair of ``run_pair`` with a still feature 40 px above the moving one (not a wake), with
    ``box_disp_two_anchor`` and the box members' anchor (``box_dv_px_s`` on); before the last frame
    the cluster's box of the frame before is set to ``last_box`` (None: left as it was)."""
    params = P(box_disp_two_wake_px=2.0, box_disp_two_anchor=True, box_dv_px_s=1.5)
    cl = FeatureClusterer(params)
    for fi in range(20):
        if fi == 19 and last_box is not None:
            cl._cluster_boxes = {c: np.asarray(last_box, float) for c in cl._cluster_boxes}
        xy = np.array([[100 + 0.5 * fi, 60.0], [80.0, 20.0]])
        _, tr = cl.update(snap(xy, [[5.0, 0.0]] * 2, 0.1 * fi, fi, ids=[10, 11], shape=(400, 400)))
        assert len(tr) == 1
    return tr.boxes[0]


def test_anchor_keeps_the_member_the_box_was_on():
    # the box was around both: both stay (as with box_disp_two_wake_px alone)
    both = run_anchor(None)
    assert both[0] == pytest.approx(78) and both[1] == pytest.approx(18)
    assert both[1] + both[3] == pytest.approx(62)
    # the box was on the still feature (another boat): the one that moved leaves
    still = run_anchor([70.0, 10.0, 20.0, 20.0])
    assert still.tolist() == pytest.approx([78, 18, 4, 4])
    # the box was on the moving feature: the still one leaves (session 22's rule)
    moving = run_anchor([100.0, 50.0, 20.0, 20.0])
    assert moving.tolist() == pytest.approx(BOAT_ONLY)


def test_far_h_leaves_a_member_just_outside_the_box():
    params = P(box_disp_two_wake_px=2.0, box_disp_two_anchor=True, box_disp_two_far_h=1.0, box_dv_px_s=1.5)

    def last(box):
        cl = FeatureClusterer(params)
        for fi in range(20):
            if fi == 19:
                cl._cluster_boxes = {c: np.asarray(box, float) for c in cl._cluster_boxes}
            xy = np.array([[100 + 0.5 * fi, 60.0], [80.0, 20.0]])
            _, tr = cl.update(snap(xy, [[5.0, 0.0]] * 2, 0.1 * fi, fi, ids=[10, 11], shape=(400, 400)))
        return tr.boxes[0]

    # the moving feature (109.5, 60) lies 40 px below a 20 px box on the still one: far, it leaves
    assert last([70.0, 10.0, 20.0, 20.0]).tolist() == pytest.approx([78, 18, 4, 4])
    # a 50 px tall box: 10 px outside is less than its height: both stay
    both = last([70.0, 0.0, 20.0, 50.0])
    assert both[0] == pytest.approx(78) and both[1] + both[3] == pytest.approx(62)
