"""`atlas repl` driven as a user drives it: through a pipe (`atlas repl < session.txt`),
and through prompt_toolkit's pipe input into the same session engine."""

from __future__ import annotations

import io
import subprocess
from pathlib import Path

from cli_process import ENV, REPO, assert_no_traceback, atlas_command
from rich.console import Console

from atlas_rap.cli.repl_session import Session

GREETER = """\
(define-virtual-skill (wave ?who) (after 2 (assert (greeted ?who)) (finish :succeed)))
(define-rap (greet ?who)
  (succeed (greeted ?who))
  (method wave
    (task-net
      (t1 (wave ?who)))))
"""


def repl(script: str, *files: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(atlas_command("repl", *files), input=script, cwd=cwd, capture_output=True, text=True,
                          env=ENV, timeout=60)


def test_a_piped_session_defines_a_multiline_rap_runs_a_task_and_answers_a_query(tmp_path: Path) -> None:
    done = repl(GREETER + "(post (greet alice))\n:run\n(? (greeted ?who))\n(? (greeted bob))\n", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert "defined RAP (greet ?who)" in out
    assert "✓ [1] (greet alice) succeeded" in out
    assert "?who = alice" in out
    assert out.rstrip().endswith("no")  # nobody greeted bob


def test_an_error_mid_session_is_reported_and_the_next_form_still_runs(tmp_path: Path) -> None:
    script = GREETER + "(post (greet\n:run 1\n(post (frobnicate))\n(post (greet carol))\n:run\n(? (greeted carol))\n"
    done = repl(script, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1  # some submissions failed
    assert "error: unbalanced '(': this list is never closed" in done.stderr  # errors go to stderr
    assert "'frobnicate' is neither a RAP nor a skill" in done.stderr
    assert "error" not in done.stdout
    assert "✓ [1] (greet carol) succeeded" in done.stdout
    assert done.stdout.rstrip().endswith("yes")


def test_reload_changes_the_method_a_later_task_uses(tmp_path: Path) -> None:
    (tmp_path / "greeter.rap").write_text(GREETER, encoding="utf-8")
    louder = GREETER.replace("(method wave", "(method shout").replace("(t1 (wave ?who))",
                                                                    "(assert (shouted-at ?who)) (t1 (wave ?who))")
    script = ("(post (greet ann))\n:run\n"
              ":reload new-greeter.rap\n(post (greet bea))\n:run\n(? (shouted-at ?who))\n")
    (tmp_path / "new-greeter.rap").write_text(louder, encoding="utf-8")
    done = repl(script, "greeter.rap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout
    assert "reloaded new-greeter.rap: greet" in done.stdout
    assert "(greet ann) method wave" in done.stdout and "(greet bea) method shout" in done.stdout
    assert "?who = bea" in done.stdout and "?who = ann" not in done.stdout


def test_save_writes_memory_that_loads_back_the_same(tmp_path: Path) -> None:
    first = repl(GREETER + "(assert (at robot lab))\n(assert (battery robot 0.5))\n(post (greet dan))\n:run\n"
                 ":save saved.rap\n:memory\n", cwd=tmp_path)
    assert first.returncode == 0, first.stdout
    second = repl(":memory\n(post (greet eve))\n:run\n", "saved.rap", cwd=tmp_path)
    assert_no_traceback(second)
    assert second.returncode == 0, second.stdout

    def table(text: str) -> list[str]:
        return sorted(line for line in text.splitlines() if line.startswith("│ ("))

    facts_before = [row.split("│")[1].strip() for row in table(first.stdout)]
    facts_after = [row.split("│")[1].strip() for row in table(second.stdout)][:len(facts_before)]
    assert sorted(facts_before) == sorted(facts_after)
    assert "(battery robot 0.5)" in facts_after
    assert "✓ [1] (greet eve) succeeded" in second.stdout  # the saved RAPs and skills came back too


def test_a_session_through_prompt_toolkit_pipe_input(tmp_path: Path) -> None:
    """The interactive reader (multi-line, submits when the parentheses balance)
    feeding the session, as a terminal would."""
    from prompt_toolkit.input import create_pipe_input
    from prompt_toolkit.output import DummyOutput

    from atlas_rap.cli.repl_input import make_prompt_session

    buffer = io.StringIO()
    session = Session(out=Console(file=buffer, width=200, no_color=True, highlight=False, soft_wrap=True))
    typed = GREETER.replace("\n", "\r") + "(post (greet fay))\r:run\r(? (greeted ?who))\r"
    with create_pipe_input() as pipe:
        pipe.send_text(typed)
        prompt = make_prompt_session(input=pipe, output=DummyOutput(), history_file=tmp_path / "history")
        submitted = []
        while True:
            try:
                text = prompt.prompt()
            except EOFError:
                break
            submitted.append(text)
            session.submit(text)
            if text.startswith("(?"):
                break
    assert submitted[1].startswith("(define-rap (greet ?who)") and submitted[1].count("\n") == 4
    assert session.failures == 0
    assert "?who = fay" in buffer.getvalue()
    assert "(post (greet fay))" in (tmp_path / "history").read_text(encoding="utf-8")


PACKING = """\
(operator fetch :purpose (have ?x) :agent ?arm :preconditions ((on-shelf ?x)) :constraints ((arm ?arm))
  :plot (take ?arm ?x) :effects ((have ?x) (not (on-shelf ?x))))
(agents (controlled arm-1))
(define-virtual-skill (take-skill ?arm ?x) (after 2 (assert (have ?x)) (finish :succeed)))
(define-rap (take ?arm ?x) (succeed (have ?x))
  (method (primitive (enable (take-skill ?arm ?x)) (wait-for (have ?x) :succeed) (disable :above))))
(assert (arm arm-1))
(assert (on-shelf cup))
"""


def test_plan_shows_a_plan_from_memory_and_a_plan_form_carries_it_out(tmp_path: Path) -> None:
    done = repl(PACKING + ":plan (have cup)\n(plan (have cup))\n:run\n(? (have cup))\n", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout
    assert done.stdout.count("solved: 1 steps") == 1  # shown by :plan
    assert "◆ plan 1 ready" in done.stdout and "s1 (take arm-1 cup) [arm-1]" in done.stdout  # planned by (plan ...)
    assert "✓ [1] (carry-out-plan-" in done.stdout
    assert done.stdout.rstrip().endswith("yes")


def test_in_a_world_a_posted_task_drives_the_robot_and_the_map_is_drawn(tmp_path: Path) -> None:
    script = "(? (place ?p))\n(post (go-to office))\n:run\n(? (at robot ?where))\n:skills\n:map route.png\n"
    done = repl(script, str(REPO / "rap_library/navigation.rap"), "--world", "lab-corridor-office", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "?p = office" in done.stdout  # the prior map is in memory
    assert "✓ [1] (go-to office) succeeded" in done.stdout
    assert "?where = office" in done.stdout
    assert "navigate-to (1 args)" in done.stdout
    assert (tmp_path / "route.png").stat().st_size > 10_000
