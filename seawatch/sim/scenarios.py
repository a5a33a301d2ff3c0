"""Named synthetic scenarios: a world, a camera (fixed or moving), AIS and radar, exact ground truth.

``make_scenario(name, seed=0, width=704, height=576, duration_s=None, fps=None)`` builds one of
:data:`SCENARIOS`; :func:`make_multicam` builds the same world seen by several cameras (paper C).
Frames are addressed by index ``i`` at time ``t_s = i / fps``; any frame renders the same in any
order (the noise is seeded by the frame index).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

import cv2
import numpy as np
import pymap3d

from seawatch.camera import CameraModel, Intrinsics, save_camera
from seawatch.sim.ais import AISConfig, AISStream, simulate_ais
from seawatch.sim.radar import RadarConfig, simulate_radar
from seawatch.sim.render import Renderer, RenderOptions, RenderResult
from seawatch.sim.schedule import PTZSchedule, Shake
from seawatch.sim.texture import CoastSpec, SkySpec
from seawatch.sim.world import Trajectory, VesselSpec, World, make_vessel
from seawatch.types import AISReport, CameraPose, Frame, Modality, PTZState

__all__ = ["GroundTruth", "Scenario", "MultiCamScenario", "SCENARIOS", "make_scenario", "make_multicam",
           "scenario_names"]


@dataclass
class GroundTruth:
    """Exact ground truth of one frame.

    Only vessels whose unoccluded silhouette touches the image are listed (a vessel hidden behind
    a nearer one is listed with ``visible == 0``).

    Attributes
    ----------
    t_s, frame_index : time and 0-based index of the frame
    ids : (N,) int64 vessel ids
    boxes : (N, 4) float64 x, y, w, h of the visible pixels (pixel-aligned extent: ``x, y`` the
        top-left pixel, ``w, h`` in pixels; clipped to the image).  For a fully hidden vessel
        (``visible == 0``) the box of its unoccluded silhouette.
    visible : (N,) float64 fraction of the vessel's silhouette that is visible (after occlusion by
        nearer vessels and the image border)
    enu_m : (N, 3) world ENU position of the vessel's centre on the waterline
    lat_deg, lon_deg : (N,) geodetic position of the same point
    mmsi : (N,) int64 MMSI, 0 when the vessel has no AIS
    full_boxes : (N, 4) unoccluded silhouette extent, clipped to the image
    visible_px, full_px : (N,) int64 visible / unoccluded silhouette pixel counts
    azel_deg : (N, 2) azimuth and elevation of the vessel's waterline centre from the camera
    range_m : (N,) ground distance from the camera
    water_row : (W,) first row of water in each image column (sea horizon or coast water line;
        fractional rows are rounded up to the first pixel whose centre is on the water)
    pose : the camera's true pose in this frame (shake included)
    ptz : the commanded pan/tilt/zoom state
    """

    t_s: float
    frame_index: int
    ids: np.ndarray
    boxes: np.ndarray
    visible: np.ndarray
    enu_m: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    mmsi: np.ndarray
    full_boxes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    visible_px: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    full_px: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    azel_deg: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    range_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    water_row: np.ndarray = field(default_factory=lambda: np.zeros(0))
    camera_id: str = "cam0"
    pose: CameraPose | None = None
    ptz: PTZState | None = None

    def __len__(self) -> int:
        return len(self.ids)

    def subset(self, mask) -> "GroundTruth":
        """The listed vessels selected by a boolean mask or index array."""
        kw = {}
        for f in dataclasses.fields(self):
            val = getattr(self, f.name)
            if isinstance(val, np.ndarray) and f.name != "water_row" and len(val) == len(self.ids):
                val = val[mask]
            kw[f.name] = val
        return GroundTruth(**kw)


def _affine_world_to_camera(lat0, lon0, lat_c, lon_c, extent_m=15000.0) -> np.ndarray | None:
    """Affine (2, 3) from the world's ENU (e, n) to a camera's ENU, fitted on a grid (exact to mm)."""
    if abs(lat0 - lat_c) < 1e-12 and abs(lon0 - lon_c) < 1e-12:
        return None
    g = np.linspace(-extent_m, extent_m, 9)
    E, N = np.meshgrid(g, g)
    lat, lon, alt = pymap3d.enu2geodetic(E.ravel(), N.ravel(), np.zeros(E.size), lat0, lon0, 0.0)
    e2, n2, _ = pymap3d.geodetic2enu(lat, lon, np.zeros(E.size), lat_c, lon_c, 0.0)
    X = np.stack([E.ravel(), N.ravel(), np.ones(E.size)], axis=1)
    coef, *_ = np.linalg.lstsq(X, np.stack([e2, n2], axis=1), rcond=None)
    return coef.T


class Scenario:
    """A synthetic scene seen by one camera, with exact ground truth, AIS and radar.

    Attributes
    ----------
    name, fps, duration_s, n_frames, modality, camera, vessels, world, seed, camera_id
    width, height : image size
    origin : (lat_deg, lon_deg) of the world's ENU origin
    schedule : PTZSchedule of the camera (a fixed one for fixed cameras)
    shake : Shake or None
    """

    def __init__(
        self,
        name: str,
        world: World,
        camera: CameraModel,
        *,
        fps: float,
        duration_s: float,
        origin: tuple[float, float] | None = None,
        schedule: PTZSchedule | None = None,
        shake: Shake | None = None,
        sky: SkySpec = SkySpec(),
        coasts: tuple[CoastSpec, ...] = (),
        options: RenderOptions = RenderOptions(),
        seed: int = 0,
        camera_id: str = "cam0",
        ais_config: AISConfig | None = AISConfig(),
        radar_config: RadarConfig | None = None,
        description: str = "",
        ais_seed: int | None = None,
    ):
        if fps <= 0 or duration_s <= 0:
            raise ValueError(f"scenario {name!r}: fps and duration_s must be positive, got {fps}, {duration_s}")
        self._init_args = dict(name=name, world=world, camera=camera, fps=fps, duration_s=duration_s, origin=origin,
                               schedule=schedule, shake=shake, sky=sky, coasts=coasts, options=options, seed=seed,
                               camera_id=camera_id, ais_config=ais_config, radar_config=radar_config,
                               description=description, ais_seed=ais_seed)
        self.options = options
        self.name = name
        self.description = description
        self.world = world
        self.vessels: list[VesselSpec] = world.vessels
        self.camera = camera
        self.width, self.height = camera.intrinsics.width, camera.intrinsics.height
        self.fps = float(fps)
        self.duration_s = float(duration_s)
        self.n_frames = max(1, int(round(self.duration_s * self.fps)))
        self.modality = Modality.IR if options.ir else Modality.EO
        self.seed = int(seed)
        self.camera_id = camera_id
        self.origin = origin or (camera.pose.lat_deg, camera.pose.lon_deg)
        p = camera.pose
        self.schedule = schedule or PTZSchedule.fixed(p.pan_deg, p.tilt_deg, 1.0)
        self.shake = shake
        self.ais_config = ais_config
        self.radar_config = radar_config
        self.ais_seed = self.seed if ais_seed is None else int(ais_seed)
        (pmin, pmax), (tmin, tmax), zmax = self.schedule.extremes()
        sp = shake.pan_deg if shake else 0.0
        st = shake.tilt_deg if shake else 0.0
        self.world_to_camera = _affine_world_to_camera(self.origin[0], self.origin[1], p.lat_deg, p.lon_deg)
        self.renderer = Renderer(
            world, self.width, self.height, camera,
            pan_range_deg=(pmin - sp, pmax + sp), tilt_range_deg=(tmin - st, tmax + st), max_zoom=zmax,
            max_roll_deg=abs(p.roll_deg) + (shake.max_roll_deg if shake else 0.0),
            sky=sky, coasts=coasts, options=options, seed=self.seed, world_to_camera=self.world_to_camera,
        )
        self._last: tuple[int, RenderResult] | None = None
        self._fixed_cam: CameraModel | None = None
        self._ptz_last: tuple | None = None  # (frame, schedule, fps, its commanded state)
        self._ais: AISStream | None = None
        self._radar = None

    def with_render_options(self, **changes) -> "Scenario":
        """The same scenario rendered with changed :class:`RenderOptions` (e.g. ``noise_sigma=0``)."""
        kw = dict(self._init_args)
        kw["options"] = dataclasses.replace(self.options, **changes)
        name, world, camera = kw.pop("name"), kw.pop("world"), kw.pop("camera")
        return Scenario(name, world, camera, **kw)

    # ------------------------------------------------------------------ time & camera
    def time_s(self, i: int) -> float:
        """Time of frame ``i`` (seconds from the start)."""
        return i / self.fps

    def _check(self, i: int) -> int:
        i = int(i)
        if not 0 <= i < self.n_frames:
            raise IndexError(f"scenario {self.name!r}: frame {i} outside 0..{self.n_frames - 1}")
        return i

    def ptz_at(self, i: int) -> PTZState:
        """Commanded pan/tilt/zoom of frame ``i`` (what a PTZ controller reports)."""
        last = self._ptz_last  # (the frame just asked for, unless the schedule or the rate changed since)
        if last is not None and last[0] == i and last[1] is self.schedule and last[2] == self.fps:
            return last[3]
        ptz = self.schedule.at(self.time_s(i))
        self._ptz_last = (i, self.schedule, self.fps, ptz)
        return ptz

    def nominal_pose(self, i: int) -> CameraPose:
        ptz = self.ptz_at(i)
        return dataclasses.replace(self.camera.pose, pan_deg=ptz.pan_deg, tilt_deg=ptz.tilt_deg)

    def camera_at(self, i: int) -> CameraModel:
        """The true camera of frame ``i``: commanded PTZ plus shake."""
        if self.shake is None and len(self.schedule.times_s) == 1:  # a fixed camera
            if self._fixed_cam is None:
                self._fixed_cam = self.camera.with_ptz(self.schedule.at(0.0))
            return self._fixed_cam
        ptz = self.ptz_at(i)
        p = self.camera.pose
        pan, tilt, roll = ptz.pan_deg, ptz.tilt_deg, p.roll_deg
        if self.shake is not None:
            dp, dt, dr = self.shake.at(self.time_s(i))
            pan, tilt, roll = (pan + dp) % 360.0, tilt + dt, roll + dr
        # (what camera.with_ptz(ptz).with_pose(...) gives, built once: a CameraModel, never a subclass)
        return CameraModel(self.camera.intrinsics.zoomed(ptz.zoom),
                           dataclasses.replace(p, pan_deg=pan, tilt_deg=tilt, roll_deg=roll), self.camera.refraction_k)

    # ------------------------------------------------------------------------ frames
    def _render(self, i: int) -> RenderResult:
        i = self._check(i)
        if self._last is not None and self._last[0] == i:
            return self._last[1]
        res = self.renderer.render(self.time_s(i), self.camera_at(i), frame_seed=i)
        self._last = (i, res)
        return res

    def render(self, i: int) -> Frame:
        """Frame ``i`` (``pose`` is the nominal pose, without shake; ``ptz`` the commanded state)."""
        res = self._render(i)
        if res.image is None:  # handed out before (and maybe drawn on by its user): render again
            self._last = None
            res = self._render(i)
        image, res.image = res.image, None
        return Frame(image=image, t_s=self.time_s(i), index=int(i), camera_id=self.camera_id,
                     modality=self.modality, pose=self.nominal_pose(i), ptz=self.ptz_at(i))

    def render_empty(self, i: int) -> np.ndarray:
        """Frame ``i`` without any vessel (same sea, sky, coast and noise)."""
        i = self._check(i)
        return self.renderer.render(self.time_s(i), self.camera_at(i), frame_seed=i, draw_vessels=False).image

    def label_image(self, i: int) -> np.ndarray:
        """(H, W) int64 image of vessel ids (0 = no vessel) of frame ``i``: the exact vessel masks."""
        res = self._render(i)
        ids = np.array([0] + [v.id for v in self.vessels], np.int64)
        return ids[res.label]

    def ground_truth(self, i: int) -> GroundTruth:
        """Exact ground truth of frame ``i``."""
        res = self._render(i)
        t = self.time_s(i)
        idx = res.index
        vs = [self.vessels[k] for k in idx]
        st = np.array([[float(x) for x in v.state(t)] for v in vs]).reshape(-1, 4)
        enu = np.zeros((len(vs), 3))
        enu[:, :2] = st[:, :2]
        if len(vs):
            lat, lon, _ = pymap3d.enu2geodetic(enu[:, 0], enu[:, 1], np.zeros(len(vs)), self.origin[0],
                                               self.origin[1], 0.0)
        else:
            lat = lon = np.zeros(0)
        cam = self.camera_at(i)
        ce, cn = enu[:, 0], enu[:, 1]
        if self.world_to_camera is not None:
            A = self.world_to_camera
            ce = A[0, 0] * enu[:, 0] + A[0, 1] * enu[:, 1] + A[0, 2]
            cn = A[1, 0] * enu[:, 0] + A[1, 1] * enu[:, 1] + A[1, 2]
        rng_m = np.hypot(ce, cn)
        az = np.degrees(np.arctan2(ce, cn)) % 360.0
        drop = rng_m ** 2 / (2 * cam.r_eff_m)
        el = np.degrees(np.arctan2(-(cam.pose.height_m + drop), rng_m))
        return GroundTruth(
            t_s=t, frame_index=int(i), ids=np.array([v.id for v in vs], np.int64), boxes=res.boxes.copy(),
            visible=res.visible.copy(), enu_m=enu, lat_deg=np.asarray(lat, float).reshape(-1),
            lon_deg=np.asarray(lon, float).reshape(-1), mmsi=np.array([v.mmsi for v in vs], np.int64),
            full_boxes=res.full_boxes.copy(), visible_px=res.visible_px.copy(), full_px=res.full_px.copy(),
            azel_deg=np.stack([az, el], axis=1).reshape(-1, 2), range_m=rng_m, water_row=res.water_row.copy(),
            camera_id=self.camera_id, pose=cam.pose, ptz=self.ptz_at(i),
        )

    def frame_and_truth(self, i: int) -> tuple[Frame, GroundTruth]:
        return self.render(i), self.ground_truth(i)

    def iter_frames(self, start: int = 0, stop: int | None = None,
                    step: int = 1) -> Iterator[tuple[Frame, GroundTruth]]:
        """``(Frame, GroundTruth)`` for frames ``start, start + step, ... < stop``."""
        stop = self.n_frames if stop is None else min(stop, self.n_frames)
        for i in range(start, stop, step):
            yield self.render(i), self.ground_truth(i)

    def __len__(self) -> int:
        return self.n_frames

    # ------------------------------------------------------------------ AIS & radar
    def ais_stream(self) -> AISStream:
        if self._ais is None:
            cfg = self.ais_config or AISConfig()
            self._ais = simulate_ais(self.world, self.origin[0], self.origin[1], self.duration_s, cfg, self.ais_seed)
        return self._ais

    def ais_reports(self) -> list[AISReport]:
        """Decoded AIS reports, sorted by receive time (``t_s``)."""
        return list(self.ais_stream().reports)

    def ais_nmea(self) -> list[tuple[float, str]]:
        """``(receive time, !AIVDM sentence)`` pairs."""
        return self.ais_stream().nmea()

    def ais_truth(self) -> np.ndarray:
        """One row per AIS message: MMSI, vessel id, type, transmit and receive times, true and reported
        positions, spoof flag."""
        return self.ais_stream().truth

    def _radar_data(self):
        if self._radar is None:
            cfg = self.radar_config or RadarConfig()
            self._radar = simulate_radar(self.world, self.origin[0], self.origin[1], self.duration_s, cfg,
                                         self.ais_seed)
        return self._radar

    def radar_plots(self) -> np.ndarray:
        """Radar plots (structured array, see :data:`seawatch.sim.radar.RADAR_DTYPE`)."""
        return self._radar_data()[0]

    def radar_tracks(self) -> np.ndarray:
        """Radar (VTS) tracks (structured array, see :data:`seawatch.sim.radar.RADAR_DTYPE`)."""
        return self._radar_data()[1]

    # -------------------------------------------------------------------------- files
    def vessel_table(self) -> list[dict]:
        return [dict(id=v.id, mmsi=v.mmsi, name=v.name, type=v.type, length_m=round(v.length_m, 2),
                     beam_m=round(v.beam_m, 2), ais_class=v.ais_class, ship_type=v.ship_type, callsign=v.callsign)
                for v in self.vessels]

    def write(self, out_dir, progress: Callable[[int, int], None] | None = None) -> dict[str, Path]:
        """Write the scenario to ``out_dir``.

        Files: ``video.mp4`` (mp4v), ``gt.txt`` (MOTChallenge ground truth
        ``frame,id,x,y,w,h,1,1,visibility`` with 1-based frames), ``gt.jsonl`` (one object per vessel
        per frame), ``ais.nmea`` (``\\c:<receive time>*hh\\!AIVDM...`` lines), ``ais_truth.csv``,
        ``camera.toml`` (base camera), ``ptz.csv`` (``t_s,pan_deg,tilt_deg,zoom`` per frame),
        ``radar.csv`` and ``radar_tracks.csv``, ``scenario.json`` (metadata and vessels).
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {k: out / f for k, f in [
            ("video", "video.mp4"), ("gt", "gt.txt"), ("gt_jsonl", "gt.jsonl"), ("ais", "ais.nmea"),
            ("ais_truth", "ais_truth.csv"), ("camera", "camera.toml"), ("ptz", "ptz.csv"),
            ("radar", "radar.csv"), ("radar_tracks", "radar_tracks.csv"), ("meta", "scenario.json")]}
        writer = cv2.VideoWriter(str(paths["video"]), cv2.VideoWriter_fourcc(*"mp4v"), self.fps,
                                 (self.width, self.height), True)
        if not writer.isOpened():
            raise OSError(f"cannot open a video writer for {paths['video']}")
        names = {v.id: v for v in self.vessels}
        try:
            with open(paths["gt"], "w", encoding="utf-8") as gt_fh, \
                    open(paths["gt_jsonl"], "w", encoding="utf-8") as js_fh, \
                    open(paths["ptz"], "w", encoding="utf-8") as ptz_fh:
                ptz_fh.write("t_s,pan_deg,tilt_deg,zoom\n")
                for i in range(self.n_frames):
                    frame, gt = self.render(i), self.ground_truth(i)
                    img = frame.image if frame.image.ndim == 3 else cv2.cvtColor(frame.image, cv2.COLOR_GRAY2BGR)
                    writer.write(img)
                    p = frame.ptz
                    ptz_fh.write(f"{frame.t_s:.6f},{p.pan_deg:.6f},{p.tilt_deg:.6f},{p.zoom:.6f}\n")
                    for j in range(len(gt)):
                        x, y, w, h = gt.boxes[j]
                        gt_fh.write(f"{i + 1},{gt.ids[j]},{x:.2f},{y:.2f},{w:.2f},{h:.2f},1,1,{gt.visible[j]:.4f}\n")
                        v = names[int(gt.ids[j])]
                        js_fh.write(json.dumps({
                            "frame": i, "t_s": round(gt.t_s, 6), "camera_id": self.camera_id, "id": int(gt.ids[j]),
                            "box": [float(b) for b in gt.boxes[j]], "visible": round(float(gt.visible[j]), 5),
                            "mmsi": int(gt.mmsi[j]), "name": v.name, "type": v.type,
                            "lat": round(float(gt.lat_deg[j]), 8), "lon": round(float(gt.lon_deg[j]), 8),
                            "enu_m": [round(float(c), 3) for c in gt.enu_m[j]],
                            "azel_deg": [round(float(c), 5) for c in gt.azel_deg[j]],
                        }) + "\n")
                    if progress:
                        progress(i + 1, self.n_frames)
        finally:
            writer.release()
        self.ais_stream().write_nmea(paths["ais"])
        tr = self.ais_truth()
        with open(paths["ais_truth"], "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(tr.dtype.names)
            for row in tr:
                w.writerow([int(x) if isinstance(x, (np.integer, np.bool_)) else x for x in row.tolist()])
        save_camera(self.camera, paths["camera"])
        for key, arr in (("radar", self.radar_plots()), ("radar_tracks", self.radar_tracks())):
            with open(paths[key], "w", newline="", encoding="utf-8") as fh:
                w = csv.writer(fh)
                w.writerow(arr.dtype.names)
                for row in arr:
                    w.writerow(row.tolist())
        meta = dict(name=self.name, description=self.description, seed=self.seed, fps=self.fps,
                    duration_s=self.duration_s, n_frames=self.n_frames, modality=self.modality.value,
                    width=self.width, height=self.height, camera_id=self.camera_id,
                    origin_lat_deg=self.origin[0], origin_lon_deg=self.origin[1], vessels=self.vessel_table())
        paths["meta"].write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
        return paths


# ---------------------------------------------------------------------------- builders
def _polar(az_deg: float, r_m: float, origin=(0.0, 0.0)) -> tuple[float, float]:
    a = math.radians(az_deg)
    return origin[0] + r_m * math.sin(a), origin[1] + r_m * math.cos(a)


def _straight(az_deg, r_m, course_deg, speed_mps, origin=(0.0, 0.0)) -> Trajectory:
    e, n = _polar(az_deg, r_m, origin)
    return Trajectory(e, n, course_deg, ((1e9, speed_mps, 0.0),))


def _camera(width, height, hfov_deg, lat, lon, height_m, pan, tilt, roll=0.0) -> CameraModel:
    return CameraModel(Intrinsics.from_fov(hfov_deg, width, height),
                       CameraPose(lat_deg=lat, lon_deg=lon, height_m=height_m, pan_deg=pan, tilt_deg=tilt,
                                  roll_deg=roll))


def _harbour(seed, width, height, duration_s, fps, ir=False, name="harbour"):
    """Fixed harbour camera, 6 vessels (one without AIS), the ferry partly hides a sailboat, coastline."""
    rng = np.random.default_rng([seed, 1])
    cam = _camera(width, height, 50.0, 50.7950, -1.1080, 22.0, 160.0, -3.5)
    j = lambda s=1.0: float(rng.uniform(-s, s))  # small seeded variations
    vs = [
        make_vessel(1, "ferry", Trajectory(*_polar(148 + j(0.5), 700), 238.0, ((1e9, 6.0, 0.0),)), rng,
                    length_m=70.0, ais="A"),
        make_vessel(2, "sailboat", _straight(158 + j(0.3), 1050, 60.0, 1.2), rng, length_m=11.0, ais="B"),
        make_vessel(3, "rib", Trajectory(*_polar(182 + j(), 260), 92.0, ((10.0, 8.0, 0.0), (20.0, 8.0, 9.0),
                                                                          (1e9, 8.0, 0.0))), rng, ais=False),
        make_vessel(4, "fishing", Trajectory(*_polar(176 + j(), 420), 120.0, ((20.0, 2.5, 0.0), (1e9, 2.5, 1.5))),
                    rng, length_m=18.0, ais="A"),
        make_vessel(5, "cargo", _straight(165 + j(), 2000, 80.0, 4.0), rng, length_m=140.0, ais="A"),
        make_vessel(6, "tug", _straight(141 + j(), 320, 200.0, 1.5), rng, ais="A"),
    ]
    sky = SkySpec(sun_az_deg=175.0, sun_el_deg=22.0)
    if ir:
        sky = SkySpec(sun_az_deg=175.0, sun_el_deg=-10.0, clouds=0.2)
    coasts = (CoastSpec(az_from_deg=118.0, az_to_deg=206.0, distance_m=2900.0, distance_slope=0.25, hill_m=45.0,
                        structures=30, seed=seed + 3),)
    opts = RenderOptions(ir=ir, noise_sigma=2.5 if ir else 2.0, blur_sigma_px=0.7 if ir else 0.0,
                         glint=0.0 if ir else 1.0, wave_contrast=0.5 if ir else 1.0)
    desc = ("fixed harbour camera, six vessels (ferry, sailboat, RIB without AIS, fishing boat, cargo ship, tug), "
            "the ferry partly hides the sailboat, a coastline with buildings, the fishing boat's AIS position "
            "spoofed 300 m west (out of the view) from t = 20 s")
    if ir:
        desc = ("thermal (IR, white-hot) view of a harbour at dusk: halo around warm vessels, no glints; the "
                "fishing boat's AIS position spoofed from t = 20 s")
    # the fishing boat's AIS positions are shifted 300 m west, across the camera's bearing (its
    # reported position leaves the field of view), from t = 20 s
    spoof = AISConfig(spoof_mmsi=vs[3].mmsi, spoof_offset_m=(-300.0, 0.0), spoof_from_s=20.0)
    return Scenario(name, World(vs), cam, fps=fps or 10.0, duration_s=duration_s or 45.0, sky=sky, coasts=coasts,
                    options=opts, seed=seed, camera_id="cam0", description=desc,
                    radar_config=RadarConfig(sector_deg=(90.0, 250.0)), ais_config=spoof)


def _ir(seed, width, height, duration_s, fps):
    """Thermal (IR, white-hot) harbour at dusk: halo around warm vessels, blur, fixed-pattern noise."""
    return _harbour(seed, width, height, duration_s, fps, ir=True, name="ir")


def _pan(seed, width, height, duration_s, fps):
    """PTZ camera panning across a harbour and zooming 3.5x on a ship, with shake and JPEG."""
    rng = np.random.default_rng([seed, 2])
    cam = _camera(width, height, 50.0, 50.7950, -1.1080, 25.0, 140.0, -1.5)
    j = lambda s=1.0: float(rng.uniform(-s, s))
    vs = [
        make_vessel(1, "cargo", _straight(188 + j(0.5), 2200, 100.0, 3.0), rng, length_m=160.0),
        make_vessel(2, "fishing", _straight(141 + j(), 500, 60.0, 2.5), rng, length_m=20.0),
        make_vessel(3, "motorboat", _straight(155 + j(), 300, 250.0, 5.0), rng),
        make_vessel(4, "sailboat", _straight(172 + j(), 650, 200.0, 2.0), rng),
        make_vessel(5, "patrol", Trajectory(*_polar(196 + j(), 450), 300.0, ((1e9, 6.0, 2.0),)), rng, ais=False),
        make_vessel(6, "tanker", _straight(206 + j(), 3000, 270.0, 4.0), rng),
        make_vessel(7, "rib", _straight(131 + j(), 220, 170.0, 6.0), rng, ais=False),
        make_vessel(8, "tug", _straight(165 + j(), 900, 20.0, 2.0), rng),
    ]
    sched = PTZSchedule(
        times_s=(0.0, 5.0, 14.0, 17.0, 23.0, 29.0, 35.0, 40.0),
        pan_deg=(135.0, 135.0, 188.0, 188.0, 188.0, 188.0, 165.0, 150.0),
        tilt_deg=(-1.5, -1.5, -1.0, -1.0, -0.6, -0.6, -1.2, -1.5),
        zoom=(1.0, 1.0, 1.0, 1.0, 3.5, 3.5, 1.6, 1.0),
    )
    coasts = (CoastSpec(az_from_deg=105.0, az_to_deg=175.0, distance_m=3500.0, distance_slope=0.3, hill_m=60.0,
                        structures=30, seed=seed + 5),
              CoastSpec(az_from_deg=200.0, az_to_deg=250.0, distance_m=4500.0, distance_slope=-0.2, hill_m=35.0,
                        structures=12, seed=seed + 6))
    return Scenario("pan", World(vs), cam, fps=fps or 10.0, duration_s=duration_s or 45.0, schedule=sched,
                    shake=Shake(0.04, 0.03, 0.05, 0.5, seed + 9), sky=SkySpec(sun_az_deg=205.0, sun_el_deg=18.0),
                    coasts=coasts, options=RenderOptions(jpeg_quality=85), seed=seed,
                    description="a PTZ camera pans across the harbour, zooms 3.5x on a cargo ship and back")


def _crossing(seed, width, height, duration_s, fps):
    """Two boats cross in front of a low camera; the near ferry fully hides the far motorboat at 12 s."""
    rng = np.random.default_rng([seed, 3])
    cam = _camera(width, height, 40.0, 50.8000, -1.1000, 8.0, 90.0, -0.8)
    t_x = 12.0  # both boats cross the line of sight at this time
    # near: a small passenger ferry moving right-to-left at 250 m; far: a motorboat left-to-right at 550 m
    ne, nn = _polar(90.0, 250.0)
    near = Trajectory(ne, nn - 4.0 * t_x, 0.0, ((1e9, 4.0, 0.0),))
    fe, fn = _polar(90.0, 550.0)
    far = Trajectory(fe, fn + 3.0 * t_x, 180.0, ((1e9, 3.0, 0.0),))
    vs = [make_vessel(1, "ferry", near, rng, length_m=40.0, ais="A"),
          make_vessel(2, "motorboat", far, rng, length_m=9.0, ais="B")]
    coasts = (CoastSpec(az_from_deg=60.0, az_to_deg=125.0, distance_m=4000.0, distance_slope=0.2, hill_m=50.0,
                        structures=15, seed=seed + 4),)
    return Scenario("crossing", World(vs), cam, fps=fps or 10.0, duration_s=duration_s or 24.0, coasts=coasts,
                    sky=SkySpec(sun_az_deg=120.0, sun_el_deg=30.0), seed=seed,
                    description="two boats cross in front of a low camera; the near ferry fully hides the far "
                                "motorboat")


def _open_sea(seed, width, height, duration_s, fps):
    """Open sea from a swaying mast (rolling horizon), far ships, one AIS position spoofed."""
    rng = np.random.default_rng([seed, 4])
    cam = _camera(width, height, 50.0, 50.6000, -1.0000, 15.0, 200.0, -1.0, roll=1.0)
    j = lambda s=1.0: float(rng.uniform(-s, s))
    vs = [
        make_vessel(1, "tanker", _straight(195 + j(), 4500, 290.0, 5.0), rng),
        make_vessel(2, "cargo", _straight(210 + j(), 3000, 120.0, 6.0), rng),
        make_vessel(3, "fishing", Trajectory(*_polar(188 + j(), 1200), 30.0, ((1e9, 3.0, -1.0),)), rng),
        make_vessel(4, "sailboat", _straight(220 + j(), 800, 250.0, 2.5), rng),
        make_vessel(5, "motorboat", _straight(180 + j(), 1800, 140.0, 8.0), rng, ais=False),
    ]
    spoof = vs[1].mmsi
    return Scenario("open_sea", World(vs), cam, fps=fps or 10.0, duration_s=duration_s or 40.0,
                    shake=Shake(0.15, 0.25, 1.5, 0.25, seed + 10), sky=SkySpec(
                        zenith_bgr=(160, 115, 75), horizon_bgr=(210, 200, 190), sea_far_bgr=(130, 115, 95),
                        sea_near_bgr=(80, 60, 30), sun_az_deg=230.0, sun_el_deg=35.0, clouds=0.55),
                    options=RenderOptions(wave_contrast=1.3), seed=seed,
                    ais_config=AISConfig(spoof_mmsi=spoof, spoof_offset_m=(1200.0, -600.0), spoof_from_s=10.0),
                    description="open sea from a swaying mast (rolling horizon), far ships, one AIS position spoofed")


SCENARIOS: dict[str, Callable[..., Scenario]] = {
    "harbour": _harbour,
    "pan": _pan,
    "ir": _ir,
    "crossing": _crossing,
    "open_sea": _open_sea,
}


def scenario_names() -> list[str]:
    return list(SCENARIOS)


def make_scenario(name: str, seed: int = 0, width: int = 704, height: int = 576,
                  duration_s: float | None = None, fps: float | None = None) -> Scenario:
    """Build a named scenario.

    Parameters
    ----------
    name : str
        One of :data:`SCENARIOS`.
    seed : int
        Varies positions, colours, names and all noise; the same seed gives identical frames.
    width, height : int
        Image size (up to 1920 x 1080 and beyond).
    duration_s, fps : float or None
        Override the scenario's duration and frame rate.
    """
    if name not in SCENARIOS:
        raise KeyError(f"unknown scenario {name!r}; known: {', '.join(SCENARIOS)} (and make_multicam())")
    if duration_s is not None and duration_s <= 0:
        raise ValueError(f"duration_s must be positive, got {duration_s}")
    if fps is not None and fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    return SCENARIOS[name](int(seed), int(width), int(height), duration_s, fps)


# ---------------------------------------------------------------------------- multicam
class MultiCamScenario:
    """One world seen by several fixed cameras (paper C's distributed surveillance).

    Attributes
    ----------
    views : list of Scenario, one per camera (``camera_id`` "cam0", "cam1", ...), sharing the world,
        the time base, the AIS feed and the radar
    world, origin, fps, duration_s, n_frames
    """

    def __init__(self, views: list[Scenario]):
        self.views = views
        v0 = views[0]
        self.world, self.origin = v0.world, v0.origin
        self.fps, self.duration_s, self.n_frames = v0.fps, v0.duration_s, v0.n_frames
        self.vessels = v0.vessels
        self.name = "multicam"

    @property
    def cameras(self) -> list[CameraModel]:
        return [v.camera for v in self.views]

    def render(self, i: int) -> list[Frame]:
        return [v.render(i) for v in self.views]

    def ground_truth(self, i: int) -> list[GroundTruth]:
        return [v.ground_truth(i) for v in self.views]

    def world_truth(self, i: int) -> dict[str, np.ndarray]:
        """Every vessel's state at frame ``i``: ids, enu_m (N, 3), lat/lon, course, speed, mmsi."""
        t = self.views[0].time_s(i)
        st = self.world.states(t)
        lat, lon, _ = pymap3d.enu2geodetic(st[:, 0], st[:, 1], np.zeros(len(st)), self.origin[0], self.origin[1], 0.0)
        enu = np.zeros((len(st), 3))
        enu[:, :2] = st[:, :2]
        return dict(ids=np.array([v.id for v in self.vessels], np.int64), enu_m=enu, lat_deg=np.asarray(lat),
                    lon_deg=np.asarray(lon), course_deg=st[:, 2], speed_mps=st[:, 3],
                    mmsi=np.array([v.mmsi for v in self.vessels], np.int64))

    def ais_reports(self) -> list[AISReport]:
        return self.views[0].ais_reports()

    def ais_nmea(self) -> list[tuple[float, str]]:
        return self.views[0].ais_nmea()

    def radar_plots(self) -> np.ndarray:
        return self.views[0].radar_plots()

    def write(self, out_dir) -> dict[str, Path]:
        """Write every camera's files to ``out_dir/<camera_id>/`` (see :meth:`Scenario.write`) and
        ``world_truth.jsonl`` (every vessel's state at every frame: frame, t_s, id, mmsi, lat, lon,
        enu_m, course_deg, speed_mps)."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {}
        for v in self.views:
            for key, p in v.write(out / v.camera_id).items():
                paths[f"{v.camera_id}/{key}"] = p
        wt_path = out / "world_truth.jsonl"
        with open(wt_path, "w", encoding="utf-8") as fh:
            for i in range(self.n_frames):
                wt = self.world_truth(i)
                for k in range(len(wt["ids"])):
                    fh.write(json.dumps({
                        "frame": i, "t_s": round(self.views[0].time_s(i), 6), "id": int(wt["ids"][k]),
                        "mmsi": int(wt["mmsi"][k]), "lat": round(float(wt["lat_deg"][k]), 8),
                        "lon": round(float(wt["lon_deg"][k]), 8),
                        "enu_m": [round(float(c), 3) for c in wt["enu_m"][k]],
                        "course_deg": round(float(wt["course_deg"][k]), 3),
                        "speed_mps": round(float(wt["speed_mps"][k]), 3)}) + "\n")
        paths["world_truth"] = wt_path
        return paths


def make_multicam(seed: int = 0, width: int = 704, height: int = 576, duration_s: float | None = None,
                  fps: float | None = None, n_cameras: int = 3) -> MultiCamScenario:
    """A bay watched by ``n_cameras`` (default 3) fixed cameras along its shore, about 1.2 km apart.

    The cameras look out over a shared sea area from different positions, heights and headings, so
    that most vessels are seen by at least two cameras (for triangulating azimuth/elevation detections).
    """
    if not 1 <= n_cameras <= 5:
        raise ValueError(f"n_cameras must be 1..5, got {n_cameras}")
    rng = np.random.default_rng([seed, 6])
    lat0, lon0 = 50.7000, -1.3000
    j = lambda s=1.0: float(rng.uniform(-s, s))
    vs = [
        make_vessel(1, "cargo", Trajectory(-1500.0 + 100 * j(), -2200.0, 90.0, ((1e9, 5.0, 0.0),)), rng,
                    length_m=120.0),
        make_vessel(2, "fishing", Trajectory(-500.0, -1000.0 + 100 * j(), 45.0,
                                             ((15.0, 3.0, 0.0), (1e9, 3.0, -2.0))), rng),
        make_vessel(3, "motorboat", Trajectory(800.0 + 50 * j(), -700.0, 250.0, ((1e9, 7.0, 0.0),)), rng),
        make_vessel(4, "sailboat", Trajectory(300.0, -1500.0 + 100 * j(), 300.0, ((1e9, 2.0, 0.0),)), rng),
        make_vessel(5, "ferry", Trajectory(600.0, -1500.0 + 100 * j(), 270.0, ((1e9, 6.0, 0.0),)), rng, length_m=60.0),
        make_vessel(6, "rib", Trajectory(-900.0, -600.0, 120.0, ((1e9, 9.0, 1.5),)), rng, ais=False),
    ]
    world = World(vs)
    # cameras on the northern shore, spread east-west, looking south
    spots = [(-1200.0, 0.0, 30.0, 145.0), (0.0, 150.0, 22.0, 180.0), (1200.0, 0.0, 26.0, 220.0),
             (-2500.0, -300.0, 18.0, 135.0), (2500.0, -300.0, 18.0, 225.0)][:n_cameras]
    views = []
    for c, (e, n, h, pan) in enumerate(spots):
        lat, lon, _ = pymap3d.enu2geodetic(e, n, 0.0, lat0, lon0, 0.0)
        cam = _camera(width, height, 70.0, float(lat), float(lon), h, pan, -2.5)
        views.append(Scenario(
            "multicam", world, cam, fps=fps or 10.0, duration_s=duration_s or 40.0, origin=(lat0, lon0),
            sky=SkySpec(sun_az_deg=170.0, sun_el_deg=28.0), seed=seed * 10 + c, camera_id=f"cam{c}",
            options=RenderOptions(), description=f"camera {c} of {n_cameras} watching a bay",
            radar_config=RadarConfig(position_enu_m=(0.0, 200.0), sector_deg=(90.0, 270.0)), ais_seed=seed,
        ))
    return MultiCamScenario(views)
