"""Session 23 (helper H6): the core of the box growing on infrared frames (``ClusterParams.grow_core_q_ir``)."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _core_quantiles


def halo_scene():
    """A warm (white-hot) hull at rows 60-72, columns 100-150, in a dark sea with a faint halo around it."""
    rng = np.random.default_rng(7)
    img = 40.0 + rng.normal(0.0, 2.0, (160, 240))
    yy, xx = np.mgrid[0:160, 0:240]
    dx = np.maximum(np.maximum(100 - xx, xx - 149), 0)
    dy = np.maximum(np.maximum(60 - yy, yy - 71), 0)
    d = np.hypot(dx, dy)
    img += 12.0 * np.exp(-0.5 * (d / 6.0) ** 2) * (d > 0)  # the halo: below the growing's threshold
    img[60:72, 100:150] = 200.0
    return np.clip(img, 0, 255).astype(np.uint8)


# eight features on the hull, two at the halo's rim left and right of it (moving with the boat)
HULL = [[104, 63], [110, 68], [118, 64], [125, 69], [131, 62], [138, 67], [143, 64], [147, 70]]
RIM = [[70, 66], [180, 66]]


def report(params, ir, xy=HULL + RIM):
    c = FeatureClusterer(params)
    _, tr = c.update(snap(xy, [[20, 0]] * len(xy), 0.0, 0), halo_scene(), ir=ir)
    assert len(tr) == 1
    return tr.boxes[0].tolist()


# the steps off (grow_core_q_ir 0.4 with grow_core_retry_ir is on by default since session 23); each
# test names what it turns on
BASE = dict(confirm_s=0.0, grow_core_q_ir=0.0, grow_core_retry_ir=False)


def P(**kw):
    d = dict(BASE)
    d.update(kw)
    return ClusterParams(**d)


def test_defaults():
    d = ClusterParams()
    assert (d.grow_core_q_ir, d.grow_core_retry_ir, d.grow_core_box_ir, d.top_halo_ir) == (0.4, True, False, 0.0)


def test_rim_features_make_the_box_the_features_extent_without_the_step():
    b = report(P(), ir=True)
    # the grown hull covers too little of the core (70..180): the padded features' extent is reported
    assert b[0] < 70 and b[0] + b[2] > 180


def test_inner_quantile_core_grows_to_the_hull_on_ir():
    p = P(grow_core_q_ir=0.2)
    assert report(p, ir=True) == pytest.approx([100, 60, 50, 12])


def test_eo_frames_are_untouched():
    p = P(grow_core_q_ir=0.2)
    assert report(p, ir=False) == report(P(), ir=False)


def test_without_rim_features_the_step_changes_nothing():
    p = P(grow_core_q_ir=0.2)
    assert report(p, ir=True, xy=HULL) == report(P(), ir=True, xy=HULL) == \
        pytest.approx([100, 60, 50, 12])


def test_core_quantiles_nearest_rank_inward():
    rng = np.random.default_rng(3)
    k = np.array([0] * 11 + [2] * 3)
    v = np.concatenate([rng.permutation(np.arange(11.0)), [5.0, 1.0, 9.0]])
    lo, hi = _core_quantiles(k, v, 3, 0.1, np.full(3, -7.0), np.full(3, 7.0))
    assert lo.tolist() == [1.0, -7.0, 1.0]  # cluster 0: the 1st and 9th of 0..10; cluster 1: none
    assert hi.tolist() == [9.0, 7.0, 9.0]   # cluster 2: three members, the full extent


def test_core_box_shrinks_the_box_before_the_growing_on_ir_only():
    # grow_box 0: the box before the growing is reported as it is
    base = dict(BASE, grow_box=0.0, grow_core_q_ir=0.2)
    assert report(ClusterParams(**base), ir=True) == pytest.approx([68, 60, 114, 12])  # full extent, padded by 2
    on = ClusterParams(**base, grow_core_box_ir=True)
    # x: the 2nd and 9th of the ten sorted (104, 147); y: 63 and 69; padded by 2
    assert report(on, ir=True) == pytest.approx([102, 61, 47, 10])
    assert report(on, ir=False) == pytest.approx([68, 60, 114, 12])


def tower_scene(halo):
    """A warm hull (rows 60-72, columns 100-150) with, above it, a warm tower (rows 44-60, columns 118-128)
    when ``halo`` is False, or a thermal halo (as bright as the tower, fading upward and sideways) when True."""
    rng = np.random.default_rng(11)
    img = 40.0 + rng.normal(0.0, 1.5, (160, 240))
    if halo:
        yy, xx = np.mgrid[0:160, 0:240]
        dx = np.maximum(np.maximum(100 - xx, xx - 149), 0)
        dy = np.maximum(np.maximum(60 - yy, yy - 71), 0)
        d = np.hypot(dx, dy)
        img += 70.0 * np.exp(-0.5 * (d / 4.0) ** 2) * (d > 0)
    else:
        img[44:60, 118:128] = 100.0
    img[60:72, 100:150] = 200.0
    return np.clip(img, 0, 255).astype(np.uint8)


def tower_report(params, halo, ir=True):
    c = FeatureClusterer(params)
    xy = [[104, 63], [118, 66], [131, 62], [147, 70]]
    _, tr = c.update(snap(xy, [[20, 0]] * len(xy), 0.0, 0), tower_scene(halo), ir=ir)
    assert len(tr) == 1
    return tr.boxes[0].tolist()


def test_top_halo_keeps_the_halo_out_of_the_top_and_the_tower_in():
    off = P(top_frac=0.25, top_frac_ir=0.25)
    on = P(top_frac=0.25, top_frac_ir=0.25, top_halo_ir=1.0)
    assert off.top_halo_ir == 0.0
    # without the step the halo above the hull is taken for a superstructure
    b = tower_report(off, halo=True)
    assert b[1] < 58
    assert tower_report(on, halo=True)[1] >= 59  # with it the top stays at the hull's (+- the closing)
    assert tower_report(on, halo=False) == tower_report(off, halo=False) == pytest.approx([100, 44, 50, 28])
    assert tower_report(on, halo=True, ir=False) == b  # EO frames: off


def test_retry_grows_with_the_inner_core_only_where_the_full_extent_fails():
    retry = P(grow_core_q_ir=0.2, grow_core_retry_ir=True)
    assert report(retry, ir=True) == pytest.approx([100, 60, 50, 12])  # the full extent failed: the retry
    assert report(retry, ir=True, xy=HULL) == report(P(), ir=True, xy=HULL)
    assert report(retry, ir=False) == report(P(), ir=False)  # EO: off
    # the tower above the hull: the full extent grows, the retry is not used (the tower stays in)
    on = P(top_frac=0.25, top_frac_ir=0.25, grow_core_q_ir=0.4, grow_core_retry_ir=True)
    assert tower_report(on, halo=False) == pytest.approx([100, 44, 50, 28])
