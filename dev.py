#!/usr/bin/env python3
"""Set up seawatch in a local virtual environment and run a task; needs only Python 3.11+ and pip.

    python3 dev.py demo      set up, then run the built-in demo scene (seawatch demo)
    python3 dev.py test      set up, then run the test suite (pytest)
    python3 dev.py bench     set up, then run the benchmarks (seawatch bench)
    python3 dev.py setup     only set up

Extra arguments after the task go to the command, e.g. ``python3 dev.py test -k camera``.
The environment lives in ``.venv`` beside this file and is reinstalled when ``pyproject.toml``
changes.  Set ``SEAWATCH_VENV`` to use another folder.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = Path(os.environ.get("SEAWATCH_VENV", ROOT / ".venv"))
TASKS = {
    "demo": ["-m", "seawatch", "demo"],
    "test": ["-m", "pytest"],
    "bench": ["-m", "seawatch", "bench"],
    "setup": None,
}


def _python() -> Path:
    return VENV / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def setup() -> Path:
    if sys.version_info < (3, 11):
        sys.exit(f"seawatch needs Python 3.11 or newer; this is {sys.version.split()[0]}")
    py = _python()
    digest = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    stamp = VENV / ".seawatch-installed"
    if py.exists() and stamp.exists() and stamp.read_text().strip() == digest:
        return py
    if not py.exists():
        print(f"[dev] creating virtual environment {VENV}", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    print("[dev] installing seawatch and its pinned dependencies (first time: a few minutes)", flush=True)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "--upgrade", "pip"], check=True)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "-e", f"{ROOT}[test]"], check=True)
    stamp.write_text(digest + "\n")
    return py


def main(argv: list[str]) -> int:
    if not argv or argv[0] not in TASKS:
        print(__doc__)
        return 2
    task, extra = argv[0], argv[1:]
    py = setup()
    if TASKS[task] is None:
        return 0
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    return subprocess.run([str(py), *TASKS[task], *extra], cwd=ROOT, env=env).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
