"""Session 26 (issue #8, helper H24): boats back in view after the pan and zoom.
``coast_edge_horizon``: an edge look of a coast waiting outside the image that sees nothing at the
expected rows is tried again at rows re-estimated from the horizon (the box's bottom as far below the
horizon, times the zoom ratio, as when the coast was last seen whole in the image);
``coast_edge_horizon_contrast``: that look's contrast floor; ``coast_edge_clear``: not where another
report lies near those rows at the edge."""

import numpy as np

from _feature_snap import COAST_BASE, dark_box_sea, shift, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
HULL = (100, 60, 140, 70)  # x0, y0, x1, y1 (exclusive) of the dark hull, 40 x 10 px


class Flat:
    """A level horizon at ``row``."""

    def __init__(self, row):
        self.row = float(row)

    def row_at(self, x):
        return np.full(np.shape(np.asarray(x, np.float64)), self.row)


def run(moves, boats, dys, rows, other=None, **kw):
    """The hull seen with two features for 6 frames (horizon at row 40), then its features gone:
    each frame the camera moves the content by ``moves`` (px along x), the hull drawn (``boats``)
    ``dys`` px below its rows and the horizon at ``rows`` (a tilt the camera's motion does not give:
    the expected box keeps its rows).  ``other``: a second dark box drawn in the last frame, with
    its own features (another boat, reported).  Returns the clusterer, the hull's identity and the
    tracks of each frame after the loss."""
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, **kw}))
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[104, 63], [112, 66]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(SHAPE, HULL, k), horizon=Flat(40))
    assert len(tr) == 1
    ident = int(tr.ids[0])
    out = []
    dx = 0.0
    for j, m in enumerate(moves):
        dx += m
        fi = 6 + j
        box = (HULL[0], HULL[1] + dys[j], HULL[2], HULL[3] + dys[j])
        img = dark_box_sea(SHAPE, box, fi, dx=int(dx), boat=boats[j])
        feats = (np.zeros((0, 2)), np.zeros((0, 2)), [])
        if other is not None and j == len(moves) - 1:
            x0, y0, x1, y1 = other
            img[y0:y1, x0:x1] = np.minimum(img[y0:y1, x0:x1], 60)
            feats = ([[x0 + 2, y0 + 2], [x0 + 8, y0 + 4]], [[0, 0], [0, 0]], [7, 8])
        out.append(c.update(snap(feats[0], feats[1], 0.1 * fi, fi, feats[2], h=shift(m)), img,
                            horizon=Flat(rows[j]))[1])
    return c, ident, out


# seen in view one frame (its coast's rows remembered, 30 px below the horizon), out of view for three,
# then back 10 px into view at the left edge, 15 px below its rows: the horizon went down 15 px meanwhile
MOVES, BOATS = [0.0, -150.0, 0.0, 0.0, 20.0], [True, False, False, False, True]
DYS, ROWS = [0, 0, 0, 0, 15], [40, 40, 55, 55, 55]


def test_on_by_default_since_session_28_and_off_the_boat_below_its_rows_is_not_seen():
    p = ClusterParams()
    assert p.coast_edge_horizon is True and p.coast_edge_clear == 0.0 and p.coast_edge_horizon_contrast == 5.0
    c, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_seen=True, coast_edge_horizon=False)
    assert out[0].ids.tolist() == [ident]  # the coast saw it in view
    assert all(len(tr) == 0 for tr in out[1:])
    assert [e[3] for e in c.coast_log][-1] == "outside"


def test_the_horizon_rows_find_the_boat_with_its_identity():
    c, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_seen=True, coast_edge_horizon=True)
    assert all(len(tr) == 0 for tr in out[1:4])
    tr = out[4]
    assert tr.ids.tolist() == [ident]
    x, y, w, h = tr.boxes[0]
    assert x == 0 and abs(w - 10) <= 1.5 and abs(y - 75) <= 1 and abs(y + h - 85) <= 1
    assert [e[3] for e in c.coast_log][-1] == "edge"


def test_the_horizon_look_needs_its_contrast_floor():
    _, _, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_seen=True, coast_edge_horizon=True,
                    coast_edge_horizon_contrast=1e6)
    assert len(out[4]) == 0


def test_open_water_at_the_horizon_rows_is_not_reported():
    _, _, out = run(MOVES, [True, False, False, False, False], DYS, ROWS, coast_edge_seen=True,
                    coast_edge_horizon=True)
    assert all(len(tr) == 0 for tr in out[1:])


def test_coast_edge_clear_skips_the_look_near_another_report():
    # another boat with its own features at the left edge, just above the re-estimated rows
    other = (0, 62, 12, 70)
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, other=other, coast_edge_seen=True, coast_edge_horizon=True)
    assert ident in out[4].ids.tolist()
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, other=other, coast_edge_seen=True, coast_edge_horizon=True,
                        coast_edge_clear=1.0)
    assert ident not in out[4].ids.tolist() and len(out[4]) >= 1  # the other boat is reported
