"""Evaluation of one prediction file against one ground-truth file, as a table and a report.

:func:`evaluate` runs every metric that the inputs allow (detection always; CLEAR MOT, HOTA,
IDF1, MELT when both sides carry identities; METE always; OSPA/GOSPA when both carry world
coordinates), :func:`format_summary` prints the headline figures, and :func:`write_report`
writes ``report.md``, ``report.json`` and the plots (METE per frame, cardinality over time, OSPA
over time, precision-recall) into a folder.  ``seawatch eval`` is a thin wrapper around them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from seawatch.eval.clear import clear_mot
from seawatch.eval.detection import detection_metrics
from seawatch.eval.matching import prepare
from seawatch.eval.hota import hota, identity_metrics
from seawatch.eval.mete import melt, mete
from seawatch.eval.ospa import gospa, ospa

__all__ = ["evaluate", "format_summary", "write_report", "to_jsonable"]


def _has_ids(fs) -> bool:
    """True when every object has an id and no id repeats within a frame (a track file)."""
    from seawatch.eval.matching import check_unique_ids

    if len(fs.ids) == 0 or np.any(fs.ids < 0):
        return False
    try:
        check_unique_ids(fs.fidx, fs.ids, "", fs.frames)
    except ValueError:
        return False
    return True


def evaluate(gt, pred, iou: float = 0.5, frames=None, ospa_cutoff_m: float = 50.0, ospa_p: float = 1.0) -> dict:
    """Every applicable metric of ``pred`` against ``gt``.

    Parameters
    ----------
    gt, pred : Annotations or per-frame data
        Usually :class:`seawatch.io.gt.Annotations` (world coordinates in ``.world``).
    iou : float
        IoU threshold of detection, CLEAR MOT and IDF1 matches.
    frames : array-like, optional
        Frames to score (default: every frame of either input).
    ospa_cutoff_m, ospa_p : float
        Cut-off and order of OSPA/GOSPA.

    Returns
    -------
    dict with sections ``detection``, ``clear_motchallenge``, ``clear_vace``, ``hota``,
    ``identity``, ``mete``, ``melt``, ``ospa``, ``gospa`` (absent when not applicable), ``frames``,
    ``n_frames`` and ``summary`` (the headline figures, flat).
    """
    prep = prepare(gt, pred, frames)  # flattened, paired and matched once for all metrics
    axis = prep.g.frames
    res: dict = {"iou": float(iou), "frames": axis, "n_frames": int(len(axis))}
    res["detection"] = detection_metrics(prep, None, iou=iou)
    res["mete"] = mete(prep, None)
    gt_ids, pred_ids = _has_ids(prep.g), _has_ids(prep.p)
    res["notes"] = []
    for who, ok, n in (("ground truth", gt_ids, len(prep.g)), ("predictions", pred_ids, len(prep.p))):
        if not ok and n:
            res["notes"].append(f"{who}: no usable identities (missing, or repeated within a frame); "
                                "tracking metrics skipped")
    if gt_ids and pred_ids:
        res["clear_motchallenge"] = clear_mot(prep, None, iou=iou, variant="motchallenge")
        res["clear_vace"] = clear_mot(prep, None, iou=iou, variant="vace")
        res["hota"] = hota(prep, None)
        res["identity"] = identity_metrics(prep, None, iou=iou)
    if gt_ids:
        res["melt"] = melt(prep, None)
    world = _world_points(gt, pred)
    if world is not None:
        gpts, ppts, res["world_source"] = world
        res["ospa"] = ospa(gpts, ppts, cutoff_m=ospa_cutoff_m, p=ospa_p, frames=axis)
        res["gospa"] = gospa(gpts, ppts, cutoff_m=ospa_cutoff_m, p=ospa_p, frames=axis)
    res["summary"] = _summary(res)
    return res


def _world_points(gt, pred):
    """Per-frame world points of both inputs in one metric frame, or None.

    Latitude/longitude on both sides is preferred (both converted to metres east/north of the
    ground truth's mean position); otherwise ``world`` metres (e.g. ``enu_m``) on both sides.
    Rows without a position are left out.
    """
    from seawatch.io.gt import latlon_to_local_m

    gl, pl = getattr(gt, "latlon", None), getattr(pred, "latlon", None)
    if gl is not None and pl is not None and np.isfinite(gl).all(axis=1).any():
        origin = np.nanmean(gl, axis=0)
        return (gt.per_frame(world=True, points=latlon_to_local_m(gl, origin)),
                pred.per_frame(world=True, points=latlon_to_local_m(pl, origin)), "lat/lon")
    gw, pw = getattr(gt, "world", None), getattr(pred, "world", None)
    if gw is not None and pw is not None and gw.shape[1] == pw.shape[1]:
        return gt.per_frame(world=True), pred.per_frame(world=True), "world (enu_m)"
    return None


def _summary(res: dict) -> dict:
    d = res["detection"]
    s = {"TPR": d["TPR"], "FAR": d["FAR"], "precision": d["precision"], "F1": d["F1"], "AP": d.get("AP"),
         "TP": d["TP"], "FP": d["FP"], "FN": d["FN"]}
    if "clear_motchallenge" in res:
        c, v = res["clear_motchallenge"], res["clear_vace"]
        s.update({"MOTA": c["MOTA"], "MOTP": c["MOTP"], "IDSW": c["IDSW"], "Frag": c["Frag"], "MT": c["MT"],
                  "PT": c["PT"], "ML": c["ML"], "MOTA_VACE": v["MOTA"], "MOTP_VACE": v["MOTP"]})
        h, i = res["hota"], res["identity"]
        s.update({"HOTA": h["HOTA"], "DetA": h["DetA"], "AssA": h["AssA"], "LocA": h["LocA"],
                  "IDF1": i["IDF1"], "IDP": i["IDP"], "IDR": i["IDR"]})
    s["METE"] = res["mete"]["METE"]
    if "melt" in res:
        s["MELT"] = res["melt"]["MELT"]
    if "ospa" in res:
        s["OSPA"] = res["ospa"]["OSPA"]
        s["GOSPA"] = res["gospa"]["GOSPA"]
    return s


_HELP = {
    "TPR": "detection rate TP/(TP+FN)", "FAR": "false alarm rate FP/(TP+FP) (Bloisi et al.)",
    "precision": "TP/(TP+FP)", "F1": "2TP/(2TP+FP+FN)", "AP": "area under the PR curve",
    "MOTA": "CLEAR MOT, MOTChallenge", "MOTP": "mean IoU of matches", "MOTA_VACE": "Kasturi et al., log10 ID switches",
    "MOTP_VACE": "mean overlap, VACE", "IDSW": "identity switches", "Frag": "fragmentations",
    "MT": "mostly tracked", "PT": "partly tracked", "ML": "mostly lost",
    "HOTA": "mean over alpha", "IDF1": "identity F1", "METE": "Nawaz et al., lower is better",
    "MELT": "Nawaz et al., lower is better",
}


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    v = float(v)
    return "nan" if math.isnan(v) else f"{v:.4f}"


def format_summary(res: dict, title: str = "") -> str:
    """The headline figures as a two-column text table."""
    s = res["summary"]
    lines = [title] if title else []
    lines.append(f"{res['n_frames']} frames, IoU threshold {res['iou']:g}")
    lines += [f"note: {n}" for n in res.get("notes", [])]
    w = max(len(k) for k in s)
    for k, v in s.items():
        note = _HELP.get(k, "")
        lines.append(f"  {k.ljust(w)}  {_fmt(v):>10}  {note}")
    return "\n".join(lines)


def to_jsonable(x):
    """Numbers, arrays and nested containers as plain JSON values (NaN and inf -> null)."""
    if isinstance(x, dict):
        return {str(k): to_jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return to_jsonable(x.tolist())
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        x = float(x)
        return x if math.isfinite(x) else None
    return x


def _plots(res: dict, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    frames = np.asarray(res["frames"], dtype=float)

    def save(fig, name):
        p = out / name
        fig.tight_layout()
        fig.savefig(p, dpi=100)
        plt.close(fig)
        paths.append(p)

    m = res["mete"]
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(frames, m["per_frame"], lw=1, label="METE")
    ax.plot(frames, m["cardinality_per_frame"], lw=0.8, ls="--", label="cardinality term")
    ax.set_xlabel("frame")
    ax.set_ylabel("METE")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(f"METE per frame (mean {m['METE']:.3f})")
    ax.legend(loc="upper right")
    save(fig, "mete_per_frame.png")

    fig, ax = plt.subplots(figsize=(8, 3))
    ax.step(frames, m["n_gt_per_frame"], where="mid", label="ground truth")
    ax.step(frames, m["n_pred_per_frame"], where="mid", label="predicted")
    ax.set_xlabel("frame")
    ax.set_ylabel("objects")
    ax.set_title("Cardinality over time")
    ax.legend(loc="upper right")
    save(fig, "cardinality.png")

    if "ospa" in res:
        o, g = res["ospa"], res["gospa"]
        fig, ax = plt.subplots(figsize=(8, 3))
        ax.plot(frames, o["per_frame"], lw=1, label=f"OSPA (mean {o['OSPA']:.2f} m)")
        ax.plot(frames, g["per_frame"], lw=1, label=f"GOSPA (mean {g['GOSPA']:.2f} m)")
        ax.set_xlabel("frame")
        ax.set_ylabel("m")
        ax.set_title(f"OSPA / GOSPA over time (c = {o['cutoff_m']:g} m, p = {o['p']:g})")
        ax.legend(loc="upper right")
        save(fig, "ospa.png")

    d = res["detection"]
    pr = d.get("pr_curve")
    if pr is not None:
        fig, ax = plt.subplots(figsize=(4.5, 4))
        ax.plot(pr["recall"], pr["precision"], marker=".", lw=1)
        ax.plot([d["TPR"]], [d["precision"]], "o", label="operating point")
        ax.set_xlim(0, 1.02)
        ax.set_ylim(0, 1.02)
        ax.set_xlabel("recall (TPR)")
        ax.set_ylabel("precision")
        ax.set_title(f"Precision-recall, IoU {d['iou']:g} (AP {d.get('AP', 0):.3f})")
        ax.legend(loc="lower left")
        save(fig, "precision_recall.png")
    return paths


def _markdown(res: dict, plots: list[Path], meta: dict) -> str:
    lines = ["# seawatch evaluation report", ""]
    for k, v in meta.items():
        lines.append(f"- **{k}**: {v}")
    lines += ["", f"{res['n_frames']} frames scored, IoU threshold {res['iou']:g}."]
    lines += [f"Note: {n}." for n in res.get("notes", [])]
    lines += ["",
              "| metric | value | note |", "| --- | ---: | --- |"]
    for k, v in res["summary"].items():
        lines.append(f"| {k} | {_fmt(v)} | {_HELP.get(k, '')} |")
    bs = res["detection"]["by_size"]
    lines += ["", "## Detection by box size", "", "| size | area px^2 | GT | TP | FN | TPR | pred | FP | precision |",
              "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name, b in bs.items():
        lo, hi = b["area_px2"]
        lines.append(f"| {name} | {lo:g}-{hi:g} | {b['n_gt']} | {b['TP']} | {b['FN']} | {_fmt(b['TPR'])} | "
                     f"{b['n_pred']} | {b['FP']} | {_fmt(b['precision'])} |")
    if "hota" in res:
        h = res["hota"]
        lines += ["", "## HOTA per localisation threshold", "", "| alpha | HOTA | DetA | AssA | LocA |",
                  "| ---: | ---: | ---: | ---: | ---: |"]
        pa = h["per_alpha"]
        for a in range(len(pa["alpha"])):
            lines.append(f"| {pa['alpha'][a]:.2f} | {pa['HOTA'][a]:.4f} | {pa['DetA'][a]:.4f} | "
                         f"{pa['AssA'][a]:.4f} | {pa['LocA'][a]:.4f} |")
    if plots:
        lines += ["", "## Plots", ""]
        for p in plots:
            lines.append(f"![{p.stem}]({p.name})")
            lines.append("")
    lines += ["", "Definitions: docs/evaluation.md. Full figures: report.json.", ""]
    return "\n".join(lines)


def write_report(res: dict, out_dir, meta: dict | None = None, plots: bool = True) -> list[Path]:
    """Write ``report.json``, ``report.md`` and the plots into ``out_dir``; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    meta = dict(meta or {})
    pl = _plots(res, out) if plots else []
    j = out / "report.json"
    j.write_text(json.dumps(to_jsonable({"meta": meta, **res}), indent=1) + "\n", encoding="utf-8")
    md = out / "report.md"
    md.write_text(_markdown(res, pl, meta), encoding="utf-8")
    return [md, j, *pl]
