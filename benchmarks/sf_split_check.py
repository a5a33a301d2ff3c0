"""Check that a change to the clusterer leaves its output unchanged, and time the clusterer alone.

The extractor knows nothing of the clusterer, so its snapshots are recorded once per scenario and
seed (``--snaps DIR``, kept between runs; delete the folder when the extractor or the simulator
changes) and the clustering is replayed on them, with the frame images rendered again (the box
growing reads them).  The records hold, per frame, the reported tracks (identities, boxes,
states) and detections (boxes) and the clusterer's feature labels.

``dump``: replay ``FeatureClusterer`` (``--params``: ``ClusterParams`` fields) on the scenario's
frames and write its output to OUT (a pickle).  Run it with the code before a change (e.g. in a
``git worktree`` of the commit before, with ``PYTHONPATH`` set to it) and after; ``compare``
then says whether the two are identical frame by frame (boxes compared exactly).

``time``: CPU time per frame of the clusterer alone (``update``: the clustering and the reports),
default ``ClusterParams`` against ``--params``, N alternating pairs in one process, with the
median of the per-pair ratios; and the time spent in ``FeatureClusterer._split_for_report``.

Uses only the simulator.  Example (the report split on, before and after a change)::

    .venv/bin/python benchmarks/sf_split_check.py dump pan 1 /tmp/after_pan1.pkl --snaps /tmp/snaps \\
        --params '{"split_dv_px_s": 6}'
    .venv/bin/python benchmarks/sf_split_check.py compare /tmp/before_pan1.pkl /tmp/after_pan1.pkl
    .venv/bin/python benchmarks/sf_split_check.py time pan 1 --pairs 8 --snaps /tmp/snaps \\
        --params '{"split_dv_px_s": 6}'
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
    ap = argparse.ArgumentParser(prog="sf_split_check.py", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("dump", "time"):
        p = sub.add_parser(name)
        p.add_argument("scenario")
        p.add_argument("seed", type=int)
        if name == "dump":
            p.add_argument("out", help="the output pickle")
        else:
            p.add_argument("--pairs", type=int, default=6, help="alternating pairs (default 6)")
            p.add_argument("--frames", type=int, default=250, help="frames replayed (default 250)")
        p.add_argument("--params", default="{}", help="JSON object of ClusterParams fields")
        p.add_argument("--snaps", default=None, metavar="DIR", help="keep the extractor's snapshots here")
        p.add_argument("--size", default=None, help="WIDTHxHEIGHT (default: the scenario's own; "
                                                    "time: 640x480 at 25 frames/s, 10 s, as sf_diagnose's --speed-pairs)")
    p = sub.add_parser("compare")
    p.add_argument("a")
    p.add_argument("b")
    return ap.parse_args(argv)


def _scenario(args):
    from seawatch.sim import make_scenario

    kw = {}
    if args.size:
        w, h = (int(x) for x in args.size.lower().split("x"))
        kw = dict(width=w, height=h)
    if args.cmd == "time":
        kw = dict(width=640, height=480, fps=25.0, duration_s=10.0, **kw)
    return make_scenario(args.scenario, seed=args.seed, **kw), kw


def _inputs(args):
    """Per frame: (frame, snapshot, horizon, zoom, camera) with the snapshots recorded or replayed."""
    import cv2

    from seawatch.detect.features import StableFeatureExtractor
    from seawatch.track.feature_clusters import StableFeatureTracker, camera_at

    cv2.setNumThreads(1)
    scn, kw = _scenario(args)
    n = scn.n_frames if args.cmd == "dump" else min(args.frames, scn.n_frames)
    frames = [scn.render(i) for i in range(n)]
    trk = StableFeatureTracker(StableFeatureExtractor(nominal_fps=scn.fps), camera=scn.camera)
    snaps = None
    path = None
    if args.snaps:
        key = json.dumps([args.scenario, args.seed, sorted(kw.items()), n], sort_keys=True)
        path = os.path.join(args.snaps, f"{args.scenario}_{args.seed}_{hashlib.sha1(key.encode()).hexdigest()[:12]}.pkl")
        if os.path.exists(path):
            with open(path, "rb") as fh:
                snaps = pickle.load(fh)
    out = []
    rec = []
    for i, f in enumerate(frames):
        cam = camera_at(trk.camera, f)[0] if trk.camera is not None else None
        trk._frame_camera = cam
        hz = trk._horizon(f)
        zoom = float(f.ptz.zoom) if (f.ptz is not None and trk.camera is not None) else 1.0
        if snaps is None:
            s = trk.extractor.process(f.image, f.t_s, f.index, horizon=hz, zoom=zoom)
            rec.append(s)
        else:
            s = snaps[i]
        out.append((f, s, hz, zoom, cam))
    if path and snaps is None:
        os.makedirs(args.snaps, exist_ok=True)
        with open(path + f".{os.getpid()}.part", "wb") as fh:
            pickle.dump(rec, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(path + f".{os.getpid()}.part", path)
    return out


def _replay(inputs, params, keep=True):
    from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

    c = FeatureClusterer(ClusterParams(**params))
    rows = []
    for f, s, hz, zoom, cam in inputs:
        c.camera_id = f.camera_id
        dets, tr = c.update(s, f.image, horizon=hz, zoom=zoom, camera=cam)
        if keep:
            rows.append(dict(ids=np.asarray(tr.ids).copy(), boxes=np.asarray(tr.boxes).copy(),
                             states=np.asarray(tr.states).copy(), det_boxes=np.asarray(dets.boxes).copy(),
                             labels=np.asarray(c.last_labels).copy()))
    return rows


def main(argv=None) -> int:
    args = _parse(argv)
    if args.cmd == "compare":
        with open(args.a, "rb") as fh:
            a = pickle.load(fh)
        with open(args.b, "rb") as fh:
            b = pickle.load(fh)
        if len(a["rows"]) != len(b["rows"]):
            print(f"different lengths: {len(a['rows'])} and {len(b['rows'])} frames")
            return 1
        nrep = 0
        for i, (ra, rb) in enumerate(zip(a["rows"], b["rows"])):
            for k in ra:
                if ra[k].shape != rb[k].shape or not np.array_equal(ra[k], rb[k], equal_nan=ra[k].dtype.kind == "f"):
                    print(f"frame {i}: {k} differ: {ra[k]!r} vs {rb[k]!r}")
                    return 1
            nrep += len(ra["ids"])
        ids = set(int(x) for r in a["rows"] for x in r["ids"])
        print(f"identical: {len(a['rows'])} frames, {nrep} reports, {len(ids)} identities "
              f"({a['name']} vs {b['name']})")
        return 0
    from sf_diagnose import parse_params  # this folder is on the path when run as a script

    params = parse_params(args.params, "sf_split_check")
    if params is None:
        return 2
    inputs = _inputs(args)
    if args.cmd == "dump":
        rows = _replay(inputs, params)
        with open(args.out, "wb") as fh:
            pickle.dump(dict(name=f"{args.scenario} {args.seed} {args.params}", rows=rows), fh)
        print(f"{args.scenario} seed {args.seed}: {len(rows)} frames, {sum(len(r['ids']) for r in rows)} reports "
              f"-> {args.out}")
        return 0
    from seawatch.track.feature_clusters import FeatureClusterer

    spent = [0.0]
    orig = FeatureClusterer._split_for_report

    def timed(self, *a, **k):
        c0 = time.process_time()
        r = orig(self, *a, **k)
        spent[0] += time.process_time() - c0
        return r

    FeatureClusterer._split_for_report = timed
    cfg = {"default": {}, "--params": params}
    ms = {k: [] for k in cfg}
    split_ms = []
    n = len(inputs)
    for r in range(args.pairs):
        for k in (("default", "--params") if r % 2 == 0 else ("--params", "default")):
            spent[0] = 0.0
            c0 = time.process_time()
            _replay(inputs, cfg[k], keep=False)
            ms[k].append(1e3 * (time.process_time() - c0) / n)
            if k == "--params":
                split_ms.append(1e3 * spent[0] / n)
    FeatureClusterer._split_for_report = orig
    for k, v in ms.items():
        print(f"{k}: clusterer ms/frame {', '.join(f'{x:.2f}' for x in v)}; median {np.median(v):.2f}")
    print(f"--params: _split_for_report ms/frame median {np.median(split_ms):.3f} ({', '.join(f'{x:.3f}' for x in split_ms)})")
    ratio = np.array(ms["--params"]) / np.array(ms["default"])
    print(f"--params / default per pair: {', '.join(f'{x:.3f}' for x in ratio)}; median {np.median(ratio):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
