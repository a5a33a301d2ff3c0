"""Stable features on the water (the deviations of paper B that use the horizon): still clusters
on the water, the water-band keypoint pass, the camera motion fitted to the scene above the
horizon, guided matching, and the horizon from the camera model."""

import cv2
import numpy as np

from seawatch.camera import CameraModel, Intrinsics
from seawatch.detect.features import StableFeatureExtractor
from seawatch.detect.horizon import Horizon
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, StableFeatureTracker, frame_edges
from seawatch.types import CameraPose, Frame, PTZState

FPS = 10.0
W, H = 320, 240
HORIZON_ROW = 100.0


def _hist(v, n=6):
    return np.tile(np.asarray(v, float), (n, 1))


# ---------------------------------------------------------------- graph edges
def test_still_features_on_the_water_are_joined_and_a_moving_neighbour_is_not():
    xy = np.array([[50, 150], [56, 151], [62, 150],  # a still boat on the water
                   [70, 150],  # a moving boat's feature right next to it
                   [75, 151],  # ... and its second feature
                   [50, 60], [56, 61]])  # still features in the sky (scene, not water)
    rng = np.random.default_rng(0)
    still = [_hist(rng.normal(0, 0.3, 2)) for _ in range(3)]
    moving = [_hist([12.0, 0.0]), _hist([12.5, 0.3])]
    sky = [_hist(rng.normal(0, 0.3, 2)) for _ in range(2)]
    history = np.stack(still + moving + sky)
    on_water = xy[:, 1] > HORIZON_ROW
    i, j, d = frame_edges(xy, history, 0.31, 50.0, min_speed_px_s=1.5, still_ok=on_water, still_radius_px=15.0)
    edges = set(zip(i.tolist(), j.tolist()))
    assert {(0, 1), (1, 2), (0, 2)} <= edges  # the still boat (0-2 is 12 px apart)
    assert (3, 4) in edges  # the moving boat, by the paper's motion dissimilarity
    assert not any((a < 3) != (b < 3) for a, b in edges if max(a, b) < 5)  # still and moving never joined
    assert (5, 6) not in edges  # still features off the water are scene
    assert np.all(d < 0.31) and np.all(i < j)
    # without the water mask (the paper's graph) the still boat makes no edge
    i0, j0, _ = frame_edges(xy, history, 0.31, 50.0, min_speed_px_s=1.5)
    assert set(zip(i0.tolist(), j0.tolist())) == {(3, 4)}
    # a still pair farther apart than still_radius_px stays apart
    far = xy.copy()
    far[1] = [80, 190]
    i2, j2, _ = frame_edges(far, history, 0.31, 50.0, min_speed_px_s=1.5, still_ok=on_water, still_radius_px=15.0)
    assert (0, 1) not in set(zip(i2.tolist(), j2.tolist()))


# ------------------------------------------------------------ synthetic scene
def _scene(rng, boats, shift=(0.0, 0.0), t=0.0, noise=3.0):
    """Sky with a textured coast above the horizon row, a sea of changing noise below it, and
    small still boats (x, y, w, h) on the water; the camera shifts the whole image by ``shift``."""
    big = np.empty((H + 80, W + 80), np.float32)
    big[:] = 170
    r2 = np.random.default_rng(11)
    y_h = int(HORIZON_ROW) + 40
    for _ in range(90):  # coast just above the horizon
        x, y, s = r2.integers(0, W + 80), r2.integers(y_h - 25, y_h), r2.integers(2, 7)
        big[y - s: y, x: x + s] = r2.uniform(40, 240)
    big[y_h:] = 110
    for (x, y, w, h) in boats:
        x, y = x + 40, y + 40
        big[y: y + h, x: x + w] = 30
        big[y + 1: y + 3, x + 1: x + w // 2] = 230
        big[y + h - 3: y + h - 1, x + w // 2 + 1: x + w - 1] = 200
    m = np.float32([[1, 0, -40 + shift[0]], [0, 1, -40 + shift[1]]])
    img = cv2.warpAffine(big, m, (W, H), flags=cv2.INTER_LINEAR)
    img[int(HORIZON_ROW) + 2:] += rng.normal(0, noise, (H - int(HORIZON_ROW) - 2, W)).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8)


def test_band_pass_gives_small_far_boats_more_keypoints():
    rng = np.random.default_rng(1)
    boats = [(40 + 45 * k, 106 + 3 * k, 9, 6) for k in range(6)]  # 9 x 6 px boats just below the horizon
    img = _scene(rng, boats)
    hz = Horizon(HORIZON_ROW, HORIZON_ROW, W)

    def on_boats(snap):
        n = []
        for (x, y, w, h) in boats:
            inb = ((snap.xy[:, 0] >= x - 1) & (snap.xy[:, 0] <= x + w + 1)
                   & (snap.xy[:, 1] >= y - 1) & (snap.xy[:, 1] <= y + h + 1))
            n.append(int(inb.sum()))
        return np.array(n)

    plain = on_boats(StableFeatureExtractor(nominal_fps=FPS).process(img, 0.0))
    band = on_boats(StableFeatureExtractor(nominal_fps=FPS).process(img, 0.0, horizon=hz))
    off = on_boats(StableFeatureExtractor(nominal_fps=FPS, band_px=0).process(img, 0.0, horizon=hz))
    assert band.sum() > plain.sum() and np.all(band >= 1)
    assert np.array_equal(off, plain)  # band_px = 0: the paper's single pass


def test_still_boats_on_the_water_are_tracked_with_a_horizon_and_not_without():
    rng = np.random.default_rng(2)
    boats = [(60, 120, 16, 9), (200, 140, 20, 10)]
    hz = Horizon(HORIZON_ROW, HORIZON_ROW, W)
    found = {}
    for name, h in (("water", hz), ("paper", None)):
        ext = StableFeatureExtractor(nominal_fps=FPS)
        cl = FeatureClusterer(ClusterParams())
        ids = {0: set(), 1: set()}
        for i in range(30):
            t = i / FPS
            shift = (2.0 * i, 0.5 * np.sin(i))  # the camera pans; the boats stay still on the water
            img = _scene(rng, boats, shift, t)
            snap = ext.process(img, t, i, horizon=h)
            _, tracks = cl.update(snap, img, horizon=h)
            conf = tracks.states == 1
            if i < 15:
                continue
            for k, (x, y, w, hh) in enumerate(boats):
                x, y = x + shift[0], y + shift[1]  # the image moves with the shift
                for tid, b in zip(tracks.ids[conf], tracks.boxes[conf]):
                    cx, cy = b[0] + 0.5 * b[2], b[1] + 0.5 * b[3]
                    if x - 3 <= cx <= x + w + 3 and y - 3 <= cy <= y + hh + 3:
                        ids[k].add(int(tid))
        found[name] = ids
    # with the water: each still boat is one object, and the two are different objects
    assert all(len(found["water"][k]) == 1 for k in (0, 1))
    assert found["water"][0] != found["water"][1]
    # the paper's graph (no water mask) cannot tell a still boat from the scene
    assert not found["paper"][0] and not found["paper"][1]


def test_camera_motion_is_fitted_to_the_scene_above_the_horizon():
    rng = np.random.default_rng(3)
    # a big boat on the water, moving right by 3 px per frame; its features outnumber the coast's
    boat = (np.full((40, 150), 40, np.float32), 60, 150)
    r2 = np.random.default_rng(4)
    for _ in range(60):
        x, y = r2.integers(0, 144), r2.integers(0, 34)
        boat[0][y: y + 4, x: x + 4] = r2.uniform(150, 255)
    hz = Horizon(HORIZON_ROW, HORIZON_ROW, W)
    ext = {k: StableFeatureExtractor(nominal_fps=FPS, band_px=0, min_camera_matches=4) for k in ("scene", "all")}
    tx = {}
    for i in range(12):
        img = _scene(rng, [], noise=0.0).astype(np.float32)
        img[HORIZON_ROW.__int__() + 2:] = 110
        x0 = boat[1] + 3 * i
        img[boat[2]: boat[2] + 40, x0: x0 + 150] = boat[0]
        img = img.astype(np.uint8)
        for k, e in ext.items():
            snap = e.process(img, i / FPS, i, horizon=hz if k == "scene" else None)
            tx.setdefault(k, []).append(snap.homography[0, 2])
    # the camera does not move: fitted to the coast it stays put; fitted to all stable features
    # (the boat's outnumber the coast's) it follows the boat
    assert np.abs(tx["scene"][6:]).max() < 0.3
    assert np.median(tx["all"][6:]) > 2.0


def test_guided_matching_keeps_a_feature_near_where_it_is_expected():
    # a feature whose look-alike appears far away is not matched to it
    rng = np.random.default_rng(5)
    img = (rng.random((H, W)) > 0.985).astype(np.float32) * 255
    img = np.clip(cv2.GaussianBlur(img, (0, 0), 1.2) * 4, 0, 255).astype(np.uint8)
    ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=10.0, gate_min_px_s=50.0)
    for i in range(6):
        snap = ext.process(img, i / FPS)
    assert snap.stable.sum() > 20
    ids_before = dict(zip(snap.ids.tolist(), snap.xy.tolist()))
    moved = np.roll(img, 120, axis=1)  # the whole picture jumps by 120 px: beyond the search radius
    snap2 = ext.process(moved, 6 / FPS)
    assert snap2.n_matched < 0.1 * snap.stable.sum()  # only chance look-alikes within the radius
    paper = StableFeatureExtractor(nominal_fps=FPS, guided_px=0.0, gate_min_px_s=5000.0)
    for i in range(6):
        paper.process(img, i / FPS)
    assert paper.process(moved, 6 / FPS).n_matched > 20  # the paper's global search follows the jump
    assert len(ids_before) > 20


def test_tracker_takes_the_horizon_from_the_camera_model_at_the_frames_ptz_state():
    cam = CameraModel(Intrinsics.from_fov(50.0, W, H),
                      CameraPose(lat_deg=50.8, lon_deg=-1.1, height_m=20.0, pan_deg=180.0, tilt_deg=-2.0))
    trk = StableFeatureTracker(camera=cam)
    img = np.full((H, W), 120, np.uint8)
    trk.process(Frame(img, 0.0, 0, ptz=PTZState(0.0, 180.0, -2.0, 1.0)))
    low = trk.last_horizon
    trk.process(Frame(img, 0.1, 1, ptz=PTZState(0.1, 180.0, -4.0, 1.0)))  # tilted down: the horizon rises
    high = trk.last_horizon
    assert low is not None and high is not None
    assert abs(low.y_left - float(cam.horizon_row(0.0))) < 0.5
    assert high.y_left < low.y_left - 5
    # no camera: no horizon unless asked to detect it in the image
    trk2 = StableFeatureTracker()
    trk2.process(Frame(img, 0.0, 0))
    assert trk2.last_horizon is None


def test_relink_follows_a_lost_boat_with_its_own_velocity():
    from test_feature_boxes import snap

    vel = [[40.0, 0.0]] * 2  # the boat moves 40 px/s; the camera is still
    ids = {}
    for predict in (True, False):
        c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=2.0, relink_px=10.0, relink_predict=predict,
                                           relink_predict_s=2.0, relink_px_per_s=0.0))
        _, tr = c.update(snap([[100, 60], [110, 62]], vel, 0.0, 0, ids=[1, 2]))
        first = int(tr.ids[0])
        for k in range(1, 11):  # lost for a second
            _, tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.1 * k, k, ids=[]))
            assert len(tr) == 0
        # found again 44 px further on (1.1 s at 40 px/s), with new features
        _, tr = c.update(snap([[144, 60], [154, 62]], vel, 1.1, 11, ids=[3, 4]))
        ids[predict] = (first, int(tr.ids[0]))
    assert ids[True][0] == ids[True][1]  # predicted with its velocity: the same identity
    assert ids[False][0] != ids[False][1]  # where it was lost: 44 px away, a new identity


def test_horizon_mode_comes_from_the_settings_and_a_bad_one_is_named():
    from seawatch.config import load_config

    cam = CameraModel(Intrinsics.from_fov(50.0, W, H),
                      CameraPose(lat_deg=50.8, lon_deg=-1.1, height_m=20.0, pan_deg=180.0, tilt_deg=-2.0))
    off = StableFeatureTracker.from_settings(load_config(overrides=["tracker.sf_horizon=off"]).tracker, camera=cam)
    off.process(Frame(np.full((H, W), 120, np.uint8), 0.0, 0, ptz=PTZState(0.0, 180.0, -2.0, 1.0)))
    assert off.last_horizon is None
    on = StableFeatureTracker.from_settings(load_config().tracker, camera=cam)
    on.process(Frame(np.full((H, W), 120, np.uint8), 0.0, 0, ptz=PTZState(0.0, 180.0, -2.0, 1.0)))
    assert on.last_horizon is not None
    # the clusterer gets the frame's camera (for the relink by the camera model) in every horizon
    # mode, at the frame's PTZ state
    for mode in ("off", "detect", "camera", "auto"):
        trk = StableFeatureTracker(camera=cam, horizon=mode)
        seen = []
        upd = trk.clusterer.update
        trk.clusterer.update = lambda *a, _u=upd, **k: (seen.append(k.get("camera")), _u(*a, **k))[1]
        trk.process(Frame(np.full((H, W), 120, np.uint8), 0.0, 0, ptz=PTZState(0.0, 181.0, -3.0, 1.0)))
        assert seen[0] is not None and seen[0].pose.pan_deg == 181.0 and seen[0].pose.tilt_deg == -3.0, mode
    import pytest

    from seawatch.config import ConfigError

    # a bad value is refused when the settings are read (tests/test_config.py), and by the stage
    with pytest.raises(ConfigError, match="tracker.sf_horizon = 'sky'"):
        load_config(overrides=["tracker.sf_horizon=sky"])
    with pytest.raises(ValueError, match="horizon must be auto, camera, detect or off, not 'sky'"):
        StableFeatureTracker(camera=cam, horizon="sky")


# ------------------------------------------------------ horizon from the camera
def _rolled_camera(width=640, height=480):
    """A camera with roll (a sloping horizon, so both line ends matter), at another size than the frames."""
    return CameraModel(Intrinsics(600.0, 640.0, 300.0, 250.0, width, height),
                       CameraPose(lat_deg=50.8, lon_deg=-1.1, height_m=25.0, pan_deg=90.0, tilt_deg=-1.5,
                                  roll_deg=3.0))


def test_camera_horizon_rescales_the_camera_to_a_frame_of_another_size():
    from seawatch.track.feature_clusters import camera_horizon

    cam = _rolled_camera()
    ptz = PTZState(0.0, 95.0, -2.5, 1.6)
    for w, h in ((320, 240), (352, 288), (640, 480)):  # sx = sy, sx != sy, the camera's own size
        hz, zoom = camera_horizon(cam, Frame(np.zeros((h, w), np.uint8), 0.0, 0, ptz=ptz))
        ref = cam.with_ptz(ptz).with_intrinsics(cam.with_ptz(ptz).intrinsics.scaled_to(w, h))
        yl, yr = ref.horizon_line()
        assert zoom == 1.6 and hz.width == w
        assert abs(hz.y_left - yl) < 1e-9 and abs(hz.y_right - yr) < 1e-9
        assert abs(float(hz.row_at(w - 1)) - float(ref.horizon_row(w - 1.0))) < 1e-9  # the end column is w - 1
        assert abs(hz.y_right - hz.y_left) > 5  # the roll slopes the line
    # at another size the line is the camera's own, rescaled (rows by the height ratio, half-pixel centres)
    hz2, _ = camera_horizon(cam, Frame(np.zeros((288, 352), np.uint8), 0.0, 0, ptz=ptz))
    full, _ = camera_horizon(cam, Frame(np.zeros((480, 640), np.uint8), 0.0, 0, ptz=ptz))
    mid_full = float(full.row_at(319.5))  # the centre column of both images
    assert abs(float(hz2.row_at(175.5)) - ((mid_full + 0.5) * 288 / 480 - 0.5)) < 0.05


def test_camera_horizon_follows_the_frames_pose_without_ptz():
    from dataclasses import replace

    from seawatch.track.feature_clusters import camera_horizon

    cam = _rolled_camera()
    pose = replace(cam.pose, height_m=60.0, pan_deg=100.0, tilt_deg=-4.0, roll_deg=-2.0)
    w, h = 352, 288
    hz, zoom = camera_horizon(cam, Frame(np.zeros((h, w), np.uint8), 0.0, 0, pose=pose))
    ref = CameraModel(cam.intrinsics.scaled_to(w, h), pose, cam.refraction_k)
    yl, yr = ref.horizon_line()
    assert zoom == 1.0
    assert abs(hz.y_left - yl) < 1e-9 and abs(hz.y_right - yr) < 1e-9
    # the pose moves the line: tilted further down and rolled the other way
    base, _ = camera_horizon(cam, Frame(np.zeros((h, w), np.uint8), 0.0, 0))
    assert hz.y_left < base.y_left - 10 and (hz.y_right - hz.y_left) * (base.y_right - base.y_left) < 0
    # the PTZ state, when the frame has one, wins over the pose
    ptz = PTZState(0.0, 90.0, -1.5, 1.0)
    hz3, _ = camera_horizon(cam, Frame(np.zeros((h, w), np.uint8), 0.0, 0, pose=pose, ptz=ptz))
    assert abs(hz3.y_left - base.y_left) < 1e-9


def _sea_and_sky(row, seed=0):
    """A bright sky above ``row`` and a darker, noisy sea below it."""
    rng = np.random.default_rng(seed)
    img = np.full((H, W), 200.0)
    img[row:] = 90.0 + rng.normal(0, 6.0, (H - row, W))
    return np.clip(img, 0, 255).astype(np.uint8)


def test_detect_and_auto_find_the_horizon_in_the_image():
    cam = CameraModel(Intrinsics.from_fov(50.0, W, H),
                      CameraPose(lat_deg=50.8, lon_deg=-1.1, height_m=20.0, pan_deg=180.0, tilt_deg=-2.0))
    img = _sea_and_sky(150)  # the camera model would put the horizon near row 140 - 2 deg
    ptz = PTZState(0.0, 180.0, -2.0, 1.0)
    from_cam = float(cam.horizon_row(0.0))
    assert abs(from_cam - 150) > 20
    for mode, camera in (("detect", cam), ("auto", None)):
        trk = StableFeatureTracker(camera=camera, horizon=mode)
        trk.process(Frame(img, 0.0, 0, ptz=ptz))
        hz = trk.last_horizon
        assert hz is not None, mode
        assert abs(hz.y_left - 150) < 3 and abs(hz.y_right - 150) < 3, (mode, hz)
    # auto with a camera takes the camera's line; camera mode without one has none
    trk = StableFeatureTracker(camera=cam, horizon="auto")
    trk.process(Frame(img, 0.0, 0, ptz=ptz))
    assert abs(trk.last_horizon.y_left - from_cam) < 1e-6
    trk = StableFeatureTracker(horizon="camera")
    trk.process(Frame(img, 0.0, 0, ptz=ptz))
    assert trk.last_horizon is None


def test_the_coast_foot_within_the_water_margin_is_not_a_still_object():
    # a still object whose features lie 3-7 px under the sea horizon (the foot of a coast in front
    # of it) is not joined by default (water_margin_px 8); with the old margin of 4 px it was
    rng = np.random.default_rng(6)
    boats = [(60, 102, 20, 6), (200, 140, 20, 10)]
    hz = Horizon(HORIZON_ROW, HORIZON_ROW, W)
    seen = {}
    for margin in (8.0, 4.0):
        ext = StableFeatureExtractor(nominal_fps=FPS)
        cl = FeatureClusterer(ClusterParams(water_margin_px=margin))
        hits = {0: 0, 1: 0}
        ys = []
        for i in range(30):
            t = i / FPS
            img = _scene(rng, boats, (2.0 * i, 0.0), t)
            snap = ext.process(img, t, i, horizon=hz)
            _, tracks = cl.update(snap, img, horizon=hz)
            if i < 15:
                continue
            for k, (x, y, w, hh) in enumerate(boats):
                x0 = x + 2.0 * i
                inb = snap.stable & (np.abs(snap.xy[:, 0] - (x0 + w / 2)) < w / 2 + 2) & \
                    (np.abs(snap.xy[:, 1] - (y + hh / 2)) < hh / 2 + 2)
                if k == 0:
                    ys += (snap.xy[inb, 1] - HORIZON_ROW).tolist()
                for b in tracks.boxes[tracks.states == 1]:
                    cx, cy = b[0] + 0.5 * b[2], b[1] + 0.5 * b[3]
                    if x0 - 3 <= cx <= x0 + w + 3 and y - 3 <= cy <= y + hh + 3:
                        hits[k] += 1
                        break
        seen[margin] = (hits, ys)
    ys = np.array(seen[8.0][1])
    assert len(ys) and 4.0 < np.median(ys) < 8.0  # the object's features lie between the margins
    assert seen[8.0][0][0] == 0 and seen[4.0][0][0] >= 10  # joined with 4 px only
    assert seen[8.0][0][1] >= 10 and seen[4.0][0][1] >= 10  # a still boat lower down either way
