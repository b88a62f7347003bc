"""The robot's prior map as RAP memory facts.

What the robot knows of a world before it moves: its named places and the
doors between them (not the walls: those it senses). A mission in a world
starts with these facts in memory, so RAPs can reason about routes:

- ``(place NAME)`` for each place;
- ``(door DOOR A B)`` and ``(door DOOR B A)`` for each doorway between places A and B;
- ``(connected A B)`` and ``(connected B A)`` for each pair of places a doorway joins;
- ``(openable DOOR)`` for each door the robot can open itself.

Door states are not prior knowledge: the door monitor asserts
``(door-open D)`` / ``(door-closed D)`` when the sonar sees them, and
``(edge-blocked A B)`` (both ways) while the only door it knows between A
and B is closed.
"""

from __future__ import annotations

from atlas_rap.logic import Compound
from atlas_rap.model import World


def prior_facts(world: World) -> list[Compound]:
    """The facts above, in the world file's order."""
    facts = [Compound("place", (name,)) for name in world.places]
    for door in world.doors.values():
        a, b = door.between
        facts.append(Compound("door", (door.name, a, b)))
        facts.append(Compound("door", (door.name, b, a)))
        for pair in ((a, b), (b, a)):
            connected = Compound("connected", pair)
            if connected not in facts:
                facts.append(connected)
        if door.openable:
            facts.append(Compound("openable", (door.name,)))
    return facts
