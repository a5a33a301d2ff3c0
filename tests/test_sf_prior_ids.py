"""Session 21, helper H3 (issue #8: the PTZ motion prior on ``ir``): two switchable identity steps,
off by default.

* ``merge_id_dv_px_s`` (with ``merge_id_ratio``): a report joined from overlapping clusters that
  move differently keeps the identity of the cluster holding most features (when it holds at least
  ``merge_id_ratio`` times the oldest's), not the oldest; and the identity of a cluster joined that
  way is not handed over to the report it is joined into.
* ``merge_min_share``: in the graph, a carried identity claims a cluster only with at least this
  share of the most-carried identity's features there (one feature remembering a dead cluster's
  older identity does not rename the cluster it joins)."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import (
    AffinityClusters,
    ClusterParams,
    FeatureClusterer,
    _merge_overlapping,
    assign_identities,
)


def test_defaults_and_the_papers_rule_when_off():
    p = ClusterParams()  # on by default since session 21 (with the PTZ motion prior)
    assert p.merge_id_dv_px_s == 3.0 and p.merge_min_share == 0.34
    assert FeatureClusterer(p).graph.min_share == 0.34
    off = ClusterParams(merge_id_dv_px_s=0.0, merge_min_share=0.0)
    assert FeatureClusterer(off).graph.min_share == 0.0


# a small, old cluster (identity 3, 2 features, still) inside a large, younger one's box (identity 8,
# 10 features, moving at 6 px/s)
_CIDS = np.array([8, 3])
_BOXES = np.array([[100.0, 50, 80, 16], [170, 52, 8, 9]])
_COUNT = np.array([10, 2])
_RV = np.array([[6.0, 0.0], [0.0, 0.0]])


def test_report_merge_keeps_the_oldest_when_off():
    g = []
    c, b, n, _ = _merge_overlapping(_CIDS, _BOXES, _COUNT, np.zeros((2, 2)), 0.25, _RV, groups=g)
    assert c.tolist() == [3] and n.tolist() == [12] and g == [[3, 8]]
    assert b[0].tolist() == [100, 50, 80, 16]


def test_report_merge_of_clusters_moving_apart_keeps_the_large_ones_identity():
    g = []
    c, b, n, _ = _merge_overlapping(_CIDS, _BOXES, _COUNT, np.zeros((2, 2)), 0.25, _RV, groups=g, id_dv=3.0)
    assert c.tolist() == [8] and n.tolist() == [12] and g == [[8, 3]]  # the kept identity first
    assert b[0].tolist() == [100, 50, 80, 16]  # the union box as before


def test_report_merge_id_moving_alike_ratio_and_unknown_velocity_keep_the_oldest():
    alike = np.array([[6.0, 0.0], [4.0, 0.0]])  # 2 px/s apart: one boat in two clusters
    assert _merge_overlapping(_CIDS, _BOXES, _COUNT, np.zeros((2, 2)), 0.25, alike, id_dv=3.0)[0].tolist() == [3]
    unknown = np.array([[6.0, 0.0], [np.nan, np.nan]])
    assert _merge_overlapping(_CIDS, _BOXES, _COUNT, np.zeros((2, 2)), 0.25, unknown, id_dv=3.0)[0].tolist() == [3]
    # the large cluster holds fewer than id_ratio times the oldest's features: the oldest stays
    like = np.array([10, 6])
    assert _merge_overlapping(_CIDS, _BOXES, like, np.zeros((2, 2)), 0.25, _RV, id_dv=3.0)[0].tolist() == [3]
    assert _merge_overlapping(_CIDS, _BOXES, like, np.zeros((2, 2)), 0.25, _RV, id_dv=3.0,
                              id_ratio=1.5)[0].tolist() == [8]


def test_report_merge_id_picks_the_oldest_moving_with_the_largest():
    cids = np.array([8, 3, 5])
    boxes = np.array([[100.0, 50, 80, 16], [170, 52, 8, 9], [165, 50, 10, 10]])  # all overlapping
    count = np.array([10, 2, 3])
    rv = np.array([[6.0, 0.0], [0.0, 0.0], [5.0, 0.5]])  # 5 moves with 8, 3 does not
    g = []
    c, _, n, _ = _merge_overlapping(cids, boxes, count, np.zeros((3, 2)), 0.25, rv, groups=g, id_dv=3.0,
                                    id_ratio=3.0)
    assert c.tolist() == [5] and n.tolist() == [15] and g[0][0] == 5 and sorted(g[0]) == [3, 5, 8]


def _clusterer_run(**kw):
    """A still 2-feature cluster (born first) lies inside the box of a 10-feature cluster moving at
    +8 px/s (born a frame later, so younger); their reports overlap.  Returns the reported
    identities of each frame."""
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, coast_s=0.0, **kw))
    small_xy = [[170.0, 60.0], [172.0, 62.0]]
    small_v = [[-4.0, 0.0]] * 2  # opposite directions: no edge between the two objects
    out = []
    for k in range(6):
        t = 0.1 * k
        xy, vel, ids = list(small_xy), list(small_v), [1, 2]
        if k >= 1:
            xy += [[120.0 + 6 * j + 0.8 * k, 55.0 + 2 * (j % 5)] for j in range(10)]
            vel += [[8.0, 0.0]] * 10
            ids += list(range(20, 30))
        _, tr = c.update(snap(xy, vel, t, k, ids=ids, shape=(160, 240)))
        out.append(sorted(int(i) for i in tr.ids))
    return out


def test_clusterer_off_gives_the_passing_boat_the_small_clusters_older_identity():
    out = _clusterer_run(merge_id_dv_px_s=0.0)
    assert out[0] == [1]  # the small cluster alone
    assert all(o == [1] for o in out[1:])  # one report, the oldest identity


def test_clusterer_on_keeps_the_large_clusters_identity_and_no_hand_over():
    # relink_retry_s (on by default since session 28) named off: it acts on the young large cluster
    # (see the next test)
    out = _clusterer_run(merge_id_dv_px_s=3.0, relink_retry_s=0.0)
    assert out[0] == [1]
    big = out[1]
    assert len(big) == 1 and big != [1]
    # the report keeps the large cluster's identity in every frame: the small cluster's identity,
    # lost from the reports, is not handed over to it
    assert all(o == big for o in out[1:])


def test_retry_takes_the_joined_clusters_identity():
    """A known interaction (session 28, measured and kept): relink_retry_s offers the young large cluster
    the small cluster's identity, lost from the reports when it was joined into the large one's report,
    and the report takes it a frame later."""
    out = _clusterer_run(merge_id_dv_px_s=3.0, relink_retry_s=1.0)
    assert out[0] == [1] and out[1] != [1]
    assert all(o == [1] for o in out[2:])


def test_assign_identities_min_share():
    prev = np.array([9, 32, 32, 32, 32, 32, -1])
    comp = np.array([0, 0, 0, 0, 0, 0, 0])
    ids, nxt = assign_identities(prev, comp, 40)
    assert ids.tolist() == [9] and nxt == 40  # the paper: the oldest carried identity
    ids, _ = assign_identities(prev, comp, 40, min_share=0.34)
    assert ids.tolist() == [32]  # 1 of 5: no claim
    ids, _ = assign_identities(prev, comp, 40, min_share=0.2)
    assert ids.tolist() == [9]  # 1 >= 0.2 x 5
    # a real merge (3 and 5 features) still keeps the oldest; a split still follows the paper
    prev2 = np.array([9, 9, 9, 32, 32, 32, 32, 32])
    assert assign_identities(prev2, np.zeros(8, np.int64), 40, min_share=0.34)[0].tolist() == [9]
    ids, nxt = assign_identities(prev2, np.array([0, 0, 0, 1, 1, 1, 1, 1]), 40, min_share=0.34)
    assert ids.tolist() == [9, 32] and nxt == 40
    # an identity without a claim anywhere is not handed out; a cluster with no claimant gets a new one
    ids, nxt = assign_identities(np.array([9, 32, 32, 32, 32]), np.array([0, 0, 0, 0, 0]), 40, min_share=0.5)
    assert ids.tolist() == [32] and nxt == 40


def _graph_run(min_share):
    """Cluster A (ids 1, 2; identity 1) dies at 0.2 s; its feature 2 remembers identity 1 and joins
    cluster B (features 3..7, identity 2) at 0.4 s.  Returns B's identity at the end."""
    g = AffinityClusters(alpha=3.0, w_link=1.0, min_features=2, label_memory_s=2.0, min_share=min_share)
    slots = np.arange(1, 8)
    # frames 0, 0.1: A = {1, 2} linked; B = {3..7} linked (a chain)
    bi = np.array([2, 3, 4, 5])
    bj = np.array([3, 4, 5, 6])
    for k in range(2):
        labels, cids = g.step(slots, slots, np.r_[0, bi], np.r_[1, bj], 0.1 * k)
    a_id, b_id = int(labels[0]), int(labels[2])
    assert a_id < b_id
    # A breaks apart (no edges among it any more; its weight decays to 0) while B goes on
    for k in range(2, 9):
        labels, cids = g.step(slots, slots, bi, bj, 0.1 * k)
    assert labels[1] == -1 and labels[2] == b_id
    # feature 2 (index 1) now links to B, within the label memory
    for k in range(9, 11):
        labels, cids = g.step(slots, slots, np.r_[1, bi], np.r_[2, bj], 0.1 * k)
    assert labels[1] == labels[2]
    return a_id, b_id, int(labels[2])


def test_graph_min_share_off_and_on():
    a_id, b_id, now = _graph_run(0.0)
    assert now == a_id  # the paper: the remembered older identity takes the cluster
    a_id, b_id, now = _graph_run(0.34)
    assert now == b_id


def _gate_run(**kw):
    """Boat A (5 features, +6 px/s) is clustered alone for two frames; then boat B (5 features,
    +3.5 px/s) appears 15 px below it.  Returns the number of reports in the last frame."""
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, coast_s=0.0, merge_overlap=0.0, **kw))
    a_xy = [[100.0 + 7 * j, 60.0] for j in range(5)]
    b_xy = [[104.0 + 7 * j, 75.0] for j in range(5)]
    for k in range(5):
        xy, vel, ids = list(a_xy), [[6.0, 0.0]] * 5, list(range(1, 6))
        if k >= 2:
            xy += b_xy
            vel += [[3.5, 0.0]] * 5
            ids += list(range(11, 16))
        _, tr = c.update(snap(xy, vel, 0.1 * k, k, ids=ids))
    return len(tr)


def test_gate_dv_off_uses_merge_dv_and_on_keeps_slow_neighbours_apart():
    assert ClusterParams().gate_dv_px_s == 0.0
    assert _gate_run() == 1  # 2.5 px/s apart: within merge_dv_px_s (3), one cluster
    assert _gate_run(gate_dv_px_s=2.0) == 2
    assert _gate_run(merge_dv_px_s=2.0) == 2  # the same gate through merge_dv_px_s


def test_report_merge_id_apart_keeps_like_sized_boats_moving_differently_apart():
    like = np.array([10, 6])
    # off: joined under the oldest identity (like sizes)
    assert _merge_overlapping(_CIDS, _BOXES, like, np.zeros((2, 2)), 0.25, _RV, id_dv=3.0)[0].tolist() == [3]
    c, b, _, _ = _merge_overlapping(_CIDS, _BOXES, like, np.zeros((2, 2)), 0.25, _RV, id_dv=3.0, id_apart=True)
    assert sorted(c.tolist()) == [3, 8] and len(b) == 2
    # a dominant cluster (10 vs 2) is still joined, under its identity; moving alike: joined, the oldest
    assert _merge_overlapping(_CIDS, _BOXES, _COUNT, np.zeros((2, 2)), 0.25, _RV, id_dv=3.0,
                              id_apart=True)[0].tolist() == [8]
    alike = np.array([[6.0, 0.0], [4.0, 0.0]])
    assert _merge_overlapping(_CIDS, _BOXES, like, np.zeros((2, 2)), 0.25, alike, id_dv=3.0,
                              id_apart=True)[0].tolist() == [3]
    # without id_dv it does nothing
    assert _merge_overlapping(_CIDS, _BOXES, like, np.zeros((2, 2)), 0.25, _RV, id_apart=True)[0].tolist() == [3]
