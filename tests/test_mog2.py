"""MOG2 baseline detector on synthetic moving boxes with exact ground truth."""

import numpy as np
import pytest

from _pipeline_synth import moving_boxes
from seawatch.config import load_config
from seawatch.detect.mog2 import Mog2Detector, foreground_boxes
from seawatch.track.sort import iou_matrix
from seawatch.types import Detector, Frame

FPS = 10.0


def _run(det, frames, fps=FPS):
    return [det.detect(Frame(f, i / fps, i)) for i, f in enumerate(frames)]


def test_is_a_detector_named_mog2():
    det = Mog2Detector(FPS)
    assert isinstance(det, Detector)
    assert det.name == "mog2"


def test_history_is_seconds_converted_with_fps():
    assert Mog2Detector(10.0, history_s=20.0).history_frames == 200
    assert Mog2Detector(25.0, history_s=20.0).history_frames == 500
    assert Mog2Detector(1.0, history_s=3.0).history_frames == 3


def test_finds_moving_boxes_after_warmup():
    # object 1 appears from the left edge after the model has learnt the empty sea
    objects = [(1, -60.0, 60.0, 40, 16, 40.0, 0.0, 230), (2, 330.0, 160.0, 30, 14, -30.0, 0.0, 20)]
    frames, gt = moving_boxes(80, objects=objects, seed=1)
    dets = _run(Mog2Detector(FPS, warmup_s=1.0), frames)
    hits = total = 0
    for i in range(40, 80):
        g = np.array([r[1:] for r in gt[i]], float)
        total += len(g)
        if len(g) and len(dets[i]):
            iou = iou_matrix(g, dets[i].boxes)
            hits += int(np.sum(iou.max(axis=1) >= 0.5))
        assert len(dets[i]) <= len(g) + 1  # at most one spurious blob per frame
    assert hits / total >= 0.9
    assert all(d.source == "mog2" for d in dets)
    assert np.all(dets[50].scores > 0) and np.all(dets[50].scores <= 1)


def test_nothing_during_warmup_and_nothing_on_static_noise():
    objects = [(1, 0.0, 0.0, 1, 1, 0.0, 0.0, 110)]  # a 1-pixel "object" that never moves
    frames, _ = moving_boxes(40, objects=objects, seed=2, noise=4.0)
    dets = _run(Mog2Detector(FPS, warmup_s=2.0), frames)
    assert all(len(d) == 0 for d in dets[:20])  # warmup: 2 s at 10 fps
    assert sum(len(d) for d in dets[20:]) == 0  # sensor noise only: no blobs


def test_min_area_drops_small_blobs():
    objects = [(1, -60.0, 60.0, 40, 16, 40.0, 0.0, 230), (2, -10.0, 150.0, 4, 4, 40.0, 0.0, 240)]
    frames, gt = moving_boxes(50, objects=objects, seed=3)
    dets = _run(Mog2Detector(FPS, min_area_px=100.0), frames)
    for d in dets[30:]:
        assert np.all(d.boxes[:, 2] * d.boxes[:, 3] >= 100)
        assert len(d) <= 1


def test_work_width_returns_boxes_in_source_pixels():
    objects = [(1, -60.0, 60.0, 40, 16, 40.0, 0.0, 230)]
    frames, gt = moving_boxes(50, objects=objects, seed=4)
    det = Mog2Detector(FPS, work_width_px=160, close_px=3, open_px=1, min_area_px=30)
    dets = _run(det, frames)
    g = np.array([r[1:] for r in gt[45]], float)
    assert len(dets[45]) >= 1
    assert iou_matrix(g, dets[45].boxes).max() >= 0.6


def test_foreground_boxes_exact():
    mask = np.zeros((50, 60), np.uint8)
    mask[10:20, 5:25] = 255  # 20 x 10 blob
    mask[40:42, 50:52] = 255  # 4-pixel blob, dropped by min_area
    boxes, fill = foreground_boxes(mask, min_area_px=10, open_px=0, close_px=0)
    np.testing.assert_array_equal(boxes, [[5, 10, 20, 10]])
    np.testing.assert_allclose(fill, [1.0])


def test_from_config_uses_detector_section():
    cfg = load_config(None, ["detector.mog2_history_s=5", "detector.min_area_px=77"])
    det = Mog2Detector.from_config(cfg, fps=4.0)
    assert det.history_frames == 20 and det.min_area_px == 77


def test_rejects_bad_parameters():
    with pytest.raises(ValueError, match="fps"):
        Mog2Detector(0.0)
    with pytest.raises(ValueError, match="history_s"):
        Mog2Detector(10.0, history_s=0)


def test_from_config_work_width_and_warmup():
    cfg = load_config(None, ["detector.mog2_work_width_px=160", "detector.mog2_warmup_s=0.5",
                             "detector.mog2_background_ratio=0.8"])
    det = Mog2Detector.from_config(cfg, fps=10.0)
    assert det.work_width_px == 160 and det.warmup_s == 0.5 and det.background_ratio == 0.8
    frames, _ = moving_boxes(8, seed=6)
    dets = _run(det, frames)
    assert det._model.getBackgroundRatio() == pytest.approx(0.8)
    assert all(len(d) == 0 for d in dets[:5])  # 0.5 s at 10 fps
