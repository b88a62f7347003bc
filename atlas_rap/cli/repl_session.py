"""The REPL's engine: a running sequencer (and world) that typed forms and commands act on.

:class:`Session` is what ``atlas repl`` drives, interactively or from a
pipe, and what tests drive directly. :meth:`Session.submit` takes one
submission (the text typed before Enter) and returns True when it worked;
output goes to the ``out`` console. What a submission may be:

- any top-level form of LANGUAGE.md: ``define-rap``, ``define-memory-rule``,
  ``define-virtual-skill``, ``post``, ``initial-memory``, ``at-time``,
  ``include``, ``plan``, and the AP forms (``operator``, ``agents``,
  ``define-relation``, ``initial``, ``goals``) that the planner uses;
- ``(assert FACT)`` and ``(retract FACT)``, straight into memory;
- a query ``(? QUERY)``, answered with every binding;
- a command, ``:agenda``, ``:memory [PATTERN]``, ... (``:help`` lists them).

Choices where the issue is silent:

- A submission is read and validated as a whole before any of it runs, so
  a syntax error anywhere in it changes nothing.
- A redefined RAP replaces the old one by name and arity; a running task
  uses it at its next method choice (as ``Mission.reload``).
- Time moves only by ``:step``, ``:run`` or, interactively, the background
  clock (paced to the wall clock, off with ``:pause``), so a piped session
  is reproducible.
- ``(plan GOAL ...)`` plans from the current memory with the operators
  typed or included so far and posts the RAP that carries the plan out;
  ``:plan GOAL ...`` only shows the plan.
- ``:save FILE`` writes memory as ``initial-memory`` and the live top-level
  tasks as ``post`` forms, with the RAPs, rules and virtual skills defined in
  the session, so ``atlas repl FILE`` (or ``include``) brings them back.
"""

from __future__ import annotations

import shlex
import threading
from pathlib import Path
from typing import Callable

from rich.console import Console

from atlas_rap.errors import (
    AtlasError,
    Problem,
    SourceError,
    SourceLocation,
    line_of,
    source_lines,
)
from atlas_rap.lang import ast, format_node, load
from atlas_rap.lang.loader import Program
from atlas_rap.lang.reader import Forms, SList, read_text
from atlas_rap.lang.validator import to_term, validate
from atlas_rap.logic import Compound, Term, Var, is_anonymous, substitute, term_to_str, variables
from atlas_rap.shipped import resolve_user_path

COMMANDS = {
    ":agenda": "the task tree with each task's status",
    ":memory": "[PATTERN]  the facts in memory (those matching PATTERN)",
    ":trace": "[N]  the last N trace records (default 20)",
    ":step": "[SECONDS]  advance time one step (0.1 s, or SECONDS)",
    ":run": "[SECONDS]  run SECONDS of simulated time, or until the posted tasks end (Ctrl-C stops it)",
    ":pause": "stop (or restart) the clock that runs the world in the background",
    ":reload": "FILE  load FILE again: its RAPs, rules and virtual skills replace the old ones",
    ":skills": "the skills tasks can use, and which are running",
    ":map": "[FILE.png]  draw the world and the robot's path (needs --world)",
    ":plan": "GOAL ...  show a plan for the goals (does not run it)",
    ":save": "FILE  write memory, live tasks and session definitions to a file that loads back",
    ":help": "this list",
}

STEP = 0.1
RUN_LIMIT = 3600.0


class Session:
    """A sequencer with its skills (and a simulated world with ``world``), ready for forms."""

    def __init__(self, world: str | None = None, seed: int = 0, *, out: Console | None = None,
                 trace_file: str | None = None, verbose: bool = False) -> None:
        from atlas_rap.cli.views import LiveTrace
        from atlas_rap.layers.setup import WorldSetup
        from atlas_rap.sequencer import JsonlSink, Trace
        from atlas_rap.sequencer.mission import Mission
        from atlas_rap.skills.virtual import VirtualSkills

        self.out = out or Console(highlight=False, soft_wrap=True)
        self.setup = WorldSetup(world or "none", seed)
        empty = Program(root="<repl>", files=(), forms=())
        self.skills = self.setup.skills_for(empty)
        self.virtual = self.skills if isinstance(self.skills, VirtualSkills) else self.skills.links[-1]
        self.trace = Trace(keep=True)
        self.mission = Mission(empty, self.skills, trace=self.trace)
        self.mission.started = True
        self.setup.start(self.mission)
        self.sequencer = self.mission.sequencer
        self.sink = JsonlSink(trace_file) if trace_file else None
        if self.sink is not None:
            self.trace.add_sink(self.sink)
        self.trace.add_sink(LiveTrace(self.out, verbose=verbose))
        self.lock = threading.RLock()
        self.defined: dict[str, ast.TopLevel] = {}  # session definitions, for :save
        self.planning: list[ast.TopLevel] = []  # operators, agents, relations, initial facts
        self.lines: dict[str, list[str]] = {}
        self.submissions = 0
        self.paused = False
        self.interrupted = threading.Event()
        self.failures = 0

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
                self.out.print(problem.render(), style="red", markup=False)
        except AtlasError as exc:
            self.out.print(f"error: {exc}", style="red", markup=False)
        self.failures += 1
        return False

    def forms(self, text: str) -> None:
        """Read and validate every form of ``text``, then run them in order."""
        self.submissions += 1
        name = f"<input {self.submissions}>"
        self.lines[name] = source_lines(text)
        data = read_text(text, name)
        actions: list[tuple[str, object, SourceLocation]] = []
        toplevel_items, toplevel_locs = [], []
        for datum, (line, column) in zip(data, data.locs):
            where = SourceLocation(name, line, column)
            head = datum.head if type(datum) is SList else None
            if type(head) is Var and is_anonymous(head):
                head = "?"  # the reader reads a lone ? as an anonymous variable
            if head in ("?", "assert", "retract"):
                actions.append((head, self._special(datum, where, head), where))
            else:
                toplevel_items.append(datum)
                toplevel_locs.append((line, column))
                actions.append(("form", None, where))
        validated = iter(validate(Forms(toplevel_items, toplevel_locs), name, text).forms)
        for kind, value, where in actions:
            if kind == "form":
                form = next(validated)
                if isinstance(form, ast.Include):
                    program = load(resolve_user_path(form.path))
                    self.lines.update(program.lines)
                    for included in program.forms:
                        self.apply(included)
                else:
                    self.apply(form)
            elif kind == "?":
                self.query(value)
            else:
                self.change(kind, value)

    def _special(self, datum: SList, where: SourceLocation, head: str) -> Term:
        if len(datum.items) != 2:
            what = "a query, e.g. (? (at robot ?where))" if head == "?" else "one fact, e.g. (assert (at robot lab))"
            raise SourceError(Problem(f"({head} ...) takes {what}", where, self._line(where)))
        term = to_term(datum.items[1])
        if head != "?" and (type(term) is not Compound or variables(term)):
            line, column = datum.locs[1]
            loc = SourceLocation(where.file, line, column)
            raise SourceError(Problem(f"({head} ...) needs a ground fact such as (at robot lab)", loc, self._line(loc)))
        return term

    def _line(self, loc: SourceLocation) -> str | None:
        return line_of(self.lines.get(loc.file, []), loc.line)

    def apply(self, form: ast.TopLevel) -> None:
        """Run one validated top-level form."""
        seq = self.sequencer
        if isinstance(form, ast.RapDef):
            self._check_rap(form)
            seq.define([form])
            self.defined[f"rap {form.name}/{len(form.params)}"] = form
            self.note(f"defined RAP {term_to_str(form.head)}")
        elif isinstance(form, ast.MemoryRuleDef):
            seq.define_rules([form.rule])
            self.defined[f"rule {form.name}"] = form
            self.note(f"defined memory rule {form.name}")
        elif isinstance(form, ast.VirtualSkillDef):
            self.virtual.define([form])
            seq.refresh_skills()
            self.defined[f"skill {form.name}"] = form
            self.note(f"defined virtual skill {term_to_str(form.head)}")
        elif isinstance(form, ast.Post):
            self._check_task(form.task, form.loc)
            task = seq.post(form.task, form.priority, form.deadline)
            seq.settle()
            self.note(f"posted [{task.id}] {task.text}")
        elif isinstance(form, ast.InitialMemory):
            seq.change([("assert", fact) for fact in form.facts], "repl")
        elif isinstance(form, ast.AtTime):
            if form.time < seq.now():
                raise AtlasError(f"at-time {form.time:g} is in the past (the time is {seq.now():g} s)")
            changes = [(op.kind, op.fact) for op in form.actions]
            seq.timers.at(form.time, lambda: seq.change(changes, f"at-time {form.time:g}"))
        elif isinstance(form, ast.PlanRequest):
            self.plan(form.goals, execute=True, loc=form.loc)
        elif isinstance(form, (ast.Operator, ast.Agents, ast.RelationDef, ast.Initial, ast.Goals)):
            self.planning.append(form)
            if isinstance(form, ast.RelationDef):
                from atlas_rap.logic import Relation

                seq.relations.setdefault(form.name, []).append(Relation(form.head, form.body))
            self.note(f"noted {type(form).__name__.lower()} for the planner")
        elif isinstance(form, ast.WorldDecl):
            raise AtlasError("the world is chosen when the REPL starts: atlas repl --world W")

    def note(self, text: str) -> None:
        self.out.print(text, style="dim", markup=False)

    def _check_rap(self, rap: ast.RapDef) -> None:
        """The sequencer's load-time checks of a new RAP, against what is defined now."""
        from atlas_rap.sequencer.checks import check_program

        raps = {(r.name, len(r.params)): r for r in self.sequencer.library.values()}
        raps[(rap.name, len(rap.params))] = rap
        program = Program(root="<repl>", files=(), forms=tuple(raps.values()), lines=self.lines)
        problems = [p for p in check_program(program, self.skills.skills(), self.skills.produces())
                    if p.location.file == rap.loc.file and p.severity == "error"]
        if problems:
            raise SourceError(problems)

    def _check_task(self, call: Compound, loc: SourceLocation) -> None:
        seq = self.sequencer
        if not seq.is_rap(call) and not seq.is_skill(call):
            raise SourceError(Problem(f"no RAP or skill {call.functor} with {len(call.args)} argument(s)",
                                      loc, self._line(loc), "define it with define-rap first, or see :skills"))

    # -- memory ------------------------------------------------------------

    def change(self, kind: str, fact: Compound) -> None:
        """Assert or retract a fact, as an event from outside (memory rules run)."""
        self.sequencer.change([(kind, fact)], "repl")

    def query(self, q: Term) -> list[dict]:
        """Print every answer of ``q`` over memory: its bindings, or yes / no."""
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
            executive = self.setup.executive
            if executive is not None:
                executive.advance(seconds, stop=self.interrupted.is_set)
            else:
                seq = self.sequencer
                until = seq.now() + seconds
                seq.settle()
                while not self.interrupted.is_set():
                    due = seq.timers.next_time()
                    if due is None or due > until:
                        break
                    seq.advance_to(due)
                if not self.interrupted.is_set():
                    seq.advance_to(until)

    def run(self, seconds: float | None) -> None:
        """:run: for ``seconds``, or until every live top-level task has ended."""
        self.interrupted.clear()
        seq = self.sequencer
        if seconds is not None:
            self.advance(seconds)
        else:
            start = seq.now()
            while seq.live_roots() and not self.interrupted.is_set() and seq.now() - start < RUN_LIMIT:
                before = seq.now()
                due = seq.timers.next_time()
                if self.setup.executive is None and due is None:
                    self.note("nothing more can happen: no timer is due and no event can arrive")
                    break
                self.advance(STEP if self.setup.executive is not None else max(due - before, 0.0) or STEP)
        if self.interrupted.is_set():
            self.note(f"interrupted at {seq.now():g} s")
        self.note(f"time {seq.now():g} s")

    # -- commands --------------------------------------------------------

    def command(self, text: str) -> None:
        """Run one ``:command``."""
        name, _, rest = text.partition(" ")
        rest = rest.strip()
        handler = _COMMAND_HANDLERS.get(name)
        if handler is None:
            from difflib import get_close_matches

            close = get_close_matches(name, list(COMMANDS), n=1)
            hint = f"; did you mean {close[0]}?" if close else ""
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
        self.advance(_number(rest, ":step SECONDS") if rest else STEP)
        self.note(f"time {self.sequencer.now():g} s")

    def _run(self, rest: str) -> None:
        self.run(_number(rest, ":run SECONDS") if rest else None)

    def _pause(self, rest: str) -> None:
        self.paused = not self.paused
        self.note("the clock is paused (:pause again to restart it)" if self.paused else "the clock runs")

    def _reload(self, rest: str) -> None:
        if not rest:
            raise AtlasError(":reload takes a file name")
        names = self.mission.reload(resolve_user_path(rest))
        self.note(f"reloaded {rest}: {', '.join(names) if names else 'nothing to replace'}")

    def _skills(self, rest: str) -> None:
        running = {str(call) for call in self.virtual.running()}
        if self.setup.manager is not None:
            running |= {str(call) for call in self.setup.manager.running()}
        for name, arities in sorted(self.skills.skills().items()):
            self.out.print(f"{name} ({'/'.join(map(str, sorted(arities)))} args)", markup=False)
        if running:
            self.out.print("running: " + ", ".join(sorted(running)), markup=False)

    def _map(self, rest: str) -> None:
        if self.setup.world is None:
            raise AtlasError(":map needs a world: start the REPL with --world W")
        path = rest or "repl-map.png"
        self.setup.render(path, "atlas repl")
        self.note(f"picture written to {path}")

    def _plan(self, rest: str) -> None:
        from atlas_rap.lang import parse_term

        term = parse_term(f"({rest})", "<plan goals>")
        goals = term.args if type(term) is Compound and term.functor == "" else ()
        if not goals or any(type(goal) is not Compound for goal in goals):
            raise AtlasError(":plan takes goals such as (at robot lab) (seen box)")
        self.plan(tuple(goals), execute=False, loc=None)

    def _save(self, rest: str) -> None:
        if not rest:
            raise AtlasError(":save takes a file name")
        path = Path(shlex.split(rest)[0])
        try:
            path.write_text(self.saved_text(), encoding="utf-8")
        except OSError as exc:
            raise AtlasError(f"cannot write {path}: {exc.strerror}") from None
        self.note(f"saved memory, {len(self.sequencer.live_roots())} live task(s) and "
                  f"{len(self.defined)} definition(s) to {path}")

    def _help(self, rest: str) -> None:
        self.out.print("Type a form (define-rap, post, assert, retract, include, plan, ...), "
                       "a query (? (at robot ?where)), or a command:", markup=False)
        for name, text in COMMANDS.items():
            self.out.print(f"  {name:<8} {text}", markup=False)

    def saved_text(self) -> str:
        """Memory, live top-level tasks and session definitions as a file that loads back."""
        seq = self.sequencer
        lines = [f";; saved by atlas repl at {seq.now():g} s simulated", ""]
        lines += [format_node(form) for form in self.defined.values()]
        facts = [term_to_str(f) for f in seq.memory]
        if facts:
            lines.append("(initial-memory\n  " + "\n  ".join(facts) + ")")
        for task in seq.live_roots():
            lines.append(f"(post {term_to_str(task.call)})")
        return "\n".join(lines) + "\n"

    # -- planning ----------------------------------------------------------

    def plan(self, goals: tuple[Term, ...], execute: bool, loc: SourceLocation | None):
        """Plan for ``goals`` from memory with the session's operators; show it, and
        with ``execute`` post the RAP that carries it out."""
        from atlas_rap.planner.checks import raise_problems
        from atlas_rap.planner.execute import PLAN_TASK, plan_rap_text
        from atlas_rap.planner.problem import problem_from_program
        from atlas_rap.planner.solve import solve

        forms = tuple(self.planning) + tuple(self.sequencer.library.values())
        program = Program(root="<repl>", files=(), forms=forms, lines=self.lines)
        problem = problem_from_program(program, name="<repl>").asked(goals, tuple(self.sequencer.memory), loc)
        raise_problems(problem)
        result = solve(problem)
        self.out.print(result.to_text(), markup=False)
        if result.status != "solved" or not execute:
            return result
        self.submissions += 1
        name = PLAN_TASK.format(n=self.submissions)
        text, missing = plan_rap_text(result, list(self.sequencer.library.values()), name)
        if missing:
            raise AtlasError("no RAP can execute plan step " + "; ".join(missing))
        self.forms(text + f"(post ({name}))\n")
        return result

    def close(self) -> None:
        """Write the trace file, if one was asked for."""
        if self.sink is not None:
            self.sink.close()


def _number(text: str, usage: str, kind: Callable = float):
    try:
        value = kind(text)
    except ValueError:
        raise AtlasError(f"expected a number: {usage}") from None
    if value < 0:
        raise AtlasError(f"expected a number at least 0: {usage}")
    return value


_COMMAND_HANDLERS: dict[str, Callable[[Session, str], None]] = {
    ":agenda": Session._agenda, ":memory": Session._memory, ":trace": Session._trace, ":step": Session._step,
    ":run": Session._run, ":pause": Session._pause, ":reload": Session._reload, ":skills": Session._skills,
    ":map": Session._map, ":plan": Session._plan, ":save": Session._save, ":help": Session._help,
}
