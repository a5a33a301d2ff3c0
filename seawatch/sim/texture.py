"""Procedural textures for the synthetic world: noise tiles, animated sea waves, sky and coast.

Everything here is built once per scenario (or lazily once per animation frame) and then only
sampled while rendering, so per-frame work stays a few vectorised passes.

Panoramas are indexed by azimuth relative to a reference azimuth (``az_rel_deg`` in
``[az_min, az_max]``) and elevation (``el_deg``): pixel ``(x, y)`` holds
``az_rel = az_min + (x + 0.5) / ppd``, ``el = el_max - (y + 0.5) / ppd`` (``ppd`` pixels per degree).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = [
    "periodic_noise",
    "WaveField",
    "Panorama",
    "CoastSpec",
    "SkySpec",
    "build_panorama",
    "water_elevation_deg",
]

G_MPS2 = 9.81


def periodic_noise(size: int, beta: float, seed: int, aspect: float = 1.0) -> np.ndarray:
    """Tileable coloured noise (power spectrum ``1 / f**beta``), float32 scaled to [-1, 1].

    Parameters
    ----------
    size : int
        Tile side in texels (a power of two is fastest).
    beta : float
        Spectral slope; 2 gives cloud-like noise, 0 white noise.
    seed : int
    aspect : float
        Horizontal stretch (> 1 makes features wider than tall).
    """
    rng = np.random.default_rng(seed)
    fy = np.fft.fftfreq(size)[:, None]
    fx = np.fft.rfftfreq(size)[None, :] / aspect
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    amp = f ** (-beta / 2.0)
    amp[0, 0] = 0.0
    spec = amp * (rng.standard_normal(amp.shape) + 1j * rng.standard_normal(amp.shape))
    out = np.fft.irfft2(spec, s=(size, size))
    out /= max(1e-12, float(np.abs(out).max()))
    return out.astype(np.float32)


class WaveField:
    """An animated, tileable sea surface (a small linear-wave spectrum, periodic in time).

    Each animation frame is a ``(size, size, 2)`` uint8 texture: channel 0 is the shading
    (128 = flat water; brighter for facets tilted towards the viewer's sky), channel 1 the sun
    glint strength.  Frames are computed lazily and cached; the animation loops every
    ``loop_s`` seconds.

    Parameters
    ----------
    size : int
        Tile side in texels (power of two).
    texel_m : float
        Sea-surface size of one texel in metres.
    wind_dir_deg : float
        Direction the waves travel towards (clockwise from north).
    peak_wavelength_m : float
        Dominant wavelength.
    roughness : float
        Slope scale (0.5 calm ... 2 rough).
    loop_s : float
        Animation period.
    n_frames : int
        Frames per loop.
    seed : int
    """

    def __init__(self, size: int = 256, texel_m: float = 0.25, wind_dir_deg: float = 30.0,
                 peak_wavelength_m: float = 6.0, roughness: float = 1.0, loop_s: float = 8.0,
                 n_frames: int = 64, seed: int = 0):
        if size & (size - 1):
            raise ValueError(f"WaveField size must be a power of two, got {size}")
        self.size, self.texel_m, self.loop_s, self.n_frames = size, texel_m, float(loop_s), int(n_frames)
        rng = np.random.default_rng(seed)
        k1 = 2 * np.pi * np.fft.fftfreq(size, d=texel_m)  # rad/m
        ky, kx = k1[:, None], k1[None, :]
        k = np.hypot(kx, ky)
        kp = 2 * np.pi / peak_wavelength_m
        wd = math.radians(wind_dir_deg)
        # texel axes: x east, y SOUTH (image rows grow downwards); the direction vector in texels
        dirx, diry = math.sin(wd), -math.cos(wd)
        with np.errstate(divide="ignore", invalid="ignore"):
            cosang = np.where(k > 0, (kx * dirx + ky * diry) / k, 0.0)
            spec = np.where(k > 0, np.exp(-1.25 * (kp / k) ** 2) / k ** 4, 0.0)
        spread = np.clip(cosang, 0, None) ** 4 + 0.08  # mostly down-wind, some cross-sea
        spec = spec * spread
        spec[k > 6 * kp] *= np.exp(-(k[k > 6 * kp] / (6 * kp) - 1.0) * 2)
        amp = np.sqrt(spec)
        h0 = amp * (rng.standard_normal(k.shape) + 1j * rng.standard_normal(k.shape))
        # real surface: H(k, t) = h0(k) e^{i w t} + conj(h0(-k)) e^{-i w t}
        neg = (-np.arange(size)) % size
        self._h0 = h0
        self._h0m = np.conj(h0[neg][:, neg])
        # deep-water dispersion, quantised so the animation is periodic in loop_s
        w0 = 2 * np.pi / self.loop_s
        self._omega = np.round(np.sqrt(G_MPS2 * k) / w0) * w0
        self._kx, self._ky = kx, ky
        # slopes: sx + i sy = ifft2(i kx H + i (i ky H)) = ifft2(i (kx + i ky) H), both real fields
        self._grad = 1j * (kx + 1j * ky)
        sx, sy = self._slopes(0.0)
        self._scale = 1.0 / max(1e-9, float(np.std(np.hypot(sx, sy))))
        self.roughness = float(roughness)
        self._cache: dict[int, np.ndarray] = {}

    def _slopes(self, t_s: float):
        ph = np.exp(1j * self._omega * t_s)
        H = self._h0 * ph + self._h0m * np.conj(ph)
        z = np.fft.ifft2(self._grad * H)
        return z.real, z.imag

    def frame_index(self, t_s: float) -> int:
        return int(math.floor(t_s / self.loop_s * self.n_frames + 1e-9)) % self.n_frames

    def frame(self, t_s: float) -> np.ndarray:
        """The ``(size, size, 2)`` uint8 texture at time ``t_s``."""
        return self.frame_by_index(self.frame_index(t_s))

    def frame_by_index(self, i: int) -> np.ndarray:
        """The ``(size, size, 2)`` uint8 texture of animation frame ``i`` (0 .. n_frames - 1)."""
        i = int(i) % self.n_frames
        tex = self._cache.get(i)
        if tex is None:
            sx, sy = self._slopes(i * self.loop_s / self.n_frames)
            sx *= self._scale * self.roughness
            sy *= self._scale * self.roughness
            # facets tilted towards the camera (rows = south... the viewer is "below" the tile)
            shade = 128.0 + 70.0 * np.tanh(0.8 * sy + 0.25 * sx)
            slope2 = (sx - 0.5) ** 2 + (sy + 0.9) ** 2
            glint = 255.0 * np.exp(-slope2 / 0.08)
            tex = np.empty((self.size, self.size, 2), np.uint8)
            tex[..., 0] = np.clip(shade, 0, 255)
            tex[..., 1] = np.clip(glint, 0, 255)
            self._cache[i] = tex
        return tex


# ------------------------------------------------------------------------------- scenery
@dataclass(frozen=True)
class SkySpec:
    """Colours (BGR) and brightness (IR) of the sky and the sea's base."""

    zenith_bgr: tuple = (170, 120, 70)
    horizon_bgr: tuple = (225, 210, 195)
    sea_far_bgr: tuple = (150, 135, 110)  # just below the horizon (sky reflection + haze)
    sea_near_bgr: tuple = (95, 75, 40)  # looking steeply down
    haze_deg: float = 6.0  # elevation scale of the sky gradient
    clouds: float = 0.35  # cloud cover 0..1
    cloud_bgr: tuple = (235, 235, 235)
    sun_az_deg: float = 200.0
    sun_el_deg: float = 25.0
    # thermal (IR, white-hot grey levels)
    ir_sky_zenith: float = 30.0
    ir_sky_horizon: float = 90.0
    ir_sea_far: float = 85.0
    ir_sea_near: float = 70.0
    ir_land: float = 120.0


@dataclass(frozen=True)
class CoastSpec:
    """A coastline band: land between two azimuths at a distance, with hills and structures.

    Parameters
    ----------
    az_from_deg, az_to_deg : float
        Absolute azimuth span of the land (clockwise from ``az_from_deg`` to ``az_to_deg``).
    distance_m : float
        Distance of the water line at the middle of the span.
    distance_slope : float
        Relative change of the distance across the span (the shore is not perpendicular to the view).
    hill_m : float
        Typical hill height above the water line.
    structures : int
        Number of buildings / cranes / towers along the shore.
    land_bgr, rock_bgr : tuple
        Vegetation and shore colours.
    seed : int
    """

    az_from_deg: float = 150.0
    az_to_deg: float = 230.0
    distance_m: float = 3000.0
    distance_slope: float = 0.3
    hill_m: float = 40.0
    structures: int = 25
    land_bgr: tuple = (70, 105, 85)
    rock_bgr: tuple = (120, 130, 135)
    seed: int = 0

    def span_deg(self) -> float:
        return (self.az_to_deg - self.az_from_deg) % 360.0


def _rel(az_deg, ref_deg):
    return (np.asarray(az_deg, np.float64) - ref_deg + 180.0) % 360.0 - 180.0


def water_elevation_deg(distance_m, height_m: float, r_eff_m: float) -> np.ndarray:
    """Elevation of the water line of a shore at ``distance_m`` seen from ``height_m`` (curved sea)."""
    d = np.asarray(distance_m, np.float64)
    drop = d * d / (2.0 * r_eff_m)
    return np.degrees(np.arctan2(-(height_m + drop), d))


@dataclass
class Panorama:
    """Background panoramas of one scene for one camera position.

    ``lo`` covers the whole visible sphere part at ``ppd_lo``; ``hi`` is a thin, sharp band around
    the horizon and the coast at ``ppd_hi``; both have the same channels (3 EO, 1 IR).
    ``water_top_deg`` gives, for each ``hi`` column, the elevation above which there is no
    water (the sea horizon, or the coast's water line).  A direction at azimuth ``az_rel``
    (degrees from ``ref_az_deg``) and elevation ``el`` sits at pixel
    ``((az_rel - az_min) * ppd - 0.5, (top - el) * ppd - 0.5)`` of either panorama, ``top`` being
    ``el_max`` for ``lo`` and ``band_el_max`` for ``hi`` (what the view kernels compute).
    """

    ref_az_deg: float
    az_min: float
    az_max: float
    el_min: float
    el_max: float
    ppd_lo: float
    lo: np.ndarray
    band_el_min: float
    band_el_max: float
    ppd_hi: float
    hi: np.ndarray
    water_top_deg: np.ndarray
    horizon_el_deg: float
    extras: dict = field(default_factory=dict)

    def water_top_at(self, az_rel) -> np.ndarray:
        x = np.clip(((np.asarray(az_rel) - self.az_min) * self.ppd_hi).astype(np.int64), 0,
                    len(self.water_top_deg) - 1)
        return self.water_top_deg[x]


def _sky_sea_column(el: np.ndarray, horizon_el: float, sky: SkySpec, ir: bool) -> np.ndarray:
    """Colour (N, C) float of the sky above and the sea base below the horizon, by elevation."""
    above = el - horizon_el
    if ir:
        a = np.clip(1 - np.exp(-np.maximum(above, 0) / (sky.haze_deg * 1.5)), 0, 1)
        skyv = sky.ir_sky_horizon + (sky.ir_sky_zenith - sky.ir_sky_horizon) * a
        b = np.clip(1 - np.exp(np.minimum(above, 0) / 5.0), 0, 1)
        seav = sky.ir_sea_far + (sky.ir_sea_near - sky.ir_sea_far) * b
        return np.where(above >= 0, skyv, seav)[:, None]
    a = np.clip(1 - np.exp(-np.maximum(above, 0) / sky.haze_deg), 0, 1)[:, None]
    skyc = np.asarray(sky.horizon_bgr, float) + (np.asarray(sky.zenith_bgr, float) - sky.horizon_bgr) * a
    b = np.clip(1 - np.exp(np.minimum(above, 0) / 4.0), 0, 1)[:, None]
    seac = np.asarray(sky.sea_far_bgr, float) + (np.asarray(sky.sea_near_bgr, float) - sky.sea_far_bgr) * b
    return np.where((above >= 0)[:, None], skyc, seac)


def _paint_background(az_rel: np.ndarray, el: np.ndarray, horizon_el: float, sky: SkySpec, ir: bool,
                      clouds: np.ndarray | None) -> np.ndarray:
    """Sky gradient + clouds + sea base for a grid of (az_rel columns, el rows) -> (H, W, C) float."""
    col = _sky_sea_column(el, horizon_el, sky, ir)  # (H, C)
    img = np.repeat(col[:, None, :], len(az_rel), axis=1)
    if clouds is not None and sky.clouds > 0:
        above = (el - horizon_el)[:, None]
        fade = np.clip((above - 1.0) / 6.0, 0, 1)  # no clouds in the haze just above the horizon
        cov = np.clip((clouds + (sky.clouds - 0.5) * 1.2) * 1.6, 0, 1) * fade
        target = np.array([sky.ir_sky_horizon + 10.0]) if ir else np.asarray(sky.cloud_bgr, float)
        shade = 0.85 + 0.15 * np.clip(clouds, -1, 1)  # cloud bases darker
        img = img * (1 - cov[..., None]) + (target * shade[..., None]) * cov[..., None]
    return img


def _sample_tile(tile: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear, wrapping lookup of a periodic tile at (broadcast) texel coordinates."""
    x, y = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
    xm = np.mod(x, tile.shape[1]).astype(np.float32)
    ym = np.mod(y, tile.shape[0]).astype(np.float32)
    return cv2.remap(tile, xm, ym, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)


def build_panorama(
    *,
    ref_az_deg: float,
    az_span_deg: tuple[float, float],
    el_span_deg: tuple[float, float],
    camera_height_m: float,
    r_eff_m: float,
    horizon_el_deg: float,
    sky: SkySpec,
    coasts: tuple[CoastSpec, ...] = (),
    ppd_hi: float = 20.0,
    ppd_lo: float = 6.0,
    ir: bool = False,
    seed: int = 0,
) -> Panorama:
    """Build the sky/sea/coast panoramas seen from one camera position.

    Parameters
    ----------
    ref_az_deg : float
        Azimuth that relative azimuths are measured from (usually the base pan).
    az_span_deg, el_span_deg : (float, float)
        Relative azimuth and elevation ranges that the camera can ever see.
    camera_height_m, r_eff_m : float
        Camera height and effective Earth radius (for the coast's water line).
    horizon_el_deg : float
        Elevation of the sea horizon (negative: the dip).
    sky : SkySpec
    coasts : tuple of CoastSpec
    ppd_hi, ppd_lo : float
        Pixels per degree of the sharp horizon band and of the coarse panorama.
    ir : bool
        Thermal panorama (one channel) instead of colour.
    seed : int
    """
    az_min, az_max = float(az_span_deg[0]), float(az_span_deg[1])
    el_min, el_max = float(el_span_deg[0]), float(el_span_deg[1])
    rng = np.random.default_rng(seed)
    # ---- coarse sky / sea
    w_lo = max(2, int(math.ceil((az_max - az_min) * ppd_lo)))
    h_lo = max(2, int(math.ceil((el_max - el_min) * ppd_lo)))
    az_lo = az_min + (np.arange(w_lo) + 0.5) / ppd_lo
    el_lo = el_max - (np.arange(h_lo) + 0.5) / ppd_lo
    cloud_tile = periodic_noise(256, 2.6, seed + 11, aspect=3.0)
    # clouds in az/el, roughly 1 texel per 0.25 deg horizontally, sheared by elevation
    ca = _sample_tile(cloud_tile, (az_lo[None, :] + 360.0) * 2.0, (el_lo[:, None] + 90.0) * 5.0)
    lo = _paint_background(az_lo, el_lo, horizon_el_deg, sky, ir, ca)
    # ---- sharp band around the horizon and the coast
    band_lo, band_hi = horizon_el_deg - 0.6, horizon_el_deg + 0.6
    for c in coasts:
        d = np.array([c.distance_m * (1 - abs(c.distance_slope)), c.distance_m * (1 + abs(c.distance_slope))])
        wl = water_elevation_deg(d, camera_height_m, r_eff_m)
        band_lo = min(band_lo, float(wl.min()) - 0.3)
        top = math.degrees(math.atan2(c.hill_m * 2.5 + 60.0, d.min()))
        band_hi = max(band_hi, horizon_el_deg + top + 0.3)
    band_lo = max(band_lo, el_min)
    band_hi = min(band_hi, el_max)
    w_hi = max(2, int(math.ceil((az_max - az_min) * ppd_hi)))
    h_hi = max(2, int(math.ceil((band_hi - band_lo) * ppd_hi)))
    az_hi = az_min + (np.arange(w_hi) + 0.5) / ppd_hi
    el_hi = band_hi - (np.arange(h_hi) + 0.5) / ppd_hi
    # the band repeats the coarse panorama's colours (no clouds this low) plus a crisp horizon
    hi = _paint_background(az_hi[:1], el_hi, horizon_el_deg, sky, ir, None)
    hi = np.repeat(hi, w_hi, axis=1)
    water_top = np.full(w_hi, horizon_el_deg)
    for c in coasts:
        _paint_coast(hi, water_top, az_hi, el_hi, ref_az_deg, c, camera_height_m, r_eff_m, ppd_hi, sky, ir,
                     int(rng.integers(1 << 30)))
    lo8 = np.clip(lo, 0, 255).astype(np.uint8)
    hi8 = np.clip(hi, 0, 255).astype(np.uint8)
    return Panorama(ref_az_deg, az_min, az_max, el_min, el_max, ppd_lo, lo8, band_lo, band_hi, ppd_hi, hi8,
                    water_top, horizon_el_deg)


def _paint_coast(img, water_top, az_hi, el_hi, ref_az, c: CoastSpec, h_m, r_eff, ppd, sky: SkySpec, ir: bool,
                 seed: int) -> None:
    """Paint one coast into the sharp band (in place) and lower ``water_top`` where it stands."""
    rng = np.random.default_rng(seed)
    a0 = _rel(c.az_from_deg, ref_az)
    span = c.span_deg()
    rel_all = (az_hi - a0) % 360.0
    cols = np.nonzero(rel_all <= span)[0]
    if len(cols) == 0:
        return
    c0, c1 = int(cols[0]), int(cols[-1]) + 1  # the span is contiguous unless it wraps the panorama
    inside = rel_all[c0:c1] <= span
    s = np.where(inside, rel_all[c0:c1] / max(span, 1e-9), 0.0)  # 0..1 across the span
    dist = c.distance_m * (1 + c.distance_slope * (s - 0.5) * 2)
    wl = water_elevation_deg(dist, h_m, r_eff)  # water line elevation per column
    # hills: smooth profile, tapering into the sea at both ends (headlands)
    prof_noise = periodic_noise(1024, 3.0, seed, aspect=1.0)[0]
    hills = c.hill_m * (0.55 + 0.45 * prof_noise[(s * 1023).astype(int)])
    taper = np.clip(np.minimum(s, 1 - s) * span / 3.0, 0, 1) ** 0.7
    hills = hills * taper + 1.5
    drop = dist * dist / (2.0 * r_eff)
    top = np.maximum(np.degrees(np.arctan2(hills - h_m - drop, dist)), wl + 0.02)
    # structures: buildings, towers, cranes (from the shore up)
    n = c1 - c0
    struct_top = np.full(n, -np.inf)
    struct_base = np.full(n, np.inf)
    struct_col = np.full(n, -1, np.int64)
    palette = [(200, 200, 195), (180, 190, 205), (150, 150, 160), (210, 220, 230), (120, 130, 150),
               (70, 90, 160), (220, 215, 205)]
    colours = {}
    for k in range(c.structures):
        centre = rng.uniform(0.08, 0.92)
        rel_w = rng.uniform(8, 60) / (dist.mean() * math.radians(max(span, 1e-3)))  # fraction of the span
        kind = rng.choice(["building", "building", "building", "tower", "crane"])
        hgt = {"building": rng.uniform(6, 30), "tower": rng.uniform(25, 60), "crane": rng.uniform(30, 55)}[kind]
        col = palette[int(rng.integers(len(palette)))]
        if kind != "building":
            rel_w *= 0.25
        sel = inside & (np.abs(s - centre) < rel_w / 2)
        if not sel.any():
            continue
        base = wl[sel] + np.degrees(np.arctan2(2.0, dist[sel]))
        struct_top[sel] = base + np.degrees(np.arctan2(hgt, dist[sel]))
        struct_base[sel] = base
        struct_col[sel] = k
        colours[k] = col
    hi_el = np.maximum(top, np.where(np.isfinite(struct_top), struct_top, -np.inf))
    rows = np.nonzero((el_hi >= wl.min() - 0.01) & (el_hi <= hi_el.max() + 0.01))[0]
    if len(rows) == 0:
        return
    r0, r1 = int(rows[0]), int(rows[-1]) + 1
    E = el_hi[r0:r1, None].astype(np.float32)
    sub = img[r0:r1, c0:c1]
    land = inside[None, :] & (E >= wl[None, :]) & (E <= top[None, :])
    struct = inside[None, :] & (E >= struct_base[None, :]) & (E <= struct_top[None, :])
    tex = periodic_noise(256, 1.6, seed + 5, aspect=1.0)
    t = _sample_tile(tex, np.arange(c0, c1)[None, :], np.arange(r0, r1)[:, None])
    frac = (E - wl[None, :]) / np.maximum(top - wl, 1e-6)[None, :]
    if ir:
        land_v = sky.ir_land + 25 * t - 10 * frac
        sub[..., 0] = np.where(land, land_v, sub[..., 0])
        sub[..., 0] = np.where(struct, sky.ir_land + 30 + 10 * t, sub[..., 0])
    else:
        veg = np.asarray(c.land_bgr, np.float32)
        rock = np.asarray(c.rock_bgr, np.float32)
        haze = np.clip(dist / 12000.0, 0, 0.6).astype(np.float32)[None, :, None]
        hz = np.asarray(sky.horizon_bgr, np.float32)
        col = np.where((frac < 0.12)[..., None], rock, veg) * (0.8 + 0.35 * t[..., None])
        col = col * (1 - haze) + hz * haze
        ys, xs = np.nonzero(land)
        sub[ys, xs] = col[ys, xs]
        ys, xs = np.nonzero(struct)
        if len(ys):
            scol = np.zeros((n, 3), np.float32)
            for k, col_k in colours.items():
                scol[struct_col == k] = col_k
            vals = scol[xs] * (1 - haze[0, xs]) + hz * haze[0, xs]
            # windows: a darker pattern of rows and columns
            win = ((ys + r0) // max(1, int(ppd * 0.02)) % 2 == 0) & ((xs + c0) // max(1, int(ppd * 0.015)) % 3 == 0)
            vals[win] *= 0.6
            sub[ys, xs] = vals
    water_top[c0:c1][inside] = np.minimum(water_top[c0:c1][inside], wl[inside])
