"""Small PDDL problems for the planner's tests: domains as strings, problem generators.

Each generator writes ``domain.pddl`` and a problem file into a folder
(pytest's ``tmp_path``) and returns their paths, so tests read them
exactly as they would read a benchmark.
"""

from __future__ import annotations

import random
from pathlib import Path

SHARED_PDDL = Path(__file__).resolve().parents[2] / "shared" / "data" / "pddl"
"""The public benchmarks (``/work/shared/data/pddl``); tests skip when absent."""

# Gripper with types (the IPC-1998 domain, its unary room/ball/gripper
# predicates written as types).
GRIPPER_DOMAIN = """\
(define (domain gripper-typed)
  (:requirements :strips :typing)
  (:types room ball gripper)
  (:predicates (at-robby ?r - room)
               (at ?b - ball ?r - room)
               (free ?g - gripper)
               (carry ?o - ball ?g - gripper))
  (:action move
    :parameters (?from ?to - room)
    :precondition (at-robby ?from)
    :effect (and (at-robby ?to) (not (at-robby ?from))))
  (:action pick
    :parameters (?obj - ball ?room - room ?gripper - gripper)
    :precondition (and (at ?obj ?room) (at-robby ?room) (free ?gripper))
    :effect (and (carry ?obj ?gripper) (not (at ?obj ?room)) (not (free ?gripper))))
  (:action drop
    :parameters (?obj - ball ?room - room ?gripper - gripper)
    :precondition (and (carry ?obj ?gripper) (at-robby ?room))
    :effect (and (at ?obj ?room) (free ?gripper) (not (carry ?obj ?gripper)))))
"""

# The 4-operator blocks world (IPC-2000), untyped.
BLOCKS_DOMAIN = """\
(define (domain blocks)
  (:requirements :strips)
  (:predicates (on ?x ?y) (ontable ?x) (clear ?x) (handempty) (holding ?x))
  (:action pick-up
    :parameters (?x)
    :precondition (and (clear ?x) (ontable ?x) (handempty))
    :effect (and (not (ontable ?x)) (not (clear ?x)) (not (handempty)) (holding ?x)))
  (:action put-down
    :parameters (?x)
    :precondition (holding ?x)
    :effect (and (not (holding ?x)) (clear ?x) (handempty) (ontable ?x)))
  (:action stack
    :parameters (?x ?y)
    :precondition (and (holding ?x) (clear ?y))
    :effect (and (not (holding ?x)) (not (clear ?y)) (clear ?x) (handempty) (on ?x ?y)))
  (:action unstack
    :parameters (?x ?y)
    :precondition (and (on ?x ?y) (clear ?x) (handempty))
    :effect (and (holding ?x) (clear ?y) (not (clear ?x)) (not (handempty)) (not (on ?x ?y)))))
"""

# Triangle tireworld (FOND): every move may flatten the tire.
TIREWORLD_DOMAIN = """\
(define (domain tireworld)
  (:requirements :typing :strips :non-deterministic)
  (:types location)
  (:predicates (vehicle-at ?loc - location) (spare-in ?loc - location)
               (road ?from - location ?to - location) (not-flattire))
  (:action move-car
    :parameters (?from - location ?to - location)
    :precondition (and (vehicle-at ?from) (road ?from ?to) (not-flattire))
    :effect (and (vehicle-at ?to) (not (vehicle-at ?from))
                 (oneof (and) (not (not-flattire)))))
  (:action changetire
    :parameters (?loc - location)
    :precondition (and (spare-in ?loc) (vehicle-at ?loc))
    :effect (and (not (spare-in ?loc)) (not-flattire))))
"""


def write_problem(folder: Path, domain: str, problem: str, name: str = "problem.pddl") -> tuple[Path, Path]:
    """Write ``domain.pddl`` and the problem file into ``folder``; their paths."""
    domain_path = folder / "domain.pddl"
    problem_path = folder / name
    domain_path.write_text(domain, encoding="utf-8")
    problem_path.write_text(problem, encoding="utf-8")
    return domain_path, problem_path


def gripper_problem(folder: Path, balls: int, rooms: int = 2) -> tuple[Path, Path]:
    """All balls and the robot in the first room; the goal: every ball in the last room."""
    room_names = [f"room{i}" for i in range(1, rooms + 1)]
    ball_names = [f"ball{i}" for i in range(1, balls + 1)]
    init = [f"(at-robby {room_names[0]})", "(free left)", "(free right)"]
    init += [f"(at {b} {room_names[0]})" for b in ball_names]
    goal = " ".join(f"(at {b} {room_names[-1]})" for b in ball_names)
    problem = f"""\
(define (problem gripper-{balls}-{rooms})
  (:domain gripper-typed)
  (:objects {' '.join(room_names)} - room {' '.join(ball_names)} - ball left right - gripper)
  (:init {' '.join(init)})
  (:goal (and {goal})))
"""
    return write_problem(folder, GRIPPER_DOMAIN, problem, f"gripper-{balls}-{rooms}.pddl")


def random_towers(blocks: list[str], rng: random.Random) -> list[list[str]]:
    """The blocks shuffled into a random number of towers, each listed bottom up."""
    order = blocks[:]
    rng.shuffle(order)
    towers: list[list[str]] = []
    for block in order:
        if towers and rng.random() < 0.6:
            rng.choice(towers).append(block)
        else:
            towers.append([block])
    return towers


def tower_facts(towers: list[list[str]]) -> list[str]:
    """``ontable``, ``on`` and ``clear`` facts of towers listed bottom up."""
    facts = []
    for tower in towers:
        facts.append(f"(ontable {tower[0]})")
        facts += [f"(on {upper} {lower})" for lower, upper in zip(tower, tower[1:])]
        facts.append(f"(clear {tower[-1]})")
    return facts


def blocks_problem(folder: Path, n: int, seed: int) -> tuple[Path, Path]:
    """``n`` blocks in random towers; the goal: the ``on`` facts of other random towers."""
    rng = random.Random(seed)
    blocks = [f"b{i}" for i in range(1, n + 1)]
    init = tower_facts(random_towers(blocks, rng)) + ["(handempty)"]
    goal = [f for f in tower_facts(random_towers(blocks, rng)) if f.startswith("(on ")]
    problem = f"""\
(define (problem blocks-{n}-{seed})
  (:domain blocks)
  (:objects {' '.join(blocks)})
  (:init {' '.join(init)})
  (:goal (and {' '.join(goal)})))
"""
    return write_problem(folder, BLOCKS_DOMAIN, problem, f"blocks-{n}-{seed}.pddl")


def tireworld_problem(folder: Path) -> tuple[Path, Path]:
    """From ``a`` to ``c``: directly via ``d`` (no spare there) or via ``b`` (a spare)."""
    problem = """\
(define (problem tire-small)
  (:domain tireworld)
  (:objects a b c d - location)
  (:init (vehicle-at a) (not-flattire) (spare-in b)
         (road a d) (road d c) (road a b) (road b c))
  (:goal (vehicle-at c)))
"""
    return write_problem(folder, TIREWORLD_DOMAIN, problem, "tire-small.pddl")


TRIANGLE_TIRE_DOMAIN = """\
(define (domain triangle-tire)
  (:requirements :typing :strips :non-deterministic)
  (:types location)
  (:predicates (vehicle-at ?loc - location) (spare-in ?loc - location)
               (road ?from - location ?to - location) (not-flattire))
  (:action move-car
    :parameters (?from - location ?to - location)
    :precondition (and (vehicle-at ?from) (road ?from ?to) (not-flattire))
    :effect (and (vehicle-at ?to) (not (vehicle-at ?from)) (oneof (and) (not (not-flattire)))))
  (:action changetire
    :parameters (?loc - location)
    :precondition (and (spare-in ?loc) (vehicle-at ?loc))
    :effect (and (not (spare-in ?loc)) (not-flattire))))
"""


def triangle_tireworld_problem(folder: Path, n: int) -> tuple[Path, Path]:
    """FOND triangle-tireworld problem ``n`` (Little and Thiebaux's family, as the IPC ships
    p1-p10 in ../shared/data, fact for fact): a triangle of 2n+1 rows; a flat tyre may happen
    on any move, and spares lie on the even rows and at the ends of the odd ones, so the only
    safe routes go by the spares."""
    size = 2 * n + 1

    def cell(row: int, col: int) -> str:
        return f"l-{row}-{col}"

    facts = [f"(vehicle-at {cell(1, 1)})"]
    facts += [f"(road {cell(1, i)} {cell(1, i + 1)})" for i in range(1, size)]
    for row in range(2, size + 1):
        width = size - row + 1
        cols = range(1, width + 1) if row % 2 == 0 else range(1, width + 1, 2)
        if row % 2 == 1:
            facts += [f"(road {cell(row, i)} {cell(row, i + 1)})" for i in range(1, width)]
        facts += [f"(road {cell(row - 1, i)} {cell(row, i)})" for i in cols]
        facts += [f"(road {cell(row, i)} {cell(row - 1, i + 1)})" for i in cols]
        spares = cols if row % 2 == 0 else sorted({1, width})  # odd rows: a spare at either end only
        facts += [f"(spare-in {cell(row, i)})" for i in spares]
    facts.append("(not-flattire)")
    objects = " ".join(cell(r, c) for r in range(1, size + 1) for c in range(1, size + 1))
    problem = (f"(define (problem triangle-tire-{n})\n  (:domain triangle-tire)\n"
               f"  (:objects {objects} - location)\n  (:init {' '.join(facts)})\n"
               f"  (:goal (vehicle-at {cell(1, size)})))\n")
    return write_problem(folder, TRIANGLE_TIRE_DOMAIN, problem, f"p{n}.pddl")
