"""Sets of seeds written the short way: ``0-9``, ``0,3,5``, ``2-4,7``.

``atlas experiment skill-acquisition --seeds SPEC`` takes one;
:func:`parse_seeds` reads it (a :class:`ValueError` that says what is
wrong and how to write it), :func:`seeds_text` writes a set of seeds back
the same short way for titles and messages (``seeds 0–9``).

>>> parse_seeds("2-4,7")
(2, 3, 4, 7)
>>> seeds_text((0, 1, 2, 3, 5))
'seeds 0\u20133, 5'
"""

from __future__ import annotations

import re
from collections.abc import Iterable

__all__ = ["MAX_SEED", "MAX_SEEDS", "parse_seeds", "seeds_text"]

MAX_SEED = 2 ** 63 - 1
"""The largest seed (numpy takes no negative seed), as ``--seed`` takes it."""

MAX_SEEDS = 1000
"""The most seeds one experiment runs: ``0-999`` is already hours of work."""

FORMS = "N or N-M, separated by commas: 0-9, 0,3,5, 2-4,7"
"""How a set of seeds is written, for the error messages."""

_ITEM = re.compile(r"(\d+)(?:-(\d+))?")


def parse_seeds(spec: str) -> tuple[int, ...]:
    """The seeds ``spec`` names, in increasing order: whole numbers and ranges ``N-M`` (both ends
    included), separated by commas; spaces round them are allowed.

    A :class:`ValueError` says what is wrong: a part that is not a seed or a range (``a``, ``-1``,
    ``3-``), a range that goes down (``9-0``), a seed given twice, a seed above :data:`MAX_SEED`,
    more than :data:`MAX_SEEDS` seeds, or nothing at all.
    """
    seeds: set[int] = set()
    parts = str(spec).split(",")
    if not str(spec).strip():
        raise ValueError(f"no seeds given; write them as {FORMS}")
    for part in parts:
        item = part.strip()
        match = _ITEM.fullmatch(item)
        if match is None:
            what = "an empty part" if not item else repr(item)
            raise ValueError(f"{what} is not a seed or a range of seeds; write them as {FORMS}")
        first = int(match.group(1))
        last = int(match.group(2)) if match.group(2) is not None else first
        if last < first:
            raise ValueError(f"{item}: the range goes down; write it from the smaller seed, {last}-{first}")
        if last > MAX_SEED:
            raise ValueError(f"{item}: a seed is at most 2**63 - 1 ({MAX_SEED})")
        if len(seeds) + (last - first + 1) > MAX_SEEDS:
            raise ValueError(f"{spec.strip()}: more than {MAX_SEEDS} seeds; run fewer at a time")
        span = set(range(first, last + 1))
        twice = sorted(seeds & span)
        if twice:
            raise ValueError(f"{item}: seed {twice[0]} is given twice")
        seeds |= span
    return tuple(sorted(seeds))


def seeds_text(seeds: Iterable[int]) -> str:
    """``seeds`` the short way, runs of consecutive seeds as ranges: ``seeds 0–9``, ``seed 4``,
    ``seeds 2–4, 7`` (an en dash, for people; :func:`parse_seeds` reads the hyphen)."""
    ordered = sorted(set(seeds))
    if not ordered:
        return "no seeds"
    groups: list[list[int]] = [[ordered[0], ordered[0]]]
    for seed in ordered[1:]:
        if seed == groups[-1][1] + 1:
            groups[-1][1] = seed
        else:
            groups.append([seed, seed])
    text = ", ".join(str(a) if a == b else f"{a}, {b}" if b == a + 1 else f"{a}\u2013{b}" for a, b in groups)
    return f"{'seed' if len(ordered) == 1 else 'seeds'} {text}"
