"""Numba kernels of the renderer (per-pixel loops that NumPy cannot express in one pass)."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, fastmath=True)
def sea_waves(out, r0, tx, ty, amp, glint, tile, ox, oy, gain, glint_col):
    """Add the animated wave shading and sun glints to the water pixels of ``out`` (in place).

    Parameters
    ----------
    out : (H, W, C) uint8
        Background image; rows ``r0 .. r0 + tx.shape[0]`` are processed.
    tx, ty : (Hs, W) float32
        Wave-texture coordinates (texels) of those rows.
    amp, glint : (Hs, W) float32
        Wave contrast and glint strength; both 0 where there is no water (pixel skipped).
    tile : (T, T, 2) uint8
        Wave texture (shade, glint); T a power of two.
    ox, oy : float
        Texture drift (texels).
    gain, glint_col : (C,) float32
        Per-channel gain of the shading and colour of the glints.
    """
    hs, w = tx.shape
    c = out.shape[2]
    m = tile.shape[0] - 1
    oxf = np.float32(ox)
    oyf = np.float32(oy)
    one = np.float32(1.0)
    half = np.float32(0.5)
    c128 = np.float32(128.0)
    inv = np.float32(1.0 / 255.0)
    for yy in range(hs):
        y = r0 + yy
        for x in range(w):
            a = amp[yy, x]
            g = glint[yy, x]
            if a <= 0.0 and g <= 0.0:
                continue
            fx = tx[yy, x] + oxf
            fy = ty[yy, x] + oyf
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
