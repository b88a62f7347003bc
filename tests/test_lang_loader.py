"""Loading a program: includes relative to the including file, each file once."""

from __future__ import annotations

from pathlib import Path

from atlas_rap.lang import ast, load


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def test_includes_resolve_relative_to_the_including_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "missions" / "m.rap", '(include "../lib/nav.rap")\n(post (go lab))\n')
    write(tmp_path / "lib" / "nav.rap", '(include "skills/move.rap")\n'
                                        "(define-rap (go ?p) (method (task-net (t1 (move ?p)))))\n")
    write(tmp_path / "lib" / "skills" / "move.rap", "(define-virtual-skill (move ?p) (after 1 (finish :succeed)))\n")
    program = load(tmp_path / "missions" / "m.rap")
    assert [f.path for f in program.files] == ["missions/m.rap", "lib/nav.rap", "lib/skills/move.rap"]
    assert [type(f).__name__ for f in program.forms] == ["VirtualSkillDef", "RapDef", "Post"]


def test_a_file_included_twice_is_loaded_once(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "common.rap", "(define-memory-rule r (on (a ?x)) (assert (b ?x)))\n")
    write(tmp_path / "one.rap", '(include "common.rap")\n(define-rap (one) (method (task-net (wait-for (b 1)))))\n')
    write(tmp_path / "two.rap", '(include "./common.rap")\n(define-rap (two) (method (task-net (wait-for (b 2)))))\n')
    write(tmp_path / "main.rap", '(include "one.rap")\n(include "two.rap")\n(include "common.rap")\n')
    program = load(tmp_path / "main.rap")
    assert len(program.files) == 4
    assert len(program.of_type(ast.MemoryRuleDef)) == 1
    assert [r.name for r in program.of_type(ast.RapDef)] == ["one", "two"]


def test_problems_in_several_files_are_all_reported(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "main.rap", '(include "a.rap")\n(include "b.rap")\n(post go)\n')
    write(tmp_path / "a.rap", "(define-rap (x) (methd))\n")
    write(tmp_path / "b.rap", "(define-rap (y) (method)\n")
    import pytest

    from atlas_rap.errors import SourceError
    with pytest.raises(SourceError) as caught:
        load(tmp_path / "main.rap")
    found = [(p.location.file, p.location.line, p.location.column, p.message) for p in caught.value.problems]
    assert found == [
        ("main.rap", 3, 7, "expected a task call such as (name arg ...), found 'go'"),
        ("a.rap", 1, 18, "unknown clause 'methd'"),
        ("b.rap", 1, 1, "unbalanced '(': this list is never closed"),
    ]


def test_a_rap_defined_twice_across_files_is_an_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "a.rap", '(include "b.rap")\n(define-rap (go) (method (task-net (t1 (walk)))))\n')
    write(tmp_path / "b.rap", "(define-rap (go) (method (task-net (t1 (run)))))\n")
    import pytest

    from atlas_rap.errors import SourceError
    with pytest.raises(SourceError) as caught:
        load(tmp_path / "a.rap")
    (problem,) = caught.value.problems
    assert problem.message == "define-rap 'go' is defined twice (first at b.rap:1:1)"
    assert (problem.location.file, problem.location.line) == ("a.rap", 2)
