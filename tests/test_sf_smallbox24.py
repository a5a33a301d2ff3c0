"""Session 24 (helper H8): small boats' boxes on ``pan``.

``ClusterParams.top_min_px`` / ``grow_boxes(..., top_min_px=)``: the top extension (``top_frac``) only
for an object found at least that many pixels tall; a one-pixel line at the waterline (a wake) is
not raised into the fainter texture above it.
"""
from __future__ import annotations

import numpy as np

from seawatch.track import feature_clusters as F
from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, grow_boxes


def _scene(obj_h: int, seed: int = 0):
    """A grey sea (seeded noise) with a bright object ``obj_h`` rows tall at rows 60.. and, right
    above it, a fainter patch 4 rows tall (above the top extension's threshold, below the grow's)."""
    rng = np.random.default_rng(seed)
    img = np.clip(100 + rng.normal(0, 1.0, (120, 160)), 0, 255)
    img[60:60 + obj_h, 60:75] += 60  # the object (a wake's line or a hull)
    img[56:60, 62:73] += 15  # fainter, touching its top: 15 > max(10, 0.2 * 60), < 0.3 * 60
    img = np.clip(img, 0, 255).astype(np.uint8)
    core = np.array([[61.0, 60.0, 12.0, max(obj_h - 1.0, 0.0)]])
    box = core + [-1, -1, 2, 2]
    return img, box, core


KW = dict(grow=1.0, peak_frac=0.3, top_frac=0.2, min_contrast=10.0)


def test_default_since_session_24():
    assert ClusterParams().top_min_px == 2.0  # the lead's decision U3 (0: off)


def test_a_line_is_raised_without_and_kept_with_top_min_px():
    img, box, core = _scene(1)
    off = grow_boxes(img, box, core, **KW)[0]
    on = grow_boxes(img, box, core, top_min_px=2.0, **KW)[0]
    # without the field the line goes up into the faint patch (4 rows): no longer a line
    assert off[1] == 56 and off[3] == 5
    # with it the line stays one pixel tall, at its own row and width
    assert on[1] == 60 and on[3] == 1
    assert on[0] == off[0] and on[2] == off[2] == 15


def test_a_taller_object_is_still_raised():
    for h in (2, 5):
        img, box, core = _scene(h, seed=h)
        off = grow_boxes(img, box, core, **KW)[0]
        on = grow_boxes(img, box, core, top_min_px=2.0, **KW)[0]
        assert np.array_equal(off, on)
        assert on[1] == 56 and on[3] == h + 4  # the patch above is the superstructure


def test_top_min_px_zero_equals_the_old_call_on_random_boxes():
    rng = np.random.default_rng(7)
    for it in range(20):
        img, box, core = _scene(int(rng.integers(1, 6)), seed=it)
        shift = rng.uniform(-3, 3, 2)
        box[0, :2] += shift
        core[0, :2] += shift
        a = grow_boxes(img, box, core, **KW)[0]
        b = grow_boxes(img, box, core, top_min_px=0.0, **KW)[0]
        assert np.array_equal(a, b)


def line_scene():
    """A grey sea; a bright line 1 px tall and 31 px wide at row 64 (a wake's foam at the waterline)
    with a fainter patch 4 rows tall right above it."""
    rng = np.random.default_rng(5)
    img = 120.0 + rng.normal(0.0, 2.0, (160, 240))
    img[64, 100:131] += 60.0
    img[60:64, 103:128] += 15.0
    return np.clip(img, 0, 255).astype(np.uint8)


def cluster_reports(**kw):
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, **kw))
    xy = [[104, 64], [115, 64], [126, 64]]  # features on the line
    _, tr = c.update(snap(xy, [[20, 0]] * 3, 0.0, 0), line_scene())
    return tr.boxes.tolist()


def test_the_clusterer_uses_its_field():
    off = cluster_reports(top_min_px=0.0)
    assert len(off) == 1 and off[0][3] >= 5  # the line raised into the patch: reported
    # with the field the line stays a line, which max_aspect (12) does not report
    assert cluster_reports(top_min_px=2.0) == [] == cluster_reports()  # on by default
    # and without max_aspect it is reported one pixel tall
    on = cluster_reports(top_min_px=2.0, max_aspect=0.0)
    assert len(on) == 1 and on[0][3] == 1


# ``ClusterParams.box_wake_below_px``: a small moving cluster's members lying below its front member
# (a wake's foam behind a small boat) leave its box.

HULL = [[120.0, 64.0], [126.0, 63.0]]


def wake_box(foam, vel, ir=False, **kw):
    """The report box (no image: the box members' extent, padded by 2 px) of one cluster made of the
    hull's two features and ``foam``, all moving at ``vel``."""
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, **kw))
    xy = HULL + [foam]
    _, tr = c.update(snap(xy, [vel] * 3, 0.0, 0), ir=ir)
    assert len(tr) == 1
    return [float(v) for v in tr.boxes[0]]


def test_wake_rule_on_by_default_since_session_24_and_off_with_zero():
    p = ClusterParams()
    assert p.box_wake_below_px == 5.0 and p.box_wake_below_px_ir == 0.0  # the lead's decision U3
    assert wake_box([104.0, 72.0], [20.0, 0.0], box_wake_below_px=0.0) == [102.0, 61.0, 26.0, 13.0]
    assert wake_box([104.0, 72.0], [20.0, 0.0]) == [118.0, 61.0, 10.0, 5.0]


def test_foam_below_and_behind_a_moving_boat_leaves_the_box():
    on = wake_box([104.0, 72.0], [20.0, 0.0], box_wake_below_px=5.0)
    assert on == [118.0, 61.0, 10.0, 5.0]  # the hull's two features alone
    # moving left: the front member is the leftmost; foam behind it (right) and below leaves too
    on = wake_box([142.0, 72.0], [-20.0, 0.0], box_wake_below_px=5.0)
    assert on == [118.0, 61.0, 10.0, 5.0]


def test_wake_rule_keeps_members_within_reach_and_still_clusters_and_tall_ones():
    # 4 px below the front one: not more than 5
    assert wake_box([104.0, 67.0], [20.0, 0.0], box_wake_below_px=5.0) == [102.0, 61.0, 26.0, 8.0]
    # a cluster not moving across the image (a still boat: no wake behind it)
    assert wake_box([104.0, 72.0], [2.0, 0.0], box_wake_below_px=5.0) == [102.0, 61.0, 26.0, 13.0]
    # members spanning more than box_wake_max_h_px (20) vertically: a large ship's hull below its bow
    assert wake_box([104.0, 88.0], [20.0, 0.0], box_wake_below_px=5.0) == [102.0, 61.0, 26.0, 29.0]
    assert wake_box([104.0, 88.0], [20.0, 0.0], box_wake_below_px=5.0, box_wake_max_h_px=0.0) == \
        [118.0, 61.0, 10.0, 5.0]


def test_wake_rule_on_infrared_frames_only_with_its_own_value():
    # default box_wake_below_px_ir 0: off on IR
    assert wake_box([104.0, 72.0], [20.0, 0.0], ir=True, box_wake_below_px=5.0) == [102.0, 61.0, 26.0, 13.0]
    # None: the EO value
    assert wake_box([104.0, 72.0], [20.0, 0.0], ir=True, box_wake_below_px=5.0, box_wake_below_px_ir=None) == \
        [118.0, 61.0, 10.0, 5.0]
