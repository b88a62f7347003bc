"""`atlas check` as a user runs it: real processes, real files, exit codes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from cli_process import REPO, assert_no_traceback, atlas

from atlas_rap.lang import parse_text


def test_the_files_that_ship_are_clean():
    shipped = sorted(str(p.relative_to(REPO)) for folder in ("rap_library", "operators")
                     for p in (REPO / folder).rglob("*") if p.suffix in (".rap", ".ap"))
    assert len(shipped) >= 4
    done = atlas("check", *shipped, cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("ok: ") == len(shipped)


def test_the_two_robot_examples_check_clean_for_two_robots_on_the_bus():
    examples = sorted(str(p.relative_to(REPO)) for p in (REPO / "examples").glob("*.rap"))
    assert len(examples) >= 2
    done = atlas("check", *examples, "--robot", "alice", "--robot", "bob", cwd=REPO)
    assert done.returncode == 0, done.stderr
    alone = atlas("check", "examples/two-robots.rap", cwd=REPO)  # one robot: its skills take no name
    assert alone.returncode == 1 and "navigate-to takes 1 argument, not 2" in alone.stderr


def test_shipped_files_are_found_from_any_directory(tmp_path):
    done = atlas("check", "rap_library/missions/site-visit.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "7 RAPs" in done.stdout


def test_a_file_with_problems_prints_each_with_a_caret_and_exits_1(tmp_path):
    (tmp_path / "bad.rap").write_text(
        "(define-rap (go ?x)\n  (sucede (at ?x))\n  (method (context (ready))))\n", encoding="utf-8")
    done = atlas("check", "bad.rap", cwd=tmp_path)
    assert done.returncode == 1
    assert_no_traceback(done)
    lines = done.stderr.splitlines()
    assert lines[0] == "bad.rap:2:4: error: unknown clause 'sucede'"
    assert lines[1:4] == ["      (sucede (at ?x))", "       ^", "  hint: did you mean 'succeed'?"]
    assert "bad.rap:3:3: error: method has no body" in lines
    assert lines[-1] == "bad.rap: 2 problems"


def test_clean_and_bad_files_together_exit_1_and_report_both(tmp_path):
    (tmp_path / "good.ap").write_text("(operator go :purpose (at robot ?place) :effects ((at robot ?place)))\n"
                                      "(goals (at robot office))\n", encoding="utf-8")
    (tmp_path / "bad.ap").write_text("(goals (at robot office)\n", encoding="utf-8")
    done = atlas("check", "good.ap", "bad.ap", cwd=tmp_path)
    assert done.returncode == 1
    assert "ok: good.ap: 1 goals, 1 operator" in done.stdout
    assert "bad.ap:1:1: error: unbalanced '(': this list is never closed" in done.stderr


@pytest.mark.parametrize("content, message", [
    (b"", "file is empty"),
    (b"(post (go \"caf\xe9\"))", "file is not UTF-8 text"),
    (b"(post (go \"open))", "unterminated string"),
    (b"(post (go)))", "unbalanced ')'"),
])
def test_bad_input_gets_a_message_and_exit_1_never_a_traceback(tmp_path, content, message):
    (tmp_path / "m.rap").write_bytes(content)
    done = atlas("check", "m.rap", cwd=tmp_path)
    assert done.returncode == 1
    assert_no_traceback(done)
    assert message in done.stderr


def test_a_missing_file_is_a_clear_error(tmp_path):
    done = atlas("check", "nowhere.rap", cwd=tmp_path)
    assert done.returncode == 1
    assert "nowhere.rap:1:1: error: no such file" in done.stderr


def test_no_arguments_is_a_usage_error_with_exit_2(tmp_path):
    done = atlas("check", cwd=tmp_path)
    assert done.returncode == 2
    assert "Missing argument" in done.stderr


def test_tree_prints_the_ast_with_positions(tmp_path):
    (tmp_path / "t.rap").write_text("(define-rap (go ?x)\n  (succeed (at robot ?x))\n"
                                    "  (method (primitive (enable (move-to ?x)))))\n"
                                    "(define-virtual-skill (move-to ?x) (after 1 (finish :succeed)))\n",
                                    encoding="utf-8")
    done = atlas("check", "--tree", "t.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "RapDef 1:1" in done.stdout
    assert "succeed: (at robot ?x)" in done.stdout
    assert "Enable 3:22" in done.stdout


def test_format_prints_source_that_checks_clean(tmp_path):
    (tmp_path / "t.rap").write_text("(DEFINE-RAP (Go ?X) (method (primitive (enable (Move-To ?x)))))"
                                    "(Define-Virtual-Skill (Move-To ?X) (After 1 (Finish :Succeed)))",
                                    encoding="utf-8")
    done = atlas("check", "--format", "t.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    formatted = done.stdout.split(";; t.rap\n", 1)[1]
    assert formatted.strip() == ("(define-rap (go ?x) (method (primitive (enable (move-to ?x)))))\n\n"
                                 "(define-virtual-skill (move-to ?x) (after 1 (finish :succeed)))")
    (tmp_path / "again.rap").write_text(formatted, encoding="utf-8")
    assert atlas("check", "again.rap", cwd=tmp_path).returncode == 0


def test_check_does_not_import_the_heavy_libraries():
    code = ("import sys; from atlas_rap.cli.main import main\n"
            "try:\n    main(['check', 'rap_library/space-station.rap'])\n"
            "except SystemExit:\n    pass\n"
            "print(sorted(m for m in ('scipy', 'skimage', 'pymunk', 'numpy', 'rich') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                          env={"PYTHONPATH": str(REPO)})
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stderr


def test_tree_prints_every_shipped_file_with_operators_and_effects():
    done = atlas("check", "--tree", "operators/space-station-goals.ap", "rap_library/missions/site-visit.rap",
                 cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert "Effect 13:13" in done.stdout
    assert "positive: nil" in done.stdout  # the astronaut's (not (pointed-at ...))
    assert "VirtualSkillDef" in done.stdout and "MemoryRuleDef" in done.stdout


def test_a_memory_rule_cycle_is_a_warning_that_does_not_fail_the_check(tmp_path):
    (tmp_path / "cyc.rap").write_text(
        "; rules only: a library of memory rules\n"
        "(define-memory-rule up (on (ping ?n)) (assert (pong ?n)))\n"
        "(define-memory-rule down (on (pong ?n)) (assert (ping (+ ?n 1))))\n", encoding="utf-8")
    done = atlas("check", "cyc.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_no_traceback(done)
    lines = done.stderr.splitlines()
    assert lines[0] == ("cyc.rap:2:1: warning: memory rules can trigger each other in a cycle: "
                        "up (cyc.rap:2:1) -> down (cyc.rap:3:1) -> up")
    assert lines[1:3] == ["    (define-memory-rule up (on (ping ?n)) (assert (pong ?n)))", "    ^"]
    assert lines[3].startswith("  hint: a rule in this cycle needs a (when ...) that stops it")
    assert "ok: cyc.rap: 2 memory rules" in done.stdout


def test_initial_memory_arithmetic_without_a_value_fails_the_check_with_a_caret(tmp_path):
    (tmp_path / "m.rap").write_text("(initial-memory (level (+ 1 2))\n  (level (/ 1 0)))\n", encoding="utf-8")
    done = atlas("check", "m.rap", cwd=tmp_path)
    assert done.returncode == 1
    assert_no_traceback(done)
    lines = done.stderr.splitlines()
    assert lines[0] == ("m.rap:2:3: error: cannot evaluate the arithmetic in the fact (level (/ 1 0)): "
                        "division by zero in (/ 1 0)")
    assert lines[1:3] == ["      (level (/ 1 0)))", "      ^"]
    assert lines[-1] == "m.rap: 1 problem"


def test_format_writes_only_the_program_to_stdout_so_a_redirect_gives_a_file_that_reads_the_same(tmp_path):
    (tmp_path / "missions").mkdir()
    for name in ("missions/deliver.rap", "navigation.rap"):  # a mission with an include, a world, a post ...
        (tmp_path / name).write_text((REPO / "rap_library" / name).read_text(encoding="utf-8"), encoding="utf-8")
    done = atlas("check", "--format", "missions/deliver.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "ok:" not in done.stdout
    assert done.stderr.startswith("ok: missions/deliver.rap")  # the status goes with the problems
    (tmp_path / "missions" / "formatted.rap").write_text(done.stdout, encoding="utf-8")  # as `> formatted.rap`
    again = atlas("check", "--format", "missions/formatted.rap", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    original = (tmp_path / "missions" / "deliver.rap").read_text(encoding="utf-8")
    assert parse_text(done.stdout, "a.rap") == parse_text(original, "a.rap")
    assert again.stdout.split("\n", 1)[1] == done.stdout.split("\n", 1)[1]  # formatted again: the same text


def test_format_prints_the_file_named_and_not_the_files_it_includes(tmp_path):
    (tmp_path / "lib.rap").write_text("(define-virtual-skill (beep) (after 1 (finish :succeed)))\n", encoding="utf-8")
    (tmp_path / "main.rap").write_text('(include "lib.rap")\n(define-rap (go) (method (task-net (beep))))\n',
                                       encoding="utf-8")
    done = atlas("check", "--format", "main.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "define-virtual-skill" not in done.stdout and '(include "lib.rap")' in done.stdout
    (tmp_path / "out.rap").write_text(done.stdout, encoding="utf-8")
    assert atlas("check", "out.rap", cwd=tmp_path).returncode == 0  # no definition twice
