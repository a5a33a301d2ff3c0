"""Session 27 (issue #8, helper h28): one coast per boat.  ``coast_dup_iou``: among one frame's coasts
whose reported boxes overlap by at least that IoU only the most recently lost (``coast_dup_seen``: the one
reported last) is reported (the others
end); ``coast_live_iou``: a coast whose reported box overlaps a live report by at least that IoU is not
reported and ends.  Synthetic: the lost identities are set directly and ``_coast`` is called without
the image check (``coast_check`` False: a coast is reported at its expected box)."""

from types import SimpleNamespace

import numpy as np

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer


def _clusterer(**kw):
    # coast_dup_iou 0.5, coast_dup_seen True: on by default since session 28; named off here (tests turn them on)
    kw = {"coast_dup_iou": 0.0, "coast_dup_seen": False, **kw}
    c = FeatureClusterer(ClusterParams(coast_check=False, **kw))
    # identity -> (loss time, expected box, velocity); all born at 0 s
    c._lost = {9: (6.7, np.array([300.0, 338, 24, 8]), None),
               17: (6.3, np.array([301.0, 338, 24, 8]), None),  # the same boat, lost earlier
               30: (6.5, np.array([100.0, 200, 30, 10]), None)}  # another boat
    c._birth = {9: 0.0, 17: 0.0, 30: 0.0}
    return c


def _coast(c, t, reported=np.zeros((0, 4)), present=frozenset()):
    snap = SimpleNamespace(t_s=t, shape=(480, 640), frame_index=int(round(t * 10)), ids=np.zeros(0, np.int64))
    ids, boxes, _ = c._coast(snap, np.asarray(reported, np.float64), None, present)
    return sorted(ids.tolist())


def test_defaults_since_session_28_and_off_both_coasts_are_reported():
    p = ClusterParams()
    assert p.coast_dup_iou == 0.5 and p.coast_live_iou == 0.0 and p.coast_dup_seen is True
    assert p.coast_dup_ir is False  # visible frames only
    assert _coast(_clusterer(coast_dup_iou=0.0), 7.0) == [9, 17, 30]  # both coasts on the one boat are reported


def test_two_coasts_on_one_boat_report_the_most_recently_lost_only():
    c = _clusterer(coast_dup_iou=0.5)
    assert _coast(c, 7.0) == [9, 30]
    assert _coast(c, 7.1) == [9, 30]  # 17 has ended: not back the next frame
    assert c._coast_end.get(17) == 6.3


def test_ties_keep_the_lower_identity_and_apart_boxes_are_kept():
    c = _clusterer(coast_dup_iou=0.5)
    c._lost[17] = (6.7, c._lost[17][1], None)
    assert _coast(c, 7.0) == [9, 30]
    c = _clusterer(coast_dup_iou=0.95)  # IoU of the two boxes is 23/25: under 0.95, both kept
    assert _coast(c, 7.0) == [9, 17, 30]


def test_a_coast_over_a_live_report_yields():
    live = [[302.0, 337, 22, 9]]  # a live report on the boat of 9 and 17 (inside fraction < coast_overlap)
    c = _clusterer(coast_overlap=0.99)
    assert _coast(c, 7.0, live) == [9, 17, 30]
    c = _clusterer(coast_overlap=0.99, coast_live_iou=0.3)
    assert _coast(c, 7.0, live) == [30]
    assert _coast(c, 7.1) == [30]  # ended


def test_coast_dup_seen_keeps_the_coast_reported_last():
    for seen, kept in ((True, [17, 30]), (False, [9, 30])):
        c = _clusterer(coast_dup_iou=0.5, coast_dup_seen=seen)
        assert _coast(c, 7.0, present={9}) == [17, 30]  # 9 not coasted now (reported through the label memory)
        # 9, lost later (6.7 s) than 17 (6.3 s), comes onto 17's box: 17 was reported last (7.0 s)
        assert _coast(c, 7.1) == kept
