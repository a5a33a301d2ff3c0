"""Paper A boat detector (Bloisi et al.): a boosted Haar cascade with horizon and noise filters.

Per frame: grey image (thermal frames normalised by a percentile stretch), 3x3 median,
resize to the *detection scale*, ``cv2.CascadeClassifier.detectMultiScale`` with a scale factor,
a minimum number of neighbours and the cascade's window as minimum size; then

1. Canny pruning: windows with too few edge pixels are dropped (OpenCV ignores its own
   ``CASCADE_DO_CANNY_PRUNING`` flag for current-format cascades);
2. nested-box suppression (the outer box is kept, as in the authors' detector);
3. the horizon filter (:mod:`seawatch.detect.horizon`): no detection above a water-coast line,
   none wholly above a water-sky line; the line is smoothed over time;
4. the reflection filter: boxes with a negligible FAST keypoint count for their area go;
5. the window is mapped to a box with the box convention learned in training (the median
   box/window width and height ratios stored beside the model).

The wake filter is the cascade's last stage (see :mod:`seawatch.train`).

Detection scale: the frame is resized by ``z`` so that the smallest boat to find
(``min_size_px``, a box width in source pixels) fills the cascade's window; with
``min_size_px = 0`` the smallest boat is 1/16 of the frame width (at least 12 px).
``detection_width_px`` overrides it.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from seawatch.detect.filters import canny_prune, prepare_grey, reflection_filter, suppress_nested, to_grey
from seawatch.detect.horizon import Horizon, HorizonTracker, horizon_filter
from seawatch.types import Detections, Frame, Modality

__all__ = ["CascadeDetector", "CascadeParams", "default_model_path", "load_model_meta"]


def default_model_path() -> Path:
    """The shipped boat cascade."""
    return Path(__file__).resolve().parent.parent / "models" / "boat_cascade.xml"


def load_model_meta(model_path: str | Path) -> dict:
    """The JSON written beside a cascade by the trainer (box convention), or defaults."""
    p = Path(model_path).with_suffix(".json")
    meta = {"box_ratio_w": 1.0, "box_ratio_h": 1.0, "box_dx_frac": 0.0, "box_dy_frac": 0.0}
    if p.is_file():
        try:
            data = json.loads(p.read_text(encoding="utf-8"))
        except (ValueError, OSError) as exc:
            raise ValueError(f"{p}: not a valid model description: {exc}") from None
        for k in ("box_ratio_w", "box_ratio_h", "box_dx_frac", "box_dy_frac", "detector"):
            if k in data:
                meta[k] = data[k]
    return meta


@dataclass
class CascadeParams:
    """Settings of :class:`CascadeDetector` (see ``DetectorSettings`` in :mod:`seawatch.config`)."""

    scale_factor: float = 0.0  # 0: the model's, stored beside it (default model: session 15's speed rule; else 1.1)
    min_neighbors: int = 0  # 0: the model's, stored beside it (best on validation at its scale factor; else 3)
    # a window of w detection pixels needs min_neighbors * (w / window width) ** neighbors_size_exp
    # neighbours (larger boats gather many more); -1: the model's value (else 0)
    neighbors_size_exp: float = -1.0
    min_size_px: float = 0.0  # smallest boat (box width, source px); 0: automatic
    detection_width_px: int = 0  # overrides the detection scale; 0: automatic
    max_upscale: float = 4.0
    median_px: int = 3
    canny_prune: bool = True
    min_edge_frac: float = 0.03
    suppress_nested: bool = True
    horizon_filter: bool = True
    horizon_tau_s: float = 0.5
    horizon_hold_s: float = 2.0
    horizon_every_s: float = 0.2  # detect the line at most 5 times a second (smoothed in between)
    water_roi: bool = True  # with the horizon filter: scan only below the horizon (less a margin)
    roi_margin_frac: float = 0.2
    # with the horizon filter: each pyramid level scans only the rows whose windows can give an
    # accepted detection (see :meth:`CascadeDetector.scan_region_windows`); supersedes water_roi
    scan_region: bool = True
    # grid of window positions: 0 = OpenCV's (2 px below pyramid scale 2, 1 px from 2 on, so large
    # boats are scanned four times as densely as small ones), 2 = a 2 px grid at every scale (each
    # level scanned by its own call); -1: the model's value (stored beside it), else 0
    grid_step_px: int = -1
    # on the 2 px grid, which code evaluates the windows: "numba" (seawatch.detect.cascade_scan, the
    # same decisions as OpenCV's, about 1.4x faster per level, 1.2x in the whole detector),
    # "opencv" (cv2.CascadeClassifier), or "auto" (numba on the 2 px grid when it can read the
    # cascade; OpenCV's grid is always scanned by OpenCV)
    scanner: str = "auto"
    # x step of the window grid with grid_step_px 2: 0 or 2 = OpenCV's 2 px; 4 = every 4 px in x
    # (2 px in y; the Numba scanner, every position evaluated); -1: the model's value when the grid
    # is 2 px, else 0
    grid_step_x_px: int = -1
    scan_region_margin_win: float = 0.5  # extra rows above that limit, in window heights (grouping)
    reflection_filter: bool = True
    reflection_min_per_100px2: float = 0.01
    fast_threshold: int = 20


class CascadeDetector:
    """Boosted Haar cascade boat detector with the paper's filters (a :class:`~seawatch.types.Detector`).

    Parameters
    ----------
    model_path : str or Path, optional
        OpenCV cascade XML (default: the shipped ``seawatch/models/boat_cascade.xml``).  A
        ``.json`` beside it, written by the trainer, gives the box convention; cascades without
        one (e.g. the authors' ``barche.xml``) report their raw windows.
    params : CascadeParams, optional
    **overrides
        Any :class:`CascadeParams` field.

    Raises
    ------
    FileNotFoundError
        When the model file does not exist.
    ValueError
        When OpenCV cannot load it.
    """

    name = "cascade"

    def __init__(self, model_path: str | Path | None = None, params: CascadeParams | None = None, **overrides):
        p = dataclasses.replace(params) if params is not None else CascadeParams()
        for k, v in overrides.items():
            if not hasattr(p, k):
                raise TypeError(f"CascadeDetector: unknown parameter {k!r}")
            setattr(p, k, v)
        if p.scale_factor != 0.0 and p.scale_factor <= 1.0:
            raise ValueError(f"scale_factor must be > 1 (or 0: the model's), got {p.scale_factor}")
        path = Path(model_path) if model_path else default_model_path()
        if not path.is_file():
            raise FileNotFoundError(f"cascade model not found: {path}")
        self.model_path = path
        try:
            self.classifier = cv2.CascadeClassifier(str(path))
        except (cv2.error, SystemError) as exc:
            raise ValueError(f"{path}: OpenCV could not load this cascade: {exc}") from None
        if self.classifier.empty():
            raise ValueError(f"{path}: OpenCV could not load this cascade")
        ws = self.classifier.getOriginalWindowSize()
        self.window = (int(ws[0]), int(ws[1])) if ws[0] > 0 else (60, 30)
        meta = load_model_meta(path)
        self.ratio_w = float(meta["box_ratio_w"])
        self.ratio_h = float(meta["box_ratio_h"])
        tuned = meta.get("detector") or {}
        if p.min_neighbors <= 0:
            p.min_neighbors = int(tuned.get("min_neighbors", 3))
        if p.scale_factor == 0.0:
            p.scale_factor = float(tuned.get("scale_factor", 1.1))
        if p.neighbors_size_exp < 0:
            p.neighbors_size_exp = float(tuned.get("neighbors_size_exp", 0.0))
        if p.grid_step_px < 0:
            p.grid_step_px = int(tuned.get("grid_step_px", 0))
        if p.grid_step_px not in (0, 2):
            raise ValueError(f"grid_step_px must be 0 (OpenCV's grid) or 2, got {p.grid_step_px}")
        explicit_x = p.grid_step_x_px >= 0
        if not explicit_x:  # the model's x step belongs to its 2 px grid: none on OpenCV's grid
            p.grid_step_x_px = int(tuned.get("grid_step_x_px", 0)) if p.grid_step_px == 2 else 0
        if p.grid_step_x_px not in (0, 2, 4):
            raise ValueError(f"grid_step_x_px must be 0, 2 or 4, got {p.grid_step_x_px}")
        if p.grid_step_x_px == 4 and p.grid_step_px != 2:
            raise ValueError("grid_step_x_px 4 needs grid_step_px 2")
        if p.scanner not in ("auto", "numba", "opencv"):
            raise ValueError(f"scanner must be 'auto', 'numba' or 'opencv', got {p.scanner!r}")
        if p.scanner == "numba" and p.grid_step_px != 2:
            raise ValueError("the Numba scanner scans the 2 px grid only (grid_step_px 2); OpenCV's grid is "
                             "scanned by OpenCV")
        if p.scanner == "opencv" and p.grid_step_x_px == 4:
            raise ValueError(("grid_step_x_px 4" if explicit_x else f"{path.name}'s 4x2 px grid (its JSON)")
                             + " is scanned by the Numba scanner only: give grid_step_x_px=2 to scan the 2 px "
                             "grid with OpenCV")
        self.packed = None  # the Numba scanner's cascade (2 px grid, scanner not "opencv")
        if p.grid_step_px == 2 and p.scanner != "opencv":
            from seawatch.detect.cascade_scan import PackedCascade

            try:
                self.packed = PackedCascade(path)
            except ValueError as exc:  # e.g. trees deeper than stumps, tilted features
                if p.scanner == "numba" or p.grid_step_x_px == 4:
                    raise ValueError(f"the Numba scanner cannot read this cascade: {exc}") from None
                # "auto": OpenCV scans it (self.packed stays None)
        self.dx_frac = float(meta.get("box_dx_frac", 0.0))
        self.dy_frac = float(meta.get("box_dy_frac", 0.0))
        self.params = p
        self.horizon_tracker = HorizonTracker(tau_s=p.horizon_tau_s, hold_s=p.horizon_hold_s,
                                              every_s=p.horizon_every_s)
        self.horizon: Horizon | None = None
        self.n_bad_frames = 0
        self.last_windows = np.zeros((0, 4))
        self._plans: dict = {}  # pyramid plans per detection image size (see _level_plan)

    @classmethod
    def from_config(cls, config) -> "CascadeDetector":
        """Build from a :class:`seawatch.config.Config` (its ``[detector]`` section)."""
        d = config.detector
        return cls(
            d.cascade_model or None,
            scale_factor=float(getattr(d, "cascade_scale_factor", 0.0)),
            min_neighbors=int(getattr(d, "cascade_min_neighbors", 0)),
            min_size_px=float(d.min_size_px),
            detection_width_px=int(d.detection_width_px),
            horizon_filter=d.horizon_filter,
            reflection_filter=d.reflection_filter,
            canny_prune=getattr(d, "canny_prune", True),
            horizon_tau_s=getattr(d, "horizon_tau_s", 0.5),
            water_roi=getattr(d, "water_roi", True),
            scan_region=getattr(d, "cascade_scan_region", True),
            scanner=getattr(d, "cascade_scanner", "auto"),
        )

    # ------------------------------------------------------------------ geometry
    def min_boat_px(self, width_px: int) -> float:
        """Width of the smallest boat searched for in a frame ``width_px`` wide (source pixels)."""
        return float(self.window[0] * self.ratio_w / self.detection_scale(width_px))

    def detection_scale(self, width_px: int) -> float:
        """Resize factor applied to a frame ``width_px`` wide before the cascade runs."""
        p = self.params
        if p.detection_width_px and p.detection_width_px > 0:
            return float(p.detection_width_px) / float(width_px)
        min_boat = p.min_size_px if p.min_size_px > 0 else max(12.0, width_px / 16.0)
        z = self.window[0] * self.ratio_w / float(min_boat)
        return float(min(max(z, 0.05), p.max_upscale))

    def windows_to_boxes(self, windows: np.ndarray) -> np.ndarray:
        w = np.asarray(windows, np.float64).reshape(-1, 4)
        cx = w[:, 0] + w[:, 2] * (0.5 + self.dx_frac)
        cy = w[:, 1] + w[:, 3] * (0.5 + self.dy_frac)
        bw = w[:, 2] * self.ratio_w
        bh = w[:, 3] * self.ratio_h
        return np.stack([cx - bw / 2, cy - bh / 2, bw, bh], axis=1)

    # ------------------------------------------------------------------ detection
    def raw_windows(self, grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grouped cascade windows (source pixels) and their neighbour counts, before filters."""
        p = self.params
        h, w = grey.shape
        z = self.detection_scale(w)
        dw, dh = max(1, int(round(w * z))), max(1, int(round(h * z)))
        img = grey if (dw, dh) == (w, h) else cv2.resize(
            grey, (dw, dh), interpolation=cv2.INTER_LINEAR if z > 1 else cv2.INTER_AREA)
        if dw < self.window[0] or dh < self.window[1]:
            return np.zeros((0, 4)), np.zeros(0)
        if p.grid_step_px == 2:
            rects, counts = self.scan_region_windows(img, None)
        else:
            rects, counts = self.classifier.detectMultiScale2(
                img, scaleFactor=p.scale_factor, minNeighbors=int(p.min_neighbors), minSize=self.window)
        rects = np.asarray(rects, np.float64).reshape(-1, 4)
        counts = np.asarray(counts, np.float64).reshape(-1)
        if len(rects) == 0:
            return np.zeros((0, 4)), np.zeros(0)
        sx, sy = w / dw, h / dh
        return rects * np.array([sx, sy, sx, sy]), counts

    def _levels(self, dw: int, dh: int):
        """OpenCV's pyramid for a ``dw x dh`` image: (factor, float32 factor, level size, window size)."""
        return [lv[:4] for lv in self._level_plan(dw, dh)]

    def _level_plan(self, dw: int, dh: int) -> list:
        """Per pyramid level of a ``dw x dh`` detection image: (factor, float32 factor, level size,
        window size, grid step, first row not scanned), cached per image size, scale factor and grid.

        The last entry is OpenCV's stripe rule: it splits each level's rows into stripes sized
        from the first level's width, so with a 2 px grid the last row can fall outside every
        stripe, and a per-level call must skip it too.
        """
        p = self.params
        key = (dw, dh, float(p.scale_factor), int(p.grid_step_px), self.window)
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        ww, wh = self.window
        n_stripes = max(1, int(np.ceil((dw + 1 - ww) / 32.0)))
        plan = []
        f = 1.0
        while True:
            win = (int(np.rint(ww * f)), int(np.rint(wh * f)))
            f32 = np.float32(f)
            sz = (int(np.rint(np.float32(dw) / f32)), int(np.rint(np.float32(dh) / f32)))
            if sz[0] < ww or sz[1] < wh:
                break
            step = 1 if (f32 >= 2.0 and p.grid_step_px == 0) else 2
            szw_h = sz[1] + 1 - wh
            stripe = max((szw_h // step + n_stripes - 1) // n_stripes, 1) * step
            plan.append((f, f32, sz, win, step, min(n_stripes * stripe, szw_h)))
            f *= p.scale_factor
        if len(self._plans) > 16:
            self._plans.clear()
        self._plans[key] = plan
        return plan

    def scan_region_windows(self, img: np.ndarray, row_min_det: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Grouped cascade windows of one detection-scale image, scanning each pyramid level from
        a first row on (detection pixels, in the same units as the returned windows).

        ``row_min_det[k]`` is the first window top row scanned at level ``k`` (None: all rows).
        Every level is scanned by its own ``detectMultiScale`` call on the rows of the level image
        that OpenCV would build (``INTER_LINEAR_EXACT``, float32 scale, its 2 px grid below scale 2
        and 1 px grid from 2 on, obtained by scanning the pixel-doubled level at scale 2), so each
        window scanned gets OpenCV's decision and its box; the raw windows are then grouped as
        ``detectMultiScale`` groups them (``groupRectangles``, eps 0.2).  With ``row_min_det``
        None (and OpenCV's grid, ``grid_step_px`` 0) the result equals ``detectMultiScale2`` on
        the whole image; with ``grid_step_px`` 2 every level is scanned on the 2 px grid, by the
        Numba scanner (:mod:`seawatch.detect.cascade_scan`: the same windows as OpenCV's call)
        unless ``scanner`` is "opencv", and with ``grid_step_x_px`` 4 on a 4 px grid in x.
        """
        p = self.params
        dh, dw = img.shape
        ww, wh = self.window
        pos, lvl_f, lvl_win = [], [], []
        for k, (f, f32, sz, win, step, y_end) in enumerate(self._level_plan(dw, dh)):
            y_lo = 0
            if row_min_det is not None:
                y_lo = int(np.ceil(max(0.0, float(row_min_det[k])) / float(f32)))
                y_lo += (-y_lo) % step  # OpenCV's grid starts at row 0
            if y_end - y_lo <= 0:
                continue
            lvl = img if sz == (dw, dh) else cv2.resize(img, sz, interpolation=cv2.INTER_LINEAR_EXACT)
            y_last = y_lo + ((y_end - 1 - y_lo) // step) * step  # last row scanned
            y_stop = y_last + wh
            if step == 2 and self._use_numba():
                # the same windows as OpenCV's call below (tests/test_cascade_scan.py)
                r = self.packed.scan(lvl[y_lo:y_stop], 0, y_last - y_lo, step_x=max(2, p.grid_step_x_px))
            else:
                r = self._opencv_level(lvl, y_lo, y_stop, step)
            if len(r) == 0:
                continue
            r = r[r[:, 1] <= y_last - y_lo]
            if len(r) == 0:
                continue
            r[:, 1] += y_lo
            pos.append(r)
            lvl_f.append(np.full(len(r), f32, np.float32))
            lvl_win.append(np.repeat(np.array([win], np.int64), len(r), axis=0))
        if not pos:
            return np.zeros((0, 4)), np.zeros(0)
        xy = np.rint(np.concatenate(pos).astype(np.float32) * np.concatenate(lvl_f)[:, None]).astype(np.int64)
        rects = np.concatenate([xy, np.concatenate(lvl_win)], axis=1).astype(np.int32)
        mn = int(p.min_neighbors)
        if mn <= 0:
            return rects.astype(np.float64), np.ones(len(rects))
        g, counts = cv2.groupRectangles(rects.tolist(), mn, 0.2)
        g = np.asarray(g, np.float64).reshape(-1, 4)
        return g, np.asarray(counts, np.float64).reshape(-1)[: len(g)]

    def _opencv_level(self, lvl: np.ndarray, y_lo: int, y_stop: int, step: int) -> np.ndarray:
        """Raw window corners (x, y) of one level's rows ``y_lo`` to ``y_stop`` by OpenCV's own
        call, on its grid ``step`` (relative to ``y_lo``; rows past the last scanned one included)."""
        ww, wh = self.window
        if step == 2 and (y_stop - y_lo + 1 - wh) % 2 == 1:
            # one more row, never scanned (no window of this call starts on it), so that this
            # call's own stripes reach the last row: the level's next row, or a copy of the last
            if y_stop < lvl.shape[0]:
                part = lvl[y_lo:y_stop + 1]
            else:
                part = np.concatenate([lvl[y_lo:y_stop], lvl[y_stop - 1:y_stop]], axis=0)
        else:
            part = lvl[y_lo:y_stop]
        if step == 1:
            big = np.repeat(np.repeat(part, 2, axis=0), 2, axis=1)
            r, _ = self.classifier.detectMultiScale2(big, scaleFactor=2.0, minNeighbors=0,
                                                     minSize=(2 * ww, 2 * wh), maxSize=(2 * ww, 2 * wh))
            return np.asarray(r, np.int64).reshape(-1, 4)[:, :2] // 2
        r, _ = self.classifier.detectMultiScale2(np.ascontiguousarray(part), scaleFactor=2.0, minNeighbors=0,
                                                 minSize=(ww, wh), maxSize=(ww, wh))
        return np.asarray(r, np.int64).reshape(-1, 4)[:, :2]

    def _use_numba(self) -> bool:
        """Whether the 2 px grid's levels are scanned by :mod:`seawatch.detect.cascade_scan`."""
        return self.packed is not None and self.params.grid_step_px == 2 and self.params.scanner != "opencv"

    def region_rows(self, horizon: Horizon, z: float, dw: int, dh: int) -> np.ndarray:
        """First window top row (detection pixels) per pyramid level that can still give an
        accepted detection under ``horizon`` (source pixels, resized by ``z``).

        The horizon filter acts on the grouped windows: under a water-coast line a window is kept
        when its centre is on or below the line, so a window of height ``h`` needs its top at or
        below ``line - 0.5 h``; under a water-sky line when its bottom is, ``line - h``. The
        box-based reach (``0.5 + dy``, and ``+ ratio_h / 2`` under a sky line) is used where it
        is larger.  ``line`` is the highest point of the line, and ``scan_region_margin_win``
        window heights more are scanned for the windows that group with them (the grouping can
        chain windows across the cut, so the region is exact only as far as that margin covers
        the chain: no difference was measured, see docs/cascade.md).
        """
        p = self.params
        top = float(min(horizon.y_left, horizon.y_right)) * z
        coast = horizon.kind == "coast"
        reach_box = 0.5 + self.dy_frac + (0.0 if coast else self.ratio_h / 2.0)
        reach = max(reach_box, 0.5 if coast else 1.0) + p.scan_region_margin_win
        wins_h = np.array([lv[3][1] for lv in self._level_plan(dw, dh)], np.float64)
        return np.maximum(0.0, top - reach * wins_h)

    def detect_grey(self, grey_raw: np.ndarray, t_s: float = 0.0, ir: bool = False
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Boxes and scores on one grey (unsmoothed) image; updates the horizon state.

        With the horizon filter on and ``water_roi``, the cascade scans only the image below
        the horizon line less ``roi_margin_frac`` of the image height: detections whose centre
        lies above a water-coast line are dropped anyway, and the textured land is where a
        cascade spends its time (flat sky and water are rejected by the variance check).
        """
        p = self.params
        g = prepare_grey(grey_raw, ir=ir, median_px=p.median_px)
        y0 = 0
        if p.horizon_filter:
            self._update_horizon(grey_raw, t_s, ir)
            if p.scan_region and self.horizon is not None and self.horizon.width == g.shape[1]:
                wins, counts = self.region_scan(g)
                return self.postprocess(g, grey_raw, wins, counts, t_s, ir, update_horizon=False)
            if p.water_roi and self.horizon is not None:
                y0 = int(max(0.0, np.floor(min(self.horizon.y_left, self.horizon.y_right)
                                           - p.roi_margin_frac * g.shape[0])))
        wins, counts = self.raw_windows(g[y0:] if y0 else g)
        if y0 and len(wins):
            wins = wins + np.array([0.0, y0, 0.0, 0.0])
        return self.postprocess(g, grey_raw, wins, counts, t_s, ir, update_horizon=False)

    def region_scan(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grouped windows (source pixels) and neighbour counts, scanning only the region that can
        hold an accepted detection under the current horizon line (see :meth:`region_rows`)."""
        h, w = g.shape
        z = self.detection_scale(w)
        dw, dh = max(1, int(round(w * z))), max(1, int(round(h * z)))
        if dw < self.window[0] or dh < self.window[1]:
            return np.zeros((0, 4)), np.zeros(0)
        img = g if (dw, dh) == (w, h) else cv2.resize(
            g, (dw, dh), interpolation=cv2.INTER_LINEAR if z > 1 else cv2.INTER_AREA)
        rows = self.region_rows(self.horizon, dh / h, dw, dh)
        rects, counts = self.scan_region_windows(img, rows)
        if len(rects) == 0:
            return np.zeros((0, 4)), np.zeros(0)
        sx, sy = w / dw, h / dh
        return rects * np.array([sx, sy, sx, sy]), counts

    def _update_horizon(self, grey_raw: np.ndarray, t_s: float, ir: bool) -> None:
        src = grey_raw if grey_raw.dtype == np.uint8 and not ir else prepare_grey(grey_raw, ir=True, median_px=0)
        self.horizon = self.horizon_tracker.update(src, t_s)

    def postprocess(self, g: np.ndarray, grey_raw: np.ndarray, wins: np.ndarray, scores: np.ndarray,
                    t_s: float = 0.0, ir: bool = False, min_neighbors: int | None = None,
                    update_horizon: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The filters after the cascade: neighbour threshold, Canny pruning, nested boxes,
        horizon line, reflections; then windows become boxes.

        ``min_neighbors`` (default: the detector's) drops grouped windows with fewer neighbours,
        so that one cascade pass run with ``min_neighbors=1`` can be re-thresholded.
        """
        p = self.params
        mn = p.min_neighbors if min_neighbors is None else min_neighbors
        if len(wins) and (min_neighbors is not None or p.neighbors_size_exp != 0):
            w_det = wins[:, 2] * self.detection_scale(g.shape[1]) / self.window[0]
            keep = scores >= mn * np.maximum(w_det, 1.0) ** p.neighbors_size_exp
            wins, scores = wins[keep], scores[keep]
        if p.canny_prune and len(wins):
            keep = canny_prune(g, wins, p.min_edge_frac)
            wins, scores = wins[keep], scores[keep]
        if p.suppress_nested and len(wins) > 1:
            keep = suppress_nested(wins, scores)
            wins, scores = wins[keep], scores[keep]
        if p.horizon_filter:
            if update_horizon:
                self._update_horizon(grey_raw, t_s, ir)
            if len(wins):
                keep = horizon_filter(wins, self.horizon)
                wins, scores = wins[keep], scores[keep]
        if p.reflection_filter and len(wins):
            keep = reflection_filter(g, wins, p.reflection_min_per_100px2, p.fast_threshold)
            wins, scores = wins[keep], scores[keep]
        self.last_windows = wins
        return self.windows_to_boxes(wins), scores

    def detect(self, frame: Frame) -> Detections:
        """Detect boats in one frame.

        A corrupt frame (empty, wrong shape) gives no detections and is counted in
        ``n_bad_frames``; it never raises.
        """
        try:
            grey = to_grey(frame.image, f"frame {frame.index}")
        except ValueError:
            self.n_bad_frames += 1
            return Detections.empty(frame.t_s, frame.index, self.name, frame.camera_id)
        ir = frame.modality == Modality.IR
        boxes, scores = self.detect_grey(grey, frame.t_s, ir=ir)
        return Detections(frame.t_s, frame.index, boxes, scores, self.name, frame.camera_id)

    def observe(self, frame: Frame) -> None:
        """Update the time-smoothed horizon line from a frame without detecting (cheap)."""
        if not self.params.horizon_filter:
            return
        try:
            grey = to_grey(frame.image, f"frame {frame.index}")
        except ValueError:
            self.n_bad_frames += 1
            return
        self._update_horizon(grey, frame.t_s, frame.modality == Modality.IR)

    def reset(self) -> None:
        """Forget the horizon state (a new video)."""
        self.horizon_tracker.reset()
        self.horizon = None
