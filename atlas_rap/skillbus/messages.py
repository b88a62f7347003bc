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

**Hostile input.** Bytes on a bus may come from anyone, so :func:`decode`
trusts nothing: a message over ``max_bytes`` (default :data:`MAX_MESSAGE`,
1 MiB) or nested deeper than ``max_depth`` (:data:`MAX_DEPTH`) is refused
before it is parsed, and every message is checked against its schema (each
field's type and range, no unknown fields, finite numbers, names that are
symbols), so whatever :func:`decode` returns can be used without another
check. It raises :class:`DecodeError` and nothing else.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any, ClassVar, Iterable

from atlas_rap.errors import SkillBusError
from atlas_rap.logic import Compound, String, Term, Var

VERSION = 1
"""The protocol version every message carries (``"v"``); another version is a :class:`VersionError`."""

MAX_MESSAGE = 1 << 20
"""The largest message :func:`decode` reads by default, in bytes (1 MiB): a whole world's prior map
fits many times over; anything larger is refused before it is parsed."""

MAX_DEPTH = 64
"""The deepest nesting of JSON arrays and objects :func:`decode` reads: a frame of facts about
nested terms is about 8 deep; deeper input is refused before it is parsed."""

PHASES = 4
"""Phases of a tick (``skillbus.protocol``: SKILLS, SEQUENCER, END, BEGIN): a phase is 0-3."""


class DecodeError(SkillBusError):
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
    try:
        text = json.dumps(value) if not isinstance(value, (bytes, bytearray)) else repr(value)
    except (TypeError, ValueError, RecursionError):
        text = repr(type(value))
    return text if len(text) <= 60 else text[:57] + "..."


# -- reading fields against a schema ---------------------------------------------------

_SYMBOL = re.compile(r"^[^\s()\"';]+$")
_SESSION = re.compile(r"^[0-9a-f]{0,32}$")
_MISSING = object()


class _Fields:
    """The fields of one message, read against its schema: each read checks a field's type and
    range; :meth:`end` refuses the fields that no read asked for."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.data = data
        self.read = {"v", "type"}

    def get(self, name: str, kind: type | tuple[type, ...], default: Any = _MISSING) -> Any:
        self.read.add(name)
        if name not in self.data:
            if default is _MISSING:
                raise DecodeError(f"no field {name!r}")
            return default
        value = self.data[name]
        kinds = kind if isinstance(kind, tuple) else (kind,)
        if type(value) not in kinds:
            names = " or ".join(k.__name__ for k in kinds)
            raise DecodeError(f"field {name!r} must be a {names}, not {_short(value)}")
        return value

    def count(self, name: str, default: Any = _MISSING, below: int | None = None) -> int:
        """A whole number >= 0 (and < ``below``)."""
        value = self.get(name, int, default)
        if value < 0 or (below is not None and value >= below):
            raise DecodeError(f"field {name!r} must be a whole number from 0"
                              f"{f' to {below - 1}' if below is not None else ''}, not {value}")
        return value

    def number(self, name: str) -> float:
        """A finite number (int or float)."""
        value = self.get(name, (int, float))
        if not math.isfinite(value):
            raise DecodeError(f"field {name!r} must be a finite number, not {value}")
        return float(value)

    def symbol(self, name: str, default: Any = _MISSING) -> str:
        """A name that is one symbol (a robot, a world, a rule)."""
        value = self.get(name, str, default)
        if value and not _SYMBOL.match(value):
            raise DecodeError(f"field {name!r} must be a symbol, not {_short(value)}")
        return value

    def compound(self, name: str) -> Compound:
        return _compound(self.get(name, (list, str, dict, int, float)), name)

    def end(self) -> None:
        unknown = sorted(set(self.data) - self.read)
        if unknown:
            raise DecodeError(f"unknown field {unknown[0]!r}")


# -- messages ---------------------------------------------------------------------


class Message:
    """One typed message; subclasses are frozen dataclasses with a ``TYPE`` and typed fields."""

    TYPE: ClassVar[str] = ""

    def fields(self) -> dict[str, Any]:
        """The message's fields as JSON values (without ``v`` and ``type``)."""
        raise NotImplementedError

    @classmethod
    def read(cls, data: _Fields) -> Message:
        """The message from its JSON fields, each checked; raises :class:`DecodeError` on a bad one."""
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
    def read(cls, data: _Fields) -> Enable:
        return cls(data.compound("call"))


@dataclass(frozen=True, slots=True)
class Disable(Message):
    """Turn a skill off again; what it has not done is cancelled."""

    TYPE: ClassVar[str] = "disable"
    call: Compound

    def fields(self) -> dict[str, Any]:
        return {"call": encode_term(self.call)}

    @classmethod
    def read(cls, data: _Fields) -> Disable:
        return cls(data.compound("call"))


@dataclass(frozen=True, slots=True)
class Done(Message):
    """A skill finished: the fact ``(done CALL OUTCOME)``, ``outcome`` a keyword such as ``:succeed``."""

    TYPE: ClassVar[str] = "done"
    call: Compound
    outcome: str

    def fields(self) -> dict[str, Any]:
        return {"call": encode_term(self.call), "outcome": self.outcome}

    @classmethod
    def read(cls, data: _Fields) -> Done:
        outcome = data.symbol("outcome")
        if not outcome.startswith(":") or len(outcome) < 2:
            raise DecodeError(f"outcome must be a keyword such as :succeed, not {outcome!r}")
        return cls(data.compound("call"), outcome)

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
    def read(cls, data: _Fields) -> Why:
        return cls(data.compound("call"), data.get("reason", str))

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
    def read(cls, data: _Fields) -> FactAsserted:
        return cls(data.compound("fact"))


@dataclass(frozen=True, slots=True)
class FactRetracted(Message):
    """A fact retracted; see :class:`FactAsserted`."""

    TYPE: ClassVar[str] = "retracted"
    fact: Compound

    def fields(self) -> dict[str, Any]:
        return {"fact": encode_term(self.fact)}

    @classmethod
    def read(cls, data: _Fields) -> FactRetracted:
        return cls(data.compound("fact"))


@dataclass(frozen=True, slots=True)
class Tick(Message):
    """The clock: "advance to t". ``tick`` counts physics steps, ``phase`` is where in that step
    to stop (:data:`~atlas_rap.skillbus.protocol.SKILLS` ... ``BEGIN``), ``t`` the time in seconds."""

    TYPE: ClassVar[str] = "tick"
    tick: int
    phase: int
    t: float

    def fields(self) -> dict[str, Any]:
        return {"tick": self.tick, "phase": self.phase, "t": self.t}

    @classmethod
    def read(cls, data: _Fields) -> Tick:
        return cls(data.count("tick"), data.count("phase", below=PHASES), data.number("t"))


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
    def read(cls, data: _Fields) -> Ack:
        return cls(data.count("tick"), data.count("phase", below=PHASES), data.get("error", str, None))


@dataclass(frozen=True, slots=True)
class Hello(Message):
    """A sequencer starts a session with a host: its robot, and the tick its clock is at."""

    TYPE: ClassVar[str] = "hello"
    robot: str
    tick: int = 0

    def fields(self) -> dict[str, Any]:
        return {"robot": self.robot, "tick": self.tick}

    @classmethod
    def read(cls, data: _Fields) -> Hello:
        return cls(data.symbol("robot"), data.count("tick"))


@dataclass(frozen=True, slots=True)
class Welcome(Message):
    """A host's answer to :class:`Hello`: its world, skills (name → arities), the predicates its
    events assert, the world's prior-map facts, its rates (physics, skills, sequencer Hz),
    or an ``error`` (the host is busy with another sequencer, or refuses this one)."""

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
    def read(cls, data: _Fields) -> Welcome:
        skills = data.get("skills", dict)
        if not all(_SYMBOL.match(name) and type(a) is list and all(type(n) is int and 0 <= n < 256 for n in a)
                   for name, a in skills.items()):
            raise DecodeError("skills must map skill names to lists of arities (whole numbers)")
        produces = data.get("produces", list)
        rates = data.get("rates", list)
        if not all(type(p) is str and _SYMBOL.match(p) for p in produces):
            raise DecodeError("produces must be a list of predicate names")
        if len(rates) != 3 or not all(type(r) in (int, float) and math.isfinite(r) and r > 0 for r in rates):
            raise DecodeError("rates must be three positive numbers")
        return cls(data.symbol("robot"), data.get("world", str), {name: tuple(a) for name, a in skills.items()},
                   tuple(produces), tuple(_compound(f, "a prior fact") for f in data.get("prior", list)),
                   (float(rates[0]), float(rates[1]), float(rates[2])), data.get("error", str, None))


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
    def read(cls, data: _Fields) -> RuleFired:
        effects = data.get("effects", list)
        if not all(type(e) is list and len(e) == 2 and e[0] in ("assert", "retract") for e in effects):
            raise DecodeError("effects must be [kind, term] pairs")
        return cls(data.symbol("rule"), tuple((e[0], decode_term(e[1])) for e in effects), data.compound("fact"))


_NOTE_FIELD = re.compile(r"^[a-z_][a-z0-9_]*$")


@dataclass(frozen=True, slots=True)
class Note(Message):
    """A trace record made on the host (the layers' ``layer-switched``) at time ``t``: ``data`` are
    its fields, named as Python names other than ``t`` and ``event``."""

    TYPE: ClassVar[str] = "note"
    t: float
    event: str
    data: dict[str, Any] = field(default_factory=dict)

    def fields(self) -> dict[str, Any]:
        return {"t": self.t, "event": self.event, "data": self.data}

    @classmethod
    def read(cls, data: _Fields) -> Note:
        fields = data.get("data", dict)
        bad = next((name for name in fields if not _NOTE_FIELD.match(name) or name in ("t", "event")), None)
        if bad is not None:
            raise DecodeError(f"a note's field is named as a Python name other than t and event, not {bad!r}")
        return cls(data.number("t"), data.symbol("event"), fields)


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
    def read(cls, data: _Fields) -> Frame:
        messages = tuple(_message(m) for m in data.get("messages", list))
        if any(type(m) is Frame for m in messages):
            raise DecodeError("a frame cannot hold a frame")
        session = data.get("session", str)
        if not _SESSION.match(session):
            raise DecodeError(f"a session is named by up to 32 hex digits, not {_short(session)}")
        skill = data.get("skill", (list, str, dict, int, float), None)
        return cls(session, data.count("seq"), messages, data.count("tick"), data.count("phase", below=PHASES),
                   data.get("source", str, ""), None if skill is None else _compound(skill, "skill"))

    @property
    def last(self) -> Message | None:
        return self.messages[-1] if self.messages else None


MESSAGES[Frame.TYPE] = Frame


def decode(data: bytes | bytearray | memoryview | str, *, max_bytes: int = MAX_MESSAGE,
           max_depth: int = MAX_DEPTH) -> Message:
    """The message that ``data`` (UTF-8 JSON) holds, checked against its schema.

    Refuses, before parsing, more than ``max_bytes`` bytes or arrays and objects
    nested deeper than ``max_depth``. Raises :class:`VersionError` for another
    protocol version and :class:`DecodeError` for anything else that is not a
    message; never another exception.
    """
    try:
        raw = data.encode() if isinstance(data, str) else bytes(data)
    except UnicodeEncodeError:
        raise DecodeError("not a skill-bus message (not UTF-8 text)") from None
    if len(raw) > max_bytes:
        raise DecodeError(f"a message of {len(raw)} bytes: more than the {max_bytes} the bus takes")
    if raw.count(b"[") + raw.count(b"{") > max_depth:  # else it cannot nest deeper: not scanned
        depth = nesting_depth(raw)
        if depth > max_depth:
            raise DecodeError(f"a message nested {depth} deep: deeper than the {max_depth} the bus takes")
    try:
        obj = json.loads(raw.decode())
    except (UnicodeDecodeError, ValueError) as exc:
        raise DecodeError(f"not a skill-bus message (not UTF-8 JSON: {exc})") from None
    except RecursionError:  # a max_depth too deep for this interpreter's stack
        raise DecodeError("a message nested too deep to read") from None
    try:
        return _message(obj)
    except RecursionError:
        raise DecodeError("a message nested too deep to read") from None


_QUOTED = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")


def nesting_depth(data: bytes) -> int:
    """How deep JSON arrays and objects nest in ``data`` (brackets inside strings do not count):
    a scan in C and numpy, a few milliseconds for a megabyte."""
    brackets = _QUOTED.sub(b"", data).translate(None, _NOT_BRACKETS)
    if not brackets:
        return 0
    import numpy as np

    steps = np.frombuffer(brackets, dtype=np.uint8)
    opens = (steps == ord("[")) | (steps == ord("{"))
    return int(np.cumsum(np.where(opens, 1, -1), dtype=np.int64).max())


def _message(obj: Any) -> Message:
    if type(obj) is not dict:
        raise DecodeError(f"a skill-bus message is a JSON object, not {_short(obj)}")
    version = obj.get("v")
    if version != VERSION or type(version) is not int:
        raise VersionError(f"skill-bus protocol version {_short(version)} where {VERSION} was expected: "
                           f"run the same atlas-rap on the sequencer and the skill host")
    kind = obj.get("type")
    cls = MESSAGES.get(kind) if type(kind) is str else None
    if cls is None:
        raise DecodeError(f"unknown skill-bus message type {_short(kind)}")
    try:
        fields = _Fields(obj)
        message = cls.read(fields)
        fields.end()
        return message
    except DecodeError as exc:
        raise DecodeError(f"bad {kind} message: {exc}") from None
    except (TypeError, ValueError, KeyError) as exc:
        raise DecodeError(f"bad {kind} message: {exc}") from None


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
