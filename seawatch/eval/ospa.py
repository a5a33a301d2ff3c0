"""OSPA (Schuhmacher, Vo & Vo 2008) and GOSPA (Rahmathullah, Garcia-Fernandez & Svensson 2017).

For world-coordinate tracks, e.g. the 3-D tracks of the multi-camera GM-PHD tracker.  At each
time, with truth points ``X`` (``n``), estimates ``Y`` (``m``), cut-off ``c`` and order ``p``,
``d_c(x, y) = min(||x - y||, c)``:

* ``OSPA = ((min_pi sum d_c(x, y_pi)^p + c^p |n - m|) / max(n, m))^(1/p)``; 0 when both sets
  are empty and ``c`` when exactly one is.
* ``GOSPA`` (``alpha = 2``) ``= (min_pi sum d_c(x, y_pi)^p + c^p / 2 (n + m - 2 |pi|))^(1/p)``,
  the pairs farther than ``c`` counting as one missed and one false object.  It splits into
  ``localisation`` (sum of ``d^p`` over pairs closer than ``c``), ``missed`` and ``false``
  (``c^p / 2`` per missed truth / false estimate); these are ``p``-th powers, so
  ``GOSPA^p = localisation + missed + false`` (as Stone Soup reports them).

The optimal assignment minimises the summed ``d_c^p``.  Stone Soup's OSPA (1.9) assigns on the
sum of ``d_c`` and then raises to ``p``; for ``p = 1`` both are the same, for ``p != 1`` this
module's value is the one of the definition and is never larger.
Identities are not used (no track-switch term).
"""

from __future__ import annotations

import numpy as np

from seawatch.eval.frames import align, pair_table
from seawatch.eval.matching import assign_frames

__all__ = ["ospa", "gospa"]


def _setup(gt, pred, frames):
    g, p = align(gt, pred, frames, dim=None)
    if len(g) and len(p) and g.boxes.shape[1] != p.boxes.shape[1]:
        raise ValueError(f"truth points have {g.boxes.shape[1]} coordinates, estimates {p.boxes.shape[1]}")
    pt = pair_table(g, p, measure="euclidean")
    return g, p, pt


def ospa(gt, pred, cutoff_m: float, p: float = 1.0, frames=None) -> dict:
    """OSPA distance per time step and its mean.

    Parameters
    ----------
    gt, pred : per-frame data
        ``time or frame -> points`` or ``-> (ids, points)``, points ``(N, D)`` in metres.
    cutoff_m : float
        Cut-off distance ``c``.
    p : float
        Order (``>= 1``).
    frames : array-like, optional
        Times to score (default: every key of either input).

    Returns
    -------
    dict with ``OSPA`` (mean over time), ``frames`` and ``per_frame`` arrays, and the mean
    ``OSPA_localisation`` and ``OSPA_cardinality`` terms (before the ``1/p`` root).
    """
    if cutoff_m <= 0 or p < 1:
        raise ValueError("OSPA needs cutoff_m > 0 and p >= 1")
    g, pr, pt = _setup(gt, pred, frames)
    c = float(cutoff_m)
    cost = np.minimum(pt.sim, c) ** p
    q = assign_frames(pt, -cost, keep_positive=False)
    n = g.counts.astype(float)
    m = pr.counts.astype(float)
    loc = np.bincount(pt.pf[q], weights=cost[q], minlength=g.n_frames)
    card = c ** p * np.abs(n - m)
    big = np.maximum(n, m)
    safe = np.where(big > 0, big, 1.0)
    per = np.where(big > 0, ((loc + card) / safe) ** (1.0 / p), 0.0)
    return {
        "OSPA": float(per.mean()) if len(per) else 0.0,
        "frames": g.frames,
        "per_frame": per,
        "OSPA_localisation": float(np.mean(np.where(big > 0, loc / safe, 0.0))) if len(per) else 0.0,
        "OSPA_cardinality": float(np.mean(np.where(big > 0, card / safe, 0.0))) if len(per) else 0.0,
        "cutoff_m": c, "p": float(p), "n_frames": int(g.n_frames),
    }


def gospa(gt, pred, cutoff_m: float, p: float = 1.0, frames=None) -> dict:
    """GOSPA (``alpha = 2``) per time step, its decomposition, and the means.

    Parameters
    ----------
    gt, pred : per-frame data
        ``time or frame -> points`` or ``-> (ids, points)``, points ``(N, D)`` in metres.
    cutoff_m : float
        Cut-off distance ``c``.
    p : float
        Order (``>= 1``).
    frames : array-like, optional
        Times to score.

    Returns
    -------
    dict with ``GOSPA`` (mean over time), ``frames``, ``per_frame``, ``localisation``, ``missed``,
    ``false`` arrays (``p``-th powers, as Stone Soup), ``n_missed``, ``n_false`` arrays, and the
    means ``GOSPA_localisation``, ``GOSPA_missed``, ``GOSPA_false``.
    """
    if cutoff_m <= 0 or p < 1:
        raise ValueError("GOSPA needs cutoff_m > 0 and p >= 1")
    g, pr, pt = _setup(gt, pred, frames)
    c = float(cutoff_m)
    cost = np.minimum(pt.sim, c) ** p
    q = assign_frames(pt, -cost, keep_positive=False)
    q = q[pt.sim[q] < c]  # pairs at the cut-off are a miss plus a false object
    nf = g.n_frames
    loc = np.bincount(pt.pf[q], weights=cost[q], minlength=nf)
    k = np.bincount(pt.pf[q], minlength=nf).astype(float)
    n_missed = g.counts - k
    n_false = pr.counts - k
    dummy = c ** p / 2.0
    missed = dummy * n_missed
    false = dummy * n_false
    per = (loc + missed + false) ** (1.0 / p)
    mean = (lambda a: float(a.mean()) if nf else 0.0)
    return {
        "GOSPA": mean(per),
        "frames": g.frames,
        "per_frame": per,
        "localisation": loc, "missed": missed, "false": false,
        "n_missed": n_missed.astype(np.int64), "n_false": n_false.astype(np.int64),
        "GOSPA_localisation": mean(loc), "GOSPA_missed": mean(missed), "GOSPA_false": mean(false),
        "cutoff_m": c, "p": float(p), "n_frames": int(nf),
    }
