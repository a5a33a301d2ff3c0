"""The foot of a coast not reported (issue #8, session 25 H13, ``ClusterParams.foot_open_px``; 0: off):
a cluster whose members all lie inside the water margin under the horizon, with no open sky beside
its box, is not reported.  Synthetic, seeded: the image and horizon of ``test_sf_far.py``."""

from __future__ import annotations

import numpy as np

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _coast_foot

from _feature_snap import Level
from test_sf_far import ROW, _image, stable_snap

# the coast foot's features: 4.5-7 px under the horizon (inside the 8-px margin), x 60-100
FOOT = [(60.0, 5.0), (72.0, 6.5), (85.0, 4.5), (98.0, 6.0)]


def _snap(k, pts, v=(3.0, 0.4), seed=0):
    """Frame ``k``: features at (x, dy under the horizon), all moving with velocity ``v`` (px/s, above
    the 1.5 px/s floor) plus 0.2 px/s of noise: the moving rule joins them."""
    rng = np.random.default_rng(seed + 100 * k)
    xy = np.array([(x, ROW + dy) for x, dy in pts], float)
    return stable_snap(k, xy, np.array(v, float)[None, None, :] + rng.normal(0, 0.2, (len(xy), 4, 2)))


def _params(**kw):
    """The step off unless named (on by default since session 25)."""
    kw = {"foot_open_px": 0.0, "foot_dark": 0.0, **kw}
    return ClusterParams(relink_s=0.0, coast_s=0.0, confirm_s=0.0, known_min_speed_px_s=0.0,
                         grow_box=0.0, min_contrast=0.0, max_aspect=0.0, **kw)


def _reports(params, pts, coast_x1, zoom=1.0, frames=6, image=True):
    c = FeatureClusterer(params)
    hz = Level(ROW)
    img = _image(coast_x1)
    out = []
    for k in range(frames):
        dets, _ = c.update(_snap(k, pts), image=img if image else None, horizon=hz, zoom=zoom)
        out.append(dets.boxes.copy())
    return out


def test_on_since_session_25_and_off_reports_the_foot():
    assert ClusterParams().foot_open_px == 10.0 and ClusterParams().foot_dark == 8.0
    # off: the coast foot's moving cluster is reported (the clutter this step removes)
    assert len(_reports(_params(), FOOT, 200)[-1]) == 1


def test_coast_foot_not_reported():
    assert all(len(b) == 0 for b in _reports(_params(foot_open_px=10.0), FOOT, 200))


def test_open_sea_beside_is_reported():
    # no coast: sky down to the horizon beside the box, a far boat: reported
    assert len(_reports(_params(foot_open_px=10.0), FOOT, 0)[-1]) == 1
    # the coast ends at x 110: 10 px right of the box's right edge (98 + half a feature) lies on it,
    # 30 px right of it (129) is open sea
    assert len(_reports(_params(foot_open_px=10.0), FOOT, 110)[-1]) == 0
    assert len(_reports(_params(foot_open_px=30.0), FOOT, 110)[-1]) == 1


def test_cluster_reaching_below_the_margin_is_reported():
    # one member 12 px under the horizon (below the 8-px margin): a boat reaching into the water
    pts = FOOT + [(80.0, 12.0)]
    assert len(_reports(_params(foot_open_px=10.0), pts, 200)[-1]) == 1
    # at zoom 2 the margin is 16 px: the same cluster lies inside it and is the coast's foot
    assert all(len(b) == 0 for b in _reports(_params(foot_open_px=10.0), pts, 200, zoom=2.0))


def test_without_an_image_nothing_changes():
    assert len(_reports(_params(foot_open_px=10.0), FOOT, 200, image=False)[-1]) == 1


def test_coast_foot_mask():
    p = _params(foot_open_px=10.0)
    hz = Level(ROW)
    xy = np.array([(x, ROW + dy) for x, dy in FOOT + [(250.0, 5.0), (262.0, 6.0), (150.0, 5.0), (150.0, 20.0)]])
    k = np.array([0, 0, 0, 0, 1, 1, 2, 2])
    boxes = np.array([[58.0, 102.0, 42.0, 5.0], [248.0, 103.0, 16.0, 5.0], [148.0, 103.0, 4.0, 19.0]])
    # cluster 0 on the coast foot; cluster 1 on open sea; cluster 2 reaches 20 px under the horizon
    assert _coast_foot(xy, k, 3, boxes, np.arange(3), _image(200), hz, 1.0, p).tolist() == [True, False, False]
    # only the clusters still reported (idx) are looked at, in their order
    assert _coast_foot(xy, k, 3, boxes[[1, 0]], np.array([1, 0]), _image(200), hz, 1.0, p).tolist() == [False, True]


def _under_image(strip_x1=200, sky=200.0, sea=125.0, seed=4):
    """240 x 320 grey image: sky down to the horizon (row 100), sea under it; a dark strip (105) wholly
    under the horizon, rows 101-104, over columns 0 .. ``strip_x1`` (the coast's foot with the sky
    reaching down to the horizon's row above it)."""
    rng = np.random.default_rng(seed)
    img = np.full((240, 320), sky)
    img[100:] = sea
    img[100:] += rng.normal(0, 2.0, img[100:].shape)
    img[101:105, :strip_x1] = sea - 20.0
    return np.clip(img, 0, 255).astype(np.uint8)


def _reports_on(params, pts, img, frames=6):
    c = FeatureClusterer(params)
    hz = Level(ROW)
    return [c.update(_snap(k, pts), image=img, horizon=hz)[0].boxes.copy() for k in range(frames)]


def test_foot_dark_strip_under_the_horizon():
    img = _under_image(200)
    # the sky reaches down to the horizon's row: the side test alone sees open sea and keeps the report
    assert len(_reports_on(_params(foot_open_px=10.0), FOOT, img)[-1]) == 1
    # the dark strip under the horizon on both sides: the coast's foot, not reported
    assert all(len(b) == 0 for b in _reports_on(_params(foot_open_px=10.0, foot_dark=8.0), FOOT, img))
    # foot_dark without foot_open_px does nothing
    assert len(_reports_on(_params(foot_dark=8.0), FOOT, img)[-1]) == 1


def test_foot_dark_open_sea_and_thermal_kept():
    # open sea beside (no strip): reported
    assert len(_reports_on(_params(foot_open_px=10.0, foot_dark=8.0), FOOT, _under_image(0))[-1]) == 1
    # the strip ends at x 110: the right side (10 px past the box) lies on it, 30 px past it is open
    assert len(_reports_on(_params(foot_open_px=10.0, foot_dark=8.0), FOOT, _under_image(110))[-1]) == 0
    assert len(_reports_on(_params(foot_open_px=30.0, foot_dark=8.0), FOOT, _under_image(110))[-1]) == 1
    # a thermal-like image (sky 120, sea 118: contrast under far_open_contrast 20): never the coast's foot
    th = _under_image(200, sky=120.0, sea=118.0)
    assert len(_reports_on(_params(foot_open_px=10.0, foot_dark=8.0, far_open_contrast=20.0), FOOT, th)[-1]) == 1


def test_under_dark_mask():
    from seawatch.track.feature_clusters import _under_dark

    p = _params(foot_open_px=10.0, foot_dark=8.0)
    hz = Level(ROW)
    x = np.array([50.0, 250.0, 1.0, 150.0])
    # 50 and 150 on the strip, 250 open sea, 1 outside the image
    assert _under_dark(_under_image(200), x, hz, 1.0, p, 8.0).tolist() == [True, False, False, True]
    # a threshold above the strip's 20 grey levels: nothing is dark
    assert not _under_dark(_under_image(200), x, hz, 1.0, p, 25.0).any()


def test_coast_foot_dark_batch_matches_one_cluster_at_a_time():
    """Session 28: with ``foot_dark`` the sides of every candidate are tested in one call; each
    cluster's answer is the one it gets alone (the tests work column by column)."""
    p = _params(foot_open_px=10.0, foot_dark=8.0)
    hz = Level(ROW)
    xy = np.array([(x, ROW + dy) for x, dy in FOOT + [(250.0, 5.0), (262.0, 6.0), (150.0, 5.0), (150.0, 20.0),
                                                    (140.0, 4.0), (156.0, 5.0)]])
    k = np.array([0, 0, 0, 0, 1, 1, 2, 2, 3, 3])
    boxes = np.array([[58.0, 102.0, 42.0, 5.0], [248.0, 103.0, 16.0, 5.0], [148.0, 103.0, 4.0, 19.0],
                      [138.0, 102.0, 20.0, 5.0]])
    for strip in (200, 110, 0):
        img = _under_image(strip)
        both = _coast_foot(xy, k, 4, boxes, np.arange(4), img, hz, 1.0, p)
        alone = [bool(_coast_foot(xy, k, 4, boxes[[i]], np.array([i]), img, hz, 1.0, p)[0]) for i in range(4)]
        assert both.tolist() == alone
        if strip == 200:  # the foot and the cluster on the strip (sides 128, 168); open sea, deep cluster reported
            assert both.tolist() == [True, False, False, True]
        if strip == 110:  # the strip ends at x 110: cluster 3's sides are open sea now
            assert both.tolist() == [True, False, False, False]
        if strip == 0:
            assert not both.any()
