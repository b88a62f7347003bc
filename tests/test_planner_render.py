"""The pictures of a plan: the Gantt chart (``atlas plan --render``) and the partial order
as a graph (``--render-order``). What they draw is decided by pure functions, tested here
on hand-made plans; the PNGs are checked to be written, decodable and byte-identical when
drawn twice; the CLI option in a new process, as a user runs it."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_process import assert_no_traceback, atlas
from matplotlib.image import imread
from planner_cases import DELIVERY, write_ap

from atlas_rap.views.plan_dot import plan_dot
from atlas_rap.lang import load
from atlas_rap.logic import Compound
from atlas_rap.views.order_picture import GOAL, INIT, drawn_edges, order_columns, render_order
from atlas_rap.planner.plan import Plan, PlanStep
from atlas_rap.planner.problem import problem_from_program
from atlas_rap.views.plan_render import (
    agent_colours,
    counter_labels,
    lane_rows,
    lanes_by_first_use,
    reduced_orderings,
    render_plan,
)
from atlas_rap.planner.solve import solve

REPO = Path(__file__).resolve().parent.parent


def _step(i: int, agent: str | None, start: float, end: float, name: str = "act") -> PlanStep:
    return PlanStep(id=i, action=Compound(name, (f"x{i}",)), operator=name, agent=agent, start=start, end=end,
                    source=i - 1)


def _shipped_plan(name: str) -> Plan:
    path = REPO / "operators" / name
    plan = solve(problem_from_program(load(path), name=name))
    assert plan.status == "solved"
    return plan


# ============================================================================= the Gantt chart: what it draws

def test_lanes_go_by_first_use_ties_by_step_id_and_no_agent_last() -> None:
    plan = Plan(status="solved", steps=[
        _step(1, "zeta", 5, 6),
        _step(2, None, 0, 1),
        _step(3, "mid", 0, 2),
        _step(4, "alpha", 0, 1),  # starts with mid, but mid's first step has the lower id
        _step(5, "alpha", 1, 2),
        _step(6, "zeta", 2, 3),  # zeta's first step is this one, at 2: before beta's
        _step(7, "beta", 3, 4),
    ], makespan=6)
    assert lanes_by_first_use(plan) == ["mid", "alpha", "zeta", "beta", None]
    rows = lane_rows(plan)
    assert [(lane, [s.id for s in steps]) for lane, steps in rows] == [
        ("mid", [3]), ("alpha", [4, 5]), ("zeta", [6, 1]), ("beta", [7]), (None, [2])]
    colours = agent_colours(plan)
    assert list(colours) == ["mid", "alpha", "zeta", "beta", None]
    assert len({colours[a] for a in colours}) == 5  # each agent its own colour


def test_lanes_of_a_shipped_plan() -> None:
    plan = _shipped_plan("space-station-repair-goals.ap")
    lanes = lanes_by_first_use(plan)
    assert lanes[0] == "robot"  # flies first, at 0
    first = {lane: min((s.start, s.id) for s in plan.steps if s.agent == lane) for lane in lanes}
    assert [first[lane] for lane in lanes] == sorted(first.values())


def test_arrows_are_the_transitive_reduction_of_the_orderings() -> None:
    orderings = [(1, 2), (2, 3), (1, 3), (1, 4), (3, 4), (2, 4), (5, 6)]
    assert reduced_orderings(orderings) == [(1, 2), (2, 3), (3, 4), (5, 6)]
    assert reduced_orderings([(1, 2), (1, 2)]) == [(1, 2)]
    assert reduced_orderings([]) == []
    assert reduced_orderings([(1, 2), (2, 1)]) == [(1, 2), (2, 1)]  # a circle is left as it is


def test_the_arrows_of_a_shipped_plan_keep_every_order_and_drop_implied_ones() -> None:
    import networkx as nx

    plan = _shipped_plan("space-station-repair-goals.ap")
    reduced = reduced_orderings(plan.orderings)
    implied = sorted(set(plan.orderings) | {(1, 14), (3, 11)})  # 1 ... 14 and 3 ... 11 through other steps
    assert reduced_orderings(implied) == reduced
    full, kept = nx.DiGraph(implied), nx.DiGraph(reduced)
    assert set(nx.transitive_closure(full).edges()) == set(nx.transitive_closure(kept).edges())


def test_counterplan_steps_are_labelled_with_the_threat_they_answer() -> None:
    plan = Plan(status="solved", steps=[_step(1, "robot", 0, 1), _step(2, "robot", 1, 2)],
                counterplan=[{"step": 1, "threat": "(astronaut-bumps-camera astronaut camera-1)",
                              "protects": "(pointed-at camera-1 site)"},
                             {"step": 1, "threat": "(person-closes-door person d)", "protects": "(open d)"}])
    labels = counter_labels(plan)
    assert list(labels) == [1]
    assert labels[1] == ("counters (astronaut-bumps-camera astronaut camera-1) \u2192 keeps (pointed-at camera-1 site)"
                         "; counters (person-closes-door person d) \u2192 keeps (open d)")


def test_the_shipped_adversarial_plan_names_its_threats_in_labels_and_in_dot() -> None:
    plan = _shipped_plan("adversarial-goals.ap")
    labels = counter_labels(plan)
    assert labels and all(text.startswith("counters (person-") and "\u2192 keeps (" in text for text in labels.values())
    dot = plan_dot(plan)
    for step, text in labels.items():
        node = next(line for line in dot.split("\n") if line.strip().startswith(f"s{step} ["))
        assert "counters (person-" in node and "#e8590c" in node  # the threat, outlined orange
    assert "subgraph cluster_agents" in dot and 'label="robot"' in dot
    assert dot.count("{") == dot.count("}")


# ============================================================================= the partial order: what it draws

def _hand_made_order() -> Plan:
    """Links init -> 1 -> 2 -> goal, init -> 3, 4 -> goal; orderings 1 < 2 < 4, 3 < 4 and
    1 < 4 (implied through 2); step 5 has neither."""
    return Plan(status="solved", steps=[_step(i, "a" if i % 2 else "b", 0, 1) for i in range(1, 6)],
                orderings=[(1, 2), (1, 4), (2, 4), (3, 4)],
                links=[(INIT, 1, "(p)"), (1, 2, "(q)"), (1, 2, "(r)"), (INIT, 3, "(s)"), (2, GOAL, "(g1)"),
                       (4, GOAL, "(g2)")])


def test_order_columns_are_the_longest_path_from_init() -> None:
    plan = _hand_made_order()
    assert order_columns(plan) == {INIT: 0, 1: 1, 2: 2, 3: 1, 4: 3, 5: 1, GOAL: 4}


def test_simultaneous_steps_share_a_column_and_what_follows_moves_on() -> None:
    plan = _hand_made_order()
    plan.simultaneous = [[2, 3]]
    plan.orderings.append((3, 5))
    columns = order_columns(plan)
    assert columns[2] == columns[3] == 2
    assert columns[4] == 3 and columns[5] == 3  # 5 after 3, which moved right
    assert columns[GOAL] == 4


def test_drawn_edges_links_with_their_facts_and_pure_orderings_not_implied() -> None:
    edges = drawn_edges(_hand_made_order())
    links = {(e.src, e.dst): e.facts for e in edges if e.kind == "link"}
    assert links == {(INIT, 1): ("(p)",), (1, 2): ("(q)", "(r)"), (INIT, 3): ("(s)",), (2, GOAL): ("(g1)",),
                     (4, GOAL): ("(g2)",)}
    pure = [(e.src, e.dst) for e in edges if e.kind == "order"]
    assert pure == [(2, 4), (3, 4)]  # 1 -> 2 is a link; 1 -> 4 is implied by 1 -> 2 -> 4


def test_a_threatened_link_is_marked() -> None:
    plan = _shipped_plan("adversarial-partial.ap")
    threatened = [e for e in drawn_edges(plan) if e.threatened]
    assert threatened
    assert {(t.producer, t.consumer) for t in plan.threats} == {(e.src, e.dst) for e in threatened}


# ============================================================================= the PNGs

@pytest.mark.parametrize("goals", ["adversarial-partial.ap", "bulky-object-goals.ap"])
def test_pictures_are_written_and_the_same_twice(tmp_path: Path, goals: str) -> None:
    plan = _shipped_plan(goals)
    for draw in (render_plan, render_order):
        first = draw(plan, tmp_path / f"{draw.__name__}-1.png")
        again = draw(plan, tmp_path / f"{draw.__name__}-2.png")
        data = first.read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n")
        assert data == again.read_bytes()
        assert b"matplotlib" not in data.lower()
        image = imread(first)
        h, w = image.shape[:2]
        assert 200 <= w <= 8000 and 150 <= h <= 4000, (w, h)
        assert image[..., :3].std() > 0.05  # not blank


def test_pictures_of_plans_without_agents_or_steps(tmp_path: Path) -> None:
    plan = Plan(status="solved", steps=[_step(1, None, 0, 1), _step(2, None, 1, 2)], orderings=[(1, 2)],
                links=[(INIT, 1, "(p)"), (1, 2, "(q)"), (2, GOAL, "(g)")], makespan=2)
    assert render_plan(plan, tmp_path / "g.png").stat().st_size > 0
    assert render_order(plan, tmp_path / "o.png").stat().st_size > 0
    empty = Plan(status="solved")
    assert render_plan(empty, tmp_path / "g0.png").stat().st_size > 0
    assert render_order(empty, tmp_path / "o0.png").stat().st_size > 0


# ============================================================================= the CLI

def test_render_order_from_the_command_line(tmp_path: Path) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    done = atlas("plan", "delivery.ap", "--render-order", "out/order.png", "--render", "gantt.png", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_no_traceback(done)
    assert "wrote out/order.png" in done.stderr and "wrote gantt.png" in done.stderr
    for name in ("out/order.png", "gantt.png"):
        assert (tmp_path / name).read_bytes().startswith(b"\x89PNG")
    again = atlas("plan", "delivery.ap", "--render-order", "again.png", cwd=tmp_path)
    assert again.returncode == 0
    assert (tmp_path / "again.png").read_bytes() == (tmp_path / "out/order.png").read_bytes()


def test_render_order_to_a_bad_path_is_a_one_line_error(tmp_path: Path) -> None:
    write_ap(tmp_path, DELIVERY, "delivery.ap")
    (tmp_path / "a-file").write_text("not a folder\n")
    for target in ("a-file/order.png", "."):
        done = atlas("plan", "delivery.ap", "--render-order", target, cwd=tmp_path)
        assert done.returncode == 1
        assert_no_traceback(done)
        lines = done.stderr.strip().split("\n")
        assert len(lines) == 1 and "--render-order" in lines[0], done.stderr
