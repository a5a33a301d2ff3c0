"""Far ships on the horizon (issue #8, session 23 H1): the still-object rule inside the water margin
where the columns hold no coast (``ClusterParams.far_top_px``; 0: off; on by default since session 23
with ``far_open_px`` and ``far_open_contrast``).  ``_params`` starts from the three off, so each test
names the ones it turns on."""

from __future__ import annotations

import numpy as np

from _feature_snap import Level

from seawatch.detect.features import FeatureSnapshot
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _far_still

ROW = 100.0  # the horizon's row




def _snap(k, ship, coast=(), seed=0):
    """Frame ``k``: the ``ship``'s still features (x, dy under the horizon), the ``coast``'s features
    (x, dy: negative above the horizon), all with velocity noise of 0.3 px/s (below the 1.5 px/s floor)."""
    rng = np.random.default_rng(seed + 100 * k)
    pts = [(x, ROW + dy) for x, dy in ship] + [(x, ROW + dy) for x, dy in coast]
    xy = np.array(pts, float)
    return stable_snap(k, xy, rng.normal(0, 0.3, (len(xy), 4, 2)))


def stable_snap(k, xy, hist):
    """Frame ``k`` (0.04 s apart) of stable features at ``xy`` (N, 2) with velocity samples ``hist``
    (N, 4, 2), the last one their velocity; a 320x240 image."""
    n = len(xy)
    return FeatureSnapshot(
        t_s=0.04 * k, frame_index=k, ids=np.arange(n) + 10, slots=np.arange(n), xy=xy,
        size_px=np.full(n, 4.0), confidence=np.full(n, 6), stable=np.ones(n, bool),
        matched=np.ones(n, bool), velocity=hist[:, -1], history=hist, image_velocity=hist[:, -1],
        homography=np.eye(3), dt_s=0.04, n_keypoints=n, n_matched=n, shape=(240, 320),
    )


def _params(**kw):
    # session 25's coast-foot step (on by default since) off: these tests isolate the far rule
    far = dict(far_top_px=0.0, far_open_px=0.0, far_open_contrast=0.0, foot_open_px=0.0, foot_dark=0.0)
    far.update(kw)
    return ClusterParams(relink_s=0.0, coast_s=0.0, confirm_s=0.0, known_min_speed_px_s=0.0, **far)


def _reports(params, ship, coast=(), zoom=1.0, frames=8):
    c = FeatureClusterer(params)
    hz = Level(ROW)
    out = []
    for k in range(frames):
        dets, _ = c.update(_snap(k, ship, coast), horizon=hz, zoom=zoom)
        out.append(dets.boxes.copy())
    return out


SHIP = [(150.0, 6.0), (160.0, 5.5), (158.0, 7.0)]  # a far ship's waterline, 5.5-7 px under the horizon


def test_defaults_and_inside_the_margin_not_joined_when_off():
    d = ClusterParams()
    assert (d.far_top_px, d.far_open_px, d.far_open_contrast) == (3.0, 30.0, 20.0)
    r = _reports(_params(), SHIP)
    assert all(len(b) == 0 for b in r)  # inside the 8 px margin: not a still object


def test_far_ship_found_on_open_sea():
    r = _reports(_params(far_top_px=3.0), SHIP)
    assert len(r[-1]) == 1
    x0, y0, w, h = r[-1][0]
    assert x0 <= 150 and x0 + w >= 160 and y0 <= ROW + 5.5 and y0 + h >= ROW + 7


def test_not_under_a_coast():
    # a coast's features 6-15 px above the horizon in the same columns: the foot of the coast stays out
    coast = [(140.0, -8.0), (165.0, -12.0), (185.0, -6.0)]
    r = _reports(_params(far_top_px=3.0), SHIP, coast)
    assert all(len(b) == 0 for b in r)
    # the same coast farther than far_cols_px (30 px) from every ship column does not keep it out
    far_coast = [(x + 100.0, dy) for x, dy in coast]
    r = _reports(_params(far_top_px=3.0), SHIP, far_coast)
    assert len(r[-1]) == 1
    # a narrower column window lets the near coast in too (the window does what it says)
    r = _reports(_params(far_top_px=3.0, far_cols_px=2.0), SHIP, [(120.0, -8.0), (200.0, -12.0)])
    assert len(r[-1]) == 1


def test_ship_superstructure_is_not_a_coast():
    # features 2 px above the horizon (the ship's own superstructure; the gap is 4 px) do not count
    mast = [(155.0, -2.0), (157.0, -2.5)]
    r = _reports(_params(far_top_px=3.0), SHIP, mast)
    assert len(r[-1]) == 1
    # nor do features far above the horizon (clouds, hills' tops: more than far_coast_px 20 px)
    r = _reports(_params(far_top_px=3.0), SHIP, [(155.0, -30.0), (160.0, -40.0)])
    assert len(r[-1]) == 1


def test_horizon_texture_not_taken():
    # features 0.5-2.5 px under the horizon (its own texture) stay out
    line = [(150.0, 1.0), (160.0, 2.5), (158.0, 0.5)]
    r = _reports(_params(far_top_px=3.0), line)
    assert all(len(b) == 0 for b in r)


def test_scales_with_zoom():
    # at zoom 2 the band is 6-16 px under the horizon: the same ship seen at zoom 2
    ship2 = [(150.0, 12.0), (160.0, 11.0), (158.0, 14.0)]
    assert len(_reports(_params(far_top_px=3.0), ship2, zoom=2.0)[-1]) == 1
    assert all(len(b) == 0 for b in _reports(_params(), ship2, zoom=2.0))  # inside 16 px when off
    line2 = [(150.0, 3.0), (160.0, 5.0), (158.0, 4.0)]  # 3-5 px at zoom 2: the horizon's texture
    assert all(len(b) == 0 for b in _reports(_params(far_top_px=3.0), line2, zoom=2.0))
    # the coast's window scales too: a coast 50 px away counts at zoom 2 (30 x 2 = 60 px)
    coast = [(210.0, -16.0)]
    assert all(len(b) == 0 for b in _reports(_params(far_top_px=3.0), ship2, coast, zoom=2.0))
    assert len(_reports(_params(far_top_px=3.0), SHIP, [(210.0, -8.0)], zoom=1.0)[-1]) == 1  # 50 px > 30 at zoom 1


def test_far_still_mask():
    p = _params(far_top_px=3.0)
    xy = np.array([[10, ROW + 2], [10, ROW + 5], [10, ROW + 9], [100, ROW + 6], [103, ROW - 10], [200, ROW + 5]])
    row = np.full(len(xy), ROW)
    row[5] = np.nan  # no horizon at that column
    m = _far_still(xy, row, 1.0, p)
    # 2 px: too close to the horizon; 5 px: in the band, open sea; 9 px: below the margin (the usual
    # still rule's); 6 px under a coast feature 3 px away: out; the coast feature itself: out; no horizon: out
    assert m.tolist() == [False, True, False, False, False, False]


# ------------------------------------------------------------ the open-sea check (far_open_px)
def _image(coast_x1=200, seed=3):
    """240 x 320 grey image: sky 200 above the horizon (row 100), sea 125 under it with noise; a coast's
    dark strip (105) from 4 px above to 5 px under the horizon over columns 0 .. ``coast_x1``; a far
    ship's dark hull (60) over columns 145-165, rows 97-107."""
    rng = np.random.default_rng(seed)
    img = np.full((240, 320), 200.0)
    img[100:] = 125.0
    img[100:] += rng.normal(0, 2.0, img[100:].shape)
    img[96:105, :coast_x1] = 105.0
    img[97:107, 145:166] = 60.0
    return np.clip(img, 0, 255).astype(np.uint8)


def test_far_open_mask():
    from seawatch.track.feature_clusters import _far_open

    p = _params(far_top_px=3.0, far_open_px=30.0)
    hz = Level(ROW)
    x = np.array([150.0, 160.0, 260.0, 20.0, 100.0, 215.0])
    # on the coast (coast_x1 200): 150/160 have coast on their left (120/130) and right (180/190);
    # 260 (open on both sides), 215 (right side 245 open, left 185 coast): open; 20 (left outside, right coast), 100: coast
    assert _far_open(_image(200), x, hz, 1.0, p).tolist() == [False, False, True, False, False, True]
    # no coast: every column but the image's edges is open; at x 20 the right side (50) is open
    assert _far_open(_image(0), x, hz, 1.0, p).all()
    # the window scales with the zoom: at zoom 2 the sides of 215 are 155 (the ship) and 275 (open)
    assert _far_open(_image(200), np.array([215.0, 100.0]), hz, 2.0, p).tolist() == [True, False]


def _reports_img(params, ship, coast_x1, frames=8):
    c = FeatureClusterer(params)
    hz = Level(ROW)
    out = []
    img = _image(coast_x1)
    for k in range(frames):
        dets, _ = c.update(_snap(k, ship), image=img, horizon=hz)
        out.append(dets.boxes.copy())
    return out


def test_far_ship_beside_open_sea_but_not_the_coast_foot():
    # the far ship's features (dy 5.5-7 at x 150-160) with no stable feature above the horizon: the
    # feature check alone takes them whether or not a coast runs through; the image check only on open sea
    kw = dict(grow_box=0.0, min_contrast=0.0)
    assert len(_reports_img(_params(far_top_px=3.0, **kw), SHIP, 200)[-1]) == 1  # feature check alone: the coast's foot
    assert all(len(b) == 0 for b in _reports_img(_params(far_top_px=3.0, far_open_px=30.0, **kw), SHIP, 200))
    assert len(_reports_img(_params(far_top_px=3.0, far_open_px=30.0, **kw), SHIP, 0)[-1]) == 1  # open sea
    # off when far_top_px is 0, whatever far_open_px says
    assert all(len(b) == 0 for b in _reports_img(_params(far_open_px=30.0, **kw), SHIP, 0))


def test_far_open_low_contrast_falls_back_to_the_feature_check():
    from seawatch.track.feature_clusters import _far_open

    # a thermal-like image: sky and sea alike (120 and 118), a warm band (150) along the horizon everywhere
    rng = np.random.default_rng(5)
    img = np.full((240, 320), 120.0)
    img[100:] = 118.0
    img[96:106] = 150.0
    img += rng.normal(0, 1.0, img.shape)
    img = np.clip(img, 0, 255).astype(np.uint8)
    hz = Level(ROW)
    x = np.array([150.0, 260.0, 10.0])
    p = _params(far_top_px=3.0, far_open_px=30.0)
    assert not _far_open(img, x, hz, 1.0, p).any()  # the band is not sky: never open
    p = _params(far_top_px=3.0, far_open_px=30.0, far_open_contrast=20.0)
    assert _far_open(img, x, hz, 1.0, p).tolist() == [True, True, True]  # contrast 2 < 20: open (x 10: right side)
    # with the pan-like image (sky-sea contrast 75) the contrast floor changes nothing
    assert _far_open(_image(200), x, hz, 1.0, p).tolist() == _far_open(_image(200), x, hz, 1.0,
                                                                       _params(far_top_px=3.0, far_open_px=30.0)).tolist()
