"""The Zenoh key expressions of the skill bus: one tree per robot.

::

    atlas/<robot>/skill/<name>/enable     sequencer → host: turn a skill on
    atlas/<robot>/skill/<name>/disable    sequencer → host: turn it off
    atlas/<robot>/clock/tick              sequencer → host: advance to t
    atlas/<robot>/clock/ack               host → sequencer: reached t (or did what was asked)
    atlas/<robot>/event/done              host → sequencer: a skill finished (with why)
    atlas/<robot>/event/facts             host → sequencer: facts asserted or retracted
    atlas/<robot>/event/note              host → sequencer: a trace record of the host's layers
    atlas/<robot>/sequencer/ack           sequencer → host: changes taken (and memory since)
    atlas/<robot>/sequencer/hello         sequencer → host: start a session
    atlas/<robot>/session/welcome         host → sequencer: the host's world and skills
    atlas/<robot>/host                    liveliness token of the robot's skill host
    atlas/<robot>/sequencer/<session>     liveliness token of the sequencer using it

Anyone can watch a robot: ``atlas/<robot>/event/**`` are its events,
``atlas/<robot>/clock/**`` its clock, ``atlas/*/host`` the hosts alive.
"""

from __future__ import annotations

import re

ROOT = "atlas"
DEFAULT_ROBOT = "robot"
"""The robot's name when none is given: the name the stock skills' facts use, ``(at robot lab)``."""

_NAME = re.compile(r"^[a-z0-9][a-z0-9_-]*$")


def check_robot(name: str) -> str:
    """``name`` if it can be a robot's name (a lower-case symbol that is one key chunk); else ValueError."""
    if not _NAME.match(name):
        raise ValueError(f"robot name {name!r}: use lower-case letters, digits, - and _ (it is a symbol in "
                         f"facts and a chunk of Zenoh keys)")
    return name


def skill(robot: str, name: str, what: str) -> str:
    """``atlas/<robot>/skill/<name>/<what>`` (``what``: enable or disable)."""
    return f"{ROOT}/{robot}/skill/{name}/{what}"


def clock(robot: str, what: str) -> str:
    return f"{ROOT}/{robot}/clock/{what}"


def event(robot: str, what: str) -> str:
    return f"{ROOT}/{robot}/event/{what}"


def sequencer(robot: str, what: str) -> str:
    return f"{ROOT}/{robot}/sequencer/{what}"


def session(robot: str, what: str) -> str:
    return f"{ROOT}/{robot}/session/{what}"


def host_token(robot: str) -> str:
    """The liveliness token a skill host holds while it runs."""
    return f"{ROOT}/{robot}/host"


def sequencer_token(robot: str, session: str = "*") -> str:
    """The liveliness token a sequencer holds while its session with the robot's host lasts."""
    return f"{ROOT}/{robot}/sequencer/{session}"


def to_host(robot: str) -> list[str]:
    """What a host subscribes to: everything the sequencer sends it."""
    return [f"{ROOT}/{robot}/skill/**", clock(robot, "tick"), f"{ROOT}/{robot}/sequencer/**"]


def to_sequencer(robot: str) -> list[str]:
    """What a sequencer subscribes to for one robot: everything its host sends."""
    return [f"{ROOT}/{robot}/event/**", clock(robot, "ack"), f"{ROOT}/{robot}/session/**"]
