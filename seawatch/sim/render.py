"""Render EO colour and IR frames of the synthetic world through the camera model, with exact masks.

One frame is built in this order:

1. **background** (cached per camera state): a coarse sky/sea/cloud panorama and a sharp band around
   the horizon and the coast, resampled through the camera's exact azimuth/elevation of every pixel
   (computed on a 16-pixel grid and interpolated bilinearly, error far below a pixel);
2. **sea**: an animated, tileable wave field sampled at each water pixel's sea-surface position,
   fading with range, with sun glints strongest along the sun's azimuth (one Numba pass).
   A camera that only sways (``panorama``) gets steps 1-2 from azimuth/elevation panoramas of
   background plus sea, one per wave frame, built lazily in tiles: one ``cv2.remap`` per frame;
3. **wakes and reflections** on the water (they never cover a vessel's pixels);
4. **vessels**, far to near (occlusion by depth): each a set of convex lofted parts projected with
   :meth:`CameraModel.enu_to_pixel` (Earth curvature included), back faces culled, faces shaded by
   the sun, filled (``fill_polys``, inside the Numba kernel ``draw_vessel``) into a per-vessel canvas
   whose non-zero pixels are the vessel's exact mask; the frame and a label image take the same
   pixels (a uint8 label: at most 255 vessels);
5. IR **halo** around warm vessels, optical blur, **sensor noise** (precomputed Gaussian pools at
   a random offset per frame) and optional **JPEG** compression.

Ground truth comes from the label image of step 4: a vessel's box is the pixel-aligned extent of
its visible pixels, its visible fraction = visible pixels / pixels of its unoccluded silhouette
(including any part outside the image).  Blur, noise and compression act after that, as in a
real camera, so the box is the vessel's geometric extent, not a threshold of the final image.
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass, field

import cv2
import numpy as np

from seawatch.camera import CameraModel
from seawatch.sim._kernels import (
    draw_reflection,
    draw_vessel,
    draw_wake,
    first_water_rows,
    grid_layouts,
    label_boxes,
    last_dry_row,
    pose_vertices,
    sea_maps_grid,
    sea_shade_grid,
    sea_waves_grid,
    trajectory_states,
    vessel_poses,
    view_grid,
    wake_quads,
)
from seawatch.sim.texture import (
    CoastSpec,
    Panorama,
    SkySpec,
    WaveField,
    _sky_sea_column,
    build_panorama,
    periodic_noise,
)
from seawatch.sim.world import World

__all__ = ["RenderOptions", "RenderResult", "Renderer"]

_GRID_PX = 16
_LOD_TEXELS_PER_PX = 0.5  # the sea below the band is rendered at half width where a pixel spans <= this
_TILE_PX = 128  # tiles of the swaying-camera panoramas (a multiple of _GRID_PX)
_PANO_MAX_SPAN_DEG = 4.0  # pan/tilt range up to which a swaying camera renders from panoramas
_PANO_OVERSAMPLE = 1.25  # panorama pixels per image pixel (at the image centre)


@dataclass(frozen=True)
class RenderOptions:
    """What to draw and how.

    Parameters
    ----------
    ir : bool
        Thermal (one channel, grey levels) instead of colour.
    waves, wakes, reflections : bool
        Draw the animated sea texture and glints, the vessels' wakes, their reflections.
    wave_contrast, glint : float
        Strength of the wave shading and of the sun glints (0 disables).
    noise_sigma : float
        Standard deviation of the sensor noise in grey levels (0 disables).
    jpeg_quality : int
        JPEG compression quality (1-100); 0 disables.
    blur_sigma_px : float
        Optical blur (Gaussian sigma in pixels); 0 disables.
    ir_polarity : str
        "white_hot" or "black_hot".
    ir_halo : float
        Strength of the bright halo around warm vessels in IR (0 disables).
    ir_fixed_pattern : float
        Amplitude (grey levels) of the IR column fixed-pattern noise.
    vessel_motion : bool
        Let vessels heave, roll and pitch in the waves.
    sea_half_res : bool or None
        Range-dependent detail of the sea below the horizon/coast band: rows where one pixel spans
        at most half a wave-texture texel across are rendered at half width and upscaled (one
        sample per texel at most, so waves and glints keep their detail); the farther rows stay
        at full resolution.  The wave texture is sampled there with ``cv2.remap`` and shaded in
        an element-wise pass.  A moving camera re-renders its sea every frame, so None chooses it
        for cameras whose pan or tilt schedule spans more than the panorama range (``pan``); not
        for fixed ones, whose animated sea is cached, for swaying ones, which render from
        panoramas, nor for a camera that only zooms (its pan and tilt span 0).
    """

    ir: bool = False
    waves: bool = True
    wakes: bool = True
    reflections: bool = True
    wave_contrast: float = 1.0
    glint: float = 1.0
    noise_sigma: float = 2.0
    jpeg_quality: int = 0
    blur_sigma_px: float = 0.0
    ir_polarity: str = "white_hot"
    ir_halo: float = 0.6
    ir_fixed_pattern: float = 1.0
    vessel_motion: bool = True
    sea_half_res: bool | None = None


@dataclass
class RenderResult:
    """A rendered image and the exact per-vessel ground truth of that image.

    ``index`` holds the positions (in the world's vessel list) of the vessels whose unoccluded
    silhouette touches the image; the other arrays are aligned with it.
    """

    image: np.ndarray
    index: np.ndarray  # (N,) int
    boxes: np.ndarray  # (N, 4) visible extent x, y, w, h (pixels, clipped)
    full_boxes: np.ndarray  # (N, 4) unoccluded extent clipped to the image
    visible: np.ndarray  # (N,) visible fraction
    visible_px: np.ndarray  # (N,) int
    full_px: np.ndarray  # (N,) int (unoccluded, including outside the image)
    depth_m: np.ndarray  # (N,) range to the vessel
    label: np.ndarray  # (H, W) uint8: 0 background, k+1 for the k-th vessel of the world
    water_row: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (W,) top row of the water


def _bgr_tuple(c, n: int):
    return tuple(float(x) for x in np.asarray(c, float)[:n])


def _upsample_grid(a: np.ndarray, gw: int, step: int, size: tuple[int, int], r0: int = 0) -> np.ndarray:
    """Bilinear upsampling of coarse-grid channels ``a`` (gh, gw, K) to rows ``r0:size[0]`` of an
    image whose grid step is ``step`` (the coarse grid has one padding sample around the image:
    sample ``(i, j)`` sits at pixel ``((j - 0.5) * step - 0.5, (i - 0.5) * step - 0.5)``)."""
    a = a.astype(np.float32, copy=False)
    k0 = max(0, r0 // step - 1)
    # grid rows down to the last one the bottom output row interpolates (one more, so that no
    # row is clamped at the cut: the same pixels as resizing the whole grid)
    k1 = min(a.shape[0], (size[0] + step) // step + 2)
    sub = a[k0:k1]
    big = cv2.resize(sub, (gw * step, sub.shape[0] * step), interpolation=cv2.INTER_LINEAR)
    o = step - k0 * step
    return big[r0 + o:size[0] + o, step:step + size[1]]


@functools.lru_cache(maxsize=16)
def _grid_cols(w: int, step: int, gw: int) -> tuple[np.ndarray, np.ndarray]:
    """Interpolation of ``w`` image columns between the columns of a grid of ``gw`` samples,
    grid column ``j`` sitting at image column ``(j - 0.5) * step - 0.5`` (INTER_LINEAR's
    convention, clamped at the grid's last column): ``seg`` (gw,), the image columns
    ``seg[j] .. seg[j + 1]`` lying between grid columns ``j`` and ``j + 1``, and ``wts`` (w,),
    the weight of column ``j + 1``."""
    fx = (np.arange(w, dtype=np.float32) + np.float32(0.5)) / np.float32(step) + np.float32(0.5)
    j = np.floor(fx).astype(np.int64)
    b = (fx - j).astype(np.float32)
    last = j >= gw - 1
    j[last], b[last] = gw - 2, 1.0
    seg = np.searchsorted(j, np.arange(gw), side="left").astype(np.int64)
    seg.setflags(write=False)
    b.setflags(write=False)
    return seg, b


class _PanoLevel:
    """Panoramas (background plus animated sea, one per wave frame) at one zoom step."""

    __slots__ = ("ppd", "f_px", "shape", "water_top_y", "frames", "bg", "bg_built")

    def __init__(self, ppd, f_px, shape, water_top_y):
        self.ppd, self.f_px, self.shape, self.water_top_y = ppd, f_px, shape, water_top_y
        self.bg = self.bg_built = None  # the static background (no waves), built tile by tile
        self.frames: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # wave frame -> (image, built tiles)


class _View:
    """Per camera state: background, sea maps and helpers (cached)."""

    __slots__ = ("bg", "sea_r0", "sea_grid", "sea_base", "hi_map", "hi_r0", "water_row", "f_px", "sea_cache",
                 "half_y0", "lod_y")


class Renderer:
    """Renders a :class:`World` seen through camera models.

    Parameters
    ----------
    world : World
    width, height : int
        Image size.
    reference_camera : CameraModel
        The camera's base model (position, base pan); panoramas are built around it.
    pan_range_deg, tilt_range_deg : (float, float)
        Absolute pan and tilt extremes the camera will take (shake included).
    max_zoom : float
        Largest zoom the camera will take (sets the sharpness of the horizon band).
    sky : SkySpec
    coasts : tuple of CoastSpec
    options : RenderOptions
    seed : int
    world_to_camera : (2, 3) array or None
        Affine map from world (e, n) to this camera's ENU (e, n) (multi-camera worlds); None for
        the identity.
    wave_field : WaveField or None
        The animated sea (default: a seeded one).
    sea_cache_mb : float
        Memory for caching the animated sea of steady (fixed) views, one image per wave frame.
    max_roll_deg : float
        Largest roll the camera will take (widens the panoramas).
    panorama : bool or None
        Render sky, coast and animated sea of a camera that only sways around one direction (a
        pan and tilt range of at most a few degrees, not zero) from azimuth/elevation panoramas,
        one per animated-sea frame, built lazily in tiles: a frame is then one ``cv2.remap``.
        None chooses from ``pan_range_deg`` and ``tilt_range_deg``; False renders every frame
        directly.
    """

    def __init__(
        self,
        world: World,
        width: int,
        height: int,
        reference_camera: CameraModel,
        *,
        pan_range_deg: tuple[float, float] | None = None,
        tilt_range_deg: tuple[float, float] | None = None,
        max_zoom: float = 1.0,
        max_roll_deg: float = 0.0,
        sky: SkySpec = SkySpec(),
        coasts: tuple[CoastSpec, ...] = (),
        options: RenderOptions = RenderOptions(),
        seed: int = 0,
        world_to_camera: np.ndarray | None = None,
        wave_field: WaveField | None = None,
        sea_cache_mb: float = 256.0,
        panorama: bool | None = None,
    ):
        if not (16 <= width <= 8192 and 16 <= height <= 8192):
            raise ValueError(f"Renderer: image size {width}x{height} out of range")
        self.world = world
        self.W, self.H = int(width), int(height)
        self.options = options
        self.seed = int(seed)
        self.sky = sky
        self.C = 1 if options.ir else 3
        cam = reference_camera
        if cam.intrinsics.width != self.W or cam.intrinsics.height != self.H:
            cam = cam.with_intrinsics(cam.intrinsics.scaled_to(self.W, self.H))
        self.ref_camera = cam
        self.height_m = cam.pose.height_m
        pan0 = cam.pose.pan_deg
        pr = pan_range_deg or (pan0, pan0)
        tr = tilt_range_deg or (cam.pose.tilt_deg, cam.pose.tilt_deg)
        K = cam.intrinsics
        half_h = math.degrees(math.atan2(math.hypot(K.width, K.height) / 2, K.fx)) + 3.0
        half_v = math.degrees(math.atan2(math.hypot(K.width, K.height) / 2, K.fy)) + 3.0 + abs(max_roll_deg)
        self.ref_az = 0.5 * (pr[0] + pr[1])
        az_span = (pr[0] - self.ref_az - half_h, pr[1] - self.ref_az + half_h)
        el_span = (max(-89.0, tr[0] - half_v), min(89.0, tr[1] + half_v))
        ppd_hi = max(4.0, K.fx * max_zoom * math.pi / 180.0 * 1.25)
        self.horizon_el = cam.horizon_elevation_deg()
        self.pano: Panorama = build_panorama(
            ref_az_deg=self.ref_az, az_span_deg=az_span, el_span_deg=el_span,
            camera_height_m=self.height_m, r_eff_m=cam.r_eff_m, horizon_el_deg=self.horizon_el,
            sky=sky, coasts=tuple(coasts), ppd_hi=ppd_hi, ppd_lo=min(8.0, ppd_hi), ir=options.ir,
            seed=self.seed + 101,
        )
        # colour panoramas resampled as 4 channels (OpenCV's remap has a fast path for 4, not 3;
        # the pixels are the same to the last bit), converted back with cvtColor
        self._lo_src = _bgra(self.pano.lo)
        # the sea's base colour by row of the coarse panorama (below the horizon it depends on the
        # elevation only), evaluated as sea even in the rows that straddle the horizon
        p = self.pano
        el_lo = p.el_max - (np.arange(p.lo.shape[0]) + 0.5) / p.ppd_lo
        col = _sky_sea_column(np.minimum(el_lo, self.horizon_el - 1e-9), self.horizon_el, sky, options.ir)
        self._sea_lut = np.floor(np.clip(col, 0, 255)).astype(np.float32)  # whole levels, as the panoramas
        self._hi_src = _bgra(self.pano.hi)
        wt = self.pano.water_top_deg
        self._water_top_y = ((self.pano.band_el_max - wt) * self.pano.ppd_hi - 0.5).astype(np.float32)
        self.waves = wave_field or WaveField(seed=self.seed + 7)
        self.world_to_camera = None if world_to_camera is None else np.asarray(world_to_camera, float)
        self._pano_geo = np.array([p.az_min, p.el_max, p.band_el_max, p.ppd_lo, p.ppd_hi], np.float64)
        span = max(pr[1] - pr[0], tr[1] - tr[0])
        self.use_panorama = bool(0.0 < span <= _PANO_MAX_SPAN_DEG) if panorama is None else bool(panorama)
        hr = options.sea_half_res
        self.sea_half_res = bool(span > 0.0 and not self.use_panorama) if hr is None else bool(hr)
        self._levels: dict[int, _PanoLevel] = {}
        self._lo_skip_band = True  # skip the coarse layer where the sharp band covers whole rows
        self._views: OrderedDict[tuple, _View] = OrderedDict()
        self._tiles4: dict[int, np.ndarray] = {}
        self._bufs: dict[str, np.ndarray] = {}
        self._draw_res = np.zeros(9, np.int64)
        self.sea_cache_mb = float(sea_cache_mb)
        self._cache_bytes = 0
        # noise pools (static; a random offset per frame)
        rng = np.random.default_rng(self.seed + 3)
        pad = 256
        self._pad = pad
        if options.noise_sigma > 0:
            n = rng.normal(0.0, options.noise_sigma, (self.H + pad, self.W, self.C))
            self._noise_pos = np.clip(n, 0, 255).astype(np.uint8)
            self._noise_neg = np.clip(-n, 0, 255).astype(np.uint8)
        else:
            self._noise_pos = self._noise_neg = None
        self._fpn = None
        if options.ir and options.ir_fixed_pattern > 0:
            col = rng.normal(0, options.ir_fixed_pattern, self.W)
            f = np.repeat(col[None, :], self.H, axis=0)[..., None]
            self._fpn = (np.clip(f, 0, 255).astype(np.uint8), np.clip(-f, 0, 255).astype(np.uint8))
        foam = periodic_noise(256, 1.2, self.seed + 17)
        self._foam = (0.55 + 0.45 * foam).astype(np.float32)
        self._gain = np.array([1.0] if options.ir else [0.55, 0.6, 0.65], np.float32) * 0.9
        self._foam_col = np.array([sky.ir_sea_far + 25.0] if options.ir else [235.0, 240.0, 240.0], np.float32)
        self._glint_col = np.array([140.0] if options.ir else [255.0, 255.0, 250.0], np.float32)
        sun_az, sun_el = math.radians(sky.sun_az_deg), math.radians(sky.sun_el_deg)
        self._sun = np.array([math.sin(sun_az) * math.cos(sun_el), math.cos(sun_az) * math.cos(sun_el),
                              math.sin(sun_el)])

    # ------------------------------------------------------------------ background
    def _view(self, cam: CameraModel) -> _View:
        p, K = cam.pose, cam.intrinsics
        key = (round(p.pan_deg, 9), round(p.tilt_deg, 9), round(p.roll_deg, 9), round(K.fx, 6), round(K.fy, 6),
               round(K.cx, 6), round(K.cy, 6))
        v = self._views.get(key)
        if v is not None:
            self._views.move_to_end(key)
            if v.bg is None:  # its background became the frame that built it (:meth:`_sea_image`):
                v = self._views[key] = self._build_view(cam)  # build it again, as a steady view
                v.sea_cache = {}
            elif v.sea_cache is None:  # a steady view: keep its animated sea frames
                v.sea_cache = {}
            return v
        v = self._build_view(cam)
        self._views[key] = v
        while len(self._views) > 8:
            _, old = self._views.popitem(last=False)
            if old.sea_cache:
                self._cache_bytes -= sum(a.nbytes for a in old.sea_cache.values())
        return v

    def _grid_px(self):
        """The coarse grid of every view: ``(gw, gh, U, V)``, its sample (i, j) at pixel
        ``((j - 0.5) * step - 0.5, (i - 0.5) * step - 0.5)`` (one padding sample around the
        image); made once (read-only arrays)."""
        g = self.__dict__.get("_grid")
        if g is None:
            W, H, s = self.W, self.H, _GRID_PX
            gw, gh = -(-W // s) + 2, -(-H // s) + 2
            uc = (np.arange(gw) + 0.5) * s - 0.5 - s
            vc = (np.arange(gh) + 0.5) * s - 0.5 - s
            U, V = np.meshgrid(uc, vc)
            U.setflags(write=False)
            V.setflags(write=False)
            g = self._grid = (gw, gh, U, V)
        return g

    def _grid_params(self, az, el, f_px: float, r_eff_m: float) -> np.ndarray:
        """Panorama coordinates and sea parameters of grid samples seen along azimuths ``az`` and
        elevations ``el`` (deg), for a camera of focal length ``f_px``: a (9, gh, gw) array of
        ``lox, loy, hix, hiy`` (coarse panorama and sharp band), ``tx, ty`` (wave texels), wave
        contrast, glint strength and ground range (m; NaN above the horizon).  The texture is
        anchored to the world and compressed beyond ``1.5 r_a`` so it stays bounded; the waves fade
        out beyond ``r_a``, where they get smaller than a few pixels."""
        p, o, sky = self.pano, self.options, self.sky
        lam = 6.0
        r_a = math.sqrt(f_px * self.height_m * lam / 3.0)
        sea = np.array([r_a, self.waves.texel_m, o.wave_contrast, o.glint, sky.sun_az_deg,
                        1.0 if sky.sun_el_deg > 0 else 0.0, 1.0 if o.waves else 0.0])
        # camera ENU -> world ENU directions (the wave texture is anchored to the world)
        inv = _EYE2 if self.world_to_camera is None else np.linalg.inv(self.world_to_camera[:, :2])
        out = np.empty((9,) + az.shape)
        view_grid(az, el, self.ref_az, self._pano_geo, self.height_m, r_eff_m, sea, inv, out)
        return out

    def _build_view(self, cam: CameraModel) -> _View:
        W, H, s = self.W, self.H, _GRID_PX
        gw, gh, U, V = self._grid_px()
        az, el = cam.pixel_to_azel(U, V)
        pano = self.pano
        f_px = float(cam.intrinsics.fy)
        g = self._grid_params(az, el, f_px, cam.r_eff_m)
        # the same grids interleaved as float32 (coarse and sharp panorama maps, sea parameters)
        # and the sea base colour at each sample, in one compiled pass
        lo2, hi2 = np.empty((gh, gw, 2), np.float32), np.empty((gh, gw, 2), np.float32)
        sea4, base4 = np.empty((gh, gw, 4), np.float32), np.empty((gh, gw, 4), np.float32)
        stats = np.empty((gh, 4))  # per grid row: hiy max, hiy min, all inside the band, texel step
        hh_hi, hw_hi = pano.hi.shape[:2]
        grid_layouts(g, self._sea_lut, float(hw_hi), float(hh_hi), lo2, hi2, sea4, base4, stats)

        view = _View()
        view.sea_base = None
        view.f_px = f_px
        view.sea_cache = None
        # the sharp band around the horizon and the coast, at full resolution; rows above it hold
        # neither water nor coast, so the full-resolution maps start at the band (or the water)
        hmax, hmin = stats[:, 0], stats[:, 1]
        # pairs of consecutive coarse rows (k, k+1) whose span touches the band
        pair_hi = np.maximum(hmax[:-1], hmax[1:])
        pair_lo = np.minimum(hmin[:-1], hmin[1:])
        rows_c = np.nonzero((pair_hi >= -1) & (pair_lo <= pano.hi.shape[0] + 1))[0]
        srows = np.nonzero(hmax > float(self._water_top_y.min()))[0]
        r0_ = max(0, (int(srows[0]) - 2) * s) if len(srows) else H
        b0 = max(0, (int(rows_c[0]) - 1) * s) if len(rows_c) else H
        b1 = min(H, (int(rows_c[-1]) + 1) * s) if len(rows_c) else H
        m0 = min(r0_, b0)
        # below the band every pixel is water: the panorama coordinates are needed only down to b1
        # (rows with a stride: a window into the upsampled grid, no copy; OpenCV and the kernels take it)
        hi_map = _upsample_grid(hi2, gw, s, (b1, W), m0) if m0 < b1 else np.zeros((0, W, 2), np.float32)
        band_maps = None
        c0 = c1 = 0  # rows that the band covers entirely (they need no coarse layer)
        if b1 > b0:
            band_maps = hi_map[b0 - m0:b1 - m0]
            # rows whose every pixel has its 4 taps inside the band: pixel row y interpolates the
            # grid rows i = (y + 0.5) / s + 0.5 and i + 1 (a convex combination), so it is covered
            # when every sample of both rows lies inside (with a margin for rounding)
            inside = stats[:, 2] > 0  # (grid_layouts)
            pair_ok = inside[:-1] & inside[1:]
            ys = np.arange(b0, b1)
            full = pair_ok[np.minimum(((ys + 0.5) / s + 0.5).astype(np.int64), len(pair_ok) - 1)]
            if full.any():
                c0 = int(np.argmax(full))
                c1 = c0 + (int(np.argmin(full[c0:])) if not full[c0:].all() else len(full) - c0)
                c0, c1 = b0 + c0, b0 + c1
        # coarse sky / sea / clouds: smooth, so resampled at half resolution and upscaled (rows the
        # band covers entirely are skipped)
        bg = np.empty((H, W, self.C), np.uint8)
        # moving cameras: rows from ys down are all water (below the band, or below the band's
        # last row with a dry pixel), rendered every frame by :meth:`_sea_sampled` with their sea
        # base colour, so they need neither the coarse layer nor the band here
        ys = H
        if self.sea_half_res and self.options.waves and r0_ < H:
            ys = b1
            if b1 > m0:
                # (two rows of margin: the band's bilinear taps there still blend in the horizon or
                # the shore, which the band remap anti-aliases)
                ys = min(b1, max(r0_, m0 + last_dry_row(hi_map, self._water_top_y) + 3))
        view.half_y0 = view.lod_y = ys
        mlo = _upsample_grid(lo2, gw, s // 2, (min(-(-H // 2), (ys + 1) // 2 + 1), -(-W // 2)))
        for y0, y1 in ((0, c0), (c1, H)) if c1 > c0 and self._lo_skip_band else ((0, H),):
            y1 = min(y1, ys)
            if y1 > y0:
                self._lo_rows(bg, mlo, y0, y1)
        bg[ys:] = 0
        bb = min(b1, ys)
        if band_maps is not None and bb > b0:  # BORDER_TRANSPARENT: pixels off the band keep the coarse layer
            _remap_into(bg[b0:bb], self._hi_src, band_maps[:bb - b0], self._buf("band4", (bb - b0, W, 4), np.uint8))
        view.bg = bg
        view.hi_map = hi_map
        view.hi_r0 = m0
        if r0_ < H:
            view.sea_r0 = r0_
            view.sea_grid = sea4
            # the sea base colour: the coarse panorama's elevation profile at loy (grid_layouts)
            view.sea_base = base4 if ys < H else None
            # half width from the first pixel row below which every grid row has at most half a
            # texel per pixel across (pixel row y interpolates grid rows i, i + 1 from the top)
            step = stats[:, 3] / s  # (grid_layouts)
            fine = np.logical_and.accumulate((step <= _LOD_TEXELS_PER_PX)[::-1])[::-1]
            k = int(np.argmax(fine)) if fine.any() else len(fine)
            view.lod_y = min(H, max(ys, int(math.ceil((k - 0.5) * s - 0.5))))
        else:
            view.sea_r0 = 0
            view.sea_grid = None
        # (rows above r0_ hold no water: the scan starts there)
        w0 = max(0, min(r0_, b1) - m0)
        wr = first_water_rows(hi_map[w0:], self._water_top_y) + (m0 + w0)  # b1 where none in the band rows
        view.water_row = np.where(wr >= b1, b1 if r0_ < H else H, wr).astype(np.float64)
        return view

    def _lo_rows(self, bg: np.ndarray, mlo: np.ndarray, y0: int, y1: int) -> None:
        """Rows ``y0 .. y1`` of the coarse layer into ``bg``: ``pano.lo`` resampled through the
        half-resolution maps ``mlo`` and upscaled twice (the same pixels as doing it for the whole
        image: one half-resolution row of margin on each side feeds the interpolation)."""
        lo, k0 = self._lo_half(mlo, y0, y1)
        self._lo_up(bg, lo, k0, mlo.shape[1], y0, y1)

    def _lo_half(self, mlo: np.ndarray, y0: int, y1: int):
        """The half-resolution coarse layer that feeds rows ``y0 .. y1``: ``(lo, k0)``, ``lo`` holding
        half-resolution rows ``k0 ..`` (shape ``(k1 - k0, W / 2, C)``)."""
        hh = mlo.shape[0]
        k0, k1 = max(0, y0 // 2 - 1), min(hh, (y1 + 1) // 2 + 1)
        lo = cv2.remap(self._lo_src, mlo[k0:k1], None, cv2.INTER_LINEAR,
                       dst=self._buf("lo_half", (k1 - k0, mlo.shape[1], self._lo_src.shape[2] if self._lo_src.ndim == 3 else 1),
                                     np.uint8).reshape((k1 - k0, mlo.shape[1]) + self._lo_src.shape[2:]),
                       borderMode=cv2.BORDER_REPLICATE)
        return _from_bgra(lo, self.C).reshape(k1 - k0, mlo.shape[1], self.C), k0

    def _lo_up(self, bg: np.ndarray, lo: np.ndarray, k0: int, wh: int, y0: int, y1: int) -> None:
        """Rows ``y0 .. y1`` of ``bg`` from half-resolution rows ``k0 ..`` (``lo``), upscaled twice."""
        big = cv2.resize(lo, (2 * wh, 2 * lo.shape[0]), dst=self._buf("lo_up", (2 * lo.shape[0], 2 * wh, self.C), np.uint8),
                         interpolation=cv2.INTER_LINEAR)
        bg[y0:y1] = big[y0 - 2 * k0:y1 - 2 * k0, :self.W].reshape(y1 - y0, self.W, self.C)

    # ------------------------------------------------------- swaying cameras: panoramas
    def _level(self, fy: float) -> _PanoLevel:
        """The panorama level (zoom steps of sqrt(2)) for a camera of focal length ``fy``."""
        k = int(round(2.0 * math.log2(fy / self.ref_camera.intrinsics.fy)))
        L = self._levels.get(k)
        if L is None:
            f_px = self.ref_camera.intrinsics.fy * 2.0 ** (k / 2.0)
            ppd = f_px * math.pi / 180.0 * _PANO_OVERSAMPLE
            p = self.pano
            shape = (max(2, int(math.ceil((p.el_max - p.el_min) * ppd))),
                     max(2, int(math.ceil((p.az_max - p.az_min) * ppd))))
            az_rel = p.az_min + (np.arange(shape[1]) + 0.5) / ppd
            wt = ((p.el_max - p.water_top_at(az_rel)) * ppd - 0.5).astype(np.float32)
            L = self._levels[k] = _PanoLevel(ppd, f_px, shape, wt)
        return L

    def _pano_hi_map(self, L: _PanoLevel, y0: int, y1: int, x0: int, x1: int):
        """Coordinates in the sharp band of the rows ``0 .. b1`` of level ``L``'s panorama region
        ``[y0:y1, x0:x1]`` (the sea kernel's water test; rows below ``b1`` are all water), and the
        band's rows ``b0 .. b1`` within them."""
        p, ppd = self.pano, L.ppd
        w = x1 - x0
        xs = (np.arange(x0, x1, dtype=np.float64) + 0.5) / ppd  # degrees from az_min / el_max
        ys = (np.arange(y0, y1, dtype=np.float64) + 0.5) / ppd
        hix = (xs * p.ppd_hi - 0.5).astype(np.float32)
        hiy = ((p.band_el_max - p.el_max + ys) * p.ppd_hi - 0.5).astype(np.float32)
        band = np.nonzero((hiy >= -1.0) & (hiy <= p.hi.shape[0]))[0]
        b1 = int(band[-1]) + 1 if len(band) else (y1 - y0 if len(hiy) and hiy[-1] < 0 else 0)
        b0 = int(band[0]) if len(band) else b1
        hi_map = np.empty((b1, w, 2), np.float32)
        hi_map[..., 0] = hix[None, :]
        hi_map[..., 1] = hiy[:b1, None]
        return hi_map, b0, b1

    def _pano_bg_region(self, L: _PanoLevel, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
        """Sky, clouds, coast and sea base of level ``L``'s panorama, pixels ``[y0:y1, x0:x1]``."""
        p, ppd = self.pano, L.ppd
        h, w = y1 - y0, x1 - x0
        xs = (np.arange(x0, x1, dtype=np.float64) + 0.5) / ppd  # degrees from az_min / el_max
        ys = (np.arange(y0, y1, dtype=np.float64) + 0.5) / ppd
        lox = (xs * p.ppd_lo - 0.5).astype(np.float32)
        loy = (ys * p.ppd_lo - 0.5).astype(np.float32)
        out = cv2.remap(p.lo, np.broadcast_to(lox[None, :], (h, w)).copy(),
                        np.broadcast_to(loy[:, None], (h, w)).copy(), cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_REPLICATE).reshape(h, w, self.C)
        hi_map, b0, b1 = self._pano_hi_map(L, y0, y1, x0, x1)
        if b1 > b0:
            dst = np.ascontiguousarray(out[b0:b1])
            res = cv2.remap(p.hi, np.ascontiguousarray(hi_map[b0:b1]), None, cv2.INTER_LINEAR,
                            dst=dst[..., 0] if self.C == 1 else dst, borderMode=cv2.BORDER_TRANSPARENT)
            out[b0:b1] = res.reshape(dst.shape)
        return out

    def _pano_region(self, L: _PanoLevel, fi: int, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
        """Pixels ``[y0:y1, x0:x1]`` of level ``L``'s panorama at wave frame ``fi`` (-1: no waves).

        Every pixel depends only on its panorama position (the sea grid is anchored to panorama
        multiples of the grid step), so regions built in any order tile seamlessly."""
        p, ppd, s, T = self.pano, L.ppd, _GRID_PX, _TILE_PX
        if L.bg is None:
            L.bg = np.zeros(L.shape + (self.C,), np.uint8)
            L.bg_built = np.zeros((-(-L.shape[0] // T), -(-L.shape[1] // T)), bool)
        bg, oy, ox = self._tiles(L.bg, L.bg_built, y0 // T, -(-y1 // T), x0 // T, -(-x1 // T),
                                 lambda a0, a1, b0, b1: self._pano_bg_region(L, a0, a1, b0, b1))
        out = bg[y0 - oy:y1 - oy, x0 - ox:x1 - ox].copy()
        h, w = out.shape[:2]
        r0 = max(0, int(math.floor(float(L.water_top_y[max(0, x0 - 2):x1 + 2].min()))) - y0 - 1)  # no water above
        if fi < 0 or r0 >= h:
            return out
        hi_map = self._pano_hi_map(L, y0, y1, x0, x1)[0]
        gw, gh = -(-w // s) + 2, -(-h // s) + 2
        gx = x0 + (np.arange(gw) - 0.5) * s - 0.5  # grid samples at panorama positions
        gy = y0 + (np.arange(gh) - 0.5) * s - 0.5
        az_rel = p.az_min + (gx + 0.5) / ppd
        el = p.el_max - (gy + 0.5) / ppd
        az = np.broadcast_to((self.ref_az + az_rel[None, :]) % 360.0, (gh, gw))
        g = self._grid_params(np.ascontiguousarray(az), np.repeat(el[:, None], gw, axis=1), L.f_px,
                              self.ref_camera.r_eff_m)
        grid = np.ascontiguousarray(np.moveaxis(g[4:8], 0, -1), np.float32)
        sea_waves_grid(out, r0, grid, s, self.waves.frame_by_index(fi), self._gain, self._glint_col,
                       hi_map, 0, self._water_top_y)
        return out

    def _tiles(self, store, built, ty0, ty1, tx0, tx1, make, conv=None):
        """Build the missing tiles of ``store`` among tiles ``[ty0:ty1, tx0:tx1]`` (one region:
        the bounding box of the missing ones) with ``make(y0, y1, x0, x1)``.  Returns ``(image,
        oy, ox)``: ``store`` (0, 0), or over the memory budget a region built for this call only."""
        T = _TILE_PX
        ph, pw = store.shape[:2]
        miss = ~built[ty0:ty1, tx0:tx1]
        if not miss.any():
            return store, 0, 0
        rr, cc = np.nonzero(miss)
        a0, a1 = ty0 + int(rr.min()), ty0 + int(rr.max()) + 1
        b0, b1 = tx0 + int(cc.min()), tx0 + int(cc.max()) + 1
        nb = int(np.count_nonzero(~built[a0:a1, b0:b1])) * T * T * store.shape[2]
        if self._cache_bytes + nb > self.sea_cache_mb * 1e6:
            oy, ox = ty0 * T, tx0 * T
            out = make(oy, min(ph, ty1 * T), ox, min(pw, tx1 * T))
            return (out if conv is None else conv(out)), oy, ox
        y0, y1, x0, x1 = a0 * T, min(ph, a1 * T), b0 * T, min(pw, b1 * T)
        out = make(y0, y1, x0, x1)
        store[y0:y1, x0:x1] = out if conv is None else conv(out)
        built[a0:a1, b0:b1] = True
        self._cache_bytes += nb
        return store, 0, 0

    def _pano_frame(self, cam: CameraModel, t_s: float):
        """Background and sea of a swaying camera's frame: one remap of a cached panorama."""
        W, H, s = self.W, self.H, _GRID_PX
        L = self._level(float(cam.intrinsics.fy))
        gw, gh, U, V = self._grid_px()
        az, el = cam.pixel_to_azel(U, V)
        p = self.pano
        az_rel = (az - self.ref_az + 180.0) % 360.0 - 180.0
        px = (az_rel - p.az_min) * L.ppd - 0.5
        py = (p.el_max - el) * L.ppd - 0.5
        ph, pw = L.shape
        T = _TILE_PX
        tx0 = max(0, int(math.floor(px.min())) - 2) // T
        tx1 = min(pw - 1, int(math.ceil(px.max())) + 2) // T + 1
        ty0 = max(0, int(math.floor(py.min())) - 2) // T
        ty1 = min(ph - 1, int(math.ceil(py.max())) + 2) // T + 1
        fi = self.waves.frame_index(t_s) if self.options.waves else -1
        entry = L.frames.get(fi)
        if entry is None:  # virtual memory: pages are only touched tile by tile
            entry = L.frames[fi] = (np.zeros((ph, pw, 4 if self.C == 3 else 1), np.uint8),  # BGRA: fast remap
                                    np.zeros((-(-ph // T), -(-pw // T)), bool))
        src, oy, ox = self._tiles(entry[0], entry[1], ty0, ty1, tx0, tx1,
                                  lambda y0, y1, x0, x1: self._pano_region(L, fi, y0, y1, x0, x1), conv=_bgra)
        m = _upsample_grid(np.stack((px - ox, py - oy), axis=-1), gw, s, (H, W))
        # rows whose grid samples above and below all lie above the lowest water top hold no water
        # (the map is linear between samples): the scan for the first water row starts below them
        wet = np.nonzero((py > float(L.water_top_y.min())).any(axis=1))[0]
        r_s = min(H, max(0, (int(wet[0]) - 2) * s)) if len(wet) else H
        water_row = (first_water_rows(m[r_s:], L.water_top_y[ox:] - np.float32(oy)) + r_s).astype(np.float64)
        m1, m2 = cv2.convertMaps(m, None, cv2.CV_16SC2)
        img = _from_bgra(cv2.remap(src, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE), self.C)
        return img.reshape(H, W, self.C), water_row

    # --------------------------------------------------------------------- vessels
    def _traj_table(self):
        """Every vessel's trajectory legs packed for :func:`trajectory_states`, with the vessels'
        ids and lengths (remade when the vessel list changes)."""
        vs = self.world.vessels
        tab = self.__dict__.get("_traj_tab")
        # (the table keeps the trajectories it was made from and compares them by identity: an id()
        # alone could be reused by a new trajectory after the old one is freed)
        if tab is None or len(tab[0]) != len(vs) or any(
                t is not v.trajectory or i != v.id or L != v.length_m for (t, i, L), v in zip(tab[0], vs)):
            key = [(v.trajectory, v.id, v.length_m) for v in vs]
            tabs = [v.trajectory._table for v in vs]
            cat = (lambda i: np.concatenate([t[i] for t in tabs]).astype(np.float64)) if vs else (lambda i: np.zeros(0))
            legs = np.concatenate([t[4] for t in tabs]) if vs else np.zeros((0, 3))
            off = np.cumsum([0] + [len(t[0]) for t in tabs]).astype(np.int64)
            tab = self._traj_tab = (key, off, cat(0), cat(1), cat(2), cat(3), np.ascontiguousarray(legs[:, 1]),
                                    np.ascontiguousarray(legs[:, 2]), np.array([v.id for v in vs], np.int64),
                                    np.array([v.length_m for v in vs], np.float64))
        return tab[1:]

    def _states(self, ks: np.ndarray, t: np.ndarray) -> np.ndarray:
        """``(len(ks), T, 4)`` e, n, course, speed of vessels ``ks`` at times ``t`` (len(ks), T)."""
        off, ts, es, ns, cs, vs, ws = self._traj_table()[:7]
        out = np.empty(t.shape + (4,))
        trajectory_states(t, ks, off, ts, es, ns, cs, vs, ws, out)
        return out

    def _vessel_points(self, t_s: float):
        """World vertices of every vessel at ``t_s``, concatenated: ``(E, N, Z, bounds, poses)``,
        vessel ``k``'s vertices at ``bounds[k]:bounds[k + 1]`` and its pose ``poses[k] = (e, n,
        course, speed, fwd, port, roll, pitch, heave)``."""
        vs = self.world.vessels
        key = tuple(id(v.model) for v in vs)
        cat = self.__dict__.get("_verts_cat")
        if cat is None or cat[0] != key:  # every vessel's model vertices in one array, and the vessel
            sizes = [len(v.model.verts) for v in vs]  # that each vertex belongs to (remade when the
            verts = np.concatenate([v.model.verts for v in vs]) if vs else np.zeros((0, 3))  # list changes)
            cat = self._verts_cat = (key, [v.model for v in vs], verts[:, 0].copy(), verts[:, 1].copy(),
                                     verts[:, 2].copy(), np.repeat(np.arange(len(vs)), sizes), np.cumsum([0] + sizes))
        x, y, z, owner, bounds = cat[2:]
        nv = len(vs)
        st = self._states(np.arange(nv), np.full((nv, 1), float(t_s)))[:, 0]
        ids, lengths = self._traj_table()[7:]
        # e, n, fwd (2), port (2), cos and sin of roll and pitch, heave, roll, pitch
        par = np.empty((13, nv))
        vessel_poses(st, ids, lengths, float(t_s), bool(self.options.vessel_motion), par)
        cols = par.T.tolist()
        stl = st.tolist()
        poses = [(p[0], p[1], q[2], q[3], (p[2], p[3]), (p[4], p[5]), p[11], p[12], p[10]) for p, q in zip(cols, stl)]
        E, N, Z = np.empty(len(x)), np.empty(len(x)), np.empty(len(x))
        pose_vertices(x, y, z, owner, par, bool(self.options.vessel_motion), E, N, Z)  # (attitude, then place)
        return E, N, Z, bounds, poses

    def _to_cam(self, e, n):
        if self.world_to_camera is None:
            return e, n
        A = self.world_to_camera
        return A[0, 0] * e + A[0, 1] * n + A[0, 2], A[1, 0] * e + A[1, 1] * n + A[1, 2]

    def _sea_image(self, view: _View, t_s: float) -> np.ndarray:
        """Background plus animated waves (a fresh array), cached per wave frame for steady views."""
        o = self.options
        if not (o.waves and view.sea_grid is not None):
            return view.bg.copy()
        fi = self.waves.frame_index(t_s)
        cache = view.sea_cache
        r0 = view.sea_r0
        if cache is not None:
            hit = cache.get(fi)
            if hit is not None:  # only the rows with water are cached
                img = np.empty_like(view.bg)
                img[:r0] = view.bg[:r0]
                img[r0:] = hit
                return img
        ys = view.half_y0
        if cache is None and self.sea_half_res:  # a moving camera's view, at its first (and most often
            img, view.bg = view.bg, None  # only) frame: the background becomes the frame, no copy; a
        else:  # later hit rebuilds the view (fixed cameras keep theirs and copy it)
            img = np.empty_like(view.bg)
            img[:ys] = view.bg[:ys]
        tile = self.waves.frame(t_s)
        if r0 < ys:  # full resolution down to the half-resolution rows
            sea_waves_grid(img[:ys], r0, view.sea_grid, _GRID_PX, tile, self._gain, self._glint_col,
                           view.hi_map, view.hi_r0, self._water_top_y)
        if ys < self.H:
            self._sea_sampled(img, view, t_s)
        nb = img[r0:].nbytes
        if cache is not None and self._cache_bytes + nb <= self.sea_cache_mb * 1e6:
            cache[fi] = img[r0:].copy()
            self._cache_bytes += nb
        return img

    def _sea_sampled(self, img: np.ndarray, view: _View, t_s: float) -> None:
        """Rows ``view.half_y0 ..`` (all water, below the horizon band): the wave parameters and
        the sea base's row in the coarse panorama interpolated from the grid, the wave texture
        sampled with one ``cv2.remap`` (coordinates wrapped into the tile), shading and glints in
        one element-wise pass.  Below the horizon the coarse panorama depends on elevation only
        (no clouds), so the sea base colour is its first column's profile, evaluated at the grid
        samples and interpolated with the other wave parameters.

        Range-dependent detail: from row ``view.lod_y`` down, where one image pixel spans at most
        half a texel across (the texture is magnified along the rows; it is foreshortened along
        the columns, which keep full resolution), the rows are rendered at half width and
        upscaled: one sample per texel at most, so the texture (glints included) keeps its detail.
        The rows above, where the texture is minified, are rendered at full resolution."""
        ys, yl, H = view.half_y0, view.lod_y, self.H
        if yl > ys:
            self._sea_rows(img, view, t_s, ys, yl, half=False)
        if H > yl:
            self._sea_rows(img, view, t_s, yl, H, half=True)

    def _sea_rows(self, img: np.ndarray, view: _View, t_s: float, y0: int, y1: int, half: bool) -> None:
        """Water rows ``y0 .. y1`` of ``img`` (see :meth:`_sea_sampled`), at full or half width.

        The wave parameters and the sea base colour are interpolated from the grid inside the
        kernels, row by row (no full-size intermediate arrays)."""
        W, C, s = self.W, self.C, _GRID_PX
        sx = s // 2 if half else s
        w = -(-W // 2) if half else W
        grid = view.sea_grid
        seg, wts = _grid_cols(w, sx, grid.shape[1])
        n = y1 - y0
        maps = self._buf("sea_maps", (n, w, 2))
        tile4 = self._wave_tile4(t_s)
        sea_maps_grid(grid, y0, s, seg, wts, tile4.shape[0] - 1, maps)
        tex = cv2.remap(tile4, maps, None, cv2.INTER_LINEAR, dst=self._buf("sea_tex", (n, w, 4), np.uint8))
        if not half:
            sea_shade_grid(img[y0:y1], tex, grid, view.sea_base, y0, s, seg, wts, self._gain, self._glint_col)
            return
        rows = self._buf("sea_rows", (n, w, C), np.uint8)
        sea_shade_grid(rows, tex, grid, view.sea_base, y0, s, seg, wts, self._gain, self._glint_col)
        if 2 * w == W:  # straight into the image's rows (C-contiguous)
            d = img[y0:y1] if C > 1 else img[y0:y1, :, 0]  # views of img (never copies)
            res = cv2.resize(rows.reshape(d.shape[:1] + (w,) + d.shape[2:]), (W, n), dst=d,
                             interpolation=cv2.INTER_LINEAR)
            if not np.shares_memory(res, d):  # (OpenCV wrote into a new array)
                d[...] = res
            return
        wide = cv2.resize(rows, (2 * w, n), interpolation=cv2.INTER_LINEAR)
        img[y0:y1] = wide[:, :W].reshape(n, W, C)

    def _buf(self, name: str, shape: tuple, dtype=np.float32) -> np.ndarray:
        """A C-contiguous scratch array of ``shape``, reused from call to call under ``name``
        (its content is undefined; the caller overwrites it)."""
        n = math.prod(shape)
        b = self._bufs.get(name)
        if b is None or b.size < n or b.dtype != np.dtype(dtype):
            b = self._bufs[name] = np.empty(max(n, n + n // 4), dtype)
        return b[:n].reshape(shape)

    def _wave_tile4(self, t_s: float) -> np.ndarray:
        """The wave texture of ``t_s`` as a (T + 1, T + 1, 4) uint8 tile (shade, glint, 0, 0) with
        its first row and column repeated at the end, so that bilinear sampling at wrapped
        coordinates in ``[0, T)`` never leaves it (cached per animation frame)."""
        fi = self.waves.frame_index(t_s)
        t4 = self._tiles4.get(fi)
        if t4 is None:
            tile = self.waves.frame_by_index(fi)
            n = tile.shape[0]
            t4 = np.zeros((n + 1, n + 1, 4), np.uint8)
            t4[:n, :n, :2] = tile
            t4[n, :n, :2] = tile[0]
            t4[:n, n, :2] = tile[:, 0]
            t4[n, n, :2] = tile[0, 0]
            self._tiles4[fi] = t4
        return t4

    def render(self, t_s: float, cam: CameraModel, frame_seed: int = 0, draw_vessels: bool = True) -> RenderResult:
        """Render the world at time ``t_s`` through ``cam``.

        Parameters
        ----------
        t_s : float
            World time in seconds.
        cam : CameraModel
            The camera (its intrinsics must match the renderer's size, or are rescaled).
        frame_seed : int
            Seeds this frame's noise (so any frame renders the same, in any order).
        draw_vessels : bool
            False renders the empty scene (sea, sky, coast; no wakes or reflections either).
        """
        if cam.intrinsics.width != self.W or cam.intrinsics.height != self.H:
            cam = cam.with_intrinsics(cam.intrinsics.scaled_to(self.W, self.H))
        if self.use_panorama:
            img, water_row = self._pano_frame(cam, t_s)
        else:
            view = self._view(cam)
            img = self._sea_image(view, t_s)
            water_row = view.water_row
        if draw_vessels and len(self.world.vessels) > 255:
            raise ValueError(f"the renderer labels at most 255 vessels (uint8 label image); the world has "
                             f"{len(self.world.vessels)}")
        label = np.zeros((self.H, self.W), np.uint8)
        rows = []
        if draw_vessels and len(self.world.vessels):
            drawn = self._draw_vessels(img, label, t_s, cam)
            vis = np.empty((len(drawn), 5), np.int64)  # visible pixels and their box, per vessel
            label_boxes(label, np.array([d[0] + 1 for d in drawn], np.int64),
                        np.array([d[2] for d in drawn], np.int64).reshape(-1, 4), vis)
            for (k, full_px, fbox, depth), (vpx, bx, by, bw, bh) in zip(drawn, vis.tolist()):
                x0, y0, x1, y1 = fbox
                rows.append((k, (bx, by, bw, bh), (x0, y0, x1 - x0, y1 - y0), vpx / max(full_px, 1), vpx, full_px,
                             depth))
        img = self._finish(img, frame_seed)
        rows.sort(key=lambda r: r[0])
        return RenderResult(
            image=img,
            index=np.array([r[0] for r in rows], np.int64),
            boxes=np.array([r[1] for r in rows], np.float64).reshape(-1, 4),
            full_boxes=np.array([r[2] for r in rows], np.float64).reshape(-1, 4),
            visible=np.array([r[3] for r in rows], np.float64),
            visible_px=np.array([r[4] for r in rows], np.int64),
            full_px=np.array([r[5] for r in rows], np.int64),
            depth_m=np.array([r[6] for r in rows], np.float64),
            label=label,
            water_row=water_row,
        )

    def _draw_vessels(self, img, label, t_s, cam: CameraModel):
        o = self.options
        E, N, Z, bounds, poses = self._vessel_points(t_s)
        ce, cn = self._to_cam(E, N)
        nv = len(E)
        if o.reflections:  # one projection for every vertex and its mirror image in the sea
            u, v, depth = cam.enu_to_pixel(np.concatenate([ce, ce]), np.concatenate([cn, cn]),
                                           np.concatenate([Z, -Z]))
        else:
            u, v, depth = cam.enu_to_pixel(ce, cn, Z)
        order = []
        W, H = self.W, self.H
        # per-vessel extents of the projected vertices (and of their mirror images), in one pass each
        starts = bounds[:-1]
        dmin = np.minimum.reduceat(depth[:nv], starts)
        umin, umax = np.minimum.reduceat(u[:nv], starts), np.maximum.reduceat(u[:nv], starts)
        vmin, vmax = np.minimum.reduceat(v[:nv], starts), np.maximum.reduceat(v[:nv], starts)
        for k, p in enumerate(poses):
            if dmin[k] <= 0.5:
                continue  # partly behind the camera: not renderable as a pinhole silhouette
            e, n = p[0], p[1]
            cx, cy = self._to_cam(e, n)
            order.append((math.hypot(cx, cy), k, cx, cy))
        order.sort(reverse=True)  # far first
        # ---- pass 1: wakes and reflections on the water (they never cover a vessel's pixels)
        near = []
        for dist, k, _, _ in order:
            if not (umax[k] < -0.5 * W or umin[k] > 1.5 * W or vmin[k] > H):
                near.append(k)  # else far outside the view: its wake and reflection cannot show
        wakes = self._wake_quads(near, t_s, cam) if o.wakes and near else {}
        for k in near:
            if k in wakes:
                self._draw_wake(img, wakes[k], t_s)
            if o.reflections:
                msl = slice(nv + bounds[k], nv + bounds[k + 1])
                self._draw_reflection(img, k, u[msl], v[msl])
        # ---- pass 2: vessels, far to near
        drawn = []
        for dist, k, cx, cy in order:
            sl = slice(bounds[k], bounds[k + 1])
            if umax[k] < -1 or vmax[k] < -1 or umin[k] > W or vmin[k] > H:
                continue
            uu, vv = u[sl], v[sl]
            e, n, course, speed, fwd, port, roll, pitch, heave = poses[k]
            # the camera in the vessel's frame (for back-face culling); far vessels sit lower (curvature)
            cam_up = self.height_m + dist * dist / (2 * cam.r_eff_m) - heave
            if self.world_to_camera is not None:
                de, dn = np.linalg.solve(self.world_to_camera[:, :2], -np.array([cx, cy], float))
            else:
                de, dn = -cx, -cy
            xl, yl, zl = de * fwd[0] + dn * fwd[1], de * port[0] + dn * port[1], cam_up
            if roll or pitch:  # undo the vessel's attitude
                cp, sp = math.cos(pitch), math.sin(pitch)
                xl, zl = xl * cp + zl * sp, -xl * sp + zl * cp
                cr, sr = math.cos(roll), math.sin(roll)
                yl, zl = yl * cr + zl * sr, -yl * sr + zl * cr
            sun = self._sun
            sun_local = np.array([sun[0] * fwd[0] + sun[1] * fwd[1], sun[0] * port[0] + sun[1] * port[1], sun[2]])
            res = self._draw_one(img, label, k, uu, vv, np.array([xl, yl, zl]), sun_local)
            if res is not None:
                drawn.append((k, res[0], res[1], dist))
        return drawn

    def _draw_one(self, img, label, k, uu, vv, cam_local, sun_local):
        """Draw vessel ``k`` into a canvas of its own, composite it and label its pixels
        (:func:`draw_vessel`): ``(full_px, (x0, y0, x1, y1))`` of its visible pixels, or None."""
        vessel = self.world.vessels[k]
        m = vessel.model
        cols = np.ascontiguousarray(m.all_ir[:, None] if self.options.ir else m.all_bgr, np.float64)  # (no copy)
        res = self._draw_res
        draw_vessel(img, label, k + 1, np.ascontiguousarray(uu), np.ascontiguousarray(vv), m.all_normals,
                    m.all_centres, cols, not self.options.ir, m.face_idx, m.face_nvert, m.face_part,
                    m.part_centres, cam_local, sun_local, res)
        full_px, ix0, iy0, ix1, iy1, bx0, by0, bx1, by1 = (int(x) for x in res)
        if full_px == 0:
            return None
        if self.options.ir and self.options.ir_halo > 0:
            cm = label[iy0:iy1, ix0:ix1] == k + 1
            self._halo(img, label, cm, ix0, iy0, ix1, iy1, vessel)
        return full_px, (bx0, by0, bx1, by1)

    def _halo(self, img, label, cm, ix0, iy0, ix1, iy1, vessel):
        """A soft bright glow around a warm vessel (thermal sensors' halo), outside its pixels."""
        sig = max(1.5, 0.25 * (iy1 - iy0))
        pad = int(3 * sig) + 1
        X0, Y0 = max(ix0 - pad, 0), max(iy0 - pad, 0)
        X1, Y1 = min(ix1 + pad, self.W), min(iy1 + pad, self.H)
        m = np.zeros((Y1 - Y0, X1 - X0), np.float32)
        m[iy0 - Y0:iy1 - Y0, ix0 - X0:ix1 - X0] = cm
        g = cv2.GaussianBlur(m, (0, 0), sig)
        strength = self.options.ir_halo * max(0.0, vessel.ir_level - self.sky.ir_sea_far) * 0.8
        roi = img[Y0:Y1, X0:X1, 0]
        free = label[Y0:Y1, X0:X1] == 0
        out = np.clip(roi + g * strength, 0, 255).astype(np.uint8)
        np.copyto(roi, out, where=free)

    def _draw_reflection(self, img, k, mu, mv):
        """Mirror image of the vessel in the water: darkened, fading with depth, rippled."""
        m = self.world.vessels[k].model
        draw_reflection(img, mu, mv, m.face_idx, m.face_nvert, m.face_refl_ir if self.options.ir else m.face_refl_bgr,
                        0.25 if self.options.ir else 0.45, float(k))

    def _wake_quads(self, ks, t_s, cam: CameraModel) -> dict:
        """Projected wake quads of vessels ``ks``, all vessels at once: ``k -> (u (q, 4), v (q, 4),
        alpha (q,), ok (q,))`` (``ok``: the quads wholly in front of the camera); the foam of the
        turbulent wake, the Kelvin arms and the bow wave."""
        tau = _WAKE_TAU
        ks = np.asarray(ks, np.int64)
        st = self._states(ks, t_s - np.broadcast_to(tau, (len(ks), len(tau))))  # (V, len(tau), 4)
        moving = st[:, 0, 3] >= 0.3
        if not moving.any():
            return {}
        ks, st = ks[moving], st[moving]
        vs = self.world.vessels
        c = np.radians(st[..., 2])
        V, nq = len(ks), len(tau) - 1
        Q = np.empty((V, 3 * nq + 1, 4, 2))
        al = np.empty((V, 3 * nq + 1))
        wake_quads(np.ascontiguousarray(st[..., 0]), np.ascontiguousarray(st[..., 1]), np.sin(c), np.cos(c),
                   np.ascontiguousarray(st[:, 0, 3]), np.array([vs[k].length_m for k in ks], float),
                   np.array([vs[k].beam_m for k in ks], float), tau, _WAKE_DECAY, Q, al)
        ce, cn = self._to_cam(Q[..., 0], Q[..., 1])
        uu, vv, dd = cam.enu_to_pixel(ce, cn, 0.0)
        ok = (dd > 0.5).all(axis=-1)  # (V, q)
        return {int(k): (uu[i], vv[i], al[i], ok[i]) for i, k in enumerate(ks)}

    def _draw_wake(self, img, quads, t_s):
        """Blend one vessel's projected wake quads (from :meth:`_wake_quads`) as foam."""
        uu, vv, al, ok = quads
        draw_wake(img, uu, vv, al, ok, self._foam_col, self._foam, int(7 * t_s))

    # ---------------------------------------------------------------------- sensor
    def _finish(self, img: np.ndarray, frame_seed: int) -> np.ndarray:
        o = self.options
        if o.blur_sigma_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), o.blur_sigma_px).reshape(img.shape)
        img = np.ascontiguousarray(img)
        flat = img.reshape(self.H, self.W * self.C)  # in place, on a view OpenCV takes as it is
        if self._fpn is not None:
            cv2.add(flat, self._fpn[0].reshape(flat.shape), dst=flat)
            cv2.subtract(flat, self._fpn[1].reshape(flat.shape), dst=flat)
        if self._noise_pos is not None:
            # (default_rng's generator, built without its dispatch: the same stream, a third cheaper)
            rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([self.seed, 5, frame_seed])))
            dy = int(rng.integers(0, self._pad))  # whole rows: a contiguous slice
            cv2.add(flat, self._noise_pos[dy:dy + self.H].reshape(flat.shape), dst=flat)
            cv2.subtract(flat, self._noise_neg[dy:dy + self.H].reshape(flat.shape), dst=flat)
        if o.ir:
            img = img[..., 0]
            if o.ir_polarity == "black_hot":
                img = 255 - img
        if o.jpeg_quality > 0:
            ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(o.jpeg_quality)])
            img = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
        return np.ascontiguousarray(img)


def _bgra(img: np.ndarray) -> np.ndarray:
    """A colour image as BGRA (one-channel images unchanged)."""
    return cv2.cvtColor(img, cv2.COLOR_BGR2BGRA) if img.ndim == 3 and img.shape[2] == 3 else img


def _from_bgra(img: np.ndarray, c: int) -> np.ndarray:
    return cv2.cvtColor(img, cv2.COLOR_BGRA2BGR) if c == 3 else img


def _remap_into(dst: np.ndarray, src: np.ndarray, maps: np.ndarray, scratch: np.ndarray | None = None) -> None:
    """``cv2.remap`` of ``src`` (BGRA or one channel) into the C-contiguous rows ``dst`` (H, W, C)
    with ``BORDER_TRANSPARENT``: pixels that map outside ``src`` keep their value (``scratch``: an
    optional (H, W, 4) uint8 array for the BGRA rows)."""
    h, w, c = dst.shape
    if c == 3:
        d4 = cv2.cvtColor(dst, cv2.COLOR_BGR2BGRA, dst=scratch)
        cv2.remap(src, maps, None, cv2.INTER_LINEAR, dst=d4, borderMode=cv2.BORDER_TRANSPARENT)
        cv2.cvtColor(d4, cv2.COLOR_BGRA2BGR, dst=dst)
        return
    d2 = dst.reshape(h, w)
    res = cv2.remap(src, maps, None, cv2.INTER_LINEAR, dst=d2, borderMode=cv2.BORDER_TRANSPARENT)
    if not np.shares_memory(res, d2):  # (OpenCV wrote into a new array)
        d2[...] = res


_EYE2 = np.eye(2)
_WAKE_TAU = np.array([0.0, 1.0, 2.5, 4.5, 7.0, 10.0, 14.0])
_WAKE_DECAY = np.exp(-_WAKE_TAU / 6.0)
