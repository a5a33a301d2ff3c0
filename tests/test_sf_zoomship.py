"""Session 21: the cargo ship at full zoom (issue #8): a long hull's box growing made steady
(``grow_cover_wide``: a cover failure in the first window tries the wide one; ``grow_hint``: the
cluster's grown box of the frame before is looked at again when both windows fail)."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, grow_boxes


def water(seed, h=140, w=560):
    rng = np.random.default_rng(seed)
    return np.clip(85 + rng.normal(0, 2, (h, w)), 0, 255)


# scene 1: a dark hull x 120..319, y 60..71 (200 px, longer than the first window) and a
# superstructure x 200..239, y 44..55, apart from the hull by 4 rows (the closing does not join them)
HULL1 = (120, 60, 200, 12)
CORE1 = np.array([[190.0, 50.0, 60.0, 20.0]])
BOX1 = CORE1 + [[-2.0, -2.0, 4.0, 4.0]]


def scene1(seed):
    img = water(seed)
    x, y, w, h = HULL1
    img[y:y + h, x:x + w] = 30
    img[44:56, 200:240] = 30
    return img.astype(np.uint8)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_cover_failure_in_the_first_window_tries_the_wide_window(seed):
    img = scene1(seed)
    # the first window (40 px each side) lies inside the hull's length: its border strips are on
    # the hull at the hull's rows, so the hull is background there, and the superstructure alone
    # does not cover the core: the box stays the features' extent
    off = grow_boxes(img, BOX1, CORE1, peak_frac=0.5, wide_grow_px=120, return_found=True)
    assert off[0][0].tolist() == pytest.approx(BOX1[0].tolist()) and not off[2][0]
    on = grow_boxes(img, BOX1, CORE1, peak_frac=0.5, wide_grow_px=120, return_found=True, cover_wide=True)
    assert on[2][0]
    assert on[0][0].tolist() == pytest.approx([120, 44, 200, 28])  # the hull and the superstructure


def test_cover_wide_needs_the_wide_window_and_changes_nothing_when_the_first_window_grows():
    img = scene1(3)
    # no wide window: nothing else to try
    none = grow_boxes(img, BOX1, CORE1, peak_frac=0.5, wide_grow_px=0, cover_wide=True)
    assert none[0].tolist() == pytest.approx(BOX1[0].tolist())
    # a short boat inside the first window: the same box with and without the step
    img2 = water(3)
    img2[60:72, 200:240] = 30
    core = np.array([[205.0, 61.0, 30.0, 9.0]])
    box = core + [[-2.0, -2.0, 4.0, 4.0]]
    a = grow_boxes(img2, box, core, peak_frac=0.5, wide_grow_px=120)
    b = grow_boxes(img2, box, core, peak_frac=0.5, wide_grow_px=120, cover_wide=True)
    assert a[0].tolist() == pytest.approx([200, 60, 40, 12]) and np.array_equal(a, b)


# scene 2: a hull x 150..409 (260 px, longer than the wide window can hold from its end), the
# features only at its stern
HULL2 = (150, 60, 260, 24)
CORE2 = np.array([[160.0, 62.0, 40.0, 16.0]])
BOX2 = CORE2 + [[-2.0, -2.0, 4.0, 4.0]]


def scene2(seed, coast=False):
    img = water(seed)
    x, y, w, h = HULL2
    if coast:  # a dark band across the whole image instead (a coastline)
        img[y:y + h, :] = 30
    else:
        img[y:y + h, x:x + w] = 30
    return img.astype(np.uint8)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_box_grown_the_frame_before_is_looked_at_again(seed):
    img = scene2(seed)
    off = grow_boxes(img, BOX2, CORE2, peak_frac=0.5, wide_grow_px=120, return_found=True)
    assert not off[2][0]  # the hull reaches the edge of both windows
    hint = np.array([[152.0, 61.0, 255.0, 22.0]])  # last frame's box, a little off
    on = grow_boxes(img, BOX2, CORE2, peak_frac=0.5, wide_grow_px=120, return_found=True, hints=hint,
                    hint_pad_px=20)
    assert on[2][0] and on[0][0].tolist() == pytest.approx(list(HULL2))
    # no hint (NaN) or a hint inside the first window: as without
    for h in (np.full((1, 4), np.nan), BOX2):
        same = grow_boxes(img, BOX2, CORE2, peak_frac=0.5, wide_grow_px=120, return_found=True, hints=h)
        assert np.array_equal(same[0], off[0]) and not same[2][0]


def test_hint_core_refuses_a_hint_that_the_features_left():
    img = scene2(6)
    # the features (the core) lie outside last frame's box: they moved onto something else
    hint = np.array([[250.0, 60.0, 160.0, 24.0]])
    kw = dict(peak_frac=0.5, wide_grow_px=120, return_found=True, hints=hint, hint_pad_px=20)
    anyway = grow_boxes(img, BOX2, CORE2, **kw)
    assert anyway[2][0] and anyway[0][0].tolist() == pytest.approx(list(HULL2))  # no check: grown
    refused = grow_boxes(img, BOX2, CORE2, hint_core=0.5, **kw)
    assert not refused[2][0] and refused[0][0].tolist() == pytest.approx(BOX2[0].tolist())
    # the core inside the hint: used
    inside = grow_boxes(img, BOX2, CORE2, hint_core=0.5, **{**kw, "hints": np.array([[150.0, 60.0, 260.0, 24.0]])})
    assert inside[2][0] and inside[0][0].tolist() == pytest.approx(list(HULL2))


def test_hint_core_x_counts_the_columns_only():
    img = scene2(7)
    img[84:104, 150:410] = 50  # the hull's reflection below it
    # last frame's box ends at the waterline, the core reaches down into the reflection below it:
    # a third of the core's height lies inside the box, all of its width
    hint = np.array([[150.0, 60.0, 260.0, 24.0]])
    core = np.array([[160.0, 76.0, 40.0, 24.0]])
    box = core + [[-2.0, -2.0, 4.0, 4.0]]
    kw = dict(peak_frac=0.5, wide_grow_px=120, return_found=True, hints=hint, hint_pad_px=20, hint_core=0.5)
    assert not grow_boxes(img, box, core, **kw)[2][0]
    got = grow_boxes(img, box, core, hint_core_x=True, **kw)
    assert got[2][0] and got[0][0].tolist() == pytest.approx([150, 60, 260, 44])  # hull and reflection
    # beside the hint (the ir 8 case): refused on the columns too
    assert not grow_boxes(img, BOX2, CORE2, hint_core_x=True, **{**kw, "hints": np.array([[250.0, 60.0, 160.0, 24.0]])})[2][0]
    assert ClusterParams().grow_hint_core_x is False


def test_a_hint_on_a_coastline_grows_nothing():
    img = scene2(4, coast=True)
    hint = np.array([[150.0, 60.0, 260.0, 24.0]])
    got = grow_boxes(img, BOX2, CORE2, peak_frac=0.5, wide_grow_px=120, return_found=True, hints=hint,
                     hint_pad_px=20)
    assert not got[2][0] and got[0][0].tolist() == pytest.approx(BOX2[0].tolist())


def hull_frames(params, img):
    """The one cluster's reported box in two frames: the features along the whole hull, then only
    the two at its stern (the others lost)."""
    cl = FeatureClusterer(params)
    xs = [160.0, 200.0, 240.0, 280.0, 320.0, 360.0, 400.0]
    xy = np.array([[x, 62.0 + 8.0 * (i % 2)] for i, x in enumerate(xs)])
    _, t0 = cl.update(snap(xy, [[20.0, 0.0]] * len(xy), 0.0, 0, ids=list(range(1, 8)), shape=img.shape[:2]), img)
    _, t1 = cl.update(snap(xy[:2], [[20.0, 0.0]] * 2, 0.1, 1, ids=[1, 2], shape=img.shape[:2]), img)
    assert len(t0) == 1 and len(t1) == 1 and t0.ids[0] == t1.ids[0]
    return t0.boxes[0], t1.boxes[0]


def test_the_clusterer_keeps_the_hull_box_with_grow_hint_only():
    # on by default (session 21: grow_hint with grow_hint_core 0.5); grow_cover_wide off
    assert ClusterParams().grow_hint is True and ClusterParams().grow_hint_core == 0.5
    assert ClusterParams().grow_cover_wide is False and ClusterParams().grow_hint_core_x is False
    img = scene2(5)
    p = dict(confirm_s=0.0, relink_s=0.0, coast_s=0.0, waterline_frac=0.0, wake_frac=0.0, top_frac=0.0)
    b0, b1 = hull_frames(ClusterParams(grow_hint=False, **p), img)
    assert b0.tolist() == pytest.approx(list(HULL2))  # all the features: the hull in the first window
    assert b1[2] < 50  # the stern's features only: the features' extent
    h0, h1 = hull_frames(ClusterParams(**p), img)
    assert h0.tolist() == pytest.approx(list(HULL2))
    assert h1.tolist() == pytest.approx(list(HULL2))  # looked for where the hull was
