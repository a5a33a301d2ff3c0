"""PTracking: the multi-clustered particle filter of paper A, local layer (one camera).

After Bloisi et al., "Enhancing automatic maritime surveillance systems with visual information"
(IEEE T-ITS), whose tracker is PTracking (Previtali and Iocchi): a particle filter whose
particle cloud holds every vessel at once, split into targets by KClusterize, with group
tracking and colour re-identification through occlusions.

The loop, per frame (:meth:`PTrackingTracker.update`):

1. **Ego-motion** (optional): a moving camera's image motion since the last frame, from the PTZ
   state and the camera model or from sparse optical flow, is applied to every particle and
   track.
2. **Predict**: each track moves on its constant velocity; its particles with it, plus jitter.
3. **Observe**: the observation of a box is its bottom centre.  A share of the particles is
   drawn around the observations (so new vessels are found), and every particle is weighed by
   ``sum_j exp(-|(p - z_j) / sigma_j|)``, an elliptical kernel scaled by each box.
4. **KClusterize** the weighted cloud into a Gaussian mixture (:mod:`.kclusterize`); a cluster
   holding several observations is split between them.
5. **Groups** (:mod:`.group`): the observations in a group's region belong to the group; members
   plainly observed are updated, the others coast on their velocities.  When the members'
   predicted boxes separate, the observations that come out are given to the members by the
   Bhattacharyya distance of their HSV histograms.
6. **Associate** the other clusters with tracks (Hungarian on the distance to the predicted
   position, gated); update matched tracks (position = posterior mean of the track's own
   particles, velocity = exponentially weighted regression over the recent positions, box size
   = a constant-rate Kalman filter).
7. **Births**: a cluster with an observation and no track (and not on top of one) starts a
   tentative track; it is confirmed after ``confirm_hits`` sightings within
   ``confirm_window_s``; at confirmation it is first re-identified against recently lost and
   coasting tracks (the paper's tests: same direction, similar speed, closeness, and the colour
   model) before a new number is given.
8. **Delete** tentative tracks unseen for ``confirm_window_s``, confirmed ones unseen for
   ``max_coast_s`` (group members are kept while their group lasts).
9. **Form groups** of confirmed tracks whose boxes, shrunk to 0.8, overlap; save their colours.
10. **Resample** each track's particles (systematic, per cluster) to its share of the budget.

See ``docs/ptracking.md`` for the deviations from the paper.

Every time parameter is in seconds; pixel parameters are given for a 704-pixel-wide image and
scaled with the width of the frames (or ``image_width_px``).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.track.group import (
    HSV_BINS,
    Group,
    colour_distance_matrix,
    hsv_histograms,
    match_by_colour,
    overlap_components,
)
from seawatch.track.kclusterize import Clusters, kclusterize
from seawatch.track.particle import (
    kernel_likelihood,
    predict_particles,
    resample_groups,
    sample_gaussians,
)
from seawatch.types import Detections, Frame, Tracks, TrackState

__all__ = ["PTrackingTracker", "REFERENCE_WIDTH_PX", "BELIEF_DTYPE"]

REFERENCE_WIDTH_PX = 704.0  # the paper's image width; pixel parameters are given for it

#: One published belief of a sensor (local layer -> global layer): a Gaussian per confirmed track.
BELIEF_DTYPE = np.dtype(
    [
        ("sensor", "U32"),
        ("id", np.int64),
        ("t_s", np.float64),
        ("weight", np.float64),
        ("mean", np.float64, (2,)),
        ("sigma", np.float64, (2,)),
        ("velocity", np.float64, (2,)),
    ]
)

_NB = int(sum(HSV_BINS))


class _Bank:
    """Track state in parallel arrays (one row per track, rows in ascending ``uid``)."""

    FIELDS = {
        "uid": (np.int64, ()),  # internal identity (particle labels)
        "pid": (np.int64, ()),  # public id, -1 while tentative
        "pos": (np.float64, (2,)),  # bottom centre, px
        "vel": (np.float64, (2,)),  # px/s
        "size": (np.float64, (2,)),  # w, h px
        "sigma": (np.float64, (2,)),  # cluster spread, px
        "weight": (np.float64, ()),  # cluster weight
        "born_t": (np.float64, ()),
        "last_t": (np.float64, ()),  # start of the current coasting period (deletion clock)
        "obs_t": (np.float64, ()),  # time of the last observation
        "obs_pos": (np.float64, (2,)),  # position at the last observation
        "hits": (np.int64, ()),
        "resid_var": (np.float64, ()),  # smoothed squared innovation per axis, px^2
        "confirmed": (np.bool_, ()),
        "updated": (np.bool_, ()),  # updated in this frame
        "reg": (np.float64, (7,)),  # S_w, S_t, S_tt, S_x, S_y, S_tx, S_ty (time origin = now)
        "srate": (np.float64, (2,)),  # box size rate (w, h), px/s: a constant-rate Kalman filter ...
        "sP": (np.float64, (2, 3)),  # ... with covariance (p_ss, p_sr, p_rr) per axis
        "hist": (np.float64, (_NB,)),  # clean colour model
        "has_hist": (np.bool_, ()),
        "hist_t": (np.float64, ()),
        "group": (np.int64, ()),  # index into the tracker's groups, -1 when none
    }

    def __init__(self, confirm_hits: int) -> None:
        self.k = max(int(confirm_hits), 1)
        for name, (dt, shape) in self.FIELDS.items():
            setattr(self, name, np.zeros((0, *shape), dt))
        self.hit_t = np.zeros((0, self.k))  # the last k sighting times (ring, oldest first)

    def __len__(self) -> int:
        return len(self.uid)

    def append(self, n: int) -> np.ndarray:
        """Append ``n`` zeroed rows; return their row indices."""
        start = len(self.uid)
        for name, (dt, shape) in self.FIELDS.items():
            setattr(self, name, np.concatenate([getattr(self, name), np.zeros((n, *shape), dt)]))
        self.hit_t = np.concatenate([self.hit_t, np.full((n, self.k), -np.inf)])
        self.group[start:] = -1
        self.pid[start:] = -1
        return np.arange(start, start + n)

    def keep(self, mask: np.ndarray) -> None:
        for name in self.FIELDS:
            setattr(self, name, getattr(self, name)[mask])
        self.hit_t = self.hit_t[mask]

    def boxes(self, rows=None) -> np.ndarray:
        pos = self.pos if rows is None else self.pos[rows]
        size = self.size if rows is None else self.size[rows]
        return np.column_stack([pos[:, 0] - size[:, 0] / 2, pos[:, 1] - size[:, 1], size[:, 0], size[:, 1]])


def _bottom_centres(boxes: np.ndarray) -> np.ndarray:
    return np.column_stack([boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3]])


def _box_from(pos: np.ndarray, size: np.ndarray) -> np.ndarray:
    return np.column_stack([pos[:, 0] - size[:, 0] / 2, pos[:, 1] - size[:, 1], size[:, 0], size[:, 1]])


def _iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every box of ``a`` with every box of ``b`` (x, y, w, h)."""
    ix = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    iy = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    inter = np.clip(ix, 0, None) * np.clip(iy, 0, None)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
    return inter / np.maximum(union, 1e-12)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na == 0 or nb == 0:
        return 180.0
    c = float(np.dot(a, b) / (na * nb))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


class PTrackingTracker:
    """PTracking local layer: multi-clustered particle filter with group tracking (paper A).

    Pixel parameters (``*_px``, ``*_px_s``) are for a 704-pixel-wide image and scale with the
    width of the frames; ``*_frac`` parameters are fractions of each vessel's box size.

    Parameters
    ----------
    num_particles : int
        Particle budget (paper: 500).  A share ``inject_frac`` is drawn around the observations
        each frame, the rest is split evenly among the tracks (at least
        ``min_particles_per_track`` each).
    delta_px : float
        KClusterize radius (paper: 20 px).
    kernel_frac : float
        Scale of the likelihood kernel ``exp(-|(p - z) / sigma|)`` of an observation, per axis,
        as a fraction of its box width and height (bounded by 0.5 px and ``kernel_sigma_px``).
    kernel_sigma_px, inject_sigma_px : float
        Upper bounds of the kernel scale and of the spread of the particles drawn around an
        observation.
    process_noise_frac : float
        Particle jitter, a random walk whose speed is this many box sizes (geometric mean of
        width and height) per second, between 2 px/s and ``process_noise_px_s``.
    inject_frac : float
        Share of the budget drawn around the observations each frame (new vessels are found
        there; a track whose own particles lose its vessel is re-seeded from them).
    min_particles_per_track : int
    gate_px : float
        Largest distance from a track's predicted position to a cluster it is associated with
        (default ``3 * delta_px``).
    confirm_hits : int
        Sightings a tentative track needs ...
    confirm_window_s : float
        ... within this time to be confirmed (widened to 1.5 frame intervals per sighting at low
        frame rates); a tentative track unseen this long is deleted.
    max_coast_s : float
        A confirmed track without an observation for this long is deleted (and remembered for
        re-identification for ``reid_memory_s``).
    velocity_tau_s : float
        Time constant of the exponentially weighted regression over the recent positions that
        gives each track's velocity.
    size_accel_frac, size_meas_frac, size_rate0_frac : float
        The box size (carried along) is a constant-rate Kalman filter per axis: white-noise
        acceleration of ``size_accel_frac`` box heights per s^2, measurement noise of
        ``size_meas_frac`` of the size, initial rate uncertainty ``size_rate0_frac`` of the
        size per second.
    prior_estimate : bool
        Sequential importance resampling on each track's own particles (the posterior mean of
        its predicted particles is its position); off: the cluster mean, observation-drawn
        particles included.
    birth_iou_max : float
        A cluster whose box overlaps a live track's by this IoU or more starts no track.
    group_shrink : float
        Boxes shrunk to this fraction of their size that overlap form a group (paper: 0.8).
    colour_max_dist : float
        Weighted H/S/V Bhattacharyya distance below which two colour models match (paper: 0.35).
    group_update : bool
        Update group members from observations that can only be theirs (as many observations
        as members, or a colour match); off: members always coast, as in the paper.
    group_hold_s : float
        A group member unobserved for less than this carries on from its last view (a partial
        occlusion); longer, it coasts from its last whole view, with that box (hidden).
    group_max_s : float
        A group lasting longer than this is dissolved (its members then re-identified).
    hist_interval_s : float
        How often an isolated confirmed track refreshes its colour model.
    reid_memory_s : float
        How long a lost track can be re-identified.
    reid_angle_deg, reid_speed_ratio : float
        The paper's association tests against a lost track: the displacement since it was lost
        and the new track's velocity must point along its velocity (angle below
        ``reid_angle_deg``, widened by the velocity's uncertainty) at a speed within
        ``reid_speed_ratio`` (relative) of its speed.
    min_speed_px_s : float
        Below this speed a track counts as still and only closeness is tested.
    ego_motion : {"none", "flow", "ptz"}
        Compensate a moving camera: from sparse optical flow between frames, or from the frames'
        PTZ states through ``camera`` (a :class:`seawatch.camera.CameraModel`).
    camera : CameraModel, optional
        Needed by ``ego_motion="ptz"``.
    image_width_px : float
        Image width used to scale the pixel parameters until a frame is seen (0: 704).
    output_tentative : bool
        Also output tentative tracks (with negative, provisional ids).
    seed : int
        Seed of the particle filter's random numbers (the same seed and input give the same
        tracks).
    """

    name = "ptracking"

    def __init__(
        self,
        *,
        num_particles: int = 500,
        delta_px: float = 20.0,
        kernel_sigma_px: float = 5.0,
        inject_sigma_px: float = 3.0,
        process_noise_px_s: float = 20.0,
        inject_frac: float = 0.3,
        min_particles_per_track: int = 12,
        gate_px: float = 0.0,
        confirm_hits: int = 3,
        confirm_window_s: float = 1.0,
        max_coast_s: float = 2.0,
        velocity_tau_s: float = 1.0,
        group_shrink: float = 0.8,
        colour_max_dist: float = 0.35,
        group_max_s: float = 15.0,
        hist_interval_s: float = 0.5,
        reid_memory_s: float = 10.0,
        reid_angle_deg: float = 10.0,
        reid_speed_ratio: float = 0.5,
        min_speed_px_s: float = 5.0,
        ego_motion: str = "none",
        camera=None,
        image_width_px: float = 0.0,
        output_tentative: bool = False,
        prior_estimate: bool = True,
        kernel_frac: float = 0.05,
        size_accel_frac: float = 2.0,
        size_meas_frac: float = 0.04,
        size_rate0_frac: float = 0.5,
        birth_iou_max: float = 0.5,
        group_update: bool = True,
        group_hold_s: float = 0.5,
        process_noise_frac: float = 0.15,
        seed: int = 0,
    ) -> None:
        if num_particles < 10:
            raise ValueError(f"PTrackingTracker: num_particles must be >= 10, got {num_particles}")
        if confirm_hits < 1:
            raise ValueError(f"PTrackingTracker: confirm_hits must be >= 1, got {confirm_hits}")
        for nm, v in (("confirm_window_s", confirm_window_s), ("max_coast_s", max_coast_s),
                      ("velocity_tau_s", velocity_tau_s),
                      ("group_max_s", group_max_s), ("reid_memory_s", reid_memory_s)):
            if not v >= 0:
                raise ValueError(f"PTrackingTracker: {nm} must be >= 0 seconds, got {v}")
        if not delta_px > 0 or not kernel_sigma_px > 0 or not inject_sigma_px > 0:
            raise ValueError("PTrackingTracker: delta_px, kernel_sigma_px and inject_sigma_px must be > 0")
        if not 0 < inject_frac < 1:
            raise ValueError(f"PTrackingTracker: inject_frac must be in (0, 1), got {inject_frac}")
        if ego_motion not in ("none", "flow", "ptz"):
            raise ValueError(f"PTrackingTracker: ego_motion must be none, flow or ptz, got {ego_motion!r}")
        if ego_motion == "ptz" and camera is None:
            raise ValueError("PTrackingTracker: ego_motion='ptz' needs a camera model (camera=...)")
        self.num_particles = int(num_particles)
        self.delta_px = float(delta_px)
        self.kernel_sigma_px = float(kernel_sigma_px)
        self.inject_sigma_px = float(inject_sigma_px)
        self.process_noise_px_s = float(process_noise_px_s)
        self.inject_frac = float(inject_frac)
        self.min_particles_per_track = int(min_particles_per_track)
        self.gate_px = float(gate_px) if gate_px > 0 else 3.0 * self.delta_px
        self.confirm_hits = int(confirm_hits)
        self.confirm_window_s = float(confirm_window_s)
        self.max_coast_s = float(max_coast_s)
        self.velocity_tau_s = float(velocity_tau_s)
        self.group_shrink = float(group_shrink)
        self.colour_max_dist = float(colour_max_dist)
        self.group_max_s = float(group_max_s)
        self.hist_interval_s = float(hist_interval_s)
        self.reid_memory_s = float(reid_memory_s)
        self.reid_angle_deg = float(reid_angle_deg)
        self.reid_speed_ratio = float(reid_speed_ratio)
        self.min_speed_px_s = float(min_speed_px_s)
        self.ego_motion = ego_motion
        self.camera = camera
        self.image_width_px = float(image_width_px)
        self.output_tentative = bool(output_tentative)
        self.prior_estimate = bool(prior_estimate)
        self.kernel_frac = float(kernel_frac)
        self.size_accel_frac = float(size_accel_frac)
        self.size_meas_frac = float(size_meas_frac)
        self.size_rate0_frac = float(size_rate0_frac)
        self.birth_iou_max = float(birth_iou_max)
        self.group_update = bool(group_update)
        self.group_hold_s = float(group_hold_s)
        self.process_noise_frac = float(process_noise_frac)
        self.seed = int(seed)
        self.reset()

    @classmethod
    def from_config(cls, config, *, fps: float | None = None, camera=None) -> "PTrackingTracker":
        """Build from a :class:`seawatch.config.Config` (its ``[tracker]`` section)."""
        t = config.tracker
        kw = dict(
            num_particles=t.num_particles,
            confirm_hits=t.confirm_hits,
            confirm_window_s=t.confirm_window_s,
            max_coast_s=t.max_coast_s,
            seed=t.seed,
        )
        for name in ("delta_px", "group_shrink", "colour_max_dist", "reid_memory_s", "ego_motion"):
            if hasattr(t, name):
                kw[name] = getattr(t, name)
        if kw.get("ego_motion") == "ptz" and camera is None:
            kw["ego_motion"] = "none"
        return cls(camera=camera, **kw)

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget every track, particle and lost track (ids keep counting up)."""
        self.rng = np.random.default_rng(self.seed)
        self.bank = _Bank(self.confirm_hits)
        self.particles = np.zeros((0, 2))
        self.labels = np.zeros(0, np.int64)  # uid of each particle's track, -1 none
        self.prow = np.zeros(0, np.int64)  # bank row of each particle's track, -1 none
        self.groups: list[Group | None] = []
        self.lost: list[dict] = []
        self._t: float | None = None
        self._dt = 0.0  # latest frame interval
        self._scale = (self.image_width_px or REFERENCE_WIDTH_PX) / REFERENCE_WIDTH_PX
        self._img_size: tuple[int, int] | None = None
        self._prev_grey: np.ndarray | None = None
        self._prev_ptz = None
        self._frame: Frame | None = None
        if not hasattr(self, "_next_uid"):
            self._next_uid = 1
            self._next_pid = 1
        self.n_rejected = 0  # detections rejected as malformed (non-finite, non-positive size)

    def _px(self, v: float) -> float:
        return v * self._scale

    # ------------------------------------------------------------------ ego-motion
    def _ego_affine(self, frame: Frame) -> np.ndarray | None:
        """2x3 affine taking last frame's pixels to this frame's, or None."""
        if self.ego_motion == "ptz":
            ptz, prev = frame.ptz, self._prev_ptz
            self._prev_ptz = ptz
            if ptz is None or prev is None or (
                ptz.pan_deg == prev.pan_deg and ptz.tilt_deg == prev.tilt_deg and ptz.zoom == prev.zoom
            ):
                return None
            h, w = frame.shape
            cam = self.camera
            if cam.intrinsics.width != w or cam.intrinsics.height != h:
                cam = cam.with_intrinsics(cam.intrinsics.scaled_to(w, h))
            c0, c1 = cam.with_ptz(prev), cam.with_ptz(ptz)
            gu, gv = np.meshgrid(np.linspace(0, w - 1, 5), np.linspace(0, h - 1, 5))
            az, el = c0.pixel_to_azel(gu.ravel(), gv.ravel())
            u, v, ok = c1.azel_to_pixel(az, el)
            if ok.sum() < 3:
                return None
            src = np.column_stack([gu.ravel(), gv.ravel()])[ok]
            dst = np.column_stack([u, v])[ok]
            X = np.column_stack([src, np.ones(len(src))])
            A, *_ = np.linalg.lstsq(X, dst, rcond=None)
            return A.T
        if self.ego_motion == "flow":
            img = frame.image
            grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            if grey.dtype != np.uint8:
                grey = cv2.normalize(grey, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
            f = min(1.0, 320.0 / grey.shape[1])
            small = cv2.resize(grey, None, fx=f, fy=f, interpolation=cv2.INTER_AREA) if f < 1 else grey
            prev, self._prev_grey = self._prev_grey, small
            if prev is None or prev.shape != small.shape:
                return None
            pts = cv2.goodFeaturesToTrack(prev, maxCorners=200, qualityLevel=0.01, minDistance=8)
            if pts is None or len(pts) < 8:
                return None
            nxt, st, _ = cv2.calcOpticalFlowPyrLK(prev, small, pts, None, winSize=(21, 21), maxLevel=3)
            ok = st.ravel() == 1
            if ok.sum() < 8:
                return None
            M, inl = cv2.estimateAffinePartial2D(pts[ok], nxt[ok], method=cv2.RANSAC,
                                                 ransacReprojThreshold=2.0)
            if M is None:
                return None
            M = M.astype(np.float64)
            M[:, 2] /= f  # back to full-resolution pixels
            return M
        return None

    def _apply_affine(self, M: np.ndarray) -> None:
        A, b = M[:, :2], M[:, 2]
        s = math.sqrt(abs(np.linalg.det(A)))
        if len(self.particles):
            self.particles = self.particles @ A.T + b
        bk = self.bank
        if len(bk):
            bk.pos = bk.pos @ A.T + b
            bk.obs_pos = bk.obs_pos @ A.T + b
            bk.vel = bk.vel @ A.T
            bk.size = bk.size * s
            bk.sigma = bk.sigma * s
            sx = bk.reg[:, 3:5] @ A.T + bk.reg[:, 0:1] * b
            stx = bk.reg[:, 5:7] @ A.T + bk.reg[:, 1:2] * b
            bk.reg[:, 3:5] = sx
            bk.reg[:, 5:7] = stx
            bk.srate = bk.srate * s
            bk.sP = bk.sP * np.array([s * s, s * s, s * s])
        for lt in self.lost:
            lt["pos"] = lt["pos"] @ A.T + b
            lt["vel"] = lt["vel"] @ A.T
            lt["size"] = lt["size"] * s

    # ------------------------------------------------------------------ regression
    @staticmethod
    def _advance(r: np.ndarray, dt: float, tau: float) -> None:
        """Move a regression's time origin forward by ``dt`` and age its samples (in place).

        Columns: S_w, S_t, S_tt, S_a, S_b, S_ta, S_tb, exponentially weighted (time constant
        ``tau``) sums over the samples of the two fitted quantities a, b."""
        if len(r) == 0 or dt <= 0:
            return
        sw, st, stt = r[:, 0].copy(), r[:, 1].copy(), r[:, 2].copy()
        r[:, 1] = st - dt * sw
        r[:, 2] = stt - 2 * dt * st + dt * dt * sw
        r[:, 5] = r[:, 5] - dt * r[:, 3]
        r[:, 6] = r[:, 6] - dt * r[:, 4]
        r *= math.exp(-dt / tau) if tau > 0 else 0.0

    def _advance_regression(self, dt: float) -> None:
        self._advance(self.bank.reg, dt, self.velocity_tau_s)
        # box size: constant-rate Kalman prediction (white-noise size acceleration)
        bk = self.bank
        q = (self.size_accel_frac * bk.size[:, 1:2]) ** 2 * np.ones((1, 2))  # (T, 2), scaled by the height
        p = bk.sP
        p00, p01, p11 = p[:, :, 0], p[:, :, 1], p[:, :, 2]
        n00 = p00 + 2 * dt * p01 + dt * dt * p11 + q * dt ** 4 / 4
        n01 = p01 + dt * p11 + q * dt ** 3 / 2
        n11 = p11 + q * dt * dt
        bk.sP = np.stack([n00, n01, n11], axis=2)
        bk.size = np.maximum(bk.size + bk.srate * dt, 1.0)

    def _update_size(self, rows: np.ndarray, z: np.ndarray, fresh: np.ndarray) -> None:
        """Kalman update of the box size of tracks ``rows`` with measured sizes ``z``."""
        bk = self.bank
        r = (self.size_meas_frac * np.maximum(z, 1.0)) ** 2
        p = bk.sP[rows]
        p00, p01, p11 = p[:, :, 0], p[:, :, 1], p[:, :, 2]
        S = p00 + r
        k0, k1 = p00 / S, p01 / S
        y = z - bk.size[rows]
        size = bk.size[rows] + k0 * y
        rate = bk.srate[rows] + k1 * y
        newp = np.stack([(1 - k0) * p00, (1 - k0) * p01, p11 - k1 * p01], axis=2)
        # a new track starts from its measurement, its rate unknown
        init = np.stack([r, np.zeros_like(r), (self.size_rate0_frac * z) ** 2], axis=2)
        f = fresh[:, None]
        bk.size[rows] = np.maximum(np.where(f, z, size), 1.0)
        bk.srate[rows] = np.where(f, 0.0, rate)
        bk.sP[rows] = np.where(f[:, :, None], init, newp)

    def _velocity_sigmas(self) -> np.ndarray:
        """Standard deviation of every track's velocity (px/s; inf with fewer than two sightings)."""
        reg = self.bank.reg
        with np.errstate(divide="ignore", invalid="ignore"):
            spread = reg[:, 2] - reg[:, 1] ** 2 / reg[:, 0]
            sv = np.sqrt(self.bank.resid_var / spread)
        return np.where((reg[:, 0] > 0) & (spread > 1e-12), sv, np.inf)

    def _velocity_sigma(self, r: int) -> float:
        """Standard deviation of track ``r``'s velocity (px/s), from its regression's time spread."""
        reg = self.bank.reg[r]
        if reg[0] <= 0:
            return np.inf
        spread = reg[2] - reg[1] ** 2 / reg[0]  # sum of w (t - mean t)^2
        if spread <= 1e-12:
            return np.inf
        return float(np.sqrt(self.bank.resid_var[r] / spread))

    def _regression_velocity(self, rows: np.ndarray) -> np.ndarray:
        r = self.bank.reg[rows]
        den = r[:, 0] * r[:, 2] - r[:, 1] ** 2
        ok = den > 1e-9 * np.maximum(r[:, 0] ** 2, 1e-300)
        v = np.zeros((len(rows), 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            v[:, 0] = (r[:, 0] * r[:, 5] - r[:, 1] * r[:, 3]) / den
            v[:, 1] = (r[:, 0] * r[:, 6] - r[:, 1] * r[:, 4]) / den
        return np.where(ok[:, None], v, self.bank.vel[rows])

    # ------------------------------------------------------------------ the loop
    def update(self, detections: Detections, frame: Frame | None = None) -> Tracks:
        """Advance to ``detections.t_s`` and return the tracks (confirmed and coasting).

        Parameters
        ----------
        detections : Detections
            Boxes of this frame (malformed ones, non-finite or of non-positive size, are
            rejected and counted in ``n_rejected``).
        frame : Frame, optional
            The image: used for the colour models of group tracking and re-identification, for
            the image size (parameter scaling, tracks leaving the image) and for ego-motion.
        """
        t = float(detections.t_s)
        if self._t is not None and t < self._t:  # time went backwards: a new sequence
            self.reset()
        dt = 0.0 if self._t is None else t - self._t
        self._t = t
        if dt > 0:
            self._dt = dt
        self._frame = frame
        if frame is not None:
            h, w = frame.shape
            if self._img_size is None:
                self._scale = w / REFERENCE_WIDTH_PX
            self._img_size = (h, w)
            M = self._ego_affine(frame) if self.ego_motion != "none" else None
            if M is not None:
                self._apply_affine(M)
        bk = self.bank
        delta = self._px(self.delta_px)

        # observations: bottom centres of the well-formed boxes
        boxes = np.asarray(detections.boxes, dtype=np.float64).reshape(-1, 4)
        good = np.all(np.isfinite(boxes), axis=1) & (boxes[:, 2] > 0) & (boxes[:, 3] > 0)
        if not np.all(good):
            self.n_rejected += int((~good).sum())
            boxes = boxes[good]
        z = _bottom_centres(boxes)
        m = len(z)

        # 1. predict tracks and their particles
        if dt > 0 and len(bk):
            bk.pos = bk.pos + bk.vel * dt
            self._advance_regression(dt)
        bk.updated[:] = False
        if len(self.particles):
            rows = self.prow
            safe = np.maximum(rows, 0)
            vp = np.where(rows[:, None] >= 0, bk.vel[safe] if len(bk) else 0.0, 0.0)
            # jitter: a random walk whose speed scales with the vessel's size in the image, plus
            # the uncertainty of the track's velocity (large for a young track)
            cap = self._px(self.process_noise_px_s)
            spd = cap
            if len(bk):
                base = np.clip(self.process_noise_frac * np.sqrt(np.prod(bk.size, 1)), self._px(2.0), cap)
                trk_spd = np.sqrt(base ** 2 + np.minimum(self._velocity_sigmas(), cap) ** 2)
                spd = np.where(rows >= 0, trk_spd[safe], cap)
            jitter = np.maximum(spd * dt, 0.3 * self._scale)
            self.particles = predict_particles(self.particles, vp, dt, jitter, self.rng)

        # 2. draw particles around the observations, 3. weigh every particle
        n_inj_total = int(round(self.inject_frac * self.num_particles))
        per_obs = max(2 * self._min_size(), n_inj_total // max(m, 1)) if m else 0
        # kernel scale and spread per observation: a fraction of the box size, within bounds
        osig = np.clip(self.kernel_frac * boxes[:, 2:4], self._px(0.5), self._px(self.kernel_sigma_px))
        inj, comp = sample_gaussians(z, np.minimum(osig, self._px(self.inject_sigma_px)),
                                     np.full(m, per_obs), self.rng)
        P = np.vstack([self.particles, inj]) if len(inj) else self.particles
        lab = np.concatenate([self.labels, np.full(len(inj), -1, np.int64)])
        w = kernel_likelihood(P, z, osig) if m else np.zeros(len(P))
        self._osig = osig

        # 4. KClusterize
        cl = kclusterize(P, w, delta, min_seed_weight=math.exp(-3.0), min_size=self._min_size())
        K = len(cl)
        # each observation's cluster: where most of its drawn particles went
        obs_cluster = np.full(m, -1, np.int64)
        if m and K:
            sel = cl.labels[len(self.particles):]
            okp = sel >= 0
            tab = np.bincount(comp[okp] * K + sel[okp], minlength=m * K).reshape(m, K)
            has = tab.max(axis=1) > 0
            obs_cluster = np.where(has, tab.argmax(axis=1), -1)
            cl, obs_cluster = self._split_by_observation(P, w, cl, z, osig, obs_cluster)
            K = len(cl)
        # each supported cluster's representative observation (the one nearest its mean)
        c_obs = np.full(K, -1, np.int64)
        if m and K:
            j = np.flatnonzero(obs_cluster >= 0)
            d = np.linalg.norm(z[j] - cl.means[obs_cluster[j]], axis=1)
            order = np.argsort(-d, kind="stable")  # nearest written last wins
            c_obs[obs_cluster[j[order]]] = j[order]
        supported = c_obs >= 0
        c_size = np.zeros((K, 2))
        c_size[supported] = boxes[c_obs[supported], 2:4]
        c_pos = cl.means
        self._prior_table(cl, w, K)
        c_track = np.full(K, -1, np.int64)  # row of the track each cluster went to
        consumed = np.zeros(K, bool)  # taken by a group
        self._pending: list[tuple] = []  # track updates of this frame, applied at once
        self._renew: list[tuple] = []  # (group, uid) anchors to renew after them

        # 5. groups
        self._process_groups(t, cl, z, boxes[:, 2:4], obs_cluster, c_track, consumed)

        # 6. associate the remaining clusters with the non-grouped tracks
        free_tr = np.flatnonzero((bk.group < 0) & ~bk.updated)
        free_cl = np.flatnonzero(supported & ~consumed & (c_track < 0))
        gate = self._px(self.gate_px)
        if len(free_tr) and len(free_cl):
            d = np.linalg.norm(bk.pos[free_tr][:, None, :] - c_pos[free_cl][None, :, :], axis=2)
            cost = np.where(d <= gate, d, 1e9)
            ri, ci = linear_sum_assignment(cost)
            ok = cost[ri, ci] < 1e9
            rows, cls_ = free_tr[ri[ok]], free_cl[ci[ok]]
            self._queue_update(rows, self._estimate(rows, cls_, c_pos), c_size[cls_], cl.sigmas[cls_],
                               cl.weights[cls_])
            c_track[cls_] = rows

        # 7. births (not on top of a live track: a second detection of one vessel)
        born = np.flatnonzero(supported & ~consumed & (c_track < 0))
        if len(born) and len(bk):
            iou = _iou(_box_from(c_pos[born], c_size[born]), bk.boxes())
            born = born[iou.max(axis=1) < self.birth_iou_max]
        if len(born):
            rows = bk.append(len(born))
            bk.uid[rows] = np.arange(self._next_uid, self._next_uid + len(born))
            self._next_uid += len(born)
            bk.pos[rows] = c_pos[born]
            bk.size[rows] = c_size[born]
            bk.born_t[rows] = t
            self._queue_update(rows, c_pos[born], c_size[born], cl.sigmas[born], cl.weights[born])
            c_track[born] = rows

        self._flush_updates(t, dt)
        for g, u in self._renew:
            r = int(np.flatnonzero(bk.uid == u)[0])
            g.anchors[u] = (bk.pos[r].copy(), bk.vel[r].copy(), bk.size[r].copy(), t)

        # confirmation (with re-identification against lost tracks)
        window = self._confirm_window()
        ready = np.flatnonzero(~bk.confirmed & bk.updated & (bk.hits >= self.confirm_hits)
                               & (t - bk.hit_t[:, 0] <= window + 1e-9))
        self._absorbed = np.zeros(len(bk), bool)
        for r in ready:  # a handful of events per run
            self._confirm(int(r), t)

        # 8. deletion
        alive = np.where(bk.confirmed, t - bk.last_t <= self.max_coast_s + 1e-9,
                         t - bk.last_t <= window + 1e-9)
        alive |= bk.group >= 0
        alive &= ~self._absorbed
        if self._img_size is not None and len(bk):
            h, wd = self._img_size
            b = bk.boxes()
            inside = (b[:, 0] + b[:, 2] > 0) & (b[:, 1] + b[:, 3] > 0) & (b[:, 0] < wd) & (b[:, 1] < h)
            alive &= inside | bk.updated
        if not np.all(alive):
            dead = np.flatnonzero(~alive)
            for r in dead:
                if bk.confirmed[r] and not self._absorbed[r]:
                    self._remember(int(r), t)
            dead_uids = set(bk.uid[dead].tolist())
            for g in self.groups:
                g.members = [u for u in g.members if u not in dead_uids]
            keep_rows = np.flatnonzero(alive)
            remap = np.full(len(bk), -1, np.int64)
            remap[keep_rows] = np.arange(len(keep_rows))
            c_track = np.where(c_track >= 0, remap[np.maximum(c_track, 0)], -1)
            self.prow = np.where(self.prow >= 0, remap[np.maximum(self.prow, 0)], -1)
            bk.keep(alive)
        self.lost = [lt for lt in self.lost if t - lt["t_lost"] <= self.reid_memory_s]

        # 9. groups form; colour models of isolated tracks refresh
        self._form_groups(t)
        self._refresh_colour(t)

        # 10. per-cluster resampling
        self._resample(P, w, lab, cl, c_track)

        return self._output(t, detections)

    # ------------------------------------------------------------------ pieces
    def _min_size(self) -> int:
        return 5

    def _confirm_window(self) -> float:
        """The confirmation window, widened to 1.5 frame intervals per needed sighting at low rates."""
        return max(self.confirm_window_s, 1.5 * (self.confirm_hits - 1) * self._dt)

    @staticmethod
    def _split_by_observation(P, w, cl, z, osig, obs_cluster):
        """A cluster holding several observations is split between them (each particle goes to the
        observation nearest in kernel units), so that every cluster holds at most one observation.

        KClusterize's radius is fixed, and vessels whose waterlines are closer than it (two small
        boats, or a small boat in front of a large one) share a cluster; their observations are
        distinct, and so must their estimates be."""
        K = len(cl)
        j_all = np.flatnonzero(obs_cluster >= 0)
        n_obs = np.bincount(obs_cluster[j_all], minlength=K)
        if K == 0 or n_obs.max(initial=0) < 2:
            return cl, obs_cluster
        labels = cl.labels.copy()
        obs_cluster = obs_cluster.copy()
        new_k = K
        for c in np.flatnonzero(n_obs >= 2):  # rare: a few per frame at most
            js = j_all[obs_cluster[j_all] == c]
            idx = np.flatnonzero(labels == c)
            d = np.linalg.norm((P[idx][:, None, :] - z[js][None, :, :]) / osig[js][None, :, :], axis=2)
            near = np.argmin(d, axis=1)
            for k, j in enumerate(js[1:], start=1):
                labels[idx[near == k]] = new_k
                obs_cluster[j] = new_k
                new_k += 1
        ok = labels >= 0
        lab = labels[ok]
        ww = w[ok]
        pts = P[ok]
        mass = np.bincount(lab, ww, new_k)
        cnt = np.bincount(lab, None, new_k).astype(np.int64)
        den = np.where(mass > 0, mass, np.maximum(cnt, 1))
        wu = np.where(mass[lab] > 0, ww, 1.0)
        means = np.column_stack([np.bincount(lab, wu * pts[:, 0], new_k), np.bincount(lab, wu * pts[:, 1], new_k)])
        means /= den[:, None]
        dev = (pts - means[lab]) ** 2
        sig = np.sqrt(np.column_stack([np.bincount(lab, wu * dev[:, 0], new_k),
                                       np.bincount(lab, wu * dev[:, 1], new_k)]) / den[:, None])
        tot = mass.sum()
        out = Clusters(labels, mass / tot if tot > 0 else np.zeros(new_k), means, sig, cnt, mass)
        # a split-off piece with no particle (every particle nearer another observation) keeps
        # its observation as its mean
        empty = cnt == 0
        if empty.any():
            for j in np.flatnonzero(np.isin(obs_cluster, np.flatnonzero(empty))):
                out.means[obs_cluster[j]] = z[j]
        return out, obs_cluster

    def _prior_table(self, cl, w, K) -> None:
        """Per (cluster, track): likelihood-weighted sums of the track's predicted particles."""
        n_old = len(self.particles)
        T = len(self.bank)
        self._tab = np.zeros((4, max(K, 1), max(T, 1)))
        self._c_sir = np.zeros(K, bool)
        if n_old == 0 or K == 0 or T == 0:
            return
        prow = self.prow
        lab = cl.labels[:n_old]
        ok = (prow >= 0) & (lab >= 0)
        key = lab[ok] * T + prow[ok]
        ww = w[:n_old][ok]
        pts = self.particles[ok]
        size = K * T
        self._tab[0] = np.bincount(key, ww, size).reshape(K, T)
        self._tab[1] = np.bincount(key, ww * pts[:, 0], size).reshape(K, T)
        self._tab[2] = np.bincount(key, ww * pts[:, 1], size).reshape(K, T)
        self._tab[3] = np.bincount(key, None, size).reshape(K, T)

    def _estimate(self, rows, cls, c_pos) -> np.ndarray:
        """Position of each track ``rows[i]`` given cluster ``cls[i]``: the likelihood-weighted
        mean of its own predicted particles in the cluster (the particle filter's posterior mean),
        or the cluster mean when it has none there (a new or re-acquired track)."""
        rows = np.asarray(rows, np.int64)
        cls = np.asarray(cls, np.int64)
        out = c_pos[cls].copy()
        if not self.prior_estimate or len(rows) == 0:
            return out
        tab = self._tab
        ok = (rows < tab.shape[2]) & (cls < tab.shape[1])
        r, c = rows[ok], cls[ok]
        m = tab[0, c, r]
        # the track's own particles must reach the observation (mean weight above e^-3),
        # else it is re-acquired from the particles drawn around the observation
        good = m > math.exp(-3.0) * np.maximum(tab[3, c, r], 1.0)
        idx = np.flatnonzero(ok)[good]
        self._c_sir[c[good]] = True
        out[idx, 0] = tab[1, c[good], r[good]] / m[good]
        out[idx, 1] = tab[2, c[good], r[good]] / m[good]
        return out

    def _queue_update(self, rows, pos, size, sigma, weight) -> None:
        """Mark tracks ``rows`` updated this frame; their state is updated by :meth:`_flush_updates`."""
        rows = np.asarray(rows, np.int64)
        if len(rows) == 0:
            return
        self.bank.updated[rows] = True
        self._pending.append((rows, np.asarray(pos, float).reshape(-1, 2), np.asarray(size, float).reshape(-1, 2),
                              np.asarray(sigma, float).reshape(-1, 2), np.asarray(weight, float).reshape(-1)))

    def _flush_updates(self, t: float, dt: float) -> None:
        if not self._pending:
            return
        parts = list(zip(*self._pending))
        self._pending = []
        self._update_tracks(*(np.concatenate(p) for p in parts), t, dt)

    def _update_tracks(self, rows, pos, size, sigma, weight, t, dt) -> None:
        """Update tracks ``rows`` with cluster estimates."""
        bk = self.bank
        if len(rows) == 0:
            return
        fresh = bk.hits[rows] == 0
        innov = 0.5 * np.sum((pos - bk.pos[rows]) ** 2, axis=1)
        a = np.where(bk.hits[rows] <= 1, 1.0, 0.2)
        bk.resid_var[rows] = np.where(fresh, (self._px(self.inject_sigma_px)) ** 2,
                                      (1 - a) * bk.resid_var[rows] + a * innov)
        bk.pos[rows] = pos
        self._update_size(rows, size, fresh)
        bk.sigma[rows] = sigma
        bk.weight[rows] = weight
        reg = bk.reg[rows]
        reg[:, 0] += 1.0
        reg[:, 3:5] += pos
        bk.reg[rows] = reg
        bk.vel[rows] = self._regression_velocity(rows)
        bk.last_t[rows] = t
        bk.obs_t[rows] = t
        bk.obs_pos[rows] = pos
        bk.hits[rows] += 1
        ht = bk.hit_t[rows]
        bk.hit_t[rows] = np.column_stack([ht[:, 1:], np.full(len(rows), t)])
        bk.updated[rows] = True

    def _colour(self, boxes: np.ndarray) -> np.ndarray | None:
        f = self._frame
        if f is None or len(boxes) == 0:
            return None
        return hsv_histograms(f.image, boxes)

    def _confirm(self, r: int, t: float) -> None:
        """Confirm track row ``r``: re-identify it against lost and coasting tracks, or number it."""
        bk = self.bank
        bk.confirmed[r] = True
        hist = self._colour(bk.boxes(np.array([r])))
        if hist is not None:
            bk.hist[r] = hist[0]
            bk.has_hist[r] = hist[0].sum() > 0
            bk.hist_t[r] = t
        mine = bk.hist[r] if bk.has_hist[r] else None
        motion = (bk.vel[r].copy(), self._velocity_sigma(r))
        best, best_cost, best_kind = -1, np.inf, ""
        for k, lt in enumerate(self.lost):
            ok, cost = self._reid_test(lt["pos"], lt["vel"], lt["last_t"], lt["hist"], bk.pos[r], mine, t, motion)
            if ok and cost < best_cost:
                best, best_cost, best_kind = k, cost, "lost"
        # confirmed tracks coasting right now are lost too, for the time being
        coasting = np.flatnonzero(bk.confirmed & ~bk.updated & (bk.group < 0) & ~self._absorbed[: len(bk)])
        for q in coasting:
            if q == r:
                continue
            ok, cost = self._reid_test(bk.obs_pos[q], bk.vel[q], bk.obs_t[q],
                                       bk.hist[q] if bk.has_hist[q] else None, bk.pos[r], mine, t, motion)
            if ok and cost < best_cost:
                best, best_cost, best_kind = int(q), cost, "coasting"
        if best_kind == "lost":
            lt = self.lost.pop(best)
            pid, born, old_hist = lt["pid"], lt["born_t"], lt["hist"]
        elif best_kind == "coasting":
            pid, born = int(bk.pid[best]), float(bk.born_t[best])
            old_hist = bk.hist[best].copy() if bk.has_hist[best] else None
            self._absorbed[best] = True  # the coasting track lives on in r
        else:
            bk.pid[r] = self._next_pid
            self._next_pid += 1
            return
        bk.pid[r] = pid
        bk.born_t[r] = born
        if old_hist is not None:
            bk.hist[r] = old_hist  # the older model was taken when the vessel was alone
            bk.has_hist[r] = True

    def _reid_test(self, last_pos, vel, last_t, hist_old, pos, hist, t, motion=None) -> tuple[bool, float]:
        """The paper's tests of a new track at ``pos`` against a track lost at ``last_pos``.

        Closeness to where the lost track should be now; the same direction and a similar speed,
        both for the displacement since it was lost and for the new track's own velocity
        (``motion = (velocity, its standard deviation)``, the tolerance widened by that
        uncertainty, as a new track's velocity rests on a few sightings); and a colour match when
        both colour models exist.  Returns (passed, cost), the cost ranking passing candidates.
        """
        dt = max(t - last_t, 0.0)
        disp = pos - last_pos
        speed = float(np.linalg.norm(vel))
        pred_err = float(np.linalg.norm(pos - (last_pos + vel * dt)))
        delta = self._px(self.delta_px)
        gate = self._px(self.gate_px) + self.reid_speed_ratio * speed * dt
        if pred_err > gate:
            return False, np.inf  # not close to where it should be
        dist = float(np.linalg.norm(disp))
        if speed >= self._px(self.min_speed_px_s) and dist > 2 * delta:
            if _angle_deg(disp, vel) > self.reid_angle_deg:
                return False, np.inf  # not the same direction
            if abs(dist / max(dt, 1e-9) - speed) > self.reid_speed_ratio * speed:
                return False, np.inf  # not a similar speed
        if motion is not None and np.isfinite(motion[1]):
            v_new, sv = motion
            s_new = float(np.linalg.norm(v_new))
            vmin = self._px(self.min_speed_px_s)
            if speed >= vmin and s_new >= max(vmin, 2 * sv):
                tol = self.reid_angle_deg + math.degrees(math.atan2(2 * sv, s_new))
                if _angle_deg(v_new, vel) > tol:
                    return False, np.inf  # heading elsewhere
                if abs(s_new - speed) > self.reid_speed_ratio * speed + 2 * sv:
                    return False, np.inf  # at another speed
        cost = pred_err / max(gate, 1e-9)
        if hist is not None and hist_old is not None:
            dc = float(colour_distance_matrix(hist, hist_old)[0, 0])
            if dc >= self.colour_max_dist:
                return False, np.inf
            cost = dc + 0.1 * cost
        return True, cost

    def _remember(self, r: int, t: float) -> None:
        bk = self.bank
        self.lost.append(dict(
            pid=int(bk.pid[r]), pos=bk.obs_pos[r].copy(), vel=bk.vel[r].copy(),
            size=bk.size[r].copy(), last_t=float(bk.obs_t[r]), t_lost=t, born_t=float(bk.born_t[r]),
            hist=bk.hist[r].copy() if bk.has_hist[r] else None,
        ))

    def _process_groups(self, t, cl, z, osize, obs_cluster, c_track, consumed) -> None:
        """Groups: take the observations in their region; update or coast the members; dissolve.

        Works on the observations themselves rather than on clusters: the members of a group are
        close, so their observations often fall in one cluster."""
        bk = self.bank
        if not self.groups:
            return
        m = len(z)
        o_taken = np.zeros(m, bool)
        # the track each observation is nearest to, in box sizes: a going-on group only looks at
        # the observations nearest to one of its members
        if len(bk) and m:
            msize = np.maximum(bk.size, self._px(self.delta_px) / 4)
            nd = np.linalg.norm((z[:, None, :] - bk.pos[None, :, :]) / msize[None, :, :], axis=2)
            owner = np.argmin(nd, axis=1)
            owner_d = nd[np.arange(m), owner]
        else:
            owner = np.zeros(m, np.int64)
            owner_d = np.full(m, np.inf)
        cc = np.maximum(obs_cluster, 0)
        for gi, g in enumerate(self.groups):
            rows = np.flatnonzero(bk.group == gi)
            if len(rows) < 2:
                bk.group[rows] = -1
                self.groups[gi] = None
                continue
            is_member = np.zeros(len(bk), bool)
            is_member[rows] = True
            boxes = bk.boxes(rows)
            x1, y1 = boxes[:, 0].min(), boxes[:, 1].min()
            x2, y2 = (boxes[:, 0] + boxes[:, 2]).max(), (boxes[:, 1] + boxes[:, 3]).max()
            pad = self._px(self.delta_px)
            free = ~o_taken
            if len(c_track):
                free &= (obs_cluster < 0) | (~consumed[cc] & (c_track[cc] < 0))
            inside = free & (z[:, 0] >= x1 - pad) & (z[:, 0] <= x2 + pad) & (z[:, 1] >= y1 - pad) \
                & (z[:, 1] <= y2 + pad)
            cand = np.flatnonzero(inside)
            comps = overlap_components(boxes, self.group_shrink)
            still = comps.max() == 0 and t - g.formed_t_s <= self.group_max_s
            if still:
                mine = cand[is_member[owner[cand]]]
                pairs = []
                if self.group_update and len(mine):
                    # as many observations as members: only "which is which" is asked, so the
                    # colour is compared relatively (no absolute threshold); fewer: a member is
                    # updated only by a colour match
                    pairs = self._match_members(g, rows, z[mine], osize[mine],
                                                mode="equal" if len(mine) == len(rows) else "fewer")
                    self._take(pairs, rows, mine, z, osize, obs_cluster, cl, c_track, t)
                    for i, j in pairs:  # a whole (not shrunk) view renews the member's anchor
                        u = int(bk.uid[rows[i]])
                        a = g.anchors.get(u)
                        if a is None or np.all(osize[mine[j]] >= 0.9 * a[2]):
                            self._renew.append((g, u))  # once the update is applied
                seen = {i for i, _ in pairs}
                for k, r in enumerate(rows):  # the others coast from their last whole view
                    a = g.anchors.get(int(bk.uid[r]))
                    if k not in seen and t - bk.obs_t[r] <= self.group_hold_s:
                        bk.srate[r] = 0.0  # a short gap: carry on from the last view as it was
                    elif k not in seen and a is not None:
                        bk.pos[r] = a[0] + a[1] * (t - a[3])
                        bk.vel[r] = a[1]
                        bk.size[r] = a[2]
                        bk.srate[r] = 0.0
                # the observations in the region are the group's, bar those plainly another track's
                grab = inside & ~(~is_member[owner] & (owner_d < 0.5))
                o_taken |= grab
                if len(consumed):
                    consumed[obs_cluster[grab & (obs_cluster >= 0)]] = True
                continue
            # the group separates: give the members the observations that come out of it
            self.groups[gi] = None
            bk.group[rows] = -1
            bk.last_t[rows] = np.maximum(bk.last_t[rows], t - 1e-9)  # a fresh coasting period
            if len(cand) == 0:
                continue
            pairs = self._match_members(g, rows, z[cand], osize[cand])
            self._take(pairs, rows, cand, z, osize, obs_cluster, cl, c_track, t)
            # the rest of the observations near the group stay with it for this frame
            o_taken[cand] = True
            rest = obs_cluster[cand]
            rest = rest[rest >= 0]
            if len(consumed):
                consumed[rest[c_track[rest] < 0]] = True
        self._renumber_groups()

    def _renumber_groups(self) -> None:
        """Drop dissolved groups and write each track's group index."""
        bk = self.bank
        self.groups = [g for g in self.groups if g is not None]
        bk.group[:] = -1
        if self.groups:
            where = {u: gi for gi, g in enumerate(self.groups) for u in g.members}
            uids = bk.uid.tolist()
            for r, u in enumerate(uids):
                if u in where:
                    bk.group[r] = where[u]

    def _match_members(self, g: Group, rows, c_pos, c_size, mode="dissolve") -> list[tuple[int, int]]:
        """Pairs (member index, candidate index) of a group's members and the observations
        (bottom centres ``c_pos``, sizes ``c_size``) in its region.

        ``mode``:

        * ``"dissolve"`` (the group separates; the members may have coasted far): colour match
          (Bhattacharyya below ``colour_max_dist``, a small position term breaking ties) when
          every member has a colour model and there is an image, else nearest by position;
          both within twice the gate;
        * ``"equal"`` (as many observations as members, the group goes on): only "which is which"
          is asked; least total cost of colour distance + position offset (in box sizes) + size
          change, no colour threshold; each pair within one box size;
        * ``"fewer"`` (some member is hidden): within half a box size of the member's prediction,
          either a colour match below ``colour_max_dist`` or an observation no other member
          could have made (farther than 1.5 of their box sizes from each of them).
        """
        bk = self.bank
        saved = [g.histograms.get(int(u)) for u in bk.uid[rows]]
        ch = self._colour(_box_from(c_pos, c_size)) if all(h is not None for h in saved) else None
        if mode == "dissolve":
            d = np.linalg.norm(bk.pos[rows][:, None, :] - c_pos[None, :, :], axis=2)
            gate = self._px(self.gate_px)
            pos_cost = np.where(d <= 2 * gate, 0.1 * d / gate, np.inf)
            if ch is not None:
                return [(i, j) for i, j, _ in match_by_colour(np.array(saved), ch, self.colour_max_dist,
                                                              extra_cost=pos_cost)]
            cost = np.where(np.isfinite(pos_cost), pos_cost, 1e9)
            ri, ci = linear_sum_assignment(cost)
            return [(int(i), int(j)) for i, j in zip(ri, ci) if cost[i, j] < 1e9]
        if mode == "fewer" and ch is None:
            return []
        floor = self._px(self.delta_px) / 4
        msize = np.maximum(bk.size[rows], floor)  # (R, 2)
        off = (c_pos[None, :, :] - bk.pos[rows][:, None, :]) / msize[:, None, :]
        pos_norm = np.linalg.norm(off, axis=2)
        ratio = np.maximum(c_size[None, :, :], 1.0) / msize[:, None, :]
        size_term = np.abs(np.log(ratio)).sum(2) + 4.0 * np.maximum(ratio.max(2) - 1.5, 0.0)
        col = colour_distance_matrix(np.array(saved), ch) if ch is not None else np.zeros(pos_norm.shape)
        cost = col + pos_norm + 0.25 * size_term
        ok = pos_norm <= (1.0 if mode == "equal" else 0.5)
        if mode == "fewer":
            # a colour match, or an observation that can only be this member's (every other
            # member is more than 1.5 of its box sizes away from it)
            others = np.array([[np.delete(pos_norm[:, j], i).min(initial=np.inf) for j in range(pos_norm.shape[1])]
                               for i in range(pos_norm.shape[0])])
            ok &= (col < self.colour_max_dist) | (others > 1.5)
        cost = np.where(ok, cost, 1e9)
        ri, ci = linear_sum_assignment(cost)
        return [(int(i), int(j)) for i, j in zip(ri, ci) if cost[i, j] < 1e9]

    def _take(self, pairs, rows, obs, z, osize, obs_cluster, cl, c_track, t) -> None:
        """Update group members ``rows[i]`` with observations ``obs[j]`` for each pair (i, j)."""
        if not pairs:
            return
        pr = rows[[i for i, _ in pairs]]
        pj = obs[[j for _, j in pairs]]
        pc = obs_cluster[pj]
        pos = self._estimate_obs(pr, pj, z)
        sigma = np.where(pc[:, None] >= 0, cl.sigmas[np.maximum(pc, 0)] if len(cl) else 0.0,
                         self._px(self.inject_sigma_px))
        weight = np.where(pc >= 0, cl.weights[np.maximum(pc, 0)] if len(cl) else 0.0, 0.0)
        self._queue_update(pr, pos, osize[pj], sigma, weight)
        for r, c in zip(pr, pc):
            if c >= 0 and c_track[c] < 0:
                c_track[c] = r
                self._c_sir[c] = True  # the others' particles in it stay theirs

    def _estimate_obs(self, rows, obs, z) -> np.ndarray:
        """Posterior mean of each track's own predicted particles given one observation each
        (the kernel of that observation alone); the observation itself when they do not reach it."""
        rows = np.asarray(rows, np.int64)
        obs = np.asarray(obs, np.int64)
        out = z[obs].copy()
        if not self.prior_estimate or len(self.particles) == 0 or len(rows) == 0:
            return out
        pair = np.full(len(self.bank), -1, np.int64)
        pair[rows] = np.arange(len(rows))
        k = np.where(self.prow >= 0, pair[np.maximum(self.prow, 0)], -1)
        sel = np.flatnonzero(k >= 0)
        if len(sel) == 0:
            return out
        k = k[sel]
        p = self.particles[sel]
        j = obs[k]
        w = np.exp(-np.linalg.norm((p - z[j]) / self._osig[j], axis=1))
        n = len(rows)
        mass = np.bincount(k, w, n)
        cnt = np.bincount(k, None, n)
        good = (cnt > 0) & (mass > math.exp(-3.0) * np.maximum(cnt, 1))
        sx = np.bincount(k, w * p[:, 0], n)
        sy = np.bincount(k, w * p[:, 1], n)
        out[good, 0] = sx[good] / mass[good]
        out[good, 1] = sy[good] / mass[good]
        return out

    def _form_groups(self, t: float) -> None:
        bk = self.bank
        conf = np.flatnonzero(bk.confirmed)
        if len(conf) < 2:
            return
        comps = overlap_components(bk.boxes(conf), self.group_shrink)
        if comps.max() == len(conf) - 1:
            return  # nobody overlaps
        for c in range(comps.max() + 1):
            rows = conf[comps == c]
            if len(rows) < 2:
                continue
            old = sorted({int(bk.group[r]) for r in rows if bk.group[r] >= 0})
            if len(old) == 1 and np.all(bk.group[rows] == old[0]):
                continue  # already this group
            members: list[int] = []
            hists: dict[int, np.ndarray | None] = {}
            anchors: dict[int, tuple] = {}
            formed = t
            for gi in old:
                g = self.groups[gi]
                members += g.members
                hists.update(g.histograms)
                anchors.update(g.anchors)
                formed = min(formed, g.formed_t_s)
                self.groups[gi] = None
            for r in rows:
                u = int(bk.uid[r])
                if u not in members:
                    members.append(u)
                    hists[u] = bk.hist[r].copy() if bk.has_hist[r] else None
                    anchors[u] = (bk.pos[r].copy(), bk.vel[r].copy(), bk.size[r].copy(), t)
            self.groups.append(Group(members, hists, formed, anchors))
        self._renumber_groups()

    def _refresh_colour(self, t: float) -> None:
        """Refresh the colour model of confirmed, updated tracks whose box overlaps no other track."""
        bk = self.bank
        if self._frame is None or len(bk) == 0:
            return
        due = bk.confirmed & bk.updated & (bk.group < 0) & (
            ~bk.has_hist | (t - bk.hist_t >= self.hist_interval_s))
        if not due.any():
            return
        boxes = bk.boxes()
        comps = overlap_components(boxes, 1.0)
        alone = np.bincount(comps, minlength=comps.max() + 1)[comps] == 1
        rows = np.flatnonzero(due & alone)
        if len(rows):
            h = self._colour(boxes[rows])
            bk.hist[rows] = h
            bk.has_hist[rows] = h.sum(1) > 0
            bk.hist_t[rows] = t

    def _resample(self, P, w, lab, cl, c_track) -> None:
        bk = self.bank
        n_trk = len(bk)
        if n_trk == 0:
            self.particles = np.zeros((0, 2))
            self.labels = np.zeros(0, np.int64)
            self.prow = np.zeros(0, np.int64)
            return
        grp = np.full(len(P), -1, np.int64)
        # a track without a cluster keeps its own particles (uniform weights)
        prow = np.concatenate([self.prow, np.full(len(P) - len(self.prow), -1, np.int64)])
        has_cluster = np.zeros(n_trk, bool)
        has_cluster[c_track[c_track >= 0]] = True
        own = (prow >= 0) & ~has_cluster[np.maximum(prow, 0)]
        grp[own] = prow[own]
        wts = np.where(own, 1.0, w)
        # a cluster given to a track passes its particles to it (weighted)
        pc = np.where(cl.labels >= 0, c_track[np.maximum(cl.labels, 0)], -1) if len(c_track) else grp
        take = pc >= 0
        if self.prior_estimate and len(c_track):
            # SIR: a track that reached its observation resamples its own particles only
            sir = self._c_sir[np.maximum(cl.labels, 0)] & (cl.labels >= 0)
            take &= ~sir | (lab == bk.uid[np.maximum(pc, 0)])
        grp[take] = pc[take]
        wts[take] = w[take]
        n_inj = int(round(self.inject_frac * self.num_particles))
        per = max(self.min_particles_per_track, (self.num_particles - n_inj) // n_trk)
        idx, g = resample_groups(grp, wts, np.full(n_trk, per), self.rng)
        newP = P[idx]
        newL = bk.uid[g]
        # tracks left without particles get a fresh cloud around their position
        empty = np.flatnonzero(np.bincount(g, minlength=n_trk) == 0)
        if len(empty):
            sig = np.maximum(bk.sigma[empty], self._px(self.inject_sigma_px))
            pts, comp = sample_gaussians(bk.pos[empty], sig, np.full(len(empty), per), self.rng)
            newP = np.vstack([newP, pts])
            newL = np.concatenate([newL, bk.uid[empty][comp]])
        self.particles = newP
        self.labels = newL
        self.prow = np.concatenate([g, empty[comp]]) if len(empty) else g

    def _output(self, t: float, det: Detections) -> Tracks:
        bk = self.bank
        show = bk.confirmed | self.output_tentative
        rows = np.flatnonzero(show)
        ids = np.where(bk.confirmed[rows], bk.pid[rows], -bk.uid[rows])
        states = np.where(bk.confirmed[rows],
                          np.where(bk.updated[rows], int(TrackState.CONFIRMED), int(TrackState.COASTING)),
                          int(TrackState.TENTATIVE)).astype(np.int8)
        return Tracks(t, det.frame_index, ids, bk.boxes(rows), bk.vel[rows].copy(), states,
                      t - bk.born_t[rows], source=self.name, camera_id=det.camera_id)

    # ------------------------------------------------------------------ distributed layer
    def beliefs(self, sensor: str = "cam0", to_world=None) -> np.ndarray:
        """This sensor's beliefs for the global layer: one Gaussian per confirmed track.

        Parameters
        ----------
        sensor : str
            Name of this sensor.
        to_world : callable, optional
            Maps ``(N, 2)`` image points (bottom centres) to ``(N, 2)`` common coordinates (e.g.
            sea-plane metres); the spread and velocity are mapped through its local Jacobian.
            Without it the beliefs stay in pixels.

        Returns
        -------
        structured array of :data:`BELIEF_DTYPE`, ``weight`` normalised over the beliefs.
        """
        bk = self.bank
        rows = np.flatnonzero(bk.confirmed)
        out = np.zeros(len(rows), BELIEF_DTYPE)
        if len(rows) == 0:
            return out
        mean = bk.pos[rows]
        sig = np.maximum(bk.sigma[rows], 0.5 * self._scale)
        vel = bk.vel[rows]
        if to_world is not None:
            h = 1.0
            c = np.asarray(to_world(mean), np.float64)
            jx = (np.asarray(to_world(mean + [h, 0]), np.float64) - c) / h
            jy = (np.asarray(to_world(mean + [0, h]), np.float64) - c) / h
            vel = jx * vel[:, :1] + jy * vel[:, 1:2]
            sig = np.sqrt((jx * sig[:, :1]) ** 2 + (jy * sig[:, 1:2]) ** 2)
            mean = c
        wt = np.where(bk.updated[rows], 1.0, 0.5)  # coasting tracks are less sure
        out["sensor"] = sensor
        out["id"] = bk.pid[rows]
        out["t_s"] = self._t if self._t is not None else 0.0
        out["weight"] = wt / wt.sum()
        out["mean"] = mean
        out["sigma"] = sig
        out["velocity"] = vel
        return out
