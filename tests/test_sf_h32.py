"""Session 27 (issue #8, helper h32: W's added ``pan`` switches): ``relink_hold_s`` (seconds, 0: off):
a young cluster under its own identity with a lost identity in view within its relink gate, not given
one this frame, stays tentative (not reported) until it is this old, so that ``relink_retry_s`` can
rename it before its own identity is ever shown."""

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer
from seawatch.types import TrackState

PA = [[100, 60], [130, 70]]  # the boat's first cluster A
PD = [[20, 120], [44, 130]]  # another boat far away (keeps the frames non-empty)
TINY = [[114, 64], [116, 65]]  # the boat's young cluster B: two close features inside A's box
V = [[10.0, 0.0]] * 2
VB = [[-10.0, 0.0]] * 2
OFF = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.05, relink_s=10.0, coast_s=0.0,
           relink_view_px=0.0, relink_dy_h=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False,
           hand_over_relinked=False, split_follow_box=0.0, relink_min_s=0.0, relink_overlap=0.0,
           box_wake_below_px=0.0, relink_jump_iou=0.0, relink_young_s=0.0, relink_aspect_ratio=0.0,
           relink_young_after_s=0.0, relink_min_area=0.3, relink_height_zoom_min=0.0, relink_iou_tie=True,
           relink_side_h_ratio=0.0, relink_retry_s=1.0,
           # on by default since session 28; named off here: the tests isolate relink_hold_s
           lost_dup_iou=0.0, relink_area_at_loss=False, relink_app_margin=0.0, relink_hold_s=0.0,
           # session 31's relink shape steps (infrared; on since rules N and O)
           relink_shape_block_s_ir=0.0, relink_shape_min_n_ir=0)


def test_on_by_default_since_session_28():
    p = ClusterParams()
    assert p.relink_hold_s == 1.0 and p.relink_retry_s == 1.0 and p.relink_retry_ir is False


def _run(tiny=TINY, **kw):
    """A on the boat at 0-0.1 s, lost at 0.2 s; B (too small for ``relink_min_area``) first seen at
    0.3 s inside A's box, still small at 0.4 s (past ``confirm_s``), spread over the boat at 0.5 s.
    Returns {time: [(identity, state)] of the boat's reports}, A's identity and B's own."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    _, t0 = c.update(snap(PD + PA, V * 2, 0.0, 0, ids=[7, 8, 1, 2]))
    d_id = int(t0.ids[0])
    a_id = max(int(i) for i in t0.ids)
    c.update(snap(PD + PA, V * 2, 0.1, 1, ids=[7, 8, 1, 2]))
    c.update(snap(PD, V, 0.2, 2, ids=[7, 8]))
    out = {}
    for k, (t, pts) in enumerate([(0.3, tiny), (0.4, tiny), (0.5, PA)]):
        _, tr = c.update(snap(PD + pts, V + VB, t, 3 + k, ids=[7, 8, 5, 6]))
        out[t] = [(int(i), int(s)) for i, s in zip(tr.ids, tr.states) if int(i) != d_id]
    b_id = out[0.3][0][0]
    return out, a_id, b_id


def test_off_reports_the_young_cluster_under_its_own_identity():
    out, a_id, b_id = _run(relink_hold_s=0.0)
    assert b_id != a_id
    assert out[0.4] == [(b_id, int(TrackState.CONFIRMED))]  # shown as B: a switch when renamed
    assert out[0.5][0][0] == a_id  # relink_retry_s renames it


def test_hold_keeps_it_tentative_until_renamed():
    out, a_id, b_id = _run(relink_hold_s=1.0)
    assert out[0.4] == [(b_id, int(TrackState.TENTATIVE))]  # not reported
    assert out[0.5] == [(a_id, int(TrackState.CONFIRMED))]  # the lost identity, reported


def test_hold_ends_with_its_window_and_needs_a_lost_identity_in_the_gate():
    out, a_id, b_id = _run(relink_hold_s=0.05)  # B 0.1 s old at 0.4 s: no longer held
    assert out[0.4] == [(b_id, int(TrackState.CONFIRMED))]
    far = [[300, 200], [302, 201]]  # B far outside A's gate: not held
    out, a_id, b_id = _run(tiny=far, relink_hold_s=1.0, relink_px=5.0, relink_px_per_s=0.0)
    assert out[0.4] == [(b_id, int(TrackState.CONFIRMED))]


def test_hold_follows_the_retry_switch_on_infrared(monkeypatch):
    """Without relink_retry_s on infrared (relink_retry_ir off) nothing could rename the held cluster:
    no hold there; on visible frames the same settings hold it."""
    import test_sf_h31 as h31

    out, a_id, b_id = _run(relink_hold_s=1.0, relink_retry_ir=False)
    assert out[0.4] == [(b_id, int(TrackState.TENTATIVE))]  # visible frames: held as before
    monkeypatch.setitem(globals(), "FeatureClusterer", h31._IrClusterer)
    out, a_id, b_id = _run(relink_hold_s=1.0, relink_retry_ir=False)
    assert out[0.4] == [(b_id, int(TrackState.CONFIRMED))]  # infrared, retry off: reported
    assert out[0.5][0][0] == b_id  # and never renamed
    out, a_id, b_id = _run(relink_hold_s=1.0, relink_retry_ir=True)
    assert out[0.4] == [(b_id, int(TrackState.TENTATIVE))]  # infrared, retry on (the switch True): held
    out, a_id, b_id = _run(relink_hold_s=1.0)
    assert out[0.4] == [(b_id, int(TrackState.CONFIRMED))]  # infrared, retry off by default: reported
