"""Motion dissimilarity and per-frame graph of paper B on hand-made feature tracks."""

import numpy as np
import pytest

from seawatch.track.feature_clusters import NO_COMMON_FRAME, frame_edges, motion_dissimilarity

FPS = 25.0
DT = 1.0 / FPS


def track(vx_px_frame, vy_px_frame, n=5):
    """A constant velocity track in px/s (the function takes px/s; the paper thinks per frame)."""
    v = np.tile([vx_px_frame * FPS, vy_px_frame * FPS], (n, 1)).astype(float)
    return v


def sigmoid(m, p=3.0):
    return 1.0 / (1.0 + np.exp(p - m))


def test_identical_motion_is_zero():
    a = track(2.0, 1.0)
    assert motion_dissimilarity(a, a.copy()) == pytest.approx(0.0, abs=1e-12)


def test_opposite_slow_motion_is_pure_angle():
    a, b = track(0.5, 0.0), track(-0.5, 0.0)
    # Theta = 1 (pi / pi); both magnitudes equal so Lambda = 0
    assert motion_dissimilarity(a, b) == pytest.approx(1.0, abs=1e-12)


def test_perpendicular_is_half():
    a, b = track(1.0, 0.0), track(0.0, 1.0)
    assert motion_dissimilarity(a, b) == pytest.approx(0.5, abs=1e-12)


def test_angle_wraps_around():
    ang_a, ang_b = np.deg2rad(170.0), np.deg2rad(-170.0)
    a = track(np.cos(ang_a), np.sin(ang_a))
    b = track(np.cos(ang_b), np.sin(ang_b))
    assert motion_dissimilarity(a, b) == pytest.approx(20.0 / 180.0, abs=1e-9)


def test_magnitude_term_same_direction():
    a, b = track(10.0, 0.0), track(5.0, 0.0)
    expected = sigmoid(10.0) * (1.0 - 5.0 / 10.0)
    assert motion_dissimilarity(a, b) == pytest.approx(expected, rel=1e-9)
    # the sigmoid makes slow pairs cheap: 1 vs 0.5 px/frame costs far less than 10 vs 5
    slow = motion_dissimilarity(track(1.0, 0.0), track(0.5, 0.0))
    assert slow == pytest.approx(sigmoid(1.0) * 0.5, rel=1e-9)
    assert slow < 0.1 < expected


def test_terms_averaged_over_common_frames_only():
    a = np.array([[1, 0], [1, 0], [np.nan, np.nan], [1, 0]], float) * FPS
    b = np.array([[1, 0], [0, 1], [-1, 0], [np.nan, np.nan]], float) * FPS
    # common frames 0 and 1: angles 0 and pi/2 -> Theta = 0.25, equal magnitudes -> Lambda = 0
    assert motion_dissimilarity(a, b) == pytest.approx(0.25, abs=1e-12)


def test_combined_theta_lambda():
    a = np.array([[6, 0], [6, 0]], float) * FPS
    b = np.array([[0, 3], [3, 0]], float) * FPS
    theta = (0.5 + 0.0) / 2
    lam = sigmoid(6.0) * 0.5
    assert motion_dissimilarity(a, b) == pytest.approx(np.hypot(theta, lam), rel=1e-9)


def test_no_common_frame_is_1000():
    a = np.array([[1, 0], [np.nan, np.nan]], float)
    b = np.array([[np.nan, np.nan], [1, 0]], float)
    assert motion_dissimilarity(a, b) == NO_COMMON_FRAME == 1000.0


def test_vectorised_over_pairs_and_frame_rate_invariant():
    rng = np.random.default_rng(3)
    va = rng.normal(0, 60, (7, 6, 2))
    vb = rng.normal(0, 60, (7, 6, 2))
    d = motion_dissimilarity(va, vb)
    assert d.shape == (7,)
    for k in range(7):
        assert d[k] == pytest.approx(motion_dissimilarity(va[k], vb[k]))
    # the same motion filmed at 10 frames/s gives the same D when px/s are compared
    assert np.allclose(motion_dissimilarity(va, vb, frame_interval_s=0.04), d)
    assert not np.allclose(motion_dissimilarity(va, vb, frame_interval_s=0.1), d)


def test_frame_edges_gate_on_distance_and_dissimilarity():
    xy = np.array([[0, 0], [30, 0], [200, 0], [10, 10]], float)
    hist = np.stack([track(2, 0), track(2, 0.1), track(2, 0), track(-2, 0)])
    i, j, d = frame_edges(xy, hist, dmax=0.31, radius_px=50.0)
    pairs = set(zip(i.tolist(), j.tolist()))
    # 0-1 similar and close; 0-2 similar but 200 px apart; 0-3 and 1-3 close but opposite
    assert pairs == {(0, 1)}
    assert np.all(d < 0.31)


def test_frame_edges_min_speed_drops_static_features():
    xy = np.array([[0, 0], [20, 0], [40, 0], [60, 0]], float)
    # two static features (0.1 px/frame = 2.5 px/s of noise, same direction) and two movers
    hist = np.stack([track(0.1, 0), track(0.1, 0), track(2, 0), track(2, 0)])
    i, j, _ = frame_edges(xy, hist, 0.31, 50.0, min_speed_px_s=0.0)
    # without the floor the static pair links (D = 0) and even links to the movers
    # (Lambda = N(2) (1 - 0.05) = 0.26 < 0.31); 0-3 are 60 px apart
    assert set(zip(i.tolist(), j.tolist())) == {(0, 1), (0, 2), (1, 2), (1, 3), (2, 3)}
    i, j, _ = frame_edges(xy, hist, 0.31, 50.0, min_speed_px_s=5.0)
    assert set(zip(i.tolist(), j.tolist())) == {(2, 3)}


def test_frame_edges_kernel_agrees_with_motion_dissimilarity():
    """The compiled per-pair kernel used by frame_edges computes the public formula."""
    from seawatch.track.feature_clusters import _pair_dissimilarity

    rng = np.random.default_rng(3)
    hist = rng.normal(0.0, 60.0, (40, 15, 2))
    hist[rng.random((40, 15)) < 0.3] = np.nan
    hist[5] = np.nan  # never seen: no common frame with anyone
    i, j = np.triu_indices(40, 1)
    for angle in (True, False):
        ref = motion_dissimilarity(hist[i], hist[j], 3.0, 0.04, angle=angle)
        got = _pair_dissimilarity(hist, i.astype(np.int64), j.astype(np.int64), 3.0, 0.04, angle)
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)
        assert np.all(got[(i == 5) | (j == 5)] == NO_COMMON_FRAME)
