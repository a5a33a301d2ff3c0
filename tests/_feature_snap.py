"""A hand-made snapshot of stable features for the clusterer's tests."""

from __future__ import annotations

import numpy as np

from seawatch.detect.features import FeatureSnapshot


def snap(xy, vel, t, fi, ids=None, h=None, slots=None, shape=(160, 240)):
    """Stable features at ``xy`` moving at ``vel`` (a 4-sample history of it), at time ``t`` and
    frame ``fi``; ``ids`` default 10, 11, ...; ``slots`` default the ids when given (each feature's
    slot is its identity), else 0, 1, ...; ``h`` the camera homography (default identity)."""
    n = len(xy)
    hist = np.repeat(np.asarray(vel, float).reshape(-1, 2)[:, None, :], 4, axis=1)
    ids_a = np.arange(n) + 10 if ids is None else np.asarray(ids)
    if slots is None:
        slots = np.arange(n) if ids is None else np.asarray(ids)
    return FeatureSnapshot(
        t_s=t, frame_index=fi, ids=ids_a, slots=np.asarray(slots),
        xy=np.asarray(xy, float).reshape(-1, 2), size_px=np.full(n, 4.0), confidence=np.full(n, 6),
        stable=np.ones(n, bool), matched=np.ones(n, bool), velocity=hist[:, -1], history=hist,
        image_velocity=hist[:, -1], homography=np.eye(3) if h is None else h, dt_s=0.1, n_keypoints=n,
        n_matched=n, shape=shape,
    )
