"""Small synthetic sea scenes with boats and exact boxes (for tests and smoke runs of the trainer).

Not a simulator (see :mod:`seawatch.sim` for that): a grey sky above a straight horizon, a sea of
smoothed noise below it, an optional textured coast band on the horizon, and boats drawn as a
bright hull with a cabin.  Every boat's box is the tight bounding box of its drawn pixels.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["boat_scene"]


def _draw_boat(img: np.ndarray, x: float, y_water: float, w: float, rng: np.random.Generator, bright: bool):
    h_hull = max(3.0, w * rng.uniform(0.16, 0.22))
    hull_val = rng.uniform(200, 245) if bright else rng.uniform(20, 50)
    cab_val = rng.uniform(35, 70) if bright else rng.uniform(150, 200)
    x0, x1 = x, x + w
    yt = y_water - h_hull
    slant = w * 0.12
    hull = np.array([[x0, yt], [x1, yt], [x1 - slant, y_water], [x0 + slant * 0.5, y_water]], np.float64)
    cw = w * rng.uniform(0.3, 0.45)
    ch = h_hull * rng.uniform(0.7, 1.1)
    cx0 = x0 + w * rng.uniform(0.2, 0.4)
    cab = np.array([[cx0, yt - ch], [cx0 + cw, yt - ch], [cx0 + cw, yt], [cx0, yt]], np.float64)
    sh = 4  # sub-pixel drawing
    cv2.fillPoly(img, [np.round(hull * (1 << sh)).astype(np.int32)], float(hull_val), cv2.LINE_AA, sh)
    cv2.fillPoly(img, [np.round(cab * (1 << sh)).astype(np.int32)], float(cab_val), cv2.LINE_AA, sh)
    top = yt - ch
    return np.array([np.floor(x0), np.floor(top), np.ceil(x1) - np.floor(x0), np.ceil(y_water) - np.floor(top)])


def boat_scene(
    seed: int = 0,
    width_px: int = 320,
    height_px: int = 240,
    n_boats: int = 2,
    boat_w_px: tuple[float, float] = (40.0, 90.0),
    horizon_px: float | None = None,
    tilt_deg: float = 0.0,
    coast: bool = False,
    bright_boats: bool = True,
    clutter: int = 0,
) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """One synthetic grey frame.

    Parameters
    ----------
    seed : int
    width_px, height_px : int
    n_boats : int
        Boats drawn, without overlap, below the horizon.
    boat_w_px : (float, float)
        Range of hull lengths in pixels.
    horizon_px : float, optional
        Row of the horizon at the image centre (default: a random row in the upper third).
    tilt_deg : float
        Slope of the horizon (positive: lower on the right).
    coast : bool
        Draw a textured coast band just above the horizon (a water-coast line).
    bright_boats : bool
        White hulls (else dark hulls).
    clutter : int
        Number of non-boat objects on the water (glints, buoys, debris), drawn under the boats.

    Returns
    -------
    image : (H, W) uint8
    boxes : (N, 4) float64 x, y, w, h of the boats
    horizon : (y_left, y_right) rows of the horizon at columns 0 and W - 1
    """
    rng = np.random.default_rng(seed)
    w, h = int(width_px), int(height_px)
    if horizon_px is None:
        horizon_px = rng.uniform(0.2, 0.35) * h
    slope = np.tan(np.radians(tilt_deg))
    yl = horizon_px - slope * (w - 1) / 2
    yr = horizon_px + slope * (w - 1) / 2
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    line = yl + (yr - yl) * xx / max(w - 1, 1)
    sky_val = rng.uniform(170, 210)
    sea_val = rng.uniform(80, 115)
    sky = sky_val - 20 * yy / h
    noise = rng.normal(0, 1, (h, w)).astype(np.float32)
    waves = cv2.GaussianBlur(noise, (0, 0), sigmaX=3.0, sigmaY=0.8) * 14 + rng.normal(0, 2.5, (h, w))
    sea = sea_val + waves + 10 * (yy - horizon_px) / h
    img = np.where(yy < line, sky, sea).astype(np.float32)
    if coast:
        band = rng.uniform(0.08, 0.14) * h
        tex = cv2.GaussianBlur(rng.normal(0, 1, (h, w)).astype(np.float32), (0, 0), 1.2) * 35
        blocks = (np.sin(xx / rng.uniform(5, 11)) > 0.3) * 30
        coast_val = sea_val + rng.choice([-1.0, 1.0]) * rng.uniform(55, 70) + tex + blocks
        m = (yy < line) & (yy >= line - band)
        img[m] = coast_val[m]
    for _ in range(int(clutter)):  # glints, buoys, debris: things that are not boats
        cx, cy = rng.uniform(0, w), rng.uniform(horizon_px + 4, h)
        kind = rng.integers(3)
        if kind == 0:
            cv2.ellipse(img, (int(cx), int(cy)), (int(rng.uniform(3, 14)), int(rng.uniform(1, 3))), 0, 0, 360,
                        float(rng.uniform(190, 250)), -1)
        elif kind == 1:
            cv2.circle(img, (int(cx), int(cy)), int(rng.uniform(2, 5)), float(rng.uniform(20, 60)), -1)
        else:
            bw = rng.uniform(10, 40)
            cv2.rectangle(img, (int(cx), int(cy)), (int(cx + bw), int(cy + rng.uniform(2, 6))),
                          float(rng.uniform(140, 230)), -1)
    img = cv2.GaussianBlur(img, (0, 0), 0.6)
    boxes = []
    taken = []
    for _ in range(n_boats):
        for _try in range(50):
            bw = rng.uniform(*boat_w_px)
            x = rng.uniform(2, w - bw - 2)
            top = horizon_px + 8 + bw * 0.45
            if top > h - 4:
                continue
            y_water = rng.uniform(top, h - 4)
            box = (x, y_water - bw * 0.45, bw, bw * 0.45)
            if any(not (box[0] + box[2] < t[0] - 6 or t[0] + t[2] < box[0] - 6 or box[1] + box[3] < t[1] - 6
                        or t[1] + t[3] < box[1] - 6) for t in taken):
                continue
            taken.append(box)
            boxes.append(_draw_boat(img, x, y_water, bw, rng, bright_boats))
            break
    out = np.clip(img + 0.5, 0, 255).astype(np.uint8)
    return out, np.asarray(boxes, np.float64).reshape(-1, 4), (float(yl), float(yr))
