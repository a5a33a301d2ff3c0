"""Robust Kalman background model (paper C) beside OpenCV MOG2 and KNN: F1 and frames/s.

* F1 (precision, recall) of the foreground blobs against ground-truth boxes (IoU >= 0.3; a
  background model finds the moving parts of a vessel, so its box is often smaller than the
  annotated extent) on the simulator's fixed-camera scenes (harbour, crossing, ir), and on CORAL
  D1 (a fixed shore camera; its images in time order of their file-name timestamps, labels
  1-based).  Ground truth under 50 % visible or under the detectors' minimum blob area is
  "don't care": detections on it are neither true nor false.  The first 2 s are the models'
  warm-up and are not scored.  The detectors' defaults were chosen on seed 1 of the scenes
  (``TUNE_SEED``); the figures are over seeds 2-4 (``SEEDS``), per scene and seed, per scene
  (the seeds' counts pooled), and pooled over all scenes and seeds.
* Frames/s of the whole detector (conversion, model, blobs) at 704x576 and 1920x1080 on one
  core (CPU time of this process, OpenCV and Numba single-threaded), median over frames, beside
  MOG2 (``seawatch.detect.mog2``) measured in the same process.
"""

from __future__ import annotations

import datetime as _dt
import os
import re
import time

import cv2
import numpy as np

from seawatch.detect.background import RobustKalmanDetector
from seawatch.detect.mog2 import Mog2Detector, foreground_boxes
from seawatch.eval import box_iou, detection_metrics
from seawatch.types import Detections, Frame

NAME = "background"
DESCRIPTION = "paper C robust Kalman background model vs MOG2/KNN: F1 on fixed-camera scenes, fps"

IOU = 0.3
REF = "paper C, background model"
MIN_AREA_PX = 30.0
#: the settings measured (the [detector] rk_* defaults)
RK = dict()
#: the seed the detectors' defaults were tuned on (never reported), and the seeds reported
TUNE_SEED = 1
SEEDS = (2, 3, 4)


class KnnDetector:
    """OpenCV's KNN background subtractor with the same blob extraction as the MOG2 baseline."""

    name = "knn"

    def __init__(self, fps: float, history_s: float = 20.0, warmup_s: float = 1.0):
        self.model = cv2.createBackgroundSubtractorKNN(history=max(2, int(history_s * fps)),
                                                       detectShadows=False)
        self.warmup_s = warmup_s
        self._t0 = None

    def detect(self, frame: Frame) -> Detections:
        mask = self.model.apply(frame.image)
        if self._t0 is None:
            self._t0 = frame.t_s
        if frame.t_s - self._t0 < self.warmup_s:
            return Detections.empty(frame.t_s, frame.index, self.name, frame.camera_id)
        h, w = mask.shape
        boxes, fill = foreground_boxes(mask, min_area_px=MIN_AREA_PX, max_area_px=0.25 * h * w)
        return Detections(frame.t_s, frame.index, boxes, fill, self.name, frame.camera_id)


def _detectors(fps: float) -> dict:
    return {"robust_kalman": RobustKalmanDetector(min_area_px=MIN_AREA_PX, **RK),
            "mog2": Mog2Detector(fps, min_area_px=MIN_AREA_PX),
            "knn": KnnDetector(fps)}


def _score_sequence(frames, fps: float, warmup_s: float = 2.0) -> dict:
    """Run every detector over ``(Frame, gt_boxes, ignore_boxes)`` and score it."""
    dets = _detectors(fps)
    gt, pred = {}, {k: {} for k in dets}
    t0 = None
    for fr, g, ign in frames:
        t0 = fr.t_s if t0 is None else t0
        for k, d in dets.items():
            b = d.detect(fr).boxes
            if len(ign) and len(b):
                b = b[box_iou(b, ign).max(axis=1) < 0.3]  # on a don't-care object
            if fr.t_s - t0 >= warmup_s:
                pred[k][fr.index] = b
        if fr.t_s - t0 >= warmup_s:
            gt[fr.index] = g
    return {k: detection_metrics(gt, pred[k], iou=IOU, pr=False) for k in dets}


def _sim_frames(name: str, n_frames: int | None, seed: int = SEEDS[0]):
    from seawatch.sim import make_scenario

    scn = make_scenario(name, seed=seed)
    n = scn.n_frames if n_frames is None else min(n_frames, scn.n_frames)

    def gen():
        for i in range(n):
            fr = scn.render(i)
            g = scn.ground_truth(i)
            keep = (g.visible >= 0.5) & (g.boxes[:, 2] * g.boxes[:, 3] >= MIN_AREA_PX)
            yield fr, g.boxes[keep], g.boxes[~keep]

    return scn, gen()


_TS = re.compile(r"(\d{4})-(\d{2})-(\d{2})_(\d{2})-(\d{2})-(\d{2})")


def coral_frames(root, limit: int | None = None):
    """CORAL D1 images in time order (file-name timestamps), with 0-based ground-truth boxes."""
    import csv

    from pathlib import Path

    root = Path(root)
    labels: dict[str, list] = {}
    with open(root / "labels.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            labels.setdefault(row["file"], []).append(
                [float(row["x"]) - 1.0, float(row["y"]) - 1.0, float(row["w"]), float(row["h"])])
    files = []
    for p in (root / "images").glob("*.jpg"):
        m = _TS.search(p.name)
        if m is None:
            raise ValueError(f"{p}: no capture time in the file name")
        t = _dt.datetime(*map(int, m.groups()), tzinfo=_dt.timezone.utc).timestamp()
        files.append((t, p))
    files.sort()
    files = files[:limit] if limit else files
    t0 = files[0][0]
    for i, (t, p) in enumerate(files):
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            raise ValueError(f"{p}: unreadable image")
        g = np.array(labels.get(p.name, []), np.float64).reshape(-1, 4)
        keep = g[:, 2] * g[:, 3] >= MIN_AREA_PX
        yield Frame(img, t - t0, i, "coral_d1"), g[keep], g[~keep]


def _pool(results: list) -> dict:
    """Sum the TP/FP/FN of several runs per method and recompute F1, precision and recall."""
    out = {}
    for k in results[0]:
        tp = sum(r[k]["TP"] for r in results)
        fp = sum(r[k]["FP"] for r in results)
        fn = sum(r[k]["FN"] for r in results)
        out[k] = {"F1": 2 * tp / max(2 * tp + fp + fn, 1), "precision": tp / max(tp + fp, 1),
                  "recall": tp / max(tp + fn, 1), "TP": tp, "FP": fp, "FN": fn}
    return out


def _record_f1(ctx, ds, res, **extra):
    for k, m in res.items():
        for metric in ("F1", "precision", "recall"):
            ctx.record(ds, k, metric, m[metric], "", ref=REF, iou=IOU, TP=m["TP"], FP=m["FP"],
                       FN=m["FN"], **extra)


def _speed(ctx, width: int, height: int, n: int) -> None:
    from seawatch.sim import make_scenario

    scn = make_scenario("harbour", seed=0, width=width, height=height)
    imgs = [scn.render(i).image for i in range(8)]
    ds = f"sim_harbour_{width}x{height}"
    times = {}
    for name, det in (("robust_kalman", RobustKalmanDetector(min_area_px=MIN_AREA_PX, **RK)),
                      ("mog2", Mog2Detector(scn.fps, min_area_px=MIN_AREA_PX)),
                      ("knn", KnnDetector(scn.fps))):
        det.detect(Frame(imgs[0], 0.0, 0))  # compile / allocate
        ts = []
        for i in range(1, n + 1):
            fr = Frame(imgs[i % len(imgs)], i / scn.fps, i)
            t0 = time.process_time()
            det.detect(fr)
            ts.append(time.process_time() - t0)
        times[name] = float(np.median(ts))
        ctx.record(ds, name, "fps", 1.0 / times[name], "1/s", ref=REF, threads=1, frames=n)
        ctx.record(ds, name, "ms_per_frame", 1e3 * times[name], "ms", ref=REF, threads=1, frames=n)
    ctx.record(ds, "robust_kalman", "speedup_vs_mog2", times["mog2"] / times["robust_kalman"], "x",
               ref=REF, threads=1)


def run(ctx) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cv2.setNumThreads(1)
    n_sim = 120 if ctx.quick else None
    scenes = ["harbour"] if ctx.quick else ["harbour", "crossing", "ir"]
    seeds = SEEDS[:1] if ctx.quick else SEEDS
    allres, by_scene = [], {}
    for name in scenes:
        for seed in seeds:
            scn, frames = _sim_frames(name, n_sim, seed)
            res = _score_sequence(frames, scn.fps)
            _record_f1(ctx, f"sim_{name}_seed{seed}", res, seed=seed)
            allres.append(res)
            by_scene.setdefault(name, []).append(res)
    note = f"defaults tuned on seed {TUNE_SEED}; reported seeds " + ",".join(map(str, seeds))
    for name, rs in by_scene.items():  # each scene, its seeds pooled
        _record_f1(ctx, f"sim_{name}", _pool(rs), seeds=",".join(map(str, seeds)), note=note)
    # all scenes and seeds pooled (F1 of the summed counts), and the mean of the per-run F1
    _record_f1(ctx, "sim_fixed_pooled", _pool(allres), scenes=",".join(scenes),
               seeds=",".join(map(str, seeds)), note=note)
    for k in allres[0]:
        ctx.record("sim_fixed_mean", k, "F1", float(np.mean([r[k]["F1"] for r in allres])), "",
                   ref=REF, iou=IOU, runs=len(allres), scenes=",".join(scenes),
                   seeds=",".join(map(str, seeds)), note="mean over scenes x seeds of the F1")
    # speed, one core
    _speed(ctx, 704, 576, 30 if ctx.quick else 100)
    _speed(ctx, 1920, 1080, 20 if ctx.quick else 60)
    # CORAL D1 (real, fixed camera, three photos a minute)
    if ctx.data_dir is not None and (ctx.data_dir / "coral_d1").is_dir():
        root = ctx.data(("coral_d1"))
        res = _score_sequence(coral_frames(root, limit=60 if ctx.quick else None), fps=0.25,
                              warmup_s=0.0)
        _record_f1(ctx, "coral_d1", res, note="first image of the sequence has no detections")
