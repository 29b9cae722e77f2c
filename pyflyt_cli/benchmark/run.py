"""Running a plan: which runs are done, the local launcher, and the end-of-sweep summary.

Every run is trained by its own worker process (:mod:`pyflyt_cli.benchmark.worker`)
whose output goes to ``<benchmark>/logs/<task>__<algo>__seed<k>.log``, so a crash or a
failed run never takes the others down.  The local launcher keeps ``jobs`` workers busy
on this machine; :mod:`pyflyt_cli.benchmark.launch` hands the same workers to a Hydra
launcher (Ray, Slurm) instead.  Whether a run is complete is read from its run
directory (``state.json``), the single source of truth, so any launcher, an
interrupted sweep or a rerun agree on it.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from pyflyt_cli.benchmark.plan import LOGS_DIR, RUNS_DIR, Job, Plan
from pyflyt_cli.errors import UsageError

Echo = Callable[[str], None]

#: run states, as the summary names them
COMPLETE, NEW, PARTIAL, BUSY, CHANGED = "complete", "new", "partial", "busy", "changed"
#: where runs restarted by --restart-changed are moved: <benchmark>/replaced/<time>/<task>/<algo>/seed<k>
REPLACED_DIR = "replaced"


#: held (``flock``) by the pyflyt benchmark process working on the directory; holds its pid and command
LOCK_FILE = "benchmark.lock"


@contextlib.contextmanager
def hold_benchmark(root: Path, command: Sequence[str]) -> Iterator[None]:
    """Hold ``<root>/benchmark.lock`` while this process works on the benchmark directory.

    An OS lock (``flock``) on the file: the kernel releases it when the process ends,
    however it ends, so a killed benchmark never leaves a stale lock.  A second process
    finds it held and gets a :class:`UsageError` naming the holder, before it touches
    anything.  (Without ``fcntl``, on Windows, nothing is locked.)
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    from pyflyt_engine.safe_load import open_own_file

    path = root / LOCK_FILE
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(
            f"cannot use {root} as the benchmark directory ({exc.strerror}): choose another benchmark.output_dir"
        ) from None
    # never through a link, never a file with a second name elsewhere (it is truncated below)
    fd = open_own_file(path, readable=True, what="benchmark lock file", error=UsageError)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 4096).decode(errors="replace").strip() or "another process"
            pid, _, cmd = holder.partition(" ")
            raise UsageError(
                f"benchmark directory {root} is in use by process {pid}"
                + (f" ({cmd})" if cmd else "")
                + ": wait for it to finish or stop it (Ctrl-C), or give this benchmark another directory "
                "(benchmark.name=<name> or benchmark.output_dir=<dir>)"
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()} {shlex.join(command)}\n".encode())
        yield
    finally:
        os.close(fd)  # releases the lock; the file stays (removing it would race with the next holder)


def run_state(plan: Plan, job: Job) -> str:
    """``new`` (no run directory yet), ``busy`` (another process trains it), ``changed`` (its settings
    differ from the plan: :func:`~pyflyt_cli.benchmark.worker.run_differences`), ``complete`` or
    ``partial`` (interrupted, or its budget grew)."""
    from pyflyt_cli.benchmark.worker import run_differences
    from pyflyt_cli.training import rundir

    path = plan.run_dir(job)
    if not (path / rundir.CONFIG_FILE).is_file():
        return NEW
    pid = rundir.read_pid(path / rundir.LOCK_FILE)
    if pid and pid != os.getpid() and rundir._alive(pid):
        return BUSY
    if run_differences(plan, job):
        return CHANGED
    state = rundir.read_state(path)
    if state.get("status") == "complete" and int(state.get("total_timesteps") or 0) >= job.total_timesteps:
        return COMPLETE
    return PARTIAL


def to_restart(plan: Plan, states: dict[str, str]) -> dict[str, str]:
    """Run id -> why it must start afresh: its settings changed, or it starts from a run that restarts."""
    why = {j.id: "its settings differ from the plan" for j in plan.jobs if states[j.id] == CHANGED}
    for job in plan.jobs:
        if job.depends_on in why and job.id not in why and states[job.id] != NEW:
            why[job.id] = f"it starts from {job.depends_on}, which restarts"
    return why


def move_aside(plan: Plan, jobs: Sequence[Job], echo: Echo) -> Path:
    """Move the run directories (and logs) of ``jobs`` to ``<benchmark>/replaced/<time>/``; returns that folder.

    Nothing is deleted: ``pyflyt plot <that folder>`` still reports the old runs.
    """
    stamp = time.strftime("%Y%m%d-%H%M%S")
    parent = plan.root / REPLACED_DIR
    parent.mkdir(parents=True, exist_ok=True)
    for n in range(10_000):
        folder = parent / (stamp if n == 0 else f"{stamp}-{n}")
        try:
            folder.mkdir()
        except FileExistsError:
            continue
        break
    for job in jobs:
        target = folder / job.run_dir.removeprefix(f"{RUNS_DIR}/")
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(plan.run_dir(job), target)
        log = plan.log_file(job)
        if log.is_file():
            (folder / LOGS_DIR).mkdir(exist_ok=True)
            os.replace(log, folder / LOGS_DIR / log.name)
        echo(f"restarting {job.id}: its old run directory is now {target}")
    return folder


def worker_command(plan: Plan, job: Job) -> list[str]:
    return [sys.executable, "-m", "pyflyt_cli.benchmark.worker", str(plan.root), job.id]


def open_log(plan: Plan, job: Job) -> tuple[Path, BinaryIO]:
    """``<benchmark>/logs/<run>.log`` open for appending: the benchmark's own file, reached through
    no link and with no second name (a hard link would append to a file outside the benchmark)."""
    from pyflyt_engine.safe_load import open_own_file

    path = plan.log_file(job)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create {path.parent}: {exc.strerror or exc}") from None
    fd = open_own_file(path, append=True, what="run log", error=UsageError)
    return path, os.fdopen(fd, "ab")


def run_job(root: str | Path, job_id: str) -> int:
    """Train one run in a worker process (blocking), its output appended to its log; the exit code.

    What a Hydra launcher executes for each run (on a Ray worker, in a Slurm job ...).
    """
    from pyflyt_cli.benchmark.plan import read_plan

    plan = read_plan(root)
    job = plan.job(job_id)
    _, log = open_log(plan, job)
    with log:
        return subprocess.call(worker_command(plan, job), stdout=log, stderr=subprocess.STDOUT)


@dataclass
class Outcome:
    """What happened to one run in this invocation."""

    job: Job
    status: str  # skipped (complete before), complete, failed, interrupted, blocked, busy
    seconds: float = 0.0
    code: int | None = None
    detail: str = ""


def failure_reason(path: Path) -> str:
    """The line of a run's log that says why it failed: its ``error:`` line, else the exception, else the last line."""
    try:
        lines = [line.strip() for line in path.read_text(errors="replace").splitlines() if line.strip()]
    except OSError:
        return "no log"
    for line in reversed(lines):
        if line.startswith("error:"):
            return line
    return lines[-1] if lines else "empty log"


def outcome_of(plan: Plan, job: Job, code: int | None, seconds: float) -> Outcome:
    """Classify a finished worker from its exit code and its run directory."""
    from pyflyt_cli.benchmark.worker import INTERRUPTED

    if code == 0 and run_state(plan, job) == COMPLETE:
        return Outcome(job, "complete", seconds, code)
    if code == INTERRUPTED or (code is not None and code < 0):
        from pyflyt_cli.training import rundir

        step = rundir.read_state(plan.run_dir(job)).get("checkpoint")
        detail = (
            f"checkpoint at step {step}; rerun to resume"
            if step is not None
            else "stopped before its first checkpoint; rerun to start it again"
        )
        return Outcome(job, "interrupted", seconds, code, detail)
    log = plan.log_file(job)
    return Outcome(job, "failed", seconds, code, f"{failure_reason(log)}  (log: {log})")


def run_local(plan: Plan, jobs: Sequence[Job], parallel: int, echo: Echo) -> list[Outcome]:
    """Train ``jobs`` in at most ``parallel`` worker processes at a time, sources before their dependents.

    Ctrl-C or SIGTERM stops every worker cleanly (each saves a checkpoint); killing this
    process outright makes the workers do the same (Linux), so a rerun resumes them.
    """
    # imported here: the package imports this module, and ``python -m ...worker`` imports the package first
    from pyflyt_cli.benchmark.worker import INTERRUPTED, PARENT_ENV

    pending = list(jobs)
    planned = {j.id for j in jobs}
    running: dict[str, tuple[Job, subprocess.Popen, float, BinaryIO]] = {}
    outcomes: dict[str, Outcome] = {}
    failed: set[str] = set()
    total = len(jobs)
    env = {**os.environ, PARENT_ENV: str(os.getpid())}
    #: each run's number in the order runs start: its `started` and its end line share it
    number: dict[str, int] = {}

    def start(job: Job) -> None:
        path, log = open_log(plan, job)
        proc = subprocess.Popen(worker_command(plan, job), stdout=log, stderr=subprocess.STDOUT, env=env)
        running[job.id] = (job, proc, time.monotonic(), log)
        number[job.id] = len(number) + 1
        echo(f"[{number[job.id]}/{total}] started  {job.id}  (log: {path})")

    def source_ready(job: Job) -> bool | None:
        """True: can start; False: wait; None: its source failed or cannot complete."""
        if job.depends_on is None:
            return True
        if job.depends_on in failed:
            return None
        if job.depends_on in planned and job.depends_on not in outcomes:
            return False
        return run_state(plan, plan.job(job.depends_on)) == COMPLETE or None

    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        while pending or running:
            for job in list(pending):
                if len(running) >= parallel:
                    break
                ready = source_ready(job)
                if ready is None:
                    pending.remove(job)
                    outcomes[job.id] = Outcome(
                        job, "blocked", detail=f"its source run {job.depends_on} is not complete"
                    )
                    failed.add(job.id)
                    echo(f"blocked  {job.id}: {outcomes[job.id].detail}")
                elif ready:
                    pending.remove(job)
                    start(job)
            if not running:
                for job in pending:  # nothing runs and nothing could start: never spin
                    outcomes[job.id] = Outcome(job, "blocked", detail=f"its source run {job.depends_on} never ran")
                    failed.add(job.id)
                pending.clear()
                continue
            time.sleep(0.2)
            for job_id, (job, proc, t0, log) in list(running.items()):
                code = proc.poll()
                if code is None:
                    continue
                log.close()
                del running[job_id]
                out = outcome_of(plan, job, code, time.monotonic() - t0)
                outcomes[job_id] = out
                if out.status != "complete":
                    failed.add(job_id)
                ended = sum(1 for o in outcomes.values() if o.status != "blocked")
                echo(
                    f"[{number[job_id]}/{total}] {out.status:<8} {job_id}  {_duration(out.seconds)}"
                    + (f"  {out.detail}" if out.status != "complete" else "")
                    + f"  ({ended}/{total} ended)"
                )
    except KeyboardInterrupt:
        echo(f"stopping {len(running)} run(s): each saves a checkpoint (rerun the same command to resume)")
        for _, proc, _, _ in running.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for job_id, (job, proc, t0, log) in running.items():
            code = proc.wait()
            log.close()
            outcomes[job_id] = outcome_of(
                plan, job, code if code != 0 or run_state(plan, job) == COMPLETE else INTERRUPTED, time.monotonic() - t0
            )
        for job in pending:
            outcomes[job.id] = Outcome(job, "not started")
    finally:
        signal.signal(signal.SIGTERM, previous)
    return [outcomes[j.id] for j in jobs if j.id in outcomes]


def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _duration(seconds: float) -> str:
    m, s = divmod(round(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}h{m:02d}m{s:02d}s" if h else f"{m}m{s:02d}s"


def summary(plan: Plan, outcomes: Sequence[Outcome], skipped: Sequence[Job], elapsed: float) -> str:
    """The end-of-sweep report: what ran, what was skipped, what failed (also written to summary.md)."""
    counts: dict[str, int] = {}
    for o in outcomes:
        counts[o.status] = counts.get(o.status, 0) + 1
    head = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    lines = [
        f"# Benchmark {plan.root.name}: {len(plan.jobs)} runs",
        "",
        f"This invocation ({_duration(elapsed)}): {len(skipped)} skipped (complete before)"
        + (f", {head}" if head else "")
        + ".",
        "",
        "| run | status | time | detail |",
        "|---|---|---:|---|",
    ]
    lines += [f"| {j.id} | skipped (complete) | | |" for j in skipped]
    lines += [
        f"| {o.job.id} | {o.status}{'' if o.code in (None, 0) else f' (exit {o.code})'} | "
        f"{_duration(o.seconds) if o.seconds else ''} | {o.detail} |"
        for o in outcomes
    ]
    return "\n".join(lines) + "\n"
