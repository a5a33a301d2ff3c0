"""Trace how two identities' clusters join in the graph (issue #8, session 22, helper H3).

Replays the stage on one tuning sequence (``--cache``) and, in the frames of ``--window``, finds
every component of the gated links that holds features remembering both identities ``--ids A,B``
(the label memory); prints the shortest chain of links between them: each feature's remembered
identity, its velocity (px/s), the velocity of the established clusters, and the links' ends.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_graph_trace.py ir 5 --cache /tmp/s21/cache \
        --ids 3,22 --window 18.5,20
"""
from __future__ import annotations

import collections
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sf_diagnose import _process, replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_graph_trace.py", __doc__)
    ap.add_argument("--ids", required=True, help="two identities A,B")
    ap.add_argument("--window", default="0,1e9", help="t0,t1 (s)")
    ap.add_argument("--max-frames", type=int, default=6, help="print at most this many joined frames")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_graph_trace")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    a_id, b_id = (int(x) for x in args.ids.split(","))
    t0, t1 = (float(x) for x in args.window.split(","))
    g = trk.clusterer.graph
    orig_gate = g._velocity_gate
    cur = {}
    printed = [0]

    def gate(lab, vel, li, lj, t_s, max_dv, min_age_s):
        keep = orig_gate(lab, vel, li, lj, t_s, max_dv, min_age_s)
        if t0 <= t_s <= t1 and printed[0] < args.max_frames:
            _report(lab, vel, li[keep], lj[keep], t_s, g, a_id, b_id, printed)
        return keep

    g._velocity_gate = gate
    for k, (fr, _) in enumerate(scn.iter_frames()):
        if fr.t_s > t1:
            break
        _process(trk, fr, recorded[k] if recorded else None)
    return 0


def _report(lab, vel, li, lj, t_s, g, a_id, b_id, printed):
    if not ((lab == a_id).any() and (lab == b_id).any()):
        return
    m = len(lab)
    adj = collections.defaultdict(list)
    for i, j in zip(li.tolist(), lj.tolist()):
        adj[i].append(j)
        adj[j].append(i)
    src = np.flatnonzero(lab == a_id).tolist()
    prev = {s: -1 for s in src}
    dq = collections.deque(src)
    hit = -1
    while dq:
        u = dq.popleft()
        if lab[u] == b_id:
            hit = u
            break
        for v in adj[u]:
            if v not in prev:
                prev[v] = u
                dq.append(v)
    if hit < 0:
        return
    path = []
    u = hit
    while u >= 0:
        path.append(u)
        u = prev[u]
    path = path[::-1]
    fin = np.isfinite(vel).all(axis=1)
    means = {c: np.nanmean(vel[(lab == c) & fin], axis=0) if ((lab == c) & fin).any() else np.full(2, np.nan)
             for c in (a_id, b_id)}
    comp_a = set(src)
    print(f"t {t_s:.2f}: chain {a_id} -> {b_id}, {len(path) - 1} links; mean v {a_id} "
          f"({means[a_id][0]:.1f},{means[a_id][1]:.1f}) n={int((lab == a_id).sum())}, {b_id} "
          f"({means[b_id][0]:.1f},{means[b_id][1]:.1f}) n={int((lab == b_id).sum())}; "
          f"born {g.birth_s.get(a_id)}, {g.birth_s.get(b_id)}")
    for u in path:
        v = vel[u]
        d = {c: float(np.hypot(*(v - means[c]))) for c in (a_id, b_id)}
        print(f"   node {u}: label {int(lab[u])} v ({v[0]:.1f},{v[1]:.1f}) dv to {a_id} {d[a_id]:.1f}, to {b_id} "
              f"{d[b_id]:.1f}, degree {len(adj[u])}")
    del comp_a, m
    printed[0] += 1


if __name__ == "__main__":
    raise SystemExit(main())
