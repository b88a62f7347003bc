"""Trace event names live in one place (atlas_rap.trace_events.Event): producers emit members of it and
consumers compare records with them, so renaming an event is one edit and a typo is a NameError,
not a record that silently matches nothing (issue 26)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import atlas_rap
from atlas_rap.sequencer.trace import EVENTS
from atlas_rap.trace_events import Event

PACKAGE = Path(atlas_rap.__file__).parent
NAMES = "|".join(re.escape(event.value) for event in Event)
# an event name written as a string where an event is emitted, or where a record's event is compared
# (``event == "..."``, ``record["event"] != "..."``, ``record.get("event") == "..."``, ``event in (...)``)
BARE = re.compile(rf'(emit\(|trace\(|event["\])]*\s*[!=]=\s*|event\s+in\s+\([^)]*)"({NAMES})"')


def test_no_module_emits_or_compares_a_trace_event_by_a_bare_string():
    found = [f"{path.relative_to(PACKAGE.parent)}:{number}: {line.strip()}"
             for path in sorted(PACKAGE.rglob("*.py")) if path.name != "trace_events.py"
             for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
             if BARE.search(line)]
    assert found == [], "name these events through atlas_rap.trace_events.Event:\n" + "\n".join(found)


def test_an_event_is_its_string_in_records_json_and_messages():
    record = {"t": 0.0, "event": Event.TASK_POSTED}
    assert json.dumps(record) == '{"t": 0.0, "event": "task-posted"}'
    assert f"{Event.PLAN_DONE}" == str(Event.PLAN_DONE) == "plan-done"
    assert Event("layer-switched") is Event.LAYER_SWITCHED
    assert EVENTS == tuple(event.value for event in Event)
