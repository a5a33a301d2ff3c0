"""Session 31 (h41): infrared class A, the ferry and the small boat beside it.

``ClusterParams.grow_core_in_ir``: a grown box holding less than this fraction of its cluster's core (the
box members' extent) is not kept on infrared frames (sim ``ir`` 19 at 35-36 s: the small boat's 5 features
in 12 x 14 px, their box grown to 73 x 16 px over the ferry's hull, holding ~5 % of the core).
``ClusterParams.merge_id_apart_ir``: ``merge_id_apart`` on infrared frames only."""
import numpy as np

import seawatch.track.feature_clusters as fc
from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _inside_frac, _inside_frac_many

CORE = np.array([447.0, 264.0, 12.0, 14.0])  # ir 19, 36.0 s: the small boat's members
HULL = np.array([383.0, 249.0, 73.0, 16.0])  # the box grown onto the ferry's hull


def test_defaults_since_rule_n():
    # session 31's rule N turned the growth check, its fallback and the joined report's cover rule on
    p = ClusterParams()
    assert p.grow_core_in_ir == 0.1 and p.grow_core_hint_ir == 0.6 and p.merge_id_now_any_ir is True
    assert p.merge_id_apart_ir is False


def test_inside_frac_many_matches_inside_frac():
    a = np.array([CORE, [0.0, 0.0, 0.0, 0.0], [10.0, 10.0, 5.0, 5.0]])
    b = np.array([HULL, [0.0, 0.0, 4.0, 4.0], [0.0, 0.0, 100.0, 100.0]])
    got = _inside_frac_many(a, b)
    want = [_inside_frac(a[i], b[i]) for i in range(3)]
    np.testing.assert_allclose(got, want)
    assert got[0] < 0.1 and got[2] == 1.0


def _run(monkeypatch, frac, ir=True, grown_off=True):
    """Four members of one cluster (a 12 x 2 px core at x 100-112, y 60-62) through ``update``, with the
    growing replaced by one that returns a box off the core (``grown_off``) or around it: the reported box."""
    def fake_grow(img, boxes, cores, *a, **k):
        b = np.array(boxes, np.float64, copy=True).reshape(-1, 4)
        if grown_off:
            b[:] = [40.0, 40.0, 70.0, 21.0]  # touches the core's top row only
        else:
            b[:, 0] -= 2.0
            b[:, 2] += 4.0
        return b, np.full(len(b), 50.0), np.ones(len(b), bool)

    monkeypatch.setattr(fc, "grow_boxes", fake_grow)
    cl = FeatureClusterer(ClusterParams(grow_core_in_ir=frac, grow_core_hint_ir=0.0, confirm_s=0.0, relink_s=0.0))
    img = np.full((160, 240), 120, np.uint8)
    xy0 = np.array([[100.0, 60.0], [104.0, 62.0], [108.0, 60.0], [112.0, 61.0]])
    out = None
    for fi in range(6):
        xy = xy0 + [0.3 * fi, 0.0]
        _, tracks = cl.update(snap(xy, [[3.0, 0.0]] * 4, 0.1 * fi, fi, shape=(160, 240)), img, ir=ir)
        out = tracks
    assert len(out) == 1
    return np.asarray(out.boxes[0], float)


def test_a_box_grown_off_its_core_is_not_kept_on_infrared(monkeypatch):
    off = _run(monkeypatch, 0.0)
    np.testing.assert_allclose(off, [40.0, 40.0, 70.0, 21.0])  # the step off: the grown box is reported
    on = _run(monkeypatch, 0.5)
    assert on[0] > 90 and on[0] + on[2] < 125 and on[1] > 50  # the members' own box
    # visible frames: unchanged
    np.testing.assert_allclose(_run(monkeypatch, 0.5, ir=False), off)
    # a grown box around the core is kept
    a = _run(monkeypatch, 0.0, grown_off=False)
    np.testing.assert_allclose(_run(monkeypatch, 0.5, grown_off=False), a)


def test_merge_id_apart_ir_on_infrared_only(monkeypatch):
    seen = []
    orig = fc._merge_overlapping

    def spy(*a, **k):
        seen.append(a[16])  # id_apart (the 17th positional argument)
        return orig(*a, **k)

    monkeypatch.setattr(fc, "_merge_overlapping", spy)
    for ir, on, want in ((True, True, True), (False, True, False), (True, False, False)):
        seen.clear()
        cl = FeatureClusterer(ClusterParams(merge_id_apart_ir=on, grow_core_in_ir=0.0, confirm_s=0.0, relink_s=0.0))
        xy = np.array([[100.0, 60.0], [104.0, 62.0], [108.0, 60.0], [150.0, 61.0], [154.0, 60.0], [158.0, 62.0]])
        v = [[3.0, 0.0]] * 3 + [[-3.0, 0.0]] * 3
        for fi in range(4):
            cl.update(snap(xy + np.array([[0.3 * fi, 0.0]] * 3 + [[-0.3 * fi, 0.0]] * 3), v, 0.1 * fi, fi), ir=ir)
        assert seen and all(x is want for x in seen), (ir, on, seen)


# sim ir 13 at 36.8 s: the small boat's cluster 5 (older) and the ferry's 26, 6 features each, moving apart
IDS13 = np.array([5, 26])
BOXES13 = np.array([[446.0, 261.0, 16.0, 16.0], [386.0, 250.0, 76.0, 15.0]])
COUNT13 = np.array([6, 6])
VEL13 = np.array([[-0.8, -0.1], [5.4, -0.1]])
PREV13 = {5: np.array([446.0, 261.0, 16.0, 16.0]), 26: np.array([407.0, 251.0, 7.0, 4.0])}  # the ferry's box held small


def _merge13(any_, counts=COUNT13, prev=PREV13):
    c, b, _, _ = fc._merge_overlapping(IDS13, BOXES13, counts, VEL13, 0.2, VEL13, id_dv=3.0, id_ratio=2.0,
                                       prev=prev, keep_iou=0.3, keep_now_iou=0.5, keep_now_any=any_)
    return c.tolist()


def test_merge_id_now_any_gives_the_joined_report_to_the_member_covering_it():
    assert _merge13(False) == [5]  # by age
    assert _merge13(True) == [26]  # the ferry's own box covers the joined box (IoU 0.56)
    # the id_dv rule's choice (a member with twice the features) is not undone
    assert _merge13(True, counts=np.array([13, 6])) == [5]
    # a member not reported in the frame before is not taken
    assert _merge13(True, prev={5: PREV13[5]}) == [5]


def _run_hint(monkeypatch, hint):
    """Good growth (2 px around the core) for 3 frames, then a box off the core: the reported boxes."""
    calls = []

    def fake_grow(img, boxes, cores, *a, **k):
        b = np.array(boxes, np.float64, copy=True).reshape(-1, 4)
        calls.append(1)
        if len(calls) <= 3:
            b[:, 0] -= 2.0
            b[:, 2] += 4.0
        else:
            b[:] = [40.0, 40.0, 70.0, 21.0]
        return b, np.full(len(b), 50.0), np.ones(len(b), bool)

    monkeypatch.setattr(fc, "grow_boxes", fake_grow)
    cl = FeatureClusterer(ClusterParams(grow_core_in_ir=0.5, grow_core_hint_ir=0.5 if hint else 0.0, confirm_s=0.0, relink_s=0.0))
    img = np.full((160, 240), 120, np.uint8)
    xy0 = np.array([[100.0, 60.0], [104.0, 62.0], [108.0, 60.0], [112.0, 61.0]])
    out = []
    for fi in range(6):
        xy = xy0 + [0.3 * fi, 0.0]
        _, tracks = cl.update(snap(xy, [[3.0, 0.0]] * 4, 0.1 * fi, fi, shape=(160, 240)), img, ir=True)
        out.append(np.asarray(tracks.boxes[0], float) if len(tracks) else None)
    return out


def test_grow_core_hint_falls_back_on_the_last_grown_box(monkeypatch):
    plain = _run_hint(monkeypatch, False)
    hint = _run_hint(monkeypatch, True)
    good = hint[2]
    assert good is not None
    for b in hint[3:]:  # the box grown the frame before, kept (the camera still)
        np.testing.assert_allclose(b, good, atol=1e-6)
    for b in plain[3:]:  # the members' own box: narrower than the grown one
        assert b is not None and b[2] < good[2]
