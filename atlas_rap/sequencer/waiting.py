"""The wait index: waking a waiting branch only when a fact it could match changes.

A branch blocked on ``(wait-for (at robot ?where))`` registers a
:class:`Waiter`. The index files it under the keys of the facts that could
make its query true: ``(at/2, robot)`` for an assertion of an ``at`` fact
about ``robot``. A change to memory then looks up only the waiters under
that fact's keys, so a thousand branches waiting on other things cost
nothing (no polling, no scan). Keys come from the query:

- a pattern ``(pred a ...)`` in a positive place: woken by assertions of
  ``pred`` facts, under ``(pred, arity, a)`` when ``a`` is bound, else under
  ``(pred, arity)``;
- a pattern under ``not``: woken by retractions of ``pred`` facts (negation
  as failure turns true when a fact goes away);
- ``(get-value OBJ ATTR)`` in a comparison: woken by any change of ``ATTR`` facts;
- a defined relation: woken by every change (its body is not analysed).

A woken waiter's whole query is then evaluated against memory; only if it
holds is the waiter's owner told. A waiter made by :func:`change_waiter`
is told of every change that could concern its queries, true or not (a
failed task waiting for the world to change before it tries again). Candidates are tried in the order the
waiters were registered, so waking is deterministic.
"""

from __future__ import annotations

from itertools import count
from typing import Iterable, Mapping, Protocol, Sequence

from atlas_rap.logic import COMPARISONS, Compound, Relation, Subst, Term, Var, is_ground
from atlas_rap.logic.rules import Change

_LOGIC = frozenset({"and", "or"})
_VALUE_TESTS = frozenset({"=", "/="}) | frozenset(COMPARISONS)
_ANY = object()  # the key part of an unbound first argument

Key = tuple  # (pred, arity, first) or (pred, arity, _ANY)


class WaitOwner(Protocol):
    """Whoever registered a waiter: told when its query holds, or when it cannot be evaluated."""

    def woken(self, waiter: Waiter, answer: Subst) -> None: ...

    def broken(self, waiter: Waiter, message: str) -> None: ...


class Waiter:
    """One registered wait: a query (already substituted), its owner and its index keys."""

    __slots__ = ("query", "owner", "seq", "active", "assert_keys", "retract_keys", "everything", "tag",
                 "any_change")

    def __init__(self, query: Term, owner: WaitOwner, tag: object = None) -> None:
        self.query = query
        self.owner = owner
        self.tag = tag
        self.seq = 0
        self.active = False
        self.assert_keys: list[Key] = []
        self.retract_keys: list[tuple[str, int]] = []
        self.everything = False
        self.any_change = False  # woken by every change its keys match, without asking its query


def change_waiter(queries: Sequence[Term], owner: WaitOwner,
                  relations: Mapping[str, Sequence[Relation]]) -> Waiter:
    """A waiter woken by any assertion or retraction that could change what ``queries`` answer
    (its owner is told with an empty answer); file it with :meth:`WaitIndex.add`."""
    waiter = Waiter(Compound("and", tuple(queries)), owner)
    waiter.any_change = True
    for query in queries:
        _collect_keys(query, True, waiter, relations)
        _collect_keys(query, False, waiter, relations)
    return waiter


class WaitIndex:
    """Waiters filed by the changes that could wake them."""

    def __init__(self, relations: Mapping[str, Sequence[Relation]] | None = None) -> None:
        self.relations = relations if relations is not None else {}
        self._on_assert: dict[Key, dict[Waiter, None]] = {}
        self._on_retract: dict[tuple[str, int], dict[Waiter, None]] = {}
        self._on_everything: dict[Waiter, None] = {}
        self._order = count(1)
        self.size = 0

    def add(self, waiter: Waiter) -> None:
        """File ``waiter`` under the keys of its query (a :func:`change_waiter` has its keys already)."""
        if not waiter.any_change:
            _collect_keys(waiter.query, True, waiter, self.relations)
        waiter.seq = next(self._order)
        waiter.active = True
        for key in waiter.assert_keys:
            self._on_assert.setdefault(key, {})[waiter] = None
        for key in waiter.retract_keys:
            self._on_retract.setdefault(key, {})[waiter] = None
        if waiter.everything:
            self._on_everything[waiter] = None
        self.size += 1

    def remove(self, waiter: Waiter) -> None:
        """Take ``waiter`` out of the index (removing it twice does nothing)."""
        if not waiter.active:
            return
        waiter.active = False
        self.size -= 1
        for key in waiter.assert_keys:
            _discard(self._on_assert, key, waiter)
        for key in waiter.retract_keys:
            _discard(self._on_retract, key, waiter)
        self._on_everything.pop(waiter, None)

    def candidates(self, changes: Iterable[Change]) -> list[Waiter]:
        """The waiters that the changes could wake, in registration order."""
        found: dict[Waiter, None] = {}
        on_assert = self._on_assert
        for kind, fact in changes:
            args = fact.args
            if kind == "assert":
                pred = (fact.functor, len(args))
                if args:
                    bucket = on_assert.get((fact.functor, len(args), args[0]))
                    if bucket:
                        found.update(bucket)
                bucket = on_assert.get(pred + (_ANY,))
            else:
                bucket = self._on_retract.get((fact.functor, len(args)))
            if bucket:
                found.update(bucket)
        if self._on_everything:
            found.update(self._on_everything)
        if len(found) <= 1:
            return list(found)
        return sorted(found, key=_by_seq)


def _by_seq(waiter: Waiter) -> int:
    return waiter.seq


def _discard(index: dict, key: object, waiter: Waiter) -> None:
    bucket = index.get(key)
    if bucket is not None:
        bucket.pop(waiter, None)
        if not bucket:
            del index[key]


def _collect_keys(query: Term, positive: bool, waiter: Waiter, relations: Mapping[str, Sequence[Relation]]) -> None:
    if type(query) is not Compound:
        return
    functor = query.functor
    args = query.args
    if functor in _LOGIC:
        for part in args:
            _collect_keys(part, positive, waiter, relations)
    elif functor == "not":
        for part in args:
            _collect_keys(part, not positive, waiter, relations)
    elif functor in _VALUE_TESTS:
        for part in args:
            _collect_value_keys(part, waiter)
    elif functor in relations:
        waiter.everything = True
    elif functor:
        if positive:
            first = args[0] if args else _ANY
            if type(first) is Var or (type(first) is Compound and not is_ground(first)):
                first = _ANY
            waiter.assert_keys.append((functor, len(args), first))
        else:
            waiter.retract_keys.append((functor, len(args)))


def _collect_value_keys(expr: Term, waiter: Waiter) -> None:
    """``(get-value OBJ ATTR)`` reads ``(ATTR OBJ V)`` facts: any change of them can matter."""
    if type(expr) is not Compound:
        return
    if expr.functor == "get-value" and len(expr.args) == 2 and isinstance(expr.args[1], str):
        attr = expr.args[1]
        waiter.assert_keys.append((attr, 2, _ANY))
        waiter.retract_keys.append((attr, 2))
        return
    for part in expr.args:
        _collect_value_keys(part, waiter)


