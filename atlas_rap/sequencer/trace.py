"""The trace: what happened, when, as one record per event (the language reference, docs/language/trace.md).

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

from atlas_rap.trace_events import Event

Record = dict[str, Any]
Sink = Callable[[Record], object]

EVENTS: tuple[str, ...] = tuple(event.value for event in Event)
"""The event names, as plain strings; every record's ``event`` is one of them."""


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

    def emit(self, event: Event | str, **fields: Any) -> None:
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
    """Writes each record as one JSON line to a file, which appears whole at :meth:`close`.

    The lines go to a temporary file beside ``path`` (``atlas_rap.outputs``),
    renamed over ``path`` when the sink is closed, so an existing file stays
    as it was until then and is never left half-written. The CLI closes the
    sink in a ``finally``, so that a failed or interrupted run keeps what it
    traced; :meth:`discard` drops the lines instead (a run that never
    started). A write that fails (a full disk) stops the writing, and
    :meth:`close` raises it as an :class:`~atlas_rap.outputs.OutputError`
    (``what`` names the file in it: the CLI's option by default), leaving
    the old file.
    """

    def __init__(self, path: str | Path, what: str = "--trace") -> None:
        from atlas_rap.outputs import AtomicFile

        self.path = Path(path)
        self._file = AtomicFile(path, what, stream="t")
        self._stream: IO[str] = self._file.stream  # type: ignore[assignment]
        self._error: OSError | None = None

    def __call__(self, record: Record) -> None:
        if self._error is not None:
            return
        try:
            self._stream.write(json.dumps(record, separators=(",", ":")) + "\n")
        except OSError as exc:
            self._error = exc

    def close(self) -> None:
        """Finish the file: rename it into place (safe to call twice); an :class:`OutputError`
        when a write failed or the file cannot be finished."""
        if self._error is not None:
            self._file.discard()
            error, self._error = self._error, None
            raise self._file.error(error)
        self._file.commit()

    def discard(self) -> None:
        """Drop what was written; the file at ``path``, if any, stays as it was."""
        self._file.discard()
