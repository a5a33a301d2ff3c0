"""The box growing's Numba kernels (session 18, issue #8: speed with identical output) against the
numpy / OpenCV code they replace, on random input: exact equality, not closeness."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from seawatch.track import feature_clusters as F


def _reference_grow_one(img, box, core_box, gx, gy, large, b, k_sigma, min_contrast, max_fill, peak_frac,
                        waterline_frac=0.0, wake_frac=0.0, trail=0, top_frac=0.0, cut_core_frac=0.0,
                        cut_core_undo=False, wake_thick=False, sign_frac=0.0, cover_wide=False, sign_side=0,
                        top_halo=0.0, top_min_px=0.0, wake_core=0.0, wake_front=0.0):
    """``_grow_one`` as it was before session 18 (np.percentile, cv2.morphologyEx,
    cv2.connectedComponentsWithStats, np.unique / setdiff1d / isin); it has no ``wake_thick``
    (session 19), no ``sign_frac`` (session 20), no ``cover_wide`` (session 21) and no ``sign_side``
    (session 22; it acts only with ``sign_frac``) and no ``top_halo`` (session 23); ``top_min_px``
    (session 24) as there, all off by default; no ``wake_core`` (session 25, H20) and no ``wake_front`` (session 26, H23)."""
    assert not wake_thick and sign_frac == 0 and not cover_wide and top_halo == 0 and wake_core == 0 and wake_front == 0
    hh, ww = img.shape[:2]
    x, y, w, h = box
    x0, y0 = int(max(0, np.floor(x - gx))), int(max(0, np.floor(y - gy)))
    x1, y1 = int(min(ww, np.ceil(x + w + gx))), int(min(hh, np.ceil(y + h + gy)))
    bw = max(b, int(round(0.1 * (x1 - x0))))
    if x1 - x0 < 2 * bw + 3 or y1 - y0 < 3:
        return None, np.nan, False
    win = img[y0:y1, x0:x1]
    bg, sigma = F._window_background(win.astype(np.float32), bw)
    cx, cy, cw, ch = core_box
    c0x, c0y = int(max(0, np.floor(cx)) - x0), int(max(0, np.floor(cy)) - y0)
    c1x, c1y = int(np.ceil(cx + cw)) - x0 + 1, int(np.ceil(cy + ch)) - y0 + 1
    c0x, c0y = max(c0x, 0), max(c0y, 0)
    core = (slice(c0y, max(c1y, c0y + 1)), slice(c0x, max(c1x, c0x + 1)))
    r0, r1 = min(core[0].start, win.shape[0]), min(core[0].stop, win.shape[0])
    q0, q1 = min(core[1].start, win.shape[1]), min(core[1].stop, win.shape[1])
    dev_core = F._window_deviation(win, bg, r0, r1, q0, q1)
    peak = float(np.percentile(dev_core, 90)) if dev_core.size else 0.0
    contrast = peak / max(sigma, 1.0)
    if large or peak <= max(k_sigma * sigma, min_contrast):
        return None, contrast, not large
    dev = F._window_deviation(win, bg, 0, win.shape[0], 0, win.shape[1])
    thr = max(k_sigma * sigma, min_contrast, peak_frac * peak)
    fg = (dev > thr).astype(np.uint8)
    if fg.mean() > max_fill:
        return None, contrast, False
    fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
    nlab, lab, stats, _ = cv2.connectedComponentsWithStats(fg, connectivity=8)
    if nlab <= 1:
        return None, contrast, False
    sub = lab[core]
    hit = np.unique(sub[sub > 0])
    edge = np.unique(np.r_[lab[:, 0] if x0 > 0 else [], lab[:, -1] if x1 < ww else []]).astype(np.int64)
    at_edge = len(hit) > 0
    hit = np.setdiff1d(hit, edge)
    if len(hit) == 0:
        return None, contrast, at_edge
    st = stats[hit]
    nx0, nx1 = st[:, 0].min() + x0, (st[:, 0] + st[:, 2]).max() + x0
    ny0, ny1 = st[:, 1].min() + y0, (st[:, 1] + st[:, 3]).max() + y0
    cw1, ch1 = max(cw, 1.0), max(ch, 1.0)
    iw = min(nx1, cx + cw1) - max(nx0, cx)
    ih = min(ny1, cy + ch1) - max(ny0, cy)
    if max(iw, 0.0) * max(ih, 0.0) < 0.5 * cw1 * ch1:
        return None, contrast, False
    if waterline_frac > 0 or wake_frac > 0:
        core_w = (cx - x0, cy - y0, cx + cw - x0, cy + ch - y0) if cut_core_frac > 0 else None
        nx0, ny0, nx1, ny1 = _reference_trim_object(dev, (lab, hit), (nx0 - x0, ny0 - y0, nx1 - x0, ny1 - y0),
                                            waterline_frac, wake_frac, trail, core_w, cut_core_frac, cut_core_undo)
        nx0, nx1, ny0, ny1 = nx0 + x0, nx1 + x0, ny0 + y0, ny1 + y0
    if top_frac > 0 and top_frac < peak_frac and ny1 - ny0 >= top_min_px:
        ny0 = y0 + _reference_extend_top(dev, (nx0 - x0, ny0 - y0, nx1 - x0, ny1 - y0),
                                         max(k_sigma * sigma, min_contrast, top_frac * peak), x0 > 0, x1 < ww)
    return (nx0, ny0, nx1 - nx0, ny1 - ny0), contrast, False


def _reference_extend_top(dev, ext, thr, left_edge, right_edge):
    x0, y0, x1, y1 = (int(v) for v in ext)
    if y0 <= 0 or not (dev[max(y0 - 2, 0):y0, x0:x1] > thr).any():
        return y0
    fg = cv2.morphologyEx((dev > thr).astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
    nlab, lab = cv2.connectedComponents(fg, connectivity=8)
    if nlab <= 1:
        return y0
    hit = np.unique(lab[y0:min(y0 + 2, y1), x0:x1])
    edge = np.r_[lab[:, 0] if left_edge else [], lab[:, -1] if right_edge else []].astype(np.int64)
    hit = np.setdiff1d(hit[hit > 0], edge)
    if not len(hit):
        return y0
    rows = np.flatnonzero(np.isin(lab[:y0, x0:x1], hit).any(axis=1))
    return int(rows[0]) if len(rows) else y0


def _reference_trim_object(dev, sel, ext, waterline_frac, wake_frac, trail=0, core=None, core_frac=0.0,
                           core_undo=False):
    """``_trim_object`` as it was before session 18 (np.median, np.percentile, np.where)."""
    x0, y0, x1, y1 = (int(v) for v in ext)
    check = core is not None and core_frac > 0
    if waterline_frac > 0 and y1 - y0 >= 3:
        rows = np.median(dev[y0:y1, x0:x1], axis=1)
        strong = np.flatnonzero(rows >= waterline_frac * rows.max())
        yc = y0 + int(strong[-1]) + 1
        if check:
            ch = max(core[3] - core[1], 1.0)
            if min(core[3], y1) - yc > core_frac * ch:
                yc = y1 if core_undo else max(yc, min(y1, int(np.ceil(core[3] - core_frac * ch))))
        y1 = yc
    if wake_frac > 0 and trail != 0 and x1 - x0 >= 3:
        m = np.isin(sel[0][y0:y1, x0:x1], sel[1]) if isinstance(sel, tuple) else sel[y0:y1, x0:x1]
        ext = np.where(m.any(axis=0), (y1 - y0) - np.argmax(m, axis=0), 0)
        ref = np.percentile(ext[ext > 0], 75) if (ext > 0).any() else 0.0
        tall = np.flatnonzero(ext >= wake_frac * ref)
        if len(tall):
            run = max(3, 0.25 * (x1 - x0))
            a, b = int(tall[0]), (x1 - x0) - int(tall[-1]) - 1
            nx0, nx1 = x0 + (a if a >= run and trail < 0 else 0), x1 - (b if b >= run and trail > 0 else 0)
            if check:
                cw = max(core[2] - core[0], 1.0)
                if nx0 - max(core[0], x0) > core_frac * cw:
                    nx0 = x0 if core_undo else min(nx0, max(x0, int(np.floor(core[0] + core_frac * cw))))
                if min(core[2], x1) - nx1 > core_frac * cw:
                    nx1 = x1 if core_undo else max(nx1, min(x1, int(np.ceil(core[2] - core_frac * cw))))
            x0, x1 = nx0, nx1
    return x0, y0, x1, y1


def test_trim_object_kernels_equal_the_reference():
    rng = np.random.default_rng(7)
    n_cut = 0
    for it in range(1500):
        rows, cols = int(rng.integers(3, 50)), int(rng.integers(3, 90))
        dev = (rng.integers(0, 511, (rows, cols)) / 2.0).astype(np.float32)
        if rng.random() < 0.5:  # a hull over a fainter reflection
            dev[: rows // 2] += np.float32(rng.integers(0, 100))
        mask = rng.random((rows, cols)) < rng.uniform(0.1, 0.9)
        if rng.random() < 0.5:  # a low wake at one end
            mask[: rows - 2, : cols // 3] = False
        x0, y0 = int(rng.integers(0, cols - 2)), int(rng.integers(0, rows - 2))
        x1, y1 = int(rng.integers(x0 + 1, cols + 1)), int(rng.integers(y0 + 1, rows + 1))
        core = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)), float(rng.uniform(x0, x1 + 3)),
                float(rng.uniform(y0, y1 + 3))) if rng.random() < 0.5 else None
        args = (dev, mask, (x0, y0, x1, y1), float(rng.choice([0.0, 0.5, 0.37])), float(rng.choice([0.0, 0.3, 0.71])),
                int(rng.choice([-1, 0, 1])), core, float(rng.choice([0.0, 0.3])), bool(rng.random() < 0.5))
        got, ref = F._trim_object(*args), _reference_trim_object(*args)
        assert [int(v) for v in got] == [int(v) for v in ref]
        n_cut += got != (x0, y0, x1, y1)
    assert n_cut > 100


def test_close_label_is_opencvs_closing_and_components():
    rng = np.random.default_rng(1)
    for it in range(600):
        rows, cols = int(rng.integers(1, 40)), int(rng.integers(1, 60))
        fg = rng.random((rows, cols)) < rng.uniform(0.02, 0.7)
        lab, n = F._close_label(fg)
        closed = cv2.morphologyEx(fg.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
        nref, ref = cv2.connectedComponents(closed, connectivity=8)
        assert np.array_equal(lab > 0, closed > 0)
        assert n == nref - 1
        # the same partition: a one-to-one map between the label sets
        pairs = np.unique(np.stack([lab.ravel(), ref.ravel()], axis=1), axis=0)
        assert len(pairs) == len(np.unique(pairs[:, 0])) == len(np.unique(pairs[:, 1])) == len(np.unique(ref))


def test_core_peak_u8_is_numpys_percentile_of_the_deviations():
    rng = np.random.default_rng(5)
    for it in range(400):
        rows, cols, nc = int(rng.integers(1, 60)), int(rng.integers(8, 120)), int(rng.choice([1, 3]))
        win = rng.integers(0, 256, (rows, cols, nc), dtype=np.uint8)
        if it % 3 == 0:
            win = np.clip(120 + rng.normal(0, 3, win.shape), 0, 255).astype(np.uint8)  # ties
        bg, _ = F._window_background_u8(win, max(1, cols // 10))
        r0, c0 = int(rng.integers(0, rows)), int(rng.integers(0, cols))
        r1, c1 = int(rng.integers(r0, rows + 1)), int(rng.integers(c0, cols + 1))
        dev = F._window_deviation(win, bg, r0, r1, c0, c1)
        ref = float(np.percentile(dev, 90)) if dev.size else 0.0
        assert float(F._core_peak_u8(win, bg, r0, r1, c0, c1)) == ref


def test_window_background_u8_equals_the_sorting_kernel_exactly():
    rng = np.random.default_rng(2)
    for _ in range(300):
        rows, cols, nc = int(rng.integers(1, 30)), int(rng.integers(8, 90)), int(rng.choice([1, 3]))
        bw = int(rng.integers(1, cols // 2))
        win = rng.integers(0, 256, (rows, cols, nc), dtype=np.uint8)
        if rng.random() < 0.5:  # few levels: many ties
            win = (win // 64 * 64).astype(np.uint8)
        b8, s8 = F._window_background_u8(win, bw)
        bf, sf = F._window_background(win.astype(np.float32), bw)
        assert np.array_equal(b8, bf) and s8 == sf


def _scene(rng, h, w, nc):
    img = rng.normal(rng.uniform(60, 180), rng.uniform(1, 6), (h, w, nc))
    hz = int(rng.integers(0, h))
    img[:hz] += rng.uniform(-40, 40)  # sky and sea
    boats = []
    for _ in range(int(rng.integers(1, 5))):
        bw_, bh_ = int(rng.integers(4, 80)), int(rng.integers(3, 30))
        x, y = int(rng.integers(0, w - 4)), int(rng.integers(0, h - 3))
        img[y:y + bh_, x:x + bw_] += rng.uniform(-90, 90)
        if rng.random() < 0.5:  # a cabin, a reflection
            img[max(0, y - bh_ // 2):y, x + bw_ // 3:x + bw_ // 2] += rng.uniform(-60, 60)
            img[y + bh_:y + bh_ + bh_ // 2, x:x + bw_] += rng.uniform(-30, 30)
        boats.append((x, y, bw_, bh_))
    if rng.random() < 0.3:  # a coastline across the image
        img[hz:hz + int(rng.integers(2, 10))] -= 50
    return np.clip(img, 0, 255).astype(np.uint8), boats


def test_grow_one_equals_the_reference_on_random_scenes():
    rng = np.random.default_rng(3)
    n_grown = 0
    for it in range(250):
        h, w = int(rng.integers(40, 200)), int(rng.integers(60, 320))
        img, boats = _scene(rng, h, w, int(rng.choice([1, 3])))
        for x, y, bw_, bh_ in boats:
            # a core inside the boat (features), the box around it
            cx, cy = x + rng.uniform(0, bw_ / 2), y + rng.uniform(0, bh_ / 2)
            core = np.array([cx, cy, rng.uniform(0, bw_), rng.uniform(0, bh_)])
            box = core + [-2, -2, 4, 4]
            kw = dict(waterline_frac=float(rng.choice([0.0, 0.5])), wake_frac=float(rng.choice([0.0, 0.3])),
                      trail=int(rng.choice([-1, 0, 1])), top_frac=float(rng.choice([0.0, 0.35])),
                      cut_core_frac=float(rng.choice([0.0, 0.3])), cut_core_undo=bool(rng.random() < 0.5),
                      top_min_px=float(rng.choice([0.0, 0.0, 3.0])))
            g = float(rng.choice([6.0, 20.0, 40.0, 120.0]))
            args = (img, box, core, g, min(g, 40.0), bool(rng.random() < 0.05), 3, 3.0, float(rng.choice([4.0, 10.0])),
                    float(rng.choice([0.5, 0.9])), 0.5)
            got = F._grow_one(*args, **kw)
            ref = _reference_grow_one(*args, **kw)
            assert (got[0] is None) == (ref[0] is None)
            if ref[0] is not None:
                n_grown += 1
                assert [float(v) for v in got[0]] == [float(v) for v in ref[0]]
            assert got[2] == ref[2]
            assert (np.isnan(ref[1]) and np.isnan(got[1])) or got[1] == ref[1]
    assert n_grown > 100  # the comparison reached the segmentation, the cuts and the top often


@pytest.mark.parametrize("nc", [1, 3])
def test_grow_boxes_with_the_defaults_equals_the_reference(nc, monkeypatch):
    rng = np.random.default_rng(4 + nc)
    for it in range(40):
        img, boats = _scene(rng, 240, 320, nc)
        cores = np.array([[x + 1.0, y + 1.0, max(bw_ - 3.0, 0.0), max(bh_ - 2.0, 0.0)] for x, y, bw_, bh_ in boats])
        boxes = cores + [-2, -2, 4, 4]
        trail = rng.integers(-1, 2, len(boxes))
        kw = dict(grow=1.0, peak_frac=0.5, return_contrast=True, wide_grow_px=120.0, waterline_frac=0.5,
                  wake_frac=0.3, trail=trail, top_frac=0.35)
        got = F.grow_boxes(img[:, :, 0] if nc == 1 else img, boxes, cores, **kw)
        with monkeypatch.context() as m:
            m.setattr(F, "_grow_one", _reference_grow_one)
            ref = F.grow_boxes(img[:, :, 0] if nc == 1 else img, boxes, cores, **kw)
        assert np.array_equal(got[0], ref[0])
        assert np.array_equal(got[1], ref[1], equal_nan=True)


def _reference_box_members(k, vel, n, max_dv, anchor=None):
    """``_box_members`` as it was before session 18 (a numpy loop over the clusters)."""
    keep = np.ones(len(k), bool)
    fin = np.isfinite(vel).all(axis=1)
    for c in range(n):
        mc = np.flatnonzero(k == c)
        f = mc[fin[mc]]
        if len(f) < 3:
            continue
        fa = f[anchor[f]] if anchor is not None else f[:0]
        med = np.median(vel[fa if len(fa) >= 2 else f], axis=0)
        far = f[np.hypot(*(vel[f] - med).T) > max_dv]
        if len(mc) - len(far) >= 2:
            keep[far] = False
    return keep


def test_box_members_kernel_equals_the_reference():
    rng = np.random.default_rng(6)
    n_dropped = 0
    for it in range(800):
        n = int(rng.integers(1, 12))
        m = int(rng.integers(0, 80))
        k = rng.integers(0, n, m)
        vel = rng.normal(0, rng.choice([0.5, 3.0, 20.0]), (m, 2))
        if rng.random() < 0.5:  # two velocity groups, quantised (ties in the medians)
            vel += np.where(rng.random(m) < 0.3, 10.0, 0.0)[:, None]
            vel = np.round(vel * 2) / 2
        vel[rng.random(m) < 0.2] = np.nan
        vel[rng.random(m) < 0.05, 1] = np.nan
        anchor = (rng.random(m) < rng.uniform(0, 1)) if rng.random() < 0.6 else None
        dv = float(rng.choice([0.5, 1.5, 3.0]))
        got = F._box_members(k, vel, n, dv, anchor)
        ref = _reference_box_members(k, vel, n, dv, anchor)
        assert np.array_equal(got, ref)
        n_dropped += int((~ref).sum())
    assert n_dropped > 100
