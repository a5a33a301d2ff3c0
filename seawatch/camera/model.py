"""Pinhole camera over a curved sea: pixels <-> bearings <-> sea-surface positions.

Frames
------
* **ENU**: local east-north-up metres, origin on the sea surface directly below the camera; the
  camera's optical centre is at ``(0, 0, height_m)``.
* **Camera**: x right, y down, z forward (OpenCV).  Pixel ``(u, v)`` = ``(fx x/z + cx, fy y/z + cy)``
  with optional Brown-Conrady distortion ``(k1, k2, p1, p2, k3)``.

The camera looks along azimuth ``pan_deg`` (clockwise from north) at elevation ``tilt_deg``
(positive up), rolled by ``roll_deg`` about its axis (positive clockwise seen from behind).

Earth curvature and refraction: the sea is a sphere of effective radius
``R_eff = R / (1 - k)`` (standard refraction ``k = 0.13``), so a point at ground distance ``d``
sits ``d**2 / (2 R_eff)`` below the tangent plane, and the visible horizon lies
``acos(R_eff / (R_eff + h))`` below the horizontal (the dip).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d

from seawatch.camera._kernels import enu_to_pixel_pinhole, pixel_to_azel_pinhole
from seawatch.types import CameraPose, PTZState

__all__ = [
    "EARTH_RADIUS_M",
    "REFRACTION_K",
    "Intrinsics",
    "CameraModel",
    "load_camera",
    "save_camera",
    "load_fvessel_camera",
    "CameraFileError",
]

EARTH_RADIUS_M = 6_371_008.8
REFRACTION_K = 0.13


class CameraFileError(ValueError):
    """A camera file that cannot be read; the message names the file and the key."""


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics in pixels, for an image of ``width`` x ``height``.

    ``dist`` holds OpenCV's ``(k1, k2, p1, p2, k3)`` or is None for an ideal pinhole.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    dist: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not (self.fx > 0 and self.fy > 0):
            raise ValueError(f"Intrinsics: focal lengths must be positive, got fx={self.fx}, fy={self.fy}")
        if not (self.width > 0 and self.height > 0):
            raise ValueError(f"Intrinsics: image size must be positive, got {self.width}x{self.height}")

    @classmethod
    def from_fov(
        cls, hfov_deg: float, width: int, height: int, vfov_deg: float | None = None
    ) -> "Intrinsics":
        """Intrinsics from a horizontal (and optionally vertical) field of view, centred."""
        if not 0 < hfov_deg < 180:
            raise ValueError(f"hfov_deg must be in (0, 180), got {hfov_deg}")
        fx = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        fy = fx if vfov_deg is None else (height / 2.0) / math.tan(math.radians(vfov_deg) / 2.0)
        return cls(fx, fy, (width - 1) / 2.0, (height - 1) / 2.0, int(width), int(height))

    @property
    def hfov_deg(self) -> float:
        return math.degrees(2 * math.atan2(self.width / 2.0, self.fx))

    @property
    def vfov_deg(self) -> float:
        return math.degrees(2 * math.atan2(self.height / 2.0, self.fy))

    def zoomed(self, zoom: float) -> "Intrinsics":
        """Focal lengths multiplied by ``zoom`` (principal point and size unchanged)."""
        if zoom <= 0:
            raise ValueError(f"zoom must be positive, got {zoom}")
        return dataclasses.replace(self, fx=self.fx * zoom, fy=self.fy * zoom)

    def scaled_to(self, width: int, height: int) -> "Intrinsics":
        """The same camera seen at another image size (a resized image)."""
        sx, sy = width / self.width, height / self.height
        return dataclasses.replace(
            self,
            fx=self.fx * sx,
            fy=self.fy * sy,
            cx=(self.cx + 0.5) * sx - 0.5,
            cy=(self.cy + 0.5) * sy - 0.5,
            width=int(width),
            height=int(height),
        )

    @property
    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])


def _flat(a: np.ndarray) -> np.ndarray:
    """``a`` as a flat, C-contiguous, writable float64 array for the compiled kernels (a copy only
    when it is strided, broadcast or read-only: one compiled version of each kernel serves all)."""
    return np.require(a, np.float64, ["C", "W"]).reshape(-1)


def _rotation(pan_deg: float, tilt_deg: float, roll_deg: float) -> np.ndarray:
    """World-from-camera rotation: columns are the camera's x (right), y (down), z (forward) in ENU."""
    p, t, r = np.radians([pan_deg, tilt_deg, roll_deg])
    sp, cp, st, ct, sr, cr = np.sin(p), np.cos(p), np.sin(t), np.cos(t), np.sin(r), np.cos(r)
    f0, f1, f2 = sp * ct, cp * ct, st  # forward
    r0, r1, r2 = cp, -sp, 0.0  # right before the roll
    # down before the roll: forward x right, written out (what np.cross computes, without its
    # overhead: a camera is built for every frame)
    d0, d1, d2 = f1 * r2 - f2 * r1, f2 * r0 - f0 * r2, f0 * r1 - f1 * r0
    return np.array([[cr * r0 + sr * d0, -sr * r0 + cr * d0, f0],
                     [cr * r1 + sr * d1, -sr * r1 + cr * d1, f1],
                     [cr * r2 + sr * d2, -sr * r2 + cr * d2, f2]])


class CameraModel:
    """A calibrated camera at a pose above the sea.

    Parameters
    ----------
    intrinsics : Intrinsics
    pose : CameraPose
    refraction_k : float
        Atmospheric refraction coefficient for the effective Earth radius (0 for none).
    """

    def __init__(self, intrinsics: Intrinsics, pose: CameraPose, refraction_k: float = REFRACTION_K):
        if pose.height_m <= 0:
            raise ValueError(f"camera height_m must be above the sea (> 0), got {pose.height_m}")
        if not (-90 <= pose.lat_deg <= 90 and -180 <= pose.lon_deg <= 180):
            raise ValueError(f"camera position out of range: lat {pose.lat_deg}, lon {pose.lon_deg}")
        self.intrinsics = intrinsics
        self.pose = pose
        self.refraction_k = float(refraction_k)
        self.r_eff_m = EARTH_RADIUS_M / (1.0 - self.refraction_k)
        self.R = _rotation(pose.pan_deg, pose.tilt_deg, pose.roll_deg)

    def __repr__(self) -> str:
        return f"CameraModel({self.intrinsics!r}, {self.pose!r})"

    # -------------------------------------------------------------- derived models
    def with_pose(self, **changes) -> "CameraModel":
        return CameraModel(self.intrinsics, dataclasses.replace(self.pose, **changes), self.refraction_k)

    def with_ptz(self, ptz: PTZState) -> "CameraModel":
        """The camera at a pan/tilt/zoom state (absolute pan and tilt; zoom scales the base focal length)."""
        pose = dataclasses.replace(self.pose, pan_deg=ptz.pan_deg, tilt_deg=ptz.tilt_deg)
        return CameraModel(self.intrinsics.zoomed(ptz.zoom), pose, self.refraction_k)

    def with_intrinsics(self, intrinsics: Intrinsics) -> "CameraModel":
        return CameraModel(intrinsics, self.pose, self.refraction_k)

    def rotation_homography(self, other: "CameraModel") -> np.ndarray:
        """The image motion from this camera to ``other`` when it turns and zooms about its centre:
        the (3, 3) homography ``H`` with ``p_other ~ H @ p_this`` (pixels ``[u, v, 1]``).

        Exact for a pan/tilt/zoom head (the same position; what :meth:`with_ptz` changes) and a
        pinhole lens; lens distortion is ignored and a change of position is treated as a pure
        rotation (right for a distant scene).  ``other`` may be of another image size.
        """
        h = other.intrinsics.matrix @ other.R.T @ self.R @ np.linalg.inv(self.intrinsics.matrix)
        return h / h[2, 2]

    # ------------------------------------------------------- camera-frame helpers
    def _distort(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = self.intrinsics.dist
        if not d:
            return x, y
        k1, k2, p1, p2, k3 = (list(d) + [0.0] * 5)[:5]
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        return xd, yd

    def _undistort(self, xd: np.ndarray, yd: np.ndarray, iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
        if not self.intrinsics.dist:
            return xd, yd
        x, y = xd.copy(), yd.copy()
        for _ in range(iterations):  # fixed-point iteration, fine for moderate distortion
            xx, yy = self._distort(x, y)
            x = x - (xx - xd)
            y = y - (yy - yd)
        return x, y

    def _cam_to_pixel(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Camera-frame vectors (..., 3) -> u, v, z (z <= 0 behind the camera; u, v NaN there)."""
        z = c[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(z > 0, c[..., 0] / z, np.nan)
            y = np.where(z > 0, c[..., 1] / z, np.nan)
        x, y = self._distort(x, y)
        K = self.intrinsics
        return K.fx * x + K.cx, K.fy * y + K.cy, z

    def pixel_to_ray(self, u, v) -> np.ndarray:
        """Unit ENU direction vectors (..., 3) of pixels."""
        K = self.intrinsics
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        x, y = self._undistort((u - K.cx) / K.fx, (v - K.cy) / K.fy)
        c = np.stack(np.broadcast_arrays(x, y, np.ones_like(x)), axis=-1)
        w = c @ self.R.T
        return w / np.linalg.norm(w, axis=-1, keepdims=True)

    # ------------------------------------------------------------ angles <-> pixels
    def pixel_to_azel(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """Azimuth (clockwise from north, [0, 360)) and elevation of pixels, in degrees."""
        K = self.intrinsics
        if not K.dist:  # pinhole: one compiled pass
            u, v = np.broadcast_arrays(np.asarray(u, np.float64), np.asarray(v, np.float64))
            az, el = np.empty(u.shape), np.empty(u.shape)
            pixel_to_azel_pinhole(_flat(u), _flat(v), self.R,
                                  float(K.fx), float(K.fy), float(K.cx), float(K.cy), az.reshape(-1), el.reshape(-1))
            return az[()], el[()]  # (NumPy scalars for scalar input, as the ufuncs give)
        w = self.pixel_to_ray(u, v)
        az = np.degrees(np.arctan2(w[..., 0], w[..., 1])) % 360.0
        el = np.degrees(np.arcsin(np.clip(w[..., 2], -1, 1)))
        return az, el

    def azel_to_pixel(self, az_deg, el_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixels of directions; ``in_front`` is False (and u, v NaN) behind the camera."""
        a = np.radians(np.asarray(az_deg, dtype=np.float64))
        e = np.radians(np.asarray(el_deg, dtype=np.float64))
        a, e = np.broadcast_arrays(a, e)
        w = np.stack([np.sin(a) * np.cos(e), np.cos(a) * np.cos(e), np.sin(e)], axis=-1)
        u, v, z = self._cam_to_pixel(w @ self.R)
        return u, v, z > 0

    # --------------------------------------------------------------- world <-> pixels
    def curvature_drop_m(self, ground_m) -> np.ndarray:
        """Apparent drop below the tangent plane at a ground distance (refraction included)."""
        g = np.asarray(ground_m, dtype=np.float64)
        return g * g / (2.0 * self.r_eff_m)

    def enu_to_pixel(self, e_m, n_m, up_m, curvature: bool = True):
        """Project ENU points (origin on the sea below the camera) to pixels.

        With ``curvature`` the points drop by ``d**2 / (2 R_eff)`` with their ground distance ``d``
        (use it for flat-world coordinates such as the simulator's).

        Returns
        -------
        u, v : pixel coordinates (NaN behind the camera)
        depth_m : distance along the optical axis (<= 0 behind the camera)
        """
        e, n, up = np.broadcast_arrays(
            np.asarray(e_m, np.float64), np.asarray(n_m, np.float64), np.asarray(up_m, np.float64)
        )
        K = self.intrinsics
        if not K.dist:  # pinhole: one compiled pass
            u, v, depth = np.empty(e.shape), np.empty(e.shape), np.empty(e.shape)
            enu_to_pixel_pinhole(_flat(e), _flat(n), _flat(up), self.R, float(self.pose.height_m),
                                 1.0 / (2.0 * self.r_eff_m) if curvature else 0.0, float(K.fx), float(K.fy),
                                 float(K.cx), float(K.cy),
                                 u.reshape(-1), v.reshape(-1), depth.reshape(-1))
            return u[()], v[()], depth[()]
        if curvature:
            up = up - self.curvature_drop_m(np.hypot(e, n))
        w = np.stack([e, n, up - self.pose.height_m], axis=-1)
        return self._cam_to_pixel(w @ self.R)

    def geodetic_to_enu(self, lat_deg, lon_deg, alt_m=0.0):
        """Geodetic WGS-84 -> this camera's ENU frame (true geometry, no refraction)."""
        return pymap3d.geodetic2enu(
            np.asarray(lat_deg, np.float64), np.asarray(lon_deg, np.float64), np.asarray(alt_m, np.float64),
            self.pose.lat_deg, self.pose.lon_deg, 0.0,
        )

    def enu_to_geodetic(self, e_m, n_m, up_m=0.0):
        """This camera's ENU frame -> geodetic WGS-84 (lat, lon, alt)."""
        return pymap3d.enu2geodetic(
            np.asarray(e_m, np.float64), np.asarray(n_m, np.float64), np.asarray(up_m, np.float64),
            self.pose.lat_deg, self.pose.lon_deg, 0.0,
        )

    def geodetic_to_pixel(self, lat_deg, lon_deg, alt_m=0.0):
        """Project geodetic points to pixels through the local ENU frame.

        The true geometric drop comes from the ellipsoid; refraction lifts far points by ``k`` of it.
        Returns ``u, v, depth_m`` as :meth:`enu_to_pixel`.
        """
        e, n, up = self.geodetic_to_enu(lat_deg, lon_deg, alt_m)
        d = np.hypot(e, n)
        up = up + self.refraction_k * d * d / (2.0 * EARTH_RADIUS_M)
        return self.enu_to_pixel(e, n, up, curvature=False)

    def pixel_to_sea_enu(self, u, v):
        """Where pixel rays meet the (curved) sea surface.

        Returns
        -------
        e_m, n_m : flat-world ENU position at the ground distance along the ray's azimuth
        range_m : ground distance from the camera's foot (NaN at or above the horizon)
        """
        w = self.pixel_to_ray(u, v)
        h, R = self.pose.height_m, self.r_eff_m
        # sphere centre at (0, 0, -R); camera at (0, 0, h): solve |q + t w| = R with q = (0, 0, h + R)
        b = w[..., 2] * (h + R)
        c = (h + R) ** 2 - R * R
        disc = b * b - c
        with np.errstate(invalid="ignore"):
            t = -b - np.sqrt(disc)
        ok = (disc >= 0) & (t > 0)
        t = np.where(ok, t, np.nan)
        horiz = np.hypot(w[..., 0], w[..., 1])
        px, pz = t * horiz, h + R + t * w[..., 2]  # in the vertical plane of the ray, from the sphere centre
        ground = R * np.arctan2(px, pz)
        with np.errstate(invalid="ignore", divide="ignore"):
            e = ground * w[..., 0] / horiz
            n = ground * w[..., 1] / horiz
        return e, n, ground

    def pixel_to_sea(self, u, v):
        """Latitude, longitude (deg) and ground range (m) of pixels on the sea surface (NaN above the horizon)."""
        e, n, ground = self.pixel_to_sea_enu(u, v)
        drop = ground * ground / (2.0 * EARTH_RADIUS_M)
        lat, lon, _ = self.enu_to_geodetic(np.nan_to_num(e), np.nan_to_num(n), -np.nan_to_num(drop))
        bad = ~np.isfinite(ground)
        lat = np.where(bad, np.nan, lat)
        lon = np.where(bad, np.nan, lon)
        return lat, lon, ground

    # -------------------------------------------------------------------- horizon
    def horizon_dip_deg(self) -> float:
        """Angle of the visible sea horizon below the horizontal (positive degrees)."""
        return math.degrees(math.acos(self.r_eff_m / (self.r_eff_m + self.pose.height_m)))

    def horizon_elevation_deg(self) -> float:
        """Elevation of the visible sea horizon (negative)."""
        return -self.horizon_dip_deg()

    def horizon_row(self, u=None) -> np.ndarray | float:
        """Image row of the sea horizon at column(s) ``u`` (default: the principal point's column).

        The horizon is the circle of constant elevation ``-dip``; it is sampled in azimuth across
        the field of view and interpolated at ``u``.  NaN where the horizon is not in front.
        """
        K = self.intrinsics
        scalar = u is None or np.ndim(u) == 0
        uq = np.atleast_1d(np.asarray(K.cx if u is None else u, dtype=np.float64))
        half = min(89.0, 0.5 * math.degrees(2 * math.atan2(max(K.width, K.height), min(K.fx, K.fy))) + 2.0)
        az = self.pose.pan_deg + np.linspace(-half, half, 721)
        hu, hv, front = self.azel_to_pixel(az, np.full_like(az, self.horizon_elevation_deg()))
        keep = front & np.isfinite(hu)
        if keep.sum() < 2:
            out = np.full(uq.shape, np.nan)
        else:
            order = np.argsort(hu[keep])
            xs, ys = hu[keep][order], hv[keep][order]
            out = np.interp(uq, xs, ys, left=np.nan, right=np.nan)
        return float(out[0]) if scalar else out

    def horizon_line(self) -> tuple[float, float]:
        """Rows of the horizon at the left (column 0) and right (column width-1) image borders."""
        v = self.horizon_row(np.array([0.0, self.intrinsics.width - 1.0]))
        return float(v[0]), float(v[1])

    def in_image(self, u, v, margin_px: float = 0.0) -> np.ndarray:
        K = self.intrinsics
        u = np.asarray(u)
        v = np.asarray(v)
        with np.errstate(invalid="ignore"):
            return (
                (u >= -margin_px) & (u <= K.width - 1 + margin_px)
                & (v >= -margin_px) & (v <= K.height - 1 + margin_px)
            )

    def to_dict(self) -> dict:
        K = self.intrinsics
        intr = {"fx": K.fx, "fy": K.fy, "cx": K.cx, "cy": K.cy, "width": K.width, "height": K.height}
        if K.dist:
            intr["dist"] = list(K.dist)
        return {"intrinsics": intr, "pose": dataclasses.asdict(self.pose), "refraction_k": self.refraction_k}


# ------------------------------------------------------------------------- files
_POSE_KEYS = {f.name for f in dataclasses.fields(CameraPose)}
_INTR_KEYS = {"fx", "fy", "cx", "cy", "width", "height", "hfov_deg", "vfov_deg", "dist"}


def load_camera(path: str | Path) -> CameraModel:
    """Read a camera TOML file.

    ``[intrinsics]`` has ``width``, ``height`` and either ``fx, fy, cx, cy`` or ``hfov_deg``
    (optional ``vfov_deg``), optional ``dist = [k1, k2, p1, p2, k3]``; ``[pose]`` has the
    :class:`~seawatch.types.CameraPose` fields; optional top-level ``refraction_k``.
    """
    p = Path(path)
    if not p.is_file():
        raise CameraFileError(f"camera file not found: {p}")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise CameraFileError(f"{p}: not valid TOML: {exc}") from None
    for key in data:
        if key not in ("intrinsics", "pose", "refraction_k"):
            raise CameraFileError(f"{p}: unknown key '{key}' (expected [intrinsics], [pose], refraction_k)")
    intr = data.get("intrinsics")
    if not isinstance(intr, dict):
        raise CameraFileError(f"{p}: missing table [intrinsics]")
    for key in intr:
        if key not in _INTR_KEYS:
            raise CameraFileError(f"{p}: [intrinsics] unknown key '{key}'")
    pose_d = data.get("pose", {})
    for key in pose_d:
        if key not in _POSE_KEYS:
            raise CameraFileError(f"{p}: [pose] unknown key '{key}'")
    try:
        w, h = int(intr["width"]), int(intr["height"])
        if "fx" in intr:
            K = Intrinsics(
                float(intr["fx"]), float(intr.get("fy", intr["fx"])),
                float(intr.get("cx", (w - 1) / 2)), float(intr.get("cy", (h - 1) / 2)), w, h,
                tuple(float(x) for x in intr["dist"]) if "dist" in intr else None,
            )
        elif "hfov_deg" in intr:
            K = Intrinsics.from_fov(float(intr["hfov_deg"]), w, h, intr.get("vfov_deg"))
        else:
            raise CameraFileError(f"{p}: [intrinsics] needs fx (and fy, cx, cy) or hfov_deg")
        pose = CameraPose(**{k: float(v) for k, v in pose_d.items()})
        return CameraModel(K, pose, float(data.get("refraction_k", REFRACTION_K)))
    except KeyError as exc:
        raise CameraFileError(f"{p}: [intrinsics] missing key {exc}") from None
    except (TypeError, ValueError) as exc:
        raise CameraFileError(f"{p}: {exc}") from None


def save_camera(camera: CameraModel, path: str | Path) -> Path:
    """Write a camera TOML file readable by :func:`load_camera`."""
    d = camera.to_dict()
    lines = [f"refraction_k = {d['refraction_k']!r}", "", "[intrinsics]"]
    for k, v in d["intrinsics"].items():
        lines.append(f"{k} = {v!r}")
    lines += ["", "[pose]"]
    for k, v in d["pose"].items():
        lines.append(f"{k} = {float(v)!r}")
    p = Path(path)
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def load_fvessel_camera(path: str | Path, width: int = 2560, height: int = 1440) -> CameraModel:
    """Read FVessel's ``camera_para.txt``.

    Format: ``[lon, lat, horizontal orientation (deg from north), vertical orientation (deg),
    camera height (m), horizontal FOV, vertical FOV, fx, fy, u0, v0]``.
    """
    p = Path(path)
    if not p.is_file():
        raise CameraFileError(f"camera file not found: {p}")
    text = p.read_text(encoding="utf-8").strip().strip("[]")
    try:
        vals = [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise CameraFileError(f"{p}: expected 11 numbers in brackets") from None
    if len(vals) != 11:
        raise CameraFileError(f"{p}: expected 11 numbers, found {len(vals)}")
    lon, lat, pan, tilt, hgt, _hfov, _vfov, fx, fy, u0, v0 = vals
    K = Intrinsics(fx, fy, u0, v0, width, height)
    return CameraModel(K, CameraPose(lat_deg=lat, lon_deg=lon, height_m=hgt, pan_deg=pan, tilt_deg=tilt))
