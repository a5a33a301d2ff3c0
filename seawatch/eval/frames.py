"""Per-frame inputs of the metrics, flattened into arrays.

Every metric in :mod:`seawatch.eval` takes ground truth and predictions as *per-frame* data and
turns them into a :class:`FrameSet`: one row per object, sorted by frame, with the row offsets of
each frame.  Pairs of objects in the same frame (all ground-truth x prediction pairs) are then
built and scored in one vectorised pass by :func:`pair_table`, so the per-frame loops of the
metrics only slice precomputed arrays.

Accepted per-frame inputs (``data``)
-----------------------------------
* a mapping ``frame -> entry`` (frame keys are ints or floats, e.g. frame indices or times);
* a list/tuple of entries, the position being the frame index;
* a :class:`FrameSet`, or any object with flat ``frame``, ``boxes`` (and optionally ``ids``,
  ``scores``) arrays such as :class:`seawatch.io.gt.Annotations`.

An *entry* (one frame) is any of

* an ``(N, D)`` array of boxes ``x, y, w, h`` (``D = 4``) or of points (world coordinates);
* ``(ids, boxes)``: ``(N,)`` ids and ``(N, D)`` boxes;
* ``(ids, boxes, scores)``;
* ``(boxes, scores)`` when the first element is two-dimensional;
* a dict with keys ``boxes`` (or ``points``) and optionally ``ids``, ``scores``;
* an object with ``boxes`` (and optionally ``ids``, ``scores``) attributes, such as
  :class:`seawatch.types.Tracks` and :class:`seawatch.types.Detections`.

Rows without ids get id ``-1``; rows without scores get score ``1.0``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["FrameSet", "as_frameset", "align", "PairTable", "pair_table", "box_iou", "box_iou_pairs"]

_EPS = np.finfo(float).eps


@dataclass
class FrameSet:
    """Objects of many frames as flat arrays.

    Attributes
    ----------
    frames : (F,) float64 or int64, the frame keys, sorted and unique.
    fidx : (K,) int64, the position in ``frames`` of each row (non-decreasing).
    ids : (K,) int64 object identities (``-1`` when unknown).
    boxes : (K, D) float64 boxes ``x, y, w, h`` or points.
    scores : (K,) float64 confidences.
    starts : (F + 1,) int64 row offsets: frame ``f`` owns rows ``starts[f]:starts[f + 1]``.
    """

    frames: np.ndarray
    fidx: np.ndarray
    ids: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray

    def __post_init__(self) -> None:
        counts = np.bincount(self.fidx, minlength=len(self.frames)) if len(self.fidx) else np.zeros(
            len(self.frames), np.int64)
        self.starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def counts(self) -> np.ndarray:
        """(F,) number of objects in each frame."""
        return np.diff(self.starts)

    def frame(self, f: int) -> tuple[np.ndarray, np.ndarray]:
        """``(ids, boxes)`` of the ``f``-th frame (position, not key)."""
        s, e = self.starts[f], self.starts[f + 1]
        return self.ids[s:e], self.boxes[s:e]

    def per_frame(self) -> dict:
        """``frame key -> (ids, boxes)``, the simple form every metric accepts."""
        out = {}
        for f, key in enumerate(self.frames.tolist()):
            out[key] = self.frame(f)
        return out

    def reindexed(self, frames: np.ndarray) -> "FrameSet":
        """The same rows on another (sorted, unique) frame axis; rows of frames not on it are dropped."""
        frames = np.asarray(frames)
        if len(self.frames) == 0 or len(frames) == 0:
            z = np.zeros(0, np.int64)
            return FrameSet(frames, z, self.ids[:0], self.boxes[:0], self.scores[:0])
        pos = np.clip(np.searchsorted(frames, self.frames), 0, len(frames) - 1)
        on_axis = frames[pos] == self.frames  # per own frame
        keep = on_axis[self.fidx]
        fidx = pos[self.fidx[keep]].astype(np.int64)
        return FrameSet(frames, fidx, self.ids[keep], self.boxes[keep], self.scores[keep])


def _entry(value, dim: int | None):
    """(ids, boxes, scores) of one per-frame entry."""
    ids = scores = None
    if isinstance(value, Mapping):
        boxes = value.get("boxes", value.get("points"))
        ids = value.get("ids")
        scores = value.get("scores")
    elif hasattr(value, "boxes") and not isinstance(value, np.ndarray):
        boxes = value.boxes
        ids = getattr(value, "ids", None)
        scores = getattr(value, "scores", None)
    elif isinstance(value, (tuple, list)) and len(value) in (2, 3) and not _is_numeric_row_list(value):
        first = np.asarray(value[0], dtype=float)
        if first.ndim == 2 and len(value) == 2:
            boxes, scores = value
        else:
            ids, boxes = value[0], value[1]
            if len(value) == 3:
                scores = value[2]
    else:
        boxes = value
    boxes = np.asarray(boxes if boxes is not None else [], dtype=np.float64)
    if boxes.size == 0:
        boxes = boxes.reshape(0, dim or (boxes.shape[-1] if boxes.ndim == 2 else 4))
    elif boxes.ndim == 1:
        boxes = boxes.reshape(1, -1) if dim is None or boxes.size == dim else boxes.reshape(-1, dim)
    n = len(boxes)
    ids = np.full(n, -1, np.int64) if ids is None else np.asarray(ids, dtype=np.int64).reshape(-1)
    scores = np.ones(n) if scores is None else np.asarray(scores, dtype=np.float64).reshape(-1)
    if len(scores) == 0 and n:
        scores = np.ones(n)
    if len(ids) != n or len(scores) != n:
        raise ValueError(f"{len(ids)} ids, {n} boxes and {len(scores)} scores in one frame")
    return ids, boxes, scores


def _is_numeric_row_list(value) -> bool:
    """True for boxes given as a plain list of rows (``[[x, y, w, h], ...]``).

    Tuples are always read as ``(ids, boxes[, scores])`` or ``(boxes, scores)``.
    """
    if not isinstance(value, list):
        return False
    try:
        arr = np.asarray(value, dtype=float)
    except (ValueError, TypeError):
        return False
    return arr.ndim == 2


def as_frameset(data, dim: int | None = None) -> FrameSet:
    """Flatten per-frame ``data`` (see the module docstring) into a :class:`FrameSet`.

    Parameters
    ----------
    data : mapping, sequence, FrameSet or flat-array object
        The per-frame objects.
    dim : int, optional
        Number of columns of a box/point (4 for image boxes); used to shape empty frames.
    """
    if isinstance(data, FrameSet):
        return data
    if hasattr(data, "frame") and hasattr(data, "boxes") and not isinstance(data, Mapping):
        frame = np.asarray(data.frame)
        boxes = np.asarray(data.boxes, dtype=np.float64).reshape(len(frame), -1)
        ids = np.asarray(getattr(data, "ids", None) if getattr(data, "ids", None) is not None
                         else np.full(len(frame), -1), dtype=np.int64)
        sc = getattr(data, "scores", None)
        scores = np.ones(len(frame)) if sc is None else np.asarray(sc, dtype=np.float64)
        frames = np.unique(frame)
        extra = getattr(data, "frames", None)
        if extra is not None and not callable(extra):
            frames = np.union1d(frames, np.asarray(extra))
        order = np.argsort(frame, kind="stable")
        fidx = np.searchsorted(frames, frame[order]).astype(np.int64)
        return FrameSet(frames, fidx, ids[order], boxes[order], scores[order])
    if isinstance(data, Mapping):
        items = list(data.items())
    elif isinstance(data, (list, tuple)):
        items = list(enumerate(data))
    else:
        raise TypeError(f"cannot read per-frame data of type {type(data).__name__}")
    keys = np.asarray([k for k, _ in items]) if items else np.zeros(0, np.int64)
    order = np.argsort(keys, kind="stable")
    keys = keys[order]
    if len(keys) > 1 and np.any(keys[1:] == keys[:-1]):
        raise ValueError("duplicate frame keys")
    ids_l, boxes_l, scores_l, counts = [], [], [], np.zeros(len(items), np.int64)
    for pos, i in enumerate(order.tolist()):
        ids, boxes, scores = _entry(items[i][1], dim)
        if dim is not None and boxes.shape[1] != dim and len(boxes):
            raise ValueError(f"frame {items[i][0]!r}: expected {dim} columns, got {boxes.shape[1]}")
        ids_l.append(ids)
        boxes_l.append(boxes)
        scores_l.append(scores)
        counts[pos] = len(ids)
    if items:
        width = max((b.shape[1] for b in boxes_l if len(b)), default=dim or 4)
        boxes = np.concatenate([b.reshape(-1, width) for b in boxes_l])
        ids = np.concatenate(ids_l)
        scores = np.concatenate(scores_l)
    else:
        boxes, ids, scores = np.zeros((0, dim or 4)), np.zeros(0, np.int64), np.zeros(0)
    fidx = np.repeat(np.arange(len(items), dtype=np.int64), counts)
    return FrameSet(keys, fidx, ids, boxes, scores)


def align(gt, pred, frames=None, dim: int | None = 4) -> tuple[FrameSet, FrameSet]:
    """Ground truth and predictions on one frame axis.

    The axis is ``frames`` when given (objects of other frames are ignored, e.g. predictions
    between the annotated frames of a sparsely annotated video), otherwise the union of both
    inputs' frame keys (a frame listed with no objects still counts, e.g. for the mean of METE).
    """
    g = as_frameset(gt, dim)
    p = as_frameset(pred, dim)
    if frames is None:
        axis = np.union1d(g.frames, p.frames)
    else:
        axis = np.unique(np.asarray(frames))
    return g.reindexed(axis), p.reindexed(axis)


# ----------------------------------------------------------------------------------------- IoU
def box_iou_pairs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of boxes ``a[i]`` and ``b[i]`` (both ``(N, 4)`` as ``x, y, w, h``).

    Boxes of zero or negative area have IoU 0 with everything (as in TrackEval).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    iw = np.minimum(a[:, 0] + a[:, 2], b[:, 0] + b[:, 2]) - np.maximum(a[:, 0], b[:, 0])
    ih = np.minimum(a[:, 1] + a[:, 3], b[:, 1] + b[:, 3]) - np.maximum(a[:, 1], b[:, 1])
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    area_a = a[:, 2] * a[:, 3]
    area_b = b[:, 2] * b[:, 3]
    union = area_a + area_b - inter
    bad = (area_a <= _EPS) | (area_b <= _EPS) | (union <= _EPS)
    inter = np.where(bad, 0.0, inter)
    union = np.where(union <= _EPS, 1.0, union)
    return inter / union


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(N, M)`` IoU matrix between boxes ``a`` (``(N, 4)``) and ``b`` (``(M, 4)``), ``x, y, w, h``."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    n, m = len(a), len(b)
    if n == 0 or m == 0:
        return np.zeros((n, m))
    ia = np.repeat(np.arange(n), m)
    ib = np.tile(np.arange(m), n)
    return box_iou_pairs(a[ia], b[ib]).reshape(n, m)


@dataclass
class PairTable:
    """The scored (ground truth, prediction) pairs of every frame.

    For IoU only the pairs that overlap (IoU > 0) are kept: the others can never be matched and
    add nothing to any metric, and in a typical frame most pairs do not overlap.  For distances
    every pair is kept.  Pairs are in frame order, then ground-truth row, then prediction column;
    frame ``f`` owns pairs ``start[f]:start[f + 1]`` and :meth:`matrix` rebuilds its full
    ``(ng[f], np_[f])`` matrix (zeros where no pair is stored).
    """

    gi: np.ndarray  # (P,) ground-truth row (into the FrameSet) of each pair
    pj: np.ndarray  # (P,) prediction row of each pair
    pf: np.ndarray  # (P,) frame position of each pair
    lr: np.ndarray  # (P,) row of the pair inside its frame's matrix
    lc: np.ndarray  # (P,) column of the pair inside its frame's matrix
    sim: np.ndarray  # (P,) similarity (IoU, or distance for points)
    start: np.ndarray  # (F + 1,) pair offsets per frame
    ng: np.ndarray  # (F,) ground-truth objects per frame
    np_: np.ndarray  # (F,) predictions per frame

    def matrix(self, f: int, values: np.ndarray | None = None) -> np.ndarray:
        """Frame ``f``'s full matrix of ``values`` (default the similarities), zeros elsewhere."""
        vals = self.sim if values is None else values
        s, e = self.start[f], self.start[f + 1]
        out = np.zeros((self.ng[f], self.np_[f]))
        out[self.lr[s:e], self.lc[s:e]] = vals[s:e]
        return out


#: Most cells of one padded block when looking for overlapping boxes.
_BLOCK_CELLS = 1 << 22


def _padded(fs: FrameSet, f0: int, f1: int, width: int) -> np.ndarray:
    s, e = fs.starts[f0], fs.starts[f1]
    out = np.zeros((f1 - f0, width, fs.boxes.shape[1] if fs.boxes.ndim == 2 else 4))
    local = np.arange(s, e) - fs.starts[fs.fidx[s:e]]
    out[fs.fidx[s:e] - f0, local] = fs.boxes[s:e]
    return out


def _overlapping_pairs(gt: FrameSet, pred: FrameSet):
    """(frame, row, col) of every same-frame pair of boxes with a positive intersection."""
    ng, npd = gt.counts, pred.counts
    nf = len(ng)
    out_f, out_r, out_c = [], [], []
    f0 = 0
    while f0 < nf:
        # grow a block of frames while its padded size stays within budget
        f1, gmax, pmax = f0, 0, 0
        while f1 < nf:
            g2, p2 = max(gmax, int(ng[f1])), max(pmax, int(npd[f1]))
            if f1 > f0 and (f1 + 1 - f0) * g2 * p2 > _BLOCK_CELLS:
                break
            gmax, pmax, f1 = g2, p2, f1 + 1
        if gmax and pmax:
            a = _padded(gt, f0, f1, gmax)
            b = _padded(pred, f0, f1, pmax)
            ax, ay = a[:, :, None, 0], a[:, :, None, 1]
            bx, by = b[:, None, :, 0], b[:, None, :, 1]
            iw = np.minimum(ax + a[:, :, None, 2], bx + b[:, None, :, 2]) - np.maximum(ax, bx)
            ih = np.minimum(ay + a[:, :, None, 3], by + b[:, None, :, 3]) - np.maximum(ay, by)
            ff, rr, cc = np.nonzero((iw > 0) & (ih > 0))
            ff = ff + f0
            ok = (rr < ng[ff]) & (cc < npd[ff])
            out_f.append(ff[ok])
            out_r.append(rr[ok])
            out_c.append(cc[ok])
        f0 = f1
    if not out_f:
        z = np.zeros(0, np.int64)
        return z, z, z
    return (np.concatenate(out_f).astype(np.int64), np.concatenate(out_r).astype(np.int64),
            np.concatenate(out_c).astype(np.int64))


def _all_pairs(ng: np.ndarray, npd: np.ndarray):
    npairs = ng * npd
    start = np.concatenate([[0], np.cumsum(npairs)]).astype(np.int64)
    pf = np.repeat(np.arange(len(ng), dtype=np.int64), npairs)
    local = np.arange(int(start[-1]), dtype=np.int64) - start[pf]
    cols = np.maximum(npd[pf], 1)
    return pf, local // cols, local % cols


def pair_table(gt: FrameSet, pred: FrameSet, measure: str = "iou") -> PairTable:
    """Same-frame pairs of ``gt`` and ``pred`` (on one frame axis) with their similarity.

    ``measure`` is ``"iou"`` (boxes ``x, y, w, h``; only overlapping pairs are kept) or
    ``"euclidean"`` (points; every pair, the distance is stored).
    """
    if gt.n_frames != pred.n_frames:
        raise ValueError("gt and pred must share a frame axis (use align)")
    ng, npd = gt.counts, pred.counts
    if measure == "iou":
        pf, lr, lc = _overlapping_pairs(gt, pred)
        gi = gt.starts[pf] + lr
        pj = pred.starts[pf] + lc
        sim = box_iou_pairs(gt.boxes[gi], pred.boxes[pj]) if len(pf) else np.zeros(0)
        keep = sim > 0  # zero-area boxes overlap nothing
        if not keep.all():
            pf, lr, lc, gi, pj, sim = pf[keep], lr[keep], lc[keep], gi[keep], pj[keep], sim[keep]
    elif measure == "euclidean":
        pf, lr, lc = _all_pairs(ng, npd)
        gi = gt.starts[pf] + lr
        pj = pred.starts[pf] + lc
        if len(pf):
            d = gt.boxes[gi] - pred.boxes[pj]
            sim = np.sqrt(np.einsum("ij,ij->i", d, d))
        else:
            sim = np.zeros(0)
    else:
        raise ValueError(f"unknown measure {measure!r}")
    start = np.searchsorted(pf, np.arange(len(ng) + 1)).astype(np.int64)
    return PairTable(gi, pj, pf, lr, lc, sim, start, ng, npd)
