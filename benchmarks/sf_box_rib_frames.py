"""One boat's report each frame next to its cluster's core, box before growing and grown box
(issue #8, session 25, H14), from the frame's FIRST grow_boxes call (the clusters'; the coast check
calls it later in the frame).

Usage: sf_box_rib_frames.py SCENARIO SEED CACHE PARAMS_JSON BOAT; ends with the boat's too-large loss
split by the growing's outcome (found / not found / no cluster box inside the report).
Refuses the evaluation seeds 0, 3, 4."""
import os
import sys, json, numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cv2
cv2.setNumThreads(1)
import seawatch.track.feature_clusters as fc
from sf_diagnose import _process, mete_pairs, snapshot_cache
from seawatch.detect.features import StableFeatureExtractor
from seawatch.sim import make_scenario
scnname, seed, cache, kw, boat = sys.argv[1], int(sys.argv[2]), sys.argv[3], json.loads(sys.argv[4]), int(sys.argv[5])
if seed in (0, 3, 4):
    sys.exit('evaluation seeds 0, 3, 4: refused')
scn = make_scenario(scnname, seed=seed)
trk = fc.StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), fc.ClusterParams(**kw), camera=scn.camera, horizon="camera")
_, rec = snapshot_cache(cache, scnname, seed, None, {}, "camera")
orig = fc.grow_boxes
calls = []
def wrapped(image, boxes, cores, **k2):
    res = orig(image, boxes, cores, **k2)
    calls.append((np.array(boxes, float).reshape(-1, 4), np.array(cores, float).reshape(-1, 4), res[0].copy(), res[2].copy() if len(res) > 2 else None, k2.get("trail")))
    return res
fc.grow_boxes = wrapped
n = 0; stat = {}
def s(b): return f"x {b[0]:.0f}-{b[0]+b[2]:.0f} y {b[1]:.0f}-{b[1]+b[3]:.0f}"
for f, g in scn.iter_frames():
    calls.clear()
    vis = g.visible > 0
    gi, gb = g.ids[vis], g.boxes[vis]
    tr = _process(trk, f, rec[n], None); n += 1
    if boat not in gi or not len(tr.ids):
        continue
    rr, cc, iou = mete_pairs(gb, tr.boxes)
    for a, b in zip(rr, cc):
        if gi[a] != boat: continue
        G, R = gb[a], tr.boxes[b]
        ratio = R[2]*R[3]/(G[2]*G[3])
        line = f"{f.index} st {tr.states[b]} ratio {ratio:.2f} iou {iou[a,b]:.2f} gt {s(G)} rep {s(R)}"
        kind = "none"
        if calls:
            pre, core, grown, found, trail = calls[0]
            ins = [i for i in range(len(grown)) if grown[i][0] >= R[0]-0.6 and grown[i][1] >= R[1]-0.6 and grown[i][0]+grown[i][2] <= R[0]+R[2]+0.6 and grown[i][1]+grown[i][3] <= R[1]+R[3]+0.6]
            for i in ins:
                line += f" | part{i} found {found[i]} trail {None if trail is None else trail[i]} core {s(core[i])} pre {s(pre[i])} grown {s(grown[i])}"
            kind = "nf" if ins and not any(found[i] for i in ins) else ("found" if ins else "none")
        if ratio > 1.5:
            L = (1 - iou[a, b]) / max(len(gi), len(tr.ids)) / 450
            stat[kind] = stat.get(kind, 0) + L
        print(line)
print("too-large loss by kind", stat)
