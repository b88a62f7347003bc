"""`atlas run` as a user runs it: real processes, real missions, exit codes and trace files."""

from __future__ import annotations

import json
import signal
import subprocess
import time

from atlas_rap.sequencer import EVENTS
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

SITE_VISIT = "rap_library/missions/site-visit.rap"
GRIPPER_BROKEN = "rap_library/missions/gripper-broken.rap"


def read_trace(path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def test_a_mission_that_succeeds_exits_0_with_a_live_trace_and_a_summary():
    done = atlas("run", SITE_VISIT, cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert "▶ [3] (visit-site hull-3 spare-pump) method 1 (attempt 1)" in done.stdout
    assert "(navigate-to hull-7) method around (attempt 2)" in done.stdout  # recovered from the debris
    assert "2 of 2 posted tasks succeeded in 32 s simulated" in done.stdout
    assert_no_traceback(done)


def test_the_trace_file_follows_the_language_contract(tmp_path):
    trace = tmp_path / "out.jsonl"
    done = atlas("run", SITE_VISIT, "--quiet", "--trace", str(trace), cwd=REPO)
    assert done.returncode == 0, done.stderr
    records = read_trace(trace)
    times = [r["t"] for r in records]
    assert times == sorted(times)
    assert {r["event"] for r in records} <= set(EVENTS)
    for record in records:
        if record["event"].startswith("task-") or record["event"] == "method-selected":
            assert isinstance(record["id"], int) and record["task"].startswith("(")
    methods = [r for r in records if r["event"] == "method-selected"]
    assert all({"method", "attempt"} <= set(r) for r in methods)
    assert {"method": "around", "attempt": 2} in [{"method": r["method"], "attempt": r["attempt"]}
                                                  for r in methods if r["task"] == "(navigate-to hull-7)"]
    asserted = [r["fact"] for r in records if r["event"] == "fact-asserted"]
    assert "(fault hull-7 light)" in asserted
    enabled = [r["skill"] for r in records if r["event"] == "skill-enabled"]
    disabled = [r["skill"] for r in records if r["event"] == "skill-disabled"]
    assert sorted(enabled) == sorted(disabled)  # no skill left running


def test_the_same_mission_gives_the_same_trace_file_byte_for_byte(tmp_path):
    first, second = tmp_path / "1.jsonl", tmp_path / "2.jsonl"
    for path in (first, second):
        assert atlas("run", SITE_VISIT, "-q", "--seed", "7", "--trace", str(path), cwd=REPO).returncode == 0
    assert first.read_bytes() == second.read_bytes()


def test_a_failing_mission_exits_1_with_the_chain_down_to_the_skill_and_keeps_its_trace(tmp_path):
    trace = tmp_path / "fail.jsonl"
    done = atlas("run", GRIPPER_BROKEN, "-q", "--trace", str(trace), cwd=REPO)
    assert done.returncode == 1
    assert_no_traceback(done)
    chain = done.stdout[done.stdout.index("✗ (visit-site hull-7 filter) failed"):]
    for link in ("gave up after 3 attempts", "step t2 (attach-at-site hull-7): the subtask failed",
                 "method 2: a step failed", "skill (grip-attach hull-7): finished :fail"):
        assert link in chain
    records = read_trace(trace)
    assert records[-1]["event"] == "task-failed" and records[-1]["task"] == "(visit-site hull-7 filter)"


def test_quiet_prints_only_the_summary():
    done = atlas("run", SITE_VISIT, "--quiet", cwd=REPO)
    assert done.returncode == 0
    assert done.stdout.splitlines()[0].startswith(SITE_VISIT + ": 2 of 2 posted tasks succeeded")
    assert "method" not in done.stdout


def test_agenda_and_memory_are_printed_at_the_end_on_request():
    done = atlas("run", SITE_VISIT, "-q", "--agenda", "--memory", cwd=REPO)
    assert "✓ [1] (service-round) succeeded method 1 (attempt 1)" in done.stdout
    assert "✓ [9] (navigate-to hull-7) succeeded method around (attempt 2)" in done.stdout
    assert "(reported hull-7)" in done.stdout and "(route-blocked hull-7)" in done.stdout


def test_bad_input_gets_a_located_message_and_exit_1(tmp_path):
    (tmp_path / "m.rap").write_text("(define-rap (go) (method (task-net (fly-to lab))))\n(post (go))\n",
                                    encoding="utf-8")
    done = atlas("run", "m.rap", "--world", "none", cwd=tmp_path)
    assert done.returncode == 1
    assert "m.rap:1:36: error: 'fly-to' is neither a RAP nor a skill" in done.stderr
    assert_no_traceback(done)


def test_an_unknown_world_is_a_clear_error(tmp_path):
    done = atlas("run", SITE_VISIT, "--world", "atlantis", cwd=REPO)
    assert done.returncode == 1
    assert "atlantis" in done.stderr and "lab-corridor-office" in done.stderr  # the worlds that ship
    assert_no_traceback(done)


def wait_for_line(path, text: str, process: subprocess.Popen, timeout: float = 60.0) -> None:
    """Poll the file ``path`` until a line of it holds ``text`` (fails if the process ends first or time runs out)."""
    deadline = time.monotonic() + timeout
    while text not in path.read_text(encoding="utf-8"):
        assert process.poll() is None, f"the run ended before {text!r}:\n{path.read_text(encoding='utf-8')}"
        assert time.monotonic() < deadline, f"no {text!r} within {timeout} s"
        time.sleep(0.05)


def test_ctrl_c_stops_the_run_with_130_and_keeps_the_trace(tmp_path):
    trace, live = tmp_path / "interrupted.jsonl", tmp_path / "live.txt"
    with live.open("w", encoding="utf-8") as stdout:
        process = subprocess.Popen(atlas_command("run", SITE_VISIT, "--realtime", "--trace", str(trace)),
                                   cwd=REPO, env=ENV, stdout=stdout, stderr=subprocess.PIPE, text=True)
    try:  # the trace file is written whole at the end: its live view on stdout shows the record as it comes
        wait_for_line(live, "(navigate-to hull-3) succeeded", process)
    finally:
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=20)
    assert process.returncode == 130, err
    assert "(interrupted)" in live.read_text(encoding="utf-8")
    records = read_trace(trace)
    assert any(r["event"] == "task-succeeded" and r["task"] == "(navigate-to hull-3)" for r in records)
    assert not any(r["task"] == "(service-round)" for r in records if r["event"] == "task-succeeded")


def test_a_run_whose_task_is_done_before_it_starts_prints_no_empty_primary_layer_line(tmp_path):
    mission = tmp_path / "already.rap"
    mission.write_text('(include "' + (REPO / "rap_library" / "navigation.rap").as_posix() + '")\n'
                       "(define-rap (stay) (succeed (at robot lab)) (method (task-net (t1 (go-to office)))))\n"
                       "(post (stay))\n")
    done = atlas("run", str(mission), "--quiet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "(stay) succeeded at 0 s" in done.stdout
    assert all(line.strip() != "primary layer:" for line in done.stdout.splitlines())
