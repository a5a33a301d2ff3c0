"""Full-pipeline speed per image size, one core and two cores, beside Bloisi et al.'s Table V.

For each resolution of Bloisi et al. (T-ITS), Table V (319x261 ... 704x576) and two larger ones
(1280x720, 1920x1080), frames of the simulator's ``harbour`` scene (or, while the simulator is
missing, synthetic moving boxes) are rendered once, then the whole pipeline (detector -> tracker ->
MOT CSV + JSON Lines writers; the annotated video is left out, as the paper's figures have no
video encoding) runs over them with OpenCV and Numba limited to 1 and to 2 threads.  The figure is
the median frames/s over repeats.  The in-process peer is OpenCV's MOG2 background subtractor alone
(``apply`` on the same frames): the ratio pipeline/peer says how much the rest of the pipeline
costs.

``ref`` is the paper's figure on 2 cores (its whole system: Haar cascade + PTracking, C++); the
8-core figure is kept as ``ref_8_cores``.  The default pipeline here is the MOG2 + SORT baseline; the
paper's own method (cascade + PTracking) is measured too when those stages are installed.
Each row carries the machine's 1-minute load average: on a shared machine a load above the core
count makes the 2-thread figures unreliable.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

NAME = "pipeline"
DESCRIPTION = "full-pipeline frames/s per resolution on 1 and 2 cores vs Bloisi et al. Table V"

RESOLUTIONS = [(319, 261), (352, 288), (414, 338), (586, 479), (704, 576), (1280, 720), (1920, 1080)]
# Bloisi et al., Table V: frames/s of the whole system
REF_2_CORES = {(319, 261): 15.5, (352, 288): 13.8, (414, 338): 10.1, (586, 479): 6.2, (704, 576): 4.5}
REF_8_CORES = {(319, 261): 81.3, (352, 288): 75.6, (414, 338): 51.7, (586, 479): 29.4, (704, 576): 23.5}
PIPELINES = [("mog2", "sort"), ("cascade", "ptracking")]
FPS = 25.0


def _set_threads(n: int) -> None:
    import cv2

    cv2.setNumThreads(n)
    try:
        import numba

        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    except (ImportError, ValueError):
        pass


def _synthetic_frames(w: int, h: int, n: int, seed: int = 0):
    """Moving bright/dark boxes over a textured, noisy sea (fallback without the simulator)."""
    import cv2

    from seawatch.types import Frame

    rng = np.random.default_rng(seed)
    base = cv2.GaussianBlur(rng.normal(110, 14, (h, w)), (0, 0), 2.0)
    sky = int(h * 0.3)
    base[:sky] = np.linspace(200, 160, sky)[:, None]
    boats = [(rng.uniform(0, w), rng.uniform(sky + 10, h - 40), rng.uniform(-w / 20, w / 20),
              int(w / rng.uniform(8, 25)), rng.choice([30, 230])) for _ in range(5)]
    out = []
    for i in range(n):
        t = i / FPS
        img = base + rng.normal(0, 3, base.shape)
        for x0, y0, vx, bw, level in boats:
            x = int((x0 + vx * t) % w)
            bh = max(4, bw // 3)
            img[int(y0):int(y0) + bh, x:x + bw] = level
        g = img.clip(0, 255).astype(np.uint8)
        out.append(Frame(cv2.cvtColor(g, cv2.COLOR_GRAY2BGR), t, i))
    return out


def _frames(w: int, h: int, n: int):
    try:
        from seawatch.sim import make_scenario
    except ImportError:
        return "boxes-synth", _synthetic_frames(w, h, n)
    scn = make_scenario("harbour", seed=0, width=w, height=h)
    n = min(n, scn.n_frames)
    return "harbour-sim", [scn.render(i) for i in range(n)]


def _available(det_kind: str, trk_kind: str) -> bool:
    """Whether both stages can be built (installed, with their models)."""
    from seawatch.config import load_config
    from seawatch.pipeline import build_detector, build_tracker

    cfg = load_config(None, [f"detector.kind={det_kind}", f"tracker.kind={trk_kind}"])
    try:
        build_detector(cfg, FPS)
        build_tracker(cfg, FPS)
        return True
    except Exception:  # not installed, no model yet, ...: measured once it is
        return False


def _pipeline_fps(frames, det_kind: str, trk_kind: str, fps: float, out: Path) -> float:
    from seawatch.config import load_config
    from seawatch.io.results import JsonlWriter, MotCsvWriter
    from seawatch.pipeline import Pipeline, build_detector, build_tracker

    cfg = load_config(None, [f"detector.kind={det_kind}", f"tracker.kind={trk_kind}", "run.progress=false"])
    sinks = [MotCsvWriter(out / "d.csv", "detections"), MotCsvWriter(out / "t.csv", "tracks"),
             JsonlWriter(out / "d.jsonl", "detections"), JsonlWriter(out / "t.jsonl", "tracks")]
    pipe = Pipeline(build_detector(cfg, fps), build_tracker(cfg, fps), sinks=sinks)
    t0 = time.perf_counter()
    pipe.run(frames)
    return len(frames) / (time.perf_counter() - t0)


def _mog2_fps(frames, fps: float) -> float:
    import cv2

    m = cv2.createBackgroundSubtractorMOG2(history=int(20 * fps), varThreshold=16, detectShadows=False)
    t0 = time.perf_counter()
    for f in frames:
        m.apply(f.image)
    return len(frames) / (time.perf_counter() - t0)


def run(ctx) -> None:
    import cv2

    repeats = 1 if ctx.quick else 3
    resolutions = RESOLUTIONS[::3] if ctx.quick else RESOLUTIONS
    threads = (1, 2)
    old_threads = cv2.getNumThreads()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp)
            pipelines = [p for p in PIPELINES if _available(*p)]
            for w, h in resolutions:
                n = (20 if ctx.quick else 100) if w * h <= 704 * 576 else (10 if ctx.quick else 40)
                dataset, frames = _frames(w, h, n)
                ds = f"{dataset} {w}x{h}"
                for nt in threads:
                    _set_threads(nt)
                    cores = f"{nt} core" + ("s" if nt > 1 else "")
                    peer = float(np.median([_mog2_fps(frames, FPS) for _ in range(repeats)]))
                    ctx.record(ds, f"opencv MOG2 alone ({cores})", "fps", peer, "frames/s",
                               threads=nt, frames=len(frames), repeats=repeats)
                    for det_kind, trk_kind in pipelines:
                        vals = [_pipeline_fps(frames, det_kind, trk_kind, FPS, out) for _ in range(repeats)]
                        v = float(np.median(vals))
                        extra = dict(threads=nt, frames=len(frames), repeats=repeats, peer_fps=peer,
                                     load_avg_1min=round(os.getloadavg()[0], 2), cpu_count=os.cpu_count())
                        if nt == 2 and (w, h) in REF_2_CORES:
                            extra["ref"] = REF_2_CORES[(w, h)]
                            extra["ref_8_cores"] = REF_8_CORES[(w, h)]
                        method = f"pipeline {det_kind}+{trk_kind} ({cores})"
                        ctx.record(ds, method, "fps", v, "frames/s", **extra)
                        ctx.record(ds, method, "ms_per_frame", 1000.0 / v, "ms", threads=nt)
                        ctx.record(ds, method, "ratio_to_peer", v / peer, "x", threads=nt,
                                   peer="opencv MOG2 alone")
                del frames
    finally:
        _set_threads(old_threads if old_threads > 0 else 1)
