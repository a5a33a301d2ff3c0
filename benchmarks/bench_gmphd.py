"""GM-PHD multi-camera fusion (paper C): OSPA/GOSPA, cardinality and speed beside Stone Soup.

The paper's three-camera scenario (``seawatch.sim.phd_scenario``) for several seeds; the
seawatch filter, the same filter without its two additions (the plain Vo and Ma GM-PHD), and
Stone Soup's GM-PHD (``PHDUpdater`` + ``UnscentedKalmanUpdater`` + ``GaussianMixtureReducer``)
run on identical reports with identical models, births, field-of-view rule and extraction.
Times are the CPU time of this (single-threaded) process, so that a shared machine does not
inflate them; speeds are medians over scans.  The
Stone Soup peer is optional (``pip install stonesoup==1.9.1``, the ``peers`` extra) and skipped
when missing.  Plots (plan view, cardinality, OSPA over time) go to ``benchmarks/results``.
"""

from __future__ import annotations

import datetime as _dt
import os
import time

import numpy as np

from seawatch.eval import gospa, ospa
from seawatch.sim.phd_scenario import make_phd_scenario
from seawatch.track.gmphd import GMPHDFilter, PHDReport, PHDSensor, birth_from_azel, cv_model

NAME = "gmphd"
DESCRIPTION = "paper C GM-PHD: OSPA/GOSPA, cardinality error, scans/s at 10/20/40 targets vs Stone Soup"

CUTOFF_M = 100.0  # OSPA / GOSPA cut-off c
ORDER_P = 1.0
REF = "paper C, GM-PHD three-camera scenario"

#: the filter settings shared by every method (and mirrored in the Stone Soup run)
COMMON = dict(accel_std_mps2=0.3, vertical_accel_std_mps2=0.02, ps=0.995, birth_weight=0.02,
              birth_range_m=(1500.0, 3000.0, 4500.0), birth_sigma_range_m=750.0,
              birth_sigma_v_mps=8.0, birth_sigma_vu_mps=0.3, birth_max_abs_up_m=50.0,
              prune_threshold=1e-5, merge_threshold=4.0, max_components=100,
              extract_threshold=0.5, ut_alpha=0.5, ut_beta=2.0, ut_kappa=0.0)
PLAIN = dict(penalise=False, extract_keep_threshold=None, ps_unseen=0.995)  # Vo & Ma as such
#: the robust Kalman detector as used end to end (the defaults of ``[detector]`` rk_* fields)
RK_SETTINGS: dict = {}


# ------------------------------------------------------------------------------ seawatch
def run_seawatch(scn, **kw):
    """Run the seawatch GM-PHD over a scenario; returns estimates per time and seconds per scan."""
    f = GMPHDFilter([PHDSensor.from_spec(c) for c in scn.cameras], **{**COMMON, **kw})
    est, dts = {}, []
    for r in scn.reports:
        t0 = time.process_time()
        f.step(PHDReport(r.t_s, r.sensor_id, r.azel_deg))
        lab, st, _ = f.estimates()
        dts.append(time.process_time() - t0)
        est[r.t_s] = (lab, st[:, :3])
    return est, np.array(dts)


# ------------------------------------------------------------------------------ Stone Soup
def stonesoup_available() -> bool:
    try:
        import stonesoup  # noqa: F401
    except ImportError:
        return False
    return True


_PERM = [0, 3, 1, 4, 2, 5]  # Stone Soup [x, vx, y, vy, z, vz] from seawatch [e, n, u, ve, vn, vu]


def run_stonesoup(scn, max_reports: int | None = None, **kw):
    """The same GM-PHD with Stone Soup's components on the same reports.

    Births (the unscented transform of each detection, weights scaled by one minus the share of
    the detection explained by existing components), the field-of-view rule (components whose
    predicted mean is outside the reporting camera's view are predicted and not updated, Pd = 0)
    and extraction (weight > 0.5) are done here exactly as in the seawatch filter; prediction,
    hypotheses, the PHD update and pruning/merging/capping are Stone Soup's.
    """
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
    from stonesoup.measures import Mahalanobis
    from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
    from stonesoup.models.measurement.nonlinear import CartesianToElevationBearing
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.array import CovarianceMatrix, StateVector
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import TaggedWeightedGaussianState
    from stonesoup.updater.kalman import UnscentedKalmanUpdater
    from stonesoup.updater.pointprocess import PHDUpdater

    p = {**COMMON, **kw}
    sensors = {c.sensor_id: PHDSensor.from_spec(c) for c in scn.cameras}
    qh, qv = p["accel_std_mps2"] ** 2, p["vertical_accel_std_mps2"] ** 2
    transition = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(qh), ConstantVelocity(qh), ConstantVelocity(qv)])
    predictor = KalmanPredictor(transition)
    updater = UnscentedKalmanUpdater(measurement_model=None, alpha=p["ut_alpha"],
                                     beta=p["ut_beta"], kappa=p["ut_kappa"])
    models = {
        sid: CartesianToElevationBearing(
            ndim_state=6, mapping=(0, 2, 4),
            noise_covar=np.diag([np.radians(s.sigma_el_deg) ** 2, np.radians(s.sigma_az_deg) ** 2]),
            translation_offset=StateVector(s.pos.reshape(3, 1)))
        for sid, s in sensors.items()
    }
    # a Mahalanobis gate of 6 sigma only skips pairs whose weight would be pruned anyway
    hypothesiser = GaussianMixtureHypothesiser(
        DistanceHypothesiser(predictor, updater, measure=Mahalanobis(), missed_distance=6.0),
        order_by_detection=True)
    reducer = GaussianMixtureReducer(prune_threshold=p["prune_threshold"], pruning=True,
                                     merge_threshold=p["merge_threshold"], merging=True,
                                     max_number_components=p["max_components"])
    t0 = _dt.datetime(2020, 1, 1)
    ts = lambda t: t0 + _dt.timedelta(seconds=float(t))  # noqa: E731
    comps: list = []
    pending: list = []
    tag_n = [0]
    est, dts = {}, []
    t_prev = None
    reports = scn.reports if max_reports is None else scn.reports[:max_reports]
    for r in reports:
        tic = time.process_time()
        sensor = sensors[r.sensor_id]
        now = ts(r.t_s)
        dt = 0.0 if t_prev is None else r.t_s - t_prev
        t_prev = r.t_s
        ps = p["ps"] ** dt
        comps = comps + pending  # births from the previous report
        pending = []
        inside, outside = [], []
        for c in comps:
            m = np.asarray(c.state_vector, float).ravel()
            d = m[[0, 2, 4]] - sensor.pos
            az = np.degrees(np.arctan2(d[0], d[1]))
            el = np.degrees(np.arctan2(d[2], np.hypot(d[0], d[1])))
            (inside if sensor.in_fov(az, el) else outside).append(c)
        kept = []
        for c in outside:  # Pd = 0: predicted, weight times ps
            pr = predictor.predict(c, timestamp=now)
            kept.append(TaggedWeightedGaussianState(pr.state_vector, pr.covar, weight=c.weight * ps,
                                                    tag=c.tag, timestamp=now))
        dets = [Detection(StateVector([[np.radians(z[1])], [np.pi / 2 - np.radians(z[0])]]),
                          timestamp=now, measurement_model=models[r.sensor_id])
                for z in r.azel_deg]
        explained = np.zeros(len(dets))
        if inside:
            phd = PHDUpdater(updater, clutter_spatial_density=sensor.clutter_density,
                             prob_detection=sensor.pd, prob_survival=ps)
            dset = set(dets)
            order = list(dset)
            hyps = hypothesiser.hypothesise(inside, dset, now)
            upd = phd.update(hyps)
            # the updated components come detection by detection, in ``order``
            k = 0
            index = {id(d): i for i, d in enumerate(dets)}
            for det, mh in zip(order, hyps[:-1]):
                n = len(mh)
                explained[index[id(det)]] = sum(c.weight for c in upd.components[k:k + n])
                k += n
            kept += list(upd.components)
        elif dets:
            pass
        comps = reducer.reduce(kept)
        # births for the next report, as in the seawatch filter
        if len(dets):
            bm, bP = birth_from_azel(
                r.azel_deg, sensor.pos, sigma_az_deg=sensor.sigma_az_deg,
                sigma_el_deg=sensor.sigma_el_deg, range_m=p["birth_range_m"],
                sigma_range_m=p["birth_sigma_range_m"], sigma_v_mps=p["birth_sigma_v_mps"],
                sigma_vu_mps=p["birth_sigma_vu_mps"])
            R = len(np.atleast_1d(p["birth_range_m"]))
            bw = np.repeat(p["birth_weight"] * np.clip(1.0 - explained, 0, 1) / R, R)
            ok = (bw >= p["prune_threshold"]) & (np.abs(bm[:, 2]) <= p["birth_max_abs_up_m"])
            for w, m, P in zip(bw[ok], bm[ok], bP[ok]):
                tag_n[0] += 1
                pending.append(TaggedWeightedGaussianState(
                    StateVector(m[_PERM].reshape(6, 1)), CovarianceMatrix(P[np.ix_(_PERM, _PERM)]),
                    weight=float(w), tag=f"b{tag_n[0]}", timestamp=now))
        out = [c for c in comps if c.weight > p["extract_threshold"]]
        dts.append(time.process_time() - tic)
        pts = np.array([np.asarray(c.state_vector, float).ravel()[[0, 2, 4]] for c in out]).reshape(-1, 3)
        est[r.t_s] = (np.arange(len(out)), pts)
    return est, np.array(dts)


# ------------------------------------------------------------------------------ scoring
def score(scn, est, max_reports: int | None = None) -> dict:
    """OSPA, GOSPA and cardinality error of estimates against the scenario's truth."""
    reps = scn.reports if max_reports is None else scn.reports[:max_reports]
    truth = {r.t_s: (i, p) for r, i, p in zip(reps, scn.truth_ids, scn.truth_pos)}
    frames = [r.t_s for r in reps]
    o = ospa(truth, est, cutoff_m=CUTOFF_M, p=ORDER_P, frames=frames)
    g = gospa(truth, est, cutoff_m=CUTOFF_M, p=ORDER_P, frames=frames)
    n_true = np.array([len(truth[t][0]) for t in frames])
    n_est = np.array([len(est[t][0]) for t in frames])
    return {"OSPA": o["OSPA"], "GOSPA": g["GOSPA"], "card_err": float(np.mean(np.abs(n_est - n_true))),
            "ospa_t": o["per_frame"], "n_true": n_true, "n_est": n_est}


# ------------------------------------------------------------------------------ end to end
def sensors_for_multicam(mc, *, sigma_az_deg=0.25, sigma_el_deg=0.1, pd=0.7, clutter_per_scan=3.0):
    """PHD sensors for the simulator's multi-camera views, in the world's ENU frame."""
    lat0, lon0 = mc.origin
    return [PHDSensor.from_camera(v.camera_id, v.camera, (lat0, lon0, 0.0), sigma_az_deg=sigma_az_deg,
                                  sigma_el_deg=sigma_el_deg, pd=pd, clutter_per_scan=clutter_per_scan)
            for v in mc.views]


def run_end_to_end(seed: int = 0, duration_s: float = 40.0, report_period_s: float = 3.0,
                   camera_offset_s: float = 1.0, detectors=("robust_kalman", "mog2"),
                   width: int = 1280, height: int = 720, fps: float = 5.0, min_area_px: float = 8.0,
                   **filter_kw):
    """Render one simulated world from several cameras, detect with background models, fuse.

    Every camera's detector sees every frame (the background model needs them); each camera
    reports its detections (azimuth/elevation of each blob's bottom centre through its camera
    model) to the fusion centre every ``report_period_s``, camera ``k`` at ``k * camera_offset_s``,
    as in the paper.  The same filter also runs on the ground-truth boxes (``"gt_boxes"``) as an
    upper bound.  The simulator's bay is wide (vessels 1-3 km away are a few pixels tall at
    704 px), so it is rendered at ``width x height`` and small blobs (``min_area_px``) are kept.  Returns ``{detector: score dict}`` with OSPA, GOSPA and cardinality error
    against the vessels visible (>= 30 %) in at least one camera at each report time.
    """
    from seawatch.detect.background import RobustKalmanDetector
    from seawatch.detect.blobs import blobs_to_detections
    from seawatch.detect.mog2 import Mog2Detector
    from seawatch.sim import make_multicam

    mc = make_multicam(seed=seed, duration_s=duration_s, width=width, height=height, fps=fps)
    sensors = sensors_for_multicam(mc)
    cams = {v.camera_id: v.camera for v in mc.views}
    n_cam = len(mc.views)
    dets = {}
    for name in detectors:
        for k, v in enumerate(mc.views):
            if name == "robust_kalman":
                dets[(name, k)] = RobustKalmanDetector(camera=v.camera, min_area_px=min_area_px,
                                                       **RK_SETTINGS)
            elif name == "mog2":
                dets[(name, k)] = Mog2Detector(mc.fps, min_area_px=min_area_px)
    methods = list(detectors) + ["gt_boxes"]
    filters = {m: GMPHDFilter(sensors, **{**COMMON, **filter_kw}) for m in methods}
    est = {m: {} for m in methods}
    truth = {}
    n_reports = {m: 0 for m in methods}
    for i in range(mc.n_frames):
        frames = mc.render(i)
        gts = mc.ground_truth(i)
        t = frames[0].t_s
        outs = {}
        for (name, k), d in dets.items():
            outs[(name, k)] = d.detect(frames[k])
        # which camera reports now (a report per camera every report_period_s)
        for k, v in enumerate(mc.views):
            phase = (t - k * camera_offset_s) / report_period_s
            if t < k * camera_offset_s or abs(phase - round(phase)) * report_period_s > 0.5 / mc.fps:
                continue
            sid = v.camera_id
            for name in detectors:
                d = outs[(name, k)]
                if d.azel_deg is None:
                    d = blobs_to_detections(d.boxes, d.t_s, d.frame_index, camera=cams[sid],
                                            source=name, camera_id=sid)
                filters[name].step(PHDReport(t, sid, d.azel_deg if d.azel_deg is not None
                                             else np.zeros((0, 2))))
            g = gts[k]
            ok = g.visible >= 0.3
            gd = blobs_to_detections(g.boxes[ok], t, i, camera=cams[sid], camera_id=sid)
            filters["gt_boxes"].step(PHDReport(t, sid, gd.azel_deg if gd.azel_deg is not None
                                               else np.zeros((0, 2))))
            for m in methods:
                lab, st, _ = filters[m].estimates()
                est[m][t] = (lab, st[:, :3])
                n_reports[m] += 1
            wt = mc.world_truth(i)
            seen = set()
            for gg in gts:
                seen |= set(gg.ids[gg.visible >= 0.3].tolist())
            sel = np.isin(wt["ids"], sorted(seen))
            truth[t] = (wt["ids"][sel], wt["enu_m"][sel])
    frames_t = sorted(truth)
    out = {}
    for m in methods:
        o = ospa(truth, est[m], cutoff_m=CUTOFF_M, p=ORDER_P, frames=frames_t)
        g = gospa(truth, est[m], cutoff_m=CUTOFF_M, p=ORDER_P, frames=frames_t)
        n_true = np.array([len(truth[t][0]) for t in frames_t])
        n_est = np.array([len(est[m][t][0]) for t in frames_t])
        out[m] = {"OSPA": o["OSPA"], "GOSPA": g["GOSPA"],
                  "card_err": float(np.mean(np.abs(n_est - n_true))), "reports": len(frames_t),
                  "cameras": n_cam}
    return out


def run(ctx) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    seeds = [0] if ctx.quick else [0, 1, 2, 3, 4]
    ss_seeds = [0] if ctx.quick else [0, 1]  # Stone Soup takes minutes per seed
    duration = 120.0 if ctx.quick else 300.0
    have_ss = stonesoup_available()
    ds = f"phd_3cam_10tgt_{int(duration)}s"
    methods = {"seawatch_gmphd": {}, "seawatch_gmphd_plain": PLAIN}
    res: dict[str, list] = {m: [] for m in methods}
    res["stonesoup_gmphd"] = []
    scn0 = None
    for seed in seeds:
        scn = make_phd_scenario(10, duration_s=duration, seed=seed)
        if scn0 is None:
            scn0 = scn
        for m, kw in methods.items():
            est, dts = run_seawatch(scn, **kw)
            res[m].append((score(scn, est), dts, est))
        if have_ss and seed in ss_seeds:
            est, dts = run_stonesoup(scn)
            res["stonesoup_gmphd"].append((score(scn, est), dts, est))
    for m, rows in res.items():
        if not rows:
            continue
        nseed = len(rows)
        for metric, unit in (("OSPA", "m"), ("GOSPA", "m"), ("card_err", "targets")):
            v = float(np.mean([r[0][metric] for r in rows]))
            ctx.record(ds, m, metric if metric != "card_err" else "cardinality_error", v, unit,
                       ref=REF, seeds=nseed, cutoff_m=CUTOFF_M, p=ORDER_P)
    # the same seeds for a like-for-like comparison
    if res["stonesoup_gmphd"]:
        n = len(res["stonesoup_gmphd"])
        for m in methods:
            v = float(np.mean([r[0]["OSPA"] for r in res[m][:n]]))
            ctx.record(ds, m, "OSPA_same_seeds_as_stonesoup", v, "m", ref=REF, seeds=n)
    if not have_ss:
        ctx.record(ds, "stonesoup_gmphd", "OSPA", float("nan"), "m",
                   note="stonesoup not installed (pip install stonesoup==1.9.1): peer skipped")
    # speed: scans/s at 10, 20, 40 targets, one core, median over scans
    n_ss = 20 if ctx.quick else 30
    for n_t in (10, 20, 40):
        scn = make_phd_scenario(n_t, duration_s=duration, seed=100 + n_t)
        _, dts = run_seawatch(scn)
        _, dts2 = run_seawatch(scn)  # second pass: compiled kernels, warm caches
        ours = 1.0 / np.median(dts2)
        ctx.record(f"phd_3cam_{n_t}tgt", "seawatch_gmphd", "scans_per_s", ours, "1/s", ref=REF,
                   mean_scans_per_s=float(len(dts2) / dts2.sum()))
        if have_ss:
            # Stone Soup on the first scans of the same run (its per-scan cost grows as targets
            # are born, so the comparison is made on the same first scans for both)
            _, d_ss = run_stonesoup(scn, max_reports=n_ss)
            s_ss = 1.0 / np.median(d_ss[n_ss // 2:])
            o_same = 1.0 / np.median(dts2[n_ss // 2:n_ss])
            ctx.record(f"phd_3cam_{n_t}tgt", "stonesoup_gmphd", "scans_per_s", s_ss, "1/s", ref=REF,
                       scans=n_ss)
            ctx.record(f"phd_3cam_{n_t}tgt", "seawatch_gmphd", "speedup_vs_stonesoup",
                       o_same / s_ss, "x", ref=REF, scans=n_ss)
    # end to end: rendered multi-camera video -> background models -> blobs -> GM-PHD
    e2e = run_end_to_end(seed=0, duration_s=20.0 if ctx.quick else 40.0)
    for m, sc in e2e.items():
        for metric, unit in (("OSPA", "m"), ("GOSPA", "m"), ("card_err", "targets")):
            ctx.record("sim_multicam_e2e", f"gmphd<-{m}",
                       metric if metric != "card_err" else "cardinality_error", sc[metric], unit,
                       ref="paper C, end to end", reports=sc["reports"], cameras=sc["cameras"])
    # plots of the first seed
    try:
        from seawatch.track.gmphd_plots import plot_phd_run

        runs = {m: res[m][0] for m in res if res[m]}
        path = plot_phd_run(scn0, {m: (r[2], r[0]) for m, r in runs.items()},
                            ctx.results_dir / "gmphd_scenario.png")
        ctx.record(ds, "seawatch_gmphd", "plot", 1.0, "", path=str(path))
    except ImportError:
        pass
