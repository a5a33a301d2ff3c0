"""Session 24 (issue #8, the switches at the session-23 defaults, helper H9):
``relink_jump_iou`` (0: off): a reported cluster whose box jumps onto an older lost identity's expected
box takes that identity (its own is lost where its box was); ``relink_side_h_up`` (0: off): an identity
lost at the image's side edge is not relinked to a cluster taller than this many times its own height;
``relink_young_s`` (0: off): a lost identity is handed over to a young cluster beside its last box;
``relink_aspect_ratio`` (0: off): a lost identity is not relinked to a box of a very different shape."""

import numpy as np

from _feature_snap import snap
from test_sf_pan23 import _run
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer


def test_defaults_since_session_24():
    d = ClusterParams()  # the lead's decision V (0: off)
    assert d.relink_jump_iou == 0.5
    assert d.relink_side_h_up == 0.0
    assert d.relink_young_s == 1.0
    assert d.relink_aspect_ratio == 6.0


# relink_jump_iou: boat 2's cluster K (older) is lost; boat 1's cluster R then jumps onto K's box
P1 = [[100, 60], [130, 70]]  # boat 1 (R's boat)
P2 = [[20, 120], [44, 130]]  # boat 2 (K's boat), far from boat 1 (more than the graph's 50 px)
OFF_J = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=10.0, coast_s=0.0,
             relink_view_px=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False, hand_over_relinked=False,
             split_follow_box=0.0, relink_min_s=0.0,
             box_wake_below_px=0.0,  # session 24's wake cut (on by default) would cut the two-point boxes
             relink_jump_iou=0.0, relink_young_s=0.0, relink_aspect_ratio=0.0,
             relink_young_after_s=0.0)  # off unless a test sets them


def _jump_run(jump_pts=P2, **kw):
    """K (features 5, 6) on boat 2 from 0 s, R (features 1, 2) on boat 1 from 0.1 s; K's features gone
    at 0.2 s (K lost); at 0.3 s features 1, 2 lie on ``jump_pts`` (R's box jumps).  Returns the identity
    reported at 0.3 s, K's and R's identities and the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF_J, **kw}))
    v = [[10.0, 0.0]] * 2
    _, t0 = c.update(snap(P2, v, 0.0, 0, ids=[5, 6]))
    k_id = int(t0.ids[0])
    _, t1 = c.update(snap(P2 + P1, v * 2, 0.1, 1, ids=[5, 6, 1, 2]))
    r_id = max(int(i) for i in t1.ids)
    assert r_id > k_id
    _, t2 = c.update(snap(P1, v, 0.2, 2, ids=[1, 2]))
    assert [int(i) for i in t2.ids] == [r_id]
    assert k_id in c._lost
    _, t3 = c.update(snap(jump_pts, v, 0.3, 3, ids=[1, 2]))
    assert len(t3) == 1
    return int(t3.ids[0]), k_id, r_id, c


def test_jump_off_is_the_old_behaviour():
    got, k_id, r_id, c = _jump_run()
    assert got == r_id  # the cluster keeps its identity on boat 2; boat 2's own stays lost
    assert k_id in c._lost and r_id not in c._lost


def test_jump_onto_a_lost_box_takes_that_identity():
    got, k_id, r_id, c = _jump_run(relink_jump_iou=0.5)
    assert got == k_id  # boat 2's identity back on boat 2
    assert k_id not in c._lost
    assert r_id in c._lost  # R lost where its box was (boat 1), for a later relink there
    lb = c._lost[r_id][1]
    assert lb[0] > 90 and lb[1] < 80


def test_jump_needs_the_overlap_and_a_jump():
    got, k_id, r_id, c = _jump_run(relink_jump_iou=1.01)
    assert got == r_id and k_id in c._lost  # overlap short of the threshold: unchanged
    near = [[x + 30, y] for x, y in P2]  # jumps, but beside K's box (no overlap)
    got, k_id, r_id, c = _jump_run(jump_pts=near, relink_jump_iou=0.5)
    assert got == r_id and k_id in c._lost
    moved = [[x + 3, y] for x, y in P1]  # no jump: the box stays on boat 1
    got, k_id, r_id, c = _jump_run(jump_pts=moved, relink_jump_iou=0.01)
    assert got == r_id and k_id in c._lost


def test_jump_never_gives_a_younger_identity():
    # the cluster on boat 2 is the older one here: it jumps onto the younger lost identity's box
    c = FeatureClusterer(ClusterParams(**{**OFF_J, "relink_jump_iou": 0.5}))
    v = [[10.0, 0.0]] * 2
    _, t0 = c.update(snap(P1, v, 0.0, 0, ids=[1, 2]))
    old_id = int(t0.ids[0])
    _, t1 = c.update(snap(P1 + P2, v * 2, 0.1, 1, ids=[1, 2, 5, 6]))
    young_id = max(int(i) for i in t1.ids)
    c.update(snap(P1, v, 0.2, 2, ids=[1, 2]))
    assert young_id in c._lost
    _, t3 = c.update(snap(P2, v, 0.3, 3, ids=[1, 2]))
    assert [int(i) for i in t3.ids] == [old_id]
    assert young_id in c._lost


# relink_side_h_up: the setup of tests/test_sf_pan23.py (two boats left at the image's left edge)
OFF_S = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=30.0, coast_s=0.0,
             relink_px=200.0, relink_iou_tie=False, relink_view_px=0.0, relink_min_area=0.0,
             relink_height_zoom_min=0.0, relink_dy_h=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False,
             hand_over_relinked=False, split_follow_box=0.0, relink_size_ratio=0.0,
             relink_side_h_ratio=3.0, relink_undo_hand_over=False,
             box_wake_below_px=0.0,  # session 24's wake cut (on by default) would cut the two-point boxes
             relink_jump_iou=0.0, relink_young_s=0.0, relink_aspect_ratio=0.0,
             relink_young_after_s=0.0)  # off unless a test sets them
NEW_LOW = [[20, 116], [30, 132]]  # a cluster about 20 px tall on the small boat's row (nearer its box)


def _side_run(new_pts, **kw):
    """tests/test_sf_pan23.py's two boats left at the image's left edge and lost; at 20 s one new
    cluster on ``new_pts``.  Returns the new cluster's identity, the small and the tall boat's
    identities, the clusterer."""
    got, s_id, t_id, c = _run(new_pts, **{**OFF_S, **kw})
    return got, s_id, t_id, c


def test_side_h_up_off_takes_the_nearer_within_the_ratio():
    got, s_id, t_id, c = _side_run(NEW_LOW)
    assert got == s_id  # 20 px against 8 px: within the ratio 3, and the small boat's box is the nearer


def test_side_h_up_refuses_a_much_taller_cluster():
    got, s_id, t_id, c = _side_run(NEW_LOW, relink_side_h_up=2.0)
    assert got == t_id  # 20 px is over twice the small boat's 8 px: the tall boat's (28 px) taken
    assert s_id in c._lost
    got, s_id, t_id, c = _side_run(NEW_LOW, relink_side_h_up=3.0)
    assert got == s_id  # a looser limit: unchanged


# relink_young_s: a boat's new cluster born beside its old one shortly before that one dies
A = [[100, 60], [120, 70]]  # the old cluster's features (box about 24 x 14 px)
OFF_Y = dict(OFF_J, relink_px=20.0)


def _young_run(gap=8.0, t_born=0.1, **kw):
    """Cluster A (features 1, 2) from 0 s; a cluster N (features 5, 6, moving otherwise, so apart in
    the graph) ``gap`` px to the right of A's box from ``t_born``; A's features gone at 0.5 s.
    Returns N's identity at 0.5 s, A's and N's own identities and the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF_Y, **kw}))
    va, vn = [[10.0, 0.0]] * 2, [[-10.0, 0.0]] * 2
    _, t0 = c.update(snap(A, va, 0.0, 0, ids=[1, 2]))
    a_id = int(t0.ids[0])
    x0 = 120 + 2 + gap + 2  # N's box starts gap px right of A's (boxes pad the features by 2 px)
    npts = [[x0, 60], [x0 + 20, 70]]
    n_id = None
    fi = 1
    for t in (0.1, 0.2, 0.3, 0.4):
        if t >= t_born - 1e-9:
            _, tr = c.update(snap(A + npts, va + vn, t, fi, ids=[1, 2, 5, 6]))
            n_id = max(int(i) for i in tr.ids)
        else:
            c.update(snap(A, va, t, fi, ids=[1, 2]))
        fi += 1
    assert n_id is not None and n_id > a_id
    _, t5 = c.update(snap(npts, vn, 0.5, fi, ids=[5, 6]))
    assert len(t5) == 1
    return int(t5.ids[0]), a_id, n_id, c


def test_young_off_keeps_the_own_identity():
    got, a_id, n_id, c = _young_run()
    assert got == n_id and a_id in c._lost  # no overlap: no hand-over; born before the loss: no relink


def test_young_cluster_beside_takes_the_lost_identity():
    got, a_id, n_id, c = _young_run(relink_young_s=1.0)
    assert got == a_id and a_id not in c._lost
    assert n_id not in c._lost  # the young identity is retired, not lost


def test_young_needs_youth_and_nearness():
    got, a_id, n_id, c = _young_run(relink_young_s=0.2)  # born 0.4 s before the loss: too old
    assert got == n_id and a_id in c._lost
    got, a_id, n_id, c = _young_run(gap=30.0, relink_young_s=1.0)  # 30 px away: beyond relink_px
    assert got == n_id and a_id in c._lost


# relink_aspect_ratio: a tall box's identity (a sailboat) and a long new box (a hull) on its place
MAST = [[100, 40], [104, 70]]  # box about 8 x 34 px (w/h 0.24)
HULL = [[96, 62], [136, 70]]  # box about 44 x 12 px (w/h 3.7), overlapping the mast's box


def _aspect_run(new_pts=HULL, **kw):
    c = FeatureClusterer(ClusterParams(**{**OFF_J, **kw}))
    v = [[10.0, 0.0]] * 2
    _, t0 = c.update(snap(MAST, v, 0.0, 0, ids=[1, 2]))
    m_id = int(t0.ids[0])
    c.update(snap(MAST, v, 0.1, 1, ids=[1, 2]))
    c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.2, 2, ids=[]))
    assert m_id in c._lost and m_id not in c._lost_side
    _, t3 = c.update(snap(new_pts, v, 0.5, 3, ids=[5, 6]))
    assert len(t3) == 1
    return int(t3.ids[0]), m_id, c


def test_aspect_off_relinks_whatever_the_shape():
    got, m_id, c = _aspect_run()
    assert got == m_id


def test_aspect_refuses_another_shape():
    got, m_id, c = _aspect_run(relink_aspect_ratio=5.0)
    assert got != m_id and m_id in c._lost  # x15: refused
    like = [[98, 44], [106, 70]]  # a box of like shape on the same place: relinked
    got, m_id, c = _aspect_run(new_pts=like, relink_aspect_ratio=5.0)
    assert got == m_id
    got, m_id, c = _aspect_run(relink_aspect_ratio=20.0)  # a looser limit
    assert got == m_id
