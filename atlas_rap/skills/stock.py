"""The skills every simulated robot has, and the manager that runs them."""

from __future__ import annotations

from typing import Any

from atlas_rap.skills.beliefs import OBJECTS
from atlas_rap.skills.camera import Approach, ColourCamera, LookAround
from atlas_rap.skills.events import BumpMonitor, DoorMonitor, PlaceMonitor
from atlas_rap.skills.handling import Drop, PickUp
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.motion import FollowRoute, MoveTo, Stop, TurnTo, Wander, WallFollow
from atlas_rap.skills.navigation import NavigateTo, OpenDoor
from atlas_rap.skills.safety import SafetyReflex
from atlas_rap.skills.sensing import Bumper, Drive, Odometry, SonarSensor
from atlas_rap.skills.skill import Skill


def stock_skills() -> list[Skill]:
    """One fresh instance of each stock skill: sensors, reflex, events, motion, navigation,
    the colour camera and what it serves, the gripper."""
    return [SonarSensor(), Odometry(), Bumper(), SafetyReflex(), Drive(),
            PlaceMonitor(), DoorMonitor(), BumpMonitor(),
            MoveTo(), FollowRoute(), TurnTo(), Wander(), WallFollow(), Stop(),
            NavigateTo(), OpenDoor(),
            ColourCamera(), LookAround(), Approach(), PickUp(), Drop()]


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
    return SkillManager(stock_skills()).skills()


def stock_events() -> set[str]:
    """Predicates the stock skills may assert."""
    return SkillManager(stock_skills()).produces()
