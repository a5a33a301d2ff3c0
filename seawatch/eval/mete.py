"""METE and MELT (Nawaz, Poiesi & Cavallaro, "Measures of effective video tracking", IEEE TIP 2014).

The stable-features tracker paper reports its accuracy with these two measures.

METE, multiple extended-target tracking error
---------------------------------------------
In frame ``k`` with ground-truth boxes ``X`` (``n = |X|``) and estimates ``Y`` (``m = |Y|``), an
optimal one-to-one assignment of ``min(n, m)`` pairs minimises the summed cost ``1 - IoU``
(pairs that do not overlap at all may be assigned; they cost 1).  Then::

    METE_k = (sum over assigned pairs of (1 - IoU) + |n - m|) / max(n, m),   METE_k = 0 if n = m = 0

The first term is the accuracy error, the second the cardinality error; both are reported.  The
sequence score is the mean of ``METE_k`` over the scored frames (lower is better, in [0, 1]).

MELT, multiple extended-target lost-track ratio
-----------------------------------------------
With the same per-frame assignment, ground-truth track ``i`` (all frames holding its id) has
overlap ``IoU`` with its assigned estimate in each of its frames (0 where it has none).  For an
accuracy level ``tau`` its lost-track ratio is the fraction of its frames whose overlap is below
``tau``; ``MELT_tau`` is the mean of the ratios over the ground-truth tracks and
``MELT = mean over tau of MELT_tau``, with ``tau = 0, 0.05, ..., 1`` by default (lower is better).
Since an overlap is never below 0, ``MELT_0 = 0``; ``MELT_1`` counts every imperfect frame.
"""

from __future__ import annotations

import numpy as np

from seawatch.eval.matching import prepare, relabel

__all__ = ["mete", "melt", "TAUS"]

#: Default accuracy levels of MELT: 0, 0.05, ..., 1.
TAUS = np.round(np.linspace(0.0, 1.0, 21), 10)


def mete(gt, pred, frames=None) -> dict:
    """METE per frame and its mean.

    Parameters
    ----------
    gt, pred : per-frame data
        ``frame -> boxes`` or ``frame -> (ids, boxes)``, boxes ``x, y, w, h`` (ids are not used).
    frames : array-like, optional
        Frames to score (default: every frame key of either input; frames listed with no object
        in both inputs score 0 and count in the mean).

    Returns
    -------
    dict
        ``METE`` (mean), ``METE_accuracy`` and ``METE_cardinality`` (means of the two terms),
        ``frames``, ``per_frame``, ``accuracy_per_frame``, ``cardinality_per_frame`` arrays,
        ``n_gt_per_frame``, ``n_pred_per_frame``.
    """
    prep = prepare(gt, pred, frames)
    g, p, pt = prep.g, prep.p, prep.pt
    q = prep.max_overlap()
    n = g.counts.astype(float)
    m = p.counts.astype(float)
    nf = g.n_frames
    # assigned pairs cost 1 - IoU; the min(n, m) - |q_k| assigned cells without overlap cost 1
    acc = np.minimum(n, m) - np.bincount(pt.pf[q], weights=pt.sim[q], minlength=nf)
    card = np.abs(n - m)
    denom = np.maximum(n, m)
    safe = np.where(denom > 0, denom, 1.0)
    acc_k = np.where(denom > 0, acc / safe, 0.0)
    card_k = np.where(denom > 0, card / safe, 0.0)
    per = acc_k + card_k
    return {
        "METE": float(per.mean()) if nf else 0.0,
        "METE_accuracy": float(acc_k.mean()) if nf else 0.0,
        "METE_cardinality": float(card_k.mean()) if nf else 0.0,
        "frames": g.frames,
        "per_frame": per,
        "accuracy_per_frame": acc_k,
        "cardinality_per_frame": card_k,
        "n_gt_per_frame": g.counts,
        "n_pred_per_frame": p.counts,
        "n_frames": int(nf),
    }


def melt(gt, pred, taus=None, frames=None) -> dict:
    """MELT: mean lost-track ratio over accuracy levels.

    Parameters
    ----------
    gt : per-frame data
        ``frame -> (ids, boxes)``; the ids define the ground-truth tracks.
    pred : per-frame data
        ``frame -> boxes`` or ``frame -> (ids, boxes)`` (ids are not used).
    taus : array-like, optional
        Accuracy levels (default :data:`TAUS`, 0 to 1 in steps of 0.05).
    frames : array-like, optional
        Frames to score.

    Returns
    -------
    dict
        ``MELT`` (nan without ground truth), ``tau``, ``MELT_tau`` (one value per tau),
        ``track_ids``, ``lost_ratio`` (tracks x taus) and ``overlap`` (the per-row overlap of the
        ground truth with its assigned estimate).
    """
    taus = TAUS if taus is None else np.asarray(taus, dtype=float)
    prep = prepare(gt, pred, frames)
    g, pt = prep.g, prep.pt
    q = prep.max_overlap()
    overlap = np.zeros(len(g))
    overlap[pt.gi[q]] = pt.sim[q]
    gid, n_gid = relabel(g.ids)
    if n_gid == 0:
        return {"MELT": float("nan"), "tau": taus, "MELT_tau": np.full(len(taus), np.nan),
                "track_ids": np.zeros(0, np.int64), "lost_ratio": np.zeros((0, len(taus))),
                "overlap": overlap}
    count = np.bincount(gid, minlength=n_gid).astype(float)
    lost = overlap[:, None] < taus[None, :]  # (rows, taus)
    t_idx, r_idx = np.nonzero(lost.T)
    lost_n = np.bincount(t_idx * n_gid + gid[r_idx], minlength=len(taus) * n_gid).reshape(len(taus), n_gid)
    ratio = (lost_n / count[None, :]).T  # (tracks, taus)
    melt_tau = ratio.mean(axis=0)
    return {
        "MELT": float(melt_tau.mean()),
        "tau": taus,
        "MELT_tau": melt_tau,
        "track_ids": np.unique(g.ids),
        "lost_ratio": ratio,
        "overlap": overlap,
        "n_tracks": int(n_gid),
    }
