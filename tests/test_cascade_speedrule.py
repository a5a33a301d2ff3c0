"""Session 14's rule for speed settings (seawatch.train.scanstats.speed_settings) on synthetic frames."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from seawatch.detect.cascade import CascadeDetector
from seawatch.train.samples import LabelledImage
from seawatch.train.scanstats import (OWN_SETTINGS_KEYS, choose_speed_setting, played_cpu_s, played_sequences,
                                      played_speed_settings, speed_settings, write_speed_rule_json)
from seawatch.train.scanstats import main as scanstats_main
from seawatch.train.synthetic import boat_scene

V6 = Path(__file__).resolve().parent.parent / "seawatch" / "models" / "boat_cascade_v6.xml"


def _parts():
    def im(seed, part):
        img, boxes, _ = boat_scene(seed, 320, 240, n_boats=2, boat_w_px=(40.0, 90.0), horizon_px=70.0, clutter=5)
        return LabelledImage(f"{part}{seed}", "mardct", boxes, image=img)
    return {"train": [im(1, "t")], "val": [im(2, "v"), im(3, "v")], "heldout": [im(4, "h")]}


def test_speed_rule_chooses_the_best_validation_score_among_the_fast_enough():
    parts = _parts()
    r = speed_settings(V6, parts, scale_factors=(1.2, 1.5), target_fps=0.0, size=(352, 288), passes=1,
                       log=lambda *a: None)
    rows = {c["scale_factor"]: c for c in r["candidates"]}
    assert sorted(rows) == [1.2, 1.5]
    assert r["speed_frames"] == 3  # training + validation frames, never the held-out one
    for c in rows.values():
        assert c["fps"] > 0 and len(c["fps_per_pass"]) == 1 and 0.0 <= c["score"] <= 1.0
    # every candidate is fast enough at 0 frames/s: the best validation score wins
    assert r["chosen"]["score"] == max(c["score"] for c in rows.values())
    # none is at an impossible rate
    r2 = speed_settings(V6, parts, scale_factors=(1.2, 1.5), target_fps=1e9, size=(352, 288), passes=1,
                        log=lambda *a: None)
    assert r2["chosen"] is None


def test_speed_rule_picks_the_best_score_at_or_above_the_target_not_the_fastest():
    rows = [{"scale_factor": 1.1, "score": 0.80, "fps": 22.0},
            {"scale_factor": 1.2, "score": 0.70, "fps": 35.0},
            {"scale_factor": 1.3, "score": 0.73, "fps": 43.0},
            {"scale_factor": 1.4, "score": 0.65, "fps": 50.0},
            {"scale_factor": 1.5, "score": 0.70, "fps": 54.0}]
    assert choose_speed_setting(rows, 40.0)["scale_factor"] == 1.3  # not 1.5 (fastest), not 1.1 (best)
    assert choose_speed_setting(rows, 50.0)["scale_factor"] == 1.5  # 50.0 itself reaches the target
    assert choose_speed_setting(rows, 30.0)["scale_factor"] == 1.3
    assert choose_speed_setting(rows, 0.0)["scale_factor"] == 1.1
    assert choose_speed_setting(rows, 54.01) is None


def _clip_parts():
    def im(seed, part, group, order):
        img, boxes, _ = boat_scene(seed, 320, 240, n_boats=2, boat_w_px=(40.0, 90.0), horizon_px=70.0, clutter=5)
        return LabelledImage(f"{group}_{order}", "mardct", boxes, image=img, group=group, order=float(order))
    train = [im(10 + k, "t", "a", o) for k, o in enumerate((5, 1, 3))] + [im(20, "t", "b", 7)]
    return {"train": train, "val": [im(30, "v", "a", 9), im(31, "v", "b", 8)], "heldout": [im(40, "h", "a", 11)]}


def test_played_sequences_keep_each_clip_in_temporal_order():
    parts = _clip_parts()
    ims = parts["train"] + parts["val"]
    seqs = played_sequences(ims, size=(176, 144), seq_len=3)
    # clip a: orders 1, 3, 5, 9 -> [1, 3, 5], [9]; clip b: 7, 8 -> [7, 8]
    assert [len(q) for q in seqs] == [3, 1, 2]
    by_order = {im.order: im for im in ims}
    expect = [[1, 3, 5], [9], [7, 8]]
    for q, orders in zip(seqs, expect):
        for img, o in zip(q, orders):
            assert img.shape[:2] == (144, 176)
            ref = cv2.resize(by_order[o].image, (176, 144), interpolation=cv2.INTER_LINEAR)
            assert np.array_equal(img, ref)


class _Recorder:
    def __init__(self, log):
        self.log = log

    def reset(self):
        self.log.append("reset")

    def detect(self, frame):
        self.log.append((frame.index, frame.t_s))


def test_played_timing_resets_only_between_sequences_with_video_timestamps():
    log = []
    seqs = [[np.zeros((8, 8), np.uint8)] * 3, [np.zeros((8, 8), np.uint8)] * 2]
    out = played_cpu_s({"a": _Recorder(log)}, seqs, passes=2)
    assert len(out["a"]) == 2 and [len(p) for p in out["a"]] == [5, 5]
    one_pass = ["reset", (0, 0.0), (1, 0.04), (2, 0.08), "reset", (0, 0.0), (1, 0.04)]
    assert log == [(0, 0.0)] + one_pass * 2  # a warm-up call, then the played passes


def test_played_rule_needs_the_margin_not_only_the_target():
    parts = _clip_parts()
    r = played_speed_settings(V6, parts, scale_factors=(1.2, 1.5), target_fps=0.0, margin_fps=0.0, size=(352, 288),
                              passes=1, log=lambda *a: None)
    assert r["speed_frames"] == 6 and sorted(r["sequences"]) == [2, 4]  # never the held-out frame
    rows = {c["scale_factor"]: c for c in r["candidates"]}
    assert sorted(rows) == [1.2, 1.5] and all(c["fps"] > 0 for c in rows.values())
    assert r["chosen"]["score"] == max(c["score"] for c in rows.values())
    fastest = max(c["fps"] for c in rows.values())
    r2 = played_speed_settings(V6, parts, scale_factors=(1.2, 1.5), target_fps=0.0, margin_fps=fastest * 100,
                               size=(352, 288), passes=1, log=lambda *a: None)
    assert r2["chosen"] is None and r2["margin_fps"] == fastest * 100


MODELS = V6.parent


def test_speed_rule_json_rebuilds_the_shipped_default_byte_for_byte(tmp_path):
    # v6s15's JSON was assembled by hand in session 15: the writer, given v6's JSON and the
    # rule's record as stored, gives the same bytes (the default's until session 18)
    shipped = json.loads((MODELS / "boat_cascade_v6s15.json").read_text())
    rule = {k: v for k, v in shipped["speed_selection"].items() if k not in ("command", "note")}
    out = write_speed_rule_json(tmp_path / "boat_cascade_v6s15.json", V6, rule, shipped["speed_selection"]["command"])
    assert out.read_bytes() == (MODELS / "boat_cascade_v6s15.json").read_bytes()


def test_speed_rule_json_rebuilds_v6g4_the_shipped_default_byte_for_byte(tmp_path):
    # session 18's rule ran on a copy of v6 whose JSON's detector block says grid_step_x_px 4;
    # the writer, given that and the rule's record as stored, gives v6g4's JSON (the default's)
    shipped = json.loads((MODELS / "boat_cascade_v6g4.json").read_text())
    src = json.loads(V6.with_suffix(".json").read_text())
    src["detector"]["grid_step_x_px"] = 4
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / V6.name).write_bytes(V6.read_bytes())
    (tmp_path / "src" / V6.with_suffix(".json").name).write_text(json.dumps(src, indent=1))
    rule = {k: v for k, v in shipped["speed_selection"].items() if k not in ("command", "note")}
    out = write_speed_rule_json(tmp_path / "boat_cascade_v6g4.json", tmp_path / "src" / V6.name, rule,
                                shipped["speed_selection"]["command"])
    assert out.read_bytes() == (MODELS / "boat_cascade_v6g4.json").read_bytes()
    assert out.read_bytes() == (MODELS / "boat_cascade.json").read_bytes()
    assert shipped["detector"] == {"min_neighbors": 2, "scale_factor": 1.2, "neighbors_size_exp": 0.5,
                                   "grid_step_px": 2, "grid_step_x_px": 4}


def test_speed_rule_json_from_a_synthetic_rule_run(tmp_path):
    parts = _clip_parts()
    r = played_speed_settings(V6, parts, scale_factors=(1.2, 1.5), target_fps=0.0, margin_fps=0.0, size=(352, 288),
                              passes=1, log=lambda *a: None)
    v6 = json.loads(V6.with_suffix(".json").read_text())
    out = write_speed_rule_json(tmp_path / "boat_cascade_test.json", V6, r, "the command")
    got = json.loads(out.read_text())
    c = r["chosen"]
    assert got["detector"] == {**v6["detector"], "scale_factor": c["scale_factor"],
                               "min_neighbors": c["min_neighbors"], "neighbors_size_exp": c["neighbors_size_exp"]}
    assert got["detector"]["grid_step_px"] == 2  # kept from v6
    assert got["speed_selection"]["candidates"] == json.loads(json.dumps(r["candidates"]))
    assert got["speed_selection"]["command"] == "the command"
    for k in OWN_SETTINGS_KEYS:
        assert k in v6 and k not in got
    assert got["stages"] == v6["stages"] and got["split"] == v6["split"]
    assert "no training was run for test" in got["note_v6_keys"]
    # the detector reads the written settings
    shutil.copyfile(V6, out.with_suffix(".xml"))
    d = CascadeDetector(out.with_suffix(".xml"))
    assert (d.params.scale_factor, d.params.min_neighbors) == (c["scale_factor"], c["min_neighbors"])
    # nothing chosen: nothing written
    with pytest.raises(ValueError, match="chose no candidate"):
        write_speed_rule_json(tmp_path / "none.json", V6, {**r, "chosen": None}, "c")
    assert not (tmp_path / "none.json").exists()


def test_write_json_needs_the_played_rule(tmp_path, capsys):
    with pytest.raises(SystemExit):
        scanstats_main(["--data", str(tmp_path), "--model", str(V6), "--what", "speedrule",
                        "--write-json", str(tmp_path / "x.json")])
    assert "--write-json needs --what playedrule" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        scanstats_main(["--data", str(tmp_path), "--model", str(tmp_path / "m.xml"), "--what", "playedrule",
                        "--write-json", str(tmp_path / "x.json")])
    assert "no JSON beside --model" in capsys.readouterr().err


def test_both_rules_start_from_the_same_candidates():
    from seawatch.train.scanstats import _rule_candidates

    parts = _clip_parts()
    img, boxes, _ = boat_scene(50, 320, 240, n_boats=1, boat_w_px=(40.0, 60.0), horizon_px=70.0)
    parts["train"].append(LabelledImage("coral_x", "coral", boxes, image=img))
    best, ims, dets = _rule_candidates(V6, parts, (1.2, 1.5), log=lambda *a: None)
    assert sorted(best) == sorted(dets) == [1.2, 1.5]
    # the MarDCT training and validation images only: not CORAL, never the held-out part
    assert [im.name for im in ims] == [im.name for im in parts["train"][:-1] + parts["val"]]
    for sf, d in dets.items():
        b = best[sf]
        assert (d.params.scale_factor, d.params.min_neighbors, d.params.neighbors_size_exp) == (
            b["scale_factor"], b["min_neighbors"], b["neighbors_size_exp"])
        assert d.params.grid_step_px == 2  # v6's grid, from its JSON
    # the two rules report these very candidates
    r = played_speed_settings(V6, parts, scale_factors=(1.2, 1.5), margin_fps=0.0, size=(176, 144), passes=1,
                              log=lambda *a: None)
    r14 = speed_settings(V6, parts, scale_factors=(1.2, 1.5), target_fps=0.0, size=(176, 144), passes=1,
                         log=lambda *a: None)
    for rr in (r, r14):
        assert [(c["scale_factor"], c["min_neighbors"], c["score"]) for c in rr["candidates"]] == [
            (sf, best[sf]["min_neighbors"], best[sf]["score"]) for sf in sorted(best)]


def test_played_timing_rotates_the_order_of_the_candidates():
    log = []

    class _Named:
        def __init__(self, name):
            self.name = name

        def reset(self):
            log.append((self.name, "reset"))

        def detect(self, frame):
            log.append((self.name, frame.index))

    seqs = [[np.zeros((8, 8), np.uint8)] * 3, [np.zeros((8, 8), np.uint8)] * 2]
    out = played_cpu_s({k: _Named(k) for k in "abc"}, seqs, passes=2)
    assert all([len(p) for p in out[k]] == [5, 5] for k in "abc")
    calls = [e for e in log if e[1] != "reset"]
    assert calls[:3] == [("a", 0), ("b", 0), ("c", 0)]  # one warm-up call each
    played = calls[3:]
    assert len(played) == 3 * 5 * 2
    orders = ["".join(n for n, _ in played[i:i + 3]) for i in range(0, len(played), 3)]
    # frame by frame the first candidate moves on, across sequences and passes
    assert orders == ["abc", "bca", "cab"] * 3 + ["abc"]
    for i in range(0, len(played), 3):  # the three calls of a step are on the same frame
        assert len({f for _, f in played[i:i + 3]}) == 1
