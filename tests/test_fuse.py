"""Fusion: dead reckoning, association on scripted geometry, self-calibration, theta, alerts."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from seawatch.camera import CameraModel, Intrinsics
from seawatch.config import FusionSettings
from seawatch.fuse import Fuser, TargetTable, build_fuser, dead_reckon_enu, dead_reckon_geodetic
from seawatch.fuse.alerts import read_alerts_jsonl, write_alerts_jsonl
from seawatch.fuse.associate import WindowAssociator
from seawatch.fuse.table import KN_TO_MPS
from seawatch.fuse.theta import calibrate_theta_pg, estimate_theta_robust, match_velocities, rotate_cw
from seawatch.io.radar import RADAR_DTYPE
from seawatch.types import AISReport, CameraPose, Frame, Tracks, TrackState

POSE = CameraPose(lat_deg=50.80, lon_deg=-1.10, height_m=20.0, pan_deg=90.0, tilt_deg=-1.0)
CAM = CameraModel(Intrinsics.from_fov(60.0, 1280, 720), POSE)


@dataclasses.dataclass
class Vessel:
    tid: int  # camera track id
    mmsi: int  # 0: no AIS
    e0: float
    n0: float
    ve: float
    vn: float
    length_m: float = 30.0
    ais_offset_m: tuple = (0.0, 0.0)  # AIS position error (spoofing when large)
    spoof_after_s: float = math.inf

    def enu(self, t):
        return self.e0 + self.ve * t, self.n0 + self.vn * t


def render_tracks(vessels, t, cam=CAM, rng=None, noise_px=0.0) -> Tracks:
    """Camera tracks of the vessels at time t: boxes from the true geometry (waterline bottom centre)."""
    ids, boxes, vels = [], [], []
    for v in vessels:
        e, n = v.enu(t)
        u, vv, depth = cam.enu_to_pixel(e, n, 0.0)
        u2, vv2, _ = cam.enu_to_pixel(e + v.ve, n + v.vn, 0.0)
        if not (depth > 0 and cam.in_image(u, vv)):
            continue
        w = v.length_m * cam.intrinsics.fx / math.hypot(e, n)
        h = 0.4 * w
        du = rng.normal(0, noise_px, 2) if rng is not None and noise_px else np.zeros(2)
        ids.append(v.tid)
        boxes.append([u - w / 2 + du[0], vv - h + du[1], w, h])
        vels.append([float(u2 - u), float(vv2 - vv)])
    return Tracks(t, int(round(t * 10)), np.array(ids, np.int64), np.array(boxes).reshape(-1, 4),
                  np.array(vels).reshape(-1, 2), np.full(len(ids), int(TrackState.CONFIRMED), np.int8))


def ais_reports(vessels, t0, t1, interval_s=2.0, cam=CAM, stagger=True):
    out = []
    for k, v in enumerate(vessels):
        if not v.mmsi:
            continue
        t = t0 + (0.37 * k if stagger else 0.0)
        while t <= t1:
            e, n = v.enu(t)
            if t >= v.spoof_after_s:
                e, n = e + v.ais_offset_m[0], n + v.ais_offset_m[1]
            lat, lon, _ = cam.enu_to_geodetic(e, n, 0.0)
            sog = math.hypot(v.ve, v.vn) / KN_TO_MPS
            cog = math.degrees(math.atan2(v.ve, v.vn)) % 360
            out.append(AISReport(v.mmsi, t, float(lat), float(lon), sog, cog, msg_type=1))
            t += interval_s
        out.append(AISReport(v.mmsi, t0, name=f"SHIP{v.mmsi % 1000}", ship_type=70, length_m=v.length_m, msg_type=5))
    return out


def run(fuser, vessels, t0, t1, fps=5.0, **kw):
    rng = np.random.default_rng(0)
    alerts, results = [], []
    t = t0
    while t <= t1 + 1e-9:
        trk = render_tracks(vessels, t, rng=rng, **kw)
        out, al = fuser.update(trk, Frame(np.zeros((720, 1280), np.uint8), t, 0, pose=POSE), t)
        alerts += al
        results.append((t, dict(zip(out.ids.tolist(), out.mmsi.tolist())), out))
        t += 1.0 / fps
    return results, alerts


# --------------------------------------------------------------------------- dead reckoning
def test_dead_reckon_functions():
    e, n = dead_reckon_enu(10.0, 20.0, 5.0, 90.0, 4.0)
    assert e == pytest.approx(30.0) and n == pytest.approx(20.0)
    e, n = dead_reckon_enu([0.0], [0.0], [np.nan], [45.0], [10.0])  # unknown speed: still
    assert e[0] == 0.0 and n[0] == 0.0
    lat, lon = dead_reckon_geodetic(50.0, -1.0, 10.0, 0.0, 111.2)  # ~1112 m north
    assert lat == pytest.approx(50.0 + 1112 / 111_229, abs=2e-5) and lon == pytest.approx(-1.0, abs=1e-9)


def test_target_table_dead_reckoning_static_and_history():
    tab = TargetTable(50.0, -1.0, history=4, max_age_s=100.0)
    lat0, lon0 = tab.to_geodetic(1000.0, 0.0)
    tab.add_reports([
        AISReport(235000001, 10.0, float(lat0), float(lon0), 10.0, 90.0),
        AISReport(235000001, 0.0, name="ALPHA", ship_type=60, length_m=80.0, msg_type=5),
        AISReport(235000002, 12.0, float(lat0), float(lon0), float("nan"), float("nan")),
    ])
    st = tab.states_at(40.0)
    k = {int(x): i for i, x in enumerate(st.keys)}
    i = k[235000001]
    assert st.e_m[i] == pytest.approx(1000 + 10 * KN_TO_MPS * 30, abs=0.01)
    assert st.n_m[i] == pytest.approx(0.0, abs=1e-3) and st.age_s[i] == pytest.approx(30.0)
    assert st.length_m[i] == 80.0 and tab.static_of(235000001)["name"] == "ALPHA"
    # no SOG/COG: still until a second report gives the velocity from the two positions
    j = k[235000002]
    assert st.e_m[j] == pytest.approx(1000.0, abs=1e-3)
    lat1, lon1 = tab.to_geodetic(1000.0, 50.0)
    tab.add_reports([AISReport(235000002, 22.0, float(lat1), float(lon1))])
    st = tab.states_at(32.0)
    j = {int(x): i for i, x in enumerate(st.keys)}[235000002]
    assert st.vn_mps[j] == pytest.approx(5.0, abs=1e-3) and st.n_m[j] == pytest.approx(100.0, abs=0.01)
    # nothing from the future, nothing too old
    assert 235000002 not in st.keys[st.age_s < 0]
    assert len(tab.states_at(5.0)) == 0
    assert len(tab.states_at(500.0)) == 0
    # history: interpolation between reports, dead reckoning after the last, out-of-order report
    lat2, lon2 = tab.to_geodetic(1200.0, 0.0)
    tab.add_reports([AISReport(235000001, 30.0, float(lat2), float(lon2), 10.0, 90.0)])
    lat3, lon3 = tab.to_geodetic(1100.0, 0.0)
    tab.add_reports([AISReport(235000001, 20.0, float(lat3), float(lon3), 10.0, 90.0)])  # late
    s = tab.slot(235000001)
    e, n, valid = tab.positions_at(25.0, [s])
    assert valid[0] and e[0] == pytest.approx(1150.0, abs=0.01)
    assert tab.states_at(30.0).e_m[0] == pytest.approx(1200.0, abs=0.01)  # latest unchanged by the late one
    e, n, valid = tab.positions_at(34.0, [s])
    assert e[0] == pytest.approx(1200.0 + 10 * KN_TO_MPS * 4, abs=0.01)
    assert tab.state_of(235000001, 30.0) == pytest.approx((float(lat2), float(lon2)), abs=1e-7)


def test_table_batch_with_repeated_keys_and_growth():
    tab = TargetTable(50.0, -1.0)
    n = 300
    keys = np.repeat(np.arange(235000000, 235000000 + n), 2)
    t = np.tile([0.0, 1.0], n)
    lat = np.full(2 * n, 50.01)
    lon = np.full(2 * n, -1.0)
    assert tab.update(keys, t, lat, lon, np.full(2 * n, 1.0), np.zeros(2 * n)) == 2 * n
    assert len(tab) == n
    st = tab.states_at(3.0)
    assert len(st) == n and np.allclose(st.age_s, 2.0)


# ------------------------------------------------------------------------------ association
def scene():
    # camera at the origin looking east; ranges 600-2500 m
    return [
        Vessel(1, 235000001, 1500.0, 300.0, 0.0, -4.0),  # moving south
        Vessel(2, 235000002, 900.0, -150.0, 0.0, 3.0),  # north
        Vessel(3, 235000003, 2500.0, -500.0, -2.0, 0.0, length_m=60.0),  # coming in
        Vessel(4, 0, 1200.0, 0.0, 0.0, -2.0, length_m=15.0),  # no AIS
    ]


def test_association_scripted_geometry_and_no_ais_alert():
    vessels = scene()
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports(vessels, -60.0, 60.0))
    results, alerts = run(fuser, vessels, 0.0, 40.0, noise_px=1.0)
    truth = {v.tid: v.mmsi for v in vessels}
    correct = wrong = total = 0
    for t, got, _ in results:
        if t < 3.0:
            continue
        for tid, m in got.items():
            total += 1
            correct += m == truth[tid]
            wrong += m != 0 and m != truth[tid]
    assert wrong == 0
    assert correct / total > 0.97
    no_ais = [a for a in alerts if a.kind == "no_ais"]
    assert [a.track_id for a in no_ais] == [4]
    assert no_ais[0].t_s <= FusionSettings().no_ais_dwell_s + 1.0
    assert not [a for a in alerts if a.kind in ("ais_not_seen", "possible_spoofing")]
    # names, world position from the camera bearing and the AIS range
    t, got, out = results[-1]
    i = list(out.ids).index(1)
    assert out.names[i] == "SHIP1"
    e, n = vessels[0].enu(t)
    lat, lon, _ = CAM.enu_to_geodetic(e, n, 0.0)
    assert out.world[i, 0] == pytest.approx(lat, abs=2e-5) and out.world[i, 1] == pytest.approx(lon, abs=2e-5)
    assert out.world[i, 2] == pytest.approx(4.0, abs=0.05)
    pic = fuser.picture()
    assert {p.mmsi for p in pic if p.camera_track_id is not None} == {235000001, 235000002, 235000003, 0}


def test_crossing_vessels_keep_identities():
    # two vessels at different ranges crossing in azimuth: elevation and rates keep them apart
    vessels = [Vessel(1, 235000011, 800.0, -100.0, 0.0, 5.0), Vessel(2, 235000012, 1800.0, 200.0, 0.0, -5.0)]
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports(vessels, -30.0, 90.0))
    results, _ = run(fuser, vessels, 0.0, 60.0, noise_px=0.5)
    for t, got, _ in results:
        for tid, m in got.items():
            assert m in (0, {1: 235000011, 2: 235000012}[tid]), (t, tid, m)
    late = [got for t, got, _ in results if t > 5.0]
    assert sum(g.get(1) == 235000011 and g.get(2) == 235000012 for g in late) / len(late) > 0.95


def test_ais_latency_and_no_future_reports():
    vessels = [Vessel(1, 235000021, 1000.0, 0.0, 0.0, 6.0)]
    reps = ais_reports(vessels, 30.0, 60.0)  # AIS starts at t=30
    fuser = Fuser(CAM, FusionSettings(no_ais_dwell_s=100.0), ais=reps)
    results, _ = run(fuser, vessels, 0.0, 40.0)
    assert all(not got.get(1) for t, got, _ in results if t < 30.0)
    assert any(got.get(1) == 235000021 for t, got, _ in results if t > 34.0)


def test_self_calibration_recovers_heading_and_tilt():
    vessels = scene()[:3]
    true_cam = CAM.with_pose(pan_deg=POSE.pan_deg + 1.2, tilt_deg=POSE.tilt_deg - 0.25)
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports(vessels, -60.0, 120.0))
    rng = np.random.default_rng(1)
    t = 0.0
    while t <= 90.0:
        trk = render_tracks(vessels, t, cam=true_cam, rng=rng, noise_px=1.0)
        # boxes rendered by the true camera are interpreted with the nominal one
        fuser.update(trk, None, t)
        t += 0.5
    cal = fuser.calibration
    # azimuth of the box centre vs the antenna (centre here): pan offset = true - nominal
    assert cal["pan_offset_deg"] == pytest.approx(1.2, abs=0.1)
    assert cal["tilt_offset_deg"] == pytest.approx(-0.25, abs=0.06)
    # the uncertainty allows for the unknown antenna position along each hull; the offsets are significant
    assert 0 < cal["pan_sigma_deg"] < 0.5 * abs(cal["pan_offset_deg"])
    assert 0 < cal["tilt_sigma_deg"] < 0.5 * abs(cal["tilt_offset_deg"])
    assert cal["n_samples"] >= 30 and cal["n_vessels"] == 3


def test_radar_tracks_give_range_without_ais():
    vessels = [Vessel(1, 0, 1200.0, 100.0, 0.0, -3.0)]
    plots = []
    for t in np.arange(-10.0, 30.0, 2.0):
        e, n = vessels[0].enu(t)
        lat, lon, _ = CAM.enu_to_geodetic(e, n, 0.0)
        plots.append((t, 77, lat, lon, np.nan, np.nan, 3.0, 180.0))
    fuser = Fuser(CAM, FusionSettings(no_ais_dwell_s=1000.0), radar=np.array(plots, RADAR_DTYPE))
    results, _ = run(fuser, vessels, 0.0, 20.0)
    out = results[-1][2]
    assert out.mmsi[0] == 0
    e, n = vessels[0].enu(results[-1][0])
    lat, lon, _ = CAM.enu_to_geodetic(e, n, 0.0)
    assert out.world[0, 0] == pytest.approx(lat, abs=2e-5) and out.world[0, 1] == pytest.approx(lon, abs=2e-5)
    assert any(p.sources == ("camera", "radar") for p in fuser.picture())


# ---------------------------------------------------------------------------------- alerts
def test_ais_not_seen_and_occlusion():
    seen = Vessel(1, 235000031, 800.0, 0.0, 0.0, 0.5, length_m=40.0)
    hidden = Vessel(2, 235000032, 2000.0, 10.0, 0.0, 0.5)  # behind vessel 1: occluded, no alert
    absent = Vessel(3, 235000033, 1500.0, -600.0, 0.0, 1.0)  # in view, not tracked: alert
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports([seen, hidden, absent], -30.0, 60.0))
    _, alerts = run(fuser, [seen], 0.0, 30.0)
    kinds = [(a.kind, a.mmsi) for a in alerts]
    assert kinds == [("ais_not_seen", 235000033)]
    a = alerts[0]
    assert FusionSettings().ais_unseen_dwell_s <= a.t_s <= FusionSettings().ais_unseen_dwell_s + 1.0
    assert "inside the camera view" in a.message
    # hidden vessel stays in the fused picture from AIS alone
    assert any(p.mmsi == 235000032 and p.sources == ("ais",) and p.track_id == -235000032 for p in fuser.picture())


def test_spoofing_of_a_matched_vessel():
    v = Vessel(1, 235000041, 1200.0, 0.0, 0.0, 3.0, ais_offset_m=(0.0, 900.0), spoof_after_s=20.0)
    other = Vessel(2, 235000042, 900.0, -300.0, 0.0, 2.0)
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports([v, other], -30.0, 80.0))
    results, alerts = run(fuser, [v, other], 0.0, 50.0)
    assert any(got.get(1) == 235000041 for t, got, _ in results if 10 < t < 20)
    spoof = [a for a in alerts if a.kind == "possible_spoofing"]
    assert spoof and spoof[0].mmsi == 235000041 and spoof[0].track_id == 1
    assert 20.0 < spoof[0].t_s < 20.0 + 20.0
    assert not [a for a in alerts if a.kind == "possible_spoofing" and a.mmsi == 235000042]


def test_alerts_jsonl_round_trip(tmp_path):
    vessels = scene()
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports(vessels, -60.0, 60.0))
    _, alerts = run(fuser, vessels, 0.0, 12.0)
    assert alerts
    p = write_alerts_jsonl(alerts, tmp_path / "alerts.jsonl", append=False)
    back = read_alerts_jsonl(p)
    assert [a.to_dict() for a in back] == [a.to_dict() for a in alerts]
    assert '"kind": "no_ais"' in p.read_text()


def test_build_fuser_from_config_and_file(tmp_path):
    from pyais import encode_dict

    from seawatch.config import load_config

    lat, lon, _ = CAM.enu_to_geodetic(1000.0, 0.0, 0.0)
    s = encode_dict({"msg_type": 1, "mmsi": 235000051, "lat": float(lat), "lon": float(lon)}, talker_id="AI",
                    sentence_type="VDM")[0]
    p = tmp_path / "ais.nmea"
    p.write_text(f"1000.0 {s}\n")
    cfg = load_config(overrides=["fusion.ais_time_offset_s=1000.0"])
    f = build_fuser(cfg, ais=str(p), camera=CAM)
    f.update(Tracks.empty(0.0, 0), None, 0.0)
    assert len(f.ais) == 1 and f.summary()["ais_input"]["reports"] == 1
    with pytest.raises(ValueError, match="camera"):
        build_fuser(cfg, ais=str(p), camera=None)


# ----------------------------------------------------------------------------------- theta
def _velocity_pairs(theta_deg, n, rng, outliers=0):
    ref = rng.normal(0, 4.0, (n, 2))
    cam = rotate_cw(ref, -theta_deg) + rng.normal(0, 0.15, (n, 2))
    if outliers:
        cam[:outliers] = rng.normal(0, 4.0, (outliers, 2))
    return cam, ref


def test_theta_robust_estimate_recovers_rotation():
    rng = np.random.default_rng(3)
    cam, ref = _velocity_pairs(7.5, 60, rng, outliers=12)
    est = estimate_theta_robust(cam, ref)
    assert est.theta_deg == pytest.approx(7.5, abs=0.6)
    assert 0 < est.sigma_deg < 1.0 and est.n_inliers >= 40
    # unknown association: consensus over all combinations
    cam, ref = _velocity_pairs(-12.0, 8, rng)
    est = estimate_theta_robust(cam, ref, pairs=False)
    assert est.theta_deg == pytest.approx(-12.0, abs=1.5)


def test_theta_policy_gradient_from_15_degrees():
    rng = np.random.default_rng(4)
    frames = []
    for _ in range(10):
        cam, ref = _velocity_pairs(-4.0, 5, rng)
        perm = rng.permutation(5)
        frames.append((cam, ref[perm]))
    theta, hist = calibrate_theta_pg(frames, theta0_deg=15.0, seed=0, n_iter=80)
    assert theta == pytest.approx(-4.0, abs=1.5)
    assert abs(hist[0] - 15.0) < 3.0
    r, c, _ = match_velocities(frames[0][0], frames[0][1], theta)
    perm_inv = {int(j): i for i, j in enumerate(frames and np.argsort(np.argsort(c)))}
    assert len(r) == 5
    # matching after calibration pairs each camera vector with its own reference vector
    cam, ref = _velocity_pairs(-4.0, 5, np.random.default_rng(9))
    r, c, _ = match_velocities(cam, ref, theta)
    assert (r == c).all()
    assert perm_inv is not None


def test_window_associator_hysteresis_and_support():
    a = WindowAssociator(window_s=5.0, gate=3.0, min_support_s=1.0)
    keys = np.array([101, 102])
    # track 7 close to 101, then briefly closer to 102: the identity holds
    for k in range(20):
        t = k * 0.5
        d2 = np.array([[0.5, 8.0]]) if not (10 <= k <= 11) else np.array([[4.0, 0.5]])
        out, conf = a.update(t, np.array([7]), keys, d2)
        if t < 1.0:
            assert out[0] == 0  # not enough support yet
    assert out[0] == 101


def test_window_associator_withholds_a_new_identity_while_two_targets_fit():
    """Two AIS targets behind one camera track: no new identity until one clearly leads."""
    keys = np.array([101, 102])
    strict = WindowAssociator(window_s=5.0, gate=3.0, min_support_s=1.0, ambiguity_margin=1.0)
    plain = WindowAssociator(window_s=5.0, gate=3.0, min_support_s=1.0, ambiguity_margin=0.0)
    out_s = out_p = None
    for k in range(12):  # 6 s with both targets on the track (102 a hair closer)
        d2 = np.array([[0.6, 0.5]])
        out_s, _ = strict.update(k * 0.5, np.array([7]), keys, d2)
        out_p, _ = plain.update(k * 0.5, np.array([7]), keys, d2)
        assert out_s[0] == 0
    assert out_p[0] == 102  # without the rule the hair decides
    for k in range(12, 40):  # 102 moves off the track (the crossing ends)
        d2 = np.array([[0.5, 12.0]])
        out_s, _ = strict.update(k * 0.5, np.array([7]), keys, d2)
    assert out_s[0] == 101
    # a target another track holds does not make the pair ambiguous
    both = WindowAssociator(window_s=5.0, gate=3.0, min_support_s=1.0, ambiguity_margin=1.0)
    for k in range(12):
        out_b, _ = both.update(k * 0.5, np.array([7, 8]), keys, np.array([[0.5, 0.6], [8.0, 0.5]]))
    assert list(out_b) == [101, 102]
    # an identity already held is kept when a second target comes close (hysteresis, not ambiguity)
    for k in range(40, 46):
        out_s, _ = strict.update(k * 0.5, np.array([7]), keys, np.array([[0.5, 0.5]]))
    assert out_s[0] == 101


def test_no_ais_alert_once_per_vessel_and_not_for_fragments():
    rib = Vessel(1, 0, 700.0, -200.0, 0.0, 3.0, length_m=8.0)
    ship = Vessel(2, 235000061, 1500.0, 250.0, 0.0, -1.0, length_m=80.0)
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports([rib, ship], -60.0, 60.0))
    rng = np.random.default_rng(0)
    alerts = []
    for k in range(0, 301):
        t = k * 0.1
        trk = render_tracks([rib, ship], t, rng=rng, noise_px=0.5)
        ids = trk.ids.copy()
        ids[ids == 1] = 1 if t < 15.0 else 11  # the RIB is lost and re-tracked under a new id
        boxes = trk.boxes.copy()
        # a fragment of the ship's box (e.g. its wake) tracked separately
        b = boxes[ids == 2][0]
        frag = np.array([[b[0] - 0.5 * b[2], b[1] + 0.5 * b[3], 0.4 * b[2], 0.5 * b[3]]])
        tr = Tracks(t, k, np.concatenate([ids, [99]]), np.vstack([boxes, frag]))
        _, al = fuser.update(tr, None, t)
        alerts += al
    no_ais = [a for a in alerts if a.kind == "no_ais"]
    assert [a.track_id for a in no_ais] == [1]  # not again for id 11, never for the fragment 99
    assert no_ais[0].t_s <= 6.0


def test_swaying_camera_common_elevation_error_is_measured():
    # the camera's tilt sways by +-0.4 deg (common to every vessel); per-frame alignment measures it
    vessels = [Vessel(1, 235000071, 3000.0, 400.0, 0.0, -3.0, length_m=60.0),
               Vessel(2, 235000072, 2200.0, -300.0, -1.0, 2.0, length_m=40.0),
               Vessel(3, 235000073, 1600.0, 100.0, 0.5, 1.0, length_m=25.0)]
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports(vessels, -60.0, 60.0))
    rng = np.random.default_rng(5)
    err, ok, total = [], 0, 0
    truth = {v.tid: v.mmsi for v in vessels}
    for k in range(0, 400):
        t = k * 0.1
        sway = 0.4 * math.sin(2 * math.pi * 0.7 * t)
        cam = CAM.with_pose(tilt_deg=POSE.tilt_deg + sway)
        out, _ = fuser.update(render_tracks(vessels, t, cam=cam, rng=rng, noise_px=0.3), None, t)
        if t > 8.0:
            # boxes appear lower when the camera tilts up: the AIS-minus-camera residual is +sway
            err.append(fuser.frame_el_offset_deg - sway)
            ok += sum(int(m == truth[i]) for i, m in zip(out.ids.tolist(), out.mmsi.tolist()))
            total += len(out)
    err = np.abs(np.array(err))
    # measured in (almost) every frame once two vessels are identified; without it the error is the sway (0.4)
    assert np.median(err) < 0.03 and np.percentile(err, 90) < 0.05
    assert ok / total > 0.97
    fuser_off = Fuser(CAM, FusionSettings(frame_align_min_pairs=0), ais=ais_reports(vessels, -60.0, 60.0))
    fuser_off.update(render_tracks(vessels, 0.0), None, 0.0)
    assert fuser_off.frame_el_offset_deg == 0.0


# ------------------------------------------------- "no AIS": reporting intervals, plausibility, wakes
def test_ais_report_interval_table():
    from seawatch.fuse import ais_report_interval_s

    kn = 1852.0 / 3600.0
    assert ais_report_interval_s(1.0 * kn) == 180.0  # nearly stopped, class A: 3 minutes
    assert ais_report_interval_s(10.0 * kn) == 10.0
    assert ais_report_interval_s(15.0 * kn) == 6.0
    assert ais_report_interval_s(30.0 * kn) == 2.0
    assert ais_report_interval_s(float("nan")) == 180.0  # unknown speed: the slowest rate
    assert ais_report_interval_s(1.0 * kn, "B") == 180.0 and ais_report_interval_s(5.0 * kn, "B") == 30.0
    assert np.array_equal(ais_report_interval_s(np.array([1.0, 10.0, 30.0]) * kn), [180.0, 10.0, 2.0])
    with pytest.raises(ValueError):
        ais_report_interval_s(1.0, "C")


def _no_ais_times(alerts):
    out = {}
    for a in alerts:
        if a.kind == "no_ais":
            out.setdefault(a.track_id, a.t_s)
    return out


def test_no_ais_waits_for_the_reporting_interval_of_a_vessel_at_that_speed():
    fast = Vessel(8, 0, 800.0, 0.0, 0.0, 8.0, length_m=8.0)  # 15.5 kn across the line of sight
    slow = Vessel(9, 0, 700.0, -250.0, 0.0, 0.8, length_m=12.0)  # 1.6 kn: AIS class A reports every 3 min
    ship = Vessel(1, 235000081, 2000.0, 600.0, 0.0, 2.0, length_m=60.0)
    # cold start: the AIS feed starts with the video (first report at t = 0)
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports([ship], 0.0, 60.0))
    _, alerts = run(fuser, [fast, slow, ship], 0.0, 30.0)
    got = _no_ais_times(alerts)
    # 6 s (class A at 14-23 kn) + 2 s tolerated latency of AIS; not the 5 s dwell alone
    assert 8.0 - 1e-6 <= got[8] <= 8.5
    assert 9 not in got  # a slow vessel cannot be told from an unheard class A one for 3 minutes
    assert "class B" in next(a.message for a in alerts if a.track_id == 8)
    # tolerating a lost first report of a vessel never heard: two intervals + latency
    fuser = Fuser(CAM, FusionSettings(no_ais_unheard_lost_reports=1), ais=ais_reports([ship], 0.0, 60.0))
    _, alerts = run(fuser, [fast, slow, ship], 0.0, 30.0)
    got = _no_ais_times(alerts)
    assert 14.0 - 1e-6 <= got[8] <= 14.5 and 9 not in got
    # a warm feed (live for minutes): both after the 5 s dwell
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports([ship], -200.0, 60.0))
    _, alerts = run(fuser, [fast, slow, ship], 0.0, 30.0)
    got = _no_ais_times(alerts)
    assert set(got) == {8, 9} and max(got.values()) <= FusionSettings().no_ais_dwell_s + 0.5


class _SilentListener:
    def poll(self):
        return []


def test_no_ais_with_a_live_listener_counts_from_when_listening_starts():
    fast = Vessel(8, 0, 800.0, -800.0, 0.0, 8.0, length_m=8.0)  # at (800, 0) at t = 100 s
    fuser = Fuser(CAM, FusionSettings(), ais=_SilentListener())
    _, alerts = run(fuser, [fast], 100.0, 115.0)
    got = _no_ais_times(alerts)
    assert 108.0 - 1e-6 <= got[8] <= 108.5


def _fragment_run(static: bool):
    # a 200 m ship whose AIS antenna is 160 m ahead of the part of the hull the detector boxes
    ship = Vessel(1, 235000091, 1500.0, 0.0, 0.0, 2.0, length_m=200.0)
    reps = [r for r in ais_reports([ship], -60.0, 60.0) if static or r.msg_type != 5]
    fuser = Fuser(CAM, FusionSettings(), ais=reps)
    alerts = []
    for k in range(0, 76):
        t = k * 0.2
        e, n = ship.enu(t)
        u, v, _ = CAM.enu_to_pixel(e, n - 160.0, 0.0)
        w = 40.0 * CAM.intrinsics.fx / math.hypot(e, n - 160.0)
        tr = Tracks(t, k, np.array([5]), np.array([[u - w / 2, v - 0.3 * w, w, 0.3 * w]]))
        alerts += fuser.update(tr, None, t)[1]
    return [a for a in alerts if a.kind == "no_ais"]


def test_no_ais_not_raised_for_a_box_on_part_of_a_long_vessel():
    assert _fragment_run(static=True) == []  # the reported length (message 5) covers the box
    assert [a.track_id for a in _fragment_run(static=False)] == [5]  # unknown length: the box is 6 deg away


def _upper_box_run(box_height_deg: float):
    # a ship at 1000 m boxed whole (track 1) and, by a second track, only above 0.5 deg over its waterline
    ship = Vessel(1, 235000095, 1000.0, 0.0, 0.0, 2.0, length_m=60.0)
    fuser = Fuser(CAM, FusionSettings(), ais=ais_reports([ship], -60.0, 60.0))
    px = CAM.intrinsics.fy * math.pi / 180.0  # pixels per degree
    alerts = []
    for k in range(0, 76):
        t = k * 0.2
        full = render_tracks([ship], t)
        b = full.boxes[0]
        bottom = b[1] + b[3] - 0.5 * px
        up = np.array([b[0], bottom - box_height_deg * px, b[2], box_height_deg * px])
        tr = Tracks(t, k, np.array([1, 7]), np.vstack([b, up]))
        alerts += fuser.update(tr, None, t)[1]
    return [a for a in alerts if a.kind == "no_ais"]


def test_no_ais_not_raised_for_a_box_on_the_upper_part_of_a_hull():
    # its bottom 0.5 deg above the waterline puts it 1.8x farther than the ship, but a box that tall
    # can be the upper part of the ship's hull
    assert _upper_box_run(0.8) == []
    assert [a.track_id for a in _upper_box_run(0.1)] == [7]  # a thin strip that far above is something else


def _wake_run(wake_s: float):
    # an AIS vessel crosses at 12 m/s; where it was at t = 3 s a patch of foam is tracked from 5 to 16 s
    ship = Vessel(1, 235000097, 800.0, -200.0, 0.0, 12.0, length_m=20.0)
    fuser = Fuser(CAM, FusionSettings(wake_s=wake_s), ais=ais_reports([ship], -200.0, 60.0))
    foam = Vessel(6, 0, *ship.enu(3.0), 0.0, 0.0, length_m=8.0)
    alerts = []
    for k in range(0, 101):
        t = k * 0.2
        tr = render_tracks([ship, foam] if 5.0 <= t <= 16.0 else [ship], t)
        alerts += fuser.update(tr, None, t)[1]
    return [a for a in alerts if a.kind == "no_ais"]


def test_no_ais_not_raised_for_a_track_born_on_a_vessels_trail():
    assert _wake_run(10.0) == []
    assert [a.track_id for a in _wake_run(0.0)] == [6]  # without the wake rule: a false "no AIS"


@pytest.mark.parametrize("key, value", [("wake_s", -1.0), ("wake_s", float("nan")), ("no_ais_dwell_s", -5.0),
                                        ("ais_warmup_s", float("inf"))])
def test_invalid_time_settings_are_rejected_naming_the_key(key, value):
    with pytest.raises(ValueError, match=f"'{key}'"):
        Fuser(CAM, FusionSettings(**{key: value}))


def test_a_re_born_track_inherits_the_no_ais_flag_within_the_range_error():
    """The waterline range of a box is uncertain by ``range_frac``: a vessel re-tracked 2 s later
    100 m further out at 500 m is the same vessel; one 400 m away, or after a minute, is not."""
    fuser = Fuser(CAM, FusionSettings(range_frac=0.3))
    fuser._no_ais_last = {1: (10.0, 0.0, 500.0)}  # flagged track 1, last seen at 10 s, 500 m north
    assert fuser._inherits_no_ais(2, 12.0, 0.0, 600.0)
    assert not fuser._inherits_no_ais(2, 12.0, 0.0, 900.0)
    strict = Fuser(CAM, FusionSettings(range_frac=0.0))
    strict._no_ais_last = {1: (10.0, 0.0, 500.0)}
    assert not strict._inherits_no_ais(2, 12.0, 0.0, 600.0)  # without the range error: 100 m > 50 m
    fuser._no_ais_last = {1: (10.0, 0.0, 500.0)}
    assert not fuser._inherits_no_ais(2, 75.0, 0.0, 500.0)  # forgotten after 60 s


def test_track_angles_use_the_camera_pixel_centre_convention():
    """A box whose bottom edge centre sits on the principal point (edge coordinates) lies on the optical axis."""
    from seawatch.fuse.associate import track_angles, waterline_px

    K = CAM.intrinsics
    w, h = 10.0, 6.0
    # edge coordinate cx + 0.5 is the centre of pixel cx
    box = np.array([[K.cx + 0.5 - w / 2, K.cy + 0.5 - h, w, h]])
    u, v = waterline_px(box)
    assert u[0] == pytest.approx(K.cx) and v[0] == pytest.approx(K.cy)
    ta = track_angles(CAM, box)
    az, el = CAM.pixel_to_azel(np.array([K.cx]), np.array([K.cy]))
    assert ta.az_deg[0] == pytest.approx(float(az[0]) % 360.0, abs=1e-9)
    assert ta.el_deg[0] == pytest.approx(float(el[0]), abs=1e-9)
    # the old convention (no shift) would be half a pixel off: about 0.023 deg at 60 deg / 1280 px
    az_old, _ = CAM.pixel_to_azel(np.array([K.cx + 0.5]), np.array([K.cy + 0.5]))
    assert abs(float(az_old[0]) - float(az[0])) > 0.01


def test_a_box_much_longer_than_the_reported_length_does_not_take_that_identity():
    # a 70 m ferry (its AIS not heard) passes in front of an 11 m boat 1.5x farther away at the same
    # bearing, which the camera does not track on its own: the ferry's box (70 m at its range,
    # 105 m at the boat's) cannot be the boat's hull of 11 m
    ferry = Vessel(1, 0, 700.0, -40.0, 0.0, 6.0, length_m=70.0)
    boat = Vessel(2, 235000101, 1050.0, 0.0, 0.0, 0.5, length_m=11.0)
    reps = ais_reports([boat], -60.0, 60.0)

    def labels(settings):
        fuser = Fuser(CAM, settings, ais=reps)
        res, _ = run(fuser, [ferry], 0.0, 12.0)
        return [got.get(1, 0) for _, got, _ in res]

    assert set(labels(FusionSettings())) == {0}
    assert 235000101 in labels(FusionSettings(max_box_length_ratio=0.0))  # the check off: it would


def _merge_run(settings, t1=50.0):
    """An 8 m boat with AIS, labelled, whose box merges with a passing 60 m hull from 25 s to
    45 s (the box grows to cover both, its bottom still on the boat's waterline)."""
    boat = Vessel(1, 235000111, 600.0, -60.0, 0.0, 3.0, length_m=8.0)
    fuser = Fuser(CAM, settings, ais=ais_reports([boat], -60.0, 60.0))
    rng = np.random.default_rng(0)
    alerts, labels = [], []
    for k in range(int(round(t1 * 5)) + 1):
        t = k / 5.0
        tr = render_tracks([boat], t, rng=rng)
        if 25.0 <= t < 45.0:  # the hull beside the boat joins the box
            e, n = boat.enu(t)
            tr.boxes[0, 2] += 60.0 * CAM.intrinsics.fx / math.hypot(e, n)
        out, al = fuser.update(tr, None, t)
        alerts += al
        labels.append((t, int(out.mmsi[0])))
    return alerts, labels


def test_a_box_growing_by_a_merge_is_not_a_spoofing_alert():
    alerts, labels = _merge_run(FusionSettings())
    assert any(m == 235000111 for t, m in labels if 10.0 < t < 25.0)  # labelled before the merge
    assert not [a for a in alerts if a.kind == "possible_spoofing"]
    assert all(m == 235000111 for t, m in labels if t > 48.0)  # and after it
    alerts, _ = _merge_run(FusionSettings(max_box_length_ratio=0.0))
    assert not [a for a in alerts if a.kind == "possible_spoofing"]


def _big_ship_labels(settings, length_m):
    # a 40 m ship whose AIS static data reports length_m
    ship = Vessel(1, 235000121, 900.0, -50.0, 0.0, 4.0, length_m=40.0)
    reps = [dataclasses.replace(r, length_m=length_m) if r.msg_type == 5 else r
            for r in ais_reports([ship], -60.0, 60.0)]
    fuser = Fuser(CAM, settings, ais=reps)
    res, _ = run(fuser, [ship], 0.0, 12.0)
    return [got.get(1, 0) for t, got, _ in res if t > 5.0]


def test_the_size_gate_ignores_an_implausibly_short_reported_length():
    # a misconfigured AIS length (1 + 1 m) would keep a 40 m ship unlabelled: below
    # box_length_min_reported_m (3 m) the reported length is not trusted
    assert set(_big_ship_labels(FusionSettings(), 2.0)) == {235000121}
    assert set(_big_ship_labels(FusionSettings(box_length_min_reported_m=1.0), 2.0)) == {0}
    # a length of 4 m is trusted: the 40 m box is not that vessel
    assert set(_big_ship_labels(FusionSettings(), 4.0)) == {0}
    # an unknown (NaN) length rules nothing out
    assert set(_big_ship_labels(FusionSettings(), float("nan"))) == {235000121}


@pytest.mark.parametrize("key, value", [("max_box_length_ratio", float("nan")), ("max_box_length_ratio", -1.0),
                                        ("max_box_length_ratio", 0.5), ("max_box_length_ratio", float("inf")),
                                        ("box_length_margin_m", -1.0), ("box_length_margin_m", float("nan")),
                                        ("box_length_min_reported_m", -1.0),
                                        ("box_length_min_reported_m", float("inf"))])
def test_invalid_size_gate_settings_are_rejected_naming_the_key(key, value):
    with pytest.raises(ValueError, match=f"'{key}'"):
        Fuser(CAM, FusionSettings(**{key: value}))
    Fuser(CAM, FusionSettings(max_box_length_ratio=0.0))  # 0: off
    Fuser(CAM, FusionSettings(max_box_length_ratio=1.0, box_length_margin_m=0.0))


def test_a_size_gated_pair_is_not_far_for_the_spoofing_check(monkeypatch):
    # without the held-identity exemption the merged box loses its label (the size gate removes
    # the pair); the spoofing check must read the removed pair as "not comparable", not as "far"
    orig = Fuser._distance
    monkeypatch.setattr(Fuser, "_distance", lambda self, ta, st, tg, held=None: orig(self, ta, st, tg, None))
    alerts, labels = _merge_run(FusionSettings())
    assert any(m == 0 for t, m in labels if 30.0 < t < 45.0)  # the label was lost during the merge
    assert not [a for a in alerts if a.kind == "possible_spoofing"]
