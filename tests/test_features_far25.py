"""Session 25, helper H16 (issue #8): the far ships' keypoints and the water band's budget.

The diagnosis (docs/stable_features_log.md, "Session 25: far ships' features (helper H16)") found
that the band's keypoint budget is not what starves a far ship: the priority of the keypoints where an
active feature is expected keeps them even when the sea offers several times the budget.  These tests
pin that behaviour of ``select_keypoints`` (synthetic, seeded).
"""

import numpy as np

from seawatch.detect.features import select_keypoints


def _crowded_band(seed: int = 0):
    rng = np.random.default_rng(seed)
    # 400 strong sea keypoints over a 640x100 band, 2 weak ship keypoints in one crowded cell
    sea = np.column_stack([rng.uniform(0, 640, 400), rng.uniform(0, 100, 400)])
    sea_resp = rng.uniform(20.0, 60.0, 400)
    # crowd the ship's cell (x 320-360, y 0-50) with strong sea blobs
    crowd = np.column_stack([rng.uniform(320, 360, 30), rng.uniform(0, 50, 30)])
    ship = np.array([[330.0, 20.0], [350.0, 21.0]])
    xy = np.vstack([sea, crowd, ship])
    resp = np.r_[sea_resp, rng.uniform(40.0, 80.0, 30), [6.0, 7.0]]
    return xy, resp, len(xy) - 2


def test_crowded_cell_drops_weak_ship_keypoints_without_priority():
    xy, resp, i0 = _crowded_band()
    keep = select_keypoints(xy, resp, (100, 640), 150, (16, 2))
    assert len(keep) == 150
    assert not np.isin([i0, i0 + 1], keep).any()


def test_priority_keeps_the_expected_ship_keypoints_in_a_crowded_band():
    xy, resp, i0 = _crowded_band()
    pri = np.zeros(len(xy), bool)
    pri[[i0, i0 + 1]] = True
    keep = select_keypoints(xy, resp, (100, 640), 150, (16, 2), pri)
    assert len(keep) == 150
    assert np.isin([i0, i0 + 1], keep).all()
    # the rest of the budget is still shared out over the grid, not all taken by the crowded cell
    rest = keep[~np.isin(keep, [i0, i0 + 1])]
    cols = np.floor(xy[rest, 0] / 40.0).astype(int)
    assert len(np.unique(cols)) == 16


def test_budget_above_the_keypoints_keeps_all():
    xy, resp, i0 = _crowded_band(1)
    keep = select_keypoints(xy, resp, (100, 640), 1000, (16, 2))
    assert sorted(keep.tolist()) == list(range(len(xy)))
