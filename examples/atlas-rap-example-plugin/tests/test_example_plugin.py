"""The example plugin's own tests: run them where the plugin is installed (``pip install '.[test]' && pytest``).

They run the real ``atlas`` command in a new process, as a user would, so
they check what atlas finds through the entry points, not only the classes.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from atlas_rap_example_plugin import MISSION
from atlas_rap_example_plugin.sensors import BRIGHT, light_level


def atlas(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "atlas_rap", *args], cwd=cwd, capture_output=True, text=True)


def test_the_light_is_bright_within_a_metre_of_the_lamp():
    assert light_level((6.0, 1.5), (6.0, 1.5)) == 1.0
    assert light_level((5.1, 1.5), (6.0, 1.5)) > BRIGHT > light_level((4.9, 1.5), (6.0, 1.5))


def test_atlas_lists_the_plugin_skills_with_their_declarations(tmp_path):
    done = atlas("skills", "list", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    skills = {skill["name"]: skill for skill in json.loads(done.stdout)}
    assert skills["creep"] == {"name": "creep", "params": [{"name": "distance", "type": "number"},
                                                           {"name": "speed", "type": "number"}],
                               "events": ["blocked"], "rate": 20.0, "always_on": False,
                               "origin": "atlas-rap-example-plugin"}
    assert skills["light-sensor"]["always_on"] and skills["light-sensor"]["events"] == ["light"]
    assert skills["move-to"]["origin"] == "stock"


def test_the_mission_finds_the_lamp_in_the_greenhouse(tmp_path):
    done = atlas("check", str(MISSION), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    done = atlas("run", str(MISSION), "--quiet", "--trace", "trace.jsonl", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 of 1 posted tasks succeeded" in done.stdout
    trace = (tmp_path / "trace.jsonl").read_text()
    assert "(light robot bright)" in trace and "(creep 6.0 0.3)" in trace


def test_creep_stops_and_fails_before_a_wall(tmp_path):
    mission = tmp_path / "too-far.rap"
    mission.write_text("""
(world "greenhouse")
(define-rap (creep-far)
  (method
    (primitive
      (enable (creep 20.0 0.4))
      (wait-for (done (creep 20.0 0.4) :succeed) :succeed)
      (wait-for (done (creep 20.0 0.4) :fail) :fail)
      (disable :above))))
(post (creep-far))
""")
    done = atlas("run", str(mission), "--quiet", "--trace", "trace.jsonl", cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    trace = (tmp_path / "trace.jsonl").read_text()
    assert "(blocked robot creep)" in trace
    assert "m ahead" in trace  # why it failed: (why (creep 20.0 0.4) "something 0.34 m ahead")
