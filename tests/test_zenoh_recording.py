"""Recording a run whose skills run on another host: `atlas skills serve --record` records the world,
`atlas run --connect --record` the trace, both in the same simulated time (Foxglove opens them together).

Real processes on loopback, each test on ports of its own; every wait is on a condition with a
deadline (a line of output, a process ending), never a fixed sleep."""

from __future__ import annotations

import json
import math
import signal
from collections import defaultdict
from pathlib import Path

import pytest
from cli_process import assert_no_traceback, atlas

pytest.importorskip("zenoh")
pytest.importorskip("foxglove")
pytest.importorskip("mcap")

from mcap.reader import make_reader  # noqa: E402
from bus_processes import DELIVER, Running, free_port, processes  # noqa: E402,F401  (processes: a fixture)

from atlas_rap.views.mcap_reader import read_recording  # noqa: E402
from atlas_rap.views.recording import POSE_RATE, WORLD_TOPICS  # noqa: E402


def recording_host(processes, tmp_path: Path, port: int, *args: str) -> Running:
    running = Running("skills", "serve", "--listen", f"tcp/127.0.0.1:{port}", *args, cwd=tmp_path)
    processes.append(running)
    running.wait_for("skill host for robot robot")
    return running


def log_times_in_file_order(path: Path) -> dict[str, list[int]]:
    """Per topic, the log times in the order they are in the file."""
    found: dict[str, list[int]] = defaultdict(list)
    with open(path, "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            found[channel.topic].append(message.log_time)
    return found


def trace_records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def test_deliver_over_the_bus_is_recorded_on_both_sides_as_in_one_process(processes, tmp_path):
    port = free_port()
    served = recording_host(processes, tmp_path, port, "--record", "host.mcap")
    run = Running("run", DELIVER, "--quiet", "--trace", "bus.jsonl", "--record", "seq.mcap",
                  "--connect", f"tcp/127.0.0.1:{port}", cwd=tmp_path)
    processes.append(run)
    assert run.finish() == 0, run.output
    assert "recording written to seq.mcap" in run.output
    served.wait_for("recording written to host.mcap")  # the session ended: the host finished its file
    alone = atlas("run", DELIVER, "--quiet", "--trace", "alone.jsonl", "--record", "alone.mcap", cwd=tmp_path)
    assert alone.returncode == 0, alone.stderr
    assert "Traceback" not in run.output + served.output

    records = trace_records(tmp_path / "bus.jsonl")
    end = records[-1]["t"]  # the posted task's end ends the run
    host, seq, one = (read_recording(tmp_path / name) for name in ("host.mcap", "seq.mcap", "alone.mcap"))

    # the host's file: the world's channels, in time order, a pose 10 times a simulated second
    # on the prior map nothing builds a grid; the host's localiser estimates the pose (noisy odometry)
    assert set(host.channels()) == set(WORLD_TOPICS) - {"/map/grid"}
    for topic, times in log_times_in_file_order(tmp_path / "host.mcap").items():
        assert times == sorted(times), f"{topic} is not in time order"
    poses = list(host.messages("/robot/pose"))
    assert len(poses) == math.floor(end * POSE_RATE + 1e-9)
    assert [ns for ns, _ in host.raw["/robot/pose"]] == [(i + 1) * 100_000_000 for i in range(len(poses))]
    # lock step runs the same simulation as one process: the same messages, byte for byte
    for topic in WORLD_TOPICS:
        assert host.raw.get(topic) == one.raw.get(topic), topic

    # the sequencer's file: a log line per trace record, and the primary layer's switches
    assert set(seq.channels()) == {"/atlas/trace", "/atlas/primary_layer"}
    logs = list(seq.messages("/atlas/trace"))
    assert len(logs) == len(records)
    assert [(t, log["name"]) for t, log in logs] == [(r["t"], r["event"]) for r in records]
    switches = [r["layer"] for r in records if r["event"] == "layer-switched"]
    assert [m["layer"] for _, m in seq.messages("/atlas/primary_layer")] == switches
    for topic in ("/atlas/trace", "/atlas/primary_layer"):
        assert seq.raw[topic] == one.raw[topic], topic

    # the next session is a file of its own
    again = Running("run", DELIVER, "--quiet", "--until", "2", "--connect", f"tcp/127.0.0.1:{port}", cwd=tmp_path)
    processes.append(again)
    assert again.finish() == 1, again.output  # the errand does not end in 2 s
    served.wait_for("recording written to host-2.mcap")
    assert read_recording(tmp_path / "host-2.mcap").channels()["/robot/pose"][1] == 20
    assert read_recording(tmp_path / "host.mcap").raw == host.raw


@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_host_stopped_mid_run_leaves_a_whole_recording(processes, tmp_path, signum, code):
    port = free_port()
    served = recording_host(processes, tmp_path, port, "--record", "host.mcap")
    run = Running("run", DELIVER, "--realtime", "--host-grace", "1", "--connect", f"tcp/127.0.0.1:{port}",
                  cwd=tmp_path)
    processes.append(run)
    run.wait_for("(door-open lab-door)")  # 8 s into the run
    served.proc.send_signal(signum)
    assert served.finish(timeout=20) == code, served.output
    assert "Traceback" not in served.output
    assert "recording written to host.mcap" in served.output
    run.wait_for("skill host lost", timeout=5)
    assert run.finish(timeout=20) == 1, run.output

    recording = read_recording(tmp_path / "host.mcap")  # readable: the file was closed properly
    poses = list(recording.messages("/robot/pose"))
    assert len(poses) >= 80
    times = [t for t, _ in poses]
    assert times == sorted(times)
    assert recording.last("/robot/path") is not None
    assert {"walls", "places", "doors"} <= {e["id"] for _, update in recording.messages("/world/scene")
                                            for e in update.get("entities", [])}


@pytest.mark.parametrize("args, message", [
    (["--live"], "--live (the host serves the world live: atlas skills serve --live) cannot go with --connect"),
    (["--render", "out.png"], "--render cannot go with --connect"),
])
def test_what_the_sequencer_side_cannot_record_is_a_clear_error(tmp_path, args, message):
    done = atlas("run", DELIVER, "--connect", "tcp/127.0.0.1:1", *args, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 2
    assert message in done.stderr


def test_a_host_serves_its_world_live(processes, tmp_path):
    import re
    import struct

    from ws_client import MESSAGE_DATA, FoxgloveClient

    port = free_port()
    served = recording_host(processes, tmp_path, port, "--live", "--live-port", "0")
    served.wait_for("live: ws://")
    url = re.search(r"ws://127\.0\.0\.1:\d+", served.output).group()
    client = FoxgloveClient(url)
    try:
        channels = client.advertised()
        assert set(channels) == set(WORLD_TOPICS)
        client.send_json({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": channels["/robot/pose"]["id"]}]})
        run = Running("run", DELIVER, "--quiet", "--realtime", "--until", "2", "--connect", f"tcp/127.0.0.1:{port}",
                      cwd=tmp_path)
        processes.append(run)
        poses: list[int] = []
        while len(poses) < 10:
            opcode, payload = client.frame()
            if opcode == 2 and payload[0] == MESSAGE_DATA:
                poses.append(struct.unpack("<IQ", payload[1:13])[1])
        assert poses == [(i + 1) * 100_000_000 for i in range(10)]  # simulated time, from the session's start
    finally:
        client.close()
    assert run.finish() == 1, run.output  # the errand does not end in 2 s
    served.wait_for("session 1 the sequencer went away")
    assert "Traceback" not in served.output
