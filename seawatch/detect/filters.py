"""Image preparation and false-alarm filters of the paper A boat detector (Bloisi et al.).

* :func:`to_grey`, :func:`normalize_ir` and :func:`prepare_grey`: the grey image the cascade and
  the horizon detector see (IR frames are stretched by scale and shift between two percentiles
  first, so a 14-bit or low-contrast thermal image looks like an 8-bit visible one).
* :func:`canny_prune`: drops windows without enough edge pixels.  OpenCV's
  ``CASCADE_DO_CANNY_PRUNING`` flag is ignored for current-format cascades, so it is a filter
  here: the fraction of Canny edge pixels in the inner part of each box, from an integral image.
* :func:`suppress_nested`: of two boxes where one contains the other, keeps the outer one
  (the authors' detector does the same).
* :func:`reflection_filter`: the paper's keypoint filter against reflections on the water: a
  box with a negligible number of keypoints for its area is rejected.  The paper used SURF,
  which no PyPI OpenCV build ships (patented); FAST corners are used instead (see
  ``docs/cascade.md``).
* The wake filter is the cascade's last stage (trained by :mod:`seawatch.train`), so it has no
  function here.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = [
    "to_grey",
    "normalize_ir",
    "prepare_grey",
    "canny_prune",
    "edge_density",
    "suppress_nested",
    "keypoint_density",
    "reflection_filter",
]


def to_grey(image: np.ndarray, where: str = "image") -> np.ndarray:
    """An 8- or 16-bit grey image from a grey, BGR or BGRA image.

    Raises
    ------
    ValueError
        For an empty image or an unsupported shape (the message names ``where``).
    """
    if image is None:
        raise ValueError(f"{where}: no image (None)")
    img = np.asarray(image)
    if img.size == 0:
        raise ValueError(f"{where}: empty image (shape {img.shape})")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 2:
        return img
    if img.ndim == 3 and img.shape[2] in (3, 4):
        if img.dtype not in (np.uint8, np.uint16):
            img = np.clip(img, 0, 255).astype(np.uint8)
        code = cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        return cv2.cvtColor(img, code)
    raise ValueError(f"{where}: unsupported image shape {img.shape} (expected HxW, HxWx3 or HxWx4)")


def normalize_ir(image: np.ndarray, low_pct: float = 1.0, high_pct: float = 99.0) -> np.ndarray:
    """Scale and shift a thermal (or any grey) image so percentiles map to 0 and 255.

    Parameters
    ----------
    image : (H, W) array, any numeric dtype (8- or 16-bit thermal counts).
    low_pct, high_pct : float
        Percentiles mapped to 0 and 255; values outside are clipped.

    Returns
    -------
    (H, W) uint8
    """
    img = np.asarray(image)
    if img.size == 0:
        raise ValueError("normalize_ir: empty image")
    if not 0.0 <= low_pct < high_pct <= 100.0:
        raise ValueError(f"normalize_ir: need 0 <= low_pct < high_pct <= 100, got {low_pct}, {high_pct}")
    sub = img[:: max(1, img.shape[0] // 128), :: max(1, img.shape[1] // 128)] if img.ndim == 2 else img
    lo, hi = np.percentile(sub, [low_pct, high_pct])
    if hi <= lo:
        hi = lo + 1.0
    out = (img.astype(np.float32) - np.float32(lo)) * np.float32(255.0 / (hi - lo))
    return np.clip(out + 0.5, 0, 255).astype(np.uint8)


def prepare_grey(image: np.ndarray, ir: bool = False, median_px: int = 3, where: str = "image") -> np.ndarray:
    """The 8-bit grey image the detector works on.

    Grey conversion, IR normalisation (``ir=True``, or any 16-bit input), then a
    ``median_px`` x ``median_px`` median filter (0 or 1: none).
    """
    g = to_grey(image, where)
    if ir or g.dtype != np.uint8:
        g = normalize_ir(g)
    if median_px and median_px > 1:
        g = cv2.medianBlur(g, int(median_px))
    return g


def edge_density(edges: np.ndarray, boxes: np.ndarray, inset: float = 0.1) -> np.ndarray:
    """Fraction of edge pixels inside each box (shrunk by ``inset`` of its size on each side).

    Parameters
    ----------
    edges : (H, W) uint8 edge map (non-zero = edge).
    boxes : (N, 4) x, y, w, h in pixels of ``edges``.
    """
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    if len(boxes) == 0:
        return np.zeros(0)
    ii = cv2.integral((edges > 0).astype(np.uint8))
    h, w = edges.shape[:2]
    x0 = np.clip(np.round(boxes[:, 0] + inset * boxes[:, 2]), 0, w).astype(int)
    y0 = np.clip(np.round(boxes[:, 1] + inset * boxes[:, 3]), 0, h).astype(int)
    x1 = np.clip(np.round(boxes[:, 0] + (1 - inset) * boxes[:, 2]), 0, w).astype(int)
    y1 = np.clip(np.round(boxes[:, 1] + (1 - inset) * boxes[:, 3]), 0, h).astype(int)
    area = np.maximum((x1 - x0) * (y1 - y0), 1)
    s = ii[y1, x1] - ii[y0, x1] - ii[y1, x0] + ii[y0, x0]
    return s / area


def canny_prune(
    grey: np.ndarray, boxes: np.ndarray, min_edge_frac: float = 0.02, low: float = 30.0, high: float = 100.0,
    edges: np.ndarray | None = None,
) -> np.ndarray:
    """Mask of the boxes that keep enough Canny edges (``True`` = keep).

    Parameters
    ----------
    grey : (H, W) uint8
    boxes : (N, 4) x, y, w, h
    min_edge_frac : float
        Smallest fraction of edge pixels in the inner 80 % of the box.
    low, high : float
        Canny hysteresis thresholds (the authors' 30 and 100).
    edges : optional precomputed edge map of the whole image; without it, edges are computed
        on each box's crop only (a few boxes: much cheaper than the whole frame).
    """
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    if len(boxes) == 0:
        return np.zeros(0, bool)
    if edges is not None:
        return edge_density(edges, boxes) >= min_edge_frac
    h, w = grey.shape[:2]
    keep = np.zeros(len(boxes), bool)
    for k, (x, y, bw, bh) in enumerate(boxes):
        x0, y0 = max(0, int(x) - 2), max(0, int(y) - 2)
        x1, y1 = min(w, int(np.ceil(x + bw)) + 2), min(h, int(np.ceil(y + bh)) + 2)
        if x1 - x0 < 3 or y1 - y0 < 3:
            continue
        e = cv2.Canny(np.ascontiguousarray(grey[y0:y1, x0:x1]), low, high)
        keep[k] = edge_density(e, np.array([[x - x0, y - y0, bw, bh]]))[0] >= min_edge_frac
    return keep


def suppress_nested(boxes: np.ndarray, scores: np.ndarray | None = None, tol_px: float = 0.0) -> np.ndarray:
    """Indices of the boxes not contained in another box (the outer box is kept).

    Parameters
    ----------
    boxes : (N, 4) x, y, w, h
    scores : ignored for the choice, kept for symmetry with other suppressors.
    tol_px : float
        A box counts as inside another when it lies within it up to ``tol_px`` on each side.

    Returns
    -------
    (M,) int64 indices of kept boxes, in input order.  Of identical boxes the first is kept.
    """
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    n = len(b)
    if n < 2:
        return np.arange(n, dtype=np.int64)
    x0, y0 = b[:, 0], b[:, 1]
    x1, y1 = x0 + b[:, 2], y0 + b[:, 3]
    # inside[i, j]: box i lies inside box j
    inside = (
        (x0[:, None] >= x0[None, :] - tol_px) & (y0[:, None] >= y0[None, :] - tol_px)
        & (x1[:, None] <= x1[None, :] + tol_px) & (y1[:, None] <= y1[None, :] + tol_px)
    )
    np.fill_diagonal(inside, False)
    same = inside & inside.T
    # of identical boxes, only the later one counts as inside the earlier one
    idx = np.arange(n)
    inside = inside & ~(same & (idx[:, None] < idx[None, :]))
    return np.flatnonzero(~inside.any(axis=1)).astype(np.int64)


def keypoint_density(grey: np.ndarray, boxes: np.ndarray, fast_threshold: int = 20,
                     keypoints: np.ndarray | None = None) -> np.ndarray:
    """FAST keypoints per 100 px^2 of each box.

    Parameters
    ----------
    grey : (H, W) uint8
    boxes : (N, 4) x, y, w, h
    fast_threshold : int
        FAST intensity threshold.
    keypoints : optional (K, 2) x, y of precomputed keypoints.
    """
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    if len(boxes) == 0:
        return np.zeros(0)
    if keypoints is None:  # FAST on each box's crop (with the detector's 3 px border) only
        fast = cv2.FastFeatureDetector_create(threshold=int(fast_threshold), nonmaxSuppression=True)
        h, w = grey.shape[:2]
        pts = []
        for x, y, bw, bh in boxes:
            x0, y0 = max(0, int(x) - 4), max(0, int(y) - 4)
            x1, y1 = min(w, int(np.ceil(x + bw)) + 4), min(h, int(np.ceil(y + bh)) + 4)
            if x1 - x0 < 8 or y1 - y0 < 8:
                continue
            kps = fast.detect(np.ascontiguousarray(grey[y0:y1, x0:x1]), None)
            pts += [(k.pt[0] + x0, k.pt[1] + y0) for k in kps]
        keypoints = np.unique(np.array(pts, np.float64).reshape(-1, 2), axis=0)
    kx, ky = keypoints[:, 0], keypoints[:, 1]
    inside = (
        (kx[None, :] >= boxes[:, 0:1]) & (kx[None, :] < boxes[:, 0:1] + boxes[:, 2:3])
        & (ky[None, :] >= boxes[:, 1:2]) & (ky[None, :] < boxes[:, 1:2] + boxes[:, 3:4])
    )
    area = np.maximum(boxes[:, 2] * boxes[:, 3], 1.0)
    return inside.sum(axis=1) * 100.0 / area


def reflection_filter(grey: np.ndarray, boxes: np.ndarray, min_per_100px2: float = 0.01,
                      fast_threshold: int = 20) -> np.ndarray:
    """Mask of the boxes with a non-negligible keypoint count for their area (``True`` = keep).

    A reflection or a glint on the water is smooth and bright: it has few corners.  A box with
    fewer than ``min_per_100px2`` FAST keypoints per 100 px^2 is rejected.
    """
    boxes = np.asarray(boxes, np.float64).reshape(-1, 4)
    if len(boxes) == 0:
        return np.zeros(0, bool)
    return keypoint_density(grey, boxes, fast_threshold) >= min_per_100px2
