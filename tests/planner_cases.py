"""Small planning problems written as AP text, shared by the planner's tests,
and helpers to read them, to lay a plan out and to enumerate linearisations.

Each problem is a string; :func:`write_ap` puts it (with the operator files it
includes) into a folder such as pytest's ``tmp_path`` and :func:`load_problem`
reads it the way ``atlas plan`` does (``load`` then ``problem_from_program``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

from atlas_rap.lang import load
from atlas_rap.planner.ground import GroundAction, GroundTask, ground
from atlas_rap.planner.partial_order import PartialOrder, deorder
from atlas_rap.planner.problem import PlanningProblem, problem_from_program
from atlas_rap.planner.search import eliminate_redundant, greedy_best_first

REPO = Path(__file__).resolve().parent.parent
SPACE_STATION = REPO / "operators" / "space-station.ap"
"""The paper's grasp-bulky-object operator lives here."""

# ----------------------------------------------------------------------------- the bulky box

def bulky_box(agents: Sequence[str], lifts: dict[str, int], size: int = 40) -> str:
    """The paper's box of ``size`` on a shelf; the goal: hold it. ``agents`` are the
    controlled agents, ``lifts`` their max-lift. The astronaut is declared because
    the included file has an astronaut's operator."""
    facts = " ".join(f"(max-lift {a} {w})" for a, w in lifts.items())
    return f"""\
(include "{SPACE_STATION}")
(agents (controlled {' '.join(agents)}) (uncontrolled astronaut))
(initial {facts} (size box-1 {size}) (top box-1 clear) (on box-1 shelf-2))
(goals (holding planner box-1))
"""


# ----------------------------------------------------------------------------- the door a person may close

DOOR_OPERATORS = """\
;; A robot carries things and goes through doors; it can prop a door open
;; with a wedge. A person may close a door that is not propped.
(operator pick-up
  :purpose (holding ?r ?thing)
  :agent ?r
  :preconditions ((at ?r ?place) (at ?thing ?place) (portable ?thing))
  :effects ((holding ?r ?thing) (not (at ?thing ?place))))

(operator go-through
  :purpose (at ?r ?to)
  :agent ?r
  :preconditions ((at ?r ?from) (door ?d ?from ?to) (open ?d))
  :effects ((at ?r ?to) (not (at ?r ?from))))

(operator prop-door
  :purpose (propped ?d)
  :agent ?r
  :preconditions ((at ?r ?place) (door ?d ?place ?other) (open ?d) (wedge ?r))
  :effects ((propped ?d)))

(operator close-door
  :agent ?p
  :preconditions ((open ?d) (not (propped ?d)))
  :effects ((not (open ?d)))
  :uncontrolled t
  :probability 0.3)
"""


def door_problem(people: Sequence[str] = ("person",), wedge: bool = True,
                 things: Sequence[str] = ("parcel",), go_to_lab: bool = True) -> str:
    """The robot in the hall with ``things`` to pick up; the goal: hold them and (when
    ``go_to_lab``) be in the lab, through door d1. ``people`` are the uncontrolled
    agents (none: no ``uncontrolled`` group); ``wedge`` whether the robot can prop."""
    agents = "(controlled robot)" + (f" (uncontrolled {' '.join(people)})" if people else "")
    facts = ["(at robot hall)", "(door d1 hall lab)", "(door d1 lab hall)", "(open d1)"]
    facts += [f"(at {t} hall) (portable {t})" for t in things]
    if wedge:
        facts.append("(wedge robot)")
    goals = [f"(holding robot {t})" for t in things] + (["(at robot lab)"] if go_to_lab else [])
    return f"""\
(include "door-operators.ap")
(agents {agents})
(initial {' '.join(facts)})
(goals {' '.join(goals)})
"""


# ----------------------------------------------------------------------------- unsolvable, in AP

# The paper's bulky box and a camera inspection, on the shipped space-station operators.
STATION = f"""\
(include "{Path(__file__).resolve().parent.parent / 'operators' / 'space-station.ap'}")
(agents (controlled left-arm right-arm camera-1) (uncontrolled astronaut))
(initial (max-lift left-arm 25) (max-lift right-arm 25) (size box-1 40)
         (top box-1 clear) (on box-1 shelf-2) (camera camera-1))
(goals (holding planner box-1) (inspected camera-site))
"""


# Two operators whose plots name each other's purposes.
PLOT_CYCLE = """\
(operator fetch
  :purpose (have ?x)
  :agent ?r
  :plot (sequence (ready ?x))
  :effects ((have ?x)))
(operator prepare
  :purpose (ready ?x)
  :agent ?r
  :plot (sequence (have ?x))
  :effects ((ready ?x)))
(agents (controlled robot))
(initial (thing box))
(goals (have box))
"""


ONE_WAY_DOOR = """\
;; The robot may go from the lab to the hall, never back; it must visit the
;; hall and end in the lab. The delete relaxation says yes; the truth is no.
(operator go
  :purpose (at ?r ?to)
  :agent ?r
  :preconditions ((at ?r ?from) (one-way ?from ?to))
  :effects ((at ?r ?to) (visited ?to) (not (at ?r ?from))))
(agents (controlled robot))
(initial (at robot lab) (one-way lab hall))
(goals (visited hall) (at robot lab))
"""

# ----------------------------------------------------------------------------- a small delivery with parallel steps

DELIVERY = """\
;; Two robots each carry a parcel to a room: independent work, so the
;; partial order has two chains that may interleave.
(operator pick-up
  :purpose (holding ?r ?thing)
  :agent ?r
  :preconditions ((at ?r ?place) (at ?thing ?place) (hand-free ?r))
  :effects ((holding ?r ?thing) (not (at ?thing ?place)) (not (hand-free ?r))))
(operator move
  :purpose (at ?r ?to)
  :agent ?r
  :preconditions ((at ?r ?from) (corridor ?from ?to))
  :effects ((at ?r ?to) (not (at ?r ?from))))
(operator put-down
  :agent ?r
  :preconditions ((holding ?r ?thing) (at ?r ?place))
  :effects ((at ?thing ?place) (hand-free ?r) (not (holding ?r ?thing))))
(agents (controlled r1 r2))
(initial (at r1 dock) (at r2 dock) (hand-free r1) (hand-free r2)
         (at p1 dock) (at p2 dock)
         (corridor dock lab) (corridor lab dock) (corridor dock office) (corridor office dock))
(goals (at p1 lab) (at p2 office))
"""


# ----------------------------------------------------------------------------- negative preconditions

LOCKS = """\
;; Each robot unlocks the other's door, it goes in, the door is locked again:
;; entering needs (not (locked ?d)), so locking must wait for the entry.
(operator unlock
  :purpose (not (locked ?d))
  :agent ?r
  :preconditions ((locked ?d) (has-key ?r ?d))
  :effects ((not (locked ?d))))
(operator lock
  :purpose (locked ?d)
  :agent ?r
  :preconditions ((has-key ?r ?d))
  :effects ((locked ?d)))
(operator enter
  :purpose (inside ?r ?room)
  :agent ?r
  :preconditions ((door-of ?d ?room) (not (locked ?d)))
  :effects ((inside ?r ?room)))
(agents (controlled robot helper))
(initial (door-of d1 lab) (door-of d2 store) (locked d1) (locked d2) (has-key helper d1) (has-key robot d2))
(goals (inside robot lab) (inside helper store) (locked d1) (locked d2))
"""


# ----------------------------------------------------------------------------- helpers

def write_ap(folder: Path, text: str, name: str = "problem.ap") -> Path:
    """Write ``text`` as ``folder/name``, with ``door-operators.ap`` beside it; its path."""
    (folder / "door-operators.ap").write_text(DOOR_OPERATORS, encoding="utf-8")
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def load_problem(folder: Path, text: str, name: str = "problem.ap") -> PlanningProblem:
    """The planning problem of AP ``text``, read as ``atlas plan`` reads it."""
    return problem_from_program(load(write_ap(folder, text, name)), name=name)


def sequential_plan(task: GroundTask) -> list[GroundAction]:
    """Search and shorten, as solve() does before counterplanning."""
    found = greedy_best_first(task, timeout=10.0)
    assert found.status == "solved", found.status
    return eliminate_redundant(task, found.plan)


def partial_order_of(problem: PlanningProblem) -> tuple[GroundTask, PartialOrder]:
    """The grounded task and the deordered plan (without counterplanning)."""
    task = ground(problem)
    return task, deorder(task, sequential_plan(task))


def linearisations(n: int, orderings: Sequence[tuple[int, int]] | set[tuple[int, int]],
                   first: int = 0) -> Iterator[list[int]]:
    """Every sequence of the ids ``first .. first+n-1`` that keeps ``orderings``
    (pairs (before, after); pairs naming other ids, such as GOAL, are ignored)."""
    ids = list(range(first, first + n))
    preds: dict[int, set[int]] = {i: set() for i in ids}
    for a, b in orderings:
        if a in preds and b in preds:
            preds[b].add(a)
    placed: set[int] = set()
    sequence: list[int] = []

    def extend() -> Iterator[list[int]]:
        if len(sequence) == n:
            yield list(sequence)
            return
        for i in ids:
            if i not in placed and preds[i] <= placed:
                placed.add(i)
                sequence.append(i)
                yield from extend()
                sequence.pop()
                placed.discard(i)

    return extend()


def runs(task: GroundTask, actions: Sequence[GroundAction]) -> bool:
    """Whether ``actions`` apply one after another from the initial state and reach the goals."""
    state = task.init
    for action in actions:
        if not task.applicable(action, state):
            return False
        state = task.apply(action, state)
    return task.is_goal(state)


# The person may take the wrench and leave it in any room: one event, however
# many rooms (its groundings differ only in a variable of the effects).
TOOL_TAKEN = """\
(operator go :purpose (at ?r ?to) :agent ?r :preconditions ((at ?r ?from) (room ?to))
  :effects ((at ?r ?to) (not (at ?r ?from))))
(operator pick-up :purpose (holding ?r ?t) :agent ?r :preconditions ((at ?r ?room) (tool-in ?t ?room))
  :effects ((holding ?r ?t) (not (tool-in ?t ?room))))
(operator person-takes-tool :agent ?p :preconditions ((tool-in ?t ?room))
  :effects ((not (tool-in ?t ?room)) (tool-left-in ?t ?elsewhere)) :uncontrolled t :probability 0.2)
(agents (controlled robot) (uncontrolled person))
(initial (at robot hall) (room hall) (room workshop) (room office) (room store) (tool-in wrench workshop))
(goals (holding robot wrench))
"""
