"""Where a cascade detector spends its time, on TRAINING and VALIDATION frames (never MarDCT video2).

Two tools, both run on the recipe's split (:func:`seawatch.train.recipe.load_training_data`):

* :func:`stage_pass_fractions`: the share of the windows the detector scans (automatic detection
  scale, OpenCV's pyramid and grid, the water region below the horizon) that pass each stage of a
  cascade, by image source, away from the boats;
* :func:`region_check`: the detector with the scan region (``scan_region``) against the same
  detector scanning every row: how many accepted detections differ, and the CPU time of each;
* :func:`speed_compare`: CPU time per frame of models and grids of window positions on 20
  MarDCT training frames resized to 704x576;
* :func:`horizon_check`: how often the horizon detector finds a line at each working width, on the
  images at their own size and resized to 704x576, how often it agrees with the full-size line
  (position and water-sky / water-coast kind), and how many annotated boats its filter would drop;
* :func:`speed_settings`: session 14's rule for speed settings (docs/cascade.md): per scale factor
  the best settings on the 14 MarDCT validation frames, their speed at 704x576 on the MarDCT
  training and validation frames, and the choice;
* :func:`played_speed_settings`: session 15's rule: the same candidates, their speed on the MarDCT
  training and validation frames played as video (horizon state kept within a sequence), and the
  choice with a margin above the target; :func:`write_speed_rule_json` (``--write-json PATH``)
  writes the chosen candidate's model JSON (how the default v6s15 is reproduced, PROVENANCE.md).

Command line::

    python -m seawatch.train.scanstats --data ../shared/data --model seawatch/models/boat_cascade_v5.xml
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import cv2
import numpy as np

__all__ = ["stage_pass_fractions", "region_check", "speed_compare", "speed_settings", "choose_speed_setting",
           "horizon_check", "played_sequences", "played_cpu_s", "played_speed_settings", "played_compare",
           "speed_rule_json", "write_speed_rule_json"]


def stage_pass_fractions(model_xml: str | Path, images, scale_factor: float = 1.1, box_ratio_w: float = 0.7,
                         roi_margin_frac: float = 0.2) -> dict:
    """Per-stage pass fractions of a cascade on the windows the detector scans.

    Returns ``{source: {"windows": n, "nonflat": share of windows OpenCV evaluates,
    "pass_after_stage": [share of the evaluated windows passing stages 0..k]}}`` plus ``"all"``.
    """
    from seawatch.train.model import read_cascade_xml
    from seawatch.train.trainer import ScanPool

    casc = read_cascade_xml(model_xml)
    out = {}
    srcs = np.array([im.source for im in images])
    pool = ScanPool(images, (casc.width_px, casc.height_px), scale_factor, box_ratio_w, 4.0, roi_margin_frac)
    total = np.zeros(casc.n_stages + 1, np.int64)
    flat = 0
    for k in sorted(set(srcs.tolist())):
        hist = pool.stage_histogram(casc, np.where(srcs == k)[0], aspect=casc.width_px / casc.height_px)
        total += hist
        out[k] = _summary(hist, casc, pool.last_flat)
        flat += pool.last_flat
    out["all"] = _summary(total, casc, flat)
    return out


def _summary(hist: np.ndarray, casc, n_flat: int) -> dict:
    n = int(hist.sum())
    # windows passing at least j + 1 stages; hist[0] also holds the flat windows
    reach = n - np.cumsum(hist)
    stumps = np.array([len(st.feature) for st in casc.stages], np.float64)
    entering = np.concatenate([[n], reach[:-1]])[: casc.n_stages]
    n_eval = max(n - int(n_flat), 1)
    entering[0] = n_eval
    return {"windows": n, "evaluated_share": round(n_eval / max(n, 1), 4),
            # shares of the evaluated (non-flat) windows passing stages 0..k
            "pass_after_stage": [round(float(r) / n_eval, 5) for r in reach[:-1]],
            "stump_evals_per_evaluated_window": round(float((entering * stumps).sum()) / n_eval, 3)}


def region_check(model_xml: str | Path, images, sizes=((0, 0), (704, 576)), reps: int = 1) -> dict:
    """Detections and CPU time of the detector with and without the scan region.

    Each image is a still: the horizon state is reset before it.  ``sizes``: (0, 0) keeps the
    image's size, else the image is resized to it first.  Returns the counts of accepted
    detections in the full scan, in the region scan, and of those that differ (a box present in
    one and not, to 1e-6 px, in the other), and the median CPU ms per frame of each.
    """
    from seawatch.detect.cascade import CascadeDetector
    from seawatch.train.recipe import _raw_grey

    cv2.setNumThreads(1)
    res = {}
    for size in sizes:
        dets = {"full": CascadeDetector(model_xml, scan_region=False, water_roi=False),
                "region": CascadeDetector(model_xml, scan_region=True),
                "water_roi": CascadeDetector(model_xml, scan_region=False, water_roi=True)}
        n = {k: 0 for k in dets}
        diff = {"region": 0, "water_roi": 0}
        frames_diff = {"region": 0, "water_roi": 0}
        ts = {k: [] for k in dets}
        ts_line = {k: [] for k in dets}
        n_horizon = 0
        for im in images:
            g = _raw_grey(im)
            if size != (0, 0):
                g = cv2.resize(g, size, interpolation=cv2.INTER_LINEAR)
            out = {}
            for k, d in dets.items():
                for _ in range(reps):
                    d.reset()
                    c0 = time.process_time()
                    out[k] = d.detect_grey(g, 0.0, ir=im.ir)
                    ts[k].append(time.process_time() - c0)
                n[k] += len(out[k][0])
            has_line = dets["full"].horizon is not None
            n_horizon += has_line
            for k in dets:
                if has_line:
                    ts_line[k] += ts[k][-reps:]
            ref = out["full"][0]
            for k in diff:
                b = out[k][0]
                d_ab = _unmatched(ref, b) + _unmatched(b, ref)
                diff[k] += d_ab
                frames_diff[k] += d_ab > 0
        res[f"{size[0]}x{size[1]}" if size != (0, 0) else "native"] = {
            "images": len(images), "with_horizon": int(n_horizon),
            "detections": n, "differing_detections": diff, "differing_images": frames_diff,
            "cpu_ms_median": {k: round(1000 * float(np.median(v)), 3) for k, v in ts.items()},
            "cpu_ms_median_with_horizon": {k: round(1000 * float(np.median(v)), 3) if v else None
                                           for k, v in ts_line.items()}}
    return res


def speed_compare(models, images, size=(704, 576), grids=(0, 2), reps: int = 3) -> dict:
    """CPU ms per frame (median) of the whole detector for each model and grid of window
    positions, on ``images`` resized to ``size`` (each a still: horizon state reset), the
    detectors interleaved frame by frame so that a changing machine load touches them alike."""
    from seawatch.detect.cascade import CascadeDetector

    cv2.setNumThreads(1)
    dets = {f"{Path(m).stem}_grid{g}": CascadeDetector(m, grid_step_px=g) for m in models for g in grids}
    greys = _stills(images, size)
    ts = {k: [t for p in v for t in p] for k, v in _interleaved_cpu_s(dets, greys, reps).items()}
    return {"size": f"{size[0]}x{size[1]}", "images": len(greys), "reps": reps,
            "cpu_ms_median": {k: round(1000 * float(np.median(v)), 2) for k, v in ts.items()}}


def speed_settings(model_xml: str | Path, parts: dict, scale_factors=(1.1, 1.2, 1.3, 1.4, 1.5),
                   target_fps: float = 50.0, size=(704, 576), passes: int = 3, log=print) -> dict:
    """Session 14's rule for the detector's speed settings (fixed before it was run on MarDCT video2).

    1. Per scale factor, the best ``min_neighbors`` and size exponent on the 14 MarDCT validation
       frames by session 11's criterion (:func:`seawatch.train.recipe.select_detector_settings`,
       the model's grid of window positions).
    2. The speed of each at ``size``: the whole detector (horizon line, cascade with its scan
       region, filters) on the MarDCT training and validation frames resized to ``size``, each
       a still (horizon state reset, the line detected on it); CPU time, one core; the detectors
       interleaved frame by frame; ``passes`` passes; the median over all of them.
    3. Chosen: the highest validation score among the settings reaching ``target_fps``; when none
       does, none is chosen (``chosen`` None).

    Never MarDCT video2, never the held-out part.
    """
    best, ims, dets = _rule_candidates(model_xml, parts, scale_factors, log)
    greys = _stills(ims, size)
    tps = _interleaved_cpu_s(dets, greys, passes)
    ts = {sf: [t for p in v for t in p] for sf, v in tps.items()}
    per_pass = {sf: [round(1.0 / float(np.median(p)), 2) for p in v] for sf, v in tps.items()}
    rows = []
    for sf, b in sorted(best.items()):
        fps = 1.0 / float(np.median(ts[sf]))
        rows.append({**b, "fps": round(fps, 2), "fps_per_pass": per_pass[sf],
                     "ms_per_frame": round(1000.0 / fps, 3)})
        log(f"  sf {sf:g}: {b['min_neighbors']} / {b['neighbors_size_exp']:g}, validation score {b['score']:.4f}, "
            f"{fps:.1f} frames/s at {size[0]}x{size[1]} (passes {per_pass[sf]})")
    chosen = choose_speed_setting(rows, target_fps)
    log(f"  chosen: {chosen}")
    return {"rule": "session 14 (docs/cascade.md)", "size": f"{size[0]}x{size[1]}", "target_fps": target_fps,
            "speed_frames": len(greys), "passes": passes, "candidates": rows, "chosen": chosen}


def _rule_candidates(model_xml, parts: dict, scale_factors, log) -> tuple[dict, list, dict]:
    """The common start of the speed rules of sessions 14 and 15 (one OpenCV thread): the
    candidates (:func:`_best_per_scale_factor`), the MarDCT training and validation images their
    speed is measured on (never the held-out part) and a detector per candidate:
    ``(best, images, {scale_factor: CascadeDetector})``."""
    from seawatch.detect.cascade import CascadeDetector

    cv2.setNumThreads(1)
    best = _best_per_scale_factor(model_xml, parts, scale_factors, log)
    ims = [im for im in parts["train"] + parts["val"] if im.source == "mardct"]
    dets = {sf: CascadeDetector(model_xml, scale_factor=b["scale_factor"], min_neighbors=b["min_neighbors"],
                                neighbors_size_exp=b["neighbors_size_exp"]) for sf, b in best.items()}
    return best, ims, dets


def _best_per_scale_factor(model_xml, parts: dict, scale_factors, log) -> dict:
    """Per scale factor the best ``min_neighbors`` and size exponent on the MarDCT validation
    frames by session 11's criterion (:func:`seawatch.train.recipe.select_detector_settings`)."""
    from seawatch.train.recipe import select_detector_settings

    val = [im for im in parts["val"] if im.source == "mardct"]
    _, table = select_detector_settings(model_xml, val, scale_factors=tuple(scale_factors),
                                        fixed_min_size_px={"coral": 20.0}, log=log)
    best = {}
    for key, row in table.items():
        sf = float(key.split("_")[0][2:])
        if sf not in best or row["score"] > best[sf]["score"] + 1e-12:
            mn, ex = key.split("_")[1][2:], key.split("_")[2][3:]
            best[sf] = {"scale_factor": sf, "min_neighbors": int(mn), "neighbors_size_exp": float(ex),
                        "score": row["score"], "macro_F1@0.3": row["macro_F1@0.3"], "macro_F1@0.5": row["macro_F1@0.5"]}
    return best


def played_sequences(images, size=(704, 576), seq_len: int = 20) -> list[list[np.ndarray]]:
    """Frames played as the detection bench plays its speed frames: each clip's (``group``) frames
    in temporal order (``order``), cut into sequences of ``seq_len`` frames (a clip's last
    sequence may be shorter), each frame read in colour and resized to ``size`` (linear; None:
    kept at its own size)."""
    from seawatch.detect.filters import to_grey

    groups: dict = {}
    for im in images:
        groups.setdefault(im.group, []).append(im)
    seqs = []
    for g in sorted(groups):
        ims = sorted(groups[g], key=lambda im: im.order)
        for i in range(0, len(ims), seq_len):
            seq = []
            for im in ims[i:i + seq_len]:
                img = im.image if im.image is not None else cv2.imread(str(im.path), cv2.IMREAD_COLOR)
                if img is None:
                    raise ValueError(f"cannot read image {im.path}")
                if img.ndim == 2 or img.dtype != np.uint8:
                    img = to_grey(img, im.name)
                seq.append(img if size is None else cv2.resize(img, size, interpolation=cv2.INTER_LINEAR))
            seqs.append(seq)
    return seqs


def played_cpu_s(dets: dict, seqs, passes: int, fps: float = 25.0) -> dict:
    """CPU seconds of each detector on each frame of sequences played as video: the horizon state
    is reset at the start of each sequence and kept within it, frame ``k`` at ``k / fps`` seconds
    (as the detection bench times its speed frames); the detectors interleaved frame by frame in
    a rotating order; one warm-up call each first; ``passes`` passes.
    Returns ``{key: [[s per frame] per pass]}``."""
    from seawatch.types import Frame

    keys = list(dets)
    for k in keys:
        dets[k].detect(Frame(seqs[0][0], 0.0, 0))
    out = {k: [] for k in keys}
    n = 0
    for _ in range(passes):
        tp = {k: [] for k in keys}
        for seq in seqs:
            for k in keys:
                dets[k].reset()
            for i, img in enumerate(seq):
                fr = Frame(img, i / fps, i)
                r = n % len(keys)
                n += 1
                for k in keys[r:] + keys[:r]:
                    c0 = time.process_time()
                    dets[k].detect(fr)
                    tp[k].append(time.process_time() - c0)
        for k in keys:
            out[k].append(tp[k])
    return out


def played_speed_settings(model_xml: str | Path, parts: dict, scale_factors=(1.1, 1.2, 1.3, 1.4, 1.5),
                          target_fps: float = 50.0, margin_fps: float = 55.0, size=(704, 576), passes: int = 3,
                          seq_len: int = 20, log=print) -> dict:
    """Session 15's rule for the detector's speed settings (docs/cascade.md, fixed before any of
    its candidates was scored on MarDCT video2).

    1. Candidates: per scale factor, the best ``min_neighbors`` and size exponent on the MarDCT
       validation frames by session 11's criterion (the model's grid of window positions).
    2. Speed: the whole detector (horizon line, cascade with its scan region, filters) on the
       MarDCT training and validation frames *played* as the bench plays its speed frames
       (:func:`played_sequences`, :func:`played_cpu_s`: each clip in temporal order, sequences of
       ``seq_len`` frames at ``k / 25`` s, the horizon state kept within a sequence and reset
       between them, resized to ``size``); CPU time, one core; candidates interleaved; ``passes``
       passes; the median over every frame of every pass.
    3. Chosen: the highest validation score among the candidates reaching ``margin_fps`` (a margin
       above the target ``target_fps``); None when none does.

    Never MarDCT video2, never the held-out part.
    """
    best, ims, dets = _rule_candidates(model_xml, parts, scale_factors, log)
    seqs = played_sequences(ims, size, seq_len)
    tps = played_cpu_s(dets, seqs, passes)
    rows = []
    for sf, b in sorted(best.items()):
        allt = [t for p in tps[sf] for t in p]
        fps = 1.0 / float(np.median(allt))
        per_pass = [round(1.0 / float(np.median(p)), 2) for p in tps[sf]]
        rows.append({**b, "fps": round(fps, 2), "fps_per_pass": per_pass, "ms_per_frame": round(1000.0 / fps, 3),
                     "ms_per_frame_mean": round(1000.0 * float(np.mean(allt)), 3)})
        log(f"  sf {sf:g}: {b['min_neighbors']} / {b['neighbors_size_exp']:g}, validation score {b['score']:.4f}, "
            f"{fps:.1f} frames/s played at {size[0]}x{size[1]} (passes {per_pass})")
    chosen = choose_speed_setting(rows, margin_fps)
    log(f"  chosen: {chosen}")
    return {"rule": "session 15 (docs/cascade.md)", "size": f"{size[0]}x{size[1]}", "target_fps": target_fps,
            "margin_fps": margin_fps, "sequences": [len(q) for q in seqs], "speed_frames": sum(len(q) for q in seqs),
            "passes": passes, "candidates": rows, "chosen": chosen}


# keys of a trained model's JSON that describe its own choice of settings, left out of the JSON
# of the same cascade at settings chosen by a speed rule (in this order in the note)
OWN_SETTINGS_KEYS = ("validation", "heldout", "selection", "validation_by_grid", "validation_grid0",
                     "validation_others")


def speed_rule_json(model_xml: str | Path, rule: dict, command: str, name: str) -> dict:
    """The JSON of ``model_xml``'s cascade at the settings a speed rule chose (how v6fast's and
    v6s15's JSONs were made, session 14 and 15).

    ``rule``: the output of :func:`played_speed_settings` (or :func:`speed_settings`) for this
    model; ``command``: the command that ran it (stored); ``name``: the new model's tag (e.g.
    ``"v6s15"``).  The result is the model's JSON with its ``detector`` block given the chosen
    ``scale_factor``, ``min_neighbors`` and ``neighbors_size_exp`` (its other entries, e.g.
    ``grid_step_px``, kept), the keys of ``OWN_SETTINGS_KEYS`` left out (they describe the
    model's own choice), ``speed_selection`` (the rule's whole record: candidates, validation
    scores, played speeds, choice, with ``command`` and a note) and ``note_<tag>_keys`` (what is
    the original model's), where ``<tag>`` is the model's own tag (``boat_cascade_v6`` -> ``v6``).
    Raises ValueError when the rule chose nothing or the model has no JSON.
    """
    xml = Path(model_xml)
    meta_path = xml.with_suffix(".json")
    if not meta_path.is_file():
        raise ValueError(f"{meta_path}: no JSON beside the model (the training record to copy)")
    chosen = rule.get("chosen")
    if not chosen:
        raise ValueError(f"the rule chose no candidate (none reached {rule.get('margin_fps', rule.get('target_fps'))} "
                         "frames/s): no JSON to write")
    meta = json.loads(meta_path.read_text(encoding="utf-8"))
    tag = xml.stem[len("boat_cascade_"):] if xml.stem.startswith("boat_cascade_") else xml.stem
    dropped = [k for k in OWN_SETTINGS_KEYS if k in meta]
    out = {k: v for k, v in meta.items() if k not in dropped}
    det = dict(out.get("detector") or {})
    det.update({"min_neighbors": int(chosen["min_neighbors"]), "scale_factor": float(chosen["scale_factor"]),
                "neighbors_size_exp": float(chosen["neighbors_size_exp"])})
    out["detector"] = det
    out["speed_selection"] = {**rule, "command": command,
                              "note": f"{tag}'s cascade (byte copy of {xml.name}) with the detector settings chosen "
                                      f"by {_rule_name(rule)} (docs/cascade.md); {tag}'s training record is kept above"}
    out[f"note_{tag}_keys"] = (
        f"command, training_time_s, total_time_s and the training record (settings, stages, split, box "
        f"calibration, ...) are {tag}'s: this file is {tag}'s JSON ({meta_path.name}) with new detector settings; "
        f"no training was run for {name}. Dropped from {tag}'s JSON (they describe {tag}'s own settings): "
        f"{', '.join(dropped)}; see PROVENANCE.md")
    return out


def _rule_name(rule: dict) -> str:
    r = str(rule.get("rule", ""))
    return {"session 15": "session 15's played-speed rule", "session 14": "session 14's speed rule"}.get(
        r.split(" (")[0], r or "a speed rule")


def write_speed_rule_json(path: str | Path, model_xml: str | Path, rule: dict, command: str,
                          name: str | None = None) -> Path:
    """Write :func:`speed_rule_json` to ``path`` (indent 1, a final newline, as the trainer
    writes its JSONs); ``name`` defaults to the file's tag (``boat_cascade_v6s15.json`` ->
    ``v6s15``).  The cascade XML to go beside it is a byte copy of ``model_xml``."""
    path = Path(path)
    if name is None:
        name = path.stem[len("boat_cascade_"):] if path.stem.startswith("boat_cascade_") else path.stem
    data = speed_rule_json(model_xml, rule, command, name)
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    return path


def played_compare(before_commit: str, model_xml: str | Path, parts: dict, settings: dict | None = None,
                   sizes=((704, 576), None), passes: int = 3, repo: str | Path | None = None) -> dict:
    """The detector of ``seawatch/detect/cascade.py`` at ``before_commit`` against today's, on the
    MarDCT training and validation frames played as the bench plays (:func:`played_sequences`):
    frames whose boxes, scores or horizon line differ (at ``sizes``; None: each frame's own size),
    and the paired CPU time at the first size (the two detectors alternating frame by frame, the
    first of each pair alternating too; ``passes`` passes).  Only ``cascade.py`` is taken from
    ``before_commit`` (it imports today's filters and horizon modules).  ``settings``:
    ``{scale_factor: (min_neighbors, size exponent)}``, default the candidates of session 14/15."""
    import importlib.util
    import subprocess
    import sys
    import tempfile

    from seawatch.detect.cascade import CascadeDetector
    from seawatch.types import Frame

    cv2.setNumThreads(1)
    repo = Path(repo) if repo else Path(__file__).resolve().parents[2]
    src = subprocess.run(["git", "-C", str(repo), "show", f"{before_commit}:seawatch/detect/cascade.py"],
                         check=True, capture_output=True, text=True).stdout
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cascade_before.py"
        path.write_text(src, encoding="utf-8")
        spec = importlib.util.spec_from_file_location("cascade_before", path)
        old = importlib.util.module_from_spec(spec)
        sys.modules["cascade_before"] = old
        spec.loader.exec_module(old)
    settings = settings or {1.1: (16, 0.0), 1.2: (6, 0.0), 1.3: (6, 0.0), 1.4: (8, 0.0), 1.5: (4, 0.0)}
    ims = [im for im in parts["train"] + parts["val"] if im.source == "mardct"]
    native = played_sequences(ims, size=None, seq_len=20)
    out = {"before": before_commit, "frames": 0, "differing_frames": 0, "boxes": 0, "frames_with_line": 0,
           "speed": {}}
    for size in sizes:
        seqs = native if size is None else [[cv2.resize(f, size, interpolation=cv2.INTER_LINEAR) for f in q]
                                            for q in native]
        for sf, (mn, ex) in settings.items():
            kw = dict(scale_factor=sf, min_neighbors=mn, neighbors_size_exp=ex)
            a, b = old.CascadeDetector(model_xml, **kw), CascadeDetector(model_xml, **kw)
            for q in seqs:
                a.reset()
                b.reset()
                for k, img in enumerate(q):
                    da, db = a.detect(Frame(img, k / 25.0, k)), b.detect(Frame(img, k / 25.0, k))
                    same = (da.boxes.shape == db.boxes.shape and np.array_equal(da.boxes, db.boxes)
                            and np.array_equal(da.scores, db.scores) and a.horizon == b.horizon)
                    out["frames"] += 1
                    out["differing_frames"] += int(not same)
                    out["boxes"] += len(db.boxes)
                    out["frames_with_line"] += int(b.horizon is not None)
            if size != sizes[0]:
                continue
            ta, tb = [], []
            n = 0
            for _ in range(passes):
                for q in seqs:
                    a.reset()
                    b.reset()
                    for k, img in enumerate(q):
                        fr = Frame(img, k / 25.0, k)
                        pair = ((a, ta), (b, tb)) if n % 2 == 0 else ((b, tb), (a, ta))
                        n += 1
                        for d, ts in pair:
                            c0 = time.process_time()
                            d.detect(fr)
                            ts.append(time.process_time() - c0)
            ta, tb = np.array(ta), np.array(tb)
            out["speed"][f"sf{sf:g}"] = {"before_ms": round(1000 * float(np.median(ta)), 3),
                                         "after_ms": round(1000 * float(np.median(tb)), 3),
                                         "ratio": round(float(np.median(tb) / np.median(ta)), 4),
                                         "after_faster_share": round(float((tb < ta).mean()), 3)}
    return out


def _sorted_rows(d) -> np.ndarray:
    """Detections as rows (box, score) in a fixed order: OpenCV's multi-threaded scan returns the
    raw windows, and so the groups, in an order that varies; the order is not a decision."""
    r = np.column_stack([np.asarray(d.boxes, np.float64).reshape(-1, 4), np.asarray(d.scores, np.float64)])
    return r[np.lexsort(r.T[::-1])]


def scanner_check(models, parts: dict, settings=None, size=(704, 576), passes: int = 3, seq_len: int = 20) -> dict:
    """The Numba scanner (:mod:`seawatch.detect.cascade_scan`) against OpenCV's in the whole
    detector: every model (with ``settings``: :class:`~seawatch.detect.cascade.CascadeParams`
    overrides, e.g. session 15's v6 at ``{"scale_factor": 1.1, "min_neighbors": 16}``; None:
    its own) on the 2 px grid, played on the MarDCT training and validation frames as the bench
    plays its speed frames (:func:`played_cpu_s`), scanner "opencv" and "numba" interleaved.
    Returns per model: whether the detections (boxes and scores) were identical on every frame of
    every pass, the number of frames that differ, and the median frames/s of each and their ratio.
    Never MarDCT video2, never the held-out part."""
    from seawatch.detect.cascade import CascadeDetector
    from seawatch.types import Frame

    ims = [im for p in ("train", "val") for im in parts[p] if im.source == "mardct"]
    seqs = played_sequences(ims, size, seq_len)
    out = {}
    for m in models:
        kw = dict(settings or {}, grid_step_px=2, grid_step_x_px=2)  # OpenCV's 2 px grid, which both scan
        dets = {sc: CascadeDetector(m, scanner=sc, **kw) for sc in ("opencv", "numba")}
        n_diff = n_frames = 0
        for seq in seqs:  # the detections, frame by frame
            for d in dets.values():
                d.reset()
            for i, img in enumerate(seq):
                fr = Frame(img, i / 25.0, i)
                a, b = (dets[sc].detect(fr) for sc in ("opencv", "numba"))
                n_frames += 1
                n_diff += not np.array_equal(_sorted_rows(a), _sorted_rows(b))
        tps = played_cpu_s(dets, seqs, passes)
        fps = {sc: 1.0 / float(np.median([t for p in tps[sc] for t in p])) for sc in dets}
        out[Path(m).stem] = {"settings": {k: v for k, v in kw.items()}, "frames": n_frames,
                             "frames_differing": n_diff, "identical": n_diff == 0,
                             "fps_opencv": fps["opencv"], "fps_numba": fps["numba"],
                             "speed_ratio": fps["numba"] / fps["opencv"],
                             "fps_passes": {sc: [1.0 / float(np.median(p)) for p in tps[sc]] for sc in dets}}
        print(json.dumps({Path(m).stem: out[Path(m).stem]}, indent=1), flush=True)
    return out


def choose_speed_setting(rows, target_fps: float) -> dict | None:
    """Step 3 of session 14's rule: among the candidate rows (each with ``"score"``, the validation
    score, and ``"fps"``) those reaching ``target_fps``, the one with the highest score (the
    first of equal scores); None when none reaches it.  Not the fastest one."""
    ok = [r for r in rows if r["fps"] >= target_fps]
    return max(ok, key=lambda r: r["score"]) if ok else None


def _stills(images, size) -> list[np.ndarray]:
    """The images' grey frames resized to ``size`` (linear), for the speed measurements."""
    from seawatch.train.recipe import _raw_grey

    return [cv2.resize(_raw_grey(im), size, interpolation=cv2.INTER_LINEAR) for im in images]


def _interleaved_cpu_s(dets: dict, greys, passes: int) -> dict:
    """CPU seconds of each detector on each frame, as stills (state reset before each frame),
    the detectors interleaved frame by frame, ``passes`` passes: ``{key: [[s per frame] per pass]}``."""
    out = {k: [] for k in dets}
    for _ in range(passes):
        tp = {k: [] for k in dets}
        for g in greys:
            for k, d in dets.items():
                d.reset()
                c0 = time.process_time()
                d.detect_grey(g, 0.0)
                tp[k].append(time.process_time() - c0)
        for k in dets:
            out[k].append(tp[k])
    return out


def horizon_check(images, widths=(640, 320, 352, 384, (352, 288), (352, 288, "+640")), size=(704, 576),
                  agree_frac: float = 0.015) -> dict:
    """The horizon detector at several working widths (``work_width_px`` of
    :func:`seawatch.detect.horizon.detect_horizon`) on labelled images, each at its own size and
    resized to ``size`` (linear): per source, the images with a line, the annotated boats in them
    that :func:`~seawatch.detect.horizon.horizon_filter` would drop, how many lines agree (both
    ends within ``agree_frac`` of the image height) with the line found on the image at its own
    size by the detector working at full size up to 640 px (session 13's), how many of those
    have the same kind (water-sky or water-coast), the median and 90th percentile of the larger
    end difference (px of the image at its own size), and the median CPU ms per call.

    A width entry is an int or a tuple of ints, tried in turn without the 640 px fallback
    (``fallback_width_px=0``); a tuple ending with ``"+640"`` uses the detector's default
    fallback (640 px) after its widths."""
    from seawatch.detect.horizon import Horizon, detect_horizon, horizon_filter
    from seawatch.train.recipe import _raw_grey

    cv2.setNumThreads(1)
    data = [(im.source, _raw_grey(im), im.boxes) for im in images]
    ref = [detect_horizon(g, work_width_px=0 if g.shape[1] <= 640 else 640, fallback_width_px=0) for _, g, _ in data]
    out = {}
    for ww in widths:
        if isinstance(ww, tuple):
            fb = 640 if ww and ww[-1] == "+640" else 0
            ww = tuple(int(x) for x in ww if x != "+640")
            key = ",".join(str(x) for x in ww) + ("+640" if fb else "")
        else:
            fb, key = 0, str(ww)
        for sz in ("native", f"{size[0]}x{size[1]}"):
            st: dict = {}
            ts = []
            ends: dict = {}
            for (src, g, boxes), r0 in zip(data, ref):
                h0 = g.shape[0]
                gi = g if sz == "native" else cv2.resize(g, size, interpolation=cv2.INTER_LINEAR)
                c0 = time.process_time()
                hz = detect_horizon(gi, work_width_px=ww, fallback_width_px=fb)
                ts.append(time.process_time() - c0)
                d = st.setdefault(src, {"images": 0, "lines": 0, "boats_in_line_images": 0, "boats_dropped": 0,
                                        "lines_with_reference": 0, "agreeing": 0, "same_kind": 0})
                d["images"] += 1
                if hz is None:
                    continue
                sy = h0 / gi.shape[0]
                hz = Horizon((hz.y_left + 0.5) * sy - 0.5, (hz.y_right + 0.5) * sy - 0.5, g.shape[1], hz.kind)
                d["lines"] += 1
                d["boats_in_line_images"] += len(boxes)
                d["boats_dropped"] += int((~horizon_filter(boxes, hz)).sum()) if len(boxes) else 0
                if r0 is not None:
                    d["lines_with_reference"] += 1
                    e_px = max(abs(hz.y_left - r0.y_left), abs(hz.y_right - r0.y_right))
                    d["agreeing"] += int(e_px / h0 <= agree_frac)
                    d["same_kind"] += int(hz.kind == r0.kind)
                    ends.setdefault(src, []).append(e_px)
            for src, e in ends.items():
                st[src]["end_diff_px_median"] = round(float(np.median(e)), 2)
                st[src]["end_diff_px_p90"] = round(float(np.percentile(e, 90)), 2)
            out[f"{key} {sz}"] = {"cpu_ms_median": round(1000 * float(np.median(ts)), 3), **st}
    return out


def _unmatched(a: np.ndarray, b: np.ndarray) -> int:
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    if len(b) == 0:
        return len(a)
    return int((np.abs(a[:, None, :] - b[None, :, :]).max(axis=2) > 1e-6).all(axis=1).sum())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--model", type=Path, required=True)
    ap.add_argument("--parts", default="train,val", help="split parts to use (train,val; never video2)")
    ap.add_argument("--what", default="stages,region", help="stages, region, speed, horizon, speedrule, playedrule, "
                    "samecheck, scannercheck (comma-separated)")
    ap.add_argument("--settings", default="", help="with --what scannercheck: detector settings as JSON, "
                    "e.g. '{\"scale_factor\": 1.1, \"min_neighbors\": 16}' (default: each model's own)")
    ap.add_argument("--no-sim", action="store_true")
    ap.add_argument("--speed-models", default="", help="with --what speed: more models, comma-separated")
    ap.add_argument("--out", type=Path, default=None, help="write the figures as JSON here")
    ap.add_argument("--before", default="7a40f93", help="with --what samecheck: the commit of the old cascade.py")
    ap.add_argument("--write-json", type=Path, default=None, metavar="PATH",
                    help="with --what playedrule: write the chosen candidate's model JSON here (the --model JSON "
                         "with the chosen detector block and the rule's record; PROVENANCE.md), e.g. "
                         "/tmp/cv/boat_cascade_v6s15.json; its XML is a byte copy of --model")
    a = ap.parse_args(argv)
    if a.write_json is not None and "playedrule" not in {w.strip() for w in a.what.split(",")}:
        ap.error("--write-json needs --what playedrule")
    if a.write_json is not None and not a.model.with_suffix(".json").is_file():
        ap.error(f"--write-json: no JSON beside --model {a.model}")
    from seawatch.train.recipe import load_training_data

    parts = load_training_data(a.data, use_sim=not a.no_sim, seed=0)
    imgs = [im for p in a.parts.split(",") for im in parts[p.strip()]]
    res = {"model": str(a.model), "parts": a.parts, "n_images": len(imgs)}
    what = {w.strip() for w in a.what.split(",")}
    if "stages" in what:
        res["stages"] = stage_pass_fractions(a.model, [im for im in parts["train"]])
        print(json.dumps(res["stages"], indent=1))
    if "region" in what:
        res["region"] = region_check(a.model, imgs)
        print(json.dumps(res["region"], indent=1))
    if "speed" in what:
        models = [a.model] + [Path(m) for m in a.speed_models.split(",") if m.strip()]
        mardct = [im for im in parts["train"] if im.source == "mardct"][::5][:20]
        res["speed"] = speed_compare(models, mardct)
        print(json.dumps(res["speed"], indent=1))
    if "horizon" in what:
        res["horizon"] = horizon_check(imgs)
        print(json.dumps(res["horizon"], indent=1))
    if "speedrule" in what:
        res["speed_settings"] = speed_settings(a.model, parts)
    if "scannercheck" in what:
        try:
            settings = json.loads(a.settings) if a.settings.strip() else None
        except ValueError as exc:
            ap.error(f"--settings: not JSON: {exc}")
        if settings is not None and not isinstance(settings, dict):
            ap.error("--settings: a JSON object is needed")
        models = [a.model] + [Path(m) for m in a.speed_models.split(",") if m.strip()]
        res["scanner_check"] = scanner_check(models, parts, settings)
    if "samecheck" in what:
        res["played_compare"] = played_compare(a.before, a.model, parts)
        print(json.dumps(res["played_compare"], indent=1))
    if "playedrule" in what:
        res["played_speed_settings"] = played_speed_settings(a.model, parts)
        print(json.dumps(res["played_speed_settings"], indent=1))
        if a.write_json is not None:
            import os
            import sys

            from seawatch.eval.bench import _git_commit

            env = " ".join(f"{k}={os.environ[k]}" for k in ("OMP_NUM_THREADS", "NUMBA_NUM_THREADS") if k in os.environ)
            cmd = ((env + " " if env else "") + "python -m seawatch.train.scanstats "
                   + " ".join(sys.argv[1:] if argv is None else argv)
                   + f" (commit {_git_commit(Path(__file__).resolve().parents[2])})")
            try:
                write_speed_rule_json(a.write_json, a.model, res["played_speed_settings"], cmd)
                print(f"wrote {a.write_json}")
            except ValueError as exc:
                print(f"--write-json: {exc}")
                return 1
    if a.out:
        a.out.write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
