"""Why a boat found once is missed later (issue #8, session 19): each lost boat-frame's METE charged
to what became of the identity last matched on that boat.

Replays the default stage on one simulator sequence (with ``--cache``, on the extractor snapshots
that ``sf_diagnose.py --cache`` records) and, in every frame, pairs boats and reports as METE does.
A boat in view that is not paired in a frame after its first paired frame is *lost*; its METE
share (``1 / max(n, m)``, only in frames with ``n >= m``, as ``sf_mete_parts.py`` charges
"lost") goes to the first that applies:

* ``elsewhere``: its last identity is reported now, on something else;
* ``coast <outcome>``: its identity is lost and its coast was looked at in this frame or ended
  earlier with that outcome (``FeatureClusterer.coast_log``: outside, overlap, contrast, not
  found, size);
* ``not coasted``: its identity is lost but was never looked at for a coast (reported for less than
  ``coast_min_age_s``, or lost longer than ``coast_s``);
* ``retired``: its identity is neither reported nor lost (handed over, or forgotten).

Also printed: the coasts' outcomes over all frames, and the METE of the frames in which a coasted
report is on no boat (IoU < 0.1 with every boat: coasting clutter).

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_lost_causes.py ir 1 --cache /tmp/s18h2/cache
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, mete_pairs, parse_params, snapshot_cache  # noqa: E402

EVAL_SEEDS = {0, 3, 4}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="sf_lost_causes.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--params", default="{}", help="JSON object of ClusterParams fields (default {})")
    ap.add_argument("--cache", default=None, metavar="DIR", help="sf_diagnose.py's snapshot cache")
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the parts")
    args = ap.parse_args(argv)
    if args.seed in EVAL_SEEDS:
        print(f"sf_lost_causes: seed {args.seed} is an evaluation seed", file=sys.stderr)
        return 2
    kw = parse_params(args.params, "sf_lost_causes")
    if kw is None:
        return 2
    import cv2

    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.eval import box_iou
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker
    from seawatch.types import TrackState

    cv2.setNumThreads(1)
    scn = make_scenario(args.scenario, seed=args.seed)
    trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), ClusterParams(**kw), camera=scn.camera)
    recorded = record = None
    if args.cache:
        path, recorded = snapshot_cache(args.cache, args.scenario, args.seed, None, {}, "camera")
        if recorded is None:
            print("sf_lost_causes: no snapshots in the cache for this sequence; run sf_diagnose.py with --cache "
                  "first", file=sys.stderr)
            return 2
    parts = collections.Counter()
    outcomes = collections.Counter()
    ended: dict[int, str] = {}  # identity -> outcome of its coast's last look
    last_id: dict[int, int] = {}  # boat -> identity last paired with it
    first: set = set()
    coast_clutter = 0.0
    n_frames = 0
    for i, (f, g) in enumerate(scn.iter_frames()):
        tr = _process(trk, f, None if recorded is None else recorded[i], record)
        c = trk.clusterer
        now = [e for e in c.coast_log if e[0] == f.t_s]
        for _, k, _, why in now:
            outcomes[why] += 1
            ended[k] = why
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        n, m = len(gi), len(tr)
        n_frames += 1
        if m and n:
            iou_all = box_iou(gb, tr.boxes)
            co = tr.states == int(TrackState.COASTING)
            if (co & (iou_all.max(axis=0) < 0.1)).any():
                coast_clutter += float((co & (iou_all.max(axis=0) < 0.1)).sum()) / max(n, m)
        rr, cc, _ = mete_pairs(gb, tr.boxes) if n and m else (np.zeros(0, int), np.zeros(0, int), None)
        paired = dict(zip(rr.tolist(), cc.tolist()))
        for j, vid in enumerate(gi.tolist()):
            if j in paired:
                first.add(vid)
                last_id[vid] = int(tr.ids[paired[j]])
                continue
            if vid not in first or n < m:
                continue
            k = last_id[vid]
            w = 1.0 / max(n, m)
            if k in set(tr.ids.tolist()):
                parts["elsewhere"] += w
            elif k in c._lost:
                parts[f"coast {ended[k]}" if k in ended and c._lost[k][0] <= max(
                    e[0] for e in c.coast_log if e[1] == k) else "not coasted"] += w
            else:
                parts["retired"] += w
    total = {k: v / n_frames for k, v in parts.items()}
    print(f"{args.scenario} seed {args.seed}: lost METE {sum(total.values()):.4f}")
    for k, v in sorted(total.items(), key=lambda kv: -kv[1]):
        print(f"  {k:18s} {v:.4f}")
    print("coast outcomes (identity-frames):", dict(outcomes))
    print(f"coasted reports on no boat: METE share {coast_clutter / n_frames:.4f}")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(scenario=args.scenario, seed=args.seed, parts=total, outcomes=dict(outcomes),
                                     coast_clutter=coast_clutter / n_frames)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
