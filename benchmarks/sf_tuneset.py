"""The tuning set of issue #8 in one command: mean METE and identity switches of the stage on the
simulator's ``pan`` and ``ir`` at the tuning seeds (1, 2, 5, 6, 7, 8 by default).

Runs ``sf_diagnose.py SCN SEED`` for every sequence (``--jobs`` at a time, each with one thread),
with the same ``--params`` and ``--cache`` and prints one line per sequence, the mean METE per
scenario and over all, and the total of identity switches (CLEAR-MOT at IoU 0.3, as
``sf_diagnose.py`` prints it).  The seeds 0, 3 and 4 and MarDCT video2 are evaluation sets: the
script refuses them unless ``--allow-eval`` is given (for a bench-like check that is not tuning).
Seeds 9-12 are the validation seeds (session 22): a candidate that passed on the tuning seeds is
checked there once (``--validation``); nothing is diagnosed on them.

Example::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/sf_tuneset.py --cache /tmp/s18h2/cache \\
        --params '{"coast_s": 2.0}' --json /tmp/coast2.json
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

HERE = os.path.dirname(os.path.abspath(__file__))
EVAL_SEEDS = {0, 3, 4}
VALIDATION_SEEDS = [9, 10, 11, 12]
LINE = re.compile(r"METE ([0-9.]+) \(accuracy ([0-9.]+) \+ cardinality ([0-9.]+)\) IDSW (\d+) MELT ([0-9.]+)")


def _parse(argv):
    ap = argparse.ArgumentParser(prog="sf_tuneset.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--params", default="{}", help="JSON object passed to sf_diagnose.py --params (default {})")
    ap.add_argument("--cache", default=None, metavar="DIR", help="sf_diagnose.py's snapshot cache directory")
    ap.add_argument("--scenarios", default="pan,ir", help="comma-separated scenarios (default pan,ir)")
    ap.add_argument("--seeds", default="1,2,5,6,7,8", help="comma-separated seeds (default the tuning seeds)")
    ap.add_argument("--validation", action="store_true", help="the validation seeds 9-12 instead of --seeds")
    ap.add_argument("--jobs", type=int, default=2, help="sequences run at once (default 2)")
    ap.add_argument("--json", default=None, metavar="FILE", help="append one JSON line with the results")
    ap.add_argument("--allow-eval", action="store_true", help="allow the evaluation seeds 0, 3, 4")
    return ap.parse_args(argv)


def run_one(scn: str, seed: int, params: str, cache: str | None) -> dict:
    cmd = [sys.executable, os.path.join(HERE, "sf_diagnose.py"), scn, str(seed), "--params", params]
    if cache:
        cmd += ["--cache", cache]
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    out = subprocess.run(cmd, capture_output=True, text=True, env=env)
    m = LINE.search(out.stdout)
    if out.returncode != 0 or m is None:
        raise RuntimeError(f"sf_diagnose.py {scn} {seed} failed (exit {out.returncode}): {out.stderr[-2000:]}")
    mete_, acc, card, idsw, melt_ = m.groups()
    return dict(scenario=scn, seed=seed, METE=float(mete_), accuracy=float(acc), cardinality=float(card),
                IDSW=int(idsw), MELT=float(melt_))


def main(argv=None) -> int:
    args = _parse(argv)
    try:
        json.loads(args.params)
        seeds = VALIDATION_SEEDS if args.validation else [int(s) for s in args.seeds.split(",") if s.strip()]
    except ValueError as exc:
        print(f"sf_tuneset: bad --params or --seeds: {exc}", file=sys.stderr)
        return 2
    if EVAL_SEEDS & set(seeds) and not args.allow_eval:
        print(f"sf_tuneset: seeds {sorted(EVAL_SEEDS & set(seeds))} are evaluation seeds (use --allow-eval "
              "only for a check that is not tuning)", file=sys.stderr)
        return 2
    jobs = [(s, k) for s in args.scenarios.split(",") for k in seeds]
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as ex:
        rows = list(ex.map(lambda j: run_one(j[0], j[1], args.params, args.cache), jobs))
    print(f"params {args.params}")
    print("sequence   METE   accuracy  cardinality  IDSW  MELT")
    for r in rows:
        print(f"{r['scenario']:>4s} {r['seed']:<4d}  {r['METE']:.4f}  {r['accuracy']:.3f}     {r['cardinality']:.3f}"
              f"        {r['IDSW']:3d}  {r['MELT']:.3f}")
    summary = {}
    for s in args.scenarios.split(","):
        sel = [r for r in rows if r["scenario"] == s]
        summary[s] = dict(METE=sum(r["METE"] for r in sel) / len(sel), IDSW=sum(r["IDSW"] for r in sel))
        print(f"{s}: mean METE {summary[s]['METE']:.4f}, IDSW {summary[s]['IDSW']}")
    mean = sum(r["METE"] for r in rows) / len(rows)
    idsw = sum(r["IDSW"] for r in rows)
    print(f"all {len(rows)}: mean METE {mean:.4f}, IDSW {idsw}")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps(dict(params=args.params, rows=rows, per_scenario=summary, METE=mean, IDSW=idsw)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
