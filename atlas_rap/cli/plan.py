"""``atlas plan GOALS.ap`` and ``atlas plan --pddl DOMAIN PROBLEM``: make a plan."""

from __future__ import annotations

import sys

import click


@click.command()
@click.argument("files", nargs=-1, metavar="GOALS.ap | DOMAIN.pddl PROBLEM.pddl", type=click.Path(dir_okay=False))
@click.option("--pddl", is_flag=True, help="Read FILES as a PDDL domain and problem (STRIPS, typing, negative "
                                           "preconditions, equality; FOND oneof as uncontrolled outcomes).")
@click.option("--json", "as_json", is_flag=True, help="Print the plan as JSON (LANGUAGE.md §3.3).")
@click.option("--dot", "as_dot", is_flag=True, help="Print the partial order as Graphviz DOT.")
@click.option("--plan-file", type=click.Path(dir_okay=False, writable=True), metavar="FILE",
              help="Also write one linearisation, an action a line, for a PDDL plan validator.")
@click.option("--render", type=click.Path(dir_okay=False, writable=True), metavar="OUT.png",
              help="Draw the plan's schedule: a lane per agent, orderings as arrows.")
@click.option("--check-raps", type=click.Path(file_okay=False), metavar="DIR",
              help="Report the plan steps that no RAP in DIR (its .rap files) can execute; exit 1 if any.")
@click.option("--timeout", type=float, default=60.0, show_default=True, metavar="SECONDS",
              help="CPU time for the whole planner; the status is 'timeout' past it.")
@click.option("--timing", is_flag=True, help="Add CPU times (grounding, search, total) to --json.")
@click.option("--no-counterplan", is_flag=True, help="Do not protect the plan from uncontrolled agents "
                                                     "(the risk is still reported).")
def plan(files: tuple[str, ...], pddl: bool, as_json: bool, as_dot: bool, plan_file: str | None,
         render: str | None, check_raps: str | None, timeout: float, timing: bool, no_counterplan: bool) -> None:
    """Plan for the goals of GOALS.ap (with the operators it includes), or for a
    PDDL problem with --pddl.

    Prints a partially ordered plan: steps with agents and times, orderings,
    causal links, simultaneous steps, the counterplan steps that protect it
    from uncontrolled agents and the risk left. Exits 0 when solved, 1 when
    unsolvable, out of time or the input is bad, 2 on bad usage.
    """
    from atlas_rap.errors import AtlasError
    from atlas_rap.planner.solve import solve

    if as_json and as_dot:
        raise click.UsageError("choose one of --json and --dot")
    problem = _read_problem(files, pddl)
    result = solve(problem, timeout=timeout, protect=not no_counterplan)
    if as_json:
        click.echo(result.to_json(timing))
    elif as_dot:
        click.echo(result.to_dot())
    else:
        click.echo(result.to_text())
    if result.status != "solved":
        sys.exit(1)
    if plan_file:
        from atlas_rap.planner.plan_file import write_plan_file

        try:
            write_plan_file(plan_file, result.sequence)
        except OSError as exc:
            raise AtlasError(f"cannot write the plan file {plan_file}: {exc.strerror}") from None
    if render:
        from atlas_rap.planner.render import render_plan

        render_plan(result, render)
        click.echo(f"wrote {render}", err=True)
    if check_raps and not _raps_cover(result, check_raps):
        sys.exit(1)


def _read_problem(files: tuple[str, ...], pddl: bool):
    from atlas_rap.lang import load
    from atlas_rap.planner.checks import raise_problems
    from atlas_rap.planner.problem import problem_from_program
    from atlas_rap.shipped import resolve_user_path

    if pddl:
        if len(files) != 2:
            raise click.UsageError("--pddl takes two files: DOMAIN.pddl PROBLEM.pddl")
        from atlas_rap.planner.pddl import load_pddl

        return load_pddl(files[0], files[1])
    if len(files) != 1:
        raise click.UsageError("give one goals file (GOALS.ap), or --pddl DOMAIN.pddl PROBLEM.pddl")
    path = resolve_user_path(files[0])
    problem = problem_from_program(load(path), name=str(files[0]))
    raise_problems(problem)
    return problem


def _raps_cover(result, folder: str) -> bool:
    """Print the steps no RAP in ``folder`` can execute; True when there are none."""
    from atlas_rap.errors import AtlasError
    from atlas_rap.planner.dispatch import load_raps, match_steps
    from atlas_rap.shipped import resolve_user_path

    found = resolve_user_path(folder)
    if not found.is_dir():
        raise AtlasError(f"--check-raps {folder}: no such folder")
    missing = [d for d in match_steps(result, load_raps(found)) if d.rap is None]
    for d in missing:
        click.secho(f"step {d.step.id} {d.step.action}: no RAP in {folder} can execute it "
                    f"({d.how})", fg="red", err=True)
    if not missing:
        click.echo(f"every step has a RAP in {folder}", err=True)
    return not missing
