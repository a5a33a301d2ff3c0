"""``seawatch train-cascade``: --out is required and a shipped model is overwritten only with
--force (no data needed: every case stops before training)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import seawatch.detect.cascade as cascade_mod
from seawatch.cli import EXIT_FAIL, main

MODELS = Path(__file__).resolve().parent.parent / "seawatch" / "models"


@pytest.fixture()
def shipped(tmp_path, monkeypatch):
    """A models folder standing in for seawatch/models/ (a copy of the default's files), so that
    nothing here can touch the real one; and an empty data folder."""
    models = tmp_path / "pkg" / "models"
    models.mkdir(parents=True)
    for suffix in (".xml", ".json"):
        shutil.copyfile(MODELS / f"boat_cascade{suffix}", models / f"boat_cascade{suffix}")
    monkeypatch.setattr(cascade_mod, "default_model_path", lambda: models / "boat_cascade.xml")
    data = tmp_path / "data"
    data.mkdir()
    return models, data


def _snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.parametrize("extra", [[], ["--select-only"]])
def test_out_is_required(shipped, capsys, extra):
    models, data = shipped
    before = _snapshot(models)
    assert main(["train-cascade", "--data", str(data), "--no-sim", *extra]) == EXIT_FAIL
    err = capsys.readouterr().err
    assert "--out is required" in err and "/tmp/" in err and "seawatch/models" in err
    assert _snapshot(models) == before


@pytest.mark.parametrize("name", ["boat_cascade.xml", "boat_cascade.json", "sub/../boat_cascade.xml"])
@pytest.mark.parametrize("extra", [[], ["--select-only"]])
def test_a_shipped_model_is_not_overwritten_without_force(shipped, capsys, name, extra):
    models, data = shipped
    before = _snapshot(models)
    # a JSON path names the same model (the XML beside it is written, and the JSON)
    out = models / name
    assert main(["train-cascade", "--data", str(data), "--no-sim", "--out", str(out), *extra]) == EXIT_FAIL
    err = capsys.readouterr().err
    assert "--out" in err and "would overwrite" in err and "--force" in err
    assert _snapshot(models) == before


def test_frames_training_is_guarded_too(shipped, capsys, tmp_path):
    models, _ = shipped
    frames = tmp_path / "frames"
    frames.mkdir()
    before = _snapshot(models)
    assert main(["train-cascade", "--frames", str(frames), "--out", str(models / "boat_cascade.xml")]) == EXIT_FAIL
    assert "--force" in capsys.readouterr().err
    assert _snapshot(models) == before
    # with --out elsewhere the guard is passed and the empty folder is reported
    assert main(["train-cascade", "--frames", str(frames), "--out", str(tmp_path / "b.xml")]) == EXIT_FAIL
    err = capsys.readouterr().err
    assert "no annotated" in err and "--force" not in err


def test_force_or_a_new_file_passes_the_guard(shipped, capsys):
    models, data = shipped
    before = _snapshot(models)
    # --force: the guard lets it through; it then stops at the missing data, before writing
    assert main(["train-cascade", "--data", str(data), "--no-sim", "--select-only", "--force",
                 "--out", str(models / "boat_cascade.xml")]) == EXIT_FAIL
    err = capsys.readouterr().err
    assert "would overwrite" not in err and "MarDCT frames folder not found" in err
    # a new file in the models folder overwrites nothing: not refused
    assert main(["train-cascade", "--data", str(data), "--no-sim", "--select-only",
                 "--out", str(models / "boat_cascade_new.xml")]) == EXIT_FAIL
    err = capsys.readouterr().err
    assert "would overwrite" not in err and "no model at" in err
    assert _snapshot(models) == before


def test_help_documents_out_and_force(capsys):
    with pytest.raises(SystemExit):
        main(["train-cascade", "--help"])
    out = capsys.readouterr().out
    assert "--force" in out and "required" in out
