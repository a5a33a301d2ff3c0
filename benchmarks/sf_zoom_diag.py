"""The cargo ship at full zoom (issue #8, session 21): frame by frame, what the box growing and the
report join do with the clusters on one boat.

Replays the stage on the snapshot cache (as ``sf_ids_diag.py``) and prints, for each frame where
the boat (``--boat``, default: the scenario's cargo ship) is in view at least ``--min-w`` px wide,
its ground-truth box and each cluster whose features' box overlaps it: the cluster, its box
members, the box before the growing, the core (the members' extent), the grown box, the outcome
of each growing try (``seg-ok``: grown, ``flat``: the core does not stand out, ``none``: the window
is full or empty, ``3``: nothing touches the core, ``edge``: the components touching the core all
reach the window's left or right edge, ``cover``: the object does not cover the core; ``W`` marks
the wide window, ``H`` the window of the last frame's box, ``grow_hint``), then the
reports (identity, box, IoU with the boat, the clusters joined into it).  The summary counts,
per cluster, how often its grown box is the whole boat (IoU >= 0.5) and how often a fragment.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_zoom_diag.py pan 2 --cache /tmp/s18h2/cache \
        --t0 22 --t1 27
"""
from __future__ import annotations

import collections
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_zoom_diag.py", __doc__)
    ap.add_argument("--boat", type=int, default=None, help="ground-truth boat id (default: the cargo ship)")
    ap.add_argument("--min-w", type=float, default=100.0, help="only frames where the boat is this wide (px)")
    ap.add_argument("--t0", type=float, default=0.0)
    ap.add_argument("--t1", type=float, default=1e9)
    ap.add_argument("--quiet", action="store_true", help="only the summary")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_zoom_diag")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    import seawatch.track.feature_clusters as fc
    from seawatch.eval import box_iou

    boat = args.boat
    if boat is None:
        boat = next(v.id for v in scn.vessels if v.type == "cargo")
    c = trk.clusterer
    cur: dict = {}
    orig_grow, orig_seg, orig_merge = fc.grow_boxes, fc._segment_object, fc._merge_overlapping
    names = {1: "none", 2: "edge"}

    orig_one = fc._grow_one
    wide_px = trk.clusterer.params.grow_wide_px

    def seg(dev, thr, max_fill, r0, r1, q0, q1, le, re):
        out = orig_seg(dev, thr, max_fill, r0, r1, q0, q1, le, re)
        if cur.get("seg"):
            cur["seg"][-1][1] = names.get(int(out[0]), "seg-ok" if out[0] == 0 else str(int(out[0])))
        return out

    def one(img, box, core_box, gx, *a, **kw):
        # which window: the first, the wide one (gx = grow_wide_px) or the hint's (grow_hint)
        s_ = cur.setdefault("seg", [])
        s_.append(["" if not s_ else ("W" if gx == wide_px else "H"), "flat"])
        r = orig_one(img, box, core_box, gx, *a, **kw)
        if r[0] is None and s_[-1][1] == "seg-ok":
            s_[-1][1] = "cover"  # segmented, but the object does not cover the core
        return r

    def grow(img, boxes, cores, **kw):
        if "hints" not in kw:  # the coasting's growing: not recorded
            return orig_grow(img, boxes, cores, **kw)
        tries = []
        res = []
        hints = kw.pop("hints", None)
        for n in range(len(boxes)):
            cur["seg"] = []
            o = orig_grow(img, boxes[n:n + 1], cores[n:n + 1], **{**kw, "return_contrast": True, "return_found": True},
                          hints=None if hints is None else hints[n:n + 1])
            res.append(o)
            tries.append(list(cur["seg"]))
        cur["grow"] = (np.asarray(boxes).copy(), np.asarray(cores).copy(), tries, res)
        out = np.concatenate([r[0] for r in res]) if res else np.zeros((0, 4))
        con = np.concatenate([r[1] for r in res]) if res else np.zeros(0)
        fnd = np.concatenate([r[2] for r in res]) if res else np.zeros(0, bool)
        return out, con, fnd

    def merge(cids, boxes, *a, **kw):
        cur["pre_merge"] = (cids.copy(), boxes.copy())
        out = orig_merge(cids, boxes, *a, **kw)
        return out

    fc.grow_boxes, fc._segment_object, fc._merge_overlapping, fc._grow_one = grow, seg, merge, one
    orig_rel = c._relink

    def relink(snap, cids, boxes, vel=None):
        rep = orig_rel(snap, cids, boxes, vel)
        cur["rep"] = {int(cids[i]): int(r) for i, r in enumerate(rep)}
        return rep

    c._relink = relink
    whole = collections.Counter()
    frag = collections.Counter()
    outc = collections.Counter()
    nrep = collections.Counter()
    for i, (f, g) in enumerate(scn.iter_frames()):
        cur.clear()
        orig_out = c._outputs

        def outputs(snap, labels, cids, image=None):
            cur["cids"] = np.asarray(cids).copy()
            r = orig_out(snap, labels, cids, image)
            return r

        c._outputs = outputs
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
        c._outputs = orig_out
        if not (args.t0 <= f.t_s <= args.t1):
            continue
        sel = np.flatnonzero((g.ids == boat) & (g.visible > 0))
        if not len(sel):
            continue
        gb = g.boxes[sel[0]]
        if gb[2] < args.min_w:
            continue
        lines = [f"{f.t_s:6.2f} s frame {f.index}: boat {boat} box {np.round(gb).astype(int).tolist()}"]
        if "grow" in cur:
            pre, cores, tries, res = cur["grow"]
            cids = cur.get("cids", np.zeros(0, int))
            for n in range(len(pre)):
                b0 = pre[n]
                if box_iou(gb[None], b0[None])[0, 0] <= 0 and box_iou(gb[None], res[n][0])[0, 0] <= 0:
                    continue
                gbx = res[n][0][0]
                ok = bool(res[n][2][0])
                iou = float(box_iou(gb[None], gbx[None])[0, 0])
                t = []
                for w_, code in tries[n]:
                    t.append(w_ + code)
                cid = int(cids[n]) if n < len(cids) else -1
                if ok:
                    (whole if iou >= 0.5 else frag)[cid] += 1
                outc[(cid, "whole" if ok and iou >= 0.5 else ("frag" if ok else "not grown"))] += 1
                lines.append(f"    cluster {cid} (id {cur.get('rep', {}).get(cid, '?')}): pre "
                             f"{np.round(b0).astype(int).tolist()} core {np.round(cores[n]).astype(int).tolist()} -> "
                             f"{np.round(gbx).astype(int).tolist()} {'grown' if ok else 'kept'} IoU {iou:.2f} "
                             f"contrast {res[n][1][0]:.1f} tries {t}")
        if len(tr):
            io = box_iou(gb[None], tr.boxes)[0]
            on = np.flatnonzero(io > 0.05)
            nrep[len(np.flatnonzero(io >= 0.3))] += 1
            for j in on:
                lines.append(f"    REPORT id {int(tr.ids[j])} box {np.round(tr.boxes[j]).astype(int).tolist()} "
                             f"IoU {io[j]:.2f} state {int(tr.states[j])}")
        if not args.quiet:
            print("\n".join(lines))
    print("frames by number of reports at IoU >= 0.3 on the boat:", dict(sorted(nrep.items())))
    print("per cluster outcomes (cluster, outcome): count")
    for k, v in sorted(outc.items()):
        print(f"  {k}: {v}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
