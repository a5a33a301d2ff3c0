"""Robust Kalman background model (paper C) and connected-component blobs."""

import numpy as np
import pytest

from seawatch.detect.background import RobustKalmanBackground, RobustKalmanDetector
from seawatch.detect.blobs import blobs_to_detections, find_blobs
from seawatch.types import CameraPose, Detector, Frame

H, W = 96, 128
FPS = 10.0


def _scene(seed=0):
    rng = np.random.default_rng(seed)
    # smooth textured background (sea and sky-like gradients)
    yy, xx = np.mgrid[0:H, 0:W]
    base = 90 + 40 * np.sin(xx / 9.0) * np.cos(yy / 13.0) + 0.3 * yy
    return rng, base


def _iou(a, b):
    ax2, ay2 = a[0] + a[2], a[1] + a[3]
    bx2, by2 = b[0] + b[2], b[1] + b[3]
    iw = max(0.0, min(ax2, bx2) - max(a[0], b[0]))
    ih = max(0.0, min(ay2, by2) - max(a[1], b[1]))
    inter = iw * ih
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


def test_is_a_detector():
    assert isinstance(RobustKalmanDetector(), Detector)
    assert RobustKalmanDetector.name == "robust_kalman"


def test_moving_blob_is_found_each_frame():
    rng, base = _scene(1)
    det = RobustKalmanDetector(work_scale=1.0, min_area_px=20, warmup_s=0.5)
    hits = 0
    n_eval = 0
    for i in range(60):
        img = base + rng.normal(0, 2.0, base.shape)
        box = None
        if i >= 15:
            x0 = 5 + 1.5 * (i - 15)
            box = (int(x0), 40, 14, 8)
            img[40:48, int(x0):int(x0) + 14] += 45
        d = det.detect(Frame(np.clip(img, 0, 255).astype(np.uint8), i / FPS, i))
        if box is None:
            assert len(d) == 0, f"false detection before the blob appears, frame {i}: {d.boxes}"
            continue
        n_eval += 1
        # exactly the blob, well localised
        if len(d) == 1 and _iou(d.boxes[0], box) > 0.6:
            hits += 1
    assert hits >= n_eval - 1, f"blob found in only {hits} of {n_eval} frames"


def test_lighting_ramp_is_not_foreground():
    rng, base = _scene(2)
    det = RobustKalmanDetector(work_scale=1.0, min_area_px=20, window_s=2.0)
    n_det = 0
    fg_frac = []
    for i in range(100):
        t = i / FPS
        img = base.copy()
        if i >= 20:  # 8 s ramp: +25 % gain and +20 grey levels (a cloud clearing the sun)
            g = (i - 20) / 80.0
            img = img * (1 + 0.25 * g) + 20 * g
        img = img + rng.normal(0, 2.0, base.shape)
        d = det.detect(Frame(np.clip(img, 0, 255).astype(np.uint8), t, i))
        n_det += len(d)
        fg_frac.append((det.mask > 0).mean())
    assert n_det == 0
    assert max(fg_frac[20:]) < 0.03
    # the background followed the ramp (and a learned gain above 1)
    bg = det.model.background
    final = base * 1.25 + 20 * (79 / 80)
    assert np.median(np.abs(bg - final)) < 4.0
    assert np.median(det.model.param("a")) > 1.0


def test_em_learns_noise_level():
    rng = np.random.default_rng(3)
    out = {}
    for sigma in (1.0, 6.0):
        m = RobustKalmanBackground(window_s=3.0)
        y0 = np.full((40, 40), 120.0)
        for i in range(150):
            m.apply((y0 + rng.normal(0, sigma, y0.shape)).astype(np.float32), i / 25.0)
        out[sigma] = float(np.median(m.param("r")))
        assert 0.95 < np.median(m.param("a")) < 1.05
    # r follows the noise variance (a robust scale: below the variance, same order)
    assert 0.3 < out[1.0] < 2.0
    assert 12.0 < out[6.0] < 50.0


def test_robust_weights_keep_background_under_a_stopped_boat():
    rng = np.random.default_rng(4)
    y0 = np.full((30, 30), 100.0)
    res = {}
    for alpha in (1.0, 1e4):  # Ting's weights vs (almost) plain Gaussian Kalman
        m = RobustKalmanBackground(window_s=2.0, alpha=alpha, beta=alpha)
        for i in range(40):
            m.apply((y0 + rng.normal(0, 2, y0.shape)).astype(np.float32), i / 10)
        for i in range(40, 60):  # a bright boat stops on the centre for 2 s
            y = y0 + rng.normal(0, 2, y0.shape)
            y[10:20, 10:20] += 60
            mask = m.apply(y.astype(np.float32), i / 10)
        res[alpha] = (float(m.background[15, 15]), float((mask[10:20, 10:20] > 0).mean()))
    assert res[1.0][0] < 115.0  # robust: the background barely moved towards the boat
    assert res[1.0][1] > 0.9  # and the boat is still foreground
    assert res[1e4][0] > res[1.0][0] + 10.0  # the plain filter absorbs it


def test_hard_gate_freezes_foreground_pixels():
    y0 = np.full((20, 20), 80.0, np.float32)
    m = RobustKalmanBackground(hard_gate=True, warmup_s=0.0)
    for i in range(10):
        m.apply(y0, i * 0.1)
    before = m.background.copy()
    y = y0.copy()
    y[5:8, 5:8] = 200
    mask = m.apply(y, 1.0)
    assert (mask[5:8, 5:8] > 0).all()
    np.testing.assert_allclose(m.background[5:8, 5:8], before[5:8, 5:8], atol=0.05)  # a x only


def test_colour_and_downscaled_and_bad_frames():
    rng = np.random.default_rng(5)
    det = RobustKalmanDetector(colour=True, work_scale=0.5, min_area_px=40, warmup_s=0.0)
    base = np.full((H, W, 3), 100.0)
    for i in range(20):
        img = base + rng.normal(0, 1.5, base.shape)
        if i >= 10:
            img[30:50, 60:90, 2] += 80  # red boat: visible in one channel only
        d = det.detect(Frame(np.clip(img, 0, 255).astype(np.uint8), i / FPS, i))
    assert det.mask.shape == (48, 64)
    assert len(d) == 1
    x, y, w, h = d.boxes[0]  # scaled back to the source image
    assert abs(x - 60) <= 2 and abs(y - 30) <= 2 and abs(w - 30) <= 3 and abs(h - 20) <= 3
    bad = det.detect(Frame(np.zeros((0,), np.uint8), 2.1, 21))
    assert len(bad) == 0 and det.n_bad_frames == 1


def test_deterministic():
    rng, base = _scene(6)
    frames = [np.clip(base + rng.normal(0, 3, base.shape), 0, 255).astype(np.uint8) for _ in range(20)]
    outs = []
    for _ in range(2):
        det = RobustKalmanDetector(work_scale=1.0)
        for i, f in enumerate(frames):
            det.detect(Frame(f, i / FPS, i))
        outs.append(det.model.state.copy())
    np.testing.assert_array_equal(outs[0], outs[1])


def test_find_blobs_connectivity_and_area():
    m = np.zeros((20, 20), np.uint8)
    m[2, 2] = m[3, 3] = m[4, 4] = 1  # diagonal: one 8-connected blob of 3 px
    m[10:14, 10:15] = 1  # 20 px
    m[18, 0] = 1  # 1 px
    boxes, areas = find_blobs(m, min_area_px=2, max_area_px=10)
    assert boxes.tolist() == [[2, 2, 3, 3]] and areas.tolist() == [3]
    boxes4, _ = find_blobs(m, min_area_px=2, max_area_px=10, connectivity=4)
    assert len(boxes4) == 0
    boxes, areas = find_blobs(m, min_area_px=2)
    assert sorted(areas.tolist()) == [3, 20]
    with pytest.raises(ValueError):
        find_blobs(np.zeros((2, 2, 2)))


def test_blobs_to_detections_azel():
    from seawatch.camera import CameraModel, Intrinsics

    cam = CameraModel(Intrinsics.from_fov(60.0, 640, 480), CameraPose(height_m=20.0, pan_deg=30.0,
                                                                       tilt_deg=-2.0))
    boxes = np.array([[310.0, 200.0, 20.0, 40.0], [0.0, 0.0, 10.0, 10.0]])
    d = blobs_to_detections(boxes, 1.5, 7, camera=cam, source="x", camera_id="c1")
    az, el = cam.pixel_to_azel(np.array([319.5, 4.5]), np.array([239.5, 9.5]))
    np.testing.assert_allclose(d.azel_deg[:, 0], az)
    np.testing.assert_allclose(d.azel_deg[:, 1], el)
    assert abs(d.azel_deg[0, 0] - 30.0) < 0.2  # the image centre looks along the pan
    assert d.camera_id == "c1" and d.t_s == 1.5 and len(d) == 2
    assert blobs_to_detections(np.zeros((0, 4)), 0.0, 0).azel_deg is None


def test_from_config():
    from seawatch.config import load_config

    cfg = load_config(overrides=["detector.rk_k_sigma=2.5", "detector.rk_empirical_test=true"])
    det = RobustKalmanDetector.from_config(cfg)
    assert det.model.k_sigma == 2.5 and det.model.empirical_test is True
    cfg = load_config(overrides=["detector.rk_k_low=4.5", "detector.rk_neighbour_px=2",
                                 "detector.rk_absorb=true", "detector.rk_r0_local_px=7"])
    m = RobustKalmanDetector.from_config(cfg).model
    assert m.k_low == 4.5 and m.neighbour_px == 2 and m.absorb is True and m.r0_local_px == 7
    cfg = load_config(overrides=["detector.rk_k_low=0"])
    assert RobustKalmanDetector.from_config(cfg).model.k_low is None


def _texture(rng, shape, shift_px=0):
    """A smooth random texture (sea-like), optionally rolled sideways by ``shift_px``."""
    import cv2

    t = cv2.GaussianBlur(rng.normal(0, 1, shape), (0, 0), 1.0)
    t = 100 + 30 * t / t.std()
    return np.roll(t, shift_px, axis=1)


def test_first_frame_ghost_is_absorbed_as_a_change_point():
    # a bright box is in the first frame and leaves at once: its place is a "ghost"
    y0 = np.full((40, 40), 80.0, np.float32)
    masks, r_after = {}, {}
    for absorb in (False, True):
        rng = np.random.default_rng(7)
        m = RobustKalmanBackground(k_sigma=6.0, hard_gate=True, gate_max_s=1.0, absorb=absorb,
                                   warmup_s=0.0, window_s=5.0, alpha=4.0, beta=4.0)
        first = y0.copy()
        first[10:20, 10:20] = 200
        m.apply(first, 0.0)
        fr = []
        for i in range(1, 40):
            fr.append((m.apply(y0 + rng.normal(0, 2, y0.shape).astype(np.float32), i / 10)[10:20, 10:20] > 0).mean())
        masks[absorb] = fr
        r_after[absorb] = float(np.median(m.param("r")[10:20, 10:20]))
    assert masks[True][0] == 1.0 and masks[False][0] == 1.0  # at first both see the ghost
    # with the change point: gone right after the 1 s gate, and the pixel keeps its noise level
    assert max(masks[True][11:]) == 0.0 and max(masks[True][:9]) == 1.0
    assert r_after[True] < 10.0
    # without: the gain of the converged filter is tiny, so the ghost lasts longer and is only
    # "explained" by blowing r up, which leaves those pixels blind
    assert min(masks[False][:15]) == 1.0
    assert r_after[False] > 100.0


def test_ghost_frac_shortens_the_gate_of_a_young_model():
    y0 = np.full((30, 30), 80.0, np.float32)
    first = y0.copy()
    first[5:15, 5:15] = 220
    gone = {}
    for frac in (0.0, 0.5):
        rng = np.random.default_rng(8)
        m = RobustKalmanBackground(k_sigma=6.0, hard_gate=True, gate_max_s=10.0, absorb=True,
                                   ghost_frac=frac, warmup_s=0.0)
        m.apply(first, 0.0)
        t_gone = None
        for i in range(1, 150):
            fg = (m.apply(y0 + rng.normal(0, 2, y0.shape).astype(np.float32), i / 10)[5:15, 5:15] > 0).mean()
            if fg == 0 and t_gone is None:
                t_gone = i / 10
        gone[frac] = t_gone
    assert gone[0.5] is not None and gone[0.5] <= 0.6
    assert gone[0.0] is not None and gone[0.0] > 9.9  # the full 10 s gate


def test_local_variance_start_quietens_a_textured_sea():
    fa = {}
    for px in (0, 5):
        rng = np.random.default_rng(9)
        m = RobustKalmanBackground(k_sigma=5.0, warmup_s=0.0, window_s=20.0, r0_local_px=px,
                                   alpha=4.0, beta=4.0)
        n = 0.0
        for i in range(20):  # a new texture every frame: the temporal variance equals the spatial one
            n += (m.apply(_texture(rng, (60, 60)).astype(np.float32), i / 10) > 0).mean()
        fa[px] = n / 20
        if px:
            assert np.median(m.param("r")) > 300  # started near the texture's variance (30^2)
    assert fa[5] < 0.2 * fa[0]
    assert fa[5] < 0.01


def test_neighbour_test_ignores_moving_texture_but_not_a_boat():
    rng = np.random.default_rng(10)
    tex = _texture(rng, (60, 80))
    res = {}
    for nbr in (0, 1):
        m = RobustKalmanBackground(k_sigma=4.0, warmup_s=0.0, window_s=5.0, neighbour_px=nbr,
                                   r0=1.0, r_min=1.0, alpha=4.0, beta=4.0)
        fa, hit = [], []
        for i in range(40):
            img = np.roll(tex, (i // 2) % 2, axis=1).astype(np.float32)  # waves jitter by a pixel
            img = img + rng.normal(0, 0.5, img.shape).astype(np.float32)
            if i >= 30:
                img[20:30, 30:45] = 250.0  # a bright boat
            mask = m.apply(img, i / 10)
            if 10 <= i < 30:
                fa.append((mask > 0).mean())
            if i >= 30:
                hit.append((mask[22:28, 32:43] > 0).mean())
        res[nbr] = (np.mean(fa), np.mean(hit))
    assert res[0][0] > 0.02  # the plain test flags the moved texture
    assert res[1][0] < 0.1 * res[0][0]  # the neighbour test does not
    assert res[1][1] > 0.95  # and still finds the boat's inside


def test_hysteresis_grows_seeds_over_weak_pixels_only_when_connected():
    rng = np.random.default_rng(11)
    y0 = np.full((50, 50), 100.0, np.float32)
    out = {}
    for k_low in (None, 3.0):
        m = RobustKalmanBackground(k_sigma=8.0, k_low=k_low, warmup_s=0.0, r0=4.0, r_min=4.0,
                                   window_s=5.0)
        for i in range(30):
            m.apply(y0 + rng.normal(0, 2, y0.shape).astype(np.float32), i / 10)
        img = y0.copy()
        img[10:20, 10:30] += 12.0  # a weak hull (about 6 sigma) ...
        img[12:16, 18:22] += 60.0  # ... with a strong superstructure
        img[35:40, 35:40] += 12.0  # a weak patch without a strong pixel
        out[k_low] = m.apply(img, 3.0) > 0
    plain, hyst = out[None], out[3.0]
    assert plain[12:16, 18:22].all() and plain[10:20, 10:30].mean() < 0.2
    assert hyst[10:20, 10:30].mean() > 0.95  # the whole hull
    assert not hyst[35:40, 35:40].any() and not hyst[:, 40:].any()


def test_mog2_and_robust_kalman_share_the_blob_extraction():
    from seawatch.detect.mog2 import foreground_boxes

    rng = np.random.default_rng(12)
    m = (rng.random((120, 160)) > 0.93).astype(np.uint8) * 255
    m[30:60, 40:90] = 255
    for o, c in ((0, 0), (3, 0), (0, 7), (3, 15)):
        b1, a1 = find_blobs(m, min_area_px=5, max_area_px=4000, open_px=o, close_px=c)
        b2, f2 = foreground_boxes(m, min_area_px=5, max_area_px=4000, open_px=o, close_px=c)
        np.testing.assert_array_equal(b1, b2)
        np.testing.assert_allclose(a1 / np.maximum(b1[:, 2] * b1[:, 3], 1), f2)


@pytest.mark.parametrize("kw, word", [
    ({"k_low": float("nan")}, "k_low"), ({"k_low": -1.0}, "k_low"),
    ({"absorb": True, "gate_max_s": 0.0}, "gate_max_s"), ({"neighbour_px": 50}, "neighbour_px"),
    ({"r0_local_px": -2}, "r0_local_px"), ({"ghost_frac": 1.5}, "ghost_frac"),
])
def test_invalid_settings_are_rejected_naming_the_parameter(kw, word):
    with pytest.raises(ValueError, match=word):
        RobustKalmanBackground(**kw)
