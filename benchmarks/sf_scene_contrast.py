"""How faint each boat of a simulator sequence is (issue #8, session 23): no tracker is run.

For every ``--every``-th frame the sequence is rendered twice, with and without its vessels (same
sea, sky, coast and noise), and each vessel's contrast is the mean absolute grey-level difference
between the two renderings over its exact mask (``Scenario.label_image``). The script prints, per
seed, each vessel's median contrast and median mask area (pixels) over the frames where it is in
view, and the sum of the contrasts of the vessels named by ``--faint-ids`` (on ``pan``: the
motorboat 3, the sailboat 4 and the rib 7, the three small boats whose faintness goes with a high
METE; see docs/stable_features_log.md, "Session 23: why seed 0 is hard on `pan`").

Only the scene is rendered, so the evaluation seeds are allowed: this reads the inputs, not the
stage's output. With ``--mete FILE`` (one or more ``sf_tuneset.py`` outputs), the seeds found there
are paired with their METE and the Spearman correlation between the sum and the METE is printed.

Example::

    python benchmarks/sf_scene_contrast.py pan --seeds 0,1,2,5,6,7,8 --mete /tmp/ts_defaults.txt
"""
from __future__ import annotations

import argparse
import re
import sys

import cv2
import numpy as np


def _grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float64) if image.ndim == 3 else image.astype(np.float64)


def vessel_contrast(scn, every: int = 10) -> dict[int, tuple[float, float]]:
    """``vessel id -> (median contrast, median mask area)`` over every ``every``-th frame."""
    per: dict[int, list[tuple[float, int]]] = {}
    for i in range(0, len(scn), int(every)):
        image = _grey(scn.render(i).image)
        diff = np.abs(image - _grey(scn.render_empty(i)))
        labels = scn.label_image(i)
        ids, inv, area = np.unique(labels.ravel(), return_inverse=True, return_counts=True)
        sums = np.bincount(inv, weights=diff.ravel(), minlength=len(ids))
        for k, v in enumerate(ids):
            if v != 0:
                per.setdefault(int(v), []).append((float(sums[k] / area[k]), int(area[k])))
    return {v: (float(np.median([c for c, _ in rows])), float(np.median([a for _, a in rows])))
            for v, rows in sorted(per.items())}


def read_mete(paths) -> dict[int, float]:
    """``seed -> METE`` from ``sf_tuneset.py`` output lines (``" pan 1     0.3680 ..."``)."""
    out: dict[int, float] = {}
    line = re.compile(r"^\s*\w+\s+(\d+)\s+([0-9.]+)\s")
    for path in paths or ():
        with open(path) as fh:
            for text in fh:
                m = line.match(text)
                if m:
                    out[int(m.group(1))] = float(m.group(2))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="sf_scene_contrast.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("scenario", help="simulator scenario (pan, ir, ...)")
    ap.add_argument("--seeds", required=True, help="comma-separated seeds, e.g. 0,1,2 or 25-64")
    ap.add_argument("--every", type=int, default=10, help="every n-th frame (default 10)")
    ap.add_argument("--faint-ids", default="3,4,7", help="vessel ids whose contrasts are summed (default 3,4,7)")
    ap.add_argument("--mete", nargs="*", default=None, metavar="FILE",
                    help="sf_tuneset.py outputs: correlate the sum with their METE (same scenario)")
    args = ap.parse_args(argv)
    from seawatch.sim import make_scenario  # after --help

    seeds: list[int] = []
    for part in args.seeds.split(","):
        a, _, b = part.partition("-")
        seeds += list(range(int(a), int(b) + 1)) if b else [int(a)]
    faint = [int(v) for v in args.faint_ids.split(",") if v]
    sums: dict[int, float] = {}
    for seed in seeds:
        per = vessel_contrast(make_scenario(args.scenario, seed=seed), args.every)
        sums[seed] = float(sum(per[v][0] for v in faint if v in per))
        cells = " ".join(f"{v}:{c:.0f}/{a:.0f}" for v, (c, a) in per.items())
        print(f"{args.scenario} {seed:3d} sum{''.join(map(str, faint))} {sums[seed]:5.0f} | id:contrast/px {cells}",
              flush=True)
    mete = read_mete(args.mete)
    both = [s for s in seeds if s in mete]
    if len(both) >= 3:
        from scipy.stats import spearmanr

        r = spearmanr([sums[s] for s in both], [mete[s] for s in both])
        print(f"Spearman rho (sum vs METE) over {len(both)} seeds: {r.correlation:.2f} (p {r.pvalue:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
