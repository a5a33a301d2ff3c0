"""Who the box members of one boat's cluster are (issue #8, session 20): the hull's features or its
wake's foam, told apart by the simulator's ground truth, with each member's age, lifetime and
displacement in the scene.

Replays the clustering on ``sf_diagnose.py``'s snapshot cache over one simulator sequence.  In every
frame where the boat (``--boat``, its identity in the ground truth; the rib of ``pan`` is 3) is
matched by a report, the cluster whose box members lie most inside the report is looked at: each of
its box members (after ``box_dv_px_s`` and ``box_disp_s``) is "hull" when it lies inside the boat's
box grown by ``--tol`` px, else "out" (the foam of the wake, mostly).  Prints, per class, the count,
the median age (since the feature first appeared in a snapshot), the median age at which it became
a member of this cluster, whether its displacement over ``box_disp_s`` is known, and, for the
features that have died by the end, their lifetime; and the share of frames where the "out" members
are the majority.

Example (tuning seeds only; seeds 0, 3, 4 are refused)::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_boxfit_rib.py pan 1 --cache /tmp/s18h2/cache
"""
from __future__ import annotations

import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from sf_diagnose import replay_parser, replay_setup  # noqa: E402



def main(argv=None) -> int:
    ap = replay_parser("sf_boxfit_rib.py", __doc__)
    ap.add_argument("--boat", type=int, default=3)
    ap.add_argument("--tol", type=float, default=2.0)
    ap.add_argument("--show", type=int, default=0, help="print the members of every N-th matched frame")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_boxfit_rib")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    import seawatch.track.feature_clusters as fc
    from sf_diagnose import _process, mete_pairs

    seen = {}
    orig_out = fc.FeatureClusterer._outputs
    orig_disp = fc.FeatureClusterer._disp_members

    def out_w(self, snap, labels, cids, image=None):
        seen["labels"], seen["cids"], seen["snap"] = labels.copy(), cids.copy(), snap
        return orig_out(self, snap, labels, cids, image)

    def disp_w(self, snap, m, k, n, inb):
        keep = orig_disp(self, snap, m, k, n, inb)
        seen["m"], seen["k"], seen["inb"], seen["keep"] = m, k, inb, keep
        # which members had a known displacement (the ring's first frame holds them)
        t0, s0, i0, _ = self._disp_ring[0]
        known = np.isin(snap.ids, i0)
        seen["known"] = known[m]
        seen["window_ok"] = float(snap.t_s) - t0 >= 0.5 * self.params.box_disp_s
        return keep

    fc.FeatureClusterer._outputs = out_w
    fc.FeatureClusterer._disp_members = disp_w
    first = {}  # feature id -> first frame seen
    last = {}
    member_since = {}  # (feature id, cluster id) -> first frame a box member of it
    rows = []
    for f, g in scn.iter_frames():
        seen.clear()
        tr = _process(trk, f, recorded[f.index], None)
        snap = seen.get("snap")
        if snap is None:
            continue
        for i in snap.ids:
            first.setdefault(int(i), f.index)
            last[int(i)] = f.index
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        if args.boat not in set(gi.tolist()) or not len(tr.ids) or "m" not in seen:
            continue
        a = int(np.flatnonzero(gi == args.boat)[0])
        rr, cc, iou = mete_pairs(gb, tr.boxes)
        hit = [c for r, c in zip(rr, cc) if r == a]
        m, k, inb, keep = seen["m"], seen["k"], seen["inb"], seen["keep"]
        box_m = (inb & keep) if inb is not None else keep
        ids_m = snap.ids[m]
        xy_m = snap.xy[m]
        cids = seen["cids"]
        for j in np.flatnonzero(box_m):
            member_since.setdefault((int(ids_m[j]), int(cids[k[j]])), f.index)
        if not hit:
            continue
        rep = tr.boxes[hit[0]]
        inside_rep = ((xy_m[:, 0] >= rep[0]) & (xy_m[:, 0] <= rep[0] + rep[2])
                      & (xy_m[:, 1] >= rep[1]) & (xy_m[:, 1] <= rep[1] + rep[3]) & box_m)
        if not inside_rep.any():
            continue
        c = int(np.bincount(k[inside_rep]).argmax())
        sel = np.flatnonzero((k == c) & box_m)
        allc = np.flatnonzero(k == c)
        gx = gb[a]
        t = args.tol
        hull = ((xy_m[:, 0] >= gx[0] - t) & (xy_m[:, 0] <= gx[0] + gx[2] + t)
                & (xy_m[:, 1] >= gx[1] - t) & (xy_m[:, 1] <= gx[1] + gx[3] + t))
        row = dict(f=f.index, iou=float(iou[a, hit[0]]), gt=gx.tolist(), rep=rep.tolist(),
                   n_all=len(allc), n_box=len(sel), n_hull=int(hull[sel].sum()),
                   n_hull_all=int(hull[allc].sum()), window_ok=bool(seen.get("window_ok")),
                   members=[dict(id=int(ids_m[j]), hull=bool(hull[j]), box=bool(box_m[j]), x=float(xy_m[j, 0]),
                                 y=float(xy_m[j, 1]), age=f.index - first[int(ids_m[j])],
                                 mage=f.index - member_since.get((int(ids_m[j]), int(cids[c])), f.index),
                                 known=bool(seen["known"][j]), disp_out=bool(not keep[j]),
                                 dv_out=bool(inb is not None and not inb[j])) for j in allc])
        rows.append(row)
    # summary
    end = max(last.values()) if last else 0
    print(f"{args.scenario} {args.seed} boat {args.boat}: {len(rows)} matched frames")
    if not rows:
        return 0
    maj = np.mean([r["n_box"] - r["n_hull"] > r["n_hull"] for r in rows])
    print(f"  box members per frame: median {np.median([r['n_box'] for r in rows]):.0f}, hull "
          f"{np.median([r['n_hull'] for r in rows]):.0f}; 'out' the majority in {maj:.2f} of frames; "
          f"median IoU {np.median([r['iou'] for r in rows]):.2f}")
    for cls in (True, False):
        ms = [mm for r in rows for mm in r["members"] if mm["hull"] == cls]
        bx = [mm for mm in ms if mm["box"]]
        if not ms:
            continue
        life = [last[mm["id"]] - first[mm["id"]] for mm in ms if last[mm["id"]] < end]
        print(f"  {'hull' if cls else 'out '}: member-frames {len(ms)} (in box {len(bx)}); age median "
              f"{np.median([mm['age'] for mm in ms]):.0f} fr (q25 {np.percentile([mm['age'] for mm in ms], 25):.0f}), "
              f"member for {np.median([mm['mage'] for mm in bx]) if bx else float('nan'):.0f} fr; displacement known "
              f"{np.mean([mm['known'] for mm in ms]):.2f}; left out by disp {np.mean([mm['disp_out'] for mm in ms]):.2f}, "
              f"by dv {np.mean([mm['dv_out'] for mm in ms]):.2f}; lifetime (dead ones) median "
              f"{np.median(life) if life else float('nan'):.0f} fr; distinct features {len(set(mm['id'] for mm in ms))}")
    if args.show:
        for r in rows[:: args.show]:
            print(f"f {r['f']} iou {r['iou']:.2f} gt {np.round(r['gt'], 1).tolist()} rep {np.round(r['rep'], 1).tolist()}")
            for mm in sorted(r["members"], key=lambda q: q["x"]):
                print(f"    id {mm['id']:6d} {'H' if mm['hull'] else '.'}{'B' if mm['box'] else '-'} x {mm['x']:6.1f} "
                      f"y {mm['y']:6.1f} age {mm['age']:4d} mage {mm['mage']:4d} known {int(mm['known'])} "
                      f"disp_out {int(mm['disp_out'])} dv_out {int(mm['dv_out'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
