"""Why found boats are lost, per boat (issue #8, session 23, helper H5).

Replays the default stage (``--cache``: ``sf_diagnose.py``'s snapshots) on one simulator sequence
and charges each lost boat-frame (a boat in view, paired once before and not now, in frames with
``n >= m``; METE share ``1 / max(n, m)`` as ``sf_lost_causes.py``) to its boat and to what became
of the identity last paired with it (``elsewhere``, ``coast <outcome>``, ``not coasted``,
``retired``).  For each lost boat-frame it also tells what lay on the boat: ``cluster`` (a cluster
of this frame has a member inside the boat's true box) and, then, whether that cluster was left
out by the contrast check (``cut by min_contrast``: its grown core's contrast below
``min_contrast``); and it grows the coast's box from a core at the boat's true place (the middle
half of its true box) to say whether the coast's grow could have seen it there (``true found``)
and the core's contrast (peak / noise) and peak (grey levels) there.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_faint_lost.py pan 47 --cache /tmp/s23/cache_fresh
"""
from __future__ import annotations

import collections
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, mete_pairs, replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_faint_lost.py", __doc__, cache_required=False)
    ap.add_argument("--dump", type=int, default=None, metavar="BOAT",
                    help="print each lost frame of this boat: time, cause, true box, the identity's last coast box")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_faint_lost")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    from seawatch.track.feature_clusters import grow_boxes, to_grey_u8

    parts = collections.defaultdict(collections.Counter)  # boat -> cause -> METE
    frames_in = collections.Counter()
    frames_paired = collections.Counter()
    onb = collections.defaultdict(collections.Counter)  # boat -> what lay on it -> frames
    con = collections.defaultdict(list)  # boat -> (cause, true found, contrast, peak)
    ended: dict[int, str] = {}
    last_id: dict[int, int] = {}
    first: set = set()
    n_frames = 0
    c = trk.clusterer
    p = c.params
    for i, (f, g) in enumerate(scn.iter_frames()):
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
        for _, k, _, why in [e for e in c.coast_log if e[0] == f.t_s]:
            ended[k] = why
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        n, m = len(gi), len(tr)
        n_frames += 1
        rr, cc, _ = mete_pairs(gb, tr.boxes) if n and m else (np.zeros(0, int), np.zeros(0, int), None)
        paired = dict(zip(rr.tolist(), cc.tolist()))
        snap = trk.last_snapshot
        labels = c.last_labels
        img = None
        for j, vid in enumerate(gi.tolist()):
            frames_in[vid] += 1
            if j in paired:
                frames_paired[vid] += 1
                first.add(vid)
                last_id[vid] = int(tr.ids[paired[j]])
                continue
            if vid not in first or n < m:
                continue
            k = last_id[vid]
            w = 1.0 / max(n, m)
            if k in set(tr.ids.tolist()):
                cause = "elsewhere"
            elif k in c._lost:
                cause = (f"coast {ended[k]}" if k in ended and c._lost[k][0] <= max(
                    e[0] for e in c.coast_log if e[1] == k) else "not coasted")
            else:
                cause = "retired"
            parts[vid][cause] += w
            if args.dump == vid:
                lk = [e for e in c.coast_log if e[1] == k]
                eb = np.round(lk[-1][2], 1).tolist() if lk else None
                print(f"t {f.t_s:6.2f} id {k} {cause:16s} true {np.round(gb[j], 1).tolist()} coast box {eb} "
                      f"at t {lk[-1][0] if lk else None}")
            b = gb[j].astype(np.float64)
            xy = snap.xy
            inside = ((xy[:, 0] >= b[0]) & (xy[:, 0] <= b[0] + b[2]) & (xy[:, 1] >= b[1]) & (xy[:, 1] <= b[1] + b[3]))
            lab = labels[inside & (labels >= 0)] if labels is not None and len(labels) == len(xy) else np.zeros(0)
            what = "no cluster"
            if len(lab):
                what = "cluster"
                cids = np.unique(labels[labels >= 0])
                lc = c.last_contrast
                if lc is not None and len(lc) == len(cids):
                    cc_ = lc[np.searchsorted(cids, np.unique(lab))]
                    if np.all(cc_ < p.min_contrast):
                        what = "cluster cut by min_contrast"
            onb[vid][what] += 1
            if img is None:
                img = np.asarray(f.image)
                img = img if img.dtype == np.uint8 else to_grey_u8(img)
            core = np.array([b[0] + 0.25 * b[2], b[1] + 0.25 * b[3], 0.5 * b[2], 0.5 * b[3]])
            gr, ct, fd = grow_boxes(img, b[None], core[None], grow=max(p.grow_box, 0.5), peak_frac=p.grow_peak_frac,
                                    return_found=True, wide_grow_px=p.grow_wide_px, waterline_frac=p.waterline_frac,
                                    top_frac=c._top_frac)
            ratio = gr[0, 2] * gr[0, 3] / max(b[2] * b[3], 1e-9)
            con[vid].append((cause, bool(fd[0]), float(ct[0]), ratio, float(b[3])))
    print(f"{args.scenario} seed {args.seed}: lost METE by boat (frames in view / paired)")
    for vid in sorted(parts):
        tot = sum(parts[vid].values()) / n_frames
        print(f"  boat {vid}: lost {tot:.4f}  in view {frames_in[vid]}, paired {frames_paired[vid]}  on it: "
              f"{dict(onb[vid])}")
        for k, v in sorted(parts[vid].items(), key=lambda kv: -kv[1]):
            rows = [r for r in con[vid] if r[0] == k]
            fd = np.mean([r[1] for r in rows])
            ct = np.median([r[2] for r in rows])
            ra = np.median([r[3] for r in rows])
            hh = np.median([r[4] for r in rows])
            print(f"      {k:18s} {v / n_frames:.4f}  frames {len(rows):4d}  true found {fd:.2f}  "
                  f"contrast med {ct:.1f}  grown/true area med {ra:.2f}  h {hh:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
