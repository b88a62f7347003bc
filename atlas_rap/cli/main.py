"""The ``atlas`` command group and its entry point.

Commands import what they need inside their own bodies, so ``atlas --help``
and ``atlas check`` start without loading numpy, scipy, scikit-image or
pymunk (the check command's cold start is a benchmarked figure). Every
command's output paths are checked against its input files before it starts
(``cli.options.outputs_checked``).
"""

from __future__ import annotations

import sys

import click

from atlas_rap import __version__
from atlas_rap.cli.check import check
from atlas_rap.cli.experiment import experiment_group
from atlas_rap.cli.lsp import lsp
from atlas_rap.cli.map import map_group
from atlas_rap.cli.options import outputs_checked
from atlas_rap.cli.plan import plan
from atlas_rap.cli.record import record_group
from atlas_rap.cli.repl import repl
from atlas_rap.cli.run import run
from atlas_rap.cli.skills import skills_group
from atlas_rap.errors import AtlasError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="atlas")
def cli() -> None:
    """atlas-rap: task-level robot control in the 3T / ATLAS tradition.

    Write routine procedures as RAPs (.rap files) and planning operators as
    AP files (.ap); check them with `atlas check`; run a mission with
    `atlas run`; make a plan with `atlas plan` (AP goals or PDDL);
    work with a running robot in `atlas repl`; build and abstract maps
    with `atlas map`; reproduce the seed papers' experiments with
    `atlas experiment`; look at a run recorded for Foxglove with
    `atlas record show`; serve a robot's skills to a sequencer on
    another host with `atlas skills serve` (and `atlas run --connect`);
    give your editor diagnostics, hover and completion with `atlas lsp`.
    Your own skills, sensors, worlds and layer rules come in as plugins
    (installed entry points, or --plugin FILE.py); `atlas skills list`
    shows every skill and where it came from.
    """


cli.add_command(check)
cli.add_command(run)
cli.add_command(map_group)
cli.add_command(plan)
cli.add_command(repl)
cli.add_command(experiment_group)
cli.add_command(record_group)
cli.add_command(skills_group)
cli.add_command(lsp)
outputs_checked(cli)  # no command writes over its own input files


def main(argv: list[str] | None = None) -> None:
    """Run the CLI; bad input exits 1 with a located message, never a traceback; Ctrl-C exits 130."""
    try:
        cli.main(args=argv, prog_name="atlas", standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except (click.exceptions.Abort, KeyboardInterrupt):
        _interrupted()
    except AtlasError as exc:
        click.echo(str(exc), err=True)
        sys.exit(exc.exit_code)
    except Exception as exc:
        if not _by_ctrl_c(exc):
            raise
        _interrupted()
    sys.exit(0)


def _interrupted() -> None:
    click.echo("interrupted", err=True)
    sys.exit(130)


def _by_ctrl_c(exc: BaseException) -> bool:
    """An error that Ctrl-C caused: a library that turned the KeyboardInterrupt into its own error
    (a compiled module whose import was interrupted: "ImportError: initialization failed")."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
