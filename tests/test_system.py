"""The run as a typed System: each of the three backends built from RunOptions alone, and what the
options ask for reaching the parts (issue 26). The remote backend is built against a real skill host
(`atlas skills serve` in its own process, over Zenoh on loopback)."""

from __future__ import annotations

import pytest
from bus_processes import RUNTIME, Running, free_port, processes  # noqa: F401  (processes: a fixture)

from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.layers.builders import BUILDERS, backend_for, build_system
from atlas_rap.layers.executive import Executive, VirtualExecutive
from atlas_rap.layers.remote import RemoteExecutive
from atlas_rap.layers.system import NamedWorld, WorldChoice, choose_world
from atlas_rap.sequencer import Trace
from atlas_rap.skills.robot import Robot
from atlas_rap.skills.virtual import VirtualSkills


def _no_planning(goals, lost=frozenset()):
    raise AssertionError("nothing is planned while the system is built")


def test_a_world_here_is_a_simulated_body_with_the_stock_skills_the_layers_and_the_executive():
    options = RunOptions(world="lab-corridor-office", seed=4, prior_map=False)
    system = build_system(options, WorldChoice(choose_world(options, None)), Trace(), VirtualSkills(), _no_planning)
    assert backend_for(options, "lab-corridor-office") == "simulated"
    assert system.world is not None and system.world.name == "lab-corridor-office"
    assert system.robot is system.simulation and isinstance(system.robot, Robot)
    assert system.simulation.dt == pytest.approx(1.0 / options.rates.physics)
    assert system.believed is not None and not system.believed.doors  # --no-prior-map: names and points only
    assert isinstance(system.driver, Executive)
    assert system.stack is not None and "IV" in system.stack.layers  # it maps while driving
    assert system.manager is not None and system.sequencer.deliberator is system.deliberation
    assert system.remote is None


def test_no_world_is_the_virtual_skills_and_the_timers_alone():
    options = RunOptions(world="none")
    virtual = VirtualSkills()
    system = build_system(options, WorldChoice("none"), Trace(), virtual, _no_planning)
    assert backend_for(options, "none") == "virtual"
    assert system.world is None and system.world_name == "none"
    assert system.skills is virtual and system.robot is None and system.stack is None
    assert isinstance(system.driver, VirtualExecutive)


def test_choosing_the_world_is_pure_and_the_world_flag_wins():
    assert choose_world(RunOptions(), None) == "lab-corridor-office"
    assert choose_world(RunOptions(default_world="none"), None) == "none"
    assert choose_world(RunOptions(world="maze"), None) == "maze"
    assert set(BUILDERS) == {"simulated", "virtual", "remote"}


def test_the_skill_hosts_over_the_bus_are_a_named_world_and_the_lock_step_executive(processes, tmp_path,
                                                                                     monkeypatch):
    pytest.importorskip("zenoh")
    monkeypatch.setenv("ATLAS_RUNTIME_DIR", RUNTIME)  # where the host leaves the token this process reads
    from atlas_rap.skillbus.remote import BusSettings

    port = free_port()
    host = Running("skills", "serve", "--listen", f"tcp/127.0.0.1:{port}", cwd=tmp_path)
    processes.append(host)
    host.wait_for("skill host for robot robot")
    options = RunOptions(bus=BusSettings(endpoints=(f"tcp/127.0.0.1:{port}",)))
    engine = MissionEngine(options)
    system = engine.ensure_system()
    try:
        assert backend_for(options, "lab-corridor-office") == "remote"
        assert system.world == NamedWorld("lab-corridor-office")
        assert system.remote is not None and isinstance(system.driver, RemoteExecutive)
        assert system.robot is None and system.simulation is None and system.stack is None
        assert "navigate-to" in system.skills.skills()
    finally:
        system.remote.close()


GREET = """(define-virtual-skill (say ?what) (after 1.0 (assert (said ?what)) (finish :succeed)))
(define-rap (greet) (succeed (said hello)) (method (task-net (sequence (t1 (say hello))))))
(initial-memory (awake))
(post (greet))
"""


def test_checking_defining_and_posting_are_each_callable_alone_over_a_system_and_a_library():
    from atlas_rap.errors import SourceError
    from atlas_rap.lang import load_text
    from atlas_rap.layers import running
    from atlas_rap.layers.library import Library, act, check, define
    from atlas_rap.logic import Compound

    options = RunOptions(world="none")
    system = build_system(options, WorldChoice("none"), Trace(), VirtualSkills(), _no_planning)
    library = Library()
    program = load_text(GREET, "<greet>")
    with pytest.raises(SourceError, match="say"):  # the virtual skill is not defined yet: nothing takes effect
        check(system, library, load_text("(post (say hello))", "<early>"), require_post=True)
    assert check(system, library, program, require_post=True) == []
    assert sorted(define(system, library, program)) == ["greet", "say"]
    assert ("RapDef", "greet", 0) in library.definitions and "<greet>" in library.files
    (task,) = act(system, program)
    assert Compound("awake", ()) in system.sequencer.memory
    assert running.run(system, 10.0) == running.RunEnd.DONE == "done"
    result = running.finish(system, running.RunEnd.DONE)
    assert result.ok and result.tasks == [task] and result.time == pytest.approx(1.0, abs=0.2)
