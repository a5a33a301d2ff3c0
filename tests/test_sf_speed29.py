"""Session 29 (h34): the speed-ups of the default pipeline give the same values as before.

Each fast kernel is compared with the code it replaced (copied here as the reference) on
synthetic, seeded inputs: equal arrays, not close ones.  No new behaviour: nothing to turn on."""
import numba as nb
import numpy as np

from seawatch.track import feature_clusters as fc


@nb.njit(cache=True)
def _pair_dissimilarity_ref(history, pi, pj, p_px, frame_interval_s, angle):
    # main at d535c84
    out = np.empty(len(pi))
    nw = history.shape[1]
    for e in range(len(pi)):
        a, b = pi[e], pj[e]
        n = 0
        th = 0.0
        lm = 0.0
        for w in range(nw):
            ax, ay = history[a, w, 0], history[a, w, 1]
            bx, by = history[b, w, 0], history[b, w, 1]
            if not (np.isfinite(ax) and np.isfinite(ay) and np.isfinite(bx) and np.isfinite(by)):
                continue
            n += 1
            ang = abs(np.arctan2(ay, ax) - np.arctan2(by, bx))
            th += min(ang, 2.0 * np.pi - ang) / np.pi
            ma = np.hypot(ax, ay) * frame_interval_s
            mb = np.hypot(bx, by) * frame_interval_s
            fast = max(ma, mb)
            if fast > 0:
                lm += (1.0 / (1.0 + np.exp(p_px - fast))) * (1.0 - min(ma, mb) / fast)
        if n == 0:
            out[e] = fc.NO_COMMON_FRAME
        else:
            t = th / n if angle else 0.0
            m = lm / n
            out[e] = np.sqrt(t * t + m * m)
    return out


def test_pair_dissimilarity_same_values():
    rng = np.random.default_rng(29)
    n, w = 300, 15
    h = rng.normal(0.0, 30.0, (n, w, 2))
    h[rng.random((n, w)) < 0.3] = np.nan
    h[rng.random((n, w)) < 0.05, 1] = np.nan  # one coordinate missing
    h[:5] = 0.0  # still features: no step
    h[5:8] = np.nan  # never seen
    pi = rng.integers(0, n, 3000)
    pj = rng.integers(0, n, 3000)
    for angle in (True, False):
        for p_px, dt in ((3.0, 0.04), (1.5, 1 / 30)):
            got = fc._pair_dissimilarity(h, pi, pj, p_px, dt, angle)
            ref = _pair_dissimilarity_ref(h, pi, pj, p_px, dt, angle)
            assert np.array_equal(got, ref)
    empty = np.zeros(0, np.int64)
    assert fc._pair_dissimilarity(h, empty, empty, 3.0, 0.04, True).shape == (0,)


def _deviation_ref(win, bg, r0, r1, c0, c1):
    d = np.abs(win[r0:r1, c0:c1].astype(np.float32) - bg[r0:r1, None, :])
    return d.max(axis=2) if d.size else np.zeros((max(r1 - r0, 0), max(c1 - c0, 0)), np.float32)


def test_grow_kernels_same_values():
    rng = np.random.default_rng(7)
    for _ in range(20):
        rows, cols = rng.integers(8, 60), rng.integers(12, 90)
        img = rng.integers(0, 256, (rows + 10, cols + 10, 3)).astype(np.uint8)
        img[:, :, 1] //= 4
        win = img[3:3 + rows, 5:5 + cols]  # a strided window, as grow_boxes cuts it
        bw = int(rng.integers(3, max(4, cols // 4)))
        bg, sigma = fc._window_background_u8(win, bw)
        strips = np.concatenate((win[:, :bw], win[:, cols - bw:]), axis=1).astype(np.float64)
        assert np.array_equal(bg, np.median(strips, axis=1).astype(np.float32))
        edge = np.concatenate((np.arange(bw), np.arange(cols - bw, cols)))
        dev_edge = np.abs(win[:, edge].astype(np.float32) - bg[:, None, :]).max(axis=2)
        assert sigma == 1.4826 * float(np.float32(np.median(dev_edge)))
        r0, r1 = sorted(rng.integers(0, rows, 2))
        c0, c1 = sorted(rng.integers(0, cols, 2))
        dev = fc._window_deviation(win, bg, r0, r1 + 1, c0, c1 + 1)
        assert np.array_equal(dev, _deviation_ref(win, bg, r0, r1 + 1, c0, c1 + 1))
        peak = fc._core_peak_u8(win, bg, r0, r1 + 1, c0, c1 + 1)
        assert np.float32(peak) == np.float32(np.percentile(dev, 90))


def _same(a, b):
    if isinstance(a, np.ndarray):
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if hasattr(a, "__dict__"):
        return type(a) is type(b) and _same(vars(a), vars(b))
    return a == b or (a != a and b != b)


def test_stage_one_grey_same_outputs(monkeypatch):
    """The stage converts the frame once and gives the grey image to the extractor and to the
    clustering; the old path (the colour frame to both, each test converting it) gives the same."""
    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import StableFeatureTracker

    scn = make_scenario("pan", seed=1, width=320, height=240, fps=25.0, duration_s=1.0)
    new = StableFeatureTracker(StableFeatureExtractor(nominal_fps=25.0), report_tentative=True, camera=scn.camera)
    old = StableFeatureTracker(StableFeatureExtractor(nominal_fps=25.0), report_tentative=True, camera=scn.camera)
    n_grey = []
    real = fc.to_grey_u8

    def counted(img, *a, **k):
        n_grey.append(1)
        return real(img, *a, **k)

    monkeypatch.setattr(fc, "to_grey_u8", counted)
    for i in range(10):
        fr = scn.render(i)
        n_grey.clear()
        d_new, t_new = new.process(fr)
        assert len(n_grey) == 1  # once a frame
        hz, zoom, prior = old.extractor_inputs(fr)
        snap = old.extractor.process(fr.image, fr.t_s, fr.index, horizon=hz, zoom=zoom, motion_prior=prior)
        assert _same(vars(snap), vars(new.last_snapshot))
        n_grey.clear()
        d_old, t_old = old.clusterer.update(snap, fr.image, horizon=hz, zoom=zoom, camera=old._frame_camera)
        assert len(n_grey) <= 1  # made at most once an update when not given
        assert _same(d_new, d_old) and _same(t_new, t_old)
