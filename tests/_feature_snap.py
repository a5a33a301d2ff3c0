"""A hand-made snapshot of stable features for the clusterer's tests."""

from __future__ import annotations

import numpy as np

from seawatch.detect.features import FeatureSnapshot


class Level:
    """A level sea horizon at row ``r`` (the ``row_at`` the clusterer and the extractor ask)."""

    def __init__(self, r):
        self.r = float(r)

    def row_at(self, x):
        return np.full(np.shape(x), self.r)


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


# the coast tests' base: no confirmation, relink 10 s, coast 5 s, session 24's second looks off; the edge
# look's steps of sessions 25-26 (on by default since session 28) named off here: the tests turn them on
COAST_BASE = dict(confirm_s=0.0, relink_s=10.0, coast_s=5.0, coast_look_up=0.0, coast_look_ahead=0.0,
                  coast_edge_seen=False, coast_edge_horizon=False, coast_edge_horizon_contrast=0.0,
                  coast_edge_horizon_h=0.0)


def hull_lost_then_moved(moves, boats=None, dys=None, dxs=None, shape=(160, 240), hull=(100, 60, 140, 70), **kw):
    """A dark hull (``hull``: x0, y0, x1, y1, exclusive, on a grey sea of ``shape``) seen with two
    features for 6 frames (0.1 s apart); then its features are gone and the camera moves the content
    by each of ``moves`` (px along x, one per frame); ``boats`` (one per frame, default all True):
    whether the hull is drawn; ``dys`` (``dxs``): how many px below its rows (right of where the camera
    carried it) it is drawn, the boat's own motion, which the camera does not give.  ``kw``: fields of
    ``ClusterParams`` over the base (``COAST_BASE``: no confirmation, relink 10 s, coast 5 s, session 24's
    second looks and the edge look's steps of sessions 25-26 off).  Returns the clusterer, the hull's identity and the tracks of each frame after the loss."""
    from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, **kw}))
    tr = None
    for k in range(6):
        _, tr = c.update(snap([[104, 63], [112, 66]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]),
                         dark_box_sea(shape, hull, k))
    assert len(tr) == 1
    ident = int(tr.ids[0])
    out = []
    none = (np.zeros((0, 2)), np.zeros((0, 2)))
    dx = 0.0
    for j, m in enumerate(moves):
        dx += m
        fi = 6 + j
        dy = 0 if dys is None else dys[j]
        ex = 0 if dxs is None else dxs[j]
        box = (hull[0], hull[1] + dy, hull[2], hull[3] + dy)
        img = dark_box_sea(shape, box, fi, dx=int(dx) + ex, boat=True if boats is None else boats[j])
        out.append(c.update(snap(*none, 0.1 * fi, fi, [], h=shift(m)), img)[1])
    return c, ident, out


LINEAR_CAMERA_F = 200.0  # px per radian


class LinearCamera:
    """A fixed camera for the side-edge relink tests: azimuth 180 deg at column 120, elevation 0 at row 80,
    ``LINEAR_CAMERA_F`` px per radian."""

    def pixel_to_azel(self, u, v):
        u, v = np.asarray(u, float), np.asarray(v, float)
        f = LINEAR_CAMERA_F
        return 180.0 + np.degrees((u - 120.0) / f), np.degrees(-(v - 80.0) / f)

    def azel_to_pixel(self, az, el):
        az, el = np.asarray(az, float), np.asarray(el, float)
        f = LINEAR_CAMERA_F
        return 120.0 + np.radians(az - 180.0) * f, 80.0 - np.radians(el) * f, np.ones(az.shape, bool)
