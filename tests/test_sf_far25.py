"""The foot of a coast not reported (issue #8, session 25 H13, ``ClusterParams.foot_open_px``; 0: off):
a cluster whose members all lie inside the water margin under the horizon, with no open sky beside
its box, is not reported.  Synthetic, seeded: the image and horizon of ``test_sf_far.py``."""

from __future__ import annotations

import numpy as np

from seawatch.detect.features import FeatureSnapshot
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _coast_foot

from test_sf_far import ROW, _image, _Level

# the coast foot's features: 4.5-7 px under the horizon (inside the 8-px margin), x 60-100
FOOT = [(60.0, 5.0), (72.0, 6.5), (85.0, 4.5), (98.0, 6.0)]


def _snap(k, pts, v=(3.0, 0.4), seed=0):
    """Frame ``k``: features at (x, dy under the horizon), all moving with velocity ``v`` (px/s, above
    the 1.5 px/s floor) plus 0.2 px/s of noise: the moving rule joins them."""
    rng = np.random.default_rng(seed + 100 * k)
    xy = np.array([(x, ROW + dy) for x, dy in pts], float)
    n = len(xy)
    hist = np.array(v, float)[None, None, :] + rng.normal(0, 0.2, (n, 4, 2))
    return FeatureSnapshot(
        t_s=0.04 * k, frame_index=k, ids=np.arange(n) + 10, slots=np.arange(n), xy=xy,
        size_px=np.full(n, 4.0), confidence=np.full(n, 6), stable=np.ones(n, bool),
        matched=np.ones(n, bool), velocity=hist[:, -1], history=hist, image_velocity=hist[:, -1],
        homography=np.eye(3), dt_s=0.04, n_keypoints=n, n_matched=n, shape=(240, 320),
    )


def _params(**kw):
    return ClusterParams(relink_s=0.0, coast_s=0.0, confirm_s=0.0, known_min_speed_px_s=0.0,
                         grow_box=0.0, min_contrast=0.0, max_aspect=0.0, **kw)


def _reports(params, pts, coast_x1, zoom=1.0, frames=6, image=True):
    c = FeatureClusterer(params)
    hz = _Level(ROW)
    img = _image(coast_x1)
    out = []
    for k in range(frames):
        dets, _ = c.update(_snap(k, pts), image=img if image else None, horizon=hz, zoom=zoom)
        out.append(dets.boxes.copy())
    return out


def test_off_by_default_and_off_reports_the_foot():
    assert ClusterParams().foot_open_px == 0.0
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
    hz = _Level(ROW)
    xy = np.array([(x, ROW + dy) for x, dy in FOOT + [(250.0, 5.0), (262.0, 6.0), (150.0, 5.0), (150.0, 20.0)]])
    k = np.array([0, 0, 0, 0, 1, 1, 2, 2])
    boxes = np.array([[58.0, 102.0, 42.0, 5.0], [248.0, 103.0, 16.0, 5.0], [148.0, 103.0, 4.0, 19.0]])
    # cluster 0 on the coast foot; cluster 1 on open sea; cluster 2 reaches 20 px under the horizon
    assert _coast_foot(xy, k, 3, boxes, np.arange(3), _image(200), hz, 1.0, p).tolist() == [True, False, False]
    # only the clusters still reported (idx) are looked at, in their order
    assert _coast_foot(xy, k, 3, boxes[[1, 0]], np.array([1, 0]), _image(200), hz, 1.0, p).tolist() == [False, True]
