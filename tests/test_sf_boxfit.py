"""Session 19: the box fitted to the boat (issue #8): the box size filter."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _keep_edge, grow_boxes

# a boat of four features moving 20 px/s; with the default pad (the keypoint's radius, 2 px)
# its box is x 98..128, y 58..66
BOAT = [[100, 60], [110, 62], [120, 61], [126, 64]]
VEL = [20.0, 0.0]


def run(params, extra_at=None, extra=(), n=12, scale=1.0):
    """Boxes of the one reported cluster over ``n`` frames at 10 frames/s; from frame ``extra_at``
    on, the features ``extra`` join it (moving alike). ``scale``: the camera zooms by this factor
    per frame about (110, 62) (features and homography alike)."""
    cl = FeatureClusterer(params)
    out = []
    s = 1.0
    for fi in range(n):
        xy = [list(p) for p in BOAT]
        ids = list(range(10, 10 + len(BOAT)))
        if extra_at is not None and fi >= extra_at:
            xy += [list(p) for p in extra]
            ids += list(range(50, 50 + len(extra)))
        h = np.eye(3)
        if fi > 0 and scale != 1.0:
            s *= scale
            h = np.array([[scale, 0, 110 * (1 - scale)], [0, scale, 62 * (1 - scale)], [0, 0, 1.0]])
        c = np.array([110.0, 62.0])
        xy = (np.asarray(xy, float) - c) * s + c
        _, tr = cl.update(snap(xy, [VEL] * len(xy), 0.1 * fi, fi, ids=ids, h=h, shape=(400, 400)))
        assert len(tr) == 1
        out.append(tr.boxes[0].copy())
    return np.array(out)


P = dict(confirm_s=0.0, relink_s=0.0)


def test_size_filter_is_off_by_default_and_off_changes_nothing():
    assert ClusterParams().size_filter_s == 0.0
    extra = [[60, 63]]  # a feature 40 px behind the boat (its wake) joins in frame 8
    off = run(ClusterParams(**P), 8, extra)
    assert off[-1].tolist() == pytest.approx([58, 58, 70, 8])  # the box takes it in
    base = run(ClusterParams(**P))
    assert off[:8].tolist() == base[:8].tolist()


def test_a_box_widened_in_a_few_frames_goes_back_to_its_width_keeping_the_edge_that_stayed():
    extra = [[60, 63]]
    on = run(ClusterParams(size_filter_s=1.0, size_filter_k=1.5, **P), 8, extra)
    # frames 0-7 are the boat alone, unchanged
    assert on[:8].tolist() == run(ClusterParams(**P))[:8].tolist()
    # from frame 8 the wide box (70 px) is cut to the median width (30 px), keeping the right
    # (leading) edge, which did not move; the height is not touched
    for b in on[8:]:
        assert b.tolist() == pytest.approx([98, 58, 30, 8])


def test_a_box_raised_in_a_few_frames_keeps_its_bottom():
    extra = [[112, 30]]  # a feature of the coast 30 px above the deck joins in frame 8
    off = run(ClusterParams(**P), 8, extra)
    assert off[-1][1] == pytest.approx(28)
    on = run(ClusterParams(size_filter_s=1.0, **P), 8, extra)
    # the bottom (66) stays, the height goes back to 8 (the median of the last second)
    for b in on[8:]:
        assert b[1] + b[3] == pytest.approx(off[-1][1] + off[-1][3])
        assert b[3] == pytest.approx(8.0)
        assert b[2] == pytest.approx(30.0)


def test_a_lasting_change_of_size_is_followed():
    # the extra feature stays: after about half the filter's time the median is the new width
    extra = [[60, 63]]
    on = run(ClusterParams(size_filter_s=1.0, **P), 4, extra, n=20)
    assert on[5][2] == pytest.approx(30)  # just after the change: cut
    assert on[-1].tolist() == pytest.approx([58, 58, 70, 8])  # a second later: followed


def test_zoom_does_not_count_as_a_change_of_size():
    # the camera zooms in by 10 % a frame (x2.4 over the run): the box grows with it and the
    # filter (which compares sizes at one scale) leaves it alone
    on = run(ClusterParams(size_filter_s=1.0, size_filter_k=1.2, **P), n=10, scale=1.1)
    off = run(ClusterParams(**P), n=10, scale=1.1)
    np.testing.assert_allclose(on, off)
    assert off[-1][2] > 2.0 * off[0][2]
    # without following the zoom, the last box would be cut: it is wider than 1.2 times the
    # median width over the last second in pixels
    assert off[-1][2] > 1.2 * np.median(off[:-1, 2])


def test_keep_edge():
    assert _keep_edge(0.0, 50.0, 10.0, None) == (20.0, 30.0)
    assert _keep_edge(0.0, 50.0, 10.0, (30.0, 50.5)) == (40.0, 50.0)  # the right end stayed
    assert _keep_edge(0.0, 50.0, 10.0, (0.5, 20.0)) == (0.0, 10.0)  # the left end stayed


def small_boat_with_slanted_wake(seed=0):
    """Grey sea with a small dark hull (x 150-165, y 60-67) and a thin line of foam (2 px thick)
    running from its stern 50 px to the left and 10 px down (a Kelvin arm seen at a slant)."""
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, (160, 260))
    img[60:68, 150:166] = 30.0  # hull
    for k in range(50):  # the arm: from (149, 66) to (100, 76)
        x = 149 - k
        y = 66 + int(round(k * 10 / 50))
        img[y:y + 2, x] = 200.0
    return np.clip(img, 0, 255).astype(np.uint8)


def test_wake_cut_by_thickness_cuts_a_slanted_arm_that_the_height_rule_keeps():
    img = small_boat_with_slanted_wake()
    core = np.array([[120.0, 62.0, 44.0, 10.0]])  # features on the hull and on the arm near it
    kw = dict(grow=1.0, waterline_frac=0.0, wide_grow_px=120.0, wake_frac=0.3, trail=np.array([-1]))
    height = grow_boxes(img, core, core, **kw)
    assert height[0][0] <= 101  # the arm's columns reach the object's bottom: kept
    thick = grow_boxes(img, core, core, wake_thick=True, **kw)
    assert thick[0][0] == pytest.approx(150) and thick[0][0] + thick[0][2] == pytest.approx(166)
    # on the leading side nothing is cut
    lead = grow_boxes(img, core, core, wake_thick=True, **dict(kw, trail=np.array([1])))
    assert lead[0].tolist() == pytest.approx(height[0].tolist())


def test_wake_cut_by_thickness_keeps_a_hull_beside_a_wheelhouse():
    # a tug: hull 40 x 6 with a wheelhouse 10 px wide and 8 px tall at its stern; moving left
    # (trail +1 would cut the right end): the hull's columns are 6 px thick, the house's 14,
    # above 0.3 x 14
    rng = np.random.default_rng(3)
    img = 120.0 + rng.normal(0.0, 2.0, (160, 260))
    img[66:72, 100:140] = 30.0
    img[58:66, 128:138] = 50.0
    img = np.clip(img, 0, 255).astype(np.uint8)
    core = np.array([[104.0, 60.0, 32.0, 10.0]])
    for trail in (-1, 1):
        out = grow_boxes(img, core, core, grow=1.5, wake_frac=0.3, trail=np.array([trail]), wake_thick=True)
        assert out[0].tolist() == pytest.approx([100, 58, 40, 14])


def run_wake(params, n=20, pan=0.0):
    """A slow boat (four features moving 5 px/s to the right) and three features of its wake that
    stay where they are (their measured velocity says 2 px/s: too noisy to tell them apart), at
    10 frames/s; the camera pans ``pan`` px a frame (features and homography alike). Boxes of the
    one reported cluster."""
    cl = FeatureClusterer(params)
    out = []
    for fi in range(n):
        dx = 0.5 * fi
        boat = [[100 + dx, 60], [106 + dx, 62], [112 + dx, 61], [116 + dx, 63]]
        wake = [[80, 64], [88, 63], [94, 64]]
        xy = np.array(boat + wake, float) - [pan * fi, 0.0]
        vel = [[5.0, 0.0]] * 4 + [[2.0, 0.0]] * 3
        h = np.array([[1, 0, -pan], [0, 1, 0], [0, 0, 1.0]]) if fi else np.eye(3)
        _, tr = cl.update(snap(xy, vel, 0.1 * fi, fi, ids=list(range(10, 17)), h=h, shape=(400, 400)))
        assert len(tr) == 1
        out.append(tr.boxes[0] + [pan * fi, 0, 0, 0])  # in the scene's pixels
    return np.array(out)


def test_members_that_stay_behind_leave_the_box():
    base = dict(confirm_s=0.0, relink_s=0.0, box_dv_px_s=0.0)
    off = run_wake(ClusterParams(box_disp_s=0.0, **base))
    assert off[-1][0] == pytest.approx(78)  # the wake's features are in the box
    assert ClusterParams().box_disp_s == 1.0 and ClusterParams(box_disp_s=0.0).box_disp_s == 0.0
    on = run_wake(ClusterParams(**base))  # the default: 1 s
    # the first half second (no displacement known yet) is as before
    np.testing.assert_allclose(on[:5], off[:5])
    # after a second the boat's features have moved 5 px and the wake's 0: the box is the boat's
    assert on[-1].tolist() == pytest.approx([98 + 9.5, 58, 20, 7])
    # the same through a pan of 3 px a frame (positions followed through the homographies)
    np.testing.assert_allclose(run_wake(ClusterParams(**base), pan=3.0)[-1], on[-1], atol=1e-6)
    # a boat slower than the floor (2 px over the second) is left alone
    slow = run_wake(ClusterParams(box_disp_min_px=6.0, **base))
    np.testing.assert_allclose(slow, off)


def test_members_that_stay_behind_leave_the_box_when_they_are_the_majority_with_a_quantile():
    # six features of foam behind three of the boat: the members' median displacement is the
    # foam's (0), so the default leaves the box as it is; the median of the farther half is the boat's
    cl_kw = dict(confirm_s=0.0, relink_s=0.0, box_dv_px_s=0.0)

    def boxes(params):
        cl = FeatureClusterer(params)
        out = []
        for fi in range(20):
            dx = 0.5 * fi
            boat = [[100 + dx, 60], [106 + dx, 62], [112 + dx, 61]]
            foam = [[70, 64], [76, 63], [82, 64], [88, 63], [94, 64], [97, 62]]
            vel = [[5.0, 0.0]] * 3 + [[2.0, 0.0]] * 6
            _, tr = cl.update(snap(np.array(boat + foam, float), vel, 0.1 * fi, fi, ids=list(range(10, 19)),
                                   shape=(400, 400)))
            assert len(tr) == 1
            out.append(tr.boxes[0].copy())
        return np.array(out)

    off = boxes(ClusterParams(box_disp_s=0.0, **cl_kw))
    assert off[-1][0] == pytest.approx(68)
    np.testing.assert_allclose(boxes(ClusterParams(**cl_kw)), off)  # box_disp_q 0: the median is the foam's
    q = boxes(ClusterParams(box_disp_q=0.5, **cl_kw))
    assert q[-1].tolist() == pytest.approx([98 + 9.5, 58, 16, 6])
