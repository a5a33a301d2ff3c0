"""A simulated AIS stream for the vessels of a synthetic world.

Each vessel with an MMSI transmits position reports at the ITU-R M.1371 rates of its class
(A: message 1, every 10 s at 0-14 kn, 3.3 s while turning, 6 s at 14-23 kn, 2 s above, 3 min when
nearly stopped; B ("CS"): message 18, every 30 s above 2 kn, 3 min below) and static data
(A: message 5, B: message 24 parts A and B) every ``static_interval_s``.  Reported positions carry
GNSS noise, reports arrive after a random latency (and a few are lost), vessels without an MMSI
never appear, and optionally one vessel's positions are spoofed (shifted by a fixed offset).

The reports are :class:`seawatch.types.AISReport` whose ``t_s`` is the **receive time** (what a
live feed sees) and whose fields hold exactly what the NMEA sentences encode (positions rounded to
AIS resolution, 1/10000 minute); :meth:`AISStream.nmea` gives the ``!AIVDM`` sentences (pyais).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d
from pyais.encode import encode_dict

from seawatch.sim.world import World
from seawatch.types import AISReport

__all__ = ["AISConfig", "AISStream", "simulate_ais", "report_interval_s", "nmea_tag_block"]

KN_PER_MPS = 3600.0 / 1852.0
AIS_DEG_RES = 1.0 / 600000.0

TRUTH_DTYPE = np.dtype([
    ("mmsi", np.int64), ("vessel_id", np.int64), ("msg_type", np.int64), ("t_tx_s", np.float64),
    ("t_rx_s", np.float64), ("lat_true", np.float64), ("lon_true", np.float64), ("lat", np.float64),
    ("lon", np.float64), ("spoofed", np.bool_),
])


@dataclass(frozen=True)
class AISConfig:
    """Parameters of the simulated AIS feed.

    Parameters
    ----------
    pos_sigma_a_m, pos_sigma_b_m : float
        GNSS position noise (standard deviation per axis, metres) for class A and B.
    latency_mean_s, latency_max_s : float
        Receive latency: exponential with this mean, clipped to the maximum.
    drop_prob : float
        Probability that a message is lost.
    static_interval_s : float
        Interval of static messages (5 / 24).
    first_static_max_s : float
        The first static message of each vessel comes within this time of the start.
    spoof_mmsi : int
        MMSI whose reported positions are spoofed (0: none).
    spoof_offset_m : (float, float)
        East, north offset of the spoofed positions.
    spoof_from_s : float
        Spoofing starts at this time.
    """

    pos_sigma_a_m: float = 4.0
    pos_sigma_b_m: float = 8.0
    latency_mean_s: float = 0.8
    latency_max_s: float = 5.0
    drop_prob: float = 0.03
    static_interval_s: float = 360.0
    first_static_max_s: float = 15.0
    spoof_mmsi: int = 0
    spoof_offset_m: tuple[float, float] = (900.0, 400.0)
    spoof_from_s: float = 0.0


def report_interval_s(ais_class: str, speed_kn: float, turning: bool) -> float:
    """Nominal interval between position reports (ITU-R M.1371, simplified)."""
    if ais_class == "A":
        if speed_kn < 3.0:
            return 180.0
        if speed_kn <= 14.0:
            return 10.0 / 3.0 if turning else 10.0
        if speed_kn <= 23.0:
            return 2.0 if turning else 6.0
        return 2.0
    return 180.0 if speed_kn < 2.0 else 30.0


def _q_deg(x: float) -> float:
    """A latitude/longitude as an AIS decoder returns it (1/10000 minute units, 6 decimals)."""
    return round(round(float(x) * 600000.0) / 600000.0, 6)


def nmea_tag_block(t_s: float, sentence: str) -> str:
    """Prefix a sentence with an NMEA 4.0 tag block carrying the receive time ``c:<t_s>``."""
    body = f"c:{t_s:.3f}"
    cs = 0
    for ch in body:
        cs ^= ord(ch)
    return f"\\{body}*{cs:02X}\\{sentence}"


class AISStream:
    """Reports of a simulated AIS feed, sorted by receive time, and their NMEA sentences."""

    def __init__(self, reports: list[AISReport], payloads: list[dict], channels: list[str], truth: np.ndarray):
        self.reports = reports
        self._payloads = payloads
        self._channels = channels
        self.truth = truth

    def __len__(self) -> int:
        return len(self.reports)

    def nmea(self) -> list[tuple[float, str]]:
        """``(receive time, !AIVDM sentence)`` pairs; multi-sentence messages give several pairs."""
        out = []
        seq = 0
        for rep, payload, ch in zip(self.reports, self._payloads, self._channels):
            multi = payload["type"] == 5
            sents = encode_dict(payload, talker_id="AI", sentence_type="VDM", radio_channel=ch,
                                seq_id=(seq % 10) if multi else None)
            if multi:
                seq += 1
            out.extend((rep.t_s, s) for s in sents)
        return out

    def write_nmea(self, path) -> None:
        """Write the sentences, one per line, each with a ``\\c:<receive time>*hh\\`` tag block."""
        with open(path, "w", encoding="ascii") as fh:
            for t, s in self.nmea():
                fh.write(nmea_tag_block(t, s) + "\n")


def simulate_ais(
    world: World,
    origin_lat_deg: float,
    origin_lon_deg: float,
    duration_s: float,
    config: AISConfig = AISConfig(),
    seed: int = 0,
    t0_s: float = 0.0,
) -> AISStream:
    """Simulate the AIS messages of every vessel of ``world`` with an MMSI.

    Parameters
    ----------
    world : World
    origin_lat_deg, origin_lon_deg : float
        Geodetic position of the world's ENU origin.
    duration_s : float
        Messages transmitted in ``[t0_s, t0_s + duration_s)`` are produced.
    config : AISConfig
    seed : int
    t0_s : float
        Start time.

    Returns
    -------
    AISStream
    """
    rng = np.random.default_rng([seed, 41])
    rows: list[tuple] = []
    t_end = t0_s + duration_s
    for v in world.vessels:
        if not v.mmsi or not v.ais_class:
            continue
        vr = np.random.default_rng([seed, 41, v.id])
        sigma = config.pos_sigma_a_m if v.ais_class == "A" else config.pos_sigma_b_m
        # position reports
        _, _, _, sp = v.state(t0_s)
        first = report_interval_s(v.ais_class, float(sp) * KN_PER_MPS, False)
        t = t0_s + vr.uniform(0, min(first, 10.0))
        while t < t_end:
            e, n, course, speed = (float(x) for x in v.state(t))
            rot = float(v.trajectory.turn_rate_dps(t))
            spoofed = bool(config.spoof_mmsi and v.mmsi == config.spoof_mmsi and t >= config.spoof_from_s)
            ne, nn = e + vr.normal(0, sigma), n + vr.normal(0, sigma)
            if spoofed:
                ne += config.spoof_offset_m[0]
                nn += config.spoof_offset_m[1]
            rows.append(("pos", v, t, e, n, ne, nn, course, speed, rot, spoofed))
            turning = abs(rot) > 0.05
            t += report_interval_s(v.ais_class, speed * KN_PER_MPS, turning) * vr.uniform(0.97, 1.03)
        # static data
        t = t0_s + vr.uniform(0, min(config.first_static_max_s, duration_s))
        while t < t_end:
            rows.append(("static", v, t, 0, 0, 0, 0, 0, 0, 0, False))
            t += config.static_interval_s
    # geodetic conversion in one call
    pos = [r for r in rows if r[0] == "pos"]
    if pos:
        ee = np.array([[r[3], r[5]] for r in pos])
        nn = np.array([[r[4], r[6]] for r in pos])
        lat, lon, _ = pymap3d.enu2geodetic(ee, nn, np.zeros_like(ee), origin_lat_deg, origin_lon_deg, 0.0)
    msgs = []
    pi = 0
    for r in rows:
        kind, v, t_tx = r[0], r[1], r[2]
        if rng.random() < config.drop_prob:
            if kind == "pos":
                pi += 1
            continue
        t_rx = t_tx + min(config.latency_max_s, rng.exponential(config.latency_mean_s))
        ch = "A" if rng.random() < 0.5 else "B"
        if kind == "pos":
            lat_t, lon_t = float(lat[pi, 0]), float(lon[pi, 0])
            la, lo = _q_deg(lat[pi, 1]), _q_deg(lon[pi, 1])
            pi += 1
            course, speed, rot, spoofed = r[7], r[8], r[9], r[10]
            sog = min(102.2, round(speed * KN_PER_MPS, 1))
            cog = round(course % 360.0, 1) % 360.0
            hdg = int(round(course)) % 360
            second = int(math.floor(t_tx)) % 60
            if v.ais_class == "A":
                mtype = 1
                payload = {"type": 1, "mmsi": v.mmsi, "status": 0 if speed > 0.3 else 5, "turn": 0,
                           "speed": sog, "accuracy": 1, "lon": lo, "lat": la, "course": cog, "heading": hdg,
                           "second": second}
            else:
                mtype = 18
                payload = {"type": 18, "mmsi": v.mmsi, "speed": sog, "accuracy": 1, "lon": lo, "lat": la,
                           "course": cog, "heading": hdg, "second": second, "cs": 1}
            rep = AISReport(mmsi=v.mmsi, t_s=t_rx, lat_deg=la, lon_deg=lo, sog_kn=sog, cog_deg=cog,
                            heading_deg=float(hdg), nav_status=payload.get("status"), msg_type=mtype)
            msgs.append((t_rx, rep, payload, ch, (v.mmsi, v.id, mtype, t_tx, t_rx, lat_t, lon_t, la, lo, spoofed)))
        else:
            bow = int(round(v.length_m / 2))
            beam = int(round(v.beam_m / 2))
            name = v.name[:20]
            if v.ais_class == "A":
                payload = {"type": 5, "mmsi": v.mmsi, "ais_version": 0, "imo": 0, "callsign": v.callsign,
                           "shipname": name, "ship_type": v.ship_type, "to_bow": bow,
                           "to_stern": int(round(v.length_m)) - bow, "to_port": beam,
                           "to_starboard": max(0, int(round(v.beam_m)) - beam), "epfd": 1,
                           "draught": 0.0, "destination": ""}
                rep = AISReport(mmsi=v.mmsi, t_s=t_rx, msg_type=5, name=name, callsign=v.callsign,
                                ship_type=v.ship_type, length_m=float(int(round(v.length_m))),
                                beam_m=float(int(round(v.beam_m))))
                msgs.append((t_rx, rep, payload, ch,
                             (v.mmsi, v.id, 5, t_tx, t_rx, np.nan, np.nan, np.nan, np.nan, False)))
            else:
                pa = {"type": 24, "mmsi": v.mmsi, "partno": 0, "shipname": name}
                pb = {"type": 24, "mmsi": v.mmsi, "partno": 1, "ship_type": v.ship_type, "vendorid": "",
                      "callsign": v.callsign, "to_bow": bow, "to_stern": int(round(v.length_m)) - bow,
                      "to_port": beam, "to_starboard": max(0, int(round(v.beam_m)) - beam)}
                ra = AISReport(mmsi=v.mmsi, t_s=t_rx, msg_type=24, name=name)
                rb = AISReport(mmsi=v.mmsi, t_s=t_rx + 0.05, msg_type=24, callsign=v.callsign,
                               ship_type=v.ship_type, length_m=float(int(round(v.length_m))),
                               beam_m=float(int(round(v.beam_m))))
                msgs.append((t_rx, ra, pa, ch, (v.mmsi, v.id, 24, t_tx, t_rx, np.nan, np.nan, np.nan, np.nan, False)))
                msgs.append((t_rx + 0.05, rb, pb, ch,
                             (v.mmsi, v.id, 24, t_tx, t_rx + 0.05, np.nan, np.nan, np.nan, np.nan, False)))
    msgs.sort(key=lambda m: (m[0], m[1].mmsi))
    truth = np.array([m[4] for m in msgs], dtype=TRUTH_DTYPE)
    return AISStream([m[1] for m in msgs], [m[2] for m in msgs], [m[3] for m in msgs], truth)
