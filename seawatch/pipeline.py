"""The pipeline: sources -> detector -> tracker -> [fuser] -> sinks.  No algorithm code here.

Stages plug in through small interfaces (``seawatch.types``):

* a :class:`~seawatch.types.Detector` (``detect(frame) -> Detections``) and a
  :class:`~seawatch.types.Tracker` (``update(detections, frame) -> Tracks``), or one
  :class:`~seawatch.types.DetectorTracker` (``process(frame) -> (Detections, Tracks)``);
* an optional **fuser**: any object with ``update(tracks, frame, t_s) -> (tracks, alerts)`` that
  returns the tracks with ``mmsi`` (and optionally ``world`` and a ``names`` list attribute) filled
  in, and a list of alerts (dicts or dataclasses, e.g. "camera sees a vessel that AIS does not
  report");
* sinks (``write(frame, detections, tracks, alerts, camera)`` and ``close()``), see
  :mod:`seawatch.io.results`.

Stages are built by name from the configuration (``detector.kind``, ``tracker.kind``) through
:data:`DETECTORS` and :data:`TRACKERS`, importing their modules lazily.  A stage class is built
with ``cls.from_config(config, fps=..., camera=...)`` when it has that class method, otherwise
with ``cls()``.  The fuser is built by ``seawatch.fuse.build_fuser(config, ais=..., camera=...,
fps=...)`` when that function exists.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Protocol

import numpy as np

from seawatch.config import Config, ConfigError, config_to_dict
from seawatch.detect.blobs import boxes_azel
from seawatch.types import Detections, Frame, Tracks, TrackState

__all__ = [
    "DETECTORS",
    "TRACKERS",
    "Fuser",
    "Pipeline",
    "StepResult",
    "build_detector",
    "build_tracker",
    "build_fuser",
    "check_settings",
    "open_ais",
    "AISInput",
    "make_sinks",
    "run_pipeline",
    "PipelineError",
]

# kind -> "module:Class".  Classes are imported only when chosen.
DETECTORS: dict[str, str] = {
    "mog2": "seawatch.detect.mog2:Mog2Detector",
    "cascade": "seawatch.detect.cascade:CascadeDetector",
    "robust_kalman": "seawatch.detect.background:RobustKalmanDetector",
    "stable_features": "seawatch.track.feature_clusters:StableFeatureTracker",
}
TRACKERS: dict[str, str] = {
    "sort": "seawatch.track.sort:SortTracker",
    "ptracking": "seawatch.track.ptracking:PTrackingTracker",
    "stable_features": "seawatch.track.feature_clusters:StableFeatureTracker",
}
JOINT = {"stable_features"}  # kinds that detect and track at once (DetectorTracker)


class PipelineError(Exception):
    """A pipeline that cannot be built or run; the message names the cause."""


class Fuser(Protocol):
    """The fusion hook: attaches AIS identities to camera tracks and raises alerts.

    ``update`` receives the camera tracks of one frame (all states), the frame (with its pose
    and PTZ state) and the frame time, and returns the same tracks with ``mmsi`` filled where a
    track is associated with an AIS vessel (0 elsewhere; optionally ``world`` and a ``names``
    attribute, a list of vessel names or None, same order) and a list of alerts.
    """

    def update(self, tracks: Tracks, frame: Frame, t_s: float) -> tuple[Tracks, list]: ...


@dataclass
class StepResult:
    """What one frame produced."""

    detections: Detections
    tracks: Tracks
    alerts: list = field(default_factory=list)


# ------------------------------------------------------------------------------ registry
def _resolve(kind: str, registry: dict[str, str], what: str):
    if kind not in registry:
        raise ConfigError(f"{what}.kind: unknown {what} '{kind}' (known: {', '.join(sorted(registry))})")
    modname, clsname = registry[kind].split(":")
    try:
        mod = importlib.import_module(modname)
    except ImportError as exc:
        raise PipelineError(f"{what} '{kind}' is not available ({modname}: {exc})") from None
    cls = getattr(mod, clsname, None)
    if cls is None:  # the class may have another name: take the one whose .name is the kind
        for obj in vars(mod).values():
            if inspect.isclass(obj) and getattr(obj, "name", None) == kind and obj.__module__ == modname:
                cls = obj
                break
    if cls is None:
        raise PipelineError(f"{what} '{kind}': {modname} has no {clsname}")
    return cls


def _construct(cls, config: Config, fps: float, camera):
    """``cls.from_config(config, fps=..., camera=...)`` (passing only the keywords it accepts),
    else ``cls.from_settings(section)`` (the tracker section for a kind that is a tracker, else
    the detector section), else ``cls()``."""
    if not hasattr(cls, "from_config"):
        if hasattr(cls, "from_settings"):
            kind = getattr(cls, "name", "")
            return cls.from_settings(config.tracker if kind in TRACKERS else config.detector)
        return cls()
    kwargs = {"fps": fps, "camera": camera}
    try:
        params = inspect.signature(cls.from_config).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return cls.from_config(config, **kwargs)
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        kwargs = {k: v for k, v in kwargs.items() if k in params}
    return cls.from_config(config, **kwargs)


def _build(kind: str, registry: dict[str, str], what: str, config: Config, fps: float, camera):
    cls = _resolve(kind, registry, what)
    try:
        return _construct(cls, config, fps, camera)
    except (ValueError, TypeError) as exc:  # a setting the stage rejects: name the stage
        raise ConfigError(f"[{what}] kind '{kind}': {exc}") from None


def build_detector(config: Config, fps: float, camera=None):
    """The detector (or DetectorTracker) named by ``config.detector.kind``."""
    return _build(config.detector.kind, DETECTORS, "detector", config, fps, camera)


def build_tracker(config: Config, fps: float, camera=None):
    """The tracker named by ``config.tracker.kind``."""
    return _build(config.tracker.kind, TRACKERS, "tracker", config, fps, camera)


def check_settings(config: Config) -> None:
    """Reject values of the ``[run]`` and ``[output]`` settings that cannot work.

    Raises
    ------
    ConfigError
        Naming the key and the allowed values.
    """
    r, o = config.run, config.output
    if r.modality not in ("EO", "IR"):
        raise ConfigError(f"[run] key 'modality': expected 'EO' or 'IR', got {r.modality!r}")
    if r.fps < 0:
        raise ConfigError(f"[run] key 'fps': expected >= 0 (0: the source's), got {r.fps}")
    if r.max_frames < 0:
        raise ConfigError(f"[run] key 'max_frames': expected >= 0 (0: all), got {r.max_frames}")
    if r.max_bad_frames_in_row < 1:
        raise ConfigError(f"[run] key 'max_bad_frames_in_row': expected >= 1, got {r.max_bad_frames_in_row}")
    if len(o.video_codec) != 4:
        raise ConfigError(f"[output] key 'video_codec': expected a 4-character FourCC such as 'mp4v', got {o.video_codec!r}")


@dataclass
class AISInput:
    """AIS for a run: every report of a file (time-sorted), or a live listener (``poll()``)."""

    name: str
    reports: list | None = None
    listener: Any = None
    stats: Any = None  # seawatch.io.ais.AISStats

    @property
    def data(self):
        """What the fuser gets: the report list, or the listener."""
        return self.listener if self.listener is not None else self.reports

    def close(self) -> None:
        if self.listener is not None:
            self.listener.close()


def open_ais(ais) -> AISInput | None:
    """Read (file or folder) or start listening to (``udp://``/``tcp://``) an AIS source with
    :mod:`seawatch.io.ais`; a list of :class:`~seawatch.types.AISReport` is taken as is.

    Raises
    ------
    SourceError
        Missing or unreadable file, malformed URL, port that cannot be bound.
    """
    from seawatch.io.video import SourceError

    if ais is None:
        return None
    if isinstance(ais, (list, tuple)):
        return AISInput("reports", reports=sorted(ais, key=lambda r: r.t_s))
    from seawatch.io import ais as aisio

    name = str(ais)
    if re.match(r"^(udp|tcp)://", name, re.IGNORECASE):
        try:
            return AISInput(name, listener=aisio.AISListener(name))
        except (ValueError, OSError) as exc:
            raise SourceError(f"AIS stream {name}: {exc}") from None
    try:
        reports, stats = aisio.read_ais(name)
    except FileNotFoundError:
        raise SourceError(f"AIS file not found: {name}") from None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise SourceError(f"AIS file {name}: {exc}") from None
    return AISInput(name, reports=reports, stats=stats)


def build_fuser(config: Config, ais: Any, camera=None, fps: float = 25.0, notes: list | None = None):
    """The fuser for an AIS input (the report list of a file, or a live
    :class:`seawatch.io.ais.AISListener`), or None when there is no AIS, fusion is disabled, or
    ``seawatch.fuse`` does not provide ``build_fuser`` yet (a note says so)."""
    if isinstance(ais, AISInput):
        ais = ais.data
    if ais is None or not config.fusion.enabled:
        return None
    try:
        fuse = importlib.import_module("seawatch.fuse")
    except ImportError as exc:  # pragma: no cover - the package ships with seawatch
        fuse, err = None, exc
    factory = getattr(fuse, "build_fuser", None) if fuse is not None else None
    if factory is None:
        msg = "AIS given but fusion (seawatch.fuse.build_fuser) is not available yet; AIS ignored"
        if notes is not None:
            notes.append(msg)
        print(f"seawatch: warning: {msg}", file=sys.stderr)
        return None
    try:
        return factory(config, ais=ais, camera=camera, fps=fps)
    except ValueError as exc:  # e.g. no camera model: fusion cannot run, say why
        raise PipelineError(f"AIS fusion: {exc}") from None


# ------------------------------------------------------------------------------ pipeline
class Pipeline:
    """Wires one camera's stages.

    Parameters
    ----------
    detector : Detector or DetectorTracker
    tracker : Tracker, optional
        None when ``detector`` is a DetectorTracker (has ``process``).
    fuser : Fuser, optional
    sinks : list of sinks
    camera : CameraModel, optional
        Base camera model; with a frame's PTZ state it gives the per-frame model (horizon drawing,
        azimuth/elevation of the detections).
    catch_errors : bool
        Count and skip a frame whose stages raise, instead of stopping (live sources).
    """

    def __init__(self, detector, tracker=None, *, fuser=None, sinks: Iterable = (), camera=None,
                 catch_errors: bool = False) -> None:
        self.joint = tracker is None
        if self.joint and not hasattr(detector, "process"):
            raise PipelineError("a pipeline needs a tracker (or a detector that also tracks)")
        self.detector = detector
        self.tracker = tracker
        self.fuser = fuser
        self.sinks = list(sinks)
        self.camera = camera
        self.catch_errors = catch_errors
        self.stage_errors: list[str] = []
        self.n_detections = 0
        self.track_ids: set[int] = set()
        self.n_alerts = 0
        self.frames = 0
        self.stage_s = {"detect": 0.0, "track": 0.0, "fuse": 0.0, "sinks": 0.0}

    def camera_at(self, frame: Frame):
        """The camera model for this frame (its PTZ state applied), or None."""
        if self.camera is None:
            return None
        if frame.ptz is not None:
            return self.camera.with_ptz(frame.ptz)
        return self.camera

    def step(self, frame: Frame) -> StepResult:
        """Run every stage on one frame and hand the results to the sinks."""
        cam = self.camera_at(frame)
        t0 = time.perf_counter()
        if self.joint:
            det, trk = self.detector.process(frame)
            t1 = t2 = time.perf_counter()
        else:
            det = self.detector.detect(frame)
            t1 = time.perf_counter()
            # the camera at this frame's PTZ state is authoritative: a detector built with the
            # base camera (e.g. the robust Kalman blobs) would miss the pan/tilt/zoom
            if cam is not None and len(det):
                det.azel_deg = boxes_azel(det.boxes, cam, "bottom")
            trk = self.tracker.update(det, frame)
            t2 = time.perf_counter()
        alerts: list = []
        if self.fuser is not None:
            trk, alerts = self.fuser.update(trk, frame, frame.t_s)
            alerts = list(alerts or [])
        t3 = time.perf_counter()
        for s in self.sinks:
            s.write(frame, det, trk, alerts, cam)
        t4 = time.perf_counter()
        st = self.stage_s
        st["detect"] += t1 - t0
        st["track"] += t2 - t1
        st["fuse"] += t3 - t2
        st["sinks"] += t4 - t3
        self.frames += 1
        self.n_detections += len(det)
        self.track_ids.update(int(i) for i in trk.ids[trk.states != int(TrackState.TENTATIVE)])
        self.n_alerts += len(alerts)
        return StepResult(det, trk, alerts)

    def run(self, source: Iterable[Frame], *, progress: bool = False, total: int | None = None,
            on_step=None) -> dict[str, Any]:
        """Process every frame of ``source``; return the processing part of the run summary."""
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=total, unit="frame", desc="seawatch", dynamic_ncols=True, leave=True,
                       mininterval=0.5, file=sys.stderr)
        t_start = time.perf_counter()
        try:
            for frame in source:
                try:
                    res = self.step(frame)
                except Exception as exc:
                    if not self.catch_errors:
                        raise
                    where = traceback.extract_tb(exc.__traceback__)[-1]
                    self.stage_errors.append(
                        f"frame {frame.index}: {type(exc).__name__}: {exc} ({Path(where.filename).name}:{where.lineno})"
                    )
                    continue
                if on_step is not None:
                    on_step(frame, res)
                if bar is not None:
                    bar.update(1)
                    if self.frames % 10 == 0:
                        bar.set_postfix(dets=len(res.detections), track_ids=len(self.track_ids), refresh=False)
        finally:
            if bar is not None:
                bar.close()
            for s in self.sinks:
                s.close()
        wall = time.perf_counter() - t_start
        return {
            "frames_processed": self.frames,
            "wall_s": round(wall, 3),
            "processing_fps": round(self.frames / wall, 2) if wall > 0 else None,
            "stage_ms_per_frame": {k: round(1000 * v / max(self.frames, 1), 3) for k, v in self.stage_s.items()},
            "detections": self.n_detections,
            "tracks": len(self.track_ids),
            "alerts": self.n_alerts,
            "stage_errors": len(self.stage_errors),
            "stage_error_examples": self.stage_errors[:20],
        }


def make_sinks(out_dir: str | Path, config: Config, fps: float, with_alerts: bool = False) -> tuple[list, dict]:
    """The writers the output settings ask for, in ``out_dir``; returns (sinks, {name: path})."""
    from seawatch.io.results import AlertWriter, AnnotatedVideoWriter, JsonlWriter, MotCsvWriter

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    o = config.output
    sinks, paths = [], {}
    if o.mot_csv:
        sinks += [MotCsvWriter(out / "detections.csv", "detections"), MotCsvWriter(out / "tracks.csv", "tracks")]
        paths["detections_csv"], paths["tracks_csv"] = out / "detections.csv", out / "tracks.csv"
    if o.jsonl:
        sinks += [JsonlWriter(out / "detections.jsonl", "detections"), JsonlWriter(out / "tracks.jsonl", "tracks")]
        paths["detections_jsonl"], paths["tracks_jsonl"] = out / "detections.jsonl", out / "tracks.jsonl"
    if with_alerts:
        sinks.append(AlertWriter(out / "alerts.jsonl"))
        paths["alerts_jsonl"] = out / "alerts.jsonl"
    if o.video:
        sinks.append(AnnotatedVideoWriter(out / "annotated.mp4", fps, o.video_codec, o.draw_horizon))
        paths["video"] = out / "annotated.mp4"
    return sinks, {k: str(v) for k, v in paths.items()}


def _fit_camera(camera, width: int, height: int):
    """The camera model with its intrinsics scaled to the source's image size when they differ."""
    if camera is None or not width:
        return camera
    K = camera.intrinsics
    if (int(K.width), int(K.height)) != (int(width), int(height)):
        return camera.with_intrinsics(K.scaled_to(width, height))
    return camera


def run_pipeline(
    source,
    config: Config | None = None,
    *,
    out_dir: str | Path,
    camera=None,
    ptz=None,
    ais=None,
    progress: bool | None = None,
    total: int | None = None,
    on_step=None,
) -> dict[str, Any]:
    """Run the whole pipeline on a source and write every output to ``out_dir``.

    Parameters
    ----------
    source : str, Path or FrameSource
        Video file, image folder, stream URL, or a ready :class:`seawatch.io.video.FrameSource`.
    config : Config, optional
        Settings (defaults when None).
    out_dir : str or Path
        Folder for ``annotated.mp4``, ``detections.csv``, ``tracks.csv``, ``*.jsonl`` and
        ``summary.json``.
    camera : CameraModel or path of a camera file, optional
    ptz : path of a PTZ CSV file or PTZTrack, optional
    ais : path, ``udp://``/``tcp://`` URL or list of AISReport, optional
        Handed to the fuser (see :func:`build_fuser`).
    progress : bool, optional
        Progress bar (default: ``config.run.progress``).

    Returns
    -------
    dict
        The run summary, also written to ``out_dir/summary.json``.

    Raises
    ------
    SourceError, ConfigError, PipelineError
        When nothing can be done (the message names the input).
    """
    from seawatch.io.video import FrameSource, load_camera_file, open_source, read_ptz_csv

    config = config or Config()
    check_settings(config)
    r = config.run
    if camera is not None and isinstance(camera, (str, Path)):
        camera = load_camera_file(camera)
    if ptz is not None and isinstance(ptz, (str, Path)):
        ptz = read_ptz_csv(ptz)
    if isinstance(source, FrameSource):
        src = source
    else:
        src = open_source(
            source, fps=r.fps, camera_id=r.camera_id, modality=r.modality,
            pose=camera.pose if camera is not None else None, ptz=ptz, max_frames=r.max_frames,
            max_bad_in_row=r.max_bad_frames_in_row,
        )
    try:
        return _run_opened(src, config, out_dir, camera, ptz, ais, progress, total, on_step)
    finally:
        src.close()


def _run_opened(src, config, out_dir, camera, ptz, ais, progress, total, on_step) -> dict[str, Any]:
    from seawatch.io.results import write_summary

    r = config.run
    camera = _fit_camera(camera, src.width, src.height)
    notes: list[str] = []
    if config.detector.kind in JOINT:  # one stage detects and tracks; tracker.kind is not used
        detector, tracker = build_detector(config, src.fps, camera), None
    elif config.tracker.kind in JOINT:
        detector, tracker = build_tracker(config, src.fps, camera), None
    else:
        detector = build_detector(config, src.fps, camera)
        tracker = build_tracker(config, src.fps, camera)
    ais_in = open_ais(ais)
    fuser = build_fuser(config, ais_in, camera, src.fps, notes)
    try:
        sinks, paths = make_sinks(out_dir, config, src.fps, with_alerts=fuser is not None)
    except OSError as exc:
        if ais_in is not None:
            ais_in.close()
        raise PipelineError(f"output folder {out_dir}: cannot write: {exc.strerror or exc}") from None
    pipe = Pipeline(detector, tracker, fuser=fuser, sinks=sinks, camera=camera, catch_errors=src.is_live)
    if total is None and getattr(src, "declared_frames", 0):
        total = src.declared_frames
    if total is None and hasattr(src, "files"):
        total = len(src.files)
    if total and r.max_frames:
        total = min(total, r.max_frames)
    started = time.time()
    try:
        proc = pipe.run(src, progress=r.progress if progress is None else progress, total=total, on_step=on_step)
    finally:
        if ais_in is not None:
            ais_in.close()
    summary: dict[str, Any] = {
        "source": src.name,
        "started_unix_s": round(started, 3),
        "frames_read": src.frames_read,
        **proc,
        "source_fps": src.fps,
        "image_size": [src.width, src.height],
        "bad_frames": src.n_bad,
        "bad_frames_by_reason": src.bad_frame_counts(),
        "bad_frame_examples": [f"frame {b.index}: {b.reason}" for b in src.bad_frames[:20]],
        "missing_frames": src.missing_frames,
        "rejected_inputs": {"frames": src.n_bad},
        "notes": list(src.notes) + notes,
        "detector": getattr(detector, "name", type(detector).__name__),
        "tracker": None if tracker is None else getattr(tracker, "name", type(tracker).__name__),
        "fuser": None if fuser is None else getattr(fuser, "name", type(fuser).__name__),
        "camera": None if camera is None else repr(camera),
        "ptz_states": 0 if ptz is None else len(ptz),
        "outputs": paths,
        "config": config_to_dict(config),
    }
    if ptz is not None:
        summary["rejected_inputs"]["ptz_rows"] = len(ptz.rejected)
        summary["notes"] += ptz.rejected[:20]
    if ais_in is not None:
        st = ais_in.stats if ais_in.listener is None else ais_in.listener.stats
        summary["ais"] = {"source": ais_in.name, **(st.as_dict() if st is not None else
                                                    {"reports": len(ais_in.reports or [])})}
        if st is not None:
            summary["rejected_inputs"]["ais"] = st.n_rejected
            summary["notes"] += st.messages_log[:20]
        if ais_in.listener is not None and ais_in.listener.errors:
            summary["notes"] += [f"AIS {ais_in.name}: {e}" for e in ais_in.listener.errors[:10]]
    if fuser is not None and hasattr(fuser, "stats"):
        st = fuser.stats() if callable(fuser.stats) else fuser.stats
        summary["fusion"] = st.as_dict() if hasattr(st, "as_dict") else st
    out = Path(out_dir)
    summary["outputs"]["summary"] = str(out / "summary.json")
    write_summary(out / "summary.json", summary)
    return summary
