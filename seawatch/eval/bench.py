"""The benchmark harness behind ``seawatch bench``.

A benchmark is a module ``benchmarks/bench_<name>.py`` at the repository root with

* ``NAME``: short name (``"detection"``), used by ``seawatch bench --only NAME``;
* ``DESCRIPTION``: one line;
* ``run(ctx: BenchContext) -> None``: measures, and calls ``ctx.record(...)`` once per figure.

Each figure is appended as one JSON object per line to ``benchmarks/results/<benchmark>.jsonl``
(``benchmark, dataset, method, metric, value, unit, commit, time, command`` plus any extra
fields), and the figures of the latest run are written to ``benchmarks/results/<benchmark>.json``.
Benchmarks that need real data read ``ctx.data_dir`` and call ``ctx.skip(reason)`` when it is
missing.  Speed figures are medians over repeats, and each is reported beside a peer measured in
the same process.
"""

from __future__ import annotations

import datetime as _dt
import importlib.util
import json
import math
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["BenchContext", "BenchSkipped", "discover", "run_benchmarks", "repo_root", "default_data_dir"]


class BenchSkipped(Exception):
    """Raised by :meth:`BenchContext.skip` when a benchmark cannot run (e.g. no data)."""


def repo_root() -> Path:
    """The repository root (the folder holding ``benchmarks/``)."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        if (parent / "benchmarks").is_dir() and (parent / "pyproject.toml").is_file():
            return parent
    return Path.cwd()


def default_data_dir() -> Path | None:
    """``../shared/data`` beside the repository, when it exists."""
    cand = repo_root().parent / "shared" / "data"
    return cand if cand.is_dir() else None


def _git_commit(root: Path) -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True, timeout=5
        )
        commit = out.stdout.strip() or "unknown"
        # results written by earlier runs (benchmarks/results/) are outputs, not code: they do not
        # make the checkout dirty
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)benchmarks/results"],
            cwd=root, capture_output=True, text=True, timeout=5,
        ).stdout.strip()
        return commit + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


@dataclass
class BenchContext:
    """What a benchmark gets: where the data is, where results go, and a recorder."""

    data_dir: Path | None
    results_dir: Path
    quick: bool = False
    command: str = ""
    commit: str = "unknown"
    benchmark: str = ""
    rows: list[dict[str, Any]] = field(default_factory=list)

    def data(self, *parts: str) -> Path:
        """Path inside the data directory; skips the benchmark when it does not exist."""
        if self.data_dir is None:
            self.skip("no data directory (give --data DIR, or place ../shared/data)")
        p = Path(self.data_dir, *parts)
        if not p.exists():
            self.skip(f"missing {p}")
        return p

    def skip(self, reason: str) -> None:
        raise BenchSkipped(reason)

    def record(
        self,
        dataset: str,
        method: str,
        metric: str,
        value: float,
        unit: str = "",
        **extra: Any,
    ) -> dict[str, Any]:
        """Record one figure (printed in the table and appended to the JSONL file)."""
        v = float(value) if value is not None else float("nan")
        row = {
            "benchmark": self.benchmark,
            "dataset": dataset,
            "method": method,
            "metric": metric,
            "value": None if math.isnan(v) else v,
            "unit": unit,
            "commit": self.commit,
            "time": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "command": self.command,
        }
        row.update(extra)
        self.rows.append(row)
        return row


def discover(root: Path | None = None) -> dict[str, Any]:
    """Load every ``benchmarks/bench_*.py`` module, keyed by its ``NAME``."""
    root = root or repo_root()
    mods: dict[str, Any] = {}
    for path in sorted((root / "benchmarks").glob("bench_*.py")):
        spec = importlib.util.spec_from_file_location(f"seawatch_bench_{path.stem}", path)
        if spec is None or spec.loader is None:
            continue
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod
        spec.loader.exec_module(mod)
        name = getattr(mod, "NAME", path.stem[len("bench_"):])
        mods[name] = mod
    return mods


def _fmt(v: Any) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float) and math.isfinite(v) and v == int(v) and abs(v) < 1e9:
        return str(int(v))
    if isinstance(v, float):
        if math.isnan(v):
            return "n/a"
        if v == 0 or 0.001 <= abs(v) < 100000:
            return f"{v:.4g}" if abs(v) < 10 else f"{v:.1f}"
        return f"{v:.3g}"
    return str(v)


def _ref(r: dict[str, Any]) -> str:
    """The comparison figure of a row: its ``ref`` (a paper's figure), else its ``target``."""
    ref, target = r.get("ref"), r.get("target")
    if ref not in (None, ""):
        return _fmt(ref) if isinstance(ref, (int, float)) else str(ref)
    if target not in (None, ""):
        return "target " + (_fmt(target) if isinstance(target, (int, float)) else str(target))
    return ""


def format_table(rows: list[dict[str, Any]]) -> str:
    """A plain-text table of recorded figures, one block per benchmark.

    Columns: benchmark, dataset, method, metric, value, unit, and ``ref`` (the row's ``ref``
    figure, e.g. the paper's, or else its ``target``).  Values are right-aligned; whole numbers
    print without decimals.
    """
    cols = ["benchmark", "dataset", "method", "metric", "value", "unit", "ref"]
    if not rows:
        return "(no figures recorded)"
    body = []
    for r in rows:
        body.append([str(r.get("benchmark", "")), str(r.get("dataset", "")), str(r.get("method", "")),
                     str(r.get("metric", "")), _fmt(r.get("value")), str(r.get("unit", "") or ""), _ref(r)])
    widths = [max(len(c), *(len(b[i]) for b in body)) for i, c in enumerate(cols)]
    right = {cols.index("value")}

    def line(cells):
        return "  ".join(x.rjust(w) if i in right else x.ljust(w)
                         for i, (x, w) in enumerate(zip(cells, widths))).rstrip()

    lines = [line(cols), "  ".join("-" * w for w in widths)]
    prev = None
    for b in body:
        if prev is not None and b[0] != prev:
            lines.append("")
        prev = b[0]
        lines.append(line(b))
    return "\n".join(lines)


def run_benchmarks(
    only: list[str] | None = None,
    data_dir: Path | None = None,
    results_dir: Path | None = None,
    quick: bool = False,
    command: str = "",
    echo=print,
) -> list[dict[str, Any]]:
    """Run the selected benchmarks, write their results, and return all recorded rows."""
    root = repo_root()
    results_dir = Path(results_dir or root / "benchmarks" / "results")
    results_dir.mkdir(parents=True, exist_ok=True)
    mods = discover(root)
    if only:
        unknown = [n for n in only if n not in mods]
        if unknown:
            raise SystemExit(
                f"seawatch bench: unknown benchmark(s) {', '.join(unknown)}; known: {', '.join(sorted(mods))}"
            )
        mods = {n: mods[n] for n in only}
    commit = _git_commit(root)
    all_rows: list[dict[str, Any]] = []
    for name, mod in mods.items():
        ctx = BenchContext(data_dir, results_dir, quick, command, commit, name)
        t0 = time.perf_counter()
        echo(f"[bench] {name}: {getattr(mod, 'DESCRIPTION', '')}")
        try:
            mod.run(ctx)
            status = "ok"
        except BenchSkipped as exc:
            status = f"skipped: {exc}"
        except Exception as exc:  # a broken benchmark must not hide the others' figures
            status = f"failed: {type(exc).__name__}: {exc}"
        dt = time.perf_counter() - t0
        echo(f"[bench] {name}: {status} ({dt:.1f} s, {len(ctx.rows)} figures)")
        if ctx.rows:
            with open(results_dir / f"{name}.jsonl", "a", encoding="utf-8") as fh:
                for r in ctx.rows:
                    fh.write(json.dumps(r) + "\n")
            (results_dir / f"{name}.json").write_text(json.dumps(ctx.rows, indent=1) + "\n")
        all_rows.extend(ctx.rows)
    return all_rows
