"""Small synthetic videos for the pipeline tests: bright rectangles moving over a noisy background,
with exact ground-truth boxes."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def moving_boxes(n_frames=60, width=320, height=240, fps=10.0, seed=0, objects=None, noise=4.0):
    """Frames (BGR uint8) and ground truth ``{frame_index: [(id, x, y, w, h), ...]}``.

    ``objects``: list of (id, x0, y0, w, h, vx_px_s, vy_px_s, grey level); default two boats.
    """
    rng = np.random.default_rng(seed)
    if objects is None:
        objects = [
            (1, 20.0, 60.0, 40, 16, 40.0, 0.0, 230),
            (2, 260.0, 160.0, 30, 14, -30.0, 5.0, 20),
        ]
    base = rng.normal(110, 12, (height, width)).clip(0, 255)
    base = cv2.GaussianBlur(base, (0, 0), 2.0)
    frames, gt = [], {}
    for i in range(n_frames):
        t = i / fps
        img = base + rng.normal(0, noise, base.shape)
        rows = []
        for oid, x0, y0, w, h, vx, vy, level in objects:
            x, y = x0 + vx * t, y0 + vy * t
            xi, yi = int(round(x)), int(round(y))
            x1, y1 = max(xi, 0), max(yi, 0)
            x2, y2 = min(xi + w, width), min(yi + h, height)
            if x2 <= x1 or y2 <= y1:
                continue
            img[y1:y2, x1:x2] = level + rng.normal(0, noise, (y2 - y1, x2 - x1))
            rows.append((oid, x1, y1, x2 - x1, y2 - y1))
        gt[i] = rows
        g = img.clip(0, 255).astype(np.uint8)
        frames.append(cv2.cvtColor(g, cv2.COLOR_GRAY2BGR))
    return frames, gt


def write_video(path: Path, frames, fps=10.0, codec="MJPG") -> Path:
    h, w = frames[0].shape[:2]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*codec), fps, (w, h))
    assert vw.isOpened(), f"cannot write {path}"
    for f in frames:
        vw.write(f)
    vw.release()
    return path


def write_folder(folder: Path, frames, ext=".png") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"frame_{i:04d}{ext}"), f)
    return folder
