"""One ``pyflyt benchmark`` invocation on a plan: survey its runs, refuse changed ones, train the rest.

:func:`survey` reads every run's state from its directory; :func:`run_benchmark` holds
the benchmark directory's lock, refuses runs trained with other settings than planned
(or moves them aside with ``restart_changed``), records the random-policy and reference
scores, trains what is not complete (local processes or a Hydra launcher) and writes
``summary.md``.  :func:`dry_run_script` is what ``--dry-run`` prints.
"""

from __future__ import annotations

import shlex
import time
from dataclasses import dataclass

from pyflyt_cli.benchmark.plan import Job, Plan, levels
from pyflyt_cli.benchmark.run import (
    BUSY,
    COMPLETE,
    NEW,
    PARTIAL,
    REPLACED_DIR,
    Echo,
    Outcome,
    hold_benchmark,
    run_state,
    to_restart,
)
from pyflyt_cli.errors import UsageError


def _silent(_: str) -> None:
    pass


@dataclass(frozen=True)
class Survey:
    """What a benchmark invocation finds in the run directories of a plan.

    Attributes:
        states: run id -> ``new``, ``partial``, ``complete``, ``busy`` or ``changed``
            (:func:`~pyflyt_cli.benchmark.run.run_state`).
        restart: run id -> why it must start afresh (its settings changed, or its source restarts).
        skipped: complete runs that do not restart.
        busy: runs another process is training.
        todo: runs to train, sources before the runs that start from them (restarts included).
    """

    states: dict[str, str]
    restart: dict[str, str]
    skipped: list[Job]
    busy: list[Job]
    todo: list[Job]

    def headline(self, plan: Plan) -> str:
        """``benchmark <dir>: 6 runs; 2 complete (skipped), 1 to resume, 3 to start``."""
        todo = self.todo
        return (
            f"benchmark {plan.root}: {len(plan.jobs)} runs; {len(self.skipped)} complete (skipped), "
            f"{sum(self.states[j.id] == PARTIAL and j.id not in self.restart for j in todo)} to resume, "
            f"{sum(self.states[j.id] == NEW for j in todo)} to start"
            + (f", {len(self.restart)} to restart (settings changed)" if self.restart else "")
            + (f", {len(self.busy)} being trained by another process" if self.busy else "")
        )


def check_benchmark_dir(plan: Plan) -> None:
    """Refuse a benchmark directory that is not a closed world before anything in it is read or written:
    a link leading out of it (its top level, ``logs/``, or on the way to a run directory) or a special file;
    and a file written in place (the lock file, a run's log) that is a link or has a second name (a
    hard link: appending to it would append to a file outside).

    Raises:
        RunDirError: naming the link and where it leads.
    """
    from pyflyt_cli.benchmark.plan import LOGS_DIR
    from pyflyt_cli.training.rundir import RunDirError, check_closed
    from pyflyt_cli.benchmark.run import LOCK_FILE
    from pyflyt_engine.safe_load import check_own_file, outside

    if not plan.root.is_dir():
        return
    check_closed(plan.root, folders=(LOGS_DIR,), what="benchmark directory")
    check_own_file(plan.root / LOCK_FILE, what="benchmark lock file", error=RunDirError)
    for job in plan.jobs:
        check_own_file(plan.log_file(job), what="run log", error=RunDirError)
    for job in plan.jobs:
        if outside(plan.root, plan.run_dir(job)):
            raise RunDirError(
                f"{plan.run_dir(job)} leads outside {plan.root} (a link on its way): a shared benchmark directory "
                "is read and written only inside itself; replace the link by a copy of what it points to"
            )


def survey(plan: Plan) -> Survey:
    """The state of every run of ``plan``, read from its run directory."""
    check_benchmark_dir(plan)
    states = {j.id: run_state(plan, j) for j in plan.jobs}
    restart = to_restart(plan, states)
    return Survey(
        states=states,
        restart=restart,
        skipped=[j for j in plan.jobs if states[j.id] == COMPLETE and j.id not in restart],
        busy=[j for j in plan.jobs if states[j.id] == BUSY],
        todo=[j for wave in levels(plan.jobs) for j in wave if j.id in restart or states[j.id] not in (COMPLETE, BUSY)],
    )


def platform_note(plan: Plan, found: Survey) -> str | None:
    """One line when runs already in the directory were made under another numeric platform
    than this process's (``run.yaml``'s ``numerics``), or on another CPU: what is reused or
    resumed here was computed there."""
    from pyflyt_cli.training import rundir

    kept = [j for j in plan.jobs if found.states[j.id] not in (NEW, BUSY) and j.id not in found.restart]
    if not kept:
        return None
    here = rundir.numeric_platform()
    notes: dict[str, list[str]] = {}
    for job in kept:
        note = rundir.platform_note(rundir.read_yaml(plan.run_dir(job) / rundir.RUN_FILE), here)
        if note:
            notes.setdefault(note, []).append(job.id)
    if not notes:
        return None
    return "; ".join(f"note: {len(ids)} of the runs here ({', '.join(ids[:3])}{', ...' if len(ids) > 3 else ''}) were {note}"
                     for note, ids in notes.items())  # fmt: skip


def check_restarts(plan: Plan, found: Survey, restart_changed: bool) -> None:
    """Refuse runs with other settings than planned unless ``restart_changed``, and restarts of busy runs.

    Raises:
        UsageError: one line per changed run and setting (saved value -> planned value), or the busy runs.
    """
    if found.restart and not restart_changed:
        raise UsageError(changed_message(plan, found.restart))
    busy = [i for i in found.restart if found.states[i] == BUSY]
    if busy:
        raise UsageError(f"cannot restart {', '.join(busy)}: being trained by another process; stop it first")


def changed_message(plan: Plan, restart: dict[str, str]) -> str:
    """Why runs of ``plan`` are not reused, setting by setting, and what to do."""
    from pyflyt_cli.benchmark.worker import run_differences

    lines = [f"{len(restart)} run(s) in {plan.root} differ from this plan and are not reused:"]
    for run_id, why in restart.items():
        diffs = run_differences(plan, plan.job(run_id))
        lines += [f"  {run_id}  {d}" for d in diffs] if diffs else [f"  {run_id}  {why}"]
    lines.append(
        "(saved value -> planned value.)  Keep those runs and write this benchmark elsewhere "
        "(benchmark.name=<new name> or benchmark.output_dir=<dir>), or start them afresh with --restart-changed: "
        f"their directories move to {plan.root / REPLACED_DIR}/<time>/, nothing is deleted"
    )
    return "\n".join(lines)


def dry_run_script(plan: Plan, states: dict[str, str], restart: dict[str, str]) -> list[str]:
    """One ``pyflyt train`` line per run, sources first, each after a comment: its state, or
    ``restart`` for the runs that would start afresh.  Run as printed, a line trains that run."""
    lines = []
    for wave in levels(plan.jobs):
        for job in wave:
            state = "restart" if job.id in restart else states[job.id]
            lines += [f"# {state:<9} {job.id}", shlex.join(["pyflyt", "train", *job.overrides])]
    return lines


@dataclass(frozen=True)
class BenchmarkResult:
    """What one :func:`run_benchmark` did.

    Attributes:
        plan: the plan it ran.
        outcomes: one per run it trained, or found busy (status ``complete``, ``failed``,
            ``interrupted``, ``not started``, ``blocked``, ``busy``).
        skipped: runs complete before it started.
        summary: the summary table (also ``<benchmark>/summary.md``).
    """

    plan: Plan
    outcomes: list[Outcome]
    skipped: list[Job]
    summary: str

    @property
    def interrupted(self) -> bool:
        return bool({o.status for o in self.outcomes} & {"interrupted", "not started"})

    @property
    def complete(self) -> bool:
        """Every run of the plan is complete."""
        return all(o.status == "complete" for o in self.outcomes)


def run_benchmark(plan: Plan, *, restart_changed: bool = False, log: Echo = _silent) -> BenchmarkResult:
    """Bring every run of ``plan`` to completion; the directory's lock is held throughout.

    Complete runs are skipped, interrupted ones resumed, runs whose budget grew extended,
    the rest trained: ``plan.spec["jobs"]`` worker processes at a time, or through the
    Hydra launcher of ``plan.launcher``.  A failed run is reported and the others carry on.

    Args:
        restart_changed: train runs whose saved settings differ from the plan afresh (and
            the runs that start from them); their directories move to ``<benchmark>/replaced/<time>/``.
        log: receives one-line progress messages.

    Raises:
        UsageError: the directory is in use by another ``pyflyt benchmark``; runs with other
            settings than planned and no ``restart_changed``; a restart of a run another
            process trains.  Nothing has been trained then.
    """
    from pyflyt_cli.benchmark.launch import run_hydra
    from pyflyt_cli.benchmark.launchers import launcher_name
    from pyflyt_cli.benchmark.normalise import update_normalisation
    from pyflyt_cli.benchmark.plan import few_evaluations_note
    from pyflyt_cli.benchmark.run import move_aside, run_local, summary
    from pyflyt_cli.training.rundir import atomic_write

    check_benchmark_dir(plan)  # before the lock file is opened
    with hold_benchmark(plan.root, plan.command):  # a second benchmark on this directory stops here
        found = survey(plan)
        check_restarts(plan, found, restart_changed)
        log(found.headline(plan))
        note = platform_note(plan, found)
        if note:
            log(note)
        note = few_evaluations_note(plan)
        if note:
            log(note)
        if found.restart:
            move_aside(plan, [plan.job(i) for i in found.restart], log)
        plan.write()
        started = time.monotonic()
        update_normalisation(plan, echo=log)
        if not found.todo:
            outcomes: list[Outcome] = []
        elif launcher_name(plan.launcher) is None:
            parallel = int(plan.spec["jobs"])
            log(f"training {len(found.todo)} run(s), {parallel} at a time; logs in {plan.root / 'logs'}")
            outcomes = run_local(plan, found.todo, parallel, log)
        else:
            outcomes = run_hydra(plan, found.todo, plan.launcher, log)
        outcomes += [Outcome(j, "busy", detail="being trained by another process") for j in found.busy]
        text = summary(plan, outcomes, found.skipped, time.monotonic() - started)
        atomic_write(plan.root / "summary.md", text)
    return BenchmarkResult(plan, outcomes, found.skipped, text)
