"""The training configuration as ``pyflyt train`` composes it: ``conf/train.yaml`` + overrides.

The one place a training config is put together, for the CLI and for Python alike::

    from pyflyt_cli.training import compose_config, train
    cfg = compose_config(env="quadx_waypoints", algo="sac", overrides=["seed=3"])
    train(cfg)

Every default value lives in ``conf/`` (``train.yaml``, ``algo/``, ``hparams/``, ``env/`` ...);
the schema (:mod:`.schema`) only validates.  Hydra is used through its compose API
(:func:`pyflyt_cli.compose.compose`): it never changes the working directory and writes
nothing.  This is the only Hydra-aware module of :mod:`pyflyt_cli.training`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pyflyt_cli.compose import group_choices, absolute_airframes, compose, to_container
from pyflyt_cli.errors import UsageError
from pyflyt_cli.training.schema import OPT_INS, TrainConfig, parse_train_config
from pyflyt_engine.paths import conf_dir

#: top-level keys of ``conf/train.yaml`` that tell ``pyflyt train`` what to do, not what to train
COMMAND_KEYS = ("resume", "run_dir")


def compose_config(env: str | None = None, algo: str | None = None, overrides: Sequence[str] = ()) -> TrainConfig:
    """The validated :class:`TrainConfig` that ``pyflyt train [env=<env>] [algo=<algo>] <overrides>`` trains.

    Args:
        env: an env config of ``conf/env`` (default: ``conf/train.yaml``'s).
        algo: an algorithm config of ``conf/algo`` (default: ``conf/train.yaml``'s).
        overrides: Hydra overrides, as on the command line (``"train.total_timesteps=5e4"``,
            ``"experiment=smoke"``).

    Raises :class:`~pyflyt_cli.compose.UsageError` or :class:`~pyflyt_engine.errors.ConfigError`
    with a message naming the problem.
    """
    given = [*([f"env={env}"] if env else []), *([f"algo={algo}"] if algo else []), *overrides]
    cfg, command = _compose(given)
    for key, value in command.items():
        if value is not None:
            raise UsageError(
                f"{key}={value} tells pyflyt train what to do, it is not part of a configuration "
                "(from Python: train(cfg, run_dir=...), resume(run_dir))"
            )
    return cfg


def compose_run(overrides: Sequence[str]) -> tuple[TrainConfig, Path | None]:
    """``pyflyt train <overrides>`` (no ``resume=``): the validated config and the ``run_dir=`` it names (or None)."""
    cfg, command = _compose(overrides)
    run_dir = command["run_dir"]
    return cfg, None if run_dir is None else Path(str(run_dir)).expanduser()


def _compose(overrides: Sequence[str]) -> tuple[TrainConfig, dict[str, Any]]:
    data, command = compose_train_data(overrides)
    source = "pyflyt train " + " ".join(overrides) if overrides else "pyflyt train"
    return parse_train_config(data, source=source), command


def compose_train_data(overrides: Sequence[str], benchmark: bool = False) -> tuple[dict[str, Any], dict[str, Any]]:
    """(training config as plain data, ready for :func:`parse_train_config`; the command keys).

    An experiment may declare a ``benchmark:`` section (a grid of runs for ``pyflyt
    benchmark``); with ``benchmark`` it is kept in the data, otherwise it is refused.
    """
    from omegaconf import OmegaConf, open_dict

    overrides = absolute_airframes(overrides, into_env=True)
    for item in overrides:
        if item.lstrip("+~").startswith(("hydra.", "hydra/")):
            raise UsageError(
                f"'{item}': pyflyt train takes no Hydra settings (Hydra only composes conf/train.yaml here); "
                "give config keys (key=value), and launcher settings to pyflyt benchmark"
            )
    overrides, replaced = _whole_value_overrides(overrides)
    cfg = compose("train", overrides, return_hydra_config=True)  # an unknown key's message names the closest
    choices = dict(cfg.hydra.runtime.choices)
    with open_dict(cfg):
        del cfg["hydra"]
    missing = sorted(OmegaConf.missing_keys(cfg))
    if missing:
        origin = f" (required by experiment={choices['experiment']})" if choices.get("experiment") else ""
        raise UsageError(
            f"{', '.join(missing)} must be given{origin}: add " + " ".join(f"{k}=<value>" for k in missing)
        )
    data = to_container(cfg)
    given = {item.lstrip("+~").partition("=")[0] for item in overrides}
    for key in OPT_INS:
        if data.get(key) and key not in given:
            origin = f"experiment={choices['experiment']}" if choices.get("experiment") else "a config file"
            raise UsageError(
                f"{key} is set by {origin}: an opt-in to load pickled files is taken from the command line only, "
                f"never from a file; give {key}=true on the command line if you made those files yourself"
            )
    for key, value in replaced.items():  # the command line's value, not merged into the tuning's
        *parents, leaf = key.split(".")
        node = data
        for part in parents:
            node = node[part]
        node[leaf] = value
    command = {key: data.pop(key, None) for key in COMMAND_KEYS}
    section = data.pop("benchmark", None)
    if section is not None and not benchmark and command["run_dir"] is None:
        # one run of a benchmark names its run directory (the lines pyflyt benchmark --dry-run prints)
        name = choices.get("experiment")
        raise UsageError(
            f"experiment={name} declares a benchmark (a grid of envs x algorithms x seeds): run it with "
            f"pyflyt benchmark experiment={name} (--dry-run prints one pyflyt train line per run)"
        )
    env_name = choices.get("env")
    if not isinstance(data.get("env"), dict):
        raise UsageError("no environment selected: pass env=<name> (" + ", ".join(group_choices("env")) + ")")
    env = dict(data["env"])
    uav_choice = choices.get("uav")
    uav = data.pop("uav", None)
    if uav_choice:
        shipped = OmegaConf.to_container(OmegaConf.load(conf_dir() / "uav" / f"{uav_choice}.yaml"), resolve=True)
        if uav != shipped:
            raise UsageError(
                f"uav.* keys cannot be overridden in training (uav={uav_choice} names a shipped airframe); "
                "write your airframe to a file and pass env.uav=path/to/airframe.yaml"
            )
        env["uav"] = uav_choice
    reward_choice = choices.get("reward")
    reward = data.pop("reward", None)
    if reward_choice:
        env["reward"] = {**(reward or {}), "name": reward_choice}
    data["env"] = env
    data["env_name"] = data.get("env_name") or env_name
    data["experiment"] = choices.get("experiment")
    if benchmark and section is not None:
        data["benchmark"] = section
    return data, command


#: keys whose ``key=value`` override replaces the value as a whole: Hydra merges a mapping
#: given on the command line into the one a tuning set (``train.curriculum={num_targets:...}``
#: would keep the tuning's ``goal_reach_distance`` schedule beside it, or fail on a key the
#: tuning's mapping lacks).  ``key.field=value`` still changes one field of the tuning's.
WHOLE_VALUE_KEYS = ("train.curriculum",)


def _whole_value_overrides(overrides: Sequence[str]) -> tuple[list[str], dict[str, Any]]:
    """(the overrides Hydra composes, {key: value} of the :data:`WHOLE_VALUE_KEYS` ones, set after)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    kept, replaced = [], {}
    for item in overrides:
        key, sep, _ = item.partition("=")
        if not sep or key not in WHOLE_VALUE_KEYS:
            kept.append(item)
            continue
        try:
            value = OverridesParser.create().parse_overrides([item])[0].value()
        except HydraException as exc:
            raise UsageError(f"'{item}': cannot read the value: {exc}") from None
        replaced[key] = _plain(value)
    return kept, replaced


def _plain(value: Any) -> Any:
    """A parsed override value as plain dicts, lists and scalars."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value
