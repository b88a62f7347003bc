"""``atlas check FILE...``: parse and validate RAP and AP files."""

from __future__ import annotations

import sys
from collections import Counter

import click

from atlas_rap.cli.console import console, secho, styles_on
from atlas_rap.cli.options import PLUGIN


@click.command()
@PLUGIN
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--tree", is_flag=True, help="Print the AST of each file as a tree.")
@click.option("--format", "format_", is_flag=True,
              help="Print each FILE as atlas reads it, pretty-printed, and nothing else: the status goes to "
                   "stderr, so `atlas check --format a.rap > b.rap` writes a file that reads as a.rap does "
                   "(includes not expanded; comments are not kept).")
@click.option("--robot", "robots", multiple=True, metavar="NAME",
              help="Check for a run with these robots on the skill bus (atlas run --connect --robot ...): "
                   "with two or more, every stock skill takes the robot's name first.")
def check(files: tuple[str, ...], tree: bool, format_: bool, robots: tuple[str, ...]) -> None:
    """Validate .rap and .ap FILES and what they include.

    Prints every problem with file:line:column and a caret under it, and
    exits 0 when all files are clean, 1 otherwise.
    """
    # With --format, stdout is the program alone (it is redirected to a file); the status goes with the problems.
    status_to_stderr = format_
    from atlas_rap.errors import SourceError
    from atlas_rap.lang import format_file, load
    from atlas_rap.shipped import resolve_user_path

    failed = 0
    for path in files:
        try:
            program = load(resolve_user_path(path))
        except SourceError as exc:
            failed += 1
            for problem in exc.problems:
                _echo_problem(problem.render())
            secho(f"{path}: {_plural(len(exc.problems), 'problem')}", fg="red", err=True)
            continue
        problems = program_problems(program, path, robots)
        for problem in problems:
            _echo_problem(problem.render())
        if any(problem.severity == "error" for problem in problems):
            failed += 1
            secho(f"{path}: {_plural(len(problems), 'problem')}", fg="red", err=True)
            continue
        counts = Counter(type(form).__name__ for form in program.forms)
        summary = ", ".join(_plural(n, _KINDS.get(kind, kind)) for kind, n in sorted(counts.items()))
        includes = len(program.files) - 1
        extra = f" (+{_plural(includes, 'included file')})" if includes else ""
        secho(f"ok: {path}{extra}: {summary or 'no definitions'}", fg="green", err=status_to_stderr)
        if tree:
            for source in program.files:
                _print_tree(source)
        if format_:  # the file named, not those it includes: its (include ...) forms stay
            root = program.files[0]
            click.echo(f";; {root.path}")
            click.echo(format_file(root))
    if failed:
        sys.exit(1)


def program_problems(program, path: str, robots: tuple[str, ...] = ()) -> list:
    """Every load-time problem ``atlas check`` finds in a loaded program (parsing and validation
    problems are raised by the loader): the RAPs against the skills they can use, and a planning
    problem's operators against its goals and agents. ``robots``: as ``--robot``. The language
    server (``atlas lsp``) reports exactly these."""
    return _sequencer_problems(program, robot_first=len(set(robots)) > 1) + _planner_problems(program, path)


def _sequencer_problems(program, robot_first: bool = False) -> list:
    """Load-time checks of the RAPs against the skills they can use: the program's virtual
    skills, and the stock and plugin skills of a simulated world unless the program says ``(world none)``
    (``robot_first``: with the robot's name as a first argument, as over the bus with several robots)."""
    from atlas_rap.lang import ast
    from atlas_rap.sequencer.checks import check_program
    from atlas_rap.skillbus.remote import robot_first as with_robot_first
    from atlas_rap.skills.catalog import catalog, param_types, skill_events, skill_names
    from atlas_rap.skills.virtual import VirtualSkills

    if not any(program.of_type(kind) for kind in (ast.RapDef, ast.Post, ast.MemoryRuleDef, ast.InitialMemory,
                                                   ast.AtTime)):
        return []
    virtual = VirtualSkills.from_program(program)
    names, events = virtual.skills(), virtual.produces()
    types = {}
    worlds = program.of_type(ast.WorldDecl)
    if not worlds or worlds[-1].world != "none":  # a world run also has the stock skills
        available = skill_names()
        if not robot_first:  # (with the robot's name first, the arguments are not as declared)
            types = {name: typed for name, typed in param_types(catalog()).items() if name not in names}
        names = {**(with_robot_first(available) if robot_first else available), **names}
        events |= skill_events()
    problems = check_program(program, names, events, param_types=types) + _place_problems(program, worlds, types)
    return sorted(problems, key=lambda problem: problem.severity != "error")  # errors first


def _place_problems(program, worlds: list, types: dict) -> list:
    """The places the program names against those of the world its last ``(world ...)`` form names
    (:mod:`atlas_rap.sequencer.place_checks`); nothing without such a form, or when that world does
    not load (a run reports why). Only then are the world's reader and numpy imported."""
    if not types or not worlds or worlds[-1].world == "none":
        return []
    from atlas_rap.errors import AtlasError
    from atlas_rap.layers.system import world_of
    from atlas_rap.sequencer.place_checks import place_problems
    from atlas_rap.sim.world import load_world

    try:
        world = load_world(world_of(worlds[-1]))
    except AtlasError:
        return []
    return place_problems(program, world.name, set(world.places), types)


def _planner_problems(program, path: str) -> list:
    """Load-time checks of a planning problem (operators against goals and agents),
    for a file that states goals."""
    from atlas_rap.lang import ast
    from atlas_rap.planner.checks import check_problem
    from atlas_rap.planner.problem import problem_from_program

    if not program.of_type(ast.Goals):
        return []
    return check_problem(problem_from_program(program, name=path))


_KINDS = {"RapDef": "RAP", "MemoryRuleDef": "memory rule", "VirtualSkillDef": "virtual skill",
          "AtTime": "at-time event", "WorldDecl": "world", "InitialMemory": "initial-memory",
          "Post": "post", "PlanRequest": "plan request", "Operator": "operator", "Agents": "agents",
          "RelationDef": "relation", "Initial": "initial", "Goals": "goals", "Deadline": "deadline"}


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _echo_problem(text: str) -> None:
    first, _, rest = text.partition("\n")
    location, _, message = first.partition(": ")
    click.echo(click.style(location + ":", bold=True) + " " + click.style(message, fg="red"), err=True,
               color=styles_on(err=True))
    if rest:
        click.echo(rest, err=True)


def _print_tree(source) -> None:
    from atlas_rap.cli.tree import ast_tree

    console().print(ast_tree(source))
