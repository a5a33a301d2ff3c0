"""A simulated VTS radar: noisy plots once per antenna sweep, and the tracks a VTS tracker reports.

Plots are detections in polar coordinates around the radar (range and bearing noise, detection
probability, sea-clutter false alarms spread uniformly in the covered sector); each carries the
time the beam crossed it.  Tracks are per-vessel alpha-beta filters fed with that vessel's plots
(ideal association, as a VTS system's own tracker would give) with the filter's lag and noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d

from seawatch.sim.world import World

__all__ = ["RadarConfig", "RADAR_DTYPE", "simulate_radar"]

RADAR_DTYPE = np.dtype([
    ("t_s", np.float64), ("id", np.int64), ("lat", np.float64), ("lon", np.float64), ("range_m", np.float64),
    ("bearing_deg", np.float64), ("speed_mps", np.float64), ("course_deg", np.float64), ("truth_id", np.int64),
])


@dataclass(frozen=True)
class RadarConfig:
    """Parameters of the simulated radar.

    Parameters
    ----------
    position_enu_m : (float, float)
        Radar position in world ENU.
    scan_period_s : float
        Antenna rotation period.
    range_sigma_m, bearing_sigma_deg : float
        Measurement noise.
    pd : float
        Detection probability of a vessel per sweep (small boats: scaled down by length).
    max_range_m, min_range_m : float
        Coverage.
    clutter_per_scan : float
        Mean number of false plots per sweep.
    sector_deg : (float, float) or None
        Covered bearings (clockwise from the first to the second); None for all round.
    alpha, beta : float
        Gains of the tracks' alpha-beta filters.
    """

    position_enu_m: tuple[float, float] = (0.0, 0.0)
    scan_period_s: float = 2.5
    range_sigma_m: float = 12.0
    bearing_sigma_deg: float = 0.35
    pd: float = 0.95
    max_range_m: float = 12000.0
    min_range_m: float = 50.0
    clutter_per_scan: float = 2.0
    sector_deg: tuple[float, float] | None = None
    alpha: float = 0.5
    beta: float = 0.2


def _in_sector(brg, sector):
    if sector is None:
        return np.ones_like(np.asarray(brg), bool)
    a, b = sector
    return ((np.asarray(brg) - a) % 360.0) <= ((b - a) % 360.0)


def simulate_radar(world: World, origin_lat_deg: float, origin_lon_deg: float, duration_s: float,
                   config: RadarConfig = RadarConfig(), seed: int = 0, t0_s: float = 0.0):
    """Radar plots and tracks of ``world`` over ``[t0_s, t0_s + duration_s)``.

    Returns
    -------
    plots, tracks : structured arrays of :data:`RADAR_DTYPE`, time-sorted.  Plots have ``id`` -1 and
        NaN speed/course; ``truth_id`` is the vessel id (-1 for clutter).  Tracks have ``id``
        1000 + vessel id.
    """
    rng = np.random.default_rng([seed, 77])
    re, rn = config.position_enu_m
    plots = []
    n_scans = int(math.ceil(duration_s / config.scan_period_s))
    trk_state: dict[int, list] = {}
    tracks = []
    for s in range(n_scans + 1):
        t_scan = t0_s + s * config.scan_period_s
        for v in world.vessels:
            # the beam sweeps clockwise from north: the target is hit when the beam reaches its bearing
            e, n, _, _ = v.state(t_scan)
            brg = math.degrees(math.atan2(float(e) - re, float(n) - rn)) % 360.0
            t_hit = t_scan + brg / 360.0 * config.scan_period_s
            if t_hit >= t0_s + duration_s:
                continue
            e, n, course, speed = (float(x) for x in v.state(t_hit))
            de, dn = e - re, n - rn
            rng_m = math.hypot(de, dn)
            brg = math.degrees(math.atan2(de, dn)) % 360.0
            if not (config.min_range_m <= rng_m <= config.max_range_m) or not _in_sector(brg, config.sector_deg):
                continue
            pd = config.pd * min(1.0, 0.6 + v.length_m / 25.0)
            if rng.random() > pd:
                continue
            mr = rng_m + rng.normal(0, config.range_sigma_m)
            mb = (brg + rng.normal(0, config.bearing_sigma_deg)) % 360.0
            pe = re + mr * math.sin(math.radians(mb))
            pn = rn + mr * math.cos(math.radians(mb))
            plots.append((t_hit, -1, pe, pn, mr, mb, np.nan, np.nan, v.id))
            # alpha-beta track of this vessel
            st = trk_state.get(v.id)
            z = np.array([pe, pn])
            if st is None:
                trk_state[v.id] = [t_hit, z.copy(), np.zeros(2), 1]
                continue
            t_prev, x, vel, nhits = st
            dt = t_hit - t_prev
            xp = x + vel * dt
            r_ = z - xp
            x = xp + config.alpha * r_
            vel = vel + (config.beta / max(dt, 1e-6)) * r_
            trk_state[v.id] = [t_hit, x, vel, nhits + 1]
            if nhits + 1 >= 3:
                sp = float(np.hypot(*vel))
                crs = math.degrees(math.atan2(vel[0], vel[1])) % 360.0
                tr = math.hypot(x[0] - re, x[1] - rn)
                tb = math.degrees(math.atan2(x[0] - re, x[1] - rn)) % 360.0
                tracks.append((t_hit, 1000 + v.id, x[0], x[1], tr, tb, sp, crs, v.id))
        # clutter
        k = rng.poisson(config.clutter_per_scan)
        for _ in range(k):
            if config.sector_deg is None:
                b = rng.uniform(0, 360)
            else:
                a0, a1 = config.sector_deg
                b = (a0 + rng.uniform(0, (a1 - a0) % 360.0)) % 360.0
            r = rng.uniform(config.min_range_m, min(config.max_range_m, 6000.0))
            t_hit = t_scan + b / 360.0 * config.scan_period_s
            if t_hit >= t0_s + duration_s:
                continue
            plots.append((t_hit, -1, re + r * math.sin(math.radians(b)), rn + r * math.cos(math.radians(b)), r, b,
                          np.nan, np.nan, -1))

    def pack(rows):
        if not rows:
            return np.zeros(0, RADAR_DTYPE)
        a = np.array(rows, dtype=float)
        lat, lon, _ = pymap3d.enu2geodetic(a[:, 2], a[:, 3], np.zeros(len(a)), origin_lat_deg, origin_lon_deg, 0.0)
        out = np.zeros(len(a), RADAR_DTYPE)
        out["t_s"], out["id"], out["lat"], out["lon"] = a[:, 0], a[:, 1].astype(np.int64), lat, lon
        out["range_m"], out["bearing_deg"], out["speed_mps"], out["course_deg"] = a[:, 4], a[:, 5], a[:, 6], a[:, 7]
        out["truth_id"] = a[:, 8].astype(np.int64)
        return out[np.argsort(out["t_s"], kind="stable")]

    return pack(plots), pack(tracks)
