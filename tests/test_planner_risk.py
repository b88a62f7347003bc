"""What a plan risks, as `atlas plan` shows it: each threat left (the uncontrolled
action as written, the step after which it may happen, the causal link it
breaks, its probability) in the JSON, the text and the --render picture, and
the risk is made of exactly those threats."""

from __future__ import annotations

import json
import math
import subprocess
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from cli_process import REPO, assert_no_traceback, atlas
from matplotlib.image import imread
from planner_cases import TOOL_TAKEN, write_ap

OPERATORS = REPO / "operators"

# The person's probabilities in operators/adversarial.ap.
P_CLOSE_DOOR = 0.3
P_TAKE_TOOL = 0.2
CLOSE_DOOR = "(person-closes-door person lab-door)"
TAKE_TOOL = "(person-takes-tool person wrench tool-cabinet)"
DOOR_OPEN = "(door-open lab-door)"
TOOL_IN = "(tool-in wrench tool-cabinet)"

THREAT_RGB = (0xc9, 0x2a, 0x2a)  # how render.py draws a threat left

def plan_operators(*args: str) -> subprocess.CompletedProcess:
    done = atlas("plan", *args, cwd=OPERATORS)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    return done


@lru_cache(maxsize=None)
def plan_json(goals: str, *flags: str) -> dict:
    return json.loads(plan_operators(goals, "--json", *flags).stdout)


def action_of(data: dict, step_id: int) -> str:
    return next(s["action"] for s in data["steps"] if s["id"] == step_id)


def threat_story(data: dict) -> list[tuple]:
    """Each threat as a reader checks it: the action, the step after which it may
    happen, the link (producer step, fact, consumer step) by their actions."""
    def name(end: object) -> object:
        return end if end in ("init", "goal") else action_of(data, end)

    return [(t["action"], action_of(data, t["after"]), name(t["link"]["from"]), t["link"]["fact"],
             name(t["link"]["to"]), t["probability"]) for t in data["threats"]]


def risk_of_threats(threats: list[dict]) -> float:
    """1 - prod(1 - p) over the distinct events of the listed threats."""
    probability = {t["event"]: t["probability"] for t in threats}
    return 1 - math.prod(1 - p for p in probability.values())


def assert_threats_make_the_risk(data: dict) -> None:
    assert data["risk"] == pytest.approx(risk_of_threats(data["threats"]), abs=1e-9)
    for t in data["threats"]:
        assert t["link"] in data["links"], t  # a causal link of the plan
        assert set(t) >= {"action", "operator", "agent", "after", "link", "probability", "event"}


# ============================================================================= JSON

PLAIN_THREATS = [
    (CLOSE_DOOR, "(grasp-object robot valve)", "init", DOOR_OPEN, "(pass-door robot lab-door workshop)",
     P_CLOSE_DOOR),
    (TAKE_TOOL, "(grasp-object robot valve)", "init", TOOL_IN, "(fetch-tool robot wrench tool-cabinet)",
     P_TAKE_TOOL),
    (TAKE_TOOL, "(pass-door robot lab-door workshop)", "init", TOOL_IN, "(fetch-tool robot wrench tool-cabinet)",
     P_TAKE_TOOL),
]


def test_unprotected_plan_names_each_threat_that_makes_its_risk() -> None:
    """The door may be shut after the first step, the wrench taken after the first or
    the second: 1 - 0.7 * 0.8^2 = 0.552."""
    data = plan_json("adversarial-unprotected.ap")
    assert data["risk"] == pytest.approx(0.552)
    assert threat_story(data) == PLAIN_THREATS
    assert {t["agent"] for t in data["threats"]} == {"person"}
    assert {t["operator"] for t in data["threats"]} == {"person-closes-door", "person-takes-tool"}
    assert_threats_make_the_risk(data)


def test_without_counterplanning_the_same_threats_are_named() -> None:
    data = plan_json("adversarial-goals.ap", "--no-counterplan")
    assert data["risk"] == pytest.approx(0.552)
    assert threat_story(data) == PLAIN_THREATS
    assert_threats_make_the_risk(data)


def test_a_protected_plan_has_no_threats_left() -> None:
    data = plan_json("adversarial-goals.ap")
    assert data["risk"] == 0 and data["threats"] == []


def test_partly_protected_plan_names_only_the_threat_it_could_not_answer() -> None:
    """The door is propped; the wrench may go after each of the three steps before it is taken."""
    data = plan_json("adversarial-partial.ap")
    assert data["risk"] == pytest.approx(1 - (1 - P_TAKE_TOOL) ** 3)
    story = threat_story(data)
    assert [s[0] for s in story] == [TAKE_TOOL] * 3
    assert [s[1] for s in story] == ["(grasp-object robot valve)", "(place-door-stop robot lab-door)",
                                     "(pass-door robot lab-door workshop)"]
    assert {s[2:5] for s in story} == {("init", TOOL_IN, "(fetch-tool robot wrench tool-cabinet)")}
    assert CLOSE_DOOR not in {t["action"] for t in data["threats"]}
    assert_threats_make_the_risk(data)


def test_one_event_with_many_groundings_is_one_chance_of_defeat(tmp_path: Path) -> None:
    """Wherever the person leaves the wrench, taking it is one event: every grounding
    is listed, with one event number, and the risk is 0.2, not 1 - 0.8^4."""
    write_ap(tmp_path, TOOL_TAKEN, "tool.ap")
    done = atlas("plan", "tool.ap", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["risk"] == pytest.approx(0.2)
    assert len(data["threats"]) > 1
    assert len({t["event"] for t in data["threats"]}) == 1
    assert {t["link"]["fact"] for t in data["threats"]} == {"(tool-in wrench workshop)"}
    assert_threats_make_the_risk(data)


# ============================================================================= text

def test_text_lists_each_threat_under_the_risk_line() -> None:
    lines = plan_operators("adversarial-unprotected.ap").stdout.rstrip("\n").split("\n")
    at = next(i for i, line in enumerate(lines) if line.startswith("risk left: 0.552"))
    threats = lines[at + 1:]
    assert len(threats) == 3, lines
    assert CLOSE_DOOR in threats[0] and "after step 1" in threats[0] and DOOR_OPEN in threats[0]
    assert "0.3" in threats[0] and "initial state" in threats[0] and "step 2" in threats[0]
    for line, after in zip(threats[1:], ("after step 1", "after step 2")):
        assert TAKE_TOOL in line and after in line and TOOL_IN in line and "0.2" in line and "step 3" in line


def test_text_of_a_protected_plan_names_no_threat() -> None:
    out = plan_operators("adversarial-goals.ap").stdout
    assert "risk left" not in out and "may undo" not in out


# ============================================================================= the picture

def threat_pixels(png: Path) -> np.ndarray:
    """A mask of the pixels drawn in the threat colour."""
    image = imread(png)[..., :3]
    return np.all(np.abs(image - np.array(THREAT_RGB) / 255.0) < 0.08, axis=-1)


def test_the_picture_marks_and_names_the_threats_left(tmp_path: Path) -> None:
    threatened, safe = tmp_path / "threatened.png", tmp_path / "safe.png"
    plan_operators("adversarial-unprotected.ap", "--render", str(threatened))
    plan_operators("adversarial-goals.ap", "--render", str(safe))
    marks = threat_pixels(threatened)
    assert not threat_pixels(safe).any()  # nothing threatens the protected plan
    rows = np.flatnonzero(marks.any(axis=1))
    height = marks.shape[0]
    # marks on the chart, and a note of several lines under it
    assert rows.min() < height * 0.6, rows
    chart_left = np.flatnonzero(marks[: int(height * 0.6)].any(axis=0)).min()  # the threat lines start here
    notes = marks[int(height * 0.6):, : chart_left + 5]  # the notes are left-aligned under the chart;
    note_rows = np.flatnonzero(notes.any(axis=1))        # the legend's red mark stands further right
    assert len(note_rows) > 0
    lines_of_text = 1 + np.count_nonzero(np.diff(note_rows) > 1)
    assert lines_of_text == 1 + len(plan_json("adversarial-unprotected.ap")["threats"])  # a heading, a line each
