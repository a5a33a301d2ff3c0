"""Tracking by clustering temporally stable features (paper B, steps 2 to 4).

Osborne, Cane, Nawaz and Ferryman, "Temporally stable feature clusters for maritime object
tracking in visible and thermal imagery", AVSS 2015.  The stable features of
:mod:`seawatch.detect.features` are grouped, frame after frame, into objects:

1. **Motion dissimilarity** of two features over the frames where both were seen
   (:func:`motion_dissimilarity`): the mean normalised angle between their velocities
   ``Theta`` and the mean magnitude term ``Lambda = N(m_fast) (1 - m_slow / m_fast)`` with
   ``N(m) = 1 / (1 + exp(p - m))``; ``D = sqrt(Theta^2 + Lambda^2)``, and ``D = 1000`` when
   they share no frame.
2. **Per-frame graph**: an edge between two stable features when ``D < Dmax`` and they are
   closer than ``R`` pixels (:func:`frame_edges`).
3. **Affinity graph** (:class:`AffinityClusters`): the weight of a pair grows by ``alpha`` when
   the pair is an edge of the frame's graph and decays by 1 otherwise; a link forms when the
   weight reaches ``Wlink`` and breaks when it falls to 0.  The connected components of the
   links with at least two features are the objects.  A component takes the identity its
   features carried; a merge keeps the oldest identity, and of the parts of a split one keeps
   the identity (the one holding most of its features) and the others get new ones
   (:func:`assign_identities`).
4. :class:`StableFeatureTracker` is the pipeline's detector-tracker stage: frames in, the
   clusters' boxes out as :class:`~seawatch.types.Detections` and
   :class:`~seawatch.types.Tracks`.
"""

from __future__ import annotations

import collections
import dataclasses
import warnings
from dataclasses import dataclass

import cv2
import numba as nb
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from seawatch.detect.features import FeatureSnapshot, StableFeatureExtractor, to_grey_u8
from seawatch.track.sort import iou_matrix
from seawatch.types import Detections, Frame, Modality, Tracks, TrackState

__all__ = [
    "NO_COMMON_FRAME",
    "motion_dissimilarity",
    "frame_edges",
    "assign_identities",
    "AffinityClusters",
    "ClusterParams",
    "FeatureClusterer",
    "StableFeatureTracker",
    "grow_boxes",
    "camera_horizon",
]

NO_COMMON_FRAME = 1000.0  # dissimilarity of two features that were never seen in the same frame


def motion_dissimilarity(
    va: np.ndarray, vb: np.ndarray, p_px: float = 3.0, frame_interval_s: float = 0.04, angle: bool = True,
) -> np.ndarray:
    """Motion dissimilarity of pairs of feature tracks.

    Parameters
    ----------
    va, vb : (..., W, 2) velocity samples (px/s) of the two features of each pair over the same
        W frames, NaN where a feature was not seen.
    p_px : float
        Midpoint of the magnitude sigmoid ``N(m) = 1 / (1 + exp(p - m))``, in pixels per frame
        interval (paper: 3 px).
    frame_interval_s : float
        The frame interval that the magnitudes ``m`` are expressed in (paper: per frame; 0.04 s,
        i.e. 25 frames/s), so the result does not depend on the frame rate.
    angle : bool
        Include the angle term (the paper); False gives ``Lambda`` alone (for two features that
        do not move relative to the scene, whose directions are noise).

    Returns
    -------
    (...) float64: ``D = sqrt(Theta^2 + Lambda^2)`` with ``Theta`` the mean over the common
    frames of the absolute angle difference of the velocity directions divided by pi (with
    wrap-around, so in [0, 1]) and ``Lambda`` the mean of ``N(m_fast) (1 - m_slow / m_fast)``;
    :data:`NO_COMMON_FRAME` (1000) where the two share no frame.
    """
    va = np.asarray(va, np.float64)
    vb = np.asarray(vb, np.float64)
    both = np.isfinite(va).all(axis=-1) & np.isfinite(vb).all(axis=-1)
    n = both.sum(axis=-1)
    a = np.where(both[..., None], va, 0.0)
    b = np.where(both[..., None], vb, 0.0)
    ang = np.abs(np.arctan2(a[..., 1], a[..., 0]) - np.arctan2(b[..., 1], b[..., 0]))
    ang = np.minimum(ang, 2.0 * np.pi - ang) / np.pi
    ma = np.hypot(a[..., 0], a[..., 1]) * frame_interval_s
    mb = np.hypot(b[..., 0], b[..., 1]) * frame_interval_s
    fast = np.maximum(ma, mb)
    slow = np.minimum(ma, mb)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sig = 1.0 / (1.0 + np.exp(p_px - fast))
        lam = np.where(fast > 0, sig * (1.0 - slow / fast), 0.0)
    nn = np.maximum(n, 1)
    theta = np.where(both, ang, 0.0).sum(axis=-1) / nn if angle else 0.0
    lam_m = np.where(both, lam, 0.0).sum(axis=-1) / nn
    d = np.sqrt(theta**2 + lam_m**2)
    return np.where(n > 0, d, NO_COMMON_FRAME)


@nb.njit(cache=True, nogil=True)
def _pair_dissimilarity(history, pi, pj, p_px, frame_interval_s, angle):
    """:func:`motion_dissimilarity` of the pairs ``(history[pi], history[pj])`` without
    gathering their histories (the same formula, sample by sample).  Each feature's direction
    and step per sample are computed once (session 29: not once per pair it is in; the same
    values)."""
    out = np.empty(len(pi))
    nf, nw = history.shape[0], history.shape[1]
    need = np.zeros(nf, np.bool_)
    for e in range(len(pi)):
        need[pi[e]] = True
        need[pj[e]] = True
    fin = np.zeros((nf, nw), np.bool_)
    ang = np.zeros((nf, nw))
    mag = np.zeros((nf, nw))
    for f in range(nf):
        if not need[f]:
            continue
        for w in range(nw):
            x, y = history[f, w, 0], history[f, w, 1]
            if np.isfinite(x) and np.isfinite(y):
                fin[f, w] = True
                ang[f, w] = np.arctan2(y, x)
                mag[f, w] = np.hypot(x, y) * frame_interval_s
    for e in range(len(pi)):
        a, b = pi[e], pj[e]
        n = 0
        th = 0.0
        lm = 0.0
        for w in range(nw):
            if not (fin[a, w] and fin[b, w]):
                continue
            n += 1
            ang_ = abs(ang[a, w] - ang[b, w])
            th += min(ang_, 2.0 * np.pi - ang_) / np.pi
            ma = mag[a, w]
            mb = mag[b, w]
            fast = max(ma, mb)
            if fast > 0:
                lm += (1.0 / (1.0 + np.exp(p_px - fast))) * (1.0 - min(ma, mb) / fast)
        if n == 0:
            out[e] = NO_COMMON_FRAME
        else:
            t = th / n if angle else 0.0
            m = lm / n
            out[e] = np.sqrt(t * t + m * m)
    return out


def frame_edges(
    xy: np.ndarray, history: np.ndarray, dmax: float, radius_px: float, p_px: float = 3.0,
    frame_interval_s: float = 0.04, min_speed_px_s: float = 0.0, still_ok: np.ndarray | None = None,
    still_radius_px: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edges of one frame's graph: pairs closer than ``radius_px`` with ``D < dmax``.

    Parameters
    ----------
    xy : (N, 2) positions of the features.
    history : (N, W, 2) their velocity samples (px/s), NaN where not seen.
    min_speed_px_s : float or (N,) floats (one per feature)
        Velocity samples slower than this count as not seen (not in the paper: the direction
        of a feature that does not move relative to the scene is noise, and a small bias of the
        camera-motion estimate would otherwise line up the directions of neighbouring static
        features).
    still_ok : (N,) bool, optional
        Features that may be joined as *still objects* (not in the paper): stable features on
        the water that were never seen moving faster than ``min_speed_px_s``.  Two of them closer
        than ``still_radius_px`` form an edge when their magnitude term ``Lambda`` alone is
        below ``dmax`` (the angle between two velocities that are noise means nothing); a moving
        feature is never joined to a still one this way, so the motion still splits a moving boat
        from a still neighbour.  Water does not keep a stable feature (its texture changes), so
        a cluster of stable features on the water is an object even when it moves with the
        camera.

    Returns
    -------
    i, j : (E,) int64 indices into ``xy`` with ``i < j``.
    d : (E,) their dissimilarities.
    """
    z = np.zeros(0, np.int64)
    history = np.ascontiguousarray(history, np.float64)
    raw = history
    idx = np.arange(len(xy))
    floor = np.asarray(min_speed_px_s, np.float64)
    if np.any(floor > 0) and len(xy):
        if floor.ndim:  # one floor per feature
            floor = floor[:, None]
        with np.errstate(invalid="ignore"):
            slow = np.hypot(history[..., 0], history[..., 1]) < floor
        history = np.where(slow[..., None], np.nan, history)
        idx = np.flatnonzero(np.isfinite(history[..., 0]).any(axis=1))  # features seen moving
    out_i, out_j, out_d = [z], [z], [np.zeros(0)]
    if len(idx) >= 2:
        pairs = cKDTree(xy[idx]).query_pairs(r=float(radius_px), output_type="ndarray")
        if len(pairs):
            i, j = idx[pairs[:, 0]], idx[pairs[:, 1]]
            d = _pair_dissimilarity(history, i, j, float(p_px), float(frame_interval_s), True)
            keep = d < dmax
            out_i.append(i[keep]), out_j.append(j[keep]), out_d.append(d[keep])
    if still_ok is not None and still_radius_px > 0:
        moving = np.zeros(len(xy), bool)
        moving[idx] = True
        sidx = np.flatnonzero(np.asarray(still_ok, bool) & ~moving & np.isfinite(raw[..., 0]).any(axis=1))
        if len(sidx) >= 2:
            pairs = cKDTree(xy[sidx]).query_pairs(r=float(still_radius_px), output_type="ndarray")
            if len(pairs):
                i, j = sidx[pairs[:, 0]], sidx[pairs[:, 1]]
                d = _pair_dissimilarity(raw, i, j, float(p_px), float(frame_interval_s), False)
                keep = d < dmax
                out_i.append(i[keep]), out_j.append(j[keep]), out_d.append(d[keep])
    i, j, d = np.concatenate(out_i), np.concatenate(out_j), np.concatenate(out_d)
    return np.minimum(i, j), np.maximum(i, j), d


def _far_still(xy: np.ndarray, row: np.ndarray, zoom: float, p) -> np.ndarray:
    """Stable features inside the water margin that may still be joined as still objects
    (session 23, ``ClusterParams.far_top_px``; 0: off): those lying between ``far_top_px`` and
    ``water_margin_px`` (times the zoom) under the horizon (the waterline of a ship far out, about
    5-8 px under it at any zoom) in columns that hold no coast: no stable feature lies between
    ``far_coast_gap_px`` and ``far_coast_px`` (times the zoom) above the horizon within
    ``far_cols_px`` (times the zoom) of their column (a distant coast shows features above the
    horizon; a ship's own superstructure rises only a few pixels above it, which the gap leaves out).

    ``xy`` (N, 2) the stable features, ``row`` (N,) the horizon's row at each one's column (NaN:
    none).  Returns (N,) bool."""
    ok = np.isfinite(row)
    y = xy[:, 1]
    with np.errstate(invalid="ignore"):
        band = ok & (y > row + p.far_top_px * zoom) & (y <= row + p.water_margin_px * zoom)
        up = ok & (y < row - p.far_coast_gap_px * zoom) & (y >= row - p.far_coast_px * zoom)
    if band.any() and up.any():
        dx = np.abs(xy[band, 0][:, None] - xy[up, 0][None, :]).min(axis=1)
        b = np.flatnonzero(band)
        band[b[dx <= p.far_cols_px * zoom]] = False
    return band


def _far_cut(xy: np.ndarray, ei: np.ndarray, ej: np.ndarray, horizon, zoom: float, p) -> np.ndarray:
    """Which graph edges ``(ei, ej)`` (indices into ``xy``) to keep under ``ClusterParams.far_cut_px``
    (session 26, helper H22): an edge is dropped when its upper end lies less than ``far_cut_px``
    (source px, not scaled) under the horizon's row at its column, or above it, and its lower end
    lies more than ``far_cut_gap_px`` (times ``zoom``) below the upper end.  A feature whose column
    has no horizon row (NaN) keeps its edges."""
    ei = np.asarray(ei, np.int64)
    ej = np.asarray(ej, np.int64)
    y = xy[:, 1].astype(np.float64)
    top = np.where(y[ei] <= y[ej], ei, ej)
    dy = np.abs(y[ei] - y[ej])
    row = np.asarray(horizon.row_at(xy[top, 0].astype(np.float64)), np.float64)
    with np.errstate(invalid="ignore"):
        cut = (y[top] < row + p.far_cut_px) & (dy > p.far_cut_gap_px * zoom)
        if p.far_cut_deep_px > 0:  # session 26 round 2 (H25): a deeper band with a longer gap
            cut |= (y[top] < row + p.far_cut_deep_px) & (dy > p.far_cut_deep_gap_px * zoom)
    return ~cut


def _far_open(image: np.ndarray, x: np.ndarray, horizon, zoom: float, p) -> np.ndarray:
    """Whether open sea lies beside each column ``x`` (session 23, ``ClusterParams.far_open_px``):
    at ``far_open_px`` (times the zoom) to the left or to the right of it, the rows from 3 to 1 px
    (times the zoom) above the horizon are sky: each within ``far_sky_tol`` grey levels (or a quarter
    of the sky-sea contrast, if larger) of the sky 14-20 px (times the zoom) above the horizon in
    that column (7 columns averaged).  The foot of a coast lies under a dark strip that rises a few
    pixels above the horizon and runs on for hundreds of pixels; a ship far out has open sea on at
    least one side.  A side outside the image is not open.  With ``far_open_contrast`` > 0 a side
    where the sky and the sea (2-6 px, times the zoom, under the water margin) differ by less than
    that many grey levels counts as open: the test cannot tell a coast there (a thermal image's sky
    near the sea's temperature, with a warm band along the horizon), and the stable-feature coast
    check of :func:`_far_still` alone decides.  Returns (N,) bool."""
    img = np.asarray(image)
    if img.ndim == 3 or img.dtype != np.uint8:
        img = to_grey_u8(img)
    h, w = img.shape[:2]
    x = np.asarray(x, np.float64)
    d = p.far_open_px * zoom
    xs = np.round(np.concatenate([x - d, x + d])).astype(np.int64)  # the two sides
    inside = (xs >= 3) & (xs < w - 3)
    xs = np.clip(xs, 3, max(w - 4, 3))
    row = np.asarray(horizon.row_at(xs.astype(np.float64)), np.float64)
    inside &= np.isfinite(row)
    row = np.where(np.isfinite(row), row, 0.0)
    near = np.arange(int(np.floor(-3 * zoom)), int(np.floor(-1 * zoom)) + 1)
    sky = np.arange(int(np.floor(-20 * zoom)), int(np.floor(-14 * zoom)) + 1)
    sea = np.arange(int(np.floor((p.water_margin_px + 2) * zoom)), int(np.floor((p.water_margin_px + 6) * zoom)) + 1)
    r0 = np.floor(row).astype(np.int64)
    inside &= (r0 + sky[0] >= 0) & (r0 + sea[-1] < h)
    lo = int(max(np.min(r0 + sky[0]), 0))
    hi = int(min(np.max(r0 + sea[-1]) + 1, h))
    if hi <= lo or not inside.any():
        return np.zeros(len(x), bool)
    strip = cv2.blur(img[lo:hi].astype(np.float32), (7, 1))  # 7 columns averaged

    def rows(off):
        rr = np.clip(r0[:, None] + off[None, :] - lo, 0, hi - lo - 1)
        return strip[rr, xs[:, None]]

    sky_v = _row_medians_f32(rows(sky))  # np.median(..., axis=1)
    sea_v = _row_medians_f32(rows(sea))
    tol = np.maximum(p.far_sky_tol, 0.25 * np.abs(sky_v - sea_v))
    ok = (np.abs(rows(near) - sky_v[:, None]) <= tol[:, None]).all(axis=1)
    if p.far_open_contrast > 0:
        ok |= np.abs(sky_v - sea_v) < p.far_open_contrast
    ok &= inside
    n = len(x)
    return ok[:n] | ok[n:]


def _coast_foot(xy: np.ndarray, k: np.ndarray, n: int, boxes: np.ndarray, idx: np.ndarray, image,
                horizon, zoom: float, p) -> np.ndarray:
    """Which reported clusters are the foot of a coast (session 25, ``ClusterParams.foot_open_px``; 0:
    off): all their members lie less than ``water_margin_px`` (times the zoom) under the horizon and
    the sky does not reach down to the horizon ``foot_open_px`` (times the zoom) left of the box's left
    edge nor as far right of its right edge (:func:`_far_open`'s test, with its ``far_sky_tol`` and
    ``far_open_contrast``).  A ship far out has open sea beside it; the dark foot of a coast runs on.

    ``xy`` (M, 2) the members, ``k`` (M,) each one's cluster (0..n-1), ``boxes`` (C, 4) the clusters
    still reported, ``idx`` (C,) their cluster indices.  Returns (C,) bool."""
    out = np.zeros(len(idx), bool)
    if not len(idx) or not len(xy):
        return out
    row = np.asarray(horizon.row_at(xy[:, 0].astype(np.float64)), np.float64)
    dy = np.where(np.isfinite(row), xy[:, 1] - row, np.inf)
    deep = np.full(n, -np.inf)
    np.maximum.at(deep, k, dy)
    cand = np.flatnonzero(deep[idx] <= p.water_margin_px * zoom)
    if not len(cand):
        return out
    img = np.asarray(image)
    if img.ndim == 3 or img.dtype != np.uint8:
        img = to_grey_u8(img)  # once for every candidate (the tests below take a grey image as it is)
    dark = float(getattr(p, "foot_dark", 0.0))
    half = 0.5 * boxes[cand, 2].astype(np.float64)
    mid = boxes[cand, 0].astype(np.float64) + half
    if dark <= 0:
        for j, c in enumerate(cand):
            q = _FootSide(p.foot_open_px + half[j] / zoom, p.far_sky_tol, p.far_open_contrast, p.water_margin_px)
            out[c] = not bool(_far_open(img, mid[j:j + 1], horizon, zoom, q)[0])
        return out
    # the two sides of every candidate in one call each (the tests work column by column, so a batch
    # gives each column's answer as a call of its own would)
    d = (p.foot_open_px + half / zoom) * zoom
    xs = np.stack([mid - d, mid + d], axis=1).ravel()  # left, right of each candidate
    q0 = _FootSide(0.0, p.far_sky_tol, p.far_open_contrast, p.water_margin_px)
    side = _far_open(img, xs, horizon, zoom, q0) & ~_under_dark(img, xs, horizon, zoom, p, dark)
    out[cand] = ~side.reshape(-1, 2).any(axis=1)
    return out


def _under_dark(image: np.ndarray, x: np.ndarray, horizon, zoom: float, p, dark: float) -> np.ndarray:
    """Whether a dark strip lies just under the horizon at each column ``x`` (session 25,
    ``ClusterParams.foot_dark``): the rows 1-4 px (times the zoom) under the horizon are darker than
    the sea 2-6 px (times the zoom) under the water margin by more than ``dark`` grey levels (7 columns
    averaged); never where sky and sea differ by less than ``far_open_contrast`` (a thermal image) nor
    outside the image.  The foot of a coast can lie wholly under the sea horizon's row, with the sky
    reaching down to it; open sea under the horizon is as bright as the sea below, or brighter (haze).
    Returns (N,) bool."""
    img = np.asarray(image)
    if img.ndim == 3 or img.dtype != np.uint8:
        img = to_grey_u8(img)
    h, w = img.shape[:2]
    xs = np.round(np.asarray(x, np.float64)).astype(np.int64)
    inside = (xs >= 3) & (xs < w - 3)
    xs = np.clip(xs, 3, max(w - 4, 3))
    row = np.asarray(horizon.row_at(xs.astype(np.float64)), np.float64)
    inside &= np.isfinite(row)
    r0 = np.floor(np.where(np.isfinite(row), row, 0.0)).astype(np.int64)
    under = np.arange(int(np.floor(1 * zoom)), int(np.floor(4 * zoom)) + 1)
    sky = np.arange(int(np.floor(-20 * zoom)), int(np.floor(-14 * zoom)) + 1)
    sea = np.arange(int(np.floor((p.water_margin_px + 2) * zoom)), int(np.floor((p.water_margin_px + 6) * zoom)) + 1)
    inside &= (r0 + sky[0] >= 0) & (r0 + sea[-1] < h)
    out = np.zeros(len(xs), bool)
    if not inside.any():
        return out
    lo = int(max(np.min(r0[inside] + sky[0]), 0))
    hi = int(min(np.max(r0[inside] + sea[-1]) + 1, h))
    strip = cv2.blur(img[lo:hi].astype(np.float32), (7, 1))

    def rows(off):
        rr = np.clip(r0[:, None] + off[None, :] - lo, 0, hi - lo - 1)
        return _row_medians_f32(strip[rr, xs[:, None]])  # np.median(..., axis=1)

    sky_v, sea_v, under_v = rows(sky), rows(sea), rows(under)
    out = inside & (sea_v - under_v > dark)
    if p.far_open_contrast > 0:
        out &= ~(np.abs(sky_v - sea_v) < p.far_open_contrast)
    return out


@dataclass
class _FootSide:
    """The fields :func:`_far_open` reads, for :func:`_coast_foot`'s box-wide distance."""
    far_open_px: float
    far_sky_tol: float
    far_open_contrast: float
    water_margin_px: float


def assign_identities(
    prev_labels: np.ndarray, comp: np.ndarray, next_id: int, min_share: float = 0.0,
    origin: np.ndarray | None = None, comp_vel: np.ndarray | None = None, split_dv: float = 0.0,
    major: bool = False,
) -> tuple[np.ndarray, int]:
    """Identities of this frame's clusters from the identities their features carried.

    Parameters
    ----------
    prev_labels : (N,) int64 identity each feature carried (-1: none).
    comp : (N,) int64 cluster (component) index of each feature this frame (-1: in no cluster).
    next_id : int, the next free identity (identities are issued in increasing order, so a
        smaller identity is an older one).
    min_share : float
        Not in the paper (0: off, the paper's rules).  A carried identity claims a component
        only when its features there number at least this fraction of those of the identity
        most carried in that component: one or two features remembering a dead cluster's
        identity (the label memory) do not give that older identity to the cluster they join.
    origin, comp_vel, split_dv :
        Not in the paper (``split_dv`` 0: off; ``ClusterParams.split_origin_dv_px_s``, session 22):
        ``origin`` (N,) the identity each feature had before its cluster merged into an older one
        (:class:`AffinityClusters`' origin memory), ``comp_vel`` (C, 2) each component's mean
        velocity (px/s, NaN: unknown).  When an identity's features lie in two or more components
        whose velocities differ by more than ``split_dv`` (a split of boats moving apart, not of one
        boat's parts), it goes to the component holding most of its features that had it before the
        merge (``origin`` equal to it), instead of most of its features: the rib's cluster that took
        a few features of the fishing boat, and then the fishing boat's cluster, keeps its identity
        on the rib when they part.  The other parts get new identities as in the paper.
    major : bool
        Not in the paper (False: off; ``ClusterParams.merge_id_major_ir``, session 25, helper H18):
        identities are handed out by the number of their features in a component first (most first),
        then oldest first: when two clusters merge, the identity carried by most of the merged
        cluster's features keeps it (the big boat's cluster that absorbs a small boat's keeps its
        own identity), not the oldest one; the other identity is left without a cluster.

    Returns
    -------
    cluster_ids : (C,) int64 identity of each component ``0 .. C-1`` (C = ``comp.max() + 1``).
    next_id : the next free identity afterwards.

    Notes
    -----
    Identities are handed out oldest first: each carried identity goes to the unclaimed
    component holding most of its features (ties: the larger component, then the lower index).
    So a merge keeps the oldest identity; a split leaves the identity with the part holding
    most of its features, and the other parts, and components whose features carried none,
    get new identities.
    """
    prev_labels = np.asarray(prev_labels, np.int64)
    comp = np.asarray(comp, np.int64)
    n_comp = int(comp.max()) + 1 if comp.size and comp.max() >= 0 else 0
    ids = np.full(n_comp, -1, np.int64)
    if n_comp == 0:
        return ids, next_id
    size = np.bincount(comp[comp >= 0], minlength=n_comp)
    m = (comp >= 0) & (prev_labels >= 0)
    if m.any():
        lab, c = prev_labels[m], comp[m]
        pairs, counts = np.unique(np.stack([lab, c], axis=1), axis=0, return_counts=True)
        if min_share > 0:
            cmax = np.zeros(n_comp, np.int64)
            np.maximum.at(cmax, pairs[:, 1], counts)
            ok = counts >= min_share * cmax[pairs[:, 1]]
            pairs, counts = pairs[ok], counts[ok]
        # oldest label first; within a label most features, then larger component, lower index
        if major:
            order = np.lexsort((pairs[:, 1], -size[pairs[:, 1]], pairs[:, 0], -counts))
        else:
            order = np.lexsort((pairs[:, 1], -size[pairs[:, 1]], -counts, pairs[:, 0]))
        split = split_dv > 0 and origin is not None and comp_vel is not None
        if split:
            # features per (label, component) that carried the label before a merge too
            mo = m & (np.asarray(origin, np.int64) == prev_labels)
            own = collections.Counter(zip(prev_labels[mo].tolist(), comp[mo].tolist()))
        done_labels: set[int] = set()
        for q, k in enumerate(order):
            lab_k, c_k = int(pairs[k, 0]), int(pairs[k, 1])
            if lab_k in done_labels or ids[c_k] >= 0:
                continue
            if split:
                cand = [int(pairs[kk, 1]) for kk in order[q:] if int(pairs[kk, 0]) == lab_k and ids[pairs[kk, 1]] < 0]
                if len(cand) > 1:
                    v = comp_vel[cand]
                    fin = np.isfinite(v).all(axis=1)
                    if fin.sum() > 1:
                        vf = v[fin]
                        spread = np.hypot(vf[:, None, 0] - vf[None, :, 0], vf[:, None, 1] - vf[None, :, 1]).max()
                        if spread > split_dv:
                            best = max(cand, key=lambda c: own.get((lab_k, c), 0))  # first of the ties
                            if own.get((lab_k, best), 0) > own.get((lab_k, c_k), 0):
                                c_k = best
            ids[c_k] = lab_k
            done_labels.add(lab_k)
    for c in np.flatnonzero(ids < 0):
        ids[c] = next_id
        next_id += 1
    return ids, next_id


@nb.njit(cache=True, nogil=True)
def _affinity_update(w_all, linked_all, has, ss, pi, pj, act_s, alpha, w_cap, w_link):
    """One frame's affinity update of the slots ``ss`` in place (see :meth:`AffinityClusters.step`):
    every weight among them decays by 1, those of this frame's edges ``(pi, pj)`` (indices into
    ``ss``) grow by ``alpha`` instead, clipped to ``[0, w_cap]``; a link forms at ``w_link`` and
    holds while the weight is positive.  Float32 arithmetic, as the weights are stored.  Returns
    the links among the ``act_s`` features as index pairs ``i < j`` into ``ss``, row by row."""
    m = len(ss)
    edge = np.zeros((m, m), np.bool_)
    for k in range(len(pi)):
        edge[pi[k], pj[k]] = True
        edge[pj[k], pi[k]] = True
    one = np.float32(1.0)
    gain = np.float32(1.0 + alpha)
    cap = np.float32(w_cap)
    wl = np.float32(w_link)
    zero = np.float32(0.0)
    n_links = 0
    li = np.empty(m * (m - 1) // 2 if m > 1 else 0, np.int64)
    lj = np.empty_like(li)
    for i in range(m):
        si = ss[i]
        any_pos = False
        for j in range(m):
            sj = ss[j]
            if i == j:
                w_all[si, sj] = zero
                linked_all[si, sj] = False
                continue
            w = w_all[si, sj] - one
            if edge[i, j]:
                w = w + gain
            if w < zero:
                w = zero
            elif w > cap:
                w = cap
            lk = (w >= wl) or (linked_all[si, sj] and w > zero)
            w_all[si, sj] = w
            linked_all[si, sj] = lk
            if w > zero:
                any_pos = True
            if lk and j > i and act_s[i] and act_s[j]:
                li[n_links] = i
                lj[n_links] = j
                n_links += 1
        has[si] = any_pos
    return li[:n_links], lj[:n_links]


class AffinityClusters:
    """The affinity graph of the features and its clusters (paper B, step 3).

    State is kept per storage slot (a feature's slot is stable over its life), in dense arrays.

    Parameters
    ----------
    alpha : float
        Weight added to a pair on re-association (an edge of the frame's graph) (paper: 3).
    w_link : float
        Weight at which a link forms (paper: 1); it breaks when the weight falls to 0.
    w_cap : float
        Largest weight (0: none).  Not in the paper; without one, a pair associated for a long
        time would stay linked for as many frames after the objects separate.  The cap used is
        at least ``w_link + alpha``.
    min_features : int
        Features a cluster needs (paper: 2).
    label_memory_s : float
        How long a feature remembers the identity of its cluster after leaving every cluster,
        so that a cluster that dissolves for a moment comes back with its identity.
    unmerge : bool
        Not in the paper (False: the paper's rules).  Each feature also remembers the identity
        it had before its cluster merged into an older one; identities are then handed out by
        those (:func:`assign_identities` on them), so a merge still keeps the oldest identity
        but when the merged cluster splits again each part gets back the identity its features
        had before the merge (the paper: the part holding most features keeps the merged
        identity, the others get new ones).  Two boats whose clusters merge while they pass
        each other keep their identities when they part.
    """

    def __init__(
        self, alpha: float = 3.0, w_link: float = 1.0, w_cap: float = 15.0, min_features: int = 2,
        label_memory_s: float = 2.0, unmerge: bool = False, gate_clusters: bool = False,
        min_share: float = 0.0, gate_rel: float = 0.0, gate_rel_min_px_s: float = 0.0,
        gate_chain: bool = False, split_origin_dv: float = 0.0, split_origin_s: float = 0.0,
        cut_dv: float = 0.0, cut_parts: bool = False, cut_hold: float = 0.0, gate_ema_s: float = 0.0,
    ) -> None:
        if alpha <= 0 or w_link <= 0:
            raise ValueError(f"affinity: alpha ({alpha}) and w_link ({w_link}) must be > 0")
        self.alpha = float(alpha)
        self.w_link = float(w_link)
        self.w_cap = float(w_cap) if w_cap > 0 else np.inf
        self.w_cap = max(self.w_cap, self.w_link + self.alpha)
        self.min_features = max(2, int(min_features))
        self.label_memory_s = float(label_memory_s)
        self.unmerge = bool(unmerge)
        self.gate_clusters = bool(gate_clusters)
        self.min_share = float(min_share)
        self.gate_rel = float(gate_rel)
        self.gate_rel_min_px_s = float(gate_rel_min_px_s)
        self.gate_chain = bool(gate_chain)
        self.split_origin_dv = float(split_origin_dv)
        self.split_origin_s = float(split_origin_s)
        self.cut_dv = float(cut_dv)
        self.cut_parts = bool(cut_parts)
        self.cut_hold = float(cut_hold)
        self.gate_ema_s = float(gate_ema_s)
        self.id_major = False  # assign_identities' ``major`` (FeatureClusterer: ``merge_id_major_ir``)
        self.reset()

    def reset(self) -> None:
        self._cap = 0
        self._w = np.zeros((0, 0), np.float32)
        self._linked = np.zeros((0, 0), bool)
        self._fid = np.zeros(0, np.int64)
        self._label = np.zeros(0, np.int64)
        self._label_t = np.zeros(0)
        self._origin = np.zeros(0, np.int64)  # identity before the last merge into an older one
        self._has = np.zeros(0, bool)  # slots with a positive weight to some other slot
        self._cut = np.zeros((0, 0), bool)  # cut_hold: pairs whose link was cut (held while they differ)
        self.next_id = 1
        self.birth_s: dict[int, float] = {}
        self.merged_s: dict[int, float] = {}  # split_origin_s: last time a cluster absorbed another's features
        self.vel_est: dict[int, tuple[np.ndarray, float]] = {}  # gate_ema_s: identity -> (velocity, time)

    def _grow(self, need: int) -> None:
        if need <= self._cap:
            return
        new = max(need, 2 * self._cap, 64)
        w = np.zeros((new, new), np.float32)
        w[: self._cap, : self._cap] = self._w
        lk = np.zeros((new, new), bool)
        lk[: self._cap, : self._cap] = self._linked
        self._w, self._linked = w, lk
        if self.cut_hold > 0:
            ct = np.zeros((new, new), bool)
            ct[: self._cap, : self._cap] = self._cut
            self._cut = ct
        self._fid = np.r_[self._fid, np.full(new - self._cap, -1, np.int64)]
        self._label = np.r_[self._label, np.full(new - self._cap, -1, np.int64)]
        self._label_t = np.r_[self._label_t, np.full(new - self._cap, -np.inf)]
        self._origin = np.r_[self._origin, np.full(new - self._cap, -1, np.int64)]
        self._has = np.r_[self._has, np.zeros(new - self._cap, bool)]
        self._cap = new

    def weights(self, slot_a: int, slot_b: int) -> float:
        """Current affinity weight of two slots."""
        return float(self._w[slot_a, slot_b])

    def linked(self, slot_a: int, slot_b: int) -> bool:
        """Whether two slots are linked."""
        return bool(self._linked[slot_a, slot_b])

    def _velocity_gate(self, lab, vel, li, lj, t_s, max_dv, min_age_s):
        est = np.array([c for c, b in self.birth_s.items() if t_s - b >= min_age_s - 1e-9], np.int64)
        vref = {k: v for k, (v, _) in self.vel_est.items()} if self.gate_ema_s > 0 else None
        return _gate_links(lab, vel, li, lj, est, max_dv, self.gate_clusters, self.gate_rel, self.gate_rel_min_px_s,
                           vref)

    def step(
        self,
        slots: np.ndarray,
        ids: np.ndarray,
        edge_i: np.ndarray,
        edge_j: np.ndarray,
        t_s: float,
        active: np.ndarray | None = None,
        velocity: np.ndarray | None = None,
        max_dv_px_s: float = 0.0,
        min_age_s: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Update the affinity graph with one frame's edges and return the clusters.

        Parameters
        ----------
        slots : (N,) int storage slots of the features alive in this frame (features absent
            here are forgotten).
        ids : (N,) int64 their feature identities (a slot whose identity changed is a new feature).
        edge_i, edge_j : (E,) int indices into ``slots`` of this frame's graph edges.
        t_s : time of the frame (s).
        active : (N,) bool, the features that may be in a cluster this frame (the stable
            ones); all when None.  Inactive features keep and decay their weights.
        velocity : (N, 2) each feature's recent velocity relative to the scene (px/s, NaN when
            unknown), for the velocity gate below.
        max_dv_px_s : float
            Velocity gate (not in the paper; 0: off): a link between a feature of a cluster at
            least ``min_age_s`` old and a feature outside it does not join them this frame when
            that feature's velocity differs from the cluster's mean velocity by more than
            ``max_dv_px_s`` (vector difference; a feature of unknown velocity is not refused).
            The link's weight is kept; only the merge is refused.  The paper's magnitude term
            hardly separates slow objects (``N(m)`` is small below a few px per frame), so two
            neighbouring boats moving the same way at different slow speeds would merge.

        Returns
        -------
        labels : (N,) int64 cluster identity of each feature (-1: in no cluster).
        cluster_ids : (C,) int64 the identities of this frame's clusters, ascending.
        """
        slots = np.asarray(slots, np.int64)
        ids = np.asarray(ids, np.int64)
        n = len(slots)
        if n:
            self._grow(int(slots.max()) + 1)
        present = np.zeros(self._cap, bool)
        present[slots] = True
        changed = np.zeros(self._cap, bool)
        changed[slots] = self._fid[slots] != ids
        gone = ~present & (self._fid >= 0)
        reset = (changed | gone) & self._has
        if reset.any():
            r = np.flatnonzero(reset)
            self._w[r, :] = 0.0
            self._w[:, r] = 0.0
            self._linked[r, :] = False
            self._linked[:, r] = False
            self._has[r] = False
        if self.cut_hold > 0 and (changed | gone).any():
            r = np.flatnonzero(changed | gone)
            self._cut[r, :] = False
            self._cut[:, r] = False
        forget = changed | gone
        self._label[forget] = -1
        self._label_t[forget] = -np.inf
        self._origin[forget] = -1
        self._fid[gone] = -1
        self._fid[slots] = ids
        if n == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)

        # affinity weights: +alpha on re-association, -1 otherwise, link hysteresis; only the
        # features with a weight or an edge can change (the rest stay at 0)
        ei = np.asarray(edge_i, np.int64)
        ej = np.asarray(edge_j, np.int64)
        touched = self._has[slots].copy()
        touched[ei] = True
        touched[ej] = True
        sub = np.flatnonzero(touched)  # indices into slots
        ss = slots[sub]
        pos = np.full(n, -1, np.int64)
        pos[sub] = np.arange(len(sub))
        # clusters: connected components of the links among the active features
        act = np.ones(n, bool) if active is None else np.asarray(active, bool)
        act_s = act[sub]
        li, lj = _affinity_update(self._w, self._linked, self._has, ss, pos[ei], pos[ej], act_s,
                                  self.alpha, self.w_cap, self.w_link)
        lab = self._label[slots].copy()
        lab[t_s - self._label_t[slots] > self.label_memory_s] = -1
        chain = None
        if self.cut_dv > 0 and velocity is not None and len(li):
            # session 24 (helper H11, ``ClusterParams.graph_cut_dv_px_s``): a link whose two ends
            # both have a known velocity more than ``cut_dv`` apart joins nothing this frame, also
            # inside one cluster, so a cluster holding two boats that move apart falls into its
            # connected components (the paper's split keeps the identity on the larger part)
            vsub = np.asarray(velocity, np.float64)[sub]
            with np.errstate(invalid="ignore"):
                dl = np.hypot(*(vsub[li] - vsub[lj]).T)
            cut = dl > self.cut_dv  # NaN (unknown): kept
            if self.cut_hold > 0:
                # session 25 (helper H15, ``ClusterParams.graph_cut_hold``): a pair cut in an
                # earlier frame stays cut while its velocities still differ by more than
                # ``cut_hold`` times ``cut_dv`` (a noisy velocity dipping under the threshold for a
                # frame does not join the two boats again)
                held = self._cut[ss[li], ss[lj]]
                cut |= held & (dl > self.cut_hold * self.cut_dv)
            if self.cut_parts and cut.any():
                # ``graph_cut_parts``: a cut holds only where both its ends fall in parts of at least
                # ``min_features`` features (two boats); a cut that leaves a smaller piece (a boat
                # whose features' velocities are noisy) is undone
                m = len(sub)
                g = coo_matrix((np.ones(int((~cut).sum())), (li[~cut], lj[~cut])), shape=(m, m))
                _, cc0 = connected_components(g, directed=False)
                sz = np.bincount(cc0)
                cut &= (sz[cc0[li]] >= self.min_features) & (sz[cc0[lj]] >= self.min_features)
            if self.cut_hold > 0:
                self._cut[ss[li], ss[lj]] = cut
                self._cut[ss[lj], ss[li]] = cut
            keep = ~cut
            li, lj = li[keep], lj[keep]
        if max_dv_px_s > 0 and velocity is not None and len(li):
            vsub = np.asarray(velocity, np.float64)[sub]
            keep = self._velocity_gate(lab[sub], vsub, li, lj, t_s, max_dv_px_s, min_age_s)
            li, lj = li[keep], lj[keep]
            if self.gate_chain and self.gate_clusters and len(li):
                est = np.array([c for c, b in self.birth_s.items() if t_s - b >= min_age_s - 1e-9], np.int64)
                chain = _chain_components(lab[sub], vsub, li, lj, est, max_dv_px_s, self.gate_rel,
                                          self.gate_rel_min_px_s)
        comp = np.full(n, -1, np.int64)
        if len(li):
            m = len(sub)
            if chain is not None:
                cc = chain
            else:
                g = coo_matrix((np.ones(len(li)), (li, lj)), shape=(m, m))
                _, cc = connected_components(g, directed=False)
            size = np.bincount(cc)
            big = size[cc] >= self.min_features
            # renumber the components that are clusters to 0..C-1
            _, inv = np.unique(cc[big], return_inverse=True)
            comp[sub[big]] = inv

        vote = lab
        if self.unmerge:
            org = self._origin[slots]
            vote = np.where((lab >= 0) & (org >= 0), org, lab)
        if self.split_origin_dv > 0 and not self.unmerge and velocity is not None and (comp >= 0).any():
            vel_all = np.asarray(velocity, np.float64)
            nc = int(comp.max()) + 1
            fin = (comp >= 0) & np.isfinite(vel_all).all(axis=1)
            vs = np.zeros((nc, 2))
            np.add.at(vs, comp[fin], vel_all[fin])
            vn = np.bincount(comp[fin], minlength=nc)
            cvel = np.where(vn[:, None] > 0, vs / np.maximum(vn, 1)[:, None], np.nan)
            org = self._origin[slots]
            if self.split_origin_s > 0:
                # the origin rule only for identities that absorbed another's features recently
                recent = np.zeros(len(lab), bool)
                if self.merged_s and len(lab):
                    keys = np.fromiter(self.merged_s.keys(), np.int64, len(self.merged_s))
                    when = np.fromiter(self.merged_s.values(), np.float64, len(self.merged_s))
                    o = np.argsort(keys)
                    keys, when = keys[o], when[o]
                    i = np.minimum(np.searchsorted(keys, lab), len(keys) - 1)
                    recent = (keys[i] == lab) & (t_s - when[i] <= self.split_origin_s)
                org = np.where(recent, org, lab)
            cids, self.next_id = assign_identities(vote, comp, self.next_id, self.min_share, org,
                                                   cvel, self.split_origin_dv, major=self.id_major)
        else:
            cids, self.next_id = assign_identities(vote, comp, self.next_id, self.min_share, major=self.id_major)
        for c in cids:
            self.birth_s.setdefault(int(c), float(t_s))
        labels = np.full(n, -1, np.int64)
        labels[comp >= 0] = cids[comp[comp >= 0]]
        member = comp >= 0
        if self.unmerge or self.split_origin_dv > 0:
            # a feature absorbed into an older cluster keeps its origin; otherwise its origin
            # is its identity now (new feature, split part, unmerged part)
            sm = slots[member]
            old = lab[member]
            keep = (old >= 0) & (labels[member] <= old) & (self._origin[sm] >= 0)
            if self.split_origin_s > 0:
                for x in np.unique(labels[member][(old >= 0) & (labels[member] < old)]):
                    self.merged_s[int(x)] = float(t_s)
            self._origin[sm] = np.where(keep, self._origin[sm], labels[member])
        if self.gate_ema_s > 0 and velocity is not None and len(cids):
            self._update_vel_est(labels, cids, np.asarray(velocity, np.float64), t_s)
        self._label[slots[member]] = labels[member]
        self._label_t[slots[member]] = t_s
        live = set(int(c) for c in cids)
        # forget the birth of identities that no feature remembers any more
        if len(self.birth_s) > 4 * max(len(live), 16):
            valid = self._label[(self._label >= 0) & (t_s - self._label_t <= self.label_memory_s)]
            keep = live | set(int(x) for x in np.unique(valid))
            self.birth_s = {k: v for k, v in self.birth_s.items() if k in keep}
            self.merged_s = {k: v for k, v in self.merged_s.items() if k in keep}
            self.vel_est = {k: v for k, v in self.vel_est.items() if k in keep}
        return labels, np.sort(cids)

    def _update_vel_est(self, labels, cids, vel, t_s):
        """``gate_ema_s`` (session 25, helper H18): each cluster's established velocity, an exponential
        mean over time (time constant ``gate_ema_s``) of its members' mean velocity; the velocity gate
        compares a joining feature with it instead of this frame's mean, so a cluster whose members are
        replaced one by one by those of a neighbouring boat (its mean following them) still refuses them.
        A new identity (also a split part) starts from its members' mean."""
        m = labels >= 0
        fin = m & np.isfinite(vel).all(axis=1)
        if not fin.any():
            return
        u, inv = np.unique(labels[fin], return_inverse=True)
        vs = np.zeros((len(u), 2))
        np.add.at(vs, inv, vel[fin])
        vm = vs / np.bincount(inv, minlength=len(u))[:, None]
        for q, c in enumerate(u.tolist()):
            old = self.vel_est.get(c)
            if old is None:
                self.vel_est[c] = (vm[q].copy(), float(t_s))
            else:
                a = 1.0 - np.exp(-max(float(t_s) - old[1], 0.0) / self.gate_ema_s)
                self.vel_est[c] = (old[0] + a * (vm[q] - old[0]), float(t_s))


def _gate_links(lab, vel, li, lj, established, max_dv, clusters=False, rel=0.0, rel_min=0.0, vref=None):
    """Which links ``(li, lj)`` may join their ends (see :meth:`AffinityClusters.step`,
    ``max_dv_px_s``): False where one end belongs to an established cluster and the other, not
    in it, has a velocity more than ``max_dv`` from the cluster's mean velocity.  With
    ``clusters`` (stop 16), also False where the two ends belong to two different established
    clusters whose mean velocities differ by more than ``max_dv``: the feature test alone lets
    a link through when the end in one cluster is a stray member of the other object (its own
    velocity alike) and the other end's velocity is unknown.  ``rel`` (session 22, 0: off; with
    ``clusters``): two established clusters are also kept apart when their mean velocities differ by
    more than ``rel`` times the faster one's speed and by more than ``rel_min`` (px/s): a ferry at
    6 px/s and a rib at 3 px/s.  ``vref`` (session 25, helper H18; None: off): a mapping from a
    cluster's identity to its established velocity (px/s), used instead of this frame's mean velocity
    of its members where given and finite (:class:`AffinityClusters`' ``gate_ema_s``)."""
    keep = np.ones(len(li), bool)
    la, lb = lab[li], lab[lj]
    cand = (la != lb) & ((la >= 0) | (lb >= 0))
    if not cand.any():
        return keep
    labels = np.unique(lab[lab >= 0])
    labels = labels[np.isin(labels, established)]
    if not len(labels):
        return keep
    k = np.searchsorted(labels, lab)
    k = np.where((lab >= 0) & (k < len(labels)), k, -1)
    k[k >= 0] = np.where(labels[k[k >= 0]] == lab[k >= 0], k[k >= 0], -1)
    m = k >= 0
    nl = len(labels)
    fin = m & np.isfinite(vel).all(axis=1)
    vs = np.zeros((nl, 2))
    np.add.at(vs, k[fin], vel[fin])
    vn = np.bincount(k[fin], minlength=nl)
    vmean = np.where(vn[:, None] > 0, vs / np.maximum(vn, 1)[:, None], np.nan)
    if vref:
        for q, lb_ in enumerate(labels.tolist()):
            r = vref.get(lb_)
            if r is not None and np.isfinite(r).all():
                vmean[q] = r

    def refuse(c, o):
        """End ``c``'s cluster refuses the feature ``o``."""
        kc = k[c]
        ok = kc >= 0
        out = np.zeros(len(c), bool)
        if not ok.any():
            return out
        kc, oo = kc[ok], o[ok]
        with np.errstate(invalid="ignore"):
            out[ok] = np.hypot(*(vel[oo] - vmean[kc]).T) > max_dv  # NaN (unknown): not refused
        return out

    keep[cand] = ~(refuse(li[cand], lj[cand]) | refuse(lj[cand], li[cand]))
    if clusters:
        a, b = k[li], k[lj]
        both = cand & (a >= 0) & (b >= 0)
        if both.any():
            with np.errstate(invalid="ignore"):
                dvab = np.hypot(*(vmean[a[both]] - vmean[b[both]]).T)
                far = dvab > max_dv  # NaN: not refused
                if rel > 0:
                    fast = np.maximum(np.hypot(*vmean[a[both]].T), np.hypot(*vmean[b[both]].T))
                    far |= (dvab > rel * fast) & (dvab > rel_min)
            keep[np.flatnonzero(both)[far]] = False
    return keep


def _chain_components(lab, vel, li, lj, established, max_dv, rel=0.0, rel_min=0.0):
    """Components of the links ``(li, lj)`` among ``len(lab)`` features (``ClusterParams.gate_chain``,
    session 22): a union of the links, taken in the order of their ends' velocity difference (the
    links within one established cluster first; an unknown velocity last), that refuses each link
    whose two sets hold two established clusters the cluster-pair test of :func:`_gate_links`
    keeps apart (mean velocities more than ``max_dv`` apart, or with ``rel`` > 0 more than ``rel``
    times the faster one's speed and more than ``rel_min``).  So two such clusters are not joined
    through a chain of features outside them.  Returns each feature's component (a root index)."""
    m = len(lab)
    labels = np.unique(lab[lab >= 0])
    labels = labels[np.isin(labels, established)]
    nl = len(labels)
    k = np.full(m, -1, np.int64)
    if nl:
        kk = np.searchsorted(labels, lab)
        ok = (lab >= 0) & (kk < nl)
        ok[ok] = labels[kk[ok]] == lab[ok]
        k[ok] = kk[ok]
    apart = np.zeros((max(nl, 1), max(nl, 1)), np.bool_)
    if nl > 1:
        fin = (k >= 0) & np.isfinite(vel).all(axis=1)
        vs = np.zeros((nl, 2))
        np.add.at(vs, k[fin], vel[fin])
        vn = np.bincount(k[fin], minlength=nl)
        vmean = np.where(vn[:, None] > 0, vs / np.maximum(vn, 1)[:, None], np.nan)
        with np.errstate(invalid="ignore"):
            dv = np.hypot(vmean[:, None, 0] - vmean[None, :, 0], vmean[:, None, 1] - vmean[None, :, 1])
            far = dv > max_dv  # NaN (unknown): not apart
            if rel > 0:
                sp = np.hypot(vmean[:, 0], vmean[:, 1])
                fast = np.maximum(sp[:, None], sp[None, :])
                far |= (dv > rel * fast) & (dv > rel_min)
        apart[:nl, :nl] = far
    with np.errstate(invalid="ignore"):
        d = np.hypot(*(vel[li] - vel[lj]).T)
    d = np.where(np.isfinite(d), d, np.inf)
    d = np.where((k[li] >= 0) & (k[li] == k[lj]), -1.0, d)
    order = np.argsort(d, kind="stable")
    return _chain_union(m, li[order], lj[order], k, apart, nl)


@nb.njit(cache=True, nogil=True)
def _chain_union(m, li, lj, k, apart, nl):
    """The union-find of :func:`_chain_components`: ``has[r]`` the established clusters in the set of
    root ``r``, ``bad[r]`` those kept apart from one of them; a link joins two sets unless one holds a
    cluster the other keeps apart."""
    parent = np.arange(m)
    w = max(nl, 1)
    has = np.zeros((m, w), np.bool_)
    bad = np.zeros((m, w), np.bool_)
    for i in range(m):
        if k[i] >= 0:
            has[i, k[i]] = True
            for c in range(nl):
                bad[i, c] = apart[k[i], c]
    for e in range(len(li)):
        a = li[e]
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        b = lj[e]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        if a == b:
            continue
        clash = False
        for c in range(nl):
            if (has[a, c] and bad[b, c]) or (has[b, c] and bad[a, c]):
                clash = True
                break
        if clash:
            continue
        parent[b] = a
        for c in range(nl):
            has[a, c] = has[a, c] or has[b, c]
            bad[a, c] = bad[a, c] or bad[b, c]
    out = np.empty(m, np.int64)
    for i in range(m):
        r = i
        while parent[r] != r:
            r = parent[r]
        out[i] = r
    return out


@nb.njit(cache=True, nogil=True)
def _median_sorted(v):
    """Median of a sorted 1-D float32 array (the mean of the two middle values when even)."""
    n = len(v)
    if n % 2:
        return v[n // 2]
    return np.float32((v[n // 2 - 1] + v[n // 2]) / np.float32(2.0))


@nb.njit(cache=True, nogil=True)
def _row_medians_f32(a):
    """``np.median(a, axis=1)`` of a 2-d float32 array with no NaN (the same values: the middle
    one, or the two middle ones' float32 mean)."""
    out = np.empty(a.shape[0], np.float32)
    for r in range(a.shape[0]):
        out[r] = _median_sorted(np.sort(a[r]))
    return out


@nb.njit(cache=True, nogil=True)
def _window_background(win, bw):
    """Each row's background of a ``(rows, cols, C)`` window (per channel, the median of its
    ``bw`` left and ``bw`` right border pixels) and the border's robust noise (1.4826 times the
    median over the border of the largest channel deviation from it)."""
    rows, cols, nc = win.shape
    bg = np.empty((rows, nc), np.float32)
    buf = np.empty(2 * bw, np.float32)
    for r in range(rows):
        for c in range(nc):
            for k in range(bw):
                buf[k] = np.float32(win[r, k, c])
                buf[bw + k] = np.float32(win[r, cols - bw + k, c])
            bg[r, c] = _median_sorted(np.sort(buf))
    dev = np.empty(rows * 2 * bw, np.float32)
    i = 0
    for r in range(rows):
        for k in range(2 * bw):
            dev[i] = _edge_deviation(win, bg, r, k, bw)
            i += 1
    return bg, 1.4826 * float(_median_sorted(np.sort(dev)))


@nb.njit(cache=True, nogil=True, inline="always")
def _edge_deviation(win, bg, r, k, bw):
    """Largest channel deviation from the row's background of the ``k``-th of the ``2 bw`` edge
    pixels of row ``r`` (the ``bw`` leftmost columns, then the ``bw`` rightmost)."""
    return _pixel_deviation(win, bg, r, k if k < bw else win.shape[1] - 2 * bw + k)


@nb.njit(cache=True, nogil=True, inline="always")
def _pixel_deviation(win, bg, r, q):
    """Largest channel deviation of pixel ``(r, q)`` from its row's background ``bg[r]``."""
    m = np.float32(0.0)
    for c in range(win.shape[2]):
        d = abs(np.float32(win[r, q, c]) - bg[r, c])
        if d > m:
            m = d
    return m


@nb.njit(cache=True, nogil=True)
def _hist_rank(hist, k):
    """The bin holding the ``k``-th smallest value (0-based) of a histogram."""
    acc = 0
    for b in range(len(hist)):
        acc += hist[b]
        if acc > k:
            return b
    return len(hist) - 1


@nb.njit(cache=True, nogil=True)
def _hist_median(hist, n, step):
    """Median of ``n`` values counted in ``hist`` (bin b holds the value ``b * step``)."""
    if n % 2:
        return np.float32(_hist_rank(hist, n // 2) * step)
    lo = _hist_rank(hist, n // 2 - 1)
    hi = _hist_rank(hist, n // 2)
    return np.float32((lo + hi) * step / 2.0)


@nb.njit(cache=True, nogil=True)
def _window_background_u8(win, bw):
    """:func:`_window_background` for 8-bit windows, with histogram medians (exactly the same
    values: the medians of whole grey levels are whole or half levels)."""
    rows, cols, nc = win.shape
    bg = np.empty((rows, nc), np.float32)
    hist = np.zeros(256, np.int64)
    for r in range(rows):
        for c in range(nc):
            hist[:] = 0
            for k in range(bw):
                hist[win[r, k, c]] += 1
                hist[win[r, cols - bw + k, c]] += 1
            bg[r, c] = _hist_median(hist, 2 * bw, 1.0)
    dh = np.zeros(512, np.int64)  # deviations are multiples of half a grey level
    for r in range(rows):
        for k in range(2 * bw):
            dh[int(_edge_deviation(win, bg, r, k, bw) * 2.0 + 0.5)] += 1
    return bg, 1.4826 * float(_hist_median(dh, rows * 2 * bw, 0.5))


@nb.njit(cache=True, nogil=True)
def _window_deviation(win, bg, r0, r1, c0, c1):
    """Largest channel deviation from the row's background, over ``win[r0:r1, c0:c1]``."""
    out = np.empty((r1 - r0, c1 - c0), np.float32)
    for r in range(r0, r1):
        for q in range(c0, c1):
            out[r - r0, q - c0] = _pixel_deviation(win, bg, r, q)
    return out


@nb.njit(cache=True, nogil=True)
def _core_peak_u8(win, bg, r0, r1, c0, c1):
    """For an 8-bit window: the 90th percentile (``np.percentile``'s value, its "linear" method
    with its float32 interpolation) of the largest channel deviation from the row's background over
    ``win[r0:r1, c0:c1]``, 0 when that is empty; the deviations are multiples of half a grey level
    (the background is a whole or half level), so their order statistics come from a histogram."""
    if r1 <= r0 or c1 <= c0:
        return np.float32(0.0)
    hist = np.zeros(512, np.int64)
    for r in range(r0, r1):
        for q in range(c0, c1):
            hist[int(_pixel_deviation(win, bg, r, q) * 2.0 + 0.5)] += 1
    n = (r1 - r0) * (c1 - c0)
    vi = (n - 1) * 0.9
    if vi >= n - 1:
        return np.float32(_hist_rank(hist, n - 1) * 0.5)
    lo = int(np.floor(vi))
    g = vi - np.floor(vi)
    a = np.float32(_hist_rank(hist, lo) * 0.5)
    b = np.float32(_hist_rank(hist, lo + 1) * 0.5)
    d = b - a
    if g >= 0.5:
        return b - d * np.float32(1.0 - g)
    return a + d * np.float32(g)


@nb.njit(cache=True, nogil=True)
def _close_label(fg):
    """Labels (int32, 0 background, components numbered 1.. in no particular order) of the
    8-connected components of ``fg`` closed by a 3x3 square (``cv2.morphologyEx(MORPH_CLOSE)``
    with its default border: pixels outside the image neither dilate nor erode), and their count."""
    rows, cols = fg.shape
    # the 3x3 square is a 1x3 by a 3x1 segment: dilation and erosion along the rows, then the
    # columns (pixels outside the image are False for the dilation, True for the erosion)
    tmp = np.zeros((rows, cols), np.bool_)
    for r in range(rows):
        for c in range(cols):
            tmp[r, c] = fg[r, c] or (c > 0 and fg[r, c - 1]) or (c + 1 < cols and fg[r, c + 1])
    dil = np.zeros((rows, cols), np.bool_)
    for r in range(rows):
        for c in range(cols):
            dil[r, c] = tmp[r, c] or (r > 0 and tmp[r - 1, c]) or (r + 1 < rows and tmp[r + 1, c])
    for r in range(rows):
        for c in range(cols):
            tmp[r, c] = dil[r, c] and (c == 0 or dil[r, c - 1]) and (c + 1 == cols or dil[r, c + 1])
    par = np.empty(rows * cols + 1, np.int64)
    lab = np.zeros((rows, cols), np.int32)
    nxt = 1
    for r in range(rows):
        for c in range(cols):
            # closed: the row-eroded pixel and its upper and lower neighbours inside the image are set
            if not (tmp[r, c] and (r == 0 or tmp[r - 1, c]) and (r + 1 == rows or tmp[r + 1, c])):
                continue
            cur = 0
            # the neighbours already visited: left, and the three above
            for dr, dc in ((0, -1), (-1, -1), (-1, 0), (-1, 1)):
                rr, cc = r + dr, c + dc
                if rr < 0 or cc < 0 or cc >= cols:
                    continue
                o = lab[rr, cc]
                if o == 0:
                    continue
                while par[o] != o:
                    o = par[o]
                if cur == 0:
                    cur = o
                elif o != cur:
                    if o < cur:
                        par[cur] = o
                        cur = o
                    else:
                        par[o] = cur
            if cur == 0:
                par[nxt] = nxt
                cur = nxt
                nxt += 1
            lab[r, c] = cur
    # flatten: every label to its root, roots renumbered 1..n
    new = np.zeros(nxt, np.int32)
    n = 0
    for i in range(1, nxt):
        o = i
        while par[o] != o:
            o = par[o]
        if o == i:
            n += 1
            new[i] = n
    for i in range(1, nxt):
        o = i
        while par[o] != o:
            o = par[o]
        new[i] = new[o]
    for r in range(rows):
        for c in range(cols):
            if lab[r, c]:
                lab[r, c] = new[lab[r, c]]
    return lab, n


@nb.njit(cache=True, nogil=True)
def _one_sign(win, bg, dev, thr, r0, r1, c0, c1, frac, low=False, side=0):
    """The deviation ``dev`` (float32) of a window ``win`` from its rows' background ``bg`` kept to
    the core's polarity (session 20, ``grow_boxes``' ``sign_frac``): each pixel's sign is that of
    the sum over the channels of its difference from the background (darker -1, brighter +1);
    when at least ``frac`` of the core's foreground pixels (``dev > thr`` in ``[r0:r1, c0:c1]``)
    have one sign, the pixels of the other sign outside the core get deviation 0.  A dark hull's
    bright wake foam (or a bright hull's dark shadow) then no longer joins the object.  Returns
    ``(dev or its masked copy, polarity)``, polarity 0 when neither sign dominates.  With ``low``
    only the pixels from the core's top row down are masked (a superstructure of the other sign
    above the hull stays; a wake lies at the waterline).  With ``side`` -1 (+1) only the columns
    left (right) of the core are masked: the side a wake trails on (session 22); 0 all."""
    rows, cols = dev.shape
    nc = win.shape[2]
    sg = np.zeros((rows, cols), np.int8)
    for r in range(rows):
        for q in range(cols):
            s = np.float32(0.0)
            for c in range(nc):
                s += np.float32(win[r, q, c]) - bg[r, c]
            sg[r, q] = 1 if s > 0 else (-1 if s < 0 else 0)
    nd = 0
    nb_ = 0
    for r in range(r0, r1):
        for q in range(c0, c1):
            if dev[r, q] > thr:
                if sg[r, q] < 0:
                    nd += 1
                elif sg[r, q] > 0:
                    nb_ += 1
    tot = nd + nb_
    if tot == 0:
        return dev, 0
    if nd >= frac * tot and nd > nb_:
        pol = -1
    elif nb_ >= frac * tot and nb_ > nd:
        pol = 1
    else:
        return dev, 0
    out = dev.copy()
    q_lo = c1 if side > 0 else 0
    q_hi = c0 if side < 0 else cols
    for r in range(r0 if low else 0, rows):
        for q in range(q_lo, q_hi):
            if sg[r, q] == -pol and not (r0 <= r < r1 and c0 <= q < c1):
                out[r, q] = np.float32(0.0)
    return out, pol


@nb.njit(cache=True, nogil=True)
def _segment_object(dev, thr, max_fill, r0, r1, c0, c1, left_edge, right_edge):
    """The foreground (``dev > thr``; ``thr`` float32 as numpy compares a float32 array with a
    Python float) closed by a 3x3 square, its 8-connected components touching the core
    ``[r0:r1, c0:c1]`` and not the window's left (``left_edge``) or right (``right_edge``) column:
    ``(code, obj, x0, y0, x1, y1)`` with ``obj`` their mask and ``x0, y0, x1, y1`` (end exclusive)
    its extent.  ``code``: 0 found; 1 the foreground fills more than ``max_fill`` of the window or
    is empty; 2 every component touching the core was left out for the edges; 3 none touches it."""
    rows, cols = dev.shape
    fg = np.empty((rows, cols), np.bool_)
    cnt = 0
    for r in range(rows):
        for c in range(cols):
            f = dev[r, c] > thr
            fg[r, c] = f
            if f:
                cnt += 1
    obj = np.zeros((rows, cols), np.bool_)
    if cnt / (rows * cols) > max_fill or cnt == 0:
        return 1, obj, 0, 0, 0, 0
    lab, n = _close_label(fg)
    hit = np.zeros(n + 1, np.bool_)
    for r in range(r0, r1):
        for c in range(c0, c1):
            hit[lab[r, c]] = True
    hit[0] = False
    any_hit = False
    for i in range(1, n + 1):
        if hit[i]:
            any_hit = True
    if not any_hit:
        return 3, obj, 0, 0, 0, 0
    for r in range(rows):
        if left_edge:
            hit[lab[r, 0]] = False
        if right_edge:
            hit[lab[r, cols - 1]] = False
    x0, y0, x1, y1 = cols, rows, -1, -1
    for r in range(rows):
        for c in range(cols):
            if hit[lab[r, c]]:
                obj[r, c] = True
                x0 = min(x0, c)
                x1 = max(x1, c)
                y0 = min(y0, r)
                y1 = max(y1, r)
    if x1 < 0:
        return 2, obj, 0, 0, 0, 0
    return 0, obj, x0, y0, x1 + 1, y1 + 1


@nb.njit(cache=True, nogil=True)
def _top_row(dev, thr, x0, y0, x1, y1, left_edge, right_edge):
    """:func:`_extend_top`'s row after its quick check: the first row above ``y0`` holding, within
    the columns ``x0:x1``, a pixel of a component (of ``dev > thr`` closed by a 3x3 square,
    8-connected) that touches the rows ``y0:min(y0 + 2, y1)`` there and reaches neither the left
    (``left_edge``) nor the right (``right_edge``) column; ``y0`` when none."""
    rows, cols = dev.shape
    fg = np.empty((rows, cols), np.bool_)
    for r in range(rows):
        for c in range(cols):
            fg[r, c] = dev[r, c] > thr
    lab, n = _close_label(fg)
    if n == 0:
        return y0
    hit = np.zeros(n + 1, np.bool_)
    x1 = min(x1, cols)
    for r in range(y0, min(y0 + 2, y1, rows)):
        for c in range(x0, x1):
            hit[lab[r, c]] = True
    hit[0] = False
    for r in range(rows):
        if left_edge:
            hit[lab[r, 0]] = False
        if right_edge:
            hit[lab[r, cols - 1]] = False
    for r in range(0, min(y0, rows)):
        for c in range(x0, x1):
            if hit[lab[r, c]]:
                return r
    return y0


def grow_boxes(
    image: np.ndarray, boxes: np.ndarray, cores: np.ndarray, grow: float = 1.0, min_grow_px: float = 6.0,
    k_sigma: float = 3.0, min_contrast: float = 10.0, border_px: int = 3, max_fill: float = 0.5,
    peak_frac: float = 0.3, max_grow_px: float = 40.0, max_area_frac: float = 0.05,
    return_contrast: bool = False, wide_grow_px: float = 0.0, waterline_frac: float = 0.0,
    wake_frac: float = 0.0, trail: np.ndarray | None = None, top_frac: float = 0.0,
    cut_core_frac: float = 0.0, cut_core_undo: bool = False, wake_thick: bool = False,
    return_found: bool = False, sign_frac: float = 0.0, sign_max_px: float = 0.0,
    cover_wide: bool = False, hints: np.ndarray | None = None, hint_pad_px: float = 0.0,
    hint_core: float = 0.0, hint_core_x: bool = False, sign_side: np.ndarray | None = None,
    top_halo: float = 0.0, cores_retry: np.ndarray | None = None, top_min_px: float = 0.0,
    wake_core: float = 0.0, wake_front: float = 0.0,
) -> np.ndarray | tuple:
    """Grow each cluster's box to the object around it with a local segmentation.

    A cluster's features lie inside the hull, so the extent of its features is smaller than the
    object.  Around each box, a window grown by ``grow`` times the box's larger side (at least
    ``min_grow_px``, at most ``max_grow_px``, which bounds the cost) on every side is segmented against its background: each row's background
    is the median of the window's left and right border strips (a tenth of the window wide, at
    least ``border_px``; this follows the sky-to-sea gradient at the horizon), a pixel is foreground where it differs from it by
    more than the larger of ``k_sigma`` times the border's robust noise and ``min_contrast``
    grey levels (in any colour channel) and than ``peak_frac`` times the contrast inside the
    cluster's core (the features' extent; this leaves out a thermal halo), and the foreground's
    connected components that touch the core and not the window's left or right edge make the
    new box.  The box is kept as it was
    when nothing touches the core or the foreground fills more than ``max_fill`` of the window
    (a textured background, not one object), when the core itself does not stand out from the
    background, and when the box covers more than ``max_area_frac`` of the image (its contrast
    is still measured).  Not in the paper.

    Parameters
    ----------
    image : (H, W) or (H, W, C) image, in the pixels of the boxes.
    boxes : (N, 2) ... (N, 4) boxes ``x, y, w, h``.
    cores : (N, 4) the features' extent ``x, y, w, h`` of each cluster (within its box).
    wide_grow_px : float
        When the object's components touching the core all reach the window's left or right
        edge (a hull longer than the window, or a coastline), or the core does not stand out
        from the window's border strips (which may lie on a long hull), look again in a window
        grown by this many pixels to the left and right (0: never); a coastline still reaches
        its edges and is left out, a hull is now held inside, and its contrast is the wider
        window's.  Not in the paper (stop 13).
    waterline_frac : float
        Cut the reflection (0: off; not in the paper, stop 15): each row's contrast is the median
        of its deviation from the background over the object's columns; the object ends below
        the lowest row whose contrast reaches this fraction of the strongest row's.  A boat's
        reflection on the water is a fainter copy of it, so its rows fall below the hull's at
        the waterline.
    wake_frac : float
        Keep a wake out of the width (0: off; not in the paper, stop 15): after the waterline
        cut, on the side given by ``trail``, a run of columns at the object's end whose height
        (from its top foreground pixel to the object's bottom) is below this fraction of the
        75th percentile of the columns' heights is dropped when the run is at least 3 px and a
        quarter of the object's width long (a wake is a long, thin band of foam at the
        waterline behind a moving boat; the hull and its superstructure are tall).
    trail : (N,) int, optional
        The side of each object that a wake would trail on: -1 left, +1 right, 0 none (the
        boat's motion across the image points the other way).  None: no wake is cut.
    top_frac : float
        Keep the superstructure in (0: off; not in the paper, stop 15): the object's top goes up
        to the top of the foreground found with this fraction of the core's contrast instead of
        ``peak_frac`` (components touching the object's top rows within its columns and not the
        window's left or right edge; only rows above the object count, so its width and bottom
        stay).  A bridge or a sail against the sky stands out less than the dark hull on the
        water.
    cut_core_frac : float
        The core check of the two cuts (0: off; not in the paper, stop 16): the waterline cut
        may leave out at most this fraction of the core's height (the core is the features'
        extent, ``cores``), and the wake cut at most this fraction of its width; a cut that
        would leave out more is limited to that (``cut_core_undo`` False) or undone (True).
        The features lie on the boat, so a cut through the middle of them is more likely a
        darker hull under a bright cabin, or a low stern, than a reflection or a wake.
    cut_core_undo : bool
        See ``cut_core_frac``.
    return_found : bool
        Also return whether each box was grown (session 19; implies ``return_contrast``).
    sign_frac : float
        Grow to the core's polarity only (0: off; not in the paper, session 20): when at least
        this fraction of the core's foreground pixels are darker than the background (or that
        fraction brighter), the pixels of the other sign outside the core are not foreground for the
        segmentation and the cuts (the top extension, ``top_frac``, still sees them).  A dark
        hull's wake is bright foam at its stern; with both signs the growing joined the foam
        to the hull (the rib of sim ``pan``: reports 2-6 times its size).  Negative: the same
        fraction, but only the pixels from the core's top row down are masked (the other sign above
        the core, a superstructure, stays in).
    sign_max_px : float
        ``sign_frac`` only for boxes (as given, before the growing) at most this tall (0: all).  A
        ship seen large is often two clusters of opposite polarity (a dark hull, a white
        superstructure) whose grown boxes overlap and are reported as one; kept to their
        polarities they are reported apart.
    sign_side : (N,) int, optional
        ``sign_frac`` only behind a moving boat (not in the paper; session 22; None: off): only for
        boxes whose side is -1 (left) or +1 (right), and only the columns beyond the core on that
        side are masked (a wake's foam trails behind the boat; the other polarity above or beside
        the core, a large ship's superstructure or its other parts, stays in); 0: not masked.
    cover_wide : bool
        Also look in the wider window (``wide_grow_px``) when the object found in the first window
        does not cover the core (not in the paper; session 21, off by default).  A ship at full
        zoom is longer than the first window: its hull's components reach the window's left or
        right edge and are left out, and what remains (a mast, a fragment of the bridge) covers
        too little of a core spread over the hull; without this the box stays the features'
        extent in that frame and is grown to the whole ship in the next.
    hints : (N, 4) float, optional
        A box per cluster to look in when both windows fail (NaN: none; not in the paper;
        session 21): the cluster's grown box of the frame before, carried by the camera motion.
        The window is the union of the box and its hint, grown by ``hint_pad_px`` on every side
        (at least ``min_grow_px``), with the same checks (the components touching the core and
        not the window's left or right edge, covering most of the core).  A part of a long hull
        that was grown to the whole ship keeps that box while the image still shows it.
    hint_pad_px : float
        See ``hints``.
    hint_core : float
        A hint is used only when at least this fraction of the core's area lies inside it (0: any;
        session 21): the features are still on the object that was grown; a cluster whose features
        moved onto a neighbouring boat would otherwise be grown over both.
    hint_core_x : bool
        ``hint_core`` on the columns only: the fraction of the core's width inside the hint's (the
        features on a hull's reflection lie below its grown box, which the waterline cut ends at
        the waterline).
    wake_thick : bool
        The wake cut measures each column by its number of foreground pixels (its thickness)
        instead of its height from its top foreground pixel to the object's bottom (not in the
        paper; session 19): a wake seen at a slant (a Kelvin arm running down and back from a small
        boat) is a thin line whose columns' heights to the object's bottom are large.

    wake_front : float
        The wake cut (where ``wake_frac`` is on and a trailing side is set) takes its reference height
        from the columns of this fraction of the object's width at its leading end (the side away from
        ``trail``: the hull leads its wake), times ``wake_core`` where that is on, else ``wake_frac``
        (0: off; session 26, H23).
    wake_core : float
        The wake cut (where ``wake_frac`` is on) drops the columns lower than this fraction of the
        75th percentile of the heights of the columns under the core (the features' extent)
        instead of ``wake_frac`` of all the object's columns' (0: off; not in the paper; session
        25, H20): a small fast boat's grown foreground may be mostly its wake, whose own height
        is then the reference and nothing is cut.  Without a positive column under the core, all
        columns count.

    top_halo : float
        The top extension (``top_frac``) only through foreground brighter than this many times the
        halo beside the object (0: off; not in the paper; session 23): the 90th percentile of the
        deviations in the two columns left and right of the object over its rows.  A warm boat's
        thermal halo lies around it, as far above the hull as beside it; its own superstructure
        stands out more than the halo beside the hull.

    top_min_px : float
        The top extension (``top_frac``) only for an object at least this many pixels tall as found
        (after the cuts; 0: all; not in the paper; session 24): a line one or two pixels tall at the
        waterline (a small boat's wake behind it) has no superstructure; raised into the sea texture
        above it, it was no longer a line for ``ClusterParams.max_aspect`` and was reported (and
        took the boat's identity).

    cores_retry : (N, 4) float, optional
        A second core per cluster (NaN: none; not in the paper; session 23): where every window
        above failed, the first window is tried once more with this core (the members' inner
        quantiles on infrared frames, ``ClusterParams.grow_core_retry_ir``).

    Returns
    -------
    boxes : (N, 4) float64 grown boxes.
    contrast : (N,) float64, only with ``return_contrast``: the core's contrast (90th percentile
        of its difference from the background) over the background's robust noise (at least 1
        grey level); NaN where the window is too small to tell.
    found : (N,) bool, only with ``return_found``: whether the box was grown (False: it is the
        box given).
    """
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[:, :, None]
    hh, ww = img.shape[:2]
    out = np.array(boxes, np.float64, copy=True).reshape(-1, 4)
    cores = np.asarray(cores, np.float64).reshape(-1, 4)
    b = int(border_px)
    contrast = np.full(len(out), np.nan)
    found = np.zeros(len(out), bool)
    trail = np.zeros(len(out), np.int64) if trail is None else np.asarray(trail, np.int64).reshape(-1)
    hints = None if hints is None else np.asarray(hints, np.float64).reshape(-1, 4)
    cores_retry = None if cores_retry is None else np.asarray(cores_retry, np.float64).reshape(-1, 4)
    for n in range(len(out)):
        x, y, w, h = out[n]
        large = w * h > max_area_frac * hh * ww  # no small hull hidden inside its features' extent
        gx = gy = min(max(min_grow_px, grow * max(w, h)), max_grow_px)  # features often lie along a line
        sf = sign_frac if (sign_max_px <= 0 or h <= sign_max_px) else 0.0
        side = 0
        if sign_side is not None:
            side = int(sign_side[n])
            sf = sf if side != 0 else 0.0
        box, contrast[n], wider = _grow_one(img, out[n], cores[n], gx, gy, large, b, k_sigma, min_contrast,
                                            max_fill, peak_frac, waterline_frac, wake_frac * (trail[n] != 0),
                                            int(trail[n]), top_frac, cut_core_frac, cut_core_undo, wake_thick,
                                            sf, cover_wide, side, top_halo, top_min_px, wake_core, wake_front)
        if box is None and wider and wide_grow_px > gx:
            # a hull longer than the window reaches its left and right edges as a coastline does
            # (or fills its border strips): look again in a window wide enough to hold it (a
            # coastline still reaches its edges)
            box, c2, _ = _grow_one(img, out[n], cores[n], wide_grow_px, gy, large, b, k_sigma, min_contrast,
                                   max_fill, peak_frac, waterline_frac, wake_frac * (trail[n] != 0),
                                   int(trail[n]), top_frac, cut_core_frac, cut_core_undo, wake_thick,
                                   sf, False, side, top_halo, top_min_px, wake_core, wake_front)
            if box is not None:
                contrast[n] = c2
        if (box is None and hints is not None and np.all(np.isfinite(hints[n])) and not large
                and (hint_core <= 0 or _inside_frac(cores[n], hints[n], hint_core_x) >= hint_core)):
            # the box grown in the frame before (carried by the camera): look where it was
            hb = hints[n]
            ux0, uy0 = min(x, hb[0]), min(y, hb[1])
            ux1, uy1 = max(x + w, hb[0] + hb[2]), max(y + h, hb[1] + hb[3])
            if ux0 < x - gx or ux1 > x + w + gx or uy0 < y - gy or uy1 > y + h + gy:  # beyond the first window
                pad = max(min_grow_px, hint_pad_px)
                box, c3, _ = _grow_one(img, np.array([ux0, uy0, ux1 - ux0, uy1 - uy0]), cores[n], pad, pad, large,
                                       b, k_sigma, min_contrast, max_fill, peak_frac, waterline_frac,
                                       wake_frac * (trail[n] != 0), int(trail[n]), top_frac, cut_core_frac,
                                       cut_core_undo, wake_thick, sf, False, side, top_halo, top_min_px, wake_core, wake_front)
                if box is not None:
                    contrast[n] = c3
        if box is None and cores_retry is not None and np.all(np.isfinite(cores_retry[n])) and not large:
            # the features' extent reaches beyond the object (a thermal halo's rim): its inner part
            box, c4, _ = _grow_one(img, out[n], cores_retry[n], gx, gy, large, b, k_sigma, min_contrast,
                                   max_fill, peak_frac, waterline_frac, wake_frac * (trail[n] != 0),
                                   int(trail[n]), top_frac, cut_core_frac, cut_core_undo, wake_thick,
                                   sf, cover_wide, side, top_halo, top_min_px, wake_core, wake_front)
            if box is not None:
                contrast[n] = c4
        if box is not None:
            out[n] = box
            found[n] = True
    if return_found:
        return out, contrast, found
    return (out, contrast) if return_contrast else out


def _core_quantiles(k, v, n, q, lo, hi):
    """Each cluster's ``q`` and ``1 - q`` quantiles (nearest rank inward: the ``floor(q (c - 1))``-th
    and ``ceil((1 - q) (c - 1))``-th of its ``c`` sorted values) of the members' coordinate ``v``
    (cluster index ``k`` in ``0..n-1``); clusters without members keep ``lo``, ``hi``.  With few
    members (``q (c - 1) < 1``) that is the full extent."""
    lo, hi = lo.copy(), hi.copy()
    o = np.lexsort((v, k))
    ks, vs = k[o], v[o]
    cnt = np.bincount(ks, minlength=n)
    start = np.concatenate(([0], np.cumsum(cnt)[:-1]))
    has = cnt > 0
    a = start + np.floor(q * (cnt - 1)).astype(np.int64)
    b = start + np.ceil((1.0 - q) * (cnt - 1)).astype(np.int64)
    lo[has] = vs[a[has]]
    hi[has] = vs[b[has]]
    return lo, hi


def _covers_a_report(boxes, reported, frac=0.25) -> np.ndarray:
    """Per box in ``boxes`` (``x, y, w, h``): whether it covers more than ``frac`` of the area of one
    of the ``reported`` boxes (a boat reported in this frame, so not the one looked for)."""
    g = np.asarray(boxes, np.float64).reshape(-1, 4)
    r = np.asarray(reported, np.float64).reshape(-1, 4)
    if not len(g) or not len(r):
        return np.zeros(len(g), bool)
    jx = np.maximum(np.minimum(g[:, None, 0] + g[:, None, 2], r[None, :, 0] + r[None, :, 2])
                    - np.maximum(g[:, None, 0], r[None, :, 0]), 0)
    jy = np.maximum(np.minimum(g[:, None, 1] + g[:, None, 3], r[None, :, 1] + r[None, :, 3])
                    - np.maximum(g[:, None, 1], r[None, :, 1]), 0)
    return np.any(jx * jy > frac * np.maximum(r[None, :, 2] * r[None, :, 3], 1e-9), axis=1)


def _inside_frac(a, b, x_only=False) -> float:
    """The fraction of box ``a``'s area (``x, y, w, h``; sides at least 1 px) that lies inside box ``b``
    (``x_only``: of its width inside ``b``'s columns)."""
    aw, ah = max(a[2], 1.0), max(a[3], 1.0)
    iw = min(a[0] + aw, b[0] + b[2]) - max(a[0], b[0])
    if x_only:
        return max(iw, 0.0) / aw
    ih = min(a[1] + ah, b[1] + b[3]) - max(a[1], b[1])
    return max(iw, 0.0) * max(ih, 0.0) / (aw * ah)


def _inside_frac_many(a, b) -> np.ndarray:
    """:func:`_inside_frac` row by row for two (N, 4) arrays of boxes ``x, y, w, h``."""
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    aw, ah = np.maximum(a[:, 2], 1.0), np.maximum(a[:, 3], 1.0)
    iw = np.minimum(a[:, 0] + aw, b[:, 0] + b[:, 2]) - np.maximum(a[:, 0], b[:, 0])
    ih = np.minimum(a[:, 1] + ah, b[:, 1] + b[:, 3]) - np.maximum(a[:, 1], b[:, 1])
    with np.errstate(invalid="ignore"):
        f = np.maximum(iw, 0.0) * np.maximum(ih, 0.0) / (aw * ah)
    return np.where(np.isfinite(f), f, 1.0)


def _grow_one(img, box, core_box, gx, gy, large, b, k_sigma, min_contrast, max_fill, peak_frac,
              waterline_frac=0.0, wake_frac=0.0, trail=0, top_frac=0.0, cut_core_frac=0.0, cut_core_undo=False,
              wake_thick=False, sign_frac=0.0, cover_wide=False, sign_side=0, top_halo=0.0, top_min_px=0.0,
              wake_core=0.0, wake_front=0.0):
    """One box of :func:`grow_boxes` in a window grown by ``gx`` (columns) and ``gy`` (rows):
    ``(grown box or None, contrast, wider)``; ``wider`` when a wider window may tell more: the
    components touching the core were all left out for reaching the window's left or right
    edge, or the core does not stand out from the window's border strips (which may lie on the
    object itself), or (``cover_wide``, session 21) the object found does not cover the core."""
    hh, ww = img.shape[:2]
    x, y, w, h = box
    x0, y0 = int(max(0, np.floor(x - gx))), int(max(0, np.floor(y - gy)))
    x1, y1 = int(min(ww, np.ceil(x + w + gx))), int(min(hh, np.ceil(y + h + gy)))
    bw = max(b, int(round(0.1 * (x1 - x0))))
    if x1 - x0 < 2 * bw + 3 or y1 - y0 < 3:
        return None, np.nan, False
    win = img[y0:y1, x0:x1]
    # (rows, C) background and its noise
    bg, sigma = (_window_background_u8 if win.dtype == np.uint8 else _window_background)(win, bw)
    cx, cy, cw, ch = core_box
    c0x, c0y = int(max(0, np.floor(cx)) - x0), int(max(0, np.floor(cy)) - y0)
    c1x, c1y = int(np.ceil(cx + cw)) - x0 + 1, int(np.ceil(cy + ch)) - y0 + 1
    c0x, c0y = max(c0x, 0), max(c0y, 0)
    core = (slice(c0y, max(c1y, c0y + 1)), slice(c0x, max(c1x, c0x + 1)))
    r0, r1 = min(core[0].start, win.shape[0]), min(core[0].stop, win.shape[0])
    q0, q1 = min(core[1].start, win.shape[1]), min(core[1].stop, win.shape[1])
    if win.dtype == np.uint8:
        peak = float(_core_peak_u8(win, bg, r0, r1, q0, q1))  # np.percentile(dev_core, 90), 0 when empty
    else:
        dev_core = _window_deviation(win, bg, r0, r1, q0, q1)
        peak = float(np.percentile(dev_core, 90)) if dev_core.size else 0.0
    contrast = peak / max(sigma, 1.0)
    if large or peak <= max(k_sigma * sigma, min_contrast):
        return None, contrast, not large  # the core does not stand out: nothing to grow to (here)
    dev = _window_deviation(win, bg, 0, win.shape[0], 0, win.shape[1])
    thr = max(k_sigma * sigma, min_contrast, peak_frac * peak)
    dev_all = dev
    if sign_frac != 0:  # the other polarity outside the core is not the object (a dark hull's foam)
        dev, _ = _one_sign(win, bg, dev, np.float32(thr), r0, r1, q0, q1, abs(float(sign_frac)), sign_frac < 0,
                           int(sign_side))
    # the foreground (numpy compares the float32 deviations with thr cast to float32) closed by
    # a 3x3 square, its components touching the core; a component reaching the window's left or
    # right edge is background structure (coast, horizon, sea texture), not the object (a mast or
    # a reflection may reach the top or the bottom); the image's own border is not the window's
    # edge: an object may be cut by it
    code, obj, nx0, ny0, nx1, ny1 = _segment_object(dev, np.float32(thr), float(max_fill), r0, r1, q0, q1,
                                                    x0 > 0, x1 < ww)
    if code:
        return None, contrast, code == 2
    nx0, nx1, ny0, ny1 = nx0 + x0, nx1 + x0, ny0 + y0, ny1 + y0
    # the object must cover most of the core (not a speck of noise at its corner)
    cw1, ch1 = max(cw, 1.0), max(ch, 1.0)
    iw = min(nx1, cx + cw1) - max(nx0, cx)
    ih = min(ny1, cy + ch1) - max(ny0, cy)
    if max(iw, 0.0) * max(ih, 0.0) < 0.5 * cw1 * ch1:
        return None, contrast, bool(cover_wide)
    if waterline_frac > 0 or wake_frac > 0:
        core_w = (cx - x0, cy - y0, cx + cw - x0, cy + ch - y0) if (cut_core_frac > 0 or wake_core > 0) else None
        nx0, ny0, nx1, ny1 = _trim_object(dev, obj, (nx0 - x0, ny0 - y0, nx1 - x0, ny1 - y0),
                                          waterline_frac, wake_frac, trail, core_w, cut_core_frac, cut_core_undo,
                                          wake_thick, wake_core, wake_front)
        nx0, nx1, ny0, ny1 = nx0 + x0, nx1 + x0, ny0 + y0, ny1 + y0
    if top_frac > 0 and top_frac < peak_frac and ny1 - ny0 >= top_min_px:
        tthr = max(k_sigma * sigma, min_contrast, top_frac * peak)
        if top_halo > 0:  # not through a thermal halo: as bright as the halo beside the object
            ox0, ox1, oy0, oy1 = nx0 - x0, nx1 - x0, ny0 - y0, ny1 - y0
            side = np.concatenate((dev_all[oy0:oy1, max(ox0 - 2, 0):ox0].ravel(), dev_all[oy0:oy1, ox1:ox1 + 2].ravel()))
            if side.size:
                tthr = max(tthr, top_halo * float(np.percentile(side, 90)))
        ny0 = y0 + _extend_top(dev_all, (nx0 - x0, ny0 - y0, nx1 - x0, ny1 - y0), tthr, x0 > 0, x1 < ww)
    return (nx0, ny0, nx1 - nx0, ny1 - ny0), contrast, False


def _extend_top(dev, ext, thr, left_edge, right_edge):
    """The object's top row (window pixels) raised to the foreground above it at the lower
    threshold ``thr`` (see :func:`grow_boxes`, ``top_frac``): components of that foreground
    touching the object's two top rows within its columns, not reaching the window's left
    (``left_edge``) or right (``right_edge``) edge; only their rows within the object's columns
    count."""
    x0, y0, x1, y1 = (int(v) for v in ext)
    if y0 <= 0 or not (dev[max(y0 - 2, 0):y0, x0:x1] > thr).any():
        return y0  # nothing above the object's top within reach of the closing
    return int(_top_row(dev, np.float32(thr), x0, y0, x1, y1, bool(left_edge), bool(right_edge)))


@nb.njit(cache=True, nogil=True)
def _last_strong_row(dev, y0, y1, x0, x1, frac):
    """The last row ``r - y0`` of ``dev[y0:y1, x0:x1]`` (float32) whose median reaches ``frac``
    (float32) times the largest row median, as ``np.median(axis=1)`` and numpy's float32 product
    give them (the median of an even count is the mean of the two middle values in float32)."""
    med = np.empty(y1 - y0, np.float32)
    for r in range(y0, y1):
        med[r - y0] = _median_sorted(np.sort(dev[r, x0:x1]))
    thr = frac * med.max()
    last = -1
    for i in range(len(med)):
        if med[i] >= thr:
            last = i
    return last


@nb.njit(cache=True, nogil=True)
def _tall_columns(m, frac, thick=False, r0=0, r1=-1):
    """For the object's mask ``m`` (rows, cols): each column's height (from its top pixel to the
    bottom, 0 without one), and the first and last column whose height is at least ``frac``
    times the 75th percentile of the positive heights (``np.percentile``'s float64 value; 0 when
    none is positive); ``(-1, -1)`` when no column is.  As the numpy code of :func:`_trim_object`.
    With ``thick``: each column's number of foreground pixels instead of its height, against
    ``frac`` times the largest of them.  ``r0:r1`` (``r1`` -1: all): the columns whose heights
    give the reference (the core's, ``wake_core``); all when none of them is positive."""
    rows, cols = m.shape
    ext = np.zeros(cols, np.int64)
    for c in range(cols):
        if thick:  # the column's thickness: its foreground pixels
            for r in range(rows):
                if m[r, c]:
                    ext[c] += 1
            continue
        for r in range(rows):
            if m[r, c]:
                ext[c] = rows - r
                break
    sub = ext[max(r0, 0):cols if r1 < 0 else min(r1, cols)]
    pos = np.sort(sub[sub > 0])
    if len(pos) == 0:
        pos = np.sort(ext[ext > 0])
    ref = 0.0
    n = len(pos)
    if thick and n:
        ref = float(pos[n - 1])  # the thickest column (a slanted wake may be most of the columns)
    elif n:
        vi = (n - 1) * 0.75
        if vi >= n - 1:
            ref = float(pos[n - 1])
        else:
            lo = int(np.floor(vi))
            g = vi - np.floor(vi)
            a, b = pos[lo], pos[lo + 1]
            d = b - a
            ref = b - d * (1.0 - g) if g >= 0.5 else a + d * g
    thr = frac * ref
    first, last = -1, -1
    for c in range(cols):
        if ext[c] >= thr:
            if first < 0:
                first = c
            last = c
    return first, last


def _trim_object(dev, sel, ext, waterline_frac, wake_frac, trail=0, core=None, core_frac=0.0, core_undo=False,
                 thick=False, wake_core=0.0, wake_front=0.0):
    """The object's extent ``ext = (x0, y0, x1, y1)`` (window pixels, end exclusive) with its
    reflection cut and its wake's columns dropped on the side ``trail`` (-1 left, +1 right; see
    :func:`grow_boxes`, ``waterline_frac`` and ``wake_frac``); ``dev`` is the window's deviation
    from its background, ``sel`` the object's foreground mask, or ``(labels, object's labels)``.
    ``core`` (``x0, y0, x1, y1``, window pixels, the features' extent) with ``core_frac`` > 0:
    a cut may leave out at most that fraction of the core's height (waterline) or width (wake);
    beyond it the cut is limited to that, or undone with ``core_undo``.  ``wake_core`` (> 0) with ``core``:
    the wake cut's reference height is the core's columns', its fraction ``wake_core`` (see
    :func:`grow_boxes`).  ``wake_front`` (> 0): the reference columns are instead that fraction of the
    object's width at its leading end (the side away from ``trail``)."""
    x0, y0, x1, y1 = (int(v) for v in ext)
    check = core is not None and core_frac > 0
    if waterline_frac > 0 and y1 - y0 >= 3:
        if x1 > x0 and dev.dtype == np.float32:  # the rows' medians in Numba (the same values)
            yc = y0 + int(_last_strong_row(dev, y0, y1, x0, x1, np.float32(waterline_frac))) + 1
        else:
            rows = np.median(dev[y0:y1, x0:x1], axis=1)
            strong = np.flatnonzero(rows >= waterline_frac * rows.max())
            yc = y0 + int(strong[-1]) + 1
        if check:
            ch = max(core[3] - core[1], 1.0)
            if min(core[3], y1) - yc > core_frac * ch:  # the cut leaves out too much of the core
                yc = y1 if core_undo else max(yc, min(y1, int(np.ceil(core[3] - core_frac * ch))))
        y1 = yc
    if wake_frac > 0 and trail != 0 and x1 - x0 >= 3:
        m = np.isin(sel[0][y0:y1, x0:x1], sel[1]) if isinstance(sel, tuple) else sel[y0:y1, x0:x1]
        # each column's height: from its top foreground pixel down to the object's bottom; the
        # first and last column at least wake_frac times their 75th percentile tall (-1: none)
        r0, r1, wf = 0, -1, float(wake_frac)
        if wake_core > 0 and core is not None:  # the reference: the columns under the features
            r0 = int(np.floor(core[0])) - x0
            r1 = max(int(np.ceil(core[2])) - x0, r0 + 1)
            wf = float(wake_core)
            if r1 <= 0:
                r0, r1 = 0, -1
        if wake_front > 0:  # session 26 (H23): the reference: the columns at the object's leading end
            nf = max(int(np.ceil(wake_front * (x1 - x0))), 1)
            r0, r1 = ((x1 - x0) - nf, x1 - x0) if trail < 0 else (0, nf)
        t0, t1 = _tall_columns(np.ascontiguousarray(m, np.bool_), wf, bool(thick), r0, r1)
        if t0 >= 0:
            # only a long run of low columns is a wake (not a bow or stern beside a mast)
            run = max(3, 0.25 * (x1 - x0))
            a, b = int(t0), (x1 - x0) - int(t1) - 1
            nx0, nx1 = x0 + (a if a >= run and trail < 0 else 0), x1 - (b if b >= run and trail > 0 else 0)
            if check:
                cw = max(core[2] - core[0], 1.0)
                if nx0 - max(core[0], x0) > core_frac * cw:  # the cut leaves out too much of the core
                    nx0 = x0 if core_undo else min(nx0, max(x0, int(np.floor(core[0] + core_frac * cw))))
                if min(core[2], x1) - nx1 > core_frac * cw:
                    nx1 = x1 if core_undo else max(nx1, min(x1, int(np.ceil(core[2] - core_frac * cw))))
            x0, x1 = nx0, nx1
    return x0, y0, x1, y1


@nb.njit(cache=True, nogil=True)
def _median_of(v):
    """``np.median`` of a 1-d finite array (the same value: the middle one, or the mean of the two
    middle ones)."""
    s = np.sort(v)
    n = len(s)
    if n % 2 == 1:
        return s[n // 2]
    return (s[n // 2 - 1] + s[n // 2]) / 2


@nb.njit(cache=True, nogil=True)
def _split_groups(history, m, k, n_clusters, anchor, dv, need):
    """The two velocity groups of each cluster for :meth:`FeatureClusterer._split_for_report`.

    ``history`` (N, W, 2) the snapshot's velocity samples (px/s, NaN: none), ``m`` (M,) the
    clustered features (indices into it), ``k`` (M,) each one's cluster (``0 .. n_clusters - 1``),
    ``anchor`` (M,) bool, the members inside their cluster's last box (all False: none), ``dv``
    and ``need`` as there.  Each member's velocity is the mean of its known samples, summed in
    the order ``np.nanmean(history[m], axis=1)`` sums them (the same values).  In a cluster with
    at least ``need + 2`` members of known velocity: ``med``, the median velocity of the anchored
    ones (of all when fewer than two are anchored); the members farther than ``dv`` from it
    (``far``, at least ``need``, with two or more left); ``med2``, their median; the far ones
    within ``dv`` of it (the part, at least ``need``), with ``med2`` farther than ``dv`` from
    ``med``: the cluster splits.  Medians as ``np.median``'s, distances by ``hypot``, so the
    outcome is that of the per-cluster numpy code this replaced.

    Returns ``ok`` (n_clusters,) bool, the clusters that split, and ``code`` (M,) int8: 1 a member
    of known velocity within ``dv`` of ``med``, 2 one of the part, 0 otherwise (3: far, not in
    the part); ``code`` is set for the members of clusters with enough known velocities."""
    n = len(m)
    w = history.shape[1]
    fv = np.full((n, 2), np.nan)
    fin = np.zeros(n, np.bool_)
    cnt = np.zeros(n_clusters, np.int64)
    for i in range(n):
        if w == 0:
            continue
        for d in range(2):
            x = history[m[i], 0, d]
            if x != x:
                tot = 0.0
                c = 0
            else:
                tot = x
                c = 1
            for j in range(1, w):
                x = history[m[i], j, d]
                if x != x:
                    tot += 0.0
                else:
                    tot += x
                    c += 1
            if c > 0:
                fv[i, d] = tot / c
        fin[i] = np.isfinite(fv[i, 0]) and np.isfinite(fv[i, 1])
        if fin[i]:
            cnt[k[i]] += 1
    ok = np.zeros(n_clusters, np.bool_)
    code = np.zeros(n, np.int8)
    # the members of known velocity of each cluster with enough of them, grouped (index order)
    start = np.zeros(n_clusters + 1, np.int64)
    for c in range(n_clusters):
        start[c + 1] = start[c] + (cnt[c] if cnt[c] >= need + 2 else 0)
    if start[n_clusters] == 0:
        return ok, code
    mem = np.empty(start[n_clusters], np.int64)
    fill = start[:-1].copy()
    for i in range(n):
        c = k[i]
        if fin[i] and cnt[c] >= need + 2:
            mem[fill[c]] = i
            fill[c] += 1
    for c in range(n_clusters):
        a, b = start[c], start[c + 1]
        nf = b - a
        if nf == 0:
            continue
        f = mem[a:b]
        na = 0
        for i in f:
            if anchor[i]:
                na += 1
        base = np.empty(na if na >= 2 else nf, np.int64)
        q = 0
        for i in f:
            if na < 2 or anchor[i]:
                base[q] = i
                q += 1
        med0 = _median_of(fv[base, 0])
        med1 = _median_of(fv[base, 1])
        nfar = 0
        for i in f:
            if np.hypot(fv[i, 0] - med0, fv[i, 1] - med1) > dv:
                code[i] = 3
                nfar += 1
            else:
                code[i] = 1
        if nfar < need or nf - nfar < 2:
            continue
        far = np.empty(nfar, np.int64)
        q = 0
        for i in f:
            if code[i] == 3:
                far[q] = i
                q += 1
        med20 = _median_of(fv[far, 0])
        med21 = _median_of(fv[far, 1])
        npart = 0
        for i in far:
            if np.hypot(fv[i, 0] - med20, fv[i, 1] - med21) <= dv:
                code[i] = 2
                npart += 1
        ok[c] = npart >= need and np.hypot(med20 - med0, med21 - med1) > dv
    return ok, code


def _box_members(k, vel, n, max_dv, anchor=None):
    """Members ``(k: cluster index, vel: velocity relative to the scene, px/s, NaN unknown)`` that
    count in their cluster's box: those within ``max_dv`` of the cluster's median velocity (and
    those of unknown velocity); a cluster left with fewer than two keeps all its members.
    ``anchor`` (bool per member, optional; stop 16): the members inside the cluster's last box;
    where at least two of them have a known velocity, the median is theirs (the box stays on the
    object it was on when the cluster holds features of two objects)."""
    k = np.ascontiguousarray(k, np.int64)
    vel = np.ascontiguousarray(vel, np.float64).reshape(-1, 2)
    anc = np.zeros(len(k), np.bool_) if anchor is None else np.ascontiguousarray(anchor, np.bool_)
    return _box_members_nb(k, vel, int(n), float(max_dv), anc)


@nb.njit(cache=True, nogil=True)
def _box_members_nb(k, vel, n, max_dv, anchor):
    """:func:`_box_members` in one pass (the medians as ``np.median``'s, the distances by
    ``np.hypot``, libm's as numpy's); ``anchor`` all False for none."""
    m = len(k)
    keep = np.ones(m, np.bool_)
    # the members of each cluster, in index order (a counting sort)
    cnt = np.zeros(n + 1, np.int64)
    for i in range(m):
        cnt[k[i] + 1] += 1
    for c in range(n):
        cnt[c + 1] += cnt[c]
    order = np.empty(m, np.int64)
    pos = cnt[:n].copy()
    for i in range(m):
        order[pos[k[i]]] = i
        pos[k[i]] += 1
    f = np.empty(m, np.int64)
    fa = np.empty(m, np.int64)
    for c in range(n):
        mc = order[cnt[c]:cnt[c + 1]]
        nf = 0
        na = 0
        for i in mc:
            if np.isfinite(vel[i, 0]) and np.isfinite(vel[i, 1]):
                f[nf] = i
                nf += 1
                if anchor[i]:
                    fa[na] = i
                    na += 1
        if nf < 3:
            continue
        sel = fa[:na] if na >= 2 else f[:nf]
        mx = _median_of(vel[sel, 0])
        my = _median_of(vel[sel, 1])
        nfar = 0
        for j in range(nf):
            i = f[j]
            if np.hypot(vel[i, 0] - mx, vel[i, 1] - my) > max_dv:
                nfar += 1
        if len(mc) - nfar >= 2:
            for j in range(nf):
                i = f[j]
                if np.hypot(vel[i, 0] - mx, vel[i, 1] - my) > max_dv:
                    keep[i] = False
    return keep


def _box_iou(a, b) -> float:
    """Intersection over union of two boxes ``x, y, w, h`` (0 when either is empty)."""
    iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    if not (iw > 0 and ih > 0):
        return 0.0
    inter = iw * ih
    union = a[2] * a[3] + b[2] * b[3] - inter
    return float(inter / union) if union > 0 else 0.0


def _merge_overlapping(cids, boxes, count, vel, min_overlap, rel_vel=None, gap_h=0.0, max_dv=0.0, min_h=0.0,
                       sticky=None, groups=None, sticky_gap_px=0.0, sticky_gap_h=0.0, apart=None, id_dv=0.0,
                       id_ratio=2.0, id_apart=False, prev=None, keep_iou=0.0,
                       keep_now_iou=0.0, keep_now_any=False):
    """Report clusters whose boxes overlap by at least ``min_overlap`` of the smaller box as one
    object (two clusters grown to the same object): the oldest identity stays, the box is the
    union, the velocity the feature-weighted mean.  With ``gap_h`` > 0 and ``rel_vel`` (each
    cluster's mean velocity relative to the scene, px/s), also two boxes side by side (their rows
    overlapping by half the lower box) less than ``gap_h`` times the taller box's height apart,
    whose relative velocities differ by at most ``max_dv``, when both are at least ``min_h`` tall
    (parts of one long hull seen large, e.g. the bow and the superstructure of a ship at full
    zoom; small boats side by side are left apart).  ``sticky``: pairs of cluster identities
    (frozensets) joined in the last frame: they stay joined while their boxes of this frame
    overlap, touch or lie at most ``sticky_gap_px``, or ``sticky_gap_h`` times the taller box's
    height where that is more, apart (in x and in y) and their relative
    velocities differ by at most ``max_dv`` (``max_dv`` 0: any velocity; an unknown velocity
    counts as alike); ``groups`` (a list), when given, receives the
    identities joined into each report (a list per report, in the order returned).  ``apart``:
    pairs of identities (frozensets) never joined (a cluster and its split part).  ``id_dv`` (0: off,
    the oldest identity stays; session 21, H3): with ``rel_vel``, a report joined from clusters that
    move differently keeps the identity of the cluster holding most features (ties: the oldest), or
    the oldest of the clusters whose velocities lie within ``id_dv`` of that one's (an unknown
    velocity counts as alike), when that cluster holds at least ``id_ratio`` times the features of
    the oldest (otherwise the oldest stays, so two boats of like size do not swap the identity
    from frame to frame): a small cluster on a slow boat whose grown box covers a passing
    boat does not give that boat its older identity.  The kept identity comes first in its
    ``groups`` entry.  ``id_apart`` (with ``id_dv``): two reports whose largest clusters move
    differently and of which neither holds ``id_ratio`` times the other's features are not joined
    (two boats of like size passing each other stay two reports).  ``prev`` (a dict: cluster
    identity -> its report's box in the frame before, carried to this frame) with ``keep_iou`` > 0
    (session 22, H5): a joined report takes the identity of the member whose box in ``prev``
    overlaps the joined box most (IoU), when that IoU is at least ``keep_iou``, whatever the
    rules above say: a report joined from the same clusters keeps the identity it had, and a small
    boat's cluster inside a big boat's box does not give the big boat's report its older identity
    frame by frame as the join comes and goes.  ``keep_now_iou`` (0: off; session 29, with ``prev`` and
    ``keep_iou``): where no member passes ``keep_iou``, the member whose box in ``prev`` overlaps the
    joined box most (below ``keep_iou``) takes the identity when its own box of this frame overlaps
    the joined box by at least ``keep_now_iou`` (the frame before's box can be a part of the boat).
    ``keep_now_any`` (False: off; session 31, h41, with ``keep_now_iou``): where that member's own box does not
    confirm it and the ``id_dv`` rule did not choose, the member in ``prev`` whose own box of this frame overlaps
    the joined box most, by at least ``keep_now_iou``, takes the identity, unless the oldest holds ``id_ratio``
    times its features (a report joined by age alone goes to the boat it covers)."""
    order = np.argsort(cids, kind="stable")  # oldest (smallest) identity first
    cids, boxes, count, vel = cids[order], boxes[order].copy(), count[order].copy(), vel[order].copy()
    own = {int(c): boxes[q].copy() for q, c in enumerate(cids)} if keep_now_iou > 0 else {}  # before any join
    n0 = count.copy()  # each cluster's own feature count and velocity, before any join
    v0 = None if rel_vel is None or id_dv <= 0 else np.asarray(rel_vel, np.float64)[order].copy()
    pos0 = {int(c): q for q, c in enumerate(cids)}
    rv = None if rel_vel is None or gap_h <= 0 else np.asarray(rel_vel, np.float64)[order].copy()
    sv = None if rel_vel is None or not sticky else np.asarray(rel_vel, np.float64)[order].copy()
    alive = np.ones(len(cids), bool)
    members = [[int(c)] for c in cids]
    for i in range(len(cids)):
        if not alive[i]:
            continue
        for j in range(i + 1, len(cids)):
            if not alive[j]:
                continue
            if apart and any(frozenset((x, y)) in apart for x in members[i] for y in members[j]):
                continue
            if id_apart and v0 is not None:
                bi = max((pos0[c] for c in members[i]), key=lambda x: (n0[x], -x))
                bj = max((pos0[c] for c in members[j]), key=lambda x: (n0[x], -x))
                dvij = v0[bi] - v0[bj]
                if (np.all(np.isfinite(dvij)) and np.hypot(dvij[0], dvij[1]) > id_dv
                        and max(count[i], count[j]) < id_ratio * min(count[i], count[j])):
                    continue  # two boats of like size moving differently
            a, b = boxes[i], boxes[j]
            iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
            ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
            small = min(a[2] * a[3], b[2] * b[3])
            join = iw > 0 and ih > 0 and small > 0 and iw * ih >= min_overlap * small
            gap = max(sticky_gap_px, sticky_gap_h * max(a[3], b[3]))
            if (not join and sticky and iw >= -gap and ih >= -gap
                    and any(frozenset((x, y)) in sticky for x in members[i] for y in members[j])):
                # joined in the last frame and their boxes still touch: one object unless they move apart
                dv = np.zeros(2) if sv is None else sv[i] - sv[j]
                join = not (np.all(np.isfinite(dv)) and np.hypot(dv[0], dv[1]) > max_dv > 0)
            if (not join and rv is not None and min(a[3], b[3]) >= min_h and ih >= 0.5 * min(a[3], b[3]) > 0
                    and -iw <= gap_h * max(a[3], b[3])):
                dv = rv[i] - rv[j]
                join = bool(np.all(np.isfinite(dv)) and np.hypot(dv[0], dv[1]) <= max_dv)
            if join:
                x0, y0 = min(a[0], b[0]), min(a[1], b[1])
                x1, y1 = max(a[0] + a[2], b[0] + b[2]), max(a[1] + a[3], b[1] + b[3])
                boxes[i] = (x0, y0, x1 - x0, y1 - y0)
                tot = max(count[i] + count[j], 1)
                vel[i] = (vel[i] * count[i] + vel[j] * count[j]) / tot
                if rv is not None:
                    rv[i] = (rv[i] * count[i] + rv[j] * count[j]) / tot
                if sv is not None:
                    if np.all(np.isfinite(sv[i])) and np.all(np.isfinite(sv[j])):
                        sv[i] = (sv[i] * count[i] + sv[j] * count[j]) / tot
                    elif not np.all(np.isfinite(sv[i])):
                        sv[i] = sv[j]
                count[i] += count[j]
                members[i] += members[j]
                alive[j] = False
    by_dv = set()  # the reports whose identity the id_dv rule chose
    if v0 is not None:
        pos = {int(c): q for q, c in enumerate(cids)}
        cids = cids.copy()
        for i in np.flatnonzero(alive):
            if len(members[i]) < 2:
                continue
            q = [pos[c] for c in members[i]]  # oldest first
            big = max(q, key=lambda x: (n0[x], -x))
            if n0[big] < id_ratio * n0[q[0]]:
                continue
            by_dv.add(int(i))
            alike = []
            for x in q:
                dv = v0[x] - v0[big]
                if not (np.all(np.isfinite(dv)) and np.hypot(dv[0], dv[1]) > id_dv):
                    alike.append(x)
            keep = min(alike)  # the oldest that moves with the largest cluster
            cids[i] = cids[keep]
            members[i] = [int(cids[keep])] + [c for c in members[i] if c != int(cids[keep])]
    if prev and keep_iou > 0:
        cids = cids.copy()
        for i in np.flatnonzero(alive):
            if len(members[i]) < 2:
                continue
            best, best_iou = None, keep_iou
            for c in members[i]:  # the kept identity first: it wins ties
                pb = prev.get(c)
                if pb is None:
                    continue
                u = _box_iou(boxes[i], pb)
                if u >= best_iou and (best is None or u > best_iou):
                    best, best_iou = c, u
            if best is None and keep_now_iou > 0:
                # the member whose box in the frame before overlaps the joined box most, confirmed by its own box now
                top, top_iou = None, 0.0
                for c in members[i]:
                    if c in prev:
                        u = _box_iou(boxes[i], prev[c])
                        if u > top_iou:
                            top, top_iou = c, u
                if top is not None and _box_iou(boxes[i], own[top]) >= keep_now_iou:
                    best = top
                elif keep_now_any and int(i) not in by_dv:
                    # session 31 (h41): any member reported in the frame before whose own box now covers the
                    # joined box, where the identity was left to the oldest by age alone
                    top, top_iou = None, keep_now_iou
                    n_old = n0[pos0[min(members[i])]]
                    for c in members[i]:
                        if c in prev and id_ratio * n0[pos0[c]] > n_old:  # not far fewer features than the oldest
                            u = _box_iou(boxes[i], own[c])
                            if u >= top_iou and (top is None or u > top_iou):
                                top, top_iou = c, u
                    best = top
            if best is not None:
                cids[i] = best
                members[i] = [best] + [c for c in members[i] if c != best]
    if groups is not None:
        groups.extend(members[i] for i in np.flatnonzero(alive))
    return cids[alive], boxes[alive], count[alive], vel[alive]


APPEARANCE_SIZE = (16, 8)  # the appearance template's width and height (pixels)


def appearance_signature(image: np.ndarray, box) -> tuple[np.ndarray, np.ndarray] | None:
    """An object's look in ``box`` (``x, y, w, h``) of ``image`` ((H, W) or (H, W, C)), for the
    relink's appearance check, against its surroundings: the background is the median, per
    channel, of a ring around the box (half the box's larger side wide, at least 2 pixels; the
    image's border cuts it); the box's deviation from it gives ``(template, contrast)``: the
    object's contrast, per channel, the mean deviation of the box's 30 % most deviating pixels
    (the object rather than the water around it: it does not depend on how tight the box is), and
    the deviation's grey levels resampled to a 16x8 template (pixel areas averaged: a zoom
    changes nothing), scaled to unit norm (its sign kept).  None when the box holds less than 2x2
    pixels of the image."""
    h, w = image.shape[:2]
    x0, y0 = max(int(np.floor(box[0])), 0), max(int(np.floor(box[1])), 0)
    x1, y1 = min(int(np.ceil(box[0] + box[2])), w), min(int(np.ceil(box[1] + box[3])), h)
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    m = max(2, int(0.5 * max(x1 - x0, y1 - y0)))
    bx0, by0, bx1, by1 = max(x0 - m, 0), max(y0 - m, 0), min(x1 + m, w), min(y1 + m, h)
    big = np.asarray(image[by0:by1, bx0:bx1], np.float32)
    if big.ndim == 2:
        big = big[:, :, None]
    ring = np.ones(big.shape[:2], bool)
    ring[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0] = False
    bg = np.median(big[ring] if ring.any() else big.reshape(-1, big.shape[2]), axis=0)
    dev = big[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0] - bg
    g = np.abs(dev).mean(axis=2)
    contrast = dev[g >= np.percentile(g, 70)].mean(axis=0)
    tpl = cv2.resize(np.ascontiguousarray(dev.mean(axis=2)), APPEARANCE_SIZE, interpolation=cv2.INTER_AREA).ravel()
    return tpl / max(float(np.sqrt(np.dot(tpl, tpl))), 1e-3), contrast


def appearance_parts(a, b) -> tuple[float, float]:
    """The two parts of the appearance distance between signatures ``a`` and ``b``
    (:func:`appearance_signature`): the contrasts' difference relative to the stronger contrast
    (Euclidean over the channels; at least 1 grey level; 0 alike, 1 one of them flat, 2
    inverted), and ``(1 - correlation of the templates) / 2`` (0 alike, 1 inverted)."""
    ca, cb = a[1], b[1]
    dc = float(np.sqrt(np.sum((ca - cb) ** 2)) / max(float(np.sqrt(np.sum(ca * ca))), float(np.sqrt(np.sum(cb * cb))), 1.0))
    return dc, 0.5 * (1.0 - float(np.dot(a[0], b[0])))


def appearance_distance(a, b, template_weight: float = 0.0) -> float:
    """The appearance distance between two signatures (:func:`appearance_signature`): the
    contrasts' part plus ``template_weight`` times the templates' part (:func:`appearance_parts`)."""
    dc, dt = appearance_parts(a, b)
    return dc + template_weight * dt


def _limit_jump(box, pre, last, ratio):
    """The grown ``box`` (``x, y, w, h``) no more than ``ratio`` times as wide and as tall as
    ``last`` (the same cluster's grown box in the frame before, carried by the camera): along each
    axis where it is larger, the side that reaches farther beyond ``pre`` (the box before the
    growing) is moved in (then the other, where one is not enough); ``box`` itself when ``last``
    is not finite or not positive (``ClusterParams.grow_jump``, session 25)."""
    out = np.array(box, np.float64, copy=True)
    if not (np.all(np.isfinite(last)) and last[2] > 0 and last[3] > 0):
        return out
    for a in (0, 1):
        lim = ratio * last[2 + a]
        ex = out[2 + a] - lim
        if ex <= 0:
            continue
        lo, hi = out[a], out[a] + out[2 + a]
        out_lo = pre[a] - lo  # how far the box reaches beyond the pre-grow box on each side
        out_hi = hi - (pre[a] + pre[2 + a])
        if out_lo >= out_hi:
            cut = min(ex, max(out_lo, 0.0))
            lo += cut
            hi -= ex - cut
        else:
            cut = min(ex, max(out_hi, 0.0))
            hi -= cut
            lo += ex - cut
        out[a], out[2 + a] = lo, hi - lo
    return out


def _carry_box(box, hmg):
    """Box ``x, y, w, h`` carried by the homography ``hmg`` (its two corners); the box itself when
    a corner maps to infinity."""
    c = np.array([[box[0], box[1]], [box[0] + box[2], box[1] + box[3]]], np.float64)
    q = c @ hmg[:2, :2].T + hmg[:2, 2]
    w = c @ hmg[2, :2] + hmg[2, 2]
    if np.any(np.abs(w) < 1e-12):
        return np.asarray(box, np.float64)
    q = q / w[:, None]
    return np.array([q[0, 0], q[0, 1], q[1, 0] - q[0, 0], q[1, 1] - q[0, 1]])


def _keep_edge(a0, a1, size, last):
    """The interval ``[a0, a1]`` cut to ``size``: keeping the end that lies nearer to its place in
    ``last`` (``(l0, l1)``, the interval of the frame before), or its centre when ``last`` is None."""
    if last is None:
        m = 0.5 * (a0 + a1)
        return m - 0.5 * size, m + 0.5 * size
    if abs(a0 - last[0]) <= abs(a1 - last[1]):
        return a0, a0 + size
    return a1 - size, a1


def _iou(a, b) -> float:
    """Intersection over union of two boxes (x, y, w, h)."""
    iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    if iw <= 0 or ih <= 0:
        return 0.0
    inter = iw * ih
    return float(inter / max(a[2] * a[3] + b[2] * b[3] - inter, 1e-12))


def _moves_alike(v_lost, v_new, max_dv) -> bool:
    """Whether two own velocities (px/s) differ by at most ``max_dv`` (vector difference); True
    when either is unknown (None or not finite)."""
    if v_lost is None or v_new is None:
        return True
    a, b = np.asarray(v_lost, np.float64), np.asarray(v_new, np.float64)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return True
    return float(np.hypot(*(a - b))) <= max_dv


@dataclass(frozen=True)
class ClusterParams:
    """Parameters of the clustering (paper B defaults: Dmax 0.31, alpha 3, Wlink 1, R 50 px).

    The fields after ``confirm_s`` act on the output only and are not in the paper (see
    ``docs/stable_features.md``): box growing, contrast check, merge of overlapping reports, and
    the identity relink (``relink_s``, ``relink_px``, ``relink_px_per_s``, ``relink_predict``,
    ``relink_predict_s``, ``relink_overlap``, ``relink_camera``, ``relink_min_s``; see
    :meth:`FeatureClusterer._relink`), ``grow_wide_px`` (see :func:`grow_boxes`) and
    ``merge_gap_h`` / ``merge_gap_min_px`` (side-by-side reports, off).  Two act on the
    clustering and are not in the paper either: ``merge_dv_px_s`` (the velocity gate of
    :meth:`AffinityClusters.step`; 0 gives the paper's clustering) and ``unmerge`` (off; see
    :class:`AffinityClusters`).  ``relink_min_s``: when the cluster that took a lost identity
    dies within this time, the identity is lost again as it was before (0: off);
    ``relink_undo_drop_alias`` (off) also takes the identity from that cluster's label memory
    (on, it raised sim `pan` seed-0 ID switches from 5 to 14 in the stop-13 bench).
    Stop 14: ``sky_margin_px`` (5; 0 off): with a horizon, a report whose box bottom lies more
    than this (times the zoom) above it is not reported (a cloud); ``box_dv_px_s`` (1.5; 0 off):
    a cluster's box is drawn around the members whose velocity relative to the scene is within
    this of the cluster's median (clusters of three or more; a feature of the coast or another
    boat linked in stays in the cluster but not in its box), or within ``box_dv_noise_k`` (0:
    off) times the running estimate of the velocity noise (``noise_px_s``) where that is larger; ``merge_keep`` (0.5; 0 off):
    clusters reported as one stay one while each box lies by this much inside the last frame's
    report, their boxes of this frame overlap, touch or lie at most ``merge_keep_gap_px`` (2,
    times the zoom) or ``merge_keep_gap_h`` (2) times the taller box's height apart, whichever
    is more, and they move alike: relative velocities within ``merge_dv_px_s``
    (with ``merge_dv_px_s`` 0 the join ignores velocity; an unknown velocity counts as alike; see
    :meth:`FeatureClusterer._sticky_pairs`).
    Stop 15: ``waterline_frac`` (0.5; 0 off): the grown box ends at the waterline, below the
    lowest row whose contrast reaches half the strongest row's (the reflection is cut);
    ``wake_frac`` (0.3; 0 off) with ``wake_min_px_s`` (5): a cluster whose box members move
    across the image faster than ``wake_min_px_s`` relative to the scene loses a long run of low
    columns on its trailing side (its wake); ``top_frac`` (0.2 since session 23, 0.35 before; 0
    off): the box's top goes up
    to the foreground found at this fraction of the core's contrast (a superstructure against
    the sky); see :func:`grow_boxes`; ``top_frac_ir`` (0.35, session 23; None: ``top_frac``): the
    fraction on infrared frames (``FeatureClusterer.update(..., ir=True)``), where no bright sky
    hides a superstructure; ``max_aspect`` (12; 0 off): a report whose box is more
    than this many times wider than tall is dropped (the foot of a coast, the horizon).
    ``merge_dv_px_s`` is 3 px/s since stop 15 (5 before).
    Stop 16: ``cut_core_frac`` (0: off; 0.6 with ``cut_core_undo`` True is the variant tried
    last): the waterline cut may leave out at most this fraction of the core's height and the
    wake cut of its width (the core: the box members' extent); a cut that would leave out more
    is limited to that, or undone with ``cut_core_undo`` (a bright cabin over a darker hull keeps
    its hull); off by default, since with the extractor of 6a67f5f it raised the tuning seeds'
    identity switches (81 -> 88); ``box_keep_last`` (True): the box members are chosen around the median velocity of the
    members inside the cluster's box of the frame before (carried by the camera motion), when two
    or more of them have a known velocity, so the box does not jump to another object whose
    features the cluster also holds (see :func:`_box_members`); ``merge_dv_clusters`` (True; False
    off): the velocity gate also refuses a link between two established clusters whose mean
    velocities differ by more than ``merge_dv_px_s`` (see :func:`_gate_links`).  Tried and left
    off: ``relink_size_ratio`` (0, off: a lost identity is not relinked to a box whose height
    differs from the lost box's by more than this factor).
    ``split_dv_px_s`` (6 px/s, the tuned value, on by default again since session 17; 0: off. On at 786ea76, turned off in 16106ee because its cost, about 7 %, took the bench's `pan` under 25 frames/s; session 17 cut its own cost from about 1.1 to 0.3 ms a frame with the output unchanged, and a second paired run on `pan` seed 1 measured on / off 1.004, within the 1.02 set for turning it on; the first had given 1.044, before and after the change alike) with ``split_min_features`` (2): a cluster whose members form two
    groups whose velocities relative to the scene differ by more than this (px/s) is reported as
    two objects: the part around the box's anchor (the members that move with the cluster's box
    of the frame before, see :func:`_box_members`) keeps the identity, the other part (at least
    ``split_min_features`` members within ``split_dv_px_s`` of their own median velocity) is
    reported under an identity of its own, kept while the split lasts (a cluster holding the
    features of two boats that pass each other); the new part is reported from ``confirm_s`` on,
    so the split must last that long.  The clustering (the affinity graph) is unchanged: only the
    reports are split (see :meth:`FeatureClusterer._split_for_report`).  ``split_hand_over``
    (on): a cluster new in the graph whose features were, for the most part, a split part's
    (within ``label_memory_s``) takes that part's identity (the graph split them apart later).
    ``split_s`` (1 s; 0: at once): the two groups must be seen in every frame for this long before the split;
    ``split_memory_s`` (10 s): a split part's identity is kept this long (at least
    ``label_memory_s``) after the split last held; ``split_keep_parts`` (on): of the two groups,
    the one whose features were more often in the split part the frame before is the split
    part (not the one away from the anchor: two boats that cross keep their identities).
    Session 18: ``relink_appearance`` (on; False: off) with ``relink_appearance_max`` (1.4): a
    lost identity is not relinked (:meth:`FeatureClusterer._relink`) to a new cluster whose box
    looks unlike the lost box did in the last frame it was seen: the appearance distance
    (:func:`appearance_distance`: the difference of the two objects' contrasts against their
    surroundings, per channel, relative to the stronger one; plus ``relink_appearance_tpl`` (0)
    times a 16x8 contrast template's part) above ``relink_appearance_max`` refuses the pair.  At
    1.4 it refuses little more than an inverted contrast (a dark object for a bright one); chosen
    on the 12 tuning sequences (71 -> 69 identity switches, mean METE 0.4703 -> 0.4701).
    Session 19: ``coast_s`` (0: off) with ``coast_min_age_s``, ``coast_check``, ``coast_follow``,
    ``coast_size_ratio``, ``coast_overlap`` and ``coast_inside_big``: a reported identity lost less than ``coast_s``
    ago, after being reported for at least ``coast_min_age_s``, is still reported (state
    ``COASTING``) at the place the relink expects it, while the image still shows an object
    there (:meth:`FeatureClusterer._coast`).  On by default at 15 s, 0.4 s, with the check and
    ``coast_follow``, overlap 0.8 with ``coast_inside_big``: on the 12 tuning sequences mean METE
    0.4702 -> 0.4385, identity switches 69 -> 64 (``benchmarks/sf_tuneset.py``; docs/stable_features_log.md, "Session 19: coasting").
    Session 19 (the box fitted to the boat): ``box_disp_s`` (1 s; 0: off) with ``box_disp_frac``
    (0.5) and ``box_disp_min_px`` (2 px): a box member whose displacement in the scene over the
    last second, along its cluster's median displacement, is under half of it stays out of the
    box (the foam of a wake, the coast; see :meth:`FeatureClusterer._disp_members`); on the 12
    tuning sequences mean METE 0.4701 -> 0.4633, identity switches 69 -> 70.  Tried and left
    off: ``size_filter_s`` (0: off) with ``size_filter_k`` (1.5), ``size_filter_min_n`` (5),
    ``size_filter_width``, ``size_filter_height`` and ``size_filter_grown`` (a cluster's box held
    to its median size over the last ``size_filter_s``; see :meth:`FeatureClusterer._size_filter`;
    best 0.4673), ``wake_thick`` (False: the wake cut by column thickness; no gain) and
    ``box_disp_q`` (0: the displacement reference from the members that moved farthest; 0.5 gave
    0.4631 with 66 identity switches, short of the 0.002 set for replacing the adopted setting).
    Session 20 (the ``pan`` box fit): ``grow_sign`` (0: off): the box growing keeps to the core's
    polarity when at least this fraction of the core's foreground pixels are darker (or brighter)
    than the background: pixels of the other sign outside the core are not the object (the bright
    foam at a dark rib's stern; see :func:`grow_boxes`, ``sign_frac``); negative: only from the
    core's top row down; ``grow_sign_max_px`` (0: all): only for boxes at most this tall before
    the growing (a large ship's dark hull and white superstructure, two clusters, stay joined).
    Off by default: on the 12 tuning sequences (mean METE 0.4343, identity switches 65 without)
    0.7 gave 0.4293 / 81, -0.7 0.4283 / 69, -0.7 with 16 px 0.4296 / 68, with 12 px 0.4304 / 67,
    none both 0.004 lower and within 2 switches (docs/stable_features_log.md, "Session 20").
    Session 23: on by default, together (the lead's decision U, docs/stable_features_log.md):
    ``grow_sign`` -0.7 with ``grow_sign_trail_px_s`` 2, ``box_disp_two`` with ``box_disp_two_wake_px``
    2, ``box_disp_two_anchor`` and ``box_disp_two_far_h`` 1, and helper H3's ``relink_dy_px_per_s``
    1.2 with ``relink_dy_side``, ``hand_over_relinked`` and ``split_follow_box`` 0.5 (the off values
    below are the fields' old defaults).
    Session 22: ``box_disp_two`` (False: off): ``box_disp_s`` also for a box of two members, the
    one that moved farther being the boat's (see :meth:`FeatureClusterer._disp_members`).
    Session 23 (H2): ``box_disp_two_wake_px`` (0: off): with ``box_disp_two``, the member that
    stayed behind leaves a two-member box only when it lies where a wake's foam lies: behind the
    other member (against that one's displacement) and at most this many pixels (times the zoom)
    above it (foam floats at the waterline, under or level with the hull's features).  A cluster
    holding one feature on each of two boats no longer has its box jump to the boat that moved
    farther (sim `pan` seed 1 at 12.1 s: 42 px above), nor a far ship's box shrink to one feature.
    ``box_disp_two_anchor`` (False): with it, such a pair that is not a wake keeps the member inside
    the cluster's box of the frame before when only one lies there (sim `pan` seed 6 at 14.1 s: the
    box stays on the patrol boat, not on the tanker 38 px above); otherwise both stay.
    ``box_disp_two_far_h`` (0: off): with ``box_disp_two_anchor``, only when the member outside that
    box lies more than this many times the box's height outside it (sim `ir` seed 6 at 3.0 s: two
    members of the fishing boat, one 4 px outside its 20 px box, both stay).
    Session 22: ``grow_sign_trail_px_s`` (0: off, the rule on every side): ``grow_sign`` only
    behind a boat whose box members move across the image at least this fast (relative to the
    scene), and only the columns beyond the core on that side (the wake's): a large ship's parts of
    the other polarity above or beside its core stay joined (see :func:`grow_boxes`, ``sign_side``).
    Session 20 (one identity per boat; see docs/stable_features_log.md, "Session 20: one identity per boat"):
    ``relink_dv_px_s`` / ``hand_over_dv_px_s`` (0: off): a lost identity is relinked (handed over) only
    to a cluster whose own velocity lies within this (px/s, times the zoom) of the identity's own
    velocity when last seen (an unknown one passes), with ``dv_still_px_s`` (0: always) only where the
    camera's image speed at both boxes is under that (times the zoom); none of four settings passed.
    ``coast_skip_merged`` (True; False: off): an identity whose cluster is joined into another's report
    this frame is not coasted (its boat is in that report), with ``coast_skip_merged_dv`` (3; 0: any)
    only when the cluster's velocity relative to the scene lies within this (px/s; times the zoom with
    ``coast_skip_merged_zoom``, True) of the report's oldest cluster's; on the 12 tuning sequences
    mean METE 0.4343 -> 0.4342, identity switches 65 -> 60.

    Session 21 (the cargo ship at full zoom; see ``grow_boxes``): ``grow_cover_wide`` (False: off):
    an object that does not cover the core in the first window sends the growing on to the wide
    window (``grow_wide_px``), as a hull reaching the window's edges does; ``grow_hint`` (True; False: off):
    a cluster whose box neither window grows is looked for again where its box was grown in the
    frame before (carried by the camera motion), in that box's union with its own, padded by
    ``grow_hint_pad_px`` (20 px), and with ``grow_hint_core`` (0.5; 0: any) only when at least that
    fraction of the core (the box members' extent) lies inside that box (``grow_hint_core_x``, False:
    of the core's width inside that box's columns).  On the 12 tuning sequences ``grow_hint`` with
    ``grow_hint_core`` 0.5 gave mean METE 0.4325 -> 0.4172, identity switches 53 -> 49.

    Session 21 (one identity per boat on ``ir``; see docs/stable_features_log.md, "Session 21"; on by
    default together: ``hand_over_height_ratio`` 3, ``relink_min_area`` 0.3 with
    ``relink_area_same_zoom``, ``relink_alt_s`` 3 s; on the 12 tuning sequences mean METE 0.4325 ->
    0.4318, identity switches 53 -> 48; ``hand_over_size_ratio`` is off):
    ``hand_over_size_ratio`` (0: off): a lost identity is not handed over
    (:meth:`FeatureClusterer._hand_over`) to a report whose box is more than this many times the
    area of the identity's last box (a small boat passing a larger one lies inside the larger one's
    grown box: the rib's 18 x 6 px box in the fishing boat's 21 x 27 px one);
    ``hand_over_height_ratio`` (3; 0: off): the same with the boxes' heights (a longer hull is not a
    larger boat: the fragments of one ship differ more in width than in height);
    ``relink_min_area`` (0.3; 0: off): a lost identity is not relinked to a new cluster whose box is less
    than this fraction of the lost box's area (carried through the zoom; a large boat's identity on
    a small boat or a fragment), with ``relink_area_same_zoom`` (True; False: always) only when the camera's
    zoom now is within 5 % of its zoom when the identity was lost (the lost box's size is carried
    through a zoom change by the features' homographies, which is not reliable);
    ``relink_alt_s`` (3 s; 0: off): when the cluster that took a lost identity by a relink dies within
    this many seconds of the relink (and after ``relink_min_s``), the identity is lost where that
    cluster died and also, as an alternative, where it was expected before the relink (with the
    time lost of that earlier loss); a later relink may take it at either place
    (:meth:`FeatureClusterer._relink`); ``relink_alt_memory`` (False: off) does the same for a lost
    identity that came back through the graph's label memory (a cluster that once carried it) rather
    than by a relink (on the 12 tuning sequences 0.4318 / 48 -> 0.4314 / 52: not kept);
    ``known_min_speed_px_s`` (0: off): the speed floor (``min_speed_px_s``) follows how well the camera
    motion is known: it is ``known_err_k`` (2) times the running error of the camera motion
    (:attr:`FeatureClusterer.camera_err_px_s`, the median speed relative to the camera of the
    stable features above the horizon, which are static) held between ``known_min_speed_px_s`` and
    ``min_speed_px_s``; with no such estimate yet it stays ``min_speed_px_s`` (with the telemetry's
    exact camera motion a slow boat, about 1 px/s, is no longer static; where the motion's error is
    large, e.g. a mast's shake, the floor stays high); ``known_still_px`` (0: off) measures that error and
    lowers the floor only in frames where the camera is still by its motion (the frame's homography moves
    the image centre by less than this many pixels; a panning camera's coast tells little of the error
    in its dwells, where a mast shakes); ``known_band_px`` (0: everywhere) lowers it only for the features
    less than this many pixels (times the zoom) below the horizon (distant slow boats; the near water's
    drift stays static).

    Session 21 (helper H3, the camera motion from the telemetry on ``ir``): ``merge_id_dv_px_s`` (0:
    off, the oldest identity stays): a report joined from overlapping clusters
    (:func:`_merge_overlapping`) whose velocities relative to the scene differ by more than this
    (px/s, times the zoom) keeps the identity of the cluster with most features, or the oldest of
    the clusters moving with that one (a sailboat's two-feature cluster, whose grown box is the
    passing ferry's, gave the ferry the sailboat's older identity, and the joined cluster's identity is
    not handed over to that report); ``merge_id_ratio`` (2): only when the cluster with most features
    holds at least this many times the oldest's (two boats of like size would swap the identity from
    frame to frame); ``merge_min_share`` (0: off, the paper's rule): a carried identity claims a
    graph cluster only with at least this share of the most-carried identity's features there
    (:func:`assign_identities`; one feature remembering a dead cluster's identity through the label
    memory renamed the passing ferry's cluster); ``merge_id_apart`` (False: off): with
    ``merge_id_dv_px_s``, two overlapping reports whose largest clusters move differently, neither
    holding ``merge_id_ratio`` times the other's features, are not joined (the ferry and the
    fishing boat passing each other swapped the joined report's identity); ``gate_dv_px_s`` (0: ``merge_dv_px_s``): the graph's
    velocity gate (:meth:`AffinityClusters.step`) alone at this value.

    Session 22 (helper H5, the joined report's identity): ``merge_id_keep_iou`` (0.3, on by default since session 22 with ``relink_height_zoom_min`` 0.3; 0: off): a report
    joined from several clusters (:func:`_merge_overlapping`) takes the identity of the member whose
    report in the frame before (its box carried by the camera motion) overlaps the joined box most,
    when that IoU is at least this (otherwise the rules above): on ``ir`` the fishing boat's small
    cluster inside the ferry's box gave the ferry's report its older identity in the frames where
    the two were joined, and the ferry's own back in those where they were not.

    Session 22 (helper H1, boats lost after they were first found on ``pan``): ``coast_search``
    (0: off): a coast whose grow at the expected box fails (not found, contrast or size) looks again
    from cores shifted by up to this many box widths and heights (steps of half a box) and takes the
    good grown box nearest the expected place that does not lie in a report (``coast_overlap``)
    (:meth:`FeatureClusterer._coast_search`); the expected box of a boat that came into view during a
    pan lies half a box or more off it.  With ``coast_search_below_px`` (12; 0: anywhere) only where the
    expected box's bottom and the grown box's lie more than this many pixels (times the zoom) below the
    sea horizon: at the horizon the search finds the horizon's own texture (flat boxes of 1-10 px).
    ``coast_retry_s`` (1 s, on by default since session 22; 0: off): a coast whose grow fails (not found, contrast, size) is not ended at
    once but looked at again in the next frames (not reported while it fails) until it has failed
    for this long in a row; a small boat is often not grown in one frame and grown in the next.  Not
    in the horizon band of ``coast_search_below_px``.  On the 12 tuning sequences mean METE 0.3970 ->
    0.3925, identity switches 48 -> 44; validation seeds 9-12 0.4120 -> 0.4089, 52 -> 52.
    ``coast_max_aspect`` (False: off; session 22, lead): a coasted box grown to more than
    ``max_aspect`` times wider than tall is not reported (outcome "size"), as a live report is not.

    Session 23 (helper H5, faint boats lost on ``pan``): ``coast_outside_wait`` (False: off): a coast
    whose expected box's centre lies outside the image (outcome "outside") is not ended but waits,
    unreported, and is looked at again (the grow's checks) when the box comes back into the image
    within ``coast_s`` of the loss: a boat the pan took out of the view and brings back is reported
    as soon as the image shows it there, not only when a new cluster forms on it and is relinked.
    ``coast_grow_up`` (0: off): a coast whose grown box is more than ``coast_size_ratio`` times the
    expected box's area is still reported (and followed) when it is at most this many times that area
    and holds at least 0.8 of the expected box: the box a faint small boat was lost with is often a
    fragment of its hull (its cluster held part of it), and the grow at the right place found the
    whole boat, which the size check refused (``pan`` 55, the motorboat: a 16x5 box on a 39x10 hull);
    not when that grown box covers more than a quarter of one of this frame's reports (another boat).

    Session 24 (helper H7, faint boats lost through the zoom on ``pan``): ``coast_edge`` (0: off): a
    coast whose expected box's centre lies left or right of the image (its rows in it) is not ended
    but looked at on the image's edge on its side (:meth:`FeatureClusterer._coast_edge_look`), and so
    is a coast whose look failed at a box touching the image's left or right side: grown from the half
    of the expected box nearest the edge, on a copy of those rows with the same rows' water put in
    front of the edge (the grow's background strip at the edge would lie on the boat); a grown box
    that was found, stands out, touches the edge, lies below the horizon band, is at most this many
    times the expected box's area and covers no more than a quarter of a report now is reported
    (outcome "edge") and followed.  The faint motorboat that the zoom carries across the left edge
    and back (``pan`` 55: the expected box 388 px out, its rows right) keeps its identity through.
    ``coast_edge_s`` (0: within ``coast_s``): the edge look (and the wait outside) only within this
    many seconds of the loss; not run on the tuning sequences (``pan`` 5: the tug's identity, lost at
    the left edge, waited 13 s there and took the sailboat that came in at the same edge).

    Session 25 (helper H19, boats the pan brings back): ``coast_edge_seen`` (False: off): ``coast_edge_s``
    counted from the last frame the identity's coast was seen (reported) since its loss, not from the
    loss (``pan`` 2: a boat followed at the edge to 20.4 s, lost at 15.4 s, back in at 26.3 s).
    ``coast_edge_dy`` (0: off; box heights): an edge look that sees nothing at the expected rows is
    tried at rows shifted by half a box height at a time up to this, nearest first, under the same
    checks and not for a sliver (under 0.35 of the box's height) or a line (``max_aspect``): the zoom
    carries the expected box of a boat far outside the image off its rows.  Neither on: the shift
    reports other boats and the sea's texture at the edge (faint four worse).

    Session 26 (helper H24, boats back in view after the pan and zoom): ``coast_edge_horizon`` (False:
    off): the edge look of a coast whose expected box lies outside the image (left or right, waiting)
    that sees nothing at the expected rows is tried again at rows re-estimated from the horizon (the
    camera's motion extrapolated far out of the image carries the box off the boat's rows): the box's bottom lies as many pixels below the horizon's row at the edge's column as
    it lay below the horizon (at its centre's column) when the coast was last seen whole in the image
    (not at its side; or when the identity was lost), times the zoom now over the zoom then (a boat's range keeps its
    distance below the horizon through the zoom); its height the expected box's.  Not for the failed
    looks at a box on the image's side (their rows are the image's).  ``coast_edge_clear`` (0: off; box
    heights): that look is not made where a report of this frame or another identity's coast reported
    now lies within this many of the expected box's heights of the re-estimated rows (above or below)
    and within the box's width plus that margin of the edge (the boat is then most likely that one).
    ``coast_edge_horizon_contrast`` (0: ``min_contrast``): the contrast that look's grown box needs at
    least (the sea's texture at the edge, 4.1-4.8 on ``pan`` 44 and 47, against 5.5 on ``pan`` 2's boat).

    Session 26 round 2 (helper H27): ``coast_edge_horizon_out`` (0: off; the expected box's widths): the
    horizon look only for a coast whose expected box lies more than this many of its widths outside the
    image (the gap between the box's near side and the image's side): the extrapolated rows go wrong far
    out (``pan`` 2: 229 px out), while a box just outside keeps rows about right, and there the moved look
    finds other things (``pan`` 58: a coast on no boat just outside the right edge moved to another box).
    Not enough on ``pan`` 58 (the same coast goes 3 widths out and takes a box there).
    ``coast_edge_horizon_h`` (0: off; a factor > 1): the horizon look only for a coast whose expected box's
    height lies within this factor (either way) of the height recorded with its rows times the zoom now over
    the zoom then: the rows are the recorded boat's, and a coast whose box has shrunk or grown away from
    that boat's size since (its follow-on looks took fragments or the sea's texture) is most likely no
    longer that boat.  The ratios of the looks that reported (``pan`` 2, 58, 55, 44, 47): ``pan`` 2's boat
    1.08 and ``pan`` 55's 1.20, against ``pan`` 58's identity 126 on no boat 0.56 and 0.15, ``pan`` 44's
    0.45 and ``pan`` 47's sea texture 0.54.  With 1.5 no contrast floor (``coast_edge_horizon_contrast``)
    is needed.

    Session 27 (helper h28, the rib's flip-flop between two coasts on ``pan`` 86): ``coast_dup_iou`` (IoU;
    0: off): among one frame's coasts that pass their checks, those whose reported boxes (after the grow,
    the follow and the edge look) overlap by at least this IoU are one boat: only the most recently lost of
    them (ties: the lower identity) is reported, the others end as a failed coast does (until found and lost
    again).  ``coast_follow`` grows two coasts that lost the same boat onto the same object, and both are
    then reported on it every frame, so the boat's identity alternates between them.
    ``coast_live_iou`` (IoU; 0: off): a coast whose reported box (after the grow) overlaps one of this
    frame's live reports by at least this IoU is not reported and ends (``coast_overlap`` checks the
    expected box before the grow only, as the fraction of it inside a report).
    ``coast_dup_seen`` (False: off): with ``coast_dup_iou``, the coast kept is the one reported last (as a
    coast, or live at its loss), the loss time only breaking ties: on ``pan`` 89 an edge look brought a coast
    lost 2 s before (227 px outside) onto the boat that another identity's coast, lost 10.8 s before, had
    been reported on every frame; the more recently lost one took the boat.

    Session 24 (helper H10, faint boats round 2): ``coast_look_up`` (0: off): a coast whose grow was not
    found at its expected box is looked at once more, grown from the middle half of that box
    extended upward by this many times its height (the expected box was the hull alone, and the
    boat's body stands above it: a faint sailboat's sail over its 6 x 7 px hull on ``pan`` 58). The
    grown box is reported (outcome "up") and followed when it was found, stands out
    (``min_contrast``), holds at least half of the expected box, its area lies within
    ``coast_size_ratio`` of the extended box's either way, it is no line (``max_aspect``) and covers no
    more than a quarter of one of this frame's reports.  ``coast_look_ahead`` (0: off): a coast still
    not found is grown once more from the expected box shifted by this many box widths in the
    direction of the identity's own horizontal velocity when lost (the expected box lags behind a
    boat whose own motion it does not follow: ``pan`` 44's ferry, 6-9 px behind at 40 px/s);
    reported (outcome "ahead") and followed under the same checks, with the grown box's centre
    within the rows of the expected box and between it and the shifted box.

    Session 22 (helper H2, one identity per boat on ``ir``): ``relink_dy_h`` (0: off): a lost identity
    is not relinked (:meth:`FeatureClusterer._relink`) to a new cluster whose box bottom (the
    waterline) lies more than this many times the taller of the two boxes' heights above or below the
    lost box's expected bottom: the waterline's row is the boat's range, which changes little while
    it is lost (the right relinks on the tuning sequences moved it by at most 0.67 of the lost box's
    height; the wrong ones that made switches by 2-44 times: a sailboat's identity on the rib
    30 px lower, an identity lost at the image's foot on a boat near the horizon);
    ``relink_dy_same_zoom`` (False: always): that check only when the zoom now is within 5 % of the
    zoom at the loss (as ``relink_area_same_zoom``); ``relink_iou_tie`` (False: off, the older
    identity first): of the lost identities within the gate of a new cluster at one gap (0 where the
    boxes overlap), the one whose expected box overlaps the new box most (intersection over union)
    takes it (a long-lost ferry's identity took the cargo ship it had once passed, over the cargo
    ship's own); ``gate_rel`` (0: off) with ``gate_rel_min_px_s`` (2): with ``merge_dv_clusters``, the
    graph's velocity gate also keeps two established clusters apart whose mean velocities differ by
    more than ``gate_rel`` times the faster one's speed and more than ``gate_rel_min_px_s`` (px/s;
    see :func:`_gate_links`: the ferry at 6 px/s and the rib at 3 px/s merged under the 3 px/s gate);
    ``gate_chain`` (False: off; session 22, helper H3): with ``merge_dv_clusters``, two established
    clusters that the cluster-pair test keeps apart are not joined through a chain of links either
    (an unlabelled feature linked to both, its velocity within the gate of each: the ferry and the rib
    on `ir` 7 at 18.3 s); the clusters are then the components of a union of the links that refuses
    every join of two such clusters, the links taken in the order of their ends' velocity difference
    (see :func:`_chain_components`); ``split_origin_dv_px_s`` (0: off, the paper's split rule; session 22,
    helper H3): when a cluster splits into parts moving more than this apart (px/s), its identity goes
    to the part holding most of the features that had it before they merged (the rib's cluster took a
    few of the fishing boat's features, then the fishing boat's young clusters, and on the split the
    larger fishing part kept the rib's identity: `ir` 6 8.1 s; see :func:`assign_identities`); with
    ``split_origin_s`` (0: no limit) only when the identity's cluster absorbed another identity's
    features within this many seconds (a split long after the merge follows the paper's rule).

    Session 22 (helper H4, identities on ``pan``): ``relink_view_px`` (0: off): a lost identity whose
    expected box (carried by the camera) lies more than this many pixels outside the image is not
    relinked (:meth:`FeatureClusterer._relink`): its boat is out of the view (a boat left behind by a
    pan), so no cluster in the image is it, however far its gate has grown; it waits until the camera
    points back at it.  ``relink_view_same_zoom`` (True; False: always): that check only when the zoom
    now is within 5 % of the zoom at the loss (as ``relink_area_same_zoom``: through a zoom change the
    carried box is less sure); ``relink_view_zoom_in`` (False: off) widens it to any zoom at least 0.95 of
    the zoom at the loss (the camera zoomed in or not at all since; on ``pan`` the boats left behind by
    the pan at zoom 1 are passed again while the camera zooms back out from 3.5 to about 1.6, while
    boxes carried through a zoom-out, lost at the full zoom, lay 170-330 px off the view from their boat);
    ``relink_view_zoom_scale`` (False: off): the margin is ``relink_view_px`` times the zoom now (the
    carried box's error is an angle: the motorboat lost at zoom 1.7 lay 240-320 px off the view from
    where it came back at zoom 3.5).  On by default since session 22 together with helper H2's
    ``relink_dy_h`` 1.5, ``relink_iou_tie`` and ``gate_rel`` 0.4 (``gate_rel_min_px_s`` 2): on the 12
    tuning sequences mean METE 0.3925 -> 0.3914, identity switches 44 -> 38 (``pan`` 25 -> 20, ``ir``
    19 -> 18); validation seeds 9-12 0.4089 -> 0.4100, 52 -> 45 (docs/stable_features_log.md,
    "Session 22: the lead's decisions").

    Session 22 (helper H6, identities at ``pan``'s zoom-out): ``relink_area_zoom_min`` (0: off): when
    ``relink_area_same_zoom`` skips the ``relink_min_area`` check (the zoom changed by more than 5 %
    since the loss), a lost identity is still not relinked to a new cluster whose box is less than this
    fraction of the lost box's area (carried through the zoom): a looser check for the less sure carried
    size (on ``pan`` 6 the motorboat's identity, lost at zoom 1.7 and carried to 121 x 31 px at zoom 3.5,
    went at 28.0 s to a 35 x 6 px fragment, area x0.06, while the boat's own 113 x 30 px cluster came
    0.4-1 s later).  ``relink_height_zoom_min`` (0.3, on by default since session 22; 0: off): the same with the boxes' heights (a boat
    entering the view at the image's edge is narrow, not low: on ``pan`` 7 the motorboat's right relink
    at 27.5 s was area x0.21 but height x0.75; the fragment above height x0.19).

    Session 23 (helper H1, far ships on the horizon; on by default since session 23 with
    ``far_top_px`` 3, ``far_open_px`` 30, ``far_open_contrast`` 20): ``far_top_px`` (0: off): the still-object rule
    (``still_radius_px``) also takes stable features between this many pixels and ``water_margin_px``
    (both times the zoom) under the horizon, where no stable feature lies between ``far_coast_gap_px``
    (4) and ``far_coast_px`` (20) pixels (times the zoom) above the horizon within ``far_cols_px`` (30,
    times the zoom) of their column (:func:`_far_still`): a ship far out (``pan``'s cargo ship, 2200 m:
    waterline 8.6 px, features 5-7 px under the horizon at any zoom, about 1 px/s) is not left out as
    the foot of a coast.  ``far_open_px`` (0: off; only with ``far_top_px``): and only where, this many
    pixels (times the zoom) to the left or right, the sky reaches down to the horizon (rows 3-1 px above
    it within ``far_sky_tol`` (8) grey levels, or a quarter of the sky-sea contrast, of the sky 14-20 px
    above it; :func:`_far_open`): a low coast holds no stable feature above the horizon, but a dark strip
    rising a few pixels above it.  ``far_open_contrast`` (0: off): a side where sky and sea differ by less
    than this many grey levels counts as open (a thermal image, whose warm band along the horizon the
    test cannot tell from a coast).

    Session 23 (helper H3, the switches left): ``relink_dy_px_per_s`` (0: off): the row check of
    ``relink_dy_h`` allows a row gap up to ``relink_dy_h`` times the smaller box's height plus this many
    pixels per second lost (times the zoom now), when that is more than the check's own limit (which
    stays: ``relink_dy_h`` times the taller box's height): a boat's range, and so its waterline's row, drifts while it
    is out of the view for long (on ``pan`` the rib, left behind by the pan at the image's left edge
    at 10 s, came back at 35 s 40-50 px higher than its carried box: refused, a new identity on all six
    tuning seeds); with ``relink_dy_side`` (False: every lost identity) only for identities lost with
    their last box at the image's left or right edge (a boat the pan left behind; a boat lost inside
    the image keeps the strict check).  ``hand_over_relinked`` (False: off): the hand-over
    (:meth:`FeatureClusterer._hand_over`) may also give a lost identity to a cluster that took a
    younger lost identity by a relink in the same frame (the older identity stays, the paper's rule);
    the younger one is lost again as it was before that relink (on ``pan`` 6 at 29.0 s the motorboat's
    cluster died while a new cluster on it took a fragment's identity lost 0.6 s before; the
    motorboat's identity, lost after the relink pass, could not go to it: two switches).
    ``split_follow_box`` (0: off): when a reported cluster's box jumps away from its own box of the
    frame before (carried by the camera; intersection over union under 0.1) while a cluster born in
    this frame overlaps that box by at least this IoU, the new cluster takes the identity (the boat it
    was on) and the jumped cluster gets a new one, which the hand-over may replace by an older
    identity lost on its box (also later: that one's new cluster may die soon after) (the paper's split gives the identity to the part holding most of its
    features: on ``ir`` 5 and 7 at 3.2-3.5 s the ferry's cluster, linked to boat 6's features, split
    and its identity went to boat 6 while the ferry's part was born anew; on ``ir`` 6 at 8.1 s the
    rib's identity went to the fishing boat's part).

    Session 24: on by default since session 24 (the lead's decision U3): helper H7's ``coast_edge`` 6
    with ``coast_edge_s`` 8 and helper H5's ``coast_grow_up`` 6 (session 23), and helper H8's
    ``box_wake_below_px`` 5 with ``top_min_px`` 2; then (decision V) helper H9's ``relink_jump_iou`` 0.5,
    ``relink_young_s`` 1 and ``relink_aspect_ratio`` 6; then (decision W, round 2) helper H10's
    ``coast_look_up`` 1 with ``coast_look_ahead`` 0.5 (the off value of each is 0).
    Session 23 round 2: on by default since session 23 (the lead's decision U2): helper H4's
    ``relink_side_h_ratio`` 3 with ``relink_undo_hand_over``, and helper H6's ``grow_core_q_ir`` 0.4
    with ``grow_core_retry_ir`` (the off values below are the fields' old defaults).
    Session 23 round 2 (helper H4, ``pan``'s switches at the new defaults): ``relink_side_h_ratio``
    (0: off): an identity lost with its last box at the image's left or right edge (its last box,
    clipped by the edge, tells nothing of its size) is relinked only to a cluster whose height lies
    within this factor of the identity's own height: the median of its last ``relink_side_h_n`` (5)
    reported boxes clear of both edges, scaled by the zoom's change since then (on ``pan`` 2 and 7
    the rib and the fishing boat, both left behind by the pan at the image's left edge at ~10 s,
    come back at 35 s and 39 s; the rib's cluster, 9 px tall at zoom 1.6, took the fishing boat's
    identity, 15-20 px tall at zoom 1.0, whose carried box was the nearer: two switches each).
    ``relink_undo_hand_over`` (False: off): when the cluster that took a lost identity by a relink
    dies within ``relink_min_s`` (the relink undone), the hand-over is first tried on that cluster's
    last box (carried): a younger cluster reported under its own identity overlapping it by
    ``relink_overlap`` takes the identity, which is then not lost again (on ``pan`` 6 at 28.4 s the
    motorboat's identity, relinked to a fragment at 28.0 s, went back to its old expected box while
    the boat's own cluster was born on the fragment's box in the same frame: three switches).

    Session 24 (helper H9, the switches at the session-23 defaults; both off by default):
    ``relink_jump_iou`` (0: off): a reported cluster whose box jumps away from its own box of the frame
    before (IoU under 0.1 with it, carried by the camera) onto a lost identity's expected box (IoU at
    least this), that identity older than its own, takes that identity; its own is lost where its box
    was (and may be handed over or relinked there as any lost identity): on ``ir`` 7 at 19.0 s the
    rib's graph cluster took the features of the ferry, whose identity was lost 0.7 s before, and its
    box jumped onto the ferry; the ferry was reported under the rib's identity and the rib, when its
    features parted, under new ones (three switches).  ``relink_side_h_up`` (0: off): with
    ``relink_side_h_ratio``, an identity lost at the image's side edge is not relinked to a cluster
    taller than this many times its own height (the zoom-scaled median of its heights clear of the
    edges): a new cluster is often a part of its boat, rarely more, so the check is tighter upwards
    than ``relink_side_h_ratio`` (on ``pan`` 6 at 39.0 s the rib's identity, 6 px tall, took the
    fishing boat's 17 px cluster, ratio 2.7, when the fishing boat came back).  ``relink_young_s``
    (0: off): when an identity is lost and no cluster overlaps its last box for the hand-over, a
    cluster reported under its own identity, younger, born at most this many seconds before, and
    within ``relink_px`` (times the zoom) of that box takes it, the nearest first, with the
    hand-over's size checks (the relink gives lost identities only to clusters born after the loss:
    on ``ir`` 7 at 30.0 s the rib's new cluster, born 0.5 s before its old one died beside it,
    overlap 0.12, kept its own identity).  ``relink_aspect_ratio`` (0: off): a lost identity is not
    relinked to a new cluster whose box's width-to-height ratio differs from its lost box's by more than
    this factor (either way; not for an identity lost at the image's side edge, whose box is clipped, nor
    for boxes under 2 px): on ``ir`` 8 at 15.5 s and ``ir`` 7 at 18.0 s the sailboat's identity (a box
    14 x 18 and 5 x 8 px) went to the far cargo ship's new cluster (53 x 11, 52 x 13 px), x6.2 and x6.4.
    ``relink_young_after_s`` (0: off; session 24, helper H12; on by default since session 25: 1 s): ``relink_young_s``'s young cluster takes
    the lost identity only if it was born at least this many seconds after the lost identity's own
    cluster (a boat's new cluster is born after its old one; two boats born together, moving apart,
    do not exchange identities when one is lost).  ``relink_own_speed_k`` (0: off; H12): the relink
    gate of a lost identity whose last velocity is known grows at ``min(relink_px_per_s,
    max(relink_own_speed_floor, relink_own_speed_k * its speed))`` px/s instead of ``relink_px_per_s``
    (a slow boat lost long is not given to a cluster hundreds of px away).  ``coast_drop_alt`` (False:
    off; session 25, helper H17): a lost identity whose coast is reported (with ``coast_follow``) forgets
    the place it was expected before a relink undone (``relink_alt_s``): its place is known now (on
    ``pan`` 44 at 33.0 s the sailboat's coasted identity went to a cluster 350 px away through its
    alternative place from 14.1 s, whose gate had grown to 390 px).

    Session 23 (helper H6, ``ir``'s METE): ``grow_core_q_ir`` (0: off): on infrared frames
    (``FeatureClusterer.update(..., ir=True)``) the core given to :func:`grow_boxes` (the features'
    extent, which the object found must mostly cover and touch) is each cluster's box members' inner
    quantiles ``q`` and ``1 - q`` per axis (nearest rank inward; the full extent for a cluster with
    few members).  A warm boat's thermal halo moves with it, so features at the halo's rim are box
    members; their full extent is then wider than the hull that the segmentation finds, the growing
    fails its cover test and the padded features' extent is reported (sim ``ir`` 8: 0.05 of METE in
    boxes over 1.5 times the boat's area, ``benchmarks/sf_boxfit_diag.py``, stage ``core_big``).
    ``grow_core_retry_ir`` (False): with ``grow_core_q_ir``, the full extent stays the core and the
    inner quantiles are only a second try where every window failed (``grow_boxes``'s ``cores_retry``):
    a large boat whose features cover it grows as before (on ``ir`` 2 the inner core alone cut the
    tug's box).  0.4 with True: 12 tuning sequences mean METE 0.3712 -> 0.3595, switches 30 -> 28;
    validation 0.3908 -> 0.3797, 32 -> 31 (``pan`` unchanged).  ``grow_core_box_ir`` (False): with
    ``grow_core_q_ir``, the box before the growing (reported where the growing fails) is those
    quantiles too, padded by the members' largest radius (tried, not better).  ``top_halo_ir`` (0: off):
    on IR frames the top extension (``top_frac_ir``) only through foreground brighter than this many
    times the halo beside the object (``grow_boxes``'s ``top_halo``; tried, not better).

    Session 24 (helper H8, small boats' boxes): ``top_min_px`` (0: off): the top extension
    (``top_frac``) only for an object found at least this many pixels tall (``grow_boxes``'s
    ``top_min_px``; the clusters' growing, not the coast's).  On sim ``pan`` 2 (13.6 s) a cluster on
    the motorboat's wake, a line 15 x 1 px at the waterline that ``max_aspect`` drops, was raised
    by the top extension at 0.2 into a 15 x 4 box, reported, and took the lost motorboat's
    identity, which ended its coast (the boat then unreported for 0.3-2 s at a time).
    ``box_wake_below_px`` (0: off) with ``box_wake_max_h_px`` (20; 0: any): in a small cluster moving
    across the image, the box members more than this many pixels (times the zoom) below its front
    member (the one farthest in the direction of motion) leave the box (a small boat's wake foam;
    see :meth:`FeatureClusterer._wake_below_members`); ``box_wake_top`` (False): below the topmost
    box member instead of the front one (tried, worse); ``box_wake_below_px_ir`` (0: off on infrared
    frames; None: ``box_wake_below_px``): a warm boat's halo rim lies below its hull too (the
    rule on IR lost METE on the tuning ``ir`` sequences).
    Session 25 (helper H20): ``wake_core`` (0: off): the wake cut (``wake_frac``, where a trailing side
    is set) measures the columns against ``wake_core`` times the 75th percentile height of the columns
    under the features (the core) instead of ``wake_frac`` times that of all columns (see
    :func:`grow_boxes`).  Tried 0.3 and 0.5 (tuning 0.3382/17 and 0.3392/17 against 0.3382/15; faint
    four 0.3663/12 and 0.3628/14 against 0.3662/12): not kept.
    Session 26 (helper H23, the rib's box): ``wake_track_s`` (seconds; 0: off): where a cluster's box
    members move slower than ``wake_min_px_s`` across the image (a small fast boat whose features sit
    on its wake's foam, which stays in the water), the wake cut's trailing side is taken from the
    cluster's own track instead: the least-squares velocity along x of the centres of its boxes grown
    over the last ``wake_track_s`` seconds (consecutive frames, at least ``wake_track_n`` boxes), each
    centre carried into the frame by the camera's motion (the features' homographies), so relative to
    the scene; the side is set where that velocity is at least ``wake_track_px_s`` px/s (0: the
    ``wake_min_px_s``).  ``wake_hold_s`` (seconds; 0: off): instead (or first), a cluster whose members
    are too slow keeps the trailing side its members last gave, for at most this long (the rib's box
    centre jumps between its hull and hull plus foam, so its track's sign is wrong at its birth).
``wake_front`` (fraction of the object's width; 0: off): the wake cut's reference height is the
    75th percentile of the columns in that fraction of the grown object at its leading end (the side
    away from the trailing side), not of all its columns (nor of the core's, ``wake_core``): where the
    rib's features lie on its foam, the core's and all columns' heights are the foam's.
    ``wake_track_ir`` (True): these also on infrared frames.  ``wake_core_ir`` (None: as
    ``wake_core``; 0: off on infrared frames): ``wake_core`` on infrared frames (H20's ``wake_core`` cost
    ``ir`` 2 two switches).
    Session 26 round 2 (helper H26): ``wake_core_iou`` (IoU, 0: off): a guard on ``wake_core``'s cut.  Where
    a cluster with a trailing side gets a grown box whose IoU with its grown box of the frame before
    (carried by the camera's motion) is under this, its box is grown again without ``wake_core`` (the
    reference fraction ``wake_frac``, of ``wake_front``'s columns where that is on) and that box is kept if
    it overlaps the box before more.  On ``pan`` 47 (H23's C1) ``wake_core`` took a tug's low hull for the
    wake of a taller object ahead of it in the same cluster and cut the box to that object (the tug's
    identity swapped twice); the guard undoes the first such cut.
    ``wake_core_iou_cut`` (fraction of the box before's width, 0: off): the guard's box is taken only where
    the columns the cut took away (the regrown box's beyond the cut one) within the box before's columns
    are at least this fraction of its width: a cut that only drops what the box before did not hold (a
    rib's foam beside its hull) stays.
    Session 25 (helper H14, the rib's box): ``grow_jump`` (0: off): a cluster's grown box may be at
    most this many times as wide (and as tall) as its grown box in the frame before (carried by the
    camera's motion; both grown, ``found``); beyond it the side that reaches farther out of the box
    before the growing is cut back (:func:`_limit_jump`).  A small fast boat's growing takes in its
    wake's foam in single frames (a 66 px box on an 11 px rib), in every direction of motion.
    ``grow_jump_max_h_px`` (0: any): only where that box before was at most this many pixels tall
    (times the zoom: small boats); ``grow_jump_keep`` (True): the box before is the one kept (cut)
    then; False: the one grown then (a jump of one frame is cut, a lasting change passes a frame later).
    ``grow_trail_max`` (0: off) with ``grow_trail_max_h_px`` (10; 0: any): a grown box at most that many
    pixels tall (times the zoom) of a cluster with a trailing side (``wake_frac``'s ``trail``: moving
    faster than ``wake_min_px_s``) reaches beyond its box before the growing on that side by at most
    ``grow_trail_max`` times the larger of that box's width and the grown box's height: the wake cut's
    reference (the columns' 75th percentile height) is the wake's own when a small hull's wake is most
    of the box, so the cut does not see it.  ``grow_trail_max_ir`` (0: off on infrared frames; None:
    ``grow_trail_max``).
    Session 24 (helper H11, two boats in one graph cluster on ``ir``): ``graph_cut_dv_px_s`` (0: off): a
    graph link whose two ends' known velocities differ by more than this (px/s) joins nothing this
    frame, also inside one cluster, so a cluster holding two boats that move apart falls into its
    connected components (the paper's split: the larger part keeps the identity); ``graph_cut_parts``
    (False): with it, a cut holds only where both ends fall in parts of at least ``min_features``
    features (a boat whose features' velocities are noisy is not broken up; see
    :meth:`AffinityClusters.step`).

    Session 25 (helper H13, the coast's foot on ``pan``; on by default since session 25: 10 and 8):
    ``foot_open_px`` (0: off): a cluster whose
    members all lie less than ``water_margin_px`` (times the zoom) under the horizon is not reported
    when the sky does not reach down to the horizon this many pixels (times the zoom) left of its box's
    left edge nor as far right of its right edge (:func:`_coast_foot`, with :func:`_far_open`'s test and
    its ``far_sky_tol`` and ``far_open_contrast``): the foot of a coast, 4-7 px under the horizon,
    whose features' noise speeds pass the speed floor and are joined by the moving rule (``pan``'s
    largest clutter early in the sequence); a ship far out has open sea beside it.  ``foot_dark`` (0:
    off; only with ``foot_open_px``): a side is open only where the rows 1-4 px (times the zoom) under
    the horizon are also not darker than the sea under the margin by more than this many grey levels
    (:func:`_under_dark`): the coast's foot can lie wholly under the horizon's row, the sky reaching
    down to it.

    Session 25 (helper H15, identity switches on ``ir``): ``graph_cut_dv_px_s_ir`` (0: off, i.e.
    ``graph_cut_dv_px_s`` on infrared frames too): the cut's threshold on infrared frames
    (``FeatureClusterer.update(..., ir=True)``), so the cut can run on ``ir`` alone (it helped every
    tuning ``ir`` sequence and hurt ``pan``); ``graph_cut_hold`` (0: off): a pair cut in one frame
    stays cut while its two velocities still differ by more than this fraction of the threshold
    (the cut held over time; the velocities are noisy frame to frame).

    Session 25 (helper H18, a cluster drifting from one boat onto the next on ``ir``):
    ``gate_dv_px_s_ir`` (0: off, i.e. ``gate_dv_px_s`` or ``merge_dv_px_s`` on infrared frames too):
    the velocity gate's threshold (a feature joining an established cluster) on infrared frames;
    ``gate_ema_s_ir`` (0: off; infrared frames only): the gate compares a joining feature's velocity with the cluster's
    established velocity, an exponential mean over time of its members' mean velocity with this time
    constant (s), instead of this frame's mean (which follows the newcomers feature by feature);
    ``merge_id_major_ir`` (False: off; infrared frames only): a merged cluster keeps the identity most
    of its features carried, not the oldest (:func:`assign_identities`' ``major``).

    Session 26 (helper H22, the far strip kept apart from the boats below it; for the extractor's
    far pass, ``StableFeatureExtractor(far_px=...)``): ``far_cut_px`` (0: off; px, source pixels
    under the horizon, not scaled by the zoom, as the extractor's ``far_px``): a graph edge whose
    upper feature lies less than this far under the horizon (or above it) and whose lower feature
    lies more than ``far_cut_gap_px`` (px, times the zoom) below the upper one is dropped from the
    frame's graph (:func:`_far_cut`), so the far strip's features (a far ship's, the far water's
    and the horizon's blobs) do not join a boat lying below the strip, and no cluster spans a far
    ship and a boat below it; a boat straddling the strip's line stays joined through its shorter
    edges.  Without a horizon nothing is dropped.  ``far_cut_ir`` (False: off): the cut on infrared
    frames too (by default visible frames only, as the extractor's ``far_skip_ir``; on the tuning
    ``ir`` sequences the cut alone added switches).

    Session 26 round 2 (helper H25, the far strip's identities): ``far_id_px`` (0: off; px, source
    pixels under the horizon, not scaled by the zoom, as ``far_cut_px``): an identity does not pass
    between the far strip and the water below it.  A box is in the far strip when its bottom lies
    less than ``far_id_px`` under the horizon's row at its centre's column (or above it); a lost
    identity whose last box (carried into this frame) was in the far strip is not relinked to, nor
    handed over to, a cluster whose box is not, and the other way round (:meth:`_far_side`).
    Without a horizon nothing changes.  ``far_id_ir`` (False: off): also on infrared frames (by
    default visible frames only, as ``far_cut_ir``).  ``far_cut_deep_px`` (0: off; px, source pixels
    under the horizon, not scaled, as ``far_cut_px``) with ``far_cut_deep_gap_px`` (20; px, times the
    zoom): a second, deeper band of :func:`_far_cut` with a longer gap: an edge whose upper end lies
    less than ``far_cut_deep_px`` under the horizon and whose lower end lies more than
    ``far_cut_deep_gap_px`` below it is dropped too (on frames where ``far_cut_px``'s cut acts:
    visible ones unless ``far_cut_ir``).  A boat 12-25 px under the horizon (sim ``pan`` 20's tug)
    otherwise joins a boat 35-50 px below it in one cluster, its identity passing between them; a
    tall ship near the horizon keeps its features (less than the gap apart) together.

    Session 27 (helper h29, two identities on one boat during a fast pan): ``lost_dup_iou`` (IoU,
    0: off): when an identity is lost (no hand-over took it) that was first seen less than
    ``lost_dup_age_s`` (0.5 s; seconds) before, after another identity had been lost, and its
    last box (carried into this frame) overlaps that older lost identity's expected box by at
    least this IoU, it is retired into the older one: the older identity takes its place, time
    lost and the rest of its lost entry, and a cluster that carried the young identity and comes
    back is reported under the older one.  The young identity was the relink's missed chance (on
    sim ``pan`` 90 with the far pass, at 10.6 s the motorboat's new cluster 112 was born too
    small for ``relink_min_area`` beside its lost identity 81, died at 10.9 s unconfirmed, and
    the two lost identities then alternated on the boat to 29 s: four switches).  The youngest
    identity has never been reported (``confirm_s``), so the older one is the boat's last.
    ``relink_area_at_loss`` (False: off): ``relink_min_area`` compares a new cluster's box with the
    smaller of the lost identity's expected box and its box at the loss (its area times the square
    of the zoom now over the zoom then): a coast (``coast_follow``) may grow the expected box onto
    the wake or the sea (on sim ``pan`` 90 at 16.8 s the motorboat's coasted box grew from 20 x 12
    to 76 x 14 px, and its new 15 x 9 px cluster was refused the identity).  ``relink_retry_s``
    (0: off; seconds): a cluster first seen less than this long ago and still under its own identity
    is offered the lost identities again in each frame, as a new cluster is (with every check), but
    only those lost before it was first seen; its own identity is then retired, not lost.  It may take
    the identity of a cluster joined into its report while moving otherwise, which ``merge_id_dv_px_s``
    does not hand over (session 28: skipping those added 3 switches on ``pan`` 111-142, so it is not done).  Below
    ``confirm_s`` its own identity was never reported.  A boat's new cluster is often born on a few
    features, a box too small for ``relink_min_area``, and grows in the next frames (on sim ``pan`` 82
    at 15.0 s the motorboat's new 9 x 4 px cluster beside its lost 35 x 9 px box, reported under its
    own identity from 15.6 s).

    ``edge_min_w_px`` (session 27, h30; px, not scaled; 0: off): a box that touches the image's left or
    right edge and is clipped there to under this width (its members have left the view: U reports
    such boxes as ``[0, y, 0, h]``) is not reported.  Its identity is then lost with its last whole
    box and its look (``relink_appearance``'s signature), not with a zero-width box whose look is
    unknown (no appearance check) and whose row and height are the strip's at the edge.  On ``pan`` 94
    under U the fishing boat's identity was lost as ``[0, 316, 0, 7]`` and taken 25 s later by the RIB
    at the pan's return, unchecked; the boat then took the RIB's (a swap, 2 switches).

    ``relink_app_margin`` (session 27, h30; appearance distance, no unit; 0: off; needs
    ``relink_appearance``): a new cluster with two or more lost identities in its relink gate whose looks
    are known takes none whose appearance distance exceeds the smallest of them by more than this margin
    (the relink's pairs go nearest first; the gate does not see that a boat has moved ~200 px in 25 s out
    of view at the pan's return, its look does).  On ``pan`` 21 and 93 the nearer lost identity looked
    0.70 / 1.16 away, the right one 0.05 / 0.39.

    ``relink_hold_s`` (session 27, h32; seconds; 0: off; meant with ``relink_retry_s``): a cluster first
    seen less than this long ago, still under its own identity, that has a lost identity in view within
    its relink gate (``relink_px`` + ``relink_px_per_s`` per second lost) but was not given one this frame
    (refused by the size, appearance or another check) stays tentative: it is not reported, even past
    ``confirm_s``.  Its own identity is then never shown while ``relink_retry_s`` may still rename it to
    the lost one; once it is older than this, or no lost identity has it in its gate, it is reported as
    usual.  It acts only where ``relink_retry_s`` does (not on infrared frames with ``relink_retry_ir`` off):
    without the retry a hold would only delay the report.  Under W ``relink_retry_s`` renamed clusters reported for 0.1-0.3 s (2 switches where the
    defaults had 0 or 1: sim ``pan`` 108 at 29.4 s the motorboat's new 86 x 16 px cluster, confirmed as
    139, renamed to the boat's lost 7 at 29.5 s; 35.3 s the rib's).

    Session 27 (helper h31, round 1's steps on infrared): ``coast_dup_ir``, ``lost_dup_ir``,
    ``relink_area_at_loss_ir``, ``relink_retry_ir``, ``relink_app_margin_ir`` (True: the step acts on
    infrared frames too, as before; False: off on infrared frames, i.e. ``coast_dup_iou``,
    ``lost_dup_iou``, ``relink_area_at_loss``, ``relink_retry_s``, ``relink_app_margin`` on visible frames
    only, in the style of ``wake_track_ir``).  They change nothing while their step is off.

    Session 29 (the lead, the joined report's identity on infrared): ``merge_id_now_iou_ir`` (0: off;
    infrared frames only; an IoU): where ``merge_id_keep_iou`` finds no member whose report in the frame before
    overlaps the joined box enough, the member whose report in the frame before overlaps it most keeps its identity
    when its own box of this frame overlaps the joined box by at least this. The frame before's box
    of a big boat's cluster can flicker (sim ``ir`` 19 at 35.5 s: the ferry's report was its lower hull alone,
    IoU 0.25 with the next frame's joined box, which the ferry cluster's own box overlaps by 0.81); the older
    small cluster of a boat beside it then won the joined report by age, and kept it through the frame before's box.

    Session 30 (h36, the tug's box drawn over the ferry on infrared): ``box_anchor_far_h_ir`` (0: off;
    infrared frames only; in heights of the cluster's box of the frame before, ``box_keep_last``'s anchor):
    a box member lying more than this many times that box's height outside it (in x or y, the box carried by
    the camera motion) leaves the box when at least two of its cluster's box members lie inside that box.
    One feature of another boat held in the same graph cluster, whose velocity passes ``box_dv_px_s`` for a
    frame, otherwise widens the box over both boats, and the next frame's anchor then takes the other boat
    (sim ``ir`` 19 at 2.8 s: a ferry feature 76 px right of the tug's 59 x 32 px box drew the box over both;
    from 2.9 s the tug's identity was on the ferry).
    ``box_anchor_far_minority_ir`` (False: off): with it, those members leave only where they are fewer than the
    box members inside that box (a few features of another object; where most lie outside, the last box was a
    part of the boat, and the box may grow back: sim ``ir`` 13 at 35.8 s, the ferry's box held at 6 x 7 px).

    Session 31 (h44, the sailboat's box widened over the cargo ship's stern on infrared): ``box_anchor_near_h_ir``
    (0: off; infrared frames only; in heights of the anchor box, as ``box_anchor_far_h_ir``, and with it): the box
    members lying inside the anchor box or at most this many of its heights outside it count towards
    ``box_anchor_far_h_ir``'s two members (and ``box_anchor_far_minority_ir``'s majority). A small boat's grown box
    is tighter than its features' span, so often only one member lies inside it, and one feature of another boat
    held in the same graph cluster then widens the box over both (sim ``ir`` 20 at 11.1 s: members at x 308, 312,
    319 beside the 8 x 10 px box at x 310, only 312 inside; a cargo ship's stern feature at x 361 drew the box to
    60 x 12 px, the next frame's anchor took it, and the sailboat's identity was lost at that wide box 3 s later).

    Session 32 (h47, the sailboat's box drawn over the cargo ship on infrared): ``box_anchor_gap_side_ir`` (0: off;
    3.0, with the two below on, the default since session 32's rule P; infrared frames only; in the anchor box's
    smaller side, so scaled by the zoom; with ``box_anchor_far_h_ir``): where
    ``box_anchor_far_minority_ir`` keeps a cluster's far members (they are not fewer than the members inside or
    near the anchor box, of which there are at least two), a far member still leaves when it is spatially apart
    from those members: not joined to them by a chain of the cluster's box members, sorted by x, each at most
    this many times the anchor box's smaller side from the next (a group of another boat's features, beyond a
    gap; the smaller side, since a small boat's grown box can grow tall for a frame over a sail or a mast:
    sim ``ir`` 86 at 37.1 s, 8 x 23 px).  ``box_anchor_gap_one_ir`` (False: off; with it): the gap rule acts also where only one
    box member lies inside or near the anchor box (``box_anchor_far_h_ir`` needs two): sim ``ir`` 86 at 43.5 s, one
    of the sailboat's two features gone for a frame, and its box went over the cargo ship's four.
    ``box_anchor_gap_steady_ir`` (False: off; with it): the gap rule acts only in clusters whose anchor box
    overlapped (IoU >= 0.1) their box of the frame before it: an anchor that is a one-frame jump is not kept (sim
    ``ir`` 82 at 12.0 s: the cargo ship's cluster held two sailboat features; for one frame only those were left
    and its box jumped onto the sailboat; the next frame the gap rule kept it there against the cargo's four, and
    the sailboat was reported under that cluster's new identity). The minority rule
    keeps the rest of a boat whose last box was a part of it (its members run on along the hull without a gap).
    (sim ``ir`` 79 at 36.2 s: two cargo features joined the sailboat's graph cluster, which held one of the cargo's
    stern already; three far against three near, so the box went over both boats, 109 x 30 px, and at the graph's
    split 0.8 s later the sailboat's identity stayed with the cargo's part: the wide box hid the jump from
    ``split_follow_box``.)
    Session 32 (h46, the sailboat's box drawn over the cargo ship on infrared): ``box_anchor_far_gap_h_ir`` (0: off;
    infrared frames only; in heights of the anchor box, as ``box_anchor_far_h_ir``, and with it and
    ``box_anchor_far_minority_ir``): the far members leave even where they are not fewer than the members inside the
    anchor box, when the nearest of them lies more than this many of its heights outside it and the anchor box was
    grown in the frame before (``grow_boxes`` found the boat there): a separate group of features, another boat held
    in the same graph cluster, not the rest of a boat whose box was held on a part. (Where the anchor box is only its
    members' box it may itself lie on the wrong boat: sim ``ir`` 42 at 38.3 s, the sailboat's 10 x 7 px box on two
    cargo-stern members, its own two members 39 px away; leaving those out drew the box onto the cargo ship.)
    Sim ``ir`` 68 at 38.0 s: the sailboat's 11 x 16 px box with 3 members at x 285-295 and 3 of the cargo ship's at
    x 332-389 (2.2-6 heights outside, all ~-1 px/s) in one graph cluster; 3 against 3 is no minority, the box became
    108 x 20 px, the next frame's anchor took it, and from 40.4 s the cargo ship carried the sailboat's identity.

    ``relink_side_row_margin`` (session 29, h33; px, not scaled; 0: off; needs a horizon): a new cluster
    with two or more lost identities in its relink gate that were lost at the image's left or right edge
    takes none whose row under the horizon at the loss (its box's bottom less the horizon's row at its
    centre, in the frame of the loss) lies further from the new cluster's own, by more than this margin,
    than the nearest one's.  The relink's pairs go nearest first, on a gap that the boats' own motion out of
    view (~200 px in 25 s) dominates, to an expected box whose row, carried 25 s outside the image by the
    frames' homographies, drifts by 30-60 px; the row under the horizon at the loss was kept to a few px.
    At the pan's return on sim ``pan`` 80 (34.8 s) the rib's new cluster (76 px under the horizon) took
    the fishing boat's identity (29 px at the loss, gap 177 px) rather than the rib's (66 px, gap 196 px),
    and the fishing boat the rib's at 38.8 s; on ``pan`` 91 and 94 the rib came back 1 px from its row at the
    loss, the fishing boat's 28-39 px off.  Not scaled by the zoom: there the zoom read 1.6 against 1.0 at
    the loss, and the rows matched unscaled (scaled, the rib's and the fishing boat's tied).
    ``relink_side_row_ir`` (False: visible frames only; True: infrared too).

    ``relink_side_app_near_px`` (session 30, h38; px, times the zoom; 0: off): an identity lost at the
    image's left or right edge whose expected box lies within this gap (box edge to box edge) of a new
    cluster is not refused by the look (``relink_appearance``'s maximum or ``relink_app_margin``) for that
    cluster: its look was taken from a box cut by the edge.  At the pan's return on sim ``pan`` 160 (31.3 s)
    the sailboat's new cluster lay 11 px from the sailboat's expected box, but its look (0.87, lost as a
    9 px wide box at the left edge) was 0.5 worse than the tug's (0.34, gap 369 px), so ``relink_app_margin``
    left only the tug's identity; on ``pan`` 95 the sailboat's (gap 18 px, lost as a 2 px sliver) failed
    ``relink_appearance_max`` outright.  The sailboat took the tug's identity and the tug the sailboat's.
    ``relink_side_app_near_ir`` (False: visible frames only; True: infrared too).

    ``relink_side_app_near_margin`` (session 31, h43; False: off; with ``relink_side_app_near_px``): such a
    pair's look distance still counts in ``relink_app_margin`` (only the look check's own limit is skipped):
    another lost identity that looks much more like the new cluster keeps it.  On sim ``pan`` 237 at the pan's
    return (31.7 s) the sailboat's new cluster lay 20 px from both the tug's expected box (lost at the side,
    look distance 0.98) and the sailboat's own (0.37); without its distance the tug's pair escaped the
    margin and won the tie (2 -> 4 switches); 226 the same at 32.3 s.

    ``relink_side_app_near_alone_px`` (session 31, h45; px, times the zoom; 0: off; with
    ``relink_side_app_near_px``): a new cluster whose box lies within this gap (box edge to box edge) of a
    cluster that is not new this frame, or of a box reported in the last frame (carried by the camera), gets no
    such exemption (the look checks as without the step): it is likely a part of a boat already in view.  On sim ``pan`` 179 at the pan's return the sailboat's mast came
    back as a new cluster that took its own identity (31.5 s), and its hull as a second new cluster 2 px
    beside the mast's box of 0.1 s before (that cluster gone), 8 px from the tug's expected box (lost at the side, look distance 1.74): with the
    exemption the hull took the tug's identity (5 -> 7 switches).

    ``relink_side_h_clear_px`` (session 30, h40; px, times the zoom; 0: off, a box counts as clear of the
    side edges 1 px from them): ``relink_side_h_ratio``'s heights of an identity are kept only from its
    boxes at least this far from the image's left and right edges.  A boat leaving at the side edge is
    cut to a few columns there, and its box, then 4-9 px from the edge, grows on the water beside it: on
    sim ``pan`` 153 the tug's last heights before its loss at the left edge (17.8 s) were 50, 14, 14, 54,
    54 px (boxes 29 px wide at x 4-9) against its 7-13 px hull, so at the pan's return (32.8 s) its new
    13 px cluster, 30 px from its expected box, was refused (median 50 > 3 x 13) and took a thin
    identity lost there 20 s before.  Boxes grown in mid-frame still count: on ``pan`` 160 (15 px) the
    sailboat's last heights became 69-75 px (grown on the motorboat) and its 25 px new cluster was refused;
    a longer median (``relink_side_h_n`` 15) keeps both.  ``relink_side_h_clear_ir`` (False: visible frames
    only; True: infrared too).

    ``relink_side_h_clear_either`` (session 31, h45; False: off; with ``relink_side_h_clear_px``): the height
    check refuses a pair only when the heights clear by that margin refuse it and so do the heights 1 px clear
    of the side edges (as without the margin): the margin only adds pairs.  On sim ``pan`` 193 (31.4 s) the
    sailboat's heights clear by 15 px were 74-77 px (grown before it left) against its 30 px new cluster 2 px
    from its expected box; its heights nearer the edge passed, and without them it took the tug's identity
    (4 -> 6 switches).

    ``relink_near_refused_px`` (session 32, h48; px, times the zoom; 0: off; 10, with the two guards below on, the default since session 32's rule Q): a new cluster with a lost
    identity (not present, in view) expected within this gap of its box (box edge to box edge) that a check
    refused (its height, size, look, ...) is given no lost identity expected further away than this gap this
    frame: a boat coming back in part is not named after another boat lost far away (it stays under its own
    identity, held tentative by ``relink_hold_s`` while ``relink_retry_s`` may still give it its own).  On sim
    ``pan`` 244 at the pan's return (31.2 s, zoom 2.76) the sailboat's hull came back as a 16 px high cluster 3 px
    from the sailboat's expected box, refused by ``relink_side_h_ratio`` (its heights 53 px at this zoom), and
    took the tug's identity, lost at the left edge 13.5 s before and expected 391 px away (the gate, scaled by
    the zoom, 393 px); the tug then took the sailboat's (2 switches); 255 and 270 the same.
    ``relink_near_refused_ir`` (False: visible frames only; True: infrared too).
    ``relink_near_refused_newer`` (False: off; with ``relink_near_refused_px``): only the far identities lost
    before the last-lost of the refused near ones are withheld (the boat last seen there is the newer loss): on
    ``pan`` 240 and 243 (33.0-33.4 s) the tug's new cluster lay 7 px from an identity lost 20 s before (a 0 px
    wide sliver; a thin 91 x 8 px box), refused, and lost its own tug identity (lost later, 30-42 px away).
    ``relink_near_refused_far_out`` (False: off; with ``relink_near_refused_px``): only far identities expected
    wholly beyond the image's left or right edge are withheld (the pan's return: in 244, 255, 270 all the far
    ones were); on sim ``pan`` 2 (11.1 s) the motorboat's new cluster,
    10 px from its own wide grown box (refused), was withheld the identity lost 77 px away in mid-frame 9.5 s
    before, then reported under its own for a frame and renamed (1 -> 2 switches).

    ``relink_predict_side_s`` (session 30, h39; seconds; 0: off): an identity lost at the image's left or
    right edge may also be relinked where its own motion took it (a second place for the relink gap, as
    ``relink_alt_s``'s; its carried box, which the coast also reads, is unchanged): its corners'
    directions at the loss moved on in azimuth for up to this many seconds: a boat pushed out of the
    view at the side by the pan or the zoom goes on moving while out of it.  On sim ``pan`` 174 the motorboat (5 m/s at 300 m) left at the left
    edge in the zoom-in at 20 s; its lost box, carried by the camera only, sat at x -286 while the boat
    came back at 28.7 s at x 2, 333 px away (gate 282): "too far".  Only with the camera model
    (``relink_camera``); the rates are a line fitted to the directions of its box's centre over the last
    ``relink_predict_side_win_s`` (2) seconds, boxes clear of the edges, in azimuth only (its last velocity,
    from a box cut by the edge or a cluster that slid onto the sailboat's mast, threw it 1100 px off; the
    fitted elevation rate lifted it into the sky); its row is its centre's median elevation over that
    time (the motorboat's last box had slid onto the sailboat's mast, 50 px above its hull).  Without a
    fit (fewer boxes clear of the edges, as a boat that hugged the edge), it is carried as without the step.  ``relink_predict_side_ir`` (False:
    visible frames only; True: infrared too).

    ``relink_predict_side_min_rate`` (session 31, h43; deg/s; 0: off; with ``relink_predict_side_s``): the
    second place only for a boat whose fitted azimuth rate is at least this fast in magnitude; a slower fit
    counts as none (carried as without the step).  A slow boat's second place is its carried box moved a
    few pixels, which only slips a far new cluster inside the gate: on sim ``pan`` 173 the tug's identity
    (fitted 0.05 deg/s) had its carried box 395 px from the sailboat's new cluster (gate 388) and its
    second place 375 px, and took it at the pan's return (31.1 s).  The motorboat turns about 1 deg/s
    and the rib 1.5, the sailboat and the tug 0.1-0.2.

    ``relink_predict_side_near_px`` (session 31, h43; px, times the zoom; 0: off; with
    ``relink_predict_side_s``): an identity lost with its box within this of the image's left or right edge
    (not on it) also gets the second place: a boat about to be pushed out by the zoom is often lost a few
    frames before its box reaches the edge.  On sim ``pan`` 110 the motorboat's identity was lost at 19.1 s
    with its box at x 38 (zoom 1.4), its cluster grown onto the sailboat's mast, and came back at 28.5 s
    350 px from its carried box (gate 349).  Only for the second place (the other side-edge steps keep
    their own test).

    ``relink_predict_side_med_box`` (session 31, h43; False: off; with ``relink_predict_side_s``): the
    second place is a box of the identity's median width and height over the fit's window (px over the
    zoom, times the zoom now), centred on its fitted line's direction at the loss moved on by its rate, at
    its median elevation, rather than its last box's corners moved on: a last box grown onto a
    neighbour (the mast, 49 px high against a 10-12 px hull on ``pan`` 110) made the relink's height
    check through the zoom (``relink_height_zoom_min``) refuse the boat's own 19 px cluster.

    ``relink_app_min_w_px`` (session 29, h33; px, times the zoom; 0: off; with ``relink_appearance``): an
    identity lost with a box narrower than this keeps no look (its appearance signature is unknown, so a
    relink does not check it): a sliver clipped at the image's edge shows the boat's last columns, not its
    look.  On sim ``pan`` 95 the sailboat's identity, lost at the left edge as ``[0, 295, 2, 22]``, was
    refused at the pan's return (31.3 s) by the look check to its own new cluster, which took the tug's.
    ``relink_app_min_w_ir`` (False: visible frames only; True: infrared too).

    ``relink_jump_back_iou_ir`` (session 30, h37; an IoU; 0: off; infrared frames only): a cluster that comes
    back under its own identity ``r`` while ``r`` is lost (not reported the frame before: the graph kept
    the cluster, its report dropped out) with its box away from ``r``'s expected box (IoU under 0.1) and on
    another lost identity ``k``'s expected box (IoU at least this; of several, the largest) takes ``k``, of
    any age (``relink_jump_iou`` needs the cluster reported the frame before and ``k`` older); ``r`` stays
    lost where it was.  On sim ``ir`` 43 (13.4 s) and ``ir`` 14 (37.0 s) the sailboat's cluster, whose box
    had grown to the cargo ship's width, came back after 1-2 s unreported with its box on the cargo ship
    (IoU 0.9 / 0.5 with the cargo's identity lost 1.7 / 11.7 s before) and reported it under the
    sailboat's identity.  ``relink_jump_back_area`` (1.5; a ratio; 0: no check): only onto a lost box of
    an area within this ratio of the cluster's box (a joined box over two boats, ``ir`` 15 at 24.4 s and
    ``ir`` 19 at 36.2 s, is 1.8 times the lost box it overlaps).  ``relink_jump_back_s`` (3 s; 0: no check):
    only a cluster whose own identity was lost at most this long ago (a drop-out; on ``ir`` 15 at 29.0 s the
    ferry's cluster came back 17.5 s after its loss, over the ferry, on the cargo ship's expected box).
    ``relink_jump_back_own_area`` (a ratio; 0: no check): only a cluster whose box now is within this ratio of
    the area of its own identity's box at the loss (its box had already taken the other boat's size: ``ir`` 43,
    14 at 1.06, 1.73; on ``ir`` 5 at 42.8 s the fishing boat's 13 x 12 px cluster came back 69 x 15 on the ferry
    for a second, 6.6 times, and carried the ferry's identity back onto the fishing boat).

    ``relink_area_med_n_ir`` (session 30, h37; a count of frames; 0: off; infrared frames only): the relink's
    size check (``relink_min_area``) compares a new cluster's area with the median area of the lost identity's
    last this many reported boxes (times the zoom change squared) where that is smaller than its expected
    box's: a small boat's box flickers on infrared between its hull, its mast and a grown box beside it, and
    the box at the loss can be the largest of them.  On sim ``ir`` 41 (24.7 s) the sailboat's identity, lost at
    a 17 x 17 px box (its boxes before: 8 x 17-19), was refused to its own 8 x 8 px cluster (< 0.3 of 289 px).

    ``relink_shape_block_s_ir`` (session 31, h42; seconds; 0: off; infrared frames only): a new cluster whose
    box overlaps the expected box of an identity lost at most this long ago, but which the relink's shape
    checks (``relink_aspect_ratio``, ``relink_min_area``) refuse it, takes no lost identity in that frame (it
    stays under its own identity, for ``relink_retry_s`` to give the near one later): on sim ``ir`` 53 (39.4 s)
    a cluster born with a box 57 x 11 px over the sailboat and the cargo ship's stern covered the sailboat's
    identity lost 0.7 s before (11 x 14 px: refused by the aspect ratio) and took the cargo ship's, lost 18.7 s
    and 22 px away; a second later its box was the sailboat's alone.

    ``relink_shape_min_n_ir`` (session 31, h42; a count of frames; 0: off; infrared frames only): the relink's
    shape checks (``relink_aspect_ratio``, ``relink_min_area``) also accept a new cluster that passes them
    against the smallest of the lost identity's last this many reported boxes (carried by the zoom change): a
    small boat's box widens on infrared for a few frames over a neighbour's feature before the loss (sim ``ir``
    43 at 11.9 s: the sailboat's 8 x 10 px box became 55 x 11 px for 0.3 s, and at 25.0 s its own new 8 x 10 px
    cluster was refused its identity by the aspect ratio and the size check).  ``relink_shape_min_grown_ir`` (a
    ratio; 2; acts only with ``relink_shape_min_n_ir``; 0: no check): only where the expected box is at least
    this many times the smallest one's area (the box grew before the loss; sim ``ir`` 7 at 18.0 s, without it:
    the sailboat's identity lost at a 5 x 8 px box passed the aspect check against its 6 x 9 px box of 0.5 s
    before and went to the cargo ship's cluster 63 px away).
    ``relink_shape_any_ir`` (session 31, h42; False: off; with ``relink_shape_min_n_ir``): the aspect check
    passes against any of those last boxes, not only the smallest (sim ``ir`` 42 at 9.9 s: the cargo ship's
    identity lost at a 12 x 23 px sliver after 73 x 30 px boxes; its new 53 x 13 px cluster refused, 7.8), not
    restricted by ``relink_shape_min_grown_ir``; ``relink_shape_any_area`` (a ratio, 4; 0: no check): only those
    boxes whose area is within this ratio of the new cluster's (``ir`` 7: the cargo ship's 52 x 13 px cluster is
    10.6 times the sailboat's 8 x 8 px box).

    Session 31 (h41, the ferry and the small boat beside it on infrared, class A): ``grow_core_in_ir``
    (0: off; infrared frames only; a fraction of area): a grown box (``grow_boxes``) that holds less than this
    fraction of its cluster's core (the box members' extent) is not kept: the box stays the members' own, as
    where nothing was grown. The growing takes the bright components touching the core; a small boat's core
    that touches a passing ship's hull grows onto the hull, and ``grow_hint`` then holds it there (sim ``ir`` 19
    at 35.0-36.2 s: the small boat's 5 features in 12 x 14 px, their box grown to 73 x 16 px over the ferry's
    hull, holding 5 % of the core; the joined report then took the small boat's older identity).
    ``grow_core_hint_ir`` (0: off; with ``grow_core_in_ir``; a fraction of area): such a box is replaced by the
    cluster's box grown in the frame before (``grow_hint``'s, carried by the camera) where that one holds at least
    this fraction of the core, rather than by the members' own box (sim ``ir`` 8 at 35.8 s: the fishing boat's
    members' box is a part of the boat; its box of the frame before holds the whole core. Sim ``ir`` 2 at 28.8 s:
    a box of the frame before already grown half onto the boat above holds 0.46 of it, and must not be kept).
    ``merge_id_now_any_ir`` (False: off; with ``merge_id_now_iou_ir``): where neither ``merge_id_keep_iou`` nor
    ``merge_id_now_iou_ir``'s member decides and ``merge_id_dv_px_s``'s rule left the identity to the oldest by age,
    the member reported in the frame before whose own box of this frame overlaps the joined box most, by at least
    ``merge_id_now_iou_ir``, keeps its identity (sim ``ir`` 13 at 36.8 s: the ferry's box, held small the frame
    before, grew back to 76 x 15 px and touched the small boat's 16 x 16 px box; 6 features each, the small boat's
    older identity won the joined report by age; the ferry's own box overlaps the joined one by 0.56).
    ``merge_id_apart_ir`` (False: off): ``merge_id_apart`` on infrared frames only (two overlapping reports whose
    largest clusters move differently, by more than ``merge_id_dv_px_s``, and of which neither holds
    ``merge_id_ratio`` times the other's features, are not joined; sim ``ir`` 13 at 36.8 s: the ferry's cluster,
    6 features at 5.4 px/s, and the small boat's, 6 at -0.8 px/s, joined under the small boat's older identity).

    Session 28 (rule J, on never-run ``pan`` and ``ir`` seeds; docs/stable_features_log.md) turned on, as
    the defaults below: the wake steps ``wake_hold_s`` 1, ``wake_front`` 0.3, ``wake_core`` 0.5 (``wake_core_ir``
    0, ``wake_track_ir`` False), ``wake_core_iou`` 0.6; the coast steps ``coast_edge_seen``,
    ``coast_edge_horizon`` (``coast_edge_horizon_h`` 1.5, ``coast_edge_horizon_contrast`` 5),
    ``coast_dup_iou`` 0.5 with ``coast_dup_seen``; the far strip's cuts ``far_cut_px`` 12 and
    ``far_cut_deep_px`` 24 (with the extractor's far-water pass, ``StableFeatureExtractor(far_px=12)``); and
    the identity steps ``lost_dup_iou`` 0.3, ``relink_area_at_loss``, ``relink_retry_s`` 1, ``relink_app_margin``
    0.5 and ``relink_hold_s`` 1, session 27's five on visible frames only (their ``*_ir`` switches False).
    Session 29 (rule K, on never-run ``pan`` and ``ir`` seeds) turned on ``relink_side_row_margin`` 20 (visible
    frames only) and ``merge_id_now_iou_ir`` 0.5. Session 30 (rule L, on never-run ``pan`` 175-206 and ``ir``
    47-54) turned on, all on infrared frames only, ``box_anchor_far_h_ir`` 1.0 with ``box_anchor_far_minority_ir``,
    ``relink_jump_back_iou_ir`` 0.4 with ``relink_jump_back_own_area`` 2, and ``relink_area_med_n_ir`` 5.
    Session 31 (rule N, on never-run ``pan`` 239-270 and ``ir`` 55-70) turned on, all on infrared frames only,
    ``grow_core_in_ir`` 0.1 with ``grow_core_hint_ir`` 0.6, ``merge_id_now_any_ir``, and
    ``relink_shape_block_s_ir`` 1 with ``relink_shape_min_n_ir`` 5 (``relink_shape_min_grown_ir`` 2); then rule O
    (on never-run ``ir`` 71-86) ``relink_shape_min_n_ir`` 40 and ``box_anchor_near_h_ir`` 0.5 (h44).
    Where a field's text above says "off", that is the value that turns it off."""

    dmax: float = 0.31
    alpha: float = 3.0
    w_link: float = 1.0
    radius_px: float = 50.0
    p_px: float = 3.0
    frame_interval_s: float = 0.04
    min_speed_px_s: float = 1.5
    noise_factor: float = 0.0
    w_cap: float = 15.0
    min_features: int = 2
    label_memory_s: float = 2.0
    confirm_s: float = 0.4
    box_pad: float = 1.0
    grow_box: float = 1.0
    grow_peak_frac: float = 0.5
    relink_s: float = 30.0
    relink_px: float = 20.0
    min_contrast: float = 4.0
    merge_overlap: float = 0.25
    still_radius_px: float = 15.0
    relink_predict: bool = True
    water_margin_px: float = 8.0
    relink_px_per_s: float = 10.0
    relink_predict_s: float = 0.0
    relink_overlap: float = 0.3
    relink_camera: bool = True
    merge_dv_px_s: float = 3.0
    unmerge: bool = False
    merge_gap_h: float = 0.0
    merge_gap_min_px: float = 24.0
    grow_wide_px: float = 120.0
    relink_min_s: float = 0.4
    relink_undo_drop_alias: bool = False
    sky_margin_px: float = 5.0
    box_dv_px_s: float = 1.5
    merge_keep: float = 0.5
    merge_keep_gap_px: float = 2.0
    merge_keep_gap_h: float = 2.0
    box_dv_noise_k: float = 0.0
    waterline_frac: float = 0.5
    wake_frac: float = 0.3
    wake_min_px_s: float = 5.0
    top_frac: float = 0.2
    top_frac_ir: float | None = 0.35
    top_min_px: float = 2.0
    box_wake_below_px: float = 5.0
    box_wake_max_h_px: float = 20.0
    box_wake_top: bool = False
    box_wake_below_px_ir: float | None = 0.0
    max_aspect: float = 12.0
    cut_core_frac: float = 0.0
    cut_core_undo: bool = False
    merge_dv_clusters: bool = True
    box_keep_last: bool = True
    relink_size_ratio: float = 0.0
    split_dv_px_s: float = 6.0
    split_min_features: int = 2
    split_hand_over: bool = True
    split_s: float = 1.0
    split_memory_s: float = 10.0
    split_keep_parts: bool = True
    relink_appearance: bool = True
    relink_appearance_max: float = 1.4
    relink_appearance_tpl: float = 0.0
    coast_s: float = 15.0
    coast_min_age_s: float = 0.4
    coast_check: bool = True
    coast_follow: bool = True
    coast_size_ratio: float = 2.0
    coast_overlap: float = 0.8
    coast_inside_big: bool = True
    size_filter_s: float = 0.0
    size_filter_k: float = 1.5
    size_filter_min_n: int = 5
    size_filter_width: bool = True
    size_filter_grown: bool = False
    size_filter_height: bool = True
    wake_thick: bool = False
    wake_core: float = 0.5
    wake_core_ir: float | None = 0.0
    wake_track_s: float = 0.0
    wake_track_px_s: float = 0.0
    wake_track_n: int = 4
    wake_track_ir: bool = False
    wake_hold_s: float = 1.0
    wake_front: float = 0.3
    wake_core_iou: float = 0.6
    wake_core_iou_cut: float = 0.0
    box_disp_s: float = 1.0
    box_disp_frac: float = 0.5
    box_disp_min_px: float = 2.0
    box_disp_q: float = 0.0
    box_disp_two: bool = True
    box_disp_two_wake_px: float = 2.0
    box_disp_two_anchor: bool = True
    box_disp_two_far_h: float = 1.0
    grow_sign: float = -0.7
    grow_sign_max_px: float = 0.0
    grow_sign_trail_px_s: float = 2.0
    relink_dv_px_s: float = 0.0
    hand_over_dv_px_s: float = 0.0
    dv_still_px_s: float = 0.0
    coast_skip_merged: bool = True
    coast_skip_merged_dv: float = 3.0
    coast_skip_merged_zoom: bool = True
    grow_cover_wide: bool = False
    grow_hint: bool = True
    grow_hint_pad_px: float = 20.0
    grow_hint_core: float = 0.5
    grow_hint_core_x: bool = False
    grow_jump: float = 0.0
    grow_jump_max_h_px: float = 0.0
    grow_jump_keep: bool = True
    grow_trail_max: float = 0.0
    grow_trail_max_h_px: float = 10.0
    grow_trail_max_ir: float | None = 0.0
    hand_over_size_ratio: float = 0.0
    hand_over_height_ratio: float = 3.0
    relink_min_area: float = 0.3
    relink_area_same_zoom: bool = True
    relink_alt_s: float = 3.0
    relink_alt_memory: bool = False
    known_min_speed_px_s: float = 0.8
    known_err_k: float = 2.0
    known_err_tau_s: float = 0.949122  # 0.1 a frame at 10 frames/s: -0.1 / ln(0.9)
    known_still_px: float = 0.1
    known_band_px: float = 0.0
    merge_id_dv_px_s: float = 3.0
    merge_id_ratio: float = 2.0
    merge_id_apart: bool = False
    merge_min_share: float = 0.34
    merge_id_keep_iou: float = 0.3
    gate_dv_px_s: float = 0.0
    coast_search: float = 0.0
    coast_search_below_px: float = 12.0
    coast_retry_s: float = 1.0
    coast_max_aspect: bool = False
    relink_dy_h: float = 1.5
    relink_dy_same_zoom: bool = False
    relink_iou_tie: bool = True
    gate_rel: float = 0.4
    gate_rel_min_px_s: float = 2.0
    relink_view_px: float = 120.0
    relink_view_same_zoom: bool = True
    relink_view_zoom_in: bool = True
    relink_view_zoom_scale: bool = True
    gate_chain: bool = False
    split_origin_dv_px_s: float = 0.0
    split_origin_s: float = 0.0
    relink_area_zoom_min: float = 0.0
    relink_height_zoom_min: float = 0.3
    far_top_px: float = 3.0
    far_coast_px: float = 20.0
    far_coast_gap_px: float = 4.0
    far_cols_px: float = 30.0
    far_open_px: float = 30.0
    far_sky_tol: float = 8.0
    far_open_contrast: float = 20.0
    foot_open_px: float = 10.0
    foot_dark: float = 8.0
    relink_dy_px_per_s: float = 1.2
    relink_dy_side: bool = True
    hand_over_relinked: bool = True
    split_follow_box: float = 0.5
    coast_outside_wait: bool = False
    coast_grow_up: float = 6.0
    relink_side_h_ratio: float = 3.0
    relink_side_h_n: int = 5
    relink_undo_hand_over: bool = True
    grow_core_q_ir: float = 0.4
    grow_core_box_ir: bool = False
    top_halo_ir: float = 0.0
    grow_core_retry_ir: bool = True
    coast_edge: float = 6.0
    coast_edge_s: float = 8.0
    coast_edge_seen: bool = True
    coast_edge_dy: float = 0.0
    coast_edge_horizon: bool = True
    coast_edge_clear: float = 0.0
    coast_edge_horizon_contrast: float = 5.0
    coast_edge_horizon_out: float = 0.0
    coast_edge_horizon_h: float = 1.5
    coast_dup_iou: float = 0.5
    coast_live_iou: float = 0.0
    coast_dup_seen: bool = True
    coast_look_up: float = 1.0
    coast_look_ahead: float = 0.5
    relink_jump_iou: float = 0.5
    relink_side_h_up: float = 0.0
    relink_young_s: float = 1.0
    relink_aspect_ratio: float = 6.0
    graph_cut_dv_px_s: float = 0.0
    graph_cut_parts: bool = True
    graph_cut_dv_px_s_ir: float = 6.0
    graph_cut_hold: float = 0.0
    gate_dv_px_s_ir: float = 0.0
    gate_ema_s_ir: float = 1.0
    merge_id_major_ir: bool = True
    relink_young_after_s: float = 1.0
    relink_own_speed_k: float = 0.0
    relink_own_speed_floor: float = 4.0
    coast_drop_alt: bool = True
    far_cut_px: float = 12.0
    far_cut_gap_px: float = 6.0
    far_cut_ir: bool = False
    far_id_px: float = 0.0
    far_id_ir: bool = False
    far_cut_deep_px: float = 24.0
    far_cut_deep_gap_px: float = 20.0
    lost_dup_iou: float = 0.3
    lost_dup_age_s: float = 0.5
    relink_area_at_loss: bool = True
    relink_retry_s: float = 1.0
    edge_min_w_px: float = 0.0
    relink_app_margin: float = 0.5
    relink_hold_s: float = 1.0
    coast_dup_ir: bool = False
    lost_dup_ir: bool = False
    relink_area_at_loss_ir: bool = False
    relink_retry_ir: bool = False
    relink_app_margin_ir: bool = False
    merge_id_now_iou_ir: float = 0.5
    relink_side_row_margin: float = 20.0
    relink_side_row_ir: bool = False
    relink_app_min_w_px: float = 0.0
    relink_app_min_w_ir: bool = False
    box_anchor_far_h_ir: float = 1.0
    box_anchor_far_minority_ir: bool = True
    box_anchor_near_h_ir: float = 0.5
    box_anchor_gap_side_ir: float = 3.0
    box_anchor_gap_one_ir: bool = True
    box_anchor_gap_steady_ir: bool = True
    box_anchor_far_gap_h_ir: float = 0.0
    relink_side_app_near_px: float = 0.0
    relink_side_app_near_ir: bool = False
    relink_side_app_near_margin: bool = False
    relink_side_app_near_alone_px: float = 0.0
    relink_side_h_clear_px: float = 0.0
    relink_side_h_clear_ir: bool = False
    relink_side_h_clear_either: bool = False
    relink_near_refused_px: float = 10.0
    relink_near_refused_ir: bool = False
    relink_near_refused_newer: bool = True
    relink_near_refused_far_out: bool = True
    grow_core_in_ir: float = 0.1
    grow_core_hint_ir: float = 0.6
    merge_id_now_any_ir: bool = True
    merge_id_apart_ir: bool = False
    relink_jump_back_iou_ir: float = 0.4
    relink_predict_side_s: float = 0.0
    relink_predict_side_ir: bool = False
    relink_predict_side_win_s: float = 2.0
    relink_predict_side_min_rate: float = 0.0
    relink_predict_side_near_px: float = 0.0
    relink_predict_side_med_box: bool = False
    relink_jump_back_area: float = 1.5
    relink_jump_back_s: float = 3.0
    relink_jump_back_own_area: float = 2.0
    relink_area_med_n_ir: int = 5
    relink_shape_block_s_ir: float = 1.0
    relink_shape_min_n_ir: int = 40
    relink_shape_any_ir: bool = False
    relink_shape_min_grown_ir: float = 2.0
    relink_shape_any_area: float = 4.0


class FeatureClusterer:
    """Clusters of stable features as tracked objects (the tracking half of paper B).

    Takes the :class:`~seawatch.detect.features.FeatureSnapshot` of each frame and returns the
    clusters as detections and tracks.  Kept apart from the feature extraction so that a
    parameter study can run the clustering many times on the features extracted once.

    Parameters
    ----------
    params : ClusterParams
        ``dmax``, ``alpha``, ``w_link``, ``radius_px`` (the paper's parameters), ``p_px`` and
        ``frame_interval_s`` (the magnitude sigmoid, see :func:`motion_dissimilarity`),
        ``min_speed_px_s`` and ``noise_factor`` (velocity samples slower than the larger of
        ``min_speed_px_s`` and ``noise_factor`` times the running median speed of the stable
        features, most of which are static, count as static; see :func:`frame_edges`),
        ``w_cap``, ``min_features``, ``label_memory_s`` (see :class:`AffinityClusters`),
        ``confirm_s`` (age from which a cluster is a confirmed track), ``box_pad`` (the box is
        the features' extent grown by ``box_pad`` times each keypoint's radius).
    """

    def __init__(self, params: ClusterParams | None = None, source: str = "stable_features",
                 camera_id: str = "cam0") -> None:
        self.params = params or ClusterParams()
        self.source = source
        self.camera_id = camera_id
        p = self.params
        self._top_frac = p.top_frac  # this frame's superstructure fraction (``update``'s ``ir``)
        self._ir = False  # this frame is infrared (``update``'s ``ir``)
        self.graph = AffinityClusters(p.alpha, p.w_link, p.w_cap, p.min_features, p.label_memory_s, p.unmerge,
                                      p.merge_dv_clusters, p.merge_min_share, p.gate_rel, p.gate_rel_min_px_s,
                                      p.gate_chain, p.split_origin_dv_px_s, p.split_origin_s,
                                      p.graph_cut_dv_px_s, p.graph_cut_parts, p.graph_cut_hold)
        self.last_labels = np.zeros(0, np.int64)
        self.last_contrast: np.ndarray | None = None
        self.noise_px_s = float("nan")
        self.camera_err_px_s = float("nan")
        self._cam_still = True
        self._relink_reset()
        self._size_reset()

    def _size_reset(self) -> None:
        """The state of the box size filter (``params.size_filter_s``, see :meth:`_size_filter`)."""
        self._size_hist: dict = {}  # cluster identity -> deque of (time, w, h) at the reference scale
        self._size_last: dict = {}  # cluster identity -> its box (after the filter) in the last update
        self._size_fi = -1  # frame index of the last update
        self._trk_hist: dict = {}  # cluster identity -> [(time, box centre x)] in this frame's image (wake_track_s)
        self._trk_hist_t = -1  # frame index of _trk_hist
        self._trail_last: dict = {}  # cluster identity -> (time, side) of its last trailing side set by its members (wake_hold_s)
        self._wcore_last: dict = {}  # cluster identity -> its grown box last frame (wake_core_iou)
        self._wcore_last_t = -1  # frame index of _wcore_last
        self._hold: set = set()  # relink_hold_s: identities held tentative this frame
        self._size_scale = 1.0  # the camera's scale now relative to the reference (product of the homographies')
        self._disp_ring: collections.deque = collections.deque()  # (time, slots, ids, scene positions) per frame
        self._disp_c = np.eye(3)  # this frame's image -> the scene reference (box_disp_s)
        self._disp_fi = -1  # frame index of the last update

    def _relink_reset(self) -> None:
        self._alias: dict[int, int] = {}  # cluster identity -> reported identity
        self._known: dict[int, float] = {}  # cluster identity -> last time seen
        self._lost: dict[int, tuple[float, np.ndarray]] = {}  # reported identity -> (time lost, box)
        self._prev_boxes: dict[int, np.ndarray] = {}  # reported identity -> last box
        self._prev_vel: dict[int, np.ndarray] = {}  # reported identity -> own velocity (px/s)
        self._birth: dict[int, float] = {}  # reported identity -> first time reported
        self._lost_dir: dict[int, tuple] = {}  # lost identity -> (azimuths, elevations) of its box corners
        self._own_now: dict = {}  # reported identity -> its own velocity this frame (NaN: unknown; hand_over_dv_px_s)
        self._own_prev: dict = {}  # the same, the frame before
        self._lost_v: dict = {}  # lost identity -> its own velocity when last seen (NaN: unknown; relink_dv_px_s)
        self._relinked: dict[int, tuple] = {}  # relinked identity -> (time, its lost entry, its directions, the cluster that took it)
        self._lost_alt: dict = {}  # lost identity -> (time lost, box, velocity): where it was expected before a relink undone late (relink_alt_s)
        self._lost_alt_dir: dict = {}  # lost identity -> the directions of its _lost_alt box's corners
        self._relinked_alt: dict = {}  # relinked identity -> (its _lost_alt entry, directions) at the relink (relink_alt_s)
        self._lost_zoom: dict = {}  # lost identity -> the camera's zoom when it was lost (relink_area_same_zoom)
        self._relinked_now: dict = {}  # identities relinked this frame (hand_over_relinked)
        self._swapped: set = set()  # new identities given to clusters whose box jumped (split_follow_box)
        self._lost_near: set = set()  # relink_predict_side_near_px: identities lost near (not at) the left or right edge
        self._lost_side: set = set()  # identities lost with their last box at the image's left or right edge (relink_dy_side)
        self._born: dict[int, float] = {}  # cluster identity -> time first seen (relink_young_s)
        self._whole_h: dict = {}  # reported identity -> [(height, zoom)] of its last boxes clear of the side edges (relink_side_h_ratio)
        self._whole_h1: dict = {}  # relink_side_h_clear_either: the same, boxes 1 px clear of the side edges
        self._returned: dict = {}  # lost identity back through the label memory -> the time it came back (relink_alt_memory)
        self._lost_a0: dict = {}  # lost identity -> (its box's area at the loss, zoom then) (relink_area_at_loss)
        self._lost_fit: dict = {}  # relink_predict_side_s: lost identity -> (azimuth rate deg/s, median elevation deg) at the loss
        self._dir_hist: dict = {}  # relink_predict_side_s: reported identity -> [(t, az, el)] of its box centre clear of the edges
        self._area_hist: dict = {}  # relink_area_med_n_ir: reported identity -> [(area, zoom)] of its last boxes
        self._lost_amed: dict = {}  # relink_area_med_n_ir: lost identity -> (median area of its last boxes, zoom)
        self._box_hist: dict = {}  # relink_shape_min_n_ir: reported identity -> [(box, zoom)] of its last boxes
        self._lost_small: dict = {}  # relink_shape_min_n_ir: lost identity -> (its smallest last box, zoom)
        self._shape_wait: dict = {}  # relink_shape_block_s_ir: blocked cluster -> (time blocked, the identities it covered)
        self._lost_row: dict = {}  # lost identity -> (bottom row less the horizon's, raw bottom row) at the loss (relink_side_row_margin)
        self._camera = None
        self._prev_camera = None
        self._zoom = 1.0
        self._disp_anchor = None  # box_disp_two_anchor: the members inside their cluster's last box
        self._anchor_gap_h = None  # box_disp_two_far_h: each member's distance outside that box / its height
        self._anchor_h = None  # box_anchor_gap_side_ir: the smaller side of each member's anchor box
        self._anchor_cids = None  # box_anchor_gap_steady_ir: the cluster identities of _box_anchor's call
        self._horizon = None
        self._merged: list = []  # (feature identities, box) of last frame's reports joined from several clusters
        self._merged_t = float("nan")  # the time of the frame that made _merged
        self._dts: list = []  # the last frame intervals (s), for the age limit of _merged
        self._cluster_boxes: dict = {}  # cluster identity -> its box last frame (box_keep_last)
        self._cluster_boxes_t = -1  # frame index of _cluster_boxes
        self._cluster_steady: set = set()  # box_anchor_gap_steady_ir: clusters whose box overlapped the one before
        self._cluster_boxes_now = -1  # frame index before this one
        self._grown_last: dict = {}  # cluster identity -> its grown box last frame (grow_hint)
        self._grown_last_t = -1  # frame index of _grown_last
        self._jump_last: dict = {}  # cluster identity -> its kept grown box last frame (grow_jump)
        self._jump_last_t = -1  # frame index of _jump_last
        self._last_fi = -1  # frame index of the last update
        self._split_child: dict = {}  # cluster identity -> (identity of its split part, time last split)
        self._apart: set = set()  # pairs (frozensets) of a cluster and its split part this frame
        self._child_feats: dict = {}  # split part's identity -> its features' identities last frame
        self._split_since: dict = {}  # cluster identity -> time its two groups were first seen (split_s)
        self._feat_child: dict = {}  # feature identity -> (split part's identity, time) (split_hand_over)
        self._hand_alias: dict = {}  # graph cluster -> the split part's identity it took (split_hand_over)
        self._app_img = None  # this frame's image (relink_appearance)
        self._app_prev_img = None  # the frame before's image
        self._lost_sig: dict = {}  # lost (or relinked) identity -> its appearance when last seen
        self._coast_end: dict = {}  # lost identity -> the time of the loss whose coast has ended (coast_s)
        # coast_retry_s: lost identity -> (time of its loss, time of the first of its coast's failed looks in a row)
        self._coast_fail: dict = {}
        self._coast_seen: dict = {}  # coast_edge_seen: identity -> (loss time, last time its coast was seen)
        self._coast_rep: dict = {}  # coast_dup_seen: identity -> (loss time, last time its coast was reported)
        # coast_edge_horizon: identity -> (loss time, its box bottom's px below the horizon, zoom, height) when last seen
        self._coast_rows: dict = {}
        self._joined_ids: set = set()  # identities of the clusters joined into another's report this frame
        self._joined_apart: set = set()  # merge_id_dv_px_s: those of them that move otherwise (not handed over)
        self._report_last: dict = {}  # merge_id_keep_iou: cluster identity -> its report's box (frame _report_last_t)
        self._report_last_t = -1
        # (time, identity, box, outcome) of each coast looked at (coast_s; the last 2000, for diagnosis);
        # outcome: "reported", "searched" (coast_search), "outside", "overlap", "contrast", "not found", "size",
        # "no image"
        self.coast_log: collections.deque = collections.deque(maxlen=2000)
        # (time, identity, cluster, its box, template part, level part, refused) of each pair the
        # appearance check looked at (relink_appearance; the last 1000, for diagnosis)
        self.relink_log: collections.deque = collections.deque(maxlen=1000)

    def reset(self) -> None:
        self.graph.reset()
        self.noise_px_s = float("nan")
        self.camera_err_px_s = float("nan")
        self._cam_still = True
        self._relink_reset()
        self._size_reset()

    def _wake_core_guard(self, snap, fi, cids, img, pre, cores, boxes, found, trail, sign_side, hints,
                         cores_retry):
        """Session 26 (H26, ``ClusterParams.wake_core_iou``): each cluster with a trailing side whose box
        grown with ``wake_core`` overlaps its grown box of the frame before (carried by the camera's
        motion) with IoU under ``wake_core_iou`` is grown again without ``wake_core`` (the reference
        of all the object's columns, or ``wake_front``'s); that box is kept where its IoU with the box
        before is higher.  Returns ``(boxes, found)``; stores this frame's grown boxes."""
        p = self.params
        last = self._wcore_last if self._wcore_last_t == self._cluster_boxes_now else {}
        cand = []
        if last:
            hmg = np.asarray(snap.homography, np.float64)
            fin = bool(np.all(np.isfinite(hmg)))
            for i, c in enumerate(cids):
                hb = last.get(int(c))
                if hb is None or trail[i] == 0 or not found[i]:
                    continue
                hb = _carry_box(hb, hmg) if fin else hb
                if _box_iou(boxes[i], hb) < p.wake_core_iou:
                    cand.append((i, hb))
        if cand:
            idx = np.array([i for i, _ in cand])
            redo, _, f2 = grow_boxes(
                img, pre[idx], cores[idx], grow=p.grow_box, peak_frac=p.grow_peak_frac, return_contrast=True,
                wide_grow_px=p.grow_wide_px, waterline_frac=p.waterline_frac, wake_frac=p.wake_frac,
                trail=trail[idx], top_frac=self._top_frac, cut_core_frac=p.cut_core_frac,
                cut_core_undo=p.cut_core_undo, wake_thick=p.wake_thick, sign_frac=p.grow_sign,
                sign_max_px=p.grow_sign_max_px, sign_side=None if sign_side is None else sign_side[idx],
                return_found=True, cover_wide=p.grow_cover_wide, hints=None if hints is None else hints[idx],
                hint_pad_px=p.grow_hint_pad_px, hint_core=p.grow_hint_core, hint_core_x=p.grow_hint_core_x,
                top_halo=p.top_halo_ir if self._ir else 0.0,
                cores_retry=None if cores_retry is None else cores_retry[idx], top_min_px=p.top_min_px,
                wake_core=0.0, wake_front=0.0 if (self._ir and not p.wake_track_ir) else p.wake_front)
            boxes, found = boxes.copy(), found.copy()
            for j, (i, hb) in enumerate(cand):
                if not (f2[j] and _box_iou(redo[j], hb) > _box_iou(boxes[i], hb)):
                    continue
                if p.wake_core_iou_cut > 0:
                    # the columns the cut took away (the regrown box's beyond the cut one) within the box before
                    a0, a1 = max(redo[j][0], hb[0]), min(redo[j][0] + redo[j][2], hb[0] + hb[2])
                    k0, k1 = max(boxes[i][0], a0), min(boxes[i][0] + boxes[i][2], a1)
                    gone = max(a1 - a0, 0.0) - max(k1 - k0, 0.0)
                    if gone < p.wake_core_iou_cut * max(hb[2], 1.0):
                        continue
                boxes[i] = redo[j]
        self._wcore_last = {int(c): boxes[i].copy() for i, c in enumerate(cids) if found[i]}
        self._wcore_last_t = fi
        return boxes, found

    def _track_vx(self, snap: FeatureSnapshot, cids: np.ndarray) -> np.ndarray:
        """Each cluster's box centre velocity along x (px/s) over the last ``params.wake_track_s``
        seconds, relative to the scene: the centres of its boxes grown in the frames before, each
        carried into this frame by the features' homographies, fitted by least squares; NaN where
        fewer than ``params.wake_track_n`` (at least 2) boxes of consecutive frames are kept (session
        26, H23).  The stored centres are carried here (once a frame)."""
        p = self.params
        t, fi = float(snap.t_s), int(snap.frame_index)
        out = np.full(len(cids), np.nan)
        if self._trk_hist_t != self._cluster_boxes_now or not self._trk_hist:
            self._trk_hist = {}
            return out
        hmg = np.asarray(getattr(snap, "homography", None) if getattr(snap, "homography", None) is not None
                         else np.eye(3), np.float64)
        fin = bool(np.all(np.isfinite(hmg)))
        keys = list(self._trk_hist.keys())
        rows = [np.asarray(self._trk_hist[c], np.float64) for c in keys]
        allr = np.concatenate(rows, axis=0)
        if fin and len(allr):
            q = allr[:, 1:3] @ hmg[:2, :2].T + hmg[:2, 2]
            w = allr[:, 1:3] @ hmg[2, :2] + hmg[2, 2]
            ok = np.abs(w) > 1e-12
            allr[ok, 1:3] = q[ok] / w[ok, None]
        keep = allr[:, 0] >= t - p.wake_track_s - 1e-9
        hist, j = {}, 0
        for c, rr in zip(keys, rows):
            seg = allr[j:j + len(rr)][keep[j:j + len(rr)]]
            j += len(rr)
            if len(seg):
                hist[c] = seg
        self._trk_hist = hist
        nmin = max(int(p.wake_track_n), 2)
        for i, c in enumerate(cids):
            seg = hist.get(int(c))
            if seg is None or len(seg) < nmin:
                continue
            tt = seg[:, 0] - seg[:, 0].mean()
            den = float(tt @ tt)
            if den > 0:
                out[i] = float(tt @ (seg[:, 1] - seg[:, 1].mean())) / den
        return out

    def _track_store(self, snap: FeatureSnapshot, cids: np.ndarray, boxes: np.ndarray) -> None:
        """Adds this frame's box centres (time, x, y) to each cluster's history (``wake_track_s``)."""
        t, fi = float(snap.t_s), int(snap.frame_index)
        if self._trk_hist_t != self._cluster_boxes_now:
            self._trk_hist = {}
        hist = {}
        for i, c in enumerate(cids):
            b = boxes[i]
            if not np.all(np.isfinite(b)):
                continue
            row = np.array([[t, b[0] + 0.5 * b[2], b[1] + 0.5 * b[3]]])
            old = self._trk_hist.get(int(c))
            hist[int(c)] = row if old is None else np.concatenate([np.asarray(old, np.float64), row], axis=0)
        self._trk_hist = hist
        self._trk_hist_t = fi

    def _size_filter(self, snap: FeatureSnapshot, cids: np.ndarray, boxes: np.ndarray,
                     grown: np.ndarray | None = None) -> np.ndarray:
        """Each cluster's box held to the size it had over the last ``params.size_filter_s``
        seconds (not in the paper; session 19): where the box is wider (taller) than
        ``size_filter_k`` times the median width (height) of the cluster's boxes in that time, it
        is cut to that median width (height), keeping the edge that moved less since the
        cluster's box of the frame before (carried by the camera motion); without that box, the
        box keeps its centre.  The sizes are compared at one scale (the camera's zoom is followed
        through the features' homographies); the history holds the boxes as measured (before the
        filter), so a real change of size (a boat coming nearer) is followed after about half the
        time.  At least ``size_filter_min_n`` boxes must be in the history.  A box grown over a
        wake, a reflection or the coast in a few frames goes back to the boat's size.  With
        ``size_filter_width`` (``size_filter_height``) False the width (height) is not held.  ``grown`` (bool per box, with
        ``size_filter_grown``): only the boxes that the growing reached the object with are
        held and enter the history (a box left at its features' extent, where the growing found
        nothing, is neither cut nor a reference)."""
        p = self.params
        t, fi = float(snap.t_s), int(snap.frame_index)
        hmg = np.asarray(getattr(snap, "homography", np.full((3, 3), np.nan)), np.float64)
        ok_h = hmg.shape == (3, 3) and bool(np.all(np.isfinite(hmg)))
        if ok_h:
            det = abs(float(np.linalg.det(hmg[:2, :2])))
            if det > 0:
                self._size_scale *= float(np.sqrt(det))
        if not np.isfinite(self._size_scale) or self._size_scale <= 0:
            self._size_scale = 1.0
            self._size_hist = {}
        sc = self._size_scale
        last = self._size_last if (self._size_fi >= 0 and 0 < fi - self._size_fi <= 2) else {}
        out = np.array(boxes, np.float64, copy=True)
        new_last = {}
        for i, c in enumerate(np.asarray(cids).tolist()):
            x, y, w, h = out[i]
            hist = self._size_hist.get(c)
            if hist is None:
                hist = self._size_hist[c] = collections.deque()
            while hist and hist[0][0] < t - p.size_filter_s:
                hist.popleft()
            use = grown is None or bool(grown[i])
            if use and len(hist) >= p.size_filter_min_n and np.isfinite(w) and np.isfinite(h):
                arr = np.asarray(hist, np.float64)
                mw, mh = float(np.median(arr[:, 1])) * sc, float(np.median(arr[:, 2])) * sc
                lb = last.get(c)
                if lb is not None and ok_h:
                    lb = _carry_box(lb, hmg)
                nx0, ny0, nx1, ny1 = x, y, x + w, y + h
                if p.size_filter_width and w > p.size_filter_k * mw:
                    nx0, nx1 = _keep_edge(nx0, nx1, mw, None if lb is None else (lb[0], lb[0] + lb[2]))
                if p.size_filter_height and h > p.size_filter_k * mh:
                    ny0, ny1 = _keep_edge(ny0, ny1, mh, None if lb is None else (lb[1], lb[1] + lb[3]))
                out[i] = (nx0, ny0, nx1 - nx0, ny1 - ny0)
            if use and np.isfinite(w) and np.isfinite(h):
                hist.append((t, w / sc, h / sc))
            new_last[c] = out[i].copy()
        # forget the clusters not seen within the filter's time
        for c in [c for c, hq in self._size_hist.items() if not hq or hq[-1][0] < t - p.size_filter_s]:
            del self._size_hist[c]
        self._size_last = new_last
        self._size_fi = fi
        return out

    def _disp_members(self, snap: FeatureSnapshot, m: np.ndarray, k: np.ndarray, n: int,
                      inb: np.ndarray | None) -> np.ndarray:
        """Members (``m`` the snapshot's features in a cluster, ``k`` their cluster index) that
        moved with their cluster over the last ``params.box_disp_s`` seconds (not in the paper;
        session 19).  Each feature's position is followed in the scene (the image positions carried
        back to the first frame through the features' homographies); its displacement over that
        time is compared with the median displacement of its cluster's box members (``inb``, or all
        members): where that median is at least ``box_disp_min_px`` long, a member whose
        displacement along it is under ``box_disp_frac`` of it stays out of the box, unless fewer
        than two would be left.  Foam of a wake and a coast stay where they are while the boat's
        features move on, however slowly (their velocities over 0.6 s are too noisy to tell).
        With ``box_disp_q`` > 0 the reference is the median displacement of the members left
        when that fraction of them, the ones that moved least, is set aside (a cluster holding
        more foam features than boat features).  With ``box_disp_two`` (session 22) a cluster whose
        box has only two such members is judged too: the reference is the longer displacement of the
        two, and the member that stayed behind leaves the box though one member is left (a small
        boat's one hull feature and one foam feature of its wake: their median is halfway).  With
        ``box_disp_two_wake_px`` > 0 (session 23) that member leaves only when it lies behind the
        other (against the other's displacement) and at most that many pixels (times the zoom)
        above it: a wake's foam, not a feature of another boat or of a long hull's other end.  With
        ``box_disp_two_anchor`` a pair that is not a wake keeps the member lying inside the
        cluster's box of the frame before (``box_keep_last``'s anchor) when only one of them does
        (the one that moved leaves when the box was on the other); otherwise both stay.  With
        ``box_disp_two_far_h`` > 0 only when the member outside lies more than that many times the
        box's height outside it (another object; a member just outside a boat's box stays)."""
        p = self.params
        t, fi = float(snap.t_s), int(snap.frame_index)
        hmg = np.asarray(getattr(snap, "homography", np.full((3, 3), np.nan)), np.float64)
        ok_h = hmg.shape == (3, 3) and bool(np.all(np.isfinite(hmg)))
        if ok_h and self._disp_fi >= 0 and fi == self._disp_fi + 1:
            try:
                self._disp_c = self._disp_c @ np.linalg.inv(hmg)
            except np.linalg.LinAlgError:
                ok_h = False
        if not ok_h or self._disp_fi < 0 or fi != self._disp_fi + 1 or not np.all(np.isfinite(self._disp_c)):
            self._disp_c = np.eye(3)  # a new reference: nothing to compare with yet
            self._disp_ring.clear()
        self._disp_fi = fi
        c = self._disp_c
        xy = np.asarray(snap.xy, np.float64)
        hw = xy @ c[2, :2] + c[2, 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            sp = (xy @ c[:2, :2].T + c[:2, 2]) / hw[:, None]
        slots = np.asarray(snap.slots, np.int64)
        ids = np.asarray(snap.ids, np.int64)
        ring = self._disp_ring
        ring.append((t, slots, ids, sp))
        while len(ring) > 1 and ring[1][0] <= t - p.box_disp_s:
            ring.popleft()
        keep = np.ones(int(m.sum()), bool)
        t0, s0, i0, p0 = ring[0]
        if t - t0 < 0.5 * p.box_disp_s or len(slots) == 0:
            return keep
        size = int(max(slots.max(), s0.max() if len(s0) else 0)) + 1
        old = np.full((size, 2), np.nan)
        old_id = np.full(size, -1, np.int64)
        old[s0] = p0
        old_id[s0] = i0
        d = sp - old[slots]
        d[old_id[slots] != ids] = np.nan
        dm = d[m]
        sel = np.ones(len(k), bool) if inb is None else inb
        okd = np.isfinite(dm).all(axis=1)
        for c_ in np.unique(k[sel & okd]):
            mem = np.flatnonzero((k == c_) & sel & okd)
            two = len(mem) == 2 and p.box_disp_two
            if len(mem) < 3 and not two:
                continue
            ref = mem
            if two:  # the one that moved farther is the boat's
                ln = np.hypot(dm[mem, 0], dm[mem, 1])
                ref = mem[[int(np.argmax(ln))]]
            elif p.box_disp_q > 0:  # the median of the members that moved farthest
                ln = np.hypot(dm[mem, 0], dm[mem, 1])
                ref = mem[np.argsort(ln, kind="stable")[int(np.floor(p.box_disp_q * len(mem))):]]
            med = np.array([_median_of(dm[ref, 0]), _median_of(dm[ref, 1])])  # np.median's values
            L = float(np.hypot(*med))
            if L < p.box_disp_min_px:
                continue
            along = dm[mem] @ (med / L)
            out = along < p.box_disp_frac * L
            if two and p.box_disp_two_wake_px > 0 and out.any() and not out.all():
                # session 23: only foam of the boat's wake leaves: behind the moving member, not above it
                xym = np.asarray(snap.xy, np.float64)[m]
                a, b = mem[~out][0], mem[out][0]
                rel = xym[b] - xym[a]
                if not (rel @ med < 0 and rel[1] >= -p.box_disp_two_wake_px * self._zoom):
                    anc = self._disp_anchor if p.box_disp_two_anchor else None
                    if anc is None or bool(anc[a]) == bool(anc[b]):
                        continue  # not a wake: both stay
                    if p.box_disp_two_far_h > 0:
                        # only a member well outside the box (another object) leaves
                        gh = self._anchor_gap_h
                        if gh is None or len(gh) != len(anc) or not gh[b if anc[a] else a] > p.box_disp_two_far_h:
                            continue
                    if anc[b]:  # the box was on the member that stayed behind: the one that moved leaves
                        keep[a] = False
                        continue
                    # the box was on the one that moved: the other leaves, as without this rule
            if len(mem) - int(out.sum()) >= (1 if two else 2):
                keep[mem[out]] = False
        return keep

    def _wake_below_members(self, k, xy, n, inb, fv, below_px):
        """The box members (``inb``, None: all) without the wake's foam (not in the paper; session 24,
        ``params.box_wake_below_px``, on infrared frames ``box_wake_below_px_ir``; ``below_px`` the
        one of this frame): in a cluster whose box members move across the image (their
        mean velocity relative to the scene, ``fv`` per member, at least ``params.wake_min_px_s``
        along x), the front member is the one farthest in the direction of motion; a member lying
        more than ``below_px`` (times the zoom) below the front one leaves the box.  With
        ``params.box_wake_top`` the reference is the topmost box member instead (the foam may lie
        ahead of the hull, a bow wave, or level with it).  Only in clusters whose box members span
        at most ``params.box_wake_max_h_px`` (times the zoom; 0: any) vertically (a small boat: a ship's hull features lie far below its bow).  A small
        boat's foam trails behind it on the water, below the hull's features (sim ``pan``'s rib:
        foam members 5-7 px below the hull's that move with it; boxes 2-3 times the boat's area)."""
        p = self.params
        sel = np.ones(len(k), bool) if inb is None else np.asarray(inb, bool).copy()
        idx = np.flatnonzero(sel)
        if len(idx) < 2:
            return sel
        kb, xb, yb = k[idx], xy[idx, 0], xy[idx, 1]
        v = fv[idx, 0]
        okv = np.isfinite(v)
        vx = np.zeros(n)
        np.add.at(vx, kb[okv], v[okv])
        cnt = np.bincount(kb[okv], minlength=n)
        vx /= np.maximum(cnt, 1)
        moving = (cnt > 0) & (np.abs(vx) >= p.wake_min_px_s)
        if not moving[kb].any():
            return sel
        z = self._zoom
        ylo = np.full(n, np.inf)
        yhi = np.full(n, -np.inf)
        np.minimum.at(ylo, kb, yb)
        np.maximum.at(yhi, kb, yb)
        small = (yhi - ylo <= p.box_wake_max_h_px * z) if p.box_wake_max_h_px > 0 else np.ones(n, bool)
        if p.box_wake_top:
            fy = ylo  # the topmost member
        else:
            # each cluster's front member: the largest position along its motion
            proj = np.sign(vx)[kb] * xb
            o = np.lexsort((-proj, kb))
            first = np.ones(len(o), bool)
            first[1:] = kb[o][1:] != kb[o][:-1]
            fy = np.full(n, np.nan)
            fy[kb[o][first]] = yb[o][first]
        out = moving[kb] & small[kb] & (yb > fy[kb] + below_px * z)
        sel[idx[out]] = False
        return sel

    def _box_anchor(self, snap, cids, k, xy):
        """Members (``k``: their cluster index into ``cids``, ``xy`` positions) that lie inside
        their cluster's box of the last frame carried into this one by the camera motion (with
        ``params.box_keep_last``, see :func:`_box_members`); None when no cluster has one."""
        last = self._cluster_boxes
        if not last or self._cluster_boxes_t != self._cluster_boxes_now:
            return None
        nan4 = (np.nan,) * 4
        lb = np.array([last.get(int(c), nan4) for c in cids], np.float64).reshape(-1, 4)
        self._anchor_cids = np.asarray(cids, np.int64)
        h = np.asarray(snap.homography, np.float64)
        if np.all(np.isfinite(h)):  # carried by the camera motion (both corners)
            c = np.concatenate([lb[:, :2], lb[:, :2] + lb[:, 2:]], axis=0)
            q = c @ h[:2, :2].T + h[:2, 2]
            w = c @ h[2, :2] + h[2, 2]
            with np.errstate(invalid="ignore", divide="ignore"):
                q = q / w[:, None]
            n = len(lb)
            ok = np.abs(w[:n]) > 1e-12
            ok &= np.abs(w[n:]) > 1e-12
            lb = np.where(ok[:, None], np.concatenate([q[:n], q[n:] - q[:n]], axis=1), lb)
        bb = lb[k]
        with np.errstate(invalid="ignore"):
            inside = ((xy[:, 0] >= bb[:, 0]) & (xy[:, 0] <= bb[:, 0] + bb[:, 2])
                      & (xy[:, 1] >= bb[:, 1]) & (xy[:, 1] <= bb[:, 1] + bb[:, 3]))
            if self.params.box_disp_two_far_h > 0 or (self._ir and self.params.box_anchor_far_h_ir > 0):
                # each member's distance outside that box, in its heights
                gx = np.maximum(np.maximum(bb[:, 0] - xy[:, 0], xy[:, 0] - bb[:, 0] - bb[:, 2]), 0.0)
                gy = np.maximum(np.maximum(bb[:, 1] - xy[:, 1], xy[:, 1] - bb[:, 1] - bb[:, 3]), 0.0)
                self._anchor_gap_h = np.maximum(gx, gy) / np.maximum(bb[:, 3], 1.0)
                self._anchor_h = np.maximum(np.minimum(bb[:, 2], bb[:, 3]), 1.0)
        return inside if inside.any() else None

    def _anchor_far_out(self, k, n, inb, anchor, far_h, x=None, cids=None):
        """``box_anchor_far_h_ir`` (session 30, h36): the box members (``inb``, ``k`` their cluster
        index, ``n`` clusters) lying more than ``far_h`` times their cluster's last box height outside
        that box (``self._anchor_gap_h``, made by :meth:`_box_anchor`) leave the box, in the clusters
        with at least two box members inside that box (``anchor``)."""
        gh = self._anchor_gap_h
        if gh is None or len(gh) != len(inb):
            return inb
        with np.errstate(invalid="ignore"):
            far = inb & ~anchor & (gh > far_h)
        if not far.any():
            return inb
        near_h = self.params.box_anchor_near_h_ir
        if near_h > 0:  # session 31 (h44): members just outside the anchor box count as inside it
            with np.errstate(invalid="ignore"):
                near = inb & (anchor | (gh <= min(near_h, far_h)))
            n_in = np.bincount(k[near], minlength=n)
        else:
            n_in = np.bincount(k[inb & anchor], minlength=n)
        ok = n_in >= 2
        apart = None
        if self.params.box_anchor_far_minority_ir:  # only a minority of the box members leaves
            two = n_in >= (1 if self.params.box_anchor_gap_one_ir else 2)
            if self.params.box_anchor_gap_steady_ir and self._anchor_cids is not None:
                two = two & np.isin(self._anchor_cids, np.fromiter(self._cluster_steady, np.int64, len(self._cluster_steady)))
            minority = np.bincount(k[far], minlength=n) < n_in
            gap_gh = self.params.box_anchor_far_gap_h_ir
            if gap_gh > 0 and cids is not None and self._grown_last \
                    and self._grown_last_t == self._cluster_boxes_now:
                # session 32 (h46): or a group apart, its nearest member gap_gh heights out, where the
                # anchor box was grown (the grower found the boat there, not a few members' box)
                g_min = np.full(n, np.inf)
                np.minimum.at(g_min, k[far], gh[far])
                grown = np.array([int(c) in self._grown_last for c in cids], bool)
                minority |= grown & (g_min > gap_gh)
            ok = ok & minority
            gap_h = self.params.box_anchor_gap_side_ir
            if gap_h > 0 and x is not None and (two & ~ok).any() and self._anchor_h is not None:
                # session 32 (h47): far members beyond an x gap from the near ones leave all the same
                apart = self._apart_x(k, n, inb, near if near_h > 0 else inb & anchor, x, gap_h) & two[k]
        far &= ok[k] if apart is None else (ok[k] | apart)
        return inb & ~far

    def _apart_x(self, k, n, inb, near, x, gap_h):
        """``box_anchor_gap_side_ir`` (session 32, h47): the box members (``inb``) not joined to their cluster's
        ``near`` members by a chain of the cluster's box members sorted by x, each step at most ``gap_h`` times
        the anchor box's smaller side (``self._anchor_h``); arrays only (one sort)."""
        ib = np.flatnonzero(inb)
        out = np.zeros(len(inb), bool)
        if len(ib) == 0:
            return out
        kb = k[ib]
        xb = np.asarray(x, np.float64)[ib]
        o = np.lexsort((xb, kb))
        ks, xs = kb[o], xb[o]
        hs = self._anchor_h[ib][o]
        brk = np.ones(len(o), bool)
        with np.errstate(invalid="ignore"):
            brk[1:] = (ks[1:] != ks[:-1]) | ~(np.diff(xs) <= gap_h * hs[1:])
        seg = np.cumsum(brk) - 1
        has = np.bincount(seg, weights=near[ib][o].astype(np.float64), minlength=int(seg[-1]) + 1) > 0
        out[ib[o]] = ~has[seg]
        return out

    def _split_for_report(self, snap: FeatureSnapshot, labels: np.ndarray, cids: np.ndarray):
        """``params.split_dv_px_s``: the members of a cluster that move apart from the part
        around its box's anchor (two groups of clearly different velocity relative to the scene)
        are labelled as a cluster of their own, for the reports only (the affinity graph keeps
        them together).  The anchored part keeps the cluster's identity; the other part takes the
        identity it had the last time this cluster split (within ``label_memory_s``), or a new one.
        Returns the labels and the sorted identities with the split parts.

        The two groups are found for all clusters at once, in compiled code (see
        :func:`_split_groups`); only the clusters that split go through a Python loop."""
        p = self.params
        t = float(snap.t_s)
        m = np.flatnonzero(labels >= 0)
        k = np.searchsorted(cids, labels[m])
        anchor = None
        if p.box_keep_last:
            self._cluster_boxes_now = self._last_fi  # as in _outputs (the frame before this one)
            anchor = self._box_anchor(snap, cids, k, snap.xy[m])
        if anchor is None:
            anchor = np.zeros(len(m), bool)
        dv, need = float(p.split_dv_px_s), max(2, int(p.split_min_features))
        ok, code = _split_groups(np.asarray(snap.history, np.float64), m, k, len(cids), anchor, dv, need)
        labels = labels.copy()
        new = []
        seen: set = set()
        child_feats: dict = {}
        for c in np.flatnonzero(ok).tolist():
            cid = int(cids[c])
            seen.add(cid)
            since = self._split_since.setdefault(cid, t)
            if t - since < p.split_s - 1e-9:
                continue
            prev = self._split_child.get(cid)
            if prev is not None and t - prev[1] <= max(p.label_memory_s, p.split_memory_s) + 1e-9:
                child = prev[0]
            else:
                child = int(self.graph.next_id)
                self.graph.next_id += 1
            mine = k == c
            part = m[mine & (code == 2)]  # indices into the snapshot
            if p.split_keep_parts and prev is not None and child == prev[0]:
                near = m[mine & (code == 1)]
                was = self._child_feats.get(child, set())
                if sum(x in was for x in snap.ids[near].tolist()) > sum(x in was for x in snap.ids[part].tolist()):
                    part = near  # the anchored group was the split part: it stays so
            self._split_child[cid] = (child, t)
            labels[part] = child
            child_feats[child] = set(snap.ids[part].tolist())
            new.append(child)
            self._apart.add(frozenset((cid, child)))
        self._split_since = {c: v for c, v in self._split_since.items() if c in seen}
        self._child_feats = child_feats
        changed = bool(new)
        if p.split_hand_over:
            labels, handed = self._hand_over_split(snap, labels, cids, new, t)
            changed = changed or handed
        if len(self._split_child) > 64:
            self._split_child = {a: b for a, b in self._split_child.items()
                                 if t - b[1] <= max(p.label_memory_s, p.split_memory_s)}
        if changed:  # otherwise the identities are the graph's (each holds a member)
            cids = np.unique(labels[labels >= 0]).astype(np.int64)
        return labels, cids

    def _hand_over_split(self, snap, labels, cids, new, t):
        """``params.split_hand_over``: a cluster born in the graph this frame whose features were
        mostly a split part's takes that part's identity (when no cluster reports it now), and
        keeps it while the graph keeps the cluster; then remembers the split parts' features.
        Returns the labels and whether any changed."""
        p = self.params
        fc = self._feat_child
        alias = self._hand_alias
        cl = cids.tolist()
        live = set(cl)
        self._hand_alias = alias = {c: a for c, a in alias.items() if c in live}
        used = (live - set(alias)) | set(alias.values()) | set(new)
        changed = False
        birth = self.graph.birth_s
        for c in cl:
            if c in alias:
                labels[labels == c] = alias[c]
                changed = True
                continue
            if birth.get(c, -1.0) != t:
                continue
            mem = np.flatnonzero(labels == c)
            votes: dict = {}
            for fid in snap.ids[mem].tolist():
                e = fc.get(fid)
                if e is not None and t - e[1] <= p.label_memory_s + 1e-9:
                    votes[e[0]] = votes.get(e[0], 0) + 1
            if not votes:
                continue
            child, nv = max(votes.items(), key=lambda kv: kv[1])
            if 2 * nv >= len(mem) and child not in used:
                labels[mem] = child
                changed = True
                alias[c] = child
                used.discard(c)
                used.add(child)
        for child in set(new) | set(alias.values()):
            fc.update(dict.fromkeys(snap.ids[labels == child].tolist(), (child, t)))
        if len(fc) > 4096:
            self._feat_child = {a: b for a, b in fc.items() if t - b[1] <= p.label_memory_s}
        return labels, changed

    def _sticky_pairs(self, snap, labels, cids, boxes) -> set:
        """Clusters reported as one object in the last frame stay one while each box lies, by at
        least ``merge_keep`` of its area, inside that report's box carried into this frame by the
        camera motion (not in the paper: two clusters on one long hull at full zoom, whose grown
        boxes overlap in one frame and not in the next, would otherwise be one report and then
        two, the identity going back and forth between them).  A cluster belongs to a last
        frame's report when at least a quarter of its current features were in it (cluster
        identities change as the clusters merge and split).  Only the frame just before counts:
        reports made more than 1.5 typical frame intervals back (the median of the last nine)
        are dropped.  The pairs found here stay joined only while their boxes of this frame
        still touch (``merge_keep_gap_px``, see :func:`_merge_overlapping`)."""
        out = set()
        if not self._merged or len(cids) < 2:
            return out
        if self._dts and not snap.t_s - self._merged_t <= 1.5 * float(np.median(self._dts)) + 1e-9:
            self._merged = []  # stale: not made in the frame just before
            return out
        h = np.asarray(snap.homography, np.float64)
        for fids, pb in self._merged:
            here = []
            for i, c in enumerate(cids):
                f = snap.ids[labels == c]
                if len(f) and np.isin(f, fids).sum() * 4 >= len(f):
                    here.append(i)
            if len(here) < 2:
                continue
            if np.all(np.isfinite(h)):
                c = h @ np.array([pb[0], pb[1], 1.0]), h @ np.array([pb[0] + pb[2], pb[1] + pb[3], 1.0])
                if abs(c[0][2]) > 1e-12 and abs(c[1][2]) > 1e-12:
                    x0, y0 = c[0][:2] / c[0][2]
                    x1, y1 = c[1][:2] / c[1][2]
                    pb = np.array([x0, y0, x1 - x0, y1 - y0])
            inside = []
            for i in here:
                b = boxes[i]
                iw = min(b[0] + b[2], pb[0] + pb[2]) - max(b[0], pb[0])
                ih = min(b[1] + b[3], pb[1] + pb[3]) - max(b[1], pb[1])
                if iw > 0 and ih > 0 and iw * ih >= self.params.merge_keep * b[2] * b[3]:
                    inside.append(int(cids[i]))
            out.update(frozenset((a, b)) for k, a in enumerate(inside) for b in inside[k + 1:])
        return out

    def _side_h_ok(self, hw, hb: float) -> bool:
        """``relink_side_h_ratio`` (and ``relink_side_h_up``): whether a new cluster ``hb`` px high passes
        against the heights ``hw`` ([(height, zoom)]) of a lost identity."""
        p = self.params
        he = float(np.median([hh_ * self._zoom / max(z_, 1e-6) for hh_, z_ in hw]))
        if max(hb, he) > p.relink_side_h_ratio * max(min(hb, he), 1.0):
            return False
        if p.relink_side_h_up > 0 and hb > p.relink_side_h_up * max(he, 1.0):
            return False  # session 24 (H9): a new cluster is a part of its boat, rarely more
        return True

    @staticmethod
    def _beside_old(bi: np.ndarray, o: np.ndarray, px: float) -> bool:
        """``relink_side_app_near_alone_px``: whether box ``bi`` lies within ``px`` (box edge to box edge) of
        one of the boxes ``o`` (n x 4)."""
        if len(o) == 0:
            return False
        bi = np.asarray(bi, np.float64)
        g = np.maximum(np.abs((bi[:2] + 0.5 * bi[2:]) - (o[:, :2] + 0.5 * o[:, 2:])) - 0.5 * (bi[2:] + o[:, 2:]), 0.0)
        return bool(np.any(np.hypot(g[:, 0], g[:, 1]) <= px))

    def _relink(self, snap: FeatureSnapshot, cids: np.ndarray, boxes: np.ndarray,
                vel: np.ndarray | None = None) -> np.ndarray:
        """Reported identities of this frame's clusters: a cluster born within ``relink_s`` of
        the loss of a reported identity, where that identity's last box lies within
        ``relink_px + relink_px_per_s * (time lost) * zoom`` (or overlaps), takes that identity,
        nearest pairs first (not in the paper: a boat whose features drop out, or that leaves
        the view during a pan, keeps its identity).  The lost box is carried by the camera's
        motion (the snapshots' homographies) or, with a camera model (``update(camera=...)``),
        by projecting the directions of its corners through this frame's camera; with
        ``relink_predict`` it also moves on with the object's own last velocity for
        ``relink_predict_s``.  When an identity is lost while a younger cluster overlaps its
        last box by ``relink_overlap`` of the smaller box, that cluster takes it
        (:meth:`_hand_over`)."""
        self._hold = set()  # relink_hold_s: identities held tentative this frame
        p = self.params
        t = snap.t_s
        dt = float(getattr(snap, "dt_s", p.frame_interval_s))
        h = np.asarray(snap.homography, np.float64)
        sc = float(np.sqrt(abs(np.linalg.det(h[:2, :2])))) if np.all(np.isfinite(h)) else 1.0

        def carry(b, v=None):
            c = np.array([b[0] + 0.5 * b[2], b[1] + 0.5 * b[3], 1.0])
            q = h @ c
            if not np.all(np.isfinite(q)) or abs(q[2]) < 1e-12:
                return b
            w, hh = b[2] * sc, b[3] * sc
            out = np.array([q[0] / q[2] - 0.5 * w, q[1] / q[2] - 0.5 * hh, w, hh])
            if v is not None and p.relink_predict:
                out[:2] += v * dt
            return out

        def gap_px(b, lb):
            """Distance between two boxes' edges (0 when they overlap)."""
            g = np.maximum(np.abs((b[:2] + 0.5 * b[2:]) - (lb[:2] + 0.5 * lb[2:])) - 0.5 * (b[2:] + lb[2:]), 0.0)
            return float(np.hypot(*g))

        # lost identities follow the camera (and, for relink_predict_s, their own last velocity);
        # with the camera model, their directions are projected through this frame's camera
        fcam = self._camera if p.relink_camera else None

        side_pred_on = p.relink_predict_side_s > 0 and (p.relink_predict_side_ir or not self._ir)

        def expect(lost, dirs):
            kept = {}
            for k, (tl, b, v) in lost.items():
                if t - tl > p.relink_s:
                    dirs.pop(k, None)
                    continue
                d = dirs.get(k) if fcam is not None else None
                nb_ = None
                if d is not None:
                    el_s = min(t - tl, p.relink_predict_s) if p.relink_predict else 0.0
                    u, w_, ok = fcam.azel_to_pixel(d[0] + d[2] * el_s, d[1] + d[3] * el_s)
                    if np.all(ok) and np.all(np.isfinite(u)) and np.all(np.isfinite(w_)):
                        nb_ = np.array([min(u), min(w_), abs(u[1] - u[0]), abs(w_[1] - w_[0])])
                kept[k] = (tl, nb_ if nb_ is not None else carry(b, v if t - tl <= p.relink_predict_s else None), v)
            return kept

        self._lost = expect(self._lost, self._lost_dir)
        if self._lost_alt:  # relink_alt_s: the places expected before a relink undone late
            self._lost_alt = {k: e for k, e in expect(self._lost_alt, self._lost_alt_dir).items() if k in self._lost}
        rep = np.array([self._alias.get(int(c), int(c)) for c in cids], np.int64)
        new = [i for i, c in enumerate(cids) if int(c) not in self._known]
        if p.relink_young_s > 0:  # session 24: each cluster's time of birth
            for i in new:
                self._born.setdefault(int(cids[i]), t)
            if len(self._born) > 4 * max(len(cids), 16):  # bounded memory
                keep = p.relink_young_s + max(p.relink_young_after_s, 0.0) + 1.0  # (a lost identity's birth, too)
                self._born = {k: tb for k, tb in self._born.items() if t - tb <= keep}
        if p.split_follow_box > 0 and new and self._prev_boxes:
            # session 23: a box that jumps away while a new cluster is born on it: the identity stays with the box
            for i in range(len(cids)):
                r = int(rep[i])
                if int(cids[i]) not in self._known or r not in self._prev_boxes:
                    continue
                lb = carry(self._prev_boxes[r])
                if _iou(boxes[i], lb) >= 0.1:
                    continue
                best, best_o = -1, p.split_follow_box
                for j in new:
                    o = _iou(boxes[j], lb)
                    if o >= best_o:
                        best, best_o = j, o
                if best < 0:
                    continue
                nid = int(self.graph.next_id)
                self.graph.next_id += 1
                self._alias[int(cids[best])] = r
                rep[best] = r
                self._alias[int(cids[i])] = nid
                rep[i] = nid
                new.remove(best)
                self._swapped.add(nid)
        if p.relink_jump_iou > 0 and self._prev_boxes and self._lost:
            self._jump_lost(carry, cids, boxes, rep, t)
        if p.relink_jump_back_iou_ir > 0 and self._ir and len(self._lost) > 1:
            self._jump_back(cids, boxes, rep, t)
        present = set(int(r) for r in rep)
        if p.relink_alt_memory and p.relink_alt_s > 0:  # lost identities back through the label memory
            for k in present:
                if k in self._lost and k not in self._returned:
                    self._returned[k] = t
        own_v = self._own_velocity(h, boxes, vel, dt)  # each cluster's own velocity (px/s), the camera's speed
        own_v, cam_s = (None, None) if own_v is None else own_v
        # for the velocity checks (relink_dv_px_s, hand_over_dv_px_s): NaN where no member has a velocity
        own_k = None if own_v is None else np.where(np.all(np.asarray(vel) == 0, axis=1)[:, None], np.nan, own_v)
        # new clusters take lost identities, nearest pairs first, within a gate that grows with
        # the time lost (relink_px + relink_px_per_s per second)
        pairs = []
        sig_new = {}  # new cluster -> its appearance (relink_appearance), computed when needed
        # relink_view_px: the image's size (width, height), None when off or unknown
        view_wh = (None if p.relink_view_px <= 0 or getattr(snap, "shape", None) is None
                   else (float(snap.shape[1]), float(snap.shape[0])))
        retry = set()
        retry_on = p.relink_retry_s > 0 and (p.relink_retry_ir or not self._ir)
        # session 27 (h29): young clusters under their own identity, not yet confirmed (h31: relink_retry_ir)
        if retry_on:
            seen = set(new)
            retry = {i for i in range(len(cids)) if i not in seen and int(rep[i]) == int(cids[i])
                     and t - self._birth.get(int(cids[i]), -np.inf) < p.relink_retry_s - 1e-9}
        far_new = self._far_side(boxes) if (new or retry) else None  # far_id_px: each cluster in the far strip
        app_d = {}  # relink_app_margin: (new cluster, lost identity) -> appearance distance, where known
        size_ref = set()  # relink_hold_s: clusters within the gate of a lost identity in view
        side_row = {}  # relink_side_row_margin: (new cluster, lost identity lost at the side) -> its row key at the loss
        side_row_on = p.relink_side_row_margin > 0 and (p.relink_side_row_ir or not self._ir)
        side_app_on = p.relink_side_app_near_px > 0 and (p.relink_side_app_near_ir or not self._ir)
        side_pred = {}  # relink_predict_side_s: lost identity -> its predicted box this frame (None: none)
        beside_old = {}  # relink_side_app_near_alone_px: new cluster -> whether it lies beside a known cluster
        old_boxes = None  # relink_side_app_near_alone_px: the boxes of the boats in view
        block_on = p.relink_shape_block_s_ir > 0 and self._ir
        shape_min_on = p.relink_shape_min_n_ir > 0 and self._ir
        blocked = set()  # relink_shape_block_s_ir: new clusters that cover a just-lost identity refused by shape
        block_ks = {}  # relink_shape_block_s_ir: blocked new cluster -> the identities it covered
        waiting = {}  # relink_shape_block_s_ir: a cluster blocked before, under its own identity -> those identities
        if block_on and self._shape_wait:
            self._shape_wait = {c: e for c, e in self._shape_wait.items()
                                if t - e[0] <= p.relink_shape_block_s_ir + 1e-9}
            seen_ = set(new) | set(retry)
            for i in range(len(cids)):
                c = int(cids[i])
                if i not in seen_ and c in self._shape_wait and int(rep[i]) == c:
                    waiting[i] = self._shape_wait[c][1]
        near_ref_px = (p.relink_near_refused_px * self._zoom
                       if p.relink_near_refused_px > 0 and (p.relink_near_refused_ir or not self._ir) else 0.0)
        near_ks = {}  # relink_near_refused_px: new cluster -> the lost identities expected within the gap
        near_out = set()  # relink_near_refused_far_out: pairs whose expected box is not wholly beyond a side edge
        img_w = float(snap.shape[1]) if getattr(snap, "shape", None) is not None else None
        for i in list(new) + sorted(retry) + sorted(waiting):
            for k, (tl, lb, vl) in self._lost.items():
                if k in present:
                    continue
                if i in waiting and k not in waiting[i]:
                    continue  # relink_shape_block_s_ir: only the identities it covered when blocked
                if i in retry and tl > self._birth[int(cids[i])] + 1e-9:
                    continue  # relink_retry_s: only an identity lost before the young cluster was first seen
                d = gap_px(boxes[i], lb)
                rate = p.relink_px_per_s
                if p.relink_own_speed_k > 0 and vl is not None and np.all(np.isfinite(vl)):
                    # session 24 (H12): a slow boat's gate grows with its own last speed, not the default rate
                    rate = min(rate, max(p.relink_own_speed_floor, p.relink_own_speed_k * float(np.hypot(*vl))))
                gate = p.relink_px + rate * (t - tl) * self._zoom
                if side_pred_on and d > gate and k in self._lost_fit and (k in self._lost_side or k in self._lost_near):
                    # relink_predict_side_s (session 30, h39): or where its own fitted azimuth rate took it
                    if k not in side_pred:
                        side_pred[k] = self._side_pred_box(k, tl, t, fcam)
                    if side_pred[k] is not None:
                        d_pr = gap_px(boxes[i], side_pred[k])
                        if d_pr <= gate:
                            d, lb = d_pr, side_pred[k]
                alt = self._lost_alt.get(k)
                if alt is not None and d > gate:  # relink_alt_s: or where it was expected before a relink undone late
                    d_alt = gap_px(boxes[i], alt[1])
                    if d_alt <= p.relink_px + p.relink_px_per_s * (t - alt[0]) * self._zoom:
                        d, gate, lb = d_alt, np.inf, alt[1]
                if view_wh is not None and not self._in_view(k, lb, view_wh):
                    continue  # session 22: its boat is out of the view
                if near_ref_px > 0 and d <= near_ref_px:
                    near_ks.setdefault(i, set()).add(k)  # relink_near_refused_px: expected right here
                if (near_ref_px > 0 and p.relink_near_refused_far_out and img_w is not None
                        and lb[0] + lb[2] > 0 and lb[0] < img_w):
                    near_out.add((i, k))  # relink_near_refused_far_out: not beyond a side edge (kept)
                if p.relink_hold_s > 0 and d <= gate:
                    size_ref.add(i)  # relink_hold_s: a lost identity in view within its gate
                if p.relink_dy_h > 0 and (not p.relink_dy_same_zoom
                                          or abs(self._zoom / self._lost_zoom.get(k, np.nan) - 1.0) <= 0.05):
                    # session 22: a boat keeps its waterline's row (its range) through a loss
                    dy = abs((boxes[i][1] + boxes[i][3]) - (lb[1] + lb[3]))
                    dy_max = p.relink_dy_h * max(float(boxes[i][3]), float(lb[3]), 1.0)
                    if p.relink_dy_px_per_s > 0 and (not p.relink_dy_side or k in self._lost_side):
                        # session 23: the row drifts while the boat is out of the view for long (the
                        # drift on top of the smaller box's slack: a tall carried box has its own)
                        dy_max = max(dy_max, p.relink_dy_h * max(min(float(boxes[i][3]), float(lb[3])), 1.0)
                                     + p.relink_dy_px_per_s * (t - tl) * self._zoom)
                    if dy > dy_max:
                        continue
                if p.relink_side_h_ratio > 0 and k in self._lost_side and self._whole_h.get(k):
                    # session 23 (H4): a boat left at the side edge keeps its size, from its boxes clear of the edge
                    hb = float(boxes[i][3])
                    if not self._side_h_ok(self._whole_h[k], hb):
                        # relink_side_h_clear_either (session 31, h45): or from its boxes 1 px clear of the edge
                        if not (k in self._whole_h1 and self._whole_h1[k] and self._side_h_ok(self._whole_h1[k], hb)):
                            continue
                sm = self._lost_small.get(k) if shape_min_on else None
                if sm is not None:  # relink_shape_min_n_ir: its smallest last box, carried by the zoom change
                    sm = np.asarray(sm[0], np.float64) * np.array([1.0, 1.0, self._zoom / max(sm[1], 1e-6),
                                                                   self._zoom / max(sm[1], 1e-6)])
                    if float(lb[2] * lb[3]) < p.relink_shape_min_grown_ir * float(sm[2] * sm[3]):
                        sm = None  # relink_shape_min_grown_ir: its box had not grown before the loss
                if (p.relink_aspect_ratio > 0 and k not in self._lost_side and min(lb[2], lb[3]) >= 2.0
                        and min(boxes[i][2], boxes[i][3]) >= 2.0):
                    # session 24 (H9): a boat keeps its shape (a mast's tall box is not a hull's long one)
                    ar = (float(boxes[i][2]) / float(boxes[i][3])) / (float(lb[2]) / float(lb[3]))
                    if max(ar, 1.0 / ar) > p.relink_aspect_ratio:
                        ok_sm = False
                        if sm is not None and min(sm[2], sm[3]) >= 2.0:
                            ar = (float(boxes[i][2]) / float(boxes[i][3])) / (float(sm[2]) / float(sm[3]))
                            ok_sm = max(ar, 1.0 / ar) <= p.relink_aspect_ratio
                        e_sm = self._lost_small.get(k) if shape_min_on else None
                        if not ok_sm and e_sm is not None and e_sm[2] is not None:
                            # relink_shape_any_ir: any of its last boxes' shapes, of an area within
                            # relink_shape_any_area of the new cluster's
                            a_new = float(boxes[i][2] * boxes[i][3])
                            for b_ in e_sm[2]:
                                if min(b_[2], b_[3]) < 2.0:
                                    continue
                                a_b = float(b_[2] * b_[3]) * (self._zoom / max(e_sm[1], 1e-6)) ** 2
                                if (p.relink_shape_any_area > 0
                                        and max(a_b, a_new) > p.relink_shape_any_area * max(min(a_b, a_new), 1e-6)):
                                    continue
                                ar = (float(boxes[i][2]) / float(boxes[i][3])) / (float(b_[2]) / float(b_[3]))
                                if max(ar, 1.0 / ar) <= p.relink_aspect_ratio:
                                    ok_sm = True
                                    break
                        if not ok_sm:
                            if block_on and d <= 0.0 and t - tl <= p.relink_shape_block_s_ir + 1e-9:
                                blocked.add(i)  # relink_shape_block_s_ir: it covers a just-lost identity
                                block_ks.setdefault(i, set()).add(k)
                            continue
                if p.relink_size_ratio > 0:  # stop 16: a boat keeps its size (the lost box is carried through the zoom)
                    hb, hl = float(boxes[i][3]), float(lb[3])
                    if max(hb, hl) > p.relink_size_ratio * max(min(hb, hl), 1.0):
                        continue
                a_ref = lb[2] * lb[3]
                if p.relink_area_at_loss and (p.relink_area_at_loss_ir or not self._ir) and k in self._lost_a0:  # session 27 (h29): not a coast's grown box
                    a0, z0 = self._lost_a0[k]
                    a_ref = min(a_ref, a0 * (self._zoom / max(z0, 1e-6)) ** 2)
                if p.relink_area_med_n_ir > 0 and self._ir and k in self._lost_amed:  # session 30 (h37)
                    am, zm = self._lost_amed[k]
                    a_ref = min(a_ref, am * (self._zoom / max(zm, 1e-6)) ** 2)
                if sm is not None:  # relink_shape_min_n_ir
                    a_ref = min(a_ref, float(sm[2] * sm[3]))
                if (p.relink_min_area > 0 and boxes[i][2] * boxes[i][3] < p.relink_min_area * a_ref
                        and (not p.relink_area_same_zoom
                             or abs(self._zoom / self._lost_zoom.get(k, np.nan) - 1.0) <= 0.05)):
                    if block_on and d <= 0.0 and t - tl <= p.relink_shape_block_s_ir + 1e-9:
                        blocked.add(i)  # relink_shape_block_s_ir
                        block_ks.setdefault(i, set()).add(k)
                    continue  # session 21: a large boat's identity is not given to a much smaller cluster
                if ((p.relink_area_zoom_min > 0 or p.relink_height_zoom_min > 0) and p.relink_area_same_zoom
                        and not abs(self._zoom / self._lost_zoom.get(k, np.nan) - 1.0) <= 0.05
                        and (boxes[i][2] * boxes[i][3] < p.relink_area_zoom_min * lb[2] * lb[3]
                             or boxes[i][3] < p.relink_height_zoom_min * lb[3])):
                    continue  # session 22 (H6): the same, looser, through a zoom change
                if d <= gate and far_new is not None and bool(far_new[i]) != bool(self._far_side(lb[None])[0]):
                    continue  # session 26 round 2 (H25, far_id_px): not across the far strip's line
                if d <= gate:
                    # whether _looks_alike logged a look for this pair: by the last entry's identity, not the
                    # log's length (a full deque's length stops growing; session 31, h43 found it)
                    last_look = self.relink_log[-1] if self.relink_log else None
                    # relink_side_app_near_px (session 30, h38): lost at the side, expected right here: its
                    # look (from a box cut by the edge) refuses nothing
                    near_side = (side_app_on and k in self._lost_side
                                 and d <= p.relink_side_app_near_px * self._zoom)
                    if near_side and p.relink_side_app_near_alone_px > 0:
                        # session 31 (h45): not for a new cluster beside a cluster already reported (a part of
                        # a boat in view, as the sailboat's hull beside its relinked mast)
                        if i not in beside_old:
                            if old_boxes is None:  # last frame's reported boxes
                                old_boxes = np.asarray([carry(np.asarray(b_, np.float64))
                                                        for b_ in self._prev_boxes.values()], np.float64).reshape(-1, 4)
                            nw = set(new)
                            ob = np.asarray([boxes[j] for j in range(len(cids)) if j not in nw and j != i],
                                            np.float64).reshape(-1, 4)  # the other clusters not new this frame
                            own = self._prev_boxes.get(int(rep[i])) if int(rep[i]) == int(cids[i]) else None
                            pb = old_boxes
                            if own is not None:  # not its own last box (a young cluster retried)
                                keep = ~np.all(np.isclose(pb, carry(np.asarray(own, np.float64))), axis=1)
                                pb = pb[keep]
                            beside_old[i] = self._beside_old(boxes[i], np.vstack([ob, pb]),
                                                             p.relink_side_app_near_alone_px * self._zoom)
                        near_side = not beside_old[i]
                    if p.relink_appearance and not near_side and not self._looks_alike(k, i, cids, boxes, t, sig_new):
                        continue
                    if (p.relink_app_margin > 0 and p.relink_appearance and not near_side
                            and self._looked(last_look)):
                        app_d[(i, k)] = float(self.relink_log[-1][4])  # relink_app_margin: its look's distance
                    if (near_side and p.relink_side_app_near_margin and p.relink_app_margin > 0 and p.relink_appearance):
                        # session 31 (h43): its look refuses nothing, but another lost identity looking much more
                        # like the new cluster still wins (relink_app_margin)
                        self._looks_alike(k, i, cids, boxes, t, sig_new)
                        if self._looked(last_look):
                            app_d[(i, k)] = float(self.relink_log[-1][4])
                    if p.relink_dv_px_s > 0 and not self._dv_ok(k, own_k[i], cam_s[i], p.relink_dv_px_s):
                        continue  # session 20: a boat keeps its own velocity through a loss
                    # relink_iou_tie: among pairs at one gap (overlapping: 0), the lost box overlapping most first
                    o = _iou(boxes[i], lb) if p.relink_iou_tie else 0.0
                    pairs.append((d, -o, i, k))
                    if side_row_on and k in self._lost_side and k in self._lost_row:
                        side_row[(i, k)] = self._lost_row[k]
        if near_ks:
            # relink_near_refused_px (session 32, h48): a new cluster with a lost identity expected right here
            # but refused gets none expected further away this frame
            paired = {(q[2], q[3]) for q in pairs}
            held_near = {i for i, ks in near_ks.items() if any((i, k) not in paired for k in ks)}
            if held_near and p.relink_near_refused_far_out:
                # relink_near_refused_far_out: only the far identities expected wholly outside the image are withheld
                far_keep = {(q[2], q[3]) for q in pairs if q[2] in held_near and q[0] > near_ref_px
                            and (q[2], q[3]) in near_out}
                held_pairs = [q for q in pairs if (q[2], q[3]) in far_keep]
            else:
                held_pairs = []
            if held_near and p.relink_near_refused_newer:
                # relink_near_refused_newer: only the identities lost before the last-lost refused one
                lim = {i: max(self._lost[k][0] for k in near_ks[i] if (i, k) not in paired) for i in held_near}
                pairs = [q for q in pairs if q[2] not in held_near or q[0] <= near_ref_px
                         or self._lost[q[3]][0] > lim[q[2]] + 1e-9]
            elif held_near:
                pairs = [q for q in pairs if q[2] not in held_near or q[0] <= near_ref_px]
            if held_pairs:
                pairs = pairs + [q for q in held_pairs if q not in pairs]
        if blocked:  # relink_shape_block_s_ir: no identity now; the covered ones wait for it a while
            pairs = [q for q in pairs if q[2] not in blocked]
            for i in blocked:
                if i not in waiting:
                    self._shape_wait[int(cids[i])] = (t, block_ks.get(i, set()))
        if p.relink_app_margin > 0 and (p.relink_app_margin_ir or not self._ir) and len(app_d) > 1:
            # relink_app_margin: of a new cluster's lost identities whose looks are known, those looking
            # more than the margin further away than the best-looking one are not its candidates
            best = {}
            for (i, k), a in app_d.items():
                best[i] = min(best.get(i, np.inf), a)
            pairs = [q for q in pairs if app_d.get((q[2], q[3]), -np.inf) <= best.get(q[2], np.inf) + p.relink_app_margin]
        if side_row_on and len(side_row) > 1:
            # relink_side_row_margin: of a new cluster's lost identities lost at the side, those whose row under the
            # horizon at the loss lies more than the margin further from the new cluster's than the nearest one's
            # are not its candidates
            by_i = {}
            for (i, k), rk in side_row.items():
                by_i.setdefault(i, []).append((k, rk))
            drop = set()
            for i, lst in by_i.items():
                if len(lst) < 2:
                    continue
                me = self._row_key(boxes[i])[0]
                if me is None:
                    continue
                dr = {k: abs(me - rk[0]) for k, rk in lst if rk[0] is not None}
                if len(dr) < 2:
                    continue
                lim = min(dr.values()) + p.relink_side_row_margin
                drop.update((i, k) for k, r in dr.items() if r > lim)
            if drop:
                pairs = [q for q in pairs if (q[2], q[3]) not in drop]
        done = set()
        self._relinked_now = {}  # hand_over_relinked: identity relinked this frame -> (cluster index, its lost entries)
        retired = set()  # relink_retry_s: the young clusters' own identities given up for a lost one
        for d, _, i, k in sorted(pairs):
            if i in done or k in present:
                continue
            if p.hand_over_relinked:
                self._relinked_now[k] = (i, self._lost[k], self._lost_dir.get(k), self._lost_alt.get(k),
                                         self._lost_alt_dir.get(k), self._relinked.get(k), self._relinked_alt.get(k))
            if i in retry or i in waiting:
                retired.add(int(rep[i]))
                self._shape_wait.pop(int(cids[i]), None)
            self._alias[int(cids[i])] = k
            rep[i] = k
            present.add(k)
            done.add(i)
            if p.relink_min_s > 0 or p.relink_alt_s > 0:  # kept to give the identity back if this cluster dies young
                self._relinked[k] = (t, self._lost[k], self._lost_dir.get(k), int(cids[i]))
            if p.relink_alt_s > 0:
                self._relinked_alt[k] = (self._lost_alt.get(k), self._lost_alt_dir.get(k))
            del self._lost[k]
            self._lost_dir.pop(k, None)
            self._lost_alt.pop(k, None)
            self._lost_alt_dir.pop(k, None)
        self._hold = set()
        if p.relink_hold_s > 0 and retry_on:
            # session 27 (h32): young fragments a lost identity may take later (relink_retry_s) stay tentative
            self._hold = {int(rep[i]) for i in size_ref if i not in done and int(rep[i]) == int(cids[i])
                          and t - self._birth.get(int(cids[i]), t) < p.relink_hold_s - 1e-9}
        # one reported identity per frame: a cluster reported under its own identity keeps it; a
        # duplicate falls back to its own identity, or to a new one when that is taken too (a
        # cluster identity that came back, e.g. after an unmerge, while another cluster carries it)
        if len(np.unique(rep)) < len(rep):
            used = set()
            own_first = sorted(range(len(rep)), key=lambda i: (int(rep[i]) != int(cids[i]), i))
            for i in own_first:
                r = int(rep[i])
                if r in used:
                    self._alias.pop(int(cids[i]), None)
                    r = int(cids[i])
                    if r in used:
                        r = self.graph.next_id
                        self.graph.next_id += 1
                        self._alias[int(cids[i])] = r
                    rep[i] = r
                used.add(r)
        self._known.update((int(c), t) for c in cids)
        if len(self._known) > 4 * max(len(cids), 16):  # bounded memory in a long live run
            # a cluster identity comes back only through the graph's label memory
            memory_s = max(10.0, 5.0 * p.label_memory_s)
            self._known = {k: tk for k, tk in self._known.items() if t - tk <= memory_s}
            self._alias = {k: v for k, v in self._alias.items() if k in self._known}
        now = {int(r): boxes[i].copy() for i, r in enumerate(rep)}
        own = {}
        if vel is not None and len(rep) and own_v is not None:
            own = {int(r): np.nan_to_num(own_v[i]) for i, r in enumerate(rep)}
        self._own_now = {int(r): (own_k[i], cam_s[i]) for i, r in enumerate(rep)} if own_k is not None else {}
        renamed = set(retired)  # younger identities handed over to an older one: retired, not lost
        for k, b in self._prev_boxes.items():
            if k not in now and k not in renamed:
                back = self._relinked.pop(k, None)
                back_alt = self._relinked_alt.pop(k, None)
                ret = self._returned.pop(k, None)
                mem = None
                if (back is None and ret is not None and k in self._lost and p.relink_alt_s > 0
                        and t - ret <= p.relink_alt_s + 1e-9):
                    # relink_alt_memory: k came back through the label memory and is lost again soon:
                    # its entry from before (still kept in _lost, carried on) is the place to keep
                    mem = ((self._lost[k], self._lost_dir.get(k)), (self._lost_alt.get(k), self._lost_alt_dir.get(k)))
                if (back is not None and t - back[0] <= p.relink_min_s + 1e-9 and p.relink_undo_hand_over
                        and p.relink_overlap > 0 and k not in self._joined_apart):
                    # session 23 (H4): a cluster born on the dying cluster's box takes k (the hand-over, on
                    # that box), rather than k going back to where it was expected before the relink
                    self._lost[k] = (t, carry(b), self._prev_vel.get(k))
                    r = self._hand_over(k, cids, boxes, rep, now, own)
                    if r is not None:
                        renamed.add(r)
                        e = self._relinked_now.pop(r, None)
                        if e is not None:  # hand_over_relinked: r is lost again as before its relink
                            self._lost[r] = e[1]
                            for dct, v in ((self._lost_dir, e[2]), (self._lost_alt, e[3]),
                                           (self._lost_alt_dir, e[4]), (self._relinked, e[5]),
                                           (self._relinked_alt, e[6])):
                                if v is None:
                                    dct.pop(r, None)
                                else:
                                    dct[r] = v
                        else:
                            self._lost.pop(r, None)
                            self._lost_dir.pop(r, None)
                            self._lost_alt.pop(r, None)
                            self._lost_alt_dir.pop(r, None)
                        if back_alt is not None and back_alt[0] is not None:
                            self._relinked_alt.pop(k, None)
                        continue
                if back is not None and t - back[0] <= p.relink_min_s + 1e-9:
                    # the cluster that took k died within relink_min_s: k is lost as it was before,
                    # and that cluster no longer carries k (should it come back through the graph's
                    # label memory, it is reported under its own identity, not k)
                    if p.relink_undo_drop_alias and self._alias.get(back[3]) == k:
                        del self._alias[back[3]]
                    self._lost[k] = back[1]
                    if back[2] is not None:
                        self._lost_dir[k] = back[2]
                    if back_alt is not None and back_alt[0] is not None:
                        self._lost_alt[k] = back_alt[0]
                        if back_alt[1] is not None:
                            self._lost_alt_dir[k] = back_alt[1]
                    continue
                self._lost_alt.pop(k, None)
                self._lost_alt_dir.pop(k, None)
                if back is not None and p.relink_alt_s > 0 and t - back[0] <= p.relink_alt_s + 1e-9:
                    # session 21: the cluster that took k died soon after the relink: k is lost here,
                    # and also still where it was expected before that relink (the older place of a
                    # chain of such relinks; carried on with the earlier time lost)
                    if back_alt is not None and back_alt[0] is not None:
                        self._lost_alt[k] = back_alt[0]
                        if back_alt[1] is not None:
                            self._lost_alt_dir[k] = back_alt[1]
                    else:
                        self._lost_alt[k] = back[1]
                        if back[2] is not None:
                            self._lost_alt_dir[k] = back[2]
                elif mem is not None:  # the same for a return through the label memory
                    e, d = mem[1] if mem[1][0] is not None else mem[0]
                    self._lost_alt[k] = e
                    if d is not None:
                        self._lost_alt_dir[k] = d
                v0 = self._prev_vel.get(k)
                self._lost[k] = (t, carry(b, v0 if p.relink_predict_s > 0 else None), v0)
                if p.relink_area_at_loss:
                    self._lost_a0[k] = (float(self._lost[k][1][2] * self._lost[k][1][3]), self._zoom)
                if p.relink_shape_min_n_ir > 0 and self._ir and self._box_hist.get(k):
                    bh = self._box_hist[k]
                    j_ = int(np.argmin([b_[2] * b_[3] * (self._zoom / max(z_, 1e-6)) ** 2 for b_, z_ in bh]))
                    self._lost_small[k] = (bh[j_][0].copy(), bh[j_][1],
                                           [b_.copy() for b_, _ in bh] if p.relink_shape_any_ir else None)
                else:
                    self._lost_small.pop(k, None)
                if p.relink_area_med_n_ir > 0 and self._ir and self._area_hist.get(k):
                    ah = self._area_hist[k]
                    self._lost_amed[k] = (float(np.median([a_ * self._zoom ** 2 / max(z_, 1e-6) ** 2 for a_, z_ in ah])),
                                          self._zoom)
                if ((p.relink_dy_px_per_s > 0 and p.relink_dy_side) or p.relink_side_h_ratio > 0 or p.relink_aspect_ratio > 0
                        or p.relink_side_row_margin > 0 or p.relink_predict_side_s > 0):
                    # session 23: lost at the left or right edge
                    w_img = None if getattr(snap, "shape", None) is None else float(snap.shape[1])
                    if w_img is not None and (b[0] <= 1.0 or b[0] + b[2] >= w_img - 1.0):
                        self._lost_side.add(k)
                    else:
                        self._lost_side.discard(k)
                    m_near = p.relink_predict_side_near_px * self._zoom
                    if (side_pred_on and m_near > 0 and w_img is not None and k not in self._lost_side
                            and (b[0] <= m_near or b[0] + b[2] >= w_img - m_near)):
                        self._lost_near.add(k)  # session 31 (h43): lost near the side edge, about to leave
                    else:
                        self._lost_near.discard(k)
                if p.relink_side_row_margin > 0:  # session 29 (h33): its row at the loss, not the carried one's
                    self._lost_row[k] = self._row_key(self._lost[k][1])
                if (p.relink_area_same_zoom or p.relink_dy_same_zoom or p.relink_view_px > 0
                        or p.relink_area_zoom_min > 0 or p.relink_height_zoom_min > 0):
                    self._lost_zoom[k] = self._zoom
                if p.relink_dv_px_s > 0 or p.hand_over_dv_px_s > 0:
                    self._lost_v[k] = self._own_prev.get(k)
                if p.relink_appearance:  # its look in the last frame it was seen
                    self._lost_sig[k] = (None if self._app_prev_img is None
                                         else appearance_signature(self._app_prev_img, b))
                    if (p.relink_app_min_w_px > 0 and (p.relink_app_min_w_ir or not self._ir)
                            and float(b[2]) < p.relink_app_min_w_px * self._zoom):
                        self._lost_sig[k] = None  # session 29 (h33): a sliver's look is not its boat's
                prev_cam = self._prev_camera
                if prev_cam is not None:  # the directions of its last box's corners, and their rates
                    az, el = prev_cam.pixel_to_azel(np.array([b[0], b[0] + b[2]]), np.array([b[1], b[1] + b[3]]))
                    v = self._prev_vel.get(k)
                    daz = del_ = 0.0
                    if v is not None and np.all(np.isfinite(v)):
                        c = np.array([b[0] + 0.5 * b[2], b[1] + 0.5 * b[3]])
                        a2, e2 = prev_cam.pixel_to_azel(np.array([c[0], c[0] + v[0]]), np.array([c[1], c[1] + v[1]]))
                        daz = float((a2[1] - a2[0] + 180.0) % 360.0 - 180.0)
                        del_ = float(e2[1] - e2[0])
                    if side_pred_on and (k in self._lost_side or k in self._lost_near):
                        # relink_predict_side_s (session 30, h39): the rates fitted to its centre's directions over
                        # the last relink_predict_side_win_s (boxes clear of the edges), not its last velocity
                        # (a box cut by the edge, or a cluster that slid onto a neighbour, moves anyhow)
                        r_ = self._dir_rate(k, t, dt)
                        if r_ is not None and abs(r_[0]) < p.relink_predict_side_min_rate:
                            r_ = None  # session 31 (h43): a slow boat's second place is its carried box, slipped
                        if r_ is not None:
                            self._lost_fit[k] = r_
                        else:
                            self._lost_fit.pop(k, None)
                    self._lost_dir[k] = (az, el, daz, del_)
                if p.relink_overlap > 0 and k not in self._joined_apart:
                    r = self._hand_over(k, cids, boxes, rep, now, own)
                    if r is None and p.relink_young_s > 0:
                        r = self._hand_over_to(k, cids, boxes, rep, now, own, young=(t, gap_px))
                    if r is not None and r in self._relinked_now:
                        # hand_over_relinked: the younger identity relinked this frame is lost again as before
                        e = self._relinked_now.pop(r)
                        self._lost[r] = e[1]
                        for dct, v in ((self._lost_dir, e[2]), (self._lost_alt, e[3]), (self._lost_alt_dir, e[4]),
                                       (self._relinked, e[5]), (self._relinked_alt, e[6])):
                            if v is None:
                                dct.pop(r, None)
                            else:
                                dct[r] = v
                        continue
                    if r is not None:
                        renamed.add(r)
                        self._lost.pop(r, None)
                        self._lost_dir.pop(r, None)
                        self._lost_alt.pop(r, None)
                        self._lost_alt_dir.pop(r, None)
        if p.lost_dup_iou > 0 and (p.lost_dup_ir or not self._ir):  # session 27 (h29): a young lost identity beside an older lost one
            self._lost_dup(t)
        if p.relink_side_h_ratio > 0 and getattr(snap, "shape", None) is not None:
            # relink_side_h_ratio: each reported identity's last heights clear of the image's side edges
            w_img = float(snap.shape[1])
            m_side = 1.0
            if p.relink_side_h_clear_px > 0 and (p.relink_side_h_clear_ir or not self._ir):
                m_side = max(1.0, p.relink_side_h_clear_px * self._zoom)  # session 30 (h40): clear by a margin
            either = m_side > 1.0 and p.relink_side_h_clear_either
            for k, b in now.items():
                if b[0] > m_side and b[0] + b[2] < w_img - m_side and b[3] > 0:
                    hw = self._whole_h.setdefault(k, [])
                    hw.append((float(b[3]), float(self._zoom)))
                    if len(hw) > max(int(p.relink_side_h_n), 1):
                        del hw[0]
                if either and b[0] > 1.0 and b[0] + b[2] < w_img - 1.0 and b[3] > 0:
                    # relink_side_h_clear_either (session 31, h45): the heights 1 px clear too
                    hw = self._whole_h1.setdefault(k, [])
                    hw.append((float(b[3]), float(self._zoom)))
                    if len(hw) > max(int(p.relink_side_h_n), 1):
                        del hw[0]
            if len(self._whole_h) > 2 * (len(now) + len(self._lost)) + 16:  # bounded memory
                self._whole_h = {k: v for k, v in self._whole_h.items() if k in now or k in self._lost}
            if len(self._whole_h1) > 2 * (len(now) + len(self._lost)) + 16:
                self._whole_h1 = {k: v for k, v in self._whole_h1.items() if k in now or k in self._lost}
        if p.relink_shape_min_n_ir > 0 and self._ir:
            # relink_shape_min_n_ir: each reported identity's last boxes
            for k, b in now.items():
                bh = self._box_hist.setdefault(k, [])
                bh.append((np.asarray(b, np.float64).copy(), float(self._zoom)))
                if len(bh) > int(p.relink_shape_min_n_ir):
                    del bh[0]
            if len(self._box_hist) > 2 * (len(now) + len(self._lost)) + 16:  # bounded memory
                self._box_hist = {k: v for k, v in self._box_hist.items() if k in now or k in self._lost}
                self._lost_small = {k: v for k, v in self._lost_small.items() if k in self._lost}
        if p.relink_area_med_n_ir > 0 and self._ir:
            # relink_area_med_n_ir: each reported identity's last areas
            for k, b in now.items():
                ah = self._area_hist.setdefault(k, [])
                ah.append((float(b[2] * b[3]), float(self._zoom)))
                if len(ah) > int(p.relink_area_med_n_ir):
                    del ah[0]
            if len(self._area_hist) > 2 * (len(now) + len(self._lost)) + 16:  # bounded memory
                self._area_hist = {k: v for k, v in self._area_hist.items() if k in now or k in self._lost}
                self._lost_amed = {k: v for k, v in self._lost_amed.items() if k in self._lost}
        if side_pred_on and fcam is not None and now and getattr(snap, "shape", None) is not None:
            # relink_predict_side_s: each reported identity's centre directions, boxes clear of the edges
            w_img = float(snap.shape[1])
            ks = [k for k, b in now.items() if b[0] > 1.0 and b[0] + b[2] < w_img - 1.0]
            if ks:
                cb = np.array([now[k] for k in ks], np.float64)
                az_, el_ = fcam.pixel_to_azel(cb[:, 0] + 0.5 * cb[:, 2], cb[:, 1] + 0.5 * cb[:, 3])
                for k, a_, e_ in zip(ks, np.atleast_1d(az_).tolist(), np.atleast_1d(el_).tolist()):
                    dq = self._dir_hist.setdefault(k, collections.deque())
                    dq.append((t, a_, e_, float(now[k][2]) / max(self._zoom, 1e-6), float(now[k][3]) / max(self._zoom, 1e-6)))
                    while dq and dq[0][0] < t - p.relink_predict_side_win_s - 1e-9:
                        dq.popleft()
            if len(self._dir_hist) > 2 * (len(now) + len(self._lost)) + 16:  # bounded memory
                self._dir_hist = {k: v for k, v in self._dir_hist.items() if k in now or k in self._lost}
        self._prev_boxes = now
        self._prev_vel = own
        self._own_prev = self._own_now
        if len(self._lost_v) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_v = {k: v for k, v in self._lost_v.items() if k in self._lost}
        if len(self._relinked_alt) > 2 * len(self._relinked) + 16:  # bounded memory
            self._relinked_alt = {k: v for k, v in self._relinked_alt.items() if k in self._relinked}
        if len(self._returned) > 2 * len(self._lost) + 16:  # bounded memory
            self._returned = {k: v for k, v in self._returned.items() if k in self._lost}
        if len(self._lost_row) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_row = {k: v for k, v in self._lost_row.items() if k in self._lost}
        if len(self._lost_a0) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_a0 = {k: v for k, v in self._lost_a0.items() if k in self._lost}
        if len(self._lost_zoom) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_zoom = {k: v for k, v in self._lost_zoom.items() if k in self._lost}
        if len(self._swapped) > 2 * len(now) + 16:  # bounded memory
            self._swapped = {k for k in self._swapped if k in now}
        if len(self._lost_near) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_near = {k for k in self._lost_near if k in self._lost}
        if len(self._lost_side) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_side = {k for k in self._lost_side if k in self._lost}
        if len(self._lost_fit) > 2 * len(self._lost) + 16:  # bounded memory
            self._lost_fit = {k: v for k, v in self._lost_fit.items() if k in self._lost}
        if len(self._lost_alt_dir) > len(self._lost_alt) + 16:
            self._lost_alt_dir = {k: v for k, v in self._lost_alt_dir.items() if k in self._lost_alt}
        self._prev_camera = fcam
        if p.relink_appearance:
            self._app_prev_img = self._app_img
            if len(self._lost_sig) > 2 * (len(self._lost) + len(self._relinked)) + 16:  # bounded memory
                self._lost_sig = {k: v for k, v in self._lost_sig.items() if k in self._lost or k in self._relinked}
        return rep

    def _row_key(self, b) -> tuple:
        """``relink_side_row_margin``: box ``b``'s bottom row less the horizon's row at its centre's
        column (this frame's horizon; None without one), and its raw bottom row."""
        bottom = float(b[1] + b[3])
        rel = None
        if self._horizon is not None:
            try:
                r = float(np.asarray(self._horizon.row_at(np.array([float(b[0] + 0.5 * b[2])])), np.float64).reshape(-1)[0])
            except Exception:  # noqa: BLE001 - any horizon without a usable row
                r = float("nan")
            if np.isfinite(r):
                rel = bottom - r
        return (rel, bottom)

    def _lost_dup(self, t: float) -> None:
        """``lost_dup_iou`` (session 27, h29): each identity lost this frame (time lost ``t``) and
        first seen less than ``lost_dup_age_s`` before, after an older identity was lost, whose box
        overlaps that older identity's expected box by ``lost_dup_iou`` (IoU) or more, is retired
        into it: the older identity (the best overlap) takes the young one's lost entry."""
        p = self.params
        young = [k for k, e in self._lost.items()
                 if abs(e[0] - t) < 1e-9 and t - self._birth.get(k, -np.inf) < p.lost_dup_age_s + 1e-9]
        for k in young:
            e = self._lost.get(k)
            if e is None:
                continue
            born = self._birth[k]
            best, best_o = None, p.lost_dup_iou
            for j, (tl, lb, _) in self._lost.items():
                if j == k or tl > born + 1e-9:
                    continue  # the older identity was lost before the young one was first seen
                o = _iou(np.asarray(e[1], np.float64), np.asarray(lb, np.float64))
                if o >= best_o:
                    best, best_o = j, o
            if best is None:
                continue
            j = best
            self._lost[j] = e
            del self._lost[k]
            for dct in (self._lost_dir, self._lost_zoom, self._lost_v, self._lost_sig, self._lost_a0, self._lost_row):
                if k in dct:
                    dct[j] = dct.pop(k)
                else:
                    dct.pop(j, None)
            for dct in (self._lost_alt, self._lost_alt_dir, self._relinked, self._relinked_alt):
                dct.pop(k, None)
            self._lost_near.discard(k)
            self._lost_near.discard(j)
            if k in self._lost_side:
                self._lost_side.discard(k)
                self._lost_side.add(j)
            else:
                self._lost_side.discard(j)
            for c in [c for c, r in self._alias.items() if r == k] + [k]:
                self._alias[c] = j  # a cluster of the young identity that comes back is reported as the older

    def _jump_lost(self, carry, cids, boxes, rep, t) -> None:
        """``relink_jump_iou`` (session 24): a cluster reported last frame under identity ``r`` whose
        box now lies away from its box of the frame before (``carry``: into this frame; IoU under 0.1)
        and on a lost identity ``k``'s expected box (IoU at least ``relink_jump_iou``; ``k`` older than
        ``r``; of several, the largest overlap) takes ``k``, as a relink would (``rep`` and the aliases are changed in place); ``r`` is then not reported this
        frame and is lost at its last box by :meth:`_relink`'s loss pass (hand-over included)."""
        p = self.params
        taken = set(int(x) for x in rep)
        for i in range(len(cids)):
            r = int(rep[i])
            if int(cids[i]) not in self._known or r not in self._prev_boxes:
                continue  # a new cluster, or one not reported the frame before
            if _iou(boxes[i], carry(self._prev_boxes[r])) >= 0.1:
                continue  # no jump
            best, best_o = -1, p.relink_jump_iou
            for k, (_, lb, _) in self._lost.items():
                if k >= r or k in taken:
                    continue
                o = _iou(boxes[i], lb)
                if o >= best_o:
                    best, best_o = k, o
            if best < 0:
                continue
            self._alias[int(cids[i])] = best
            rep[i] = best
            taken.add(best)
            if p.relink_min_s > 0 or p.relink_alt_s > 0:  # as a relink: given back if the cluster dies young
                self._relinked[best] = (t, self._lost[best], self._lost_dir.get(best), int(cids[i]))
            del self._lost[best]
            self._lost_dir.pop(best, None)
            self._lost_alt.pop(best, None)
            self._lost_alt_dir.pop(best, None)

    def _jump_back(self, cids, boxes, rep, t) -> None:
        """``relink_jump_back_iou_ir`` (session 30): a known cluster reported under its own identity ``r``
        while ``r`` is lost (it comes back), whose box lies away from ``r``'s expected box (IoU under 0.1)
        and on another lost identity ``k``'s expected box (IoU at least ``relink_jump_back_iou_ir``; of
        several, the largest; any age), takes ``k`` as a relink would; ``r`` stays lost (``rep`` and the
        aliases are changed in place)."""
        p = self.params
        taken = set(int(x) for x in rep)
        for i in range(len(cids)):
            r = int(rep[i])
            c = int(cids[i])
            if c not in self._known or r not in self._lost or self._alias.get(c, c) != r:
                continue
            if _iou(boxes[i], self._lost[r][1]) >= 0.1:
                continue  # back where it was expected
            if p.relink_jump_back_s > 0 and t - self._lost[r][0] > p.relink_jump_back_s + 1e-9:
                continue  # not a drop-out
            if p.relink_jump_back_own_area > 0:
                a1, a2 = float(boxes[i][2] * boxes[i][3]), float(self._lost[r][1][2] * self._lost[r][1][3])
                if max(a1, a2) > p.relink_jump_back_own_area * max(min(a1, a2), 1e-6):
                    continue  # its box is not the one it had at its loss
            best, best_o = -1, p.relink_jump_back_iou_ir
            for k, (_, lb, _) in self._lost.items():
                if k == r or k in taken:
                    continue
                o = _iou(boxes[i], lb)
                if p.relink_jump_back_area > 0:
                    a1, a2 = float(boxes[i][2] * boxes[i][3]), float(lb[2] * lb[3])
                    if max(a1, a2) > p.relink_jump_back_area * max(min(a1, a2), 1e-6):
                        continue
                if o >= best_o:
                    best, best_o = k, o
            if best < 0:
                continue
            self._alias[c] = best
            rep[i] = best
            taken.add(best)
            if p.relink_min_s > 0 or p.relink_alt_s > 0:  # as a relink: given back if the cluster dies young
                self._relinked[best] = (t, self._lost[best], self._lost_dir.get(best), c)
            del self._lost[best]
            self._lost_dir.pop(best, None)
            self._lost_alt.pop(best, None)
            self._lost_alt_dir.pop(best, None)

    def _in_view(self, k, lb, view_wh) -> bool:
        """``relink_view_px``: whether lost identity ``k``'s expected box ``lb`` lies within
        ``relink_view_px`` pixels of the image (``view_wh``: its width and height), or the check does
        not apply (``relink_view_same_zoom`` and the zoom changed by more than 5 % since the loss;
        with ``relink_view_zoom_in``, only when it fell below 0.95 of the zoom at the loss)."""
        p = self.params
        if p.relink_view_same_zoom:
            r = self._zoom / self._lost_zoom.get(k, np.nan)
            if not (r >= 0.95 if p.relink_view_zoom_in else abs(r - 1.0) <= 0.05):
                return True
        w, hh = view_wh
        ox = max(-(lb[0] + lb[2]), lb[0] - w, 0.0)
        oy = max(-(lb[1] + lb[3]), lb[1] - hh, 0.0)
        return bool(np.hypot(ox, oy) <= p.relink_view_px * (self._zoom if p.relink_view_zoom_scale else 1.0))

    @staticmethod
    def _own_velocity(h, boxes, vel, dt):
        """Each cluster's own velocity (px/s): its image velocity ``vel`` less the camera's motion
        at its box's centre (the snapshot's homography ``h`` over ``dt``); NaN where the cluster's
        velocity is unknown (no member with a velocity) is not marked.  Returns it with the camera's
        image speed at each box's centre (px/s); None without ``vel`` or when ``h`` cannot be
        inverted."""
        if vel is None or not len(boxes):
            return None
        c = np.stack([boxes[:, 0] + 0.5 * boxes[:, 2], boxes[:, 1] + 0.5 * boxes[:, 3]], axis=1)
        try:
            hinv = np.linalg.inv(h)
        except np.linalg.LinAlgError:
            return None
        back = (hinv[:2, :2] @ c.T).T + hinv[:2, 2]
        back /= ((hinv[2, :2] @ c.T) + hinv[2, 2])[:, None]
        cam = (c - back) / max(dt, 1e-6)
        return np.asarray(vel, np.float64) - cam, np.hypot(cam[:, 0], cam[:, 1])

    def _side_pred_box(self, k, tl, t, fcam):
        """``relink_predict_side_s``: lost identity ``k``'s box moved on by its fitted azimuth rate for
        ``min(t - tl, relink_predict_side_s)`` seconds from its corners' directions at the loss, its row at
        its median elevation, projected through the camera ``fcam``; None without them."""
        d = self._lost_dir.get(k)
        if fcam is None or d is None:
            return None
        rate, el_med = self._lost_fit[k][:2]
        if self.params.relink_predict_side_med_box:
            # session 31 (h43): its fitted centre moved on, its median size over the fit's window (px at zoom 1)
            az_c, w1, h1 = self._lost_fit[k][2:5]
            u, w_, ok = fcam.azel_to_pixel(np.array([az_c + rate * min(t - tl, self.params.relink_predict_side_s)]),
                                           np.array([el_med]))
            u, w_ = np.atleast_1d(u), np.atleast_1d(w_)
            if not (np.all(ok) and np.all(np.isfinite(u)) and np.all(np.isfinite(w_))):
                return None
            bw, bh = w1 * self._zoom, h1 * self._zoom
            return np.array([float(u[0]) - 0.5 * bw, float(w_[0]) - 0.5 * bh, bw, bh])
        az = np.asarray(d[0], np.float64) + rate * min(t - tl, self.params.relink_predict_side_s)
        el = np.asarray(d[1], np.float64)
        el = el + (el_med - float(np.mean(el)))
        u, w_, ok = fcam.azel_to_pixel(az, el)
        if not (np.all(ok) and np.all(np.isfinite(u)) and np.all(np.isfinite(w_))):
            return None
        return np.array([min(u), min(w_), abs(u[1] - u[0]), abs(w_[1] - w_[0])])

    def _dir_rate(self, k, t, dt):
        """``relink_predict_side_s``: identity ``k``'s azimuth rate (deg/s) and median elevation (deg),
        a least-squares line through its box centre's directions over the last ``relink_predict_side_win_s``
        seconds before ``t``; None with fewer than half the frames of that time (``dt``: the frame
        interval; at least 3) or spanning under half that time."""
        dq = self._dir_hist.get(k)
        w = self.params.relink_predict_side_win_s
        if not dq:
            return None
        a = np.array([q for q in dq if q[0] >= t - w - 1e-9], np.float64)
        if len(a) < max(3, 0.5 * w / max(dt, 1e-3)) or a[-1, 0] - a[0, 0] < 0.5 * w:
            return None  # too few: a box that hugged the edge for long (cut by it, its centre tells nothing)
        ts = a[:, 0] - a[:, 0].mean()
        az = (a[:, 1] - a[0, 1] + 180.0) % 360.0 - 180.0
        vt = float(ts @ ts)
        if vt <= 0:
            return None
        rate = float(ts @ (az - az.mean())) / vt
        az_t = float(a[0, 1] + az.mean() + rate * (t - a[:, 0].mean()))  # the fitted line's direction at t
        return rate, float(np.median(a[:, 2])), az_t, float(np.median(a[:, 3])), float(np.median(a[:, 4]))

    def _dv_ok(self, k, v_new, cam_new, max_dv) -> bool:
        """``relink_dv_px_s`` / ``hand_over_dv_px_s``: whether a cluster of own velocity ``v_new``
        (px/s; the camera's image speed at its box ``cam_new``) may take lost identity ``k``: the
        two own velocities differ by at most ``max_dv`` times the zoom.  True when either is
        unknown and, with ``dv_still_px_s``, when the camera moved faster than that (times the
        zoom) at either box (a pan: the own velocities are unreliable then)."""
        e = self._lost_v.get(k)
        if e is None or v_new is None:
            return True
        v_lost, cam_lost = e
        z = self._zoom
        still = self.params.dv_still_px_s
        if still > 0 and not (cam_lost <= still * z and cam_new <= still * z):
            return True
        return _moves_alike(v_lost, v_new, max_dv * z)

    def _looks_alike(self, k, i, cids, boxes, t, sig_new) -> bool:
        """``relink_appearance``: whether new cluster ``i`` (its box ``boxes[i]`` in this frame's
        image) looks like lost identity ``k`` did when last seen: the appearance distance
        (:func:`appearance_distance`) is at most ``relink_appearance_max``.  True (no check) when
        either signature is unknown (no image, a box under 2x2 pixels)."""
        a = self._lost_sig.get(k)
        if a is None or self._app_img is None:
            return True
        if i not in sig_new:
            sig_new[i] = appearance_signature(self._app_img, boxes[i])
        b = sig_new[i]
        if b is None:
            return True
        dc, dt = appearance_parts(a, b)
        refused = dc + self.params.relink_appearance_tpl * dt > self.params.relink_appearance_max
        self.relink_log.append((t, int(k), int(cids[i]), boxes[i].copy(), dc, dt, refused))
        return not refused

    def _looked(self, last_look) -> bool:
        """Whether ``_looks_alike`` appended a look to ``relink_log`` since its last entry was ``last_look``
        (compared by identity: the log is a bounded deque, so its length stops growing once full)."""
        return bool(self.relink_log) and self.relink_log[-1] is not last_look

    def _far_side(self, boxes) -> np.ndarray | None:
        """``params.far_id_px``: whether each box (rows x, y, w, h) lies in the far strip (its bottom
        less than ``far_id_px`` under the horizon's row at its centre's column, or above it); None
        when off, without a horizon, or on an infrared frame without ``far_id_ir``."""
        p = self.params
        if p.far_id_px <= 0 or self._horizon is None or (self._ir and not p.far_id_ir):
            return None
        b = np.asarray(boxes, np.float64).reshape(-1, 4)
        if not len(b):
            return np.zeros(0, bool)
        row = np.asarray(self._horizon.row_at(b[:, 0] + 0.5 * b[:, 2]), np.float64).reshape(-1)
        with np.errstate(invalid="ignore"):
            return b[:, 1] + b[:, 3] < row + p.far_id_px

    def _far_apart(self, a, b) -> bool:
        """``params.far_id_px``: box ``a`` and box ``b`` lie on two sides of the far strip's line."""
        f = self._far_side(np.array([a, b], np.float64))
        return f is not None and bool(f[0]) != bool(f[1])

    def _hand_over(self, k, cids, boxes, rep, now, own) -> int | None:
        """Identity ``k`` was just lost: the hand-over (see :meth:`_hand_over_to`)."""
        return self._hand_over_to(k, cids, boxes, rep, now, own)

    def _hand_over_to(self, k, cids, boxes, rep, now, own, young=None) -> int | None:
        """Identity ``k`` was just lost: a younger cluster reported under its own identity whose
        box overlaps ``k``'s last box (carried into this frame) by ``relink_overlap`` of the
        smaller one takes ``k`` (the paper's merge rule, the oldest identity stays, applied when
        one of two clusters on an object dies rather than joins the other).  Returns the younger
        identity given up (retired: it is not lost, so it cannot come back on another cluster),
        or None.  ``young`` (``relink_young_s``, session 24: this frame's time and the gap function):
        instead of the overlap, a cluster reported under its own identity, born at most
        ``relink_young_s`` before, within ``relink_px`` (times the zoom) of the lost box takes ``k``,
        the nearest first (a boat's new cluster born beside its old one shortly before that one
        died: the relink takes only clusters born after the loss)."""
        lb = self._lost[k][1]
        best, best_o = -1, self.params.relink_overlap
        if young is not None:
            t_now, gap_fn = young
            best_o = -(self.params.relink_px * self._zoom)
        for i, r in enumerate(rep):
            r = int(r)
            if r <= k or (r != int(cids[i]) and r not in self._swapped
                          and not (r in self._relinked_now and self._relinked_now[r][0] == i)):
                continue  # older, or already carrying another identity (unless relinked this frame: hand_over_relinked)
            b = boxes[i]
            if young is not None:
                if r != int(cids[i]) or t_now - self._born.get(r, -np.inf) > self.params.relink_young_s + 1e-9:
                    continue  # only a young cluster under its own identity
                if self.params.relink_young_after_s > 0 and (
                        self._born.get(r, -np.inf) - self._born.get(k, -np.inf)
                        < self.params.relink_young_after_s - 1e-9):
                    continue  # session 24 (H12): born with the lost one (not after it): another boat
                o = -gap_fn(b, lb)  # the nearer, the higher
            else:
                iw = min(b[0] + b[2], lb[0] + lb[2]) - max(b[0], lb[0])
                ih = min(b[1] + b[3], lb[1] + lb[3]) - max(b[1], lb[1])
                small = min(b[2] * b[3], lb[2] * lb[3])
                o = iw * ih / small if iw > 0 and ih > 0 and small > 0 else 0.0
            if o >= best_o and self.params.hand_over_dv_px_s > 0 and not self._dv_ok(
                    k, *self._own_now.get(r, (None, 0.0)), self.params.hand_over_dv_px_s):
                continue  # session 20: a neighbour moving otherwise is another boat
            if o >= best_o and self.params.hand_over_size_ratio > 0 and (
                    b[2] * b[3] > self.params.hand_over_size_ratio * lb[2] * lb[3]):
                continue  # session 21: a small boat's identity is not given to a much larger one
            if o >= best_o and self.params.hand_over_height_ratio > 0 and (
                    b[3] > self.params.hand_over_height_ratio * lb[3]):
                continue  # the same by the heights
            if o >= best_o and self.params.far_id_px > 0 and self._far_apart(b, lb):
                continue  # session 26 round 2 (H25): not across the far strip's line
            if o >= best_o:
                best, best_o = i, o
        if best < 0:
            return None
        r = int(rep[best])
        self._alias[int(cids[best])] = k
        rep[best] = k
        now[k] = now.pop(r)
        if r in own:
            own[k] = own.pop(r)
        del self._lost[k]
        self._lost_dir.pop(k, None)
        self._lost_alt.pop(k, None)
        self._lost_alt_dir.pop(k, None)
        return r

    @property
    def min_speed_px_s(self) -> float:
        """The speed below which a velocity sample counts as static now."""
        p = self.params
        floor = p.min_speed_px_s
        if p.known_min_speed_px_s > 0 and np.isfinite(self.camera_err_px_s) and self._cam_still:
            floor = min(max(p.known_err_k * self.camera_err_px_s, p.known_min_speed_px_s), p.min_speed_px_s)
        if not np.isfinite(self.noise_px_s):
            return floor
        return max(floor, p.noise_factor * self.noise_px_s)

    def _camera_error(self, snap: FeatureSnapshot, horizon) -> None:
        """Updates :attr:`camera_err_px_s`, the running error of the camera motion: the median
        speed relative to the camera of this frame's matched stable features above the horizon
        (the coast and the sky's edge, static), smoothed over the frames that have any
        (over ``params.known_err_tau_s`` seconds: the new frame's weight is
        ``1 - exp(-dt / tau)``); with ``params.known_still_px`` > 0 only in
        frames where the camera is still (:attr:`_cam_still`, set here)."""
        p = self.params
        self._cam_still = True
        if p.known_still_px > 0:
            h, w = snap.shape if snap.shape is not None else (0, 0)
            H = np.asarray(snap.homography, np.float64)
            c = np.array([w / 2.0, h / 2.0, 1.0])
            m = H @ c
            self._cam_still = bool(abs(m[2]) > 1e-12 and np.hypot(m[0] / m[2] - c[0], m[1] / m[2] - c[1]) < p.known_still_px)
            if not self._cam_still:
                return
        if horizon is None:
            return
        st = np.flatnonzero(snap.stable & snap.matched)
        if not len(st):
            return
        row = np.asarray(horizon.row_at(snap.xy[st, 0]), np.float64)
        up = st[np.isfinite(row) & (snap.xy[st, 1] < row)]
        if not len(up):
            return
        v = np.hypot(snap.velocity[up, 0], snap.velocity[up, 1])
        v = v[np.isfinite(v)]
        if not len(v):
            return
        e = float(np.median(v))
        dt = float(snap.dt_s) if np.isfinite(snap.dt_s) and snap.dt_s > 0 else 0.1
        a = 1.0 - float(np.exp(-dt / max(float(self.params.known_err_tau_s), 1e-9)))
        self.camera_err_px_s = e if not np.isfinite(self.camera_err_px_s) else (1 - a) * self.camera_err_px_s + a * e

    def update(self, snap: FeatureSnapshot, image: np.ndarray | None = None,
               horizon=None, zoom: float = 1.0, camera=None, ir: bool = False,
               grey: np.ndarray | None = None) -> tuple[Detections, Tracks]:
        """Cluster one frame's features; returns ``(Detections, Tracks)`` of the clusters.

        ``image`` (the frame, in the snapshot's pixels) lets ``params.grow_box`` > 0 grow each
        box to the object around its features (:func:`grow_boxes`); without it the boxes are
        the features' extent.  ``horizon`` (anything with ``row_at(x)``, in the snapshot's
        pixels) marks the water, from ``params.water_margin_px`` times ``zoom`` (the camera's
        zoom factor, 1 at its widest) below it: with ``params.still_radius_px`` > 0, still stable
        features there are clustered too (see :func:`frame_edges`).  The margin leaves out the
        foot of a distant coast, which lies a few pixels below the sea horizon.  ``ir`` says the
        frame is infrared (``params.top_frac_ir`` then replaces ``params.top_frac``).  ``grey``: the
        image's :func:`~seawatch.detect.features.to_grey_u8`, when the caller has it (it saves a
        conversion; otherwise it is made once here when a test needs it)."""
        p = self.params
        self._grey_in = grey
        self._top_frac = p.top_frac_ir if (ir and p.top_frac_ir is not None) else p.top_frac
        self._ir = bool(ir)
        # session 25 (helper H15): ``graph_cut_dv_px_s_ir`` replaces ``graph_cut_dv_px_s`` on infrared frames
        self.graph.cut_dv = p.graph_cut_dv_px_s_ir if (ir and p.graph_cut_dv_px_s_ir > 0) else p.graph_cut_dv_px_s
        # session 25 (helper H18): ``gate_ema_s_ir``, the gate's established cluster velocity, on infrared frames
        self.graph.gate_ema_s = p.gate_ema_s_ir if ir else 0.0
        self.graph.id_major = bool(ir and p.merge_id_major_ir)
        if horizon is None and getattr(snap, "horizon", None) is not None:
            horizon, zoom = snap.horizon, float(getattr(snap, "zoom", 1.0))
        nz = getattr(snap, "noise_px_s", float("nan"))
        if np.isfinite(nz):  # running estimate of the static features' velocity noise
            self.noise_px_s = nz if not np.isfinite(self.noise_px_s) else 0.9 * self.noise_px_s + 0.1 * nz
        if p.known_min_speed_px_s > 0:
            self._camera_error(snap, horizon)
        st = np.flatnonzero(snap.stable)
        still = None
        if horizon is not None and p.still_radius_px > 0 and len(st):
            row = np.asarray(horizon.row_at(snap.xy[st, 0]), np.float64)
            still = np.isfinite(row) & (snap.xy[st, 1] > row + p.water_margin_px * max(float(zoom), 1e-3))
            if p.far_top_px > 0:
                far = _far_still(snap.xy[st], row, max(float(zoom), 1e-3), p)
                if p.far_open_px > 0 and image is not None and far.any():
                    fi = np.flatnonzero(far)
                    far[fi[~_far_open(self._grey_of(image), snap.xy[st][fi, 0], horizon, max(float(zoom), 1e-3),
                                      p)]] = False
                still |= far
        floor = self.min_speed_px_s
        if p.known_band_px > 0 and floor < p.min_speed_px_s and len(st):
            # the lowered floor only near the horizon; elsewhere the floor without this step
            full = p.min_speed_px_s if not np.isfinite(self.noise_px_s) else \
                max(p.min_speed_px_s, p.noise_factor * self.noise_px_s)
            near = np.zeros(len(st), bool)
            if horizon is not None:
                hr = np.asarray(horizon.row_at(snap.xy[st, 0]), np.float64)
                with np.errstate(invalid="ignore"):
                    near = np.isfinite(hr) & (snap.xy[st, 1] < hr + p.known_band_px * max(float(zoom), 1e-3))
            floor = np.where(near, floor, full)
        ei, ej, _ = frame_edges(snap.xy[st], snap.history[st], p.dmax, p.radius_px, p.p_px, p.frame_interval_s,
                                floor, still, p.still_radius_px)
        if ((p.far_cut_px > 0 or p.far_cut_deep_px > 0) and horizon is not None and len(ei)
                and (p.far_cut_ir or not ir)):
            keep = _far_cut(snap.xy[st], ei, ej, horizon, max(float(zoom), 1e-3), p)
            ei, ej = ei[keep], ej[keep]
        # indices into the snapshot
        vel = None
        if p.merge_dv_px_s > 0:
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                vel = np.nanmean(snap.history, axis=1)  # recent velocity relative to the scene
        gate_dv = p.gate_dv_px_s if p.gate_dv_px_s > 0 and p.merge_dv_px_s > 0 else p.merge_dv_px_s
        if ir and p.gate_dv_px_s_ir > 0 and p.merge_dv_px_s > 0:
            # session 25 (helper H18): the velocity gate's threshold on infrared frames
            gate_dv = p.gate_dv_px_s_ir
        labels, cids = self.graph.step(snap.slots, snap.ids, st[ei], st[ej], snap.t_s, active=snap.stable,
                                       velocity=vel, max_dv_px_s=gate_dv,
                                       min_age_s=p.confirm_s)
        self._apart = set()
        if p.split_dv_px_s > 0 and len(cids):
            labels, cids = self._split_for_report(snap, labels, cids)
        self.last_labels = labels
        self._camera = camera
        self._zoom = max(float(zoom), 1e-3)
        self._horizon = horizon
        return self._outputs(snap, labels, cids, image)

    def _grey_of(self, image):
        """``to_grey_u8(image)`` for this :meth:`update`, made at most once (session 29: the far-open
        and coast-foot tests made it each; the stage passes the extractor's)."""
        if getattr(self, "_grey_in", None) is None:
            self._grey_in = to_grey_u8(image)
        return self._grey_in

    def _outputs(self, snap: FeatureSnapshot, labels: np.ndarray, cids: np.ndarray, image=None):
        p = self.params
        n = len(cids)
        t, fi = snap.t_s, snap.frame_index
        dts = float(getattr(snap, "dt_s", float("nan")))
        if np.isfinite(dts) and dts > 0:
            self._dts = (self._dts + [dts])[-9:]
        self._joined_ids = set()
        self._joined_apart = set()
        if n == 0:
            self._merged = []
            self._last_fi = fi
            tracks = Tracks.empty(t, fi, self.source, self.camera_id)
            if p.relink_s > 0:
                self._app_img = image if p.relink_appearance else None
                self._relink(snap, cids, np.zeros((0, 4)))
                if p.coast_s > 0:
                    tracks = self._with_coasts(tracks, snap, image)
            return Detections.empty(t, fi, self.source, self.camera_id), tracks
        m = labels >= 0
        k = np.searchsorted(cids, labels[m])
        xy = snap.xy[m]
        self._cluster_boxes_now = self._last_fi
        self._last_fi = fi
        r = p.box_pad * 0.5 * snap.size_px[m]
        fv_m = []  # each member's velocity relative to the scene (the mean of its history), computed once

        def member_velocity():
            if not fv_m:
                with np.errstate(invalid="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    fv_m.append(np.nanmean(snap.history[m], axis=1))
            return fv_m[0]

        if p.box_dv_px_s > 0:
            # the box is drawn around the members that move with the cluster
            fv = member_velocity()
            dv = p.box_dv_px_s
            if p.box_dv_noise_k > 0 and np.isfinite(self.noise_px_s):
                dv = max(dv, p.box_dv_noise_k * self.noise_px_s)
            anchor = self._box_anchor(snap, cids, k, xy) if p.box_keep_last else None
            inb = _box_members(k, fv, n, dv, anchor)
            if self._ir and p.box_anchor_far_h_ir > 0 and anchor is not None:
                inb = self._anchor_far_out(k, n, inb, anchor, p.box_anchor_far_h_ir, xy[:, 0], cids)
        else:
            inb = None
        if p.box_disp_s > 0:
            # the box is drawn around the members that moved with the cluster over box_disp_s
            self._disp_anchor = anchor if p.box_dv_px_s > 0 else None
            keep = self._disp_members(snap, m, k, n, inb)
            inb = keep if inb is None else inb & keep
        wake_below = p.box_wake_below_px_ir if (self._ir and p.box_wake_below_px_ir is not None) else p.box_wake_below_px
        if wake_below > 0:
            # session 24: the members below and behind a small moving cluster's front one (its wake's foam)
            inb = self._wake_below_members(k, xy, n, inb, member_velocity(), wake_below)
        if inb is not None:
            kb, xyb, rb = k[inb], xy[inb], r[inb]
        else:
            kb, xyb, rb = k, xy, r
        x0 = np.full(n, np.inf)
        y0 = np.full(n, np.inf)
        x1 = np.full(n, -np.inf)
        y1 = np.full(n, -np.inf)
        np.minimum.at(x0, kb, xyb[:, 0] - rb)
        np.minimum.at(y0, kb, xyb[:, 1] - rb)
        np.maximum.at(x1, kb, xyb[:, 0] + rb)
        np.maximum.at(y1, kb, xyb[:, 1] + rb)
        if self._ir and p.grow_core_q_ir > 0 and p.grow_core_box_ir and len(kb):
            # the box before the growing (reported where the growing fails): the members' inner
            # quantiles padded by the largest radius, within the full extent
            rmax = np.zeros(n)
            np.maximum.at(rmax, kb, rb)
            qx0, qx1 = _core_quantiles(kb, xyb[:, 0], n, p.grow_core_q_ir, x0, x1)
            qy0, qy1 = _core_quantiles(kb, xyb[:, 1], n, p.grow_core_q_ir, y0, y1)
            has = np.bincount(kb, minlength=n) > 0
            x0 = np.where(has, np.maximum(x0, qx0 - rmax), x0)
            x1 = np.where(has, np.minimum(x1, qx1 + rmax), x1)
            y0 = np.where(has, np.maximum(y0, qy0 - rmax), y0)
            y1 = np.where(has, np.minimum(y1, qy1 + rmax), y1)
        if snap.shape is not None:
            h, w = snap.shape
            x0, x1 = np.clip(x0, 0, w), np.clip(x1, 0, w)
            y0, y1 = np.clip(y0, 0, h), np.clip(y1, 0, h)
        boxes = np.stack([x0, y0, x1 - x0, y1 - y0], axis=1)
        self.last_contrast = None
        if image is not None and p.grow_box > 0:
            cx0 = np.full(n, np.inf)
            cy0 = np.full(n, np.inf)
            cx1 = np.full(n, -np.inf)
            cy1 = np.full(n, -np.inf)
            np.minimum.at(cx0, kb, xyb[:, 0])
            np.minimum.at(cy0, kb, xyb[:, 1])
            np.maximum.at(cx1, kb, xyb[:, 0])
            np.maximum.at(cy1, kb, xyb[:, 1])
            cores_retry = None
            if self._ir and p.grow_core_q_ir > 0 and len(kb):
                # the core is the members' inner quantiles (a thermal halo's features at the rim)
                qx0, qx1 = _core_quantiles(kb, xyb[:, 0], n, p.grow_core_q_ir, cx0, cx1)
                qy0, qy1 = _core_quantiles(kb, xyb[:, 1], n, p.grow_core_q_ir, cy0, cy1)
                if p.grow_core_retry_ir:  # only where the full extent fails
                    cores_retry = np.stack([qx0, qy0, qx1 - qx0, qy1 - qy0], axis=1)
                    cores_retry[~np.isfinite(cores_retry).all(axis=1)] = np.nan
                else:
                    cx0, cx1, cy0, cy1 = qx0, qx1, qy0, qy1
            img = np.asarray(image)
            if img.dtype != np.uint8:
                img = to_grey_u8(img)
            trail = sign_side = None
            if p.wake_frac > 0 or (p.grow_sign != 0 and p.grow_sign_trail_px_s > 0):
                # a wake trails behind a boat moving across the image (relative to the scene):
                # the box members' mean velocity
                fvb = member_velocity()
                fvb = fvb[inb] if inb is not None else fvb
                okv = np.isfinite(fvb).all(axis=1)
                vx = np.zeros(n)
                np.add.at(vx, kb[okv], fvb[okv, 0])
                vx /= np.maximum(np.bincount(kb[okv], minlength=n), 1)
                if p.wake_frac > 0:
                    trail = np.where(np.abs(vx) >= p.wake_min_px_s, -np.sign(vx), 0).astype(np.int64)
                    if p.wake_track_s > 0:
                        # session 26 (H23): where the members are too slow (on the wake's foam), the
                        # trailing side from the motion of the cluster's own box over the last seconds
                        tv = self._track_vx(snap, cids)
                        if self._ir and not p.wake_track_ir:
                            tv[:] = np.nan
                        thr = p.wake_track_px_s if p.wake_track_px_s > 0 else p.wake_min_px_s
                        fill = (trail == 0) & np.isfinite(tv) & (np.abs(tv) >= thr)
                        trail[fill] = -np.sign(tv[fill]).astype(np.int64)
                    if p.wake_hold_s > 0 and not (self._ir and not p.wake_track_ir):
                        # session 26 (H23): a cluster whose members slow down under wake_min_px_s (they
                        # moved onto the wake's foam) keeps its last trailing side for wake_hold_s
                        t_now = float(snap.t_s)
                        last = {c: v for c, v in self._trail_last.items() if t_now - v[0] <= p.wake_hold_s}
                        for i, c in enumerate(cids):
                            if trail[i] != 0:
                                last[int(c)] = (t_now, int(trail[i]))
                            elif int(c) in last:
                                trail[i] = last[int(c)][1]
                        self._trail_last = last
                if p.grow_sign != 0 and p.grow_sign_trail_px_s > 0:  # the sign rule only on the wake's side
                    sign_side = np.where(np.abs(vx) >= p.grow_sign_trail_px_s, -np.sign(vx), 0).astype(np.int64)
            pre_grow = boxes
            hints = None
            if p.grow_hint and self._grown_last and self._grown_last_t == self._cluster_boxes_now:
                # each cluster's box grown in the frame before, carried by the camera motion
                hmg = np.asarray(snap.homography, np.float64)
                hints = np.full((n, 4), np.nan)
                for i, c in enumerate(cids):
                    hb = self._grown_last.get(int(c))
                    if hb is not None:
                        hints[i] = _carry_box(hb, hmg) if np.all(np.isfinite(hmg)) else hb
            cores_now = np.stack([cx0, cy0, cx1 - cx0, cy1 - cy0], axis=1)
            wcore = p.wake_core_ir if (self._ir and p.wake_core_ir is not None) else p.wake_core
            boxes, self.last_contrast, found = grow_boxes(
                img, boxes, cores_now, grow=p.grow_box,
                peak_frac=p.grow_peak_frac, return_contrast=True, wide_grow_px=p.grow_wide_px,
                waterline_frac=p.waterline_frac, wake_frac=p.wake_frac, trail=trail, top_frac=self._top_frac,
                cut_core_frac=p.cut_core_frac, cut_core_undo=p.cut_core_undo, wake_thick=p.wake_thick,
                sign_frac=p.grow_sign, sign_max_px=p.grow_sign_max_px, sign_side=sign_side, return_found=True,
                cover_wide=p.grow_cover_wide, hints=hints, hint_pad_px=p.grow_hint_pad_px,
                hint_core=p.grow_hint_core, hint_core_x=p.grow_hint_core_x,
                top_halo=p.top_halo_ir if self._ir else 0.0, cores_retry=cores_retry, top_min_px=p.top_min_px,
                wake_core=p.wake_core_ir if (self._ir and p.wake_core_ir is not None) else p.wake_core,
                wake_front=0.0 if (self._ir and not p.wake_track_ir) else p.wake_front)
            if p.wake_core_iou > 0 and wcore > 0 and p.wake_frac > 0 and trail is not None:
                # session 26 (H26): a wake_core cut that moves the box off the cluster's box of the frame
                # before (carried by the camera) is undone: the box grown again with the all-columns reference
                boxes, found = self._wake_core_guard(snap, fi, cids, img, pre_grow, cores_now, boxes, found, trail,
                                                     sign_side, hints, cores_retry)
            if self._ir and p.grow_core_in_ir > 0 and found.any():
                # session 31 (h41): a grown box holding too little of its core is not kept (a passing hull)
                bad = found & (_inside_frac_many(cores_now, boxes) < p.grow_core_in_ir)
                if bad.any():
                    back = pre_grow
                    if p.grow_core_hint_ir > 0 and hints is not None:
                        # the box grown in the frame before (carried), where it holds the core
                        okh = np.isfinite(hints).all(axis=1)
                        okh &= _inside_frac_many(cores_now, np.where(okh[:, None], hints, 0.0)) >= p.grow_core_hint_ir
                        back = np.where(okh[:, None], hints, pre_grow)
                        bad_keep = bad & okh
                    else:
                        bad_keep = np.zeros_like(bad)
                    boxes = np.where(bad[:, None], back, boxes)
                    found = found & ~(bad & ~bad_keep)
            if p.wake_track_s > 0 and p.wake_frac > 0:
                self._track_store(snap, cids, boxes)
            if p.grow_hint:
                self._grown_last = {int(c): boxes[i].copy() for i, c in enumerate(cids) if found[i]}
                self._grown_last_t = fi
            trail_max = p.grow_trail_max_ir if (self._ir and p.grow_trail_max_ir is not None) else p.grow_trail_max
            if trail_max > 0 and trail is not None:
                # session 25 (H14): a small moving cluster's box not far beyond its features on its trailing side
                for i in np.flatnonzero(found & (trail != 0)):
                    b, q = boxes[i], pre_grow[i]
                    if p.grow_trail_max_h_px > 0 and b[3] > p.grow_trail_max_h_px * self._zoom:
                        continue
                    ext = trail_max * max(q[2], b[3])
                    x0, x1 = b[0], b[0] + b[2]
                    if trail[i] < 0:
                        x0 = max(x0, min(q[0] - ext, x1 - 1.0))
                    else:
                        x1 = min(x1, max(q[0] + q[2] + ext, x0 + 1.0))
                    boxes[i, 0], boxes[i, 2] = x0, x1 - x0
            if p.grow_jump > 0:
                # session 25 (H14): no sudden growth beyond the box grown in the frame before
                raw = boxes.copy()
                if self._jump_last and self._jump_last_t == self._cluster_boxes_now:
                    hmg = np.asarray(snap.homography, np.float64)
                    fin = bool(np.all(np.isfinite(hmg)))
                    for i, c in enumerate(cids):
                        hb = self._jump_last.get(int(c))
                        if found[i] and hb is not None:
                            hb = _carry_box(hb, hmg) if fin else hb
                            if p.grow_jump_max_h_px <= 0 or hb[3] <= p.grow_jump_max_h_px * self._zoom:
                                boxes[i] = _limit_jump(boxes[i], pre_grow[i], hb, p.grow_jump)
                src = boxes if p.grow_jump_keep else raw
                self._jump_last = {int(c): src[i].copy() for i, c in enumerate(cids) if found[i]}
                self._jump_last_t = fi
        if p.size_filter_s > 0:
            grown = None
            if p.size_filter_grown and image is not None and p.grow_box > 0:
                grown = np.any(boxes != pre_grow, axis=1)  # the boxes that the growing changed
            boxes = self._size_filter(snap, cids, boxes, grown)
        if p.box_keep_last:
            if self._ir and p.box_anchor_gap_steady_ir and p.box_anchor_gap_side_ir > 0:
                # session 32 (h47): the clusters whose box overlaps their box of the frame before
                prev = self._cluster_boxes if self._cluster_boxes_t == self._cluster_boxes_now else {}
                nan4 = (np.nan,) * 4
                lb = np.array([prev.get(int(c), nan4) for c in cids], np.float64).reshape(-1, 4)
                with np.errstate(invalid="ignore"):
                    iw = np.minimum(boxes[:, 0] + boxes[:, 2], lb[:, 0] + lb[:, 2]) - np.maximum(boxes[:, 0], lb[:, 0])
                    ih = np.minimum(boxes[:, 1] + boxes[:, 3], lb[:, 1] + lb[:, 3]) - np.maximum(boxes[:, 1], lb[:, 1])
                    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
                    union = boxes[:, 2] * boxes[:, 3] + lb[:, 2] * lb[:, 3] - inter
                    st = inter >= 0.1 * union
                self._cluster_steady = {int(c) for c, ok in zip(cids, st) if ok}
            self._cluster_boxes = {int(c): boxes[i].copy() for i, c in enumerate(cids)}
            self._cluster_boxes_t = fi
        count = np.bincount(k, minlength=n)
        iv = snap.image_velocity[m]
        ok = np.isfinite(iv).all(axis=1)
        vsum = np.zeros((n, 2))
        np.add.at(vsum, k[ok], iv[ok])
        vn = np.bincount(k[ok], minlength=n)
        vel = np.where(vn[:, None] > 0, vsum / np.maximum(vn, 1)[:, None], 0.0)
        keep_c = None
        if self.last_contrast is not None and p.min_contrast > 0:
            # a cluster that does not stand out from its surroundings is not reported
            ok = ~(self.last_contrast < p.min_contrast)
            cids, boxes, count, vel = cids[ok], boxes[ok], count[ok], vel[ok]
            keep_c = ok
        if self._horizon is not None and p.sky_margin_px > 0 and len(cids):
            # a boat floats: its box reaches the water, so a box whose bottom lies above the
            # horizon (a cloud, a bird, the coast) is not reported
            row = np.maximum(*(np.asarray(self._horizon.row_at(x), np.float64)
                               for x in (boxes[:, 0], boxes[:, 0] + boxes[:, 2])))
            ok = ~(boxes[:, 1] + boxes[:, 3] < row - p.sky_margin_px * self._zoom)
            cids, boxes, count, vel = cids[ok], boxes[ok], count[ok], vel[ok]
            keep_c = ok if keep_c is None else np.flatnonzero(keep_c)[ok]
        if p.max_aspect > 0 and len(cids):
            # a box many times wider than tall is a line (the foot of a coast, the horizon), not a boat
            ok = ~(boxes[:, 2] > p.max_aspect * np.maximum(boxes[:, 3], 1e-9))
            cids, boxes, count, vel = cids[ok], boxes[ok], count[ok], vel[ok]
            if keep_c is None:
                keep_c = ok
            else:  # a mask over the clusters, or the indices kept so far
                keep_c = (np.flatnonzero(keep_c) if keep_c.dtype == bool else keep_c)[ok]
        if p.edge_min_w_px > 0 and snap.shape is not None and len(cids):
            # edge_min_w_px: a box clipped to a sliver at the image's side edge has left the view
            w_img = float(snap.shape[1])
            ok = ~((boxes[:, 2] < p.edge_min_w_px) & ((boxes[:, 0] <= 0.0) | (boxes[:, 0] + boxes[:, 2] >= w_img)))
            cids, boxes, count, vel = cids[ok], boxes[ok], count[ok], vel[ok]
            if keep_c is None:
                keep_c = ok
            else:
                keep_c = (np.flatnonzero(keep_c) if keep_c.dtype == bool else keep_c)[ok]
        if p.foot_open_px > 0 and image is not None and self._horizon is not None and len(cids):
            # a cluster wholly inside the water margin with no open sea beside it: the foot of a coast
            idx = np.arange(n) if keep_c is None else (np.flatnonzero(keep_c) if keep_c.dtype == bool else keep_c)
            ok = ~_coast_foot(xy, k, n, boxes, idx, self._grey_of(image), self._horizon, self._zoom, p)
            cids, boxes, count, vel = cids[ok], boxes[ok], count[ok], vel[ok]
            keep_c = idx[ok]
        if p.merge_overlap > 0 and len(cids) > 1:
            rv = None
            if p.merge_gap_h > 0 or p.merge_keep > 0 or p.merge_id_dv_px_s > 0:
                fv = member_velocity()  # each member's velocity relative to the scene
                okv = np.isfinite(fv).all(axis=1)
                rs = np.zeros((n, 2))
                np.add.at(rs, k[okv], fv[okv])
                rn = np.bincount(k[okv], minlength=n)
                rv = np.where(rn[:, None] > 0, rs / np.maximum(rn, 1)[:, None], np.nan)
                if keep_c is not None:
                    rv = rv[keep_c]
            sticky = self._sticky_pairs(snap, labels, cids, boxes) if p.merge_keep > 0 else None
            # each cluster's velocity relative to the scene, before the merge (coast_skip_merged_dv)
            rv_of = {} if rv is None else {int(c): rv[i] for i, c in enumerate(cids)}
            skip_dv = p.coast_skip_merged_dv if p.coast_skip_merged_dv > 0 else np.inf
            if p.coast_skip_merged_zoom:
                skip_dv *= self._zoom
            groups = []
            prev = None
            if p.merge_id_keep_iou > 0 and self._report_last and self._report_last_t == self._cluster_boxes_now:
                # each report's box in the frame before, carried by the camera motion
                hmg = np.asarray(snap.homography, np.float64)
                fin = bool(np.all(np.isfinite(hmg)))
                prev = {c: (_carry_box(b, hmg) if fin else b) for c, b in self._report_last.items()}
            cids, boxes, count, vel = _merge_overlapping(cids, boxes, count, vel, p.merge_overlap, rv,
                                                         p.merge_gap_h, p.merge_dv_px_s, p.merge_gap_min_px,
                                                         sticky, groups, p.merge_keep_gap_px * self._zoom,
                                                         p.merge_keep_gap_h, self._apart or None,
                                                         p.merge_id_dv_px_s * self._zoom, p.merge_id_ratio,
                                                         p.merge_id_apart or (self._ir and p.merge_id_apart_ir),
                                                         prev, p.merge_id_keep_iou,
                                                         p.merge_id_now_iou_ir if self._ir else 0.0,
                                                         keep_now_any=self._ir and p.merge_id_now_any_ir)
            if p.merge_id_keep_iou > 0:
                self._report_last = {int(c): boxes[i].copy() for i, c in enumerate(cids)}
                self._report_last_t = fi
            self._merged = [(snap.ids[np.isin(labels, g)], boxes[i].copy()) for i, g in enumerate(groups) if len(g) > 1]
            self._merged_t = t
            # session 20 (coast_skip_merged): the identities of the clusters joined into another's report
            self._joined_ids = {self._alias.get(int(c), int(c)) for g in groups if len(g) > 1 for c in g[1:]
                                if _moves_alike(rv_of.get(int(g[0])), rv_of.get(int(c)), skip_dv)}
            if p.merge_id_dv_px_s > 0:
                # session 21 (H3): a cluster joined into the report of a cluster moving otherwise is
                # another boat behind or in front of it: its identity is not handed over to that report
                id_dv = p.merge_id_dv_px_s * self._zoom
                self._joined_apart = {self._alias.get(int(c), int(c)) for g in groups if len(g) > 1
                                      for c in g[1:] if not _moves_alike(rv_of.get(int(g[0])), rv_of.get(int(c)), id_dv)}
        else:
            self._merged = []
        if p.relink_s > 0:
            self._app_img = image if p.relink_appearance else None
            ids = self._relink(snap, cids, boxes, vel)
            for r in ids:
                self._birth.setdefault(int(r), t)
            births = np.array([self._birth[int(r)] for r in ids])
            if len(self._birth) > 4 * max(len(ids) + len(self._lost), 16):
                keep = set(int(r) for r in ids) | set(self._lost)
                self._birth = {k: v for k, v in self._birth.items() if k in keep}
        else:
            ids = cids
            births = np.array([self.graph.birth_s.get(int(c), t) for c in cids])
        ages = t - births
        states = np.where(ages >= p.confirm_s - 1e-9, int(TrackState.CONFIRMED), int(TrackState.TENTATIVE))
        if p.relink_hold_s > 0 and p.relink_s > 0 and self._hold and len(ids):
            # relink_hold_s (session 27, h32): held young fragments are not reported yet
            states = np.where(np.isin(np.asarray(ids, dtype=np.int64), np.fromiter(self._hold, np.int64)),
                              int(TrackState.TENTATIVE), states)
        scores = 1.0 - np.exp(-count / 5.0)
        dets = Detections(t, fi, boxes, scores, self.source, self.camera_id)
        tracks = Tracks(t, fi, ids, boxes, vel, states, ages, self.source, self.camera_id)
        if p.coast_s > 0 and p.relink_s > 0:
            tracks = self._with_coasts(tracks, snap, image)
        return dets, tracks

    def _with_coasts(self, tracks: Tracks, snap: FeatureSnapshot, image=None) -> Tracks:
        """``tracks`` with the coasting identities appended (:meth:`_coast`)."""
        present = set(int(i) for i in tracks.ids)
        if self.params.coast_skip_merged:  # a cluster joined into another's report: its boat is in that report
            present |= self._joined_ids
        ids, boxes, vel = self._coast(snap, tracks.boxes, image, present)
        if not len(ids):
            return tracks
        t = snap.t_s
        ages = np.array([t - self._birth.get(int(k), t) for k in ids])
        return Tracks(t, snap.frame_index, np.concatenate([tracks.ids, ids]),
                      np.concatenate([tracks.boxes, boxes]), np.concatenate([tracks.velocities, vel]),
                      np.concatenate([tracks.states, np.full(len(ids), int(TrackState.COASTING), np.int8)]),
                      np.concatenate([tracks.ages_s, ages]), self.source, self.camera_id)

    def _coast(self, snap: FeatureSnapshot, reported: np.ndarray, image=None, present=frozenset()):
        """``params.coast_s``: the identities to report although no cluster carries them now
        (not in the paper, session 19).  A reported identity lost (see :meth:`_relink`) less than
        ``coast_s`` ago, after it had been reported for at least ``coast_min_age_s``, is reported
        at the box where the relink expects it (its last box carried by the camera's motion, or
        its corners' directions projected through this frame's camera), when that box's centre
        lies in the image and no more than ``coast_overlap`` of it lies in one of this frame's
        reports (``reported``: the boat is then most likely in that report); with
        ``coast_inside_big`` a report more than ``coast_size_ratio`` times the box's area does not
        count (it holds more than this boat: a still boat swallowed by a neighbour's report).  A coast that fails
        one of these checks ends until the identity is found and lost again (a report that came
        and went would swap identities with a neighbour's).  An identity in
        ``present`` (reported now: a cluster identity back through the graph's label memory) is
        not coasted.

        With ``coast_check`` (without the frame's ``image`` nothing is coasted then), the box is grown to the object at that
        place (:func:`grow_boxes`, from the middle half of the expected box as the core) and
        reported only when the object stands out (contrast at least ``min_contrast``), was found
        (the growing succeeded) and its area lies within ``coast_size_ratio`` of the expected
        box's either way: a boat whose features dropped out is still seen, open water is not.
        With ``coast_follow`` the grown box becomes the identity's expected box from then on, so
        the report follows the boat's own motion (otherwise only the camera's motion moves it).
        Session 22: with ``coast_search`` a failed grow looks around the expected box
        (:meth:`_coast_search`); with ``coast_retry_s`` a failed grow does not end the coast until
        it has failed that long in a row (the identity is not reported while it fails).

        Returns ``(ids, boxes, velocities)``; the velocities are the identity's own velocity when
        it was lost (px/s, 0 when unknown)."""
        p = self.params
        t = snap.t_s
        cand = []
        for k, (tl, lb, v) in self._lost.items():
            born = self._birth.get(k)
            if (k in present or t - tl > p.coast_s + 1e-9 or born is None
                    or tl - born < p.coast_min_age_s - 1e-9 or self._coast_end.get(k) == tl):
                continue
            cand.append((k, np.asarray(lb, np.float64), np.zeros(2) if v is None else np.nan_to_num(v)))
        empty = (np.zeros(0, np.int64), np.zeros((0, 4)), np.zeros((0, 2)))
        if not cand:
            return empty
        ids = np.array([c[0] for c in cand], np.int64)
        lbs = np.stack([c[1] for c in cand])
        vel = np.stack([c[2] for c in cand])
        ok = np.all(np.isfinite(lbs), axis=1) & (lbs[:, 2] > 0) & (lbs[:, 3] > 0)
        cx, cy = lbs[:, 0] + 0.5 * lbs[:, 2], lbs[:, 1] + 0.5 * lbs[:, 3]
        if snap.shape is not None:
            hh, ww = snap.shape
            ok &= (cx >= 0) & (cx < ww) & (cy >= 0) & (cy < hh)
        why = np.where(ok, "reported", "outside").astype(object)
        if len(reported) and p.coast_overlap < 1:
            r = np.asarray(reported, np.float64).reshape(-1, 4)
            iw = (np.minimum(lbs[:, None, 0] + lbs[:, None, 2], r[None, :, 0] + r[None, :, 2])
                  - np.maximum(lbs[:, None, 0], r[None, :, 0]))
            ih = (np.minimum(lbs[:, None, 1] + lbs[:, None, 3], r[None, :, 1] + r[None, :, 3])
                  - np.maximum(lbs[:, None, 1], r[None, :, 1]))
            inside = np.maximum(iw, 0) * np.maximum(ih, 0) / np.maximum(lbs[:, 2] * lbs[:, 3], 1e-9)[:, None]
            if p.coast_inside_big:  # a report much larger than the box holds two objects: not this one alone
                big = r[None, :, 2] * r[None, :, 3] > p.coast_size_ratio * (lbs[:, 2] * lbs[:, 3])[:, None]
                inside = np.where(big, 0.0, inside)
            over = ok & (inside.max(axis=1) > p.coast_overlap)
            why[over] = "overlap"
            ok &= ~over
        if p.coast_check and image is None:
            ok[:] = False  # nothing to check against (e.g. the parameter sweep): no coast
            why[:] = "no image"
        if p.coast_check and image is not None and ok.any():
            img = np.asarray(image)
            if img.dtype != np.uint8:
                img = to_grey_u8(img)
            sel = np.flatnonzero(ok)
            b = lbs[sel]
            cores = np.stack([b[:, 0] + 0.25 * b[:, 2], b[:, 1] + 0.25 * b[:, 3], 0.5 * b[:, 2], 0.5 * b[:, 3]],
                             axis=1)
            grown, contrast, found = grow_boxes(img, b, cores, grow=max(p.grow_box, 0.5),
                                                peak_frac=p.grow_peak_frac, return_found=True,
                                                wide_grow_px=p.grow_wide_px, waterline_frac=p.waterline_frac,
                                                top_frac=self._top_frac)
            ratio = (grown[:, 2] * grown[:, 3]) / np.maximum(b[:, 2] * b[:, 3], 1e-9)
            good = (found & (contrast >= p.min_contrast) & (ratio <= p.coast_size_ratio)
                    & (ratio >= 1.0 / p.coast_size_ratio))
            if p.coast_grow_up > 0:
                # session 23 (H5): the expected box was a fragment of the hull (a faint small boat's
                # cluster held part of it): a grown box up to coast_grow_up times larger that holds
                # the expected box is the boat
                ix = np.maximum(np.minimum(b[:, 0] + b[:, 2], grown[:, 0] + grown[:, 2]) - np.maximum(b[:, 0], grown[:, 0]), 0)
                iy = np.maximum(np.minimum(b[:, 1] + b[:, 3], grown[:, 1] + grown[:, 3]) - np.maximum(b[:, 1], grown[:, 1]), 0)
                held = ix * iy >= 0.8 * b[:, 2] * b[:, 3]
                if len(reported):  # not onto a boat reported now (ir 7: a sailboat's coast grown onto the ferry)
                    held &= ~_covers_a_report(grown, reported)
                good |= (found & (contrast >= p.min_contrast) & (ratio > p.coast_size_ratio)
                         & (ratio <= p.coast_grow_up) & held)
            if p.coast_max_aspect and p.max_aspect > 0:  # a line (the horizon's texture), as for live reports
                good &= ~(grown[:, 2] > p.max_aspect * np.maximum(grown[:, 3], 1e-9))
            up = np.zeros(len(sel), bool)
            if p.coast_look_up > 0 and not (found | good).all():
                # session 24 (H10): not found at the expected box (the hull alone): the box extended up
                miss = np.flatnonzero(~found & ~good)
                g3, ok3 = self._coast_look_up(img, b[miss], reported)
                grown[miss[ok3]] = g3[ok3]
                found[miss[ok3]] = True
                contrast[miss[ok3]] = np.inf
                good[miss[ok3]] = True
                up[miss[ok3]] = True
            ahead = np.zeros(len(sel), bool)
            vx = vel[sel, 0]
            if p.coast_look_ahead > 0 and not (found | good | (np.abs(vx) < 1.0)).all():
                # session 24 (H10): not found where the camera carried the box: looked at ahead of it
                miss = np.flatnonzero(~found & ~good & (np.abs(vx) >= 1.0))
                g4, ok4 = self._coast_look_ahead(img, b[miss], np.sign(vx[miss]), reported)
                grown[miss[ok4]] = g4[ok4]
                found[miss[ok4]] = True
                contrast[miss[ok4]] = np.inf
                good[miss[ok4]] = True
                ahead[miss[ok4]] = True
            searched = np.zeros(len(sel), bool)
            if p.coast_search > 0 and not good.all():  # session 22: look around the expected place
                bad = np.flatnonzero(~good)
                g2, ok2 = self._coast_search(img, b[bad], reported)
                grown[bad[ok2]] = g2[ok2]
                found[bad[ok2]] = True
                contrast[bad[ok2]] = np.inf
                good[bad[ok2]] = True
                searched[bad[ok2]] = True
            ok[sel] = good
            why[sel] = np.where(~found, "not found", np.where(~(contrast >= p.min_contrast), "contrast",
                                                              np.where(good, "reported", "size")))
            why[sel[searched]] = "searched"  # coast_search: reported at a box found around the expected place
            why[sel[up]] = "up"  # coast_look_up: reported at the box grown from the expected box extended up
            why[sel[ahead]] = "ahead"  # coast_look_ahead: reported at the box grown ahead of the expected box
            lbs[sel] = np.where(good[:, None], grown, b)
            if p.coast_follow:
                for j in np.flatnonzero(good):
                    k = int(ids[sel[j]])
                    tl, _, v = self._lost[k]
                    self._lost[k] = (tl, grown[j].copy(), v)
                    self._lost_dir.pop(k, None)  # the grown box is where it is now, not the lost corners
                    if p.coast_drop_alt:  # session 25 (H17): nor where it was expected before a relink undone
                        self._lost_alt.pop(k, None)
                        self._lost_alt_dir.pop(k, None)
        edge = wait = np.zeros(len(ids), bool)  # coast_edge: outside to the left or right, its rows in the image
        if p.coast_edge > 0 and snap.shape is not None:
            hh, ww = snap.shape
            edge = (why == "outside") & ((cx < 0) | (cx >= ww)) & (cy >= 0) & (cy < hh)
            wait = edge.copy()  # outside: waits for the boat (not ended while it is not seen)
            # a look that failed at a box on the image's side (the boat straddles it): looked at the edge
            edge |= (np.isin(why, ("not found", "contrast", "size")) & ((lbs[:, 0] < 1.0)
                                                                         | (lbs[:, 0] + lbs[:, 2] > ww - 1.0)))
            if p.coast_edge_s > 0:  # only this long after the loss (a boat back later may be another)
                tls = np.array([self._lost[int(k)][0] for k in ids], np.float64)
                if p.coast_edge_seen:  # session 25 (H19): this long after its coast was last seen
                    tls = np.array([max(tl, self._coast_seen.get(int(k), (None, tl))[1])
                                    if self._coast_seen.get(int(k), (None, 0.0))[0] == tl else tl
                                    for k, tl in zip(ids.tolist(), tls.tolist())], np.float64)
                edge &= t - tls <= p.coast_edge_s + 1e-9
                wait &= edge
            if p.coast_check and image is not None and edge.any():
                self._coast_edge_look(image, snap.shape, ids, lbs, ok, why, edge, reported, wait)
        if (p.coast_dup_iou > 0 or p.coast_live_iou > 0) and ok.any():
            self._coast_dedup(ids, lbs, ok, why, reported)
        self.coast_log.extend((t, int(k), lbs[j].copy(), str(why[j])) for j, k in enumerate(ids))
        if p.coast_dup_iou > 0 and p.coast_dup_seen:
            for j in np.flatnonzero(ok):  # reported now (the loss time keys it)
                self._coast_rep[int(ids[j])] = (self._lost[int(ids[j])][0], t)
            if len(self._coast_rep) > 2 * len(self._lost) + 16:
                self._coast_rep = {k: v for k, v in self._coast_rep.items() if k in self._lost}
        if p.coast_edge_horizon and self._horizon is not None and snap.shape is not None and len(ids):
            self._record_rows(ids, lbs, ok, why, snap.shape)
        if p.coast_edge_seen:
            for j in np.flatnonzero(ok):  # seen now (the loss time keys it: a new loss starts afresh)
                self._coast_seen[int(ids[j])] = (self._lost[int(ids[j])][0], t)
            if len(self._coast_seen) > 2 * len(self._lost) + 16:
                self._coast_seen = {k: v for k, v in self._coast_seen.items() if k in self._lost}
        low = None
        if p.coast_retry_s > 0 and p.coast_search_below_px > 0 and self._horizon is not None and len(ids):
            low = self._below_horizon(lbs)  # no retry in the horizon band (its texture comes and goes)
        for j in np.flatnonzero(~ok):  # a coast that failed a check has ended: no report back and forth
            k = int(ids[j])
            tl = self._lost[k][0]
            if (p.coast_outside_wait and why[j] == "outside") or (wait[j] and why[j] == "outside"):
                # session 23 (H5): a boat the pan took out of the view is looked at again when its
                # expected box comes back into the image (within coast_s of its loss)
                self._coast_fail.pop(k, None)
                continue
            if (p.coast_retry_s > 0 and why[j] in ("not found", "contrast", "size")
                    and (low is None or low[j])):
                # coast_retry_s: the grow's checks failed (a wave over a small boat, the boat off the
                # expected box for a frame): looked at again in the next frames, for this long
                tl0, tf = self._coast_fail.get(k, (None, None))
                if tl0 != tl:
                    tf = t
                    self._coast_fail[k] = (tl, t)
                if t - tf < p.coast_retry_s - 1e-9:
                    continue
            self._coast_end[k] = tl
        if p.coast_retry_s > 0:
            for j in np.flatnonzero(ok):  # a good look ends the run of failed ones
                self._coast_fail.pop(int(ids[j]), None)
            if len(self._coast_fail) > 2 * len(self._lost) + 16:
                self._coast_fail = {k: v for k, v in self._coast_fail.items() if k in self._lost}
        if len(self._coast_end) > 2 * len(self._lost) + 16:  # bounded memory
            self._coast_end = {k: v for k, v in self._coast_end.items() if k in self._lost}
        if not ok.any():
            return empty
        return ids[ok], lbs[ok], vel[ok]

    def _coast_dedup(self, ids, lbs, ok, why, reported):
        """``params.coast_live_iou`` / ``params.coast_dup_iou`` (session 27, h28): the coasts in ``ok``
        whose box ``lbs`` overlaps a live report (``reported``) by at least ``coast_live_iou``, or another
        coast kept now by at least ``coast_dup_iou``, are set not ``ok`` (``why`` "live" / "duplicate"); among
        overlapping coasts the most recently lost one is kept (ties: the lower identity)."""
        p = self.params
        sel = np.flatnonzero(ok)
        b = lbs[sel]
        if p.coast_live_iou > 0 and len(reported):
            live = iou_matrix(b, np.asarray(reported, np.float64).reshape(-1, 4)).max(axis=1) >= p.coast_live_iou
            ok[sel[live]] = False
            why[sel[live]] = "live"
            sel, b = sel[~live], b[~live]
        if p.coast_dup_iou > 0 and (p.coast_dup_ir or not self._ir) and len(sel) > 1:
            tl = np.array([self._lost[int(ids[j])][0] for j in sel], np.float64)
            if p.coast_dup_seen:  # reported last first (a coast's last report for this loss, else the loss)
                seen = np.array([max(tl[i], self._coast_rep.get(int(ids[j]), (None, 0.0))[1])
                                 if self._coast_rep.get(int(ids[j]), (None, 0.0))[0] == tl[i] else tl[i]
                                 for i, j in enumerate(sel)], np.float64)
                order = np.lexsort((ids[sel], -tl, -seen))
            else:
                order = np.lexsort((ids[sel], -tl))  # most recently lost first, then the lower identity
            m = iou_matrix(b, b)
            kept = []
            for o in order:
                if kept and m[o, kept].max() >= p.coast_dup_iou:
                    ok[sel[o]] = False
                    why[sel[o]] = "duplicate"
                else:
                    kept.append(int(o))

    def _record_rows(self, ids, lbs, ok, why, shape):
        """``params.coast_edge_horizon``: remember, for each coast seen now in the image (``ok``), or
        not yet remembered for this loss and with its box's centre in the image, how far its box's
        bottom lies below the horizon (px, at the box centre's column), the zoom and its height; not from
        a box at the image's left or right side (an edge look's)."""
        hh, ww = shape
        cx = lbs[:, 0] + 0.5 * lbs[:, 2]
        cy = lbs[:, 1] + 0.5 * lbs[:, 3]
        inside = (cx >= 0) & (cx < ww) & (cy >= 0) & (cy < hh) & (why != "outside")
        # not a box at the image's side (an edge look's box holds the part in view, its rows less sure)
        inside &= (why != "edge") & (lbs[:, 0] >= 1.0) & (lbs[:, 0] + lbs[:, 2] <= ww - 1.0)
        for j in np.flatnonzero(inside):
            k = int(ids[j])
            tl = self._lost[k][0]
            if not ok[j] and self._coast_rows.get(k, (None,))[0] == tl:
                continue
            row = float(np.asarray(self._horizon.row_at(np.array([cx[j]])), np.float64)[0])
            if np.isfinite(row):
                self._coast_rows[k] = (tl, float(lbs[j, 1] + lbs[j, 3]) - row, self._zoom, float(lbs[j, 3]))
        if len(self._coast_rows) > 2 * len(self._lost) + 16:
            self._coast_rows = {k: v for k, v in self._coast_rows.items() if k in self._lost}

    def _horizon_rows(self, ids, sel, e, left, wait, ww, hh):
        """``params.coast_edge_horizon``: the edge boxes ``e`` (of the coasts ``ids[sel]``) of those
        waiting outside moved to rows re-estimated from the horizon (see :class:`ClusterParams`).
        Returns the moved boxes and which were moved."""
        e = e.copy()
        moved = np.zeros(len(sel), bool)
        if self._horizon is None:
            return e, moved
        for j, i in enumerate(sel):
            if not wait[i]:
                continue
            k = int(ids[i])
            rec = self._coast_rows.get(k)
            if rec is None or rec[0] != self._lost[k][0]:
                continue
            xe = 0.0 if left[j] else float(ww - 1)
            row = float(np.asarray(self._horizon.row_at(np.array([xe])), np.float64)[0])
            if not np.isfinite(row):
                continue
            if self.params.coast_edge_horizon_h > 0:  # session 26 round 2 (H27): still the recorded boat's size
                hr = e[j, 3] / max(rec[3] * self._zoom / max(rec[2], 1e-6), 1e-6)
                if not 1.0 / self.params.coast_edge_horizon_h <= hr <= self.params.coast_edge_horizon_h:
                    continue
            bottom = row + rec[1] * self._zoom / max(rec[2], 1e-6)
            y = min(max(bottom - e[j, 3], 0.0), hh - e[j, 3])
            e[j, 1] = y
            moved[j] = True
        return e, moved

    def _edge_clear(self, e, left, ww, others):
        """``params.coast_edge_clear``: whether no box of ``others`` lies within ``coast_edge_clear``
        times the box's height of the rows of the edge box ``e`` and within its width plus that margin
        of the edge."""
        if not len(others):
            return True
        m = self.params.coast_edge_clear * e[3]
        o = np.asarray(others, np.float64).reshape(-1, 4)
        rows = (o[:, 1] < e[1] + e[3] + m) & (o[:, 1] + o[:, 3] > e[1] - m)
        near = o[:, 0] < e[2] + m if left else o[:, 0] + o[:, 2] > ww - e[2] - m
        return not bool((rows & near).any())

    def _coast_edge_look(self, image, shape, ids, lbs, ok, why, edge, reported, wait=None):
        """``params.coast_edge`` (session 24, helper H7): each coast in ``edge`` (its expected box's
        centre lies left or right of the image, its rows in it: a boat the pan or the zoom carried
        across the image's side) is looked at on the image's edge on its side: grown
        (:func:`grow_boxes`) from a core the half of the expected box (moved to that edge) nearest
        the edge, in the box's middle rows.  A grown box that was found, stands out (contrast at
        least ``min_contrast``), touches that edge (the boat straddles it), lies below the horizon
        band (``coast_search_below_px``), is at most ``coast_edge`` times the expected box's area and
        covers no more than a quarter of one of this frame's ``reported`` boxes (another boat) is
        reported (outcome "edge") and, with ``coast_follow``, followed from then on.  Updates
        ``ok``, ``why`` and ``lbs`` in place; a coast that is not seen waits (is not ended)."""
        p = self.params
        hh, ww = shape
        img = np.asarray(image)
        if img.dtype != np.uint8:
            img = to_grey_u8(img)
        sel = np.flatnonzero(edge)
        b = lbs[sel].copy()
        left = b[:, 0] + 0.5 * b[:, 2] < 0.5 * ww
        w = np.minimum(b[:, 2], 0.5 * ww)
        e = np.stack([np.where(left, 0.0, ww - w), b[:, 1], w, b[:, 3]], axis=1)
        grown, contrast, found = np.zeros((len(sel), 4)), np.zeros(len(sel)), np.zeros(len(sel), bool)
        for j in range(len(sel)):
            grown[j], contrast[j], found[j] = self._edge_grow(img, e[j], bool(left[j]))
        touch = np.where(left, grown[:, 0] <= 1.0, grown[:, 0] + grown[:, 2] >= ww - 1.0)
        ratio = (grown[:, 2] * grown[:, 3]) / np.maximum(b[:, 2] * b[:, 3], 1e-9)
        good = found & (contrast >= p.min_contrast) & touch & (ratio <= p.coast_edge)
        if p.coast_search_below_px > 0 and self._horizon is not None and good.any():
            good &= self._below_horizon(grown)
        if len(reported) and good.any():
            good &= ~_covers_a_report(grown, reported)
        look = np.zeros(len(sel), bool)
        if p.coast_edge_horizon and wait is not None and not good.all():
            # session 26 (H24): not seen at the expected rows: a box far outside looked at again at rows
            # re-estimated from the horizon (the camera's motion extrapolated far out carries it off them)
            eh, moved = self._horizon_rows(ids, sel, e, left, wait, ww, hh)
            look = moved & ~good & (np.abs(eh[:, 1] - e[:, 1]) >= 1.0)
            if p.coast_edge_horizon_out > 0:  # session 26 round 2 (H27): only for a box far outside
                gap = np.where(left, -(b[:, 0] + b[:, 2]), b[:, 0] - ww)
                look &= gap > p.coast_edge_horizon_out * np.maximum(b[:, 2], 1e-9)
            floor = max(p.min_contrast, p.coast_edge_horizon_contrast)
            for j in np.flatnonzero(look):
                if p.coast_edge_clear > 0:
                    others = list(np.asarray(reported, np.float64).reshape(-1, 4))
                    others += [lbs[i] for i in np.flatnonzero(ok) if i != sel[j]]
                    if not self._edge_clear(eh[j], bool(left[j]), ww, others):
                        continue
                g, ct, fd = self._edge_grow(img, eh[j], bool(left[j]))
                tch = g[0] <= 1.0 if left[j] else g[0] + g[2] >= ww - 1.0
                ok1 = (fd and ct >= floor and tch and g[2] * g[3] <= p.coast_edge * max(b[j, 2] * b[j, 3], 1e-9))
                if ok1 and p.coast_search_below_px > 0 and self._horizon is not None:
                    ok1 = bool(self._below_horizon(g[None])[0])
                if ok1 and len(reported):
                    ok1 = not bool(_covers_a_report(g[None], reported)[0])
                if ok1:
                    grown[j], contrast[j], found[j], good[j] = g, ct, True, True
        if p.coast_edge_dy > 0 and not good.all():
            # session 25 (H19): not seen at the expected rows: the zoom carried the expected box of a
            # boat far outside the image off its rows (pan 2: 30 px below the boat coming back in at the
            # left edge); looked at again in rows shifted by half a box height at a time, nearest first
            steps = np.arange(0.5, p.coast_edge_dy + 1e-9, 0.5)
            for j in np.flatnonzero(~good):
                for dy in np.stack([-steps, steps], axis=1).ravel():
                    y = e[j, 1] + dy * e[j, 3]
                    if y + e[j, 3] <= 0 or y >= hh:
                        continue
                    f = e[j].copy()
                    f[1] = min(max(y, 0.0), hh - f[3])
                    g, ct, fd = self._edge_grow(img, f, bool(left[j]))
                    tch = g[0] <= 1.0 if left[j] else g[0] + g[2] >= ww - 1.0
                    ok1 = (fd and ct >= p.min_contrast and tch
                           and g[2] * g[3] <= p.coast_edge * max(b[j, 2] * b[j, 3], 1e-9)
                           and g[3] >= 0.35 * b[j, 3]  # not a sliver of the sea's texture
                           and not (p.max_aspect > 0 and g[2] > p.max_aspect * max(g[3], 1e-9)))  # nor a line
                    if ok1 and p.coast_search_below_px > 0 and self._horizon is not None:
                        ok1 = bool(self._below_horizon(g[None])[0])
                    if ok1 and len(reported):
                        ok1 = not bool(_covers_a_report(g[None], reported)[0])
                    if ok1:
                        grown[j], contrast[j], found[j], good[j] = g, ct, True, True
                        break
        for j in np.flatnonzero(good):
            i = sel[j]
            ok[i] = True
            why[i] = "edge"
            lbs[i] = grown[j]
            if p.coast_follow:
                k = int(ids[i])
                tl, _, v = self._lost[k]
                self._lost[k] = (tl, grown[j].copy(), v)
                self._lost_dir.pop(k, None)
                if p.coast_drop_alt:
                    self._lost_alt.pop(k, None)
                    self._lost_alt_dir.pop(k, None)

    def _edge_grow(self, img, e, left, pad=48):
        """``coast_edge``'s grow of the box ``e`` (``x, y, w, h``, on the image's left edge, or its
        right one when not ``left``) from the core the half of it nearest the edge.  The grow takes
        each row's background from the window's side strips; at the image's edge one of them lies on
        the boat, so the look is made on a copy of the rows around the box with ``pad`` columns of
        the same rows' water (from beyond the window, away from the edge) put in front of the edge.
        Returns ``(box, contrast, found)`` in the image's pixels, the box cut at the edge."""
        p = self.params
        hh, ww = img.shape[:2]
        x, y, w, h = (float(v) for v in e)
        y0, y1 = int(max(0, np.floor(y - pad))), int(min(hh, np.ceil(y + h + pad)))
        s0 = int(np.ceil(w + pad))  # the water copied in front of the edge: beyond the grow's window
        cw = int(min(ww, max(s0 + pad, w + 3 * pad + p.grow_wide_px)))
        if s0 + pad > ww or y1 - y0 < 3:
            return np.array([x, y, w, h]), 0.0, False
        crop = img[y0:y1, :cw] if left else img[y0:y1, ww - cw:][:, ::-1]
        padded = np.ascontiguousarray(np.concatenate([crop[:, s0:s0 + pad], crop], axis=1))
        bx = np.array([[pad, y - y0, w, h]])
        core = np.array([[pad, y - y0 + 0.25 * h, 0.5 * w, 0.5 * h]])
        frac = 0.05 * hh * ww / float(padded.shape[0] * padded.shape[1])  # grow_boxes' large box, as in the image
        g, ct, fd = grow_boxes(padded, bx, core, grow=max(p.grow_box, 0.5), peak_frac=p.grow_peak_frac,
                               return_found=True, wide_grow_px=p.grow_wide_px, waterline_frac=p.waterline_frac,
                               top_frac=self._top_frac, max_area_frac=frac)
        gx0, gy, gw, gh = (float(v) for v in g[0])
        gx1 = min(gx0 + gw - pad, float(cw))
        gx0 = max(gx0 - pad, 0.0)
        out = np.array([gx0, gy + y0, max(gx1 - gx0, 0.0), gh])
        if not left:
            out[0] = ww - gx1
        return out, float(ct[0]), bool(fd[0]) and gx1 > gx0

    def _below_horizon(self, boxes):
        """Whether each box's bottom lies more than ``coast_search_below_px`` (times the zoom) below
        the sea horizon (under the lower of its two ends at the box's left and right edges)."""
        row = np.maximum(*(np.asarray(self._horizon.row_at(x), np.float64)
                           for x in (boxes[:, 0], boxes[:, 0] + boxes[:, 2])))
        return boxes[:, 1] + boxes[:, 3] > row + self.params.coast_search_below_px * self._zoom

    def _coast_look_up(self, img, b, reported):
        """``params.coast_look_up``: each expected box in ``b`` (``x, y, w, h``) extended upward by
        ``coast_look_up`` times its height and grown from that box's middle half; a grown box is
        good when it was found, stands out (``min_contrast``), holds at least half of the expected
        box, its area lies within ``coast_size_ratio`` of the extended box's either way, it is not a
        line (``max_aspect``) and it covers no more than a quarter of one of ``reported``.
        Returns ``(boxes, ok)``."""
        p = self.params
        b = np.asarray(b, np.float64).reshape(-1, 4)
        out = b.copy()
        if not len(b):
            return out, np.zeros(0, bool)
        u = float(p.coast_look_up)
        e = np.stack([b[:, 0], b[:, 1] - u * b[:, 3], b[:, 2], (1.0 + u) * b[:, 3]], axis=1)
        e[:, 3] -= np.maximum(-e[:, 1], 0.0)  # clipped at the image's top
        e[:, 1] = np.maximum(e[:, 1], 0.0)
        cores = np.stack([e[:, 0] + 0.25 * e[:, 2], e[:, 1] + 0.25 * e[:, 3], 0.5 * e[:, 2], 0.5 * e[:, 3]], axis=1)
        grown, contrast, found = grow_boxes(img, e, cores, grow=max(p.grow_box, 0.5), peak_frac=p.grow_peak_frac,
                                            return_found=True, wide_grow_px=p.grow_wide_px,
                                            waterline_frac=p.waterline_frac, top_frac=self._top_frac)
        ratio = (grown[:, 2] * grown[:, 3]) / np.maximum(e[:, 2] * e[:, 3], 1e-9)
        ix = np.maximum(np.minimum(b[:, 0] + b[:, 2], grown[:, 0] + grown[:, 2]) - np.maximum(b[:, 0], grown[:, 0]), 0)
        iy = np.maximum(np.minimum(b[:, 1] + b[:, 3], grown[:, 1] + grown[:, 3]) - np.maximum(b[:, 1], grown[:, 1]), 0)
        ok = (found & (contrast >= p.min_contrast) & (ratio <= p.coast_size_ratio)
              & (ratio >= 1.0 / p.coast_size_ratio) & (ix * iy >= 0.5 * b[:, 2] * b[:, 3]))
        if p.max_aspect > 0:
            ok &= ~(grown[:, 2] > p.max_aspect * np.maximum(grown[:, 3], 1e-9))
        if len(reported) and ok.any():
            ok &= ~_covers_a_report(grown, reported)
        out[ok] = grown[ok]
        return out, ok

    def _coast_look_ahead(self, img, b, dirx, reported):
        """``params.coast_look_ahead``: each expected box in ``b`` (``x, y, w, h``) shifted by
        ``coast_look_ahead`` times its width in the direction ``dirx`` (+1 right, -1 left) and grown
        from the shifted box's middle half; a grown box is good when it was found, stands out
        (``min_contrast``), its area lies within ``coast_size_ratio`` of the expected box's either
        way, its centre lies within the expected box's rows and between the expected and the shifted
        box's left and right sides, it is not a line (``max_aspect``) and it covers no more than a
        quarter of one of ``reported``.  Returns ``(boxes, ok)``."""
        p = self.params
        b = np.asarray(b, np.float64).reshape(-1, 4)
        out = b.copy()
        if not len(b):
            return out, np.zeros(0, bool)
        e = b.copy()
        e[:, 0] += np.asarray(dirx, np.float64) * float(p.coast_look_ahead) * b[:, 2]
        cores = np.stack([e[:, 0] + 0.25 * e[:, 2], e[:, 1] + 0.25 * e[:, 3], 0.5 * e[:, 2], 0.5 * e[:, 3]], axis=1)
        grown, contrast, found = grow_boxes(img, e, cores, grow=max(p.grow_box, 0.5), peak_frac=p.grow_peak_frac,
                                            return_found=True, wide_grow_px=p.grow_wide_px,
                                            waterline_frac=p.waterline_frac, top_frac=self._top_frac)
        ratio = (grown[:, 2] * grown[:, 3]) / np.maximum(b[:, 2] * b[:, 3], 1e-9)
        gx, gy = grown[:, 0] + 0.5 * grown[:, 2], grown[:, 1] + 0.5 * grown[:, 3]
        lo, hi = np.minimum(b[:, 0], e[:, 0]), np.maximum(b[:, 0] + b[:, 2], e[:, 0] + e[:, 2])
        ok = (found & (contrast >= p.min_contrast) & (ratio <= p.coast_size_ratio)
              & (ratio >= 1.0 / p.coast_size_ratio) & (gx >= lo) & (gx <= hi)
              & (gy >= b[:, 1]) & (gy <= b[:, 1] + b[:, 3]))
        if p.max_aspect > 0:
            ok &= ~(grown[:, 2] > p.max_aspect * np.maximum(grown[:, 3], 1e-9))
        if len(reported) and ok.any():
            ok &= ~_covers_a_report(grown, reported)
        out[ok] = grown[ok]
        return out, ok

    def _coast_search(self, img, b, reported):
        """``params.coast_search``: each expected box in ``b`` (``x, y, w, h``) grown again from cores
        (the middle half of the box) shifted by up to ``coast_search`` box widths and heights in
        steps of half a box; of the grown boxes that pass the coast's checks (found, contrast at
        least ``min_contrast``, area within ``coast_size_ratio`` of the expected box's either way),
        lie below the horizon band (``coast_search_below_px``; the expected box too) and lie by no more than ``coast_overlap`` in one of this frame's ``reported`` boxes (a boat
        already reported is not this one), the one whose centre lies nearest the expected box's.
        Returns ``(boxes, ok)``."""
        p = self.params
        n = len(b)
        steps = np.arange(-p.coast_search, p.coast_search + 1e-9, 0.5)
        ox, oy = np.meshgrid(steps, steps)
        off = np.stack([ox.ravel(), oy.ravel()], axis=1)
        off = off[np.any(off != 0, axis=1)]  # the expected place itself was looked at
        m = len(off)
        bb = np.repeat(b, m, axis=0)
        sh = bb.copy()
        sh[:, 0] += np.tile(off[:, 0], n) * bb[:, 2]
        sh[:, 1] += np.tile(off[:, 1], n) * bb[:, 3]
        hh, ww = img.shape[:2]
        cx, cy = sh[:, 0] + 0.5 * sh[:, 2], sh[:, 1] + 0.5 * sh[:, 3]
        inimg = (cx >= 0) & (cx < ww) & (cy >= 0) & (cy < hh)
        below = self._below_horizon if p.coast_search_below_px > 0 and self._horizon is not None else None
        if below is not None:
            inimg &= below(bb)  # the expected box itself lies below the horizon band
        out = b.copy()
        ok = np.zeros(n, bool)
        if not inimg.any():
            return out, ok
        idx = np.flatnonzero(inimg)
        s_ = sh[idx]
        cores = np.stack([s_[:, 0] + 0.25 * s_[:, 2], s_[:, 1] + 0.25 * s_[:, 3], 0.5 * s_[:, 2], 0.5 * s_[:, 3]],
                         axis=1)
        grown, contrast, found = grow_boxes(img, s_, cores, grow=max(p.grow_box, 0.5), peak_frac=p.grow_peak_frac,
                                            return_found=True, wide_grow_px=p.grow_wide_px,
                                            waterline_frac=p.waterline_frac, top_frac=self._top_frac)
        e = bb[idx]
        ratio = (grown[:, 2] * grown[:, 3]) / np.maximum(e[:, 2] * e[:, 3], 1e-9)
        good = found & (contrast >= p.min_contrast) & (ratio <= p.coast_size_ratio) & (ratio >= 1 / p.coast_size_ratio)
        if len(reported) and good.any():
            r = np.asarray(reported, np.float64).reshape(-1, 4)
            iw = (np.minimum(grown[:, None, 0] + grown[:, None, 2], r[None, :, 0] + r[None, :, 2])
                  - np.maximum(grown[:, None, 0], r[None, :, 0]))
            ih = (np.minimum(grown[:, None, 1] + grown[:, None, 3], r[None, :, 1] + r[None, :, 3])
                  - np.maximum(grown[:, None, 1], r[None, :, 1]))
            inside = np.maximum(iw, 0) * np.maximum(ih, 0) / np.maximum(grown[:, 2] * grown[:, 3], 1e-9)[:, None]
            good &= inside.max(axis=1) <= p.coast_overlap
        if below is not None and good.any():
            good &= below(grown)
        d = np.hypot(grown[:, 0] + 0.5 * grown[:, 2] - e[:, 0] - 0.5 * e[:, 2],
                     grown[:, 1] + 0.5 * grown[:, 3] - e[:, 1] - 0.5 * e[:, 3])
        d = np.where(good, d, np.inf)
        owner = idx // m
        for j in range(n):
            q = np.flatnonzero(owner == j)
            if len(q) and np.isfinite(d[q]).any():
                best = q[np.argmin(d[q])]
                out[j] = grown[best]
                ok[j] = True
        return out, ok


def camera_at(camera, frame: Frame):
    """The camera model at a frame's PTZ state (or pose), in the frame's pixels, and the zoom
    factor: ``(CameraModel, zoom)`` (see :func:`camera_horizon`)."""
    cam = camera
    zoom = 1.0
    if frame.ptz is not None:
        cam = cam.with_ptz(frame.ptz)
        zoom = float(frame.ptz.zoom)
    elif frame.pose is not None and frame.pose != cam.pose:
        cam = cam.with_pose(**dataclasses.asdict(frame.pose))
    h, w = frame.shape
    if (cam.intrinsics.width, cam.intrinsics.height) != (w, h):  # a camera model of another resolution
        cam = cam.with_intrinsics(cam.intrinsics.scaled_to(w, h))
    return cam, zoom


def camera_horizon(camera, frame: Frame):
    """The sea horizon of a frame from a camera model at the frame's PTZ state (or pose), in the
    frame's pixels, and the zoom factor: ``(Horizon or None, zoom)``.

    A camera model of another image size is first rescaled to the frame's (``Intrinsics.scaled_to``,
    pixel-centre convention), so the line's ends are at the frame's columns 0 and ``width - 1``.
    A frame's ``ptz`` takes precedence over its ``pose``; the pose replaces the model's whole pose
    (position, height, pan, tilt, roll), as in the fuser."""
    cam, zoom = camera_at(camera, frame)
    return _horizon_of(cam, frame.shape[1]), zoom


def _horizon_of(cam, width: int):
    from seawatch.detect.horizon import Horizon

    yl, yr = cam.horizon_line()
    if not (np.isfinite(yl) and np.isfinite(yr)):
        return None
    return Horizon(float(yl), float(yr), int(width), kind="sky")


class StableFeatureTracker:
    """Detector-tracker stage of paper B: frames in, tracked feature clusters out.

    Parameters
    ----------
    extractor : StableFeatureExtractor, optional
        The feature stage (default parameters when None).
    params : ClusterParams, optional
        The clustering parameters (the paper's defaults when None).
    report_tentative : bool
        Whether :meth:`process` also returns clusters younger than ``params.confirm_s``.

    Examples
    --------
    >>> trk = StableFeatureTracker()                       # doctest: +SKIP
    >>> dets, tracks = trk.process(frame)                   # doctest: +SKIP
    """

    name = "stable_features"

    def __init__(self, extractor: StableFeatureExtractor | None = None,
                 params: ClusterParams | None = None, report_tentative: bool = False,
                 camera=None, horizon: str = "camera", horizon_every_s: float = 0.5) -> None:
        if horizon not in ("auto", "camera", "detect", "off"):
            raise ValueError(f"stable_features: horizon must be auto, camera, detect or off, not {horizon!r}")
        self.extractor = extractor or StableFeatureExtractor()
        self.clusterer = FeatureClusterer(params)
        self.report_tentative = bool(report_tentative)
        self.last_snapshot: FeatureSnapshot | None = None
        self.camera = camera
        self.horizon_mode = horizon
        self.horizon_every_s = float(horizon_every_s)
        self.last_horizon = None
        self._frame_camera = None
        self._horizon_tracker = None

    def extractor_inputs(self, frame: Frame):
        """What the extractor is given besides the image, for one frame (call once a frame, in
        order): ``(horizon, zoom, motion_prior)``.  The stage's frame camera (the PTZ state or
        pose; the relink by the camera model needs it too) is updated; ``motion_prior`` is the
        camera's image motion from the previous frame's camera to this one's
        (:meth:`CameraModel.rotation_homography`), None without a camera model or on the first
        frame of a size."""
        prev = self._frame_camera
        self._frame_camera = camera_at(self.camera, frame)[0] if self.camera is not None else None
        hz = self._horizon(frame)
        zoom = float(frame.ptz.zoom) if (frame.ptz is not None and self.camera is not None) else 1.0
        prior = None
        cur = self._frame_camera
        if prev is not None and cur is not None and \
                (prev.intrinsics.width, prev.intrinsics.height) == (cur.intrinsics.width, cur.intrinsics.height):
            prior = prev.rotation_homography(cur)
        return hz, zoom, prior

    def _horizon(self, frame: Frame):
        """The sea horizon of this frame: from the camera model at the frame's PTZ state (or
        pose) when the stage has a camera, otherwise from the image (paper A's detector,
        :class:`seawatch.detect.horizon.HorizonTracker`) when asked (``horizon="auto"`` or
        ``"detect"``); None when off or not found."""
        from seawatch.detect.horizon import HorizonTracker

        mode = self.horizon_mode
        if mode == "off":
            return None
        if self._frame_camera is not None and mode in ("auto", "camera"):
            return _horizon_of(self._frame_camera, frame.shape[1])
        if mode == "camera":
            return None
        if self._horizon_tracker is None:
            self._horizon_tracker = HorizonTracker(every_s=self.horizon_every_s)
        return self._horizon_tracker.update(frame.image, frame.t_s, ir=frame.modality == Modality.IR)

    @classmethod
    def from_config(cls, config, *, fps: float | None = None, camera=None) -> "StableFeatureTracker":
        """Build from a :class:`seawatch.config.Config` (the ``sf_*`` fields of ``[tracker]``)."""
        return cls.from_settings(config.tracker, fps=fps, camera=camera)

    @classmethod
    def from_settings(cls, settings, fps: float | None = None, camera=None) -> "StableFeatureTracker":
        """Build from :class:`seawatch.config.TrackerSettings` (its ``sf_*`` fields)."""
        ext = StableFeatureExtractor(
            max_keypoints=int(getattr(settings, "sf_max_keypoints", 200)),
            nominal_fps=float(fps) if fps and fps > 0 else 25.0,
            motion_prior=str(getattr(settings, "sf_motion_prior", "fallback")),
        )
        params = ClusterParams(
            dmax=float(getattr(settings, "sf_dmax", 0.31)),
            alpha=float(getattr(settings, "sf_alpha", 3.0)),
            w_link=float(getattr(settings, "sf_w_link", 1.0)),
            radius_px=float(getattr(settings, "sf_radius_px", 50.0)),
            min_speed_px_s=float(getattr(settings, "sf_min_speed_px_s", 1.5)),
        )
        return cls(ext, params, camera=camera, horizon=str(getattr(settings, "sf_horizon", "camera")))

    def reset(self) -> None:
        self.extractor.reset()
        self.clusterer.reset()
        self._frame_camera = None
        if self._horizon_tracker is not None:
            self._horizon_tracker.reset()

    def process(self, frame: Frame) -> tuple[Detections, Tracks]:
        """Detect and track in one frame.

        Raises
        ------
        ValueError
            When the frame's image is not an image (the message names the frame).
        """
        try:
            hz, zoom, prior = self.extractor_inputs(frame)
            grey = to_grey_u8(frame.image)  # once a frame, for the extractor and the clustering (session 29)
            snap = self.extractor.process(grey, frame.t_s, frame.index, horizon=hz, zoom=zoom,
                                          motion_prior=prior, ir=frame.modality == Modality.IR)
        except ValueError as exc:
            raise ValueError(f"stable_features: frame {frame.index} (t={frame.t_s:.3f} s): {exc}") from None
        self.last_snapshot = snap
        self.last_horizon = hz
        self.clusterer.camera_id = frame.camera_id
        dets, tracks = self.clusterer.update(snap, frame.image, horizon=hz, zoom=zoom, camera=self._frame_camera,
                                             ir=frame.modality == Modality.IR, grey=grey)
        if not self.report_tentative and len(tracks):
            keep = tracks.states != int(TrackState.TENTATIVE)
            tracks = tracks.subset(keep)
            dets = dets.subset(keep[:len(dets)])  # coasting tracks (appended last) have no detection
        return dets, tracks
