"""Bad option values are refused with a usage error, and the help lists what actually ships."""

from __future__ import annotations

import re

import pytest
from cli_process import REPO, assert_no_traceback, atlas

from atlas_rap.shipped import shipped_worlds

SITE_VISIT = str(REPO / "rap_library" / "missions" / "site-visit.rap")
SMALL_MAP = str(REPO / "worlds" / "maps" / "small-office-map.yaml")


@pytest.mark.parametrize("args, option", [
    (("run", SITE_VISIT, "--until", "-5"), "--until"),
    (("run", SITE_VISIT, "--until", "0"), "--until"),
    (("repl", "--speed", "0"), "--speed"),
    (("map", "build", "--out", "m", "--until", "-1"), "--until"),
    (("map", "abstract", SMALL_MAP, "--out", "m", "--robot-radius", "0"), "--robot-radius"),
    (("plan", "operators/office-goals.ap", "--timeout", "-1"), "--timeout"),
], ids=["run --until -5", "run --until 0", "repl --speed 0", "map build --until -1",
        "map abstract --robot-radius 0", "plan --timeout -1"])
def test_zero_and_negative_amounts_are_refused_with_a_usage_error(tmp_path, args, option):
    done = atlas(*args, cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 2
    assert f"Invalid value for '{option}'" in done.stderr
    assert "x>0" in done.stderr


@pytest.mark.parametrize("command", ["run", "repl"])
def test_the_world_option_lists_the_worlds_that_ship(tmp_path, command):
    done = atlas(command, "--help", cwd=tmp_path)
    text = re.sub(r"-\s+", "-", " ".join(done.stdout.split()))  # click's wrapping may break a name at a hyphen
    names = shipped_worlds()
    assert len(names) >= 5
    assert f"a shipped world ({', '.join(names)})" in text


def test_the_docs_list_the_worlds_that_ship():
    page = (REPO / "docs" / "how-to" / "run.md").read_text(encoding="utf-8")
    section = page.split("Worlds that ship:", 1)[1].split("\n\n", 2)[1]
    listed = [line.split("`")[1] for line in section.splitlines() if line.startswith("| `")]
    assert listed == shipped_worlds()
