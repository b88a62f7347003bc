"""Plugins as a user has them (issue 29): the example plugin package installed with pip and found through its
entry points, plugin files given with --plugin, and every way a plugin can be wrong, each a clear message
(exit 2) and never a traceback. Real processes, real files, real simulations."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bus_processes import processes  # noqa: F401  (a fixture)
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

EXAMPLE = REPO / "examples" / "atlas-rap-example-plugin"
SHIPPED_RULES = REPO / "rap_library" / "layers.rap"


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, Path]:
    """The example plugin package pip-installed into a folder of its own, as ``pip install`` would put it
    in a venv (from a copy, so the build leaves nothing in the checkout): (that folder, the copy)."""
    work = tmp_path_factory.mktemp("example-plugin")
    source = work / "source"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    site = work / "site"
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--disable-pip-version-check",
                           "--target", str(site), str(source)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    return site, source


def with_plugins(site: Path) -> dict[str, str]:
    """The environment of a process that has the installed plugin (its folder on the path) and this checkout."""
    return {**ENV, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)])}


def run_atlas(*args: str, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(atlas_command(*args), cwd=cwd, capture_output=True, text=True, env=env)


# -- the example plugin package, installed --------------------------------------------------------------

def test_the_example_plugins_own_tests_pass_where_it_is_installed(installed, tmp_path):
    site, source = installed
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(source / "tests")],
                          cwd=tmp_path, capture_output=True, text=True, env=with_plugins(site))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "4 passed" in done.stdout


def test_the_example_mission_runs_in_the_plugin_world_with_the_plugin_skills(installed, tmp_path):
    site, _ = installed
    mission = site / "atlas_rap_example_plugin" / "find-the-lamp.rap"
    done = run_atlas("run", str(mission), "--world", "greenhouse", cwd=tmp_path, env=with_plugins(site))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 of 1 posted tasks succeeded" in done.stdout
    assert "+ (place lamp)  (world)" in done.stdout  # the greenhouse's places
    assert "enable (creep 6.0 0.3)" in done.stdout and "+ (light robot bright)" in done.stdout


def test_skills_list_shows_the_plugin_skills_and_where_they_came_from(installed, tmp_path):
    site, _ = installed
    done = run_atlas("skills", "list", cwd=tmp_path, env=with_plugins(site))
    assert done.returncode == 0, done.stderr
    rows = {line.split()[0]: line for line in done.stdout.splitlines()}
    assert rows["creep"].split("  ")[-1] == "atlas-rap-example-plugin"
    assert "distance: number, speed: number" in rows["creep"] and "by RAPs" in rows["creep"]
    assert "light" in rows["light-sensor"] and "5 Hz" in rows["light-sensor"] and "always on" in rows["light-sensor"]
    assert rows["move-to"].endswith("stock") and "x: number, y: number" in rows["move-to"]
    without = run_atlas("skills", "list", cwd=tmp_path, env=ENV)
    assert "creep" not in without.stdout and "move-to" in without.stdout


def test_atlas_check_knows_the_plugin_skills_only_where_the_plugin_is_installed(installed, tmp_path):
    site, _ = installed
    mission = site / "atlas_rap_example_plugin" / "find-the-lamp.rap"
    done = run_atlas("check", str(mission), cwd=tmp_path, env=with_plugins(site))
    assert done.returncode == 0, done.stderr
    assert "warning" not in done.stderr  # (wait-for (light robot bright)): the sensor's declared event
    alone = run_atlas("check", str(mission), cwd=tmp_path, env=ENV)
    assert alone.returncode == 1 and "cannot enable unknown skill 'creep'" in alone.stderr


def test_a_misspelt_world_name_lists_the_plugins_worlds(installed, tmp_path):
    site, _ = installed
    mission = site / "atlas_rap_example_plugin" / "find-the-lamp.rap"
    done = run_atlas("run", str(mission), "--world", "greenhous", cwd=tmp_path, env=with_plugins(site))
    assert done.returncode == 1
    assert_no_traceback(done)
    assert "did you mean 'greenhouse'?" in done.stderr and "plugins' worlds: greenhouse" in done.stderr


# -- a plugin file: --plugin FILE.py ------------------------------------------------------------------------

BEEPER = '''\
"""A plugin file: a skill, a world and layer rules."""
from atlas_rap.logic import Compound
from atlas_rap.skills import Skill


class Beep(Skill):
    name = "beep"
    params = ("times: number",)
    events = ("beeped",)
    rate = 2.0

    def transform(self, inputs):
        self.context.assert_fact(Compound("beeped", ("robot", self.args[0])))
        self.context.finish(self)
        return {}


ATLAS_SKILLS = [Beep]
ATLAS_WORLDS = {"closet": "closet.yaml"}
ATLAS_LAYER_RULES = {"my-rules": "my-rules.rap"}
'''

CLOSET = """\
name: closet
polygons:
  - [[0, 0], [3, 0], [3, 2], [0, 2]]
places:
  inside: {point: [1.5, 1], region: [[0, 0], [3, 0], [3, 2], [0, 2]]}
"""

BEEP_MISSION = """\
(world "closet")
(define-rap (beep-three)
  (succeed (beeped robot 3))
  (method
    (primitive
      (enable (beep 3))
      (wait-for (beeped robot 3) :succeed)
      (disable :above))))
(post (beep-three))
"""


@pytest.fixture
def beeper(tmp_path) -> Path:
    """A folder with the plugin file beeper.py, its world and layer rules, and a mission that uses them."""
    (tmp_path / "beeper.py").write_text(BEEPER)
    (tmp_path / "closet.yaml").write_text(CLOSET)
    (tmp_path / "my-rules.rap").write_text(SHIPPED_RULES.read_text().replace("way-clear-prior-map", "my-way-clear"))
    (tmp_path / "beep.rap").write_text(BEEP_MISSION)
    return tmp_path


def test_a_plugin_file_gives_a_skill_a_world_and_layer_rules_to_a_run(beeper):
    done = atlas("run", "beep.rap", "--plugin", "beeper.py", "--layer-rules", "my-rules", cwd=beeper)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 of 1 posted tasks succeeded" in done.stdout
    assert "+ (beeped robot 3)" in done.stdout
    assert "rule my-way-clear" in done.stdout  # the plugin's layer rules, by their name
    unknown = atlas("run", "beep.rap", "--plugin", "beeper.py", "--layer-rules", "their-rules", cwd=beeper)
    assert unknown.returncode == 2 and "the plugins' layer rules: my-rules" in unknown.stderr


def test_an_output_over_a_plugin_file_is_refused_and_the_file_kept(beeper):
    done = atlas("run", "beep.rap", "--plugin", "beeper.py", "--trace", "beeper.py", cwd=beeper)
    assert done.returncode == 2 and "--trace beeper.py: is a plugin file of this command" in done.stderr
    assert (beeper / "beeper.py").read_text() == BEEPER


def test_atlas_check_and_skills_list_take_the_plugin_file(beeper):
    assert atlas("check", "--plugin", "beeper.py", "beep.rap", cwd=beeper).returncode == 0
    without = atlas("check", "beep.rap", cwd=beeper)
    assert without.returncode == 1 and "cannot enable unknown skill 'beep'" in without.stderr
    listed = atlas("skills", "list", "--plugin", "beeper.py", cwd=beeper)
    row = next(line for line in listed.stdout.splitlines() if line.startswith("beep "))
    assert row.split() == ["beep", "times:", "number", "beeped", "2", "Hz", "by", "RAPs", "beeper.py"]


def test_literal_arguments_are_checked_against_the_declared_types_by_check_and_run(beeper):
    (beeper / "typed.rap").write_text(BEEP_MISSION.replace("(beep 3)", "(beep three) (move-to 2.0 lab)"))
    for command in (["check"], ["run", "--quiet"]):
        done = atlas(*command, "--plugin", "beeper.py", "typed.rap", cwd=beeper)
        assert done.returncode == 1, done.stdout + done.stderr
        assert_no_traceback(done)
        assert "typed.rap:6:7: error: skill beep's times is a number, not the symbol three" in done.stderr
        assert "hint: beep takes (times: number)" in done.stderr
        assert "error: skill move-to's y is a number, not the symbol lab" in done.stderr  # a stock skill's
    (beeper / "hidden.rap").write_text(BEEP_MISSION.replace("(beep 3)", "(beep 3) (move-to 2.0 lab)") +
                                       "(define-virtual-skill (move-to ?x ?y) (after 1 (finish :succeed)))\n")
    done = atlas("check", "--plugin", "beeper.py", "hidden.rap", cwd=beeper)  # its own move-to: no types
    assert done.returncode == 0, done.stderr


def test_the_repl_takes_the_plugin_file(beeper):
    done = subprocess.run(atlas_command("repl", "--plugin", "beeper.py", "beep.rap"), cwd=beeper,
                          input=":run 5\n(? (beeped robot ?n))\n", capture_output=True, text=True, env=ENV)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "+ (place inside)  (world)" in done.stdout  # the plugin's world, named by the mission
    assert "?n = 3" in done.stdout


def test_a_skill_host_serves_a_plugin_files_skills_to_a_sequencer_that_has_no_plugin(beeper, processes):
    """The host's skill list, sent over the bus, is the one the catalog gives: the sequencer checks and runs
    the mission against it without the plugin file."""
    pytest.importorskip("zenoh")
    from bus_processes import Running, free_port

    port = free_port()
    host = Running("skills", "serve", "--plugin", "beeper.py", "--world", "closet", "--listen",
                   f"tcp/127.0.0.1:{port}", cwd=beeper)
    processes.append(host)
    host.wait_for("skill host for robot robot in world closet")
    run = Running("run", "beep.rap", "--quiet", "--connect", f"tcp/127.0.0.1:{port}", cwd=beeper)
    processes.append(run)
    assert run.finish() == 0, run.output + host.output
    assert "1 of 1 posted tasks succeeded" in run.output


# -- plugins that are wrong: a clear message, exit 2, no traceback ------------------------------------------

SKILL_HEAD = "from atlas_rap.skills import Skill\n\n\n"

BAD_PLUGINS = {
    "syntax-error": ("x = 1\n\ndef broken(:\n    pass\n",
                     ["plugin bad.py failed to load: SyntaxError: ", "\n  at bad.py, line 3: def broken(:"]),
    "import-error": ("import atlas_no_such_module\n",
                     ["plugin bad.py failed to load: ModuleNotFoundError: No module named 'atlas_no_such_module'",
                      "\n  at bad.py, line 1: import atlas_no_such_module"]),
    "raises": ("x = 1\nraise RuntimeError('no robot here')\n",
               ["plugin bad.py failed to load: RuntimeError: no robot here", "\n  at bad.py, line 2"]),
    "gives-nothing": ("x = 1\n", ["plugin bad.py: gives nothing: define ATLAS_SKILLS, ATLAS_WORLDS"]),
    "no-name": (SKILL_HEAD + "class Nameless(Skill):\n    pass\n\n\nATLAS_SKILLS = [Nameless]\n",
                ["plugin bad.py: skill class Nameless declares no name"]),
    "stock-name": (SKILL_HEAD + "class MySpin(Skill):\n    name = 'spin'\n\n\nATLAS_SKILLS = [MySpin]\n",
                   ["plugin bad.py: skill class MySpin: name 'spin' is already the stock skill spin"]),
    "bad-type": (SKILL_HEAD + "class Go(Skill):\n    name = 'go'\n    params = ('x: float',)\n\n\n"
                 "ATLAS_SKILLS = [Go]\n", ["skill class Go (go): parameter x: unknown type 'float'"]),
    "not-a-skill": ("ATLAS_SKILLS = [print]\n", ["plugin bad.py: a skill must be a subclass of atlas_rap.skills.Skill"]),
    "world-missing": ("ATLAS_WORLDS = {'nowhere': 'nowhere.yaml'}\n",
                      ["plugin bad.py: world 'nowhere': no such file"]),
}


@pytest.mark.parametrize("case", sorted(BAD_PLUGINS))
def test_a_bad_plugin_file_is_a_clear_error(tmp_path, case):
    text, expected = BAD_PLUGINS[case]
    (tmp_path / "bad.py").write_text(text)
    (tmp_path / "m.rap").write_text('(world "nowhere")\n(post (wander))\n')
    for command in (["skills", "list"], ["check", "m.rap"], ["run", "m.rap"]):
        done = atlas(*command, "--plugin", "bad.py", cwd=tmp_path)
        assert done.returncode == 2, (command, done.stdout, done.stderr)
        assert_no_traceback(done)
        for part in expected:
            assert part in done.stderr, (command, done.stderr)


@pytest.mark.parametrize("command", [["repl"], ["skills", "serve"], ["run", "m.rap"]])
def test_every_command_with_plugins_reports_a_broken_one_before_it_starts(tmp_path, command):
    (tmp_path / "bad.py").write_text("def broken(:\n")
    (tmp_path / "m.rap").write_text("(post (wander))\n")
    done = subprocess.run(atlas_command(*command, "--plugin", "bad.py"), cwd=tmp_path, input="", capture_output=True,
                          text=True, env=ENV, timeout=60)
    assert done.returncode == 2, done.stdout + done.stderr
    assert_no_traceback(done)
    assert "plugin bad.py failed to load: SyntaxError" in done.stderr and "bad.py, line 1" in done.stderr


def test_a_plugin_skill_that_raises_as_it_runs_stops_the_run_with_a_clear_error(beeper):
    (beeper / "beeper.py").write_text(BEEPER.replace("self.context.finish(self)", "1 / 0"))
    done = atlas("run", "beep.rap", "--plugin", "beeper.py", "--trace", "trace.jsonl", cwd=beeper)
    assert done.returncode == 1
    assert_no_traceback(done)
    assert ("skill beep (plugin beeper.py) failed in transform: ZeroDivisionError: division by zero\n"
            "  at beeper.py, line 14: 1 / 0") in done.stderr
    assert '"skill":"(beep 3)"' in (beeper / "trace.jsonl").read_text()  # the trace up to then is written


def test_a_plugin_file_that_is_not_there(tmp_path):
    done = atlas("skills", "list", "--plugin", "missing.py", cwd=tmp_path)
    assert done.returncode == 2 and "plugin missing.py: no such file" in done.stderr
    assert_no_traceback(done)


INSTALLED_BAD = {
    "names nothing": ("[atlas_rap.skills]\nghost = ghost_plugin.skills:Ghost\n", ["skills", "list"],
                      "plugin ghost-plugin (entry point atlas_rap.skills: ghost = ghost_plugin.skills:Ghost) failed to "
                      "load: AttributeError: module 'ghost_plugin.skills' has no attribute 'Ghost'"),
    "named not as its skill": ("[atlas_rap.skills]\nghost = ghost_plugin.skills:Spook\n", ["skills", "list"],
                               "plugin ghost-plugin (entry point atlas_rap.skills: ghost = ghost_plugin.skills:Spook): "
                               "skill class Spook: the entry point is named 'ghost' but the skill 'spook'"),
    "a world that is no path": ("[atlas_rap.worlds]\nhaunted = ghost_plugin.skills:NOT_A_PATH\n",
                                ["run", str(REPO / "rap_library" / "missions" / "deliver.rap"), "--world", "haunted"],
                                "world 'haunted' must be the path of a file, not int"),
}


@pytest.mark.parametrize("case", sorted(INSTALLED_BAD))
def test_an_installed_plugin_that_is_wrong_is_a_clear_error(tmp_path, case):
    """An installed distribution (its metadata written as pip writes it) whose entry point is wrong."""
    entry_points, command, message = INSTALLED_BAD[case]
    site = tmp_path / "site"
    info = site / "ghost_plugin-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: ghost-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(entry_points)
    (site / "ghost_plugin").mkdir()
    (site / "ghost_plugin" / "__init__.py").write_text("")
    (site / "ghost_plugin" / "skills.py").write_text(
        "from atlas_rap.skills import Skill\n\n\nclass Spook(Skill):\n    name = 'spook'\n\n\nNOT_A_PATH = 3\n")
    done = run_atlas(*command, cwd=tmp_path, env=with_plugins(site))
    assert done.returncode == 2, done.stdout + done.stderr
    assert_no_traceback(done)
    assert message in done.stderr
    if case == "names nothing":  # atlas check too: it reads the plugins' skills
        done = run_atlas("check", str(REPO / "rap_library" / "missions" / "deliver.rap"), cwd=tmp_path,
                         env=with_plugins(site))
        assert done.returncode == 2 and message in done.stderr
