"""The paper A cascade detector: detection on synthetic scenes, filters, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from seawatch.detect.cascade import CascadeDetector, default_model_path
from seawatch.detect.horizon import Horizon
from seawatch.train.recipe import match_counts
from seawatch.train.samples import LabelledImage
from seawatch.train.synthetic import boat_scene
from seawatch.train.trainer import TrainSettings, train_cascade
from seawatch.types import Detector, Frame, Modality


def _scene(seed, **kw):
    kw = {"clutter": 12, "coast": seed % 2 == 1, **kw}
    return boat_scene(seed, **kw)


def _synthetic_images():
    """The synthetic training problem: 14 labelled scenes with boats."""
    images = []
    for i in range(14):
        img, boxes, _ = _scene(100 + i)
        images.append(LabelledImage(f"syn{i}", "sim", boxes, image=img, group="syn", order=float(i)))
    return images


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    images = _synthetic_images()
    s = TrainSettings(
        n_stages=8, features_per_stage=600, feature_pos_step_px=3, feature_size_step_px=3,
        max_positives=500, n_aug={"sim": 8}, neg_per_pos=1.5, max_weak_count=30,
        max_scan_windows=3e6, wake_stage=True, time_budget_s=60, seed=3,
    )
    negatives = []
    for i in range(10):  # boat-free scenes full of clutter
        img, _, _ = _scene(300 + i, n_boats=0, clutter=30)
        negatives.append(LabelledImage(f"neg{i}", "sim", np.zeros((0, 4)), image=img, group="neg", order=float(i)))
    xml = tmp_path_factory.mktemp("det") / "boats.xml"
    train_cascade(images, xml, s, negative_images=negatives, log=lambda m: None)
    return xml


def _detector(model, **kw):
    kw = {"min_size_px": 36.0, "min_neighbors": 2, **kw}
    return CascadeDetector(model, **kw)


def test_is_a_detector_and_finds_synthetic_boats(model):
    det = _detector(model)
    assert isinstance(det, Detector) and det.name == "cascade"
    tp = fp = fn = 0
    for k in range(6):
        img, boxes, _ = _scene(600 + k)
        det.reset()
        d = det.detect(Frame(img, t_s=0.04 * k, index=k))
        assert d.source == "cascade" and d.frame_index == k and len(d.scores) == len(d.boxes)
        a, b, c = match_counts(d.boxes, boxes, 0.3)
        tp, fp, fn = tp + a, fp + b, fn + c
    assert tp >= 0.75 * (tp + fn)
    assert fp <= 0.35 * (tp + fp)


def test_grey_colour_and_ir_inputs_agree(model):
    img, boxes, _ = _scene(610)
    det = _detector(model)
    grey = det.detect(Frame(img, 0.0, 0)).boxes
    det.reset()
    colour = det.detect(Frame(np.dstack([img, img, img]), 0.0, 0)).boxes
    np.testing.assert_allclose(grey, colour)
    assert len(grey) >= 1
    # a 16-bit thermal frame of the same scene, normalised by the percentile stretch
    ir = (1000 + img.astype(np.uint16) * 16).astype(np.uint16)
    det.reset()
    d_ir = det.detect(Frame(ir, 0.0, 0, modality=Modality.IR))
    tp, _, _ = match_counts(d_ir.boxes, boxes, 0.3)
    assert tp >= 1


def test_bad_frames_are_counted_not_raised(model):
    det = _detector(model)
    d = det.detect(Frame(np.zeros((0, 0), np.uint8), 0.0, 3))
    assert len(d) == 0 and d.frame_index == 3
    d = det.detect(Frame(np.zeros((10, 10, 2), np.uint8), 0.0, 4))
    assert len(d) == 0
    assert det.n_bad_frames == 2
    small = det.detect(Frame(np.full((12, 20), 100, np.uint8), 0.0, 5))  # smaller than the window
    assert len(small) == 0 and det.n_bad_frames == 2


def test_missing_or_invalid_model(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.xml"):
        CascadeDetector(tmp_path / "nope.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<opencv_storage></opencv_storage>\n")
    with pytest.raises(ValueError, match="bad.xml"):
        CascadeDetector(bad)
    with pytest.raises(TypeError):
        CascadeDetector(default_model_path() if default_model_path().is_file() else bad, no_such_param=1)


def test_horizon_filter_removes_boats_on_the_coast(model):
    # a boat pasted above a water-coast line (on the quay) is dropped by the horizon filter only
    img, boxes, (yl, yr) = _scene(620, coast=True, horizon_px=120.0, n_boats=1, clutter=0)
    boat = img[int(boxes[0, 1]) - 4:int(boxes[0, 1] + boxes[0, 3]) + 4, int(boxes[0, 0]) - 4:int(boxes[0, 0] + boxes[0, 2]) + 4]
    img2 = img.copy()
    y0 = int(min(yl, yr)) - boat.shape[0] - 30
    x0 = 10 if boxes[0, 0] > 160 else 320 - boat.shape[1] - 10
    img2[y0:y0 + boat.shape[0], x0:x0 + boat.shape[1]] = boat
    on = _detector(model)
    off = _detector(model, horizon_filter=False)
    d_on = on.detect(Frame(img2, 0.0, 0))
    d_off = off.detect(Frame(img2, 0.0, 0))
    assert on.horizon is not None and on.horizon.kind == "coast"
    above = lambda d: int(((d.boxes[:, 1] + d.boxes[:, 3] / 2) < on.horizon.row_at(d.boxes[:, 0])).sum())
    assert above(d_off) >= 1
    assert above(d_on) == 0
    assert match_counts(d_on.boxes, boxes, 0.3)[0] == 1


def test_detection_scale_follows_smallest_boat(model):
    det = _detector(model, min_size_px=30.0)
    z = det.detection_scale(320)
    assert z == pytest.approx(60 * det.ratio_w / 30.0)
    assert _detector(model, min_size_px=0.0).detection_scale(1920) == pytest.approx(60 * det.ratio_w / 120.0)
    assert _detector(model, detection_width_px=640).detection_scale(320) == pytest.approx(2.0)


def test_shipped_model_loads():
    path = default_model_path()
    if not path.is_file():
        pytest.skip("no shipped model yet")
    det = CascadeDetector()
    # session 18: v6's 30x15 cascade on a 4x2 px grid at the settings of session 18's rule (1.2 / 2 / 0.5)
    assert det.window == (30, 15)
    p = det.params
    assert (p.scale_factor, p.min_neighbors, p.neighbors_size_exp, p.grid_step_px, p.grid_step_x_px) == (1.2, 2, 0.5, 2, 4)
    assert 0.3 < det.ratio_w <= 1.0 and 0.3 < det.ratio_h <= 1.2
    img, _, _ = _scene(630)
    d = det.detect(Frame(img, 0.0, 0))
    assert d.boxes.shape[1] == 4
    # the previous default, v6s15, is kept beside it with its own settings (2 px grid, 1.3 / 6 / 0)
    s15 = CascadeDetector(path.parent / "boat_cascade_v6s15.xml")
    assert (s15.params.scale_factor, s15.params.min_neighbors, s15.params.grid_step_x_px) == (1.3, 6, 0)
    # an older default, v2, is kept beside it with its own settings
    v2 = CascadeDetector(path.parent / "boat_cascade_v2.xml")
    assert v2.window == (60, 30)
    assert (v2.params.scale_factor, v2.params.min_neighbors, v2.params.grid_step_px) == (1.1, 48, 0)


def test_from_config(model):
    from seawatch.config import load_config

    cfg = load_config(overrides=[f"detector.cascade_model={model}", "detector.cascade_min_neighbors=7",
                                 "detector.horizon_filter=false", "detector.min_size_px=40"])
    det = CascadeDetector.from_config(cfg)
    assert det.model_path == model
    assert det.params.min_neighbors == 7 and det.params.horizon_filter is False
    assert det.min_boat_px(320) == pytest.approx(40.0)


@pytest.fixture(scope="module")
def small_model(tmp_path_factory):
    """The same synthetic problem with a 30x15 window (the shipped v5's size)."""
    images = _synthetic_images()
    s = TrainSettings(
        width_px=30, height_px=15, n_stages=8, features_per_stage=600, feature_pos_step_px=2,
        feature_size_step_px=2, max_positives=500, n_aug={"sim": 8}, neg_per_pos=1.5, max_weak_count=30,
        max_scan_windows=3e6, wake_stage=False, time_budget_s=60, seed=3,
    )
    negatives = []
    for i in range(10):
        img, _, _ = _scene(300 + i, n_boats=0, clutter=30)
        negatives.append(LabelledImage(f"neg{i}", "sim", np.zeros((0, 4)), image=img, group="neg", order=float(i)))
    xml = tmp_path_factory.mktemp("det30") / "boats30.xml"
    cascade, _ = train_cascade(images, xml, s, negative_images=negatives, log=lambda m: None)
    return cascade, xml


def test_small_window_scans_a_smaller_image_and_opencv_agrees(small_model, model):
    import cv2

    from seawatch.train.model import evaluate_windows
    from seawatch.train.samples import box_to_window, extract_windows

    cascade, xml = small_model
    det = _detector(xml)
    big = _detector(model)
    assert det.window == (30, 15)
    # the same smallest boat fills a window half as wide: the detection image is about half as wide
    assert det.detection_scale(320) == pytest.approx(30 * det.ratio_w / 36.0)
    assert det.detection_scale(320) / big.detection_scale(320) == pytest.approx(
        0.5 * det.ratio_w / big.ratio_w)
    tp = fp = fn = 0
    for k in range(6):
        img, boxes, _ = _scene(600 + k)
        det.reset()
        d = det.detect(Frame(img, t_s=0.04 * k, index=k))
        a, b, c = match_counts(d.boxes, boxes, 0.3)
        tp, fp, fn = tp + a, fp + b, fn + c
    assert tp >= 0.75 * (tp + fn)
    assert fp <= 0.35 * (tp + fp)
    # OpenCV accepts exactly the 30x15 windows the trainer's evaluator accepts
    clf = cv2.CascadeClassifier(str(xml))
    assert tuple(clf.getOriginalWindowSize()) == (30, 15)
    rng = np.random.default_rng(5)
    wins = []
    for k in range(3):
        img, boxes, _ = _scene(700 + k)
        wins.append(extract_windows(img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY),
                                    box_to_window(boxes), (30, 15), rng, n_aug=6))
        g = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        ys, xs = rng.integers(0, g.shape[0] - 15, 40), rng.integers(0, g.shape[1] - 30, 40)
        wins.append(np.stack([g[y:y + 15, x:x + 30] for y, x in zip(ys, xs)]))
    wins = np.concatenate(wins)
    mine = evaluate_windows(cascade, wins) == cascade.n_stages
    theirs = np.array([len(clf.detectMultiScale(w, scaleFactor=1.5, minNeighbors=0, minSize=(30, 15),
                                                maxSize=(30, 15))) > 0 for w in wins])
    assert mine.sum() > 10 and (~mine).sum() > 10
    np.testing.assert_array_equal(mine, theirs)
