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

import collections
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, mete_pairs, replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_lost_causes.py", __doc__, cache_required=False)
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the parts")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_lost_causes")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    from seawatch.eval import box_iou
    from seawatch.types import TrackState

    parts = collections.Counter()
    outcomes = collections.Counter()
    ended: dict[int, str] = {}  # identity -> outcome of its coast's last look
    last_id: dict[int, int] = {}  # boat -> identity last paired with it
    first: set = set()
    coast_clutter = 0.0
    n_frames = 0
    for i, (f, g) in enumerate(scn.iter_frames()):
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
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
