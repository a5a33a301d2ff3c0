"""The "no AIS" alert against hand-made AIS sequences with exact timing: MMSIs heard without a
position (static data only), lost position reports, and the bound on how long an alert waits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from seawatch.camera import CameraModel, Intrinsics
from seawatch.config import FusionSettings
from seawatch.fuse import Fuser
from seawatch.fuse.table import KN_TO_MPS
from seawatch.types import AISReport, CameraPose, Tracks, TrackState

POSE = CameraPose(lat_deg=50.80, lon_deg=-1.10, height_m=20.0, pan_deg=90.0, tilt_deg=-1.0)
CAM = CameraModel(Intrinsics.from_fov(60.0, 1280, 720), POSE)
FPS = 5.0

# camera vessels: (track id, east m, north m at t = 0, north velocity m/s, length m)
RIB = (8, 800.0, 0.0, 8.0, 8.0)  # no AIS; 15.5 kn across the line of sight: class A would report every 6 s
FERRY = (3, 1200.0, -300.0, 6.0, 40.0)  # 11.7 kn: class A reports every 10 s
FAR_SHIP = (1, 2500.0, 900.0, -2.0, 80.0)  # reports every 10 s from the start of the feed


def _enu(v, t):
    return v[1], v[2] + v[3] * t


def _box(v, t):
    e, n = _enu(v, t)
    u, vv, _ = CAM.enu_to_pixel(e, n, 0.0)
    w = v[4] * CAM.intrinsics.fx / math.hypot(e, n)
    return [u - w / 2, vv - 0.4 * w, w, 0.4 * w]


def _position(mmsi, v, t_rx, t_tx=None):
    e, n = _enu(v, t_rx if t_tx is None else t_tx)
    lat, lon, _ = CAM.enu_to_geodetic(e, n, 0.0)
    return AISReport(mmsi, t_rx, float(lat), float(lon), abs(v[3]) / KN_TO_MPS, 0.0 if v[3] >= 0 else 180.0,
                     msg_type=1)


def _static(mmsi, t_rx, msg_type=5, length_m=40.0):
    return AISReport(mmsi, t_rx, name=f"SHIP{mmsi % 1000}", ship_type=60, length_m=length_m, msg_type=msg_type)


def _reports(mmsi, v, times):
    return [_position(mmsi, v, t) for t in times]


def _first_no_ais(settings, reports, vessels, t1=50.0, keep=None):
    """Run camera tracks of ``vessels`` (ground-truth boxes) from t = 0 to ``t1``; the first
    ``no_ais`` alert time per track id, and every alert message (the fuser appended to ``keep``)."""
    fuser = Fuser(CAM, settings, ais=reports)
    if keep is not None:
        keep.append(fuser)
    got, msgs = {}, []
    for k in range(int(round(t1 * FPS)) + 1):
        t = k / FPS
        tr = Tracks(t, k, np.array([v[0] for v in vessels], np.int64), np.array([_box(v, t) for v in vessels]),
                    states=np.full(len(vessels), int(TrackState.CONFIRMED), np.int8))
        for a in fuser.update(tr, None, t)[1]:
            if a.kind == "no_ais":
                got.setdefault(a.track_id, a.t_s)
                msgs.append(a.message)
    return got, msgs


WARM = _reports(235000001, FAR_SHIP, np.arange(-400.0, 60.0, 10.0))  # a feed live for minutes


def test_warm_feed_flags_after_the_dwell():
    got, _ = _first_no_ais(FusionSettings(), WARM, [RIB, FAR_SHIP], t1=20.0)
    assert got == {8: pytest.approx(5.0, abs=0.21)}


def test_static_only_mmsi_holds_the_alert_then_releases_it_after_the_bound():
    # a class A MMSI heard at 2 s through static data only (message 5), never located: it could be
    # the RIB until its position reports are due -- class A at the RIB's speed every 6 s, one of
    # them lost: 2 x 6 + 2 s latency
    reps = WARM + [_static(235000002, 2.0, 5)]
    got, msgs = _first_no_ais(FusionSettings(), reps, [RIB, FAR_SHIP])
    assert got == {8: pytest.approx(2.0 + 2 * 6.0 + 2.0, abs=0.21)}
    assert "MMSI 235000002 (class A" in msgs[0]
    # the bound is a setting
    got, _ = _first_no_ais(FusionSettings(no_ais_unlocated_hold_s=10.0), reps, [RIB, FAR_SHIP])
    assert got == {8: pytest.approx(12.0, abs=0.21)}
    # 0 turns the hold off: flagged after the dwell
    got, _ = _first_no_ais(FusionSettings(no_ais_unlocated_hold_s=0.0), reps, [RIB, FAR_SHIP])
    assert got == {8: pytest.approx(5.0, abs=0.21)}
    # a slow camera vessel (class A every 3 min): the hold ends at the 30 s bound
    slow = (8, 700.0, -250.0, 0.8, 12.0)
    got, _ = _first_no_ais(FusionSettings(), reps, [slow, FAR_SHIP], t1=40.0)
    assert got == {8: pytest.approx(32.0, abs=0.21)}


def test_class_b_heard_without_a_position_is_named_but_not_waited_for():
    # class B reports every 30 s; like a class B never heard, it is not waited for (class A is what
    # a VTS must see), but the alert names it
    reps = WARM + [_static(235000002, 2.0, 24)]
    got, msgs = _first_no_ais(FusionSettings(), reps, [RIB, FAR_SHIP], t1=20.0)
    assert got == {8: pytest.approx(5.0, abs=0.21)}
    assert "MMSI 235000002 (class B" in msgs[0]


def test_static_only_mmsi_stops_holding_once_located_elsewhere():
    # heard at 2 s without a position, located at 9 s far from the RIB (the far ship's position):
    # from then on it cannot be the RIB, which is flagged at once
    reps = WARM + [_static(235000002, 2.0), _position(235000002, FAR_SHIP, 9.0)]
    got, _ = _first_no_ais(FusionSettings(), reps, [RIB, FAR_SHIP])
    assert got == {8: pytest.approx(9.0, abs=0.21)}


def test_static_first_then_a_lost_position_report_does_not_flag_the_ferry():
    # the harbour seed-14 case: a cold start (the feed's first report at 0.5 s), the ferry's static
    # message at 3.7 s, its position report sent at 7.7 s lost, the next received at 19.4 s
    cold = _reports(235000001, FAR_SHIP, np.arange(0.5, 60.0, 10.0))
    ferry = [_static(235000003, 3.7)] + _reports(235000003, FERRY, np.arange(19.4, 60.0, 10.0))
    got, _ = _first_no_ais(FusionSettings(), cold + ferry, [FERRY, FAR_SHIP])
    assert got == {}
    # without the static message (a vessel never heard): by default one interval + latency after
    # the feed went live, a false alert; tolerating a lost first report of unheard vessels holds it
    got, _ = _first_no_ais(FusionSettings(), cold + ferry[1:], [FERRY, FAR_SHIP])
    assert got == {3: pytest.approx(12.6, abs=0.21)}
    got, _ = _first_no_ais(FusionSettings(no_ais_unheard_lost_reports=1), cold + ferry[1:], [FERRY, FAR_SHIP])
    assert got == {}
    # the rule before: one interval + latency after the feed went live (12.5 s), then a false alert
    got, _ = _first_no_ais(FusionSettings(no_ais_lost_reports=0, no_ais_unlocated_hold_s=0.0),
                           cold + ferry, [FERRY, FAR_SHIP])
    assert got == {3: pytest.approx(12.6, abs=0.21)}


def test_a_dropped_report_in_a_warm_feed_does_not_flag():
    # a ferry reporting every 10 s for minutes; reports at 0 s and 10 s are lost: its last position
    # is 20 s old at 10 s and it stays identified (dead reckoning), no alert
    ferry = [r for r in _reports(235000003, FERRY, np.arange(-300.0, 60.0, 10.0)) if r.t_s not in (0.0, 10.0)]
    got, _ = _first_no_ais(FusionSettings(), WARM + ferry + [_static(235000003, -300.0)], [FERRY, RIB, FAR_SHIP])
    assert got == {8: pytest.approx(5.0, abs=0.21)}


@pytest.mark.parametrize("unheard_lost, expect_s", [(0, 0.5 + 6.0 + 2.0), (1, 0.5 + 2 * 6.0 + 2.0)])
def test_a_silent_boat_is_flagged_within_the_bound_at_a_cold_start(unheard_lost, expect_s):
    # the feed's first report at 0.5 s; the RIB (class A would report every 6 s) is flagged one
    # interval (+ one per tolerated lost report) + 2 s latency later
    cold = _reports(235000001, FAR_SHIP, np.arange(0.5, 60.0, 10.0))
    s = FusionSettings(no_ais_unheard_lost_reports=unheard_lost)
    got, _ = _first_no_ais(s, cold, [RIB, FAR_SHIP], t1=30.0)
    assert got == {8: pytest.approx(expect_s, abs=0.21)}
    # with a class A heard without a position at 1 s and never located: 2 x 6 s + 2 s after it
    got, _ = _first_no_ais(s, cold + [_static(235000009, 1.0, 5)], [RIB, FAR_SHIP], t1=40.0)
    assert got == {8: pytest.approx(max(expect_s, 1.0 + 2 * 6.0 + 2.0), abs=0.21)}


@pytest.mark.parametrize("key", ["no_ais_lost_reports", "no_ais_unheard_lost_reports"])
@pytest.mark.parametrize("value", [-1, 1.5, 11])
def test_invalid_lost_reports_setting_is_rejected(key, value):
    with pytest.raises(ValueError, match=key):
        Fuser(CAM, FusionSettings(**{key: value}))


def test_a_position_report_without_a_fix_holds_the_alert_like_static_data():
    # a class A vessel whose GNSS has no fix sends position reports with lat 91 / lon 181 ("not
    # available"): the decoder keeps them without a position, and the fuser holds the RIB's alert
    # as for an MMSI heard through static data only
    from pyais import encode_dict

    from seawatch.io.ais import NMEADecoder

    dec = NMEADecoder()
    (line,) = encode_dict({"msg_type": 1, "mmsi": 235000002, "lat": 91, "lon": 181},
                          talker_id="AI", sentence_type="VDM", radio_channel="A")
    (nofix,) = dec.feed(line, t_s=2.0)
    assert not nofix.has_position and dec.stats.rejected["invalid_position"] == 1
    got, msgs = _first_no_ais(FusionSettings(), WARM + [nofix], [RIB, FAR_SHIP])
    assert got == {8: pytest.approx(2.0 + 2 * 6.0 + 2.0, abs=0.21)}
    assert "MMSI 235000002 (class A" in msgs[0]


def _nofix(mmsi, t_rx):
    """A class A position report without a GNSS fix (decoded lat 91 / lon 181: no position)."""
    return AISReport(mmsi, t_rx, msg_type=1)


def test_an_mmsi_heard_without_a_fix_for_minutes_is_named_but_not_held():
    # no GNSS fix since long before the video: reports every 10 s since -400 s.  It is named in the
    # alert while it is heard; the hold counts from when it was first heard (long ago), so none
    reps = WARM + [_nofix(235000002, t) for t in np.arange(-400.0, 60.0, 10.0)]
    keep = []
    got, msgs = _first_no_ais(FusionSettings(), reps, [RIB, FAR_SHIP], t1=20.0, keep=keep)
    assert got == {8: pytest.approx(5.0, abs=0.21)}
    assert "MMSI 235000002 (class A, since 405 s)" in msgs[0]
    assert list(keep[0]._heard) == [235000002]


def test_an_mmsi_heard_again_after_a_long_silence_holds_the_alert_anew():
    # heard once 400 s ago (longer ago than ais_max_age_s = 360 s), heard again at 2 s: the hold
    # counts from 2 s, as for an MMSI never heard before
    reps = WARM + [_static(235000002, -400.0), _static(235000002, 2.0)]
    got, msgs = _first_no_ais(FusionSettings(), reps, [RIB, FAR_SHIP])
    assert got == {8: pytest.approx(2.0 + 2 * 6.0 + 2.0, abs=0.21)}
    assert "MMSI 235000002 (class A, since 14 s)" in msgs[0]


def test_mmsis_heard_without_a_position_are_forgotten_after_the_max_age():
    # heard at 2 s, never again: after ais_max_age_s it is no longer held, named or kept
    s = FusionSettings(ais_max_age_s=20.0)
    reps = _reports(235000001, FAR_SHIP, np.arange(-100.0, 60.0, 10.0)) + [_static(235000002, 2.0)]
    keep = []
    _first_no_ais(s, reps, [FAR_SHIP], t1=21.0, keep=keep)
    assert list(keep[0]._heard) == [235000002]
    keep = []
    _first_no_ais(s, reps, [FAR_SHIP], t1=23.0, keep=keep)
    assert keep[0]._heard == {}


def test_a_vessel_whose_gnss_fails_mid_voyage_holds_once_its_position_is_stale():
    # positions until -370 s, then no fix (a report every 6 s): its last position is older than
    # ais_max_age_s (360 s) from -4 s on, when it counts as heard without a position: held to
    # -4 + 2 x 6 + 2 = 10 s, and named
    far = (0, 3000.0, -2000.0, 0.0, 30.0)
    reps = (WARM + _reports(235000002, far, np.arange(-600.0, -369.0, 10.0))
            + [_nofix(235000002, t) for t in np.arange(-364.0, 60.0, 6.0)])
    got, msgs = _first_no_ais(FusionSettings(), reps, [RIB, FAR_SHIP], t1=20.0)
    assert got == {8: pytest.approx(10.0, abs=0.21)}
    assert "MMSI 235000002 (class A" in msgs[0]


class _LaggedListener:
    """A live feed: one static message, time-stamped 0.3 s after the frame at which it arrives."""

    def __init__(self, k_arrive, t_stamp):
        self.k, self.k_arrive, self.t_stamp = 0, k_arrive, t_stamp

    def poll(self):
        self.k += 1
        return [_static(235000002, self.t_stamp)] if self.k - 1 == self.k_arrive else []


def test_a_report_time_stamped_after_the_frame_still_holds_the_alert():
    # the RIB is due at 8 s (live 6 s interval + 2 s latency); a static message stamped 8.3 s
    # arrives with the 8.0 s frame (processing lag): held until 8.3 + 14 s
    got, msgs = _first_no_ais(FusionSettings(), _LaggedListener(40, 8.3), [RIB])
    assert got == {8: pytest.approx(8.3 + 2 * 6.0 + 2.0, abs=0.21)}
    assert "MMSI 235000002 (class A" in msgs[0]
