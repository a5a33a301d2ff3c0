"""Guided re-detection in the water band (``redetect_threshold``; stop 16, issue #8): where an
active feature is expected and the band's detector did not fire this frame, CenSurE looks again
with a lower threshold in a small window around it and offers what it finds to the matching."""

import cv2
import numpy as np
import pytest

from seawatch.detect.features import StableFeatureExtractor

FPS = 25.0
XS = list(range(30, 300, 45))  # seven far boats on row 130, 30 rows below the horizon


class _Horizon:
    def __init__(self, r):
        self.r = float(r)

    def row_at(self, x):
        return np.full(np.shape(x), self.r)


def _scene(faint):
    """Seven small bright blobs in the water band, each with a dark dot at its own angle (so that
    their descriptors differ); with ``faint`` the third is dimmer, so that the band's threshold
    (5) finds no keypoint on it while a threshold of 3 does."""
    img = np.full((240, 320), 100, np.uint8)
    for i, x in enumerate(XS):
        cv2.circle(img, (x, 130), 2, 125 if (faint and i == 2) else 160, -1)
        a = i * 2 * np.pi / len(XS)
        cv2.circle(img, (int(x + 7 * np.cos(a)), int(130 + 7 * np.sin(a))), 1, 60, -1)
    return img


def _run(thr):
    ext = StableFeatureExtractor(nominal_fps=FPS, redetect_threshold=thr)
    for f in range(6):
        snap = ext.process(_scene(False), f / FPS, horizon=_Horizon(100.0))
    before = snap
    after = ext.process(_scene(True), 6 / FPS, horizon=_Horizon(100.0))
    return before, after


def _on_boat(snap, x=XS[2], y=130.0):
    return np.hypot(snap.xy[:, 0] - x, snap.xy[:, 1] - y) < 5.0


def test_a_feature_whose_keypoint_falls_under_the_threshold_is_still_matched_with_redetection():
    before_off, off = _run(0)
    before_on, on = _run(3)
    # six frames of the bright scene: the boat's features are matched every frame either way
    for b in (before_off, before_on):
        assert _on_boat(b).sum() >= 2 and b.matched[_on_boat(b)].all()
    # the faint frame: without re-detection none of the boat's features matches (confidence falls)
    assert _on_boat(off).sum() >= 2 and not off.matched[_on_boat(off)].any()
    # with it, the lower threshold finds the boat again near where its features are expected
    assert on.matched[_on_boat(on)].sum() >= 2
    # the other boats are matched either way
    others = ~_on_boat(on) & (np.abs(on.xy[:, 1] - 130.0) < 5.0)
    assert on.matched[others].all() and off.matched[~_on_boat(off) & (np.abs(off.xy[:, 1] - 130.0) < 5.0)].all()


def test_a_redetected_keypoint_that_matches_nothing_does_not_become_a_feature():
    """Active features expected on the faint boat, with descriptors unlike anything in the image:
    the re-detected keypoints there match nothing and are dropped (``dedup_px`` 0, so that only
    this rule keeps them out); the band's own keypoints on the other boats do become features."""
    snaps = {}
    for thr in (0, 3):
        rng = np.random.default_rng(0)
        ext = StableFeatureExtractor(nominal_fps=FPS, redetect_threshold=thr, dedup_px=0.0)
        seeded = np.array([[122.2, 127.8], [117.8, 127.8], [10.0, 10.0]])
        ext._grow(len(seeded))
        ext._alive[:3] = True
        ext._ids[:3] = [1000, 1001, 1002]
        ext._next_id = 2000
        ext._xy[:3] = seeded
        ext._desc[:3] = rng.uniform(0, 60, (3, 128)).astype(np.float32)
        ext._conf[:3] = 3
        snaps[thr] = ext.process(_scene(True), 0.0, horizon=_Horizon(100.0))
    snap = snaps[3]
    assert snap.n_matched == 0
    assert snap.n_keypoints > snaps[0].n_keypoints  # re-detected keypoints were offered
    assert sorted(snap.ids[_on_boat(snap)].tolist()) == [1000, 1001]
    assert (snap.ids >= 2000).sum() >= 6  # the other boats' keypoints are new features


def test_redetection_off_by_default_and_bad_values_refused():
    assert StableFeatureExtractor().redetect_threshold == 0
    with pytest.raises(ValueError, match="redetect"):
        StableFeatureExtractor(redetect_threshold=-1)
    with pytest.raises(ValueError, match="redetect"):
        StableFeatureExtractor(redetect_px=-1.0)
