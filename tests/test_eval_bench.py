"""The benchmark table and the metrics benchmark (quick mode) through the harness."""

import json
import os

import pytest

from seawatch.eval.bench import format_table, run_benchmarks


def test_format_table_blocks_refs_and_numbers():
    rows = [
        {"benchmark": "a", "dataset": "d", "method": "m", "metric": "IDSW", "value": 107.0, "unit": ""},
        {"benchmark": "a", "dataset": "d", "method": "m", "metric": "fps", "value": 12.345, "unit": "fps",
         "ref": 15.5},
        {"benchmark": "b", "dataset": "d", "method": "m", "metric": "s", "value": 1.13, "unit": "s", "target": 5.0},
        {"benchmark": "b", "dataset": "d", "method": "m", "metric": "F1", "value": None, "unit": ""},
    ]
    lines = format_table(rows).splitlines()
    assert lines[0].split() == ["benchmark", "dataset", "method", "metric", "value", "unit", "ref"]
    assert lines[2].split()[-1] == "107"  # whole numbers without decimals
    assert lines[3].split()[-1] == "15.5" and "12.3" in lines[3]
    assert lines[4] == ""  # a blank line between benchmarks
    assert lines[5].endswith("target 5")
    assert "n/a" in lines[6]
    assert format_table([]) == "(no figures recorded)"


def test_metrics_benchmark_quick(tmp_path):
    rows = run_benchmarks(only=["metrics"], results_dir=tmp_path, quick=True, command="test", echo=lambda *a: None)
    by = {(r["method"], r["metric"]): r["value"] for r in rows}
    assert by[("seawatch.eval", "s_all_metrics")] < 5.0
    assert by[("seawatch.eval.clear_mot", "speedup_vs_peer")] > 0
    assert 0.5 < by[("seawatch.eval", "MOTA")] < 1.0
    saved = json.loads((tmp_path / "metrics.json").read_text())
    assert len(saved) == len(rows) and all(r["benchmark"] == "metrics" for r in saved)
    assert len((tmp_path / "metrics.jsonl").read_text().splitlines()) == len(rows)
    with pytest.raises(SystemExit, match="unknown benchmark"):
        run_benchmarks(only=["no-such-benchmark"], results_dir=tmp_path, echo=lambda *a: None)


def test_commit_field_ignores_results_written_by_earlier_runs(tmp_path):
    """A checkout whose only changes are benchmark results is not "-dirty"; a code change is."""
    import shutil
    import subprocess

    from seawatch.eval.bench import _git_commit

    if shutil.which("git") is None:
        pytest.skip("git not installed")

    def git(*args):
        subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True,
                       env={"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
                            "GIT_COMMITTER_EMAIL": "t@t", "HOME": str(tmp_path), "PATH": os.environ["PATH"]})

    (tmp_path / "benchmarks" / "results").mkdir(parents=True)
    (tmp_path / "benchmarks" / "results" / "x.jsonl").write_text("{}\n")
    (tmp_path / "code.py").write_text("a = 1\n")
    git("init", "-q")
    git("add", "-A")
    git("commit", "-q", "-m", "c")
    head = _git_commit(tmp_path)
    assert head != "unknown" and not head.endswith("-dirty")
    (tmp_path / "benchmarks" / "results" / "x.jsonl").write_text("{}\n{}\n")  # a later run appended
    assert _git_commit(tmp_path) == head
    (tmp_path / "code.py").write_text("a = 2\n")
    assert _git_commit(tmp_path) == head + "-dirty"
