"""The Numba cascade scanner (seawatch.detect.cascade_scan) makes OpenCV's decisions."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from seawatch.detect.cascade import CascadeDetector, default_model_path
from seawatch.detect.cascade_scan import PackedCascade, deinterleave
from seawatch.train.model import read_cascade_xml, write_cascade_xml
from seawatch.types import Frame

V6 = default_model_path().parent / "boat_cascade_v6.xml"


def _truncated(tmp_path, n_stages: int):
    """v6 with only its first ``n_stages`` stages: many windows then pass every stage, so every
    depth of the scanner is exercised."""
    casc = read_cascade_xml(V6)
    casc = dataclasses.replace(casc, stages=casc.stages[:n_stages])
    return write_cascade_xml(casc, tmp_path / f"v6_{n_stages}.xml")


def _scene(seed: int, h: int = 150, w: int = 260) -> np.ndarray:
    """A sea-like level image: a horizon, textured water with waves, a few bright and dark hulls,
    and a flat sky (flat windows exercise the variance rejection)."""
    rng = np.random.default_rng(seed)
    img = np.full((h, w), 150.0)
    yh = int(rng.integers(20, 50))
    img[:yh] = 200.0
    yy, xx = np.mgrid[yh:h, 0:w]
    img[yh:] = 90 + 20 * np.sin(xx / rng.uniform(3, 9) + yy / rng.uniform(2, 6)) + rng.normal(0, 12, (h - yh, w))
    for _ in range(int(rng.integers(3, 7))):
        bw, bh = int(rng.integers(20, 60)), int(rng.integers(8, 22))
        x0, y0 = int(rng.integers(0, w - bw)), int(rng.integers(yh, h - bh))
        img[y0:y0 + bh, x0:x0 + bw] = rng.choice([20.0, 235.0])
        img[y0 - 4:y0, x0 + bw // 3:x0 + bw // 2] = rng.choice([30.0, 220.0])
    return cv2.medianBlur(np.clip(img, 0, 255).astype(np.uint8), 3)


def _opencv_windows(clf, img, ww, wh) -> set:
    r, _ = clf.detectMultiScale2(img, scaleFactor=2.0, minNeighbors=0, minSize=(ww, wh), maxSize=(ww, wh))
    return {(int(x), int(y)) for x, y, _, _ in np.asarray(r).reshape(-1, 4)}


def _scan(pc, img, step_x=2) -> set:
    y_last = ((img.shape[0] - pc.height_px) // 2) * 2
    return set(map(tuple, pc.scan(img, 0, y_last, step_x=step_x).tolist()))


@pytest.mark.parametrize("n_stages", [1, 2, 4, 7, 20])
def test_scanner_equals_opencv_on_its_grid(tmp_path, n_stages):
    path = _truncated(tmp_path, n_stages)
    clf = cv2.CascadeClassifier(str(path))
    total = 0
    for n_dense in (1, 2, 5):
        pc = PackedCascade(path, n_dense=n_dense)
        for seed in range(4):
            img = _scene(seed)
            want = _opencv_windows(clf, img, pc.width_px, pc.height_px)
            assert _scan(pc, img) == want, (n_stages, n_dense, seed)
            total += len(want)
    if n_stages <= 4:
        assert total > 100  # the comparison is not between empty sets


def test_coarse_grid_is_every_fourth_column_without_the_skip(tmp_path):
    """On the 4 px grid every position is evaluated: each window (x % 4 == 0) gets the decision
    OpenCV gives it when scanned alone (a crop of exactly the window's size)."""
    path = _truncated(tmp_path, 3)
    clf = cv2.CascadeClassifier(str(path))
    pc = PackedCascade(path)
    ww, wh = pc.width_px, pc.height_px
    img = _scene(11, h=70, w=150)
    want = set()
    for y in range(0, img.shape[0] - wh + 1, 2):
        for x in range(0, img.shape[1] - ww + 1, 4):
            if _opencv_windows(clf, np.ascontiguousarray(img[y:y + wh, x:x + ww]), ww, wh):
                want.add((x, y))
    got = _scan(pc, img, step_x=4)
    assert got == want and len(want) > 20
    # and OpenCV's own grid, with its skip, finds a subset of them among x % 4 == 0
    assert {p for p in _scan(pc, img) if p[0] % 4 == 0} <= got


def test_levels_of_neighbouring_widths_share_no_stale_offsets(tmp_path):
    """The corner offsets are cached per level shape: widths 260 and 261 split into the same
    number of columns, and each must still get its own row stride."""
    path = _truncated(tmp_path, 4)
    pc = PackedCascade(path)
    imgs = [np.ascontiguousarray(_scene(s, w=262)[:, :w]) for s, w in ((1, 261), (2, 260), (3, 261))]
    for img in imgs:
        assert _scan(pc, img) == _scan(PackedCascade(path), img)


def test_rows_from_a_first_row(tmp_path):
    """Scanning from row y_lo gives the full scan's windows of those rows."""
    path = _truncated(tmp_path, 2)
    pc = PackedCascade(path)
    img = _scene(3)
    y_last = ((img.shape[0] - pc.height_px) // 2) * 2
    full = set(map(tuple, pc.scan(img, 0, y_last).tolist()))
    part = set(map(tuple, pc.scan(img, 40, y_last - 10).tolist()))
    assert part == {p for p in full if 40 <= p[1] <= y_last - 10} and part


def test_deinterleave():
    a = np.arange(5 * 7).reshape(5, 7)
    flat, cols = deinterleave(a, 2)
    assert cols == 4
    parts = flat[: 5 * 2 * 4].reshape(5, 2, 4)  # row, part (column modulo 2), column
    assert np.array_equal(parts[:, 0], a[:, 0::2])
    assert np.array_equal(parts[:, 1, :3], a[:, 1::2]) and np.array_equal(parts[:, 1, 3], a[:, -1])
    flat4, cols4 = deinterleave(a, 4)
    assert cols4 == 2 and np.array_equal(flat4[: 5 * 4 * 2].reshape(5, 4, 2)[:, 3, 0], a[:, 3])


def test_levels_of_different_heights_share_the_offsets(tmp_path):
    """The offsets are cached per level width: a level scanned from other rows (the horizon moved)
    reuses them and still finds OpenCV's windows."""
    path = _truncated(tmp_path, 4)
    pc = PackedCascade(path)
    clf = cv2.CascadeClassifier(str(path))
    img = _scene(8)
    for h in (150, 101, 64):
        part = np.ascontiguousarray(img[-h:])
        assert _scan(pc, part) == _opencv_windows(clf, part, pc.width_px, pc.height_px)
    assert len(pc._offsets) == 1


def test_bad_arguments(tmp_path):
    pc = PackedCascade(V6)
    img = _scene(0)
    with pytest.raises(ValueError, match="step_x"):
        pc.scan(img, 0, 10, step_x=3)
    with pytest.raises(ValueError, match="even"):
        pc.scan(img, 1, 11)
    with pytest.raises(ValueError, match="uint8"):
        pc.scan(img.astype(np.float32), 0, 10)
    assert pc.scan(img, 0, 1000).shape == (0, 2)  # rows past the image: nothing, no crash
    with pytest.raises(FileNotFoundError):
        PackedCascade(tmp_path / "missing.xml")
    with pytest.raises(ValueError, match="scanner"):
        CascadeDetector(V6, scanner="cuda")
    with pytest.raises(ValueError, match="grid_step_x_px"):
        CascadeDetector(V6, grid_step_px=0, grid_step_x_px=4)
    with pytest.raises(ValueError, match="2 px grid only"):
        CascadeDetector(V6, grid_step_px=0, scanner="numba")
    # the model's 4x2 grid is a 2 px grid's: asking for OpenCV's grid drops it, not an error
    g4 = default_model_path().parent / "boat_cascade_v6g4.xml"
    assert CascadeDetector(g4, grid_step_px=0).params.grid_step_x_px == 0
    assert CascadeDetector(g4).params.grid_step_x_px == 4
    with pytest.raises(ValueError, match="grid_step_x_px=2"):
        CascadeDetector(g4, scanner="opencv")
    assert not CascadeDetector(g4, scanner="opencv", grid_step_x_px=2)._use_numba()
    with pytest.raises(ValueError, match="grid_step_x_px"):
        CascadeDetector(V6, grid_step_px=2, grid_step_x_px=3)


def _frames(n=6, seed=5):
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        g = _scene(int(rng.integers(0, 1000)), h=288, w=352)
        out.append(np.dstack([g, g, g]))
    return out


def _rows(boxes, scores) -> np.ndarray:
    """Boxes with their scores, sorted: OpenCV's multi-threaded scan returns the raw windows in
    an order that varies, and the groups follow it; the order is not a decision."""
    r = np.column_stack([np.asarray(boxes, np.float64).reshape(-1, 4), np.asarray(scores, np.float64)])
    return r[np.lexsort(r.T[::-1])]


@pytest.mark.parametrize("n_stages,overrides", [(20, {"scale_factor": 1.1, "min_neighbors": 4}),
                                                (6, {}), (6, {"horizon_filter": False, "scale_factor": 1.3})])
def test_detector_same_detections_with_either_scanner(tmp_path, n_stages, overrides):
    path = V6 if n_stages == 20 else _truncated(tmp_path, n_stages)
    a = CascadeDetector(path, grid_step_px=2, scanner="opencv", **overrides)
    b = CascadeDetector(path, grid_step_px=2, scanner="numba", **overrides)
    n_boxes = 0
    for i, img in enumerate(_frames()):
        fr = Frame(img, i / 25.0, i)
        da, db = a.detect(fr), b.detect(fr)
        assert np.array_equal(_rows(da.boxes, da.scores), _rows(db.boxes, db.scores))
        ga = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        wa, ca = a.scan_region_windows(ga, None)
        wb, cb = b.scan_region_windows(ga, None)
        assert np.array_equal(_rows(wa, ca), _rows(wb, cb))
        n_boxes += len(wa)
    assert n_boxes > 0


def test_detector_coarse_grid_scans_fewer_windows():
    fine = CascadeDetector(V6, grid_step_px=2, min_neighbors=1)
    coarse = CascadeDetector(V6, grid_step_px=2, grid_step_x_px=4, min_neighbors=1)
    assert coarse.params.grid_step_x_px == 4 and fine.params.grid_step_x_px == 0
    g = cv2.cvtColor(_frames(1)[0], cv2.COLOR_BGR2GRAY)
    wf, cf = fine.scan_region_windows(g, None)
    wc, cc = coarse.scan_region_windows(g, None)
    assert 0 < cc.sum() < cf.sum()  # the raw windows grouped: about half as many


def test_config_chooses_the_scanner(tmp_path):
    from seawatch.config import ConfigError, load_config

    cfg = tmp_path / "c.toml"
    s15 = default_model_path().parent / "boat_cascade_v6s15.xml"  # 2 px grid
    cfg.write_text(f'[detector]\nkind = "cascade"\ncascade_model = "{s15}"\ncascade_scanner = "opencv"\n')
    det = CascadeDetector.from_config(load_config(cfg))
    assert det.params.scanner == "opencv" and not det._use_numba()
    # the default model's 4x2 grid is the Numba scanner's only: a clear error, not a silent switch
    cfg.write_text('[detector]\nkind = "cascade"\ncascade_scanner = "opencv"\n')
    with pytest.raises(ValueError, match="Numba scanner only"):
        CascadeDetector.from_config(load_config(cfg))
    cfg.write_text('[detector]\nkind = "cascade"\ncascade_scanner = "openvc"\n')
    with pytest.raises(ConfigError, match="cascade_scanner"):
        load_config(cfg)


def test_a_cascade_the_scanner_cannot_read(tmp_path):
    """Trees deeper than stumps: "auto" lets OpenCV scan it; asking for the Numba scanner (or the
    4 px grid, which only it scans) is a clear error at construction, not at the first frame."""
    import re

    xml = V6.read_text()
    # turn the first stump into a depth-2 tree node list (OpenCV reads it; seawatch's reader refuses)
    xml2 = re.sub(r"<internalNodes>\s*0 -1 (\d+) ([-0-9.e]+)</internalNodes>",
                  r"<internalNodes>1 -1 \1 \2 0 -2 \1 \2</internalNodes>", xml, count=1)
    assert xml2 != xml
    bad = tmp_path / "deep.xml"
    bad.write_text(xml2)
    det = CascadeDetector(bad, grid_step_px=2)
    assert det.params.scanner == "auto" and not det._use_numba()
    with pytest.raises(ValueError, match="Numba scanner cannot read"):
        CascadeDetector(bad, grid_step_px=2, scanner="numba")
    with pytest.raises(ValueError, match="Numba scanner cannot read"):
        CascadeDetector(bad, grid_step_px=2, grid_step_x_px=4)
