"""Frame sources: video files, image folders and live streams, with camera pose and PTZ states.

Every source is an iterable of :class:`seawatch.types.Frame` with bookkeeping of what it could not
read.  Bad input never crashes a run: an unreadable image or an undecodable frame is counted in
:attr:`FrameSource.bad_frames` with a reason and skipped; a truncated video ends cleanly with a
note in :attr:`FrameSource.notes`; a live stream that drops is reopened a few times and then ends.
Only when *nothing* can be read (missing file, not a video, empty folder, unreachable stream) is a
:class:`SourceError` raised, whose message names the input.

Timestamps are seconds: from the first frame (``index / fps``) for files and folders, Unix seconds
(the time of arrival) for live streams.
"""

from __future__ import annotations

import csv
import math
import os
import re
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator

import cv2
import numpy as np

from seawatch.types import CameraPose, Frame, Modality, PTZState

__all__ = [
    "SourceError",
    "BadFrame",
    "FrameSource",
    "VideoFileSource",
    "ImageFolderSource",
    "StreamSource",
    "IterableSource",
    "PTZTrack",
    "open_source",
    "read_ptz_csv",
    "load_camera_file",
    "is_stream_url",
    "IMAGE_EXTENSIONS",
]

IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".pnm", ".webp")
_URL = re.compile(r"^(rtsp|rtsps|rtmp|http|https|udp|tcp|srt)://", re.IGNORECASE)
DEFAULT_FPS = 25.0
# FFmpeg's own log lines ("moov atom not found", "overread 7") duplicate the errors this module
# reports with the input's name; silence them unless the user asks (OPENCV_FFMPEG_LOGLEVEL=32).
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
MAX_BAD_KEPT = 1000  # skipped frames listed one by one (all are counted)


def _reason_kind(reason: str) -> str:
    kind = reason.split(":")[0]
    return "size differs" if kind.startswith("size ") else kind


class SourceError(Exception):
    """An input that cannot be used at all; the message names it."""


@dataclass
class BadFrame:
    """A frame that was skipped: its position in source order and why."""

    index: int
    reason: str


def is_stream_url(source: str | Path) -> bool:
    """Whether ``source`` is a live-stream URL (rtsp://, http://, ...)."""
    return bool(_URL.match(str(source)))


# ----------------------------------------------------------------------------------- PTZ track
@dataclass
class PTZTrack:
    """Timestamped pan/tilt/zoom states of a moving camera, interpolated at any time.

    Pan is interpolated on the circle (the short way round), tilt and zoom linearly; before the
    first and after the last sample the end state holds.
    """

    t_s: np.ndarray
    pan_deg: np.ndarray
    tilt_deg: np.ndarray
    zoom: np.ndarray
    path: str = ""
    rejected: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        order = np.argsort(self.t_s, kind="stable")
        self.t_s = np.asarray(self.t_s, float)[order]
        self.pan_deg = np.asarray(self.pan_deg, float)[order]
        self.tilt_deg = np.asarray(self.tilt_deg, float)[order]
        self.zoom = np.asarray(self.zoom, float)[order]
        self._pan_unwrapped = np.rad2deg(np.unwrap(np.deg2rad(self.pan_deg)))

    def __len__(self) -> int:
        return len(self.t_s)

    def at(self, t_s: float) -> PTZState:
        """The PTZ state at time ``t_s`` (seconds, same clock as the frames)."""
        pan = float(np.interp(t_s, self.t_s, self._pan_unwrapped)) % 360.0
        tilt = float(np.interp(t_s, self.t_s, self.tilt_deg))
        zoom = float(np.interp(t_s, self.t_s, self.zoom))
        return PTZState(t_s=float(t_s), pan_deg=pan, tilt_deg=tilt, zoom=zoom)


_PTZ_ALIASES = {
    "t_s": ("t_s", "t", "time_s", "time", "timestamp"),
    "pan_deg": ("pan_deg", "pan"),
    "tilt_deg": ("tilt_deg", "tilt"),
    "zoom": ("zoom", "zoom_x"),
}


def read_ptz_csv(path: str | Path) -> PTZTrack:
    """Read a PTZ CSV file: a header naming ``t_s, pan_deg, tilt_deg, zoom`` (any order; ``zoom``
    optional, 1 when absent), then one row per state.  ``#`` lines are comments.

    Malformed rows (wrong field count, not numbers, non-finite values, zoom <= 0) are skipped and
    listed in :attr:`PTZTrack.rejected` as ``"file:line: reason"``.

    Raises
    ------
    SourceError
        When the file is missing or unreadable, has no usable header, or no valid row.
    """
    p = Path(path)
    if not p.is_file():
        raise SourceError(f"PTZ file not found: {p}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SourceError(f"PTZ file {p}: cannot read: {exc}") from None
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise SourceError(f"PTZ file {p}: empty")
    header_no, header = lines[0]
    names = [h.strip().lower() for h in next(csv.reader([header]))]
    col: dict[str, int] = {}
    for key, aliases in _PTZ_ALIASES.items():
        for a in aliases:
            if a in names:
                col[key] = names.index(a)
                break
    missing = [k for k in ("t_s", "pan_deg", "tilt_deg") if k not in col]
    if missing:
        raise SourceError(
            f"PTZ file {p}:{header_no}: header must name t_s, pan_deg, tilt_deg[, zoom]; missing {', '.join(missing)}"
        )
    rows, rejected = [], []
    for line_no, ln in lines[1:]:
        fields = next(csv.reader([ln]))
        if len(fields) != len(names):
            rejected.append(f"{p}:{line_no}: expected {len(names)} fields, got {len(fields)}")
            continue
        try:
            t = float(fields[col["t_s"]])
            pan = float(fields[col["pan_deg"]])
            tilt = float(fields[col["tilt_deg"]])
            zoom = float(fields[col["zoom"]]) if "zoom" in col else 1.0
        except ValueError:
            rejected.append(f"{p}:{line_no}: not a number in {ln.strip()!r}")
            continue
        if not all(math.isfinite(v) for v in (t, pan, tilt, zoom)):
            rejected.append(f"{p}:{line_no}: non-finite value")
            continue
        if zoom <= 0 or not -90.0 <= tilt <= 90.0:
            rejected.append(f"{p}:{line_no}: zoom must be > 0 and tilt within [-90, 90], got zoom {zoom}, tilt {tilt}")
            continue
        rows.append((t, pan, tilt, zoom))
    if not rows:
        raise SourceError(f"PTZ file {p}: no valid row ({len(rejected)} rejected)")
    a = np.array(rows)
    return PTZTrack(a[:, 0], a[:, 1], a[:, 2], a[:, 3], path=str(p), rejected=rejected)


def load_camera_file(path: str | Path):
    """Read a camera file with :func:`seawatch.camera.load_camera` (FVessel's ``camera_para.txt``
    with :func:`seawatch.camera.load_fvessel_camera`).

    Raises
    ------
    SourceError
        Missing file, or a file the camera model rejects (the message names the file).
    """
    p = Path(path)
    if not p.is_file():
        raise SourceError(f"camera file not found: {p}")
    try:
        from seawatch import camera as cam
    except ImportError as exc:  # pragma: no cover - the camera package ships with seawatch
        raise SourceError(f"camera file {p}: the camera model is not available ({exc})") from None
    loader = getattr(cam, "load_fvessel_camera", None) if p.suffix == ".txt" else getattr(cam, "load_camera", None)
    if loader is None:
        raise SourceError(f"camera file {p}: the camera model is not available yet")
    try:
        return loader(p)
    except SourceError:
        raise
    except (OSError, ValueError, KeyError, TypeError) as exc:
        msg = str(exc)
        raise SourceError(msg if str(p) in msg else f"camera file {p}: {msg}") from None


# ---------------------------------------------------------------------------------- sources
class FrameSource:
    """Base of the frame sources: iteration, bookkeeping and pose/PTZ attachment.

    Attributes
    ----------
    name : str
        The input as the user gave it (path or URL).
    fps : float
        Frame rate used for timestamps and for the time parameters of the stages.
    bad_frames : list of BadFrame
        Frames skipped, with reasons.
    notes : list of str
        Other events (a truncated video, a reconnection, a dropped stream).
    frames_read : int
        Frames delivered.
    """

    is_live = False

    def __init__(
        self,
        name: str,
        fps: float,
        *,
        camera_id: str = "cam0",
        modality: Modality | str = Modality.EO,
        pose: CameraPose | None = None,
        ptz: PTZTrack | None = None,
        max_frames: int = 0,
    ) -> None:
        self.name = str(name)
        self.fps = float(fps)
        self.camera_id = camera_id
        self.modality = Modality(modality)
        self.pose = pose
        self.ptz = ptz
        self.max_frames = int(max_frames)
        self.bad_frames: list[BadFrame] = []  # the first MAX_BAD_KEPT of them
        self.bad_counts: Counter = Counter()  # skipped frames per kind of reason
        self.n_bad = 0
        self.notes: list[str] = []
        self.frames_read = 0
        self.width = 0
        self.height = 0
        self.missing_frames = 0  # frames a file declares but does not hold (truncated)

    # subclasses yield (index, t_s, image) for the good frames and call self._bad(...) otherwise
    def _raw(self) -> Iterator[tuple[int, float, np.ndarray]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _bad(self, index: int, reason: str) -> None:
        self.n_bad += 1
        self.bad_counts[_reason_kind(reason)] += 1
        if len(self.bad_frames) < MAX_BAD_KEPT:
            self.bad_frames.append(BadFrame(int(index), reason))

    def _convert(self, image: np.ndarray) -> np.ndarray:
        if image.ndim == 3 and image.shape[2] == 4:
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
        if self.modality == Modality.EO and image.ndim == 2:
            if image.dtype != np.uint8:
                image = cv2.normalize(image, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        elif self.modality == Modality.IR and image.ndim == 3:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        return image

    def __iter__(self) -> Iterator[Frame]:
        try:
            for index, t_s, image in self._raw():
                if image is None or image.size == 0:
                    self._bad(index, "empty image")
                    continue
                image = self._convert(image)
                h, w = image.shape[:2]
                if self.frames_read == 0:
                    self.width, self.height = w, h
                elif (w, h) != (self.width, self.height):
                    self._bad(index, f"size {w}x{h} differs from the first frame's {self.width}x{self.height}")
                    continue
                ptz = self.ptz.at(t_s) if self.ptz is not None else None
                self.frames_read += 1
                yield Frame(image, float(t_s), int(index), self.camera_id, self.modality, self.pose, ptz)
                if self.max_frames and self.frames_read >= self.max_frames:
                    break
        finally:
            self.close()

    def close(self) -> None:
        """Release the underlying file or connection."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def bad_frame_counts(self) -> dict[str, int]:
        """Skipped frames per kind of reason (``undecodable``, ``size differs``, ...)."""
        return dict(self.bad_counts)


class VideoFileSource(FrameSource):
    """Frames of a video file, decoded with OpenCV (FFmpeg).

    A file that ends before the frame count its header declares (a truncated download, a corrupt
    tail) ends cleanly; the shortfall is recorded in :attr:`notes`.
    """

    def __init__(self, path: str | Path, fps: float = 0.0, **kwargs) -> None:
        p = Path(path)
        if not p.exists():
            raise SourceError(f"video file not found: {p}")
        if not p.is_file():
            raise SourceError(f"video source {p}: not a file")
        try:
            with open(p, "rb") as fh:
                fh.read(1)
        except OSError as exc:
            raise SourceError(f"video file {p}: cannot read: {exc.strerror or exc}") from None
        cap = cv2.VideoCapture(str(p))
        if not cap.isOpened():
            cap.release()
            raise SourceError(f"video file {p}: cannot open (not a video, or truncated/corrupt header)")
        src_fps = cap.get(cv2.CAP_PROP_FPS)
        if not fps:
            fps = src_fps if src_fps and math.isfinite(src_fps) and 0 < src_fps < 1000 else DEFAULT_FPS
        super().__init__(str(p), fps, **kwargs)
        self._cap = cap
        n = cap.get(cv2.CAP_PROP_FRAME_COUNT)
        self.declared_frames = int(n) if n and math.isfinite(n) and n > 0 else 0
        self.width = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
        self.height = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))

    def _raw(self):
        cap = self._cap
        if cap is None:
            return
        index = 0
        while True:
            ok, image = cap.read()
            if not ok:
                # FFmpeg drops undecodable packets itself; a failed read means the stream ended.
                if index == 0:
                    raise SourceError(f"video file {self.name}: no readable frame")
                if self.declared_frames and index < self.declared_frames:
                    self.missing_frames = self.declared_frames - index
                    self.notes.append(
                        f"video file {self.name}: ended after {index} of {self.declared_frames} declared "
                        f"frames (truncated or corrupt)"
                    )
                break
            yield index, index / self.fps, image
            index += 1

    def close(self) -> None:
        if getattr(self, "_cap", None) is not None:
            self._cap.release()
            self._cap = None


class ImageFolderSource(FrameSource):
    """Images of a folder, in sorted file-name order; frame ``i`` is the ``i``-th file.

    An unreadable or undecodable file is skipped and counted; it keeps its place in the numbering
    (frame numbers stay in source order).
    """

    def __init__(self, folder: str | Path, fps: float = 0.0, **kwargs) -> None:
        p = Path(folder)
        if not p.is_dir():
            raise SourceError(f"image folder not found: {p}")
        self.files = sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_EXTENSIONS and f.is_file())
        if not self.files:
            raise SourceError(f"image folder {p}: no images ({', '.join(IMAGE_EXTENSIONS)})")
        super().__init__(str(p), fps or DEFAULT_FPS, **kwargs)

    def _raw(self):
        flags = cv2.IMREAD_UNCHANGED
        for index, f in enumerate(self.files):
            try:
                buf = np.fromfile(f, dtype=np.uint8)
            except OSError as exc:
                self._bad(index, f"unreadable: {f.name}: {exc.strerror or exc}")
                continue
            image = cv2.imdecode(buf, flags) if buf.size else None
            if image is None:
                self._bad(index, f"undecodable: {f.name}")
                continue
            yield index, index / self.fps, image


def _open_capture(url: str):
    return cv2.VideoCapture(url)


class StreamSource(FrameSource):
    """A live stream (RTSP, HTTP MJPEG, ...) read with OpenCV; timestamps are Unix seconds.

    Parameters
    ----------
    url : str
        Stream address.
    max_bad_in_row : int
        Failed reads in a row after which the stream counts as dropped.
    reconnect_attempts : int
        Times a dropped stream is reopened before the source ends.
    reconnect_wait_s : float
        Wait before the first reopening (doubled at each further attempt).
    open_capture : callable, optional
        ``url -> capture`` with ``isOpened``, ``read``, ``get``, ``release`` (``cv2.VideoCapture``
        by default; replaceable for tests).
    clock : callable, optional
        Returns the current Unix time in seconds (``time.time`` by default).
    """

    is_live = True

    def __init__(
        self,
        url: str,
        fps: float = 0.0,
        *,
        max_bad_in_row: int = 50,
        reconnect_attempts: int = 3,
        reconnect_wait_s: float = 1.0,
        open_capture: Callable[[str], object] | None = None,
        clock: Callable[[], float] | None = None,
        sleep: Callable[[float], None] | None = None,
        **kwargs,
    ) -> None:
        self._open = open_capture or _open_capture
        self._clock = clock or time.time
        self._sleep = sleep or time.sleep
        self.max_bad_in_row = max(1, int(max_bad_in_row))
        self.reconnect_attempts = int(reconnect_attempts)
        self.reconnect_wait_s = float(reconnect_wait_s)
        self.reconnects = 0
        cap = self._open(str(url))
        if not cap.isOpened():
            cap = self._reopen(str(url), cap, first=True)
            if cap is None:
                raise SourceError(
                    f"stream {url}: cannot connect (tried {1 + self.reconnect_attempts} times)"
                )
        src_fps = cap.get(cv2.CAP_PROP_FPS)
        if not fps:
            fps = src_fps if src_fps and math.isfinite(src_fps) and 0 < src_fps < 1000 else DEFAULT_FPS
        super().__init__(str(url), fps, **kwargs)
        self._cap = cap
        w, h = cap.get(cv2.CAP_PROP_FRAME_WIDTH), cap.get(cv2.CAP_PROP_FRAME_HEIGHT)
        if w and h and math.isfinite(w) and math.isfinite(h):
            self.width, self.height = int(w), int(h)

    def _reopen(self, url: str, cap, first: bool = False):
        if cap is not None:
            cap.release()
        wait = self.reconnect_wait_s
        for attempt in range(1, self.reconnect_attempts + 1):
            self._sleep(wait)
            wait *= 2
            cap = self._open(url)
            if cap.isOpened():
                if not first:
                    self.reconnects += 1
                    self.notes.append(f"stream {url}: reconnected (attempt {attempt})")
                return cap
            cap.release()
        return None

    def _raw(self):
        index = 0
        bad_in_row = 0
        while self._cap is not None:
            ok, image = self._cap.read()
            if ok and image is not None and image.size:
                bad_in_row = 0
                yield index, self._clock(), image
                index += 1
                continue
            self._bad(index, "read failed")
            bad_in_row += 1
            if bad_in_row >= self.max_bad_in_row:
                self.notes.append(f"stream {self.name}: dropped after {bad_in_row} failed reads in a row")
                self._cap = self._reopen(self.name, self._cap)
                bad_in_row = 0
                if self._cap is None:
                    self.notes.append(
                        f"stream {self.name}: gave up after {self.reconnect_attempts} reconnection attempts"
                    )

    def close(self) -> None:
        if getattr(self, "_cap", None) is not None:
            self._cap.release()
            self._cap = None


class IterableSource(FrameSource):
    """Wrap an iterable of ready :class:`Frame` objects (e.g. a simulator) as a source."""

    def __init__(self, frames: Iterable[Frame], fps: float, name: str = "frames", **kwargs) -> None:
        super().__init__(name, fps, **kwargs)
        self._frames = frames

    def __iter__(self) -> Iterator[Frame]:
        for fr in self._frames:
            if fr.image is None or fr.image.size == 0:
                self._bad(fr.index, "empty image")
                continue
            if self.frames_read == 0:
                self.height, self.width = fr.shape
            if fr.ptz is None and self.ptz is not None:
                fr.ptz = self.ptz.at(fr.t_s)
            if fr.pose is None and self.pose is not None:
                fr.pose = self.pose
            self.frames_read += 1
            yield fr
            if self.max_frames and self.frames_read >= self.max_frames:
                break


def open_source(
    source: str | Path,
    *,
    fps: float = 0.0,
    camera_id: str = "cam0",
    modality: Modality | str = Modality.EO,
    pose: CameraPose | None = None,
    ptz: PTZTrack | str | Path | None = None,
    max_frames: int = 0,
    max_bad_in_row: int = 50,
    reconnect_attempts: int = 3,
    reconnect_wait_s: float = 1.0,
) -> FrameSource:
    """Open a video file, an image folder or a stream URL as a :class:`FrameSource`.

    Parameters
    ----------
    source : str or Path
        Video file, folder of images (sorted file-name order) or stream URL (``rtsp://``,
        ``http://``, ...).
    fps : float
        Frame rate; 0: the source's own (25 for folders or when the source does not say).
    ptz : PTZTrack, or path of a PTZ CSV file, optional
        Pan/tilt/zoom states attached to each frame (interpolated at its timestamp).

    Raises
    ------
    SourceError
        When the source cannot be used at all; the message names it.
    """
    if ptz is not None and not isinstance(ptz, PTZTrack):
        ptz = read_ptz_csv(ptz)
    common = dict(camera_id=camera_id, modality=modality, pose=pose, ptz=ptz, max_frames=max_frames)
    if is_stream_url(source):
        return StreamSource(
            str(source), fps, max_bad_in_row=max_bad_in_row, reconnect_attempts=reconnect_attempts,
            reconnect_wait_s=reconnect_wait_s, **common,
        )
    p = Path(source)
    if p.is_dir():
        return ImageFolderSource(p, fps, **common)
    return VideoFileSource(p, fps, **common)
