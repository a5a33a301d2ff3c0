"""The speed floor that follows how well the camera motion is known (``known_min_speed_px_s``,
session 21 H4): with the telemetry's exact camera motion a slow boat is not static."""

from __future__ import annotations

import numpy as np

from _feature_snap import Level
import pytest

from seawatch.detect.features import FeatureSnapshot
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer




def _scene(k, coast_speed, boat_speed=1.0, seed=0):
    """Frame ``k``: three coast features above the horizon (row 50) moving (relative to the
    camera) at ``coast_speed`` px/s in random directions, a boat of three features 20 px apart
    on the water moving right at ``boat_speed`` px/s, and two water features far away."""
    rng = np.random.default_rng(seed + 1000 * k)
    ang = rng.uniform(0, 2 * np.pi, 3)
    coast_v = coast_speed * np.c_[np.cos(ang), np.sin(ang)]
    xy = np.array([[20, 30], [60, 32], [100, 28],  # coast
                   [100 + boat_speed * 0.04 * k, 120], [120 + boat_speed * 0.04 * k, 122],
                   [140 + boat_speed * 0.04 * k, 118],  # boat
                   [250, 200], [20, 220]], float)  # water, far apart
    vel = np.vstack([coast_v, np.tile([boat_speed, 0.0], (3, 1)), [[0.3, 0.2], [-0.2, 0.1]]])
    hist = np.repeat(vel[:, None, :], 4, axis=1)
    n = len(xy)
    return FeatureSnapshot(
        t_s=0.04 * k, frame_index=k, ids=np.arange(n) + 10, slots=np.arange(n), xy=xy,
        size_px=np.full(n, 4.0), confidence=np.full(n, 6), stable=np.ones(n, bool),
        matched=np.ones(n, bool), velocity=hist[:, -1], history=hist, image_velocity=hist[:, -1],
        homography=np.eye(3), dt_s=0.04, n_keypoints=n, n_matched=n, shape=(240, 320),
    )


def _run(params, coast_speed, horizon=True, frames=12, boat_speed=1.0):
    c = FeatureClusterer(params)
    hz = Level(50) if horizon else None
    n_det = []
    for k in range(frames):
        dets, _ = c.update(_scene(k, coast_speed, boat_speed), horizon=hz)
        n_det.append(len(dets))
    return c, n_det


def _params(**kw):
    return ClusterParams(still_radius_px=0.0, relink_s=0.0, coast_s=0.0, confirm_s=0.0, **kw)


def test_on_by_default_and_slow_boat_static_when_off():
    assert ClusterParams().known_min_speed_px_s == 0.8 and ClusterParams().known_still_px == 0.1
    c, n_det = _run(_params(known_min_speed_px_s=0.0), coast_speed=0.1)
    assert max(n_det) == 0  # 1 px/s is below the 1.5 px/s floor: no edge, no cluster
    assert not np.isfinite(c.camera_err_px_s)  # not even measured when off
    assert c.min_speed_px_s == pytest.approx(1.5)


def test_known_camera_motion_lowers_floor_and_finds_slow_boat():
    c, n_det = _run(_params(known_min_speed_px_s=0.8), coast_speed=0.1)
    assert c.camera_err_px_s == pytest.approx(0.1, abs=1e-9)
    assert c.min_speed_px_s == pytest.approx(0.8)  # 2 x 0.1 held up to the 0.8 px/s minimum
    assert n_det[-1] == 1  # the boat is one cluster
    # the water features (0.36 and 0.22 px/s) stay static
    assert all(n <= 1 for n in n_det)


def test_large_camera_error_keeps_floor():
    # the coast moves 2 px/s relative to the camera (a mast's shake): the floor stays 1.5
    c, n_det = _run(_params(known_min_speed_px_s=0.8), coast_speed=2.0)
    assert c.camera_err_px_s == pytest.approx(2.0, abs=1e-9)
    assert c.min_speed_px_s == pytest.approx(1.5)
    assert max(n_det) == 0


def test_intermediate_error_and_smoothing():
    # the snapshots are 0.04 s apart: a time constant of 0.04 / ln 2 weighs the new frame 0.5
    p = _params(known_min_speed_px_s=0.8, known_err_k=2.0, known_err_tau_s=0.04 / np.log(2.0))
    c = FeatureClusterer(p)
    hz = Level(50)
    c.update(_scene(0, 0.6), horizon=hz)
    assert c.camera_err_px_s == pytest.approx(0.6)
    assert c.min_speed_px_s == pytest.approx(1.2)
    c.update(_scene(1, 0.2), horizon=hz)
    assert c.camera_err_px_s == pytest.approx(0.4)  # 0.5 * 0.6 + 0.5 * 0.2
    assert c.min_speed_px_s == pytest.approx(0.8)
    c.reset()
    assert not np.isfinite(c.camera_err_px_s) and c.min_speed_px_s == pytest.approx(1.5)


def test_no_horizon_no_estimate():
    c, n_det = _run(_params(known_min_speed_px_s=0.8), coast_speed=0.1, horizon=False)
    assert not np.isfinite(c.camera_err_px_s)
    assert c.min_speed_px_s == pytest.approx(1.5) and max(n_det) == 0


def _with_h(s, dx):
    """The snapshot ``s`` with a camera motion of ``dx`` px a frame (a pure translation)."""
    h = np.eye(3)
    h[0, 2] = dx
    s.homography = h
    return s


def test_still_gate_lowers_floor_only_with_still_camera():
    p = _params(known_min_speed_px_s=0.8, known_still_px=0.1)
    hz = Level(50)
    # a panning camera (2 px a frame): no estimate, the floor stays, no cluster
    c = FeatureClusterer(p)
    n = [len(c.update(_with_h(_scene(k, 0.1), 2.0), horizon=hz)[0]) for k in range(12)]
    assert not np.isfinite(c.camera_err_px_s) and c.min_speed_px_s == pytest.approx(1.5) and max(n) == 0
    # the same camera still: the estimate and the lower floor find the boat
    c = FeatureClusterer(p)
    n = [len(c.update(_with_h(_scene(k, 0.1), 0.01), horizon=hz)[0]) for k in range(12)]
    assert c.camera_err_px_s == pytest.approx(0.1) and c.min_speed_px_s == pytest.approx(0.8) and n[-1] == 1
    # it pans again: the estimate is kept but the floor is back at 1.5 while it pans
    c.update(_with_h(_scene(12, 3.0), 2.0), horizon=hz)
    assert c.camera_err_px_s == pytest.approx(0.1) and c.min_speed_px_s == pytest.approx(1.5)
    # without the gate (known_still_px 0) the panning frames measure and lower it too
    c = FeatureClusterer(_params(known_min_speed_px_s=0.8, known_still_px=0.0))
    c.update(_with_h(_scene(0, 0.1), 2.0), horizon=hz)
    assert c.min_speed_px_s == pytest.approx(0.8)


def test_band_keeps_floor_far_below_horizon():
    # the boat lies 70 px below the horizon (row 50): a band of 40 px leaves it static, 80 px finds it
    c, n_det = _run(_params(known_min_speed_px_s=0.8, known_band_px=40.0), coast_speed=0.1)
    assert c.min_speed_px_s == pytest.approx(0.8) and max(n_det) == 0
    c, n_det = _run(_params(known_min_speed_px_s=0.8, known_band_px=80.0), coast_speed=0.1)
    assert n_det[-1] == 1


def test_frame_edges_per_feature_floor():
    from seawatch.track.feature_clusters import frame_edges

    xy = np.array([[0, 0], [10, 0], [100, 0], [110, 0]], float)
    hist = np.repeat(np.array([[1.0, 0.0]] * 4)[:, None, :], 4, axis=1)
    i, j, _ = frame_edges(xy, hist, 0.31, 50.0, min_speed_px_s=1.5)
    assert len(i) == 0
    i, j, _ = frame_edges(xy, hist, 0.31, 50.0, min_speed_px_s=np.array([0.8, 0.8, 1.5, 1.5]))
    assert list(zip(i, j)) == [(0, 1)]
    i2, j2, d2 = frame_edges(xy, hist, 0.31, 50.0, min_speed_px_s=0.8)
    i3, j3, d3 = frame_edges(xy, hist, 0.31, 50.0, min_speed_px_s=np.full(4, 0.8))
    assert list(zip(i2, j2)) == list(zip(i3, j3)) == [(0, 1), (2, 3)] and np.allclose(d2, d3)
