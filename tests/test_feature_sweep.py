"""The parameter study of the stable-features tracker (seawatch.track.sweep and `seawatch sweep`)."""

import json

import numpy as np
import pytest

from seawatch.cli import main
from seawatch.detect.features import FeatureSnapshot
from seawatch.track.feature_clusters import ClusterParams
from seawatch.track.sweep import (
    SweepResult,
    SweepSequence,
    default_grid,
    plot_sweep,
    run_clustering,
    sweep,
    welch_anova,
)

FPS = 25.0


def boat_sequence(name, n=12, spread=1.0, seed=0):
    """Hand-made snapshots: a 'boat' of 4 features moving right and 4 static background features.

    ``spread`` scales the boat's direction noise (px/s), so that sequences differ.
    """
    rng = np.random.default_rng(seed)
    boat0 = np.array([[100, 100], [115, 104], [108, 112], [122, 110]], float)
    boat0[1:] += rng.normal(0, 2.0, (3, 2))  # a different boat per sequence: boxes (and IoU) differ
    bg = np.array([[300, 50], [320, 60], [340, 55], [310, 70]], float)
    snaps, gt = [], {}
    hist = np.full((8, 6, 2), np.nan)
    for k in range(n):
        t = k / FPS
        v_boat = np.array([50.0, 0.0]) + rng.normal(0, spread, (4, 2))
        v_bg = rng.normal(0, 1.0, (4, 2))  # static: below a speed floor of 2.5 px/s
        hist = np.roll(hist, -1, axis=1)
        hist[:, -1] = np.r_[v_boat, v_bg]
        xy = np.r_[boat0 + [50.0 * t, 0], bg]
        snaps.append(FeatureSnapshot(
            t_s=t, frame_index=k, ids=np.arange(8), slots=np.arange(8), xy=xy, size_px=np.full(8, 4.0),
            confidence=np.full(8, 6), stable=np.ones(8, bool), matched=np.ones(8, bool),
            velocity=hist[:, -1].copy(), history=hist.copy(), image_velocity=hist[:, -1].copy(),
            homography=np.eye(3), dt_s=1 / FPS, n_keypoints=8, n_matched=8, shape=(240, 320),
        ))
        gt[k] = (np.array([1]), np.array([[99.0 + 50 * t, 99.0, 25.0, 15.0]]))
    return SweepSequence(name, snaps, gt)


def test_default_grid_covers_the_papers_ranges():
    g = default_grid(11)
    assert min(g["dmax"]) == 0.0 and max(g["dmax"]) == 1.0 and 0.31 in g["dmax"]
    assert min(g["alpha"]) == 1 and max(g["alpha"]) == 50 and 3 in g["alpha"]
    assert min(g["w_link"]) == 1 and max(g["w_link"]) == 50


def test_run_clustering_finds_the_boat():
    seq = boat_sequence("a")
    pred = run_clustering(seq.snapshots, ClusterParams(confirm_s=0.0, min_speed_px_s=2.5))
    ids, boxes = pred[11]
    assert ids.tolist() == [1]
    # the leftmost feature, less the keypoint radius (size 4)
    assert boxes[0, 0] == pytest.approx(100 - 2 + 50 * 11 / FPS, abs=1e-6)


def test_sweep_scores_settings_and_anova_tells_them_apart():
    seqs = [boat_sequence("a", spread=1.0, seed=1), boat_sequence("b", spread=3.0, seed=2),
            boat_sequence("c", spread=6.0, seed=3)]
    grid = {"dmax": [0.0, 0.31, 1.0], "w_link": [1.0, 50.0]}
    res = sweep(seqs, grid, ClusterParams(confirm_s=0.0, min_speed_px_s=2.5))
    assert len(res.rows) == (3 + 2) * 3
    _, names, m = res.table("dmax")
    assert names == ["a", "b", "c"]
    # Dmax = 0 admits no edge at all: nothing is found, METE = 1 on every frame
    assert np.allclose(m[0], 1.0)
    # Dmax = 0.31 finds the boat in most frames
    assert np.all(m[1] < 0.6)
    # Wlink = 50 needs 17 re-associations at alpha = 3: never within 12 frames
    _, _, mw = res.table("w_link")
    assert np.allclose(mw[1], 1.0) and np.all(mw[0] < 0.6)
    a = welch_anova(res)
    assert set(a) == {"dmax", "w_link"}
    # the Dmax = 0 group has no variance and is left out of Welch's test; the others enter it
    assert a["dmax"]["k"] == 3 and a["dmax"]["n"] == 3 and a["dmax"]["k_tested"] == 2
    assert np.isfinite(a["dmax"]["F"])
    # Wlink = 50 scores 1 everywhere: one group left, no test
    assert a["w_link"]["k_tested"] == 1 and np.isnan(a["w_link"]["F"])
    assert res.best("dmax") == pytest.approx(0.31) or res.best("dmax") == pytest.approx(1.0)


def test_welch_anova_against_scipy_on_a_hand_made_table():
    from scipy import stats

    res = SweepResult(rows=[])
    values = {0.1: [0.5, 0.6, 0.55], 0.5: [0.2, 0.25, 0.3], 0.9: [0.8, 0.7, 0.95]}
    for v, ms in values.items():
        for s, m in zip("xyz", ms):
            res.rows.append({"param": "dmax", "value": v, "sequence": s, "METE": m,
                             "METE_accuracy": 0, "METE_cardinality": 0})
    a = welch_anova(res)["dmax"]
    ref = stats.f_oneway(*[np.array(x) for x in values.values()], equal_var=False)
    assert a["F"] == pytest.approx(ref.statistic) and a["p"] == pytest.approx(ref.pvalue)
    assert a["p"] < 0.05
    assert res.best("dmax") == 0.5


def test_results_written_and_plotted(tmp_path):
    res = sweep([boat_sequence("a"), boat_sequence("b", seed=5)], {"alpha": [1.0, 3.0]}, ClusterParams(confirm_s=0.0, min_speed_px_s=2.5))
    welch_anova(res)
    csv, js = res.write(tmp_path)
    assert csv.read_text().splitlines()[0].startswith("param,value,sequence,METE")
    assert len(csv.read_text().splitlines()) == 1 + 4
    data = json.loads(js.read_text())
    assert set(data) == {"base", "rows", "anova"} and data["base"]["dmax"] == 0.31
    png = plot_sweep(res, tmp_path / "sweep.png")
    assert png.stat().st_size > 1000


def test_sweep_rejects_unknown_parameter():
    with pytest.raises(ValueError, match="unknown parameter 'gamma'"):
        sweep([boat_sequence("a")], {"gamma": [1.0]})


def test_cli_sweep_errors(capsys):
    assert main(["sweep", "--scenario", "none", "--out", "x"]) == 1
    assert "no sequence" in capsys.readouterr().err
    assert main(["sweep", "--scenario", "none", "--param", "gamma=1,2"]) == 1
    assert "unknown parameter 'gamma'" in capsys.readouterr().err
    assert main(["sweep", "--scenario", "none", "--video", "a.avi"]) == 1
    assert "one annotation folder per video" in capsys.readouterr().err


def test_cli_sweep_on_a_short_scenario(tmp_path, capsys):
    out = tmp_path / "sw"
    rc = main(["sweep", "--scenario", "ir", "--duration-s", "1.5", "--param", "dmax=0.31,0.6",
               "--param", "alpha=3", "--out", str(out), "--quiet"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "dmax" in text and "alpha" in text
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert len(rows) == 3 and all(r.split(",")[2] == "sim:ir" for r in rows)
    mete = [float(r.split(",")[3]) for r in rows]
    assert all(0.0 <= m <= 1.0 for m in mete)
    assert (out / "sweep.png").is_file() and (out / "sweep.json").is_file()
