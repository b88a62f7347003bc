"""Terms: the values that facts, queries, tasks and operators are made of.

A term is one of

- a **symbol**: a plain ``str``, lower case (``'robot'``, ``'office-3'``);
  keywords are symbols starting with ``':'`` (``':succeed'``); ``'t'`` is
  true and ``'nil'`` is false and the empty list;
- a **number**: an ``int`` or a ``float`` (never a ``bool``);
- a :class:`String`: text in double quotes, distinct from symbols;
- a :class:`Var`: a logic variable (``?x`` is ``Var('x')``);
- a :class:`Compound`: ``(functor arg ...)``, e.g. ``(at robot lab)`` is
  ``Compound('at', ('robot', 'lab'))``. A list whose first element is not a
  symbol has the functor ``''``: ``(1 2 3)`` is ``Compound('', (1, 2, 3))``.

All terms are immutable and hashable, so facts can be set and dict keys.
A substitution (:data:`Subst`) is a plain ``dict`` from variables to terms;
:func:`walk` and :func:`substitute` apply one.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any, Iterable, TypeAlias, final


@dataclass(frozen=True, slots=True)
class String:
    """A string literal (``"Robbie"``): text that keeps its case.

    ``String('a') != 'a'``: a string is never equal to the symbol ``a``.
    """

    value: str

    def __str__(self) -> str:
        return term_to_str(self)


@final
@dataclass(frozen=True, slots=True)
class Var:
    """A logic variable; ``name`` is written without the ``?``.

    Two variables are the same variable when their names are equal. The
    anonymous variable ``?`` is read as a fresh variable from
    :func:`fresh_var`, so each ``?`` is a different variable.
    """

    name: str
    _hash: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_hash", hash(self.name) ^ 0x5BD1E995)

    # Hand-written, with the hash cached: variables are the keys of every
    # substitution, and the dataclass versions build tuples on every call.
    def __eq__(self, other: object) -> bool:
        return type(other) is Var and self.name == other.name  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self) -> tuple[type, tuple[str]]:
        # The cached hash of a str differs between processes: recompute it.
        return (Var, (self.name,))

    def __str__(self) -> str:
        return term_to_str(self)


@final
class Compound:
    """An immutable term ``(functor arg ...)``: a fact, a query, a task.

    ``functor`` is a symbol, or ``''`` for a plain list whose first element
    is not a symbol (``(?p a)`` is ``Compound('', (Var('p'), 'a'))``).
    The hash and whether the term is ground are computed once, at
    construction, because facts are dict keys millions of times.
    Use :meth:`of` to build one from arguments: ``Compound.of('at', 'robot', 'lab')``.
    """

    __slots__ = ("functor", "args", "_hash", "_ground")

    functor: str
    args: tuple[Term, ...]
    _hash: int
    _ground: bool

    def __init__(self, functor: str, args: Iterable[Term] = ()) -> None:
        if type(args) is not tuple:
            args = tuple(args)
        ground = True
        for arg in args:
            kind = type(arg)
            if kind is Var or (kind is Compound and not arg._ground):  # type: ignore[union-attr]
                ground = False
                break
        _set_functor(self, functor)
        _set_args(self, args)
        _set_hash(self, hash((functor, args)))
        _set_ground(self, ground)

    @classmethod
    def of(cls, functor: str, *args: Term) -> Compound:
        """Build ``(functor arg ...)`` from its arguments, for code and tests."""
        return cls(functor, args)

    @property
    def arity(self) -> int:
        """The number of arguments."""
        return len(self.args)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"Compound is immutable (cannot set {name!r})")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"Compound is immutable (cannot delete {name!r})")

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if type(other) is not Compound:
            return NotImplemented
        return (
            self._hash == other._hash  # type: ignore[attr-defined]
            and self.functor == other.functor  # type: ignore[attr-defined]
            and self.args == other.args  # type: ignore[attr-defined]
        )

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self) -> tuple[type, tuple[str, tuple[Term, ...]]]:
        return (Compound, (self.functor, self.args))

    def __repr__(self) -> str:
        return f"Compound({self.functor!r}, {self.args!r})"

    def __str__(self) -> str:
        return term_to_str(self)


# Slot setters, so that __init__ can fill an object whose __setattr__ refuses.
_set_functor = Compound.functor.__set__  # type: ignore[attr-defined]
_set_args = Compound.args.__set__  # type: ignore[attr-defined]
_set_hash = Compound._hash.__set__  # type: ignore[attr-defined]
_set_ground = Compound._ground.__set__  # type: ignore[attr-defined]

Term: TypeAlias = str | int | float | String | Var | Compound
"""Any term: symbol, number, :class:`String`, :class:`Var` or :class:`Compound`."""

Subst: TypeAlias = dict[Var, Term]
"""A substitution: a plain dict from variables to the terms they are bound to.

Bindings may chain (``?x -> ?y -> 3``); :func:`walk` follows a chain and
:func:`substitute` applies a substitution to a whole term. Functions that
take a substitution never mutate it; they return a new dict.
"""


# Variable names a user can write start with a letter or a digit and are
# lower case (the reader folds case). Generated names start with "_" (the
# reader's anonymous "?" is Var("_1"), Var("_2")... numbered per file) or
# contain an upper-case letter, so they never collide with a user's.
_fresh_numbers = itertools.count(1)


def fresh_var(base: str = "") -> Var:
    """A new variable that no user can write and no other call returns.

    Without ``base`` it is anonymous (``Var('_G7')``, see
    :func:`is_anonymous`); with ``base`` (e.g. ``'agent'``) it is a renamed
    copy of ``?agent`` (``Var('agent_R8')``), for renaming a clause apart.
    Names come from one counter per process: deterministic for a given
    sequence of calls, so a seeded run is reproducible.
    """
    number = next(_fresh_numbers)
    if base:
        return Var(f"{base}_R{number}")
    return Var(f"_G{number}")


def is_anonymous(var: Var) -> bool:
    """True for an anonymous variable: the reader's ``?`` or a bare ``fresh_var()``.

    Anonymous variables print as ``?``; their names start with ``_``,
    which no variable a user writes can.
    """
    return var.name.startswith("_")


def is_symbol(term: object) -> bool:
    """True for a symbol (keywords, ``t`` and ``nil`` included)."""
    return type(term) is str


def is_keyword(term: object) -> bool:
    """True for a keyword symbol such as ``:succeed``."""
    return type(term) is str and term.startswith(":")  # type: ignore[union-attr]


def is_number(term: object) -> bool:
    """True for an ``int`` or ``float`` term (a ``bool`` is not a number)."""
    kind = type(term)
    return kind is int or kind is float


def is_ground(term: Term) -> bool:
    """True when the term contains no variables (constant time for compounds)."""
    kind = type(term)
    if kind is Var:
        return False
    if kind is Compound:
        return term._ground  # type: ignore[union-attr]
    return True


def variables(term: Term) -> list[Var]:
    """The variables of a term, in order of first appearance, each once."""
    found: dict[Var, None] = {}
    _collect_variables(term, found)
    return list(found)


def _collect_variables(term: Term, found: dict[Var, None]) -> None:
    kind = type(term)
    if kind is Var:
        found[term] = None  # type: ignore[index]
    elif kind is Compound and not term._ground:  # type: ignore[union-attr]
        for arg in term.args:  # type: ignore[union-attr]
            _collect_variables(arg, found)


_UNBOUND: Any = object()


def walk(term: Term, subst: Subst) -> Term:
    """Follow variable bindings until a non-variable or an unbound variable.

    Only the top of the term is resolved (``?x -> (f ?y)`` gives ``(f ?y)``);
    use :func:`substitute` to resolve a whole term.
    """
    while type(term) is Var:
        bound = subst.get(term, _UNBOUND)  # type: ignore[arg-type]
        if bound is _UNBOUND:
            return term
        term = bound
    return term


def substitute(term: Term, subst: Subst) -> Term:
    """The term with every bound variable replaced, chains resolved fully.

    Unbound variables stay as they are. Ground subterms are shared, not
    copied, so applying a substitution to a fact costs nothing.
    """
    kind = type(term)
    if kind is Var:
        bound = subst.get(term, _UNBOUND)  # type: ignore[arg-type]
        if bound is _UNBOUND:
            return term
        return substitute(bound, subst)
    if kind is Compound and not term._ground and subst:  # type: ignore[union-attr]
        new_args = []
        changed = False
        for arg in term.args:  # type: ignore[union-attr]
            new = substitute(arg, subst)
            changed = changed or new is not arg
            new_args.append(new)
        return Compound(term.functor, tuple(new_args)) if changed else term  # type: ignore[union-attr]
    return term


def _escape(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


def term_to_str(term: Term) -> str:
    """The term as s-expression text that the reader reads back to the same term.

    Symbols and keywords print as they are, strings in double quotes with
    ``\\`` and ``"`` escaped, variables as ``?name`` (anonymous ones as
    ``?``), floats with ``repr`` so they round-trip, compounds as
    ``(functor arg ...)`` (functor ``''`` as ``(arg ...)``).
    """
    kind = type(term)
    if kind is str:
        return term  # type: ignore[return-value]
    if kind is Compound:
        parts = [term_to_str(arg) for arg in term.args]  # type: ignore[union-attr]
        if term.functor:  # type: ignore[union-attr]
            parts.insert(0, term.functor)  # type: ignore[union-attr]
        return "(" + " ".join(parts) + ")"
    if kind is Var:
        return "?" if is_anonymous(term) else "?" + term.name  # type: ignore[union-attr, arg-type]
    if kind is int:
        return str(term)
    if kind is float:
        return repr(term)
    if kind is String:
        return '"' + _escape(term.value) + '"'  # type: ignore[union-attr]
    raise TypeError(f"not a term: {term!r}")
