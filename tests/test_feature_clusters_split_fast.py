"""The report split's compiled group search (``_split_groups``, session 17) gives what the
per-cluster numpy code it replaced gave: the same velocities, medians, groups and decisions."""

import warnings

import numpy as np
import pytest

from seawatch.track.feature_clusters import _median_of, _split_groups


def _reference(history, m, k, n_clusters, anchor, dv, need):
    """The per-cluster numpy code of ``FeatureClusterer._split_for_report`` before session 17."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        fv = np.nanmean(history[m], axis=1)
    fin = np.isfinite(fv).all(axis=1)
    cnt = np.bincount(k[fin], minlength=n_clusters)
    ok = np.zeros(n_clusters, bool)
    near_of, part_of = {}, {}
    for c in np.flatnonzero(cnt >= need + 2):
        f = np.flatnonzero((k == c) & fin)
        fa = f[anchor[f]]
        med = np.median(fv[fa if len(fa) >= 2 else f], axis=0)
        far = f[np.hypot(*(fv[f] - med).T) > dv]
        if len(far) < need or len(f) - len(far) < 2:
            continue
        med2 = np.median(fv[far], axis=0)
        part = far[np.hypot(*(fv[far] - med2).T) <= dv]
        if len(part) < need or np.hypot(*(med2 - med)) <= dv:
            continue
        ok[c] = True
        near_of[c] = f[np.hypot(*(fv[f] - med).T) <= dv]
        part_of[c] = part
    return ok, near_of, part_of


def _case(rng, n_clusters):
    """Clusters of 1-14 members, some of two velocity groups, with unknown samples, ties (rounded
    velocities) and anchors."""
    sizes = rng.integers(1, 15, n_clusters)
    k = np.repeat(np.arange(n_clusters), sizes)
    rng.shuffle(k)
    n = len(k)
    base = rng.normal(0, 10, (n_clusters, 2))
    other = base + rng.normal(0, 8, (n_clusters, 2))
    second = rng.random(n) < rng.random(n_clusters)[k]
    vel = np.where(second[:, None], other[k], base[k]) + rng.normal(0, 1.5, (n, 2))
    if rng.random() < 0.5:
        vel = np.round(vel)
    w = 15
    hist = vel[:, None, :] + rng.normal(0, 1.0, (n, w, 2))
    hist[rng.random((n, w, 2)) < 0.4] = np.nan
    hist[rng.random(n) < 0.1] = np.nan  # never seen moving
    # features outside any cluster in between
    extra = rng.integers(0, 5)
    full = np.concatenate([rng.normal(0, 5, (extra, w, 2)), hist])
    m = np.arange(extra, extra + n)
    anchor = rng.random(n) < rng.choice([0.0, 0.2, 0.7])
    return full, m, k, anchor


@pytest.mark.parametrize("seed", range(6))
def test_split_groups_match_the_numpy_code(seed):
    rng = np.random.default_rng(seed)
    splits = kept = 0
    for _ in range(60):
        nc = int(rng.integers(1, 8))
        hist, m, k, anchor = _case(rng, nc)
        dv = float(rng.choice([3.0, 6.0, 10.0]))
        need = int(rng.choice([2, 3]))
        ok, code = _split_groups(hist, m, k, nc, anchor, dv, need)
        ref_ok, near_of, part_of = _reference(hist, m, k, nc, anchor, dv, need)
        assert ok.tolist() == ref_ok.tolist()
        for c in np.flatnonzero(ref_ok):
            assert np.flatnonzero((k == c) & (code == 2)).tolist() == part_of[c].tolist()
            assert np.flatnonzero((k == c) & (code == 1)).tolist() == near_of[c].tolist()
        splits += int(ref_ok.sum())
        kept += int((~ref_ok).sum())
    assert splits > 10 and kept > 10  # both outcomes were tried


def test_median_of_is_numpys():
    rng = np.random.default_rng(3)
    for n in range(1, 12):
        v = np.round(rng.normal(0, 3, n), 1)
        assert _median_of(v) == np.median(v)


def test_no_cluster_large_enough():
    hist = np.zeros((3, 15, 2))
    ok, code = _split_groups(hist, np.arange(3), np.zeros(3, np.int64), 1, np.zeros(3, bool), 6.0, 2)
    assert not ok.any() and not code.any()
