"""Session 27 (issue #8, helper h29: two identities on one boat during a fast pan):
``lost_dup_iou`` (0: off) with ``lost_dup_age_s``: a young lost identity (first seen less than
``lost_dup_age_s`` before its loss, after an older identity was lost) whose box overlaps that older
lost identity's expected box is retired into it; ``relink_area_at_loss`` (False: off):
``relink_min_area`` compares with the smaller of the expected box and the box at the loss;
``relink_retry_s`` (0: off): a young cluster under its own identity is offered the lost identities again.
All three on by default since session 28 (0.3, True, 1 s; visible frames only): ``OFF`` names them off."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

PA = [[100, 60], [130, 70]]  # the boat's first cluster A
PB = [[112, 62], [136, 72]]  # its young cluster B (and later C): overlaps A's box
PD = [[20, 120], [44, 130]]  # another boat far away (keeps the frames non-empty)
V = [[10.0, 0.0]] * 2
VB = [[-10.0, 0.0]] * 2  # the young cluster of the retry tests (apart from A while both are seen)
OFF = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.4, relink_s=10.0, coast_s=0.0,
           relink_view_px=0.0, relink_dy_h=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False,
           hand_over_relinked=False, split_follow_box=0.0, relink_min_s=0.0, relink_overlap=0.0,
           box_wake_below_px=0.0, relink_jump_iou=0.0, relink_young_s=0.0, relink_aspect_ratio=0.0,
           relink_young_after_s=0.0, relink_min_area=0.0, relink_height_zoom_min=0.0, relink_iou_tie=True,
           relink_side_h_ratio=0.0,
           # on by default since session 28; named off here: the tests turn on the step they measure
           lost_dup_iou=0.0, relink_area_at_loss=False, relink_retry_s=0.0, relink_hold_s=0.0, relink_app_margin=0.0,
           # session 31's relink shape steps (infrared; on since rules N and O)
           relink_shape_block_s_ir=0.0, relink_shape_min_n_ir=0)


def test_defaults_since_session_28():
    d = ClusterParams()
    assert d.lost_dup_iou == 0.3
    assert d.lost_dup_age_s == 0.5
    assert d.relink_area_at_loss is True
    assert d.relink_retry_s == 1.0
    assert d.lost_dup_ir is False and d.relink_area_at_loss_ir is False and d.relink_retry_ir is False


def _dup_run(**kw):
    """A on the boat at 0-0.1 s, lost at 0.2 s while B is born beside it (no hand-over); B lost at 0.4 s
    (0.2 s old, never confirmed); at 0.5 s a new cluster C on B's place.  Returns C's identity, A's, B's
    and the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    _, t0 = c.update(snap(PD + PA, V * 2, 0.0, 0, ids=[7, 8, 1, 2]))
    c.update(snap(PD + PA, V * 2, 0.1, 1, ids=[7, 8, 1, 2]))
    a_id = max(int(i) for i in t0.ids)
    _, t2 = c.update(snap(PD + PB, V * 2, 0.2, 2, ids=[7, 8, 5, 6]))
    b_id = max(int(i) for i in t2.ids)
    assert b_id != a_id and a_id in c._lost
    c.update(snap(PD + PB, V * 2, 0.3, 3, ids=[7, 8, 5, 6]))
    c.update(snap(PD, V, 0.4, 4, ids=[7, 8]))
    _, t5 = c.update(snap(PD + PB, V * 2, 0.5, 5, ids=[7, 8, 9, 10]))
    got = [int(i) for i in t5.ids if int(i) not in (int(t0.ids[0]),)]
    assert len(got) == 1
    return got[0], a_id, b_id, c


def test_dup_off_keeps_two_lost_identities():
    got, a_id, b_id, c = _dup_run(lost_dup_iou=0.0)
    assert got == b_id  # the young identity (nearer, overlapping most) takes the new cluster
    assert a_id in c._lost  # and the boat's older identity stays lost beside it


def test_dup_retires_the_young_identity_into_the_older():
    got, a_id, b_id, c = _dup_run(lost_dup_iou=0.2)
    assert got == a_id  # the boat keeps its older identity
    assert b_id not in c._lost and a_id not in c._lost
    assert c._alias.get(b_id) == a_id  # B's cluster, back through the label memory, is reported as A


def test_dup_needs_the_overlap_and_a_young_identity():
    got, a_id, b_id, c = _dup_run(lost_dup_iou=0.95)  # overlap short of the threshold: unchanged
    assert got == b_id and a_id in c._lost
    got, a_id, b_id, c = _dup_run(lost_dup_iou=0.2, lost_dup_age_s=0.1)  # B 0.2 s old: not young
    assert got == b_id and a_id in c._lost


def _area_run(**kw):
    """A lost at 0.2 s; its expected box then grown (as a coast's follow does) to 10x its width; at
    0.3 s a new cluster of A's size inside it.  Returns the new cluster's identity and A's."""
    c = FeatureClusterer(ClusterParams(**{**OFF, "relink_min_area": 0.3, **kw}))
    _, t0 = c.update(snap(PD + PA, V * 2, 0.0, 0, ids=[7, 8, 1, 2]))
    c.update(snap(PD + PA, V * 2, 0.1, 1, ids=[7, 8, 1, 2]))
    a_id = max(int(i) for i in t0.ids)
    c.update(snap(PD, V, 0.2, 2, ids=[7, 8]))
    tl, lb, v = c._lost[a_id]
    lb = np.asarray(lb, float).copy()
    big = np.array([lb[0] - 4.5 * lb[2], lb[1], 10.0 * lb[2], lb[3]])  # a coast's box grown onto the wake
    c._lost[a_id] = (tl, big, v)
    _, t3 = c.update(snap(PD + PA, V * 2, 0.3, 3, ids=[7, 8, 11, 12]))
    got = [int(i) for i in t3.ids if int(i) != int(t0.ids[0])]
    assert len(got) == 1
    return got[0], a_id


def test_area_at_loss_off_refuses_under_a_grown_box():
    got, a_id = _area_run(relink_area_at_loss=False)
    assert got != a_id


def test_area_at_loss_compares_with_the_box_at_the_loss():
    got, a_id = _area_run(relink_area_at_loss=True)
    assert got == a_id


def _retry_run(lose_after=False, **kw):
    """A on the boat at 0-0.1 s, lost at 0.2 s; at 0.3 s a new cluster B of two close features inside A's
    box (too small for ``relink_min_area``), at 0.4 s B's features spread over the boat.  ``lose_after``:
    B is first seen at 0.2 s beside A's box and A is lost at 0.3 s, after it.  Returns B's identity at 0.4 s, A's, B's own and the
    clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF, "relink_min_area": 0.3, **kw}))
    _, t0 = c.update(snap(PD + PA, V * 2, 0.0, 0, ids=[7, 8, 1, 2]))
    d_id = int(t0.ids[0])
    a_id = max(int(i) for i in t0.ids)
    tiny = [[114, 64], [116, 65]]
    c.update(snap(PD + PA, V * 2, 0.1, 1, ids=[7, 8, 1, 2]))
    if lose_after:  # B first seen at 0.2 s beside A's box (apart from it), A lost at 0.3 s
        c.update(snap(PD + PA + [[140, 64], [142, 65]], V * 2 + VB, 0.2, 2, ids=[7, 8, 1, 2, 5, 6]))
        _, t3 = c.update(snap(PD + [[140, 64], [142, 65]], V + VB, 0.3, 3, ids=[7, 8, 5, 6]))
    else:
        c.update(snap(PD, V, 0.2, 2, ids=[7, 8]))
        _, t3 = c.update(snap(PD + tiny, V + VB, 0.3, 3, ids=[7, 8, 5, 6]))
    b_id = max(int(i) for i in t3.ids if int(i) not in (d_id, a_id))
    _, t4 = c.update(snap(PD + PA, V + VB, 0.4, 4, ids=[7, 8, 5, 6]))
    got = [int(i) for i in t4.ids if int(i) != d_id]
    assert len(got) == 1
    return got[0], a_id, b_id, c


def test_retry_off_keeps_the_young_cluster_apart():
    got, a_id, b_id, c = _retry_run(relink_retry_s=0.0)
    assert got == b_id and a_id in c._lost


def test_retry_gives_the_lost_identity_to_the_grown_young_cluster():
    got, a_id, b_id, c = _retry_run(relink_retry_s=1.0)
    assert got == a_id and a_id not in c._lost
    assert b_id not in c._lost  # the young cluster's own identity is retired, not lost


def test_retry_needs_a_young_cluster_born_after_the_loss():
    got, a_id, b_id, c = _retry_run(relink_retry_s=0.05)  # B 0.1 s old at 0.4 s: no longer young
    assert got == b_id and a_id in c._lost
    got, a_id, b_id, c = _retry_run(lose_after=True, relink_retry_s=1.0)  # A lost after B was first seen
    assert got == b_id
