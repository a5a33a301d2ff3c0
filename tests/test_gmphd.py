"""GM-PHD filter over (az, el) reports of several cameras (paper C) and its scenario."""

import numpy as np
import pytest

from seawatch.sim.phd_scenario import make_phd_scenario, paper_cameras
from seawatch.track.gmphd import (
    GMPHDFilter,
    GMPHDTracker,
    PHDReport,
    PHDSensor,
    azel_from_points,
    birth_from_azel,
    merge_components,
)
from seawatch.types import Detections, Tracker


def _azel_deg(p, origin):
    az, el = azel_from_points(np.atleast_2d(p), np.asarray(origin, float))
    return np.degrees(np.stack([az, el], axis=1))


def test_unscented_birth_of_one_bearing_is_a_cone():
    origin = np.array([100.0, -50.0, 20.0])
    az, el = 35.0, -1.0
    ranges = np.array([1000.0, 2000.0, 4000.0])
    m, P = birth_from_azel([[az, el]], origin, sigma_az_deg=0.2, sigma_el_deg=0.2, range_m=ranges,
                           sigma_range_m=200.0, sigma_v_mps=5.0)
    assert m.shape == (3, 6) and P.shape == (3, 6, 6)
    u = np.array([np.cos(np.radians(el)) * np.sin(np.radians(az)),
                  np.cos(np.radians(el)) * np.cos(np.radians(az)), np.sin(np.radians(el))])
    cross = []
    for k, r in enumerate(ranges):
        d = m[k, :3] - origin
        # the mean lies on the line of sight, about r0 out
        assert np.linalg.norm(np.cross(d / np.linalg.norm(d), u)) < 1e-4
        assert abs(np.linalg.norm(d) - r) < 0.01 * r
        vals, vecs = np.linalg.eigh(P[k, :3, :3])
        # the long axis is the line of sight, with sigma_r
        assert abs(abs(vecs[:, -1] @ u) - 1.0) < 1e-4
        assert np.sqrt(vals[-1]) == pytest.approx(200.0, rel=0.02)
        cross.append(np.sqrt(vals[:2]))
        np.testing.assert_allclose(P[k, 3:5, 3:5], np.eye(2) * 25.0)
    cross = np.array(cross)
    # the cross-range spread grows in proportion to range: a cone of angle sigma_az
    np.testing.assert_allclose(cross[:, 1] / ranges, np.radians(0.2), rtol=0.02)
    np.testing.assert_allclose(cross[2] / cross[0], 4.0, rtol=0.02)
    # and the Gaussian matches the moments of the sampled cloud
    rng = np.random.default_rng(0)
    n = 200_000
    a = np.radians(az + 0.2 * rng.standard_normal(n))
    e = np.radians(el + 0.2 * rng.standard_normal(n))
    r = 4000.0 + 200.0 * rng.standard_normal(n)
    pts = origin + np.stack([r * np.cos(e) * np.sin(a), r * np.cos(e) * np.cos(a), r * np.sin(e)], 1)
    np.testing.assert_allclose(m[2, :3], pts.mean(0), atol=1.0)
    np.testing.assert_allclose(P[2, :3, :3], np.cov(pts.T), atol=0.03 * 200.0**2)


def test_two_camera_triangulation_of_a_moving_target():
    cams = [PHDSensor("a", (0.0, 0.0, 20.0), 0.0, -5.0, sigma_az_deg=0.05, sigma_el_deg=0.05,
                      pd=1.0, clutter_per_scan=1.0),
            PHDSensor("b", (800.0, 0.0, 20.0), 0.0, -5.0, sigma_az_deg=0.05, sigma_el_deg=0.05,
                      pd=1.0, clutter_per_scan=1.0)]
    f = GMPHDFilter(cams, birth_range_m=[1500.0, 3000.0, 4500.0], birth_sigma_range_m=750.0)
    rng = np.random.default_rng(1)
    p0, v = np.array([300.0, 2500.0, 0.0]), np.array([4.0, -3.0, 0.0])
    for k in range(40):
        t = 1.0 * k
        cam = cams[k % 2]
        z = _azel_deg(p0 + v * t, cam.pos) + rng.normal(0, 0.05, (1, 2))
        f.step(PHDReport(t, cam.sensor_id, z))
    labels, states, w = f.estimates()
    assert len(labels) == 1
    truth = p0 + v * 39.0
    assert np.linalg.norm(states[0, :3] - truth) < 15.0
    assert np.linalg.norm(states[0, 3:5] - v[:2]) < 1.0
    assert f.cardinality == pytest.approx(1.0, abs=0.3)


def test_single_bearing_does_not_make_a_target_and_fov_gates_pd():
    cams = [PHDSensor("a", (0.0, 0.0, 20.0), 0.0, -5.0, pd=0.9, clutter_per_scan=5.0),
            PHDSensor("b", (1000.0, 0.0, 20.0), 90.0, -5.0, hfov_deg=60.0, pd=0.9,
                      clutter_per_scan=5.0)]
    f = GMPHDFilter(cams)
    z = _azel_deg([0.0, 2000.0, 0.0], cams[0].pos)
    f.step(PHDReport(0.0, "a", z))  # one bearing: births only, nothing extracted
    assert len(f.estimates()[0]) == 0
    # camera b looks east: the births (north of the origin) are outside its view, Pd = 0
    w_before = f._birth[0].sum()
    f.step(PHDReport(1.0, "b", np.zeros((0, 2))))
    assert f.w.sum() == pytest.approx(w_before, rel=1e-9)  # births are not thinned by ps
    # camera a sees them: an empty report scales them by ps and 1 - pd
    f.step(PHDReport(2.0, "a", np.zeros((0, 2))))
    assert f.w.sum() == pytest.approx(w_before * f.ps * 0.1, rel=1e-9)


def test_clutter_only_gives_few_short_false_targets():
    def run(**kw):
        cams = [PHDSensor.from_spec(c) for c in paper_cameras(clutter_per_scan=30.0)]
        f = GMPHDFilter(cams, **kw)
        rng = np.random.default_rng(2)
        n_est, longest, run_len = 0, 0, 0
        for k in range(90):
            c = cams[k % 3]
            n = rng.poisson(30)
            z = np.stack([c.boresight_az_deg + rng.uniform(-60, 60, n),
                          c.boresight_el_deg + rng.uniform(-15, 15, n)], 1)
            f.step(PHDReport(float(k), c.sensor_id, z))
            n = len(f.estimates()[0])
            n_est += n
            run_len = run_len + 1 if n else 0
            longest = max(longest, run_len)
        assert len(f.w) <= 100
        return n_est, longest

    n_est, longest = run()
    assert n_est <= 9 and longest <= 8  # false targets in under 10 % of reports, none lasting
    # births restricted to lines of sight that meet the sea surface are what keeps it so
    n_paper, _ = run(birth_max_abs_up_m=np.inf)
    assert n_paper > 2 * max(n_est, 1)


def test_merge_keeps_heaviest_label():
    m = np.zeros((3, 6))
    m[1, 0] = 1.0  # within 1 sigma of component 0
    m[2, 0] = 100.0  # far away
    P = np.tile(np.eye(6), (3, 1, 1))
    w, mm, PP, lab = merge_components(np.array([0.3, 0.6, 0.5]), m, P, np.array([7, 8, 9]), 4.0)
    order = np.argsort(lab)
    assert lab[order].tolist() == [8, 9]
    np.testing.assert_allclose(w[order], [0.9, 0.5])
    np.testing.assert_allclose(mm[order][0, 0], 0.6 / 0.9)
    assert PP[order][0, 0, 0] > 1.0  # the spread of the means adds to the covariance


def test_scenario_schedule_and_determinism():
    scn = make_phd_scenario(10, duration_s=60.0, seed=3)
    t = scn.times
    assert np.all(np.diff(t) == 1.0)
    ids = [r.sensor_id for r in scn.reports]
    assert ids[:6] == ["cam1", "cam2", "cam3", "cam1", "cam2", "cam3"]
    cams = {c.sensor_id: c for c in scn.cameras}
    assert cams["cam2"].position_m[0] == -cams["cam3"].position_m[0] > 0
    assert [cams[k].boresight_az_deg for k in ("cam1", "cam2", "cam3")] == [0.0, 20.0, -20.0]
    # detections of true vessels are within a few sigma of their true angles
    r = scn.reports[10]
    k = 10
    for z, sid in zip(r.azel_deg, r.source_id):
        if sid >= 0:
            p = scn.truth_pos[k][list(scn.truth_ids[k]).index(sid)]
            assert np.all(np.abs(z - _azel_deg(p, cams[r.sensor_id].position_m)[0]) < 0.6)
    assert scn.n_false_alarms() > 0
    # speeds 10-15 knots
    sp = np.linalg.norm(np.concatenate(scn.truth_vel), axis=1)
    assert sp.min() >= 10 * 1852 / 3600 - 1e-6 and sp.max() <= 15 * 1852 / 3600 + 1e-6

    def run(seed):
        s = make_phd_scenario(10, duration_s=60.0, seed=seed)
        f = GMPHDFilter([PHDSensor.from_spec(c) for c in s.cameras])
        out = []
        for rr in s.reports:
            f.step(PHDReport(rr.t_s, rr.sensor_id, rr.azel_deg))
            out.append(f.estimates())
        return out

    a, b, c = run(3), run(3), run(4)
    for x, y in zip(a, b):
        for u, v in zip(x, y):
            np.testing.assert_array_equal(u, v)
    assert any(len(x[0]) != len(y[0]) or not np.array_equal(x[1], y[1]) for x, y in zip(a, c))


def test_scenario_tracking_quality_and_persistent_labels():
    scn = make_phd_scenario(6, duration_s=120.0, seed=5)
    f = GMPHDFilter([PHDSensor.from_spec(c) for c in scn.cameras],
                    birth_range_m=[1500.0, 3000.0, 4500.0], birth_sigma_range_m=750.0,
                    extract_keep_threshold=0.05)
    errs, label_of = [], {}
    switches = 0
    for k, r in enumerate(scn.reports):
        f.step(PHDReport(r.t_s, r.sensor_id, r.azel_deg))
        lab, st, _ = f.estimates()
        if r.t_s < 30 or len(st) == 0:
            continue
        for i, p in zip(scn.truth_ids[k], scn.truth_pos[k]):
            d = np.linalg.norm(st[:, :2] - p[:2], axis=1)
            j = int(np.argmin(d))
            if d[j] < 100:
                errs.append(d[j])
                if i in label_of and label_of[i] != lab[j]:
                    switches += 1
                label_of[i] = lab[j]
    n_truth = sum(len(x) for x, r in zip(scn.truth_ids, scn.reports) if r.t_s >= 30)
    assert len(errs) >= 0.9 * n_truth
    assert np.median(errs) < 25.0
    assert switches <= 2


def test_tracker_protocol_and_bad_input():
    cams = [PHDSensor("a", (0.0, 0.0, 20.0), 0.0, -5.0), PHDSensor("b", (800.0, 0.0, 20.0), 0.0, -5.0)]
    tr = GMPHDTracker(cams, origin_geodetic=(50.0, -1.0, 0.0))
    assert isinstance(tr, Tracker) and tr.name == "gmphd"
    p = np.array([200.0, 2000.0, 0.0])
    for k in range(12):
        cam = cams[k % 2]
        z = _azel_deg(p, cam.pos)
        out = tr.update(Detections(float(k), k, np.zeros((1, 4)), np.ones(1), "x", cam.sensor_id, z))
    assert len(out) == 1 and out.world is not None
    assert out.world[0, 0] == pytest.approx(50.0 + 2000.0 / 111_200, abs=2e-4)
    # detections without angles are counted, not fused
    tr.update(Detections(12.0, 12, np.zeros((1, 4)), np.ones(1), "x", "a"))
    assert tr.n_bad_detections == 1
    with pytest.raises(KeyError, match="unknown sensor"):
        tr.update(Detections.empty(13.0, 13, "x", "zz"))
    late = tr.update(Detections.empty(1.0, 14, "x", "a"))  # out of order: counted, dropped
    assert tr.n_late_reports == 1 and len(late) == 1
    with pytest.raises(ValueError, match="older"):
        tr.filter.step(PHDReport(1.0, "a", np.zeros((0, 2))))


def test_from_config():
    from seawatch.config import load_config

    cfg = load_config(overrides=["tracker.phd_birth_range_m=[2000.0, 4000.0]", "tracker.phd_penalise=false"])
    tr = GMPHDTracker.from_config(cfg, [PHDSensor("a", (0.0, 0.0, 10.0))])
    assert tr.filter.birth_range_m.tolist() == [2000.0, 4000.0] and tr.filter.penalise is False
    assert tr.filter.max_components == 100 and tr.filter.merge_threshold == 4.0


def test_sensor_from_camera_fov():
    from seawatch.camera import CameraModel, Intrinsics
    from seawatch.types import CameraPose

    import pymap3d

    lat0, lon0 = 50.0, -1.0
    lat, lon, _ = pymap3d.enu2geodetic(500.0, 0.0, 0.0, lat0, lon0, 0.0)
    cam = CameraModel(Intrinsics.from_fov(60.0, 640, 480), CameraPose(lat_deg=lat, lon_deg=lon,
                                                                      height_m=15.0, pan_deg=90.0))
    s = PHDSensor.from_camera("c", cam, (lat0, lon0, 0.0))
    np.testing.assert_allclose(s.pos, [500.0, 0.0, 15.0], atol=0.05)
    assert s.hfov_deg == pytest.approx(60.0)
    assert s.in_fov(np.array([90.0, 125.0, 270.0]), np.array([-1.0, -1.0, -1.0])).tolist() == [True, False, False]
