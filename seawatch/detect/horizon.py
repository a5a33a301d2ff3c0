"""Horizon line (water-sky or water-coast line) detector of paper A (Bloisi et al.).

As the authors' code does it: Canny(50, 70) on the unsmoothed grey image with the 5 top and
bottom rows zeroed, the standard Hough transform (1 px, 1 degree, 100 votes), only the lines
with ``theta`` in [1.50, 1.60] rad (within 4 degrees of horizontal).  The candidates are walked
from the bottom of the image up; a line is accepted when its two ends (columns 0 and W - 1)
differ by less than 10 px and more than 90 % of about 150 pixel pairs (the rows 10, 20 and 30 px
above and below the line, at about 50 columns) differ by more than 10 grey levels; otherwise the
next line up is tried.  Unlike the original, which compares rows at the mean height of the two
ends, the pairs are sampled along the actual, sloped line, and each Hough line is first refitted
(least squares) to the edge pixels within 3 px of it, which removes the 1-degree quantisation of
the Hough grid.

The image is worked on at a fixed working width (session 14): 352 px, MarDCT's own width, the video
size the authors' pixel constants (Canny 50/70, 100 votes, 10 px ends, 10-30 px pairs) were made
for; when no line passes there, once more at 288 px.  Only wider images are resized (area
averaging, by an integer factor first), and the line is scaled back.  An upscaled or soft frame
(a 320x240 video shown at 704x576) spreads the horizon's grey step over several pixels, so its
Sobel gradient falls under the Canny thresholds at full size; at the working width the step is
sharp again, and the coarser second width recovers most of the lines that are still too soft at
the first (on the training and validation frames, see docs/cascade.md).  The pixel constants count
in working pixels, so near the top or bottom of a wide frame (within about 30 working rows: 15 % of
a 1080p frame's height at 352 px) no line can pass; when neither width gives a line, the image is
tried once more at 640 px wide (session 13's width; at its own size when narrower).

The line is then classified: a *water-coast* line has texture above it (coast, quays,
buildings), a *water-sky* line has none.  :func:`horizon_filter` drops detections whose centre
lies above a water-coast line (the authors' rule) and those lying wholly above a water-sky line.
:class:`HorizonTracker` smooths the line over time (time constant in seconds) and holds it for a
while when a frame gives none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from seawatch.detect.filters import normalize_ir, to_grey

__all__ = ["Horizon", "detect_horizon", "horizon_filter", "HorizonTracker"]


@dataclass(frozen=True)
class Horizon:
    """A horizon line in image pixels: row ``y_left`` at column 0, ``y_right`` at column ``width - 1``."""

    y_left: float
    y_right: float
    width: int
    kind: str = "sky"  # "sky" (water-sky) or "coast" (water-coast)
    support: float = 1.0  # fraction of pixel pairs that differ across the line

    def row_at(self, x) -> np.ndarray:
        """Row of the line at column(s) ``x``."""
        x = np.asarray(x, np.float64)
        if self.width <= 1:
            return np.full_like(x, self.y_left)
        return self.y_left + (self.y_right - self.y_left) * x / (self.width - 1)

    @property
    def angle_deg(self) -> float:
        """Slope angle, positive when the line goes down to the right (image rows grow downwards)."""
        return math.degrees(math.atan2(self.y_right - self.y_left, max(self.width - 1, 1)))


def _texture_above(grey: np.ndarray, edges: np.ndarray, yl: float, yr: float, band_px: int) -> float:
    """Edge density in a band above the line (skipping the 3 px next to it)."""
    h, w = grey.shape
    xs = np.arange(0, w, 2)
    ys_line = yl + (yr - yl) * xs / max(w - 1, 1)
    tot = 0
    cnt = 0
    for d in range(3, band_px + 3, 2):
        ys = np.round(ys_line - d).astype(int)
        ok = ys >= 6
        tot += int((edges[ys[ok], xs[ok]] > 0).sum())
        cnt += int(ok.sum())
    return tot / cnt if cnt else 0.0


def _refine_one(pts: tuple[np.ndarray, np.ndarray], yl: float, yr: float, w: int, band_px: float = 3.0
                ) -> tuple[float, float]:
    """Least-squares fit of a Hough line to the edge pixels within ``band_px`` of it.

    The Hough grid is 1 degree and 1 px; the fit removes that quantisation (which alone can
    push the two ends of a long line 10 px apart).
    """
    xf, yf = pts
    if len(xf) == 0:
        return yl, yr
    a, b = yl, (yr - yl) / max(w - 1, 1)
    lo, hi = min(yl, yr) - band_px - 1, max(yl, yr) + band_px + 1
    sel = (yf >= lo) & (yf <= hi)  # edge rows near the line only
    xs, ys = xf[sel], yf[sel]
    for _ in range(2):
        near = np.abs(ys - (a + b * xs)) <= band_px
        n = int(near.sum())
        if n < max(10, 0.1 * w):
            break
        xn, yn = xs[near], ys[near]
        mx, my = xn.mean(), yn.mean()
        vx = float(((xn - mx) ** 2).sum())
        if vx <= 0:
            break
        b = float(((xn - mx) * (yn - my)).sum()) / vx
        a = my - b * mx
    return float(a), float(a + b * (w - 1))


def detect_horizon(
    image: np.ndarray,
    ir: bool = False,
    canny_low: float = 50.0,
    canny_high: float = 70.0,
    hough_votes: int = 100,
    theta_range_rad: tuple[float, float] = (1.50, 1.60),
    max_end_diff_px: float = 10.0,
    pair_offsets_px: tuple[int, ...] = (10, 20, 30),
    n_columns: int = 50,
    min_grey_diff: float = 10.0,
    min_support: float = 0.9,
    coast_edge_density: float = 0.04,
    max_lines: int = 100,
    work_width_px: int | tuple[int, ...] = (352, 288),
    fallback_width_px: int = 640,
) -> Horizon | None:
    """Find the horizon line in one frame.

    Parameters
    ----------
    image : (H, W) grey or (H, W, 3) BGR image (8- or 16-bit).
    ir : bool
        Normalise the image by scale and shift (percentile stretch) first.
    canny_low, canny_high : float
        Canny thresholds (the authors' 50, 70).
    hough_votes : int
        Standard Hough accumulator threshold (100).
    theta_range_rad : (float, float)
        Accepted line normal angles (1.50..1.60 rad: near-horizontal lines).
    max_end_diff_px : float
        Largest difference between the rows of the two ends of the line.
    pair_offsets_px : tuple of int
        Distances above and below the line of the compared pixel pairs.
    n_columns : int
        Number of sampled columns (pairs = columns x offsets).
    min_grey_diff : float
        A pair "differs" when its grey levels differ by more than this.
    min_support : float
        Fraction of differing pairs needed to accept a line.
    coast_edge_density : float
        Edge density above the line beyond which it is a water-coast line.
    max_lines : int
        At most this many Hough lines (strongest first) are considered.
    work_width_px : int or tuple of int
        Working widths, tried in turn until one gives a line: an image wider than a working
        width is resized to it (area averaging; the pixel parameters refer to the working
        image), a narrower one is used as it is (once).  0 or () : the image's own size only.
    fallback_width_px : int
        Tried last, only when no working width gives a line (0: none): the image resized to this
        width, or at its own size when narrower (session 13's detector worked at up to 640 px).
        The pixel constants (5 zeroed border rows, pairs up to 30 px from the line) are counted
        in working pixels, so at 352 px a line within about 30 working rows of the top or bottom
        (15 % of a 1920x1080 frame's height) cannot pass; at 640 px the band is about half as
        wide.  Its area resize is computed from the image itself, not shared with the working
        widths.

    Returns
    -------
    Horizon in the input image's pixels, or None when no line passes.
    """
    g0 = to_grey(image, "detect_horizon")
    if ir or g0.dtype != np.uint8:
        g0 = normalize_ir(g0)
    h0, w0 = g0.shape
    widths = (work_width_px,) if isinstance(work_width_px, (int, np.integer)) else tuple(work_width_px)
    sizes: list[int] = []
    for ww in widths or (0,):
        ww = int(ww)
        s = ww if 0 < ww < w0 else w0
        if s not in sizes:
            sizes.append(s)
    kw = dict(canny_low=canny_low, canny_high=canny_high, hough_votes=hough_votes, theta_range_rad=theta_range_rad,
              max_end_diff_px=max_end_diff_px, pair_offsets_px=pair_offsets_px, n_columns=n_columns,
              min_grey_diff=min_grey_diff, min_support=min_support, coast_edge_density=coast_edge_density,
              max_lines=max_lines)
    for s, base, kb in _working_images(g0, sizes):
        g, fx, fy = _resize_to(g0, s, base, kb)
        found = _detect_at(g, **kw)
        if found is not None:
            return _scaled_back(found, g.shape[1], fx, fy, w0)
    fb = int(fallback_width_px)
    if fb > 0:
        s = min(fb, w0)
        if s not in sizes:
            for s, base, kb in _working_images(g0, [s]):
                g, fx, fy = _resize_to(g0, s, base, kb)
                found = _detect_at(g, **kw)
                if found is not None:
                    return _scaled_back(found, g.shape[1], fx, fy, w0)
    return None


def _working_images(g0: np.ndarray, sizes: list[int]):
    """Yield ``(width, base, k)`` for each working width in turn: ``base`` is the image averaged
    over k x k blocks, shared by all the widths (or the image itself, k = 1).

    Area averaging: OpenCV's INTER_AREA is fast only for integer factors (5-6 ms from 1920x1080 to
    352 px wide against about 1.4 ms for a factor of 5), so the image is first averaged once over
    k x k blocks (k: the integer part of the largest working factor; the last < k rows and columns
    are left out), and each working width is then area-resized from that small image.  The base
    is computed only when the first width narrower than the image is reached.
    """
    h0, w0 = g0.shape
    base, kb = None, 1
    for s in sizes:
        if s < w0 and base is None:
            wmax = max(x for x in sizes if x < w0)
            k = max(1, min(w0 // wmax, h0 // max(1, int(round(h0 * wmax / w0)))))
            base, kb = g0, 1
            if k >= 2:
                base = cv2.resize(g0[: (h0 // k) * k, : (w0 // k) * k], (w0 // k, h0 // k),
                                  interpolation=cv2.INTER_AREA)
                kb = k
        yield s, (g0 if base is None else base), kb


def _resize_to(g0: np.ndarray, s: int, base: np.ndarray, kb: int) -> tuple[np.ndarray, float, float]:
    """The working image ``s`` px wide and its scale factors (working px per input px)."""
    h0, w0 = g0.shape
    if s == w0:
        return g0, 1.0, 1.0
    hs = max(1, int(round(h0 * s / w0)))
    g = base if base.shape == (hs, s) else cv2.resize(base, (s, hs), interpolation=cv2.INTER_AREA)
    return g, s / (base.shape[1] * kb), hs / (base.shape[0] * kb)


def _scaled_back(found: tuple[float, float, str, float], w: int, fx: float, fy: float, w0: int) -> Horizon:
    """A working-image line back in the input's pixels.

    Pixel centres scale as (v + 0.5) / f - 0.5; the ends are at columns 0 and w - 1 of the
    working image, i.e. at (0.5 / fx - 0.5) and (w - 0.5) / fx - 0.5 of the input: the line is
    extended to columns 0 and w0 - 1.
    """
    a, b, kind, support = found
    xa, xb = 0.5 / fx - 0.5, (w - 0.5) / fx - 0.5
    ya, yb = (a + 0.5) / fy - 0.5, (b + 0.5) / fy - 0.5
    slope = (yb - ya) / (xb - xa) if xb > xa else 0.0
    y0 = ya - slope * xa
    y1 = ya + slope * (w0 - 1 - xa)
    return Horizon(float(y0), float(y1), w0, kind, support)


def _detect_at(g: np.ndarray, canny_low: float, canny_high: float, hough_votes: int,
               theta_range_rad: tuple[float, float], max_end_diff_px: float, pair_offsets_px: tuple[int, ...],
               n_columns: int, min_grey_diff: float, min_support: float, coast_edge_density: float,
               max_lines: int) -> tuple[float, float, str, float] | None:
    """The authors' line search on one (working-size) grey image: rows of the line at its first
    and last columns, its kind and its pair support, or None."""
    h, w = g.shape
    omax = max(pair_offsets_px)
    if h < 2 * omax + 12 or w < 8:
        return None
    edges = cv2.Canny(g, canny_low, canny_high, apertureSize=3)
    edges[:5] = 0
    edges[-5:] = 0
    step = math.pi / 180.0
    t0 = math.ceil(theta_range_rad[0] / step - 1e-9) * step
    t1 = math.floor(theta_range_rad[1] / step + 1e-9) * step
    lines = cv2.HoughLines(edges, 1, step, int(hough_votes), min_theta=t0 - 1e-6, max_theta=t1 + 1e-6)
    if lines is None:
        return None
    lines = lines[:max_lines, 0, :]
    rho, theta = lines[:, 0].astype(np.float64), lines[:, 1].astype(np.float64)
    keep = (theta >= theta_range_rad[0]) & (theta <= theta_range_rad[1])
    rho, theta = rho[keep], theta[keep]
    if len(rho) == 0:
        return None
    # row at column x: y = (rho - x cos t) / sin t
    yl = rho / np.sin(theta)
    yr = (rho - (w - 1) * np.cos(theta)) / np.sin(theta)
    order = np.argsort(-(yl + yr))  # bottom first
    pts = None  # edge pixel coordinates, found when a line is first refitted
    cols = np.linspace(0, w - 1, n_columns + 1)[1:-1] if n_columns > 1 else np.array([w / 2])
    xc = np.round(cols).astype(int)
    gi = g.astype(np.int16)

    def support_of(a: float, b: float) -> float:
        ys = a + (b - a) * cols / max(w - 1, 1)
        if ys.min() - omax < 0 or ys.max() + omax > h - 1:
            return -1.0
        yc = np.round(ys).astype(int)
        diffs = np.concatenate([np.abs(gi[yc - d, xc] - gi[yc + d, xc]) for d in pair_offsets_px])
        return float((diffs > min_grey_diff).mean())

    slack = 0.5 * math.pi / 180.0 * w + 1.0  # the Hough grid's angular quantisation over the width
    seen: list[tuple[float, float]] = []
    for i in order:
        a, b = float(yl[i]), float(yr[i])
        if abs(a - b) >= max_end_diff_px + slack or any(abs(a - p) < 1.5 and abs(b - q) < 1.5 for p, q in seen):
            continue
        seen.append((a, b))
        if support_of(a, b) <= min_support - 0.2:  # hopeless even before refitting
            continue
        if pts is None:
            ys_e, xs_e = np.nonzero(edges)
            pts = (xs_e.astype(np.float64), ys_e.astype(np.float64))
        a, b = _refine_one(pts, a, b, w)
        if abs(a - b) >= max_end_diff_px:
            continue
        support = support_of(a, b)
        if support > min_support:
            band = max(8, int(round(0.08 * h)))
            tex = _texture_above(g, edges, a, b, band)
            kind = "coast" if tex > coast_edge_density else "sky"
            return a, b, kind, support
    return None


def horizon_filter(boxes: np.ndarray, horizon: Horizon | None, sky_margin_frac: float = 0.0) -> np.ndarray:
    """Mask of the boxes that survive the horizon line (``True`` = keep).

    Water-coast line: a box whose centre lies above the line is dropped.  Water-sky line: a
    box whose bottom lies above the line (by more than ``sky_margin_frac`` of its height) is
    dropped, since a vessel sits on or below the horizon.
    """
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    if horizon is None or len(b) == 0:
        return np.ones(len(b), bool)
    cx = b[:, 0] + b[:, 2] / 2
    line = horizon.row_at(cx)
    if horizon.kind == "coast":
        return b[:, 1] + b[:, 3] / 2 >= line
    return b[:, 1] + b[:, 3] * (1.0 + sky_margin_frac) >= line


class HorizonTracker:
    """Horizon line smoothed over time.

    Parameters
    ----------
    tau_s : float
        Time constant of the exponential smoothing of the line's two ends, seconds.
    hold_s : float
        How long the last line is kept when frames give none, seconds.
    max_jump_px : float
        A new line farther than this from the smoothed one (at either end) restarts the
        smoothing (a pan or zoom moved it).
    every_s : float
        Detect the line at most once per this many seconds (0: every frame).
    **detect_kw
        Passed to :func:`detect_horizon`.
    """

    def __init__(self, tau_s: float = 0.5, hold_s: float = 2.0, max_jump_px: float = 25.0, every_s: float = 0.0,
                 **detect_kw):
        if tau_s < 0 or hold_s < 0 or every_s < 0:
            raise ValueError("HorizonTracker: tau_s, hold_s and every_s must be >= 0")
        self.every_s = float(every_s)
        self.t_detect: float | None = None
        self.tau_s = float(tau_s)
        self.hold_s = float(hold_s)
        self.max_jump_px = float(max_jump_px)
        self.detect_kw = detect_kw
        self.state: Horizon | None = None
        self.t_last: float | None = None  # time of the last line found
        self.t_prev: float | None = None  # time of the last update

    def reset(self) -> None:
        self.state = None
        self.t_last = self.t_prev = self.t_detect = None

    def update(self, image: np.ndarray, t_s: float, ir: bool = False) -> Horizon | None:
        """Detect the line in this frame and return the smoothed line (or None).

        With ``every_s > 0`` the line is detected at most once per ``every_s`` seconds; in
        between, the smoothed line is returned as it is.
        """
        if self.every_s > 0 and self.t_detect is not None and 0.0 <= t_s - self.t_detect < self.every_s:
            return self.state
        self.t_detect = float(t_s)
        found = detect_horizon(image, ir=ir, **self.detect_kw)
        return self.update_with(found, t_s)

    def update_with(self, found: Horizon | None, t_s: float) -> Horizon | None:
        """Smooth an already detected line (or None) into the state."""
        t_s = float(t_s)
        if found is None:
            if self.state is not None and self.t_last is not None and t_s - self.t_last > self.hold_s:
                self.state = None
            self.t_prev = t_s
            return self.state
        if self.state is None or self.state.width != found.width or (
            max(abs(found.y_left - self.state.y_left), abs(found.y_right - self.state.y_right)) > self.max_jump_px
        ):
            self.state = found
        else:
            dt = max(0.0, t_s - (self.t_prev if self.t_prev is not None else t_s))
            a = 1.0 if self.tau_s == 0 else 1.0 - math.exp(-dt / self.tau_s)
            a = max(a, 0.05)
            yl = self.state.y_left + a * (found.y_left - self.state.y_left)
            yr = self.state.y_right + a * (found.y_right - self.state.y_right)
            self.state = Horizon(yl, yr, found.width, found.kind, found.support)
        self.t_last = self.t_prev = t_s
        return self.state
