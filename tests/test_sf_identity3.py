"""Session 22 (issue #8, one identity per boat on ``ir``, helper H2): a lost identity is not
relinked to a new cluster whose box bottom (the waterline: the boat's range) lies far above or
below the lost box's expected bottom (``relink_dy_h``, off by default)."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

EMPTY = (np.zeros((0, 2)), np.zeros((0, 2)))
# the session-21 relink checks and session 22's defaults switched off, so that only the check
# under test acts
OFF = dict(relink_min_area=0.0, relink_area_same_zoom=False, relink_alt_s=0.0, relink_dy_h=0.0,
           relink_iou_tie=False, relink_view_px=0.0,
           box_wake_below_px=0.0)  # session 24's wake cut (on by default) would cut these two-point boxes


def test_defaults_since_session_22():
    assert ClusterParams().relink_dy_h == 1.5 and ClusterParams().relink_iou_tie is True


def _relink_to(new_xy, zoom=1.0, **kw):
    """A cluster of two features at (100, 60) and (130, 70) (a 34 x 14 px box, bottom at 72) is lost
    at 0.2 s; at 0.5 s (at ``zoom``) a cluster of two features at ``new_xy`` appears within the
    relink gate (20 px + 10 px/s * 0.3 s).  Returns (the lost identity, the new report's identity and
    box, the clusterer)."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **dict(confirm_s=0.0, relink_s=10.0, coast_s=0.0), **kw}))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap([[100, 60], [130, 70]], vel, 0.0, 0, ids=[1, 2]))
    c.update(snap([[100, 60], [130, 70]], vel, 0.1, 1, ids=[1, 2]))
    for k in range(2, 5):
        c.update(snap(*EMPTY, 0.1 * k, k, ids=[]))
    _, tr2 = c.update(snap(new_xy, vel, 0.5, 5, ids=[3, 4]), zoom=zoom)
    assert len(tr2) == 1
    return int(tr.ids[0]), int(tr2.ids[0]), tr2.boxes[0], c


LOWER = [[100, 90], [130, 92]]  # a 34 x 6 px box, bottom at 94: 22 px below, 1.57 times the taller box (14 px)
SAME_ROW = [[140, 60], [170, 70]]  # 6 px to the right, the same rows


def test_relink_refused_to_a_cluster_on_another_row():
    first, now, box, _ = _relink_to(LOWER)
    assert np.isclose(box[1] + box[3], 94.0) and np.isclose(box[3], 6.0)
    assert now == first  # off: within the gate, relinked
    first, now, _, c = _relink_to(LOWER, relink_dy_h=1.5)
    assert now != first and first in c._lost  # refused: the identity stays lost
    first, now, _, _ = _relink_to(LOWER, relink_dy_h=2.0)
    assert now == first  # 1.57 times the height: within 2


def test_relink_kept_on_the_same_row():
    first, now, _, _ = _relink_to(SAME_ROW, relink_dy_h=0.5)
    assert now == first


def test_refused_identity_goes_to_a_later_cluster_on_its_row():
    """The identity refused on the lower row is still lost and goes to a cluster on its row."""
    first, now, _, c = _relink_to(LOWER, relink_dy_h=1.5)
    assert now != first
    vel = [[20.0, 0.0]] * 2 + [[-20.0, 0.0]] * 2  # moving apart: two clusters
    _, tr = c.update(snap(LOWER + SAME_ROW, vel, 0.6, 6, ids=[3, 4, 5, 6]))
    assert first in tr.ids.tolist() and now in tr.ids.tolist()
    k = tr.ids.tolist().index(first)
    assert np.isclose(tr.boxes[k][1] + tr.boxes[k][3], 72.0)


def test_row_check_only_at_the_same_zoom():
    """``relink_dy_same_zoom``: the row check applies only when the zoom is (within 5 %) the one at
    the loss."""
    def run(zoom_now, **kw):
        return _relink_to(LOWER, zoom=zoom_now, **kw)[:2]

    first, now = run(1.04, relink_dy_h=1.5, relink_dy_same_zoom=True)
    assert now != first  # the same zoom: checked, refused
    first, now = run(2.0, relink_dy_h=1.5, relink_dy_same_zoom=True)
    assert now == first  # the zoom changed: not checked
    first, now = run(2.0, relink_dy_h=1.5)
    assert now != first  # without relink_dy_same_zoom: checked whatever the zoom


def _two_lost_one_new(**kw):
    """Two clusters lost at once: an older one A (features at (100, 60), (130, 70): box x 98-132) and
    a younger one B (at (121, 62), (150, 70): x 119-152), moving apart; then a new cluster on B's place
    overlaps both expected boxes (gap 0 to each).  Returns (A, B, the new report's identity)."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **dict(confirm_s=0.0, relink_s=10.0, coast_s=0.0,
                                                         merge_overlap=0.0, relink_overlap=0.0), **kw}))
    xy = [[100, 60], [130, 70], [121, 62], [150, 70]]
    vel = [[20.0, 0.0]] * 2 + [[-20.0, 0.0]] * 2
    for f in range(2):
        _, tr = c.update(snap(xy, vel, 0.1 * f, f, ids=[1, 2, 3, 4]))
    assert len(tr) == 2
    a, b = sorted(int(i) for i in tr.ids)
    for k in range(2, 5):
        c.update(snap(*EMPTY, 0.1 * k, k, ids=[]))
    _, tr2 = c.update(snap([[121, 62], [150, 70]], vel[2:], 0.5, 5, ids=[5, 6]))
    assert len(tr2) == 1
    return a, b, int(tr2.ids[0])


def test_iou_tie_gives_the_best_overlapping_identity():
    a, b, now = _two_lost_one_new()
    assert now == a  # off: at one gap (0) the older identity goes first
    a, b, now = _two_lost_one_new(relink_iou_tie=True)
    assert now == b  # the lost box it overlaps most


def _two_clusters_link(va, vb, **kw):
    """Two established clusters (labels 1 and 2, two features each, at velocities ``va`` and ``vb``
    px/s along x) and one link between them: is it kept by the graph's velocity gate (3 px/s)?"""
    from seawatch.track.feature_clusters import _gate_links
    lab = np.array([1, 1, 2, 2])
    vel = np.array([[va, 0.0], [va, 0.0], [vb, 0.0], [vb, 0.0]])
    keep = _gate_links(lab, vel, np.array([1]), np.array([2]), np.array([1, 2]), 3.0, clusters=True, **kw)
    return bool(keep[0])


def test_relative_gate_between_clusters():
    assert _two_clusters_link(5.9, 3.0)  # 2.9 px/s apart: within the 3 px/s gate, joined (off)
    assert not _two_clusters_link(5.9, 3.0, rel=0.4, rel_min=2.0)  # 0.49 of the faster: kept apart
    assert not _two_clusters_link(5.9, 3.0, rel=0.4, rel_min=2.5)
    assert _two_clusters_link(5.9, 3.0, rel=0.4, rel_min=3.0)  # under the floor
    assert _two_clusters_link(12.5, 10.0, rel=0.4, rel_min=2.0)  # 2.5 px/s, 0.2 of the faster: one boat
    assert _two_clusters_link(2.5, 1.0, rel=0.4, rel_min=2.0)  # 1.5 px/s: under the floor
    assert not _two_clusters_link(8.0, 3.0, rel=0.4, rel_min=2.0)  # 5 px/s: the absolute gate
    assert ClusterParams().gate_rel == 0.4 and ClusterParams().gate_rel_min_px_s == 2.0


def test_relative_gate_in_the_graph():
    """``gate_rel`` reaches the graph's step (``FeatureClusterer``'s ``AffinityClusters``)."""
    c = FeatureClusterer(ClusterParams(gate_rel=0.4, gate_rel_min_px_s=2.5))
    assert c.graph.gate_rel == 0.4 and c.graph.gate_rel_min_px_s == 2.5
    assert FeatureClusterer().graph.gate_rel == 0.4
    assert FeatureClusterer(ClusterParams(gate_rel=0.0)).graph.gate_rel == 0.0
