"""The commands the documentation shows are run, and what they print is compared with what is shown.

Each ```console block of README.md and docs/ (tests/doc_blocks.py says how one is written) runs in a
fresh folder, its commands one after another by bash, with the installed `atlas` first on PATH (the
one beside this Python), so a page's command works as it would for a reader who installed the
package. A block that must not run says why in a `<!-- not-run: REASON -->` comment; every other block
that shows a command is a console block.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from doc_blocks import REPO, Block, all_blocks, blocks

SHELL_LANGS = ("console", "sh", "bash", "shell")
CONSOLE = [block for block in all_blocks("console") if block.not_run is None]


def commands(block: Block) -> list[tuple[str, list[str]]]:
    """The block's commands, each with the lines shown after it."""
    found: list[tuple[str, list[str]]] = []
    for line in block.text.rstrip("\n").split("\n"):
        if line.startswith("$ "):
            found.append((line[2:], []))
        else:
            assert found, f"{block.where}: a console block starts with a '$ ' command"
            found[-1][1].append(line)
    return found


def pattern(shown: list[str]) -> re.Pattern:
    """A line '...' is any number of lines; '...' inside a line is any text."""
    parts = []
    for line in shown:
        if line.strip() == "...":
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            parts.append(".*?".join(re.escape(piece) for piece in line.split("...")) + r"[ \t]*\n")
    return re.compile("".join(parts))


def run(command: str, folder: Path) -> subprocess.CompletedProcess:
    scripts = str(Path(sys.executable).parent)  # the venv's bin: its atlas is the one installed here
    env = {"PATH": f"{scripts}:/usr/bin:/bin", "HOME": str(folder), "NO_COLOR": "1", "PYTHONUNBUFFERED": "1",
           "LANG": "C.UTF-8", "XDG_RUNTIME_DIR": str(folder / "run"), "XDG_DATA_HOME": str(folder / "data")}
    return subprocess.run(["bash", "-c", command], cwd=folder, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=300)


@pytest.mark.parametrize("block", CONSOLE, ids=[block.where for block in CONSOLE])
def test_the_commands_of_a_console_block_print_what_it_shows(block: Block, tmp_path):
    for earlier in blocks(block.path):  # the files the page had the reader save so far
        if earlier.line < block.line and earlier.marked("file"):
            (tmp_path / earlier.marked("file")).write_text(earlier.text, encoding="utf-8")
    for command, shown in commands(block):
        done = run(command, tmp_path)
        expected = re.search(r"#\s*exit\s+(\d+)\s*$", command)
        code = int(expected.group(1)) if expected else 0
        context = f"{block.where}: $ {command}\n--- printed (exit {done.returncode}):\n{done.stdout}"
        assert "Traceback" not in done.stdout, context
        assert done.returncode == code, context
        printed = done.stdout if done.stdout.endswith("\n") or not done.stdout else done.stdout + "\n"
        if shown:
            assert pattern(shown).fullmatch(printed), context + "--- shown:\n" + "\n".join(shown)


def shows_a_command(block: Block) -> bool:
    return any(re.match(r"(\$ |atlas |pip |python |sh )", line) for line in block.text.splitlines())


def test_every_block_that_shows_a_command_runs_or_says_why_not():
    unrun = [block.where for path in [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
             for block in blocks(path)
             if block.lang in SHELL_LANGS[1:] or (block.lang in ("", "text") and shows_a_command(block))
             if block.not_run is None]
    assert unrun == [], "write these as ```console blocks, or say why they do not run (<!-- not-run: ... -->)"


def test_the_blocks_not_run_are_few():
    assert len([b for b in all_blocks(*SHELL_LANGS) if b.not_run]) <= 25
    assert len(CONSOLE) >= 10


def test_the_readme_shows_the_test_command_ci_runs_verbatim():
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    command = ci[ci.index("# The README's test command, verbatim:") + 1]
    assert command == "pip install '.[test]' && pytest"
    assert command in (REPO / "README.md").read_text(encoding="utf-8")


def test_shown_output_is_compared_not_just_run(tmp_path):
    """The comparison itself: a wrong line is caught, a '...' line stands for any lines, '...' in a line for any text."""
    printed = "rap_library/x.rap: 1 of 1 posted tasks succeeded in 4 s simulated (0.01 s wall)\n  ✓ (a) succeeded\n"
    assert pattern(["rap_library/x.rap: 1 of 1 posted tasks succeeded in 4 s simulated (... s wall)",
                    "  ✓ (a) succeeded"]).fullmatch(printed)
    assert pattern(["...", "  ✓ (a) succeeded"]).fullmatch(printed)
    assert not pattern(["...", "  ✗ (a) failed"]).fullmatch(printed)
    assert not pattern(["rap_library/x.rap: 1 of 1 posted tasks succeeded in 5 s simulated (... s wall)",
                        "..."]).fullmatch(printed)
