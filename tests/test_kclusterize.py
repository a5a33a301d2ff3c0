"""KClusterize (paper A, Fig. 10) and the particle-filter parts it works with."""

import numpy as np
import pytest

from seawatch.track.kclusterize import kclusterize
from seawatch.track.particle import (
    kernel_likelihood,
    predict_particles,
    resample_groups,
    sample_gaussians,
    systematic_resample,
)


def _mixture(rng, means, sigma, counts):
    pts = np.vstack([rng.normal(m, sigma, (k, 2)) for m, k in zip(means, counts)])
    truth = np.repeat(np.arange(len(means)), counts)
    return pts, truth


def test_recovers_known_mixture():
    rng = np.random.default_rng(1)
    means = np.array([[100.0, 100.0], [170.0, 95.0], [120.0, 190.0]])
    counts = [250, 150, 100]
    pts, truth = _mixture(rng, means, 3.0, counts)
    c = kclusterize(pts, None, 20.0)
    assert len(c) == 3
    np.testing.assert_allclose(c.weights, [0.5, 0.3, 0.2], atol=1e-12)  # heaviest first
    np.testing.assert_allclose(c.means, means, atol=1.0)
    np.testing.assert_allclose(c.sigmas, 3.0, rtol=0.25)
    np.testing.assert_array_equal(c.counts, counts)
    # every particle is in the cluster of its own component
    for k in range(3):
        assert np.all(c.labels[truth == k] == k)


def test_weights_drive_seeds_and_mixture_weights():
    rng = np.random.default_rng(2)
    pts, truth = _mixture(rng, [[50.0, 50.0], [150.0, 50.0]], 2.0, [100, 100])
    w = np.where(truth == 1, 3.0, 1.0)
    c = kclusterize(pts, w, 20.0)
    assert len(c) == 2
    np.testing.assert_allclose(c.weights, [0.75, 0.25])
    np.testing.assert_allclose(c.means[0], [150.0, 50.0], atol=1.0)
    # particles too light to seed still form a cluster as numerous outliers
    c2 = kclusterize(pts, w, 20.0, min_seed_weight=2.0)
    assert len(c2) == 2 and np.all(c2.labels >= 0)


def test_non_gaussian_cluster_splits():
    rng = np.random.default_rng(3)
    # a wide blob and a tight one 15 px away: every particle lies within delta of the seed (the
    # centre of the wide blob), so the first pass makes one cluster; its diameter exceeds delta
    # and its two halves are well separated, so it splits
    a = np.column_stack([rng.normal(100.0, 3.0, 150), rng.normal(100.0, 0.5, 150)])
    b = rng.normal([115.0, 100.0], 0.5, (80, 2))
    pts = np.vstack([[[100.0, 100.0]], a, b])
    truth = np.repeat([0, 0, 1], [1, 150, 80])
    w = np.ones(len(pts))
    w[0] = 5.0
    no_split = kclusterize(pts, w, 20.0, split_d=np.inf)
    assert len(no_split) == 1  # the first pass alone does not separate them
    c = kclusterize(pts, w, 20.0)
    assert len(c) == 2
    np.testing.assert_allclose(c.means[np.argsort(c.means[:, 0])], [[100, 100], [115, 100]], atol=0.6)
    lb = c.labels[-1]
    assert np.all(c.labels[truth == 1] == lb)  # the tight blob is whole
    assert np.mean(c.labels[truth == 0] != lb) > 0.97  # bar the wide blob's far tail (x > 107.5)


def test_recursive_split_of_four_modes():
    rng = np.random.default_rng(4)
    corners = np.array([[-12.5, -12.5], [12.5, -12.5], [-12.5, 12.5], [12.5, 12.5]]) + 100.0
    pts, truth = _mixture(rng, corners, 0.4, [50, 50, 50, 50])
    pts = np.vstack([[[100.0, 100.0]], pts])  # the heaviest particle, in the middle, seeds alone
    w = np.ones(len(pts))
    w[0] = 1.5
    assert len(kclusterize(pts, w, 20.0, max_depth=0)) == 1
    assert len(kclusterize(pts, w, 20.0, max_depth=1)) == 2  # halves of the square: still wide
    c = kclusterize(pts, w, 20.0)
    assert len(c) == 4
    d = np.linalg.norm(c.means[:, None] - corners[None], axis=2)
    assert sorted(d.argmin(1)) == [0, 1, 2, 3]
    assert d.min(1).max() < 0.7  # (the middle particle pulls one mean by ~0.5 px)


def test_gaussian_cluster_is_not_split():
    rng = np.random.default_rng(5)
    n_split = 0
    for _ in range(20):
        pts = rng.normal([200.0, 200.0], 20.0 / 6.0, (300, 2))  # diameter well above delta
        w = np.exp(-np.linalg.norm(pts - 200.0, axis=1) / 5.0)
        c = kclusterize(pts, w, 20.0)
        n_split += len(c) != 1
    assert n_split == 0


def test_outliers_join_or_form_clusters():
    rng = np.random.default_rng(6)
    main = rng.normal([100.0, 100.0], 2.0, (100, 2))
    stray = np.array([[127.0, 100.0], [128.0, 101.0]])  # a few light outliers near the cluster
    far_group = rng.normal([300.0, 300.0], 2.0, (30, 2))  # numerous light outliers: a cluster
    lone = np.array([[600.0, 50.0]])  # a lone far outlier: dropped
    pts = np.vstack([main, stray, far_group, lone])
    w = np.concatenate([np.ones(100), np.full(2, 0.01), np.full(30, 0.01), [0.01]])
    c = kclusterize(pts, w, 20.0, min_seed_weight=0.5, min_size=5)
    assert len(c) == 2
    assert np.all(c.labels[100:102] == c.labels[0])  # strays joined the main cluster
    assert np.all(c.labels[102:132] == c.labels[102]) and c.labels[102] != c.labels[0]
    assert c.labels[-1] == -1
    assert c.counts.sum() == len(pts) - 1


def test_close_clusters_merge_into_the_heavier():
    # two heavy seeds 21 px apart, whose members sit between them: means 2.5 px apart
    a = np.array([[0.0, 0.0]])
    b = np.array([[21.0, 0.0]])
    ga = np.column_stack([np.full(20, 10.4), np.linspace(-0.5, 0.5, 20)])
    gb = np.column_stack([np.full(20, 10.6), np.linspace(-0.5, 0.5, 20)])
    pts = np.vstack([a, b, ga, gb])
    w = np.concatenate([[3.0], [2.0], np.ones(40)])
    kept = kclusterize(pts, w, 20.0, merge_frac=0.0, split_d=np.inf)
    assert len(kept) == 2
    c = kclusterize(pts, w, 20.0, split_d=np.inf)
    assert len(c) == 1 and c.counts[0] == 42


def test_deterministic_and_edge_cases():
    rng = np.random.default_rng(7)
    pts, _ = _mixture(rng, [[0.0, 0.0], [50.0, 0.0]], 4.0, [200, 200])
    w = rng.random(len(pts))
    a, b = kclusterize(pts, w, 20.0), kclusterize(pts.copy(), w.copy(), 20.0)
    np.testing.assert_array_equal(a.labels, b.labels)
    np.testing.assert_array_equal(a.means, b.means)
    e = kclusterize(np.zeros((0, 2)), None, 20.0)
    assert len(e) == 0 and e.labels.shape == (0,)
    z = kclusterize(pts, np.zeros(len(pts)), 20.0)  # weightless: uniform statistics
    assert len(z) >= 2 and np.all(np.isfinite(z.means)) and np.all(z.weights == 0)
    with pytest.raises(ValueError, match="weights"):
        kclusterize(pts, -w, 20.0)
    with pytest.raises(ValueError, match="delta"):
        kclusterize(pts, w, 0.0)
    with pytest.raises(ValueError, match="finite"):
        kclusterize(np.array([[np.nan, 0.0]]), None, 20.0)


def test_particle_parts():
    rng = np.random.default_rng(8)
    # systematic resampling is low-variance: counts within one of n * w
    w = np.array([0.1, 0.0, 0.6, 0.3])
    idx = systematic_resample(w, 100, rng)
    counts = np.bincount(idx, minlength=4)
    assert np.all(np.abs(counts - 100 * w) <= 1) and counts[1] == 0
    np.testing.assert_array_equal(systematic_resample(np.zeros(4), 8, rng), [0, 0, 1, 1, 2, 2, 3, 3])
    # per-group resampling keeps each group's particles in the group
    groups = np.array([0, 0, 1, 1, 1, -1, 0])
    wts = np.array([1.0, 0.0, 0.2, 0.2, 0.6, 5.0, 1.0])
    idx, g = resample_groups(groups, wts, np.array([4, 10]), rng)
    assert len(idx) == 14 and np.all(groups[idx] == g)
    assert 5 not in idx and 1 not in idx
    assert np.sum(idx == 4) in (6, 7)
    # kernel likelihood: sum of exp(-d / sigma)
    p = np.array([[0.0, 0.0], [3.0, 4.0]])
    z = np.array([[0.0, 0.0], [6.0, 8.0]])
    np.testing.assert_allclose(kernel_likelihood(p, z, 5.0), [1 + np.exp(-2), 2 * np.exp(-1)])
    # prediction: constant velocity plus jitter
    q = predict_particles(np.zeros((1000, 2)), np.array([10.0, -5.0]), 0.5, 1.0, rng)
    np.testing.assert_allclose(q.mean(0), [5.0, -2.5], atol=0.15)
    np.testing.assert_allclose(q.std(0), 1.0, atol=0.1)
    pts, comp = sample_gaussians([[0.0, 0.0], [100.0, 0.0]], [1.0, 3.0], [500, 700], rng)
    assert len(pts) == 1200 and np.sum(comp == 1) == 700
    np.testing.assert_allclose(pts[comp == 1].std(0), 3.0, rtol=0.1)
