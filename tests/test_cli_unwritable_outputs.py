"""Every output of every command that cannot be written is a one-line error before the work starts,
and whatever was at that path stays as it was: a read-only folder, /proc, a path under a file,
/dev/full, the command's own input. An output that fails after a run comes after the run's summary.

A read-only folder is a read-only bind mount in a private mount namespace (`unshare -m`): these
tests run as root (as CI does), for whom a folder without write permission is still writable.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

OLD = b"an existing file, which must not change\n"
MISSION = """(include "{operators}")
(world none)
(initial-memory (at robot dock) (holding robot filter) (ferrous-hull hull-3) (gripper-ok))
(post (visit-site hull-3 filter))
"""


def in_read_only_folder(folder: Path, args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``atlas ARGS`` with ``folder`` mounted read-only (a private mount namespace: nothing else sees it)."""
    command = ["unshare", "-m", "sh", "-c", 'mount --bind -o ro "$0" "$0" && exec "$@"', str(folder),
               *atlas_command(*args)]
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, env=ENV, timeout=120)


@pytest.fixture
def inputs(tmp_path: Path) -> Path:
    """A folder with each command's inputs: a mission, a goals file and its operators, a map, a world,
    a grid, a recording (made by atlas run --record), rules for the layers."""
    (tmp_path / "space-station.rap").write_text(
        (REPO / "rap_library" / "space-station.rap").read_text(encoding="utf-8"), encoding="utf-8")
    (tmp_path / "m.rap").write_text(MISSION.format(operators="space-station.rap"), encoding="utf-8")
    for name in ("office-goals.ap", "office.ap"):
        shutil.copy(REPO / "operators" / name, tmp_path / name)
    for name in ("small-office-map.yaml", "small-office-map.pgm"):
        shutil.copy(REPO / "worlds" / "maps" / name, tmp_path / name)
    shutil.copy(REPO / "worlds" / "lab-corridor-office.yaml", tmp_path / "world.yaml")
    (tmp_path / "grid.npz").write_bytes(OLD)
    (tmp_path / "rules.rap").write_bytes(OLD)
    return tmp_path


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("recording")
    mission = folder / "m.rap"
    mission.write_text(MISSION.format(operators=REPO / "rap_library" / "space-station.rap"), encoding="utf-8")
    done = atlas("run", str(mission), "-q", "--record", "run.mcap", cwd=folder)
    assert done.returncode == 0, done.stderr
    return folder / "run.mcap"


@dataclass(frozen=True)
class Output:
    """One output option of one command: its arguments given the output's path, the name of a file
    it writes there (for a folder: in it), and the same command with that output on its own input."""

    args: Callable[[str], list[str]]
    name: str
    own_input: tuple[list[str], str]  # (the arguments, the input they would overwrite)
    folder: bool = False


OUTPUTS = {
    "run --trace": Output(lambda out: ["run", "m.rap", "-q", "--trace", out], "t.jsonl",
                          (["run", "m.rap", "-q", "--trace", "m.rap"], "m.rap")),
    "run --render": Output(lambda out: ["run", "m.rap", "-q", "--render", out], "run.png",
                           (["run", "m.rap", "-q", "--render", "space-station.rap"], "space-station.rap")),
    "run --map-out": Output(lambda out: ["run", "m.rap", "-q", "--no-prior-map", "--map-out", out], "grid.npz",
                            (["run", "m.rap", "--map-in", "grid.npz", "--map-out", "grid.npz"], "grid.npz")),
    "run --record": Output(lambda out: ["run", "m.rap", "-q", "--record", out], "run.mcap",
                           (["run", "m.rap", "-q", "--record", "m.rap"], "m.rap")),
    "repl --trace": Output(lambda out: ["repl", "--trace", out], "t.jsonl",
                           (["repl", "m.rap", "--trace", "m.rap"], "m.rap")),
    "repl --map-out": Output(lambda out: ["repl", "--no-prior-map", "--map-out", out], "grid.npz",
                             (["repl", "--map-in", "grid.npz", "--map-out", "grid.npz"], "grid.npz")),
    "plan --plan-file": Output(lambda out: ["plan", "office-goals.ap", "--plan-file", out], "plan.txt",
                               (["plan", "office-goals.ap", "--plan-file", "office.ap"], "office.ap")),
    "plan --render": Output(lambda out: ["plan", "office-goals.ap", "--json", "--render", out], "plan.png",
                            (["plan", "office-goals.ap", "--render", "office-goals.ap"], "office-goals.ap")),
    "plan --render-order": Output(lambda out: ["plan", "office-goals.ap", "--render-order", out], "order.png",
                                  (["plan", "office-goals.ap", "--render-order", "office.ap"], "office.ap")),
    "map build --out": Output(lambda out: ["map", "build", "--out", out], "occupancy.npz",
                              (["map", "build", "--world", "levels/occupancy.yaml", "--out", "levels"],
                               "levels/occupancy.yaml"), folder=True),
    "map abstract --out": Output(lambda out: ["map", "abstract", "small-office-map.yaml", "--out", out], "grid.npz",
                                 (["map", "abstract", "levels/grid.yaml", "--out", "levels"], "levels/grid.png"),
                                 folder=True),
    "map render --out": Output(lambda out: ["map", "render", "small-office-map.yaml", "--out", out], "map.png",
                               (["map", "render", "small-office-map.yaml", "--out", "small-office-map.pgm"],
                                "small-office-map.pgm")),
    "record show --out": Output(lambda out: ["record", "show", "run.mcap", "--out", out], "run.png",
                                (["record", "show", "run.mcap", "--out", "run.mcap"], "run.mcap")),
    "experiment --out": Output(lambda out: ["experiment", "skill-acquisition", "--runs", "1", "--out", out],
                               "figures.json",
                               (["experiment", "skill-acquisition", "--layer-rules", "levels/errand.rap",
                                 "--out", "levels"], "levels/errand.rap"), folder=True),
    "skills serve --record": Output(lambda out: ["skills", "serve", "--record", out], "host.mcap",
                                    (["skills", "serve", "--world", "world.yaml", "--record", "world.yaml"],
                                     "world.yaml")),
}

KINDS = ["a read-only folder", "a path in /proc", "a path under a file", "/dev/full", "its own input"]
"""For a folder output, /dev/full is a file where a folder is wanted."""


def unwritable(kind: str, output: Output, cwd: Path) -> tuple[subprocess.CompletedProcess, Path | None, int]:
    """Run the command with its output on an unwritable path of ``kind``: (what it did, the file
    that must stay unchanged (None: nothing can change there), the exit code it must give)."""
    if kind == "a read-only folder":
        folder = cwd / "locked"
        folder.mkdir()
        existing = folder / output.name
        existing.write_bytes(OLD)
        path = folder if output.folder else existing
        return in_read_only_folder(folder, output.args(str(path.relative_to(cwd))), cwd), existing, 1
    if kind == "a path in /proc":
        return atlas(*output.args(f"/proc/atlas-{output.name}"), cwd=cwd), None, 1
    if kind == "a path under a file":
        blocking = cwd / "afile"
        blocking.write_bytes(OLD)
        return atlas(*output.args(f"afile/{output.name}"), cwd=cwd), blocking, 1
    if kind == "/dev/full":
        return atlas(*output.args("/dev/full"), cwd=cwd), None, 1
    args, own = output.own_input
    return atlas(*args, cwd=cwd), cwd / own, 2


def prepare_own_inputs(cwd: Path, recording_file: Path) -> None:
    """The inputs that the own-input cases name inside an output folder, and the recording."""
    shutil.copy(recording_file, cwd / "run.mcap")
    levels = cwd / "levels"
    levels.mkdir()
    shutil.copy(cwd / "world.yaml", levels / "occupancy.yaml")  # a world file where map build writes its grid
    (levels / "errand.rap").write_bytes(OLD)  # layer rules where the experiment writes its mission
    from atlas_rap.maps.rosmap import load_ros_map, write_ros_map

    rosmap = load_ros_map(cwd / "small-office-map.yaml")  # a map whose image is where the levels' grid.png go
    write_ros_map(levels / "grid.yaml", rosmap.labels, rosmap.resolution, rosmap.origin, image_format="png")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("option", list(OUTPUTS))
def test_an_unwritable_output_is_a_one_line_error_and_changes_nothing(inputs, recording, option, kind):
    output = OUTPUTS[option]
    prepare_own_inputs(inputs, recording)
    kept = {path: path.read_bytes() for path in inputs.rglob("*") if path.is_file()}
    done, unchanged, code = unwritable(kind, output, inputs)
    assert_no_traceback(done)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert done.returncode == code, done.stderr
    assert lines[0].startswith(("--", ":")), lines[0]  # it names the option
    if unchanged is not None:
        assert unchanged.read_bytes() == kept.get(unchanged, OLD)
    for path, content in kept.items():  # nothing else was touched either
        assert path.read_bytes() == content, path
    assert not [p for p in inputs.rglob("*.part")], "a temporary file was left behind"
