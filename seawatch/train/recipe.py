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

__all__ = ["load_training_data", "match_counts", "evaluate_images", "tune_min_neighbors", "train_default_model",
           "select_detector_settings", "choose_detector_settings", "reselect_model", "SELECT_ON"]


def load_training_data(data_dir: str | Path, use_sim: bool = True, sim_frames: int = 20, seed: int = 0
                       ) -> dict[str, list[LabelledImage]]:
    """Training, validation and held-out images from ``data_dir`` (``../shared/data`` layout)."""
    d = Path(data_dir)
    images = load_mardct_frames(d / "mardct" / "train" / "frames")
    if (d / "coral_d1" / "labels.csv").is_file():
        images += load_coral(d / "coral_d1")
    parts = split_images(images)
    if use_sim:
        parts["train"] += load_sim(frames_per_scenario=sim_frames, seed=seed)
        parts["val"] += load_sim(frames_per_scenario=max(2, sim_frames // 4), seed=seed + 100)
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


def calibrate_boxes(model_path: str | Path, images: list[LabelledImage], min_iou: float = 0.3,
                    log=print) -> dict:
    """Learn the window -> box mapping (the annotation's box convention) from training images.

    The cascade's grouped windows that match an annotated box (IoU >= ``min_iou`` after the
    trainer's nominal mapping, or containing it) give the median offsets of the box centre and
    the median box/window width and height ratios.  Returns ``box_ratio_w, box_ratio_h,
    box_dx_frac, box_dy_frac`` and the number of matches.
    """
    from seawatch.detect.cascade import CascadeDetector

    det = CascadeDetector(model_path, min_neighbors=3, canny_prune=False, horizon_filter=False,
                          reflection_filter=False, suppress_nested=False)
    rel = []
    for im in images:
        if len(im.boxes) == 0:
            continue
        g = det_prepare(im, det)
        wins, _ = det.raw_windows(g)
        if len(wins) == 0:
            continue
        iou = iou_matrix(det.windows_to_boxes(wins), im.boxes)
        r, c = linear_sum_assignment(-iou)
        for i, j in zip(r, c):
            if iou[i, j] >= min_iou:
                wk, gb = wins[i], im.boxes[j]
                rel.append(((gb[0] + gb[2] / 2 - wk[0] - wk[2] / 2) / wk[2],
                            (gb[1] + gb[3] / 2 - wk[1] - wk[3] / 2) / wk[3], gb[2] / wk[2], gb[3] / wk[3]))
    if len(rel) < 10:
        log(f"  box calibration: only {len(rel)} matches, keeping the nominal convention")
        return {"box_calibration_matches": len(rel)}
    rel = np.asarray(rel)
    med = np.median(rel, axis=0)
    out = {"box_dx_frac": float(med[0]), "box_dy_frac": float(med[1]), "box_ratio_w": float(med[2]),
           "box_ratio_h": float(med[3]), "box_calibration_matches": int(len(rel))}
    log(f"  box calibration on {len(rel)} matched windows: w x{med[2]:.3f}, h x{med[3]:.3f}, "
        f"dx {med[0]:+.3f}, dy {med[1]:+.3f} of the window")
    return out


def det_prepare(im: LabelledImage, det) -> np.ndarray:
    """The grey image a detector's cascade sees for a labelled image."""
    from seawatch.detect.filters import prepare_grey
    return prepare_grey(_raw_grey(im), ir=im.ir, median_px=det.params.median_px)


def _update_json(xml: str | Path, fields: dict) -> None:
    p = Path(xml).with_suffix(".json")
    data = json.loads(p.read_text(encoding="utf-8")) if p.is_file() else {}
    data.update(fields)
    p.write_text(json.dumps(data, indent=1, default=float) + "\n", encoding="utf-8")


def tune_min_neighbors(model_path: str | Path, images: list[LabelledImage],
                       candidates=(1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128),
                       iou: float = 0.3, log=print, size_exps=(0.0,), **detector_kw) -> tuple[int, dict]:
    """The ``min_neighbors`` of best F1 at ``iou`` on validation images, and all figures.

    One cascade pass per image (``min_neighbors=1``), re-thresholded for every candidate.
    """
    from seawatch.detect.cascade import CascadeDetector

    det = CascadeDetector(model_path, min_neighbors=1, neighbors_size_exp=0.0, **detector_kw)
    raw = []
    for im in images:
        g = det_prepare(im, det)
        raw.append((g, _raw_grey(im)) + det.raw_windows(g))
    truth = []
    for im, (g, _, _, _) in zip(images, raw):
        small = im.boxes[:, 2] < 0.8 * det.min_boat_px(g.shape[1]) if len(im.boxes) else np.zeros(0, bool)
        truth.append((im.boxes[~small], np.concatenate([im.ignore.reshape(-1, 4), im.boxes[small]])))
    table = {}
    for mn, ex in [(m, e) for e in size_exps for m in candidates]:
        det.params.neighbors_size_exp = float(ex)
        counts = {i: [0, 0, 0] for i in (0.3, 0.5)}
        for im, (g, graw, wins, cnt), (gt, ign) in zip(images, raw, truth):
            det.reset()
            boxes, _ = det.postprocess(g, graw, wins, cnt, 0.0, im.ir, min_neighbors=int(mn))
            for i in counts:
                tp, fp, fn = match_counts(boxes, gt, i)
                if fp and len(ign):
                    un = _unmatched(boxes, gt, i)
                    fp -= int((iou_matrix(boxes[un], ign).max(axis=1) >= i).sum()) if len(un) else 0
                c = counts[i]
                c[0] += tp
                c[1] += fp
                c[2] += fn
        res = {i: scores_from_counts(*c) for i, c in counts.items()}
        key = int(mn) if len(size_exps) == 1 else (int(mn), float(ex))
        table[key] = res
        log(f"  min_neighbors {mn} size exponent {ex:g}: F1@0.3 {res[0.3]['F1']:.3f} (TPR {res[0.3]['TPR']:.3f}, FAR {res[0.3]['FAR']:.3f}),"
            f" F1@0.5 {res[0.5]['F1']:.3f}")
    best = max(table, key=lambda k: (table[k][iou]["F1"], -np.sum(k)))
    return best, table


def train_default_model(data_dir: str | Path, out_xml: str | Path, settings: TrainSettings | None = None,
                        use_sim: bool = True, command: str = "", log=print,
                        scale_factors: tuple[float, ...] = (1.1, 1.2, 1.3), select_on: str = "mardct",
                        grid_modes: tuple[int, ...] = (0,)) -> dict:
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
    if cascade.n_stages == 0:
        raise ValueError(f"training stopped before the first stage ({record.get('stop_reason')}); "
                         "allow more stumps per stage (--early-weak-counts, --max-weak-count)")
    # the annotation's box convention, learned from the real training frames
    calib = calibrate_boxes(out_xml, [im for im in parts["train"] if im.source == "mardct"], log=log)
    _update_json(out_xml, calib)
    record.update(calib)
    record.update(choose_detector_settings(out_xml, parts, log=log, scale_factors=scale_factors,
                                           select_on=select_on, grid_modes=grid_modes))
    record["split"] = {k: sorted(im.name for im in v) for k, v in parts.items()}
    record["command"] = command
    record["total_time_s"] = round(time.perf_counter() - t0, 1)
    Path(out_xml).with_suffix(".json").write_text(json.dumps(record, indent=1, default=float) + "\n",
                                                  encoding="utf-8")
    return record


SELECT_ON = {
    # session 11's rule (fixed before it was run): the deployment is a moving, zooming port camera
    "mardct": ("mardct",),
    # session 10's rule: every validation source
    "all": ("mardct", "sim", "coral"),
}


def choose_detector_settings(model_xml: str | Path, parts: dict[str, list[LabelledImage]], log=print,
                             scale_factors: tuple[float, ...] = (1.1, 1.2, 1.3), select_on: str = "mardct",
                             report_others: bool = True, grid_modes: tuple[int, ...] = (0,)) -> dict:
    """Choose the detector settings on the validation part, store them beside the model and
    report the held-out part with them (the model's JSON gains ``detector``, ``validation``
    and ``heldout``).

    The criterion is :func:`select_detector_settings`'s (MarDCT and simulator frames each
    scanned with the smallest boat at 0.5, 1, 2 and 3 times the automatic value, CORAL images
    with the smallest boat at 20 px; mean over IoU 0.3 and 0.5 of the F1 averaged over
    boat-size bins), computed on the validation images of the sources ``SELECT_ON[select_on]``:
    ``"mardct"`` (the default since session 11: the 14 MarDCT validation frames only) or
    ``"all"`` (session 10: MarDCT, simulator and CORAL).  With ``report_others`` the chosen
    settings are also scored, not chosen, on the other validation sources
    (``validation_others``).  Never the held-out part, never MarDCT video2.

    ``grid_modes``: the detector's grids of window positions tried (0: OpenCV's; 2: a 2 px grid
    at every scale; session 13's rule): the best settings of each are found, the grid with the
    higher score is chosen, and a tie within 0.005 goes to the 2 px grid (fewer windows).
    """
    if select_on not in SELECT_ON:
        raise ValueError(f"select_on {select_on!r}: expected one of {sorted(SELECT_ON)}")
    srcs = SELECT_ON[select_on]
    val = [im for im in parts["val"] if im.source in srcs]
    if not val:
        raise ValueError(f"select_on {select_on!r}: no validation images of {srcs}")
    per_grid = {}
    for grid in grid_modes:
        if len(grid_modes) > 1:
            log(f"  grid of window positions: {grid} ({'OpenCV' if grid == 0 else f'{grid} px at every scale'})")
        per_grid[int(grid)] = select_detector_settings(model_xml, val, scale_factors=scale_factors,
                                                       fixed_min_size_px={"coral": 20.0}, log=log,
                                                       grid_step_px=int(grid))
    score = {g: 0.5 * (b["macro_F1@0.3"] + b["macro_F1@0.5"]) for g, (b, _) in per_grid.items()}
    top = max(score.values())
    chosen = max(g for g in per_grid if score[g] >= top - 0.005) if len(per_grid) > 1 else next(iter(per_grid))
    best, table = per_grid[chosen]
    settings = {k: best[k] for k in ("min_neighbors", "scale_factor", "neighbors_size_exp")}
    if len(grid_modes) > 1 or chosen != 0:
        settings["grid_step_px"] = int(chosen)
        log(f"  grid chosen: {chosen} (scores {', '.join(f'{g}: {v:.4f}' for g, v in score.items())})")
    from seawatch.detect.cascade import load_model_meta

    old_block = load_model_meta(model_xml).get("detector") or {}
    if chosen == 2 and "grid_step_x_px" in old_block:
        settings["grid_step_x_px"] = int(old_block["grid_step_x_px"])  # the 2 px grid's x step, chosen on
    _update_json(model_xml, {"detector": settings})
    grid_kw = {"grid_step_px": int(chosen)}
    others = {}
    if report_others:
        for src in ("mardct", "sim", "coral"):
            ims = [im for im in parts["val"] if im.source == src]
            if src in srcs or not ims:
                continue
            o, _ = select_detector_settings(model_xml, ims, scale_factors=(settings["scale_factor"],),
                                            candidates=(settings["min_neighbors"],),
                                            size_exps=(settings["neighbors_size_exp"],),
                                            fixed_min_size_px={"coral": 20.0}, log=lambda *a: None,
                                            **grid_kw)
            others[src] = {"images": len(ims), "score": 0.5 * (o["macro_F1@0.3"] + o["macro_F1@0.5"]),
                           **{k: o[k] for k in ("macro_F1@0.3", "macro_F1@0.5", "boats_by_bin")}}
            log(f"  reported, not chosen on: validation {src} ({len(ims)} images) score {others[src]['score']:.3f}")
    from seawatch.detect.cascade import CascadeDetector

    held = {}
    for src, kw in (("mardct", {}), ("coral", {"min_size_px": 20.0})):
        ims = [im for im in parts["heldout"] if im.source == src]
        if ims:
            det = CascadeDetector(model_xml, **kw, **grid_kw)
            held[src] = evaluate_images(det, ims, min_box_w_px=kw.get("min_size_px", 0.0))
            log(f"  held-out {src} ({len(ims)} images): F1@0.3 {held[src][0.3]['F1']:.3f} "
                f"F1@0.5 {held[src][0.5]['F1']:.3f} FAR@0.3 {held[src][0.3]['FAR']:.3f}")
    return {
        "detector": settings,
        "selection": {"criterion": "mean over IoU 0.3 and 0.5 of the F1 averaged over boat-size bins "
                                   "(box width / smallest boat: " + ", ".join(f"{e:g}" for e in SIZE_BINS) + ")",
                      "select_on": select_on,
                      "validation_images": {src: sum(im.source == src for im in val) for src in ("mardct", "sim", "coral")},
                      "best": best},
        "validation": table,
        **({"validation_by_grid": {str(g): {"best": b, "score": score[g]} for g, (b, _) in per_grid.items()},
            **{f"validation_grid{g}": t for g, (_, t) in per_grid.items() if g != chosen}}
           if len(per_grid) > 1 else {}),
        "validation_others": others,
        "heldout": {k: {str(i): v for i, v in r.items()} for k, r in held.items()},
    }


def reselect_model(model_xml: str | Path, data_dir: str | Path, use_sim: bool = True, seed: int = 0,
                   command: str = "", log=print, select_on: str = "mardct", grid_modes: tuple[int, ...] = (0,)) -> dict:
    """Choose a trained model's detector settings again (:func:`choose_detector_settings`) on the
    split :func:`load_training_data` makes, without retraining; updates the JSON beside it."""
    t0 = time.perf_counter()
    parts = load_training_data(data_dir, use_sim=use_sim, seed=seed)
    upd = choose_detector_settings(model_xml, parts, log=log, select_on=select_on, grid_modes=grid_modes)
    upd["selection"]["command"] = command
    upd["selection"]["time_s"] = round(time.perf_counter() - t0, 1)
    _update_json(model_xml, upd)
    return upd


# ---------------------------------------------------------------- detector settings over boat sizes
SIZE_BINS = (0.8, 1.5, 2.5, 4.0, np.inf)  # box width / the detector's smallest boat


def _auto_min_boat_px(width_px: int) -> float:
    return max(12.0, width_px / 16.0)


def select_detector_settings(
    model_path: str | Path,
    images: list[LabelledImage],
    scale_factors: tuple[float, ...] = (1.1, 1.2, 1.3),
    min_size_mults: tuple[float, ...] = (0.5, 1.0, 2.0, 3.0),
    fixed_min_size_px: dict | None = None,
    candidates: tuple[int, ...] = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256),
    size_exps: tuple[float, ...] = (0.0, 0.5, 1.0, 1.5, 2.0),
    size_bins: tuple[float, ...] = SIZE_BINS,
    log=print,
    grid_step_px: int = -1,
) -> tuple[dict, dict]:
    """Detector settings (scale factor, ``min_neighbors``, size exponent) of best F1 over boat sizes.

    A boat's size matters to the cascade only relative to the smallest boat the detector looks
    for (the window at the detection scale): a small boat gathers few neighbours.  So every
    validation image is scanned with the smallest boat at ``min_size_mults`` times the
    automatic value (``max(12, width / 16)``): at 2 and 3 the image is seen as a camera with a
    wider view would see it, its boats small and blurred by the upscaling, at 0.5 as a closer
    one.  Images whose source is a key of ``fixed_min_size_px`` are scanned once with that
    smallest boat instead (CORAL: far boats in 1920 px images).  Boxes narrower than 0.8
    smallest boats are ignored.  True positives and misses count in the size bin of their
    annotated box, false alarms in that of the detected box (``size_bins``, in smallest
    boats); the score is the mean over IoU 0.3 and 0.5 of the F1 averaged over the bins that
    hold boats (macro F1), so that small and large boats weigh the same whatever their
    number.

    Returns ``(best settings, table)``: ``best`` has ``scale_factor``, ``min_neighbors``,
    ``neighbors_size_exp`` and the scores; ``table`` every candidate's per-bin counts.
    ``grid_step_px``: the detector's grid of window positions (-1: the model's; see
    :class:`~seawatch.detect.cascade.CascadeParams`).
    """
    from seawatch.detect.cascade import CascadeDetector

    fixed = fixed_min_size_px or {}
    edges = np.asarray(size_bins, np.float64)
    nb = len(edges) - 1
    table = {}
    best, best_score = None, -1.0
    for sf in scale_factors:
        det = CascadeDetector(model_path, min_neighbors=1, neighbors_size_exp=0.0, scale_factor=sf,
                              grid_step_px=grid_step_px)
        runs = []  # (image, min size, prepared grey, raw grey, windows, counts, truth, ignore)
        t0 = time.perf_counter()
        for im in images:
            graw = _raw_grey(im)
            g = det_prepare(im, det)
            w = g.shape[1]
            sizes = ([float(fixed[im.source])] if im.source in fixed
                     else [_auto_min_boat_px(w) * m for m in min_size_mults])
            for ms in sizes:
                det.params.min_size_px = ms
                mb = det.min_boat_px(w)
                small = im.boxes[:, 2] < 0.8 * mb if len(im.boxes) else np.zeros(0, bool)
                wins, cnt = det.raw_windows(g)
                det.reset()
                if det.params.horizon_filter:
                    det._update_horizon(graw, 0.0, im.ir)
                runs.append((im, ms, mb, g, graw, wins, cnt, im.boxes[~small],
                             np.concatenate([im.ignore.reshape(-1, 4), im.boxes[small]]), det.horizon))
        log(f"  scale factor {sf:g}: {len(runs)} scans of {len(images)} images in {time.perf_counter() - t0:.0f} s")
        for ex in size_exps:
            det.params.neighbors_size_exp = float(ex)
            for mn in candidates:
                c = np.zeros((2, nb, 3), np.int64)  # IoU, bin, (TP, FP, FN)
                for im, ms, mb, g, graw, wins, cnt, gt, ign, hz in runs:
                    det.params.min_size_px = ms
                    det.horizon = hz  # the image's horizon line, found once
                    boxes, _ = det.postprocess(g, graw, wins, cnt, 0.0, im.ir, min_neighbors=int(mn),
                                               update_horizon=False)
                    bin_gt = np.clip(np.searchsorted(edges, gt[:, 2] / mb, side="right") - 1, 0, nb - 1)
                    bin_det = np.clip(np.searchsorted(edges, boxes[:, 2] / mb, side="right") - 1, 0, nb - 1)
                    for k, iou_min in enumerate((0.3, 0.5)):
                        matched_gt, matched_det = _matches(boxes, gt, iou_min)
                        fp = np.ones(len(boxes), bool)
                        fp[matched_det] = False
                        if fp.any() and len(ign):
                            fp &= ~(iou_matrix(boxes, ign).max(axis=1) >= iou_min)
                        hit = np.zeros(len(gt), bool)
                        hit[matched_gt] = True
                        np.add.at(c[k, :, 0], bin_gt[hit], 1)
                        np.add.at(c[k, :, 2], bin_gt[~hit], 1)
                        np.add.at(c[k, :, 1], bin_det[fp], 1)
                f1 = 2 * c[:, :, 0] / np.maximum(2 * c[:, :, 0] + c[:, :, 1] + c[:, :, 2], 1)
                has = (c[0, :, 0] + c[0, :, 2]) > 0
                macro = f1[:, has].mean(axis=1)
                score = float(macro.mean())
                key = f"sf{sf:g}_mn{mn}_exp{ex:g}"
                table[key] = {"counts": c.tolist(), "macro_F1@0.3": float(macro[0]), "macro_F1@0.5": float(macro[1]),
                              "score": score}
                if score > best_score + 1e-12:
                    best_score = score
                    best = {"scale_factor": float(sf), "min_neighbors": int(mn), "neighbors_size_exp": float(ex),
                            "macro_F1@0.3": float(macro[0]), "macro_F1@0.5": float(macro[1]),
                            "F1_by_bin@0.3": f1[0].tolist(), "F1_by_bin@0.5": f1[1].tolist(),
                            "boats_by_bin": (c[0, :, 0] + c[0, :, 2]).tolist()}
            log(f"    size exponent {ex:g}: best so far {best['scale_factor']:g}/{best['min_neighbors']}/"
                f"{best['neighbors_size_exp']:g} score {best_score:.3f}")
    log(f"  chosen: scale factor {best['scale_factor']:g}, min_neighbors {best['min_neighbors']}, "
        f"size exponent {best['neighbors_size_exp']:g}; macro F1 {best['macro_F1@0.3']:.3f} (IoU 0.3), "
        f"{best['macro_F1@0.5']:.3f} (IoU 0.5); F1 by size bin {np.round(best['F1_by_bin@0.3'], 3).tolist()} "
        f"boats {best['boats_by_bin']}")
    return best, table


def _matches(pred: np.ndarray, truth: np.ndarray, iou_min: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices (truth, pred) of the one-to-one Hungarian matches with IoU >= ``iou_min``."""
    if len(pred) == 0 or len(truth) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    iou = iou_matrix(pred, truth)
    r, c = linear_sum_assignment(-iou)
    ok = iou[r, c] >= iou_min
    return c[ok], r[ok]
