"""atlas_rap.host.SkillHost: a robot's own process serving its own skills to `atlas run --connect`.

The host is examples/robot-host/rover_host.py, run as a second process with the
simulator made unimportable (a real robot's process has no pymunk and no world):
if the library reached for atlas_rap.sim, the host would fail to start.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from bus_processes import Running, free_port, processes  # noqa: F401  (processes: a fixture)
from cli_process import REPO, atlas

zenoh = pytest.importorskip("zenoh")

EXAMPLE = REPO / "examples" / "robot-host"
HOST = EXAMPLE / "rover_host.py"
PATROL = EXAMPLE / "patrol.rap"

NO_SIMULATOR = ("import runpy, sys\n"
                "sys.modules['pymunk'] = None  # a robot's own process: no simulator to import\n"
                "sys.modules['atlas_rap.sim'] = None\n"
                "sys.argv = [sys.argv[1], *sys.argv[2:]]\n"
                "runpy.run_path(sys.argv[0], run_name='__main__')\n")


def rover_host(processes, tmp_path: Path, port: int) -> Running:
    running = Running(cwd=tmp_path, command=[sys.executable, "-c", NO_SIMULATOR, str(HOST),
                                             "--listen", f"tcp/127.0.0.1:{port}", "--token-file", "rover.token"])
    processes.append(running)
    running.wait_for("skill host for robot rover on tcp/127.0.0.1")
    running.wait_for("token: ")
    return running


def sequencer(processes, tmp_path: Path, port: int, mission: Path, *args: str, env: dict | None = None) -> Running:
    running = Running("run", str(mission), "--connect", f"tcp/127.0.0.1:{port}", "--robot", "rover",
                      "--token-file", "rover.token", *args, cwd=tmp_path, env=env)
    processes.append(running)
    return running


def test_a_mission_drives_the_robots_own_skills_served_by_a_process_without_the_simulator(processes, tmp_path):
    port = free_port()
    host = rover_host(processes, tmp_path, port)
    run = sequencer(processes, tmp_path, port, PATROL, "--memory")
    assert run.finish() == 0, run.output + host.output
    out = run.output
    assert "(patrol) succeeded" in out
    for corner in ("(done (drive-to 2 0) :succeed)", "(done (drive-to 2 2) :succeed)",
                   "(done (drive-to 0 2) :succeed)", "(done (drive-to 0 0) :succeed)"):
        assert corner in out  # each skill call was the host's, and said it was done
    assert "(at-point rover 0 0)" in out  # the host's facts say the robot's name on the bus
    levels = [int(level) for level in re.findall(r"\(battery rover (\d+)\)", out)]
    assert levels[0] == 100 and 91 <= levels[-1] <= 93  # the always-on sensor: 8 m driven at 1 % a metre
    host.wait_for("session 1 started at t=0 s")
    host.wait_for("session 1 the sequencer went away")
    assert "Traceback" not in host.output + out


def test_the_same_mission_on_a_fresh_host_gives_the_same_trace(processes, tmp_path):
    traces = []
    for name in ("first.jsonl", "second.jsonl"):
        port = free_port()
        rover_host(processes, tmp_path, port)
        run = sequencer(processes, tmp_path, port, PATROL, "--trace", name)
        assert run.finish() == 0, run.output
        traces.append((tmp_path / name).read_bytes())
    assert traces[0] == traces[1] and b"drive-to" in traces[0]


def test_a_sequencer_without_the_hosts_token_is_refused_and_starts_nothing(processes, tmp_path):
    port = free_port()
    host = rover_host(processes, tmp_path, port)
    wrong = Running("run", str(PATROL), "--connect", f"tcp/127.0.0.1:{port}", "--robot", "rover", cwd=tmp_path,
                    env={"ATLAS_BUS_TOKEN": "not-the-rovers-secret-at-all"})
    processes.append(wrong)
    assert wrong.finish() == 1
    assert "refused: this sequencer's token is not the skill host's" in wrong.output
    assert "Traceback" not in wrong.output
    host.wait_for("a Hello that fails authentication")
    assert "session 1 started" not in host.output


def test_in_real_time_the_mission_takes_the_robots_time(processes, tmp_path):
    mission = tmp_path / "nudge.rap"
    mission.write_text("(define-rap (nudge) (method (task-net (t1 (drive-to 0.5 0)))))\n(post (nudge))\n")
    port = free_port()
    rover_host(processes, tmp_path, port)
    run = sequencer(processes, tmp_path, port, mission, "--realtime")
    assert run.finish() == 0, run.output
    # 0.5 m at 0.5 m/s: about a second of the robot's time, paced to the wall clock (lock-step: ~0.05 s).
    simulated, wall = map(float, re.search(r"succeeded in ([\d.]+) s simulated \(([\d.]+) s wall\)",
                                           run.output).groups())
    assert 0.9 <= simulated <= 1.0 and wall >= 0.7


def test_when_the_host_stops_a_sequencer_is_told_no_host_answers(processes, tmp_path):
    port = free_port()
    host = rover_host(processes, tmp_path, port)
    host.proc.send_signal(2)  # Ctrl-C
    assert host.finish() == 130
    lost = sequencer(processes, tmp_path, port, PATROL)
    assert lost.finish() == 1
    assert "no skill host for robot 'rover' answers" in lost.output
    assert "Traceback" not in lost.output + host.output


def test_the_host_file_is_also_the_plugin_atlas_check_reads_the_skills_from(tmp_path):
    checked = atlas("check", str(PATROL), "--plugin", str(HOST), cwd=tmp_path)
    assert checked.returncode == 0, checked.stderr
    unknown = atlas("check", str(PATROL), cwd=tmp_path)
    assert unknown.returncode == 1 and "'drive-to' is neither a RAP nor a skill" in unknown.stderr
    bad = tmp_path / "bad.rap"
    bad.write_text('(include "' + PATROL.as_posix() + '")\n(define-rap (to-lab) (method (task-net (t1 (drive-to lab 0)))))\n')
    typed = atlas("check", str(bad), "--plugin", str(HOST), cwd=tmp_path)
    assert typed.returncode == 1 and "is a number, not the symbol lab" in typed.stderr


@pytest.mark.parametrize("skills, message", [
    ([], "at least one skill"),
    (["drive-to"], "a skill must be a subclass of atlas_rap.skills.Skill, not 'drive-to'"),
])
def test_a_host_refuses_what_is_not_a_skill_before_it_opens_the_bus(skills, message):
    from atlas_rap.host import SkillHost

    with pytest.raises(ValueError, match=message):
        SkillHost("rover", skills)


def test_a_host_refuses_skills_declared_as_no_plugin_may_be_and_a_fact_that_does_not_read():
    from atlas_rap.host import Skill, SkillHost

    class Nameless(Skill):
        pass

    class Beep(Skill):
        name = "beep"

    class OtherBeep(Skill):
        name = "beep"

    class Untyped(Skill):
        name = "drive-to"
        params = ("x: nmber",)

    with pytest.raises(ValueError, match="skill class .*Nameless declares no name"):
        SkillHost("rover", [Nameless])
    with pytest.raises(ValueError, match="name 'beep' is already the skill beep from this host"):
        SkillHost("rover", [Beep, OtherBeep])
    with pytest.raises(ValueError, match="parameter x: unknown type 'nmber'"):
        SkillHost("rover", [Untyped])
    with pytest.raises(ValueError, match="does not read as a term"):
        SkillHost("rover", [Beep], facts=["(at robot"])
