"""``pyflyt train``: compose ``conf/train.yaml`` (:func:`pyflyt_cli.training.compose_config`), call :func:`train`.

Hydra is used through its compose API, so it never changes the working directory and
writes no ``outputs/`` folder; everything a run produces goes to its run directory.  ``-m`` expands sweeps (``seed=0,1,2``,
``algo=ppo,sac``, ``seed=range(5)``) with Hydra's own basic sweeper rules and runs the
jobs one after another; every job's config is composed and validated before the first
one starts.
"""

from __future__ import annotations

from pathlib import Path

import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.compose import group_choices
from pyflyt_cli.errors import UsageError
from pyflyt_cli.training.requests import plan_runs, resume_args

#: config groups a user picks from, in the order --help lists them
USER_GROUPS = ("env", "algo", "uav", "reward", "experiment")
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


def _echo(message: str) -> None:
    typer.echo(message, err=True)


def run_train(overrides: list[str], multirun: bool = False, show_config: bool = False) -> int:
    """``pyflyt train``: returns the exit code (0 done, 130 interrupted)."""
    import yaml

    from pyflyt_cli.training.loop import resume, train
    from pyflyt_cli.training.rundir import config_dict

    overrides = parse_overrides(overrides)
    if any(o.startswith("resume=") for o in overrides):
        if multirun:
            raise UsageError("resume= continues one run: do not combine it with -m")
        run, kwargs = resume_args(overrides)
        try:
            result = resume(run, log=_echo, **kwargs)
        except KeyboardInterrupt:
            _echo("aborted (no checkpoint saved by this abort)")
            return INTERRUPTED
        return INTERRUPTED if result.interrupted else 0

    planned = plan_runs(overrides, multirun)  # every job composed and validated before the first runs
    jobs, composed = [job for job, _, _ in planned], [(cfg, run_dir) for _, cfg, run_dir in planned]
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
