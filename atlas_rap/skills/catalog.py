"""The skills registry: each skill's name, typed parameters, events, rate and class, declared once.

Every skill a robot has is one :class:`SkillSpec` here, the one place its
interface is written; everything else is derived from it:

- the class's ``name``, ``params``, ``events``, ``rate``, ``always_on`` and
  ``origin`` (set on it by :func:`registered` for a stock skill, by
  :func:`plugin_specs` for a plugin's);
- the load-time checks of ``atlas check`` and of a run: :func:`skill_names`,
  :func:`skill_events`, and :func:`param_types` (a literal argument of
  another type than declared is an error);
- the skill manager's skills (:func:`skill_classes`); the skill bus lists
  what the manager was built from;
- ``atlas skills list`` (:func:`catalog`).

- **Stock skills** are the table :data:`STOCK`, written here so that
  ``atlas check`` reads them without importing the skills (which import
  numpy and would slow the check's start); :data:`STOCK_SKILLS` and
  :data:`STOCK_EVENTS` are what it gives.
- **Plugin skills** (:mod:`atlas_rap.plugins`: the ``atlas_rap.skills``
  entry points and the ``ATLAS_SKILLS`` of ``--plugin`` files; a sensor is a
  skill) declare the same things as class attributes of their
  :class:`~atlas_rap.skills.skill.Skill` subclass: ``name`` (a RAP symbol),
  ``params`` (each ``"name"`` or ``"name: type"``, a type of
  :data:`PARAM_TYPES`), ``events`` (the predicates of the facts it posts),
  ``rate`` (Hz) and ``always_on``. :func:`spec_of` reads and checks them: a
  bad declaration (no name, a name a stock or another plugin skill has, an
  unknown type) is a :class:`~atlas_rap.plugins.PluginError` naming the plugin.
"""

from __future__ import annotations

import importlib
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, NamedTuple, TypeVar

from atlas_rap.plugins import Contribution, PluginError, contributions

__all__ = ["PARAM_TYPES", "STOCK", "STOCK_EVENTS", "STOCK_SKILLS", "Param", "SkillSpec", "catalog", "param_types",
           "params", "plugin_specs", "registered", "skill_classes", "skill_events", "skill_names", "spec_of",
           "stock_classes"]

PARAM_TYPES = ("number", "symbol", "string", "list", "any")
"""The types a skill's parameter may declare: what a RAP writes as its argument."""

NAME = re.compile(r"[a-z][a-z0-9-]*\Z")
"""A skill's name: a RAP symbol (lower case, digits and hyphens)."""


class Param(NamedTuple):
    """One parameter of a skill: its name and the type of argument it takes (one of :data:`PARAM_TYPES`)."""

    name: str
    type: str = "any"

    def __str__(self) -> str:
        return f"{self.name}: {self.type}"


def params(*declared: str | Param) -> tuple[Param, ...]:
    """Parameters as declared (``"x: number"``, ``"x"`` for any type, or a :class:`Param`), checked.
    Raises ValueError saying what is wrong."""
    found = []
    for item in declared:
        if isinstance(item, Param):
            name, kind = item
        elif isinstance(item, str):
            name, _, kind = (part.strip() for part in item.partition(":"))
            kind = kind or "any"
        else:
            raise ValueError(f"a parameter is written 'name' or 'name: type', not {item!r}")
        if not name.isidentifier() and not NAME.match(name):
            raise ValueError(f"parameter {name!r} is not a name")
        if kind not in PARAM_TYPES:
            raise ValueError(f"parameter {name}: unknown type {kind!r} (the types: {', '.join(PARAM_TYPES)})")
        found.append(Param(name, kind))
    return tuple(found)


@dataclass(frozen=True)
class SkillSpec:
    """One skill as RAPs see it: its name, typed parameters, the predicates it posts, its rate (Hz), whether
    it is always on, where it came from (``stock``, a distribution's name, a plugin file) and its class
    (``code``, ``module:Class``, imported on demand; or ``cls``, given, for a plugin's)."""

    name: str
    code: str
    params: tuple[Param, ...] = ()
    events: tuple[str, ...] = ()
    rate: float = 20.0
    always_on: bool = False
    origin: str = "stock"
    cls: type | None = field(default=None, compare=False, repr=False)

    def load(self) -> type:
        """The class that runs this skill."""
        if self.cls is not None:
            return self.cls
        module, _, name = self.code.partition(":")
        return getattr(importlib.import_module(module), name)


_SENSING, _EVENTS, _MOTION = "atlas_rap.skills.sensing", "atlas_rap.skills.events", "atlas_rap.skills.motion"
_NAVIGATION, _CAMERA, _HANDLING = "atlas_rap.skills.navigation", "atlas_rap.skills.camera", "atlas_rap.skills.handling"

STOCK: tuple[SkillSpec, ...] = (
    SkillSpec("sonar-ring", f"{_SENSING}:SonarSensor", rate=10.0, always_on=True),  # at the world's sonar.rate
    SkillSpec("localiser", "atlas_rap.skills.localising:Localiser", events=("localised", "lost"), always_on=True),
    SkillSpec("bumper", f"{_SENSING}:Bumper", always_on=True),
    SkillSpec("safety-reflex", "atlas_rap.skills.safety:SafetyReflex", always_on=True),
    SkillSpec("drive", f"{_SENSING}:Drive", always_on=True),
    SkillSpec("place-monitor", f"{_EVENTS}:PlaceMonitor", events=("at",), rate=10.0, always_on=True),
    SkillSpec("door-monitor", f"{_EVENTS}:DoorMonitor", events=("door-open", "door-closed", "edge-blocked"),
              rate=10.0, always_on=True),
    SkillSpec("bump-monitor", f"{_EVENTS}:BumpMonitor", events=("bumped",), always_on=True),
    SkillSpec("move-to", f"{_MOTION}:MoveTo", params("x: number", "y: number"), ("blocked",)),
    SkillSpec("follow-route", f"{_MOTION}:FollowRoute", params("waypoints: list"), ("blocked",)),
    SkillSpec("turn-to", f"{_MOTION}:TurnTo", params("heading: number")),
    SkillSpec("wander", f"{_MOTION}:Wander"),
    SkillSpec("wall-follow", f"{_MOTION}:WallFollow", params("side: symbol")),
    SkillSpec("spin", f"{_MOTION}:Spin"),
    SkillSpec("stop", f"{_MOTION}:Stop"),
    SkillSpec("navigate-to", f"{_NAVIGATION}:NavigateTo", params("place: symbol"), ("blocked",)),
    SkillSpec("open-door", f"{_NAVIGATION}:OpenDoor", params("door: symbol"), ("door-open",)),
    SkillSpec("colour-camera", f"{_CAMERA}:ColourCamera", events=("in-view", "seen", "is-a"), rate=10.0,
              always_on=True),
    SkillSpec("look-around", f"{_CAMERA}:LookAround"),
    SkillSpec("approach", f"{_CAMERA}:Approach", params("object: symbol"), ("blocked", "lost")),
    SkillSpec("pick-up", f"{_HANDLING}:PickUp", params("item: symbol"), ("holding",)),
    SkillSpec("drop", f"{_HANDLING}:Drop", params("item: symbol", "bin: symbol"), ("in-bin",)),
)
"""Every stock skill, in the order the skill manager is given them: sensors, reflex, drive, events,
motion, navigation, the colour camera and what it serves, the gripper."""

STOCK_SKILLS: dict[str, set[int]] = {skill.name: {len(skill.params)} for skill in STOCK if not skill.always_on}
"""Stock skills RAPs can enable in a world: name → arities."""

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
        _declare(cls, entry)
        return cls

    return register


def _declare(cls: type, spec: SkillSpec) -> None:
    """Give the class the interface its spec declares (what the skill manager reads)."""
    cls.name, cls.params, cls.events = spec.name, spec.params, spec.events  # type: ignore[attr-defined]
    cls.rate, cls.always_on, cls.origin = spec.rate, spec.always_on, spec.origin  # type: ignore[attr-defined]


def stock_classes() -> list[type]:
    """The class of each stock skill, in :data:`STOCK`'s order (importing the skills' modules)."""
    return [skill.load() for skill in STOCK]


def spec_of(contribution: Contribution, taken: dict[str, SkillSpec]) -> SkillSpec:
    """The spec a plugin's skill class declares, checked against the skills ``taken`` before it (by name).
    Raises :class:`PluginError` naming the plugin and what is wrong."""
    from atlas_rap.skills.skill import Skill

    cls, plugin = contribution.value, contribution.plugin
    if not (isinstance(cls, type) and issubclass(cls, Skill)):
        raise PluginError(f"{plugin}: a skill must be a subclass of atlas_rap.skills.Skill, not {cls!r}")
    what = f"{plugin}: skill class {cls.__qualname__}"
    name = getattr(cls, "name", "")
    if not isinstance(name, str) or not name:
        raise PluginError(f"{what} declares no name (name = \"my-skill\", the symbol RAPs call it by)")
    if not NAME.match(name):
        raise PluginError(f"{what}: name {name!r} is not a RAP symbol (lower case letters, digits, hyphens)")
    if contribution.name != name:  # (a file's skills are named by their classes)
        raise PluginError(f"{what}: the entry point is named {contribution.name!r} but the skill {name!r}; "
                          f"name the entry point as the skill")
    if name in taken:
        other = taken[name]
        owner = f"the stock skill {name}" if other.origin == "stock" else f"the skill {name} from {other.origin}"
        raise PluginError(f"{what}: name {name!r} is already {owner}; choose another name")
    try:
        declared = params(*_sequence(cls.params, "params"))
        events = tuple(str(event) for event in _sequence(cls.events, "events"))
        rate = float(cls.rate)
        if not rate > 0:
            raise ValueError(f"rate must be more than 0 Hz, not {cls.rate!r}")
    except (TypeError, ValueError) as exc:
        raise PluginError(f"{what} ({name}): {exc}") from None
    spec = SkillSpec(name, f"{cls.__module__}:{cls.__qualname__}", declared, events, rate, bool(cls.always_on),
                     contribution.origin, cls)
    _declare(cls, spec)
    return spec


def _sequence(value: object, what: str) -> tuple:
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)):
        raise ValueError(f"{what} must be a tuple, not {value!r}")
    return tuple(value)


def plugin_specs() -> tuple[SkillSpec, ...]:
    """The skills the plugins give (:func:`atlas_rap.plugins.contributions`), in their order, checked."""
    taken = dict(_BY_NAME)
    found = []
    for contribution in contributions("skills"):
        spec = spec_of(contribution, taken)
        taken[spec.name] = spec
        found.append(spec)
    return tuple(found)


def catalog() -> tuple[SkillSpec, ...]:
    """Every skill available: the stock skills, then the plugins'."""
    return STOCK + plugin_specs()


def skill_classes() -> list[type]:
    """The class of every skill available, in :func:`catalog`'s order (importing the stock skills' modules)."""
    return [skill.load() for skill in catalog()]


def param_types(skills: Iterable[Any]) -> dict[str, tuple[Param, ...]]:
    """The declared parameters of ``skills`` (specs, classes or instances: anything with a ``name`` and
    ``params``) by name, for the argument checks of ``atlas check`` and of a run."""
    return {skill.name: params(*skill.params) for skill in skills}


def skill_names() -> dict[str, set[int]]:
    """Skills RAPs can enable in a world, stock and plugin: name → arities (for ``atlas check``)."""
    return {**STOCK_SKILLS, **{skill.name: {len(skill.params)} for skill in plugin_specs() if not skill.always_on}}


def skill_events() -> set[str]:
    """Predicates the skills available may assert, stock and plugin."""
    return STOCK_EVENTS.union(*(skill.events for skill in plugin_specs()))
