"""Which detector + tracker the demo runs: every fixed-camera combination on the ``harbour`` scene.

``seawatch demo`` runs one pipeline on the simulator's ``harbour`` scene (seed 0). This benchmark
runs each fixed-camera detector (the MOG2 baseline, Paper C's robust Kalman background model, Paper
A's cascade) with each tracker (the SORT baseline, Paper A's PTracking) end to end, AIS fusion
included, exactly as the demo does (``seawatch demo --seed S --set detector.kind=.. --set
tracker.kind=..``), and scores tracks (HOTA, MOTA, IDF1, IDSW), raw detections (F1) and fusion
(share of matched track frames with the correct MMSI) against the scene's exact ground truth.

The default is chosen on the *selection* seeds 2-4 (seed 1 is where the MOG2 and robust Kalman
defaults were tuned, seed 0 is the demo's) by the mean rank over four scores: HOTA, MOTA,
IDF1 and the share of matched track frames given the correct MMSI (the demo exists to show the
operator identities). This rule was adopted after a first run chose by HOTA alone and found MOG2+SORT
and robust Kalman+SORT level on HOTA (0.346 vs 0.337, within the spread over seeds) but far apart on
MOTA (-0.26 vs +0.06) and correct MMSI (70 % vs 86 %); see docs/pipeline.md. Seed 0, the demo's own
scene, is reported separately and is not used for the choice. ``--quick`` runs seeds 2-3 and the first 200
frames.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

NAME = "demo"
DESCRIPTION = "demo pipeline choice: detector x tracker end to end on harbour (select on seeds 2-4, report seed 0)"

DETECTORS = ["mog2", "robust_kalman", "cascade"]
TRACKERS = ["sort", "ptracking"]
SELECTION_SEEDS = [2, 3, 4]  # seed 1 is where the MOG2 and robust Kalman defaults were tuned
DEMO_SEED = 0
CHOICE_METRICS = ("HOTA", "MOTA", "IDF1", "mmsi_correct")


def _run_demo(seed: int, det: str, trk: str, frames: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="sw-demo-bench-") as tmp:
        cmd = [sys.executable, "-m", "seawatch", "demo", "--quiet", "--out", tmp, "--seed", str(seed),
               "--set", f"detector.kind={det}", "--set", f"tracker.kind={trk}", "--set", "output.video=false"]
        if frames:
            cmd += ["--frames", str(frames)]
        env = dict(os.environ, OMP_NUM_THREADS="1")
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-500:]}")
        summary = json.loads((Path(tmp) / "summary.json").read_text(encoding="utf-8"))
    ev = summary.get("evaluation") or {}
    tr, de, fu = ev.get("tracks", {}), ev.get("detections", {}), ev.get("fusion", {})
    alerts = summary.get("alerts")
    return {
        "HOTA": tr.get("HOTA", np.nan), "MOTA": tr.get("MOTA", np.nan), "IDF1": tr.get("IDF1", np.nan),
        "IDSW": tr.get("IDSW", np.nan), "det_F1": de.get("F1", np.nan),
        "mmsi_correct": fu.get("mmsi_correct", np.nan), "mmsi_wrong": fu.get("mmsi_wrong", np.nan),
        "alerts": float(alerts if isinstance(alerts, (int, float)) else len(alerts or [])),
        "fps": summary.get("processing_fps", np.nan),
    }


def run(ctx) -> None:
    seeds = SELECTION_SEEDS[:2] if ctx.quick else SELECTION_SEEDS
    frames = 200 if ctx.quick else 0
    means: dict[tuple[str, str], dict[str, float]] = {}
    for det in DETECTORS:
        for trk in TRACKERS:
            method = f"{det}+{trk}"
            rows = []
            for s in seeds:
                try:
                    rows.append(_run_demo(s, det, trk, frames))
                except RuntimeError as exc:
                    ctx.record("harbour", method, "not_run", float("nan"), "", reason=str(exc))
                    break
            if len(rows) != len(seeds):
                continue
            for metric in ("HOTA", "MOTA", "IDF1", "IDSW", "det_F1", "mmsi_correct", "mmsi_wrong"):
                vals = [r[metric] for r in rows]
                ctx.record(f"harbour seeds {seeds[0]}-{seeds[-1]}", method, metric, float(np.mean(vals)), "",
                           per_seed=[round(float(v), 4) for v in vals])
            means[(det, trk)] = {m: float(np.mean([r[m] for r in rows])) for m in CHOICE_METRICS}
    if not means:
        return
    combos = list(means)
    ranks = np.zeros(len(combos))
    for m in CHOICE_METRICS:  # rank 1 = best (all four: higher is better)
        vals = np.array([means[c][m] for c in combos])
        ranks += (-vals).argsort().argsort() + 1
    ranks /= len(CHOICE_METRICS)
    for c, rk in zip(combos, ranks):
        ctx.record(f"harbour seeds {seeds[0]}-{seeds[-1]}", f"{c[0]}+{c[1]}", "mean_rank", float(rk), "")
    best = combos[int(np.argmin(ranks))]
    ctx.record(f"harbour seeds {seeds[0]}-{seeds[-1]}", f"{best[0]}+{best[1]}", "chosen", float(ranks.min()),
               "mean rank", rule="mean rank over " + ", ".join(CHOICE_METRICS))
    # the demo's own scene, reported for every combination (never used for the choice)
    for (det, trk) in combos:
        r = _run_demo(DEMO_SEED, det, trk, frames)
        for metric in ("HOTA", "MOTA", "IDF1", "IDSW", "det_F1", "mmsi_correct", "mmsi_wrong", "alerts"):
            ctx.record(f"harbour seed {DEMO_SEED} (demo)", f"{det}+{trk}", metric, float(r[metric]), "")
