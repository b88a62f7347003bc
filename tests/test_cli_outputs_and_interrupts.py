"""Every output path behaves the same, every interruption keeps what was asked for, and
nothing is styled where it should not be (NO_COLOR, output that is not a terminal)."""

from __future__ import annotations

import json
import os
import pty
import select
import shutil
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


def _started(args: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(atlas_command(*args), cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**ENV, "PYTHONUNBUFFERED": "1"})


def _interrupted(args: list[str], cwd: Path, ready) -> tuple[int, str, str]:
    """Start ``atlas ARGS``, wait for ``ready(process)``, then Ctrl-C: (exit code, stdout after the wait,
    stderr); never a traceback."""
    process = _started(args, cwd)
    try:
        ready(process)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert "Traceback" not in out + err, err
    return process.returncode, out, err


def _a_line_with(text: str):
    """Ready once the command printed a line holding ``text``."""
    def ready(process: subprocess.Popen) -> None:
        for line in process.stdout:
            if text in line:
                return
        raise AssertionError(f"no line with {text!r}: {process.stderr.read()}")

    return ready


def test_ctrl_c_while_map_build_drives_exits_130_and_still_writes_the_map(tmp_path):
    code, out, err = _interrupted(["map", "build", "--world", "lab-corridor-office", "--out", "built"], tmp_path,
                                  _a_line_with("driving in lab-corridor-office"))  # just before it drives
    assert code == 130, out + err
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


DELIVER = str(REPO / "rap_library" / "missions" / "deliver.rap")


def _temporary_files(folder: Path) -> list[Path]:
    return [path for path in folder.rglob("*") if path.name.endswith(".part")]


def test_ctrl_c_during_a_run_leaves_the_old_trace_until_a_whole_new_one_replaces_it(tmp_path):
    old = b'{"t":0.0,"event":"an older run"}\n'
    (tmp_path / "t.jsonl").write_bytes(old)
    started = _a_line_with("⚙ enable")  # loaded; the run has started when the first skill is enabled

    def ready(process: subprocess.Popen) -> None:
        started(process)
        assert (tmp_path / "t.jsonl").read_bytes() == old  # nothing half-written at the path meanwhile

    code, out, err = _interrupted(["run", DELIVER, "--realtime", "--until", "600", "--trace", "t.jsonl"], tmp_path,
                                  ready)
    assert code == 130, out + err
    text = (tmp_path / "t.jsonl").read_text(encoding="utf-8")
    assert text.endswith("\n")
    records = [json.loads(line) for line in text.splitlines()]
    assert records[0]["event"] != "an older run"
    assert any(r["event"] == "task-halted" and "interrupted" in r["reason"] for r in records)
    assert not _temporary_files(tmp_path)


def test_an_output_that_fails_after_the_run_comes_after_the_summary(tmp_path):
    process = _started(["run", DELIVER, "--realtime", "--until", "2", "--no-prior-map", "--trace", "out/t.jsonl",
                        "--map-out", "out/grid.npz"], tmp_path)
    try:
        process.stdout.readline()  # the run has started
        shutil.rmtree(tmp_path / "out")  # the folder of the outputs goes away while it runs
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert "Traceback" not in out + err, err
    assert process.returncode == 1, out + err
    assert "0 of 1 posted tasks succeeded" in out and "(time limit reached)" in out  # the summary is there
    assert "written to" not in out
    assert err.strip().splitlines() == [
        "--trace out/t.jsonl: cannot write it (No such file or directory)",
        "--map-out out/grid.npz: cannot write it (No such file or directory)",
    ]
    assert not (tmp_path / "out").exists()


def test_ctrl_c_in_the_experiment_stops_it_and_writes_what_it_has_marked_incomplete(tmp_path):
    code, out, err = _interrupted(["experiment", "skill-acquisition", "--seed", "0", "--runs", "4",
                                   "--obstacles", "none", "--out", "out"],
                                  tmp_path, _a_line_with("run 1: map quality"))  # run 2 drives
    assert code == 130, out + err
    data = json.loads((tmp_path / "out" / "figures.json").read_text(encoding="utf-8"))
    assert data["complete"] is False and data["runs_asked"] == 4
    done = len(data["runs"])
    assert 1 <= done < 4
    assert data["incomplete"] == f"interrupted after run {done} of 4"
    assert f"interrupted after run {done} of 4: the results are marked incomplete" in err
    assert len((tmp_path / "out" / "runs.csv").read_text().splitlines()) == 1 + done
    for name in ("fig12a-map-quality", "fig12b-durations", "fig13a-layers-per-run"):
        assert (tmp_path / "out" / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not _temporary_files(tmp_path)


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


def test_atlas_plan_json_stopped_with_ctrl_c_prints_an_interrupted_result(tmp_path):
    from pddl_problems import triangle_tireworld_problem

    domain, problem = triangle_tireworld_problem(tmp_path, 60)  # a search far longer than the test

    def searching(process: subprocess.Popen) -> None:  # past start-up and reading: 1.5 s of CPU
        while _cpu_seconds(process.pid) < 1.5:
            assert process.poll() is None, process.stderr.read()
            select.select([], [], [], 0.05)

    code, out, err = _interrupted(["plan", "--pddl", str(domain), str(problem), "--json"], tmp_path, searching)
    assert code == 130, out + err
    result = json.loads(out)
    assert result["status"] == "interrupted" and result["steps"] == []
    assert "interrupted" in result["reason"] and result["limits"]["timeout_s"] == 60
