"""Velocity-vector matching through a rotation theta (Bloisi et al.), and two ways to find theta.

The camera measures each vessel's velocity in its own ground frame (here: the sea-plane ENU
frame of the camera's *nominal* pose), the VTS/AIS in the true east-north frame.  The two are
related by a rotation ``theta`` (the camera's heading error); matching velocity vectors after
rotating the camera's by ``theta`` associates camera and VTS tracks without trusting positions.

* :func:`calibrate_theta_pg` finds theta with the paper's policy-gradient search (the finite-
  difference policy gradient of Kohl & Stone: random perturbations of the parameter by
  ``-eps, 0, +eps``, the reward of each, a step along the normalised gradient estimate), from an
  initial 15 degrees, maximising the agreement of the best one-to-one velocity matching.
* :func:`estimate_theta_robust` estimates theta directly: every camera/VTS pair proposes the angle
  between its two vectors; the angle with the largest weighted consensus (a circular mode) is
  refined by a Tukey-biweight circular mean of its inliers, with a standard error.

Vectors are (N, 2) arrays ``(east, north)`` in m/s; angles in degrees, positive = clockwise
(the rotation that turns the camera frame's north towards its east).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["rotate_cw", "velocity_cost", "match_velocities", "matching_reward", "calibrate_theta_pg",
           "estimate_theta_robust", "ThetaEstimate"]


def rotate_cw(vec: np.ndarray, theta_deg) -> np.ndarray:
    """Rotate (..., 2) east-north vectors clockwise (seen from above) by ``theta_deg``.

    A course ``c`` becomes course ``c + theta``.
    """
    v = np.asarray(vec, float)
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    e, n = v[..., 0], v[..., 1]
    return np.stack([e * c + n * s, -e * s + n * c], axis=-1)


def velocity_cost(cam_vel: np.ndarray, ref_vel: np.ndarray, theta_deg: float, min_speed_mps: float = 0.3) -> np.ndarray:
    """Normalised difference of every rotated camera vector and every reference vector, (N, M).

    ``|R(theta) c - r| / max(|c|, |r|, min_speed)``: 0 for equal vectors, 2 for opposite ones.
    """
    c = rotate_cw(cam_vel, theta_deg).reshape(-1, 2)
    r = np.asarray(ref_vel, float).reshape(-1, 2)
    diff = np.linalg.norm(c[:, None, :] - r[None, :, :], axis=-1)
    scale = np.maximum(np.maximum(np.linalg.norm(c, axis=1)[:, None], np.linalg.norm(r, axis=1)[None, :]),
                       min_speed_mps)
    return diff / scale


def match_velocities(cam_vel, ref_vel, theta_deg: float, gate: float = 0.5, mask=None):
    """One-to-one matching of velocity vectors after rotation by theta.

    Parameters
    ----------
    gate : float, largest :func:`velocity_cost` of a match.
    mask : optional (N, M) bool, pairs allowed (e.g. a loose position gate).

    Returns
    -------
    rows, cols : index arrays of the matched pairs; cost : their costs.
    """
    cost = velocity_cost(cam_vel, ref_vel, theta_deg)
    if cost.size == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    big = cost.copy()
    bad = cost > gate
    if mask is not None:
        bad |= ~np.asarray(mask, bool)
    big[bad] = 1e6
    r, c = linear_sum_assignment(big)
    ok = ~bad[r, c]
    return r[ok], c[ok], cost[r[ok], c[ok]]


def matching_reward(theta_deg: float, frames, gate: float = 0.5) -> float:
    """Reward of a theta over several frames: sum over matched pairs of ``1 - cost/gate``.

    ``frames`` is a list of ``(cam_vel, ref_vel)`` or ``(cam_vel, ref_vel, mask)`` tuples.
    """
    total = 0.0
    for fr in frames:
        r, c, cost = match_velocities(fr[0], fr[1], theta_deg, gate, fr[2] if len(fr) > 2 else None)
        total += float(np.sum(1.0 - cost / gate))
    return total


def calibrate_theta_pg(
    frames,
    theta0_deg: float = 15.0,
    eps_deg: float = 2.0,
    step_deg: float = 2.0,
    n_policies: int = 8,
    n_iter: int = 60,
    gate: float = 0.5,
    seed: int = 0,
    anneal: float = 0.95,
) -> tuple[float, list[float]]:
    """Find theta by finite-difference policy gradient (Kohl & Stone), as in Bloisi et al.

    Each iteration draws ``n_policies`` perturbed thetas ``theta + {-eps, 0, +eps}`` at random,
    scores each with :func:`matching_reward`, and estimates the gradient from the mean reward of
    the ``+eps`` and ``-eps`` groups (zero when the ``0`` group beats both); theta moves by
    ``step_deg`` along its sign.  Step and perturbation shrink by ``anneal`` per iteration.

    Returns
    -------
    theta_deg : float, the calibrated rotation.
    history : list of theta after each iteration.
    """
    rng = np.random.default_rng(seed)
    theta = float(theta0_deg)
    hist = []
    eps, step = float(eps_deg), float(step_deg)
    cache: dict[float, float] = {}

    def reward(t: float) -> float:
        k = round(t, 4)
        if k not in cache:
            cache[k] = matching_reward(t, frames, gate)
        return cache[k]

    for _ in range(int(n_iter)):
        signs = rng.integers(-1, 2, size=n_policies)
        rewards = np.array([reward(theta + s * eps) for s in signs])
        avg = {s: rewards[signs == s].mean() if np.any(signs == s) else None for s in (-1, 0, 1)}
        if avg[-1] is None:
            avg[-1] = reward(theta - eps)
        if avg[1] is None:
            avg[1] = reward(theta + eps)
        if avg[0] is None:
            avg[0] = reward(theta)
        if avg[0] >= avg[1] and avg[0] >= avg[-1]:
            g = 0.0
        else:
            g = avg[1] - avg[-1]
        if g != 0.0:
            theta += step * np.sign(g)
        hist.append(theta)
        eps *= anneal
        step *= anneal
        if step < 1e-3:
            break
    return theta, hist


@dataclass
class ThetaEstimate:
    """A robust rotation estimate: value, standard error (degrees) and inliers used."""

    theta_deg: float
    sigma_deg: float
    n_inliers: int
    n_pairs: int


def estimate_theta_robust(cam_vel, ref_vel, weights=None, pairs: bool = True, bin_deg: float = 2.0,
                          min_speed_mps: float = 0.5, tukey_c_deg: float = 15.0) -> ThetaEstimate:
    """Estimate the rotation from camera to reference velocity vectors, robustly.

    Parameters
    ----------
    cam_vel, ref_vel : (N, 2) vectors.  With ``pairs=True`` row ``i`` of each is one matched pair;
        with ``pairs=False`` every combination is a candidate (unknown association).
    weights : optional (N,) or (N, M) weights per pair.
    bin_deg : width of the consensus search.
    min_speed_mps : slower vectors have no reliable direction and are ignored.
    tukey_c_deg : Tukey biweight cut-off of the refinement.

    Returns
    -------
    ThetaEstimate (theta NaN when no pair is usable).
    """
    c = np.asarray(cam_vel, float).reshape(-1, 2)
    r = np.asarray(ref_vel, float).reshape(-1, 2)
    ac = np.degrees(np.arctan2(c[:, 0], c[:, 1]))
    ar = np.degrees(np.arctan2(r[:, 0], r[:, 1]))
    sc = np.linalg.norm(c, axis=1)
    sr = np.linalg.norm(r, axis=1)
    if pairs:
        if len(c) != len(r):
            raise ValueError("estimate_theta_robust: pairs=True needs equal numbers of vectors")
        d = ar - ac
        ok = (sc >= min_speed_mps) & (sr >= min_speed_mps)
        w = np.ones(len(d)) if weights is None else np.asarray(weights, float).reshape(-1)
        # vectors of very different speed are probably not the same vessel
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.minimum(sc, sr) / np.maximum(sc, sr)
        w = w * np.where(np.isfinite(ratio), ratio, 0.0)
    else:
        d = (ar[None, :] - ac[:, None]).ravel()
        ok = ((sc[:, None] >= min_speed_mps) & (sr[None, :] >= min_speed_mps)).ravel()
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = (np.minimum(sc[:, None], sr[None, :]) / np.maximum(sc[:, None], sr[None, :])).ravel()
        w = np.ones(len(d)) if weights is None else np.asarray(weights, float).ravel()
        w = w * np.where(np.isfinite(ratio), ratio, 0.0) ** 2
    d = (d[ok] + 180.0) % 360.0 - 180.0
    w = w[ok]
    if len(d) == 0 or w.sum() <= 0:
        return ThetaEstimate(float("nan"), float("nan"), 0, int(ok.size))
    # consensus: the candidate angle with the largest summed weight within +-bin_deg
    cand = d
    diff = np.abs((cand[:, None] - d[None, :] + 180.0) % 360.0 - 180.0)
    support = (w[None, :] * (diff <= bin_deg)).sum(axis=1)
    theta = float(cand[np.argmax(support)])
    # refinement: iteratively reweighted (Tukey biweight) circular mean
    for _ in range(20):
        res = (d - theta + 180.0) % 360.0 - 180.0
        u = res / tukey_c_deg
        bw = np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0) * w
        if bw.sum() <= 0:
            break
        step = float(np.sum(bw * res) / bw.sum())
        theta += step
        if abs(step) < 1e-6:
            break
    res = (d - theta + 180.0) % 360.0 - 180.0
    inl = np.abs(res) < tukey_c_deg
    n_in = int(inl.sum())
    if n_in >= 2:
        ww = w[inl]
        var = float(np.sum(ww * res[inl] ** 2) / ww.sum())
        n_eff = ww.sum() ** 2 / np.sum(ww * ww)
        sigma = float(np.sqrt(var / max(n_eff - 1.0, 1.0)))
    else:
        sigma = float("nan")
    return ThetaEstimate(float((theta + 180.0) % 360.0 - 180.0), sigma, n_in, int(ok.size))
