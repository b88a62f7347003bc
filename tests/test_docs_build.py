"""The documentation site builds with MkDocs, warnings as errors (`mkdocs build --strict`), as CI builds it."""

from __future__ import annotations

import os
import subprocess
import sys

from doc_blocks import REPO


def test_the_site_builds_strictly_with_the_command_reference(tmp_path):
    site = tmp_path / "site"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(REPO / "mkdocs.yml"),
                           "-d", str(site)], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"}, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr  # --strict: any warning (a broken link, a page
    # left out of the nav, a missing anchor) aborts the build
    commands = (site / "reference" / "commands" / "index.html").read_text(encoding="utf-8")
    for command in ("atlas check", "atlas run", "atlas plan", "atlas repl", "atlas map", "atlas skills"):
        assert command in commands, f"{command} is missing from the generated command reference"
    assert "--until" in commands  # the options are there, from the click commands themselves
    assert (site / "language" / "rap" / "index.html").is_file()
    assert (site / "foxglove-recording.png").is_file()  # the README's figures stay where they were
