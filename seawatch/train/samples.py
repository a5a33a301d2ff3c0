"""Training data for the boat cascade: labelled images, their split, positive and negative windows.

Box convention
--------------
The cascade's window (60x30 by default) is wider than an annotated boat box and has a fixed
2:1 aspect.  A box ``(x, y, w, h)`` becomes the window centred on it with width
``margin * max(w, aspect * h)`` (:func:`box_to_window`).  The detector maps a detected window
back to a box with the median width and height ratios box/window of the training boxes
(:func:`box_ratios`), so its output follows the annotation's (tight) convention.

Sources
-------
* MarDCT training frames (``mardct/train/frames``): ``<clip>_<frame>.png`` with ``.txt`` boxes
  ``boat x y w h`` (0-based top-left).  Never MarDCT video2 (the evaluation clip).
* CORAL D1 (``coral_d1``): ``labels.csv`` with MATLAB 1-based ``x, y`` (1 is subtracted).
* The simulator (:mod:`seawatch.sim`), when it is installed: rendered frames and their exact
  ground-truth boxes.

:func:`split_images` keeps a validation part (for choosing detector settings) and a held-out part
(reported, never tuned on), by clip time and by day, so neighbouring frames never straddle parts.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from seawatch.detect.filters import prepare_grey

__all__ = [
    "LabelledImage",
    "box_to_window",
    "window_to_box",
    "box_ratios",
    "load_mardct_frames",
    "load_coral",
    "load_sim",
    "split_images",
    "extract_windows",
    "iou_matrix",
]


@dataclass
class LabelledImage:
    """One training image with its boat boxes (``x, y, w, h``, 0-based pixels)."""

    name: str
    source: str
    boxes: np.ndarray
    path: Path | None = None
    image: np.ndarray | None = None  # in memory (simulator frames); else read from ``path``
    ir: bool = False
    group: str = ""  # clip or day, for splitting
    order: float = 0.0  # time within the group
    ignore: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))  # boxes too small to learn

    def grey(self) -> np.ndarray:
        """The prepared grey image (grey, IR normalisation, median 3x3)."""
        if self.image is not None:
            img = self.image
        else:
            img = cv2.imread(str(self.path), cv2.IMREAD_UNCHANGED)
            if img is None:
                raise ValueError(f"cannot read image {self.path}")
        return prepare_grey(img, ir=self.ir, where=str(self.path or self.name))


def box_to_window(boxes: np.ndarray, aspect: float = 2.0, margin: float = 1.2) -> np.ndarray:
    """Windows (x, y, w, h) of the cascade's aspect centred on boxes.

    ``w = margin * max(box_w, aspect * box_h)``, ``h = w / aspect``.
    """
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    cx = b[:, 0] + b[:, 2] / 2
    cy = b[:, 1] + b[:, 3] / 2
    w = margin * np.maximum(b[:, 2], aspect * b[:, 3])
    h = w / aspect
    return np.stack([cx - w / 2, cy - h / 2, w, h], axis=1)


def window_to_box(windows: np.ndarray, ratio_w: float, ratio_h: float, dy_frac: float = 0.0) -> np.ndarray:
    """Boxes centred in windows, of ``ratio_w`` and ``ratio_h`` times the window's size.

    ``dy_frac`` shifts the box centre down by that fraction of the window height.
    """
    wn = np.asarray(windows, np.float64).reshape(-1, 4)
    cx = wn[:, 0] + wn[:, 2] / 2
    cy = wn[:, 1] + wn[:, 3] * (0.5 + dy_frac)
    w = wn[:, 2] * ratio_w
    h = wn[:, 3] * ratio_h
    return np.stack([cx - w / 2, cy - h / 2, w, h], axis=1)


def box_ratios(boxes: np.ndarray, aspect: float = 2.0, margin: float = 1.2) -> tuple[float, float]:
    """Median box/window width and height ratios of annotated boxes (the box convention)."""
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    if len(b) == 0:
        return 1.0 / margin, 1.0 / margin
    wn = box_to_window(b, aspect, margin)
    return float(np.median(b[:, 2] / wn[:, 2])), float(np.median(b[:, 3] / wn[:, 3]))


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) intersection over union of boxes ``x, y, w, h``."""
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    ix0 = np.maximum(a[:, None, 0], b[None, :, 0])
    iy0 = np.maximum(a[:, None, 1], b[None, :, 1])
    ix1 = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2])
    iy1 = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3])
    inter = np.clip(ix1 - ix0, 0, None) * np.clip(iy1 - iy0, 0, None)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
    return inter / np.maximum(union, 1e-12)


def _read_boxes(txt: Path) -> np.ndarray:
    rows = []
    for ln, line in enumerate(txt.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        try:
            x, y, w, h = (float(v) for v in parts[1:5])
        except ValueError:
            raise ValueError(f"{txt}:{ln}: malformed box line {line!r}") from None
        if w > 0 and h > 0:
            rows.append((x, y, w, h))
    return np.asarray(rows, np.float64).reshape(-1, 4)


def load_mardct_frames(frames_dir: str | Path) -> list[LabelledImage]:
    """MarDCT annotated frames ``<clip>_<frame>.png`` + ``.txt`` from a folder."""
    d = Path(frames_dir)
    if not d.is_dir():
        raise FileNotFoundError(f"MarDCT frames folder not found: {d}")
    out = []
    for png in sorted(d.glob("*.png")):
        if "video2-clipped" in png.name:
            raise ValueError(f"{png}: MarDCT video2 is the evaluation clip and must not be trained on")
        txt = png.with_suffix(".txt")
        if not txt.is_file():
            continue
        m = re.match(r"(.+)_(\d+)$", png.stem)
        group, order = (m.group(1), float(m.group(2))) if m else (png.stem, 0.0)
        out.append(LabelledImage(png.stem, "mardct", _read_boxes(txt), png, group=f"mardct:{group}", order=order))
    return out


def load_coral(coral_dir: str | Path) -> list[LabelledImage]:
    """CORAL D1 images with their boxes (``labels.csv``, 1-based, converted to 0-based)."""
    d = Path(coral_dir)
    lab = d / "labels.csv"
    if not lab.is_file():
        raise FileNotFoundError(f"CORAL labels not found: {lab}")
    boxes: dict[str, list] = {}
    with open(lab, newline="", encoding="utf-8") as fh:
        for ln, row in enumerate(csv.DictReader(fh), 2):
            try:
                b = (float(row["x"]) - 1, float(row["y"]) - 1, float(row["w"]), float(row["h"]))
            except (KeyError, ValueError, TypeError):
                raise ValueError(f"{lab}:{ln}: malformed row {row}") from None
            boxes.setdefault(row["file"], []).append(b)
    out = []
    for name in sorted(boxes):
        m = re.search(r"(\d{4}-\d{2}-\d{2})_(\d{2})-(\d{2})-(\d{2})", name)
        group = m.group(1) if m else ""
        order = float(int(m.group(2)) * 60 + int(m.group(3))) if m else 0.0  # minute: one triplet
        out.append(LabelledImage(Path(name).stem, "coral", np.asarray(boxes[name], np.float64).reshape(-1, 4),
                                 d / "images" / name, group=f"coral:{group}", order=order))
    return out


#: Render options the simulator's training frames are drawn with (see :func:`load_sim`).
TRAINING_RENDER_OPTIONS = {"sea_half_res": False}


def load_sim(scenarios: tuple[str, ...] = ("harbour", "pan", "ir", "open_sea", "crossing"),
             frames_per_scenario: int = 20, seed: int = 0, min_visible: float = 0.7,
             min_box_w_px: float = 12.0) -> list[LabelledImage]:
    """Frames rendered by the simulator with their ground-truth boxes (empty without it).

    Only vessels at least ``min_visible`` visible and ``min_box_w_px`` wide are kept as boats;
    the others are remembered as ``ignore`` regions (neither positives nor negatives).
    """
    try:
        from seawatch.sim import SCENARIOS, make_scenario
    except ImportError:
        return []
    out = []
    for si, name in enumerate(scenarios):
        if name not in SCENARIOS:
            continue
        # the training frames are pinned to the renderer the shipped cascades were trained on: moving
        # cameras' near water at full resolution (the renderer's default since session 11 renders it
        # at half width), so the recorded training command stays byte-reproducible
        scn = make_scenario(name, seed=seed + si).with_render_options(**TRAINING_RENDER_OPTIONS)
        n = scn.n_frames
        idx = np.unique(np.linspace(0, n - 1, min(frames_per_scenario, n)).astype(int))
        for i in idx:
            fr = scn.render(int(i))
            gt = scn.ground_truth(int(i))
            vis = np.asarray(gt.visible, float)
            bx = np.asarray(gt.boxes, np.float64).reshape(-1, 4)
            ok = (vis >= min_visible) & (bx[:, 2] >= min_box_w_px)
            ir = str(getattr(scn, "modality", "EO")).upper().endswith("IR")
            out.append(LabelledImage(f"sim_{name}_{i}", "sim", bx[ok], image=fr.image, ir=ir,
                                     group=f"sim:{name}", order=float(i), ignore=bx[~ok]))
    return out


def split_images(images: list[LabelledImage], val_frac: float = 0.12, heldout_frac: float = 0.15,
                 ) -> dict[str, list[LabelledImage]]:
    """Split by time within each group: the last ``heldout_frac`` of every group is held out,
    the ``val_frac`` before it is for validation, the rest is for training.

    Images of the same time in a group (a CORAL triplet) stay in one part.  Groups with fewer
    than 8 distinct times go entirely to training.  Deterministic.
    """
    parts: dict[str, list[LabelledImage]] = {"train": [], "val": [], "heldout": []}
    groups: dict[str, list[LabelledImage]] = {}
    for im in images:
        groups.setdefault(im.group, []).append(im)
    for g in sorted(groups):
        items = sorted(groups[g], key=lambda im: (im.order, im.name))
        keys = sorted({im.order for im in items})  # images of one time (a triplet) stay together
        n = len(keys)
        if n < 8:
            parts["train"].extend(items)
            continue
        n_ho = max(1, int(round(heldout_frac * n)))
        n_val = max(1, int(round(val_frac * n)))
        rank = {k: i for i, k in enumerate(keys)}
        for im in items:
            r = rank[im.order]
            part = "train" if r < n - n_ho - n_val else ("val" if r < n - n_ho else "heldout")
            parts[part].append(im)
    return parts


def extract_windows(
    grey: np.ndarray,
    windows: np.ndarray,
    size: tuple[int, int] = (60, 30),
    rng: np.random.Generator | None = None,
    n_aug: int = 0,
    scale_jitter: float = 0.08,
    shift_jitter: float = 0.06,
    flip: bool = True,
    contrast: tuple[float, float] = (0.75, 1.3),
    brightness_px: float = 20.0,
    blur_prob: float = 0.3,
    blur_sigma_px: float = 1.0,
    lowres_prob: float = 0.0,
    lowres_window_px: tuple[float, float] = (28.0, 60.0),
    median_px: int = 3,
) -> np.ndarray:
    """Cut windows out of a grey image and resample them to ``size`` (width, height).

    With ``n_aug > 0`` each window gives ``n_aug`` augmented copies (the first one plain, the
    others with scale and shift jitter, horizontal flip, contrast and brightness change and
    blur) instead of one.

    Low-resolution copies (``lowres_prob`` of the augmented ones): the window is rendered as a
    camera that saw it ``lowres_window_px`` wide (drawn log-uniformly; only when the window
    is wider in the source) would give it to the detector: area-downsampled to that width,
    median-filtered (``median_px``, as the detector does on the source frame) and upscaled
    linearly to ``size`` (the detector's detection scale).  Small, far boats (20-50 px) reach
    the cascade this way, so a training set of large, sharp boats must contain such copies.

    Returns
    -------
    (M * max(1, n_aug), height, width) uint8
    """
    wins = np.asarray(windows, np.float64).reshape(-1, 4)
    out_w, out_h = size
    reps = max(1, n_aug)
    res = np.empty((len(wins) * reps, out_h, out_w), np.uint8)
    if rng is None:
        rng = np.random.default_rng(0)
    k = 0
    for x, y, w, h in wins:
        for r in range(reps):
            s, dx, dy, fl = 1.0, 0.0, 0.0, False
            a, b, sig, lw = 1.0, 0.0, 0.0, 0.0
            if r > 0:
                s = float(np.exp(rng.uniform(-scale_jitter, scale_jitter)))
                dx = float(rng.uniform(-shift_jitter, shift_jitter)) * w
                dy = float(rng.uniform(-shift_jitter, shift_jitter)) * h
                fl = bool(flip and rng.random() < 0.5)
                a = float(rng.uniform(*contrast))
                b = float(rng.uniform(-brightness_px, brightness_px))
                if rng.random() < blur_prob:
                    sig = float(rng.uniform(0.3, blur_sigma_px))
                if lowres_prob > 0 and rng.random() < lowres_prob:
                    lo, hi = lowres_window_px
                    lw = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
            ww, hh = w * s, h * s
            cx, cy = x + w / 2 + dx, y + h / 2 + dy
            sx = ww / out_w
            sy = hh / out_h
            # destination (u, v) -> source: x = x0 + (u + 0.5) * sx - 0.5
            x0 = cx - ww / 2
            y0 = cy - hh / 2
            if fl:
                m = np.array([[-sx, 0, x0 + ww - 0.5 * sx - 0.5 + 0.0], [0, sy, y0 + 0.5 * sy - 0.5]])
                m[0, 2] = x0 + (out_w - 0.5) * sx - 0.5
            else:
                m = np.array([[sx, 0, x0 + 0.5 * sx - 0.5], [0, sy, y0 + 0.5 * sy - 0.5]])
            patch = cv2.warpAffine(grey, m, (out_w, out_h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                   borderMode=cv2.BORDER_REFLECT)
            if 0 < lw < w * s and lw < out_w:
                small = cv2.resize(patch, (max(2, int(round(lw))), max(2, int(round(lw * out_h / out_w)))),
                                   interpolation=cv2.INTER_AREA)
                if median_px >= 3 and min(small.shape) >= median_px:
                    small = cv2.medianBlur(small, median_px)
                patch = cv2.resize(small, (out_w, out_h), interpolation=cv2.INTER_LINEAR)
            elif sig > 0:
                patch = cv2.GaussianBlur(patch, (0, 0), sig)
            if a != 1.0 or b != 0.0:
                patch = np.clip(patch.astype(np.float32) * a + (b + (1 - a) * float(patch.mean())), 0, 255
                                ).astype(np.uint8)
            res[k] = patch
            k += 1
    return res
