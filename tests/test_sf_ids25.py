"""Session 25, helper H15: ``graph_cut_dv_px_s_ir`` (the graph cut's threshold on infrared frames
only) and ``graph_cut_hold`` (a pair cut once stays cut while its velocities still differ)."""
import numpy as np

from seawatch.track.feature_clusters import AffinityClusters, ClusterParams, FeatureClusterer
from tests._feature_snap import snap


def _run(dip_every=0, **kw):
    """Boat A (slots 0-2, 6 px/s) and boat B (slots 3-6, -3 px/s: 9 px/s apart) linked through a
    bridge (2, 3) that stays; every ``dip_every``-th frame B's velocity is noisy, 1 px/s (5 px/s
    from A: under a cut of 6, over its half).  Returns each frame's labels."""
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=4.0, **kw)
    slots, ids = np.arange(7), np.arange(10, 17)
    e = np.array([(0, 1), (1, 2), (3, 4), (4, 5), (5, 6), (2, 3)])
    out = []
    for k in range(16):
        vb = 1.0 if dip_every and k % dip_every == dip_every - 1 else -3.0
        vel = np.array([[6.0, 0.0]] * 3 + [[vb, 0.0]] * 4)
        out.append(g.step(slots, ids, e[:, 0], e[:, 1], 0.1 * k, velocity=vel)[0])
    return out


def _apart(lab):
    a, b = set(lab[:3].tolist()), set(lab[3:].tolist())
    return len(a) == 1 and len(b) == 1 and a != b and -1 not in a | b


def test_noisy_dip_joins_the_boats_without_hold():
    out = _run(dip_every=4, cut_dv=6.0, cut_parts=True)
    assert all(_apart(lab) for lab in out[:3])
    joined = [k for k, lab in enumerate(out) if len(set(lab.tolist())) == 1]
    assert joined == [3, 7, 11, 15]  # every dip joins A and B into one cluster


def test_hold_keeps_the_cut_through_the_dips_and_the_identities():
    out = _run(dip_every=4, cut_dv=6.0, cut_parts=True, cut_hold=0.5)
    assert all(_apart(lab) for lab in out)
    assert [x.tolist() for x in out] == [out[0].tolist()] * len(out)


def test_hold_releases_when_the_velocities_agree():
    # B's velocity within 0.5 * 6 = 3 px/s of A's: the held cut lets go, one cluster again
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=4.0, cut_dv=6.0, cut_hold=0.5)
    slots, ids = np.arange(7), np.arange(10, 17)
    e = np.array([(0, 1), (1, 2), (3, 4), (4, 5), (5, 6), (2, 3)])
    for k in range(10):
        vb = -3.0 if k < 5 else 4.0
        vel = np.array([[6.0, 0.0]] * 3 + [[vb, 0.0]] * 4)
        lab = g.step(slots, ids, e[:, 0], e[:, 1], 0.1 * k, velocity=vel)[0]
        if k == 4:
            assert _apart(lab)
    assert len(set(lab.tolist())) == 1 and lab[0] >= 0


def test_hold_off_is_the_old_cut():
    a = _run(dip_every=3, cut_dv=6.0, cut_parts=True)
    b = _run(dip_every=3, cut_dv=6.0, cut_parts=True, cut_hold=0.0)
    assert [x.tolist() for x in a] == [x.tolist() for x in b]


def _two_boats(ir, **kw):
    """Two boats side by side (3 features each) moving the same way at 10 and 3 px/s: without a
    cut the paper's graph joins them into one cluster.  Session 25's infrared graph steps (on by
    default since) are off unless named."""
    kw = {"graph_cut_dv_px_s_ir": 0.0, "graph_cut_parts": False, "gate_ema_s_ir": 0.0, "merge_id_major_ir": False, **kw}
    fc = FeatureClusterer(ClusterParams(radius_px=60.0, **kw))
    xy = [[40, 80], [46, 82], [52, 80], [58, 82], [64, 80], [70, 82]]
    vel = [[10, 0]] * 3 + [[3, 0]] * 3
    labs = []
    for k in range(8):
        fc.update(snap(xy, vel, 0.1 * k, k), ir=ir)
        labs.append(fc.last_labels.copy())
    return fc, labs


def test_cut_ir_only_on_infrared_frames():
    # on by default since session 25 (6 px/s on infrared frames); the hold stays off
    assert ClusterParams().graph_cut_dv_px_s_ir == 6.0 and ClusterParams().graph_cut_hold == 0.0
    fc, _ = _two_boats(False, graph_cut_dv_px_s_ir=6.0)
    assert fc.graph.cut_dv == 0.0
    fc, _ = _two_boats(True, graph_cut_dv_px_s_ir=6.0)
    assert fc.graph.cut_dv == 6.0
    fc, _ = _two_boats(True)
    assert fc.graph.cut_dv == 0.0
    fc, _ = _two_boats(True, graph_cut_dv_px_s=4.0)
    assert fc.graph.cut_dv == 4.0
    fc, _ = _two_boats(False, graph_cut_dv_px_s=4.0, graph_cut_dv_px_s_ir=6.0)
    assert fc.graph.cut_dv == 4.0
    assert FeatureClusterer(ClusterParams(graph_cut_hold=0.5)).graph.cut_hold == 0.5


def test_cut_ir_splits_the_two_boats_on_infrared_frames_only():
    _, vis = _two_boats(False, graph_cut_dv_px_s_ir=6.0, graph_cut_parts=True)
    _, ir = _two_boats(True, graph_cut_dv_px_s_ir=6.0, graph_cut_parts=True)
    _, off = _two_boats(True)
    for lab in vis[-3:] + off[-3:]:  # one cluster: the step is off on visible frames, and when switched off
        assert len(set(lab.tolist())) == 1 and lab[0] >= 0
    for lab in ir[-3:]:  # 7 px/s apart > 6 on infrared frames: two clusters, the identities kept
        assert _apart(lab)
    assert [x.tolist() for x in ir[-3:]] == [ir[-1].tolist()] * 3
