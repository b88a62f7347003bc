"""Benchmark the sequencer: events per second with N concurrent waiting tasks.

The workload: N concurrent tasks, each a sequence of three steps that wait
for an event, fed the 3N events one at a time in round-robin order
(``(ev 0 1) (ev 1 1) ... (ev N-1 1) (ev 0 2) ...``), for N = 100, 1,000 and
10,000. Prints one JSON object a line:

- ``sequencer``: one line per N. ``ours_events_per_s`` is the RAP
  sequencer: N posted ``(worker ?i)`` tasks, each a ``task-net`` sequence of
  three ``wait-for (ev ?i j)`` steps; each event is one ``assert_fact`` then
  ``settle``. Only the event loop is timed (parsing, posting and the first
  ``settle`` are not), best of several runs, and every task must have
  succeeded afterwards. ``ours_events_per_s_traced`` is the same with the
  trace kept in memory (``Trace(keep=True)``, best of up to three runs):
  informative, not a target.
  ``py_trees_events_per_s`` is the same workload in py_trees, in this same
  process: a ``Parallel`` root (``SuccessOnAll``) over N
  ``Sequence(memory=True)`` of three ``py_trees.behaviours.WaitForBlackboardVariable``
  (py_trees' own behaviour for "RUNNING until a blackboard key exists",
  reading through its own blackboard ``Client``); each event sets that
  (task, step)'s key through a writer ``Client`` and ticks the root once
  (``tick_once``, without the ``BehaviourTree`` wrapper's visitors, which
  only favours py_trees). py_trees re-ticks all N sequences per event, so at
  large N it is *sampled*: fed only the first events, within a time budget
  (``py_trees_events`` fed, ``sampled: true``); the tree's state is then
  checked for exactly those events (the root SUCCESS when all 3N were fed).
  ``ratio`` is our events/s over py_trees'.
- ``sequencer-flatness``: our cost per event at the largest N over that at
  the smallest (target <= 2.0: the wait index, not a scan) and our lowest
  events/s over all N (target >= 20,000/s).

Run: ``pip install '.[bench]' && python benchmarks/bench_sequencer.py``
(``--quick`` for N = 100 and 1,000 only, to try it out).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]  # the checkout, if not installed

TARGET_EVENTS_PER_S = 20000
TARGET_COST_RATIO = 2.0

WORKER = """(define-rap (worker ?i)
  (method (task-net (sequence (wait-for (ev ?i 1)) (wait-for (ev ?i 2)) (wait-for (ev ?i 3))))))"""


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def best_of(runs: int, fn, setup=None, after=None) -> float:
    """Least seconds ``fn`` took over ``runs`` runs.

    ``setup()``, untimed, makes ``fn``'s argument afresh for each run (a run
    consumes it); ``after(arg)``, untimed, checks what the run did.
    """
    best = float("inf")
    for _ in range(runs):
        arg = setup() if setup is not None else None
        start = time.perf_counter()
        fn(arg) if setup is not None else fn()
        best = min(best, time.perf_counter() - start)
        if after is not None:
            after(arg)
    return best


def event_order(n: int) -> list[tuple[int, int]]:
    """(task, step) of every event, round-robin: step 1 of every task, then step 2, then 3."""
    return [(i, j) for j in (1, 2, 3) for i in range(n)]


# -- ours ----------------------------------------------------------------------


def bench_ours(n: int, runs: int) -> tuple[float, float]:
    """Events per second of the RAP sequencer, untraced (best of ``runs``) and traced (once)."""
    from atlas_rap.lang import parse_text
    from atlas_rap.logic import Compound
    from atlas_rap.sequencer import SUCCEEDED, Sequencer, Trace

    forms = parse_text(WORKER, "bench.rap").forms
    events = [Compound("ev", (i, j)) for i, j in event_order(n)]

    def setup(trace: Trace | None = None) -> Sequencer:
        seq = Sequencer(forms, trace=trace)
        for i in range(n):
            seq.post(Compound("worker", (i,)))
        seq.settle()  # selects every task; each now waits for (ev i 1)
        if any(task.finished for task in seq.roots):
            raise SystemExit("bench: a worker ended before any event")
        return seq

    def feed(seq: Sequencer) -> None:
        assert_fact, settle = seq.assert_fact, seq.settle
        for event in events:
            assert_fact(event)
            settle()

    def check(seq: Sequencer) -> None:
        if len(seq.roots) != n or any(task.status != SUCCEEDED for task in seq.roots):
            raise SystemExit(f"bench: N={n}: not every worker succeeded")

    seconds = best_of(runs, feed, setup, check)

    def check_traced(seq: Sequencer) -> None:
        check(seq)
        if not seq.trace.records or len(seq.trace.records) < len(events):
            raise SystemExit(f"bench: N={n}: the traced run kept too few records")

    traced_s = best_of(min(runs, 3), feed, lambda: setup(Trace(keep=True)), check_traced)
    return len(events) / seconds, len(events) / traced_s


# -- py_trees ------------------------------------------------------------------


def bench_py_trees(n: int, budget_s: float) -> tuple[int, float]:
    """Events fed and events per second of the py_trees tree, feeding until all or ``budget_s`` spent."""
    import py_trees
    from py_trees.behaviours import WaitForBlackboardVariable
    from py_trees.common import Access, ParallelPolicy, Status

    py_trees.blackboard.Blackboard.clear()  # the blackboard is global: start empty
    order = event_order(n)
    keys = [f"ev_{i}_{j}" for i, j in order]
    sequences = [
        py_trees.composites.Sequence(
            name=f"worker {i}", memory=True,
            children=[WaitForBlackboardVariable(name=f"wait ev {i} {j}", variable_name=f"ev_{i}_{j}")
                      for j in (1, 2, 3)])
        for i in range(n)
    ]
    root = py_trees.composites.Parallel(name="workers", policy=ParallelPolicy.SuccessOnAll(),
                                        children=sequences)
    writer = py_trees.blackboard.Client(name="events")
    for key in keys:
        writer.register_key(key=key, access=Access.WRITE)
    root.tick_once()  # every sequence now RUNNING on its first wait
    if root.status != Status.RUNNING:
        raise SystemExit(f"bench: py_trees root is {root.status} before any event")

    fed = 0
    set_key, tick = writer.set, root.tick_once
    clock = time.perf_counter
    start = clock()
    deadline = start + budget_s
    for key in keys:
        set_key(key, True)
        tick()
        fed += 1
        if clock() >= deadline:
            break
    seconds = clock() - start

    # The tree must have done exactly the work of the events fed.
    steps_done = [0] * n
    for i, _ in order[:fed]:
        steps_done[i] += 1
    for i, sequence in enumerate(sequences):
        statuses = [child.status for child in sequence.children]
        want = steps_done[i]
        if want == 3:
            ok = sequence.status == Status.SUCCESS
        else:
            ok = (sequence.status == Status.RUNNING and statuses[:want] == [Status.SUCCESS] * want
                  and statuses[want] == Status.RUNNING)
        if not ok:
            raise SystemExit(f"bench: py_trees N={n}: worker {i} is {sequence.status} {statuses} "
                             f"after {want} of its events")
    if fed == len(keys) and root.status != Status.SUCCESS:
        raise SystemExit(f"bench: py_trees N={n}: root is {root.status} after every event")
    py_trees.blackboard.Blackboard.clear()
    return fed, fed / seconds


# -- main ----------------------------------------------------------------------


def bench(sizes: list[int], budget_s: float) -> None:
    ours: dict[int, float] = {}
    for n in sizes:
        runs = 10 if n <= 100 else 5 if n <= 1000 else 3
        per_s, traced_per_s = bench_ours(n, runs)
        ours[n] = per_s
        fed, peer_per_s = bench_py_trees(n, budget_s)
        emit({"bench": "sequencer", "n": n, "events": 3 * n,
              "ours_events_per_s": round(per_s), "ours_events_per_s_traced": round(traced_per_s),
              "py_trees_events": fed, "py_trees_events_per_s": round(peer_per_s, 2),
              "ratio": round(per_s / peer_per_s, 1), "sampled": fed < 3 * n})
    small, large = min(sizes), max(sizes)
    cost_ratio = ours[small] / ours[large]  # cost per event is 1 / (events/s)
    lowest = min(ours.values())
    emit({"bench": "sequencer-flatness", f"cost_ratio_{large}_vs_{small}": round(cost_ratio, 2),
          "target": TARGET_COST_RATIO, "ok": cost_ratio <= TARGET_COST_RATIO and lowest >= TARGET_EVENTS_PER_S,
          "min_events_per_s": round(lowest), "target_events_per_s": TARGET_EVENTS_PER_S})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N = 100 and 1,000 only, a shorter py_trees budget")
    args = parser.parse_args()
    if args.quick:
        bench([100, 1000], budget_s=2.0)
    else:
        bench([100, 1000, 10000], budget_s=5.0)


if __name__ == "__main__":
    main()
