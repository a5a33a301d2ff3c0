"""Result sinks: annotated video, MOTChallenge CSV, JSON Lines and the run summary.

Every sink has ``write(frame, detections, tracks, alerts, camera=None)`` and ``close()``; the
pipeline calls ``write`` once per processed frame.  The formats are specified in
``docs/formats.md``; :func:`read_mot_csv` and :func:`read_jsonl` read them back.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, Iterable, Protocol

import cv2
import numpy as np

from seawatch.types import Detections, Frame, Tracks, TrackState

__all__ = [
    "Sink",
    "MotCsvWriter",
    "JsonlWriter",
    "AlertWriter",
    "AnnotatedVideoWriter",
    "read_mot_csv",
    "read_jsonl",
    "write_summary",
    "track_rows",
    "STATE_NAMES",
]

STATE_NAMES = {int(TrackState.TENTATIVE): "tentative", int(TrackState.CONFIRMED): "confirmed",
               int(TrackState.COASTING): "coasting"}


class Sink(Protocol):
    """Where the pipeline's per-frame results go."""

    def write(self, frame: Frame, detections: Detections, tracks: Tracks, alerts: list,
              camera=None) -> None: ...

    def close(self) -> None: ...


def _names(tracks: Tracks) -> list[str | None]:
    """The vessel names a fuser attached (``tracks.names``), or Nones."""
    names = getattr(tracks, "names", None)
    if names is None or len(names) != len(tracks):
        return [None] * len(tracks)
    return [str(n) if n else None for n in names]


def _select(tracks: Tracks, keep: np.ndarray) -> Tracks:
    """``tracks.subset(keep)`` that keeps the fuser's ``names`` attribute."""
    names = _names(tracks)
    out = tracks.subset(keep)
    out.names = [n for n, k in zip(names, keep) if k]
    return out


def _reported(tracks: Tracks, include_coasting: bool) -> Tracks:
    """The tracks a writer reports: confirmed ones updated in this frame (and coasting ones)."""
    keep = tracks.states == int(TrackState.CONFIRMED)
    if include_coasting:
        keep |= tracks.states == int(TrackState.COASTING)
    return _select(tracks, keep)


class _RowWriter:
    """A text file of one row per detection or per track (the common part of the row writers)."""

    def __init__(self, path: str | Path, kind: str, include_coasting: bool) -> None:
        if kind not in ("detections", "tracks"):
            raise ValueError(f"{type(self).__name__}: kind must be 'detections' or 'tracks', got {kind!r}")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.kind = kind
        self.include_coasting = include_coasting
        self._fh = open(self.path, "w", encoding="utf-8", newline="\n")
        self.rows = 0

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()


class MotCsvWriter(_RowWriter):
    """MOTChallenge CSV: ``frame,id,x,y,w,h,conf,-1,-1,-1`` with 1-based frame numbers.

    Parameters
    ----------
    path : str or Path
        File to write (parent folders are created).
    kind : {"detections", "tracks"}
        Detections get id -1 and their score; tracks get their id and conf 1.
    include_coasting : bool
        Also write confirmed tracks that were not updated by a detection in the frame (with their
        predicted box); by default only tracks updated in the frame are written, as SORT does.
    """

    def __init__(self, path: str | Path, kind: str = "tracks", include_coasting: bool = False) -> None:
        super().__init__(path, kind, include_coasting)

    def write(self, frame, detections, tracks, alerts=(), camera=None) -> None:
        if self.kind == "detections":
            boxes, ids, conf = detections.boxes, np.full(len(detections), -1), detections.scores
            fi = detections.frame_index
        else:
            t = _reported(tracks, self.include_coasting)
            boxes, ids, conf = t.boxes, t.ids, np.ones(len(t))
            fi = tracks.frame_index
        lines = [
            f"{fi + 1},{int(i)},{b[0]:.2f},{b[1]:.2f},{b[2]:.2f},{b[3]:.2f},{c:.4g},-1,-1,-1\n"
            for i, b, c in zip(ids, boxes, conf)
        ]
        self._fh.writelines(lines)
        self.rows += len(lines)



def _num(v: float, nd: int = 3):
    v = float(v)
    return round(v, nd) if math.isfinite(v) else None


def track_rows(tracks: Tracks, include_coasting: bool = True) -> list[dict[str, Any]]:
    """The JSON Lines objects of one frame's reportable tracks (see ``docs/formats.md``)."""
    t = _reported(tracks, include_coasting)
    names = _names(t)
    rows = []
    for k in range(len(t)):
        row: dict[str, Any] = {
            "frame": int(t.frame_index),
            "t_s": _num(t.t_s, 4),
            "camera_id": t.camera_id,
            "id": int(t.ids[k]),
            "box": [_num(x, 2) for x in t.boxes[k]],
            "state": STATE_NAMES.get(int(t.states[k]), str(int(t.states[k]))),
            "vel_px_s": [_num(x, 2) for x in t.velocities[k]],
            "age_s": _num(t.ages_s[k], 3),
        }
        if t.mmsi is not None and t.mmsi[k] > 0:
            row["mmsi"] = int(t.mmsi[k])
        if names[k]:
            row["name"] = names[k]
        if t.world is not None and np.all(np.isfinite(t.world[k, :2])):
            row["lat"] = _num(t.world[k, 0], 6)
            row["lon"] = _num(t.world[k, 1], 6)
            if math.isfinite(t.world[k, 2]):
                row["speed_mps"] = _num(t.world[k, 2], 2)
            if math.isfinite(t.world[k, 3]):
                row["course_deg"] = _num(t.world[k, 3], 1)
        rows.append(row)
    return rows


class JsonlWriter(_RowWriter):
    """JSON Lines, one object per detection or per reported track per frame."""

    def __init__(self, path: str | Path, kind: str = "tracks", include_coasting: bool = True) -> None:
        super().__init__(path, kind, include_coasting)

    def write(self, frame, detections, tracks, alerts=(), camera=None) -> None:
        if self.kind == "detections":
            d = detections
            rows = []
            for k in range(len(d)):
                row = {
                    "frame": int(d.frame_index),
                    "t_s": _num(d.t_s, 4),
                    "camera_id": d.camera_id,
                    "box": [_num(x, 2) for x in d.boxes[k]],
                    "score": _num(d.scores[k], 4),
                    "source": d.source,
                }
                if d.azel_deg is not None:
                    row["azel_deg"] = [_num(x, 4) for x in d.azel_deg[k]]
                rows.append(row)
        else:
            rows = track_rows(tracks, self.include_coasting)
        self._fh.writelines(json.dumps(r, separators=(", ", ": ")) + "\n" for r in rows)
        self.rows += len(rows)



def _jsonable(obj: Any) -> Any:
    if callable(getattr(obj, "to_dict", None)) and not isinstance(obj, type):
        obj = obj.to_dict()
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        obj = dataclasses.asdict(obj)
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return _num(obj, 6)
    if isinstance(obj, (str, int, bool)) or obj is None:
        return obj
    return str(obj)


class AlertWriter:
    """The fuser's alerts as JSON Lines (``{"frame": i, "t_s": t, "alert": {...}}``)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.path, "w", encoding="utf-8", newline="\n")
        self.rows = 0

    def write(self, frame, detections, tracks, alerts=(), camera=None) -> None:
        for a in alerts or ():
            self._fh.write(json.dumps({"frame": int(frame.index), "t_s": _num(frame.t_s, 4),
                                       "alert": _jsonable(a)}) + "\n")
            self.rows += 1

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()


def _colour(track_id: int) -> tuple[int, int, int]:
    """A stable, saturated BGR colour per id."""
    hue = int((track_id * 47) % 180)
    hsv = np.array([[[hue, 220, 255]]], np.uint8)
    b, g, r = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
    return int(b), int(g), int(r)


def draw_annotations(image: np.ndarray, detections: Detections | None, tracks: Tracks | None,
                     camera=None, draw_horizon: bool = True, alerts: Iterable | None = None,
                     t_s: float | None = None) -> np.ndarray:
    """A BGR copy of ``image`` with detections (thin grey), tracks (coloured, id and MMSI/name
    when known; coasting tracks thin), the horizon line (when ``camera`` is given) and a status
    line."""
    if image.ndim == 2:
        if image.dtype != np.uint8:
            image = cv2.normalize(image, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
        out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    else:
        out = image.copy()
    h, w = out.shape[:2]
    scale = max(0.35, min(1.0, h / 720))
    thick = max(1, int(round(2 * scale)))
    if draw_horizon and camera is not None:
        try:
            vl, vr = camera.horizon_line()
            if np.isfinite(vl) and np.isfinite(vr):
                cv2.line(out, (0, int(round(vl))), (w - 1, int(round(vr))), (255, 200, 0), 1, cv2.LINE_AA)
        except Exception:  # a camera model without a horizon must not stop the video
            pass
    if detections is not None:
        for b in detections.boxes.astype(int):
            cv2.rectangle(out, (b[0], b[1]), (b[0] + b[2], b[1] + b[3]), (160, 160, 160), 1)
    if tracks is not None and len(tracks):
        t = _select(tracks, tracks.states != int(TrackState.TENTATIVE))
        names = _names(t)
        for k in range(len(t)):
            x, y, bw, bh = (int(round(v)) for v in t.boxes[k])
            col = _colour(int(t.ids[k]))
            coasting = int(t.states[k]) == int(TrackState.COASTING)
            cv2.rectangle(out, (x, y), (x + bw, y + bh), col, 1 if coasting else thick)
            label = f"{int(t.ids[k])}"
            if t.mmsi is not None and t.mmsi[k] > 0:
                label += f" {int(t.mmsi[k])}"
            if names[k]:
                label += f" {names[k]}"
            (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, 1)
            ty = y - 3 if y - th - 4 >= 0 else y + bh + th + 3
            cv2.rectangle(out, (x, ty - th - 2), (x + tw + 2, ty + 2), col, -1)
            cv2.putText(out, label, (x + 1, ty), cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, (0, 0, 0), 1, cv2.LINE_AA)
    status = []
    if t_s is not None:
        status.append(f"t={t_s:.2f}s")
    if tracks is not None:
        status.append(f"tracks {int(np.sum(tracks.states != int(TrackState.TENTATIVE)))}")
    n_alerts = len(list(alerts)) if alerts is not None else 0
    if n_alerts:
        status.append(f"alerts {n_alerts}")
    if status:
        cv2.putText(out, "  ".join(status), (6, h - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale,
                    (255, 255, 255), 1, cv2.LINE_AA)
    return out


class AnnotatedVideoWriter:
    """An MP4 of the frames with detections, tracks, MMSI/name and the horizon drawn on them.

    Parameters
    ----------
    path : str or Path
        Output file (``.mp4``).
    fps : float
        Frame rate of the output.
    codec : str
        FourCC of the encoder (``mp4v`` works with every OpenCV wheel).
    draw_horizon : bool
        Draw the horizon line of the camera model when one is known.
    """

    def __init__(self, path: str | Path, fps: float, codec: str = "mp4v", draw_horizon: bool = True) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fps = float(fps) if fps and fps > 0 else 25.0
        if len(codec) != 4:
            raise ValueError(f"output video codec must be a 4-character FourCC, got {codec!r}")
        self.codec = codec
        self.draw_horizon = draw_horizon
        self._vw = None
        self._size: tuple[int, int] | None = None
        self.frames = 0

    def write(self, frame, detections, tracks, alerts=(), camera=None) -> None:
        img = draw_annotations(frame.image, detections, tracks, camera, self.draw_horizon, alerts, frame.t_s)
        h, w = img.shape[:2]
        if self._vw is None:
            self._vw = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*self.codec), self.fps, (w, h))
            if not self._vw.isOpened():
                self._vw = None
                raise OSError(f"cannot write video {self.path} with codec {self.codec!r}")
            self._size = (w, h)
        if (w, h) != self._size:
            img = cv2.resize(img, self._size)
        self._vw.write(img)
        self.frames += 1

    def close(self) -> None:
        if self._vw is not None:
            self._vw.release()
            self._vw = None


def read_mot_csv(path: str | Path) -> np.ndarray:
    """Read a MOTChallenge CSV file into an (N, 10) float64 array (empty file: (0, 10))."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"MOT CSV file not found: {p}")
    rows = []
    for no, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip():
            continue
        parts = line.split(",")
        if len(parts) < 6:
            raise ValueError(f"{p}:{no}: expected at least 6 comma-separated fields, got {len(parts)}")
        vals = [float(x) for x in parts[:10]] + [-1.0] * (10 - min(10, len(parts)))
        rows.append(vals)
    return np.array(rows, dtype=np.float64).reshape(-1, 10)


def read_jsonl(path: str | Path) -> list[dict]:
    """Read a JSON Lines file into a list of dicts."""
    p = Path(path)
    with open(p, encoding="utf-8") as fh:
        return [json.loads(line) for line in fh if line.strip()]


def write_summary(path: str | Path, summary: dict) -> Path:
    """Write the run summary as indented JSON."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(_jsonable(summary), indent=1) + "\n", encoding="utf-8")
    return p
