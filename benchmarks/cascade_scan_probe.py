"""Probe (session 17, issue #4): can an exact Numba scanner beat ``cv2.CascadeClassifier``?

A breadth-first Numba evaluation of one pyramid level (variance check and first stage along each
row with OpenCV's skip-after-first-stage-reject rule, then the later stages over the compacted
survivors) is compared with ``detectMultiScale2`` on the same level: the raw windows must be
identical, and the CPU time is paired in one process. Training frames only (never video2 or the
held-out frames). Not used by the detector: it was about 1.0-1.2x OpenCV's speed, far from the
1.3-2x that v6 at its own settings (1.1 / 16 / 0) would need for 50 frames/s.

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/cascade_scan_probe.py --data ../shared/data
"""
from __future__ import annotations

import argparse
import glob
import time

import cv2
import numpy as np
from numba import njit

from seawatch.train.model import read_cascade_xml
@njit(cache=True, boundscheck=False, nogil=True)
def scan_level(ii, sq, win_w, win_h, step, y_lo, y_last, start, thr, nrect, off, wts, split, left, right,
               out_y, out_x):
    """Accepted windows of one level (integral ``ii`` int32, ``sq`` float64): their number;
    their (y, x) in ``out_y`` / ``out_x``."""
    W = ii.shape[1] - 1
    stride = W + 1
    iif = ii.ravel()
    sqf = sq.ravel()
    area = float((win_w - 2) * (win_h - 2))
    nmax = ((y_last - y_lo) // step + 1) * ((W - win_w) // step + 1)
    base = np.empty(nmax, np.int64)
    fac = np.empty(nmax, np.float32)
    n = 0
    # phase 1: variance and stage 0, sequential along x (OpenCV skips the next position after a stage-0 reject)
    s0a = start[0]; s0b = start[1]; t0 = float(thr[0])
    for oy in range(y_lo, y_last + 1, step):
        ox = -step
        while True:
            ox += step
            if ox > W - win_w:
                break
            p = oy * stride + ox
            p1 = p + stride + 1
            p2 = p + stride + win_w - 1
            p3 = p + (win_h - 1) * stride + 1
            p4 = p + (win_h - 1) * stride + win_w - 1
            s = iif[p1] - iif[p2] - iif[p3] + iif[p4]
            q = sqf[p1] - sqf[p2] - sqf[p3] + sqf[p4]
            nf = area * q - float(s) * float(s)
            if nf <= 0.0:
                continue
            factor = np.float32(1.0 / np.sqrt(nf))
            if not (area * float(factor) < 0.1):
                continue
            acc = 0.0
            for j in range(s0a, s0b):
                v = wts[j, 0] * np.float32(iif[p + off[j, 0]] - iif[p + off[j, 1]] - iif[p + off[j, 2]] + iif[p + off[j, 3]])
                v = v + wts[j, 1] * np.float32(iif[p + off[j, 4]] - iif[p + off[j, 5]] - iif[p + off[j, 6]] + iif[p + off[j, 7]])
                if nrect[j] == 3:
                    v = v + wts[j, 2] * np.float32(iif[p + off[j, 8]] - iif[p + off[j, 9]] - iif[p + off[j, 10]] + iif[p + off[j, 11]])
                v = v * factor
                if v < split[j]:
                    acc += float(left[j])
                else:
                    acc += float(right[j])
            if acc < t0:
                ox += step
                continue
            base[n] = p
            fac[n] = factor
            n += 1
    # phase 2: later stages breadth-first over the survivors
    acc2 = np.empty(n, np.float64)
    for st in range(1, thr.shape[0]):
        if n == 0:
            break
        for i in range(n):
            acc2[i] = 0.0
        for j in range(start[st], start[st + 1]):
            o0 = off[j, 0]; o1 = off[j, 1]; o2 = off[j, 2]; o3 = off[j, 3]
            o4 = off[j, 4]; o5 = off[j, 5]; o6 = off[j, 6]; o7 = off[j, 7]
            w0 = wts[j, 0]; w1 = wts[j, 1]; sp = split[j]; lf = float(left[j]); rt = float(right[j])
            if nrect[j] == 3:
                o8 = off[j, 8]; o9 = off[j, 9]; o10 = off[j, 10]; o11 = off[j, 11]; w2 = wts[j, 2]
                for i in range(n):
                    p = base[i]
                    v = w0 * np.float32(iif[p + o0] - iif[p + o1] - iif[p + o2] + iif[p + o3])
                    v = v + w1 * np.float32(iif[p + o4] - iif[p + o5] - iif[p + o6] + iif[p + o7])
                    v = v + w2 * np.float32(iif[p + o8] - iif[p + o9] - iif[p + o10] + iif[p + o11])
                    v = v * fac[i]
                    acc2[i] += lf if v < sp else rt
            else:
                for i in range(n):
                    p = base[i]
                    v = w0 * np.float32(iif[p + o0] - iif[p + o1] - iif[p + o2] + iif[p + o3])
                    v = v + w1 * np.float32(iif[p + o4] - iif[p + o5] - iif[p + o6] + iif[p + o7])
                    v = v * fac[i]
                    acc2[i] += lf if v < sp else rt
        t = float(thr[st])
        m = 0
        for i in range(n):
            if acc2[i] >= t:
                base[m] = base[i]
                fac[m] = fac[i]
                m += 1
        n = m
    for i in range(n):
        out_y[i] = base[i] // stride
        out_x[i] = base[i] % stride
    return n


def pack(casc, stride):
    start, thr, feat, split, left, right, rects, weights = casc.packed()
    m = len(feat)
    off = np.zeros((m, 12), np.int64)
    wts = np.zeros((m, 3), np.float32)
    nrect = np.zeros(m, np.int32)
    for j in range(m):
        f = feat[j]
        k = 0
        for r in range(3):
            if weights[f, r] == 0.0:
                continue
            x, y, w, h = rects[f, r]
            off[j, 4*k:4*k+4] = [y*stride + x, y*stride + x + w, (y+h)*stride + x, (y+h)*stride + x + w]
            wts[j, k] = weights[f, r]
            k += 1
        nrect[j] = k
    return start, thr, nrect, off, wts, split, left, right


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--model", default="seawatch/models/boat_cascade_v6.xml")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args(argv)
    cv2.setNumThreads(1)
    casc = read_cascade_xml(a.model)
    clf = cv2.CascadeClassifier(a.model)
    fs = sorted(glob.glob(f"{a.data}/mardct/train/frames/*.png"))[::12]
    ww, wh = casc.width_px, casc.height_px
    tn, to, same = [], [], 0
    for f in fs:
        img = cv2.resize(cv2.imread(f, cv2.IMREAD_GRAYSCALE), (704, 576))
        img = cv2.medianBlur(cv2.resize(img, (480, 393), interpolation=cv2.INTER_AREA), 3)
        h, w = img.shape
        packed = pack(casc, w + 1)
        oy = np.zeros(200000, np.int64)
        ox = np.zeros(200000, np.int64)
        y_last = ((h - wh) // 2) * 2
        ii, sq = cv2.integral2(img, sdepth=cv2.CV_32S, sqdepth=cv2.CV_64F)
        scan_level(ii, sq, ww, wh, 2, 0, y_last, *packed, oy, ox)
        t0 = time.process_time()
        for _ in range(a.reps):
            ii, sq = cv2.integral2(img, sdepth=cv2.CV_32S, sqdepth=cv2.CV_64F)
            n = scan_level(ii, sq, ww, wh, 2, 0, y_last, *packed, oy, ox)
        t1 = time.process_time()
        for _ in range(a.reps):
            r, _ = clf.detectMultiScale2(img, scaleFactor=2.0, minNeighbors=0, minSize=(ww, wh), maxSize=(ww, wh))
        t2 = time.process_time()
        mine = set(zip(oy[:n].tolist(), ox[:n].tolist()))
        ocv = set((int(y), int(x)) for x, y, _, _ in np.asarray(r).reshape(-1, 4))
        same += mine == ocv
        tn.append((t1 - t0) / a.reps)
        to.append((t2 - t1) / a.reps)
        print(f"{f.split('/')[-1]}: {n} windows, {'same' if mine == ocv else 'DIFFERENT'}, "
              f"numba {tn[-1] * 1e3:.2f} ms, OpenCV {to[-1] * 1e3:.2f} ms")
    print(f"identical on {same} of {len(fs)} frames; median OpenCV / numba time ratio "
          f"{float(np.median(np.array(to) / np.array(tn))):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
