"""Memory rules: keeping memory consistent when facts arrive (docs/language/rap.md, define-memory-rule).

::

    (define-memory-rule at-is-unique
      (on (at ?thing ?new))
      (when (and (at ?thing ?old) (/= ?old ?new)))
      (retract (at ?thing ?old)))

is ``MemoryRule('at-is-unique', trigger=(at ?thing ?new), condition=(and
...), effects=(('retract', (at ?thing ?old)),))``. A :class:`RuleEngine`
asserts a fact into a memory and then fires the rules it triggers, and the
rules that *their* assertions trigger, until nothing more happens (a fixed
point), or gives up with :class:`RuleCycleError` after a bound.

How a rule fires, exactly:

- A rule is triggered by a fact that was *new* in memory (asserting a
  fact already there triggers nothing) and is still there when its turn
  comes. Retractions trigger nothing.
- The trigger's bindings, then every answer of the condition (computed in
  full before any effect is applied), each give one firing: its effects,
  substituted, applied in the order written. An effect must be ground.
- Order: triggering facts first-in first-out (assertion order), and for
  each fact the rules in the order they were defined.
- Arithmetic in a fact is evaluated before it reaches memory, for outside
  changes and effects alike (``(assert (n (+ ?x 1)))`` with ?x = 3 asserts
  ``(n 4)``; ``logic.arithmetic.evaluated_fact``).

Errors while rules fire (:class:`RuleError`, :class:`RuleCycleError`) name
each rule with where it was written (``MemoryRule.loc``), e.g. ``up
(cyc.rap:2:1)``. :func:`rule_cycles` finds, before anything runs, the rules
that can trigger each other in a circle (``atlas check`` warns about them).
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence, TypeAlias

from atlas_rap.errors import SourceLocation
from atlas_rap.logic.arithmetic import ARITHMETIC, ArithmeticUndefined, arithmetic_value, evaluated_fact
from atlas_rap.logic.errors import FactError, QueryError, RuleCycleError, RuleError
from atlas_rap.logic.memory import Memory
from atlas_rap.logic.query import Relation, evaluate
from atlas_rap.logic.terms import Compound, Subst, Term, Var, is_ground, substitute, term_to_str, variables
from atlas_rap.logic.unify import match, unify

Change: TypeAlias = tuple[str, Compound]
"""A change made to memory: ``('assert', fact)`` or ``('retract', fact)``."""

EFFECT_KINDS = ("assert", "retract")
"""What a memory rule's effect can do."""

DEFAULT_MAX_FIRINGS = 10_000
"""Rule firings allowed for one outside change before :class:`RuleCycleError`."""


@dataclass(frozen=True, slots=True)
class MemoryRule:
    """A ``define-memory-rule``: when ``trigger`` is asserted and ``condition``
    holds, apply ``effects`` (each ``('assert', fact)`` or ``('retract', fact)``).

    ``condition`` None means no ``when`` clause (always true). ``loc`` is
    where the ``define-memory-rule`` form starts (the validator sets it;
    None for a rule made in code); it is not part of equality, so the same
    rule written in two places is the same rule.
    """

    name: str
    trigger: Compound
    condition: Term | None = None
    effects: tuple[tuple[str, Compound], ...] = ()
    loc: SourceLocation | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if type(self.trigger) is not Compound or not self.trigger.functor:
            raise RuleError(
                f"memory rule {self.name}: the trigger must be a pattern (pred arg ...), "
                f"not {_text(self.trigger)}"
            )
        for kind, fact in self.effects:
            if kind not in EFFECT_KINDS or type(fact) is not Compound:
                raise RuleError(
                    f"memory rule {self.name}: an effect must be (assert FACT) or (retract FACT), "
                    f"not ({kind} {_text(fact)})"
                )

    @property
    def label(self) -> str:
        """The name and where the rule was written, for messages: ``up (cyc.rap:2:1)``."""
        return f"{self.name} ({self.loc})" if self.loc is not None else self.name

    def __str__(self) -> str:
        parts = [f"(define-memory-rule {self.name}", f"(on {term_to_str(self.trigger)})"]
        if self.condition is not None:
            parts.append(f"(when {term_to_str(self.condition)})")
        parts.extend(f"({kind} {term_to_str(fact)})" for kind, fact in self.effects)
        return " ".join(parts) + ")"


class RuleEngine:
    """Applies changes to a memory and runs the memory rules to a fixed point.

    Make one with the rules in definition order, then change memory through
    :meth:`assert_fact` / :meth:`retract_fact` (or :meth:`apply`) instead of
    through the memory itself; each returns the changes actually made, the
    outside change first, for the trace. ``max_firings`` bounds the rule
    firings caused by one outside change; ``relations`` are available to
    rule conditions.
    """

    def __init__(
        self,
        rules: Iterable[MemoryRule] = (),
        *,
        max_firings: int = DEFAULT_MAX_FIRINGS,
        relations: Mapping[str, Sequence[Relation]] | None = None,
    ) -> None:
        self.max_firings = max_firings
        self.relations = relations
        self.fired: deque[tuple[MemoryRule, Compound]] = deque(maxlen=16)
        """The latest firings (rule, the fact that fired it), newest last: who concluded what."""
        self._rules: list[MemoryRule] = []
        self._by_trigger: dict[tuple[str, int], list[MemoryRule]] = {}
        for rule in rules:
            self.add(rule)

    @property
    def rules(self) -> tuple[MemoryRule, ...]:
        """The rules, in definition order."""
        return tuple(self._rules)

    def add(self, rule: MemoryRule) -> None:
        """Add a rule after the others; a second rule with the same name is a RuleError."""
        if any(existing.name == rule.name for existing in self._rules):
            raise RuleError(f"memory rule {rule.name} is defined twice")
        self._rules.append(rule)
        key = (rule.trigger.functor, len(rule.trigger.args))
        self._by_trigger.setdefault(key, []).append(rule)

    def assert_fact(self, memory: Memory, fact: Compound, time: float = 0.0) -> list[Change]:
        """Assert ``fact`` at ``time``, then run the rules it triggers to a fixed point.

        Returns every change made, in order (empty if the fact was already
        in memory). Raises :class:`RuleCycleError` if the rules do not
        settle within ``max_firings``; memory keeps the changes made so far.
        """
        return self.apply(memory, [("assert", fact)], time)

    def retract_fact(self, memory: Memory, fact: Compound, time: float = 0.0) -> list[Change]:
        """Retract ``fact``; returns ``[('retract', fact)]``, or ``[]`` if it was not there.

        Retractions trigger no rules (rules are triggered by assertions),
        so this is the memory's own retract, in the engine's vocabulary.
        """
        return self.apply(memory, [("retract", fact)], time)

    def apply(self, memory: Memory, changes: Iterable[Change], time: float = 0.0) -> list[Change]:
        """Make several outside changes in order, each followed by its rules' fixed point.

        The one door every change goes through: each fact's arithmetic is
        evaluated first (``evaluated_fact``), so ``(counter (+ 3 1))`` is
        asserted (or retracted) as ``(counter 4)`` and the changes returned
        hold the evaluated facts. Arithmetic without a value raises
        :class:`FactError` naming the fact; an error while the rules fire
        raises :class:`RuleError` (see :meth:`assert_fact`).
        """
        made: list[Change] = []
        for kind, fact in changes:
            fact = evaluated_fact(fact)
            if kind == "assert":
                if memory.assert_fact(fact, time):
                    made.append(("assert", fact))
                    self._run_to_fixed_point(memory, fact, time, made)
            elif kind == "retract":
                if memory.retract(fact, time):
                    made.append(("retract", fact))
            else:
                raise RuleError(f"a change is 'assert' or 'retract', not {kind!r}")
        return made

    def _run_to_fixed_point(self, memory: Memory, fact: Compound, time: float, made: list[Change]) -> None:
        pending: deque[Compound] = deque([fact])
        firings = 0
        counts: Counter[str] = Counter()
        recent: deque[tuple[str, Compound]] = deque(maxlen=_SHOWN_FIRINGS)
        while pending:
            trigger_fact = pending.popleft()
            for rule in self._by_trigger.get((trigger_fact.functor, len(trigger_fact.args)), ()):
                if trigger_fact not in memory:
                    break
                bindings = match(rule.trigger, trigger_fact)
                if bindings is None:
                    continue
                if rule.condition is None:
                    answers = [bindings]
                else:
                    answers = self._condition_answers(memory, rule, bindings, made)
                for answer in answers:
                    firings += 1
                    counts[rule.name] += 1
                    recent.append((rule.name, trigger_fact))
                    self.fired.append((rule, trigger_fact))
                    if firings > self.max_firings:
                        raise self._cycle_error(fact, counts, recent, made)
                    for kind, effect in rule.effects:
                        self._apply_effect(memory, rule, kind, substitute(effect, answer), time, made, pending)

    def _condition_answers(self, memory: Memory, rule: MemoryRule, bindings: Subst, made: list[Change]) -> list[Subst]:
        """Every answer of the rule's condition, in full; a QueryError becomes a RuleError naming the rule."""
        try:
            return list(evaluate(rule.condition, memory, bindings, self.relations))
        except QueryError as exc:
            raise _rule_error(rule, f"its condition (when {_short(rule.condition)}) cannot be evaluated: {exc}",
                              made) from exc

    @staticmethod
    def _apply_effect(
        memory: Memory,
        rule: MemoryRule,
        kind: str,
        fact: Term,
        time: float,
        made: list[Change],
        pending: deque[Compound],
    ) -> None:
        if type(fact) is not Compound or not fact._ground:
            raise _rule_error(
                rule,
                f"the effect ({kind} {term_to_str(fact)}) is not ground; "
                f"every variable of an effect must be bound by the trigger or the condition",
                made,
            )
        try:
            fact = evaluated_fact(fact)
        except FactError as exc:
            reason = exc.__cause__ if isinstance(exc.__cause__, ArithmeticUndefined) else exc
            raise _rule_error(rule, f"cannot evaluate the effect ({kind} {_short(fact)}): {reason}", made) from exc
        if kind == "assert":
            if memory.assert_fact(fact, time):
                made.append(("assert", fact))
                pending.append(fact)
        elif memory.retract(fact, time):
            made.append(("retract", fact))

    def _cycle_error(
        self,
        cause: Compound,
        counts: Counter[str],
        recent: deque[tuple[str, Compound]],
        made: list[Change],
    ) -> RuleCycleError:
        by_name = {rule.name: rule for rule in self._rules}
        ranked = tuple(name for name, _ in counts.most_common())
        fired = [f"{by_name[name].label} fired {counts[name]} times" for name in ranked[:_SHOWN_RULES]]
        if len(ranked) > _SHOWN_RULES:
            fired.append(f"and {len(ranked) - _SHOWN_RULES} more")
        last = ", ".join(f"{name} on {_short(fact)}" for name, fact in recent)
        return RuleCycleError(
            f"memory rules did not reach a fixed point after {self.max_firings} firings "
            f"caused by asserting {_short(cause)}: {', '.join(fired)}; last firings: {last}",
            ranked,
            list(made),
            tuple(by_name[name].loc for name in ranked),
        )


_SHOWN_RULES = 5  # rules named in a cycle error, most firings first
_SHOWN_FIRINGS = 3  # last firings shown in a cycle error
_SHORT = 40  # characters of a term shown in an error before it is cut


def _rule_error(rule: MemoryRule, problem: str, made: list[Change]) -> RuleError:
    """A RuleError about one rule, named with its location, carrying the changes made so far."""
    return RuleError(f"memory rule {rule.label}: {problem}", rules=(rule.name,), locations=(rule.loc,),
                     changes=list(made))


def _short(term: Term) -> str:
    """A term's text, cut in the middle to a readable length for an error message."""
    text = term_to_str(term)
    if len(text) <= _SHORT:
        return text
    tail = _SHORT // 3
    return text[: _SHORT - tail - 5] + " ... " + text[-tail:]


# -- static cycles -------------------------------------------------------------------


def rule_cycles(rules: Iterable[MemoryRule]) -> list[tuple[MemoryRule, ...]]:
    """The cycles of rules that can trigger each other, seen without running them.

    Rule A *can trigger* rule B when one of A's ``assert`` effects unifies
    with B's trigger, variables renamed apart (an arithmetic form in the
    effect is its value, or stands for any number if it has variables). A cycle is a chain of such edges that
    comes back to its first rule; ``(A,)`` is a rule that can trigger
    itself, except when that effect *is* its trigger (asserting a fact
    already in memory triggers nothing). Conditions are not looked at: a
    cycle is a warning that the ``when`` clauses must stop it, not proof
    that they do not.

    One cycle per group of rules that can all reach each other: the
    shortest through the group's first-defined rule, starting there and
    in firing order. Deterministic: groups in the order their first rule
    was defined. Use it for load-time warnings (``atlas check``).
    """
    rules = list(rules)
    edges = [[j for j, b in enumerate(rules) if _can_trigger(a, b)] for a in rules]
    cycles: list[tuple[MemoryRule, ...]] = []
    grouped: set[int] = set()
    for start in range(len(rules)):
        if start in grouped:
            continue
        path = _shortest_cycle(start, edges)
        if path is None:
            continue
        grouped |= _reachable(start, edges) & _reachable(start, _reversed(edges))
        cycles.append(tuple(rules[i] for i in path))
    return cycles


def _can_trigger(a: MemoryRule, b: MemoryRule) -> bool:
    """True when an assert effect of ``a`` may be a fact that triggers ``b``."""
    trigger = b.trigger
    for kind, effect in a.effects:
        if kind != "assert" or effect.functor != trigger.functor or len(effect.args) != len(trigger.args):
            continue
        pattern = _numbers_as_variables(effect, [0])
        if a is b and pattern == a.trigger:
            continue
        renamed: Subst = {var: Var(var.name + "_Effect") for var in variables(pattern)}
        if unify(substitute(pattern, renamed), trigger) is not None:
            return True
    return False


def _numbers_as_variables(term: Term, count: list[int]) -> Term:
    """The facts ``term`` may stand for, as a pattern: each arithmetic form its
    value, or a new variable when its value is not known before it runs."""
    if type(term) is not Compound:
        return term
    if term.functor in ARITHMETIC:
        if is_ground(term):
            try:
                return arithmetic_value(term)
            except ArithmeticUndefined:
                pass
        count[0] += 1
        return Var(f"_Number{count[0]}")
    return Compound(term.functor, tuple(_numbers_as_variables(arg, count) for arg in term.args))


def _shortest_cycle(start: int, edges: list[list[int]]) -> list[int] | None:
    """The shortest path from ``start`` back to it (successors in definition order), or None."""
    parents: dict[int, int] = {}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for nxt in edges[node]:
            if nxt == start:
                path = [node]
                while path[-1] != start:
                    path.append(parents[path[-1]])
                return path[::-1]
            if nxt not in parents:
                parents[nxt] = node
                queue.append(nxt)
    return None


def _reachable(start: int, edges: list[list[int]]) -> set[int]:
    seen = {start}
    stack = [start]
    while stack:
        for nxt in edges[stack.pop()]:
            if nxt not in seen:
                seen.add(nxt)
                stack.append(nxt)
    return seen


def _reversed(edges: list[list[int]]) -> list[list[int]]:
    back: list[list[int]] = [[] for _ in edges]
    for node, targets in enumerate(edges):
        for target in targets:
            back[target].append(node)
    return back


def _text(term: object) -> str:
    try:
        return term_to_str(term)  # type: ignore[arg-type]
    except TypeError:
        return repr(term)
