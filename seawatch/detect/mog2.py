"""MOG2 background-subtraction baseline detector for fixed cameras.

A clearly named baseline, kept as a peer for the paper methods: OpenCV's Gaussian-mixture
background model (Zivkovic 2004/2006, ``cv2.BackgroundSubtractorMOG2``), a morphological opening
and closing of the foreground mask, and connected components with a size filter.  It assumes a
**fixed** camera: a panning or zooming camera makes the whole image foreground (use the cascade or
the stable-features stage there).

Time parameters are seconds and are converted to frames with the source's frame rate.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from seawatch.types import Detections, Frame

__all__ = ["Mog2Detector", "foreground_boxes"]


def foreground_boxes(
    mask: np.ndarray,
    *,
    min_area_px: float = 30.0,
    max_area_px: float = math.inf,
    open_px: int = 3,
    close_px: int = 7,
) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of the connected foreground blobs of a binary mask.

    Parameters
    ----------
    mask : (H, W) uint8 or bool
        Foreground mask; pixels > 0 (or True) are foreground.
    min_area_px, max_area_px : float
        Blobs whose pixel count is outside ``[min_area_px, max_area_px]`` are dropped.
    open_px, close_px : int
        Side of the square structuring elements of the opening (removes speckle) and the closing
        (joins the fragments of one object); 0 or 1 disables the step.

    Returns
    -------
    boxes : (N, 4) float64
        ``x, y, w, h`` of each blob's bounding box.
    fill : (N,) float64
        Fraction of each box covered by the blob (a confidence in 0..1).
    """
    m = (np.asarray(mask) > 0).astype(np.uint8)
    if open_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, np.ones((open_px, open_px), np.uint8))
    if close_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, np.ones((close_px, close_px), np.uint8))
    n, _, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    stats = stats[1:n]  # drop the background component
    area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
    keep = (area >= min_area_px) & (area <= max_area_px)
    stats, area = stats[keep], area[keep]
    boxes = stats[:, :4].astype(np.float64)  # left, top, width, height
    fill = area / np.maximum(boxes[:, 2] * boxes[:, 3], 1.0)
    return boxes.reshape(-1, 4), fill


class Mog2Detector:
    """OpenCV MOG2 background subtraction + blob extraction (fixed cameras only).

    Parameters
    ----------
    fps : float
        Frame rate of the source, used to convert the time parameters to frames.
    history_s : float
        Length of the background model's memory, in seconds.
    var_threshold : float
        Squared Mahalanobis distance beyond which a pixel is foreground (OpenCV's ``varThreshold``;
        its default 16 turns sun glints on the waves into blobs).
    learning_rate : float
        Per-frame learning rate in 0..1; negative: automatic (``1 / history frames``).
    background_ratio : float
        Share of the mixture weight that counts as background (OpenCV's ``backgroundRatio``).
        OpenCV's 0.9 makes a colour background once it has ~10 % of the weight, i.e. after
        about ``0.1 * history`` frames: a slow hull that covers a pixel longer than that vanishes
        into the background. 0.7 keeps it about three times longer.
    min_area_px : float
        Smallest blob kept, in pixels of the source image.
    max_area_frac : float
        Largest blob kept, as a fraction of the image area (a global illumination change makes
        huge blobs).
    warmup_s : float
        Seconds after the first frame during which the model learns and nothing is reported.
    open_px, close_px : int
        Morphological opening / closing sizes in pixels of the working image; ``close_px`` None:
        15 px at 704 px wide, scaled with the width (joins hull and superstructure).
    work_width_px : int
        Width at which the background model runs (the image is downscaled, keeping its aspect
        ratio, and the boxes are scaled back); 0 or a width >= the image width: native size.
    camera_id : str
        Only used to label the detections when the frame has none.
    """

    name = "mog2"

    def __init__(
        self,
        fps: float = 25.0,
        *,
        history_s: float = 60.0,
        var_threshold: float = 64.0,
        learning_rate: float = -1.0,
        background_ratio: float = 0.7,
        min_area_px: float = 30.0,
        max_area_frac: float = 0.25,
        warmup_s: float = 1.0,
        open_px: int = 3,
        close_px: int | None = None,
        work_width_px: int = 0,
    ) -> None:
        if not fps > 0:
            raise ValueError(f"Mog2Detector: fps must be positive, got {fps}")
        if history_s <= 0:
            raise ValueError(f"Mog2Detector: history_s must be positive, got {history_s}")
        self.fps = float(fps)
        self.history_s = float(history_s)
        self.var_threshold = float(var_threshold)
        self.learning_rate = float(learning_rate)
        self.background_ratio = float(background_ratio)
        self.min_area_px = float(min_area_px)
        self.max_area_frac = float(max_area_frac)
        self.warmup_s = float(warmup_s)
        self.open_px = int(open_px)
        self.close_px = None if close_px is None else int(close_px)
        self.work_width_px = int(work_width_px)
        self.history_frames = max(2, int(round(self.history_s * self.fps)))
        self._model = None
        self._t0: float | None = None
        self._shape: tuple[int, ...] | None = None

    @classmethod
    def from_config(cls, config, *, fps: float, camera=None) -> "Mog2Detector":
        """Build from a :class:`seawatch.config.Config` (its ``[detector]`` section)."""
        d = config.detector
        return cls(
            fps,
            history_s=d.mog2_history_s,
            var_threshold=d.mog2_var_threshold,
            learning_rate=d.mog2_learning_rate,
            background_ratio=getattr(d, "mog2_background_ratio", 0.7),
            min_area_px=d.min_area_px,
            max_area_frac=d.max_area_frac,
            warmup_s=getattr(d, "mog2_warmup_s", 1.0),
            work_width_px=getattr(d, "mog2_work_width_px", 0),
        )

    def reset(self) -> None:
        """Forget the background model (e.g. after the camera moved)."""
        self._model = None
        self._t0 = None
        self._shape = None

    def _new_model(self):
        m = cv2.createBackgroundSubtractorMOG2(
            history=self.history_frames, varThreshold=self.var_threshold, detectShadows=False
        )
        m.setBackgroundRatio(self.background_ratio)
        return m

    def foreground(self, image: np.ndarray) -> np.ndarray:
        """Update the background model with ``image`` and return its foreground mask (uint8 0/255),
        at the working size."""
        if self._model is None or self._shape != image.shape:
            self._model = self._new_model()
            self._shape = image.shape
            self._t0 = None
        h, w = image.shape[:2]
        if 0 < self.work_width_px < w:
            ww = self.work_width_px
            hh = max(1, int(round(h * ww / w)))
            image = cv2.resize(image, (ww, hh), interpolation=cv2.INTER_AREA)
        return self._model.apply(image, learningRate=self.learning_rate)

    def detect(self, frame: Frame) -> Detections:
        """Foreground blobs of one frame as :class:`Detections` (``source="mog2"``)."""
        image = frame.image
        if image.dtype != np.uint8:  # e.g. 16-bit IR: stretch to 8 bits
            image = cv2.normalize(image, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
        restarted = self._model is None or self._shape != frame.image.shape
        mask = self.foreground(image)
        if restarted or self._t0 is None:
            self._t0 = frame.t_s
        if frame.t_s - self._t0 < self.warmup_s:
            return Detections.empty(frame.t_s, frame.index, self.name, frame.camera_id)
        h, w = frame.image.shape[:2]
        scale = w / mask.shape[1]
        close_px = self.close_px
        if close_px is None:  # 15 px at 704 px wide, scaled with the working width
            close_px = max(3, int(round(15 * mask.shape[1] / 704)))
        boxes, fill = foreground_boxes(
            mask,
            min_area_px=self.min_area_px / scale**2,
            max_area_px=self.max_area_frac * mask.shape[0] * mask.shape[1],
            open_px=self.open_px,
            close_px=close_px,
        )
        if scale != 1.0:
            boxes = boxes * scale
        return Detections(frame.t_s, frame.index, boxes, fill, self.name, frame.camera_id)
