"""Review tests (session 18, issue #4): the Numba scanner (seawatch.detect.cascade_scan) and its
integration in the detector, on cases that tests/test_cascade_scan.py does not reach.

* random stump cascades with 3-rectangle features in the dense stages (v6 has none in its first
  three stages), non-integer rectangle weights (the order of the float32 operations matters),
  stump splits equal to a window's feature value and stage thresholds equal to a window's stage
  sum (ties: ``<`` against the split, ``>=`` against the threshold less 1e-5f);
* levels from exactly the window's size up, odd and even, so that the last row and the last
  column are the edge of the level;
* the 4x2 grid from a first row ``y_lo > 0``;
* ``scan_region_windows`` with a ``row_min_det`` (the horizon's scan region), either scanner;
* a level large enough for its int32 integral image to wrap around;
* scans of one ``PackedCascade`` from several threads at once.

OpenCV's windows of one level on its 2 px grid are those of ``detectMultiScale2`` at that
level's scale only; OpenCV's stripe rule drops the last row when the number of row positions is
odd, so one row is appended there (no window compared reads it).
"""

from __future__ import annotations

import dataclasses
import threading

import cv2
import numpy as np
import pytest

from seawatch.detect.cascade import CascadeDetector, default_model_path
from seawatch.detect.cascade_scan import THRESHOLD_EPS, PackedCascade
from seawatch.train.haar import HaarFeatures
from seawatch.train.model import Cascade, Stage, read_cascade_xml, write_cascade_xml

MODELS = default_model_path().parent
V6 = MODELS / "boat_cascade_v6.xml"
V6G4 = MODELS / "boat_cascade_v6g4.xml"


def _scene(seed: int, h: int, w: int) -> np.ndarray:
    """Textured water with waves, a few bright and dark hulls and a flat band (flat windows
    exercise the variance rejection)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    img = 110 + 25 * np.sin(xx / rng.uniform(2, 7) + yy / rng.uniform(2, 5)) + rng.normal(0, 14, (h, w))
    band = int(rng.integers(0, max(1, h // 4)))
    img[:band] = 200.0
    for _ in range(int(rng.integers(2, 6))):
        bw, bh = int(rng.integers(4, max(5, w // 3))), int(rng.integers(3, max(4, h // 3)))
        x0, y0 = int(rng.integers(0, max(1, w - bw))), int(rng.integers(0, max(1, h - bh)))
        img[y0:y0 + bh, x0:x0 + bw] = rng.choice([15.0, 240.0])
    return cv2.medianBlur(np.clip(img, 0, 255).astype(np.uint8), 3)


def _opencv_level(clf, img: np.ndarray, ww: int, wh: int) -> set:
    """OpenCV's accepted windows (x, y) of one level on its 2 px grid, every row position
    0..h - wh included (a row appended where the stripe rule would drop the last one)."""
    h = img.shape[0]
    big = img if (h + 1 - wh) % 2 == 0 else np.ascontiguousarray(np.vstack([img, img[-1:]]))
    r, _ = clf.detectMultiScale2(big, scaleFactor=2.0, minNeighbors=0, minSize=(ww, wh), maxSize=(ww, wh))
    return {(int(x), int(y)) for x, y, _, _ in np.asarray(r).reshape(-1, 4) if y <= h - wh}


def _scan(pc: PackedCascade, img: np.ndarray, y_lo: int = 0, step_x: int = 2) -> set:
    y_last = ((img.shape[0] - pc.height_px) // 2) * 2
    return set(map(tuple, pc.scan(img, y_lo, y_last, step_x=step_x).tolist()))


# ------------------------------------------------------------------ random cascades with ties
def _opencv_values(img, rects, wts, ww, wh):
    """OpenCV's float32 feature values (HaarEvaluator::OptFeature::calc times the variance
    factor) of every stump at every 2 px grid position, and which positions pass the variance
    check: ``(values (m, ny, nx), ok (ny, nx))``."""
    ii, sq = cv2.integral2(img, sdepth=cv2.CV_32S, sqdepth=cv2.CV_64F)
    ii = ii.astype(np.int64)
    h, w = img.shape
    ys, xs = np.arange(0, h - wh + 1, 2), np.arange(0, w - ww + 1, 2)
    Y, X = np.meshgrid(ys, xs, indexing="ij")

    def rsum(a, x, y, rw, rh):
        return a[Y + y, X + x] - a[Y + y, X + x + rw] - a[Y + y + rh, X + x] + a[Y + y + rh, X + x + rw]

    area = float((ww - 2) * (wh - 2))
    s = rsum(ii, 1, 1, ww - 2, wh - 2).astype(np.float64)
    nf = area * rsum(sq, 1, 1, ww - 2, wh - 2) - s * s
    fac = np.where(nf > 0, (1.0 / np.sqrt(np.where(nf > 0, nf, 1.0))).astype(np.float32), np.float32(1.0))
    ok = (nf > 0) & (area * fac.astype(np.float64) < 0.1)
    vals, alts = [], []
    for r, wt in zip(rects, wts):
        s0, s1 = rsum(ii, *r[0]).astype(np.float32), rsum(ii, *r[1]).astype(np.float32)
        s2 = rsum(ii, *r[2]).astype(np.float32) if wt[2] != 0 else np.zeros_like(s0)
        w0, w1, w2 = (np.float32(v) for v in wt)
        v = w0 * s0 + w1 * s1  # OpenCV's order, float32
        if wt[2] != 0:
            v = v + w2 * s2
        vals.append((v * fac).astype(np.float32))
        # other orders and precisions a scanner might use (values it would compare with the split)
        alts.append([(w0 * s0 + (w1 * s1 + w2 * s2)) * fac,  # the last two products first
                     (w0 * s0.astype(np.float64) + w1 * s1.astype(np.float64) + w2 * s2.astype(np.float64)
                      ).astype(np.float32) * fac,  # the sum in float64, rounded once
                     v.astype(np.float64) * fac.astype(np.float64)])  # the product not rounded to float32
    return np.array(vals), ok, alts


def _random_feature(rng, ww, wh, three: bool):
    a = int(rng.integers(1, max(2, (ww - 1) // 3)))
    b = int(rng.integers(1, max(2, (wh - 1) // 3)))
    x = int(rng.integers(0, ww - 2 * a + 1))
    y = int(rng.integers(0, wh - 2 * b + 1))
    r = np.zeros((3, 4), np.int32)
    wt = np.zeros(3, np.float32)
    r[0] = (x, y, 2 * a, 2 * b)
    wt[0] = -1.0
    r[1] = (x + int(rng.integers(0, a + 1)), y, a, b)
    wt[1] = np.float32(rng.uniform(1.0, 4.0))  # non-integer: float32 rounding shows the order
    if three:
        r[2] = (x + int(rng.integers(0, a + 1)), y + b, a, b)
        wt[2] = np.float32(rng.uniform(0.3, 3.0))
    return r, wt


def _threshold_between(lo: float, hi: float) -> np.float32 | None:
    """A float32 stage threshold T whose effective value ``float32(T) - 1e-5f`` (OpenCV's) lies in
    ``(lo, hi]``, as close to ``hi`` as found (equal to it when ``hi`` is a float32); else None."""
    t = np.float32(np.float32(hi) + THRESHOLD_EPS)
    for k in range(0, 12):
        for c in (np.float32(t - np.float32(k) * np.spacing(t)), np.float32(t + np.float32(k) * np.spacing(t))):
            eff = float(np.float32(c - THRESHOLD_EPS))
            if lo < eff <= hi:
                return c
    return None


def _random_cascade(seed: int, ww: int, wh: int, ref: np.ndarray, n_stages: int = 4, per_stage: int = 6,
                    dyadic: bool = True) -> tuple[Cascade, dict]:
    """A stump cascade of 2- and 3-rectangle features that passes a good part of ``ref``'s
    windows and puts its decisions where the arithmetic matters: each split on a value where
    OpenCV's float32 feature value and another order's or precision's (``_opencv_values``' alts)
    fall on either side for some window, or on a value some window takes (a tie); each stage
    threshold between the stage sums such a window gets in the two arithmetics (or, failing one,
    on a stage sum some windows take, a tie with ``>=``)."""
    rng = np.random.default_rng(seed)
    m = n_stages * per_stage
    rects, wts = zip(*[_random_feature(rng, ww, wh, three=(j % 3 != 1)) for j in range(m)])
    vals, ok, alts = _opencv_values(ref, rects, wts, ww, wh)
    alive = ok.copy()
    stages = []
    n_tied_split = n_tied_stage = n_split_flips = 0
    for st in range(n_stages):
        idx = np.arange(st * per_stage, (st + 1) * per_stage)
        splits, lefts, rights = [], [], []
        acc = np.zeros(ok.shape, np.float64)
        acc_alt = [np.zeros(ok.shape, np.float64) for _ in range(3)]
        for n, j in enumerate(idx):
            c = vals[j].astype(np.float64)
            ka = (n + st) % 3  # the arithmetic this stump targets
            a = np.asarray(alts[j][ka], np.float64)
            flips = [np.float32(v) for v in vals[j][alive & (a < c)]]
            flips += [np.float32(v) for v in a[alive & (a > c) & (a == a.astype(np.float32))]]
            pool = np.array(flips, np.float32) if flips and rng.random() < 0.85 else (
                vals[j][alive] if alive.any() else vals[j].ravel())
            sp = np.float32(pool[int(rng.integers(0, len(pool)))])
            n_tied_split += int((vals[j][alive] == sp).sum())
            if dyadic:  # sums of eighths are exact: many windows tie with the stage threshold
                lf, rt = np.float32(int(rng.integers(-8, 0)) / 8.0), np.float32(int(rng.integers(1, 9)) / 8.0)
            else:
                lf, rt = np.float32(rng.uniform(-1, 0)), np.float32(rng.uniform(0, 1))
            if rng.random() < 0.3:
                lf, rt = rt, lf
            splits.append(sp)
            lefts.append(lf)
            rights.append(rt)
            acc += np.where(vals[j] < sp, np.float64(lf), np.float64(rt))
            for k in range(3):
                acc_alt[k] += np.where(np.asarray(alts[j][k], np.float64) < sp, np.float64(lf), np.float64(rt))
        thr = None
        diff = alive & np.any([x != acc for x in acc_alt], axis=0)
        for i in rng.permutation(np.flatnonzero(diff.ravel()))[:20]:
            cands = sorted({float(acc.flat[i])} | {float(x.flat[i]) for x in acc_alt})
            lo, hi = cands[0], cands[-1]
            t = _threshold_between(lo, hi)
            if t is not None:
                frac = float((acc[alive] >= float(np.float32(t - THRESHOLD_EPS))).mean())
                if 0.2 <= frac <= 0.9:
                    thr = t
                    n_split_flips += 1
                    break
        if thr is None:
            sums = acc[alive] if alive.any() else acc.ravel()
            d = float(np.quantile(sums, 0.3, method="nearest"))
            thr = _threshold_between(d - 1e-3, d) or np.float32(d)
        eff = np.float64(np.float32(thr - THRESHOLD_EPS))
        n_tied_stage += int((acc[alive] == eff).sum())
        alive &= acc >= eff
        stages.append(Stage(float(thr), np.asarray(idx, np.int32), np.asarray(splits, np.float32),
                            np.asarray(lefts, np.float32), np.asarray(rights, np.float32)))
    feats = HaarFeatures(np.asarray(rects, np.int32), np.asarray(wts, np.float32), np.zeros(m, np.int8))
    info = {"tied_splits": n_tied_split, "tied_stage_sums": n_tied_stage, "accepted_ref": int(alive.sum()),
            "stages_on_a_flip": n_split_flips}
    return Cascade(ww, wh, feats, stages), info


@pytest.mark.parametrize("seed,ww,wh,dyadic", [(0, 24, 12, True), (1, 23, 13, True), (2, 30, 15, False),
                                               (3, 17, 9, True)])
def test_random_cascades_with_three_rect_features_and_ties(tmp_path, seed, ww, wh, dyadic):
    ref = _scene(100 + seed, 61, 97)
    casc, info = _random_cascade(seed, ww, wh, ref, dyadic=dyadic)
    path = write_cascade_xml(casc, tmp_path / "rand.xml")
    clf = cv2.CascadeClassifier(str(path))
    pcs = [PackedCascade(path, n_dense=k) for k in (1, 2, 3, 4)]
    assert int((pcs[0].nrect[: pcs[0].start[1]] == 3).sum()) >= 2  # 3-rectangle stumps in the first stage
    assert info["tied_splits"] > 0 and info["accepted_ref"] > 0
    assert info["stages_on_a_flip"] >= 2  # stage thresholds between two arithmetics' sums of a window
    if dyadic:
        assert info["tied_stage_sums"] > 0
    total = 0
    for k, img in enumerate([ref, _scene(200 + seed, 48, 80), _scene(300 + seed, 40, 59)]):
        want = _opencv_level(clf, img, ww, wh)
        for pc in pcs:
            assert _scan(pc, img) == want, (k, pc.n_dense)
        total += len(want)
    assert total > 10


def _evaluated(ok: np.ndarray, pass0: np.ndarray) -> np.ndarray:
    """Positions OpenCV evaluates on its 2 px grid: a first-stage reject skips the next position."""
    ev = np.zeros_like(ok)
    for r in range(ok.shape[0]):
        x = 0
        while x < ok.shape[1]:
            ev[r, x] = True
            x += 2 if (ok[r, x] and not pass0[r, x]) else 1
    return ev


def _flip_cascade(seed: int, ww: int, wh: int, ref: np.ndarray, alt: int, three: bool):
    """Three loose stages, then one stump whose split separates, at one window that reaches it,
    OpenCV's float32 feature value from the value arithmetic ``alt`` gives (``_opencv_values``:
    0 the last two products summed first, 1 the sum in float64, 2 the product with the variance
    factor not rounded): a scanner using that arithmetic decides that window the other way.
    Returns the cascade and the window (x, y) with OpenCV's decision on it, or None."""
    rng = np.random.default_rng(seed)
    n_loose, per = 3, 5
    rects, wts = [], []
    for j in range(n_loose * per):
        r, w = _random_feature(rng, ww, wh, three=bool(j % 2))
        rects.append(r)
        wts.append(w)
    vals, ok, _ = _opencv_values(ref, rects, wts, ww, wh)
    alive = ok.copy()
    stages = []
    for st in range(n_loose):
        idx = np.arange(st * per, (st + 1) * per)
        acc = np.zeros(ok.shape, np.float64)
        sps, lfs, rts = [], [], []
        for j in idx:
            pool = vals[j][alive]
            sp = np.float32(pool[int(rng.integers(0, len(pool)))])
            lf, rt = np.float32(-0.25), np.float32(0.25)
            acc += np.where(vals[j] < sp, np.float64(lf), np.float64(rt))
            sps.append(sp)
            lfs.append(lf)
            rts.append(rt)
        d = float(np.quantile(acc[alive], 0.1, method="nearest"))
        thr = np.float32(d - 0.01)
        passed = acc >= float(np.float32(thr - THRESHOLD_EPS))
        if st == 0:
            alive &= _evaluated(ok, passed)
        alive &= passed
        stages.append(Stage(float(thr), idx.astype(np.int32), np.array(sps, np.float32), np.array(lfs, np.float32),
                            np.array(rts, np.float32)))
    for _ in range(200):  # a feature with a window where the two arithmetics differ
        r, w = _random_feature(rng, ww, wh, three=three)
        v, _, al = _opencv_values(ref, [r], [w], ww, wh)
        c = v[0].astype(np.float64)
        a = np.asarray(al[0][alt], np.float64)
        lo = np.flatnonzero((alive & (a < c)).ravel())
        hi = np.flatnonzero((alive & (a > c) & (a == a.astype(np.float32))).ravel())
        if len(lo) + len(hi) == 0:
            continue
        i = int(rng.choice(np.concatenate([lo, hi])))
        sp = np.float32(c.flat[i] if i in set(lo.tolist()) else a.flat[i])
        accept = bool(c.flat[i] >= sp)  # OpenCV: not below the split -> the right leaf, +1: accepted
        rects.append(r)
        wts.append(w)
        stages.append(Stage(0.0, np.array([len(rects) - 1], np.int32), np.array([sp], np.float32),
                            np.array([-1.0], np.float32), np.array([1.0], np.float32)))
        feats = HaarFeatures(np.asarray(rects, np.int32), np.asarray(wts, np.float32), np.zeros(len(rects), np.int8))
        yy, xx = np.unravel_index(i, ok.shape)
        return Cascade(ww, wh, feats, stages), (2 * int(xx), 2 * int(yy)), accept
    return None


@pytest.mark.parametrize("alt,three", [(0, True), (1, False), (1, True), (2, False), (2, True)])
def test_a_window_on_which_the_float_arithmetic_decides(tmp_path, alt, three):
    """One window's decision depends on computing the feature value as OpenCV does: (w0 s0 + w1
    s1) + w2 s2 in float32, then times the float32 variance factor, rounded to float32. Every
    n_dense (the last stage dense or per row) gives OpenCV's decision on it."""
    ww, wh = 24, 12
    for seed in range(40):
        ref = _scene(700 + seed, 61, 97)
        made = _flip_cascade(seed, ww, wh, ref, alt, three)
        if made is not None:
            break
    assert made is not None
    casc, (x, y), accept = made
    path = write_cascade_xml(casc, tmp_path / "flip.xml")
    want = _opencv_level(cv2.CascadeClassifier(str(path)), ref, ww, wh)
    assert ((x, y) in want) == accept  # the replica of OpenCV's arithmetic agrees with OpenCV
    for n_dense in (1, 2, 3, 4):
        assert _scan(PackedCascade(path, n_dense=n_dense), ref) == want, n_dense


def test_levels_from_the_window_size_up(tmp_path):
    """Levels exactly the window's size and a few pixels more, odd and even: the last row and
    column of positions are the level's edge."""
    ref = _scene(7, 61, 97)
    ww, wh = 22, 11
    casc, _ = _random_cascade(7, ww, wh, ref, n_stages=2, per_stage=4)
    path = write_cascade_xml(casc, tmp_path / "small.xml")
    clf = cv2.CascadeClassifier(str(path))
    pc = PackedCascade(path)
    n_acc = 0
    for dh in range(0, 5):
        for dw in range(0, 6):
            for s in range(6):
                img = np.ascontiguousarray(_scene(1000 + 31 * dh + 7 * dw + s, 61, 97)[s:s + wh + dh, 2 * s:2 * s + ww + dw])
                want = _opencv_level(clf, img, ww, wh)
                assert _scan(pc, img) == want, (dh, dw, s)
                n_acc += len(want)
    assert n_acc > 20
    assert pc.scan(np.zeros((wh, ww - 1), np.uint8), 0, 0).shape == (0, 2)  # narrower than the window


def _truncated(tmp_path, n_stages: int):
    casc = read_cascade_xml(V6)
    casc = dataclasses.replace(casc, stages=casc.stages[:n_stages])
    return write_cascade_xml(casc, tmp_path / f"v6_{n_stages}.xml")


def test_coarse_grid_from_a_first_row(tmp_path):
    """The 4x2 grid from a first row y_lo > 0 scans the full scan's windows of those rows."""
    pc = PackedCascade(_truncated(tmp_path, 2))
    img = _scene(21, 90, 161)
    full = _scan(pc, img, step_x=4)
    assert full and all(x % 4 == 0 and y % 2 == 0 for x, y in full)
    for y_lo in (2, 10, 36):
        y_last = ((img.shape[0] - pc.height_px) // 2) * 2
        part = set(map(tuple, pc.scan(img, y_lo, y_last, step_x=4).tolist()))
        assert part == {p for p in full if p[1] >= y_lo}
        # and the rows of a crop starting at y_lo (as the detector passes them) shifted back
        crop = set(map(tuple, pc.scan(np.ascontiguousarray(img[y_lo:]), 0, y_last - y_lo, step_x=4).tolist()))
        assert {(x, y + y_lo) for x, y in crop} == part


@pytest.mark.parametrize("overrides", [{"min_neighbors": 2, "scale_factor": 1.2},
                                       {"min_neighbors": 1, "scale_factor": 1.3}])
def test_scan_region_with_a_first_row_per_level_either_scanner(tmp_path, overrides):
    path = _truncated(tmp_path, 6)
    a = CascadeDetector(path, grid_step_px=2, scanner="opencv", **overrides)
    b = CascadeDetector(path, grid_step_px=2, scanner="numba", **overrides)
    rng = np.random.default_rng(3)
    n = 0
    for k in range(4):
        g = _scene(500 + k, 150 + 3 * k, 211 + 5 * k)
        n_lv = len(a._level_plan(g.shape[1], g.shape[0]))
        for _ in range(3):
            rows = rng.uniform(-5, g.shape[0], n_lv)  # odd, negative and past-the-level rows too
            wa, ca = a.scan_region_windows(g, rows)
            wb, cb = b.scan_region_windows(g, rows)
            ra = np.column_stack([wa, ca])
            rb = np.column_stack([wb, cb])
            assert np.array_equal(ra[np.lexsort(ra.T[::-1])], rb[np.lexsort(rb.T[::-1])])
            n += len(wa)
    assert n > 0


def test_integral_image_wrapping_around_int32(tmp_path):
    """A level whose int32 integral image wraps (its sum is over 2**31): OpenCV's int32
    arithmetic wraps too, and the window sums stay exact."""
    h, w = 3200, 3000
    img = np.full((h, w), 250, np.uint8)
    img[2600:, 2300:] = _scene(9, h - 2600, w - 2300)
    ii = cv2.integral(img, sdepth=cv2.CV_32S)
    assert int(img.astype(np.int64).sum()) > 2 ** 31 and int(ii[-1, -1]) != int(img.astype(np.int64).sum())
    path = _truncated(tmp_path, 2)
    clf = cv2.CascadeClassifier(str(path))
    pc = PackedCascade(path)
    want = _opencv_level(clf, img, pc.width_px, pc.height_px)
    got = _scan(pc, img)
    assert got == want
    # windows accepted where the integral image has wrapped (past row 2900, at x near the right)
    assert any(y * x > 8_600_000 for x, y in want)


def test_one_packed_cascade_scanned_from_threads(tmp_path):
    """The scanner keeps no state across calls but its offset cache: scans of one PackedCascade
    from several threads at once (nogil) give each image its own windows."""
    path = _truncated(tmp_path, 3)
    pc = PackedCascade(path)
    imgs = [_scene(40 + k, 80 + 2 * (k % 3), 150 + (k % 4)) for k in range(12)]
    want = [_scan(PackedCascade(path), im) for im in imgs]  # each alone, a fresh cache each
    assert sum(map(len, want)) > 0
    got = [None] * len(imgs)
    errors = []

    def work(i0):
        try:
            for _ in range(3):
                for i in range(i0, len(imgs), 4):
                    got[i] = _scan(pc, imgs[i], step_x=2)
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    ts = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert not errors and got == want


def test_the_default_model_on_opencvs_grid():
    det = CascadeDetector(V6G4, grid_step_px=0)
    assert det.params.grid_step_x_px in (0, 2) and not det._use_numba()
