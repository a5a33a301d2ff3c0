"""Stable features (paper B, step 1) and the whole tracker on a short synthetic pan and zoom."""

import cv2
import numpy as np
import pytest

from seawatch.config import load_config
from seawatch.detect.features import (
    StableFeatureExtractor,
    fit_zoom_pan,
    match_quality,
    select_keypoints,
    to_grey_u8,
)
from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker
from seawatch.types import DetectorTracker, Frame, TrackState

FPS = 25.0
W, H = 320, 240


# --------------------------------------------------------------- synthetic scene
def _world(rng, w=1400, h=500):
    img = np.empty((h, w), np.float32)
    img[:200] = 200 - 0.1 * np.arange(200)[:, None]  # sky
    img[200:260] = 90  # coast: boxes of random grey
    for _ in range(260):
        x, y, s = rng.integers(0, w), rng.integers(200, 260), rng.integers(3, 12)
        img[max(200, y - s): y + s, x: x + s] = rng.uniform(20, 230)
    img[260:] = 120  # sea
    return img


def _boat(rng, bw, bh):
    b = np.full((bh, bw), 40, np.float32)
    for _ in range(14):
        x, y = rng.integers(0, bw - 6), rng.integers(0, bh - 6)
        b[y: y + rng.integers(3, 7), x: x + rng.integers(3, 8)] = rng.uniform(150, 255)
    return b


def synthetic_pan(n_frames=90, seed=0, pan_px_s=60.0, zoom_per_s=0.1):
    """A camera panning right and zooming in over a coast, two textured boats crossing.

    Yields ``(t_s, image, boxes)``, boxes a dict ``boat -> (x, y, w, h)`` (visible part).
    """
    rng = np.random.default_rng(seed)
    world = _world(rng)
    boats = [(_boat(rng, 56, 22), 420.0, 300.0, 40.0), (_boat(rng, 70, 26), 700.0, 330.0, -30.0)]
    for i in range(n_frames):
        t = i / FPS
        canvas = world.copy()
        canvas[260:] += rng.normal(0, 4, (canvas.shape[0] - 260, canvas.shape[1])).astype(np.float32)
        placed = []
        for k, (patch, x0, y0, vx) in enumerate(boats):
            xi, yi = int(round(x0 + vx * t)), int(round(y0))
            canvas[yi: yi + patch.shape[0], xi: xi + patch.shape[1]] = patch
            placed.append((k, xi, yi, patch.shape[1], patch.shape[0]))
        cx, cy, z = 540 + pan_px_s * t, 290.0, 1.0 + zoom_per_s * t
        m = np.array([[z, 0, W / 2 - z * cx], [0, z, H / 2 - z * cy]])
        img = np.clip(cv2.warpAffine(canvas, m, (W, H), flags=cv2.INTER_LINEAR), 0, 255).astype(np.uint8)
        boxes = {}
        for k, xi, yi, pw, ph in placed:
            x0, y0 = z * xi + m[0, 2], z * yi + m[1, 2]
            x1, y1 = min(x0 + z * pw, W), min(y0 + z * ph, H)
            x0, y0 = max(x0, 0), max(y0, 0)
            if x1 - x0 > 0 and y1 - y0 > 0:
                boxes[k] = (x0, y0, x1 - x0, y1 - y0)
        yield t, img, boxes


def _iou(a, b):
    ax1, ay1, bx1, by1 = a[0] + a[2], a[1] + a[3], b[0] + b[2], b[1] + b[3]
    iw = max(0.0, min(ax1, bx1) - max(a[0], b[0]))
    ih = max(0.0, min(ay1, by1) - max(a[1], b[1]))
    inter = iw * ih
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


# -------------------------------------------------------------------- helpers
def test_to_grey_handles_eo_and_ir():
    bgr = np.zeros((4, 5, 3), np.uint8)
    bgr[..., 2] = 255
    assert to_grey_u8(bgr).shape == (4, 5)
    ir = np.linspace(1000, 5000, 20 * 30).reshape(20, 30).astype(np.uint16)
    g = to_grey_u8(ir)
    assert g.dtype == np.uint8 and g.min() == 0 and g.max() == 255
    with pytest.raises(ValueError, match="not an image"):
        to_grey_u8(np.zeros((4, 5, 2), np.uint8))
    with pytest.raises(ValueError, match="not an image"):
        to_grey_u8(np.zeros((0,), np.uint8))


def test_select_keypoints_spreads_over_the_grid():
    rng = np.random.default_rng(0)
    # 100 strong keypoints in the left cell, 10 weak ones in the right cell
    xy = np.r_[rng.uniform(0, 10, (100, 2)), rng.uniform([90, 0], [100, 10], (10, 2))]
    resp = np.r_[np.full(100, 100.0), np.full(10, 1.0)]
    keep = select_keypoints(xy, resp, (10, 100), max_keypoints=20, grid_cells=(2, 1))
    assert len(keep) == 20
    assert (keep >= 100).sum() == 10  # every weak keypoint of the other cell kept
    assert len(select_keypoints(xy, resp, (10, 100), 0)) == 110


def test_match_quality():
    q = match_quality(np.array([1.0, 4.0, 0.0]), np.array([4.0, 4.0, 0.0]))
    assert q.tolist() == pytest.approx([0.5, 0.0, 1.0])


def test_fit_zoom_pan_recovers_camera_motion_among_movers():
    rng = np.random.default_rng(1)
    src = rng.uniform(0, 320, (80, 2))
    h_true = np.array([[1.01, 0, -3.0], [0, 1.01, 0.5], [0, 0, 1]])
    dst = src * 1.01 + [-3.0, 0.5] + rng.normal(0, 0.1, src.shape)
    dst[:25] += [1.5, 0.0]  # a third of the points on a boat moving 1.5 px/frame
    h, inl = fit_zoom_pan(src, dst, threshold_px=0.5)
    corners = np.array([[0, 0, 1], [320, 0, 1], [0, 240, 1], [320, 240, 1]], float)
    assert np.abs(corners @ h.T - corners @ h_true.T).max() < 0.1  # px
    assert not inl[:25].any() and inl[25:].mean() > 0.9


def test_fit_similarity_recovers_roll():
    rng = np.random.default_rng(4)
    src = rng.uniform(0, 320, (60, 2))
    phi, s = np.deg2rad(0.3), 0.995
    h_true = np.array([[s * np.cos(phi), -s * np.sin(phi), 2.0], [s * np.sin(phi), s * np.cos(phi), -1.0], [0, 0, 1]])
    dst = src @ h_true[:2, :2].T + h_true[:2, 2] + rng.normal(0, 0.1, src.shape)
    dst[:10] = rng.uniform(0, 320, (10, 2))  # mismatches
    h, inl = fit_zoom_pan(src, dst, threshold_px=0.5, rotation=True)
    corners = np.array([[0, 0, 1], [320, 0, 1], [0, 240, 1], [320, 240, 1]], float)
    assert np.abs(corners @ h.T - corners @ h_true.T).max() < 0.1
    assert not inl[:10].any()
    # the model without roll cannot follow it
    h0, _ = fit_zoom_pan(src, dst, threshold_px=0.5, rotation=False)
    assert np.abs(corners @ h0.T - corners @ h_true.T).max() > 0.5


# ------------------------------------------------------------------ extractor
def test_confidence_counters_on_a_still_scene():
    rng = np.random.default_rng(2)
    img = (rng.random((120, 160)) > 0.97).astype(np.uint8) * 200
    img = cv2.GaussianBlur(img, (0, 0), 1.5) * 3
    ext = StableFeatureExtractor(stable_confidence=5, max_confidence=10)
    first = ext.process(img, 0.0)
    assert len(first) > 10 and (first.confidence == 1).all() and not first.stable.any()
    for k in range(1, 5):
        snap = ext.process(img, k / FPS)
    # born at 1, +1 per match: stable (5) on the fifth frame
    assert snap.stable.mean() > 0.9
    assert np.allclose(snap.homography, np.eye(3), atol=1e-3)
    # the features vanish: -1 per frame from at most 10, so all gone within 10 frames
    blank = np.full_like(img, 50)
    for k in range(5, 20):
        snap = ext.process(blank, k / FPS)
        if len(snap) == 0:
            break
    assert len(snap) == 0 and k <= 5 + 10


def test_extractor_rejects_bad_frames_with_the_frame_named():
    trk = StableFeatureTracker()
    with pytest.raises(ValueError, match="frame 7"):
        trk.process(Frame(np.zeros((3,), np.uint8), 0.28, 7))


# -------------------------------------------------------------------- tracker
def test_tracker_is_a_detector_tracker_and_builds_from_config():
    cfg = load_config(overrides=["tracker.sf_dmax=0.5", "tracker.sf_max_keypoints=150"])
    trk = StableFeatureTracker.from_settings(cfg.tracker)
    assert isinstance(trk, DetectorTracker) and trk.name == "stable_features"
    assert trk.clusterer.params.dmax == 0.5 and trk.extractor.max_keypoints == 150


def test_tracker_on_synthetic_pan_and_zoom():
    # the coast of this scene is made of flat grey rectangles whose keypoints slide by up to
    # about 4 px/s as the camera zooms: a speed floor of 5 px/s keeps them static
    trk = StableFeatureTracker(params=ClusterParams(min_speed_px_s=5.0))
    owner = {0: [], 1: []}  # track id that covers each boat, per frame
    false_frames = 0
    ious = []
    n_gt = 0
    for i, (t, img, boxes) in enumerate(synthetic_pan()):
        dets, tracks = trk.process(Frame(img, t, i))
        # the detections are the clusters seen; a coasting track (session 19) has none and comes last
        live = tracks.states != int(TrackState.COASTING)
        assert np.array_equal(dets.boxes, tracks.boxes[live]) and not live[len(dets):].any()
        for k, box in boxes.items():
            n_gt += 1
            if not len(tracks):
                continue
            ov = np.array([_iou(box, b) for b in tracks.boxes])
            j = int(np.argmax(ov))
            if ov[j] > 0.3:
                owner[k].append(int(tracks.ids[j]))
                ious.append(ov[j])
        touching = [any(_iou(b, g) > 0 for g in boxes.values()) for b in tracks.boxes]
        false_frames += int(not all(touching))
    # the camera motion itself never makes an object of the static coast
    assert false_frames <= 2
    # each boat is found (IoU > 0.3) in most frames; it takes about 0.5 s for the features to
    # become stable and linked, and a boat half out of the image is lost
    assert len(owner[0]) + len(owner[1]) >= 0.6 * n_gt
    # ... and keeps one identity through the pan and the zoom; the two identities differ
    assert len(set(owner[0])) == 1 and len(set(owner[1])) == 1
    assert owner[0][0] != owner[1][0]
    assert np.mean(ious) > 0.6


def test_descriptors_on_a_smaller_copy_keep_full_resolution_positions():
    rng = np.random.default_rng(5)
    img = (rng.random((240, 320)) > 0.985).astype(np.float32) * 255
    img = cv2.resize(cv2.GaussianBlur(img, (0, 0), 1.2) * 4, (640, 480)).clip(0, 255).astype(np.uint8)
    shift = np.float32([[1, 0, 1.5], [0, 1, -0.75]])  # the second frame moves by (1.5, -0.75) px
    snaps = {}
    for width in (0, 320):
        ext = StableFeatureExtractor(descriptor_width_px=width)
        for k in range(6):
            frame = cv2.warpAffine(img, shift * [[1, 1, k], [1, 1, k]], (640, 480))
            snap = ext.process(frame, k / FPS)
        snaps[width] = snap
        assert snap.stable.sum() > 20
        # sub-pixel positions follow the motion; the camera motion is measured in source pixels
        assert snap.homography[:2, 2] == pytest.approx([1.5, -0.75], abs=0.05)
    a, b = snaps[0].xy[snaps[0].stable], snaps[320].xy[snaps[320].stable]
    d = np.min(np.linalg.norm(a[:, None] - b[None], axis=2), axis=1)
    assert np.median(d) < 0.1


def test_guided_matching_with_one_candidate_takes_the_second_distance_from_anywhere():
    # three active features; the previous camera motion moves the image 5 px right
    rng = np.random.default_rng(7)
    # the paper's second neighbour (features 1 and 2 lie 4 px apart: the default
    # ratio_distinct_px would leave 2 out as the same structure)
    ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=8.0, ratio_distinct_px=0.0)
    base = rng.uniform(0, 40, (4, 128)).astype(np.float32)  # on the scale of SIFT's
    ext._xy = np.array([[20.0, 20.0], [100.0, 100.0], [104.0, 100.0], [200.0, 50.0]])
    ext._desc = base.copy()
    ext._h_prev = np.array([[1.0, 0, 5.0], [0, 1.0, 0], [0, 0, 1.0]])
    act = np.array([0, 1, 2, 3])
    q = np.stack([base[0] + 0.5, base[1] + 0.5, base[3], base[0]]).astype(np.float32)
    kxy = np.array([[26.0, 21.0],  # one candidate (feature 0 expected at 25, 20)
                    [107.0, 100.0],  # two candidates (features 1 and 2 expected at 105 and 109)
                    [300.0, 300.0],  # none within 8 px
                    [16.0, 20.0]])  # near feature 0's old position, 9 px from where it is expected
    nn, dist = ext._guided(q, act, kxy, 8.0)
    d2 = ((q[:, None, :] - base[None, :, :]) ** 2).sum(axis=2)
    # one candidate: nearest is it, second is the nearest OTHER active feature anywhere
    assert nn[0, 0] == 0 and nn[0, 1] == -1
    assert dist[0, 0] == pytest.approx(d2[0, 0], rel=1e-5)
    assert dist[0, 1] == pytest.approx(d2[0, 1:].min(), rel=1e-3)
    # two candidates: both from within the radius, in order of descriptor distance
    assert list(nn[1]) == [1, 2] and dist[1, 0] == pytest.approx(d2[1, 1], rel=1e-5)
    assert dist[1, 1] == pytest.approx(d2[1, 2], rel=1e-5)
    # none: no match
    assert list(nn[2]) == [-1, -1] and np.isinf(dist[2]).all()
    assert nn[3, 0] == -1  # guided by the camera motion, not the old positions
    # the single candidate passes the quality test only when no look-alike exists anywhere
    qi, si = ext._match(q[:1], act, kxy[:1], 8.0)
    assert list(qi) == [0] and list(si) == [0]
    ext._desc[3] = q[0] + 0.6  # a look-alike of feature 0 (quality 1 - 0.5 / 0.6 < 0.25), far outside the radius
    dist2 = ext._guided(q[:1], act, kxy[:1], 8.0)[1]
    assert dist2[0, 1] == pytest.approx(((q[0] - ext._desc[3]) ** 2).sum(), rel=1e-3)
    assert len(ext._match(q[:1], act, kxy[:1], 8.0)[0]) == 0


def test_guided_best_two_picks_the_two_nearest_candidates():
    from seawatch.detect.features import _best_two

    rng = np.random.default_rng(5)
    desc = rng.random((6, 128), dtype=np.float32)
    stored = rng.random((10, 128), dtype=np.float32)
    act = np.arange(10, dtype=np.int64)[::-1].copy()
    qi = np.repeat(np.arange(5), 4).astype(np.int64)  # query 5 has no candidate
    ai = np.concatenate([rng.choice(10, 4, replace=False) for _ in range(5)]).astype(np.int64)  # distinct pairs
    nn = np.full((6, 2), -1, np.int64)
    dist = np.full((6, 2), np.inf, np.float32)
    _best_two(desc, stored, act, qi, ai, nn, dist)
    for q in range(5):
        cand = np.unique(ai[qi == q])
        d2 = ((desc[q][None, :] - stored[act[cand]]) ** 2).sum(axis=1)
        order = np.argsort(d2)
        assert nn[q, 0] == cand[order[0]]
        np.testing.assert_allclose(dist[q, 0], d2[order[0]], rtol=1e-5)
        if len(cand) > 1:
            assert nn[q, 1] == cand[order[1]]
    assert nn[5, 0] == -1 and np.isinf(dist[5, 0])


def test_no_new_feature_on_top_of_an_active_one():
    """An unmatched keypoint within ``dedup_px`` of an active feature does not become a second
    feature of that point (two features of one point spoil each other's ratio test)."""
    rng = np.random.default_rng(5)
    img = np.full((H, W), 110, np.uint8)
    for _ in range(60):
        x, y, s = rng.integers(5, W - 15), rng.integers(5, H - 15), rng.integers(3, 8)
        img[y: y + s, x: x + s] = rng.integers(0, 60) if rng.random() < 0.5 else rng.integers(170, 255)
    flipped = (255 - img).astype(np.uint8)  # the same blobs, other descriptors: nothing matches
    counts = {}
    for dedup in (0.0, 2.0):
        # min_quality 1: only identical descriptors match (the repeated frame), so the flipped
        # frame matches nothing and the camera stays put
        ext = StableFeatureExtractor(nominal_fps=FPS, dedup_px=dedup, guided_px=0, min_quality=1.0)
        for k in range(3):  # confidence 3: the features outlive one unmatched frame
            first = ext.process(img, k / FPS)
        old = {int(i): xy for i, xy in zip(first.ids, first.xy)}
        second = ext.process(flipped, 3.0 / FPS)
        new = np.array([xy for i, xy in zip(second.ids, second.xy) if int(i) not in old]).reshape(-1, 2)
        gap = np.hypot(*(new[:, None, :] - np.array(list(old.values()))[None]).transpose(2, 0, 1)).min(axis=1)
        counts[dedup] = (len(new), int((gap <= 2.0).sum()))
    assert counts[0.0][1] > 10  # without it, most blobs get a second feature
    assert counts[2.0][1] == 0 and counts[2.0][0] < counts[0.0][0]
