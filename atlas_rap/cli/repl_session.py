"""The REPL's session: typed forms, queries and commands acting on a running mission engine.

:class:`Session` is what ``atlas repl`` drives, interactively or from a
pipe, and what tests drive directly. Programs go to the same
:class:`~atlas_rap.layers.engine.MissionEngine` that ``atlas run`` uses, so
the REPL loads what ``atlas run`` loads. :meth:`Session.submit` takes one
submission (the text typed before Enter) and returns True when it worked;
output goes to the ``out`` console. What a submission may be:

- any top-level form of the languages (docs/language/): ``define-rap``, ``define-memory-rule``,
  ``define-virtual-skill``, ``post``, ``initial-memory``, ``at-time``,
  ``include``, ``plan``, and the AP forms (``operator``, ``agents``,
  ``define-relation``, ``initial``, ``goals``) that the planner uses;
- ``(assert FACT)`` and ``(retract FACT)``, straight into memory;
- a query ``(? QUERY)``, answered with every binding;
- a command, ``:agenda``, ``:memory [PATTERN]``, ... (``:help`` lists them).

Choices where the issue is silent:

- A submission is a program like a file, loaded in one pass (so a RAP may
  use a skill defined further down), and read, validated and checked as a
  whole before any of it runs: an error anywhere in it changes nothing. Its
  queries, asserts and retracts run after its program, in the order written.
- The world: ``--world`` if given; else the first program's ``(world ...)``
  (``atlas repl deliver.rap`` runs in deliver's world); else none. A later
  program that names another world is an error saying so.
- A redefined RAP replaces the old one by name and arity; a running task
  uses it at its next method choice (as ``Mission.reload``).
- Time moves only by ``:step``, ``:run`` or, interactively, the background
  clock (paced to the wall clock, off with ``:pause``), so a piped session
  is reproducible.
- ``(plan GOAL ...)`` posts a RAP whose one step plans from memory when it
  runs (on a worker thread on a terminal: the robot goes on meanwhile),
  with the operators typed or included so far, then carries the plan out,
  watching and repairing it; ``:plan GOAL ...`` only shows a plan.
- Results go to standard output, errors to standard error.
- Ending the session (Ctrl-D, end of input) halts the live tasks, so their
  skills are disabled in the trace, before the trace is written.
- ``:save FILE`` writes the session as a file that ``atlas repl FILE`` loads
  back (:meth:`Session.saved_text`): the world as ``(world ...)``, the RAPs,
  memory rules, relations and virtual skills defined in the session (not the
  layers' switching rules, which come with the world), the operators, agents,
  goals and deadlines typed or included for the planner, memory as
  ``initial-memory``, the ``at-time`` events still to come and the live
  top-level tasks as ``post`` (``(plan ...)`` for a plan being carried out),
  with their priority and what is left of their deadline. A world cannot be
  saved mid-run: it starts again from its start, so memory leaves out what
  the world itself asserted (its map, what its skills and layers sensed):
  the world asserts it again. Times (``at-time``, deadlines) count from the
  moment of saving, as the loading session's clock starts at 0.

Over 25 KB on purpose: the REPL's session: every command is a method over one session's
state.
"""

from __future__ import annotations

import dataclasses
import math
import shlex
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from rich.console import Console

from atlas_rap.errors import (AtlasError, LanguageError, Problem, SourceError, SourceLocation, did_you_mean, line_of,
                              source_lines)
from atlas_rap.lang import ast, format_node, load_text
from atlas_rap.lang.reader import Forms, SList, read_text
from atlas_rap.lang.validator import MAX_SECONDS, to_term
from atlas_rap.logic import Compound, Term, Var, is_anonymous, substitute, term_to_str, variables
from atlas_rap.shipped import resolve_user_path
from atlas_rap.trace_events import Event

if TYPE_CHECKING:  # downward only
    from atlas_rap.layers import RunOptions
    from atlas_rap.sequencer import Sequencer
    from atlas_rap.skillbus.skill_link import CombinedSkills
    from atlas_rap.skills.virtual import VirtualSkills

COMMANDS = {
    ":agenda": "the task tree with each task's status",
    ":memory": "[PATTERN]  the facts in memory (those matching PATTERN)",
    ":trace": "[N]  the last N trace records (default 20)",
    ":step": "[SECONDS]  advance time one step (0.1 s, or SECONDS)",
    ":run": "[SECONDS]  run SECONDS of simulated time, or until the posted tasks end (Ctrl-C stops it)",
    ":pause": "stop (or restart) the clock that runs the world in the background",
    ":reload": "FILE  load FILE again: its RAPs, rules and virtual skills replace the old ones",
    ":skills": "the skills tasks can use, and which are running for which task",
    ":map": "[FILE.png]  draw the world and the robot's path (needs a world)",
    ":layers": "the primary layer, how long each layer drove, and the last switches with their reasons",
    ":plan": "GOAL ...  show a plan for the goals (does not run it)",
    ":save": "FILE  write memory, live tasks and session definitions to a file that loads back",
    ":help": "this list",
}

STEP = 0.1
RUN_LIMIT = 3600.0
_SPECIAL = ("?", "assert", "retract")


class Session:
    """A mission engine (in a world, or none) ready for typed forms, queries and commands."""

    def __init__(self, options: RunOptions | None = None, *, out: Console | None = None,
                 err: Console | None = None, trace_file: str | None = None, verbose: bool = False) -> None:
        from atlas_rap.cli.views import LiveTrace
        from atlas_rap.layers import MissionEngine, RunOptions
        from atlas_rap.views import RunPicture
        from atlas_rap.sequencer import JsonlSink, Trace

        self.out = out or Console(highlight=False, soft_wrap=True)
        self.err = err or self.out
        self.trace = Trace(keep=True)
        options = options if options is not None else RunOptions(default_world="none")
        self.engine = MissionEngine(options, trace=self.trace)
        self.map_out = options.map_out
        self.sink = JsonlSink(trace_file) if trace_file else None
        if self.sink is not None:
            self.trace.add_sink(self.sink)
        self.trace.add_sink(LiveTrace(self.out, verbose=verbose))
        self.picture = RunPicture(self.engine)
        self.lock = threading.RLock()
        self.lines: dict[str, list[str]] = {}
        self.events: list[ast.AtTime] = []  # every at-time loaded, for :save
        self._sources: tuple[int, dict[str, str]] | None = None  # who asserted each fact, from the trace
        self.submissions = 0
        self.paused = False
        self.interrupted = threading.Event()
        self.failures = 0

    @property
    def sequencer(self) -> Sequencer:
        """The running sequencer (the session's world is built when first needed)."""
        return self.engine.ensure_system().sequencer

    @property
    def skills(self) -> CombinedSkills | VirtualSkills:
        """The skills the session's RAPs can enable."""
        return self.engine.ensure_system().skills

    # -- submissions -----------------------------------------------------

    def submit(self, text: str) -> bool:
        """Run one submission (forms or a command); print what happened; False on an error."""
        if not text.strip():
            return True
        try:
            with self.lock:
                stripped = text.strip()
                if stripped.startswith(":"):
                    self.command(stripped)
                else:
                    self.forms(text)
            return True
        except SourceError as exc:
            for problem in exc.problems:
                self.err.print(problem.render(), style="red", markup=False)
        except AtlasError as exc:
            self.err.print(f"error: {exc}", style="red", markup=False)
        finally:
            self._report_fault()
        self.failures += 1
        return False

    def load_file(self, path: str) -> bool:
        """Load a file given on the command line, as ``atlas run`` loads a mission; False on an error."""
        return self.submit(f'(include "{_escape(str(resolve_user_path(path)))}")')

    def forms(self, text: str) -> None:
        """Load the program in ``text`` in one pass, then run its queries, asserts and retracts in order."""
        self.submissions += 1
        name = f"<input {self.submissions}>"
        self.lines[name] = source_lines(text)
        data = read_text(text, name)
        specials: list[tuple[str, Term]] = []
        items, locs = [], []
        for datum, (line, column) in zip(data, data.locs):
            head = datum.head if type(datum) is SList else None
            if type(head) is Var and is_anonymous(head):
                head = "?"  # the reader reads a lone ? as an anonymous variable
            if head in _SPECIAL:
                specials.append((head, self._special(datum, SourceLocation(name, line, column), head)))
            else:
                items.append(datum)
                locs.append((line, column))
        if items:
            program = load_text(text, name, Forms(items, locs))
            self.lines.update(program.lines)
            loaded = self.engine.load(program)
            self.events += program.of_type(ast.AtTime)
            for warning in loaded.warnings:
                self.err.print(warning.render(), style="yellow", markup=False)
            self._describe(program, loaded)
        for kind, value in specials:
            if kind == "?":
                self.query(value)
            else:
                self.change(kind, value)

    def _describe(self, program, loaded) -> None:
        for form in program.forms:
            if isinstance(form, ast.RapDef):
                self.note(f"defined RAP {term_to_str(form.head)}")
            elif isinstance(form, ast.MemoryRuleDef):
                self.note(f"defined memory rule {form.name}")
            elif isinstance(form, ast.VirtualSkillDef):
                self.note(f"defined virtual skill {term_to_str(form.head)}")
            elif isinstance(form, ast.Initial):
                self.note("noted initial for the planner; its facts are in memory")
            elif isinstance(form, (ast.Operator, ast.Agents, ast.RelationDef, ast.Goals, ast.Deadline)):
                self.note(f"noted {type(form).__name__.lower()} for the planner")
        for task in loaded.posted:
            self.note(f"posted [{task.id}] {task.text}")

    def _special(self, datum: SList, where: SourceLocation, head: str) -> Term:
        if len(datum.items) != 2:
            what = "a query, e.g. (? (at robot ?where))" if head == "?" else "one fact, e.g. (assert (at robot lab))"
            raise LanguageError(Problem(f"({head} ...) takes {what}", where, self._line(where)))
        term = to_term(datum.items[1])
        if head != "?" and (type(term) is not Compound or variables(term)):
            line, column = datum.locs[1]
            loc = SourceLocation(where.file, line, column)
            raise LanguageError(Problem(f"({head} ...) needs a ground fact such as (at robot lab)", loc,
                                        self._line(loc)))
        return term

    def _line(self, loc: SourceLocation) -> str | None:
        return line_of(self.lines.get(loc.file, []), loc.line)

    def note(self, text: str) -> None:
        self.out.print(text, style="dim", markup=False)

    def _report_fault(self) -> None:
        """A memory rule that broke while time passed: say so (the tasks have already failed)."""
        fault = self.engine.take_fault()
        if fault is not None:
            self.err.print(f"error: the run stopped: {fault}", style="red", markup=False)

    # -- memory ------------------------------------------------------------

    def change(self, kind: str, fact: Compound) -> None:
        """Assert or retract a fact, as an event from outside (memory rules run)."""
        self.engine.start()
        self.sequencer.change([(kind, fact)], "repl")

    def query(self, q: Term) -> list[dict]:
        """Print every answer of ``q`` over memory: its bindings, or yes / no."""
        self.engine.start()
        seq = self.sequencer
        answers = list(seq.memory.query(q, None, seq.relations))
        shown = [v for v in variables(q) if not v.name.startswith("_")]
        if not answers:
            self.out.print("no", markup=False)
        elif not shown:
            self.out.print("yes", markup=False)
        else:
            for answer in answers:
                self.out.print("  ".join(f"?{v.name} = {term_to_str(substitute(v, answer))}" for v in shown),
                               markup=False)
        return answers

    # -- time ------------------------------------------------------------

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass (the world, skills, timers)."""
        with self.lock:
            self.engine.advance(seconds, stop=self.interrupted.is_set)
            self._report_fault()

    def run(self, seconds: float | None) -> None:
        """:run: for ``seconds``, or until every live top-level task has ended."""
        self.interrupted.clear()
        engine = self.engine
        if seconds is not None:
            self.note(f"running {seconds:g} s of simulated time (Ctrl-C stops it)")
            self.advance(seconds)
        else:
            self.note("running until the posted tasks end (Ctrl-C stops it)")
            ended = engine.run(engine.now() + RUN_LIMIT, stop=self.interrupted.is_set)
            if ended == "stalled":
                self.note("nothing more can happen: no timer is due and no event can arrive")
            elif ended == "time-limit":
                self.note(f"the posted tasks are still running after {RUN_LIMIT:g} s")
        if self.interrupted.is_set():
            self.note(f"interrupted at {engine.now():g} s")
        self.note(f"time {engine.now():g} s")

    # -- commands --------------------------------------------------------

    def command(self, text: str) -> None:
        """Run one ``:command``."""
        name, _, rest = text.partition(" ")
        rest = rest.strip()
        handler = _COMMAND_HANDLERS.get(name)
        if handler is None:
            close = did_you_mean(name, COMMANDS, quote="")
            hint = f"; {close}" if close else ""
            raise AtlasError(f"unknown command {name}{hint} (:help lists them)")
        handler(self, rest)

    def _agenda(self, rest: str) -> None:
        from atlas_rap.cli.views import task_tree
        from atlas_rap.sequencer import agenda_tree

        nodes = agenda_tree(self.sequencer)
        if not nodes:
            self.out.print("the agenda is empty", markup=False)
        else:
            self.out.print(task_tree(nodes, f"agenda at {self.sequencer.now():g} s"))

    def _memory(self, rest: str) -> None:
        from atlas_rap.cli.views import memory_table
        from atlas_rap.lang import parse_term

        pattern = parse_term(rest, "<memory pattern>") if rest else None
        if pattern is not None and type(pattern) is not Compound:
            raise AtlasError(":memory takes a pattern such as (at ?thing ?place)")
        self.out.print(memory_table(self.sequencer.memory, pattern))

    def _trace(self, rest: str) -> None:
        import json

        count = _number(rest, ":trace N", int) if rest else 20
        for record in self.trace.records[-count:]:
            self.out.print(json.dumps(record, separators=(",", ":")), markup=False)

    def _step(self, rest: str) -> None:
        self.advance(_number(rest, ":step SECONDS", seconds=True) if rest else STEP)
        self.note(f"time {self.sequencer.now():g} s")

    def _run(self, rest: str) -> None:
        self.run(_number(rest, ":run SECONDS", seconds=True) if rest else None)

    def _pause(self, rest: str) -> None:
        self.paused = not self.paused
        self.note("the clock is paused (:pause again to restart it)" if self.paused else "the clock runs")

    def _reload(self, rest: str) -> None:
        if not rest:
            raise AtlasError(":reload takes a file name")
        names = self.engine.reload(resolve_user_path(rest)).names
        self.note(f"reloaded {rest}: {', '.join(names) if names else 'nothing to replace'}")

    def _skills(self, rest: str) -> None:
        for name, arities in sorted(self.skills.skills().items()):
            self.out.print(f"{name} ({'/'.join(map(str, sorted(arities)))} args)", markup=False)
        held = [f"{term_to_str(call)} for [{run.task.id}] {run.task.text}"
                for run, call in self.sequencer.holders.values()]
        if held:
            self.out.print("running: " + ", ".join(sorted(held)), markup=False)
        waiting = [f"[{claim.task.id}] {claim.task.text} for {term_to_str(claim.call)}"
                   for claim in self.sequencer.resources.claims()]
        if waiting:
            self.out.print("waiting: " + ", ".join(waiting), markup=False)

    def _layers(self, rest: str) -> None:
        stack = self.engine.stack if self.engine.built else None
        if stack is None:
            raise AtlasError(":layers needs a world: start the REPL with --world W, or load a mission that names one")
        if not stack.timeline:
            self.out.print(f"no layer is primary yet (enabled: {', '.join(sorted(stack.enabled))})", markup=False)
            return
        self.out.print(f"primary: Layer {stack.primary}; {stack.primary_summary(self.engine.now())}", markup=False)
        for switch in stack.timeline[-5:]:
            was = f" (was {switch.previous})" if switch.previous else ""
            self.out.print(f"{switch.t:9.2f}  Layer {switch.layer}{was}: {switch.reason}", markup=False)

    def _map(self, rest: str) -> None:
        from atlas_rap.outputs import output_file

        if self.engine.ensure_system().world_name == "none":
            raise AtlasError(":map needs a world: start the REPL with --world W, or load a mission that names one")
        path = output_file(shlex.split(rest)[0] if rest else "repl-map.png", ":map")
        self.picture.render(str(path), "atlas repl")
        self.note(f"picture written to {path}")

    def _plan(self, rest: str) -> None:
        from atlas_rap.lang import parse_term

        term = parse_term(f"({rest})", "<plan goals>")
        goals = term.args if type(term) is Compound and term.functor == "" else ()
        if not goals or any(type(goal) is not Compound for goal in goals):
            raise AtlasError(":plan takes goals such as (at robot lab) (seen box)")
        from atlas_rap.layers.deliberation import plan_for
        from atlas_rap.planner.checks import raise_problems

        self.engine.start()
        problem = self.engine.planning_problem(tuple(goals))
        raise_problems(problem)  # bad input is shown with its caret
        self.lock.release()  # the world goes on while the planner thinks (submit holds the lock once)
        try:
            plan = plan_for(problem)
        finally:
            self.lock.acquire()
        self.out.print(plan.to_text(), markup=False)

    def _save(self, rest: str) -> None:
        from atlas_rap.outputs import output_file, write_text

        if not rest:
            raise AtlasError(":save takes a file name")
        path = output_file(shlex.split(rest)[0], ":save")
        try:
            write_text(path, self.saved_text(), ":save")
        except OSError as exc:
            raise AtlasError(f"cannot write {path}: {exc.strerror}") from None
        self.note(f"saved the session (world {self.engine.ensure_system().world_name}, memory, definitions and "
                  f"{len(self.sequencer.live_roots())} live task(s)) to {path}")

    def _help(self, rest: str) -> None:
        self.out.print("Type a form (define-rap, post, assert, retract, include, plan, ...), "
                       "a query (? (at robot ?where)), or a command:", markup=False)
        for name, text in COMMANDS.items():
            self.out.print(f"  {name:<8} {text}", markup=False)

    def saved_text(self) -> str:
        """The session as a file that ``atlas repl FILE`` loads back (the module docstring says what is in it)."""
        engine, seq = self.engine, self.sequencer
        now = seq.now()
        lines = [f";; saved by atlas repl at {now:g} s simulated; `atlas repl FILE` loads it back.",
                 ";; The world starts again from its start; at-time and deadlines count from the saving."]
        if engine.seed:
            lines.append(f";; The session ran with --seed {engine.seed}.")
        lines += ["", format_node(ast.WorldDecl(_saved_world(engine)))]
        plans = {}  # a plan being carried out is saved as its (plan ...) form, not as the RAP made for it
        for form in engine.library.definitions.values():
            request = _plan_request(form)
            if request is not None:
                plans[form.name] = request
            elif not _is_layer_rule(form, engine):
                lines.append(format_node(form))
        lines += [format_node(form) for form in engine.library.planning
                  if isinstance(form, (ast.Operator, ast.Agents, ast.Goals, ast.Deadline))]
        facts = [term_to_str(fact) for fact in seq.memory if not self._from_world(fact)]
        if facts:
            lines.append("(initial-memory\n  " + "\n  ".join(facts) + ")")
        lines += [format_node(dataclasses.replace(event, time=event.time - now))
                  for event in self.events if event.time > now]
        for task in seq.live_roots():
            if task.call.functor in plans and not task.call.args:
                lines.append(format_node(plans[task.call.functor]))
                continue
            rap = seq.library.get((task.call.functor, len(task.call.args)))
            usual = rap.priority if rap is not None and rap.priority is not None else 0
            priority = None if task.priority == usual else task.priority
            deadline = None if task.deadline is None else max(task.deadline - now, 0.0)
            lines.append(format_node(ast.Post(task.call, priority, deadline)))
        return "\n".join(lines) + "\n"

    def _from_world(self, fact: Compound) -> bool:
        """Whether the fact was last asserted by the world (its prior map, its sensing skills and
        layers): the world asserts it again when it starts. Virtual skills are not the world."""
        if self._sources is None or self._sources[0] != len(self.trace.records):
            sources: dict[str, str] = {}
            for record in self.trace.records:
                if record.get("event") == Event.FACT_ASSERTED:
                    sources[record["fact"]] = str(record.get("by", ""))
            self._sources = (len(self.trace.records), sources)
        by = self._sources[1].get(term_to_str(fact), "")
        if by in ("world", "skills") or by.startswith("layer "):
            return True
        if by.startswith("skill ("):
            return by[len("skill ("):].split(" ")[0].rstrip(")") not in self.engine.virtual.skills()
        return False

    def close(self) -> None:
        """End the session: halt the live tasks (their skills disabled), then write the trace file."""
        try:
            with self.lock:
                if self.engine.built:
                    self.engine.halt_live("the session ended")
        finally:
            if self.sink is not None:
                self.sink.close()
            if self.map_out and self.engine.grid is not None:
                self.engine.save_map(self.map_out)


def _number(text: str, usage: str, kind: Callable = float, *, seconds: bool = False):
    """A command's number: at least 0, and finite (``:run nan``, ``:run inf`` and ``:run 1e400`` are errors);
    ``seconds``: a time, at most the longest time a file may give (``lang.validator.MAX_SECONDS``)."""
    try:
        value = kind(text)
    except ValueError:
        raise AtlasError(f"expected a number: {usage}") from None
    if type(value) is float and not math.isfinite(value):
        raise AtlasError(f"expected a finite number, not {text.strip()}: {usage}")
    if value < 0:
        raise AtlasError(f"expected a number at least 0: {usage}")
    if seconds and value > MAX_SECONDS:
        raise AtlasError(f"expected at most {MAX_SECONDS:g} seconds (about 32 years): {usage}")
    return value


_COMMAND_HANDLERS: dict[str, Callable[[Session, str], None]] = {
    ":agenda": Session._agenda, ":memory": Session._memory, ":trace": Session._trace, ":step": Session._step,
    ":run": Session._run, ":pause": Session._pause, ":reload": Session._reload, ":skills": Session._skills,
    ":map": Session._map, ":layers": Session._layers, ":plan": Session._plan, ":save": Session._save, ":help": Session._help,
}


def _saved_world(engine) -> str:
    """The world to name in a saved session: ``none``, a shipped world's name, or its file's full path."""
    if engine.world is None:
        return "none"
    if engine.remote is not None or engine.world_file is None:
        return engine.world.name
    from atlas_rap.sim.world import world_path

    try:
        if world_path(engine.world.name).resolve() == engine.world_file:
            return engine.world.name
    except AtlasError:
        pass
    return str(engine.world_file)


def _plan_request(form) -> ast.PlanRequest | None:
    """The ``(plan ...)`` of a RAP the engine made to carry out a top-level plan, or None."""
    from atlas_rap.layers.library import PLAN_TASK

    made = PLAN_TASK.split("{")[0]
    if not (isinstance(form, ast.RapDef) and form.name.startswith(made) and len(form.methods) == 1):
        return None
    body = form.methods[0].body
    if isinstance(body, ast.TaskNet) and len(body.nets) == 1 and isinstance(body.nets[0], ast.PlanRequest):
        return body.nets[0]
    return None


def _is_layer_rule(form, engine) -> bool:
    """A definition read from the layers' switching rules (``--layer-rules``), which come with the world."""
    try:
        return Path(form.loc.file).resolve() == engine.options.rules_file.resolve()
    except (OSError, ValueError):
        return False


def _escape(path: str) -> str:
    return path.replace("\\", "\\\\").replace('"', '\\"')
