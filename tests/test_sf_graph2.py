"""Session 22, helper H3: ``gate_chain`` (two established clusters kept apart by the cluster-pair
velocity test are not joined through a chain of features outside them)."""
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from seawatch.track.feature_clusters import (AffinityClusters, ClusterParams, FeatureClusterer,
                                             _chain_components)


def _chain_run(**kw):
    """Cluster A (slots 0, 1, at rest) and cluster B (slots 2, 3, 5.5 px/s along x) grow apart for 5
    frames; then feature 4 (2.8 px/s: within the 3 px/s gate of both) is linked to 1 and to 2."""
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0, gate_clusters=True, **kw)
    slots, ids = np.arange(5), np.arange(10, 15)
    vel = np.array([[0.0, 0], [0.0, 0], [5.5, 0], [5.5, 0], [2.8, 0]])
    e = np.array([(0, 1), (2, 3)])
    for k in range(5):
        g.step(slots, ids, e[:, 0], e[:, 1], 0.04 * k, velocity=vel, max_dv_px_s=3.0)
    e = np.array([(0, 1), (2, 3), (1, 4), (2, 4)])
    out = []
    for k in range(5, 10):
        out.append(g.step(slots, ids, e[:, 0], e[:, 1], 0.04 * k, velocity=vel, max_dv_px_s=3.0))
    return out


def test_chain_joins_the_clusters_when_off():
    labels, cids = _chain_run()[0]
    # each link passes the feature gate (2.8 and 2.7 px/s): the chain merges them, the oldest identity stays
    assert cids.tolist() == [1] and (labels == 1).all()


def test_gate_chain_keeps_them_apart():
    for labels, cids in _chain_run(gate_chain=True):
        assert cids.tolist() == [1, 2]
        # the bridge joins the cluster whose velocity is nearer (B: 2.7 px/s against A's 2.8)
        assert labels.tolist() == [1, 1, 2, 2, 2]


def test_gate_chain_lets_alike_clusters_merge_and_uses_gate_rel():
    # the clusters 2.9 px/s apart (under the 3 px/s pair gate) merge through the chain ...
    def run(**kw):
        g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0, gate_clusters=True, gate_chain=True, **kw)
        slots, ids = np.arange(5), np.arange(10, 15)
        vel = np.array([[3.0, 0], [3.0, 0], [5.9, 0], [5.9, 0], [4.5, 0]])
        e = np.array([(0, 1), (2, 3)])
        for k in range(5):
            g.step(slots, ids, e[:, 0], e[:, 1], 0.04 * k, velocity=vel, max_dv_px_s=3.0)
        e = np.array([(0, 1), (2, 3), (1, 4), (2, 4)])
        return g.step(slots, ids, e[:, 0], e[:, 1], 0.2, velocity=vel, max_dv_px_s=3.0)
    assert run()[1].tolist() == [1]
    # ... unless the relative pair test keeps them apart (0.49 of the faster > 0.4, 2.9 > 2 px/s)
    labels, cids = run(gate_rel=0.4, gate_rel_min_px_s=2.0)
    assert cids.tolist() == [1, 2] and labels[:4].tolist() == [1, 1, 2, 2]


def test_chain_components_equal_connected_components_without_clusters():
    rng = np.random.default_rng(3)
    m = 40
    li = rng.integers(0, m, 25)
    lj = rng.integers(0, m, 25)
    ok = li != lj
    li, lj = np.minimum(li, lj)[ok], np.maximum(li, lj)[ok]
    vel = rng.normal(0, 4, (m, 2))
    lab = np.full(m, -1)
    cc = _chain_components(lab, vel, li, lj, np.zeros(0, np.int64), 3.0)
    _, ref = connected_components(coo_matrix((np.ones(len(li)), (li, lj)), shape=(m, m)), directed=False)
    # the same partition
    n_ref = len(np.unique(ref))
    assert n_ref > 5  # a test that can fail: several components
    assert np.unique(np.stack([cc, ref]), axis=1).shape[1] == n_ref == len(np.unique(cc))


def test_gate_chain_off_by_default_and_reaches_the_graph():
    assert ClusterParams().gate_chain is False
    assert FeatureClusterer().graph.gate_chain is False
    assert FeatureClusterer(ClusterParams(gate_chain=True)).graph.gate_chain is True


def _split_run(**kw):
    """Cluster A (slots 0-2, -20 px/s) and then cluster B (slots 3-6, -3 px/s) form; a bridge (2, 3)
    merges B into the older A (no velocity gate) for 6 frames; then the bridge goes and they split.
    Returns the labels of every frame after the bridge is gone."""
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=4.0, **kw)
    slots, ids = np.arange(7), np.arange(10, 17)
    vel = np.array([[-20.0, 0]] * 3 + [[-3.0, 0]] * 4)
    a = [(0, 1), (1, 2)]
    b = [(3, 4), (4, 5), (5, 6)]
    t = 0.0
    for frames, e in ((3, a), (3, a + b), (6, a + b + [(2, 3)]), (8, a + b)):
        out = []
        for _ in range(frames):
            e_ = np.array(e)
            out.append(g.step(slots, ids, e_[:, 0], e_[:, 1], t, velocity=vel)[0])
            t += 0.1
    return out


def test_split_rule_paper_and_split_origin():
    paper = _split_run()
    assert paper[0].tolist() == [1] * 7  # merged: the oldest identity
    # the paper: the larger part (B's four features) keeps the merged identity, A gets a new one
    assert paper[-1].tolist()[3:] == [1] * 4 and paper[-1][0] not in (1, -1)
    on = _split_run(split_origin_dv=3.0)
    assert on[0].tolist() == [1] * 7
    # split_origin: the part whose features had identity 1 before the merge (A) keeps it
    assert on[-1].tolist()[:3] == [1] * 3 and on[-1][3] not in (1, -1)
    # parts moving alike (within the threshold): the paper's rule
    alike = _split_run(split_origin_dv=20.0)
    assert [x.tolist() for x in alike] == [x.tolist() for x in paper]
    assert ClusterParams().split_origin_dv_px_s == 0.0
    assert FeatureClusterer(ClusterParams(split_origin_dv_px_s=3.0)).graph.split_origin_dv == 3.0


def test_split_origin_only_soon_after_the_merge():
    # the split comes about 0.3-0.6 s after the bridge goes (the merge itself 0.6 s before that)
    soon = _split_run(split_origin_dv=3.0, split_origin_s=5.0)
    assert soon[-1].tolist()[:3] == [1] * 3  # within the window: as without a limit
    late = _split_run(split_origin_dv=3.0, split_origin_s=0.05)
    assert [x.tolist() for x in late] == [x.tolist() for x in _split_run()]  # too late: the paper's rule
