"""Running a mission written inline, and asking its trace what happened.

    from scenario import run

    def test_something(tmp_path):
        with run(tmp_path, MISSION) as s:
            assert s.times("task-succeeded", task="(fasten bolt-1)") == [3.0]

``run`` writes the text to ``tmp_path/m.rap``, loads it, runs it on
simulated time and returns a :class:`Scenario`. Assertions made inside
``with s:`` that fail get the final task tree and the last trace records
appended to their message, so a failing scenario says what the sequencer did.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from atlas_rap.lang import parse_term
from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.logic import term_to_str
from atlas_rap.sequencer import Trace, agenda_tree, tree_text

LIBRARY = Path(__file__).resolve().parents[1] / "rap_library" / "space-station.rap"
"""The shipped 3T space-station RAPs, for ``(include "...")``."""

INCLUDE_LIBRARY = f'(include "{LIBRARY}")'

LAST_RECORDS = 30


def load_mission(path: Path | str, trace: Trace | None = None) -> MissionEngine:
    """A mission loaded as `atlas run --world none` loads it (virtual skills, no world), not yet run."""
    engine = MissionEngine(RunOptions(default_world="none"), trace=trace)
    engine.load_file(path, require_post=True)
    return engine


def show(record: dict[str, Any]) -> str:
    """One trace record as one short line."""
    rest = " ".join(f"{k}={v}" for k, v in record.items() if k not in ("t", "event"))
    return f"t={record['t']:g} {record['event']} {rest}"


class Scenario:
    """A mission that has run: its result, trace records, memory and task tree."""

    def __init__(self, path: Path, until: float) -> None:
        self.path = path
        self.mission = load_mission(path, trace=Trace(keep=True))
        self.result = self.mission.run_mission(until)
        self.records: list[dict[str, Any]] = self.mission.trace.records

    # -- the trace -----------------------------------------------------------

    def events(self, name: str | None = None, **match: Any) -> list[dict[str, Any]]:
        """Records of event ``name`` (any when None) whose fields equal ``match``."""
        return [r for r in self.records
                if (name is None or r["event"] == name)
                and all(r.get(key) == value for key, value in match.items())]

    def times(self, name: str | None = None, **match: Any) -> list[float]:
        """When the matching records happened."""
        return [r["t"] for r in self.events(name, **match)]

    def field(self, key: str, name: str | None = None, **match: Any) -> list[Any]:
        """One field of every matching record, e.g. ``field("method", "method-selected")``."""
        return [r.get(key) for r in self.events(name, **match)]

    def task(self, text: str):
        """The task with this call text (posted or a subtask); the first if several."""
        stack = list(self.result.tasks)
        while stack:
            task = stack.pop(0)
            if task.text == text:
                return task
            stack.extend(task.children)
        raise AssertionError(f"no task {text}")

    def all_tasks(self) -> list:
        found, stack = [], list(self.result.tasks)
        while stack:
            task = stack.pop(0)
            found.append(task)
            stack.extend(task.children)
        return found

    # -- memory and the tree ---------------------------------------------------

    @property
    def memory(self):
        return self.mission.sequencer.memory

    def holds(self, text: str) -> bool:
        """Whether a query (source text) holds in final memory."""
        return self.memory.holds(parse_term(text))

    def facts(self, predicate: str | None = None) -> list[str]:
        """Final memory as sorted strings, optionally of one predicate."""
        return sorted(term_to_str(f) for f in self.memory
                      if predicate is None or f.functor == predicate)

    @property
    def tree(self) -> str:
        return tree_text(agenda_tree(self.mission.sequencer))

    def report(self) -> str:
        """The task tree, how the run ended and the last trace records."""
        tail = self.records[-LAST_RECORDS:]
        return "\n".join([
            f"--- task tree (run ended by {self.result.ended_by} at t={self.result.time:g}) ---",
            self.tree,
            f"--- last {len(tail)} of {len(self.records)} trace records ---",
            *map(show, tail),
        ])

    # -- failing with the tree ---------------------------------------------------

    def __enter__(self) -> Scenario:
        return self

    def __exit__(self, kind, error, traceback) -> bool:
        if isinstance(error, AssertionError):
            error.args = (f"{error.args[0] if error.args else ''}\n\n{self.report()}",)
        return False


def run(tmp_path: Path, text: str, until: float = 600.0, name: str = "m.rap") -> Scenario:
    """Write ``text`` as a mission file in ``tmp_path``, load it and run it."""
    path = Path(tmp_path) / name
    path.write_text(text, encoding="utf-8")
    return Scenario(path, until)
