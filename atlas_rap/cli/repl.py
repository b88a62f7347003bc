"""``atlas repl``: post tasks, query memory and watch the robot while it runs.

Interactive on a terminal (prompt_toolkit: multi-line input that submits
when the parentheses balance, history, completion, colours; the world runs
in the background, paced to the wall clock, and trace lines print above the
prompt); the planner runs on a worker thread, so the robot and the prompt go
on while a ``(plan ...)`` is being made. From a pipe or a file (``atlas repl < session.txt``) it reads the
same forms and commands, prints plain results, lets time pass only when
told (``:run``, ``:step``), and exits 1 if any submission failed. The
engine is :class:`~atlas_rap.cli.repl_session.Session`.
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from contextlib import contextmanager
from typing import TYPE_CHECKING, Iterable, Iterator, TextIO

import click

from atlas_rap.cli.bus_options import bus_options, check_bus_options
from atlas_rap.cli.options import PLUGIN, POSITIVE, SEED, OutputFile, layer_options, run_options, world_help

if TYPE_CHECKING:
    from atlas_rap.skillbus.remote import BusSettings


@click.command()
@PLUGIN
@click.argument("files", nargs=-1, metavar="[FILE...]", type=click.Path(dir_okay=False))
@click.option("--world", metavar="W",
              help=world_help("Default: the first file's (world ...) form, else none (virtual skills only)."))
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed for the world's randomness.")
@click.option("--trace", "trace_file", type=OutputFile(), metavar="FILE",
              help="Write the trace as JSON lines; written when the session ends, however it ends.")
@click.option("--verbose", "-v", is_flag=True, help="Also show task selections and skill disables.")
@click.option("--speed", type=POSITIVE, default=1.0, show_default=True,
              help="Interactive: simulated seconds per wall-clock second of the background clock.")
@layer_options
@bus_options
def repl(files: tuple[str, ...], world: str | None, seed: int, trace_file: str | None, verbose: bool,
         speed: float, no_prior_map: bool, map_in: str | None, map_out: str | None, localisation: str,
         layers: tuple[str, ...], layer_rules: str | None, bus: BusSettings | None) -> None:
    """Load FILEs, then read forms, queries and commands (:help lists them).

    Type any top-level form (define-rap, post, include, plan, ...),
    (assert FACT), (retract FACT), a query such as (? (at robot ?where)),
    or a command such as :agenda, :memory, :run 10. FILEs load as `atlas
    run` loads a mission, and the first file's (world ...) is the session's
    world unless --world says otherwise. Ctrl-C stops a :run, Ctrl-D ends
    the session (halting live tasks). Results go to stdout, errors to
    stderr. Exits 1 if any submission failed.
    """
    from atlas_rap.cli.console import console
    from atlas_rap.cli.repl_session import Session

    interactive = sys.stdin.isatty()
    width = None if interactive else 200
    out, err = console(width=width), console(err=True, width=width)
    options = run_options(world=world, seed=seed, default_world="none", bus=bus, no_prior_map=no_prior_map,
                          map_in=map_in, map_out=map_out, layers=layers, layer_rules=layer_rules,
                          localisation=localisation)
    check_bus_options(bus, **{"--world": world, "--no-prior-map": no_prior_map, "--map-in": map_in,
                      "--layers": tuple(layers) != ("I", "II", "III", "IV"),
                      "--localisation (the host's localiser runs beside its sensors)": localisation != "mcl"})
    session = Session(options, out=out, err=err, trace_file=trace_file, verbose=verbose)
    try:
        for path in files:
            session.load_file(path)
        if interactive:
            _interactive(session, speed)
        else:
            # bytes that are not UTF-8 reach the reader as surrogates, which it reports with a caret
            # (a strict decoder would end the session with a UnicodeDecodeError on such a line)
            if hasattr(sys.stdin, "reconfigure"):
                sys.stdin.reconfigure(errors="surrogateescape")
            for text in submissions(sys.stdin):
                with _interruptible(session):
                    session.submit(text)
    finally:
        session.close()
    sys.exit(1 if session.failures else 0)


def submissions(lines: Iterable[str] | TextIO) -> Iterator[str]:
    """The submissions in a stream of lines: each ends where its parentheses balance
    (a command is one line). While one is still open, a line that starts in column 1
    with ``(`` or ``:`` starts the next one, and the unbalanced one goes to the reader
    as it is, to be reported with a caret (a script's later forms still run)."""
    from atlas_rap.cli.repl_input import is_complete

    pending: list[str] = []
    for line in lines:
        if pending and line[:1] in ("(", ":"):
            yield "".join(pending)
            pending = []
        pending.append(line)
        text = "".join(pending)
        if is_complete(text):
            if text.strip():
                yield text
            pending = []
    if "".join(pending).strip():
        yield "".join(pending)  # unbalanced at the end: the reader says where


@contextmanager
def _interruptible(session) -> Iterator[None]:
    """Ctrl-C while a submission runs stops its :run, not the session."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: session.interrupted.set())
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        session.interrupted.clear()


def _interactive(session, speed: float) -> None:
    from prompt_toolkit.patch_stdout import patch_stdout

    from atlas_rap.cli.repl_input import (
        ReplCompleter,
        history_path,
        make_prompt_session,
    )

    prompt = make_prompt_session(ReplCompleter(lambda: _names(session)), history_path())
    session.engine.plan_in_worker()  # the robot and the prompt go on while the planner thinks
    stop = threading.Event()
    clock = threading.Thread(target=_background_clock, args=(session, speed, stop), daemon=True)
    session.out.print("atlas repl: type :help for commands, Ctrl-D to leave", style="dim")
    with patch_stdout(raw=True):
        clock.start()
        try:
            while True:
                try:
                    text = prompt.prompt()
                except KeyboardInterrupt:
                    continue
                except EOFError:
                    break
                try:
                    with _interruptible(session):
                        session.submit(text)
                except KeyboardInterrupt:  # Ctrl-C in the instant before the handler is in place
                    session.out.print("interrupted", style="dim")
        finally:
            stop.set()
            clock.join(timeout=2)


def _background_clock(session, speed: float, stop: threading.Event) -> None:
    """Keep simulated time going with the wall clock while nobody is typing a :run."""
    tick = 0.1
    last = time.monotonic()
    while not stop.wait(tick / max(speed, 1e-6) if speed > 0 else tick):
        now = time.monotonic()
        elapsed, last = now - last, now
        if session.paused or speed <= 0:
            continue
        try:
            session.advance(elapsed * speed)
        except Exception as exc:  # the clock must never die silently: say why and pause
            session.out.print(f"the background clock stopped: {exc}", style="red", markup=False)
            session.paused = True


def _names(session) -> dict[str, list[str]]:
    """What the completer offers: commands, RAPs, skills, predicates in memory, places."""
    from atlas_rap.cli.repl_session import COMMANDS

    seq = session.sequencer
    facts = list(seq.memory)
    return {
        "command": list(COMMANDS),
        "rap": sorted({name for name, _ in seq.library}),
        "skill": sorted(session.skills.skills()),
        "predicate": sorted({fact.functor for fact in facts}),
        "place": sorted({str(fact.args[0]) for fact in facts if fact.functor == "place" and fact.args}),
    }
