"""Session 14's rule for speed settings (seawatch.train.scanstats.speed_settings) on synthetic frames."""

from __future__ import annotations

from pathlib import Path

from seawatch.train.samples import LabelledImage
from seawatch.train.scanstats import choose_speed_setting, speed_settings
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
