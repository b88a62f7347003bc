"""The errors of the logic package: bad facts, bad queries, runaway rules.

Every one is an :class:`~atlas_rap.errors.AtlasError`, so the CLI reports
it as text; catch :class:`LogicError` to catch any of them.
"""

from __future__ import annotations

from atlas_rap.errors import AtlasError, SourceLocation


class LogicError(AtlasError):
    """Base of the errors raised by terms, memory, queries and memory rules."""


class FactError(LogicError):
    """Something that is not a ground ``(pred arg ...)`` was asserted as a fact."""


class QueryError(LogicError):
    """A query that cannot be evaluated: arithmetic on a non-number, a
    comparison of an unbound variable, a form that is not a query."""


class RelationDepthError(QueryError):
    """Defined relations called each other deeper than the allowed bound
    (usually a recursive relation without a base case)."""


class RuleError(LogicError):
    """A memory rule that cannot be applied: an effect that is not ground, an
    effect whose arithmetic has no value, a condition that raised a
    :class:`QueryError`, or a badly formed rule.

    Raised while rules fire, it names the rule with its source location
    (``memory rule r (m.rap:3:1): ...``); ``rules`` and ``locations`` hold
    the same (names, and :class:`~atlas_rap.errors.SourceLocation` or None
    for a rule made in code), for a caller that reports them its own way;
    ``changes`` is the list of memory changes made before the error, outside
    change first (memory is left as it was at that point). All three are
    empty for an error raised outside a firing.
    """

    def __init__(
        self,
        message: str,
        *,
        rules: tuple[str, ...] = (),
        locations: tuple[SourceLocation | None, ...] = (),
        changes: list[tuple[str, object]] | None = None,
    ) -> None:
        super().__init__(message)
        self.rules = rules
        self.locations = locations
        self.changes = changes if changes is not None else []


class RuleCycleError(RuleError):
    """Memory rules kept firing without reaching a fixed point.

    ``rules`` names the rules that fired, most often first; ``locations``
    are where those rules were written, in the same order (None for a rule
    made in code); ``changes`` is the list of memory changes made before the
    engine gave up (memory is left as it was at that point).
    """

    def __init__(
        self,
        message: str,
        rules: tuple[str, ...],
        changes: list[tuple[str, object]],
        locations: tuple[SourceLocation | None, ...] = (),
    ) -> None:
        super().__init__(message, rules=rules, locations=locations, changes=changes)
