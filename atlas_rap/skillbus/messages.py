"""The typed messages of the skill bus, and the one serialisation every bus backend uses.

Each message is a frozen dataclass with a ``TYPE`` name and
:meth:`Message.to_bytes` / :func:`decode` (``Message.from_bytes``). The
serialisation is **JSON**, version :data:`VERSION`, one object per message::

    {"v": 1, "type": "done", "call": ["navigate-to", "office"], "outcome": ":succeed"}

Terms are written as a **compact JSON structure**, not as text, so a
message is decoded without the RAP reader: a symbol or keyword is a JSON
string, a number a JSON number, a compound ``(f a b)`` the array
``["f", a, b]`` (a list with no functor: ``["", a, b]``), a string literal
``{"str": "text"}`` and a variable ``{"var": "name"}``. Any JSON library
reads it, so any Zenoh client can watch a robot's events.

The messages (what they mean is :mod:`atlas_rap.skillbus.remote`'s protocol):

- sequencer → host: :class:`Enable`, :class:`Disable` a skill call;
  :class:`Tick` "advance to t" (a tick and a phase of it); :class:`Ack` the
  host's changes; :class:`Hello` to start a session; and, before any of
  these, what changed in memory since the last frame
  (:class:`FactAsserted`, :class:`FactRetracted`, :class:`RuleFired`), so
  the host's copy of memory is the sequencer's;
- host → sequencer: :class:`Done` and :class:`Why` (a skill finished, and
  why), :class:`FactAsserted` / :class:`FactRetracted` (events),
  :class:`Note` (a trace record the host's layers made), :class:`Ack`
  (reached the tick, or did what was asked) and :class:`Welcome`.

Messages travel in a :class:`Frame`: the unit put on the bus, numbered per
sender, with the session it belongs to and, for a batch of changes, who made
them. Anything that cannot be decoded raises :class:`DecodeError` (a
:class:`VersionError` when it is from another version of the protocol);
backends log such a message and drop it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Iterable

from atlas_rap.errors import AtlasError
from atlas_rap.logic import Compound, String, Term, Var

VERSION = 1
"""The protocol version every message carries (``"v"``); another version is a :class:`VersionError`."""


class DecodeError(AtlasError):
    """A message on the bus that cannot be decoded: not JSON, an unknown type, a bad field."""


class VersionError(DecodeError):
    """A message from another version of the skill-bus protocol."""


# -- terms ------------------------------------------------------------------------


def encode_term(term: Term) -> Any:
    """A term as the compact JSON structure of the module docstring."""
    kind = type(term)
    if kind is str:
        return term
    if kind is Compound:
        return [term.functor, *(encode_term(arg) for arg in term.args)]  # type: ignore[union-attr]
    if kind is int or kind is float:
        if kind is float and not math.isfinite(term):  # type: ignore[arg-type]
            return {"float": repr(term)}
        return term
    if kind is String:
        return {"str": term.value}  # type: ignore[union-attr]
    if kind is Var:
        return {"var": term.name}  # type: ignore[union-attr]
    raise TypeError(f"not a term: {term!r}")


def decode_term(value: Any) -> Term:
    """The term a compact JSON structure stands for; :class:`DecodeError` if it stands for none."""
    kind = type(value)
    if kind is str:
        if not value:
            raise DecodeError("an empty symbol is not a term")
        return value
    if kind is list:
        if not value or type(value[0]) is not str:
            raise DecodeError(f"a compound term is [functor, arg, ...] with a symbol first, not {_short(value)}")
        return Compound(value[0], tuple(decode_term(arg) for arg in value[1:]))
    if kind is int or kind is float:
        return value
    if kind is dict and len(value) == 1:
        (key, inner), = value.items()
        if type(inner) is str:
            if key == "str":
                return String(inner)
            if key == "var" and inner:
                return Var(inner)
            if key == "float" and inner in ("inf", "-inf", "nan"):
                return float(inner)
    raise DecodeError(f"not a term: {_short(value)}")


def _compound(value: Any, what: str) -> Compound:
    term = decode_term(value)
    if type(term) is not Compound or not term.functor:
        raise DecodeError(f"{what} must be a compound term (name arg ...), not {_short(value)}")
    return term


def _short(value: Any) -> str:
    text = json.dumps(value) if not isinstance(value, (bytes, bytearray)) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# -- messages ---------------------------------------------------------------------


class Message:
    """One typed message; subclasses are frozen dataclasses with a ``TYPE`` and typed fields."""

    TYPE: ClassVar[str] = ""

    def fields(self) -> dict[str, Any]:
        """The message's fields as JSON values (without ``v`` and ``type``)."""
        raise NotImplementedError

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Message:
        """The message from its JSON fields; raises :class:`DecodeError` on a bad field."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        return {"v": VERSION, "type": self.TYPE, **self.fields()}

    def to_bytes(self) -> bytes:
        """The message as UTF-8 JSON (the wire format of every backend)."""
        return json.dumps(self.to_dict(), separators=(",", ":")).encode()

    @staticmethod
    def from_bytes(data: bytes | bytearray | memoryview | str) -> Message:
        """The message ``data`` holds; see :func:`decode`."""
        return decode(data)


@dataclass(frozen=True, slots=True)
class Enable(Message):
    """Turn a skill on: ``call`` is the skill's name and ground arguments, ``(navigate-to office)``."""

    TYPE: ClassVar[str] = "enable"
    call: Compound

    def fields(self) -> dict[str, Any]:
        return {"call": encode_term(self.call)}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Enable:
        return cls(_compound(_field(data, "call"), "call"))


@dataclass(frozen=True, slots=True)
class Disable(Message):
    """Turn a skill off again; what it has not done is cancelled."""

    TYPE: ClassVar[str] = "disable"
    call: Compound

    def fields(self) -> dict[str, Any]:
        return {"call": encode_term(self.call)}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Disable:
        return cls(_compound(_field(data, "call"), "call"))


@dataclass(frozen=True, slots=True)
class Done(Message):
    """A skill finished: the fact ``(done CALL OUTCOME)``, ``outcome`` a keyword such as ``:succeed``."""

    TYPE: ClassVar[str] = "done"
    call: Compound
    outcome: str

    def fields(self) -> dict[str, Any]:
        return {"call": encode_term(self.call), "outcome": self.outcome}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Done:
        outcome = _field(data, "outcome", str)
        if not outcome.startswith(":"):
            raise DecodeError(f"outcome must be a keyword such as :succeed, not {outcome!r}")
        return cls(_compound(_field(data, "call"), "call"), outcome)

    def fact(self) -> Compound:
        return Compound("done", (self.call, self.outcome))


@dataclass(frozen=True, slots=True)
class Why(Message):
    """Why a skill finished as it did: the fact ``(why CALL "reason")``."""

    TYPE: ClassVar[str] = "why"
    call: Compound
    reason: str

    def fields(self) -> dict[str, Any]:
        return {"call": encode_term(self.call), "reason": self.reason}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Why:
        return cls(_compound(_field(data, "call"), "call"), _field(data, "reason", str))

    def fact(self) -> Compound:
        return Compound("why", (self.call, String(self.reason)))


@dataclass(frozen=True, slots=True)
class FactAsserted(Message):
    """A fact asserted (by a host's skills or layers; or, towards a host, in the sequencer's memory)."""

    TYPE: ClassVar[str] = "asserted"
    fact: Compound

    def fields(self) -> dict[str, Any]:
        return {"fact": encode_term(self.fact)}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> FactAsserted:
        return cls(_compound(_field(data, "fact"), "fact"))


@dataclass(frozen=True, slots=True)
class FactRetracted(Message):
    """A fact retracted; see :class:`FactAsserted`."""

    TYPE: ClassVar[str] = "retracted"
    fact: Compound

    def fields(self) -> dict[str, Any]:
        return {"fact": encode_term(self.fact)}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> FactRetracted:
        return cls(_compound(_field(data, "fact"), "fact"))


@dataclass(frozen=True, slots=True)
class Tick(Message):
    """The clock: "advance to t". ``tick`` counts physics steps, ``phase`` is where in that step
    to stop (:data:`~atlas_rap.skillbus.remote.SKILLS` ... ``BEGIN``), ``t`` the time in seconds."""

    TYPE: ClassVar[str] = "tick"
    tick: int
    phase: int
    t: float

    def fields(self) -> dict[str, Any]:
        return {"tick": self.tick, "phase": self.phase, "t": self.t}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Tick:
        return cls(_field(data, "tick", int), _field(data, "phase", int), _number(data, "t"))


@dataclass(frozen=True, slots=True)
class Ack(Message):
    """Done what was asked: a host reached ``tick``/``phase`` (or did an enable or disable), or
    the sequencer took a host's changes (then ``tick``/``phase`` is where the host is to stop
    now). ``error`` says what went wrong, if anything did."""

    TYPE: ClassVar[str] = "ack"
    tick: int
    phase: int
    error: str | None = None

    def fields(self) -> dict[str, Any]:
        return {"tick": self.tick, "phase": self.phase, **({"error": self.error} if self.error else {})}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Ack:
        error = data.get("error")
        if error is not None and type(error) is not str:
            raise DecodeError("error must be a string")
        return cls(_field(data, "tick", int), _field(data, "phase", int), error)


@dataclass(frozen=True, slots=True)
class Hello(Message):
    """A sequencer starts a session with a host: its robot, and the tick its clock is at."""

    TYPE: ClassVar[str] = "hello"
    robot: str
    tick: int = 0

    def fields(self) -> dict[str, Any]:
        return {"robot": self.robot, "tick": self.tick}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Hello:
        return cls(_field(data, "robot", str), _field(data, "tick", int))


@dataclass(frozen=True, slots=True)
class Welcome(Message):
    """A host's answer to :class:`Hello`: its world, skills (name → arities), the predicates its
    events assert, the world's prior-map facts, its rates (physics, skills, sequencer Hz),
    or an ``error`` (the host is busy with another sequencer)."""

    TYPE: ClassVar[str] = "welcome"
    robot: str
    world: str = ""
    skills: dict[str, tuple[int, ...]] = field(default_factory=dict)
    produces: tuple[str, ...] = ()
    prior: tuple[Compound, ...] = ()
    rates: tuple[float, float, float] = (100.0, 20.0, 10.0)
    error: str | None = None

    def fields(self) -> dict[str, Any]:
        return {"robot": self.robot, "world": self.world,
                "skills": {name: list(arities) for name, arities in self.skills.items()},
                "produces": list(self.produces), "prior": [encode_term(f) for f in self.prior],
                "rates": list(self.rates), **({"error": self.error} if self.error else {})}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Welcome:
        skills = _field(data, "skills", dict)
        if not all(type(a) is list and all(type(n) is int for n in a) for a in skills.values()):
            raise DecodeError("skills must map names to lists of arities")
        produces = _field(data, "produces", list)
        rates = _field(data, "rates", list)
        if not all(type(p) is str for p in produces):
            raise DecodeError("produces must be a list of predicate names")
        if len(rates) != 3 or not all(type(r) in (int, float) and r > 0 for r in rates):
            raise DecodeError("rates must be three positive numbers")
        error = data.get("error")
        if error is not None and type(error) is not str:
            raise DecodeError("error must be a string")
        return cls(_field(data, "robot", str), _field(data, "world", str),
                   {name: tuple(a) for name, a in skills.items()}, tuple(produces),
                   tuple(_compound(f, "a prior fact") for f in _field(data, "prior", list)),
                   (float(rates[0]), float(rates[1]), float(rates[2])), error)


@dataclass(frozen=True, slots=True)
class RuleFired(Message):
    """A memory rule fired on the sequencer (its name, its effects, the fact that fired it):
    the host's layers say which rule chose the primary layer."""

    TYPE: ClassVar[str] = "rule-fired"
    rule: str
    effects: tuple[tuple[str, Term], ...]
    fact: Compound

    def fields(self) -> dict[str, Any]:
        return {"rule": self.rule, "effects": [[kind, encode_term(t)] for kind, t in self.effects],
                "fact": encode_term(self.fact)}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> RuleFired:
        effects = _field(data, "effects", list)
        if not all(type(e) is list and len(e) == 2 and e[0] in ("assert", "retract") for e in effects):
            raise DecodeError("effects must be [kind, term] pairs")
        return cls(_field(data, "rule", str), tuple((e[0], decode_term(e[1])) for e in effects),
                   _compound(_field(data, "fact"), "fact"))


@dataclass(frozen=True, slots=True)
class Note(Message):
    """A trace record made on the host (the layers' ``layer-switched``) at time ``t``."""

    TYPE: ClassVar[str] = "note"
    t: float
    event: str
    data: dict[str, Any] = field(default_factory=dict)

    def fields(self) -> dict[str, Any]:
        return {"t": self.t, "event": self.event, "data": self.data}

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Note:
        return cls(_number(data, "t"), _field(data, "event", str), _field(data, "data", dict))


MESSAGES: dict[str, type[Message]] = {cls.TYPE: cls for cls in (
    Enable, Disable, Done, Why, FactAsserted, FactRetracted, Tick, Ack, Hello, Welcome, RuleFired, Note)}


@dataclass(frozen=True, slots=True)
class Frame(Message):
    """What is put on the bus: messages in order, numbered ``seq`` per sender within ``session``.

    ``tick``/``phase`` is where the sender's clock is. A batch of changes says
    who made them (``source``, as the trace's ``by``) and, for a skill's
    finish, the skill call (``skill``).
    """

    TYPE: ClassVar[str] = "frame"
    session: str
    seq: int
    messages: tuple[Message, ...]
    tick: int = 0
    phase: int = 0
    source: str = ""
    skill: Compound | None = None

    def fields(self) -> dict[str, Any]:
        data: dict[str, Any] = {"session": self.session, "seq": self.seq, "tick": self.tick, "phase": self.phase,
                                "messages": [m.to_dict() for m in self.messages]}
        if self.source:
            data["source"] = self.source
        if self.skill is not None:
            data["skill"] = encode_term(self.skill)
        return data

    @classmethod
    def from_fields(cls, data: dict[str, Any]) -> Frame:
        messages = tuple(_message(m) for m in _field(data, "messages", list))
        if any(type(m) is Frame for m in messages):
            raise DecodeError("a frame cannot hold a frame")
        skill = data.get("skill")
        source = data.get("source", "")
        if type(source) is not str:
            raise DecodeError("source must be a string")
        return cls(_field(data, "session", str), _field(data, "seq", int), messages, _field(data, "tick", int),
                   _field(data, "phase", int), source, None if skill is None else _compound(skill, "skill"))

    @property
    def last(self) -> Message | None:
        return self.messages[-1] if self.messages else None


MESSAGES[Frame.TYPE] = Frame


def decode(data: bytes | bytearray | memoryview | str) -> Message:
    """The message that ``data`` (UTF-8 JSON) holds.

    Raises :class:`VersionError` for another protocol version and
    :class:`DecodeError` for anything else that is not a message.
    """
    try:
        text = data if isinstance(data, str) else bytes(data).decode()
        obj = json.loads(text)
    except (UnicodeDecodeError, ValueError) as exc:
        raise DecodeError(f"not a skill-bus message (not UTF-8 JSON: {exc})") from None
    return _message(obj)


def _message(obj: Any) -> Message:
    if type(obj) is not dict:
        raise DecodeError(f"a skill-bus message is a JSON object, not {_short(obj)}")
    version = obj.get("v")
    if version != VERSION:
        raise VersionError(f"skill-bus protocol version {version!r} where {VERSION} was expected: "
                           f"run the same atlas-rap on the sequencer and the skill host")
    kind = obj.get("type")
    cls = MESSAGES.get(kind) if type(kind) is str else None
    if cls is None:
        raise DecodeError(f"unknown skill-bus message type {kind!r}")
    try:
        return cls.from_fields(obj)
    except DecodeError as exc:
        raise DecodeError(f"bad {kind} message: {exc}") from None
    except (TypeError, ValueError, KeyError) as exc:
        raise DecodeError(f"bad {kind} message: {exc}") from None


def _field(data: dict[str, Any], name: str, kind: type | None = None) -> Any:
    if name not in data:
        raise DecodeError(f"no field {name!r}")
    value = data[name]
    if kind is not None and (type(value) is not kind):
        raise DecodeError(f"field {name!r} must be a {kind.__name__}, not {_short(value)}")
    return value


def _number(data: dict[str, Any], name: str) -> float:
    value = _field(data, name)
    if type(value) not in (int, float):
        raise DecodeError(f"field {name!r} must be a number, not {_short(value)}")
    return float(value)


def changes_to_messages(changes: Iterable[tuple[str, Compound]]) -> tuple[Message, ...]:
    """Memory changes as messages: ``done`` and ``why`` facts as :class:`Done` and :class:`Why`."""
    out: list[Message] = []
    for kind, fact in changes:
        args = fact.args
        if kind == "assert" and len(args) == 2 and type(args[0]) is Compound and args[0].functor:
            if fact.functor == "done" and type(args[1]) is str and args[1].startswith(":"):
                out.append(Done(args[0], args[1]))
                continue
            if fact.functor == "why" and type(args[1]) is String:
                out.append(Why(args[0], args[1].value))
                continue
        out.append(FactAsserted(fact) if kind == "assert" else FactRetracted(fact))
    return tuple(out)


def message_change(message: Message) -> tuple[str, Compound] | None:
    """The memory change a message stands for (None for messages that change no fact)."""
    kind = type(message)
    if kind is FactAsserted:
        return "assert", message.fact  # type: ignore[attr-defined]
    if kind is FactRetracted:
        return "retract", message.fact  # type: ignore[attr-defined]
    if kind is Done or kind is Why:
        return "assert", message.fact()  # type: ignore[attr-defined]
    return None
