"""Foreground blobs: 8-connected components with a size filter, and their detections.

A binary foreground mask becomes a set of boxes (one per 8-connected component whose pixel count
lies in ``[min_area_px, max_area_px]``); each box becomes one detection, with the azimuth and
elevation of its reference point through the camera model when a camera is given.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from seawatch.types import Detections

__all__ = ["find_blobs", "blobs_to_detections", "box_reference_points", "boxes_azel"]


def find_blobs(
    mask: np.ndarray,
    *,
    min_area_px: float = 30.0,
    max_area_px: float = math.inf,
    open_px: int = 0,
    close_px: int = 0,
    connectivity: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """Boxes and pixel counts of the connected foreground components of a mask.

    Parameters
    ----------
    mask : (H, W) bool or uint8
        Foreground where non-zero.
    min_area_px, max_area_px : float
        Components whose pixel count is outside this range are dropped.
    open_px, close_px : int
        Side of a square opening (removes speckle) and closing (joins fragments) applied before
        labelling; 0 or 1 disables.
    connectivity : {8, 4}
        Pixel connectivity of a component.

    Returns
    -------
    boxes : (N, 4) float64
        ``x, y, w, h`` of each component's bounding box (pixels of ``mask``).
    areas : (N,) float64
        Pixel count of each component.
    """
    m = np.asarray(mask)
    if m.ndim != 2:
        raise ValueError(f"find_blobs: mask must be 2-D, got shape {m.shape}")
    m = (m > 0).astype(np.uint8) if m.dtype != np.uint8 else m
    if open_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, np.ones((open_px, open_px), np.uint8))
    if close_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, np.ones((close_px, close_px), np.uint8))
    n, _, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=connectivity,
                                                       ltype=cv2.CV_32S)
    stats = stats[1:n]
    area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
    keep = (area >= min_area_px) & (area <= max_area_px)
    return stats[keep, :4].astype(np.float64).reshape(-1, 4), area[keep]


def box_reference_points(boxes: np.ndarray, ref: str = "bottom") -> tuple[np.ndarray, np.ndarray]:
    """Pixel ``(u, v)`` of each box's reference point: ``"bottom"`` centre (the waterline of a
    sea-surface target) or ``"centre"``."""
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    u = b[:, 0] + 0.5 * b[:, 2]
    if ref == "bottom":
        v = b[:, 1] + b[:, 3]
    elif ref == "centre":
        v = b[:, 1] + 0.5 * b[:, 3]
    else:
        raise ValueError(f"box_reference_points: ref must be 'bottom' or 'centre', got {ref!r}")
    return u, v


def boxes_azel(boxes: np.ndarray, camera, ref: str = "bottom") -> np.ndarray:
    """Azimuth and elevation (degrees), ``(N, 2)``, of each box's reference point through ``camera``.

    Boxes are in edge coordinates (pixel ``i`` spans ``[i, i + 1)``); the camera model works in
    pixel centres, so an edge coordinate ``v`` is the pixel coordinate ``v - 0.5``.
    """
    u, v = box_reference_points(boxes, ref)
    az, el = camera.pixel_to_azel(u - 0.5, v - 0.5)
    return np.stack([np.asarray(az, np.float64).reshape(-1), np.asarray(el, np.float64).reshape(-1)], axis=1)


def blobs_to_detections(
    boxes: np.ndarray,
    t_s: float,
    frame_index: int,
    *,
    camera=None,
    scores: np.ndarray | None = None,
    ref: str = "bottom",
    source: str = "blobs",
    camera_id: str = "cam0",
) -> Detections:
    """Detections from blob boxes, with azimuth/elevation through ``camera`` when given.

    Parameters
    ----------
    boxes : (N, 4)
        ``x, y, w, h`` in pixels of the camera's image.
    camera : CameraModel, optional
        Its ``pixel_to_azel`` maps each box's reference point to ``azel_deg``.
    scores : (N,), optional
        Confidences (1 when omitted).
    ref : {"bottom", "centre"}
        Reference point of a box (see :func:`box_reference_points`).
    """
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    s = np.ones(len(b)) if scores is None else np.asarray(scores, np.float64).reshape(-1)
    azel = None
    if camera is not None:
        azel = boxes_azel(b, camera, ref)
    return Detections(float(t_s), int(frame_index), b, s, source, camera_id, azel)
