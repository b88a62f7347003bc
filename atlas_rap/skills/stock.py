"""The skills every simulated robot has, and the manager that runs them."""

from __future__ import annotations

from typing import Any

from atlas_rap.skills.beliefs import OBJECTS
from atlas_rap.skills.catalog import STOCK_EVENTS, STOCK_SKILLS, stock_classes
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.skill import Skill


def stock_skills() -> list[Skill]:
    """One fresh instance of each stock skill, in the catalog's order: sensors, reflex, events, motion,
    navigation, the colour camera and what it serves, the gripper."""
    return [skill_class() for skill_class in stock_classes()]


def stock_manager(world: Any, robot: Any, rng: Any = None) -> SkillManager:
    """A skill manager with the stock skills for ``robot`` in ``world`` (what the robot
    believes of it: the true world, or only its places with no prior map). Mapping is
    not a skill: ATLAS Layer IV builds the grid (``atlas_rap.layers.strategic``).

    A simulated robot in a world with objects gets a camera and a gripper on them
    (:class:`atlas_rap.sim.objects.ObjectSim`, under the ``OBJECTS`` belief); the world
    they see is the robot's true one (``robot.world``), not what it believes."""
    manager = SkillManager(stock_skills(), world=world, robot=robot, rng=rng)
    truth = getattr(robot, "world", None)
    if getattr(truth, "objects", None):
        from atlas_rap.sim.objects import ObjectSim  # the simulated devices, only where there is something to see

        manager.context.beliefs[OBJECTS] = ObjectSim(truth, robot)
    return manager


def stock_skill_names() -> dict[str, set[int]]:
    """The stock skills RAPs can enable: name → arity (for checking files without a world)."""
    return {name: set(arities) for name, arities in STOCK_SKILLS.items()}


def stock_events() -> set[str]:
    """Predicates the stock skills may assert."""
    return set(STOCK_EVENTS)
