"""What the boxes of matched boats hold: the core (features' extent), the grown box and the report
against the simulator's ground truth (issue #8, session 19).

Replays the clustering on ``sf_diagnose.py``'s snapshot cache (same key) over one simulator
sequence, and for every METE pair (a reported box assigned to a boat, IoU > 0) records

* the report's box, the boxes of the clusters it is made of before the box growing (the features'
  extent padded by the keypoints' radius), their core (the features' positions) and after the
  growing without the stop-15 cuts and with them (``grow_boxes`` is wrapped to see them: its first
  call in each frame, the clusters'; the coasts' boxes are grown after it, session 25);
* the pair's METE weight ``1 / max(n, m)`` and IoU loss ``1 - IoU``;
* every ``--every``-th frame, what the report's pixels outside the boat's box are: another boat,
  a wake, a reflection (both found by rendering the frame again without them), above the water
  line (coast, sky), or sea; and the IoU it would have with each side clipped to the boat's edge.

Prints the IoU loss (in METE units, as ``sf_mete_parts.py``) of the too-large (area > 1.5 times
the boat's), too-small and badly placed (IoU < 0.3) pairs, split by what made them so, and the
box size's temporal spread per boat.  With ``--json FILE`` appends one line with the figures.

Example (tuning seeds only; seeds 0, 3, 4 are refused)::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_boxfit_diag.py pan 1 \\
        --cache /tmp/s18h2/cache --json /tmp/s19h1/diag.jsonl
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

EVAL_SEEDS = {0, 3, 4}
CATS = ("other_boat", "wake", "reflection", "above_water", "sea")


def _parse(argv):
    ap = argparse.ArgumentParser(prog="sf_boxfit_diag.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--params", default="{}", help="ClusterParams fields as JSON")
    ap.add_argument("--cache", required=True, metavar="DIR", help="sf_diagnose.py's snapshot cache")
    ap.add_argument("--every", type=int, default=5, help="render the masks every N-th frame (default 5)")
    ap.add_argument("--json", default=None, metavar="FILE")
    return ap.parse_args(argv)


def _iou(a, b):
    ix = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    iy = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    inter = max(ix, 0.0) * max(iy, 0.0)
    u = a[2] * a[3] + b[2] * b[3] - inter
    return inter / u if u > 0 else 0.0


def _union(bs):
    bs = np.asarray(bs, float).reshape(-1, 4)
    x0, y0 = bs[:, 0].min(), bs[:, 1].min()
    x1, y1 = (bs[:, 0] + bs[:, 2]).max(), (bs[:, 1] + bs[:, 3]).max()
    return np.array([x0, y0, x1 - x0, y1 - y0])


def _inside(inner, outer, tol=0.51):
    return (inner[0] >= outer[0] - tol and inner[1] >= outer[1] - tol
            and inner[0] + inner[2] <= outer[0] + outer[2] + tol and inner[1] + inner[3] <= outer[1] + outer[3] + tol)


def _clip_side(r, g, side):
    """The report ``r`` with one side moved in to the boat's edge where it lies beyond it."""
    x0, y0, x1, y1 = r[0], r[1], r[0] + r[2], r[1] + r[3]
    if side == "left":
        x0 = max(x0, g[0])
    elif side == "right":
        x1 = min(x1, g[0] + g[2])
    elif side == "top":
        y0 = max(y0, g[1])
    else:
        y1 = min(y1, g[1] + g[3])
    return np.array([x0, y0, max(x1 - x0, 0.0), max(y1 - y0, 0.0)])


def main(argv=None) -> int:
    args = _parse(argv)
    if args.seed in EVAL_SEEDS:
        print("sf_boxfit_diag: seeds 0, 3, 4 are evaluation seeds", file=sys.stderr)
        return 2
    import cv2

    import seawatch.track.feature_clusters as fc
    from sf_diagnose import _process, mete_pairs, snapshot_cache
    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.eval import mete
    from seawatch.sim import make_scenario

    cv2.setNumThreads(1)
    kw = json.loads(args.params)
    scn = make_scenario(args.scenario, seed=args.seed)
    trk = fc.StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), fc.ClusterParams(**kw),
                                  camera=scn.camera, horizon="camera")
    _, recorded = snapshot_cache(args.cache, args.scenario, args.seed, None, {}, "camera")
    if recorded is None:
        print("sf_boxfit_diag: no cached snapshots (run sf_diagnose.py --cache first)", file=sys.stderr)
        return 2
    no_wake = scn.with_render_options(wakes=False)
    no_refl = scn.with_render_options(reflections=False)

    orig = fc.grow_boxes
    seen = {}

    def wrapped(image, boxes, cores, **k2):
        res = orig(image, boxes, cores, **k2)
        if "grown" in seen:  # a later call in the frame (the coasts' boxes): keep the clusters', the first
            return res
        plain = orig(image, boxes, cores, **dict(k2, waterline_frac=0.0, wake_frac=0.0, top_frac=0.0,
                                                   return_contrast=False, return_found=False))
        plain = plain[0] if isinstance(plain, tuple) else plain
        seen["pre"] = np.array(boxes, float).reshape(-1, 4)
        seen["core"] = np.array(cores, float).reshape(-1, 4)
        seen["plain"] = np.array(plain, float).reshape(-1, 4)
        seen["grown"] = np.array(res[0] if isinstance(res, tuple) else res, float).reshape(-1, 4)
        return res

    fc.grow_boxes = wrapped
    gt, pred = {}, {}
    rows = []  # one per METE pair
    for f, g in scn.iter_frames():
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        gt[f.index] = (gi, gb)
        seen.clear()
        label = scn.label_image(f.index) if f.index % args.every == 0 else None
        img = f.image
        tr = _process(trk, f, recorded[len(pred)], None)
        pred[f.index] = (tr.ids, tr.boxes)
        n, m = len(gi), len(tr.ids)
        if not n or not m:
            continue
        rr, cc, iou = mete_pairs(gb, tr.boxes)
        den = float(max(n, m))
        masks = None
        if label is not None:
            a = img.astype(np.int16)
            dw = np.abs(a - no_wake.render(f.index).image.astype(np.int16))
            dr = np.abs(a - no_refl.render(f.index).image.astype(np.int16))
            if dw.ndim == 3:
                dw, dr = dw.max(axis=2), dr.max(axis=2)
            hh, ww = label.shape
            above = np.arange(hh)[:, None] < g.water_row[None, :]
            masks = (label, dw > 6, dr > 6, above)
        for a_, b_ in zip(rr, cc):
            gbox, rbox = gb[a_], tr.boxes[b_]
            row = dict(f=int(f.index), boat=int(gi[a_]), w=1.0 / den, iou=float(iou[a_, b_]),
                       gt=[float(v) for v in gbox], rep=[float(v) for v in rbox])
            if "grown" in seen:
                parts = [i for i in range(len(seen["grown"])) if _inside(seen["grown"][i], rbox)]
                if parts:
                    for key in ("pre", "core", "plain", "grown"):
                        u = _union(seen[key][parts])
                        row[key] = [float(v) for v in u]
                    row["nparts"] = len(parts)
            if masks is not None:
                lab, wk, rf, ab = masks
                hh, ww = lab.shape
                x0, y0 = int(max(np.floor(rbox[0]), 0)), int(max(np.floor(rbox[1]), 0))
                x1, y1 = int(min(np.ceil(rbox[0] + rbox[2]), ww)), int(min(np.ceil(rbox[1] + rbox[3]), hh))
                gx0, gy0 = int(gbox[0]), int(gbox[1])
                gx1, gy1 = int(gbox[0] + gbox[2]), int(gbox[1] + gbox[3])
                yy, xx = np.mgrid[y0:y1, x0:x1]
                out = ~((xx >= gx0) & (xx < gx1) & (yy >= gy0) & (yy < gy1))
                sl = (slice(y0, y1), slice(x0, x1))
                lb = lab[sl]
                other = (lb > 0) & (lb != gi[a_])
                cat = np.full(lb.shape, 4, np.int8)  # sea
                cat[ab[sl]] = 3
                cat[rf[sl]] = 2
                cat[wk[sl]] = 1
                cat[other] = 0
                cnt = np.bincount(cat[out].ravel(), minlength=5)
                row["excess"] = [int(v) for v in cnt]
                row["side_iou"] = {s: _iou(_clip_side(rbox, gbox, s), gbox) for s in ("left", "right", "top", "bottom")}
                # which side each excess pixel lies on (left/right strips first, then top/bottom)
                side_cnt = {}
                for s, sm in (("left", xx < gx0), ("right", xx >= gx1), ("top", (yy < gy0) & (xx >= gx0) & (xx < gx1)),
                              ("bottom", (yy >= gy1) & (xx >= gx0) & (xx < gx1))):
                    side_cnt[s] = [int(v) for v in np.bincount(cat[sm & out].ravel(), minlength=5)]
                row["side_excess"] = side_cnt
            rows.append(row)
    frames = sorted(gt)
    nf = len(frames)
    e = mete(gt, pred, frames=frames)
    print(f"{args.scenario} {args.seed}: METE {e['METE']:.4f}, {len(rows)} pairs")
    summary = summarise(rows, nf)
    summary.update(scenario=args.scenario, seed=args.seed, METE=float(e["METE"]), params=args.params)
    print_summary(summary)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(summary=summary, rows=rows)) + "\n")
    return 0


def _ratio(b, g):
    return (b[2] * b[3]) / max(g[2] * g[3], 1e-9)


def summarise(rows, nf):
    """The figures of one sequence (IoU losses in METE units: sum of ``w (1 - IoU)`` over ``nf``)."""
    s = dict(nf=nf)
    loss = lambda sel: float(sum(r["w"] * (1 - r["iou"]) for r in sel) / nf)  # noqa: E731
    big = [r for r in rows if _ratio(r["rep"], r["gt"]) > 1.5]
    small = [r for r in rows if _ratio(r["rep"], r["gt"]) < 1 / 1.5]
    low = [r for r in rows if r["iou"] < 0.3]
    s["loss_all"], s["loss_big"], s["loss_small"], s["loss_low"] = loss(rows), loss(big), loss(small), loss(low)
    # the stage that made a too-large box too large: the core already (features outside the boat),
    # the growing (plain grown box), the cuts (grown with cuts larger than plain?), the merge of parts
    st = {"core_big": [], "pre_big": [], "grow_big": [], "merge": [], "none": [], "unknown": []}
    for r in big:
        if "core" not in r:
            st["unknown"].append(r)
            continue
        g = r["gt"]
        if _ratio(r["core"], g) > 1.0 and (r["core"][2] > 1.2 * g[2] or r["core"][3] > 1.2 * g[3]):
            st["core_big"].append(r)
        elif _ratio(r["pre"], g) > 1.5:
            st["pre_big"].append(r)
        elif _ratio(r["plain"], g) > 1.5 or _ratio(r["grown"], g) > 1.5:
            st["grow_big"].append(r)
        else:
            st["none"].append(r)
    s["big_by_stage"] = {k: loss(v) for k, v in st.items()}
    s["big_multi_part"] = loss([r for r in big if r.get("nparts", 1) > 1])
    # what the too-large boxes' excess pixels are (sampled frames only), weighted by the pair's loss
    ex = np.zeros(5)
    side_gain = {k: 0.0 for k in ("left", "right", "top", "bottom")}
    side_cat = {k: np.zeros(5) for k in side_gain}
    nsamp = 0
    for r in big:
        if "excess" not in r:
            continue
        nsamp += 1
        c = np.asarray(r["excess"], float)
        if c.sum() > 0:
            ex += r["w"] * (1 - r["iou"]) * c / c.sum()
        for k in side_gain:
            side_gain[k] += r["w"] * (r["side_iou"][k] - r["iou"])
            sc = np.asarray(r["side_excess"][k], float)
            side_cat[k] += sc
    tot = sum(r["w"] * (1 - r["iou"]) for r in big if "excess" in r)
    s["big_sampled_pairs"] = nsamp
    s["big_excess_share"] = {c: float(ex[i] / tot) if tot else 0.0 for i, c in enumerate(CATS)}
    s["big_side_gain_share"] = {k: float(v / tot) if tot else 0.0 for k, v in side_gain.items()}
    s["big_side_pixels"] = {k: {c: int(v[i]) for i, c in enumerate(CATS)} for k, v in side_cat.items()}
    # low-IoU pairs: the same content split
    ex = np.zeros(5)
    tot = 0.0
    for r in low:
        if "excess" in r:
            c = np.asarray(r["excess"], float)
            tot += r["w"] * (1 - r["iou"])
            if c.sum() > 0:
                ex += r["w"] * (1 - r["iou"]) * c / c.sum()
    s["low_excess_share"] = {c: float(ex[i] / tot) if tot else 0.0 for i, c in enumerate(CATS)}
    # IoU of each stage's box with the boat, median over all pairs and over the too-large ones
    for key in ("core", "pre", "plain", "grown"):
        v = [_iou(r[key], r["gt"]) for r in rows if key in r]
        vb = [_iou(r[key], r["gt"]) for r in big if key in r]
        s[f"iou_{key}"] = float(np.median(v)) if v else float("nan")
        s[f"iou_{key}_big"] = float(np.median(vb)) if vb else float("nan")
    s["iou_rep"] = float(np.median([r["iou"] for r in rows])) if rows else float("nan")
    # loss if every pair had its stage's box instead (same pairs, same weights)
    for key in ("core", "pre", "plain"):
        s[f"loss_if_{key}"] = float(sum(r["w"] * (1 - (_iou(r[key], r["gt"]) if key in r else r["iou"]))
                                        for r in rows) / nf)
    # temporal: per boat the log area ratio's median and spread; the too-large loss on boats whose
    # median is too large (consistent) vs boats whose median is fine (a few frames)
    by_boat = {}
    for r in rows:
        by_boat.setdefault(r["boat"], []).append(r)
    cons, trans = 0.0, 0.0
    per_boat = {}
    for b, rs in by_boat.items():
        lr = np.log([_ratio(r["rep"], r["gt"]) for r in rs])
        med = float(np.median(lr))
        mad = float(np.median(np.abs(lr - med)))
        lb = sum(r["w"] * (1 - r["iou"]) for r in rs if _ratio(r["rep"], r["gt"]) > 1.5) / nf
        if med > np.log(1.5):
            cons += lb
        else:
            trans += lb
        per_boat[int(b)] = dict(n=len(rs), med_ratio=float(np.exp(med)), mad_log=mad,
                                frac_big=float(np.mean(lr > np.log(1.5))), loss=float(sum(r["w"] * (1 - r["iou"]) for r in rs) / nf),
                                loss_big=float(lb), med_iou=float(np.median([r["iou"] for r in rs])))
    s["big_consistent"], s["big_transient"] = float(cons), float(trans)
    s["per_boat"] = per_boat
    return s


def print_summary(s):
    print(f"IoU loss: all {s['loss_all']:.4f}, too large (>1.5) {s['loss_big']:.4f}, too small {s['loss_small']:.4f}, "
          f"IoU<0.3 {s['loss_low']:.4f}")
    print("too-large loss by the stage that made it: " + ", ".join(f"{k} {v:.4f}" for k, v in s["big_by_stage"].items())
          + f"; of it in reports of several clusters {s['big_multi_part']:.4f}")
    print(f"too-large pairs' excess pixels ({s['big_sampled_pairs']} sampled pairs, loss-weighted shares): "
          + ", ".join(f"{k} {v:.2f}" for k, v in s["big_excess_share"].items()))
    print("too-large: IoU gained by clipping one side (share of their loss): "
          + ", ".join(f"{k} {v:.2f}" for k, v in s["big_side_gain_share"].items()))
    for k, v in s["big_side_pixels"].items():
        print(f"   {k:6s} pixels: " + ", ".join(f"{c} {n}" for c, n in v.items()))
    print("IoU<0.3 pairs' excess pixels: " + ", ".join(f"{k} {v:.2f}" for k, v in s["low_excess_share"].items()))
    print(f"median IoU with the boat: core {s['iou_core']:.2f}, pre-grow {s['iou_pre']:.2f}, grown without cuts "
          f"{s['iou_plain']:.2f}, grown {s['iou_grown']:.2f}, report {s['iou_rep']:.2f}; too-large pairs: core "
          f"{s['iou_core_big']:.2f}, pre {s['iou_pre_big']:.2f}, plain {s['iou_plain_big']:.2f}, grown {s['iou_grown_big']:.2f}")
    print(f"IoU loss with the same pairs' boxes replaced by: core {s['loss_if_core']:.4f}, pre-grow {s['loss_if_pre']:.4f}, "
          f"grown without cuts {s['loss_if_plain']:.4f} (report {s['loss_all']:.4f})")
    print(f"too-large loss on boats whose median box is too large {s['big_consistent']:.4f}, on the others "
          f"{s['big_transient']:.4f}")
    print("boat   n  med area ratio  MAD(log)  frac>1.5  loss  loss>1.5  med IoU")
    for b, p in sorted(s["per_boat"].items()):
        print(f"{b:4d} {p['n']:4d}  {p['med_ratio']:6.2f}  {p['mad_log']:8.2f}  {p['frac_big']:8.2f}  {p['loss']:.4f}  "
              f"{p['loss_big']:.4f}  {p['med_iou']:.2f}")


if __name__ == "__main__":
    sys.exit(main())
