"""Particle-filter parts of PTracking (paper A): predict, weigh, resample, sample.

Particles are rows of a ``(N, 2)`` float64 array of image positions (the bottom centre of a
vessel's box in the local layer; sea-plane metres in the global layer).  Each function works on
the whole array at once, in NumPy or Numba; none loops over particles in Python.

* :func:`predict_particles` moves every particle with the velocity of the track it belongs to
  (constant velocity) plus Gaussian jitter;
* :func:`kernel_likelihood` weighs particles by a sum of ``exp(-distance / sigma)`` kernels over
  the observations (the paper's observation model);
* :func:`systematic_resample` and :func:`resample_groups` do low-variance (systematic)
  resampling, the second one independently per cluster (per-cluster SIR);
* :func:`sample_gaussians` draws particles around observations or beliefs.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "predict_particles",
    "kernel_likelihood",
    "systematic_resample",
    "resample_groups",
    "sample_gaussians",
]


def predict_particles(points, velocities, dt_s: float, jitter_px: float, rng: np.random.Generator):
    """Constant-velocity prediction with Gaussian jitter.

    Parameters
    ----------
    points : (N, 2) float64
        Particle positions.
    velocities : (N, 2) float64 or (2,)
        Velocity of each particle (its track's), units per second.
    dt_s : float
        Time step in seconds (>= 0).
    jitter_px : float or (N,) array_like
        Standard deviation of the Gaussian jitter added to each coordinate (one for all
        particles, or one per particle).
    rng : numpy.random.Generator

    Returns
    -------
    (N, 2) float64, the predicted positions (a new array).
    """
    p = np.asarray(points, dtype=np.float64)
    out = p + np.asarray(velocities, dtype=np.float64) * float(dt_s)
    jit = np.asarray(jitter_px, dtype=np.float64)
    if len(p) and np.any(jit > 0):
        out += rng.standard_normal(p.shape) * (jit[:, None] if jit.ndim == 1 else jit)
    return out


@njit(cache=True)
def _kernel_likelihood(points, obs, sigma):
    n = points.shape[0]
    m = obs.shape[0]
    w = np.zeros(n)
    inv = 1.0 / sigma
    for i in range(n):
        s = 0.0
        for j in range(m):
            dx = (points[i, 0] - obs[j, 0]) * inv[j, 0]
            dy = (points[i, 1] - obs[j, 1]) * inv[j, 1]
            s += np.exp(-np.sqrt(dx * dx + dy * dy))
        w[i] = s
    return w


def kernel_likelihood(points, observations, sigma_px) -> np.ndarray:
    """Weights ``w_i = sum_j exp(-|(p_i - z_j) / sigma_j|)`` of particles given observations.

    Parameters
    ----------
    points : (N, 2) array_like
    observations : (M, 2) array_like
    sigma_px : float, (M,) or (M, 2) array_like
        Kernel scale (same unit as the points): one for all observations, one per observation,
        or one per observation and axis (an elliptical kernel).

    Returns
    -------
    (N,) float64, unnormalised weights in ``[0, M]`` (all zero when there is no observation).
    """
    p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 2))
    z = np.ascontiguousarray(np.asarray(observations, dtype=np.float64).reshape(-1, 2))
    sig = np.asarray(sigma_px, dtype=np.float64)
    sig = sig.reshape(-1, 1) if sig.ndim == 1 else sig
    sig = np.ascontiguousarray(np.broadcast_to(sig, (len(z), 2)))
    if not np.all(sig > 0):
        raise ValueError(f"kernel_likelihood: sigma_px must be positive, got {sigma_px}")
    return _kernel_likelihood(p, z, sig)


@njit(cache=True)
def _systematic(weights, n, u0):
    m = weights.shape[0]
    out = np.empty(n, np.int64)
    tot = 0.0
    for i in range(m):
        tot += weights[i]
    if m == 0 or n == 0:
        return out[:0]
    if not tot > 0:
        for k in range(n):
            out[k] = (k * m) // n
        return out
    step = tot / n
    u = u0 * step
    c = weights[0]
    i = 0
    for k in range(n):
        while u > c and i < m - 1:
            i += 1
            c += weights[i]
        out[k] = i
        u += step
    return out


def systematic_resample(weights, n: int, rng: np.random.Generator) -> np.ndarray:
    """Low-variance (systematic) resampling: ``n`` indices drawn in proportion to ``weights``.

    One uniform number positions a comb of ``n`` evenly spaced teeth over the cumulative
    weights.  All-zero weights give evenly spread indices (a uniform resample).
    """
    w = np.ascontiguousarray(np.asarray(weights, dtype=np.float64).reshape(-1))
    return _systematic(w, int(n), float(rng.random()))


@njit(cache=True)
def _resample_groups(groups, weights, counts, u0):
    # indices of particles per group, in index order
    g = counts.shape[0]
    n = groups.shape[0]
    sizes = np.zeros(g, np.int64)
    for i in range(n):
        if groups[i] >= 0:
            sizes[groups[i]] += 1
    starts = np.zeros(g + 1, np.int64)
    for k in range(g):
        starts[k + 1] = starts[k] + sizes[k]
    members = np.empty(starts[g], np.int64)
    fill = starts[:g].copy()
    for i in range(n):
        k = groups[i]
        if k >= 0:
            members[fill[k]] = i
            fill[k] += 1
    total = 0
    for k in range(g):
        if sizes[k] > 0:
            total += counts[k]
    out = np.empty(total, np.int64)
    outg = np.empty(total, np.int64)
    o = 0
    for k in range(g):
        if sizes[k] == 0 or counts[k] == 0:
            continue
        mem = members[starts[k]:starts[k + 1]]
        w = np.empty(mem.shape[0])
        for j in range(mem.shape[0]):
            w[j] = weights[mem[j]]
        idx = _systematic(w, counts[k], u0[k])
        for j in range(idx.shape[0]):
            out[o] = mem[idx[j]]
            outg[o] = k
            o += 1
    return out[:o], outg[:o]


def resample_groups(groups, weights, counts, rng: np.random.Generator):
    """Per-cluster systematic resampling.

    Parameters
    ----------
    groups : (N,) int
        Group (cluster) of each particle, ``0..G-1``; -1 drops the particle.
    weights : (N,) float
        Particle weights (a group whose weights are all zero is resampled uniformly).
    counts : (G,) int
        How many particles each group gets (a group with no particle gets none).
    rng : numpy.random.Generator

    Returns
    -------
    index : (sum counts,) int64, the resampled particles' indices into the input.
    group : (sum counts,) int64, the group of each resampled particle.
    """
    gr = np.ascontiguousarray(np.asarray(groups, dtype=np.int64).reshape(-1))
    w = np.ascontiguousarray(np.asarray(weights, dtype=np.float64).reshape(-1))
    c = np.ascontiguousarray(np.asarray(counts, dtype=np.int64).reshape(-1))
    if len(gr) != len(w):
        raise ValueError(f"resample_groups: {len(gr)} groups but {len(w)} weights")
    if len(gr) and gr.max() >= len(c):
        raise ValueError("resample_groups: a group index exceeds the number of counts")
    u0 = rng.random(len(c))
    return _resample_groups(gr, w, c, u0)


def sample_gaussians(means, sigmas, counts, rng: np.random.Generator):
    """Draw ``counts[k]`` points from each axis-aligned Gaussian ``N(means[k], sigmas[k]**2)``.

    Parameters
    ----------
    means : (K, 2) array_like
    sigmas : (K, 2) or (K,) array_like or float
        Standard deviations (per axis, per component, or one for all).
    counts : (K,) int array_like
    rng : numpy.random.Generator

    Returns
    -------
    points : (sum counts, 2) float64
    component : (sum counts,) int64, the component each point came from.
    """
    mu = np.asarray(means, dtype=np.float64).reshape(-1, 2)
    cnt = np.asarray(counts, dtype=np.int64).reshape(-1)
    sig = np.asarray(sigmas, dtype=np.float64)
    if sig.ndim == 0:
        sig = np.full((len(mu), 2), float(sig))
    elif sig.ndim == 1:
        sig = np.repeat(sig.reshape(-1, 1), 2, axis=1)
    if sig.shape != (len(mu), 2) or len(cnt) != len(mu):
        raise ValueError(f"sample_gaussians: {len(mu)} means, sigmas {np.shape(sigmas)}, {len(cnt)} counts")
    comp = np.repeat(np.arange(len(mu)), cnt)
    pts = mu[comp] + rng.standard_normal((len(comp), 2)) * sig[comp]
    return pts, comp
