"""Radar / VTS track input: a documented CSV / JSON format and NMEA ``TTM`` / ``TLL`` sentences.

API
---
Every reader returns ``(plots, stats)``: a structured array of :data:`RADAR_DTYPE`, sorted by
time, and an :class:`~seawatch.io.ais.AISStats`-like counter of lines read and rejected (with
messages naming the input and line).

``read_radar(path, site_lat_deg=None, site_lon_deg=None, day_start_s=0.0)``
    Chooses by extension: ``.csv`` -> :func:`read_radar_csv`, ``.json``/``.jsonl`` ->
    :func:`read_radar_json`, anything else -> :func:`read_radar_nmea`.

CSV / JSON format (one row or object per track update)
------------------------------------------------------
=============  ==========================================================================
column         meaning
=============  ==========================================================================
``t_s``        time: seconds (same clock as the AIS) or an ISO 8601 date-time (UTC)
``id``         radar/VTS track number (integer)
``lat_deg``    latitude, WGS-84 (or leave empty and give ``range_m`` and ``bearing_deg``)
``lon_deg``    longitude
``range_m``    range from the radar site, metres (needs the site position)
``bearing_deg`` true bearing from the radar site, degrees clockwise from north
``speed_mps``  speed over ground, m/s (optional)
``course_deg`` course over ground, degrees (optional)
=============  ==========================================================================

JSON: either a list of such objects or JSON Lines (one object per line).

NMEA
----
``$--TTM`` (tracked target: number, distance, bearing T, speed, course T, ..., units K/N/S,
name, status, reference, UTC ``hhmmss.ss``, acquisition) becomes a position from the radar site
(``site_lat_deg``, ``site_lon_deg`` required); relative bearings/courses (``R``) need
``heading_deg``.  ``$--TLL`` (target number, lat, N/S, lon, E/W, name, UTC, status) carries the
position itself.  UTC times of day are added to ``day_start_s`` (Unix time of that day's 00:00
UTC; 0 gives seconds of the day).  Targets with status ``L`` (lost) are skipped.  Checksums are
verified when present.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pymap3d

from seawatch.io.ais import AISStats, parse_time

__all__ = ["RADAR_DTYPE", "read_radar", "read_radar_csv", "read_radar_json", "read_radar_nmea",
           "parse_radar_sentence", "nmea_checksum", "RadarStats"]

#: One radar/VTS track update.
RADAR_DTYPE = np.dtype([
    ("t_s", np.float64),
    ("id", np.int64),
    ("lat_deg", np.float64),
    ("lon_deg", np.float64),
    ("range_m", np.float64),
    ("bearing_deg", np.float64),
    ("speed_mps", np.float64),
    ("course_deg", np.float64),
])

RadarStats = AISStats  # same counters: lines, reports, rejected per reason, messages

_UNIT_M = {"K": 1000.0, "N": 1852.0, "S": 1609.344}


def nmea_checksum(body: str) -> str:
    """The two-hex-digit XOR checksum of an NMEA sentence body (between ``$`` and ``*``)."""
    c = 0
    for ch in body.encode("ascii", errors="replace"):
        c ^= ch
    return f"{c:02X}"


def _fill(rows: list[dict], site: tuple[float, float] | None, stats: AISStats, where: str) -> np.ndarray:
    """Complete rows (lat/lon from range/bearing or the reverse), validate, -> structured array."""
    out = []
    for row, w in rows:
        lat, lon = row.get("lat_deg", np.nan), row.get("lon_deg", np.nan)
        rng, brg = row.get("range_m", np.nan), row.get("bearing_deg", np.nan)
        if not (np.isfinite(lat) and np.isfinite(lon)):
            if not (np.isfinite(rng) and np.isfinite(brg)):
                stats.reject("no_position", f"{w}: neither lat/lon nor range/bearing")
                continue
            if site is None:
                stats.reject("no_site", f"{w}: range/bearing given but no radar site position")
                continue
            b = math.radians(brg)
            lat, lon, _ = pymap3d.enu2geodetic(rng * math.sin(b), rng * math.cos(b), 0.0, site[0], site[1], 0.0)
            lat, lon = float(lat), float(lon)
        elif site is not None and not np.isfinite(rng):
            e, n, _ = pymap3d.geodetic2enu(lat, lon, 0.0, site[0], site[1], 0.0)
            rng, brg = float(math.hypot(e, n)), float(math.degrees(math.atan2(e, n)) % 360.0)
        if not (abs(lat) <= 90 and abs(lon) <= 180):
            stats.reject("invalid_position", f"{w}: invalid position lat {lat} lon {lon}")
            continue
        out.append((row["t_s"], row["id"], lat, lon, rng, brg, row.get("speed_mps", np.nan),
                    row.get("course_deg", np.nan)))
        stats.reports += 1
    arr = np.array(out, dtype=RADAR_DTYPE)
    return arr[np.argsort(arr["t_s"], kind="stable")]


def _num(v) -> float:
    if v is None:
        return float("nan")
    if isinstance(v, str):
        v = v.strip()
        if not v:
            return float("nan")
    return float(v)


def _row_from_mapping(d: dict) -> dict:
    t = d.get("t_s", d.get("time"))
    if t is None or (isinstance(t, str) and not t.strip()):
        raise ValueError("missing t_s")
    row = {"t_s": parse_time(t) if isinstance(t, str) else float(t), "id": int(float(d["id"]))}
    for k in ("lat_deg", "lon_deg", "range_m", "bearing_deg", "speed_mps", "course_deg"):
        row[k] = _num(d.get(k))
    return row


def read_radar_csv(path, site_lat_deg=None, site_lon_deg=None) -> tuple[np.ndarray, AISStats]:
    """Read radar/VTS track updates from a CSV file of the documented format (header required)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"radar file not found: {p}")
    st = AISStats()
    rows = []
    with open(p, newline="", encoding="utf-8", errors="replace") as fh:
        rd = csv.DictReader(fh)
        if rd.fieldnames is None or "id" not in rd.fieldnames or not ({"t_s", "time"} & set(rd.fieldnames)):
            raise ValueError(f"{p}: radar CSV needs a header with t_s (or time) and id columns, got {rd.fieldnames}")
        for lineno, d in enumerate(rd, start=2):
            st.lines += 1
            try:
                rows.append((_row_from_mapping(d), f"{p}:{lineno}"))
            except (ValueError, KeyError, TypeError) as exc:
                st.reject("bad_row", f"{p}:{lineno}: {exc}")
    site = None if site_lat_deg is None else (float(site_lat_deg), float(site_lon_deg))
    return _fill(rows, site, st, str(p)), st


def read_radar_json(path, site_lat_deg=None, site_lon_deg=None) -> tuple[np.ndarray, AISStats]:
    """Read radar/VTS track updates from a JSON list or JSON Lines file of the documented format."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"radar file not found: {p}")
    st = AISStats()
    text = p.read_text(encoding="utf-8", errors="replace")
    items: list[tuple[object, str]] = []
    if text.lstrip().startswith("["):
        try:
            items = [(d, f"{p}[{i}]") for i, d in enumerate(json.loads(text))]
        except json.JSONDecodeError as exc:
            raise ValueError(f"{p}: not valid JSON: {exc}") from None
    else:
        for lineno, line in enumerate(text.splitlines(), start=1):
            if not line.strip():
                continue
            try:
                items.append((json.loads(line), f"{p}:{lineno}"))
            except json.JSONDecodeError as exc:
                st.lines += 1
                st.reject("bad_row", f"{p}:{lineno}: not valid JSON: {exc}")
    rows = []
    for d, w in items:
        st.lines += 1
        try:
            if not isinstance(d, dict):
                raise TypeError("not an object")
            rows.append((_row_from_mapping(d), w))
        except (ValueError, KeyError, TypeError) as exc:
            st.reject("bad_row", f"{w}: {exc}")
    site = None if site_lat_deg is None else (float(site_lat_deg), float(site_lon_deg))
    return _fill(rows, site, st, str(p)), st


def _hms(text: str) -> float:
    text = text.strip()
    if len(text) < 6:
        raise ValueError(f"bad UTC time {text!r}")
    return int(text[0:2]) * 3600 + int(text[2:4]) * 60 + float(text[4:])


def _latlon(v: str, hemi: str, deg_digits: int) -> float:
    v = v.strip()
    x = int(v[:deg_digits]) + float(v[deg_digits:]) / 60.0
    return -x if hemi.strip().upper() in ("S", "W") else x


def parse_radar_sentence(sentence: str, day_start_s: float = 0.0, heading_deg: float | None = None) -> dict | None:
    """Parse one ``TTM`` or ``TLL`` sentence into a row dict (no site conversion yet).

    Returns None for other sentence types and for lost targets.

    Raises
    ------
    ValueError
        On a bad checksum or malformed fields (the message says which).
    """
    s = sentence.strip()
    if not s.startswith("$") or len(s) < 7:
        raise ValueError("not an NMEA sentence")
    body, _, cs = s[1:].partition("*")
    if cs:
        if nmea_checksum(body) != cs[:2].upper():
            raise ValueError(f"bad checksum (got {cs[:2]}, computed {nmea_checksum(body)})")
    f = body.split(",")
    kind = f[0][-3:]
    if kind == "TTM":
        if len(f) < 15:
            raise ValueError(f"TTM with {len(f)} fields, expected at least 15")
        if f[12].strip().upper() == "L":
            return None
        unit = _UNIT_M.get(f[10].strip().upper() or "N")
        if unit is None:
            raise ValueError(f"unknown distance unit {f[10]!r}")
        rng = float(f[2]) * unit
        brg = float(f[3])
        if f[4].strip().upper() == "R":
            if heading_deg is None:
                raise ValueError("relative bearing but no own heading given")
            brg = (brg + heading_deg) % 360.0
        spd = float(f[5]) * unit / 3600.0 if f[5].strip() else float("nan")
        crs = float(f[6]) if f[6].strip() else float("nan")
        if f[7].strip().upper() == "R" and np.isfinite(crs):
            if heading_deg is None:
                raise ValueError("relative course but no own heading given")
            crs = (crs + heading_deg) % 360.0
        t = day_start_s + _hms(f[14]) if f[14].strip() else float("nan")
        return {"t_s": t, "id": int(f[1]), "lat_deg": float("nan"), "lon_deg": float("nan"), "range_m": rng,
                "bearing_deg": brg, "speed_mps": spd, "course_deg": crs}
    if kind == "TLL":
        if len(f) < 9:
            raise ValueError(f"TLL with {len(f)} fields, expected at least 9")
        if f[8].strip().upper() == "L":
            return None
        lat = _latlon(f[2], f[3], 2)
        lon = _latlon(f[4], f[5], 3)
        t = day_start_s + _hms(f[7]) if f[7].strip() else float("nan")
        return {"t_s": t, "id": int(f[1]), "lat_deg": lat, "lon_deg": lon, "range_m": float("nan"),
                "bearing_deg": float("nan"), "speed_mps": float("nan"), "course_deg": float("nan")}
    return None


def read_radar_nmea(path, site_lat_deg=None, site_lon_deg=None, day_start_s: float = 0.0,
                    heading_deg: float | None = None) -> tuple[np.ndarray, AISStats]:
    """Read ``TTM`` / ``TLL`` sentences (other sentences are counted as ``other`` and skipped).

    A ``TLL`` without speed/course gets them from the same target's next ``TTM`` at the same time
    when present; otherwise the fusion estimates the velocity from consecutive positions.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"radar file not found: {p}")
    st = AISStats()
    rows = []
    with open(p, encoding="ascii", errors="replace") as fh:
        for lineno, line in enumerate(fh, start=1):
            if not line.strip():
                continue
            st.lines += 1
            w = f"{p}:{lineno}"
            try:
                row = parse_radar_sentence(line, day_start_s, heading_deg)
            except (ValueError, IndexError) as exc:
                reason = "bad_checksum" if "checksum" in str(exc) else "malformed"
                st.reject(reason, f"{w}: {exc}")
                continue
            if row is None:
                st.rejected["other"] += 1
                continue
            if not np.isfinite(row["t_s"]):
                st.reject("bad_time", f"{w}: no UTC time")
                continue
            st.sentences += 1
            rows.append((row, w))
    site = None if site_lat_deg is None else (float(site_lat_deg), float(site_lon_deg))
    return _fill(rows, site, st, str(p)), st


def read_radar(path, site_lat_deg=None, site_lon_deg=None, day_start_s: float = 0.0,
               heading_deg: float | None = None) -> tuple[np.ndarray, AISStats]:
    """Read radar/VTS tracks, choosing the reader by file extension (see the module docstring)."""
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".csv":
        return read_radar_csv(p, site_lat_deg, site_lon_deg)
    if ext in (".json", ".jsonl"):
        return read_radar_json(p, site_lat_deg, site_lon_deg)
    return read_radar_nmea(p, site_lat_deg, site_lon_deg, day_start_s, heading_deg)
