"""One benchmark run, in its own process: ``python -m pyflyt_cli.benchmark.worker <benchmark dir> <run id>``.

Reads the run's configuration from ``<benchmark>/plan.json`` and brings its run
directory to completion: trains it if it does not exist, resumes it from its newest
checkpoint if it was interrupted, extends it if the plan's budget grew, and does
nothing if it is complete.  A run directory whose settings differ from the plan
(:func:`run_differences`) is refused, never reused or overwritten; ``pyflyt benchmark``
checks the same before anything starts.  Exit codes: 0 complete, 130 interrupted
(checkpoint saved), 2 user error, 1 crash (traceback in the log).
"""

from __future__ import annotations

import faulthandler
import json
import os
import shutil
import signal
import sys
import time
import traceback
from dataclasses import dataclass
from typing import Any

from pyflyt_cli.benchmark.plan import Job, Plan, read_plan
from pyflyt_engine.errors import ConfigError, PyFlytError

#: environment variable: the pid of the local launcher; the worker stops (checkpoint saved) if it dies
PARENT_ENV = "PYFLYT_BENCHMARK_PARENT"
INTERRUPTED = 130
#: the budget may grow: the run is extended (never shortened)
EXTENSION_KEY = "train.total_timesteps"
#: files a run directory holds before its configuration is written (safe to start over)
_STARTUP_FILES = {"run.lock", "state.json", "run.yaml"}
_ABSENT = object()


def _log(message: str) -> None:
    print(message, flush=True)


@dataclass(frozen=True)
class Difference:
    """A setting whose value in a run directory is not the planned one."""

    key: str
    saved: Any
    planned: Any

    def __str__(self) -> str:
        return f"{self.key}: {_show(self.saved)} -> {_show(self.planned)}"


def _show(value: Any) -> str:
    return "(not set)" if value is _ABSENT else json.dumps(value)


def run_differences(plan: Plan, job: Job) -> list[Difference]:
    """The settings of ``job``'s run directory (its ``config.yaml``) that differ from the plan.

    Compared: the run's identity (:func:`pyflyt_cli.training.rundir.identity`, the
    settings that decide what it computes).  A larger planned ``train.total_timesteps``
    is an extension, not a difference; a smaller one is.  An unreadable ``config.yaml``
    is one difference.  Empty if the run directory has no ``config.yaml``.
    """
    from pyflyt_cli.training import rundir

    path = plan.run_dir(job)
    if not (path / rundir.CONFIG_FILE).is_file():
        return []
    planned = rundir.identity(planned_config(plan, job))
    try:
        saved = rundir.identity(rundir.load_run_config(path), path)
    except PyFlytError as exc:
        return [Difference(rundir.CONFIG_FILE, f"unreadable: {exc}".splitlines()[0], "the planned configuration")]
    out = []
    for key in sorted(set(saved) | set(planned)):
        old, new = saved.get(key, _ABSENT), planned.get(key, _ABSENT)
        if old == new or (key == EXTENSION_KEY and isinstance(old, int) and isinstance(new, int) and new > old):
            continue
        out.append(Difference(key, old, new))
    return out


def planned_config(plan: Plan, job: Job) -> Any:
    """The validated configuration ``job`` trains with (its ``init_from`` as planned: ``<run>@<step>``
    names the source's first checkpoint at or after that step, found when the run starts)."""
    from pyflyt_cli.training.schema import parse_train_config

    return parse_train_config(job.config, source=f"{plan.root / 'plan.json'}: {job.id}")


def bring_to_completion(plan: Plan, job: Job) -> int:
    """Train, resume, extend or skip ``job``; returns the exit code."""
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.loop import resume, train

    run_dir = plan.run_dir(job)
    _log(f"== {job.id}  {time.strftime('%Y-%m-%d %H:%M:%S')}  pid {os.getpid()}")
    _log("   pyflyt train " + " ".join(job.overrides))
    if (run_dir / rundir.CONFIG_FILE).is_file():
        diffs = run_differences(plan, job)
        if diffs:
            raise ConfigError(
                f"{run_dir} was trained with other settings than planned ({'; '.join(map(str, diffs))}): "
                "it is not reused. Rerun pyflyt benchmark with --restart-changed to move it aside and train "
                "it afresh, or give this benchmark another benchmark.name"
            )
        saved = rundir.load_run_config(run_dir)
        state = rundir.read_state(run_dir)
        if state.get("status") == "complete" and int(state.get("total_timesteps") or 0) >= job.total_timesteps:
            _log(f"   complete already ({state.get('num_timesteps')} steps)")
            return 0
        extend = job.total_timesteps if saved.train.total_timesteps != job.total_timesteps else None
        if extend is not None:
            _log(f"   budget {saved.train.total_timesteps} -> {extend} steps")
        result = resume(run_dir, total_timesteps=extend, log=_log)
    else:
        if run_dir.exists():
            leftovers = {p.name for p in run_dir.iterdir()}
            if leftovers - _STARTUP_FILES:
                raise ConfigError(
                    f"{run_dir} exists without a config.yaml but holds {', '.join(sorted(leftovers))}: "
                    "move it away to train this run"
                )
            shutil.rmtree(run_dir)  # killed while being created: nothing trained yet
        cfg = planned_config(plan, job)
        try:
            result = train(cfg, run_dir=run_dir, log=_log, command=list(plan.command), overrides=list(job.overrides))
        except ConfigError as exc:
            if job.depends_on is None or not str(exc).startswith("init_from="):
                raise
            raise ConfigError(f"{exc} (pyflyt benchmark trains {job.depends_on} before {job.id})") from None
    return INTERRUPTED if result.interrupted else 0


def _die_with_parent() -> None:
    """Linux: get SIGTERM (a clean stop, checkpoint saved) when the launcher dies, even by SIGKILL."""
    parent = os.environ.get(PARENT_ENV)
    if not parent or not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - no prctl
        return
    if os.getppid() != int(parent):  # the launcher died before prctl
        sys.exit(INTERRUPTED)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m pyflyt_cli.benchmark.worker <benchmark dir> <run id>", file=sys.stderr)
        return 2
    faulthandler.enable()  # a hard crash (segfault ...) leaves its Python traceback in the run's log
    _die_with_parent()
    try:
        plan = read_plan(args[0])
        return bring_to_completion(plan, plan.job(args[1]))
    except PyFlytError as exc:
        print(f"error: {exc}", flush=True)
        return 2
    except KeyboardInterrupt:
        print("aborted", flush=True)
        return INTERRUPTED
    except Exception:  # noqa: BLE001 - any crash: its traceback goes to the run's log, the sweep carries on
        traceback.print_exc(file=sys.stdout)
        sys.stdout.flush()
        return 1


if __name__ == "__main__":
    sys.exit(main())
