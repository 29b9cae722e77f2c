"""Benchmark runs through a Hydra launcher: Ray, Slurm (submitit), joblib, ...

``pyflyt benchmark experiment=paper_rl hydra/launcher=ray`` sweeps the Hydra app
``conf/benchmark_launch.yaml`` over the runs to do (``job=<index in plan.json>``) with
the chosen launcher plugin; each Hydra job calls :func:`hydra_task`, which trains its run
in a worker process exactly as the local launcher does.  The launcher is configured
with Hydra's own overrides (``hydra.launcher.ray.init.address=auto``,
``hydra.launcher.partition=gpu`` ...): see docs/benchmarks.md.  Runs that start from
another run's policy are launched in a second sweep, after the first.
"""

from __future__ import annotations

import importlib.util
import time
from collections.abc import Sequence
from typing import Any

from pyflyt_cli.benchmark.plan import Job, Plan, levels
from pyflyt_cli.benchmark.run import Echo, Outcome, outcome_of
from pyflyt_cli.config import CLIError

#: launcher name -> (plugin module, pip install hint)
PLUGINS = {
    "ray": ("hydra_plugins.hydra_ray_launcher", "pip install 'pyflyt-toolkit[ray]'"),
    "ray_aws": ("hydra_plugins.hydra_ray_launcher", "pip install 'pyflyt-toolkit[ray]'"),
    "submitit_slurm": ("hydra_plugins.hydra_submitit_launcher", "pip install 'pyflyt-toolkit[slurm]'"),
    "submitit_local": ("hydra_plugins.hydra_submitit_launcher", "pip install 'pyflyt-toolkit[slurm]'"),
    "joblib": ("hydra_plugins.hydra_joblib_launcher", "pip install hydra-joblib-launcher"),
    "basic": ("hydra", ""),
}


#: the only Hydra settings pyflyt benchmark passes on (Hydra would instantiate others: callbacks, logging ...)
ALLOWED = "hydra/launcher=<name> and hydra.launcher.<key>=<value>"


def check_launcher_overrides(hydra_overrides: Sequence[str]) -> None:
    """Refuse every Hydra override but the launcher's choice and its plain settings.

    Hydra instantiates ``hydra.callbacks``, the logging configs and anything carrying a
    ``_target_`` (the launcher config itself is instantiated recursively), and
    ``hydra.searchpath`` can swap in other config files.  Accepted: ``hydra/launcher=<name>``
    and ``hydra.launcher.<key>=<value>`` whose key parts do not start with ``_`` and whose
    value holds no ``_...`` key and no ``${...}`` interpolation.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    parser = OverridesParser.create()
    for item in hydra_overrides:
        try:
            override = parser.parse_override(item)
        except HydraException:
            problem = "it is not a well-formed override"
        else:
            problem = _launcher_problem(override)
        if problem:
            names = "|".join(PLUGINS)
            raise CLIError(
                f"'{item}' cannot be given to pyflyt benchmark: {problem}. The only Hydra settings accepted are "
                f"the launcher, hydra/launcher=<{names}>, and its options, hydra.launcher.<key>=<value> (keys "
                "not starting with '_', plain values: no _target_/_args_ keys, no ${...} interpolations)"
            )


def _launcher_problem(override: Any) -> str | None:
    key = override.key_or_group
    if override.is_delete() or override.package is not None:
        return "only a launcher setting with a value is accepted"
    if key == "hydra/launcher":
        return None if isinstance(override.value(), str) else "a launcher is chosen by one name"
    parts = key.split(".")
    if parts[:2] != ["hydra", "launcher"] or len(parts) < 3:
        return "Hydra instantiates and runs what these settings name"
    if any(not p or p.startswith("_") for p in parts[2:]):
        return "a key starting with '_' makes Hydra instantiate code"
    if override.is_sweep_override():
        return "a launcher option takes one value"
    return _value_problem(override.value())


def _value_problem(value: Any) -> str | None:
    if isinstance(value, dict):
        for key, item in value.items():
            if str(key).startswith("_"):
                return f"the value's key '{key}' would make Hydra instantiate code"
            problem = _value_problem(item)
            if problem:
                return problem
    elif isinstance(value, list):
        for item in value:
            problem = _value_problem(item)
            if problem:
                return problem
    elif isinstance(value, str) and "${" in value:
        return "an interpolation (${...}) is resolved by Hydra when the launcher is built"
    return None


def launcher_name(hydra_overrides: Sequence[str]) -> str | None:
    """The ``hydra/launcher=<name>`` choice among the overrides (None: the local launcher)."""
    name = None
    for item in hydra_overrides:
        key, _, value = item.partition("=")
        if key.lstrip("+~") == "hydra/launcher":
            name = value
    if name is None and hydra_overrides:
        raise CLIError(
            f"{hydra_overrides[0]}: hydra.* overrides configure a Hydra launcher; choose one with "
            f"hydra/launcher=<{'|'.join(n for n in PLUGINS if n != 'basic')}>"
        )
    if name is not None:
        if name not in PLUGINS:
            raise CLIError(f"unknown launcher hydra/launcher={name}: choose one of {', '.join(PLUGINS)}")
        module, hint = PLUGINS[name]
        if importlib.util.find_spec(module.split(".")[0]) is None or (module != "hydra" and _missing(module)):
            raise CLIError(f"hydra/launcher={name} needs its Hydra plugin: {hint}")
    return name


def _missing(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is None
    except ModuleNotFoundError:
        return True


def hydra_task(cfg: Any) -> int:
    """One Hydra job: train run number ``cfg.job`` of the plan in ``cfg.bench_dir``; returns its exit code."""
    from pyflyt_cli.benchmark.plan import read_plan
    from pyflyt_cli.benchmark.run import run_job

    plan = read_plan(cfg.bench_dir)
    return run_job(plan.root, plan.jobs[int(cfg.job)].id)


def run_hydra(plan: Plan, jobs: Sequence[Job], hydra_overrides: Sequence[str], echo: Echo) -> list[Outcome]:
    """Launch ``jobs`` with the Hydra launcher the overrides choose, in dependency waves."""
    from hydra._internal.hydra import Hydra
    from hydra._internal.utils import create_config_search_path
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.utils import JobStatus
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    from pyflyt_engine.paths import conf_dir

    index = {j.id: i for i, j in enumerate(plan.jobs)}
    outcomes: list[Outcome] = []
    for wave in levels(list(jobs)):
        numbers = [index[j.id] for j in wave]
        overrides = [f"bench_dir={plan.root}", "job=" + ",".join(str(n) for n in numbers), *hydra_overrides]
        echo(f"launching {len(wave)} run(s) with {' '.join(hydra_overrides)}")
        started = time.monotonic()
        GlobalHydra.instance().clear()
        try:
            hydra = Hydra.create_main_hydra2(
                task_name="pyflyt_benchmark", config_search_path=create_config_search_path(str(conf_dir()))
            )
            results = hydra.multirun(config_name="benchmark_launch", task_function=hydra_task, overrides=overrides)
        except (HydraException, OmegaConfBaseException) as exc:
            raise CLIError(f"the Hydra launcher failed: {str(exc).splitlines()[0]}") from None
        finally:
            GlobalHydra.instance().clear()
        elapsed = time.monotonic() - started
        codes: dict[int, int | None] = {}
        for batch in results or []:
            for ret in batch if isinstance(batch, list) else [batch]:
                number = dict(o.split("=", 1) for o in ret.overrides if "=" in o).get("job")
                if number is not None and ret.status == JobStatus.COMPLETED:
                    codes[int(number)] = ret.return_value
        for job in wave:
            out = outcome_of(plan, job, codes.get(index[job.id]), elapsed)
            outcomes.append(out)
            echo(f"{out.status:<8} {job.id}" + (f"  {out.detail}" if out.status != "complete" else ""))
    return outcomes
