"""AIS input: NMEA 0183 sentences, CSV files and live UDP/TCP streams -> :class:`~seawatch.types.AISReport`.

API
---
Every reader returns ``(reports, stats)``: a time-ordered list of :class:`seawatch.types.AISReport`
and an :class:`AISStats` that counts what was read and what was rejected, and why (each rejection
also keeps a message naming the input and the line, up to ``AISStats.max_messages``).

``read_ais(source)``
    Any file or folder: a folder of FVessel snapshots, a ``.csv`` file (FVessel or Solent format,
    told apart by the header), or otherwise an NMEA file.
``read_nmea(path, start_s=0.0, line_interval_s=0.0)``
    ``!AIVDM``/``!AIVDO`` sentences, one per line, single and multi-part, message types 1, 2, 3,
    5, 18, 19, 24 and 27.  A line may carry its receive time as a tag block
    (``\\s:rcv,c:1654315502*hh\\!AIVDM,...``, ``c`` in Unix seconds or milliseconds), as a leading
    field (``1654315502.004 !AIVDM...``, ``1654315502004,!AIVDM...``,
    ``2016-01-12T13:02:11.2Z !AIVDM...``) or as a trailing field after the checksum
    (``!AIVDM,...*hh,1654315502``).  Untimed lines get ``start_s + i * line_interval_s``.
``read_ais_csv(path)``
    FVessel snapshot CSV (``,mmsi,lon,lat,speed,course,heading,type,timestamp``; timestamp in Unix
    ms UTC, speed in knots, heading 511 = unavailable) or Stone Soup Solent CSV
    (``Time,MMSI,Latitude_degrees,Longitude_degrees,COG_degrees,SOG_knots``, time in UTC).
``read_fvessel_ais(folder)``
    All snapshot files of a folder (FVessel ``ais/``), duplicates (same MMSI and time) dropped.
``NMEADecoder``
    The streaming decoder behind the NMEA readers: ``feed(line, t_s=None, where="")`` returns the
    reports completed by that line (multi-part messages are assembled across calls).
``AISListener(url)``
    A background listener on ``udp://HOST:PORT`` (binds and receives datagrams) or
    ``tcp://HOST:PORT`` (connects to a server that streams NMEA lines); ``poll()`` returns the
    reports received since the last call, ``close()`` stops it.  Times are the receive time
    (Unix seconds) unless a sentence carries a tag-block time.
``reports_to_array(reports)``
    Position reports as a structured array of dtype :data:`AIS_DTYPE` (for the track table).

Times are Unix seconds (UTC) when the source carries absolute times.  Rejected, and counted:
sentences with a bad checksum or malformed fields, incomplete multi-part messages, message types
other than the eight above, invalid MMSIs (:func:`valid_mmsi`), invalid positions (lat outside
[-90, 90] such as 91 = unavailable, lon outside [-180, 180] such as 181), unparsable CSV rows.
An NMEA position report whose position is AIS's "not available" (lat 91 or lon 181) is counted
as an invalid position but kept as a report without a position (``has_position`` False): the
MMSI is on the air, which the fuser's "no AIS" rule needs to know.
Unavailable speed (102.3 kn), course (360) and heading (511) become NaN without rejecting the
report.
"""

from __future__ import annotations

import csv
import datetime as _dt
import math
import queue
import re
import socket
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

import numpy as np

from seawatch.types import AISReport

__all__ = [
    "AIS_DTYPE",
    "AISStats",
    "NMEADecoder",
    "AISListener",
    "read_ais",
    "read_nmea",
    "read_ais_csv",
    "read_fvessel_ais",
    "reports_to_array",
    "valid_mmsi",
    "parse_time",
    "SUPPORTED_TYPES",
]

SUPPORTED_TYPES = frozenset({1, 2, 3, 5, 18, 19, 24, 27})
POSITION_TYPES = frozenset({1, 2, 3, 18, 19, 27})

#: Structured dtype of position reports (see :func:`reports_to_array`).
AIS_DTYPE = np.dtype(
    [
        ("mmsi", np.int64),
        ("t_s", np.float64),
        ("lat_deg", np.float64),
        ("lon_deg", np.float64),
        ("sog_kn", np.float64),
        ("cog_deg", np.float64),
        ("heading_deg", np.float64),
    ]
)

# Placeholder MMSIs that transponders are often left configured with.
_PLACEHOLDER_MMSI = frozenset({123456789, 987654321} | {int(str(d) * 9) for d in range(1, 10)})


def valid_mmsi(mmsi) -> np.ndarray | bool:
    """Whether an MMSI can belong to a real station.

    Valid MMSIs have at most nine digits and a Maritime Identification Digits (MID, 201-775)
    somewhere in the first three, so any value below 2,000,000 (e.g. 0, 1, 12345) or above
    999,999,999 is invalid, as are placeholders such as 123456789 or 111111111.

    Parameters
    ----------
    mmsi : int or array of int

    Returns
    -------
    bool or bool array
    """
    m = np.asarray(mmsi, dtype=np.int64)
    ok = (m >= 2_000_000) & (m <= 999_999_999)
    if _PLACEHOLDER_MMSI:
        ok &= ~np.isin(m, np.fromiter(_PLACEHOLDER_MMSI, np.int64))
    return bool(ok) if ok.ndim == 0 else ok


def _valid_position(lat, lon) -> np.ndarray | bool:
    lat = np.asarray(lat, float)
    lon = np.asarray(lon, float)
    ok = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90.0) & (np.abs(lon) <= 180.0)
    return bool(ok) if ok.ndim == 0 else ok


@dataclass
class AISStats:
    """What an AIS reader read and rejected.

    Attributes
    ----------
    lines : lines (or CSV rows, or datagrams) seen.
    sentences : NMEA sentences with a valid checksum.
    messages : AIS messages decoded (a multi-part message counts once).
    reports : reports produced.
    rejected : counts per reason (``bad_checksum``, ``malformed``, ``incomplete_multipart``,
        ``unsupported_type``, ``invalid_mmsi``, ``invalid_position``, ``bad_time``, ``bad_row``).
    messages_log : the first ``max_messages`` rejection messages, each naming the input and line.
    """

    lines: int = 0
    sentences: int = 0
    messages: int = 0
    reports: int = 0
    rejected: Counter = field(default_factory=Counter)
    messages_log: list[str] = field(default_factory=list)
    max_messages: int = 100

    def reject(self, reason: str, message: str) -> None:
        """Count one rejection and keep its message."""
        self.rejected[reason] += 1
        if len(self.messages_log) < self.max_messages:
            self.messages_log.append(message)

    @property
    def n_rejected(self) -> int:
        return int(sum(self.rejected.values()))

    def merge(self, other: "AISStats") -> None:
        self.lines += other.lines
        self.sentences += other.sentences
        self.messages += other.messages
        self.reports += other.reports
        self.rejected.update(other.rejected)
        room = self.max_messages - len(self.messages_log)
        if room > 0:
            self.messages_log.extend(other.messages_log[:room])

    def as_dict(self) -> dict:
        return {
            "lines": self.lines,
            "sentences": self.sentences,
            "messages": self.messages,
            "reports": self.reports,
            "rejected": dict(self.rejected),
            "n_rejected": self.n_rejected,
        }

    def summary(self) -> str:
        rej = ", ".join(f"{k} {v}" for k, v in sorted(self.rejected.items())) or "none"
        return (
            f"{self.lines} lines, {self.sentences} sentences, {self.messages} messages, "
            f"{self.reports} reports; rejected: {rej}"
        )


# ----------------------------------------------------------------------------------- times
def parse_time(text: str) -> float:
    """A time stamp as Unix seconds (UTC).

    Accepts Unix seconds (``1654315502.004``), Unix milliseconds (values above 1e11) and ISO 8601
    date-times (``2016-01-12 13:02:11.218``, ``2016-01-12T13:02:11Z``; naive ones are UTC).

    Raises
    ------
    ValueError
        When the text is none of these.
    """
    s = text.strip()
    try:
        v = float(s)
    except ValueError:
        pass
    else:
        if not math.isfinite(v):
            raise ValueError(f"not a time: {text!r}")
        return v / 1000.0 if abs(v) > 1e11 else v
    try:
        d = _dt.datetime.fromisoformat(s.replace("Z", "+00:00").replace("z", "+00:00"))
    except ValueError:
        raise ValueError(f"not a time: {text!r}") from None
    if d.tzinfo is None:
        d = d.replace(tzinfo=_dt.timezone.utc)
    return d.timestamp()


_TAG_RE = re.compile(r"\\([^\\]*)\\")
_TRAIL_RE = re.compile(r"(\*[0-9A-Fa-f]{2})[,;\s]+(\S+)\s*$")


def _split_line(line: str) -> tuple[float | None, str]:
    """Separate a line's time stamp (tag block, leading or trailing field) from its sentence."""
    t = None
    s = line.strip()
    i = s.find("!")
    if i < 0:
        return None, s
    j = s.find("\\")
    if 0 <= j < i:  # tag block before the sentence
        m = _TAG_RE.search(s, j)
        if m is not None and m.end() <= i + 1:
            body = m.group(1).split("*", 1)[0]
            for part in body.split(","):
                if part.startswith("c:"):
                    t = parse_time(part[2:])
            s = s[m.end():]
            i = s.find("!")
        prefix = s[:i]
    else:
        prefix = s[:i]
    prefix = prefix.strip(" \t,;")
    if prefix and t is None:
        t = parse_time(prefix)
    s = s[i:]
    m = _TRAIL_RE.search(s)
    if m is not None:
        if t is None:
            t = parse_time(m.group(2))
        s = s[: m.start(1) + 3]
    return t, s


# ------------------------------------------------------------------------------ decoding
def _nan_if(v, bad) -> float:
    if v is None:
        return float("nan")
    v = float(v)
    return float("nan") if v >= bad else v


def _dims(d: dict) -> tuple[float | None, float | None]:
    bow, stern = d.get("to_bow"), d.get("to_stern")
    port, stb = d.get("to_port"), d.get("to_starboard")
    length = float(bow + stern) if bow is not None and stern is not None and bow + stern > 0 else None
    beam = float(port + stb) if port is not None and stb is not None and port + stb > 0 else None
    return length, beam


def _text(v) -> str | None:
    if v is None:
        return None
    v = str(v).replace("@", " ").strip()
    return v or None


def message_to_report(d: dict, t_s: float, stats: AISStats, where: str) -> AISReport | None:
    """One decoded pyais message (as a dict) -> an :class:`AISReport`, or None when rejected."""
    mt = int(d.get("msg_type", -1))
    if mt not in SUPPORTED_TYPES:
        stats.reject("unsupported_type", f"{where}: AIS message type {mt} not used")
        return None
    mmsi = int(d.get("mmsi", 0))
    if not valid_mmsi(mmsi):
        stats.reject("invalid_mmsi", f"{where}: invalid MMSI {mmsi} (type {mt})")
        return None
    rep = AISReport(mmsi=mmsi, t_s=float(t_s), msg_type=mt)
    has_static = False
    heard = False  # kept without a position: the vessel's transponder is on (see below)
    if mt in (5, 19, 24):
        name = _text(d.get("shipname"))
        callsign = _text(d.get("callsign"))
        st = d.get("ship_type")
        length, beam = _dims(d)
        rep.name = name
        rep.callsign = callsign
        rep.ship_type = int(st) if st is not None and int(st) > 0 else None
        rep.length_m, rep.beam_m = length, beam
        has_static = any(x is not None for x in (name, callsign, rep.ship_type, length, beam))
    if mt in POSITION_TYPES:
        lat, lon = d.get("lat"), d.get("lon")
        if lat is None or lon is None or not _valid_position(lat, lon):
            # lat 91 / lon 181 is AIS's "not available" (no GNSS fix): the position is rejected and
            # counted, but the report is kept without one, so that the fuser knows this MMSI is on
            # the air (it could be a vessel the camera sees; see docs/fusion.md, rule 3b)
            heard = lat == 91 or lon == 181
            stats.reject(
                "invalid_position", f"{where}: MMSI {mmsi} type {mt}: invalid position lat {lat} lon {lon}"
                + (" (not available: kept as heard, without a position)" if heard else "")
            )
            if not (has_static or heard):
                return None
        else:
            rep.lat_deg, rep.lon_deg = float(lat), float(lon)
            if mt == 27:
                rep.sog_kn = _nan_if(d.get("speed"), 63.0)
                rep.cog_deg = _nan_if(d.get("course"), 360.0)
            else:
                rep.sog_kn = _nan_if(d.get("speed"), 102.3)
                rep.cog_deg = _nan_if(d.get("course"), 360.0)
                rep.heading_deg = _nan_if(d.get("heading"), 360.0)
            st = d.get("status")
            rep.nav_status = int(st) if st is not None else None
    elif mt == 5:
        pass
    if not rep.has_position and not (has_static or heard):
        return None
    return rep


class NMEADecoder:
    """Streaming decoder of ``!AIVDM``/``!AIVDO`` lines with multi-part assembly.

    Parameters
    ----------
    source : str
        Name of the input, used in rejection messages.
    max_part_age_s : float
        A multi-part message whose parts do not all arrive within this time is dropped (counted
        as ``incomplete_multipart``).
    stats : AISStats, optional
        Counters to add to (a new one by default).
    """

    def __init__(self, source: str = "nmea", max_part_age_s: float = 10.0, stats: AISStats | None = None):
        from pyais.messages import NMEAMessage  # lazy: pyais import is ~50 ms

        self._NMEAMessage = NMEAMessage
        self.source = source
        self.max_part_age_s = float(max_part_age_s)
        self.stats = stats if stats is not None else AISStats()
        self._parts: dict[tuple, tuple[float, dict[int, object], str]] = {}

    def feed(self, line: str | bytes, t_s: float | None = None, where: str = "") -> list[AISReport]:
        """Decode one line; returns the reports it completes (often none or one).

        ``t_s`` is used when the line carries no time of its own.
        """
        st = self.stats
        where = where or self.source
        if isinstance(line, bytes):
            try:
                line = line.decode("ascii")
            except UnicodeDecodeError:
                st.lines += 1
                st.reject("malformed", f"{where}: not ASCII")
                return []
        if not line.strip():
            return []
        st.lines += 1
        try:
            t_line, sentence = _split_line(line)
        except ValueError as exc:
            st.reject("bad_time", f"{where}: {exc}")
            return []
        if not sentence.startswith(("!AIVDM", "!AIVDO", "!ABVDM", "!BSVDM", "!SAVDM", "!ANVDM")):
            st.reject("malformed", f"{where}: not an AIS sentence: {sentence[:40]!r}")
            return []
        t = t_line if t_line is not None else (t_s if t_s is not None else float("nan"))
        try:
            msg = self._NMEAMessage.from_string(sentence)
        except Exception as exc:  # pyais raises several kinds on malformed input
            st.reject("malformed", f"{where}: malformed sentence ({type(exc).__name__}): {sentence[:60]!r}")
            return []
        if not msg.is_valid:
            st.reject("bad_checksum", f"{where}: bad checksum: {sentence[:80]!r}")
            return []
        st.sentences += 1
        n, k = int(msg.frag_cnt), int(msg.frag_num)
        if n < 1 or k < 1 or k > n or n > 9:
            st.reject("malformed", f"{where}: fragment {k} of {n}")
            return []
        self._expire(t)
        if n == 1:
            return self._decode(msg, t, where)
        key = (msg.talker, msg.channel, msg.seq_id, n)
        if k == 1:
            if key in self._parts:
                st.reject("incomplete_multipart", f"{where}: multi-part message {key} restarted before completion")
            self._parts[key] = (t, {1: msg}, where)
            return []
        if key not in self._parts:
            st.reject("incomplete_multipart", f"{where}: part {k}/{n} without its first part")
            return []
        t0, parts, where0 = self._parts[key]
        if k in parts:
            st.reject("incomplete_multipart", f"{where}: duplicate part {k}/{n}")
            del self._parts[key]
            return []
        parts[k] = msg
        if len(parts) < n:
            return []
        del self._parts[key]
        try:
            full = self._NMEAMessage.assemble_from_iterable([parts[i] for i in range(1, n + 1)])
        except Exception as exc:
            st.reject("malformed", f"{where}: cannot assemble multi-part message: {exc}")
            return []
        return self._decode(full, t0, where0)

    def _expire(self, t: float) -> None:
        if not self._parts or not math.isfinite(t):
            return
        for key in [k for k, (t0, _, _) in self._parts.items() if math.isfinite(t0) and t - t0 > self.max_part_age_s]:
            _, parts, w = self._parts.pop(key)
            self.stats.reject("incomplete_multipart", f"{w}: multi-part message {key} incomplete after "
                              f"{self.max_part_age_s:g} s ({len(parts)} of {key[3]} parts)")

    def flush(self) -> None:
        """Count multi-part messages still waiting for parts as incomplete, and drop them."""
        for key, (_, parts, w) in self._parts.items():
            self.stats.reject("incomplete_multipart", f"{w}: multi-part message incomplete at end of input "
                              f"({len(parts)} of {key[3]} parts)")
        self._parts.clear()

    def _decode(self, msg, t: float, where: str) -> list[AISReport]:
        st = self.stats
        try:
            d = msg.decode().asdict()
        except Exception as exc:
            st.reject("malformed", f"{where}: cannot decode payload ({type(exc).__name__}: {exc})")
            return []
        st.messages += 1
        rep = message_to_report(d, t, st, where)
        if rep is None:
            return []
        st.reports += 1
        return [rep]


# ------------------------------------------------------------------------------- readers
def read_nmea(
    path: str | Path,
    start_s: float = 0.0,
    line_interval_s: float = 0.0,
    max_part_age_s: float = 10.0,
) -> tuple[list[AISReport], AISStats]:
    """Read an NMEA file of ``!AIVDM``/``!AIVDO`` sentences.

    Parameters
    ----------
    path : path of the file.
    start_s, line_interval_s : float
        Time given to line ``i`` when it carries no time stamp: ``start_s + i * line_interval_s``.
    max_part_age_s : float
        See :class:`NMEADecoder`.

    Returns
    -------
    reports : list of AISReport, sorted by time (stable).
    stats : AISStats

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"AIS file not found: {p}")
    dec = NMEADecoder(str(p), max_part_age_s=max_part_age_s)
    out: list[AISReport] = []
    with open(p, "r", encoding="ascii", errors="replace") as fh:
        for i, line in enumerate(fh):
            out.extend(dec.feed(line, start_s + i * line_interval_s, f"{p}:{i + 1}"))
    dec.flush()
    out.sort(key=lambda r: r.t_s)
    return out, dec.stats


def _sniff_header(p: Path) -> list[str]:
    with open(p, "r", encoding="utf-8", errors="replace", newline="") as fh:
        first = fh.readline()
    return [c.strip().lower() for c in first.strip().split(",")]


def read_ais_csv(path: str | Path, stats: AISStats | None = None) -> tuple[list[AISReport], AISStats]:
    """Read AIS position reports from a CSV file in the FVessel or the Solent format.

    The format is told from the header: FVessel snapshots
    ``,mmsi,lon,lat,speed,course,heading,type,timestamp`` (timestamp Unix ms UTC, speed in knots)
    or Stone Soup Solent ``Time,MMSI,Latitude_degrees,Longitude_degrees,COG_degrees,SOG_knots``.

    Returns
    -------
    reports : list of AISReport, sorted by time.
    stats : AISStats (``lines`` counts data rows).

    Raises
    ------
    FileNotFoundError, ValueError
        Missing file, or a header of neither format.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"AIS file not found: {p}")
    st = stats if stats is not None else AISStats()
    head = _sniff_header(p)
    if "mmsi" in head and "timestamp" in head and "lon" in head:
        cols = {"mmsi": "mmsi", "lat": "lat", "lon": "lon", "sog": "speed", "cog": "course",
                "heading": "heading", "type": "type", "time": "timestamp"}
    elif "mmsi" in head and "time" in head and "latitude_degrees" in head:
        cols = {"mmsi": "mmsi", "lat": "latitude_degrees", "lon": "longitude_degrees", "sog": "sog_knots",
                "cog": "cog_degrees", "heading": None, "type": None, "time": "time"}
    else:
        raise ValueError(f"{p}: unknown AIS CSV header {head!r} (expected the FVessel or the Solent format)")
    idx = {k: (head.index(v) if v is not None else None) for k, v in cols.items()}
    ncol = len(head)
    out: list[AISReport] = []
    with open(p, "r", encoding="utf-8", errors="replace", newline="") as fh:
        rd = csv.reader(fh)
        next(rd, None)
        for lineno, row in enumerate(rd, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            st.lines += 1
            where = f"{p}:{lineno}"
            if len(row) < ncol:
                st.reject("bad_row", f"{where}: {len(row)} fields, expected {ncol}")
                continue
            try:
                mmsi = int(float(row[idx["mmsi"]]))
                lat = float(row[idx["lat"]])
                lon = float(row[idx["lon"]])
                sog = float(row[idx["sog"]]) if row[idx["sog"]].strip() else float("nan")
                cog = float(row[idx["cog"]]) if row[idx["cog"]].strip() else float("nan")
                hdg = float(row[idx["heading"]]) if idx["heading"] is not None and row[idx["heading"]].strip() else float("nan")
            except ValueError as exc:
                st.reject("bad_row", f"{where}: {exc}")
                continue
            try:
                t = parse_time(row[idx["time"]])
            except ValueError as exc:
                st.reject("bad_time", f"{where}: {exc}")
                continue
            if not valid_mmsi(mmsi):
                st.reject("invalid_mmsi", f"{where}: invalid MMSI {mmsi}")
                continue
            if not _valid_position(lat, lon):
                st.reject("invalid_position", f"{where}: MMSI {mmsi}: invalid position lat {lat} lon {lon}")
                continue
            rep = AISReport(
                mmsi=mmsi, t_s=t, lat_deg=lat, lon_deg=lon,
                sog_kn=sog if 0 <= sog < 102.2 else float("nan"),
                cog_deg=cog if 0 <= cog < 360 else float("nan"),
                heading_deg=hdg if 0 <= hdg < 360 else float("nan"),
            )
            if idx["type"] is not None:
                try:
                    ty = int(float(row[idx["type"]]))
                    rep.ship_type = ty if ty > 0 else None
                except ValueError:
                    pass
            out.append(rep)
            st.reports += 1
    out.sort(key=lambda r: r.t_s)
    return out, st


def read_fvessel_ais(folder: str | Path) -> tuple[list[AISReport], AISStats]:
    """Read a folder of FVessel one-per-second AIS snapshot CSVs.

    Each snapshot repeats the latest report of every vessel heard; reports with the same MMSI and
    time stamp are kept once.  Returns ``(reports, stats)`` sorted by time.
    """
    d = Path(folder)
    if not d.is_dir():
        raise FileNotFoundError(f"AIS folder not found: {d}")
    files = sorted(d.glob("*.csv"))
    if not files:
        raise FileNotFoundError(f"{d}: no AIS .csv files")
    st = AISStats()
    seen: set[tuple[int, float]] = set()
    out: list[AISReport] = []
    for f in files:
        reps, _ = read_ais_csv(f, stats=st)
        for r in reps:
            key = (r.mmsi, r.t_s)
            if key not in seen:
                seen.add(key)
                out.append(r)
    st.reports = len(out)
    out.sort(key=lambda r: r.t_s)
    return out, st


def read_ais(source: str | Path, **kwargs) -> tuple[list[AISReport], AISStats]:
    """Read AIS from a file or folder, choosing the reader by what it is.

    A folder -> :func:`read_fvessel_ais`; a ``.csv`` file -> :func:`read_ais_csv`; anything else
    -> :func:`read_nmea` (``kwargs`` go to it).
    """
    p = Path(source)
    if p.is_dir():
        return read_fvessel_ais(p)
    if not p.exists():
        raise FileNotFoundError(f"AIS source not found: {p}")
    if p.suffix.lower() == ".csv":
        return read_ais_csv(p)
    return read_nmea(p, **kwargs)


def reports_to_array(reports: Iterable[AISReport]) -> np.ndarray:
    """Position reports as a structured array of :data:`AIS_DTYPE` (static-only reports skipped)."""
    rows = [
        (r.mmsi, r.t_s, r.lat_deg, r.lon_deg, r.sog_kn, r.cog_deg, r.heading_deg)
        for r in reports
        if r.has_position
    ]
    return np.array(rows, dtype=AIS_DTYPE)


# ------------------------------------------------------------------------------ listeners
def _parse_url(url: str) -> tuple[str, str, int]:
    m = re.fullmatch(r"(udp|tcp)://([^:/]*):(\d+)/?", url.strip())
    if m is None:
        raise ValueError(f"AIS stream {url!r}: expected udp://HOST:PORT or tcp://HOST:PORT")
    return m.group(1), m.group(2) or "0.0.0.0", int(m.group(3))


class AISListener:
    """Receive AIS sentences from a UDP port or a TCP server in a background thread.

    Parameters
    ----------
    url : str
        ``udp://HOST:PORT`` binds HOST:PORT and decodes every line of every datagram;
        ``tcp://HOST:PORT`` connects to a server and decodes the lines it streams, reconnecting
        after ``reconnect_s`` when the connection drops.
    reconnect_s : float
        Wait before reconnecting a dropped TCP connection (0: do not reconnect).
    clock : callable
        Returns the receive time in seconds (default :func:`time.time`).

    Notes
    -----
    Reports are queued; :meth:`poll` returns those received so far.  ``stats`` counts lines and
    rejections; ``errors`` keeps connection errors.  Use as a context manager or call
    :meth:`close`.  A UDP listener bound to port 0 reports its port in ``port``.
    """

    def __init__(self, url: str, reconnect_s: float = 2.0, clock=time.time, max_part_age_s: float = 10.0):
        self.kind, self.host, self.port = _parse_url(url)
        self.url = url
        self.reconnect_s = float(reconnect_s)
        self.clock = clock
        self.decoder = NMEADecoder(url, max_part_age_s=max_part_age_s)
        self.errors: list[str] = []
        self._q: queue.Queue[AISReport] = queue.Queue()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._sock: socket.socket | None = None
        self.connected = threading.Event()
        if self.kind == "udp":
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((self.host, self.port))
            s.settimeout(0.2)
            self.port = s.getsockname()[1]
            self._sock = s
            self.connected.set()
            target = self._run_udp
        else:
            target = self._run_tcp
        self._thread = threading.Thread(target=target, name=f"AISListener {url}", daemon=True)
        self._thread.start()

    @property
    def stats(self) -> AISStats:
        return self.decoder.stats

    def _feed_text(self, text: str) -> None:
        t = self.clock()
        with self._lock:
            for line in text.splitlines():
                for rep in self.decoder.feed(line, t, self.url):
                    self._q.put(rep)

    def _run_udp(self) -> None:
        assert self._sock is not None
        while not self._stop.is_set():
            try:
                data, _ = self._sock.recvfrom(65535)
            except socket.timeout:
                continue
            except OSError as exc:
                if not self._stop.is_set():
                    self.errors.append(f"{self.url}: {exc}")
                break
            self._feed_text(data.decode("ascii", errors="replace"))

    def _run_tcp(self) -> None:
        while not self._stop.is_set():
            try:
                s = socket.create_connection((self.host, self.port), timeout=2.0)
            except OSError as exc:
                self.errors.append(f"{self.url}: cannot connect: {exc}")
                if self.reconnect_s <= 0 or self._stop.wait(self.reconnect_s):
                    return
                continue
            s.settimeout(0.2)
            self._sock = s
            self.connected.set()
            buf = b""
            while not self._stop.is_set():
                try:
                    data = s.recv(65536)
                except socket.timeout:
                    continue
                except OSError as exc:
                    self.errors.append(f"{self.url}: {exc}")
                    break
                if not data:  # server closed
                    break
                buf += data
                *lines, buf = buf.split(b"\n")
                if lines:
                    self._feed_text(b"\n".join(lines).decode("ascii", errors="replace"))
            if buf.strip():
                self._feed_text(buf.decode("ascii", errors="replace"))
            s.close()
            self.connected.clear()
            if self.reconnect_s <= 0 or self._stop.wait(self.reconnect_s):
                return

    def poll(self) -> list[AISReport]:
        """The reports received since the last call (receive order)."""
        out = []
        while True:
            try:
                out.append(self._q.get_nowait())
            except queue.Empty:
                return out

    def close(self, timeout_s: float = 2.0) -> None:
        """Stop the thread and close the socket."""
        self._stop.set()
        self._thread.join(timeout_s)
        if self._sock is not None:
            try:
                self._sock.close()
            except OSError:
                pass

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def __enter__(self) -> "AISListener":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
