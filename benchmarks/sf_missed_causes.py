"""Why the stable-feature tracker (paper B) misses boats: each missed boat-frame charged to its cause.

Runs the stage as ``sf_diagnose.py`` does (``StableFeatureTracker`` with the scenario's camera
model) with the extractor instrumented, and charges every missed boat-frame (a boat left
unmatched by the METE assignment, weighted as ``sf_diagnose.py --breakdown`` weights it, so that
the column sums to its "missed boats" figure) to the first cause that applies:

* ``no_kp``: no CenSurE keypoint inside the boat's box at all (size, contrast, threshold);
* ``not_sel``: keypoints detected there but none kept by the keypoint budget (``select_keypoints``);
* ``no_cand``: kept keypoints, none with an active feature expected near it (guided search);
* ``ratio``: candidates, but every keypoint failed the ratio test ``Q >= min_q``;
* ``gate``: some passed the ratio test, none matched after one-per-feature and the velocity gate;
* ``unstable``: matched, but fewer than two stable features inside the box;
* ``unclustered``: two or more stable features in the box, none in a cluster (clusterer's side);
* ``unreported``: clustered, but no report on this boat (clusterer's side).

It also prints, over every kept keypoint inside a boat box in every frame (missed or not), what
became of it, and for the ratio-test failures how far the nearest and the second-nearest
candidates' expected positions lie apart, and how many would pass if the second neighbour had
to lie more than X px from the nearest (``ratio_distinct_px``).

Example::

    .venv/bin/python benchmarks/sf_missed_causes.py ir 1
    .venv/bin/python benchmarks/sf_missed_causes.py pan 2 --params '{"ext": {"ratio_distinct_px": 4}}'
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

CAUSES = ("no_kp", "not_sel", "no_cand", "ratio", "gate", "unstable", "unclustered", "unreported")
DISTINCT = (0.0, 2.0, 3.0, 4.0, 6.0, 8.0)


def _inside(xy, b, pad=0.0):
    return ((xy[:, 0] >= b[0] - pad) & (xy[:, 0] <= b[0] + b[2] + pad)
            & (xy[:, 1] >= b[1] - pad) & (xy[:, 1] <= b[1] + b[3] + pad))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="sf_missed_causes.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--params", default="{}", help="as sf_diagnose.py: ClusterParams fields plus \"ext\": {...}")
    ap.add_argument("--duration-s", type=float, default=None)
    args = ap.parse_args(argv)
    kw = json.loads(args.params)
    import cv2

    import seawatch.detect.features as F
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker
    from sf_diagnose import mete_pairs  # this folder is on the path when run as a script

    cv2.setNumThreads(1)
    ext_kw = kw.pop("ext", {})
    horizon = kw.pop("horizon", "camera")
    scn = make_scenario(args.scenario, seed=args.seed, duration_s=args.duration_s)
    ext = F.StableFeatureExtractor(nominal_fps=scn.fps, **ext_kw)
    trk = StableFeatureTracker(ext, ClusterParams(**kw), camera=scn.camera, horizon=horizon)

    rec: dict = {}
    orig_select = F.select_keypoints
    orig_band = ext._describe_band
    orig_guided = ext._guided
    offset = [0.0]

    def select(xy, response, shape, max_keypoints, grid_cells=(8, 6), priority=None):
        keep = orig_select(xy, response, shape, max_keypoints, grid_cells, priority)
        rec.setdefault("detected", []).append(np.asarray(xy, float) + [0.0, offset[0]])
        return keep

    def band(grey, b, pred):
        offset[0] = float(b[0])
        try:
            return orig_band(grey, b, pred)
        finally:
            offset[0] = 0.0

    def guided(desc, act, kxy, radius_px):
        nn, dist = orig_guided(desc, act, kxy, radius_px)
        rec["guided"] = (desc, act.copy(), np.asarray(kxy).copy(), radius_px, nn.copy(), dist.copy(),
                         F._apply_h(ext._h_prev, ext._xy[act]), ext._desc[act].copy())
        return nn, dist

    F.select_keypoints = select
    ext._describe_band = band
    ext._guided = guided

    kinds = {v.id: v.type for v in scn.vessels}
    share = {c: 0.0 for c in CAUSES}
    per_boat: dict[int, dict] = {}
    fate = dict(kp=0, no_cand=0, ratio_fail=0, ratio_pass=0, matched=0)
    feat_fate: dict[int, dict] = {}
    fail_sep = []  # distance between the two nearest candidates' expected positions, ratio failures
    fail_q = []
    pass_distinct = np.zeros(len(DISTINCT))
    nf = 0
    for f, g in scn.iter_frames():
        rec.clear()
        _, tr = trk.process(f)
        snap = trk.last_snapshot
        labels = trk.clusterer.last_labels
        nf += 1
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis].astype(float)
        pi, pb = tr.ids, tr.boxes
        sc = ext._scale
        det = np.concatenate(rec.get("detected", [np.zeros((0, 2))])) if rec.get("detected") else np.zeros((0, 2))
        gd = rec.get("guided")
        min_q = ext.guided_min_quality if gd is not None else ext.min_quality
        if gd is not None:
            desc, act, kxy, radius, nn, dist, pred, adesc = gd
            q = F.match_quality(dist[:, 0], dist[:, 1])
        else:
            kxy = np.zeros((0, 2))
        # fate of each kept keypoint inside a boat box (working image), every frame
        for b in gb:
            bw = b * sc
            kin = np.flatnonzero(_inside(kxy, bw)) if len(kxy) else np.zeros(0, int)
            for k in kin:
                fate["kp"] += 1
                if nn[k, 0] < 0:
                    fate["no_cand"] += 1
                    continue
                if q[k] >= min_q:
                    fate["ratio_pass"] += 1
                    continue
                fate["ratio_fail"] += 1
                fail_q.append(q[k])
                a1 = nn[k, 0]
                if nn[k, 1] >= 0:
                    fail_sep.append(float(np.linalg.norm(pred[a1] - pred[nn[k, 1]])))
                # all candidates within the radius, and the second neighbour beyond X px of the first
                d_all = np.sum((adesc - desc[k]) ** 2, axis=1)
                near = np.flatnonzero(np.linalg.norm(pred - kxy[k], axis=1) <= radius)
                near = near[np.isfinite(d_all[near])]
                sep_all = np.linalg.norm(pred - pred[a1], axis=1)
                for j, x in enumerate(DISTINCT):
                    # the extractor compares the separation in working pixels: X source px times its scale
                    cand = near[(near != a1) & (sep_all[near] > x * sc)] if x > 0 else near[near != a1]
                    if len(cand):
                        d2 = d_all[cand].min()
                    else:  # the extractor's fallback: the nearest other active feature anywhere
                        far = (np.arange(len(d_all)) != a1) & ((sep_all > x * sc) if x > 0 else True)
                        d2 = d_all[far].min() if far.any() else np.inf
                    qq = F.match_quality(np.array([dist[k, 0]]), np.array([d2]))[0]
                    pass_distinct[j] += qq >= min_q
        # each active feature expected inside a boat box: matched, or why not
        if gd is not None and len(act):
            mslot = np.zeros(ext._cap, bool)
            mslot[snap.slots[snap.matched]] = True
            for v, b in zip(gi, gb):
                bw = b * sc
                ain = np.flatnonzero(_inside(pred, bw))
                if not len(ain):
                    continue
                fb = feat_fate.setdefault(int(v), dict(h=[], n=0, matched=0, no_kp=0, ratio=0, other=0, gate=0))
                fb["h"].append(b[3])
                for ai in ain:
                    fb["n"] += 1
                    if mslot[act[ai]]:
                        fb["matched"] += 1
                        continue
                    if not len(kxy):
                        fb["no_kp"] += 1
                        continue
                    dk = np.linalg.norm(kxy - pred[ai], axis=1)
                    near = np.flatnonzero(dk <= 3.0)
                    if not len(near):
                        fb["no_kp"] += 1
                    elif (nn[near, 0] == ai).any():
                        fb["ratio" if not (q[near][nn[near, 0] == ai] >= min_q).any() else "gate"] += 1
                    else:
                        fb["other"] += 1
        # missed boat-frames, weighted as METE's
        n, m = len(gi), len(pi)
        if max(n, m) == 0 or n < m:
            continue
        den = float(max(n, m))
        matched_gt = np.zeros(n, bool)
        if n and m:
            matched_gt[mete_pairs(gb, pb)[0]] = True
        sxy = snap.xy
        for a in np.flatnonzero(~matched_gt):
            b = gb[a]
            bw = b * sc
            st = per_boat.setdefault(int(gi[a]), dict(h=[], **{c: 0.0 for c in CAUSES}))
            st["h"].append(b[3])
            kin = np.flatnonzero(_inside(kxy, bw)) if len(kxy) else np.zeros(0, int)
            inb = _inside(sxy, b) if len(sxy) else np.zeros(0, bool)
            if len(kin) == 0:
                c = "not_sel" if (len(det) and _inside(det, bw).any()) else "no_kp"
            elif gd is None or not (nn[kin, 0] >= 0).any():
                c = "no_cand"
            elif not (q[kin] >= min_q).any():
                c = "ratio"
            elif not (snap.matched & inb).any():
                c = "gate"
            elif (snap.stable & inb).sum() < 2:
                c = "unstable"
            elif not (labels[snap.stable & inb] >= 0).any():
                c = "unclustered"
            else:
                c = "unreported"
            share[c] += 1.0 / den
            st[c] += 1.0 / den
    F.select_keypoints = orig_select
    tot = sum(share.values()) / nf
    print(f"{args.scenario} seed {args.seed}: {nf} frames; missed boats {tot:.3f} of METE, by cause:")
    print("  " + "  ".join(f"{c} {share[c] / nf:.3f}" for c in CAUSES))
    print("boat  type        h_px  " + "  ".join(f"{c:>11s}" for c in CAUSES))
    for v, st in sorted(per_boat.items()):
        print(f"{v:4d}  {kinds[v]:10s}  {np.median(st['h']):4.0f}  "
              + "  ".join(f"{st[c] / nf:11.3f}" for c in CAUSES))
    print("active features expected inside a boat's box, per frame: matched, or why not (no kept keypoint within "
          "3 px; the keypoint there chose it but failed the ratio test; passed but lost to the gate or to another "
          "keypoint; the keypoint there chose another feature)")
    print("boat  type        h_px  feat/frame  matched  no_kp  ratio  gate  other")
    for v, fb in sorted(feat_fate.items()):
        n = max(fb["n"], 1)
        print(f"{v:4d}  {kinds[v]:10s}  {np.median(fb['h']):4.0f}  {fb['n'] / max(len(fb['h']), 1):10.1f}  "
              f"{fb['matched'] / n:7.2f}  {fb['no_kp'] / n:5.2f}  {fb['ratio'] / n:5.2f}  {fb['gate'] / n:4.2f}  "
              f"{fb['other'] / n:5.2f}")
    k = max(fate["kp"], 1)
    print(f"kept keypoints inside boat boxes, all frames: {fate['kp']}; no candidate {fate['no_cand'] / k:.2f}, "
          f"ratio test failed {fate['ratio_fail'] / k:.2f}, passed {fate['ratio_pass'] / k:.2f}")
    if fail_q:
        sep = np.array(fail_sep)
        print(f"ratio failures: median Q {np.median(fail_q):.2f}; two nearest candidates' expected positions apart: "
              f"median {np.median(sep):.1f} px, <= 2 px {np.mean(sep <= 2):.2f}, <= 4 px {np.mean(sep <= 4):.2f}, "
              f"<= 8 px {np.mean(sep <= 8):.2f}")
        print("would pass with the second neighbour beyond X px of the nearest: "
              + ", ".join(f"X={x:g}: {p / len(fail_q):.2f}" for x, p in zip(DISTINCT, pass_distinct)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
