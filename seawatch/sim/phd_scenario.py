"""The three-camera angle-space scenario of paper C (GM-PHD fusion of several cameras).

Three fixed cameras watch a large sea area: camera 1 at the origin, cameras 2 and 3 placed
symmetrically ``baseline_m`` east and west of it; boresights (azimuth, elevation) (0, -5),
(20, -5) and (-20, -5) degrees; field of view 120 x 30 degrees.  Vessels sail at 10-15 knots
with slow turns (2 degrees/s) on the sea surface (``u = 0``).  Each camera reports every
``report_period_s`` (3 s), the cameras ``camera_offset_s`` (1 s) apart, so the fusion centre
gets one report a second.  A report holds, for every vessel inside that camera's field of view,
a detection with probability ``pd`` and Gaussian angular noise, plus Poisson(``clutter_per_scan``)
false alarms uniform over the image (the "waves").

Everything is in one local east-north-up frame (metres, flat sea; the camera model's curvature
is ignored at these ranges).  Angles are degrees, azimuth clockwise from north.  The scenario is
a plain data product: it knows nothing of the tracker that will consume it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["PHDCamera", "PHDScenarioReport", "PHDScenario", "make_phd_scenario", "paper_cameras"]

KNOT_MPS = 1852.0 / 3600.0


@dataclass(frozen=True)
class PHDCamera:
    """A camera of the scenario (the fields a fusion centre needs; see ``PHDSensor``)."""

    sensor_id: str
    position_m: tuple[float, float, float]
    boresight_az_deg: float
    boresight_el_deg: float
    hfov_deg: float = 120.0
    vfov_deg: float = 30.0
    sigma_az_deg: float = 0.1
    sigma_el_deg: float = 0.1
    pd: float = 0.9
    clutter_per_scan: float = 20.0

    def in_fov(self, az_deg, el_deg) -> np.ndarray:
        daz = (np.asarray(az_deg) - self.boresight_az_deg + 180.0) % 360.0 - 180.0
        return (np.abs(daz) <= 0.5 * self.hfov_deg) & (
            np.abs(np.asarray(el_deg) - self.boresight_el_deg) <= 0.5 * self.vfov_deg)


@dataclass
class PHDScenarioReport:
    """One camera report: detections ``azel_deg (M, 2)`` and, for scoring only, the true vessel
    id of each detection (``-1`` for a false alarm)."""

    t_s: float
    sensor_id: str
    azel_deg: np.ndarray
    source_id: np.ndarray


@dataclass
class PHDScenario:
    """Cameras, time-ordered reports, and the truth at every report time."""

    cameras: list[PHDCamera]
    reports: list[PHDScenarioReport]
    truth_ids: list[np.ndarray]  # per report: ids of vessels inside at least one field of view
    truth_pos: list[np.ndarray]  # per report: (N, 3) ENU positions, same order
    truth_vel: list[np.ndarray]  # per report: (N, 3) ENU velocities
    tracks_t: np.ndarray = field(repr=False, default=None)  # (T,) simulation times
    tracks_pos: np.ndarray = field(repr=False, default=None)  # (V, T, 3), NaN when not alive
    seed: int = 0

    @property
    def times(self) -> np.ndarray:
        return np.array([r.t_s for r in self.reports])

    def truth_dict(self) -> dict:
        """``{t_s: (ids, positions)}`` for :func:`seawatch.eval.ospa` / ``gospa``."""
        return {r.t_s: (i, p) for r, i, p in zip(self.reports, self.truth_ids, self.truth_pos)}

    def n_false_alarms(self) -> int:
        return int(sum((r.source_id < 0).sum() for r in self.reports))


def paper_cameras(
    *,
    baseline_m: float = 1000.0,
    height_m: float = 20.0,
    sigma_deg: float = 0.1,
    pd: float = 0.9,
    clutter_per_scan: float = 20.0,
) -> list[PHDCamera]:
    """The three cameras: origin (0, -5), east (20, -5), west (-20, -5); FOV 120 x 30 degrees."""
    spec = [("cam1", 0.0, 0.0), ("cam2", baseline_m, 20.0), ("cam3", -baseline_m, -20.0)]
    return [
        PHDCamera(sid, (x, 0.0, height_m), az, -5.0, 120.0, 30.0, sigma_deg, sigma_deg, pd,
                  clutter_per_scan)
        for sid, x, az in spec
    ]


def _vessel_paths(rng, n, t, region, speed_kn, turn_rate_deg_s, duration_s, dt):
    """(V, T, 3) positions and velocities of vessels with straight legs and slow turns."""
    T = len(t)
    pos = np.full((n, T, 3), np.nan)
    vel = np.full((n, T, 3), np.nan)
    x0, x1, y0, y1 = region
    for v in range(n):
        # a third of the vessels are there from the start; the others arrive and some leave
        if v < max(1, n // 3):
            t_on = 0.0
        else:
            t_on = rng.uniform(0.0, 0.5 * duration_s)
        t_off = duration_s if rng.random() < 0.6 else rng.uniform(t_on + 0.4 * duration_s, duration_s)
        p = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1), 0.0])
        # head roughly across the area, towards its centre
        centre = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)])
        to_c = math.degrees(math.atan2(centre[0] - p[0], centre[1] - p[1]))
        hdg = to_c + rng.uniform(-60.0, 60.0)
        spd = rng.uniform(*speed_kn) * KNOT_MPS
        # legs: straight, then a turn of +-turn_rate for a while
        leg_end = 0.0
        rate = 0.0
        for k, tk in enumerate(t):
            if tk >= leg_end:
                if rate == 0.0 and rng.random() < 0.6:
                    rate = turn_rate_deg_s * (1 if rng.random() < 0.5 else -1)
                    leg_end = tk + rng.uniform(10.0, 30.0)
                else:
                    rate = 0.0
                    leg_end = tk + rng.uniform(20.0, 60.0)
            if k > 0:
                hdg += rate * dt
                h = math.radians(hdg)
                p = p + dt * spd * np.array([math.sin(h), math.cos(h), 0.0])
            if t_on <= tk <= t_off:
                h = math.radians(hdg)
                pos[v, k] = p
                vel[v, k] = spd * np.array([math.sin(h), math.cos(h), 0.0])
    return pos, vel


def make_phd_scenario(
    n_targets: int = 10,
    *,
    duration_s: float = 300.0,
    seed: int = 0,
    baseline_m: float = 1000.0,
    height_m: float = 20.0,
    sigma_deg: float = 0.1,
    pd: float = 0.9,
    clutter_per_scan: float = 20.0,
    report_period_s: float = 3.0,
    camera_offset_s: float = 1.0,
    speed_kn: tuple[float, float] = (10.0, 15.0),
    turn_rate_deg_s: float = 2.0,
    region_m: tuple[float, float, float, float] = (-3000.0, 3000.0, 1500.0, 5000.0),
    dt_s: float = 0.5,
) -> PHDScenario:
    """Generate the paper's three-camera scenario (all randomness from ``seed``).

    Parameters
    ----------
    n_targets : int
        Number of vessels over the run (a third present from the start, the rest arriving).
    duration_s : float
        Length of the run.
    baseline_m, height_m : float
        Cameras 2 and 3 sit ``baseline_m`` east and west of camera 1; all at ``height_m``.
    sigma_deg, pd, clutter_per_scan : float
        Angular noise (azimuth and elevation), detection probability inside the field of view,
        and mean number of false alarms per image.
    report_period_s, camera_offset_s : float
        Each camera reports every ``report_period_s``; camera ``k`` at ``k * camera_offset_s``.
    speed_kn, turn_rate_deg_s : (float, float), float
        Vessel speed range and turn rate of the turning legs.
    region_m : (e_min, e_max, n_min, n_max)
        Where vessels start.
    dt_s : float
        Simulation step of the vessel motion.
    """
    rng = np.random.default_rng(seed)
    cams = paper_cameras(baseline_m=baseline_m, height_m=height_m, sigma_deg=sigma_deg, pd=pd,
                         clutter_per_scan=clutter_per_scan)
    t = np.arange(0.0, duration_s + 0.5 * dt_s, dt_s)
    pos, vel = _vessel_paths(rng, n_targets, t, region_m, speed_kn, turn_rate_deg_s, duration_s, dt_s)
    # report times: camera k at k * offset + n * period
    rep = []
    for k, cam in enumerate(cams):
        tk = np.arange(k * camera_offset_s, duration_s + 1e-9, report_period_s)
        rep += [(float(x), k) for x in tk]
    rep.sort()
    reports, tids, tpos, tvel = [], [], [], []
    ids_all = np.arange(n_targets)
    for tr, k in rep:
        cam = cams[k]
        i = int(round(tr / dt_s))
        p = pos[:, i]
        alive = np.isfinite(p[:, 0])
        ids = ids_all[alive]
        P = p[alive]
        vis_any = np.zeros(len(ids), bool)
        for c in cams:
            d = P - np.asarray(c.position_m)
            az = np.degrees(np.arctan2(d[:, 0], d[:, 1]))
            el = np.degrees(np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])))
            inside = c.in_fov(az, el)
            vis_any |= inside
            if c is cam:
                in_this, az_t, el_t = inside, az, el
        det = in_this & (rng.random(len(ids)) < cam.pd)
        z_t = np.stack([az_t[det] + rng.normal(0, cam.sigma_az_deg, det.sum()),
                        el_t[det] + rng.normal(0, cam.sigma_el_deg, det.sum())], axis=1)
        n_fa = rng.poisson(cam.clutter_per_scan)
        z_c = np.stack([cam.boresight_az_deg + rng.uniform(-0.5, 0.5, n_fa) * cam.hfov_deg,
                        cam.boresight_el_deg + rng.uniform(-0.5, 0.5, n_fa) * cam.vfov_deg], axis=1)
        z = np.concatenate([z_t, z_c])
        src = np.concatenate([ids[det], np.full(n_fa, -1)])
        order = rng.permutation(len(z))
        reports.append(PHDScenarioReport(tr, cam.sensor_id, z[order], src[order].astype(np.int64)))
        tids.append(ids[vis_any].astype(np.int64))
        tpos.append(P[vis_any])
        tvel.append(vel[alive, i][vis_any])
    return PHDScenario(cams, reports, tids, tpos, tvel, t, pos, seed)
