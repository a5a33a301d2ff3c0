"""Every hand-over and relink of the stage on one simulator sequence, checked against the ground
truth (issue #8, session 21): was the identity given to a cluster on the boat it was on?

Replays the stage (``--cache``: the snapshots that ``sf_diagnose.py --cache`` records) and records
each identity transfer of :meth:`FeatureClusterer._relink`: a relink (a lost identity taken by a
new cluster) and a hand-over (:meth:`FeatureClusterer._hand_over`: an identity lost while a younger
cluster overlaps its last box).  For each it prints the time, the kind, the identity and the cluster
that took it, the boat under the identity's last report (IoU >= 0.3 with a visible boat, else
``-``), the boat under the receiving cluster's box now, and what the identity rules could look at:
the two boxes' sizes (area ratio, height ratio), the part of the lost box lying inside the
receiver's *core* (its box members' extent before the box growing: the features' extent), the time
lost and the gap against the gate (relinks).  A transfer is ``right`` when both boats are known
and equal, ``wrong`` when both are known and differ, ``?`` otherwise.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_ids_events.py ir 1 --cache /tmp/s18h2/cache \\
        --json /tmp/events.jsonl
"""
from __future__ import annotations

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, replay_parser, replay_setup  # noqa: E402


def _boat_of(box, gi, gb, box_iou):
    """The boat (identity) a box lies on: IoU >= 0.3 with it (the best), else None."""
    if box is None or not len(gi):
        return None
    io = box_iou(gb, np.asarray(box, float)[None])[:, 0]
    j = int(np.argmax(io))
    return int(gi[j]) if io[j] >= 0.3 else None


def _inside(a, b):
    """The part of box ``a`` lying inside box ``b``."""
    iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    ar = a[2] * a[3]
    return float(iw * ih / ar) if iw > 0 and ih > 0 and ar > 0 else 0.0


def main(argv=None) -> int:
    ap = replay_parser("sf_ids_events.py", __doc__)
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line per transfer")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_ids_events")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    from seawatch.eval import box_iou

    c = trk.clusterer
    cur: dict = {}
    orig_relink, orig_hand = c._relink, c._hand_over

    def cores(snap, cids):
        lab = c.last_labels
        out = {}
        for cid in cids:
            m = lab == cid
            if m.any():
                xy = snap.xy[m]
                out[int(cid)] = np.array([xy[:, 0].min(), xy[:, 1].min(), np.ptp(xy[:, 0]), np.ptp(xy[:, 1])])
        return out

    def relink(snap, cids, boxes, vel=None):
        known = set(c._known)
        lost_before = {int(k): (float(v[0]), np.asarray(v[1], float).copy()) for k, v in c._lost.items()}
        cur["core"] = cores(snap, cids)
        cur["hand"] = []
        cur["boxes"] = {int(ci): boxes[i].copy() for i, ci in enumerate(cids)}
        rep = orig_relink(snap, cids, boxes, vel)
        cur["relinks"] = []
        for i, r in enumerate(rep):
            r, ci = int(r), int(cids[i])
            if ci not in known and r != ci and r in lost_before:
                cur["relinks"].append((r, ci, boxes[i].copy(), lost_before[r]))
        return rep

    def hand_over(k, cids, boxes, rep, now, own):
        lb = np.asarray(c._lost[k][1], float).copy()
        r = orig_hand(k, cids, boxes, rep, now, own)
        if r is not None:
            i = [int(x) for x in rep].index(int(k))
            cur["hand"].append((int(k), int(cids[i]), boxes[i].copy(), lb, int(r)))
        return r

    c._relink, c._hand_over = relink, hand_over
    last_rep: dict = {}  # reported identity -> (time, box, boat) when last reported
    rows = []
    for i, (f, g) in enumerate(scn.iter_frames()):
        cur.clear()
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        t = f.t_s
        for kind, items in (("hand-over", cur.get("hand", [])), ("relink", cur.get("relinks", []))):
            for it in items:
                if kind == "hand-over":
                    k, ci, nb, lb, gave = it
                    tl = t
                else:
                    k, ci, nb, (tl, lb) = it
                    gave = None
                prev = last_rep.get(k)
                old_boat = prev[2] if prev is not None else None
                new_boat = _boat_of(nb, gi, gb, box_iou)
                core = cur.get("core", {}).get(ci)
                ok = "?" if old_boat is None or new_boat is None else ("right" if old_boat == new_boat else "wrong")
                row = dict(scenario=args.scenario, seed=args.seed, t=round(t, 2), kind=kind, ident=k, cluster=ci,
                           gave_up=gave, old_boat=old_boat, new_boat=new_boat, verdict=ok,
                           lost_box=np.round(lb, 1).tolist(), new_box=np.round(nb, 1).tolist(),
                           last_box=None if prev is None else np.round(prev[1], 1).tolist(),
                           area_ratio=round(float(nb[2] * nb[3] / max(lb[2] * lb[3], 1e-9)), 2),
                           height_ratio=round(float(nb[3] / max(lb[3], 1e-9)), 2),
                           in_core=None if core is None else round(_inside(lb, core), 2),
                           in_box=round(_inside(lb, nb), 2), lost_s=round(t - tl, 2),
                           gap=round(float(np.hypot(*np.maximum(np.abs((nb[:2] + 0.5 * nb[2:]) - (lb[:2] + 0.5 * lb[2:]))
                                                                 - 0.5 * (nb[2:] + lb[2:]), 0.0))), 1))
                rows.append(row)
        for j, r in enumerate(tr.ids.tolist()):
            last_rep[int(r)] = (t, tr.boxes[j].copy(), _boat_of(tr.boxes[j], gi, gb, box_iou))
    for w in rows:
        print(f"  {w['t']:6.2f} s {w['kind']:9s} {w['ident']:4d} -> cluster {w['cluster']:4d}: boat {w['old_boat']} -> "
              f"{w['new_boat']} {w['verdict']:5s} area x{w['area_ratio']} height x{w['height_ratio']} "
              f"in core {w['in_core']} in box {w['in_box']} lost {w['lost_s']} s gap {w['gap']} "
              f"lost {w['lost_box']} new {w['new_box']}")
    n = {v: sum(w["verdict"] == v for w in rows) for v in ("right", "wrong", "?")}
    print(f"{args.scenario} seed {args.seed}: {len(rows)} transfers, right {n['right']}, wrong {n['wrong']}, "
          f"unknown {n['?']}")
    if args.json:
        with open(args.json, "a") as fh:
            for w in rows:
                fh.write(json.dumps(w) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
