"""Where a simulator sequence's METE goes (issue #8): the bench's parts split once more, per cause.

Runs (or, with ``--cache``, replays on recorded extractor snapshots exactly as ``sf_diagnose.py
--cache`` does, the same cache files) the default stage on one simulator scenario and splits each
frame's METE ``(sum over matched pairs of (1 - IoU) + max(n, m) - matched) / max(n, m)`` (pairs of
METE's own largest-total-IoU assignment) into additive parts that sum to the mean METE:

* accuracy (the matched pairs' IoU loss), split into ``acc_merged`` (the matched report also
  covers half or more of another boat in view: two boats in one report) and ``acc_other``;
* cardinality in frames with ``n >= m`` (the bench's "missed boats"), each unmatched boat charged
  to the first that applies:
  ``merged`` (half or more of its box lies in a report matched to another boat: two boats in one
  report), ``never`` (the boat is matched in no frame of the sequence), ``late`` (a frame before
  the boat's first matched frame), ``lost`` (a frame after it: dropped or gaps; also split by the
  length of the run of unmatched in-view frames it lies in);
* cardinality in frames with ``m > n`` (the bench's "reports beyond the boats' count"), each
  unmatched report charged to ``clutter`` (IoU < 0.1 with every boat in view) or ``on_boat``
  (overlaps a boat: a second report on it, a fragment).

Every part is also given on the boat-frames of boats that move <= 1.5 px/s relative to the scene
(``slow``: the boats that the oracle of ``bench_stable_features.py`` also misses), and the
sequence's oracle METE (perfect boxes on exactly the boats moving > 1.5 px/s) is printed.  Per
boat it prints how long after coming into view it was first matched (``late`` delays).

A missed boat in a frame that also has an unmatched report on clutter is charged to the missed
boat (with ``n >= m`` removing the clutter report would not lower that frame's METE, reporting the
boat would); ``clutter_subst`` counts the METE of such frames' unmatched boats as a side figure.
The parts follow ``sf_diagnose.py --breakdown`` (IoU loss + missed + beyond the count); METE's own
accuracy term (``seawatch.eval.mete``) also holds the ``min(n, m) - matched`` assigned pairs that
do not overlap (cost 1 each), which the parts count as missed boats: ``unpaired`` gives that amount,
so METE's accuracy = ``acc_merged + acc_other + unpaired`` and its cardinality = the other parts
minus ``unpaired``.

Example (the 12 tuning sequences, one JSON line each)::

    for s in pan ir; do for k in 1 2 5 6 7 8; do
      .venv/bin/python benchmarks/sf_mete_parts.py $s $k --cache /tmp/s18h2/cache --json parts.jsonl
    done; done
    .venv/bin/python benchmarks/sf_mete_parts.py --summary parts.jsonl

``--params '{"field": value}'`` (session 23) replays with those ``ClusterParams`` fields (the cached
snapshots are the default extractor's, so no ``"ext"``). The evaluation seeds 0, 3 and 4 are refused.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np

PARTS = ("acc_merged", "acc_other", "merged", "never", "late", "lost", "clutter", "on_boat")


def _cover(gb, pb):
    """Fraction of each boat box (rows) lying inside each report box (columns)."""
    x0 = np.maximum(gb[:, None, 0], pb[None, :, 0])
    y0 = np.maximum(gb[:, None, 1], pb[None, :, 1])
    x1 = np.minimum(gb[:, None, 0] + gb[:, None, 2], pb[None, :, 0] + pb[None, :, 2])
    y1 = np.minimum(gb[:, None, 1] + gb[:, None, 3], pb[None, :, 1] + pb[None, :, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    return inter / np.maximum(gb[:, 2] * gb[:, 3], 1e-9)[:, None]


def _slow_ids(scn, i, ids, floor):
    """Ids (of ``ids``, boats in view at frame ``i``) moving <= ``floor`` px/s relative to the scene,
    measured as ``bench_stable_features._moving_bound`` does."""
    cam = scn.camera_at(i)
    t = scn.time_s(i)
    s0, s1 = scn.world.states(t), scn.world.states(t + 0.1)
    row = {v.id: k for k, v in enumerate(scn.vessels)}
    out = set()
    for vid in ids:
        k = row[int(vid)]
        u0 = np.asarray(cam.enu_to_pixel(s0[k, 0], s0[k, 1], 0.0), float).ravel()[:2]
        u1 = np.asarray(cam.enu_to_pixel(s1[k, 0], s1[k, 1], 0.0), float).ravel()[:2]
        if not np.hypot(*(u1 - u0)) / 0.1 > floor:
            out.add(int(vid))
    return out


def summary(path) -> int:
    """Means over the JSON lines in ``path`` (one per sequence): METE, the bench's split, the oracle,
    and each part on all boats, on the slow ones and on the moving ones (with clutter), as a share
    of the gap to 0.4 and (the moving part) of the gap to the oracle."""
    rows = [json.loads(line) for line in open(path) if line.strip()]
    mean = {k: float(np.mean([r[k] for r in rows])) for k in ("METE", "accuracy", "cardinality", "oracle",
                                                               "unpaired", "clutter_subst", "late_ge3s")}
    print(f"{len(rows)} sequences: " + ", ".join(f"{k} {v:.4f}" for k, v in mean.items()))
    g4, go = mean["METE"] - 0.4, mean["METE"] - mean["oracle"]
    print(f"gap to 0.4 {g4:.4f}, to the oracle {go:.4f}")
    print("part         all     slow    moving  /gap-0.4  moving/gap-oracle")
    for p in PARTS:
        a = float(np.mean([r["parts"][p] for r in rows]))
        b = float(np.mean([r["parts_slow"][p] for r in rows]))
        print(f"{p:11s}  {a:.4f}  {b:.4f}  {a - b:.4f}  {a / g4:8.2f}  {(a - b) / go:8.2f}")
    for k in ("acc_other_by_iou", "acc_other_by_area", "lost_by_run_s"):
        print(k, " ".join(f"{x:.4f}" for x in np.mean([r[k] for r in rows], axis=0)))
    d = [v for r in rows for v in r["delays_s"].values() if v is not None]
    nv = sum(v is None for r in rows for v in r["delays_s"].values())
    print(f"first-match delays: {len(d)} boats, median {np.median(d):.1f} s, max {max(d):.1f} s, "
          f">= 3 s {sum(x >= 3.0 for x in d)}; never matched {nv}")
    return 0


def main(argv=None) -> int:
    if argv is None:
        argv = sys.argv[1:]
    if len(argv) == 2 and argv[0] == "--summary":
        return summary(argv[1])
    ap = argparse.ArgumentParser(prog="sf_mete_parts.py", description=__doc__.split("\n\n")[0],
                                 epilog="sf_mete_parts.py --summary FILE: the means over FILE's JSON lines")
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--cache", default=None, metavar="DIR", help="sf_diagnose.py's snapshot cache (same keys)")
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the parts")
    ap.add_argument("--params", default="{}", help="ClusterParams fields as a JSON object (default {}: the defaults; "
                                                   "no \"ext\": the snapshots are the default extractor's)")
    args = ap.parse_args(argv)
    from sf_diagnose import EVAL_SEEDS, parse_params  # this folder is on the path as a script

    if args.seed in EVAL_SEEDS:
        print(f"sf_mete_parts.py: seed {args.seed} is an evaluation seed", file=sys.stderr)
        return 2
    kw = parse_params(args.params, "sf_mete_parts.py")
    if kw is None or "ext" in kw:
        if kw is not None:
            print("sf_mete_parts.py: --params takes ClusterParams fields only (no \"ext\")", file=sys.stderr)
        return 2
    import cv2

    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.eval import mete
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker
    from sf_diagnose import _process, mete_pairs, snapshot_cache  # this folder is on the path as a script

    cv2.setNumThreads(1)
    scn = make_scenario(args.scenario, seed=args.seed)
    trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), ClusterParams(**kw), camera=scn.camera,
                               horizon="camera")
    recorded, record, cache_path = None, None, None
    if args.cache:  # sf_diagnose.py's key with no extractor --params and no --duration-s
        cache_path, recorded = snapshot_cache(args.cache, args.scenario, args.seed, None, {}, "camera")
        if recorded is None:
            record = []
            print(f"no snapshots under this key yet: recording {cache_path}")
    floor = trk.clusterer.params.min_speed_px_s
    gt, pred, slow = {}, {}, {}
    for f, g in scn.iter_frames():
        vis = g.visible > 0
        gt[f.index] = (g.ids[vis], g.boxes[vis])
        if recorded is None and record is None:
            _, tr = trk.process(f)
        else:
            tr = _process(trk, f, None if recorded is None else recorded[len(pred)], record)
        pred[f.index] = (tr.ids, tr.boxes)
        slow[f.index] = _slow_ids(scn, f.index, g.ids[vis], floor)
    if record is not None:
        os.makedirs(args.cache, exist_ok=True)
        part = f"{cache_path}.{os.getpid()}.part"
        with open(part, "wb") as fh:
            pickle.dump(record, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(part, cache_path)
    frames = sorted(gt)
    nf = len(frames)
    e = mete(gt, pred, frames=frames)

    # pass 1: METE's pairs per frame, each boat's first matched frame and first frame in view
    pairs, first_match, first_seen = {}, {}, {}
    for k in frames:
        gi, gb = gt[k]
        pi, pb = pred[k]
        for v in gi:
            first_seen.setdefault(int(v), k)
        if len(gi) and len(pi):
            rr, cc, iou = mete_pairs(gb, pb)
            pairs[k] = (rr, cc, iou)
            for a in rr:
                first_match.setdefault(int(gi[a]), k)
        else:
            pairs[k] = (np.zeros(0, int), np.zeros(0, int), np.zeros((len(gi), len(pi))))

    # each boat's runs of in-view frames without a match after its first match: (boat, frame) -> run length
    runs = {}
    for v in first_match:
        seq = [(k, v in set(int(gt[k][0][a]) for a in pairs[k][0])) for k in frames
               if k >= first_match[v] and v in set(int(x) for x in gt[k][0])]
        cur = []
        for k, ok in seq + [(None, True)]:
            if ok:
                for kk in cur:
                    runs[(v, kk)] = len(cur) / scn.fps
                cur = []
            else:
                cur.append(k)
    lost_gap = np.zeros(3)  # lost by the length of the run it is in: < 1 s, 1-5 s, >= 5 s
    late_boat = {}  # boat -> its late part (sum over frames)
    tot = {p: 0.0 for p in PARTS}
    tot_slow = {p: 0.0 for p in PARTS}
    clutter_subst = 0.0
    unpaired = 0.0  # min(n, m) - overlapping pairs: METE's accuracy term counts these, the parts cardinality
    oracle = 0.0
    acc_band = np.zeros(3)  # acc_other by the pair's IoU: < 0.3, 0.3-0.7, >= 0.7
    acc_size = np.zeros(3)  # acc_other by report area / boat area: > 1.5, < 1 / 1.5, between
    for k in frames:
        gi, gb = gt[k]
        pi, pb = pred[k]
        n, m = len(gi), len(pi)
        if n:
            oracle += len(slow[k]) / n
        if max(n, m) == 0:
            continue
        den = float(max(n, m))
        rr, cc, iou = pairs[k]
        cov = _cover(gb, pb) if n and m else np.zeros((n, m))
        rep_of = {int(b): int(a) for a, b in zip(rr, cc)}  # report column -> matched boat row
        for a, b in zip(rr, cc):
            other = [j for j in range(n) if j != a and cov[j, b] >= 0.5]
            part = "acc_merged" if other else "acc_other"
            w = (1.0 - iou[a, b]) / den
            tot[part] += w
            if int(gi[a]) in slow[k]:
                tot_slow[part] += w
            if part == "acc_other":
                q = iou[a, b]
                area = pb[b, 2] * pb[b, 3] / max(gb[a, 2] * gb[a, 3], 1e-9)
                acc_band[0 if q < 0.3 else 1 if q < 0.7 else 2] += w
                acc_size[0 if area > 1.5 else 1 if area < 1 / 1.5 else 2] += w
        matched = np.zeros(n, bool)
        matched[rr] = True
        unpaired += (min(n, m) - matched.sum()) / den
        if n >= m:
            has_clutter = m > 0 and n > 0 and bool(((iou.max(axis=0) < 0.1) & ~np.isin(np.arange(m), cc)).any())
            for a in np.flatnonzero(~matched):
                v = int(gi[a])
                if any(cov[a, b] >= 0.5 and b in rep_of for b in range(m)):
                    part = "merged"
                elif v not in first_match:
                    part = "never"
                elif k < first_match[v]:
                    part = "late"
                    late_boat[v] = late_boat.get(v, 0.0) + 1.0 / den
                else:
                    part = "lost"
                    g = runs.get((v, k), 0.0)
                    lost_gap[0 if g < 1.0 else 1 if g < 5.0 else 2] += 1.0 / den
                tot[part] += 1.0 / den
                if v in slow[k]:
                    tot_slow[part] += 1.0 / den
                if has_clutter:
                    clutter_subst += 1.0 / den
        else:
            for b in np.setdiff1d(np.arange(m), cc):
                part = "clutter" if (n == 0 or iou[:, b].max() < 0.1) else "on_boat"
                tot[part] += 1.0 / den
    out = {p: tot[p] / nf for p in PARTS}
    out_slow = {p: tot_slow[p] / nf for p in PARTS}
    acc = out["acc_merged"] + out["acc_other"]
    card = sum(out[p] for p in PARTS[2:])
    print(f"{args.scenario} seed {args.seed}: {nf} frames; METE {e['METE']:.4f} (accuracy {e['METE_accuracy']:.4f} + "
          f"cardinality {e['METE_cardinality']:.4f}); parts sum {acc + card:.4f} (accuracy {acc:.4f} + "
          f"cardinality {card:.4f}); oracle {oracle / nf:.4f}")
    print("part         METE    of it on slow boats")
    for p in PARTS:
        print(f"{p:11s}  {out[p]:.4f}  {out_slow[p]:.4f}")
    print(f"acc_other by the pair's IoU: < 0.3 {acc_band[0] / nf:.4f}, 0.3-0.7 {acc_band[1] / nf:.4f}, "
          f">= 0.7 {acc_band[2] / nf:.4f}; by report area / boat area: > 1.5 {acc_size[0] / nf:.4f}, "
          f"< 1/1.5 {acc_size[1] / nf:.4f}, between {acc_size[2] / nf:.4f}")
    print(f"lost by the length of the unmatched run (in view) it lies in: < 1 s {lost_gap[0] / nf:.4f}, "
          f"1-5 s {lost_gap[1] / nf:.4f}, >= 5 s {lost_gap[2] / nf:.4f}")
    print(f"missed boats in frames that also have an unmatched report on clutter: {clutter_subst / nf:.4f}")
    print(f"assigned pairs without overlap (METE's accuracy term counts them as 1 each, the parts above as "
          f"missed boats): {unpaired / nf:.4f}; accuracy {acc:.4f} + {unpaired / nf:.4f} = {acc + unpaired / nf:.4f}")
    print("boat  in view from  first matched  delay_s  matched frames / frames in view")
    delays = {}
    for v in sorted(first_seen):
        nv = sum(int(v in set(int(x) for x in gt[k][0])) for k in frames)
        nm = sum(int(v in set(int(gt[k][0][a]) for a in pairs[k][0])) for k in frames)
        fm = first_match.get(v)
        d = None if fm is None else (fm - first_seen[v]) / scn.fps
        delays[v] = d
        print(f"{v:4d}  {first_seen[v] / scn.fps:8.1f} s  "
              f"{'never' if fm is None else f'{fm / scn.fps:8.1f} s':>13s}  "
              f"{'-' if d is None else f'{d:7.1f}':>7s}  {nm:4d} / {nv:4d}")
    long_late = sum(w for v, w in late_boat.items() if delays.get(v) is not None and delays[v] >= 3.0)
    print(f"late part of the boats first matched 3 s or more after coming into view: {long_late / nf:.4f} "
          f"(of {out['late']:.4f})")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(scenario=args.scenario, seed=args.seed, params=kw, frames=nf, fps=scn.fps,
                                     METE=e["METE"], accuracy=e["METE_accuracy"],
                                     cardinality=e["METE_cardinality"], oracle=oracle / nf, parts=out,
                                     parts_slow=out_slow, clutter_subst=clutter_subst / nf,
                                     unpaired=unpaired / nf, acc_other_by_iou=(acc_band / nf).tolist(),
                                     acc_other_by_area=(acc_size / nf).tolist(),
                                     lost_by_run_s=(lost_gap / nf).tolist(), late_ge3s=long_late / nf,
                                     delays_s={str(v): d for v, d in delays.items()})) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
