"""Unification: the most general substitution that makes two terms equal.

:func:`unify` is two-sided (both terms may contain variables): use it to
match a goal against an operator's purpose or a RAP's ``succeed`` clause,
or a call against a relation's head. :func:`match` is the one-sided fast
path for a pattern against a *ground* term, such as a fact in memory.

Choices:

- **Occurs check on.** ``?x`` does not unify with ``(f ?x)``: the result
  would be an infinite term. It costs a walk of the other term, skipped
  for ground terms, which are most terms here.
- **Numbers compare numerically.** ``1`` unifies with ``1.0`` (as in
  Python, ``1 == 1.0``); facts ``(p 1)`` and ``(p 1.0)`` are the same fact.
- Symbols, :class:`~atlas_rap.logic.terms.String` and numbers unify only
  with an equal term of the same kind (``'a'`` does not unify with
  ``String('a')``).
"""

from __future__ import annotations

from typing import Any

from atlas_rap.logic.terms import Compound, Subst, Term, Var

_UNBOUND: Any = object()


def unify(a: Term, b: Term, subst: Subst | None = None) -> Subst | None:
    """The most general unifier of ``a`` and ``b`` extending ``subst``, or None.

    ``subst`` is not changed; the answer is a new dict holding the old
    bindings plus the new ones (bindings may chain; see ``substitute``).
    """
    s: Subst = dict(subst) if subst else {}
    return s if _unify(a, b, s) else None


def _unify(a: Term, b: Term, s: Subst) -> bool:
    while type(a) is Var:
        bound = s.get(a, _UNBOUND)  # type: ignore[arg-type]
        if bound is _UNBOUND:
            break
        a = bound
    while type(b) is Var:
        bound = s.get(b, _UNBOUND)  # type: ignore[arg-type]
        if bound is _UNBOUND:
            break
        b = bound
    if a is b:
        return True
    type_a = type(a)
    type_b = type(b)
    if type_a is Var:
        if type_b is Var:
            if a != b:
                s[a] = b  # type: ignore[index]
            return True
        if _occurs(a, b, s):  # type: ignore[arg-type]
            return False
        s[a] = b  # type: ignore[index]
        return True
    if type_b is Var:
        if _occurs(b, a, s):  # type: ignore[arg-type]
            return False
        s[b] = a  # type: ignore[index]
        return True
    if type_a is Compound:
        if type_b is not Compound:
            return False
        if a._ground and b._ground:  # type: ignore[union-attr]
            return a == b
        args_a = a.args  # type: ignore[union-attr]
        args_b = b.args  # type: ignore[union-attr]
        if a.functor != b.functor or len(args_a) != len(args_b):  # type: ignore[union-attr]
            return False
        for x, y in zip(args_a, args_b):
            if not _unify(x, y, s):
                return False
        return True
    if type_b is Compound:
        return False
    return a == b


def _occurs(var: Var, term: Term, s: Subst) -> bool:
    """True when ``var`` appears in ``term`` under the bindings ``s``."""
    while type(term) is Var:
        if term == var:
            return True
        bound = s.get(term, _UNBOUND)  # type: ignore[arg-type]
        if bound is _UNBOUND:
            return False
        term = bound
    if type(term) is Compound and not term._ground:  # type: ignore[union-attr]
        return any(_occurs(var, arg, s) for arg in term.args)  # type: ignore[union-attr]
    return False


def match(pattern: Term, ground: Term, subst: Subst | None = None) -> Subst | None:
    """One-sided unification of ``pattern`` with a ground term, or None.

    Faster than :func:`unify` because it never binds a variable of
    ``ground``: use it for facts, which are ground. If ``ground`` does
    contain variables, they are treated as constants (compared by name),
    which is not unification; call :func:`unify` then.
    """
    s: Subst = dict(subst) if subst else {}
    return s if match_into(pattern, ground, s) else None


def match_into(pattern: Term, ground: Term, s: Subst) -> bool:
    """Like :func:`match`, but extends ``s`` in place; False on failure.

    On failure ``s`` may hold some new bindings: pass a copy you can
    throw away. For inner loops that already own a fresh dict.
    """
    kind = type(pattern)
    if kind is Var:
        bound = s.get(pattern, _UNBOUND)  # type: ignore[arg-type]
        if bound is _UNBOUND:
            s[pattern] = ground  # type: ignore[index]
            return True
        return match_into(bound, ground, s)
    if kind is Compound:
        if pattern._ground:  # type: ignore[union-attr]
            return pattern == ground
        if type(ground) is not Compound:
            return False
        args = pattern.args  # type: ignore[union-attr]
        ground_args = ground.args  # type: ignore[union-attr]
        if pattern.functor != ground.functor or len(args) != len(ground_args):  # type: ignore[union-attr]
            return False
        for p, g in zip(args, ground_args):
            if not match_into(p, g, s):
                return False
        return True
    return pattern == ground
