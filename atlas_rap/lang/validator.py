"""The second pass: forms to typed AST nodes, reporting every problem.

Use :func:`validate` on the reader's forms of one file. It does not stop at
the first problem: it skips the bad clause or form, goes on, and raises one
:class:`~atlas_rap.errors.LanguageError` with all of them at the end. A
misspelt clause or form name gets the nearest valid name as a hint, and a
name from another language the name atlas uses (``lang/guesses.py``).

Choices (also in the language reference, docs/language/):

- Every top-level form is accepted in both ``.rap`` and ``.ap`` files: one
  language, two habits of use.
- A net item ``(NAME (LIST ...) ANNOTATION ...)`` whose second item is a list
  and whose remaining items are all annotations is a *labelled* step; so a
  task whose only argument is a list must be written with a label:
  ``(t1 (deliver (box 1)))``.
- ``(for L ...)`` may name several labels. Labels are unique within one
  ``define-rap`` and must name a step of the same method.
- Clause-style operator parts list their items directly
  (``(preconditions F1 F2)``); a single wrapping list (``(preconditions (F1 F2))``)
  and a single bare fact (``:preconditions (top ?x clear)``) are accepted too.
- Facts in ``initial-memory`` and ``initial`` must be ground; so must what
  nothing can bind: a posted task, the goals of ``goals`` and of a top-level
  ``plan``, ``at-time`` facts, a virtual skill's facts beyond its head's
  variables, a memory rule's effects beyond its ``on`` and ``when`` (the
  caret goes under the variable). A ``deadline``'s goal is a pattern and may
  have variables; a ``plan`` in a task net takes the RAP's bindings.
- A time (timeout, delay, at-time, deadline, duration) is at most
  :data:`MAX_SECONDS`; ``nan`` and ``inf`` are symbols, never numbers.
- ``(succeed Q)``-like clauses take exactly one query; write ``(and ...)``
  for several. ``define-relation`` bodies of several queries are their ``and``.
- ``(plan GOAL ... [:deadline S] [:max-failures N])`` is a top-level form and a
  net item: bare (``NET := ... | PLAN``, an :class:`ast.PlanRequest` node) or
  labelled, ``(p1 (plan GOAL ...) (for t2))`` (an :class:`ast.Step` whose task
  is the PlanRequest). So ``plan`` at the head of a net item is never a task
  or a label. Its goals come first, then the options: ``:deadline`` a number
  > 0, ``:max-failures`` a whole number >= 1, each at most once.
- ``(deadline GOAL SECONDS)``: GOAL is a goal as in ``goals``, SECONDS > 0.

Over 25 KB on purpose: the rules of every form of the language, each beside the hint its
error gives, in one pass over the syntax tree that the loader, the checks and the REPL call as one.
"""

from __future__ import annotations

from typing import Callable

from atlas_rap.errors import LanguageError, Problem, SourceLocation, did_you_mean, line_of, source_lines
from atlas_rap.lang import ast
from atlas_rap.lang.guesses import QUERY_OPERATORS, hint_for
from atlas_rap.lang.reader import Datum, Forms, SList
from atlas_rap.logic import Compound, MemoryRule, String, Term, Var, is_anonymous, is_ground, term_to_str, variables

TOP_LEVEL_FORMS = (
    "define-rap", "define-memory-rule", "define-virtual-skill", "at-time", "include", "world",
    "initial-memory", "post", "plan", "operator", "agents", "define-relation", "initial", "goals",
    "deadline",
)
RAP_CLAUSES = ("succeed", "constraints", "repeat-while", "repeat-until", "timeout", "priority",
               "retries", "retry-backoff", "method")
METHOD_PARTS = ("context", "on-preempt", "task-net", "primitive")
ON_PREEMPT = ("resume", "fail")
NUMBER_CLAUSES = ("timeout", "priority", "retries", "retry-backoff")
NET_FORMS = ("sequence", "parallel", "wait-for", "assert", "retract", "plan")
ANNOTATIONS = ("for", "until-end", "wait-for")
PRIMITIVE_ACTIONS = ("enable", "disable", "wait-for", "assert", "retract")
SCRIPT_LINES = ("after", "when")
SCRIPT_ACTIONS = ("assert", "retract", "finish")
OPERATOR_PARTS = ("purpose", "agent", "arguments", "preconditions", "constraints", "plot", "effects",
                  "duration", "uncontrolled", "probability")
PLOT_GROUPS = ("sequence", "parallel", "simultaneous")
MAX_SECONDS = 1e9
"""The longest time a file may give (a timeout, a delay, an at-time, a deadline, a duration): about 32
years of simulated time. More is no limit in practice, and sums of such times would overflow."""
QUERY_ARITY = {"not": 1, "<": 2, "<=": 2, ">": 2, ">=": 2, "=": 2, "/=": 2}


class _Skip(Exception):
    """Raised after a problem is recorded, to abandon the current form or clause."""


def to_term(datum: Datum) -> Term:
    """An s-expression as a logic term: a list whose head is a symbol is a
    compound term; ``()`` is ``nil``; any other list is ``Compound('', items)``."""
    if type(datum) is not SList:
        return datum
    items = datum.items
    if not items:
        return "nil"
    head = items[0]
    if type(head) is str:
        return Compound(head, tuple(to_term(x) for x in items[1:]))
    return Compound("", tuple(to_term(x) for x in items))


def _describe(datum: Datum) -> str:
    if type(datum) is SList:
        return "a list"
    if type(datum) is Var:
        return f"the variable ?{datum.name}"
    if type(datum) is String:
        return "a string"
    if isinstance(datum, (int, float)):
        return f"the number {datum}"
    if datum.startswith(":"):
        return f"the keyword {datum}"
    return f"'{datum}'"


def _free_variable(datum: Datum, where: tuple[int, int],
                   bound: frozenset[Var] = frozenset()) -> tuple[Var, tuple[int, int]] | None:
    """The first variable in ``datum`` that is not in ``bound``, with where it is written; None if none.
    Lists under the planner's own quantifiers (``adl:forall``, ``adl:exists``) bind their variables
    and are not looked into."""
    if type(datum) is Var:
        return None if datum in bound else (datum, where)
    if type(datum) is not SList or datum.head in _QUANTIFIERS:
        return None
    for item, loc in zip(datum.items, datum.locs):
        found = _free_variable(item, loc, bound)
        if found is not None:
            return found
    return None


_QUANTIFIERS = ("adl:forall", "adl:exists")


def _shown(var: Var) -> str:
    return "?" if is_anonymous(var) else f"?{var.name}"


class Validator:
    """Validates the forms of one file; ``problems`` collects what is wrong."""

    def __init__(self, filename: str, text: str) -> None:
        self.filename = filename
        self.text = text
        self.problems: list[Problem] = []
        self._lines: list[str] | None = None

    # ------------------------------------------------------------ reporting

    def _source_line(self, line: int) -> str | None:
        if self._lines is None:
            self._lines = source_lines(self.text)
        return line_of(self._lines, line)

    def loc(self, where: tuple[int, int]) -> SourceLocation:
        return SourceLocation(self.filename, where[0], where[1])

    def report(self, message: str, where: tuple[int, int], hint: str | None = None) -> None:
        """Record a problem at (line, column)."""
        self.problems.append(Problem(message, self.loc(where), self._source_line(where[0]), hint))

    def fail(self, message: str, where: tuple[int, int], hint: str | None = None):
        """Record a problem and abandon the current clause or form."""
        self.report(message, where, hint)
        raise _Skip

    @staticmethod
    def at(form: SList) -> tuple[int, int]:
        return form.line, form.column

    def unknown(self, what: str, name: str, where: tuple[int, int], choices: tuple[str, ...]):
        self.fail(f"unknown {what} '{name}'", where, hint_for(what, name, choices))

    # ------------------------------------------------------------ shapes

    def list_form(self, datum: Datum, where: tuple[int, int], expected: str) -> SList:
        if type(datum) is not SList:
            self.fail(f"expected {expected}, found {_describe(datum)}", where)
        return datum

    def name(self, datum: Datum, where: tuple[int, int], what: str) -> str:
        """A symbol standing as a name (not a variable, number, string or keyword)."""
        if type(datum) is str and not datum.startswith(":") and datum not in ("t", "nil"):
            return datum
        hint = "names are plain symbols such as t1 or attach-at-site"
        if type(datum) is Var:
            self.fail(f"a variable cannot stand as {what}; found ?{datum.name}", where, hint)
        self.fail(f"expected {what}, found {_describe(datum)}", where, hint)

    def head_name(self, form: SList, what: str) -> str:
        if not form.items:
            self.fail(f"expected {what}, found ()", self.at(form))
        return self.name(form.items[0], form.locs[0], what)

    def compound(self, datum: Datum, where: tuple[int, int], what: str) -> Compound:
        """A list whose head is a name: a fact, a task call or a skill call."""
        form = self.list_form(datum, where, f"{what} such as (name arg ...)")
        head = self.head_name(form, f"a name at the head of {what}")
        return Compound(head, tuple(to_term(x) for x in form.items[1:]))

    def number(self, datum: Datum, where: tuple[int, int], what: str, *, minimum: float | None = None,
               integer: bool = False, positive: bool = False, seconds: bool = False) -> float:
        """A number; ``minimum`` is the least allowed, ``positive`` asks for one > 0; ``seconds``: a time,
        at most :data:`MAX_SECONDS`."""
        ok = isinstance(datum, int) if integer else isinstance(datum, (int, float))
        if not ok or type(datum) is bool:
            kind = "a whole number" if integer else "a number"
            hint = None
            if type(datum) is str and datum.lstrip("+-") in ("nan", "inf", "infinity"):
                hint = f"{datum} is not a number here; for no limit, leave the limit out"
            self.fail(f"{what} must be {kind}, found {_describe(datum)}", where, hint)
        if minimum is not None and datum < minimum:
            self.fail(f"{what} must be at least {minimum}, found {datum}", where)
        if positive and not datum > 0:
            self.fail(f"{what} must be greater than 0, found {datum}", where)
        if seconds and datum > MAX_SECONDS:
            self.fail(f"{what} must be at most {MAX_SECONDS:g} seconds (about 32 years), found {datum:g}", where,
                      "times are in seconds" if what == "duration" else "for no time limit, leave the limit out")
        return datum

    def query(self, datum: Datum, where: tuple[int, int]) -> Term:
        """A memory query; checks the arity of not and the comparisons."""
        if type(datum) is str and datum in ("t", "nil"):
            return datum
        form = self.list_form(datum, where, "a query such as (at robot ?place)")
        self._check_query(form)
        return to_term(form)

    def _check_query(self, form: SList) -> None:
        if not form.items:
            self.fail("empty query ()", self.at(form), "write a fact pattern such as (at robot ?place)")
        head = form.items[0]
        if type(head) is str and head in QUERY_OPERATORS:
            self.fail(f"'{head}' is not a comparison or connective here", form.locs[0],
                      f"write ({QUERY_OPERATORS[head]} ...); the comparisons are < <= > >= = /=")
        if head in ("and", "or", "not"):
            for item, loc in zip(form.items[1:], form.locs[1:]):
                if type(item) is SList:
                    self._check_query(item)
                elif item not in ("t", "nil"):
                    self.fail(f"'{head}' takes queries, found {_describe(item)}", loc)
        arity = QUERY_ARITY.get(head) if type(head) is str else None
        if arity is not None and len(form.items) - 1 != arity:
            self.fail(f"'{head}' takes {arity} argument{'s' if arity > 1 else ''}, found {len(form.items) - 1}",
                      self.at(form), "wrap several queries in (and ...)" if head == "not" else None)

    def no_free_variable(self, datum: Datum, where: tuple[int, int], what: str, hint: str,
                         bound: frozenset[Var] = frozenset()) -> None:
        """Fail at the first variable of ``datum`` outside ``bound``: ``what`` says where it is."""
        found = _free_variable(datum, where, bound)
        if found is not None:
            var, loc = found
            self.fail(f"{what} has the unbound variable {_shown(var)}: nothing gives it a value", loc, hint)

    def ground_fact(self, datum: Datum, where: tuple[int, int], what: str) -> Compound:
        fact = self.compound(datum, where, "a fact")
        if not is_ground(fact):
            self.fail(f"{what} must be ground, but {term_to_str(fact)} has a variable", where,
                      "memory holds only facts without variables")
        return fact

    def one_arg(self, form: SList, what: str) -> tuple[Datum, tuple[int, int]]:
        if len(form.items) != 2:
            self.fail(f"({form.items[0]} ...) takes exactly one {what}, found {len(form.items) - 1}",
                      self.at(form), "wrap several queries in (and ...)" if what == "query" else None)
        return form.items[1], form.locs[1]

    def each(self, form: SList, start: int, parse: Callable[[Datum, tuple[int, int]], object]) -> tuple:
        """Parse items[start:] one by one; a bad item is reported and skipped."""
        out = []
        for item, loc in zip(form.items[start:], form.locs[start:]):
            try:
                out.append(parse(item, loc))
            except _Skip:
                pass
        return tuple(out)

    # ------------------------------------------------------------ top level

    def file(self, forms: Forms) -> ast.SourceFile:
        """The file's valid top-level forms; what is wrong is left in ``problems``."""
        nodes = []
        for datum, loc in zip(forms, forms.locs):
            try:
                nodes.append(self.top_level(datum, loc))
            except _Skip:
                pass
        return ast.SourceFile(self.filename, tuple(nodes))

    def top_level(self, datum: Datum, where: tuple[int, int]) -> ast.TopLevel:
        form = self.list_form(datum, where, "a top-level form such as (define-rap ...)")
        head = self.head_name(form, "a form name such as define-rap")
        parser = _TOP_LEVEL.get(head)
        if parser is None:
            self.unknown("top-level form", head, form.locs[0], TOP_LEVEL_FORMS)
        return parser(self, form)

    # ------------------------------------------------------------ define-rap

    def define_rap(self, form: SList) -> ast.RapDef:
        if len(form.items) < 2:
            self.fail("define-rap needs a head such as (attach-at-site ?site)", self.at(form))
        head_datum, head_loc = form.items[1], form.locs[1]
        if (type(head_datum) is SList and len(head_datum.items) == 2 and head_datum.items[0] == "index"
                and type(head_datum.items[1]) is SList):
            head_datum, head_loc = head_datum.items[1], head_datum.locs[1]
        head = self.compound(head_datum, head_loc, "a RAP head")
        fields: dict[str, object] = {}
        first_seen: dict[str, int] = {}
        methods = []
        for clause, loc in zip(form.items[2:], form.locs[2:]):
            try:
                clause = self.list_form(clause, loc, "a clause such as (succeed ...) or (method ...)")
                name = self.head_name(clause, "a clause name")
                if name not in RAP_CLAUSES:
                    self.unknown("clause", name, clause.locs[0], RAP_CLAUSES)
                if name == "method":
                    methods.append(self.method(clause))
                    continue
                if name in first_seen:
                    self.fail(f"clause '{name}' given twice in define-rap (first at line {first_seen[name]})",
                              clause.locs[0], "keep one; combine queries with (and ...)")
                first_seen[name] = clause.line
                arg, arg_loc = self.one_arg(clause, "number" if name in NUMBER_CLAUSES else "query")
                if name == "timeout":
                    fields["timeout"] = self.number(arg, arg_loc, "timeout", minimum=0, seconds=True)
                elif name == "priority":
                    fields["priority"] = self.number(arg, arg_loc, "priority")
                elif name == "retries":
                    fields["retries"] = self.number(arg, arg_loc, "retries", minimum=1, integer=True)
                elif name == "retry-backoff":
                    fields["retry_backoff"] = self.number(arg, arg_loc, "retry-backoff", minimum=0, seconds=True)
                else:
                    fields[name.replace("-", "_")] = self.query(arg, arg_loc)
            except _Skip:
                pass
        return ast.RapDef(head=head, methods=tuple(methods), loc=self.loc(self.at(form)), **fields)

    def method(self, form: SList) -> ast.Method:
        items, locs = form.items, form.locs
        index = 1
        name = None
        if len(items) > 1 and type(items[1]) is not SList:
            name = self.name(items[1], locs[1], "a method name")
            index = 2
        context = None
        on_preempt = None
        body = None
        for part, loc in zip(items[index:], locs[index:]):
            part = self.list_form(part, loc, "(context ...), (task-net ...) or (primitive ...)")
            kind = self.head_name(part, "a method part")
            if kind not in METHOD_PARTS:
                self.unknown("method part", kind, part.locs[0], METHOD_PARTS)
            if kind == "context":
                if context is not None:
                    self.fail("method has two contexts", part.locs[0], "combine them with (and ...)")
                context = self.query(*self.one_arg(part, "query"))
                continue
            if kind == "on-preempt":
                if on_preempt is not None:
                    self.fail("method has two on-preempt parts", part.locs[0], "keep one")
                on_preempt = self.on_preempt(*self.one_arg(part, "symbol"))
                continue
            if body is not None:
                self.fail("method has two bodies", part.locs[0],
                          "a method has one (task-net ...) or one (primitive ...); split it into two methods")
            body = self.task_net(part) if kind == "task-net" else self.primitive(part)
        if body is None:
            what = "context or body" if context is None else "body"
            self.fail(f"method has no {what}", self.at(form), "add (task-net ...) or (primitive ...)")
        return ast.Method(body=body, name=name, context=context, on_preempt=on_preempt or "resume",
                          loc=self.loc(self.at(form)))

    def on_preempt(self, datum: Datum, where: tuple[int, int]) -> str:
        """``resume`` or ``fail``: what a method's step does when its skill is taken."""
        if datum not in ON_PREEMPT:
            self.fail(f"on-preempt takes resume or fail, found {_describe(datum)}", where,
                      "resume (the default): the step waits and runs again; fail: the step ends :preempted")
        return datum  # type: ignore[return-value]

    # ------------------------------------------------------------ task nets

    def task_net(self, form: SList) -> ast.TaskNet:
        if len(form.items) < 2:
            self.fail("task-net is empty", self.at(form), "add steps, e.g. (sequence (t1 (approach-site ?s)) ...)")
        nets = self.each(form, 1, self.net)
        net = ast.TaskNet(nets=nets, loc=self.loc(self.at(form)))
        self._check_labels(net)
        return net

    def net(self, datum: Datum, where: tuple[int, int]) -> ast.Net:
        form = self.list_form(datum, where, "a step, (sequence ...), (parallel ...), (wait-for ...) or (plan ...)")
        head = form.head
        if head == "plan":
            return self.plan(form)
        if head in ("sequence", "parallel"):
            parts = self.each(form, 1, self.net)
            cls = ast.Sequence if head == "sequence" else ast.Parallel
            return cls(parts=parts, loc=self.loc(self.at(form)))
        if head == "wait-for":
            return self.wait_for(form)
        if head in ("assert", "retract"):
            return self.memory_op(form)
        return self.step(form)

    def step(self, form: SList) -> ast.Step:
        items, locs = form.items, form.locs
        if (len(items) >= 2 and type(items[0]) is str and type(items[1]) is SList
                and items[1].head not in ANNOTATIONS
                and all(type(x) is SList and x.head in ANNOTATIONS for x in items[2:])):
            label = self.name(items[0], locs[0], "a step label")
            if items[1].head == "plan":
                task = self.plan(items[1])
            else:
                task = self.compound(items[1], locs[1], "a task call")
            before: list[str] = []
            until_end = None
            waits = []
            for note, note_loc in zip(items[2:], locs[2:]):
                try:
                    if note.head == "wait-for":
                        waits.append(self.wait_for(note))
                    elif note.head == "for":
                        if len(note.items) < 2:
                            self.fail("(for ...) needs the label of a later step", note_loc)
                        before.extend(self.each(note, 1, lambda d, l: self.name(d, l, "a step label")))
                    else:
                        if until_end is not None:
                            self.fail("step has two until-end annotations", note_loc)
                        until_end = self.name(*self.one_arg(note, "step label"), "a step label")
                except _Skip:
                    pass
            return ast.Step(task=task, label=label, before=tuple(before), until_end=until_end,
                            waits=tuple(waits), loc=self.loc(self.at(form)))
        if type(items[0] if items else None) is Var:
            self.name(items[0], locs[0], "a task name or step label")
        if items and type(items[0]) is str and items[0] not in ("t", "nil") and not items[0].startswith(":"):
            for note in items[1:]:
                if type(note) is SList and note.head in ("for", "until-end"):
                    self.fail("annotation on a step without a label", (note.line, note.column),
                              "write the step as (LABEL (TASK ARG ...) ANNOTATION ...)")
        return ast.Step(task=self.compound(form, self.at(form), "a task call"), loc=self.loc(self.at(form)))

    def _check_labels(self, net: ast.TaskNet) -> None:
        steps: list[ast.Step] = []

        def collect(node: object) -> None:
            if isinstance(node, ast.Step):
                steps.append(node)
            elif isinstance(node, (ast.Sequence, ast.Parallel)):
                for part in node.parts:
                    collect(part)
            elif isinstance(node, ast.TaskNet):
                for part in node.nets:
                    collect(part)

        collect(net)
        labels: dict[str, ast.Step] = {}
        for step in steps:
            if step.label is None:
                continue
            if step.label in labels:
                self.report(f"step label '{step.label}' used twice in one method "
                            f"(first at line {labels[step.label].loc.line})", (step.loc.line, step.loc.column))
            else:
                labels[step.label] = step
        for step in steps:
            for ref in step.before + ((step.until_end,) if step.until_end else ()):
                if ref not in labels:
                    hint = did_you_mean(ref, labels) or ("the labels in this method are " + ", ".join(labels)
                                                         if labels else f"label the step, e.g. ({ref} (task ...))")
                    self.report(f"no step labelled '{ref}' in this method", (step.loc.line, step.loc.column), hint)

    def wait_for(self, form: SList) -> ast.WaitFor:
        items, locs = form.items, form.locs
        if len(items) < 2:
            self.fail("wait-for needs a query", self.at(form), "e.g. (wait-for (at robot ?place))")
        query = self.query(items[1], locs[1])
        outcome = None
        timeout = None
        i = 2
        while i < len(items):
            item, loc = items[i], locs[i]
            if item == ":timeout":
                if i + 1 >= len(items):
                    self.fail(":timeout needs a number of seconds", loc)
                timeout = self.number(items[i + 1], locs[i + 1], ":timeout", minimum=0, seconds=True)
                i += 2
                continue
            if type(item) is str and item.startswith(":") and len(item) > 1:
                if outcome is not None:
                    self.fail(f"wait-for has two outcomes, {outcome} and {item}", loc)
                outcome = item
                i += 1
                continue
            self.fail(f"expected an outcome keyword such as :succeed or :fail, or :timeout, found {_describe(item)}",
                      loc)
        return ast.WaitFor(query=query, outcome=outcome or ":succeed", timeout=timeout,
                           loc=self.loc(self.at(form)))

    def memory_op(self, form: SList) -> ast.MemoryOp:
        fact, loc = self.one_arg(form, "fact")
        return ast.MemoryOp(kind=form.items[0], fact=self.compound(fact, loc, "a fact"),
                            loc=self.loc(self.at(form)))

    # ------------------------------------------------------------ primitives

    def primitive(self, form: SList) -> ast.Primitive:
        if len(form.items) < 2:
            self.fail("primitive is empty", self.at(form), "add (enable (skill ...)) and a (wait-for ...)")
        return ast.Primitive(actions=self.each(form, 1, self.primitive_action), loc=self.loc(self.at(form)))

    def primitive_action(self, datum: Datum, where: tuple[int, int]) -> ast.PrimitiveAction:
        form = self.list_form(datum, where, "(enable ...), (disable ...), (wait-for ...), (assert ...)")
        kind = self.head_name(form, "a primitive action")
        if kind not in PRIMITIVE_ACTIONS:
            self.unknown("primitive action", kind, form.locs[0], PRIMITIVE_ACTIONS)
        here = self.loc(self.at(form))
        if kind == "wait-for":
            return self.wait_for(form)
        if kind in ("assert", "retract"):
            return self.memory_op(form)
        if kind == "disable" and form.items[1:] == (":above",):
            return ast.Disable(above=True, loc=here)
        if len(form.items) < 2:
            self.fail(f"{kind} needs a skill such as (move-to ?x ?y)"
                      + (" or :above" if kind == "disable" else ""), self.at(form))
        skills = self.each(form, 1, lambda d, l: self.compound(d, l, "a skill call"))
        return ast.Enable(skills=skills, loc=here) if kind == "enable" else ast.Disable(skills=skills, loc=here)

    # ------------------------------------------------------------ memory rules, skills, events

    def define_memory_rule(self, form: SList) -> ast.MemoryRuleDef:
        if len(form.items) < 2:
            self.fail("define-memory-rule needs a name", self.at(form))
        name = self.name(form.items[1], form.locs[1], "a rule name")
        trigger = None
        condition = None
        effects = []
        effect_clauses: list[SList] = []
        for clause, loc in zip(form.items[2:], form.locs[2:]):
            try:
                clause = self.list_form(clause, loc, "(on ...), (when ...), (assert ...) or (retract ...)")
                kind = self.head_name(clause, "a rule clause")
                if kind == "on":
                    if trigger is not None:
                        self.fail("rule has two 'on' clauses", clause.locs[0])
                    trigger = self.compound(*self.one_arg(clause, "fact pattern"), "a fact pattern")
                elif kind == "when":
                    if condition is not None:
                        self.fail("rule has two 'when' clauses", clause.locs[0], "combine them with (and ...)")
                    condition = self.query(*self.one_arg(clause, "query"))
                elif kind in ("assert", "retract"):
                    fact = self.memory_op(clause).fact
                    effects.append((kind, fact))
                    effect_clauses.append(clause)
                else:
                    self.unknown("rule clause", kind, clause.locs[0], ("on", "when", "assert", "retract"))
            except _Skip:
                pass
        if trigger is None:
            self.fail("memory rule has no (on FACT) clause", self.at(form),
                      "say which assertion triggers it, e.g. (on (at ?thing ?place))")
        bound = frozenset(variables(trigger)) | frozenset(variables(condition) if condition is not None else ())
        for clause in effect_clauses:
            self.no_free_variable(clause.items[1], clause.locs[1], f"this {clause.head}",
                                  "an effect may use the variables of (on ...) and (when ...); "
                                  "write a value in this one's place", bound)
        here = self.loc(self.at(form))
        rule = MemoryRule(name=name, trigger=trigger, condition=condition, effects=tuple(effects), loc=here)
        return ast.MemoryRuleDef(rule=rule, loc=here)

    def define_virtual_skill(self, form: SList) -> ast.VirtualSkillDef:
        if len(form.items) < 2:
            self.fail("define-virtual-skill needs a head such as (approach-site ?site)", self.at(form))
        head = self.compound(form.items[1], form.locs[1], "a skill head")
        lines = self.each(form, 2, self.script_line)
        self._script_variables(form, frozenset(variables(head)), term_to_str(head))
        return ast.VirtualSkillDef(head=head, lines=lines, loc=self.loc(self.at(form)))

    def script_line(self, datum: Datum, where: tuple[int, int]) -> ast.ScriptLine:
        form = self.list_form(datum, where, "(after SECONDS ...) or (when QUERY ...)")
        kind = self.head_name(form, "a script line")
        if kind == "after":
            if len(form.items) < 2:
                self.fail("after needs a number of seconds", self.at(form))
            delay = self.number(form.items[1], form.locs[1], "the delay of after", minimum=0, seconds=True)
            actions = self.each(form, 2, self.script_action)
            return ast.After(delay=delay, actions=actions, loc=self.loc(self.at(form)))
        if kind == "when":
            if len(form.items) < 3:
                self.fail("when needs a query and at least one (after ...)", self.at(form))
            condition = self.query(form.items[1], form.locs[1])
            lines = self.each(form, 2, self.script_line)
            if any(isinstance(line, ast.When) for line in lines):
                self.fail("when inside when: combine the queries with (and ...)", self.at(form))
            return ast.When(condition=condition, lines=lines, loc=self.loc(self.at(form)))
        self.unknown("script line", kind, form.locs[0], SCRIPT_LINES)

    def _script_variables(self, form: SList, bound: frozenset[Var], head: str) -> None:
        """Report the variables of a script's asserts and retracts that are not the head's (nothing binds them)."""
        todo = [line for line in form.items[2:] if type(line) is SList]
        while todo:
            line = todo.pop(0)
            start = 2 if line.head in ("after", "when") else 1
            for item in line.items[start:]:
                if type(item) is not SList:
                    continue
                if item.head in ("after", "when"):
                    todo.append(item)
                elif item.head in ("assert", "retract") and len(item.items) == 2:
                    try:
                        self.no_free_variable(item.items[1], item.locs[1], f"this {item.head}",
                                              f"a script may use the variables of its skill's head {head}; "
                                              f"write a value in this one's place", bound)
                    except _Skip:
                        pass

    def script_action(self, datum: Datum, where: tuple[int, int]) -> ast.ScriptAction:
        form = self.list_form(datum, where, "(assert ...), (retract ...) or (finish OUTCOME)")
        kind = self.head_name(form, "a script action")
        if kind in ("assert", "retract"):
            return self.memory_op(form)
        if kind == "finish":
            outcome, loc = self.one_arg(form, "outcome")
            if not (type(outcome) is str and outcome.startswith(":") and len(outcome) > 1):
                self.fail(f"finish takes an outcome keyword such as :succeed, found {_describe(outcome)}", loc)
            return ast.Finish(outcome=outcome, loc=self.loc(self.at(form)))
        self.unknown("script action", kind, form.locs[0], SCRIPT_ACTIONS)

    def memory_action(self, datum: Datum, where: tuple[int, int]) -> ast.MemoryOp:
        form = self.list_form(datum, where, "(assert FACT) or (retract FACT)")
        kind = self.head_name(form, "assert or retract")
        if kind not in ("assert", "retract"):
            self.unknown("memory action", kind, form.locs[0], ("assert", "retract"))
        return self.memory_op(form)

    def at_time(self, form: SList) -> ast.AtTime:
        if len(form.items) < 3:
            self.fail("at-time needs a time and at least one (assert ...) or (retract ...)", self.at(form))
        time = self.number(form.items[1], form.locs[1], "the time of at-time", minimum=0, seconds=True)
        return ast.AtTime(time=time, actions=self.each(form, 2, self.at_time_action), loc=self.loc(self.at(form)))

    def at_time_action(self, datum: Datum, where: tuple[int, int]) -> ast.MemoryOp:
        op = self.memory_action(datum, where)
        self.no_free_variable(datum.items[1], datum.locs[1], f"this {op.kind}",
                              "at-time changes memory with facts written out, "
                              "e.g. (at-time 30 (assert (door-closed office-door)))")
        return op

    # ------------------------------------------------------------ mission forms

    def include(self, form: SList) -> ast.Include:
        path, loc = self.one_arg(form, "path")
        if type(path) is not String:
            self.fail(f"include takes a path in double quotes, found {_describe(path)}", loc,
                      'e.g. (include "navigation.rap")')
        return ast.Include(path=path.value, loc=self.loc(self.at(form)))

    def world(self, form: SList) -> ast.WorldDecl:
        world, loc = self.one_arg(form, "world")
        if type(world) is String:
            return ast.WorldDecl(world=world.value, loc=self.loc(self.at(form)))
        return ast.WorldDecl(world=self.name(world, loc, "a world name"), loc=self.loc(self.at(form)))

    def initial_memory(self, form: SList) -> ast.InitialMemory:
        facts = self.each(form, 1, lambda d, l: self.ground_fact(d, l, "a fact in initial-memory"))
        return ast.InitialMemory(facts=facts, loc=self.loc(self.at(form)))

    def post(self, form: SList) -> ast.Post:
        if len(form.items) < 2:
            self.fail("post needs a task such as (deliver box-1 office)", self.at(form))
        task = self.compound(form.items[1], form.locs[1], "a task call")
        self.no_free_variable(form.items[1], form.locs[1], "the posted task",
                              "a posted task needs a value for each argument, e.g. (post (go-to office)); "
                              "variables get their values inside a RAP, from its head and memory")
        options = self.keyword_options(form, 2, {":priority": {}, ":deadline": {"minimum": 0, "seconds": True}})
        return ast.Post(task=task, priority=options.get(":priority"), deadline=options.get(":deadline"),
                        loc=self.loc(self.at(form)))

    def keyword_options(self, form: SList, start: int, allowed: dict[str, dict]) -> dict[str, float]:
        """``:key NUMBER`` pairs from ``items[start:]``, each key at most once;
        ``allowed`` maps each key to the keyword arguments of :meth:`number`
        that its value must meet (``minimum``, ``integer``, ``positive``, ``seconds``)."""
        options: dict[str, float] = {}
        items, locs = form.items, form.locs
        i = start
        while i < len(items):
            key, loc = items[i], locs[i]
            if key not in allowed:
                if type(key) is str and key.startswith(":"):
                    self.fail(f"unknown option {key}", loc, did_you_mean(key, allowed) or
                              "expected one of: " + ", ".join(allowed))
                self.fail(f"expected an option ({', '.join(allowed)}), found {_describe(key)}", loc)
            if key in options:
                self.fail(f"option {key} given twice", loc, "keep one")
            if i + 1 >= len(items):
                self.fail(f"{key} needs a number", loc)
            options[key] = self.number(items[i + 1], locs[i + 1], key, **allowed[key])
            i += 2
        return options

    def plan(self, form: SList) -> ast.PlanRequest:
        """``(plan GOAL ... [:deadline S] [:max-failures N])``, at top level or in a net."""
        items = form.items
        end = next((i for i in range(1, len(items)) if type(items[i]) is str and items[i].startswith(":")),
                   len(items))
        if end < 2:
            self.fail("plan needs at least one goal", self.at(form) if end == len(items) else form.locs[end],
                      "write the goals first, then the options, e.g. (plan (delivered mail office-b) :deadline 150)")
        goals = self.each(_Items(items[:end], form.locs[:end]), 1, self.query)
        options = self.keyword_options(form, end, {":deadline": {"positive": True, "seconds": True},
                                                   ":max-failures": {"minimum": 1, "integer": True}})
        return ast.PlanRequest(goals=goals, deadline=options.get(":deadline"),
                               max_failures=options.get(":max-failures"), loc=self.loc(self.at(form)))

    def top_plan(self, form: SList) -> ast.PlanRequest:
        """A top-level ``(plan GOAL ...)``: as in a net, but nothing can give its goals' variables values."""
        request = self.plan(form)
        for goal, loc in zip(form.items[1:1 + len(request.goals)], form.locs[1:]):
            self.no_free_variable(goal, loc, "a goal of a top-level plan",
                                  "write the goal with values, e.g. (plan (at robot office)); a (plan ...) "
                                  "in a RAP's task-net may use the RAP's variables")
        return request

    # ------------------------------------------------------------ AP: operators

    def operator(self, form: SList) -> ast.Operator:
        if len(form.items) < 2:
            self.fail("operator needs a name", self.at(form))
        name = self.name(form.items[1], form.locs[1], "an operator name")
        parts: dict[str, tuple[tuple[Datum, ...], tuple[tuple[int, int], ...], tuple[int, int]]] = {}
        items, locs = form.items, form.locs
        i = 2
        while i < len(items):
            item, loc = items[i], locs[i]
            try:
                if type(item) is str and item.startswith(":"):
                    key = item[1:]
                    if i + 1 >= len(items):
                        i += 1
                        self.fail(f"{item} needs a value", loc)
                    values, value_locs = (items[i + 1],), (locs[i + 1],)
                    i += 2
                elif type(item) is SList and type(item.head) is str:
                    key = item.head
                    values, value_locs = item.items[1:], item.locs[1:]
                    loc = item.locs[0]
                    i += 1
                else:
                    i += 1
                    self.fail(f"expected an operator part such as :purpose or (preconditions ...), "
                              f"found {_describe(item)}", loc)
                if key not in OPERATOR_PARTS:
                    self.unknown("operator part", key, loc, OPERATOR_PARTS)
                if key in parts:
                    self.fail(f"operator part '{key}' given twice (first at line {parts[key][2][0]})", loc)
                parts[key] = (values, value_locs, loc)
            except _Skip:
                pass
        fields: dict[str, object] = {}
        for key, (values, value_locs, loc) in parts.items():
            try:
                fields[key] = self.operator_part(key, values, value_locs, loc)
            except _Skip:
                pass
        if fields.get("probability") is not None and not fields.get("uncontrolled"):
            self.report("probability is for uncontrolled operators", parts["probability"][2],
                        "add :uncontrolled t, or remove :probability")
        return ast.Operator(name=name, loc=self.loc(self.at(form)), **fields)

    def operator_part(self, key: str, values: tuple, locs: tuple, where: tuple[int, int]) -> object:
        if key in ("purpose", "agent", "plot", "duration", "uncontrolled", "probability"):
            if len(values) != 1:
                self.fail(f"operator part '{key}' takes one value, found {len(values)}", where)
            value, loc = values[0], locs[0]
            if key == "purpose":
                return self.query(value, loc)
            if key == "agent":
                if type(value) is not Var:
                    self.fail(f"agent must be a variable such as ?arm, found {_describe(value)}", loc)
                return value
            if key == "plot":
                return self.plot(value, loc)
            if key == "duration":
                return self.number(value, loc, "duration", minimum=0, seconds=True)
            if key == "uncontrolled":
                if value not in ("t", "nil"):
                    self.fail(f"uncontrolled takes t or nil, found {_describe(value)}", loc)
                return value == "t"
            probability = self.number(value, loc, "probability", minimum=0)
            if probability > 1:
                self.fail(f"probability must be at most 1, found {probability}", loc)
            return probability
        values, locs = _unwrap_list(values, locs)
        if key == "arguments":
            return self.each(_Items(values, locs), 0, self.argument)
        if key == "effects":
            return self.each(_Items(values, locs), 0, self.effect)
        return self.each(_Items(values, locs), 0, self.query)

    def argument(self, datum: Datum, where: tuple[int, int]) -> ast.Argument:
        form = self.list_form(datum, where, "an argument such as (?size (get-value ?thing size))")
        if len(form.items) != 2 or type(form.items[0]) is not Var:
            self.fail("an argument is (?VARIABLE EXPRESSION)", where)
        return ast.Argument(var=form.items[0], expr=to_term(form.items[1]), loc=self.loc(where))

    def effect(self, datum: Datum, where: tuple[int, int]) -> ast.Effect:
        form = self.list_form(datum, where, "an effect such as (holding ?arm ?thing) or (not ...)")
        if form.head == "not":
            fact, loc = self.one_arg(form, "fact")
            return ast.Effect(fact=self.compound(fact, loc, "a fact"), positive=False, loc=self.loc(where))
        return ast.Effect(fact=self.compound(form, where, "a fact"), loc=self.loc(where))

    def plot(self, datum: Datum, where: tuple[int, int]) -> ast.Plot:
        form = self.list_form(datum, where, "a plot step or (sequence ...), (parallel ...), (simultaneous ...)")
        if form.head in PLOT_GROUPS:
            return ast.PlotGroup(kind=form.head, parts=self.each(form, 1, self.plot), loc=self.loc(where))
        return ast.PlotStep(term=self.compound(form, where, "a plot step"), loc=self.loc(where))

    # ------------------------------------------------------------ AP: problems

    def agents(self, form: SList) -> ast.Agents:
        groups: dict[str, tuple[str, ...]] = {}
        for group, loc in zip(form.items[1:], form.locs[1:]):
            try:
                group = self.list_form(group, loc, "(controlled NAME ...) or (uncontrolled NAME ...)")
                kind = self.head_name(group, "controlled or uncontrolled")
                if kind not in ("controlled", "uncontrolled"):
                    self.unknown("agent group", kind, group.locs[0], ("controlled", "uncontrolled"))
                if kind in groups:
                    self.fail(f"agent group '{kind}' given twice", group.locs[0])
                groups[kind] = self.each(group, 1, lambda d, l: self.name(d, l, "an agent name"))
            except _Skip:
                pass
        return ast.Agents(controlled=groups.get("controlled", ()), uncontrolled=groups.get("uncontrolled", ()),
                          loc=self.loc(self.at(form)))

    def define_relation(self, form: SList) -> ast.RelationDef:
        if len(form.items) < 3:
            self.fail("define-relation needs a head and a query", self.at(form),
                      "e.g. (define-relation (can-lift ?a ?w) (>= (get-value ?a max-lift) ?w))")
        head = self.compound(form.items[1], form.locs[1], "a relation head")
        body = self.each(form, 2, self.query)
        query = body[0] if len(body) == 1 else Compound("and", body)
        return ast.RelationDef(head=head, body=query, loc=self.loc(self.at(form)))

    def initial(self, form: SList) -> ast.Initial:
        facts = self.each(form, 1, lambda d, l: self.ground_fact(d, l, "a fact in initial"))
        return ast.Initial(facts=facts, loc=self.loc(self.at(form)))

    def goals(self, form: SList) -> ast.Goals:
        if len(form.items) < 2:
            self.fail("goals needs at least one goal", self.at(form))
        return ast.Goals(goals=self.each(form, 1, self.goal), loc=self.loc(self.at(form)),
                         goal_locs=tuple(self.loc(where) for where in form.locs[1:]))

    def goal(self, datum: Datum, where: tuple[int, int]) -> Term:
        """A goal of ``goals``: a query without free variables."""
        query = self.query(datum, where)
        self.no_free_variable(datum, where, "a goal",
                              "the planner plans for facts with values: write one in the variable's place, "
                              "e.g. (goals (delivered mail office-b))")
        return query

    def deadline(self, form: SList) -> ast.Deadline:
        """``(deadline GOAL SECONDS)``: GOAL achieved within SECONDS of the plan's start."""
        if len(form.items) != 3:
            self.fail(f"deadline takes a goal and a number of seconds, found {len(form.items) - 1} "
                      f"item{'' if len(form.items) == 2 else 's'}", self.at(form),
                      "e.g. (deadline (delivered mail office-b) 150)")
        goal = self.query(form.items[1], form.locs[1])  # a pattern: (at ?who c) applies to every goal it matches
        seconds = self.number(form.items[2], form.locs[2], "the seconds of deadline", positive=True, seconds=True)
        return ast.Deadline(goal=goal, seconds=seconds, loc=self.loc(self.at(form)),
                            goal_loc=self.loc(form.locs[1]))


class _Items:
    """A run of items with locations, shaped like an SList for ``Validator.each``."""

    def __init__(self, items: tuple, locs: tuple) -> None:
        self.items = items
        self.locs = locs


def _unwrap_list(values: tuple, locs: tuple) -> tuple[tuple, tuple]:
    """``((F1) (F2))`` given as one value is the list (F1) (F2); a bare fact
    ``(top ?x clear)`` and a single argument ``(?v EXPR)`` are lists of one;
    ``(t (F1))`` is the list of ``t`` and ``(F1)`` (no fact is named ``t``)."""
    if len(values) == 1 and type(values[0]) is SList:
        only = values[0]
        head = only.head
        if only.items and (type(head) is SList or head in ("t", "nil")):
            return only.items, only.locs
    return values, locs


_TOP_LEVEL: dict[str, Callable[[Validator, SList], ast.TopLevel]] = {
    "define-rap": Validator.define_rap,
    "define-memory-rule": Validator.define_memory_rule,
    "define-virtual-skill": Validator.define_virtual_skill,
    "at-time": Validator.at_time,
    "include": Validator.include,
    "world": Validator.world,
    "initial-memory": Validator.initial_memory,
    "post": Validator.post,
    "plan": Validator.top_plan,
    "operator": Validator.operator,
    "agents": Validator.agents,
    "define-relation": Validator.define_relation,
    "initial": Validator.initial,
    "goals": Validator.goals,
    "deadline": Validator.deadline,
}


def validate_partial(forms: Forms, filename: str, text: str) -> tuple[ast.SourceFile, list[Problem]]:
    """The valid forms of one file and the problems of the others (for the loader,
    which follows the includes of a file even when some of its forms are wrong)."""
    validator = Validator(filename, text)
    source = validator.file(forms)
    return source, validator.problems


def validate(forms: Forms, filename: str, text: str) -> ast.SourceFile:
    """Turn one file's forms into AST nodes; raise LanguageError listing every problem."""
    source, problems = validate_partial(forms, filename, text)
    if problems:
        raise LanguageError(problems)
    return source
