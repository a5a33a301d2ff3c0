"""The :class:`Fuser`: camera tracks + AIS (+ radar/VTS) -> tracks with identities, fused picture, alerts."""

from __future__ import annotations

import bisect
import math
from collections import deque
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from seawatch.config import FusionSettings
from seawatch.fuse.alerts import KN_PER_MPS, Alert, ais_report_interval_s
from seawatch.fuse.associate import (
    AngleHistory,
    TrackAngles,
    WindowAssociator,
    angle_diff_deg,
    index_of,
    pair_distance2,
    target_angles,
    track_angles,
    waterline_px,
)
from seawatch.fuse.table import TargetTable
from seawatch.fuse.theta import calibrate_theta_pg, estimate_theta_robust, velocity_cost
from seawatch.types import AISReport, Frame, FusedTrack, Tracks, TrackState

__all__ = ["Fuser", "Calibration"]



def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    o = np.argsort(x)
    cw = np.cumsum(w[o])
    return float(x[o][np.searchsorted(cw, 0.5 * cw[-1])])


class Calibration:
    """Self-calibration of the camera's heading (pan) and tilt from confident matches.

    Samples are ``az_target - az_track`` and ``el_target - el_track`` from raw (uncorrected)
    camera angles with inverse-variance weights, at most one per (track, vessel) pair per
    ``interval_s``; once there are ``min_samples`` from at least ``min_pairs`` different vessels
    (one vessel cannot tell a camera error from its own AIS error), the offsets are the weighted
    medians of the latest ``max_samples`` and their standard errors
    ``1.2533 * 1.4826 * MAD / sqrt(n_eff)``.
    """

    def __init__(self, max_samples: int = 400, interval_s: float = 1.0, min_samples: int = 10,
                 max_offset_deg: float = 5.0, min_pairs: int = 2):
        self.samples: deque = deque(maxlen=int(max_samples))
        self.interval_s = float(interval_s)
        self.min_samples = int(min_samples)
        self.min_pairs = int(min_pairs)
        self._pairs: dict[tuple[int, int], int] = {}
        self.max_offset_deg = float(max_offset_deg)
        self._last: dict[tuple[int, int], float] = {}
        self.pan_offset_deg = 0.0
        self.tilt_offset_deg = 0.0
        self.pan_sigma_deg = float("nan")
        self.tilt_sigma_deg = float("nan")
        self.pan_estimate_deg = float("nan")
        self.tilt_estimate_deg = float("nan")

    def add(self, t_s: float, pair: tuple[int, int], daz_deg: float, del_deg: float,
            w_az: float = 1.0, w_el: float = 1.0) -> None:
        """Add one sample (weights: inverse variances of the azimuth and elevation residuals)."""
        last = self._last.get(pair)
        if last is not None and t_s - last < self.interval_s:
            return
        self._last[pair] = t_s
        if len(self.samples) == self.samples.maxlen:
            old = self.samples[0][4]
            self._pairs[old] -= 1
            if not self._pairs[old]:
                del self._pairs[old]
        self.samples.append((daz_deg, del_deg, w_az, w_el, pair))
        self._pairs[pair] = self._pairs.get(pair, 0) + 1

    def estimate(self) -> bool:
        """Recompute the offsets; returns True when there are enough samples and vessels.

        Per vessel, the weighted median of its samples; across vessels, the median weighted by
        each vessel's inverse variance.  The standard error is the larger of the spread between
        vessels (``1.2533 * 1.4826 * MAD / sqrt(n_eff)``) and ``1 / sqrt(sum of inverse
        variances)``.  An offset is applied only when it exceeds twice its standard error.
        """
        n = len(self.samples)
        if n < self.min_samples or len({p[1] for p in self._pairs}) < self.min_pairs:
            return False
        groups: dict[tuple, list] = {}
        for x in self.samples:
            groups.setdefault(x[4], []).append(x[:4])
        out = []
        for d in (0, 1):
            m, wv = [], []
            for rows in groups.values():
                g = np.asarray(rows)
                m.append(_weighted_median(g[:, d], g[:, 2 + d]))
                wv.append(float(np.median(g[:, 2 + d])))
            m, wv = np.asarray(m), np.asarray(wv)
            med = _weighted_median(m, wv)
            mad = _weighted_median(np.abs(m - med), wv)
            n_eff = wv.sum() ** 2 / np.sum(wv * wv)
            se = max(1.2533 * 1.4826 * mad / math.sqrt(n_eff), 1.0 / math.sqrt(wv.sum()))
            out.append((med, se))
        (mp, sp), (mt, stt) = out
        self.pan_estimate_deg, self.tilt_estimate_deg = float(mp), float(mt)
        self.pan_offset_deg = float(np.clip(mp, -self.max_offset_deg, self.max_offset_deg)) if abs(mp) > 2 * sp else 0.0
        self.tilt_offset_deg = float(np.clip(mt, -self.max_offset_deg, self.max_offset_deg)) if abs(mt) > 2 * stt else 0.0
        self.pan_sigma_deg, self.tilt_sigma_deg = float(sp), float(stt)
        return True

    def as_dict(self) -> dict:
        return {
            "pan_offset_deg": self.pan_offset_deg,
            "pan_estimate_deg": self.pan_estimate_deg,
            "pan_sigma_deg": self.pan_sigma_deg,
            "tilt_offset_deg": self.tilt_offset_deg,
            "tilt_estimate_deg": self.tilt_estimate_deg,
            "tilt_sigma_deg": self.tilt_sigma_deg,
            "n_samples": len(self.samples),
            "n_vessels": len({p[1] for p in self._pairs}),
        }


class _AISFeed:
    """Reports released by time: a replay list (sorted) and/or a live listener."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.reports: list[AISReport] = []
        self.i = 0
        self.listeners: list[Any] = []

    def add(self, reports: Iterable[AISReport]) -> None:
        reps = sorted(reports, key=lambda r: r.t_s)
        if not reps:
            return
        rest = self.reports[self.i:]
        if rest and reps[0].t_s < rest[-1].t_s:
            merged = sorted(rest + reps, key=lambda r: r.t_s)
        else:
            merged = rest + reps
        self.reports = merged
        self.t = [r.t_s for r in merged]
        self.i = 0

    def release(self, t_s: float) -> list[AISReport]:
        j = bisect.bisect_right(self.t, t_s, lo=self.i)
        out = self.reports[self.i:j]
        self.i = j
        for lis in self.listeners:
            out = out + lis.poll()
        return out


class Fuser:
    """Camera / AIS / radar fusion for one camera (see :mod:`seawatch.fuse` for the API).

    Parameters
    ----------
    camera : seawatch.camera.CameraModel
        The base camera model; a frame's ``ptz`` (or ``pose``) gives the per-frame model.
    settings : FusionSettings, optional
    ais : list of AISReport, structured array (``AIS_DTYPE``), path, ``udp://``/``tcp://`` URL or
        an object with ``poll()``; optional, more can be added with :meth:`add_ais`.
    radar : structured array of radar/VTS plots (:data:`seawatch.io.radar.RADAR_DTYPE`), optional.
    camera_id : str
    """

    def __init__(self, camera, settings: FusionSettings | None = None, ais=None, radar=None,
                 camera_id: str = "cam0"):
        self.settings = s = settings or FusionSettings()
        for key in ("wake_s", "ais_warmup_s", "no_ais_dwell_s", "spoof_dwell_s", "ais_unseen_dwell_s",
                    "no_ais_unlocated_hold_s"):
            v = getattr(s, key, 0.0)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"[fusion] key '{key}': expected a finite number of seconds >= 0, got {v}")
        for key in ("no_ais_lost_reports", "no_ais_unheard_lost_reports"):
            v = getattr(s, key)
            if not (isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 10):
                raise ValueError(f"[fusion] key '{key}': expected an integer 0-10, got {v!r}")
        v = s.max_box_length_ratio
        if not (math.isfinite(v) and (v == 0 or v >= 1)):
            raise ValueError(f"[fusion] key 'max_box_length_ratio': expected 0 (off) or a finite number >= 1, got {v}")
        for key in ("box_length_margin_m", "box_length_min_reported_m"):
            v = getattr(s, key)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"[fusion] key '{key}': expected a finite number of metres >= 0, got {v}")
        self.camera = camera
        self.camera_id = camera_id
        lat0, lon0 = camera.pose.lat_deg, camera.pose.lon_deg
        self.ais = TargetTable(lat0, lon0, max_age_s=s.ais_max_age_s)
        self.vts = TargetTable(lat0, lon0, max_age_s=max(30.0, 3 * s.window_s))
        mk = lambda: WindowAssociator(s.window_s, s.gate_sigma, s.min_llr, s.min_support_s,  # noqa: E731
                                      s.switch_margin, forget_s=max(30.0, 3 * s.window_s),
                                      ambiguity_margin=s.ambiguity_margin)
        self.assoc = mk()
        self.angles = AngleHistory(s.rate_window_s if s.rate_window_s > 0 else 2.0)
        self.assoc_vts = mk()
        self.calib = Calibration(min_samples=s.calib_min_samples, max_offset_deg=s.calib_max_offset_deg)
        self.theta = estimate_theta_robust(np.zeros((0, 2)), np.zeros((0, 2)))
        self.theta_pg_deg = float("nan")
        self._theta_pairs: deque = deque(maxlen=600)
        self._theta_frames: deque = deque(maxlen=60)
        self._theta_last_t = -np.inf
        self._calib_last_t = -np.inf
        self._track_pos: dict[int, deque] = {}
        self._born: dict[int, float] = {}  # track id -> AIS-clock time first seen
        self._trail: tuple[float, np.ndarray] | None = None  # (time, rows t, e, n, owner born, owner id)
        self._vel_cache: dict = {}
        self._feed = _AISFeed()
        self._radar: np.ndarray | None = None
        self._radar_i = 0
        self._cam_cache: dict = {}
        self.ais_stats = None
        # alert state
        self._first_conf: dict[int, float] = {}
        self._last_plausible: dict[int, float] = {}
        self._no_ais_alerted: set[int] = set()
        self._no_ais_last: dict[int, tuple[float, float, float]] = {}  # flagged track -> (t, e, n) last seen
        self._unseen_since: dict[int, float] = {}
        self._unseen_alerted: set[int] = set()
        self._spoof_since: dict[int, float] = {}
        self._spoof_alerted: set[int] = set()
        self._history: dict[int, tuple[int, float]] = {}  # track id -> (mmsi, seconds matched)
        self._track_seen: dict[int, float] = {}
        self._motion_spoof_since: dict[tuple[int, int], float] = {}
        self.n_updates = 0
        self.n_alerts: dict[str, int] = {"no_ais": 0, "ais_not_seen": 0, "possible_spoofing": 0}
        self._t_prev: float | None = None
        # AIS clock time since which the AIS feed is live: the first report of a replay (a file may
        # begin later than the video), the first update of a live listener
        self._ais_since: float | None = None
        # MMSIs heard only without a usable position (static data, or positions "not available"):
        # MMSI -> (AIS-clock time first heard, time last heard, class "A"/"B" from its message
        # types); "first heard" restarts after a silence longer than ais_max_age_s, and entries
        # not heard for ais_max_age_s are deleted
        self._heard: dict[int, tuple[float, float, str]] = {}
        self.frame_el_offset_deg = 0.0
        self._last = None
        if ais is not None:
            self.add_ais(ais)
        if radar is not None:
            self.add_radar(radar)

    # ------------------------------------------------------------------- inputs
    def add_ais(self, ais) -> None:
        """Add AIS: reports, a structured array, a file/folder path, a stream URL or a listener.

        Reports are released to the track table when the frame clock (plus
        ``ais_time_offset_s``) reaches their time, so a file replays in step with the video.
        """
        if ais is None:
            return
        if hasattr(ais, "poll"):
            self._feed.listeners.append(ais)
            return
        if isinstance(ais, (str, Path)):
            text = str(ais)
            if text.startswith(("udp://", "tcp://")):
                from seawatch.io.ais import AISListener

                self._feed.listeners.append(AISListener(text))
                return
            from seawatch.io.ais import read_ais

            reps, stats = read_ais(ais)
            self.ais_stats = stats
            self._feed.add(reps)
            return
        if isinstance(ais, np.ndarray):
            self._feed.add(
                AISReport(int(r["mmsi"]), float(r["t_s"]), float(r["lat_deg"]), float(r["lon_deg"]),
                          float(r["sog_kn"]), float(r["cog_deg"]), float(r["heading_deg"]))
                for r in ais
            )
            return
        self._feed.add(list(ais))

    def add_radar(self, plots: np.ndarray) -> None:
        """Add radar/VTS plots (structured array with ``t_s, id, lat_deg, lon_deg, speed_mps,
        course_deg``), released by time like AIS."""
        p = np.asarray(plots)
        if self._radar is not None:
            p = np.concatenate([self._radar[self._radar_i:], p])
        self._radar = p[np.argsort(p["t_s"], kind="stable")]
        self._radar_i = 0

    def close(self) -> None:
        for lis in self._feed.listeners:
            if hasattr(lis, "close"):
                lis.close()

    # ---------------------------------------------------------------- camera
    def camera_for(self, frame: Frame | None):
        """The camera model at a frame's PTZ state / pose and image size."""
        cam = self.camera
        if frame is None:
            return cam
        key = (frame.ptz, frame.pose, frame.shape)
        hit = self._cam_cache.get(key)
        if hit is not None:
            return hit
        if frame.ptz is not None:
            cam = cam.with_ptz(frame.ptz)
        elif frame.pose is not None and frame.pose != cam.pose:
            cam = cam.with_pose(**{k: getattr(frame.pose, k) for k in ("lat_deg", "lon_deg", "height_m", "pan_deg",
                                                                        "tilt_deg", "roll_deg")})
        h, w = frame.shape
        K = cam.intrinsics
        if (K.width, K.height) != (w, h) and w > 0 and h > 0:
            cam = cam.with_intrinsics(K.scaled_to(w, h))
        if len(self._cam_cache) > 256:
            self._cam_cache.clear()
        self._cam_cache[key] = cam
        return cam

    # -------------------------------------------------------------------- update
    def update(self, tracks: Tracks, frame: Frame | None = None, t_s: float | None = None) -> tuple[Tracks, list[Alert]]:
        """Fuse one frame's camera tracks.

        Returns the tracks with ``mmsi`` (0 = none), ``world`` (lat, lon, speed m/s, course) and
        a ``names`` list attribute filled, and the alerts raised at this frame.
        """
        s = self.settings
        t = float(tracks.t_s if t_s is None else t_s)
        t_ais = t + s.ais_time_offset_s
        self.n_updates += 1
        dt = 0.0 if self._t_prev is None else max(0.0, t - self._t_prev)
        self._t_prev = t
        reps = self._feed.release(t_ais)
        if reps:
            self.ais.add_reports(reps)
            for r in reps:  # MMSIs heard without a usable position so far
                if r.has_position:
                    self._heard.pop(r.mmsi, None)
                    continue
                tr = float(r.t_s)
                slot = self.ais.slot(r.mmsi)
                if slot is not None and tr - self.ais.t[slot] <= s.ais_max_age_s:
                    continue  # located recently (a stale position, e.g. before its GNSS failed, is none)
                prev = self._heard.get(r.mmsi)
                if prev is not None and tr - prev[1] > s.ais_max_age_s:
                    prev = None  # silent for longer than the max age: heard anew
                cls = "B" if r.msg_type in (18, 19, 24) or (prev is not None and prev[2] == "B") else "A"
                self._heard[r.mmsi] = ((tr, tr, cls) if prev is None else (min(prev[0], tr), max(prev[1], tr), cls))
            if self._ais_since is None:
                self._ais_since = min(t_ais, min(r.t_s for r in reps))
        elif self._ais_since is None and self._feed.listeners:
            self._ais_since = t_ais  # a live feed is live from when the fuser starts listening
        if self._heard:
            for m in [m for m, h in self._heard.items() if t_ais - h[1] > s.ais_max_age_s]:
                del self._heard[m]
        if self._radar is not None and self._radar_i < len(self._radar):
            j = int(np.searchsorted(self._radar["t_s"], t_ais, side="right"))
            if j > self._radar_i:
                p = self._radar[self._radar_i:j]
                self.vts.update(p["id"], p["t_s"], p["lat_deg"], p["lon_deg"], p["speed_mps"], p["course_deg"])
                self._radar_i = j
        cam = self.camera_for(frame)
        n = len(tracks)
        ids = tracks.ids
        confirmed = tracks.states != int(TrackState.TENTATIVE)
        ta = track_angles(cam, tracks.boxes, tracks.velocities, self.calib.pan_offset_deg, self.calib.tilt_offset_deg,
                          tracks.ages_s)
        # --- AIS
        st, tg = self._targets(self.ais, t_ais, cam)
        el_before_align = ta.el_deg.copy()
        self._frame_align(ids, ta, st, tg)
        if s.rate_window_s > 0:  # rates fitted to the track's recent angles instead of the tracker's velocity
            ta.az_rate_dps, ta.el_rate_dps, ta.rate_valid = self.angles.update(
                t_ais, ids, ta.az_deg - self.calib.pan_offset_deg, ta.el_deg - self.calib.tilt_offset_deg)
        held = np.array([self.assoc.assigned.get(tid, 0) for tid in ids.tolist()], np.int64)
        d2, self._sized = self._distance(ta, st, tg, held)
        keys, conf = self.assoc.update(t_ais, ids, st.keys, d2, eligible=confirmed)
        # --- VTS (radar), for tracks without AIS
        vkeys = np.zeros(n, np.int64)
        vst = None
        if len(self.vts):
            vst, vtg, vd2 = self._candidates(self.vts, t_ais, cam, ta)
            vkeys, _ = self.assoc_vts.update(t_ais, ids, vst.keys, vd2, eligible=confirmed)
        # --- calibration from confident, unambiguous matches
        if s.self_calibrate and n and len(st):
            self._calibrate(t_ais, ids, ta, st, tg, d2, keys, conf, el_before_align)
        self._record_positions(t_ais, cam, tracks)
        self._theta_update(t_ais, cam, tracks, ta, st, tg, d2, keys)
        # --- outputs
        out = tracks.subset(np.arange(n))
        out.mmsi = keys.copy()
        world = self._world(cam, ta, st, tg, keys, vst, vkeys, tracks)
        out.world = world
        out.names = [self.ais.names[self.ais.slot(k)] if k else None for k in keys.tolist()]
        alerts: list[Alert] = []
        if s.alerts:
            alerts = self._alerts(t, t_ais, dt, cam, tracks, ta, st, tg, d2, keys, vkeys, world)
        self._last = (t, t_ais, out, keys, vst, vkeys)
        return out, alerts

    def _targets(self, table: TargetTable, t_ais: float, cam):
        """Targets dead-reckoned to ``t_ais`` near the field of view, and their angles."""
        s = self.settings
        st = table.states_at(t_ais)
        if len(st):
            rng = np.hypot(st.e_m, st.n_m)
            az = np.degrees(np.arctan2(st.e_m, st.n_m))
            half = 0.5 * cam.intrinsics.hfov_deg + s.gate_deg + 5.0
            keep = (rng <= s.max_range_m) & (np.abs(angle_diff_deg(az, cam.pose.pan_deg)) <= half)
            if not keep.all():
                st = st.subset(keep)
        return st, target_angles(st, 0.0, 0.0, cam.pose.height_m, cam.r_eff_m)

    def _distance(self, ta: TrackAngles, st, tg, held: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(N, M) normalised squared distances of tracks and targets, and the (N, M) mask of the
        pairs the size gate removed (``d2 = inf`` there): a box far longer, at the target's range,
        than ``max_box_length_ratio`` x the target's reported length + ``box_length_margin_m``.

        A pair removed by size is *not comparable*, not far: its position says nothing (a
        labelled boat whose box merges with a passing hull has not left its bearing).  The gate
        applies only to reported lengths of at least ``box_length_min_reported_m`` (a length of
        1 + 1 m is a misconfigured transponder, not a 2 m vessel); unknown (NaN) lengths rule
        nothing out.  Nor does it remove a track's current identity (``held``, (N,) target keys,
        0 none): a box that grows around a labelled vessel keeps its label.
        """
        s = self.settings
        sized = np.zeros((len(ta.az_deg), len(st)), bool)
        if len(ta.az_deg) == 0 or len(st) == 0:
            return np.zeros((len(ta.az_deg), len(st))), sized
        sp = st.speed_mps
        d2 = pair_distance2(ta, tg, st.age_s, sp, s.sigma_az_deg, s.sigma_el_deg, s.sigma_rate_dps,
                            s.pos_sigma_m + sp * s.ais_latency_s, range_frac=s.range_frac,
                            rate_box_frac=s.rate_box_frac, gate_deg=s.gate_deg)
        trusted = st.length_m >= s.box_length_min_reported_m  # NaN compares False: unknown rules nothing out
        if s.max_box_length_ratio > 0 and trusted.any():
            # a box far longer, at the target's range, than the target's reported length is not
            # that vessel (e.g. a small boat's AIS position behind a passing ferry's box)
            box_m = 2.0 * np.radians(ta.half_width_deg)[:, None] * np.maximum(tg.range_m, 1.0)[None, :]
            sized = trusted[None, :] & (box_m > (s.max_box_length_ratio * st.length_m + s.box_length_margin_m)[None, :])
            if held is not None:
                sized &= held[:, None] != st.keys[None, :]
            d2[sized] = np.inf
        return d2, sized

    def _candidates(self, table: TargetTable, t_ais: float, cam, ta: TrackAngles):
        st, tg = self._targets(table, t_ais, cam)
        return st, tg, self._distance(ta, st, tg)[0]

    def _frame_align(self, ids: np.ndarray, ta: TrackAngles, st, tg) -> None:
        """Remove this frame's common elevation error (a swaying or jittering camera).

        The residuals ``el_AIS - el_camera`` of the tracks that held an identity at the previous
        frame are common to all tracks when the camera moves; each track is shifted by the median
        residual of the *other* identified tracks (leave-one-out, so a track never corrects
        itself), when there are at least ``frame_align_min_pairs`` (>= 2) of them.
        """
        k_min = max(2, self.settings.frame_align_min_pairs) if self.settings.frame_align_min_pairs > 0 else 0
        assigned = self.assoc.assigned
        if k_min <= 0 or len(assigned) < k_min or not len(st):
            self.frame_el_offset_deg = 0.0
            return
        prev = np.array([assigned.get(t, -1) for t in ids.tolist()], np.int64)
        jj = index_of(st.keys, prev)
        ii = np.flatnonzero(jj >= 0)
        if len(ii) < k_min:
            self.frame_el_offset_deg = 0.0
            return
        res = tg.el_deg[jj[ii]] - ta.el_deg[ii]
        off = np.full(len(ids), float(np.median(res)))
        m = np.tile(res, (len(ii), 1))  # identified tracks: the median of the others
        np.fill_diagonal(m, np.nan)
        off[ii] = np.nanmedian(m, axis=1)
        ta.el_deg = ta.el_deg + off
        self.frame_el_offset_deg = float(np.median(res))

    def _calibrate(self, t_ais, ids, ta, st, tg, d2, keys, conf, el_before_align) -> None:
        s = self.settings
        if t_ais - self._calib_last_t < 0.5 and t_ais >= self._calib_last_t:
            return
        self._calib_last_t = t_ais
        g2 = s.gate_sigma ** 2
        jj = index_of(st.keys, keys)
        ii = np.flatnonzero((keys > 0) & (jj >= 0) & (conf > 0.3 * g2))
        if not len(ii):
            return
        jj = jj[ii]
        # unambiguous: no runner-up within the gate, in either direction
        near = d2 < g2
        ok = (near[ii].sum(axis=1) <= 1) & (near[:, jj].sum(axis=0) <= 1) & near[ii, jj]
        ii, jj = ii[ok], jj[ok]
        raw_az = ta.az_deg[ii] - self.calib.pan_offset_deg
        raw_el = el_before_align[ii] - self.calib.tilt_offset_deg
        daz = angle_diff_deg(tg.az_deg[jj], raw_az)
        del_ = tg.el_deg[jj] - raw_el
        # per-vessel systematic variances (what does not average out over frames): the AIS antenna
        # is anywhere along the hull (uniform over the box's half-width), the AIS position error
        # seen at the vessel's range, and a small waterline / range error
        pos_m = s.pos_sigma_m + st.speed_mps[jj] * s.ais_latency_s
        pos = np.degrees(pos_m / np.maximum(tg.range_m[jj], 1.0))
        w_az = 1.0 / (0.1 ** 2 + ta.half_width_deg[ii] ** 2 / 3.0 + pos ** 2)
        w_el = 1.0 / (0.05 ** 2 + (0.05 * tg.el_deg[jj]) ** 2 + (tg.del_dr[jj] * pos_m) ** 2)
        for c, i in enumerate(ii.tolist()):
            self.calib.add(t_ais, (int(ids[i]), int(keys[i])), float(daz[c]), float(del_[c]), float(w_az[c]),
                           float(w_el[c]))
        self.calib.estimate()

    def _ground_velocity(self, cam, tracks: Tracks) -> np.ndarray:
        """Camera tracks' sea-surface velocity (east, north) m/s in the nominal camera frame."""
        u, v = waterline_px(tracks.boxes)
        vel = tracks.velocities
        e, nn, _ = cam.pixel_to_sea_enu(np.concatenate([u, u + vel[:, 0]]), np.concatenate([v, v + vel[:, 1]]))
        m = len(u)
        return np.stack([e[m:] - e[:m], nn[m:] - nn[:m]], axis=1)

    def _record_positions(self, t_ais, cam, tracks: Tracks) -> None:
        """Keep each track's waterline sea position (nominal camera frame) for its velocity."""
        if len(tracks) == 0:
            return
        e, nn, _ = cam.pixel_to_sea_enu(*waterline_px(tracks.boxes))
        for tid, ee, en in zip(tracks.ids.tolist(), e.tolist(), nn.tolist()):
            h = self._track_pos.get(tid)
            if h is None:
                h = self._track_pos[tid] = deque(maxlen=64)
                self._born.setdefault(tid, t_ais)
            if math.isfinite(ee) and math.isfinite(en) and (not h or t_ais - h[-1][0] >= 0.2):
                h.append((t_ais, ee, en))
        if len(self._track_pos) > 4 * max(len(tracks), 16):
            live = set(tracks.ids.tolist())
            for tid in [k for k, h in self._track_pos.items() if k not in live and (not h or t_ais - h[-1][0] > 60)]:
                del self._track_pos[tid]
                self._born.pop(tid, None)

    def track_velocity(self, tid: int, t_s: float | None = None, window_s: float | None = None) -> np.ndarray:
        """Least-squares sea-surface velocity (east, north) m/s of a camera track over the last
        ``window_s`` (default ``fusion.window_s``), in the nominal camera frame; NaN when the
        track has fewer than 3 positions spanning 2 s."""
        h = self._track_pos.get(int(tid))
        if not h:
            return np.full(2, np.nan)
        key = (int(tid), window_s)
        hit = self._vel_cache.get(key)
        if hit is not None and t_s is not None and 0 <= t_s - hit[0] < 1.0:
            return hit[1]
        a = np.asarray(h)
        t_end = a[-1, 0] if t_s is None else t_s
        a = a[a[:, 0] >= t_end - (self.settings.window_s if window_s is None else window_s)]
        if len(a) < 3 or a[-1, 0] - a[0, 0] < 2.0:
            return np.full(2, np.nan)
        tt = a[:, 0] - a[:, 0].mean()
        den = float(np.sum(tt * tt))
        vel = np.array([np.sum(tt * (a[:, 1] - a[:, 1].mean())) / den, np.sum(tt * (a[:, 2] - a[:, 2].mean())) / den])
        if t_s is not None:
            if len(self._vel_cache) > 4096:
                self._vel_cache.clear()
            self._vel_cache[key] = (t_s, vel)
        return vel

    def track_speed(self, tid: int, t_s: float | None = None) -> tuple[float, float, float, float]:
        """Sea-surface speed (m/s) of a camera track, its cross-range part, and their standard errors.

        A least-squares line through the track's waterline positions over the last
        ``fusion.window_s`` (as :meth:`track_velocity`), standard errors from the fit's residuals.
        The cross-range part (perpendicular to the line of sight) comes from the bearing rate,
        which a camera measures well; the range part comes from the box's bottom edge, which a
        changing box shape biases (one pixel is tens of metres of range at a kilometre).

        Returns
        -------
        speed, speed_se, cross_speed, cross_se : float
            NaN with fewer than 4 positions spanning 2 s.
        """
        nan = float("nan")
        h = self._track_pos.get(int(tid))
        if not h or len(h) < 4:
            return nan, nan, nan, nan
        a = np.asarray(h)
        t_end = a[-1, 0] if t_s is None else t_s
        a = a[a[:, 0] >= t_end - self.settings.window_s]
        if len(a) < 4 or a[-1, 0] - a[0, 0] < 2.0:
            return nan, nan, nan, nan
        tt = a[:, 0] - a[:, 0].mean()
        den = float(np.sum(tt * tt))
        mean = a[:, 1:3].mean(axis=0)
        xy = a[:, 1:3] - mean
        # line-of-sight frame at the mean position: (cross-range, range)
        r = float(np.hypot(mean[0], mean[1]))
        ur = mean / r if r > 0 else np.array([0.0, 1.0])
        uc = np.array([ur[1], -ur[0]])
        comp = np.stack([xy @ uc, xy @ ur], axis=1)
        v = (tt @ comp) / den
        res = comp - tt[:, None] * v[None, :]
        var = np.sum(res * res, axis=0) / (len(a) - 2) / den  # variance of each slope
        sp = float(math.hypot(v[0], v[1]))
        se = float(math.sqrt((v[0] ** 2 * var[0] + v[1] ** 2 * var[1]) / sp ** 2)) if sp > 0 else float(
            math.sqrt(var.sum()))
        return sp, se, float(abs(v[0])), float(math.sqrt(var[0]))

    def _theta_update(self, t_ais, cam, tracks, ta, st, tg, d2, keys) -> None:
        """Collect velocity pairs for the paper's theta (rotation camera -> VTS/AIS frame)."""
        if len(tracks) == 0 or len(st) == 0 or t_ais - self._theta_last_t < 1.0:
            return
        self._theta_last_t = t_ais
        cv = np.array([self.track_velocity(tid, t_ais) for tid in tracks.ids.tolist()]).reshape(-1, 2)
        ok = np.isfinite(cv).all(axis=1) & (tracks.states != int(TrackState.TENTATIVE))
        av = np.stack([st.ve_mps, st.vn_mps], axis=1)
        col = {int(k): j for j, k in enumerate(st.keys.tolist())}
        for i, k in enumerate(keys.tolist()):
            j = col.get(k)
            if k and j is not None and ok[i]:
                self._theta_pairs.append((cv[i], av[j]))
        if ok.any():
            mask = np.isfinite(d2[ok]) & (d2[ok] < 1e6)  # loose (azimuth) position gate
            self._theta_frames.append((cv[ok], av, mask))
        if len(self._theta_pairs) >= 5:
            c = np.array([p[0] for p in self._theta_pairs])
            a = np.array([p[1] for p in self._theta_pairs])
            self.theta = estimate_theta_robust(c, a)

    def calibrate_theta(self, theta0_deg: float | None = None, seed: int = 0, **kwargs) -> float:
        """Run the paper's policy-gradient calibration of theta on the collected velocity frames."""
        frames = list(self._theta_frames)
        if not frames:
            return float("nan")
        th, _ = calibrate_theta_pg(frames, self.settings.theta0_deg if theta0_deg is None else theta0_deg,
                                   seed=seed, **kwargs)
        self.theta_pg_deg = float(th)
        return self.theta_pg_deg

    # ---------------------------------------------------------------- outputs
    def _world(self, cam, ta, st, tg, keys, vst, vkeys, tracks) -> np.ndarray:
        """lat, lon, speed, course per track: camera bearing with the AIS/VTS range when matched,
        the camera's sea-surface intersection otherwise."""
        n = len(keys)
        e = ta.e_m.copy()
        nn = ta.n_m.copy()
        gv = self._ground_velocity(cam, tracks) if n else np.zeros((0, 2))
        sp = np.hypot(gv[:, 0], gv[:, 1]) if n else np.zeros(0)
        co = np.degrees(np.arctan2(gv[:, 0], gv[:, 1])) % 360.0 if n else np.zeros(0)
        for table_st, kk in ((vst, vkeys), (st, keys)):  # AIS last: it wins
            if table_st is None or not np.any(kk):
                continue
            col = {int(k): j for j, k in enumerate(table_st.keys.tolist())}
            ii = np.flatnonzero(kk)
            jj = np.array([col.get(int(kk[i]), -1) for i in ii], np.int64)
            ok = jj >= 0
            ii, jj = ii[ok], jj[ok]
            r = np.hypot(table_st.e_m[jj], table_st.n_m[jj])
            a = np.radians(ta.az_deg[ii])
            e[ii], nn[ii] = r * np.sin(a), r * np.cos(a)
            sp[ii] = np.hypot(table_st.ve_mps[jj], table_st.vn_mps[jj])
            co[ii] = np.degrees(np.arctan2(table_st.ve_mps[jj], table_st.vn_mps[jj])) % 360.0
        world = np.full((n, 4), np.nan)
        if n:
            ok = np.isfinite(e) & np.isfinite(nn)
            lat, lon = self.ais.to_geodetic(np.nan_to_num(e), np.nan_to_num(nn))
            world[:, 0] = np.where(ok, lat, np.nan)
            world[:, 1] = np.where(ok, lon, np.nan)
            world[:, 2] = sp
            world[:, 3] = co
        return world

    def _picture(self, t, t_ais, out: Tracks, keys, st, vst, vkeys) -> list[FusedTrack]:
        pic: list[FusedTrack] = []
        conf = out.states != int(TrackState.TENTATIVE)
        for i in np.flatnonzero(conf).tolist():
            k = int(keys[i])
            src = ("camera",) + (("ais",) if k else ()) + (("radar",) if vkeys[i] else ())
            stat = self.ais.static_of(k) if k else {"name": None, "ship_type": None}
            w = out.world[i]
            b = out.boxes[i]
            pic.append(FusedTrack(int(out.ids[i]), t, float(w[0]), float(w[1]), float(w[2]), float(w[3]),
                                  int(out.ids[i]), (float(b[0]), float(b[1]), float(b[2]), float(b[3])), k,
                                  stat["name"], stat["ship_type"], src))
        seen = {int(k) for k in keys.tolist() if k}
        # AIS vessels not seen by the camera (occluded or out of view) stay on the picture
        full = self.ais.states_at(t_ais)
        if len(full):
            rest = np.array([int(k) not in seen for k in full.keys.tolist()], bool)
            if rest.any():
                sub = full.subset(rest)
                lat, lon = self.ais.to_geodetic(sub.e_m, sub.n_m)
                sp, co = sub.speed_mps, sub.course_deg
                for j, k in enumerate(sub.keys.tolist()):
                    stat = self.ais.static_of(k)
                    pic.append(FusedTrack(-int(k), t, float(lat[j]), float(lon[j]), float(sp[j]), float(co[j]),
                                          None, None, int(k), stat["name"], stat["ship_type"], ("ais",)))
        if vst is not None and len(vst):
            vseen = {int(k) for k in vkeys.tolist() if k}
            lat, lon = self.vts.to_geodetic(vst.e_m, vst.n_m)
            for j, k in enumerate(vst.keys.tolist()):
                if int(k) in vseen:
                    continue
                pic.append(FusedTrack(-(10 ** 10 + int(k)), t, float(lat[j]), float(lon[j]), float(vst.speed_mps[j]),
                                      float(vst.course_deg[j]), None, None, 0, None, None, ("radar",)))
        return pic

    def picture(self) -> list[FusedTrack]:
        """The fused picture of the latest update: every confirmed camera track (with its MMSI,
        name and type when identified) plus the AIS and radar vessels the camera does not see.

        Ids: camera tracks keep their id; AIS-only vessels have ``-mmsi``; radar-only tracks
        ``-(10**10 + radar id)``.
        """
        if self._last is None:
            return []
        t, t_ais, out, keys, vst, vkeys = self._last
        return self._picture(t, t_ais, out, keys, None, vst, vkeys)

    # ----------------------------------------------------------------- alerts
    def _alerts(self, t, t_ais, dt, cam, tracks, ta, st, tg, d2, keys, vkeys, world) -> list[Alert]:
        s = self.settings
        out: list[Alert] = []
        g2 = s.gate_sigma ** 2
        loose = 4.0 * g2  # twice the association gate
        sized = self._sized
        confirmed = tracks.states != int(TrackState.TENTATIVE)
        ids = tracks.ids.tolist()
        taken = {int(k) for k in keys.tolist() if k}
        col = {int(k): j for j, k in enumerate(st.keys.tolist())}
        # "no AIS" is claimed only when no AIS vessel heard could be this one (see _could_be: a
        # fragment of a long hull's box, or the upper part of a hull, is not a vessel without AIS)
        plausible = self._could_be(ta, st, tg) if len(ids) else np.zeros((0, len(st)), bool)
        unlocated = self._unlocated(t_ais)
        n_intervals = 1 + s.no_ais_lost_reports  # a lost report: the next one comes an interval later
        n_unheard = 1 + s.no_ais_unheard_lost_reports
        for tid in list(self._track_seen):
            if t - self._track_seen[tid] > 60.0:
                for dct in (self._track_seen, self._first_conf, self._last_plausible, self._history, self._spoof_since):
                    dct.pop(tid, None)
                self._no_ais_alerted.discard(tid)
                self._spoof_alerted.discard(tid)
        for i, tid in enumerate(ids):
            self._track_seen[tid] = t
            if not confirmed[i]:
                continue
            self._first_conf.setdefault(tid, t)
            k = int(keys[i])
            # -- identity history (for spoofing of matched vessels)
            if k:
                m0, secs = self._history.get(tid, (k, 0.0))
                self._history[tid] = (k, (secs + dt) if m0 == k else 0.0)
                self._spoof_since.pop(tid, None)
            else:
                hist = self._history.get(tid)
                if hist is not None and hist[1] >= s.min_support_s + s.spoof_dwell_s:
                    j = col.get(hist[0])
                    # a pair removed by the size gate (a box grown by a merge) is not comparable: not far
                    far = j is None or (not sized[i, j] and (not np.isfinite(d2[i, j]) or d2[i, j] > loose))
                    mslot = self.ais.slot(hist[0])
                    reported = mslot is not None and t_ais - self.ais.t[mslot] <= s.ais_max_age_s
                    if far and reported and hist[0] not in taken:
                        since = self._spoof_since.setdefault(tid, t)
                        if t - since >= s.spoof_dwell_s and tid not in self._spoof_alerted:
                            self._spoof_alerted.add(tid)
                            pos = self.ais.state_of(hist[0], t_ais)
                            msg = (f"possible spoofing: MMSI {hist[0]} was matched to camera track {tid} but its AIS "
                                   f"position has left the camera bearing {ta.az_deg[i]:.1f} deg for "
                                   f"{t - since:.0f} s")
                            out.append(self._alert(t, "possible_spoofing", msg, tid, hist[0],
                                                   pos[0] if pos else np.nan, pos[1] if pos else np.nan,
                                                   ta.az_deg[i]))
                    else:
                        self._spoof_since.pop(tid, None)
            # -- no AIS
            if k:
                self._last_plausible[tid] = t
                self._no_ais_alerted.discard(tid)
                continue
            if not np.isfinite(ta.range_m[i]):  # above the horizon: not a vessel on the sea
                continue
            hist = self._history.get(tid)
            if hist is not None and hist[1] >= s.min_support_s:
                # it had an identity: losing it is the spoofing check's business, not "no AIS"
                continue
            if plausible.shape[1] and plausible[i].any():
                self._last_plausible[tid] = t
            start = max(self._first_conf[tid], self._last_plausible.get(tid, -np.inf))
            if tid in self._no_ais_alerted:
                self._no_ais_last[tid] = (t, float(ta.e_m[i]), float(ta.n_m[i]))
                continue
            # a box a vessel cannot have (e.g. a wave crest right below the camera) is not a vessel
            length_m = 2.0 * math.radians(ta.half_width_deg[i]) * ta.range_m[i]
            if length_m < s.min_vessel_length_m:
                continue
            if t - start < s.no_ais_dwell_s:
                continue
            if self._on_wake(tid, t_ais, cam):
                self._last_plausible[tid] = t  # a patch of another vessel's wake: not (yet) a vessel
                continue
            # an AIS vessel never heard is excluded only once the feed has been live for the
            # reporting interval of a (class A) vessel moving as this one does (one more per lost
            # first report tolerated: no_ais_unheard_lost_reports), plus the latency
            # (at the lower bound of its speed: a slower vessel reports less often; the cross-range
            # speed, from the bearing rate, is a lower bound that a drifting box bottom does not inflate)
            speed, _, cross, cross_se = self.track_speed(tid, t_ais)
            v_low = max(cross - 2.0 * cross_se, 0.0) if np.isfinite(cross_se) else np.nan
            need_s = n_unheard * ais_report_interval_s(v_low, "A")
            live_s = -np.inf if self._ais_since is None else t_ais - self._ais_since
            if live_s < max(need_s + s.ais_latency_s, s.ais_warmup_s):
                continue
            # a class A vessel heard without a position (static data only) could be this one until
            # its position reports, at the class A rate for this speed and allowing for lost ones,
            # are due -- for at most no_ais_unlocated_hold_s after it was first heard.  Class B
            # ones are named in the alert but not waited for (as in the interval rule above)
            # (an MMSI heard without a position for longer than that, e.g. a vessel without GNSS
            # fix for minutes, is named but no longer held)
            if unlocated and any(t_ais < t0 + min(n_intervals * ais_report_interval_s(v_low, "A") + s.ais_latency_s,
                                                  s.no_ais_unlocated_hold_s) for _, t0, cls in unlocated if cls == "A"):
                continue
            self._no_ais_alerted.add(tid)
            self._no_ais_last[tid] = (t, float(ta.e_m[i]), float(ta.n_m[i]))
            if self._inherits_no_ais(tid, t, float(ta.e_m[i]), float(ta.n_m[i])):
                continue  # a new track of a vessel already flagged: no second alert
            msg = (f"no AIS: camera track {tid} at bearing {ta.az_deg[i]:.1f} deg, range {ta.range_m[i]:.0f} m, "
                   f"{speed * KN_PER_MPS:.0f} kn, has no AIS counterpart for {t - start:.0f} s "
                   f"(AIS feed live {live_s:.0f} s")
            need_b = ais_report_interval_s(speed, "B")
            msg += ")" if live_s >= need_b + s.ais_latency_s else (
                f"; a class B transponder, reporting every {need_b:.0f} s, is not yet excluded)")
            if unlocated:
                msg += "; heard without a position: " + ", ".join(
                    f"MMSI {m} (class {cls}, since {t_ais - t0:.0f} s)" for m, t0, cls in unlocated[:3]) + (
                    f" and {len(unlocated) - 3} more" if len(unlocated) > 3 else "")
            out.append(self._alert(t, "no_ais", msg, tid, 0, world[i, 0], world[i, 1], ta.az_deg[i]))
        # -- AIS in view but not seen
        if len(st):
            out.extend(self._unseen_alerts(t, t_ais, dt, cam, tracks, ta, st, tg, keys, confirmed))
        return out

    def _unlocated(self, t_ais: float) -> list[tuple[int, float, str]]:
        """MMSIs heard within ``ais_max_age_s`` that have no usable position (none, or none
        younger than ``ais_max_age_s``): ``(mmsi, AIS-clock time first heard, class "A"/"B")``,
        oldest first.  A report time-stamped after the frame (a live feed's processing lag)
        counts."""
        if not self._heard:
            return []
        out = [(m, t0, cls) for m, (t0, t1, cls) in self._heard.items() if t_ais - t1 <= self.settings.ais_max_age_s]
        return sorted(out, key=lambda x: x[1])

    def _could_be(self, ta: TrackAngles, st, tg) -> np.ndarray:
        """(N, M) whether AIS vessel j could be what camera track i shows (its hull, or part of it).

        In azimuth: within ``gate_deg`` of the box's extent, widened by the vessel's reported
        length seen at its range (the antenna may be anywhere on the hull, and a detector box
        may cover only part of a long vessel).  In range: the waterline ranges agree within a
        factor ``no_ais_range_ratio``, or the vessel's waterline lies below the box's bottom by
        at most the box's angular height (a box covering only the upper part of a hull, whose
        bottom is then above the waterline) or above it by at most ``sigma_el_deg``.
        """
        s = self.settings
        if not len(st):
            return np.zeros((len(ta.az_deg), 0), bool)
        hull = np.where(np.isfinite(st.length_m), np.degrees(np.arctan2(np.nan_to_num(st.length_m),
                                                                         np.maximum(tg.range_m, 1.0))), 0.0)
        daz = (np.abs(angle_diff_deg(ta.az_deg[:, None], tg.az_deg[None, :])) - ta.half_width_deg[:, None]
               - hull[None, :])
        with np.errstate(invalid="ignore", divide="ignore"):
            lr = np.abs(np.log(ta.range_m[:, None] / np.maximum(tg.range_m[None, :], 1.0)))
        h = 2.0 * (ta.half_height_deg if ta.half_height_deg is not None else np.zeros_like(ta.el_deg))
        de = tg.el_deg[None, :] - ta.el_deg[:, None]
        el_ok = (de >= -h[:, None] - s.sigma_el_deg) & (de <= s.sigma_el_deg)
        return (daz <= s.gate_deg) & ((lr <= math.log(s.no_ais_range_ratio)) | ~np.isfinite(lr) | el_ok)

    def _on_wake(self, tid: int, t_ais: float, cam) -> bool:
        """Whether a track was born, and still is, on the recent trail of an older confirmed track.

        A vessel leaves a wake (a turning one a patch of foam) that a background-subtraction
        detector tracks as a new object where the vessel was a few seconds earlier.  A track
        born after another confirmed track passed its position, within the last
        ``fusion.wake_s``, is taken as that vessel's wake while it stays on the trail (within 10 m
        plus the range error of 2 pixels of waterline).
        """
        s = self.settings
        h = self._track_pos.get(tid)
        born = self._born.get(tid)
        if s.wake_s <= 0 or not h or born is None:
            return False
        _, e, n = h[-1]
        r = math.hypot(e, n)
        tol = 10.0 + 2.0 * r * r / max(cam.pose.height_m * cam.intrinsics.fy, 1e-9)
        if self._trail is None or self._trail[0] != t_ais:  # every confirmed track's recent trail, once a frame
            rows = [(tt, ee, nn, self._born.get(other, np.inf), other) for other, oh in self._track_pos.items()
                    if other in self._first_conf for tt, ee, nn in oh if tt >= t_ais - s.wake_s]
            self._trail = (t_ais, np.array(rows, float).reshape(-1, 5))
        a = self._trail[1]
        m = (a[:, 4] != tid) & (a[:, 3] < born) & (a[:, 0] <= born)
        return bool(np.any(m & (np.hypot(a[:, 1] - e, a[:, 2] - n) <= tol)))

    def _inherits_no_ais(self, tid: int, t: float, e: float, n: float) -> bool:
        """Whether a flagged track ended (or is) near here recently: the same vessel, re-tracked.

        Near: within 30 m, plus 10 m/s of travel over the gap, plus the waterline range error
        (``range_frac`` of the range; positions east/north are relative to the camera).
        """
        frac = self.settings.range_frac
        for other, (t0, e0, n0) in list(self._no_ais_last.items()):
            if other == tid:
                continue
            gap = t - t0
            if gap > 60.0:
                del self._no_ais_last[other]
                continue
            tol = 30.0 + 10.0 * gap + frac * max(math.hypot(e, n), math.hypot(e0, n0))
            if math.hypot(e - e0, n - n0) <= tol:
                return True
        return False

    def _unseen_alerts(self, t, t_ais, dt, cam, tracks, ta, st, tg, keys, confirmed) -> list[Alert]:
        s = self.settings
        out: list[Alert] = []
        off_p, off_t = self.calib.pan_offset_deg, self.calib.tilt_offset_deg
        u, v, front = cam.azel_to_pixel(tg.az_deg - off_p, tg.el_deg - off_t)
        length = np.where(np.isfinite(st.length_m), st.length_m, 10.0)
        size_px = length * cam.intrinsics.fx / np.maximum(tg.range_m, 1.0)
        horizon_m = math.sqrt(2.0 * cam.r_eff_m * cam.pose.height_m)
        visible = (front & cam.in_image(u, v, margin_px=-10.0) & (tg.range_m <= s.max_visible_range_m)
                   & (tg.range_m < horizon_m) & (size_px >= s.min_visible_px))
        seen = {int(k) for k in keys.tolist() if k}
        for k in seen:
            self._unseen_alerted.discard(k)
        # occlusion: inside the azimuth extent of any camera track (a nearer vessel may hide it)
        cand = visible.copy()
        if len(tracks) and cand.any():
            daz = np.abs(angle_diff_deg(tg.az_deg[None, :], ta.az_deg[:, None])) - ta.half_width_deg[:, None]
            cand &= ~(daz <= s.sigma_az_deg).any(axis=0)
        if seen and cand.any():
            cand &= ~np.isin(st.keys, np.fromiter(seen, np.int64))
        cj = np.flatnonzero(cand)
        ckeys = st.keys[cj].tolist()
        keep = set(ckeys)
        for k in [k for k in self._unseen_since if k not in keep]:
            del self._unseen_since[k]
        if not len(cj):
            return out
        unmatched = [i for i in range(len(tracks)) if confirmed[i] and not keys[i] and np.isfinite(ta.range_m[i])]
        cost = None
        if unmatched:
            # an unseen AIS vessel that moves like an unidentified camera vessel: position spoofed?
            gv = np.array([self.track_velocity(int(tracks.ids[i]), t_ais) for i in unmatched]).reshape(-1, 2)
            th = self.theta.theta_deg if np.isfinite(self.theta.theta_deg) else 0.0
            cost = velocity_cost(np.nan_to_num(gv, nan=1e6), np.stack([st.ve_mps[cj], st.vn_mps[cj]], axis=1), th)
        for c, (j, k) in enumerate(zip(cj.tolist(), ckeys)):
            since = self._unseen_since.setdefault(k, t)
            if t - since >= s.ais_unseen_dwell_s and k not in self._unseen_alerted:
                self._unseen_alerted.add(k)
                lat, lon = self.ais.to_geodetic(st.e_m[j], st.n_m[j])
                name = self.ais.names[st.slots[j]]
                label = f"MMSI {k}" + (f" ({name})" if name else "")
                msg = (f"AIS not seen: {label} reported {tg.range_m[j]:.0f} m away at bearing {tg.az_deg[j]:.1f} deg, "
                       f"inside the camera view, not seen for {t - since:.0f} s")
                out.append(self._alert(t, "ais_not_seen", msg, None, k, float(lat), float(lon), tg.az_deg[j]))
            if cost is None or math.hypot(st.ve_mps[j], st.vn_mps[j]) < 1.0:
                continue
            best = int(np.argmin(cost[:, c]))
            i = unmatched[best]
            pair = (int(tracks.ids[i]), k)
            if cost[best, c] < 0.35:
                sp0 = self._motion_spoof_since.setdefault(pair, t)
                if (t - sp0 >= s.spoof_dwell_s and k not in self._spoof_alerted
                        and t - since >= s.ais_unseen_dwell_s):
                    self._spoof_alerted.add(k)
                    lat, lon = self.ais.to_geodetic(st.e_m[j], st.n_m[j])
                    msg = (f"possible spoofing: MMSI {k} reports a position {tg.range_m[j]:.0f} m away at bearing "
                           f"{tg.az_deg[j]:.1f} deg where the camera sees nothing, while unidentified camera "
                           f"track {pair[0]} at bearing {ta.az_deg[i]:.1f} deg moves like it")
                    out.append(self._alert(t, "possible_spoofing", msg, pair[0], k, float(lat), float(lon),
                                           ta.az_deg[i]))
            else:
                self._motion_spoof_since.pop(pair, None)
        return out

    def _alert(self, t, kind, msg, tid, mmsi, lat, lon, az) -> Alert:
        self.n_alerts[kind] = self.n_alerts.get(kind, 0) + 1
        return Alert(float(t), kind, msg, self.camera_id, None if tid is None else int(tid), int(mmsi),
                     float(lat), float(lon), float(az))

    # ----------------------------------------------------------------- reports
    @property
    def calibration(self) -> dict:
        """Self-calibration state: heading/tilt offsets with standard errors, and theta (paper)."""
        d = self.calib.as_dict()
        d.update({"theta_robust_deg": self.theta.theta_deg, "theta_robust_sigma_deg": self.theta.sigma_deg,
                  "theta_pairs": self.theta.n_inliers, "theta_pg_deg": self.theta_pg_deg})
        return d

    def summary(self) -> dict:
        """Counts for a run summary."""
        return {
            "updates": self.n_updates,
            "ais_targets": len(self.ais),
            "radar_targets": len(self.vts),
            "alerts": dict(self.n_alerts),
            "calibration": self.calibration,
            "ais_input": None if self.ais_stats is None else self.ais_stats.as_dict(),
        }

