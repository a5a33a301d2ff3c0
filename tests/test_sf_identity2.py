"""Session 21 (issue #8, one identity per boat on ``ir``, the boat back at the end of the pan):
a small boat's identity is not handed over to a much larger report (``hand_over_size_ratio``), a
large boat's identity is not relinked to a much smaller cluster (``relink_min_area``), and an
identity taken by a cluster that dies soon after the relink is still expected where it was before
that relink (``relink_alt_s``).  On by default: ``hand_over_height_ratio`` 3, ``relink_min_area``
0.3 with ``relink_area_same_zoom``, ``relink_alt_s`` 3 s; ``hand_over_size_ratio`` off.  Each test
switches off the steps it does not look at (``OFF``)."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

EMPTY = (np.zeros((0, 2)), np.zeros((0, 2)))
OFF = dict(hand_over_size_ratio=0.0, hand_over_height_ratio=0.0, relink_min_area=0.0, relink_area_same_zoom=False,
           relink_alt_s=0.0)


def _params(**kw):
    return ClusterParams(**{**OFF, **kw})


def test_defaults():
    p = ClusterParams()
    assert p.hand_over_size_ratio == 0.0 and p.hand_over_height_ratio == 3.0
    assert p.relink_min_area == 0.3 and p.relink_area_same_zoom and p.relink_alt_s == 3.0


def _small_inside_large(**kw):
    """An older small cluster (two features 4 px apart, moving +20 px/s in x: an 8 x 5 px box) inside
    a younger large one (two features at (90, 50) and (130, 75), moving +20 px/s in y: 44 x 29 px),
    reported apart (no overlap merge); then the small one's features are gone."""
    c = FeatureClusterer(_params(confirm_s=0.0, relink_s=2.0, relink_overlap=0.3, merge_overlap=0.0,
                                 coast_s=0.0, **kw))
    xy = [[100, 60], [104, 61], [90, 50], [130, 75]]
    vel = [[20, 0], [20, 0], [0, 20], [0, 20]]
    _, tr = c.update(snap(xy, vel, 0.0, 0, ids=[1, 2, 3, 4]))
    _, tr = c.update(snap(xy, vel, 0.1, 1, ids=[1, 2, 3, 4]))
    assert len(tr) == 2
    small = int(tr.ids[np.argmin(tr.boxes[:, 2] * tr.boxes[:, 3])])
    large = int(tr.ids[np.argmax(tr.boxes[:, 2] * tr.boxes[:, 3])])
    ratio = float(np.max(tr.boxes[:, 2] * tr.boxes[:, 3]) / np.min(tr.boxes[:, 2] * tr.boxes[:, 3]))
    _, tr = c.update(snap(xy[2:], vel[2:], 0.2, 2, ids=[3, 4]))
    return small, large, ratio, tr.ids.tolist(), c


def test_hand_over_refused_to_a_much_larger_report():
    small, large, ratio, now, c = _small_inside_large()
    assert small < large and 20 < ratio < 40  # 44 x 29 against 8 x 5: about 32 times the area
    assert now == [small]  # off: the large cluster takes the small one's older identity
    small, large, ratio, now, c = _small_inside_large(hand_over_size_ratio=5.0)
    assert now == [large] and small in c._lost  # refused: the small boat's identity stays lost
    small, large, ratio, now, c = _small_inside_large(hand_over_size_ratio=40.0)
    assert now == [small]  # within 40 times its area: handed over as before


def test_hand_over_refused_to_a_much_taller_report():
    """``hand_over_height_ratio``: the same by the heights (29 px against 5 px: 5.8 times)."""
    small, large, ratio, now, c = _small_inside_large(hand_over_height_ratio=3.0)
    assert now == [large] and small in c._lost
    small, large, ratio, now, c = _small_inside_large(hand_over_height_ratio=6.0)
    assert now == [small]


def _relink_to(new_xy, zoom_now=1.0, **kw):
    """A cluster of two features at (100, 60) and (130, 70) (a 34 x 14 px box) is lost at 0.2 s
    (zoom 1); at 0.5 s a cluster of two features at ``new_xy`` appears (within the relink gate), at
    zoom ``zoom_now``.  Returns (the lost identity, the new report's identity, the clusterer)."""
    c = FeatureClusterer(_params(confirm_s=0.0, relink_s=10.0, coast_s=0.0, **kw))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap([[100, 60], [130, 70]], vel, 0.0, 0, ids=[1, 2]))
    c.update(snap([[100, 60], [130, 70]], vel, 0.1, 1, ids=[1, 2]))
    for k in range(2, 5):
        c.update(snap(*EMPTY, 0.1 * k, k, ids=[]))
    _, tr2 = c.update(snap(new_xy, vel, 0.5, 5, ids=[3, 4]), zoom=zoom_now)
    assert len(tr2) == 1
    return int(tr.ids[0]), int(tr2.ids[0]), c


def test_relink_refused_to_a_much_smaller_cluster():
    small = [[110, 64], [113, 65]]  # a 7 x 5 px box: 0.07 of the lost 34 x 14 px box
    first, now, _ = _relink_to(small)
    assert now == first  # off: relinked
    first, now, c = _relink_to(small, relink_min_area=0.3)
    assert now != first and first in c._lost  # refused; the identity stays lost
    first, now, _ = _relink_to([[102, 60], [128, 69]], relink_min_area=0.3)  # 30 x 13 px: 0.82 of it
    assert now == first
    first, now, _ = _relink_to(small, relink_min_area=0.05)
    assert now == first


def test_relink_area_check_only_at_the_same_zoom():
    """With ``relink_area_same_zoom`` the area check applies only when the zoom is (within 5 %) the
    one at the loss: the lost box's size is not trusted through a zoom change."""
    small = [[110, 64], [113, 65]]
    kw = dict(relink_min_area=0.3, relink_area_same_zoom=True)
    first, now, _ = _relink_to(small, zoom_now=1.04, **kw)
    assert now != first  # the same zoom: checked, refused
    first, now, _ = _relink_to(small, zoom_now=2.0, **kw)
    assert now == first  # the zoom changed: not checked
    first, now, _ = _relink_to(small, zoom_now=2.0, relink_min_area=0.3)
    assert now != first  # without relink_area_same_zoom: checked whatever the zoom


def _flash_then_back(alt_s, back_x=70.0):
    """A boat at x 100-110 (reported 0-0.1 s) is lost at 0.2 s.  At 3.0 s a short-lived cluster
    appears 40 px to its right (x 150-160; within the gate, 20 + 10 px/s x 2.8 s = 48 px) and takes
    its identity; it dies at 3.6 s (0.6 s old: past ``relink_min_s`` 0.4).  At 4.0 s a cluster
    appears at x ``back_x``, within the gate of the boat's own place (20 + 38 = 58 px) and far from
    the short-lived cluster's (about 80 px; gate 20 + 4 = 24 px).  Returns (the boat's identity,
    the short-lived cluster's report, the last report, the clusterer)."""
    c = FeatureClusterer(_params(confirm_s=0.0, relink_s=30.0, coast_s=0.0, relink_min_s=0.4, relink_alt_s=alt_s))
    vel = [[20.0, 0.0]] * 2
    boat = [[100, 60], [110, 62]]
    _, tr = c.update(snap(boat, vel, 0.0, 0, ids=[1, 2]))
    c.update(snap(boat, vel, 0.1, 1, ids=[1, 2]))
    fi = 2
    for k in range(2, 30):  # 0.2 - 2.9 s: nothing
        c.update(snap(*EMPTY, 0.1 * k, fi, ids=[]))
        fi += 1
    flash = [[150, 60], [160, 62]]
    reps = []
    for k in range(30, 36):  # 3.0 - 3.5 s: the short-lived cluster
        _, tf = c.update(snap(flash, vel, 0.1 * k, fi, ids=[3, 4]))
        reps.append(tf.ids.tolist())
        fi += 1
    for k in range(36, 40):  # 3.6 - 3.9 s: nothing
        c.update(snap(*EMPTY, 0.1 * k, fi, ids=[]))
        fi += 1
    _, tb = c.update(snap([[back_x, 60], [back_x + 10, 62]], vel, 4.0, fi, ids=[5, 6]))
    return int(tr.ids[0]), reps, tb.ids.tolist(), c


def test_relink_alt_keeps_the_place_before_a_short_relink():
    first, reps, last, c = _flash_then_back(0.0)
    assert all(r == [first] for r in reps)  # the short-lived cluster took the boat's identity
    assert last != [first] and first in c._lost  # off: lost where it died; the boat back gets a new identity
    first, reps, last, c = _flash_then_back(1.0)
    assert all(r == [first] for r in reps)
    assert last == [first]  # the place before the relink is still expected
    # beyond the old place's gate too (x 20: 70 px from x 100-110): not relinked
    first, reps, last, c = _flash_then_back(1.0, back_x=20.0)
    assert last != [first]


def test_relink_alt_only_for_a_cluster_dying_soon():
    """A cluster that took the identity and lived longer than ``relink_alt_s`` moves the identity
    for good: the place before the relink is forgotten."""
    first, reps, last, c = _flash_then_back(0.5)  # the short-lived cluster lived 0.6 s > 0.5 s
    assert all(r == [first] for r in reps)
    assert last != [first] and first in c._lost and first not in c._lost_alt


def test_relink_alt_still_takes_the_new_place():
    """With ``relink_alt_s`` the identity is also still expected where the short-lived cluster
    died (a cluster there takes it)."""
    first, reps, last, c = _flash_then_back(1.0, back_x=165.0)  # 5 px right of where it died
    assert last == [first]


def test_defaults_act():
    """The defaults refuse the small boat's hand-over to the taller report and the relink to the much
    smaller cluster, and keep the place before the short relink."""
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=2.0, relink_overlap=0.3, merge_overlap=0.0,
                                       coast_s=0.0))
    xy = [[100, 60], [104, 61], [90, 50], [130, 75]]
    vel = [[20, 0], [20, 0], [0, 20], [0, 20]]
    _, tr = c.update(snap(xy, vel, 0.0, 0, ids=[1, 2, 3, 4]))
    c.update(snap(xy, vel, 0.1, 1, ids=[1, 2, 3, 4]))
    _, tr2 = c.update(snap(xy[2:], vel[2:], 0.2, 2, ids=[3, 4]))
    assert tr2.ids.tolist() == [max(tr.ids.tolist())]  # the large one keeps its own identity
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=10.0, coast_s=0.0))
    v2 = [[20.0, 0.0]] * 2
    _, tr = c.update(snap([[100, 60], [130, 70]], v2, 0.0, 0, ids=[1, 2]))
    c.update(snap([[100, 60], [130, 70]], v2, 0.1, 1, ids=[1, 2]))
    for k in range(2, 5):
        c.update(snap(*EMPTY, 0.1 * k, k, ids=[]))
    _, tr2 = c.update(snap([[110, 64], [113, 65]], v2, 0.5, 5, ids=[3, 4]))
    assert tr2.ids.tolist() != tr.ids.tolist()  # not relinked to the much smaller cluster


def _memory_return(memory):
    """A boat (features 1, 2 at x 100-110) is reported 0-0.1 s and lost at 0.2 s (its features no
    longer stable); at 0.4 s the same two features are stable again at x 150-160 (the graph's label
    memory gives their cluster its identity back, no relink) and are gone again from 1.2 s (0.8 s after the return); at 3.0 s a new cluster
    appears at x 75-85: within the gate of the boat's first place (20 + 10 x 2.8 = 48 px; gap 15 px),
    far from where the returned cluster died (gap 65 px, gate 20 + 18 = 38 px)."""
    c = FeatureClusterer(_params(confirm_s=0.0, relink_s=30.0, coast_s=0.0, relink_min_s=0.4, relink_alt_s=3.0,
                                 relink_alt_memory=memory))
    vel = [[20.0, 0.0]] * 2
    _, tr = c.update(snap([[100, 60], [110, 62]], vel, 0.0, 0, ids=[1, 2]))
    c.update(snap([[100, 60], [110, 62]], vel, 0.1, 1, ids=[1, 2]))
    fi = 2
    for k in (2, 3):  # the features stay, not stable: no cluster, but the graph remembers their label
        s_ = snap([[100, 60], [110, 62]], vel, 0.1 * k, fi, ids=[1, 2])
        s_.stable = np.zeros(2, bool)
        c.update(s_)
        fi += 1
    back = []
    for k in range(4, 12):
        _, tb = c.update(snap([[150, 60], [160, 62]], vel, 0.1 * k, fi, ids=[1, 2]))
        back.append(tb.ids.tolist())
        fi += 1
    for k in range(12, 30):
        c.update(snap(*EMPTY, 0.1 * k, fi, ids=[]))
        fi += 1
    _, tn = c.update(snap([[75, 60], [85, 62]], vel, 3.0, fi, ids=[5, 6]))
    return int(tr.ids[0]), back, tn.ids.tolist(), c


def test_relink_alt_memory_keeps_the_place_before_a_return_through_the_label_memory():
    first, back, last, c = _memory_return(False)
    assert all(b == [first] for b in back)  # the label memory gave the returned cluster the identity
    assert last != [first]  # off: lost where the returned cluster died
    first, back, last, c = _memory_return(True)
    assert all(b == [first] for b in back)
    assert last == [first]  # the place before the return is still expected
