"""Per-frame optimal assignment over a :class:`~seawatch.eval.frames.PairTable`."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.eval.frames import PairTable

__all__ = ["assign_frames", "relabel"]

EPS = float(np.finfo(float).eps)


def assign_frames(pt: PairTable, score: np.ndarray | None = None, keep_positive: bool = True) -> np.ndarray:
    """Maximum-score one-to-one assignment in every frame.

    Parameters
    ----------
    pt : PairTable
        The frame pairs.
    score : (P,) array, optional
        Score of each pair to maximise (default ``pt.sim``).  Set pairs that may not be matched
        to 0.
    keep_positive : bool
        Keep only assigned pairs whose score is above machine epsilon (the Hungarian algorithm
        assigns ``min(n, m)`` cells, some of them with zero score).  Assigned cells with no stored
        pair (boxes that do not overlap) are never returned.

    Returns
    -------
    (Q,) int64 indices into the pair table of the assigned pairs, in frame order.
    """
    score = pt.sim if score is None else score
    fast, slow_frames = split_conflict_free(pt, score, keep_positive)
    out = [fast]
    start, ng, npd, lr, lc = pt.start, pt.ng, pt.np_, pt.lr, pt.lc
    for f in slow_frames.tolist():
        s, e = int(start[f]), int(start[f + 1])
        mat = np.zeros((int(ng[f]), int(npd[f])))
        rr, cc = lr[s:e], lc[s:e]
        mat[rr, cc] = score[s:e]
        r, c = linear_sum_assignment(-mat)  # -mat, not maximize=True: same ties as TrackEval
        val = mat[r, c]
        # map the assigned cells back to stored pairs (cells without a pair are not returned)
        pos = np.full(mat.shape, -1, np.int64)
        pos[rr, cc] = np.arange(s, e)
        idx = pos[r, c]
        keep = idx >= 0
        if keep_positive:
            keep &= val > EPS
        out.append(idx[keep])
    q = np.concatenate(out).astype(np.int64)
    q.sort()
    return q


def split_conflict_free(pt: PairTable, score: np.ndarray, keep_positive: bool = True):
    """Pairs of the frames whose assignment needs no solver, and the frames that do.

    In a frame where the positive-score pairs share no row and no column, every optimal
    assignment takes exactly those pairs (their sum bounds any assignment and is reached), so
    they are returned directly.  Frames with competing pairs (or, with ``keep_positive=False``,
    with a stored pair of non-positive score) are left to the Hungarian algorithm.

    Returns
    -------
    fast : (Q,) int64 pair indices assigned without a solver.
    slow_frames : (S,) int64 frame positions to solve.
    """
    n_pairs = len(score)
    if n_pairs == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pos = score > EPS
    ai = np.flatnonzero(pos)
    gi, pj = pt.gi[ai], pt.pj[ai]
    rc = np.bincount(gi, minlength=int(pt.gi.max()) + 1)
    cc = np.bincount(pj, minlength=int(pt.pj.max()) + 1)
    bad = np.zeros(len(pt.ng), bool)
    bad[pt.pf[ai[(rc[gi] > 1) | (cc[pj] > 1)]]] = True
    if not keep_positive:
        bad[pt.pf[~pos]] = True
    fast = ai[~bad[pt.pf[ai]]]
    return fast.astype(np.int64), np.flatnonzero(bad)


class Prepared:
    """Ground truth and predictions on one frame axis, with their IoU pairs and cached matchings.

    Every metric accepts one in place of ``gt`` (``pred`` is then ignored), so that scoring many
    metrics on the same data flattens, pairs and matches it only once (see ``score_tracks``).
    """

    def __init__(self, gt, pred, frames=None):
        from seawatch.eval.frames import align

        self.g, self.p = align(gt, pred, frames)
        self._pt = None
        self._ids = None
        self._assign: dict = {}

    @property
    def pt(self) -> PairTable:
        if self._pt is None:
            from seawatch.eval.frames import pair_table

            self._pt = pair_table(self.g, self.p)
        return self._pt

    def ids(self):
        """``(gid, n_gid, pid, n_pid)``: identities relabelled ``0..n-1``, checked unique per frame."""
        if self._ids is None:
            check_unique_ids(self.g.fidx, self.g.ids, "ground truth", self.g.frames)
            check_unique_ids(self.p.fidx, self.p.ids, "predictions", self.p.frames)
            gid, n_gid = relabel(self.g.ids)
            pid, n_pid = relabel(self.p.ids)
            self._ids = (gid, n_gid, pid, n_pid)
        return self._ids

    def thresholded(self, iou: float) -> np.ndarray:
        """Pairs of the per-frame assignment maximising IoU over pairs with IoU >= ``iou``."""
        key = ("thr", float(iou))
        if key not in self._assign:
            pt = self.pt
            self._assign[key] = assign_frames(pt, np.where(pt.sim >= iou - EPS, pt.sim, 0.0))
        return self._assign[key]

    def max_overlap(self) -> np.ndarray:
        """Pairs of the per-frame assignment maximising summed IoU (minimising 1 - IoU)."""
        if "max" not in self._assign:
            self._assign["max"] = assign_frames(self.pt, self.pt.sim, keep_positive=False)
        return self._assign["max"]


def prepare(gt, pred, frames=None) -> Prepared:
    """``gt`` itself when it is already :class:`Prepared`, else a new one."""
    return gt if isinstance(gt, Prepared) else Prepared(gt, pred, frames)


def relabel(ids: np.ndarray) -> tuple[np.ndarray, int]:
    """Identities mapped to ``0 .. n - 1`` (sorted order) and ``n``."""
    if len(ids) == 0:
        return np.zeros(0, np.int64), 0
    uniq, inv = np.unique(ids, return_inverse=True)
    return inv.astype(np.int64).reshape(-1), len(uniq)


def check_unique_ids(fidx: np.ndarray, ids: np.ndarray, what: str, frames: np.ndarray) -> None:
    """Raise ``ValueError`` naming the frame when an identity occurs twice in one frame."""
    if len(ids) < 2:
        return
    lo = int(ids.min())
    span = int(ids.max()) - lo + 1
    key = fidx.astype(np.int64) * span + (ids - lo)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    dup = np.flatnonzero(ks[1:] == ks[:-1])
    if len(dup):
        k = order[dup[0]]
        raise ValueError(f"{what}: id {ids[k]} occurs more than once in frame {frames[fidx[k]]}")
