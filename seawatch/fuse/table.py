"""Target tables: one row per AIS vessel (keyed by MMSI) or radar/VTS track, state in arrays.

A :class:`TargetTable` keeps, for every key, its latest position report in a local east-north-up
frame (metres, around a reference point such as the camera) and a short history, so that any
target can be dead-reckoned (constant SOG/COG) to any time with a few array operations.  Static
data (name, type, length) is merged per key from any report that carries it.
"""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np
import pymap3d

from seawatch.types import AISReport

__all__ = ["KN_TO_MPS", "TargetTable", "TargetStates", "dead_reckon_enu", "dead_reckon_geodetic",
           "geodetic_to_enu", "enu_to_geodetic"]

KN_TO_MPS = 1852.0 / 3600.0

# WGS-84
_A = 6378137.0
_F = 1.0 / 298.257223563
_E2 = _F * (2.0 - _F)
_B = _A * (1.0 - _F)
_EP2 = (_A * _A - _B * _B) / (_B * _B)


def _geodetic_to_ecef(lat, lon, h):
    la, lo = np.radians(lat), np.radians(lon)
    sl, cl = np.sin(la), np.cos(la)
    N = _A / np.sqrt(1.0 - _E2 * sl * sl)
    return (N + h) * cl * np.cos(lo), (N + h) * cl * np.sin(lo), (N * (1.0 - _E2) + h) * sl


def geodetic_to_enu(lat_deg, lon_deg, lat0_deg: float, lon0_deg: float, h_m=0.0):
    """WGS-84 geodetic -> local ENU (m) at ``(lat0, lon0, 0)``; same as pymap3d, several times faster."""
    x, y, z = _geodetic_to_ecef(np.asarray(lat_deg, float), np.asarray(lon_deg, float), h_m)
    x0, y0, z0 = _geodetic_to_ecef(lat0_deg, lon0_deg, 0.0)
    dx, dy, dz = x - x0, y - y0, z - z0
    la, lo = math.radians(lat0_deg), math.radians(lon0_deg)
    sl, cl, so, co = math.sin(la), math.cos(la), math.sin(lo), math.cos(lo)
    e = -so * dx + co * dy
    n = -sl * co * dx - sl * so * dy + cl * dz
    u = cl * co * dx + cl * so * dy + sl * dz
    return e, n, u


def enu_to_geodetic(e_m, n_m, lat0_deg: float, lon0_deg: float, u_m=0.0):
    """Local ENU (m) at ``(lat0, lon0, 0)`` -> WGS-84 (lat, lon) in degrees (Bowring, sub-mm near the surface)."""
    e, n, u = np.asarray(e_m, float), np.asarray(n_m, float), np.asarray(u_m, float)
    la, lo = math.radians(lat0_deg), math.radians(lon0_deg)
    sl, cl, so, co = math.sin(la), math.cos(la), math.sin(lo), math.cos(lo)
    x0, y0, z0 = _geodetic_to_ecef(lat0_deg, lon0_deg, 0.0)
    x = x0 - so * e - sl * co * n + cl * co * u
    y = y0 + co * e - sl * so * n + cl * so * u
    z = z0 + cl * n + sl * u
    p = np.hypot(x, y)
    th = np.arctan2(z * _A, p * _B)
    st, ct = np.sin(th), np.cos(th)
    lat = np.arctan2(z + _EP2 * _B * st ** 3, p - _E2 * _A * ct ** 3)
    return np.degrees(lat), np.degrees(np.arctan2(y, x))


def dead_reckon_enu(e_m, n_m, speed_mps, course_deg, dt_s):
    """Constant-velocity dead reckoning in a local ENU frame.

    Parameters
    ----------
    e_m, n_m : array_like, positions (m).
    speed_mps : array_like, speed over ground (NaN is taken as 0: the target is assumed still).
    course_deg : array_like, course over ground, clockwise from north (NaN: still).
    dt_s : array_like, time to move forward (negative moves back).

    Returns
    -------
    e_m, n_m : arrays, the dead-reckoned positions.
    """
    sp = np.nan_to_num(np.asarray(speed_mps, float))
    c = np.radians(np.asarray(course_deg, float))
    ok = np.isfinite(c)
    sp = np.where(ok, sp, 0.0)
    c = np.where(ok, c, 0.0)
    d = sp * np.asarray(dt_s, float)
    return np.asarray(e_m, float) + d * np.sin(c), np.asarray(n_m, float) + d * np.cos(c)


def dead_reckon_geodetic(lat_deg, lon_deg, speed_mps, course_deg, dt_s):
    """Dead reckoning of geodetic positions (on a local tangent plane at each start point)."""
    de, dn = dead_reckon_enu(0.0, 0.0, speed_mps, course_deg, dt_s)
    lat, lon, _ = pymap3d.enu2geodetic(de, dn, 0.0, np.asarray(lat_deg, float), np.asarray(lon_deg, float), 0.0)
    return lat, lon


class TargetStates:
    """Targets of a table dead-reckoned to one time (a read-only view of arrays).

    Attributes
    ----------
    keys : (M,) int64, MMSI or track id.
    slots : (M,) int64, rows of the table.
    e_m, n_m : (M,) positions in the table's ENU frame.
    ve_mps, vn_mps : (M,) velocity.
    age_s : (M,) time since the report used.
    length_m : (M,) vessel length (NaN unknown).
    """

    __slots__ = ("t_s", "keys", "slots", "e_m", "n_m", "ve_mps", "vn_mps", "age_s", "length_m")

    def __init__(self, t_s, keys, slots, e_m, n_m, ve_mps, vn_mps, age_s, length_m):
        self.t_s = t_s
        self.keys = keys
        self.slots = slots
        self.e_m = e_m
        self.n_m = n_m
        self.ve_mps = ve_mps
        self.vn_mps = vn_mps
        self.age_s = age_s
        self.length_m = length_m

    def __len__(self) -> int:
        return len(self.keys)

    @property
    def speed_mps(self) -> np.ndarray:
        return np.hypot(self.ve_mps, self.vn_mps)

    @property
    def course_deg(self) -> np.ndarray:
        return np.degrees(np.arctan2(self.ve_mps, self.vn_mps)) % 360.0

    def subset(self, mask) -> "TargetStates":
        return TargetStates(self.t_s, *(getattr(self, a)[mask] for a in self.__slots__[1:]))


class TargetTable:
    """Latest state and recent history of many targets, in arrays.

    Parameters
    ----------
    ref_lat_deg, ref_lon_deg : float, optional
        Origin of the local ENU frame (e.g. the camera's foot).  When None, the first report's
        position is taken.
    history : int
        Reports kept per target (for positions at past times within the association window).
    max_age_s : float
        Targets whose latest report is older than this are left out of :meth:`states_at`.
    latency_s : float
        Reports are taken to describe the position ``latency_s`` before their time stamp
        (receive-time stamps of a delayed feed).
    min_dt_for_velocity_s : float
        When a report has no SOG/COG, the velocity comes from the two latest reports if they are
        at least this far apart.

    Notes
    -----
    Reports older than a target's latest one go into its history (sorted) without changing the
    latest state.  Rows are never deleted; stale rows are masked by ``max_age_s``.
    """

    def __init__(
        self,
        ref_lat_deg: float | None = None,
        ref_lon_deg: float | None = None,
        history: int = 16,
        max_age_s: float = 600.0,
        latency_s: float = 0.0,
        min_dt_for_velocity_s: float = 1.0,
    ):
        self.ref = None if ref_lat_deg is None else (float(ref_lat_deg), float(ref_lon_deg))
        self.H = int(history)
        self.max_age_s = float(max_age_s)
        self.latency_s = float(latency_s)
        self.min_dt_for_velocity_s = float(min_dt_for_velocity_s)
        self._slot: dict[int, int] = {}
        cap = 64
        self.n = 0
        self.keys = np.zeros(cap, np.int64)
        self.t = np.full(cap, -np.inf)  # time of the latest position (latency removed)
        self.e = np.zeros(cap)
        self.nn = np.zeros(cap)
        self.ve = np.zeros(cap)
        self.vn = np.zeros(cap)
        self.lat = np.full(cap, np.nan)
        self.lon = np.full(cap, np.nan)
        self.heading = np.full(cap, np.nan)
        self.length_m = np.full(cap, np.nan)
        self.beam_m = np.full(cap, np.nan)
        self.ship_type = np.zeros(cap, np.int64)
        self.names = np.full(cap, None, dtype=object)
        self.callsigns = np.full(cap, None, dtype=object)
        self.n_reports = np.zeros(cap, np.int64)
        # history ring buffers (t, e, n), newest last in time order per row
        self.ht = np.full((cap, self.H), np.nan)
        self.he = np.full((cap, self.H), np.nan)
        self.hn = np.full((cap, self.H), np.nan)

    # ------------------------------------------------------------------ storage
    def __len__(self) -> int:
        return self.n

    def _grow(self, need: int) -> None:
        cap = len(self.keys)
        if need <= cap:
            return
        new = max(need, 2 * cap)
        for name in ("keys", "t", "e", "nn", "ve", "vn", "lat", "lon", "heading", "length_m", "beam_m",
                     "ship_type", "names", "callsigns", "n_reports"):
            a = getattr(self, name)
            fill = {"t": -np.inf, "keys": 0, "ship_type": 0, "n_reports": 0, "e": 0, "nn": 0, "ve": 0, "vn": 0,
                    "names": None, "callsigns": None}.get(name, np.nan)
            b = np.full(new, fill, dtype=a.dtype)
            b[:cap] = a
            setattr(self, name, b)
        for name in ("ht", "he", "hn"):
            a = getattr(self, name)
            b = np.full((new, self.H), np.nan)
            b[:cap] = a
            setattr(self, name, b)

    def slots_for(self, keys) -> np.ndarray:
        """Rows of the given keys, creating rows for new keys."""
        keys = np.asarray(keys, np.int64).reshape(-1)
        out = np.empty(len(keys), np.int64)
        for i, k in enumerate(keys.tolist()):
            s = self._slot.get(k)
            if s is None:
                s = self.n
                self._grow(s + 1)
                self._slot[k] = s
                self.keys[s] = k
                self.n += 1
            out[i] = s
        return out

    def slot(self, key: int) -> int | None:
        """Row of a key, or None."""
        return self._slot.get(int(key))

    def to_enu(self, lat_deg, lon_deg) -> tuple[np.ndarray, np.ndarray]:
        """Geodetic -> this table's ENU frame (sea level)."""
        if self.ref is None:
            raise ValueError("TargetTable: no reference point yet")
        e, n, _ = geodetic_to_enu(lat_deg, lon_deg, self.ref[0], self.ref[1])
        return np.asarray(e, float), np.asarray(n, float)

    def to_geodetic(self, e_m, n_m) -> tuple[np.ndarray, np.ndarray]:
        """This table's ENU frame -> geodetic (lat, lon)."""
        if self.ref is None:
            raise ValueError("TargetTable: no reference point yet")
        lat, lon = enu_to_geodetic(e_m, n_m, self.ref[0], self.ref[1])
        return np.asarray(lat, float), np.asarray(lon, float)

    # ------------------------------------------------------------------- updates
    def update(
        self,
        keys,
        t_s,
        lat_deg,
        lon_deg,
        speed_mps=None,
        course_deg=None,
        heading_deg=None,
    ) -> int:
        """Add position reports given as arrays (one element per report, any order).

        NaN speed or course: the velocity is estimated from the previous report when possible.
        Returns the number of reports taken.
        """
        keys = np.asarray(keys, np.int64).reshape(-1)
        m = len(keys)
        if m == 0:
            return 0
        t = np.asarray(t_s, float).reshape(-1) - self.latency_s
        lat = np.asarray(lat_deg, float).reshape(-1)
        lon = np.asarray(lon_deg, float).reshape(-1)
        sp = np.full(m, np.nan) if speed_mps is None else np.asarray(speed_mps, float).reshape(-1)
        co = np.full(m, np.nan) if course_deg is None else np.asarray(course_deg, float).reshape(-1)
        hd = np.full(m, np.nan) if heading_deg is None else np.asarray(heading_deg, float).reshape(-1)
        ok = np.isfinite(t) & np.isfinite(lat) & np.isfinite(lon)
        if not ok.all():
            keys, t, lat, lon, sp, co, hd = (a[ok] for a in (keys, t, lat, lon, sp, co, hd))
            m = len(keys)
            if m == 0:
                return 0
        if self.ref is None:
            self.ref = (float(lat[0]), float(lon[0]))
        order = np.argsort(t, kind="stable")
        keys, t, lat, lon, sp, co, hd = (a[order] for a in (keys, t, lat, lon, sp, co, hd))
        e, n = self.to_enu(lat, lon)
        slots = self.slots_for(keys)
        c = np.radians(co)
        ve = sp * np.sin(c)
        vn = sp * np.cos(c)
        # several reports of one target in one batch: apply them in time order, one pass per repeat
        uniq, first = np.unique(slots, return_index=True)
        if len(uniq) == m:
            self._apply(slots, t, e, n, ve, vn, lat, lon, hd)
        else:
            remaining = np.ones(m, bool)
            while remaining.any():
                idx = np.flatnonzero(remaining)
                _, f = np.unique(slots[idx], return_index=True)
                pick = idx[f]
                self._apply(slots[pick], t[pick], e[pick], n[pick], ve[pick], vn[pick], lat[pick], lon[pick], hd[pick])
                remaining[pick] = False
        return m

    def _apply(self, s, t, e, n, ve, vn, lat, lon, hd) -> None:
        # history: drop the oldest column, append, keep rows sorted by time
        self.ht[s, :-1] = self.ht[s, 1:]
        self.he[s, :-1] = self.he[s, 1:]
        self.hn[s, :-1] = self.hn[s, 1:]
        self.ht[s, -1] = t
        self.he[s, -1] = e
        self.hn[s, -1] = n
        late = t < self.t[s]
        if late.any():  # out-of-order reports: re-sort those rows' history
            r = s[late]
            o = np.argsort(np.nan_to_num(self.ht[r], nan=-np.inf), axis=1)
            self.ht[r] = np.take_along_axis(self.ht[r], o, 1)
            self.he[r] = np.take_along_axis(self.he[r], o, 1)
            self.hn[r] = np.take_along_axis(self.hn[r], o, 1)
        self.n_reports[s] += 1
        new = ~late
        if not new.any():
            return
        s, t, e, n, ve, vn, lat, lon, hd = (a[new] for a in (s, t, e, n, ve, vn, lat, lon, hd))
        # missing SOG/COG: velocity from the previous report
        miss = ~(np.isfinite(ve) & np.isfinite(vn))
        if miss.any():
            dt = t - self.t[s]
            can = miss & np.isfinite(dt) & (dt >= self.min_dt_for_velocity_s) & (dt < self.max_age_s)
            with np.errstate(invalid="ignore", divide="ignore"):
                ve = np.where(can, (e - self.e[s]) / dt, np.where(miss, self.ve[s], ve))
                vn = np.where(can, (n - self.nn[s]) / dt, np.where(miss, self.vn[s], vn))
            ve = np.nan_to_num(ve)
            vn = np.nan_to_num(vn)
        self.t[s] = t
        self.e[s] = e
        self.nn[s] = n
        self.ve[s] = ve
        self.vn[s] = vn
        self.lat[s] = lat
        self.lon[s] = lon
        self.heading[s] = hd

    def update_static(self, key: int, name=None, callsign=None, ship_type=None, length_m=None, beam_m=None) -> None:
        """Merge static data of one target (values that are None are left as they were)."""
        s = int(self.slots_for([key])[0])
        if name:
            self.names[s] = name
        if callsign:
            self.callsigns[s] = callsign
        if ship_type:
            self.ship_type[s] = int(ship_type)
        if length_m:
            self.length_m[s] = float(length_m)
        if beam_m:
            self.beam_m[s] = float(beam_m)

    def add_reports(self, reports: Iterable[AISReport]) -> int:
        """Add :class:`AISReport` objects (position and static data).  Returns the number taken."""
        reps = list(reports)
        pos = [r for r in reps if r.has_position]
        for r in reps:
            if r.name or r.callsign or r.ship_type or r.length_m or r.beam_m:
                self.update_static(r.mmsi, r.name, r.callsign, r.ship_type, r.length_m, r.beam_m)
        if pos:
            self.update(
                [r.mmsi for r in pos], [r.t_s for r in pos], [r.lat_deg for r in pos], [r.lon_deg for r in pos],
                [r.sog_kn * KN_TO_MPS for r in pos], [r.cog_deg for r in pos], [r.heading_deg for r in pos],
            )
        return len(reps)

    def add_array(self, arr: np.ndarray) -> int:
        """Add position reports from a structured array of :data:`seawatch.io.ais.AIS_DTYPE`."""
        if len(arr) == 0:
            return 0
        return self.update(arr["mmsi"], arr["t_s"], arr["lat_deg"], arr["lon_deg"], arr["sog_kn"] * KN_TO_MPS,
                           arr["cog_deg"], arr["heading_deg"])

    # ------------------------------------------------------------------- queries
    def states_at(self, t_s: float, max_age_s: float | None = None) -> TargetStates:
        """All targets with a report no older than ``max_age_s``, dead-reckoned to ``t_s``.

        Targets reported only after ``t_s`` are left out (no look into the future).
        """
        max_age = self.max_age_s if max_age_s is None else float(max_age_s)
        n = self.n
        age = t_s - self.t[:n]
        keep = (age >= -1e-9) & (age <= max_age)
        s = np.flatnonzero(keep)
        age = age[s]
        e = self.e[s] + self.ve[s] * age
        nn = self.nn[s] + self.vn[s] * age
        return TargetStates(float(t_s), self.keys[s], s, e, nn, self.ve[s].copy(), self.vn[s].copy(), age,
                            self.length_m[s])

    def state_of(self, key: int, t_s: float) -> tuple[float, float] | None:
        """Dead-reckoned (lat, lon) of one target at ``t_s`` from its latest report, or None."""
        s = self.slot(key)
        if s is None or not np.isfinite(self.t[s]):
            return None
        dt = t_s - self.t[s]
        lat, lon = self.to_geodetic(self.e[s] + self.ve[s] * dt, self.nn[s] + self.vn[s] * dt)
        return float(lat), float(lon)

    def positions_at(self, t_s: float, slots=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions at ``t_s`` interpolated in the history where it brackets ``t_s``, else
        dead-reckoned from the latest report at or before ``t_s``.

        Returns ``e_m, n_m, valid`` for the given rows (default: all).
        """
        s = np.arange(self.n) if slots is None else np.asarray(slots, np.int64)
        ht, he, hn = self.ht[s], self.he[s], self.hn[s]
        # rows are time-sorted with their unused (NaN) columns first
        with np.errstate(invalid="ignore"):
            cnt = (ht <= t_s).sum(axis=1)
        nan_lead = np.isnan(ht).sum(axis=1)
        has_before = cnt > 0
        idx_before = np.clip(nan_lead + cnt - 1, 0, self.H - 1)
        idx_after = np.clip(idx_before + 1, 0, self.H - 1)
        has_after = has_before & (idx_before + 1 < self.H)
        r = np.arange(len(s))
        t0, e0, n0 = ht[r, idx_before], he[r, idx_before], hn[r, idx_before]
        t1, e1, n1 = ht[r, idx_after], he[r, idx_after], hn[r, idx_after]
        has_after &= np.isfinite(t1) & (t1 > t0)
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(has_after, (t_s - t0) / (t1 - t0), 0.0)
        e = e0 + w * (e1 - e0)
        n = n0 + w * (n1 - n0)
        # no later report: dead reckon from the latest (which is the row's latest state)
        latest = has_before & ~has_after
        dt = t_s - t0
        e = np.where(latest, e0 + self.ve[s] * dt, e)
        n = np.where(latest, n0 + self.vn[s] * dt, n)
        valid = has_before & (t_s - t0 <= self.max_age_s)
        return e, n, valid

    def static_of(self, key: int) -> dict:
        """Static data of a key: name, callsign, ship_type, length_m, beam_m (None when unknown)."""
        s = self.slot(key)
        if s is None:
            return {"name": None, "callsign": None, "ship_type": None, "length_m": None, "beam_m": None}
        f = lambda v: None if not np.isfinite(v) else float(v)  # noqa: E731
        return {
            "name": self.names[s],
            "callsign": self.callsigns[s],
            "ship_type": int(self.ship_type[s]) or None,
            "length_m": f(self.length_m[s]),
            "beam_m": f(self.beam_m[s]),
        }

    def speed_course(self, slots) -> tuple[np.ndarray, np.ndarray]:
        s = np.asarray(slots, np.int64)
        return np.hypot(self.ve[s], self.vn[s]), np.degrees(np.arctan2(self.ve[s], self.vn[s])) % 360.0

