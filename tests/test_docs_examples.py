"""Every RAP and AP example in the documentation is a program `atlas check` accepts.

The ```rap and ```ap blocks of README.md and docs/ (tests/doc_blocks.py) are
written to files and checked by one `atlas check` process; a bad block is
reported by the page and line it is on.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from doc_blocks import all_blocks

PROGRAMS = all_blocks("rap", "ap")


def test_the_language_reference_has_examples_of_both_languages():
    pages = {block.path.name for block in PROGRAMS}
    assert {"rap.md", "ap.md"} <= pages
    assert len(PROGRAMS) >= 12


def test_every_rap_and_ap_block_in_the_docs_checks(tmp_path):
    files: dict[str, str] = {}
    for n, block in enumerate(PROGRAMS):
        name = f"block-{n}.{block.lang}"
        (tmp_path / name).write_text(block.text, encoding="utf-8")
        files[name] = block.where
    done = subprocess.run([sys.executable, "-m", "atlas_rap", "check", *files], cwd=tmp_path,
                          capture_output=True, text=True, env={**os.environ, "NO_COLOR": "1"}, timeout=120)
    report = done.stdout + done.stderr
    shown = re.sub(r"block-\d+\.(rap|ap)", lambda m: files[m.group(0)], report)
    assert "Traceback" not in report, shown
    assert done.returncode == 0, f"examples in the docs that atlas check refuses:\n{shown}"
    for name in files:
        assert f"ok: {name}" in report, f"{files[name]}: not checked\n{shown}"


def test_a_bad_block_is_reported_by_its_page_and_line(tmp_path):
    """The collector itself: a block that does not check is found and named where it is written."""
    from doc_blocks import blocks

    page = tmp_path / "page.md"
    page.write_text("# A page\n\n```rap\n(define-rap (a) (sucede (x)))\n```\n", encoding="utf-8")
    (block,) = blocks(page)
    assert (block.line, block.lang) == (3, "rap")
    (tmp_path / "b.rap").write_text(block.text, encoding="utf-8")
    done = subprocess.run([sys.executable, "-m", "atlas_rap", "check", "b.rap"], cwd=tmp_path,
                          capture_output=True, text=True, env={**os.environ, "NO_COLOR": "1"}, timeout=60)
    assert done.returncode == 1 and "unknown clause 'sucede'" in done.stdout + done.stderr


EXCERPTS = [block for block in all_blocks("lisp", "rap", "ap", "yaml", "text", "") if block.marked("excerpt")]


@pytest.mark.parametrize("block", EXCERPTS, ids=[block.where for block in EXCERPTS])
def test_an_excerpt_of_a_shipped_file_is_in_it_verbatim(block):
    from doc_blocks import REPO

    shipped = (REPO / block.marked("excerpt")).read_text(encoding="utf-8")
    # verbatim but for a common indentation (an excerpt of a docstring's example)
    assert any(textwrap.indent(block.text, " " * n) in shipped for n in range(0, 13, 4)), \
        f"{block.where}: not what {block.marked('excerpt')} says"


def test_the_getting_started_mission_is_the_one_that_ships():
    from doc_blocks import REPO, blocks

    saved = [block for block in blocks(REPO / "docs" / "getting-started.md") if block.marked("file") == "coffee.rap"]
    assert len(saved) >= 2  # written step by step
    assert saved[-1].text == (REPO / "rap_library" / "missions" / "deliver-coffee.rap").read_text(encoding="utf-8")


MISSIONS = [block for block in PROGRAMS if block.lang == "rap" and "(post " in block.text and not block.marked("file")]


@pytest.mark.parametrize("block", MISSIONS, ids=[block.where for block in MISSIONS])
def test_every_example_mission_runs_and_its_tasks_succeed(block, tmp_path):
    """A reference example that posts tasks means what the page says: run, every posted task succeeds.
    (Examples saved as files by a page run in its console blocks instead.)"""
    (tmp_path / "example.rap").write_text(block.text, encoding="utf-8")
    done = subprocess.run([sys.executable, "-m", "atlas_rap", "run", "example.rap", "--quiet"], cwd=tmp_path,
                          capture_output=True, text=True, env={**os.environ, "NO_COLOR": "1"}, timeout=120)
    assert done.returncode == 0, f"{block.where}:\n{done.stdout}{done.stderr}"
    assert re.match(r"example\.rap: (\d+) of \1 posted tasks succeeded", done.stdout), done.stdout
