"""Why a matched boat's box is too small (issue #8, session 20): for every METE pair whose report
is smaller than 1 / 1.5 of the boat's area, what the box growing did with the cluster's box:
grown, or not and why (the core does not stand out, the foreground fills the window or is empty,
the components touching the core reach the window's edges, none touches the core, the object does
not cover the core).  Replays the clustering on ``sf_diagnose.py``'s snapshot cache.

Example (tuning seeds only)::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_boxfit_small.py pan 1 --cache /tmp/s18h2/cache
"""
from __future__ import annotations

import collections
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from sf_diagnose import replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_boxfit_small.py", __doc__)
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_boxfit_small")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    import seawatch.track.feature_clusters as fc
    from sf_boxfit_diag import _inside
    from sf_diagnose import _process, mete_pairs

    seg_orig, one_orig, grow_orig = fc._segment_object, fc._grow_one, fc.grow_boxes
    st = {}

    def seg(*a):
        r = seg_orig(*a)
        st["code"] = int(r[0])
        return r

    def one(img, box, core_box, *a, **k):
        st["code"] = None
        r = one_orig(img, box, core_box, *a, **k)
        if r[0] is not None:
            why = "grown"
        elif st["code"] is None:
            why = "core does not stand out" if np.isfinite(r[1]) else "window too small"
        else:
            why = {0: "object does not cover the core", 1: "foreground fills the window", 2: "reaches the window's edges",
                   3: "nothing touches the core"}[st["code"]]
        st.setdefault("why", {})[tuple(np.round(box, 6))] = why
        return r

    def grow(image, boxes, cores, **k):
        st["why"] = {}
        r = grow_orig(image, boxes, cores, **k)
        st["pre"] = np.array(boxes, float).reshape(-1, 4)
        st["grown"] = np.array(r[0] if isinstance(r, tuple) else r, float).reshape(-1, 4)
        return r

    fc._segment_object, fc._grow_one, fc.grow_boxes = seg, one, grow
    nf = 0
    loss = collections.Counter()
    count = collections.Counter()
    by_boat = collections.Counter()
    total = 0.0
    for f, g in scn.iter_frames():
        nf += 1
        st.pop("pre", None)
        tr = _process(trk, f, recorded[f.index], None)
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        if not len(gi) or not len(tr.ids):
            continue
        rr, cc, iou = mete_pairs(gb, tr.boxes)
        den = float(max(len(gi), len(tr.ids)))
        for a, b in zip(rr, cc):
            rep, gt = tr.boxes[b], gb[a]
            if rep[2] * rep[3] >= gt[2] * gt[3] / 1.5:
                continue
            w = (1 - iou[a, b]) / den
            total += w
            why = "coasting or no growing"
            if "pre" in st:
                parts = [i for i in range(len(st["grown"])) if _inside(st["grown"][i], rep)]
                if parts:
                    ws = [st["why"].get(tuple(np.round(st["pre"][i], 6)), "?") for i in parts]
                    why = ws[0] if len(set(ws)) == 1 else "several parts: " + "/".join(sorted(set(ws)))
            loss[why] += w
            count[why] += 1
            by_boat[int(gi[a])] += w
            if os.environ.get("SMALL_SHOW") == why:
                print(f"  f {f.index} boat {int(gi[a])} gt {np.round(gt, 1).tolist()} rep {np.round(rep, 1).tolist()} "
                      f"iou {iou[a, b]:.2f}")
    print(f"{args.scenario} {args.seed}: too-small IoU loss {total / nf:.4f} (METE units)")
    for k, v in loss.most_common():
        print(f"  {k:45s} {v / nf:.4f}  ({count[k]} pairs)")
    print("  by boat: " + ", ".join(f"{b} {v / nf:.4f}" for b, v in by_boat.most_common()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
