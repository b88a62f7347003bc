"""The skill-acquisition experiment over many seeds, in parallel processes, with its statistics.

One seed of the experiment (:func:`atlas_rap.views.experiment.skill_acquisition`)
is one robot's story: on which run its map got good enough, how close to
the optimal time it drove after that. Over many seeds the spread shows.
:func:`skill_acquisition_seeds` runs each seed in a process of its own
(``seed-N/`` in the output folder, each written as the single-seed form
writes its folder: figures.json, runs.csv, the grids and the figures, so
any one seed can be looked at alone) and returns the combined
``figures.json`` structure::

    {"seeds": [0, ..., 9], "threshold": 0.9, "world": ..., "localisation": ...,
     "runs_asked": 7, "complete": true, ("incomplete": "why", when false)
     "per_seed": [each seed's own figures.json, in seed order],
     "summary": {... see summary()}}

:func:`write_seeds_results` writes it into the output folder with the
runs of all seeds in one ``runs.csv`` (a seed column first) and the
figures over all seeds (:func:`atlas_rap.views.figures.write_seeds_figures`).

The results are gathered in seed order, so the same seeds give the same
``figures.json``, byte for byte, whatever the number of processes and
whichever seed ends first.

Ctrl-C: the seeds running are stopped as the single-seed form stops
(each returns the runs it finished, marked incomplete, and writes its
folder), the seeds not started are not run, and the whole result is
marked incomplete. The worker processes ignore Ctrl-C while they wait
for a seed, so the pool never breaks; the parent also passes its Ctrl-C
on to the workers running a seed, so that ``kill -INT`` of the parent
alone stops them too (from a terminal every process gets it: a worker
takes the first and ignores the rest).
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from atlas_rap.views.experiment import RESULT_FILES as SEED_RESULT_FILES
from atlas_rap.views.experiment import (
    RUNS_CSV_COLUMNS,
    Settings,
    check_worlds,
    layer_order,
    runs_csv_row,
    skill_acquisition,
    write_results,
    write_tables,
)
from atlas_rap.views.figures import (
    FIGURE_FILES,
    LAYERS,
    obstacle_case,
    obstacle_case_keys,
    write_seeds_figures,
)

__all__ = [
    "DEFAULT_SEEDS", "RESULT_FILES", "SEED_FOLDER", "after_crossing", "combine", "crossing_run", "runs_after_crossing",
    "seed_outcome",
    "skill_acquisition_seeds", "summary", "worker_count", "write_seeds_results",
]

DEFAULT_SEEDS = tuple(range(10))
"""The seeds of ``atlas experiment skill-acquisition`` when it is given neither --seed nor --seeds."""

SEED_FOLDER = "seed-{seed}"
"""The folder of one seed's results in the output folder."""

RESULT_FILES = ("figures.json", "runs.csv", FIGURE_FILES["map_quality"], FIGURE_FILES["durations"],
                FIGURE_FILES["run_layers"], "fig13b-obstacles*.png",
                *(f"{SEED_FOLDER.format(seed='*')}/{name}" for name in SEED_RESULT_FILES))
"""The files the multi-seed form writes in its folder (glob patterns), its seeds' folders included."""

POLL_S = 0.1
"""How often the parent looks at what the workers say (a seed's run started) while it waits for seeds."""


# -- running ------------------------------------------------------------------------------------------


def skill_acquisition_seeds(out: str | Path, settings: Settings = Settings(), seeds: Iterable[int] = DEFAULT_SEEDS,
                            jobs: int | None = None, progress: Callable[[str], None] | None = None,
                            finished: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run the experiment of ``settings`` once per seed (its ``seed`` replaced), ``jobs`` seeds at a
    time in processes of their own (default: one per CPU; one job: in this process), each into
    ``out/seed-N``; the combined ``figures.json`` structure (the module docstring).

    ``progress`` is told what starts (``"seed 3: run 2 of 7"``), ``finished`` is given each seed's
    figures as the seed ends, in the order they end; both are called in this process. Ctrl-C stops
    the experiment (the module docstring); what it has is returned with ``"complete": false``. An
    error in a seed stops the others and goes on up.

    The worker processes are new interpreters (multiprocessing's "spawn": nothing of this process's
    threads or locks comes along), so a script that calls this calls it under
    ``if __name__ == "__main__":``, as multiprocessing asks.
    """
    order = sorted(seeds)
    if not order or len(set(order)) != len(order):
        raise ValueError(f"the seeds must be distinct, and at least one: {order}")
    check_worlds(settings)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    workers = worker_count(jobs, order)
    results: dict[int, dict[str, Any]] = {}
    run = _in_this_process if workers == 1 else _in_processes
    interrupted = run(out, settings, order, workers, results, progress or _quiet, finished or _quiet)
    return combine(settings, order, [results[seed] for seed in order if seed in results], interrupted)


def worker_count(jobs: int | None, seeds: Sequence[int]) -> int:
    """How many seeds run at a time: ``jobs`` (default: one per CPU), no more than there are seeds."""
    return min(jobs or os.cpu_count() or 1, len(seeds))


def _in_this_process(out: Path, settings: Settings, seeds: Sequence[int], workers: int,
                     results: dict[int, dict[str, Any]], progress: Callable[[str], None],
                     finished: Callable[[dict[str, Any]], None]) -> bool:
    """The seeds one after another in this process; whether Ctrl-C stopped them."""
    for seed in seeds:
        try:
            data = _run_seed(out, settings, seed, lambda what, seed=seed: progress(f"seed {seed}: {what}"))
        except KeyboardInterrupt:  # before its first run started, or while its folder was written
            return True
        results[seed] = data
        finished(data)
        if not data["complete"]:  # skill_acquisition caught the Ctrl-C
            return True
    return False


def _in_processes(out: Path, settings: Settings, seeds: Sequence[int], workers: int,
                  results: dict[int, dict[str, Any]], progress: Callable[[str], None],
                  finished: Callable[[dict[str, Any]], None]) -> bool:
    """The seeds in a pool of ``workers`` processes; whether Ctrl-C stopped them."""
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: no threads or locks of ours inherited
    messages = context.SimpleQueue()  # from the workers: a seed started (its worker's pid), a run started
    stop = context.Event()  # set: a worker starts no more seeds
    started: dict[int, int] = {}  # seed -> pid of the worker that runs it
    futures: dict[Future, int] = {}
    pool: ProcessPoolExecutor | None = None
    try:
        with _ctrl_c_held():  # the workers ignore Ctrl-C from birth, until a seed runs in them (_seed_task)
            pool = ProcessPoolExecutor(workers, mp_context=context, initializer=_worker_start,
                                       initargs=(messages, stop))
            for seed in seeds:
                futures[pool.submit(_seed_task, out, settings, seed)] = seed
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            _hear(messages, started, progress)
            for future in sorted(done, key=futures.__getitem__):
                _gather(future, futures[future], results, finished)
        return False  # (a seed stopped by a signal of its own is incomplete: so is the whole, see combine)
    except KeyboardInterrupt:
        _stop(stop, messages, started, futures, results)
        for future in sorted(futures, key=futures.__getitem__):
            if future.done() and not future.cancelled() and futures[future] not in results:
                _gather(future, futures[future], results, finished)
        return True
    except BaseException:
        _stop(stop, messages, started, futures, {})
        raise
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


def _gather(future: Future, seed: int, results: dict[int, dict[str, Any]],
            finished: Callable[[dict[str, Any]], None]) -> None:
    """Keep a seed's figures (none: it was stopped before it had any); an error in it goes on up."""
    data = future.result()
    if data is not None:
        results[seed] = data
        finished(data)


def _stop(stop: Any, messages: Any, started: dict[int, int], futures: dict[Future, int],
          results: Mapping[int, Any]) -> None:
    """Stop the pool's work: no seed starts any more, the seeds running are interrupted (as Ctrl-C
    stops one), and the parent waits until each has returned what it has."""
    stop.set()
    for future in futures:
        future.cancel()  # those not yet handed to a worker
    _hear(messages, started, _quiet)  # every seed that started before the stop was set has said so
    ended = {futures[future] for future in futures if future.done()} | set(results)
    for seed, pid in started.items():
        if seed not in ended:
            try:
                os.kill(pid, signal.SIGINT)
            except ProcessLookupError:  # the worker is gone already
                pass
    wait(list(futures))


def _hear(messages: Any, started: dict[int, int], progress: Callable[[str], None]) -> None:
    """Read what the workers said since last time: a seed started (kept in ``started``), a run of it
    started (told to ``progress``)."""
    news = []
    with _ctrl_c_blocked():  # a message is read whole (a Ctrl-C between its length and its body would
        while not messages.empty():  # leave the rest unreadable), and every start is kept
            kind, seed, what = messages.get()
            if kind == "start":
                started[seed] = what
            else:
                news.append(f"seed {seed}: {what}")
    for what in news:
        progress(what)


# -- in a worker --------------------------------------------------------------------------------------

_WORKER: dict[str, Any] = {}
"""In a worker process: the queue to the parent and the stop event (set by :func:`_worker_start`)."""


def _worker_start(messages: Any, stop: Any) -> None:
    """A worker's start: it ignores Ctrl-C while it waits for a seed (a Ctrl-C there would break the
    pool); :func:`_seed_task` listens to it while a seed runs."""
    _WORKER.update(messages=messages, stop=stop)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # (already so since its birth: see _ctrl_c_held)
    if hasattr(signal, "pthread_sigmask"):  # born with it blocked too, when it came ignored: let it in
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _seed_task(out: Path, settings: Settings, seed: int) -> dict[str, Any] | None:
    """One seed in a worker: its figures (None: stopped before it had any). The first Ctrl-C stops
    it as it stops the single-seed form; later ones are ignored, so the seed's folder is written whole."""
    messages, stop = _WORKER["messages"], _WORKER["stop"]
    signal.signal(signal.SIGINT, _interrupt_once)
    try:
        messages.put(("start", seed, os.getpid()))  # before looking at stop: see _stop
        if stop.is_set():
            return None
        data = skill_acquisition(_folder(out, seed), dataclasses.replace(settings, seed=seed),
                                 progress=lambda what: messages.put(("run", seed, what)))
    except KeyboardInterrupt:  # before its first run started
        return None
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    write_results(data, _folder(out, seed))
    return data


def _interrupt_once(signum: int, frame: Any) -> None:
    """Ctrl-C during a seed: stop it (KeyboardInterrupt), and ignore any Ctrl-C after this one."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    raise KeyboardInterrupt


def _run_seed(out: Path, settings: Settings, seed: int, progress: Callable[[str], None]) -> dict[str, Any]:
    """One seed in this process, its folder written; its figures."""
    data = skill_acquisition(_folder(out, seed), dataclasses.replace(settings, seed=seed), progress=progress)
    write_results(data, _folder(out, seed))
    return data


def _folder(out: Path, seed: int) -> Path:
    return out / SEED_FOLDER.format(seed=seed)


@contextmanager
def _ctrl_c_held() -> Iterator[None]:
    """Ctrl-C ignored by the processes started meanwhile from birth (a new interpreter keeps an
    ignored SIGINT ignored, and blocked: :func:`_worker_start` unblocks it) and held back in this
    one (:func:`_ctrl_c_blocked`). Only in the main thread (elsewhere, nothing)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with _ctrl_c_blocked():  # (Linux keeps a blocked signal pending even while it is ignored)
        handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, handler)


@contextmanager
def _ctrl_c_blocked() -> Iterator[None]:
    """Ctrl-C held back in this thread, not lost: one that comes meanwhile is delivered when the block ends."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _quiet(*_: Any) -> None:
    """Nobody listening."""


# -- the combined results -----------------------------------------------------------------------------


def combine(settings: Settings, seeds: Sequence[int], per_seed: list[dict[str, Any]],
            interrupted: bool) -> dict[str, Any]:
    """The combined ``figures.json`` structure of the seeds' figures ``per_seed`` (in seed order)."""
    first = per_seed[0] if per_seed else {}
    complete = not interrupted and len(per_seed) == len(seeds) and all(one["complete"] for one in per_seed)
    data: dict[str, Any] = {"seeds": list(seeds), "threshold": first.get("threshold"),
                            "world": first.get("world", settings.world),
                            "localisation": first.get("localisation", settings.localisation),
                            "runs_asked": settings.runs, "complete": complete}
    if not complete:
        whole = sum(1 for one in per_seed if one["complete"])
        stopped = [f"seed {one['seed']} {one['incomplete']}" for one in per_seed if not one["complete"]]
        data["incomplete"] = (f"interrupted with {whole} of {len(seeds)} seeds complete"
                              + (f" ({'; '.join(stopped)})" if stopped else ""))
    data["per_seed"] = per_seed
    data["summary"] = summary(per_seed, settings.runs)
    return data


def summary(per_seed: Sequence[Mapping[str, Any]], runs_asked: int) -> dict[str, Any]:
    """The statistics over the seeds' figures ``per_seed``::

        {"seeds_run": [seeds with figures],
         "per_run": [{"run": n, "seeds": how many seeds ran it,
                      "map_quality": {"median", "q1", "q3", "min", "max"}, "duration_s": {the same},
                      "optimal_s": median optimal time, "primary_share": {layer: mean share of the run}}],
         "crossed_in": {"by_seed": {"3": first run whose map quality >= the threshold, or null},
                        "histogram": {"1": seeds, ..., "<runs_asked>": seeds, "never": seeds}},
         "after_crossing": {"runs": how many, "median_duration_s", "optimal_s", "ratio_to_optimal",
                            "by_seed": {"3": {"runs", "median_duration_s"}}},
         "obstacles": [{"case": name or null, "title", "by_seed": {"3": {"end_s", "layers": [...]}}}]}

    Quartiles are numpy's linear percentiles. ``primary_share``: each seed's share of the run's time
    each layer was primary, averaged over the seeds. "never" counts the seeds whose map stayed below
    the threshold in every run they ran. ``after_crossing``: the runs after each seed's crossing
    run (the runs Layer II drives), all seeds together; its values are null when there are none.
    """
    per_run = []
    for number in range(1, max([runs_asked] + [len(one["runs"]) for one in per_seed]) + 1):
        runs = [run for one in per_seed for run in one["runs"] if run["run"] == number]
        if runs:
            per_run.append({"run": number, "seeds": len(runs),
                            "map_quality": _spread([run["map_quality"] for run in runs], 6),
                            "duration_s": _spread([run["duration_s"] for run in runs], 3),
                            "optimal_s": _median([run["optimal_s"] for run in runs], 3),
                            "primary_share": _shares(runs)})
    outcomes = [seed_outcome(one) for one in per_seed]
    histogram = {str(n): 0 for n in range(1, runs_asked + 1)} | {"never": 0}
    for outcome in outcomes:
        key = "never" if outcome["crossed_in"] is None else str(outcome["crossed_in"])
        histogram[key] = histogram.get(key, 0) + 1
    after = after_crossing(per_seed)
    return {"seeds_run": [one["seed"] for one in per_seed],
            "per_run": per_run,
            "crossed_in": {"by_seed": {str(o["seed"]): o["crossed_in"] for o in outcomes}, "histogram": histogram},
            "after_crossing": {**after,
                               "by_seed": {str(o["seed"]): {"runs": o["runs_after"],
                                                            "median_duration_s": o["median_after_s"]}
                                           for o in outcomes}},
            "obstacles": _obstacles(per_seed)}


def crossing_run(one: Mapping[str, Any]) -> int | None:
    """The first run of one seed in which the map was found good (None: none): its map quality at
    the end is at least the seed's threshold, or Layer II took the drive over from Layer IV during
    it. The rules switch when the quality passes the threshold as Layer IV measures it while
    driving; the run may then end a little under it (within the hysteresis, so Layer II keeps
    the drive), and that run is still the one in which the switch happened."""
    threshold = float(one["threshold"])
    return next((run["run"] for run in sorted(one["runs"], key=lambda run: run["run"])
                 if float(run["map_quality"]) >= threshold or _handed_to_ii(run)), None)


def runs_after_crossing(one: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The runs of one seed after its crossing run (:func:`crossing_run`): the runs Layer II drives."""
    crossed = crossing_run(one)
    return [run for run in one["runs"] if crossed is not None and run["run"] > crossed]


def _handed_to_ii(run: Mapping[str, Any]) -> bool:
    """Whether Layer IV handed the drive to Layer II during the run."""
    return any(entry["layer"] == "II" and entry.get("previous") == "IV" for entry in run.get("timeline", ()))


def seed_outcome(one: Mapping[str, Any]) -> dict[str, Any]:
    """What one seed came to: ``{"seed", "crossed_in"`` (:func:`crossing_run`), ``"runs_after"`` (the
    runs after it), ``"median_after_s"`` (their median duration; None without any), ``"optimal_s"``,
    ``"complete"``, ``"failed"`` (errands that did not get there), ``"obstacles"`` (per case, the
    primary layers in turn: :func:`~atlas_rap.views.experiment.layer_order`)``}``."""
    crossed = crossing_run(one)
    after = runs_after_crossing(one)
    return {"seed": one["seed"], "crossed_in": crossed, "runs_after": len(after),
            "median_after_s": _median([run["duration_s"] for run in after], 3),
            "optimal_s": _median([run["optimal_s"] for run in one["runs"]], 3), "complete": one["complete"],
            "failed": sum(1 for run in one["runs"] if not run["ok"]),
            "obstacles": [{"case": key, "layers": layer_order(obstacle_case(one, key))}
                          for key in obstacle_case_keys({"per_seed": [one]})]}


def after_crossing(per_seed: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The runs after each seed's crossing run, all seeds together: ``{"runs": how many,
    "median_duration_s", "optimal_s"`` (their median optimal time), ``"ratio_to_optimal"}``."""
    after = [run for one in per_seed for run in runs_after_crossing(one)]
    median = _median([run["duration_s"] for run in after], 3)
    optimal = _median([run["optimal_s"] for run in after], 3)
    ratio = round(median / optimal, 3) if median is not None and optimal else None
    return {"runs": len(after), "median_duration_s": median, "optimal_s": optimal, "ratio_to_optimal": ratio}


def write_seeds_results(data: Mapping[str, Any], out: str | Path) -> list[Path]:
    """``figures.json``, ``runs.csv`` (one row per seed and run, the seed first) and the figures over
    all seeds, into ``out``, each written whole; the paths written. (The seeds' own folders are
    written by :func:`skill_acquisition_seeds` as each seed ends.)"""
    out = Path(out)
    written = write_tables(data, out, ("seed", *RUNS_CSV_COLUMNS),
                           ([one["seed"], *runs_csv_row(run)] for one in data["per_seed"] for run in one["runs"]))
    return written + write_seeds_figures(data, out)


def _spread(values: Sequence[float], digits: int) -> dict[str, float]:
    """Median, quartiles (numpy's linear percentiles), least and greatest of ``values``."""
    q1, median, q3 = np.percentile(np.asarray(values, dtype=float), [25, 50, 75], method="linear")
    return {"median": round(float(median), digits), "q1": round(float(q1), digits), "q3": round(float(q3), digits),
            "min": round(float(min(values)), digits), "max": round(float(max(values)), digits)}


def _median(values: Sequence[float], digits: int) -> float | None:
    return round(float(np.median(np.asarray(values, dtype=float))), digits) if len(values) else None


def _shares(runs: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """Each layer's share of a run's time as primary, averaged over the runs (of different seeds)."""
    shares = {layer: 0.0 for layer in LAYERS}
    counted = 0
    for run in runs:
        total = sum(float(run["primary_s"].get(layer, 0.0)) for layer in LAYERS)
        if total > 0:
            counted += 1
            for layer in LAYERS:
                shares[layer] += float(run["primary_s"].get(layer, 0.0)) / total
    return {layer: round(share / counted, 4) if counted else 0.0 for layer, share in shares.items()}


def _obstacles(per_seed: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Each obstacle case: per seed, how long it took and the primary layers in turn."""
    cases = []
    for key in obstacle_case_keys({"per_seed": per_seed}):
        by_seed, title = {}, None
        for one in per_seed:
            case = obstacle_case(one, key)
            if case is None:
                continue
            title = title or case.get("title")
            by_seed[str(one["seed"])] = {"end_s": case["end_s"], "layers": layer_order(case)}
        cases.append({"case": key, "title": title, "by_seed": by_seed})
    return cases

