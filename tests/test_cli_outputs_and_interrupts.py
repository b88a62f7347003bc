"""Every output path behaves the same, every interruption keeps what was asked for, and
nothing is styled where it should not be (NO_COLOR, output that is not a terminal)."""

from __future__ import annotations

import os
import pty
import select
import signal
import subprocess
from pathlib import Path

import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

GRIPPER_BROKEN = str(REPO / "rap_library" / "missions" / "gripper-broken.rap")
SITE_VISIT = str(REPO / "rap_library" / "missions" / "site-visit.rap")
SMALL_MAP = str(REPO / "worlds" / "maps" / "small-office-map.yaml")


def test_a_trace_in_a_missing_folder_makes_the_folder(tmp_path):
    done = atlas("run", SITE_VISIT, "--quiet", "--trace", "nodir/sub/t.jsonl", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "nodir" / "sub" / "t.jsonl").read_text(encoding="utf-8").count("\n") > 10


@pytest.mark.parametrize("args", [
    ("run", SITE_VISIT, "--quiet", "--trace", "afile/t.jsonl"),
    ("repl", "--trace", "afile/t.jsonl"),
    ("map", "abstract", SMALL_MAP, "--out", "afile/levels"),
    ("map", "render", SMALL_MAP, "--out", "afile/m.png"),
], ids=["run --trace", "repl --trace", "map abstract --out", "map render --out"])
def test_an_output_that_cannot_be_created_is_a_one_line_error(tmp_path, args):
    (tmp_path / "afile").write_text("in the way\n", encoding="utf-8")
    done = atlas(*args, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    (line,) = done.stderr.strip().splitlines()
    assert "cannot create the folder" in line and "afile is a file" in line


def test_map_outputs_in_missing_folders_are_made(tmp_path):
    done = atlas("map", "render", SMALL_MAP, "--out", "pictures/today/map.png", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "pictures" / "today" / "map.png").stat().st_size > 0


def test_the_repl_saves_into_a_missing_folder(tmp_path):
    done = subprocess.run(atlas_command("repl"), input="(assert (at robot lab))\n:save saved/today/s.rap\n",
                          cwd=tmp_path, capture_output=True, text=True, env=ENV, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "(at robot lab)" in (tmp_path / "saved" / "today" / "s.rap").read_text(encoding="utf-8")


def test_ctrl_c_while_map_build_drives_exits_130_and_still_writes_the_map(tmp_path):
    process = subprocess.Popen(atlas_command("map", "build", "--world", "lab-corridor-office", "--out", "built"),
                               cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**ENV, "PYTHONUNBUFFERED": "1"})
    try:
        first = process.stdout.readline()  # printed just before the robot starts to drive
        assert first.startswith("driving in lab-corridor-office"), first
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert "Traceback" not in out + err, err
    assert process.returncode == 130, out + err
    assert "mission interrupted at" in out
    assert (tmp_path / "built" / "occupancy.yaml").is_file() and (tmp_path / "built" / "occupancy.npz").is_file()


def _on_a_terminal(args: list[str], cwd: Path, no_color: bool, stdin: str | None = None) -> str:
    """Run atlas with stdout and stderr on a pseudo-terminal; what it wrote there."""
    leader, follower = pty.openpty()
    env = {**ENV, "TERM": "xterm-256color", "COLUMNS": "200"}
    if no_color:
        env["NO_COLOR"] = "1"
    process = subprocess.Popen(atlas_command(*args), cwd=cwd, stdin=subprocess.PIPE if stdin is not None else None,
                               stdout=follower, stderr=follower, env=env)
    os.close(follower)
    if stdin is not None:
        process.stdin.write(stdin.encode())
        process.stdin.close()
    chunks = []
    while True:
        ready, _, _ = select.select([leader], [], [], 60)
        if not ready:
            break
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # the program closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    process.wait(timeout=60)
    os.close(leader)
    return b"".join(chunks).decode("utf-8", "replace")


@pytest.mark.parametrize("args, stdin", [
    (["run", GRIPPER_BROKEN], None),
    (["check", GRIPPER_BROKEN, str(REPO / "rap_library" / "navigation.rap")], None),
    (["repl"], "(post (frobnicate))\n(assert (at robot lab))\n"),
], ids=["run", "check", "repl"])
def test_no_colour_or_style_on_a_terminal_when_no_color_is_set(tmp_path, args, stdin):
    styled = _on_a_terminal(args, tmp_path, no_color=False, stdin=stdin)
    plain = _on_a_terminal(args, tmp_path, no_color=True, stdin=stdin)
    assert "\x1b[" in styled  # on a terminal, without NO_COLOR, there is colour
    assert "\x1b[" not in plain, plain
    assert len(plain.strip()) > 20


def test_nothing_is_styled_when_the_output_is_not_a_terminal(tmp_path):
    done = atlas("run", GRIPPER_BROKEN, cwd=tmp_path)
    assert done.returncode == 1
    assert "\x1b[" not in done.stdout + done.stderr
