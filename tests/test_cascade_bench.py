"""The detection bench's choice of models and settings to run (benchmarks/bench_detection.py),
on a folder of model files built here (no data, no bench run)."""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "seawatch" / "models"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_detection_under_test",
                                                  ROOT / "benchmarks" / "bench_detection.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _write(folder: Path, name: str, xml_src: Path, meta: dict) -> Path:
    xml = folder / f"{name}.xml"
    shutil.copyfile(xml_src, xml)
    xml.with_suffix(".json").write_text(json.dumps(meta), encoding="utf-8")
    return xml


def _table(rows: dict) -> dict:
    return {k: {"score": v} for k, v in rows.items()}


@pytest.fixture()
def folder(tmp_path):
    """The session 15 layout: the default and v6s15 the same model, v6 and v6fast its cascade at
    other settings, v2 another cascade; v5 absent."""
    v6_xml, v2_xml = MODELS / "boat_cascade_v6.xml", MODELS / "boat_cascade_v2.xml"
    fast = {"min_neighbors": 6, "scale_factor": 1.3, "neighbors_size_exp": 0.0, "grid_step_px": 2}
    _write(tmp_path, "boat_cascade", v6_xml, {"detector": fast, "speed_selection": {}})
    _write(tmp_path, "boat_cascade_v6s15", v6_xml, {"detector": dict(fast), "note": "other keys may differ"})
    _write(tmp_path, "boat_cascade_v6", v6_xml, {
        "detector": {"min_neighbors": 16, "scale_factor": 1.1, "neighbors_size_exp": 0.0, "grid_step_px": 2},
        "validation": _table({"sf1.1_mn16_exp0": 0.80, "sf1.1_mn8_exp0": 0.70, "sf1.2_mn6_exp0": 0.77,
                              "sf1.2_mn4_exp0.5": 0.60, "sf1.3_mn6_exp0": 0.73})})
    _write(tmp_path, "boat_cascade_v6fast", v6_xml, {
        "detector": {"min_neighbors": 4, "scale_factor": 1.5, "neighbors_size_exp": 0.0, "grid_step_px": 2}})
    _write(tmp_path, "boat_cascade_v2", v2_xml, {
        "detector": {"min_neighbors": 48, "scale_factor": 1.1, "neighbors_size_exp": 1.0},
        "validation": _table({"sf1.1_mn48_exp1": 0.82, "sf1.4_mn8_exp0": 0.5})})
    return tmp_path


def test_alternatives_sharing_the_default_cascade_with_other_settings_are_kept(bench, folder):
    model = folder / "boat_cascade.xml"
    alts = bench._alternatives(model)
    # v6 and v6fast share the default's XML but not its settings: they are run (the rule's
    # "half of v6's held-out F1" needs v6's rows); v6s15 is the default itself
    assert sorted(alts) == ["v2", "v6", "v6fast"]
    assert alts["v6"] == folder / "boat_cascade_v6.xml"
    assert bench._identical_alternatives(model) == ["boat_cascade_v6s15.xml"]
    ident = bench._default_id(model)
    assert ident["model"] == "boat_cascade.xml" and ident["identical_to"] == "boat_cascade_v6s15.xml"
    assert ident["settings"] == ("window 30x15, scale factor 1.3, min_neighbors 6, size exponent 0, "
                                 "2 px grid at every scale")
    # v6s15 at other settings than the default's is an alternative again
    (folder / "boat_cascade_v6s15.json").write_text(json.dumps({"detector": {**json.loads(
        (folder / "boat_cascade.json").read_text())["detector"], "min_neighbors": 7}}))
    assert "v6s15" in bench._alternatives(model) and bench._identical_alternatives(model) == []


def test_default_without_a_validation_table_takes_that_of_its_cascade(bench, folder):
    model = folder / "boat_cascade.xml"
    alts = bench._alternatives(model)
    # v2 comes first and has a table, but another cascade: only v6's table stands for the default
    cands = [alts["v2"], alts["v6fast"], alts["v6"]]
    got = bench._best_per_scale_factor(model, cands)
    # the default's own scale factor (1.3) is left out; per other scale factor the best score
    assert got == {1.1: {"scale_factor": 1.1, "min_neighbors": 16, "neighbors_size_exp": 0.0},
                   1.2: {"scale_factor": 1.2, "min_neighbors": 6, "neighbors_size_exp": 0.0}}
    assert bench._validation_source(model, cands) == folder / "boat_cascade_v6.json"
    # without candidates, or with only other cascades, there is no table
    assert bench._best_per_scale_factor(model) == {}
    assert bench._best_per_scale_factor(model, [alts["v2"]]) == {}
    # a model with its own table uses it, leaving out its own scale factor
    assert bench._best_per_scale_factor(alts["v6"]) == {
        1.2: {"scale_factor": 1.2, "min_neighbors": 6, "neighbors_size_exp": 0.0},
        1.3: {"scale_factor": 1.3, "min_neighbors": 6, "neighbors_size_exp": 0.0}}
    assert sorted(bench._best_per_scale_factor(alts["v2"], cands)) == [1.4]
