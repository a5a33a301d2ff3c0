"""Session 27 (issue #8, helper h30): ``edge_min_w_px``.  A box that touches the image's left or right
edge and is clipped there to under that width (its members have left the view) is not reported, so its
identity is lost with its last whole box and its appearance signature, not with a sliver ``[0, y, 0, h]``
(whose look is unknown, so a relink 25 s later skips the appearance check).  The scene: a dark hull seen
with two features for 6 frames, then the pan carries it out of the left edge while its two features are
still tracked just outside the image (x < 0), then they are gone."""

import numpy as np

from _feature_snap import COAST_BASE, dark_box_sea, shift, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
HULL = (4, 60, 44, 70)  # x0, y0, x1, y1 (exclusive): 40 x 10 px near the left edge


def run(**kw):
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, **kw}))
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[12, 63], [24, 66]], [[-5, 0], [-5, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(SHAPE, HULL, k))
    assert len(tr) == 1
    ident = int(tr.ids[0])
    # the pan moves the content 60 px left: the hull is out of view, its features tracked at x < 0
    _, edge = c.update(snap([[-48, 63], [-36, 66]], [[-5, 0], [-5, 0]], 0.6, 6, [1, 2], h=shift(-60)),
                       dark_box_sea(SHAPE, HULL, 6, dx=-60))
    # then the features are gone
    _, after = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.7, 7, [], h=shift(0)),
                        dark_box_sea(SHAPE, HULL, 7, dx=-60))
    return c, ident, edge, after


def test_off_by_default_the_sliver_is_reported_and_the_identity_lost_with_it():
    assert ClusterParams().edge_min_w_px == 0.0
    c, ident, edge, _ = run()
    assert edge.ids.tolist() == [ident]
    x, y, w, h = edge.boxes[0]
    assert x == 0 and w < 2  # the sliver at the left edge
    lb = c._lost[ident][1]
    assert lb[2] < 2  # lost with the sliver's zero width
    assert c._lost_sig.get(ident) is None  # and no look to check a relink against


def test_edge_min_w_px_drops_the_sliver_and_keeps_the_whole_box_and_its_look():
    c, ident, edge, _ = run(edge_min_w_px=2.0)
    assert ident not in edge.ids.tolist()
    lb = c._lost[ident][1]
    assert lb[2] > 20 and abs(lb[3] - 10) <= 4  # the last whole box (40 x 10), carried by the pan
    assert c._lost_sig.get(ident) is not None


def test_a_narrow_box_inside_the_image_is_still_reported():
    # two features well inside the image: a 4 px wide box, under edge_min_w_px 5 but not at an edge
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "edge_min_w_px": 5.0, "grow_box": 0.0}))
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[120, 60], [120.5, 68]], [[-5, 0], [-5, 0]], 0.1 * k, k, [1, 2]), None)
    assert len(tr) == 1 and tr.boxes[0][2] < 5


# relink_app_margin: two boats lost together; a new cluster is born nearer the one it does not look like


def _two_lost(monkeypatch, dc, full_log=False, **kw):
    """Boats A (features at x 85-93) and B (x 120-128) reported for 6 frames, both lost in frame 6, and a new
    cluster born in frame 7 at x 108-116: nearer B's box (gap ~2 px) than A's (~11 px), both in the gate.
    ``dc``: the appearance distance the relink's look check gives each lost identity (A, B)."""
    def looks(self, k, i, cids, boxes, t, sig_new):
        d = dc[0] if k == ids["A"] else dc[1]
        self.relink_log.append((t, int(k), int(cids[i]), boxes[i].copy(), d, 0.0, d > 1.4))
        return d <= 1.4

    monkeypatch.setattr(FeatureClusterer, "_looks_alike", looks)
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, **kw}))
    if full_log:  # a long live run: the bounded look log is already full
        old = (0.0, 0, 0, np.zeros(4), 0.0, 0.0, False)
        c.relink_log.extend([old] * c.relink_log.maxlen)
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[85, 63], [93, 66], [120, 63], [128, 66]], [[5, 0], [5, 0], [-5, 0], [-5, 0]],
                              0.1 * k, k, [1, 2, 3, 4]), None)
    assert len(tr) == 2
    order = np.argsort(tr.boxes[:, 0])
    ids = {"A": int(tr.ids[order[0]]), "B": int(tr.ids[order[1]])}
    c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.6, 6, []), None)
    _, tr = c.update(snap([[108, 63], [116, 66]], [[3, 0], [3, 0]], 0.7, 7, [5, 6]), None)
    born = [int(r) for r, b in zip(tr.ids, tr.boxes) if b[0] > 100 and b[0] < 115]
    return ids, born


def test_relink_app_margin_on_by_default_and_off_the_nearer_lost_identity_is_taken(monkeypatch):
    p = ClusterParams()
    assert p.relink_app_margin == 0.5 and p.relink_app_margin_ir is False  # since session 28
    ids, born = _two_lost(monkeypatch, (0.1, 0.9), relink_app_margin=0.0)
    assert born == [ids["B"]]


def test_relink_app_margin_the_better_looking_lost_identity_is_taken(monkeypatch):
    ids, born = _two_lost(monkeypatch, (0.1, 0.9), relink_app_margin=0.5)
    assert born == [ids["A"]]
    ids, born = _two_lost(monkeypatch, (0.5, 0.9), relink_app_margin=0.5)  # within the margin: the nearer
    assert born == [ids["B"]]


def test_relink_app_margin_still_acts_once_the_look_log_is_full(monkeypatch):
    # the log keeps the last 1000 looks; the margin must not stop acting when its length stops growing
    ids, born = _two_lost(monkeypatch, (0.1, 0.9), full_log=True, relink_app_margin=0.5)
    assert born == [ids["A"]]
    ids, born = _two_lost(monkeypatch, (0.5, 0.9), full_log=True, relink_app_margin=0.5)
    assert born == [ids["B"]]
