"""Handling skills: picking trash up and dropping it into bins (Chip's manipulator, seed 003 §4).

Both work through the robot's :data:`~atlas_rap.skills.beliefs.OBJECTS`
devices (in a simulated world, :mod:`atlas_rap.sim.objects`), stand the
robot still while the gripper works, and finish as the other skills do,
with ``(done (SKILL ARG ...) OUTCOME)`` and, on failure, ``(why (SKILL ARG
...) "reason")``:

- ``(pick-up ITEM)``: when the gripper is empty and ITEM (trash, lying on
  the floor) is within :attr:`PickUp.reach` of the robot's centre, after
  :attr:`PickUp.duration` the item is in the gripper and moves with the
  robot; asserts ``(holding robot ITEM)`` and retracts ``(seen ITEM ...)``
  and ``(in-view ITEM ...)`` (the camera does not see what the gripper
  holds). Out of reach, a bin, already in a bin, the gripper full: it
  fails at once saying so.
- ``(drop ITEM BIN)``: when the gripper holds ITEM and the bin BIN is
  within :attr:`Drop.reach`, after :attr:`Drop.duration` the item is in
  the bin; asserts ``(in-bin ITEM BIN)`` and retracts ``(holding robot
  ITEM)``. Otherwise it fails at once saying why.

Counting what is in the bins is the RAPs' business (``rap_library/trash.rap``).
"""

from __future__ import annotations

from typing import Any, Mapping

from atlas_rap.logic import Compound, Var
from atlas_rap.skills.beliefs import OBJECTS, SIGHTINGS
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.skill import Skill

NO_GRIPPER = "this robot has no gripper: its world has no objects"


class _Handling(Skill):
    """A gripper action: check, stand still for ``duration`` seconds, act."""

    inputs = ("pose",)
    outputs = ("command",)
    duration = 1.0
    reach = 0.6

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.started: float | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        context = self.context
        devices = context.beliefs.get(OBJECTS)
        why = NO_GRIPPER if devices is None else self.why_not(devices)
        if why is not None:
            context.finish(self, ":fail", why)
            return {"command": (0.0, 0.0)}
        now = context.now()
        if self.started is None:
            self.started = now
        if now - self.started + 1e-9 < self.duration:
            return {"command": (0.0, 0.0)}
        why = self.act(devices)
        if why is not None:
            context.finish(self, ":fail", why)
        else:
            context.finish(self)
        return {"command": (0.0, 0.0)}

    def why_not(self, devices: Any) -> str | None:
        """Why the action cannot be done now (None: it can)."""
        raise NotImplementedError

    def act(self, devices: Any) -> str | None:
        """Do it, post its facts; None when done, else why not."""
        raise NotImplementedError


@registered("pick-up")
class PickUp(_Handling):
    """``(pick-up ITEM)``: take a piece of trash within reach into the empty gripper."""

    duration = 1.0  # seconds the gripper takes to close on the item
    reach = 0.6

    def why_not(self, devices: Any) -> str | None:
        return devices.why_not_pick_up(str(self.args[0]), self.reach)

    def act(self, devices: Any) -> str | None:
        item = str(self.args[0])
        why = devices.pick_up(item, self.reach)
        if why is None:
            context = self.context
            context.retract_matching(Compound("seen", (item, Var("colour"), Var("place"))))
            context.retract_matching(Compound("in-view", (item, Var("colour"))))
            context.assert_fact(Compound("holding", ("robot", item)))
            (context.beliefs.get(SIGHTINGS) or {}).pop(item, None)
        return why


@registered("drop")
class Drop(_Handling):
    """``(drop ITEM BIN)``: drop the item in the gripper into a bin within reach."""

    duration = 1.0  # seconds the gripper takes to let go over the bin
    reach = 0.8

    def why_not(self, devices: Any) -> str | None:
        return devices.why_not_drop(str(self.args[0]), str(self.args[1]), self.reach)

    def act(self, devices: Any) -> str | None:
        item, bin_name = str(self.args[0]), str(self.args[1])
        why = devices.drop(item, bin_name, self.reach)
        if why is None:
            self.context.retract_fact(Compound("holding", ("robot", item)))
            self.context.assert_fact(Compound("in-bin", (item, bin_name)))
        return why
