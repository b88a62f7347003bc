"""The fenced code blocks of the documentation (README.md and docs/**/*.md), for the tests that run them.

A block is a fence ```LANG ... ``` at the start of a line. Languages with a meaning here:

- ``rap`` and ``ap``: a complete program, which ``atlas check`` must accept
  (tests/test_docs_examples.py);
- ``console``: commands and what they print. A line ``$ COMMAND`` is run by a shell
  in a fresh folder with atlas-rap installed; the lines after it, up to the next
  ``$`` line, are what it must print (stdout and stderr together). A line ``...``
  in the shown output stands for any number of lines (output that is long or
  differs from run to run). A command with no lines after it must only succeed
  (exit 0) unless ``# exit N`` ends the command line (the comment is shell's own).

An HTML comment on the line before a block says more of it:

- ``<!-- not-run: REASON -->``: the block is not run (it needs a second machine,
  a network, minutes); the reason is required. A block that shows a command is a
  ``console`` block unless it says why it is not run (tests/test_docs_commands.py);
- ``<!-- file: NAME -->``: the block is a file the reader saves as NAME; the
  console blocks after it on the same page run with it in their folder, as the
  reader's would be (a later block of the same NAME replaces it);
- ``<!-- excerpt: PATH -->``: the block is an excerpt of the shipped file PATH, and
  appears in it verbatim (tests/test_docs_examples.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MARKER = re.compile(r"^<!--\s*(not-run|file|excerpt):\s*(\S.*?)\s*-->\s*$")
FENCE = re.compile(r"^```([A-Za-z0-9_-]*)\s*$")


@dataclass(frozen=True)
class Block:
    path: Path  # the Markdown file
    line: int  # 1-based line of the opening fence
    lang: str
    text: str
    marker: tuple[str, str] | None  # ("not-run", REASON), ("file", NAME) or ("excerpt", PATH)

    @property
    def not_run(self) -> str | None:
        """The reason given, when the block is marked not to run."""
        return self.marker[1] if self.marker and self.marker[0] == "not-run" else None

    def marked(self, kind: str) -> str | None:
        return self.marker[1] if self.marker and self.marker[0] == kind else None

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(REPO)}:{self.line}"


def doc_files() -> list[Path]:
    return [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]


def blocks(path: Path) -> list[Block]:
    lines = path.read_text(encoding="utf-8").split("\n")
    found, i = [], 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if opening is None:
            i += 1
            continue
        end = next((j for j in range(i + 1, len(lines)) if lines[j].rstrip() == "```"), None)
        assert end is not None, f"{path.relative_to(REPO)}:{i + 1}: a code block that never ends"
        marker = MARKER.match(lines[i - 1]) if i else None
        found.append(Block(path, i + 1, opening.group(1), "\n".join(lines[i + 1:end]) + "\n",
                           marker.groups() if marker else None))
        i = end + 1
    return found


def all_blocks(*langs: str) -> list[Block]:
    return [block for path in doc_files() for block in blocks(path) if block.lang in langs]
