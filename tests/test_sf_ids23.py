"""Session 23 (issue #8, the switches left, helper H3): ``relink_dy_px_per_s`` (on by default since
session 23, with the other fields here; the runs below start from all four off) lets
the row check of ``relink_dy_h`` grow with the time lost, on top of the smaller box's slack; with
``relink_dy_side`` only for identities lost with their last box at the image's left or right edge
(the rib on ``pan``, left behind by the pan at 10 s and back 40-50 px higher at 35 s)."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

EMPTY = (np.zeros((0, 2)), np.zeros((0, 2)))
# the other relink checks off except the row check (relink_dy_h 1.5, the default); a wide gate
OFF = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=30.0, coast_s=0.0,
           relink_px=200.0, relink_iou_tie=False, relink_view_px=0.0, relink_min_area=0.0,
           relink_height_zoom_min=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False, hand_over_relinked=False, split_follow_box=0.0)
EDGE = [[0, 60], [24, 66]]  # a boat at the image's left edge (its box starts at x = 0)
MID = [[100, 60], [124, 66]]  # the same boat inside the image
HIGHER = [[140, 35], [164, 41]]  # a cluster like it, 25 px higher (its waterline's row)
W = 240  # the test snapshots' image width


def _run(lost_pts, new_pts, t_new, **kw):
    """A cluster on ``lost_pts`` is lost at 0.2 s; at ``t_new`` one new cluster appears on
    ``new_pts``.  Returns whether it took the lost identity, and the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap(lost_pts, vel, 0.0, 0, ids=[1, 2]))
    c.update(snap(lost_pts, vel, 0.1, 1, ids=[1, 2]))
    fi = 2
    for t in (0.2, 0.3, 0.4, t_new - 0.2, t_new - 0.1):
        c.update(snap(*EMPTY, t, fi, ids=[]))
        fi += 1
    first = int(tr.ids[0])
    assert first in c._lost
    _, tr2 = c.update(snap(new_pts, vel, t_new, fi, ids=[3, 4]))
    assert len(tr2) == 1
    return int(tr2.ids[0]) == first, c


def _bottom_gap(a, b):
    return abs(max(p[1] for p in a) - max(p[1] for p in b))


def test_defaults_and_off_is_the_old_behaviour():
    p = ClusterParams()
    assert (p.relink_dy_px_per_s, p.relink_dy_side, p.relink_dy_h) == (1.2, True, 1.5)
    assert (p.hand_over_relinked, p.split_follow_box) == (True, 0.5)
    assert _bottom_gap(EDGE, HIGHER) == 25
    took, c = _run(EDGE, HIGHER, 20.0)
    assert not took and len(c._lost) == 1  # 25 px off the row: refused by relink_dy_h, still lost
    took, _ = _run(EDGE, [[140, 58], [164, 64]], 20.0)
    assert took  # on the row (2 px): relinked


def test_row_gate_grows_with_the_time_lost():
    took, _ = _run(EDGE, HIGHER, 20.0, relink_dy_px_per_s=1.2)
    assert took  # 1.5 x h + 1.2 px/s x 19.8 s > 25 px
    took, c = _run(EDGE, HIGHER, 2.0, relink_dy_px_per_s=1.2)
    assert not took and len(c._lost) == 1  # lost 1.8 s: 2 px more only
    took, _ = _run(EDGE, HIGHER, 20.0, relink_dy_px_per_s=0.3)
    assert not took  # a slower drift: 6 px more only


def test_side_only():
    took, c = _run(EDGE, HIGHER, 20.0, relink_dy_px_per_s=1.2, relink_dy_side=True)
    assert took  # lost at the image's left edge
    took, c = _run(MID, HIGHER, 20.0, relink_dy_px_per_s=1.2, relink_dy_side=True)
    assert not took and len(c._lost) == 1 and not c._lost_side  # lost inside the image: strict check
    took, _ = _run(MID, HIGHER, 20.0, relink_dy_px_per_s=1.2)
    assert took  # without relink_dy_side every lost identity gets the drift
    right = [[W - 1 - x, y] for x, y in EDGE]  # at the right edge
    took, c = _run(right, [[60, 35], [84, 41]], 20.0, relink_dy_px_per_s=1.2, relink_dy_side=True)
    assert took


def test_zoom_scales_the_drift():
    """The drift is in pixels per second times the zoom now (a boat's move is an angle)."""
    c = FeatureClusterer(ClusterParams(**{**OFF, "relink_dy_px_per_s": 0.4}))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap(EDGE, vel, 0.0, 0, ids=[1, 2]))
    c.update(snap(EDGE, vel, 0.1, 1, ids=[1, 2]))
    for k, t in enumerate((0.2, 19.8, 19.9)):
        c.update(snap(*EMPTY, t, 2 + k, ids=[]), zoom=2.0)
    _, tr2 = c.update(snap(HIGHER, vel, 20.0, 5, ids=[3, 4]), zoom=2.0)
    assert int(tr2.ids[0]) == int(tr.ids[0])  # 0.4 x 19.8 x 2 + 1.5 x 10 = 31 > 25 px (at zoom 1: 23)
    took, _ = _run(EDGE, HIGHER, 20.0, relink_dy_px_per_s=0.4)
    assert not took


def test_a_tall_carried_box_keeps_its_own_limit_only():
    """The drift adds to the smaller box's slack: a tall lost box (1.5 x its height already far more
    than the drift) does not get the drift on top of its own limit."""
    tall = [[0, 30], [24, 66]]  # 40 px tall, at the left edge
    low = [[140, 116], [164, 122]]  # its bottom 56 px below the tall box's: within 1.5 x 40 = 60
    took, _ = _run(tall, low, 20.0)
    assert took  # 56 <= 1.5 x 40 (the old limit, unchanged)
    lower = [[140, 130], [164, 136]]  # 70 px below: over the old limit 60
    took, _ = _run(tall, lower, 20.0, relink_dy_px_per_s=0.6)
    assert not took  # 1.5 x 10 + 0.6 x 19.8 = 27 < 60: the old limit stays the limit
    took, _ = _run(tall, lower, 20.0, relink_dy_px_per_s=3.0)
    assert took  # 1.5 x 10 + 3 x 19.8 = 74 > 70


# hand_over_relinked: an older identity lost in the frame where a new cluster on its boat took a
# younger identity by a relink
A = [[100, 60], [130, 70]]  # the boat's cluster (the older identity)
F = [[100, 90], [104, 94]]  # a fragment moving otherwise (a younger identity), lost before A
N = [[102, 62], [128, 72]]  # a new cluster on the boat, born in the frame where A's cluster dies
OFF2 = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=10.0, coast_s=0.0,
            relink_dy_h=0.0, relink_view_px=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False, hand_over_relinked=False, split_follow_box=0.0)


def _hand_over_run(**kw):
    c = FeatureClusterer(ClusterParams(**{**OFF2, **kw}))
    va, vf = [[20.0, 0.0]] * 2, [[-20.0, 0.0]] * 2
    _, t0 = c.update(snap(A, va, 0.0, 0, ids=[1, 2]))
    a_id = int(t0.ids[0])
    _, t1 = c.update(snap(A + F, va + vf, 0.1, 1, ids=[1, 2, 3, 4]))
    assert len(t1) == 2
    f_id = max(int(x) for x in t1.ids)
    assert f_id > a_id
    for k in (2, 3, 4):  # the fragment is lost
        _, tk = c.update(snap(A, va, 0.1 * k, k, ids=[1, 2]))
        assert [int(x) for x in tk.ids] == [a_id]
    assert f_id in c._lost
    _, t5 = c.update(snap(N, va, 0.5, 5, ids=[5, 6]))  # A's cluster gone, N born on the boat
    assert len(t5) == 1
    return int(t5.ids[0]), a_id, f_id, c


def test_hand_over_relinked_off_is_the_old_behaviour():
    got, a_id, f_id, c = _hand_over_run()
    assert got == f_id  # relinked to the fragment's younger identity; the boat's own is lost
    assert a_id in c._lost and f_id not in c._lost


def test_hand_over_relinked_keeps_the_older_identity():
    got, a_id, f_id, c = _hand_over_run(hand_over_relinked=True)
    assert got == a_id  # the older identity stays on the boat
    assert f_id in c._lost and a_id not in c._lost  # the younger one is lost again, as before the relink
    assert c._lost[f_id][0] == pytest.approx(0.2)  # with its time of loss kept


# split_follow_box: a cluster's box jumps onto another boat while a new cluster is born on its box
P1 = [[100, 60], [130, 70]]  # boat 1 (the identity's boat)
P2 = [[20, 120], [44, 130]]  # boat 2, far from boat 1 (more than the graph's 50 px)
OFF3 = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=10.0, coast_s=0.0,
            relink_view_px=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False, hand_over_relinked=False, split_follow_box=0.0)


def _jump_run(with_y, **kw):
    """Cluster X (features 1, 2) on boat 1 from 0 s; with ``with_y`` a younger cluster Y (features 5,
    6) on boat 2 from 0.1 s.  At 0.3 s features 1, 2 lie on boat 2 (X's box jumps; Y's features are
    gone) and new features 3, 4 on boat 1.  Returns the identities reported on boat 1 and boat 2
    at 0.3 s, and X's and Y's identities."""
    c = FeatureClusterer(ClusterParams(**{**OFF3, **kw}))
    v = [[10.0, 0.0]] * 2
    _, t0 = c.update(snap(P1, v, 0.0, 0, ids=[1, 2]))
    x_id = int(t0.ids[0])
    pts, ids = (P1 + P2, [1, 2, 5, 6]) if with_y else (P1, [1, 2])
    _, t1 = c.update(snap(pts, v * (len(ids) // 2), 0.1, 1, ids=ids))
    y_id = max(int(i) for i in t1.ids) if with_y else None
    c.update(snap(pts, v * (len(ids) // 2), 0.2, 2, ids=ids))
    _, t3 = c.update(snap(P2 + P1, v * 2, 0.3, 3, ids=[1, 2, 3, 4]))
    assert len(t3) == 2
    on = {}
    for i, b in zip(t3.ids, t3.boxes):
        on[1 if b[0] > 70 else 2] = int(i)
    return on, x_id, y_id, c


def test_split_follow_box_off_is_the_old_behaviour():
    on, x_id, _, _ = _jump_run(False)
    assert on[2] == x_id and on[1] != x_id  # the identity goes with the features (the paper's rule)


def test_split_follow_box_keeps_the_identity_on_its_box():
    on, x_id, _, c = _jump_run(False, split_follow_box=0.5)
    assert on[1] == x_id  # the new cluster on boat 1 takes it
    assert on[2] != x_id and on[2] > x_id and on[2] in c._swapped  # the jumped cluster: a new identity
    on, x_id, _, _ = _jump_run(False, split_follow_box=1.01)
    assert on[2] == x_id  # no new cluster overlapping enough: unchanged


def test_split_follow_box_jumped_cluster_takes_the_lost_identity_on_its_box():
    on, x_id, y_id, c = _jump_run(True)
    assert on[2] == x_id and y_id in c._lost  # off: boat 2 gets X's identity, Y's is lost
    on, x_id, y_id, c = _jump_run(True, split_follow_box=0.5)
    assert on == {1: x_id, 2: y_id}  # each boat keeps its identity (Y handed over to the jumped cluster)
    assert y_id not in c._lost
