"""The skill bus's messages and seams, without a bus: every message round-trips through its
one serialisation, what cannot be decoded is one clear error, and the in-process path
serialises nothing."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from atlas_rap.layers import MissionEngine
from atlas_rap.logic import Compound, String, Var
from atlas_rap.sequencer import Trace
from atlas_rap.skillbus import DecodeError, VersionError
from atlas_rap.skillbus.messages import (
    VERSION,
    Ack,
    Disable,
    Done,
    Enable,
    FactAsserted,
    FactRetracted,
    Frame,
    Hello,
    Message,
    Note,
    RuleFired,
    Tick,
    Welcome,
    Why,
    changes_to_messages,
    decode,
    decode_term,
    encode_term,
    message_change,
)

PACKAGE = Path(__file__).resolve().parent.parent / "atlas_rap"
CALL = Compound("navigate-to", ("office",))
ODD = Compound("odd", (String('a "quoted" Ünïcode\n'), -3, 2.5, 1e-300, Var("x"), Compound("", (1, 2)),
                       ":keyword", Compound("nested", (Compound("deep", ("t", "nil")),))))

MESSAGES: list[Message] = [
    Enable(CALL),
    Disable(Compound("move-to", (2.0, -3.5))),
    Done(CALL, ":succeed"),
    Why(CALL, "the door is closed"),
    FactAsserted(Compound("at", ("robot", "office"))),
    FactRetracted(ODD),
    Tick(6580, 1, 65.8),
    Ack(6580, 2),
    Ack(12, 0, "KeyError: 'fly'"),
    Hello("alice", 300),
    Welcome("robot", "lab-corridor-office", {"navigate-to": (1,), "move-to": (2,)}, ("at", "done", "why"),
            (Compound("place", ("lab",)), Compound("map", ("prior",))), (100.0, 20.0, 10.0)),
    Welcome("robot", error="busy"),
    RuleFired("way-clear", (("assert", Compound("primary-layer", ("ii",))), ("retract", Compound("x", (Var("l"),)))),
              Compound("obstacle", ("none",))),
    Note(22.1, "layer-switched", {"layer": "I", "previous": "II", "reason": "rule something-in-the-way"}),
]


@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: f"{m.TYPE}")
def test_each_message_round_trips_through_its_bytes(message):
    data = message.to_bytes()
    back = Message.from_bytes(data)
    assert back == message and type(back) is type(message)
    obj = json.loads(data)
    assert obj["v"] == VERSION and obj["type"] == message.TYPE


def test_a_frame_round_trips_with_its_messages_in_order():
    frame = Frame("abc123", 7, tuple(MESSAGES), 6580, 1, "skill (navigate-to office)", CALL)
    assert decode(frame.to_bytes()) == frame


def test_terms_are_written_as_a_compact_json_structure_any_client_can_read():
    assert encode_term(Compound("done", (CALL, ":succeed"))) == ["done", ["navigate-to", "office"], ":succeed"]
    assert encode_term(String("hi")) == {"str": "hi"}
    assert decode_term(encode_term(ODD)) == ODD
    assert decode_term(encode_term(float("inf"))) == float("inf")
    assert type(decode_term(encode_term(1.0))) is float and type(decode_term(encode_term(1))) is int


@pytest.mark.parametrize("data", [
    b"\xff\xfe not utf-8",
    b"{not json",
    b"[1, 2, 3]",
    b'{"v": 1, "type": "warp"}',
    b'{"v": 1, "type": "enable"}',
    b'{"v": 1, "type": "enable", "call": 42}',
    b'{"v": 1, "type": "enable", "call": [1, "x"]}',
    b'{"v": 1, "type": "done", "call": ["go"], "outcome": "succeed"}',
    b'{"v": 1, "type": "tick", "tick": "soon", "phase": 0, "t": 0}',
    b'{"v": 1, "type": "tick", "tick": true, "phase": 0, "t": 0}',
    b'{"v": 1, "type": "asserted", "fact": ["at", {"what": 1}]}',
    b'{"v": 1, "type": "frame", "session": "s", "seq": 0, "tick": 0, "phase": 0, "messages": [{"v": 1}]}',
    b'{"v": 1, "type": "welcome", "robot": "r", "world": "w", "skills": {"a": [1]}, "produces": [],'
    b' "prior": [], "rates": [100, 20]}',
], ids=lambda d: d[:40].decode("utf-8", "replace"))
def test_a_malformed_message_raises_the_decode_error(data):
    with pytest.raises(DecodeError):
        decode(data)


def test_another_protocol_version_is_a_clear_version_error():
    data = json.dumps({"v": VERSION + 1, "type": "enable", "call": ["stop"]}).encode()
    with pytest.raises(VersionError, match=f"version {VERSION + 1} where {VERSION} was expected"):
        decode(data)
    with pytest.raises(VersionError):
        decode(b'{"type": "enable", "call": ["stop"]}')
    assert issubclass(VersionError, DecodeError)


def test_changes_become_typed_messages_and_back():
    changes = [("assert", Compound("why", (CALL, String("blocked")))), ("assert", Compound("done", (CALL, ":fail"))),
               ("assert", Compound("at", ("robot", "lab"))), ("retract", Compound("at", ("robot", "hall")))]
    messages = changes_to_messages(changes)
    assert [type(m) for m in messages] == [Why, Done, FactAsserted, FactRetracted]
    assert [message_change(m) for m in messages] == changes
    assert message_change(Tick(1, 0, 0.01)) is None


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return found


def test_the_skill_bus_sits_below_the_sequencer_and_the_skills_and_imports_neither():
    for path in (PACKAGE / "skillbus").glob("*.py"):
        bad = {m for m in _imports(path) if m.startswith(("atlas_rap.sequencer", "atlas_rap.skills",
                                                           "atlas_rap.layers", "atlas_rap.cli"))}
        assert not bad, f"{path.name} imports {bad}"
    assert not (PACKAGE / "sequencer" / "skill_link.py").exists()
    assert not (PACKAGE / "sequencer" / "timers.py").exists()
    for folder in ("skills", "sequencer"):
        for path in (PACKAGE / folder).glob("*.py"):
            assert not {m for m in _imports(path) if m.startswith("atlas_rap.sequencer")} or folder == "sequencer"


def test_the_in_process_path_serialises_nothing(monkeypatch, tmp_path):
    def refuse(self):
        raise AssertionError("serialised on the in-process path")

    monkeypatch.setattr(Message, "to_bytes", refuse)
    monkeypatch.setattr(Frame, "to_bytes", refuse)
    mission = tmp_path / "m.rap"
    mission.write_text("(world none)\n(define-virtual-skill (beep) (after 1.0 (assert (beeped)) (finish :succeed)))\n"
                       "(define-rap (go) (succeed (beeped)) (method (task-net (t1 (beep)))))\n(post (go))\n",
                       encoding="utf-8")
    engine = MissionEngine(trace=Trace(keep=True))
    engine.load_file(mission, require_post=True)
    assert engine.run_mission(60).ok
