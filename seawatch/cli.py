"""The ``seawatch`` command line.

Each subcommand has a pair of functions here, ``_add_<name>`` (its arguments and help) and
``_cmd_<name>`` (what it does, importing its stages lazily so ``--help`` stays fast).  This module
and :mod:`seawatch.pipeline` are the only places that know every stage.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from seawatch import __version__
from seawatch.config import ConfigError

EXIT_OK = 0
EXIT_FAIL = 1
EXIT_USAGE = 2


class CLIError(Exception):
    """An error the user can fix; printed without a traceback."""


def _formatter(prog):
    return argparse.RawDescriptionHelpFormatter(prog, max_help_position=32)


# -------------------------------------------------------------------------- run
def _add_config_args(p) -> None:  # owner: pipeline
    p.add_argument("--config", type=Path, metavar="FILE", help="settings file (TOML); see docs/pipeline.md")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override one setting, e.g. --set detector.kind=mog2 (repeatable)")


def _add_run(sub) -> None:  # owner: pipeline
    p = sub.add_parser(
        "run",
        help="run the pipeline on a video file, image folder or stream",
        description=(
            "Detect and track vessels in SOURCE (a video file, a folder of images read in sorted "
            "file-name order, or an rtsp:// / http:// stream URL) and write to --out: annotated.mp4, "
            "detections.csv and tracks.csv (MOTChallenge), detections.jsonl and tracks.jsonl, and "
            "summary.json. Unreadable frames are counted and skipped; the exit status is non-zero "
            "only when nothing could be processed."
        ),
        epilog=(
            "examples:\n"
            "  seawatch run harbour.mp4 --out out/harbour\n"
            "  seawatch run frames/ --set run.fps=1 --set tracker.max_coast_s=5\n"
            "  seawatch run rtsp://cam1/stream --camera cam1.toml --ptz cam1_ptz.csv --ais udp://0.0.0.0:10110"
        ),
        formatter_class=_formatter,
    )
    p.add_argument("source", metavar="SOURCE", help="video file, image folder or stream URL")
    _add_config_args(p)
    p.add_argument("--camera", type=Path, metavar="FILE",
                   help="camera pose and intrinsics (TOML, or FVessel camera_para.txt)")
    p.add_argument("--ptz", type=Path, metavar="FILE",
                   help="timestamped pan/tilt/zoom states, CSV with header t_s,pan_deg,tilt_deg,zoom")
    p.add_argument("--ais", metavar="FILE|udp://HOST:PORT|tcp://HOST:PORT",
                   help="AIS input (NMEA or CSV file, or a live UDP/TCP NMEA feed) for fusion")
    p.add_argument("--out", type=Path, metavar="DIR", help="output folder (default: out/<source name>)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")


def _load_settings(args):  # owner: pipeline
    from seawatch.config import load_config

    return load_config(args.config, args.overrides)


def _print_run_summary(summary: dict, out_dir) -> None:  # owner: pipeline
    fps = summary.get("processing_fps")
    print(
        f"{summary['frames_processed']} frames processed"
        + (f" at {fps:.1f} frames/s" if fps else "")
        + f", {summary['bad_frames']} bad frames skipped, {summary['detections']} detections, "
        f"{summary['tracks']} tracks" + (f", {summary['alerts']} alerts" if summary.get("alerts") else "")
    )
    for note in summary.get("notes", [])[:10]:
        print(f"  note: {note}")
    for ex in summary.get("bad_frame_examples", [])[:5]:
        print(f"  skipped {ex}")
    print(f"outputs in {out_dir}/")


def _cmd_run(args) -> int:  # owner: pipeline
    from seawatch.io.video import SourceError, is_stream_url
    from seawatch.pipeline import PipelineError, run_pipeline

    cfg = _load_settings(args)
    if args.quiet:
        from seawatch.config import apply_overrides

        cfg = apply_overrides(cfg, ["run.progress=false"])
    if args.out is not None:
        out = args.out
    else:
        name = "stream" if is_stream_url(args.source) else (Path(args.source).stem or "run")
        out = Path("out") / name
    try:
        summary = run_pipeline(args.source, cfg, out_dir=out, camera=args.camera, ptz=args.ptz, ais=args.ais)
    except (SourceError, PipelineError) as exc:
        raise CLIError(str(exc)) from None
    if not args.quiet:
        _print_run_summary(summary, out)
    if summary["frames_processed"] == 0:
        raise CLIError(f"{args.source}: no frame could be processed (see {out}/summary.json)")
    return EXIT_OK


# ------------------------------------------------------------------------- demo
def _add_demo(sub) -> None:  # owner: pipeline
    p = sub.add_parser(
        "demo",
        help="render the built-in harbour scene and run the whole pipeline on it",
        description=(
            "Render the synthetic 'harbour' scene (fixed camera, vessels with and without AIS, a "
            "coastline) with its AIS stream, run detector -> tracker -> AIS fusion on it, write the "
            "annotated video, MOT CSV, JSON Lines and summary.json to --out, and print a short "
            "summary with the scores against the scene's exact ground truth (HOTA, MOTA, IDF1)."
        ),
        formatter_class=_formatter,
    )
    p.add_argument("--out", type=Path, default=Path("seawatch-demo"), metavar="DIR",
                   help="output folder (default: seawatch-demo)")
    p.add_argument("--frames", type=int, default=0, metavar="N", help="render only the first N frames")
    p.add_argument("--scenario", default="harbour", metavar="NAME", help="scene to run (default: harbour)")
    p.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    _add_config_args(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _demo_evaluation(gt: dict, out_dir: Path, fused: bool) -> dict:  # owner: pipeline
    """Scores of the run's tracks and detections against the scene's ground truth."""
    import numpy as np

    from seawatch.io.results import read_jsonl, read_mot_csv

    try:
        from seawatch import eval as ev
    except ImportError:
        return {}
    frames = sorted(gt)
    g = {i: (gt[i][0], gt[i][1]) for i in frames}
    res: dict = {}
    trk_file, det_file = out_dir / "tracks.csv", out_dir / "detections.csv"
    if trk_file.is_file():
        mot = read_mot_csv(trk_file)
        fi = mot[:, 0].astype(np.int64) - 1
        pred = {i: (mot[fi == i, 1].astype(np.int64), mot[fi == i, 2:6]) for i in frames}
        if hasattr(ev, "score_tracks"):
            sc = ev.score_tracks(g, pred)
        else:
            sc = {**ev.clear_mot(g, pred), **ev.hota(g, pred), **ev.identity_metrics(g, pred)}
        res["tracks"] = {k: float(sc[k]) for k in ("HOTA", "MOTA", "IDF1", "MOTP", "IDSW", "FP", "FN",
                                                     "DetA", "AssA") if k in sc}
    if det_file.is_file() and hasattr(ev, "detection_metrics"):
        mot = read_mot_csv(det_file)
        fi = mot[:, 0].astype(np.int64) - 1
        pred = {i: (mot[fi == i, 2:6], mot[fi == i, 6]) for i in frames}
        d = ev.detection_metrics({i: g[i][1] for i in frames}, pred)
        res["detections"] = {k: float(d[k]) for k in ("TPR", "FAR", "precision", "F1") if k in d}
    if fused and (out_dir / "tracks.jsonl").is_file():
        # MMSI of the fused tracks vs the ground truth vessel they cover (IoU >= 0.5)
        from seawatch.track.sort import iou_matrix

        right = wrong = mislabelled = 0  # mislabelled: an MMSI that is not the vessel's (wrong also counts none)
        rows = [r for r in read_jsonl(out_dir / "tracks.jsonl") if r.get("state") == "confirmed"]
        for r in rows:
            if r["frame"] not in gt or not len(gt[r["frame"]][1]):
                continue
            iou = iou_matrix(np.array([r["box"]], float), gt[r["frame"]][1])[0]
            k = int(np.argmax(iou))
            if iou[k] < 0.5:
                continue
            true_mmsi = int(gt[r["frame"]][2][k])
            if r.get("mmsi", 0) == true_mmsi and true_mmsi:
                right += 1
            elif r.get("mmsi", 0) != true_mmsi:
                wrong += 1
                mislabelled += int(r.get("mmsi", 0) != 0)
        if right + wrong:
            res["fusion"] = {"mmsi_correct": right / (right + wrong), "mmsi_wrong": mislabelled / (right + wrong),
                             "track_frames": right + wrong}
    return res


def _cmd_demo(args) -> int:  # owner: pipeline
    import time

    import numpy as np

    from seawatch.config import apply_overrides
    from seawatch.io.results import write_summary
    from seawatch.io.video import IterableSource, SourceError
    from seawatch.pipeline import PipelineError, run_pipeline

    try:
        from seawatch.sim import SCENARIOS, make_scenario
    except ImportError as exc:
        raise CLIError(f"the simulator is not available ({exc})") from None
    if args.scenario not in SCENARIOS:
        raise CLIError(f"unknown scenario '{args.scenario}' (known: {', '.join(sorted(SCENARIOS))})")
    if args.frames < 0:
        raise CLIError(f"--frames must be >= 0, got {args.frames}")
    cfg = _load_settings(args)
    if args.quiet:
        cfg = apply_overrides(cfg, ["run.progress=false"])
    t0 = time.perf_counter()
    scn = make_scenario(args.scenario, seed=args.seed)
    n = min(args.frames, scn.n_frames) if args.frames else scn.n_frames
    out = args.out
    scene_dir = out / "scene"
    try:
        scene_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CLIError(f"output folder {out}: cannot write: {exc.strerror or exc}") from None
    # the scene's inputs beside the outputs: AIS as NMEA, the camera, the ground truth
    try:
        from seawatch.camera import save_camera

        save_camera(scn.camera, scene_dir / "camera.toml")
    except (ImportError, AttributeError):
        pass
    nmea = scn.ais_nmea()
    (scene_dir / "ais.nmea").write_text("".join(f"{t:.3f} {s}\n" for t, s in nmea), encoding="utf-8")
    gt: dict = {}
    gt_lines: list[str] = []

    def frames():
        for i in range(n):
            frame = scn.render(i)
            g = scn.ground_truth(i)
            seen = np.asarray(g.visible) > 0  # fully hidden vessels are listed with visible 0
            gt[i] = (g.ids[seen], g.boxes[seen].reshape(-1, 4), g.mmsi[seen])
            gt_lines.extend(f"{i + 1},{int(k)},{b[0]:.2f},{b[1]:.2f},{b[2]:.2f},{b[3]:.2f},1,-1,-1,-1\n"
                            for k, b in zip(gt[i][0], gt[i][1]))
            yield frame

    src = IterableSource(frames(), scn.fps, name=f"sim:{args.scenario} seed {args.seed}",
                         camera_id=cfg.run.camera_id, modality=scn.modality)
    try:
        summary = run_pipeline(src, cfg, out_dir=out, camera=scn.camera, ais=scn.ais_reports(),
                               total=n, progress=None if not args.quiet else False)
    except (SourceError, PipelineError) as exc:
        raise CLIError(str(exc)) from None
    (scene_dir / "gt.txt").write_text("".join(gt_lines), encoding="utf-8")
    evaluation = _demo_evaluation(gt, out, summary.get("fuser") is not None)
    summary["evaluation"] = evaluation
    summary["scene"] = {"name": args.scenario, "seed": args.seed, "frames": n, "fps": scn.fps,
                        "vessels": len(scn.vessels), "ais_sentences": len(nmea),
                        "files": {"camera": str(scene_dir / "camera.toml"), "ais": str(scene_dir / "ais.nmea"),
                                  "gt": str(scene_dir / "gt.txt")}}
    summary["demo_wall_s"] = round(time.perf_counter() - t0, 2)
    write_summary(out / "summary.json", summary)
    print(f"seawatch demo: scene '{args.scenario}' (seed {args.seed}), {n} frames of "
          f"{summary['image_size'][0]}x{summary['image_size'][1]} at {scn.fps:g} fps, "
          f"{len(scn.vessels)} vessels, {len(nmea)} AIS sentences")
    print(f"  pipeline: {summary['detector']} -> {summary['tracker']}"
          + (f" -> {summary['fuser']}" if summary.get("fuser") else "")
          + f"; {summary['processing_fps']:.1f} frames/s (render included), total {summary['demo_wall_s']:.1f} s")
    print(f"  {summary['detections']} detections, {summary['tracks']} tracks, {summary['alerts']} alerts")
    t = evaluation.get("tracks")
    if t:
        print(f"  vs ground truth: HOTA {t['HOTA']:.3f}  MOTA {t['MOTA']:.3f}  IDF1 {t['IDF1']:.3f}  "
              f"IDSW {int(t.get('IDSW', 0))}")
    d = evaluation.get("detections")
    if d:
        print(f"  detections: TPR {d['TPR']:.3f}  precision {d['precision']:.3f}  F1 {d['F1']:.3f}")
    f = evaluation.get("fusion")
    if f:
        print(f"  fusion: MMSI correct on {100 * f['mmsi_correct']:.1f}% of matched track frames, "
              f"a wrong MMSI on {100 * f.get('mmsi_wrong', 0.0):.1f}%")
    for note in summary.get("notes", [])[:5]:
        print(f"  note: {note}")
    print(f"  outputs in {out}/: annotated.mp4, tracks.csv, tracks.jsonl, detections.*, summary.json; scene in {scene_dir}/")
    return EXIT_OK


# -------------------------------------------------------------------------- sim
def _add_sim(sub) -> None:  # owner: pipeline (writes what seawatch.sim renders)
    p = sub.add_parser(
        "sim",
        help="render a synthetic scenario to video with exact ground truth and AIS",
        description=(
            "Render a named synthetic scenario (harbour, pan, ir, crossing, ...) into --out: "
            "video.mp4, gt.txt (MOTChallenge), gt.jsonl, ais.nmea, camera.toml and ptz.csv, ready "
            "for 'seawatch run DIR/video.mp4 --camera DIR/camera.toml --ptz DIR/ptz.csv --ais DIR/ais.nmea'."
        ),
        formatter_class=_formatter,
    )
    p.add_argument("name", nargs="?", metavar="NAME", help="scenario name (see --list)")
    p.add_argument("--out", type=Path, metavar="DIR", help="output folder (default: sim-<NAME>)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--width", type=int, help="image width in pixels (default: the scenario's)")
    p.add_argument("--height", type=int, help="image height in pixels (default: the scenario's)")
    p.add_argument("--duration", type=float, metavar="S", help="length in seconds (default: the scenario's)")
    p.add_argument("--fps", type=float, help="frame rate (default: the scenario's)")
    p.add_argument("--list", action="store_true", help="list the scenarios and exit")


def _cmd_sim(args) -> int:  # owner: pipeline
    try:
        from seawatch.sim import SCENARIOS, make_scenario
    except ImportError as exc:
        raise CLIError(f"the simulator is not available ({exc})") from None
    if args.list:
        for name in SCENARIOS:
            doc = SCENARIOS[name] if isinstance(SCENARIOS, dict) else ""
            doc = (getattr(doc, "__doc__", None) or (doc if isinstance(doc, str) else "") or "").strip()
            print(f"{name:16s} {doc.splitlines()[0] if doc else ''}")
        return EXIT_OK
    if not args.name:
        raise CLIError(f"give a scenario NAME ({', '.join(SCENARIOS)})")
    if args.name not in SCENARIOS:
        raise CLIError(f"unknown scenario '{args.name}' (known: {', '.join(SCENARIOS)})")
    if (args.width is None) != (args.height is None):
        raise CLIError("give both --width and --height")
    kw = {}
    if args.width is not None:
        if args.width < 16 or args.height < 16:
            raise CLIError(f"image size {args.width}x{args.height} is too small")
        kw.update(width=args.width, height=args.height)
    if args.duration is not None:
        if args.duration <= 0:
            raise CLIError(f"--duration must be positive, got {args.duration}")
        kw["duration_s"] = args.duration
    if args.fps is not None:
        if args.fps <= 0:
            raise CLIError(f"--fps must be positive, got {args.fps}")
        kw["fps"] = args.fps
    out = args.out or Path(f"sim-{args.name}")
    scn = make_scenario(args.name, seed=args.seed, **kw)
    scn.write(out)
    print(f"seawatch sim: {args.name} (seed {args.seed}), {scn.n_frames} frames at {scn.fps:g} fps -> {out}/")
    for f in sorted(Path(out).iterdir()):
        print(f"  {f.name}")
    return EXIT_OK


# ------------------------------------------------------------------------- eval
def _add_eval(sub) -> None:  # owner: evaluation
    p = sub.add_parser(
        "eval",
        help="score predictions against ground truth and write a report",
        description=(
            "Score detections or tracks against ground truth: detection (TPR, FAR, F1, by box size, "
            "precision-recall), CLEAR MOT (MOTChallenge and VACE), HOTA, IDF1, METE/MELT, and "
            "OSPA/GOSPA when both files carry world positions. Prints the headline table; with "
            "--out writes report.md, report.json and plots. Formats: mot (MOTChallenge CSV), mardct "
            "(folder of 'boat x y w h' files), fvessel, coral (labels.csv), argos (XML), jsonl "
            "(seawatch JSON Lines); 'auto' guesses from the name."
        ),
        formatter_class=_formatter,
    )
    p.add_argument("--gt", required=True, type=Path, help="ground-truth file or folder")
    p.add_argument("--pred", required=True, type=Path, help="predictions (detections or tracks)")
    fmts = ["auto", "mot", "mardct", "fvessel", "coral", "argos", "jsonl"]
    p.add_argument("--format", default="auto", choices=fmts, help="ground-truth format (default: auto)")
    p.add_argument("--pred-format", default="auto", choices=fmts, help="prediction format (default: auto)")
    p.add_argument("--iou", type=float, default=0.5, help="IoU threshold of a match (default 0.5; 0.3 for small targets)")
    p.add_argument("--frame-offset", type=int, default=0,
                   help="subtracted from ground-truth frame numbers (MarDCT video2: 1300)")
    p.add_argument("--frames", choices=["auto", "gt", "union"], default="auto",
                   help="frames scored: gt = annotated frames only, union = frames of either file "
                        "(auto: gt for sparsely annotated mardct/coral/argos, else union)")
    p.add_argument("--images", type=Path, help="CORAL image folder (unlabelled images count as frames)")
    p.add_argument("--camera-id", help="keep only this camera's rows of JSON Lines input")
    p.add_argument("--ospa-cutoff-m", type=float, default=50.0, help="OSPA/GOSPA cut-off in metres (default 50)")
    p.add_argument("--ospa-p", type=float, default=1.0, help="OSPA/GOSPA order (default 1)")
    p.add_argument("--out", type=Path, help="write report.md, report.json and plots here")
    p.add_argument("--no-plots", action="store_true", help="skip the plots")


def _cmd_eval(args) -> int:  # owner: evaluation
    from seawatch.eval.report import evaluate, format_summary, write_report
    from seawatch.io.gt import _guess_format, read_annotations

    if not 0.0 < args.iou <= 1.0:
        raise CLIError(f"--iou must be in (0, 1], got {args.iou}")

    def load(path, fmt, role):
        if not path.exists():
            raise CLIError(f"--{role} {path}: not found")
        fmt = _guess_format(path) if fmt == "auto" else fmt
        kw = {}
        if fmt in ("mardct", "argos") and role == "gt":
            kw["frame_offset"] = args.frame_offset
        if fmt == "mot" and role == "gt":
            kw["ignore_zero_conf"] = True
        if fmt == "coral" and args.images is not None:
            kw["image_dir"] = args.images
        if fmt == "jsonl" and args.camera_id:
            kw["camera_id"] = args.camera_id
        try:
            ann = read_annotations(path, fmt, **kw)
        except (ValueError, OSError) as exc:
            raise CLIError(f"--{role} {path}: {exc}") from exc
        if ann.errors:
            print(f"seawatch eval: {len(ann.errors)} malformed row(s) skipped in {path}:", file=sys.stderr)
            for e in ann.errors[:5]:
                print(f"  {e}", file=sys.stderr)
            if len(ann.errors) > 5:
                print(f"  ... and {len(ann.errors) - 5} more", file=sys.stderr)
        return ann, fmt

    gt, gt_fmt = load(args.gt, args.format, "gt")
    pred, pred_fmt = load(args.pred, args.pred_format, "pred")
    mode = args.frames
    if mode == "auto":
        mode = "gt" if gt_fmt in ("mardct", "coral", "argos") else "union"
    frames = gt.frames if mode == "gt" else None
    try:
        res = evaluate(gt, pred, iou=args.iou, frames=frames, ospa_cutoff_m=args.ospa_cutoff_m, ospa_p=args.ospa_p)
    except ValueError as exc:
        raise CLIError(str(exc)) from exc
    print(format_summary(res, title=f"seawatch eval: {args.pred} against {args.gt}"))
    if args.out is not None:
        meta = {"ground truth": f"{args.gt} ({gt_fmt}, {len(gt)} rows, {len(gt.errors)} malformed)",
                "predictions": f"{args.pred} ({pred_fmt}, {len(pred)} rows, {len(pred.errors)} malformed)",
                "frames": mode, "command": "seawatch " + " ".join(sys.argv[1:])}
        paths = write_report(res, args.out, meta=meta, plots=not args.no_plots)
        print(f"report: {paths[0]} ({len(paths)} files in {args.out})")
    return EXIT_OK


# ---------------------------------------------------------------- train-cascade
def _add_train_cascade(sub) -> None:  # owner: cascade trainer
    p = sub.add_parser(
        "train-cascade",
        help="train a boosted Haar cascade and write OpenCV cascade XML",
        description=(
            "Train a boosted cascade of Haar stumps (Gentle AdaBoost, hard-negative mining, an optional\n"
            "last wake stage) and write it in OpenCV's cascade XML, with a JSON beside it (box convention,\n"
            "training record). Default: seawatch's boat cascade recipe from --data (MarDCT training frames,\n"
            "CORAL D1, simulator frames; MarDCT video2 is never used), with min_neighbors chosen on a\n"
            "validation part. With --frames DIR: train on annotated frames <name>.png + <name>.txt\n"
            "('label x y w h' per line) from DIR instead. --out is required; a model shipped in\n"
            "seawatch/models/ is overwritten only with --force (seawatch/models/PROVENANCE.md gives\n"
            "the commands that reproduce each shipped model)."
        ),
        formatter_class=_formatter,
    )
    p.add_argument("--data", type=Path, help="data directory (default: ../shared/data beside the repository)")
    p.add_argument("--frames", type=Path, help="train on the annotated frames in this folder instead")
    p.add_argument("--out", type=Path, default=None,
                   help="output XML, required, e.g. /tmp/cv/boat_cascade.xml (its JSON is written beside it)")
    p.add_argument("--force", action="store_true",
                   help="allow --out to overwrite a model shipped in seawatch/models/ (refused without it)")
    p.add_argument("--stages", type=int, default=20, help="maximum number of stages before the wake stage (20)")
    p.add_argument("--min-hit-rate", type=float, default=0.995, help="per-stage minimum hit rate (0.995)")
    p.add_argument("--max-false-alarm", type=float, default=0.5, help="per-stage maximum false-alarm rate (0.5)")
    p.add_argument("--max-weak-count", type=int, default=100, help="most stumps per stage (100)")
    p.add_argument("--early-weak-counts", default="",
                   help="most stumps in each of the first stages, comma-separated, e.g. 8,12,16 (default: none)")
    p.add_argument("--features-per-stage", type=int, default=6000, help="random Haar features tried per stage (6000)")
    p.add_argument("--max-positives", type=int, default=6000, help="most positive windows after augmentation (6000)")
    p.add_argument("--window", default="60x30", help="window WIDTHxHEIGHT in pixels (60x30)")
    p.add_argument("--feature-step-px", type=int, default=2,
                   help="grid of the Haar features' positions and sizes, pixels (2; 1 suits a 30x15 window)")
    p.add_argument("--time-budget-s", type=float, default=1800.0, help="stop adding stages after this many seconds")
    p.add_argument("--no-sim", action="store_true", help="do not use simulator frames")
    p.add_argument("--no-wake-stage", action="store_true", help="do not train the last wake stage")
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--lowres-prob", type=float, default=0.5,
                   help="share of augmented positives rendered as far boats of about 20-50 px (0.5)")
    p.add_argument("--scale-jitter", type=float, default=0.08,
                   help="augmented positives: window scale drawn log-uniformly in +-this (natural log) (0.08)")
    p.add_argument("--shift-jitter", type=float, default=0.06,
                   help="augmented positives: centre shifted by up to +-this share of the window's width and "
                        "height (0.06)")
    p.add_argument("--scan-mining-stages", type=int, default=0,
                   help="the first N stages take their negatives from every window the detector scans on the "
                        "training images (automatic detection scale, pyramid, water region) (0)")
    p.add_argument("--grid-modes", default="0",
                   help="grids of window positions the settings are chosen for, comma-separated: 0 (OpenCV's: "
                        "1 px from pyramid scale 2 on), 2 (2 px at every scale); the higher validation score "
                        "wins, a tie within 0.005 goes to 2 (0)")
    p.add_argument("--select-only", action="store_true",
                   help="do not train: choose the detector settings of the model at --out again on the "
                        "validation part of --data (its JSON is updated)")
    p.add_argument("--select-on", choices=("mardct", "all"), default="mardct",
                   help="validation images the detector settings are chosen on: mardct (the MarDCT "
                        "validation frames only, the rule of session 11) or all (MarDCT, simulator and "
                        "CORAL, session 10); the others are reported (mardct)")


def _cmd_train_cascade(args) -> int:  # owner: cascade trainer
    import dataclasses

    from seawatch.train.trainer import TrainSettings

    try:
        ww, wh = (int(v) for v in str(args.window).lower().split("x"))
    except ValueError:
        raise CLIError(f"--window {args.window!r}: expected WIDTHxHEIGHT, e.g. 60x30") from None
    if ww < 8 or wh < 8:
        raise CLIError(f"--window {args.window}: at least 8x8 pixels")
    try:
        early = tuple(int(v) for v in str(args.early_weak_counts).split(",") if v.strip())
    except ValueError:
        raise CLIError(f"--early-weak-counts {args.early_weak_counts!r}: expected integers like 4,8,16") from None
    if not 0.0 <= args.lowres_prob <= 1.0:
        raise CLIError(f"--lowres-prob {args.lowres_prob}: expected a probability in [0, 1]")
    if not 0.0 <= args.scale_jitter <= 1.0:
        raise CLIError(f"--scale-jitter {args.scale_jitter}: expected a log-scale half-range in [0, 1]")
    if not 0.0 <= args.shift_jitter <= 0.5:
        raise CLIError(f"--shift-jitter {args.shift_jitter}: expected a share of the window in [0, 0.5]")
    if args.feature_step_px < 1:
        raise CLIError(f"--feature-step-px {args.feature_step_px}: at least 1")
    if args.scan_mining_stages < 0:
        raise CLIError(f"--scan-mining-stages {args.scan_mining_stages}: at least 0")
    try:
        grid_modes = tuple(int(v) for v in str(args.grid_modes).split(",") if v.strip())
    except ValueError:
        grid_modes = ()
    if not grid_modes or any(g not in (0, 2) for g in grid_modes):
        raise CLIError(f"--grid-modes {args.grid_modes!r}: expected 0, 2 or 0,2")
    s = TrainSettings(
        early_weak_counts=early,
        feature_pos_step_px=args.feature_step_px, feature_size_step_px=args.feature_step_px,
        width_px=ww, height_px=wh, n_stages=args.stages, min_hit_rate=args.min_hit_rate,
        max_false_alarm=args.max_false_alarm, max_weak_count=args.max_weak_count,
        features_per_stage=args.features_per_stage, max_positives=args.max_positives,
        wake_stage=not args.no_wake_stage, time_budget_s=args.time_budget_s, seed=args.seed,
        lowres_prob=args.lowres_prob, scan_mining_stages=args.scan_mining_stages,
        scale_jitter=args.scale_jitter, shift_jitter=args.shift_jitter,
    )
    out = args.out
    if out is None:
        raise CLIError("--out is required: the output XML, e.g. --out /tmp/cv/boat_cascade.xml (a path outside "
                       "seawatch/models/, whose boat_cascade.xml is the shipped default)")
    from seawatch.detect.cascade import default_model_path

    shipped = default_model_path().parent.resolve()
    out_r = Path(out).resolve()
    if (shipped in out_r.parents and not args.force
            and any(q.exists() for q in (out_r, out_r.with_suffix(".json")))):
        raise CLIError(f"--out {out}: would overwrite a model shipped in {shipped} "
                       f"({'its JSON' if args.select_only else 'XML and JSON'}); give another path, e.g. "
                       f"/tmp/cv/{out_r.name}, or --force")
    command = "seawatch " + " ".join(sys.argv[1:])
    if args.frames is not None:
        from seawatch.train.samples import load_mardct_frames
        from seawatch.train.trainer import train_cascade

        images = load_mardct_frames(args.frames)
        if not images:
            raise CLIError(f"--frames {args.frames}: no annotated <name>.png + <name>.txt pairs")
        train_cascade(images, out, dataclasses.replace(s))
        return EXIT_OK
    from seawatch.eval.bench import default_data_dir
    from seawatch.train.recipe import train_default_model

    data = args.data if args.data is not None else default_data_dir()
    if data is None or not Path(data).is_dir():
        raise CLIError("no data directory: give --data DIR (the layout of ../shared/data)")
    if args.select_only:
        from seawatch.train.recipe import reselect_model

        if not Path(out).is_file():
            raise CLIError(f"--select-only: no model at {out}")
        reselect_model(out, data, use_sim=not args.no_sim, seed=args.seed, command=command,
                       select_on=args.select_on, grid_modes=grid_modes)
        return EXIT_OK
    train_default_model(data, out, s, use_sim=not args.no_sim, command=command, select_on=args.select_on,
                        grid_modes=grid_modes)
    return EXIT_OK


# ------------------------------------------------------------------------ sweep
def _add_sweep(sub) -> None:  # owner: stable-features tracker
    p = sub.add_parser(
        "sweep",
        help="parameter sensitivity study of the stable-features tracker",
        description=(
            "The parameter study of the stable-features tracker (paper B, Fig. 3): Dmax is varied "
            "over [0, 1] and alpha and Wlink over [1, 50], one at a time, the others at their "
            "defaults; the mean METE of every setting on every sequence is computed, a Welch ANOVA "
            "per parameter tests whether the setting matters, and mean METE is plotted against each "
            "parameter. The features of each sequence are extracted once (the three parameters only "
            "act on the clustering). Sequences: the simulator's scenarios (--scenario, default pan "
            "and ir) and videos with MarDCT annotations (--video with --gt). Writes sweep.csv, "
            "sweep.json and sweep.png to --out."
        ),
        epilog=(
            "examples:\n"
            "  seawatch sweep --out out/sweep\n"
            "  seawatch sweep --scenario pan --video ../shared/data/mardct/video2-clipped-start-at-3300.avi \\\n"
            "      --gt ../shared/data/mardct/video2_gt --gt-offset 1300 --steps 6\n"
            "  seawatch sweep --param dmax=0.1,0.2,0.31,0.5 --param alpha=1,3,10"
        ),
        formatter_class=_formatter,
    )
    p.add_argument("--scenario", action="append", metavar="NAME",
                   help="simulator scenario (repeatable; default: pan and ir; 'none' for no scenario)")
    p.add_argument("--seed", type=int, default=0, help="scenario seed (default 0)")
    p.add_argument("--fps", type=float, default=0.0, help="scenario frame rate (default: the scenario's)")
    p.add_argument("--duration-s", type=float, default=0.0, help="scenario length in s (default: the scenario's)")
    p.add_argument("--video", action="append", type=Path, default=[], metavar="FILE",
                   help="a video to add (repeatable, each with a --gt)")
    p.add_argument("--gt", action="append", type=Path, default=[], metavar="DIR",
                   help="MarDCT annotation folder of the --video at the same position")
    p.add_argument("--gt-offset", action="append", type=int, default=[], metavar="N",
                   help="annotation N is video frame N - offset (default 0; 1300 for MarDCT video2)")
    p.add_argument("--steps", type=int, default=11, help="settings per parameter (default 11)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="sweep NAME (dmax, alpha, w_link or another ClusterParams field) over these values "
                        "instead of the default grid (repeatable; then only the named ones are swept)")
    _add_config_args(p)
    p.add_argument("--out", type=Path, default=Path("out/sweep"), metavar="DIR", help="output folder (default out/sweep)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def _cmd_sweep(args) -> int:  # owner: stable-features tracker
    import dataclasses

    from seawatch.config import load_config
    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.track.feature_clusters import ClusterParams
    from seawatch.track.sweep import (
        SweepSequence, default_grid, extract_features, plot_sweep, sweep, welch_anova,
    )

    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, flush=True))
    cfg = load_config(args.config, args.overrides).tracker
    base = ClusterParams(dmax=cfg.sf_dmax, alpha=cfg.sf_alpha, w_link=cfg.sf_w_link,
                         radius_px=cfg.sf_radius_px, min_speed_px_s=cfg.sf_min_speed_px_s)
    grid = default_grid(args.steps)
    if args.param:
        fields = {f.name for f in dataclasses.fields(ClusterParams)}
        grid = {}
        for item in args.param:
            name, _, vals = item.partition("=")
            name = name.strip()
            if name not in fields:
                raise CLIError(f"--param {item}: unknown parameter '{name}' (one of {', '.join(sorted(fields))})")
            try:
                grid[name] = [float(v) for v in vals.split(",") if v.strip()]
            except ValueError:
                raise CLIError(f"--param {item}: values must be numbers separated by commas") from None
            if not grid[name]:
                raise CLIError(f"--param {item}: no values")
    if len(args.gt) != len(args.video):
        raise CLIError(f"{len(args.video)} --video but {len(args.gt)} --gt: give one annotation folder per video")
    offsets = list(args.gt_offset) + [0] * (len(args.video) - len(args.gt_offset))

    def extractor(fps):
        return StableFeatureExtractor(max_keypoints=cfg.sf_max_keypoints, nominal_fps=fps or 25.0)

    sequences = []
    scenarios = args.scenario if args.scenario else ["pan", "ir"]
    scenarios = [s for s in scenarios if s.lower() != "none"]
    if scenarios:
        from seawatch.sim import SCENARIOS, make_scenario

        for name in scenarios:
            if name not in SCENARIOS:
                raise CLIError(f"--scenario {name}: unknown scenario (one of {', '.join(SCENARIOS)})")
            scn = make_scenario(name, seed=args.seed, fps=args.fps or None, duration_s=args.duration_s or None)
            say(f"[sweep] {name}: extracting features from {scn.n_frames} frames")
            gt = {}

            def frames(scn=scn, gt=gt):
                for f, g in scn.iter_frames():
                    vis = g.visible > 0
                    gt[f.index] = (g.ids[vis], g.boxes[vis])
                    yield f

            snaps = extract_features(frames(), extractor(scn.fps), camera=scn.camera)
            sequences.append(SweepSequence(f"sim:{name}", snaps, gt))
    for video, gt_dir, off in zip(args.video, args.gt, offsets):
        from seawatch.io.gt import read_mardct
        from seawatch.io.video import open_source

        ann = read_mardct(gt_dir, frame_offset=off)
        src = open_source(video)
        say(f"[sweep] {video.name}: extracting features ({len(ann.frames)} annotated frames)")
        try:
            snaps = extract_features(iter(src), extractor(src.fps))
        finally:
            src.close()
        have = {s.frame_index for s in snaps}
        gt = {k: v for k, v in ann.per_frame().items() if k in have}
        if not gt:
            raise CLIError(f"--gt {gt_dir}: no annotated frame falls in {video} (check --gt-offset)")
        sequences.append(SweepSequence(video.stem, snaps, gt))
    if not sequences:
        raise CLIError("no sequence: give --scenario and/or --video with --gt")
    res = sweep(sequences, grid, base, progress=lambda line: say(f"[sweep] {line}"))
    anova = welch_anova(res)
    paths = res.write(args.out)
    paths.append(plot_sweep(res, Path(args.out) / "sweep.png"))
    print(f"{'parameter':10s} {'best':>8s} {'Welch F':>9s} {'p':>9s}  settings x sequences")
    for p, a in anova.items():
        print(f"{p:10s} {res.best(p):8g} {a['F']:9.3f} {a['p']:9.3g}  {a['k']} x {a['n']}")
    print("wrote " + ", ".join(str(x) for x in paths))
    return EXIT_OK


# --------------------------------------------------------------------------------------- bench
def _add_bench(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="run the speed and accuracy benchmarks and print one table",
        description=(
            "Run the benchmark suite (benchmarks/bench_*.py) on the real data in --data (default "
            "../shared/data beside the repository) and on the synthetic scenarios. Prints one "
            "table, appends every figure to benchmarks/results/<benchmark>.jsonl and writes the "
            "latest figures to benchmarks/results/<benchmark>.json."
        ),
        formatter_class=_formatter,
    )
    p.add_argument("--only", action="append", metavar="NAME", help="run only this benchmark (repeatable)")
    p.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    p.add_argument("--data", type=Path, help="data directory (default: ../shared/data when present)")
    p.add_argument("--results", type=Path, help="results directory (default: benchmarks/results)")
    p.add_argument("--quick", action="store_true", help="fewer repeats and frames, for a smoke run")


def _cmd_bench(args) -> int:
    from seawatch.eval.bench import default_data_dir, discover, format_table, run_benchmarks

    if args.list:
        for name, mod in discover().items():
            print(f"{name:24s} {getattr(mod, 'DESCRIPTION', '')}")
        return EXIT_OK
    data = args.data if args.data is not None else default_data_dir()
    if args.data is not None and not args.data.is_dir():
        raise CLIError(f"--data {args.data}: not a directory")
    rows = run_benchmarks(
        only=args.only, data_dir=data, results_dir=args.results, quick=args.quick,
        command="seawatch " + " ".join(sys.argv[1:]),
    )
    print()
    print(format_table(rows))
    return EXIT_OK


# -------------------------------------------------------------------------- ais
def _add_ais(sub) -> None:  # owner: fusion
    p = sub.add_parser(
        "ais",
        help="decode and inspect AIS (NMEA file, FVessel/Solent CSV, or a live udp:// / tcp:// stream)",
        description=(
            "Decode AIS from a file or folder (NMEA 0183 !AIVDM/!AIVDO with optional tag-block or leading\n"
            "time stamps; FVessel snapshot CSVs; Stone Soup Solent CSV) or listen to a stream\n"
            "(udp://HOST:PORT binds, tcp://HOST:PORT connects) and print what was read: counts, rejected\n"
            "input with reasons and the first messages, and one line per vessel. --jsonl writes every\n"
            "decoded report as JSON Lines."
        ),
        formatter_class=_formatter,
    )
    p.add_argument("source", help="file, folder, udp://HOST:PORT or tcp://HOST:PORT")
    p.add_argument("--listen-s", type=float, default=10.0, help="seconds to listen to a stream (10)")
    p.add_argument("--show", type=int, default=0, metavar="N", help="print the first N reports")
    p.add_argument("--jsonl", type=Path, help="write the decoded reports to this JSON Lines file")
    p.add_argument("--errors", type=int, default=5, metavar="N", help="print up to N rejection messages (5)")


def _cmd_ais(args) -> int:  # owner: fusion
    import dataclasses
    import json
    import math
    import time as _time

    from seawatch.io.ais import AISListener, read_ais

    src = str(args.source)
    if src.startswith(("udp://", "tcp://")):
        try:
            lis = AISListener(src, reconnect_s=1.0)
        except (ValueError, OSError) as exc:
            raise CLIError(f"{src}: {exc}") from None
        reports = []
        try:
            t_end = _time.monotonic() + args.listen_s
            while _time.monotonic() < t_end:
                _time.sleep(0.2)
                reports += lis.poll()
        finally:
            lis.close()
        reports += lis.poll()
        stats = lis.stats
        for e in lis.errors[:3]:
            print(f"seawatch ais: {e}", file=sys.stderr)
    else:
        try:
            reports, stats = read_ais(src)
        except ValueError as exc:
            raise CLIError(str(exc)) from None
    print(f"{src}: {stats.summary()}")
    for m in stats.messages_log[: max(0, args.errors)]:
        print(f"  rejected: {m}")
    vessels: dict[int, dict] = {}
    for r in reports:
        v = vessels.setdefault(r.mmsi, {"n": 0, "t0": r.t_s, "t1": r.t_s, "name": None, "type": None, "last": None})
        v["n"] += 1
        v["t0"], v["t1"] = min(v["t0"], r.t_s), max(v["t1"], r.t_s)
        v["name"] = r.name or v["name"]
        v["type"] = r.ship_type or v["type"]
        if r.has_position:
            v["last"] = (r.lat_deg, r.lon_deg, r.sog_kn, r.cog_deg)
    print(f"{len(vessels)} vessels")
    for mmsi, v in sorted(vessels.items()):
        last = v["last"]
        pos = (f"{last[0]:.5f} {last[1]:.5f} {last[2]:.1f} kn {last[3]:.0f} deg" if last and math.isfinite(last[2])
               and math.isfinite(last[3]) else (f"{last[0]:.5f} {last[1]:.5f}" if last else "no position"))
        print(f"  {mmsi:9d}  {v['n']:6d} reports  {v['t1'] - v['t0']:8.0f} s  {str(v['name'] or ''):20s} "
              f"type {v['type'] or '-':>3}  {pos}")
    for r in reports[: max(0, args.show)]:
        print(f"  {r}")
    if args.jsonl is not None:
        with open(args.jsonl, "w", encoding="utf-8") as fh:
            for r in reports:
                d = {k: (None if isinstance(x, float) and not math.isfinite(x) else x)
                     for k, x in dataclasses.asdict(r).items()}
                fh.write(json.dumps(d) + "\n")
        print(f"wrote {len(reports)} reports to {args.jsonl}")
    return EXIT_OK


# ----------------------------------------------------------------------------------- the parser
COMMANDS = ["run", "demo", "sim", "eval", "bench", "train-cascade", "sweep", "ais"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="seawatch",
        description=(
            "seawatch: detect and track vessels in EO/IR video, fuse them with AIS and radar, "
            "and flag vessels that AIS does not report."
        ),
        formatter_class=_formatter,
    )
    parser.add_argument("--version", action="version", version=f"seawatch {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        globals()[f"_add_{name.replace('-', '_')}"](sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.command:
        parser.print_help()
        return EXIT_USAGE
    func = globals()[f"_cmd_{args.command.replace('-', '_')}"]
    try:
        return int(func(args) or 0)
    except (CLIError, ConfigError, FileNotFoundError) as exc:
        print(f"seawatch {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except KeyboardInterrupt:
        print(f"seawatch {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
