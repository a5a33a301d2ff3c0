"""Affinity graph, cluster merge and split, and identities (paper B, step 3) on scripted sequences."""

import numpy as np
import pytest

from seawatch.detect.features import FeatureSnapshot
from seawatch.track.feature_clusters import (
    AffinityClusters,
    ClusterParams,
    FeatureClusterer,
    assign_identities,
)
from seawatch.types import TrackState


def chain(idx):
    """Edges linking consecutive members of a group."""
    return [(a, b) for a, b in zip(idx[:-1], idx[1:])]


def step(g, n, edges, t, ids=None):
    slots = np.arange(n)
    ids = np.arange(100, 100 + n) if ids is None else np.asarray(ids)
    e = np.array(edges, np.int64).reshape(-1, 2)
    return g.step(slots, ids, e[:, 0], e[:, 1], t)


# ---------------------------------------------------------------- identities
def test_assign_new_merge_split_rules():
    # two components, no history: new identities in component order
    ids, nxt = assign_identities(np.full(4, -1), np.array([0, 0, 1, 1]), next_id=7)
    assert ids.tolist() == [7, 8] and nxt == 9
    # merge: features of 3 (older) and 5 in one component -> 3, even when 5 has more features
    ids, nxt = assign_identities(np.array([3, 5, 5, 5]), np.array([0, 0, 0, 0]), next_id=9)
    assert ids.tolist() == [3] and nxt == 9
    # split: identity 4 over two components; the one holding most of its features keeps it
    ids, nxt = assign_identities(np.array([4, 4, 4, 4, 4]), np.array([0, 0, 1, 1, 1]), next_id=9)
    assert ids.tolist() == [9, 4] and nxt == 10
    # features in no component carry nothing forward; -1 components are ignored
    ids, nxt = assign_identities(np.array([4, 2, -1]), np.array([-1, 0, 0]), next_id=9)
    assert ids.tolist() == [2]
    # no component at all
    ids, nxt = assign_identities(np.array([1, 2]), np.array([-1, -1]), next_id=5)
    assert ids.size == 0 and nxt == 5


def test_split_and_merge_in_the_same_frame():
    # old 1 spans comps 0 and 1 (more in 0); old 2 is in comp 1 -> comp 0 keeps 1, comp 1 takes 2
    prev = np.array([1, 1, 1, 1, 2, 2])
    comp = np.array([0, 0, 0, 1, 1, 1])
    ids, _ = assign_identities(prev, comp, next_id=10)
    assert ids.tolist() == [1, 2]


# ------------------------------------------------------------- affinity graph
def test_weights_grow_by_alpha_and_decay_by_one():
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0)
    step(g, 2, [(0, 1)], 0.0)
    assert g.weights(0, 1) == pytest.approx(3.0) and g.linked(0, 1)
    step(g, 2, [(0, 1)], 0.04)
    assert g.weights(0, 1) == pytest.approx(6.0)
    for k, expect in enumerate([5.0, 4.0, 3.0]):
        step(g, 2, [], 0.08 + 0.04 * k)
        assert g.weights(0, 1) == pytest.approx(expect)
    assert g.linked(0, 1)


def test_link_forms_at_wlink_and_breaks_at_zero():
    g = AffinityClusters(alpha=3.0, w_link=5.0, w_cap=0.0)
    labels, cids = step(g, 2, [(0, 1)], 0.0)
    assert not g.linked(0, 1) and cids.size == 0 and (labels == -1).all()
    labels, cids = step(g, 2, [(0, 1)], 0.04)  # 6 >= 5
    assert g.linked(0, 1) and cids.tolist() == [1] and labels.tolist() == [1, 1]
    # hysteresis: stays linked below Wlink until the weight reaches 0
    for k in range(5):  # 5, 4, 3, 2, 1
        labels, cids = step(g, 2, [], 0.08 + 0.04 * k)
        assert g.linked(0, 1) and labels.tolist() == [1, 1]
    labels, cids = step(g, 2, [], 0.4)  # 0
    assert not g.linked(0, 1) and (labels == -1).all()


def test_weight_cap_bounds_time_to_break():
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=6.0)
    for k in range(50):
        step(g, 2, [(0, 1)], 0.04 * k)
    assert g.weights(0, 1) == pytest.approx(6.0)
    n = 0
    while g.linked(0, 1):
        step(g, 2, [], 2.0 + 0.04 * n)
        n += 1
    assert n == 6


def test_single_feature_is_no_cluster_and_pairs_are():
    g = AffinityClusters()
    labels, cids = step(g, 3, [(0, 1)], 0.0)
    assert labels.tolist() == [1, 1, -1] and cids.tolist() == [1]


def test_scripted_merge_keeps_oldest_and_split_gives_new_identity():
    a, b = [0, 1, 2], [3, 4, 5, 6, 7]  # A is born first, B is bigger
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0, label_memory_s=10.0)
    t = 0.0
    labels, _ = step(g, 8, chain(a), t)
    assert labels[a].tolist() == [1, 1, 1] and (labels[b] == -1).all()
    for _ in range(3):
        t += 0.04
        labels, cids = step(g, 8, chain(a) + chain(b), t)
    assert (labels[a] == 1).all() and (labels[b] == 2).all() and cids.tolist() == [1, 2]

    # one frame with a bridge between the groups: they merge, keeping A's (the oldest) identity
    t += 0.04
    labels, cids = step(g, 8, chain(a) + chain(b) + [(2, 3)], t)
    assert (labels == 1).all() and cids.tolist() == [1]
    # the bridge weight (3) decays 2, 1: still one object
    for _ in range(2):
        t += 0.04
        labels, cids = step(g, 8, chain(a) + chain(b), t)
        assert (labels == 1).all()
    # at 0 the link breaks: split; B holds most of the features labelled 1 and keeps 1,
    # A gets a new identity
    t += 0.04
    labels, cids = step(g, 8, chain(a) + chain(b), t)
    assert (labels[b] == 1).all() and (labels[a] == 3).all() and cids.tolist() == [1, 3]
    # and the identities then hold
    for _ in range(5):
        t += 0.04
        labels, cids = step(g, 8, chain(a) + chain(b), t)
    assert (labels[b] == 1).all() and (labels[a] == 3).all()


def test_split_tie_goes_to_the_lower_component():
    a, b = [0, 1], [2, 3]
    g = AffinityClusters(alpha=1.0, w_link=1.0, w_cap=0.0)
    step(g, 4, chain(a + b), 0.0)
    labels, _ = step(g, 4, chain(a) + chain(b), 0.04)  # bridge 1 -> 0: breaks
    assert (labels[a] == 1).all() and (labels[b] == 2).all()


def test_new_feature_in_old_slot_starts_afresh():
    g = AffinityClusters(alpha=3.0, w_link=1.0)
    step(g, 3, [(0, 1), (1, 2)], 0.0)
    assert g.linked(1, 2)
    # slot 2 now holds another feature (id 999): its old weights are gone
    labels, _ = g.step(np.arange(3), np.array([100, 101, 999]), np.array([0]), np.array([1]), 0.04)
    assert g.weights(1, 2) == 0.0 and not g.linked(1, 2)
    assert labels.tolist() == [1, 1, -1]


def test_absent_feature_is_forgotten():
    g = AffinityClusters()
    step(g, 3, [(0, 1), (1, 2)], 0.0)
    labels, _ = g.step(np.array([0, 1]), np.array([100, 101]), np.array([0]), np.array([1]), 0.04)
    assert labels.tolist() == [1, 1]
    assert g.weights(1, 2) == 0.0


def test_label_memory_restores_identity_after_a_gap():
    g = AffinityClusters(alpha=1.0, w_link=1.0, label_memory_s=0.5)
    for k in range(3):
        step(g, 4, [(0, 1)], 0.04 * k)
    t = 0.12
    while g.linked(0, 1):  # 0-1 stop associating: their weight decays and the link breaks
        labels, _ = step(g, 4, [(2, 3)], t)
        t += 0.04
    labels, _ = step(g, 4, [(0, 1), (2, 3)], t)  # back within 0.5 s
    assert labels[:2].tolist() == [1, 1]
    g2 = AffinityClusters(alpha=1.0, w_link=1.0, label_memory_s=0.05)
    step(g2, 2, [(0, 1)], 0.0)
    step(g2, 2, [], 0.04)
    step(g2, 2, [], 0.5)
    labels, _ = step(g2, 2, [(0, 1)], 0.6)  # forgotten: a new identity
    assert labels.tolist() == [2, 2]


def test_inactive_features_are_in_no_cluster_but_keep_weights():
    g = AffinityClusters()
    e = np.array([[0, 1]])
    g.step(np.arange(2), np.array([5, 6]), e[:, 0], e[:, 1], 0.0)
    labels, cids = g.step(np.arange(2), np.array([5, 6]), e[:, 0], e[:, 1], 0.04,
                          active=np.array([True, False]))
    assert (labels == -1).all() and cids.size == 0 and g.weights(0, 1) == pytest.approx(6.0)


# ------------------------------------------------------------------ clusterer
def snapshot(xy, hist, size=4.0, t=0.0, fi=0, stable=None):
    n = len(xy)
    hist = np.asarray(hist, float)
    iv = hist[:, -1].copy()
    return FeatureSnapshot(
        t_s=t, frame_index=fi, ids=np.arange(n) + 10, slots=np.arange(n), xy=np.asarray(xy, float),
        size_px=np.full(n, size), confidence=np.full(n, 6), stable=np.ones(n, bool) if stable is None else stable,
        matched=np.ones(n, bool), velocity=hist[:, -1], history=hist, image_velocity=iv,
        homography=np.eye(3), dt_s=0.04, n_keypoints=n, n_matched=n, shape=(240, 320),
    )


def test_clusterer_boxes_velocities_and_confirmation():
    right = np.tile([[50.0, 0.0]], (4, 1))  # 2 px/frame
    down = np.tile([[0.0, 50.0]], (4, 1))
    xy = [[10, 10], [30, 20], [20, 40], [200, 100], [220, 110], [300, 10]]
    hist = [right, right, right, down, down, right]
    c = FeatureClusterer(ClusterParams(confirm_s=0.08, box_pad=0.5))
    for k in range(3):
        dets, tracks = c.update(snapshot(xy, hist, t=0.04 * k, fi=k))
        states = tracks.states.tolist()
        if k < 2:
            assert states == [int(TrackState.TENTATIVE)] * 2
    assert tracks.ids.tolist() == [1, 2] and states == [int(TrackState.CONFIRMED)] * 2
    # box = features' extent grown by half the keypoint radius (size 4 -> 1 px)
    assert tracks.boxes[0].tolist() == pytest.approx([9, 9, 22, 32])
    assert tracks.boxes[1].tolist() == pytest.approx([199, 99, 22, 12])
    assert np.allclose(tracks.velocities, [[50, 0], [0, 50]])
    assert tracks.ages_s.tolist() == pytest.approx([0.08, 0.08])
    assert len(dets) == 2 and np.allclose(dets.boxes, tracks.boxes)
    # the lone feature at (300, 10) is in no cluster
    assert c.last_labels.tolist() == [1, 1, 1, 2, 2, -1]


def test_clusterer_ignores_unstable_features():
    right = np.tile([[50.0, 0.0]], (4, 1))
    xy = [[10, 10], [30, 20], [20, 40]]
    c = FeatureClusterer()
    _, tracks = c.update(snapshot(xy, [right] * 3, stable=np.array([True, True, False])))
    assert c.last_labels.tolist() == [1, 1, -1]
    # default box: the features' extent grown by each keypoint's radius (size 4 -> 2 px)
    assert tracks.boxes[0].tolist() == pytest.approx([8, 8, 24, 14])


def test_speed_floor_follows_the_measured_noise():
    slow = np.tile([[6.0, 0.0]], (4, 1))  # 6 px/s: above the 2.5 px/s floor
    xy = [[10, 10], [30, 20], [20, 40]]
    quiet = snapshot(xy, [slow] * 3)
    quiet.noise_px_s = 0.5
    c = FeatureClusterer(ClusterParams(noise_factor=3.0, min_speed_px_s=2.5))
    c.update(quiet)
    assert c.min_speed_px_s == pytest.approx(2.5) and (c.last_labels == 1).all()
    noisy = snapshot(xy, [slow] * 3, t=0.04, fi=1)
    noisy.noise_px_s = 4.0  # the static features jitter at 4 px/s: 6 px/s is no longer motion
    c2 = FeatureClusterer(ClusterParams(noise_factor=3.0, min_speed_px_s=2.5))
    c2.update(noisy)
    assert c2.min_speed_px_s == pytest.approx(12.0) and (c2.last_labels == -1).all()


# ------------------------------------------- velocity gate and unmerge (not in the paper)
def _gate_run(max_dv, unmerge=False, bridge_frames=1):
    """A (features 0-2, 20 px/s) and B (3-5, 3 px/s) become clusters, then a bridge edge links
    them for ``bridge_frames`` frames; returns the cluster identities per frame after."""
    a, b = [0, 1, 2], [3, 4, 5]
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0, label_memory_s=10.0, unmerge=unmerge)
    vel = np.array([[20.0, 0.0]] * 3 + [[3.0, 0.0]] * 3)
    slots, ids = np.arange(6), np.arange(100, 106)
    t, out = 0.0, []

    def go(edges):
        e = np.array(edges, np.int64).reshape(-1, 2)
        return g.step(slots, ids, e[:, 0], e[:, 1], t, velocity=vel, max_dv_px_s=max_dv, min_age_s=0.1)

    for _ in range(5):
        labels, cids = go(chain(a) + chain(b))
        t += 0.04
    assert (labels[a] == 1).all() and (labels[b] == 2).all()
    for _ in range(bridge_frames):
        out.append(go(chain(a) + chain(b) + [(2, 3)]))
        t += 0.04
    for _ in range(8):
        out.append(go(chain(a) + chain(b)))
        t += 0.04
    return out


def test_velocity_gate_refuses_a_merge_of_clusters_moving_differently():
    # without the gate the bridge merges them (the oldest identity stays) ...
    labels, cids = _gate_run(0.0)[0]
    assert cids.tolist() == [1] and (labels == 1).all()
    # ... with it (17 px/s apart > 5) they stay apart with their identities throughout
    for labels, cids in _gate_run(5.0):
        assert labels.tolist() == [1, 1, 1, 2, 2, 2] and cids.tolist() == [1, 2]
    # a gate wider than their difference lets them merge as the paper does
    labels, cids = _gate_run(20.0)[0]
    assert cids.tolist() == [1]


def test_velocity_gate_lets_a_feature_moving_alike_join_and_ignores_unknown_velocity():
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0)
    slots, ids = np.arange(4), np.arange(10, 14)
    vel = np.array([[10.0, 0], [10.0, 0], [11.0, 1.0], [np.nan, np.nan]])
    e = np.array([(0, 1)])
    for k in range(4):
        g.step(slots, ids, e[:, 0], e[:, 1], 0.04 * k, velocity=vel, max_dv_px_s=5.0)
    # feature 2 moves like the cluster (1.4 px/s off): it joins; feature 3 has no velocity and is
    # linked straight to a member of the established cluster (so the gate judges it): not refused
    e = np.array([(0, 1), (1, 2), (0, 3)])
    labels, cids = g.step(slots, ids, e[:, 0], e[:, 1], 0.2, velocity=vel, max_dv_px_s=5.0)
    assert labels.tolist() == [1, 1, 1, 1]
    # the same feature moving 8 px/s faster is refused
    vel[2] = (18.0, 0.0)
    g2 = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0)
    e = np.array([(0, 1)])
    for k in range(4):
        g2.step(slots, ids, e[:, 0], e[:, 1], 0.04 * k, velocity=vel, max_dv_px_s=5.0)
    e = np.array([(0, 1), (1, 2)])
    labels, _ = g2.step(slots, ids, e[:, 0], e[:, 1], 0.2, velocity=vel, max_dv_px_s=5.0)
    assert labels.tolist() == [1, 1, -1, -1]


def test_unmerge_gives_each_part_back_its_identity():
    # paper: one part keeps the merged identity 1 (a tie: the lower component, A) and B gets a
    # new one (3); unmerge: after the split B is 2 again
    paper = _gate_run(0.0, unmerge=False)
    um = _gate_run(0.0, unmerge=True)
    assert paper[0][1].tolist() == [1] and um[0][1].tolist() == [1]  # the merge keeps the oldest
    labels, cids = paper[-1]
    assert labels.tolist() == [1, 1, 1, 3, 3, 3]
    labels, cids = um[-1]
    assert labels.tolist() == [1, 1, 1, 2, 2, 2] and cids.tolist() == [1, 2]


def test_side_by_side_reports_merge_only_when_large_near_and_moving_alike():
    from seawatch.track.feature_clusters import _merge_overlapping

    cids = np.array([4, 9])
    boxes = np.array([[100.0, 50, 90, 30], [240, 52, 50, 30]])  # 50 px apart, same rows
    count, vel = np.array([10, 6]), np.zeros((2, 2))
    same = np.array([[1.0, 0], [2.0, 0]])
    # off (gap_h 0): two reports
    assert _merge_overlapping(cids, boxes, count, vel, 0.5, same, 0.0, 5.0, 24)[0].tolist() == [4, 9]
    # near (50 <= 2 x 30), alike (1 px/s apart), tall enough: one report, the oldest identity, the union box
    c, b, n, _ = _merge_overlapping(cids, boxes, count, vel, 0.5, same, 2.0, 5.0, 24)
    assert c.tolist() == [4] and b[0].tolist() == [100, 50, 190, 32] and n.tolist() == [16]
    # moving differently, too far apart, or too small: apart
    diff = np.array([[1.0, 0], [9.0, 0]])
    assert len(_merge_overlapping(cids, boxes, count, vel, 0.5, diff, 2.0, 5.0, 24)[0]) == 2
    assert len(_merge_overlapping(cids, boxes, count, vel, 0.5, same, 1.5, 5.0, 24)[0]) == 2
    assert len(_merge_overlapping(cids, boxes, count, vel, 0.5, same, 2.0, 5.0, 31)[0]) == 2
