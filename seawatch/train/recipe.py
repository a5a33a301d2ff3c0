"""The recipe of seawatch's shipped boat cascade: data, split, training, detector settings.

``seawatch train-cascade --data ../shared/data`` runs :func:`train_default_model`: it loads the
MarDCT training frames, CORAL D1 and (when installed) simulator frames, splits them
(:func:`~seawatch.train.samples.split_images`), trains on the training part, picks the detector's
``min_neighbors`` on the validation part (never on the held-out part, never on MarDCT video2) and
writes the XML, a JSON beside it (box convention, settings, training record, split) and the
figures on the validation and held-out parts.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.train.samples import (
    LabelledImage, iou_matrix, load_coral, load_mardct_frames, load_sim, split_images,
)
from seawatch.train.trainer import TrainSettings, train_cascade

__all__ = ["load_training_data", "match_counts", "evaluate_images", "tune_min_neighbors", "train_default_model"]


def load_training_data(data_dir: str | Path, use_sim: bool = True, sim_frames: int = 20, seed: int = 0
                       ) -> dict[str, list[LabelledImage]]:
    """Training, validation and held-out images from ``data_dir`` (``../shared/data`` layout)."""
    d = Path(data_dir)
    images = load_mardct_frames(d / "mardct" / "train" / "frames")
    if (d / "coral_d1" / "labels.csv").is_file():
        images += load_coral(d / "coral_d1")
    parts = split_images(images)
    if use_sim:
        sim = load_sim(frames_per_scenario=sim_frames, seed=seed)
        parts["train"] += sim
    return parts


def match_counts(pred: np.ndarray, truth: np.ndarray, iou_min: float) -> tuple[int, int, int]:
    """(TP, FP, FN) of one frame under one-to-one Hungarian matching with IoU >= ``iou_min``."""
    pred = np.asarray(pred, np.float64).reshape(-1, 4)
    truth = np.asarray(truth, np.float64).reshape(-1, 4)
    if len(pred) == 0 or len(truth) == 0:
        return 0, len(pred), len(truth)
    iou = iou_matrix(pred, truth)
    r, c = linear_sum_assignment(-iou)
    tp = int((iou[r, c] >= iou_min).sum())
    return tp, len(pred) - tp, len(truth) - tp


def scores_from_counts(tp: int, fp: int, fn: int) -> dict:
    """TPR, FAR (= FP / (TP + FP), as in paper A), precision and F1."""
    tpr = tp / (tp + fn) if tp + fn else 0.0
    far = fp / (tp + fp) if tp + fp else 0.0
    prec = 1.0 - far if tp + fp else 0.0
    f1 = 2 * tp / (2 * tp + fp + fn) if tp + fp + fn else 0.0
    return {"TP": tp, "FP": fp, "FN": fn, "TPR": tpr, "FAR": far, "precision": prec, "F1": f1}


def evaluate_images(detector, images: list[LabelledImage], ious=(0.3, 0.5), min_box_w_px: float = 0.0) -> dict:
    """Detection figures of a detector on single labelled images (horizon state reset per image).

    Ground-truth boxes narrower than ``min_box_w_px`` are ignored (neither hit nor missed;
    detections matching them are not false alarms).
    """
    counts = {iou: [0, 0, 0] for iou in ious}
    for im in images:
        detector.reset()
        boxes, _ = detector.detect_grey(_raw_grey(im), 0.0, ir=im.ir)
        truth = im.boxes
        small = truth[:, 2] < min_box_w_px if len(truth) else np.zeros(0, bool)
        ign = np.concatenate([truth[small], im.ignore.reshape(-1, 4)])
        truth = truth[~small]
        for iou in ious:
            tp, fp, fn = match_counts(boxes, truth, iou)
            if fp and len(ign):
                # unmatched detections on ignored boxes are not false alarms
                un = _unmatched(boxes, truth, iou)
                fp -= int((iou_matrix(boxes[un], ign).max(axis=1) >= iou).sum()) if len(un) else 0
            c = counts[iou]
            c[0] += tp
            c[1] += fp
            c[2] += fn
    return {iou: scores_from_counts(*c) for iou, c in counts.items()}


def _unmatched(pred, truth, iou_min):
    if len(truth) == 0:
        return np.arange(len(pred))
    iou = iou_matrix(pred, truth)
    r, c = linear_sum_assignment(-iou)
    matched = set(int(i) for i, j in zip(r, c) if iou[i, j] >= iou_min)
    return np.array([i for i in range(len(pred)) if i not in matched], int)


def _raw_grey(im: LabelledImage) -> np.ndarray:
    import cv2

    from seawatch.detect.filters import to_grey
    if im.image is not None:
        return to_grey(im.image, im.name)
    img = cv2.imread(str(im.path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise ValueError(f"cannot read image {im.path}")
    return to_grey(img, str(im.path))


def tune_min_neighbors(model_path: str | Path, images: list[LabelledImage], candidates=(1, 2, 3, 4, 5, 6, 8),
                       iou: float = 0.3, log=print, **detector_kw) -> tuple[int, dict]:
    """The ``min_neighbors`` of best F1 at ``iou`` on validation images, and all figures."""
    from seawatch.detect.cascade import CascadeDetector

    table = {}
    for mn in candidates:
        det = CascadeDetector(model_path, min_neighbors=int(mn), **detector_kw)
        res = evaluate_images(det, images, ious=(0.3, 0.5))
        table[int(mn)] = res
        log(f"  min_neighbors {mn}: F1@0.3 {res[0.3]['F1']:.3f} (TPR {res[0.3]['TPR']:.3f}, FAR {res[0.3]['FAR']:.3f}),"
            f" F1@0.5 {res[0.5]['F1']:.3f}")
    best = max(table, key=lambda k: (table[k][iou]["F1"], -k))
    return best, table


def train_default_model(data_dir: str | Path, out_xml: str | Path, settings: TrainSettings | None = None,
                        use_sim: bool = True, command: str = "", log=print) -> dict:
    """Train, tune and describe the default boat cascade (see the module docstring)."""
    s = settings or TrainSettings()
    t0 = time.perf_counter()
    parts = load_training_data(data_dir, use_sim=use_sim, seed=s.seed)
    for k, v in parts.items():
        srcs = {}
        for im in v:
            srcs[im.source] = srcs.get(im.source, 0) + 1
        log(f"  {k}: {len(v)} images {srcs}")
    cascade, record = train_cascade(parts["train"], out_xml, s, log=log)
    val_mardct = [im for im in parts["val"] if im.source == "mardct"]
    best, table = tune_min_neighbors(out_xml, val_mardct, log=log)
    log(f"  chosen min_neighbors {best} (validation part, MarDCT)")
    from seawatch.detect.cascade import CascadeDetector

    det = CascadeDetector(out_xml, min_neighbors=best)
    held = {}
    for src in ("mardct",):
        ims = [im for im in parts["heldout"] if im.source == src]
        if ims:
            held[src] = evaluate_images(det, ims)
            log(f"  held-out {src} ({len(ims)} images): F1@0.3 {held[src][0.3]['F1']:.3f} "
                f"F1@0.5 {held[src][0.5]['F1']:.3f} FAR@0.3 {held[src][0.3]['FAR']:.3f}")
    record["detector"] = {"min_neighbors": int(best)}
    record["validation"] = {str(k): {str(i): v for i, v in r.items()} for k, r in table.items()}
    record["heldout"] = {k: {str(i): v for i, v in r.items()} for k, r in held.items()}
    record["split"] = {k: sorted(im.name for im in v) for k, v in parts.items()}
    record["command"] = command
    record["total_time_s"] = round(time.perf_counter() - t0, 1)
    Path(out_xml).with_suffix(".json").write_text(json.dumps(record, indent=1, default=float) + "\n",
                                                  encoding="utf-8")
    return record
