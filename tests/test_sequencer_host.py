"""The sequencer's parts see the interpreter through narrow host protocols, and ``Sequencer`` satisfies them."""

from __future__ import annotations

import inspect

import pytest

from atlas_rap.sequencer import Sequencer
from atlas_rap.sequencer.host import Knowledge, PlanHost, Subtasks, Watching
from atlas_rap.sequencer.net import NetHost, SkillResources


def members(protocol: type) -> set[str]:
    """The names a protocol declares, its bases' included (attributes and methods)."""
    found: set[str] = set()
    for cls in protocol.__mro__:
        if cls is object or not getattr(cls, "_is_protocol", False) or cls.__module__ == "typing":
            continue
        found.update(getattr(cls, "__annotations__", {}))
        found.update(name for name, value in vars(cls).items() if not name.startswith("_") and callable(value))
    return found


@pytest.mark.parametrize("protocol", [Knowledge, Subtasks, Watching, PlanHost, SkillResources, NetHost])
def test_a_sequencer_has_every_member_of_each_host_protocol(protocol):
    seq = Sequencer()
    missing = sorted(name for name in members(protocol) if not hasattr(seq, name))
    assert not missing, f"Sequencer lacks {missing} of {protocol.__name__}"


def test_each_method_of_the_host_protocols_takes_what_the_sequencer_takes():
    for protocol in (PlanHost, NetHost):
        for name in members(protocol):
            declared = getattr(protocol, name, None)
            if not inspect.isfunction(declared):
                continue
            wanted = list(inspect.signature(declared).parameters)
            offered = list(inspect.signature(getattr(Sequencer, name)).parameters)
            assert wanted == offered, f"{protocol.__name__}.{name}{wanted} vs Sequencer.{name}{offered}"


def test_the_hosts_are_narrow_parts_of_the_sequencer():
    public = {name for name in dir(Sequencer()) if not name.startswith("_")}
    assert members(NetHost) < public and members(PlanHost) < public
    assert len(members(PlanHost)) <= 11 and len(members(NetHost)) <= 17, (members(PlanHost), members(NetHost))
