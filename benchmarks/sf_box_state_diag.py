"""Each ground-truth boat's IoU loss split into live and coasted reports (issue #8, session 25, H14).

Usage: sf_box_state_diag.py SCENARIO SEED CACHE [PARAMS_JSON [BOAT]]: replays the clustering on
sf_diagnose.py's snapshot cache (CACHE) and prints per boat the pairs, loss, too-large (> 1.5 x area)
loss, the coasted pairs' share and the median area ratio; with BOAT, that boat's report every 6th frame.
Refuses the evaluation seeds 0, 3, 4."""
import os
import sys, json, numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cv2
cv2.setNumThreads(1)
import seawatch.track.feature_clusters as fc
from sf_diagnose import _process, mete_pairs, snapshot_cache
from seawatch.detect.features import StableFeatureExtractor
from seawatch.eval import mete
from seawatch.sim import make_scenario
scnname, seed, cache = sys.argv[1], int(sys.argv[2]), sys.argv[3]
kw = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
if seed in (0, 3, 4):
    sys.exit('evaluation seeds 0, 3, 4: refused')
scn = make_scenario(scnname, seed=seed)
trk = fc.StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), fc.ClusterParams(**kw), camera=scn.camera, horizon="camera")
_, rec = snapshot_cache(cache, scnname, seed, None, {}, "camera")
gt, pred = {}, {}
rows = []
for f, g in scn.iter_frames():
    vis = g.visible > 0
    gi, gb = g.ids[vis], g.boxes[vis]
    gt[f.index] = (gi, gb)
    tr = _process(trk, f, rec[len(pred)], None)
    pred[f.index] = (tr.ids, tr.boxes)
    if not len(gi) or not len(tr.ids):
        continue
    rr, cc, iou = mete_pairs(gb, tr.boxes)
    den = float(max(len(gi), len(tr.ids)))
    for a, b in zip(rr, cc):
        G, R = gb[a], tr.boxes[b]
        ratio = R[2] * R[3] / max(G[2] * G[3], 1e-9)
        rows.append((f.index, int(gi[a]), int(tr.states[b]), ratio, float(iou[a, b]), 1.0 / den,
                     float(tr.velocities[b][0]), [float(v) for v in G], [float(v) for v in R], int(tr.ids[b])))
nf = len(gt)
e = mete(gt, pred, frames=sorted(gt))
print(f"{scnname} {seed} METE {e['METE']:.4f} nf {nf}")
COAST = int(fc.TrackState.COASTING)
for boat in sorted(set(r[1] for r in rows)):
    rs = [r for r in rows if r[1] == boat]
    L = lambda s: sum(r[5] * (1 - r[4]) for r in s) / nf
    big = [r for r in rs if r[3] > 1.5]
    co = [r for r in rs if r[2] == COAST]
    print(f"boat {boat:2d} n {len(rs):3d} loss {L(rs):.4f} big {L(big):.4f} | coast n {len(co):3d} loss {L(co):.4f} big {L([r for r in co if r[3]>1.5]):.4f} medratio live {np.median([r[3] for r in rs if r[2]!=COAST] or [np.nan]):.2f} coast {np.median([r[3] for r in co] or [np.nan]):.2f} gtw {np.median([r[7][2] for r in rs]):.0f} gth {np.median([r[7][3] for r in rs]):.0f}")
if len(sys.argv) > 5:
    b = int(sys.argv[5])
    for r in rows:
        if r[1] == b and r[0] % 6 == 0:
            G, R = r[7], r[8]
            print(r[0], "coast" if r[2] == COAST else "live", f"ratio {r[3]:.2f} iou {r[4]:.2f} vx {r[6]:.1f} gt x {G[0]:.0f}-{G[0]+G[2]:.0f} y {G[1]:.0f}-{G[1]+G[3]:.0f} rep x {R[0]:.0f}-{R[0]+R[2]:.0f} y {R[1]:.0f}-{R[1]+R[3]:.0f}")
