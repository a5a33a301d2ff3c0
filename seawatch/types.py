"""Messages that flow between seawatch stages.

Every arrow of the data flow (see ``docs/architecture.md``) is one of these plain, typed
messages.  Where there are many items (detections, tracks) they are stored as NumPy arrays,
one row per item, so stages stay vectorised and messages serialise cheaply.

Conventions
-----------
* Times are seconds (``t_s``), as float, on one clock per run (Unix seconds for live sources,
  seconds from the start for files and simulations).
* Image boxes are ``(x, y, w, h)`` in pixels, ``x, y`` the top-left corner, float64.
* Angles are degrees.  Azimuth / pan / heading / course are clockwise from true north;
  elevation / tilt are positive upwards.
* ``mmsi == 0`` means "no MMSI".
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = [
    "Modality",
    "TrackState",
    "CameraPose",
    "PTZState",
    "Frame",
    "Detections",
    "Tracks",
    "AISReport",
    "FusedTrack",
    "Detector",
    "Tracker",
    "DetectorTracker",
]


class Modality(str, enum.Enum):
    """Imaging modality of a camera."""

    EO = "EO"  # visible colour
    IR = "IR"  # thermal


class TrackState(enum.IntEnum):
    """Life-cycle state of a track."""

    TENTATIVE = 0
    CONFIRMED = 1
    COASTING = 2  # confirmed, but not updated by a detection in this frame


@dataclass(frozen=True)
class CameraPose:
    """Where a camera is and where it looks.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Geodetic position of the camera (WGS-84).
    height_m : float
        Height of the optical centre above the sea surface.
    pan_deg : float
        Azimuth of the optical axis, clockwise from true north.
    tilt_deg : float
        Elevation of the optical axis, positive upwards (a camera looking down has a negative tilt).
    roll_deg : float
        Rotation about the optical axis, positive clockwise as seen from behind the camera
        (the scene, and so the horizon, then appears rotated anticlockwise in the image).
    """

    lat_deg: float = 0.0
    lon_deg: float = 0.0
    height_m: float = 10.0
    pan_deg: float = 0.0
    tilt_deg: float = 0.0
    roll_deg: float = 0.0


@dataclass(frozen=True)
class PTZState:
    """Pan/tilt/zoom state of a moving camera at time ``t_s``.

    ``pan_deg`` and ``tilt_deg`` are absolute (they replace the pose's), ``zoom`` multiplies the
    focal length of the base intrinsics (1.0 = widest).
    """

    t_s: float
    pan_deg: float
    tilt_deg: float
    zoom: float = 1.0


@dataclass
class Frame:
    """One image from one camera."""

    image: np.ndarray  # HxWx3 uint8 BGR (EO) or HxW uint8/uint16 (IR / grey)
    t_s: float
    index: int  # frame number in source order, 0-based
    camera_id: str = "cam0"
    modality: Modality = Modality.EO
    pose: CameraPose | None = None
    ptz: PTZState | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) of the image."""
        return int(self.image.shape[0]), int(self.image.shape[1])


def _as_2d(a, cols: int, dtype=np.float64) -> np.ndarray:
    arr = np.asarray(a, dtype=dtype)
    if arr.size == 0:
        return np.zeros((0, cols), dtype=dtype)
    return arr.reshape(-1, cols)


@dataclass
class Detections:
    """Detections of one frame.

    Attributes
    ----------
    boxes : (N, 4) float64, x, y, w, h in pixels.
    scores : (N,) float64, detector confidence (higher is surer; 1.0 when the detector has none).
    source : name of the detector that made them.
    azel_deg : optional (N, 2) float64, azimuth and elevation of each box's reference point
        (bottom centre for sea-surface targets), filled when the camera model is known.
    """

    t_s: float
    frame_index: int
    boxes: np.ndarray
    scores: np.ndarray
    source: str = ""
    camera_id: str = "cam0"
    azel_deg: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.boxes = _as_2d(self.boxes, 4)
        self.scores = np.asarray(self.scores, dtype=np.float64).reshape(-1)
        if self.scores.size == 0 and len(self.boxes):
            self.scores = np.ones(len(self.boxes))
        if len(self.scores) != len(self.boxes):
            raise ValueError(
                f"Detections: {len(self.boxes)} boxes but {len(self.scores)} scores"
            )
        if self.azel_deg is not None:
            self.azel_deg = _as_2d(self.azel_deg, 2)

    def __len__(self) -> int:
        return len(self.boxes)

    @classmethod
    def empty(cls, t_s: float, frame_index: int, source: str = "", camera_id: str = "cam0"):
        return cls(t_s, frame_index, np.zeros((0, 4)), np.zeros(0), source, camera_id)

    def subset(self, mask_or_index) -> "Detections":
        """Detections selected by a boolean mask or an index array."""
        az = None if self.azel_deg is None else self.azel_deg[mask_or_index]
        return Detections(
            self.t_s,
            self.frame_index,
            self.boxes[mask_or_index],
            self.scores[mask_or_index],
            self.source,
            self.camera_id,
            az,
        )


@dataclass
class Tracks:
    """Tracks of one camera (or fused) at one time.

    Attributes
    ----------
    ids : (N,) int64 track identities, unique within a run.
    boxes : (N, 4) float64 image boxes x, y, w, h.
    velocities : (N, 2) float64 image velocity of the box centre, px/s.
    states : (N,) int8, :class:`TrackState` values.
    ages_s : (N,) float64, seconds since each track was born.
    world : optional (N, 4) float64, lat_deg, lon_deg, speed_mps, course_deg.
    mmsi : optional (N,) int64, 0 where unknown.
    """

    t_s: float
    frame_index: int
    ids: np.ndarray
    boxes: np.ndarray
    velocities: np.ndarray | None = None
    states: np.ndarray | None = None
    ages_s: np.ndarray | None = None
    source: str = ""
    camera_id: str = "cam0"
    world: np.ndarray | None = None
    mmsi: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        n = len(self.ids)
        self.boxes = _as_2d(self.boxes, 4)
        if len(self.boxes) != n:
            raise ValueError(f"Tracks: {n} ids but {len(self.boxes)} boxes")
        self.velocities = (
            np.zeros((n, 2)) if self.velocities is None else _as_2d(self.velocities, 2)
        )
        self.states = (
            np.full(n, int(TrackState.CONFIRMED), dtype=np.int8)
            if self.states is None
            else np.asarray(self.states, dtype=np.int8).reshape(-1)
        )
        self.ages_s = np.zeros(n) if self.ages_s is None else np.asarray(self.ages_s, float).reshape(-1)
        if self.world is not None:
            self.world = _as_2d(self.world, 4)
        if self.mmsi is not None:
            self.mmsi = np.asarray(self.mmsi, dtype=np.int64).reshape(-1)

    def __len__(self) -> int:
        return len(self.ids)

    @classmethod
    def empty(cls, t_s: float, frame_index: int, source: str = "", camera_id: str = "cam0"):
        return cls(t_s, frame_index, np.zeros(0, np.int64), np.zeros((0, 4)), source=source,
                   camera_id=camera_id)

    def confirmed(self) -> "Tracks":
        """Only the confirmed (including coasting) tracks."""
        keep = self.states != int(TrackState.TENTATIVE)
        return self.subset(keep)

    def subset(self, mask_or_index) -> "Tracks":
        return Tracks(
            self.t_s,
            self.frame_index,
            self.ids[mask_or_index],
            self.boxes[mask_or_index],
            self.velocities[mask_or_index],
            self.states[mask_or_index],
            self.ages_s[mask_or_index],
            self.source,
            self.camera_id,
            None if self.world is None else self.world[mask_or_index],
            None if self.mmsi is None else self.mmsi[mask_or_index],
        )


@dataclass
class AISReport:
    """One decoded AIS report (position and/or static data) of one vessel.

    Position fields are NaN for purely static messages (type 5, 24).
    """

    mmsi: int
    t_s: float
    lat_deg: float = float("nan")
    lon_deg: float = float("nan")
    sog_kn: float = float("nan")
    cog_deg: float = float("nan")
    heading_deg: float = float("nan")  # NaN when unavailable (511 in the message)
    nav_status: int | None = None
    msg_type: int | None = None
    name: str | None = None
    callsign: str | None = None
    ship_type: int | None = None
    length_m: float | None = None
    beam_m: float | None = None

    @property
    def has_position(self) -> bool:
        return bool(np.isfinite(self.lat_deg) and np.isfinite(self.lon_deg))


@dataclass
class FusedTrack:
    """One vessel of the fused picture."""

    track_id: int
    t_s: float
    lat_deg: float
    lon_deg: float
    speed_mps: float = float("nan")
    course_deg: float = float("nan")
    camera_track_id: int | None = None  # None when the camera does not see it
    box: tuple[float, float, float, float] | None = None
    mmsi: int = 0
    name: str | None = None
    ship_type: int | None = None
    sources: tuple[str, ...] = field(default_factory=tuple)  # e.g. ("camera", "ais")


@runtime_checkable
class Detector(Protocol):
    """A stage that finds objects in one frame."""

    name: str

    def detect(self, frame: Frame) -> Detections: ...


@runtime_checkable
class Tracker(Protocol):
    """A stage that turns per-frame detections into tracks with identities."""

    name: str

    def update(self, detections: Detections, frame: Frame | None = None) -> Tracks: ...


@runtime_checkable
class DetectorTracker(Protocol):
    """A stage that detects and tracks at once (e.g. the stable-features tracker)."""

    name: str

    def process(self, frame: Frame) -> tuple[Detections, Tracks]: ...
