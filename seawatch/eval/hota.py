"""HOTA (Luiten et al., IJCV 2021) and the identity metrics IDF1 / IDP / IDR (Ristani et al. 2016).

Both follow the definitions as computed by TrackEval, so figures are comparable with published
MOTChallenge results; they are written here over flat NumPy arrays.

HOTA
----
For every ground-truth id ``i`` and prediction id ``j`` a global alignment score
``A(i, j) = P(i, j) / (|i| + |j| - P(i, j))`` is built from the per-frame "potential matches"
``P`` (each pair's IoU normalised by the IoUs of its row and column).  In every frame the
Hungarian algorithm maximises ``A * IoU`` once; for each localisation threshold ``alpha`` in
``0.05, 0.10, ..., 0.95`` the assigned pairs with ``IoU >= alpha`` are true positives.  Then
``DetA = TP / (TP + FN + FP)``, ``AssA = sum_TP A_c / TP`` with ``A_c`` the association Jaccard
of the pair's ids, ``HOTA_alpha = sqrt(DetA * AssA)``, ``LocA`` the mean IoU of the true positives,
and HOTA, DetA, AssA, LocA are the means over ``alpha``.

IDF1
----
Prediction ids are assigned to ground-truth ids once for the whole sequence, maximising the
number of frames in which an assigned pair overlaps with ``IoU >= threshold`` (IDTP).
``IDF1 = 2 IDTP / (|GT| + |pred|)``, ``IDP = IDTP / |pred|``, ``IDR = IDTP / |GT|``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.eval.matching import EPS, assign_frames, prepare

__all__ = ["hota", "identity_metrics", "ALPHAS"]

#: The localisation thresholds of HOTA (as TrackEval: ``np.arange(0.05, 0.99, 0.05)``).
ALPHAS = np.arange(0.05, 0.99, 0.05)


def hota(gt, pred, alphas=None, frames=None) -> dict:
    """HOTA and its components.

    Parameters
    ----------
    gt, pred : per-frame data
        ``frame -> (ids, boxes)``, boxes ``x, y, w, h``.
    alphas : array-like, optional
        Localisation thresholds (default :data:`ALPHAS`).
    frames : array-like, optional
        Frames to score (default: all frame keys of either input).

    Returns
    -------
    dict
        Means over alpha: ``HOTA, DetA, AssA, LocA, DetRe, DetPr, AssRe, AssPr``; ``HOTA(0)``,
        ``LocA(0)``, ``HOTALocA(0)`` at the smallest alpha; per-alpha arrays under ``per_alpha``
        (``alpha, HOTA, DetA, AssA, LocA, DetRe, DetPr, AssRe, AssPr, TP, FN, FP``).
    """
    alphas = ALPHAS if alphas is None else np.asarray(alphas, dtype=float)
    prep = prepare(gt, pred, frames)
    g, p = prep.g, prep.p
    gid, n_gid, pid, n_pid = prep.ids()
    na = len(alphas)
    n_gt, n_pred = len(g), len(p)
    tp = np.zeros(na)
    fn = np.full(na, float(n_gt))
    fp = np.full(na, float(n_pred))
    loca = np.ones(na)
    ass_a = np.zeros(na)
    ass_re = np.zeros(na)
    ass_pr = np.zeros(na)
    if n_gt and n_pred:
        pt = prep.pt
        sim = pt.sim
        # potential matches: IoU normalised by row and column sums of its frame
        row_sum = np.bincount(pt.gi, weights=sim, minlength=n_gt)
        col_sum = np.bincount(pt.pj, weights=sim, minlength=n_pred)
        denom = row_sum[pt.gi] + col_sum[pt.pj] - sim
        sim_iou = np.zeros_like(sim)
        ok = denom > EPS
        sim_iou[ok] = sim[ok] / denom[ok]
        key = gid[pt.gi] * n_pid + pid[pt.pj]
        ukey, kinv = np.unique(key, return_inverse=True)  # id pairs that ever share a frame
        kinv = kinv.reshape(-1)
        nk = len(ukey)
        potential = np.bincount(kinv, weights=sim_iou, minlength=nk)
        g_count = np.bincount(gid, minlength=n_gid).astype(float)[ukey // n_pid]
        p_count = np.bincount(pid, minlength=n_pid).astype(float)[ukey % n_pid]
        align_score = potential / (g_count + p_count - potential)
        score = align_score[kinv] * sim
        q = assign_frames(pt, score, keep_positive=False)
        qs = sim[q]
        ok_a = qs[:, None] >= alphas[None, :] - EPS  # (Q, A)
        tp = ok_a.sum(0).astype(float)
        fn = n_gt - tp
        fp = n_pred - tp
        loc_sum = (qs[:, None] * ok_a).sum(0)
        loca = np.maximum(1e-10, loc_sum) / np.maximum(1e-10, tp)
        qa, qi = np.nonzero(ok_a.T)  # (alpha, matched pair) of every true positive
        mc = np.bincount(qa * nk + kinv[q][qi], minlength=na * nk).reshape(na, nk).astype(float)
        t = np.maximum(1.0, tp)
        ass_a = np.sum(mc * mc / np.maximum(1, g_count + p_count - mc), axis=1) / t
        ass_re = np.sum(mc * mc / np.maximum(1, g_count), axis=1) / t
        ass_pr = np.sum(mc * mc / np.maximum(1, p_count), axis=1) / t
    det_re = tp / np.maximum(1, tp + fn)
    det_pr = tp / np.maximum(1, tp + fp)
    det_a = tp / np.maximum(1, tp + fn + fp)
    h = np.sqrt(det_a * ass_a)
    per = {"alpha": alphas, "HOTA": h, "DetA": det_a, "AssA": ass_a, "LocA": loca, "DetRe": det_re,
           "DetPr": det_pr, "AssRe": ass_re, "AssPr": ass_pr, "TP": tp, "FN": fn, "FP": fp}
    res = {k: float(np.mean(v)) for k, v in per.items() if k not in ("alpha", "TP", "FN", "FP")}
    res["HOTA(0)"] = float(h[0])
    res["LocA(0)"] = float(loca[0])
    res["HOTALocA(0)"] = float(h[0] * loca[0])
    res["n_gt"], res["n_pred"], res["n_frames"] = int(n_gt), int(n_pred), int(g.n_frames)
    res["per_alpha"] = per
    return res


def identity_metrics(gt, pred, iou: float = 0.5, frames=None) -> dict:
    """IDF1, IDP, IDR (and IDTP, IDFP, IDFN) of tracks against ground truth.

    Parameters
    ----------
    gt, pred : per-frame data
        ``frame -> (ids, boxes)``, boxes ``x, y, w, h``.
    iou : float
        Minimum IoU for a frame to count as a match of an assigned id pair.
    frames : array-like, optional
        Frames to score.

    Returns
    -------
    dict with ``IDF1, IDP, IDR, IDTP, IDFP, IDFN, n_gt, n_pred`` and ``assignment``
    (``(K, 2)`` array of matched ``(gt id, pred id)``).
    """
    if not 0.0 < iou <= 1.0:
        raise ValueError(f"identity_metrics: iou must be in (0, 1], got {iou}")
    prep = prepare(gt, pred, frames)
    g, p = prep.g, prep.p
    gid, n_gid, pid, n_pid = prep.ids()
    n_gt, n_pred = len(g), len(p)
    idtp = 0.0
    assignment = np.zeros((0, 2), np.int64)
    if n_gt and n_pred:
        pt = prep.pt
        hit = pt.sim >= iou
        key = gid[pt.gi[hit]] * n_pid + pid[pt.pj[hit]]
        if len(key):
            # only ids that ever overlap enough can be assigned with profit
            rows, r_inv = np.unique(key // n_pid, return_inverse=True)
            cols, c_inv = np.unique(key % n_pid, return_inverse=True)
            nr, nc = len(rows), len(cols)
            potential = np.bincount(r_inv.reshape(-1) * nc + c_inv.reshape(-1),
                                    minlength=nr * nc).reshape(nr, nc).astype(float)
            r, c = linear_sum_assignment(-potential)
            w = potential[r, c]
            idtp = float(w.sum())
            keep = w > 0
            ug, up = np.unique(g.ids), np.unique(p.ids)
            assignment = np.stack([ug[rows[r[keep]]], up[cols[c[keep]]]], axis=1)
    idfn = n_gt - idtp
    idfp = n_pred - idtp
    return {
        "IDF1": idtp / max(1.0, idtp + 0.5 * idfp + 0.5 * idfn),
        "IDP": idtp / max(1.0, idtp + idfp),
        "IDR": idtp / max(1.0, idtp + idfn),
        "IDTP": int(idtp), "IDFP": int(idfp), "IDFN": int(idfn),
        "n_gt": int(n_gt), "n_pred": int(n_pred), "n_frames": int(g.n_frames),
        "iou": float(iou), "assignment": assignment,
    }
