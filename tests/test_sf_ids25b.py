"""Session 25 round 2 (issue #8, identity switches on ``ir``, helper H18): a cluster drifting from
one boat onto the next feature by feature.  ``gate_ema_s_ir`` (the velocity gate compares a joining
feature with the cluster's established velocity, an exponential mean over time, instead of this
frame's mean) and ``gate_dv_px_s_ir`` (the gate's threshold on infrared frames); both off by default."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import AffinityClusters, ClusterParams, FeatureClusterer, _gate_links


def test_defaults_since_session_25():
    p = ClusterParams()
    assert p.gate_ema_s_ir == 1.0 and p.gate_dv_px_s_ir == 0.0 and p.merge_id_major_ir is True
    assert AffinityClusters().gate_ema_s == 0.0


def test_gate_links_uses_the_established_velocity_where_given():
    # cluster 1 (features 0, 1) moves at 1.6 px/s this frame; feature 2 (3.5 px/s) is 1.9 px/s off
    lab = np.array([1, 1, -1])
    vel = np.array([[1.6, 0.0], [1.6, 0.0], [3.5, 0.0]])
    li, lj, est = np.array([1]), np.array([2]), np.array([1])
    assert _gate_links(lab, vel, li, lj, est, 2.0).tolist() == [True]
    # its established velocity is 1 px/s: 2.5 px/s off, refused
    assert _gate_links(lab, vel, li, lj, est, 2.0, vref={1: np.array([1.0, 0.0])}).tolist() == [False]
    # an unknown established velocity falls back on this frame's mean
    assert _gate_links(lab, vel, li, lj, est, 2.0, vref={1: np.array([np.nan, 0.0])}).tolist() == [True]


def _drift(ema_s):
    """Cluster {0, 1} at 1 px/s for 0.8 s; then feature 2 (2.8 px/s) links to it, and a frame later
    feature 3 (3.5 px/s) links to feature 2.  Gate 2 px/s.  Returns the last frame's labels."""
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0, gate_ema_s=ema_s)
    slots, ids = np.arange(4), np.arange(10, 14)
    vel = np.array([[1.0, 0.0], [1.0, 0.0], [2.8, 0.0], [3.5, 0.0]])
    t = 0.0
    e = np.array([(0, 1)])
    for _ in range(20):
        g.step(slots, ids, e[:, 0], e[:, 1], t, velocity=vel, max_dv_px_s=2.0)
        t += 0.04
    e = np.array([(0, 1), (1, 2)])
    labels, _ = g.step(slots, ids, e[:, 0], e[:, 1], t, velocity=vel, max_dv_px_s=2.0)
    assert labels.tolist()[:3] == [1, 1, 1]  # 1.8 px/s off the cluster: it joins either way
    t += 0.04
    e = np.array([(0, 1), (1, 2), (2, 3)])
    labels, _ = g.step(slots, ids, e[:, 0], e[:, 1], t, velocity=vel, max_dv_px_s=2.0)
    return labels.tolist(), g


def test_established_velocity_stops_the_drift():
    # off: feature 3 is 1.9 px/s off the cluster's mean now (1.6 px/s, pulled by feature 2): it joins
    labels, _ = _drift(0.0)
    assert labels == [1, 1, 1, 1]
    # on: 2.5 px/s off the cluster's established velocity (about 1 px/s): refused
    labels, g = _drift(2.0)
    assert labels == [1, 1, 1, -1]
    v, _ = g.vel_est[1]
    assert 1.0 < v[0] < 1.1


def test_established_velocity_is_an_exponential_mean_over_time():
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=0.0, gate_ema_s=1.0)
    slots, ids, e = np.arange(2), np.arange(10, 12), np.array([(0, 1)])
    vel = np.array([[2.0, 0.0], [2.0, 0.0]])
    g.step(slots, ids, e[:, 0], e[:, 1], 0.0, velocity=vel, max_dv_px_s=3.0)
    assert np.allclose(g.vel_est[1][0], [2.0, 0.0])  # a new identity starts from its members' mean
    vel[:] = (4.0, 2.0)
    g.step(slots, ids, e[:, 0], e[:, 1], 0.5, velocity=vel, max_dv_px_s=3.0)
    a = 1.0 - np.exp(-0.5)
    assert np.allclose(g.vel_est[1][0], [2.0 + 2.0 * a, 2.0 * a])


def test_switches_act_on_infrared_frames_only():
    c = FeatureClusterer(ClusterParams(gate_dv_px_s_ir=1.5, gate_ema_s_ir=2.0))
    seen = []
    orig = c.graph.step

    def step(*a, **k):
        seen.append((k["max_dv_px_s"], c.graph.gate_ema_s))
        return orig(*a, **k)

    c.graph.step = step
    s = snap([[100, 60], [110, 62]], [[5.0, 0.0]] * 2, 0.0, 0)
    c.update(s, ir=False)
    c.update(snap([[100, 60], [110, 62]], [[5.0, 0.0]] * 2, 0.1, 1), ir=True)
    assert seen == [(3.0, 0.0), (1.5, 2.0)]
    for params, want in ((ClusterParams(gate_ema_s_ir=0.0), (3.0, 0.0)), (ClusterParams(), (3.0, 1.0))):
        c2 = FeatureClusterer(params)  # switched off: the plain gate on infrared frames; the defaults: 1 s
        seen.clear()
        orig2 = c2.graph.step
        c2.graph.step = lambda *a, _c=c2, _o=orig2, **k: (seen.append((k["max_dv_px_s"], _c.graph.gate_ema_s)), _o(*a, **k))[1]
        c2.update(s, ir=True)
        assert seen == [want]


def test_major_identity_keeps_a_merge():
    from seawatch.track.feature_clusters import assign_identities
    # identity 3 (old, 2 features) and 7 (5 features) merge into one component
    prev = np.array([3, 3, 7, 7, 7, 7, 7])
    comp = np.zeros(7, np.int64)
    ids, nxt = assign_identities(prev, comp, 10)
    assert ids.tolist() == [3] and nxt == 10  # the paper: the oldest identity
    ids, nxt = assign_identities(prev, comp, 10, major=True)
    assert ids.tolist() == [7] and nxt == 10
    # a split still leaves an identity with the part holding most of its features
    prev = np.array([3, 3, 3, 3, 3, 7, 7])
    comp = np.array([0, 0, 0, 1, 1, 1, 1])
    ids, _ = assign_identities(prev, comp, 10, major=True)
    assert ids.tolist() == [3, 7]


def test_major_switch_on_infrared_frames_only():
    c = FeatureClusterer(ClusterParams(merge_id_major_ir=True))
    xy, v = [[100, 60], [110, 62]], [[5.0, 0.0]] * 2
    c.update(snap(xy, v, 0.0, 0), ir=False)
    assert c.graph.id_major is False
    c.update(snap(xy, v, 0.1, 1), ir=True)
    assert c.graph.id_major is True
    c2 = FeatureClusterer(ClusterParams(merge_id_major_ir=False))
    c2.update(snap(xy, v, 0.0, 0), ir=True)
    assert c2.graph.id_major is False and ClusterParams().merge_id_major_ir is True  # on since session 25
