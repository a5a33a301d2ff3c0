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
