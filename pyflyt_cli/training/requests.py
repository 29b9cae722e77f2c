"""What a ``pyflyt train`` command line asks for: the runs to train, or the run to resume.

The command (:mod:`pyflyt_cli.commands.train`) parses its arguments, calls these and prints;
everything that decides what is trained lives here, where Python code and tests call it too:

* :func:`plan_runs` -- one validated :class:`~pyflyt_cli.training.schema.TrainConfig` per job:
  a sweep (``-m seed=0,1,2``) expanded by Hydra's basic sweeper rules through its public
  override parser, or a run's saved ``config.yaml`` trained again (``from_config=``);
* :func:`resume_args` -- ``resume=<run>`` and the few keys that may go with it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pyflyt_cli.errors import UsageError

#: overrides accepted together with resume=<run>
RESUME_KEYS = ("train.total_timesteps", "train.progress_bar")
#: overrides accepted together with from_config=<file>: where the new run goes, how it reports, opt-ins
FROM_CONFIG_KEYS = ("run_dir", "train.output_dir", "train.progress_bar", "trust_pickle")


def plan_runs(overrides: list[str], multirun: bool = False) -> list[tuple[list[str], Any, Path | None]]:
    """``(job's overrides, its TrainConfig, its run_dir or None)`` for every run ``overrides`` ask for,
    each composed and validated before any trains (``resume=`` is :func:`resume_args`' business)."""
    from pyflyt_cli.training.compose import compose_run

    if any(o.startswith("from_config=") for o in overrides):
        if multirun:
            raise UsageError("from_config= trains one configuration: do not combine it with -m")
        cfg, run_dir = from_config(overrides)
        return [(list(overrides), cfg, run_dir)]
    jobs = sweep_jobs(overrides, multirun)
    planned = [(job, *compose_run(job)) for job in jobs]
    if len(jobs) > 1 and any(run_dir is not None for _, _, run_dir in planned):
        raise UsageError("run_dir= names the directory of one run: leave it out with -m (each job gets its own)")
    return planned


def sweep_jobs(overrides: list[str], multirun: bool) -> list[list[str]]:
    """The jobs of a command line: itself, or with ``-m`` every combination of its swept values."""
    import itertools

    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    try:
        parsed = OverridesParser.create().parse_overrides(overrides)
    except HydraException as exc:
        raise UsageError(f"malformed override: {exc}. Overrides look like key=value, e.g. seed=3 or algo=sac") from None
    sweeps = [o.input_line for o in parsed if o.is_sweep_override()]
    if not multirun:
        if sweeps:
            raise UsageError(
                f"{sweeps[0]} is a sweep: add -m (--multirun) to start one run per value, "
                "or quote the value to use it as a string"
            )
        return [overrides]
    # Hydra's basic sweeper rules, through its public override API: every combination of
    # the swept values; a key given twice keeps its first place and its last value
    choices: dict[str, list[str]] = {}
    for override in parsed:
        key = override.get_key_element()
        if not override.is_sweep_override():
            choices[key] = [f"{key}={override.get_value_element_as_str()}"]
        elif override.is_discrete_sweep():
            choices[key] = [f"{key}={value}" for value in override.sweep_string_iterator()]
        else:
            raise UsageError(
                f"{override.input_line}: a sweep takes a list of values (a,b,c or range(...)), not an interval"
            )
    return [list(job) for job in itertools.product(*choices.values())]


def resume_args(overrides: list[str]) -> tuple[str, dict[str, Any]]:
    """``(run directory, keyword arguments of loop.resume)`` of ``resume=<run> [train.total_timesteps=N]
    [train.progress_bar=B]``."""
    run = None
    extra: dict[str, Any] = {}
    for item in overrides:
        key, _, value = item.partition("=")
        if key == "resume":
            run = value
        elif key in RESUME_KEYS:
            extra[key] = value
        else:
            raise UsageError(
                f"'{item}' cannot be combined with resume=: a resumed run keeps its saved configuration "
                f"(only {', '.join(k + '=' for k in RESUME_KEYS)} may be given)"
            )
    if not run:
        raise UsageError("resume= needs a run directory: pyflyt train resume=runs/<env>/<algo>/<time>-seed<k>")
    total = extra.get("train.total_timesteps")
    bar = extra.get("train.progress_bar")
    try:
        parsed_total = int(float(total)) if total is not None else None
    except ValueError:
        raise UsageError(f"train.total_timesteps must be a number, got {total!r}") from None
    parsed_bar = None if bar in (None, "null") else bar.lower() in ("true", "1", "yes")
    return run, {"total_timesteps": parsed_total, "progress_bar": parsed_bar}


def from_config(overrides: list[str]) -> tuple[Any, Path | None]:
    """``from_config=<file> [run_dir=...] [train.output_dir=...] [train.progress_bar=...] [trust_pickle=...]``:
    the resolved configuration in ``<file>`` (a run's ``config.yaml``) to train as a new run, and its ``run_dir``.

    The file is read as untrusted data, as a run's own (:func:`~pyflyt_cli.training.rundir.load_config_file`:
    the airframe copies beside it, no ``trust_pickle`` from it), then validated as a config to start.
    """
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.schema import parse_train_config

    file, extra = None, {}
    for item in overrides:
        key, _, value = item.partition("=")
        if key == "from_config":
            file = value
        elif key in FROM_CONFIG_KEYS:
            extra[key] = value
        else:
            raise UsageError(
                f"'{item}' cannot be combined with from_config=: the new run trains the file's settings "
                f"(only {', '.join(k + '=' for k in FROM_CONFIG_KEYS)} may be given)"
            )
    if not file:
        raise UsageError("from_config= needs a configuration file: pyflyt train from_config=<run dir>/config.yaml")
    path = Path(file).expanduser()
    if not path.is_file():
        raise UsageError(f"from_config={file}: no such file ({path.absolute()})")
    data = rundir.config_dict(rundir.load_config_file(path, root=path.resolve().parent))
    flag = {"true": True, "false": False, "1": True, "0": False, "yes": True, "no": False}
    for key in ("train.progress_bar", "trust_pickle"):
        if key in extra:
            if extra[key].lower() not in flag:
                raise UsageError(f"{key} must be true or false, got {extra[key]!r}")
            section, _, leaf = key.rpartition(".")
            (data[section] if section else data)[leaf] = flag[extra[key].lower()]
    if "train.output_dir" in extra:
        data["train"]["output_dir"] = extra["train.output_dir"]
    cfg = parse_train_config(data, source=str(path))
    run_dir = extra.get("run_dir")
    return cfg, Path(run_dir).expanduser() if run_dir else None
