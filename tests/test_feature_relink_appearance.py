"""Session 18 (issue #8): the relink's appearance check (``relink_appearance``): a lost identity is
not given to a new cluster that looks unlike the lost box did when it was last seen."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import (
    ClusterParams,
    FeatureClusterer,
    appearance_distance,
    appearance_parts,
    appearance_signature,
)

SHAPE = (160, 240)


def sea(seed, boats=()):
    """Grey sea (120, noise 2) with boats ``(x0, x1, level)`` on rows 59-63."""
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, SHAPE)
    for x0, x1, level in boats:
        img[59:64, x0:x1] = level
    return np.clip(img, 0, 255).astype(np.uint8)


DARK, BRIGHT = 60.0, 210.0


def run(**kw):
    """Boat A (dark, features at x 100-110, moving right) and boat B (bright, x 130-140, moving
    left) are seen, lost together for three frames, and a cluster comes back on the bright boat at
    x 114-122: nearer A's last box (gap 0 px) than B's (gap 4 px).  Returns A's and B's identities,
    the returning cluster's identity, the tracks of every frame and the clusterer."""
    # relink_app_margin: on by default since session 28; named off here: the tests isolate relink_appearance
    kw = {"relink_app_margin": 0.0, **kw}
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=10.0, relink_px=30.0, grow_box=0.0, **kw))
    va, vb = [[20, 0]] * 2, [[-20, 0]] * 2
    img0 = sea(0, [(99, 111, DARK), (129, 141, BRIGHT)])
    _, tr = c.update(snap([[100, 60], [110, 62], [130, 60], [140, 62]], va + vb, 0.0, 0, [1, 2, 3, 4]), img0)
    assert len(tr) == 2
    ida, idb = (int(r) for r in tr.ids[np.argsort(tr.boxes[:, 0])])
    out = [(tr.ids.copy(), tr.boxes.copy())]
    for k in range(1, 4):
        _, tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.1 * k, k, []), sea(k))
        out.append((tr.ids.copy(), tr.boxes.copy()))
    _, tr = c.update(snap([[114, 60], [122, 62]], vb, 0.4, 4, [5, 6]), sea(4, [(113, 123, BRIGHT)]))
    out.append((tr.ids.copy(), tr.boxes.copy()))
    assert len(tr) == 1
    return ida, idb, int(tr.ids[0]), out, c


def test_on_by_default():
    p = ClusterParams()
    assert p.relink_appearance is True and p.relink_appearance_max == 1.4


def test_without_the_check_the_nearer_lost_identity_is_taken():
    ida, idb, now, _, c = run(relink_appearance=False)
    assert now == ida  # the dark boat's identity on the bright boat: the old behaviour
    assert len(c.relink_log) == 0  # nothing checked


def test_with_the_check_the_other_boats_identity_is_refused():
    ida, idb, now, _, c = run()  # on by default
    assert now == idb  # the bright boat gets its own identity back
    refused = {k: r for (_, k, _, _, _, _, r) in c.relink_log}
    assert refused == {ida: True, idb: False}


def test_the_check_with_an_infinite_threshold_changes_nothing():
    *_, off, _ = run(relink_appearance=False)
    *_, on, c = run(relink_appearance=True, relink_appearance_max=np.inf)
    assert len(c.relink_log) == 2  # both pairs were checked, none refused
    assert len(off) == len(on)
    for (i0, b0), (i1, b1) in zip(off, on):
        assert i0.tolist() == i1.tolist()
        assert np.array_equal(b0, b1)


def test_a_box_too_small_to_compare_is_not_refused():
    # a box off the image or under 2 px wide has no signature, so no check (old behaviour)
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=10.0, relink_px=30.0, grow_box=0.0,
                                       relink_appearance=True))
    assert appearance_signature(sea(0), [300.0, 10.0, 5.0, 5.0]) is None
    assert appearance_signature(sea(0), [10.0, 10.0, 1.0, 8.0]) is None
    assert c._looks_alike(7, 0, np.array([9]), np.array([[10.0, 10.0, 5.0, 5.0]]), 0.0, {})  # nothing stored for 7


def test_signature_ignores_scale_and_sees_contrast():
    rng = np.random.default_rng(3)
    img = np.clip(120.0 + rng.normal(0.0, 2.0, (200, 300)), 0, 255)
    img[50:60, 40:80] = 200.0  # a bright boat, 40 x 10
    img[52:57, 50:60] = 90.0  # with a dark cabin
    big = np.clip(120.0 + rng.normal(0.0, 2.0, (200, 300)), 0, 255)
    big[100:120, 100:180] = 200.0  # the same boat twice as large (a zoom)
    big[104:114, 120:140] = 90.0
    dark = img.copy()
    dark[50:60, 40:80] = 40.0  # a dark boat with the same cabin
    a = appearance_signature(img.astype(np.uint8), [38, 48, 44, 14])
    b = appearance_signature(big.astype(np.uint8), [96, 96, 88, 28])
    d = appearance_signature(dark.astype(np.uint8), [38, 48, 44, 14])
    dc, dt = appearance_parts(a, b)
    assert dc < 0.1 and dt < 0.1
    dc, dt = appearance_parts(a, d)
    assert dc > 1.5  # the contrast inverted
    assert appearance_distance(a, d) == pytest.approx(dc)
    assert appearance_distance(a, d, template_weight=1.0) == pytest.approx(dc + dt)
    # colour: the same grey level, another colour
    col = np.repeat(img[:, :, None], 3, axis=2)
    red = col.copy()
    red[50:60, 40:80] = (40.0, 40.0, 200.0)
    red[52:57, 50:60] = 90.0
    a3 = appearance_signature(col.astype(np.uint8), [38, 48, 44, 14])
    r3 = appearance_signature(red.astype(np.uint8), [38, 48, 44, 14])
    assert a3[1].shape == (3,)
    assert appearance_parts(a3, r3)[0] > 0.8
