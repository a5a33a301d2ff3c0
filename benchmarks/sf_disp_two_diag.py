"""Where ``box_disp_two`` acts (issue #8, session 23, helper H2): every frame in which the rule
(``box_disp_s`` for a box of two members) leaves a member out of its cluster's box, with the two
members' positions, their displacements in the scene over ``box_disp_s``, their distance, whether
the member left out lies behind the kept one (against the kept one's displacement), and the
ground-truth boat (by the simulator's boxes grown by ``--tol`` px) each lies on.

Replays ``sf_diagnose.py``'s snapshot cache (tuning seeds only).  Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_disp_two_diag.py ir 8 --cache /tmp/s21/cache \
        --params '{"box_disp_two": true}'
"""
from __future__ import annotations

import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from sf_diagnose import replay_parser, replay_setup  # noqa: E402


def main(argv=None) -> int:
    ap = replay_parser("sf_disp_two_diag.py", __doc__)
    ap.add_argument("--tol", type=float, default=2.0)
    ap.add_argument("--quiet", action="store_true", help="only the summary")
    args = ap.parse_args(argv)
    setup = replay_setup(args, "sf_disp_two_diag")
    if setup is None:
        return 2
    scn, trk, recorded = setup
    import seawatch.track.feature_clusters as fc
    from sf_diagnose import _process

    seen = {}
    orig_disp = fc.FeatureClusterer._disp_members

    def disp_w(self, snap, m, k, n, inb):
        p = self.params
        keep = orig_disp(self, snap, m, k, n, inb)
        if not p.box_disp_two:
            return keep
        # the same displacement as the rule, to print it
        t0, s0, i0, p0 = self._disp_ring[0]
        c = self._disp_c
        xy = np.asarray(snap.xy, np.float64)
        hw = xy @ c[2, :2] + c[2, 2]
        sp = (xy @ c[:2, :2].T + c[:2, 2]) / hw[:, None]
        slots = np.asarray(snap.slots, np.int64)
        size = int(max(slots.max(initial=0), s0.max() if len(s0) else 0)) + 1
        old = np.full((size, 2), np.nan)
        old_id = np.full(size, -1, np.int64)
        old[s0] = p0
        old_id[s0] = i0
        d = sp - old[slots]
        d[old_id[slots] != np.asarray(snap.ids)] = np.nan
        dm = d[m]
        xym = xy[m]
        sel = np.ones(len(k), bool) if inb is None else inb
        okd = np.isfinite(dm).all(axis=1)
        for c_ in np.unique(k[sel & okd]):
            mem = np.flatnonzero((k == c_) & sel & okd)
            if len(mem) != 2 or keep[mem].all():
                continue
            out = mem[~keep[mem]][0]
            kin = mem[keep[mem]][0]
            dk = dm[kin]
            L = float(np.hypot(*dk))
            rel = xym[out] - xym[kin]
            behind = float(rel @ dk / max(L, 1e-9))
            seen.setdefault("ev", []).append(dict(
                kin=xym[kin].copy(), out=xym[out].copy(), Lk=L, Lo=float(np.hypot(*dm[out])),
                gap=float(np.hypot(*rel)), behind=behind, nclu=int((k == c_).sum())))
        return keep

    fc.FeatureClusterer._disp_members = disp_w
    rows = []
    for f, g in scn.iter_frames():
        seen.clear()
        _process(trk, f, recorded[f.index], None)
        vis = g.visible > 0
        gi, gb = g.ids[vis], g.boxes[vis]
        t = args.tol

        def boat(p):
            on = ((p[0] >= gb[:, 0] - t) & (p[0] <= gb[:, 0] + gb[:, 2] + t)
                  & (p[1] >= gb[:, 1] - t) & (p[1] <= gb[:, 1] + gb[:, 3] + t))
            return int(gi[np.flatnonzero(on)[0]]) if on.any() else -1

        for e in seen.get("ev", []):
            e.update(t=f.t_s, bk=boat(e["kin"]), bo=boat(e["out"]))
            rows.append(e)
            if not args.quiet:
                print(f"{f.t_s:6.2f} s kept ({e['kin'][0]:6.1f},{e['kin'][1]:6.1f}) boat {e['bk']:2d} moved "
                      f"{e['Lk']:5.1f} px | out ({e['out'][0]:6.1f},{e['out'][1]:6.1f}) boat {e['bo']:2d} moved "
                      f"{e['Lo']:5.1f} px | gap {e['gap']:5.1f} px, along {e['behind']:+6.1f} px; cluster of {e['nclu']}")
    print(f"{args.scenario} {args.seed}: {len(rows)} two-member exclusions")
    if rows:
        kb = np.array([r["bk"] for r in rows])
        ob = np.array([r["bo"] for r in rows])
        cls = {"kept on a boat, out off it": int(((kb >= 0) & (ob < 0)).sum()),
               "both on the same boat": int(((kb >= 0) & (ob == kb)).sum()),
               "kept off a boat, out on one": int(((kb < 0) & (ob >= 0)).sum()),
               "both off boats": int(((kb < 0) & (ob < 0)).sum()),
               "on two boats": int(((kb >= 0) & (ob >= 0) & (ob != kb)).sum())}
        for kx, v in cls.items():
            print(f"  {kx:30s} {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
