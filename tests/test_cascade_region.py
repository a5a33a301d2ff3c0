"""The cascade detector's scan region and the trainer's detection-scale scan pool."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from seawatch.detect.cascade import CascadeDetector
from seawatch.detect.horizon import Horizon
from seawatch.train.model import Cascade, read_cascade_xml
from seawatch.train.samples import LabelledImage
from seawatch.train.synthetic import boat_scene
from seawatch.train.trainer import ScanPool, TrainSettings, mine_scan_negatives
from seawatch.types import Frame
from pathlib import Path

V5 = Path(__file__).resolve().parent.parent / "seawatch" / "models" / "boat_cascade_v5.xml"


def _frame(seed, coast, horizon_px=90.0, tilt_deg=0.0):
    img, boxes, line = boat_scene(seed, width_px=352, height_px=288, n_boats=3, boat_w_px=(30.0, 80.0),
                                  horizon_px=horizon_px, coast=coast, clutter=20, tilt_deg=tilt_deg)
    return img, boxes, line


@pytest.fixture(scope="module")
def det_pair():
    kw = {"min_neighbors": 2, "neighbors_size_exp": 0.0, "reflection_filter": True}
    return (CascadeDetector(V5, scan_region=True, **kw),
            CascadeDetector(V5, scan_region=False, water_roi=False, **kw))


def test_level_scans_equal_detectmultiscale(det_pair):
    region, _ = det_pair
    p = region.params
    n_total = 0
    for seed in range(4):
        img, _, _ = _frame(seed, coast=seed % 2 == 1)
        g = cv2.medianBlur(img, 3)
        for mn in (1, 2):
            region.params.min_neighbors = mn
            a, na = region.classifier.detectMultiScale2(g, scaleFactor=p.scale_factor, minNeighbors=mn,
                                                        minSize=region.window)
            b, nb = region.scan_region_windows(g, None)
            a = sorted(map(tuple, np.asarray(a).reshape(-1, 4).tolist()))
            bb = sorted(map(tuple, b.astype(int).tolist()))
            assert a == bb
            assert sorted(np.asarray(na).ravel().astype(int).tolist()) == sorted(nb.astype(int).tolist())
            n_total += len(a)
    region.params.min_neighbors = 2
    assert n_total > 0  # the comparison saw detections


@pytest.mark.parametrize("coast", [True, False])
def test_region_scan_keeps_every_detection_below_the_line(det_pair, coast):
    region, full = det_pair
    n_seen = n_line = 0
    skipped = []
    for seed in range(10, 40):
        if n_line == 6:
            break
        img, boxes, (yl, yr) = _frame(seed, coast=coast, horizon_px=100.0, tilt_deg=2.0 * (seed % 3 - 1))
        # a boat pasted high above the line: the full scan finds or filters it, the region never scans it
        b = boxes[0].astype(int)
        patch = img[b[1] - 3:b[1] + b[3] + 3, b[0] - 3:b[0] + b[2] + 3].copy()
        img[5:5 + patch.shape[0], 5:5 + patch.shape[1]] = patch
        region.reset()
        full.reset()
        d_r = region.detect(Frame(img, 0.0, 0))
        d_f = full.detect(Frame(img, 0.0, 0))
        rows = lambda d: sorted(zip(map(tuple, d.boxes.tolist()), d.scores.tolist()))
        assert rows(d_r) == rows(d_f)
        n_seen += len(d_f.boxes)
        if region.horizon is None:
            continue
        assert (region.horizon.kind == "coast") == coast
        n_line += 1
        z = region.detection_scale(img.shape[1])
        dw, dh = int(round(img.shape[1] * z)), int(round(img.shape[0] * z))
        skipped.append(region.region_rows(region.horizon, dh / img.shape[0], dw, dh)[0])
    assert n_seen > 0 and n_line == 6
    assert min(skipped) > 10  # the finest level skips rows above the line


def test_region_rows_follow_the_line_kind_and_window_height():
    det = CascadeDetector(V5)
    coast = Horizon(y_left=200.0, y_right=220.0, width=704, kind="coast")
    sky = Horizon(y_left=200.0, y_right=220.0, width=704, kind="sky")
    rc = det.region_rows(coast, 0.5, 352, 288)
    rs = det.region_rows(sky, 0.5, 352, 288)
    assert len(rc) == len(det._levels(352, 288)) > 5
    assert rc[0] < 100.0  # the highest point of the line, 100 detection rows, less a window's reach
    assert np.all(np.diff(rc) <= 0) and rc[5] < rc[0]  # taller windows start higher
    assert np.all(rs <= rc) and rs[0] < rc[0]  # a water-sky line keeps boxes whose bottom is below it
    # with no margin the region still holds every window the horizon filter keeps: under a
    # water-sky line a window whose bottom is on the line (its top one window height above),
    # under a water-coast line one whose centre is on it
    det.params.scan_region_margin_win = 0.0
    wins_h = np.array([lv[3][1] for lv in det._levels(352, 288)], np.float64)
    assert np.all(det.region_rows(sky, 0.5, 352, 288) <= np.maximum(0.0, 100.0 - wins_h))
    assert np.all(det.region_rows(coast, 0.5, 352, 288) <= np.maximum(0.0, 100.0 - 0.5 * wins_h))


def _pool_images():
    ims = []
    for i, src in enumerate(["mardct", "mardct", "coral", "sim"]):
        img, boxes, _ = boat_scene(40 + i, width_px=320, height_px=240, n_boats=2, clutter=25, coast=i % 2 == 0)
        ims.append(LabelledImage(f"p{i}", src, boxes, image=img))
    return ims


def test_scan_pool_counts_and_histogram():
    ims = _pool_images()
    pool = ScanPool(ims, (30, 15), roi_margin_frac=-1.0)
    # every level of the detector's pyramid, 2 px grid
    for i in range(len(ims)):
        n = sum(((h - 15) // 2 + 1) * ((w - 30) // 2 + 1) for _, (w, h) in pool.levels[i])
        assert pool.n_windows[i] == n
        assert pool.base[i].shape[1] == int(round(320 * 30 * 0.7 / 20.0))  # smallest boat: 1/16 of the width
    casc = read_cascade_xml(V5)
    hist = pool.stage_histogram(casc, avoid_boats=False)
    assert hist.sum() == pool.n_windows.sum()
    assert 0 < pool.last_flat < hist[0]
    # a one-stage cascade passes exactly the windows that pass v5's first stage
    one = Cascade(casc.width_px, casc.height_px, casc.features, casc.stages[:1])
    h1 = pool.stage_histogram(one, avoid_boats=False)
    assert h1[1] == hist[1:].sum()


def test_scan_mining_is_away_from_boats_and_shares_sources():
    ims = _pool_images()
    pool = ScanPool(ims, (30, 15), roi_margin_frac=-1.0)
    s = TrainSettings(width_px=30, height_px=15, mine_weights={"mardct": 0.5, "coral": 0.25, "sim": 0.25})
    empty = Cascade(30, 15, read_cascade_xml(V5).features, [])
    rng = np.random.default_rng(0)
    neg, src, stats = mine_scan_negatives(empty, pool, 400, s, rng, {})
    assert 0 < len(neg) < 400  # the first guess (every window accepted) over-estimates; flat ones are not
    expected = {k: v[1] / v[0] for k, v in stats.items()}
    neg, src, stats = mine_scan_negatives(empty, pool, 400, s, rng, expected)
    assert neg.shape == (400, 15, 30)
    assert abs((src == "mardct").sum() - 200) <= 1 and abs((src == "coral").sum() - 100) <= 1
    for k, (n_scan, n_acc) in stats.items():
        assert 0 < n_acc < n_scan  # flat windows are never accepted
    # windows on the boats are not counted: fewer accepted than the pool's evaluated windows
    casc = read_cascade_xml(V5)
    hist = pool.stage_histogram(empty, avoid_boats=True)
    assert sum(v[1] for v in stats.values()) == hist.sum() - pool.last_flat
    # the top-left window of level 0 maps back to the source image
    np.testing.assert_allclose(pool.to_source(0, 0, np.array([[0, 0, 0]])),
                               [[0.0, 0.0, 30 / pool.z[0], 15 / pool.z[0]]])
    assert casc.n_stages > 0


def test_two_px_grid_scans_a_subset_of_opencvs_windows():
    img, _, _ = _frame(3, coast=False)
    g = cv2.medianBlur(img, 3)
    raw = {}
    for grid in (0, 2):
        det = CascadeDetector(V5, grid_step_px=grid, min_neighbors=1)
        det.params.min_neighbors = 0  # raw (ungrouped) windows
        r, _ = det.scan_region_windows(g, None)
        raw[grid] = set(map(tuple, r.astype(int).tolist()))
    w0 = CascadeDetector(V5).window
    small = lambda s: {t for t in s if t[2] < 2 * w0[0]}
    assert raw[2] <= raw[0]
    assert small(raw[2]) == small(raw[0])  # below scale 2 both grids are 2 px
    assert len(raw[0] - raw[2]) > 0  # from scale 2 on OpenCV's 1 px grid finds more
    with pytest.raises(ValueError):
        CascadeDetector(V5, grid_step_px=1)
