"""Fusion of camera tracks with AIS and radar/VTS: identities, fused picture, alerts.

API (for the pipeline)
----------------------
``build_fuser(config, ais=None, camera=None, fps=25.0, radar=None) -> Fuser``
    ``ais``: a file or folder (NMEA, FVessel/Solent CSV, see :mod:`seawatch.io.ais`), a
    ``udp://HOST:PORT`` / ``tcp://HOST:PORT`` URL, a list of :class:`~seawatch.types.AISReport`
    or an object with ``poll()``.  ``camera``: the base :class:`~seawatch.camera.CameraModel`
    (required).  Settings come from ``config.fusion`` (:class:`~seawatch.config.FusionSettings`).

``Fuser.update(tracks, frame, t_s) -> (tracks_with_mmsi, alerts)``
    Call once per frame with the tracker's :class:`~seawatch.types.Tracks` (all states), the
    :class:`~seawatch.types.Frame` (its ``ptz``/``pose`` select the per-frame camera model; may
    be None for a fixed camera) and the frame time.  AIS reports are released to the fusion when
    ``t_s + fusion.ais_time_offset_s`` reaches their time (a file replays in step with the video;
    nothing from the future is used).  Returns a copy of the tracks with

    * ``mmsi`` (N,) int64, 0 where no AIS vessel is associated;
    * ``world`` (N, 4) lat, lon, speed m/s, course deg: the camera bearing combined with the AIS
      (else radar) range when matched, the waterline's sea-surface position otherwise;
    * ``names``: list of vessel names (or None), same order;

    and a list of :class:`~seawatch.fuse.alerts.Alert` (``to_dict()``/``to_json()`` give the JSON
    Lines event): ``no_ais``, ``ais_not_seen``, ``possible_spoofing``.

``Fuser.picture() -> list[FusedTrack]``
    The fused picture of the latest update: confirmed camera tracks (with MMSI, name, type) plus
    the AIS vessels (id ``-mmsi``) and radar tracks the camera does not see (occluded or outside).
``Fuser.calibration`` -> dict
    Self-calibrated heading (``pan_offset_deg``) and tilt offsets with standard errors, and the
    paper's rotation theta (robust estimate; ``calibrate_theta()`` runs the policy-gradient search).
``Fuser.add_ais(...)``, ``Fuser.add_radar(plots)``, ``Fuser.summary()``, ``Fuser.close()``.

Building blocks: :class:`~seawatch.fuse.table.TargetTable` (per-MMSI state in arrays, dead
reckoning), :mod:`seawatch.fuse.associate` (geometric cost, windowed one-to-one association),
:mod:`seawatch.fuse.theta` (velocity matching through theta, policy gradient and robust
estimates), :mod:`seawatch.fuse.alerts`.  See ``docs/fusion.md``.
"""

from __future__ import annotations

from seawatch.fuse.alerts import ALERT_KINDS, Alert, ais_report_interval_s, read_alerts_jsonl, write_alerts_jsonl
from seawatch.fuse.fuser import Calibration, Fuser
from seawatch.fuse.table import TargetTable, dead_reckon_enu, dead_reckon_geodetic

__all__ = [
    "ALERT_KINDS",
    "Alert",
    "Calibration",
    "Fuser",
    "TargetTable",
    "ais_report_interval_s",
    "build_fuser",
    "dead_reckon_enu",
    "dead_reckon_geodetic",
    "read_alerts_jsonl",
    "write_alerts_jsonl",
]


def build_fuser(config, ais=None, camera=None, fps: float = 25.0, radar=None) -> Fuser:
    """A :class:`Fuser` from a configuration (``config.fusion``), an AIS source and a camera.

    Raises
    ------
    ValueError
        When no camera model is given (fusion needs the camera geometry).
    """
    if camera is None:
        raise ValueError("fusion needs a camera model (give a camera file with --camera)")
    settings = getattr(config, "fusion", config)
    return Fuser(camera, settings, ais=ais, radar=radar, camera_id=getattr(getattr(config, "run", None),
                                                                          "camera_id", "cam0"))
