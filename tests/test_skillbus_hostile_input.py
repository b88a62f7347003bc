"""Whatever comes on the bus, the decoder answers with a message or a DecodeError, and the
turn-taking keeps only what holds: fuzzed bytes, JSON and mutated frames; tags that fail on a
flipped bit, another key or the other direction; replays out of turn; token files."""

from __future__ import annotations

import json
import os
import stat

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from atlas_rap.logic import Compound
from atlas_rap.skillbus.auth import (TO_HOST, TO_SEQUENCER, Secret, TokenError, host_secret, read_token_file,
                                     sequencer_secrets, session_key, tag, verify)
from atlas_rap.skillbus.messages import (MAX_DEPTH, Ack, DecodeError, Done, Enable, FactAsserted, Frame, Message,
                                         Note, Tick, decode, nesting_depth)
from atlas_rap.skillbus.protocol import FRAME, Peer
from atlas_rap.skillbus.zenoh_bus import DropLog

CALL = Compound("navigate-to", ("office",))
FRAMES = [
    Frame("0a1b2c3d4e5f", 3, (FactAsserted(Compound("at", ("robot", "lab"))), Enable(CALL)), 120, 1),
    Frame("0a1b2c3d4e5f", 4, (Done(CALL, ":succeed"), Ack(130, 2)), 130, 2, "skill (navigate-to office)", CALL),
    Frame("0a1b2c3d4e5f", 5, (Tick(6580, 1, 65.8), Note(65.8, "layer-switched", {"layer": "II"}))),
]
VALID = [frame.to_bytes() for frame in FRAMES]


def decoded_or_refused(data: bytes) -> Message | None:
    """What decode makes of ``data``: a message, or None for a DecodeError; nothing else may escape."""
    try:
        message = decode(data)
    except DecodeError:
        return None
    assert decode(message.to_bytes()) == message  # whatever decodes is a whole message
    return message


@settings(max_examples=400, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=2048))
def test_random_bytes_decode_to_a_message_or_a_decode_error(data):
    decoded_or_refused(data)


JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
                    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=10), inner, max_size=5),
                    max_leaves=40)
FIELDS = st.sampled_from(["v", "type", "session", "seq", "tick", "phase", "messages", "call", "fact", "outcome",
                          "t", "robot", "world", "skills", "rates", "data", "event", "error", "source", "skill"])


@settings(max_examples=400, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(FIELDS, JSON, max_size=8), st.sampled_from(["frame", "enable", "done", "tick", "welcome",
                                                                   "note", "rule-fired", "hello", "ack"]))
def test_random_json_in_the_shape_of_a_message_decodes_or_is_refused(fields, kind):
    decoded_or_refused(json.dumps({"v": 1, "type": kind, **fields}, allow_nan=True).encode())


@settings(max_examples=600, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(VALID), st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)), min_size=1,
                                        max_size=4))
def test_mutated_valid_frames_decode_or_are_refused(data, changes):
    mutated = bytearray(data)
    for where, value in changes:
        mutated[where % len(mutated)] = value
    decoded_or_refused(bytes(mutated))


def test_messages_too_large_or_too_deep_are_refused_before_they_are_parsed():
    deep = b"[" * 100_000 + b"]" * 100_000  # a stack overflow for a naive recursive reader
    with pytest.raises(DecodeError, match="deeper than"):
        decode(deep)
    with pytest.raises(DecodeError, match="more than the"):
        decode(b'{"v": 1, "pad": "' + b"x" * (1 << 20) + b'"}')
    assert nesting_depth(b'{"a": "[[[[[[" , "b": [1, [2]]}') == 3  # brackets in strings do not count
    assert nesting_depth(VALID[0]) < MAX_DEPTH


def test_a_note_cannot_name_its_fields_t_or_event():
    note = {"v": 1, "type": "note", "t": 1.0, "event": "layer-switched", "data": {"event": "x"}}
    with pytest.raises(DecodeError, match="other than t and event"):
        decode(json.dumps(note).encode())


def test_unknown_fields_and_out_of_range_numbers_are_refused():
    tick = {"v": 1, "type": "tick", "tick": 1, "phase": 0, "t": 0.01}
    assert decode(json.dumps(tick).encode()) == Tick(1, 0, 0.01)
    for bad in ({**tick, "extra": 1}, {**tick, "phase": 4}, {**tick, "tick": -1}, {**tick, "t": float("nan")}):
        with pytest.raises(DecodeError):
            decode(json.dumps(bad).encode())


# -- tags ------------------------------------------------------------------------------------

KEY = bytes(range(32))
EXPR = "atlas/robot/clock/tick"


def test_a_tag_holds_only_for_its_frame_its_key_expression_and_its_direction():
    payload = VALID[0]
    attachment = tag(KEY, TO_HOST, EXPR, payload)
    assert verify(KEY, TO_HOST, EXPR, payload, attachment)
    assert not verify(KEY, TO_SEQUENCER, EXPR, payload, attachment)  # reflected back to its sender
    assert not verify(KEY, TO_HOST, "atlas/robot/skill/stop/enable", payload, attachment)
    assert not verify(bytes(32), TO_HOST, EXPR, payload, attachment)
    assert not verify(KEY, TO_HOST, EXPR, payload, attachment[:-1])
    for bit in range(0, len(payload) * 8, 37):
        flipped = bytearray(payload)
        flipped[bit // 8] ^= 1 << (bit % 8)
        assert not verify(KEY, TO_HOST, EXPR, bytes(flipped), attachment)
    for bit in range(len(attachment) * 8):
        flipped = bytearray(attachment)
        flipped[bit // 8] ^= 1 << (bit % 8)
        assert not verify(KEY, TO_HOST, EXPR, payload, bytes(flipped))


def test_each_session_has_its_own_key_from_both_sides_nonces():
    secret = Secret(b"s" * 32, "test")
    one = session_key(secret, "abc", b"n" * 16, b"h" * 16)
    assert one == session_key(secret, "abc", b"n" * 16, b"h" * 16)
    assert len({one, session_key(secret, "abc", b"n" * 16, b"H" * 16), session_key(secret, "abd", b"n" * 16, b"h" * 16),
                session_key(Secret(b"t" * 32, "other"), "abc", b"n" * 16, b"h" * 16)}) == 4


class Wire:
    """A conversation's two ends as a list: what a Peer puts, and what it is given to receive.
    (A stand-in for the Zenoh conversation, in this unit test of the Peer that uses it.)"""

    def __init__(self) -> None:
        self.put_frames: list[tuple[str, bytes, bytes]] = []
        self.incoming: list[tuple[str, tuple[str, bytes, bytes]]] = []
        self.drops = DropLog()
        self.max_message = 1 << 20

    def put(self, key: str, payload: bytes, attachment: bytes = b"") -> None:
        self.put_frames.append((key, payload, attachment))

    def receive(self, timeout: float):
        return self.incoming.pop(0) if self.incoming else None


def pair() -> tuple[Peer, Peer, Wire, Wire]:
    secret = Secret(b"k" * 32, "test")
    wire_a, wire_b = Wire(), Wire()
    sender, receiver = Peer(wire_a, "robot", secret), Peer(wire_b, "robot", secret)
    receiver.outbound = TO_SEQUENCER
    for peer in (sender, receiver):
        peer.restart("0a1b2c3d4e5f")
        peer.key = KEY
    return sender, receiver, wire_a, wire_b


def test_a_peer_takes_frames_that_hold_in_turn_and_drops_replays_flips_and_strangers():
    sender, receiver, sent, received = pair()
    for messages in ([Enable(CALL)], [Tick(1, 0, 0.01)]):
        sender.send(EXPR, messages)
    first, second = sent.put_frames
    flipped = (first[0], first[1].replace(b"navigate-to", b"navigate-tp"), first[2])
    stranger = (first[0], Frame("0a1b2c3d4e5f", 0, (Enable(Compound("stop", ())),)).to_bytes(), os.urandom(32))
    received.incoming = [(FRAME, frame) for frame in (flipped, stranger, first, first, second, first)]
    taken = []
    while (event := receiver.next_event(0)) is not None:
        taken.append(event[1].last)
    assert taken == [Enable(CALL), Tick(1, 0, 0.01)]  # each once, in order
    assert received.drops.counts == {"a frame that fails authentication": 2, "a frame out of turn (a replay?)": 2}


# -- token files -------------------------------------------------------------------------------


def test_a_host_makes_its_secret_once_readable_only_by_its_user(tmp_path, monkeypatch):
    monkeypatch.delenv("ATLAS_BUS_TOKEN", raising=False)
    path = tmp_path / "run" / "alice.token"
    made = host_secret("alice", path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert host_secret("alice", path) == made  # kept across restarts
    assert read_token_file(path) == ("alice", made)
    with pytest.raises(TokenError, match="robot 'alice''s, not 'bob''s"):
        host_secret("bob", path)
    path.chmod(0o640)
    with pytest.raises(TokenError, match="chmod 600"):
        host_secret("alice", path)


def test_the_environment_holds_the_secret_in_place_of_a_file(tmp_path, monkeypatch):
    monkeypatch.setenv("ATLAS_BUS_TOKEN", "a-secret-of-enough-characters")
    assert host_secret("alice", tmp_path / "never.token").key == b"a-secret-of-enough-characters"
    assert not (tmp_path / "never.token").exists()
    monkeypatch.setenv("ATLAS_BUS_TOKEN", "short")
    with pytest.raises(TokenError, match="at least 16"):
        host_secret("alice", tmp_path / "never.token")


def test_a_sequencer_reads_each_robots_secret_from_its_file_or_its_default(tmp_path, monkeypatch):
    monkeypatch.delenv("ATLAS_BUS_TOKEN", raising=False)
    monkeypatch.setenv("ATLAS_RUNTIME_DIR", str(tmp_path / "runtime"))
    alice = host_secret("alice")  # the default file, as a host on this machine writes it
    bob = host_secret("bob", tmp_path / "copied-from-bob.token")
    sources = sequencer_secrets(["alice", "bob"], [tmp_path / "copied-from-bob.token"])
    assert (sources["alice"](), sources["bob"]()) == (alice, bob)
    with pytest.raises(TokenError, match="robot 'bob''s; this run uses alice"):
        sequencer_secrets(["alice"], [tmp_path / "copied-from-bob.token"])
    (tmp_path / "junk.token").write_text("not json")
    with pytest.raises(TokenError, match="not a token file"):
        sequencer_secrets(["alice"], [tmp_path / "junk.token"])
    with pytest.raises(TokenError, match="no token for robot 'carol'"):
        sequencer_secrets(["carol"], [])["carol"]()


def test_a_secret_never_shows_in_its_repr():
    assert "k" * 8 not in repr(Secret(b"k" * 32, "where"))
