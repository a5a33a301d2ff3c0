"""Session 22: the box growing's polarity rule kept to the wake's side of a moving boat
(``ClusterParams.grow_sign_trail_px_s`` / ``grow_boxes(sign_side=...)``)."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, grow_boxes

# a dark hull (grey 30) x 100..119, y 60..66 on water (grey 85, noise 2); bright foam (grey 150) at
# its left end, x 92..99, rows 63..66; optionally a bright part (grey 200) at its right end,
# x 120..127, rows 60..66 (a white superstructure beside the core, the other polarity)
HULL = (100, 60, 20, 7)
CORE = np.array([[104.0, 61.0, 12.0, 4.0]])
BOX = np.array([[102.0, 59.0, 16.0, 8.0]])
GROW = dict(peak_frac=0.5, wide_grow_px=120)


def scene(seed, foam=True, bright_bow=False):
    rng = np.random.default_rng(seed)
    img = np.clip(85 + rng.normal(0, 2, (200, 240)), 0, 255)
    x, y, w, h = HULL
    img[y:y + h, x:x + w] = 30
    if foam:
        img[63:67, 92:100] = 150
    if bright_bow:
        img[60:67, 120:128] = 200
    return img.astype(np.uint8)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_foam_is_left_out_only_when_it_lies_on_the_trailing_side(seed):
    img = scene(seed)
    # the boat moves right: its wake trails on the left, where the foam is
    left = grow_boxes(img, BOX, CORE, sign_frac=0.7, sign_side=np.array([-1]), **GROW)[0]
    assert left.tolist() == pytest.approx(list(HULL))
    # moving left (wake on the right) or not moving: the foam is not masked
    right = grow_boxes(img, BOX, CORE, sign_frac=0.7, sign_side=np.array([1]), **GROW)[0]
    still = grow_boxes(img, BOX, CORE, sign_frac=0.7, sign_side=np.array([0]), **GROW)[0]
    off = grow_boxes(img, BOX, CORE, **GROW)[0]
    assert off[0] == pytest.approx(92)  # the foam's 8 px are in without the rule
    assert right.tolist() == off.tolist()
    assert still.tolist() == off.tolist()


@pytest.mark.parametrize("seed", [3, 4])
def test_the_other_polarity_ahead_of_the_core_stays_in(seed):
    # a white part at the bow (right, ahead of a boat moving right): the rule on every side drops
    # it with the foam; kept to the trailing side it drops the foam only
    img = scene(seed, bright_bow=True)
    every = grow_boxes(img, BOX, CORE, sign_frac=0.7, **GROW)[0]
    assert every.tolist() == pytest.approx(list(HULL))
    trailing = grow_boxes(img, BOX, CORE, sign_frac=0.7, sign_side=np.array([-1]), **GROW)[0]
    assert trailing.tolist() == pytest.approx([100, 60, 28, 7])
    off = grow_boxes(img, BOX, CORE, **GROW)[0]
    assert off.tolist() == pytest.approx([92, 60, 36, 7])


def test_the_side_needs_the_sign_rule():
    img = scene(5)
    got = grow_boxes(img, BOX, CORE, sign_side=np.array([-1]), **GROW)[0]  # sign_frac 0: off
    assert got[0] == pytest.approx(92)


def run_clusterer(params, img, vx):
    cl = FeatureClusterer(params)
    xy = np.array([[104.0, 61.0], [110.0, 63.0], [116.0, 65.0], [108.0, 64.0]])
    _, tr = cl.update(snap(xy, [[vx, 0.0]] * len(xy), 0.0, 0, ids=[1, 2, 3, 4], shape=img.shape[:2]), img)
    assert len(tr) == 1
    return tr.boxes[0]


def test_the_clusterer_takes_the_side_from_the_members_motion():
    assert ClusterParams().grow_sign_trail_px_s == 2.0  # on by default since session 23
    img = scene(6, bright_bow=True)
    p = dict(confirm_s=0.0, relink_s=0.0, coast_s=0.0, grow_sign=0.7)
    # moving right at 20 px/s: the foam (left) out, the white bow in
    assert run_clusterer(ClusterParams(grow_sign_trail_px_s=5.0, **p), img, 20.0).tolist() == pytest.approx(
        [100, 60, 28, 7])
    # slower than the threshold: no side, nothing masked
    slow = run_clusterer(ClusterParams(grow_sign_trail_px_s=30.0, **p), img, 20.0)
    assert slow.tolist() == pytest.approx([92, 60, 36, 7])
    # the threshold off (0): the rule on every side, as in session 20
    assert run_clusterer(ClusterParams(grow_sign_trail_px_s=0.0, **p), img, 20.0).tolist() == pytest.approx(list(HULL))
