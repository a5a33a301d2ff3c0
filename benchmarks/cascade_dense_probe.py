"""Probe (session 18, issue #4): dense evaluation of a cascade's first stages, exact to OpenCV.

``cv2.CascadeClassifier`` evaluates one window at a time. v6's first three stages pass 83 %,
66 % and 39 % of the windows it evaluates and are 45 % of its stump evaluations, so this probe
evaluates the first ``n_dense`` stages *densely*: for each row of window positions on the 2 px
grid, stump by stump over every position at once, from an integral image split into its even
and odd columns so that the loads are contiguous and vectorised (int32 corner sums, as OpenCV;
about 0.9 ns per stump and position in a micro-benchmark, against about 6 ns per stump and
window for OpenCV). The later stages run one window at a time over the survivors
(``scan_level``), or a whole block of 8 positions at a time wherever a block holds a live window
(``scan_level_blocks``, ``--n-dense 0``). The decisions are OpenCV's: the raw windows equal
``detectMultiScale2``'s on every frame checked (variance factor, float32 stump values, float64
stage sums, thresholds less 1e-5f, the skip after a first-stage reject).

It is not used by the detector: on one 480x393 level of 11 MarDCT training frames it ran at
0.65-1.2 times OpenCV's speed (see docs/cascade.md, "Session 18"), far from the 1.5-2x that v6 at
its own settings (1.1 / 16 / 0) would need for 50 frames/s. Training frames only.

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/cascade_dense_probe.py --data ../shared/data --n-dense 3
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numba import njit

__all__ = ["PackedCascade", "scan_level"]

THRESHOLD_EPS = 1e-5  # OpenCV subtracts it from every stage threshold when it reads a cascade


class PackedCascade:
    """A stump cascade in flat arrays, with the rectangle offsets for a given integral stride.

    Parameters
    ----------
    path : str or Path
        A current-format OpenCV HAAR cascade of stumps (as the trainer writes them).
    n_dense : int
        How many first stages are evaluated densely (over every column of a row).
    """

    def __init__(self, path: str | Path, n_dense: int = 3):
        from seawatch.train.model import read_cascade_xml  # the XML reader is the trainer's

        casc = read_cascade_xml(path)
        self.width_px, self.height_px = int(casc.width_px), int(casc.height_px)
        if not casc.stages:
            raise ValueError(f"{path}: the cascade has no stage")
        counts = [len(s.feature) for s in casc.stages]
        self.start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        # OpenCV keeps the threshold as a float: (float)threshold - 1e-5f
        self.thr = np.array([np.float32(s.threshold) - np.float32(THRESHOLD_EPS) for s in casc.stages],
                            np.float32).astype(np.float64)
        feat = np.concatenate([s.feature for s in casc.stages]).astype(np.int64)
        self.split = np.concatenate([s.split for s in casc.stages]).astype(np.float32)
        self.left = np.concatenate([s.left for s in casc.stages]).astype(np.float32).astype(np.float64)
        self.right = np.concatenate([s.right for s in casc.stages]).astype(np.float32).astype(np.float64)
        rects = np.asarray(casc.features.rects, np.int64)[feat]  # (m, 3, 4): x, y, w, h
        weights = np.asarray(casc.features.weights, np.float32)[feat]  # (m, 3)
        m = len(feat)
        # rectangles with a non-zero weight, packed to the front (OpenCV reads them in order)
        self.nrect = np.zeros(m, np.int64)
        self.rects = np.zeros((m, 3, 4), np.int64)
        self.wts = np.zeros((m, 3), np.float32)
        for j in range(m):
            k = 0
            for r in range(3):
                if weights[j, r] != 0.0:
                    self.rects[j, k] = rects[j, r]
                    self.wts[j, k] = weights[j, r]
                    k += 1
            self.nrect[j] = k
        if np.any(self.nrect < 2):
            raise ValueError(f"{path}: a feature with fewer than two weighted rectangles")
        self.n_stages = len(counts)
        self.n_dense = int(min(max(n_dense, 0), self.n_stages))
        self._offsets: dict[int, np.ndarray] = {}

    def offsets(self, rows: int, cols: int) -> np.ndarray:
        """(m, 12) offsets of each stump's rectangle corners in the de-interleaved integral image
        (see :func:`deinterleave`) of ``rows`` x ``cols`` columns per half, from a window's corner."""
        key = (rows, cols)
        off = self._offsets.get(key)
        if off is None:
            x, y, w, h = (self.rects[..., i] for i in range(4))
            off = np.stack([_corner(y, x, rows, cols), _corner(y, x + w, rows, cols),
                            _corner(y + h, x, rows, cols), _corner(y + h, x + w, rows, cols)],
                           axis=-1).reshape(len(self.rects), 12)
            off = np.ascontiguousarray(off, np.int64)
            if len(self._offsets) > 64:
                self._offsets.clear()
            self._offsets[key] = off
        return off

    def offsets_flat(self, stride: int) -> np.ndarray:
        """(m, 12) offsets of each stump's rectangle corners in the integral image itself (row
        stride ``stride``), for the windows evaluated one at a time."""
        off = self._offsets.get(stride)
        if off is None:
            x, y, w, h = (self.rects[..., i] for i in range(4))
            off = np.stack([y * stride + x, y * stride + x + w, (y + h) * stride + x,
                            (y + h) * stride + x + w], axis=-1).reshape(len(self.rects), 12)
            off = np.ascontiguousarray(off, np.uint64)
            self._offsets[stride] = off
        return off

    def scan(self, ii: np.ndarray, sq: np.ndarray, y_lo: int, y_last: int) -> np.ndarray:
        """Accepted windows ``(n, 2)`` as (x, y) of one level, rows ``y_lo`` to ``y_last``
        (both on the 2 px grid), from its integral images (``cv2.integral2``: int32 sums,
        float64 squared sums)."""
        W = ii.shape[1] - 1
        if W < self.width_px or y_last < y_lo:
            return np.zeros((0, 2), np.int64)
        d_ii, d_sq = deinterleave(ii), deinterleave(sq)
        rows, cols = ii.shape[0], (ii.shape[1] + 1) // 2
        ny = (y_last - y_lo) // 2 + 1
        nx = (W - self.width_px) // 2 + 1
        out = np.empty((ny * nx, 2), np.int64)
        ww, wh = self.width_px, self.height_px
        var_off = np.array([_corner(1, 1, rows, cols), _corner(1, ww - 1, rows, cols),
                            _corner(wh - 1, 1, rows, cols), _corner(wh - 1, ww - 1, rows, cols)], np.int64)
        if self.n_dense <= 0:
            n = scan_level_blocks(d_ii, d_sq, cols, nx, ww, wh, y_lo, y_last, var_off, self.start, self.thr,
                                  self.nrect, self.offsets(rows, cols), self.wts, self.split, self.left,
                                  self.right, out)
        else:
            n = scan_level(d_ii, d_sq, cols, nx, ww, wh, y_lo, y_last, self.n_dense, var_off,
                           self.start, self.thr, self.nrect, self.offsets(rows, cols), self.wts, self.split,
                           self.left, self.right, ii.ravel(), self.offsets_flat(W + 1), out)
        return out[:n]


def _corner(dy, dx, rows: int, cols: int):
    """Offset of the integral image's point (dy, dx) from a window's corner at an even column,
    in the de-interleaved layout: even columns first, then odd ones, ``cols`` per row."""
    dx = np.asarray(dx, np.int64)
    return (dx & 1) * rows * cols + np.asarray(dy, np.int64) * cols + (dx >> 1)


def deinterleave(a: np.ndarray) -> np.ndarray:
    """``(2, rows, cols)``: the even columns of ``a``, then its odd columns (padded with the
    last), so that windows on a 2 px grid read each rectangle corner from consecutive memory."""
    rows, n = a.shape
    cols = (n + 1) // 2
    flat = np.zeros(2 * rows * cols + 2 * BLOCK, a.dtype)  # padded: whole blocks read past a row's end
    out = flat[: 2 * rows * cols].reshape(2, rows, cols)
    out[0] = a[:, 0::2]
    out[1, :, : n // 2] = a[:, 1::2]
    if n % 2:
        out[1, :, -1] = a[:, -1]
    return flat


@njit(cache=True, boundscheck=False, nogil=True, inline="always")
def _rect(a, b, c, d, x):
    return np.float32(np.int32(a[x] - b[x] - c[x] + d[x]))


@njit(cache=True, boundscheck=False, nogil=True)
def _dense_stump(D, row, L, off, j, w0, w1, w2, three, sp, lf, rt, fac, acc):
    """Add one stump's leaf to ``acc`` for the ``L`` windows of a row (row offset ``row``).
    The corner arrays are slices, so that the loads are contiguous and vectorised."""
    a0 = D[row + off[j, 0]:]; a1 = D[row + off[j, 1]:]; a2 = D[row + off[j, 2]:]; a3 = D[row + off[j, 3]:]
    a4 = D[row + off[j, 4]:]; a5 = D[row + off[j, 5]:]; a6 = D[row + off[j, 6]:]; a7 = D[row + off[j, 7]:]
    if three:
        a8 = D[row + off[j, 8]:]; a9 = D[row + off[j, 9]:]; a10 = D[row + off[j, 10]:]; a11 = D[row + off[j, 11]:]
        for x in range(L):
            v = w0 * _rect(a0, a1, a2, a3, x)
            v = v + w1 * _rect(a4, a5, a6, a7, x)
            v = v + w2 * _rect(a8, a9, a10, a11, x)
            v = v * fac[x]
            acc[x] += lf if v < sp else rt
    else:
        for x in range(L):
            v = w0 * _rect(a0, a1, a2, a3, x)
            v = v + w1 * _rect(a4, a5, a6, a7, x)
            v = v * fac[x]
            acc[x] += lf if v < sp else rt


@njit(cache=True, boundscheck=False, nogil=True)
def scan_level(D, Q, cols, L, win_w, win_h, y_lo, y_last, n_dense, var_off, start, thr, nrect, off, wts,
               split, left, right, I, off_i, out):
    """Accepted windows of one level on the 2 px grid; their number, their (x, y) in ``out``.

    ``D`` / ``Q``: the de-interleaved int32 / float64 integral images (flat, ``cols`` per row);
    ``L`` window positions per row; rows ``y_lo`` to ``y_last`` (even offsets from 0, as OpenCV's
    grid); the first ``n_dense`` stages dense per row, the rest breadth-first over the survivors,
    which read the integral image itself (``I``, flat, with the corner offsets ``off_i``): a
    window's corners lie closer together there than in the de-interleaved copy.
    """
    stride = I.shape[0] // ((D.shape[0] - 2 * BLOCK) // (2 * cols))
    area = float((win_w - 2) * (win_h - 2))
    fac = np.empty(L, np.float32)
    ok = np.empty(L, np.bool_)
    acc = np.empty(L, np.float64)
    depth = np.empty(L, np.int64)
    rb = np.empty(L, np.uint64)
    rf = np.empty(L, np.float32)
    racc = np.empty(L, np.float64)
    n = 0
    for oy in range(y_lo, y_last + 1, 2):
        row = oy * cols
        # the variance factor of every position
        s1 = D[row + var_off[0]:]; s2 = D[row + var_off[1]:]; s3 = D[row + var_off[2]:]; s4 = D[row + var_off[3]:]
        q1 = Q[row + var_off[0]:]; q2 = Q[row + var_off[1]:]; q3 = Q[row + var_off[2]:]; q4 = Q[row + var_off[3]:]
        for x in range(L):  # branch-free, so that it vectorises
            s = float(np.int32(s1[x] - s2[x] - s3[x] + s4[x]))
            q = q1[x] - q2[x] - q3[x] + q4[x]
            nf = area * q - s * s
            pos = nf > 0.0
            f = np.float32(1.0 / np.sqrt(max(nf, 1e-300)))
            f = f if pos else np.float32(1.0)
            fac[x] = f
            ok[x] = pos and area * float(f) < 0.1  # OpenCV: enough variance
            depth[x] = 0
        # the first stages, dense; depth = the number of stages passed in a row
        for st in range(n_dense):
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
        # OpenCV's row walk: skip the next position after a first-stage reject
        m = 0
        x = 0
        while x < L:
            if not ok[x]:
                x += 1
                continue
            if depth[x] == 0:
                x += 2
                continue
            if depth[x] == n_dense:
                rb[m] = np.uint64(oy * stride + 2 * x)
                rf[m] = fac[x]
                m += 1
            x += 1
        # the later stages, breadth-first over the row's survivors (their corners stay in the cache)
        for st in range(n_dense, thr.shape[0]):
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
            out[n, 0] = rb[i] % stride
            out[n, 1] = rb[i] // stride
            n += 1
    return n


@njit(cache=True, boundscheck=False, nogil=True)
def _later_stages(I, p, f, first, start, thr, nrect, off_i, wts, split, left, right):
    """Whether the window at ``p`` of the flat integral image passes the stages from ``first`` on,
    one window at a time (its corners stay in the cache from stump to stump). Unsigned indices:
    no negative-index wrap-around test per load."""
    up = np.uint64(p)
    for st in range(first, thr.shape[0]):
        acc = 0.0
        for j in range(start[st], start[st + 1]):
            o = off_i[j]
            v = wts[j, 0] * np.float32(np.int32(I[up + o[0]] - I[up + o[1]] - I[up + o[2]] + I[up + o[3]]))
            v = v + wts[j, 1] * np.float32(np.int32(I[up + o[4]] - I[up + o[5]] - I[up + o[6]] + I[up + o[7]]))
            if nrect[j] == 3:
                v = v + wts[j, 2] * np.float32(np.int32(I[up + o[8]] - I[up + o[9]] - I[up + o[10]] + I[up + o[11]]))
            v = v * f
            acc += left[j] if v < split[j] else right[j]
        if acc < thr[st]:
            return False
    return True


BLOCK = 8  # window positions evaluated together (one vector of float32)


@njit(cache=True, boundscheck=False, nogil=True)
def scan_level_blocks(D, Q, cols, L, win_w, win_h, y_lo, y_last, var_off, start, thr, nrect, off, wts,
                      split, left, right, out):
    """Accepted windows of one level on the 2 px grid; their number, their (x, y) in ``out``.

    Every stage runs over the blocks of ``BLOCK`` consecutive positions of a row that still hold
    a live window, a whole block at a time (the loads are contiguous and vectorised); windows
    already rejected in a live block are computed and ignored. ``D`` / ``Q``: the de-interleaved
    int32 / float64 integral images (flat, ``cols`` per row, padded at the end by ``BLOCK``).
    """
    area = float((win_w - 2) * (win_h - 2))
    nb = (L + BLOCK - 1) // BLOCK
    Lp = nb * BLOCK
    fac = np.ones(Lp, np.float32)
    alive = np.zeros(Lp, np.bool_)
    acc = np.zeros(Lp, np.float64)
    blocks = np.empty(nb, np.int64)
    n = 0
    for oy in range(y_lo, y_last + 1, 2):
        row = oy * cols
        s1 = D[row + var_off[0]:]; s2 = D[row + var_off[1]:]; s3 = D[row + var_off[2]:]; s4 = D[row + var_off[3]:]
        q1 = Q[row + var_off[0]:]; q2 = Q[row + var_off[1]:]; q3 = Q[row + var_off[2]:]; q4 = Q[row + var_off[3]:]
        for x in range(L):
            s = float(np.int32(s1[x] - s2[x] - s3[x] + s4[x]))
            q = q1[x] - q2[x] - q3[x] + q4[x]
            nf = area * q - s * s
            if nf > 0.0:
                f = np.float32(1.0 / np.sqrt(nf))
                fac[x] = f
                alive[x] = area * float(f) < 0.1  # OpenCV: enough variance
            else:
                fac[x] = np.float32(1.0)
                alive[x] = False
        for st in range(thr.shape[0]):
            nact = 0
            for b in range(nb):
                x0 = b * BLOCK
                for x in range(x0, x0 + BLOCK):
                    if alive[x]:
                        blocks[nact] = x0
                        nact += 1
                        break
            if nact == 0:
                break
            for k in range(nact):
                x0 = blocks[k]
                for x in range(x0, x0 + BLOCK):
                    acc[x] = 0.0
            for j in range(start[st], start[st + 1]):
                a0 = D[row + off[j, 0]:]; a1 = D[row + off[j, 1]:]; a2 = D[row + off[j, 2]:]; a3 = D[row + off[j, 3]:]
                a4 = D[row + off[j, 4]:]; a5 = D[row + off[j, 5]:]; a6 = D[row + off[j, 6]:]; a7 = D[row + off[j, 7]:]
                w0 = wts[j, 0]; w1 = wts[j, 1]; sp = split[j]; lf = left[j]; rt = right[j]
                if nrect[j] == 3:
                    a8 = D[row + off[j, 8]:]; a9 = D[row + off[j, 9]:]; a10 = D[row + off[j, 10]:]; a11 = D[row + off[j, 11]:]
                    w2 = wts[j, 2]
                    for k in range(nact):
                        x0 = blocks[k]
                        for x in range(x0, x0 + BLOCK):
                            v = w0 * _rect(a0, a1, a2, a3, x)
                            v = v + w1 * _rect(a4, a5, a6, a7, x)
                            v = v + w2 * _rect(a8, a9, a10, a11, x)
                            v = v * fac[x]
                            acc[x] += lf if v < sp else rt
                else:
                    for k in range(nact):
                        x0 = blocks[k]
                        for x in range(x0, x0 + BLOCK):
                            v = w0 * _rect(a0, a1, a2, a3, x)
                            v = v + w1 * _rect(a4, a5, a6, a7, x)
                            v = v * fac[x]
                            acc[x] += lf if v < sp else rt
            t = thr[st]
            if st == 0:
                # OpenCV's row walk: a first-stage reject skips the next position
                x = 0
                while x < L:
                    if not alive[x]:
                        x += 1
                        continue
                    if acc[x] < t:
                        alive[x] = False
                        if x + 1 < L:
                            alive[x + 1] = False
                        x += 2
                        continue
                    x += 1
            else:
                for k in range(nact):
                    x0 = blocks[k]
                    for x in range(x0, x0 + BLOCK):
                        if acc[x] < t:
                            alive[x] = False
        for x in range(L):
            if alive[x]:
                out[n, 0] = 2 * x
                out[n, 1] = oy
                n += 1
    return n


def main(argv=None) -> int:
    import argparse
    import glob
    import time

    import cv2

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--model", default="seawatch/models/boat_cascade_v6.xml")
    ap.add_argument("--n-dense", type=int, default=3, help="stages evaluated densely (0: blocks of 8 for all)")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args(argv)
    cv2.setNumThreads(1)
    pc = PackedCascade(a.model, n_dense=a.n_dense)
    clf = cv2.CascadeClassifier(a.model)
    fs = sorted(glob.glob(f"{a.data}/mardct/train/frames/*.png"))[::12]
    if not fs:
        raise SystemExit(f"no MarDCT training frames under {a.data}/mardct/train/frames")
    ww, wh = pc.width_px, pc.height_px
    tn, to, same = [], [], 0
    for f in fs:
        img = cv2.resize(cv2.imread(f, cv2.IMREAD_GRAYSCALE), (704, 576))
        img = cv2.medianBlur(cv2.resize(img, (480, 393), interpolation=cv2.INTER_AREA), 3)
        y_last = ((img.shape[0] - wh) // 2) * 2
        ii, sq = cv2.integral2(img, sdepth=cv2.CV_32S, sqdepth=cv2.CV_64F)
        r = pc.scan(ii, sq, 0, y_last)  # compiles
        t0 = time.process_time()
        for _ in range(a.reps):
            ii, sq = cv2.integral2(img, sdepth=cv2.CV_32S, sqdepth=cv2.CV_64F)
            r = pc.scan(ii, sq, 0, y_last)
        t1 = time.process_time()
        for _ in range(a.reps):
            ro, _ = clf.detectMultiScale2(img, scaleFactor=2.0, minNeighbors=0, minSize=(ww, wh), maxSize=(ww, wh))
        t2 = time.process_time()
        mine = set(map(tuple, r.tolist()))
        ocv = set((int(x), int(y)) for x, y, _, _ in np.asarray(ro).reshape(-1, 4))
        same += mine == ocv
        tn.append((t1 - t0) / a.reps)
        to.append((t2 - t1) / a.reps)
        print(f"{f.split('/')[-1]}: {len(mine)} windows, {'same' if mine == ocv else 'DIFFERENT'}, "
              f"numba {tn[-1] * 1e3:.2f} ms, OpenCV {to[-1] * 1e3:.2f} ms")
    print(f"n_dense {a.n_dense}: identical on {same} of {len(fs)} frames; median OpenCV / numba time ratio "
          f"{float(np.median(np.array(to) / np.array(tn))):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
