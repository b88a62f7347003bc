"""One mission engine for `atlas run` and `atlas repl`: the REPL loads what `atlas run` loads,
a program is loaded in one pass, the world comes from the first file, and every skill a task
enabled is disabled again before the trace ends, whatever the outcome."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.sequencer import Trace

MISSIONS = sorted((REPO / "rap_library" / "missions").glob("*.rap"))


def repl(script: str, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(atlas_command("repl", *args), input=script, cwd=cwd, capture_output=True, text=True,
                          env=ENV, timeout=120)


def ends(trace_file: Path) -> list[tuple[str, str, float]]:
    """How each posted task ended, in order: (task, event, time)."""
    records = [json.loads(line) for line in trace_file.read_text(encoding="utf-8").splitlines()]
    roots = {r["id"] for r in records if r["event"] == "task-posted" and "parent" not in r}
    return [(r["task"], r["event"], r["t"]) for r in records
            if r["event"] in ("task-succeeded", "task-failed", "task-halted") and r["id"] in roots]


@pytest.mark.parametrize("mission", MISSIONS, ids=lambda path: path.name)
def test_every_shipped_mission_loads_in_the_repl_and_runs_to_the_same_end_as_atlas_run(mission, tmp_path):
    ran = atlas("run", str(mission), "--quiet", "--trace", "run.jsonl", cwd=tmp_path)
    assert_no_traceback(ran)
    session = repl(":run\n", str(mission), "--trace", "repl.jsonl", cwd=tmp_path)
    assert_no_traceback(session)
    assert session.returncode == 0, session.stderr
    expected = ends(tmp_path / "run.jsonl")
    assert expected and ends(tmp_path / "repl.jsonl") == expected
    assert ran.returncode == (0 if all(event == "task-succeeded" for _, event, _ in expected) else 1)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("mission", MISSIONS, ids=lambda path: path.name)
def test_every_skill_a_task_enabled_is_disabled_before_the_trace_ends(mission, seed):
    engine = MissionEngine(RunOptions(seed=seed), trace=Trace(keep=True))
    engine.load_file(mission, require_post=True)
    engine.run_mission(900)
    records = engine.trace.records
    enabled = [i for i, r in enumerate(records) if r["event"] == "skill-enabled"]
    assert enabled, "the mission enables no skill"
    for i in enabled:
        on = records[i]
        assert any(r["event"] == "skill-disabled" and r["skill"] == on["skill"] and r["id"] == on["id"]
                   for r in records[i + 1:]), f"{on['skill']} enabled by [{on['id']}] at {on['t']} is never disabled"


def test_a_submission_is_loaded_in_one_pass_so_a_rap_may_use_a_skill_defined_below_it(tmp_path):
    """A submission is what is typed before Enter (in a script: the forms of one line, or of
    lines that continue an open form); like a file, it may name what it defines further on."""
    script = ("(define-rap (greet) (succeed (greeted)) (method (task-net (t1 (wave))))) "
              "(define-virtual-skill (wave) (after 1 (assert (greeted)) (finish :succeed)))\n"
              "(post (greet))\n:run\n(? (greeted))\n")
    done = repl(script, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "✓ [1] (greet) succeeded" in done.stdout and done.stdout.rstrip().endswith("yes")


def test_the_repl_takes_the_world_of_the_file_it_is_given(tmp_path):
    done = repl("(? (place ?p))\n:map m.png\n", str(REPO / "rap_library" / "missions" / "deliver.rap"), cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "?p = office" in done.stdout and "?p = storeroom" in done.stdout
    assert (tmp_path / "m.png").stat().st_size > 0


def test_the_repl_given_the_world_the_file_names_runs_it(tmp_path):
    deliver = str(REPO / "rap_library" / "missions" / "deliver.rap")
    done = repl(":run\n", "--world", "lab-corridor-office", deliver, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "✓ [1] (deliver mail office lab) succeeded" in done.stdout


def test_a_file_that_names_another_world_than_the_running_one_is_a_located_error(tmp_path):
    other = REPO / "rap_library" / "missions" / "door-closed.rap"
    done = repl(f'(include "{other}")\n(? (place ?p))\n', str(REPO / "rap_library" / "missions" / "deliver.rap"),
                cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "door-closed.rap:8:1: error: this session runs in lab-corridor-office; this file names the world " \
           "'lab-corridor-office-door-closed'" in done.stderr
    assert "hint: start a session in that world (atlas repl --world lab-corridor-office-door-closed)" in done.stderr
    assert "?p = office" in done.stdout  # the session goes on


def test_a_world_that_does_not_exist_is_an_error_at_the_world_form(tmp_path):
    (tmp_path / "m.rap").write_text("(define-rap (x) (method (task-net (wait-for (t)))))\n"
                                    "(world nowhere)\n(post (x))\n", encoding="utf-8")
    done = atlas("run", "m.rap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "m.rap:2:1: error: no shipped world named 'nowhere'" in done.stderr
    assert "    (world nowhere)\n    ^" in done.stderr
    assert "shipped worlds: " in done.stderr and " lab-corridor-office," in done.stderr


def test_a_relation_typed_at_the_repl_is_used_by_queries(tmp_path):
    done = repl("(define-relation (heavy ?x) (size ?x 40))\n(assert (size box 40))\n(? (heavy ?what))\n",
                cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "?what = box" in done.stdout


def test_ending_the_repl_with_live_tasks_halts_them_before_the_trace_is_written(tmp_path):
    script = ("(define-virtual-skill (hum) (after 100 (finish :succeed)))\n"
              "(define-rap (concert) (method (task-net (t1 (hum)))))\n(post (concert))\n:run 5\n")
    done = repl(script, "--trace", "t.jsonl", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    records = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text(encoding="utf-8").splitlines()]
    events = [(r["event"], r.get("skill") or r.get("task")) for r in records[-2:]]
    assert events == [("skill-disabled", "(hum)"), ("task-halted", "(concert)")]
    assert records[-1]["reason"] == "the session ended" and records[-1]["t"] == 5.0
