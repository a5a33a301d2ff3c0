"""Session 26 (H23, issue #8): the rib's box.  ``wake_front``: the wake cut's reference height from
the columns at the object's leading end (a rib whose features lie on its foam); ``wake_track_s`` /
``wake_hold_s``: a trailing side where the members are too slow.  Off by default until session 28; since then ``wake_front``
0.3 and ``wake_hold_s`` 1 are on (``wake_core_ir`` 0: visible frames only), ``wake_track_s`` off."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, grow_boxes


def _rib_scene(seed: int = 0):
    """A dark sea, a small bright hull (12 x 8 px at x 150-161) and a long low bright wake
    (35 x 2 px at the waterline) trailing on its left."""
    rng = np.random.default_rng(seed)
    img = rng.normal(60.0, 2.0, (120, 260)).clip(0, 255)
    img[60:68, 150:162] = 200.0
    img[66:68, 115:150] = 190.0
    return img.astype(np.uint8)


def _grow(img, core, trail=-1, **kw):
    core = np.array([core], float)
    box = core + [-2, -2, 4, 4]
    return grow_boxes(img, box, core, grow=6.0, max_grow_px=60.0, wake_frac=0.3, trail=np.array([trail]), **kw)[0]


def test_wake_front_cuts_the_wake_when_the_features_lie_on_the_foam():
    img = _rib_scene()
    core = [136.0, 65.0, 18.0, 2.0]  # features on the foam and the hull's stern
    off = _grow(img, core)
    assert off[0] <= 116  # all columns' and the core's reference is the foam: nothing cut
    assert _grow(img, core, wake_core=0.5)[0] <= 116
    on = _grow(img, core, wake_front=0.3)
    assert 140 <= on[0] <= 151 and on[0] + on[2] >= 161  # the hull's height is the reference: wake cut
    on2 = _grow(img, core, wake_front=0.3, wake_core=0.5)
    assert 140 <= on2[0] <= 151 and on2[0] + on2[2] >= 161
    # the trailing side on the right: the leading end is the wake's end; the hull is kept
    r = _grow(img, core, trail=1, wake_front=0.3)
    assert r[0] + r[2] >= 161
    # no trailing side: no cut
    assert np.array_equal(_grow(img, core, trail=0, wake_front=0.3), _grow(img, core, trail=0))


def test_wake_front_keeps_a_long_hull():
    rng = np.random.default_rng(1)
    img = rng.normal(60.0, 2.0, (120, 260)).clip(0, 255)
    img[55:68, 120:170] = 200.0  # a long hull
    img[45:55, 160:168] = 200.0  # a cabin at its bow (the leading end, trail -1)
    img = img.astype(np.uint8)
    for wf in (0.0, 0.3):
        g = _grow(img, [141.0, 47.0, 8.0, 18.0], wake_front=wf)
        assert g[0] <= 121 and g[0] + g[2] >= 169


def _snap(t, fi, hmg=None):
    return SimpleNamespace(t_s=t, frame_index=fi, homography=np.eye(3) if hmg is None else hmg)


def test_track_velocity_net_of_the_camera():
    fc = FeatureClusterer(ClusterParams(wake_track_s=1.0, wake_track_n=3))
    cids = np.array([7])
    # the box moves +3 px a frame in the image while the camera moves the scene by +1 px a frame
    shift = np.array([[1.0, 0, 1.0], [0, 1.0, 0], [0, 0, 1.0]])
    x = 100.0
    for fi in range(6):
        fc._cluster_boxes_now = fi - 1
        v = fc._track_vx(_snap(0.1 * fi, fi, shift), cids)
        fc._track_store(_snap(0.1 * fi, fi), cids, np.array([[x, 50.0, 10.0, 6.0]]))
        x += 3.0
    assert np.isclose(v[0], 20.0)  # (3 - 1) px a frame at 10 frames/s
    # a gap of a frame: the history starts again
    fc._cluster_boxes_now = 99
    assert np.isnan(fc._track_vx(_snap(2.0, 100), cids)[0])


def test_defaults_since_session_28():
    p = ClusterParams()
    assert p.wake_track_s == 0 and p.wake_hold_s == 1.0 and p.wake_front == 0.3 and p.wake_core_ir == 0.0
    assert p.wake_track_ir is False
    # grow_boxes' own default keeps wake_front off
    img = _rib_scene()
    core = [136.0, 65.0, 18.0, 2.0]
    assert np.array_equal(_grow(img, core, wake_front=0.0), _grow(img, core))
