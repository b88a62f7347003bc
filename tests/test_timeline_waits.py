"""Waiting on the timeline of a run with no world (views.timeline): the spans a task, or a task
below it, waited for a skill another task held or before retrying, and the skills taken from it,
read from the trace records of real runs and drawn on its bar."""

from __future__ import annotations

import numpy as np
from matplotlib.image import imread

from atlas_rap.views.timeline import (OUTCOME_COLOURS, Preemption, WaitSpan, _tint, legend_labels, plan_lines,
                                       preemptions, render_timeline, step_bars, task_bars, wait_spans)
from cli_process import REPO, assert_no_traceback, atlas
from scenario import Scenario, run
from test_skills_as_resources import CAMERA, POLISHING

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
WAIT_WORDS = {"waits for a skill", "waits before retrying", "skill taken by a task of higher priority"}
EXAMPLE = "examples/shared-camera.rap"
EXAMPLE_PNG = REPO / "docs" / "tasks-share-the-robot.png"

TAKEN_AT_3 = CAMERA + "(post (look-at pump))\n(at-time 3 (assert (go)))\n(post (watch pump) :priority 5)\n"
"""(look-at pump) holds (camera pump) from t=0; (watch pump), of priority 5, takes it at t=3."""

BACK_OFF = """
(define-virtual-skill (grab ?x) (after 0.5 (finish :fail)))
(define-rap (pick ?x) (succeed (held ?x)) (retries 3) (method (task-net (t1 (grab ?x)))))
(post (pick cup))
"""


def _bars(records):
    steps = step_bars(records)
    return steps, task_bars(records, skip={b.task for b in steps if b.task is not None})


def _pixels(png, colour: str) -> int:
    img = imread(png)[..., :3]
    rgb = np.array([int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    return int((np.abs(img - rgb).max(axis=2) < 0.02).sum())


def test_the_holder_waits_from_the_preemption_until_the_skill_is_let_go(tmp_path) -> None:
    with run(tmp_path, TAKEN_AT_3) as s:
        look, watch = task_bars(s.records)
        assert (look.text, look.start, look.end, look.outcome) == ("(look-at pump)", 0.0, 23.0, "done")
        assert look.waits == (WaitSpan(3.0, 13.0, "skill", 1, "(camera pump)"),)
        assert look.preempted == (Preemption(3.0, 1, "(camera pump)", "(watch pump)", ":halted"),)
        assert (watch.text, watch.waits, watch.preempted) == ("(watch pump)", (), ())
        assert wait_spans(s.records) == {1: [WaitSpan(3.0, 13.0, "skill", 1, "(camera pump)")]}
        assert list(preemptions(s.records)) == [1]
        assert legend_labels([], [look, watch], []) == ["done / succeeded", "waits for a skill",
                                                        "skill taken by a task of higher priority"]


def test_a_wait_still_open_where_the_records_end_runs_to_the_end_of_the_bar(tmp_path) -> None:
    with run(tmp_path, TAKEN_AT_3) as s:
        so_far = [r for r in s.records if r["t"] < 8.0]  # a picture taken at t=8, as the REPL draws one
        look = task_bars(so_far)[0]
        assert look.end is None and look.waits == (WaitSpan(3.0, None, "skill", 1, "(camera pump)"),)
        png = render_timeline(so_far, tmp_path / "at-8.png", "m.rap, seed 0", end=8.0)
        assert _pixels(png, _tint(OUTCOME_COLOURS["running"])) > 50  # the waiting part, lighter


def test_a_posted_task_shows_the_waits_of_its_subtask_and_a_plain_wait_has_no_mark() -> None:
    s = Scenario(REPO / EXAMPLE, 600.0)
    inspect, look, check, photo = task_bars(s.records)
    assert [b.text for b in (inspect, look, check, photo)] == [
        "(inspect pump)", "(look-at pump)", "(check-alarm pump)", "(photograph pump)"]
    assert inspect.waits == look.waits == (WaitSpan(3.0, 13.0, "skill", look.task, "(camera pump)"),)
    assert inspect.preempted == look.preempted == (
        Preemption(3.0, look.task, "(camera pump)", "(check-alarm pump)", ":halted"),)
    assert (check.waits, check.preempted) == ((), ())
    assert photo.waits == (WaitSpan(5.0, 23.0, "skill", photo.task, "(camera pump)"),) and photo.preempted == ()


def test_a_retrys_back_off_is_a_wait_of_its_own_kind(tmp_path) -> None:
    with run(tmp_path, BACK_OFF) as s:
        (pick,) = task_bars(s.records)
        assert pick.waits == (WaitSpan(0.5, 1.5, "retry", 1), WaitSpan(2.0, 3.0, "retry", 1))
        labels = legend_labels([], [pick], [])
        assert "waits before retrying" in labels and "waits for a skill" not in labels
        png = render_timeline(s.records, tmp_path / "b.png", "m.rap, seed 0")
        assert _pixels(png, _tint(OUTCOME_COLOURS["failed"])) > 20


def test_a_plan_step_that_waits_shows_it_on_its_bar_and_on_the_posted_task(tmp_path) -> None:
    with run(tmp_path, POLISHING + "(plan (polished vase) :deadline 12)\n") as s:
        (step,), tasks = _bars(s.records)
        assert step.waits == (WaitSpan(0.201, 5.0, "skill", step.task, "(buff arm-1)"),)
        assert [(t.text, t.waits) for t in tasks] == [("(hog)", ()), ("(carry-out-plan-1)", step.waits)]


def test_a_run_without_waits_has_none_on_its_bars_and_none_in_the_legend(tmp_path) -> None:
    plans = Scenario(REPO / "rap_library" / "missions" / "evahr.rap", 600.0)  # plan steps, re-plans, no waits
    apart = run(tmp_path, CAMERA + "(post (look-at pump))\n(post (look-at valve))\n")  # two cameras: no contest
    for s in (plans, apart):
        assert s.result.ok
        steps, tasks = _bars(s.records)
        assert tasks and all(b.waits == () and b.preempted == () for b in [*steps, *tasks])
        assert not WAIT_WORDS & set(legend_labels(steps, tasks, plan_lines(s.records)))


def test_a_timeline_with_waits_is_a_png_and_the_same_bytes_twice(tmp_path) -> None:
    with run(tmp_path, TAKEN_AT_3) as s:
        first = render_timeline(s.records, tmp_path / "one.png", "m.rap, seed 0")
        again = render_timeline(s.records, tmp_path / "two.png", "m.rap, seed 0")
        assert first.read_bytes()[:8] == PNG_MAGIC
        assert first.read_bytes() == again.read_bytes()
        assert _pixels(first, _tint(OUTCOME_COLOURS["done"])) > 50  # the wait, lighter than the bar
        assert _pixels(first, "#e8590c") > 5  # where the skill was taken


def test_the_example_runs_and_draws_the_picture_in_docs(tmp_path) -> None:
    done = atlas("run", EXAMPLE, "-q", "--render", str(tmp_path / "shared.png"), cwd=REPO)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "shared.png").read_bytes() == EXAMPLE_PNG.read_bytes(), (
        f"{EXAMPLE_PNG.relative_to(REPO)} is not what the example draws now: "
        f"atlas run {EXAMPLE} --render {EXAMPLE_PNG.relative_to(REPO)}")
