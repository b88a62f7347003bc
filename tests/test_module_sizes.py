"""Modules stay small (one idea each): a module of the package over 25 KB says in its docstring why it
is one module (issue 26), so a module that grows past it gets split or explained, not forgotten."""

from __future__ import annotations

import ast
from pathlib import Path

import atlas_rap

LIMIT = 25 * 1024


def test_every_module_over_25_kb_says_why_it_is_one_module():
    package = Path(atlas_rap.__file__).parent
    unexplained = []
    for path in sorted(package.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        size = len(text.encode("utf-8"))
        if size > LIMIT and "Over 25 KB on purpose:" not in (ast.get_docstring(ast.parse(text)) or ""):
            unexplained.append(f"{path.relative_to(package.parent)} ({size // 1024} KB)")
    assert unexplained == [], "split these modules, or say in the docstring why each is one module:\n" + \
        "\n".join(unexplained)
