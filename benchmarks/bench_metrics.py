"""Scoring speed of the evaluation suite: 10,000 frames x 20 objects must score in under 5 s.

A synthetic sequence (seeded): 20 boats per frame moving linearly, predictions with position
noise, 8 % misses, false positives and occasional identity switches, given as the simple per-frame
dicts (``frame -> (ids, boxes)``) that other benchmarks pass.  Timed on one core (set
``OMP_NUM_THREADS=1``), median of the repeats:

* every image-track metric at once (``score_tracks`` + ``detection_metrics``), the issue's target;
* each metric alone;
* a peer in the same process: a textbook per-frame CLEAR MOT (IoU matrix, Hungarian assignment and
  dictionaries of previous matches, one frame at a time), against ``clear_mot``; both give the
  same MOTA, which is checked.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
from scipy.optimize import linear_sum_assignment

NAME = "metrics"
DESCRIPTION = "scoring speed: all metrics on 10,000 frames x 20 objects (target < 5 s), vs a per-frame peer"

TARGET_S = 5.0


def make_sequence(n_frames: int, n_objects: int = 20, seed: int = 0):
    """Ground truth and predictions as ``frame -> (ids, boxes)`` dicts."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(0, 1500, (n_objects, 2))
    vel = rng.normal(0, 0.5, (n_objects, 2))
    size = rng.uniform(20, 80, (n_objects, 2))
    pid = np.arange(n_objects) + 1000
    next_id = 2000
    gt, pred = {}, {}
    for t in range(n_frames):
        pos = (start + vel * t) % 1500
        boxes = np.c_[pos, size]
        gt[t] = (np.arange(n_objects), boxes)
        keep = rng.random(n_objects) > 0.08
        switch = rng.random(n_objects) < 0.0005
        pid[switch] = np.arange(next_id, next_id + switch.sum())
        next_id += int(switch.sum())
        noisy = boxes + rng.normal(0, 2.0, boxes.shape)
        n_fp = rng.poisson(1.0)
        fp = np.c_[rng.uniform(0, 1500, (n_fp, 2)), rng.uniform(20, 80, (n_fp, 2))]
        fp_ids = np.arange(next_id, next_id + n_fp)
        next_id += n_fp
        pred[t] = (np.r_[pid[keep], fp_ids], np.r_[noisy[keep], fp])
    return gt, pred


def naive_clear_mot(gt, pred, thr=0.5):
    """Peer: per-frame CLEAR MOT written the straightforward way (MOTChallenge rules)."""
    def iou(a, b):
        x1 = np.maximum(a[:, None, 0], b[None, :, 0])
        y1 = np.maximum(a[:, None, 1], b[None, :, 1])
        x2 = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2])
        y2 = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3])
        inter = np.clip(x2 - x1, 0, None) * np.clip(y2 - y1, 0, None)
        union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
        return inter / union

    last, prev = {}, {}
    tp = fp = fn = sw = 0
    n_gt = 0
    for t in sorted(set(gt) | set(pred)):
        gi, gb = gt.get(t, ((), np.zeros((0, 4))))
        pi, pb = pred.get(t, ((), np.zeros((0, 4))))
        n_gt += len(gi)
        if len(gi) == 0 or len(pi) == 0:
            fp += len(pi)
            fn += len(gi)
            continue
        s = iou(np.asarray(gb, float), np.asarray(pb, float))
        bonus = np.array([[1000.0 if prev.get(g) == p else 0.0 for p in pi] for g in gi])
        score = np.where(s >= thr, s + bonus, 0.0)
        r, c = linear_sum_assignment(-score)
        cur = {}
        for i, j in zip(r, c):
            if score[i, j] > 0:
                g, p = gi[i], pi[j]
                if g in last and last[g] != p:
                    sw += 1
                last[g] = p
                cur[g] = p
        prev = cur
        tp += len(cur)
        fp += len(pi) - len(cur)
        fn += len(gi) - len(cur)
    return (tp - fp - sw) / max(1, n_gt)


def _median_time(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def run(ctx) -> None:
    from seawatch.eval import (clear_mot, detection_metrics, hota, identity_metrics, melt, mete,
                               score_tracks)

    n_frames = 1000 if ctx.quick else 10_000
    repeats = 1 if ctx.quick else 3
    gt, pred = make_sequence(n_frames)
    ds = f"synthetic_{n_frames}x20"
    n_rows = sum(len(v[0]) for v in pred.values())
    detection_metrics({0: [[0, 0, 1, 1]]}, {0: [[0, 0, 1, 1]]})  # compile the Numba PR matcher

    def all_metrics():
        s = score_tracks(gt, pred)
        d = detection_metrics(gt, pred)
        return s, d

    t_all, (s, d) = _median_time(all_metrics, repeats)
    ctx.record(ds, "seawatch.eval", "s_all_metrics", t_all, "s", target=TARGET_S * n_frames / 10_000,
               note="score_tracks + detection_metrics, dict input", n_pred=n_rows)
    ctx.record(ds, "seawatch.eval", "ms_per_frame", 1000 * t_all / n_frames, "ms")
    for name, fn in [("detection", lambda: detection_metrics(gt, pred)),
                     ("clear_motchallenge", lambda: clear_mot(gt, pred)),
                     ("clear_vace", lambda: clear_mot(gt, pred, variant="vace")),
                     ("hota", lambda: hota(gt, pred)),
                     ("identity", lambda: identity_metrics(gt, pred)),
                     ("mete", lambda: mete(gt, pred)),
                     ("melt", lambda: melt(gt, pred))]:
        t, _ = _median_time(fn, repeats)
        ctx.record(ds, f"seawatch.eval.{name}", "s", t, "s")
    t_ours, c = _median_time(lambda: clear_mot(gt, pred), repeats)
    t_peer, mota_peer = _median_time(lambda: naive_clear_mot(gt, pred), repeats)
    if abs(mota_peer - c["MOTA"]) > 1e-9:
        raise AssertionError(f"peer MOTA {mota_peer} != clear_mot MOTA {c['MOTA']}")
    ctx.record(ds, "peer: per-frame CLEAR MOT", "s", t_peer, "s")
    ctx.record(ds, "seawatch.eval.clear_mot", "speedup_vs_peer", t_peer / t_ours, "x")
    for k in ("MOTA", "MOTP", "IDSW", "HOTA", "IDF1", "METE", "MELT"):
        ctx.record(ds, "seawatch.eval", k, s[k], "")
    ctx.record(ds, "seawatch.eval", "F1", d["F1"], "")
