"""The camera-motion prior from the pan/tilt/zoom telemetry (``motion_prior``): the rotation
homography between two camera states, its use in the extractor's camera fit (the water's drifting
features no longer vote for the camera) and the stage handing it over frame to frame."""

import numpy as np
import pytest

from seawatch.camera import CameraModel, Intrinsics
from seawatch.detect.features import StableFeatureExtractor, _apply_h
from seawatch.track.feature_clusters import StableFeatureTracker
from seawatch.types import CameraPose, Frame, PTZState

W, H = 320, 240


def _camera(pan=140.0, tilt=-1.5, roll=0.0):
    return CameraModel(Intrinsics.from_fov(50.0, W, H),
                       CameraPose(lat_deg=50.8, lon_deg=-1.1, height_m=25.0, pan_deg=pan, tilt_deg=tilt, roll_deg=roll))


# ------------------------------------------------------------ the rotation homography
@pytest.mark.parametrize("pan,tilt,zoom", [(141.0, -1.2, 1.0), (138.5, -2.0, 1.7), (140.0, -1.5, 3.5)])
def test_rotation_homography_maps_a_direction_to_its_pixel_in_the_other_camera(pan, tilt, zoom):
    a = _camera()
    b = a.with_ptz(PTZState(t_s=0.0, pan_deg=pan, tilt_deg=tilt, zoom=zoom))
    rng = np.random.default_rng(3)
    az = 140.0 + rng.uniform(-8, 8, 30)
    el = rng.uniform(-3, 3, 30)
    ua, va, ia = a.azel_to_pixel(az, el)
    ub, vb, ib = b.azel_to_pixel(az, el)
    assert ia.all() and ib.all()
    got = _apply_h(a.rotation_homography(b), np.stack([ua, va], axis=1))
    np.testing.assert_allclose(got, np.stack([ub, vb], axis=1), atol=1e-6)


def test_rotation_homography_of_the_same_camera_is_the_identity_and_inverts():
    a = _camera()
    np.testing.assert_allclose(a.rotation_homography(a), np.eye(3), atol=1e-12)
    b = a.with_ptz(PTZState(t_s=0.0, pan_deg=143.0, tilt_deg=-1.0, zoom=2.0))
    h = a.rotation_homography(b) @ b.rotation_homography(a)
    np.testing.assert_allclose(h / h[2, 2], np.eye(3), atol=1e-9)


# ------------------------------------------------------------ the extractor's camera fit
def _matches(seed=0, n_scene=5, n_water=40, drift=(1.6, 0.4), shift=(0.3, -0.2)):
    """Matches of a still camera (its prior a pan of 2 px) whose true motion is the prior moved by
    ``shift`` (the shake), with ``n_scene`` features above the horizon (row 100) and ``n_water``
    below it drifting by ``drift`` more (the waves)."""
    rng = np.random.default_rng(seed)
    prior = np.array([[1.0, 0, 2.0], [0, 1.0, 0.0], [0, 0, 1.0]])
    truth = np.array([[1.0, 0, shift[0]], [0, 1.0, shift[1]], [0, 0, 1.0]]) @ prior
    src = np.r_[np.c_[rng.uniform(10, 310, n_scene), rng.uniform(60, 95, n_scene)],
                np.c_[rng.uniform(10, 310, n_water), rng.uniform(110, 230, n_water)]]
    dst = _apply_h(truth, src) + rng.normal(0, 0.05, src.shape)
    dst[n_scene:] += np.asarray(drift) + rng.normal(0, 0.3, (n_water, 2))
    scene = np.arange(len(src)) < n_scene
    return prior, truth, src, dst, np.ones(len(src), bool), scene


def test_fallback_prior_keeps_the_drifting_water_out_of_the_camera_fit():
    prior, truth, src, dst, stable, scene = _matches()
    ext = StableFeatureExtractor(motion_prior="fallback")
    h_fit, _ = ext._camera_motion(src, dst, stable, scene)  # 5 above the horizon: fitted to all
    h_pri, ok = ext._prior_motion(prior, src, dst, stable, scene, 1.0)
    probe = np.array([[160.0, 100.0], [20.0, 90.0], [300.0, 120.0]])
    err_fit = np.linalg.norm(_apply_h(h_fit, probe) - _apply_h(truth, probe), axis=1).max()
    err_pri = np.linalg.norm(_apply_h(h_pri, probe) - _apply_h(truth, probe), axis=1).max()
    assert ok
    assert err_fit > 1.0  # the waves' drift leads the fit astray
    assert err_pri < 0.1  # the prior, moved by the scene's median residual (the shake)


def test_fallback_prior_without_scene_inliers_is_the_prior_itself():
    prior, truth, src, dst, stable, scene = _matches(n_scene=2)  # fewer than prior_min_matches (3)
    ext = StableFeatureExtractor(motion_prior="fallback")
    h, ok = ext._prior_motion(prior, src, dst, stable, scene, 1.0)
    assert ok
    np.testing.assert_allclose(h, prior)
    h, _ = ext._prior_motion(prior, src, dst, stable, None, 1.0)  # no horizon: nothing is scene
    np.testing.assert_allclose(h, prior)


def test_fallback_leaves_a_well_covered_scene_to_the_fit_and_always_fits_the_prior_inliers():
    prior, truth, src, dst, stable, scene = _matches(n_scene=20, shift=(0.3, -0.2))
    # one scene feature far from the prior (a mismatch) must not vote under "always"
    dst[0] += (6.0, 4.0)
    fall = StableFeatureExtractor(motion_prior="fallback")
    h_f, _ = fall._prior_motion(prior, src, dst, stable, scene, 1.0)
    h_c, _ = fall._camera_motion(src, dst, stable, scene)
    np.testing.assert_allclose(h_f, h_c)  # 20 above the horizon: the fit without a prior
    alw = StableFeatureExtractor(motion_prior="always")
    h_a, ok = alw._prior_motion(prior, src, dst, stable, scene, 1.0)
    probe = np.array([[160.0, 100.0], [20.0, 70.0]])
    assert ok
    assert np.linalg.norm(_apply_h(h_a, probe) - _apply_h(prior @ np.eye(3), probe), axis=1).max() > 0.2
    assert np.linalg.norm(_apply_h(h_a, probe) - _apply_h(truth, probe), axis=1).max() < 0.1


def test_prior_inlier_distance_grows_with_the_zoom():
    prior, truth, src, dst, stable, scene = _matches(shift=(2.0, 0.0))  # 2 px off the prior
    ext = StableFeatureExtractor(motion_prior="fallback", prior_px=1.5)
    h1, _ = ext._prior_motion(prior, src, dst, stable, scene, 1.0)
    np.testing.assert_allclose(h1, prior)  # beyond 1.5 px: no inliers, the prior as it is
    h2, _ = ext._prior_motion(prior, src, dst, stable, scene, 2.0)  # 3 px at zoom 2
    assert abs(h2[0, 2] - (prior[0, 2] + 2.0)) < 0.1


def _texture(seed=1, w=W + 200, h=H):
    rng = np.random.default_rng(seed)
    img = np.zeros((h, w), np.uint8)
    for _ in range(400):
        x, y, r = rng.integers(0, w), rng.integers(0, h), rng.integers(2, 6)
        v = int(rng.integers(120, 255))
        img[max(0, y - r):y + r, max(0, x - r):x + r] = v
    return img


def test_process_uses_the_prior_and_scales_it_to_the_working_image():
    tex = _texture()
    prior = np.array([[1.0, 0, -3.0], [0, 1.0, 0.0], [0, 0, 1.0]])  # a pan: the image moves 3 px left
    ext = StableFeatureExtractor(motion_prior="fallback", work_width_px=W // 2, nominal_fps=10.0)
    off = StableFeatureExtractor(motion_prior="off", work_width_px=W // 2, nominal_fps=10.0)
    for i in range(8):
        img = np.ascontiguousarray(tex[:, 3 * i:3 * i + W])
        snap = ext.process(img, i / 10.0, motion_prior=prior if i else None)
        snap_off = off.process(img, i / 10.0, motion_prior=prior if i else None)
    # no horizon: the prior itself, in source pixels
    np.testing.assert_allclose(snap.homography, prior, atol=1e-9)
    assert snap.camera_motion_ok
    # "off" ignores the prior and fits the features (the same pan, not exactly the prior)
    assert abs(snap_off.homography[0, 2] + 3.0) < 0.5
    assert not np.allclose(snap_off.homography, prior, atol=1e-9)
    with pytest.raises(ValueError, match="3x3"):
        ext.process(np.ascontiguousarray(tex[:, :W]), 1.0, motion_prior=np.eye(2))


def test_bad_motion_prior_settings_are_refused():
    with pytest.raises(ValueError, match="motion_prior"):
        StableFeatureExtractor(motion_prior="ptz")
    with pytest.raises(ValueError, match="prior_px"):
        StableFeatureExtractor(prior_px=0.0)


# ------------------------------------------------------------ the stage hands it over
def test_tracker_gives_the_extractor_the_motion_between_consecutive_ptz_states():
    cam = _camera()
    trk = StableFeatureTracker(camera=cam)
    img = np.zeros((H, W, 3), np.uint8)
    states = [PTZState(t_s=0.0, pan_deg=140.0, tilt_deg=-1.5, zoom=1.0),
              PTZState(t_s=0.1, pan_deg=140.6, tilt_deg=-1.4, zoom=1.2)]
    frames = [Frame(image=img, t_s=s.t_s, index=i, ptz=s) for i, s in enumerate(states)]
    _, _, p0 = trk.extractor_inputs(frames[0])
    assert p0 is None  # the first frame has no previous camera
    _, zoom, p1 = trk.extractor_inputs(frames[1])
    assert zoom == 1.2
    np.testing.assert_allclose(p1, cam.with_ptz(states[0]).rotation_homography(cam.with_ptz(states[1])))
    trk.reset()
    assert trk.extractor_inputs(frames[1])[2] is None  # after a reset, no previous camera
    assert StableFeatureTracker().extractor_inputs(frames[0])[2] is None  # no camera model: no prior


def test_config_key_reaches_the_extractor_and_a_typo_is_refused():
    from seawatch.config import ConfigError, load_config

    cfg = load_config(None, ["tracker.sf_motion_prior=fallback"])
    assert StableFeatureTracker.from_config(cfg, fps=10.0).extractor.motion_prior == "fallback"
    assert StableFeatureTracker.from_config(load_config(None, []), fps=10.0).extractor.motion_prior == "fallback"
    assert StableFeatureExtractor().motion_prior == "fallback"  # the default since session 21
    cfg = load_config(None, ["tracker.sf_motion_prior=off"])
    assert StableFeatureTracker.from_config(cfg, fps=10.0).extractor.motion_prior == "off"
    with pytest.raises(ConfigError, match="tracker.sf_motion_prior"):
        load_config(None, ["tracker.sf_motion_prior=ptz"])


def test_a_frame_without_matches_is_carried_by_the_prior_and_a_bad_prior_changes_nothing():
    tex = _texture(seed=4)
    ext = StableFeatureExtractor(motion_prior="fallback", nominal_fps=10.0)
    for i in range(6):
        ext.process(np.ascontiguousarray(tex[:, :W]), i / 10.0)  # a still camera
    alive = np.flatnonzero(ext._alive)
    before = ext._xy[alive].copy()
    n = ext._n
    with pytest.raises(ValueError, match="3x3"):
        ext.process(np.zeros((H, W), np.uint8), 0.6, motion_prior=np.full((3, 3), np.nan))
    assert ext._n == n and np.array_equal(ext._xy[alive], before)  # nothing changed
    prior = np.array([[1.0, 0, 5.0], [0, 1.0, -2.0], [0, 0, 1.0]])
    snap = ext.process(np.zeros((H, W), np.uint8), 0.6, motion_prior=prior)  # blank: no match
    assert snap.n_matched == 0 and snap.camera_motion_ok
    np.testing.assert_allclose(snap.homography, prior, atol=1e-9)
    np.testing.assert_allclose(ext._xy[alive], before + [5.0, -2.0], atol=1e-9)  # carried with the camera
