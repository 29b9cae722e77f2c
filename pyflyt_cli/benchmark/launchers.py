"""Which Hydra launchers a benchmark may use, and the only settings it passes on to them.

:mod:`~pyflyt_cli.benchmark.plan` checks a benchmark's ``hydra/launcher=...`` and
``hydra.launcher.<key>=<value>`` overrides here before anything runs, and
:mod:`~pyflyt_cli.benchmark.launch` launches the runs; this module imports neither, so
the plan never depends on the code that runs it.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from typing import Any

from pyflyt_cli.errors import UsageError

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
        problem: str | None
        try:
            override = parser.parse_override(item)
        except HydraException:
            problem = "it is not a well-formed override"
        else:
            problem = _launcher_problem(override)
        if problem:
            names = "|".join(PLUGINS)
            raise UsageError(
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


#: launcher name -> (Hydra key, value): the setting :func:`plugin_overrides` adds unless the user gives it
PLUGIN_SETTINGS = {
    # hydra-ray-launcher 1.2.2 gives ray.init an object store of 75 MB unless the config names
    # one (a ``setdefault`` in hydra_plugins/hydra_ray_launcher/_core.py, ``launch``), and Ray
    # refuses any object_store_memory when ray.init joins a running cluster ("When connecting to
    # an existing cluster, object_store_memory must not be provided": ray/_private/worker.py,
    # ``init``, Ray 2.x), so hydra.launcher.ray.init.address=<cluster> failed before any run
    # started.  None passes both: a running cluster keeps its own object store, and a new local
    # instance is sized by Ray (a run returns one small exit code through it).
    "ray": ("hydra.launcher.ray.init.object_store_memory", "null"),
}


def plugin_overrides(hydra_overrides: Sequence[str]) -> list[str]:
    """The overrides ``pyflyt benchmark`` adds to the user's for the chosen launcher plugin to work.

    :data:`PLUGIN_SETTINGS`: each is left out when the user's overrides set that key themselves.
    """
    name = _chosen(hydra_overrides)
    if name not in PLUGIN_SETTINGS:
        return []
    key, value = PLUGIN_SETTINGS[name]
    given = {item.partition("=")[0].lstrip("+~") for item in hydra_overrides}
    return [] if key in given else [f"+{key}={value}"]


def launcher_name(hydra_overrides: Sequence[str]) -> str | None:
    """The ``hydra/launcher=<name>`` choice among the overrides (None: the local launcher)."""
    name = _chosen(hydra_overrides)
    if name is None and hydra_overrides:
        raise UsageError(
            f"{hydra_overrides[0]}: hydra.* overrides configure a Hydra launcher; choose one with "
            f"hydra/launcher=<{'|'.join(n for n in PLUGINS if n != 'basic')}>"
        )
    if name is not None:
        if name not in PLUGINS:
            raise UsageError(f"unknown launcher hydra/launcher={name}: choose one of {', '.join(PLUGINS)}")
        module, hint = PLUGINS[name]
        if importlib.util.find_spec(module.split(".")[0]) is None or (module != "hydra" and _missing(module)):
            raise UsageError(f"hydra/launcher={name} needs its Hydra plugin: {hint}")
    return name


def _chosen(hydra_overrides: Sequence[str]) -> str | None:
    """The last ``hydra/launcher=<name>`` value among the overrides, unchecked."""
    name = None
    for item in hydra_overrides:
        key, _, value = item.partition("=")
        if key.lstrip("+~") == "hydra/launcher":
            name = value
    return name


def _missing(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is None
    except ModuleNotFoundError:
        return True
