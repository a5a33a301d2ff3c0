"""Numba kernels of the renderer: per-pixel loops that NumPy cannot express in one pass, and the
per-frame geometry of small arrays (view grid, wakes, one vessel) where NumPy's per-call overhead
would dominate."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def _above_water(hi_map, y, x, water_top_y):
    """Whether pixel ``(y, x)`` of the band map ``hi_map`` lies at or above the water's top edge
    (land or sky: not water); the map's panorama column is clamped into ``water_top_y``."""
    nwt = water_top_y.shape[0]
    xi = int(hi_map[y, x, 0])
    if xi < 0:
        xi = 0
    elif xi >= nwt:
        xi = nwt - 1
    return hi_map[y, x, 1] <= water_top_y[xi]


@numba.njit(cache=True, nogil=True, fastmath=True)
def sea_waves(out, r0, maps, tile, gain, glint_col, hi_map, hi_r0, water_top_y):
    """Add the animated wave shading and sun glints to the water pixels of ``out`` (in place).

    Parameters
    ----------
    out : (H, W, C) uint8
        Background image; rows ``r0 .. r0 + maps.shape[0]`` are processed.
    maps : (Hs, W, 4) float32
        Per pixel of those rows: wave-texture coordinates x, y (texels), wave contrast and glint
        strength (both 0: no waves).
    tile : (T, T, 2) uint8
        Wave texture (shade, glint); T a power of two.
    gain, glint_col : (C,) float32
        Per-channel gain of the shading and colour of the glints.
    hi_map : (Hb, W, 2) float32
        Coordinates of image rows ``hi_r0 .. hi_r0 + Hb`` in the sharp horizon panorama; a pixel
        there is water when its row is below ``water_top_y[int(x)]`` (the sea horizon or the coast's
        water line); rows below ``hi_r0 + Hb`` are all water.  ``hi_r0 <= r0``.
    water_top_y : (Wp,) float32
    """
    hs = maps.shape[0]
    w = maps.shape[1]
    c = out.shape[2]
    hb = hi_map.shape[0]
    m = tile.shape[0] - 1
    one = np.float32(1.0)
    half = np.float32(0.5)
    c128 = np.float32(128.0)
    inv = np.float32(1.0 / 255.0)
    for yy in range(hs):
        y = r0 + yy
        for x in range(w):
            a = maps[yy, x, 2]
            g = maps[yy, x, 3]
            if a < 0.004 and g < 0.004:  # invisible (< 1 grey level)
                continue
            yh = y - hi_r0
            if yh < hb:
                if _above_water(hi_map, yh, x, water_top_y):
                    continue
            fx = maps[yy, x, 0]
            fy = maps[yy, x, 1]
            ix = int(np.floor(fx))
            iy = int(np.floor(fy))
            wx = fx - np.float32(ix)
            wy = fy - np.float32(iy)
            x0 = ix & m
            x1 = (ix + 1) & m
            y0 = iy & m
            y1 = (iy + 1) & m
            w00 = (one - wx) * (one - wy)
            w01 = wx * (one - wy)
            w10 = (one - wx) * wy
            w11 = wx * wy
            s = (w00 * np.float32(tile[y0, x0, 0]) + w01 * np.float32(tile[y0, x1, 0])
                 + w10 * np.float32(tile[y1, x0, 0]) + w11 * np.float32(tile[y1, x1, 0]))
            d = (s - c128) * a
            gg = np.float32(0.0)
            if g > 0.0:
                gl = (w00 * np.float32(tile[y0, x0, 1]) + w01 * np.float32(tile[y0, x1, 1])
                      + w10 * np.float32(tile[y1, x0, 1]) + w11 * np.float32(tile[y1, x1, 1]))
                gg = gl * g * inv
            for k in range(c):
                v = np.float32(out[y, x, k]) + d * gain[k] + gg * glint_col[k] + half
                if v < 0.0:
                    v = np.float32(0.0)
                elif v > 255.0:
                    v = np.float32(255.0)
                out[y, x, k] = np.uint8(v)


@numba.njit(cache=True, nogil=True)
def fill_polys(canvas, polys, nvert, colours):
    """Fill convex polygons into ``canvas`` in order (later ones on top).

    A pixel is inside a polygon when its centre (integer coordinates: pixel ``(c, r)`` has its
    centre at ``x = c, y = r``) is: rows ``ymin <= r < ymax`` along each edge, columns
    ``xl <= c < xr``.  Edge crossings are computed from canonically ordered end points, so two
    polygons sharing an edge tile the plane with neither gaps nor overlaps.

    Parameters
    ----------
    canvas : (H, W, C) array (uint8 or float32)
    polys : (F, K, 2) float64
        Vertices ``(x, y)`` in canvas pixel coordinates; polygon ``f`` uses the first ``nvert[f]``.
    nvert : (F,) int64
    colours : (F, C) float64
    """
    h, w, nc = canvas.shape
    for f in range(polys.shape[0]):
        n = nvert[f]
        if n < 3:
            continue
        ymin = polys[f, 0, 1]
        ymax = ymin
        for i in range(1, n):
            y = polys[f, i, 1]
            if y < ymin:
                ymin = y
            if y > ymax:
                ymax = y
        r0 = int(np.ceil(ymin))
        r1 = int(np.ceil(ymax)) - 1
        if r0 < 0:
            r0 = 0
        if r1 > h - 1:
            r1 = h - 1
        for r in range(r0, r1 + 1):
            yc = float(r)
            xl = np.inf
            xr = -np.inf
            for i in range(n):
                ax = polys[f, i, 0]
                ay = polys[f, i, 1]
                j = i + 1
                if j == n:
                    j = 0
                bx = polys[f, j, 0]
                by = polys[f, j, 1]
                if ay > by or (ay == by and ax > bx):  # canonical order
                    ax, ay, bx, by = bx, by, ax, ay
                if ay <= yc < by:
                    x = ax + (yc - ay) * (bx - ax) / (by - ay)
                    if x < xl:
                        xl = x
                    if x > xr:
                        xr = x
            if not xl < xr:
                continue
            c0 = int(np.ceil(xl))
            c1 = int(np.ceil(xr)) - 1
            if c0 < 0:
                c0 = 0
            if c1 > w - 1:
                c1 = w - 1
            for c in range(c0, c1 + 1):
                for k in range(nc):
                    canvas[r, c, k] = colours[f, k]


@numba.njit(cache=True, nogil=True)
def first_water_rows(hi_map, water_top_y):
    """For each column, the first row whose pixel is water (``H`` when none); see :func:`sea_waves`.

    Scans row by row (memory order) and stops once every column has found its water."""
    h = hi_map.shape[0]
    w = hi_map.shape[1]
    out = np.full(w, h, np.int64)
    left = w
    for y in range(h):
        for x in range(w):
            if out[x] < h:
                continue
            if not _above_water(hi_map, y, x, water_top_y):
                out[x] = y
                left -= 1
        if left == 0:
            break
    return out


@numba.njit(cache=True, nogil=True)
def blend_foam(img, y0, x0, alpha, colour, foam, fox):
    """Blend ``colour`` into ``img[y0:, x0:]`` with ``alpha`` (h, w) modulated by a foam texture."""
    h, w = alpha.shape
    nc = img.shape[2]
    fh, fw = foam.shape
    for r in range(h):
        for c in range(w):
            a = alpha[r, c]
            if a <= 0.0:
                continue
            a = a * foam[(y0 + r) % fh, (x0 + c + fox) % fw]
            for k in range(nc):
                v = img[y0 + r, x0 + c, k] * (1.0 - a) + colour[k] * a + 0.5
                img[y0 + r, x0 + c, k] = np.uint8(min(255.0, max(0.0, v)))


@numba.njit(cache=True, nogil=True)
def blend_reflection(img, y0, x0, h, w, canvas, cy0, cx0, a0, top, depth_px, amp, phase):
    """Blend a reflection canvas (ch, cw, C + 1; last channel alpha) into ``img[y0:y0+h, x0:x0+w]``.

    Canvas row ``cy0 + r`` lands on image row ``y0 + r``; alpha fades with the distance below the
    water line (``top``, canvas rows) over ``depth_px``; rows are shifted sideways by a ripple.
    """
    nc = img.shape[2]
    cw = canvas.shape[1]
    for r in range(h):
        rr = cy0 + r
        f = 1.0 - (rr - top) / depth_px
        if f <= 0.0:
            continue
        if f > 1.0:
            f = 1.0
        f = f * np.sqrt(f)
        shift = int(np.round(np.sin(rr * 0.9 + phase) * amp))
        for c in range(w):
            cc = cx0 + c - shift
            if cc < 0 or cc >= cw:
                continue
            a = canvas[rr, cc, nc] * a0 * f
            if a <= 0.0:
                continue
            for k in range(nc):
                v = img[y0 + r, x0 + c, k] * (1.0 - a) + canvas[rr, cc, k] * a + 0.5
                img[y0 + r, x0 + c, k] = np.uint8(min(255.0, max(0.0, v)))


@numba.njit(cache=True, nogil=True, fastmath=True)
def sea_waves_grid(out, r0, grid, step, tile, gain, glint_col, hi_map, hi_r0, water_top_y):
    """:func:`sea_waves` with the per-pixel maps interpolated from a coarse grid on the fly.

    ``grid`` is ``(Gh, Gw, 4)`` float32 (texture x, y, wave contrast, glint strength); sample
    ``(i, j)`` sits at pixel ``((j - 0.5) * step - 0.5, (i - 0.5) * step - 0.5)`` (one sample of
    padding), and pixels take the bilinear interpolation of the four samples around them (what
    ``cv2.resize(INTER_LINEAR)`` of the grid by ``step`` gives).  Rows ``r0 .. H`` are processed.
    """
    h = out.shape[0]
    w = out.shape[1]
    c = out.shape[2]
    gw = grid.shape[1]
    hb = hi_map.shape[0]
    m = tile.shape[0] - 1
    one = np.float32(1.0)
    half = np.float32(0.5)
    c128 = np.float32(128.0)
    inv = np.float32(1.0 / 255.0)
    inv_s = 1.0 / step
    jx = np.empty(w, np.int64)
    wx = np.empty(w, np.float32)
    for x in range(w):
        f = (x + 0.5) * inv_s + 0.5
        jx[x] = int(f)
        wx[x] = f - int(f)
    row = np.empty((gw, 4), np.float32)
    drow = np.empty((gw, 4), np.float32)
    zero = np.float32(0.0)
    c255 = np.float32(255.0)
    g0, g1, g2 = np.float32(gain[0]), np.float32(gain[1 % c]), np.float32(gain[2 % c])
    l0, l1, l2 = np.float32(glint_col[0]), np.float32(glint_col[1 % c]), np.float32(glint_col[2 % c])
    for y in range(r0, h):
        f = (y + 0.5) * inv_s + 0.5
        i = int(f)
        a = np.float32(f - i)
        for j in range(gw):
            for k in range(4):
                row[j, k] = grid[i, j, k] + a * (grid[i + 1, j, k] - grid[i, j, k])
        for j in range(gw - 1):
            for k in range(4):
                drow[j, k] = row[j + 1, k] - row[j, k]
        for x in range(w):
            j = jx[x]
            b = wx[x]
            am = row[j, 2] + b * drow[j, 2]
            g = row[j, 3] + b * drow[j, 3]
            if am < 0.004 and g < 0.004:  # invisible (< 1 grey level)
                continue
            yh = y - hi_r0
            if yh < hb:
                if _above_water(hi_map, yh, x, water_top_y):
                    continue
            fx = row[j, 0] + b * drow[j, 0]
            fy = row[j, 1] + b * drow[j, 1]
            ix = int(np.floor(fx))
            iy = int(np.floor(fy))
            ax = fx - np.float32(ix)
            ay = fy - np.float32(iy)
            x0 = ix & m
            x1 = (ix + 1) & m
            y0 = iy & m
            y1 = (iy + 1) & m
            w00 = (one - ax) * (one - ay)
            w01 = ax * (one - ay)
            w10 = (one - ax) * ay
            w11 = ax * ay
            s = (w00 * np.float32(tile[y0, x0, 0]) + w01 * np.float32(tile[y0, x1, 0])
                 + w10 * np.float32(tile[y1, x0, 0]) + w11 * np.float32(tile[y1, x1, 0]))
            d = (s - c128) * am
            gg = np.float32(0.0)
            if g > 0.0:
                gl = (w00 * np.float32(tile[y0, x0, 1]) + w01 * np.float32(tile[y0, x1, 1])
                      + w10 * np.float32(tile[y1, x0, 1]) + w11 * np.float32(tile[y1, x1, 1]))
                gg = gl * g * inv
            if c == 3:  # unrolled (the common colour case): no loop over a run-time channel count
                v0 = np.float32(out[y, x, 0]) + d * g0 + gg * l0 + half
                v1 = np.float32(out[y, x, 1]) + d * g1 + gg * l1 + half
                v2 = np.float32(out[y, x, 2]) + d * g2 + gg * l2 + half
                out[y, x, 0] = np.uint8(min(max(v0, zero), c255))
                out[y, x, 1] = np.uint8(min(max(v1, zero), c255))
                out[y, x, 2] = np.uint8(min(max(v2, zero), c255))
                continue
            for k in range(c):
                v = np.float32(out[y, x, k]) + d * gain[k] + gg * glint_col[k] + half
                if v < 0.0:
                    v = np.float32(0.0)
                elif v > 255.0:
                    v = np.float32(255.0)
                out[y, x, k] = np.uint8(v)





@numba.njit(cache=True, nogil=True)
def last_dry_row(hi_map, water_top_y):
    """The last row of ``hi_map`` holding a pixel that is not water (see :func:`sea_waves`), or -1:
    every row below it is all water.  Scans from the bottom and stops at the first dry pixel."""
    h = hi_map.shape[0]
    w = hi_map.shape[1]
    for y in range(h - 1, -1, -1):
        for x in range(w):
            if _above_water(hi_map, y, x, water_top_y):
                return y
    return -1


@numba.njit(cache=True, nogil=True, fastmath=True)
def _grid_hrow(grid, i, k, seg, wts, out):
    """Channel ``k`` of grid row ``i`` linearly interpolated at every output column, into ``out``
    (w,): output columns ``seg[j] .. seg[j + 1]`` lie between grid columns ``j`` and ``j + 1``,
    ``wts`` holding the weight of ``j + 1`` (see ``_grid_cols`` in render.py)."""
    for j in range(len(seg) - 1):
        v0 = grid[i, j, k]
        dv = grid[i, j + 1, k] - v0
        for x in range(seg[j], seg[j + 1]):  # (short runs with constant coefficients)
            out[x] = v0 + wts[x] * dv


@numba.njit(cache=True, nogil=True, fastmath=True)
def _grid_vpos(y, step, gh):
    """Grid rows ``(i, i2)`` and the weight of ``i2`` at image row ``y``, grid row ``i`` sitting at
    image row ``(i - 0.5) * step - 0.5`` (``cv2.resize``'s INTER_LINEAR convention of an upscale
    by ``step``, clamped at the grid's ends)."""
    fy = (np.float32(y) + np.float32(0.5)) / np.float32(step) + np.float32(0.5)
    i = int(np.floor(fy))
    b = fy - np.float32(i)
    if i < 0:
        i, b = 0, np.float32(0.0)
    if i >= gh - 1:
        i, b = gh - 1, np.float32(0.0)
    return i, min(i + 1, gh - 1), b


@numba.njit(cache=True, nogil=True, fastmath=True)
def _grid_band(grid, chans, i, i2, seg, wts, top, dif):
    """For each channel ``chans[c]`` of ``grid``: grid rows ``i`` and ``i2`` interpolated at every
    output column, as ``top[c]`` (row ``i``) and ``dif[c]`` (row ``i2`` minus row ``i``): the rows
    between them are ``top + b * dif``."""
    for c in range(len(chans)):
        _grid_hrow(grid, i, chans[c], seg, wts, top[c])
        _grid_hrow(grid, i2, chans[c], seg, wts, dif[c])
        for x in range(top.shape[1]):
            dif[c, x] -= top[c, x]


@numba.njit(cache=True, nogil=True, fastmath=True)
def sea_maps_grid(grid, y0, step, seg, wts, period, out):
    """Wave-texture coordinates of image rows ``y0 .. y0 + n`` interpolated from the sea grid and
    brought into ``[0, period)`` for ``cv2.remap`` (what resizing the grid to the image and
    wrapping them give, without the full-size intermediate; each pair of grid rows is
    interpolated across once, then every image row between them in one pass).

    Parameters
    ----------
    grid : (gh, gw, 4) float32
        Per grid sample: texture x, y, wave contrast, glint strength (rows as :func:`_grid_vpos`).
    y0, step : int
        First image row; grid spacing in rows.
    seg : (gw,) int64, wts : (w,) float32
        Output columns per grid interval and their weights (see :func:`_grid_hrow`).
    period : float
        Texture period (texels).
    out : (n, w, 2) float32, C-contiguous
    """
    n, w = out.shape[0], out.shape[1]
    gh = grid.shape[0]
    p = np.float32(period)
    ip = np.float32(1.0 / period)
    chans = np.array([0, 1])
    top = np.empty((2, w), np.float32)
    dif = np.empty((2, w), np.float32)
    of = out.reshape(n * w * 2)
    cur = -1
    for y in range(n):
        i, i2, b = _grid_vpos(y0 + y, step, gh)
        if i != cur:
            _grid_band(grid, chans, i, i2, seg, wts, top, dif)
            cur = i
        ot = of[2 * w * y:2 * w * (y + 1)]
        for x in range(w):
            u = top[0, x] + b * dif[0, x]
            v = top[1, x] + b * dif[1, x]
            ot[2 * x] = u - p * np.floor(u * ip)
            ot[2 * x + 1] = v - p * np.floor(v * ip)


@numba.njit(cache=True, nogil=True, fastmath=True)
def sea_shade_grid(out, tex, grid, base, y0, step, seg, wts, gain, glint_col):
    """The sea pixels of moving cameras (as :func:`sea_waves_grid`, from the wave texture already
    sampled at every pixel by ``cv2.remap``), with the wave contrast, glint strength and sea base
    colour interpolated from the sea grid (as :func:`sea_maps_grid`), in an element-wise pass
    over contiguous rows (which vectorises).

    Parameters
    ----------
    out : (n, w, C) uint8, C-contiguous
    tex : (n, w, 4) uint8, C-contiguous
        Wave texture (shade, glint, -, -) at the pixels.
    grid, base : (gh, gw, 4) float32
        Sea grid (texture x, y, contrast, glint) and sea base colour (C channels, then padding).
    y0, step, seg, wts
        As :func:`sea_maps_grid`.
    gain, glint_col : (C,) float32
    """
    n, w, c = out.shape
    gh = grid.shape[0]
    half = np.float32(0.5)
    c128 = np.float32(128.0)
    inv = np.float32(1.0 / 255.0)
    zero = np.float32(0.0)
    c255 = np.float32(255.0)
    g0, g1, g2 = np.float32(gain[0]), np.float32(gain[1 % c]), np.float32(gain[2 % c])
    l0, l1, l2 = np.float32(glint_col[0]), np.float32(glint_col[1 % c]), np.float32(glint_col[2 % c])
    pch = np.array([2, 3])
    bch = np.array([0, 1, 2]) if c == 3 else np.array([0])
    ptop = np.empty((2, w), np.float32)
    pdif = np.empty((2, w), np.float32)
    btop = np.empty((3, w), np.float32)
    bdif = np.empty((3, w), np.float32)
    of = out.reshape(n * w * c)
    tf = tex.reshape(n * w * 4)
    cur = -1
    for y in range(n):
        i, i2, b = _grid_vpos(y0 + y, step, gh)
        if i != cur:
            _grid_band(grid, pch, i, i2, seg, wts, ptop, pdif)
            _grid_band(base, bch, i, i2, seg, wts, btop, bdif)
            cur = i
        tt = tf[4 * w * y:4 * w * (y + 1)]
        ot = of[c * w * y:c * w * (y + 1)]
        if c == 3:  # one row as flat slices with constant strides: the loop vectorises
            for x in range(w):
                am = ptop[0, x] + b * pdif[0, x]
                gl = max(ptop[1, x] + b * pdif[1, x], zero) * inv
                d = (np.float32(tt[4 * x]) - c128) * am
                gg = np.float32(tt[4 * x + 1]) * gl
                v0 = btop[0, x] + b * bdif[0, x] + d * g0 + gg * l0 + half
                v1 = btop[1, x] + b * bdif[1, x] + d * g1 + gg * l1 + half
                v2 = btop[2, x] + b * bdif[2, x] + d * g2 + gg * l2 + half
                ot[3 * x] = np.uint8(int(min(max(v0, zero), c255)))
                ot[3 * x + 1] = np.uint8(int(min(max(v1, zero), c255)))
                ot[3 * x + 2] = np.uint8(int(min(max(v2, zero), c255)))
        else:
            for x in range(w):
                am = ptop[0, x] + b * pdif[0, x]
                gl = max(ptop[1, x] + b * pdif[1, x], zero) * inv
                d = (np.float32(tt[4 * x]) - c128) * am
                v = btop[0, x] + b * bdif[0, x] + d * g0 + np.float32(tt[4 * x + 1]) * gl * l0 + half
                ot[x] = np.uint8(int(min(max(v, zero), c255)))


@numba.njit(cache=True, nogil=True)
def view_grid(az, el, ref_az, pano, height_m, r_eff_m, sea, inv, out):
    """Panorama coordinates and sea parameters of the coarse grid samples, in one pass.

    Parameters
    ----------
    az, el : (gh, gw) float64
        Azimuth (clockwise from north) and elevation of the samples, degrees.
    ref_az : float
        The panorama's reference azimuth, degrees.
    pano : (5,) float64
        ``az_min, el_max, band_el_max, ppd_lo, ppd_hi`` of the panorama (degrees, pixels per degree).
    height_m, r_eff_m : float
        Camera height above the sea and effective Earth radius (refraction included).
    sea : (7,) float64
        ``r_a, texel_m, wave_contrast, glint, sun_az_deg, sun_on, waves``: the range where waves
        fade (m), the wave texel (m), the render options' contrast and glint, the sun's azimuth,
        1 when the sun is up, 1 when waves are drawn.
    inv : (2, 2) float64
        Camera ENU -> world ENU (identity when the camera's frame is the world's).
    out : (9, gh, gw) float64
        Written: ``lox, loy`` (coarse panorama), ``hix, hiy`` (sharp band), ``tx, ty`` (wave texels),
        wave contrast, glint strength and the ground range ``r`` (m; NaN above the horizon).
    """
    az_min, el_max, band_el_max, ppd_lo, ppd_hi = pano[0], pano[1], pano[2], pano[3], pano[4]
    r_a, texel, contrast, glint, sun_az, sun_on, waves = sea[0], sea[1], sea[2], sea[3], sea[4], sea[5], sea[6]
    r0 = 1.5 * r_a
    h, R = height_m, r_eff_m
    hR = h + R
    c2 = hR * hR - R * R
    d2r = np.pi / 180.0
    gh, gw = az.shape
    for i in range(gh):
        for j in range(gw):
            a, e = az[i, j], el[i, j]
            a_rel = (a - ref_az + 180.0) % 360.0 - 180.0
            out[0, i, j] = (a_rel - az_min) * ppd_lo - 0.5
            out[1, i, j] = (el_max - e) * ppd_lo - 0.5
            out[2, i, j] = (a_rel - az_min) * ppd_hi - 0.5
            out[3, i, j] = (band_el_max - e) * ppd_hi - 0.5
            # where the ray meets the curved sea (as CameraModel.pixel_to_sea_enu)
            er = e * d2r
            wz = np.sin(er)
            b = wz * hR
            disc = b * b - c2
            r = np.nan
            if disc >= 0:
                t = -b - np.sqrt(disc)
                if t > 0:
                    r = R * np.arctan2(t * np.cos(er), hR + t * wz)
            out[8, i, j] = r
            above = not np.isfinite(r)
            rs = 1e9 if above else r
            rc = rs if rs < r0 else r0 + r0 * (1.0 - r0 / max(rs, r0))
            ar = a * d2r
            ex, ny = rc * np.sin(ar), rc * np.cos(ar)
            ex, ny = inv[0, 0] * ex + inv[0, 1] * ny, inv[1, 0] * ex + inv[1, 1] * ny
            out[4, i, j] = ex / texel
            out[5, i, j] = -ny / texel
            if above or waves == 0.0:
                out[6, i, j] = 0.0
                out[7, i, j] = 0.0
                continue
            q = rs / r_a
            out[6, i, j] = contrast * np.exp(-(q * q)) * (0.35 + 0.65 * np.exp(-rs / 4000))
            daz = (a - sun_az + 180.0) % 360.0 - 180.0
            dq = daz / 18.0
            q2 = rs / (2.5 * r_a)
            out[7, i, j] = glint * (0.12 + np.exp(-(dq * dq)) * sun_on) * np.exp(-(q2 * q2))


@numba.njit(cache=True, nogil=True)
def grid_layouts(g, lut, hw_hi, hh_hi, lo2, hi2, sea4, base, rows):
    """The interleaved float32 grids that a view is built from, out of :func:`view_grid`'s
    output ``g`` (9, gh, gw), in one pass: ``lo2`` and ``hi2`` (gh, gw, 2), the coarse and sharp
    panorama coordinates; ``sea4`` (gh, gw, 4), the wave texels, contrast and glint; ``base``
    (gh, gw, 4), the sea base colour, ``lut`` (rows, C) interpolated at the coarse panorama row
    ``loy`` as ``np.interp`` does (clamped at both ends), its channels after C filled with the
    texel ``tx``; ``rows`` (gh, 4), per grid row: the largest and the smallest sharp-band row
    ``hiy``, 1.0 when every sample lies inside the sharp band (``hw_hi`` x ``hh_hi`` pixels,
    0.05 px of margin, 2.05 at the far edges) else 0.0, and the largest step in wave texels
    between neighbouring samples (``hypot`` of the ``tx``, ``ty`` differences)."""
    gh, gw = g.shape[1], g.shape[2]
    n, C = lut.shape
    for i in range(gh):
        hmax, hmin, step = g[3, i, 0], g[3, i, 0], 0.0
        inside = True
        for j in range(gw):
            hx, hy = g[2, i, j], g[3, i, j]
            hmax = max(hmax, hy)
            hmin = min(hmin, hy)
            if not (hx >= 0.05 and hx <= hw_hi - 2.05 and hy >= 0.05 and hy <= hh_hi - 2.05):
                inside = False
            if j + 1 < gw:
                step = max(step, math.hypot(g[4, i, j + 1] - g[4, i, j], g[5, i, j + 1] - g[5, i, j]))
        rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3] = hmax, hmin, 1.0 if inside else 0.0, step
        for j in range(gw):
            lo2[i, j, 0] = g[0, i, j]
            lo2[i, j, 1] = g[1, i, j]
            hi2[i, j, 0] = g[2, i, j]
            hi2[i, j, 1] = g[3, i, j]
            for k in range(4):
                sea4[i, j, k] = g[4 + k, i, j]
            x = g[1, i, j]
            for k in range(C):
                if x != x:
                    val = np.nan
                elif x >= n - 1:
                    val = np.float64(lut[n - 1, k])
                elif x < 0:
                    val = np.float64(lut[0, k])
                else:
                    jj = int(x)
                    if jj == x:
                        val = np.float64(lut[jj, k])
                    else:
                        y0 = np.float64(lut[jj, k])
                        val = (np.float64(lut[jj + 1, k]) - y0) * (x - jj) + y0
                base[i, j, k] = val
            for k in range(C, 4):
                base[i, j, k] = g[4, i, j]


@numba.njit(cache=True, nogil=True)
def trajectory_states(t, ks, off, ts, es, ns, cs, vs, ws, out):
    """Position, course and speed of vessels ``ks`` at times ``t`` (len(ks), T), as
    :meth:`Trajectory.state`'s scalar path computes them: ``out`` (len(ks), T, 4) gets e, n (m),
    course (deg) and speed (m/s).  Vessel ``k``'s legs are rows ``off[k] .. off[k + 1]`` of the
    packed tables (start time, e, n, course; speed and turn rate of each leg)."""
    d2r = math.pi / 180.0
    for a in range(ks.shape[0]):
        k = ks[a]
        i0, i1 = off[k], off[k + 1]
        for j in range(t.shape[1]):
            tt = t[a, j]
            i = i0  # the last leg starting at or before tt (the first before the start)
            while i + 1 < i1 and ts[i + 1] <= tt:
                i += 1
            dt = tt - ts[i]
            v, wd, c0 = vs[i], ws[i], cs[i]
            if abs(wd) < 1e-9:
                c = c0 * d2r
                out[a, j, 0] = es[i] + v * dt * math.sin(c)
                out[a, j, 1] = ns[i] + v * dt * math.cos(c)
                out[a, j, 2] = c0 % 360.0
            else:
                w = wd * d2r
                a0 = c0 * d2r
                a1 = c0 * d2r + w * dt
                out[a, j, 0] = es[i] + v / w * (math.cos(a0) - math.cos(a1))
                out[a, j, 1] = ns[i] + v / w * (math.sin(a1) - math.sin(a0))
                out[a, j, 2] = (c0 + wd * dt) % 360.0
            out[a, j, 3] = v


@numba.njit(cache=True, nogil=True)
def vessel_poses(st, ids, lengths, t_s, motion, par):
    """Pose parameters of every vessel from its state ``st`` (V, 4) at ``t_s``: ``par`` (13, V)
    gets e, n, the forward and port unit vectors (2 each), cos and sin of roll and of pitch, the
    heave (m), roll and pitch (rad); with ``motion`` the vessels roll, pitch and heave in the
    waves (smaller boats more), else those are 0."""
    d2r = math.pi / 180.0
    two_pi = 2 * math.pi
    for k in range(st.shape[0]):
        c = st[k, 2] * d2r
        roll = pitch = heave = 0.0
        if motion:
            L = lengths[k]
            ph = (ids[k] * 2.399) % two_pi
            small = 1.0 / (1.0 + L / 15.0)
            roll = (5.0 * small * d2r) * math.sin(two_pi * t_s / (3.0 + 0.05 * L) + ph)
            pitch = (2.0 * small * d2r) * math.sin(two_pi * t_s / (2.5 + 0.04 * L) + 2 * ph)
            heave = 0.15 * small * math.sin(two_pi * t_s / 3.1 + 3 * ph)
        par[0, k] = st[k, 0]
        par[1, k] = st[k, 1]
        par[2, k] = math.sin(c)
        par[3, k] = math.cos(c)
        par[4, k] = -math.cos(c)
        par[5, k] = math.sin(c)
        par[6, k] = math.cos(roll)
        par[7, k] = math.sin(roll)
        par[8, k] = math.cos(pitch)
        par[9, k] = math.sin(pitch)
        par[10, k] = heave
        par[11, k] = roll
        par[12, k] = pitch


@numba.njit(cache=True, nogil=True)
def label_boxes(label, labs, fboxes, out):
    """Visible pixels of each drawn vessel: for ``labs[i]`` within its box ``fboxes[i]`` (x0, y0,
    x1, y1) of ``label``, ``out[i]`` gets the count of pixels labelled ``labs[i]`` and the tight
    box (x, y, w, h) around them (what ``cv2.countNonZero`` and ``cv2.boundingRect`` of the mask
    give; the full box when no pixel is left)."""
    for i in range(labs.shape[0]):
        lab = labs[i]
        x0, y0, x1, y1 = fboxes[i, 0], fboxes[i, 1], fboxes[i, 2], fboxes[i, 3]
        n = 0
        bx0, by0, bx1, by1 = x1, y1, x0 - 1, y0 - 1
        for y in range(y0, y1):
            for x in range(x0, x1):
                if label[y, x] == lab:
                    n += 1
                    if x < bx0:
                        bx0 = x
                    if x > bx1:
                        bx1 = x
                    if y < by0:
                        by0 = y
                    by1 = y
        out[i, 0] = n
        if n:
            out[i, 1], out[i, 2], out[i, 3], out[i, 4] = bx0, by0, bx1 - bx0 + 1, by1 - by0 + 1
        else:
            out[i, 1], out[i, 2], out[i, 3], out[i, 4] = x0, y0, x1 - x0, y1 - y0


@numba.njit(cache=True, nogil=True)
def pose_vertices(x, y, z, owner, par, motion, E, N, Z):
    """World positions ``E, N, Z`` of model vertices ``x, y, z`` (vessel frame) of vessels
    ``owner``, posed by :func:`vessel_poses`' ``par``: with ``motion`` rolled about the keel,
    then pitched, then placed at the vessel's position and course and raised by its heave."""
    for i in range(x.shape[0]):
        k = owner[i]
        xi, yi, zi = x[i], y[i], z[i]
        if motion:
            cr, sr, cp, sp = par[6, k], par[7, k], par[8, k], par[9, k]
            yi, zi = yi * cr - zi * sr, yi * sr + zi * cr
            xi, zi = xi * cp - zi * sp, xi * sp + zi * cp
        E[i] = par[0, k] + xi * par[2, k] + yi * par[4, k]
        N[i] = par[1, k] + xi * par[3, k] + yi * par[5, k]
        Z[i] = zi + par[10, k]


@numba.njit(cache=True, nogil=True)
def draw_vessel(img, label, lab, uu, vv, normals, centres, base_cols, shade, face_idx, face_nvert, face_part,
                part_centres, cam_local, sun_local, out):
    """Draw one vessel's faces into a canvas of its own, composite it into ``img`` and write
    ``lab`` into ``label`` where it shows.

    The faces that face the camera are filled (:func:`fill_polys`): the hull first, then the other
    parts far to near, each part's faces in their stored order.  A face's colour is its base colour,
    shaded by the sun when ``shade`` (``base * (0.55 + 0.5 * clip(n . sun, 0, 1))``), rounded and
    kept within 1-255 (the canvas' zeros mark "no vessel").

    Parameters
    ----------
    img : (H, W, C) uint8
    label : (H, W) uint8
    lab : int
        Label value of this vessel.
    uu, vv : (V,) float64
        Projected vertices (pixels).
    normals, centres : (F, 3) float64
        Face normals and centres in the vessel frame.
    base_cols : (F, C) float64
    shade : bool
    face_idx : (F, K) int64; face_nvert, face_part : (F,) int64
    part_centres : (P, 3) float64
    cam_local, sun_local : (3,) float64
        The camera's position and the sun's direction in the vessel frame.
    out : (9,) int64
        Written: ``full_px`` (pixels of the whole silhouette, 0 when nothing shows), the image
        region ``ix0, iy0, ix1, iy1`` and the visible pixels' extent ``bx0, by0, bx1, by1``.
    """
    H, W, C = img.shape
    out[:] = 0
    x0 = int(np.floor(uu.min())) - 1
    y0 = int(np.floor(vv.min())) - 1
    x1 = int(np.ceil(uu.max())) + 2
    y1 = int(np.ceil(vv.max())) + 2
    if x1 - x0 > 2 * W or y1 - y0 > 2 * H:  # cap the canvas of enormous (very near) vessels
        x0, x1 = max(x0, (-W) // 2), min(x1, W + W // 2)
        y0, y1 = max(y0, (-H) // 2), min(y1, H + H // 2)
    cw, ch = x1 - x0, y1 - y0
    if cw <= 0 or ch <= 0:
        return
    F, K = face_idx.shape
    P = part_centres.shape[0]
    # faces towards the camera
    vis = np.empty(F, np.bool_)
    nvis = 0
    for f in range(F):
        d = (normals[f, 0] * (cam_local[0] - centres[f, 0]) + normals[f, 1] * (cam_local[1] - centres[f, 1])
             + normals[f, 2] * (cam_local[2] - centres[f, 2]))
        vis[f] = d > 0
        nvis += vis[f]
    # parts in drawing order: the hull (part 0), then the others far to near (stable)
    neg = np.empty(P)
    for p in range(P):
        dx = part_centres[p, 0] - cam_local[0]
        dy = part_centres[p, 1] - cam_local[1]
        dz = part_centres[p, 2] - cam_local[2]
        neg[p] = -np.sqrt(dx * dx + dy * dy + dz * dz)
    neg[0] = -np.inf
    order = np.argsort(neg, kind="mergesort")
    polys = np.empty((nvis, K, 2))
    nv = np.empty(nvis, np.int64)
    cols = np.empty((nvis, C))
    n = 0
    for r in range(P):
        p = order[r] if P > 1 else 0
        for f in range(F):
            if not vis[f] or face_part[f] != p:
                continue
            for q in range(K):
                polys[n, q, 0] = uu[face_idx[f, q]] - x0
                polys[n, q, 1] = vv[face_idx[f, q]] - y0
            nv[n] = face_nvert[f]
            lam = 1.0
            if shade:
                lam = normals[f, 0] * sun_local[0] + normals[f, 1] * sun_local[1] + normals[f, 2] * sun_local[2]
                lam = min(max(lam, 0.0), 1.0)
                lam = 0.55 + 0.5 * lam
            for k in range(C):
                v = np.round(base_cols[f, k] * lam) if shade else np.round(base_cols[f, k])
                cols[n, k] = min(max(v, 1.0), 255.0)
            n += 1
    canvas = np.zeros((ch, cw, C), np.uint8)
    fill_polys(canvas, polys[:n], nv[:n], cols[:n])
    full = 0
    for y in range(ch):
        for x in range(cw):
            full += canvas[y, x, 0] > 0
    if full == 0:
        return
    ix0, iy0, ix1, iy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if ix1 <= ix0 or iy1 <= iy0:
        return
    bx0, by0, bx1, by1 = ix1, iy1, ix0, iy0
    for y in range(iy0, iy1):
        for x in range(ix0, ix1):
            if canvas[y - y0, x - x0, 0] > 0:
                for k in range(C):
                    img[y, x, k] = canvas[y - y0, x - x0, k]
                label[y, x] = lab
                bx0, by0 = min(bx0, x), min(by0, y)
                bx1, by1 = max(bx1, x + 1), max(by1, y + 1)
    if bx1 <= bx0:
        return
    out[0], out[1], out[2], out[3], out[4] = full, ix0, iy0, ix1, iy1
    out[5], out[6], out[7], out[8] = bx0, by0, bx1, by1


@numba.njit(cache=True, nogil=True)
def _wake_strip(Q, q0, le, ln_, re, rn):
    """Quads ``q0 ..`` of a strip between the left (``le``, ``ln_``) and right (``re``, ``rn``) edges
    (one quad per pair of consecutive samples)."""
    for s in range(le.shape[0] - 1):
        Q[q0 + s, 0, 0], Q[q0 + s, 0, 1] = le[s], ln_[s]
        Q[q0 + s, 1, 0], Q[q0 + s, 1, 1] = le[s + 1], ln_[s + 1]
        Q[q0 + s, 2, 0], Q[q0 + s, 2, 1] = re[s + 1], rn[s + 1]
        Q[q0 + s, 3, 0], Q[q0 + s, 3, 1] = re[s], rn[s]


@numba.njit(cache=True, nogil=True)
def wake_quads(e, n, fx, fy, sp, L, B, tau, decay, Q, al):
    """World quads of the vessels' wakes: the turbulent wake behind the stern, the two Kelvin arms
    spreading from the bow at 19.5 degrees, and the bow wave.

    Parameters
    ----------
    e, n : (V, T) float64
        Each vessel's position ``tau`` seconds ago (ENU metres).
    fx, fy : (V, T) float64
        Sine and cosine of its course then.
    sp, L, B : (V,) float64
        Speed (m/s), length and beam (m).
    tau, decay : (T,) float64
        The ages of the samples (s) and ``exp(-tau / 6)``.
    Q : (V, 3 (T - 1) + 1, 4, 2) float64
        Written: the quads' corners (e, n).
    al : (V, 3 (T - 1) + 1) float64
        Written: the quads' foam opacity.
    """
    V, T = e.shape
    nq = T - 1
    trav = np.empty(T)
    fade = np.empty(T)
    le, ln_, re, rn = np.empty(T), np.empty(T), np.empty(T), np.empty(T)
    be, bn, kel, aw = np.empty(T), np.empty(T), np.empty(T), np.empty(T)
    for v in range(V):
        Lv, Bv = L[v], B[v]
        f7 = min(max(sp[v] / 7.0, 0.2), 0.75)
        for t in range(T):
            trav[t] = sp[v] * tau[t]
            fade[t] = f7 * decay[t]
        # turbulent wake behind the stern
        for t in range(T):
            se = e[v, t] - 0.48 * Lv * fx[v, t]
            sn = n[v, t] - 0.48 * Lv * fy[v, t]
            wt = 0.45 * Bv * np.sqrt(1 + 0.08 * trav[t] / max(Bv, 1.0))
            px, py = -fy[v, t], fx[v, t]
            le[t], ln_[t], re[t], rn[t] = se + px * wt, sn + py * wt, se - px * wt, sn - py * wt
        _wake_strip(Q[v], 0, le, ln_, re, rn)
        for s in range(nq):
            al[v, s] = 0.5 * (fade[s] + fade[s + 1])
        # Kelvin arms
        for t in range(T):
            be[t] = e[v, t] + 0.45 * Lv * fx[v, t]
            bn[t] = n[v, t] + 0.45 * Lv * fy[v, t]
            kel[t] = 0.3536 * (trav[t] + 0.3 * Lv) + 0.3 * Bv  # tan(19.47 deg) = 0.3536
            aw[t] = 0.15 * Bv + 0.03 * trav[t]
        for j in range(2):
            side = -1.0 if j == 0 else 1.0
            for t in range(T):
                spx, spy = side * -fy[v, t], side * fx[v, t]
                ce = be[t] + spx * kel[t]
                cn = bn[t] + spy * kel[t]
                le[t], ln_[t], re[t], rn[t] = ce - spx * aw[t], cn - spy * aw[t], ce + spx * aw[t], cn + spy * aw[t]
            _wake_strip(Q[v], nq * (1 + j), le, ln_, re, rn)
            for s in range(nq):
                al[v, nq * (1 + j) + s] = 0.6 * al[v, s]
        # bow wave
        f0, f1 = fx[v, 0], fy[v, 0]
        p0, p1 = -f1, f0
        b0e, b0n = be[0] + 0.05 * Lv * f0, bn[0] + 0.05 * Lv * f1
        q = 3 * nq
        Q[v, q, 0, 0], Q[v, q, 0, 1] = b0e, b0n
        Q[v, q, 1, 0] = b0e - 0.25 * Lv * f0 + 0.55 * Bv * p0
        Q[v, q, 1, 1] = b0n - 0.25 * Lv * f1 + 0.55 * Bv * p1
        Q[v, q, 2, 0], Q[v, q, 2, 1] = b0e - 0.3 * Lv * f0, b0n - 0.3 * Lv * f1
        Q[v, q, 3, 0] = b0e - 0.25 * Lv * f0 - 0.55 * Bv * p0
        Q[v, q, 3, 1] = b0n - 0.25 * Lv * f1 - 0.55 * Bv * p1
        al[v, q] = min(0.9, 1.2 * fade[0])


@numba.njit(cache=True, nogil=True)
def draw_wake(img, uu, vv, al, ok, colour, foam, fox):
    """Blend one vessel's projected wake quads into ``img`` as foam (:func:`blend_foam`).

    Parameters
    ----------
    uu, vv : (q, 4) float64
        The quads' corners in pixels.
    al : (q,) float64
        Their opacity.
    ok : (q,) bool
        The quads to draw (those wholly in front of the camera).
    colour : (C,) float32
    foam : (fh, fw) float32
        Foam texture, shifted sideways by ``fox`` pixels.
    """
    H, W = img.shape[0], img.shape[1]
    q = 0
    umin, umax, vmin, vmax = np.inf, -np.inf, np.inf, -np.inf
    for i in range(uu.shape[0]):
        if ok[i]:
            q += 1
            for c in range(4):
                umin, umax = min(umin, uu[i, c]), max(umax, uu[i, c])
                vmin, vmax = min(vmin, vv[i, c]), max(vmax, vv[i, c])
    if q == 0:
        return
    x0 = int(max(0, np.floor(umin) - 1))
    y0 = int(max(0, np.floor(vmin) - 1))
    x1 = int(min(W, np.ceil(umax) + 2))
    y1 = int(min(H, np.ceil(vmax) + 2))
    if x1 <= x0 or y1 <= y0:
        return
    polys = np.empty((q, 4, 2))
    cols = np.empty((q, 1))
    n = 0
    for i in range(uu.shape[0]):
        if ok[i]:
            for c in range(4):
                polys[n, c, 0] = uu[i, c] - x0
                polys[n, c, 1] = vv[i, c] - y0
            cols[n, 0] = al[i]
            n += 1
    alpha = np.zeros((y1 - y0, x1 - x0, 1), np.float32)
    fill_polys(alpha, polys, np.full(q, 4, np.int64), cols)
    blend_foam(img, y0, x0, alpha[:, :, 0], colour, foam, fox)


@numba.njit(cache=True, nogil=True)
def draw_reflection(img, mu, mv, face_idx, face_nvert, cols, a0, phase):
    """A vessel's mirror image in the water (:func:`blend_reflection`): its faces filled from the
    mirrored vertices ``mu, mv`` (pixels) with ``cols`` (F, C + 1; colour, then alpha), darkened,
    fading with depth below the water line and rippled.  Nothing is drawn when it lies off the
    image, is enormous (a very near vessel) or less than 5 rows tall."""
    H, W, C = img.shape
    if mu.shape[0] == 0:
        return
    umin, umax, vmin, vmax = mu.min(), mu.max(), mv.min(), mv.max()
    if not (np.isfinite(umin) and np.isfinite(umax) and np.isfinite(vmin) and np.isfinite(vmax)):
        return
    x0, y0 = int(np.floor(umin)) - 1, int(np.floor(vmin)) - 1
    x1, y1 = int(np.ceil(umax)) + 2, int(np.ceil(vmax)) + 2
    ix0, iy0, ix1, iy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if ix1 <= ix0 or iy1 <= iy0 or (x1 - x0) > 4 * W or (y1 - y0) > 4 * H or (y1 - y0) < 5:
        return
    F, K = face_idx.shape
    polys = np.empty((F, K, 2))
    for f in range(F):
        for q in range(K):
            polys[f, q, 0] = mu[face_idx[f, q]] - x0
            polys[f, q, 1] = mv[face_idx[f, q]] - y0
    canvas = np.zeros((y1 - y0, x1 - x0, C + 1), np.float32)
    fill_polys(canvas, polys, face_nvert, cols)
    top = vmin - y0
    depth_px = max(1.0, vmax - vmin)
    amp = min(2.0, 0.05 * (x1 - x0))
    blend_reflection(img, iy0, ix0, iy1 - iy0, ix1 - ix0, canvas, iy0 - y0, ix0 - x0, a0, top, depth_px, amp, phase)
