"""Simulated AIS (NMEA round trip, intervals, noise, latency, spoofing) and radar."""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest
from pyais import decode

from seawatch.sim import AISConfig, Trajectory, World, make_scenario, make_vessel, simulate_ais
from seawatch.sim.ais import nmea_tag_block, report_interval_s


@pytest.fixture(scope="module")
def harbour():
    return make_scenario("harbour", seed=1, duration_s=60.0)


def _decode_all(nmea):
    """Decode (t, sentence) pairs, joining multi-fragment messages."""
    out, pending = [], []
    for t, s in nmea:
        parts = s.split(",")
        n_frag, frag = int(parts[1]), int(parts[2])
        pending.append(s.encode())
        if frag == n_frag:
            out.append((t, decode(*pending).asdict()))
            pending = []
    assert not pending
    return out


def test_nmea_decodes_to_the_reports(harbour):
    reps = harbour.ais_reports()
    nmea = harbour.ais_nmea()
    assert all(s.startswith("!AIVDM,") for _, s in nmea)
    dec = _decode_all(nmea)
    assert len(dec) == len(reps)
    n_pos = 0
    for (t, d), r in zip(dec, reps):
        assert t == r.t_s and d["mmsi"] == r.mmsi and d["msg_type"] == r.msg_type
        if r.has_position:
            n_pos += 1
            assert d["lat"] == pytest.approx(r.lat_deg, abs=1e-9)
            assert d["lon"] == pytest.approx(r.lon_deg, abs=1e-9)
            assert d["speed"] == pytest.approx(r.sog_kn, abs=1e-9)
            assert d["course"] == pytest.approx(r.cog_deg, abs=1e-9)
            assert d["heading"] == r.heading_deg
        elif r.msg_type == 5:
            assert d["shipname"] == r.name and d["callsign"] == r.callsign
            assert d["to_bow"] + d["to_stern"] == r.length_m
    assert n_pos > 10
    assert [r.t_s for r in reps] == sorted(r.t_s for r in reps)


def test_reports_follow_the_truth(harbour):
    tr = harbour.ais_truth()
    pos = tr[np.isfinite(tr["lat"])]
    ids = {v.mmsi: v for v in harbour.vessels}
    # AIS-off vessels never appear; every AIS vessel does
    assert set(tr["mmsi"]) == {m for m in ids if m}
    e, n, _ = pymap3d.geodetic2enu(pos["lat"], pos["lon"], 0.0, *harbour.origin, 0.0)
    et, nt, _ = pymap3d.geodetic2enu(pos["lat_true"], pos["lon_true"], 0.0, *harbour.origin, 0.0)
    honest = ~pos["spoofed"]
    err = np.hypot(e - et, n - nt)[honest]
    assert 1.0 < np.median(err) < 15.0 and err.max() < 60.0  # GNSS noise of a few metres
    # harbour's spoofed vessel: its reports after spoof_from_s carry the configured offset (plus noise)
    cfg = harbour.ais_config
    sp = pos["spoofed"]
    assert sp.any() and set(pos["mmsi"][sp]) == {cfg.spoof_mmsi}
    assert np.all(pos["t_tx_s"][sp] >= cfg.spoof_from_s)
    assert not np.any((pos["mmsi"] == cfg.spoof_mmsi) & (pos["t_tx_s"] >= cfg.spoof_from_s) & ~sp)
    off = np.hypot(e[sp] - et[sp] - cfg.spoof_offset_m[0], n[sp] - nt[sp] - cfg.spoof_offset_m[1])
    assert off.max() < 60.0
    # the true positions are the vessels' positions at the transmit times
    for row in pos[:20]:
        v = next(v for v in harbour.vessels if v.mmsi == row["mmsi"])
        ve, vn, _, _ = v.state(row["t_tx_s"])
        lat, lon, _ = pymap3d.enu2geodetic(ve, vn, 0.0, *harbour.origin, 0.0)
        assert lat == pytest.approx(row["lat_true"], abs=1e-9) and lon == pytest.approx(row["lon_true"], abs=1e-9)
    lat = pos["t_rx_s"] - pos["t_tx_s"]
    assert lat.min() >= 0 and lat.max() <= 5.0 and 0.2 < lat.mean() < 2.0


def test_reporting_intervals_by_class():
    assert report_interval_s("A", 10.0, False) == 10.0
    assert report_interval_s("A", 10.0, True) == pytest.approx(10 / 3)
    assert report_interval_s("A", 18.0, False) == 6.0
    assert report_interval_s("A", 30.0, False) == 2.0
    assert report_interval_s("A", 1.0, False) == 180.0
    assert report_interval_s("B", 5.0, False) == 30.0 and report_interval_s("B", 1.0, False) == 180.0
    rng = np.random.default_rng(0)
    a = make_vessel(1, "ferry", Trajectory(0, 1000, 90, ((1e9, 5.0, 0.0),)), rng, ais="A", mmsi=235000001)
    b = make_vessel(2, "sailboat", Trajectory(0, 2000, 90, ((1e9, 3.0, 0.0),)), rng, ais="B", mmsi=235000002)
    c = make_vessel(3, "rib", Trajectory(0, 500, 90, ((1e9, 8.0, 0.0),)), rng, ais=False)
    st = simulate_ais(World([a, b, c]), 50.0, -1.0, 300.0, AISConfig(drop_prob=0.0), seed=2)
    tr = st.truth
    for mmsi, expected, mtype in ((235000001, 10.0, 1), (235000002, 30.0, 18)):
        t = np.sort(tr["t_tx_s"][(tr["mmsi"] == mmsi) & (tr["msg_type"] == mtype)])
        assert np.median(np.diff(t)) == pytest.approx(expected, rel=0.05)
    assert 0 not in set(tr["mmsi"])
    assert {5, 24} <= set(tr["msg_type"].tolist())  # static data of both classes
    # a turning class A vessel reports every 3.3 s
    d = make_vessel(4, "tug", Trajectory(0, 800, 0, ((1e9, 4.0, 3.0),)), rng, ais="A", mmsi=235000004)
    st2 = simulate_ais(World([d]), 50.0, -1.0, 60.0, AISConfig(drop_prob=0.0), seed=2)
    t = np.sort(st2.truth["t_tx_s"][st2.truth["msg_type"] == 1])
    assert np.median(np.diff(t)) == pytest.approx(10 / 3, rel=0.05)


def test_spoofed_positions_in_open_sea():
    s = make_scenario("open_sea", duration_s=40.0)
    tr = s.ais_truth()
    sp = tr[tr["spoofed"]]
    assert len(sp) >= 2 and np.all(sp["t_tx_s"] >= 10.0)
    e, n, _ = pymap3d.geodetic2enu(sp["lat"], sp["lon"], 0.0, *s.origin, 0.0)
    et, nt, _ = pymap3d.geodetic2enu(sp["lat_true"], sp["lon_true"], 0.0, *s.origin, 0.0)
    off = np.hypot(e - et, n - nt)
    assert np.all(np.abs(off - math.hypot(1200, 600)) < 60)
    honest = tr[~tr["spoofed"] & np.isfinite(tr["lat"])]
    assert len(honest) > 5


def test_tag_block_checksum():
    line = nmea_tag_block(12.5, "!AIVDM,1,1,,A,13P;U:P01sOs0CFM3C5DlSm;P000,0*4E")
    assert line.startswith("\\c:12.500*")
    body, cs = line[1:].split("\\")[0].split("*")
    x = 0
    for ch in body:
        x ^= ord(ch)
    assert int(cs, 16) == x


def test_radar_plots_and_tracks(harbour):
    plots = harbour.radar_plots()
    tracks = harbour.radar_tracks()
    assert plots.dtype.names[:8] == ("t_s", "id", "lat", "lon", "range_m", "bearing_deg", "speed_mps", "course_deg")
    assert np.all(np.diff(plots["t_s"]) >= 0) and plots["t_s"].max() < harbour.duration_s
    real = plots[plots["truth_id"] > 0]
    assert (plots["truth_id"] == -1).any()  # clutter
    errs = []
    for p in real:
        v = next(v for v in harbour.vessels if v.id == p["truth_id"])
        e, n, _, _ = v.state(p["t_s"])
        pe, pn, _ = pymap3d.geodetic2enu(p["lat"], p["lon"], 0.0, *harbour.origin, 0.0)
        errs.append(math.hypot(pe - e, pn - n))
    assert np.median(errs) < 30 and len({int(x) for x in real["truth_id"]}) >= 4
    assert len(tracks) > 0 and np.all(np.isfinite(tracks["speed_mps"]))
    v1 = tracks[tracks["truth_id"] == 1]
    assert abs(np.median(v1["speed_mps"][-3:]) - 6.0) < 2.0  # the ferry's 6 m/s
