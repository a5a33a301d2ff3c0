"""FVessel clip-01: project the AIS positions of the ground-truth vessels through the camera model.

For every ground-truth second the vessel's latest AIS report is dead-reckoned (SOG/COG) to that
second and projected with ``camera_para.txt``; the horizontal pixel error is measured against the
centre of the vessel's ground-truth box, and we count the seconds in which the projection falls
inside the box horizontally.  Video second ``s`` is taken as Unix time ``t0 + s`` where ``t0`` is
the first AIS snapshot (12:05:12 UTC+8, the clip's start).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

NAME = "camera"
DESCRIPTION = "FVessel clip-01: AIS positions projected through the camera model vs ground-truth boxes"

T0_UNIX_S = 1654315512.0  # 2022-06-04 12:05:12 UTC+8, first AIS snapshot of clip-01


def _read_reports(ais_dir: Path) -> dict[int, np.ndarray]:
    """All distinct valid reports per MMSI: rows (t_s, lat, lon, sog_kn, cog_deg), time-sorted."""
    seen: dict[tuple[int, int], tuple] = {}
    for f in sorted(ais_dir.glob("*.csv")):
        with open(f, newline="") as fh:
            for row in csv.DictReader(fh):
                lat, lon = float(row["lat"]), float(row["lon"])
                if not (-90 <= lat <= 90 and -180 <= lon <= 180):
                    continue
                key = (int(row["mmsi"]), int(row["timestamp"]))
                seen[key] = (key[1] / 1000.0, lat, lon, float(row["speed"]), float(row["course"]))
    out: dict[int, list] = {}
    for (mmsi, _), rec in seen.items():
        out.setdefault(mmsi, []).append(rec)
    return {m: np.array(sorted(r)) for m, r in out.items()}


def _dead_reckon(reports: np.ndarray, t_s: np.ndarray):
    import pymap3d

    idx = np.clip(np.searchsorted(reports[:, 0], t_s, side="right") - 1, 0, len(reports) - 1)
    r = reports[idx]
    dist = r[:, 3] * 0.514444 * (t_s - r[:, 0])
    cog = np.radians(r[:, 4])
    lat, lon, _ = pymap3d.enu2geodetic(dist * np.sin(cog), dist * np.cos(cog), 0.0, r[:, 1], r[:, 2], 0.0)
    return lat, lon


def run(ctx) -> None:
    from seawatch.camera import load_fvessel_camera

    root = ctx.data("fvessel_clip01")
    cam = load_fvessel_camera(root / "camera_para.txt")
    reports = _read_reports(root / "ais")
    gt = np.loadtxt(root / "gt" / "clip-01_gt_fusion.txt", delimiter=",", ndmin=2)
    t0 = time.perf_counter()
    for mmsi in np.unique(gt[:, 1]).astype(int):
        rows = gt[gt[:, 1] == mmsi]
        lat, lon = _dead_reckon(reports[mmsi], T0_UNIX_S + rows[:, 0])
        u, v, _ = cam.geodetic_to_pixel(lat, lon, 0.0)
        left, top, w, h = rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5]
        err_u = u - (left + w / 2)
        inside = (u >= left) & (u <= left + w)
        name = str(mmsi)
        ctx.record("fvessel_clip01", name, "median_abs_u_error", float(np.median(np.abs(err_u))), "px")
        ctx.record("fvessel_clip01", name, "mean_u_error", float(np.mean(err_u)), "px")
        ctx.record("fvessel_clip01", name, "inside_box_u_frac", float(inside.mean()), "fraction",
                   target=0.9 if mmsi == 380000000 else None)
        ctx.record("fvessel_clip01", name, "median_v_error_vs_box_bottom", float(np.median(v - (top + h))), "px")
        ctx.record("fvessel_clip01", name, "seconds", float(len(rows)), "s")
    dt = (time.perf_counter() - t0) / max(1, len(gt))
    ctx.record("fvessel_clip01", "camera_model", "ms_per_projection", dt * 1000, "ms")
