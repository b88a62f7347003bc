"""Processes of `atlas` on the skill bus, for the Zenoh tests: each on ports of its own,
their output gathered as it comes so a test waits on a line, not on a clock."""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest
from cli_process import ENV, REPO, atlas_command

DELIVER = str(REPO / "rap_library" / "missions" / "deliver.rap")
BUS_ENV = {**ENV, "PYTHONUNBUFFERED": "1"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Running:
    """A process whose output lines are gathered as they come, to wait on."""

    def __init__(self, *args: str, cwd: Path) -> None:
        self.proc = subprocess.Popen(atlas_command(*args), cwd=cwd, env=BUS_ENV, text=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
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

    @property
    def output(self) -> str:
        return "".join(self.lines)

    def kill(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=10)


@pytest.fixture
def processes():
    started: list[Running] = []
    yield started
    for running in started:
        running.kill()
