"""Check that a speed change to the stable-feature stage leaves its output unchanged, and time it.

``dump``: run the WHOLE stage (``StableFeatureTracker`` with default parameters, the scenario's
camera model, as ``bench_stable_features`` builds it) over a simulator scenario's frames and write,
per frame, the reported track identities, boxes and states, the detection boxes and scores, the
number of active and of stable features, and a digest of the extractor's snapshot (feature ids,
positions, confidences, velocity histories, the camera homography) to OUT (a pickle).  Run it with
the code before a change (a ``git worktree`` of the commit before, ``PYTHONPATH`` set to it) and
after; ``compare`` says whether two dumps are identical frame by frame (boxes compared exactly, the
digests byte for byte) and prints the first frames that differ.

``time``: CPU time per frame of the whole stage on a scenario rendered at 640x480, 25 frames/s,
10 s (250 frames; as ``sf_diagnose.py --speed-pairs``), one OpenCV thread, after a short warm-up
run (Numba's cached kernels loaded); prints one number.  ``pairs``: runs ``time`` in fresh
processes with ``PYTHONPATH`` set to the BEFORE and the AFTER checkouts alternately (the first of
each pair alternating too), N pairs, and prints each pair's ratio after / before and the median.

Uses only the simulator.  Set ``OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1`` for the timings.  Example::

    git worktree add /tmp/sf_before HEAD
    PYTHONPATH=/tmp/sf_before .venv/bin/python benchmarks/sf_speed_check.py dump pan 1 /tmp/b_pan1.pkl
    .venv/bin/python benchmarks/sf_speed_check.py dump pan 1 /tmp/a_pan1.pkl
    .venv/bin/python benchmarks/sf_speed_check.py compare /tmp/b_pan1.pkl /tmp/a_pan1.pkl
    .venv/bin/python benchmarks/sf_speed_check.py pairs pan 1 --before /tmp/sf_before --after . --n 6
"""

from __future__ import annotations

import argparse
import hashlib
import os
import pickle
import subprocess
import sys
import time

import numpy as np


def _parse(argv):
    ap = argparse.ArgumentParser(prog="sf_speed_check.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("dump")
    p.add_argument("scenario")
    p.add_argument("seed", type=int)
    p.add_argument("out", help="the output pickle")
    p.add_argument("--size", default=None, help="WIDTHxHEIGHT (default: the scenario's own)")
    p.add_argument("--frames", type=int, default=0, help="at most this many frames (default: all)")
    p = sub.add_parser("compare")
    p.add_argument("a")
    p.add_argument("b")
    for name in ("time", "pairs"):
        p = sub.add_parser(name)
        p.add_argument("scenario")
        p.add_argument("seed", type=int)
        p.add_argument("--frames", type=int, default=250, help="frames timed (default 250)")
        if name == "pairs":
            p.add_argument("--before", required=True, help="checkout of the code before (PYTHONPATH)")
            p.add_argument("--after", required=True, help="checkout of the code after (PYTHONPATH)")
            p.add_argument("--n", type=int, default=6, help="pairs (default 6)")
    return ap.parse_args(argv)


def _tracker(scn):
    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker

    return StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), ClusterParams(), camera=scn.camera)


def _digest(snap) -> str:
    h = hashlib.sha1()
    for a in (snap.ids, snap.xy, snap.confidence, snap.stable, snap.matched, snap.history,
              snap.image_velocity, snap.size_px, snap.homography):
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(a.tobytes())
    h.update(repr((snap.n_keypoints, snap.n_matched, snap.camera_motion_ok, snap.noise_px_s)).encode())
    return h.hexdigest()


def _dump(args) -> int:
    import cv2

    from seawatch.sim import make_scenario

    cv2.setNumThreads(1)
    kw = {}
    if args.size:
        w, h = (int(x) for x in args.size.lower().split("x"))
        kw = dict(width=w, height=h)
    scn = make_scenario(args.scenario, seed=args.seed, **kw)
    trk = _tracker(scn)
    rec = []
    for f, _ in scn.iter_frames():
        if args.frames and len(rec) >= args.frames:
            break
        dets, tr = trk.process(f)
        s = trk.last_snapshot
        rec.append(dict(frame=int(f.index), ids=np.asarray(tr.ids).copy(), boxes=np.asarray(tr.boxes).copy(),
                        states=np.asarray(tr.states).copy(), det_boxes=np.asarray(dets.boxes).copy(),
                        det_scores=np.asarray(dets.scores).copy(), n_active=len(s), n_stable=int(s.stable.sum()),
                        snap=_digest(s)))
    with open(args.out, "wb") as fh:
        pickle.dump(dict(scenario=args.scenario, seed=args.seed, size=args.size, frames=rec), fh)
    n_rep = sum(len(r["ids"]) for r in rec)
    print(f"{args.out}: {len(rec)} frames, {n_rep} reports, {sum(r['n_stable'] for r in rec)} stable features")
    return 0


def _compare(args) -> int:
    with open(args.a, "rb") as fh:
        a = pickle.load(fh)
    with open(args.b, "rb") as fh:
        b = pickle.load(fh)
    fa, fb = a["frames"], b["frames"]
    bad = []
    if len(fa) != len(fb):
        print(f"different lengths: {len(fa)} and {len(fb)} frames")
    for ra, rb in zip(fa, fb):
        diff = [k for k in ra if not (np.array_equal(ra[k], rb[k]) if isinstance(ra[k], np.ndarray) else ra[k] == rb[k])]
        if diff:
            bad.append((ra["frame"], diff))
    n_rep = sum(len(r["ids"]) for r in fa)
    if bad or len(fa) != len(fb):
        for fr, diff in bad[:10]:
            print(f"frame {fr}: differs in {', '.join(diff)}")
        print(f"DIFFERENT: {len(bad)} of {min(len(fa), len(fb))} frames differ")
        return 1
    print(f"identical: {len(fa)} frames, {n_rep} reports, {sum(r['n_stable'] for r in fa)} stable features "
          f"(boxes, ids, states, detections, feature counts and snapshot digests)")
    return 0


def _time(args) -> int:
    import cv2

    from seawatch.sim import make_scenario

    cv2.setNumThreads(1)
    scn = make_scenario(args.scenario, seed=args.seed, width=640, height=480, fps=25.0, duration_s=10.0)
    frames = [scn.render(i) for i in range(min(args.frames, scn.n_frames))]
    trk = _tracker(scn)
    for f in frames[:20]:  # warm-up: Numba's cached kernels loaded, first-call costs paid
        trk.process(f)
    trk = _tracker(scn)
    c0 = time.process_time()
    for f in frames:
        trk.process(f)
    print(f"{1e3 * (time.process_time() - c0) / len(frames):.3f}")
    return 0


def _pairs(args) -> int:
    here = os.path.abspath(__file__)
    ms = {"before": [], "after": []}
    for r in range(args.n):
        for k in (("before", "after") if r % 2 == 0 else ("after", "before")):
            env = dict(os.environ, PYTHONPATH=os.path.abspath(getattr(args, k)))
            out = subprocess.run([sys.executable, here, "time", args.scenario, str(args.seed), "--frames",
                                  str(args.frames)], env=env, capture_output=True, text=True, check=True)
            ms[k].append(float(out.stdout.strip().splitlines()[-1]))
        print(f"pair {r}: before {ms['before'][-1]:.2f}, after {ms['after'][-1]:.2f} ms/frame, "
              f"after / before {ms['after'][-1] / ms['before'][-1]:.3f}", flush=True)
    ratio = np.array(ms["after"]) / np.array(ms["before"])
    for k, v in ms.items():
        print(f"{k}: median {np.median(v):.2f} ms/frame ({1e3 / np.median(v):.1f} frames/s)")
    print(f"after / before per pair: {', '.join(f'{x:.3f}' for x in ratio)}; median {np.median(ratio):.3f}")
    return 0


def main(argv=None) -> int:
    args = _parse(argv)
    return {"dump": _dump, "compare": _compare, "time": _time, "pairs": _pairs}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
