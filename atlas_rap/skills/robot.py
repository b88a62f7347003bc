"""The body the skills drive: what a skill may ask of a robot, simulated or real.

:class:`Robot` names it as a Protocol, so a real robot's driver can stand in
for :class:`atlas_rap.sim.physics.Simulation` without inheriting from it (the
simulation satisfies it structurally). Skills reach the body through
``SkillContext.robot`` and nothing else.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Pose", "Robot"]

Pose = tuple[float, float, float]
"""(x, y, heading): metres and radians, heading in (-pi, pi]."""


@runtime_checkable
class Robot(Protocol):
    """What skills may ask of a body: its odometry, its sonar and bumper, a drive command, doors.

    Not its true pose: a real robot has none to give, and a simulator's
    (``Simulation.pose``, ROS's ``/ground_truth``) is for evaluation only.
    Where the robot is, the skills learn from the localiser
    (:mod:`atlas_rap.skills.localising`). The same names and meanings as
    ROS's usual topics: ``odometry`` is the dead-reckoned pose (``/odom``),
    ``sonar()`` one reading of the ring
    (``sensor_msgs/Range`` per transducer), ``command`` a body-frame
    velocity (``/cmd_vel``).
    """

    @property
    def time(self) -> float:
        """The body's clock: simulated seconds since the start."""
        ...

    @property
    def odometry(self) -> Pose:
        """The pose as dead reckoning has it (drifts when the world says so)."""
        ...

    @property
    def sonar_angles(self) -> np.ndarray:
        """Body-frame angles of the sonar transducers (0 forward, counter-clockwise)."""
        ...

    def sonar(self) -> np.ndarray:
        """The ring's ranges now, in metres (the maximum range where there is no echo)."""
        ...

    @property
    def bumped(self) -> bool:
        """Whether the body touched something during the last step."""
        ...

    @property
    def bump_angle(self) -> float | None:
        """Body-frame direction of the last step's contact, or None without one."""
        ...

    def command(self, v: float, omega: float) -> None:
        """Drive at forward speed ``v`` (m/s) and turn rate ``omega`` (rad/s)."""
        ...

    def set_door(self, name: str, open: bool) -> None:
        """Open or close the door ``name`` (a robot that opens doors; KeyError for an unknown door)."""
        ...
