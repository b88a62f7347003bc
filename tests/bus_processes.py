"""Processes of `atlas` on the skill bus, for the Zenoh tests: each on ports of its own,
their output gathered as it comes so a test waits on a line, not on a clock.

The processes of a test run keep their token files in a runtime folder of their own
(``ATLAS_RUNTIME_DIR``), as a user's processes on one machine share theirs."""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest
from cli_process import ENV, REPO, atlas_command

DELIVER = str(REPO / "rap_library" / "missions" / "deliver.rap")
RUNTIME = tempfile.mkdtemp(prefix="atlas-runtime-")
BUS_ENV = {**ENV, "PYTHONUNBUFFERED": "1", "ATLAS_RUNTIME_DIR": RUNTIME}
ATTACKER = str(Path(__file__).resolve().parent / "bus_attacker.py")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Running:
    """A process whose output lines are gathered as they come, to wait on."""

    def __init__(self, *args: str, cwd: Path, command: list[str] | None = None, env: dict | None = None,
                 stdin: bool = False) -> None:
        self.proc = subprocess.Popen(command or atlas_command(*args), cwd=cwd, env={**BUS_ENV, **(env or {})},
                                     text=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     stdin=subprocess.PIPE if stdin else subprocess.DEVNULL, start_new_session=True)
        self.lines: list[str] = []
        self.seen: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)
            self.seen.put(line)

    def wait_for(self, text: str, timeout: float = 20.0) -> float:
        """Wait until a line with ``text`` comes out; the monotonic time it was read."""
        deadline = time.monotonic() + timeout
        if any(text in line for line in self.lines):
            return time.monotonic()
        while time.monotonic() < deadline:
            try:
                line = self.seen.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                break
            if text in line:
                return time.monotonic()
        raise AssertionError(f"no {text!r} within {timeout} s; output:\n{self.output}")

    def finish(self, timeout: float = 30.0) -> int:
        return self.proc.wait(timeout=timeout)

    def say(self, line: str) -> None:
        """Write a line to the process's input."""
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def close_input(self) -> None:
        self.proc.stdin.close()

    @property
    def output(self) -> str:
        return "".join(self.lines)

    def kill(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=10)


def attacker(processes: list, tmp_path: Path, mode: str, *args: str) -> Running:
    """A stranger on the bus (``bus_attacker.py``: eclipse-zenoh only), ready."""
    running = Running(cwd=tmp_path, command=[sys.executable, ATTACKER, *args, mode], stdin=True)
    processes.append(running)
    running.wait_for("ready")
    return running


@pytest.fixture
def processes():
    started: list[Running] = []
    yield started
    for running in started:
        running.kill()
