"""Arithmetic: the one evaluation of ``(+ a ...)`` ``(- a ...)`` ``(* a ...)`` ``(/ a ...)``.

Two places evaluate arithmetic, with the same rules:

- queries, in the arguments of comparisons, ``=`` and ``/=``
  (``logic.query``, which also resolves variables and ``get-value``);
- facts, when they are asserted or retracted through a
  :class:`~atlas_rap.logic.rules.RuleEngine`: :func:`evaluated_fact` turns
  ``(counter (+ 3 1))`` into ``(counter 4)`` before it reaches memory, so
  memory never holds an arithmetic form and ``(counter 4)`` matches it.

The rules (:func:`combine`): ``(+)`` is 0 and ``(*)`` is 1; ``(- a)``
negates and ``(/ a)`` is ``1/a``; ``-`` and ``/`` of several numbers go
left to right; ``/`` of two integers is an integer when it divides exactly
(``(/ 6 3)`` is 2, ``(/ 7 2)`` is 3.5). Division by zero, ``(-)`` and
``(/)`` have no value.
"""

from __future__ import annotations

import sys
from typing import Sequence

from atlas_rap.logic.errors import FactError
from atlas_rap.logic.terms import Compound, Term, term_to_str

ARITHMETIC: frozenset[str] = frozenset({"+", "-", "*", "/"})
"""The arithmetic functors: evaluated in comparisons and in asserted facts."""


class ArithmeticUndefined(ValueError):
    """Arithmetic without a value: division by zero, ``(-)`` or ``(/)``, or (for
    facts) an argument that is not a number. The message says which, without
    context; callers raise their own error (QueryError, FactError) around it."""


def combine(functor: str, numbers: Sequence[int | float]) -> int | float:
    """The value of ``(functor n ...)`` for one of :data:`ARITHMETIC` and its numbers.

    The arithmetic shared by queries and facts; raises
    :class:`ArithmeticUndefined` when the value does not exist, and when it
    is too large for a float (past about 1.8e308, as the reader's numbers
    are): ``(* 1e300 1e300)`` has no value rather than ``inf``.
    """
    try:
        value = _combine(functor, numbers)
    except OverflowError:
        raise ArithmeticUndefined("the result is too large") from None
    if not -_LARGEST <= value <= _LARGEST:  # inf, or an int past the largest float; nan fails too
        raise ArithmeticUndefined("the result is too large")
    return value


_LARGEST = sys.float_info.max


def _combine(functor: str, numbers: Sequence[int | float]) -> int | float:
    if functor == "+":
        return sum(numbers)
    if functor == "*":
        product: int | float = 1
        for number in numbers:
            product *= number
        return product
    if not numbers:
        raise ArithmeticUndefined(f"({functor}) needs at least one number")
    if functor == "-":
        if len(numbers) == 1:
            return -numbers[0]
        result = numbers[0]
        for number in numbers[1:]:
            result -= number
        return result
    if functor != "/":
        raise ArithmeticUndefined(f"{functor} is not arithmetic")
    if len(numbers) == 1:
        numbers = (1, numbers[0])
    result = numbers[0]
    for number in numbers[1:]:
        if number == 0:
            raise ArithmeticUndefined("division by zero")
        result = _divide(result, number)
    return result


def _divide(a: int | float, b: int | float) -> int | float:
    if type(a) is int and type(b) is int and a % b == 0:
        return a // b
    return a / b


def evaluated_fact(fact: Compound) -> Compound:
    """``fact`` with every arithmetic form in its arguments replaced by its value.

    ``(counter (+ 3 1))`` gives ``(counter 4)`` and ``(pos ((+ 1 1) (* 2 3)))``
    gives ``(pos (2 6))``: any argument, at any depth, lists included; the
    predicate itself is never evaluated. Use it on every fact before it
    goes into (or out of) memory; ``RuleEngine`` does, for outside changes
    and for rule effects. A fact without arithmetic is returned as it is
    (the same object, at the cost of a look at its arguments); so is
    anything that is not a ground compound, for memory to refuse.

    Raises :class:`FactError` naming the fact when a form has no value: an
    argument that is not a number, or a division by zero (its
    ``__cause__`` is the :class:`ArithmeticUndefined` saying which).
    """
    if type(fact) is not Compound or not fact._ground:
        return fact
    for arg in fact.args:
        if type(arg) is Compound:
            break
    else:
        return fact  # the hot path: no compound argument, nothing to evaluate
    try:
        args = _evaluated_args(fact.args)
    except ArithmeticUndefined as exc:
        raise FactError(f"cannot evaluate the arithmetic in the fact {term_to_str(fact)}: {exc}") from exc
    return fact if args is fact.args else Compound(fact.functor, args)


def _evaluated_args(args: tuple[Term, ...]) -> tuple[Term, ...]:
    """``args`` with arithmetic evaluated: the same tuple when nothing changed."""
    new: list[Term] | None = None
    for i, arg in enumerate(args):
        if type(arg) is Compound:
            value = arithmetic_value(arg) if arg.functor in ARITHMETIC else _evaluated_list(arg)
            if value is not arg:
                if new is None:
                    new = list(args)
                new[i] = value
    return args if new is None else tuple(new)


def _evaluated_list(term: Compound) -> Compound:
    args = _evaluated_args(term.args)
    return term if args is term.args else Compound(term.functor, args)


def arithmetic_value(expression: Compound) -> int | float:
    """The number a ground arithmetic form stands for: ``(+ 1 (* 2 3))`` is 7.

    For ground terms only (a query evaluates its own, through its
    bindings). Raises :class:`ArithmeticUndefined` saying what is wrong
    when it has no value (a variable or a symbol is not a number).
    """
    numbers = []
    for arg in expression.args:
        if type(arg) is Compound and arg.functor in ARITHMETIC:
            arg = arithmetic_value(arg)
        kind = type(arg)
        if kind is not int and kind is not float:
            raise ArithmeticUndefined(f"{term_to_str(arg)} is not a number, in {term_to_str(expression)}")
        numbers.append(arg)
    try:
        return combine(expression.functor, numbers)
    except ArithmeticUndefined as exc:
        if not numbers:
            raise  # "(-) needs at least one number" says it all
        raise ArithmeticUndefined(f"{exc} in {term_to_str(expression)}") from None
