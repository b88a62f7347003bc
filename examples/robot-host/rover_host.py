"""A robot's own process serving its own skills to `atlas run --connect` (atlas_rap.host).

The robot here is a fake: a point on a floor that drives where it is told,
with a battery that drains as it drives. On a real robot, `Rover` is your
driver (a ROS 2 node's publishers and action clients, a motor controller's
serial port) and `step` goes: the robot moves in real time by itself.

    python examples/robot-host/rover_host.py --listen tcp/127.0.0.1:7450
    atlas run examples/robot-host/patrol.rap --connect tcp/127.0.0.1:7450 --robot rover

Two skills:

- drive-to X Y (motion): drives the rover to the point at 0.5 m/s; done
  when it is within 5 cm, and (at-point robot X Y) says where it stopped.
- battery (a sensor, always on): (battery robot PERCENT) once a second,
  and (battery-low robot) below 20 %.
"""

from __future__ import annotations

import argparse
import math
import sys

from atlas_rap.host import Compound, Skill, SkillHost

SPEED = 0.5
"""Metres per second the rover drives at."""

ARRIVED = 0.05
"""Metres from the point at which drive-to is done."""


class Rover:
    """The fake robot: where it is, where it is going, its battery. ``step`` moves it."""

    def __init__(self) -> None:
        self.x = self.y = 0.0
        self.vx = self.vy = 0.0
        self.battery = 100.0  # percent; 1 % per metre driven

    def command(self, vx: float, vy: float) -> None:
        self.vx, self.vy = vx, vy

    def step(self, dt: float) -> None:
        self.x += self.vx * dt
        self.y += self.vy * dt
        self.battery = max(0.0, self.battery - math.hypot(self.vx, self.vy) * dt)


class DriveTo(Skill):
    """Drive the rover to (X, Y) in a straight line."""

    name = "drive-to"
    params = ("x: number", "y: number")
    events = ("at-point",)
    rate = 20.0

    def enable(self, args: tuple) -> None:
        super().enable(args)
        self.goal = (float(args[0]), float(args[1]))

    def transform(self, inputs: dict) -> dict:
        rover: Rover = self.context.robot
        dx, dy = self.goal[0] - rover.x, self.goal[1] - rover.y
        distance = math.hypot(dx, dy)
        if distance < ARRIVED:
            rover.command(0.0, 0.0)
            self.context.assert_fact(Compound("at-point", ("robot", *self.args)))
            self.context.finish(self)
        else:
            speed = min(SPEED, distance * self.rate)  # no overshoot in the last period
            rover.command(speed * dx / distance, speed * dy / distance)
        return {}

    def disable(self, reason: str = "") -> None:
        self.context.robot.command(0.0, 0.0)


class Battery(Skill):
    """The battery's charge, once a second; (battery-low robot) below 20 %."""

    name = "battery"
    events = ("battery", "battery-low")
    rate = 1.0
    always_on = True

    def transform(self, inputs: dict) -> dict:
        percent = round(self.context.robot.battery)
        self.context.assert_fact(Compound("battery", ("robot", percent)))  # the mission keeps the latest
        if percent < 20:
            self.context.assert_fact(Compound("battery-low", ("robot",)))
        return {}


ATLAS_SKILLS = [DriveTo, Battery]
"""The skills, for atlas's --plugin: atlas check patrol.rap --plugin rover_host.py checks the mission
against them without the host running."""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--listen", action="append", default=[], help="Zenoh endpoint (default tcp/127.0.0.1:7447)")
    parser.add_argument("--token-file", help="the host's token file (default: one per robot, printed at start)")
    args = parser.parse_args(argv)
    try:  # Ctrl-C, whenever it comes: the host leaves the bus (its token goes) and the process exits 130
        with SkillHost("rover", ATLAS_SKILLS, body=Rover(), facts=["(at-point robot 0 0)"],
                       listen=args.listen, token_file=args.token_file) as host:
            if host.exposure:
                print(host.exposure, file=sys.stderr)
            print(f"skill host for robot rover on {', '.join(host.endpoints)} (Ctrl-C to stop)")
            print(f"token: {host.token_source}", flush=True)
            host.serve(on_session=lambda text: print(f"robot rover: {text}", flush=True))
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
