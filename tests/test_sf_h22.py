"""The far strip kept apart from the boats below it (issue #8, session 26 H22):
``ClusterParams.far_cut_px`` (0: off) and ``far_cut_gap_px`` drop a graph edge whose upper end lies
in the far strip (less than ``far_cut_px`` under the horizon, or above it) and whose lower end lies
more than ``far_cut_gap_px`` (times the zoom) below it, so the far strip's features (a far ship, the
far water's blobs) do not join a boat lying below the strip."""

from __future__ import annotations

import numpy as np

from _feature_snap import Level
from test_sf_far import stable_snap

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer, _far_cut

ROW = 100.0  # the horizon's row




def _snap(k, pts, v=(12.0, 0.0), seed=0):
    """Frame ``k`` (0.04 s apart): stable features at ``pts`` (x, dy under the horizon), all moving
    at ``v`` px/s with 0.3 px/s noise; a 320x240 image."""
    rng = np.random.default_rng(seed + 100 * k)
    xy = np.array([(x + v[0] * 0.04 * k, ROW + dy) for x, dy in pts], float)
    n = len(xy)
    hist = np.asarray(v, float) + rng.normal(0, 0.3, (n, 4, 2))
    return stable_snap(k, xy, hist)


def _params(**kw):
    # far_cut_px, far_cut_deep_px: on by default since session 28; named off here (tests turn them on)
    kw = {"far_cut_px": 0.0, "far_cut_deep_px": 0.0, **kw}
    return ClusterParams(relink_s=0.0, coast_s=0.0, confirm_s=0.0, known_min_speed_px_s=0.0,
                         grow_box=0.0, **kw)


def _boxes(params, pts, zoom=1.0, frames=10):
    c = FeatureClusterer(params)
    hz = Level(ROW)
    for k in range(frames):
        dets, _ = c.update(_snap(k, pts), horizon=hz, zoom=zoom)
    return dets.boxes.copy()


# a boat whose top lies 16 px under the horizon, and two blobs of the far strip 2-3 px under it above
# the boat, moving alike (the far water's blobs joining a slow boat; a far ship above a near boat)
BOAT = [(150.0, 16.0), (162.0, 17.0), (156.0, 22.0), (170.0, 24.0), (145.0, 26.0)]
FAR = [(152.0, 2.0), (166.0, 3.0)]


def test_on_by_default_since_session_28_and_joined_when_off():
    d = ClusterParams()
    assert (d.far_cut_px, d.far_cut_gap_px, d.far_cut_deep_px, d.far_cut_deep_gap_px) == (12.0, 6.0, 24.0, 20.0)
    b = _boxes(_params(), BOAT + FAR)
    top = b[:, 1].min()
    assert top <= ROW + 3.0  # the far strip's blobs stretch the boat's box up to them


def test_far_strip_not_joined_to_the_boat_below():
    b = _boxes(_params(far_cut_px=12.0, far_cut_gap_px=6.0), BOAT + FAR)
    boat = [bb for bb in b if bb[1] + bb[3] >= ROW + 24]
    assert len(boat) == 1
    assert boat[0][1] >= ROW + 13.0  # the box starts at the boat's own top (16 px, less the margin)
    assert not any(bb[1] <= ROW + 3.0 and bb[1] + bb[3] >= ROW + 24 for bb in b)


def test_boat_straddling_the_line_stays_one():
    # features every 3-4 rows from 6 to 26 px under the horizon: the short edges keep it one cluster
    pts = [(150.0 + 3 * (i % 4), 6.0 + 3.3 * i) for i in range(7)]
    b = _boxes(_params(far_cut_px=12.0, far_cut_gap_px=6.0), pts)
    assert len(b) == 1
    assert np.allclose(b, _boxes(_params(), pts))  # the same box as with the step off
    assert b[0][1] <= ROW + 6.5 and b[0][1] + b[0][3] >= ROW + 20.0


def test_far_cut_edges_and_zoom():
    xy = np.array([[100.0, ROW + 2.0], [105.0, ROW + 20.0], [110.0, ROW + 6.0],
                   [100.0, ROW + 30.0], [100.0, ROW + 50.0]])
    ei = np.array([0, 0, 1, 3])
    ej = np.array([1, 2, 2, 4])
    p = _params(far_cut_px=12.0, far_cut_gap_px=6.0)
    # 0-1: strip to 18 px below: cut; 0-2: 4 px: kept; 1-2: upper end 2 at 6 px, 14 below: cut;
    # 3-4: both below the strip: kept
    assert _far_cut(xy, ei, ej, Level(ROW), 1.0, p).tolist() == [False, True, False, True]
    # at zoom 3 the gap is 18 px: 0-1 (18 px) and 1-2 (14 px) kept
    assert _far_cut(xy, ei, ej, Level(ROW), 3.0, p).tolist() == [True, True, True, True]
    # no horizon row (NaN) at a column: kept
    assert _far_cut(xy, ei, ej, Level(np.nan), 1.0, p).all()


# the extractor side: ``far_skip_ir`` (False: off) keeps the far pass off infrared frames


def _far_scene():
    """A far 'ship' 3 rows below the horizon (row 100) with 1-px marks (as tests/test_features_far25b.py)."""
    img = np.full((240, 320), 100, np.uint8)
    img[103:107, 140:180] = 140
    for x in range(141, 180, 4):
        img[104 + x % 2, x] = 60
    return img


def _ext_run(ir, n=4, **kw):
    from seawatch.detect.features import StableFeatureExtractor

    # the far pass: on by default since session 28; named off here with H22's settings (tests turn it on)
    kw = {"far_px": 0.0, "far_skip_ir": False, "far_threshold": 0, "far_max_keypoints": 60, **kw}
    ext = StableFeatureExtractor(nominal_fps=25.0, **kw)
    for f in range(n):
        snap = ext.process(_far_scene(), f / 25.0, horizon=Level(ROW), ir=ir)
    return snap


def _same(a, b):
    return np.array_equal(a.ids, b.ids) and np.array_equal(a.xy, b.xy)


def test_far_skip_ir_on_by_default_since_session_28_and_visible_frames_keep_the_far_pass():
    from seawatch.detect.features import StableFeatureExtractor

    assert StableFeatureExtractor().far_skip_ir is True
    on = _ext_run(False, far_px=12)
    assert not _same(on, _ext_run(False))  # the far pass changes the far rows' keypoints
    assert _same(_ext_run(True, far_px=12), on)  # off: the ir flag changes nothing
    assert _same(_ext_run(False, far_px=12, far_skip_ir=True), on)  # visible frames keep the far pass


def test_far_skip_ir_leaves_infrared_frames_as_without_the_far_pass():
    assert _same(_ext_run(True, far_px=12, far_skip_ir=True), _ext_run(True))


def test_far_cut_on_visible_frames_only_unless_far_cut_ir():
    def top(ir, **kw):
        c = FeatureClusterer(_params(far_cut_px=12.0, far_cut_gap_px=6.0, **kw))
        for k in range(10):
            dets, _ = c.update(_snap(k, BOAT + FAR), horizon=Level(ROW), ir=ir)
        b = dets.boxes
        return bool(np.any((b[:, 1] <= ROW + 3.0) & (b[:, 1] + b[:, 3] >= ROW + 24.0)))  # one box spans both

    assert top(True)  # infrared: not cut
    assert not top(True, far_cut_ir=True)
    assert not top(False)
