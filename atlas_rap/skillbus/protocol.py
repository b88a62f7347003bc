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

Each side numbers the frames it sends; a frame out of turn or of another
session is logged and dropped.
"""

from __future__ import annotations

import logging
from typing import Any, Iterable

from atlas_rap.skillbus.messages import Frame, Hello, Message
from atlas_rap.skillbus.zenoh_bus import ALIVE, FRAME, GONE, Conversation

log = logging.getLogger("atlas_rap.skillbus")

HELLO = "hello"
"""What :meth:`Peer.next_event` calls a Hello frame of another session (someone starting one)."""

SKILLS, SEQUENCER, END, BEGIN = 0, 1, 2, 3
"""The phases of a tick at which the sequencer may act (see the module docstring)."""

Position = tuple[int, int]


class Peer:
    """One side's turn-taking over a :class:`Conversation`: numbered frames out, in-order frames in."""

    def __init__(self, conversation: Conversation, robot: str) -> None:
        self.conversation = conversation
        self.robot = robot
        self.session = ""
        self.sent = 0
        self.expected = 0

    def restart(self, session: str) -> None:
        """A new session: numbering starts again; what came before is forgotten."""
        self.session = session
        self.sent = 0
        self.expected = 0

    def send(self, key: str, messages: Iterable[Message], position: Position = (0, 0), *, source: str = "",
             skill: Any = None) -> None:
        frame = Frame(self.session, self.sent, tuple(messages), position[0], position[1], source, skill)
        self.sent += 1
        self.conversation.put(key, frame)

    def next_event(self, timeout: float) -> tuple[str, Any] | None:
        """The next frame of this session in turn (``(FRAME, frame)``), a liveliness change
        (``(ALIVE|GONE, key)``), a Hello of another session (``(HELLO, frame)``), or None
        after ``timeout`` seconds; other frames are dropped."""
        item = self.conversation.receive(timeout)
        while item is not None:
            kind, value = item
            if kind != FRAME:
                return kind, value
            key, frame = value
            if frame.session != self.session and type(frame.last) is Hello and frame.seq == 0:
                return HELLO, frame
            if self.accept(key, frame):
                return FRAME, frame
            item = self.conversation.receive(0)
        return None

    def accept(self, key: str, frame: Frame) -> bool:
        """Whether ``frame`` is this session's next; a frame from elsewhere is logged and dropped."""
        if frame.session != self.session:
            log.debug("skill bus: dropped a frame of another session on %s", key)
            return False
        if frame.seq != self.expected:
            log.warning("skill bus: dropped frame %d on %s: frame %d was expected", frame.seq, key, self.expected)
            return False
        self.expected += 1
        return True


__all__ = ["ALIVE", "BEGIN", "END", "FRAME", "GONE", "HELLO", "Peer", "Position", "SEQUENCER", "SKILLS"]
