"""The real terminal program, driven through tmux: typing at the prompt, a trace line
appearing above what is being typed, Ctrl-C stopping a :run but not the session,
Ctrl-D leaving and writing the trace that was asked for."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest
from cli_process import REPO

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed on this machine")


class Terminal:
    """A detached tmux session running one command, read with capture-pane.

    Each terminal has a tmux server of its own (``-L``): on the shared default
    server, a test could connect just as the last one's server was exiting
    ("server exited unexpectedly").
    """

    def __init__(self, command: str, cwd: Path, **extra_env: str) -> None:
        self.name = f"atlas-{uuid.uuid4().hex[:8]}"
        env = {"PYTHONPATH": str(REPO), "ATLAS_RAP_DATA_DIR": str(cwd / "data"), "TERM": "xterm-256color",
               "PATH": os.environ.get("PATH", "/usr/bin:/bin"), **extra_env}
        exports = " ".join(f"{k}='{v}'" for k, v in env.items())
        self.tmux = ["tmux", "-L", self.name]
        subprocess.run([*self.tmux, "new-session", "-d", "-s", self.name, "-x", "120", "-y", "40",
                        f"cd '{cwd}' && env {exports} {command}; echo EXITED $?; sleep 30"], check=True)

    def screen(self, styles: bool = False) -> str:
        """What the terminal shows; with ``styles``, its colour and style codes too."""
        return subprocess.run([*self.tmux, "capture-pane", "-p", *(["-e"] if styles else []), "-t", self.name],
                              capture_output=True, text=True).stdout

    def keys(self, *keys: str) -> None:
        subprocess.run([*self.tmux, "send-keys", "-t", self.name, *keys], check=True)

    def type(self, text: str) -> None:
        subprocess.run([*self.tmux, "send-keys", "-t", self.name, "-l", text], check=True)

    def wait_for(self, text: str, timeout: float = 20.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            screen = self.screen()
            if text in screen:
                return screen
            time.sleep(0.1)
        raise AssertionError(f"{text!r} never appeared; the screen was:\n{self.screen()}")

    def close(self) -> None:
        subprocess.run([*self.tmux, "kill-server"], capture_output=True)


@pytest.fixture
def terminal(tmp_path: Path):
    term = Terminal(f"{sys.executable} -m atlas_rap repl --world lab-corridor-office --trace run.jsonl", tmp_path)
    yield term
    term.close()


def test_typing_at_the_prompt_with_a_trace_line_appearing_above_it(terminal: Terminal, tmp_path: Path) -> None:
    terminal.wait_for("atlas>")
    terminal.type("(define-virtual-skill (wave ?who) (after 2 (assert (greeted ?who)) (finish :succeed)))")
    terminal.keys("Enter")
    terminal.wait_for("defined virtual skill (wave ?who)")
    terminal.type("(define-rap (greet ?who)")  # Enter inside an open form continues it
    terminal.keys("Enter")
    terminal.type("(succeed (greeted ?who))")
    terminal.keys("Enter")
    terminal.type("(method (task-net (t1 (wave ?who)))))")
    terminal.keys("Enter")
    screen = terminal.wait_for("defined RAP (greet ?who)")
    assert "...> " in screen  # the continuation prompt of the multi-line form
    terminal.type("(post (greet alice))")
    terminal.keys("Enter")
    terminal.type("(? (gree")  # half typed when the world's clock brings the skill's event
    screen = terminal.wait_for("✓ [1] (greet alice) succeeded")
    lines = [line for line in screen.splitlines() if line.strip()]
    assert lines[-1].startswith("atlas> (? (gree"), screen  # what is being typed stays on the prompt line
    assert any("(greet alice) succeeded" in line for line in lines[:-1])
    terminal.type("ted ?who))")
    terminal.keys("Enter")
    terminal.wait_for("?who = alice")

    terminal.type(":run 100000")
    terminal.keys("Enter")
    terminal.wait_for("running 100000 s of simulated time")  # the run has started: Ctrl-C now stops it
    terminal.keys("C-c")
    terminal.wait_for("interrupted at")
    terminal.type(":agenda")
    terminal.keys("Enter")
    terminal.wait_for("agenda at")  # the session went on

    terminal.keys("C-d")
    terminal.wait_for("EXITED 0")
    records = [json.loads(line) for line in (tmp_path / "run.jsonl").read_text(encoding="utf-8").splitlines()]
    assert any(r["event"] == "task-succeeded" and r["task"] == "(greet alice)" for r in records)


@pytest.mark.parametrize("no_color", [False, True], ids=["colour", "NO_COLOR"])
def test_no_colour_or_style_at_the_prompt_when_no_color_is_set(tmp_path: Path, no_color: bool) -> None:
    env = {"NO_COLOR": "1"} if no_color else {}
    term = Terminal(f"{sys.executable} -m atlas_rap repl", tmp_path, **env)
    try:
        term.wait_for("atlas>")
        term.type("(define-rap (x) (method (task-net (wait-for (t)))))")
        term.keys("Enter")
        term.wait_for("defined RAP (x)")
        styled = term.screen(styles=True)
        assert ("\x1b[" in styled) is not no_color, styled
    finally:
        term.close()
