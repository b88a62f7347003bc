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
- ``sequencer-contention``: one line per N, N tasks contending for
  K = max(1, N // 10) skill instances (``k`` in the record: ten tasks an
  instance, nine of them waiting). Task i is ``(worker i i mod K)``, a
  ``task-net`` sequence ``(wait-for (ev ?i 1))``, a skill step
  ``(use ?k)``, ``(wait-for (ev ?i 3))``; ``use`` is a virtual skill
  (``VirtualSkills``, the real skill link, one instance per call: so
  ``(use 3)`` is one instance) without a script, whose outcome
  ``(done (use k) :succeed)`` is one of the events fed, as a skill on
  another host reports it. The 3N events are fed round-robin as above:
  ``(ev i 1)`` for every i (the first task of each instance takes it, the
  other N - K wait: ``task-waiting``), then ``(done (use i mod K) :succeed)``
  for every i (each ends its holder's step, which lets the instance go, and
  the next task in agenda order takes it: ``task-resumed``; task i holds
  its instance when its outcome arrives), then ``(ev i 3)``. Timed like
  ``sequencer`` (only the event loop, best of several runs, every task
  must have succeeded and no instance be held or waited for afterwards);
  one more untimed run with a trace that counts its records checks that
  the contention happened: N - K ``task-waiting`` and as many
  ``task-resumed`` (``waits``), N ``skill-enabled``, no ``skill-preempted``.
  ``ours_events_per_s`` is that; ``uncontended_events_per_s`` the same
  workload with N distinct instances (task i is ``(worker i i)``; its
  traced run must have no wait), the same number and kinds of events;
  ``ratio`` the first over the second (``target`` >= 0.5).

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
TARGET_CONTENTION_RATIO = 0.5

WORKER = """(define-rap (worker ?i)
  (method (task-net (sequence (wait-for (ev ?i 1)) (wait-for (ev ?i 2)) (wait-for (ev ?i 3))))))"""

CONTENDER = """(define-virtual-skill (use ?k))
(define-rap (worker ?i ?k)
  (method (task-net (sequence (wait-for (ev ?i 1)) (t1 (use ?k)) (wait-for (ev ?i 3))))))"""


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


def started(seq, calls: list) -> object:
    """``seq`` with ``calls`` posted and selected: each worker now waits for its first event."""
    for call in calls:
        seq.post(call)
    seq.settle()
    if any(task.finished for task in seq.roots):
        raise SystemExit("bench: a worker ended before any event")
    return seq


def feed_events(seq, events: list) -> None:
    """The timed loop: each event asserted, then the agenda settled."""
    assert_fact, settle = seq.assert_fact, seq.settle
    for event in events:
        assert_fact(event)
        settle()


def all_succeeded(seq, n: int) -> bool:
    """Whether the ``n`` posted workers all succeeded."""
    from atlas_rap.sequencer import SUCCEEDED

    return len(seq.roots) == n and all(task.status == SUCCEEDED for task in seq.roots)


def bench_ours(n: int, runs: int) -> tuple[float, float]:
    """Events per second of the RAP sequencer, untraced (best of ``runs``) and traced (once)."""
    from atlas_rap.lang import parse_text
    from atlas_rap.logic import Compound
    from atlas_rap.sequencer import Sequencer, Trace

    forms = parse_text(WORKER, "bench.rap").forms
    events = [Compound("ev", (i, j)) for i, j in event_order(n)]

    def setup(trace: Trace | None = None) -> Sequencer:
        return started(Sequencer(forms, trace=trace), [Compound("worker", (i,)) for i in range(n)])

    def feed(seq: Sequencer) -> None:
        feed_events(seq, events)

    def check(seq: Sequencer) -> None:
        if not all_succeeded(seq, n):
            raise SystemExit(f"bench: N={n}: not every worker succeeded")

    seconds = best_of(runs, feed, setup, check)

    def check_traced(seq: Sequencer) -> None:
        check(seq)
        if not seq.trace.records or len(seq.trace.records) < len(events):
            raise SystemExit(f"bench: N={n}: the traced run kept too few records")

    traced_s = best_of(min(runs, 3), feed, lambda: setup(Trace(keep=True)), check_traced)
    return len(events) / seconds, len(events) / traced_s


def contention_instances(n: int) -> int:
    """K, the skill instances N tasks contend for: ten tasks an instance."""
    return max(1, n // 10)


def bench_contention(n: int, k: int, runs: int) -> tuple[float, int]:
    """Events per second of N tasks sharing K instances of ``use`` (best of ``runs``), and the waits
    a traced run counted (K = N: nobody waits)."""
    from collections import Counter

    from atlas_rap.lang import ast, parse_text
    from atlas_rap.logic import Compound
    from atlas_rap.sequencer import Sequencer, Trace
    from atlas_rap.skills.virtual import VirtualSkills

    forms = parse_text(CONTENDER, "bench.rap").forms
    raps = [form for form in forms if isinstance(form, ast.RapDef)]
    scripts = [form for form in forms if isinstance(form, ast.VirtualSkillDef)]
    events = ([Compound("ev", (i, 1)) for i in range(n)]
              + [Compound("done", (Compound("use", (i % k,)), ":succeed")) for i in range(n)]
              + [Compound("ev", (i, 3)) for i in range(n)])

    def setup(trace: Trace | None = None) -> Sequencer:
        seq = Sequencer(raps, skills=VirtualSkills(scripts), trace=trace)
        return started(seq, [Compound("worker", (i, i % k)) for i in range(n)])

    def feed(seq: Sequencer) -> None:
        feed_events(seq, events)

    def check(seq: Sequencer) -> None:
        if not all_succeeded(seq, n):
            raise SystemExit(f"bench: contention N={n} K={k}: not every worker succeeded")
        if seq.holders or seq.resources.queues or seq.skills.running():
            raise SystemExit(f"bench: contention N={n} K={k}: an instance is still held or waited for")

    seconds = best_of(runs, feed, setup, check)

    counted: Counter[str] = Counter()
    trace = Trace()
    trace.add_sink(lambda record: counted.update((record["event"],)))
    seq = setup(trace)
    feed(seq)
    check(seq)
    waits = counted["task-waiting"]
    if (waits != n - k or counted["task-resumed"] != waits or counted["skill-enabled"] != n
            or counted["skill-preempted"]):
        raise SystemExit(f"bench: contention N={n} K={k}: {waits} task-waiting, {counted['task-resumed']} "
                         f"task-resumed, {counted['skill-enabled']} skill-enabled, "
                         f"{counted['skill-preempted']} skill-preempted (want {n - k}, {n - k}, {n}, 0)")
    return len(events) / seconds, waits


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
    for n in sizes:
        runs = 10 if n <= 100 else 5 if n <= 1000 else 3
        k = contention_instances(n)
        per_s, waits = bench_contention(n, k, runs)
        alone_per_s, _ = bench_contention(n, n, runs)
        ratio = per_s / alone_per_s
        emit({"bench": "sequencer-contention", "n": n, "k": k, "events": 3 * n, "waits": waits,
              "ours_events_per_s": round(per_s), "uncontended_events_per_s": round(alone_per_s),
              "ratio": round(ratio, 2), "target": TARGET_CONTENTION_RATIO,
              "ok": ratio >= TARGET_CONTENTION_RATIO})


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
