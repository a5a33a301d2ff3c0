"""Render speed of ``pan`` (704x576) at two commits, measured in alternated pairs of processes.

On a shared machine the same code varies by tens of per cent between runs of ``seawatch bench
--only render``, more than a renderer change is worth.  This script exports each commit's
``seawatch`` package (``git archive``) into a scratch folder, then runs short child processes
that alternate between the two trees (``PYTHONPATH`` set to the tree, one thread, CPU time): in
each pair both commits render the same frames close together in time, so the ratio within a
pair is robust to the machine's load even when the absolute figures are not.  The order inside
a pair alternates (before first, then after first) so neither commit always runs second.

Every pair is written to the output JSON (default ``benchmarks/results/render_pairs.json``, the
latest run), with the per-commit medians and the within-pair ratios; commits are never pooled.
Each run is also appended as one line to the ``.jsonl`` beside it (the history of runs).

Usage (from the repository root)::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/render_pairs.py \\
        --before cf558dd --after 0bf906b --pairs 12

Not a ``bench_*`` module: it runs other commits' code, which the harness does not do.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# The child: the timing loop quoted in docs/simulator.md (Run 7), printing one JSON line.
CHILD = r"""
import json, sys, time, cv2, numba, numpy as np
from seawatch.sim import make_scenario
cv2.setNumThreads(1); numba.set_num_threads(1)
name, w, h, dur = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
scn = make_scenario(name, seed=0, width=w, height=h, duration_s=dur, fps=10.0)
scn.render(0)
cpu, wall = [], []
for i in range(scn.n_frames):
    t0, c0 = time.perf_counter(), time.process_time()
    scn.render(i)
    cpu.append(time.process_time() - c0); wall.append(time.perf_counter() - t0)
import seawatch
print(json.dumps({"cpu_ms": float(np.median(cpu) * 1e3), "wall_ms": float(np.median(wall) * 1e3),
                  "frames": int(scn.n_frames), "module": seawatch.__file__}))
"""


def _short(commit: str) -> str:
    out = subprocess.run(["git", "rev-parse", "--short=7", f"{commit}^{{commit}}"], cwd=ROOT,
                         check=True, capture_output=True, text=True)
    return out.stdout.strip()


def _export(commit: str, dest: Path) -> Path:
    """Extract ``seawatch/`` of ``commit`` into ``dest`` (no change to the repository's state)."""
    dest.mkdir(parents=True, exist_ok=True)
    tar_path = dest / "src.tar"
    with open(tar_path, "wb") as f:
        subprocess.run(["git", "archive", "--format=tar", commit, "seawatch"], cwd=ROOT, check=True,
                       stdout=f)
    with tarfile.open(tar_path) as t:
        t.extractall(dest, filter="data")
    tar_path.unlink()
    return dest


def _child(tree: Path, scenario: str, width: int, height: int, duration_s: float) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", CHILD, scenario, str(width), str(height),
                          str(duration_s)], cwd=tree, env=env, check=True, capture_output=True,
                         text=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    if not res["module"].startswith(str(tree)):
        raise RuntimeError(f"child imported seawatch from {res['module']}, not from {tree}")
    return res


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", default="cf558dd")
    p.add_argument("--after", default="0bf906b")
    p.add_argument("--pairs", type=int, default=12)
    p.add_argument("--scenario", default="pan")
    p.add_argument("--width", type=int, default=704)
    p.add_argument("--height", type=int, default=576)
    p.add_argument("--duration-s", type=float, default=45.0)
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "render_pairs.json")
    a = p.parse_args(argv)
    commits = {"before": _short(a.before), "after": _short(a.after)}
    with tempfile.TemporaryDirectory(prefix="render_pairs_") as tmp:
        trees = {k: _export(c, Path(tmp) / c) for k, c in commits.items()}
        for k in trees:  # warm-up: compile the Numba kernels into each tree's cache, not timed
            _child(trees[k], a.scenario, a.width, a.height, 2.0)
        pairs = []
        for i in range(a.pairs):
            order = ["before", "after"] if i % 2 == 0 else ["after", "before"]
            pair = {"pair": i, "order": [commits[k] for k in order],
                    "load_avg_1min": os.getloadavg()[0],
                    "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
            for k in order:
                r = _child(trees[k], a.scenario, a.width, a.height, a.duration_s)
                pair[k] = {"commit": commits[k], "cpu_ms": r["cpu_ms"], "wall_ms": r["wall_ms"],
                           "frames": r["frames"]}
            pair["ratio_cpu_after_over_before"] = pair["after"]["cpu_ms"] / pair["before"]["cpu_ms"]
            pairs.append(pair)
            print(f"pair {i}: before {pair['before']['cpu_ms']:.2f} ms, after "
                  f"{pair['after']['cpu_ms']:.2f} ms CPU (load {pair['load_avg_1min']:.2f})",
                  flush=True)

    def summary(k):
        ms = np.array([q[k]["cpu_ms"] for q in pairs])
        wall = np.array([q[k]["wall_ms"] for q in pairs])
        return {"commit": commits[k], "cpu_ms_median": float(np.median(ms)),
                "cpu_ms_min": float(ms.min()), "cpu_ms_max": float(ms.max()),
                "fps_cpu_median": float(1e3 / np.median(ms)), "fps_cpu_best": float(1e3 / ms.min()),
                "wall_ms_median": float(np.median(wall))}

    ratios = np.array([q["ratio_cpu_after_over_before"] for q in pairs])
    result = {
        "scenario": f"{a.scenario} {a.width}x{a.height}, {a.duration_s:g} s at 10 frames/s, seed 0",
        "command": ("OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/render_pairs.py "
                    f"--before {a.before} --after {a.after} --pairs {a.pairs}"),
        "time": pairs[0]["time"] if pairs else None,
        "measure": "per process: median over every frame of the CPU time of Scenario.render (one thread)",
        "before": summary("before"), "after": summary("after"),
        "ratio_cpu_after_over_before": {"median": float(np.median(ratios)), "min": float(ratios.min()),
                                        "max": float(ratios.max())},
        "pairs": pairs,
    }
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(result, indent=1) + "\n")
    with open(a.out.with_suffix(".jsonl"), "a") as f:  # every run, the latest also in ``a.out``
        f.write(json.dumps(result) + "\n")
    print(json.dumps({k: result[k] for k in ("before", "after", "ratio_cpu_after_over_before")}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
