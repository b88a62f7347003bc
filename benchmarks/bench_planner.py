"""Benchmark the AP planner on classical PDDL beside pyperplan and Fast Downward.

For each classical domain in the data root (``REPO/../shared/data/pddl``,
or the first ``shared/data/pddl`` beside a folder above the checkout;
``--data-root DIR``): the thirteen classical IPC domains there
(:data:`DOMAINS`: blocks, depot, elevators-sat08, freecell, gripper,
logistics00, mprime, pipesworld-notankage, rovers, scanalyzer-08, storage,
tpp, transport-sat08; three of them with action costs), the first twenty
problems in natural order (probBLOCKS-4-0 before
probBLOCKS-10-0, p01 before p10) are solved, one after the other in this one
run; then the problems of every ``--data DIR`` folder, each a domain of its
own. A folder holds ``domain.pddl`` and problem files, or one domain file per
problem as the IPC ships some domains (found as Fast Downward's driver finds
them: ``p01-domain.pddl``, ``domain_p01.pddl``, ``domain-p01.pddl``, or
``p01-domain.pddl`` beside ``p01-airport1-p1.pddl``); a file is a problem
when its ``(define (problem ...`` says so. Nothing is ever written into a
data folder: every run gets a scratch copy of its domain and problem.

``--quick`` is the check that the benchmark still works (the test
``tests/test_bench_planner.py`` runs it): the first two problems of each
domain, a 10 s timeout, tireworld p1-p2; about 20 s on 2 cores with both
peers installed (pyperplan on freecell is most of it).

In process: the CPU of the solve (start-up excluded)
----------------------------------------------------
Most problems are solved in well under a second, so timing each planner as a
fresh ``python`` process mostly times interpreter start-up and imports (about
0.15 s for atlas_rap, 0.055 s for pyperplan), not planning. So both Python
planners are imported once, here, and each run happens in a worker forked
from this process after the imports (``os.fork``: the worker starts with
every module loaded and with this process's ``PYTHONHASHSEED``). The worker
sets the inherited heap aside for the garbage collector (``gc.freeze()``)
and measures ``time.process_time()`` (its own CPU seconds) around:

- ours (``ours``): ``load_pddl`` (read), ``solve`` (ground, search, plan
  shortening, counterplanning, partial order, plan expansion: all of it) and
  ``write_plan_file(plan.sequence)``;
- pyperplan (``pyperplan``, PyPI 2.1): the steps of
  ``pyperplan.planner.search_plan`` with ``SEARCHES['gbf']`` and
  ``HEURISTICS['hff']``, as ``pyperplan -s gbf -H hff`` runs them (parse,
  ground, build h^FF, greedy best-first search), then ``write_solution``
  (the CLI's ``PROBLEM.soln``); not timed: the CLI's logging to stdout and
  its attempt to find VAL's ``validate`` on the PATH.

The worker sends back its CPU seconds, the status, the plan length and
(ours) the parallel length, makespan, risk and its own grounding and search
times (``ground_s``, ``search_s``; pyperplan: ``parse_s``, ``ground_s``,
``search_s`` as its log's "Search time"). It is killed after S + 5 wall
seconds (``--timeout S``, default 60), and more than S CPU seconds counts as
a timeout. ``worker_cpu_s`` is the worker's whole CPU from ``os.wait4``
(fork and exit included), ``wall_s`` the wall time of the fork.
``time_ratio_vs_pyperplan`` compares these in-process ``cpu_s`` figures.

Fast Downward is C++ and only runs as a subprocess; its in-process
counterpart is its own CPU for the work, ``solve_cpu_s``: the translator's
"Done! [X s CPU" plus the search component's "Total time" (its driver's and
components' start-up left out). ``time_ratio_vs_fd`` sets our ``cpu_s``
beside it, ``search_time_ratio_vs_fd`` our search beside its "Search time".
FD counts CPU in clock ticks (the translator 10 ms, the search often 4 ms),
so on problems solved in a few milliseconds these read 0 or one tick (and
a ratio floors them at 1 ms): compare on the larger problems.

Whole processes (interpreter start-up included)
-----------------------------------------------
- ``ours-cli``: ``python -m atlas_rap plan --pddl DOMAIN PROBLEM
  --plan-file F --json --timing --timeout S``; ``cli_cpu_s`` is its user +
  system CPU from ``os.wait4``, ``cli_wall_s`` its wall time. atlas_rap's
  modules are compiled to bytecode first, as ``pip install`` does
  (``ours_bytecode`` in the setup line): an editable install where
  ``PYTHONDONTWRITEBYTECODE`` is set would otherwise compile them again in
  every run, 0.1 s of CPU each;
  ``ground_s``/``search_s`` come from the JSON's ``timing`` (``stats`` holds
  counts only). Its plan file is validated too ("ours by --plan-file"), and
  ``plan_digest`` shows whether it is the plan of the in-process run.
  ``--no-cli`` skips these runs.
- ``pyperplan-cli``: ``python -m pyperplan -s gbf -H hff`` (``--no-cli-pyperplan``
  skips it). Not run where pyperplan in process timed out (it would too,
  start-up on top): that line says ``"skipped"`` with status ``timeout``.
- ``fd-lama-first``: Fast Downward ``--alias lama-first``, the driver bundled
  in the ``up-fast-downward`` wheel. ``cli_cpu_s`` is the driver's whole run
  (its translator and search processes included), ``search_s`` its logged
  "Search time" (CPU, 4 ms ticks), ``search_total_s`` its whole search
  component, ``translate_s`` its translator. ``--no-fd`` skips it.

Pyperplan and Fast Downward are optional (``pip install '.[bench]'``): when
one is not installed or does not run, one JSON line says so
(``planner-pyperplan-unavailable`` / ``planner-fd-unavailable``, with
``peer``, ``why`` and ``install``) and the benchmark goes on without it.

Subprocesses are killed, with their process group, after S + 5 wall
seconds, and more than S CPU seconds counts as a timeout. Every JSON field
named ``cpu_s`` is an in-process figure, every ``cli_cpu_s`` a whole
subprocess run.

Every plan is checked with atlas_rap's validator (``validate_plan_file``:
ours as written; the others after light normalisation: comments and blank
lines dropped, lower case, one ``(action arg ...)`` a line). A plan that
fails the check is ``invalid-plan`` and not solved. A plan that cannot be
checked is ``unchecked`` (``valid`` null, ``unchecked_why``), neither solved
nor invalid: the validator cannot read the domain or problem (a PDDL
feature it lacks: the peer's plan may well be right), it crashed, or it is
missing.

Output: one JSON object a line (progress goes to stderr)
--------------------------------------------------------
- ``planner-setup``: what ran (``quick``, ``data``, ``extra_data``,
  ``domains``, ``planners``, versions, paths, hash seed, load average);
  before it, a ``planner-*-unavailable`` line for each missing peer.
- ``planner``: one line per problem per planner. Always: ``domain``,
  ``problem``, ``planner``, ``mode`` (``in-process`` or ``subprocess``),
  ``solved`` (in time and valid), ``status`` (solved, unsolvable, timeout,
  memout, error, invalid-plan, unchecked, unsupported: a peer that cannot read
  the domain, pyperplan on :action-costs say), ``cpu_s`` and ``wall_s``
  (in-process) or ``cli_cpu_s`` and ``cli_wall_s`` (subprocess), ``length``,
  ``valid``, ``cost`` (the validator's sum of the plan's action costs: its
  length without :action-costs; null unless valid); as they apply: ``parallel_length``, ``makespan`` and ``risk``
  (ours), ``ground_s``/``search_s``, ``solve_cpu_s`` (FD), ``plan_digest``,
  ``validation`` (why invalid), ``unchecked_why``, ``skipped``, ``why``,
  and ``late_imports`` should a worker import a module while being timed.
- ``planner-domain``: per domain (``domain``, ``folder``, ``problems``), with
  every key present whichever peers ran (null for a planner that did not
  run, or nothing to compare): ``coverage_P`` and ``unchecked_P`` for each
  planner P (ours, pyperplan, ours-cli, pyperplan-cli, fd-lama-first);
  against pyperplan, over the problems both solved: in process the
  geometric mean of our CPU over its CPU (``time_ratio_vs_pyperplan``), the
  same for the search alone, the total CPU of each, the mean plan length of
  each, our mean parallel length; as whole processes
  ``cli_time_ratio_vs_pyperplan`` (CPU) and ``cli_wall_ratio_vs_pyperplan``;
  against Fast Downward ``commonly_solved_vs_fd``, ``time_ratio_vs_fd`` (in
  process, as above), ``search_time_ratio_vs_fd``, ``cli_time_ratio_vs_fd``
  and ``cli_wall_ratio_vs_fd`` (whole processes), ``mean_length_ours_vs_fd``
  and ``mean_length_fd``; ``cli_over_in_process_ours`` (our CLI's CPU over
  our in-process CPU: what start-up costs us), ``ours_cli_same_plan``; and
  the targets ``coverage_ok`` (ours >= pyperplan's), ``time_ok`` (in-process
  ratio <= 0.25) and ``length_ok`` (our mean length <= pyperplan's), and
  against Fast Downward ``coverage_ok_vs_fd`` (ours >= FD's),
  ``time_ok_vs_fd`` (whole-process ratio <= 2 in a domain, <= 1.5 over all)
  and ``length_ok_vs_fd`` (null when there is nothing to compare). Coverage
  and the 2x are held in every domain; the others over all of them (the
  overall line's verdicts and ``targets_failed``); and
  ``max_rss_mb_ours_cli``, ``max_rss_mb_fd``: the largest peak resident
  memory of a solved run (each subprocess line has its ``cli_max_rss_mb``;
  Fast Downward's is that of its largest component). A domain folder that is missing or holds no
  problem gives a line with ``skipped`` instead.
- ``planner-overall``: the same figures over every problem, and whether
  every target was met.
- ``planner-tireworld`` (unless ``--no-tireworld``): counterplanning on
  fond-triangle-tireworld p1-p10, ours only, in-process as above: a problem
  passes when it is solved with ``risk == 0`` and ``validate_plan_file(...,
  adversarial=True)`` accepts the plan (no flat tire can defeat it); then
  ``planner-tireworld-summary``. Then ``planner-fond-blocksworld``: the same
  on fond-blocksworld p1-p10, where any stacking may drop the block, so a
  plan is rarely safe: a problem passes when it is solved, the plan is valid
  and its risk is 0 or the threats that make it up are named (``threats``);
  then ``planner-fond-blocksworld-summary``.

Run
---
``python benchmarks/bench_planner.py --quick`` (under 30 s);
``pip install '.[bench]' && python benchmarks/bench_planner.py > bench.jsonl``
(half an hour or more: pyperplan times out on depot). Options: ``--quick``,
``--data-root DIR``, ``--data DIR`` (repeatable), ``--domains ...`` (none:
only ``--data`` and the tireworld), ``--problems N``, ``--timeout S``,
``--no-fd``, ``--no-pyperplan``, ``--no-cli``, ``--no-cli-pyperplan``, ``--no-tireworld``,
``--tireworld-problems N``, ``--jobs N`` (default 1; more runs problems side
by side, which disturbs the timings), ``--keep-plans DIR``, ``--hash-seed``
(default 0; ``random`` for none): pyperplan breaks ties by set order, so its
plans and times change from run to run without a fixed seed. The script
re-executes itself once at start when ``PYTHONHASHSEED`` is not already the
seed asked for, so this process, its forked workers and its subprocesses
all run with it.
"""

from __future__ import annotations

import argparse
import compileall
import functools
import gc
import hashlib
import importlib.metadata
import importlib.util
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path[:0] = [str(REPO)]  # the checkout, if not installed

DOMAINS = ["blocks", "depot", "elevators-sat08-strips", "freecell", "gripper", "logistics00", "mprime",
           "pipesworld-notankage", "rovers", "scanalyzer-08-strips", "storage", "tpp", "transport-sat08-strips"]
"""The thirteen classical IPC domains of the shared data (the FOND ones are the tireworld's and the tests')."""
TIREWORLD = "fond-triangle-tireworld"
FOND_BLOCKSWORLD = "fond-blocksworld"
GRACE_S = 5.0  # wall seconds past the timeout before a planner is killed
MIN_CPU_S = 1e-3  # floor for time ratios (a zero would break the geometric mean)
TAIL_CHARS = 800  # how much of a failing planner's stderr goes into its JSON line
UNSUPPORTED = "unsupported"  # a peer that cannot read the domain (a feature it lacks): not a failure of the harness

OURS, PYPERPLAN = "ours", "pyperplan"  # in-process, in a forked worker
OURS_CLI, PYPERPLAN_CLI, FD = "ours-cli", "pyperplan-cli", "fd-lama-first"  # subprocesses
IN_PROCESS = {OURS, PYPERPLAN}
ALL_PLANNERS = [OURS, PYPERPLAN, OURS_CLI, PYPERPLAN_CLI, FD]  # the order of a problem's runs

# Fast Downward's exit codes (https://www.fast-downward.org/ExitCodes).
FD_SOLVED = {0, 1, 2, 3}  # a plan was found (perhaps running out of time/memory afterwards)
FD_UNSOLVABLE = {10, 11, 12}
FD_TIMEOUT = {21, 23, 24, 256 - signal.SIGXCPU}  # the last: a component stopped by its CPU limit (tiny timeouts)
FD_MEMOUT = {20, 22}


def emit(record: dict) -> None:
    """Print one JSON line on stdout."""
    print(json.dumps(record), flush=True)


def progress(message: str) -> None:
    """Say what is going on, on stderr."""
    print(f"bench_planner: {message}", file=sys.stderr, flush=True)


def load_average() -> list[float] | None:
    """The 1, 5 and 15 minute load averages (other work on the machine disturbs the timings)."""
    try:
        return [round(load, 2) for load in os.getloadavg()]
    except OSError:
        return None


# -- the problems --------------------------------------------------------------


def natural_key(name: str) -> list:
    """Sort key that orders the numbers in a name by value: p2 < p10, BLOCKS-4-0 < BLOCKS-10-0."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


PDDL_HEADER = re.compile(r"\(\s*define\s*\(\s*(domain|problem)\b", re.IGNORECASE)


def pddl_kind(path: Path) -> str | None:
    """``"domain"`` or ``"problem"`` as the file's ``(define (...`` says; None when it does not say
    (unreadable, or not PDDL). Reads no more than the first 64 kB."""
    try:
        with open(path, encoding="utf-8", errors="replace") as file:
            head = file.read(65536)
    except OSError:
        return None
    text = re.sub(r";[^\n]*", "", head)  # a comment may mention (define (domain ...
    found = PDDL_HEADER.search(text)
    return found.group(1).lower() if found else None


def domain_file_for(problem: Path) -> Path | None:
    """The domain file of ``problem``: a per-problem one when the folder has it (the IPC layouts, named as
    Fast Downward's driver looks for them: ``p01-domain.pddl``, ``domain_p01.pddl``, ``domain-p01.pddl``;
    also ``p01_domain.pddl``, and ``p01-domain.pddl`` for ``p01-airport1-p1.pddl``), else ``domain.pddl``."""
    name, stem, folder = problem.name, problem.stem, problem.parent
    for candidate in (f"{stem}-domain.pddl", f"{stem}_domain.pddl", f"domain_{name}", f"domain-{name}",
                      f"domain_{stem}.pddl", f"domain-{stem}.pddl", f"{name[:3]}-domain.pddl"):
        if candidate != name and (folder / candidate).is_file():
            return folder / candidate
    shared = folder / "domain.pddl"
    return shared if shared.is_file() else None


def is_problem_file(path: Path) -> bool:
    """A ``.pddl`` file that defines a problem (by its contents; by its name when they do not say)."""
    if not path.is_file() or path.suffix.lower() != ".pddl":
        return False
    kind = pddl_kind(path)
    return kind == "problem" if kind else "domain" not in path.stem.lower()


def list_problems(folder: Path, count: int | None) -> list[tuple[Path, Path | None]]:
    """The first ``count`` (None: all) problems of ``folder`` in natural order, each with its domain file:
    one ``domain.pddl`` for all of them, or one domain file per problem as the IPC ships some domains."""
    problems = sorted((path for path in folder.iterdir() if is_problem_file(path)),
                      key=lambda path: natural_key(path.name))
    return [(problem, domain_file_for(problem)) for problem in problems[:count]]


def default_data_root() -> Path:
    """``REPO/../shared/data/pddl`` (the first ``shared/data/pddl`` beside the checkout or beside a folder
    above it, so a worktree nested deeper finds it too); that first path when none exists."""
    for folder in REPO.parents:
        candidate = folder / "shared" / "data" / "pddl"
        if candidate.is_dir():
            return candidate
    return REPO.parent / "shared" / "data" / "pddl"


def scratch_copy(domain: Path, problem: Path, scratch: Path) -> tuple[Path, Path]:
    """Copy the domain and problem into ``scratch`` (planners may write beside their inputs)."""
    scratch.mkdir(parents=True, exist_ok=True)
    domain_copy, problem_copy = scratch / "domain.pddl", scratch / problem.name
    if problem_copy.name == "domain.pddl":  # cannot happen with list_problems, but never overwrite
        problem_copy = scratch / "problem.pddl"
    shutil.copyfile(domain, domain_copy)
    shutil.copyfile(problem, problem_copy)
    return domain_copy, problem_copy


# -- what a run did ------------------------------------------------------------


@dataclass
class Run:
    """What one run did: exit code, CPU and wall seconds, output, whether it was killed.

    For a subprocess ``cpu_s`` is its user + system CPU (children included);
    for an in-process worker, the CPU seconds the worker measured itself.
    """

    exit_code: int | None
    cpu_s: float
    wall_s: float
    stdout: str
    stderr: str
    killed: bool
    max_rss_mb: float | None = None  # a subprocess's peak resident memory (its largest process, children included)


@dataclass
class Outcome:
    """One planner on one problem, before validation."""

    status: str  # solved / unsolvable / timeout / memout / error
    run: Run
    plan: Path | None = None  # the plan file to validate
    extra: dict = field(default_factory=dict)  # planner-specific figures for the JSON line


def tail(text: str) -> str:
    """The end of a planner's output, for a JSON line."""
    text = text.strip()
    return text if len(text) <= TAIL_CHARS else "..." + text[-TAIL_CHARS:]


def timed_out(run: Run, timeout_s: float) -> bool:
    """Whether a run went past its time: killed, or more CPU seconds than allowed."""
    return run.killed or run.cpu_s > timeout_s


def kill_later(pid: int, after_s: float, group: bool) -> tuple[threading.Timer, threading.Event]:
    """Start a timer that SIGKILLs ``pid`` (its process group when ``group``) after ``after_s`` wall seconds."""
    killed = threading.Event()

    def kill() -> None:
        killed.set()
        try:
            (os.killpg if group else os.kill)(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    timer = threading.Timer(after_s, kill)
    timer.start()
    return timer, killed


# -- in-process runs: a worker forked after the imports ---------------------------


def load_planners() -> tuple[SimpleNamespace, str]:
    """Import both Python planners once, here; forked workers inherit them. Returns them and, if
    pyperplan will not import, why (``planners.pyperplan`` is then None). Ours must import."""
    from atlas_rap.planner.pddl import load_pddl
    from atlas_rap.planner.plan_file import write_plan_file
    from atlas_rap.planner.solve import solve

    planners = SimpleNamespace(load_pddl=load_pddl, solve=solve, write_plan_file=write_plan_file, pyperplan=None)
    try:
        import pyperplan.planner as pyperplan_planner
    except Exception as exc:  # noqa: BLE001 - any failure to import means: no pyperplan
        return planners, f"{type(exc).__name__}: {exc}"
    planners.pyperplan = pyperplan_planner
    return planners, ""


def in_worker(work: Callable[[], dict], scratch: Path, kill_after_s: float) -> tuple[dict | None, Run, float]:
    """Run ``work`` in a forked child; returns what it sent back (None when it was killed or died),
    the run (CPU: the seconds the child measured, when it sent them) and the child's whole CPU."""
    read_fd, write_fd = os.pipe()
    start = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # the worker: never returns
        worker_main(work, read_fd, write_fd, scratch)
    os.close(write_fd)
    timer, killed = kill_later(pid, kill_after_s, group=False)
    try:
        with os.fdopen(read_fd, "rb") as pipe:
            data = pipe.read()  # until the worker exits or is killed
        _, status, usage = os.wait4(pid, 0)
    except BaseException:  # ^C or a harness bug: do not leave the worker behind
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise
    finally:
        timer.cancel()
    wall = time.perf_counter() - start
    worker_cpu = usage.ru_utime + usage.ru_stime
    try:
        result = json.loads(data) if data else None
    except ValueError:  # cut off mid-answer by the kill
        result = None
    out = (scratch / ".stdout").read_text(errors="replace")
    err = (scratch / ".stderr").read_text(errors="replace")
    cpu = result["cpu_s"] if result and result.get("cpu_s") is not None else worker_cpu
    run = Run(os.waitstatus_to_exitcode(status), cpu, wall, out, err, killed.is_set())
    return result, run, worker_cpu


def worker_main(work: Callable[[], dict], read_fd: int, write_fd: int, scratch: Path) -> None:
    """The forked worker: output to scratch files, the inherited heap out of the collector's way,
    ``work()`` run and its answer sent up the pipe as JSON. Ends with ``os._exit``."""
    code = 0
    try:
        os.close(read_fd)
        for fd, name in ((1, ".stdout"), (2, ".stderr")):  # keep stray prints out of our JSON lines
            target = os.open(scratch / name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(target, fd)
            os.close(target)
        gc.freeze()  # the benchmark's own objects: not the planner's to collect
        before = set(sys.modules)
        try:
            result = work()
        except BaseException as exc:  # noqa: BLE001 - whatever the planner raises is reported, ^C included
            result = {"status": "error", "why": f"{type(exc).__name__}: {exc}",
                      "traceback": tail(traceback.format_exc())}
        late = sorted(set(sys.modules) - before)
        if late:
            result["late_imports"] = late
        sys.stdout.flush()
        sys.stderr.flush()
        with os.fdopen(write_fd, "wb") as pipe:
            pipe.write(json.dumps(result).encode())
    except BaseException:  # noqa: BLE001 - the worker must reach os._exit whatever happens
        code = 70
    finally:
        os._exit(code)


def number(value) -> float | None:
    """A figure as a JSON float (the planner may hand back Fractions), None stays None."""
    return None if value is None else round(float(value), 4)


def grounding_seconds(timing: dict) -> float | None:
    """The planner's grounding seconds from its ``timing`` (``grounding_seconds``; ``ground_seconds``
    in older versions)."""
    return timing.get("grounding_seconds", timing.get("ground_seconds"))


def solve_ours(planners: SimpleNamespace, domain: Path, problem: Path, plan_path: Path, timeout_s: float) -> dict:
    """In the worker: read, solve (everything ``solve`` does) and write our plan, timed in CPU seconds."""
    started = time.process_time()
    task = planners.load_pddl(domain, problem)
    plan = planners.solve(task, timeout=timeout_s)
    solved = plan.status == "solved"
    if solved:
        planners.write_plan_file(plan_path, plan.sequence)
    cpu = time.process_time() - started
    return {"status": plan.status, "cpu_s": cpu, "length": len(plan.sequence) if solved else None,
            "parallel_length": plan.stats.get("parallel_length"),
            "makespan": number(plan.makespan) if solved else None, "risk": number(plan.risk),
            "risk_before_counterplanning": number(plan.risk_before_counterplanning),
            "counterplan_steps": len(plan.counterplan), "threats": len(plan.threats),
            "ground_s": grounding_seconds(plan.timing),
            "search_s": plan.timing.get("search_seconds"), "solve_s": plan.timing.get("seconds"),
            "reason": plan.reason or None}


def solve_pyperplan(planners: SimpleNamespace, domain: Path, problem: Path, plan_path: Path) -> dict:
    """In the worker: ``pyperplan.planner.search_plan``'s steps with gbf and hFF, then its plan
    file as its CLI writes it, timed in CPU seconds (each step too, when the steps are there)."""
    pp = planners.pyperplan
    search, heuristic_class = pp.SEARCHES["gbf"], pp.HEURISTICS["hff"]
    started = time.process_time()
    phases = {}
    if all(hasattr(pp, name) for name in ("_parse", "_ground", "_search")):  # pyperplan 2.1
        try:
            parsed = pp._parse(str(domain), str(problem))
        except Exception as exc:  # noqa: BLE001 - a PDDL feature it lacks (:action-costs, ...): no contest
            return {"status": UNSUPPORTED, "cpu_s": time.process_time() - started,
                    "why": f"pyperplan cannot read it: {type(exc).__name__}: {exc}"[:TAIL_CHARS]}
        phases["parse_s"] = time.process_time() - started
        task = pp._ground(parsed)
        grounded = time.process_time()
        phases["ground_s"] = grounded - started - phases["parse_s"]
        heuristic = heuristic_class(task)
        searching = time.process_time()  # pyperplan's "Search time" starts after building the heuristic
        phases["heuristic_s"] = searching - grounded
        solution = pp._search(task, search, heuristic)
        phases["search_s"] = time.process_time() - searching
    else:  # another version: the whole of it, without the steps
        solution = pp.search_plan(str(domain), str(problem), search, heuristic_class)
    if solution is not None:
        pp.write_solution(solution, str(plan_path))
    cpu = time.process_time() - started
    return {"status": "solved" if solution is not None else "unsolvable", "cpu_s": cpu,
            "length": len(solution) if solution is not None else None,
            **{key: round(value, 4) for key, value in phases.items()}}


def run_in_process(planner: str, planners: SimpleNamespace, domain: Path, problem: Path, scratch: Path,
                   timeout_s: float) -> Outcome:
    """One of the Python planners in a forked worker; its status, plan file and figures."""
    plan = scratch / f"{planner}.plan"
    if planner == OURS:
        work = functools.partial(solve_ours, planners, domain, problem, plan, timeout_s)
    else:
        work = functools.partial(solve_pyperplan, planners, domain, problem, plan)
    result, run, worker_cpu = in_worker(work, scratch, timeout_s + GRACE_S)
    if result is None:  # killed, or died without a word
        status = "timeout" if run.killed else "error"
        extra = {} if run.killed else {"exit_code": run.exit_code, "stderr": tail(run.stderr or run.stdout)}
        return Outcome(status, run, extra={**extra, "worker_cpu_s": round(worker_cpu, 3)})
    status = result.pop("status")
    result.pop("cpu_s", None)
    extra = {key: value for key, value in result.items() if value is not None}
    extra["worker_cpu_s"] = round(worker_cpu, 3)
    if status == "solved" and timed_out(run, timeout_s):
        status = "timeout"
    if status == "solved" and not plan.is_file():
        return Outcome("error", run, extra={**extra, "why": "said solved but wrote no plan file"})
    return Outcome(status, run, plan if status == "solved" else None, extra)


# -- subprocess runs -----------------------------------------------------------


def run_process(cmd: list[str], cwd: Path, kill_after_s: float) -> Run:
    """Run ``cmd`` in ``cwd`` as its own process group; kill the group after ``kill_after_s`` wall seconds.

    CPU time comes from ``os.wait4`` on the child, so it covers exactly this
    child and the grandchildren it waited for, even with several runs at once.
    The child inherits this process's ``PYTHONHASHSEED``.
    """
    out_path, err_path = cwd / ".stdout", cwd / ".stderr"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    with open(out_path, "wb") as out, open(err_path, "wb") as err:
        start = time.perf_counter()
        try:
            proc = subprocess.Popen(cmd, cwd=cwd, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                    env=env, start_new_session=True)
        except OSError as exc:
            return Run(None, 0.0, 0.0, "", f"could not start {cmd[0]}: {exc}", False)
        timer, killed = kill_later(proc.pid, kill_after_s, group=True)
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            timer.cancel()
        wall = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
    return Run(proc.returncode, usage.ru_utime + usage.ru_stime, wall,
               out_path.read_text(errors="replace"), err_path.read_text(errors="replace"), killed.is_set(),
               round(usage.ru_maxrss / 1024, 1))  # KiB on Linux


def run_ours_cli(domain: Path, problem: Path, scratch: Path, timeout_s: float) -> Outcome:
    """``python -m atlas_rap plan --pddl ... --json --timing``: status, plan file and figures from its JSON."""
    plan = scratch / "ours-cli.plan"
    cmd = [sys.executable, "-m", "atlas_rap", "plan", "--pddl", str(domain), str(problem),
           "--plan-file", str(plan), "--json", "--timing", "--timeout", f"{timeout_s:g}"]
    run = run_process(cmd, scratch, timeout_s + GRACE_S)
    if run.killed:
        return Outcome("timeout", run)
    try:
        answer = json.loads(run.stdout)
    except ValueError:
        answer = None
    if not isinstance(answer, dict):  # no JSON answer: it crashed
        return Outcome("error", run, extra={"exit_code": run.exit_code, "stderr": tail(run.stderr or run.stdout)})
    stats, timing = answer.get("stats") or {}, answer.get("timing") or {}
    extra = {"length_reported": stats.get("length"), "parallel_length": stats.get("parallel_length"),
             "makespan": answer.get("makespan"), "risk": answer.get("risk"),
             "counterplan_steps": len(answer.get("counterplan") or []),
             "ground_s": grounding_seconds(timing), "search_s": timing.get("search_seconds"),
             "solve_s": timing.get("seconds")}
    status = answer.get("status", "error")
    if status == "solved" and (run.exit_code != 0 or not plan.is_file()):
        extra.update(exit_code=run.exit_code, stderr=tail(run.stderr))
        return Outcome("error", run, extra={**extra, "why": "said solved but exit code or plan file is wrong"})
    if status == "solved" and timed_out(run, timeout_s):
        status = "timeout"
    if status not in ("solved", "unsolvable", "timeout"):
        extra.update(exit_code=run.exit_code, stderr=tail(run.stderr))
    return Outcome(status, run, plan if status == "solved" else None, extra)


def run_pyperplan_cli(domain: Path, problem: Path, scratch: Path, timeout_s: float) -> Outcome:
    """``pyperplan -s gbf -H hff``; solved when it wrote ``PROBLEM.soln`` (it exits 0 either way)."""
    cmd = [sys.executable, "-m", "pyperplan", "-s", "gbf", "-H", "hff", str(domain), str(problem)]
    run = run_process(cmd, scratch, timeout_s + GRACE_S)
    found = re.search(r"Search time: ([0-9.e+-]+)", run.stdout)
    extra = {"search_s": float(found.group(1)) if found else None}
    solution = Path(str(problem) + ".soln")
    if run.killed or (solution.is_file() and timed_out(run, timeout_s)):
        return Outcome("timeout", run, extra=extra)
    if run.exit_code == 0 and solution.is_file():
        return Outcome("solved", run, solution, extra)
    if run.exit_code == 0 and "No solution could be found" in run.stdout:
        return Outcome("unsolvable", run, extra=extra)
    return Outcome("error", run, extra={**extra, "exit_code": run.exit_code, "stderr": tail(run.stderr or run.stdout)})


def find_fast_downward() -> tuple[Path | None, str]:
    """The ``fast-downward.py`` driver bundled in the up-fast-downward wheel, or None and why not."""
    spec = importlib.util.find_spec("up_fast_downward")  # finding it does not import unified_planning
    if spec is None or not spec.submodule_search_locations:
        return None, "the up-fast-downward wheel is not installed (pip install up-fast-downward)"
    for location in spec.submodule_search_locations:
        driver = Path(location) / "downward" / "fast-downward.py"
        if driver.is_file():
            return driver, ""
    return None, "up-fast-downward has no downward/fast-downward.py"


def fd_plan_file(plan: Path) -> Path | None:
    """FD's plan: ``plan`` itself, or for anytime configurations the last of ``plan.1``, ``plan.2``, ..."""
    if plan.is_file():
        return plan
    numbered = sorted(plan.parent.glob(plan.name + ".*"), key=lambda path: natural_key(path.name))
    return numbered[-1] if numbered else None


def run_fd(driver: Path, domain: Path, problem: Path, scratch: Path, timeout_s: float) -> Outcome:
    """Fast Downward ``--alias lama-first``, run in ``scratch`` (its translator writes output.sas there)."""
    plan = scratch / "fd.plan"
    cmd = [sys.executable, str(driver), "--overall-time-limit", f"{math.ceil(timeout_s)}s",
           "--alias", "lama-first", "--plan-file", str(plan), str(domain), str(problem)]
    run = run_process(cmd, scratch, timeout_s + GRACE_S)
    searched = re.search(r"\] Search time: ([0-9.]+)s", run.stdout)
    search_total = re.search(r"\] Total time: ([0-9.]+)s", run.stdout)
    translated = re.search(r"^Done! \[([0-9.]+)s CPU", run.stdout, re.MULTILINE)
    extra = {"search_s": float(searched.group(1)) if searched else None,
             "search_total_s": float(search_total.group(1)) if search_total else None,
             "translate_s": float(translated.group(1)) if translated else None, "exit_code": run.exit_code}
    if extra["translate_s"] is not None and extra["search_total_s"] is not None:
        # FD's own CPU for the work (translate + search), start-up of its driver and components left out:
        # the figure our in-process cpu_s is set beside
        extra["solve_cpu_s"] = round(extra["translate_s"] + extra["search_total_s"], 4)
    found = fd_plan_file(plan)
    if run.killed or run.exit_code in FD_TIMEOUT or (found and timed_out(run, timeout_s)):
        return Outcome("timeout", run, extra=extra)
    if run.exit_code in FD_SOLVED and found:
        return Outcome("solved", run, found, extra)
    if run.exit_code in FD_UNSOLVABLE:
        return Outcome("unsolvable", run, extra=extra)
    if run.exit_code in FD_MEMOUT:
        return Outcome("memout", run, extra=extra)
    return Outcome("error", run, extra={**extra, "stderr": tail(run.stderr or run.stdout)})


# -- plans ---------------------------------------------------------------------


def plan_actions(path: Path) -> list[str]:
    """The actions of an IPC plan file, one ``(name arg ...)`` each: comments, blanks, case normalised."""
    actions = []
    for line in path.read_text(errors="replace").splitlines():
        line = line.split(";", 1)[0].strip().lower()
        if not line:
            continue
        if not line.startswith("("):
            line = f"({line})"
        actions.append(" ".join(line.split()))
    return actions


def normalised_plan(path: Path, scratch: Path, planner: str) -> Path:
    """A copy of another planner's plan file in the plain form the validator reads."""
    copy = scratch / f"{planner}.normalised.plan"
    copy.write_text("".join(action + "\n" for action in plan_actions(path)))
    return copy


def plan_digest(actions: list[str]) -> str:
    """A short fingerprint of a plan, to see whether two runs found the same one."""
    return hashlib.sha1("\n".join(actions).encode()).hexdigest()[:10]


_validate_lock = threading.Lock()


def load_validator():
    """atlas_rap's plan validator (``validate_plan_file`` in its three steps: read the task, read the plan,
    check it), or None and why not."""
    try:
        from atlas_rap.planner.pddl import load_pddl
        from atlas_rap.planner.plan_file import read_plan_file, validate_plan
    except Exception as exc:  # noqa: BLE001 - ImportError, or a module that does not import cleanly
        return None, f"{type(exc).__name__}: {exc}"
    return SimpleNamespace(read_task=load_pddl, read_plan=read_plan_file, check=validate_plan), ""


def first_line(exc: Exception) -> str:
    """An exception in one line, for a JSON field."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}"


def validate(validator, domain: Path, problem: Path, plan: Path,
             adversarial: bool = False) -> tuple[bool | None, str, float | None]:
    """(valid, message, cost) of a plan: ``cost`` is the validator's own sum of the plan's action costs
    (its length without :action-costs), None unless it is valid. ``valid`` is None when the plan cannot
    be checked: no validator, the
    validator cannot read the domain or problem (a PDDL feature it lacks: the peer's plan may well be
    right), or it crashed; False when the plan file is not IPC plan lines or the plan fails the check."""
    if validator is None:
        return None, "no validator", None
    with _validate_lock:  # the validator may keep caches; do not run it in two threads at once
        try:
            task = validator.read_task(str(domain), str(problem))
        except Exception as exc:  # noqa: BLE001 - whatever stops it reading the task: it cannot check
            return None, f"the validator cannot read the domain or problem: {first_line(exc)}", None
        try:
            actions = validator.read_plan(str(plan))
        except Exception as exc:  # noqa: BLE001 - a plan that is not IPC plan lines fails the check
            return False, f"the plan file does not read as plan lines: {first_line(exc)}", None
        try:
            check = validator.check(task, actions, adversarial)
        except Exception as exc:  # noqa: BLE001 - a crash in the validator says nothing about the plan
            return None, f"the validator raised {first_line(exc)}", None
    message = getattr(check, "message", "")
    failed = getattr(check, "failed_step", None)
    if failed is not None and not message.startswith(f"step {failed}"):
        message = f"step {failed}: {message}"
    return bool(check.ok), message, (getattr(check, "cost", None) if check.ok else None)


# -- one problem, one planner ----------------------------------------------------


@dataclass
class Job:
    """One planner on one problem."""

    domain_name: str
    problem: Path
    domain: Path | None
    planner: str


@dataclass
class Bench:
    """What every run needs: the options, the imported planners, FD's driver, the validator, a scratch root."""

    args: argparse.Namespace
    planners: SimpleNamespace
    driver: Path | None
    validator: object
    workdir: Path


def run_job(job: Job, bench: Bench, domain: Path, problem: Path, scratch: Path) -> Outcome:
    """Run the job's planner on the scratch copies."""
    timeout_s = bench.args.timeout
    if job.planner in IN_PROCESS:
        return run_in_process(job.planner, bench.planners, domain, problem, scratch, timeout_s)
    if job.planner == OURS_CLI:
        return run_ours_cli(domain, problem, scratch, timeout_s)
    if job.planner == PYPERPLAN_CLI:
        return run_pyperplan_cli(domain, problem, scratch, timeout_s)
    return run_fd(bench.driver, domain, problem, scratch, timeout_s)


def base_record(job: Job) -> dict:
    """The fields every ``planner`` line has, set for a run that did not happen (yet)."""
    in_process = job.planner in IN_PROCESS
    times = {"cpu_s": None, "wall_s": None} if in_process else {"cli_cpu_s": None, "cli_wall_s": None,
                                                                  "cli_max_rss_mb": None}
    return {"bench": "planner", "domain": job.domain_name, "problem": job.problem.stem, "planner": job.planner,
            "mode": "in-process" if in_process else "subprocess", "solved": False, "status": None,
            **times, "length": None, "valid": None}


def attempt(job: Job, bench: Bench, adversarial: bool = False) -> dict:
    """Run one planner on one problem and check its plan; never raises: a crash is an ``error`` line."""
    record = base_record(job)
    if job.domain is None:
        return {**record, "status": "error", "why": f"no domain file for {job.problem.name}"}
    scratch = Path(tempfile.mkdtemp(prefix=f"{job.planner}-{job.problem.stem}-", dir=bench.workdir))
    try:
        domain, problem = scratch_copy(job.domain, job.problem, scratch)
        outcome = run_job(job, bench, domain, problem, scratch)
        record.update(plan_record(job, outcome, domain, problem, scratch, bench, adversarial))
    except Exception as exc:  # noqa: BLE001 - the harness itself must not stop the run
        record.update(solved=False, status="error", why=f"harness: {type(exc).__name__}: {exc}", valid=None)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return record


def time_fields(job: Job, run: Run) -> dict:
    """``cpu_s``/``wall_s`` for an in-process run, ``cli_cpu_s``/``cli_wall_s`` for a subprocess."""
    if job.planner in IN_PROCESS:
        return {"cpu_s": round(run.cpu_s, 4), "wall_s": round(run.wall_s, 3)}
    return {"cli_cpu_s": round(run.cpu_s, 4), "cli_wall_s": round(run.wall_s, 3), "cli_max_rss_mb": run.max_rss_mb}


def plan_record(job: Job, outcome: Outcome, domain: Path, problem: Path, scratch: Path, bench: Bench,
                adversarial: bool = False) -> dict:
    """The JSON fields of one outcome: times, status, the plan's length and its validation."""
    fields = {"solved": False, "status": outcome.status, **time_fields(job, outcome.run),
              "length": None, "parallel_length": None, "valid": None}
    fields.update({key: value for key, value in outcome.extra.items() if key not in fields or value is not None})
    reported = fields.pop("length_reported", None)
    if outcome.plan is None:
        return fields
    ours = job.planner in (OURS, OURS_CLI)
    plan = outcome.plan if ours else normalised_plan(outcome.plan, scratch, job.planner)
    actions = plan_actions(plan)
    if fields.get("length") is not None and fields["length"] != len(actions):
        fields["length_reported"] = fields["length"]  # the planner and its plan file disagree: worth a look
    elif reported is not None and reported != len(actions):
        fields["length_reported"] = reported
    fields.update(length=len(actions), plan_digest=plan_digest(actions))
    valid, message, cost = validate(bench.validator, domain, problem, plan, adversarial)
    fields["valid"] = valid
    fields["cost"] = cost
    if valid is False:
        fields.update(status="invalid-plan", validation=message)
    elif valid is None:  # a plan, but nothing could check it: neither solved nor invalid
        fields.update(status="unchecked", unchecked_why=message)
    fields["solved"] = valid is True
    if bench.args.keep_plans is not None:
        target = bench.args.keep_plans / job.domain_name / f"{job.problem.stem}.{job.planner}.plan"
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(plan, target)
    return fields


def describe(record: dict) -> str:
    """A short progress note on a finished run."""
    seconds = record.get("cpu_s", record.get("cli_cpu_s"))
    shown = f" {seconds:.3f} s" if isinstance(seconds, (int, float)) else ""
    length = f", length {record['length']}" if record.get("length") is not None else ""
    where = f"{record.get('domain', TIREWORLD)} {record['problem']}"
    return f"{where}: {record['planner']} {record['status']}{shown}{length}"


# -- figures -------------------------------------------------------------------


def geometric_mean_ratio(pairs: list[tuple[float, float]]) -> float | None:
    """Geometric mean of a/b over the pairs (each floored at MIN_CPU_S); None when there are none."""
    if not pairs:
        return None
    logs = [math.log(max(a, MIN_CPU_S) / max(b, MIN_CPU_S)) for a, b in pairs]
    return round(math.exp(sum(logs) / len(logs)), 3)


def mean(values: list) -> float | None:
    """Arithmetic mean, None for no values."""
    values = [value for value in values if value is not None]
    return round(sum(values) / len(values), 2) if values else None


def common(by_planner: dict[str, dict], a: str, b: str) -> list:
    """Problems that both planners solved (with valid plans)."""
    if a not in by_planner or b not in by_planner:
        return []
    return [key for key, rec in by_planner[a].items() if rec["solved"] and by_planner[b].get(key, {}).get("solved")]


def paired(by_planner: dict[str, dict], a: str, key_a: str, b: str, key_b: str) -> list[tuple[float, float]]:
    """(a's key_a, b's key_b) on every problem both solved where both figures are known."""
    pairs = [(by_planner[a][key].get(key_a), by_planner[b][key].get(key_b)) for key in common(by_planner, a, b)]
    return [(x, y) for x, y in pairs if x is not None and y is not None]


def total(pairs: list[tuple[float, float]], index: int) -> float | None:
    """The sum of one side of the pairs."""
    return round(sum(pair[index] for pair in pairs), 3) if pairs else None


def count(by_planner: dict[str, dict], planner: str, test: Callable[[dict], bool]) -> int | None:
    """How many of a planner's records pass ``test``; None when the planner did not run."""
    if planner not in by_planner:
        return None
    return sum(bool(test(rec)) for rec in by_planner[planner].values())


def figures(by_planner: dict[str, dict], planners: list[str]) -> dict:
    """Coverage, time ratios and lengths from the records of each planner (keyed by problem). Every key is
    always there (``null`` for a planner that did not run, or nothing to compare), so the lines keep one
    shape whichever peers are installed."""
    ours, pp, fd = by_planner[OURS], by_planner.get(PYPERPLAN, {}), by_planner.get(FD, {})
    ran = set(planners)
    both_pp, both_fd = common(by_planner, OURS, PYPERPLAN), common(by_planner, OURS, FD)
    cpu_pp = paired(by_planner, OURS, "cpu_s", PYPERPLAN, "cpu_s")
    cpu_fd = paired(by_planner, OURS, "cpu_s", FD, "solve_cpu_s")
    cli = common(by_planner, OURS, OURS_CLI)
    return {
        **{f"coverage_{planner}": count(by_planner, planner, lambda rec: rec["solved"]) for planner in ALL_PLANNERS},
        **{f"unchecked_{planner}": count(by_planner, planner, lambda rec: rec["status"] == "unchecked")
           for planner in ALL_PLANNERS},
        # against pyperplan in process: the CPU of the solve in a forked worker
        "commonly_solved_vs_pyperplan": len(both_pp) if PYPERPLAN in ran else None,
        "time_ratio_vs_pyperplan": geometric_mean_ratio(cpu_pp),
        "search_time_ratio_vs_pyperplan": geometric_mean_ratio(paired(by_planner, OURS, "search_s",
                                                                      PYPERPLAN, "search_s")),
        "total_cpu_s_ours": total(cpu_pp, 0), "total_cpu_s_pyperplan": total(cpu_pp, 1),
        "mean_length_ours": mean([ours[key]["length"] for key in both_pp]),
        "mean_length_pyperplan": mean([pp[key]["length"] for key in both_pp]),
        "mean_parallel_length_ours": mean([ours[key].get("parallel_length") for key in both_pp]),
        "mean_parallel_length_ours_all": mean([rec.get("parallel_length") for rec in ours.values() if rec["solved"]]),
        # against pyperplan as whole processes (interpreter start included): our CLI beside its CLI
        "commonly_solved_cli_vs_pyperplan": (len(common(by_planner, OURS_CLI, PYPERPLAN_CLI))
                                             if {OURS_CLI, PYPERPLAN_CLI} <= ran else None),
        "cli_time_ratio_vs_pyperplan": geometric_mean_ratio(
            paired(by_planner, OURS_CLI, "cli_cpu_s", PYPERPLAN_CLI, "cli_cpu_s")),
        "cli_wall_ratio_vs_pyperplan": geometric_mean_ratio(
            paired(by_planner, OURS_CLI, "cli_wall_s", PYPERPLAN_CLI, "cli_wall_s")),
        # against Fast Downward: in process (our cpu_s beside its own translate + search CPU), search alone,
        # and whole processes (our CLI beside its driver's whole run)
        "commonly_solved_vs_fd": len(both_fd) if FD in ran else None,
        "time_ratio_vs_fd": geometric_mean_ratio(cpu_fd),
        "search_time_ratio_vs_fd": geometric_mean_ratio(paired(by_planner, OURS, "search_s", FD, "search_s")),
        "total_cpu_s_ours_vs_fd": total(cpu_fd, 0), "total_solve_cpu_s_fd": total(cpu_fd, 1),
        "cli_time_ratio_vs_fd": geometric_mean_ratio(paired(by_planner, OURS_CLI, "cli_cpu_s", FD, "cli_cpu_s")),
        "cli_wall_ratio_vs_fd": geometric_mean_ratio(paired(by_planner, OURS_CLI, "cli_wall_s", FD, "cli_wall_s")),
        "mean_length_ours_vs_fd": mean([ours[key]["length"] for key in both_fd]),
        "mean_length_fd": mean([fd[key]["length"] for key in both_fd]),
        "mean_cost_ours_vs_fd": mean([ours[key].get("cost") for key in both_fd]),
        "mean_cost_fd": mean([fd[key].get("cost") for key in both_fd]),
        # what start-up costs us: our CLI beside our in-process run
        "cli_over_in_process_ours": geometric_mean_ratio(paired(by_planner, OURS_CLI, "cli_cpu_s", OURS, "cpu_s")),
        "ours_cli_same_plan": (sum(ours[key].get("plan_digest") == by_planner[OURS_CLI][key].get("plan_digest")
                                   for key in cli) if OURS_CLI in ran else None),
        "ours_cli_compared": len(cli) if OURS_CLI in ran else None,
    }


def all_of(verdicts: list[bool | None]) -> bool | None:
    """False when any verdict is False, None when every one is None (nothing compared), else True."""
    if any(verdict is False for verdict in verdicts):
        return False
    return None if all(verdict is None for verdict in verdicts) else True


TARGET_VS_PYPERPLAN = 0.25  # our CPU over pyperplan's, in process, at most
TARGET_VS_FD = 1.5  # our whole-process CPU over Fast Downward's, geometric mean over all domains, at most ...
TARGET_VS_FD_DOMAIN = 2.0  # ... and in each domain


def targets(result: dict, fd_time_target: float = TARGET_VS_FD_DOMAIN) -> dict:
    """The targets on a set of figures (None where the peer did not run or nothing was solved by both):
    against pyperplan coverage, CPU in process (TARGET_VS_PYPERPLAN) and mean length; against Fast
    Downward lama-first coverage, whole-process CPU (``fd_time_target``) and mean length."""
    ratio, length_ours = result["time_ratio_vs_pyperplan"], result["mean_length_ours"]
    coverage_pp, coverage_fd = result[f"coverage_{PYPERPLAN}"], result[f"coverage_{FD}"]
    cli_fd, length_vs_fd = result["cli_time_ratio_vs_fd"], result["mean_length_ours_vs_fd"]
    return {"coverage_ok": None if coverage_pp is None else result[f"coverage_{OURS}"] >= coverage_pp,
            "time_ok": None if ratio is None else ratio <= TARGET_VS_PYPERPLAN,
            "length_ok": None if length_ours is None else length_ours <= result["mean_length_pyperplan"],
            "coverage_ok_vs_fd": None if coverage_fd is None else result[f"coverage_{OURS}"] >= coverage_fd,
            "time_ok_vs_fd": None if cli_fd is None else cli_fd <= fd_time_target,
            "length_ok_vs_fd": None if length_vs_fd is None else length_vs_fd <= result["mean_length_fd"]}


TARGET_NAMES = ("coverage_ok", "time_ok", "length_ok", "coverage_ok_vs_fd", "time_ok_vs_fd", "length_ok_vs_fd")
PER_DOMAIN_TARGETS = ("coverage_ok", "coverage_ok_vs_fd", "time_ok_vs_fd")  # the rest hold over all domains


def by_planner_of(records: list[dict], planners: list[str], key: Callable[[dict], object]) -> dict[str, dict]:
    """The records grouped by planner, each keyed by ``key(record)``."""
    grouped: dict[str, dict] = {planner: {} for planner in planners}
    for rec in records:
        grouped[rec["planner"]][key(rec)] = rec
    return grouped


def domain_summary(domain_name: str, folder: Path, records: list[dict], planners: list[str], problems: int) -> dict:
    """The per-domain line: coverage, time ratios and lengths on commonly solved problems, the targets."""
    result = figures(by_planner_of(records, planners, lambda rec: rec["problem"]), planners)
    return {"bench": "planner-domain", "domain": domain_name, "folder": str(folder), "problems": problems,
            **result, **targets(result), **peak_memory(records)}


def peak_memory(records: list[dict]) -> dict:
    """The largest peak resident memory (MiB) of our CLI and of Fast Downward over the problems each solved."""
    def largest(planner: str) -> float | None:
        peaks = [r["cli_max_rss_mb"] for r in records if r["planner"] == planner and r.get("solved")
                 and r.get("cli_max_rss_mb") is not None]
        return max(peaks, default=None)

    return {"max_rss_mb_ours_cli": largest(OURS_CLI), "max_rss_mb_fd": largest(FD)}


def overall_summary(records: list[dict], summaries: list[dict], planners: list[str]) -> dict:
    """The overall line: the figures over every problem, and whether every target was met."""
    result = figures(by_planner_of(records, planners, lambda rec: (rec["domain"], rec["problem"])), planners)
    overall = targets(result, TARGET_VS_FD)
    failed = [f"{s['domain']}:{target}" for s in summaries for target in PER_DOMAIN_TARGETS if s[target] is False]
    failed += [f"overall:{target}" for target in TARGET_NAMES if overall[target] is False]
    verdicts = {target: all_of([overall[target], *(s[target] for s in summaries if target in PER_DOMAIN_TARGETS)])
                for target in TARGET_NAMES}
    return {"bench": "planner-overall", "problems": sum(s["problems"] for s in summaries),
            "domains": [s["domain"] for s in summaries], **result,
            "target_time_ratio": TARGET_VS_PYPERPLAN, "target_cli_time_ratio_vs_fd": TARGET_VS_FD,
            "target_cli_time_ratio_vs_fd_per_domain": TARGET_VS_FD_DOMAIN, **verdicts, **peak_memory(records),
            "targets_met": not failed and any(verdict is not None for verdict in verdicts.values()),
            "targets_failed": failed, "load_average": load_average()}


# -- the runs ------------------------------------------------------------------


def run_problem(domain_name: str, problem: Path, domain: Path | None, planners: list[str], bench: Bench) -> list[dict]:
    """Every planner on one problem, one after the other; each line noted on stderr as it comes. Pyperplan's
    CLI is not run where pyperplan in process timed out or could not read the domain: it would too, start-up
    on top (a line with the same status)."""
    records = []
    for planner in planners:
        job = Job(domain_name, problem, domain, planner)
        in_process = next((rec for rec in records if rec["planner"] == PYPERPLAN), None)
        if planner == PYPERPLAN_CLI and in_process is not None and in_process["status"] in ("timeout", UNSUPPORTED):
            record = {**base_record(job), "status": in_process["status"],
                      "skipped": f"pyperplan in process: {in_process['status']}"}
        else:
            record = attempt(job, bench)
        progress(describe(record))
        records.append(record)
    return records


def run_all(problems: list[tuple[str, Path, Path | None]], planners: list[str], bench: Bench) -> list[dict]:
    """Every planner on every problem, in order (problems side by side with --jobs N, each problem's
    planners one after the other); lines printed in order as they come."""
    records = []
    one = lambda item: run_problem(*item, planners, bench)  # noqa: E731
    with ThreadPoolExecutor(max_workers=bench.args.jobs) if bench.args.jobs > 1 else nullcontext() as pool:
        for batch in (pool.map(one, problems) if pool else map(one, problems)):  # in order, whatever finishes first
            for record in batch:
                emit(record)
                records.append(record)
    return records


def domain_folders(args: argparse.Namespace) -> list[tuple[str, Path]]:
    """(name, folder) of every domain to run: ``--domains`` in the data root, then each ``--data`` folder
    (named by its folder; by its parent too when that name is taken), each folder once."""
    folders = [(name, args.data_root / name) for name in args.domains]
    seen = {folder.resolve() for _, folder in folders}
    for folder in args.data:
        if folder.resolve() in seen:
            continue
        names = {name for name, _ in folders}
        name = folder.name if folder.name not in names else f"{folder.parent.name}/{folder.name}"
        folders.append((name, folder))
        seen.add(folder.resolve())
    return folders


def bench_domains(bench: Bench, planners: list[str]) -> None:
    """Every planner on the first problems of every domain; per-problem, per-domain and overall lines."""
    all_records, summaries = [], []
    for domain_name, folder in domain_folders(bench.args):
        if not folder.is_dir():
            emit({"bench": "planner-domain", "domain": domain_name, "skipped": f"no {folder}"})
            continue
        problems = list_problems(folder, bench.args.problems)
        if not problems:
            emit({"bench": "planner-domain", "domain": domain_name, "skipped": f"no problem files in {folder}"})
            continue
        records = run_all([(domain_name, problem, domain) for problem, domain in problems], planners, bench)
        summary = domain_summary(domain_name, folder, records, planners, len(problems))
        emit(summary)
        all_records += records
        summaries.append(summary)
    if summaries:
        emit(overall_summary(all_records, summaries, planners))


def tireworld(bench: Bench) -> None:
    """Counterplanning on fond-triangle-tireworld, ours in-process: a problem passes when it is solved
    with risk 0 and no flat tire can defeat the plan (adversarial validation)."""
    fond_domain(bench, TIREWORLD, "planner-tireworld", adversarial=True,
                passes=lambda record: record.get("risk") == 0)


def fond_blocksworld(bench: Bench) -> None:
    """Counterplanning on fond-blocksworld, ours in-process: there any stacking may drop the block, so
    a sequential plan is rarely safe; a problem passes when it is solved with a valid plan and either
    risk 0 or the threats that make up its risk named (``threats`` > 0): never an unexplained risk.
    Its summary counts the plans with threats named (``with_threats_named``)."""
    fond_domain(bench, FOND_BLOCKSWORLD, "planner-fond-blocksworld", adversarial=False,
                passes=lambda record: record.get("risk") == 0 or (record.get("threats") or 0) > 0,
                counted={"with_threats_named": lambda record: bool(record.get("risk"))})


def fond_domain(bench: Bench, name: str, line: str, *, adversarial: bool, passes: Callable[[dict], bool],
                counted: dict[str, Callable[[dict], bool]] | None = None) -> None:
    """Ours on the first problems of the FOND domain ``name``, in-process: a line ``line`` per problem,
    passed when it is solved, its plan valid (under every bad outcome with ``adversarial``) and
    ``passes(record)``; then ``LINE-summary``, with the count of each of ``counted``."""
    folder = bench.args.data_root / name
    if not folder.is_dir():
        emit({"bench": f"{line}-summary", "skipped": f"no {folder}"})
        return
    records = []
    for problem, domain in list_problems(folder, bench.args.tireworld_problems):
        record = attempt(Job(name, problem, domain, OURS), bench, adversarial=adversarial)
        record.update(bench=line, passed=bool(
            record.get("status") == "solved" and record.get("valid") is True and passes(record)))
        progress(describe(record) + (" (passed)" if record["passed"] else " (FAILED)"))
        emit(record)
        records.append(record)
    passed = [record["passed"] for record in records]
    emit({"bench": f"{line}-summary", "problems": len(passed), "passed": sum(passed),
          **{key: sum(map(count, records)) for key, count in (counted or {}).items()},
          "ok": bool(passed) and all(passed) and bench.validator is not None})


# -- main ----------------------------------------------------------------------


def version_of(dist: str) -> str | None:
    """Installed version of a distribution, None when it is not installed."""
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def fd_usable(driver: Path, workdir: Path) -> str:
    """'' when the Fast Downward driver starts (``--version``), else why not."""
    scratch = Path(tempfile.mkdtemp(prefix="fd-check-", dir=workdir))
    run = run_process([sys.executable, str(driver), "--version"], scratch, 60)
    return "" if run.exit_code == 0 else f"fast-downward.py --version exited {run.exit_code}: {tail(run.stderr)}"


INSTALL_PEERS = "pip install '.[bench]' (or: pip install pyperplan up-fast-downward)"


def setup(args, workdir: Path) -> tuple[Bench, list[str]]:
    """Import the planners, decide which run, find the validator; print the setup line(s). A peer that is
    not installed (or does not run) is said in a line of its own, and the benchmark goes on without it."""
    planners_loaded, pyperplan_missing = load_planners()
    planners = [OURS]
    if args.no_pyperplan:
        pyperplan_missing = "--no-pyperplan"
    elif pyperplan_missing:
        emit({"bench": "planner-pyperplan-unavailable", "peer": PYPERPLAN, "planners": [PYPERPLAN, PYPERPLAN_CLI],
              "why": pyperplan_missing, "install": INSTALL_PEERS})
    else:
        planners.append(PYPERPLAN)
    if not args.no_cli:
        planners.append(OURS_CLI)
    if args.cli_pyperplan and not pyperplan_missing:
        planners.append(PYPERPLAN_CLI)
    driver = None
    if not args.no_fd:
        driver, why = find_fast_downward()
        why = why or fd_usable(driver, workdir)
        if why:
            emit({"bench": "planner-fd-unavailable", "peer": FD, "planners": [FD], "why": why,
                  "install": INSTALL_PEERS})
            driver = None
        else:
            planners.append(FD)
    validator, why = load_validator()
    bytecode = compile_bytecode() if OURS_CLI in planners else None
    emit({"bench": "planner-setup", "quick": args.quick, "data": str(args.data_root),
          "extra_data": [str(folder) for folder in args.data],
          "domains": [name for name, _ in domain_folders(args)], "problems": args.problems,
          "timeout_s": args.timeout, "jobs": args.jobs, "hash_seed": args.hash_seed,
          "PYTHONHASHSEED": os.environ.get("PYTHONHASHSEED"), "planners": planners,
          "in_process": [p for p in planners if p in IN_PROCESS],
          "subprocess": [p for p in planners if p not in IN_PROCESS],
          "pyperplan": version_of("pyperplan"), "up_fast_downward": version_of("up-fast-downward"),
          "fd_driver": str(driver) if driver else None, "python": sys.version.split()[0],
          "cpus": os.cpu_count(), "load_average": load_average(), "ours_bytecode": bytecode,
          "validator": "atlas_rap.planner.plan_file.validate_plan_file" if validator else None,
          **({"validator_missing": why, "note": "no plan is checked in this run: all are unchecked"}
             if validator is None else {})})
    return Bench(args, planners_loaded, driver, validator, workdir), planners


def compile_bytecode(package: str = "atlas_rap") -> str:
    """Compile ``package``'s modules to bytecode (``__pycache__``) as ``pip install`` does, so that its
    CLI runs start as an installed package's do. An editable install under ``PYTHONDONTWRITEBYTECODE``
    (set on some machines) never caches bytecode, and each CLI run would compile every module it imports
    again: 0.1 s of CPU a run, where Fast Downward's translator, installed by pip, starts compiled.
    Returns "compiled", or why not (the bench goes on)."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return f"{package} is not an importable package"
    folder = next(iter(spec.submodule_search_locations))
    try:
        compiled = compileall.compile_dir(folder, quiet=1)
    except OSError as exc:
        return f"could not write its bytecode: {exc}"
    return "compiled" if compiled else f"some of {folder} did not compile"


def ensure_hash_seed(seed: str) -> None:
    """Re-execute this script once with ``PYTHONHASHSEED=seed`` unless it already runs with it, so the
    forked workers (which cannot change their own) and the subprocesses all inherit it."""
    if os.environ.get("PYTHONHASHSEED") == seed:
        return
    os.environ["PYTHONHASHSEED"] = seed
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, *sys.orig_argv[1:]])


QUICK = {"problems": 2, "timeout": 10.0, "tireworld_problems": 2}  # --quick: about 20 s on 2 cores
FULL = {"problems": 20, "timeout": 60.0, "tireworld_problems": 10}


def parse_args() -> argparse.Namespace:
    """The command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-root", type=Path, default=None,
                        help="the folder of domain folders (default REPO/../shared/data/pddl)")
    parser.add_argument("--data", type=Path, action="append", default=[], metavar="DIR",
                        help="also run the problems of DIR: domain.pddl and problem files, or one domain file "
                             "per problem as the IPC ships some domains (repeatable)")
    parser.add_argument("--domains", nargs="*", default=DOMAINS,
                        help="domain folders in the data root (default: the thirteen classical IPC domains; none: "
                             "only --data and the tireworld)")
    parser.add_argument("--quick", action="store_true",
                        help=f"a check that runs in under a minute: the first {QUICK['problems']} problems of each "
                             f"domain, timeout {QUICK['timeout']:g} s, tireworld p1-p{QUICK['tireworld_problems']}")
    parser.add_argument("--problems", type=int, default=None,
                        help=f"first N problems of each domain (default {FULL['problems']}; --quick "
                             f"{QUICK['problems']})")
    parser.add_argument("--timeout", type=float, default=None,
                        help=f"CPU seconds per planner per problem (default {FULL['timeout']:g}; --quick "
                             f"{QUICK['timeout']:g})")
    parser.add_argument("--no-fd", action="store_true", help="do not run Fast Downward")
    parser.add_argument("--no-pyperplan", action="store_true",
                        help="do not run pyperplan (in process nor its CLI): on p11-p20 it mostly times out")
    parser.add_argument("--no-cli", action="store_true", help="do not run our CLI as a subprocess")
    parser.add_argument("--cli-pyperplan", action=argparse.BooleanOptionalAction, default=True,
                        help="also run pyperplan's CLI as a subprocess (default on; not where pyperplan in "
                             "process timed out)")
    parser.add_argument("--tireworld", action=argparse.BooleanOptionalAction, default=True,
                        help="counterplanning on the FOND domains, fond-triangle-tireworld and fond-blocksworld "
                             "(default on)")
    parser.add_argument("--tireworld-problems", type=int, default=None,
                        help=f"p1..pN of each FOND domain (default {FULL['tireworld_problems']}; --quick "
                             f"{QUICK['tireworld_problems']})")
    parser.add_argument("--jobs", type=int, default=1, help="problems at once (default 1; more disturbs the timings)")
    parser.add_argument("--keep-plans", type=Path, help="copy every plan into DIR/DOMAIN/PROBLEM.PLANNER.plan")
    parser.add_argument("--hash-seed", default="0",
                        help="PYTHONHASHSEED of every run (default 0, for repeatable plans; 'random': none)")
    args = parser.parse_args()
    if args.hash_seed != "random" and not (args.hash_seed.isdigit() and int(args.hash_seed) <= 4294967295):
        parser.error("--hash-seed takes an integer in [0, 4294967295] or 'random'")
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    args.data_root = (args.data_root or default_data_root()).resolve()
    args.data = [folder.resolve() for folder in args.data]
    for folder in args.data:
        if not folder.is_dir():
            parser.error(f"--data {folder}: no such folder")
        if not list_problems(folder, 1):
            parser.error(f"--data {folder}: no problem files in it (a folder of domain folders is --data-root)")
    if not args.data_root.is_dir():
        if not args.data:
            parser.exit(1, f"bench_planner: no data folder {args.data_root} (see --data-root, --data)\n")
        progress(f"no data folder {args.data_root}: only the --data folders run")
        args.domains, args.tireworld = [], False
    return args


def main() -> None:
    """Parse the options, fix the hash seed, import the planners, run the classical comparison, then the tireworld."""
    args = parse_args()
    ensure_hash_seed(args.hash_seed)
    with tempfile.TemporaryDirectory(prefix="bench-planner-") as tmp:
        bench, planners = setup(args, Path(tmp))
        bench_domains(bench, planners)
        if args.tireworld:
            tireworld(bench)
            fond_blocksworld(bench)


if __name__ == "__main__":
    main()
