"""Why boats are found late (issue #8, session 23): each boat's frames in view before its first match.

Replays the stage on ``sf_diagnose.py``'s snapshot cache (``--cache``, the same keys) and, for each
boat and each frame where it is in view before METE first matches it (``late`` frames), prints where
its stable features lie and what rule could take them:

* ``n_st``: stable features inside the boat's box (padded by ``--pad`` px);
* ``dy``: their median row minus the horizon's row at their column (px, + is below the horizon),
  and the margin (``water_margin_px`` times the zoom) the still-object rule needs;
* ``v``: their median speed relative to the scene (the mean of each feature's velocity history,
  px/s) and the frame's speed floor (``min_speed_px_s`` as the clusterer applies it);
* ``mov``: how many have a velocity sample above the floor (the moving rule sees them);
* ``still``: how many lie under the margin (the still-object rule may take them);
* ``clu``: how many lie in a cluster; ``rep``: whether a report overlaps the boat at all;
* ``up``: stable features above the horizon within ``--cols`` px of the box's columns (a coast).

A summary per boat gives the late frames by cause: ``none`` (fewer than two stable features),
``margin`` (two or more, not moving, inside the margin), ``slow`` (two or more below the margin,
not moving: the still rule should take them), ``clustered`` (in a cluster, not matched).

Example::

    python benchmarks/sf_far_diag.py pan 1 --cache /tmp/s21/cache
    python benchmarks/sf_far_diag.py pan 1 --cache /tmp/s21/cache --boat 1 --every 5
"""

from __future__ import annotations

import sys
import warnings

import numpy as np


def main(argv=None) -> int:
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from sf_diagnose import _process, mete_pairs, replay_setup

    import argparse

    ap = argparse.ArgumentParser(prog="sf_far_diag.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--cache", required=True)
    ap.add_argument("--params", default="{}")
    ap.add_argument("--boat", type=int, default=None, help="print this boat's late frames one by one")
    ap.add_argument("--every", type=int, default=1, help="print every k-th frame of --boat")
    ap.add_argument("--pad", type=float, default=2.0)
    ap.add_argument("--cols", type=float, default=40.0)
    ap.add_argument("--all", action="store_true", help="with --boat: print its frames after the first match too")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_far_diag.py")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    p = trk.clusterer.params
    first_seen, first_match = {}, {}
    rows = []  # (boat, t, cause, record)
    for q, (f, g) in enumerate(scn.iter_frames()):
        tr = _process(trk, f, recorded[q], None)
        snap = trk.last_snapshot
        hz = trk.last_horizon
        zoom = trk.clusterer._zoom
        labels = trk.clusterer.last_labels
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis].astype(float)
        matched = set()
        if len(gi) and len(tr.ids):
            rr, cc, iou = mete_pairs(gb, tr.boxes)
            matched = {int(gi[a]) for a in rr}
        floor = trk.clusterer.min_speed_px_s
        st = snap.stable
        xy = snap.xy
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            vmean = np.nanmean(snap.history, axis=1)
            spd = np.hypot(snap.history[..., 0], snap.history[..., 1])
            moving = (spd >= floor).any(axis=1)
        row = np.asarray(hz.row_at(xy[:, 0]), float) if hz is not None and len(xy) else np.full(len(xy), np.nan)
        margin = p.water_margin_px * max(float(zoom), 1e-3)
        for a, v in enumerate(gi):
            v = int(v)
            first_seen.setdefault(v, f.t_s)
            if v in matched:
                first_match.setdefault(v, f.t_s)
            late = v not in first_match
            if not late and not (args.all and args.boat == v):
                continue
            b = gb[a]
            inb = st & (xy[:, 0] >= b[0] - args.pad) & (xy[:, 0] <= b[0] + b[2] + args.pad) \
                & (xy[:, 1] >= b[1] - args.pad) & (xy[:, 1] <= b[1] + b[3] + args.pad)
            k = np.flatnonzero(inb)
            dy = xy[k, 1] - row[k]
            sp = np.hypot(vmean[k, 0], vmean[k, 1])
            nmov = int(moving[k].sum())
            nstill = int((dy > margin).sum())
            nclu = int((labels[k] >= 0).sum()) if labels is not None and len(labels) else 0
            cb = b[0] + 0.5 * b[2]
            up = st & (row > xy[:, 1]) & (np.abs(xy[:, 0] - cb) <= 0.5 * b[2] + args.cols)
            rep = False
            if len(tr.boxes):
                pb = tr.boxes
                ix = np.minimum(pb[:, 0] + pb[:, 2], b[0] + b[2]) - np.maximum(pb[:, 0], b[0])
                iy = np.minimum(pb[:, 1] + pb[:, 3], b[1] + b[3]) - np.maximum(pb[:, 1], b[1])
                rep = bool(((ix > 0) & (iy > 0)).any())
            if len(k) < 2:
                cause = "none"
            elif nclu >= 2:
                cause = "clustered"
            elif nmov >= 2:
                cause = "moving_unclustered"
            elif nstill >= 2:
                cause = "slow"
            else:
                cause = "margin"
            bot_dy = b[1] + b[3] - float(hz.row_at(np.array([cb]))[0]) if hz is not None else np.nan
            rec = dict(t=round(f.t_s, 2), box=[round(x, 1) for x in b], zoom=round(float(zoom), 2),
                       n_st=len(k), dy=round(float(np.median(dy)), 1) if len(k) else None,
                       bot_dy=round(bot_dy, 1), margin=round(margin, 1),
                       v=round(float(np.nanmedian(sp)), 2) if len(k) and np.isfinite(sp).any() else None,
                       floor=round(float(np.max(floor)), 2), mov=nmov, still=nstill, clu=nclu, rep=rep,
                       up=int(up.sum()), cam_still=bool(trk.clusterer._cam_still))
            if late:
                rows.append((v, f.t_s, cause, rec))
            if args.boat == v and (q % args.every == 0):
                print(v, "LATE" if late else "    ", cause, rec)
    print(f"\n{args.scenario} {args.seed}: per boat, late frames (in view before the first match) by cause")
    fps = scn.fps
    for v in sorted(first_seen):
        rs = [r for r in rows if r[0] == v]
        fm = first_match.get(v)
        c = {}
        for r in rs:
            c[r[2]] = c.get(r[2], 0) + 1
        print(f"boat {v}: in view {first_seen[v]:.1f} s, first matched {'never' if fm is None else f'{fm:.1f} s'}, "
              f"late {len(rs) / fps:.1f} s: " + ", ".join(f"{k} {n / fps:.1f} s" for k, n in sorted(c.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
