"""The lock-step protocol between a sequencer and a skill host: positions on the clock, and turns.

**Positions.** Time is counted in physics steps (*ticks*, 100 Hz by
default), as the executive counts it (``layers.executive``). Within one
tick the in-process executive runs, in this order: the physics step;
at a skills tick the sequencer's due timers (point :data:`SKILLS`), the
skills and Layer I; at a sequencer tick the RAPs (point :data:`SEQUENCER`)
and Layer II; Layers III and IV; and the tick is over (:data:`END`).
Starting a run (the executive's ``_begin``: the skills tick once and the
layers start) ends with the agenda settling (:data:`BEGIN`, after the END of
the tick it starts at). A position is ``(tick, phase)``; positions compare
as tuples.

**Turns.** Exactly one side runs at a time, so the order of everything is
the order of one process. The sequencer hands the host the turn with a
:class:`~atlas_rap.skillbus.messages.Tick` ("advance to this position"),
an ``Enable`` or a ``Disable``; the host hands it back with an ``Ack``
(reached it, or did it), and when its skills or layers change facts on the
way it sends them as a batch and waits: the sequencer applies the batch
exactly as in one process (memory rules, waking waiting tasks, which may
enable or disable skills on the host right then, the host serving those
while it waits) and answers with an ``Ack`` that says where the host is to
stop now (a change may have made a timer due sooner). Every frame the
sequencer sends begins with what changed in its memory since its last
frame, so the host's copy of memory (what its skills and layers read) is
the sequencer's whenever the host runs.

Each side numbers the frames it sends and tags each under the session's key
(:mod:`~atlas_rap.skillbus.auth`); a frame whose tag fails, out of turn, or of
another session is logged and dropped, and changes nothing.
"""

from __future__ import annotations

import logging
import time
from typing import Any, Iterable

from atlas_rap.skillbus.auth import TO_HOST, TO_SEQUENCER, Secret, tag, verify
from atlas_rap.skillbus.messages import DecodeError, Frame, Message, decode
from atlas_rap.skillbus.zenoh_bus import ALIVE, FRAME, GONE, Conversation

log = logging.getLogger("atlas_rap.skillbus")

HELLO = "hello"
"""What :meth:`Peer.next_event` calls a sequencer's Hello that holds (on the host's side)."""

SKILLS, SEQUENCER, END, BEGIN = 0, 1, 2, 3
"""The phases of a tick at which the sequencer may act (see the module docstring)."""

Position = tuple[int, int]


class Peer:
    """One side's turn-taking over a :class:`Conversation`: numbered, tagged frames out; in-order
    frames in whose tags hold.

    ``secret``: the bus's secret (None: frames are neither tagged nor checked, which only the
    benchmark of what authentication costs asks for). ``key`` is the session's key once the
    handshake made it. ``outbound``: the direction this side sends in.
    """

    outbound = TO_HOST

    def __init__(self, conversation: Conversation, robot: str, secret: Secret | None) -> None:
        self.conversation = conversation
        self.robot = robot
        self.secret = secret
        self.key: bytes | None = None
        self.session = ""
        self.sent = 0
        self.expected = 0
        self.heard = time.monotonic()  # when the other side last sent a frame that held

    @property
    def inbound(self) -> bytes:
        return TO_SEQUENCER if self.outbound == TO_HOST else TO_HOST

    def restart(self, session: str) -> None:
        """A new session: numbering starts again, the key is to be made; what came before is forgotten."""
        self.session = session
        self.sent = 0
        self.expected = 0
        self.key = None

    def send(self, key: str, messages: Iterable[Message], position: Position = (0, 0), *, source: str = "",
             skill: Any = None, nonce: bytes = b"") -> None:
        """Put the next frame of this session on ``key``, tagged (with ``nonce`` beside the tag, if given)."""
        frame = Frame(self.session, self.sent, tuple(messages), position[0], position[1], source, skill)
        self.sent += 1
        payload = frame.to_bytes()
        self.conversation.put(key, payload, self.seal(key, payload, nonce))

    def seal(self, key: str, payload: bytes, nonce: bytes = b"", with_key: bytes | None = None) -> bytes:
        """The attachment of a frame: its tag under the session's key (or ``with_key``), then ``nonce``."""
        if self.secret is None:
            return b""
        return tag(with_key if with_key is not None else self.key, self.outbound, key, payload, nonce) + nonce

    def authentic(self, key: str, payload: bytes, attachment: bytes) -> bool:
        """Whether a frame that came holds under the session's key."""
        if self.secret is None:
            return True
        return self.key is not None and verify(self.key, self.inbound, key, payload, attachment)

    def next_event(self, timeout: float) -> tuple[str, Any] | None:
        """The next frame of this session in turn (``(FRAME, frame)``), a liveliness change
        (``(ALIVE|GONE, key)``), what :meth:`admit` makes of the other frames, or None after
        ``timeout`` seconds; whatever does not hold is dropped."""
        item = self.conversation.receive(timeout)
        while item is not None:
            kind, value = item
            if kind != FRAME:
                return kind, value
            event = self.admit(*value)
            if event is not None:
                return event
            item = self.conversation.receive(0)
        return None

    def admit(self, key: str, payload: bytes, attachment: bytes) -> tuple[str, Any] | None:
        """What a frame that came means: ``(FRAME, frame)`` when it holds and is this session's
        next; None when it is dropped. Sides with frames of their own (Hello, Welcome, beats)
        look at those first."""
        if not self.authentic(key, payload, attachment):
            self.conversation.drops("a frame that fails authentication", key)
            return None
        return self.take(key, payload)

    def take(self, key: str, payload: bytes) -> tuple[str, Any] | None:
        """A frame whose tag held: ``(FRAME, frame)`` when it decodes and is this session's next."""
        frame = self.decode(key, payload)
        if frame is None or not self.accept(key, frame):
            return None
        self.heard = time.monotonic()
        return FRAME, frame

    def decode(self, key: str, payload: bytes) -> Frame | None:
        """The frame ``payload`` holds; None (and logged) when it holds none."""
        try:
            frame = decode(payload, max_bytes=self.conversation.max_message)
        except DecodeError as exc:
            self.conversation.drops("a message that cannot be decoded", key, str(exc))
            return None
        if type(frame) is not Frame:
            self.conversation.drops(f"a {frame.TYPE} message that came outside a frame", key)
            return None
        return frame

    def accept(self, key: str, frame: Frame) -> bool:
        """Whether ``frame`` is this session's next; a frame from elsewhere is logged and dropped."""
        if frame.session != self.session:
            self.conversation.drops("a frame of another session", key)
            return False
        if frame.seq != self.expected:
            self.conversation.drops("a frame out of turn (a replay?)", key,
                                    f"frame {frame.seq} where {self.expected} was expected")
            return False
        self.expected += 1
        return True


__all__ = ["ALIVE", "BEGIN", "END", "FRAME", "GONE", "HELLO", "Peer", "Position", "SEQUENCER", "SKILLS"]
