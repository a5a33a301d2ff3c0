"""The cascade detector's per-level scan plan and its row-limited level scans (session 15's
speed work must change no window)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from seawatch.detect.cascade import CascadeDetector
from seawatch.train.synthetic import boat_scene


def _frame(seed, coast, horizon_px=90.0):
    img, boxes, line = boat_scene(seed, width_px=352, height_px=288, n_boats=3, boat_w_px=(30.0, 80.0),
                                  horizon_px=horizon_px, coast=coast, clutter=20)
    return img, boxes, line


V6 = Path(__file__).resolve().parent.parent / "seawatch" / "models" / "boat_cascade_v6.xml"


@pytest.mark.parametrize("sf", [1.1, 1.3])
def test_region_rows_scan_exactly_the_full_scans_windows_below_them(sf):
    """Raw windows (2 px grid) of a scan from first rows per level are exactly the full scan's
    windows at or below those rows, level by level (the extra never-scanned row a level call may
    need is the level's next row or a copy of its last one: it must change no window)."""
    det = CascadeDetector(V6, scale_factor=sf, grid_step_px=2)
    det.params.min_neighbors = 0  # raw windows (0 at construction means the model's value)
    rng = np.random.default_rng(5)
    n_checked = n_cut = 0
    for seed in range(3):
        img, _, _ = _frame(seed, coast=seed == 1)
        g = cv2.medianBlur(img, 3)
        full, _ = det.scan_region_windows(g, None)
        plan = det._level_plan(g.shape[1], g.shape[0])
        for _ in range(4):
            rows = rng.uniform(0.0, 0.8 * g.shape[0], len(plan))
            part, _ = det.scan_region_windows(g, rows)
            for k, (f, f32, sz, win, step, y_end) in enumerate(plan):
                y_lo = int(np.ceil(rows[k] / float(f32)))
                y_lo += (-y_lo) % step
                lim = int(np.rint(np.float32(y_lo) * f32))
                at = (full[:, 2] == win[0]) & (full[:, 3] == win[1])
                want = sorted(map(tuple, full[at & (full[:, 1] >= lim)].astype(int).tolist()))
                got = sorted(map(tuple, part[(part[:, 2] == win[0]) & (part[:, 3] == win[1])].astype(int).tolist()))
                assert got == want, (seed, k)
                n_checked += len(want)
                n_cut += int((at & (full[:, 1] < lim)).sum())
    assert n_checked > 100 and n_cut > 100  # windows were kept and cut


def test_level_plan_follows_the_scale_factor_and_grid():
    det = CascadeDetector(V6, grid_step_px=2, scale_factor=1.1)
    n11 = len(det._level_plan(320, 240))
    det.params.scale_factor = 1.3
    n13 = len(det._level_plan(320, 240))
    assert n13 < n11
    assert all(lv[4] == 2 for lv in det._level_plan(320, 240))
    det.params.grid_step_px = 0
    assert any(lv[4] == 1 for lv in det._level_plan(320, 240))  # OpenCV's 1 px grid from scale 2 on
    assert det._levels(320, 240) == [lv[:4] for lv in det._level_plan(320, 240)]


@pytest.mark.parametrize("size,sf", [((120, 90), 1.1), ((120, 90), 1.3), ((176, 144), 1.3), ((150, 101), 1.1)])
def test_stripe_limit_matches_opencvs_scanned_windows(tmp_path, size, sf):
    """OpenCV cuts each level's rows into stripes sized from the first level's width; with a 2 px
    step the level's last row can fall outside every stripe and is never scanned.  A cascade that
    accepts every window shows the scanned grid itself: the per-level scans (the plan's first row
    not scanned, ``y_end``) must give exactly ``detectMultiScale2``'s raw windows.  At these sizes
    and scale factors one level has ``y_end`` below its last grid row (checked below), so scanning
    to the level's end instead adds windows.

    Two differences from OpenCV, outside the stripe rule, are applied to seawatch's windows here
    (they show only on windows at the image's right or bottom edge and on levels whose window is
    larger than the image, which the real cascades rarely accept): OpenCV clips each window to the
    image (``rect & Rect(0, 0, w, h)``) and stops at a level whose window exceeds the image
    (``maxSize`` defaults to the image size)."""
    from seawatch.train.haar import generate_features
    from seawatch.train.model import Cascade, Stage, write_cascade_xml

    feats = generate_features(30, 15, kinds=("x2",), pos_step_px=4, size_step_px=4)
    accept = Cascade(30, 15, feats, [Stage(-1e9, [0], [0.0], [0.0], [0.0])])
    xml = write_cascade_xml(accept, tmp_path / "accept.xml")
    det = CascadeDetector(xml, scale_factor=sf, grid_step_px=0, neighbors_size_exp=0.0)
    det.params.min_neighbors = 0  # raw windows, no grouping
    w_img, h_img = size
    img = np.random.default_rng(7).integers(0, 256, (h_img, w_img), dtype=np.uint8)  # no flat window
    plan = det._level_plan(w_img, h_img)
    cut = [lv for lv in plan if lv[5] < lv[2][1] + 1 - 15]
    assert cut  # the case the rule is about is present
    ref, _ = det.classifier.detectMultiScale2(img, scaleFactor=sf, minNeighbors=0, minSize=(30, 15))
    ref = sorted(map(tuple, np.asarray(ref).reshape(-1, 4).tolist()))
    got, _ = det.scan_region_windows(img, None)
    got = got.astype(int)
    got = got[(got[:, 2] <= w_img) & (got[:, 3] <= h_img)]
    x2, y2 = np.minimum(got[:, 0] + got[:, 2], w_img), np.minimum(got[:, 1] + got[:, 3], h_img)
    got = sorted(map(tuple, np.stack([got[:, 0], got[:, 1], x2 - got[:, 0], y2 - got[:, 1]], 1).tolist()))
    assert len(ref) > 1000 and got == ref
    # the windows of a cut level stop above its y_end: its last grid row has none
    f32, win, y_end = cut[0][1], cut[0][3], cut[0][5]
    rows = {int(np.rint(np.float32(y) / f32)) for (x, y, w, h) in ref if w == win[0] and x + w < w_img}
    assert rows and max(rows) < y_end <= max(rows) + 2
