"""Camera / AIS fusion: identity accuracy on FVessel clip-01, the simulator's harbour end to end,
fusion speed, and AIS replay speed on the Solent data.

FVessel clip-01
    The ground-truth tracking boxes (one per vessel per second, seconds 2-110) are the camera
    tracks, degraded at stated rates: box position noise (``NOISE_FRAC`` of the box size per
    coordinate, Gaussian), dropouts (each track-second missing with probability ``DROPOUT``) and
    identity switches (each track-second, with probability ``IDSW_RATE``, the track continues under
    a new id).  Video second ``s`` is Unix time ``T0_UNIX_S + s``: the clip's video file is named
    ``2022_06_04_12_05_12_12_07_02_b.mp4`` (start 12:05:12, end 12:07:02 local time, UTC+8, i.e.
    110 s, matching the ground truth's seconds 2-110), and DeepSORVF reads the AIS snapshot named
    by the same local time at each video second.  AIS reports are released to the fuser only once
    their time stamp is reached.  Figures: the fraction of ground-truth vessel-seconds whose camera
    track carries the correct MMSI (over the seconds the degraded tracker outputs the vessel, and
    over all), and the fraction carrying a wrong MMSI; mean over ``SEEDS`` seeds.

Speed
    One :meth:`Fuser.update` with 200 AIS vessels (all in the field of view) and 50 camera tracks,
    median CPU time (``time.process_time``) of repeats on one core, beside a naive per-pair Python loop computing the same
    geometric cost matrix (the peer).  Solent: the 84-minute file replayed through the AIS track
    table in 1-second steps (reports added, every vessel dead-reckoned to each step), vs real time
    (CPU time of the replay).
"""

from __future__ import annotations

import math
import time

import numpy as np

NAME = "fusion"
DESCRIPTION = "AIS fusion: FVessel clip-01 MMSI accuracy, harbour end to end, update and Solent replay speed"

T0_UNIX_S = 1654315512.0  # 2022-06-04 12:05:12 UTC+8: video start of FVessel clip-01
NOISE_FRAC = 0.03
DROPOUT = 0.05
IDSW_RATE = 0.01
SEEDS = (0, 1, 2, 3, 4)


# ----------------------------------------------------------------------------- FVessel
def _fvessel_tracks(gt_track: np.ndarray, gt_fusion: np.ndarray, seed: int, noise_frac: float,
                    dropout: float, idsw_rate: float):
    """Per second: (t, ids, boxes, velocities, ages, true mmsi, n_gt) of degraded ground-truth tracks."""
    rng = np.random.default_rng(seed)
    seconds = np.unique(gt_track[:, 0]).astype(int)
    # ground-truth id -> mmsi through identical boxes of the same second
    mm = {}
    for r in gt_track:
        same = gt_fusion[(gt_fusion[:, 0] == r[0]) & np.all(np.isclose(gt_fusion[:, 2:6], r[2:6]), axis=1)]
        if len(same):
            mm[(int(r[0]), int(r[1]))] = int(same[0, 1])
    cur_id = {}
    born = {}
    next_id = 100
    prev_centre = {}
    out = []
    for s in seconds:
        rows = gt_track[gt_track[:, 0] == s]
        ids, boxes, vels, ages, truth = [], [], [], [], []
        for r in rows:
            gid = int(r[1])
            if gid not in cur_id or rng.random() < idsw_rate:
                cur_id[gid] = next_id
                born[next_id] = s
                next_id += 1
            if rng.random() < dropout:
                continue
            x, y, w, h = r[2:6]
            b = np.array([x + rng.normal(0, noise_frac * w), y + rng.normal(0, noise_frac * h), w, h])
            tid = cur_id[gid]
            c = np.array([b[0] + w / 2, b[1] + h / 2])
            pc = prev_centre.get(tid)
            v = (c - pc[1]) / max(s - pc[0], 1) if pc is not None else np.zeros(2)
            prev_centre[tid] = (s, c)
            ids.append(tid)
            boxes.append(b)
            vels.append(v)
            ages.append(float(s - born[tid]))
            truth.append(mm.get((int(s), gid), 0))
        out.append((float(s), np.array(ids, np.int64), np.array(boxes).reshape(-1, 4), np.array(vels).reshape(-1, 2),
                    np.array(ages), np.array(truth, np.int64), len(rows)))
    return out


def fvessel_run(root, seed: int = 0, noise_frac: float = NOISE_FRAC, dropout: float = DROPOUT,
                idsw_rate: float = IDSW_RATE, settings=None):
    """Run the fuser over FVessel clip-01; returns (correct, wrong, tracked, total, fuser)."""
    from seawatch.camera import load_fvessel_camera
    from seawatch.config import FusionSettings
    from seawatch.fuse import Fuser
    from seawatch.io.ais import read_fvessel_ais
    from seawatch.types import Tracks

    cam = load_fvessel_camera(root / "camera_para.txt")
    reps, _ = read_fvessel_ais(root / "ais")
    gt_track = np.loadtxt(root / "gt" / "clip-01_gt_tracking.txt", delimiter=",", ndmin=2)
    gt_fusion = np.loadtxt(root / "gt" / "clip-01_gt_fusion.txt", delimiter=",", ndmin=2)
    s = settings or FusionSettings(ais_time_offset_s=T0_UNIX_S)
    fuser = Fuser(cam, s, ais=reps)
    correct = wrong = tracked = total = 0
    for t, ids, boxes, vels, ages, truth, n_gt in _fvessel_tracks(gt_track, gt_fusion, seed, noise_frac, dropout, idsw_rate):
        out, _ = fuser.update(Tracks(t, int(t), ids, boxes, vels, ages_s=ages), None, t)
        total += n_gt
        tracked += len(ids)
        correct += int(np.sum((out.mmsi == truth) & (truth > 0)))
        wrong += int(np.sum((out.mmsi != truth) & (out.mmsi > 0)))
    return correct, wrong, tracked, total, fuser


def _bench_fvessel(ctx) -> None:
    root = ctx.data("fvessel_clip01")
    seeds = SEEDS[:2] if ctx.quick else SEEDS
    for label, nf, dp, sw in (("gt_boxes_clean", 0.0, 0.0, 0.0), ("gt_boxes_degraded", NOISE_FRAC, DROPOUT, IDSW_RATE)):
        res = [fvessel_run(root, sd, nf, dp, sw) for sd in (seeds if label.endswith("degraded") else (0,))]
        c = np.array([r[0] for r in res], float)
        w = np.array([r[1] for r in res], float)
        tr = np.array([r[2] for r in res], float)
        tot = np.array([r[3] for r in res], float)
        extra = {"noise_frac": nf, "dropout": dp, "idsw_rate_per_track_s": sw, "seeds": len(res)}
        ctx.record("fvessel_clip01", label, "correct_mmsi_frac_tracked", float(np.mean(c / tr)), "fraction",
                   target=0.95, **extra)
        ctx.record("fvessel_clip01", label, "correct_mmsi_frac_all", float(np.mean(c / tot)), "fraction", **extra)
        ctx.record("fvessel_clip01", label, "wrong_mmsi_frac", float(np.mean(w / tr)), "fraction", target=0.02,
                   **extra)
        cal = res[0][4].calibration
        if label.endswith("clean"):
            f = res[0][4]
            th = f.calibrate_theta(seed=0)
            ctx.record("fvessel_clip01", "self_calibration", "pan_offset_deg", cal["pan_offset_deg"], "deg",
                       sigma=cal["pan_sigma_deg"], n=cal["n_samples"])
            ctx.record("fvessel_clip01", "self_calibration", "tilt_offset_deg", cal["tilt_offset_deg"], "deg",
                       sigma=cal["tilt_sigma_deg"], n=cal["n_samples"])
            ctx.record("fvessel_clip01", "theta_robust", "theta_deg", cal["theta_robust_deg"], "deg",
                       sigma=cal["theta_robust_sigma_deg"], n=cal["theta_pairs"])
            ctx.record("fvessel_clip01", "theta_policy_gradient", "theta_deg", th, "deg", theta0_deg=15.0)


# ------------------------------------------------------------------------------- speed
def _synthetic_update_case(n_ais: int = 200, n_tracks: int = 50, seed: int = 0):
    from seawatch.camera import CameraModel, Intrinsics
    from seawatch.types import AISReport, CameraPose, Tracks

    rng = np.random.default_rng(seed)
    cam = CameraModel(Intrinsics.from_fov(60.0, 1920, 1080), CameraPose(50.8, -1.1, 25.0, 90.0, -0.8))
    rng_m = rng.uniform(400, 6000, n_ais)
    az = 90.0 + rng.uniform(-28, 28, n_ais)
    e, n = rng_m * np.sin(np.radians(az)), rng_m * np.cos(np.radians(az))
    lat, lon, _ = cam.enu_to_geodetic(e, n, 0.0)
    reps = [AISReport(235000000 + i, -1.0, float(lat[i]), float(lon[i]), float(rng.uniform(0, 15)),
                      float(rng.uniform(0, 360)), msg_type=1) for i in range(n_ais)]
    pick = rng.choice(n_ais, n_tracks, replace=False)
    u, v, _ = cam.enu_to_pixel(e[pick], n[pick], 0.0)
    w = 30.0 * cam.intrinsics.fx / rng_m[pick]
    boxes = np.stack([u - w / 2, v - 0.4 * w, w, 0.4 * w], axis=1)
    tracks = Tracks(0.0, 0, np.arange(1, n_tracks + 1), boxes, rng.normal(0, 2, (n_tracks, 2)))
    return cam, reps, tracks


def _naive_cost(cam, tracks, table, t_s, s):
    """The peer: the same geometric cost, one Python loop iteration per pair."""
    st = table.states_at(t_s)
    n, m = len(tracks), len(st)
    out = [[0.0] * m for _ in range(n)]
    for i in range(n):
        x, y, w, h = tracks.boxes[i]
        az_t, el_t = cam.pixel_to_azel(x + w / 2, y + h)
        azl, _ = cam.pixel_to_azel(x, y + h)
        half = abs(float(az_t) - float(azl))
        for j in range(m):
            e, nn = float(st.e_m[j]), float(st.n_m[j])
            d = math.hypot(e, nn)
            az = math.degrees(math.atan2(e, nn)) % 360.0
            el = math.degrees(math.atan2(-(cam.pose.height_m + d * d / (2 * cam.r_eff_m)), d))
            daz = max(abs((float(az_t) - az + 180) % 360 - 180) - half, 0.0)
            out[i][j] = (daz / s.sigma_az_deg) ** 2 + ((float(el_t) - el) / s.sigma_el_deg) ** 2
    return out


def _bench_speed(ctx) -> None:
    from seawatch.config import FusionSettings
    from seawatch.fuse import Fuser

    cam, reps, tracks = _synthetic_update_case()
    s = FusionSettings()
    fuser = Fuser(cam, s, ais=reps)
    reps_n = 30 if ctx.quick else 200
    times = []
    for k in range(reps_n + 5):
        tracks.t_s = 0.1 * k
        t0 = time.process_time()
        fuser.update(tracks, None, 0.1 * k)
        times.append(time.process_time() - t0)
    ms = float(np.median(times[5:]) * 1000)
    n_in = len(fuser.ais.states_at(0.5))
    ctx.record("synthetic_200ais_50tracks", "Fuser.update", "ms_per_update", ms, "ms", target=5.0,
               ais_vessels=n_in, camera_tracks=len(tracks))
    peer = []
    for _ in range(3 if ctx.quick else 7):
        t0 = time.process_time()
        _naive_cost(cam, tracks, fuser.ais, 0.5, s)
        peer.append(time.process_time() - t0)
    pm = float(np.median(peer) * 1000)
    ctx.record("synthetic_200ais_50tracks", "naive_per_pair_loop_cost_only", "ms_per_update", pm, "ms")
    ctx.record("synthetic_200ais_50tracks", "Fuser.update", "speedup_vs_naive_loop", pm / ms, "x")


def solent_replay(path, step_s: float = 1.0):
    """Replay an AIS CSV through a TargetTable; returns (seconds of data, seconds of wall time, reports, vessels)."""
    from seawatch.fuse import TargetTable
    from seawatch.io.ais import read_ais_csv, reports_to_array

    t0 = time.process_time()
    reps, _ = read_ais_csv(path)
    arr = reports_to_array(reps)
    tab = TargetTable(float(np.median(arr["lat_deg"])), float(np.median(arr["lon_deg"])))
    t = arr["t_s"]
    edges = np.arange(t[0], t[-1] + step_s, step_s)
    idx = np.searchsorted(t, edges, side="right")
    lo = 0
    for te, hi in zip(edges, idx):
        if hi > lo:
            tab.add_array(arr[lo:hi])
            lo = hi
        tab.states_at(float(te))
    wall = time.process_time() - t0
    return float(t[-1] - t[0]), wall, len(arr), len(tab)


def naive_replay(reports, step_s: float = 1.0) -> float:
    """The peer: a dict per vessel, updated and dead-reckoned one vessel at a time in Python."""
    t0 = time.process_time()
    state: dict[int, tuple] = {}
    i, n = 0, len(reports)
    t = reports[0].t_s
    t_end = reports[-1].t_s
    while t <= t_end + step_s:
        while i < n and reports[i].t_s <= t:
            r = reports[i]
            state[r.mmsi] = (r.t_s, r.lat_deg, r.lon_deg, r.sog_kn, r.cog_deg)
            i += 1
        for tr, lat, lon, sog, cog in state.values():
            d = (sog if sog == sog else 0.0) * 0.514444 * (t - tr)
            c = math.radians(cog if cog == cog else 0.0)
            _ = (lat + d * math.cos(c) / 111_132.0, lon + d * math.sin(c) / (111_320.0 * math.cos(math.radians(lat))))
        t += step_s
    return time.process_time() - t0


def _bench_solent(ctx) -> None:
    from seawatch.io.ais import read_ais_csv

    path = ctx.data("ais", "solent_20160112.csv")
    runs = [solent_replay(path) for _ in range(1 if ctx.quick else 3)]
    span, wall, n, nv = runs[0][0], float(np.median([r[1] for r in runs])), runs[0][2], runs[0][3]
    ctx.record("solent_20160112", "read_csv+TargetTable_1s_steps", "replay_speed_vs_real_time", span / wall, "x",
               target=100.0, reports=n, vessels=nv, data_s=span, wall_s=wall)
    t0 = time.process_time()
    reps, _ = read_ais_csv(path)
    t_read = time.process_time() - t0
    table_only = float(np.median([r[1] for r in runs])) - t_read
    peer = float(np.median([naive_replay(reps) for _ in range(1 if ctx.quick else 3)]))
    ctx.record("solent_20160112", "TargetTable_1s_steps(excl_read)", "replay_speed_vs_real_time", span / table_only,
               "x", wall_s=table_only)
    ctx.record("solent_20160112", "naive_python_dict_replay(excl_read)", "replay_speed_vs_real_time", span / peer,
               "x", wall_s=peer)
    ctx.record("solent_20160112", "TargetTable_1s_steps(excl_read)", "speedup_vs_naive_replay", peer / table_only, "x")


# ----------------------------------------------------------------------------- harbour
def _match_tracks(gt, boxes: np.ndarray, min_iou: float = 0.2) -> dict[int, int]:
    """Track row -> ground-truth row (Hungarian on IoU; a track centre inside a small box also counts)."""
    from scipy.optimize import linear_sum_assignment

    g = gt.boxes[gt.visible > 0.05]
    gi = np.flatnonzero(gt.visible > 0.05)
    if not len(g) or not len(boxes):
        return {}
    x1 = np.maximum(boxes[:, None, 0], g[None, :, 0])
    y1 = np.maximum(boxes[:, None, 1], g[None, :, 1])
    x2 = np.minimum(boxes[:, None, 0] + boxes[:, None, 2], g[None, :, 0] + g[None, :, 2])
    y2 = np.minimum(boxes[:, None, 1] + boxes[:, None, 3], g[None, :, 1] + g[None, :, 3])
    inter = np.clip(x2 - x1, 0, None) * np.clip(y2 - y1, 0, None)
    union = boxes[:, None, 2] * boxes[:, None, 3] + g[None, :, 2] * g[None, :, 3] - inter
    iou = inter / np.maximum(union, 1e-9)
    cu = boxes[:, 0] + boxes[:, 2] / 2
    cv = boxes[:, 1] + boxes[:, 3] / 2
    inside = ((cu[:, None] >= g[None, :, 0]) & (cu[:, None] <= g[None, :, 0] + g[None, :, 2])
              & (cv[:, None] >= g[None, :, 1]) & (cv[:, None] <= g[None, :, 1] + g[None, :, 3]))
    score = np.where(inside, np.maximum(iou, min_iou), iou)
    r, c = linear_sum_assignment(-score)
    ok = score[r, c] >= min_iou
    return {int(i): int(gi[j]) for i, j in zip(r[ok], c[ok])}


def scenario_run(name: str, seed: int = 0, oracle: bool = False, duration_s: float | None = None,
                 start_s: float = 0.0, ais_lead_s: float = 0.0, fusion_overrides: dict | None = None):
    """Run a simulator scenario through detector + tracker (or ground-truth boxes when ``oracle``)
    + fusion; returns a dict of figures.  With ``start_s`` > 0 the camera starts that late while
    AIS runs from t = 0 (a fusion centre whose AIS picture is already warm).  With ``ais_lead_s``
    > 0 the scenario's AIS feed is simulated from ``-ais_lead_s`` (same vessels, rates and noise
    model; the vessels' trajectories extended backwards): a feed that has been live that long
    when the camera starts.  ``fusion_overrides``: ``[fusion]`` settings changed for this run."""
    from seawatch.config import load_config
    from seawatch.fuse import Fuser
    from seawatch.sim import make_scenario
    from seawatch.types import Tracks, TrackState

    scn = make_scenario(name, seed=seed, duration_s=duration_s)
    cfg = load_config(overrides=[f"fusion.{k}={v}" for k, v in (fusion_overrides or {}).items()])
    stream = scn.ais_stream()
    if ais_lead_s > 0:
        from seawatch.sim.ais import AISConfig, simulate_ais

        stream = simulate_ais(scn.world, scn.origin[0], scn.origin[1], scn.duration_s + ais_lead_s,
                              scn.ais_config or AISConfig(), scn.ais_seed, t0_s=-ais_lead_s)
    reps = stream.reports
    fuser = Fuser(scn.camera, cfg.fusion, ais=reps, camera_id=scn.camera_id)
    spoof = int(getattr(scn.ais_config, "spoof_mmsi", 0) or 0) if getattr(scn, "ais_config", None) else 0
    spoof_from = float(getattr(scn.ais_config, "spoof_from_s", 0.0)) if spoof else float("nan")
    no_ais_ids = {v.id for v in scn.vessels if not v.mmsi}
    pipe = None
    if not oracle:
        from seawatch.pipeline import Pipeline, build_detector, build_tracker

        det = build_detector(cfg, scn.fps, scn.camera)
        trk = build_tracker(cfg, scn.fps, scn.camera) if cfg.detector.kind != "stable_features" else None
        pipe = Pipeline(det, trk, fuser=fuser, camera=scn.camera)
    n_ais_frames = n_ais_matched = n_correct = n_matched = n_wrong = 0
    t_confirm: dict[int, float] = {}
    track_vessel: dict[int, set] = {}  # track id -> GT vessel ids it covered
    alerts = []
    t_wall = time.perf_counter()
    for frame, gt in scn.iter_frames(start=int(round(start_s * scn.fps))):
        if oracle:
            keep = gt.visible > 0.1
            tr = Tracks(gt.t_s, gt.frame_index, gt.ids[keep], gt.boxes[keep])
            out, al = fuser.update(tr, frame, frame.t_s)
        else:
            res = pipe.step(frame)
            out, al = res.tracks, res.alerts
        alerts += [(frame.t_s, a) for a in al]
        conf = out.states != int(TrackState.TENTATIVE)
        rows = np.flatnonzero(conf)
        m = _match_tracks(gt, out.boxes[rows])
        by_gt = {g: int(rows[r]) for r, g in m.items()}
        for g in np.flatnonzero(gt.visible >= 0.3).tolist():
            vid, mm = int(gt.ids[g]), int(gt.mmsi[g])
            r = by_gt.get(g)
            if r is not None:
                t_confirm.setdefault(vid, frame.t_s)
                track_vessel.setdefault(int(out.ids[r]), set()).add(vid)
            if mm and not (spoof and mm == spoof and frame.t_s >= spoof_from):
                n_ais_frames += 1
                if r is not None:
                    n_ais_matched += 1
                    n_correct += int(out.mmsi[r] == mm)
            if r is not None:
                n_matched += 1
                n_wrong += int(out.mmsi[r] > 0 and out.mmsi[r] != mm)
    wall = time.perf_counter() - t_wall
    # alerts
    flag_t = {}
    false_no_ais = false_other = clutter_no_ais = 0
    false_detail: list[str] = []
    spoof_t = float("nan")
    for t, a in alerts:
        if a.kind == "no_ais":
            vs = track_vessel.get(a.track_id, set())
            hit = vs & no_ais_ids
            if hit:
                for v in hit:
                    flag_t.setdefault(v, t)
            elif not vs:
                clutter_no_ais += 1
                false_detail.append(f"no_ais on clutter track {a.track_id} at {t:.1f} s")
            elif not (spoof and any(scn.vessels[v - 1].mmsi == spoof for v in vs if 0 < v <= len(scn.vessels))):
                false_no_ais += 1
                false_detail.append(f"no_ais on vessel(s) {sorted(vs)} at {t:.1f} s")
        elif a.kind == "possible_spoofing":
            if spoof and a.mmsi == spoof:
                spoof_t = t if spoof_t != spoof_t else spoof_t
            else:
                false_other += 1
                false_detail.append(f"possible_spoofing on MMSI {a.mmsi} at {t:.1f} s")
        elif a.kind == "ais_not_seen":
            if not (spoof and a.mmsi == spoof):
                false_other += 1
                false_detail.append(f"ais_not_seen on MMSI {a.mmsi} at {t:.1f} s")
    hours = scn.duration_s / 3600.0
    ttf = [flag_t[v] - t_confirm[v] for v in no_ais_ids if v in flag_t and v in t_confirm]
    first_spoofed = float("nan")
    if spoof:
        tr = stream.truth
        rx = tr["t_rx_s"][tr["spoofed"]]
        first_spoofed = float(rx.min()) if len(rx) else float("nan")
    return {
        "correct_mmsi_frac_tracked": n_correct / max(n_ais_matched, 1),
        "correct_mmsi_frac_all": n_correct / max(n_ais_frames, 1),
        "wrong_mmsi_frac": n_wrong / max(n_matched, 1),
        "no_ais_flagged": float(len(ttf)), "no_ais_vessels": float(len(no_ais_ids)),
        "time_to_flag_no_ais_s": float(max(ttf)) if ttf else float("nan"),
        "false_no_ais_alerts": float(false_no_ais),
        "no_ais_on_clutter_tracks": float(clutter_no_ais),
        "false_alerts_per_hour": (false_no_ais + false_other + clutter_no_ais) / max(hours - start_s / 3600.0, 1e-9),
        "false_alerts": float(false_no_ais + false_other + clutter_no_ais), "hours": hours - start_s / 3600.0,
        "false_alert_list": false_detail,
        "spoof_flag_delay_s": spoof_t - spoof_from if spoof else float("nan"),
        "spoof_flag_delay_after_first_spoofed_report_s": spoof_t - first_spoofed if spoof else float("nan"),
        "spoof_flagged": float(spoof_t == spoof_t),
        "spoofed": float(bool(spoof)),
        "frames": float(scn.n_frames), "wall_s": wall,
    }


SCENARIO_SEEDS = (0, 1, 2, 3, 4)
# the "no AIS" rule was developed looking at seeds 0-4; these seeds were never looked at before
# their figures were recorded, so they say how the rule carries over
HELDOUT_SEEDS = (5, 6, 7, 8, 9)
#: seeds first run after session 11's ambiguity rule, which held-out seed 8 motivated; seen at
#: development since session 12 (seed 14's false "no AIS" alert motivated rule 3b, seed 10 diagnosed)
HELDOUT2_SEEDS = (10, 11, 12, 13, 14)
#: seeds first run after session 12's "no AIS" rule for MMSIs heard without a position
HELDOUT3_SEEDS = (15, 16, 17, 18, 19)


def _bench_scenarios(ctx) -> None:
    """Seed 0 of each configuration, as before, and for harbour (cold start) the same over
    ``SCENARIO_SEEDS`` (seeds vary positions, the AIS reporting phases, latencies and drops)."""
    try:
        import seawatch.sim  # noqa: F401
    except ImportError as exc:  # pragma: no cover
        ctx.record("harbour", "pipeline+fusion", "not_run", float("nan"), "", reason=str(exc))
        return
    dur = 25.0 if ctx.quick else None
    runs = [("harbour", True, 0.0, 0.0), ("harbour", False, 0.0, 0.0), ("harbour", True, 15.0, 0.0),
            ("harbour", False, 15.0, 0.0), ("harbour", True, 0.0, 300.0), ("harbour", False, 0.0, 300.0),
            ("open_sea", True, 0.0, 0.0), ("open_sea", False, 0.0, 0.0)]
    if not ctx.quick:  # harbour at a cold start on the held-out seeds
        runs += [("harbour", True, 0.0, 0.0, HELDOUT_SEEDS), ("harbour", False, 0.0, 0.0, HELDOUT_SEEDS),
                 ("harbour", True, 0.0, 0.0, HELDOUT2_SEEDS), ("harbour", False, 0.0, 0.0, HELDOUT2_SEEDS),
                 ("harbour", True, 0.0, 0.0, HELDOUT3_SEEDS), ("harbour", False, 0.0, 0.0, HELDOUT3_SEEDS),
                 # the alternative: a lost first report of a vessel never heard tolerated too
                 ("harbour", True, 0.0, 0.0, SCENARIO_SEEDS + HELDOUT_SEEDS, {"no_ais_unheard_lost_reports": 1})]
    for name, oracle, start, lead, *held in runs:
        method = ("gt_boxes+fusion" if oracle else "default_detector+tracker+fusion") + (
            f"_camera_from_{start:.0f}s" if start else "") + (f"_ais_live_{lead:.0f}s_before" if lead else "")
        seeds = SCENARIO_SEEDS if (name == "harbour" and not start and not ctx.quick) else (0,)
        over = held[1] if len(held) > 1 else None
        if held:
            seeds = held[0]
            method += "".join(f"_{k}={v}" for k, v in over.items()) if over else (
                "_heldout_seen_at_development" if seeds == HELDOUT2_SEEDS else "_heldout")
        res = {}
        for sd in seeds:
            try:
                res[sd] = scenario_run(name, sd, oracle, dur, start, lead, over)
            except Exception as exc:  # an unfinished stage must not hide the other figures
                ctx.record(name, method, "not_run", float("nan"), "", reason=f"{type(exc).__name__}: {exc}", seed=sd)
        if 0 in res and not held:
            r = res[0]
            ctx.record(name, method, "correct_mmsi_frac_tracked", r["correct_mmsi_frac_tracked"], "fraction")
            ctx.record(name, method, "correct_mmsi_frac_all", r["correct_mmsi_frac_all"], "fraction")
            ctx.record(name, method, "wrong_mmsi_frac", r["wrong_mmsi_frac"], "fraction", target=0.02)
            ctx.record(name, method, "time_to_flag_no_ais_s", r["time_to_flag_no_ais_s"], "s", target=10.0,
                       flagged=r["no_ais_flagged"], vessels=r["no_ais_vessels"])
            ctx.record(name, method, "false_no_ais_alerts", r["false_no_ais_alerts"], "count", target=0.0)
            ctx.record(name, method, "no_ais_on_clutter_tracks", r["no_ais_on_clutter_tracks"], "count")
            ctx.record(name, method, "false_alerts_per_hour", r["false_alerts_per_hour"], "1/h")
            if r["spoofed"]:
                ctx.record(name, method, "spoof_flag_delay_s", r["spoof_flag_delay_s"], "s",
                           after_first_spoofed_report_s=r["spoof_flag_delay_after_first_spoofed_report_s"])
        if len(res) > 1:
            m = f"{method}_seeds{min(res)}-{max(res)}"
            ttf = [res[k]["time_to_flag_no_ais_s"] for k in sorted(res)]
            fin = [x for x in ttf if x == x]
            hours = sum(res[k]["hours"] for k in res)
            false_all = sum(res[k]["false_alerts"] for k in res)
            extra = {"seeds": sorted(res), "per_seed": [None if x != x else round(x, 2) for x in ttf]}
            ctx.record(name, m, "time_to_flag_no_ais_s_max", max(fin) if len(fin) == len(ttf) else float("nan"), "s",
                       target=10.0, **extra)
            ctx.record(name, m, "time_to_flag_no_ais_s_median", float(np.median(fin)) if fin else float("nan"), "s",
                       **extra)
            ctx.record(name, m, "no_ais_vessel_flagged_frac", len(fin) / len(ttf), "fraction", **extra)
            ctx.record(name, m, "false_no_ais_alerts", sum(res[k]["false_no_ais_alerts"] for k in res), "count",
                       target=0.0, per_seed=[res[k]["false_no_ais_alerts"] for k in sorted(res)])
            ctx.record(name, m, "no_ais_on_clutter_tracks", sum(res[k]["no_ais_on_clutter_tracks"] for k in res),
                       "count", per_seed=[res[k]["no_ais_on_clutter_tracks"] for k in sorted(res)])
            ctx.record(name, m, "false_alerts_per_hour", false_all / hours, "1/h", hours=hours, false_alerts=false_all,
                       which={k: res[k]["false_alert_list"] for k in sorted(res) if res[k]["false_alert_list"]})
            ctx.record(name, m, "correct_mmsi_frac_tracked", float(np.mean([res[k]["correct_mmsi_frac_tracked"]
                                                                            for k in res])), "fraction")
            ctx.record(name, m, "wrong_mmsi_frac", float(max(res[k]["wrong_mmsi_frac"] for k in res)), "fraction",
                       target=0.02, aggregate="max over seeds",
                       per_seed=[round(res[k]["wrong_mmsi_frac"], 4) for k in sorted(res)],
                       correct_per_seed=[round(res[k]["correct_mmsi_frac_tracked"], 4) for k in sorted(res)])
            if next(iter(res.values()))["spoofed"]:
                sp = [res[k]["spoof_flag_delay_s"] for k in sorted(res)]
                sp2 = [res[k]["spoof_flag_delay_after_first_spoofed_report_s"] for k in sorted(res)]
                ok = [x for x in sp if x == x]
                ctx.record(name, m, "spoof_flagged_frac", len(ok) / len(sp), "fraction",
                           per_seed=[None if x != x else round(x, 2) for x in sp],
                           after_first_spoofed_report_s=[None if x != x else round(x, 2) for x in sp2])
                ctx.record(name, m, "spoof_flag_delay_s_median", float(np.median(ok)) if ok else float("nan"), "s")


def run(ctx) -> None:
    import os

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _bench_speed(ctx)
    try:
        _bench_solent(ctx)
    except Exception as exc:  # missing data skips only this part
        if type(exc).__name__ != "BenchSkipped":
            raise
    try:
        _bench_fvessel(ctx)
    except Exception as exc:
        if type(exc).__name__ != "BenchSkipped":
            raise
    _bench_scenarios(ctx)
