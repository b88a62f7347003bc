"""Running a mission in a simulated world in-process, as `atlas run` does, for tests."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from atlas_rap.layers import MissionEngine, RunOptions, RunResult
from atlas_rap.sequencer import Trace, agenda_tree, tree_text

REPO = Path(__file__).resolve().parent.parent
NAVIGATION = REPO / "rap_library" / "navigation.rap"


@dataclass
class WorldRun:
    mission: MissionEngine
    result: RunResult

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
    engine = MissionEngine(RunOptions(world=world, seed=seed), trace=Trace(keep=True))
    engine.load_file(mission_file, require_post=True)
    return WorldRun(engine, engine.run_mission(until))


def go_to_mission(tmp_path: Path, *places: str, world: str | None = None) -> Path:
    """A mission file that goes to each place in turn (with the shipped navigation RAPs)."""
    steps = " ".join(f"(t{i} (go-to {place}))" for i, place in enumerate(places, 1))
    world_form = f'(world "{world}")' if world else ""
    path = tmp_path / "go.rap"
    path.write_text(f'(include "{NAVIGATION}")\n{world_form}\n'
                    f"(define-rap (tour) (method (task-net (sequence {steps}))))\n(post (tour))\n", encoding="utf-8")
    return path
