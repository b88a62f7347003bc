"""``atlas plan GOALS.ap`` and ``atlas plan --pddl DOMAIN PROBLEM``: make a plan.

What ``--json`` prints: always one JSON object on stdout, in the form of
docs/language/ap.md (What the planner returns), whatever the outcome; the exit code and the report on
stderr are the same as without ``--json``.

- ``"status": "solved"`` (exit 0): the plan. ``risk`` is made of ``threats``,
  each an uncontrolled ``action`` as written that may happen ``after`` a step
  and break a ``link`` of the plan (``from``/``to``/``fact``, as in
  ``links``), with its ``probability``; threats with the same ``event``
  number are one happening, so ``risk = 1 - prod(1 - probability)`` over
  distinct events.
- ``"status": "unsolvable"``, ``"timeout"`` or ``"memory"`` (exit 1): no plan
  (or none that can be given as safe: counterplanning cut short while threats
  were left); ``reason`` says why. When a goal is out of reach of every operator, ``problems``
  locates it (``file``, ``line``, ``column``, ``message``, ``hint``,
  ``severity``), and the report with a caret goes to stderr.
- ``"status": "error"`` (exit 1): the input is bad: a syntax error, a
  check that fails, a missing file, a file with no goals. ``reason`` and
  ``problems`` as above, the caret report on stderr.
- ``"status": "interrupted"`` (exit 130): Ctrl-C stopped the planner
  before it gave a plan; ``reason`` says so, ``limits`` as below.
- a plan for goals with a ``(deadline GOAL SECONDS)`` has ``deadline`` (the
  smallest that applies) and ``meets_deadline``. A solved plan whose makespan
  breaks it is not a usable plan: still ``"status": "solved"`` with its steps,
  but ``meets_deadline`` false, the located problem (at the deadline's goal)
  in ``problems`` and on stderr, exit 1, and no ``--plan-file`` or ``--render``.
  A deadline for a goal the file does not ask for is a warning on stderr.

- ``limits``: ``timeout_s``, ``memory_mb``, and which one was ``reached``
  ``during`` which phase (null when none; ``limits`` is null for bad input). A
  plan found before a limit ran out is still ``solved`` (exit 0): the best by
  then, its text output says so.

Every result has the same keys (``steps`` and the others empty when there
is no plan). Mistakes in the options themselves print no JSON: bad usage
(exit 2: an output path that is one of the input files, or another
output), or an output path that cannot be written (exit 1), is reported
on stderr before any planning. The outputs (``--plan-file``, ``--render``,
``--render-order``) are written after the plan is printed, each whole or
not at all; one that fails then is a line on stderr and exit 1.
"""

from __future__ import annotations

import sys

import click

from atlas_rap.cli.options import POSITIVE, OutputFile, check_outputs


@click.command()
@click.argument("files", nargs=-1, metavar="GOALS.ap | DOMAIN.pddl PROBLEM.pddl", type=click.Path(dir_okay=False))
@click.option("--pddl", is_flag=True, help="Read FILES as a PDDL domain and problem (STRIPS, typing, negative "
                                           "preconditions, equality; ADL: or, imply, exists, forall, when, "
                                           "compiled away; FOND oneof as uncontrolled outcomes).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the result as JSON (the language reference, docs/language/ap.md), whatever it is: the plan with its risk and "
                   "the threats it is made of; status 'unsolvable' or 'timeout' with the reason; status 'error' "
                   "for bad input (a syntax error, no goals); status 'interrupted' on Ctrl-C (exit 130). "
                   "Without a plan it has a 'reason' and the located "
                   "'problems' (file, line, column, message, hint); the report still goes to stderr, and the "
                   "exit code is the same.")
@click.option("--dot", "as_dot", is_flag=True, help="Print the partial order as Graphviz DOT.")
@click.option("--plan-file", type=OutputFile(), metavar="FILE",
              help="Also write one linearisation, an action a line, for a PDDL plan validator.")
@click.option("--render", type=OutputFile(), metavar="OUT.png",
              help="Draw the plan's schedule: a lane per agent (in order of first use), the orderings no "
                   "others imply as arrows, the threat each counterplan step answers, the threats left.")
@click.option("--render-order", type=OutputFile(), metavar="OUT.png",
              help="Draw the partial order as a graph, left to right from init to goal: steps coloured by "
                   "agent, causal links labelled with their facts, pure orderings dashed, counterplan steps "
                   "outlined orange with their threat. Needs no Graphviz.")
@click.option("--check-raps", type=click.Path(file_okay=False, exists=True), metavar="DIR",
              help="Report the plan steps that no RAP in DIR (its .rap files) can execute; exit 1 if any.")
@click.option("--timeout", type=POSITIVE, default=60.0, show_default=True, metavar="SECONDS",
              help="CPU time for the whole planner (grounding, search, shortening, counterplanning). Past it: "
                   "status 'timeout' without a plan, or the plan found by then, marked as such (never a "
                   "less safe plan without saying so).")
@click.option("--memory", type=POSITIVE, default=None, metavar="MB",
              help="Peak memory for the planner, in MiB, held as --timeout is; the status is 'memory' past it.")
@click.option("--timing", is_flag=True,
              help="Add the CPU seconds of every phase to --json: startup (the interpreter and reading the "
                   "files), ground, search, shorten, counterplan, order, and seconds (the total).")
@click.option("--shorten", is_flag=True,
              help="After the first plan, search again from the start for a shorter one (weighted A*, as "
                   "LAMA's later iterations restart), within --timeout: plans a little shorter, found slower.")
@click.option("--no-counterplan", is_flag=True, help="Do not protect the plan from uncontrolled agents "
                                                     "(the risk is still reported).")
def plan(files: tuple[str, ...], pddl: bool, as_json: bool, as_dot: bool, plan_file: str | None,
         render: str | None, render_order: str | None, check_raps: str | None, timeout: float,
         memory: float | None, timing: bool, shorten: bool, no_counterplan: bool) -> None:
    """Plan for the goals of GOALS.ap (with the operators it includes), or for a
    PDDL problem with --pddl.

    Prints a partially ordered plan: steps with agents and times, orderings,
    causal links, simultaneous steps, the counterplan steps that protect it
    from uncontrolled agents, the risk left and each threat it is made of.
    Exits 0 when solved, 1 when unsolvable, out of time or memory, when the plan
    breaks a (deadline GOAL SECONDS) of the file, or the input is bad (a file
    with no goals, a syntax error: reported with a caret on stderr), 2 on bad
    usage, 130 when interrupted. With --json the result is always JSON on stdout, also
    without a plan: status 'unsolvable', 'timeout', 'memory', 'interrupted' or
    (bad input) 'error', with the reason and its located problems.
    """
    from atlas_rap.errors import AtlasError
    from atlas_rap.outputs import OutputUsageError, write_all
    from atlas_rap.planner.limits import Limits
    from atlas_rap.planner.plan import Plan, plan_of_error

    if as_json and as_dot:
        raise click.UsageError("choose one of --json and --dot")
    limits = Limits(timeout, memory, whole_process=True)  # start-up and reading the files count too
    try:
        from atlas_rap.planner.solve import solve

        problem, warnings, read = _read_problem(files, pddl)
        check_outputs(click.get_current_context(), {"a file the goals file includes": read})
        result = solve(problem, protect=not no_counterplan, limits=limits, shorten=shorten)
    except OutputUsageError:
        raise  # the command line is wrong: no JSON, as for other usage errors
    except AtlasError as exc:
        if as_json:
            click.echo(plan_of_error(exc).to_json(timing))
        raise
    except KeyboardInterrupt:
        if as_json:
            click.echo(Plan(status="interrupted", reason="interrupted (Ctrl-C) before a plan was found",
                            limits=limits.to_dict()).to_json(timing))
        raise
    for found in warnings:
        click.echo(found.render(), err=True)
    late = result.status == "solved" and not result.meets_deadline
    if late:
        result.problems.append(_broken_deadline(problem, result))
    if as_json:
        click.echo(result.to_json(timing))
    elif as_dot:
        from atlas_rap.views.plan_dot import plan_dot

        click.echo(plan_dot(result))
    else:
        click.echo(result.to_text())
    for found in result.problems:
        click.echo(found.render(), err=True)
    if result.status != "solved" or late:
        sys.exit(1)
    writers = {}
    if plan_file:
        from atlas_rap.planner.plan_file import write_plan_file

        writers["--plan-file"] = lambda: write_plan_file(plan_file, result.sequence, result.cost)
    if render:
        from atlas_rap.views.plan_render import render_plan

        writers["--render"] = lambda: render_plan(result, render)
    if render_order:
        from atlas_rap.views.order_picture import render_order as draw_order

        writers["--render-order"] = lambda: draw_order(result, render_order)
    failed = write_all(writers)
    for option, path in (("--render", render), ("--render-order", render_order)):
        if path and option not in failed:
            click.echo(f"wrote {path}", err=True)
    covered = not check_raps or _raps_cover(result, check_raps)
    for error in failed.values():  # after the plan: what was found is not lost
        click.echo(str(error), err=True)
    if failed or not covered:
        sys.exit(1)


def _broken_deadline(problem, result):
    """The located problem of a plan whose makespan breaks its deadline: at the goal
    of the ``deadline`` form that set it (the first, if several set the same time)."""
    from atlas_rap.errors import Problem, SourceLocation
    from atlas_rap.logic import term_to_str, unify

    found = [(goal, loc) for (goal, seconds), loc in zip(problem.deadlines, problem.deadline_locations)
             if seconds == result.deadline and any(unify(goal, g) is not None for g in problem.goals)]
    goal, loc = found[0] if found else (None, None)
    what = f" for {term_to_str(goal)}" if goal is not None else ""
    return Problem(f"the plan's {result.deadline_text()}{what}: it is not a usable plan",
                   loc or SourceLocation(problem.name, 1, 1), problem.line(loc),
                   "the planner does not look for the fastest plan: loosen the deadline, or change the "
                   "operators' durations or the agents")


def _read_problem(files: tuple[str, ...], pddl: bool):
    """The problem of ``files``, the warnings of its load-time checks, and the files read."""
    from atlas_rap.lang import load
    from atlas_rap.planner.checks import raise_problems
    from atlas_rap.planner.problem import problem_from_program
    from atlas_rap.shipped import resolve_user_path

    if pddl:
        if len(files) != 2:
            raise click.UsageError("--pddl takes two files: DOMAIN.pddl PROBLEM.pddl")
        from atlas_rap.planner.pddl import load_pddl

        domain, problem = (resolve_user_path(file) for file in files)  # operators/pddl/... from any folder
        return _with_goals(load_pddl(domain, problem), files[1], "add (:goal ...) to the problem"), [], files
    if len(files) != 1:
        raise click.UsageError("give one goals file (GOALS.ap), or --pddl DOMAIN.pddl PROBLEM.pddl")
    path = resolve_user_path(files[0])
    program = load(path)
    problem = _with_goals(problem_from_program(program, name=str(files[0])), files[0],
                          "add (goals FACT ...), or plan a goals file that includes this one")
    return problem, raise_problems(problem), [source.path for source in program.files]


def _with_goals(problem, file: str, hint: str):
    """``problem``, if it has goals; else an error naming ``file`` as the user typed it
    (an operators file without its goals file would otherwise be 'solved: 0 steps', or
    fail checks that are about the goals file it lacks, such as declared agents)."""
    from atlas_rap.errors import PlanFileError, Problem, SourceLocation

    if not problem.goals:
        raise PlanFileError(Problem(f"no goals in {file}", SourceLocation(file, 1, 1), None, hint))
    return problem


def _raps_cover(result, folder: str) -> bool:
    """Print the steps no RAP in ``folder`` can execute; True when there are none."""
    from atlas_rap.cli.console import secho
    from atlas_rap.errors import PlanError
    from atlas_rap.planner.dispatch import load_raps, match_steps
    from atlas_rap.shipped import resolve_user_path

    found = resolve_user_path(folder)
    if not found.is_dir():
        raise PlanError(f"--check-raps {folder}: no such folder")
    missing = [d for d in match_steps(result, load_raps(found)) if d.rap is None]
    for d in missing:
        secho(f"step {d.step.id} {d.step.action}: no RAP in {folder} can execute it ({d.how})",
              fg="red", err=True)
    if not missing:
        click.echo(f"every step has a RAP in {folder}", err=True)
    return not missing
