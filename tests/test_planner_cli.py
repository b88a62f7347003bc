"""`atlas plan` in a new process, as a user runs it: exit codes, the plan's JSON,
DOT and plan-file forms, PDDL plans checked by the independent validator,
reproducibility, and bad input reported with a caret, never a traceback."""

from __future__ import annotations

import json
import os
import pty
import re
import subprocess
import time
from pathlib import Path

import pytest
from cli_process import ENV, assert_no_traceback, atlas, atlas_command
from pddl_problems import BLOCKS_DOMAIN, blocks_problem, gripper_problem, write_problem
from planner_cases import (
    DELIVERY,
    DOOR_OPERATORS,
    ONE_WAY_DOOR,
    PLOT_CYCLE,
    STATION,
    bulky_box,
    door_problem,
    linearisations,
    write_ap,
)

from atlas_rap.planner.plan_file import read_plan_file, validate_plan_file

TWO_ARMS = bulky_box(["left-arm", "right-arm"], {"left-arm": 25, "right-arm": 25})


def plan_json(done: subprocess.CompletedProcess) -> dict:
    assert_no_traceback(done)
    return json.loads(done.stdout)


def assert_located_error(done: subprocess.CompletedProcess, file: str, line: int, *words: str) -> str:
    """Exit 1, no traceback, and a report ``FILE:LINE:COL: error: ...`` followed by the
    source line and a caret under column COL; every one of ``words`` in the message."""
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    assert_no_traceback(done)
    out = done.stderr
    lines = out.split("\n")
    pattern = re.compile(rf"^(?:.*/)?{re.escape(file)}:{line}:(\d+): error: (.*)$")
    for i, text in enumerate(lines):
        match = pattern.match(text)
        if match and all(w in match.group(2) for w in words):
            column = int(match.group(1))
            source, caret = lines[i + 1], lines[i + 2]
            assert caret.strip() == "^", out
            assert caret.index("^") - 4 == column - 1, out
            assert source[4:] != "" and source[4:].strip() != "", out
            return match.group(2)
    raise AssertionError(f"no error at {file}:{line} naming {words}:\n{out}")


# ============================================================================= the bulky box and unsolvable problems

def test_bulky_box_plan_has_two_grips_by_distinct_agents_in_one_simultaneous_group(tmp_path: Path) -> None:
    write_ap(tmp_path, TWO_ARMS, "box.ap")
    done = atlas("plan", "box.ap", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    data = plan_json(done)
    grips = [s for s in data["steps"] if s["action"].startswith("(grip ")]
    assert sorted(s["action"] for s in grips) == ["(grip left-arm box-1)", "(grip right-arm box-1)"]
    assert sorted(s["agent"] for s in grips) == ["left-arm", "right-arm"]
    assert [sorted(g) for g in data["simultaneous"]] == [sorted(s["id"] for s in grips)]
    assert grips[0]["start"] == grips[1]["start"]


def test_one_strong_one_armed_robot_is_unsolvable(tmp_path: Path) -> None:
    write_ap(tmp_path, bulky_box(["strong-robot"], {"strong-robot": 1000}), "strong.ap")
    done = atlas("plan", "strong.ap", "--json", cwd=tmp_path)
    assert done.returncode == 1
    data = plan_json(done)
    assert data["status"] == "unsolvable" and data["steps"] == []


def test_one_way_door_ends_unsolvable_not_in_a_hang(tmp_path: Path) -> None:
    write_ap(tmp_path, ONE_WAY_DOOR, "oneway.ap")
    started = time.monotonic()
    done = subprocess.run(atlas_command("plan", "oneway.ap"), cwd=tmp_path, capture_output=True,
                          text=True, env=ENV, timeout=30, check=False)
    assert time.monotonic() - started < 10
    assert done.returncode == 1
    assert_no_traceback(done)
    assert done.stdout.startswith("unsolvable")


def test_blocks_goal_cycle_ends_unsolvable(tmp_path: Path) -> None:
    blocks = ["b1", "b2", "b3", "b4"]
    init = " ".join(f"(ontable {b}) (clear {b})" for b in blocks) + " (handempty)"
    goal = "(on b1 b2) (on b2 b3) (on b3 b4) (on b4 b1)"
    write_problem(tmp_path, BLOCKS_DOMAIN, f"""\
(define (problem cycle) (:domain blocks) (:objects b1 b2 b3 b4)
  (:init {init}) (:goal (and {goal})))
""", "cycle.pddl")
    started = time.monotonic()
    done = subprocess.run(atlas_command("plan", "--pddl", "domain.pddl", "cycle.pddl", "--json"), cwd=tmp_path,
                          capture_output=True, text=True, env=ENV, timeout=30, check=False)
    assert time.monotonic() - started < 10
    assert done.returncode == 1
    assert plan_json(done)["status"] == "unsolvable"


# ============================================================================= PDDL plans are valid

@pytest.mark.parametrize("kind,size,seed", [("gripper", 2, 0), ("gripper", 4, 0), ("blocks", 5, 3), ("blocks", 7, 8)])
def test_pddl_plan_file_is_valid(tmp_path: Path, kind: str, size: int, seed: int) -> None:
    domain, problem = gripper_problem(tmp_path, size) if kind == "gripper" else blocks_problem(tmp_path, size, seed)
    done = atlas("plan", "--pddl", domain.name, problem.name, "--plan-file", "out.plan", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_no_traceback(done)
    assert done.stdout.startswith("solved")
    verdict = validate_plan_file(domain, problem, tmp_path / "out.plan")
    assert verdict.ok, verdict.message


# ============================================================================= same input, same plan

def run_with_hash_seed(args: list[str], cwd: Path, seed: str) -> subprocess.CompletedProcess:
    return subprocess.run(atlas_command(*args), cwd=cwd, capture_output=True, text=True,
                          env={**ENV, "PYTHONHASHSEED": seed}, timeout=60, check=False)


def test_same_input_gives_byte_identical_json(tmp_path: Path) -> None:
    domain, problem = gripper_problem(tmp_path, 20)
    args = ["plan", "--pddl", domain.name, problem.name, "--json"]
    first = run_with_hash_seed(args, tmp_path, "1")
    second = run_with_hash_seed(args, tmp_path, "2")
    assert first.returncode == second.returncode == 0
    assert first.stdout == second.stdout


@pytest.mark.parametrize("case", ["gripper", "door"])
def test_same_input_gives_the_same_plan(tmp_path: Path, case: str) -> None:
    """The plan itself (all but the timing statistics) across processes."""
    if case == "gripper":
        domain, problem = gripper_problem(tmp_path, 20)
        args = ["plan", "--pddl", domain.name, problem.name, "--json"]
    else:
        write_ap(tmp_path, door_problem(things=("parcel", "box"), people=("person", "visitor")), "door.ap")
        args = ["plan", "door.ap", "--json"]
    first = plan_json(run_with_hash_seed(args, tmp_path, "3"))
    second = plan_json(run_with_hash_seed(args, tmp_path, "4"))
    for data in (first, second):
        stats = data.pop("stats")
        assert stats["length"] >= 3
    assert first == second


# ============================================================================= bad input

def test_effect_with_a_new_arity(tmp_path: Path) -> None:
    (tmp_path / "bad.ap").write_text(ONE_WAY_DOOR.replace("(visited ?to)", "(visited ?to ?r)"))
    message = assert_located_error(atlas("plan", "bad.ap", cwd=tmp_path), "bad.ap", 7, "(visited ?to ?r)")
    assert "2 arguments" in message


def test_goal_no_operator_achieves(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(goals (visited hall) (at robot lab))", "(goals (visited hall) (flying robot))")
    (tmp_path / "bad.ap").write_text(text)
    assert_located_error(atlas("plan", "bad.ap", cwd=tmp_path), "bad.ap", 10, "goal", "(flying robot)")


def test_constraint_variable_of_an_agent_never_declared(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace(":preconditions", ":constraints ((strong ?helper))\n  :preconditions")
    (tmp_path / "bad.ap").write_text(text)
    assert_located_error(atlas("plan", "bad.ap", cwd=tmp_path), "bad.ap", 3, "?helper")


def test_operator_needing_agents_when_none_are_declared(tmp_path: Path) -> None:
    (tmp_path / "bad.ap").write_text(ONE_WAY_DOOR.replace("(agents (controlled robot))\n", ""))
    assert_located_error(atlas("plan", "bad.ap", cwd=tmp_path), "bad.ap", 3, "go", "agent")


def test_plot_cycle(tmp_path: Path) -> None:
    (tmp_path / "bad.ap").write_text(PLOT_CYCLE)
    done = atlas("plan", "bad.ap", cwd=tmp_path)
    assert done.returncode == 1
    assert_no_traceback(done)
    assert re.search(r"bad\.ap:(4|9):\d+: error: plot cycle: .*(fetch.*prepare|prepare.*fetch)", done.stderr), \
        done.stderr
    line = int(re.search(r"bad\.ap:(\d+):", done.stderr).group(1))
    assert_located_error(done, "bad.ap", line, "plot cycle")


def test_unsupported_pddl_feature_is_named(tmp_path: Path) -> None:
    domain = """\
(define (domain d)
  (:requirements :strips :adl)
  (:predicates (p ?x) (q ?x))
  (:action a
    :parameters (?x)
    :precondition (p ?x)
    :effect (and (q ?x) (decrease (fuel ?x) 1))))
"""
    write_problem(tmp_path, domain, "(define (problem pr) (:domain d) (:objects o) (:init (p o)) (:goal (q o)))\n")
    done = atlas("plan", "--pddl", "domain.pddl", "problem.pddl", cwd=tmp_path)
    assert_located_error(done, "domain.pddl", 7, "numeric fluents")


def test_missing_file_and_bad_usage(tmp_path: Path) -> None:
    done = atlas("plan", "nothing.ap", cwd=tmp_path)
    assert done.returncode == 1 and "nothing.ap" in done.stderr
    assert_no_traceback(done)
    done = atlas("plan", "--pddl", "only-one.pddl", cwd=tmp_path)
    assert done.returncode == 2
    assert_no_traceback(done)


# ============================================================================= the plan's output forms

def test_json_fields_and_schedule(tmp_path: Path) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    done = atlas("plan", "delivery.ap", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    data = plan_json(done)
    for key in ("status", "steps", "orderings", "links", "counterplan", "risk", "makespan"):
        assert key in data, key
    assert data["status"] == "solved" and data["counterplan"] == [] and data["risk"] == 0
    ids = [s["id"] for s in data["steps"]]
    assert len(ids) == len(set(ids)) == 6
    by_id = {s["id"]: s for s in data["steps"]}
    for s in data["steps"]:
        assert set(s) >= {"id", "action", "operator", "agent", "start", "end"}
        assert s["agent"] in ("r1", "r2")
        assert s["action"].startswith(f"({s['operator']} ")
    for a, b in data["orderings"]:
        assert by_id[b]["start"] >= by_id[a]["end"]
    for link in data["links"]:
        assert set(link) == {"from", "to", "fact"}
        assert link["from"] == "init" or link["from"] in by_id
        assert link["to"] == "goal" or link["to"] in by_id
        if link["from"] != "init" and link["to"] != "goal":
            assert by_id[link["to"]]["start"] >= by_id[link["from"]]["end"]
    assert {link["fact"] for link in data["links"] if link["to"] == "goal"} == {"(at p1 lab)", "(at p2 office)"}
    assert data["makespan"] == max(s["end"] for s in data["steps"]) == 3
    # the two robots work at the same time
    assert sorted(s["start"] for s in data["steps"]) == [0, 0, 1, 1, 2, 2]


def test_json_counterplan_and_risk(tmp_path: Path) -> None:
    write_ap(tmp_path, door_problem(), "door.ap")
    data = plan_json(atlas("plan", "door.ap", "--json", cwd=tmp_path))
    prop = next(s for s in data["steps"] if s["action"].startswith("(prop-door"))
    assert data["counterplan"] == [{"step": prop["id"], "threat": "(close-door person d1)", "protects": "(open d1)"}]
    assert data["risk"] == 0 and data["risk_before_counterplanning"] == pytest.approx(0.3)
    bare = plan_json(atlas("plan", "door.ap", "--json", "--no-counterplan", cwd=tmp_path))
    assert bare["counterplan"] == [] and bare["risk"] == pytest.approx(0.3)
    assert not any(s["action"].startswith("(prop-door") for s in bare["steps"])


def test_simultaneous_steps_share_a_start(tmp_path: Path) -> None:
    text = STATION
    (tmp_path / "station.ap").write_text(text)
    data = plan_json(atlas("plan", "station.ap", "--json", cwd=tmp_path))
    assert data["status"] == "solved"
    by_id = {s["id"]: s for s in data["steps"]}
    assert data["simultaneous"]
    for group in data["simultaneous"]:
        assert len(group) >= 2
        assert len({by_id[i]["start"] for i in group}) == 1
        assert len({by_id[i]["agent"] for i in group}) == len(group)
    for a, b in data["orderings"]:
        assert by_id[b]["start"] >= by_id[a]["end"]


def test_dot_is_a_digraph_mentioning_every_step(tmp_path: Path) -> None:
    write_ap(tmp_path, door_problem(), "door.ap")
    data = plan_json(atlas("plan", "door.ap", "--json", cwd=tmp_path))
    done = atlas("plan", "door.ap", "--dot", cwd=tmp_path)
    assert done.returncode == 0
    assert_no_traceback(done)
    dot = done.stdout.strip()
    assert dot.startswith("digraph") and dot.endswith("}")
    assert dot.count("{") == dot.count("}")
    for step in data["steps"]:
        node = re.search(rf'^\s*s{step["id"]} \[label="([^"]*)"', dot, re.MULTILINE)
        assert node, step
        assert step["action"] in node.group(1)
    for a, b in data["orderings"]:
        assert re.search(rf"^\s*s{a} -> s{b}\b", dot, re.MULTILINE), (a, b)


def test_plan_file_has_one_action_a_line_in_a_valid_order(tmp_path: Path) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    done = atlas("plan", "delivery.ap", "--json", "--plan-file", "out.plan", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    data = plan_json(done)
    lines = [line for line in (tmp_path / "out.plan").read_text().split("\n") if line.strip()]
    actions = [line for line in lines if not line.startswith(";")]
    assert all(re.fullmatch(r"\([a-z0-9-]+( [a-z0-9-]+)*\)", line) for line in actions), lines
    assert len(actions) == len(data["steps"]) == len(read_plan_file(tmp_path / "out.plan"))
    assert sorted(actions) == sorted(s["action"] for s in data["steps"])
    # the file's order is one of the plan's linearisations
    position = {s["action"]: s["id"] for s in data["steps"]}
    written = [position[a] for a in actions]
    assert written in list(linearisations(len(written), data["orderings"], first=1))


def test_no_plan_file_when_unsolvable(tmp_path: Path) -> None:
    write_ap(tmp_path, ONE_WAY_DOOR, "oneway.ap")
    done = atlas("plan", "oneway.ap", "--plan-file", "out.plan", cwd=tmp_path)
    assert done.returncode == 1
    assert not (tmp_path / "out.plan").exists()


# ============================================================================= a file with no goals

def test_a_file_with_no_goals_is_an_error_naming_the_file_as_typed(tmp_path: Path) -> None:
    """An operators file planned without its goals file: not 'solved: 0 steps'."""
    (tmp_path / "ops").mkdir()
    (tmp_path / "ops" / "door-ops.ap").write_text(DOOR_OPERATORS)
    done = atlas("plan", "ops/door-ops.ap", cwd=tmp_path)
    assert done.returncode == 1, (done.stdout, done.stderr)
    assert_no_traceback(done)
    assert "no goals in ops/door-ops.ap" in done.stderr
    assert "solved" not in done.stdout + done.stderr
    data = plan_json(atlas("plan", "ops/door-ops.ap", "--json", cwd=tmp_path))
    assert data["status"] == "error" and data["steps"] == []
    assert [(p["file"], p["message"]) for p in data["problems"]] == [("ops/door-ops.ap", "no goals in ops/door-ops.ap")]


def test_a_pddl_problem_with_no_goals_is_an_error(tmp_path: Path) -> None:
    write_problem(tmp_path, BLOCKS_DOMAIN, "(define (problem p) (:domain blocks) (:objects b1)\n"
                                           "  (:init (ontable b1) (clear b1) (handempty)) (:goal (and)))\n")
    done = atlas("plan", "--pddl", "domain.pddl", "problem.pddl", cwd=tmp_path)
    assert done.returncode == 1
    assert_no_traceback(done)
    assert "no goals in problem.pddl" in done.stderr


# ============================================================================= --json prints JSON whatever happens

def test_json_of_a_goal_no_operator_achieves_is_unsolvable_with_its_location(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(goals (visited hall) (at robot lab))", "(goals (visited hall) (flying robot))")
    (tmp_path / "bad.ap").write_text(text)
    done = atlas("plan", "bad.ap", "--json", cwd=tmp_path)
    assert_located_error(done, "bad.ap", 10, "goal", "(flying robot)")  # the caret report, on stderr
    data = plan_json(done)
    assert data["status"] == "unsolvable" and data["steps"] == []
    assert "(flying robot)" in data["reason"]
    [problem] = data["problems"]
    column = text.split("\n")[9].index("(flying robot)") + 1
    assert (problem["file"], problem["line"], problem["column"]) == ("bad.ap", 10, column)
    assert "(flying robot)" in problem["message"] and problem["hint"]


def test_json_of_a_goal_no_sequence_of_actions_reaches_is_unsolvable_with_its_location(tmp_path: Path) -> None:
    """An operator could make (visited attic) true, but nothing ever lets it."""
    text = ONE_WAY_DOOR.replace("(goals (visited hall) (at robot lab))", "(goals (visited attic))")
    (tmp_path / "attic.ap").write_text(text)
    done = atlas("plan", "attic.ap", "--json", cwd=tmp_path)
    assert_located_error(done, "attic.ap", 10, "(visited attic)")
    data = plan_json(done)
    assert data["status"] == "unsolvable" and "(visited attic)" in data["reason"]
    assert [(p["file"], p["line"], p["column"]) for p in data["problems"]] == [("attic.ap", 10, 8)]
    text_done = atlas("plan", "attic.ap", cwd=tmp_path)
    assert text_done.stdout.startswith("unsolvable")
    assert_located_error(text_done, "attic.ap", 10, "(visited attic)")


def test_json_of_a_syntax_error_is_an_error_with_its_location(tmp_path: Path) -> None:
    (tmp_path / "broken.ap").write_text(ONE_WAY_DOOR.replace("(initial (at robot lab)", "(initial (at robot lab"))
    done = atlas("plan", "broken.ap", "--json", cwd=tmp_path)
    message = assert_located_error(done, "broken.ap", 9)
    data = plan_json(done)
    assert data["status"] == "error" and data["steps"] == [] and data["risk"] == 0
    [problem] = data["problems"]
    assert (problem["file"], problem["line"], problem["message"]) == ("broken.ap", 9, message)


def test_json_of_a_missing_file_is_an_error(tmp_path: Path) -> None:
    data = plan_json(atlas("plan", "nothing.ap", "--json", cwd=tmp_path))
    assert data["status"] == "error"
    assert [p["file"] for p in data["problems"]] == ["nothing.ap"]


def test_every_json_result_has_the_same_keys(tmp_path: Path) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    write_ap(tmp_path, ONE_WAY_DOOR, "oneway.ap")
    (tmp_path / "empty.ap").write_text("(initial (at robot lab))\n")
    keys = [set(plan_json(atlas("plan", name, "--json", cwd=tmp_path)))
            for name in ("delivery.ap", "oneway.ap", "empty.ap")]
    assert keys[0] - {"reason"} == keys[1] - {"reason"} == keys[2] - {"reason"}
    assert {"threats", "problems"} <= keys[0]


# ============================================================================= output paths and --timeout

@pytest.mark.parametrize("option,name", [("--render", "p.png"), ("--plan-file", "p.plan")])
def test_an_output_in_a_missing_folder_makes_the_folder(tmp_path: Path, option: str, name: str) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    done = atlas("plan", "delivery.ap", option, f"nodir/deeper/{name}", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_no_traceback(done)
    written = tmp_path / "nodir" / "deeper" / name
    assert written.is_file() and written.stat().st_size > 0
    if option == "--render":
        assert written.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("option", ["--render", "--plan-file"])
def test_an_output_that_cannot_be_created_is_a_one_line_error(tmp_path: Path, option: str) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    (tmp_path / "a-file").write_text("not a folder\n")
    done = atlas("plan", "delivery.ap", option, "a-file/out", cwd=tmp_path)
    assert done.returncode == 1
    assert_no_traceback(done)
    lines = done.stderr.strip().split("\n")
    assert len(lines) == 1 and option in lines[0] and "a-file" in lines[0], done.stderr
    done = atlas("plan", "delivery.ap", option, ".", cwd=tmp_path)  # a folder, not a file
    assert done.returncode == 1
    assert_no_traceback(done)
    assert len(done.stderr.strip().split("\n")) == 1 and option in done.stderr


@pytest.mark.parametrize("value", ["0", "-5"])
def test_timeout_must_be_positive(tmp_path: Path, value: str) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    done = atlas("plan", "delivery.ap", "--timeout", value, cwd=tmp_path)
    assert done.returncode == 2
    assert_no_traceback(done)
    assert "--timeout" in done.stderr and "solved" not in done.stdout


# ============================================================================= NO_COLOR

def stderr_on_a_terminal(args: list[str], cwd: Path, env: dict[str, str]) -> str:
    """What `atlas ARGS` writes to stderr when stderr is a terminal (a pty)."""
    main, terminal = pty.openpty()
    try:
        subprocess.run(atlas_command(*args), cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                       stdout=subprocess.DEVNULL, stderr=terminal, timeout=60, check=False)
    finally:
        os.close(terminal)
    chunks = []
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:  # the terminal is closed and drained
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(main)
    return b"".join(chunks).decode()


def test_no_colour_on_a_terminal_when_no_color_is_set(tmp_path: Path) -> None:
    write_ap(tmp_path, door_problem(), "door.ap")
    (tmp_path / "raps").mkdir()
    args = ["plan", "door.ap", "--check-raps", "raps"]
    styled = stderr_on_a_terminal(args, tmp_path, ENV)
    assert "no RAP in raps can execute it" in styled and "\x1b[" in styled  # red on a terminal...
    plain = stderr_on_a_terminal(args, tmp_path, {**ENV, "NO_COLOR": "1"})
    assert "no RAP in raps can execute it" in plain and "\x1b[" not in plain  # ...but not with NO_COLOR


@pytest.mark.parametrize("text", ["x\n", "(foo) bar\n", ""])
def test_a_pddl_file_that_is_no_define_form_is_an_error_with_a_caret_not_a_traceback(tmp_path: Path, text: str) -> None:
    (tmp_path / "domain.pddl").write_text(text, encoding="utf-8")
    (tmp_path / "problem.pddl").write_text(text, encoding="utf-8")
    done = atlas("plan", "--pddl", "domain.pddl", "problem.pddl", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "domain.pddl:1:1: error:" in done.stdout + done.stderr


def test_the_shipped_pddl_example_is_found_from_any_folder(tmp_path: Path) -> None:
    done = atlas("plan", "--pddl", "operators/pddl/rooms-domain.pddl", "operators/pddl/rooms-problem.pddl",
                 "--plan-file", "plan.txt", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "plan.txt").read_text(encoding="utf-8").splitlines()[-2] == "(drop box storeroom)"


def test_shorten_searches_again_for_a_shorter_plan(tmp_path: Path) -> None:
    from pddl_problems import SHARED_PDDL

    folder = SHARED_PDDL / "elevators-sat08-strips"
    if not folder.is_dir():
        pytest.skip(f"the public PDDL benchmarks are not here ({SHARED_PDDL} is absent)")
    domain, problem = folder / "domain.pddl", folder / "p05.pddl"
    first = plan_json(atlas("plan", "--pddl", str(domain), str(problem), "--json", "--timing", cwd=tmp_path))
    done = atlas("plan", "--pddl", str(domain), str(problem), "--json", "--timing", "--shorten",
                 "--plan-file", "shorter.plan", cwd=tmp_path)
    shorter = plan_json(done)
    # the first plan (LAMA's first search) has 35 steps; searching again from the start finds 32
    assert shorter["status"] == "solved" and shorter["stats"]["length"] < first["stats"]["length"]
    assert shorter["timing"]["shorten_seconds"] > first["timing"]["shorten_seconds"]
    assert validate_plan_file(domain, problem, tmp_path / "shorter.plan").ok
