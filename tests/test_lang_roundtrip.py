"""Printing an AST and reading it back gives the same AST (docs/language/).

Hypothesis builds random, *valid* AST nodes of every top-level form; each is
printed with ``format_node`` (or a whole file with ``format_file``), read back
with ``parse_text``, and must compare equal (``loc`` takes no part in
equality). A third property checks the reader alone: ``term_to_str`` of a
random term, read by ``read_text`` and converted by ``to_term``, is the term.

The strategies only build what the language can express. What they leave out,
and why (each is a property of the surface syntax, not of the printer):

- upper-case symbols and variable names: the reader folds them to lower case;
- the anonymous variable ``?``: each one reads as a new variable numbered by
  its place in the file, so a random one does not compare equal after a round
  trip (printing one is checked by an example test below);
- ``Compound('', ())``: it prints as ``()``, which reads as the symbol ``nil``;
- ``Compound('', (SYMBOL, ...))``: a list whose first item is a symbol reads as
  a compound with that symbol as functor;
- names (functors of facts and tasks, labels, RAP/rule/operator/method names)
  that are ``t``, ``nil``, keywords or words with a meaning where they stand
  (``sequence``, ``wait-for``, ``for``, ``and``, ``not``, ``index``, ...): see
  ``RESERVED``;
- an unlabelled step ``(TASK (X ...) ANNOTATION ...)``: it reads as the step
  labelled ``TASK``; an unlabelled step with a ``(for ...)`` or
  ``(until-end ...)`` argument is an error (validator.py documents both);
- an unlabelled ``Step`` whose task is a plan request: ``(plan ...)`` in a net
  reads as the bare PlanRequest net node (which the strategies build too);
  ``plan`` is in ``RESERVED``: a net item headed ``plan`` is a plan request,
  never a task or a label;
- the ``wait-for`` outcome ``:timeout``: it reads as the ``:timeout`` option;
- a positive effect whose fact is ``(not ...)``: it reads as a negative effect;
- NaN and infinities: they print as symbols;
- variables where nothing can give them a value (a posted task, the goals of
  ``goals`` and of a top-level ``plan``, ``at-time`` facts, a script's facts
  beyond its skill's head, a memory rule's effects beyond its ``on`` and
  ``when``): each is an error with a caret, so those are built ground.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from atlas_rap.lang import ast, format_file, format_node, parse_text, read_text, to_term
from atlas_rap.logic import Compound, MemoryRule, String, Term, Var, term_to_str

SETTINGS = settings(max_examples=100, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])

# ----------------------------------------------------------------- atoms

LETTERS = "abcdefghijklmnopqrstuvwxyz"
TAIL = LETTERS + "0123456789-" + "-_*/!<>=."  # hyphens are common; a few others for variety

RESERVED = frozenset({
    "t", "nil", "and", "or", "not", "sequence", "parallel", "simultaneous", "wait-for", "assert",
    "retract", "for", "until-end", "index", "enable", "disable", "finish", "after", "when", "on",
    "method", "context", "task-net", "primitive", "plan",
})
OPERATOR_SYMBOLS = ("+", "-", "*", "/", "<", "<=", ">", ">=", "=", "/=")


def _word(first: str, rest: str) -> str:
    return first + rest


words = st.builds(_word, st.sampled_from(LETTERS), st.text(TAIL, max_size=7))
# A name: what may stand where the language wants the name of something.
names = words.filter(lambda w: w not in RESERVED)
# Any symbol that may stand as an argument: reserved words mean nothing there.
symbols = st.one_of(words, st.sampled_from(sorted(RESERVED)), st.sampled_from(OPERATOR_SYMBOLS))
keywords = words.map(lambda w: ":" + w)
ints = st.integers(min_value=-10**15, max_value=10**15)
floats = st.floats(allow_nan=False, allow_infinity=False)
numbers = st.one_of(ints, floats)
non_negative = st.one_of(st.integers(0, 10**6), st.floats(min_value=0, max_value=1e9, allow_nan=False))
string_chars = st.one_of(st.sampled_from('"\\\n\t ;()#|?:é漢🤖'), st.characters(exclude_categories=("Cs",)))  # a file is UTF-8: no lone surrogates
strings = st.builds(String, st.text(string_chars, max_size=12))
variables = st.builds(Var, words)  # names start with a letter; never anonymous

ground_atoms = st.one_of(symbols, keywords, ints, floats, strings)
atoms = st.one_of(ground_atoms, variables)


def _compounds(children: st.SearchStrategy) -> st.SearchStrategy:
    functors = st.one_of(symbols, keywords)
    args = st.lists(children, max_size=4).map(tuple)
    named = st.builds(Compound, functors, args)
    # Functor '' is a plain list: its first item must not be a symbol (see above).
    plain = st.builds(lambda first, rest: Compound("", (first, *rest)),
                      children.filter(lambda t: type(t) is not str), st.lists(children, max_size=3))
    return st.one_of(named, named, plain)


def _terms(base: st.SearchStrategy) -> st.SearchStrategy:
    return st.recursive(base, _compounds, max_leaves=8)


terms = _terms(atoms)
ground_terms = _terms(ground_atoms)


def facts(args: st.SearchStrategy = terms, functors: st.SearchStrategy = names) -> st.SearchStrategy:
    """``(name arg ...)``: a fact, a fact pattern, a task call or a skill call."""
    return st.builds(Compound, functors, st.lists(args, max_size=4).map(tuple))


ground_facts = facts(ground_terms)
positive = st.one_of(st.integers(1, 10**6), st.floats(min_value=1e-6, max_value=1e9, allow_nan=False))


def _query_forms(children: st.SearchStrategy) -> st.SearchStrategy:
    return st.one_of(
        st.builds(Compound, st.sampled_from(["and", "or"]), st.lists(children, max_size=3).map(tuple)),
        st.builds(lambda q: Compound("not", (q,)), children),
    )


def _queries(args: st.SearchStrategy) -> st.SearchStrategy:
    comparisons = st.builds(lambda op, a, b: Compound(op, (a, b)),
                            st.sampled_from(["<", "<=", ">", ">=", "=", "/="]), args, args)
    # A query as a whole may be t or nil; inside and/or/not too.
    return st.recursive(st.one_of(facts(args), facts(args), comparisons, st.sampled_from(["t", "nil"])),
                        _query_forms, max_leaves=6)


queries = _queries(terms)
ground_queries = _queries(ground_terms)  # goals: nothing could give their variables values

outcomes = st.one_of(st.just(":succeed"), st.just(":fail"), keywords.filter(lambda k: k != ":timeout"))


def _plan_requests(goals: st.SearchStrategy) -> st.SearchStrategy:
    return st.builds(ast.PlanRequest, st.lists(goals, min_size=1, max_size=3).map(tuple),
                     st.none() | positive, st.none() | st.integers(1, 1000))


plan_requests = _plan_requests(queries)  # in a task net, where the RAP's variables have values
top_plan_requests = _plan_requests(ground_queries)

# ----------------------------------------------------------------- task nets and primitives

wait_fors = st.builds(ast.WaitFor, queries, outcomes, st.none() | non_negative)
memory_ops = st.builds(ast.MemoryOp, st.sampled_from(["assert", "retract"]), facts())
ground_memory_ops = st.builds(ast.MemoryOp, st.sampled_from(["assert", "retract"]), ground_facts)
ANNOTATIONS = ("for", "until-end", "wait-for")


def _bare_step_is_expressible(task: Compound) -> bool:
    args = task.args
    if args and type(args[0]) is Compound and all(
            type(a) is Compound and a.functor in ANNOTATIONS for a in args[1:]):
        return False  # would read as the step labelled task.functor
    return not any(type(a) is Compound and a.functor in ("for", "until-end") for a in args)


bare_tasks = facts().filter(_bare_step_is_expressible)


@st.composite
def task_nets(draw) -> ast.TaskNet:
    """A task net whose step labels are unique and whose annotations name its steps."""
    labelled: list[dict] = []  # specs of labelled steps, filled in once all labels are known

    def net(depth: int):
        leaves = ["step", "labelled", "labelled", "labelled", "wait", "memory", "plan"]
        kind = draw(st.sampled_from(leaves + ["sequence", "sequence", "parallel"] if depth < 3 else leaves))
        if kind == "step":
            return ast.Step(task=draw(bare_tasks))
        if kind == "labelled":
            spec = {"task": draw(st.one_of(facts(), facts(), facts(), plan_requests))}
            labelled.append(spec)
            return spec
        if kind == "plan":
            return draw(plan_requests)
        if kind == "wait":
            return draw(wait_fors)
        if kind == "memory":
            return draw(memory_ops)
        parts = [net(depth + 1) for _ in range(draw(st.integers(0, 3)))]
        return (kind, parts)

    skeleton = [net(0) for _ in range(draw(st.integers(1, 3)))]
    labels = draw(st.lists(names, min_size=len(labelled), max_size=len(labelled), unique=True))
    for spec, label in zip(labelled, labels):
        others = [x for x in labels if x != label]
        refs = st.sampled_from(others) if others else st.nothing()
        spec["step"] = ast.Step(
            task=spec["task"], label=label,
            before=tuple(draw(st.lists(refs, max_size=2, unique=True))) if others else (),
            until_end=draw(st.none() | refs) if others else None,
            waits=tuple(draw(st.lists(wait_fors, max_size=3))))

    def build(node):
        if type(node) is dict:
            return node["step"]
        if type(node) is tuple:
            kind, parts = node
            cls = ast.Sequence if kind == "sequence" else ast.Parallel
            return cls(parts=tuple(build(p) for p in parts))
        return node

    return ast.TaskNet(nets=tuple(build(n) for n in skeleton))


skill_calls = st.lists(facts(), min_size=1, max_size=3).map(tuple)
primitive_actions = st.one_of(
    st.builds(ast.Enable, skill_calls),
    st.just(ast.Disable(above=True)),
    st.builds(ast.Disable, skill_calls),
    wait_fors,
    memory_ops,
)
primitives = st.builds(ast.Primitive, st.lists(primitive_actions, min_size=1, max_size=5).map(tuple))
methods = st.builds(ast.Method, st.one_of(task_nets(), primitives), st.none() | names, st.none() | queries,
                    st.sampled_from(["resume", "fail"]))

rap_defs = st.builds(
    ast.RapDef,
    head=facts(),
    methods=st.lists(methods, max_size=3).map(tuple),
    succeed=st.none() | queries,
    constraints=st.none() | queries,
    repeat_while=st.none() | queries,
    repeat_until=st.none() | queries,
    timeout=st.none() | non_negative,
    priority=st.none() | numbers,
    retries=st.none() | st.integers(1, 100),
    retry_backoff=st.none() | non_negative,
)

# ----------------------------------------------------------------- memory, skills, events

memory_rule_defs = st.builds(
    lambda name, trigger, condition, effects: ast.MemoryRuleDef(MemoryRule(name, trigger, condition, effects)),
    names, facts(), st.none() | queries,
    st.lists(st.tuples(st.sampled_from(["assert", "retract"]), ground_facts), max_size=3).map(tuple))
finishes = st.builds(ast.Finish, keywords)
afters = st.builds(ast.After, non_negative, st.lists(st.one_of(ground_memory_ops, finishes), max_size=3).map(tuple))
whens = st.builds(ast.When, queries, st.lists(afters, min_size=1, max_size=3).map(tuple))
virtual_skill_defs = st.builds(ast.VirtualSkillDef, facts(),
                               st.lists(st.one_of(afters, whens), max_size=4).map(tuple))
at_times = st.builds(ast.AtTime, non_negative, st.lists(ground_memory_ops, min_size=1, max_size=3).map(tuple))

# ----------------------------------------------------------------- mission forms

paths = st.text(string_chars, max_size=20)
includes = st.builds(ast.Include, paths)
world_decls = st.builds(ast.WorldDecl, st.one_of(st.just("none"), paths))
initial_memories = st.builds(ast.InitialMemory, st.lists(ground_facts, max_size=4).map(tuple))
posts = st.builds(ast.Post, ground_facts, st.none() | numbers, st.none() | non_negative)
deadlines = st.builds(ast.Deadline, queries, positive)

# ----------------------------------------------------------------- AP forms

plot_steps = st.builds(ast.PlotStep, facts())
plots = st.recursive(plot_steps, lambda children: st.builds(
    ast.PlotGroup, st.sampled_from(["sequence", "parallel", "simultaneous"]),
    st.lists(children, max_size=3).map(tuple)), max_leaves=6)
effects = st.builds(ast.Effect, facts(), st.booleans())
arguments = st.builds(ast.Argument, variables, terms)


@st.composite
def operators(draw) -> ast.Operator:
    uncontrolled = draw(st.booleans())
    probability = draw(st.none() | st.floats(0, 1)) if uncontrolled else None
    return ast.Operator(
        name=draw(names),
        purpose=draw(st.none() | queries),
        agent=draw(st.none() | variables),
        arguments=tuple(draw(st.lists(arguments, max_size=3))),
        preconditions=tuple(draw(st.lists(queries, max_size=4))),
        constraints=tuple(draw(st.lists(queries, max_size=3))),
        plot=draw(st.none() | plots),
        effects=tuple(draw(st.lists(effects, max_size=4))),
        duration=draw(st.one_of(st.just(1), non_negative)),
        uncontrolled=uncontrolled,
        probability=probability,
    )


agents = st.builds(ast.Agents, st.lists(names, max_size=4).map(tuple), st.lists(names, max_size=3).map(tuple))
relation_defs = st.builds(ast.RelationDef, facts(), queries)
initials = st.builds(ast.Initial, st.lists(ground_facts, max_size=4).map(tuple))
goals = st.builds(ast.Goals, st.lists(ground_queries, min_size=1, max_size=3).map(tuple))

top_level_forms = st.one_of(
    rap_defs, memory_rule_defs, virtual_skill_defs, at_times, includes, world_decls, initial_memories,
    posts, top_plan_requests, operators(), agents, relation_defs, initials, goals, deadlines,
)

# ----------------------------------------------------------------- the properties


def read_back(node: ast.TopLevel) -> ast.TopLevel:
    text = format_node(node)
    note(text)
    return reread(text)


def reread(text: str) -> ast.TopLevel:
    (form,) = parse_text(text, "printed.rap").forms
    return form


@SETTINGS
@given(rap_defs)
def test_a_printed_rap_reads_back_as_the_same_rap(rap):
    assert read_back(rap) == rap


@SETTINGS
@given(st.one_of(memory_rule_defs, virtual_skill_defs, at_times))
def test_printed_memory_rules_virtual_skills_and_timed_events_read_back_the_same(form):
    assert read_back(form) == form


@SETTINGS
@given(st.one_of(includes, world_decls, initial_memories, posts, top_plan_requests))
def test_printed_mission_forms_read_back_the_same(form):
    assert read_back(form) == form


@SETTINGS
@given(operators())
def test_a_printed_operator_reads_back_as_the_same_operator(operator):
    assert read_back(operator) == operator


@SETTINGS
@given(st.one_of(agents, relation_defs, initials, goals, deadlines))
def test_printed_agents_relations_initial_states_goals_and_deadlines_read_back_the_same(form):
    assert read_back(form) == form


@settings(SETTINGS, max_examples=40)
@given(st.lists(top_level_forms, min_size=1, max_size=6))
def test_a_printed_file_reads_back_as_the_same_file(forms):
    source = ast.SourceFile("mission.rap", tuple(forms))
    text = format_file(source)
    note(text)
    assert parse_text(text, "mission.rap") == source


@settings(SETTINGS, max_examples=250)
@given(terms)
def test_a_printed_term_reads_back_as_the_same_term(term: Term):
    text = term_to_str(term)
    note(text)
    (datum,) = read_text(text)
    assert to_term(datum) == term


# ----------------------------------------------------------------- what the strategies leave out, pinned


def test_a_form_with_an_anonymous_variable_prints_as_text_that_reads_back():
    # The reader makes each '?' a Var('_N'); printing must give '?' again, not '?_1'
    # (which is not a valid variable name), so that `atlas check --format` output reads.
    (rap,) = parse_text("(define-rap (go) (succeed (at robot ?)))").forms
    text = format_node(rap)
    assert text == "(define-rap (go) (succeed (at robot ?)))"
    (again,) = parse_text(text).forms
    assert again.succeed.functor == "at" and type(again.succeed.args[1]) is Var


def test_an_operator_whose_first_precondition_is_t_reads_back_the_same():
    # (preconditions t (ready)) is valid clause-style input; the keyword-style print
    # ':preconditions (t (ready))' reads back as the single precondition (t (ready)).
    (operator,) = parse_text("(operator wait-a-bit (preconditions t (ready)) (effects (rested)))").forms
    assert operator.preconditions == ("t", Compound.of("ready"))
    assert reread(format_node(operator)) == operator


def test_an_empty_sequence_in_a_task_net_reads_and_prints_back():
    # (sequence NET ...) of no parts; the validator builds
    # Sequence(parts=()) and must not crash checking the labels.
    (rap,) = parse_text("(define-rap (idle) (method (task-net (sequence) (parallel))))").forms
    assert rap.methods[0].body.nets == (ast.Sequence(parts=()), ast.Parallel(parts=()))
    assert reread(format_node(rap)) == rap


def test_plan_requests_in_a_task_net_bare_and_labelled_print_and_read_back():
    text = ("(define-rap (fetch ?x)\n  (method (task-net\n"
            "    (sequence (t1 (go ?x)) (plan (at robot ?x) :deadline 30 :max-failures 2))\n"
            "    (parallel (plan (a)) (t3 (b)))\n"
            "    (p1 (plan (c) :deadline 5.5) (for t2) (wait-for (d) :fail))\n"
            "    (t2 (e)))))")
    (rap,) = parse_text(text).forms
    nets = rap.methods[0].body.nets
    assert nets[0].parts[1] == ast.PlanRequest((Compound("at", ("robot", Var("x"))),), 30, 2)
    assert nets[2].task == ast.PlanRequest((Compound("c", ()),), deadline=5.5)
    assert reread(format_node(rap)) == rap
