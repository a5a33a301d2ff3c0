"""The stable-feature tracker's relinks on one simulator scenario: which lost identities were given
to which new clusters, and whether the new cluster was on the same boat (session 18, issue #8).

Replays the clustering on the extractor's snapshots recorded by ``sf_diagnose.py --cache DIR``
(run that first with the same scenario, seed and no "ext"/"horizon" keys), with the relink's
appearance check on (``relink_appearance``) so that every pair it looks at is logged
(``FeatureClusterer.relink_log``); the default threshold here is 1e9, so nothing is refused and the
output is that of the check off.  A relink is *taken* when the cluster is reported under the lost
identity in that frame.  The lost identity's boat is the last boat its reports matched (IoU >= 0.3)
before the relink; the cluster's boat is the boat its box matches (IoU >= 0.3) in the relink's
frame; either may be none (clutter).  Prints mean METE, IDSW and the taken relinks by kind: right
(same boat), wrong (another boat), boat to clutter, clutter to boat, clutter to clutter; with
``--list`` each one with its appearance parts.  Uses only the simulator.  Example::

    .venv/bin/python benchmarks/sf_diagnose.py pan 1 --cache /tmp/sfc   # records the snapshots
    .venv/bin/python benchmarks/sf_relinks.py pan 1 --cache /tmp/sfc --list
    .venv/bin/python benchmarks/sf_relinks.py pan 1 --cache /tmp/sfc --params '{"relink_appearance_max": 1.2}'
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import pickle
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

KINDS = ("right", "wrong", "boat to clutter", "clutter to boat", "clutter to clutter")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="sf_relinks.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--cache", required=True, metavar="DIR", help="sf_diagnose.py's --cache folder (recorded)")
    ap.add_argument("--params", default="{}", help="JSON object of ClusterParams fields, over "
                    '{"relink_appearance": true, "relink_appearance_max": 1e9}')
    ap.add_argument("--list", action="store_true", help="print each taken relink")
    args = ap.parse_args(argv)
    import cv2

    import seawatch.detect.features as _features
    from sf_diagnose import _process
    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.eval import box_iou, clear_mot, mete
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker

    cv2.setNumThreads(1)
    kw = {"relink_appearance": True, "relink_appearance_max": 1e9}
    kw.update(json.loads(args.params))
    scn = make_scenario(args.scenario, seed=args.seed)
    with open(_features.__file__, "rb") as fh:  # the key of sf_diagnose.py's cache
        code = hashlib.sha1(fh.read()).hexdigest()
    key = json.dumps(["v2", args.scenario, args.seed, None, {}, "camera", code], sort_keys=True)
    path = os.path.join(args.cache, f"{args.scenario}_{args.seed}_{hashlib.sha1(key.encode()).hexdigest()[:12]}.pkl")
    if not os.path.exists(path):
        print(f"sf_relinks: no recording {path}: run sf_diagnose.py {args.scenario} {args.seed} --cache {args.cache}",
              file=sys.stderr)
        return 2
    with open(path, "rb") as fh:
        rec = pickle.load(fh)
    trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), ClusterParams(**kw),
                               camera=scn.camera, horizon="camera")
    gt, pred, frame_at = {}, {}, {}
    for f, g in scn.iter_frames():
        vis = g.visible > 0
        gt[f.index] = (g.ids[vis], g.boxes[vis])
        tr = _process(trk, f, rec[len(pred)])
        pred[f.index] = (tr.ids, tr.boxes)
        frame_at[round(f.t_s, 6)] = f.index
    frames = sorted(gt)
    e = mete(gt, pred, frames=frames)["METE"]
    idsw = clear_mot(gt, pred, iou=0.3, frames=frames)["IDSW"]
    last, before = {}, {}  # identity -> its last boat; frame -> that map at the frame's end
    for k in frames:
        gi, gb = gt[k]
        pi, pb = pred[k]
        if len(gi) and len(pi):
            iou = box_iou(pb, gb)
            for j, r in enumerate(pi):
                a = int(np.argmax(iou[j]))
                if iou[j, a] >= 0.3:
                    last[int(r)] = int(gi[a])
        before[k] = dict(last)
    count = dict.fromkeys(KINDS, 0)
    for t, k, cid, box, dc, dt, refused in trk.clusterer.relink_log:
        f = frame_at[round(t, 6)]
        pi, pb = pred[f]
        if not (len(pi) and np.any((pi == k) & np.all(np.abs(pb - box) < 1e-6, axis=1))):
            continue  # checked, not taken
        lost = before.get(f - 1, {}).get(k)
        gi, gb = gt[f]
        io = box_iou(box[None], gb)[0] if len(gi) else np.zeros(0)
        cand = int(gi[int(np.argmax(io))]) if len(io) and io.max() >= 0.3 else None
        kind = (("right" if lost == cand else "wrong") if lost is not None and cand is not None
                else "boat to clutter" if lost is not None else "clutter to boat" if cand is not None
                else "clutter to clutter")
        count[kind] += 1
        if args.list and kind != "clutter to clutter":
            print(f"  {t:6.1f} s  identity {k} (boat {lost}) -> cluster {cid} (boat {cand}, h {box[3]:.0f} px): {kind}; "
                  f"contrast part {dc:.2f}, template part {dt:.2f}")
    print(f"{args.scenario} seed {args.seed}: METE {e:.4f} IDSW {idsw}; relinks taken: "
          + ", ".join(f"{k} {v}" for k, v in count.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
