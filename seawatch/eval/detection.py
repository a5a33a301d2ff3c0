"""Detection metrics: one-to-one matching on IoU, TPR / FAR / precision / F1, sizes, PR curve.

Per frame, ground-truth boxes and detections are matched one-to-one by the Hungarian algorithm,
maximising the summed IoU over pairs whose IoU is at least the threshold (0.5 by default; 0.3
suits small, far targets whose boxes are a few pixels wide).  Matched detections are true
positives, unmatched detections false positives, unmatched ground truth false negatives.

* ``TPR = TP / (TP + FN)`` (recall, detection rate);
* ``FAR = FP / (TP + FP)``, the false alarm rate as defined by Bloisi et al. (the complement of
  precision, not false positives per frame; ``FP_per_frame`` is given too);
* ``precision = TP / (TP + FP)``, ``F1 = 2 TP / (2 TP + FP + FN)``.

Empty denominators give 0 (e.g. TPR = 0 when there is no ground truth).

Precision-recall curve
----------------------
Over the detections' scores, as in PASCAL VOC / COCO: detections are taken in decreasing score
order and each is matched greedily to the unmatched ground-truth box of its frame with the largest
IoU above the threshold.  ``AP`` is the area under the precision envelope (all-point
interpolation, VOC 2010 onwards).  The operating point figures above use the Hungarian matching
of all detections, so at the lowest score the curve's last point can differ slightly from them
when greedy and optimal matchings disagree.
"""

from __future__ import annotations

import numba
import numpy as np

from seawatch.eval.matching import EPS, prepare

__all__ = ["detection_metrics", "pr_curve", "SIZE_BINS_PX2"]

#: Box-area classes in square pixels (COCO's small / medium / large).
SIZE_BINS_PX2 = {"small": (0.0, 32.0 ** 2), "medium": (32.0 ** 2, 96.0 ** 2), "large": (96.0 ** 2, np.inf)}


def _ratio(a: float, b: float) -> float:
    return float(a) / float(b) if b > 0 else 0.0


def detection_metrics(gt, pred, iou: float = 0.5, frames=None, size_bins_px2: dict | None = None,
                      pr: bool = True) -> dict:
    """Score detections against ground-truth boxes.

    Parameters
    ----------
    gt : per-frame data
        ``frame -> boxes`` (``(N, 4)`` ``x, y, w, h``) or ``frame -> (ids, boxes)``; ids are ignored.
    pred : per-frame data
        ``frame -> boxes``, ``frame -> (boxes, scores)``, ``frame -> (ids, boxes, scores)`` or
        :class:`seawatch.types.Detections` per frame.  Scores (default 1) drive the PR curve.
    iou : float
        Minimum IoU of a match.
    frames : array-like, optional
        Frames to score (default: every frame key of either input; list frames without objects
        explicitly, e.g. ``{k: []}``, so that their false positives or misses count).
    size_bins_px2 : dict, optional
        ``name -> (min_area, max_area)`` classes (default :data:`SIZE_BINS_PX2`).  Ground truth is
        classed by its own area (TP, FN, TPR), detections by theirs (FP, precision).
    pr : bool
        Compute the precision-recall curve and AP.

    Returns
    -------
    dict
        ``TP, FP, FN, TPR, recall, FAR, precision, F1, FP_per_frame, mean_IoU, n_gt, n_pred,
        n_frames, iou, by_size`` and, with ``pr``, ``AP`` and ``pr_curve`` (``score, precision,
        recall`` arrays).
    """
    if not 0.0 < iou <= 1.0:
        raise ValueError(f"detection_metrics: iou must be in (0, 1], got {iou}")
    prep = prepare(gt, pred, frames)
    g, p, pt = prep.g, prep.p, prep.pt
    q = prep.thresholded(iou)
    tp = len(q)
    n_gt, n_pred = len(g), len(p)
    fn, fp = n_gt - tp, n_pred - tp
    res = {
        "TP": int(tp), "FP": int(fp), "FN": int(fn),
        "TPR": _ratio(tp, n_gt),
        "recall": _ratio(tp, n_gt),
        "precision": _ratio(tp, n_pred),
        "FAR": _ratio(fp, n_pred),
        "F1": _ratio(2 * tp, 2 * tp + fp + fn),
        "FP_per_frame": _ratio(fp, g.n_frames),
        "mean_IoU": float(pt.sim[q].mean()) if tp else 0.0,
        "n_gt": int(n_gt), "n_pred": int(n_pred), "n_frames": int(g.n_frames), "iou": float(iou),
    }
    g_hit = np.zeros(n_gt, bool)
    g_hit[pt.gi[q]] = True
    p_hit = np.zeros(n_pred, bool)
    p_hit[pt.pj[q]] = True
    g_area = g.boxes[:, 2] * g.boxes[:, 3] if n_gt else np.zeros(0)
    p_area = p.boxes[:, 2] * p.boxes[:, 3] if n_pred else np.zeros(0)
    by_size = {}
    for name, (lo, hi) in (size_bins_px2 or SIZE_BINS_PX2).items():
        gm = (g_area >= lo) & (g_area < hi)
        pm = (p_area >= lo) & (p_area < hi)
        tpg, tpp = int(np.count_nonzero(g_hit & gm)), int(np.count_nonzero(p_hit & pm))
        ngb, npb = int(gm.sum()), int(pm.sum())
        by_size[name] = {
            "area_px2": [float(lo), float(hi)],
            "n_gt": ngb, "TP": tpg, "FN": ngb - tpg, "TPR": _ratio(tpg, ngb),
            "n_pred": npb, "FP": npb - tpp, "precision": _ratio(tpp, npb),
        }
    res["by_size"] = by_size
    if pr:
        curve = _pr_from_pairs(pt, g, p, iou)
        res["AP"] = curve.pop("AP")
        res["pr_curve"] = curve
    return res


@numba.njit(cache=True)
def _greedy_match(pair_start, lr, lc, ng, npd, p_starts, sim, scores, thr):
    """VOC-style greedy matching in decreasing score order, frame by frame."""
    is_tp = np.zeros(scores.shape[0], np.bool_)
    for f in range(ng.shape[0]):
        s = pair_start[f]
        e = pair_start[f + 1]
        if s == e:
            continue
        n = ng[f]
        m = npd[f]
        mat = np.zeros((n, m))
        for k in range(s, e):
            mat[lr[k], lc[k]] = sim[k]
        p0 = p_starts[f]
        order = np.argsort(-scores[p0:p0 + m], kind="mergesort")
        taken = np.zeros(n, np.bool_)
        for jj in range(m):
            j = order[jj]
            best = -1
            best_iou = -1.0
            for i in range(n):
                if not taken[i]:
                    v = mat[i, j]
                    if v >= thr and v > best_iou:
                        best = i
                        best_iou = v
            if best >= 0:
                taken[best] = True
                is_tp[p0 + j] = True
    return is_tp


def _pr_from_pairs(pt, g, p, iou: float) -> dict:
    n_gt = len(g)
    if len(p) == 0:
        return {"score": np.zeros(0), "precision": np.zeros(0), "recall": np.zeros(0), "AP": 0.0}
    is_tp = _greedy_match(pt.start, pt.lr, pt.lc, pt.ng, pt.np_, p.starts, pt.sim, p.scores, float(iou) - EPS)
    order = np.argsort(-p.scores, kind="stable")
    tp_c = np.cumsum(is_tp[order])
    fp_c = np.cumsum(~is_tp[order])
    sc = p.scores[order]
    # one point per distinct score (the last detection of each score level)
    last = np.r_[sc[1:] != sc[:-1], True]
    tp_c, fp_c, sc = tp_c[last], fp_c[last], sc[last]
    precision = tp_c / np.maximum(tp_c + fp_c, 1)
    recall = tp_c / n_gt if n_gt else np.zeros(len(tp_c))
    # all-point interpolated AP
    env = np.maximum.accumulate(precision[::-1])[::-1]
    r_prev = np.r_[0.0, recall[:-1]]
    ap = float(np.sum((recall - r_prev) * env)) if n_gt else 0.0
    return {"score": sc, "precision": precision, "recall": recall, "AP": ap}


def pr_curve(gt, pred, iou: float = 0.5, frames=None) -> dict:
    """Precision-recall curve over detection scores (``score, precision, recall, AP``)."""
    prep = prepare(gt, pred, frames)
    return _pr_from_pairs(prep.pt, prep.g, prep.p, iou)
