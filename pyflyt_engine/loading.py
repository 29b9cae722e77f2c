"""One way to load every kind of config, and one way to word what is wrong with it.

Airframes, env configs, reward presets, wind presets, randomize presets, search spaces,
training configs, benchmark sections and command options are all plain data checked by
a pydantic model.  Each kind is given the same three ways, and loaded here:

* a **shipped name** -- ``conf/<group>/<name>.yaml``, a plain name that never walks out
  of its group (``quadx_hover``, ``dryden_light``);
* a **YAML file** -- a value ending in ``.yaml``/``.yml`` or holding a path separator
  (a bare name that is not shipped but names a file here is that file), read by the
  bounded, data-only reader of :mod:`pyflyt_engine.safe_load`;
* a **mapping** (or an already validated model), from Python.

:func:`describe_error` words one pydantic error the same way for every kind -- where
(the keys as the user wrote them), what, the value given and how to fix it; an unknown
key with the closest allowed one and every key allowed there -- and :func:`validate`
lists every problem of a document under ``<source>: invalid <what>:``.
"""

from __future__ import annotations

import os
import types
import typing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from pyflyt_engine.errors import ConfigError, PyFlytError
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.safe_load import load_yaml_file, plain_name
from pyflyt_engine.suggest import did_you_mean

Model = TypeVar("Model", bound=BaseModel)

#: validation error type -> how to fix it (appended to messages)
FIX_HINTS = {
    "extra_forbidden": "remove it or check its spelling",
    "missing": "add it",
    "float_parsing": "give a number",
    "float_type": "give a number",
    "int_parsing": "give an integer",
    "bool_parsing": "give true or false",
    "list_type": "give a list, e.g. [1, 2, 3]",
    "tuple_type": "give a list, e.g. [1, 2, 3]",
    "literal_error": "use one of the allowed values",
    "too_short": "give the expected number of values",
    "too_long": "give the expected number of values",
    "greater_than": "give a larger value",
    "greater_than_equal": "give a larger value",
    "less_than": "give a smaller value",
    "less_than_equal": "give a smaller value",
    "union_tag_invalid": "use one of the allowed values",
    "finite_number": "give a real number (not .inf or .nan)",
}


# ------------------------------------------------------------------ the wording


def first_model(annotation: Any) -> Any:
    """The first pydantic model class in a type annotation (through unions, lists, ...)."""
    found = _models_in(annotation)
    return found[0] if found else None


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """Every pydantic model class in a type annotation, in order."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _union_members(annotation: Any) -> list[Any]:
    """The members of a union annotation (through ``Annotated``); [] for anything else."""
    if typing.get_origin(annotation) is typing.Annotated:
        return _union_members(typing.get_args(annotation)[0])
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return list(typing.get_args(annotation))
    return []


def _tags(member: Any) -> set[str]:
    """How pydantic names a union member in an error's location: its discriminator value
    (a one-value ``Literal`` field) for a tagged union, else its type's name."""
    names = {str(member), getattr(member, "__name__", "")}
    if isinstance(member, type) and issubclass(member, BaseModel):
        for field in member.model_fields.values():
            values = typing.get_args(field.annotation) if typing.get_origin(field.annotation) is typing.Literal else ()
            if len(values) == 1:
                names.add(str(values[0]))
    return names - {""}


def _walk(root: type[BaseModel], loc: tuple[Any, ...]) -> tuple[Any, list[Any]]:
    """The model holding the last key of ``loc``, and ``loc`` as the user wrote it (the
    members pydantic names inside a union, e.g. ``control.multirotor`` or ``seeds.int``, left out)."""
    model: Any = root
    annotation: Any = None
    written: list[Any] = []
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        members = _union_members(annotation)
        member = next((m for m in members if isinstance(part, str) and part in _tags(m)), None)
        if member is not None and not (model is not None and part in model.model_fields):
            # a union's member: not a key the user wrote
            annotation = member
            models = _models_in(member)
            model = models[0] if models else None
            continue
        written.append(part)
        if last or isinstance(part, int):
            continue
        field = model.model_fields.get(part) if model is not None else None
        if field is None:  # a mapping's key (terms.<entry>): stay on the value's model
            continue
        annotation = field.annotation
        model = first_model(annotation)
    return model, written


def describe_error(root: type[BaseModel], error: Mapping[str, Any], prefix: str = "") -> str:
    """One pydantic error of validating ``root``, in one line: where, what, the value, the fix.

    ``prefix`` goes before the location (``task.``, ``wind.``, ``algo.``).
    """
    loc = tuple(error["loc"])
    model, written = _walk(root, loc)
    where = prefix + (".".join(str(p) for p in written) or "(top level)")
    kind = error["type"]
    if kind == "extra_forbidden":
        allowed = sorted(k for k in (model.model_fields if model is not None else {}) if k != "source")
        key = str(loc[-1])
        hint = did_you_mean(key, allowed)
        return f"{where}: unknown key '{key}'.{hint} Allowed keys here: {', '.join(allowed)}"
    message = str(error["msg"]).removeprefix("Value error, ")
    value = error.get("input")
    shown = "" if kind == "missing" or isinstance(value, dict) or "got" in message else f" (got {value!r})"
    fix = FIX_HINTS.get(kind)
    return f"{where}: {message}{shown}" + (f"; fix: {fix}" if fix else "")


def problems(root: type[BaseModel], exc: ValidationError, prefix: str = "") -> list[str]:
    """Every error of ``exc`` in one line each (:func:`describe_error`), each once."""
    lines: list[str] = []
    for error in exc.errors():
        line = describe_error(root, error, prefix)
        if line not in lines:
            lines.append(line)
    return lines


def problem_list(lines: list[str]) -> str:
    """Problems as the indented list that follows ``<source>: invalid <what>:``."""
    return "\n".join(f"  - {line}" for line in lines)


def check(
    model: type[Model], data: Any, prefix: str = "", *, context: dict[str, Any] | None = None
) -> tuple[Model | None, list[str]]:
    """(``data`` validated as ``model``, []) or (None, one line per problem): for a kind that
    collects the problems of several parts before it reports them."""
    try:
        return model.model_validate(data, context=context), []
    except ValidationError as exc:
        return None, problems(model, exc, prefix)


def validate(
    model: type[Model],
    data: Any,
    what: str,
    source: str,
    *,
    prefix: str = "",
    error: type[PyFlytError] = ConfigError,
    context: dict[str, Any] | None = None,
) -> Model:
    """``data`` validated as ``model``; otherwise ``error``: ``<source>: invalid <what>:`` and
    every problem on its own line (key, value, fix)."""
    try:
        return model.model_validate(data, context=context)
    except ValidationError as exc:
        raise error(f"{source}: invalid {what}:\n" + problem_list(problems(model, exc, prefix))) from None


# ------------------------------------------------------------------ the loader


#: a shipped file whose name starts with this is a **base**: a part other configs of its group
#: start from (``defaults: [_base, ...]``), not a config to pick (``conf/env/_base.yaml``)
BASE_PREFIX = "_"


def is_base(name: str) -> bool:
    """Whether a shipped name is a base (:data:`BASE_PREFIX`): listed, loaded and chosen only as a
    ``defaults`` entry of another config, never on its own."""
    return name.startswith(BASE_PREFIX) and name != "_self_"


def available(group: str) -> list[str]:
    """Names of the shipped configs of a group (``conf/<group>/*.yaml``), the bases left out."""
    return sorted(p.stem for p in (conf_dir() / group).glob("*.yaml") if not is_base(p.stem))


def bases(group: str) -> list[str]:
    """Names of the shipped bases of a group (``conf/<group>/_*.yaml``): what its configs start from."""
    return sorted(p.stem for p in (conf_dir() / group).glob(f"{BASE_PREFIX}*.yaml"))


def names_file(value: str | Path) -> bool:
    """Whether ``value`` is given as a file (a ``.yaml``/``.yml`` name or a path) rather than a name."""
    text = str(value)
    return text.endswith((".yaml", ".yml")) or "/" in text or os.sep in text


def unknown_name(
    value: Any, choices: list[str], what: str, shipped: str = "Shipped", files: str = "or give a .yaml path"
) -> str:
    """``unknown <what> '<value>'. Did you mean '...'? <shipped>: ...; <files>``."""
    hint = did_you_mean(str(value), choices)
    tail = f"; {files}" if files else ""
    return f"unknown {what} '{value}'.{hint} {shipped}: {', '.join(choices)}{tail}"


def resolve(
    value: str | Path,
    group: str,
    *,
    what: str,
    error: type[PyFlytError] = ConfigError,
    unknown: Callable[[str | Path], str] | None = None,
    files: bool = True,
    base: bool = False,
) -> Path:
    """The file ``value`` names: a shipped name of ``conf/<group>`` or, with ``files``, a YAML path.

    A shipped name comes first, so a file or directory of that name in the working
    directory cannot shadow it; a name never leaves ``conf/<group>``.  A base's name
    (:func:`is_base`) is taken only with ``base`` (a ``defaults`` entry).

    Raises:
        error: no such file (``<path>: no such <what> file; check the path``), an unknown
            name (``unknown(value)``, or a message listing the shipped names), or a base
            named as a config of its own.
    """
    if files and names_file(value):
        path = Path(value).expanduser()
        if not path.is_file():
            raise error(f"{path}: no such {what} file; check the path")
        return path
    shipped = conf_dir() / group / f"{value}.yaml"
    if plain_name(str(value)) and shipped.is_file():
        if is_base(str(value)) and not base:
            raise error(base_named(str(value), group))
        return shipped
    if files and Path(value).is_file():
        return Path(value)
    message = unknown(value) if unknown is not None else unknown_name(value, available(group), what)
    raise error(message)


def base_named(name: str, group: str) -> str:
    """The message for a base (:func:`is_base`) named where a config of its own is wanted."""
    return (
        f"'{name}' is a base (conf/{group}/{name}.yaml): a part other {group} configs start from with "
        f"'defaults: [{name}, _self_]', not a config to load on its own; pick one of: "
        f"{', '.join(available(group))}"
    )


#: how many files deep a variant may build on variants (a -> b -> c ...)
MAX_VARIANT_DEPTH = 8


def with_defaults(
    data: Mapping[str, Any],
    group: str,
    source: str,
    *,
    error: type[PyFlytError] = ConfigError,
    _chain: tuple[str, ...] = (),
) -> dict[str, Any]:
    """``data`` with its ``defaults`` list resolved: a **variant** of shipped configs of the same group.

    A config file may start from others of its group and change some keys, in Hydra's own
    syntax, so that the file composes the same through ``pyflyt train env=<name>`` (Hydra) and
    through :func:`load` (``make_env``, a path, a mapping)::

        defaults:
          - quadx_gates      # conf/env/quadx_gates.yaml ...
          - _self_           # ... with this file's keys over it
        camera_observation: null
        task: {observation: corners}

    The entries are names of ``conf/<group>`` -- its configs and its bases (``_base``, ...:
    :func:`is_base`, parts no one picks on their own) -- and ``_self_`` (the file's own keys;
    last when not listed, as in Hydra).  Later entries override earlier ones: mappings merge
    key by key, anything else (a list, a number, ``null``) replaces; a key cannot be removed,
    so a base holds only keys every config starting from it gives.  Only names are taken -- a
    file names no path and runs nothing -- and a chain is at most :data:`MAX_VARIANT_DEPTH`
    deep, with no loop.
    """
    if "defaults" not in data:
        return dict(data)
    own = {k: v for k, v in data.items() if k != "defaults"}
    entries = data["defaults"]
    if not isinstance(entries, list) or not all(isinstance(e, str) for e in entries):
        raise error(
            f"{source}: defaults must be a list of {group} config names (and _self_), e.g. "
            f"[{next(iter(available(group)), 'name')}, _self_]; got {entries!r}"
        )
    if "_self_" not in entries:
        entries = [*entries, "_self_"]
    merged: dict[str, Any] = {}
    for entry in entries:
        if entry == "_self_":
            part = own
        else:
            if not plain_name(entry):
                raise error(
                    f"{source}: defaults entry {entry!r} is not a name: a variant starts from shipped "
                    f"{group} configs by name ({', '.join(bases(group) + available(group))})"
                )
            if entry in _chain or len(_chain) >= MAX_VARIANT_DEPTH:
                loop = " -> ".join((*_chain, entry))
                raise error(f"{source}: defaults {loop}: a loop or a chain deeper than {MAX_VARIANT_DEPTH} files")
            try:
                path = resolve(
                    entry,
                    group,
                    what=f"{group} config",
                    error=error,
                    files=False,
                    base=True,
                    unknown=lambda name: unknown_name(
                        name, bases(group) + available(group), f"{group} config", files=""
                    ),
                )
            except PyFlytError as exc:
                raise error(f"{source}: defaults entry {entry!r}: {exc}") from None
            part = with_defaults(
                load_yaml_file(path, what=f"{group} config file", error=error),
                group,
                str(path),
                error=error,
                _chain=(*_chain, entry),
            )
        merged = _merged(merged, part)
    return merged


def _merged(base: Mapping[str, Any], top: Mapping[str, Any]) -> dict[str, Any]:
    """``top`` over ``base``: mappings key by key, anything else replaced."""
    out = dict(base)
    for key, value in top.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merged(out[key], value)
        else:
            out[key] = value
    return out


def composed(value: str | Path, group: str, *, what: str, error: type[PyFlytError] = ConfigError) -> dict[str, Any]:
    """The plain data of a shipped name of ``conf/<group>`` or a YAML file, its ``defaults`` list
    resolved (:func:`with_defaults`): every key the config gives, none of a model's defaults --
    what :func:`load` validates, e.g. to adjust a shipped config before loading it."""
    path = resolve(value, group, what=what, error=error)
    data = load_yaml_file(path, what=f"{what} file", error=error)
    if not isinstance(data, Mapping):
        raise error(f"{path}: a {group} config is a mapping of keys to values, got {type(data).__name__}")
    return with_defaults(data, group, str(path), error=error)


def load(
    value: Any,
    *,
    group: str,
    model: type[Model],
    parse: Callable[..., Model],
    what: str,
    error: type[PyFlytError] = ConfigError,
    unknown: Callable[[str | Path], str] | None = None,
    files: bool = True,
) -> Model:
    """A validated ``model`` from a shipped name of ``conf/<group>``, a YAML path, a mapping or a model.

    ``parse(data, source, name)`` validates the data of a file or a mapping (the kind's own
    steps, e.g. a wind preset's ``preset:`` base, then :func:`validate`); a file's name is
    its stem, a mapping's ``inline``.
    """
    if isinstance(value, model):
        return value
    if isinstance(value, Mapping):
        return parse(value, "<dict>", "inline")
    if not isinstance(value, (str, Path)):
        raise error(f"{what} must be a name ({', '.join(available(group))}), a .yaml path or a mapping, got {value!r}")
    path = resolve(value, group, what=what, error=error, unknown=unknown, files=files)
    return parse(load_yaml_file(path, what=f"{what} file", error=error), str(path), path.stem)


__all__ = [
    "BASE_PREFIX",
    "FIX_HINTS",
    "available",
    "base_named",
    "bases",
    "check",
    "composed",
    "describe_error",
    "first_model",
    "is_base",
    "load",
    "names_file",
    "problem_list",
    "problems",
    "resolve",
    "unknown_name",
    "validate",
    "with_defaults",
]
