"""Session 30 (issue #8, helper h38): ``relink_side_app_near_px``.  A dark hull cut by the image's left edge
(a 2-3 px sliver, as the sailboat on sim ``pan`` 95 at 19.8 s) is lost there; a new cluster is then born right
at its expected place, on a bright hull: its look differs from the sliver's by more than
``relink_appearance_max``, so by default it gets a new identity; with the step (the lost identity lost at the
side and expected within the gap) the look refuses nothing and it takes the lost identity."""

import numpy as np

from _feature_snap import COAST_BASE, dark_box_sea, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
HULL = (0, 60, 4, 72)  # a dark hull cut by the left edge: 4 x 12 px
NONE = np.zeros((0, 2))


def bright_box(shape, box, seed):
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, shape)
    x0, y0, x1, y1 = box
    img[y0:y1, x0:x1] = 230.0
    img[y0 + 3:y1 - 3, x0 + 3:x1 - 3] = 20.0
    return np.clip(img, 0, 255).astype(np.uint8)


def run(ir=False, new_at=(6, 62), **kw):
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0, **kw}))
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[1, 62], [3, 70]], [[-5, 0], [-5, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(SHAPE, HULL, k), ir=ir)
    assert len(tr) == 1
    ident = int(tr.ids[0])
    c.update(snap(NONE, NONE, 0.6, 6, []), dark_box_sea(SHAPE, HULL, 6, boat=False), ir=ir)
    assert ident in c._lost and ident in c._lost_side
    for k in range(7, 10):
        c.update(snap(NONE, NONE, 0.1 * k, k, []), dark_box_sea(SHAPE, HULL, k, boat=False), ir=ir)
    x, y = new_at
    box = (x - 2, y - 2, x + 16, y + 14)
    _, tr = c.update(snap([[x, y], [x + 12, y + 10]], [[4, 0], [4, 0]], 1.0, 10, [5, 6]),
                     bright_box(SHAPE, box, 10), ir=ir)
    assert len(tr) == 1
    return ident, int(tr.ids[0]), c


def test_off_by_default_the_look_refuses_the_side_lost_identity():
    p = ClusterParams()
    assert p.relink_side_app_near_px == 0.0 and p.relink_side_app_near_ir is False
    ident, got, c = run()
    assert got != ident
    assert any(r[1] == ident and r[6] for r in c.relink_log)  # refused by the look


def test_relink_side_app_near_px_takes_the_side_lost_identity():
    ident, got, _ = run(relink_side_app_near_px=30.0)
    assert got == ident


def test_relink_side_app_near_px_not_beyond_the_gap():
    # ~45 px from the expected box, inside a relink gate widened to 100 px: the look still refuses it
    ident, got, c = run(relink_side_app_near_px=30.0, new_at=(60, 62), relink_px=100.0)
    assert got != ident
    assert any(r[1] == ident and r[6] for r in c.relink_log)
    ident, got, _ = run(relink_side_app_near_px=60.0, new_at=(60, 62), relink_px=100.0)  # within 60 px: taken
    assert got == ident


def test_relink_side_app_near_px_off_on_infrared_unless_asked():
    ident, got, _ = run(ir=True, relink_side_app_near_px=30.0)
    assert got != ident
    ident, got, _ = run(ir=True, relink_side_app_near_px=30.0, relink_side_app_near_ir=True)
    assert got == ident
