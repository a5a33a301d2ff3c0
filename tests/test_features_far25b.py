"""The far water at a finer scale (``far_px``; session 25, H21, issue #8): the band's top rows
(down to ``far_px`` below the horizon) are searched for keypoints on a copy upscaled
``far_upscale`` (3) times with their own budget, so that the fine structure of a far ship (1-px
marks, below CenSurE's smallest filter at the band's 2x) gives keypoints; the band below keeps its
2x pass unchanged, and ``far_px`` 0 (off) is the old behaviour.  On by default since session 28
(far_px 12, far_threshold 10, far_max_keypoints 30, far_skip_ir True); the tests name their settings."""

import cv2
import numpy as np
import pytest

from seawatch.detect.features import StableFeatureExtractor

FPS = 25.0
NEAR = (40, 120, 220, 280)  # near boats on row 160, 60 rows below the horizon


class _Horizon:
    def __init__(self, r):
        self.r = float(r)

    def row_at(self, x):
        return np.full(np.shape(x), self.r)


def _scene():
    """A far 'ship' 3 rows below the horizon (row 100): a 40x4 px hull with 1-px dark marks every
    4 px, and four near boats (a bright disc with a dark dot) lower in the band."""
    img = np.full((240, 320), 100, np.uint8)
    img[103:107, 140:180] = 140
    for x in range(141, 180, 4):
        img[104 + x % 2, x] = 60
    for x in NEAR:
        cv2.circle(img, (x, 160), 3, 170, -1)
        cv2.circle(img, (x + 5, 163), 1, 60, -1)
    return img


def _run(n=6, **kw):
    ext = StableFeatureExtractor(nominal_fps=FPS, **kw)
    for f in range(n):
        snap = ext.process(_scene(), f / FPS, horizon=_Horizon(100.0))
    return snap


def _on_ship(snap):
    return (snap.xy[:, 0] > 136) & (snap.xy[:, 0] < 184) & (snap.xy[:, 1] > 100) & (snap.xy[:, 1] < 112)


def test_the_far_pass_finds_the_far_ships_fine_structure_and_makes_it_stable():
    off = _run(far_px=0.0)  # on by default since session 28; named off here
    on = _run(far_px=12, far_threshold=0, far_max_keypoints=60)  # H21's settings
    assert _on_ship(off).sum() <= 3
    assert _on_ship(on).sum() >= 10
    assert (_on_ship(on) & on.stable).sum() >= 10


def test_the_band_below_the_far_rows_is_unchanged():
    off = _run(far_px=0.0)
    on = _run(far_px=12, far_threshold=0, far_max_keypoints=60)
    low_off = off.xy[off.xy[:, 1] > 130]
    low_on = on.xy[on.xy[:, 1] > 130]
    assert len(low_off) >= 8
    key = lambda a: sorted(map(tuple, np.round(a, 3).tolist()))
    assert key(low_on) == key(low_off)


def test_far_px_zero_is_the_old_behaviour():
    a = _run(n=3, far_px=0.0, far_threshold=0, far_max_keypoints=60)  # the old defaults
    b = _run(n=3, far_px=0.0, far_upscale=4.0, far_threshold=2, far_max_keypoints=500)
    assert np.array_equal(a.ids, b.ids) and np.array_equal(a.xy, b.xy)
    assert np.array_equal(a.confidence, b.confidence)


def test_the_far_budget_caps_the_far_rows_keypoints():
    small = _run(n=1, far_px=12, far_max_keypoints=4)
    big = _run(n=1, far_px=12, far_threshold=0, far_max_keypoints=60)  # H21's budget (60)
    assert _on_ship(small).sum() <= 4 < _on_ship(big).sum()


def test_bad_far_settings_are_refused():
    with pytest.raises(ValueError):
        StableFeatureExtractor(far_px=-1.0)
    with pytest.raises(ValueError):
        StableFeatureExtractor(far_px=10.0, far_upscale=0.5)


def test_the_far_pass_is_on_by_default_since_session_28():
    import inspect

    ext = StableFeatureExtractor()
    assert (ext.far_px, ext.far_upscale, ext.far_max_keypoints, ext.far_skip_ir) == (12.0, 3.0, 30, True)
    assert inspect.signature(StableFeatureExtractor).parameters["far_threshold"].default == 10  # not kept
    assert _on_ship(_run()).sum() >= 10  # the session 28 defaults find the far ship's marks too
