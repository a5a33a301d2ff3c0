"""Numba kernels of the pinhole camera without lens distortion: the projections that the
simulator and the trackers call every frame on a few hundred to a few thousand points, where
NumPy's per-call overhead (a dozen temporaries per call) costs more than the arithmetic.

They compute what :class:`seawatch.camera.model.CameraModel` defines (see its module docstring
for the frames); the model calls them when it has no distortion coefficients.  Results agree with
the NumPy formulas to rounding (the order of the additions in the rotation differs from BLAS').
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def enu_to_pixel_pinhole(e, n, up, R, height_m, inv_2r, fx, fy, cx, cy, u, v, depth):
    """Project ENU points (flat arrays ``e, n, up``, metres) into ``u, v, depth`` (in place).

    ``R`` is the world-from-camera rotation (columns: the camera's axes in ENU), ``inv_2r`` is
    ``1 / (2 R_eff)`` for the curvature drop (0 for none).  Points at or behind the camera
    (depth <= 0) get NaN pixels."""
    for i in range(e.shape[0]):
        ee, nn = e[i], n[i]
        g = math.hypot(ee, nn)
        z_up = up[i] - g * g * inv_2r - height_m
        cx_ = ee * R[0, 0] + nn * R[1, 0] + z_up * R[2, 0]
        cy_ = ee * R[0, 1] + nn * R[1, 1] + z_up * R[2, 1]
        cz_ = ee * R[0, 2] + nn * R[1, 2] + z_up * R[2, 2]
        depth[i] = cz_
        if cz_ > 0:
            u[i] = fx * (cx_ / cz_) + cx
            v[i] = fy * (cy_ / cz_) + cy
        else:
            u[i] = np.nan
            v[i] = np.nan


@numba.njit(cache=True, nogil=True)
def pixel_to_azel_pinhole(u, v, R, fx, fy, cx, cy, az, el):
    """Azimuth (clockwise from north, [0, 360)) and elevation (degrees) of pixels (flat arrays
    ``u, v``) into ``az, el`` (in place)."""
    for i in range(u.shape[0]):
        x = (u[i] - cx) / fx
        y = (v[i] - cy) / fy
        w0 = R[0, 0] * x + R[0, 1] * y + R[0, 2]
        w1 = R[1, 0] * x + R[1, 1] * y + R[1, 2]
        w2 = R[2, 0] * x + R[2, 1] * y + R[2, 2]
        norm = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        az[i] = math.degrees(math.atan2(w0 / norm, w1 / norm)) % 360.0
        s = w2 / norm
        if s > 1.0:
            s = 1.0
        elif s < -1.0:
            s = -1.0
        el[i] = math.degrees(math.asin(s))
