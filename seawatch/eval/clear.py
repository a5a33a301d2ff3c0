"""CLEAR MOT metrics, in the MOTChallenge form and in the VACE form of Kasturi et al.

MOTChallenge (Bernardin & Stiefelhagen 2008 as computed by TrackEval)
---------------------------------------------------------------------
Per frame, ground truth and predictions are matched one-to-one by the Hungarian algorithm on
IoU; pairs below the IoU threshold cannot match, and a pair that was matched in the previous
frame is preferred over any other (score ``1000 + IoU``).  An identity switch is counted when a
ground-truth object is matched to another prediction id than the one it was last matched to (any
number of frames before).  ``MOTA = 1 - (FN + FP + IDSW) / GT``, ``MOTP`` is the mean IoU of
the matches (so higher is better), MT / PT / ML are the ground-truth tracks matched in more than
80 %, at least 20 %, and less than 20 % of their frames, and ``Frag`` counts the times a
ground-truth track resumes being matched after an interruption.  As in TrackEval, a frame with no
ground truth or no predictions leaves the memory of the previous frame's matches untouched, and a
sequence without any ground truth has ``MOTA = MODA = 0`` (MOTA is undefined there; TrackEval
reports 0, and so does the VACE variant here).

VACE (Kasturi et al., PAMI 2009; used by Bloisi et al.)
-------------------------------------------------------
Per frame, a one-to-one mapping maximising the summed spatial overlap (IoU) among pairs above the
threshold, with no preference for earlier matches.  ``MOTA = 1 - sum_t(m_t + fp_t +
log10(IDSW_t)) / sum_t N_G(t)`` with the identity switches ``IDSW_t`` of frame ``t``;
``log10(0)`` is taken as 0 (a frame without switches adds nothing, like a frame with one switch,
since ``log10(1) = 0``).  ``MOTA_logtotal`` uses ``log10`` of the total number of switches instead
(TrackEval's MOTAL), for readers who apply the logarithm to the sequence total.  ``MOTP`` is the
mean IoU of the mapped pairs; precision and recall are ``TP / (TP + FP)`` and ``TP / (TP + FN)``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.eval.matching import EPS, prepare, split_conflict_free

__all__ = ["clear_mot"]


def clear_mot(gt, pred, iou: float = 0.5, variant: str = "motchallenge", frames=None) -> dict:
    """CLEAR MOT metrics of tracks against ground truth.

    Parameters
    ----------
    gt, pred : per-frame data
        ``frame -> (ids, boxes)`` with boxes ``x, y, w, h`` (see :mod:`seawatch.eval.frames`).
    iou : float
        Minimum IoU of a match (TrackEval uses 0.5).
    variant : {"motchallenge", "vace"}
        Which definition (module docstring).
    frames : array-like, optional
        The frames to score (default: every frame key of ``gt`` or ``pred``).

    Returns
    -------
    dict
        ``MOTA, MOTP, MODA, IDSW, Frag, FP, FN, TP, MT, PT, ML, recall, precision, n_gt, n_pred,
        n_frames`` and, for VACE, ``MOTA_logtotal`` and ``idsw_per_frame``.
    """
    prep = prepare(gt, pred, frames)
    g, p, pt = prep.g, prep.p, prep.pt
    gid, n_gid, pid, _ = prep.ids()
    if variant == "motchallenge":
        res = _clear_motchallenge(g, p, pt, gid, n_gid, pid, iou)
    elif variant == "vace":
        res = _clear_vace(g, p, pt, gid, n_gid, pid, prep.thresholded(iou))
    else:
        raise ValueError(f"unknown CLEAR MOT variant {variant!r} (motchallenge or vace)")
    if len(g) == 0:
        # MOTA is undefined without ground truth; TrackEval reports 0 (its early return), and so
        # do we for both variants, so that sequence tables agree.  FP still counts them.
        for k in ("MOTA", "MODA", "sMOTA", "MOTA_logtotal"):
            if k in res:
                res[k] = 0.0
    res["variant"] = variant
    res["iou"] = float(iou)
    res["n_frames"] = int(g.n_frames)
    return res


def _summary(tp, fp, fn, idsw, motp_sum, n_gt, n_pred):
    denom = max(1.0, tp + fn)
    return {
        "MOTA": (tp - fp - idsw) / denom,
        "MODA": (tp - fp) / denom,
        "MOTP": motp_sum / max(1.0, tp),
        "TP": int(tp), "FP": int(fp), "FN": int(fn), "IDSW": int(idsw),
        "recall": tp / denom,
        "precision": tp / max(1.0, tp + fp),
        "n_gt": int(n_gt), "n_pred": int(n_pred),
    }


def _mt_pt_ml(gid, n_gid, matched_gid):
    count = np.bincount(gid, minlength=n_gid).astype(float)
    matched = np.bincount(matched_gid, minlength=n_gid).astype(float)
    present = count > 0
    ratio = matched[present] / count[present]
    mt = int(np.sum(ratio > 0.8))
    pt = int(np.sum(ratio >= 0.2)) - mt
    return mt, pt, int(n_gid) - mt - pt


def _clear_motchallenge(g, p, pt, gid, n_gid, pid, thr):
    start, ng, npd = pt.start.tolist(), pt.ng.tolist(), pt.np_.tolist()
    lr, lc = pt.lr, pt.lc
    sim_all = pt.sim
    thr_score = np.where(sim_all >= thr - EPS, sim_all, 0.0) if len(sim_all) else sim_all
    fast_q, slow = split_conflict_free(pt, thr_score)
    easy = np.ones(len(ng), bool)
    easy[slow] = False
    fast_start = np.searchsorted(pt.pf[fast_q], np.arange(len(ng) + 1))
    fast_r, fast_c = lr[fast_q], lc[fast_q]
    gs, ps = g.starts.tolist(), p.starts.tolist()
    prev_any = np.full(n_gid, -1, np.int64)  # last matched prediction id, any frame before
    prev_t = np.full(n_gid, -1, np.int64)  # matched prediction id in the last scored frame
    frag = np.zeros(n_gid, np.int64)
    tp = fp = fn = idsw = 0
    motp_sum = 0.0
    matched_g = []
    lim = thr - EPS
    for f in range(len(ng)):
        n, m = ng[f], npd[f]
        if n == 0:
            fp += m
            continue
        if m == 0:
            fn += n
            continue
        s, e = start[f], start[f + 1]
        if s == e:  # no overlapping pair: nothing can match
            fn += n
            fp += m
            prev_t[:] = -1
            continue
        g_ids = gid[gs[f]:gs[f] + n]
        p_ids = pid[ps[f]:ps[f] + m]
        if easy[f]:  # no competing candidates: the pairs above the threshold are the matches
            k0, k1 = fast_start[f], fast_start[f + 1]
            r, c = fast_r[k0:k1], fast_c[k0:k1]
            sim_rc = sim_all[fast_q[k0:k1]]
        else:
            sim = np.zeros((n, m))
            sim[lr[s:e], lc[s:e]] = sim_all[s:e]
            score = 1000.0 * (p_ids[None, :] == prev_t[g_ids][:, None]) + sim
            score[sim < lim] = 0.0
            r, c = linear_sum_assignment(-score)
            keep = score[r, c] > EPS
            r, c = r[keep], c[keep]
            sim_rc = sim[r, c]
        mg, mp = g_ids[r], p_ids[c]
        last = prev_any[mg]
        idsw += int(np.count_nonzero((last >= 0) & (last != mp)))
        was_untracked = prev_t < 0
        prev_any[mg] = mp
        prev_t[:] = -1
        prev_t[mg] = mp
        frag += was_untracked & (prev_t >= 0)
        k = len(r)
        tp += k
        fn += n - k
        fp += m - k
        motp_sum += float(sim_rc.sum())
        matched_g.append(mg)
    res = _summary(tp, fp, fn, idsw, motp_sum, len(g), len(p))
    mg_all = np.concatenate(matched_g) if matched_g else np.zeros(0, np.int64)
    res["MT"], res["PT"], res["ML"] = _mt_pt_ml(gid, n_gid, mg_all)
    res["Frag"] = int(np.sum(frag[frag > 0] - 1))
    res["sMOTA"] = (motp_sum - fp - idsw) / max(1.0, tp + fn)
    return res


def _clear_vace(g, p, pt, gid, n_gid, pid, q):
    # q: the matched pairs (Hungarian on IoU above the threshold), in frame order
    mg = gid[pt.gi[q]]
    mp = pid[pt.pj[q]]
    mf = pt.pf[q]
    # identity switches: per ground-truth id, consecutive matches with a different prediction id
    order = np.lexsort((mf, mg))
    mg_o, mp_o, mf_o = mg[order], mp[order], mf[order]
    sw = np.zeros(len(order), bool)
    if len(order) > 1:
        sw[1:] = (mg_o[1:] == mg_o[:-1]) & (mp_o[1:] != mp_o[:-1])
    sw_per_frame = np.bincount(mf_o[sw], minlength=g.n_frames)
    log_terms = np.log10(np.maximum(sw_per_frame, 1))  # log10(0) taken as 0
    tp = len(q)
    n_gt, n_pred = len(g), len(p)
    fn, fp = n_gt - tp, n_pred - tp
    idsw = int(sw.sum())
    res = _summary(tp, fp, fn, idsw, float(pt.sim[q].sum()), n_gt, n_pred)
    denom = max(1.0, n_gt)
    res["MOTA"] = 1.0 - (fn + fp + float(log_terms.sum())) / denom
    res["MOTA_logtotal"] = 1.0 - (fn + fp + (float(np.log10(idsw)) if idsw > 0 else 0.0)) / denom
    res["idsw_per_frame"] = sw_per_frame
    res["MT"], res["PT"], res["ML"] = _mt_pt_ml(gid, n_gid, mg)
    # fragmentation: a ground-truth id matched again after at least one of its frames unmatched
    present_order = np.lexsort((g.fidx, gid))
    gid_o = gid[present_order]
    matched_flag = np.zeros(len(g), bool)
    matched_flag[pt.gi[q]] = True
    mf_flag = matched_flag[present_order]
    resume = np.zeros(len(g), bool)
    if len(g) > 1:
        same = gid_o[1:] == gid_o[:-1]
        resume[1:] = same & mf_flag[1:] & ~mf_flag[:-1]
    # a resumption only counts when the track had been matched before
    seen = np.zeros(len(g), bool)
    if len(g):
        first_of_id = np.r_[True, gid_o[1:] != gid_o[:-1]]
        grp = np.cumsum(first_of_id) - 1
        cum = np.cumsum(mf_flag)
        base = cum[np.flatnonzero(first_of_id)][grp] - mf_flag[np.flatnonzero(first_of_id)][grp]
        seen = (cum - mf_flag - base) > 0
    res["Frag"] = int(np.count_nonzero(resume & seen))
    return res
