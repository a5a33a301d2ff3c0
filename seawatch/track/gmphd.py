"""Centralised Gaussian-mixture PHD filter for azimuth/elevation reports of several cameras (paper C).

The fusion centre keeps the PHD (intensity) of the targets in 3-D as a Gaussian mixture
(Vo and Ma, 2006, "The Gaussian mixture probability hypothesis density filter") over the state
``[e, n, u, ve, vn, vu]`` (metres and metres per second in one local east-north-up frame).  Each
camera report (the azimuth/elevation detections of one image) is fused as it arrives:

1. **Predict** every component to the report's time with a constant-velocity model (white-noise
   acceleration, horizontal and vertical spectral densities apart), survival probability ``ps``.
2. **Births** made from the previous report join the prediction (measurement-driven birth: each
   detection ``(az, el)`` with an a-priori range ``r0 +- sigma_r`` is pushed through the unscented
   transform to a Cartesian position; velocity zero with a wide covariance).
3. **Update** (unscented, vectorised over all components): detection probability ``pd`` where
   the component's predicted mean is inside the camera's field of view and zero outside; clutter
   uniform over the image, ``kappa = lambda / (hfov * vfov)`` in rad^-2; the usual GM-PHD
   missed-detection and per-detection terms.
4. **Prune** (weight < 1e-5), **merge** (Mahalanobis distance 4 under each candidate's
   covariance, to the heaviest remaining component, as in Vo and Ma's Table II), **cap** (100).
5. **Extract** components heavier than 0.5 as targets.

Labels persist: every component carries the label of the component it came from (update and
prediction keep it, a merge keeps the heaviest one's, a birth takes a fresh one); when two
extracted components share a label, the lighter one takes a fresh label.

All steps are array operations over the components (batched Cholesky, sigma points and gains in
NumPy; merging in a Numba kernel).  Reports need not be synchronised, only time-ordered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from seawatch.types import Detections, Tracks, TrackState

__all__ = [
    "PHDSensor",
    "PHDReport",
    "GMPHDFilter",
    "GMPHDTracker",
    "cv_model",
    "azel_from_points",
    "unscented_weights",
    "birth_from_azel",
    "merge_components",
]

NX = 6  # e, n, u, ve, vn, vu
_DEG = math.pi / 180.0


# ----------------------------------------------------------------------------------- sensors
@dataclass(frozen=True)
class PHDSensor:
    """A camera as the fusion centre sees it.

    Parameters
    ----------
    sensor_id : str
        Matches :attr:`Detections.camera_id`.
    position_m : (3,) float
        Optical centre in the common ENU frame (metres).
    boresight_az_deg, boresight_el_deg : float
        Direction of the optical axis.
    hfov_deg, vfov_deg : float
        Field of view; the test is ``|az - az0| <= hfov/2`` and ``|el - el0| <= vfov/2`` unless a
        ``camera`` is given.
    sigma_az_deg, sigma_el_deg : float
        Standard deviation of the measured angles.
    pd : float
        Detection probability inside the field of view.
    clutter_per_scan : float
        Expected number of false detections per image (uniform over the image).
    camera : CameraModel, optional
        When given, the field-of-view test projects through it (``azel_to_pixel`` and
        ``in_image``), with its own pose for the angles' origin.
    """

    sensor_id: str
    position_m: tuple[float, float, float]
    boresight_az_deg: float = 0.0
    boresight_el_deg: float = 0.0
    hfov_deg: float = 120.0
    vfov_deg: float = 30.0
    sigma_az_deg: float = 0.1
    sigma_el_deg: float = 0.1
    pd: float = 0.9
    clutter_per_scan: float = 10.0
    camera: object | None = field(default=None, compare=False, repr=False)

    @classmethod
    def from_spec(cls, spec, **changes) -> "PHDSensor":
        """A sensor from any object with the same attribute names (e.g. a scenario's camera)."""
        names = ("sensor_id", "position_m", "boresight_az_deg", "boresight_el_deg", "hfov_deg",
                 "vfov_deg", "sigma_az_deg", "sigma_el_deg", "pd", "clutter_per_scan", "camera")
        kw = {n: getattr(spec, n) for n in names if hasattr(spec, n)}
        kw["position_m"] = tuple(float(v) for v in kw["position_m"])
        kw.update(changes)
        return cls(**kw)

    @classmethod
    def from_camera(cls, sensor_id: str, camera, origin_geodetic: tuple[float, float, float], *,
                    sigma_az_deg: float = 0.25, sigma_el_deg: float = 0.1, pd: float = 0.7,
                    clutter_per_scan: float = 3.0) -> "PHDSensor":
        """A sensor from a :class:`~seawatch.camera.CameraModel`, placed in the ENU frame whose
        origin is ``origin_geodetic`` (lat, lon, alt of the fusion centre's frame); the field of
        view is tested through the camera model."""
        import pymap3d

        p = camera.pose
        e, n, u = pymap3d.geodetic2enu(p.lat_deg, p.lon_deg, 0.0, *origin_geodetic)
        K = camera.intrinsics
        return cls(sensor_id, (float(e), float(n), float(u) + float(p.height_m)), p.pan_deg,
                   p.tilt_deg, K.hfov_deg, K.vfov_deg, sigma_az_deg, sigma_el_deg, pd,
                   clutter_per_scan, camera=camera)

    @property
    def pos(self) -> np.ndarray:
        return np.asarray(self.position_m, np.float64).reshape(3)

    @property
    def clutter_density(self) -> float:
        """Clutter intensity per rad^2 of (azimuth, elevation)."""
        area = (self.hfov_deg * _DEG) * (self.vfov_deg * _DEG)
        return max(self.clutter_per_scan, 1e-12) / area

    @property
    def R(self) -> np.ndarray:
        """Measurement noise covariance (rad^2)."""
        return np.diag([(self.sigma_az_deg * _DEG) ** 2, (self.sigma_el_deg * _DEG) ** 2])

    def in_fov(self, az_deg, el_deg) -> np.ndarray:
        """Whether directions (degrees) are inside the field of view."""
        az_deg = np.asarray(az_deg, np.float64)
        el_deg = np.asarray(el_deg, np.float64)
        if self.camera is not None:
            u, v, front = self.camera.azel_to_pixel(az_deg, el_deg)
            return np.asarray(front, bool) & np.asarray(self.camera.in_image(u, v), bool)
        daz = (az_deg - self.boresight_az_deg + 180.0) % 360.0 - 180.0
        return (np.abs(daz) <= 0.5 * self.hfov_deg) & (
            np.abs(el_deg - self.boresight_el_deg) <= 0.5 * self.vfov_deg)


@dataclass
class PHDReport:
    """The detections of one image: time, sensor and ``(M, 2)`` azimuth/elevation in degrees."""

    t_s: float
    sensor_id: str
    azel_deg: np.ndarray

    def __post_init__(self) -> None:
        a = np.asarray(self.azel_deg, np.float64)
        self.azel_deg = np.zeros((0, 2)) if a.size == 0 else a.reshape(-1, 2)


# ------------------------------------------------------------------------------- the models
def cv_model(dt_s: float, accel_std_mps2: float, vertical_accel_std_mps2: float):
    """Transition matrix and process noise of the 3-D constant-velocity model.

    White-noise acceleration with standard deviation ``accel_std_mps2`` horizontally and
    ``vertical_accel_std_mps2`` vertically (continuous-time spectral densities ``sigma^2``).

    Returns
    -------
    F, Q : (6, 6) float64
    """
    dt = float(dt_s)
    F = np.eye(NX)
    F[0, 3] = F[1, 4] = F[2, 5] = dt
    q = np.array([accel_std_mps2, accel_std_mps2, vertical_accel_std_mps2], np.float64) ** 2
    Q = np.zeros((NX, NX))
    for i in range(3):
        Q[i, i] = q[i] * dt**3 / 3.0
        Q[i, i + 3] = Q[i + 3, i] = q[i] * dt**2 / 2.0
        Q[i + 3, i + 3] = q[i] * dt
    return F, Q


def azel_from_points(points_m: np.ndarray, origin_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth (clockwise from north) and elevation, in radians, of ENU points seen from ``origin_m``."""
    d = np.asarray(points_m, np.float64)[..., :3] - np.asarray(origin_m, np.float64)
    az = np.arctan2(d[..., 0], d[..., 1])
    el = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
    return az, el


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def unscented_weights(n: int, alpha: float, beta: float, kappa: float):
    """Scaled unscented transform: ``(lambda + n, Wm, Wc)`` for ``2n + 1`` sigma points."""
    lam = alpha**2 * (n + kappa) - n
    c = n + lam
    wm = np.full(2 * n + 1, 0.5 / c)
    wc = wm.copy()
    wm[0] = lam / c
    wc[0] = lam / c + (1.0 - alpha**2 + beta)
    return c, wm, wc


def _chol(P: np.ndarray) -> np.ndarray:
    """Batched lower Cholesky factors, repairing matrices that lost positive definiteness."""
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(P)
        vals = np.maximum(vals, 1e-9 * np.maximum(vals.max(axis=-1, keepdims=True), 1e-12))
        P = (vecs * vals[..., None, :]) @ np.swapaxes(vecs, -1, -2)
        P = 0.5 * (P + np.swapaxes(P, -1, -2)) + 1e-9 * np.eye(P.shape[-1])
        return np.linalg.cholesky(P)


def _sigma_points(m: np.ndarray, P: np.ndarray, c: float) -> np.ndarray:
    """(J, 2n+1, n) sigma points of ``N(m, P)`` with spread ``sqrt(c)``."""
    L = _chol(P) * math.sqrt(c)  # (J, n, n), columns are the directions
    Lt = np.swapaxes(L, 1, 2)
    return np.concatenate([m[:, None, :], m[:, None, :] + Lt, m[:, None, :] - Lt], axis=1)


def birth_from_azel(
    azel_deg: np.ndarray,
    origin_m: np.ndarray,
    *,
    sigma_az_deg: float,
    sigma_el_deg: float,
    range_m: float | np.ndarray = 3000.0,
    sigma_range_m: float = 1500.0,
    sigma_v_mps: float = 10.0,
    sigma_vu_mps: float = 0.5,
    alpha: float = 0.5,
    beta: float = 2.0,
    kappa: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian births from bearings: ``(az, el, r)`` through the unscented transform.

    Each detection ``(az, el)`` (degrees) seen from ``origin_m`` with the a-priori range
    ``range_m +- sigma_range_m`` becomes a Cartesian Gaussian whose long axis lies along the line
    of sight and whose cross-range spread grows with range (a cone of directions, summarised by
    one Gaussian per range).  Velocity is zero with standard deviation ``sigma_v_mps``
    horizontally and ``sigma_vu_mps`` vertically.  ``range_m`` may be an array of ranges: one
    component per detection and range.

    Returns
    -------
    m : (M * R, 6), P : (M * R, 6, 6)
        Detection-major order (all ranges of detection 0 first).
    """
    z = np.asarray(azel_deg, np.float64).reshape(-1, 2) * _DEG
    ranges = np.atleast_1d(np.asarray(range_m, np.float64))
    M, R = len(z), len(ranges)
    if M == 0:
        return np.zeros((0, NX)), np.zeros((0, NX, NX))
    mu = np.empty((M, R, 3))
    mu[:, :, 0] = z[:, None, 0]
    mu[:, :, 1] = z[:, None, 1]
    mu[:, :, 2] = ranges[None, :]
    mu = mu.reshape(-1, 3)
    n = 3
    c, wm, wc = unscented_weights(n, alpha, beta, kappa)
    sd = np.array([sigma_az_deg * _DEG, sigma_el_deg * _DEG, sigma_range_m])
    off = np.zeros((2 * n + 1, n))
    off[1:n + 1] = np.diag(sd) * math.sqrt(c)
    off[n + 1:] = -np.diag(sd) * math.sqrt(c)
    sp = mu[:, None, :] + off[None]  # (K, 7, 3)
    az, el, r = sp[..., 0], sp[..., 1], sp[..., 2]
    ce = np.cos(el)
    pts = np.stack([r * ce * np.sin(az), r * ce * np.cos(az), r * np.sin(el)], axis=-1)
    pts += np.asarray(origin_m, np.float64)
    mean = np.einsum("s,ksd->kd", wm, pts)
    dev = pts - mean[:, None, :]
    cov = np.einsum("s,ksa,ksb->kab", wc, dev, dev)
    K = len(mu)
    m = np.zeros((K, NX))
    m[:, :3] = mean
    P = np.zeros((K, NX, NX))
    P[:, :3, :3] = cov
    P[:, 3, 3] = P[:, 4, 4] = sigma_v_mps**2
    P[:, 5, 5] = sigma_vu_mps**2
    return m, P


# -------------------------------------------------------------------------------- merging
@nb.njit(cache=True)
def _merge_kernel(w, m, P, labels, threshold):  # pragma: no cover - compiled
    J = w.shape[0]
    n = m.shape[1]
    order = np.argsort(-w)
    used = np.zeros(J, np.bool_)
    have_inv = np.zeros(J, np.bool_)
    Pinv = np.empty((J, n, n))
    # d' P^-1 d >= |d|^2 / lambda_max(P) >= |d|^2 / trace(P): a cheap test that skips most pairs
    tr = np.empty(J)
    for i in range(J):
        t = 0.0
        for a in range(n):
            t += P[i, a, a]
        tr[i] = t
    out_w = np.empty(J)
    out_m = np.empty((J, n))
    out_P = np.empty((J, n, n))
    out_l = np.empty(J, np.int64)
    d = np.empty(n)
    members = np.empty(J, np.int64)
    k = 0
    for oi in range(J):
        j = order[oi]
        if used[j]:
            continue
        # members: every unused component within the threshold under its own covariance
        nm = 0
        wsum = 0.0
        mm = np.zeros(n)
        for i in range(J):
            if used[i]:
                continue
            dd = 0.0
            for a in range(n):
                d[a] = m[i, a] - m[j, a]
                dd += d[a] * d[a]
            if i != j and dd > threshold * tr[i]:
                continue
            if not have_inv[i]:
                Pinv[i] = np.linalg.inv(0.5 * (P[i] + P[i].T))
                have_inv[i] = True
            dist = 0.0
            for a in range(n):
                s = 0.0
                for b in range(n):
                    s += Pinv[i, a, b] * d[b]
                dist += d[a] * s
            if dist <= threshold or i == j:
                members[nm] = i
                nm += 1
                used[i] = True
                wsum += w[i]
                for a in range(n):
                    mm[a] += w[i] * m[i, a]
        for a in range(n):
            mm[a] /= wsum
        PP = np.zeros((n, n))
        for q in range(nm):
            i = members[q]
            for a in range(n):
                d[a] = mm[a] - m[i, a]
            for a in range(n):
                for b in range(n):
                    PP[a, b] += w[i] * (P[i, a, b] + d[a] * d[b])
        out_w[k] = wsum
        out_m[k] = mm
        out_P[k] = PP / wsum
        out_l[k] = labels[j]
        k += 1
    return out_w[:k], out_m[:k], out_P[:k], out_l[:k]


def merge_components(w, m, P, labels, threshold: float = 4.0):
    """Vo and Ma's merge: repeatedly take the heaviest component and merge every remaining one
    whose squared Mahalanobis distance to it, under its own covariance, is at most ``threshold``.

    The merged component keeps the label of the heaviest member.  Returns ``w, m, P, labels``.
    """
    if len(w) <= 1:
        return w, m, P, labels
    return _merge_kernel(np.ascontiguousarray(w, np.float64), np.ascontiguousarray(m, np.float64),
                         np.ascontiguousarray(P, np.float64), np.ascontiguousarray(labels, np.int64),
                         float(threshold))


# --------------------------------------------------------------------------------- the filter
class GMPHDFilter:
    """GM-PHD filter over 3-D constant-velocity targets, fusing (az, el) reports sequentially.

    Parameters
    ----------
    sensors : sequence of PHDSensor
        The cameras, by ``sensor_id``.
    accel_std_mps2, vertical_accel_std_mps2 : float
        Process noise (white-noise acceleration) horizontally and vertically.
    ps : float
        Survival probability per second (``ps ** dt`` per prediction).
    ps_unseen : float
        Survival probability per second of a component outside every camera's field of view
        (the surveillance region is the union of the views; Pd is zero outside, so without this
        a target that sails out of view would be kept for ever).
    birth_weight : float
        Weight of the birth component(s) of one detection (split over the birth ranges).
    adaptive_birth : bool
        Scale each detection's birth weight by ``1 - (its share explained by existing targets)``
        (Ristic et al. 2012), so detections of known targets do not spawn births.
    birth_range_m : float or sequence of float
        A-priori range(s) ``r0`` of a birth; several ranges give one component each (the paper
        has one ``r0`` with a large ``sigma_r``; three narrower ones linearise better).
    birth_sigma_range_m : float
        ``sigma_r`` of a birth component.
    birth_sigma_v_mps, birth_sigma_vu_mps : float
        Birth velocity spread, horizontal and vertical.
    birth_max_abs_up_m : float
        The surveillance volume of the births: a birth component whose mean lies farther than
        this above or below the sea surface (``|u|``) is dropped (``inf``: no limit, as in the
        paper).  A line of sight far above the horizon, or far into the sea at that range, then
        makes no birth: most false alarms (sky, near-field waves) never start a target.
    prune_threshold, merge_threshold, max_components, extract_threshold : float, float, int, float
        Vo and Ma's ``T = 1e-5``, ``U = 4``, ``J_max = 100`` and the extraction weight ``0.5``.
    extract_keep_threshold : float, optional
        Hysteresis (not in the paper, which has none: pass None): a label
        extracted at the previous report stays extracted while its heaviest component weighs
        more than this, so one camera's missed detection does not drop a target for a report.
    penalise : bool
        Not in the paper (Yazdian-Dehkordi et al. 2012, "penalised GM-PHD"): when several
        detections of one image each give a predicted component a large weight (a target and a
        false alarm in its gate), the component keeps its best claim and the others are scaled
        down so that its claims add up to at most one; without it a false alarm next to a
        target makes a lasting duplicate.  False: the plain GM-PHD update.
    ut_alpha, ut_beta, ut_kappa : float
        Unscented transform of the update.
    """

    def __init__(
        self,
        sensors,
        *,
        accel_std_mps2: float = 0.3,
        vertical_accel_std_mps2: float = 0.02,
        ps: float = 0.995,
        ps_unseen: float = 0.8,
        birth_weight: float = 0.02,
        adaptive_birth: bool = True,
        birth_range_m=(1500.0, 3000.0, 4500.0),
        birth_sigma_range_m: float = 750.0,
        birth_sigma_v_mps: float = 8.0,
        birth_sigma_vu_mps: float = 0.3,
        birth_max_abs_up_m: float = 50.0,
        prune_threshold: float = 1e-5,
        merge_threshold: float = 4.0,
        max_components: int = 100,
        extract_threshold: float = 0.5,
        extract_keep_threshold: float | None = 0.05,
        penalise: bool = True,
        ut_alpha: float = 0.5,
        ut_beta: float = 2.0,
        ut_kappa: float = 0.0,
    ) -> None:
        self.sensors = {s.sensor_id: s for s in sensors}
        if not self.sensors:
            raise ValueError("GMPHDFilter: at least one sensor is needed")
        self.accel_std_mps2 = float(accel_std_mps2)
        self.vertical_accel_std_mps2 = float(vertical_accel_std_mps2)
        self.ps = float(ps)
        self.ps_unseen = float(ps_unseen)
        self.birth_weight = float(birth_weight)
        self.adaptive_birth = bool(adaptive_birth)
        self.birth_range_m = np.atleast_1d(np.asarray(birth_range_m, np.float64))
        self.birth_sigma_range_m = float(birth_sigma_range_m)
        self.birth_sigma_v_mps = float(birth_sigma_v_mps)
        self.birth_sigma_vu_mps = float(birth_sigma_vu_mps)
        self.birth_max_abs_up_m = float(birth_max_abs_up_m)
        self.prune_threshold = float(prune_threshold)
        self.merge_threshold = float(merge_threshold)
        self.max_components = int(max_components)
        self.extract_threshold = float(extract_threshold)
        self.extract_keep_threshold = (self.extract_threshold if extract_keep_threshold is None
                                       else float(extract_keep_threshold))
        self.penalise = bool(penalise)
        self._ut = unscented_weights(NX, ut_alpha, ut_beta, ut_kappa)
        self.reset()

    def reset(self) -> None:
        self.t_s: float | None = None
        self.w = np.zeros(0)
        self.m = np.zeros((0, NX))
        self.P = np.zeros((0, NX, NX))
        self.labels = np.zeros(0, np.int64)
        self._next_label = 1
        self._birth: tuple | None = None  # (w, m, P) made from the last report, for the next one
        self._extracted = np.zeros(0, np.int64)  # labels extracted at the last step
        self._ext_idx = np.zeros(0, np.int64)  # and their component indices
        self.n_bad_reports = 0

    # ---------------------------------------------------------------------------- steps
    def predict(self, t_s: float) -> None:
        """Predict the intensity (and any pending births) to time ``t_s``."""
        if self.t_s is None:
            self.t_s = float(t_s)
            return
        dt = float(t_s) - self.t_s
        if dt < 0:
            raise ValueError(f"GMPHDFilter: report at t={t_s} s is older than the filter time {self.t_s} s")
        if dt > 0 and len(self.w):
            F, Q = cv_model(dt, self.accel_std_mps2, self.vertical_accel_std_mps2)
            self.m = self.m @ F.T
            self.P = F @ self.P @ F.T + Q
            ps = np.full(len(self.w), self.ps**dt)
            if self.ps_unseen != self.ps:
                ps[~self._in_any_fov(self.m)] = self.ps_unseen**dt
            self.w = self.w * ps
        self.t_s = float(t_s)

    def _in_any_fov(self, m: np.ndarray) -> np.ndarray:
        seen = np.zeros(len(m), bool)
        for s in self.sensors.values():
            az, el = azel_from_points(m[:, :3], s.pos)
            seen |= s.in_fov(np.degrees(az), np.degrees(el))
        return seen

    def _add_births(self) -> None:
        if self._birth is None:
            return
        bw, bm, bP, bt = self._birth
        self._birth = None
        dt = self.t_s - bt
        if dt > 0:
            F, Q = cv_model(dt, self.accel_std_mps2, self.vertical_accel_std_mps2)
            bm = bm @ F.T
            bP = F @ bP @ F.T + Q
        lab = np.arange(self._next_label, self._next_label + len(bw), dtype=np.int64)
        self._next_label += len(bw)
        self.w = np.concatenate([self.w, bw])
        self.m = np.concatenate([self.m, bm])
        self.P = np.concatenate([self.P, bP])
        self.labels = np.concatenate([self.labels, lab])

    def step(self, report: PHDReport) -> None:
        """Fuse one camera report: predict, add births, update, make the next births, reduce."""
        sensor = self.sensors.get(report.sensor_id)
        if sensor is None:
            raise KeyError(f"GMPHDFilter: report from unknown sensor '{report.sensor_id}' "
                           f"(known: {', '.join(sorted(self.sensors))})")
        z = report.azel_deg
        if len(z) and not np.all(np.isfinite(z)):
            self.n_bad_reports += 1
            z = z[np.all(np.isfinite(z), axis=1)]
        self.predict(report.t_s)
        self._add_births()
        explained = self._update(sensor, z * _DEG)
        self._make_births(sensor, z, explained)
        self._reduce()

    def _update(self, sensor: PHDSensor, z: np.ndarray) -> np.ndarray:
        """GM-PHD update with the unscented transform; returns each detection's explained share."""
        M = len(z)
        J = len(self.w)
        if J == 0:
            return np.zeros(M)
        pos = sensor.pos
        # field of view: Pd where the predicted mean is inside, zero outside
        az_m, el_m = azel_from_points(self.m[:, :3], pos)
        inside = sensor.in_fov(az_m / _DEG, el_m / _DEG)
        idx = np.flatnonzero(inside)
        pd = sensor.pd
        w_missed = self.w.copy()
        w_missed[idx] *= 1.0 - pd
        if len(idx) == 0 or M == 0:
            self.w = w_missed
            return np.zeros(M)
        m, P, w = self.m[idx], self.P[idx], self.w[idx]
        c, wm, wc = self._ut
        X = _sigma_points(m, P, c)  # (Ji, 13, 6)
        az, el = azel_from_points(X, pos)  # (Ji, 13)
        az = az[:, :1] + _wrap(az - az[:, :1])  # unwrap around the centre point
        Z = np.stack([az, el], axis=-1)  # (Ji, 13, 2)
        zhat = wm @ Z  # (Ji, 2)
        dZ = Z - zhat[:, None, :]
        dX = X - m[:, None, :]
        dZw = dZ * wc[None, :, None]
        S = np.swapaxes(dZw, 1, 2) @ dZ + sensor.R
        C = np.swapaxes(dX, 1, 2) @ dZw  # (Ji, 6, 2)
        det = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
        Si = np.empty_like(S)
        Si[:, 0, 0] = S[:, 1, 1] / det
        Si[:, 1, 1] = S[:, 0, 0] / det
        Si[:, 0, 1] = -S[:, 0, 1] / det
        Si[:, 1, 0] = -S[:, 1, 0] / det
        K = C @ Si  # (Ji, 6, 2)
        Pu = P - K @ np.swapaxes(C, 1, 2)
        # likelihood of every detection under every component: (M, Ji)
        nu = z[:, None, :] - zhat[None, :, :]
        nu[..., 0] = _wrap(nu[..., 0])
        d2 = (nu[..., 0] ** 2 * Si[None, :, 0, 0] + 2.0 * nu[..., 0] * nu[..., 1] * Si[None, :, 0, 1]
              + nu[..., 1] ** 2 * Si[None, :, 1, 1])
        q = np.exp(-0.5 * d2) / (2.0 * np.pi * np.sqrt(det))[None, :]
        num = pd * w[None, :] * q
        den = sensor.clutter_density + num.sum(axis=1)
        wz = num / den[:, None]  # (M, Ji) posterior weights
        if self.penalise and M > 1:
            # one target makes at most one detection per image: a component that several
            # detections each claim (a target and a false alarm in its gate) keeps its best
            # claim, the others are scaled so that its claims add up to at most 1
            col = wz.sum(axis=0)
            over = np.flatnonzero(col > 1.0)
            if len(over):
                sub = wz[:, over]
                best = sub.argmax(axis=0)
                mx = sub[best, np.arange(len(over))]
                scale = np.clip((1.0 - mx) / np.maximum(col[over] - mx, 1e-300), 0.0, 1.0)
                keep = sub[best, np.arange(len(over))]
                sub *= scale[None, :]
                sub[best, np.arange(len(over))] = keep
                wz[:, over] = sub
        explained = wz.sum(axis=1)
        # keep only pairs that would survive pruning (identical to pruning after the update)
        mi, ji = np.nonzero(wz >= self.prune_threshold)
        mu = m[ji] + (K[ji] @ nu[mi, ji][:, :, None])[:, :, 0]
        self.w = np.concatenate([w_missed, wz[mi, ji]])
        self.m = np.concatenate([self.m, mu])
        self.P = np.concatenate([self.P, Pu[ji]])
        self.labels = np.concatenate([self.labels, self.labels[idx][ji]])
        return explained

    def _make_births(self, sensor: PHDSensor, z_deg: np.ndarray, explained: np.ndarray) -> None:
        if len(z_deg) == 0 or self.birth_weight <= 0:
            return
        bm, bP = birth_from_azel(
            z_deg, sensor.pos, sigma_az_deg=sensor.sigma_az_deg, sigma_el_deg=sensor.sigma_el_deg,
            range_m=self.birth_range_m, sigma_range_m=self.birth_sigma_range_m,
            sigma_v_mps=self.birth_sigma_v_mps, sigma_vu_mps=self.birth_sigma_vu_mps,
        )
        R = len(self.birth_range_m)
        share = np.ones(len(z_deg))
        if self.adaptive_birth:
            share = np.clip(1.0 - explained, 0.0, 1.0)
        bw = np.repeat(self.birth_weight * share / R, R)
        keep = (bw >= self.prune_threshold) & (np.abs(bm[:, 2]) <= self.birth_max_abs_up_m)
        if keep.any():
            self._birth = (bw[keep], bm[keep], bP[keep], self.t_s)

    def _reduce(self) -> None:
        keep = self.w >= self.prune_threshold
        w, m, P, lab = self.w[keep], self.m[keep], self.P[keep], self.labels[keep]
        w, m, P, lab = merge_components(w, m, P, lab, self.merge_threshold)
        if len(w) > self.max_components:
            top = np.argsort(-w, kind="stable")[: self.max_components]
            w, m, P, lab = w[top], m[top], P[top], lab[top]
        # one label per extracted target: a lighter duplicate takes a fresh label
        ext = self._extract_index(w, lab)
        if len(ext) > 1:
            _, first = np.unique(lab[ext], return_index=True)
            dup = np.setdiff1d(np.arange(len(ext)), first)
            for k in dup:
                lab[ext[k]] = self._next_label
                self._next_label += 1
        self._extracted = lab[ext]
        self._ext_idx = ext
        self.w, self.m, self.P, self.labels = w, m, P, lab

    # ---------------------------------------------------------------------------- output
    @property
    def cardinality(self) -> float:
        """Expected number of targets (the sum of the weights)."""
        return float(self.w.sum())

    def _extract_index(self, w: np.ndarray, lab: np.ndarray) -> np.ndarray:
        """Indices of the extracted components, heaviest first."""
        sel = w > self.extract_threshold
        if self.extract_keep_threshold < self.extract_threshold and len(self._extracted):
            sel |= (w > self.extract_keep_threshold) & np.isin(lab, self._extracted)
        ext = np.flatnonzero(sel)
        ext = ext[np.argsort(-w[ext], kind="stable")]
        if self.extract_keep_threshold < self.extract_threshold and len(ext) > 1:
            # a held label is reported once (its heaviest component); a strong one always
            _, first = np.unique(lab[ext], return_index=True)
            strong = w[ext] > self.extract_threshold
            keep = strong.copy()
            keep[first] = True
            ext = ext[keep]
        return ext

    def estimates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Extracted targets: ``labels (N,), states (N, 6), weights (N,)``, heaviest first."""
        ext = self._ext_idx
        return self.labels[ext].copy(), self.m[ext].copy(), self.w[ext].copy()


# ----------------------------------------------------------------------------- as a Tracker
class GMPHDTracker:
    """The GM-PHD filter behind the :class:`seawatch.types.Tracker` protocol (``name="gmphd"``).

    ``update(detections)`` fuses the detections of one camera (their ``camera_id`` names the
    sensor; ``azel_deg`` must be set) and returns the extracted 3-D targets as :class:`Tracks`:
    ``boxes`` are zero (the targets live in the world), ``world`` holds latitude, longitude,
    speed and course when ``origin_geodetic`` (the ENU frame's latitude, longitude, altitude)
    is given, else NaN; :attr:`last_states` holds the ENU states.  Detections without angles
    (``n_bad_detections``) and reports older than the filter (``n_late_reports``) are counted and
    not fused; a camera that is not among the sensors is a configuration error (``KeyError``).
    """

    name = "gmphd"

    def __init__(self, sensors, *, origin_geodetic: tuple[float, float, float] | None = None,
                 **filter_kwargs) -> None:
        self.filter = GMPHDFilter(sensors, **filter_kwargs)
        self.origin_geodetic = origin_geodetic
        self._born: dict[int, float] = {}
        self.last_states = np.zeros((0, NX))
        self.n_bad_detections = 0
        self.n_late_reports = 0

    @classmethod
    def from_config(cls, config, sensors, *, origin_geodetic=None) -> "GMPHDTracker":
        """Build from a :class:`seawatch.config.Config` (its ``[tracker]`` ``phd_*`` fields)."""
        t = config.tracker
        return cls(
            sensors, origin_geodetic=origin_geodetic,
            accel_std_mps2=t.phd_accel_std_mps2, vertical_accel_std_mps2=t.phd_vertical_accel_std_mps2,
            ps=t.phd_ps, ps_unseen=t.phd_ps_unseen, birth_weight=t.phd_birth_weight,
            adaptive_birth=t.phd_adaptive_birth, birth_range_m=tuple(t.phd_birth_range_m),
            birth_sigma_range_m=t.phd_birth_sigma_range_m, birth_sigma_v_mps=t.phd_birth_sigma_v_mps,
            birth_max_abs_up_m=t.phd_birth_max_abs_up_m, prune_threshold=t.phd_prune_threshold,
            merge_threshold=t.phd_merge_threshold, max_components=t.phd_max_components,
            extract_threshold=t.phd_extract_threshold,
            extract_keep_threshold=t.phd_extract_keep_threshold, penalise=t.phd_penalise,
        )

    def update(self, detections: Detections, frame=None) -> Tracks:
        if detections.azel_deg is None:
            if len(detections):
                self.n_bad_detections += 1
            z = np.zeros((0, 2))
        else:
            z = detections.azel_deg
        report = PHDReport(detections.t_s, detections.camera_id, z)
        if self.filter.t_s is not None and report.t_s < self.filter.t_s:
            self.n_late_reports += 1  # out of order: dropped (the intensity cannot go back)
        else:
            self.filter.step(report)
        labels, states, _ = self.filter.estimates()
        self.last_states = states
        t = detections.t_s
        for lab in labels.tolist():
            self._born.setdefault(lab, t)
        ages = np.array([t - self._born[lab] for lab in labels.tolist()], np.float64)
        speed = np.hypot(states[:, 3], states[:, 4])
        course = np.degrees(np.arctan2(states[:, 3], states[:, 4])) % 360.0
        if self.origin_geodetic is not None and len(labels):
            import pymap3d

            lat, lon, _ = pymap3d.enu2geodetic(states[:, 0], states[:, 1], states[:, 2],
                                               *self.origin_geodetic)
            world = np.stack([lat, lon, speed, course], axis=1)
        else:
            world = np.stack([np.full(len(labels), np.nan), np.full(len(labels), np.nan), speed,
                              course], axis=1)
        return Tracks(t, detections.frame_index, labels, np.zeros((len(labels), 4)),
                      states=np.full(len(labels), int(TrackState.CONFIRMED), np.int8),
                      ages_s=ages, source=self.name, camera_id="fused", world=world)
