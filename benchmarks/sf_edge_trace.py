"""One boat's frames, its last identity's coast and the reports near it (issue #8, session 24, helper H7).

Replays the stage (``--cache``: ``sf_diagnose.py``'s snapshots, ``--params``: ClusterParams
fields) on one simulator sequence and prints, for each frame of ``--boat`` between ``--t0`` and
``--t1`` seconds: the zoom, the boat's true box, whether it is paired (METE's assignment) and to
which identity, and the identity last paired with it: its coast log entry of this frame (outcome
and box) or its lost (expected) box.  Written to see the faint motorboat lost while it straddles
the image's edge during a zoom (``coast outside``) on the faint ``pan`` seeds.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_edge_trace.py pan 55 --cache /tmp/s23/cache_fresh \\
        --boat 3 --t0 19 --t1 30 --params '{"coast_outside_wait": true}'
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, mete_pairs, replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_edge_trace.py", __doc__, cache_required=False)
    ap.add_argument("--boat", type=int, required=True, help="the ground truth's vessel id")
    ap.add_argument("--t0", type=float, default=0.0, help="first time printed (s)")
    ap.add_argument("--t1", type=float, default=1e9, help="last time printed (s)")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_edge_trace")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    c = trk.clusterer
    last_id = None
    for i, (f, g) in enumerate(scn.iter_frames()):
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
        if f.t_s > args.t1 + 1e-9:
            break
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        n, m = len(gi), len(tr)
        rr, cc, _ = mete_pairs(gb, tr.boxes) if n and m else (np.zeros(0, int), np.zeros(0, int), None)
        paired = dict(zip(rr.tolist(), cc.tolist()))
        js = np.flatnonzero(gi == args.boat)
        if not len(js):
            if f.t_s >= args.t0 - 1e-9 and last_id is not None:
                log = [e for e in c.coast_log if e[0] == f.t_s and e[1] == last_id]
                lb = c._lost.get(last_id)
                print(f"t {f.t_s:6.2f} zoom {c._zoom:4.2f} out of view  id {last_id}: "
                      f"{(log[0][3] + ' ' + str(np.round(log[0][2], 1).tolist())) if log else ''} "
                      f"{'lost ' + str(np.round(lb[1], 1).tolist()) if lb is not None else ''}")
            continue
        j = int(js[0])
        line = f"t {f.t_s:6.2f} zoom {c._zoom:4.2f} true {np.round(gb[j], 1).tolist()}"
        if j in paired:
            last_id = int(tr.ids[paired[j]])
            line += (f" paired id {last_id} state {int(tr.states[paired[j]])} "
                     f"box {np.round(tr.boxes[paired[j]], 1).tolist()}")
        elif last_id is not None:
            log = [e for e in c.coast_log if e[0] == f.t_s and e[1] == last_id]
            lb = c._lost.get(last_id)
            line += f" LOST id {last_id}: "
            line += (log[0][3] + " " + str(np.round(log[0][2], 1).tolist())) if log else "no coast look"
            if lb is not None:
                line += f" lost at {lb[0]:.1f} expected {np.round(lb[1], 1).tolist()}"
        if f.t_s >= args.t0 - 1e-9:
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
