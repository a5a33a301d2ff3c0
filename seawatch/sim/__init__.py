"""Synthetic maritime world: EO/IR video with exact ground truth, AIS and radar.

API (others code against it)
----------------------------
``from seawatch.sim import make_scenario, make_multicam, SCENARIOS``

* ``SCENARIOS``: names -> builders: ``"harbour"`` (fixed camera, 6 vessels, one without AIS, the
  ferry partly hides the sailboat, coastline), ``"pan"`` (panning + zooming PTZ camera with shake,
  JPEG), ``"ir"`` (thermal harbour, halo), ``"crossing"`` (two boats, the near one fully hides the
  far one around t = 12 s), ``"open_sea"`` (rolling horizon, far ships, one spoofed AIS position).
* ``scn = make_scenario(name, seed=0, width=704, height=576, duration_s=None, fps=None)``;
  attributes ``name, fps, duration_s, n_frames, modality, camera`` (base ``CameraModel``),
  ``vessels`` (``VesselSpec``: ``id, mmsi`` (0 = no AIS), ``name, type, length_m, beam_m, ais_class``),
  ``world, origin`` (lat, lon of the world ENU origin), ``schedule`` (``PTZSchedule``), ``shake``,
  ``camera_id``, ``width, height``.
* ``scn.render(i) -> Frame`` (``pose`` = nominal pose without shake, ``ptz`` = commanded state);
  ``scn.ground_truth(i) -> GroundTruth``; ``scn.iter_frames(start=0, stop=None, step=1)`` yields
  ``(Frame, GroundTruth)``; ``scn.time_s(i) = i / fps``; ``scn.camera_at(i)`` (true camera incl. shake);
  ``scn.ptz_at(i)``; ``scn.label_image(i)`` (H, W) vessel-id image = exact masks;
  ``scn.render_empty(i)`` the same frame without vessels.
* ``GroundTruth``: ``t_s, frame_index, ids (N,), boxes (N, 4)`` x, y, w, h of the visible pixels
  (clipped), ``visible (N,)`` fraction, ``enu_m (N, 3)``, ``lat_deg, lon_deg (N,)``, ``mmsi (N,)``
  (0 = no AIS), plus ``full_boxes, visible_px, full_px, azel_deg (N, 2), range_m, water_row (W,)``
  (first water row per column: sea horizon or coast water line), ``pose`` (true), ``ptz``.
  Vessels whose unoccluded silhouette touches the image are listed (hidden ones with visible 0).
* AIS: ``scn.ais_reports() -> list[AISReport]`` (``t_s`` = receive time, sorted; class A/B
  intervals, GNSS noise, latency, drops, AIS-off vessels absent, optional spoof),
  ``scn.ais_nmea() -> list[(t_s, "!AIVDM...")]``, ``scn.ais_truth()`` (transmit/receive times, true
  and reported positions, spoof flag).
* Radar: ``scn.radar_plots()``, ``scn.radar_tracks()`` -> structured arrays
  ``(t_s, id, lat, lon, range_m, bearing_deg, speed_mps, course_deg, truth_id)``.
* ``scn.write(out_dir)``: video.mp4, gt.txt (MOT17 ground truth), gt.jsonl, ais.nmea (tag block
  ``\\c:<t_s>*hh\\`` + sentence), ais_truth.csv, camera.toml, ptz.csv, radar.csv,
  radar_tracks.csv, scenario.json.
* ``mc = make_multicam(seed=0, width=704, height=576, duration_s=None, fps=None, n_cameras=3)``:
  ``mc.views`` (one ``Scenario`` per camera, ``camera_id`` cam0..), ``mc.render(i)`` /
  ``mc.ground_truth(i)`` (lists), ``mc.world_truth(i)``, ``mc.ais_reports()``, ``mc.write(dir)``.

Lower level: :mod:`seawatch.sim.world` (vessel types, ``Trajectory``, ``make_vessel``),
:mod:`seawatch.sim.render` (``Renderer``, ``RenderOptions``), :mod:`seawatch.sim.texture`
(``SkySpec``, ``CoastSpec``, ``WaveField``), :mod:`seawatch.sim.schedule` (``PTZSchedule``,
``Shake``), :mod:`seawatch.sim.ais`, :mod:`seawatch.sim.radar`.  See ``docs/simulator.md``.
"""

from seawatch.sim.ais import AISConfig, AISStream, simulate_ais
from seawatch.sim.radar import RADAR_DTYPE, RadarConfig, simulate_radar
from seawatch.sim.render import Renderer, RenderOptions
from seawatch.sim.scenarios import (
    SCENARIOS,
    GroundTruth,
    MultiCamScenario,
    Scenario,
    make_multicam,
    make_scenario,
    scenario_names,
)
from seawatch.sim.schedule import PTZSchedule, Shake
from seawatch.sim.texture import CoastSpec, SkySpec, WaveField
from seawatch.sim.world import VESSEL_TYPES, Trajectory, VesselSpec, World, make_vessel

__all__ = [
    "AISConfig", "AISStream", "simulate_ais", "RADAR_DTYPE", "RadarConfig", "simulate_radar", "Renderer",
    "RenderOptions", "SCENARIOS", "GroundTruth", "MultiCamScenario", "Scenario", "make_multicam",
    "make_scenario", "scenario_names", "PTZSchedule", "Shake", "CoastSpec", "SkySpec", "WaveField",
    "VESSEL_TYPES", "Trajectory", "VesselSpec", "World", "make_vessel",
]
