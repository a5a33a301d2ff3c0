"""Session 24 round 2 (issue #8, helper H12): ``relink_young_after_s`` (0: off): ``relink_young_s``'s
young cluster takes a lost identity only if it was born at least this many seconds after the lost
identity's own cluster, so two boats born together, moving apart, do not exchange identities."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

OFF = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=10.0, coast_s=0.0,
           relink_view_px=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False, hand_over_relinked=False,
           split_follow_box=0.0, relink_min_s=0.0, box_wake_below_px=0.0,
           relink_jump_iou=0.0, relink_aspect_ratio=0.0, relink_px=20.0, relink_young_s=1.0,
           relink_young_after_s=0.0)  # the step itself on by default since session 25: off unless named

A = [[100, 60], [120, 70]]  # boat A's features (box about 24 x 14 px)
N = [[132, 60], [152, 70]]  # boat N's, 8 px right of A's box, moving the other way (apart in the graph)
VA, VN = [[10.0, 0.0]] * 2, [[-10.0, 0.0]] * 2


def _run(t_born, **kw):
    """A (features 1, 2) from 0 s, N (features 5, 6) from ``t_born``; at 0.5 s only the older of the two
    clusters' features are gone.  Returns the identity reported at 0.5 s, the lost one's and the kept
    one's own identities and the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    ids = {}
    fi = 0
    for t in (0.0, 0.1, 0.2, 0.3, 0.4):
        if t >= t_born - 1e-9:
            _, tr = c.update(snap(A + N, VA + VN, t, fi, ids=[1, 2, 5, 6]))
            assert len(tr) == 2
            left = int(np.argmin(tr.boxes[:, 0]))
            ids = {"A": int(tr.ids[left]), "N": int(tr.ids[1 - left])}
        else:
            c.update(snap(A, VA, t, fi, ids=[1, 2]))
        fi += 1
    lost = min(ids, key=ids.get)  # the older identity dies (the hand-over gives only to younger ones)
    kept = "N" if lost == "A" else "A"
    pts, v, fid = (N, VN, [5, 6]) if lost == "A" else (A, VA, [1, 2])
    _, t5 = c.update(snap(pts, v, 0.5, fi, ids=fid))
    assert len(t5) == 1
    return int(t5.ids[0]), ids[lost], ids[kept], c


def test_on_since_session_25():
    assert ClusterParams().relink_young_after_s == 1.0


def test_born_together_young_alone_swaps_and_the_new_step_keeps_each_its_own():
    # the lead's finding: both born at 0 s, so the survivor counts as young and takes the lost identity
    got, lost_id, kept_id, c = _run(0.0)
    assert got == lost_id and lost_id not in c._lost
    got, lost_id, kept_id, c = _run(0.0, relink_young_after_s=0.3)
    assert got == kept_id and lost_id in c._lost


def test_born_after_the_lost_one_still_takes_it():
    # N born 0.3 s after A (a boat's new cluster beside its old one): the relink still happens
    got, lost_id, kept_id, c = _run(0.3, relink_young_after_s=0.2)
    assert lost_id < kept_id
    assert got == lost_id and lost_id not in c._lost and kept_id not in c._lost
    # ... unless the step asks for more than the 0.3 s between the births
    got, lost_id, kept_id, c = _run(0.3, relink_young_after_s=0.5)
    assert got == kept_id and lost_id in c._lost


def test_young_off_makes_the_new_step_inert():
    got, lost_id, kept_id, c = _run(0.0, relink_young_s=0.0, relink_young_after_s=0.3)
    assert got == kept_id and lost_id in c._lost


# relink_own_speed_k: a slow boat's relink gate grows with its own speed (session 24, H12)
def _slow_run(gap, **kw):
    """A slow cluster (3 px/s) from 0 s, lost at 0.5 s; a new cluster ``gap`` px right of its box at 2.5 s
    (lost 2.0 s: the default gate 20 + 10 x 2 = 40 px, the own-speed gate 20 + max(2, 1 x 3) x 2 = 26 px).
    Returns the identity reported at 2.5 s and the slow one's."""
    c = FeatureClusterer(ClusterParams(**{**OFF, "relink_young_s": 0.0, **kw}))
    v = [[3.0, 0.0]] * 2
    a_id = None
    for fi, t in enumerate((0.0, 0.1, 0.2, 0.3, 0.4)):
        _, tr = c.update(snap(A, v, t, fi, ids=[1, 2]))
        a_id = int(tr.ids[0])
    c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.5, 5, []))
    x0 = 120 + 2 + gap + 2
    pts = [[x0, 60], [x0 + 20, 70]]
    _, tr = c.update(snap(pts, v, 2.5, 6, ids=[7, 8]))
    assert len(tr) == 1
    return int(tr.ids[0]), a_id


def test_own_speed_off_by_default_and_the_default_gate_relinks_at_30_px():
    assert ClusterParams().relink_own_speed_k == 0.0
    got, a_id = _slow_run(30.0)
    assert got == a_id


def test_own_speed_gate_refuses_a_slow_boats_far_cluster_and_keeps_a_near_one():
    got, a_id = _slow_run(30.0, relink_own_speed_k=1.0, relink_own_speed_floor=2.0)
    assert got != a_id
    got, a_id = _slow_run(16.0, relink_own_speed_k=1.0, relink_own_speed_floor=2.0)
    assert got == a_id
