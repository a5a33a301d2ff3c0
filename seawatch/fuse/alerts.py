"""Operator alerts raised by fusion, and their JSON Lines form.

One JSON object per line::

    {"t_s": 41.2, "kind": "no_ais", "camera_id": "cam0", "track_id": 7, "mmsi": 0,
     "lat": 50.79, "lon": -1.10, "az_deg": 131.2, "message": "camera track 7 ..."}

Kinds
-----
``no_ais``
    A confirmed camera vessel with no AIS (or VTS) counterpart for the dwell time.
``ais_not_seen``
    An AIS vessel inside the camera's field of view and visible range that no camera track
    matches (and that no nearer vessel hides) for the dwell time.
``possible_spoofing``
    An AIS position inconsistent with what the camera sees: a vessel matched to an MMSI whose AIS
    position then leaves the camera bearing, or an unseen AIS vessel moving like an unidentified
    camera vessel elsewhere.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Iterable

import numpy as np

__all__ = ["ALERT_KINDS", "Alert", "write_alerts_jsonl", "read_alerts_jsonl", "ais_report_interval_s"]

ALERT_KINDS = ("no_ais", "ais_not_seen", "possible_spoofing")

KN_PER_MPS = 3600.0 / 1852.0


def ais_report_interval_s(speed_mps, ais_class: str = "A"):
    """Longest nominal interval between AIS position reports of a vessel at this speed.

    ITU-R M.1371-5, Table 1 (class A, not turning: 3 min below 3 kn -- anchored, moored or
    nearly stopped --, 10 s at 3-14 kn, 6 s at 14-23 kn, 2 s above) and class B "CS" (3 min at
    2 kn or less, 30 s above).

    Parameters
    ----------
    speed_mps : float or array_like
        Speed over ground, m/s (NaN: unknown, which gives the slowest rate, 180 s).
    ais_class : {"A", "B"}

    Returns
    -------
    float or ndarray
        Seconds.
    """
    kn = np.asarray(speed_mps, float) * KN_PER_MPS
    kn = np.where(np.isfinite(kn), kn, 0.0)
    if ais_class == "A":
        out = np.select([kn < 3.0, kn <= 14.0, kn <= 23.0], [180.0, 10.0, 6.0], 2.0)
    elif ais_class == "B":
        out = np.where(kn <= 2.0, 180.0, 30.0)
    else:
        raise ValueError(f"ais_report_interval_s: ais_class must be 'A' or 'B', not {ais_class!r}")
    return float(out) if out.ndim == 0 else out


@dataclass
class Alert:
    """One alert event (times in the frame clock, seconds)."""

    t_s: float
    kind: str
    message: str
    camera_id: str = "cam0"
    track_id: int | None = None
    mmsi: int = 0
    lat: float = float("nan")
    lon: float = float("nan")
    az_deg: float = float("nan")

    def to_dict(self) -> dict:
        d = asdict(self)
        for k in ("lat", "lon", "az_deg"):
            v = d[k]
            d[k] = None if v is None or not math.isfinite(v) else round(float(v), 7)
        d["t_s"] = round(float(self.t_s), 3)
        return d

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), separators=(", ", ": "))


def write_alerts_jsonl(alerts: Iterable[Alert], path: str | Path, append: bool = True) -> Path:
    """Write alerts as JSON Lines (appending by default)."""
    p = Path(path)
    with open(p, "a" if append else "w", encoding="utf-8") as fh:
        for a in alerts:
            fh.write(a.to_json() + "\n")
    return p


def read_alerts_jsonl(path: str | Path) -> list[Alert]:
    """Read alerts written by :func:`write_alerts_jsonl`."""
    out = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if line.strip():
                d = json.loads(line)
                for k in ("lat", "lon", "az_deg"):
                    if d.get(k) is None:
                        d[k] = float("nan")
                out.append(Alert(**d))
    return out
