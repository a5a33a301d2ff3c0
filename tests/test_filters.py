"""Image preparation and false-alarm filters of the paper A detector."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from seawatch.detect.filters import (
    canny_prune, edge_density, keypoint_density, normalize_ir, prepare_grey, reflection_filter,
    suppress_nested, to_grey,
)


def test_to_grey_accepts_grey_colour_and_rejects_bad_input():
    rng = np.random.default_rng(0)
    grey = rng.integers(0, 256, (20, 30)).astype(np.uint8)
    bgr = np.dstack([grey, grey, grey])
    np.testing.assert_array_equal(to_grey(bgr), grey)
    np.testing.assert_array_equal(to_grey(grey), grey)
    np.testing.assert_array_equal(to_grey(grey[:, :, None]), grey)
    bgra = np.dstack([grey, grey, grey, np.full_like(grey, 255)])
    np.testing.assert_array_equal(to_grey(bgra), grey)
    with pytest.raises(ValueError, match="empty"):
        to_grey(np.zeros((0, 5), np.uint8), "frame 7")
    with pytest.raises(ValueError, match="frame 7"):
        to_grey(np.zeros((4, 4, 2), np.uint8), "frame 7")
    with pytest.raises(ValueError):
        to_grey(None)


def test_normalize_ir_stretches_percentiles_to_full_range():
    rng = np.random.default_rng(1)
    ir = (3000 + rng.normal(0, 40, (64, 80))).astype(np.uint16)  # 16-bit thermal counts
    ir[20:30, 20:40] = 3400  # a warm hull
    out = normalize_ir(ir, 1.0, 99.0)
    assert out.dtype == np.uint8
    lo, hi = np.percentile(ir, [1, 99])
    # the percentiles map to 0 and 255, order is kept
    assert out[ir <= lo].max() <= 1 and out[ir >= hi].min() >= 254
    flat = ir.ravel().argsort()
    assert np.all(np.diff(out.ravel()[flat].astype(int)) >= 0)
    # an affine change of the input gives the same output (scale and shift invariance)
    np.testing.assert_array_equal(normalize_ir(ir.astype(np.float64) * 3 + 100), out)
    with pytest.raises(ValueError):
        normalize_ir(ir, 50, 10)
    # 16-bit input is normalised by prepare_grey even without ir=True
    assert prepare_grey(ir).dtype == np.uint8


def test_prepare_grey_median_removes_salt_noise():
    img = np.full((40, 40, 3), 100, np.uint8)
    img[10, 10] = 255
    g = prepare_grey(img)
    assert g[10, 10] == 100
    assert prepare_grey(img, median_px=0)[10, 10] > 200


def test_suppress_nested_keeps_outer_boxes():
    boxes = np.array([
        [10, 10, 50, 30],  # outer
        [20, 15, 20, 10],  # inside 0
        [100, 100, 20, 20],
        [100, 100, 20, 20],  # duplicate of 2
        [105, 90, 30, 40],  # overlaps 2, not nested
    ], float)
    keep = suppress_nested(boxes)
    assert keep.tolist() == [0, 2, 4]
    assert suppress_nested(np.zeros((0, 4))).tolist() == []


def test_canny_prune_drops_flat_windows():
    img = np.full((100, 200), 120, np.uint8)
    cv2.rectangle(img, (120, 40), (180, 60), 230, -1)  # a bright hull
    boxes = np.array([[10, 30, 60, 30], [115, 35, 70, 30]], float)
    keep = canny_prune(img, boxes, min_edge_frac=0.02)
    assert keep.tolist() == [False, True]
    d = edge_density(cv2.Canny(img, 30, 100), boxes)
    assert d[0] == 0 and d[1] > 0.02


def test_reflection_filter_rejects_smooth_glints_and_keeps_textured_boats():
    rng = np.random.default_rng(2)
    img = np.full((120, 240), 100, np.uint8)
    glint = cv2.GaussianBlur(np.zeros((120, 240), np.float32), (0, 0), 1)
    cv2.ellipse(glint, (60, 60), (30, 8), 0, 0, 360, 120, -1)
    img = np.clip(img + cv2.GaussianBlur(glint, (0, 0), 6), 0, 255).astype(np.uint8)  # smooth reflection
    boat = rng.integers(0, 2, (6, 12)) * 150 + 60
    img[40:70, 150:210] = cv2.resize(boat.astype(np.uint8), (60, 30), interpolation=cv2.INTER_NEAREST)
    img = cv2.GaussianBlur(img, (0, 0), 0.7)  # real edges are never one-pixel sharp
    boxes = np.array([[25, 45, 70, 30], [148, 38, 64, 34]], float)
    dens = keypoint_density(img, boxes)
    assert dens[0] < 0.05 < dens[1]
    assert reflection_filter(img, boxes).tolist() == [False, True]
    assert reflection_filter(img, np.zeros((0, 4))).shape == (0,)
