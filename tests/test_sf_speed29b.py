"""Session 29 (h35): more exact speed-ups of the default pipeline give the same values as before.

The fast paths are compared with the code they replaced (copied here as the reference) on
synthetic, seeded inputs: equal arrays, not close ones.  No new behaviour: nothing to turn on."""
import cv2
import numpy as np

from seawatch.detect import features as ft
from seawatch.detect.features import StableFeatureExtractor
from seawatch.track import feature_clusters as fc


def test_row_medians_same_values():
    rng = np.random.default_rng(35)
    for rows, cols in ((1, 1), (5, 2), (7, 7), (40, 6), (3, 13), (0, 5)):
        # blurred grey levels (multiples of 1/7, many ties) and plain floats
        a = (rng.integers(0, 256, (rows, cols)).astype(np.float32) / np.float32(7.0)).astype(np.float32)
        b = rng.normal(100.0, 30.0, (rows, cols)).astype(np.float32)
        for x in (a, b):
            got = fc._row_medians_f32(x)
            ref = np.median(x, axis=1)
            assert got.dtype == ref.dtype and np.array_equal(got, ref)
    strip = cv2.blur(rng.integers(0, 256, (30, 80)).astype(np.uint8).astype(np.float32), (7, 1))
    rr = rng.integers(0, 30, (12, 7))
    xs = rng.integers(0, 80, 12)
    assert np.array_equal(fc._row_medians_f32(strip[rr, xs[:, None]]), np.median(strip[rr, xs[:, None]], axis=1))


def test_median_of_same_values():
    rng = np.random.default_rng(36)
    for n in range(1, 30):
        for v in (rng.normal(0.0, 5.0, n), np.round(rng.normal(0.0, 5.0, n), 1)):
            assert fc._median_of(v) == np.median(v)


class _OldExtractor(StableFeatureExtractor):
    """The extractor's main pass and guided matching as at main 8c0c581 (copied)."""

    def _keypoints(self, grey, band=None):
        kps = self._star.detect(grey)
        pred = None
        act = np.flatnonzero(self._alive)
        if self.prior_radius_px > 0 and len(act):
            pred = ft._apply_h(self._h_prev, self._xy[act])
            pred = pred[np.isfinite(pred).all(axis=1)]
            if not len(pred):
                pred = None
        if band is not None and len(kps):
            y = ft._kp_xy(kps)[:, 1]
            kps = [kps[i] for i in np.flatnonzero(~((band[0] <= y) & (y < band[1])))]
        main = self._describe_main_old(grey, kps, pred)
        out = [(*main, np.zeros(len(main[0]), bool))]
        if band is not None:
            out.append(self._describe_band(grey, band, pred))
        return tuple(np.concatenate([o[i] for o in out]) for i in range(4))

    def _describe_main_old(self, grey, kps, pred):
        if not kps:
            return np.zeros((0, 2)), np.zeros(0), np.zeros((0, ft._DESC_DIM), np.float32)
        xy = ft._kp_xy(kps)
        resp = np.fromiter((k.response for k in kps), np.float64, len(kps))
        priority = self._priority(xy, pred, self.max_keypoints)
        keep = ft.select_keypoints(xy, resp, grey.shape[:2], self.max_keypoints, self.grid_cells, priority)
        ds = 1.0
        img = grey
        if 0 < self.descriptor_width_px < grey.shape[1]:
            ds = self.descriptor_width_px / grey.shape[1]
            img = cv2.resize(grey, (self.descriptor_width_px, max(1, int(round(grey.shape[0] * ds)))),
                             interpolation=cv2.INTER_AREA)
        sc = self.descriptor_scale * ds
        dxy = ((xy[keep] + 0.5) * ds - 0.5).tolist()
        kps = [cv2.KeyPoint(p[0], p[1], kps[i].size * sc, kps[i].angle, r, kps[i].octave)
               for p, i, r in zip(dxy, keep.tolist(), resp[keep].tolist())]
        kps, desc = self._sift.compute(img, kps)
        if desc is None or not kps:
            return np.zeros((0, 2)), np.zeros(0), np.zeros((0, ft._DESC_DIM), np.float32)
        xy = (ft._kp_xy(kps) + 0.5) / ds - 0.5
        size = np.fromiter((k.size for k in kps), np.float64, len(kps)) / sc
        return xy, size, np.ascontiguousarray(desc, np.float32)

    def _guided(self, desc, act, kxy, radius_px):
        """Nearest and second-nearest (index into ``act``, squared distance) among the active
        features expected within ``radius_px`` of each keypoint (see :meth:`_match`)."""
        n = len(desc)
        nn = np.full((n, 2), -1, np.int64)
        dist = np.full((n, 2), np.inf, np.float32)
        pred = ft._apply_h(self._h_prev, self._xy[act])
        fin = np.flatnonzero(np.isfinite(pred).all(axis=1))
        if len(fin) == 0:
            return nn, dist
        pairs = ft.cKDTree(kxy).sparse_distance_matrix(ft.cKDTree(pred[fin]), radius_px, output_type="ndarray")
        if len(pairs) == 0:
            return nn, dist
        qi = pairs["i"].astype(np.int64)
        ai = fin[pairs["j"].astype(np.int64)]
        sep = self.ratio_distinct_px * self._scale
        if sep > 0:
            ft._best_two_distinct(desc, self._desc, act, qi, ai, pred, sep * sep, nn, dist)
        else:
            ft._best_two(desc, self._desc, act, qi, ai, nn, dist)
        # one candidate (or none at a distinct place): the second distance is to the nearest
        # other active feature anywhere (beyond ``ratio_distinct_px`` of the nearest)
        one = np.flatnonzero((nn[:, 0] >= 0) & (nn[:, 1] < 0))
        if len(one):
            a = self._desc[act]
            d2 = (np.einsum("ij,ij->i", desc[one], desc[one])[:, None] + np.einsum("ij,ij->i", a, a)[None, :]
                  - 2.0 * (desc[one] @ a.T))
            d2[np.arange(len(one)), nn[one, 0]] = np.inf
            if sep > 0:
                gap = np.linalg.norm(pred[None, :, :] - pred[nn[one, 0]][:, None, :], axis=2)
                d2[gap <= sep] = np.inf
            dist[one, 1] = np.maximum(d2.min(axis=1), 0.0)
        near = self.near_resolve_px * self._scale
        if near > 0:
            q = ft.match_quality(dist[:, 0], dist[:, 1])
            fail = (nn[:, 0] >= 0) & (q < self.guided_min_quality)
            if fail.any():
                sel = fail[qi]
                amb = 1.0 / max(1.0 - self.guided_min_quality, 1e-6) ** 2
                nn2, dist2 = nn.copy(), dist.copy()
                ft._near_resolve(desc, self._desc, act, qi[sel], ai[sel], pred, np.ascontiguousarray(kxy, np.float64),
                              near * near, amb, nn2, dist2)
                nn[fail], dist[fail] = nn2[fail], dist2[fail]
        return nn, dist


def _state(e):
    return [e._ids, e._alive, e._xy, e._size, e._desc, e._conf, e._pos, e._vel, e._ivel]


def test_extractor_fast_paths_same_state(monkeypatch):
    """The main pass by index and the guided matching on the frame's own expected positions and
    KD-tree give the old path's features, frame by frame (with the water band and the far pass)."""
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import StableFeatureTracker

    trees = []
    real = ft.cKDTree

    def counted(*a, **k):
        trees.append(1)
        return real(*a, **k)

    scn = make_scenario("pan", seed=1, width=640, height=480, fps=25.0, duration_s=1.0)
    new = StableFeatureTracker(StableFeatureExtractor(nominal_fps=25.0), camera=scn.camera)
    old = StableFeatureTracker(_OldExtractor(nominal_fps=25.0), camera=scn.camera)
    n_new = n_old = 0
    reused = 0
    for i in range(12):
        fr = scn.render(i)
        monkeypatch.setattr(ft, "cKDTree", counted)
        trees.clear()
        new.process(fr)
        n_new += len(trees)
        trees.clear()
        old.process(fr)
        n_old += len(trees)
        monkeypatch.setattr(ft, "cKDTree", real)
        for a, b in zip(_state(new.extractor), _state(old.extractor)):
            assert a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        assert np.array_equal(new.last_snapshot.xy, old.last_snapshot.xy)
    assert n_new < n_old  # the expected positions' tree is built once a frame


def test_guided_stash_is_of_this_frame_only():
    """The positions kept by ``_keypoints`` serve only the same frame's ``_guided``."""
    e = StableFeatureExtractor(nominal_fps=25.0)
    e._frame_pred = (e._n - 1, np.zeros(0, np.int64), e._h_prev, None, None, None)  # a stale entry
    e._grow(4)
    e._alive[:3] = True
    e._xy[:3] = [[10.0, 10.0], [50.0, 50.0], [90.0, 20.0]]
    e._desc[:3] = np.eye(3, ft._DESC_DIM, dtype=np.float32)
    act = np.flatnonzero(e._alive)
    nn, dist = e._guided(np.eye(3, ft._DESC_DIM, dtype=np.float32), act,
                         np.array([[10.0, 10.0], [50.0, 51.0], [300.0, 300.0]]), 5.0)
    assert e._frame_pred is None
    assert nn[0, 0] == 0 and nn[1, 0] == 1 and nn[2, 0] == -1
