"""Paper A boat detector on MarDCT video2 (the evaluation clip): accuracy and speed.

* TPR, FAR (= FP / (TP + FP), as in Bloisi et al.) and F1 at IoU 0.5 and 0.3, with and without
  the horizon filter (the paper's Tables I and II), on the 58 annotated frames of video2, for
  seawatch's shipped cascade, the authors' reference cascade ``barche.xml`` (their settings:
  scale factor 1.1, 5 neighbours, 60x30 minimum, Canny pruning) at each image scale 1..3 (its
  best is reported too) and the MOG2 baseline.  Every frame is seen in order (25 fps): the
  cascades update their time-smoothed horizon line on each and detect on the annotated ones
  (the only ones scored), MOG2 learns its background on all.
  ``--quick``: only the annotated frames.
* The same figures on the held-out MarDCT training frames (never tuned on).
* Detector frames per second (cascade + horizon + filters) at 704x576 and 1920x1080 on one core,
  beside the reference cascade measured in the same process.

The seawatch detector runs with its defaults (since session 15 v6's cascade at the settings of
session 15's speed rule, chosen on the training and validation data; detection scale from the
1/16-of-the-width rule): nothing here is tuned on video2.  The default's rows carry ``model``,
``settings`` and ``identical_to`` (the ``ALTERNATIVES`` it equals, which are then not run again).
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import cv2
import numpy as np

NAME = "detection"
DESCRIPTION = ("paper A cascade on MarDCT video2: TPR/FAR/F1 at IoU 0.5/0.3 with/without horizon vs "
               "barche.xml and MOG2; held-out frames; fps at 704x576 and 1920x1080")

FPS_VIDEO = 25.0
REF_BARCHE = {0.3: 0.40, 0.5: 0.26}  # the reference cascade's best F1, measured independently (issue 4)
# faster settings measured beside the default (speed and video2 accuracy): the smallest boat at
# 1/8 of the frame width instead of 1/16 (a detection image half as wide), alone and with
# scale factor 1.3 (fewer pyramid levels)
FAST_SETTINGS = {"smallest_boat_w/8": {}, "smallest_boat_w/8_sf1.3": {"scale_factor": 1.3}}
TARGET = {0.3: 0.75, 0.5: 0.55}
# other shipped cascades measured beside the default in the same run (video2, held-out MarDCT,
# speed), each with the detector settings stored in its JSON; one equal to the default in both
# the XML bytes and the JSON's ``detector`` block is skipped (the default's rows name it)
ALTERNATIVES = {"v5": "boat_cascade_v5.xml", "v6": "boat_cascade_v6.xml", "v6fast": "boat_cascade_v6fast.xml",
                "v6s15": "boat_cascade_v6s15.xml", "v7": "boat_cascade_v7.xml", "v2": "boat_cascade_v2.xml",
                "v6g4": "boat_cascade_v6g4.xml"}
# the floor of a cascade scan at 704x576 (pyramid, integrals, variance checks; a cascade that
# rejects every window at its first stump) for these windows and scale factors
FLOOR_WINDOWS = ((60, 30), (40, 20), (30, 15))
FLOOR_SCALE_FACTORS = (1.1, 1.2)


def _video2(ctx, quick: bool):
    root = ctx.data("mardct")
    video = root / "video2-clipped-start-at-3300.avi"
    if not video.is_file():
        ctx.skip(f"missing {video}")
    gt = {}
    for txt in sorted((root / "video2_gt").glob("*.txt")):
        m = re.search(r"_(\d+)\.txt$", txt.name)
        if not m:
            continue
        idx = int(m.group(1)) - 1300
        rows = [ln.split() for ln in txt.read_text().splitlines() if ln.strip()]
        gt[idx] = np.array([[float(v) for v in r[1:5]] for r in rows], np.float64).reshape(-1, 4)
    cap = cv2.VideoCapture(str(video))
    frames = []
    i = 0
    while True:
        ok, f = cap.read()
        if not ok:
            break
        if not quick or i in gt:
            frames.append((i, f))
        i += 1
    cap.release()
    return frames, gt


def _run(detector, frames, gt):
    """Detections on the annotated frames; the other frames only update the horizon line
    (a cascade's detections there are not scored) or, for MOG2, the background model."""
    from seawatch.types import Frame

    out = {}
    if hasattr(detector, "reset"):
        detector.reset()
    for i, img in frames:
        fr = Frame(img, i / FPS_VIDEO, i)
        if i in gt or not hasattr(detector, "observe"):
            d = detector.detect(fr)
            if i in gt:
                out[i] = (d.boxes, d.scores)
        else:
            detector.observe(fr)
    return out


def _record_scores(ctx, dataset, method, pred, gt, horizon, extra=None):
    from seawatch.eval.detection import detection_metrics

    res = {}
    for iou in (0.5, 0.3):
        m = detection_metrics({k: gt[k] for k in gt}, {k: pred.get(k, (np.zeros((0, 4)), np.zeros(0))) for k in gt},
                              iou=iou, frames=sorted(gt), pr=False)
        res[iou] = m
        for metric in ("TPR", "FAR", "F1"):
            ref = None
            if method.startswith("barche") and metric == "F1" and "best" in method:
                ref = REF_BARCHE[iou]
            ctx.record(f"{dataset} IoU{iou}", method, metric, m[metric], "",
                       iou=iou, horizon_filter=horizon, TP=m["TP"], FP=m["FP"], FN=m["FN"], ref=ref,
                       **(extra or {}))
    return res


def run(ctx) -> None:
    cv2.setNumThreads(1)
    from seawatch.detect.cascade import CascadeDetector, default_model_path

    quick = ctx.quick
    frames, gt = _video2(ctx, quick)
    # another cascade (with its JSON) in place of the shipped one: SEAWATCH_CASCADE_MODEL=path
    model = Path(os.environ.get("SEAWATCH_CASCADE_MODEL") or default_model_path())
    if not model.is_file():
        ctx.skip(f"no shipped model at {model}")
    ds = "mardct_video2"

    # the shipped model's training record (time and set sizes), from the JSON beside it
    import json
    for tag, mp in {"": model, **{f"_{t}": a for t, a in _alternatives(model).items()}}.items():
        meta_path = mp.with_suffix(".json")
        if meta_path.is_file():
            meta = json.loads(meta_path.read_text())
            for key, unit in (("training_time_s", "s"), ("n_train_images", "images"), ("n_boxes", "boxes"),
                              ("n_positive_windows", "windows"), ("n_stages", "stages")):
                if key in meta:
                    ctx.record("shipped model training", f"seawatch_cascade{tag}", key, meta[key], unit,
                               model=mp.name)

    # which model the default's rows are: its file, its settings and the alternatives it equals
    alts = _alternatives(model)
    default_id = _default_id(model)

    # seawatch's cascade, with and without the horizon filter
    for hz in (True, False):
        det = CascadeDetector(model, horizon_filter=hz)
        pred = _run(det, frames, gt)
        _record_scores(ctx, ds, "seawatch_cascade" + ("+horizon" if hz else ""), pred, gt, hz,
                       extra={"smallest_boat_px": det.min_boat_px(320), **default_id})
    for tag, alt in alts.items():
        for hz in (True, False):
            det = CascadeDetector(alt, horizon_filter=hz)
            pred = _run(det, frames, gt)
            _record_scores(ctx, ds, f"seawatch_cascade_{tag}" + ("+horizon" if hz else ""), pred, gt, hz,
                           extra={"smallest_boat_px": det.min_boat_px(320), "model": alt.name,
                                  "settings": _settings(det)})
    # the faster settings of the speed table (smallest boat 1/8 of the width; and scale factor 1.3):
    # what they cost in accuracy on the same frames
    for name, kw in FAST_SETTINGS.items():
        det = CascadeDetector(model, min_size_px=320 / 8.0, **kw)
        pred = _run(det, frames, gt)
        _record_scores(ctx, ds, f"seawatch_cascade+horizon({name})", pred, gt, True,
                       extra={"smallest_boat_px": det.min_boat_px(320)})

    # the reference cascade at its authors' settings, at several image scales
    ref = Path(ctx.data("reference_cascades", "barche.xml"))
    scales = (2.0,) if quick else (1.0, 1.5, 2.0, 2.5, 3.0)
    best = {}
    for hz in (True, False):
        best_f1, best_z, best_pred = -1.0, None, None
        for z in scales:
            det = CascadeDetector(ref, scale_factor=1.1, min_neighbors=5, detection_width_px=int(round(320 * z)),
                                  canny_prune=True, suppress_nested=True, horizon_filter=hz,
                                  reflection_filter=False)
            pred = _run(det, frames, gt)
            r = _record_scores(ctx, ds, f"barche_x{z:g}" + ("+horizon" if hz else ""), pred, gt, hz,
                               extra={"image_scale": z})
            if r[0.3]["F1"] > best_f1:
                best_f1, best_z, best_pred = r[0.3]["F1"], z, pred
        best[hz] = best_z
        _record_scores(ctx, ds, "barche_best" + ("+horizon" if hz else ""), best_pred, gt, hz,
                       extra={"image_scale": best_z})

    # MOG2 baseline (fixed-camera method; the camera pans and zooms here)
    try:
        from seawatch.detect.mog2 import Mog2Detector
    except ImportError:
        Mog2Detector = None
    if Mog2Detector is not None and not quick:
        pred = _run(Mog2Detector(FPS_VIDEO), frames, gt)
        _record_scores(ctx, ds, "mog2", pred, gt, False)

    # held-out MarDCT training frames (never tuned on)
    parts = {"heldout": []}
    try:
        from seawatch.train.recipe import load_training_data
        parts = load_training_data(ctx.data_dir, use_sim=False)
    except (FileNotFoundError, ValueError):
        pass
    held = [im for im in parts["heldout"] if im.source == "mardct"]
    if held:
        gt_h = {k: im.boxes for k, im in enumerate(held)}
        for hz in (True, False):
            det = CascadeDetector(model, horizon_filter=hz)
            pred = {}
            for k, im in enumerate(held):
                det.reset()
                b, s = det.detect_grey(cv2.imread(str(im.path), cv2.IMREAD_GRAYSCALE), 0.0)
                pred[k] = (b, s)
            _record_scores(ctx, f"mardct_heldout({len(held)} frames)", "seawatch_cascade" + ("+horizon" if hz else ""),
                           pred, gt_h, hz, extra=default_id)
            for tag, alt in alts.items():
                det = CascadeDetector(alt, horizon_filter=hz)
                pred = {}
                for k, im in enumerate(held):
                    det.reset()
                    pred[k] = det.detect_grey(cv2.imread(str(im.path), cv2.IMREAD_GRAYSCALE), 0.0)
                _record_scores(ctx, f"mardct_heldout({len(held)} frames)",
                               f"seawatch_cascade_{tag}" + ("+horizon" if hz else ""), pred, gt_h, hz,
                               extra={"model": alt.name})
            if best.get(hz):
                det = CascadeDetector(ref, scale_factor=1.1, min_neighbors=5, horizon_filter=hz,
                                      reflection_filter=False)
                pred = {}
                for k, im in enumerate(held):
                    det.reset()
                    g = cv2.imread(str(im.path), cv2.IMREAD_GRAYSCALE)
                    det.params.detection_width_px = int(round(g.shape[1] * best[hz]))
                    pred[k] = det.detect_grey(g, 0.0)
                _record_scores(ctx, f"mardct_heldout({len(held)} frames)",
                               "barche_best" + ("+horizon" if hz else ""), pred, gt_h, hz,
                               extra={"image_scale": best[hz]})

    # CORAL D1 held-out images (small far boats under a coastline: smallest boat 20 px)
    if not quick:
        coral = [im for im in parts["heldout"] if im.source == "coral"]
        if coral:
            gt_c = {k: im.boxes for k, im in enumerate(coral)}
            for tag, mp in {"": model, **{f"_{t}": a for t, a in alts.items()}}.items():
                det = CascadeDetector(mp, min_size_px=20.0)
                pred = {}
                for k, im in enumerate(coral):
                    det.reset()
                    pred[k] = det.detect_grey(cv2.imread(str(im.path), cv2.IMREAD_GRAYSCALE), 0.0)
                _record_scores(ctx, f"coral_heldout({len(coral)} images, boats >= 20 px)",
                               f"seawatch_cascade{tag}+horizon", pred, {k: b[b[:, 2] >= 20] for k, b in gt_c.items()},
                               True, extra=default_id if mp == model else {"model": mp.name})

    # simulator: the same cascade on the EO harbour and the thermal (IR) harbour, a seed never
    # trained on (training uses seed 0 and validation seed 100)
    try:
        from seawatch.sim import make_scenario
    except ImportError:
        make_scenario = None
    if make_scenario is not None:
        for name in ("harbour", "ir"):
            scn = make_scenario(name, seed=42)
            idx = np.unique(np.linspace(0, scn.n_frames - 1, 10 if quick else 40).astype(int))
            det = CascadeDetector(model, min_size_px=24.0)
            gt_s, pred = {}, {}
            for i in idx:
                fr = scn.render(int(i))
                gt = scn.ground_truth(int(i))
                keep = (np.asarray(gt.visible) >= 0.7) & (gt.boxes[:, 2] >= 24)
                gt_s[int(i)] = gt.boxes[keep]
                d = det.detect(fr)
                pred[int(i)] = (d.boxes, d.scores)
            _record_scores(ctx, f"sim_{name}_seed42({len(idx)} frames, boats >= 24 px)",
                           "seawatch_cascade+horizon", pred, gt_s, True, extra=default_id)

    # speed, one core (cv2.setNumThreads(1)): CPU time per frame, which a machine shared with
    # other jobs does not inflate as much as wall time (both are recorded)
    sample = [f for _, f in frames[:: max(1, len(frames) // 20)]][:20]
    reps = 1 if quick else 3
    from seawatch.types import Frame

    # the Numba scanner against OpenCV's on the 2 px grid (session 18): the same detections on every
    # video2 frame, played in order, for the default and each alternative on that grid
    for tag, mp in {"": model, **{f"_{t}": a for t, a in alts.items()}}.items():
        if CascadeDetector(mp).params.grid_step_px != 2 or CascadeDetector(mp).params.grid_step_x_px == 4:
            continue
        pair = [CascadeDetector(mp, scanner=sc) for sc in ("opencv", "numba")]
        n_diff = 0
        for k, (_, f) in enumerate(frames):
            a, b = (d.detect(Frame(f, k / FPS_VIDEO, k)) for d in pair)
            ra = np.column_stack([a.boxes, a.scores])
            rb = np.column_stack([b.boxes, b.scores])
            n_diff += not np.array_equal(ra[np.lexsort(ra.T[::-1])], rb[np.lexsort(rb.T[::-1])])
        ctx.record(ds, f"seawatch_cascade{tag}", "scanner_frames_differing", n_diff, "frames",
                   n_frames=len(frames), note="Numba scanner against OpenCV's, same settings (must be 0)")
    for (w, h) in ((704, 576), (1920, 1080)):
        imgs = [cv2.resize(f, (w, h), interpolation=cv2.INTER_LINEAR) for f in sample]
        det = CascadeDetector(model)
        faster = CascadeDetector(model, detection_width_px=352)  # smallest boat ~ 0.12 x width
        peer = CascadeDetector(ref, scale_factor=1.1, min_neighbors=5, detection_width_px=w,
                               horizon_filter=False, reflection_filter=False)
        cpu, wall = {}, {}
        dets = {"seawatch_cascade+filters": det, "seawatch_cascade+filters(detection_width_352)": faster,
                **{f"seawatch_cascade+filters({k})": CascadeDetector(model, min_size_px=w / 8.0, **kw)
                   for k, kw in FAST_SETTINGS.items()},
                **{f"seawatch_cascade_{t}+filters": CascadeDetector(a) for t, a in alts.items()},
                # the scan region off (session 12's water_roi crop instead): what it saves
                **{f"seawatch_cascade_{t}+filters(no_scan_region)": CascadeDetector(a, scan_region=False)
                   for t, a in alts.items()},
                # each model at the best settings of its validation table for the other scale
                # factors (speed only, never scored on video2): what a faster scale factor costs;
                # the default without a table of its own (v6s15) takes that of the alternative
                # with its cascade (v6)
                **{f"seawatch_cascade{t}+filters(validation_best_sf{sf:g})": CascadeDetector(mp, **kw)
                   for t, mp in {"": model, **{f"_{t}": a for t, a in alts.items()}}.items()
                   for sf, kw in _best_per_scale_factor(mp, list(alts.values()) if mp == model else ()).items()},
                # the same detectors scanned by OpenCV instead of the Numba scanner (2 px grid): the peer
                **{f"seawatch_cascade{t}+filters(opencv_scanner)": CascadeDetector(mp, scanner="opencv")
                   for t, mp in {"": model, **{f"_{t}": a for t, a in alts.items()}}.items()
                   if CascadeDetector(mp).params.grid_step_px == 2 and CascadeDetector(mp).params.grid_step_x_px != 4},
                "barche_x1": peer}
        for name, d in dets.items():
            d.detect(Frame(imgs[0], 0.0, 0))  # warm-up
            per_cpu, per_wall = [], []
            for _ in range(reps):
                d.reset()
                for k, im in enumerate(imgs):
                    t0, c0 = time.perf_counter(), time.process_time()
                    d.detect(Frame(im, k / FPS_VIDEO, k))
                    per_cpu.append(time.process_time() - c0)
                    per_wall.append(time.perf_counter() - t0)
            cpu[name], wall[name] = float(np.median(per_cpu)), float(np.median(per_wall))
        for name in cpu:
            d = dets[name]
            scale = 1.0 if name == "barche_x1" else d.detection_scale(w)
            ctx.record(f"{w}x{h} one core", name, "ms_per_frame", 1000 * cpu[name], "ms",
                       clock="cpu", wall_ms=1000 * wall[name], detection_scale=scale,
                       smallest_boat_px=None if name == "barche_x1" else d.min_boat_px(w))
            ctx.record(f"{w}x{h} one core", name, "fps", 1.0 / cpu[name], "frames/s", clock="cpu",
                       wall_fps=1.0 / wall[name], ref=50.0 if name == "seawatch_cascade+filters" and w == 704 else None,
                       settings=None if name == "barche_x1" else _settings(d))
        ctx.record(f"{w}x{h} one core", "seawatch_vs_barche", "speed_ratio",
                   cpu["barche_x1"] / cpu["seawatch_cascade+filters"], "x", clock="cpu")
        for name in [n for n in cpu if n.endswith("(opencv_scanner)")]:
            ctx.record(f"{w}x{h} one core", name.replace("+filters(opencv_scanner)", "_numba_vs_opencv_scanner"),
                       "speed_ratio", cpu[name] / cpu[name.replace("(opencv_scanner)", "")], "x", clock="cpu")
        for tag, alt in alts.items():
            ctx.record(f"{w}x{h} one core", f"seawatch_{tag}_vs_seawatch_default", "speed_ratio",
                       cpu["seawatch_cascade+filters"] / cpu[f"seawatch_cascade_{tag}+filters"], "x", clock="cpu")
        _profile(ctx, model, imgs, f"{w}x{h} one core", reps)
        for tag, alt in alts.items():
            _profile(ctx, alt, imgs, f"{w}x{h} one core", reps, prefix=f"profile_{tag}")
        if w == 704:
            _floor(ctx, imgs, f"{w}x{h} one core", reps)


def _detector_block(xml: Path):
    """The ``detector`` block of the JSON beside a cascade XML (None without a JSON or block)."""
    import json

    p = xml.with_suffix(".json")
    if not p.is_file():
        return None
    return json.loads(p.read_text()).get("detector")


def _same_model(a: Path, b: Path) -> bool:
    """Same cascade (XML bytes) and same detector settings (the JSON's ``detector`` block)."""
    return a.read_bytes() == b.read_bytes() and _detector_block(a) == _detector_block(b)


def _alternatives(model: Path) -> dict:
    """The ``ALTERNATIVES`` that exist beside the default model and differ from it: in the XML or
    in the detector settings of the JSON (an alternative sharing the default's cascade with other
    settings, e.g. v6 and v6fast beside v6s15, is kept)."""
    out = {}
    for tag, name in ALTERNATIVES.items():
        p = model.parent / name
        if p.is_file() and p.resolve() != model.resolve() and not _same_model(p, model):
            out[tag] = p
    return out


def _identical_alternatives(model: Path) -> list[str]:
    """File names of the ``ALTERNATIVES`` that are the default model (same XML and settings)."""
    return [name for name in ALTERNATIVES.values()
            if (model.parent / name).is_file() and (model.parent / name).resolve() != model.resolve()
            and _same_model(model.parent / name, model)]


def _default_id(model: Path) -> dict:
    """What the default's score rows carry to say which model they are: ``model`` (file name),
    ``settings`` (window, scale factor, ``min_neighbors``, size exponent, grid) and
    ``identical_to`` (the ``ALTERNATIVES`` equal to it, comma-separated; None if none)."""
    from seawatch.detect.cascade import CascadeDetector

    return {"model": model.name, "settings": _settings(CascadeDetector(model)),
            "identical_to": ",".join(_identical_alternatives(model)) or None}


def _validation_source(model: Path, candidates) -> Path | None:
    """The JSON whose ``validation`` table stands for ``model``'s: its own, else that of the first
    of ``candidates`` with the same cascade (XML bytes) that has one (v6s15's JSON, assembled by
    session 15's rule, has none; v6's, same cascade, has)."""
    import json

    for mp in [model, *candidates]:
        p = mp.with_suffix(".json")
        if mp != model and (not mp.is_file() or mp.read_bytes() != model.read_bytes()):
            continue
        if p.is_file() and json.loads(p.read_text()).get("validation"):
            return p
    return None


def _best_per_scale_factor(model: Path, candidates=()) -> dict:
    """Per scale factor other than the model's own, the settings of best validation score in the
    ``validation`` table (selection rule) of the model's JSON or, when it has none, of a candidate
    with the same cascade (:func:`_validation_source`): ``{sf: CascadeDetector kwargs}``."""
    import json

    src = _validation_source(model, candidates)
    if src is None:
        return {}
    table = json.loads(src.read_text()).get("validation") or {}
    chosen = (_detector_block(model) or {}).get("scale_factor")
    out = {}
    for key, row in table.items():
        m = re.fullmatch(r"sf([\d.]+)_mn(\d+)_exp([\d.]+)", key)
        if not m or not isinstance(row, dict) or "score" not in row:
            continue
        sf, mn, ex = float(m.group(1)), int(m.group(2)), float(m.group(3))
        if chosen is not None and abs(sf - float(chosen)) < 1e-9:
            continue
        if sf not in out or row["score"] > out[sf][0]:
            out[sf] = (row["score"], {"scale_factor": sf, "min_neighbors": mn, "neighbors_size_exp": ex})
    return {sf: kw for sf, (_, kw) in sorted(out.items())}


def _settings(det) -> str:
    p = det.params
    return (f"window {det.window[0]}x{det.window[1]}, scale factor {p.scale_factor:g}, "
            f"min_neighbors {p.min_neighbors}, size exponent {p.neighbors_size_exp:g}"
            + ((", 4x2 px grid at every scale" if p.grid_step_x_px == 4 else ", 2 px grid at every scale")
               if p.grid_step_px == 2 else "")
            + (f", {p.scanner} scanner" if p.scanner != "auto" else ""))


def _floor(ctx, imgs, dataset, reps):
    """CPU time of a cascade scan that rejects every window at its first stump (the image
    pyramid, integral images and variance checks alone) at 704x576 with the smallest boat at
    44 px (1/16 of the width; a window maps to a box 0.70 of its width, as the shipped models
    learned), for each window of ``FLOOR_WINDOWS`` and scale factor of ``FLOOR_SCALE_FACTORS``."""
    from seawatch.detect.filters import prepare_grey
    from seawatch.train.haar import generate_features
    from seawatch.train.model import Cascade, Stage, write_cascade_xml
    import tempfile

    greys = [prepare_grey(im) for im in imgs]
    for ww, wh in FLOOR_WINDOWS:
        feats = generate_features(ww, wh, kinds=("x2",), pos_step_px=4, size_step_px=4)
        reject = Cascade(ww, wh, feats, [Stage(1e9, [0], [0.0], [0.0], [0.0])])
        with tempfile.TemporaryDirectory() as tmp:
            write_cascade_xml(reject, Path(tmp) / "reject.xml")
            clf = cv2.CascadeClassifier(str(Path(tmp) / "reject.xml"))
        z = ww * 0.70 / (greys[0].shape[1] / 16.0)
        dw, dh = int(round(greys[0].shape[1] * z)), int(round(greys[0].shape[0] * z))
        small = [cv2.resize(g, (dw, dh), interpolation=cv2.INTER_AREA if z < 1 else cv2.INTER_LINEAR) for g in greys]
        for sf in FLOOR_SCALE_FACTORS:
            ts = []
            for _ in range(reps):
                for g in small:
                    c0 = time.process_time()
                    clf.detectMultiScale2(g, scaleFactor=sf, minNeighbors=1, minSize=(ww, wh))
                    ts.append(time.process_time() - c0)
            ctx.record(dataset, f"floor:window{ww}x{wh}_sf{sf:g}", "ms_per_frame", 1000 * float(np.median(ts)), "ms",
                       clock="cpu", detection_width_px=dw)


def _profile(ctx, model, imgs, dataset, reps, prefix="profile"):
    """Where the default detector's time goes on the speed frames (CPU ms, median): grey + median,
    horizon detection (done at most 5 times a second), the cascade (``detectMultiScale2``), and
    the part of it that is the image pyramid, integral images and variance checks alone (the
    same call with a cascade that rejects every window at its first stump); and how many windows
    enter each stage (OpenCV's scan replayed by seawatch's evaluator on 5 frames). For a model on
    the 4x2 grid (``grid_step_x_px`` 4) only its own scan is timed: the variance-only call and the
    replay would measure the 2 px grid."""
    from seawatch.detect.cascade import CascadeDetector
    from seawatch.detect.filters import prepare_grey, to_grey
    from seawatch.detect.horizon import detect_horizon
    from seawatch.train.model import Cascade, Stage, read_cascade_xml, scan_image, write_cascade_xml
    import tempfile

    det = CascadeDetector(model)
    p = det.params
    w = imgs[0].shape[1]
    z = det.detection_scale(w)
    dw, dh = int(round(w * z)), int(round(imgs[0].shape[0] * z))
    small = [cv2.resize(prepare_grey(im), (dw, dh), interpolation=cv2.INTER_AREA if z < 1 else cv2.INTER_LINEAR)
             for im in imgs]
    casc = read_cascade_xml(model)
    s0 = casc.stages[0]
    reject = Cascade(casc.width_px, casc.height_px, casc.features,
                     [Stage(1e9, s0.feature[:1], s0.split[:1], s0.left[:1], s0.right[:1])]).compact()
    with tempfile.TemporaryDirectory() as tmp:
        write_cascade_xml(reject, Path(tmp) / "reject.xml")
        clf0 = cv2.CascadeClassifier(str(Path(tmp) / "reject.xml"))

    def med(fn, items):
        ts = []
        for _ in range(reps):
            for it in items:
                c0 = time.process_time()
                fn(it)
                ts.append(time.process_time() - c0)
        return 1000 * float(np.median(ts))

    stages = {
        "grey+median": med(prepare_grey, imgs),
        "horizon_detection": med(lambda im: detect_horizon(to_grey(im)), imgs),
        # the model's grid of window positions: OpenCV's (one call) or 2 px at every scale (a call per level)
        "cascade_detectMultiScale": med((lambda g: det.scan_region_windows(g, None)) if p.grid_step_px == 2 else (
            lambda g: det.classifier.detectMultiScale2(g, scaleFactor=p.scale_factor, minNeighbors=int(p.min_neighbors),
                                                       minSize=det.window)), small),
        "pyramid+integrals+variance_only": med(lambda g: clf0.detectMultiScale2(
            g, scaleFactor=p.scale_factor, minNeighbors=1, minSize=det.window), small),
    }
    if p.grid_step_x_px == 4:
        # OpenCV's call and the stage replay below scan the 2 px grid, not this model's 4x2 grid:
        # only the cascade row is its own scan
        del stages["pyramid+integrals+variance_only"]
    found = sum(detect_horizon(to_grey(im)) is not None for im in imgs)
    for k, v in stages.items():
        ctx.record(dataset, f"{prefix}:{k}", "ms_per_frame", v, "ms", clock="cpu", detection_width_px=dw,
                   scale_factor=p.scale_factor, horizon_found_frames=found, n_frames=len(imgs))
    if p.grid_step_x_px == 4:
        return
    nst = casc.n_stages
    reach = np.zeros(nst + 1)
    n_prof = len(small[:5])
    for g in small[:5]:
        f = 1.0
        while True:
            sw, sh = int(round(dw / f)), int(round(dh / f))
            if sw < casc.width_px or sh < casc.height_px:
                break
            lvl = cv2.resize(g, (sw, sh), interpolation=cv2.INTER_LINEAR)
            hits = scan_image(casc, lvl, step_px=1 if (f >= 2 and p.grid_step_px == 0) else 2, min_stage=0,
                              max_hits=5_000_000,
                              skip_after_reject=True)
            reach += np.bincount(hits[:, 2], minlength=nst + 1)
            f *= p.scale_factor
    entering = np.cumsum(reach[::-1])[::-1][:nst]
    stumps = np.array([len(st.feature) for st in casc.stages])
    evals = entering * stumps
    for k in range(nst):
        ctx.record(dataset, f"{prefix}:stage_{k:02d}", "windows_entering", entering[k] / n_prof, "windows/frame",
                   share=float(entering[k] / entering[0]), stumps=int(stumps[k]),
                   stump_eval_share=float(evals[k] / evals.sum()))
