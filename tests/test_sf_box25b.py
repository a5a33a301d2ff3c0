"""Session 25 (H20, issue #8): the wake cut measured against the columns under the features
(``wake_core``): a small fast boat whose grown foreground is mostly its wake loses the wake."""

from __future__ import annotations

import numpy as np

from seawatch.track import feature_clusters as F
from seawatch.track.feature_clusters import ClusterParams, grow_boxes


def _rib_scene(seed: int = 0):
    """A dark sea, a small bright hull (12 x 8 px at x 150-161) and a long low bright wake
    (35 x 2 px at the waterline) trailing on its left."""
    rng = np.random.default_rng(seed)
    img = rng.normal(60.0, 2.0, (120, 260)).clip(0, 255)
    img[60:68, 150:162] = 200.0  # the hull (rows 60-67)
    img[66:68, 115:150] = 190.0  # the wake, 2 px tall at the waterline, 35 px long
    return img.astype(np.uint8)


def _grow(img, wake_core, trail=-1):
    core = np.array([[151.0, 61.0, 4.0, 5.0]])  # features on the hull only
    box = core + [-2, -2, 4, 4]
    return grow_boxes(img, box, core, grow=6.0, max_grow_px=60.0, wake_frac=0.3, trail=np.array([trail]),
                      wake_core=wake_core)[0]


def test_wake_core_cuts_a_wake_that_is_most_of_the_box():
    img = _rib_scene()
    off = _grow(img, 0.0)
    on = _grow(img, 0.3)
    # off: the wake's own height is the 75th percentile of the columns: nothing is cut
    assert off[0] <= 116 and off[0] + off[2] >= 161
    # on: the hull's height (under the features) is the reference: the wake is cut
    assert 145 <= on[0] <= 151 and on[0] + on[2] >= 161
    # no trailing side: no wake cut either way
    assert np.array_equal(_grow(img, 0.3, trail=0), _grow(img, 0.0, trail=0))
    # the wake on the other side than the trailing one: kept
    assert _grow(img, 0.3, trail=1)[0] <= 116


def test_wake_core_keeps_a_hull_without_wake():
    rng = np.random.default_rng(1)
    img = rng.normal(60.0, 2.0, (120, 260)).clip(0, 255)
    img[55:68, 120:170] = 200.0  # a long hull, features on its middle
    img[45:55, 140:150] = 200.0  # a cabin
    img = img.astype(np.uint8)
    core = np.array([[141.0, 47.0, 8.0, 18.0]])
    box = core + [-2, -2, 4, 4]
    for wc in (0.0, 0.3, 0.5):
        g = grow_boxes(img, box, core, grow=6.0, max_grow_px=60.0, wake_frac=0.3, trail=np.array([-1]),
                       wake_core=wc)[0]
        assert g[0] <= 121 and g[0] + g[2] >= 169


def test_tall_columns_reference_range():
    m = np.zeros((10, 20), bool)
    m[7:, :] = True  # a wake 3 rows tall everywhere
    m[:, 15:] = True  # a hull 10 rows tall on columns 15-19
    assert F._tall_columns(m, 0.5) == (0, 19)  # 75th percentile of all: the wake's 3
    assert F._tall_columns(m, 0.5, False, 15, 20) == (15, 19)  # the hull's 10
    assert F._tall_columns(m, 0.5, False, 40, 50) == (0, 19)  # none under the core: all count


def test_wake_core_on_by_default_since_session_28_on_visible_frames():
    p = ClusterParams()
    assert p.wake_core == 0.5 and p.wake_core_ir == 0.0
