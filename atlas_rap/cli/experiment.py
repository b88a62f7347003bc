"""``atlas experiment``: the seed papers' experiments, each as one command."""

from __future__ import annotations

import sys

import click

from atlas_rap.cli.options import SEED, LayerRules, OutputFolder


class SeedSpec(click.ParamType):
    """A set of seeds written the short way (``0-9``, ``0,3,5``, ``2-4,7``): a tuple of seeds, increasing."""

    name = "seeds"

    def convert(self, value, param, ctx):
        from atlas_rap.views.seed_spec import parse_seeds

        if isinstance(value, tuple):
            return value
        try:
            return parse_seeds(value)
        except ValueError as exc:
            self.fail(str(exc), param, ctx)


class ObstacleCases(click.ParamType):
    """Cases of the obstacle scenario: ``all``, ``none`` or names, comma-separated; a tuple of them
    in the order they run (empty for none)."""

    name = "cases"

    def convert(self, value, param, ctx):
        from atlas_rap.views.experiment import OBSTACLE_CASE_KEYS

        if isinstance(value, tuple):
            return value
        words = [word.strip().lower() for word in str(value).split(",") if word.strip()]
        if words == ["all"]:
            return OBSTACLE_CASE_KEYS
        if words == ["none"]:
            return ()
        unknown = [word for word in words if word not in OBSTACLE_CASE_KEYS]
        if unknown or not words:
            self.fail(f"{value!r}: the cases are {', '.join(OBSTACLE_CASE_KEYS)} (or all, or none)", param, ctx)
        return tuple(key for key in OBSTACLE_CASE_KEYS if key in words)


@click.group("experiment")
def experiment_group() -> None:
    """Reproduce the experiments of the seed papers."""


@experiment_group.command("skill-acquisition")
@click.option("--runs", type=click.IntRange(1, 50), default=7, show_default=True,
              help="Errands from the lab to the office and back, the map carried from run to run.")
@click.option("--seeds", "seeds", type=SeedSpec(), metavar="SPEC",
              help="The seeds, each run in a process of its own: 0-9, 0,3,5 or 2-4,7.  [default: 0-9]")
@click.option("--seed", type=SEED, help="Run this one seed alone, its results in the --out folder itself (the "
                                        "single-seed form); instead of --seeds.")
@click.option("--jobs", type=click.IntRange(1, 256), metavar="N",
              help="How many seeds run at a time, each in a process of its own (1: one after another in this "
                   "process).  [default: the number of CPUs]")
@click.option("--world", "world", default="lab-corridor-office", show_default=True, metavar="W",
              help="The world of the runs: a shipped world's name or a world file, with places named lab and "
                   "office. The obstacle scenario needs lab-corridor-office's building; its robot may err "
                   "otherwise (odometry noise), and the cases then take that noise.")
@click.option("--obstacles", "obstacles", type=ObstacleCases(), default="all", show_default=True, metavar="CASES",
              help="The cases of the obstacle scenario (Fig. 13b) run on the last run's map, each from it: "
                   "person, corridor-box and full-block ('all'), some of them comma-separated, or 'none'.")
@click.option("--layer-rules", "layer_rules", type=LayerRules(), metavar="RULES.rap",
              help="Memory rules that choose the primary layer: a file, or the name of an installed plugin's "
                   "(default: the shipped rap_library/layers.rap).")
@click.option("--localisation", "localisation", type=click.Choice(["mcl", "odometry"]), default="mcl",
              show_default=True,
              help="How the robot knows where it is: its odometry corrected against the map it builds and "
                   "carries (mcl), or its odometry alone (dead reckoning, to compare).")
@click.option("--out", "out_dir", required=True, type=OutputFolder(writes=lambda: _result_files()),
              help="Folder for the results and figures.")
def skill_acquisition_command(runs: int, seeds: tuple[int, ...] | None, seed: int | None, jobs: int | None,
                              world: str, obstacles: tuple[str, ...], layer_rules: str | None, localisation: str,
                              out_dir: str) -> None:
    """The ATLAS paper's skill-acquisition experiment (seed 000 §5.2, Figs. 12 and 13), over seeds 0-9.

    A robot with no prior map drives from the lab to the office and back,
    RUNS times, carrying its occupancy grid from run to run: Layer IV maps
    while the map is poor, Layer II follows the route once it is good (the
    map quality: 1 - mean entropy over the area the errand needs, fixed
    before the first run: the free space near its shortest routes, the
    rooms they pass and their walls). Then
    the obstacle scenario (Fig. 13b, --obstacles), each case an errand of
    its own on the last run's map: a person crosses its way (Layer I, then
    II), a box blocks one way (Layer III re-routes, then II), a block cuts
    every way it knows (Layer IV remaps, then II).

    Each seed (--seeds, default 0-9) runs in a process of its own (--jobs at
    a time) into seed-N/ of the --out folder: figures.json, runs.csv, the
    grid of each run (map-runN.npz) and the figures as PNG, as --seed N
    writes them. Each seed's line says on which run its map quality crossed
    the threshold and how long the runs after it took; then how many seeds
    crossed on each run. In the --out folder itself: figures.json (every
    seed's results, "per_seed", and the statistics, "summary"), runs.csv (a
    row per seed and run) and the figures over all seeds: the median map
    quality per run with its inter-quartile range and its least and
    greatest (Fig. 12a), the same for the durations against the optimal
    time (12b), each layer's share of each run's time as primary (13a),
    and the primary layer in the obstacle scenario, a row per seed (13b).

    --seed N runs that one seed alone and writes its results and figures
    in the --out folder itself.

    Ctrl-C stops the whole experiment: what it has is written, marked
    incomplete ("complete": false in figures.json, and on every figure),
    then it exits 130.
    """
    from atlas_rap.views.experiment import Settings

    if seed is not None and seeds is not None:
        raise click.UsageError("--seed and --seeds: give one of them (--seed N runs one seed alone; --seeds SPEC "
                               "runs several, each in its own process)")
    if seed is not None and jobs is not None:
        raise click.UsageError("--jobs: with --seed there is one seed to run; to run seeds side by side, give "
                               "them with --seeds")
    settings = Settings(world=world, runs=runs, seed=0 if seed is None else seed,
                        obstacles=obstacles or None, layer_rules=layer_rules,
                        localisation=localisation)
    if seed is not None:
        _one_seed(settings, out_dir)
    else:
        from atlas_rap.views.experiment_seeds import DEFAULT_SEEDS

        _many_seeds(settings, seeds or DEFAULT_SEEDS, jobs, out_dir)


def _one_seed(settings, out_dir: str) -> None:
    """``--seed N``: the one seed, its results and figures in ``out_dir`` itself."""
    import time

    from rich.progress import Progress

    from atlas_rap.cli.console import console
    from atlas_rap.views.experiment import skill_acquisition, write_results
    from atlas_rap.outputs import naming, write_all

    started = time.perf_counter()
    steps = settings.runs + len(settings.obstacles or ())
    with Progress(transient=True, console=console(err=True)) as progress:
        bar = progress.add_task("skill acquisition", total=steps)

        def advance(what: str) -> None:
            progress.update(bar, description=what, completed=len(done))
            done.append(what)

        done: list[str] = []
        with naming("--out"):
            data = skill_acquisition(out_dir, settings, progress=advance, finished=_say_run)
        progress.update(bar, completed=steps)
    for case in data.get("obstacles") or []:
        _say_case(case)
    written: list = []
    failed = write_all({"--out": lambda: written.extend(write_results(data, out_dir))})
    for path in written:
        click.echo(f"wrote {path}")
    click.echo(f"{len(data['runs'])} runs in {time.perf_counter() - started:.1f} s wall")
    _end(data, failed)


def _many_seeds(settings, seeds: tuple[int, ...], jobs: int | None, out_dir: str) -> None:
    """``--seeds`` (and the default): each seed in its own process into ``seed-N/``, then the results
    over all seeds in ``out_dir``."""
    import time
    from pathlib import Path

    from rich.progress import Progress

    from atlas_rap.cli.console import console
    from atlas_rap.outputs import naming, write_all
    from atlas_rap.views.experiment_seeds import (
        SEED_FOLDER,
        skill_acquisition_seeds,
        worker_count,
        write_seeds_results,
    )
    from atlas_rap.views.seed_spec import seeds_text

    started = time.perf_counter()
    workers = worker_count(jobs, seeds)
    with Progress(transient=True, console=console(err=True)) as progress:
        bar = progress.add_task(f"skill acquisition, {seeds_text(seeds)}", total=len(seeds))

        def finished(one: dict) -> None:
            _say_seed(one)
            progress.update(bar, advance=1)

        with naming("--out"):
            data = skill_acquisition_seeds(out_dir, settings, seeds, jobs=workers,
                                           progress=lambda what: progress.update(bar, description=what),
                                           finished=finished)
    _say_summary(data)
    written: list = []
    failed = write_all({"--out": lambda: written.extend(write_seeds_results(data, out_dir))})
    for path in written:
        click.echo(f"wrote {path}")
    ran = [one["seed"] for one in data["per_seed"]]
    if ran:
        folder = Path(out_dir) / SEED_FOLDER.format(seed="N")
        click.echo(f"wrote the results and figures of {seeds_text(ran)} each in its own folder, {folder}")
    click.echo(f"{len(ran)} of {len(seeds)} seeds in {time.perf_counter() - started:.1f} s wall "
               f"({workers} at a time)")
    _end(data, failed)


def _end(data: dict, failed: dict) -> None:
    """Say what could not be written and exit: 130 if the results are incomplete, 1 if a file failed."""
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


def _say_case(case: dict) -> None:
    """The lines for a case of the obstacle scenario: the layers primary in turn against the seed's
    order, then each switch."""
    seen, expected = " → ".join(case["seen"]) or "no layer primary", " → ".join(case["expected"])
    verdict = "as the seed orders" if case["as_expected"] else f"the seed orders {expected}"
    failed = "" if case["ok"] else f"; the errand failed ({case['ended_by']})"
    click.echo(f"obstacles, {case['case']}: {seen} ({verdict}){failed}")
    switches = " → ".join(f"{entry['layer']} at {entry['t']:.1f} s" for entry in case["timeline"])
    click.echo(f"  {case['world']}: {switches}")


def _say_seed(one: dict) -> None:
    """One line for a seed as it ends: where its map quality crossed the threshold, the runs after it."""
    from atlas_rap.views.experiment_seeds import seed_outcome

    outcome = seed_outcome(one)
    threshold = float(one["threshold"])
    parts = []
    if outcome["crossed_in"] is None:
        parts.append(f"map quality stayed below {threshold:g} in {_count(len(one['runs']), 'run')}")
    else:
        parts.append(f"map quality crossed {threshold:g} in run {outcome['crossed_in']}")
        if outcome["runs_after"]:
            parts.append(f"the {_count(outcome['runs_after'], 'run')} after it: median "
                         f"{outcome['median_after_s']:.1f} s{_against(outcome['median_after_s'], outcome['optimal_s'])}")
    if outcome["failed"]:
        parts.append(f"{_count(outcome['failed'], 'errand')} failed")
    for case in outcome["obstacles"]:
        parts.append(f"obstacles{'' if case['case'] is None else ' ' + case['case']}: "
                     + (" → ".join(case["layers"]) or "no layer primary"))
    stopped = "" if one["complete"] else f" ({one['incomplete']})"
    click.echo(f"seed {one['seed']}{stopped}: " + "; ".join(parts))
    sys.stdout.flush()  # each seed as it ends, also through a pipe


def _say_summary(data: dict) -> None:
    """The lines over all seeds: on which run the quality crossed the threshold, how many seeds each;
    the runs after the crossing against the optimal time."""
    stats = data["summary"]
    if not stats["seeds_run"]:
        click.echo("no seed ran to the end of a run")
        return
    threshold = float(data["threshold"])
    counts = [(key, k) for key, k in stats["crossed_in"]["histogram"].items() if k]
    said = [f"{'never' if key == 'never' else 'in run ' + key} on {_count(k, 'seed') if i == 0 else k}"
            for i, (key, k) in enumerate(counts)]
    of = _count(len(stats["seeds_run"]), "seed")
    click.echo(f"quality crossed {threshold:g} " + ", ".join(said) + f" (of {of})")
    after = stats["after_crossing"]
    if after["runs"]:
        click.echo(f"after the switch: median {after['median_duration_s']:.1f} s over {_count(after['runs'], 'run')}"
                   + _against(after["median_duration_s"], after["optimal_s"]))
    else:
        click.echo("after the switch: no runs (no seed's map crossed the threshold before its last run)")


def _against(seconds: float | None, optimal: float | None) -> str:
    """`` (optimal 51.8 s, ×1.18)``."""
    if seconds is None or not optimal:
        return ""
    return f" (optimal {optimal:.1f} s, \u00d7{seconds / optimal:.2f})"


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}{'' if n == 1 else 's'}"


def _result_files() -> tuple[str, ...]:
    from atlas_rap.views.experiment import RESULT_FILES
    from atlas_rap.views.experiment_seeds import RESULT_FILES as SEEDS_RESULT_FILES

    return tuple(dict.fromkeys(RESULT_FILES + SEEDS_RESULT_FILES))
