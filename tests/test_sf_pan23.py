"""Session 23 round 2 (issue #8, ``pan``'s switches at the new defaults, helper H4):
``relink_side_h_ratio`` (0: off) relinks an identity lost at the image's left or right edge only to
a cluster whose height lies within that factor of the identity's own height, taken from its last
boxes clear of the edges and scaled by the zoom's change (the rib and the fishing boat on ``pan`` 2
and 7, both left behind by the pan at 10 s: the rib's cluster took the fishing boat's identity)."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

EMPTY = (np.zeros((0, 2)), np.zeros((0, 2)))
# the other relink checks off: a wide gate, no row or size check
OFF = dict(relink_alt_s=0.0, relink_appearance=False, confirm_s=0.0, relink_s=30.0, coast_s=0.0,
           relink_px=200.0, relink_iou_tie=False, relink_view_px=0.0, relink_min_area=0.0,
           relink_height_zoom_min=0.0, relink_dy_h=0.0, relink_dy_px_per_s=0.0, relink_dy_side=False,
           hand_over_relinked=False, split_follow_box=0.0, relink_size_ratio=0.0,
           relink_side_h_ratio=0.0, relink_undo_hand_over=False,  # session 23's steps off (on by default)
           box_wake_below_px=0.0)  # and session 24's wake cut (on by default: it cuts two-point boxes)
SMALL = [[100, 120], [110, 124]]  # a small boat (box about 8 px tall)
TALL = [[100, 40], [120, 64]]  # a tall boat (box about 28 px tall), above it
NEW_SMALL = [[140, 60], [150, 64]]  # a small cluster back later, on the tall boat's row (nearer its box)
NEW_MID = [[140, 52], [150, 72]]  # a cluster about 24 px tall on the same row


def _box_h(pts, r=2.0):
    return max(p[1] for p in pts) - min(p[1] for p in pts) + 2 * r


def _run(new_pts, edge=True, zoom=1.0, **kw):
    """Both boats seen clear of the edges, then at the left edge (``edge``; else still inside),
    then lost; at 20 s one new cluster appears on ``new_pts`` (the zoom ``zoom`` from the loss on).
    Returns the new cluster's identity, the small and the tall boat's identities, the clusterer."""
    c = FeatureClusterer(ClusterParams(**{**OFF, **kw}))
    vel = [[-20.0, 0.0]] * 4
    pts = SMALL + TALL
    ids = [1, 2, 3, 4]
    c.update(snap(pts, vel, 0.0, 0, ids=ids))
    _, tr = c.update(snap(pts, vel, 0.1, 1, ids=ids))
    assert len(tr) == 2
    byy = {int(i): b[1] for i, b in zip(tr.ids, tr.boxes)}
    s_id = max(byy, key=byy.get)  # the lower box: the small boat
    t_id = min(byy, key=byy.get)
    shift = 100 if edge else 60
    moved = [[x - shift, y] for x, y in pts]  # at the edge: boxes starting at x = 0 (clipped)
    _, tr = c.update(snap(moved, vel, 0.2, 2, ids=ids))
    assert len(tr) == 2
    fi = 3
    for t in (0.3, 0.4, 19.8, 19.9):
        c.update(snap(*EMPTY, t, fi, ids=[]), zoom=zoom)
        fi += 1
    assert s_id in c._lost and t_id in c._lost
    _, tr2 = c.update(snap(new_pts, [[-20.0, 0.0]] * 2, 20.0, fi, ids=[5, 6]), zoom=zoom)
    assert len(tr2) == 1
    return int(tr2.ids[0]), s_id, t_id, c


def test_defaults_and_off_takes_the_nearer_box():
    d = ClusterParams()  # on by default since session 23
    assert (d.relink_side_h_ratio, d.relink_side_h_n, d.relink_undo_hand_over) == (3.0, 5, True)
    assert _box_h(TALL) > 3 * _box_h(NEW_SMALL)
    got, s_id, t_id, c = _run(NEW_SMALL)
    assert got == t_id  # the tall boat's carried box is the nearer: the small cluster takes its identity
    assert s_id in c._lost


def test_side_lost_identity_keeps_its_size():
    got, s_id, t_id, c = _run(NEW_SMALL, relink_side_h_ratio=2.0)
    assert got == s_id  # the tall boat's identity refused (28 px against 8), the small boat's taken
    assert t_id in c._lost and t_id in c._lost_side and s_id not in c._lost
    assert [round(h) for h, _ in c._whole_h[t_id]] == [round(_box_h(TALL))] * 2  # only the boxes clear of the edge


def test_inside_the_image_the_check_does_not_apply():
    got, s_id, t_id, c = _run(NEW_SMALL, edge=False, relink_side_h_ratio=2.0)
    assert got == t_id  # lost inside the image: unchanged (the lost box itself tells the size there)
    assert not c._lost_side


def test_the_zoom_scales_the_remembered_height():
    # at zoom 3 the small boat is expected 24 px tall: the 8 px cluster is neither boat
    got, s_id, t_id, c = _run(NEW_SMALL, zoom=3.0, relink_side_h_ratio=2.0)
    assert got not in (s_id, t_id) and s_id in c._lost and t_id in c._lost
    # a 24 px cluster at zoom 3 is the small boat (the tall one is expected 84 px tall)
    got, s_id, t_id, _ = _run(NEW_MID, zoom=3.0, relink_side_h_ratio=2.0)
    assert got == s_id
    # at zoom 1 the same 24 px cluster is the tall boat (28 px), not the small one (8 px)
    got, s_id, t_id, _ = _run(NEW_MID, relink_side_h_ratio=2.0)
    assert got == t_id


def test_a_looser_ratio_lets_the_nearer_box_win():
    got, s_id, t_id, _ = _run(NEW_SMALL, relink_side_h_ratio=4.0)
    assert got == t_id  # 28 / 8 = 3.5 < 4



# relink_undo_hand_over: the cluster that took a lost identity dies young while a new cluster is born
# on its box (``pan`` 6 at 28.4 s: the motorboat's identity on a fragment, the boat's own cluster born)
BOAT = [[100, 60], [130, 70]]
FRAG = [[150, 60], [160, 64]]  # a fragment, 20 px right of the boat's last box
BORN = [[148, 58], [164, 68]]  # a cluster born on the fragment's box when the fragment dies
OFF3 = dict(OFF, relink_dy_h=1.5, relink_min_s=0.4)


def _undo_run(**kw):
    c = FeatureClusterer(ClusterParams(**{**OFF3, **kw}))
    vel = [[20.0, 0.0]] * 2
    c.update(snap(BOAT, vel, 0.0, 0, ids=[1, 2]))
    _, tr = c.update(snap(BOAT, vel, 0.1, 1, ids=[1, 2]))
    a_id = int(tr.ids[0])
    for k, t in enumerate((0.2, 0.3, 0.4)):
        c.update(snap(*EMPTY, t, 2 + k, ids=[]))
    assert a_id in c._lost
    lost_box = c._lost[a_id][1].copy()
    _, t5 = c.update(snap(FRAG, vel, 0.5, 5, ids=[5, 6]))
    assert [int(x) for x in t5.ids] == [a_id]  # relinked to the fragment
    c.update(snap(FRAG, vel, 0.6, 6, ids=[5, 6]))
    _, t7 = c.update(snap(BORN, vel, 0.7, 7, ids=[7, 8]))  # the fragment dies 0.2 s after the relink
    assert len(t7) == 1
    return int(t7.ids[0]), a_id, lost_box, c


def test_undo_off_is_the_old_behaviour():
    got, a_id, lost_box, c = _undo_run()
    assert got != a_id  # the new cluster keeps its own identity
    assert a_id in c._lost and np.allclose(c._lost[a_id][1], lost_box)  # lost again where it was before


def test_undo_hands_over_to_the_cluster_born_on_the_box():
    got, a_id, _, c = _undo_run(relink_undo_hand_over=True)
    assert got == a_id and a_id not in c._lost
    # without the relink_min_s undo the ordinary hand-over does the same
    got, a_id, _, c = _undo_run(relink_min_s=0.0)
    assert got == a_id


def test_undo_hand_over_needs_an_overlap():
    far = [[200, 58], [216, 68]]  # born away from the fragment's box
    c = FeatureClusterer(ClusterParams(**{**OFF3, "relink_undo_hand_over": True}))
    vel = [[20.0, 0.0]] * 2
    c.update(snap(BOAT, vel, 0.0, 0, ids=[1, 2]))
    _, tr = c.update(snap(BOAT, vel, 0.1, 1, ids=[1, 2]))
    a_id = int(tr.ids[0])
    for k, t in enumerate((0.2, 0.3, 0.4)):
        c.update(snap(*EMPTY, t, 2 + k, ids=[]))
    c.update(snap(FRAG, vel, 0.5, 5, ids=[5, 6]))
    c.update(snap(FRAG, vel, 0.6, 6, ids=[5, 6]))
    _, t7 = c.update(snap(far, vel, 0.7, 7, ids=[7, 8]))
    assert int(t7.ids[0]) != a_id and a_id in c._lost  # undone as before
