"""Memory: the set of ground facts the sequencer and the planner reason over.

A :class:`Memory` holds facts such as ``(at robot office-3)``, each with
the time it was asserted, indexed by predicate (functor and arity) and by
predicate plus first argument, so that ``(at robot ?where)`` looks at the
few ``at`` facts about ``robot`` and nothing else.

Everything is deterministic: iteration and answers follow assertion order,
never hash order. A fact asserted again after a retraction goes to the end.
"""

from __future__ import annotations

from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

from atlas_rap.logic.errors import FactError
from atlas_rap.logic.query import QUERY_FORMS, Relation, evaluate
from atlas_rap.logic.terms import Compound, String, Subst, Term, Var, is_ground, substitute, term_to_str, walk
from atlas_rap.logic.unify import match_into

Listener = Callable[[str, Compound, float], Any]
"""A change listener: ``callback(kind, fact, time)``, kind ``'assert'`` or ``'retract'``."""

_UNBOUND: Any = object()
_NO_ANSWERS: Iterator[Any] = iter(())  # always exhausted, so it can be shared
_EAGER_BUCKET = 8  # buckets up to this size are matched at once, larger ones lazily
_LIST_BUCKET = 32  # first-argument buckets up to this size are lists, larger ones dicts


class Memory:
    """A set of ground facts with assertion times, indexed for fast queries.

    Use :meth:`assert_fact` / :meth:`retract` to change it, :meth:`query`,
    :meth:`ask` and :meth:`holds` to read it (see ``logic.query`` for the
    query language), and :meth:`subscribe` to hear about changes (the
    sequencer wakes waiting tasks that way). Memory rules are not applied
    here; see ``logic.rules.RuleEngine``.
    """

    def __init__(self, facts: Iterable[Compound] = (), time: float = 0.0) -> None:
        self._times: dict[Compound, float] = {}
        self._index: dict[tuple[str, int], _PredicateIndex] = {}
        self._listeners: tuple[Listener, ...] = ()
        self._listeners_by_pred: dict[str, tuple[Listener, ...]] = {}
        for fact in facts:
            self.assert_fact(fact, time)

    # -- changing memory ---------------------------------------------------

    def assert_fact(self, fact: Compound, time: float = 0.0) -> bool:
        """Add a ground fact asserted at ``time``; True if it was not there.

        Asserting a fact that is already there changes nothing (its time
        stays the time it was first asserted) and returns False. Raises
        :class:`FactError` if ``fact`` is not a ground ``(pred arg ...)``.
        """
        if type(fact) is not Compound or not fact._ground or not fact.functor:
            raise FactError(_not_a_fact(fact))
        times = self._times
        if fact in times:
            return False
        times[fact] = time
        args = fact.args
        key = (fact.functor, len(args))
        index = self._index.get(key)
        if index is None:
            index = self._index[key] = _PredicateIndex()
        index.add(fact)
        if self._listeners or self._listeners_by_pred:
            self._notify("assert", fact, time)
        return True

    def retract(self, fact: Compound, time: float = 0.0) -> bool:
        """Remove a fact; True if it was there. ``time`` is passed to listeners."""
        times = self._times
        if type(fact) is not Compound or fact not in times:
            return False
        del times[fact]
        args = fact.args
        key = (fact.functor, len(args))
        index = self._index[key]
        index.remove(fact)
        if not index.facts:
            del self._index[key]
        if self._listeners or self._listeners_by_pred:
            self._notify("retract", fact, time)
        return True

    def retract_matching(self, pattern: Compound, time: float = 0.0) -> list[Compound]:
        """Remove every fact that matches ``pattern``; the removed facts, in memory order."""
        removed = list(self.facts(pattern))
        for fact in removed:
            self.retract(fact, time)
        return removed

    def copy(self) -> Memory:
        """An independent memory with the same facts and times (listeners are not copied)."""
        other = Memory()
        other._times = self._times.copy()
        other._index = {key: index.copy() for key, index in self._index.items()}
        return other

    # -- listening ---------------------------------------------------------

    def subscribe(self, callback: Listener, predicates: Iterable[str] | None = None) -> Callable[[], None]:
        """Call ``callback(kind, fact, time)`` after every change; returns an unsubscribe function.

        With ``predicates``, the callback hears only about facts whose
        functor is one of them (an index, so a listener on ``done`` costs
        nothing when ``at`` facts change). Listeners are called in the
        order they subscribed. With no listeners a change costs one test.
        """
        if predicates is None:
            self._listeners = self._listeners + (callback,)
            names: tuple[str, ...] = ()
        else:
            names = tuple(dict.fromkeys(predicates))
            for name in names:
                self._listeners_by_pred[name] = self._listeners_by_pred.get(name, ()) + (callback,)

        def unsubscribe() -> None:
            if predicates is None:
                self._listeners = _without(self._listeners, callback)
                return
            for name in names:
                remaining = _without(self._listeners_by_pred.get(name, ()), callback)
                if remaining:
                    self._listeners_by_pred[name] = remaining
                else:
                    self._listeners_by_pred.pop(name, None)

        return unsubscribe

    def _notify(self, kind: str, fact: Compound, time: float) -> None:
        for callback in self._listeners:
            callback(kind, fact, time)
        for callback in self._listeners_by_pred.get(fact.functor, ()):
            callback(kind, fact, time)

    # -- reading memory ----------------------------------------------------

    def __contains__(self, fact: object) -> bool:
        return fact in self._times

    def __len__(self) -> int:
        return len(self._times)

    def __iter__(self) -> Iterator[Compound]:
        """The facts in assertion order (a snapshot: changing memory while iterating is safe)."""
        return iter(tuple(self._times))

    def items(self) -> Iterator[tuple[Compound, float]]:
        """``(fact, time asserted)`` pairs in assertion order (a snapshot)."""
        return iter(tuple(self._times.items()))

    def time_of(self, fact: Compound) -> float | None:
        """When the fact was asserted, or None if it is not in memory."""
        return self._times.get(fact)

    def __repr__(self) -> str:
        return f"<Memory of {len(self._times)} facts>"

    def facts(self, pattern: Compound | None = None) -> Iterator[Compound]:
        """The facts that match ``pattern`` (all facts if None), in memory order."""
        if pattern is None:
            return iter(self)
        bucket, start = self._candidates(pattern, None)
        if not bucket:
            return _NO_ANSWERS
        return _matching_facts(pattern.args, start, tuple(bucket))

    def matches(self, pattern: Compound, subst: Subst | None = None) -> Iterator[Subst]:
        """The answers of one pattern ``(pred arg ...)`` under ``subst``, in memory order.

        The fast path behind :meth:`query`: it goes straight to the index
        bucket of (predicate, first argument) when the first argument is
        bound, else to the predicate's bucket, and matches one-sidedly.
        The candidates are taken when this is called: changing memory
        while consuming the answers is safe and does not change them.
        """
        # _candidates, inlined: this is the hottest path of the sequencer.
        args = pattern.args
        index = self._index.get((pattern.functor, len(args)))
        if index is None:
            return _NO_ANSWERS
        bucket = index.facts
        start = 0
        if args:
            first = args[0]
            kind = type(first)
            if kind is Var and subst:
                first = walk(first, subst)
                kind = type(first)
            elif kind is Compound and subst and not first._ground:  # type: ignore[union-attr]
                first = substitute(first, subst)
            if kind is not Var and (kind is not Compound or first._ground):  # type: ignore[union-attr]
                bucket = index.by_first.get(first)  # type: ignore[assignment]
                if bucket is None:
                    return _NO_ANSWERS
                start = 1
        if len(bucket) <= _EAGER_BUCKET:
            return iter(_match_all(pattern.args, start, bucket, subst))
        return _match_lazily(pattern.args, start, tuple(bucket), subst)

    def query(
        self,
        q: Term,
        subst: Subst | None = None,
        relations: Mapping[str, Sequence[Relation]] | None = None,
    ) -> Iterator[Subst]:
        """Every answer (a substitution extending ``subst``) of the query ``q``.

        ``q`` is a pattern, ``(and ...)``, ``(or ...)``, ``(not ...)``, a
        comparison, ``t`` or ``nil`` (see ``logic.query``); ``relations``
        are defined relations by predicate name.
        """
        if type(q) is Compound:
            functor = q.functor  # type: ignore[union-attr]
            if functor and functor not in QUERY_FORMS and (not relations or functor not in relations):
                return self.matches(q, subst)  # type: ignore[arg-type]
        return evaluate(q, self, subst, relations)

    def ask(
        self,
        q: Term,
        subst: Subst | None = None,
        relations: Mapping[str, Sequence[Relation]] | None = None,
    ) -> Subst | None:
        """The first answer of the query ``q``, or None if it has none."""
        return next(self.query(q, subst, relations), None)

    def holds(
        self,
        q: Term,
        subst: Subst | None = None,
        relations: Mapping[str, Sequence[Relation]] | None = None,
    ) -> bool:
        """True when the query ``q`` has at least one answer."""
        return next(self.query(q, subst, relations), None) is not None

    # -- index lookup ------------------------------------------------------

    def _candidates(
        self, pattern: Compound, subst: Subst | None
    ) -> tuple[list[Compound] | dict[Compound, None] | None, int]:
        """The smallest index bucket for ``pattern`` and the first argument left to match."""
        args = pattern.args
        index = self._index.get((pattern.functor, len(args)))
        if index is None:
            return None, 0
        if not args:
            return index.facts, 0
        first = args[0]
        if subst:
            first = substitute(first, subst)
        if not is_ground(first):
            return index.facts, 0
        return index.by_first.get(first), 1


class _PredicateIndex:
    """The facts of one predicate (functor and arity): all of them, and by first argument.

    Both in assertion order. A first-argument bucket is a list while it is
    small (compact, fast to scan; most buckets hold a few facts) and
    becomes an insertion-ordered dict past ``_LIST_BUCKET`` facts, so that
    retracting from a big bucket stays O(1).
    """

    __slots__ = ("facts", "by_first")

    def __init__(self) -> None:
        self.facts: dict[Compound, None] = {}
        self.by_first: dict[Term, list[Compound] | dict[Compound, None]] = {}

    def add(self, fact: Compound) -> None:
        """Index a fact that is not yet indexed."""
        self.facts[fact] = None
        if not fact.args:
            return
        first = fact.args[0]
        bucket = self.by_first.get(first)
        if bucket is None:
            self.by_first[first] = [fact]
        elif type(bucket) is dict:
            bucket[fact] = None
        elif len(bucket) < _LIST_BUCKET:
            bucket.append(fact)  # type: ignore[union-attr]
        else:
            self.by_first[first] = dict.fromkeys(bucket)
            self.by_first[first][fact] = None  # type: ignore[call-overload]

    def remove(self, fact: Compound) -> None:
        """Forget an indexed fact."""
        del self.facts[fact]
        if not fact.args:
            return
        first = fact.args[0]
        bucket = self.by_first[first]
        if type(bucket) is dict:
            del bucket[fact]
        else:
            bucket.remove(fact)  # type: ignore[union-attr]
        if not bucket:
            del self.by_first[first]

    def copy(self) -> _PredicateIndex:
        """An independent index with the same facts."""
        other = _PredicateIndex()
        other.facts = self.facts.copy()
        other.by_first = {first: bucket.copy() for first, bucket in self.by_first.items()}
        return other


def _match_all(args: tuple[Term, ...], start: int, facts: Iterable[Compound], subst: Subst | None) -> list[Subst]:
    """The answers of matching ``args[start:]`` against each fact's arguments.

    The hot loop of every query: unbound variables are bound and constants
    compared inline; the general matcher runs only for compounds.
    """
    arity = len(args)
    if arity - start == 1 and not subst and type(args[start]) is Var:
        # The commonest query, (pred key ?value): one binding per fact.
        var = args[start]
        return [{var: fact.args[start]} for fact in facts]  # type: ignore[dict-item]
    answers = []
    for fact in facts:
        s = subst.copy() if subst else {}
        fact_args = fact.args
        for i in range(start, arity):
            p = args[i]
            kind = type(p)
            if kind is Var:
                bound = s.get(p, _UNBOUND)  # type: ignore[arg-type]
                if bound is _UNBOUND:
                    s[p] = fact_args[i]  # type: ignore[index]
                    continue
                if bound == fact_args[i] or match_into(bound, fact_args[i], s):
                    continue
                break
            if kind is Compound:
                if not match_into(p, fact_args[i], s):
                    break
            elif p != fact_args[i]:
                break
        else:
            answers.append(s)
    return answers


def _match_lazily(args: tuple[Term, ...], start: int, facts: tuple[Compound, ...], subst: Subst | None) -> Iterator[Subst]:
    """Like :func:`_match_all`, a few facts at a time, so a first answer is cheap in a big bucket."""
    for i in range(0, len(facts), _EAGER_BUCKET):
        yield from _match_all(args, start, facts[i : i + _EAGER_BUCKET], subst)


def _matching_facts(args: tuple[Term, ...], start: int, facts: tuple[Compound, ...]) -> Iterator[Compound]:
    """The facts whose arguments ``args[start:]`` match, in order."""
    arity = len(args)
    for fact in facts:
        s: Subst = {}
        fact_args = fact.args
        if all(match_into(args[i], fact_args[i], s) for i in range(start, arity)):
            yield fact


def _without(listeners: tuple[Listener, ...], callback: Listener) -> tuple[Listener, ...]:
    """The listeners without the first occurrence of ``callback``."""
    for i, listener in enumerate(listeners):
        if listener is callback:
            return listeners[:i] + listeners[i + 1 :]
    return listeners


def _not_a_fact(fact: object) -> str:
    if type(fact) is Compound:
        text = term_to_str(fact)
        if not fact.functor:
            return f"a fact must start with a predicate name: {text}"
        return f"a fact must be ground (no variables): {text}"
    if type(fact) in (str, int, float, String, Var):
        return f"a fact must be a list (pred arg ...), not {term_to_str(fact)}"  # type: ignore[arg-type]
    return f"a fact must be a term (pred arg ...), not {fact!r}"
