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
    sub.add_parser("demo", help="render the built-in harbour scene and run the whole pipeline on it", formatter_class=_formatter)


def _cmd_demo(args) -> int:  # owner: pipeline
    raise CLIError("not available yet")


# -------------------------------------------------------------------------- sim
def _add_sim(sub) -> None:  # owner: simulator
    sub.add_parser("sim", help="render a synthetic scenario to video with exact ground truth and AIS", formatter_class=_formatter)


def _cmd_sim(args) -> int:  # owner: simulator
    raise CLIError("not available yet")


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
    sub.add_parser("train-cascade", help="train a boosted Haar cascade and write OpenCV cascade XML", formatter_class=_formatter)


def _cmd_train_cascade(args) -> int:  # owner: cascade trainer
    raise CLIError("not available yet")


# ------------------------------------------------------------------------ sweep
def _add_sweep(sub) -> None:  # owner: stable-features tracker
    sub.add_parser("sweep", help="parameter sensitivity study of the stable-features tracker", formatter_class=_formatter)


def _cmd_sweep(args) -> int:  # owner: stable-features tracker
    raise CLIError("not available yet")


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


# ----------------------------------------------------------------------------------- the parser
COMMANDS = ["run", "demo", "sim", "eval", "bench", "train-cascade", "sweep"]


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
