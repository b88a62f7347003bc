"""Load-time checks of a RAP program against the skills that will run it.

The validator checks each form on its own; these checks need the whole
program and the skill link, so they run when a mission is loaded (and in
``atlas check``). Errors stop the run before anything moves:

- a step whose task is neither a RAP nor a skill (with the nearest name as
  a hint), or that has the wrong number of arguments (a ``(plan GOAL ...)``
  item or step is no call: its goals are queries for the planner, so only
  its ``wait-for``s and orderings are checked here);
- a primitive that enables or disables a skill nobody provides, or gives
  one a literal argument of another type than the skill declares
  (``(creep fast 0.3)`` for ``distance: number``; variables and
  expressions are not checked);
- a post of something that is not a RAP;
- steps ordered in a circle by ``sequence``, ``(for L)`` and ``until-end``
  (they would wait for each other for ever);
- a mission with nothing to run (no ``post``);
- in a world, a place it lacks named for a skill's ``place``
  (:mod:`atlas_rap.sequencer.place_checks`, which the callers run beside these);
- a fact in ``initial-memory`` or ``at-time`` whose arithmetic has no value
  (``(level (/ 1 0))``), with the caret under the fact: asserted facts are
  evaluated (``(level (+ 1 2))`` is ``(level 3)``), and this one would
  fail when it is asserted.

Warnings do not stop the run:

- in a mission, a ``wait-for`` of a RAP the mission can reach from its
  posts that can never match, because no skill, memory rule, script, step
  or initial fact produces its predicate. (A library checked on its own is
  not warned: a mission may produce the fact.)
- memory rules that can trigger each other in a cycle
  (``logic.rules.rule_cycles``), at the first rule of the cycle: unless a
  ``(when ...)`` stops it, one assertion makes them fire until the engine
  gives up.
"""

from __future__ import annotations

from typing import Iterable, Iterator, Mapping, Sequence

from atlas_rap.errors import AtlasError, Problem, SourceLocation, did_you_mean
from atlas_rap.lang import ast
from atlas_rap.lang.reader import SList, read_text
from atlas_rap.lang.guesses import net_hint
from atlas_rap.logic import (COMPARISONS, Compound, FactError, String, Term, evaluated_fact, is_ground, rule_cycles,
                             term_to_str)


ParamTypes = Mapping[str, Sequence[tuple[str, str]]]
"""Skills' declared parameters: name → ((parameter, type), ...), the types ``number``, ``symbol``,
``string``, ``list`` and ``any`` (``atlas_rap.skills.catalog.Param`` is such a pair)."""


def check_program(program, skills: dict[str, set[int]], produces: Iterable[str], *,
                  require_post: bool = False, param_types: ParamTypes | None = None) -> list[Problem]:
    """Every problem of ``program`` run with ``skills`` (name → arities), errors first.

    ``produces`` are the predicates the skills' events may assert. With
    ``require_post`` (``atlas run``) a program that posts nothing is an error.
    ``param_types``: the declared parameters of the skills whose literal arguments are checked.
    """
    return _Checker(program, skills, set(produces), param_types or {}).run(require_post)


class _Checker:
    def __init__(self, program, skills: dict[str, set[int]], produces: set[str], param_types: ParamTypes) -> None:
        self.program = program
        self.skills = skills
        self.param_types = param_types
        self.raps: dict[str, set[int]] = {}
        for rap in program.of_type(ast.RapDef):
            self.raps.setdefault(rap.name, set()).add(len(rap.params))
        self.produced = produces | _produced_by_program(program)
        self.problems: list[Problem] = []
        self.warn_waits = False

    def report(self, message: str, loc: SourceLocation, hint: str | None = None, severity: str = "error") -> None:
        self.problems.append(Problem(message, loc, self.program.source_line(loc), hint, severity))

    def run(self, require_post: bool) -> list[Problem]:
        reachable = self.reachable()
        for rap in self.program.of_type(ast.RapDef):
            self.warn_waits = (rap.name, len(rap.params)) in reachable
            for method in rap.methods:
                self.method(method)
        for post in self.program.of_type(ast.Post):
            self.post(post)
        self.memory_facts()
        self.memory_rules()
        if require_post and not self.program.of_type(ast.Post):
            raps = self.program.of_type(ast.RapDef)
            example = f", e.g. (post {term_to_str(raps[-1].head)})" if raps else ""
            self.report("this mission posts no task, so there is nothing to run",
                        SourceLocation(self.program.root, 1, 1),
                        f"add a top-level (post (TASK ARG ...)) naming a RAP{example}")
        errors = [p for p in self.problems if p.severity == "error"]
        warnings = [p for p in self.problems if p.severity != "error"]
        return errors + warnings

    def reachable(self) -> set[tuple[str, int]]:
        """The RAPs (name, arity) that the posts can reach through task-net steps."""
        raps = {(rap.name, len(rap.params)): rap for rap in self.program.of_type(ast.RapDef)}
        todo = [(post.task.functor, len(post.task.args)) for post in self.program.of_type(ast.Post)]
        seen: set[tuple[str, int]] = set()
        while todo:
            key = todo.pop()
            if key in seen or key not in raps:
                continue
            seen.add(key)
            for method in raps[key].methods:
                if isinstance(method.body, ast.TaskNet):
                    todo.extend((node.task.functor, len(node.task.args)) for node in net_nodes(method.body)
                                if isinstance(node, ast.Step) and node.plan is None)
        return seen

    # -- calls --------------------------------------------------------------

    def method(self, method: ast.Method) -> None:
        body = method.body
        if isinstance(body, ast.Primitive):
            for action in body.actions:
                if isinstance(action, ast.Enable):
                    for skill in action.skills:
                        self.skill(skill, action.loc, "enable")
                elif isinstance(action, ast.Disable):
                    for skill in action.skills:
                        self.skill(skill, action.loc, "disable")
                elif isinstance(action, ast.WaitFor):
                    self.wait_for(action)
            return
        for node in net_nodes(body):
            if isinstance(node, ast.Step):
                if node.plan is None:
                    self.call(node.task, node.loc, node.label)
                for wait in node.waits:
                    self.wait_for(wait, node.loc)
            elif isinstance(node, ast.WaitFor):
                self.wait_for(node)
        self.orderings(body)

    def call(self, task: Compound, loc: SourceLocation, label: str | None = None) -> None:
        name, arity = task.functor, len(task.args)
        if arity in self.raps.get(name, ()):
            return
        if arity in self.skills.get(name, ()):  # a skill as a step: enabled with these arguments
            self.arguments(task, loc)
            return
        known = self.raps.get(name, set()) | self.skills.get(name, set())
        if known:
            self.report(f"{name} takes {_arities(known)}, not {arity}", loc,
                        f"call it as ({name}{' ?x' * min(known)})")
            return
        # (wait-until (ready)) reads as the step labelled wait-until: its label is the wrong guess
        hint = net_hint(name) or (net_hint(label) if label else None)
        hint = hint or did_you_mean(name, sorted(set(self.raps) | set(self.skills))) or \
            "define it with define-rap, or as a skill (define-virtual-skill for runs without a world)"
        self.report(f"'{name}' is neither a RAP nor a skill", loc, hint)

    def skill(self, skill: Compound, loc: SourceLocation, verb: str) -> None:
        name, arity = skill.functor, len(skill.args)
        if arity in self.skills.get(name, ()):
            self.arguments(skill, loc)
            return
        if name in self.skills:
            self.report(f"skill {name} takes {_arities(self.skills[name])}, not {arity}", loc)
        elif name in self.raps:
            self.report(f"cannot {verb} {name}: it is a RAP, not a skill", loc,
                        "call a RAP as a step of a task-net")
        else:
            known = ", ".join(sorted(self.skills))
            hint = (did_you_mean(name, sorted(self.skills)) or f"the skills here are: {known}" if known else
                    "no skills are known here; for a run without a world, define it with define-virtual-skill")
            self.report(f"cannot {verb} unknown skill '{name}'", loc, hint)

    def arguments(self, skill: Compound, loc: SourceLocation) -> None:
        """Each literal argument of a skill call against the type its parameter declares."""
        declared = self.param_types.get(skill.functor)
        if not declared or len(declared) != len(skill.args):
            return
        for (param, kind), arg in zip(declared, skill.args):
            found = _literal_type(arg)
            if found is not None and kind not in ("any", found):
                signature = ", ".join(f"{name}: {of}" for name, of in declared)
                self.report(f"skill {skill.functor}'s {param} is a {kind}, not the {found} {term_to_str(arg)}", loc,
                            f"{skill.functor} takes ({signature})")

    def post(self, post: ast.Post) -> None:
        name, arity = post.task.functor, len(post.task.args)
        if arity in self.raps.get(name, ()):
            return
        if arity in self.skills.get(name, ()):
            self.report(f"cannot post {name}: it is a skill, and only RAPs go on the agenda", post.loc,
                        f"wrap it in a RAP: (define-rap ({name} ...) (method (task-net ({name} ...))))")
            return
        self.call(post.task, post.loc)

    # -- wait-for -------------------------------------------------------------

    def wait_for(self, wait: ast.WaitFor, loc: SourceLocation | None = None) -> None:
        if not self.warn_waits:
            return
        missing = _unproducible(wait.query, self.produced)
        if missing:
            names = ", ".join(sorted(missing))
            self.report(f"this wait-for can never match: nothing asserts {names} facts "
                        f"(no skill event, memory rule, script, step or initial fact)",
                        wait.loc if wait.loc.line else (loc or wait.loc),
                        "check the predicate's spelling, or assert it somewhere", severity="warning")

    # -- memory -------------------------------------------------------------------

    def memory_facts(self) -> None:
        """Report the initial-memory and at-time facts whose arithmetic has no value."""
        for form in self.program.forms:
            if isinstance(form, ast.InitialMemory):
                for i, fact in enumerate(form.facts):
                    self.fact_arithmetic(fact, form.loc, (1 + i,))
            elif isinstance(form, ast.AtTime):
                for i, op in enumerate(form.actions):
                    if is_ground(op.fact):  # one with variables fails as it is asserted
                        self.fact_arithmetic(op.fact, form.loc, (2 + i, 1))

    def fact_arithmetic(self, fact: Compound, form_loc: SourceLocation, path: tuple[int, ...]) -> None:
        try:
            evaluated_fact(fact)
        except FactError as exc:
            self.report(str(exc), item_location(self.program, form_loc, path),
                        "arithmetic in a fact is evaluated when the fact is asserted: "
                        "every argument of + - * / must be a number, with no division by zero and no "
                        "result past about 1.8e308")

    def memory_rules(self) -> None:
        """Warn about memory rules that can trigger each other in a cycle."""
        rules = [form.rule for form in self.program.of_type(ast.MemoryRuleDef)]
        for cycle in rule_cycles(rules):
            first = cycle[0]
            if len(cycle) == 1:
                message = f"memory rule {first.label} can trigger itself: it asserts a fact its own (on ...) matches"
            else:
                chain = " -> ".join(rule.label for rule in cycle)
                message = f"memory rules can trigger each other in a cycle: {chain} -> {first.name}"
            guarded = [rule.name for rule in cycle if rule.condition is not None]
            hint = (f"make sure the (when ...) of {', '.join(guarded)} stops the cycle" if guarded else
                    "a rule in this cycle needs a (when ...) that stops it")
            loc = first.loc or SourceLocation(self.program.root, 1, 1)
            self.report(message, loc, hint + ", or one assertion makes the rules fire until the engine gives up",
                        severity="warning")

    # -- orderings ----------------------------------------------------------------

    def orderings(self, body: ast.TaskNet) -> None:
        """Report steps that would wait for each other for ever."""
        graph = _OrderGraph(body)
        cycle = graph.cycle()
        if cycle:
            first = cycle[0]
            names = " -> ".join(_name(node) for node in cycle + [first])
            self.report(f"these steps wait for each other for ever: {names} "
                        f"(each must end before the next starts, by sequence or (for ...))",
                        first.loc, "remove one of the orderings")
        for monitor, target in graph.monitors:
            if graph.reaches(monitor, target):
                self.report(f"step {monitor.label} must end before {target.label} starts, but "
                            f"(until-end {target.label}) keeps it running until {target.label} ends",
                            monitor.loc, f"run {monitor.label} beside {target.label}, e.g. in a parallel")


class _OrderGraph:
    """Leaves of a task net and the 'ends before … starts' edges between them."""

    def __init__(self, body: ast.TaskNet) -> None:
        self.edges: dict[int, list[object]] = {}
        self.nodes: list[object] = []
        self.monitors: list[tuple[ast.Step, ast.Step]] = []
        labels: dict[str, ast.Step] = {}
        for net in body.nets:
            self._structure(net)
        for node in self.nodes:
            if isinstance(node, ast.Step) and node.label:
                labels[node.label] = node
        for node in self.nodes:
            if isinstance(node, ast.Step):
                for label in node.before:
                    if label in labels:
                        self._edge(node, labels[label])
                if node.until_end in labels:
                    self.monitors.append((node, labels[node.until_end]))

    def _edge(self, a: object, b: object) -> None:
        self.edges.setdefault(id(a), []).append(b)

    def _structure(self, net: object) -> list[object]:
        if isinstance(net, ast.Sequence):
            groups = [self._structure(part) for part in net.parts]
            for before, after in zip(groups, groups[1:]):
                for a in before:
                    for b in after:
                        self._edge(a, b)
            return [leaf for group in groups for leaf in group]
        if isinstance(net, ast.Parallel):
            return [leaf for part in net.parts for leaf in self._structure(part)]
        self.nodes.append(net)
        return [net]

    def reaches(self, start: object, goal: object) -> bool:
        seen: set[int] = set()
        stack = list(self.edges.get(id(start), ()))
        while stack:
            node = stack.pop()
            if node is goal:
                return True
            if id(node) not in seen:
                seen.add(id(node))
                stack.extend(self.edges.get(id(node), ()))
        return False

    def cycle(self) -> list[object]:
        """Some cycle of edges, as the nodes along it, or [] (iterative: nets may be long)."""
        state: dict[int, int] = {}  # 1: on the current path, 2: done
        for root in self.nodes:
            if id(root) in state:
                continue
            path: list[object] = [root]
            branches = [iter(self.edges.get(id(root), ()))]
            state[id(root)] = 1
            while branches:
                nxt = next(branches[-1], None)
                if nxt is None:
                    state[id(path.pop())] = 2
                    branches.pop()
                elif state.get(id(nxt)) == 1:
                    return path[next(i for i, node in enumerate(path) if node is nxt):]
                elif id(nxt) not in state:
                    state[id(nxt)] = 1
                    path.append(nxt)
                    branches.append(iter(self.edges.get(id(nxt), ())))
        return []


def net_nodes(net: object) -> Iterator[object]:
    """The steps, waits, memory operations and plan requests of a task net, in the order written."""
    if isinstance(net, ast.TaskNet):
        for part in net.nets:
            yield from net_nodes(part)
    elif isinstance(net, (ast.Sequence, ast.Parallel)):
        for part in net.parts:
            yield from net_nodes(part)
    else:
        yield net


def _name(node: object) -> str:
    if isinstance(node, ast.Step):
        return node.label or _name(node.task)
    if isinstance(node, ast.PlanRequest):
        return term_to_str(Compound("plan", node.goals))
    if isinstance(node, Compound):
        return term_to_str(node)
    if isinstance(node, ast.WaitFor):
        return f"(wait-for {term_to_str(node.query)})"
    return type(node).__name__


def item_location(program, form_loc: SourceLocation, path: tuple[int, ...]) -> SourceLocation:
    """Where item ``path`` (indices, one per level) of the top-level form at ``form_loc`` starts.

    The AST keeps one location per form; a report about one fact inside
    it reads the file again (only then) to put the caret under the fact.
    Falls back to ``form_loc`` when the file's text is not known.
    """
    lines = getattr(program, "lines", {}).get(form_loc.file)
    if not lines:
        return form_loc
    try:
        forms = read_text("\n".join(lines), form_loc.file)
    except AtlasError:  # not readable on its own any more: keep the form's place
        return form_loc
    where = (form_loc.line, form_loc.column)
    node = next((datum for datum, loc in zip(forms, forms.locs) if loc == where), None)
    for index in path:
        if type(node) is not SList or index >= len(node.items):
            return form_loc
        where = node.locs[index]
        node = node.items[index]
    return SourceLocation(form_loc.file, where[0], where[1])


def _literal_type(term: Term) -> str | None:
    """The type of a literal argument (``number``, ``symbol``, ``string``, ``list``), or None for what
    is not checked: a variable, an expression, and ``nil`` (the empty list as well as a symbol)."""
    if isinstance(term, (int, float)) and not isinstance(term, bool):
        return "number"
    if isinstance(term, str):
        return None if term == "nil" else "symbol"
    if isinstance(term, Compound):
        return "list" if term.functor == "" else None
    return "string" if isinstance(term, String) else None


def _arities(arities: set[int]) -> str:
    numbers = " or ".join(str(n) for n in sorted(arities))
    return f"{numbers} argument{'' if arities == {1} else 's'}"


def _produced_by_program(program) -> set[str]:
    """Predicates the program itself asserts: initial memory, at-time, steps, rules, scripts."""
    found: set[str] = set()
    for form in program.forms:
        if isinstance(form, ast.InitialMemory):
            found.update(fact.functor for fact in form.facts)
        elif isinstance(form, ast.AtTime):
            found.update(op.fact.functor for op in form.actions if op.kind == "assert")
        elif isinstance(form, ast.RelationDef):
            found.add(form.name)
        elif isinstance(form, ast.MemoryRuleDef):
            found.update(fact.functor for kind, fact in form.rule.effects if kind == "assert")
        elif isinstance(form, ast.RapDef):
            for method in form.methods:
                nodes = method.body.actions if isinstance(method.body, ast.Primitive) else net_nodes(method.body)
                found.update(node.fact.functor for node in nodes
                             if isinstance(node, ast.MemoryOp) and node.kind == "assert")
    return found


def _unproducible(query: Term, produced: set[str]) -> set[str]:
    """The predicates that keep ``query`` from ever holding (empty if it can hold)."""
    if type(query) is not Compound:
        return set() if query != "nil" else {"nil"}
    functor = query.functor
    if functor == "and":
        return set().union(*(_unproducible(part, produced) for part in query.args)) if query.args else set()
    if functor == "or":
        parts = [_unproducible(part, produced) for part in query.args]
        return set().union(*parts) if parts and all(parts) else set()
    if functor in ("not", "=", "/=") or functor in COMPARISONS:
        return set()
    return set() if functor in produced else {functor}
