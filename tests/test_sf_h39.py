"""Session 30 (issue #8, helper h39): ``relink_predict_side_s``.  A boat moving left at 40 px/s (seen through a
fixed camera model) leaves the view at the left edge and is lost there.  Its lost box, carried by the camera
only, stays at the edge with or without the step; with the step a second place for the relink moves on with
the azimuth rate fitted to its box centre's directions over the last ``relink_predict_side_win_s`` seconds
(boxes clear of the edge), not its elevation."""

import numpy as np

from _feature_snap import COAST_BASE, LinearCamera, dark_box_sea, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
NONE = np.zeros((0, 2))


def pred(c, ident):
    """The step's second place for lost identity ``ident`` now (the last frame at 2.6 s)."""
    return c._side_pred_box(ident, c._lost[ident][0], 2.6, LinearCamera())


def run(ir=False, n_after=10, x_start=60.0, **kw):
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, **kw}))
    cam = LinearCamera()
    ident = None
    for k in range(16):  # x0 from 60 down to 0 at 4 px a frame (40 px/s)
        x0 = max(x_start - 4.0 * k, 0.0)
        _, tr = c.update(snap([[x0 + 0.5, 62], [x0 + 8, 70]], [[-40, 0], [-40, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(SHAPE, (int(x0), 60, int(x0) + 12, 72), k), camera=cam, ir=ir)
        if len(tr):
            ident = int(tr.ids[0])
    k = 16
    c.update(snap(NONE, NONE, 0.1 * k, k, []), dark_box_sea(SHAPE, (0, 60, 4, 72), k, boat=False), camera=cam, ir=ir)
    assert ident in c._lost and ident in c._lost_side
    for k in range(17, 17 + n_after):
        c.update(snap(NONE, NONE, 0.1 * k, k, []), dark_box_sea(SHAPE, (0, 60, 4, 72), k, boat=False),
                 camera=cam, ir=ir)
    return ident, c


def test_off_by_default_the_side_lost_box_stays():
    p = ClusterParams()
    assert p.relink_predict_side_s == 0.0 and p.relink_predict_side_ir is False
    ident, c = run()
    x = c._lost[ident][1][0]
    assert abs(x) < 6.0, x
    assert not c._lost_fit


def test_relink_predict_side_s_moves_the_lost_box_on():
    ident, c = run(relink_predict_side_s=10.0, relink_predict_side_win_s=1.0)
    assert abs(c._lost[ident][1][0]) < 6.0  # the carried box itself is unchanged
    x, y = pred(c, ident)[:2]
    # 1.0 s lost at 40 px/s: about 40 px further left; its row kept
    assert -55.0 < x < -25.0, x
    assert abs(y - 60.0) < 4.0, y


def test_relink_predict_side_s_stops_after_its_time():
    ident, c = run(relink_predict_side_s=0.5, relink_predict_side_win_s=1.0)
    x = pred(c, ident)[0]
    assert -30.0 < x < -12.0, x  # 0.5 s of it: about 20 px


def test_relink_predict_side_s_off_on_infrared_unless_asked():
    ident, c = run(ir=True, relink_predict_side_s=10.0, relink_predict_side_win_s=1.0)
    assert ident not in c._lost_fit
    ident, c = run(ir=True, relink_predict_side_s=10.0, relink_predict_side_win_s=1.0, relink_predict_side_ir=True)
    assert pred(c, ident)[0] < -25.0


def test_relink_predict_side_s_no_fit_carried_by_the_camera_only():
    # the boat reaches the edge after 2 frames and hugs it: too few boxes clear of the edge for a fit
    ident, c = run(x_start=8.0, relink_predict_side_s=10.0, relink_predict_side_win_s=1.0)
    assert ident not in c._lost_fit
