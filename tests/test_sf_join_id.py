"""Session 22 (helper H5): the identity of a report joined from several clusters
(``ClusterParams.merge_id_keep_iou``, :func:`_merge_overlapping`'s ``prev`` / ``keep_iou``)."""
import numpy as np

from seawatch.track.feature_clusters import ClusterParams, _box_iou, _merge_overlapping

# a ferry's cluster 32 (long box) and a fishing boat's older cluster 4 (small box inside it)
BOXES = np.array([[352.0, 237.0, 110.0, 28.0], [445.0, 248.0, 15.0, 13.0]])
CIDS = np.array([32, 4])
COUNT = np.array([14, 9])  # like sizes: the id_dv rule (ratio 2) keeps the oldest
VEL = np.array([[5.9, -0.1], [-0.5, 0.0]])


def _merge(prev=None, keep_iou=0.0, cids=CIDS, boxes=BOXES):
    groups = []
    c, b, n, _ = _merge_overlapping(cids, boxes, COUNT, VEL, 0.25, VEL, groups=groups, id_dv=3.0,
                                    id_ratio=2.0, prev=prev, keep_iou=keep_iou)
    return c, b, n, groups


def test_off_keeps_the_oldest():
    assert ClusterParams().merge_id_keep_iou == 0.3  # on by default since session 22
    c, b, n, groups = _merge()
    assert c.tolist() == [4] and groups == [[4, 32]] and n.tolist() == [23]
    # prev given but keep_iou 0: off
    assert _merge({32: BOXES[0] + [2, 0, 0, 0]}, 0.0)[0].tolist() == [4]


def test_joined_report_keeps_the_member_reported_there_last_frame():
    prev = {32: BOXES[0] + [-1.0, 0, 0, 0], 4: BOXES[1] + [1.0, 0, 0, 0]}  # reported apart last frame
    c, b, n, groups = _merge(prev, 0.3)
    assert c.tolist() == [32] and groups == [[32, 4]]
    np.testing.assert_allclose(b[0], [352, 237, 110, 28])  # the union (the ferry's box)
    assert n.tolist() == [23]


def test_joined_last_frame_keeps_its_identity():
    # last frame the same two clusters were one report under 32: it stays 32 (the id order does not matter)
    prev = {32: BOXES[0].copy()}
    assert _merge(prev, 0.3)[0].tolist() == [32]
    prev = {4: BOXES[0].copy()}  # ... and under 4: stays 4
    assert _merge(prev, 0.3)[0].tolist() == [4]


def test_no_good_match_falls_back_to_the_old_rule():
    # only the small boat was reported last frame: its box covers little of the joined one
    prev = {4: BOXES[1].copy()}
    assert _box_iou(BOXES[0], BOXES[1]) < 0.3
    assert _merge(prev, 0.3)[0].tolist() == [4]
    # the ferry's last box far off (another place): no match, the oldest stays
    prev = {32: BOXES[0] + [200.0, 0, 0, 0]}
    assert _merge(prev, 0.3)[0].tolist() == [4]
    # a threshold above the match: the oldest stays
    prev = {32: BOXES[0] + [30.0, 0, 0, 0]}
    assert _box_iou(BOXES[0], prev[32]) < 0.9
    assert _merge(prev, 0.9)[0].tolist() == [4]
    assert _merge(prev, 0.3)[0].tolist() == [32]


def test_single_reports_untouched():
    far = BOXES.copy()
    far[1, 0] = 10.0  # not overlapping: two reports, their own identities, whatever prev says
    c, b, n, groups = _merge({32: far[1].copy(), 4: far[0].copy()}, 0.3, boxes=far)
    assert sorted(c.tolist()) == [4, 32] and all(len(g) == 1 for g in groups)


def test_box_iou():
    assert _box_iou([0, 0, 10, 10], [0, 0, 10, 10]) == 1.0
    assert _box_iou([0, 0, 10, 10], [10, 0, 10, 10]) == 0.0
    assert abs(_box_iou([0, 0, 10, 10], [5, 0, 10, 10]) - 50 / 150) < 1e-12
