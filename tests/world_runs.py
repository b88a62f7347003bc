"""Running a mission in a simulated world in-process, as `atlas run` does, for tests."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from atlas_rap.layers.setup import WorldSetup
from atlas_rap.sequencer import Mission, RunResult, Trace, agenda_tree, tree_text

REPO = Path(__file__).resolve().parent.parent
NAVIGATION = REPO / "rap_library" / "navigation.rap"


@dataclass
class WorldRun:
    mission: Mission
    result: RunResult
    setup: WorldSetup

    @property
    def records(self) -> list[dict]:
        return self.mission.trace.records

    def facts(self, event: str) -> list[str]:
        """The facts asserted (or retracted) in order, e.g. ``facts("fact-asserted")``."""
        return [r["fact"] for r in self.records if r["event"] == event]

    def explain(self) -> str:
        """What to print when a test fails: how the run ended and the task tree."""
        return f"ended by {self.result.ended_by} at t={self.result.time:g}\n" + tree_text(
            agenda_tree(self.mission.sequencer))


def run_in_world(mission_file: str | Path, world: str | None = None, seed: int = 0, until: float = 600.0) -> WorldRun:
    """Load and run a mission in its world (or ``world``), keeping the whole trace."""
    setup = WorldSetup(world, seed)
    mission = setup.load_mission(mission_file, trace=Trace(keep=True))
    result = mission.run(until=until, driver=setup.executive)
    return WorldRun(mission, result, setup)


def go_to_mission(tmp_path: Path, *places: str, world: str | None = None) -> Path:
    """A mission file that goes to each place in turn (with the shipped navigation RAPs)."""
    steps = " ".join(f"(t{i} (go-to {place}))" for i, place in enumerate(places, 1))
    world_form = f'(world "{world}")' if world else ""
    path = tmp_path / "go.rap"
    path.write_text(f'(include "{NAVIGATION}")\n{world_form}\n'
                    f"(define-rap (tour) (method (task-net (sequence {steps}))))\n(post (tour))\n", encoding="utf-8")
    return path
