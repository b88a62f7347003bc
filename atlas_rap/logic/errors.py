"""The errors of the logic package: bad facts, bad queries, runaway rules.

Every one is an :class:`~atlas_rap.errors.AtlasError`, so the CLI reports
it as text; catch :class:`LogicError` to catch any of them.
"""

from __future__ import annotations

from atlas_rap.errors import AtlasError


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
    """A memory rule that cannot be applied (an effect that is not ground)."""


class RuleCycleError(RuleError):
    """Memory rules kept firing without reaching a fixed point.

    ``rules`` names the rules that fired, most often first; ``changes`` is
    the list of memory changes made before the engine gave up (memory is
    left as it was at that point).
    """

    def __init__(self, message: str, rules: tuple[str, ...], changes: list[tuple[str, object]]) -> None:
        super().__init__(message)
        self.rules = rules
        self.changes = changes
