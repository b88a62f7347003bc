"""The skills every simulated robot has (the stock skills and the plugins'), and the manager that runs them."""

from __future__ import annotations

from typing import Any

from atlas_rap.skills.beliefs import OBJECTS
from atlas_rap.skills.catalog import skill_classes
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.skill import Skill


def stock_skills() -> list[Skill]:
    """One fresh instance of each skill available, in the catalog's order: the stock skills (sensors, reflex,
    events, motion, navigation, the colour camera and what it serves, the gripper), then the plugins'."""
    return [skill_class() for skill_class in skill_classes()]


def stock_manager(world: Any, robot: Any, rng: Any = None) -> SkillManager:
    """A skill manager with the stock and plugin skills for ``robot`` in ``world`` (what the robot
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
