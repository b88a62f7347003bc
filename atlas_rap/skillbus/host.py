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

**Who gets in.** :class:`HostDoor` is where sequencers knock: a Hello whose
tag does not hold under the host's secret is refused (with a hint, at most
once a second) and starts nothing; a Hello seen before (a replay) is
dropped. A session is *established* once the sequencer's first frame after
the Welcome holds; until then a newer Hello that holds takes its place, so
a replayed Hello of an earlier run cannot keep the host. Established, the
session lasts while the sequencer is alive and speaks: a sequencer that
sends nothing that holds for ``lease`` seconds (frames, or the beats its
link sends every second while it thinks) loses the host, so a silent
squatter cannot hold it.
"""

from __future__ import annotations

import time
from collections import OrderedDict, deque
from types import SimpleNamespace
from typing import Any, Callable, Iterable

from atlas_rap.logic import Compound, Memory, Term
from atlas_rap.skillbus import keys
from atlas_rap.skillbus.auth import NONCE, TAG, TO_HOST, TO_SEQUENCER, Secret, new_nonce, session_key, verify
from atlas_rap.skillbus.messages import (Ack, DecodeError, Disable, Done, Enable, FactAsserted, FactRetracted, Frame,
                                         Hello, Message, Note, RuleFired, Tick, Welcome, changes_to_messages, decode)
from atlas_rap.skillbus.protocol import BEGIN, END, FRAME, GONE, HELLO, SEQUENCER, SKILLS, Peer, Position, log
from atlas_rap.skillbus.zenoh_bus import Conversation

LEASE = 10.0
"""Seconds a session lasts with nothing that holds from its sequencer (``atlas skills serve --lease``)."""

REFUSAL = ("refused: this sequencer's token is not the skill host's; use the token file the host printed at "
           "start (on another machine: copy it and pass --token-file FILE), or the host's ATLAS_BUS_TOKEN")
"""What a sequencer whose Hello does not hold is told."""


class SessionEnded(Exception):
    """The sequencer of the session went away, fell silent, or a newer Hello took its place."""


class Superseded(SessionEnded):
    """A Hello that holds came before the session was established: it takes the host."""

    def __init__(self, hello: tuple[Frame, bytes]) -> None:
        super().__init__("a new sequencer took the host before this one's first frame")
        self.hello = hello


class HostDoor:
    """Where sequencers knock (module docstring): checks Hellos, refuses the others, welcomes."""

    SEEN = 4096

    def __init__(self, conversation: Conversation, robot: str, secret: Secret | None) -> None:
        self.conversation = conversation
        self.robot = robot
        self.secret = secret
        self.hello_key = keys.sequencer(robot, "hello")
        self._seen: OrderedDict[bytes, None] = OrderedDict()
        self._refused_at = 0.0

    def admit(self, key: str, payload: bytes, attachment: bytes) -> tuple[Frame, bytes] | None:
        """A Hello that holds and was not seen before, and its nonce; None (logged) otherwise."""
        nonce = attachment[TAG:] if len(attachment) == TAG + NONCE else b""
        if self.secret is not None and not verify(self.secret.key, TO_HOST, key, payload, attachment, nonce=True):
            self.conversation.drops("a Hello that fails authentication (a sequencer without the host's token?)", key)
            self._refuse(key, payload)
            return None
        try:
            frame = decode(payload, max_bytes=self.conversation.max_message)
        except DecodeError as exc:
            self.conversation.drops("a Hello that cannot be decoded", key, str(exc))
            return None
        if type(frame) is not Frame or frame.seq != 0 or type(frame.last) is not Hello:
            self.conversation.drops("a frame on the Hello key that is no Hello", key)
            return None
        if frame.last.robot != self.robot:
            self.conversation.drops(f"a Hello for robot {frame.last.robot!r}", key)
            return None
        if self.secret is not None:
            if nonce in self._seen:
                self.conversation.drops("a Hello seen before (a replay)", key)
                return None
            self._seen[nonce] = None
            if len(self._seen) > self.SEEN:
                self._seen.popitem(last=False)
        return frame, nonce

    def _refuse(self, key: str, payload: bytes) -> None:
        """Tell a sequencer whose Hello does not hold why (untagged: only a hint; once a second at most)."""
        now = time.monotonic()
        if now - self._refused_at < 1.0:
            return
        self._refused_at = now
        try:
            frame = decode(payload, max_bytes=self.conversation.max_message)
        except DecodeError:
            return
        if type(frame) is Frame and type(frame.last) is Hello:
            refusal = Frame(frame.session, 0, (Welcome(self.robot, error=REFUSAL),))
            self.conversation.put(keys.session(self.robot, "welcome"), refusal.to_bytes())

    def welcome(self, peer: Peer, hello: tuple[Frame, bytes], welcome: Welcome, position: Position) -> None:
        """Start ``peer``'s session with the sequencer of ``hello``: make the session's key with a
        fresh nonce of the host's, and send ``welcome`` tagged under it with that nonce."""
        frame, sequencer_nonce = hello
        peer.restart(frame.session)
        peer.expected = 1  # the Hello was frame 0
        nonce = b""
        if self.secret is not None:
            nonce = new_nonce()
            peer.key = session_key(self.secret, frame.session, sequencer_nonce, nonce)
        peer.send(keys.session(self.robot, "welcome"), [welcome], position, nonce=nonce)


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

    ``hello``: the sequencer's Hello and nonce (from :class:`HostDoor`); ``ticks``
    says which tick the host's clock is at; the host's executive drives physics and
    skills and calls the stop points. :meth:`welcome` starts the session.
    """

    outbound = TO_SEQUENCER

    def __init__(self, door: HostDoor, hello: tuple[Frame, bytes], tick: int, ticks: Callable[[], int], *,
                 lease: float = LEASE) -> None:
        super().__init__(door.conversation, door.robot, door.secret)
        robot = door.robot
        self.door = door
        self.hello = hello
        self.session = hello[0].session
        self.lease = lease
        self.established = False  # the sequencer's first frame after the Welcome held
        self.beat_key = keys.sequencer(robot, "beat")
        self.last_beat = -1
        self.memory = Memory()
        self.rules = SimpleNamespace(fired=deque(maxlen=16))
        self.timers = _Timers(self)
        self.trace = _Trace(self)
        self.notes: list[Note] = []
        self.manager: Any = None
        self._ticks = ticks
        self.position: Position = (tick, END)
        self.target: Position = (tick, END)
        self.token = keys.sequencer_token(robot, self.session)
        self.rename = robot != keys.DEFAULT_ROBOT

    def welcome(self, welcome: Welcome) -> None:
        """Start the session: the Welcome, tagged under the session's new key."""
        self.door.welcome(self, self.hello, welcome, self.position)
        self.heard = time.monotonic()

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

        The sequencer may think for long (the planner): its link beats meanwhile. The
        session ends (:class:`SessionEnded`) when its liveliness token goes or nothing
        that holds came from it for ``lease`` seconds.
        """
        while True:
            event = self.next_event(0.5)
            if time.monotonic() - self.heard > self.lease:
                raise SessionEnded(f"the sequencer sent nothing for {self.lease:g} s (its lease ran out)")
            if event is None:
                continue
            kind, value = event
            if kind == GONE and value == self.token:  # (a stranger's copy of the token going is not seen)
                raise SessionEnded("the sequencer went away")
            if kind == HELLO:
                if not self.established:
                    raise Superseded(value)
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
                self.conversation.drops("a frame that came out of turn", keys.sequencer(self.robot, "*"),
                                        last.TYPE if last is not None else "empty")

    def admit(self, key: str, payload: bytes, attachment: bytes) -> tuple[str, Any] | None:
        """Hellos go to the door; beats keep the lease; the rest as any frame."""
        if key == self.door.hello_key:
            hello = self.door.admit(key, payload, attachment)
            return (HELLO, hello) if hello is not None else None
        if key == self.beat_key:
            self._beat(key, payload, attachment)
            return None
        event = super().admit(key, payload, attachment)
        if event is not None:
            self.established = True
        return event

    def _beat(self, key: str, payload: bytes, attachment: bytes) -> None:
        """A beat of the sequencer's link: the lease starts again (if it holds and is newer)."""
        if not self.authentic(key, payload, attachment):
            self.conversation.drops("a beat that fails authentication", key)
            return
        frame = self.decode(key, payload)
        if frame is not None and frame.session == self.session and frame.seq > self.last_beat:
            self.last_beat = frame.seq
            self.heard = time.monotonic()

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

    def _busy(self, hello: tuple[Frame, bytes]) -> None:
        """Another sequencer says hello while this session lasts: tell it the host is busy."""
        other = Peer(self.conversation, self.robot, self.secret)
        other.outbound = TO_SEQUENCER
        self.door.welcome(other, hello, Welcome(self.robot, error="busy: it serves another sequencer's run; wait "
                                                                  "for that run to end"), self.position)

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


def await_hello(door: HostDoor, stop: Callable[[], bool]) -> tuple[Frame, bytes] | None:
    """Wait for a sequencer to start a session: its Hello and nonce (None when ``stop()`` says so).
    Frames on other keys come from no session now and are dropped."""
    while not stop():
        item = door.conversation.receive(0.25)
        if item is None or item[0] != FRAME:
            continue
        key, payload, attachment = item[1]
        if key == door.hello_key:
            hello = door.admit(key, payload, attachment)
            if hello is not None:
                return hello
        else:
            log.debug("skill bus: dropped a frame on %s: no session is open", key)
    return None


__all__ = ["LEASE", "HostDoor", "HostSession", "SessionEnded", "Superseded", "await_hello"]
