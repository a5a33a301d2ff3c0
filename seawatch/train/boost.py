"""Gentle AdaBoost of decision stumps over quantised Haar feature values (one cascade stage).

Each feature's values on the stage's samples are cut into at most 255 bins at quantile
mid-points (:func:`bin_features`); the bin edges are the only thresholds a stump can take, and a
sample's bin is the number of edges at or below its value, so ``bin < k`` is exactly
``value < edge[k - 1]``: the stump written to the XML decides as it did in training.

A Gentle AdaBoost round (Friedman, Hastie and Tibshirani 2000) fits, for every feature and every
split, the weighted least-squares regression stump ``f(x) = mean_w(y | side)`` and keeps the one
with the smallest weighted squared error; weights become ``w * exp(-y f(x))``.  The stage stops
when its threshold, set so that ``min_hit_rate`` of the positives pass, lets at most
``max_false_alarm`` of the negatives through (opencv_traincascade's rule).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from seawatch.train.model import THRESHOLD_EPS, Stage

__all__ = ["bin_features", "best_stump", "train_stage", "StageResult"]


@njit(cache=True)
def _assign_bins(values, edges, n_edges, out):
    nf, n = values.shape
    for f in range(nf):
        ne = n_edges[f]
        e = edges[f, :ne]
        for i in range(n):
            v = values[f, i]
            c = 0
            for j in range(ne):  # number of edges <= v (branch-free, vectorised)
                c += e[j] <= v
            out[f, i] = c


def bin_features(values: np.ndarray, n_bins: int = 64, rng: np.random.Generator | None = None,
                 subsample: int = 4000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quantise feature values (F, N) into at most ``n_bins`` bins per feature.

    Returns
    -------
    bins : (F, N) uint8
    edges : (F, n_bins - 1) float32, increasing, padded with +inf
    n_edges : (F,) int32, the number of real edges of each feature
    """
    if not 2 <= n_bins <= 256:
        raise ValueError(f"n_bins must be in 2..256, got {n_bins}")
    values = np.ascontiguousarray(values, np.float32)
    nf, n = values.shape
    if rng is None:
        rng = np.random.default_rng(0)
    sub = values if n <= subsample else values[:, np.sort(rng.choice(n, subsample, replace=False))]
    srt = np.sort(sub, axis=1)
    m = srt.shape[1]
    q = np.linspace(0, m - 1, n_bins + 1)[1:-1]
    lo_i = np.floor(q).astype(int)
    hi_i = np.minimum(lo_i + 1, m - 1)
    a = srt[:, lo_i]
    b = srt[:, hi_i]
    mid = (a.astype(np.float64) + b.astype(np.float64)) * 0.5
    edges = np.full((nf, n_bins - 1), np.inf, np.float32)
    n_edges = np.zeros(nf, np.int32)
    mid32 = mid.astype(np.float32)
    valid = b > a  # only between distinct values
    for f in range(nf):
        e = np.unique(mid32[f, valid[f]])
        # an edge must separate: strictly above the lower value
        e = e[np.isfinite(e)]
        n_edges[f] = len(e)
        edges[f, : len(e)] = e
    bins = np.empty((nf, n), np.uint8)
    _assign_bins(values, edges, n_edges, bins)
    return bins, edges, n_edges


@njit(cache=True)
def _best_stump(bins, n_edges, w, wy, idx, n_bins):
    nf = bins.shape[0]
    n = idx.shape[0]
    hw = np.zeros(n_bins)
    hy = np.zeros(n_bins)
    wtot = 0.0
    ytot = 0.0
    for j in range(n):
        i = idx[j]
        wtot += w[i]
        ytot += wy[i]
    best_gain = -1.0
    best_f = -1
    best_k = -1
    best_l = 0.0
    best_r = 0.0
    for f in range(nf):
        ne = n_edges[f]
        if ne == 0:
            continue
        for b in range(ne + 1):
            hw[b] = 0.0
            hy[b] = 0.0
        row = bins[f]
        for j in range(n):
            i = idx[j]
            b = row[i]
            hw[b] += w[i]
            hy[b] += wy[i]
        wl = 0.0
        yl = 0.0
        for k in range(1, ne + 1):
            wl += hw[k - 1]
            yl += hy[k - 1]
            wr = wtot - wl
            yr = ytot - yl
            if wl <= 1e-12 or wr <= 1e-12:
                continue
            gain = yl * yl / wl + yr * yr / wr
            if gain > best_gain:
                best_gain = gain
                best_f = f
                best_k = k
                best_l = yl / wl
                best_r = yr / wr
    return best_f, best_k, best_l, best_r, best_gain


def best_stump(bins, n_edges, w, y, n_bins, idx=None):
    """The Gentle AdaBoost stump of least weighted squared error over samples ``idx``.

    Returns ``(feature, k, left, right)``: samples with ``bin < k`` get ``left``.
    """
    w = np.asarray(w, np.float64)
    if idx is None:
        idx = np.arange(len(w), dtype=np.int64)
    f, k, lv, rv, _ = _best_stump(bins, n_edges, w, np.asarray(w * y, np.float64),
                                  np.asarray(idx, np.int64), int(n_bins))
    return int(f), int(k), float(lv), float(rv)


@njit(cache=True)
def _apply(bins_row, k, lv, rv, out):
    for i in range(bins_row.shape[0]):
        out[i] = lv if bins_row[i] < k else rv


def _trimmed(w: np.ndarray, pos: np.ndarray, rate: float, min_per_class: int = 50) -> np.ndarray:
    """Indices of the heaviest samples holding ``rate`` of each class's weight (weight trimming,
    per class so that both classes always remain)."""
    out = []
    for cls in (pos, ~pos):
        idx = np.flatnonzero(cls)
        order = idx[np.argsort(w[idx])[::-1]]
        cw = np.cumsum(w[order])
        m = int(np.searchsorted(cw, rate * cw[-1])) + 1
        out.append(order[: max(m, min(len(order), min_per_class))])
    return np.sort(np.concatenate(out))


@dataclass
class StageResult:
    stage: Stage
    scores: np.ndarray  # (N,) stage sums of the training samples
    passed: np.ndarray  # (N,) bool
    hit_rate: float
    false_alarm: float
    seconds: float


def _stage_threshold(pos_scores: np.ndarray, min_hit_rate: float) -> float:
    s = np.sort(pos_scores)
    k = int(np.floor((1.0 - min_hit_rate) * len(s)))
    k = min(max(k, 0), len(s) - 1)
    return float(s[k])


def passes(scores: np.ndarray, threshold: float) -> np.ndarray:
    """Which stage sums pass a stage threshold as OpenCV applies it (``sum >= thr - 1e-5``)."""
    t = float(np.float32(np.float32(threshold) - THRESHOLD_EPS))
    return scores >= t


def train_stage(
    values: np.ndarray,
    labels: np.ndarray,
    feature_ids: np.ndarray,
    min_hit_rate: float = 0.995,
    max_false_alarm: float = 0.5,
    max_weak_count: int = 100,
    n_bins: int = 64,
    weight_trim_rate: float = 0.95,
    rng: np.random.Generator | None = None,
    log=None,
) -> StageResult:
    """Train one boosted stage.

    Parameters
    ----------
    values : (F, N) float32, or a tuple ``(bins, edges, n_edges)`` from :func:`bin_features`
        Normalised feature values (:func:`~seawatch.train.haar.feature_values`).
    labels : (N,) +1 for positives, -1 for negatives.
    feature_ids : (F,) int
        Index of each row of ``values`` in the cascade's feature pool (written to the stage).
    min_hit_rate, max_false_alarm : float
        Stage targets.
    max_weak_count : int
        At most this many stumps.
    n_bins : int
        Quantisation of the feature values (thresholds per feature + 1).
    weight_trim_rate : float
        Each round fits on the heaviest samples holding this fraction of the weight (1: all).
    """
    t0 = time.perf_counter()
    y = np.asarray(labels, np.float64)
    pos = y > 0
    neg = ~pos
    if pos.sum() == 0 or neg.sum() == 0:
        raise ValueError("train_stage: need both positives and negatives")
    if isinstance(values, tuple):
        bins, edges, n_edges = values
    else:
        bins, edges, n_edges = bin_features(values, n_bins, rng)
    n = len(y)
    w = np.where(pos, 0.5 / pos.sum(), 0.5 / neg.sum())
    score = np.zeros(n)
    feats, splits, lefts, rights = [], [], [], []
    contrib = np.empty(n)
    thr = 0.0
    hr = fa = 1.0
    for t in range(int(max_weak_count)):
        sel = _trimmed(w, pos, weight_trim_rate) if weight_trim_rate < 1.0 else None
        f, k, lv, rv = best_stump(bins, n_edges, w, y, n_bins, sel)
        if sel is not None and (f < 0 or abs(lv - rv) < 1e-9):
            f, k, lv, rv = best_stump(bins, n_edges, w, y, n_bins)  # trimming left no contrast
        if f < 0 or abs(lv - rv) < 1e-9:
            break  # no stump separates the samples any more
        lv32, rv32 = np.float32(lv), np.float32(rv)
        _apply(bins[f], k, float(lv32), float(rv32), contrib)
        score += contrib
        feats.append(int(feature_ids[f]))
        splits.append(edges[f, k - 1])
        lefts.append(lv32)
        rights.append(rv32)
        w = w * np.exp(-y * contrib)
        w /= w.sum()
        thr = _stage_threshold(score[pos], min_hit_rate)
        ok = passes(score, thr)
        hr = float(ok[pos].mean())
        fa = float(ok[neg].mean())
        if log is not None and (t < 3 or t % 10 == 9):
            log(f"    weak {t + 1:3d}: HR {hr:.4f} FA {fa:.4f}")
        if fa <= max_false_alarm:
            break
    stage = Stage(thr, feats, splits, lefts, rights,
                  info={"hit_rate": hr, "false_alarm": fa, "n_pos": int(pos.sum()), "n_neg": int(neg.sum())})
    ok = passes(score, stage.threshold)
    return StageResult(stage, score, ok, hr, fa, time.perf_counter() - t0)
