"""Session 30 (issue #8, helper h40): ``relink_side_h_clear_px``.  A boat leaving at the image's left edge is cut
to a few columns there and its box, a few px from the edge, grows tall on the water beside it (sim ``pan`` 153:
the tug's last heights before its loss were 50-54 px against its 7-13 px hull).  ``relink_side_h_ratio`` took those
heights as the boat's own and refused its 13 px new cluster at the pan's return; with the step only boxes at least
``relink_side_h_clear_px`` (x zoom) from the side edges give the heights."""

import numpy as np

from _feature_snap import COAST_BASE, dark_box_sea, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
NONE = np.zeros((0, 2))


def feats(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x0, y1], [x1, y1]]


def run(ir=False, new_at=(20, 60), **kw):
    """A boat 12 px tall clear of the left edge (x 40-52), then 6 px from it with a 70 px tall box, then at
    the edge (x 0-3), then lost; a cluster about as tall as the first boxes is born near its expected box."""
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0,
                                          "relink_appearance": False, **kw}))
    v = [[-5, 0]] * 4
    ids = [1, 2, 3, 4]
    fi = 0
    tr = None
    for x0, y0, h, n in ((40, 60, 12, 6), (6, 40, 70, 6), (0, 60, 12, 3)):
        for _ in range(n):
            _, tr = c.update(snap(feats(x0 + 1, y0 + 1, x0 + 2 if x0 == 0 else x0 + 11, y0 + h - 2), v, 0.1 * fi, fi, ids),
                             dark_box_sea(SHAPE, (x0, y0, x0 + 12, y0 + h), fi), ir=ir)
            fi += 1
    assert len(tr) == 1
    ident = int(tr.ids[0])
    for _ in range(4):
        c.update(snap(NONE, NONE, 0.1 * fi, fi, []), dark_box_sea(SHAPE, (0, 60, 1, 72), fi, boat=False), ir=ir)
        fi += 1
    assert ident in c._lost and ident in c._lost_side
    x, y = new_at
    _, tr = c.update(snap(feats(x + 1, y + 1, x + 11, y + 6), [[4, 0]] * 4, 0.1 * fi, fi, [5, 6, 7, 8]),
                     dark_box_sea(SHAPE, (x, y, x + 12, y + 8), fi), ir=ir)
    assert len(tr) == 1
    return ident, int(tr.ids[0]), c


def test_off_by_default_the_tall_edge_boxes_refuse_the_side_lost_identity():
    p = ClusterParams()
    assert p.relink_side_h_clear_px == 0.0 and p.relink_side_h_clear_ir is False
    ident, got, c = run()
    assert max(h for h, _ in c._whole_h[ident]) >= 30  # the tall boxes 6 px from the edge count
    assert got != ident


def test_relink_side_h_clear_px_keeps_only_boxes_clear_of_the_edge():
    ident, got, c = run(relink_side_h_clear_px=10.0)
    assert max(h for h, _ in c._whole_h[ident]) < 20  # only the 12 px boxes at x 40
    assert got == ident


def test_relink_side_h_clear_px_margin_below_the_boxes_changes_nothing():
    ident, got, c = run(relink_side_h_clear_px=4.0)  # the tall boxes lie 6 px from the edge: still counted
    assert got != ident


def test_relink_side_h_clear_px_off_on_infrared_unless_asked():
    ident, got, _ = run(ir=True, relink_side_h_clear_px=10.0)
    assert got != ident
    ident, got, _ = run(ir=True, relink_side_h_clear_px=10.0, relink_side_h_clear_ir=True)
    assert got == ident
