"""PTracking global layer (paper A, Fig. 9): two unsynchronised cameras with overlapping views."""

import numpy as np
import pymap3d
import pytest

from seawatch.camera import CameraModel, Intrinsics
from seawatch.track.distributed import GlobalLayer, make_beliefs
from seawatch.track.ptracking import BELIEF_DTYPE, PTrackingTracker
from seawatch.types import CameraPose, Detections

W, H = 704, 576
LAT0, LON0 = 44.0, 8.0
B_EAST_M = 250.0  # camera B stands 250 m east of camera A


def _cameras():
    lat_b, lon_b, _ = pymap3d.enu2geodetic(B_EAST_M, 0.0, 0.0, LAT0, LON0, 0.0)
    k = Intrinsics.from_fov(60.0, W, H)
    a = CameraModel(k, CameraPose(LAT0, LON0, 40.0, pan_deg=0.0, tilt_deg=-8.0))
    b = CameraModel(k, CameraPose(float(lat_b), float(lon_b), 40.0, pan_deg=-25.0, tilt_deg=-8.0))
    return a, b


def _boats(t):
    """ENU (camera A frame) of three boats at time t: id -> (e, n)."""
    return {
        1: (-150.0 + 6.0 * t, 250.0),  # crosses from A's view into the overlap
        2: (60.0 - 3.0 * t, 330.0),  # in the overlap, heading west
        3: (20.0, 180.0 + 1.0 * t),  # in the overlap, slowly north
    }


def _detect(cam, offset_e, t, rng, noise_px=0.7):
    """Boxes (40 m long, 12 m high boats) of the boats this camera sees, with their ids."""
    ids, boxes = [], []
    for bid, (e, n) in _boats(t).items():
        u, v, depth = cam.enu_to_pixel(e - offset_e, n, 0.0)
        if not depth > 0:
            continue
        w = cam.intrinsics.fx * 40.0 / depth
        h = cam.intrinsics.fy * 12.0 / depth
        box = np.array([u - w / 2, v - h, w, h]) + rng.normal(0.0, noise_px, 4)
        if box[0] > 0 and box[0] + box[2] < W and box[1] > 0 and box[1] + box[3] < H:
            ids.append(bid)
            boxes.append(box)
    return ids, np.array(boxes).reshape(-1, 4)


def _to_world(cam, offset_e):
    def f(p):
        e, n, _ = cam.pixel_to_sea_enu(p[:, 0], p[:, 1])
        return np.column_stack([e + offset_e, n])

    return f


def _run(extrapolate=True, dur_s=20.0, fail_b_at=None, b_period_s=1 / 7.0):
    cam_a, cam_b = _cameras()
    sensors = [  # name, camera, east offset, period, phase: 10 fps and 7 fps, not in step
        ("A", cam_a, 0.0, 0.1, 0.0),
        ("B", cam_b, B_EAST_M, b_period_s, 0.037),
    ]
    events = sorted((ph + k * per, name) for name, _, _, per, ph in sensors
                    for k in range(int(dur_s / per)) if ph + k * per < dur_s)
    info = {name: (cam, off) for name, cam, off, _, _ in sensors}
    local = {name: PTrackingTracker(seed=i, image_width_px=W) for i, (name, *_) in enumerate(sensors)}
    glob = GlobalLayer(delta=40.0, window_s=1.0, decay_s=0.5, extrapolate=extrapolate, seed=0)
    rng = np.random.default_rng(0)
    log = []
    seen_by = {name: set() for name in info}
    first_seen = {}
    for t, name in events:
        if fail_b_at is not None and name == "B" and t >= fail_b_at:
            continue
        cam, off = info[name]
        ids, boxes = _detect(cam, off, t, rng)
        seen_by[name] |= set(ids)
        for b in ids:
            first_seen.setdefault(b, t)
        local[name].update(Detections(t, 0, boxes, np.ones(len(boxes)), camera_id=name))
        glob.publish(local[name].beliefs(name, _to_world(cam, off)))
        est = glob.update(t)
        log.append((t, est))
    return log, seen_by, first_seen


def test_two_unsynchronised_cameras_fuse_into_one_picture():
    log, seen_by, first_seen = _run()
    assert first_seen[1] > 3.0  # boat 1 comes into view later
    assert 1 in seen_by["A"] and 1 in seen_by["B"] and {2, 3} <= seen_by["A"] & seen_by["B"]
    ids_of = {1: [], 2: [], 3: []}
    errs = []
    n_tracks = []
    for t, est in log:
        truth = {b: p for b, p in _boats(t).items() if t > first_seen[b] + 1.0}
        if not truth:
            continue
        if not any(first_seen[b] <= t <= first_seen[b] + 1.0 for b in first_seen):
            n_tracks.append(len(est) == len(truth))  # (not while a boat is being confirmed)
        for bid, (e, n) in truth.items():
            d = np.linalg.norm(est.means - [e, n], axis=1) if len(est) else np.array([np.inf])
            k = int(np.argmin(d))
            errs.append(d[k])
            ids_of[bid].append(int(est.ids[k]))
    assert np.median(errs) < 4.0 and np.percentile(errs, 95) < 10.0
    for bid in ids_of:  # one global identity per boat, through the handover from A to A+B
        assert len(set(ids_of[bid])) == 1, (bid, sorted(set(ids_of[bid])))
    assert len({ids_of[b][0] for b in ids_of}) == 3
    assert np.mean(n_tracks) > 0.97  # no duplicates from the two views
    # the boats in the overlap are fed by both sensors
    sources = [s for _, est in log[-20:] for s in est.sources]
    assert any({k[0] for k in s} == {"A", "B"} for s in sources)


def test_extrapolation_compensates_unsynchronised_reports():
    # two sensors report a 10 m/s target at 2 Hz each, a quarter second apart; the picture is
    # asked for at 10 Hz, between reports
    rng = np.random.default_rng(3)

    def err(extrapolate):
        g = GlobalLayer(delta=10.0, window_s=1.0, decay_s=0.5, extrapolate=extrapolate, seed=0)
        out = []
        for k in range(100):
            t = k * 0.1
            for name, phase in (("A", 0.0), ("B", 0.25)):
                if abs((t - phase) % 0.5) < 1e-9 or abs((t - phase) % 0.5 - 0.5) < 1e-9:
                    pos = np.array([[10.0 * t, 0.0]]) + rng.normal(0.0, 0.3, (1, 2))
                    g.publish(make_beliefs(name, [1], t, pos, [1.0], velocities=[[10.0, 0.0]]))
            est = g.update(t)
            if t > 1.0:
                assert len(est) == 1
                out.append(abs(est.means[0, 0] - 10.0 * t))
        return np.mean(out)

    with_x, without = err(True), err(False)
    assert with_x < 0.5 and without > 1.0


def test_a_silent_sensor_ages_out():
    log, _, _ = _run(dur_s=12.0, fail_b_at=6.0)
    # boat 1 starts outside B's view: only A sees it at first; after B fails, A alone carries on
    last_t, last = log[-1]
    assert len(last) == 3 and all({k[0] for k in s} == {"A"} for s in last.sources)
    # right after the failure B's beliefs still count; a window later they are gone
    mid = [est for t, est in log if 6.2 < t < 6.6]
    assert any("B" in {k[0] for s in est.sources for k in s} for est in mid)
    late = [est for t, est in log if t > 7.2]
    assert all("B" not in {k[0] for s in est.sources for k in s} for est in late)


def test_global_layer_weights_beliefs_by_age_and_keeps_links():
    g = GlobalLayer(delta=5.0, window_s=1.0, decay_s=0.3, extrapolate=False, seed=1)
    # the same target reported by two sensors at different times and places (an old and a new report)
    g.publish(make_beliefs("A", [7], 0.0, [[0.0, 0.0]], [1.0]))
    g.publish(make_beliefs("B", [3], 0.6, [[1.5, 0.0]], [1.0]))
    est = g.update(0.6)
    assert len(est) == 1
    assert 1.3 < est.means[0, 0] < 1.6  # the fresh report (B) dominates
    assert set(est.sources[0]) == {("A", 7), ("B", 3)}
    gid = int(est.ids[0])
    same_age = GlobalLayer(delta=5.0, window_s=1.0, decay_s=0.3, extrapolate=False, seed=1)
    same_age.publish(make_beliefs("A", [7], 0.6, [[0.0, 0.0]], [1.0]))
    same_age.publish(make_beliefs("B", [3], 0.6, [[1.5, 0.0]], [1.0]))
    assert 0.55 < same_age.update(0.6).means[0, 0] < 0.95  # equal weights: halfway
    # with extrapolation the old report is moved along its velocity
    g2 = GlobalLayer(delta=5.0, window_s=1.0, decay_s=0.3, extrapolate=True, seed=1)
    g2.publish(make_beliefs("A", [7], 0.0, [[0.0, 0.0]], [0.5], velocities=[[5.0, 0.0]]))
    g2.publish(make_beliefs("B", [3], 0.6, [[3.0, 0.0]], [0.5], velocities=[[5.0, 0.0]]))
    e2 = g2.update(0.6)
    assert len(e2) == 1 and set(e2.sources[0]) == {("A", 7), ("B", 3)}
    np.testing.assert_allclose(e2.means[0], [3.0, 0.0], atol=0.3)
    # a belief older than the window is ignored
    est = g.update(1.4)
    assert est.sources[0] == (("B", 3),)
    # the link (sensor, local id) -> global id holds even after a jump beyond the gate
    g.publish(make_beliefs("B", [3], 1.5, [[40.0, 0.0]], [0.5]))
    est = g.update(1.5)
    assert list(est.ids) == [gid]
    # a new local id far away gets a new global id; malformed beliefs are counted and skipped
    bad = make_beliefs("A", [8, 9], 1.6, [[100.0, 0.0], [np.nan, 0.0]], [0.5, 0.5])
    g.publish(bad)
    assert g.n_rejected == 1
    est = g.update(1.6)
    assert len(est) == 2 and gid in est.ids
    with pytest.raises(TypeError):
        g.publish(np.zeros(2))


def test_beliefs_of_the_local_layer():
    tr = PTrackingTracker(seed=0)
    for i in range(6):
        tr.update(Detections(i * 0.1, i, np.array([[100.0 + 2 * i, 200.0, 40.0, 20.0]]), [1.0]))
    b = tr.beliefs("cam7")
    assert b.dtype == BELIEF_DTYPE and len(b) == 1
    assert b["sensor"][0] == "cam7" and b["t_s"][0] == pytest.approx(0.5)
    np.testing.assert_allclose(b["mean"][0], [130.0, 220.0], atol=1.5)  # bottom centre
    np.testing.assert_allclose(b["velocity"][0], [20.0, 0.0], atol=3.0)
    w = tr.beliefs("cam7", to_world=lambda p: p * 0.5 + 10.0)  # metres = px / 2 + 10
    np.testing.assert_allclose(w["mean"][0], b["mean"][0] * 0.5 + 10.0)
    np.testing.assert_allclose(w["velocity"][0], b["velocity"][0] * 0.5)
    np.testing.assert_allclose(w["sigma"][0], b["sigma"][0] * 0.5)
