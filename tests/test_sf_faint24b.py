"""Session 24, round 2 (issue #8, helper H10): ``coast_look_up``.  A coast whose expected box was the
hull alone (a faint sailboat's cluster held its hull, the sail stands above it) and whose grow there
is not found is grown once more from the box extended upward: the boat is reported (outcome "up")
and followed; open water, a line and a boat reported now are not taken; off (0) by default."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
BOAT = (100, 60, 107, 76)  # x0, y0, x1, y1 (exclusive): a 7 x 16 px dark sail and hull
HULL_BOX = np.array([100.6, 70.2, 6.0, 6.9])  # the expected box: the boat's hull (its lowest rows) and water under it


def sea(seed, boat=True, line=False):
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, SHAPE)
    if boat:
        x0, y0, x1, y1 = BOAT
        img[y0:y1, x0:x1] = 60.0  # the sail
        img[y1 - 4:y1, x0:x1] = 90.0  # the hull: fainter than the sail
    if line:
        img[62:64, 20:220] = 60.0  # a long thin line (the horizon's texture), no boat
    return np.clip(img, 0, 255).astype(np.uint8)


def _coast_lost(img, box, vel, reported, base, kw):
    """One lost identity (7; reported 1 s, lost 0.2 s ago at ``box`` with velocity ``vel``) coasted
    in one frame; returns (clusterer, ids, boxes, the coast's outcome)."""
    c = FeatureClusterer(ClusterParams(**{**base, **kw}))
    c._birth[7] = 0.0
    c._lost[7] = (1.0, box, vel)
    s = snap(np.zeros((0, 2)), np.zeros((0, 2)), 1.2, 12, [], shape=SHAPE)
    rep = np.zeros((0, 4)) if reported is None else np.asarray(reported, float).reshape(-1, 4)
    ids, boxes, _ = c._coast(s, rep, image=img)
    return c, ids, boxes, c.coast_log[-1][3]


def coast_once(img, reported=None, **kw):
    """One lost identity (reported 1 s, lost 0.2 s ago at ``HULL_BOX``) coasted in one frame."""
    base = dict(coast_s=5.0, coast_retry_s=0.0, coast_edge=0.0, coast_look_ahead=0.0)  # the look up alone
    return _coast_lost(img, HULL_BOX.copy(), None, reported, base, kw)


def test_on_by_default_since_session_24_and_off_the_hull_alone_is_not_found():
    assert ClusterParams().coast_look_up == 1.0  # the lead's decision W (0: off)
    c, ids, boxes, why = coast_once(sea(1), coast_look_up=0.0)
    assert len(ids) == 0 and why == "not found"
    assert c._coast_end.get(7) == 1.0  # the coast ended (no retry here)


def test_look_up_finds_the_boat_above_its_hull_and_follows_it():
    c, ids, boxes, why = coast_once(sea(1), coast_look_up=1.0)
    assert why == "up" and list(ids) == [7]
    x, y, w, h = boxes[0]
    x0, y0, x1, y1 = BOAT
    assert y <= y0 + 2 and y + h >= y1 - 5  # the sail's top is in the box, and the hull's row
    assert x <= x0 + 1 and x + w >= x1 - 1
    assert np.allclose(c._lost[7][1], boxes[0])  # followed: the grown box is the expected one now
    assert 7 not in c._coast_end


def test_look_up_does_not_take_open_water_or_a_line():
    _, ids, _, why = coast_once(sea(2, boat=False), coast_look_up=1.0)
    assert len(ids) == 0 and why == "not found"
    _, ids, _, why = coast_once(sea(3, boat=False, line=True), coast_look_up=1.0)
    assert len(ids) == 0


def test_look_up_does_not_take_a_boat_reported_now():
    rep = [[99.0, 59.0, 9.0, 18.0]]  # the boat is reported by another identity in this frame
    _, ids, _, why = coast_once(sea(1), reported=rep, coast_look_up=1.0)
    assert len(ids) == 0


def test_look_up_method_extends_by_the_factor():
    c = FeatureClusterer(ClusterParams(coast_look_up=0.2))
    out, ok = c._coast_look_up(sea(1), HULL_BOX[None, :], np.zeros((0, 4)))
    assert out.shape == (1, 4) and ok.shape == (1,) and not ok[0]  # too little above the hull to find the boat
    c2 = FeatureClusterer(ClusterParams(coast_look_up=1.0))
    out2, ok2 = c2._coast_look_up(sea(1), HULL_BOX[None, :], np.zeros((0, 4)))
    assert ok2[0]
    assert out2[0, 1] < HULL_BOX[1] - 3  # reaches above the expected box


# coast_look_ahead: the expected box lags behind a boat moving on its own (the camera alone moved the box)
FERRY = (110, 60, 130, 80)  # a 20 x 20 px dark boat


def ferry_sea(seed, boat=True):
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, SHAPE)
    if boat:
        x0, y0, x1, y1 = FERRY
        img[y0:y1, x0:x1] = 60.0
    return np.clip(img, 0, 255).astype(np.uint8)


def coast_ahead(img, vx, lag=-17.0, reported=None, **kw):
    """One lost identity whose expected box lies ``-lag`` px behind the ferry (to its left when the
    lag is negative), lost 0.2 s ago with its own velocity ``vx`` px/s, coasted in one frame."""
    base = dict(coast_s=5.0, coast_retry_s=0.0, coast_edge=0.0, coast_look_up=0.0)  # the look ahead alone
    box = np.array([FERRY[0] + lag, FERRY[1], 20.0, 20.0])
    return _coast_lost(img, box, np.array([vx, 0.0]), reported, base, kw)


def test_look_ahead_on_by_default_since_session_24_and_off_the_lagging_box_is_not_found():
    assert ClusterParams().coast_look_ahead == 0.5  # the lead's decision W (0: off)
    _, ids, _, why = coast_ahead(ferry_sea(1), 40.0, coast_look_ahead=0.0)
    assert len(ids) == 0 and why == "not found"


def test_look_ahead_finds_the_boat_in_its_direction_only():
    c, ids, boxes, why = coast_ahead(ferry_sea(1), 40.0, coast_look_ahead=0.5)
    assert why == "ahead" and list(ids) == [7]
    x, y, w, h = boxes[0]
    assert abs(x - FERRY[0]) <= 2 and abs(w - 20) <= 3
    assert np.allclose(c._lost[7][1], boxes[0])  # followed
    # moving left, the look goes left, away from the boat: not found
    _, ids, _, why = coast_ahead(ferry_sea(1), -40.0, coast_look_ahead=0.5)
    assert len(ids) == 0
    # no own velocity known: no look ahead
    _, ids, _, why = coast_ahead(ferry_sea(1), 0.0, coast_look_ahead=0.5)
    assert len(ids) == 0


def test_look_ahead_does_not_take_water_or_a_reported_boat():
    _, ids, _, _ = coast_ahead(ferry_sea(2, boat=False), 40.0, coast_look_ahead=0.5)
    assert len(ids) == 0
    _, ids, _, _ = coast_ahead(ferry_sea(1), 40.0, reported=[[109.0, 59.0, 22.0, 22.0]], coast_look_ahead=0.5)
    assert len(ids) == 0
