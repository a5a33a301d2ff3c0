"""seawatch.eval: accuracy metrics, reports and the benchmark harness.

Public API
----------
Every metric takes ground truth and predictions as *per-frame* data, most simply a dict
``frame -> (ids, boxes)`` with ``ids`` ``(N,)`` and ``boxes`` ``(N, 4)`` as ``x, y, w, h`` pixels
(``frame -> boxes`` where ids do not matter; ``frame -> (boxes, scores)`` for scored detections;
``frame -> points`` ``(N, D)`` metres for OSPA/GOSPA; :class:`seawatch.types.Tracks` /
:class:`seawatch.types.Detections` per frame, or a :class:`seawatch.io.gt.Annotations`, work
too; see :mod:`seawatch.eval.frames`).  Frames missing from one input count as empty there; list
a frame with no objects (``{k: []}``) to have it scored.  Every function returns a plain dict whose
keys are the names used in the literature::

    from seawatch.eval import detection_metrics, clear_mot, hota, identity_metrics, mete, melt, ospa, gospa

    d = detection_metrics(gt_boxes_per_frame, pred_boxes_per_frame, iou=0.5)
    d["TPR"], d["FAR"], d["precision"], d["F1"], d["TP"], d["FP"], d["FN"], d["by_size"], d["AP"], d["pr_curve"]

    c = clear_mot(gt, pred, iou=0.5, variant="motchallenge")   # or variant="vace" (Kasturi et al.)
    c["MOTA"], c["MOTP"], c["IDSW"], c["Frag"], c["MT"], c["PT"], c["ML"], c["FP"], c["FN"]

    h = hota(gt, pred)                 # h["HOTA"], h["DetA"], h["AssA"], h["LocA"], h["per_alpha"]
    i = identity_metrics(gt, pred)     # i["IDF1"], i["IDP"], i["IDR"], i["IDTP"], i["IDFP"], i["IDFN"]
    e = mete(gt, pred)                 # e["METE"], e["per_frame"] (Nawaz et al. 2014)
    l = melt(gt, pred)                 # l["MELT"], l["MELT_tau"], l["tau"]
    o = ospa(gt_points, pred_points, cutoff_m=50.0, p=1)    # o["OSPA"], o["per_frame"]
    g = gospa(gt_points, pred_points, cutoff_m=50.0, p=1)   # g["GOSPA"], ["localisation"], ["missed"], ["false"]

    s = score_tracks(gt, pred)         # all the tracking metrics above in one flat dict

Definitions, conventions and deviations are in each module's docstring and in
``docs/evaluation.md``: :mod:`~seawatch.eval.detection`, :mod:`~seawatch.eval.clear`,
:mod:`~seawatch.eval.hota`, :mod:`~seawatch.eval.mete`, :mod:`~seawatch.eval.ospa`.
HOTA, IDF1 and the MOTChallenge CLEAR metrics follow TrackEval and agree with it to 1e-4 on the
fixtures in ``tests/fixtures/eval``; OSPA and GOSPA agree with Stone Soup to 1e-6.

Helpers: :func:`box_iou` (IoU matrix of ``x, y, w, h`` boxes), :func:`as_frameset`, and
:func:`prepare`: ``prep = prepare(gt, pred)`` flattens, pairs and matches once; pass ``prep`` as
``gt`` (and ``None`` as ``pred``) to several metrics to score them without repeating that work.
The benchmark harness (``seawatch bench``) is :mod:`seawatch.eval.bench`.
"""

from seawatch.eval.clear import clear_mot
from seawatch.eval.detection import SIZE_BINS_PX2, detection_metrics, pr_curve
from seawatch.eval.frames import FrameSet, as_frameset, box_iou
from seawatch.eval.hota import ALPHAS, hota, identity_metrics
from seawatch.eval.matching import Prepared, prepare
from seawatch.eval.mete import TAUS, melt, mete
from seawatch.eval.ospa import gospa, ospa

__all__ = [
    "detection_metrics", "pr_curve", "clear_mot", "hota", "identity_metrics", "mete", "melt",
    "ospa", "gospa", "score_tracks", "box_iou", "as_frameset", "FrameSet", "ALPHAS", "TAUS",
    "SIZE_BINS_PX2", "prepare", "Prepared",
]


def score_tracks(gt, pred, iou: float = 0.5, frames=None) -> dict:
    """All image-track metrics in one flat dict of floats.

    Keys: ``MOTA, MOTP, IDSW, Frag, FP, FN, MT, PT, ML`` (MOTChallenge), ``MOTA_VACE,
    MOTP_VACE`` (Kasturi), ``HOTA, DetA, AssA, LocA``, ``IDF1, IDP, IDR``, ``METE, MELT``.
    """
    prep = prepare(gt, pred, frames)  # flatten, pair and match once for every metric
    c = clear_mot(prep, None, iou=iou)
    v = clear_mot(prep, None, iou=iou, variant="vace")
    h = hota(prep, None)
    i = identity_metrics(prep, None, iou=iou)
    out = {k: c[k] for k in ("MOTA", "MOTP", "IDSW", "Frag", "FP", "FN", "TP", "MT", "PT", "ML",
                             "precision", "recall")}
    out["MOTA_VACE"] = v["MOTA"]
    out["MOTP_VACE"] = v["MOTP"]
    out.update({k: h[k] for k in ("HOTA", "DetA", "AssA", "LocA")})
    out.update({k: i[k] for k in ("IDF1", "IDP", "IDR")})
    out["METE"] = mete(prep, None)["METE"]
    out["MELT"] = melt(prep, None)["MELT"]
    return out
