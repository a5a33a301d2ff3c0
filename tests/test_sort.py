"""SORT-style baseline tracker: association, confirmation, coasting and deletion in seconds."""

import numpy as np
import pytest

from seawatch.config import load_config
from seawatch.track.sort import SortTracker, iou_matrix
from seawatch.types import Detections, Tracker, TrackState


def _dets(t, i, boxes):
    return Detections(t, i, np.asarray(boxes, float).reshape(-1, 4), np.ones(len(boxes)), "test")


def _truth(t):
    """Two boats with constant velocities (px/s), never overlapping."""
    return np.array([[20 + 30 * t, 50 + 2 * t, 40, 16], [300 - 25 * t, 150, 30, 14]], float)


def test_iou_matrix_known_values():
    a = np.array([[0, 0, 10, 10], [100, 100, 5, 5]], float)
    b = np.array([[5, 0, 10, 10], [0, 0, 10, 10], [50, 50, 1, 1]], float)
    iou = iou_matrix(a, b)
    np.testing.assert_allclose(iou[0], [50 / 150, 1.0, 0.0])
    np.testing.assert_allclose(iou[1], [0, 0, 0])
    assert iou_matrix(np.zeros((0, 4)), b).shape == (0, 3)


def test_is_a_tracker_named_sort():
    trk = SortTracker()
    assert isinstance(trk, Tracker) and trk.name == "sort"


@pytest.mark.parametrize("fps", [5.0, 25.0])
def test_keeps_identities_of_noisy_constant_velocity_boats(fps):
    rng = np.random.default_rng(0)
    trk = SortTracker(confirm_hits=3, confirm_window_s=1.0, max_coast_s=2.0)
    ids_seen = {0: set(), 1: set()}
    for i in range(int(8 * fps)):
        t = i / fps
        truth = _truth(t)
        out = trk.update(_dets(t, i, truth + rng.normal(0, 1.0, truth.shape)))
        conf = out.subset(out.states == int(TrackState.CONFIRMED))
        if i >= 3:
            assert len(conf) == 2
            iou = iou_matrix(truth, conf.boxes)
            for k in range(2):
                j = int(np.argmax(iou[k]))
                assert iou[k, j] > 0.6
                ids_seen[k].add(int(conf.ids[j]))
    assert len(ids_seen[0]) == 1 and len(ids_seen[1]) == 1
    assert ids_seen[0] != ids_seen[1]
    # the estimated image velocity is the true one (px/s), whatever the frame rate
    v = out.velocities[np.argsort(out.boxes[:, 0])]
    np.testing.assert_allclose(v[1], [30, 2], atol=3)
    np.testing.assert_allclose(v[0], [-25, 0], atol=3)


def test_confirmation_needs_hits():
    trk = SortTracker(confirm_hits=3)
    box = [[100, 100, 20, 10]]
    states = [int(trk.update(_dets(0.1 * i, i, box)).states[0]) for i in range(4)]
    assert states == [TrackState.TENTATIVE, TrackState.TENTATIVE, TrackState.CONFIRMED, TrackState.CONFIRMED]


@pytest.mark.parametrize("fps", [2.0, 10.0, 30.0])
def test_coasting_and_deletion_are_in_seconds(fps):
    trk = SortTracker(confirm_hits=2, max_coast_s=1.5)
    box = np.array([[100.0, 100.0, 30.0, 12.0]])
    i = 0
    for _ in range(int(2 * fps)):  # 2 s of detections
        out = trk.update(_dets(i / fps, i, box))
        i += 1
    tid = int(out.ids[0])
    t_last = (i - 1) / fps
    alive_until = None
    while i / fps < t_last + 3.0:  # 3 s without detections
        out = trk.update(_dets(i / fps, i, np.zeros((0, 4))))
        if len(out):
            assert int(out.ids[0]) == tid
            assert int(out.states[0]) == TrackState.COASTING
            alive_until = i / fps
        i += 1
    assert alive_until is not None
    assert 1.5 - 1 / fps - 1e-9 <= alive_until - t_last <= 1.5 + 1e-9
    # a detection at the same place after the deletion starts a new identity
    out = trk.update(_dets(i / fps, i, box))
    assert int(out.ids[0]) != tid


def test_short_gap_keeps_identity():
    trk = SortTracker(confirm_hits=2, max_coast_s=2.0)
    fps = 10.0
    ids = set()
    for i in range(60):
        t = i / fps
        truth = _truth(t)[:1]
        boxes = np.zeros((0, 4)) if 20 <= i < 30 else truth  # a 1 s gap (occlusion)
        out = trk.update(_dets(t, i, boxes))
        ids.update(int(x) for x in out.ids[out.states == int(TrackState.CONFIRMED)])
    assert len(ids) == 1


def test_unconfirmed_clutter_is_deleted():
    trk = SortTracker(confirm_hits=3, confirm_window_s=0.5)
    out = trk.update(_dets(0.0, 0, [[10, 10, 5, 5]]))
    assert int(out.states[0]) == TrackState.TENTATIVE
    for i in range(1, 10):
        out = trk.update(_dets(0.1 * i, i, np.zeros((0, 4))))
    assert len(out) == 0


def test_low_frame_rate_can_still_confirm():
    # at 1 frame/s, 3 hits take 2 s: the 1 s confirmation window widens to the frame interval
    trk = SortTracker(confirm_hits=3, confirm_window_s=1.0)
    box = np.array([[100.0, 100.0, 30.0, 12.0]])
    states = [int(trk.update(_dets(float(i), i, box + [3 * i, 0, 0, 0])).states[0]) for i in range(4)]
    assert states[2] == TrackState.CONFIRMED


def test_track_leaving_the_image_is_dropped():
    from seawatch.types import Frame

    trk = SortTracker(confirm_hits=1, max_coast_s=10.0)
    img = np.zeros((100, 200, 3), np.uint8)
    fps = 10.0
    for i in range(10):
        t = i / fps
        trk.update(_dets(t, i, [[150 + 50 * t, 40, 20, 10]]), Frame(img, t, i))
    for i in range(10, 30):  # no detections; predicted box runs off the right edge
        out = trk.update(_dets(i / fps, i, np.zeros((0, 4))), Frame(img, i / fps, i))
    assert len(out) == 0


def test_time_going_backwards_resets():
    trk = SortTracker(confirm_hits=1)
    trk.update(_dets(5.0, 0, [[10, 10, 5, 5]]))
    out = trk.update(_dets(0.0, 0, [[80, 80, 5, 5]]))
    assert len(out) == 1 and out.boxes[0, 0] == pytest.approx(80)


def test_from_config_reads_tracker_section():
    cfg = load_config(None, ["tracker.confirm_hits=5", "tracker.max_coast_s=7.5", "tracker.iou_gate=0.2"])
    trk = SortTracker.from_config(cfg, fps=10.0)
    assert (trk.confirm_hits, trk.max_coast_s, trk.iou_gate) == (5, 7.5, 0.2)
