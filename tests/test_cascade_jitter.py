"""The positives' scale and shift jitter: set by ``train-cascade --scale-jitter / --shift-jitter``,
carried by ``TrainSettings`` to the augmentation, recorded in the model's JSON."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from seawatch.train.samples import LabelledImage, extract_windows
from seawatch.train.trainer import TrainSettings, collect_positives


def _one_boat_image():
    """A bright 40x20 box on a dark, gently textured background."""
    rng = np.random.default_rng(0)
    img = (40 + rng.integers(0, 6, (240, 320))).astype(np.uint8)
    img[110:130, 140:180] = 200
    return LabelledImage("one", "sim", np.array([[140.0, 110.0, 40.0, 20.0]]), image=img, group="g", order=0.0)


def _box_extent(wins):
    """Sub-pixel width and centre (window pixels) of the bright box in each window."""
    prof = wins.astype(float).mean(axis=1)  # column profile (N, W)
    lo, hi = prof.min(axis=1, keepdims=True), prof.max(axis=1, keepdims=True)
    p = (prof - lo) / np.maximum(hi - lo, 1e-9)
    width = p.sum(axis=1)
    centre = (p * np.arange(p.shape[1])).sum(axis=1) / width
    return width, centre


def _positives(scale_jitter, shift_jitter):
    s = TrainSettings(width_px=60, height_px=30, n_aug={"sim": 301}, max_positives=10_000, lowres_prob=0.0,
                      scale_jitter=scale_jitter, shift_jitter=shift_jitter, seed=0)
    pos, _ = collect_positives([_one_boat_image()], s, np.random.default_rng(5), log=lambda m: None)
    return pos[1:]  # the first copy is the plain cut


def test_scale_jitter_reaches_the_augmentation():
    spread = {}
    for sj in (0.0, 0.08, 0.14):
        w, _ = _box_extent(_positives(sj, 0.0))
        spread[sj] = float(np.std(np.log(w)))
    # log-uniform in +-a has a standard deviation of a / sqrt(3): 0.046 at 0.08, 0.081 at 0.14
    assert spread[0.0] < 0.01
    assert spread[0.08] == pytest.approx(0.08 / np.sqrt(3), rel=0.2)
    assert spread[0.14] == pytest.approx(0.14 / np.sqrt(3), rel=0.2)


def test_shift_jitter_reaches_the_augmentation():
    spread = {}
    for sh in (0.0, 0.06, 0.12):
        _, c = _box_extent(_positives(0.0, sh))
        spread[sh] = float(np.std(c))
    # uniform in +-a of the 60 px window: standard deviation 60 a / sqrt(3) (2.1 px at 0.06)
    assert spread[0.0] < 0.1
    assert spread[0.06] == pytest.approx(60 * 0.06 / np.sqrt(3), rel=0.2)
    assert spread[0.12] == pytest.approx(60 * 0.12 / np.sqrt(3), rel=0.2)


def test_defaults_are_the_augmentations_own():
    """Every existing model's command (no jitter options) trains with the jitter it was trained with."""
    sig = inspect.signature(extract_windows).parameters
    assert TrainSettings().scale_jitter == sig["scale_jitter"].default == 0.08
    assert TrainSettings().shift_jitter == sig["shift_jitter"].default == 0.06


def _run_cli(monkeypatch, tmp_path, extra):
    import seawatch.train.recipe as recipe
    from seawatch import cli

    seen = {}

    def fake_train(data, out, settings, **kw):
        seen["settings"] = settings
        return {}

    monkeypatch.setattr(recipe, "train_default_model", fake_train)
    rc = cli.main(["train-cascade", "--data", str(tmp_path), "--out", str(tmp_path / "m.xml"), *extra])
    return rc, seen.get("settings")


def test_cli_options_reach_the_settings(monkeypatch, tmp_path):
    rc, s = _run_cli(monkeypatch, tmp_path, [])
    assert rc == 0 and (s.scale_jitter, s.shift_jitter) == (0.08, 0.06)
    rc, s = _run_cli(monkeypatch, tmp_path, ["--scale-jitter", "0.14", "--shift-jitter", "0.07"])
    assert rc == 0 and (s.scale_jitter, s.shift_jitter) == (0.14, 0.07)
    rc, s = _run_cli(monkeypatch, tmp_path, ["--scale-jitter", "-0.1"])
    assert rc != 0 and s is None
