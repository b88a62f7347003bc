"""The shipped planning domains (operators/*.ap) planned with the real `atlas plan`,
as a user would check them: each goals file is solved (or, for the one-arm bulky
variant, reported unsolvable), the plans show what each domain is about
(simultaneous grips by distinct agents, preventive steps against a person,
the risk left when nothing can prevent, a makespan within the deadline), every
step has a RAP in rap_library/plan_steps, and the same input gives the same plan."""

from __future__ import annotations

import json
import subprocess
from functools import lru_cache
from pathlib import Path

import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

OPERATORS = REPO / "operators"
PLAN_STEPS = REPO / "rap_library" / "plan_steps"

SOLVED = [
    "office-goals.ap",
    "bulky-object-goals.ap",
    "space-station-repair-goals.ap",
    "space-station-goals.ap",
    "adversarial-goals.ap",
    "adversarial-partial.ap",
    "adversarial-unprotected.ap",
]
DOMAIN_FILES = ["office.ap", "bulky-object.ap", "space-station-maintenance.ap", "adversarial.ap",
                "bulky-object-one-arm.ap", *SOLVED]

# The person's probabilities in operators/adversarial.ap.
P_CLOSE_DOOR = 0.3
P_TAKE_TOOL = 0.2
# The plain plan (valve, door, wrench, repair): the door may be shut after
# step 1, the wrench taken after step 1 or 2.
PLAIN_RISK = 1 - (1 - P_CLOSE_DOOR) * (1 - P_TAKE_TOOL) ** 2
# Door propped, wrench exposed after each of the three steps before it is taken.
PARTIAL_RISK = 1 - (1 - P_TAKE_TOOL) ** 3

CLOSE_DOOR = "(person-closes-door person lab-door)"
TAKE_TOOL = "(person-takes-tool person wrench tool-cabinet)"


def plan_operators(*args: str) -> subprocess.CompletedProcess:
    done = atlas("plan", *args, cwd=OPERATORS)
    assert_no_traceback(done)
    return done


@lru_cache(maxsize=None)
def solved(goals: str, *flags: str) -> dict:
    """The JSON plan of operators/GOALS, checked against the RAPs of
    rap_library/plan_steps (run once per module: the CLI is the slow part)."""
    done = plan_operators(goals, "--json", "--check-raps", str(PLAN_STEPS), *flags)
    assert done.returncode == 0, (done.stdout, done.stderr)
    assert f"every step has a RAP in {PLAN_STEPS}" in done.stderr
    data = json.loads(done.stdout)
    assert data["status"] == "solved"
    return data


def steps_named(data: dict, name: str) -> list[dict]:
    return [s for s in data["steps"] if s["action"].startswith(f"({name} ")]


def by_id(data: dict) -> dict[int, dict]:
    return {s["id"]: s for s in data["steps"]}


# ============================================================================= every file is clean and solved

def test_every_domain_file_and_plan_step_rap_passes_atlas_check() -> None:
    files = [str(OPERATORS / f) for f in DOMAIN_FILES] + sorted(str(p) for p in PLAN_STEPS.glob("*.rap"))
    done = atlas("check", *files, cwd=REPO)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in done.stdout + done.stderr


@pytest.mark.parametrize("goals", SOLVED)
def test_goals_file_is_solved_and_every_step_has_a_rap(goals: str) -> None:
    data = solved(goals)
    assert data["steps"] and all(s["end"] > s["start"] for s in data["steps"])


@pytest.mark.parametrize("goals", SOLVED)
def test_no_agent_does_two_steps_at_once(goals: str) -> None:
    """Steps that overlap in time have distinct agents (the robot cannot push a door
    and grasp the mail together; the two arms of one robot are two agents)."""
    steps = solved(goals)["steps"]
    overlapping = [(a["action"], b["action"]) for a in steps for b in steps
                   if a["id"] < b["id"] and a["agent"] is not None and a["agent"] == b["agent"]
                   and a["start"] < b["end"] and b["start"] < a["end"]]
    assert overlapping == []


# ============================================================================= office navigation

def office_deadline() -> float:
    """The deadline of the delivery, as the planner reads it from office-goals.ap's (deadline ...) form."""
    from atlas_rap.lang import load
    from atlas_rap.planner.problem import problem_from_program

    deadline = problem_from_program(load(OPERATORS / "office-goals.ap")).deadline_for()
    assert deadline is not None, "office-goals.ap states its deadline"
    return deadline


def test_office_mail_reaches_office_b_within_the_deadline() -> None:
    data = solved("office-goals.ap")
    assert 0 < data["makespan"] <= office_deadline() == 150
    assert (data["deadline"], data["meets_deadline"]) == (150, True)
    assert data["makespan"] == max(s["end"] for s in data["steps"])
    last = max(data["steps"], key=lambda s: s["end"])
    assert last["action"] == "(hand-over-object robot mail office-b)"
    assert {s["agent"] for s in data["steps"]} == {"robot", "lift-1"}
    assert data["risk"] == 0 and data["counterplan"] == []


def test_office_plan_opens_both_doors_and_rides_the_elevator_up() -> None:
    data = solved("office-goals.ap")
    actions = [s["action"] for s in sorted(data["steps"], key=lambda s: (s["start"], s["id"]))]
    assert actions.count("(push-door-open robot door-a)") == 1
    assert actions.count("(push-door-open robot door-b)") == 1
    assert "(push-door-open robot door-c)" not in actions
    assert actions.index("(grasp-object robot mail)") < actions.index("(enter-elevator robot lift-1)")
    assert actions.index("(leave-elevator robot lift-1 lobby-2)") < actions.index("(pass-door robot door-b office-b)")
    assert "(select-floor robot lift-1 floor-2)" in actions


def test_office_elevator_comes_down_while_the_robot_fetches_the_mail() -> None:
    """The car (an agent of its own) is called over the network, so its trip overlaps
    the robot's walk to office A; boarding waits for both."""
    data = solved("office-goals.ap")
    steps = by_id(data)
    [call] = steps_named(data, "request-elevator")
    [grasp] = steps_named(data, "grasp-object")
    [board] = steps_named(data, "enter-elevator")
    assert call["action"] == "(request-elevator lift-1 floor-1)" and call["agent"] == "lift-1"
    first_walk = min((s for s in data["steps"] if s["agent"] == "robot"), key=lambda s: s["start"])
    assert call["start"] == first_walk["start"] == 0
    assert call["end"] <= grasp["start"]
    before_board = {a for a, b in data["orderings"] if b == board["id"]}
    assert call["id"] in before_board
    assert board["start"] >= max(call["end"], grasp["end"])
    assert all(steps[b]["start"] >= steps[a]["end"] for a, b in data["orderings"])


def test_check_raps_names_the_step_no_rap_can_execute(tmp_path: Path) -> None:
    """A RAP folder without request-elevator: exit 1, and the step is named."""
    text = (PLAN_STEPS / "office-steps.rap").read_text()
    start = text.index("(define-rap (request-elevator")
    end = text.index("\n\n", start)
    folder = tmp_path / "raps"
    folder.mkdir()
    (folder / "office-steps.rap").write_text(text[:start] + text[end:])
    assert atlas("check", str(folder / "office-steps.rap"), cwd=tmp_path).returncode == 0
    done = plan_operators("office-goals.ap", "--json", "--check-raps", str(folder))
    assert done.returncode == 1, (done.stdout, done.stderr)
    assert json.loads(done.stdout)["status"] == "solved"
    missing = [line for line in done.stderr.splitlines() if "no RAP" in line]
    assert len(missing) == 1, done.stderr
    assert "(request-elevator lift-1 floor-1)" in missing[0]
    assert str(folder) in missing[0]


# ============================================================================= bulky objects

def test_two_weak_robots_grip_the_crate_at_once() -> None:
    data = solved("bulky-object-goals.ap")
    steps = by_id(data)
    groups = [sorted(g) for g in data["simultaneous"]]
    crate_grips = [s for s in steps_named(data, "grip") if s["action"].endswith(" crate-1)")]
    assert len(crate_grips) == 2
    assert sorted(s["id"] for s in crate_grips) in groups
    assert {s["agent"] for s in crate_grips} == {"robot-a", "robot-b"}
    assert crate_grips[0]["start"] == crate_grips[1]["start"]
    for group in groups:
        agents = [steps[i]["agent"] for i in group]
        assert len(group) == 2 and len(set(agents)) == 2 and None not in agents
        assert len({steps[i]["start"] for i in group}) == 1


def test_the_two_armed_robots_arms_lift_the_panel_and_the_busy_strong_robot_is_not_used() -> None:
    data = solved("bulky-object-goals.ap")
    panel_grips = [s for s in steps_named(data, "grip") if s["action"].endswith(" panel-1)")]
    assert {s["agent"] for s in panel_grips} == {"twin-left", "twin-right"}
    assert "strong-robot" not in {s["agent"] for s in data["steps"]}
    releases = steps_named(data, "release")
    assert {s["action"] for s in releases} == {"(release robot-a crate-1 cart)", "(release robot-b crate-1 cart)"}
    crate_grip_ids = {s["id"] for s in steps_named(data, "grip") if "crate-1" in s["action"]}
    for release in releases:
        assert crate_grip_ids <= {a for a, b in data["orderings"] if b == release["id"]}


def test_one_strong_one_armed_robot_cannot_lift_the_crate_alone() -> None:
    done = plan_operators("bulky-object-one-arm.ap", "--json")
    assert done.returncode == 1, (done.stdout, done.stderr)
    data = json.loads(done.stdout)
    assert data["status"] == "unsolvable"
    assert data["steps"] == []
    assert "(holding planner crate-1)" in data["reason"]


# ============================================================================= space-station maintenance

def test_station_repair_flies_attaches_inspects_unloads_with_two_arms_repairs_and_flies_home() -> None:
    data = solved("space-station-repair-goals.ap")
    steps = by_id(data)
    first = min(data["steps"], key=lambda s: (s["start"], s["id"]))
    last = max(data["steps"], key=lambda s: s["end"])
    assert first["action"] == "(fly robot truss-site)" and first["agent"] == "robot"
    assert last["action"] == "(fly robot dock)"
    [latch] = steps_named(data, "latch-onto")
    assert latch["action"] == "(latch-onto robot ap-7)"
    grips = steps_named(data, "grip")
    assert {s["action"] for s in grips} == {"(grip left-arm spare-pump)", "(grip right-arm spare-pump)"}
    assert sorted(s["id"] for s in grips) in [sorted(g) for g in data["simultaneous"]]
    camera = [s for s in data["steps"] if s["agent"] == "camera-1"]
    assert [s["action"].split()[0] for s in camera] == ["(aim-camera", "(take-image", "(downlink-image"]
    [install] = steps_named(data, "install-part")
    [unlatch] = steps_named(data, "unlatch")
    for s in camera + grips:
        assert latch["end"] <= s["start"] and s["end"] <= install["start"]
    assert install["end"] <= unlatch["start"]
    assert camera[0]["start"] == grips[0]["start"]  # the camera works while the arms unload
    assert all(steps[b]["start"] >= steps[a]["end"] for a, b in data["orderings"])
    assert data["risk"] == 0


# ============================================================================= a person who interferes

def test_adversarial_plan_props_the_door_and_locks_the_tool_away() -> None:
    data = solved("adversarial-goals.ap")
    steps = by_id(data)
    assert data["risk"] == 0
    assert data["risk_before_counterplanning"] == pytest.approx(PLAIN_RISK)
    answered = {(c["threat"], c["protects"]): steps[c["step"]]["action"] for c in data["counterplan"]}
    assert answered == {
        (CLOSE_DOOR, "(door-open lab-door)"): "(place-door-stop robot lab-door)",
        (TAKE_TOOL, "(tool-in wrench tool-cabinet)"): "(lock-cabinet robot tool-cabinet)",
    }
    [stop] = steps_named(data, "place-door-stop")
    [through] = steps_named(data, "pass-door")
    [fetch] = steps_named(data, "fetch-tool")
    [lock] = steps_named(data, "lock-cabinet")
    assert stop["end"] <= through["start"]
    assert lock["end"] <= fetch["start"]


def before(data: dict, first: int, then: int) -> bool:
    """Whether step ``first`` comes before step ``then`` in every linearisation
    (a path of orderings)."""
    after: dict[int, set[int]] = {}
    for a, b in data["orderings"]:
        after.setdefault(a, set()).add(b)
    seen, todo = set(), [first]
    while todo:
        for b in after.get(todo.pop(), ()):
            if b == then:
                return True
            if b not in seen:
                seen.add(b)
                todo.append(b)
    return False


def test_adversarial_preventive_steps_come_first_in_every_linearisation() -> None:
    """Risk 0 holds for whichever order an executive picks among unordered steps: the
    lock (whose effect no step of ours consumes) is still ordered before the wrench is
    exposed, and the door stop before the robot passes."""
    data = solved("adversarial-goals.ap")
    [stop] = steps_named(data, "place-door-stop")
    [lock] = steps_named(data, "lock-cabinet")
    [through] = steps_named(data, "pass-door")
    [fetch] = steps_named(data, "fetch-tool")
    [grasp] = steps_named(data, "grasp-object")
    assert before(data, stop["id"], through["id"])
    # the wrench is exposed after the first step: the lock must be that step
    assert before(data, lock["id"], grasp["id"]) and before(data, lock["id"], fetch["id"])


def test_adversarial_plan_without_counterplanning_carries_the_full_risk() -> None:
    data = solved("adversarial-goals.ap", "--no-counterplan")
    assert data["risk"] == pytest.approx(PLAIN_RISK) == pytest.approx(0.552)
    assert data["counterplan"] == []
    actions = {s["action"].split()[0] for s in data["steps"]}
    assert "(place-door-stop" not in actions and "(lock-cabinet" not in actions


def test_unprotected_variant_reports_the_expected_risk() -> None:
    data = solved("adversarial-unprotected.ap")
    assert data["risk"] == pytest.approx(PLAIN_RISK)
    assert data["risk_before_counterplanning"] == pytest.approx(PLAIN_RISK)
    assert data["counterplan"] == []
    assert [s["action"] for s in sorted(data["steps"], key=lambda s: s["start"])] == [
        "(grasp-object robot valve)", "(pass-door robot lab-door workshop)",
        "(fetch-tool robot wrench tool-cabinet)", "(fit-part robot valve press)",
        "(tighten robot wrench press)"]
    done = plan_operators("adversarial-unprotected.ap")
    assert "risk left: 0.552" in done.stdout


def test_partial_variant_protects_the_door_and_leaves_the_tool_at_risk() -> None:
    data = solved("adversarial-partial.ap")
    assert data["risk"] == pytest.approx(PARTIAL_RISK) == pytest.approx(0.488)
    assert data["risk_before_counterplanning"] == pytest.approx(PLAIN_RISK)
    assert [(c["threat"], c["protects"]) for c in data["counterplan"]] == [(CLOSE_DOOR, "(door-open lab-door)")]


# ============================================================================= reproducible

@pytest.mark.parametrize("goals", ["adversarial-goals.ap", "bulky-object-goals.ap"])
def test_same_input_gives_the_same_json_twice(goals: str) -> None:
    """Byte for byte, across processes with different hash seeds."""
    outputs = []
    for seed in ("11", "12"):
        done = subprocess.run(atlas_command("plan", goals, "--json"), cwd=OPERATORS, capture_output=True,
                              text=True, env={**ENV, "PYTHONHASHSEED": seed})
        assert_no_traceback(done)
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout)
    assert outputs[0] == outputs[1]
    assert json.loads(outputs[0])["stats"]["length"] > 0
