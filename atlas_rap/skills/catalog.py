"""The stock skills, registered once: each one's name, parameters, events and class.

This table is the one place a stock skill's interface is written. The skill
classes take it from here (:func:`registered` sets ``name``, ``params``,
``events`` and ``always_on`` on them); :func:`stock_classes` gives the classes
in the manager's order, for ``atlas_rap.skills.stock``; and the load-time checks
(``atlas check``) read :data:`STOCK_SKILLS` and :data:`STOCK_EVENTS` without
importing the skills, which import numpy and would slow the check's start.
The skill bus lists what the manager built from these classes.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Callable, TypeVar

__all__ = ["STOCK", "STOCK_EVENTS", "STOCK_SKILLS", "StockSkill", "registered", "stock_classes"]


@dataclass(frozen=True, slots=True)
class StockSkill:
    """One stock skill as RAPs see it, and the class that runs it (``module:Class``)."""

    name: str
    code: str
    params: tuple[str, ...] = ()
    events: tuple[str, ...] = ()
    always_on: bool = False


_SENSING, _EVENTS, _MOTION = "atlas_rap.skills.sensing", "atlas_rap.skills.events", "atlas_rap.skills.motion"
_NAVIGATION, _CAMERA, _HANDLING = "atlas_rap.skills.navigation", "atlas_rap.skills.camera", "atlas_rap.skills.handling"

STOCK: tuple[StockSkill, ...] = (
    StockSkill("sonar-ring", f"{_SENSING}:SonarSensor", always_on=True),
    StockSkill("localiser", "atlas_rap.skills.localising:Localiser", events=("localised", "lost"), always_on=True),
    StockSkill("bumper", f"{_SENSING}:Bumper", always_on=True),
    StockSkill("safety-reflex", "atlas_rap.skills.safety:SafetyReflex", always_on=True),
    StockSkill("drive", f"{_SENSING}:Drive", always_on=True),
    StockSkill("place-monitor", f"{_EVENTS}:PlaceMonitor", events=("at",), always_on=True),
    StockSkill("door-monitor", f"{_EVENTS}:DoorMonitor", events=("door-open", "door-closed", "edge-blocked"),
               always_on=True),
    StockSkill("bump-monitor", f"{_EVENTS}:BumpMonitor", events=("bumped",), always_on=True),
    StockSkill("move-to", f"{_MOTION}:MoveTo", ("x", "y"), ("blocked",)),
    StockSkill("follow-route", f"{_MOTION}:FollowRoute", ("waypoints",), ("blocked",)),
    StockSkill("turn-to", f"{_MOTION}:TurnTo", ("heading",)),
    StockSkill("wander", f"{_MOTION}:Wander"),
    StockSkill("wall-follow", f"{_MOTION}:WallFollow", ("side",)),
    StockSkill("spin", f"{_MOTION}:Spin"),
    StockSkill("stop", f"{_MOTION}:Stop"),
    StockSkill("navigate-to", f"{_NAVIGATION}:NavigateTo", ("place",), ("blocked",)),
    StockSkill("open-door", f"{_NAVIGATION}:OpenDoor", ("door",), ("door-open",)),
    StockSkill("colour-camera", f"{_CAMERA}:ColourCamera", events=("in-view", "seen", "is-a"), always_on=True),
    StockSkill("look-around", f"{_CAMERA}:LookAround"),
    StockSkill("approach", f"{_CAMERA}:Approach", ("object",), ("blocked", "lost")),
    StockSkill("pick-up", f"{_HANDLING}:PickUp", ("item",), ("holding",)),
    StockSkill("drop", f"{_HANDLING}:Drop", ("item", "bin"), ("in-bin",)),
)
"""Every stock skill, in the order the skill manager is given them: sensors, reflex, drive, events,
motion, navigation, the colour camera and what it serves, the gripper."""

STOCK_SKILLS: dict[str, set[int]] = {skill.name: {len(skill.params)} for skill in STOCK if not skill.always_on}
"""Skills RAPs can enable in a world: name → arities."""

STOCK_EVENTS: set[str] = {"done", "why"}.union(*(skill.events for skill in STOCK))
"""Predicates the stock skills may assert (every skill's ``done`` and ``why`` among them)."""

_BY_NAME = {skill.name: skill for skill in STOCK}

SkillClass = TypeVar("SkillClass", bound=type)


def registered(name: str) -> Callable[[SkillClass], SkillClass]:
    """A class decorator: the stock skill ``name`` is this class, with the interface :data:`STOCK` gives it."""
    entry = _BY_NAME[name]

    def register(cls: SkillClass) -> SkillClass:
        code = f"{cls.__module__}:{cls.__qualname__}"
        if entry.code != code:
            raise TypeError(f"stock skill {name} is registered as {entry.code}, not {code}")
        cls.name, cls.params, cls.events, cls.always_on = entry.name, entry.params, entry.events, entry.always_on
        return cls

    return register


def stock_classes() -> list[type]:
    """The class of each stock skill, in :data:`STOCK`'s order (importing the skills' modules)."""
    classes = []
    for skill in STOCK:
        module, _, name = skill.code.partition(":")
        classes.append(getattr(importlib.import_module(module), name))
    return classes
