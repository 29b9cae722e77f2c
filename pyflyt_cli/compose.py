"""Compose configs from ``conf/`` with Hydra overrides (``key=value``): the library's one door to Hydra.

The training library (:mod:`pyflyt_cli.training.compose`), ``pyflyt tune``, the zoo and the
benchmark compose here and go on with plain containers; the command line calls the same
functions.  Only Hydra's public API is used (its compose API, the override parser), and
every Hydra/OmegaConf failure becomes a :class:`~pyflyt_cli.errors.UsageError` whose
message names what is wrong and how to fix it.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml
from omegaconf import DictConfig, OmegaConf

from pyflyt_cli.errors import UsageError
from pyflyt_engine.loading import base_named, is_base, names_file
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.suggest import closest, did_you_mean


def group_choices(group: str) -> list[str]:
    """The shipped options of a config group (``conf/<group>/*.yaml``), by name; its bases
    (``conf/env/_base.yaml``: parts other options start from, :func:`~pyflyt_engine.loading.is_base`)
    are no options."""
    path = conf_dir() / group
    return sorted(p.stem for p in path.glob("*.yaml") if not is_base(p.stem)) if path.is_dir() else []


def compose(config_name: str, overrides: Sequence[str], *, return_hydra_config: bool = False) -> DictConfig:
    """Compose ``conf/<config_name>.yaml`` with Hydra overrides (``key=value`` ...).

    With ``return_hydra_config`` the result also holds ``hydra`` (e.g. the chosen option of
    each config group in ``hydra.runtime.choices``).
    """
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.errors import ConfigCompositionException, MissingConfigException, OverrideParseException
    from omegaconf.errors import OmegaConfBaseException

    _checkgroup_choices(overrides)
    _check_no_interpolation(overrides)
    overrides, copies = _group_files(overrides)
    try:
        with initialize_config_dir(config_dir=str(conf_dir()), version_base="1.3"):
            return hydra_compose(
                config_name=config_name, overrides=list(overrides), return_hydra_config=return_hydra_config
            )
    except yaml.YAMLError as exc:  # a config file of conf/ (experiment files given by path are read first)
        mark = getattr(exc, "problem_mark", None)
        name = getattr(mark, "name", None) or "a config file"
        raise UsageError(yaml_problem(exc, copies.get(name, name))) from None
    except UnicodeDecodeError as exc:
        raise UsageError(f"a config file under {conf_dir()} is not UTF-8 text ({exc}); reinstall the package") from None
    except OverrideParseException as exc:
        raise UsageError(
            f"malformed override: {exc}. Overrides look like key=value, e.g. seed=3 or uav=quadx_f450"
        ) from None
    except MissingConfigException as exc:
        raise UsageError(_missing_message(exc)) from None
    except ConfigCompositionException as exc:
        cause = exc.__cause__ or exc
        message = _suggest_key(_composition_message(str(cause), config_name), config_name, overrides)
        outer = str(exc).splitlines()[0] if str(exc) else ""
        if outer.startswith("Error merging override") and not message.startswith("unknown key"):
            message = f"cannot apply override {outer.removeprefix('Error merging override').strip()}: {message}"
        raise UsageError(message) from None
    except OmegaConfBaseException as exc:
        raise UsageError(f"invalid configuration: {exc}") from None


def _checkgroup_choices(overrides: Sequence[str]) -> None:
    """``algo=null``: a config group is left out with ``~group``, never set to null; ``env=_base``:
    a base is a part the group's configs start from, never chosen itself (Hydra would compose it)."""
    for item in overrides:
        key, sep, value = item.partition("=")
        group = key.lstrip("+")
        if not sep or not (conf_dir() / group).is_dir():
            continue
        if value.strip().lower() == "null":
            choices = ", ".join(group_choices(group))
            raise UsageError(
                f"'{item}': a config group takes a name ({choices}); to leave an optional one out, write ~{group}"
            )
        if is_base(value.strip()) and (conf_dir() / group / f"{value.strip()}.yaml").is_file():
            raise UsageError(f"'{item}': {base_named(value.strip(), group)}")


def _check_no_interpolation(overrides: Sequence[str]) -> None:
    """A command-line value is data: ``${...}`` in it would be resolved by OmegaConf's resolvers
    (``${now:...}`` reads the clock, ``${oc.env:...}`` the environment, into a run's saved config;
    ``${eval:...}`` ended in a traceback).  Interpolations belong in config files."""
    for item in overrides:
        key, sep, value = item.partition("=")
        if sep and "${" in value:
            raise UsageError(
                f"'{item}': a command-line value holds no ${{...}} interpolation (it would be resolved by "
                f"OmegaConf, reading the clock or the environment); give {key.lstrip('+~')} its value itself"
            )


#: config groups whose choice may also be the path of a YAML file (``experiment=study.yaml``,
#: ``uav=my_hexacopter.yaml``)
FILE_GROUPS = ("experiment", "uav")


def airframe_file(value: str, key: str = "uav") -> Path:
    """The airframe file given as ``<key>=<value>`` (``uav=`` or ``env.uav=``), absolute, after checking it.

    Raises:
        UsageError: no such file (the message gives the absolute path looked at).
        SpecError: the file is not a valid airframe (the message names the file, the field and the fix).
    """
    from pyflyt_engine.spec import available_uavs, load_uav_spec

    path = Path(value).expanduser()
    if not path.is_file():
        what = "is a directory, not an airframe file" if path.is_dir() else "no such airframe file"
        raise UsageError(
            f"{key}={value}: {what} ({path.absolute()}); give the path of a .yaml airframe (relative to "
            f"{Path.cwd()} or absolute), or a shipped airframe: {', '.join(available_uavs())}"
        )
    load_uav_spec(path)
    return path.resolve()


def hydra_value(value: str) -> str:
    """``value`` as a Hydra override reads it back as that string (quoted when needed)."""
    if re.fullmatch(r"[A-Za-z0-9_/.@%:+\-]+", value) and value[0] not in "+-":
        return value
    if "\\" in value or "${" in value:
        raise UsageError(f"{value!r} holds a backslash or '${{', which an override cannot carry; rename or move it")
    return "'" + value.replace("'", "\\'") + "'"


def override_value(value: Any) -> str:
    """A value in Hydra's override grammar: ``0.001``, ``true``, ``[64,64]``, ``{pi:[64],qf:[256]}``,
    ``null``; strings double-quoted (``"relu"``)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(override_value(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ",".join(f"{k}:{override_value(v)}" for k, v in value.items()) + "}"
    return json.dumps(str(value))


def absolute_airframes(overrides: Sequence[str], *, into_env: bool = False) -> list[str]:
    """``uav=<path>`` and ``env.uav=<path>`` with the path checked and made absolute.

    So a command line means the same from any working directory (a benchmark's runs, a
    launcher's jobs).  With ``into_env`` (training, where the airframe is the env's),
    ``uav=<path>`` becomes ``env.uav=<path>``.  Shipped names pass unchanged.
    """
    out = []
    for item in overrides:
        key, sep, value = item.partition("=")
        bare = key.lstrip("+")
        if sep and bare in ("uav", "env.uav") and not key.startswith("~") and names_file(value):
            path = hydra_value(str(airframe_file(value, bare)))
            key = "env.uav" if into_env else key
            item = f"{key}={path}"
        out.append(item)
    return out


def _group_files(overrides: Sequence[str]) -> tuple[list[str], dict[str, str]]:
    """``experiment=path/to/study.yaml``, ``uav=path/to/airframe.yaml``: an option given as a file.

    Hydra finds group options on its search path only, so the file is offered to it as
    ``<group>/<name>.yaml`` of a private directory added to ``hydra.searchpath``.  It is
    read first as plain YAML data (:func:`read_yaml_data`: a ``!!python/...`` tag is refused,
    never run; so are a special file, an oversized file and an alias-expansion bomb), so a
    problem is reported against the file given.  An experiment file's name must not shadow
    a shipped experiment; an airframe file is validated as one and offered as
    ``<stem>.file``, a name no shipped airframe has (``conf/`` comes first on the search
    path).  Returns the overrides and {copy: file given}.
    """
    import atexit
    import shutil
    import tempfile

    out: list[str] = []
    copies: dict[str, str] = {}
    folder: Path | None = None
    for item in overrides:
        key, _, value = item.partition("=")
        group = key.lstrip("+")
        if group not in FILE_GROUPS or not names_file(value):
            out.append(item)
            continue
        if group == "experiment":
            path = Path(value).expanduser()
            shipped = ", ".join(group_choices("experiment"))
            if not value.endswith((".yaml", ".yml")):
                raise UsageError(
                    f"experiment={value}: an experiment file must be a .yaml file (or name a shipped one: {shipped})"
                )
            if not path.is_file():
                raise UsageError(f"experiment file {path} does not exist (or name a shipped one: {shipped})")
            if path.stem in group_choices("experiment"):
                raise UsageError(
                    f"experiment file {path}: its name '{path.stem}' is a shipped experiment's; rename the file"
                )
            read_yaml_data(path)
            option = path.stem
        else:
            path = airframe_file(value, group)
            option = re.sub(r"[^A-Za-z0-9_-]", "_", path.stem) + ".file"
        if folder is None:
            folder = Path(tempfile.mkdtemp(prefix="pyflyt-files-"))
            atexit.register(shutil.rmtree, folder, True)
            out.append(f"hydra.searchpath=[file://{folder}]")
        (folder / group).mkdir(exist_ok=True)
        copy = folder / group / f"{option}.yaml"
        shutil.copyfile(path, copy)
        copies[str(copy)] = str(path)
        out.append(f"{key}={option}")
    return out, copies


def read_yaml_data(path: Path) -> Any:
    """The plain data of a YAML file (the bounded reader of :mod:`pyflyt_engine.safe_load`: no tags,
    no special files, no alias-expansion bombs); :class:`UsageError` naming the file otherwise."""
    from pyflyt_engine.safe_load import MAX_YAML_BYTES, read_text, yaml_data

    text = read_text(path, what="YAML file", error=UsageError, limit=MAX_YAML_BYTES)
    try:
        return yaml_data(text, source=str(path), error=UsageError)
    except yaml.YAMLError as exc:
        raise UsageError(yaml_problem(exc, str(path))) from None


def yaml_problem(exc: yaml.YAMLError, path: str) -> str:
    """What is wrong with a YAML file, with its line; a Python tag is named as such."""
    mark = getattr(exc, "problem_mark", None)
    where = f"{path}, line {mark.line + 1}" if mark is not None else path
    problem = str(getattr(exc, "problem", None) or exc).splitlines()[0]
    if isinstance(exc, yaml.constructor.ConstructorError) and "tag" in problem:
        tag = problem.split("'")[1] if problem.count("'") >= 2 else problem
        tag = tag.replace("tag:yaml.org,2002:", "!!")
        return (
            f"{where}: the YAML tag {tag} is not allowed: config files are plain data (mappings, lists, "
            "numbers, strings) and nothing in them is ever run; remove the tag"
        )
    return f"{where}: not valid YAML: {problem}"


def _missing_message(exc: Exception) -> str:
    options = getattr(exc, "options", None)
    missing = str(getattr(exc, "missing_cfg_file", None) or exc)
    group, _, choice = missing.rpartition("/")
    options = [o for o in options or [] if not is_base(o)]  # Hydra lists the group's bases too
    if options:
        hint = did_you_mean(choice, options)
        file_hint = "; or give the path of a .yaml file" if group in FILE_GROUPS else ""
        return f"unknown {group or 'config'} '{choice}'.{hint} Available: {', '.join(options)}{file_hint}"
    return str(exc).splitlines()[0]


def _composition_message(text: str, config_name: str) -> str:
    first = text.splitlines()[0]
    if "not in struct" in text or "Could not override" in text or "Could not append" in text:
        key = first.split("'")[1] if "'" in first else first
        full = [line.split("full_key:", 1)[1].strip() for line in text.splitlines() if "full_key:" in line]
        key = full[0] if full and full[0] else key
        # no `+key=value` hint: every config is validated against its schema, which refuses a new key
        return f"unknown key '{key}' for `{config_name}`: check the spelling"
    return first


def _suggest_key(message: str, config_name: str, overrides: Sequence[str]) -> str:
    """An unknown-key message with "Did you mean ...?" (:func:`pyflyt_engine.suggest.closest`)
    and the keys beside the misspelt one, read from the config composed without it."""
    if not message.startswith("unknown key '"):
        return message
    key = message.split("'")[1]
    parent, _, leaf = key.rpartition(".")

    def names(o: str) -> bool:  # the override of the key itself, or of a key below it (trian.seed=1)
        given = o.lstrip("+~").partition("=")[0]
        return given == key or given.startswith(key + ".")

    rest = [o for o in overrides if not names(o)]
    try:
        node: Any = compose(config_name, rest)
        for part in parent.split(".") if parent else []:
            node = node[part]
    except (UsageError, KeyError, TypeError):
        return message
    if not isinstance(node, DictConfig):
        return message
    keys = [str(k) for k in node]
    meant_leaf = closest(leaf, keys)
    hint = ""
    if meant_leaf is not None:
        meant = (parent + "." if parent else "") + meant_leaf
        given = [o.lstrip("+~").partition("=") for o in overrides if names(o)]
        use = f"{meant}{given[0][0][len(key) :]}={given[0][2]}" if given else f"{meant}=<value>"
        hint = f" Did you mean '{meant}'? Use {use}."
    tail = ". `pyflyt train --cfg` prints every key with its value" if config_name == "train" else ""
    return message.replace(": check the spelling", f":{hint} Keys here: {', '.join(keys)}{tail}", 1)


def to_container(cfg: DictConfig) -> dict[str, Any]:
    """Resolved plain-dict copy of a config (interpolations evaluated)."""
    try:
        return OmegaConf.to_container(cfg, resolve=True)  # type: ignore[return-value]
    except Exception as exc:  # omegaconf interpolation errors
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UsageError(f"cannot resolve the configuration: {first}") from None


__all__ = [
    "FILE_GROUPS",
    "absolute_airframes",
    "airframe_file",
    "compose",
    "group_choices",
    "hydra_value",
    "names_file",
    "override_value",
    "read_yaml_data",
    "to_container",
    "yaml_problem",
]
