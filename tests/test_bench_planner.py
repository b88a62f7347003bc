"""The planner benchmark keeps working: ``benchmarks/bench_planner.py --quick`` runs as a subprocess
(under a minute) and every line it prints is JSON of the expected shape, with our planner solving every
problem it was given. Pyperplan and Fast Downward are optional (``pip install '.[bench]'``): a missing
peer is a line saying so, not a failure. The run needs the public PDDL benchmarks in
``../shared/data/pddl`` and skips, saying why, without them; the small tests below do not.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

REPO = Path(__file__).resolve().parent.parent
BENCH = REPO / "benchmarks" / "bench_planner.py"
SHARED_PDDL = REPO.parent / "shared" / "data" / "pddl"
CLASSICAL = ["blocks", "depot", "elevators-sat08-strips", "freecell", "gripper", "logistics00", "mprime",
             "pipesworld-notankage", "rovers", "scanalyzer-08-strips", "storage", "tpp", "transport-sat08-strips"]
QUICK_PROBLEMS, QUICK_TIREWORLD = 2, 2
PEERS = {"pyperplan": ["pyperplan", "pyperplan-cli"], "fd-lama-first": ["fd-lama-first"]}
ALL_PLANNERS = ["ours", "pyperplan", "ours-cli", "pyperplan-cli", "fd-lama-first"]
STATUSES = {"solved", "unsolvable", "timeout", "memout", "error", "invalid-plan", "unchecked", "unsupported"}

PLANNER_KEYS = {"bench", "domain", "problem", "planner", "mode", "solved", "status", "length", "valid"}
SUMMARY_KEYS = {
    "problems", "commonly_solved_vs_pyperplan", "time_ratio_vs_pyperplan", "search_time_ratio_vs_pyperplan",
    "total_cpu_s_ours", "total_cpu_s_pyperplan", "mean_length_ours", "mean_length_pyperplan",
    "mean_parallel_length_ours", "commonly_solved_cli_vs_pyperplan", "cli_time_ratio_vs_pyperplan",
    "cli_wall_ratio_vs_pyperplan", "commonly_solved_vs_fd", "time_ratio_vs_fd", "search_time_ratio_vs_fd",
    "cli_time_ratio_vs_fd", "cli_wall_ratio_vs_fd", "mean_length_ours_vs_fd", "mean_length_fd",
    "cli_over_in_process_ours", "ours_cli_same_plan", "coverage_ok", "time_ok", "length_ok",
    "coverage_ok_vs_fd", "time_ok_vs_fd", "length_ok_vs_fd", "max_rss_mb_ours_cli", "max_rss_mb_fd",
    *(f"coverage_{planner}" for planner in ALL_PLANNERS), *(f"unchecked_{planner}" for planner in ALL_PLANNERS),
}
# the figures that compare with a peer, null exactly when that peer did not run
PEER_FIGURES = {
    "pyperplan": ["time_ratio_vs_pyperplan", "search_time_ratio_vs_pyperplan", "cli_time_ratio_vs_pyperplan",
                  "cli_wall_ratio_vs_pyperplan", "mean_length_pyperplan"],
    "fd-lama-first": ["time_ratio_vs_fd", "search_time_ratio_vs_fd", "cli_time_ratio_vs_fd",
                      "cli_wall_ratio_vs_fd", "mean_length_fd"],
}


def load_bench(monkeypatch):
    """The benchmark script as a module (it puts the checkout on sys.path: undone after the test)."""
    monkeypatch.setattr(sys, "path", list(sys.path))
    spec = importlib.util.spec_from_file_location("bench_planner_under_test", BENCH)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


# -- the quick run ---------------------------------------------------------------


@pytest.fixture(scope="module")
def quick(tmp_path_factory) -> tuple[list[dict], str]:
    """The lines of ``bench_planner.py --quick``, plus a --data folder in the IPC layout (a domain file
    per problem, named as Fast Downward's driver looks for them), and its stderr."""
    if not SHARED_PDDL.is_dir():
        pytest.skip(f"{SHARED_PDDL} is absent: the public PDDL benchmarks are optional")
    ipc = tmp_path_factory.mktemp("data") / "gripper-ipc"
    ipc.mkdir()
    gripper = SHARED_PDDL / "gripper"
    shutil.copyfile(gripper / "prob01.pddl", ipc / "p01.pddl")
    shutil.copyfile(gripper / "domain.pddl", ipc / "p01-domain.pddl")
    shutil.copyfile(gripper / "prob02.pddl", ipc / "p02-gripper.pddl")
    shutil.copyfile(gripper / "domain.pddl", ipc / "domain_p02-gripper.pddl")
    done = subprocess.run([sys.executable, str(BENCH), "--quick", "--data", str(ipc)], cwd=REPO,
                          capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr[-4000:]
    assert "Traceback" not in done.stderr, done.stderr[-4000:]
    records = []
    for number, line in enumerate(done.stdout.splitlines(), 1):
        try:
            record = json.loads(line)
        except ValueError:
            pytest.fail(f"stdout line {number} is not JSON: {line[:300]!r}")
        assert isinstance(record, dict) and isinstance(record.get("bench"), str), line[:300]
        records.append(record)
    return records, done.stderr


def lines_of(records: list[dict], bench: str) -> list[dict]:
    return [record for record in records if record["bench"] == bench]


def test_quick_setup_says_what_ran_and_which_peers_are_missing(quick):
    records, _ = quick
    (setup,) = lines_of(records, "planner-setup")
    assert setup["quick"] is True and setup["problems"] == QUICK_PROBLEMS and setup["timeout_s"] <= 10
    assert setup["domains"] == [*CLASSICAL, "gripper-ipc"]
    assert setup["validator"], "plans must be validated"
    assert {"ours", "ours-cli"} <= set(setup["planners"])
    for peer, planners in PEERS.items():  # each peer runs, or one line says why not (and how to install it)
        missing = [r for r in records if r["bench"].endswith("-unavailable") and r.get("peer") == peer]
        if peer in setup["planners"]:
            assert not missing
        else:
            assert len(missing) == 1 and missing[0]["why"] and "bench" in missing[0]["install"]
            assert not set(planners) & set(setup["planners"])
    unknown = {r["bench"] for r in records} - {"planner-setup", "planner", "planner-domain", "planner-overall",
                                               "planner-tireworld", "planner-tireworld-summary",
                                               "planner-fond-blocksworld", "planner-fond-blocksworld-summary",
                                               "planner-pyperplan-unavailable", "planner-fd-unavailable"}
    assert not unknown


def test_quick_every_problem_line_has_its_keys_and_ours_solves_everything(quick):
    records, stderr = quick
    (setup,) = lines_of(records, "planner-setup")
    runs = lines_of(records, "planner")
    expected = {(domain, planner) for domain in setup["domains"] for planner in setup["planners"]}
    assert {(r["domain"], r["planner"]) for r in runs} == expected
    for record in runs:
        assert PLANNER_KEYS <= record.keys(), record
        assert record["status"] in STATUSES, record
        in_process = record["planner"] in ("ours", "pyperplan")
        assert record["mode"] == ("in-process" if in_process else "subprocess")
        times = ("cpu_s", "wall_s") if in_process else ("cli_cpu_s", "cli_wall_s")
        assert all(key in record for key in times), record
        if not in_process:  # a whole process's peak memory, its children included; None where it did not run
            assert "cli_max_rss_mb" in record, record
            if "skipped" not in record:
                assert record["cli_max_rss_mb"] > 10, record
        if record["planner"] in ("ours", "ours-cli"):
            assert record["solved"] is True and record["status"] == "solved", (record, stderr[-2000:])
            assert record["valid"] is True and record["length"] > 0
            assert all(isinstance(record[key], float) for key in times)
        elif record["status"] != "unchecked":  # a peer's plan: checked, and so solved exactly when valid
            assert record["solved"] == (record["valid"] is True), record
        if record["planner"] == "fd-lama-first" and record["solved"]:
            # its own translate + search CPU, the in-process comparison (in clock ticks: may read 0 here)
            assert record["solve_cpu_s"] >= 0
    for domain in setup["domains"]:  # our in-process run and our CLI found the same plans
        ours = {r["problem"]: r["plan_digest"] for r in runs if r["domain"] == domain and r["planner"] == "ours"}
        cli = {r["problem"]: r["plan_digest"] for r in runs if r["domain"] == domain and r["planner"] == "ours-cli"}
        assert ours == cli


def test_quick_peers_that_ran_solve_these_small_problems(quick):
    """A peer that is installed solves the quick problems of every domain it can read: an error here is
    the harness rotting (a peer's output or exit codes read wrong, or the validator turning down good
    plans). Pyperplan cannot read the action-cost domains nor mprime: those lines say 'unsupported'."""
    records, _ = quick
    (setup,) = lines_of(records, "planner-setup")
    for record in lines_of(records, "planner"):
        if record["planner"] in setup["planners"] and record["planner"] not in ("ours", "ours-cli"):
            if record["status"] == "unsupported":
                assert record["planner"].startswith("pyperplan"), record
                assert record["domain"] in ("elevators-sat08-strips", "mprime", "scanalyzer-08-strips",
                                            "transport-sat08-strips"), record
                continue
            assert record["solved"] is True and record["valid"] is True, record


def test_quick_summaries_cover_every_domain_with_the_expected_keys(quick):
    records, _ = quick
    (setup,) = lines_of(records, "planner-setup")
    domains = lines_of(records, "planner-domain")
    assert [d["domain"] for d in domains] == setup["domains"]
    (overall,) = lines_of(records, "planner-overall")
    for summary in [*domains, overall]:
        assert SUMMARY_KEYS <= summary.keys(), SUMMARY_KEYS - summary.keys()
        assert "skipped" not in summary
        problems = summary["problems"]
        assert summary["coverage_ours"] == problems and summary["coverage_ours-cli"] == problems
        assert summary["unchecked_ours"] == 0
        for planner in ALL_PLANNERS:
            assert (summary[f"coverage_{planner}"] is None) == (planner not in setup["planners"])
        domain = summary.get("domain")
        for peer, figures in PEER_FIGURES.items():
            # a peer that ran and could read the domain (any domain, overall) is compared with
            ran = any(r["planner"] == peer and r["status"] != "unsupported" and domain in (None, r["domain"])
                      for r in lines_of(records, "planner"))
            for key in figures:
                assert (summary[key] is not None) == ran, (domain or "", key)
    assert [d["problems"] for d in domains] == [QUICK_PROBLEMS] * len(CLASSICAL) + [2]
    assert overall["problems"] == QUICK_PROBLEMS * len(CLASSICAL) + 2
    assert "targets_met" in overall and isinstance(overall["targets_failed"], list)


def test_quick_counterplanning_on_the_tireworld(quick):
    records, _ = quick
    tires = lines_of(records, "planner-tireworld")
    assert [r["problem"] for r in tires] == [f"p{n}" for n in range(1, QUICK_TIREWORLD + 1)]
    assert all(r["passed"] and r["risk"] == 0 and r["valid"] is True for r in tires)
    (summary,) = lines_of(records, "planner-tireworld-summary")
    assert summary == {"bench": "planner-tireworld-summary", "problems": QUICK_TIREWORLD,
                       "passed": QUICK_TIREWORLD, "ok": True}


def test_quick_counterplanning_on_fond_blocksworld_names_what_may_defeat_each_plan(quick):
    records, _ = quick
    blocks = lines_of(records, "planner-fond-blocksworld")
    assert [r["problem"] for r in blocks] == [f"p{n}" for n in range(1, QUICK_TIREWORLD + 1)]
    # p1 needs no step; p2's pick-up may drop the block: its risk comes with the threat named
    assert blocks[0]["risk"] == 0 and blocks[1]["risk"] > 0 and blocks[1]["threats"] > 0
    assert all(r["passed"] and r["valid"] is True for r in blocks)
    (summary,) = lines_of(records, "planner-fond-blocksworld-summary")
    assert summary == {"bench": "planner-fond-blocksworld-summary", "problems": QUICK_TIREWORLD,
                       "passed": QUICK_TIREWORLD, "with_threats_named": 1, "ok": True}


# -- small pieces, no shared data needed -------------------------------------------

GRIPPER = """(define (domain g)
  (:requirements :strips)
  (:predicates (at ?b ?r) (robot ?r))
  (:action move :parameters (?b ?from ?to)
    :precondition (and (at ?b ?from) (robot ?from))
    :effect (and (at ?b ?to) (not (at ?b ?from)) (robot ?to) (not (robot ?from)))))
"""
PROBLEM = """; a comment that says (define (domain nothing))
(define (problem p) (:domain g) (:objects b r1 r2)
  (:init (at b r1) (robot r1)) (:goal (and (at b r2))))
"""


def test_problems_and_their_domain_files_in_both_layouts(tmp_path, monkeypatch):
    bench = load_bench(monkeypatch)
    shared = tmp_path / "shared"
    shared.mkdir()
    (shared / "domain.pddl").write_text(GRIPPER)
    for name in ("p10.pddl", "p2.pddl", "p1.pddl"):
        (shared / name).write_text(PROBLEM)
    assert [(p.name, d.name) for p, d in bench.list_problems(shared, 2)] == [("p1.pddl", "domain.pddl"),
                                                                             ("p2.pddl", "domain.pddl")]
    ipc = tmp_path / "ipc"
    ipc.mkdir()
    layout = {"p01.pddl": "p01-domain.pddl", "p02.pddl": "domain_p02.pddl", "p03.pddl": "domain-p03.pddl",
              "p04-airport1-p1.pddl": "p04-domain.pddl"}
    for problem, domain in layout.items():
        (ipc / problem).write_text(PROBLEM)
        (ipc / domain).write_text(GRIPPER)
    found = bench.list_problems(ipc, None)
    assert {p.name: d.name for p, d in found} == layout
    (ipc / "p05.pddl").write_text(PROBLEM)  # no domain file for it: reported, not guessed
    assert dict((p.name, d) for p, d in bench.list_problems(ipc, None))["p05.pddl"] is None


def test_a_plan_the_validator_cannot_read_the_task_of_is_unchecked_not_invalid(tmp_path, monkeypatch):
    bench = load_bench(monkeypatch)
    validator, why = bench.load_validator()
    assert validator is not None, why
    domain, problem, plan = tmp_path / "domain.pddl", tmp_path / "p.pddl", tmp_path / "p.plan"
    domain.write_text(GRIPPER)
    problem.write_text(PROBLEM)
    plan.write_text("(move b r1 r2)\n")
    assert bench.validate(validator, domain, problem, plan)[::2] == (True, 1.0)  # valid, and its cost
    plan.write_text("(move b r2 r1)\n")
    valid, message, cost = bench.validate(validator, domain, problem, plan)
    assert cost is None
    assert valid is False and message.startswith("step 1:") and "step 1: step 1" not in message
    plan.write_text("move (b r1 r2\n")
    assert bench.validate(validator, domain, problem, plan)[0] is False

    def cannot(*args):
        raise ValueError("a PDDL feature it lacks")

    # a domain the validator cannot read (what it lacks changes as the planner grows: stand-ins here)
    plan.write_text("(move b r1 r2)\n")
    unreadable = SimpleNamespace(read_task=cannot, read_plan=validator.read_plan, check=validator.check)
    valid, message, _ = bench.validate(unreadable, domain, problem, plan)
    assert valid is None and "cannot read the domain or problem" in message
    crashing = SimpleNamespace(read_task=validator.read_task, read_plan=validator.read_plan, check=cannot)
    assert bench.validate(crashing, domain, problem, plan) == (None, "the validator raised ValueError: "
                                                                     "a PDDL feature it lacks", None)
    assert bench.validate(None, domain, problem, plan)[0] is None


def test_unchecked_plans_are_counted_apart_from_coverage(tmp_path, monkeypatch):
    bench = load_bench(monkeypatch)

    def run(problem, planner, status, cpu):
        solved = status == "solved"
        key = "cpu_s" if planner in ("ours", "pyperplan") else "cli_cpu_s"
        return {"bench": "planner", "domain": "d", "problem": problem, "planner": planner, "solved": solved,
                "status": status, key: cpu, "length": 5 if status in ("solved", "unchecked") else None}

    planners = ["ours", "pyperplan", "fd-lama-first"]
    records = [run("p1", "ours", "solved", 0.04), run("p1", "pyperplan", "solved", 0.2),
               run("p1", "fd-lama-first", "unchecked", 0.3),
               run("p2", "ours", "solved", 0.1), run("p2", "pyperplan", "timeout", 1.0),
               run("p2", "fd-lama-first", "solved", 0.3)]
    summary = bench.domain_summary("d", tmp_path, records, planners, 2)
    assert (summary["coverage_ours"], summary["coverage_pyperplan"], summary["coverage_fd-lama-first"]) == (2, 1, 1)
    assert summary["unchecked_fd-lama-first"] == 1 and summary["unchecked_ours"] == 0
    assert summary["coverage_ours-cli"] is None and summary["unchecked_pyperplan-cli"] is None
    assert summary["time_ratio_vs_pyperplan"] == 0.2 and summary["commonly_solved_vs_fd"] == 1
    assert summary["coverage_ok"] is True and summary["time_ok"] is True and summary["length_ok"] is True
    # against FD: more solved, as long on the one solved by both; no CLI ran, so no whole-process verdict
    assert summary["coverage_ok_vs_fd"] is True and summary["length_ok_vs_fd"] is True
    assert summary["time_ok_vs_fd"] is None


def test_whole_process_cpu_against_fd_is_held_to_2x_per_domain_and_1_5x_overall(tmp_path, monkeypatch):
    bench = load_bench(monkeypatch)

    def run(domain, planner, cpu):
        key = "cpu_s" if planner == "ours" else "cli_cpu_s"
        return {"bench": "planner", "domain": domain, "problem": "p1", "planner": planner, "solved": True,
                "status": "solved", key: cpu, "length": 5}

    planners = ["ours", "ours-cli", "fd-lama-first"]
    records = [run(domain, planner, cpu) for domain in ("a", "b")
               for planner, cpu in (("ours", 1.0), ("ours-cli", 1.8), ("fd-lama-first", 1.0))]
    summaries = [bench.domain_summary(domain, tmp_path, [r for r in records if r["domain"] == domain], planners, 1)
                 for domain in ("a", "b")]
    assert all(s["cli_time_ratio_vs_fd"] == 1.8 and s["time_ok_vs_fd"] is True for s in summaries)
    overall = bench.overall_summary(records, summaries, planners)
    assert overall["time_ok_vs_fd"] is False and overall["targets_failed"] == ["overall:time_ok_vs_fd"]
    assert overall["coverage_ok_vs_fd"] is True and overall["length_ok_vs_fd"] is True
    assert overall["time_ok"] is None and overall["targets_met"] is False
