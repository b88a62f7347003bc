"""The stock skills' names, arities and events, without importing them.

``atlas check`` checks RAP files against the skills a world run has; the
skills themselves import numpy, which would slow the check's start.
``tests/test_skills_manager.py`` keeps this list equal to ``stock.stock_skills()``.
"""

STOCK_SKILLS: dict[str, set[int]] = {
    "move-to": {2}, "follow-route": {1}, "turn-to": {1}, "wander": {0}, "wall-follow": {1},
    "stop": {0}, "navigate-to": {1}, "open-door": {1}, "look-around": {0}, "approach": {1}, "pick-up": {1},
    "drop": {2},
}
"""Skills RAPs can enable in a world: name → arities."""

STOCK_EVENTS: set[str] = {"done", "why", "blocked", "at", "door-open", "door-closed", "edge-blocked", "bumped",
                          "in-view", "seen", "is-a", "lost", "holding", "in-bin"}
"""Predicates the stock skills may assert."""
