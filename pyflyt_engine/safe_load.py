"""Bounded, data-only readers for files that may come from someone else.

A run directory, a recording, an airframe or a benchmark can be shared, so every file
read from one is hostile input until checked.  The readers here are the only ones the
package uses for YAML and JSON documents (configs, airframes, ``state.json``, ``plan.json``,
the JSON metadata of an MCAP recording):

* **special files are refused before they are read**: a FIFO, a device or a socket is
  not a document (reading one may block for ever or never end);
* **size is bounded**: a document larger than its limit (:data:`MAX_YAML_BYTES`,
  :data:`MAX_DOCUMENT_BYTES` for JSON) is refused by its byte length, before it is parsed;
* **YAML aliases cannot multiply a document**: the composed nodes are counted with every
  alias expanded (a "billion laughs" document is a few hundred bytes that expand to 10^9
  values); more than :data:`MAX_NODES` values, nesting deeper than :data:`MAX_DEPTH` or a
  value that contains itself is refused before anything is constructed;
* **JSON is bounded alike**: size, values and nesting depth;
* **a key given twice is refused**, in YAML and in JSON (:func:`json_loads`): readers
  disagree on which of the two counts (Python's keeps the last), so a second entry could
  make a file say one thing to a person or another tool and another to this package;
* YAML goes through ``yaml.SafeLoader``: tags that would construct Python objects are
  refused, so loading never runs code.

Each refusal is a :class:`~pyflyt_engine.errors.PyFlytError` (the caller chooses which)
whose message names the file and the limit.  Syntax errors are left to the caller, which
knows how to word them: :func:`yaml_data` raises ``yaml.YAMLError``, :func:`json_data`
``ValueError``.
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
from pathlib import Path
from typing import Any

import yaml

from pyflyt_engine.errors import ConfigError, PyFlytError

#: the largest JSON document read [bytes]
MAX_DOCUMENT_BYTES = 1 << 20
#: the largest YAML document read [bytes]: the largest shipped config is a few kB, and a
#: YAML parser written in Python takes seconds per megabyte
MAX_YAML_BYTES = 256 << 10
#: the most values (mappings, lists, scalars, keys) one document may hold, aliases expanded
MAX_NODES = 100_000
#: the deepest nesting of mappings and lists in one document
MAX_DEPTH = 64

_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


def _kind(mode: int) -> str | None:
    """What a file of ``mode`` is, if it is not a regular file."""
    for test, name in _KINDS:
        if test(mode):
            return name
    return None if stat.S_ISREG(mode) else "not a regular file"


def check_regular(path: str | os.PathLike[str], *, what: str = "file", error: type[PyFlytError] = ConfigError) -> None:
    """Refuse ``path`` unless it is a regular file (links are followed), without opening it."""
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        raise error(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
    kind = _kind(mode)
    if kind is not None:
        raise error(f"{path}: the {what} is {kind}, not a regular file; give a regular file")


def read_bytes(
    path: str | os.PathLike[str],
    *,
    limit: int | None = MAX_DOCUMENT_BYTES,
    what: str = "file",
    error: type[PyFlytError] = ConfigError,
) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (None: no limit).

    A special file is refused before it is opened, and opened without blocking (a FIFO
    swapped in meanwhile is refused by its descriptor).  The size is checked before
    reading, and again while reading (a file still growing).
    """
    check_regular(path, what=what, error=error)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise error(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
    with os.fdopen(fd, "rb") as handle:
        info = os.fstat(handle.fileno())
        kind = _kind(info.st_mode)
        if kind is not None:
            raise error(f"{path}: the {what} is {kind}, not a regular file; give a regular file")
        if limit is not None and info.st_size > limit:
            raise error(_too_large(path, what, info.st_size, limit))
        try:
            data = handle.read() if limit is None else handle.read(limit + 1)
        except OSError as exc:
            if exc.errno == errno.EAGAIN:  # pragma: no cover - only a special file blocks
                raise error(f"{path}: the {what} is not a regular file") from None
            raise error(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
    if limit is not None and len(data) > limit:
        raise error(_too_large(path, what, len(data), limit))
    return data


def read_text(
    path: str | os.PathLike[str],
    *,
    limit: int | None = MAX_DOCUMENT_BYTES,
    what: str = "file",
    error: type[PyFlytError] = ConfigError,
) -> str:
    """:func:`read_bytes` decoded as UTF-8 (a file that is not text is refused by name)."""
    data = read_bytes(path, limit=limit, what=what, error=error)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{path}: cannot read the file: it is not a text file (not UTF-8)") from None


def _too_large(path: Any, what: str, size: int, limit: int) -> str:
    return (
        f"{path}: the {what} is {_size(size)}, more than the {_size(limit)} a {what} may have; "
        "it is not one this package wrote"
    )


def _size(n: int) -> str:
    if n >= 1 << 20:
        return f"{n / (1 << 20):.1f} MiB"
    if n >= 1 << 10:
        return f"{n / (1 << 10):.1f} KiB"
    return f"{n} bytes"


# ------------------------------------------------------------------------- YAML


def yaml_data(
    text: str | bytes,
    *,
    source: str,
    error: type[PyFlytError] = ConfigError,
    limit: int | None = MAX_YAML_BYTES,
    max_nodes: int = MAX_NODES,
) -> Any:
    """The plain data of a YAML document (``yaml.SafeLoader``), within the limits.

    Raises:
        error: the document is larger than ``limit`` bytes, holds more than ``max_nodes``
            values with its aliases expanded, nests deeper than :data:`MAX_DEPTH`, or
            contains itself.
        yaml.YAMLError: not valid YAML, or a tag that is not plain data.
    """
    if limit is not None and len(text) > limit:
        raise error(_too_large(source, "document", len(text), limit))
    loader = yaml.SafeLoader(text)
    try:
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            _check_nodes(node, source, error, max_nodes)
            return loader.construct_document(node)
        except RecursionError:
            raise error(f"{source}: nested too deeply (more than {MAX_DEPTH} levels)") from None
    finally:
        loader.dispose()


def _check_nodes(root: yaml.Node, source: str, error: type[PyFlytError], max_nodes: int) -> None:
    """Refuse a composed YAML graph that expands to too many values, nests too deeply or loops.

    Aliases share their anchor's node, so the graph is small; each node's expanded size
    (itself plus its children's, an alias counted as often as it is used) and height are
    computed once, bottom-up, without recursion.
    """
    sizes: dict[int, tuple[int, int]] = {}  # id(node) -> (expanded values, height)
    open_: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if isinstance(node, yaml.MappingNode):
            children = [item for pair in node.value for item in pair]
            if not done and key not in sizes:
                _check_unique_keys(node, source, error)
        elif isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        else:
            children = []
        if not done:
            if key in sizes:
                continue
            if key in open_:
                raise error(f"{source}: a value contains itself (a YAML alias to its own anchor); write it out")
            open_.add(key)
            stack.append((node, True))
            for child in children:
                if id(child) in open_:
                    raise error(f"{source}: a value contains itself (a YAML alias to its own anchor); write it out")
                if id(child) not in sizes:
                    stack.append((child, False))
            continue
        open_.discard(key)
        count = 1 + sum(sizes[id(c)][0] for c in children)
        height = 1 + max((sizes[id(c)][1] for c in children), default=0)
        if count > max_nodes:
            raise error(
                f"{source}: the document holds more than {max_nodes} values, its YAML aliases expanded "
                "(an alias-expansion bomb?); it is not one this package wrote"
            )
        if height > MAX_DEPTH:
            raise error(f"{source}: nested too deeply (more than {MAX_DEPTH} levels)")
        sizes[key] = (count, height)


def _check_unique_keys(node: yaml.MappingNode, source: str, error: type[PyFlytError]) -> None:
    """Refuse a mapping that gives a key twice (YAML says keys are unique; PyYAML keeps the last,
    so a second entry could silently replace what a reader of the file sees first).  A merge
    (``<<: *anchor``) is not a key of its own and may be overridden, as YAML intends."""
    seen: dict[tuple[str, str], int] = {}
    for key_node, _ in node.value:
        if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
            continue
        ident = (key_node.tag, key_node.value)
        line = key_node.start_mark.line + 1
        if ident in seen:
            raise error(
                f"{source}: the key {key_node.value!r} is given twice (lines {seen[ident]} and {line}); give each key once"
            )
        seen[ident] = line


# ------------------------------------------------------------------------- JSON


class _DuplicateKey(Exception):
    """Raised inside ``json.loads`` by :func:`_unique_pairs` (not a ValueError: nothing rewords it)."""

    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    data = dict(pairs)
    if len(data) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _DuplicateKey(key)
            seen.add(key)
    return data


class _NotANumber(Exception):
    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.name = name


def _no_constant(name: str) -> Any:
    raise _NotANumber(name)


def json_loads(
    text: str | bytes, *, source: str, error: type[PyFlytError] = ConfigError, strict_numbers: bool = False
) -> Any:
    """``json.loads`` that refuses an object giving a key twice: ``error`` naming ``source`` and the key.

    ``strict_numbers``: also refuse ``NaN``, ``Infinity`` and ``-Infinity``, which are not JSON
    (Python's reader takes them; every MCAP writer of this package writes null instead).

    Raises:
        error: a key given twice in one object (or, with ``strict_numbers``, a non-finite constant).
        ValueError: not valid JSON (the caller words it); RecursionError: nested too deeply.
    """
    try:
        if strict_numbers:
            return json.loads(text, object_pairs_hook=_unique_pairs, parse_constant=_no_constant)
        return json.loads(text, object_pairs_hook=_unique_pairs)
    except _NotANumber as exc:
        raise error(
            f"{source}: holds {exc.name}, which is not a JSON number (a recorder writes null for a value that is "
            "not finite); the file was not written by pyflyt"
        ) from None
    except _DuplicateKey as exc:
        raise error(
            f"{source}: the key {exc.key!r} is given twice in one object; give each key once "
            "(JSON readers disagree on which one counts)"
        ) from None


def json_data(
    text: str | bytes,
    *,
    source: str,
    error: type[PyFlytError] = ConfigError,
    limit: int | None = MAX_DOCUMENT_BYTES,
    max_nodes: int = MAX_NODES,
) -> Any:
    """The data of a JSON document, within the limits (see :func:`yaml_data`).

    Raises:
        error: larger than ``limit`` bytes, more than ``max_nodes`` values, or nested
            deeper than :data:`MAX_DEPTH`.
        ValueError: not valid JSON.
    """
    if limit is not None and len(text) > limit:
        raise error(_too_large(source, "document", len(text), limit))
    try:
        data = json_loads(text, source=source, error=error)
    except RecursionError:
        raise error(f"{source}: nested too deeply (more than {MAX_DEPTH} levels)") from None
    count = 0
    stack: list[tuple[Any, int]] = [(data, 1)]
    while stack:
        value, depth = stack.pop()
        count += 1
        if count > max_nodes:
            raise error(f"{source}: the document holds more than {max_nodes} values; it is not one this package wrote")
        if depth > MAX_DEPTH:
            raise error(f"{source}: nested too deeply (more than {MAX_DEPTH} levels)")
        if isinstance(value, dict):
            stack.extend((v, depth + 1) for v in value.values())
            count += len(value)  # the keys
        elif isinstance(value, list):
            stack.extend((v, depth + 1) for v in value)
    return data


# --------------------------------------------------------------------- files


def load_yaml_file(
    path: str | os.PathLike[str],
    *,
    what: str = "YAML file",
    error: type[PyFlytError] = ConfigError,
    limit: int = MAX_YAML_BYTES,
    max_nodes: int = MAX_NODES,
) -> Any:
    """The plain data of a YAML file: :func:`read_text` then :func:`yaml_data`.

    Every problem (special file, too large, not text, not valid YAML, a bomb) is one
    ``error`` naming the file.
    """
    text = read_text(path, limit=limit, what=what, error=error)
    try:
        return yaml_data(text, source=str(path), error=error, limit=limit, max_nodes=max_nodes)
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML: {_yaml_problem(exc)}") from None


def load_json_file(
    path: str | os.PathLike[str],
    *,
    what: str = "JSON file",
    error: type[PyFlytError] = ConfigError,
    limit: int = MAX_DOCUMENT_BYTES,
    max_nodes: int = MAX_NODES,
) -> Any:
    """The data of a JSON file: :func:`read_text` then :func:`json_data`; one ``error`` for any problem."""
    text = read_text(path, limit=limit, what=what, error=error)
    try:
        return json_data(text, source=str(path), error=error, limit=limit, max_nodes=max_nodes)
    except ValueError as exc:
        if isinstance(exc, PyFlytError):
            raise
        raise error(f"{path}: not valid JSON: {_first_line(exc)}") from None


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """A YAML error in one line: what is wrong, and where."""
    problem = getattr(exc, "problem", None) or getattr(exc, "context", None)
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    if not problem:
        return _first_line(exc)
    where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
    return f"{problem}{where}"


def _first_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


# ------------------------------------------------------------------- writing


def _hard_link(path: Any, what: str, links: int) -> str:
    return (
        f"{path}: the {what} has {links} names (a hard link to a file elsewhere); refusing to write to it, "
        "as that would change the other file too: delete this name (the other keeps its content)"
    )


def check_own_file(path: str | os.PathLike[str], *, what: str = "file", error: type[PyFlytError] = ConfigError) -> None:
    """Refuse ``path``, if it exists, unless :func:`open_own_file` could write it: a regular file,
    not a link, with one name.  Opens and creates nothing (a check before any work starts)."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise error(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
    if stat.S_ISLNK(info.st_mode):
        raise error(
            f"{path}: the {what} is a symbolic link; this directory's files are written through no link "
            "(remove the link)"
        )
    kind = _kind(info.st_mode)
    if kind is not None:
        raise error(f"{path}: the {what} is {kind}, not a regular file; remove it")
    if info.st_nlink > 1:
        raise error(_hard_link(path, what, info.st_nlink))


def open_own_file(
    path: str | os.PathLike[str],
    *,
    append: bool = False,
    readable: bool = False,
    what: str = "file",
    error: type[PyFlytError] = ConfigError,
) -> int:
    """A descriptor open for writing on ``path`` (created if missing), that is this directory's own.

    ``append``: every write goes to the end; ``readable``: open for reading too.

    A file written in place (a log appended to, a lock file rewritten) inside a run, a
    benchmark or a study may have been put there by someone else: a symbolic link to a
    file elsewhere, or a *hard link* -- the same file under a second name outside, which no
    path check can see.  Writing to either would change that other file.  So the file is
    opened through no link (``O_NOFOLLOW``), without truncating it, and refused unless it
    is a regular file with one name (``st_nlink == 1``); nothing is written before that.
    Files replaced by a rename (:func:`pyflyt_cli.training.artifacts.write_atomically`)
    need no such check: the rename replaces the name, not the content another name shares.

    Raises:
        error: one line naming ``path``, what it is and how to fix it.
    """
    flags = (os.O_RDWR if readable else os.O_WRONLY) | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0)
    flags |= getattr(os, "O_NONBLOCK", 0)
    flags |= getattr(os, "O_NOCTTY", 0) | (os.O_APPEND if append else 0)
    try:
        fd = os.open(path, flags, 0o644)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise error(
                f"{path}: the {what} is a symbolic link; this directory's files are written through no link "
                "(remove the link)"
            ) from None
        if exc.errno == errno.ENXIO:  # a FIFO without a reader
            raise error(f"{path}: the {what} is a FIFO (named pipe), not a regular file; remove it") from None
        raise error(f"{path}: cannot write the {what}: {exc.strerror or exc}") from None
    try:
        info = os.fstat(fd)
        kind = _kind(info.st_mode)
        if kind is not None:
            raise error(f"{path}: the {what} is {kind}, not a regular file; remove it")
        if info.st_nlink > 1:
            raise error(_hard_link(path, what, info.st_nlink))
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


# -------------------------------------------------------------- closed trees


def outside(root: str | os.PathLike[str], path: str | os.PathLike[str]) -> bool:
    """Whether ``path``, with every link resolved, leaves the directory ``root``."""
    base = Path(os.path.realpath(root))
    target = Path(os.path.realpath(path))
    return target != base and base not in target.parents


def confined_file(
    root: str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    what: str = "file",
    source: str = "",
    error: type[PyFlytError] = ConfigError,
) -> Path:
    """``path`` (a relative one from ``root``) as the absolute path of a regular file inside the
    directory ``root``, reached through no symbolic link; else ``error``, one line naming it.

    What a shared directory (a run) names is its own: an absolute path elsewhere, a ``..``
    that climbs out, a link anywhere on the way (even one that stays inside: what it points to
    can change between the check and the read), a FIFO, a device or a directory where a file
    is expected are all refused, without opening anything.
    """
    base = Path(os.path.realpath(root))
    given = Path(os.fspath(path)).expanduser()
    where = f"{source}: " if source else ""
    candidate = Path(os.path.normpath(given if given.is_absolute() else base / given))
    if candidate == base or base not in candidate.parents:
        raise error(
            f"{where}the {what} {os.fspath(path)!r} is outside {base}: a shared directory names only its own files; "
            "copy the file into it and name it by its relative path"
        )
    step = base
    for part in candidate.relative_to(base).parts:
        step = step / part
        try:
            mode = os.lstat(step).st_mode
        except OSError as exc:
            raise error(f"{where}the {what} {os.fspath(path)!r}: cannot read {step}: {exc.strerror or exc}") from None
        if stat.S_ISLNK(mode):
            raise error(
                f"{where}the {what} {os.fspath(path)!r} goes through the link {step}: a shared directory's files are "
                "read through no link; replace the link by a copy of what it points to"
            )
    kind = _kind(mode)
    if kind is not None:
        raise error(f"{where}the {what} {os.fspath(path)!r} ({candidate}) is {kind}, not a regular file")
    return candidate


_PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def plain_name(value: object) -> bool:
    """Whether ``value`` is a plain name (a shipped preset's, ``dryden_light``), never a path:
    letters, digits, ``_``, ``-`` and ``.``, no separator, not ``..``."""
    return isinstance(value, str) and _PLAIN_NAME.fullmatch(value) is not None and ".." not in value
