"""The skill host's side of the bus: what its skills and layers see of a sequencer far away.

:class:`HostSession` is one session with one sequencer (``atlas run
--connect``), over the turns of :mod:`atlas_rap.skillbus.protocol`. To the
host's skill manager and layer stack it *is* the sequencer (the
:class:`~atlas_rap.skillbus.skill_link.SkillHost` they were written
against): its ``memory`` is a copy of the sequencer's, brought up to date
by every frame the sequencer sends; ``change`` sends a batch of facts and
waits while the sequencer applies it (serving the enables and disables
that come meanwhile); ``trace.emit`` sends the record along with the next
frame; ``rules.fired`` are the sequencer's firings. The host's executive
calls ``timers.fire_due`` at each skills tick, ``advance_to`` at each
sequencer tick and ``settle`` when a run starts: here those are the points
where the host stops when the sequencer asked it to, hands the turn over
and waits for the next tick.

A host speaks of its robot as ``robot``, as the stock skills do; on the
bus its facts say the robot's name (``--robot alice``: ``(at alice
office)``), and facts about ``alice`` coming back say ``robot`` again.
"""

from __future__ import annotations

from collections import deque
from types import SimpleNamespace
from typing import Any, Callable, Iterable

from atlas_rap.logic import Compound, Memory, Term
from atlas_rap.skillbus import keys
from atlas_rap.skillbus.messages import (Ack, Disable, Done, Enable, FactAsserted, FactRetracted, Frame, Hello,
                                         Message, Note, RuleFired, Tick, Welcome, changes_to_messages)
from atlas_rap.skillbus.protocol import BEGIN, END, GONE, HELLO, SEQUENCER, SKILLS, Peer, Position, log
from atlas_rap.skillbus.zenoh_bus import Conversation


class SessionEnded(Exception):
    """The sequencer of the session went away (or a new one took over)."""


class _Timers:
    """The host's stand-in for the sequencer's timers: ``fire_due`` is the skills-tick stop point."""

    def __init__(self, session: HostSession) -> None:
        self._session = session
        self.now = 0.0

    def fire_due(self, now: float, *, late: bool = True) -> int:
        self.now = max(self.now, now)
        self._session.reach(SKILLS)
        return 0


class _Trace:
    def __init__(self, session: HostSession) -> None:
        self._session = session
        self.active = True

    def emit(self, event: str, **fields: Any) -> None:
        self._session.notes.append(Note(self._session.timers.now, event, fields))


class HostSession(Peer):
    """One session of a skill host with a sequencer; see the module docstring.

    ``ticks`` says which tick the host's clock is at; the host's executive
    drives physics and skills and calls the stop points.
    """

    def __init__(self, conversation: Conversation, robot: str, session: str, tick: int,
                 ticks: Callable[[], int]) -> None:
        super().__init__(conversation, robot)
        self.restart(session)
        self.expected = 1  # the Hello was frame 0
        self.memory = Memory()
        self.rules = SimpleNamespace(fired=deque(maxlen=16))
        self.timers = _Timers(self)
        self.trace = _Trace(self)
        self.notes: list[Note] = []
        self.manager: Any = None
        self._ticks = ticks
        self.position: Position = (tick, END)
        self.target: Position = (tick, END)
        self.token = keys.sequencer_token(robot, session)
        self.rename = robot != keys.DEFAULT_ROBOT

    # -- what skills and layers call (the sequencer's interface) ------------------------

    def now(self) -> float:
        return self.timers.now

    def live_roots(self) -> list:
        return []

    def advance_to(self, now: float) -> None:
        self.timers.now = max(self.timers.now, now)
        self.reach(SEQUENCER)

    def settle(self) -> None:
        self.reach(BEGIN)

    def change(self, changes: Iterable[tuple[str, Compound]], source: str = "", *,
               skill: Compound | None = None) -> list:
        """Send a batch of changes and wait while the sequencer applies them (serving it meanwhile)."""
        changes = [(kind, self._out(fact)) for kind, fact in changes]
        messages = changes_to_messages(changes)
        key = keys.event(self.robot, "done" if any(type(m) is Done for m in messages) else "facts")
        notes, self.notes = self.notes, []
        self.send(key, [*notes, *messages], self.position, source=source, skill=skill)
        reply = self.wait(Ack)
        ack = reply.last
        self.target = max((ack.tick, ack.phase), self.position)  # type: ignore[union-attr]
        return changes

    # -- the clock ------------------------------------------------------------------------

    def reach(self, phase: int) -> None:
        """The host's executive is at ``phase`` of the current tick: stop here if asked to."""
        point = (self._ticks(), phase)
        self.position = point
        while point >= self.target:
            notes, self.notes = self.notes, []
            self.send(keys.clock(self.robot, "ack"), [*notes, Ack(*point)], point)
            tick = self.wait(Tick).last
            self.target = (tick.tick, tick.phase)  # type: ignore[union-attr]

    def first_tick(self) -> None:
        """Wait for the sequencer's first tick (serving it meanwhile)."""
        tick = self.wait(Tick).last
        self.target = (tick.tick, tick.phase)  # type: ignore[union-attr]

    # -- turns ------------------------------------------------------------------------------

    def wait(self, answer: type[Message]) -> Frame:
        """Serve the sequencer until it sends a frame ending with ``answer``; that frame.

        There is no timeout: the sequencer may think for long (the planner), and
        its going is seen through its liveliness token (:class:`SessionEnded`).
        """
        while True:
            event = self.next_event(0.5)
            if event is None:
                continue
            kind, value = event
            if kind == GONE and value == self.token:
                raise SessionEnded("the sequencer went away")
            if kind == HELLO:
                self._busy(value)
                continue
            if not isinstance(value, Frame):
                continue
            self._mirror(value)
            last = value.last
            if type(last) is answer:
                return value
            if type(last) in (Enable, Disable):
                self._command(last)  # type: ignore[arg-type]
            else:
                log.warning("skill bus: robot %s: dropped a %s frame that came out of turn", self.robot,
                            last.TYPE if last is not None else "empty")

    def _command(self, command: Enable | Disable) -> None:
        error = None
        try:
            if type(command) is Enable:
                self.manager.enable(command.call)
            else:
                self.manager.disable(command.call)
        except Exception as exc:  # an unknown skill, bad arguments: the sequencer fails the step
            error = f"{type(exc).__name__}: {exc}"
        notes, self.notes = self.notes, []
        self.send(keys.clock(self.robot, "ack"), [*notes, Ack(*self.position, error)], self.position)

    def _mirror(self, frame: Frame) -> None:
        """Bring the copy of memory up to date with the sequencer's, from a frame's first messages."""
        memory, now = self.memory, self.timers.now
        for message in frame.messages:
            kind = type(message)
            if kind is FactAsserted:
                memory.assert_fact(self._in(message.fact), now)  # type: ignore[attr-defined]
            elif kind is FactRetracted:
                memory.retract(self._in(message.fact), now)  # type: ignore[attr-defined]
            elif kind is RuleFired:
                rule = SimpleNamespace(name=message.rule, effects=message.effects)  # type: ignore[attr-defined]
                self.rules.fired.append((rule, message.fact))  # type: ignore[attr-defined]

    def _busy(self, hello: Frame) -> None:
        """Another sequencer says hello while this session lasts: tell it the host is busy."""
        other = Peer(self.conversation, self.robot)
        other.restart(hello.session)
        other.send(keys.session(self.robot, "welcome"),
                   [Welcome(self.robot, error="busy: it serves another sequencer's run; wait for that run to end")])

    # -- the robot's name on the bus ----------------------------------------------------------

    def _out(self, fact: Compound) -> Compound:
        return _renamed(fact, keys.DEFAULT_ROBOT, self.robot) if self.rename else fact  # type: ignore[return-value]

    def _in(self, fact: Compound) -> Compound:
        return _renamed(fact, self.robot, keys.DEFAULT_ROBOT) if self.rename else fact  # type: ignore[return-value]


def _renamed(term: Term, old: str, new: str) -> Term:
    if type(term) is str:
        return new if term == old else term
    if type(term) is Compound:
        return Compound(term.functor, tuple(_renamed(arg, old, new) for arg in term.args))
    return term


def await_hello(conversation: Conversation, robot: str, stop: Callable[[], bool]) -> Frame | None:
    """Wait for a sequencer to start a session (None when ``stop()`` says so)."""
    waiting = Peer(conversation, robot)
    waiting.restart("")
    while not stop():
        event = waiting.next_event(0.25)
        if event is not None and event[0] == HELLO:
            hello = event[1]
            if type(hello.last) is Hello and hello.last.robot == robot:
                return hello
    return None


__all__ = ["HostSession", "SessionEnded", "await_hello"]
