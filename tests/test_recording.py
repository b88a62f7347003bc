"""`atlas run --record` / `--live`: a run for Foxglove, as MCAP and over WebSocket, in simulated time.

The recordings are read back with the `mcap` package itself (in file order,
to see that every channel is written in time order) and with our reader
(`views.mcap_reader`), and checked against the JSON-lines trace of the same
run and against the run's simulated duration.
"""

from __future__ import annotations

import json
import math
import re
import signal
import struct
import subprocess
import time
from collections import defaultdict
from pathlib import Path

import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

pytest.importorskip("foxglove")
pytest.importorskip("mcap")

from mcap.reader import make_reader  # noqa: E402

from atlas_rap.views.mcap_reader import read_recording  # noqa: E402
from atlas_rap.views.recording import ESTIMATE_TOPICS, POSE_RATE, TOPICS  # noqa: E402

DELIVER = str(REPO / "rap_library" / "missions" / "deliver.rap")
GRIPPER_BROKEN = str(REPO / "rap_library" / "missions" / "gripper-broken.rap")


def file_order(path: Path) -> dict[str, list[tuple[int, str, int]]]:
    """Per topic, (log time, schema name, the message's own timestamp in ns or -1) in the order written."""
    from atlas_rap.views.mcap_reader import ProtobufSchemas

    decoders: dict[bytes, ProtobufSchemas] = {}
    found: dict[str, list[tuple[int, str, int]]] = defaultdict(list)
    with open(path, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            stamp = -1
            if channel.message_encoding == "protobuf":
                decoder = decoders.setdefault(schema.data, ProtobufSchemas(schema.data))
                own = decoder.decode(schema.name, message.data).get("timestamp")
                if own is not None:
                    stamp = own.get("seconds", 0) * 1_000_000_000 + own.get("nanos", 0)
            found[channel.topic].append((message.log_time, schema.name, stamp))
    return found


def trace_records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


@pytest.fixture(scope="module")
def mapping_run(tmp_path_factory) -> tuple[Path, Path, object]:
    """deliver.rap with no prior map (so Layer IV builds a grid and Layer III a topology), recorded."""
    folder = tmp_path_factory.mktemp("record")
    done = atlas("run", DELIVER, "--quiet", "--no-prior-map", "--record", "run.mcap", "--trace", "run.jsonl",
                 cwd=folder)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "recording written to run.mcap" in done.stdout
    return folder / "run.mcap", folder / "run.jsonl", done


def test_a_recording_has_every_channel_in_time_order_and_agrees_with_the_trace(mapping_run):
    mcap, trace, _ = mapping_run
    written = file_order(mcap)
    # no prior map: the belief is the odometry corrected against the map being built, so its path is
    # recorded but there is no filter estimate
    assert set(written) == set(TOPICS) - (set(ESTIMATE_TOPICS) - {"/robot/estimated_path"})
    for topic, messages in written.items():
        assert {schema for _, schema, _ in messages} == {TOPICS[topic][0]}, topic
        times = [log_time for log_time, _, _ in messages]
        assert times == sorted(times), f"{topic} is not in time order"
        stamped = [(log_time, stamp) for log_time, _, stamp in messages if stamp >= 0]
        if topic not in ("/world/scene", "/map/topology", "/robot/route"):  # scenes stamp their entities
            assert all(log_time == stamp for log_time, stamp in stamped), topic

    records = trace_records(trace)
    logs = list(read_recording(mcap).messages("/atlas/trace"))
    assert len(logs) == len(records)
    assert [log["name"] for _, log in logs] == [r["event"] for r in records]
    assert [t for t, _ in logs] == [r["t"] for r in records]
    first = json.loads(logs[0][1]["message"])
    assert first == {k: v for k, v in records[0].items() if k not in ("t", "event")}

    end = records[-1]["t"]  # the posted task's end ends the run
    assert len(written["/robot/pose"]) == math.floor(end * POSE_RATE + 1e-9) > 500  # a minute of driving
    assert len(written["/tf"]) == len(written["/robot/pose"])
    assert 0 < len(written["/robot/sonar"]) <= len(written["/robot/pose"])
    assert 1 <= len(written["/map/grid"]) <= end + 2  # at most once a simulated second, and the last
    assert len(written["/map/topology"]) >= 2  # the prior map's graph, then Layer III's
    switches = [r for r in records if r["event"] == "layer-switched"]
    primary = list(read_recording(mcap).messages("/atlas/primary_layer"))
    assert [m["layer"] for _, m in primary] == [r["layer"] for r in switches]


def test_the_recorded_grid_and_path_are_the_runs(mapping_run):
    recording = read_recording(mapping_run[0])
    grid = recording.last("/map/grid")
    assert grid["frame_id"] == "map" and [f["name"] for f in grid["fields"]] == ["occupancy"]
    cells = grid["data"]
    assert len(cells) == grid["row_stride"] * (len(cells) // grid["row_stride"])
    assert max(cells) > 65 and min(cells) < 35  # walls and free space were seen
    poses = list(recording.messages("/robot/pose"))
    last_pose = poses[-1][1]["pose"]["position"]
    last_path = recording.last("/robot/path")["poses"][-1]["position"]
    assert math.dist((last_pose["x"], last_pose.get("y", 0)), (last_path["x"], last_path.get("y", 0))) < 0.05
    scene = {e["id"] for _, update in recording.messages("/world/scene") for e in update.get("entities", [])}
    assert {"walls", "places", "doors"} <= scene


def test_the_same_run_gives_the_same_recording(tmp_path):
    for name in ("a.mcap", "b.mcap"):
        done = atlas("run", DELIVER, "--quiet", "--record", name, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()
    channels = read_recording(tmp_path / "a.mcap").channels()
    # on the prior map nothing builds a grid; the localiser estimates the pose (the world's odometry is noisy)
    assert set(channels) == set(TOPICS) - {"/map/grid"}
    seconds = float(re.search(r"in ([0-9.]+) s simulated", done.stdout).group(1))
    assert abs(channels["/robot/pose"][1] - 10 * seconds) <= 1  # the run's length at 10 Hz


def test_a_run_that_fails_is_still_recorded(tmp_path):
    done = atlas("run", DELIVER, "--quiet", "--until", "5", "--record", "short.mcap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    channels = read_recording(tmp_path / "short.mcap").channels()
    assert channels["/robot/pose"][1] == 50

    done = atlas("run", GRIPPER_BROKEN, "--quiet", "--record", "failed.mcap", "--trace", "failed.jsonl",
                 cwd=tmp_path)
    assert done.returncode == 1
    channels = read_recording(tmp_path / "failed.mcap").channels()  # no world: the trace alone
    assert channels == {"/atlas/trace": ("foxglove.Log", len(trace_records(tmp_path / "failed.jsonl")))}


def test_ctrl_c_still_writes_the_recording(tmp_path):
    process = subprocess.Popen(atlas_command("run", DELIVER, "--realtime", "--record", "stopped.mcap"),
                               cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**ENV, "PYTHONUNBUFFERED": "1"})
    try:
        process.stdout.readline()  # the live trace has begun
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert "Traceback" not in out + err, err
    assert process.returncode == 130, out + err
    recording = read_recording(tmp_path / "stopped.mcap")
    assert recording.channels()["/robot/pose"][1] >= 5
    assert recording.last("/atlas/trace")["name"] == "task-halted"


def test_record_without_the_sdk_is_a_one_line_error(tmp_path):
    fake = tmp_path / "nofoxglove" / "foxglove"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('no Foxglove here')\n", encoding="utf-8")
    done = subprocess.run(atlas_command("run", DELIVER, "--record", "run.mcap", "--trace", "t.jsonl"), cwd=tmp_path,
                          capture_output=True, text=True, env={**ENV, "PYTHONPATH": f"{fake.parent}:{REPO}"})
    assert_no_traceback(done)
    assert done.returncode == 1
    (line,) = done.stderr.strip().splitlines()
    assert "install atlas-rap[foxglove]" in line
    assert not (tmp_path / "run.mcap").exists()


def test_live_serves_the_run_over_websocket_in_real_time(tmp_path):
    from ws_client import MESSAGE_DATA, FoxgloveClient

    process = subprocess.Popen(atlas_command("run", DELIVER, "--quiet", "--live", "--live-port", "0", "--until", "3"),
                               cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    try:
        line = process.stdout.readline()
        url = re.search(r"ws://127\.0\.0\.1:\d+", line)
        assert url, line
        client = FoxgloveClient(url.group())
        try:
            channels = client.advertised()
            assert {topic: c["schemaName"] for topic, c in channels.items()} == \
                {topic: schema for topic, (schema, _) in TOPICS.items()}
            wanted = {1: "/world/scene", 2: "/robot/pose"}
            client.send_json({"op": "subscribe", "subscriptions": [
                {"id": sid, "channelId": channels[topic]["id"]} for sid, topic in wanted.items()]})
            got: dict[int, list[int]] = defaultdict(list)
            while not (got[1] and got[2]):
                opcode, payload = client.frame()
                if opcode == 2 and payload[0] == MESSAGE_DATA:
                    sid, log_time = struct.unpack("<IQ", payload[1:13])
                    got[sid].append(log_time)
            assert got[1][0] == 0  # the walls, sent again to a viewer that subscribed late
        finally:
            client.close()
        out, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert "Traceback" not in out + err, err
    assert process.returncode == 1, out + err  # the errand does not end in 3 s
    wall = float(re.search(r"\(([\d.]+) s wall\)", out).group(1))
    assert wall >= 2.5  # paced to the wall clock


def test_the_picture_of_a_recording(mapping_run, tmp_path):
    done = atlas("record", "show", str(mapping_run[0]), "--out", "end.png", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert re.search(r"/robot/pose\s+foxglove\.PoseInFrame\s+\d+ messages", done.stdout)
    png = (tmp_path / "end.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 20_000


def test_show_refuses_what_is_not_a_recording(tmp_path):
    (tmp_path / "not.mcap").write_text("hello\n", encoding="utf-8")
    done = atlas("record", "show", "not.mcap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "not a readable MCAP recording" in done.stderr
