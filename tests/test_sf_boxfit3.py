"""Session 20: the `pan` box fit (issue #8): the box growing kept to the core's polarity
(``grow_sign`` / ``grow_boxes(sign_frac=...)``)."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, grow_boxes

# a dark hull (grey 30) x 100..119, y 60..66 on water (grey 85, noise 2) with bright foam
# (grey 150) at its stern: a band x 92..99 at the waterline rows 63..66, touching the hull (inside
# the growing's window, x 86..133, clear of its border strips)
HULL = (100, 60, 20, 7)


def scene(seed, foam=True, colour=False, cabin=False):
    rng = np.random.default_rng(seed)
    img = np.clip(85 + rng.normal(0, 2, (200, 240)), 0, 255)
    x, y, w, h = HULL
    img[y:y + h, x:x + w] = 30
    if cabin:  # a white cabin over the middle of the hull, as tall as the hull
        img[y - 7:y, x + 4:x + 16] = 200
    if foam:
        img[63:67, 92:100] = 150
    img = img.astype(np.uint8)
    if colour:
        img = np.repeat(img[:, :, None], 3, axis=2)
    return img


# the cluster's box and core: the features' positions on the hull
CORE = np.array([[104.0, 61.0, 12.0, 4.0]])
BOX = np.array([[102.0, 59.0, 16.0, 8.0]])


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("colour", [False, True])
def test_the_foam_joins_the_hull_without_the_step_and_not_with_it(seed, colour):
    img = scene(seed, colour=colour)
    off = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120)[0]
    assert off[0] == pytest.approx(92)  # the foam's 8 px are in
    on = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7)[0]
    assert on.tolist() == pytest.approx(list(HULL))  # exactly the hull


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_without_foam_the_step_changes_nothing(seed):
    img = scene(seed, foam=False)
    off = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120)
    on = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7)
    assert off[0].tolist() == pytest.approx(list(HULL))
    assert on.tolist() == off.tolist()


def test_a_bright_hull_keeps_its_bright_parts_and_drops_a_dark_shadow():
    rng = np.random.default_rng(3)
    img = np.clip(85 + rng.normal(0, 2, (200, 240)), 0, 255)
    img[60:67, 100:120] = 200  # a white hull
    img[63:67, 120:128] = 20  # a dark patch (shadow, dark water) touching its bow
    img = img.astype(np.uint8)
    assert grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120)[0][2] == pytest.approx(28)
    assert grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7)[0].tolist() == pytest.approx([100, 60, 20, 7])


def test_a_core_of_both_polarities_is_grown_as_before():
    # the core covers the white cabin and the dark hull in equal parts: no polarity dominates
    img = scene(4, foam=True, cabin=True)
    core = np.array([[104.0, 54.0, 12.0, 12.0]])
    box = np.array([[102.0, 52.0, 16.0, 16.0]])
    # (dark 84 core pixels, bright 72: 0.54 of one sign; a lower peak fraction takes the hull in)
    off = grow_boxes(img, box, core, peak_frac=0.3, wide_grow_px=120)
    on = grow_boxes(img, box, core, peak_frac=0.3, wide_grow_px=120, sign_frac=0.7)
    assert on.tolist() == off.tolist()
    assert off[0].tolist() == pytest.approx([92, 53, 28, 14])


def test_a_bright_cabin_above_a_dark_hull_comes_back_through_the_top_extension():
    # the core lies on the hull only: the cabin (outside the core, the other sign) is left out of
    # the segmentation but the top extension (top_frac) still sees it; the foam stays out
    img = scene(5, foam=True, cabin=True)
    on = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, top_frac=0.35, sign_frac=0.7)[0]
    assert on.tolist() == pytest.approx([100, 53, 20, 14])
    on_no_top = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7)[0]
    assert on_no_top.tolist() == pytest.approx(list(HULL))


def run_clusterer(params, img):
    """The one cluster's reported box on the hull's features, with the image."""
    cl = FeatureClusterer(params)
    xy = np.array([[104.0, 61.0], [110.0, 63.0], [116.0, 65.0], [108.0, 64.0]])
    _, tr = cl.update(snap(xy, [[20.0, 0.0]] * len(xy), 0.0, 0, ids=[1, 2, 3, 4], shape=img.shape[:2]), img)
    assert len(tr) == 1
    return tr.boxes[0]


def test_grow_sign_defaults_and_the_clusterer_passes_it():
    d = ClusterParams()  # on since session 23: -0.7, on the trailing side only (grow_sign_trail_px_s 2)
    assert (d.grow_sign, d.grow_sign_trail_px_s) == (-0.7, 2.0)
    img = scene(6)
    p = dict(confirm_s=0.0, relink_s=0.0, coast_s=0.0, grow_sign_trail_px_s=0.0)
    off = run_clusterer(ClusterParams(grow_sign=0.0, **p), img)
    on = run_clusterer(ClusterParams(grow_sign=0.7, **p), img)
    assert off[0] == pytest.approx(92)  # the foam is in
    assert on.tolist() == pytest.approx(list(HULL))


@pytest.mark.parametrize("seed", [7, 8])
def test_negative_fraction_masks_only_from_the_core_top_down(seed):
    # grow_sign < 0: the other sign above the core (a white cabin over the dark hull) stays in the
    # segmentation itself, the foam at the waterline (below the core's top) is still left out
    img = scene(seed, foam=True, cabin=True)
    low = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=-0.7)[0]
    assert low.tolist() == pytest.approx([100, 53, 20, 14])
    full = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7)[0]
    assert full.tolist() == pytest.approx(list(HULL))
    off = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120)[0]
    assert off.tolist() == pytest.approx([92, 53, 28, 14])


def test_sign_max_px_limits_the_step_to_small_boxes():
    img = scene(9)
    small = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7, sign_max_px=8)[0]
    assert small.tolist() == pytest.approx(list(HULL))  # the box is 8 px tall: the step acts
    big = grow_boxes(img, BOX, CORE, peak_frac=0.5, wide_grow_px=120, sign_frac=0.7, sign_max_px=7.9)[0]
    assert big[0] == pytest.approx(92)  # taller than the limit: grown as without the step
    assert ClusterParams().grow_sign_max_px == 0.0
