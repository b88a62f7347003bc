"""The sequencer's side of skills on other hosts: a skill link over the Zenoh bus.

:class:`RemoteSkills` is a :class:`~atlas_rap.skillbus.skill_link.SkillLink`
for one or more robots, each served by a skill host (``atlas skills serve``)
reached over Zenoh; :class:`HostLink` is the conversation with one host
(the turns of :mod:`atlas_rap.skillbus.protocol`). Time is driven from this
side by ``layers.remote.RemoteExecutive``, which ticks the hosts.

**One robot** (the default, named ``robot``): the host's skills are offered
as they are, ``(navigate-to office)``, so a mission runs unchanged and its
trace is the same, byte for byte, as in one process.

**Several robots** (``--robot alice --robot bob``): every skill takes the
robot's name first, ``(navigate-to alice office)``, and goes to that
robot's host; each host says ``alice`` (not ``robot``) in its facts.

**Who may.** Each robot's secret is read at every handshake
(:func:`~atlas_rap.skillbus.auth.sequencer_secrets`); the handshake makes the
session's key, every frame is tagged under it, and the host's frames that do
not hold are dropped (:mod:`~atlas_rap.skillbus.auth`). While a session
lasts, a thread beats to the host every :data:`BEAT` seconds, so a sequencer
that thinks for long (the planner) keeps its lease.

**Faults.** A host whose liveliness token goes (it died, was killed, or
its link lease of one second ran out), or that does not answer within
``reply_timeout`` seconds, is *lost*: every step waiting on one of its
skills ends the usual way, ``(why CALL "skill host lost")`` and ``(done CALL
:fail)``, so RAPs recover through their methods. A skill enabled while its
host is lost (a retry) *waits* for the host to come back, for up to
``host_grace`` simulated seconds since the loss (while no host runs,
simulated time follows the wall clock): when its token comes back, the
sequencer starts a new session with it (a fresh world on the host, at the
sequencer's time) and the waiting skills are enabled there; when the grace
runs out, they fail with ``skill host lost (not back within N s)``. The
trace shows the wait (``skill-waiting``). No wait on the bus is without a
timeout.

Over 25 KB on purpose: the sequencer's side of the bus: the fleet, each host's link and the
lock-step protocol they share.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any

from atlas_rap.logic import Compound, String, term_to_str
from atlas_rap.skillbus import keys
from atlas_rap.skillbus.auth import NONCE, TAG, SecretSource, TokenError, new_nonce, sequencer_secrets, session_key, \
    verify
from atlas_rap.skillbus.messages import (MAX_MESSAGE, Ack, DecodeError, Disable, Enable, FactAsserted, FactRetracted,
                                         Frame, Hello, Message, Note, RuleFired, Tick, Welcome, decode, message_change)
from atlas_rap.skillbus.protocol import ALIVE, END, GONE, HELLO, Peer, Position, log
from atlas_rap.skillbus.skill_link import SkillHost
from atlas_rap.skillbus.zenoh_bus import BusError, Conversation, close_session, open_session
from atlas_rap.trace_events import Event

HOST_LOST = "skill host lost"
"""The reason a step gets when the host running its skill is lost."""

CONNECT_TIMEOUT = 3.0
"""Seconds to wait for a robot's skill host to show itself and answer when a run starts."""

REPLY_TIMEOUT = 10.0
"""Seconds a host may take to answer (a stride of physics and skills) before it counts as lost."""

HOST_GRACE = 30.0
"""Simulated seconds a skill enabled while its host is lost waits for the host to come back
(``atlas run --host-grace``)."""

BEAT = 1.0
"""Seconds between a link's beats to its host while a session lasts (the host's lease is longer)."""


def robot_first(skills: dict[str, set[int]]) -> dict[str, set[int]]:
    """The arities of ``skills`` when every call takes the robot's name first, as they do
    with several robots on the bus: ``(navigate-to alice office)``."""
    return {name: {n + 1 for n in arities} for name, arities in skills.items()}


class HostLost(Exception):
    """The host of a robot was lost while the sequencer waited for it."""


class HostAbsent(BusError):
    """No skill host of the robot shows itself, or none answers the Hello."""


class HostLink(Peer):
    """The sequencer's conversation with one robot's skill host.

    ``secret``: where the robot's secret is read at each handshake (None: frames are
    not authenticated, which only the benchmark of what that costs asks for).
    """

    def __init__(self, fleet: RemoteSkills, session: Any, robot: str, secret: SecretSource | None) -> None:
        super().__init__(Conversation(session, keys.to_sequencer(robot), keys.host_token(robot),
                                      max_message=fleet.max_message, robot=robot), robot, None)
        self.secret_source = secret
        self.fleet = fleet
        self.alive = False
        self.lost: str | None = None  # why it was lost, until the fleet has failed its skills
        self.lost_at: float | None = None  # when (simulated seconds), until a new session starts
        self.welcome: Welcome | None = None
        self.enabled: dict[Compound, Compound] = {}  # call on the host -> call on the sequencer
        self.waiting: dict[Compound, Compound] = {}  # enabled while the host was lost, in order
        self.position: Position = (0, END)
        self.target: Position | None = None
        self.mirror: list[Message] = []
        self.welcome_key = keys.session(robot, "welcome")
        self.beat_key = keys.sequencer(robot, "beat")
        self.beating: tuple[str, bytes | None] | None = None  # (session, key) while the link beats
        self.beats = 0
        self.refusal: str | None = None
        self.handshaking = False
        self._nonce = b""
        self._fired: tuple[Any, Any] = (None, None)  # the rule engine and the last firing sent

    # -- sessions --------------------------------------------------------------------

    def handshake(self, tick: int, timeout: float) -> Welcome:
        """Start a session with the host (it builds a fresh world at ``tick``); its Welcome.

        Raises :class:`BusError` when no host shows itself or answers within ``timeout``.
        """
        if not self.conversation.peer_alive.wait(timeout):
            raise HostAbsent(f"no skill host for robot {self.robot!r} answers (waited {timeout:g} s)")
        try:
            self.secret = self.secret_source() if self.secret_source is not None else None
        except TokenError as exc:
            raise BusError(str(exc)) from None
        self.beating = None
        self.conversation.drain()
        self.restart(uuid.uuid4().hex[:12])
        self._nonce = new_nonce() if self.secret is not None else b""
        self.refusal = None
        self.conversation.declare_token(keys.sequencer_token(self.robot, self.session))
        self.alive = True
        self.mirror = []
        self.handshaking = True
        try:
            reply = self.exchange(keys.sequencer(self.robot, "hello"), [Hello(self.robot, tick)], timeout=timeout,
                                  nonce=self._nonce)
        except HostLost:
            if self.refusal is not None:
                source = self.secret.source if self.secret is not None else "nowhere"
                raise BusError(f"the skill host of robot {self.robot!r} {self.refusal} (this sequencer's token: "
                               f"{source})") from None
            raise HostAbsent(f"the skill host of robot {self.robot!r} did not answer (waited {timeout:g} s)") from None
        finally:
            self.handshaking = False
        welcome = reply.last
        if type(welcome) is not Welcome:
            self.alive = False
            raise BusError(f"the skill host of robot {self.robot!r} answered out of turn")
        if welcome.error:
            self.alive = False
            raise BusError(f"the skill host of robot {self.robot!r}: {welcome.error}")
        self.welcome = welcome
        self.position = (tick, END)
        self.lost = None
        self.lost_at = None
        self.enabled.clear()
        self.beating = (self.session, self.key)
        host = self.fleet.host
        self.mirror = [FactAsserted(fact) for fact in host.memory] if host is not None else []
        self._fired = (None, None)
        return welcome

    def lose(self, reason: str) -> None:
        """The host is gone: no more turns; the fleet fails its running skills at the next safe point."""
        if self.alive:
            self.alive = False
            self.beating = None
            self.lost = reason
            if self.lost_at is None:  # a failed try to start a new session does not move it
                self.lost_at = self.fleet.now()
            self.conversation.declare_token(None)
            if not self.handshaking:  # a handshake says itself why it failed
                log.warning("skill bus: robot %s: %s", self.robot, reason)

    def poll(self) -> None:
        """Between turns: notice the host going (or coming back); anything else is stale."""
        while True:
            event = self.next_event(0)
            if event is None:
                return
            if self._host_gone(event):
                self.lose(HOST_LOST)

    def _host_gone(self, event: tuple[str, Any]) -> bool:
        """Whether ``event`` says the host's token went (Zenoh counts copies: a stranger's copy of
        the token going is not seen)."""
        return event[0] == GONE and event[1] == keys.host_token(self.robot)

    def beat(self) -> None:
        """Tell the host this sequencer is still here (from the beating thread; between turns too)."""
        beating = self.beating
        if beating is None:
            return
        session, key = beating
        payload = Frame(session, self.beats, ()).to_bytes()
        self.beats += 1
        try:
            self.conversation.put(self.beat_key, payload, self.seal(self.beat_key, payload, with_key=key))
        except Exception as exc:  # the session is closing
            log.debug("skill bus: a beat could not be sent: %s", exc)

    def seal(self, key: str, payload: bytes, nonce: bytes = b"", with_key: bytes | None = None) -> bytes:
        """Before the session has a key (the Hello), a frame is tagged under the secret itself."""
        if with_key is None and self.key is None and self.secret is not None:
            with_key = self.secret.key
        return super().seal(key, payload, nonce, with_key)

    def admit(self, key: str, payload: bytes, attachment: bytes) -> tuple[str, Any] | None:
        """The Welcome makes the session's key (with the host's nonce); a refusal is remembered."""
        if key == self.welcome_key and self.key is None and self.secret is not None:
            nonce = attachment[TAG:]
            if len(nonce) == NONCE:
                candidate = session_key(self.secret, self.session, self._nonce, nonce)
                if verify(candidate, self.inbound, key, payload, attachment, nonce=True):
                    self.key = candidate
                    return self.take(key, payload)
            self._refused(key, payload)
            return None
        return super().admit(key, payload, attachment)

    def _refused(self, key: str, payload: bytes) -> None:
        """A Welcome that does not hold: dropped, but a refusal of this session's Hello is kept to say
        why if no Welcome that holds comes (it is only a hint: anyone can send one)."""
        try:
            frame = decode(payload, max_bytes=self.conversation.max_message)
        except DecodeError:
            frame = None
        if type(frame) is Frame and frame.session == self.session and type(frame.last) is Welcome \
                and frame.last.error:
            self.refusal = frame.last.error
        else:
            self.conversation.drops("a Welcome that fails authentication", key)

    @property
    def returned(self) -> bool:
        """A lost host whose token is back: a new session can start."""
        return not self.alive and self.lost is None and self.conversation.peer_alive.is_set()

    # -- turns -------------------------------------------------------------------------

    def exchange(self, key: str, messages: Sequence[Message], *, timeout: float | None = None,
                 nonce: bytes = b"") -> Frame:
        """Send a frame (memory's changes first; ``nonce`` beside its tag) and serve the host until
        it answers; its answer.

        Raises :class:`HostLost` when the host goes or takes longer than ``timeout``
        (default: the fleet's reply timeout) to answer.
        """
        if not self.alive:
            raise HostLost(self.lost or HOST_LOST)
        self.send(key, self._outgoing(messages), self.position, nonce=nonce)
        limit = self.fleet.reply_timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                self.lose(f"{HOST_LOST} (no answer within {limit:g} s)")
                raise HostLost(HOST_LOST)
            event = self.next_event(min(left, 0.25))
            if not self.alive:
                raise HostLost(HOST_LOST)
            if event is None:
                continue
            kind, value = event
            if kind == GONE:
                if self._host_gone(event):
                    self.lose(HOST_LOST)
                    raise HostLost(HOST_LOST)
                continue
            if kind in (ALIVE, HELLO):
                continue
            last = value.last
            if type(last) in (Ack, Welcome):
                self._notes(value)
                return value
            self._serve(value)
            deadline = time.monotonic() + limit

    def tick_to(self, target: Position) -> Position:
        """Let the host run to ``target`` (or sooner, if its changes made the sequencer need to act
        sooner); where it stopped."""
        self.target = target
        try:
            reply = self.exchange(keys.clock(self.robot, "tick"),
                                  [Tick(target[0], target[1], target[0] / self.fleet.rates[0])])
        finally:
            self.target = None
        ack = reply.last
        self.position = (ack.tick, ack.phase)  # type: ignore[union-attr]
        return self.position

    def enable(self, host_call: Compound, call: Compound) -> None:
        if not self.alive:
            self.waiting.pop(host_call, None)
            self.waiting[host_call] = call
            self.fleet.trace(Event.SKILL_WAITING, skill=term_to_str(call), robot=self.robot,
                             reason=f"{HOST_LOST}: waiting up to {self.fleet.host_grace:g} s for it to come back")
            return
        self.enabled.pop(host_call, None)
        self.enabled[host_call] = call
        try:
            reply = self.exchange(keys.skill(self.robot, host_call.functor, "enable"), [Enable(host_call)])
        except HostLost:
            self.enabled.pop(host_call, None)
            self.fleet.fail_call(call, HOST_LOST)
            return
        error = reply.last.error  # type: ignore[union-attr]
        if error:
            self.enabled.pop(host_call, None)
            self.fleet.fail_call(call, f"the skill host could not enable it: {error}")

    def disable(self, host_call: Compound) -> None:
        self.enabled.pop(host_call, None)
        self.waiting.pop(host_call, None)
        if not self.alive:
            return
        try:
            self.exchange(keys.skill(self.robot, host_call.functor, "disable"), [Disable(host_call)])
        except HostLost:
            pass

    def fail_running(self) -> None:
        """The host was lost: every skill it ran ends ``:fail`` with the reason, as a host would say it."""
        reason, self.lost = self.lost or HOST_LOST, None
        running, self.enabled = list(self.enabled.values()), {}
        for call in running:
            self.fleet.fail_call(call, reason)

    def give_up_waiting(self, now: float) -> None:
        """The skills waiting for the lost host fail once the grace has run out."""
        if not self.waiting or self.alive or self.lost_at is None or now - self.lost_at < self.fleet.host_grace:
            return
        waiting, self.waiting = list(self.waiting.values()), {}
        for call in waiting:
            self.fleet.fail_call(call, f"{HOST_LOST} (not back within {self.fleet.host_grace:g} s)")

    def resume_waiting(self) -> None:
        """A new session with the host that came back: the skills that waited for it are enabled."""
        waiting, self.waiting = list(self.waiting.items()), {}
        for host_call, call in waiting:
            self.fleet.trace(Event.SKILL_RESUMED, skill=term_to_str(call), robot=self.robot,
                             reason="its skill host is back")
            self.enable(host_call, call)

    # -- serving the host's changes ------------------------------------------------------

    def _serve(self, frame: Frame) -> None:
        """A batch of changes from the host: apply it as in one process, then hand the turn back."""
        host = self.fleet.host
        self.position = (frame.tick, frame.phase)
        self._notes(frame)  # made on the host before these changes, at their own times
        self.fleet.clock_to(self.position)
        changes = []
        for message in frame.messages:
            change = message_change(message)
            if change is not None:
                changes.append(self._to_sequencer(change))
        skill = self.enabled.get(frame.skill, frame.skill) if frame.skill is not None else None
        source = f"skill {term_to_str(skill)}" if skill is not None else frame.source
        if changes and host is not None:
            host.change(changes, source, skill=skill)
        where = self.fleet.horizon(self.position)
        if self.target is not None:
            where = min(where, self.target)
        if self.alive:
            self.send(keys.sequencer(self.robot, "ack"), self._outgoing([Ack(*where)]), self.position)

    def _to_sequencer(self, change: tuple[str, Compound]) -> tuple[str, Compound]:
        """A host's change as the sequencer says it: a finished skill is named by the sequencer's call."""
        kind, fact = change
        if fact.functor in ("done", "why") and len(fact.args) == 2 and fact.args[0] in self.enabled:
            fact = Compound(fact.functor, (self.enabled[fact.args[0]], fact.args[1]))  # type: ignore[index]
        return kind, fact

    def _notes(self, frame: Frame) -> None:
        host = self.fleet.host
        for message in frame.messages:
            if type(message) is Note and host is not None:
                self.fleet.note(message)

    def _outgoing(self, messages: Sequence[Message]) -> list[Message]:
        """Memory's changes and the rules fired since the last frame, then ``messages``."""
        out, self.mirror = self.mirror, []
        host = self.fleet.host
        rules = getattr(host, "rules", None)
        if rules is not None:
            engine, last = self._fired
            fired = list(rules.fired)
            if engine is rules:
                for index in range(len(fired) - 1, -1, -1):
                    if fired[index] is last:
                        fired = fired[index + 1:]
                        break
            if fired:
                self._fired = (rules, fired[-1])
                out += [RuleFired(rule.name, tuple(rule.effects), fact) for rule, fact in fired]
            else:
                self._fired = (rules, last)
        out += messages
        return out


@dataclass(frozen=True)
class BusSettings:
    """What a sequencer's side of the bus is asked for (``atlas run --connect`` and its options).

    ``endpoints``: where to connect (``tcp/127.0.0.1:7447``); ``robots``: the robots
    whose hosts to use; ``token_files``: token files of robots whose secret is not
    in the default place (:func:`~atlas_rap.skillbus.auth.sequencer_secrets`);
    ``zenoh_config``: Zenoh's own configuration file (TLS, ACL); ``host_grace``:
    simulated seconds a skill waits for its lost host; ``max_message``: the largest
    message taken, in bytes; ``authenticate`` False leaves frames untagged, which
    only the benchmark of what authentication costs asks for (the hosts must not
    authenticate either).
    """

    endpoints: tuple[str, ...]
    robots: tuple[str, ...] = (keys.DEFAULT_ROBOT,)
    token_files: tuple[str, ...] = ()
    zenoh_config: str | None = None
    host_grace: float = HOST_GRACE
    max_message: int = MAX_MESSAGE
    authenticate: bool = True


class RemoteSkills:
    """The skills of one or more robots' skill hosts over Zenoh, as one skill link (module docstring)."""

    def __init__(self, settings: BusSettings, *, connect_timeout: float = CONNECT_TIMEOUT,
                 reply_timeout: float = REPLY_TIMEOUT) -> None:
        if not settings.endpoints:
            raise BusError("give the endpoint of a skill host to connect to, e.g. --connect tcp/127.0.0.1:7447")
        robots = list(dict.fromkeys(settings.robots or (keys.DEFAULT_ROBOT,)))
        for robot in robots:
            try:
                keys.check_robot(robot)
            except ValueError as exc:
                raise BusError(str(exc)) from None
        try:
            secrets = sequencer_secrets(robots, settings.token_files) if settings.authenticate else {}
        except TokenError as exc:
            raise BusError(str(exc)) from None
        self.endpoints = list(settings.endpoints)
        self.reply_timeout = reply_timeout
        self.host_grace = settings.host_grace
        self.max_message = settings.max_message
        self.host: SkillHost | None = None
        self.multi = len(robots) > 1
        self.horizon: Callable[[Position], Position] = lambda position: position
        self.clock_to: Callable[[Position], None] = lambda position: None
        self.session = open_session(connect=self.endpoints, config_file=settings.zenoh_config,
                                    max_message=settings.max_message)
        self.links: dict[str, HostLink] = {}
        self._stop_beating = threading.Event()
        try:
            for robot in robots:
                self.links[robot] = HostLink(self, self.session, robot, secrets.get(robot))
            for link in self.links.values():
                try:
                    link.handshake(0, connect_timeout)
                except HostAbsent as exc:
                    raise BusError(f"{exc} at {', '.join(self.endpoints)}: start it there with "
                                   f"atlas skills serve --robot {link.robot} --listen {self.endpoints[0]}") from None
            rates = {link.welcome.rates for link in self.links.values()}  # type: ignore[union-attr]
            worlds = {link.welcome.world for link in self.links.values()}  # type: ignore[union-attr]
            if len(rates) > 1:
                raise BusError("the skill hosts run at different rates; run them alike")
        except BaseException:
            self.close()
            raise
        self.rates: tuple[float, float, float] = rates.pop()
        self.world = sorted(worlds)[0]
        threading.Thread(target=self._beat, name="atlas-bus-beat", daemon=True).start()

    def _beat(self) -> None:
        """Every :data:`BEAT` seconds, each link beats to its host (the hosts' leases)."""
        while not self._stop_beating.wait(BEAT):
            for link in list(self.links.values()):
                link.beat()

    def now(self) -> float:
        """The sequencer's simulated time."""
        return self.host.timers.now if self.host is not None else 0.0

    # -- the skill link ------------------------------------------------------------------

    def connect(self, host: SkillHost) -> None:
        self.host = host
        host.memory.subscribe(self._memory_changed)
        for link in self.links.values():
            link.mirror = [FactAsserted(fact) for fact in host.memory]

    def _memory_changed(self, kind: str, fact: Compound, time: float) -> None:
        message = FactAsserted(fact) if kind == "assert" else FactRetracted(fact)
        for link in self.links.values():
            if link.alive:
                link.mirror.append(message)

    def skills(self) -> dict[str, set[int]]:
        names: dict[str, set[int]] = {}
        for link in self.links.values():
            for name, arities in link.welcome.skills.items():  # type: ignore[union-attr]
                names.setdefault(name, set()).update(arities)
        return robot_first(names) if self.multi else names

    def produces(self) -> set[str]:
        found = {"done", "why"}
        for link in self.links.values():
            found.update(link.welcome.produces)  # type: ignore[union-attr]
        return found

    def instance(self, call: Compound) -> Hashable:
        """A skill is one instance per robot whatever its arguments, as on a host in process."""
        if self.multi and call.args:
            return (call.args[0], call.functor)
        return call.functor

    def _route(self, call: Compound) -> tuple[HostLink | None, Compound]:
        if not self.multi:
            return next(iter(self.links.values())), call
        robot = call.args[0] if call.args else None
        return self.links.get(robot) if isinstance(robot, str) else None, Compound(call.functor, call.args[1:])

    def enable(self, call: Compound) -> None:
        link, host_call = self._route(call)
        if link is None:
            self.fail_call(call, f"no robot {term_to_str(call.args[0]) if call.args else ''} on the skill bus "
                                 f"(the robots are {', '.join(self.links)})")
            return
        link.enable(host_call, call)

    def disable(self, call: Compound) -> None:
        link, host_call = self._route(call)
        if link is not None:
            link.disable(host_call)

    # -- what the sequencer side needs besides ----------------------------------------------

    def prior_facts(self) -> list[Compound]:
        """The prior-map facts the hosts' worlds give (each once, in order)."""
        facts: dict[Compound, None] = {}
        for link in self.links.values():
            facts.update(dict.fromkeys(link.welcome.prior))  # type: ignore[union-attr]
        return list(facts)

    def fail_call(self, call: Compound, reason: str) -> None:
        """End the skill ``call`` as a host would: ``(why CALL "reason")``, ``(done CALL :fail)``."""
        if self.host is not None:
            self.host.change([("assert", Compound("why", (call, String(reason)))),
                              ("assert", Compound("done", (call, ":fail")))], f"skill {term_to_str(call)}", skill=call)

    def note(self, note: Note) -> None:
        """A trace record made on a host, traced here at its time."""
        self.clock_to_time(note.t)
        self.trace(note.event, **note.data)

    def trace(self, event: str, **fields: Any) -> None:
        """A record in the sequencer's trace, now."""
        trace = getattr(self.host, "trace", None)
        if trace is not None:
            trace.emit(event, **fields)

    def clock_to_time(self, t: float) -> None:
        host = self.host
        if host is not None and t > host.timers.now:
            host.timers.fire_due(t, late=False)

    def alive(self) -> list[HostLink]:
        return [link for link in self.links.values() if link.alive]

    def close(self) -> None:
        """Leave the bus: the hosts see this sequencer go and wait for the next."""
        self._stop_beating.set()
        for link in self.links.values():
            link.beating = None
            link.conversation.declare_token(None)
            link.conversation.close()
        close_session(self.session)
