"""Where the stable-feature tracker (paper B) loses METE on a simulator scenario, boat by boat.

Runs the stage as ``bench_stable_features`` builds it by default (``StableFeatureTracker`` with
the scenario's camera model, so with the water steps) over one simulator scenario and prints:

* mean METE (accuracy + cardinality), CLEAR MOT IDSW at IoU 0.3 and MELT;
* per boat: frames in view, median box height, the fraction of its frames in which a reported
  box has IoU > 0.3 with it ("found"), the mean IoU there, the median number of stable and of
  active features inside its box, and how many identities covered it;
* reported boxes that lie on no boat (IoU < 0.1 with every boat), per frame;
* mean METE per time segment, with the mean zoom;
* with ``--breakdown``, METE split into the matched boats' IoU loss, the missed boats and the
  reports beyond the boats' count, per boat and per segment, and the matched boxes' bias;
* with ``--switches``, every identity switch and where the identities came from.

``--cache DIR`` keeps each frame's feature snapshot (the extractor's output) in ``DIR`` the first
time a scenario, seed, length, ``"ext"``, ``"horizon"`` and extractor source
(``seawatch/detect/features.py``) are run, and later replays only the
clustering on them (the frames are rendered again; about 5 times faster).  The extractor knows
nothing of the clusterer, so a replay gives the clusterer exactly the input of a full run: use it to
compare ``ClusterParams`` variants, not extractor ones.

``--speed-pairs N`` instead times the default stage against the stage with ``--params`` (CPU
time, N alternating pairs, 250 frames at 640x480).

Uses only the simulator (no data under ``../shared``).  Tuning runs use seeds 1 and 2; the
bench reports seed 0.  Example::

    .venv/bin/python benchmarks/sf_diagnose.py pan 1
    .venv/bin/python benchmarks/sf_diagnose.py ir 2 --params '{"horizon": "off", "ext": {"guided_px": 0}}'
    .venv/bin/python benchmarks/sf_diagnose.py pan 0 --speed-pairs 4 --params '{"merge_keep": 0}'
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import pickle
import sys
import time

import numpy as np


def _parse(argv):
    ap = argparse.ArgumentParser(prog="sf_diagnose.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("scenario", help="simulator scenario name (e.g. pan, ir)")
    ap.add_argument("seed", type=int, help="scenario seed (the bench uses 0; tuning used 1 and 2)")
    ap.add_argument("--params", default="{}",
                    help="JSON object of ClusterParams fields, plus \"ext\": {StableFeatureExtractor "
                         "keywords} and \"horizon\": camera|detect|auto|off (default: {} = the defaults)")
    ap.add_argument("--duration-s", type=float, default=None, help="scenario length in seconds (default: its own)")
    ap.add_argument("--segment-s", type=float, default=5.0, help="length of the METE segments in seconds (default 5)")
    ap.add_argument("--breakdown", action="store_true",
                    help="split METE into its causes: per boat, the IoU lost where it is matched and the frames it is "
                         "missed; reports on no boat beyond the boats' count; and the matched boxes' bias (size, offset) "
                         "against the ground-truth boxes")
    ap.add_argument("--speed-pairs", type=int, default=0, metavar="N",
                    help="instead: time the default stage against the stage with --params, N alternating "
                         "pairs, CPU time, on 250 frames of the scenario rendered at 640x480 and 25 frames/s "
                         "(one OpenCV thread; set OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1)")
    ap.add_argument("--switches", action="store_true",
                    help="list every identity switch: the boat, the identity it had and the new one, whether the "
                         "old one is still reported (and on what), and how old the new one is")
    ap.add_argument("--cache", default=None, metavar="DIR",
                    help="record the extractor's snapshots in DIR on the first run and replay only the clustering "
                         "on later runs with the same scenario, seed, length, \"ext\" and \"horizon\"")
    return ap.parse_args(argv)


def _in_box(xy, b):
    return int(((xy[:, 0] >= b[0]) & (xy[:, 0] <= b[0] + b[2]) & (xy[:, 1] >= b[1]) & (xy[:, 1] <= b[1] + b[3])).sum())


def snapshot_cache(cache_dir, scenario, seed, duration_s, ext_kw, horizon):
    """The snapshot file of a scenario run in ``cache_dir`` (its key: the scenario, seed, duration,
    extractor settings, horizon source and the extractor's code) and its recorded snapshots, or
    None when there are none yet."""
    import seawatch.detect.features as _features

    with open(_features.__file__, "rb") as fh:  # the extractor's code (its defaults) is part of the key
        code = hashlib.sha1(fh.read()).hexdigest()
    key = json.dumps(["v2", scenario, seed, duration_s, ext_kw, horizon, code], sort_keys=True)
    path = os.path.join(cache_dir, f"{scenario}_{seed}_{hashlib.sha1(key.encode()).hexdigest()[:12]}.pkl")
    if not os.path.exists(path):
        return path, None
    with open(path, "rb") as fh:
        recorded = pickle.load(fh)
    print(f"replaying the clustering on the snapshots in {path}")
    return path, recorded


def parse_params(text: str, prog: str) -> dict | None:
    """``--params`` as a JSON object; None (with the reason on stderr, naming ``prog``) when it is not one."""
    try:
        kw = json.loads(text)
        if not isinstance(kw, dict):
            raise ValueError("not a JSON object")
    except ValueError as exc:
        print(f"{prog}: --params {text!r}: {exc}", file=sys.stderr)
        return None
    return kw



EVAL_SEEDS = {0, 3, 4}  # the bench's evaluation seeds: the diagnosis scripts refuse them


def replay_parser(prog: str, doc: str, cache_required: bool = True) -> argparse.ArgumentParser:
    """The arguments the replay scripts share (scenario, seed, ``--params``, ``--cache``); the
    script's docstring gives the description (its first paragraph) and the epilog (the rest)."""
    ap = argparse.ArgumentParser(prog=prog, description=doc.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=doc.split("\n\n", 1)[1] if "\n\n" in doc else None)
    ap.add_argument("scenario")
    ap.add_argument("seed", type=int)
    ap.add_argument("--params", default="{}", help="JSON object of ClusterParams fields, with the extractor's "
                    "under \"ext\" (default {})")
    ap.add_argument("--cache", required=cache_required, default=None, metavar="DIR",
                    help="sf_diagnose.py's snapshot cache")
    return ap


def replay_setup(args, prog: str):
    """The scenario, the default stage with ``--params`` and the cached snapshots (None without
    ``--cache``) for a replay script; None, with the reason on stderr, for an evaluation seed, bad
    ``--params`` or a cache without this sequence."""
    if args.seed in EVAL_SEEDS:
        print(f"{prog}: seed {args.seed} is an evaluation seed", file=sys.stderr)
        return None
    kw = parse_params(args.params, prog)
    if kw is None:
        return None
    ext_kw = kw.pop("ext", {})
    import cv2

    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker

    cv2.setNumThreads(1)
    scn = make_scenario(args.scenario, seed=args.seed)
    trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps, **ext_kw), ClusterParams(**kw),
                               camera=scn.camera, horizon="camera")
    recorded = None
    if args.cache:
        _, recorded = snapshot_cache(args.cache, args.scenario, args.seed, None, ext_kw, "camera")
        if recorded is None:
            print(f"{prog}: no snapshots in the cache for this sequence; run sf_diagnose.py with --cache first",
                  file=sys.stderr)
            return None
    return scn, trk, recorded

def main(argv=None) -> int:
    args = _parse(argv)
    kw = parse_params(args.params, "sf_diagnose")
    if kw is None:
        return 2
    import cv2

    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.eval import box_iou, clear_mot, melt, mete
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker

    cv2.setNumThreads(1)
    ext_kw = kw.pop("ext", {})
    horizon = kw.pop("horizon", "camera")
    if args.speed_pairs > 0:
        return _speed_pairs(args, ext_kw, kw, horizon)
    scn = make_scenario(args.scenario, seed=args.seed, duration_s=args.duration_s)
    trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps, **ext_kw), ClusterParams(**kw),
                               camera=scn.camera, horizon=horizon)
    gt, pred, feats, zooms = {}, {}, {}, {}
    cpu = 0.0
    cache_path, recorded, record = None, None, None
    if args.cache:
        cache_path, recorded = snapshot_cache(args.cache, args.scenario, args.seed, args.duration_s, ext_kw, horizon)
        if recorded is None:
            record = []
    for f, g in scn.iter_frames():
        vis = g.visible > 0
        gt[f.index] = (g.ids[vis], g.boxes[vis])
        c0 = time.process_time()
        if recorded is None and record is None:
            _, tr = trk.process(f)
        else:
            tr = _process(trk, f, None if recorded is None else recorded[len(pred)], record)
        cpu += time.process_time() - c0
        pred[f.index] = (tr.ids, tr.boxes)
        s = trk.last_snapshot
        feats[f.index] = (s.xy[s.stable].copy(), s.xy.copy())
        zooms[f.index] = float(f.ptz.zoom) if f.ptz is not None else 1.0
    if record is not None:
        os.makedirs(args.cache, exist_ok=True)
        part = f"{cache_path}.{os.getpid()}.part"  # two runs recording the same key do not share a file
        with open(part, "wb") as fh:
            pickle.dump(record, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(part, cache_path)
    frames = sorted(gt)
    e = mete(gt, pred, frames=frames)
    idsw = clear_mot(gt, pred, iou=0.3, frames=frames)["IDSW"]
    ml = melt(gt, pred, frames=frames)
    print(f"{args.scenario} seed {args.seed}: {len(frames)} frames, stage CPU {1e3 * cpu / len(frames):.1f} ms/frame")
    k25 = int(np.argmin(np.abs(np.asarray(ml["tau"]) - 0.25)))
    print(f"METE {e['METE']:.4f} (accuracy {e['METE_accuracy']:.3f} + cardinality {e['METE_cardinality']:.3f}) "
          f"IDSW {idsw} MELT {ml['MELT']:.3f} MELT@0.25 {float(ml['MELT_tau'][k25]):.3f}")

    kinds = {v.id: v.type for v in scn.vessels}
    stats: dict[int, dict] = {}
    off_boat = 0
    for k in frames:
        gi, gb = gt[k]
        pi, pb = pred[k]
        iou = box_iou(gb, pb) if len(gb) and len(pb) else np.zeros((len(gb), len(pb)))
        if len(pb):
            off_boat += int((iou.max(axis=0) < 0.1).sum()) if len(gb) else len(pb)
        stable_xy, active_xy = feats[k]
        for j, vid in enumerate(gi):
            b = gb[j]
            st = stats.setdefault(int(vid), dict(n=0, found=0, iou=[], h=[], ns=[], na=[], ids=set()))
            st["n"] += 1
            st["h"].append(b[3])
            st["ns"].append(_in_box(stable_xy, b))
            st["na"].append(_in_box(active_xy, b))
            if len(pb) and iou[j].max() > 0.3:
                st["found"] += 1
                st["iou"].append(iou[j].max())
                st["ids"].add(int(pi[iou[j].argmax()]))
    print("boat  type        frames  h_px  found  IoU   stable  active  ids")
    for vid, st in sorted(stats.items()):
        print(f"{vid:4d}  {kinds[vid]:10s}  {st['n']:6d}  {np.median(st['h']):4.0f}  {st['found'] / st['n']:5.2f}  "
              f"{np.mean(st['iou']) if st['iou'] else 0.0:4.2f}  {np.median(st['ns']):6.0f}  {np.median(st['na']):6.0f}"
              f"  {len(st['ids']):3d}")
    ng = np.array([len(gt[k][0]) for k in frames])
    npr = np.array([len(pred[k][0]) for k in frames])
    print(f"reported boxes on no boat (IoU < 0.1 with every boat): {off_boat / len(frames):.2f} per frame; "
          f"boats per frame {ng.mean():.2f}, reports per frame {npr.mean():.2f}")
    seg = max(1, int(round(args.segment_s * scn.fps)))
    for a in range(0, len(frames), seg):
        sl = slice(a, min(a + seg, len(frames)))
        z = np.mean([zooms[frames[i]] for i in range(sl.start, sl.stop)])
        print(f"{a / scn.fps:5.1f}-{sl.stop / scn.fps:5.1f} s: METE {e['per_frame'][sl].mean():.3f} "
              f"(accuracy {e['accuracy_per_frame'][sl].mean():.3f} + cardinality {e['cardinality_per_frame'][sl].mean():.3f})"
              f"  boats {ng[sl].mean():.1f}  reports {npr[sl].mean():.1f}  zoom {z:.2f}")
    if args.breakdown:
        _print_breakdown(gt, pred, frames, kinds, scn.fps, args.segment_s)
    if args.switches:
        _print_switches(gt, pred, frames, kinds, scn.fps)
    return 0


def _process(trk, frame, snap=None, record=None):
    """``trk.process(frame)`` with the extractor's snapshot given (``snap``: replay) or kept
    (``record``, a list that receives it pickled); the same steps as
    ``StableFeatureTracker.process``.  Returns the tracks."""
    from seawatch.types import Modality, TrackState

    hz, zoom, prior = trk.extractor_inputs(frame)
    # the extractor's input (the rendered frame, the horizon it is given, the zoom; the motion
    # prior when the extractor uses it): a replay whose input differs from the recording's (the
    # simulator or the horizon code changed) is refused
    used = None if trk.extractor.motion_prior == "off" or prior is None else np.round(prior, 9).tobytes()
    digest = hashlib.sha1(frame.image.tobytes() + repr(
        None if hz is None else (hz.y_left, hz.y_right, hz.width) if hasattr(hz, "y_left") else hz).encode()
        + repr(zoom).encode() + (b"" if used is None else used)).hexdigest()
    if snap is None:
        snap = trk.extractor.process(frame.image, frame.t_s, frame.index, horizon=hz, zoom=zoom, motion_prior=prior,
                                     ir=frame.modality == Modality.IR)
        if record is not None:
            record.append((digest, pickle.dumps(snap, protocol=pickle.HIGHEST_PROTOCOL)))
    else:
        rec_digest, snap = snap
        if rec_digest != digest:
            raise SystemExit(f"sf_diagnose: the cached snapshots are stale at frame {frame.index} (the "
                             f"extractor's input differs from the recording's); delete the cache and run again")
        snap = pickle.loads(snap)
    trk.last_snapshot = snap
    trk.last_horizon = hz
    trk.clusterer.camera_id = frame.camera_id
    _, tracks = trk.clusterer.update(snap, frame.image, horizon=hz, zoom=zoom, camera=trk._frame_camera,
                                     ir=frame.modality == Modality.IR)
    if not trk.report_tentative and len(tracks):
        tracks = tracks.subset(tracks.states != int(TrackState.TENTATIVE))
    return tracks


def _speed_pairs(args, ext_kw, kw, horizon) -> int:
    """CPU time per frame of the default stage and of the stage with ``--params``, alternating
    which runs first in each pair (the machine's speed drifts from minute to minute)."""
    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.sim import make_scenario
    from seawatch.track.feature_clusters import ClusterParams, StableFeatureTracker

    scn = make_scenario(args.scenario, seed=args.seed, width=640, height=480, fps=25.0, duration_s=10.0)
    frames = [scn.render(i) for i in range(min(250, scn.n_frames))]
    cfg = {"default": ({}, {}, "camera"), "--params": (ext_kw, kw, horizon)}
    ms = {k: [] for k in cfg}
    for r in range(args.speed_pairs):
        for k in (("default", "--params") if r % 2 == 0 else ("--params", "default")):
            e, c, hz = cfg[k]
            trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=25.0, **e), ClusterParams(**c),
                                       camera=scn.camera, horizon=hz)
            c0 = time.process_time()
            for f in frames:
                trk.process(f)
            ms[k].append(1e3 * (time.process_time() - c0) / len(frames))
    for k, v in ms.items():
        print(f"{k}: ms/frame {', '.join(f'{x:.1f}' for x in v)}; median {np.median(v):.1f} "
              f"({1e3 / np.median(v):.1f} frames/s)")
    ratio = np.array(ms["default"]) / np.array(ms["--params"])
    print(f"default / --params per pair: {', '.join(f'{x:.3f}' for x in ratio)}; median {np.median(ratio):.3f}")
    return 0


def mete_pairs(gb, pb):
    """METE's one-to-one assignment of ground-truth boxes ``gb`` to reported boxes ``pb``: the
    pairs ``(rows, cols)`` with IoU > 0 and the IoU matrix (also used by ``sf_missed_causes.py``)."""
    from scipy.optimize import linear_sum_assignment

    from seawatch.eval import box_iou

    iou = box_iou(gb, pb)
    rr, cc = linear_sum_assignment(-iou)
    keep = iou[rr, cc] > 0
    return rr[keep], cc[keep], iou


def _print_breakdown(gt, pred, frames, kinds, fps, segment_s):
    """METE of each frame is ``(sum over matched pairs of (1 - IoU) + max(n, m) - matched) / max(n, m)``
    (``n`` boats, ``m`` reports, pairs matched by largest total IoU): the first part is each matched
    boat's IoU loss, the second the missed boats (when ``n >= m``) or the reports on no boat beyond
    the boats' count (when ``m > n``).  Prints each part's share of mean METE per boat and per
    segment, and the matched boxes' bias against the ground truth."""
    nf = len(frames)
    iou_loss, miss, fp = {}, {}, 0.0
    seg = max(1, int(round(segment_s * fps)))
    seg_parts = np.zeros((int(np.ceil(nf / seg)), 3))
    bias = []  # (boat, log w ratio, log h ratio, dx / w_gt, dy / h_gt, iou)
    for q, k in enumerate(frames):
        gi, gb = gt[k]
        pi, pb = pred[k]
        n, m = len(gi), len(pi)
        if max(n, m) == 0:
            continue
        den = float(max(n, m))
        matched = np.zeros(n, bool)
        if n and m:
            rr, cc, iou = mete_pairs(gb, pb)
            for a, b in zip(rr, cc):
                matched[a] = True
                v = int(gi[a])
                iou_loss[v] = iou_loss.get(v, 0.0) + (1.0 - iou[a, b]) / den
                seg_parts[q // seg, 0] += (1.0 - iou[a, b]) / den
                g, r = gb[a], pb[b]
                bias.append((v, np.log(r[2] / max(g[2], 1e-9)), np.log(r[3] / max(g[3], 1e-9)),
                             (r[0] + 0.5 * r[2] - g[0] - 0.5 * g[2]) / max(g[2], 1e-9),
                             (r[1] + 0.5 * r[3] - g[1] - 0.5 * g[3]) / max(g[3], 1e-9), iou[a, b]))
        if n >= m:
            for a in np.flatnonzero(~matched):
                v = int(gi[a])
                miss[v] = miss.get(v, 0.0) + 1.0 / den
            seg_parts[q // seg, 1] += (n - matched.sum()) / den
        else:
            fp += (m - matched.sum()) / den
            seg_parts[q // seg, 2] += (m - matched.sum()) / den
    tot_iou, tot_miss = sum(iou_loss.values()) / nf, sum(miss.values()) / nf
    print(f"METE breakdown: IoU loss of matched boats {tot_iou:.3f} + missed boats {tot_miss:.3f} "
          f"+ reports beyond the boats' count {fp / nf:.3f} = {tot_iou + tot_miss + fp / nf:.3f}")
    b = np.array(bias).reshape(-1, 6)
    print("boat  type        IoU-loss  missed  | matched: median w ratio, h ratio, dx/w, dy/h, IoU")
    for v in sorted(set(iou_loss) | set(miss)):
        r = b[b[:, 0] == v]
        med = np.median(r[:, 1:], axis=0) if len(r) else np.full(5, np.nan)
        print(f"{v:4d}  {kinds[v]:10s}  {iou_loss.get(v, 0.0) / nf:8.3f}  {miss.get(v, 0.0) / nf:6.3f}  | "
              f"{np.exp(med[0]):5.2f} {np.exp(med[1]):5.2f} {med[2]:+5.2f} {med[3]:+5.2f} {med[4]:4.2f}")
    if len(b):
        med = np.median(b[:, 1:], axis=0)
        print(f"all matched pairs ({len(b)}): median w ratio {np.exp(med[0]):.2f}, h ratio {np.exp(med[1]):.2f}, "
              f"dx/w {med[2]:+.2f}, dy/h {med[3]:+.2f}, IoU {med[4]:.2f}")
    for s_, (a1, a2, a3) in enumerate(seg_parts):
        lo = s_ * seg
        hi = min(lo + seg, nf)
        print(f"{lo / fps:5.1f}-{hi / fps:5.1f} s: IoU loss {a1 / (hi - lo):.3f}  missed {a2 / (hi - lo):.3f}  "
              f"beyond count {a3 / (hi - lo):.3f}")


def clear_matches(gt, pred, frames):
    """The boat-report matches of each frame as CLEAR MOT's identity switches count them (IoU >= 0.3,
    a boat keeps the identity it last had while that one still matches): yields ``(k, a, b, g, r,
    last)`` for frame ``k``, boat row ``a`` (identity ``g``) matched to report row ``b`` (identity
    ``r``), ``last`` the boat's previous ``(identity, frame)`` or None; a switch is ``last[0] != r``.
    ``pred[k]`` starts with the report identities and boxes."""
    from scipy.optimize import linear_sum_assignment

    from seawatch.eval import box_iou

    last = {}  # boat -> (identity, frame index of that match)
    for k in frames:
        gi, gb = gt[k]
        pi, pb = pred[k][0], pred[k][1]
        if not len(gi) or not len(pi):
            continue
        iou = box_iou(gb, pb)
        score = np.where(iou >= 0.3 - 1e-9, iou, 0.0)
        bonus = np.array([[1000.0 if last.get(int(g), (None,))[0] == int(r) else 0.0 for r in pi] for g in gi])
        rr, cc = linear_sum_assignment(-(score + bonus * (score > 0)))
        for a, b in zip(rr, cc):
            if score[a, b] <= 0:
                continue
            g, r = int(gi[a]), int(pi[b])
            yield k, a, b, g, r, last.get(g)
            last[g] = (r, k)


def _print_switches(gt, pred, frames, kinds, fps):
    """Each identity switch as CLEAR MOT counts it (:func:`clear_matches`), with what happened to
    the old identity and where the new one came from."""
    from seawatch.eval import box_iou

    first_seen = {}  # identity -> first frame reported
    for k in frames:
        for r in pred[k][0]:
            first_seen.setdefault(int(r), k)
    covered = {}  # identity -> last boat it was matched to
    print("identity switches (t, boat, old -> new identity):")
    n = 0
    for k, a, b, g, r, prev in clear_matches(gt, pred, frames):
        gi, gb = gt[k]
        pi, pb = pred[k]
        if prev is not None and prev[0] != r:
            old, kf = prev
            n += 1
            where = "gone"
            if old in set(int(x) for x in pi):
                j = int(np.flatnonzero(pi == old)[0])
                io = box_iou(gb, pb[j:j + 1])[:, 0]
                a2 = int(np.argmax(io)) if len(io) else -1
                where = (f"still reported, IoU {io[a]:.2f} with this boat"
                         + (f", on boat {int(gi[a2])} (IoU {io[a2]:.2f})" if a2 >= 0 and a2 != a and io[a2] > 0.1 else ""))
            before = covered.get(r)
            print(f"  {k / fps:6.1f} s  boat {g:3d} ({kinds[g]}, h {gb[a, 3]:.0f} px): {old} -> {r}; "
                  f"old last matched {(k - kf) / fps:.1f} s ago, {where}; new one reported since "
                  f"{(k - first_seen[r]) / fps:.1f} s" + (f", before on boat {before}" if before not in (None, g) else ""))
        covered[r] = g
    print(f"  {n} switches")


if __name__ == "__main__":
    sys.exit(main())
