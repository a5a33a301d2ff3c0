"""Session 26 round 2 (H26, issue #8): ``wake_core_iou``, a guard on ``wake_core``'s wake cut.  A cut
with the core's (or the leading end's) reference at ``wake_core`` that moves a cluster's box off its grown
box of the frame before (IoU under ``wake_core_iou``, carried by the camera) is undone: the box is grown
again without ``wake_core``.  On by default since session 28 (0.6)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, grow_boxes


def _tug_scene(seed: int = 0):
    """A dark sea, a tall bright object (14 x 28 px at x 100-113) and a low hull (19 x 10 px at
    x 114-132, the same bottom) on its right: the low hull's columns are under 0.5 but over 0.3 of
    the tall object's height."""
    rng = np.random.default_rng(seed)
    img = rng.normal(60.0, 2.0, (120, 260)).clip(0, 255)
    img[40:68, 100:114] = 200.0
    img[58:68, 114:133] = 200.0
    return img.astype(np.uint8)


P = dict(grow=1.0, wake_frac=0.3, wake_front=0.3)
CORE = np.array([[101.0, 42.0, 28.0, 25.0]])  # the features over both objects
PRE = CORE + [-2, -2, 4, 4]
TRAIL = np.array([1])  # moving left: the wake on the right


def _grow(img, **kw):
    return grow_boxes(img, PRE, CORE, trail=TRAIL, return_contrast=True, return_found=True, **P, **kw)


def _clusterer(iou, last_box, cut=0.0):
    fc = FeatureClusterer(ClusterParams(wake_frac=0.3, wake_front=0.3, wake_core=0.5, wake_core_iou=iou,
                                        wake_core_iou_cut=cut, grow_box=1.0))
    fc._cluster_boxes_now = 4  # the frame before this one (5)
    fc._wcore_last = {7: np.asarray(last_box, float)}
    fc._wcore_last_t = 4
    return fc


def _guard(fc, img, boxes, found):
    snap = SimpleNamespace(t_s=0.5, frame_index=5, homography=np.eye(3))
    return fc._wake_core_guard(snap, 5, np.array([7]), img, PRE, CORE, boxes, found, TRAIL, None, None, None)


def test_wake_core_cuts_the_low_hull():
    img = _tug_scene()
    b0, _, f0 = _grow(img)
    assert f0[0] and b0[0][0] <= 101 and b0[0][0] + b0[0][2] >= 132  # 0.3 of the reference: both kept
    b1, _, f1 = _grow(img, wake_core=0.5)
    assert f1[0] and b1[0][0] + b1[0][2] <= 115  # 0.5: the low hull taken for a wake


def test_guard_undoes_a_cut_off_the_box_before():
    img = _tug_scene()
    b1, _, f1 = _grow(img, wake_core=0.5)
    fc = _clusterer(0.6, [100.0, 40.0, 33.0, 28.0])  # the box before held both
    out, found = _guard(fc, img, b1.copy(), f1.copy())
    assert found[0] and out[0][0] <= 101 and out[0][0] + out[0][2] >= 132
    assert fc._wcore_last_t == 5 and np.allclose(fc._wcore_last[7], out[0])
    # a cut that agrees with the box before is kept
    fc = _clusterer(0.6, [100.0, 40.0, 14.0, 28.0])
    out, _ = _guard(fc, img, b1.copy(), f1.copy())
    assert np.allclose(out, b1)
    # a lower threshold: the same cut (IoU 0.42 with the box before) is kept
    fc = _clusterer(0.3, [100.0, 40.0, 33.0, 28.0])
    out, _ = _guard(fc, img, b1.copy(), f1.copy())
    assert np.allclose(out, b1)
    # no box before (a gap of a frame): nothing undone
    fc = _clusterer(0.6, [100.0, 40.0, 33.0, 28.0])
    fc._wcore_last_t = 3
    out, _ = _guard(fc, img, b1.copy(), f1.copy())
    assert np.allclose(out, b1)


def test_guard_carries_the_box_before():
    img = _tug_scene()
    b1, _, f1 = _grow(img, wake_core=0.5)
    fc = _clusterer(0.6, [90.0, 40.0, 33.0, 28.0])  # the camera moved the scene by +10 px since
    snap = SimpleNamespace(t_s=0.5, frame_index=5, homography=np.array([[1.0, 0, 10.0], [0, 1.0, 0], [0, 0, 1.0]]))
    out, _ = fc._wake_core_guard(snap, 5, np.array([7]), img, PRE, CORE, b1.copy(), f1.copy(), TRAIL, None, None, None)
    assert out[0][0] + out[0][2] >= 132


def test_on_by_default_since_session_28():
    p = ClusterParams()
    assert p.wake_core_iou == 0.6 and p.wake_core_iou_cut == 0.0


def test_cut_fraction_keeps_a_cut_that_takes_little_of_the_box_before():
    img = _tug_scene()
    b1, _, f1 = _grow(img, wake_core=0.5)
    for frac, undone in ((0.4, True), (0.9, False)):
        fc = _clusterer(0.6, [100.0, 40.0, 33.0, 28.0], frac)  # the cut took 19 of its 33 columns (0.58)
        out, _ = _guard(fc, img, b1.copy(), f1.copy())
        assert (out[0][0] + out[0][2] >= 132) == undone
    assert ClusterParams().wake_core_iou_cut == 0
