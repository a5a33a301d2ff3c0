"""Why each identity switch happens (issue #8, session 20): every CLEAR-MOT identity switch of the
stage on one simulator sequence, classified by cause from the clusterer's own state.

Replays the stage (with ``--cache``, on the extractor snapshots that ``sf_diagnose.py --cache``
records), records in every frame each cluster's reported identity (tentative ones included), the
lost identities (``FeatureClusterer._lost``), the hand-overs and the coasts, and counts the
switches as ``sf_diagnose.py --switches`` does (IoU >= 0.3, a boat keeps its last identity while
that one still matches).  Each switch ``old -> new`` on boat ``g`` gets one cause, the first that
applies:

* ``coast took the boat``: ``new`` is a coasted identity (state COASTING) at the switch;
* ``old coasting, live one won``: ``old`` is coasted now and a live cluster under ``new`` took the boat;
* ``old on another boat``: ``old`` is reported now on another boat (IoU >= 0.3 with it);
* ``two reports on the boat``: ``old`` is reported now, on this boat too, but ``new`` matched better
  (the boat is reported twice: fragments reported apart);
* ``old on no boat``: ``old`` is reported now on no boat (drifted to wake, coast, sea);
* ``new from another boat``: ``new`` was last matched to another boat (a report took the wrong
  boat's identity);
* ``not relinked: born before the loss``: ``old`` is lost, and the cluster under ``new`` was born
  while ``old`` was still reported (the relink gives lost identities only to clusters born after
  the loss; a hand-over needs an overlap of ``relink_overlap``);
* ``not relinked: too far``: ``new``'s cluster was born after the loss, but lay outside the
  relink gate from the lost box (the gap and the gate are printed);
* ``not relinked: appearance``: in the gate, refused by the appearance check;
* ``not relinked: taken by another``: in the gate, but another lost identity was paired with it;
* ``old forgotten``: ``old`` is neither reported nor lost (lost longer than ``relink_s``, or
  retired by a hand-over);
* ``back to an earlier identity of the boat``: ``new`` was matched to this boat before (checked
  before the relink causes);
* ``other``.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_ids_diag.py pan 1 --cache /tmp/s18h2/cache
"""
from __future__ import annotations

import collections
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, clear_matches, replay_parser, replay_setup  # noqa: E402


def _gap(b, lb):
    g = np.maximum(np.abs((b[:2] + 0.5 * b[2:]) - (lb[:2] + 0.5 * lb[2:])) - 0.5 * (b[2:] + lb[2:]), 0.0)
    return float(np.hypot(*g))


def main(argv=None) -> int:
    ap = replay_parser("sf_ids_diag.py", __doc__, cache_required=False)
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the counts")
    ap.add_argument("--quiet", action="store_true", help="print only the counts")
    ap.add_argument("--trace", default="", metavar="IDS",
                    help="comma-separated identities: print each frame's state of each (reported, its cluster and box; "
                         "lost, since when and the box expected)")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_ids_diag")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    from seawatch.eval import box_iou
    from seawatch.types import TrackState

    c = trk.clusterer
    p = c.params
    rec: dict = {}  # per frame: reported id -> (cluster id, box), lost id -> (time lost, box), hand-overs
    cur: dict = {}
    orig_relink, orig_hand = c._relink, c._hand_over

    def relink(snap, cids, boxes, vel=None):
        known = set(c._known)
        rep = orig_relink(snap, cids, boxes, vel)
        cur["rep"] = {int(r): (int(cids[i]), boxes[i].copy(), int(cids[i]) not in known) for i, r in enumerate(rep)}
        cur["lost"] = {int(k): (float(v[0]), np.asarray(v[1], float).copy()) for k, v in c._lost.items()}
        cur["zoom"] = c._zoom
        return rep

    def hand_over(k, cids, boxes, rep, now, own):
        r = orig_hand(k, cids, boxes, rep, now, own)
        if r is not None:
            cur.setdefault("hand", []).append((int(k), int(r)))
        return r

    c._relink, c._hand_over = relink, hand_over
    gt, pred = {}, {}
    for i, (f, g) in enumerate(scn.iter_frames()):
        cur.clear()
        tr = _process(trk, f, None if recorded is None else recorded[i], None)
        vis = g.visible > 0
        gt[f.index] = (g.ids[vis], g.boxes[vis])
        pred[f.index] = (tr.ids.copy(), tr.boxes.copy(), tr.states.copy())
        cur["t"] = f.t_s
        cur["refused"] = {(int(e[1]), int(e[2])) for e in c.relink_log if e[0] == f.t_s and e[6]}
        rec[f.index] = dict(cur)
    frames = sorted(gt)
    fps = scn.fps
    for tid in [int(x) for x in args.trace.split(",") if x.strip()]:
        for k in frames:
            r = rec[k]
            pi, pb, ps = pred[k]
            gi, gb = gt[k]
            s_ = "-"
            if tid in r.get("rep", {}):
                cid, bx, _ = r["rep"][tid]
                s_ = f"cluster {cid} box {np.round(bx).astype(int).tolist()}"
            elif tid in r.get("lost", {}):
                tl, bx = r["lost"][tid]
                s_ = f"lost {r['t'] - tl:.1f} s, expected {np.round(bx).astype(int).tolist()}"
            if tid in set(pi.tolist()):
                j = pi.tolist().index(tid)
                io = box_iou(gb, pb[j:j + 1])[:, 0] if len(gb) else np.zeros(0)
                on = f" on boat {int(gi[io.argmax()])} IoU {io.max():.2f}" if len(io) and io.max() > 0 else " on no boat"
                s_ += f" REPORTED state {int(ps[j])}{on}"
            print(f"  trace {tid} {r['t']:6.1f} s: {s_}" + (f" hand-overs {r['hand']}" if r.get("hand") else ""))
    kinds = {v.id: v.type for v in scn.vessels}
    birth_f: dict = {}  # reported id -> first frame it was a cluster's identity (tentative included)
    cluster_f: dict = {}  # cluster id -> first frame it was seen
    for k in frames:
        for r, v in rec[k].get("rep", {}).items():
            birth_f.setdefault(r, k)
            cluster_f.setdefault(v[0], k)
    covered: dict = {}
    causes = collections.Counter()
    rows = []
    for k, a, b, g, r, prev in clear_matches(gt, pred, frames):
        gi, gb = gt[k]
        pi, pb, ps = pred[k]
        if prev is not None and prev[0] != r:
            old, kf = prev
            cause, extra = classify(old, r, a, b, g, k, kf, gi, gb, pi, pb, ps, rec, birth_f, covered, p,
                                    TrackState, box_iou, frames, cluster_f)
            causes[cause] += 1
            rows.append(dict(t=k / fps, boat=g, kind=kinds[g], old=old, new=r, cause=cause, extra=extra))
        covered[r] = g
    if not args.quiet:
        for w in rows:
            print(f"  {w['t']:6.1f} s boat {w['boat']:3d} ({w['kind']}): {w['old']} -> {w['new']}: {w['cause']}"
                  + (f" ({w['extra']})" if w['extra'] else ""))
    print(f"{args.scenario} seed {args.seed}: {len(rows)} switches")
    for k_, v in causes.most_common():
        print(f"  {k_:40s} {v}")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(scenario=args.scenario, seed=args.seed, causes=dict(causes),
                                     rows=[{**w, "extra": str(w["extra"])} for w in rows])) + "\n")
    return 0


def _via(ident, k, rec, frames, back=30):
    """How identity ``ident`` came onto the cluster that carries it in frame ``k``: a hand-over, a
    relink, or the same cluster all along (within the last ``back`` frames)."""
    cid = rec[k].get("rep", {}).get(ident, (None,))[0]
    lo = frames.index(k)
    for q in reversed(frames[max(0, lo - back):lo + 1]):
        r = rec[q]
        if any(h[0] == ident for h in r.get("hand", [])):
            return f"handed over {r['t']:.1f} s"
        v = r.get("rep", {}).get(ident)
        if v is not None and v[0] != ident and v[2]:
            return f"relinked {r['t']:.1f} s to new cluster {v[0]}"
        if v is not None and v[0] != cid:
            return f"cluster {v[0]} then {cid}"
    return f"same cluster {cid}"


def classify(old, new, a, b, g, k, kf, gi, gb, pi, pb, ps, rec, birth_f, covered, p, TrackState, box_iou, frames,
             cluster_f):
    coasting = ps == int(TrackState.COASTING)
    if coasting[b]:
        return "coast took the boat", f"old last matched {k - kf} frames ago"
    ids = [int(x) for x in pi]
    if old in ids:
        j = ids.index(old)
        io = box_iou(gb, pb[j:j + 1])[:, 0]
        if coasting[j]:
            return "old coasting, live one won", f"old IoU {io[a]:.2f}"
        a2 = int(np.argmax(io))
        if a2 != a and io[a2] >= 0.3:
            return "old on another boat", f"on boat {int(gi[a2])}; {_via(old, k, rec, frames)}"
        if io[a] > 0:
            return "two reports on the boat", f"old IoU {io[a]:.2f}"
        return "old on no boat", f"max IoU {io.max():.2f}"
    before = covered.get(new)
    if before is not None and before != g:
        return "new from another boat", f"before on boat {before}; {_via(new, k, rec, frames)}"
    r = rec[k]
    if before == g:
        return "back to an earlier identity of the boat", ""
    if old in r.get("lost", {}):
        tl = r["lost"][old][0]
        cid = r["rep"][new][0] if new in r.get("rep", {}) else None
        cb = cluster_f.get(cid, k)
        tb = rec[cb]["t"]
        fl = next((q for q in frames if rec[q]["t"] >= tl - 1e-9), k)
        if tb < tl - 1e-9:
            # the cluster existed when old was lost: the hand-over's overlap at the loss
            nb = rec[fl].get("rep", {})
            box = next((v[1] for v in nb.values() if v[0] == cid), None)
            ob = rec[fl].get("lost", {}).get(old)
            if box is None or ob is None:
                return "not relinked: born before the loss", f"cluster born {tl - tb:.2f} s before; not seen at the loss"
            lb = ob[1]
            iw = min(box[0] + box[2], lb[0] + lb[2]) - max(box[0], lb[0])
            ih = min(box[1] + box[3], lb[1] + lb[3]) - max(box[1], lb[1])
            sm = min(box[2] * box[3], lb[2] * lb[3])
            o = iw * ih / sm if iw > 0 and ih > 0 and sm > 0 else 0.0
            own = new == cid
            return ("not relinked: born before the loss",
                    f"cluster born {tl - tb:.2f} s before; overlap at the loss {o:.2f}, gap {_gap(box, lb):.0f} px, "
                    f"{'own identity' if own else 'carries a relinked identity'}")
        lb = rec[cb].get("lost", {}).get(old)
        nb = rec[cb].get("rep", {}).get(new)
        if lb is None or nb is None:
            return "other", "old not lost at the new cluster's birth"
        d = _gap(nb[1], lb[1])
        gate = p.relink_px + p.relink_px_per_s * (tb - tl) * rec[cb].get("zoom", 1.0)
        if (old, nb[0]) in rec[cb].get("refused", set()):
            return "not relinked: appearance", f"gap {d:.0f} px, gate {gate:.0f}"
        if d > gate:
            return "not relinked: too far", f"gap {d:.0f} px, gate {gate:.0f} px, lost {tb - tl:.1f} s"
        return "not relinked: taken by another", f"gap {d:.0f} px, gate {gate:.0f}"
    return "old forgotten", ""


if __name__ == "__main__":
    sys.exit(main())
