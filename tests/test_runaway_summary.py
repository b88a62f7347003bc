"""A runaway recursion is summed up in a few lines, its cause first and its repeats folded.

The language reference promises it (docs/language/rap.md, How a task runs): "The summary puts the cause of
such a runaway first and folds the repeated chain (`… 61 more levels of
(loop) …`)". These tests run the missions a user would write (a RAP that
posts itself, with the same arguments or new ones, two RAPs that call each
other, a huge `retries`) and read what `atlas run` prints.
"""

from __future__ import annotations

import re

import pytest
from cli_process import REPO, assert_no_traceback, atlas

RUNAWAYS = {
    "itself": "(define-rap (loop) (method (task-net (t1 (loop)))))\n(post (loop))\n",
    "itself with new arguments": "(define-rap (count ?n) (method (context (= ?m (+ ?n 1))) (task-net (count ?m))))\n"
                                 "(post (count 0))\n",
    "each other": "(define-rap (ping ?n) (method (task-net (pong ?n))))\n"
                  "(define-rap (pong ?n) (method (task-net (sequence (assert (seen ?n)) (ping ?n)))))\n"
                  "(post (ping 1))\n",
}


def summary(tmp_path, mission: str, *options: str):
    (tmp_path / "runaway.rap").write_text("(world none)\n" + mission, encoding="utf-8")
    done = atlas("run", "runaway.rap", *options, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    return done


def test_the_language_reference_shows_what_the_summary_of_a_rap_that_posts_itself_says(tmp_path):
    page = (REPO / "docs" / "language" / "rap.md").read_text(encoding="utf-8")
    promise = re.search(r"The summary puts the\s+cause of such a runaway first\s+and folds the repeated chain\s+"
                        r"\(`(… \d+ more levels of \(loop\) …)`\)", page)
    assert promise, "the language reference's promise about the runaway summary moved or changed"
    lines = summary(tmp_path, RUNAWAYS["itself"], "--quiet").stdout.splitlines()
    assert len(lines) < 25, "\n".join(lines)
    assert lines[1].strip() == "✗ (loop) failed at 0 s"
    assert lines[2].strip().startswith("cause: (loop): tasks nested deeper than 64")
    assert promise.group(1) in [line.strip() for line in lines]


@pytest.mark.parametrize("kind", list(RUNAWAYS))
def test_every_runaway_is_told_in_under_25_lines_with_its_cause_first(tmp_path, kind):
    lines = summary(tmp_path, RUNAWAYS[kind], "--quiet").stdout.splitlines()
    assert len(lines) < 25, "\n".join(lines)
    assert lines[2].strip().startswith("cause: (")
    assert "tasks nested deeper than 64" in lines[2] and "call itself without end?" in lines[2]
    assert sum("more level" in line or "more time" in line for line in lines) == 1  # the repeats, folded once
    assert max(len(line) for line in lines) < 200


def test_new_arguments_at_each_level_still_fold_and_say_which(tmp_path):
    lines = summary(tmp_path, RUNAWAYS["itself with new arguments"], "--quiet").stdout.splitlines()
    fold = next(line.strip() for line in lines if "more level" in line)
    assert re.fullmatch(r"… \d+ more levels of \(count …\), \(count \d+\) to \(count \d+\) …", fold), fold


def test_rap_that_call_each_other_fold_as_rounds_of_the_cycle(tmp_path):
    lines = summary(tmp_path, RUNAWAYS["each other"], "--quiet").stdout.splitlines()
    fold = next(line.strip() for line in lines if "more time" in line)
    assert re.fullmatch(r"… \d+ more times round \(pong 1\) > \(ping 1\) …", fold), fold


def test_the_live_trace_of_a_runaway_stops_indenting_and_does_not_repeat_the_cause(tmp_path):
    out = summary(tmp_path, RUNAWAYS["itself with new arguments"]).stdout
    lines = out.splitlines()
    assert any("[depth 40]" in line for line in lines)
    assert max(len(line) - len(line.lstrip()) for line in lines) < 60  # 16 levels of indentation at most
    assert out.count("does count call itself without end?") <= 5  # where it happens, then "the same cause"
    assert len(out) < 40_000  # 88 kB before


def test_a_huge_retries_of_a_method_that_fails_at_once_ends_as_a_runaway_not_a_hang(tmp_path):
    mission = ("(define-rap (go) (retries 1000000000) (retry-backoff 0) (method (task-net (wait-for (x) :fail))))\n"
               "(initial-memory (x))\n(post (go))\n")
    lines = summary(tmp_path, mission, "--quiet").stdout.splitlines()
    assert lines[2].strip() == "tried 1000 methods without simulated time passing"
    assert len(lines) < 25
