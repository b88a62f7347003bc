"""Numbers a user writes that cannot be used: located errors in files, usage errors in options.

A number too large for a float (400 digits, ``1e400``), ``nan`` and ``inf``,
a time past 32 years, a negative time: in a .rap or .ap file each is an
error with file:line:column, the line and a caret, in ``atlas check`` and
``atlas run`` alike (never an OverflowError, never "ok"); in an option of
any command it is a usage error (exit 2) naming the option; in a world
file, a located error; in the REPL, an error that keeps the session.
"""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from cli_process import REPO, assert_no_traceback, atlas

from atlas_rap.cli.main import cli
from atlas_rap.errors import SourceError
from atlas_rap.lang import parse_text

DIGITS_400 = "9" * 400

MISSION = """(world none)
(define-virtual-skill (beep) (after {after} (finish :succeed)))
(define-rap (go) (method (task-net (beep))))
(post (go))
"""


def located(text: str, name: str = "n.rap") -> list:
    """The problems reading ``text`` gives (it must give some)."""
    with pytest.raises(SourceError) as caught:
        parse_text(text, name)
    return caught.value.problems


# ----------------------------------------------------------------- in files, through the commands


@pytest.mark.parametrize("command", ["check", "run"])
def test_a_400_digit_delay_is_a_located_error_in_check_and_in_run(tmp_path, command):
    (tmp_path / "big.rap").write_text(MISSION.format(after=DIGITS_400), encoding="utf-8")
    done = atlas(command, "big.rap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    lines = done.stderr.splitlines()
    assert lines[0] == "big.rap:2:37: error: number too large: 999999999999...999999 (400 characters)"
    assert lines[1].startswith("    (define-virtual-skill (beep) (after 99999")
    assert lines[2] == " " * 40 + "^"  # under the first digit
    assert lines[3].startswith("  hint: numbers go up to about 1.8e+308")
    assert "ok:" not in done.stdout + done.stderr


def test_run_refuses_a_too_large_number_before_anything_runs(tmp_path):
    (tmp_path / "inf.rap").write_text(MISSION.format(after="1e400"), encoding="utf-8")
    done = atlas("run", "inf.rap", "--trace", "t.jsonl", cwd=tmp_path)
    assert done.returncode == 1
    assert done.stderr.startswith("inf.rap:2:37: error: number too large: 1e400")
    trace = tmp_path / "t.jsonl"
    assert not trace.exists() or "task-posted" not in trace.read_text(encoding="utf-8")


# ----------------------------------------------------------------- in files, every place a number stands

PLACES = {
    "after": "(define-virtual-skill (beep) (after {n} (finish :succeed)))",
    "at-time": "(at-time {n} (assert (door-closed d1)))",
    "timeout": "(define-rap (go) (timeout {n}) (method (task-net (beep))))",
    "priority": "(define-rap (go) (priority {n}) (method (task-net (beep))))",
    "retries": "(define-rap (go) (retries {n}) (method (task-net (beep))))",
    ":deadline": "(post (go) :deadline {n})",
    ":priority": "(post (go) :priority {n})",
    "wait-for :timeout": "(define-rap (go) (method (task-net (wait-for (ready) :timeout {n}))))",
    "plan :deadline": "(plan (ready) :deadline {n})",
    ":duration": "(operator op :effects ((ready)) :duration {n})",
    ":probability": "(operator op :effects ((ready)) :uncontrolled t :probability {n})",
    "deadline": "(deadline (ready) {n})",
    "a fact": "(initial-memory (level {n}))",
    "a query": "(define-rap (go) (succeed (> ?x {n})) (method (task-net (beep))))",
}


@pytest.mark.parametrize("place", list(PLACES))
@pytest.mark.parametrize("number", [DIGITS_400, "-" + DIGITS_400, "1e400", "-1.5e999"])
def test_a_number_no_float_can_hold_is_an_error_wherever_it_stands(place, number):
    form = PLACES[place].format(n=number)
    (problem,) = located(form)
    assert problem.message.startswith("number too large: ")
    assert (problem.location.line, problem.location.column) == (1, form.index(number) + 1)


@pytest.mark.parametrize("place", ["after", "at-time", "timeout", ":deadline", "wait-for :timeout",
                                   "plan :deadline", ":duration", "deadline"])
def test_a_time_past_32_years_is_refused_with_the_way_to_say_no_limit(place):
    form = PLACES[place].format(n="1e300")
    (problem,) = located(form)
    assert "must be at most 1e+09 seconds (about 32 years), found 1e+300" in problem.message
    assert problem.location.column == form.index("1e300") + 1
    assert problem.hint in ("for no time limit, leave the limit out", "times are in seconds")


@pytest.mark.parametrize("place", ["after", "at-time", "timeout", ":deadline", "wait-for :timeout", ":duration"])
def test_a_negative_time_is_refused(place):
    (problem,) = located(PLACES[place].format(n="-2"))
    assert "must be at least 0, found -2" in problem.message


@pytest.mark.parametrize("word", ["nan", "inf", "-inf"])
def test_nan_and_inf_where_a_time_goes_say_they_are_not_numbers(word):
    (problem,) = located(PLACES["timeout"].format(n=word))
    assert problem.message == f"timeout must be a number, found '{word}'"
    assert problem.hint == f"{word} is not a number here; for no limit, leave the limit out"


def test_a_huge_but_representable_number_is_still_a_number():
    (form,) = parse_text("(initial-memory (level 1e300) (serial " + "9" * 300 + "))", "ok.rap").forms
    assert form.facts[0].args == (1e300,) and form.facts[1].args == (int("9" * 300),)


def test_arithmetic_past_the_largest_float_is_an_error_at_load_with_a_caret(tmp_path):
    (tmp_path / "a.rap").write_text("(world none)\n(define-rap (go) (method (task-net (assert (x)))))\n"
                                    "(initial-memory (level (* 1e300 1e300)))\n(post (go))\n", encoding="utf-8")
    done = atlas("check", "a.rap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert done.stderr.startswith("a.rap:3:17: error: cannot evaluate the arithmetic in the fact "
                                  "(level (* 1e+300 1e+300)): the result is too large")


def test_a_step_whose_arithmetic_overflows_fails_naming_the_fact(tmp_path):
    (tmp_path / "a.rap").write_text("(world none)\n(define-rap (go ?n) (retries 1) "
                                    "(method (task-net (assert (level (* ?n ?n))))))\n(post (go 1e200))\n",
                                    encoding="utf-8")
    done = atlas("run", "a.rap", "--quiet", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "(assert (level (* 1e+200 1e+200))): cannot evaluate the arithmetic" in done.stdout
    assert "the result is too large" in done.stdout


# ----------------------------------------------------------------- options of every command

SITE_VISIT = str(REPO / "rap_library" / "missions" / "site-visit.rap")
SMALL_MAP = str(REPO / "worlds" / "maps" / "small-office-map.yaml")
GOALS = str(REPO / "operators" / "office-goals.ap")

# Every numeric option of every command, with the arguments it needs to get as far as its options.
OPTIONS = [
    (("run", SITE_VISIT), "--until"),
    (("run", SITE_VISIT), "--seed"),
    (("run", SITE_VISIT), "--live-port"),
    (("repl",), "--speed"),
    (("repl",), "--seed"),
    (("plan", GOALS), "--timeout"),
    (("plan", GOALS), "--memory"),
    (("map", "build", "--out", "m"), "--until"),
    (("map", "build", "--out", "m"), "--seed"),
    (("map", "build", "--out", "m"), "--min-room-area"),
    (("map", "build", "--out", "m"), "--wall-thickness"),
    (("map", "abstract", SMALL_MAP, "--out", "m"), "--robot-radius"),
    (("map", "abstract", SMALL_MAP, "--out", "m"), "--min-room-area"),
    (("map", "abstract", SMALL_MAP, "--out", "m"), "--wall-thickness"),
    (("map", "abstract", SMALL_MAP, "--out", "m"), "--core-area"),
    (("experiment", "skill-acquisition", "--out", "e"), "--runs"),
    (("experiment", "skill-acquisition", "--out", "e"), "--seed"),
]


@pytest.mark.parametrize("args, option", OPTIONS, ids=[f"{' '.join(a[:2])} {o}" for a, o in OPTIONS])
@pytest.mark.parametrize("value", ["nan", "inf", "1e400", DIGITS_400, "-1"])
def test_every_numeric_option_refuses_nan_inf_huge_and_negative_values_naming_the_option(monkeypatch, tmp_path,
                                                                                        args, option, value):
    monkeypatch.chdir(tmp_path)
    done = CliRunner().invoke(cli, [*args, option, value])
    assert done.exit_code == 2, done.output
    assert f"Invalid value for '{option}'" in done.output
    assert done.exception is None or isinstance(done.exception, SystemExit)


@pytest.mark.parametrize("value", ["nan", "inf"])
def test_door_width_refuses_nan_and_inf_in_either_place(monkeypatch, tmp_path, value):
    monkeypatch.chdir(tmp_path)
    done = CliRunner().invoke(cli, ["map", "abstract", SMALL_MAP, "--out", "m", "--door-width", "0.6", value])
    assert done.exit_code == 2
    assert "Invalid value for '--door-width'" in done.output


def test_until_nan_is_a_usage_error_from_the_real_command(tmp_path):
    done = atlas("run", SITE_VISIT, "--until", "nan", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 2
    assert "Invalid value for '--until': 'nan' is not a number" in done.stderr


def test_a_negative_seed_is_a_usage_error_not_a_numpy_traceback(tmp_path):
    done = atlas("run", str(REPO / "rap_library" / "missions" / "deliver.rap"), "--seed", "-1", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 2
    assert "Invalid value for '--seed'" in done.stderr


def test_a_robot_wider_than_the_map_is_refused_at_once(tmp_path):
    done = atlas("map", "abstract", SMALL_MAP, "--out", "m", "--robot-radius", "1e300", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "has no free space wide enough for a robot of radius 1e+300 m" in done.stderr


def test_walls_thicker_than_the_map_cost_no_more_than_walls_as_thick_as_it():
    import numpy as np

    from atlas_rap.maps.frame import GridFrame
    from atlas_rap.maps.abstraction import abstract_map
    from atlas_rap.maps.rooms import RoomSettings

    p_occ = np.full((60, 80), 0.05, dtype=np.float32)
    p_occ[[0, -1], :] = p_occ[:, [0, -1]] = 0.95
    p_occ[:, 40] = 0.95
    p_occ[25:35, 40] = 0.05  # a doorway
    result = abstract_map(p_occ, GridFrame(60, 80, 0.05), 0.1, rooms=RoomSettings(wall_thickness=1e300))
    assert result.topology.graph.number_of_nodes() > 0


# ----------------------------------------------------------------- the REPL's commands


def test_repl_commands_refuse_numbers_that_are_not_finite_and_go_on(tmp_path):
    import subprocess

    from cli_process import ENV, atlas_command

    script = ":run nan\n:step inf\n:run 1e400\n:run 1e300\n:trace " + DIGITS_400 + "\n:trace -1\n:step 1\n"
    done = subprocess.run(atlas_command("repl"), input=script, cwd=tmp_path, capture_output=True, text=True,
                          env=ENV, timeout=60)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "error: expected a finite number, not nan: :run SECONDS" in done.stderr
    assert "error: expected a finite number, not inf: :step SECONDS" in done.stderr
    assert "error: expected a finite number, not 1e400: :run SECONDS" in done.stderr
    assert "error: expected at most 1e+09 seconds (about 32 years): :run SECONDS" in done.stderr
    assert "error: expected a number at least 0: :trace N" in done.stderr
    assert done.stdout.rstrip().endswith("time 1 s")  # the session went on


# ----------------------------------------------------------------- world files


def world_with(tmp_path, old: str, new: str) -> str:
    text = (REPO / "worlds" / "lab-corridor-office.yaml").read_text(encoding="utf-8")
    assert old in text
    (tmp_path / "w.yaml").write_text(text.replace(old, new, 1), encoding="utf-8")
    return str(tmp_path / "w.yaml")


@pytest.mark.parametrize("old, new, message", [
    ("  count: 16", "  count: " + DIGITS_400,
     "sonar.count must be a finite number, not 999999999999...999999 (400 characters)"),
    ("  radius: 0.2", "  radius: .nan", "robot.radius must be a finite number, not .nan"),
    ("  radius: 0.2", "  radius: .inf", "robot.radius must be a finite number, not .inf"),
    ("  count: 16", "  count: 100000000", "sonar.count must be at most 360, not 1e+08"),
    ("  rays_per_beam: 3", "  rays_per_beam: 100000000", "sonar.rays_per_beam must be at most 64, not 1e+08"),
    ("start: [1.5, 1.5, 0]", "start: [1.0e+300, 1.5, 0]", "robot.start[0] must be at most 100000, not 1e+300"),
], ids=["400 digits", "nan", "inf", "a hundred million transducers", "a hundred million rays", "far away"])
def test_world_numbers_that_cannot_be_simulated_are_located_errors(tmp_path, old, new, message):
    from atlas_rap.sim.world import load_world

    path = world_with(tmp_path, old, new)
    with pytest.raises(SourceError) as caught:
        load_world(path)
    (problem,) = caught.value.problems
    assert problem.message == message
    assert problem.location.line == next(i for i, line in enumerate(open(path), 1) if new.strip() in line)


def test_an_exponent_yaml_reads_as_text_gets_a_hint_how_to_write_it(tmp_path):
    from atlas_rap.sim.world import load_world

    path = world_with(tmp_path, "  radius: 0.2", "  radius: 2e-1")
    with pytest.raises(SourceError) as caught:
        load_world(path)
    (problem,) = caught.value.problems
    assert problem.message == "robot.radius must be a number, not '2e-1'"
    assert problem.hint == "YAML reads 2e-1 as text: write it 2.0e-1 (a dot, and a sign after the e)"


def test_a_world_too_large_to_map_is_refused_before_the_grid_is_made(tmp_path):
    path = world_with(tmp_path, "[20, 10], [8, 10]", "[10000, 10], [8, 10]")
    done = atlas("run", str(REPO / "rap_library" / "missions" / "deliver.rap"), "--world", path,
                 "--no-prior-map", "--until", "1", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "a grid over this world (10002 m x 12 m at 0.05 m a cell) would have 48,009,600 cells" in done.stderr
