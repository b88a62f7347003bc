"""``atlas experiment``: the seed papers' experiments, each as one command."""

from __future__ import annotations

import sys

import click

from atlas_rap.cli.options import SEED, OutputFolder


@click.group("experiment")
def experiment_group() -> None:
    """Reproduce the experiments of the seed papers."""


@experiment_group.command("skill-acquisition")
@click.option("--runs", type=click.IntRange(1, 50), default=7, show_default=True,
              help="Errands from the lab to the office and back, the map carried from run to run.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of every run.")
@click.option("--world", "world", default="lab-corridor-office", show_default=True, metavar="W",
              help="The world of the runs: a shipped world's name or a world file, with places named lab and "
                   "office.")
@click.option("--obstacles", "obstacles", default="lab-corridor-office-obstacles", show_default=True, metavar="W",
              help="The world of the obstacle scenario, run on the last run's map ('none': skip it).")
@click.option("--layer-rules", "layer_rules", type=click.Path(dir_okay=False, exists=True), metavar="RULES.rap",
              help="Memory rules that choose the primary layer (default: the shipped rap_library/layers.rap).")
@click.option("--localisation", "localisation", type=click.Choice(["mcl", "odometry"]), default="mcl",
              show_default=True,
              help="How the robot knows where it is: its odometry corrected against the map it builds and "
                   "carries (mcl), or its odometry alone (dead reckoning, to compare).")
@click.option("--out", "out_dir", required=True, type=OutputFolder(writes=lambda: _result_files()),
              help="Folder for the results and figures.")
def skill_acquisition_command(runs: int, seed: int, world: str, obstacles: str, layer_rules: str | None,
                              localisation: str, out_dir: str) -> None:
    """The ATLAS paper's skill-acquisition experiment (seed 000 §5.2, Figs. 12 and 13).

    A robot with no prior map drives from the lab to the office and back,
    RUNS times, carrying its occupancy grid from run to run: Layer IV maps
    while the map is poor, Layer II follows the route once it is good. Then
    a person crosses its way and a box blocks it. Writes figures.json,
    runs.csv, the grid of each run (map-runN.npz) and the figures as PNG:
    map quality per run (Fig. 12a), durations against the optimal time (12b),
    the primary layer per run (13a) and in the obstacle scenario (13b).

    Ctrl-C stops the whole experiment: what it has is written, marked
    incomplete ("complete": false in figures.json, and on every figure),
    then it exits 130.
    """
    import time

    from rich.progress import Progress

    from atlas_rap.cli.console import console
    from atlas_rap.views.experiment import Settings, skill_acquisition, write_results
    from atlas_rap.outputs import naming, write_all

    settings = Settings(world=world, runs=runs, seed=seed, obstacles=None if obstacles == "none" else obstacles,
                        layer_rules=layer_rules, localisation=localisation)
    started = time.perf_counter()
    steps = runs + (settings.obstacles is not None)
    with Progress(transient=True, console=console(err=True)) as progress:
        bar = progress.add_task("skill acquisition", total=steps)

        def advance(what: str) -> None:
            progress.update(bar, description=what, completed=len(done))
            done.append(what)

        done: list[str] = []
        with naming("--out"):
            data = skill_acquisition(out_dir, settings, progress=advance, finished=_say_run)
        progress.update(bar, completed=steps)
    if "obstacles" in data:
        switches = " → ".join(f"{entry['layer']} at {entry['t']:.1f} s" for entry in data["obstacles"]["timeline"])
        click.echo(f"obstacles: {switches}")
    written: list = []
    failed = write_all({"--out": lambda: written.extend(write_results(data, out_dir))})
    for path in written:
        click.echo(f"wrote {path}")
    click.echo(f"{len(data['runs'])} runs in {time.perf_counter() - started:.1f} s wall")
    for error in failed.values():
        click.echo(str(error), err=True)
    if not data["complete"]:
        click.echo(f"{data['incomplete']}: the results are marked incomplete", err=True)
        sys.exit(130)
    if failed:
        sys.exit(1)


def _say_run(run: dict) -> None:
    """One line for a run as it ends."""
    layers = ", ".join(f"{name} {seconds:.0f} s" for name, seconds in run["primary_s"].items() if seconds)
    click.echo(f"run {run['run']}: map quality {run['map_quality']:.3f}, {run['duration_s']:.1f} s "
               f"(optimal {run['optimal_s']:.1f} s); primary {layers}"
               + ("" if run["ok"] else f"; the errand failed ({run['ended_by']})"))
    sys.stdout.flush()  # each run as it ends, also through a pipe


def _result_files() -> tuple[str, ...]:
    from atlas_rap.views.experiment import RESULT_FILES

    return RESULT_FILES
