"""Benchmark the AP planner on classical PDDL beside pyperplan and Fast Downward.

For each classical domain in ``../shared/data/pddl`` (gripper, blocks,
logistics00, rovers, depot) the first ten problems (natural order:
probBLOCKS-4-0 before probBLOCKS-10-0, p01 before p10) are solved, one after
the other in this one run. Nothing is ever written into the data folder:
every run gets a scratch copy of its domain and problem.

The primary figure is measured in this process (start-up excluded)
------------------------------------------------------------------
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

Secondary figures: whole runs as subprocesses (start-up included)
-----------------------------------------------------------------
- ``ours-cli``: ``python -m atlas_rap plan --pddl DOMAIN PROBLEM
  --plan-file F --json --timing --timeout S``; ``cli_cpu_s`` is its user +
  system CPU from ``os.wait4``; ``ground_s``/``search_s`` come from the
  JSON's ``timing`` (``stats`` holds counts only). Its plan file is
  validated too ("ours by --plan-file"), and ``plan_digest`` shows whether
  it is the plan of the in-process run. ``--no-cli`` skips these runs.
- ``fd-lama-first``: Fast Downward ``--alias lama-first``, the driver bundled
  in the ``up-fast-downward`` wheel (C++: it only runs as a subprocess).
  ``cli_cpu_s`` is the driver's whole run (its translator and search
  processes included), ``search_s`` its logged "Search time" (CPU, 4 ms
  ticks), ``search_total_s`` its whole search component, ``translate_s``
  its translator. Skipped, saying so in one JSON line, when the wheel is
  missing or does not run; ``--no-fd`` skips it outright.
- ``pyperplan-cli`` (only with ``--cli-pyperplan``, off by default: the
  depot timeouts would double): ``python -m pyperplan -s gbf -H hff``.

Subprocesses are killed, with their process group, after S + 5 wall
seconds, and more than S CPU seconds counts as a timeout. Every JSON field
named ``cpu_s`` is an in-process figure, every ``cli_cpu_s`` a whole
subprocess run.

Every plan is checked with ``atlas_rap.planner.plan_file.validate_plan_file``
(ours as written; the others after light normalisation: comments and blank
lines dropped, lower case, one ``(action arg ...)`` a line); a plan that
fails the check counts as not solved and says why.

Output: one JSON object a line (progress goes to stderr)
--------------------------------------------------------
- ``planner-setup``: what ran (versions, paths, hash seed, load average);
  ``planner-fd-unavailable`` when Fast Downward cannot run.
- ``planner``: one line per problem per planner: ``mode`` (``in-process``
  or ``subprocess``), ``solved`` (in time and valid), ``status``, ``cpu_s``
  and ``wall_s`` (in-process) or ``cli_cpu_s`` and ``cli_wall_s``
  (subprocess), ``length``, ``parallel_length``, ``makespan`` and ``risk``
  (ours), ``ground_s``/``search_s``, ``valid``, ``plan_digest``, and
  ``late_imports`` should a worker import a module while being timed.
- ``planner-domain``: per domain, each planner's coverage; over the problems
  both we and pyperplan solved, the geometric mean of our in-process CPU
  time over pyperplan's (``time_ratio_vs_pyperplan``), the same for the
  search times alone, the total CPU of each, the mean plan length of each,
  our mean parallel length; ``cli_over_in_process_ours`` (our CLI's CPU over
  our in-process CPU: what start-up costs us), ``ours_cli_same_plan``;
  against Fast Downward ``cli_time_ratio_vs_fd`` (our CLI run over its whole
  run) and ``search_time_ratio_vs_fd`` (search times); and the targets
  ``coverage_ok`` (ours >= pyperplan's), ``time_ok`` (ratio <= 1.0) and
  ``length_ok`` (our mean length <= pyperplan's) (``null`` when there is
  nothing to compare).
- ``planner-overall``: the same figures over every problem, and whether
  every target was met.
- ``planner-tireworld`` (unless ``--no-tireworld``): counterplanning on
  fond-triangle-tireworld p1-p10, ours only, in-process as above: a problem
  passes when it is solved with ``risk == 0`` and ``validate_plan_file(...,
  adversarial=True)`` accepts the plan (no flat tire can defeat it); then
  ``planner-tireworld-summary``.

Run
---
``pip install . pyperplan up-fast-downward && python
benchmarks/bench_planner.py > bench.jsonl`` (half an hour or more: pyperplan
times out on depot; to try it out: ``--domains gripper blocks --problems 3
--timeout 20``). Options: ``--data DIR``, ``--domains ...`` (none: the
tireworld only), ``--problems N``, ``--timeout S``, ``--no-fd``,
``--no-cli``, ``--cli-pyperplan``, ``--no-tireworld``,
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

DATA = REPO.parent / "shared" / "data" / "pddl"
DOMAINS = ["gripper", "blocks", "logistics00", "rovers", "depot"]
TIREWORLD = "fond-triangle-tireworld"
GRACE_S = 5.0  # wall seconds past the timeout before a planner is killed
MIN_CPU_S = 1e-3  # floor for time ratios (a zero would break the geometric mean)
TAIL_CHARS = 800  # how much of a failing planner's stderr goes into its JSON line

OURS, PYPERPLAN = "ours", "pyperplan"  # in-process, in a forked worker
OURS_CLI, PYPERPLAN_CLI, FD = "ours-cli", "pyperplan-cli", "fd-lama-first"  # subprocesses
IN_PROCESS = {OURS, PYPERPLAN}

# Fast Downward's exit codes (https://www.fast-downward.org/ExitCodes).
FD_SOLVED = {0, 1, 2, 3}  # a plan was found (perhaps running out of time/memory afterwards)
FD_UNSOLVABLE = {10, 11, 12}
FD_TIMEOUT = {21, 23, 24}
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


def domain_file_for(problem: Path) -> Path | None:
    """The domain file of ``problem``: a per-problem one when the folder has it, else ``domain.pddl``."""
    stem, folder = problem.stem, problem.parent
    for name in (f"domain_{stem}.pddl", f"domain-{stem}.pddl", f"{stem}-domain.pddl", f"{stem}_domain.pddl"):
        if (folder / name).is_file():
            return folder / name
    shared = folder / "domain.pddl"
    return shared if shared.is_file() else None


def list_problems(folder: Path, count: int) -> list[tuple[Path, Path | None]]:
    """The first ``count`` problems of ``folder`` in natural order, each with its domain file."""
    problems = [path for path in folder.glob("*.pddl") if "domain" not in path.stem.lower()]
    problems.sort(key=lambda path: natural_key(path.name))
    return [(problem, domain_file_for(problem)) for problem in problems[:count]]


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
            "counterplan_steps": len(plan.counterplan), "ground_s": plan.timing.get("ground_seconds"),
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
        parsed = pp._parse(str(domain), str(problem))
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
               out_path.read_text(errors="replace"), err_path.read_text(errors="replace"), killed.is_set())


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
             "ground_s": timing.get("ground_seconds"), "search_s": timing.get("search_seconds"),
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
    """``validate_plan_file`` from atlas_rap, or None and why not."""
    try:
        from atlas_rap.planner.plan_file import validate_plan_file
    except Exception as exc:  # noqa: BLE001 - ImportError, or a module that does not import cleanly
        return None, f"{type(exc).__name__}: {exc}"
    return validate_plan_file, ""


def validate(validator, domain: Path, problem: Path, plan: Path, adversarial: bool = False) -> tuple[bool | None, str]:
    """(valid, message) of a plan; (None, why) when there is no validator; a crash is a failed check."""
    if validator is None:
        return None, "no validator"
    try:
        with _validate_lock:  # the validator may keep caches; do not run it in two threads at once
            check = validator(str(domain), str(problem), str(plan), adversarial=adversarial)
    except Exception as exc:  # noqa: BLE001 - a crashing validator is a failed check
        return False, f"validator raised {type(exc).__name__}: {exc}"
    failed = getattr(check, "failed_step", None)
    message = getattr(check, "message", "")
    if failed is not None:
        message = f"step {failed}: {message}"
    return bool(check.ok), message


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


def attempt(job: Job, bench: Bench, adversarial: bool = False) -> dict:
    """Run one planner on one problem and check its plan; never raises: a crash is an ``error`` line."""
    record = {"bench": "planner", "domain": job.domain_name, "problem": job.problem.stem, "planner": job.planner,
              "mode": "in-process" if job.planner in IN_PROCESS else "subprocess"}
    if job.domain is None:
        return {**record, "solved": False, "status": "error", "why": "no domain file", "valid": None}
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
    prefix = "" if job.planner in IN_PROCESS else "cli_"
    return {f"{prefix}cpu_s": round(run.cpu_s, 4), f"{prefix}wall_s": round(run.wall_s, 3)}


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
    valid, message = validate(bench.validator, domain, problem, plan, adversarial)
    fields["valid"] = valid
    if valid is False:
        fields.update(status="invalid-plan", validation=message)
    fields["solved"] = valid is not False  # unchecked plans count when there is no validator (said in the setup line)
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


def figures(by_planner: dict[str, dict], planners: list[str]) -> dict:
    """Coverage, time ratios and lengths from the records of each planner (keyed by problem)."""
    ours, pp = by_planner[OURS], by_planner.get(PYPERPLAN, {})
    both_pp = common(by_planner, OURS, PYPERPLAN)
    cpu_pp = paired(by_planner, OURS, "cpu_s", PYPERPLAN, "cpu_s")
    result = {
        **{f"coverage_{planner}": sum(rec["solved"] for rec in by_planner[planner].values()) for planner in planners},
        "commonly_solved_vs_pyperplan": len(both_pp),
        "time_ratio_vs_pyperplan": geometric_mean_ratio(cpu_pp),
        "search_time_ratio_vs_pyperplan": geometric_mean_ratio(paired(by_planner, OURS, "search_s",
                                                                      PYPERPLAN, "search_s")),
        "total_cpu_s_ours": total(cpu_pp, 0), "total_cpu_s_pyperplan": total(cpu_pp, 1),
        "mean_length_ours": mean([ours[key]["length"] for key in both_pp]),
        "mean_length_pyperplan": mean([pp[key]["length"] for key in both_pp]),
        "mean_parallel_length_ours": mean([ours[key].get("parallel_length") for key in both_pp]),
        "mean_parallel_length_ours_all": mean([rec.get("parallel_length") for rec in ours.values() if rec["solved"]]),
    }
    if OURS_CLI in planners:
        cli = common(by_planner, OURS, OURS_CLI)
        result.update({
            "cli_over_in_process_ours": geometric_mean_ratio(paired(by_planner, OURS_CLI, "cli_cpu_s", OURS, "cpu_s")),
            "ours_cli_same_plan": sum(ours[key].get("plan_digest") == by_planner[OURS_CLI][key].get("plan_digest")
                                      for key in cli),
            "ours_cli_compared": len(cli),
        })
    if PYPERPLAN_CLI in planners:
        result["cli_time_ratio_vs_pyperplan"] = geometric_mean_ratio(
            paired(by_planner, OURS_CLI, "cli_cpu_s", PYPERPLAN_CLI, "cli_cpu_s"))
    if FD in planners:
        both_fd = common(by_planner, OURS, FD)
        result.update({
            "commonly_solved_vs_fd": len(both_fd),
            "cli_time_ratio_vs_fd": geometric_mean_ratio(paired(by_planner, OURS_CLI, "cli_cpu_s", FD, "cli_cpu_s")),
            "search_time_ratio_vs_fd": geometric_mean_ratio(paired(by_planner, OURS, "search_s", FD, "search_s")),
            "mean_length_ours_vs_fd": mean([ours[key]["length"] for key in both_fd]),
            "mean_length_fd": mean([by_planner[FD][key]["length"] for key in both_fd]),
        })
    return result


def targets(result: dict) -> dict:
    """The targets on a set of figures: coverage, time ratio and mean length against pyperplan."""
    ratio, length_ours = result["time_ratio_vs_pyperplan"], result["mean_length_ours"]
    return {"coverage_ok": result[f"coverage_{OURS}"] >= result.get(f"coverage_{PYPERPLAN}", 0),
            "time_ok": None if ratio is None else ratio <= 1.0,
            "length_ok": None if length_ours is None else length_ours <= result["mean_length_pyperplan"]}


def by_planner_of(records: list[dict], planners: list[str], key: Callable[[dict], object]) -> dict[str, dict]:
    """The records grouped by planner, each keyed by ``key(record)``."""
    grouped: dict[str, dict] = {planner: {} for planner in planners}
    for rec in records:
        grouped[rec["planner"]][key(rec)] = rec
    return grouped


def domain_summary(domain_name: str, records: list[dict], planners: list[str], problems: int) -> dict:
    """The per-domain line: coverage, time ratios and lengths on commonly solved problems, the targets."""
    result = figures(by_planner_of(records, planners, lambda rec: rec["problem"]), planners)
    return {"bench": "planner-domain", "domain": domain_name, "problems": problems, **result, **targets(result)}


def overall_summary(records: list[dict], summaries: list[dict], planners: list[str]) -> dict:
    """The overall line: the figures over every problem, and whether every target was met."""
    result = figures(by_planner_of(records, planners, lambda rec: (rec["domain"], rec["problem"])), planners)
    ratio = result["time_ratio_vs_pyperplan"]
    failed = [f"{s['domain']}:{target}" for s in summaries for target in ("coverage_ok", "time_ok", "length_ok")
              if s[target] is False]
    return {"bench": "planner-overall", "problems": sum(s["problems"] for s in summaries), **result,
            "target_time_ratio": 1.0,
            "coverage_ok": all(s["coverage_ok"] for s in summaries),
            "time_ok": ratio is not None and ratio <= 1.0 and not any(s["time_ok"] is False for s in summaries),
            "length_ok": not any(s["length_ok"] is False for s in summaries),
            "targets_met": ratio is not None and ratio <= 1.0 and not failed, "targets_failed": failed,
            "load_average": load_average()}


# -- the runs ------------------------------------------------------------------


def run_all(jobs: list[Job], bench: Bench) -> list[dict]:
    """Every job, in order (side by side with --jobs N); each line printed as it comes."""

    def one(job: Job) -> dict:
        record = attempt(job, bench)
        progress(describe(record))
        return record

    records = []
    with ThreadPoolExecutor(max_workers=bench.args.jobs) if bench.args.jobs > 1 else nullcontext() as pool:
        for record in (pool.map(one, jobs) if pool else map(one, jobs)):  # in order, whatever finishes first
            emit(record)
            records.append(record)
    return records


def bench_domains(bench: Bench, planners: list[str]) -> None:
    """Every planner on the first problems of every domain; per-problem, per-domain and overall lines."""
    all_records, summaries = [], []
    for domain_name in bench.args.domains:
        folder = bench.args.data / domain_name
        if not folder.is_dir():
            emit({"bench": "planner-domain", "domain": domain_name, "skipped": f"no {folder}"})
            continue
        problems = list_problems(folder, bench.args.problems)
        jobs = [Job(domain_name, problem, domain, planner) for problem, domain in problems for planner in planners]
        records = run_all(jobs, bench)
        summary = domain_summary(domain_name, records, planners, len(problems))
        emit(summary)
        all_records += records
        summaries.append(summary)
    if summaries:
        emit(overall_summary(all_records, summaries, planners))


def tireworld(bench: Bench) -> None:
    """Counterplanning on fond-triangle-tireworld, ours in-process: a problem passes when it is solved
    with risk 0 and no flat tire can defeat the plan (adversarial validation)."""
    folder = bench.args.data / TIREWORLD
    if not folder.is_dir():
        emit({"bench": "planner-tireworld-summary", "skipped": f"no {folder}"})
        return
    passed = []
    for problem, domain in list_problems(folder, bench.args.tireworld_problems):
        record = attempt(Job(TIREWORLD, problem, domain, OURS), bench, adversarial=True)
        record.update(bench="planner-tireworld", passed=bool(
            record.get("status") == "solved" and record.get("risk") == 0 and record.get("valid") is True))
        progress(describe(record) + (" (passed)" if record["passed"] else " (FAILED)"))
        emit(record)
        passed.append(record["passed"])
    emit({"bench": "planner-tireworld-summary", "problems": len(passed), "passed": sum(passed),
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


def setup(args, workdir: Path) -> tuple[Bench, list[str]]:
    """Import the planners, decide which run, find the validator; print the setup line(s)."""
    planners_loaded, pyperplan_missing = load_planners()
    planners = [OURS]
    if pyperplan_missing:
        emit({"bench": "planner-pyperplan-unavailable", "why": pyperplan_missing})
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
            emit({"bench": "planner-fd-unavailable", "why": why})
            driver = None
        else:
            planners.append(FD)
    validator, why = load_validator()
    emit({"bench": "planner-setup", "data": str(args.data), "domains": args.domains, "problems": args.problems,
          "timeout_s": args.timeout, "jobs": args.jobs, "hash_seed": args.hash_seed,
          "PYTHONHASHSEED": os.environ.get("PYTHONHASHSEED"), "planners": planners,
          "in_process": [p for p in planners if p in IN_PROCESS],
          "subprocess": [p for p in planners if p not in IN_PROCESS],
          "pyperplan": version_of("pyperplan"), "up_fast_downward": version_of("up-fast-downward"),
          "fd_driver": str(driver) if driver else None, "python": sys.version.split()[0],
          "cpus": os.cpu_count(), "load_average": load_average(),
          "validator": "atlas_rap.planner.plan_file.validate_plan_file" if validator else None,
          **({"validator_missing": why, "note": "plans are NOT validated in this run"} if validator is None else {})})
    return Bench(args, planners_loaded, driver, validator, workdir), planners


def ensure_hash_seed(seed: str) -> None:
    """Re-execute this script once with ``PYTHONHASHSEED=seed`` unless it already runs with it, so the
    forked workers (which cannot change their own) and the subprocesses all inherit it."""
    if os.environ.get("PYTHONHASHSEED") == seed:
        return
    os.environ["PYTHONHASHSEED"] = seed
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, *sys.orig_argv[1:]])


def parse_args() -> argparse.Namespace:
    """The command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA, help="the pddl data folder (default ../shared/data/pddl)")
    parser.add_argument("--domains", nargs="*", default=DOMAINS,
                        help="domain folders (default: the five classical; none: only the tireworld)")
    parser.add_argument("--problems", type=int, default=10, help="first N problems of each domain (default 10)")
    parser.add_argument("--timeout", type=float, default=60.0, help="CPU seconds per planner per problem (default 60)")
    parser.add_argument("--no-fd", action="store_true", help="do not run Fast Downward")
    parser.add_argument("--no-cli", action="store_true", help="do not run our CLI as a subprocess")
    parser.add_argument("--cli-pyperplan", action="store_true",
                        help="also run pyperplan's CLI as a subprocess (off by default)")
    parser.add_argument("--tireworld", action=argparse.BooleanOptionalAction, default=True,
                        help="counterplanning on fond-triangle-tireworld (default on)")
    parser.add_argument("--tireworld-problems", type=int, default=10, help="tireworld p1..pN (default 10)")
    parser.add_argument("--jobs", type=int, default=1, help="runs at once (default 1; more disturbs the timings)")
    parser.add_argument("--keep-plans", type=Path, help="copy every plan into DIR/DOMAIN/PROBLEM.PLANNER.plan")
    parser.add_argument("--hash-seed", default="0",
                        help="PYTHONHASHSEED of every run (default 0, for repeatable plans; 'random': none)")
    args = parser.parse_args()
    if args.hash_seed != "random" and not (args.hash_seed.isdigit() and int(args.hash_seed) <= 4294967295):
        parser.error("--hash-seed takes an integer in [0, 4294967295] or 'random'")
    args.data = args.data.resolve()
    if not args.data.is_dir():
        parser.exit(1, f"bench_planner: no data folder {args.data} (see --data)\n")
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


if __name__ == "__main__":
    main()
