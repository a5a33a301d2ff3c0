"""Session 22 (issue #8, helper H1): a coast whose grow at the expected box fails looks around it
(``coast_search``), below the horizon band only (``coast_search_below_px``)."""

import numpy as np

from _feature_snap import snap
from seawatch.detect.horizon import Horizon
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer
from seawatch.types import TrackState

SHAPE = (160, 240)
BOAT = (100, 59, 112, 64)  # x0, y0, x1, y1 (exclusive) of the dark boat


def sea(seed, boat=True, dx=0, dy=0):
    """Grey sea (120, noise 2) with a dark boat (60) at ``BOAT`` moved by ``dx``, ``dy`` px."""
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, SHAPE)
    if boat:
        x0, y0, x1, y1 = BOAT
        img[y0 + dy:y1 + dy, x0 + dx:x1 + dx] = 60.0
    return np.clip(img, 0, 255).astype(np.uint8)


def run(horizon_row=None, dx=10, **kw):
    """The boat seen for 6 frames, then its features gone while it jumps 10 px right and 3 px down
    (off the expected box's core: the camera moved more than its motion model said); returns the
    boat's identity and the tracks of the frame after."""
    base = dict(confirm_s=0.0, relink_s=10.0, coast_s=1.0)
    base.update(kw)
    c = FeatureClusterer(ClusterParams(**base))
    hz = None if horizon_row is None else Horizon(horizon_row, horizon_row, SHAPE[1])
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[102, 61], [110, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]), sea(k), horizon=hz)
    assert len(tr) == 1
    ident = int(tr.ids[0])
    tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.6, 6, []), sea(6, dx=dx, dy=3), horizon=hz)[1]
    return c, ident, tr


def test_off_by_default_and_the_jumped_boat_is_not_coasted_without_it():
    assert ClusterParams().coast_search == 0.0
    assert ClusterParams().coast_search_below_px == 12.0
    c, _, tr = run()
    assert len(tr) == 0
    assert [e[3] for e in c.coast_log] == ["not found"]


def test_the_search_finds_the_boat_next_to_the_expected_box():
    c, ident, tr = run(coast_search=1.0)
    assert tr.ids.tolist() == [ident]
    assert tr.states.tolist() == [int(TrackState.COASTING)]
    x, y, w, h = tr.boxes[0]
    x0, y0, x1, y1 = BOAT
    assert abs(x - (x0 + 10)) <= 1 and abs(x + w - (x1 + 10)) <= 1
    assert abs(y - (y0 + 3)) <= 1 and abs(y + h - (y1 + 3)) <= 1
    assert [e[3] for e in c.coast_log] == ["searched"]


def test_the_search_reaches_coast_search_boxes_away():
    # 20 px right (1.7 box widths): shifted by up to one box the core misses it, by 1.5 it is on it
    c, _, tr = run(coast_search=1.0, dx=20)
    assert len(tr) == 0
    assert [e[3] for e in c.coast_log] == ["not found"]
    c, ident, tr = run(coast_search=1.5, dx=20)
    assert tr.ids.tolist() == [ident]
    assert abs(tr.boxes[0, 0] - (BOAT[0] + 20)) <= 1


def test_no_search_in_the_horizon_band():
    # the expected box's bottom (row 64) lies 4 px below a horizon at row 60: inside a 12 px band
    _, _, tr = run(horizon_row=60.0, coast_search=1.0)
    assert len(tr) == 0
    # a band of 3 px: searched
    _, ident, tr = run(horizon_row=60.0, coast_search=1.0, coast_search_below_px=3.0)
    assert tr.ids.tolist() == [ident]
    # off (0): anywhere
    _, ident, tr = run(horizon_row=60.0, coast_search=1.0, coast_search_below_px=0.0)
    assert tr.ids.tolist() == [ident]


def test_open_water_is_still_not_coasted():
    base = dict(confirm_s=0.0, relink_s=10.0, coast_s=1.0, coast_search=1.5)
    c = FeatureClusterer(ClusterParams(**base))
    for k in range(6):
        c.update(snap([[102, 61], [110, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]), sea(k))
    tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.6, 6, []), sea(6, boat=False))[1]
    assert len(tr) == 0


def retry_run(horizon_row=None, **kw):
    """The boat seen for 6 frames, its features then gone; the image shows it in frames 6 and 8-9
    but not in frame 7 (a wave over it): the reports of frames 6-9."""
    base = dict(confirm_s=0.0, relink_s=10.0, coast_s=2.0)
    base.update(kw)
    c = FeatureClusterer(ClusterParams(**base))
    hz = None if horizon_row is None else Horizon(horizon_row, horizon_row, SHAPE[1])
    for k in range(6):
        c.update(snap([[102, 61], [110, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]), sea(k), horizon=hz)
    out = []
    for k in range(6, 10):
        tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.1 * k, k, []), sea(k, boat=k != 7), horizon=hz)[1]
        out.append(tr.ids.tolist())
    return out


def test_retry_on_by_default_and_off_the_coast_ends_at_the_first_failed_look():
    assert ClusterParams().coast_retry_s == 1.0
    assert retry_run() == [[1], [], [1], [1]]
    got = retry_run(coast_retry_s=0.0)
    assert got[0] == [1] and got[1:] == [[], [], []]


def test_with_retry_the_coast_comes_back_after_a_failed_look():
    got = retry_run(coast_retry_s=0.5)
    assert got == [[1], [], [1], [1]]


def test_retry_ends_after_coast_retry_s_of_failed_looks():
    # the boat gone for good from frame 7: looked at in frames 7, 8 (0.1 s < 0.15 s), ended at frame 9
    base = dict(confirm_s=0.0, relink_s=10.0, coast_s=2.0, coast_retry_s=0.15)
    c = FeatureClusterer(ClusterParams(**base))
    for k in range(6):
        c.update(snap([[102, 61], [110, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]), sea(k))
    seen = []
    for k in range(6, 12):
        tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.1 * k, k, []), sea(k, boat=k < 7 or k > 9))[1]
        seen.append(len(tr))
    assert seen[0] == 1
    assert [e[3] for e in c.coast_log][1:] == ["not found", "not found", "not found"]  # frames 7-9, then no look
    assert seen[1:] == [0, 0, 0, 0, 0]  # back in the image at frame 10, but the coast has ended


def test_no_retry_in_the_horizon_band():
    # expected box's bottom at row 64, horizon at row 60: inside the 12 px band, the coast ends as without retry
    assert retry_run(horizon_row=60.0, coast_retry_s=0.5) == [[1], [], [], []]
    assert retry_run(horizon_row=60.0, coast_retry_s=0.5, coast_search_below_px=3.0) == [[1], [], [1], [1]]


def test_coast_max_aspect_drops_a_coasted_line():
    # the boat's features gone; at the expected place the image shows a flat line (28 x 2 px, the
    # horizon's texture), about the box's area: coasted without the rule, not with it
    def line_sea(seed):
        img = sea(seed, boat=False).astype(np.float64)
        img[61:63, 92:120] = 60.0
        return img.astype(np.uint8)

    got = {}
    for on in (False, True):
        c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=10.0, coast_s=2.0, coast_max_aspect=on))
        for k in range(6):
            c.update(snap([[102, 61], [110, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]), sea(k))
        tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.6, 6, []), line_sea(6))[1]
        got[on] = tr
    assert len(got[False]) == 1 and got[False].boxes[0][2] > 12 * got[False].boxes[0][3]
    assert len(got[True]) == 0
    assert ClusterParams().coast_max_aspect is False
