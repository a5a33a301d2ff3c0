"""A boosted cascade of Haar stumps: its data, its evaluator, and OpenCV's cascade XML.

The evaluator reproduces what ``cv2.CascadeClassifier`` does for a current-format HAAR cascade
of stumps (``predictOrderedStump``): per stage, the double-precision sum of the leaf values
(``value < threshold`` selects the left leaf) is compared with the stage threshold, which
OpenCV lowers by ``1e-5`` in single precision when it reads the file; a window is accepted when
it passes every stage.  The file written by :func:`write_cascade_xml` is the format
``opencv_traincascade`` writes (``<cascade type_id="opencv-cascade-classifier">``, stages with
``<internalNodes>``/``<leafValues>``, and ``<features>`` with ``<rects>``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numba import njit

from seawatch.train.haar import HaarFeatures, integral_images, window_norm

__all__ = [
    "Stage",
    "Cascade",
    "write_cascade_xml",
    "read_cascade_xml",
    "evaluate_windows",
    "scan_image",
    "THRESHOLD_EPS",
]

#: OpenCV subtracts this from every stage threshold it reads (``cascadedetect.cpp``).
THRESHOLD_EPS = np.float32(1e-5)


@dataclass
class Stage:
    """One boosted stage of decision stumps.

    ``feature`` indexes :attr:`Cascade.features`; a stump adds ``left`` when the feature value
    is below ``threshold`` and ``right`` otherwise.  All values are single precision, as in the
    XML file.
    """

    threshold: float
    feature: np.ndarray  # (K,) int32
    split: np.ndarray  # (K,) float32
    left: np.ndarray  # (K,) float32
    right: np.ndarray  # (K,) float32
    info: dict = field(default_factory=dict)  # training record (hit rate, false-alarm rate, ...)

    def __post_init__(self) -> None:
        self.threshold = float(np.float32(self.threshold))
        self.feature = np.asarray(self.feature, np.int32).reshape(-1)
        self.split = np.asarray(self.split, np.float32).reshape(-1)
        self.left = np.asarray(self.left, np.float32).reshape(-1)
        self.right = np.asarray(self.right, np.float32).reshape(-1)
        k = len(self.feature)
        if not (len(self.split) == len(self.left) == len(self.right) == k) or k == 0:
            raise ValueError(f"Stage: inconsistent or empty stumps ({k} features)")


@dataclass
class Cascade:
    """A cascade classifier over a ``width_px`` x ``height_px`` window."""

    width_px: int
    height_px: int
    features: HaarFeatures
    stages: list[Stage] = field(default_factory=list)
    params: dict = field(default_factory=dict)  # stage/feature parameters written to the XML

    @property
    def n_stages(self) -> int:
        return len(self.stages)

    def truncated(self, n_stages: int) -> "Cascade":
        """The cascade's first ``n_stages`` stages."""
        return Cascade(self.width_px, self.height_px, self.features, list(self.stages[:n_stages]),
                       dict(self.params))

    def packed(self):
        """Flat arrays for the Numba evaluator."""
        if not self.stages:
            z = np.zeros(0, np.float32)
            return (np.zeros(1, np.int32), np.zeros(0, np.float32), np.zeros(0, np.int32), z, z, z,
                    np.ascontiguousarray(self.features.rects, np.int32),
                    np.ascontiguousarray(self.features.weights, np.float32))
        counts = [len(s.feature) for s in self.stages]
        start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        thr = np.array([np.float32(s.threshold) - THRESHOLD_EPS for s in self.stages], np.float32)
        feat = np.concatenate([s.feature for s in self.stages]).astype(np.int32)
        split = np.concatenate([s.split for s in self.stages]).astype(np.float32)
        left = np.concatenate([s.left for s in self.stages]).astype(np.float32)
        right = np.concatenate([s.right for s in self.stages]).astype(np.float32)
        return (start, thr, feat, split, left, right,
                np.ascontiguousarray(self.features.rects, np.int32),
                np.ascontiguousarray(self.features.weights, np.float32))

    def compact(self) -> "Cascade":
        """The same cascade keeping only the features its stumps use (renumbered)."""
        if not self.stages:
            return Cascade(self.width_px, self.height_px, self.features.subset(slice(0, 0)), [], dict(self.params))
        used = np.unique(np.concatenate([s.feature for s in self.stages]))
        remap = np.full(len(self.features), -1, np.int64)
        remap[used] = np.arange(len(used))
        stages = [Stage(s.threshold, remap[s.feature], s.split, s.left, s.right, dict(s.info)) for s in self.stages]
        return Cascade(self.width_px, self.height_px, self.features.subset(used), stages, dict(self.params))


# ------------------------------------------------------------------------------------ evaluator
@njit(cache=True)
def _stage_pass(ii, k, oy, ox, factor, start, thr, feat, split, left, right, rects, weights):
    """Number of stages the window at (oy, ox) of integral image ``ii[k]`` passes."""
    nst = thr.shape[0]
    for s in range(nst):
        acc = 0.0
        for j in range(start[s], start[s + 1]):
            f = feat[j]
            v = np.float32(0.0)
            for r in range(3):
                wt = weights[f, r]
                if wt == 0.0:
                    continue
                x = ox + rects[f, r, 0]
                y = oy + rects[f, r, 1]
                x2 = x + rects[f, r, 2]
                y2 = y + rects[f, r, 3]
                sm = ii[k, y, x] - ii[k, y, x2] - ii[k, y2, x] + ii[k, y2, x2]
                v = v + wt * np.float32(sm)
            v = v * factor
            if v < split[j]:
                acc += float(left[j])
            else:
                acc += float(right[j])
        if acc < float(thr[s]):
            return s
    return nst


@njit(cache=True)
def _eval_batch(ii, factor, valid, start, thr, feat, split, left, right, rects, weights, out):
    for k in range(ii.shape[0]):
        if not valid[k]:
            out[k] = -1
        else:
            out[k] = _stage_pass(ii, k, 0, 0, factor[k], start, thr, feat, split, left, right, rects, weights)


@njit(cache=True)
def _stage_sums(ii, factor, start, thr, feat, split, left, right, rects, weights, out):
    """Sum of every stage on every window (no early exit): out (N, S) float64."""
    nst = thr.shape[0]
    for k in range(ii.shape[0]):
        for s in range(nst):
            acc = 0.0
            for j in range(start[s], start[s + 1]):
                f = feat[j]
                v = np.float32(0.0)
                for r in range(3):
                    wt = weights[f, r]
                    if wt == 0.0:
                        continue
                    x = rects[f, r, 0]
                    y = rects[f, r, 1]
                    x2 = x + rects[f, r, 2]
                    y2 = y + rects[f, r, 3]
                    sm = ii[k, y, x] - ii[k, y, x2] - ii[k, y2, x] + ii[k, y2, x2]
                    v = v + wt * np.float32(sm)
                v = v * factor[k]
                if v < split[j]:
                    acc += float(left[j])
                else:
                    acc += float(right[j])
            out[k, s] = acc


def evaluate_windows(cascade: Cascade, windows: np.ndarray) -> np.ndarray:
    """How many stages each window passes.

    Parameters
    ----------
    cascade : Cascade
    windows : (N, H, W) uint8, already at the cascade's window size.

    Returns
    -------
    (N,) int32: ``-1`` for a window OpenCV rejects as flat (see
    :func:`~seawatch.train.haar.window_norm`), else the number of stages passed;
    ``cascade.n_stages`` means accepted.
    """
    windows = np.ascontiguousarray(windows, np.uint8)
    if windows.ndim != 3 or windows.shape[1:] != (cascade.height_px, cascade.width_px):
        raise ValueError(
            f"windows must be (N, {cascade.height_px}, {cascade.width_px}) uint8, got {windows.shape}"
        )
    ii = integral_images(windows)
    factor, valid = window_norm(windows)
    out = np.empty(len(windows), np.int32)
    if len(windows):
        _eval_batch(ii, factor, valid, *cascade.packed(), out)
    return out


def stage_sums(cascade: Cascade, windows: np.ndarray) -> np.ndarray:
    """(N, S) stage sums of every window at every stage (no early rejection)."""
    windows = np.ascontiguousarray(windows, np.uint8)
    ii = integral_images(windows)
    factor, _ = window_norm(windows)
    out = np.zeros((len(windows), cascade.n_stages), np.float64)
    if len(windows) and cascade.n_stages:
        _stage_sums(ii, factor, *cascade.packed(), out)
    return out


@njit(cache=True)
def _integrals64(img, ii, sq):
    h, w = img.shape
    for y in range(h):
        row = np.int64(0)
        rsq = np.int64(0)
        for x in range(w):
            v = np.int64(img[y, x])
            row += v
            rsq += v * v
            ii[0, y + 1, x + 1] = ii[0, y, x + 1] + row
            sq[y + 1, x + 1] = sq[y, x + 1] + rsq


@njit(cache=True)
def _scan(ii, sq, win_w, win_h, step, skip_after_reject, start, thr, feat, split, left, right, rects, weights,
          min_stage, out):
    """Evaluate every window on a ``step`` grid; write (y, x, stages) of those passing >= min_stage."""
    h = ii.shape[1] - 1
    w = ii.shape[2] - 1
    area = float((win_w - 2) * (win_h - 2))
    n = 0
    for oy in range(0, h - win_h + 1, step):
        ox = -step
        while True:
            ox += step
            if ox > w - win_w:
                break
            y1 = oy + 1
            x1 = ox + 1
            y2 = oy + win_h - 1
            x2 = ox + win_w - 1
            s = ii[0, y1, x1] - ii[0, y1, x2] - ii[0, y2, x1] + ii[0, y2, x2]
            q = sq[y1, x1] - sq[y1, x2] - sq[y2, x1] + sq[y2, x2]
            nf = area * float(q) - float(s) * float(s)
            if nf <= 0.0:
                continue
            factor = np.float32(1.0 / np.sqrt(nf))
            if not (area * float(factor) < 0.1):
                continue
            ns = _stage_pass(ii, 0, oy, ox, factor, start, thr, feat, split, left, right, rects, weights)
            if ns == 0 and skip_after_reject:
                ox += step  # detectMultiScale skips the next position after a first-stage reject
            if ns >= min_stage:
                if n < out.shape[0]:
                    out[n, 0] = oy
                    out[n, 1] = ox
                    out[n, 2] = ns
                n += 1
    return n


def scan_image(cascade: Cascade, image: np.ndarray, step_px: int = 1, min_stage: int | None = None,
               max_hits: int = 200000, skip_after_reject: bool = False) -> np.ndarray:
    """Evaluate the cascade on every window of one grey image at one scale.

    Parameters
    ----------
    cascade : Cascade
    image : (H, W) uint8 grey image (already at the scale to scan).
    step_px : int
        Grid stride (OpenCV's ``detectMultiScale`` uses 2 at scale factors up to 2).
    min_stage : int, optional
        Report windows passing at least this many stages (default: all stages, i.e. accepted).
    max_hits : int
        At most this many windows are reported.
    skip_after_reject : bool
        Skip the next grid position after a window the first stage rejects, as
        ``detectMultiScale`` does (so that the hits equal OpenCV's raw detections).

    Returns
    -------
    (M, 3) int32 rows ``y, x, stages_passed`` (top-left corner of the window).
    """
    image = np.ascontiguousarray(image, np.uint8)
    if image.ndim != 2:
        raise ValueError(f"scan_image: expected a grey (H, W) uint8 image, got shape {image.shape}")
    h, w = image.shape
    if h < cascade.height_px or w < cascade.width_px:
        return np.zeros((0, 3), np.int32)
    ii = np.zeros((1, h + 1, w + 1), np.int64)
    sq = np.zeros((h + 1, w + 1), np.int64)
    _integrals64(image, ii, sq)
    ms = cascade.n_stages if min_stage is None else int(min_stage)
    out = np.zeros((max_hits, 3), np.int32)
    n = _scan(ii, sq, cascade.width_px, cascade.height_px, int(step_px), bool(skip_after_reject),
              *cascade.packed(), ms, out)
    return out[: min(n, max_hits)].copy()


# ------------------------------------------------------------------------------------ XML
def _fmt(v: float) -> str:
    return repr(float(np.float32(v))) if np.isfinite(v) else "0."


def write_cascade_xml(cascade: Cascade, path: str | Path, comment: str | None = None) -> Path:
    """Write the cascade in OpenCV's current cascade XML format.

    The file loads in ``cv2.CascadeClassifier``.  Only the features the stumps use are written
    (renumbered).  Returns the path.
    """
    c = cascade.compact()
    p = dict(c.params)
    lines = ['<?xml version="1.0"?>', "<opencv_storage>"]
    if comment:
        lines.append("<!-- " + comment.replace("--", "- -") + " -->")
    lines += [
        '<cascade type_id="opencv-cascade-classifier">',
        "  <stageType>BOOST</stageType>",
        "  <featureType>HAAR</featureType>",
        f"  <height>{c.height_px}</height>",
        f"  <width>{c.width_px}</width>",
        "  <stageParams>",
        "    <boostType>GAB</boostType>",
        f"    <minHitRate>{_fmt(p.get('min_hit_rate', 0.995))}</minHitRate>",
        f"    <maxFalseAlarm>{_fmt(p.get('max_false_alarm', 0.5))}</maxFalseAlarm>",
        f"    <weightTrimRate>{_fmt(p.get('weight_trim_rate', 0.95))}</weightTrimRate>",
        "    <maxDepth>1</maxDepth>",
        f"    <maxWeakCount>{int(p.get('max_weak_count', 100))}</maxWeakCount></stageParams>",
        "  <featureParams>",
        "    <maxCatCount>0</maxCatCount>",
        "    <featSize>1</featSize>",
        "    <mode>ALL</mode></featureParams>",
        f"  <stageNum>{c.n_stages}</stageNum>",
        "  <stages>",
    ]
    for si, st in enumerate(c.stages):
        lines.append(f"    <!-- stage {si} -->")
        lines.append("    <_>")
        lines.append(f"      <maxWeakCount>{len(st.feature)}</maxWeakCount>")
        lines.append(f"      <stageThreshold>{_fmt(st.threshold)}</stageThreshold>")
        lines.append("      <weakClassifiers>")
        for f, t, lv, rv in zip(st.feature, st.split, st.left, st.right):
            lines.append("        <_>")
            lines.append(f"          <internalNodes>0 -1 {int(f)} {_fmt(t)}</internalNodes>")
            lines.append(f"          <leafValues>{_fmt(lv)} {_fmt(rv)}</leafValues></_>")
        lines.append("      </weakClassifiers></_>")
    lines.append("  </stages>")
    lines.append("  <features>")
    for r, w in zip(c.features.rects, c.features.weights):
        lines.append("    <_>")
        lines.append("      <rects>")
        for k in range(3):
            if w[k] == 0:
                continue
            lines.append(f"        <_>{r[k, 0]} {r[k, 1]} {r[k, 2]} {r[k, 3]} {_fmt(w[k])}</_>")
        lines.append("      </rects>")
        lines.append("      <tilted>0</tilted></_>")
    lines.append("  </features>")
    lines.append("</cascade>")
    lines.append("</opencv_storage>")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def read_cascade_xml(path: str | Path) -> Cascade:
    """Read a current-format HAAR cascade of stumps (as written by :func:`write_cascade_xml`).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    ValueError
        When it is not a current-format HAAR stump cascade (the message names the file).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"cascade file not found: {path}")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"{path}: not valid XML: {exc}") from None
    node = root.find("cascade")
    if node is None or node.get("type_id") != "opencv-cascade-classifier":
        raise ValueError(f"{path}: not a current-format OpenCV cascade (no <cascade type_id=\"opencv-cascade-classifier\">)")
    if (node.findtext("featureType") or "").strip() != "HAAR":
        raise ValueError(f"{path}: only HAAR cascades are supported")
    w = int(node.findtext("width"))
    h = int(node.findtext("height"))
    rects, weights = [], []
    for fnode in node.find("features"):
        r = np.zeros((3, 4), np.int32)
        wt = np.zeros(3, np.float32)
        for k, rn in enumerate(fnode.find("rects")):
            vals = rn.text.split()
            r[k] = [int(float(v)) for v in vals[:4]]
            wt[k] = float(vals[4])
        if fnode.findtext("tilted", "0").strip() not in ("0", ""):
            raise ValueError(f"{path}: tilted features are not supported")
        rects.append(r)
        weights.append(wt)
    feats = HaarFeatures(np.asarray(rects, np.int32).reshape(-1, 3, 4),
                         np.asarray(weights, np.float32).reshape(-1, 3), np.zeros(len(rects), np.int8))
    stages = []
    for snode in node.find("stages"):
        thr = float(snode.findtext("stageThreshold"))
        fi, sp, lv, rv = [], [], [], []
        for wnode in snode.find("weakClassifiers"):
            nodes = wnode.findtext("internalNodes").split()
            leaves = wnode.findtext("leafValues").split()
            if len(nodes) != 4 or len(leaves) != 2:
                raise ValueError(f"{path}: only stump (depth-1) cascades are supported")
            fi.append(int(nodes[2]))
            sp.append(float(nodes[3]))
            lv.append(float(leaves[0]))
            rv.append(float(leaves[1]))
        stages.append(Stage(thr, fi, sp, lv, rv))
    params = {}
    sp = node.find("stageParams")
    if sp is not None:
        for key, tag, conv in (("min_hit_rate", "minHitRate", float), ("max_false_alarm", "maxFalseAlarm", float),
                               ("weight_trim_rate", "weightTrimRate", float), ("max_weak_count", "maxWeakCount", int)):
            if sp.findtext(tag) is not None:
                params[key] = conv(float(sp.findtext(tag)))
    return Cascade(w, h, feats, stages, params)
