"""How one graph cluster's report box is drawn, frame by frame (issue #8, session 30, h36): its members'
x, the box members (``_box_members``' choice, before ``box_anchor_far_h_ir``), their velocities relative to
the scene, the anchor (the cluster's box of the frame before and the members inside it), the box before and
after the growing, the jump limit, the size filter and the frame's reports.

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_box_members_trace.py ir 19 --cache CACHE \
        --params '{}' --cid 3 --window 2.5,3.1
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, replay_parser, replay_setup
import seawatch.track.feature_clusters as fc
ap = replay_parser("sf_box_members_trace.py", __doc__); ap.add_argument("--cid", type=int, required=True); ap.add_argument("--window", required=True)
a = ap.parse_args()
scn, trk, rec = replay_setup(a, "trace_box")
t0, t1 = (float(x) for x in a.window.split(","))
cl = trk.clusterer
S = {}
def R(b): return [int(round(v)) for v in np.asarray(b, float)]
o_bm = fc._box_members
def bm(k, fv, n, dv, anchor=None):
    r = o_bm(k, fv, n, dv, anchor); S['inb'] = r; S['k'] = k; S['fv'] = fv; S['anchor'] = anchor; return r
fc._box_members = bm
o_gb = fc.grow_boxes
def gb(img, boxes, cores, **kw):
    out = o_gb(img, boxes, cores, **kw)
    if 'pre' in S: return out
    S['pre'] = boxes.copy(); S['grown'] = out[0].copy(); S['found'] = out[2].copy(); S['hints'] = kw.get('hints'); return out
fc.grow_boxes = gb
o_lj = fc._limit_jump
def lj(box, pre, last, ratio):
    r = o_lj(box, pre, last, ratio); S.setdefault('lj', []).append((R(box), R(pre), R(last), R(r))); return r
fc._limit_jump = lj
o_sf = cl._size_filter
def sf(snap, cids, boxes, grown):
    S['bsf'] = boxes.copy(); r = o_sf(snap, cids, boxes, grown); S['asf'] = r.copy(); S['cids'] = cids.copy(); return r
cl._size_filter = sf
o_out = cl._outputs
def outp(snap, labels, cids, image=None):
    S.clear()
    t = float(snap.t_s)
    anc_before = dict(cl._cluster_boxes)
    d, tr = o_out(snap, labels, cids, image)
    if t0 <= t <= t1 and a.cid in cids.tolist():
        i = cids.tolist().index(a.cid)
        m = labels >= 0
        k = np.searchsorted(cids, labels[m]); xy = snap.xy[m]
        sel = k == i
        inb = S.get('inb')
        print(f"--- t {t:.2f} cid {a.cid} n {sel.sum()} x {np.sort(xy[sel,0]).astype(int).tolist()}")
        if inb is not None:
            print(f"   inb x {np.sort(xy[sel & inb,0]).astype(int).tolist()}")
        fv = S.get('fv')
        if fv is not None:
            print("   fv", [(int(x), round(float(v[0]),1), round(float(v[1]),1)) for x, v in sorted(zip(xy[sel,0], fv[sel]), key=lambda q: q[0])])
        print(f"   anchor(last box) {R(anc_before.get(a.cid, [np.nan]*4)) if a.cid in anc_before else None}; anchored x {None if S.get('anchor') is None else np.sort(xy[sel & S['anchor'],0]).astype(int).tolist()}")
        if 'pre' in S: print(f"   pre {R(S['pre'][i])} grown {R(S['grown'][i])} found {S['found'][i]} hint {None if S['hints'] is None else R(S['hints'][i]) if np.all(np.isfinite(S['hints'][i])) else None}")
        for q in S.get('lj', []): print("   limit_jump box,pre,last->", q)
        if 'bsf' in S: print(f"   size filter {R(S['bsf'][i])} -> {R(S['asf'][i])}")
        ids = tr.ids.tolist()
        print(f"   report ids {ids} boxes {[R(b) for b in tr.boxes]}")
    return d, tr
cl._outputs = outp
for k, (fr, _) in enumerate(scn.iter_frames()):
    if fr.t_s > t1: break
    _process(trk, fr, rec[k] if rec else None)
