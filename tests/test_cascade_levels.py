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
