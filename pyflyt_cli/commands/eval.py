"""``pyflyt eval <run dir> [key=value ...]``: compose ``conf/eval.yaml``, evaluate, print the table.

``env.<key>=value`` and ``env.task.<option>=value`` fly the run's policy in its env with
that changed (e.g. in wind, or for longer episodes), when the policy's spaces stay the same.

``pyflyt eval oracle:<name> [key=value ...]`` flies a scripted oracle instead
(:mod:`pyflyt_engine.envs.oracles`): the keys of ``conf/eval.yaml`` go to the evaluation,
every other key composes ``conf/train.yaml`` as ``pyflyt train`` would, for the
environment (``env=``, ``env.*``, ``uav=``, ``reward=``), ``train.output_dir`` and
``run_dir``.
"""

from __future__ import annotations

from pathlib import Path

import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.compose import compose, to_container


def run_eval(run_dir: str, overrides: list[str]) -> object:
    """Evaluate ``run_dir`` with ``overrides`` of ``conf/eval.yaml``; print and return the report."""
    from pyflyt_cli.training.evaluate import evaluate_run
    from pyflyt_cli.training.rundir import check_run_dir
    from pyflyt_cli.training.schema import parse_eval_options

    if run_dir.startswith("oracle:"):
        return run_oracle_eval(run_dir[len("oracle:") :], overrides)
    shipped = None
    if run_dir.startswith("zoo:"):  # a shipped agent: copied to zoo/<name>/ here, evaluated there
        from pyflyt_cli.zoo import agent, materialise

        shipped = agent(run_dir[len("zoo:") :])
        run_dir = str(materialise(shipped.name))
    _refuse_a_folder_of_runs(run_dir)
    check_run_dir(run_dir)  # a missing run directory is reported before anything else
    evaluation, env = env_changes(parse_overrides(overrides))
    options = parse_eval_options(to_container(compose("eval", evaluation)))
    report = evaluate_run(run_dir, options, env=env)
    typer.echo(report.table())
    if shipped is not None:
        from pyflyt_cli.zoo import compare

        recorded = shipped.summary.get("evaluation", {})
        same = (
            not env
            and options.episodes == recorded.get("episodes")
            and report.seed == recorded.get("seed")
            and options.deterministic
        )
        words = (
            compare(recorded, [e.ret for e in report.episodes], report.summary["success_rate"])[1]
            if same
            else "other episodes or seeds than recorded: not comparable"
        )
        typer.echo(
            f"recorded:      return {recorded.get('mean_return', float('nan')):.2f} ± "
            f"{recorded.get('std_return', float('nan')):.2f} over {recorded.get('episodes')} episodes from seed "
            f"{recorded.get('seed')} ({words})"
        )
    return report


#: how deep below a folder `pyflyt eval <folder>` looks for runs (runs/<env>/<algo>/<run>: 3)
RUN_SEARCH_DEPTH = 4
#: how many of the runs found it lists
RUNS_LISTED = 20


def runs_inside(folder: Path, depth: int = RUN_SEARCH_DEPTH) -> list[Path]:
    """The run directories (holding ``config.yaml``) at most ``depth`` levels below ``folder``,
    sorted by path; links are not followed, nor are runs' own checkpoint and episode folders."""
    import os

    from pyflyt_cli.training.rundir import CONFIG_FILE

    found = []
    root_depth = len(folder.parts)
    for here, dirs, files in os.walk(folder, followlinks=False):
        path = Path(here)
        if CONFIG_FILE in files and path != folder:
            found.append(path)
            dirs[:] = []  # nothing below a run is another run
            continue
        if len(path.parts) - root_depth >= depth:
            dirs[:] = []
        dirs.sort()
    return sorted(found)


def _refuse_a_folder_of_runs(run_dir: str) -> None:
    """A directory without ``config.yaml`` that holds runs: :class:`UsageError` listing them
    (one line each: path, status, steps) and how to pick one."""
    from pyflyt_cli.errors import UsageError
    from pyflyt_cli.training.rundir import CONFIG_FILE, RunDirError, read_state

    folder = Path(run_dir).expanduser()
    if not folder.is_dir() or folder.is_symlink() or (folder / CONFIG_FILE).exists():
        return
    runs = runs_inside(folder)
    if not runs:
        return
    lines = []
    for run in runs[:RUNS_LISTED]:
        try:
            state = read_state(run)
        except RunDirError:
            state = {}
        about = [str(state.get("status", "?"))]
        if "num_timesteps" in state:
            about.append(f"{state['num_timesteps']} steps")
        lines.append(f"  {run}  ({', '.join(about)})")
    if len(runs) > RUNS_LISTED:
        lines.append(f"  ... and {len(runs) - RUNS_LISTED} more")
    raise UsageError(
        f"{folder} is a folder of {len(runs)} run(s), not a run directory (it has no {CONFIG_FILE}):\n"
        + "\n".join(lines)
        + f"\npick one, e.g. pyflyt eval {runs[-1]}"
    )


def env_changes(overrides: list[str]) -> tuple[list[str], dict[str, object]]:
    """Split ``pyflyt eval <run>`` overrides into those of ``conf/eval.yaml`` and changes to
    the run's env: ``env.<key>=value`` (a top-level env key) and ``env.task.<option>=value``
    (a task option); values are read as YAML data (numbers, lists, names) by the bounded reader."""
    import yaml

    from pyflyt_cli.errors import UsageError
    from pyflyt_engine.safe_load import yaml_data

    evaluation: list[str] = []
    env: dict[str, object] = {}
    task: dict[str, object] = {}
    for item in overrides:
        key, _, value = item.lstrip("+").partition("=")
        if key == "env":
            raise UsageError(
                f"{item}: a trained run flies the env it was trained in; change one of its keys with env.<key>=value"
            )
        if not key.startswith("env."):
            evaluation.append(item)
            continue
        path = key.split(".")[1:]
        try:  # the bounded reader: an alias bomb or a deep nesting in a value is refused, not expanded
            parsed = yaml_data(value, source=f"{key}= (command line)", error=UsageError) if value else None
        except yaml.YAMLError as error:
            raise UsageError(f"{item}: the value is not YAML data ({error.__class__.__name__})") from None
        if len(path) == 1 and path[0] != "task":
            env[path[0]] = parsed
        elif len(path) == 2 and path[0] == "task":
            task[path[1]] = parsed
        else:
            raise UsageError(
                f"{item}: at evaluation a run's env takes env.<key>=value (a top-level key, e.g. env.wind=gust) "
                "or env.task.<option>=value; nested keys cannot be changed here"
            )
    if task:
        env["task"] = task
    return evaluation, env


#: eval keys that name a trained policy's file or sampling: an oracle has neither
POLICY_ONLY_KEYS = ("model", "deterministic", "trust_pickle")


def run_oracle_eval(name: str, overrides: list[str]) -> object:
    """``pyflyt eval oracle:<name> [overrides]``: fly the scripted oracle, print and return the report."""
    from pyflyt_cli.errors import UsageError
    from pyflyt_cli.training.compose import compose_train_data
    from pyflyt_cli.training.evaluate import evaluate_oracle
    from pyflyt_cli.training.schema import EvalOptions, parse_eval_options, parse_train_config
    from pyflyt_engine.envs import ENVS
    from pyflyt_engine.envs.oracles import ORACLES

    if name not in ORACLES:
        from pyflyt_engine.suggest import did_you_mean

        raise UsageError(
            f"unknown oracle {name!r} in oracle:{name}.{did_you_mean(name, ORACLES)} Oracles: {', '.join(sorted(ORACLES))}"
        )
    evaluation: list[str] = []
    training: list[str] = []
    for item in parse_overrides(overrides):
        key = item.lstrip("+~").partition("=")[0]
        if key in POLICY_ONLY_KEYS:
            raise UsageError(f"{key}= applies to a trained run, not to oracle:{name} (a scripted controller)")
        (evaluation if key in EvalOptions.model_fields else training).append(item)
    if not any(item.lstrip("+").partition("=")[0] == "env" for item in training):
        training.insert(0, f"env={getattr(ORACLES[name], 'env_config', None) or ENVS[ORACLES[name].env_ids[0]].config}")
    data, command = compose_train_data(training)
    if command.get("resume") is not None:
        raise UsageError(f"resume= continues a training run; oracle:{name} flies a scripted controller")
    cfg = parse_train_config(data, source=f"pyflyt eval oracle:{name} " + " ".join(training))
    options = parse_eval_options({**to_container(compose("eval", evaluation)), "deterministic": True})
    report = evaluate_oracle(name, cfg, options, run_dir=command.get("run_dir"))
    typer.echo(report.table())
    if report.recordings:
        typer.echo(f"replay:       pyflyt replay {report.recordings[0]}")
    return report
