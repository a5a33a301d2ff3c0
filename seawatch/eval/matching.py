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
        assigns ``min(n, m)`` pairs, some of them with zero score).

    Returns
    -------
    (Q,) int64 indices into the pair table of the assigned pairs, in frame order.
    """
    score = pt.sim if score is None else score
    start = pt.start.tolist()
    ng = pt.ng.tolist()
    npd = pt.np_.tolist()
    out = []
    for f in range(len(ng)):
        n, m = ng[f], npd[f]
        if n == 0 or m == 0:
            continue
        s = start[f]
        mat = score[s:s + n * m].reshape(n, m)
        r, c = linear_sum_assignment(-mat)  # -mat, not maximize=True: same ties as TrackEval
        idx = s + r * m + c
        if keep_positive:
            idx = idx[mat[r, c] > EPS]
        out.append(idx)
    return np.concatenate(out).astype(np.int64) if out else np.zeros(0, np.int64)


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
    key = np.stack([fidx, ids], axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        k = first[np.argmax(counts > 1)]
        raise ValueError(f"{what}: id {ids[k]} occurs more than once in frame {frames[fidx[k]]}")
