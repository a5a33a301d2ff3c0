"""The stable-feature extractor's stop-15 keyword (paper B, step 1): features held through a
short miss by Lucas-Kanade (``hold_s``, ``hold_min_confidence``, ``hold_max_err``,
``hold_velocity``)."""

import numpy as np
import pytest

from seawatch.detect.features import StableFeatureExtractor

FPS = 25.0
W, H = 240, 160


def _blobs(seed=3, n=70):
    """A grey image of random dark and bright squares (corners for CenSurE and Lucas-Kanade)."""
    rng = np.random.default_rng(seed)
    img = np.full((H, W), 110.0, np.float32)
    for _ in range(n):
        x, y, s = rng.integers(8, W - 16), rng.integers(8, H - 16), rng.integers(3, 8)
        img[y: y + s, x: x + s] = rng.integers(0, 60) if rng.random() < 0.5 else rng.integers(170, 255)
    return img


def _shift(img, dx, dy):
    """``img`` moved by whole pixels (the border repeats)."""
    out = np.roll(np.roll(img, dy, axis=0), dx, axis=1)
    return out.astype(np.uint8)


def _settle(ext, img, n=6):
    """Process the same frame ``n`` times (every feature matched each time)."""
    for k in range(n):
        snap = ext.process(img.astype(np.uint8), k / FPS)
    return snap, n


def _miss(ext):
    """Make the next frames' descriptor matching find nothing (a detector or ratio-test miss)."""
    ext._match = lambda desc, act, kxy=None, radius_px=0.0: (np.zeros(0, np.int64), np.zeros(0, np.int64))


def _by_id(snap):
    return {int(i): k for k, i in enumerate(snap.ids)}


@pytest.mark.parametrize("hold_s", [0.0, 0.2])
def test_a_missed_feature_is_held_where_lucas_kanade_follows_it(hold_s):
    img = _blobs()
    ext = StableFeatureExtractor(nominal_fps=FPS, hold_s=hold_s, guided_px=0)
    before, n = _settle(ext, img)
    assert before.stable.sum() > 20
    _miss(ext)
    after = ext.process(_shift(img, 2, 1), n / FPS)  # the scene moved 2 px right, 1 down
    ia, ib = _by_id(after), _by_id(before)
    common = [i for i in ib if i in ia and before.stable[ib[i]]]
    conf_b = np.array([before.confidence[ib[i]] for i in common])
    conf_a = np.array([after.confidence[ia[i]] for i in common])
    moved = np.array([after.xy[ia[i]] - before.xy[ib[i]] for i in common])
    assert not after.matched.any()
    if hold_s == 0:  # the paper: every unmatched feature loses one, and stays where it was
        assert np.array_equal(conf_a, conf_b - 1)
        assert np.abs(moved).max() == 0
    else:  # most are held: same confidence, found at their new place
        held = conf_a == conf_b
        assert held.mean() > 0.8
        assert np.array_equal(conf_a[~held], conf_b[~held] - 1)
        assert np.allclose(moved[held], [2.0, 1.0], atol=0.3)
        # a held feature has a velocity sample from its new place: 2 px over one frame... or
        # over the velocity baseline (the scene stood still before)
        v = np.array([after.velocity[ia[i]] for i in np.array(common)[held]])
        assert np.isfinite(v).all() and np.all(v[:, 0] > 0) and np.all(v[:, 1] > 0)


def test_a_feature_is_held_at_most_hold_s_after_its_last_match():
    img = _blobs(seed=4)
    ext = StableFeatureExtractor(nominal_fps=FPS, hold_s=0.1, guided_px=0)
    before, n = _settle(ext, img)
    i0 = int(np.flatnonzero(before.stable)[0])
    fid, c0 = int(before.ids[i0]), int(before.confidence[i0])
    _miss(ext)
    confs = []
    for k in range(4):  # 0.04, 0.08, 0.12, 0.16 s after the last match
        snap = ext.process(img.astype(np.uint8), (n + k) / FPS)
        confs.append(int(snap.confidence[_by_id(snap)[fid]]))
    assert confs == [c0, c0, c0 - 1, c0 - 2]


def test_a_feature_on_a_patch_gone_flat_is_held_only_without_an_error_limit():
    """Lucas-Kanade's gradient test looks at the previous frame's window, so a feature whose
    patch has lost its texture still converges; ``hold_max_err`` (the mean absolute grey-level
    difference of the matched windows) refuses it, while the textured half is still held."""
    img = _blobs(seed=5)
    flat = img.copy()
    flat[:, : W // 2] = 110.0  # the left half's texture is gone
    res = {}
    for err in (float("inf"), 8.0):
        ext = StableFeatureExtractor(nominal_fps=FPS, hold_s=0.2, guided_px=0, hold_max_err=err)
        before, n = _settle(ext, img)
        _miss(ext)
        after = ext.process(flat.astype(np.uint8), n / FPS)
        ia = _by_id(after)
        held = {"flat": [], "textured": []}
        for k in np.flatnonzero(before.stable):
            i = int(before.ids[k])
            x = before.xy[k, 0]
            side = "flat" if x < W // 2 - 20 else ("textured" if x > W // 2 + 20 else None)
            if side:  # (15 px windows, 30 px at pyramid level 1)
                held[side].append(i in ia and after.confidence[ia[i]] == before.confidence[k])
        res[err] = {k: float(np.mean(v)) for k, v in held.items()}
        assert len(held["flat"]) >= 8 and len(held["textured"]) >= 8
    assert res[float("inf")]["flat"] > 0.25  # the gradient test alone holds some of them
    assert res[8.0]["flat"] < 0.1
    assert res[8.0]["textured"] == 1.0 and res[float("inf")]["textured"] == 1.0


def test_newborn_features_are_held_only_from_hold_min_confidence():
    img = _blobs(seed=6)
    ext = StableFeatureExtractor(nominal_fps=FPS, hold_s=0.2, hold_min_confidence=2, guided_px=0)
    first = ext.process(img.astype(np.uint8), 0.0)  # every feature is new: confidence 1
    _miss(ext)
    second = ext.process(img.astype(np.uint8), 1 / FPS)
    # confidence 1 is below hold_min_confidence 2: all die (none of the first frame's is left)
    assert not set(map(int, first.ids)) & set(map(int, second.ids))
    ext2 = StableFeatureExtractor(nominal_fps=FPS, hold_s=0.2, hold_min_confidence=1, guided_px=0)
    first2 = ext2.process(img.astype(np.uint8), 0.0)
    _miss(ext2)
    second2 = ext2.process(img.astype(np.uint8), 1 / FPS)
    kept = set(map(int, first2.ids)) & set(map(int, second2.ids))
    assert len(kept) > 0.8 * len(first2.ids)


def test_bad_hold_settings_are_refused():
    with pytest.raises(ValueError, match="hold_s"):
        StableFeatureExtractor(hold_s=-0.1)


def test_without_hold_velocity_a_held_feature_moves_but_gives_no_velocity_sample():
    img = _blobs(seed=7)
    snaps = {}
    for hv in (True, False):
        ext = StableFeatureExtractor(nominal_fps=FPS, hold_s=0.2, guided_px=0, hold_velocity=hv)
        before, n = _settle(ext, img)
        _miss(ext)
        after = ext.process(_shift(img, 2, 0), n / FPS)
        ia, ib = _by_id(after), _by_id(before)
        held = [i for i in ib if before.stable[ib[i]] and i in ia
                and after.confidence[ia[i]] == before.confidence[ib[i]]]
        assert len(held) > 10
        moved = np.array([after.xy[ia[i]] - before.xy[ib[i]] for i in held])
        assert np.allclose(moved, [2.0, 0.0], atol=0.3)
        snaps[hv] = np.array([after.velocity[ia[i]] for i in held])
    assert np.isfinite(snaps[True]).all() and np.all(snaps[True][:, 0] > 0)
    assert np.isnan(snaps[False]).all()


@pytest.mark.parametrize("band_only", [True, False])
def test_with_a_horizon_only_the_water_bands_features_are_held_when_the_hold_is_on(band_only):
    from seawatch.detect.horizon import Horizon

    img = _blobs(seed=8, n=90)
    hz = Horizon(70.0, 70.0, W)  # the band: rows 64 (6 px above) to the bottom
    ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=0, hold_s=0.2, hold_band_only=band_only)
    for k in range(6):
        before = ext.process(img.astype(np.uint8), k / FPS, horizon=hz)
    _miss(ext)
    after = ext.process(img.astype(np.uint8), 6 / FPS, horizon=hz)
    ia = _by_id(after)
    held = {"sky": [], "band": []}
    for k in np.flatnonzero(before.stable):
        i = int(before.ids[k])
        y = before.xy[k, 1]
        side = "sky" if y < 60 else ("band" if y > 68 else None)
        if side:
            held[side].append(i in ia and after.confidence[ia[i]] == before.confidence[k])
    assert len(held["sky"]) >= 5 and len(held["band"]) >= 5
    assert np.mean(held["band"]) > 0.9
    assert np.mean(held["sky"]) == (0.0 if band_only else 1.0)
    assert StableFeatureExtractor().hold_band_only and StableFeatureExtractor().hold_s == 0.0


def test_hold_levels_is_lucas_kanades_pyramid_depth_and_the_image_alone_by_default():
    """With the image alone (0 levels) a feature is held after a small move; a move beyond
    ``subpixel_max_px`` is not followed (the hold refuses it) at any depth."""
    img = _blobs(seed=9)
    assert StableFeatureExtractor().hold_levels == 0
    for levels in (0, 1):
        for dx, expect in ((2, True), (6, False)):
            ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=0, hold_s=0.2, hold_levels=levels)
            before, n = _settle(ext, img)
            _miss(ext)
            after = ext.process(_shift(img, dx, 0), n / FPS)
            ia = _by_id(after)
            st = [int(before.ids[k]) for k in np.flatnonzero(before.stable)]
            held = np.mean([i in ia and after.confidence[ia[i]] == before.confidence[_by_id(before)[i]] for i in st])
            assert (held > 0.8) if expect else (held < 0.1), (levels, dx, held)


def test_hold_levels_reaches_lucas_kanade_a_pyramid_follows_a_move_the_image_alone_does_not():
    """An 8 px move with a 14 px convergence limit: the image alone (0 levels) loses most of the
    features, one pyramid level follows most of them, so ``hold_levels`` is OpenCV's depth."""
    img = _blobs(seed=9)
    held = {}
    for levels in (0, 1):
        ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=0, hold_s=0.2, hold_levels=levels,
                                     subpixel_max_px=14)
        before, n = _settle(ext, img)
        _miss(ext)
        after = ext.process(_shift(img, 8, 0), n / FPS)
        ia, ib = _by_id(after), _by_id(before)
        st = [int(before.ids[k]) for k in np.flatnonzero(before.stable)]
        held[levels] = np.mean([i in ia and after.confidence[ia[i]] == before.confidence[ib[i]] for i in st])
    assert held[1] > 0.7 and held[0] < 0.4, held
