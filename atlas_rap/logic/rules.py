"""Memory rules: keeping memory consistent when facts arrive (LANGUAGE.md §2.5).

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
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence, TypeAlias

from atlas_rap.logic.errors import RuleCycleError, RuleError
from atlas_rap.logic.memory import Memory
from atlas_rap.logic.query import Relation, evaluate
from atlas_rap.logic.terms import Compound, Term, substitute, term_to_str
from atlas_rap.logic.unify import match

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

    ``condition`` None means no ``when`` clause (always true).
    """

    name: str
    trigger: Compound
    condition: Term | None = None
    effects: tuple[tuple[str, Compound], ...] = ()

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
        """Make several outside changes in order, each followed by its rules' fixed point."""
        made: list[Change] = []
        for kind, fact in changes:
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
        recent: deque[tuple[str, Compound]] = deque(maxlen=6)
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
                    answers = list(evaluate(rule.condition, memory, bindings, self.relations))
                for answer in answers:
                    firings += 1
                    counts[rule.name] += 1
                    recent.append((rule.name, trigger_fact))
                    if firings > self.max_firings:
                        raise self._cycle_error(fact, counts, recent, made)
                    for kind, effect in rule.effects:
                        self._apply_effect(memory, rule, kind, substitute(effect, answer), time, made, pending)

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
            raise RuleError(
                f"memory rule {rule.name}: the effect ({kind} {term_to_str(fact)}) is not ground; "
                f"every variable of an effect must be bound by the trigger or the condition"
            )
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
        ranked = tuple(name for name, _ in counts.most_common())
        fired = ", ".join(f"{name} ({counts[name]} times)" for name in ranked[:5])
        last = "; ".join(f"{name} on {term_to_str(fact)}" for name, fact in recent)
        return RuleCycleError(
            f"memory rules did not reach a fixed point after {self.max_firings} firings "
            f"caused by asserting {term_to_str(cause)}: rules in the cycle: {fired}; "
            f"last firings: {last}",
            ranked,
            list(made),
        )


def _text(term: object) -> str:
    try:
        return term_to_str(term)  # type: ignore[arg-type]
    except TypeError:
        return repr(term)
