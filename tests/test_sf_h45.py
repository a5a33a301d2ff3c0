"""Session 31 (issue #8, helper h45): two guards on session 30's side steps (``pan`` 175-206).
``relink_side_app_near_alone_px`` withholds h38's near-side look exemption from a new cluster beside a boat in
view (a not-new cluster, or a box reported in the last frame); ``relink_side_h_clear_either`` makes h40's
height margin only add pairs (the heights 1 px clear of the edges still pass)."""

import numpy as np

from _feature_snap import COAST_BASE, dark_box_sea, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
NONE = np.zeros((0, 2))


def test_off_by_default():
    p = ClusterParams()
    assert p.relink_side_app_near_alone_px == 0.0
    assert p.relink_side_h_clear_either is False


def test_beside_old_geometry():
    b = np.array([176.0, 303.0, 21.0, 25.0])
    mast = np.array([[157.0, 272.0, 17.0, 58.0]])  # pan 179: 2 px to the left
    far = np.array([[400.0, 300.0, 20.0, 20.0]])
    assert FeatureClusterer._beside_old(b, mast, 5.0)
    assert not FeatureClusterer._beside_old(b, mast, 1.0)
    assert not FeatureClusterer._beside_old(b, far, 5.0)
    assert not FeatureClusterer._beside_old(b, np.zeros((0, 4)), 5.0)


def run(**kw):
    """A boat (features 8 px apart on a 12 x 12 dark box) from x 60 left at 4 px a frame to the left edge."""
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, **kw}))
    ident = None
    for k in range(16):
        x0 = max(60.0 - 4.0 * k, 0.0)
        _, tr = c.update(snap([[x0 + 0.5, 62], [x0 + 8, 70]], [[-40, 0], [-40, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(SHAPE, (int(x0), 60, int(x0) + 12, 72), k))
        if len(tr):
            ident = int(tr.ids[0])
    return ident, c


def test_either_keeps_the_near_edge_heights():
    base = {"relink_side_h_ratio": 3.0, "relink_side_h_clear_px": 15.0}
    ident, c = run(**base)
    assert ident is not None and c._whole_h.get(ident) and not c._whole_h1  # off: no second history
    ident2, c2 = run(**base, relink_side_h_clear_either=True)
    assert ident2 == ident
    assert len(c2._whole_h1.get(ident2, [])) >= len(c2._whole_h.get(ident2, []))
    assert c2._whole_h[ident2] == c._whole_h[ident]  # the margin's history unchanged


def test_side_h_ok_either():
    c = FeatureClusterer(ClusterParams(relink_side_h_ratio=3.0))
    c._zoom = 1.0
    tall = [(75.0, 1.0)] * 5  # pan 193: heights grown before the loss
    short = [(30.0, 1.0)] * 5
    assert not c._side_h_ok(tall, 20.0)
    assert c._side_h_ok(short, 20.0)
