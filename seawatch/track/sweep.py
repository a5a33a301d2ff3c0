"""Parameter sensitivity study of the stable-features tracker (paper B, Fig. 3).

Osborne et al. vary the three clustering parameters one at a time (``Dmax`` over [0, 1],
``alpha`` and ``Wlink`` over [1, 50]), compute the mean METE of each setting on each sequence,
test with a Welch ANOVA whether the setting changes the mean METE, and plot mean METE against each
parameter.  The same study here:

* the features of each sequence are extracted **once** (:func:`extract_features`): the three
  parameters only act on the clustering, so each setting re-runs only
  :class:`~seawatch.track.feature_clusters.FeatureClusterer` on the stored features;
* :func:`sweep` runs every setting on every sequence and scores it with
  :func:`seawatch.eval.mete`;
* :func:`welch_anova` tests, per parameter, whether mean METE differs between its settings
  (groups: the settings; observations: the sequences' mean METE), with
  ``scipy.stats.f_oneway(..., equal_var=False)``;
* :func:`plot_sweep` draws mean METE against each parameter, one line per sequence and their mean.

``seawatch sweep`` (see ``docs/stable_features.md``) wires these to the simulator's scenarios and
to a video with MarDCT annotations.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from seawatch.detect.features import FeatureSnapshot, StableFeatureExtractor
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

__all__ = [
    "PARAMS",
    "SweepSequence",
    "SweepResult",
    "default_grid",
    "compact_snapshot",
    "extract_features",
    "run_clustering",
    "sweep",
    "welch_anova",
    "plot_sweep",
]

#: The swept parameters: ``ClusterParams`` field -> label in the paper.
PARAMS = {"dmax": "Dmax", "alpha": "alpha", "w_link": "Wlink"}


def default_grid(steps: int = 11) -> dict[str, list[float]]:
    """The paper's ranges: ``dmax`` evenly over [0, 1]; ``alpha`` and ``w_link`` over [1, 50]
    (evenly in log scale, rounded, the paper's defaults 3 and 1 included)."""
    steps = max(2, int(steps))
    dmax = np.round(np.linspace(0.0, 1.0, steps), 4)
    dmax = np.unique(np.r_[dmax, 0.31])
    log = np.unique(np.round(np.geomspace(1.0, 50.0, steps)).astype(int))
    alpha = np.unique(np.r_[log, 3])
    return {"dmax": dmax.tolist(), "alpha": alpha.astype(float).tolist(), "w_link": log.astype(float).tolist()}


def compact_snapshot(s: FeatureSnapshot) -> FeatureSnapshot:
    """A copy of a snapshot in float32 without the fields the clustering does not use."""
    f32 = np.float32
    return FeatureSnapshot(
        t_s=s.t_s, frame_index=s.frame_index, ids=s.ids.copy(), slots=s.slots.copy(),
        xy=s.xy.astype(f32), size_px=s.size_px.astype(f32), confidence=s.confidence.astype(np.int16),
        stable=s.stable.copy(), matched=s.matched.copy(), velocity=s.velocity.astype(f32),
        history=s.history.astype(f32), image_velocity=s.image_velocity.astype(f32),
        homography=s.homography, dt_s=s.dt_s, n_keypoints=s.n_keypoints, n_matched=s.n_matched,
        camera_motion_ok=s.camera_motion_ok, shape=s.shape, horizon=getattr(s, "horizon", None),
        zoom=float(getattr(s, "zoom", 1.0)),
    )


@dataclass
class SweepSequence:
    """One sequence of the study: its features (extracted once) and its ground truth.

    Attributes
    ----------
    name : str
    snapshots : list of FeatureSnapshot, one per frame in order.
    gt : dict ``frame -> (ids, boxes)`` of the frames to score (frames missing from it are
        run but not scored).
    """

    name: str
    snapshots: list
    gt: dict

    @property
    def n_frames(self) -> int:
        return len(self.snapshots)


def extract_features(frames: Iterable, extractor: StableFeatureExtractor | None = None,
                     keep: Callable[[int], bool] | None = None, camera=None) -> list[FeatureSnapshot]:
    """Run the feature stage over frames (:class:`seawatch.types.Frame`) and keep its snapshots.

    ``keep(frame_index)`` may drop frames from the result (they are still processed); by
    default every frame is kept, as the clustering needs them all.  With ``camera`` (a
    :class:`seawatch.camera.CameraModel`), each frame's horizon at its PTZ state goes with it, as
    in the tracker stage (the water band, and the still clusters on the water).
    """
    from seawatch.track.feature_clusters import camera_horizon

    ext = extractor or StableFeatureExtractor()
    out = []
    for f in frames:
        hz, zoom = camera_horizon(camera, f) if camera is not None else (None, 1.0)
        snap = ext.process(f.image, f.t_s, f.index, horizon=hz, zoom=zoom)
        if keep is None or keep(f.index):
            out.append(compact_snapshot(snap))
    return out


def run_clustering(snapshots: list[FeatureSnapshot], params: ClusterParams,
                   frames: set | None = None, confirmed_only: bool = True) -> dict:
    """Cluster stored features with ``params``; returns ``frame -> (ids, boxes)`` of the tracks
    (of the frames in ``frames`` only, when given)."""
    c = FeatureClusterer(params)
    out = {}
    for s in snapshots:
        _, tr = c.update(s)
        if frames is not None and s.frame_index not in frames:
            continue
        if confirmed_only:
            tr = tr.confirmed()
        out[s.frame_index] = (tr.ids.copy(), tr.boxes.copy())
    return out


@dataclass
class SweepResult:
    """Mean METE of each setting on each sequence.

    ``rows``: dicts ``param, value, sequence, METE, METE_accuracy, METE_cardinality``;
    ``base``: the fixed parameters; ``anova``: filled by :func:`welch_anova`.
    """

    rows: list = field(default_factory=list)
    base: dict = field(default_factory=dict)
    anova: dict = field(default_factory=dict)

    def table(self, param: str) -> tuple[np.ndarray, list[str], np.ndarray]:
        """(values, sequences, METE matrix values x sequences) of one parameter."""
        rows = [r for r in self.rows if r["param"] == param]
        values = np.array(sorted({r["value"] for r in rows}), float)
        seqs = sorted({r["sequence"] for r in rows})
        m = np.full((len(values), len(seqs)), np.nan)
        for r in rows:
            m[np.searchsorted(values, r["value"]), seqs.index(r["sequence"])] = r["METE"]
        return values, seqs, m

    def best(self, param: str) -> float:
        """The value of ``param`` with the lowest METE averaged over the sequences."""
        values, _, m = self.table(param)
        return float(values[int(np.nanargmin(np.nanmean(m, axis=1)))])

    def to_json(self) -> dict:
        return {"base": self.base, "rows": self.rows, "anova": self.anova}

    def write(self, out_dir: str | Path) -> list[Path]:
        """Write ``sweep.csv`` and ``sweep.json`` into ``out_dir``; returns the paths."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        csv = out / "sweep.csv"
        cols = ["param", "value", "sequence", "METE", "METE_accuracy", "METE_cardinality"]
        lines = [",".join(cols)] + [",".join(str(r[c]) for c in cols) for r in self.rows]
        csv.write_text("\n".join(lines) + "\n", encoding="utf-8")
        js = out / "sweep.json"
        js.write_text(json.dumps(self.to_json(), indent=1, default=float) + "\n", encoding="utf-8")
        return [csv, js]


def sweep(sequences: list[SweepSequence], grid: dict[str, list[float]] | None = None,
          base: ClusterParams | None = None, progress: Callable[[str], None] | None = None) -> SweepResult:
    """Vary each parameter of ``grid`` in turn, the others fixed at ``base``.

    Parameters
    ----------
    sequences : the sequences, features already extracted.
    grid : ``ClusterParams`` field -> values (default :func:`default_grid`).
    base : the fixed values of the other parameters (default: the paper's).
    progress : called with a line of text after each setting.
    """
    from seawatch.eval import mete

    grid = default_grid() if grid is None else grid
    base = base or ClusterParams()
    names = {f.name for f in dataclasses.fields(ClusterParams)}
    for p in grid:
        if p not in names:
            raise ValueError(f"sweep: unknown parameter '{p}' (ClusterParams has {', '.join(sorted(names))})")
    res = SweepResult(base=dataclasses.asdict(base))
    for p, values in grid.items():
        for v in values:
            params = dataclasses.replace(base, **{p: float(v)})
            for seq in sequences:
                pred = run_clustering(seq.snapshots, params, frames=set(seq.gt))
                e = mete(seq.gt, pred, frames=sorted(seq.gt))
                res.rows.append({
                    "param": p, "value": float(v), "sequence": seq.name, "METE": e["METE"],
                    "METE_accuracy": e["METE_accuracy"], "METE_cardinality": e["METE_cardinality"],
                })
            if progress is not None:
                ms = [r["METE"] for r in res.rows[-len(sequences):]]
                progress(f"{PARAMS.get(p, p)} = {v:g}: mean METE {np.mean(ms):.3f}")
    return res


def welch_anova(result: SweepResult) -> dict:
    """Welch's ANOVA per parameter: does mean METE differ between its settings?

    Groups are the settings of the parameter, observations the sequences' mean METE.  Welch's
    test weighs each group by the inverse of its variance, so a setting whose sequences all
    score the same (e.g. ``Dmax = 0``: nothing is ever found, METE 1 everywhere) cannot enter it
    and is left out.  Returns (and stores in ``result.anova``) ``param -> {"F", "p", "k",
    "k_tested", "n"}`` (``k`` settings, ``k_tested`` of them in the test, ``n`` sequences); F and
    p are NaN when fewer than two settings can be tested (or fewer than two sequences).
    """
    from scipy import stats

    out = {}
    for p in sorted({r["param"] for r in result.rows}):
        values, seqs, m = result.table(p)
        groups = [row[np.isfinite(row)] for row in m]
        groups = [g for g in groups if len(g) >= 2 and np.var(g) > 0]
        f = pv = float("nan")
        if len(groups) >= 2:
            with np.errstate(all="ignore"):
                r = stats.f_oneway(*groups, equal_var=False)
            f, pv = float(r.statistic), float(r.pvalue)
        out[p] = {"F": f, "p": pv, "k": int(len(values)), "k_tested": int(len(groups)), "n": int(len(seqs))}
    result.anova = out
    return out


def plot_sweep(result: SweepResult, path: str | Path) -> Path:
    """Mean METE against each parameter (one panel each), per sequence and averaged."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    params = [p for p in PARAMS if any(r["param"] == p for r in result.rows)]
    params += sorted({r["param"] for r in result.rows} - set(params))
    fig, axes = plt.subplots(1, max(1, len(params)), figsize=(4.2 * max(1, len(params)), 3.4), squeeze=False)
    for ax, p in zip(axes[0], params):
        values, seqs, m = result.table(p)
        for j, s in enumerate(seqs):
            ax.plot(values, m[:, j], marker=".", lw=1, alpha=0.7, label=s)
        ax.plot(values, np.nanmean(m, axis=1), color="k", lw=2, label="mean")
        if p in result.base:
            ax.axvline(result.base[p], color="grey", ls=":", lw=1)
        a = result.anova.get(p)
        title = PARAMS.get(p, p)
        if a and math.isfinite(a["p"]):
            title += f"  (Welch F={a['F']:.2f}, p={a['p']:.3g})"
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(PARAMS.get(p, p))
        ax.set_ylabel("mean METE")
        if p in ("alpha", "w_link"):
            ax.set_xscale("log")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
