"""One benchmark run, in its own process: ``python -m pyflyt_cli.benchmark.worker <benchmark dir> <run id>``.

Reads the run's configuration from ``<benchmark>/plan.json`` and brings its run
directory to completion: trains it if it does not exist, resumes it from its newest
checkpoint if it was interrupted, extends it if the plan's budget grew, and does
nothing if it is complete.  A run directory trained with another configuration is
refused (never overwritten).  Exit codes: 0 complete, 130 interrupted (checkpoint
saved), 2 user error, 1 crash (traceback in the log).
"""

from __future__ import annotations

import faulthandler
import os
import shutil
import signal
import sys
import time
import traceback
from pathlib import Path
from typing import Any

from pyflyt_cli.benchmark.plan import Job, Plan, read_plan
from pyflyt_engine.errors import ConfigError, PyFlytError

#: environment variable: the pid of the local launcher; the worker stops (checkpoint saved) if it dies
PARENT_ENV = "PYFLYT_BENCHMARK_PARENT"
INTERRUPTED = 130
#: keys that may differ between the plan and an existing run directory
_MAY_DIFFER = {"train.total_timesteps", "train.progress_bar", "train.output_dir"}
#: files a run directory holds before its configuration is written (safe to start over)
_STARTUP_FILES = {"run.lock", "state.json", "run.yaml"}


def _log(message: str) -> None:
    print(message, flush=True)


def _flatten(data: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(data, dict):
        out: dict[str, Any] = {}
        for k, v in data.items():
            out.update(_flatten(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: data}


def config_differences(planned: dict[str, Any], saved: dict[str, Any], run_dir: Path) -> list[str]:
    """Keys whose values differ between the plan and a run directory's ``config.yaml``."""
    a, b = _flatten(planned), _flatten(saved)
    diffs = []
    for key in sorted(set(a) | set(b)):
        if key in _MAY_DIFFER or a.get(key) == b.get(key):
            continue
        if key == "env.uav" and str(b.get(key, "")).startswith(str(run_dir)):
            continue  # an airframe file copied into the run directory
        diffs.append(key)
    return diffs


def planned_config(plan: Plan, job: Job, resolve: bool) -> Any:
    """The validated configuration ``job`` trains with; ``resolve``: its ``<run>@<step>`` source made a file.

    Without ``resolve`` an unresolvable source (not trained that far yet) is left as planned.
    """
    from pyflyt_cli.training.compose import resolve_init_from
    from pyflyt_cli.training.schema import parse_train_config

    cfg = parse_train_config(job.config, source=f"{plan.root / 'plan.json'}: {job.id}")
    try:
        return resolve_init_from(cfg)
    except ConfigError:
        if resolve:
            raise
        return cfg


def bring_to_completion(plan: Plan, job: Job) -> int:
    """Train, resume, extend or skip ``job``; returns the exit code."""
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.loop import resume, train

    run_dir = plan.run_dir(job)
    _log(f"== {job.id}  {time.strftime('%Y-%m-%d %H:%M:%S')}  pid {os.getpid()}")
    _log("   pyflyt train " + " ".join(job.overrides))
    if (run_dir / rundir.CONFIG_FILE).is_file():
        planned = planned_config(plan, job, resolve=False).model_dump(mode="json")
        saved = rundir.load_run_config(run_dir)
        diffs = config_differences(planned, saved.model_dump(mode="json"), run_dir)
        if diffs:
            raise ConfigError(
                f"{run_dir} was trained with another configuration ({', '.join(diffs[:6])}"
                f"{' ...' if len(diffs) > 6 else ''} differ from the plan): keep it and give this benchmark "
                "another benchmark.name, or delete that run directory to train it again"
            )
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
        try:
            cfg = planned_config(plan, job, resolve=True)
        except ConfigError as exc:
            raise ConfigError(f"{exc} (pyflyt benchmark trains {job.depends_on} before {job.id})") from None
        result = train(cfg, run_dir=run_dir, log=_log, command=list(plan.command), overrides=list(job.overrides))
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
