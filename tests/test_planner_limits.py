"""Limits that hold: --timeout and --memory bound the whole planner run, every phase, and
what comes back says what happened; a plan cut short is never passed off as safe."""

from __future__ import annotations

import json
import resource
import subprocess
from pathlib import Path

from cli_process import REPO, assert_no_traceback, atlas_command, ENV
from pddl_problems import triangle_tireworld_problem

from atlas_rap.lang import load
from atlas_rap.planner.limits import Limits
from atlas_rap.planner.problem import problem_from_program
from atlas_rap.planner.solve import solve

OPERATORS = REPO / "operators"


def run_plan(*args: str, cwd: Path) -> tuple[subprocess.CompletedProcess, float]:
    """``atlas plan ARGS`` and the CPU seconds the child used (user + system)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(atlas_command("plan", *args), cwd=cwd, capture_output=True, text=True, env=ENV,
                          timeout=600)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return done, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def test_a_timeout_bounds_the_whole_run_and_the_status_says_what_happened(tmp_path: Path) -> None:
    domain, problem = triangle_tireworld_problem(tmp_path, 60)  # needs far longer than 3 s
    done, cpu = run_plan("--pddl", str(domain), str(problem), "--timeout", "3", "--json", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    result = json.loads(done.stdout)
    assert result["status"] == "timeout" and result["steps"] == []
    assert result["reason"].startswith("the time limit of 3 s ran out")
    assert result["limits"]["reached"] == "timeout" and result["limits"]["timeout_s"] == 3
    assert cpu <= 3.5, cpu  # the whole process, start-up included


def test_a_memory_limit_holds_the_same_way(tmp_path: Path) -> None:
    done, _ = run_plan(str(OPERATORS / "evahr-goals.ap"), "--memory", "1", "--json", cwd=tmp_path)
    result = json.loads(done.stdout)
    assert done.returncode == 1
    assert result["status"] == "memory" and "the memory limit of 1 MB ran out" in result["reason"]
    assert result["limits"] == {"timeout_s": 60.0, "memory_mb": 1.0, "reached": "memory",
                                "during": "grounding"}


def test_timing_shows_every_phase_counterplanning_included(tmp_path: Path) -> None:
    done, _ = run_plan(str(OPERATORS / "adversarial-goals.ap"), "--json", "--timing", cwd=tmp_path)
    timing = json.loads(done.stdout)["timing"]
    phases = ("startup_seconds", "ground_seconds", "search_seconds", "shorten_seconds", "counterplan_seconds",
              "order_seconds")
    assert set(phases) <= set(timing)
    assert timing["seconds"] >= sum(timing[p] for p in phases) - 0.01


class RunsOutIn(Limits):
    """Limits that run out in ``phase``, after ``checks`` questions in it (a scripted budget,
    for the rules of what is returned)."""

    def __init__(self, phase: str, checks: int = 0) -> None:
        super().__init__(60.0)
        self.out_in = phase
        self.checks = checks

    def expired(self) -> bool:
        if self.reached is None and self.phase == self.out_in:
            if self.checks == 0:
                self.reached, self.during = "timeout", self.phase
            self.checks -= 1
        return self.reached is not None


def goals_problem(name: str):
    return problem_from_program(load(OPERATORS / name))


def test_a_plan_found_before_the_limit_is_returned_marked_as_the_best_by_then() -> None:
    plan = solve(goals_problem("evahr-goals.ap"), limits=RunsOutIn("shortening"))
    assert plan.status == "solved" and plan.steps
    assert plan.limits["reached"] == "timeout" and plan.limits["during"] == "shortening"
    assert "ran out during shortening: this is the best plan found by then" in plan.to_text()


def test_a_plan_whose_counterplanning_was_cut_is_not_passed_off_as_safe() -> None:
    unprotected = solve(goals_problem("adversarial-goals.ap"), protect=False)
    assert unprotected.risk > 0  # there is something to protect against
    before_threats_known = solve(goals_problem("adversarial-goals.ap"), limits=RunsOutIn("counterplanning"))
    assert before_threats_known.status == "timeout" and not before_threats_known.steps
    assert "before the plan's threats were known: it is not returned as safe" in before_threats_known.reason
    plan = solve(goals_problem("adversarial-goals.ap"), limits=RunsOutIn("counterplanning", checks=1))
    assert plan.status == "timeout" and not plan.steps
    assert f"while counterplanning: the best plan so far has risk {unprotected.risk:g}" in plan.reason
    safe = solve(goals_problem("adversarial-goals.ap"))
    assert safe.status == "solved" and safe.risk == 0
