"""Where the stable-feature stage spends its CPU time: per-part timers, or cProfile.

Runs the whole stage (``StableFeatureTracker``, default parameters, the scenario's camera model,
so with the water band) on a simulator scenario rendered at 640x480, 25 frames/s, 10 s (250
frames; as ``sf_diagnose.py --speed-pairs``), one OpenCV thread, once to warm up and then
``--repeats`` times, and prints the median CPU time per frame of each part: the extractor's
methods, its OpenCV calls (the main and the band StarDetector's ``detect``, SIFT's ``compute``),
the clusterer's.  Parts nest (``ext.process`` holds ``ext._keypoints``, which holds the detectors
and ``sift.compute``); the timers cost a few microseconds a call.  ``--cprofile N`` instead runs
once under cProfile and prints the N functions with the most own time and the N with the most
cumulative time (cProfile inflates the cost of many small Python calls).

Uses only the simulator; profile on tuning seeds (1, 2), not on the bench's seed 0.  Set
``OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1``.  Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/sf_speed_parts.py pan 1
    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/sf_speed_parts.py pan 1 --cprofile 30
"""

from __future__ import annotations

import argparse
import collections
import sys
import time

import numpy as np


class _TimedCV:
    """An OpenCV Feature2D whose ``detect`` and ``compute`` are timed under ``label``."""

    def __init__(self, obj, label, acc):
        self.obj, self.label, self.acc = obj, label, acc

    def detect(self, *a):
        c0 = time.process_time()
        try:
            return self.obj.detect(*a)
        finally:
            self.acc[self.label + ".detect"] += time.process_time() - c0

    def compute(self, *a):
        c0 = time.process_time()
        try:
            return self.obj.compute(*a)
        finally:
            self.acc[self.label + ".compute"] += time.process_time() - c0


def _wrap(obj, name, label, acc):
    f = getattr(obj, name)

    def timed(*a, **k):
        c0 = time.process_time()
        try:
            return f(*a, **k)
        finally:
            acc[label] += time.process_time() - c0

    setattr(obj, name, timed)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="sf_speed_parts.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--repeats", type=int, default=3, help="timed runs (default 3)")
    ap.add_argument("--cprofile", type=int, default=0, metavar="N", help="run under cProfile, print N rows")
    args = ap.parse_args(argv)
    import cv2

    import seawatch.detect.features as fe
    import seawatch.track.feature_clusters as fc
    from seawatch.sim import make_scenario

    cv2.setNumThreads(1)
    acc = collections.defaultdict(float)
    timers = args.cprofile <= 0
    if timers:
        for n in ("process", "_keypoints", "_describe_main", "_describe_band", "_match", "_refine",
                  "_camera_motion", "_hold", "_snapshot"):
            _wrap(fe.StableFeatureExtractor, n, "ext." + n, acc)
        for n in ("update", "_outputs", "_relink", "_split_for_report", "_box_anchor"):
            _wrap(fc.FeatureClusterer, n, "clu." + n, acc)
        _wrap(fc.AffinityClusters, "step", "clu.graph.step", acc)
        for n in ("frame_edges", "grow_boxes"):
            _wrap(fc, n, "clu." + n, acc)
        _wrap(fc.StableFeatureTracker, "process", "stage", acc)
    scn = make_scenario(args.scenario, seed=args.seed, width=640, height=480, fps=25.0, duration_s=10.0)
    frames = [scn.render(i) for i in range(min(250, scn.n_frames))]

    def run():
        trk = fc.StableFeatureTracker(fe.StableFeatureExtractor(nominal_fps=25.0), fc.ClusterParams(),
                                      camera=scn.camera)
        if timers:
            ex = trk.extractor
            ex._star = _TimedCV(ex._star, "cv.star_main", acc)
            ex._band_star = _TimedCV(ex._band_star, "cv.star_band", acc)
            ex._sift = _TimedCV(ex._sift, "cv.sift", acc)
        c0 = time.process_time()
        for f in frames:
            trk.process(f)
        return time.process_time() - c0

    run()  # warm-up: Numba's cached kernels loaded
    print(f"{fc.__file__}: {args.scenario} seed {args.seed}, {len(frames)} frames at 640x480")
    if not timers:
        import cProfile
        import pstats

        pr = cProfile.Profile()
        pr.enable()
        run()
        pr.disable()
        st = pstats.Stats(pr, stream=sys.stdout)
        st.sort_stats("tottime").print_stats(args.cprofile)
        st.sort_stats("cumulative").print_stats(args.cprofile)
        return 0
    res = []
    for _ in range(args.repeats):
        acc.clear()
        run()
        res.append(dict(acc))
    for k in sorted(res[0], key=lambda k: -np.median([r.get(k, 0.0) for r in res])):
        v = [r.get(k, 0.0) for r in res]
        print(f"{k:26s} {1e3 * np.median(v) / len(frames):7.2f} ms/frame")
    return 0


if __name__ == "__main__":
    sys.exit(main())
