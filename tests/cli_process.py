"""Run the real `atlas` command in a new process, as a user would."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
ENV = {"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}


def atlas_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "atlas_rap", *args]


def atlas(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(atlas_command(*args), cwd=cwd, capture_output=True, text=True, env=ENV)


def assert_no_traceback(done: subprocess.CompletedProcess) -> None:
    assert "Traceback" not in done.stderr + done.stdout, done.stderr
