"""A Numba scanner for stump Haar cascades: OpenCV's decisions, the first stages evaluated densely.

``cv2.CascadeClassifier`` evaluates one window at a time, reading every stump's rectangle
corners from scattered places of the integral image. Most of its time goes to the first stages,
which pass most windows (the shipped v6's first three pass 83 %, 66 % and 39 % of the windows it
evaluates). This scanner evaluates the first ``n_dense`` stages *densely*: for each row of window
positions, stump by stump over every position of the row at once, from a copy of the integral
image split by column modulo the grid step, so that the loads are contiguous and vectorised. The
survivors of a row then run the later stages breadth-first, stage by stage, while the row's part
of the integral image is still in the cache.

Decisions, window for window (``tests/test_cascade_scan.py`` checks them against
``detectMultiScale2``):

* the window's variance factor ``1 / sqrt(area * sqsum - sum ** 2)`` over the window less a 1 px
  border, and OpenCV's rejection of windows with too little variance (``area * factor >= 0.1``);
* each stump's value ``(w0 * s0 + w1 * s1 [+ w2 * s2]) * factor`` in float32 from int32 corner
  sums, compared with its split; the stage sum of the leaves in float64, in the stumps' order,
  against the stage threshold less 1e-5 (in float32, as OpenCV stores it);
* on OpenCV's 2 px grid (``step_x`` 2), OpenCV's row rule: a window rejected by the first stage
  makes the scan skip the next position of its row. On a coarser grid in x (``step_x`` 4: a
  window every 4 px in x and 2 px in y) every position is evaluated.

The rows are on the 2 px grid in y. One pyramid level per call; the level images and the grouping
are the detector's (:meth:`seawatch.detect.cascade.CascadeDetector.scan_region_windows`).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from numba import njit

__all__ = ["PackedCascade", "deinterleave"]

THRESHOLD_EPS = np.float32(1e-5)  # OpenCV subtracts it from every stage threshold it reads
PAD = 8  # spare elements after the split copies (no read goes past a row's last position)


class PackedCascade:
    """A stump cascade in flat arrays, and its scanner.

    Parameters
    ----------
    path : str or Path
        A current-format OpenCV HAAR cascade of stumps (as :mod:`seawatch.train` writes them).
    n_dense : int
        How many first stages run densely over every position of a row (default 2; 1 and 2
        were equally fast within the noise on MarDCT training frames, 3 slower; docs/cascade.md).

    Raises
    ------
    FileNotFoundError, ValueError
        When the file is missing or not a stump HAAR cascade (the message names the file).
    """

    def __init__(self, path: str | Path, n_dense: int = 2):
        from seawatch.train.model import read_cascade_xml  # the XML reader is the trainer's

        casc = read_cascade_xml(path)
        self.width_px, self.height_px = int(casc.width_px), int(casc.height_px)
        if not casc.stages:
            raise ValueError(f"{path}: the cascade has no stage")
        counts = [len(s.feature) for s in casc.stages]
        self.start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.thr = np.array([np.float32(s.threshold) - THRESHOLD_EPS for s in casc.stages],
                            np.float32).astype(np.float64)
        feat = np.concatenate([s.feature for s in casc.stages]).astype(np.int64)
        self.split = np.concatenate([s.split for s in casc.stages]).astype(np.float32)
        self.left = np.concatenate([s.left for s in casc.stages]).astype(np.float32).astype(np.float64)
        self.right = np.concatenate([s.right for s in casc.stages]).astype(np.float32).astype(np.float64)
        rects = np.asarray(casc.features.rects, np.int64)[feat]  # (m, 3, 4): x, y, w, h
        weights = np.asarray(casc.features.weights, np.float32)[feat]  # (m, 3)
        # the rectangles with a weight, in their order (OpenCV skips a zero third weight)
        keep = weights != 0.0
        self.nrect = keep.sum(axis=1).astype(np.int64)
        if np.any(self.nrect < 2) or np.any(~keep[:, 0]) or np.any(~keep[:, 1]):
            raise ValueError(f"{path}: a feature whose first two rectangles are not both weighted")
        self.rects = rects
        self.wts = np.where(keep, weights, np.float32(0.0)).astype(np.float32)
        self.n_stages = len(counts)
        self.n_dense = int(min(max(n_dense, 1), self.n_stages))
        self._offsets: dict = {}

    def scan(self, img: np.ndarray, y_lo: int, y_last: int, step_x: int = 2) -> np.ndarray:
        """Accepted windows ``(n, 2)`` as (x, y) of one pyramid level.

        Parameters
        ----------
        img : ndarray
            The level image, uint8 (the rows the windows cover; a view is fine).
        y_lo, y_last : int
            First and last window rows scanned, both even (OpenCV's grid starts at row 0).
        step_x : int
            2 (OpenCV's grid, with its skip after a first-stage reject) or 4 (every position).
        """
        if step_x not in (2, 4):
            raise ValueError(f"step_x must be 2 or 4, got {step_x}")
        if y_lo % 2 or y_last % 2:
            raise ValueError(f"rows must be even, got {y_lo}..{y_last}")
        if img.ndim != 2 or img.dtype != np.uint8:
            raise ValueError(f"a 2-D uint8 level image is needed, got {img.dtype} {img.shape}")
        h, w = img.shape
        ww, wh = self.width_px, self.height_px
        if w < ww or y_last < y_lo or y_lo < 0 or y_last + wh > h:
            return np.zeros((0, 2), np.int64)
        rows, W1 = h + 1, w + 1
        cols = (W1 + step_x - 1) // step_x
        key = (W1, step_x)  # not the height: a level's rows scanned follow the horizon
        tabs = self._offsets.get(key)
        if tabs is None:
            def dcorner(dy, dx):  # in the split copy: row, then part (column modulo step_x), then column
                dx = np.asarray(dx, np.int64)
                return (np.asarray(dy, np.int64) * step_x + dx % step_x) * cols + dx // step_x

            x, y, rw, rh = (self.rects[..., i] for i in range(4))
            off_d = np.stack([dcorner(y, x), dcorner(y, x + rw), dcorner(y + rh, x), dcorner(y + rh, x + rw)], -1)
            off_i = np.stack([y * W1 + x, y * W1 + x + rw, (y + rh) * W1 + x, (y + rh) * W1 + x + rw], -1)
            var_off = np.array([dcorner(1, 1), dcorner(1, ww - 1), dcorner(wh - 1, 1), dcorner(wh - 1, ww - 1)],
                               np.int64)
            tabs = (np.ascontiguousarray(off_d.reshape(-1, 12), np.int64),
                    np.ascontiguousarray(off_i.reshape(-1, 12), np.uint64), var_off)
            if len(self._offsets) > 256:
                self._offsets.clear()
            self._offsets[key] = tabs
        off_d, off_i, var_off = tabs
        ii, sq = cv2.integral2(img, sdepth=cv2.CV_32S, sqdepth=cv2.CV_64F)
        D, _ = deinterleave(ii, step_x)
        Q, _ = deinterleave(sq, step_x)
        I = ii.ravel()
        L = (w - ww) // step_x + 1
        out = np.empty((((y_last - y_lo) // 2 + 1) * L, 2), np.int64)
        n = _scan_level(D, Q, step_x * cols, L, step_x, ww, wh, y_lo, y_last, self.n_dense, var_off, self.start,
                        self.thr, self.nrect, off_d, self.wts, self.split, self.left, self.right, I, W1, off_i, out)
        return out[:n]


def deinterleave(a: np.ndarray, k: int) -> tuple[np.ndarray, int]:
    """A flat copy of the 2-D array ``a`` split by column modulo ``k`` within each row: row 0's
    columns ``0, k, 2k, ...``, then its columns ``1, k + 1, ...``, and so on, then row 1's (each
    part ``cols`` wide, padded with the row's last value), followed by ``PAD`` zeros; and
    ``cols``. A corner's offset from a window's then depends on the width only, not the height."""
    rows, n = a.shape
    cols = (n + k - 1) // k
    flat = np.empty(k * rows * cols + PAD, a.dtype)
    flat[k * rows * cols:] = 0
    parts = flat[: k * rows * cols].reshape(rows, k, cols)
    for r in range(k):
        m = len(range(r, n, k))
        parts[:, r, :m] = a[:, r::k]
        if m < cols:
            parts[:, r, m:] = a[:, -1:]
    return flat, cols


@njit(cache=True, boundscheck=False, nogil=True, inline="always")
def _rect(a, b, c, d, x):
    return np.float32(np.int32(a[x] - b[x] - c[x] + d[x]))  # int32 as OpenCV; it also vectorises


@njit(cache=True, boundscheck=False, nogil=True)
def _dense_stump(D, row, L, off, j, w0, w1, w2, three, sp, lf, rt, fac, acc):
    """Add stump ``j``'s leaf to ``acc`` for the ``L`` positions of a row (row offset ``row``).
    The corner arrays are slices, so that the compiler sees contiguous loads."""
    a0 = D[row + off[j, 0]:]; a1 = D[row + off[j, 1]:]; a2 = D[row + off[j, 2]:]; a3 = D[row + off[j, 3]:]
    a4 = D[row + off[j, 4]:]; a5 = D[row + off[j, 5]:]; a6 = D[row + off[j, 6]:]; a7 = D[row + off[j, 7]:]
    if three:
        a8 = D[row + off[j, 8]:]; a9 = D[row + off[j, 9]:]; a10 = D[row + off[j, 10]:]; a11 = D[row + off[j, 11]:]
        for x in range(L):
            v = w0 * _rect(a0, a1, a2, a3, x)
            v = v + w1 * _rect(a4, a5, a6, a7, x)
            v = v + w2 * _rect(a8, a9, a10, a11, x)
            acc[x] += lf if v * fac[x] < sp else rt
    else:
        for x in range(L):
            v = w0 * _rect(a0, a1, a2, a3, x)
            v = v + w1 * _rect(a4, a5, a6, a7, x)
            acc[x] += lf if v * fac[x] < sp else rt


@njit(cache=True, boundscheck=False, nogil=True)
def _scan_level(D, Q, rstride, L, step_x, win_w, win_h, y_lo, y_last, n_dense, var_off, start, thr, nrect, off,
                wts, split, left, right, I, stride, off_i, out):
    """Accepted windows of one level: their number, their (x, y) in ``out``.

    ``D`` / ``Q``: the split int32 / float64 integral images (``rstride`` per row); ``L``
    positions per row, ``step_x`` px apart; rows ``y_lo`` to ``y_last`` every 2 px; the first
    ``n_dense`` stages dense per row; then the survivors of the row breadth-first, reading the
    integral image itself (``I``, flat, ``stride`` per row; corner offsets ``off_i``).
    """
    area = float((win_w - 2) * (win_h - 2))
    fac = np.empty(L, np.float32)
    ok = np.empty(L, np.bool_)
    acc = np.empty(L, np.float64)
    depth = np.empty(L, np.int64)
    rb = np.empty(L, np.uint64)
    rf = np.empty(L, np.float32)
    racc = np.empty(L, np.float64)
    skip = 1 if step_x == 2 else 0  # OpenCV's skip after a first-stage reject, on its grid only
    n = 0
    for oy in range(y_lo, y_last + 1, 2):
        row = oy * rstride
        s1 = D[row + var_off[0]:]; s2 = D[row + var_off[1]:]; s3 = D[row + var_off[2]:]; s4 = D[row + var_off[3]:]
        q1 = Q[row + var_off[0]:]; q2 = Q[row + var_off[1]:]; q3 = Q[row + var_off[2]:]; q4 = Q[row + var_off[3]:]
        for x in range(L):  # the variance factor, branch-free so that it vectorises
            s = float(np.int32(s1[x] - s2[x] - s3[x] + s4[x]))
            q = q1[x] - q2[x] - q3[x] + q4[x]
            nf = area * q - s * s
            pos = nf > 0.0
            f = np.float32(1.0 / np.sqrt(max(nf, 1e-300)))
            f = f if pos else np.float32(1.0)
            fac[x] = f
            ok[x] = pos and area * float(f) < 0.1
            depth[x] = 0
        for st in range(n_dense):  # depth: the number of stages passed in a row
            for x in range(L):
                acc[x] = 0.0
            for j in range(start[st], start[st + 1]):
                _dense_stump(D, row, L, off, j, wts[j, 0], wts[j, 1], wts[j, 2], nrect[j] == 3,
                             split[j], left[j], right[j], fac, acc)
            t = thr[st]
            alive = 0
            for x in range(L):
                if depth[x] == st and acc[x] >= t:
                    depth[x] = st + 1
                    alive += 1
            if alive == 0:
                break
        m = 0
        x = 0
        while x < L:  # the row walk
            if not ok[x]:
                x += 1
                continue
            if depth[x] == 0:
                x += 1 + skip
                continue
            if depth[x] == n_dense:
                rb[m] = np.uint64(oy * stride + step_x * x)
                rf[m] = fac[x]
                m += 1
            x += 1
        for st in range(n_dense, thr.shape[0]):  # the later stages over the row's survivors
            if m == 0:
                break
            for i in range(m):
                racc[i] = 0.0
            for j in range(start[st], start[st + 1]):
                o = off_i[j]
                o0 = o[0]; o1 = o[1]; o2 = o[2]; o3 = o[3]; o4 = o[4]; o5 = o[5]; o6 = o[6]; o7 = o[7]
                w0 = wts[j, 0]; w1 = wts[j, 1]; sp = split[j]; lf = left[j]; rt = right[j]
                if nrect[j] == 3:
                    o8 = o[8]; o9 = o[9]; o10 = o[10]; o11 = o[11]; w2 = wts[j, 2]
                    for i in range(m):
                        p = rb[i]
                        v = w0 * np.float32(np.int32(I[p + o0] - I[p + o1] - I[p + o2] + I[p + o3]))
                        v = v + w1 * np.float32(np.int32(I[p + o4] - I[p + o5] - I[p + o6] + I[p + o7]))
                        v = v + w2 * np.float32(np.int32(I[p + o8] - I[p + o9] - I[p + o10] + I[p + o11]))
                        racc[i] += lf if v * rf[i] < sp else rt
                else:
                    for i in range(m):
                        p = rb[i]
                        v = w0 * np.float32(np.int32(I[p + o0] - I[p + o1] - I[p + o2] + I[p + o3]))
                        v = v + w1 * np.float32(np.int32(I[p + o4] - I[p + o5] - I[p + o6] + I[p + o7]))
                        racc[i] += lf if v * rf[i] < sp else rt
            t = thr[st]
            k = 0
            for i in range(m):
                if racc[i] >= t:
                    rb[k] = rb[i]
                    rf[k] = rf[i]
                    k += 1
            m = k
        for i in range(m):
            out[n, 0] = rb[i] % np.uint64(stride)
            out[n, 1] = rb[i] // np.uint64(stride)
            n += 1
    return n
