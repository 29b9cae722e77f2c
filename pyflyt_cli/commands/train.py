"""``pyflyt train``: compose ``conf/train.yaml`` (:func:`pyflyt_cli.training.compose_config`), call :func:`train`.

Hydra is used through its compose API, so it never changes the working directory and
writes no ``outputs/`` folder; everything a run produces goes to its run directory.  ``-m`` expands sweeps (``seed=0,1,2``,
``algo=ppo,sac``, ``seed=range(5)``) with Hydra's own basic sweeper rules and runs the
jobs one after another; every job's config is composed and validated before the first
one starts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.compose import group_choices
from pyflyt_cli.errors import UsageError

#: config groups a user picks from, in the order --help lists them
USER_GROUPS = ("env", "algo", "uav", "reward", "experiment")
#: overrides accepted together with resume=<run>
RESUME_KEYS = ("train.total_timesteps", "train.progress_bar")
#: overrides accepted together with from_config=<file>: where the new run goes, how it reports, opt-ins
FROM_CONFIG_KEYS = ("run_dir", "train.output_dir", "train.progress_bar", "trust_pickle")
#: exit code of a run stopped by Ctrl-C / SIGTERM (its checkpoint saved): 128 + SIGINT
INTERRUPTED = 130


#: what a group left unset in conf/train.yaml's defaults means
UNSET_GROUP = {
    "uav": "none (the env's own airframe)",
    "reward": "none (the env's own reward)",
    "experiment": "none",
}


def _group_defaults() -> dict[str, str | None]:
    """{group: its option in conf/train.yaml's defaults list (None: unset)}."""
    import yaml

    from pyflyt_engine.paths import conf_dir

    data = yaml.safe_load((conf_dir() / "train.yaml").read_text())
    found: dict[str, str | None] = {}
    for item in data.get("defaults", []):
        if isinstance(item, dict):
            for key, value in item.items():
                found[key.removeprefix("optional ")] = value
    return found


def train_help() -> str:
    """``pyflyt train --help``: usage, the config groups and their choices, the main keys."""
    import textwrap

    try:
        defaults = _group_defaults()
        rows = []
        for g in USER_GROUPS:
            default = defaults.get(g)
            names = [f"{c}\x00(default)" if c == default else c for c in group_choices(g)]  # \x00: kept together
            if default is None:
                names.append(f"default: {UNSET_GROUP.get(g, 'none')}")
            text = ", ".join(names) or "(none)"
            filled = textwrap.fill(text, 62, initial_indent=f"  {g + '=':<12}", subsequent_indent=" " * 14)
            rows.append(filled.replace("\x00", " "))
        groups = "\n".join(rows)
    except FileNotFoundError:  # pragma: no cover - broken install
        groups = "  (configuration directory not found)"
    return (
        "Train an agent: Hydra-style key=value overrides of conf/train.yaml.\n\n"
        "Examples:\n"
        "  pyflyt train                      # PPO on quadx_hover, short budget\n"
        "  pyflyt train env=quadx_waypoints algo=sac seed=3\n"
        "  pyflyt train uav=my_airframe.yaml # your own airframe file\n"
        "  pyflyt train env.reward=sparse algo.learning_rate=1e-3\n"
        "  pyflyt train -m seed=0,1,2        # one run per seed\n"
        "  pyflyt train resume=<run dir>     # continue an interrupted run\n"
        "  pyflyt train init_from=<run dir>  # start from a run's policy\n"
        "  pyflyt train init_from=<run dir>@<step>  # its first checkpoint at/after step\n"
        "  pyflyt train from_config=<run dir>/config.yaml  # a new run of a run's settings\n\n"
        "Config groups (group=choice):\n"
        f"{groups}\n\n"
        "Main keys: seed, env_name, run_dir, train.total_timesteps, train.n_envs,\n"
        "train.eval_freq, train.eval_episodes, train.checkpoint_freq,\n"
        "train.output_dir, train.tensorboard, train.progress_bar,\n"
        "algo.<hyper-parameter>, env.<option>, resume, init_from,\n"
        "trust_pickle (load legacy pickled files you made yourself).\n"
        "--cfg prints the full composed config.  Reference: docs/cli.md.\n\n"
        "Runs go to <train.output_dir>/<env_name>/<algo>/<time>-seed<k>,\n"
        "or exactly to run_dir=<dir>.\n"
        f"Ctrl-C saves a checkpoint and exits with code {INTERRUPTED};\n"
        "user errors exit with code 2."
    )


# ------------------------------------------------------------------- compose


def _sweep_jobs(overrides: list[str], multirun: bool) -> list[list[str]]:
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
            raise UsageError(f"{override.input_line}: a sweep takes a list of values (a,b,c or range(...)), not an interval")
    return [list(job) for job in itertools.product(*choices.values())]


def load_train_config(overrides: list[str]) -> Any:
    """Compose and validate: the :class:`TrainConfig` ``pyflyt train <overrides>`` would run."""
    from pyflyt_cli.training.compose import compose_config

    return compose_config(overrides=overrides)


# ----------------------------------------------------------------------- run


def _resume_args(overrides: list[str]) -> tuple[str, dict[str, Any]]:
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


def _from_config(overrides: list[str]) -> tuple[Any, Path | None]:
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


def _echo(message: str) -> None:
    typer.echo(message, err=True)


def run_train(overrides: list[str], multirun: bool = False, show_config: bool = False) -> int:
    """``pyflyt train``: returns the exit code (0 done, 130 interrupted)."""
    import yaml

    from pyflyt_cli.training.compose import compose_run
    from pyflyt_cli.training.loop import resume, train
    from pyflyt_cli.training.rundir import config_dict

    overrides = parse_overrides(overrides)
    if any(o.startswith("resume=") for o in overrides):
        if multirun:
            raise UsageError("resume= continues one run: do not combine it with -m")
        run, kwargs = _resume_args(overrides)
        try:
            result = resume(run, log=_echo, **kwargs)
        except KeyboardInterrupt:
            _echo("aborted (no checkpoint saved by this abort)")
            return INTERRUPTED
        return INTERRUPTED if result.interrupted else 0

    if any(o.startswith("from_config=") for o in overrides):
        if multirun:
            raise UsageError("from_config= trains one configuration: do not combine it with -m")
        jobs, composed = [overrides], [_from_config(overrides)]
    else:
        jobs = _sweep_jobs(overrides, multirun)
        composed = [compose_run(job) for job in jobs]  # every job validated before the first runs
    if len(jobs) > 1 and any(run_dir is not None for _, run_dir in composed):
        raise UsageError("run_dir= names the directory of one run: leave it out with -m (each job gets its own)")
    if show_config:
        for job, (cfg, _) in zip(jobs, composed):
            if len(jobs) > 1:
                typer.echo(f"# job: {' '.join(job)}")
            typer.echo(yaml.safe_dump(config_dict(cfg), sort_keys=False, default_flow_style=None, width=100))
        return 0
    results = []
    for i, (job, (cfg, run_dir)) in enumerate(zip(jobs, composed)):
        if len(jobs) > 1:
            _echo(f"[{i + 1}/{len(jobs)}] {' '.join(job)}")
        try:
            result = train(cfg, overrides=job, log=_echo, run_dir=run_dir)
        except KeyboardInterrupt:
            _echo("aborted (no checkpoint saved by this abort)")
            return INTERRUPTED
        results.append((job, result))
        if result.interrupted:
            if i + 1 < len(jobs):
                _echo(f"multirun stopped: {len(jobs) - i - 1} job(s) not started")
            return INTERRUPTED
    if len(results) > 1:
        _echo("\nmultirun summary:")
        for job, result in results:
            e = result.last_eval
            score = f"return {e['mean_return']:.2f} ± {e['std_return']:.2f}" if e else "no evaluation"
            _echo(f"  {' '.join(job) or '(defaults)'}: {score}  {Path(result.run_dir)}")
    return 0
