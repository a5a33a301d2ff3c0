"""Geometric camera <-> AIS/VTS association over a time window.

Each camera track is described by angles measured in the image (through the camera model):
the azimuth of its box's bottom centre and the box's angular half-width, the elevation of its
waterline, and its azimuth and elevation rates.  Each AIS/VTS target, dead-reckoned to the frame
time, is described by the same angles computed from its ENU position and velocity.  Their
normalised squared distance ``d2`` per pair (:func:`pair_distance2`) gives a per-frame
log-likelihood ratio that :class:`WindowAssociator` averages over a sliding time window
(exponential forgetting) before a one-to-one assignment with gating and hysteresis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.fuse.table import TargetStates

__all__ = ["AngleHistory", "index_of", "TrackAngles", "TargetAngles", "track_angles", "waterline_px", "target_angles",
           "pair_distance2", "angle_diff_deg", "WindowAssociator"]


def index_of(keys: np.ndarray, query) -> np.ndarray:
    """Position of each ``query`` value in ``keys`` (unique values), -1 where absent."""
    keys = np.asarray(keys, np.int64)
    q = np.asarray(query, np.int64)
    if len(keys) == 0:
        return np.full(q.shape, -1, np.int64)
    order = np.argsort(keys, kind="stable")
    sk = keys[order]
    pos = np.clip(np.searchsorted(sk, q), 0, len(sk) - 1)
    return np.where(sk[pos] == q, order[pos], -1)


def angle_diff_deg(a, b) -> np.ndarray:
    """Signed smallest difference ``a - b`` of angles in degrees, in [-180, 180)."""
    d = np.asarray(a, float) - np.asarray(b, float)
    return d - 360.0 * np.floor(d / 360.0 + 0.5)


@dataclass
class TrackAngles:
    """Angles of camera tracks (all (N,) arrays, degrees or deg/s)."""

    az_deg: np.ndarray
    el_deg: np.ndarray
    half_width_deg: np.ndarray
    az_rate_dps: np.ndarray
    el_rate_dps: np.ndarray
    range_m: np.ndarray  # from the waterline, NaN above the horizon
    e_m: np.ndarray
    n_m: np.ndarray
    half_height_deg: np.ndarray | None = None
    rate_valid: np.ndarray | None = None  # False where the track's velocity is not yet meaningful


@dataclass
class TargetAngles:
    """Angles of AIS/VTS targets seen from the camera (all (M,) arrays)."""

    az_deg: np.ndarray
    el_deg: np.ndarray
    range_m: np.ndarray
    az_rate_dps: np.ndarray
    el_rate_dps: np.ndarray
    del_dr: np.ndarray  # d(elevation)/d(range), deg per metre


def waterline_px(boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (camera-model convention) of each box's bottom centre, its waterline point.

    Boxes are in edge coordinates (pixel ``i`` spans ``[i, i + 1)``); the camera model works in
    pixel centres, so an edge coordinate ``x`` is the pixel coordinate ``x - 0.5`` (as
    ``seawatch.detect.blobs.boxes_azel`` does for detections).
    """
    b = np.asarray(boxes, float).reshape(-1, 4)
    return b[:, 0] + b[:, 2] / 2 - 0.5, b[:, 1] + b[:, 3] - 0.5


def track_angles(camera, boxes: np.ndarray, velocities_px_s: np.ndarray | None = None,
                 pan_offset_deg: float = 0.0, tilt_offset_deg: float = 0.0,
                 ages_s: np.ndarray | None = None, min_rate_age_s: float = 1.0) -> TrackAngles:
    """Angles of camera tracks from their boxes through a camera model.

    Parameters
    ----------
    camera : seawatch.camera.CameraModel (at the frame's pose / PTZ state).
    boxes : (N, 4) x, y, w, h pixels.
    velocities_px_s : (N, 2) box-centre velocity, px/s (zeros when None).
    pan_offset_deg, tilt_offset_deg : float
        Calibration offsets added to the measured azimuth and elevation (true minus nominal).
    ages_s : (N,) track ages; the rates of tracks younger than ``min_rate_age_s`` (or all, when
        there is no velocity) are marked not valid.
    """
    b = np.asarray(boxes, float).reshape(-1, 4)
    n = len(b)
    vel = np.zeros((n, 2)) if velocities_px_s is None else np.asarray(velocities_px_s, float).reshape(-1, 2)
    u, v = waterline_px(b)
    x0, y0 = b[:, 0] - 0.5, b[:, 1] - 0.5
    uu = np.concatenate([u, x0, x0 + b[:, 2], u + vel[:, 0], u])
    vv = np.concatenate([v, v, v, v + vel[:, 1], y0])
    az, el = camera.pixel_to_azel(uu, vv)
    az0, el0 = az[:n], el[:n]
    half = 0.5 * np.abs(angle_diff_deg(az[2 * n:3 * n], az[n:2 * n]))
    half_h = 0.5 * np.abs(el[4 * n:] - el0)
    az_rate = angle_diff_deg(az[3 * n:4 * n], az0)
    el_rate = el[3 * n:4 * n] - el0
    if velocities_px_s is None:
        valid = np.zeros(n, bool)
    elif ages_s is None:
        valid = np.ones(n, bool)
    else:
        a = np.asarray(ages_s, float).reshape(-1)
        moving = np.any(vel != 0, axis=1)
        # age 0 with a velocity: a tracker that does not report ages
        valid = (a >= min_rate_age_s) | ((a == 0) & moving)
    tc = camera if (pan_offset_deg == 0 and tilt_offset_deg == 0) else camera.with_pose(
        pan_deg=camera.pose.pan_deg + pan_offset_deg, tilt_deg=camera.pose.tilt_deg + tilt_offset_deg)
    e, nn, rng = tc.pixel_to_sea_enu(u, v)
    return TrackAngles((az0 + pan_offset_deg) % 360.0, el0 + tilt_offset_deg, half, az_rate, el_rate, rng, e, nn,
                       half_h, valid)


def target_angles(states: TargetStates, e0_m: float, n0_m: float, height_m: float, r_eff_m: float) -> TargetAngles:
    """Angles of targets seen from a camera at ENU ``(e0, n0, height)`` over a sea of radius ``r_eff_m``.

    The elevation is that of the target's waterline (the sea surface at its range, dropped by
    the curvature ``d**2 / (2 R_eff)``).
    """
    de = states.e_m - e0_m
    dn = states.n_m - n0_m
    d2 = de * de + dn * dn
    d = np.sqrt(d2)
    az = np.degrees(np.arctan2(de, dn)) % 360.0
    drop = d2 / (2.0 * r_eff_m)
    el = np.degrees(np.arctan2(-(height_m + drop), d))
    with np.errstate(invalid="ignore", divide="ignore"):
        az_rate = np.degrees((dn * states.ve_mps - de * states.vn_mps) / np.maximum(d2, 1.0))
        range_rate = (de * states.ve_mps + dn * states.vn_mps) / np.maximum(d, 1.0)
    # d(el)/dd for el = atan(-(h + d^2/2R) / d)
    hh = height_m + drop
    del_dr = np.degrees((hh - d * d / r_eff_m) / np.maximum(d2 + hh * hh, 1.0))
    return TargetAngles(az, el, d, az_rate, del_dr * range_rate, del_dr)


def pair_distance2(
    trk: TrackAngles,
    tgt: TargetAngles,
    age_s: np.ndarray,
    speed_mps: np.ndarray,
    sigma_az_deg: float = 0.5,
    sigma_el_deg: float = 0.3,
    sigma_rate_dps: float = 0.05,
    pos_sigma_m: float | np.ndarray = 10.0,
    speed_sigma_frac: float = 0.1,
    range_frac: float = 0.3,
    rate_box_frac: float = 0.05,
    gate_deg: float = np.inf,
    motion_cap: float = 4.5,
) -> np.ndarray:
    """Normalised squared distance between every camera track and every target, (N, M).

    * Azimuth: distance from the target's azimuth to the track box's azimuth interval (the AIS
      antenna can be anywhere on the hull, and the box covers the hull); ``sigma_az_deg`` plus
      the target's position uncertainty seen at its range.
    * Elevation of the waterline: ``sigma_el_deg`` plus ``range_frac`` of the target's depression
      angle (a relative range error, e.g. the waterline hidden by the bow wave or a camera tilt
      error shows up as a proportional elevation error) plus the position uncertainty.
    * Motion: azimuth and elevation rates, with ``sigma_rate_dps`` plus a quarter of the target's
      rate plus ``rate_box_frac`` of the box's angular size per second (box jitter); left out for
      tracks whose rate is not valid (just born); its contribution is capped at ``motion_cap``.

    Target position uncertainty grows with report age and speed
    (``pos_sigma_m + speed_sigma_frac * speed * age``).  Pairs whose azimuth distance (beyond the
    box) exceeds ``gate_deg`` get ``inf``.
    """
    daz = np.abs(angle_diff_deg(trk.az_deg[:, None], tgt.az_deg[None, :]))
    daz = np.maximum(daz - trk.half_width_deg[:, None], 0.0)
    pos_sig = pos_sigma_m + speed_sigma_frac * speed_mps * age_s
    rng = np.maximum(tgt.range_m, 1.0)
    s_az2 = sigma_az_deg ** 2 + np.degrees(pos_sig / rng) ** 2
    s_el2 = sigma_el_deg ** 2 + (range_frac * tgt.el_deg) ** 2 + (tgt.del_dr * pos_sig) ** 2
    del_ = trk.el_deg[:, None] - tgt.el_deg[None, :]
    d2 = daz * daz / s_az2[None, :] + del_ * del_ / s_el2[None, :]
    hh = trk.half_height_deg if trk.half_height_deg is not None else 0.5 * trk.half_width_deg
    s_rate = sigma_rate_dps + 0.25 * np.abs(tgt.az_rate_dps)[None, :] + (2 * rate_box_frac * trk.half_width_deg)[:, None]
    drate = trk.az_rate_dps[:, None] - tgt.az_rate_dps[None, :]
    s_erate = sigma_rate_dps + 0.25 * np.abs(tgt.el_rate_dps)[None, :] + (2 * rate_box_frac * hh)[:, None]
    derate = trk.el_rate_dps[:, None] - tgt.el_rate_dps[None, :]
    motion = (drate / s_rate) ** 2 + (derate / s_erate) ** 2
    if trk.rate_valid is not None:
        motion *= trk.rate_valid[:, None]
    # one frame's rates alone never rule a pair out (rates are the noisiest measurement)
    d2 += np.minimum(motion, motion_cap)
    if np.isfinite(gate_deg):
        d2[daz > gate_deg] = np.inf
    return d2


class AngleHistory:
    """Recent azimuth/elevation of every camera track, for rates fitted over a short window.

    Rates measured this way are in world angles (a panning camera's motion drops out) and are
    far less noisy than a tracker's frame-to-frame pixel velocity.

    Parameters
    ----------
    window_s : float, fit window.
    size : int, samples kept per track.
    forget_s : float, tracks unseen this long are dropped.
    """

    def __init__(self, window_s: float = 2.0, size: int = 32, forget_s: float = 10.0):
        self.window_s = float(window_s)
        self.K = int(size)
        self.forget_s = float(forget_s)
        self.rows: dict[int, int] = {}
        self._free: list[int] = []
        cap = 64
        self.T = np.full((cap, self.K), np.nan)
        self.AZ = np.zeros((cap, self.K))
        self.EL = np.zeros((cap, self.K))
        self.pos = np.zeros(cap, np.int64)
        self.seen = np.full(cap, -np.inf)
        self._n = 0
        self._last_forget = -np.inf

    def _row(self, tid: int) -> int:
        r = self.rows.get(tid)
        if r is None:
            if self._free:
                r = self._free.pop()
            else:
                r = self._n
                self._n += 1
                if r >= len(self.pos):
                    g = len(self.pos)
                    self.T = np.vstack([self.T, np.full((g, self.K), np.nan)])
                    self.AZ = np.vstack([self.AZ, np.zeros((g, self.K))])
                    self.EL = np.vstack([self.EL, np.zeros((g, self.K))])
                    self.pos = np.concatenate([self.pos, np.zeros(g, np.int64)])
                    self.seen = np.concatenate([self.seen, np.full(g, -np.inf)])
            self.rows[tid] = r
            self.T[r] = np.nan
            self.pos[r] = 0
        return r

    def update(self, t_s: float, ids, az_deg, el_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Add this frame's angles; returns ``az_rate_dps, el_rate_dps, valid`` per track.

        A rate is valid when the track has at least 3 samples spanning half the window.
        """
        ids = np.asarray(ids, np.int64)
        n = len(ids)
        if t_s - self._last_forget >= 1.0 or t_s < self._last_forget:
            for tid, r in list(self.rows.items()):
                if t_s - self.seen[r] > self.forget_s:
                    del self.rows[tid]
                    self._free.append(r)
            self._last_forget = t_s
        if n == 0:
            return np.zeros(0), np.zeros(0), np.zeros(0, bool)
        rows = np.fromiter((self._row(int(t)) for t in ids), np.int64, n)
        k = self.pos[rows] % self.K
        self.T[rows, k] = t_s
        self.AZ[rows, k] = az_deg
        self.EL[rows, k] = el_deg
        self.pos[rows] += 1
        self.seen[rows] = t_s
        T = self.T[rows]
        w = np.isfinite(T) & (T >= t_s - self.window_s)
        cnt = w.sum(axis=1)
        tt = np.where(w, T - t_s, 0.0)
        span = np.where(w, tt, 0.0).min(axis=1) * -1.0
        daz = np.where(w, angle_diff_deg(self.AZ[rows], np.asarray(az_deg, float)[:, None]), 0.0)
        de = np.where(w, self.EL[rows] - np.asarray(el_deg, float)[:, None], 0.0)
        c = np.maximum(cnt, 1)
        mt = tt.sum(axis=1) / c
        tc = np.where(w, tt - mt[:, None], 0.0)
        var = (tc * tc).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            az_rate = (tc * daz).sum(axis=1) / var
            el_rate = (tc * de).sum(axis=1) / var
        valid = (cnt >= 3) & (span >= 0.5 * self.window_s) & (var > 0)
        return np.where(valid, az_rate, 0.0), np.where(valid, el_rate, 0.0), valid


class WindowAssociator:
    """One-to-one association of tracks with targets from evidence averaged over a time window.

    Per pair, the per-frame log-likelihood ratio ``llr = (gate**2 - d2) / 2`` (floored at
    ``-gate**2 / 2``) is averaged with exponential forgetting (time constant ``window_s``).
    A pair may be assigned when its mean llr exceeds ``min_llr`` and its track has been observed
    for at least ``min_support_s``; the assignment maximises the summed mean llr (Hungarian),
    with ``switch_margin`` added to the current assignments (hysteresis).

    Parameters
    ----------
    window_s : float, forgetting time constant.
    gate : float, gate in standard deviations.
    min_llr : float, minimum mean llr of an assigned pair.
    min_support_s : float, minimum observed time of a track before it gets an identity.
    switch_margin : float, llr bonus of the current assignment.
    forget_s : float, rows of tracks (columns of targets) unseen this long are dropped.
    ambiguity_margin : float
        A track takes a *new* identity only when its pair's mean llr leads every other candidate
        of the track that no other track holds in this assignment by at least this much (two AIS
        vessels behind one camera track, e.g. while one passes in front of the other, give it
        none); an identity it already holds is kept (``switch_margin`` governs that).  0: off.
    """

    def __init__(self, window_s: float = 10.0, gate: float = 3.0, min_llr: float = 1.0,
                 min_support_s: float = 2.0, switch_margin: float = 1.0, forget_s: float = 30.0,
                 ambiguity_margin: float = 0.0):
        self.window_s = float(window_s)
        self.gate = float(gate)
        self.min_llr = float(min_llr)
        self.min_support_s = float(min_support_s)
        self.switch_margin = float(switch_margin)
        self.forget_s = float(forget_s)
        self.ambiguity_margin = float(ambiguity_margin)
        self.rows: dict[int, int] = {}
        self.cols: dict[int, int] = {}
        self.row_ids = np.zeros(16, np.int64)
        self.col_keys = np.zeros(64, np.int64)
        self.S = np.zeros((16, 64))  # decayed sum of llr * weight
        self.W = np.zeros(16)  # decayed observed weight per row
        self.row_seen = np.full(16, -np.inf)
        self.col_seen = np.full(64, -np.inf)
        self.observed_s = np.zeros(16)
        self.assigned: dict[int, int] = {}  # track id -> target key
        self.t_last: float | None = None
        self._last_forget = -np.inf
        self._last_ids = None
        self._last_keys = None
        self._free_rows: list[int] = []
        self._free_cols: list[int] = []
        self._nr = 0
        self._nc = 0

    # ---------------------------------------------------------------- index maps
    def _row(self, tid: int) -> int:
        r = self.rows.get(tid)
        if r is None:
            if self._free_rows:
                r = self._free_rows.pop()
            else:
                r = self._nr
                self._nr += 1
                if r >= self.S.shape[0]:
                    grow = self.S.shape[0]
                    self.S = np.vstack([self.S, np.zeros((grow, self.S.shape[1]))])
                    self.W = np.concatenate([self.W, np.zeros(grow)])
                    self.row_seen = np.concatenate([self.row_seen, np.full(grow, -np.inf)])
                    self.observed_s = np.concatenate([self.observed_s, np.zeros(grow)])
                    self.row_ids = np.concatenate([self.row_ids, np.zeros(grow, np.int64)])
            self.rows[tid] = r
            self.row_ids[r] = tid
            self.S[r] = 0.0
            self.W[r] = 0.0
            self.observed_s[r] = 0.0
        return r

    def _col(self, key: int) -> int:
        c = self.cols.get(key)
        if c is None:
            if self._free_cols:
                c = self._free_cols.pop()
            else:
                c = self._nc
                self._nc += 1
                if c >= self.S.shape[1]:
                    grow = self.S.shape[1]
                    self.S = np.hstack([self.S, np.zeros((self.S.shape[0], grow))])
                    self.col_seen = np.concatenate([self.col_seen, np.full(grow, -np.inf)])
                    self.col_keys = np.concatenate([self.col_keys, np.zeros(grow, np.int64)])
            self.cols[key] = c
            self.col_keys[c] = key
            self.S[:, c] = 0.0
        return c

    def _forget(self, t_s: float) -> None:
        self._last_ids = None
        self._last_keys = None
        for tid, r in list(self.rows.items()):
            if t_s - self.row_seen[r] > self.forget_s:
                del self.rows[tid]
                self.assigned.pop(tid, None)
                self._free_rows.append(r)
                self.row_seen[r] = -np.inf
        for key, c in list(self.cols.items()):
            if t_s - self.col_seen[c] > self.forget_s:
                del self.cols[key]
                self._free_cols.append(c)
                self.col_seen[c] = -np.inf
                for tid in [t for t, k in self.assigned.items() if k == key]:
                    del self.assigned[tid]

    # -------------------------------------------------------------------- update
    def update(self, t_s: float, track_ids: np.ndarray, target_keys: np.ndarray, d2: np.ndarray,
               eligible: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Add one frame of evidence and (re)assign.

        Parameters
        ----------
        t_s : frame time.
        track_ids : (N,) camera track ids in this frame.
        target_keys : (M,) target keys present at this time.
        d2 : (N, M) normalised squared distances (:func:`pair_distance2`).
        eligible : (N,) bool, tracks that may receive an identity this frame (e.g. confirmed).

        Returns
        -------
        keys : (N,) int64, assigned target key per track (0 = none).
        mean_llr : (N,) mean llr of the assigned pair (NaN when none).
        """
        track_ids = np.asarray(track_ids, np.int64)
        target_keys = np.asarray(target_keys, np.int64)
        n, m = len(track_ids), len(target_keys)
        dt = 0.0 if self.t_last is None else max(0.0, t_s - self.t_last)
        self.t_last = t_s
        if dt > 0:
            decay = np.exp(-dt / self.window_s)
            nr, nc = self._nr, self._nc
            self.S[:nr, :nc] *= decay
            self.W[:nr] *= decay
        w = max(dt, 1e-3) / self.window_s  # weight of this frame's evidence
        if self._last_ids is not None and np.array_equal(track_ids, self._last_ids[0]):
            rows = self._last_ids[1]
        else:
            rows = np.fromiter((self._row(int(t)) for t in track_ids), np.int64, n)
            self._last_ids = (track_ids.copy(), rows)
        if self._last_keys is not None and np.array_equal(target_keys, self._last_keys[0]):
            cols = self._last_keys[1]
        else:
            cols = np.fromiter((self._col(int(k)) for k in target_keys), np.int64, m)
            self._last_keys = (target_keys.copy(), cols)
        self.row_seen[rows] = t_s
        self.col_seen[cols] = t_s
        self.observed_s[rows] += dt if dt > 0 else 0.0
        g2 = self.gate * self.gate
        if n:
            # every known target counts as a miss for these tracks, present ones add their llr
            delta = np.full(self._nc, -0.5 * g2 * w)
            delta = np.broadcast_to(delta, (n, self._nc)).copy()
            if m:
                delta[:, cols] += 0.5 * (g2 - np.minimum(d2, 2 * g2)) * w + 0.5 * g2 * w
            self.S[rows, : self._nc] += delta
            self.W[rows] += w
        if t_s - self._last_forget >= 1.0 or t_s < self._last_forget:
            self._forget(t_s)
            self._last_forget = t_s
        out = np.zeros(n, np.int64)
        conf = np.full(n, np.nan)
        if n == 0 or m == 0:
            for tid in track_ids.tolist():
                self.assigned.pop(tid, None)
            return out, conf
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = self.S[np.ix_(rows, cols)] / self.W[rows][:, None]
        ok = (self.observed_s[rows] >= self.min_support_s)[:, None] & (mean > self.min_llr) & (d2 < 4 * g2)
        if eligible is not None:
            ok &= np.asarray(eligible, bool)[:, None]
        score = np.where(ok, mean, -1e9)
        if self.assigned:
            prev = np.array([self.assigned.get(tid, -1) for tid in track_ids.tolist()], np.int64)
            jj = index_of(target_keys, prev)
            ii = np.flatnonzero(jj >= 0)
            jj = jj[ii]
            bonus = ok[ii, jj]
            score[ii[bonus], jj[bonus]] += self.switch_margin
        ri, ci = linear_sum_assignment(-score)
        good = score[ri, ci] > -1e8
        ri, ci = ri[good], ci[good]
        if self.ambiguity_margin > 0 and len(ri):
            held = np.array([self.assigned.get(int(track_ids[i]), 0) for i in ri.tolist()], np.int64)
            new = held != target_keys[ci]
            if new.any():
                # candidates of each row that no other row holds in this assignment
                cand = np.where(ok, mean, -np.inf)[ri]
                taken = np.zeros(m, bool)
                taken[ci] = True
                cand[:, taken] = -np.inf
                runner = cand.max(axis=1) if m else np.full(len(ri), -np.inf)
                clear = mean[ri, ci] - runner >= self.ambiguity_margin
                keep = ~new | clear
                ri, ci = ri[keep], ci[keep]
        for tid in track_ids.tolist():
            self.assigned.pop(tid, None)
        out[ri] = target_keys[ci]
        conf[ri] = mean[ri, ci]
        for i, j in zip(ri.tolist(), ci.tolist()):
            self.assigned[int(track_ids[i])] = int(target_keys[j])
        return out, conf

    def mean_llr(self, track_ids, target_keys) -> np.ndarray:
        """Current mean llr of pairs (NaN for unknown ids/keys)."""
        out = np.full((len(track_ids), len(target_keys)), np.nan)
        for i, t in enumerate(np.asarray(track_ids).tolist()):
            r = self.rows.get(t)
            if r is None or self.W[r] <= 0:
                continue
            for j, k in enumerate(np.asarray(target_keys).tolist()):
                c = self.cols.get(k)
                if c is not None:
                    out[i, j] = self.S[r, c] / self.W[r]
        return out
