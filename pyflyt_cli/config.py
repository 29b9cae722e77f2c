"""Hydra glue: compose configs from ``conf/`` with command-line overrides.

Library code never sees Hydra: the CLI composes a config here, converts it to plain
containers and calls plain functions.  Every Hydra/OmegaConf failure becomes a
:class:`CLIError` whose message names what is wrong and how to fix it.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from typing import Any

from omegaconf import DictConfig, OmegaConf

from pyflyt_engine.errors import PyFlytError
from pyflyt_engine.paths import conf_dir


class CLIError(PyFlytError):
    """A user error on the command line; printed without a traceback, exit code 2."""


def _group_choices(group: str) -> list[str]:
    path = conf_dir() / group
    return sorted(p.stem for p in path.glob("*.yaml")) if path.is_dir() else []


def compose(config_name: str, overrides: Sequence[str], *, return_hydra_config: bool = False) -> DictConfig:
    """Compose ``conf/<config_name>.yaml`` with Hydra overrides (``key=value`` ...).

    With ``return_hydra_config`` the result also holds ``hydra`` (e.g. the chosen option of
    each config group in ``hydra.runtime.choices``).
    """
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.errors import ConfigCompositionException, MissingConfigException, OverrideParseException
    from omegaconf.errors import OmegaConfBaseException

    overrides = _experiment_files(overrides)
    try:
        with initialize_config_dir(config_dir=str(conf_dir()), version_base="1.3"):
            return hydra_compose(
                config_name=config_name, overrides=list(overrides), return_hydra_config=return_hydra_config
            )
    except OverrideParseException as exc:
        raise CLIError(f"malformed override: {exc}. Overrides look like key=value, e.g. seed=3 or uav=quadx_f450") from None
    except MissingConfigException as exc:
        raise CLIError(_missing_message(exc)) from None
    except ConfigCompositionException as exc:
        cause = exc.__cause__ or exc
        message = _composition_message(str(cause), config_name)
        outer = str(exc).splitlines()[0] if str(exc) else ""
        if outer.startswith("Error merging override") and not message.startswith("unknown key"):
            message = f"cannot apply override {outer.removeprefix('Error merging override').strip()}: {message}"
        raise CLIError(message) from None
    except OmegaConfBaseException as exc:
        raise CLIError(f"invalid configuration: {exc}") from None


def _experiment_files(overrides: Sequence[str]) -> list[str]:
    """``experiment=path/to/study.yaml``: an experiment file outside ``conf/`` (e.g. in ``experiments/``).

    Hydra finds group options on its search path only, so the file is offered to it as
    ``experiment/<stem>.yaml`` of a private directory added to ``hydra.searchpath``.  It
    is read as YAML data like any config; its name must not shadow a shipped experiment.
    """
    import atexit
    import shutil
    import tempfile
    from pathlib import Path

    out = []
    for item in overrides:
        key, _, value = item.partition("=")
        if key.lstrip("+") != "experiment" or not value.endswith((".yaml", ".yml")):
            out.append(item)
            continue
        path = Path(value).expanduser()
        if not path.is_file():
            raise CLIError(f"experiment file {path} does not exist (or name a shipped one: {', '.join(_group_choices('experiment'))})")
        if path.stem in _group_choices("experiment"):
            raise CLIError(f"experiment file {path}: its name '{path.stem}' is a shipped experiment's; rename the file")
        folder = Path(tempfile.mkdtemp(prefix="pyflyt-experiment-"))
        atexit.register(shutil.rmtree, folder, True)
        (folder / "experiment").mkdir()
        shutil.copyfile(path, folder / "experiment" / f"{path.stem}.yaml")
        out += [f"{key}={path.stem}", f"hydra.searchpath=[file://{folder}]"]
    return out


def _missing_message(exc: Exception) -> str:
    options = getattr(exc, "options", None)
    missing = str(getattr(exc, "missing_cfg_file", None) or exc)
    group, _, choice = missing.rpartition("/")
    if options:
        close = difflib.get_close_matches(choice, options, n=1)
        hint = f" Did you mean '{close[0]}'?" if close else ""
        return f"unknown {group or 'config'} '{choice}'.{hint} Available: {', '.join(options)}"
    return str(exc).splitlines()[0]


def _composition_message(text: str, config_name: str) -> str:
    first = text.splitlines()[0]
    if "not in struct" in text or "Could not override" in text or "Could not append" in text:
        key = first.split("'")[1] if "'" in first else first
        full = [line.split("full_key:", 1)[1].strip() for line in text.splitlines() if "full_key:" in line]
        key = full[0] if full and full[0] else key
        return f"unknown key '{key}' for `{config_name}`: check the spelling, or add a new key with +{key}=value"
    return first


def to_container(cfg: DictConfig) -> dict[str, Any]:
    """Resolved plain-dict copy of a config (interpolations evaluated)."""
    try:
        return OmegaConf.to_container(cfg, resolve=True)  # type: ignore[return-value]
    except Exception as exc:  # omegaconf interpolation errors
        raise CLIError(f"cannot resolve the configuration: {exc}") from None


def parse_overrides(overrides: Sequence[str] | None) -> list[str]:
    """Overrides as given; rejects bare words that are not key=value."""
    result = []
    for item in overrides or []:
        if "=" not in item and not item.startswith("~"):
            raise CLIError(f"'{item}' is not an override: write key=value (e.g. duration=5)")
        result.append(item)
    return result


__all__ = ["CLIError", "compose", "parse_overrides", "to_container", "_group_choices"]
