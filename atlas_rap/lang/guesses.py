"""Hints for names that are not atlas's: misspellings, and what people used to other languages write.

:func:`hint_for` gives the hint of an unknown name in one place of a file
(``what``: a top-level form, a RAP clause, an operator part ...): first a
name a PDDL, Lisp or robot-language user is likely to write for something
atlas calls otherwise (``define-operator`` is ``operator``, PDDL's
``:precondition`` is ``:preconditions``, a script's ``(done ...)`` is
``(finish ...)``), with what the right form looks like; else the nearest
valid name (:func:`~atlas_rap.errors.did_you_mean`, for misspellings); else the valid names.
Difflib alone would answer ``define-relation`` to ``define-operator``: it
is closer in letters and wrong in meaning.
"""

from __future__ import annotations

from atlas_rap.errors import nearest, suggestion

_PDDL = ("this looks like PDDL: atlas plan --pddl DOMAIN.pddl PROBLEM.pddl reads PDDL files; "
         "an .ap file writes (operator NAME :preconditions (...) :effects (...)), (initial ...) and (goals ...)")
_LISP = ("atlas files hold RAP and AP forms, not Lisp code: (define-rap ...), (define-virtual-skill ...), "
         "(operator ...), (initial-memory ...), (post ...)")

# What a user coming from PDDL, Lisp or another robot language may write, by the place it stands in:
# the name atlas uses, or (with a leading '!') a hint of its own.
WRONG_GUESSES: dict[str, dict[str, str]] = {
    "top-level form": {
        **dict.fromkeys(("define-operator", "defoperator", "def-operator", "defop", "define-action", "action",
                         ":action", "define-op"), "operator"),
        **dict.fromkeys(("defrap", "def-rap", "define-task", "deftask", "def-task", "define-method",
                         "defmethod", "define-procedure", "procedure"), "define-rap"),
        **dict.fromkeys(("task", "rap"), "!a task is defined with (define-rap (NAME ?arg ...) ...) and put on the "
                                         "agenda with (post (NAME ARG ...))"),
        **dict.fromkeys(("defrule", "define-rule", "rule", "memory-rule", "defmemory-rule"), "define-memory-rule"),
        **dict.fromkeys(("defskill", "define-skill", "def-skill", "skill", "virtual-skill", "define-virtual"),
                        "define-virtual-skill"),
        **dict.fromkeys(("init", ":init", "initial-state", "initial-facts", "facts", "memory", "assert",
                         "initial-memories", "init-memory"), "initial-memory"),
        **dict.fromkeys(("goal", ":goal", "objective", "achieve"), "goals"),
        **dict.fromkeys(("require", "load", "import", "use", "requires", "include-file"), "include"),
        **dict.fromkeys(("run", "execute", "do", "start", "post-task", "achieve-task"), "post"),
        **dict.fromkeys(("defrelation", "relation", "define-predicate", "defpredicate", "derived", ":derived"),
                        "define-relation"),
        **dict.fromkeys(("agent", "robots", "actors"), "agents"),
        **dict.fromkeys(("at", "at-times", "after", "schedule", "event"), "at-time"),
        "define": "!" + _PDDL,
        "domain": "!" + _PDDL,
        "problem": "!" + _PDDL,
        ":objects": "!PDDL's objects need no declaration here: objects are the names the initial facts use",
        "objects": "!objects need no declaration here: they are the names the facts use",
        ":predicates": "!predicates need no declaration here: a fact's name is its predicate",
        **dict.fromkeys(("defun", "defmacro", "defvar", "defparameter", "setq", "setf", "let", "lambda", "progn"),
                        "!" + _LISP),
    },
    "clause": {  # of define-rap
        **dict.fromkeys(("success", "succeeds", "succeeded", "done", "postcondition", "postconditions", "goal",
                         "achieves", "satisfied"), "succeed"),
        **dict.fromkeys(("precondition", "preconditions", "pre", "requires", "valid", "validity", "guard",
                         "condition", "when"),
                        "!a RAP's validity test is (constraints QUERY); each method has its own (context QUERY)"),
        **dict.fromkeys(("context", "task-net", "primitive"),
                        "!this goes inside a method: (method (context ...) (task-net ...))"),
        **dict.fromkeys(("retry", "attempts", "tries", "max-retries"), "retries"),
        **dict.fromkeys(("backoff", "back-off", "retry-delay", "retry-after", "retry-wait"), "retry-backoff"),
        **dict.fromkeys(("on-preempt", "preempt", "on-preemption"),
                        "!on-preempt belongs to a method: (method (on-preempt fail) (task-net ...))"),
        **dict.fromkeys(("time-out", "deadline", "time-limit", "timelimit"), "timeout"),
        **dict.fromkeys(("while", "repeat", "loop"), "repeat-while"),
        "until": "repeat-until",
        "prio": "priority",
        **dict.fromkeys(("methods", "way", "alternative"), "method"),
    },
    "method part": {
        **dict.fromkeys(("precondition", "preconditions", "pre", "when", "if", "condition", "applicable",
                         "guard"), "context"),
        **dict.fromkeys(("body", "steps", "network", "net", "subtasks", "tasks", "sequence", "parallel", "plot",
                         "do"), "!a method's body is (task-net STEP ...) or (primitive ...); "
                                "wrap sequences in it: (task-net (sequence ...))"),
        **dict.fromkeys(("action", "actions", "skills", "enable"), "primitive"),
        "succeed": "!succeed is a clause of the RAP, not of a method: write it beside the methods",
        **dict.fromkeys(("preempt", "on-preemption", "preemption", "on-halt", "when-preempted"), "on-preempt"),
    },
    "primitive action": {
        **dict.fromkeys(("start", "activate", "run", "turn-on", "on"), "enable"),
        **dict.fromkeys(("stop", "deactivate", "turn-off", "off", "halt"), "disable"),
        **dict.fromkeys(("wait", "wait-until", "await", "until"), "wait-for"),
    },
    "script line": {
        **dict.fromkeys(("finish", "done", "assert", "retract"),
                        "!a script's actions go inside (after SECONDS ...), e.g. (after 1.0 (finish :succeed))"),
        **dict.fromkeys(("wait", "delay", "at", "sleep", "in"), "after"),
        **dict.fromkeys(("if", "unless", "cond", "if-memory"), "when"),
    },
    "script action": {
        **dict.fromkeys(("done", "succeed", "success", "fail", "return", "outcome", "end", "complete"),
                        "!the action that ends a virtual skill is (finish :succeed) or (finish :fail): "
                        "it asserts (done (SKILL ARG ...) OUTCOME) for you"),
        **dict.fromkeys(("add", "add-fact", "post-fact", "tell", "insert"), "assert"),
        **dict.fromkeys(("delete", "del", "remove", "retract-fact", "forget"), "retract"),
    },
    "memory action": {
        **dict.fromkeys(("add", "add-fact", "tell", "insert"), "assert"),
        **dict.fromkeys(("delete", "del", "remove", "forget"), "retract"),
    },
    "rule clause": {
        **dict.fromkeys(("trigger", "on-assert", "when-asserted", "event", "if-asserted"), "on"),
        **dict.fromkeys(("if", "condition", "test", "guard", "unless"), "when"),
        **dict.fromkeys(("add", "then", "do", "tell"), "assert"),
        **dict.fromkeys(("delete", "remove", "del"), "retract"),
    },
    "operator part": {
        **dict.fromkeys(("precondition", "pre", "requires", "needs", "conditions"), "preconditions"),
        **dict.fromkeys(("effect", "post", "postconditions", "adds", "add", "results"), "effects"),
        "parameters": "!an operator has no parameter list: its variables take values where they are used "
                      "(:purpose, :preconditions ...); derived values are :arguments ((?v EXPR) ...)",
        "vars": "!an operator has no variable list: its variables take values where they are used",
        **dict.fromkeys(("goal", "achieves", "for", "purposes"), "purpose"),
        **dict.fromkeys(("steps", "subtasks", "method", "body", "expansion", "plan"), "plot"),
        **dict.fromkeys(("cost", "time", "length"), "duration"),
        **dict.fromkeys(("prob", "chance", "likelihood"), "probability"),
        **dict.fromkeys(("agents", "actor", "who"), "agent"),
        **dict.fromkeys(("args", "derived", "bindings"), "arguments"),
    },
    "agent group": {
        **dict.fromkeys(("ours", "own", "robots", "controllable"), "controlled"),
        **dict.fromkeys(("others", "nature", "people", "external", "environment"), "uncontrolled"),
    },
}


QUERY_OPERATORS = {"!=": "/=", "<>": "/=", "=/=": "/=", "~=": "/=", "not=": "/=", "neq": "/=", "==": "=",
                   "&&": "and", "||": "or", "!": "not", "&": "and", "|": "or"}
"""Other languages' comparisons and connectives, at the head of a query, and atlas's for them: as a fact
pattern, ``(!= ?a ?b)`` would quietly never match."""

# A task-net step named like another language's control form (a step that is neither RAP nor skill).
NET_GUESSES = {
    **dict.fromkeys(("seq", "progn", "serial", "in-order", "in-sequence", "do", "begin", "steps"), "sequence"),
    **dict.fromkeys(("par", "concurrent", "in-parallel", "together", "all", "fork"), "parallel"),
    **dict.fromkeys(("wait", "wait-until", "await", "until", "waitfor"), "wait-for"),
    **dict.fromkeys(("if", "cond", "when", "unless", "case", "choose"),
                    "!a task net has no conditionals: write a method for each case, each with its (context QUERY)"),
    **dict.fromkeys(("add", "tell", "insert"), "assert"),
    **dict.fromkeys(("delete", "remove", "del", "forget"), "retract"),
}


def net_hint(word: str) -> str | None:
    """The hint for a task-net step named like another language's control form, or None."""
    known = NET_GUESSES.get(word)
    if known is None:
        return None
    return known[1:] if known.startswith("!") else suggestion(f"({known} ...)", quote="") + \
        " a task net's forms are sequence, parallel, wait-for, assert, retract and plan"


def hint_for(what: str, word: str, choices: tuple[str, ...] | list[str]) -> str:
    """The hint for ``word``, unknown as a ``what`` (see the module docstring); ``choices`` are the valid names."""
    known = WRONG_GUESSES.get(what, {}).get(word.lower())
    if known is not None and known.startswith("!"):
        return known[1:]
    guess = nearest(word, choices)
    if known is not None and known in choices and known != guess:  # not a misspelling: show the form
        example = EXAMPLES.get(known)
        return suggestion(known) + (f" e.g. {example}" if example else "")
    return suggestion(guess) if guess else "expected one of: " + ", ".join(choices)


EXAMPLES = {
    "operator": "(operator NAME :purpose (GOAL) :preconditions ((FACT) ...) :effects ((FACT) (not (FACT))))",
    "define-rap": "(define-rap (NAME ?arg ...) (succeed QUERY) (method (context QUERY) (task-net STEP ...)))",
    "define-memory-rule": "(define-memory-rule NAME (on FACT) (when QUERY) (assert FACT))",
    "define-virtual-skill": "(define-virtual-skill (NAME ?arg ...) (after SECONDS (finish :succeed)))",
    "initial-memory": "(initial-memory FACT ...) in a mission, (initial FACT ...) in an .ap file",
    "goals": "(goals GOAL ...) in an .ap file, (plan GOAL ...) in a mission",
    "include": '(include "navigation.rap")',
    "post": "(post (TASK ARG ...))",
    "define-relation": "(define-relation (NAME ?arg ...) QUERY)",
    "agents": "(agents (controlled NAME ...) (uncontrolled NAME ...))",
    "at-time": "(at-time SECONDS (assert FACT))",
    "preconditions": ":preconditions ((FACT) ...)",
    "effects": ":effects ((FACT) (not (FACT)) ...)",
    "context": "(method (context QUERY) (task-net ...))",
    "finish": "(after 1.0 (finish :succeed))",
    "after": "(after SECONDS ACTION ...)",
    "when": "(when QUERY (after SECONDS ACTION ...))",
}
"""What the right form looks like, shown after a known wrong guess."""
