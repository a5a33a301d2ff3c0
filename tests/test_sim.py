"""Synthetic world: exact ground truth, occlusion, determinism, camera geometry, scenario timing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from seawatch.sim import (
    SCENARIOS,
    PTZSchedule,
    Trajectory,
    make_multicam,
    make_scenario,
)
from seawatch.types import Frame, Modality


@pytest.fixture(scope="module")
def harbour():
    return make_scenario("harbour", seed=0)


@pytest.fixture(scope="module")
def crossing():
    return make_scenario("crossing", seed=0, fps=5.0)


def test_scenario_names_and_timing():
    assert {"harbour", "pan", "ir", "crossing", "open_sea"} <= set(SCENARIOS)
    s = make_scenario("crossing", duration_s=3.0, fps=4.0)
    assert s.n_frames == 12 and s.duration_s == 3.0 and s.fps == 4.0
    assert s.time_s(0) == 0.0 and s.time_s(6) == pytest.approx(1.5)
    f = s.render(6)
    assert isinstance(f, Frame) and f.t_s == pytest.approx(1.5) and f.index == 6
    assert f.image.shape == (576, 704, 3) and f.image.dtype == np.uint8
    assert f.pose is not None and f.ptz is not None and f.ptz.t_s == pytest.approx(1.5)
    with pytest.raises(IndexError):
        s.render(12)
    with pytest.raises(KeyError):
        make_scenario("no_such_scene")
    h = make_scenario("harbour")
    assert h.duration_s == 45.0 and h.fps == 10.0 and h.n_frames == 450


def test_trajectory_closed_form_matches_integration():
    tr = Trajectory(100.0, -50.0, 30.0, ((5.0, 4.0, 0.0), (10.0, 4.0, 6.0), (1e9, 3.0, -2.0)))
    dt = 0.001
    t = np.arange(0, 25.0, dt)
    e, n, c, v = tr.state(t)
    # integrate the velocity numerically and compare
    ve, vn = v * np.sin(np.radians(c)), v * np.cos(np.radians(c))
    e_int = 100.0 + np.concatenate([[0], np.cumsum(0.5 * (ve[1:] + ve[:-1]) * dt)])
    n_int = -50.0 + np.concatenate([[0], np.cumsum(0.5 * (vn[1:] + vn[:-1]) * dt)])
    assert np.max(np.abs(e - e_int)) < 0.01 and np.max(np.abs(n - n_int)) < 0.01
    assert c[int(4.0 / dt)] == pytest.approx(30.0)
    assert c[int(15.0 / dt)] == pytest.approx(90.0, abs=0.01)  # 10 s at 6 deg/s


def test_harbour_content(harbour):
    assert len(harbour.vessels) >= 4
    assert sum(v.mmsi == 0 for v in harbour.vessels) >= 1  # one without AIS
    assert harbour.renderer.pano is not None and harbour.modality == Modality.EO
    gt = harbour.ground_truth(0)
    assert len(gt) >= 4
    assert set(gt.mmsi[gt.mmsi > 0]) <= {v.mmsi for v in harbour.vessels}
    # a coastline: in some columns the water starts well below the sea horizon
    cam = harbour.camera_at(0)
    hz = cam.horizon_row(np.arange(harbour.width, dtype=float))
    assert np.max(gt.water_row - hz) > 3


@pytest.mark.parametrize("i", [0, 170, 449])
def test_boxes_match_label_masks(harbour, i):
    gt = harbour.ground_truth(i)
    lab = harbour.label_image(i)
    for vid, box, vis, vpx in zip(gt.ids, gt.boxes, gt.visible, gt.visible_px):
        ys, xs = np.nonzero(lab == vid)
        assert len(xs) == vpx
        if vpx == 0:
            assert vis == 0
            continue
        assert tuple(box) == (xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
        x, y, w, h = box
        assert 0 <= x and 0 <= y and x + w <= harbour.width and y + h <= harbour.height
    # every labelled pixel belongs to a listed vessel
    assert set(np.unique(lab)) - {0} <= set(gt.ids.tolist())


def test_boxes_match_rendered_pixels(harbour):
    """Without noise, wakes and reflections, the vessels change exactly the pixels of their masks."""
    clean = harbour.with_render_options(noise_sigma=0.0, wakes=False, reflections=False)
    for i in (30, 250):
        img = clean.render(i).image.astype(int)
        empty = clean.render_empty(i).astype(int)
        diff = np.any(img != empty, axis=-1)
        lab = clean.label_image(i)
        gt = clean.ground_truth(i)
        assert not np.any(diff & (lab == 0))  # nothing drawn outside the masks
        for vid, box in zip(gt.ids, gt.boxes):
            m = lab == vid
            if not m.any():
                continue
            assert diff[m].mean() > 0.9  # the mask is what the vessel painted
            x, y, w, h = box.astype(int)
            dm = diff & m
            ys, xs = np.nonzero(dm)
            assert xs.min() >= x and xs.max() < x + w and ys.min() >= y and ys.max() < y + h


def test_partial_occlusion_in_harbour(harbour):
    vis = [dict(zip(g.ids.tolist(), g.visible.tolist())) for g in
           (harbour.ground_truth(i) for i in range(120, 230, 10))]
    sail = [d.get(2, 1.0) for d in vis]
    assert min(sail) < 0.8 and max(sail) > 0.99
    assert all(0.0 < v for v in sail)  # partly, never fully hidden


def test_crossing_full_occlusion(crossing):
    s = crossing
    far = {}
    near = {}
    for i in range(s.n_frames):
        g = s.ground_truth(i)
        d = dict(zip(g.ids.tolist(), g.visible.tolist()))
        far[i], near[i] = d.get(2), d.get(1)
    t_cross = int(round(12.0 * s.fps))
    assert far[t_cross] == 0.0  # fully hidden, still listed
    assert far[0] == pytest.approx(1.0) and far[s.n_frames - 1] == pytest.approx(1.0)
    assert all(v is not None and v > 0.999 for v in near.values())  # the near boat is never occluded
    hidden = [i for i, v in far.items() if v == 0.0]
    assert 2 <= len(hidden) and max(hidden) - min(hidden) + 1 == len(hidden)  # one contiguous spell
    # while hidden, no pixel of the far boat is labelled
    assert not np.any(s.label_image(t_cross) == 2)
    g = s.ground_truth(t_cross)
    k = list(g.ids).index(2)
    assert g.full_px[k] > 20 and g.visible_px[k] == 0


def test_determinism_same_seed_same_frames():
    a = make_scenario("crossing", seed=3, duration_s=4.0, fps=5.0)
    b = make_scenario("crossing", seed=3, duration_s=4.0, fps=5.0)
    c = make_scenario("crossing", seed=4, duration_s=4.0, fps=5.0)
    fa = [a.render(i).image for i in (0, 7, 15)]
    fb = [b.render(i).image for i in (15, 7, 0)][::-1]  # any order
    for x, y in zip(fa, fb):
        assert np.array_equal(x, y)
    assert not np.array_equal(fa[1], c.render(7).image)
    ga, gb = a.ground_truth(7), b.ground_truth(7)
    assert np.array_equal(ga.boxes, gb.boxes) and np.array_equal(ga.visible, gb.visible)


def test_horizon_matches_camera_model():
    s = make_scenario("open_sea", duration_s=3.0, fps=5.0)  # no coast, rolled and shaking camera
    for i in (0, 9):
        g = s.ground_truth(i)
        cam = s.camera_at(i)
        u = np.arange(s.width, dtype=float)
        hz = cam.horizon_row(u)
        # first pixel row whose centre lies below the horizon
        expected = np.ceil(hz - 1e-9)
        assert np.max(np.abs(g.water_row - expected)) <= 1.0
        assert abs(cam.pose.roll_deg) > 0.1  # the horizon really is tilted
    img = s.render_empty(0).astype(float)
    c = s.width // 2
    r = int(np.ceil(s.camera_at(0).horizon_row(float(c))))
    # the sky just above the horizon is brighter than the sea just below (EO)
    assert img[r - 4:r - 1, c - 20:c + 20].mean() > img[r + 2:r + 5, c - 20:c + 20].mean() + 10


def test_world_positions_project_into_boxes(harbour):
    """Ground-truth lat/lon projected by the camera model lands on the vessel's box (bottom centre)."""
    for i in (0, 300):
        g = harbour.ground_truth(i)
        cam = harbour.camera_at(i)
        u, v, d = cam.geodetic_to_pixel(g.lat_deg, g.lon_deg, 0.0)
        for k in range(len(g)):
            if g.visible[k] < 0.999:
                continue
            x, y, w, h = g.full_boxes[k]
            if x <= 0 or y <= 0 or x + w >= harbour.width or y + h >= harbour.height:
                continue
            assert x - 1 <= u[k] <= x + w + 1
            assert y <= v[k] <= y + h + 2  # the waterline is near the bottom of the box
            # azimuth/elevation of the truth matches the camera's pixel->azel
            az, el = cam.pixel_to_azel(u[k], v[k])
            assert abs((az - g.azel_deg[k, 0] + 180) % 360 - 180) < 0.02
            assert abs(el - g.azel_deg[k, 1]) < 0.02


def test_pan_scenario_moves_and_zooms():
    s = make_scenario("pan", duration_s=30.0, fps=2.0)
    pans = [s.ptz_at(i).pan_deg for i in range(s.n_frames)]
    zooms = [s.ptz_at(i).zoom for i in range(s.n_frames)]
    assert max(pans) - min(pans) > 40 and max(zooms) >= 3.0 and min(zooms) == 1.0
    i_zoom = int(np.argmax(zooms))
    g = s.ground_truth(i_zoom)
    lab = s.label_image(i_zoom)
    assert len(g) >= 1
    for vid, box, vpx in zip(g.ids, g.boxes, g.visible_px):
        ys, xs = np.nonzero(lab == vid)
        assert len(xs) == vpx
        if vpx:
            assert tuple(box) == (xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
    # the shake makes the true pose differ slightly from the commanded one
    assert g.pose.pan_deg != pytest.approx(g.ptz.pan_deg, abs=1e-6)
    assert abs((g.pose.pan_deg - g.ptz.pan_deg + 180) % 360 - 180) < 0.2
    f0, f1 = s.render(0).image, s.render(20).image
    assert f0.shape == f1.shape == (576, 704, 3)


def test_ir_frames_are_thermal():
    s = make_scenario("ir", duration_s=2.0, fps=5.0)
    f = s.render(3)
    assert f.modality == Modality.IR and f.image.ndim == 2 and f.image.dtype == np.uint8
    g = s.ground_truth(3)
    lab = s.label_image(3)
    assert len(g) >= 3
    # vessels are warmer than the sea around them (white-hot)
    img = f.image.astype(float)
    sea = img[(lab == 0)][int(0.6 * (lab == 0).sum()):].mean()  # lower part of the frame: sea
    hot = np.mean([img[lab == vid].mean() for vid in g.ids if (lab == vid).sum() > 20])
    assert hot > sea + 15
    bh = s.with_render_options(ir_polarity="black_hot").render(3).image.astype(float)
    assert bh[lab > 0].mean() < bh[lab == 0].mean()


def test_large_frames_render():
    s = make_scenario("harbour", width=1920, height=1080, duration_s=1.0, fps=2.0)
    f = s.render(1)
    g = s.ground_truth(1)
    assert f.image.shape == (1080, 1920, 3) and len(g) >= 4
    small = make_scenario("harbour", duration_s=1.0, fps=2.0).ground_truth(1)
    # the same vessels, boxes scaled by ~1920/704 horizontally
    common = sorted(set(g.ids) & set(small.ids))
    for vid in common:
        a, b = g.boxes[list(g.ids).index(vid)], small.boxes[list(small.ids).index(vid)]
        if b[2] > 15:
            assert a[2] / b[2] == pytest.approx(1920 / 704, rel=0.15)


def test_ptz_schedule_eases_between_keyframes():
    sch = PTZSchedule((0.0, 10.0), (350.0, 10.0), (-1.0, -2.0), (1.0, 4.0))
    assert sch.at(-1).pan_deg == 350.0 and sch.at(20).zoom == 4.0
    mid = sch.at(5.0)
    assert mid.pan_deg == pytest.approx(0.0, abs=1e-9) or mid.pan_deg == pytest.approx(360.0)
    assert mid.zoom == pytest.approx(2.0) and mid.tilt_deg == pytest.approx(-1.5)
    with pytest.raises(ValueError):
        PTZSchedule((0.0, 1.0), (0.0,), (0.0, 0.0), (1.0, 1.0))


def test_multicam_views_share_one_world():
    mc = make_multicam(seed=0, duration_s=2.0, fps=2.0)
    assert len(mc.views) == 3 and len({v.camera_id for v in mc.views}) == 3
    gts = mc.ground_truth(1)
    wt = mc.world_truth(1)
    seen = {}
    for g in gts:
        for k, vid in enumerate(g.ids):
            if g.visible[k] > 0.5:
                seen.setdefault(int(vid), []).append((g.lat_deg[k], g.lon_deg[k]))
    assert sum(len(x) >= 2 for x in seen.values()) >= 2  # vessels seen by two cameras or more
    for vid, pos in seen.items():
        j = list(wt["ids"]).index(vid)
        for lat, lon in pos:  # every camera reports the same world position
            assert lat == pytest.approx(wt["lat_deg"][j], abs=1e-9) and lon == pytest.approx(wt["lon_deg"][j], abs=1e-9)
    # the truth projects into the box in every camera
    for view, g in zip(mc.views, gts):
        cam = view.camera_at(1)
        u, v, _ = cam.geodetic_to_pixel(g.lat_deg, g.lon_deg, 0.0)
        for k in range(len(g)):
            x, y, w, h = g.full_boxes[k]
            if g.visible[k] > 0.999 and 0 < x and x + w < view.width and w > 4:
                assert x - 1.5 <= u[k] <= x + w + 1.5
    assert mc.ais_reports() == mc.views[1].ais_reports()


def test_multicam_write(tmp_path):
    mc = make_multicam(seed=1, duration_s=0.4, fps=5.0)
    paths = mc.write(tmp_path / "mc")
    for cid in ("cam0", "cam1", "cam2"):
        assert paths[f"{cid}/video"].is_file() and paths[f"{cid}/gt"].is_file()
    lines = paths["world_truth"].read_text().strip().splitlines()
    assert len(lines) == mc.n_frames * len(mc.vessels)


def test_write_outputs(tmp_path):
    s = make_scenario("crossing", duration_s=1.0, fps=5.0)
    paths = s.write(tmp_path / "out")
    for key in ("video", "gt", "gt_jsonl", "ais", "camera", "ptz", "meta"):
        assert paths[key].is_file() and paths[key].stat().st_size > 0
    rows = paths["gt"].read_text().strip().splitlines()
    frames = {int(r.split(",")[0]) for r in rows}
    assert frames <= set(range(1, 6)) and len(rows) == sum(len(s.ground_truth(i)) for i in range(5))
    assert paths["ptz"].read_text().count("\n") == 6
    import cv2

    cap = cv2.VideoCapture(str(paths["video"]))
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == 5
    from seawatch.camera import load_camera

    cam = load_camera(paths["camera"])
    assert cam.intrinsics.width == 704 and math.isclose(cam.pose.height_m, s.camera.pose.height_m)


def test_sea_waves_from_grid_match_full_size_maps():
    """The sea kernel that interpolates its maps from the coarse grid gives the same pixels as the
    one reading full-size maps made by cv2.resize of that grid (moving cameras use the former)."""
    import cv2

    from seawatch.sim._kernels import sea_waves, sea_waves_grid

    rng = np.random.default_rng(0)
    step, H, W = 16, 96, 80
    gh, gw = -(-H // step) + 2, -(-W // step) + 2
    grid = np.empty((gh, gw, 4), np.float32)
    grid[..., 0] = rng.uniform(-900, 900, (gh, gw))
    grid[..., 1] = rng.uniform(-900, 900, (gh, gw))
    grid[..., 2] = rng.uniform(0, 1.3, (gh, gw))
    grid[..., 3] = rng.uniform(0, 1, (gh, gw))
    grid[1, 1, 2:] = 0  # some pixels without waves
    tile = rng.integers(0, 256, (64, 64, 2), dtype=np.uint8)
    big = cv2.resize(grid, (gw * step, gh * step), interpolation=cv2.INTER_LINEAR)
    maps = np.ascontiguousarray(big[step:step + H, step:step + W])
    base = rng.integers(40, 200, (H, W, 3), dtype=np.uint8)
    gain = np.array([0.5, 0.55, 0.6], np.float32)
    glint = np.array([255.0, 255.0, 250.0], np.float32)
    wt = np.full(4, -1.0, np.float32)
    no_band = np.zeros((0, W, 2), np.float32)
    r0 = 7
    a, b = base.copy(), base.copy()
    sea_waves(a, r0, maps[r0:], tile, gain, glint, no_band, 0, wt)
    sea_waves_grid(b, r0, grid, step, tile, gain, glint, no_band, 0, wt)
    assert np.array_equal(a[:r0], base[:r0]) and np.array_equal(b[:r0], base[:r0])
    d = np.abs(a.astype(int) - b.astype(int))
    assert (a != base).mean() > 0.5  # the waves changed most pixels
    assert np.mean(d) < 0.05 and np.mean(d > 1) < 0.01


def _small_open_sea(**kw):
    return make_scenario("open_sea", seed=1, width=352, height=288, duration_s=3.0, fps=5.0, **kw)


def test_swaying_camera_panorama_matches_direct_render():
    """A swaying camera renders sky, coast and sea by one remap of cached panoramas; that agrees
    with rendering every pixel directly (up to resampling), and the ground truth is identical."""
    import cv2

    pano, direct = _small_open_sea(), _small_open_sea()
    assert pano.renderer.use_panorama  # open_sea only sways: the panorama path
    direct.renderer.use_panorama = False
    for i in (2, 11):
        t, cam = pano.time_s(i), pano.camera_at(i)
        a = pano.renderer.render(t, cam, i, draw_vessels=False)
        b = direct.renderer.render(t, cam, i, draw_vessels=False)
        x, y = a.image.astype(np.float32), b.image.astype(np.float32)
        assert np.max(np.abs(a.water_row - b.water_row)) <= 1.0
        top = int(min(a.water_row.min(), b.water_row.min())) - 3  # sky and clouds only above
        assert np.mean(np.abs(x[:top] - y[:top])) < 1.0
        assert np.mean(np.abs(x - y)) < 5.0  # wave texture sampled at other points
        # the same picture at the scale of a few pixels: local means agree
        bx, by = cv2.blur(x, (15, 15)), cv2.blur(y, (15, 15))
        assert np.mean(np.abs(bx - by)[8:-8, 8:-8]) < 1.5
        assert np.std(x[top + 40:]) > 5.0  # the waves are there
        ga, gb = pano.ground_truth(i), direct.ground_truth(i)
        assert len(ga) > 0
        assert np.array_equal(ga.boxes, gb.boxes) and np.array_equal(ga.visible, gb.visible)


def test_swaying_camera_panorama_any_order_and_memory_budget():
    """Panorama tiles built in any order, or not cached at all, give the same frames."""
    a, b, c = _small_open_sea(), _small_open_sea(), _small_open_sea()
    c.renderer.sea_cache_mb = 0.0  # every frame built for itself
    fa = [a.render(i).image for i in (0, 6, 13)]
    fb = [b.render(i).image for i in (13, 6, 0)][::-1]
    fc = [c.render(i).image for i in (6, 0, 13)]
    fc = [fc[1], fc[0], fc[2]]
    for x, y, z in zip(fa, fb, fc):
        assert np.array_equal(x, y) and np.array_equal(x, z)
    assert c.renderer._cache_bytes == 0 and a.renderer._cache_bytes > 0


@pytest.mark.parametrize("name, i", [("pan", 0), ("pan", 26), ("ir", 0)])
def test_band_covered_rows_skip_the_coarse_layer_exactly(name, i):
    """Rows the sharp horizon/coast band covers entirely are not resampled from the coarse
    panorama (a speed-up for moving cameras); the background is the same to the last bit, and
    the coarse layer of any row range equals that of the whole image."""
    s = make_scenario(name, seed=0, width=352, height=288, duration_s=27.0, fps=1.0)
    cam = s.camera_at(i)
    fast = s.renderer
    ref = make_scenario(name, seed=0, width=352, height=288, duration_s=27.0, fps=1.0).renderer
    ref._lo_skip_band = False
    rows = []
    lo_rows = fast._lo_rows
    fast._lo_rows = lambda bg, mlo, y0, y1: (rows.append(y1 - y0), lo_rows(bg, mlo, y0, y1))
    a, b = fast._build_view(cam), ref._build_view(cam)
    assert sum(rows) < fast.H  # some rows were left to the band
    assert np.array_equal(a.bg, b.bg) and np.array_equal(a.water_row, b.water_row)
    # the coarse layer in pieces (as the skipping does) equals the coarse layer of the whole image
    H, W, C = fast.H, fast.W, fast.C
    rng = np.random.default_rng(1)
    mlo = rng.uniform(0, 1, (H // 2, W // 2, 2)).astype(np.float32)
    mlo[..., 0] = mlo[..., 0] * 3 + np.arange(W // 2)[None, :] * 0.7 + 20
    mlo[..., 1] = mlo[..., 1] * 3 + np.arange(H // 2)[:, None] * 0.7 + 15
    whole = np.zeros((H, W, C), np.uint8)
    fast._lo_rows(whole, mlo, 0, H)
    for y0, y1 in ((0, 101), (101, 140), (140, H), (3, 4), (57, 58), (H - 1, H)):
        part = np.zeros((H, W, C), np.uint8)
        fast._lo_rows(part, mlo, y0, y1)
        assert np.array_equal(part[y0:y1], whole[y0:y1])


def test_sea_sampled_by_remap_matches_the_per_pixel_kernel():
    """Moving cameras sample the wave tile with one cv2.remap at coordinates interpolated from the
    grid (row by row, inside the kernel) and wrapped into the tile, then shade element-wise on the
    interpolated sea base colour: the coordinates are those of resizing the grid to the image
    (whole tiles apart), and the pixels within 1 grey level of the per-pixel kernel (remap's
    1/32-texel weights), for coordinates far outside the tile, at full and at half width."""
    import cv2

    from seawatch.sim._kernels import sea_maps_grid, sea_shade_grid, sea_waves_grid
    from seawatch.sim.render import _grid_cols

    rng = np.random.default_rng(2)
    step, H, W = 16, 96, 80
    gh, gw = -(-H // step) + 2, -(-W // step) + 2
    grid = np.empty((gh, gw, 4), np.float32)
    grid[..., 0] = rng.uniform(-3000, 3000, (gh, gw))
    grid[..., 1] = rng.uniform(-3000, 3000, (gh, gw))
    grid[..., 2] = rng.uniform(0, 1.3, (gh, gw))
    grid[..., 3] = rng.uniform(0, 1, (gh, gw))
    colour = np.array([120.0, 90.0, 60.0], np.float32)
    base_grid = np.zeros((gh, gw, 4), np.float32)
    base_grid[..., :3] = colour  # the sea base colour (and padding)
    tile = rng.integers(0, 256, (64, 64, 2), dtype=np.uint8)
    tile4 = np.zeros((65, 65, 4), np.uint8)
    tile4[:, :, :2] = np.pad(tile, ((0, 1), (0, 1), (0, 0)), mode="wrap")
    gain = np.array([0.5, 0.55, 0.6], np.float32)
    glint = np.array([255.0, 255.0, 250.0], np.float32)
    for sx, w in ((step, W), (step // 2, W // 2)):  # full width, half width
        big = cv2.resize(grid, (gw * sx, gh * step), interpolation=cv2.INTER_LINEAR)
        seg, wts = _grid_cols(w, sx, gw)
        y0 = 5  # rows y0 .. H of the image
        maps = np.empty((H - y0, w, 2), np.float32)
        sea_maps_grid(grid, y0, step, seg, wts, 64, maps)
        assert maps.min() >= 0 and maps.max() < 64
        k = (big[step + y0:step + H, sx:sx + w, :2].astype(np.float64) - maps) / 64.0  # whole tiles apart
        assert np.abs(k - np.round(k)).max() < 1e-4
        tex = cv2.remap(tile4, maps, None, cv2.INTER_LINEAR)
        b = np.zeros((H - y0, w, 3), np.uint8)
        sea_shade_grid(b, tex, grid, base_grid, y0, step, seg, wts, gain, glint)
        if sx == step:  # full width: the per-pixel kernel at the same pixels
            base = np.empty((H, W, 3), np.uint8)
            base[:] = colour.astype(np.uint8)
            a = base.copy()
            sea_waves_grid(a, 0, grid, step, tile, gain, glint, np.zeros((0, W, 2), np.float32), 0,
                           np.full(4, -1.0, np.float32))
            d = np.abs(a[y0:].astype(int) - b.astype(int))
            assert (a != base).mean() > 0.5
            assert d.max() <= 1 and d.mean() < 0.2
        # one channel (IR) takes the same arithmetic
        c = np.zeros((H - y0, w, 1), np.uint8)
        sea_shade_grid(c, tex, grid, base_grid, y0, step, seg, wts, gain[:1], glint[:1])
        assert np.array_equal(c[..., 0], b[..., 0])


def test_half_width_sea_keeps_the_waves_and_the_truth():
    """The sea of a moving camera (the default for one that pans, tilts or zooms) with range-dependent
    detail: the ground truth identical, the sky, coast and band rows untouched, the far water
    (texture minified) within 2 grey levels of the per-pixel kernel everywhere, the near water
    (half width) within 2 grey levels on average, with the wave contrast within 10 %."""
    i = 3
    opts = dict(noise_sigma=0.0, jpeg_quality=0)
    a = make_scenario("pan", seed=0, width=704, height=576, duration_s=10.0, fps=1.0).with_render_options(**opts)
    b = a.with_render_options(sea_half_res=False, **opts)
    assert a.renderer.sea_half_res and not b.renderer.sea_half_res
    ra, rb = a._render(i), b._render(i)
    assert np.array_equal(ra.label, rb.label) and np.array_equal(ra.boxes, rb.boxes)
    assert np.array_equal(ra.visible, rb.visible)
    view = a.renderer._view(a.camera_at(i))
    ys, yl = view.half_y0, view.lod_y
    assert 0 < ys < yl < a.height  # far water rows at full resolution, the near ones at half width
    ia, ib = ra.image.astype(np.float64), rb.image.astype(np.float64)
    assert np.array_equal(ia[:ys], ib[:ys])
    water = ra.label == 0
    d_full = np.abs(ia[ys:yl] - ib[ys:yl])[water[ys:yl]]  # sampled with cv2.remap, full resolution
    assert d_full.mean() < 0.5 and d_full.max() <= 2
    d = np.abs(ia[ys:] - ib[ys:])[water[ys:]]
    assert d.mean() < 2.0 and np.percentile(d, 99) <= 10
    water = water[ys:]

    def contrast(img):  # spread of the row-detrended water pixels (green)
        g = img[ys:, :, 1] - img[ys:, :, 1].mean(axis=1, keepdims=True)
        return g[water].std()

    ca, cb = contrast(ia), contrast(ib)
    assert cb > 5.0 and abs(ca - cb) < 0.1 * cb
    # the same seed renders the same frame again
    c = make_scenario("pan", seed=0, width=704, height=576, duration_s=10.0, fps=1.0).with_render_options(**opts)
    assert np.array_equal(c.render(i).image, ra.image)


def test_bgra_remap_is_bit_identical():
    """Panoramas resampled as BGRA (OpenCV's fast 4-channel path) and converted back give the
    same pixels as resampling the 3-channel panorama, also with BORDER_TRANSPARENT."""
    import cv2

    from seawatch.sim.render import _bgra, _from_bgra, _remap_into

    rng = np.random.default_rng(3)
    src = rng.integers(0, 256, (60, 90, 3), dtype=np.uint8)
    maps = np.dstack([rng.uniform(-5, 95, (40, 50)), rng.uniform(-5, 65, (40, 50))]).astype(np.float32)
    a = cv2.remap(src, maps, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    b = _from_bgra(cv2.remap(_bgra(src), maps, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE), 3)
    assert np.array_equal(a, b)
    base = rng.integers(0, 256, (40, 50, 3), dtype=np.uint8)
    c = base.copy()
    cv2.remap(src, maps, None, cv2.INTER_LINEAR, dst=c, borderMode=cv2.BORDER_TRANSPARENT)
    d = base.copy()
    _remap_into(d, _bgra(src), maps)
    assert np.array_equal(c, d) and not np.array_equal(d, base)
    outside = (maps[..., 0] < -1) | (maps[..., 1] < -1)
    assert np.array_equal(d[outside], base[outside])


def test_upsampled_grid_rows_equal_the_whole_grid():
    """Upsampling only the grid rows an image band needs gives the pixels of upsampling it all."""
    import cv2

    from seawatch.sim.render import _upsample_grid

    rng = np.random.default_rng(4)
    for _ in range(40):
        step = int(rng.choice([8, 16]))
        H, W = int(rng.integers(20, 300)), int(rng.integers(20, 200))
        gw, gh = -(-W // step) + 2, -(-H // step) + 2
        a = rng.normal(size=(gh, gw, 2)).astype(np.float32)
        r0 = int(rng.integers(0, H))
        h1 = int(rng.integers(r0 + 1, H + 1))
        whole = cv2.resize(a, (gw * step, gh * step), interpolation=cv2.INTER_LINEAR)
        ref = whole[r0 + step:h1 + step, step:step + W]
        assert np.array_equal(_upsample_grid(a, gw, step, (h1, W), r0), ref)


def test_sensor_noise_bank_sigma_and_frame_to_frame_change():
    """Sensor noise comes from a fixed, seeded bank at a random offset per frame: the noise of a
    frame has the bank's spread (Gaussian draws of the configured sigma truncated to whole grey
    levels: 0.88 sigma), is unbiased, and consecutive frames get different noise."""
    s = make_scenario("harbour", seed=0, width=352, height=288, duration_s=3.0, fps=5.0)
    clean = s.with_render_options(noise_sigma=0.0)
    noisy = s.with_render_options(noise_sigma=3.0)
    r = noisy.renderer
    bank = r._noise_pos.astype(np.int16) - r._noise_neg.astype(np.int16)
    assert abs(bank.std() - 0.878 * 3.0) < 0.03 and abs(bank.mean()) < 0.02
    n = [noisy.render(i).image.astype(np.int16) - clean.render(i).image.astype(np.int16) for i in (4, 5)]
    for x in n:
        assert abs(x.std() - bank.std()) < 0.1 and abs(x.mean()) < 0.1
    assert np.mean(n[0] == n[1]) < 0.5  # different noise in consecutive frames
    assert np.array_equal(noisy.render(4).image.astype(np.int16) - clean.render(4).image, n[0])


@pytest.mark.parametrize("ir", [False, True], ids=["eo", "ir"])
def test_moving_camera_sampled_sea_frames_any_order(ir):
    """The moving camera's sampled sea keeps scratch buffers in the renderer across frames; frames
    spread over the zoom (1x, 1.9x, 3.5x: different water rows, half-width and full-width parts),
    rendered in reverse order with noise and JPEG on, equal the same frames of a fresh scenario
    rendered forward, so nothing of one frame leaks into the next (EO and IR)."""
    frames = (5, 21, 26)

    def fresh():
        s = make_scenario("pan", seed=0, width=704, height=576, duration_s=45.0, fps=1.0)
        return s.with_render_options(ir=ir, noise_sigma=2.0, jpeg_quality=85)

    a, b = fresh(), fresh()
    assert a.renderer.sea_half_res and a.renderer.C == (1 if ir else 3)
    zooms = [a.ptz_at(i).zoom for i in frames]
    assert zooms[0] == 1.0 and 1.5 < zooms[1] < 3.0 and zooms[2] == pytest.approx(3.5)
    fwd = [a.render(i).image for i in frames]
    rev = [b.render(i).image for i in frames[::-1]][::-1]
    for x, y in zip(fwd, rev):
        assert x.shape == ((576, 704) if ir else (576, 704, 3))
        assert np.array_equal(x, y)
    assert not np.array_equal(fwd[0], fwd[1]) and not np.array_equal(fwd[1], fwd[2])
    # the same frame again after the others (the buffers hold frame 5's rows) is unchanged, also
    # with every scratch buffer overwritten by a value no frame computes (nothing read unwritten)
    assert np.array_equal(b.render(21).image, fwd[1])
    assert len(b.renderer._bufs) >= 3
    for buf in b.renderer._bufs.values():
        buf.fill(165 if buf.dtype == np.uint8 else -7777)
    assert np.array_equal(b.render(26).image, fwd[2])
    # noise is on: the same frame without sensor noise differs
    quiet = a.with_render_options(noise_sigma=0.0).render(21).image
    assert np.mean(quiet != fwd[1]) > 0.2
