"""Session 29 (the lead): a joined report's identity when the frame before's box of the right member was
only a part of its boat (``ClusterParams.merge_id_now_iou_ir``, :func:`_merge_overlapping`'s
``keep_now_iou``). The boxes are sim ``ir`` 19's at 35.6 s: the ferry's cluster 50 and the older small
cluster 6 of a boat beside it, whose box grew over the ferry's lower hull."""
import numpy as np

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _box_iou, _merge_overlapping
import seawatch.track.feature_clusters as fc

CIDS = np.array([6, 50, 275])  # 275: a young two-feature cluster on the ferry's bow
BOXES = np.array([[381.0, 250.0, 76.0, 15.0], [347.0, 234.0, 110.0, 31.0], [341.0, 229.0, 52.0, 25.0]])
COUNT = np.array([5, 8, 2])  # like sizes: the id_dv rule (ratio 2) keeps the oldest
VEL = np.array([[0.5, 0.0], [6.0, 0.0], [6.0, 0.0]])
JOINED = np.array([341.0, 229.0, 116.0, 36.0])  # the union
PREV_FERRY = np.array([381.0, 251.0, 76.0, 14.0])  # the ferry's report at 35.5 s: its lower hull alone


def _merge(prev, keep_now_iou, keep_iou=0.3, counts=COUNT):
    groups = []
    c, b, _, _ = _merge_overlapping(CIDS, BOXES, counts, VEL, 0.25, VEL, groups=groups, id_dv=3.0, id_ratio=2.0,
                                    prev=prev, keep_iou=keep_iou, keep_now_iou=keep_now_iou)
    return c.tolist(), b, groups


def test_default_and_the_old_rule_keeps_the_oldest():
    assert ClusterParams().merge_id_now_iou_ir == 0.5  # on since session 29 (rule K); 0: the old rule below
    prev = {50: PREV_FERRY}
    assert _box_iou(JOINED, PREV_FERRY) < 0.3  # merge_id_keep_iou misses it
    c, b, groups = _merge(prev, 0.0)
    assert c == [6] and groups == [[6, 50, 275]]
    np.testing.assert_allclose(b[0], JOINED)


def test_the_member_seen_there_last_frame_keeps_it_when_its_own_box_now_confirms():
    prev = {50: PREV_FERRY}
    assert _box_iou(JOINED, BOXES[1]) >= 0.5 > max(_box_iou(JOINED, BOXES[0]), _box_iou(JOINED, BOXES[2]))
    c, _, groups = _merge(prev, 0.5)
    assert c == [50] and groups == [[50, 6, 275]]
    # the confirmation's bar: above the member's own IoU now, the oldest stays
    assert _merge(prev, 0.99)[0] == [6]


def test_the_best_last_frame_member_only():
    # the small cluster's box of the frame before overlapped the joined box more than the ferry's did:
    # it is the one to confirm, and its own box now covers little of the joined box, so the rule gives
    # nothing and the id_dv / oldest rule stands (the ferry's own box now would have passed)
    prev = {50: PREV_FERRY + [60.0, 0, 0, 0], 6: PREV_FERRY.copy()}
    assert _box_iou(JOINED, prev[6]) > _box_iou(JOINED, prev[50]) > 0
    assert _merge(prev, 0.5)[0] == [6]
    # with the most features (ratio 2) the id_dv rule gives the ferry its identity; the step does not undo it
    assert _merge(prev, 0.5, counts=np.array([3, 8, 2]))[0] == [50]


def test_keep_iou_first_and_no_prev_no_change():
    # a member passing merge_id_keep_iou wins as before
    prev = {6: JOINED.copy(), 50: PREV_FERRY}
    assert _merge(prev, 0.5)[0] == [6]
    # no member in prev: the step has nothing to confirm
    assert _merge({99: JOINED.copy()}, 0.5)[0] == [6]


def test_acts_on_infrared_frames_only(monkeypatch):
    """The clusterer hands the IoU to the join only on infrared frames."""
    seen = []
    orig = fc._merge_overlapping

    def spy(*a, **k):
        seen.append(a[-1] if len(a) > 19 else k.get("keep_now_iou", 0.0))
        return orig(*a, **k)

    monkeypatch.setattr(fc, "_merge_overlapping", spy)
    rng = np.random.default_rng(3)
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import StableFeatureTracker
    from seawatch.detect.features import StableFeatureExtractor

    for scn_name, want in (("ir", 0.5), ("pan", 0.0)):
        seen.clear()
        scn = make_scenario(scn_name, seed=int(rng.integers(100, 200)), width=320, height=240, duration_s=2.0)
        trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps, far_px=0.0),
                                   ClusterParams(merge_id_now_iou_ir=0.5), camera=scn.camera)
        for i in range(scn.n_frames):
            trk.process(scn.render(i))
        assert seen and set(seen) == {want}, (scn_name, set(seen))
    assert isinstance(FeatureClusterer(ClusterParams(merge_id_now_iou_ir=0.5)).params.merge_id_now_iou_ir, float)
