"""Benchmark the foundation: reader + validator, memory queries, CLI cold start.

Prints one JSON object a line:

- ``reader``: seconds to read and validate a generated RAP/AP library of
  over 5 MB into the typed AST, beside ``sexpdata`` (PyPI) reading the same
  text into bare s-expressions, in this same process; ``ratio`` is our
  throughput over sexpdata's (target >= 0.3).
- ``memory-query``: queries per second for a pattern with a bound first
  argument, ``(at thing-N ?where)``, over a Memory of 1,000,000 facts
  (target >= 300,000/s); each query's answers are all produced. Two
  shapes: one fact per key, and four facts per key.
- ``cold-start``: wall seconds for ``atlas check`` on one small file, a new
  process each time, best of several (target <= 0.3 s).

Run: ``pip install '.[bench]' && python benchmarks/bench_lang.py``
(``--quick`` for a smaller library and memory, to try it out).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]  # generate.py, and the checkout if not installed

from generate import rap_library  # noqa: E402


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def best_of(runs: int, fn) -> float:
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def bench_reader(min_bytes: int, runs: int) -> None:
    import sexpdata

    from atlas_rap.lang import parse_text

    text = rap_library(min_bytes)
    source = parse_text(text, "generated.rap")  # also proves the text is valid
    ours = best_of(runs, lambda: parse_text(text, "generated.rap"))
    # sexpdata reads one form per loads(); wrap the library in one list.
    wrapped = "(" + text + "\n)"
    peer = best_of(runs, lambda: sexpdata.loads(wrapped))
    megabytes = len(text.encode()) / 1e6
    emit({"bench": "reader", "megabytes": round(megabytes, 2), "forms": len(source.forms),
          "atlas_s": round(ours, 3), "atlas_mb_per_s": round(megabytes / ours, 3),
          "sexpdata_s": round(peer, 3), "sexpdata_mb_per_s": round(megabytes / peer, 3),
          "ratio": round(peer / ours, 3), "target_ratio": 0.3})


def bench_memory(n_facts: int, n_queries: int) -> None:
    """Two shapes of 1,000,000 facts, one record each: every thing in one place
    (``at`` kept unique, as a memory rule would; one answer per query) and
    every node with four neighbours (four answers per query)."""
    from atlas_rap.logic import Compound, Memory, Var

    shapes = {"unique-key": (n_facts, lambda i, rng: Compound("at", (f"thing-{i}", f"place-{rng.randrange(1000)}"))),
              "four-per-key": (n_facts // 4, lambda i, rng: Compound("edge", (f"node-{i // 4}", f"node-{i}")))}
    for shape, (keys, make) in shapes.items():
        rng = random.Random(7)
        memory = Memory()
        start = time.perf_counter()
        for i in range(n_facts):
            memory.assert_fact(make(i, rng), 0.0)
        load_s = time.perf_counter() - start
        functor = "at" if shape == "unique-key" else "edge"
        prefix = "thing" if shape == "unique-key" else "node"
        value = Var("value")
        queries = [Compound(functor, (f"{prefix}-{rng.randrange(keys)}", value)) for _ in range(n_queries)]
        answers = 0

        def run() -> None:
            nonlocal answers
            answers = sum(len(list(memory.query(q))) for q in queries)

        seconds = best_of(3, run)
        emit({"bench": "memory-query", "shape": shape, "facts": len(memory), "queries": n_queries,
              "answers_per_query": round(answers / n_queries, 2), "seconds": round(seconds, 3),
              "queries_per_s": round(n_queries / seconds), "target_queries_per_s": 300000,
              "load_facts_per_s": round(n_facts / load_s)})


def bench_cold_start(runs: int) -> None:
    repo = HERE.parent
    small = repo / "rap_library" / "space-station.rap"
    exe = shutil.which("atlas")
    command = [exe] if exe else [sys.executable, "-m", "atlas_rap"]
    env = dict(os.environ, PYTHONPATH=str(repo))
    with tempfile.TemporaryDirectory() as cwd:
        def once() -> None:
            done = subprocess.run(command + ["check", str(small)], cwd=cwd, env=env,
                                  capture_output=True, text=True)
            if done.returncode != 0:
                raise SystemExit(f"atlas check failed:\n{done.stdout}{done.stderr}")

        once()  # let the OS cache the files and Lark write nothing it needs later
        seconds = best_of(runs, once)
        baseline = best_of(runs, lambda: subprocess.run([sys.executable, "-c", "pass"], env=env))
    emit({"bench": "cold-start", "command": " ".join(Path(c).name for c in command) + " check",
          "seconds": round(seconds, 3), "python_startup_s": round(baseline, 3), "target_s": 0.3})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller inputs, fewer runs")
    args = parser.parse_args()
    if args.quick:
        bench_reader(512 * 1024, 1)
        bench_memory(100_000, 20_000)
        bench_cold_start(3)
    else:
        bench_reader(5 * 1024 * 1024 + 1, 3)
        bench_memory(1_000_000, 200_000)
        bench_cold_start(10)


if __name__ == "__main__":
    main()
