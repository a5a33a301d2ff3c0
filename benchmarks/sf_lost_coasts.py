"""Why a coast fails (issue #8, session 22): each coast looked at, against the boat its identity was on.

Replays the default stage on one simulator sequence (``--cache``: the snapshots that
``sf_diagnose.py --cache`` records) and, for every coast looked at (``FeatureClusterer.coast_log``)
whose identity was last paired (METE's assignment) with a boat still in view, prints per outcome
(reported, searched, not found, size, contrast, outside, overlap): how many, the expected box's IoU with the
boat's true box, its centre's offset in boat widths/heights, its size against the boat's, the
boat's height, and (for the failed ones) whether the coast's grow would have found the boat from a
core at the boat's true place (``true core found``) or from the expected box in a window twice as
large (``wide found``), and the share of looks whose box lies on no boat (IoU < 0.1 with every boat in view,
``on none``).  That tells a coast that looks in the wrong place from one that looks in
the right place at a boat too small or faint for the grow.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_lost_coasts.py pan 6 --cache /tmp/s21/cache
"""
from __future__ import annotations

import collections
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, mete_pairs, replay_parser, replay_setup  # noqa: E402


def _grow_check(img, box, core, p, grow):
    from seawatch.track.feature_clusters import grow_boxes

    g, con, found = grow_boxes(img, box[None], core[None], grow=grow, peak_frac=p.grow_peak_frac,
                               return_found=True, wide_grow_px=p.grow_wide_px,
                               waterline_frac=p.waterline_frac, top_frac=p.top_frac)
    r = g[0, 2] * g[0, 3] / max(box[2] * box[3], 1e-9)
    return bool(found[0] and con[0] >= p.min_contrast and 1 / p.coast_size_ratio <= r <= p.coast_size_ratio), g[0]


def main(argv=None) -> int:
    ap = replay_parser("sf_lost_coasts.py", __doc__, cache_required=False)
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the rows")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_lost_coasts")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    from seawatch.eval import box_iou
    from seawatch.track.feature_clusters import to_grey_u8

    c = trk.clusterer
    p = c.params
    last_id: dict[int, int] = {}  # identity -> boat it was last paired with
    rows = []
    for i, (f, g) in enumerate(scn.iter_frames()):
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        if len(gi) and len(tr):
            rr, cc, _ = mete_pairs(gb, tr.boxes)
            for r_, c_ in zip(rr.tolist(), cc.tolist()):
                last_id[int(tr.ids[c_])] = int(gi[r_])
        now = [e for e in c.coast_log if e[0] == f.t_s]
        if not now:
            continue
        img = np.asarray(f.image)
        img = img if img.dtype == np.uint8 else to_grey_u8(img)
        for _, k, box, why in now:
            vid = last_id.get(k)
            iou_any = float(box_iou(box[None], gb).max()) if len(gb) else 0.0
            lost = c._lost.get(k)
            age = float(lost[0] - c._birth.get(k, lost[0])) if lost is not None else float("nan")
            gone = float(f.t_s - lost[0]) if lost is not None else float("nan")
            if vid is None or vid not in gi.tolist():
                rows.append(dict(t=f.t_s, k=k, why=why, boat=vid, vis=False, iou_any=iou_any, age=age, gone=gone))
                continue
            tb = gb[gi.tolist().index(vid)].astype(float)
            iou = float(box_iou(box[None], tb[None])[0, 0])
            dx = (box[0] + box[2] / 2 - tb[0] - tb[2] / 2) / max(tb[2], 1)
            dy = (box[1] + box[3] / 2 - tb[1] - tb[3] / 2) / max(tb[3], 1)
            sz = float(np.sqrt(box[2] * box[3] / max(tb[2] * tb[3], 1e-9)))
            row = dict(t=f.t_s, k=k, why=why, boat=vid, vis=True, iou=iou, iou_any=iou_any, age=age, gone=gone, dx=float(dx), dy=float(dy), size=sz,
                       h=float(tb[3]), w=float(tb[2]))
            if why in ("not found", "size", "contrast"):
                tcore = np.array([tb[0] + 0.25 * tb[2], tb[1] + 0.25 * tb[3], 0.5 * tb[2], 0.5 * tb[3]])
                row["true_core"] = _grow_check(img, tb, tcore, p, max(p.grow_box, 0.5))[0]
                core = np.array([box[0] + 0.25 * box[2], box[1] + 0.25 * box[3], 0.5 * box[2], 0.5 * box[3]])
                row["wide"] = _grow_check(img, box, core, p, 2 * max(p.grow_box, 0.5))[0]
                # the expected box's size at the true place (is it the place or the size?)
                eb = np.array([tb[0] + tb[2] / 2 - box[2] / 2, tb[1] + tb[3] / 2 - box[3] / 2, box[2], box[3]])
                ecore = np.array([eb[0] + 0.25 * eb[2], eb[1] + 0.25 * eb[3], 0.5 * eb[2], 0.5 * eb[3]])
                row["true_place"] = _grow_check(img, eb, ecore, p, max(p.grow_box, 0.5))[0]
            rows.append(row)
    by = collections.defaultdict(list)
    for r in rows:
        by[r["why"]].append(r)
    print(f"{args.scenario} seed {args.seed}: coasts looked at {len(rows)}")
    print(f"{'outcome':10s} {'n':>5s} {'nvis':>5s} {'IoU med':>8s} {'|dx| med':>8s} {'|dy| med':>8s} "
          f"{'size med':>8s} {'h med':>6s} {'truecore':>8s} {'trueplace':>9s} {'wide':>6s} {'on none':>8s}")
    for why, rs in sorted(by.items(), key=lambda kv: -len(kv[1])):
        v = [r for r in rs if r["vis"]]

        def med(key):
            return float(np.median([abs(r[key]) for r in v])) if v else float("nan")

        def frac(key):
            q = [r[key] for r in v if key in r]
            return f"{np.mean(q):.2f}" if q else "-"

        on_none = np.mean([r["iou_any"] < 0.1 for r in rs])
        print(f"{why:10s} {len(rs):5d} {len(v):5d} {med('iou'):8.2f} {med('dx'):8.2f} {med('dy'):8.2f} "
              f"{med('size'):8.2f} {med('h'):6.1f} {frac('true_core'):>8s} {frac('true_place'):>9s} "
              f"{frac('wide'):>6s} {on_none:8.2f}")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(scenario=args.scenario, seed=args.seed, rows=rows)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
