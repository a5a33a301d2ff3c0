"""Session 31 (issue #8, helper h43): three refinements of ``relink_predict_side_s``'s second place (session 30,
h39).  A boat moving left at 40 px/s (11.5 deg/s through a fixed camera model of 200 px per radian) is lost at
or near the left edge; ``relink_predict_side_min_rate`` drops a fit slower than its floor,
``relink_predict_side_near_px`` gives the second place to a boat lost near (not on) the edge, and
``relink_predict_side_med_box`` builds the second place from the fit window's median box rather than the
last box (here grown tall in its last frame); ``relink_side_app_near_margin`` measures the look of h38's
near-side pair for ``relink_app_margin``."""

import numpy as np

from _feature_snap import COAST_BASE, LinearCamera, dark_box_sea, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
NONE = np.zeros((0, 2))


BASE = {"relink_predict_side_s": 10.0, "relink_predict_side_win_s": 1.0}


def run(x_start=60.0, ir=False, **kw):
    """The boat (features 8 px apart on a 12 x 12 dark box) from ``x_start`` left at 4 px a frame for 16
    frames (its box stops at x 0), then gone.  Returns its identity and the clusterer 1 s after the loss."""
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, **kw}))
    cam = LinearCamera()
    ident = None
    for k in range(16):
        x0 = max(x_start - 4.0 * k, 0.0)
        _, tr = c.update(snap([[x0 + 0.5, 62], [x0 + 8, 70]], [[-40, 0], [-40, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(SHAPE, (int(x0), 60, int(x0) + 12, 72), k), camera=cam, ir=ir)
        if len(tr):
            ident = int(tr.ids[0])
    for k in range(16, 27):
        c.update(snap(NONE, NONE, 0.1 * k, k, []), dark_box_sea(SHAPE, (0, 60, 4, 72), k, boat=False),
                 camera=cam, ir=ir)
    assert ident in c._lost
    return ident, c


def pred(c, ident):
    """The second place for lost identity ``ident`` now (the last frame at 2.6 s)."""
    return c._side_pred_box(ident, c._lost[ident][0], 2.6, LinearCamera())


def test_off_by_default():
    p = ClusterParams()
    assert p.relink_predict_side_min_rate == 0.0
    assert p.relink_predict_side_near_px == 0.0
    assert p.relink_predict_side_med_box is False
    # h39's step alone (the three off): a fit, and the second place moved about 40 px left in 1 s
    ident, c = run(**BASE)
    assert ident in c._lost_fit and not c._lost_near
    assert -55.0 < pred(c, ident)[0] < -25.0


def test_min_rate_drops_a_slow_fit():
    # the boat turns 11.5 deg/s: a floor above that drops its fit (no second place), one below keeps it
    ident, c = run(relink_predict_side_min_rate=20.0, **BASE)
    assert ident not in c._lost_fit
    ident, c = run(relink_predict_side_min_rate=5.0, **BASE)
    assert ident in c._lost_fit and abs(c._lost_fit[ident][0]) > 5.0


def test_near_px_gives_a_boat_lost_near_the_edge_its_second_place():
    # the boat's last box at x 12 (not on the edge): no second place without the step
    ident, c = run(x_start=72.0, **BASE)
    assert ident not in c._lost_side and ident not in c._lost_near
    ident, c = run(x_start=72.0, relink_predict_side_near_px=20.0, **BASE)
    assert ident in c._lost_near and ident in c._lost_fit
    x = pred(c, ident)[0]
    assert -45.0 < x < -15.0, x  # from x ~12, about 40 px further left in 1 s
    # a margin narrower than its distance from the edge changes nothing
    ident, c = run(x_start=72.0, relink_predict_side_near_px=5.0, **BASE)
    assert ident not in c._lost_near and ident not in c._lost_fit


def test_near_px_off_on_infrared_with_the_step():
    ident, c = run(x_start=72.0, ir=True, relink_predict_side_near_px=20.0, **BASE)
    assert ident not in c._lost_near and ident not in c._lost_fit


def test_med_box_second_place_from_the_median_box():
    # its last box as if grown 40 px up onto a mast: the corners' second place is as tall, the median box is not
    cam = LinearCamera()
    hs = []
    for med in (False, True):
        ident, c = run(x_start=72.0, relink_predict_side_near_px=20.0, relink_predict_side_med_box=med, **BASE)
        h0 = pred(c, ident)[3]
        az, el = cam.pixel_to_azel(np.array([10.5, 14.5]), np.array([20.0, 64.0]))  # box [10.5, 20, 4, 44]
        c._lost_dir[ident] = (az, el) + tuple(c._lost_dir[ident][2:])
        b = pred(c, ident)
        hs.append((h0, b[3]))
        assert -45.0 < b[0] < -15.0, b  # moved on by the fitted rate either way
        assert 55.0 < b[1] + 0.5 * b[3] < 70.0, b  # centred on the median elevation (the hull, row 62)
    (h_small, h_tall), (m_small, m_tall) = hs
    assert h_tall > 40.0 > 2.0 * h_small, hs  # the corners' second place takes the last box's height
    assert m_tall == m_small < 12.0, hs  # the median box does not


def test_side_app_near_margin_off_by_default_and_records_the_look():
    # h38's harness: a hull cut by the left edge lost there, a bright new cluster born at its expected place
    import test_sf_h38 as h38

    assert ClusterParams().relink_side_app_near_margin is False
    kw = {"relink_side_app_near_px": 30.0, "relink_appearance": True, "relink_app_margin": 0.2}
    ident, got, c = h38.run(**kw)
    assert got == ident  # h38's step: the look refuses nothing
    assert not any(r[1] == ident for r in c.relink_log)  # and its look is not even measured
    ident, got, c = h38.run(relink_side_app_near_margin=True, **kw)
    assert got == ident  # the only candidate: the margin drops nothing, the look still refuses nothing
    assert any(r[1] == ident for r in c.relink_log)  # its look measured, for relink_app_margin
