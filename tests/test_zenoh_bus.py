"""Skills on their own host over Eclipse Zenoh, as a user runs them: `atlas skills serve` and
`atlas run --connect` as real processes on loopback, each test on ports of its own.

Every wait is on a condition with a deadline (a line of output, a process ending), never a
fixed sleep; subprocess timeouts guard against hangs."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import pytest
from bus_processes import DELIVER, Running, free_port, processes  # noqa: F401  (processes: a fixture)
from cli_process import REPO, assert_no_traceback, atlas

zenoh = pytest.importorskip("zenoh")

SPIN = """(world "lab-corridor-office")
(define-rap (spin ?heading)
  (method (task-net (sequence (t1 (turn-to ?heading))))))
(post (spin 180))
"""


def host(processes, tmp_path: Path, port: int, robot: str = "robot") -> Running:
    running = Running("skills", "serve", "--listen", f"tcp/127.0.0.1:{port}", "--robot", robot, cwd=tmp_path)
    processes.append(running)
    running.wait_for(f"skill host for robot {robot}")
    return running


def sequencer(processes, tmp_path: Path, *args: str) -> Running:
    running = Running("run", *args, cwd=tmp_path)
    processes.append(running)
    return running


def test_deliver_over_zenoh_gives_the_same_trace_as_in_one_process_and_anyone_can_watch(processes, tmp_path):
    port = free_port()
    host(processes, tmp_path, port)
    watched: list[bytes] = []
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("listen/endpoints", "[]")
    watcher = zenoh.open(config)
    try:
        subscriber = watcher.declare_subscriber("atlas/robot/event/**", zenoh.handlers.Callback(
            lambda sample: watched.append(sample.payload.to_bytes()), indirect=False))
        alone = atlas("run", DELIVER, "--quiet", "--trace", "alone.jsonl", cwd=tmp_path)
        assert alone.returncode == 0, alone.stderr
        remote = sequencer(processes, tmp_path, DELIVER, "--quiet", "--trace", "bus.jsonl",
                           "--connect", f"tcp/127.0.0.1:{port}")
        assert remote.finish() == 0, remote.output
        subscriber.undeclare()
    finally:
        watcher.close()
    assert "Traceback" not in remote.output
    assert (tmp_path / "bus.jsonl").read_bytes() == (tmp_path / "alone.jsonl").read_bytes()
    frames = [json.loads(data) for data in watched]
    done = [m for f in frames for m in f["messages"] if m["type"] == "done"]
    assert [m["call"] for m in done] == [["navigate-to", "office"], ["navigate-to", "lab"]]


def test_a_killed_host_fails_the_waiting_step_within_a_second_and_its_retry_waits_out_the_grace(processes, tmp_path):
    port = free_port()
    served = host(processes, tmp_path, port)
    run = sequencer(processes, tmp_path, DELIVER, "--realtime", "--host-grace", "2",
                    "--connect", f"tcp/127.0.0.1:{port}")
    run.wait_for("enable (navigate-to office)")
    killed = time.monotonic()
    served.kill()
    seen = run.wait_for("skill host lost", timeout=5)
    assert seen - killed < 1.0
    assert run.finish(timeout=30) == 1
    assert "Traceback" not in run.output
    assert "finished :fail: skill host lost" in run.output
    assert "waiting up to 2 s for it to come back" in run.output
    assert "skill host lost (not back within 2 s)" in run.output


def test_a_host_restarted_within_the_grace_serves_the_retry_and_the_mission_succeeds(processes, tmp_path):
    port = free_port()
    (tmp_path / "spin.rap").write_text(SPIN, encoding="utf-8")
    served = host(processes, tmp_path, port)
    run = sequencer(processes, tmp_path, "spin.rap", "--realtime", "--trace", "spin.jsonl",
                    "--connect", f"tcp/127.0.0.1:{port}")
    run.wait_for("enable (turn-to 180)")
    served.kill()
    run.wait_for("skill host lost", timeout=5)
    run.wait_for("waiting up to 30 s")
    again = host(processes, tmp_path, port)
    again.wait_for("session 1 started", timeout=15)
    assert run.finish(timeout=30) == 0, run.output
    assert "(spin 180) succeeded" in run.output
    records = [json.loads(line) for line in (tmp_path / "spin.jsonl").read_text().splitlines()]
    attempts = [r["attempt"] for r in records if r["event"] == "method-selected"]
    assert attempts == [1, 2]  # the failure the loss caused, then one retry that waited for the host
    events = [r["event"] for r in records]
    assert events.index("skill-waiting") < events.index("skill-resumed")
    waited = next(r for r in records if r["event"] == "skill-resumed")["t"] - \
        next(r for r in records if r["event"] == "skill-waiting")["t"]
    assert waited > 0.5  # it waited in time (the host took that long to come back), not in no time


def test_two_robots_on_one_bus_each_do_their_own_steps(processes, tmp_path):
    alice, bob = free_port(), free_port()
    host(processes, tmp_path, alice, "alice")
    host(processes, tmp_path, bob, "bob")
    run = sequencer(processes, tmp_path, str(REPO / "examples" / "two-robots.rap"), "--trace", "two.jsonl",
                    "--connect", f"tcp/127.0.0.1:{alice}", "--connect", f"tcp/127.0.0.1:{bob}",
                    "--robot", "alice", "--robot", "bob")
    assert run.finish() == 0, run.output
    facts = [json.loads(line).get("fact") for line in (tmp_path / "two.jsonl").read_text().splitlines()]
    assert "(done (navigate-to alice office) :succeed)" in facts
    assert "(done (navigate-to bob storeroom) :succeed)" in facts
    assert "(at alice office)" in facts and "(at bob storeroom)" in facts


def test_the_planner_gives_steps_to_two_robots_on_their_own_hosts(processes, tmp_path):
    alice, bob = free_port(), free_port()
    host(processes, tmp_path, alice, "alice")
    host(processes, tmp_path, bob, "bob")
    run = sequencer(processes, tmp_path, str(REPO / "examples" / "two-robot-errands.rap"), "--trace", "plan.jsonl",
                    "--connect", f"tcp/127.0.0.1:{alice}", "--connect", f"tcp/127.0.0.1:{bob}",
                    "--robot", "alice", "--robot", "bob")
    assert run.finish(timeout=60) == 0, run.output
    assert "Traceback" not in run.output
    records = [json.loads(line) for line in (tmp_path / "plan.jsonl").read_text().splitlines()]
    ready = [r for r in records if r["event"] == "plan-ready"]
    assert len(ready) == 1 and ready[0]["agents"] == ["alice", "bob"]
    started = {r["step"]: r for r in records if r["event"] == "plan-step-started"}
    done = {r["step"]: r for r in records if r["event"] == "plan-step-done"}
    assert started and set(done) == set(started)
    assert {r["agent"] for r in done.values()} == {"alice", "bob"}
    for step in done.values():  # each step's RAP drove its own agent, on that agent's host
        assert step["action"].startswith(f"(travel-to {step['agent']} ")
    first: dict[str, float] = {}
    for step in sorted(started.values(), key=lambda r: r["t"]):
        first.setdefault(step["agent"], step["t"])
    assert first["alice"] == first["bob"]  # the two agents' steps run at once
    assert not any(r["event"] in ("plan-step-failed", "replanned", "plan-abandoned") for r in records)
    assert [r["event"] for r in records if r["event"] == "plan-done"] == ["plan-done"]
    facts = [r.get("fact") for r in records]
    assert "(done (navigate-to alice office) :succeed)" in facts
    assert "(done (navigate-to bob storeroom) :succeed)" in facts
    assert (records[-1]["event"], records[-1]["task"]) == ("task-succeeded", "(errands)")


def test_connecting_where_nobody_answers_is_a_clear_error_within_seconds(tmp_path):
    started = time.monotonic()
    done = atlas("run", DELIVER, "--connect", f"tcp/127.0.0.1:{free_port()}", cwd=tmp_path)
    assert time.monotonic() - started < 10
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "no skill host for robot 'robot' answers" in done.stderr
    assert "atlas skills serve" in done.stderr


@pytest.mark.parametrize("args, message", [
    (["--connect", "localhost:7447"], "is not a Zenoh endpoint"),
    (["--connect", "tcp/127.0.0.1:1", "--world", "maze"], "cannot go with --connect"),
    (["--robot", "alice"], "--robot needs --connect"),
])
def test_bad_bus_options_are_clear_errors(tmp_path, args, message):
    done = atlas("run", DELIVER, *args, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode in (1, 2)
    assert message in done.stderr
