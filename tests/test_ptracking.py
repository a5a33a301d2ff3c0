"""PTracking local layer (paper A): tracking, group tracking through occlusions, re-identification."""

import numpy as np
import pytest

from seawatch.eval import clear_mot
from seawatch.track.group import (
    bhattacharyya_distance,
    hsv_histograms,
    match_by_colour,
    overlap_components,
    shrink_boxes,
)
from seawatch.track.ptracking import PTrackingTracker
from seawatch.types import Detections, Frame, PTZState, Tracker, TrackState

W, H = 704, 576
SEA = (120, 80, 30)  # BGR
_SEA_IMG = np.tile(np.array(SEA, np.uint8), (H, W, 1))


def _render(boats, t, texture=None, shift_px=0.0):
    """Draw boats (far ones first); return the image and the visible box of each boat.

    ``boats``: list of (id, colour BGR, f(t) -> (bottom-centre x, bottom y, w, h)).  A boat
    with a larger bottom y is nearer and hides the ones behind it.
    """
    if texture is None:
        img = _SEA_IMG.copy()
    else:
        x0 = int(round(shift_px)) % texture.shape[1]
        img = np.ascontiguousarray(np.roll(texture, -x0, axis=1)[:H, :W])
    lab = np.zeros((H, W), np.int32)
    geo = {bid: f(t) for bid, _, f in boats}
    for bid, col, _ in sorted(boats, key=lambda b: geo[b[0]][1]):
        cx, yb, w, h = geo[bid]
        x1, x2 = int(round(cx - w / 2)), int(round(cx + w / 2))
        y1, y2 = int(round(yb - h)), int(round(yb))
        x1c, x2c, y1c, y2c = max(x1, 0), min(x2, W), max(y1, 0), min(y2, H)
        if x2c > x1c and y2c > y1c:
            img[y1c:y2c, x1c:x2c] = col
            lab[y1c:y2c, x1c:x2c] = bid
    vis = {}
    for bid, _, _ in boats:
        cx, yb, w, h = geo[bid]
        x1, y1 = max(int(round(cx - w / 2)), 0), max(int(round(yb - h)), 0)
        ys, xs = np.nonzero(lab[y1:max(int(round(yb)), 0), x1:max(int(round(cx + w / 2)), 0)] == bid)
        xs, ys = xs + x1, ys + y1
        frac = len(xs) / (w * h)
        if len(xs):
            vis[bid] = (np.array([xs.min(), ys.min(), xs.max() + 1 - xs.min(), ys.max() + 1 - ys.min()], float), frac)
        else:
            vis[bid] = (np.array([cx - w / 2, yb - h, w, h]), 0.0)
    return img, vis


def _sequence(boats, fps, dur_s, *, seed=0, noise_px=1.5, dropout=0.05, min_visible=0.5, gaps=(),
              texture=None, shift=None, ptz=None):
    """(Frame, Detections, gt) per frame; gt = (ids, visible boxes) of boats at least partly seen."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(int(round(dur_s * fps))):
        t = i / fps
        img, vis = _render(boats, t, texture, 0.0 if shift is None else shift(t))
        gid, gbox, dets = [], [], []
        for bid in sorted(vis):
            box, frac = vis[bid]
            if frac > 0:
                gid.append(bid)
                gbox.append(box)
            hidden = any(a <= t < b and bid in who for a, b, who in gaps)
            if frac >= min_visible and not hidden and rng.random() >= dropout:
                dets.append(box + rng.normal(0.0, noise_px, 4))
        p = None if ptz is None else ptz(t)
        frame = Frame(img, t, i, ptz=p)
        det = Detections(t, i, np.array(dets).reshape(-1, 4), np.ones(len(dets)))
        out.append((frame, det, (np.array(gid, np.int64), np.array(gbox).reshape(-1, 4))))
    return out


def _run(tracker, seq, use_frame=True):
    gt, pred = {}, {}
    for frame, det, g in seq:
        tr = tracker.update(det, frame if use_frame else None)
        gt[frame.index] = g
        pred[frame.index] = (tr.ids, tr.boxes)
    return gt, pred


def _id_map(gt, pred, min_iou=0.3):
    """gt id -> list of the prediction ids that overlapped it, frame by frame (best IoU)."""
    from seawatch.eval import box_iou

    seen = {}
    for k in gt:
        gi, gb = gt[k]
        pi, pb = pred[k]
        if len(gi) == 0 or len(pi) == 0:
            continue
        iou = box_iou(gb, pb)
        for a in range(len(gi)):
            b = int(np.argmax(iou[a]))
            if iou[a, b] >= min_iou:
                seen.setdefault(int(gi[a]), []).append(int(pi[b]))
    return seen


def _line(x0, y, vx, w=80.0, h=30.0):
    return lambda t: (x0 + vx * t, y, w, h)


RED, GREEN = (30, 30, 220), (40, 200, 40)


def test_protocol_and_single_boat():
    tracker = PTrackingTracker(seed=0)
    assert isinstance(tracker, Tracker) and tracker.name == "ptracking"
    seq = _sequence([(1, RED, _line(100.0, 300.0, 40.0))], 25.0, 8.0, noise_px=2.0, dropout=0.1)
    gt, pred = _run(tracker, seq)
    ids = _id_map(gt, pred)
    assert list(ids) == [1] and set(ids[1]) == {1}
    c = clear_mot(gt, pred)
    assert c["MOTA"] > 0.97 and c["IDSW"] == 0 and c["MOTP"] > 0.85
    last = tracker.update(Detections.empty(8.0, 200))
    assert last.states[0] == TrackState.COASTING
    np.testing.assert_allclose(last.velocities[0], [40.0, 0.0], atol=2.0)


@pytest.mark.parametrize("use_frame", [True, False])
def test_crossing_with_full_occlusion_keeps_identities(use_frame):
    # A passes in front of B; B is fully hidden for about a second
    boats = [(1, RED, _line(100.0, 320.0, 45.0)), (2, GREEN, _line(600.0, 312.0, -45.0))]
    seq = _sequence(boats, 25.0, 12.0, seed=1)
    hidden = sum(1 for _, det, g in seq if len(g[0]) == 2 and len(det) < 2)
    assert hidden > 20  # the occlusion is real
    tracker = PTrackingTracker(seed=0)
    gt, pred = _run(tracker, seq, use_frame)
    c = clear_mot(gt, pred)
    assert c["IDSW"] == 0 and c["MOTA"] >= 0.95
    ids = _id_map(gt, pred, 0.5)
    assert len(set(ids[1])) == 1 and len(set(ids[2])) == 1 and set(ids[1]) != set(ids[2])


def _reversal():
    """A and B meet, and while B hides behind A both turn back the way they came."""

    def a(t):
        x = 150.0 + 45.0 * min(t, 4.9) - 45.0 * max(t - 4.9, 0.0)
        return (x, 320.0, 80.0, 30.0)

    def b(t):
        x = 550.0 - 45.0 * min(t, 4.9) + 45.0 * max(t - 4.9, 0.0)
        return (x, 312.0, 80.0, 30.0)

    return [(1, RED, a), (2, GREEN, b)]


def test_group_members_get_their_identity_back_by_colour():
    seq = _sequence(_reversal(), 25.0, 10.0, seed=2, dropout=0.0)
    tracker = PTrackingTracker(seed=0)
    formed = []
    gt, pred = {}, {}
    for frame, det, g in seq:
        tr = tracker.update(det, frame)
        formed.append(len(tracker.groups))
        gt[frame.index], pred[frame.index] = g, (tr.ids, tr.boxes)
    assert max(formed) == 1  # the two tracks were grouped during the occlusion
    ids = _id_map(gt, pred, 0.5)
    before = {g: ids[g][0] for g in ids}
    after = {g: ids[g][-1] for g in ids}
    assert before == after and before[1] != before[2]
    # without the image there is no colour model: the members coast across and are swapped
    gt2, pred2 = _run(PTrackingTracker(seed=0), seq, use_frame=False)
    ids2 = _id_map(gt2, pred2, 0.5)
    assert ids2[1][-1] == ids2[2][0] and ids2[2][-1] == ids2[1][0]


def test_lost_track_reidentified_by_direction_speed_and_colour():
    # the detector misses the boat for 3 s (longer than max_coast_s = 2 s): the track is
    # deleted, and the boat reappearing on its course gets its old identity back
    boats = [(1, RED, _line(80.0, 300.0, 40.0))]
    seq = _sequence(boats, 10.0, 12.0, seed=3, gaps=[(4.0, 7.0, (1,))], dropout=0.0)
    tracker = PTrackingTracker(seed=0, max_coast_s=2.0)
    n_live = []
    gt, pred = {}, {}
    for frame, det, g in seq:
        tr = tracker.update(det, frame)
        n_live.append(len(tr))
        gt[frame.index], pred[frame.index] = g, (tr.ids, tr.boxes)
    assert 0 in n_live[45:70]  # it was really deleted
    ids = _id_map(gt, pred, 0.5)
    assert set(ids[1]) == {1}
    # a boat of another colour appearing there instead is someone else
    other = [(1, RED, lambda t: (80.0 + 40.0 * t, 300.0, 80.0, 30.0) if t < 4.0 else (-500.0, 300.0, 80.0, 30.0)),
             (2, GREEN, lambda t: (80.0 + 40.0 * t, 300.0, 80.0, 30.0) if t >= 7.0 else (-500.0, 300.0, 80.0, 30.0))]
    seq2 = _sequence(other, 10.0, 12.0, seed=3, dropout=0.0)
    gt2, pred2 = _run(PTrackingTracker(seed=0), seq2)
    ids2 = _id_map(gt2, pred2, 0.5)
    assert set(ids2[1]) == {1} and set(ids2[2]) == {2}
    # without colour, the motion tests alone decide: the green boat continues the red one's course
    gt3, pred3 = _run(PTrackingTracker(seed=0), seq2, use_frame=False)
    ids3 = _id_map(gt3, pred3, 0.5)
    assert set(ids3[1]) == {1} and set(ids3[2]) == {1}
    # ... but not one coming back in the opposite direction
    back = [(1, RED, lambda t: (80.0 + 40.0 * t, 300.0, 80.0, 30.0) if t < 4.0 else (-500.0, 300.0, 80.0, 30.0)),
            (2, GREEN, lambda t: (360.0 - 40.0 * (t - 7.0), 300.0, 80.0, 30.0) if t >= 7.0 else (-500.0, 300.0, 80.0, 30.0))]
    gt4, pred4 = _run(PTrackingTracker(seed=0), _sequence(back, 10.0, 12.0, seed=3, dropout=0.0), use_frame=False)
    ids4 = _id_map(gt4, pred4, 0.5)
    assert set(ids4[2]) == {2}


@pytest.mark.parametrize("fps", [10.0, 30.0])
def test_time_parameters_are_seconds(fps):
    # seen from t = 0 to 3 s; confirmed at the third sighting, deleted 2 s after the last one
    boats = [(1, RED, _line(100.0, 300.0, 30.0))]
    seq = _sequence(boats, fps, 6.0, gaps=[(3.0, 99.0, (1,))], dropout=0.0, noise_px=0.5)
    tracker = PTrackingTracker(seed=0, confirm_hits=3, confirm_window_s=1.0, max_coast_s=2.0)
    first, last = None, None
    for frame, det, _ in seq:
        tr = tracker.update(det)  # no frame: the image bounds do not end the track
        if len(tr):
            first = frame.t_s if first is None else first
            last = frame.t_s
    assert first == pytest.approx(2 / fps)
    assert last == pytest.approx(3.0 - 1 / fps + 2.0, abs=1 / fps + 1e-9)


def test_deterministic_for_a_seed():
    boats = [(1, RED, _line(100.0, 320.0, 45.0)), (2, GREEN, _line(600.0, 312.0, -45.0))]
    seq = _sequence(boats, 25.0, 6.0, seed=4)
    _, p1 = _run(PTrackingTracker(seed=7), seq)
    _, p2 = _run(PTrackingTracker(seed=7), seq)
    _, p3 = _run(PTrackingTracker(seed=8), seq)
    assert all(np.array_equal(p1[k][0], p2[k][0]) and np.array_equal(p1[k][1], p2[k][1]) for k in p1)
    assert all(np.array_equal(p1[k][0], p3[k][0]) for k in p1)  # same identities ...
    assert any(not np.array_equal(p1[k][1], p3[k][1]) for k in p1)  # ... from other particles


def test_bad_detections_are_rejected_and_counted():
    tracker = PTrackingTracker(seed=0)
    for i in range(5):
        boxes = np.array([[100.0 + i, 200.0, 50.0, 20.0], [np.nan, 1.0, 2.0, 3.0], [10.0, 10.0, 0.0, 5.0]])
        tr = tracker.update(Detections(i * 0.1, i, boxes, np.ones(3)))
    assert tracker.n_rejected == 10 and len(tr) == 1


@pytest.mark.parametrize("mode", ["flow", "ptz"])
def test_ego_motion_keeps_a_still_boat_through_a_pan(mode):
    # the boat is still on the sea; while the detector misses it (2 s to 3.5 s) the camera pans
    # and the boat slides 90 px across the image
    from seawatch.camera import CameraModel, Intrinsics
    from seawatch.types import CameraPose

    cam = CameraModel(Intrinsics.from_fov(60.0, W, H), CameraPose(height_m=20.0, tilt_deg=-5.0))
    shift = lambda t: 60.0 * min(max(t - 2.0, 0.0), 1.5)  # noqa: E731  image motion, px
    if mode == "flow":
        rng = np.random.default_rng(5)
        tex = rng.integers(0, 255, (H // 8 + 1, 2 * W // 8 + 1, 3), dtype=np.uint8)
        tex = np.ascontiguousarray(np.repeat(np.repeat(tex, 8, 0), 8, 1)[:H, : 2 * W])
        boats = [(1, RED, lambda t: (500.0 - shift(t), 330.0, 80.0, 30.0))]
        seq = _sequence(boats, 10.0, 5.0, texture=tex, shift=shift, gaps=[(2.0, 3.5, (1,))], dropout=0.0)
    else:
        ptz = lambda t: PTZState(t, float(np.degrees(np.arctan(shift(t) / cam.intrinsics.fx))), -5.0, 1.0)  # noqa: E731
        az, el = cam.with_ptz(ptz(0.0)).pixel_to_azel(500.0, 330.0)

        def boat(t):
            u, v, _ = cam.with_ptz(ptz(t)).azel_to_pixel(az, el)
            return (float(u), float(v), 80.0, 30.0)

        seq = _sequence([(1, RED, boat)], 10.0, 5.0, gaps=[(2.0, 3.5, (1,))], dropout=0.0, ptz=ptz)
        assert seq[-1][1].boxes[0, 0] + 40 < 500.0 - 80.0  # it really moved

    def ids_of(tracker):
        gt, pred = _run(tracker, seq)
        return _id_map(gt, pred, 0.5)[1]

    with_comp = ids_of(PTrackingTracker(seed=0, ego_motion=mode, camera=cam))
    without = ids_of(PTrackingTracker(seed=0))
    assert len(set(with_comp)) == 1
    assert len(set(without)) == 2  # the coasted track stayed put in the image and was lost


def test_group_helpers():
    boxes = np.array([[0.0, 0.0, 100.0, 20.0], [85.0, 0.0, 100.0, 20.0], [300.0, 0.0, 10.0, 10.0]])
    np.testing.assert_allclose(shrink_boxes(boxes[:1], 0.8), [[10.0, 2.0, 80.0, 16.0]])
    assert list(overlap_components(boxes, 1.0)) == [0, 0, 1]
    assert list(overlap_components(boxes, 0.8)) == [0, 1, 2]  # 15 px overlap vanishes when shrunk
    img = np.zeros((40, 400, 3), np.uint8)
    img[:, :100] = RED
    img[:, 100:200] = GREEN
    img[:, 200:300] = (35, 35, 230)  # another red
    h = hsv_histograms(img, np.array([[0, 0, 100, 40], [100, 0, 100, 40], [200, 0, 100, 40]], float))
    assert bhattacharyya_distance(h[0], h[0]) == pytest.approx(0.0, abs=1e-6)
    assert bhattacharyya_distance(h[0], h[1]) > 0.9
    assert bhattacharyya_distance(h[0], h[2]) < 0.35
    pairs = match_by_colour(h[[0, 1]], h[[1, 2]])
    assert sorted((i, j) for i, j, _ in pairs) == [(0, 1), (1, 0)]
    assert match_by_colour(h[[0]], h[[1]]) == []  # red and green do not match
    grey = hsv_histograms(img[:, :, 0], np.array([[0, 0, 100, 40]], float))
    assert grey[0, :62].sum() == 0 and grey[0, 62:].sum() == pytest.approx(1.0)


def test_built_from_the_configuration():
    from seawatch.config import load_config

    cfg = load_config(overrides=["tracker.kind=ptracking", "tracker.delta_px=30.0", "tracker.num_particles=300",
                                 "tracker.max_coast_s=3.5", "tracker.ego_motion=flow"])
    tr = PTrackingTracker.from_config(cfg)
    assert (tr.delta_px, tr.num_particles, tr.max_coast_s, tr.ego_motion) == (30.0, 300, 3.5, "flow")
    with pytest.raises(ValueError, match="ego_motion"):
        PTrackingTracker(ego_motion="gyro")
    with pytest.raises(ValueError, match="camera"):
        PTrackingTracker(ego_motion="ptz")
