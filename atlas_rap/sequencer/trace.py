"""The trace: what happened, when, as one record per event (LANGUAGE.md §2.8).

The sequencer :meth:`Trace.emit`\\ s a record for every task, method, step,
skill and fact event; sinks receive the records as they happen. Records are
plain dicts with at least ``t`` (simulated seconds) and ``event``, ready to
be written as JSON lines (:class:`JsonlSink`), kept in a list
(:class:`Trace` keeps every record when ``keep=True``), or printed live by
the CLI. With no sink and ``keep=False``, emitting costs one test.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Any, Callable

Record = dict[str, Any]
Sink = Callable[[Record], object]

EVENTS = (
    "task-posted", "task-selected", "method-selected", "task-succeeded", "task-failed",
    "task-halted", "step-outcome", "skill-enabled", "skill-disabled", "fact-asserted",
    "fact-retracted", "plan-ready", "layer-switched",
    # the plan executive (sequencer.deliberation), beyond LANGUAGE.md's list:
    "plan-requested", "plan-step-started", "plan-step-done", "plan-step-failed", "replanned",
    "plan-abandoned", "plan-done",
)
"""The event names of LANGUAGE.md §2.8; every record's ``event`` is one of them."""


class Trace:
    """Collects trace records and hands each to the sinks, in order.

    ``clock`` returns the current simulated time for each record's ``t``;
    a sequencer given a trace without one sets it to its own clock.
    ``keep=True`` keeps every record in :attr:`records` (tests, the REPL).
    """

    def __init__(self, clock: Callable[[], float] | None = None, *, keep: bool = False) -> None:
        self.clock = clock
        self.sinks: list[Sink] = []
        self.records: list[Record] | None = [] if keep else None
        self.active = keep

    def add_sink(self, sink: Sink) -> None:
        """Send every later record to ``sink`` too."""
        self.sinks.append(sink)
        self.active = True

    def emit(self, event: str, **fields: Any) -> None:
        """Record one event now; fields are JSON-ready values (numbers, strings, lists)."""
        if not self.active:
            return
        record: Record = {"t": self.clock(), "event": event}  # type: ignore[misc]
        record.update(fields)
        if self.records is not None:
            self.records.append(record)
        for sink in self.sinks:
            sink(record)


class JsonlSink:
    """Writes each record as one JSON line to a file; :meth:`close` flushes it.

    The file is opened at once, so a trace that was asked for exists even
    when the run fails before its first event; the CLI closes it in a
    ``finally`` so that a failed or interrupted run keeps what it traced.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file: IO[str] = self.path.open("w", encoding="utf-8")

    def __call__(self, record: Record) -> None:
        self._file.write(json.dumps(record, separators=(",", ":")) + "\n")

    def close(self) -> None:
        """Flush and close the file (safe to call twice)."""
        if not self._file.closed:
            self._file.close()
