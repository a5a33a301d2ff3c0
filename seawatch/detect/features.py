"""Temporally stable image features (paper B, step 1).

CenSurE keypoints (OpenCV's ``StarDetector``) are described with SIFT and matched, frame after
frame, against the set of *active* features with a FLANN 2-nearest-neighbour search.  A match
counts when its quality ``Q = 1 - S1 / S2`` (``S1``, ``S2`` the descriptor distances to the
nearest and second-nearest active feature) is at least ``min_quality`` (0.4).  Every active
feature carries a confidence counter that goes up by one when it is matched and down by one when
it is not; a feature is *stable* from ``stable_confidence`` (5) on and is removed at 0.

The camera's own motion is estimated from the matches of the stable features (the paper takes
their mean velocity; here a RANSAC homography by default, which is exact for a camera that pans,
tilts and zooms about its centre, with the mean as the fallback and as an option).  A match
whose motion relative to the camera lies beyond ``gate_sigma`` (3) standard deviations of the
stable features' stays unmatched.  Each feature keeps a short history of its velocity relative
to the camera (pixels per second), from which the tracker
(:mod:`seawatch.track.feature_clusters`) computes motion dissimilarities.

The module is a detector-room module: it knows nothing of clusters or tracks.

Examples
--------
>>> ext = StableFeatureExtractor(max_keypoints=150)            # doctest: +SKIP
>>> snap = ext.process(grey_image, t_s=0.04)                     # doctest: +SKIP
>>> snap.xy[snap.stable]                                         # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numba as nb
import numpy as np
from scipy.spatial import cKDTree

__all__ = [
    "FeatureSnapshot",
    "StableFeatureExtractor",
    "to_grey_u8",
    "select_keypoints",
    "match_quality",
]

_DESC_DIM = 128
_MOTION_MODELS = ("auto", "similarity", "zoom_pan", "homography", "homography_magsac", "mean")


def to_grey_u8(image: np.ndarray, low_pct: float = 1.0, high_pct: float = 99.5) -> np.ndarray:
    """An 8-bit grey image from an EO (BGR) or IR (grey, 8 or 16 bit, or float) image.

    Images that are not 8-bit (IR, typically 14 or 16 bit) are stretched linearly between their
    ``low_pct`` and ``high_pct`` percentiles.

    Raises
    ------
    ValueError
        When the array is not an image (not 2-D or 3-D with 1, 3 or 4 channels, or empty).
    """
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.size == 0 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (3, 4)):
        raise ValueError(f"features: not an image, array of shape {img.shape}")
    if img.ndim == 3:
        if img.dtype != np.uint8:
            img = to_grey_u8(img.astype(np.float32).mean(axis=2), low_pct, high_pct)
            return img
        code = cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        return cv2.cvtColor(img, code)
    if img.dtype == np.uint8:
        return np.ascontiguousarray(img)
    f = img.astype(np.float32)
    finite = np.isfinite(f)
    if not finite.any():
        raise ValueError("features: image has no finite pixel")
    lo, hi = np.percentile(f[finite], [low_pct, high_pct])
    if hi <= lo:
        hi = lo + 1.0
    out = np.clip((np.where(finite, f, lo) - lo) * (255.0 / (hi - lo)), 0, 255)
    return out.astype(np.uint8)


def select_keypoints(
    xy: np.ndarray, response: np.ndarray, shape: tuple[int, int], max_keypoints: int,
    grid_cells: tuple[int, int] = (8, 6), priority: np.ndarray | None = None,
) -> np.ndarray:
    """Indices of at most ``max_keypoints`` keypoints, spread over the image.

    The image is cut into ``grid_cells`` (columns, rows); each cell first keeps its strongest
    ``ceil(max_keypoints / cells)`` keypoints (by absolute response), and the remaining budget
    goes to the strongest of the rest, so that a strongly textured coastline cannot take the
    whole budget from a weakly textured boat.

    Parameters
    ----------
    xy : (N, 2) keypoint positions (x, y) in pixels.
    response : (N,) detector responses.
    shape : (height, width) of the image.
    noise_px_s : median speed relative to the camera of the stable features seen this frame
        (most of them are static, so this measures the velocity noise; NaN when none).
    max_keypoints : int, 0 or less keeps all.
    grid_cells : (columns, rows) of the bucketing grid.
    priority : (N,) bool, optional
        Keypoints taken first (strongest first), before the grid shares out the rest of the
        budget: those where an active feature is expected, so that a feature once found keeps
        being described while the sea's short-lived keypoints compete for the remainder.

    Returns
    -------
    (M,) int index array, strongest first within the selection order.
    """
    n = len(xy)
    strength = np.abs(np.asarray(response, dtype=np.float64))
    order = np.argsort(-strength, kind="stable")
    if max_keypoints <= 0 or n <= max_keypoints:
        return order
    if priority is not None and np.any(priority):
        pri = np.asarray(priority, bool)
        first = order[pri[order]][:max_keypoints]
        rest = np.flatnonzero(~pri)
        if len(first) >= max_keypoints or len(rest) == 0:
            return first
        sub = select_keypoints(xy[rest], strength[rest], shape, max_keypoints - len(first), grid_cells)
        return np.r_[first, rest[sub]]
    gx, gy = max(1, int(grid_cells[0])), max(1, int(grid_cells[1]))
    h, w = shape
    cx = np.clip((xy[:, 0] * gx / max(w, 1)).astype(np.int64), 0, gx - 1)
    cy = np.clip((xy[:, 1] * gy / max(h, 1)).astype(np.int64), 0, gy - 1)
    cell = cy * gx + cx
    # rank of each keypoint within its cell, by strength
    srt = np.lexsort((-strength, cell))
    cell_sorted = cell[srt]
    first = np.r_[0, np.flatnonzero(np.diff(cell_sorted)) + 1]
    starts = np.repeat(first, np.diff(np.r_[first, n]))
    rank = np.empty(n, np.int64)
    rank[srt] = np.arange(n) - starts
    quota = int(np.ceil(max_keypoints / (gx * gy)))
    primary = order[rank[order] < quota]
    if len(primary) >= max_keypoints:
        return primary[:max_keypoints]
    rest = order[rank[order] >= quota]
    return np.r_[primary, rest[: max_keypoints - len(primary)]]


def match_quality(d1_sq: np.ndarray, d2_sq: np.ndarray) -> np.ndarray:
    """Match quality ``Q = 1 - S1 / S2`` from squared descriptor distances (1 when S2 is 0... or S1 is 0)."""
    s1 = np.sqrt(np.maximum(np.asarray(d1_sq, np.float64), 0.0))
    s2 = np.sqrt(np.maximum(np.asarray(d2_sq, np.float64), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        q = 1.0 - s1 / s2
    return np.where(s2 > 0, q, np.where(s1 > 0, 0.0, 1.0))


@dataclass
class FeatureSnapshot:
    """The active features after one frame.

    Attributes
    ----------
    t_s, frame_index : time and index of the frame.
    ids : (N,) int64 feature identities (unique within a run).
    slots : (N,) int64 storage slot of each feature (stable over its life, reused after it).
    xy : (N, 2) float64 positions (observed this frame, or predicted with the camera motion).
    size_px : (N,) keypoint diameters in pixels.
    confidence : (N,) int confidence counters.
    stable : (N,) bool, confidence at least the stable threshold.
    matched : (N,) bool, matched (observed) in this frame.
    velocity : (N, 2) velocity relative to the camera, px/s (NaN when not matched this frame).
    history : (N, W, 2) velocity samples relative to the camera in px/s over the last W frames,
        oldest first, the last column being this frame; NaN where the feature was not seen.
        Column ``k`` is the same frame for every feature.
    image_velocity : (N, 2) velocity in the image (camera motion included), px/s.
    homography : (3, 3) the camera motion from the previous frame to this one.
    dt_s : seconds since the previous frame.
    n_keypoints : keypoints described this frame.
    n_matched : features matched this frame.
    camera_motion_ok : whether the camera motion came from enough stable matches.
    shape : (height, width) of the image.
    noise_px_s : median speed relative to the camera of the stable features seen this frame
        (most of them are static, so this measures the velocity noise; NaN when none).
    horizon : the sea horizon the frame was processed with (None: none given).
    zoom : the camera's zoom factor given with it (1: its widest, or unknown).
    """

    t_s: float
    frame_index: int
    ids: np.ndarray
    slots: np.ndarray
    xy: np.ndarray
    size_px: np.ndarray
    confidence: np.ndarray
    stable: np.ndarray
    matched: np.ndarray
    velocity: np.ndarray
    history: np.ndarray
    image_velocity: np.ndarray
    homography: np.ndarray
    dt_s: float
    n_keypoints: int
    n_matched: int
    camera_motion_ok: bool = True
    shape: tuple[int, int] | None = None
    noise_px_s: float = float("nan")
    horizon: object | None = None
    zoom: float = 1.0

    def __len__(self) -> int:
        return len(self.ids)


@nb.njit(cache=True, nogil=True)
def _best_two(desc, stored, act, qi, ai, nn, dist):
    """Nearest and second-nearest candidate of each query among the pairs ``(qi, ai)``
    (query row, index into ``act``), by squared descriptor distance (accumulated in float64);
    ties go to the pair listed first.  Fills ``nn`` (-1: none) and ``dist`` (inf: none)."""
    dim = desc.shape[1]
    for k in range(len(qi)):
        q = qi[k]
        a = ai[k]
        s = act[a]
        acc = 0.0
        for c in range(dim):
            d = np.float64(desc[q, c]) - np.float64(stored[s, c])
            acc += d * d
        d2 = np.float32(acc)
        if nn[q, 0] < 0 or d2 < dist[q, 0]:
            nn[q, 1] = nn[q, 0]
            dist[q, 1] = dist[q, 0]
            nn[q, 0] = a
            dist[q, 0] = d2
        elif nn[q, 1] < 0 or d2 < dist[q, 1]:
            nn[q, 1] = a
            dist[q, 1] = d2


@nb.njit(cache=True, nogil=True)
def _best_two_distinct(desc, stored, act, qi, ai, pos, sep2, nn, dist):
    """As :func:`_best_two`, but the second neighbour of a query must lie more than
    ``sqrt(sep2)`` pixels from the nearest one (``pos``: (len(act), 2) positions, indexed like
    ``ai``): a second neighbour on the same image structure says nothing about ambiguity."""
    dim = desc.shape[1]
    d2s = np.empty(len(qi), np.float32)
    for k in range(len(qi)):
        q = qi[k]
        s = act[ai[k]]
        acc = 0.0
        for c in range(dim):
            d = np.float64(desc[q, c]) - np.float64(stored[s, c])
            acc += d * d
        d2 = np.float32(acc)
        d2s[k] = d2
        if nn[q, 0] < 0 or d2 < dist[q, 0]:
            nn[q, 0] = ai[k]
            dist[q, 0] = d2
    for k in range(len(qi)):
        q = qi[k]
        a = ai[k]
        b = nn[q, 0]
        if a == b:
            continue
        dx = pos[a, 0] - pos[b, 0]
        dy = pos[a, 1] - pos[b, 1]
        if dx * dx + dy * dy <= sep2:
            continue
        if nn[q, 1] < 0 or d2s[k] < dist[q, 1]:
            nn[q, 1] = a
            dist[q, 1] = d2s[k]


@nb.njit(cache=True, nogil=True)
def _near_resolve(desc, stored, act, qi, ai, pos, kxy, near2, amb, nn, dist):
    """Where a query's ratio test fails, the candidates that make it ambiguous (squared
    descriptor distance at most ``amb`` times the nearest's) are looked at: when exactly one of
    them is expected within ``sqrt(near2)`` pixels of the query's position (``pos``:
    (len(act), 2) expected positions, indexed like ``ai``), the position settles the ambiguity
    and the query is matched to it (``nn[q, 0]`` set to it, ``dist[q, 1]`` to inf)."""
    n = nn.shape[0]
    cnt = np.zeros(n, np.int64)
    pick = np.full(n, -1, np.int64)
    pd2 = np.zeros(n, np.float32)
    dim = desc.shape[1]
    for k in range(len(qi)):
        q = qi[k]
        if nn[q, 0] < 0:
            continue
        a = ai[k]
        dx = pos[a, 0] - kxy[q, 0]
        dy = pos[a, 1] - kxy[q, 1]
        if dx * dx + dy * dy > near2:
            continue
        s = act[a]
        acc = 0.0
        for c in range(dim):
            d = np.float64(desc[q, c]) - np.float64(stored[s, c])
            acc += d * d
        if acc <= amb * np.float64(dist[q, 0]) + 1e-6:
            cnt[q] += 1
            pick[q] = a
            pd2[q] = np.float32(acc)
    for q in range(n):
        if cnt[q] == 1:
            nn[q, 0] = pick[q]
            dist[q, 0] = pd2[q]
            dist[q, 1] = np.inf


def _kp_xy(kps) -> np.ndarray:
    """(N, 2) float64 positions of OpenCV keypoints (their float32 values, exactly)."""
    return cv2.KeyPoint_convert(kps).astype(np.float64).reshape(-1, 2)


def _apply_h(h: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Apply a 3x3 homography to (..., 2) points (NaN stays NaN)."""
    p = np.asarray(xy, np.float64)
    x, y = p[..., 0], p[..., 1]
    den = h[2, 0] * x + h[2, 1] * y + h[2, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (h[0, 0] * x + h[0, 1] * y + h[0, 2]) / den
        v = (h[1, 0] * x + h[1, 1] * y + h[1, 2]) / den
    return np.stack([u, v], axis=-1)


def fit_zoom_pan(
    src: np.ndarray, dst: np.ndarray, threshold_px: float = 1.0, n_iter: int = 64, seed: int = 0,
    rotation: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Robust fit of the camera's image motion ``dst = s R(phi) src + t``.

    Without ``rotation`` the model is ``dst = s * src + t`` (a camera that pans, tilts and zooms
    without rolling, seen through a narrow field of view); with it, a similarity (roll too).
    MSAC on two-point samples (pairs at least a tenth of the points' extent apart, so that the
    scale of a sample means something), each sample refined by least squares on its inliers
    (vectorised over the samples), then the best one refined once more.

    Parameters
    ----------
    src, dst : (N, 2) matched positions, N >= 2.
    threshold_px : float, inlier distance.
    n_iter : int, number of random samples.
    seed : int, seed of the sampler.
    rotation : bool, fit a rotation too.

    Returns
    -------
    h : (3, 3) homography ``[[a, -b, tx], [b, a, ty], [0, 0, 1]]`` (``b = 0`` without rotation).
    inliers : (N,) bool.
    """
    src = np.asarray(src, np.float64)
    dst = np.asarray(dst, np.float64)
    n = len(src)
    if n < 2:
        raise ValueError("fit_zoom_pan: needs at least 2 matches")
    rng = np.random.default_rng(seed)
    ia = rng.integers(0, n, n_iter)
    ib = (ia + rng.integers(1, n, n_iter)) % n
    ds = src[ib] - src[ia]
    dd = dst[ib] - dst[ia]
    nrm = np.sum(ds * ds, axis=1)
    extent = float(np.linalg.norm(src.max(axis=0) - src.min(axis=0)))
    ok = nrm > max((0.1 * extent) ** 2, 1e-12)
    if not ok.any():
        ok = nrm > 1e-12
    ds, dd, nrm, ia = ds[ok], dd[ok], nrm[ok], ia[ok]
    # sample models (a, b); the first candidate is the pure translation by the median
    a = np.r_[1.0, np.sum(ds * dd, axis=1) / nrm]
    b = np.r_[0.0, (ds[:, 0] * dd[:, 1] - ds[:, 1] * dd[:, 0]) / nrm] if rotation else np.zeros(len(a))
    if not rotation:
        a[1:] = np.sqrt(np.sum(dd * dd, axis=1) / nrm)

    def apply(a, b, t):
        x = src[None, :, 0]
        y = src[None, :, 1]
        u = a[:, None] * x - b[:, None] * y + t[:, None, 0]
        v = b[:, None] * x + a[:, None] * y + t[:, None, 1]
        return (u - dst[None, :, 0]) ** 2 + (v - dst[None, :, 1]) ** 2  # (M, N) squared errors

    sa = src[ia]
    t = np.r_[[np.median(dst - src, axis=0)],
              dst[ia] - np.stack([a[1:] * sa[:, 0] - b[1:] * sa[:, 1], b[1:] * sa[:, 0] + a[1:] * sa[:, 1]], 1)]
    thr2 = threshold_px**2

    def refine(w, a, b, t):
        """Weighted least squares of every model on its (M, N) 0/1 weights."""
        wn = w.sum(axis=1)
        safe = np.maximum(wn, 1.0)
        ms = (w @ src) / safe[:, None]
        md = (w @ dst) / safe[:, None]
        sxx = w @ np.sum(src * src, axis=1) - wn * np.sum(ms * ms, axis=1)
        sdot = w @ np.sum(src * dst, axis=1) - wn * np.sum(ms * md, axis=1)
        good = (wn >= 2) & (sxx > 1e-9)
        den = np.where(good, sxx, 1.0)
        a_new = sdot / den
        if rotation:
            cross = (w @ (src[:, 0] * dst[:, 1] - src[:, 1] * dst[:, 0])
                     - wn * (ms[:, 0] * md[:, 1] - ms[:, 1] * md[:, 0]))
            b_new = cross / den
        else:
            b_new = np.zeros_like(a_new)
        t_new = md - np.stack([a_new * ms[:, 0] - b_new * ms[:, 1], b_new * ms[:, 0] + a_new * ms[:, 1]], 1)
        return (np.where(good, a_new, a), np.where(good, b_new, b), np.where(good[:, None], t_new, t))

    for wide in (4.0, 1.0):  # local optimisation of every sample
        w = (apply(a, b, t) < wide * thr2).astype(np.float64)
        a, b, t = refine(w, a, b, t)
    err2 = apply(a, b, t)
    best = int(np.argmin(np.minimum(err2, thr2).sum(axis=1)))
    a, b, t = a[best: best + 1], b[best: best + 1], t[best: best + 1]
    inl = err2[best] < thr2
    if inl.sum() >= 2:
        a, b, t = refine(inl[None].astype(np.float64), a, b, t)
        inl = apply(a, b, t)[0] < thr2
    h = np.array([[a[0], -b[0], t[0, 0]], [b[0], a[0], t[0, 1]], [0.0, 0.0, 1.0]])
    return h, inl


class StableFeatureExtractor:
    """Extract, match and keep temporally stable features (paper B, step 1).

    Parameters
    ----------
    max_keypoints : int
        Keypoints described per frame (the SIFT descriptor cost grows with it); spread over
        the image by :func:`select_keypoints`.  0 keeps all.
    grid_cells : (int, int)
        Columns and rows of the keypoint bucketing grid.
    star_max_size, star_response_threshold, star_line_threshold_projected,
    star_line_threshold_binarized, star_suppress_nonmax_size : int
        CenSurE (``cv2.xfeatures2d.StarDetector``) parameters.  The largest filter size is kept
        small (16) because the SIFT descriptor window grows with the keypoint size.
    min_quality : float
        Match quality ``Q = 1 - S1/S2`` needed for a match (paper: 0.4).
    stable_confidence : int
        Confidence at which a feature is stable (paper: 5).
    max_confidence : int
        Cap of the confidence counter (not given in the paper), so that a feature that has
        been seen for long disappears within ``max_confidence`` frames once it stops matching.
    gate_sigma : float
        Matches whose velocity relative to the camera lies beyond this many standard deviations
        of the stable features' mean stay unmatched (paper: 3).
    gate_min_px_s : float
        Floor of that gate in px/s (the standard deviation is near 0 when all stable features
        are background; a boat must still be allowed to move).
    velocity_window_s : float
        Baseline over which a feature's velocity relative to the camera is measured (its
        position now minus its position ``velocity_window_s`` ago, carried into the current
        frame by the camera motion).  One frame interval reproduces the paper's per-frame
        velocity; a longer baseline divides the keypoint localisation noise.
    history_s : float
        Length of the velocity history kept for the dissimilarity.
    camera_motion : {"auto", "similarity", "zoom_pan", "homography", "homography_magsac", "mean"}
        Model of the camera's own motion between frames: "mean" is the paper's (the mean
        displacement of the stable features); "zoom_pan" adds the zoom, "similarity" the roll
        too (both fitted by :func:`fit_zoom_pan`); "homography" (RANSAC or MAGSAC++) is exact
        for a camera turning about its centre but ill-conditioned when the static features lie
        along a coastline; "auto" takes the similarity, or a MAGSAC++ homography when its
        inliers span at least ``homography_min_span`` of the image in both directions and it
        explains the matches better.
    homography_min_span : float
        See "auto" above (fraction of the width and of the height, 5th to 95th percentile).
    ransac_px : float
        Inlier threshold of the robust fit (working-image pixels).
    min_camera_matches : int
        Stable matches needed to fit the camera model (fewer: all matches; fewer than 4: the
        mean displacement; none: no motion).
    flann_trees, flann_checks : int
        FLANN randomised kd-tree parameters; ``flann_trees`` 0 (default) uses FLANN's linear
        (exact) index instead, which is deterministic and costs the same at a few hundred
        active features.
    nominal_fps : float
        Frame rate assumed for the first frame and when two frames share a time stamp.
    subpixel : bool
        Refine the positions of matched features to sub-pixel accuracy with Lucas-Kanade (not
        in the paper: CenSurE positions are whole pixels, and that quantisation noise is as
        large as the motion of a slow boat between two frames).
    descriptor_scale : float
        The SIFT descriptor is computed over the keypoint's size times this.  SIFT's window
        grows with the size (about 10.6 times the radius, so a 12-pixel CenSurE keypoint reads
        a 130-pixel square), and its cost with the window's area; a smaller support is cheaper
        and describes a small boat with less of the water around it.
    descriptor_width_px : int
        Width of the image the SIFT descriptors are computed on (the working image downscaled
        when wider; positions stay those of the working image).  0: the working image.  SIFT
        builds six Gaussian layers of the whole image before describing anything (8.5 ms at
        640x480 on one core, against 2 ms at 320x240), so this is what keeps the stage at
        25 frames/s at 640x480.
    prior_radius_px : float
        Keypoints within this distance (working-image pixels) of where an active feature is
        expected (its position carried by the previous frame's camera motion) are described
        first (see :func:`select_keypoints`); 0 turns the priority off.
    work_width_px : int
        Width of the working image: wider frames are downscaled (area averaging) before the
        keypoints are found, described and followed, and the results are scaled back to the
        source's pixels.  0: the source's size.  ``ransac_px`` and the ``subpixel_*`` sizes are
        in working-image pixels.
    band_px, band_above_px, band_upscale, band_threshold, band_max_keypoints, band_grid_cells
        The water-band pass (not in the paper), used when :meth:`process` is given the horizon:
        the rows from ``band_above_px`` above the horizon to ``band_px`` below it (source
        pixels) are searched for keypoints on a copy upscaled ``band_upscale`` times, with the
        CenSurE response threshold ``band_threshold`` (lower than the image's), and described
        on the band at the working resolution; the band has its own budget of
        ``band_max_keypoints`` shared out over ``band_grid_cells`` (so that neither the sun
        glint nor the image's coastline takes it).  The rest of the image is searched as
        before.  Small far boats, which carry one or no keypoint otherwise, carry several.
        ``band_px`` 0 turns it off.
    near_resolve_px : float
        Guided matching only (not in the paper; stop 16): where a keypoint fails the ratio
        test, the active features that make it ambiguous (descriptor distance within
        ``1 / (1 - guided_min_quality)`` of the nearest's) are looked at, and when exactly one
        of them is expected within ``near_resolve_px`` (source pixels) of the keypoint, the
        keypoint is matched to it: the place settles what the descriptor cannot (a small boat's
        features have nearly alike descriptors).  0 (default): the ratio test alone.
    band_margin_px : float
        Rows of context (source pixels) the water-band pass's detector sees above and below the
        band (stop 16; its keypoints are still those inside the band).  CenSurE finds nothing
        within about 1.4 times its largest filter size of an image's edge (22 px of the
        upscaled band with ``star_max_size`` 16, 11 rows of the band at ``band_upscale`` 2), so
        without it the band's top rows, from ``band_above_px`` above the horizon to about 5
        px below it where the far boats sit, are blind.  0: no context (stop 15).
    band_describe_upscaled : bool
        Describe the band's keypoints on the upscaled copy instead of the band at the working
        resolution (False; no better on the tuning seeds and about 10 ms slower per 640x480 frame).
    band_min_size_px : float
        Smallest descriptor window of a band keypoint, working-image pixels (before
        ``band_describe_upscaled``'s upscaling): a band keypoint's size times
        ``descriptor_scale`` is raised to at least this.  0 (default): its own size.
    scene_motion : bool
        When the horizon is given, fit the camera motion to the stable features above it (sky,
        coast) when there are enough of them, and to all stable features otherwise (not in the
        paper, whose mean is over all stable features, boats included).
    motion_prior : {"off", "fallback", "always"}
        Use of the camera motion predicted from the pan/tilt/zoom telemetry (the ``motion_prior``
        homography that :meth:`process` is given; not in the paper).  "off": ignored.
        "fallback" (default since session 21): where fewer than ``min_camera_matches`` stable matches lie above the horizon
        (or no horizon is given), the camera motion is the prior, moved by the median residual
        of the stable matches above the horizon that lie within ``prior_px`` of it (when there are
        ``prior_min_matches`` of them): the water's features, which drift with the waves, no
        longer vote for the camera.  "always": the same in every frame, the prior's inliers above
        the horizon being fitted by the camera model when there are ``min_camera_matches`` of
        them.  Frames without a prior keep the fit.
    prior_px : float
        Inlier distance to the prior, working-image pixels per frame, times the zoom (the
        telemetry's error grows with the focal length).
    prior_min_matches : int
        Inliers above the horizon needed to correct the prior's translation.
    guided_px : float
        Guided matching (not in the paper, whose FLANN search is over every active feature):
        a keypoint is matched against the active features expected within ``guided_px`` plus
        the velocity gate's reach (``gate_min_px_s`` times the frame interval) of it, so that
        the ratio test compares a boat's keypoint with its neighbours rather than with every
        similar blob in the image.  0: the paper's search.
    dedup_px : float
        An unmatched keypoint closer than this many pixels (strictly) to an active feature does
        not become a new feature (not in the paper, where every unmatched keypoint does; stop 14): two
        features of one point have nearly the same descriptor, so the ratio test then fails
        for both and neither matches again; on a small boat most keypoints were such
        duplicates and few features became stable.  0: the paper's rule.
    subpixel_win_px, subpixel_max_px, subpixel_min_eig : int, float, float
        Lucas-Kanade window, how far the refined position may lie from the keypoint, and the
        smallest eigenvalue of the window's gradient matrix (OpenCV's ``minEigThreshold``)
        below which the window is too flat or too edge-like to follow.
    hold_s : float
        Stability kept through a short miss (not in the paper, where an unmatched feature
        always loses one; stop 15; off by default (0); 0.2 s was tried: on the tuning seeds
        it lowered mean METE by 0.012 but raised the identity switches from 13 to 30 and cost
        about 3-8 % of the stage's time, so it is not the default): an active feature that no keypoint matches
        in a frame, but that Lucas-Kanade follows from its last position (started where the
        camera motion carries it, converging within ``subpixel_max_px`` of there, with the
        window's gradient test ``subpixel_min_eig``), keeps its confidence instead of losing
        one, moves to the followed position and gives a velocity sample from it.  It is held
        at most ``hold_s`` seconds after its last descriptor match (or its birth); then it
        decays as the paper's.  A held feature does not count as matched (``matched`` False)
        and never gains confidence.
    hold_min_confidence : int
        Confidence a feature needs to be held (1: any, newborn features too).
    hold_max_err : float
        Largest mean absolute grey-level difference between the feature's window in the last
        frame and the followed window in this one (OpenCV's LK error) for it to be held: the
        gradient test looks at the last frame only, so a window whose texture has gone (the
        sea's texture changed, the object left) still converges.  Default 10 grey levels;
        ``inf``: no limit.
    hold_velocity : bool
        Whether a held feature's followed position gives a velocity sample (True) or only
        moves it (False).
    hold_levels : int
        Pyramid levels above the image of the hold's Lucas-Kanade (OpenCV's ``maxLevel``; 0:
        the image only, which is enough when the camera motion's prediction is within a few
        pixels and costs less; the default, 0: on the tuning seeds as good as 1 and about 4 %
        less of the stage's time at 640x480).
    ratio_distinct_px : float
        The ratio test's second neighbour must lie more than this many pixels (source pixels)
        from the nearest one (not in the paper, whose second neighbour is the second-nearest
        descriptor wherever it lies; stop 16): a second neighbour on the same image structure,
        a few pixels away, has a descriptor nearly alike whether or not the match is right, and
        says nothing about ambiguity.  Positions are those expected this frame (guided matching)
        or the last ones (the paper's search, among the 8 nearest descriptors; none of them far
        enough: the farthest of the 8).  0: the paper's test.  Default 4 px: on the 12 tuning
        sequences (seeds 1, 2, 5-8 of ``pan`` and ``ir``) mean METE 0.4898 -> 0.4887 and ID
        switches 88 -> 82, a gain far below the seed-to-seed spread; 6 and 8 px give mean METE
        0.4892 and 0.4871 but raise the switches to 113 and 114.  Stop 14's ``dedup_px`` already
        keeps features 3 px apart, so below that it changes nothing.
    redetect_threshold : int
        Guided re-detection in the water band (not in the paper; stop 16, issue #8): where an
        active feature of confidence ``redetect_min_confidence`` or more is expected in the band
        (carried by the previous frame's camera motion) and no kept band keypoint lies within
        ``redetect_px`` (source pixels) of it, CenSurE is run again on a small window around it
        (upscaled ``band_upscale`` times, as the band) with this lower response threshold, and
        the keypoints it finds within ``redetect_px`` of the expected position are described and
        offered to the matching (ratio test and every other rule unchanged).  A re-detected
        keypoint that matches nothing is dropped (it does not become a new feature), so the sea
        away from the active features adds nothing.  0 (default): off.  On the 12 tuning
        sequences (seeds 1, 2, 5-8 of ``pan`` and ``ir``; defaults 0.4776 mean METE, 75 ID
        switches) threshold 3 gives 0.4888 / 104 (min confidence 2), 0.4804 / 80 (4) and
        0.4680 / 80 (4, ``redetect_px`` 2): fewer missed boats, but more reports on no boat and
        looser boxes, and never fewer switches, so it stays off.
    redetect_px : float
        See ``redetect_threshold``.
    redetect_min_confidence : int
        See ``redetect_threshold``.
    hold_band_only : bool
        Hold only the features inside the water band's rows (when :meth:`process` is given the
        horizon and ``band_px`` > 0; elsewhere, and without a horizon, every feature may be held).
        True by default: the boats are there, and Lucas-Kanade on every unmatched feature of
        the frame cost 14 % of the stage's time at 640x480.
    far_px, far_upscale, far_threshold, far_max_keypoints
        The far water at a finer scale (session 25, H21; on since session 28 with ``far_px`` 12,
        ``far_threshold`` 10, ``far_max_keypoints`` 30; ``far_px`` 0 turns it off): the band's rows from its top (``band_above_px`` above the horizon) to ``far_px``
        (source pixels) below the horizon are searched on a copy upscaled ``far_upscale`` times
        (CenSurE threshold ``far_threshold``; 0 = ``band_threshold``) instead of
        ``band_upscale`` times, and get their own budget of ``far_max_keypoints`` over one row
        of ``band_grid_cells[0]`` cells; the band below keeps its pass and budget.  A far ship
        (a 55x10 px cargo ship) has 0-3 blobs at 2x and 10-23 at 3x (H16), but the whole band
        at 3x makes the sea's blobs stable too.
    far_skip_ir
        Session 26 (H22; True, the default since session 28; False: off): the far pass (``far_px``) only on visible
        frames; a frame :meth:`process` is given with ``ir=True`` keeps the band's own pass in
        the far rows (the 3x pass with ``far_threshold`` 10 loses the far boats of the tuning
        ``ir`` sequences).
    """

    def __init__(
        self,
        *,
        max_keypoints: int = 200,
        grid_cells: tuple[int, int] = (8, 6),
        star_max_size: int = 16,
        star_response_threshold: int = 10,
        star_line_threshold_projected: int = 10,
        star_line_threshold_binarized: int = 8,
        star_suppress_nonmax_size: int = 5,
        min_quality: float = 0.4,
        stable_confidence: int = 5,
        max_confidence: int = 10,
        gate_sigma: float = 3.0,
        gate_min_px_s: float = 250.0,
        velocity_window_s: float = 0.4,
        history_s: float = 0.6,
        camera_motion: str = "similarity",
        ransac_px: float = 0.5,
        min_camera_matches: int = 8,
        flann_trees: int = 0,
        flann_checks: int = 32,
        nominal_fps: float = 25.0,
        subpixel: bool = True,
        subpixel_win_px: int = 15,
        subpixel_max_px: float = 3.0,
        subpixel_min_eig: float = 1e-3,
        work_width_px: int = 0,
        prior_radius_px: float = 3.0,
        descriptor_scale: float = 1.0,
        descriptor_width_px: int = 320,
        homography_min_span: float = 0.4,
        band_px: float = 100.0,
        band_above_px: float = 6.0,
        band_upscale: float = 2.0,
        band_threshold: int = 5,
        band_max_keypoints: int = 150,
        band_grid_cells: tuple[int, int] = (16, 2),
        scene_motion: bool = True,
        motion_prior: str = "fallback",
        prior_px: float = 1.5,
        prior_min_matches: int = 3,
        guided_px: float = 10.0,
        band_describe_upscaled: bool = False,
        band_min_size_px: float = 0.0,
        guided_min_quality: float = 0.25,
        dedup_px: float = 3.0,
        hold_s: float = 0.0,
        hold_min_confidence: int = 1,
        hold_max_err: float = 10.0,
        hold_velocity: bool = True,
        hold_band_only: bool = True,
        hold_levels: int = 0,
        ratio_distinct_px: float = 4.0,
        band_margin_px: float = 0.0,
        near_resolve_px: float = 0.0,
        redetect_threshold: int = 0,
        redetect_px: float = 3.0,
        redetect_min_confidence: int = 2,
        far_px: float = 12.0,
        far_upscale: float = 3.0,
        far_threshold: int = 10,
        far_max_keypoints: int = 30,
        far_skip_ir: bool = True,
    ) -> None:
        if camera_motion not in _MOTION_MODELS:
            raise ValueError(f"features: camera_motion must be one of {', '.join(_MOTION_MODELS)}, not {camera_motion!r}")
        if not 0.0 <= min_quality <= 1.0:
            raise ValueError(f"features: min_quality must lie in [0, 1], got {min_quality}")
        if stable_confidence < 1 or max_confidence < stable_confidence:
            raise ValueError(
                f"features: need 1 <= stable_confidence ({stable_confidence}) <= max_confidence ({max_confidence})"
            )
        if nominal_fps <= 0 or velocity_window_s < 0 or history_s < 0:
            raise ValueError("features: nominal_fps must be > 0, velocity_window_s and history_s >= 0")
        self.max_keypoints = int(max_keypoints)
        self.grid_cells = (int(grid_cells[0]), int(grid_cells[1]))
        self.min_quality = float(min_quality)
        self.stable_confidence = int(stable_confidence)
        self.max_confidence = int(max_confidence)
        self.gate_sigma = float(gate_sigma)
        self.gate_min_px_s = float(gate_min_px_s)
        self.velocity_window_s = float(velocity_window_s)
        self.history_s = float(history_s)
        self.camera_motion = camera_motion
        self.ransac_px = float(ransac_px)
        self.min_camera_matches = int(min_camera_matches)
        self.flann_trees = int(flann_trees)
        self.flann_checks = int(flann_checks)
        self.nominal_fps = float(nominal_fps)
        self.subpixel = bool(subpixel)
        self.subpixel_win_px = int(subpixel_win_px)
        self.subpixel_max_px = float(subpixel_max_px)
        self.subpixel_min_eig = float(subpixel_min_eig)
        self.work_width_px = int(work_width_px)
        self.prior_radius_px = float(prior_radius_px)
        if descriptor_scale <= 0:
            raise ValueError(f"features: descriptor_scale must be > 0, got {descriptor_scale}")
        self.descriptor_scale = float(descriptor_scale)
        self.descriptor_width_px = int(descriptor_width_px)
        self.homography_min_span = float(homography_min_span)
        if band_upscale < 1 or band_px < 0 or band_above_px < 0:
            raise ValueError("features: band_upscale must be >= 1, band_px and band_above_px >= 0")
        self.band_px = float(band_px)
        self.band_above_px = float(band_above_px)
        self.band_upscale = float(band_upscale)
        self.band_max_keypoints = int(band_max_keypoints)
        self.band_grid_cells = (int(band_grid_cells[0]), int(band_grid_cells[1]))
        self.scene_motion = bool(scene_motion)
        if motion_prior not in ("off", "fallback", "always"):
            raise ValueError(f"features: motion_prior must be off, fallback or always, not {motion_prior!r}")
        if not prior_px > 0 or prior_min_matches < 1:
            raise ValueError("features: prior_px must be > 0 and prior_min_matches >= 1")
        self.motion_prior = str(motion_prior)
        self.prior_px = float(prior_px)
        self.prior_min_matches = int(prior_min_matches)
        self.guided_px = float(guided_px)
        self.guided_min_quality = float(guided_min_quality)
        self.dedup_px = float(dedup_px)
        if hold_s < 0:
            raise ValueError(f"features: hold_s must be >= 0, got {hold_s}")
        self.hold_s = float(hold_s)
        self.hold_min_confidence = int(hold_min_confidence)
        self.hold_max_err = float(hold_max_err)
        self.hold_velocity = bool(hold_velocity)
        self.hold_band_only = bool(hold_band_only)
        self.hold_levels = int(hold_levels)
        if not ratio_distinct_px >= 0:
            raise ValueError(f"features: ratio_distinct_px must be >= 0, got {ratio_distinct_px}")
        self.ratio_distinct_px = float(ratio_distinct_px)
        if not band_margin_px >= 0:
            raise ValueError(f"features: band_margin_px must be >= 0, got {band_margin_px}")
        self.band_margin_px = float(band_margin_px)
        if not near_resolve_px >= 0:
            raise ValueError(f"features: near_resolve_px must be >= 0, got {near_resolve_px}")
        self.near_resolve_px = float(near_resolve_px)
        if redetect_threshold < 0 or not redetect_px >= 0:
            raise ValueError("features: redetect_threshold and redetect_px must be >= 0")
        self.redetect_threshold = int(redetect_threshold)
        self.redetect_px = float(redetect_px)
        self.redetect_min_confidence = int(redetect_min_confidence)
        self._redetect_star = None
        if self.redetect_threshold > 0:
            self._redetect_star = cv2.xfeatures2d.StarDetector_create(
                int(star_max_size), int(redetect_threshold), int(star_line_threshold_projected),
                int(star_line_threshold_binarized), int(star_suppress_nonmax_size),
            )
        self._star_max_size = int(star_max_size)
        if not far_px >= 0 or far_upscale < 1 or far_threshold < 0 or far_max_keypoints < 0:
            raise ValueError("features: far_px, far_threshold, far_max_keypoints must be >= 0, far_upscale >= 1")
        self.far_px = float(far_px)
        self.far_skip_ir = bool(far_skip_ir)
        self.far_upscale = float(far_upscale)
        self.far_max_keypoints = int(far_max_keypoints)
        self._far_star = None
        if self.far_px > 0:
            self._far_star = cv2.xfeatures2d.StarDetector_create(
                int(star_max_size), int(far_threshold or band_threshold), int(star_line_threshold_projected),
                int(star_line_threshold_binarized), int(star_suppress_nonmax_size),
            )
        self.band_describe_upscaled = bool(band_describe_upscaled)
        self.band_min_size_px = float(band_min_size_px)
        self._band_star = cv2.xfeatures2d.StarDetector_create(
            int(star_max_size), int(band_threshold), int(star_line_threshold_projected),
            int(star_line_threshold_binarized), int(star_suppress_nonmax_size),
        )
        self._star = cv2.xfeatures2d.StarDetector_create(
            int(star_max_size), int(star_response_threshold), int(star_line_threshold_projected),
            int(star_line_threshold_binarized), int(star_suppress_nonmax_size),
        )
        self._sift = cv2.SIFT_create()
        # frames kept in the position ring (velocity baseline) and in the velocity ring
        self._k = max(2, int(round(self.velocity_window_s * self.nominal_fps)) + 1)
        self._w = max(1, int(round(self.history_s * self.nominal_fps)))
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget every feature (e.g. after a cut in the video)."""
        self._cap = 0
        self._ids = np.zeros(0, np.int64)
        self._alive = np.zeros(0, bool)
        self._xy = np.zeros((0, 2))
        self._size = np.zeros(0)
        self._desc = np.zeros((0, _DESC_DIM), np.float32)
        self._conf = np.zeros(0, np.int32)
        self._tmatch = np.zeros(0)  # time of each feature's last descriptor match (or birth)
        self._pos = np.zeros((0, self._k, 2))  # past observed positions, in current-frame pixels
        self._vel = np.zeros((0, self._w, 2))  # velocity samples, px/s
        self._ivel = np.zeros((0, 2))
        self._tpos = np.full(self._k, np.nan)  # time of each position-ring column
        self._next_id = 0
        self._n = 0  # frames processed
        self._t_prev: float | None = None
        self._shape: tuple[int, int] | None = None
        self._grey_prev: np.ndarray | None = None
        self._scale = 1.0
        self._h_prev = np.eye(3)
        self._far_row = None  # the working-image row where the far water (``far_px``) ends
        self._pred_tree = None  # (expected positions, their cKDTree) of the frame being processed
        self._frame_pred = None  # (frame count, active slots, motion, expected positions, finite rows, finite positions)

    def _grow(self, need: int) -> None:
        if need <= self._cap:
            return
        new = max(need, 2 * self._cap, 256)
        extra = new - self._cap

        def pad(a, fill, *tail, dtype=None):
            return np.concatenate([a, np.full((extra, *tail), fill, dtype=dtype or a.dtype)])

        self._ids = pad(self._ids, -1)
        self._alive = pad(self._alive, False)
        self._xy = pad(self._xy, np.nan, 2)
        self._size = pad(self._size, 0.0)
        self._desc = pad(self._desc, 0.0, _DESC_DIM)
        self._conf = pad(self._conf, 0)
        self._tmatch = pad(self._tmatch, -np.inf)
        self._pos = pad(self._pos, np.nan, self._k, 2)
        self._vel = pad(self._vel, np.nan, self._w, 2)
        self._ivel = pad(self._ivel, np.nan, 2)
        self._cap = new

    @property
    def n_active(self) -> int:
        """Number of active features."""
        return int(self._alive.sum())

    # ---------------------------------------------------------------- helpers
    def _keypoints(self, grey: np.ndarray, band: tuple[int, int] | None = None):
        """Keypoints of the working image (positions, sizes, SIFT descriptors), with the rows
        ``band = (y0, y1)`` searched by the water-band pass instead when given."""
        kps = self._star.detect(grey)
        pred = None
        act = np.flatnonzero(self._alive)
        self._frame_pred = None
        if self.prior_radius_px > 0 and len(act):
            full = _apply_h(self._h_prev, self._xy[act])  # the camera keeps its motion
            fin = np.flatnonzero(np.isfinite(full).all(axis=1))
            pred = full[fin]
            # kept for :meth:`_guided` of the same frame (the same active features and motion)
            self._frame_pred = (self._n, act, self._h_prev, full, fin, pred)
            if not len(pred):
                pred = None
        kxy = _kp_xy(kps) if kps else np.zeros((0, 2))
        sel = None  # the keypoints outside the band (indices into ``kps``), all when None
        if band is not None and len(kps):
            y = kxy[:, 1]
            sel = np.flatnonzero(~((band[0] <= y) & (y < band[1])))
        main = self._describe_main(grey, kps, kxy, sel, pred)
        out = [(*main, np.zeros(len(main[0]), bool))]
        if band is not None:
            out.append(self._describe_band(grey, band, pred))
        return tuple(np.concatenate([o[i] for o in out]) for i in range(4))

    def _priority(self, xy: np.ndarray, pred: np.ndarray | None, budget: int) -> np.ndarray | None:
        if pred is None or not (len(xy) > budget > 0):
            return None
        if self._pred_tree is None or self._pred_tree[0] is not pred:  # one tree a frame (main and band pass)
            self._pred_tree = (pred, cKDTree(pred))
        d, _ = self._pred_tree[1].query(xy, k=1, distance_upper_bound=self.prior_radius_px)
        return np.isfinite(d)

    def _describe_main(self, grey: np.ndarray, kps, kxy, sel, pred):
        """The main pass's keypoints ``kps`` (positions ``kxy``), those of indices ``sel`` only
        when given, selected and described."""
        if sel is not None:
            xy = kxy[sel]
            resp = np.fromiter((kps[i].response for i in sel.tolist()), np.float64, len(sel))
        else:
            xy = kxy
            resp = np.fromiter((k.response for k in kps), np.float64, len(kps))
        if not len(xy):
            return np.zeros((0, 2)), np.zeros(0), np.zeros((0, _DESC_DIM), np.float32)
        priority = self._priority(xy, pred, self.max_keypoints)
        keep = select_keypoints(xy, resp, grey.shape[:2], self.max_keypoints, self.grid_cells, priority)
        # describe on a smaller copy when asked: SIFT's fixed cost (its Gaussian layers) and
        # its per-keypoint cost both scale with the pixels it reads
        ds = 1.0
        img = grey
        if 0 < self.descriptor_width_px < grey.shape[1]:
            ds = self.descriptor_width_px / grey.shape[1]
            img = cv2.resize(grey, (self.descriptor_width_px, max(1, int(round(grey.shape[0] * ds)))),
                             interpolation=cv2.INTER_AREA)
        sc = self.descriptor_scale * ds
        dxy = ((xy[keep] + 0.5) * ds - 0.5).tolist()
        src = keep if sel is None else sel[keep]  # indices into ``kps``
        kps = [cv2.KeyPoint(p[0], p[1], kps[i].size * sc, kps[i].angle, r, kps[i].octave)
               for p, i, r in zip(dxy, src.tolist(), resp[keep].tolist())]
        kps, desc = self._sift.compute(img, kps)
        if desc is None or not kps:
            return np.zeros((0, 2)), np.zeros(0), np.zeros((0, _DESC_DIM), np.float32)
        xy = (_kp_xy(kps) + 0.5) / ds - 0.5
        size = np.fromiter((k.size for k in kps), np.float64, len(kps)) / sc
        return xy, size, np.ascontiguousarray(desc, np.float32)

    def _describe_band(self, grey: np.ndarray, band: tuple[int, int], pred):
        """The water-band pass: keypoints found on the band upscaled ``band_upscale`` times
        with the lower threshold, described on the band at the working resolution."""
        empty = np.zeros((0, 2)), np.zeros(0), np.zeros((0, _DESC_DIM), np.float32), np.zeros(0, bool)
        y0, y1 = band
        up = self.band_upscale
        crop = grey[y0:y1]
        if crop.shape[0] < 4:
            return empty
        # the detector sees ``band_margin_px`` more rows above and below (CenSurE finds nothing
        # within about its largest filter of the image's edge), and keeps the band's keypoints
        m = int(np.ceil(self.band_margin_px * self._scale))
        d0, d1 = max(0, y0 - m), min(grey.shape[0], y1 + m)
        dcrop = grey[d0:d1]
        big = dcrop if up == 1 else cv2.resize(dcrop, None, fx=up, fy=up, interpolation=cv2.INTER_LINEAR)
        kps = self._band_star.detect(big)
        if not kps and self._redetect_star is None:
            return empty
        kxy = _kp_xy(kps) if kps else np.zeros((0, 2))
        xy = (kxy + 0.5) / up - 0.5
        xy[:, 1] += d0
        size = np.fromiter((k.size for k in kps), np.float64, len(kps)) / up
        resp = np.fromiter((k.response for k in kps), np.float64, len(kps))
        if m > 0:
            row = np.floor(kxy[:, 1] / up) + d0  # the working-image row of each keypoint
            inb = (row >= y0) & (row < y1)
            xy, size, resp = xy[inb], size[inb], resp[inb]
        yf = self._far_row if self._far_star is not None else None
        if yf is not None and not y0 < yf:
            yf = None
        if yf is not None:  # the far rows go to the finer pass below
            near = xy[:, 1] >= yf
            xy, size, resp = xy[near], size[near], resp[near]
        priority = self._priority(xy, pred, self.band_max_keypoints)
        keep = select_keypoints(xy - [0.0, y0], resp, crop.shape[:2], self.band_max_keypoints,
                                self.band_grid_cells, priority) if len(xy) else np.zeros(0, np.int64)
        if yf is not None:
            fxy, fsize, fresp, fkeep = self._far_keypoints(grey, y0, yf, m, pred)
            if len(fkeep):
                n0 = len(xy)
                xy = np.concatenate([xy, fxy])
                size = np.concatenate([size, fsize])
                resp = np.concatenate([resp, fresp])
                keep = np.r_[keep, n0 + fkeep]
        # guided re-detection (``redetect_threshold``): marked by class_id 1
        cls = np.zeros(len(keep), np.int64)
        if self._redetect_star is not None:
            rxy, rsize, rresp = self._redetect(grey, band, xy[keep])
            if len(rxy):
                n0 = len(xy)
                xy = np.concatenate([xy, rxy])
                size = np.concatenate([size, rsize])
                resp = np.concatenate([resp, rresp])
                keep = np.r_[keep, n0 + np.arange(len(rxy))]
                cls = np.r_[cls, np.ones(len(rxy), np.int64)]
        if not len(keep):
            return empty
        # describe with some rows of context above and below, on the band at the working
        # resolution or upscaled (``band_describe_upscaled``)
        pad = 16
        c0, c1 = max(0, y0 - pad), min(grey.shape[0], y1 + pad)
        sc = self.descriptor_scale
        f = up if self.band_describe_upscaled else 1.0
        img = grey[c0:c1]
        if f != 1.0:
            img = cv2.resize(img, None, fx=f, fy=f, interpolation=cv2.INTER_LINEAR)
        dsz = np.maximum(size * sc, self.band_min_size_px) * f
        px = ((xy[keep, 0] + 0.5) * f - 0.5).tolist()
        py = ((xy[keep, 1] - c0 + 0.5) * f - 0.5).tolist()
        dk = [cv2.KeyPoint(x, y, d, -1, r, 0, c)
              for x, y, d, r, c in zip(px, py, dsz[keep].tolist(), resp[keep].tolist(), cls.tolist())]
        dk, desc = self._sift.compute(img, dk)
        if desc is None or not dk:
            return empty
        xy = (_kp_xy(dk) + 0.5) / f - 0.5 + [0.0, c0]
        size = np.fromiter((k.size for k in dk), np.float64, len(dk)) / (sc * f)
        rescued = np.fromiter((k.class_id == 1 for k in dk), bool, len(dk))
        return xy, size, np.ascontiguousarray(desc, np.float32), rescued

    def _far_keypoints(self, grey: np.ndarray, y0: int, yf: int, m: int, pred):
        """The far water's keypoints (``far_px``): rows ``y0`` to ``yf`` of the working image
        searched on a copy upscaled ``far_upscale`` times (with ``m`` rows of context above, as
        the band, and enough below that the split adds no blind rows), kept by their own budget
        over one row of cells.  Returns positions, sizes, responses and the kept indices."""
        up = self.far_upscale
        ctx = int(np.ceil(1.5 * self._star_max_size / up)) + 2
        d0, d1 = max(0, y0 - m), min(grey.shape[0], yf + ctx)
        none = np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0, np.int64)
        if d1 - d0 < 4 or self.far_max_keypoints <= 0:
            return none
        dcrop = grey[d0:d1]
        big = dcrop if up == 1 else cv2.resize(dcrop, None, fx=up, fy=up, interpolation=cv2.INTER_LINEAR)
        kps = self._far_star.detect(big)
        if not kps:
            return none
        kxy = _kp_xy(kps)
        xy = (kxy + 0.5) / up - 0.5
        xy[:, 1] += d0
        size = np.fromiter((k.size for k in kps), np.float64, len(kps)) / up
        resp = np.fromiter((k.response for k in kps), np.float64, len(kps))
        row = np.floor(kxy[:, 1] / up) + d0
        inf = (row >= y0) & (xy[:, 1] < yf)
        xy, size, resp = xy[inf], size[inf], resp[inf]
        if not len(xy):
            return none
        priority = self._priority(xy, pred, self.far_max_keypoints)
        keep = select_keypoints(xy - [0.0, y0], resp, (yf - y0, grey.shape[1]), self.far_max_keypoints,
                                (self.band_grid_cells[0], 1), priority)
        return xy, size, resp, keep

    def _redetect(self, grey: np.ndarray, band: tuple[int, int], kept: np.ndarray):
        """Guided re-detection (``redetect_threshold`` > 0): keypoints (working-image positions,
        sizes, responses) found with the lower threshold within ``redetect_px`` of where an active
        feature of confidence ``redetect_min_confidence`` or more is expected in the band and no
        kept band keypoint (``kept``) lies within ``redetect_px``.  The detector runs on the
        windows around those positions only (neighbouring windows merged), upscaled as the band."""
        empty = np.zeros((0, 2)), np.zeros(0), np.zeros(0)
        act = np.flatnonzero(self._alive & (self._conf >= self.redetect_min_confidence))
        if not len(act):
            return empty
        y0, y1 = band
        pred = _apply_h(self._h_prev, self._xy[act])
        pred = pred[np.isfinite(pred).all(axis=1)]
        pred = pred[(pred[:, 1] >= y0) & (pred[:, 1] < y1)]
        r = self.redetect_px * self._scale
        if len(pred) and len(kept):
            d, _ = cKDTree(kept).query(pred, k=1, distance_upper_bound=r)
            pred = pred[~np.isfinite(d)]
        if not len(pred):
            return empty
        up = self.band_upscale
        # context: CenSurE finds nothing within about 1.4 times its largest filter of an edge
        b = r + 1.5 * self._star_max_size / up + 2.0
        p = pred[np.argsort(pred[:, 0])]
        lo, hi = p[:, 0] - b, p[:, 0] + b
        start = np.r_[True, lo[1:] > np.maximum.accumulate(hi)[:-1]]  # windows that overlap merge
        grp = np.cumsum(start) - 1
        h_img, w_img = grey.shape[:2]
        out_xy, out_size, out_resp = [], [], []
        for g in range(int(grp[-1]) + 1):
            q = p[grp == g]
            c0, c1 = max(0, int(np.floor(q[:, 0].min() - b))), min(w_img, int(np.ceil(q[:, 0].max() + b)) + 1)
            r0, r1 = max(0, int(np.floor(q[:, 1].min() - b))), min(h_img, int(np.ceil(q[:, 1].max() + b)) + 1)
            if c1 - c0 < 4 or r1 - r0 < 4:
                continue
            win = grey[r0:r1, c0:c1]
            big = win if up == 1 else cv2.resize(win, None, fx=up, fy=up, interpolation=cv2.INTER_LINEAR)
            kps = self._redetect_star.detect(big)
            if not kps:
                continue
            kxy = (_kp_xy(kps) + 0.5) / up - 0.5 + [c0, r0]
            row = np.floor(_kp_xy(kps)[:, 1] / up) + r0
            d2 = np.sum((kxy[:, None, :] - q[None, :, :]) ** 2, axis=2)
            ok = (d2.min(axis=1) <= r * r) & (row >= y0) & (row < y1)
            if not ok.any():
                continue
            ix = np.flatnonzero(ok)
            out_xy.append(kxy[ix])
            out_size.append(np.array([kps[i].size for i in ix.tolist()]) / up)
            out_resp.append(np.array([kps[i].response for i in ix.tolist()]))
        if not out_xy:
            return empty
        return np.concatenate(out_xy), np.concatenate(out_size), np.concatenate(out_resp)

    def _match(self, desc: np.ndarray, act: np.ndarray, kxy: np.ndarray | None = None,
               radius_px: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(query index, active slot) of the matches passing the quality test, one per slot.

        With ``kxy`` and ``radius_px`` > 0 (guided matching), a keypoint's nearest and
        second-nearest descriptors are sought among the active features expected (carried by
        the previous camera motion) within ``radius_px`` of it; with one such candidate the
        second distance is that to the nearest other active feature anywhere."""
        if len(act) < 2 or len(desc) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        min_q = self.min_quality
        if kxy is not None and radius_px > 0:
            nn, dist = self._guided(desc, act, kxy, radius_px)
            min_q = self.guided_min_quality
        else:
            # FLANN's linear index is exact and deterministic (the randomised kd-trees are
            # neither, and cost the same at a few hundred features)
            algo = dict(algorithm=1, trees=self.flann_trees) if self.flann_trees > 0 else dict(algorithm=0)
            index = cv2.flann_Index(self._desc[act], algo)
            sep = self.ratio_distinct_px * self._scale
            kk = min(len(act), 8) if sep > 0 else 2
            nn, dist = index.knnSearch(desc, kk, params=dict(checks=self.flann_checks))
            nn = nn.astype(np.int64)
            if sep > 0:  # the second neighbour: the nearest beyond ``sep`` of the nearest
                # (none among the ``kk``: the farthest of them, which can only lower Q)
                pos = self._xy[act]
                gap = np.linalg.norm(pos[np.maximum(nn, 0)] - pos[np.maximum(nn[:, :1], 0)], axis=2)
                far = (gap > sep) & (nn >= 0)
                far[:, 0] = False
                j = np.where(far.any(axis=1), np.argmax(far, axis=1), kk - 1)
                rows = np.arange(len(nn))
                nn = np.stack([nn[:, 0], nn[rows, j]], axis=1)
                dist = np.stack([dist[:, 0], dist[rows, j]], axis=1)
        q = match_quality(dist[:, 0], dist[:, 1])
        ok = (q >= min_q) & (nn[:, 0] >= 0)
        qi = np.flatnonzero(ok)
        if len(qi) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        ti = nn[qi, 0]
        d1 = dist[qi, 0]
        # one query per active feature: the nearest
        srt = np.lexsort((d1, ti))
        ti_s = ti[srt]
        first = np.r_[True, ti_s[1:] != ti_s[:-1]]
        sel = srt[first]
        return qi[sel], act[ti[sel]]

    def _guided(self, desc, act, kxy, radius_px):
        """Nearest and second-nearest (index into ``act``, squared distance) among the active
        features expected within ``radius_px`` of each keypoint (see :meth:`_match`)."""
        n = len(desc)
        nn = np.full((n, 2), -1, np.int64)
        dist = np.full((n, 2), np.inf, np.float32)
        fp, self._frame_pred = self._frame_pred, None
        if fp is not None and fp[0] == self._n and fp[2] is self._h_prev and np.array_equal(fp[1], act):
            # the expected positions :meth:`_keypoints` computed this frame, and their tree
            # when :meth:`_priority` built one (the same points: the same tree)
            pred, fin, pfin = fp[3:]
            tree = self._pred_tree[1] if self._pred_tree is not None and self._pred_tree[0] is pfin else None
        else:
            pred = _apply_h(self._h_prev, self._xy[act])
            fin = np.flatnonzero(np.isfinite(pred).all(axis=1))
            tree = None
        if len(fin) == 0:
            return nn, dist
        if tree is None:
            tree = cKDTree(pred[fin])
        pairs = cKDTree(kxy).sparse_distance_matrix(tree, radius_px, output_type="ndarray")
        if len(pairs) == 0:
            return nn, dist
        qi = pairs["i"].astype(np.int64)
        ai = fin[pairs["j"].astype(np.int64)]
        sep = self.ratio_distinct_px * self._scale
        if sep > 0:
            _best_two_distinct(desc, self._desc, act, qi, ai, pred, sep * sep, nn, dist)
        else:
            _best_two(desc, self._desc, act, qi, ai, nn, dist)
        # one candidate (or none at a distinct place): the second distance is to the nearest
        # other active feature anywhere (beyond ``ratio_distinct_px`` of the nearest)
        one = np.flatnonzero((nn[:, 0] >= 0) & (nn[:, 1] < 0))
        if len(one):
            a = self._desc[act]
            d2 = (np.einsum("ij,ij->i", desc[one], desc[one])[:, None] + np.einsum("ij,ij->i", a, a)[None, :]
                  - 2.0 * (desc[one] @ a.T))
            d2[np.arange(len(one)), nn[one, 0]] = np.inf
            if sep > 0:
                # np.linalg.norm(pred[None, :, :] - pred[nn[one, 0]][:, None, :], axis=2)'s values
                # (the root of dx * dx + dy * dy), without its (one, act, 2) temporary
                p1 = pred[nn[one, 0]]
                gx = pred[None, :, 0] - p1[:, 0, None]
                gy = pred[None, :, 1] - p1[:, 1, None]
                gx *= gx
                gy *= gy
                gx += gy
                d2[np.sqrt(gx, out=gx) <= sep] = np.inf
            dist[one, 1] = np.maximum(d2.min(axis=1), 0.0)
        near = self.near_resolve_px * self._scale
        if near > 0:
            q = match_quality(dist[:, 0], dist[:, 1])
            fail = (nn[:, 0] >= 0) & (q < self.guided_min_quality)
            if fail.any():
                sel = fail[qi]
                amb = 1.0 / max(1.0 - self.guided_min_quality, 1e-6) ** 2
                nn2, dist2 = nn.copy(), dist.copy()
                _near_resolve(desc, self._desc, act, qi[sel], ai[sel], pred, np.ascontiguousarray(kxy, np.float64),
                              near * near, amb, nn2, dist2)
                nn[fail], dist[fail] = nn2[fail], dist2[fail]
        return nn, dist

    def _camera_motion(self, src: np.ndarray, dst: np.ndarray, stable: np.ndarray,
                       scene: np.ndarray | None = None) -> tuple[np.ndarray, bool]:
        """Homography of the camera motion from matched (src -> dst) positions; fitted to the
        stable matches of the ``scene`` (above the horizon) when there are enough of them."""
        eye = np.eye(3)
        ok = bool(stable.sum() >= self.min_camera_matches)
        use = stable if ok else np.ones(len(src), bool)
        if scene is not None and (stable & scene).sum() >= self.min_camera_matches:
            use = stable & scene
        s, d = src[use], dst[use]
        if len(s) == 0:
            return eye, False
        mean_h = eye.copy()
        mean_h[:2, 2] = np.mean(d - s, axis=0) if self.camera_motion == "mean" else np.median(d - s, axis=0)
        if self.camera_motion == "mean" or len(s) < 4:
            return mean_h, ok and self.camera_motion == "mean"
        if self.camera_motion in ("zoom_pan", "similarity", "auto"):
            h, inl = fit_zoom_pan(s, d, self.ransac_px, seed=self._n, rotation=self.camera_motion != "zoom_pan")
            if inl.sum() < 3:
                return mean_h, False
            if self.camera_motion == "auto":
                h = self._maybe_homography(s, d, h, inl)
        else:
            s32, d32 = s.astype(np.float32), d.astype(np.float32)
            if len(s) < 8:
                return mean_h, False
            method = cv2.USAC_MAGSAC if self.camera_motion == "homography_magsac" else cv2.RANSAC
            h, inl = cv2.findHomography(s32, d32, method, self.ransac_px, maxIters=500, confidence=0.995)
            if h is None or not np.all(np.isfinite(h)) or inl is None or inl.sum() < 4:
                return mean_h, False
        h = h / h[2, 2]
        # reject degenerate fits (a camera does not flip, shear strongly or zoom 2x in a frame)
        det = np.linalg.det(h[:2, :2])
        if not (0.5 < det < 2.0) or abs(h[2, 0]) > 1e-2 or abs(h[2, 1]) > 1e-2:
            return mean_h, False
        return h, ok

    def _prior_motion(self, prior: np.ndarray, src: np.ndarray, dst: np.ndarray, stable: np.ndarray,
                      scene: np.ndarray | None, zoom: float) -> tuple[np.ndarray, bool]:
        """The camera motion with a telemetry prior (``motion_prior`` "fallback" or "always"):
        only the stable matches above the horizon that agree with the prior within ``prior_px``
        (times the zoom) vote; enough of them (``min_camera_matches``) are fitted by the camera
        model ("always"; "fallback" fits all stable matches above the horizon as without a
        prior), fewer move the prior by their median residual, none leave it as it is."""
        above = stable if scene is None else stable & scene
        if self.motion_prior == "fallback" and scene is not None and above.sum() >= self.min_camera_matches:
            return self._camera_motion(src, dst, stable, scene)
        if scene is None:  # without a horizon nothing tells the scene from the water
            above = np.zeros_like(stable)
        res = dst - _apply_h(prior, src)
        inl = above & (np.linalg.norm(res, axis=1) <= self.prior_px * zoom)
        if self.motion_prior == "always" and inl.sum() >= self.min_camera_matches:
            h, ok = self._camera_motion(src[inl], dst[inl], np.ones(int(inl.sum()), bool))
            if ok:
                return h, True
        h = prior.copy()
        if inl.sum() >= self.prior_min_matches:
            shift = np.median(res[inl], axis=0)
            h = np.array([[1.0, 0.0, shift[0]], [0.0, 1.0, shift[1]], [0.0, 0.0, 1.0]]) @ h
        return h, True

    def _maybe_homography(self, s: np.ndarray, d: np.ndarray, h_sim: np.ndarray, inl: np.ndarray) -> np.ndarray:
        """The similarity, or a homography where the static features cover enough of the image
        to pin its perspective terms down and it explains the matches better.

        A camera turning about its centre moves the image by a homography; over a wide field of
        view the similarity misses its perspective part (the image moves faster at the edges),
        and neighbouring static features then share a false residual motion.  But a homography
        fitted to features along a thin coastline is unconstrained away from it.
        """
        if len(s) < 12 or self._shape is None:
            return h_sim
        hh, hin = cv2.findHomography(s.astype(np.float32), d.astype(np.float32), cv2.USAC_MAGSAC,
                                     self.ransac_px, maxIters=500, confidence=0.995)
        if hh is None or not np.all(np.isfinite(hh)) or hin is None or hin.sum() < 12:
            return h_sim
        pts = s[hin.reshape(-1).astype(bool)]
        h_img, w_img = self._shape[0] * self._scale, self._shape[1] * self._scale
        span = np.percentile(pts, 95, axis=0) - np.percentile(pts, 5, axis=0)
        if span[0] < self.homography_min_span * w_img or span[1] < self.homography_min_span * h_img:
            return h_sim
        thr2 = self.ransac_px**2

        def cost(h):
            e = _apply_h(h, s) - d
            return float(np.minimum(np.sum(e * e, axis=1), thr2).sum())

        return hh / hh[2, 2] if cost(hh) < cost(h_sim) else h_sim

    def _refine(self, prev: np.ndarray, grey: np.ndarray, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """Sub-pixel positions of matched features: pyramidal Lucas-Kanade from their previous
        position, started at the matched keypoint.  Where LK fails or strays, the keypoint's
        position is kept and ``ok`` is False (the feature's past positions are then dropped, so
        that the jump does not read as motion)."""
        p0 = src.astype(np.float32).reshape(-1, 1, 2)
        p1 = dst.astype(np.float32).reshape(-1, 1, 2).copy()
        if not (np.isfinite(p0).all() and np.isfinite(p1).all()):
            return dst, np.zeros(len(dst), bool)
        p1, status, _ = cv2.calcOpticalFlowPyrLK(
            prev, grey, p0, p1, winSize=(self.subpixel_win_px, self.subpixel_win_px), maxLevel=1,
            criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 10, 0.01),
            flags=cv2.OPTFLOW_USE_INITIAL_FLOW, minEigThreshold=self.subpixel_min_eig,
        )
        p1 = p1.reshape(-1, 2).astype(np.float64)
        ok = (status.reshape(-1) == 1) & (np.linalg.norm(p1 - dst, axis=1) <= self.subpixel_max_px)
        out = dst.copy()
        out[ok] = p1[ok]
        return out, ok

    def _hold(self, act: np.ndarray, si: np.ndarray, h: np.ndarray, grey: np.ndarray, t_s: float,
              rows: tuple[int, int] | None = None):
        """Active features not matched this frame that Lucas-Kanade follows from their last
        position (``hold_s`` > 0; not in the paper): slots and their positions in this frame.

        A feature is held at most ``hold_s`` seconds after its last descriptor match (or its
        birth); LK starts at the position the camera motion carries it to, and must converge
        (OpenCV's status, the window's smallest gradient eigenvalue at least
        ``subpixel_min_eig``) within ``subpixel_max_px`` of that position."""
        none = np.zeros(0, np.int64), np.zeros((0, 2))
        if self.hold_s <= 0 or self._grey_prev is None or not act.size:
            return none
        um = np.setdiff1d(act, si, assume_unique=True)
        um = um[(t_s - self._tmatch[um] <= self.hold_s + 1e-9) & (self._conf[um] >= self.hold_min_confidence)]
        if rows is not None:  # only the water band's features (working-image rows y0 <= y < y1)
            y = self._xy[um, 1]
            um = um[(y >= rows[0]) & (y < rows[1])]
        if not len(um):
            return none
        src = self._xy[um]
        dst = _apply_h(h, src)
        fin = np.isfinite(src).all(axis=1) & np.isfinite(dst).all(axis=1)
        um, src, dst = um[fin], src[fin], dst[fin]
        if not len(um):
            return none
        p1, status, err = cv2.calcOpticalFlowPyrLK(
            self._grey_prev, grey, src.astype(np.float32).reshape(-1, 1, 2),
            dst.astype(np.float32).reshape(-1, 1, 2).copy(),
            winSize=(self.subpixel_win_px, self.subpixel_win_px), maxLevel=self.hold_levels,
            criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 10, 0.01),
            flags=cv2.OPTFLOW_USE_INITIAL_FLOW, minEigThreshold=self.subpixel_min_eig,
        )
        p1 = p1.reshape(-1, 2).astype(np.float64)
        ok = (status.reshape(-1) == 1) & (np.linalg.norm(p1 - dst, axis=1) <= self.subpixel_max_px)
        ok &= err.reshape(-1) <= self.hold_max_err
        return um[ok], p1[ok]

    # ----------------------------------------------------------------- main
    def process(self, image: np.ndarray, t_s: float, frame_index: int | None = None,
                horizon=None, zoom: float = 1.0, motion_prior=None, ir: bool = False) -> FeatureSnapshot:
        """Detect, describe and match the features of one frame; update the active set.

        Parameters
        ----------
        image : (H, W, 3) BGR uint8, or (H, W) grey (uint8, uint16 or float for IR).
        t_s : float, time of the frame in seconds (increasing).
        frame_index : int, optional; defaults to the number of frames processed.
        horizon : optional, the sea horizon in source pixels: anything with ``row_at(x)``
            (:class:`seawatch.detect.horizon.Horizon`).  With it, the water band below it gets
            its own keypoint pass (``band_*``) and the camera motion is fitted to the scene
            above it first (``scene_motion``); None: the paper's single pass.
        zoom : float, the camera's zoom factor (1 at its widest), kept in the snapshot for the
            clustering's water margin.
        motion_prior : (3, 3) array, optional: the camera's image motion from the previous frame
            to this one predicted from its telemetry, in source pixels (e.g.
            :meth:`seawatch.camera.model.CameraModel.rotation_homography`); used as the
            ``motion_prior`` setting says.
        ir : whether the frame is infrared (only ``far_skip_ir`` uses it).

        Raises
        ------
        ValueError
            When the image is not an image, or ``motion_prior`` is not a finite 3x3 homography
            (the extractor's state is then unchanged).
        """
        full = to_grey_u8(image)
        if self._shape is not None and full.shape != self._shape:
            self.reset()  # a new source or resolution: nothing matches any more
        self._shape = full.shape
        h_px, w_px = full.shape
        if 0 < self.work_width_px < w_px:
            self._scale = self.work_width_px / w_px
            size = (self.work_width_px, max(1, int(round(h_px * self._scale))))
            grey = cv2.resize(full, size, interpolation=cv2.INTER_AREA)
        else:
            self._scale = 1.0
            grey = full
        prior = None  # checked before anything changes: a bad prior loses nothing
        if motion_prior is not None and self.motion_prior != "off":
            prior = np.asarray(motion_prior, np.float64)
            if prior.shape != (3, 3) or not np.all(np.isfinite(prior)) or prior[2, 2] == 0:
                raise ValueError(f"motion_prior must be a finite 3x3 homography, got shape {prior.shape}")
            sc = np.diag([self._scale, self._scale, 1.0])  # source -> working pixels
            prior = sc @ prior @ np.linalg.inv(sc)
            prior = prior / prior[2, 2]
        fi = self._n if frame_index is None else int(frame_index)
        dt = 1.0 / self.nominal_fps
        if self._t_prev is not None and t_s > self._t_prev:
            dt = float(t_s - self._t_prev)
        self._t_prev = float(t_s)

        band = None
        line = None
        self._far_row = None
        if horizon is not None:
            ends = np.asarray(horizon.row_at(np.array([0.0, w_px - 1.0])), np.float64)
            if np.all(np.isfinite(ends)):
                line = ends * self._scale  # working-image rows at columns 0 and W-1
                if self.band_px > 0:
                    y0 = int(np.floor((ends.min() - self.band_above_px) * self._scale))
                    y1 = int(np.ceil((ends.max() + self.band_px) * self._scale))
                    y0, y1 = max(0, y0), min(grey.shape[0], y1)
                    if y1 - y0 >= 4:
                        band = (y0, y1)
                        if self.far_px > 0 and not (ir and self.far_skip_ir):
                            self._far_row = min(y1, int(np.ceil((ends.max() + self.far_px) * self._scale)))
        kxy, ksize, kdesc, rescued = self._keypoints(grey, band)
        act = np.flatnonzero(self._alive)
        radius = 0.0
        if self.guided_px > 0:
            radius = self.guided_px * self._scale + self.gate_min_px_s * self._scale * dt
        qi, si = self._match(kdesc, act, kxy, radius)
        # no match at all (a blank or corrupt frame): the prior, when given, still carries the
        # features with the camera
        h = np.eye(3) if prior is None else prior
        motion_ok = prior is not None
        jumped = np.zeros(len(qi), bool)
        if len(qi) and self.subpixel and self._grey_prev is not None:
            kxy[qi], ok = self._refine(self._grey_prev, grey, self._xy[si], kxy[qi])
            jumped = ~ok
        if len(qi):
            src = self._xy[si]
            dst = kxy[qi]
            stable = self._conf[si] >= self.stable_confidence
            scene = None
            if line is not None and self.scene_motion:
                wk = max(grey.shape[1] - 1, 1)
                scene = src[:, 1] < line[0] + (line[1] - line[0]) * src[:, 0] / wk - 1.0
            if prior is not None:
                h, motion_ok = self._prior_motion(prior, src, dst, stable, scene, max(1.0, float(zoom)))
            else:
                h, motion_ok = self._camera_motion(src, dst, stable, scene)
            # gate: velocity relative to the camera against the stable features' statistics
            res = (dst - _apply_h(h, src)) / dt
            ref = res[stable] if stable.sum() >= 2 else res
            mu = ref.mean(axis=0)
            sigma = float(np.sqrt(np.mean(np.sum((ref - mu) ** 2, axis=1))))
            gate = max(self.gate_sigma * sigma, self.gate_min_px_s * self._scale)
            keep = np.linalg.norm(res - mu, axis=1) <= gate
            qi, si, jumped = qi[keep], si[keep], jumped[keep]

        held, hxy = self._hold(act, si, h, grey, t_s, band if self.hold_band_only else None)

        # carry every position into this frame with the camera motion
        if act.size:
            self._xy[act] = _apply_h(h, self._xy[act])
            self._pos[act] = _apply_h(h, self._pos[act])
        col = self._n % self._k
        vcol = self._n % self._w
        self._tpos[col] = t_s
        self._pos[:, col] = np.nan
        self._vel[:, vcol] = np.nan
        self._ivel[act] = np.nan

        # matched features (those whose position could not be followed start a new history)
        self._pos[si[jumped]] = np.nan
        self._xy[si] = kxy[qi]
        self._size[si] = ksize[qi]
        self._desc[si] = kdesc[qi]
        self._pos[si, col] = kxy[qi]
        self._conf[act] -= 1
        self._conf[si] += 2
        self._conf[held] += 1  # held: neither up nor down
        self._xy[held] = hxy
        self._tmatch[si] = t_s
        if self.hold_velocity:
            self._pos[held, col] = hxy
        else:  # a held feature moves but gives no velocity sample
            held, hxy = held[:0], hxy[:0]
        np.minimum(self._conf, self.max_confidence, out=self._conf)
        obs = np.r_[si, held]
        oxy = np.concatenate([kxy[qi], hxy])
        if len(obs):
            # velocity relative to the camera: position now minus the oldest position seen
            # within the baseline, both in this frame's pixels
            ages = (col - np.arange(self._k)) % self._k  # frames ago of each ring column
            past = self._pos[obs]
            seen = np.isfinite(past[:, :, 0]) & (ages[None, :] > 0)
            score = np.where(seen, ages[None, :], -1)
            j = np.argmax(score, axis=1)
            rows = np.arange(len(obs))
            el = t_s - self._tpos[j]
            has = (score[rows, j] > 0) & (el > 0)
            with np.errstate(invalid="ignore", divide="ignore"):
                v = (oxy - past[rows, j]) / el[:, None]
            v[~has] = np.nan
            self._vel[obs, vcol] = v
            # image velocity = relative velocity + the camera's image motion at that point
            cam = (oxy - _apply_h(np.linalg.inv(h), oxy)) / dt
            self._ivel[obs] = np.where(np.isfinite(v), v, 0.0) + cam

        # remove the features whose confidence fell to zero
        dead = act[self._conf[act] <= 0]
        self._alive[dead] = False
        self._ids[dead] = -1
        self._pos[dead] = np.nan
        self._vel[dead] = np.nan

        # unmatched keypoints become new features
        new_q = np.setdiff1d(np.arange(len(kxy)), qi, assume_unique=True)
        new_q = new_q[~rescued[new_q]]  # a re-detected keypoint is offered to the matching only
        if len(new_q) and self.dedup_px > 0:
            # not one on top of an active feature: two features of one point spoil each
            # other's ratio test, so that neither matches again
            alive = np.flatnonzero(self._alive)
            if len(alive):
                d, _ = cKDTree(self._xy[alive]).query(kxy[new_q], k=1,
                                                      distance_upper_bound=self.dedup_px * self._scale)
                new_q = new_q[~np.isfinite(d)]
        if len(new_q):
            free = np.flatnonzero(~self._alive)
            if len(free) < len(new_q):
                self._grow(self._cap + len(new_q) - len(free))
                free = np.flatnonzero(~self._alive)
            s = free[: len(new_q)]
            self._alive[s] = True
            self._ids[s] = np.arange(self._next_id, self._next_id + len(s))
            self._next_id += len(s)
            self._xy[s] = kxy[new_q]
            self._size[s] = ksize[new_q]
            self._desc[s] = kdesc[new_q]
            self._conf[s] = 1
            self._tmatch[s] = t_s
            self._pos[s] = np.nan
            self._pos[s, col] = kxy[new_q]
            self._vel[s] = np.nan
            self._ivel[s] = np.nan
        self._n += 1
        self._grey_prev = grey
        self._h_prev = h
        snap = self._snapshot(t_s, fi, h, dt, len(kxy), len(si), motion_ok, matched_slots=si)
        snap.horizon = horizon
        snap.zoom = float(zoom)
        return snap

    def _snapshot(self, t_s, fi, h, dt, n_kp, n_matched, motion_ok, matched_slots) -> FeatureSnapshot:
        act = np.flatnonzero(self._alive)
        matched = np.zeros(self._cap, bool)
        matched[matched_slots] = True
        vcol = (self._n - 1) % self._w
        order = (np.arange(self._w) + vcol + 1) % self._w  # oldest first, this frame last
        k = 1.0 / self._scale  # working-image pixels -> source-image pixels
        hist = self._vel[act][:, order] * k
        sc = np.diag([self._scale, self._scale, 1.0])
        h_src = np.linalg.inv(sc) @ h @ sc
        st = self._conf[act] >= self.stable_confidence
        vnow = hist[st, -1] if len(act) else np.zeros((0, 2))
        vnow = vnow[np.isfinite(vnow[:, 0])]
        noise = float(np.median(np.hypot(vnow[:, 0], vnow[:, 1]))) if len(vnow) >= 5 else float("nan")
        return FeatureSnapshot(
            t_s=float(t_s),
            frame_index=int(fi),
            ids=self._ids[act].copy(),
            slots=act,
            xy=self._xy[act] * k,
            size_px=self._size[act] * k,
            confidence=self._conf[act].copy(),
            stable=st,
            matched=matched[act],
            velocity=hist[:, -1].copy() if len(act) else np.zeros((0, 2)),
            history=hist,
            image_velocity=self._ivel[act] * k,
            homography=h_src / h_src[2, 2],
            dt_s=float(dt),
            n_keypoints=int(n_kp),
            n_matched=int(n_matched),
            camera_motion_ok=bool(motion_ok),
            shape=self._shape,
            noise_px_s=noise,
        )
