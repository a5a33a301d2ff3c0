"""Group tracking through occlusions and colour re-identification (paper A, Fig. 11).

When two (or more) vessels come so close that their boxes, shrunk to 0.8 of their size,
overlap, the tracker stops trusting the observations to tell them apart: the tracks form a
*group*, each member's HSV colour model is saved, and the members coast on their velocities
while the group lasts.  When they separate, each is given its identity back by comparing the
colour of the observations that come out of the group with the saved models: the Bhattacharyya
distance of the H, S and V histograms, weighted 3/6, 2/6 and 1/6, and a match below 0.35.

This module holds the pieces: :func:`shrink_boxes`, :func:`overlap_components`,
:func:`hsv_histograms`, :func:`bhattacharyya_distance`, :func:`colour_distance_matrix`,
:func:`match_by_colour` and the :class:`Group` record.  The tracker that uses them is
:class:`seawatch.track.ptracking.PTrackingTracker`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numba import njit
from scipy.optimize import linear_sum_assignment

__all__ = [
    "HSV_BINS",
    "HSV_WEIGHTS",
    "Group",
    "shrink_boxes",
    "overlap_components",
    "hsv_histograms",
    "bhattacharyya_distance",
    "colour_distance_matrix",
    "match_by_colour",
]

HSV_BINS = (30, 32, 32)  # hue (OpenCV hue is 0..179), saturation, value
HSV_WEIGHTS = (3.0 / 6.0, 2.0 / 6.0, 1.0 / 6.0)


@dataclass
class Group:
    """Tracks that collapsed into one blob.

    Attributes
    ----------
    members : list of track ids.
    histograms : dict id -> (sum(HSV_BINS),) colour model saved when the group formed (None when
        no image was available).
    formed_t_s : time the group formed.
    anchors : dict id -> (position, velocity, size, t_s) of each member when it joined: a
        member that is not observed coasts from there (its box is not shrunk by the occlusion).
    """

    members: list[int]
    histograms: dict[int, np.ndarray | None] = field(default_factory=dict)
    formed_t_s: float = 0.0
    anchors: dict[int, tuple] = field(default_factory=dict)


def shrink_boxes(boxes, factor: float = 0.8) -> np.ndarray:
    """Boxes ``(x, y, w, h)`` scaled by ``factor`` about their centres."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    out = b.copy()
    out[:, 2:] = b[:, 2:] * factor
    out[:, :2] = b[:, :2] + (b[:, 2:] - out[:, 2:]) / 2
    return out


@njit(cache=True)
def _overlap_labels(boxes, shrink):
    n = boxes.shape[0]
    parent = np.arange(n)
    x1 = np.empty(n)
    y1 = np.empty(n)
    x2 = np.empty(n)
    y2 = np.empty(n)
    for i in range(n):
        w = boxes[i, 2] * shrink
        h = boxes[i, 3] * shrink
        x1[i] = boxes[i, 0] + (boxes[i, 2] - w) / 2
        y1[i] = boxes[i, 1] + (boxes[i, 3] - h) / 2
        x2[i] = x1[i] + w
        y2[i] = y1[i] + h
    for i in range(n):
        for j in range(i + 1, n):
            if min(x2[i], x2[j]) > max(x1[i], x1[j]) and min(y2[i], y2[j]) > max(y1[i], y1[j]):
                a = i
                while parent[a] != a:
                    a = parent[a]
                b = j
                while parent[b] != b:
                    b = parent[b]
                if a != b:
                    parent[max(a, b)] = min(a, b)
    lab = -np.ones(n, np.int64)
    root_lab = -np.ones(n, np.int64)
    c = 0
    for i in range(n):
        a = i
        while parent[a] != a:
            a = parent[a]
        if root_lab[a] < 0:
            root_lab[a] = c
            c += 1
        lab[i] = root_lab[a]
    return lab


def overlap_components(boxes, shrink: float = 0.8) -> np.ndarray:
    """Connected components of boxes that overlap once shrunk by ``shrink``.

    Returns
    -------
    (N,) int64, a component label per box, ``0..C-1`` in order of first appearance; boxes that
    overlap nobody are components of one.
    """
    b = np.ascontiguousarray(np.asarray(boxes, dtype=np.float64).reshape(-1, 4))
    return _overlap_labels(b, float(shrink))


def hsv_histograms(image: np.ndarray, boxes, bins=HSV_BINS) -> np.ndarray:
    """Normalised H, S and V histograms of each box of a BGR (or grey) image.

    Parameters
    ----------
    image : HxWx3 uint8 BGR, or HxW grey (then only the V histogram is filled).
    boxes : (N, 4) x, y, w, h in pixels (clipped to the image).
    bins : (3,) bins of H, S, V.

    Returns
    -------
    (N, sum(bins)) float64, each channel's part summing to one (all zero for an empty box or a
    missing channel).
    """
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    nb = int(sum(bins))
    out = np.zeros((len(b), nb))
    if image is None or len(b) == 0:
        return out
    img = np.asarray(image)
    if img.dtype != np.uint8:
        img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    h_img, w_img = img.shape[:2]
    grey = img.ndim == 2 or img.shape[2] == 1
    x1 = np.clip(np.floor(b[:, 0]), 0, w_img).astype(int)
    y1 = np.clip(np.floor(b[:, 1]), 0, h_img).astype(int)
    x2 = np.clip(np.ceil(b[:, 0] + b[:, 2]), 0, w_img).astype(int)
    y2 = np.clip(np.ceil(b[:, 1] + b[:, 3]), 0, h_img).astype(int)
    o1, o2 = bins[0], bins[0] + bins[1]
    for k in range(len(b)):  # one OpenCV call per box
        if x2[k] <= x1[k] or y2[k] <= y1[k]:
            continue
        crop = img[y1[k]:y2[k], x1[k]:x2[k]]
        if grey:
            v = cv2.calcHist([crop.reshape(crop.shape[0], crop.shape[1])], [0], None, [bins[2]], [0, 256])
            out[k, o2:] = v.ravel() / max(v.sum(), 1e-12)
            continue
        hsv = cv2.cvtColor(np.ascontiguousarray(crop), cv2.COLOR_BGR2HSV)
        for ch, (lo, n, rng) in enumerate(((0, bins[0], 180), (o1, bins[1], 256), (o2, bins[2], 256))):
            hh = cv2.calcHist([hsv], [ch], None, [n], [0, rng]).ravel()
            out[k, lo:lo + n] = hh / max(hh.sum(), 1e-12)
    return out


def _channel_slices(bins):
    o1, o2 = bins[0], bins[0] + bins[1]
    return (slice(0, o1), slice(o1, o2), slice(o2, o2 + bins[2]))


def colour_distance_matrix(a, b, bins=HSV_BINS, weights=HSV_WEIGHTS) -> np.ndarray:
    """Weighted Bhattacharyya distance between every histogram of ``a`` and of ``b``.

    Per channel, ``d = sqrt(1 - sum sqrt(p * q))`` (OpenCV's HISTCMP_BHATTACHARYYA on normalised
    histograms); the channels are combined with ``weights`` (3/6, 2/6, 1/6 for H, S, V).  A
    channel that is empty in either histogram (grey images have no H and S) is left out and the
    remaining weights renormalised.  A pair with no common channel gets distance 1.

    Returns
    -------
    (len(a), len(b)) float64 in ``[0, 1]``.
    """
    A = np.asarray(a, dtype=np.float64).reshape(-1, int(sum(bins)))
    B = np.asarray(b, dtype=np.float64).reshape(-1, int(sum(bins)))
    num = np.zeros((len(A), len(B)))
    den = np.zeros((len(A), len(B)))
    for sl, wt in zip(_channel_slices(bins), weights):
        pa, pb = A[:, sl], B[:, sl]
        ok = (pa.sum(1) > 0)[:, None] & (pb.sum(1) > 0)[None, :]
        bc = np.sqrt(pa) @ np.sqrt(pb).T
        d = np.sqrt(np.clip(1.0 - bc, 0.0, 1.0))
        num += np.where(ok, wt * d, 0.0)
        den += np.where(ok, wt, 0.0)
    return np.where(den > 0, num / np.maximum(den, 1e-12), 1.0)


def bhattacharyya_distance(h1, h2, bins=HSV_BINS, weights=HSV_WEIGHTS) -> float:
    """Weighted H/S/V Bhattacharyya distance between two colour models (see
    :func:`colour_distance_matrix`)."""
    return float(colour_distance_matrix(h1, h2, bins, weights)[0, 0])


def match_by_colour(saved, candidates, max_distance: float = 0.35, bins=HSV_BINS,
                    weights=HSV_WEIGHTS, extra_cost=None):
    """Give saved colour models their best candidates (Hungarian on the colour distance).

    Parameters
    ----------
    saved : (S, B) colour models (the group members').
    candidates : (C, B) colour models (the observations leaving the group).
    max_distance : float
        A pair matches only below this distance (paper: 0.35).
    extra_cost : (S, C) array, optional
        Added to the colour distance for the assignment (e.g. a small position term); pairs
        where it is ``inf`` are forbidden.

    Returns
    -------
    list of (saved index, candidate index, distance).
    """
    d = colour_distance_matrix(saved, candidates, bins, weights)
    if d.size == 0:
        return []
    cost = d.copy()
    if extra_cost is not None:
        cost = cost + np.asarray(extra_cost, dtype=np.float64)
    bad = (d >= max_distance) | ~np.isfinite(cost)
    cost = np.where(bad, 1e6, cost)
    r, c = linear_sum_assignment(cost)
    return [(int(i), int(j), float(d[i, j])) for i, j in zip(r, c) if not bad[i, j]]
