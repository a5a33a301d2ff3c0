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


def dark_box_sea(shape, box, seed, dx=0, boat=True):
    """Grey sea (120, noise 2, seeded) of ``shape`` with a dark box (60) at ``box`` (x0, y0, x1, y1,
    exclusive) moved ``dx`` px along x and cut by the image's edges (``boat`` False: none)."""
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, shape)
    if boat:
        x0, y0, x1, y1 = box
        a, b = max(x0 + dx, 0), min(x1 + dx, shape[1])
        if a < b:
            img[y0:y1, a:b] = 60.0
    return np.clip(img, 0, 255).astype(np.uint8)


def shift(dx):
    """A camera homography that moves the image content ``dx`` px along x."""
    h = np.eye(3)
    h[0, 2] = dx
    return h
