"""Haar-like features on integral images, evaluated the way OpenCV's cascade detector does.

A feature is up to three weighted rectangles inside the detection window (OpenCV's
``<rects>``: ``x y w h weight``).  Its value on a window is the weighted sum of the pixel sums
of its rectangles times the window's *variance normalisation factor*, exactly as
``cv2.CascadeClassifier`` computes it for current-format (``opencv-cascade-classifier``)
HAAR cascades:

* the normalisation rectangle is the window less a one-pixel border,
  ``(1, 1, W - 2, H - 2)``, of area ``A``;
* ``nf = sqrt(A * sum(I^2) - sum(I)^2)`` over it (``A`` times the standard deviation times
  ``A``), and the factor is ``float32(1 / nf)``;
* a window whose ``nf`` is zero, or whose grey-level standard deviation is 10 or less
  (``A / nf >= 0.1``), is rejected by OpenCV before the first stage: :func:`window_norm`
  reports it as not ``valid``;
* the feature value is ``float32(sum_k w_k * S_k) * factor`` in single precision.

Feature kinds (Lienhart and Maydt's extended set, upright only):

=========  ==================================================  =========
kind       rectangles (x, y, w, h, weight)                      paper A
=========  ==================================================  =========
``x2``     (x, y, 2dx, dy, -1), (x+dx, y, dx, dy, +2)           edge
``y2``     (x, y, dx, 2dy, -1), (x, y+dy, dx, dy, +2)           edge
``x3``     (x, y, 3dx, dy, -1), (x+dx, y, dx, dy, +3)           line
``y3``     (x, y, dx, 3dy, -1), (x, y+dy, dx, dy, +3)           line
``x4``     (x, y, 4dx, dy, -1), (x+dx, y, 2dx, dy, +2)          line
``y4``     (x, y, dx, 4dy, -1), (x, y+dy, dx, 2dy, +2)          line
``x2y2``   (x, y, 2dx, 2dy, -1), (x, y, dx, dy, +2),            diagonal
           (x+dx, y+dy, dx, dy, +2)
``point``  (x, y, 3dx, 3dy, -1), (x+dx, y+dy, dx, dy, +9)       centre-surround
=========  ==================================================  =========

The weights make every feature sum to zero on a flat window, as ``opencv_traincascade`` writes
them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = [
    "FEATURE_KINDS",
    "HaarFeatures",
    "generate_features",
    "integral_images",
    "window_norm",
    "feature_values",
]

FEATURE_KINDS = ("x2", "y2", "x3", "y3", "x4", "y4", "x2y2", "point")

#: OpenCV rejects windows with ``area * factor >= 0.1`` (grey-level standard deviation <= 10).
MIN_WINDOW_STD = 10.0


@dataclass
class HaarFeatures:
    """A set of upright Haar-like features.

    Attributes
    ----------
    rects : (F, 3, 4) int32
        ``x, y, w, h`` of up to three rectangles per feature (unused ones are zero).
    weights : (F, 3) float32
        Rectangle weights (0 for unused rectangles).
    kinds : (F,) int8
        Index into :data:`FEATURE_KINDS`.
    """

    rects: np.ndarray
    weights: np.ndarray
    kinds: np.ndarray

    def __len__(self) -> int:
        return len(self.rects)

    def subset(self, index) -> "HaarFeatures":
        return HaarFeatures(self.rects[index], self.weights[index], self.kinds[index])

    @classmethod
    def concat(cls, parts: list["HaarFeatures"]) -> "HaarFeatures":
        if not parts:
            return cls(np.zeros((0, 3, 4), np.int32), np.zeros((0, 3), np.float32), np.zeros(0, np.int8))
        return cls(
            np.concatenate([p.rects for p in parts]),
            np.concatenate([p.weights for p in parts]),
            np.concatenate([p.kinds for p in parts]),
        )


def _kind_rects(kind: str, x: int, y: int, dx: int, dy: int):
    if kind == "x2":
        return (2 * dx, dy), [(x, y, 2 * dx, dy, -1.0), (x + dx, y, dx, dy, 2.0)]
    if kind == "y2":
        return (dx, 2 * dy), [(x, y, dx, 2 * dy, -1.0), (x, y + dy, dx, dy, 2.0)]
    if kind == "x3":
        return (3 * dx, dy), [(x, y, 3 * dx, dy, -1.0), (x + dx, y, dx, dy, 3.0)]
    if kind == "y3":
        return (dx, 3 * dy), [(x, y, dx, 3 * dy, -1.0), (x, y + dy, dx, dy, 3.0)]
    if kind == "x4":
        return (4 * dx, dy), [(x, y, 4 * dx, dy, -1.0), (x + dx, y, 2 * dx, dy, 2.0)]
    if kind == "y4":
        return (dx, 4 * dy), [(x, y, dx, 4 * dy, -1.0), (x, y + dy, dx, 2 * dy, 2.0)]
    if kind == "x2y2":
        return (2 * dx, 2 * dy), [
            (x, y, 2 * dx, 2 * dy, -1.0), (x, y, dx, dy, 2.0), (x + dx, y + dy, dx, dy, 2.0)
        ]
    if kind == "point":
        return (3 * dx, 3 * dy), [(x, y, 3 * dx, 3 * dy, -1.0), (x + dx, y + dy, dx, dy, 9.0)]
    raise ValueError(f"unknown Haar feature kind {kind!r}; known: {', '.join(FEATURE_KINDS)}")


def generate_features(
    width_px: int = 60,
    height_px: int = 30,
    kinds: tuple[str, ...] = FEATURE_KINDS,
    pos_step_px: int = 1,
    size_step_px: int = 1,
    min_rect_px: int = 1,
) -> HaarFeatures:
    """Every feature of the given kinds that fits in a ``width_px`` x ``height_px`` window.

    Parameters
    ----------
    width_px, height_px : int
        Window size (OpenCV's ``<width>`` and ``<height>``).
    kinds : tuple of str
        Feature kinds, see :data:`FEATURE_KINDS`.
    pos_step_px : int
        Stride of the feature's top-left corner.
    size_step_px : int
        Stride of the unit cell size ``dx, dy`` (sizes ``min_rect_px, min_rect_px + step, ...``).
    min_rect_px : int
        Smallest unit cell side.

    Returns
    -------
    HaarFeatures
    """
    if width_px < 3 or height_px < 3:
        raise ValueError(f"window {width_px}x{height_px} px is too small (at least 3x3)")
    rects, weights, kcode = [], [], []
    for ki, kind in enumerate(kinds):
        _kind_rects(kind, 0, 0, 1, 1)  # validates the name
        for dy in range(min_rect_px, height_px + 1, size_step_px):
            for dx in range(min_rect_px, width_px + 1, size_step_px):
                (fw, fh), _ = _kind_rects(kind, 0, 0, dx, dy)
                if fw > width_px or fh > height_px:
                    continue
                for y in range(0, height_px - fh + 1, pos_step_px):
                    for x in range(0, width_px - fw + 1, pos_step_px):
                        _, rr = _kind_rects(kind, x, y, dx, dy)
                        r = np.zeros((3, 4), np.int32)
                        w = np.zeros(3, np.float32)
                        for i, (rx, ry, rw, rh, wt) in enumerate(rr):
                            r[i] = (rx, ry, rw, rh)
                            w[i] = wt
                        rects.append(r)
                        weights.append(w)
                        kcode.append(ki)
    if not rects:
        return HaarFeatures.concat([])
    return HaarFeatures(
        np.asarray(rects, np.int32), np.asarray(weights, np.float32), np.asarray(kcode, np.int8)
    )


@njit(cache=True)
def _integral_batch(windows, ii):
    n, h, w = windows.shape
    for k in range(n):
        for y in range(h):
            row = 0
            for x in range(w):
                row += np.int32(windows[k, y, x])
                ii[k, y + 1, x + 1] = ii[k, y, x + 1] + row


def integral_images(windows: np.ndarray) -> np.ndarray:
    """Integral images of a stack of windows.

    Parameters
    ----------
    windows : (N, H, W) uint8

    Returns
    -------
    (N, H + 1, W + 1) int32, ``ii[k, y, x]`` = sum of ``windows[k, :y, :x]``.
    """
    windows = np.ascontiguousarray(windows, dtype=np.uint8)
    if windows.ndim != 3:
        raise ValueError(f"windows must be (N, H, W) uint8, got shape {windows.shape}")
    ii = np.zeros((windows.shape[0], windows.shape[1] + 1, windows.shape[2] + 1), np.int32)
    _integral_batch(windows, ii)
    return ii


@njit(cache=True)
def _norm_batch(windows, out_factor, out_valid):
    n, h, w = windows.shape
    area = float((w - 2) * (h - 2))
    for k in range(n):
        s = 0
        sq = 0
        for y in range(1, h - 1):
            for x in range(1, w - 1):
                v = np.int64(windows[k, y, x])
                s += v
                sq += v * v
        nf = area * float(sq) - float(s) * float(s)
        if nf > 0.0:
            f = np.float32(1.0 / np.sqrt(nf))
            out_factor[k] = f
            out_valid[k] = area * float(f) < 0.1
        else:
            out_factor[k] = np.float32(1.0)
            out_valid[k] = False


def window_norm(windows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's variance normalisation factor of each window, and whether OpenCV evaluates it.

    Parameters
    ----------
    windows : (N, H, W) uint8

    Returns
    -------
    factor : (N,) float32
    valid : (N,) bool, False where OpenCV rejects the window before the first stage (flat
        window: grey-level standard deviation over the inner rectangle of 10 or less).
    """
    windows = np.ascontiguousarray(windows, dtype=np.uint8)
    n = windows.shape[0]
    factor = np.empty(n, np.float32)
    valid = np.empty(n, np.bool_)
    _norm_batch(windows, factor, valid)
    return factor, valid


@njit(cache=True)
def _feature_values(ii, factor, rects, weights, out):
    nf = rects.shape[0]
    n = ii.shape[0]
    blk = 32  # a block of windows' integral images stays in cache while every feature visits it
    for k0 in range(0, n, blk):
        k1 = min(n, k0 + blk)
        for f in range(nf):
            for k in range(k0, k1):
                acc = np.float32(0.0)
                for r in range(3):
                    wt = weights[f, r]
                    if wt == 0.0:
                        continue
                    x = rects[f, r, 0]
                    y = rects[f, r, 1]
                    x2 = x + rects[f, r, 2]
                    y2 = y + rects[f, r, 3]
                    s = ii[k, y, x] - ii[k, y, x2] - ii[k, y2, x] + ii[k, y2, x2]
                    acc = acc + wt * np.float32(s)
                out[f, k] = acc * factor[k]


def feature_values(ii: np.ndarray, factor: np.ndarray, features: HaarFeatures) -> np.ndarray:
    """Normalised values of every feature on every window.

    Parameters
    ----------
    ii : (N, H + 1, W + 1) int32
        Integral images (:func:`integral_images`).
    factor : (N,) float32
        Normalisation factors (:func:`window_norm`).
    features : HaarFeatures

    Returns
    -------
    (F, N) float32, feature-major.
    """
    out = np.empty((len(features), ii.shape[0]), np.float32)
    if len(features) and ii.shape[0]:
        _feature_values(
            np.ascontiguousarray(ii, np.int32), np.ascontiguousarray(factor, np.float32),
            np.ascontiguousarray(features.rects, np.int32),
            np.ascontiguousarray(features.weights, np.float32), out,
        )
    return out
