"""Train a boosted Haar cascade in the manner of ``opencv_traincascade``, with hard-negative mining.

Stage after stage, :func:`train_cascade`

1. keeps the positives the cascade so far still accepts;
2. mines negatives: it scans random crops of the negative images, at random scales, with the
   cascade so far (:func:`~seawatch.train.model.scan_image`, the same decisions as
   ``cv2.CascadeClassifier``) and keeps windows it accepts away from every boat; the share of
   scanned windows accepted is the cascade's false-alarm rate so far;
3. trains a Gentle AdaBoost stage of stumps (:func:`~seawatch.train.boost.train_stage`) on a
   random subset of the Haar feature pool;

until the stage count, the target false-alarm rate (too few negatives found) or the time budget
is reached.  An optional last *wake stage* (the paper's 25th level) is trained against the
cascade's own false alarms on the training images and against the wakes beside the boats.
The cascade is written to OpenCV XML after every stage.
"""

from __future__ import annotations

import json
import time
from collections import OrderedDict
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np

from seawatch.train.boost import passes, train_stage, bin_features
from seawatch.train.haar import HaarFeatures, feature_values, generate_features, integral_images, window_norm
from seawatch.train.model import Cascade, evaluate_windows, scan_image, write_cascade_xml
from seawatch.train.samples import (
    LabelledImage, box_ratios, box_to_window, extract_windows, iou_matrix,
)

__all__ = ["TrainSettings", "train_cascade", "collect_positives", "mine_negatives", "detect_windows"]


@dataclass
class TrainSettings:
    """Parameters of :func:`train_cascade` (all have opencv_traincascade-like defaults)."""

    width_px: int = 60
    height_px: int = 30
    margin: float = 1.2  # window width = margin * max(box w, aspect * box h)
    n_stages: int = 20
    min_hit_rate: float = 0.995
    max_false_alarm: float = 0.5
    target_false_alarm: float = 1e-6  # stop when the cascade's false-alarm rate falls below
    max_weak_count: int = 100
    # stumps allowed in the first stages (then max_weak_count): cheap early stages make a fast
    # detector; a capped stage may stop above max_false_alarm
    early_weak_counts: tuple[int, ...] = ()
    weight_trim_rate: float = 0.95
    n_bins: int = 64
    feature_kinds: tuple[str, ...] = ("x2", "y2", "x3", "y3", "x4", "y4", "x2y2", "point")
    feature_pos_step_px: int = 2
    feature_size_step_px: int = 2
    features_per_stage: int = 6000
    n_aug: dict = field(default_factory=lambda: {"mardct": 24, "coral": 6, "sim": 4})
    min_box_w_px: float = 12.0  # smaller boxes are ignored (not positives, not negatives)
    # share of augmented positives seen as a far boat would be: the window area-downsampled to
    # lowres_window_px wide (boats of about 20-50 px), median 3x3, upscaled to the window
    lowres_prob: float = 0.5
    lowres_window_px: tuple[float, float] = (28.0, 60.0)
    # augmented positives (all but the first copy of each box): window scale drawn log-uniformly in
    # +-scale_jitter, centre shifted uniformly by up to +-shift_jitter of the window's width / height
    scale_jitter: float = 0.08
    shift_jitter: float = 0.06
    max_positives: int = 6000
    neg_per_pos: float = 2.0
    neg_per_crop: int = 12
    crop_px: tuple[int, int] = (360, 270)  # scanned crop, in pixels of the scaled image
    min_window_src_px: float = 20.0  # smallest window width scanned for negatives, source pixels
    neg_iou_max: float = 0.2  # a negative window overlaps no boat or boat window more than this
    max_scan_windows: float = 3e7  # per stage; fewer negatives than needed then: stop
    mine_weights: dict = field(default_factory=lambda: {"mardct": 0.5, "coral": 0.25, "sim": 0.25})
    # the first ``scan_mining_stages`` stages take their negatives from every window the detector
    # scans on the training images (automatic detection scale, its pyramid, its water region), so
    # that early stages learn to reject the port/coast texture the detector meets most
    scan_mining_stages: int = 0
    scan_scale_factor: float = 1.1
    scan_max_upscale: float = 4.0
    scan_box_ratio_w: float = 0.7  # box / window width assumed for the detection scale (v2, v5: 0.70)
    scan_roi_margin_frac: float = 0.2  # water region: below the horizon less this; < 0: whole image
    wake_stage: bool = True
    wake_min_hit_rate: float = 0.99
    wake_max_false_alarm: float = 0.5
    time_budget_s: float = 1800.0
    seed: int = 0


def _log_default(msg: str) -> None:
    print(msg, flush=True)


class _GreyCache:
    """A few prepared grey images kept in memory (the big ones are re-read when needed)."""

    def __init__(self, max_items: int = 12):
        self.max_items = max_items
        self.items: OrderedDict[int, np.ndarray] = OrderedDict()

    def get(self, i: int, im: LabelledImage) -> np.ndarray:
        if i in self.items:
            self.items.move_to_end(i)
            return self.items[i]
        g = im.grey()
        self.items[i] = g
        if len(self.items) > self.max_items:
            self.items.popitem(last=False)
        return g


def collect_positives(images: list[LabelledImage], s: TrainSettings, rng: np.random.Generator,
                      log=_log_default) -> tuple[np.ndarray, np.ndarray]:
    """Augmented positive windows of every boat box (with their source names).

    Returns ``(windows (N, H, W) uint8, source (N,) str)``; flat windows that OpenCV would not
    evaluate are dropped.
    """
    size = (s.width_px, s.height_px)
    aspect = s.width_px / s.height_px
    out, src = [], []
    for im in images:
        b = im.boxes[im.boxes[:, 2] >= s.min_box_w_px] if len(im.boxes) else im.boxes
        if len(b) == 0:
            continue
        g = im.grey()
        wins = box_to_window(b, aspect, s.margin)
        out.append(extract_windows(g, wins, size, rng, n_aug=int(s.n_aug.get(im.source, 4)),
                                   scale_jitter=s.scale_jitter, shift_jitter=s.shift_jitter,
                                   lowres_prob=s.lowres_prob, lowres_window_px=tuple(s.lowres_window_px)))
        src += [im.source] * len(out[-1])
    if not out:
        raise ValueError("no positive boxes in the training images")
    pos = np.concatenate(out)
    src = np.asarray(src)
    _, valid = window_norm(pos)
    if (~valid).any():
        log(f"  {int((~valid).sum())} flat positive windows dropped (OpenCV never evaluates them)")
    pos, src = pos[valid], src[valid]
    if len(pos) > s.max_positives:
        keep = np.sort(rng.choice(len(pos), s.max_positives, replace=False))
        pos, src = pos[keep], src[keep]
    return pos, src


def _avoid_boxes(im: LabelledImage, aspect: float, margin: float) -> np.ndarray:
    parts = [im.boxes.reshape(-1, 4), im.ignore.reshape(-1, 4)]
    b = np.concatenate(parts)
    if len(b) == 0:
        return b
    return np.concatenate([b, box_to_window(b, aspect, margin)])


def detection_scale(width_px: int, window_w_px: int, box_ratio_w: float = 0.7, max_upscale: float = 4.0,
                    min_boat_px: float = 0.0) -> float:
    """The detector's automatic resize factor (see :meth:`CascadeDetector.detection_scale`)."""
    min_boat = min_boat_px if min_boat_px > 0 else max(12.0, width_px / 16.0)
    return float(min(max(window_w_px * box_ratio_w / min_boat, 0.05), max_upscale))


class ScanPool:
    """Every window the detector scans on a set of images, level by level.

    Each image is prepared as :class:`~seawatch.detect.cascade.CascadeDetector` prepares a frame
    at its automatic detection scale: the water region (below the horizon line less
    ``roi_margin_frac`` of the image height, when a line is found), resized by the detection
    scale; the pyramid (``scale_factor``) and the 2 px grid are OpenCV's.

    Parameters
    ----------
    images : list of LabelledImage
    window_px : (width, height) of the cascade window.
    scale_factor, box_ratio_w, max_upscale, roi_margin_frac : as the detector's.
    """

    def __init__(self, images: list[LabelledImage], window_px: tuple[int, int], scale_factor: float = 1.1,
                 box_ratio_w: float = 0.7, max_upscale: float = 4.0, roi_margin_frac: float = 0.2):
        from seawatch.detect.horizon import detect_horizon

        self.images = images
        self.win = (int(window_px[0]), int(window_px[1]))
        self.scale_factor = float(scale_factor)
        self.base: list[np.ndarray] = []  # detection-scale image of the scanned region
        self.y0: list[int] = []  # first source row scanned
        self.z: list[float] = []
        self.levels: list[list[tuple[float, tuple[int, int]]]] = []  # (factor, (w, h)) per level
        self.n_windows = np.zeros(len(images), np.int64)
        for i, im in enumerate(images):
            g = im.grey()
            y0 = 0
            if roi_margin_frac >= 0:
                hz = detect_horizon(g)
                if hz is not None:
                    y0 = int(max(0.0, np.floor(min(hz.y_left, hz.y_right) - roi_margin_frac * g.shape[0])))
            g = g[y0:]
            h, w = g.shape
            z = detection_scale(w, self.win[0], box_ratio_w, max_upscale)
            dw, dh = max(1, int(round(w * z))), max(1, int(round(h * z)))
            img = g if (dw, dh) == (w, h) else cv2.resize(
                g, (dw, dh), interpolation=cv2.INTER_LINEAR if z > 1 else cv2.INTER_AREA)
            lv = []
            f = 1.0
            while True:
                sz = (int(round(dw / f)), int(round(dh / f)))
                if sz[0] < self.win[0] or sz[1] < self.win[1]:
                    break
                lv.append((f, sz))
                self.n_windows[i] += ((sz[1] - self.win[1]) // 2 + 1) * ((sz[0] - self.win[0]) // 2 + 1)
                f *= self.scale_factor
            self.base.append(img)
            self.y0.append(y0)
            self.z.append(z)
            self.levels.append(lv)

    def level_image(self, i: int, k: int) -> np.ndarray:
        f, sz = self.levels[i][k]
        img = self.base[i]
        return img if sz == (img.shape[1], img.shape[0]) else cv2.resize(img, sz, interpolation=cv2.INTER_LINEAR)

    def to_source(self, i: int, k: int, hits: np.ndarray) -> np.ndarray:
        """Windows ``(x, y, w, h)`` in source pixels of hits ``(y, x, ...)`` at level ``k`` of image ``i``."""
        f = self.levels[i][k][0]
        c = f / self.z[i]
        return np.stack([hits[:, 1] * c, self.y0[i] + hits[:, 0] * c,
                         np.full(len(hits), self.win[0] * c), np.full(len(hits), self.win[1] * c)], axis=1)

    def stage_histogram(self, cascade: Cascade, images: np.ndarray | None = None, avoid_boats: bool = True,
                        aspect: float = 2.0, margin: float = 1.2, iou_max: float = 0.2) -> np.ndarray:
        """Number of scanned windows by stages passed (``out[j]``: windows that passed exactly ``j``
        stages; flat windows, which OpenCV rejects before the first stage, count as 0).

        With ``avoid_boats`` windows overlapping a boat (or its window) by more than ``iou_max``
        are left out, so that the histogram describes the background the detector meets.
        """
        hist = np.zeros(cascade.n_stages + 1, np.int64)
        self.last_flat = 0  # flat windows of the last histogram (OpenCV never evaluates them)
        idx = range(len(self.images)) if images is None else images
        for i in idx:
            avoid = _avoid_boxes(self.images[i], aspect, margin) if avoid_boats else np.zeros((0, 4))
            for k in range(len(self.levels[i])):
                img = self.level_image(i, k)
                n_all = ((img.shape[0] - self.win[1]) // 2 + 1) * ((img.shape[1] - self.win[0]) // 2 + 1)
                hits = scan_image(cascade, img, step_px=2, min_stage=0, max_hits=n_all + 1)
                if len(avoid) and len(hits):
                    ok = iou_matrix(self.to_source(i, k, hits), avoid).max(axis=1) <= iou_max
                    n_boat = int((~ok).sum())
                    hits = hits[ok]
                else:
                    n_boat = 0
                hist += np.bincount(hits[:, 2], minlength=cascade.n_stages + 1)[: cascade.n_stages + 1]
                hist[0] += n_all - len(hits) - n_boat  # flat windows
                self.last_flat += n_all - len(hits) - n_boat
        return hist


def mine_scan_negatives(
    cascade: Cascade,
    pool: ScanPool,
    n_needed: int,
    s: TrainSettings,
    rng: np.random.Generator,
    expected_pass: dict[str, float],
) -> tuple[np.ndarray, np.ndarray, dict[str, tuple[int, int]]]:
    """A uniform random sample of the windows of ``pool`` that the cascade accepts, away from boats.

    Sources share the sample as ``s.mine_weights`` says.  ``expected_pass`` (per source, the
    expected share of windows the cascade accepts) sets the sampling probability so that one
    pass over the pool gives about ``n_needed`` windows.

    Returns ``(windows (M, H, W) uint8, source (M,), {source: (n_scanned, n_accepted)})``.
    """
    aspect = s.width_px / s.height_px
    srcs = np.array([im.source for im in pool.images])
    kinds = sorted(set(srcs.tolist()))
    wsum = sum(s.mine_weights.get(k, 0.2) for k in kinds)
    q = {}
    for k in kinds:
        n_k = float(pool.n_windows[srcs == k].sum()) * max(expected_pass.get(k, 1.0), 1e-9)
        q[k] = min(1.0, 1.5 * n_needed * s.mine_weights.get(k, 0.2) / wsum / max(n_k, 1.0))
    got: dict[str, list[np.ndarray]] = {k: [] for k in kinds}
    stats = {k: [0, 0] for k in kinds}
    for i in rng.permutation(len(pool.images)):
        im = pool.images[i]
        k_src = im.source
        avoid = _avoid_boxes(im, aspect, s.margin)
        for k in range(len(pool.levels[i])):
            img = pool.level_image(i, k)
            n_all = ((img.shape[0] - s.height_px) // 2 + 1) * ((img.shape[1] - s.width_px) // 2 + 1)
            hits = scan_image(cascade, img, step_px=2, max_hits=n_all + 1)
            if len(avoid) and len(hits):
                boat = iou_matrix(pool.to_source(i, k, hits), avoid).max(axis=1) > s.neg_iou_max
                n_all -= int(boat.sum())
                hits = hits[~boat]
            stats[k_src][0] += n_all
            stats[k_src][1] += len(hits)
            if len(hits) == 0:
                continue
            hits = hits[rng.random(len(hits)) < q[k_src]]
            if len(hits):
                got[k_src].append(np.stack([img[y:y + s.height_px, x:x + s.width_px] for y, x, _ in hits]))
    parts, part_src = [], []
    for k in kinds:
        if got[k]:
            w = np.concatenate(got[k])
            n_k = int(round(n_needed * s.mine_weights.get(k, 0.2) / wsum))
            if len(w) > n_k:
                w = w[np.sort(rng.choice(len(w), n_k, replace=False))]
            parts.append(w)
            part_src += [k] * len(w)
    if not parts:
        return np.zeros((0, s.height_px, s.width_px), np.uint8), np.zeros(0, dtype="<U8"), {
            k: tuple(v) for k, v in stats.items()}
    neg = np.concatenate(parts)
    src = np.asarray(part_src)
    perm = rng.permutation(len(neg))
    return neg[perm], src[perm], {k: tuple(v) for k, v in stats.items()}


def mine_negatives(
    cascade: Cascade,
    images: list[LabelledImage],
    n_needed: int,
    s: TrainSettings,
    rng: np.random.Generator,
    cache: _GreyCache | None = None,
    max_windows: float | None = None,
) -> tuple[np.ndarray, int, int]:
    """Windows accepted by the cascade on random crops of the images, away from every boat.

    Returns ``(windows (M, H, W) uint8, n_scanned, n_accepted)``.
    """
    cache = cache or _GreyCache()
    aspect = s.width_px / s.height_px
    max_windows = s.max_scan_windows if max_windows is None else max_windows
    got: list[np.ndarray] = []
    n_got = n_scan = n_acc = 0
    cw, ch = s.crop_px
    src = [im.source for im in images]
    n_src = {k: src.count(k) for k in set(src)}
    wsum = sum(s.mine_weights.get(k, 0.2) for k in n_src)
    prob = np.array([s.mine_weights.get(k, 0.2) / wsum / n_src[k] for k in src])
    prob /= prob.sum()
    tries = 0
    while n_got < n_needed and n_scan < max_windows and tries < 200000:
        tries += 1
        i = int(rng.choice(len(images), p=prob))
        im = images[i]
        g = cache.get(i, im)
        h, w = g.shape
        ws_max = 0.9 * min(w, aspect * h)
        if ws_max <= s.min_window_src_px:
            continue
        ws = float(np.exp(rng.uniform(np.log(s.min_window_src_px), np.log(ws_max))))
        z = s.width_px / ws  # resize factor source -> scanned
        sw, sh = min(w, int(cw / z)), min(h, int(ch / z))
        if sw * z < s.width_px + 2 or sh * z < s.height_px + 2:
            continue
        x0 = int(rng.integers(0, w - sw + 1))
        y0 = int(rng.integers(0, h - sh + 1))
        crop = g[y0:y0 + sh, x0:x0 + sw]
        dst = (max(s.width_px, int(round(sw * z))), max(s.height_px, int(round(sh * z))))
        scaled = cv2.resize(crop, dst, interpolation=cv2.INTER_LINEAR)
        zx, zy = dst[0] / sw, dst[1] / sh
        off = int(rng.integers(2))
        sub = scaled[off:, off:]
        hits = scan_image(cascade, sub, step_px=2, max_hits=50000)
        n_scan += ((sub.shape[0] - s.height_px) // 2 + 1) * ((sub.shape[1] - s.width_px) // 2 + 1)
        if len(hits) == 0:
            continue
        avoid = _avoid_boxes(im, aspect, s.margin)
        if len(avoid):
            src = np.stack([x0 + (hits[:, 1] + off) / zx, y0 + (hits[:, 0] + off) / zy,
                            np.full(len(hits), s.width_px / zx), np.full(len(hits), s.height_px / zy)], axis=1)
            ok = iou_matrix(src, avoid).max(axis=1) <= s.neg_iou_max
            hits = hits[ok]
        n_acc += len(hits)  # false alarms only: windows on boats are not counted
        if len(hits) == 0:
            continue
        if len(hits) > s.neg_per_crop:
            hits = hits[rng.choice(len(hits), s.neg_per_crop, replace=False)]
        patches = np.stack([sub[y:y + s.height_px, x:x + s.width_px] for y, x, _ in hits])
        got.append(patches)
        n_got += len(patches)
    if not got:
        return np.zeros((0, s.height_px, s.width_px), np.uint8), n_scan, n_acc
    neg = np.concatenate(got)[:n_needed]
    return neg, n_scan, n_acc


def detect_windows(cascade: Cascade, grey: np.ndarray, upscale: float, scale_factor: float = 1.1,
                   max_windows: int = 20000) -> np.ndarray:
    """Raw accepted windows ``(x, y, w, h)`` in source pixels over an image pyramid (no grouping)."""
    out = []
    h, w = grey.shape
    z = upscale
    while True:
        dw, dh = int(round(w * z)), int(round(h * z))
        if dw < cascade.width_px + 1 or dh < cascade.height_px + 1:
            break
        img = cv2.resize(grey, (dw, dh), interpolation=cv2.INTER_LINEAR)
        hits = scan_image(cascade, img, step_px=2, max_hits=max_windows)
        if len(hits):
            out.append(np.stack([hits[:, 1] / z, hits[:, 0] / z,
                                 np.full(len(hits), cascade.width_px / z),
                                 np.full(len(hits), cascade.height_px / z)], axis=1))
        z /= scale_factor
    return np.concatenate(out) if out else np.zeros((0, 4))


def _wake_negatives(cascade: Cascade, images: list[LabelledImage], s: TrainSettings,
                    rng: np.random.Generator, upscale: float, max_n: int) -> np.ndarray:
    """The cascade's false alarms on the training images, and wake windows beside the boats."""
    aspect = s.width_px / s.height_px
    size = (s.width_px, s.height_px)
    out = []
    for im in images:
        g = im.grey()
        avoid = _avoid_boxes(im, aspect, s.margin)
        # (a) false alarms of the cascade, scanned like the detector would: the detection
        # scale puts a boat of 1/16 of the image width in the window (``upscale`` caps it)
        up = min(upscale, s.width_px / s.margin / max(12.0, g.shape[1] / 16.0))
        wins = detect_windows(cascade, g, up, scale_factor=1.2)
        if len(wins) and len(avoid):
            wins = wins[iou_matrix(wins, avoid).max(axis=1) <= s.neg_iou_max]
        if len(wins) > 60:
            wins = wins[rng.choice(len(wins), 60, replace=False)]
        # (b) wakes: windows beside and behind each boat, at its scale
        b = im.boxes[im.boxes[:, 2] >= s.min_box_w_px] if len(im.boxes) else im.boxes
        if len(b):
            gw = box_to_window(b, aspect, s.margin)
            shifts = [(-1.0, 0.0), (1.0, 0.0), (-0.75, 0.25), (0.75, 0.25), (0.0, 0.75), (-1.5, 0.0), (1.5, 0.0)]
            side = np.concatenate([gw + np.array([dx, dy, 0.0, 0.0]) * np.stack(
                [gw[:, 2], gw[:, 3], gw[:, 2], gw[:, 3]], axis=1) for dx, dy in shifts])
            if len(avoid):
                side = side[iou_matrix(side, avoid).max(axis=1) <= s.neg_iou_max]
            hgt, wid = g.shape
            inside = (side[:, 0] >= 0) & (side[:, 1] >= 0) & (side[:, 0] + side[:, 2] <= wid) & (
                side[:, 1] + side[:, 3] <= hgt)
            side = side[inside]
            wins = np.concatenate([wins.reshape(-1, 4), side]) if len(side) else wins
        if len(wins):
            out.append(extract_windows(g, wins, size, rng, n_aug=0))
    if not out:
        return np.zeros((0, s.height_px, s.width_px), np.uint8)
    neg = np.concatenate(out)
    acc = evaluate_windows(cascade, neg) == cascade.n_stages
    neg = neg[acc]
    if len(neg) > max_n:
        neg = neg[rng.choice(len(neg), max_n, replace=False)]
    return neg


def _binned_values(samples: np.ndarray, features: HaarFeatures, ids: np.ndarray, n_bins: int,
                   rng: np.random.Generator, chunk: int = 1000):
    ii = integral_images(samples)
    fac, _ = window_norm(samples)
    bins = np.empty((len(ids), len(samples)), np.uint8)
    edges = np.empty((len(ids), n_bins - 1), np.float32)
    n_edges = np.empty(len(ids), np.int32)
    for a in range(0, len(ids), chunk):
        sl = slice(a, min(a + chunk, len(ids)))
        vals = feature_values(ii, fac, features.subset(ids[sl]))
        bins[sl], edges[sl], n_edges[sl] = bin_features(vals, n_bins, rng)
    return bins, edges, n_edges


def train_cascade(
    train_images: list[LabelledImage],
    out_xml: str | Path,
    settings: TrainSettings | None = None,
    negative_images: list[LabelledImage] | None = None,
    detect_upscale: float = 2.5,
    log=_log_default,
) -> tuple[Cascade, dict]:
    """Train a cascade on the boxes of ``train_images`` and write it to ``out_xml``.

    Parameters
    ----------
    train_images : list of LabelledImage
        Images with boat boxes (positives; the rest of each image gives negatives).
    out_xml : path
        Written after every stage; a ``.json`` beside it holds the box convention and the
        training record.
    settings : TrainSettings
    negative_images : optional extra images (boxes there are avoided, not learned).
    detect_upscale : float
        Upscale at which the wake stage scans the small training images for false alarms.

    Returns
    -------
    (Cascade, record dict)
    """
    s = settings or TrainSettings()
    t_start = time.perf_counter()
    rng = np.random.default_rng(s.seed)
    aspect = s.width_px / s.height_px
    out_xml = Path(out_xml)
    neg_images = list(train_images) + list(negative_images or [])

    log(f"[train-cascade] {len(train_images)} training images, {len(neg_images)} negative images")
    pool = generate_features(s.width_px, s.height_px, tuple(s.feature_kinds), s.feature_pos_step_px,
                             s.feature_size_step_px)
    log(f"  feature pool: {len(pool)} Haar features")
    pos, pos_src = collect_positives(train_images, s, rng, log)
    n_pos0 = len(pos)
    counts = {k: int((pos_src == k).sum()) for k in np.unique(pos_src)}
    log(f"  positives: {n_pos0} windows {counts}")
    all_boxes = np.concatenate([im.boxes[im.boxes[:, 2] >= s.min_box_w_px] for im in train_images if len(im.boxes)])
    ratio_w, ratio_h = box_ratios(all_boxes, aspect, s.margin)

    cascade = Cascade(s.width_px, s.height_px, pool, [], params={
        "min_hit_rate": s.min_hit_rate, "max_false_alarm": s.max_false_alarm,
        "weight_trim_rate": s.weight_trim_rate, "max_weak_count": s.max_weak_count})
    record = {
        "settings": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(s).items()},
        "n_train_images": len(train_images),
        "n_negative_images": len(neg_images),
        "n_boxes": int(len(all_boxes)),
        "n_positive_windows": int(n_pos0),
        "positive_windows_by_source": counts,
        "box_ratio_w": ratio_w,
        "box_ratio_h": ratio_h,
        "aspect": aspect,
        "margin": s.margin,
        "stages": [],
    }
    cache = _GreyCache()
    neg = np.zeros((0, s.height_px, s.width_px), np.uint8)
    neg_src = np.zeros(0, dtype="<U8")
    scan_pool = None
    expected_pass: dict[str, float] = {}
    if s.scan_mining_stages > 0:
        t0 = time.perf_counter()
        scan_pool = ScanPool(train_images, (s.width_px, s.height_px), s.scan_scale_factor, s.scan_box_ratio_w,
                        s.scan_max_upscale, s.scan_roi_margin_frac)
        log(f"  scan pool: {int(scan_pool.n_windows.sum())} windows at the detection scale on "
            f"{len(train_images)} images ({time.perf_counter() - t0:.1f} s)")
        record["scan_pool_windows"] = int(scan_pool.n_windows.sum())
    fa_total = 1.0
    stop_reason = "stage count"
    for st in range(s.n_stages):
        elapsed = time.perf_counter() - t_start
        if elapsed > s.time_budget_s:
            stop_reason = "time budget"
            break
        t0 = time.perf_counter()
        n_neg_needed = int(s.neg_per_pos * len(pos))
        scan_fa = None
        if scan_pool is not None and st < s.scan_mining_stages:
            more, more_src, stats = mine_scan_negatives(cascade, scan_pool, n_neg_needed - len(neg), s, rng,
                                                        expected_pass)
            n_scan = sum(v[0] for v in stats.values())
            n_acc = sum(v[1] for v in stats.values())
            expected_pass = {k: v[1] / max(v[0], 1) for k, v in stats.items()}
            scan_fa = {k: round(v, 5) for k, v in expected_pass.items()}
            log(f"  scan mining: accepted share by source {scan_fa}")
            if len(neg) + len(more) < n_neg_needed:  # too few windows left at the detection scale
                extra, n2, a2 = mine_negatives(cascade, neg_images, n_neg_needed - len(neg) - len(more), s, rng, cache)
                more = np.concatenate([more, extra])
                more_src = np.concatenate([more_src, np.full(len(extra), "crop")])
        else:
            more, n_scan, n_acc = mine_negatives(cascade, neg_images, n_neg_needed - len(neg), s, rng, cache)
            more_src = np.full(len(more), "crop")
        neg = np.concatenate([neg, more])
        neg_src = np.concatenate([neg_src, more_src])
        if n_scan:
            fa_total = n_acc / n_scan
        log(f"stage {st}: {len(pos)} pos, {len(neg)} neg (mined {len(more)} of {n_scan} scanned windows, "
            f"cascade FA {fa_total:.2e}) {time.perf_counter() - t0:.1f} s")
        if len(neg) < 0.25 * n_neg_needed or (st > 0 and fa_total < s.target_false_alarm):
            stop_reason = "target false-alarm rate (too few negatives)"
            break
        t1 = time.perf_counter()
        ids = np.sort(rng.choice(len(pool), min(s.features_per_stage, len(pool)), replace=False))
        samples = np.concatenate([pos, neg])
        labels = np.concatenate([np.ones(len(pos)), -np.ones(len(neg))])
        binned = _binned_values(samples, pool, ids, s.n_bins, rng)
        t_feat = time.perf_counter() - t1
        cap = s.early_weak_counts[st] if st < len(s.early_weak_counts) else s.max_weak_count
        res = train_stage(binned, labels, ids, s.min_hit_rate, s.max_false_alarm, min(cap, s.max_weak_count),
                          s.n_bins, s.weight_trim_rate, rng)
        if res.false_alarm >= 0.999:
            stop_reason = "a stage could not reject any negative"
            log(f"  stage {st} rejects no negative: stopping")
            break
        cascade.stages.append(res.stage)
        keep = res.passed
        n_p = len(pos)
        pos = pos[keep[:n_p]]
        neg_pass = keep[n_p:]
        # expected share of the pool's windows the cascade will still accept after this stage:
        # the negatives of each source are a uniform sample of what it accepted before
        for k in list(expected_pass):
            m = neg_src == k
            expected_pass[k] *= float(neg_pass[m].mean()) if m.any() else float(res.false_alarm)
        neg = neg[neg_pass]
        neg_src = neg_src[neg_pass]
        info = {"stage": st, "n_weak": len(res.stage.feature), "hit_rate": res.hit_rate,
                "false_alarm": res.false_alarm, "n_pos": int(n_p), "n_neg": int(len(labels) - n_p),
                "cascade_fa_before": fa_total, "scan_accepted_share": scan_fa, "features_s": round(t_feat, 1), "boost_s": round(res.seconds, 1),
                "elapsed_s": round(time.perf_counter() - t_start, 1)}
        record["stages"].append(info)
        log(f"  stage {st}: {info['n_weak']} stumps, HR {res.hit_rate:.4f}, FA {res.false_alarm:.3f} "
            f"(features {t_feat:.1f} s, boosting {res.seconds:.1f} s, total {info['elapsed_s']:.0f} s)")
        _save(cascade, out_xml, record)

    record["stop_reason"] = stop_reason
    record["n_main_stages"] = cascade.n_stages
    record["cascade_false_alarm"] = fa_total
    if s.wake_stage and cascade.n_stages > 0:
        t0 = time.perf_counter()
        wneg = _wake_negatives(cascade, [im for im in train_images if im.source != "coral"] or train_images,
                               s, rng, detect_upscale, max_n=int(s.neg_per_pos * len(pos)))
        log(f"wake stage: {len(pos)} pos, {len(wneg)} neg (false alarms and wakes)")
        if len(wneg) >= 10:
            ids = np.sort(rng.choice(len(pool), min(s.features_per_stage, len(pool)), replace=False))
            samples = np.concatenate([pos, wneg])
            labels = np.concatenate([np.ones(len(pos)), -np.ones(len(wneg))])
            res = train_stage(_binned_values(samples, pool, ids, s.n_bins, rng), labels, ids,
                              s.wake_min_hit_rate, s.wake_max_false_alarm, s.max_weak_count, s.n_bins,
                              s.weight_trim_rate, rng)
            res.stage.info["wake"] = True
            cascade.stages.append(res.stage)
            record["wake_stage"] = {"n_weak": len(res.stage.feature), "hit_rate": res.hit_rate,
                                    "false_alarm": res.false_alarm, "n_neg": int(len(wneg)),
                                    "seconds": round(time.perf_counter() - t0, 1)}
            log(f"  wake stage: {len(res.stage.feature)} stumps, HR {res.hit_rate:.4f}, FA {res.false_alarm:.3f}")
        else:
            # too few windows that the main cascade still accepts to train on: say so in the record
            record["wake_stage"] = {"skipped": f"only {len(wneg)} wake negatives, 10 needed", "n_weak": 0,
                                    "n_neg": int(len(wneg)), "seconds": round(time.perf_counter() - t0, 1)}
            log(f"  wake stage skipped: only {len(wneg)} wake negatives (10 needed)")
    record["n_stages"] = cascade.n_stages
    record["training_time_s"] = round(time.perf_counter() - t_start, 1)
    _save(cascade, out_xml, record)
    log(f"[train-cascade] {cascade.n_stages} stages in {record['training_time_s']:.0f} s "
        f"({stop_reason}); wrote {out_xml}")
    return cascade, record


def _save(cascade: Cascade, out_xml: Path, record: dict) -> None:
    write_cascade_xml(cascade, out_xml, comment=f"seawatch boat cascade, {cascade.n_stages} stages")
    out_xml.with_suffix(".json").write_text(json.dumps(record, indent=1, default=float) + "\n", encoding="utf-8")
