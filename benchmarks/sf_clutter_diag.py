"""What the reports on no boat are (issue #8, session 20): each clutter report's METE charged to
what lies under it.

Replays the default stage on one simulator sequence (with ``--cache``, on the extractor snapshots
that ``sf_diagnose.py --cache`` records) and pairs boats and reports as METE does. A report is
*clutter* when its IoU with every boat in view is under 0.1 (``sf_mete_parts.py``'s rule); in a
frame with ``m > n`` reports beyond the count cost ``1 / max(n, m)`` each, and when ``n >= m`` a
clutter report takes a missed boat's place (charged to that boat by ``sf_mete_parts.py``; counted
here as ``subst``). Each clutter report is classified by its pixels, every ``--every``-th frame
(rendering the frame again without wakes and without reflections, as ``sf_boxfit_diag.py`` does):

* ``boat``: a quarter or more of the box is a boat's pixels (a boat out of the ground truth's view
  list, or the box on a boat's edge);
* ``wake`` / ``reflection``: a quarter or more of the box differs from the frame rendered without them;
* ``above``: the box's bottom lies above the water row (the coast, the sky);
* ``sea``: the rest (sea texture, glint, the foot of the coast at the water row).

and, in every frame, by its track: coasting or live, the identity's age, whether that identity
was ever paired with a boat before (a boat's identity gone astray) and its velocity relative to the
scene when known. Prints the METE of each class and the identities that carry most.

Example (tuning seeds only; 0, 3, 4 are refused)::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_clutter_diag.py pan 1 --cache /tmp/s18h2/cache
"""
from __future__ import annotations

import collections
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, mete_pairs, replay_parser, replay_setup  # noqa: E402


def _classify(box, label, wake, refl, water_row):
    """The class of a report's pixels (see the module's docstring)."""
    hh, ww = label.shape
    x0, y0 = int(max(np.floor(box[0]), 0)), int(max(np.floor(box[1]), 0))
    x1, y1 = int(min(np.ceil(box[0] + box[2]), ww)), int(min(np.ceil(box[1] + box[3]), hh))
    if x1 <= x0 or y1 <= y0:
        return "outside"
    sl = (slice(y0, y1), slice(x0, x1))
    area = float((x1 - x0) * (y1 - y0))
    if (label[sl] > 0).sum() >= 0.25 * area:
        return "boat"
    if wake[sl].sum() >= 0.25 * area:
        return "wake"
    if refl[sl].sum() >= 0.25 * area:
        return "reflection"
    if y1 <= int(np.median(water_row[x0:x1])):
        return "above"
    return "sea"


def main(argv=None) -> int:
    ap = replay_parser("sf_clutter_diag.py", __doc__)
    ap.add_argument("--every", type=int, default=5, help="classify the pixels every N-th frame (default 5)")
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the figures")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_clutter_diag")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    from seawatch.types import TrackState

    no_wake = scn.with_render_options(wakes=False)
    no_refl = scn.with_render_options(reflections=False)
    paired_ids: set = set()
    first_seen: dict = {}
    rows = []
    nf = 0
    for f, g in scn.iter_frames():
        nf += 1
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        tr = _process(trk, f, recorded[nf - 1], None)
        pi, pb = tr.ids, tr.boxes
        for r in pi:
            first_seen.setdefault(int(r), f.t_s)
        n, m = len(gi), len(pi)
        if not m:
            continue
        if n:
            rr, cc, iou = mete_pairs(gb, pb)
            best = iou.max(axis=0)
        else:
            rr, cc, best = np.zeros(0, int), np.zeros(0, int), np.zeros(m)
        clutter = [b for b in range(m) if best[b] < 0.1 and b not in set(cc.tolist())]
        masks = None
        if clutter and f.index % args.every == 0:
            a = f.image.astype(np.int16)
            dw = np.abs(a - no_wake.render(f.index).image.astype(np.int16))
            dr = np.abs(a - no_refl.render(f.index).image.astype(np.int16))
            if dw.ndim == 3:
                dw, dr = dw.max(axis=2), dr.max(axis=2)
            masks = (scn.label_image(f.index), dw > 6, dr > 6, np.asarray(g.water_row))
        den = float(max(n, m))
        for b in clutter:
            rid = int(pi[b])
            row = dict(f=int(f.index), t=float(f.t_s), id=rid, w=(1.0 / den) if m > n else 0.0,
                       subst=(1.0 / den) if m <= n else 0.0,
                       coasting=bool(tr.states[b] == int(TrackState.COASTING)),
                       age=float(f.t_s - first_seen[rid]), was_boat=rid in paired_ids,
                       box=[float(v) for v in pb[b]])
            if masks is not None:
                row["cls"] = _classify(pb[b], *masks)
            rows.append(row)
        for a_, b_ in zip(rr, cc):
            if iou[a_, b_] >= 0.1:
                paired_ids.add(int(pi[b_]))
    beyond = sum(r["w"] for r in rows) / nf
    subst = sum(r["subst"] for r in rows) / nf
    print(f"{args.scenario} {args.seed}: {nf} frames; clutter reports beyond the count {beyond:.4f}, "
          f"in place of a missed boat {subst:.4f}")
    # the pixel classes, from the sampled frames, scaled to the whole sequence's METE
    samp = [r for r in rows if "cls" in r]
    cls_w = collections.Counter()
    for r in samp:
        cls_w[r["cls"]] += r["w"] + r["subst"]
    tot = sum(cls_w.values())
    shares = {k: v / tot for k, v in cls_w.items()} if tot else {}
    print("pixel classes (sampled frames, share of beyond + subst): "
          + ", ".join(f"{k} {v:.2f}" for k, v in sorted(shares.items(), key=lambda kv: -kv[1])))
    by = collections.defaultdict(float)
    for r in rows:
        key = ("coast" if r["coasting"] else "live") + ("/was-boat" if r["was_boat"] else "/never-boat")
        by[key] += (r["w"] + r["subst"]) / nf
    print("by track: " + ", ".join(f"{k} {v:.4f}" for k, v in sorted(by.items(), key=lambda kv: -kv[1])))
    ages = np.array([r["age"] for r in rows]) if rows else np.zeros(0)
    wts = np.array([r["w"] + r["subst"] for r in rows]) / nf if rows else np.zeros(0)
    for lo, hi in ((0, 1), (1, 3), (3, 10), (10, 1e9)):
        sel = (ages >= lo) & (ages < hi)
        print(f"  identity age {lo}-{hi if hi < 1e9 else 'inf'} s: {wts[sel].sum():.4f}")
    per_id = collections.defaultdict(lambda: [0.0, 0, 1e9, -1.0, collections.Counter()])
    for r in rows:
        p = per_id[r["id"]]
        p[0] += (r["w"] + r["subst"]) / nf
        p[1] += 1
        p[2] = min(p[2], r["t"])
        p[3] = max(p[3], r["t"])
        if "cls" in r:
            p[4][r["cls"]] += 1
    print("identity  METE    frames  from-to (s)   box (first)                  classes")
    first_box = {}
    for r in rows:
        first_box.setdefault(r["id"], r["box"])
    for rid, p in sorted(per_id.items(), key=lambda kv: -kv[1][0])[:12]:
        bx = first_box[rid]
        print(f"{rid:8d}  {p[0]:.4f}  {p[1]:6d}  {p[2]:5.1f}-{p[3]:5.1f}   "
              f"{bx[0]:6.1f} {bx[1]:6.1f} {bx[2]:5.1f} {bx[3]:5.1f}   {dict(p[4])}")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(scenario=args.scenario, seed=args.seed, params=args.params, beyond=beyond,
                                     subst=subst, shares=shares, by_track=dict(by))) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
