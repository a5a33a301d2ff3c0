"""Session 24, helper H11: ``graph_cut_dv_px_s`` (a graph link whose two ends move more than the
threshold apart joins nothing this frame, also inside one cluster, so a cluster holding two boats
that move apart splits into its connected components)."""
import numpy as np

from seawatch.track.feature_clusters import AffinityClusters, ClusterParams, FeatureClusterer


def _run(cut_dv=0.0, vel_b=(-3.0, 0.0), unknown=False):
    """Boat A (slots 0-2, 6 px/s) and boat B (slots 3-6) are linked into one cluster from the start
    through a bridge (2, 3) that stays; B moves at ``vel_b``.  Returns each frame's labels."""
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=4.0, cut_dv=cut_dv)
    slots, ids = np.arange(7), np.arange(10, 17)
    vel = np.array([[6.0, 0.0]] * 3 + [list(vel_b)] * 4)
    if unknown:
        vel[3] = np.nan  # the bridge's B end of unknown velocity
    e = np.array([(0, 1), (1, 2), (3, 4), (4, 5), (5, 6), (2, 3)])
    out = []
    for k in range(12):
        out.append(g.step(slots, ids, e[:, 0], e[:, 1], 0.1 * k, velocity=vel)[0])
    return out


def test_off_keeps_the_two_boats_in_one_cluster():
    for lab in _run()[3:]:
        assert len(set(lab.tolist())) == 1 and lab[0] >= 0


def test_cut_splits_boats_moving_apart_and_keeps_identity_on_larger_part():
    out = _run(cut_dv=4.0)  # 9 px/s apart > 4
    for lab in out[3:]:
        a, b = set(lab[:3].tolist()), set(lab[3:].tolist())
        assert len(a) == 1 and len(b) == 1 and a != b and -1 not in a | b
    # identities stay the same frame to frame once formed
    assert [x.tolist() for x in out[3:]] == [out[3].tolist()] * (len(out) - 3)


def test_cut_leaves_alike_or_unknown_velocities_joined():
    # B 2 px/s from A (under 4): one cluster, as without the step
    assert [x.tolist() for x in _run(cut_dv=4.0, vel_b=(4.0, 0.0))] == \
        [x.tolist() for x in _run(vel_b=(4.0, 0.0))]
    # a bridge end of unknown velocity is not cut
    assert [x.tolist() for x in _run(cut_dv=4.0, unknown=True)] == [x.tolist() for x in _run(unknown=True)]


def test_off_by_default_and_reaches_the_graph():
    assert ClusterParams().graph_cut_dv_px_s == 0.0
    assert FeatureClusterer().graph.cut_dv == 0.0
    assert FeatureClusterer(ClusterParams(graph_cut_dv_px_s=5.0)).graph.cut_dv == 5.0


def test_cut_parts_keeps_a_noisy_boat_and_still_splits_two_boats():
    # one boat of three features, the middle one's velocity 7 px/s off: the plain cut leaves no cluster
    def noisy(**kw):
        g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=4.0, **kw)
        slots, ids = np.arange(3), np.arange(10, 13)
        vel = np.array([[0.0, 0.0], [7.0, 0.0], [0.0, 0.0]])
        e = np.array([(0, 1), (1, 2)])
        return [g.step(slots, ids, e[:, 0], e[:, 1], 0.1 * k, velocity=vel)[0] for k in range(6)]
    assert all((lab == -1).all() for lab in noisy(cut_dv=6.0))
    assert [x.tolist() for x in noisy(cut_dv=6.0, cut_parts=True)] == [x.tolist() for x in noisy()]
    assert (noisy()[-1] >= 0).all()
    # two boats of 3 and 4 features: the parts are big enough, the cut holds
    g = AffinityClusters(alpha=3.0, w_link=1.0, w_cap=4.0, cut_dv=4.0, cut_parts=True)
    slots, ids = np.arange(7), np.arange(10, 17)
    vel = np.array([[6.0, 0.0]] * 3 + [[-3.0, 0.0]] * 4)
    e = np.array([(0, 1), (1, 2), (3, 4), (4, 5), (5, 6), (2, 3)])
    for k in range(6):
        lab = g.step(slots, ids, e[:, 0], e[:, 1], 0.1 * k, velocity=vel)[0]
    assert len(set(lab[:3].tolist())) == 1 and len(set(lab[3:].tolist())) == 1 and lab[0] != lab[3]
    assert ClusterParams().graph_cut_parts is True  # on since session 25 (acts only where a cut threshold is set)
    assert FeatureClusterer(ClusterParams(graph_cut_dv_px_s=6.0, graph_cut_parts=True)).graph.cut_parts is True
