"""The run directory: one training run, everything needed to evaluate, resume or audit it.

::

    runs/<env>/<algo>/<YYYYmmdd-HHMMSS>-seed<k>[-<n>]/
        config.yaml          resolved, validated configuration (reload with load_run_config)
        run.yaml             seed, backend, config digest, command line, start time, host, package versions, resumes
        state.json           progress: status, steps, last checkpoint, best evaluation
        run.lock             the id of the process training it, while it trains
        metrics.mcap         /train/episode, /eval, /train/progress (metrics-<n>.mcap after a resume)
        model.pt             final policy and normaliser statistics (tensors only; artifacts.py)
        best_model.pt        best evaluation so far
        checkpoints/         model_<steps>_steps.pt (everything a resume needs but the buffer),
                             replay_buffer_<steps>_steps.npz (off-policy; the newest one is kept)
        episodes/            ep_<NNNN>.mcap written by `pyflyt eval`
        eval.json            the last `pyflyt eval` summary
        airframe.yaml        copy of a user airframe file, if the env named one by path
        init_policy.pt       copy of the policy init_from named (tensors only), if any
        airframe-<sha>.yaml  multi-agent envs: a copy of each airframe file an agent names by
                             path (<sha> = the first 12 hex digits of its SHA-256)
        obstacle-<sha>.obj   a copy of each mesh obstacle's file

Directories are created with ``mkdir(exist_ok=False)``: two runs started in the same
second get ``...-seed0`` and ``...-seed0-1``, never the same directory.  Files are written
to a temporary name and renamed into place, so a killed run never leaves half a file
under a final name.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import json
import os
import platform
import re
import socket
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pyflyt_cli.training.schema import OPT_INS, TrainConfig, parse_train_config
from pyflyt_engine.envs.terminations import DEFAULT_TERMINATIONS
from pyflyt_engine.errors import ConfigError, PyFlytError
from pyflyt_engine.safe_load import MAX_YAML_BYTES, plain_name, read_bytes

CONFIG_FILE = "config.yaml"
RUN_FILE = "run.yaml"
STATE_FILE = "state.json"
FINAL_MODEL = "model.pt"
BEST_MODEL = "best_model.pt"
#: the pickled SB3 files of older versions (read only with trust_pickle)
LEGACY_FINAL_MODEL = "model.zip"
LEGACY_BEST_MODEL = "best_model.zip"
CHECKPOINTS = "checkpoints"
EPISODES = "episodes"
AIRFRAME_COPY = "airframe.yaml"
#: the copy of a mesh obstacle's file a run keeps: ``obstacle-<first 12 hex digits of its SHA-256>.obj``
OBSTACLE_MESH_PREFIX = "obstacle-"
#: a copy of the policy ``init_from`` named, kept so a restart never reads outside the run
INIT_POLICY = "init_policy.pt"

_CHECKPOINT = re.compile(r"^model_(\d+)_steps\.(pt|zip)$")
#: a checkpoint's replay buffer file
BUFFER_PATTERN = re.compile(r"^replay_buffer_(\d+)_steps\.npz$")
_PACKAGES = (
    "pyflyt-toolkit",
    "stable-baselines3",
    "torch",
    "gymnasium",
    "numpy",
    "pybullet",
    "hydra-core",
    "pydantic",
    "mcap",
)


class RunDirError(ConfigError):
    """A run directory is missing, incomplete or not a run directory."""


# ----------------------------------------------------------------------- create


def create_run_dir(output_dir: str | Path, env_name: str, algo: str, seed: int, when: float | None = None) -> Path:
    """Create ``<output_dir>/<env>/<algo>/<YYYYmmdd-HHMMSS>-seed<k>`` (``-1``, ``-2`` ... if taken), atomically."""
    parent = Path(output_dir) / env_name / algo
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RunDirError(f"cannot create the output directory {parent}: {exc}") from None
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(time.time() if when is None else when))
    base = f"{stamp}-seed{seed}"
    for n in range(10_000):
        path = parent / (base if n == 0 else f"{base}-{n}")
        try:
            path.mkdir(exist_ok=False)
        except FileExistsError:
            continue
        return path.resolve()
    raise RunDirError(f"cannot find a free run directory name under {parent}")  # pragma: no cover


def create_named_run_dir(path: str | Path) -> Path:
    """Create exactly ``path`` (and its parents) for a new run; it must not exist yet."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.mkdir(exist_ok=False)
    except FileExistsError:
        raise RunDirError(
            f"{path} already exists: resume it (pyflyt train resume={path}) or choose another directory"
        ) from None
    except OSError as exc:
        raise RunDirError(f"cannot create the run directory {path}: {exc}") from None
    return path.resolve()


def atomic_write(path: Path, text: str | bytes) -> None:
    """Write ``path`` through a temporary file and a rename (:func:`.artifacts.write_atomically`).

    Raises:
        ArtifactError: the file could not be written (full disk, read-only directory).
    """
    from pyflyt_cli.training.artifacts import write_atomically

    def write(tmp: Path) -> None:
        if isinstance(text, bytes):
            tmp.write_bytes(text)
        else:
            tmp.write_text(text)

    write_atomically(path, write)


def write_yaml(path: Path, data: Any, header: str = "") -> None:
    atomic_write(path, header + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100))


def package_versions() -> dict[str, str]:
    """Installed versions of the packages a run depends on, plus Python's."""
    from importlib import metadata

    versions = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    if versions["pyflyt-toolkit"] == "not installed":  # running from a source checkout
        from pyflyt_engine import __version__

        versions["pyflyt-toolkit"] = f"{__version__} (source checkout)"
    revision = source_revision()
    if revision is not None:
        versions["pyflyt-toolkit revision"] = revision
    return versions


def source_revision() -> str | None:
    """The git commit of the code, when it runs from a git checkout (an editable install):
    ``<sha>``, with ``+modified`` if files differ from it; None for an installed wheel."""
    import subprocess

    import pyflyt_engine

    top = Path(pyflyt_engine.__file__).resolve().parent.parent
    if not (top / ".git").exists():
        return None
    try:
        sha = subprocess.run(["git", "-C", str(top), "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
        dirty = subprocess.run(
            ["git", "-C", str(top), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, check=True,
        )  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return None
    return sha.stdout.strip() + ("+modified" if dirty.stdout.strip() else "")


def run_record(cfg: TrainConfig, command: list[str] | None, overrides: list[str] | None) -> dict[str, Any]:
    """What ``run.yaml`` holds at creation."""
    return {
        "seed": cfg.seed,
        "env": cfg.env_name,
        "env_id": cfg.env.id,
        "algo": cfg.algo.name,
        # what simulated the training steps (evaluations always fly the PyBullet engine)
        "backend": getattr(cfg.env, "backend", "pybullet"),
        "experiment": cfg.experiment,
        "init_from": cfg.init_from,
        "config_digest": config_digest(cfg),
        "command": command if command is not None else list(sys.argv),
        "overrides": list(overrides or []),
        "cwd": os.getcwd(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "versions": package_versions(),
        # what decides the last bits: CPU, kernel sets in force, library versions
        "numerics": numeric_platform(),
        "resumes": [],
    }


def numeric_platform() -> dict[str, Any]:
    """:func:`pyflyt_engine.numerics.platform_info` of a training process: with PyTorch
    (set up as training sets it) and SciPy's BLAS loaded, so that every kernel set a run
    computes with is reported, whenever this is called."""
    import scipy.linalg  # noqa: F401 - its own OpenBLAS
    import torch  # noqa: F401

    from pyflyt_engine.numerics import apply_torch, platform_info

    apply_torch()
    return platform_info()


def platform_note(record: dict[str, Any], here: dict[str, Any]) -> str | None:
    """How the numeric platform ``run.yaml`` (``record``) recorded differs from ``here``
    (:func:`numeric_platform`), in words, or None when it does not (or none was recorded)."""
    from pyflyt_engine.numerics import describe_difference

    made = record.get("numerics") if isinstance(record.get("numerics"), dict) else None
    if not made or not isinstance(made.get("key"), dict):
        return None
    difference = describe_difference(made["key"], here["key"])
    if difference:
        return f"made under another numeric platform ({difference}): what is computed here may round differently"
    if made.get("cpu") != here["cpu"]:
        return f"made on another CPU ({made.get('cpu')}; here {here['cpu']}) with the same pinned kernels: the numbers agree"
    return None


def _is_airframe_path(uav: Any) -> bool:
    """An airframe named by a file path (not a conf/uav name)."""
    return isinstance(uav, str) and (uav.endswith((".yaml", ".yml")) or os.sep in uav or Path(uav).is_file())


def _agent_list(env: dict[str, Any]) -> list[dict[str, Any]]:
    """The listed agents of a multi-agent env's data (none for a count or a single-agent env)."""
    agents = env.get("agents")
    return [a for a in agents if isinstance(a, dict)] if isinstance(agents, list) else []


def _obstacle_items(env: dict[str, Any]) -> list[dict[str, Any]]:
    """The fixed obstacles of an env's data (none without ``obstacles.items``)."""
    obstacles = env.get("obstacles")
    items = obstacles.get("items") if isinstance(obstacles, dict) else None
    return [i for i in items if isinstance(i, dict)] if isinstance(items, list) else []


def portable_config(cfg: TrainConfig, run_dir: Path) -> TrainConfig:
    """``cfg`` with files the env names by path made part of the run directory.

    A reward preset or a wind config given as a path is inlined; an airframe given as a path is copied to
    ``airframe.yaml``, and each airframe a listed agent of a multi-agent env names by path
    to ``airframe-<sha>.yaml`` (one copy per distinct file content), each mesh obstacle's file
    to ``obstacle-<sha>.obj``; all are reloaded relative to the run directory by
    :func:`load_run_config`.
    """
    from pyflyt_engine.envs.config import load_reward_preset

    env = cfg.env
    update: dict[str, Any] = {}
    reward = env.reward_preset_name()
    if isinstance(reward, str) and (reward.endswith((".yaml", ".yml")) or Path(reward).is_file()):
        preset = load_reward_preset(reward)
        update["reward"] = preset.model_dump()
    wind = env.wind
    if isinstance(wind, str) and not plain_name(wind):  # a file: a run names no file outside itself
        from pyflyt_engine.atmosphere import load_wind_config

        update["wind"] = load_wind_config(wind).model_dump(mode="json")
    if env.uav.endswith((".yaml", ".yml")) or Path(env.uav).is_file():
        atomic_write(run_dir / AIRFRAME_COPY, read_bytes(env.uav, limit=MAX_YAML_BYTES, what="airframe file"))
        update["uav"] = str(run_dir / AIRFRAME_COPY)
    agents = getattr(env, "agents", None)
    if isinstance(agents, list) and any(_is_airframe_path(a.uav) for a in agents):
        listed = [a.model_dump(mode="json") for a in agents]
        for agent in listed:
            if _is_airframe_path(agent.get("uav")):
                content = read_bytes(agent["uav"], limit=MAX_YAML_BYTES, what="airframe file")
                copy = run_dir / f"airframe-{hashlib.sha256(content).hexdigest()[:12]}.yaml"
                if not copy.exists():
                    atomic_write(copy, content)
                agent["uav"] = str(copy)
        update["agents"] = listed
    obstacles = getattr(env, "obstacles", None)
    if obstacles is not None and obstacles.meshes:
        # a mesh obstacle's file is copied in, as the run reads only its own files (obstacle-<sha>.obj)
        from pyflyt_engine.obstacles import MAX_MESH_BYTES

        data = obstacles.model_dump(mode="json")
        for item in data["items"]:
            if item.get("type") == "mesh" and Path(item["file"]).parent != run_dir:
                content = read_bytes(item["file"], limit=MAX_MESH_BYTES, what="mesh file")
                copy = run_dir / f"{OBSTACLE_MESH_PREFIX}{hashlib.sha256(content).hexdigest()[:12]}.obj"
                if not copy.exists():
                    atomic_write(copy, content)
                item["file"] = str(copy)
        update["obstacles"] = data
    if not update:
        return cfg
    data = cfg.model_dump(mode="json")
    data["env"] = {**data["env"], **update}
    return parse_train_config(data)


def config_dict(cfg: TrainConfig) -> dict[str, Any]:
    """``cfg`` as plain data, in a readable key order (``algo.name`` first)."""
    data = cfg.model_dump(mode="json")
    data["algo"] = {"name": data["algo"].pop("name"), **data["algo"]}
    return data


#: keys that do not change what a run computes: where it is written and how it reports.
#: Everything else is part of a run's identity (:func:`config_digest`).
NON_IDENTITY_KEYS = frozenset(
    {"train.output_dir", "train.progress_bar", "train.verbose", "train.tensorboard", "experiment", "trust_pickle"}
)

#: keys added after runs were first recorded, with the value those runs had without them: a
#: key at that value (or unset) is left out of the identity, so older runs keep their digest
LATER_KEYS = {
    "env.backend": "pybullet",
    "train.best_by": "return",
    "train.imitation.value_warmup": 0,
    "train.imitation.hold_normalizer": False,
    # off-policy n-step returns (an on-policy rollout length of 1 is no config's)
    "algo.n_steps": 1,
    # the flight controller (the airframe's own, before Betaflight's firmware could replace it)
    "env.controller": "own",
    "env.firmware_action": "sticks",
}
#: as LATER_KEYS, for keys below a mapping of the user's names (prefix, suffix): the
#: curriculum's gate, added after curriculum runs were first recorded (none: the step count)
LATER_PATTERNS = {
    ("train.curriculum.", ".gate"): None,
    ("train.curriculum.", ".gate_episodes"): None,
}


#: ``env.terminations`` as every env declared it before it was a key (conf/env/_base.yaml):
#: left out of the identity, so older runs keep their digest; any other declaration counts
_DEFAULT_TERMINATIONS: dict[str, dict[str, Any]] = {name: {"term": None, "params": {}} for name in DEFAULT_TERMINATIONS}


def identity(cfg: TrainConfig | dict[str, Any], run_dir: Path | None = None) -> dict[str, Any]:
    """The flattened settings that define what a run computes (``key.path -> value``).

    Keys of :data:`NON_IDENTITY_KEYS` are left out, and those of :data:`LATER_KEYS` at their
    earlier value.  An airframe named by path
    (``env.uav``, e.g. the ``airframe.yaml`` a run keeps of it) is identified by the
    SHA-256 of its file's bytes, not its path, so a copy of the same file is the same run.
    A wind config or reward preset named by path counts by its content, as the run keeps it
    inline (:func:`portable_config`).
    """
    data = cfg.model_dump(mode="json") if isinstance(cfg, TrainConfig) else json.loads(json.dumps(cfg))
    if isinstance(data.get("env"), dict):
        _inline_preset_files(data["env"])
        if data["env"].get("terminations") == _DEFAULT_TERMINATIONS:  # every env's before it was a key
            del data["env"]["terminations"]
    flat: dict[str, Any] = {}

    def walk(node: Any, prefix: str) -> None:
        if isinstance(node, dict) and node:
            for key, value in node.items():
                walk(value, f"{prefix}{key}.")
        else:
            flat[prefix[:-1]] = node

    walk(data, "")
    for key in NON_IDENTITY_KEYS:
        flat.pop(key, None)
    for key, earlier in LATER_KEYS.items():
        if flat.get(key) in (None, earlier):
            flat.pop(key, None)
    for (prefix, suffix), earlier in LATER_PATTERNS.items():
        for key in [k for k in flat if k.startswith(prefix) and k.endswith(suffix)]:
            if flat[key] in (None, earlier):
                del flat[key]

    def file_identity(uav: Any) -> Any:
        if not (isinstance(uav, str) and (uav.endswith((".yaml", ".yml")) or os.sep in uav)):
            return uav
        path = Path(uav)
        if not path.is_absolute() and run_dir is not None:
            path = run_dir / path
        try:
            return "sha256:" + hashlib.sha256(read_bytes(path, limit=MAX_YAML_BYTES, what="airframe file")).hexdigest()
        except PyFlytError:
            return uav  # a missing (or unreadable) file keeps its name: it then differs from any readable one

    if "env.uav" in flat:
        flat["env.uav"] = file_identity(flat["env.uav"])
    if isinstance(flat.get("env.agents"), list):  # listed agents of a multi-agent env
        flat["env.agents"] = [
            {**a, "uav": file_identity(a.get("uav"))} if isinstance(a, dict) else a for a in flat["env.agents"]
        ]
    if isinstance(flat.get("env.obstacles.items"), list):  # a mesh obstacle counts by its file's content
        from pyflyt_engine.obstacles import MAX_MESH_BYTES

        def mesh_identity(file: Any) -> Any:
            path = Path(str(file))
            if not path.is_absolute() and run_dir is not None:
                path = run_dir / path
            try:
                return "sha256:" + hashlib.sha256(read_bytes(path, limit=MAX_MESH_BYTES, what="mesh file")).hexdigest()
            except PyFlytError:
                return file

        flat["env.obstacles.items"] = [
            {**i, "file": mesh_identity(i["file"])} if isinstance(i, dict) and "file" in i else i
            for i in flat["env.obstacles.items"]
        ]
    return flat


def _inline_preset_files(env: dict[str, Any]) -> None:
    """Replace a wind config or reward preset named by path with its content (as plain JSON data)."""
    from pyflyt_engine.atmosphere import load_wind_config
    from pyflyt_engine.envs.config import load_reward_preset

    wind = env.get("wind")
    declared = env.get("reward_presets")
    presets = declared if isinstance(declared, dict) else {}
    reward = presets.get(env.get("reward"), env.get("reward")) if isinstance(env.get("reward"), str) else None
    try:
        if isinstance(wind, str) and not plain_name(wind):
            env["wind"] = json.loads(json.dumps(load_wind_config(wind).model_dump(mode="json")))
        if isinstance(reward, str) and (reward.endswith((".yaml", ".yml")) or Path(reward).is_file()):
            env["reward"] = json.loads(json.dumps(load_reward_preset(reward).model_dump()))
    except PyFlytError:
        pass  # an unreadable file keeps its name: it then differs from any readable one


def config_digest(cfg: TrainConfig | dict[str, Any], run_dir: Path | None = None) -> str:
    """SHA-256 (hex) of a run's :func:`identity`: equal digests, equal settings."""
    text = json.dumps(identity(cfg, run_dir), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def save_config(cfg: TrainConfig, run_dir: Path) -> None:
    """Write ``config.yaml`` (the resolved, validated config); files inside the run are named relative to it."""
    header = (
        "# Resolved configuration of this run (validated by pyflyt_cli.training.schema.TrainConfig).\n"
        "# Resume: pyflyt train resume=<this directory>    Evaluate: pyflyt eval <this directory>\n"
    )
    data = config_dict(cfg)
    uav = Path(data["env"]["uav"])
    if uav.is_absolute() and uav.parent == run_dir:
        data["env"]["uav"] = uav.name
    for agent in _agent_list(data["env"]):
        if isinstance(agent.get("uav"), str) and Path(agent["uav"]).is_absolute():
            if Path(agent["uav"]).parent == run_dir:
                agent["uav"] = Path(agent["uav"]).name
    for item in _obstacle_items(data["env"]):
        if isinstance(item.get("file"), str) and Path(item["file"]).parent == run_dir:
            item["file"] = Path(item["file"]).name
    write_yaml(run_dir / CONFIG_FILE, data, header)


# ------------------------------------------------------------------------- read


def check_run_dir(run_dir: str | Path) -> Path:
    """``run_dir`` as a resolved path; :class:`RunDirError` unless it holds a run's ``config.yaml``
    and is a closed world (:func:`check_closed`)."""
    path = Path(run_dir).expanduser()
    if not path.exists():
        raise RunDirError(f"run directory {path} does not exist{nearest_existing(path)}")
    if not path.is_dir():
        raise RunDirError(
            f"{path} is not a directory (expected a run directory such as runs/quadx_hover/ppo/<time>-seed0)"
        )
    check_closed(path)
    if not (path / CONFIG_FILE).is_file():
        raise RunDirError(f"{path} is not a run directory: it has no {CONFIG_FILE}")
    return path.resolve()


def nearest_existing(path: Path) -> str:
    """What exists nearest a missing ``path``, for its message: the closest folder beside the
    missing part (:func:`pyflyt_engine.suggest.nearest_path`) as ``". Did you mean
    '<path>'?"``, else the runs in the first existing folder above it, else ``""``."""
    from pyflyt_engine.suggest import NEAREST_SCAN, nearest_path

    parent, meant = nearest_path(path, dirs_only=True)
    if meant is not None:
        return f". Did you mean '{meant}'?"
    try:
        runs = sorted(e.name for e in itertools.islice(parent.iterdir(), NEAREST_SCAN) if (e / CONFIG_FILE).is_file())
    except OSError:
        return ""
    if runs:
        return f". Runs in {parent}: {', '.join(runs[-5:])}" + (f" (and {len(runs) - 5} more)" if len(runs) > 5 else "")
    return ""


def check_closed(run_dir: Path, folders: tuple[str, ...] | None = None, what: str = "run directory") -> None:
    """Refuse a directory that is not a closed world: an entry that is a link leading out of it, or
    a special file (a FIFO, a device, a socket).

    ``folders=None`` (a run directory): every entry of every folder under it, however deep (links
    to folders are checked, never walked into); otherwise the top level and the ``folders`` named
    (a benchmark directory, ``what``, whose runs are checked each on their own).

    A run directory (or a benchmark directory) can be shared, so no link inside it may decide
    where a resume writes or what an evaluation reads.  Links that stay inside are allowed.
    """
    from pyflyt_engine.safe_load import outside

    root = Path(run_dir)
    pending = [root] if folders is None else [root, *(root / name for name in folders)]
    while pending:
        folder = pending.pop(0)
        if folder != root and not (folder.is_dir() and not folder.is_symlink()):
            continue
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except OSError as exc:
            raise RunDirError(f"{folder}: cannot list it: {exc.strerror or exc}") from None
        for entry in entries:
            path = Path(entry.path)
            if entry.is_symlink():
                if outside(root, path):
                    raise RunDirError(
                        f"{path} is a link to {os.readlink(path)}, outside {root}: a shared {what} is "
                        "read and written only inside itself; replace the link by a copy of what it points to"
                    )
            elif entry.is_dir(follow_symlinks=False):
                if folders is None:
                    pending.append(path)
            elif not entry.is_file(follow_symlinks=False):
                raise RunDirError(f"{path} is not a regular file or a folder (a FIFO or a device?): remove it")


#: keys of an env config that name a shipped preset (or give it inline): never a file in a run
_PRESET_KEYS = ("wind", "reward", "randomize")


def _confine(data: Any, root: Path, source: str) -> None:
    """Make the files a run's config names its own: airframes by a file name inside ``root`` (made
    absolute) or a shipped name; presets by a shipped name or inline.  Anything else is refused."""
    from pyflyt_engine.paths import uav_dir
    from pyflyt_engine.safe_load import confined_file, outside, plain_name

    env = data.get("env") if isinstance(data, dict) else None
    if not isinstance(env, dict):
        return  # the schema says what is missing

    def airframe(holder: dict[str, Any], key: str) -> None:
        uav = holder.get(key)
        if uav is None:
            return
        if isinstance(uav, str) and plain_name(uav):
            if (root / uav).is_file() and not outside(root, root / uav):
                holder[key] = str(root / uav)
                return
            if (uav_dir() / f"{uav}.yaml").is_file():
                return
        raise RunDirError(
            f"{source}: {key}={uav!r} is neither a shipped airframe nor a file of the run directory "
            "(a run keeps a copy of its airframe file beside its config.yaml)"
        )

    airframe(env, "uav")
    for agent in _agent_list(env):
        airframe(agent, "uav")
    declared = env.get("reward_presets")
    presets = declared if isinstance(declared, dict) else {}
    named = {f"env.reward_presets.{k}": v for k, v in presets.items()}
    for key in _PRESET_KEYS:
        value = env.get(key)
        named[f"env.{key}"] = value.get("preset") if isinstance(value, dict) and key == "wind" else value
    for key, name in named.items():
        if isinstance(name, str) and not plain_name(name):
            raise RunDirError(
                f"{source}: {key}={name!r} names a file: a run directory keeps its presets inline or by a "
                "shipped name, and names no file outside itself"
            )
    # every mesh file the config names: a regular file of the run reached through no link (relative
    # paths from the run directory), written back absolute so that nothing resolves it from elsewhere
    for i, payload in enumerate(env.get("payloads") or []):
        shapes = ((payload.get("body") or {}).get("shapes") or []) if isinstance(payload, dict) else []
        for j, shape in enumerate(shapes):
            if isinstance(shape, dict) and shape.get("type") == "mesh" and isinstance(shape.get("mesh"), str):
                shape["mesh"] = str(
                    confined_file(
                        root,
                        shape["mesh"],
                        what=f"mesh of env.payloads[{i}].body.shapes[{j}]",
                        source=source,
                        error=RunDirError,
                    )
                )
    obstacles = env.get("obstacles")
    items = obstacles.get("items") if isinstance(obstacles, dict) else None
    for i, item in enumerate(items if isinstance(items, list) else []):
        if isinstance(item, dict) and isinstance(item.get("file"), str):
            item["file"] = str(
                confined_file(
                    root, item["file"], what=f"env.obstacles.items[{i}].file", source=source, error=RunDirError
                )
            )


def _confine_airframes(cfg: TrainConfig, root: Path, source: str) -> None:
    """Refuse an airframe file of the run whose URDF, its meshes or the airframe's meshes are not
    regular files of the run reached through no link -- before PyBullet or the recorder opens any."""
    from pyflyt_engine.safe_load import confined_file, read_text
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import MAX_URDF_BYTES, urdf_files, urdf_problem

    agents = getattr(cfg.env, "agents", None)  # a multi-agent env: a count, or a list of agents
    names = [cfg.env.uav, *(a.uav for a in agents if a.uav)] if isinstance(agents, list) else [cfg.env.uav]
    for name in dict.fromkeys(names):
        if not (isinstance(name, str) and Path(name).is_absolute()):
            continue  # a shipped airframe
        spec = load_uav_spec(name)
        base = Path(name).parent
        label = f"{source}: the airframe {Path(name).name}"
        for shape in spec.body.shapes:
            if shape.type == "mesh" and shape.mesh is not None:
                confined_file(root, base / shape.mesh, what="mesh it names", source=label, error=RunDirError)
        if spec.body.urdf is None:
            continue
        urdf = confined_file(root, base / spec.body.urdf, what="URDF it names", source=label, error=RunDirError)
        text = read_text(urdf, limit=MAX_URDF_BYTES, what="URDF", error=RunDirError)
        problem = urdf_problem(text, allow_files=True)
        if problem is not None:
            raise RunDirError(f"{label} names the URDF {urdf.name}, which PyBullet is not given: {problem}")
        for file in urdf_files(text):
            confined_file(
                root, urdf.parent / file, what=f"mesh its URDF {urdf.name} names", source=label, error=RunDirError
            )


def load_run_config(run_dir: str | Path) -> TrainConfig:
    """The :class:`TrainConfig` a run was started with, read as untrusted data.

    The run directory must be a closed world (:func:`check_run_dir`); ``config.yaml`` is
    read with the bounded reader of :mod:`pyflyt_engine.safe_load`; the files it names
    must be the run's own (:func:`_confine`: its airframe copies; presets by a shipped name
    or inline; an airframe's URDF and meshes inside the run); ``trust_pickle`` is never
    taken from it (an opt-in comes from the command line of the current command only).
    """
    path = check_run_dir(run_dir)
    return load_config_file(path / CONFIG_FILE, root=path)


def load_config_file(file: Path, *, root: Path) -> TrainConfig:
    """A resolved configuration file (a run's ``config.yaml``) read as untrusted data, its files in ``root``."""
    from pyflyt_engine.safe_load import load_yaml_file

    source = str(file)
    data = load_yaml_file(file, what="config file", error=RunDirError)
    if isinstance(data, dict):
        data = dict(data)
        _confine(data, root, source)
        for key in OPT_INS:
            data[key] = False  # an opt-in never comes from the file it would trust
    cfg = parse_train_config(data, source=source, recorded=True)
    _confine_airframes(cfg, root, source)
    return cfg


LOCK_FILE = "run.lock"


@contextlib.contextmanager
def run_lock(run_dir: Path) -> Iterator[None]:
    """Hold ``run.lock`` (this process's id) while training; refuse if a live process holds it.

    A lock left by a killed process (its id no longer running) is taken over.
    """
    path = run_dir / LOCK_FILE
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            pid = read_pid(path)
            if pid and pid != os.getpid() and _alive(pid):
                raise RunDirError(
                    f"{run_dir} is being trained by process {pid}; wait for it, stop it (Ctrl-C), "
                    f"or delete {path} if that process is not training"
                ) from None
            path.unlink(missing_ok=True)  # stale: its process is gone
            continue
        with os.fdopen(fd, "w") as fh:
            fh.write(f"{os.getpid()}\n")
        break
    try:
        yield
    finally:
        path.unlink(missing_ok=True)


def read_pid(path: Path) -> int:
    """The process id a lock file holds (its first word); 0 if it holds none, or is not a small regular file."""
    from pyflyt_engine.safe_load import read_text

    try:
        words = read_text(path, limit=4096, what="lock file").split()
        return int(words[0]) if words else 0
    except (PyFlytError, ValueError):
        return 0


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def read_yaml(path: Path) -> dict[str, Any]:
    """A run's YAML record (``run.yaml``) as a mapping; ``{}`` if it is missing or not a mapping.

    Raises:
        RunDirError: not a regular file, too large, not YAML, or an alias-expansion bomb.
    """
    from pyflyt_engine.safe_load import load_yaml_file

    if not path.exists() and not path.is_symlink():
        return {}
    data = load_yaml_file(path, what="run record", error=RunDirError)
    return data if isinstance(data, dict) else {}


def read_state(run_dir: Path) -> dict[str, Any]:
    """``state.json`` as a mapping; ``{}`` if it is missing or not a mapping.

    Raises:
        RunDirError: not a regular file, too large or not JSON.
    """
    from pyflyt_engine.safe_load import load_json_file

    path = run_dir / STATE_FILE
    if not path.exists() and not path.is_symlink():
        return {}
    data = load_json_file(path, what="state file", error=RunDirError)
    return data if isinstance(data, dict) else {}


def write_state(run_dir: Path, state: dict[str, Any]) -> None:
    atomic_write(run_dir / STATE_FILE, json.dumps(state, indent=2) + "\n")


@dataclass(frozen=True)
class Checkpoint:
    """The files of one checkpoint.

    ``model`` is the checkpoint file (policy, optimisers, every random stream, the envs'
    episodes in progress: see :mod:`pyflyt_cli.training.continuity`); it is written last,
    so its existence marks the checkpoint complete.  ``replay_buffer`` is None if the
    checkpoint has none (on-policy algorithms, ``train.save_replay_buffer=false``, or an
    older checkpoint whose buffer was pruned).  ``legacy``: an SB3 ``.zip`` written by an
    older version (pickled; loaded only with ``trust_pickle``; never resumed from).
    """

    step: int
    model: Path
    replay_buffer: Path | None
    legacy: bool = False


def checkpoint_paths(run_dir: Path, step: int) -> Checkpoint:
    """Where the files of the checkpoint at ``step`` go."""
    folder = run_dir / CHECKPOINTS
    return Checkpoint(step, folder / f"model_{step}_steps.pt", folder / f"replay_buffer_{step}_steps.npz")


def checkpoints(run_dir: Path, *, legacy: bool = False) -> list[Checkpoint]:
    """Complete checkpoints (the checkpoint file exists), oldest first; a missing buffer is None.

    ``legacy``: also list SB3 ``model_<N>_steps.zip`` checkpoints of older versions (where
    no ``.pt`` checkpoint of the same step exists).
    """
    folder = run_dir / CHECKPOINTS
    found: dict[int, Checkpoint] = {}
    if folder.is_dir():
        for p in folder.iterdir():
            m = _CHECKPOINT.match(p.name)
            if not m:
                continue
            step, suffix = int(m[1]), m[2]
            if suffix == "pt":
                c = checkpoint_paths(run_dir, step)
                buffer = c.replay_buffer if c.replay_buffer is not None and c.replay_buffer.is_file() else None
                found[step] = Checkpoint(step, c.model, buffer)
            elif legacy and step not in found:
                buffer = folder / f"replay_buffer_{step}_steps.pkl"
                found[step] = Checkpoint(step, p, buffer if buffer.is_file() else None, legacy=True)
    return [found[k] for k in sorted(found)]


def checkpoint_at_or_after(run_dir: Path, step: int) -> Checkpoint:
    """The run's first checkpoint at or after ``step`` (what ``init_from=<run dir>@<step>`` names).

    Checkpoints are saved at the first rollout boundary at or after each multiple of
    ``train.checkpoint_freq`` (e.g. step 7504 for 7500 with ``train_freq: 8``), so a
    step names "the policy after about that many steps".
    """
    found = checkpoints(run_dir)
    later = [c for c in found if c.step >= step]
    if not later:
        have = ", ".join(str(c.step) for c in found) or "none yet"
        raise RunDirError(
            f"{run_dir} has no checkpoint at or after step {step} (its checkpoints: {have}); train that run "
            f"further (pyflyt train resume={run_dir} train.total_timesteps=<more>) or choose an earlier step"
        )
    return later[0]


def run_of(model: Path) -> Path:
    """The run directory a policy file belongs to (a checkpoint's: its folder's parent)."""
    return model.parent.parent if model.parent.name == CHECKPOINTS else model.parent


def legacy_normalizer(model: Path) -> Path | None:
    """The pickled VecNormalize statistics saved beside a legacy ``.zip`` model, if any."""
    m = _CHECKPOINT.match(model.name)
    if m:
        candidate = model.parent / f"vecnormalize_{m[1]}_steps.pkl"
    elif model.name == LEGACY_BEST_MODEL:
        candidate = model.parent / "best_vecnormalize.pkl"
    else:
        candidate = model.parent / "vecnormalize.pkl"
    return candidate if candidate.is_file() else None


def find_model(run_dir: Path, which: str = "auto", *, legacy: bool = False) -> tuple[Path, str]:
    """(policy file, which one) of a run.

    ``which``: ``best``, ``final``, ``latest`` (newest checkpoint) or ``auto`` (best, else
    final, else latest).  ``legacy``: also accept the pickled SB3 ``.zip`` files of older
    versions; without it, a run holding only those is refused with the reason.
    """
    candidates: dict[str, Path] = {}
    for name, current, old in (("best", BEST_MODEL, LEGACY_BEST_MODEL), ("final", FINAL_MODEL, LEGACY_FINAL_MODEL)):
        path = run_dir / current
        candidates[name] = path if path.is_file() or not legacy else run_dir / old
    found = checkpoints(run_dir, legacy=legacy)
    if found:
        candidates["latest"] = found[-1].model
    order = ["best", "final", "latest"] if which == "auto" else [which]
    for name in order:
        if name in candidates and candidates[name].is_file():
            return candidates[name], name
    pickled = [p.name for p in (run_dir / LEGACY_BEST_MODEL, run_dir / LEGACY_FINAL_MODEL) if p.is_file()]
    pickled += [c.model.name for c in checkpoints(run_dir, legacy=True) if c.legacy][-1:]
    if pickled and not legacy:
        from pyflyt_cli.training.artifacts import PICKLE_RISK

        raise RunDirError(f"{run_dir}: its models ({', '.join(pickled)}) were saved by an older version: {PICKLE_RISK}")
    have = [n for n, m in candidates.items() if m.is_file()]
    raise RunDirError(
        f"{run_dir}: no {'model' if which == 'auto' else which + ' model'} to load"
        + (
            f" (available: {', '.join(have)})"
            if have
            else " (the run saved none yet: it stopped before its first checkpoint)"
        )
    )
