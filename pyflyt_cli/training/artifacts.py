"""The files a run writes, in formats that are data only, and how to read them safely.

A run directory is meant to be shared, so nothing in it is a pickle:

* **policy files** (``model.pt``, ``best_model.pt``) and **checkpoints**
  (``checkpoints/model_<N>_steps.pt``) are ``torch.save`` archives of a plain dict of
  tensors, numbers and strings, read back with ``torch.load(weights_only=True)``, which
  refuses anything else.  The SB3 model is rebuilt from the run's ``config.yaml`` and the
  tensors are loaded into it.  Each carries the SHA-256 of its content (``sha256``,
  :func:`content_digest`), checked when it is read, so a damaged copy is refused.
* **replay buffers** (``checkpoints/replay_buffer_<N>_steps.npz``) are NumPy archives of
  plain arrays, read with ``np.load(allow_pickle=False)``.
* the observation/reward **normaliser** (SB3 ``VecNormalize``) is a few arrays inside
  the policy file.

Files written by older versions (SB3 ``.zip`` models whose JSON carries cloudpickled
entries, ``.pkl`` normalisers and buffers) are only read with ``trust_pickle`` set:
unpickling runs whatever code the file names.

Every file is written under a temporary name, flushed to disk and renamed into place,
so a killed process leaves either the old file or the new one, never half of one.
:func:`fault_point` marks each step of a multi-file commit; the tests replace it to
stop the commit at each step in turn.
"""

from __future__ import annotations

import json
import os
import pickle
import zipfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.safe_load import json_loads

if TYPE_CHECKING:
    from pyflyt_cli.training.evaluation import ObsNormalizer

#: ``format`` of a policy file and of a checkpoint (a policy file with the trainer's state)
POLICY_FORMAT = "pyflyt.policy"
CHECKPOINT_FORMAT = "pyflyt.checkpoint"
FORMAT_VERSION = 1

#: what a refusal to unpickle says (file names are added by the caller)
PICKLE_RISK = (
    "it is in the legacy pickled format, and unpickling a file can run any code it names; "
    "if you made it yourself, pass trust_pickle=true to load it"
)


class ArtifactError(ConfigError):
    """A run file is missing, unreadable, of the wrong kind, or refused (pickled)."""


def fault_point(name: str) -> None:
    """A named step of a multi-file commit (a no-op; fault-injection tests replace it)."""


# ------------------------------------------------------------------- writing


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(path: Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` for a temporary file beside ``path``, then rename it into place.

    On an error the temporary file is removed and ``path`` is untouched; a failed write
    (full disk, read-only directory, file-size limit: an ``OSError``, or the
    ``RuntimeError`` torch's archive writer raises for it) becomes an
    :class:`ArtifactError` naming the file.
    """
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        _create_new(tmp)  # never through a link or a file someone left under that name
        write(tmp)
        _fsync(tmp)
        fault_point(f"written {path.name}")
        os.replace(tmp, path)
    except Exception as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, (OSError, RuntimeError)):
            if isinstance(exc, OSError):
                reason = exc.strerror or str(exc)
            else:  # torch reports a short write without the OS error
                reason = "the write stopped short (a full disk or a file-size limit?)"
            raise ArtifactError(f"cannot write {path}: {reason}") from None
        raise
    fault_point(f"renamed {path.name}")


def _create_new(path: Path) -> None:
    """Create ``path`` empty and new: whatever is there (a stale temporary file, a link) is removed first,
    and the file is created exclusively, never through a link."""
    path.unlink(missing_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
    os.close(fd)


#: the key of a policy file or checkpoint that holds the SHA-256 of the rest of its content
DIGEST_KEY = "sha256"


def content_digest(data: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of a policy file's or checkpoint's content, ``DIGEST_KEY`` left out: every key,
    and every value by its kind -- a tensor by its dtype, shape and bytes, a number or a string by
    its type and ``repr`` -- in a fixed order, so the same content gives the same digest whatever
    the archive's layout.  A flipped byte anywhere in the content changes it."""
    import hashlib

    import torch

    h = hashlib.sha256()

    def feed(value: Any) -> None:
        if isinstance(value, torch.Tensor):
            t = value.detach().cpu().contiguous()
            h.update(f"t{t.dtype}{tuple(t.shape)}".encode())
            h.update(t.reshape(-1).view(torch.uint8).numpy().tobytes() if t.numel() else b"")
        elif isinstance(value, Mapping):
            keys = sorted((k for k in value if not (value is data and k == DIGEST_KEY)), key=str)
            h.update(f"d{len(keys)}".encode())
            for key in keys:
                h.update(f"k{len(str(key))}:{key}".encode())
                feed(value[key])
        elif isinstance(value, (list, tuple)):
            h.update(f"l{len(value)}".encode())
            for item in value:
                feed(item)
        else:
            text = f"{type(value).__name__}:{value!r}"
            h.update(f"v{len(text)}:{text}".encode())

    feed(data)
    return h.hexdigest()


def _save_torch(data: dict[str, Any]) -> Callable[[Path], None]:
    def write(tmp: Path) -> None:
        import torch

        torch.save({**data, DIGEST_KEY: content_digest(data)}, tmp)

    return write


# ------------------------------------------------------------------ reading


def read_payload(path: Path, *, kinds: tuple[str, ...] = (POLICY_FORMAT, CHECKPOINT_FORMAT)) -> dict[str, Any]:
    """A policy file or checkpoint, read with ``torch.load(weights_only=True)`` (no code runs).

    Raises:
        ArtifactError: missing, truncated, not written by this package, or a legacy pickle.
    """
    import torch

    path = Path(path)
    if not path.is_file():
        raise ArtifactError(f"{path}: no such file")
    if path.suffix in (".zip", ".pkl"):
        raise ArtifactError(f"{path}: {PICKLE_RISK}")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ArtifactError(f"{path}: refused: it holds more than tensors and numbers ({first})") from None
    except (RuntimeError, EOFError, OSError, ValueError, zipfile.BadZipFile, KeyError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ArtifactError(
            f"{path}: not a readable model file ({first}); it may be truncated (a full disk, a copy "
            "that did not finish) or not written by pyflyt"
        ) from None
    if not isinstance(data, dict) or data.get("format") not in kinds:
        raise ArtifactError(f"{path}: not a pyflyt model file (expected format {' or '.join(kinds)})")
    if int(data.get("version", 0)) > FORMAT_VERSION:
        raise ArtifactError(f"{path}: written by a newer version (format {data.get('version')}); upgrade pyflyt")
    # files written before the digest existed (the shipped agents among them) have none: read as before
    if DIGEST_KEY in data and data[DIGEST_KEY] != content_digest(data):
        raise ArtifactError(
            f"{path}: its content does not match the SHA-256 it was written with: the file is damaged "
            "(a flipped byte, a copy gone wrong); use another copy or checkpoint"
        )
    return data


# ------------------------------------------------------------- normaliser


def _rms_state(rms: Any) -> Any:
    import torch

    if isinstance(rms, Mapping):
        return {str(k): _rms_state(v) for k, v in rms.items()}
    return {
        "mean": torch.from_numpy(np.array(rms.mean, dtype=np.float64)),
        "var": torch.from_numpy(np.array(rms.var, dtype=np.float64)),
        "count": float(rms.count),
    }


def _rms_problem(state: Any, shape: tuple[int, ...], where: str) -> str | None:
    """Why running statistics from a file do not fit observations of ``shape`` (None: they do)."""
    import torch

    if not isinstance(state, Mapping) or not all(isinstance(state.get(k), torch.Tensor) for k in ("mean", "var")):
        return f"{where} are not a mean and a variance"
    for key, name in (("mean", "mean"), ("var", "variance")):
        value = state[key]
        if tuple(value.shape) != tuple(shape):
            return f"{where}: the {name} has shape {list(value.shape)}, the observation {list(shape)}"
        if not bool(torch.all(torch.isfinite(value))):
            return f"{where}: the {name} holds NaN or inf"
    if bool(torch.any(state["var"] < 0)):
        return f"{where}: the variance is negative"
    return None


def check_normalizer(state: Any, space: Any, path: Path | str) -> None:
    """Refuse observation-normaliser statistics (from ``path``) that do not fit the observation ``space``:
    a wrong shape, NaN or inf, a negative variance, a clip or epsilon that is not a finite number
    (a tampered file gave a NumPy broadcasting traceback, or NaN actions)."""
    from gymnasium import spaces

    if state is None or not isinstance(state, Mapping) or not state.get("norm_obs"):
        return
    for key in ("clip_obs", "epsilon"):
        value = state.get(key)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not np.isfinite(value) or value < 0:
            raise ArtifactError(f"{path}: the observation normaliser's {key} is {value!r}, not a finite number >= 0")
    rms = state.get("obs_rms")
    if isinstance(space, spaces.Dict):
        entries = rms.items() if isinstance(rms, Mapping) and "mean" not in rms else [("?", None)]
        problems = [
            f"the statistics of an observation entry {key!r} the env does not have"
            if key not in space.spaces
            # (an entry without a shape, a nested Dict, which VecNormalize does not take: checked as a scalar's)
            else _rms_problem(value, space.spaces[key].shape or (), f"the statistics of {key!r}")
            for key, value in entries
        ]
    else:
        problems = [_rms_problem(rms, tuple(space.shape), "the observation statistics")]
    problem = next((p for p in problems if p), None)
    if problem is not None:
        raise ArtifactError(f"{path}: its observation normaliser does not fit this run's env: {problem}")


def _set_rms(rms: Any, state: Any) -> None:
    if isinstance(rms, Mapping):
        for key, value in rms.items():
            _set_rms(value, state[key])
        return
    problem = _rms_problem(state, np.shape(rms.mean), "the saved normaliser statistics")
    if problem is not None:
        raise ArtifactError(f"{problem}: they are not this run's")
    rms.mean = state["mean"].numpy().astype(np.float64).copy()
    rms.var = state["var"].numpy().astype(np.float64).copy()
    rms.count = float(state["count"])


def normalizer_state(vec: Any) -> dict[str, Any] | None:
    """The statistics of an SB3 ``VecNormalize`` as plain data (None without one).

    Read from the instance's own attributes: an unpickled ``VecNormalize`` has no env
    yet, and SB3 forwards a missing attribute to it (``returns`` is not pickled).
    """
    if vec is None:
        return None
    import torch

    own = vars(vec)
    return {
        "norm_obs": bool(own["norm_obs"]),
        "norm_reward": bool(own["norm_reward"]),
        "clip_obs": float(own["clip_obs"]),
        "clip_reward": float(own["clip_reward"]),
        "epsilon": float(own["epsilon"]),
        "gamma": float(own["gamma"]),
        "obs_rms": _rms_state(own["obs_rms"]),
        "ret_rms": _rms_state(own["ret_rms"]),
        "returns": torch.from_numpy(np.array(own.get("returns", np.zeros(0)), dtype=np.float64)),
    }


def restore_normalizer(vec: Any, state: Mapping[str, Any], *, returns: bool = True) -> None:
    """Put saved statistics into a ``VecNormalize`` built from the same configuration.

    ``returns``: also the per-env discounted returns being accumulated (an exact resume);
    leave them at zero when starting a new run from another run's statistics.
    """
    _set_rms(vec.obs_rms, state["obs_rms"])
    _set_rms(vec.ret_rms, state["ret_rms"])
    saved = state["returns"].numpy()
    if returns and saved.shape == np.shape(vec.returns):
        vec.returns = saved.astype(np.float64).copy()


def observation_normalizer(state: Mapping[str, Any] | None) -> ObsNormalizer | None:
    """``obs -> normalised obs`` as SB3's ``VecNormalize.normalize_obs`` computes it (None if off)."""
    if state is None or not state["norm_obs"]:
        return None
    clip, eps = state["clip_obs"], state["epsilon"]

    def one(obs: np.ndarray, rms: Mapping[str, Any]) -> np.ndarray:
        mean, var = rms["mean"].numpy(), rms["var"].numpy()
        return np.clip((obs - mean) / np.sqrt(var + eps), -clip, clip).astype(np.float32)

    rms = state["obs_rms"]
    if "mean" in rms:
        return lambda obs: one(np.asarray(obs), rms)
    return lambda obs: {k: one(np.asarray(obs[k]), rms[k]) if k in rms else obs[k] for k in obs}


# ------------------------------------------------------------ policy files


def policy_payload(model: Any, algo: str, step: int) -> dict[str, Any]:
    """What a policy file holds: the policy's tensors and the normaliser statistics."""
    return {
        "format": POLICY_FORMAT,
        "version": FORMAT_VERSION,
        "algo": algo,
        "step": int(step),
        "policy": model.policy.state_dict(),
        "normalizer": normalizer_state(model.get_vec_normalize_env()),
    }


def save_policy(path: Path, model: Any, algo: str, step: int) -> None:
    """Write ``model.pt`` / ``best_model.pt``: the policy and normaliser, atomically."""
    write_atomically(path, _save_torch(policy_payload(model, algo, step)))


def save_policy_data(path: Path, algo: str, step: int, policy: Mapping[str, Any], normalizer: Any) -> None:
    """Write a policy file from a policy's state dict and normaliser statistics (a run's ``init_policy.pt``)."""
    payload = {
        "format": POLICY_FORMAT,
        "version": FORMAT_VERSION,
        "algo": algo,
        "step": int(step),
        "policy": dict(policy),
        "normalizer": normalizer,
    }
    write_atomically(path, _save_torch(payload))


def load_policy_into(model: Any, data: Mapping[str, Any], path: Path) -> None:
    """Load a policy file's weights into ``model`` (built from a matching configuration)."""
    try:
        model.policy.load_state_dict(data["policy"])
    except (RuntimeError, KeyError) as exc:
        first = str(exc).strip().splitlines()[0]
        raise ArtifactError(
            f"{path}: its policy does not fit this model (same env observation/action sizes, "
            f"algo.policy_kwargs.net_arch and algo.use_sde needed): {first}"
        ) from None


# -------------------------------------------------------------- checkpoints


def save_checkpoint_file(
    path: Path, model: Any, algo: str, step: int, state: dict[str, Any], tensors: dict[str, Any]
) -> None:
    """Write a checkpoint: the policy file's content plus optimisers, trainer state and streams."""
    from operator import attrgetter

    payload = policy_payload(model, algo, step)
    params = model.get_parameters()
    params.pop("policy", None)
    variables = {name: attrgetter(name)(model).detach().clone() for name in model._get_torch_save_params()[1]}
    payload.update(
        {
            "format": CHECKPOINT_FORMAT,
            "optimizers": params,
            "variables": variables,
            "state": json.dumps(state),
            "tensors": tensors,
        }
    )
    write_atomically(path, _save_torch(payload))


def load_checkpoint_into(model: Any, data: Mapping[str, Any], path: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Weights, optimisers and variables into ``model``; returns (trainer state, tensors)."""
    import torch
    from operator import attrgetter

    if data.get("format") != CHECKPOINT_FORMAT:
        raise ArtifactError(f"{path}: a policy file, not a checkpoint: it cannot be resumed from")
    load_policy_into(model, data, path)
    try:
        model.set_parameters({**data["optimizers"], "policy": data["policy"]}, exact_match=True)
        # the variables SB3 saves besides the policy (SAC's log_ent_coef ...): only the names this model
        # declares, never an attribute path taken from the file
        declared = set(model._get_torch_save_params()[1])
        unknown = sorted(str(name) for name in data["variables"] if name not in declared)
        if unknown:
            raise ArtifactError(
                f"{path}: the checkpoint carries the variable {unknown[0]!r}, which this model does not save "
                f"(its variables: {', '.join(sorted(declared)) or 'none'})"
            )
        with torch.no_grad():
            for name, value in data["variables"].items():
                attrgetter(name)(model).copy_(value)
        state = json_loads(data["state"], source=f"{path}: its state", error=ArtifactError)
    except (RuntimeError, KeyError, ValueError, AttributeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ArtifactError(f"{path}: does not fit this run's model ({first})") from None
    return state, dict(data["tensors"])


# ------------------------------------------------------------ replay buffers

_BUFFER_FIELDS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def save_replay_buffer(path: Path, buffer: Any) -> None:
    """Write an SB3 ``ReplayBuffer``/``DictReplayBuffer`` as plain arrays (filled rows only),
    deflate-compressed (``np.savez_compressed``; read back by the same ``np.load``)."""
    size = buffer.buffer_size if buffer.full else buffer.pos
    arrays: dict[str, np.ndarray] = {
        "pos": np.array(buffer.pos),
        "full": np.array(buffer.full),
        "buffer_size": np.array(buffer.buffer_size),
    }
    for name in _BUFFER_FIELDS:
        value = getattr(buffer, name, None)
        if isinstance(value, Mapping):
            arrays.update({f"{name}/{key}": v[:size] for key, v in value.items()})
        elif value is not None:
            arrays[name] = value[:size]

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as handle:
            # (NumPy's stubs would read one of the keys as allow_pickle: none is)
            np.savez_compressed(handle, **cast("dict[str, Any]", arrays))

    write_atomically(path, write)


def load_replay_buffer(path: Path, buffer: Any, *, exact: bool = True) -> int:
    """Fill ``buffer`` from a file written by :func:`save_replay_buffer`; returns the transitions loaded.

    ``exact``: restore the buffer as it was (same capacity required: a resume).  Otherwise
    the transitions are appended oldest first, keeping the newest that fit (pretraining on
    another run's buffer).
    """
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {key: archive[key] for key in archive.files}
    except FileNotFoundError:
        raise ArtifactError(f"{path}: no such replay buffer file") from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ArtifactError(f"{path}: not a readable replay buffer ({str(exc).splitlines()[0]})") from None
    try:
        pos, full, capacity = int(arrays.pop("pos")), bool(arrays.pop("full")), int(arrays.pop("buffer_size"))
    except KeyError as exc:
        raise ArtifactError(f"{path}: not a pyflyt replay buffer (no {exc})") from None
    fields: dict[str, np.ndarray] = {}
    for key, value in arrays.items():
        target = getattr(buffer, key.split("/")[0], None)
        if isinstance(target, Mapping):
            target = target.get(key.split("/", 1)[1])
        if target is None or value.shape[1:] != target.shape[1:]:
            have = None if target is None else target.shape[1:]
            raise ArtifactError(
                f"{path}: '{key}' has rows of shape {value.shape[1:]}, this run's buffer {have}: "
                "it was saved for another environment or number of envs"
            )
        fields[key] = value
    size = capacity if full else pos
    if exact:
        if capacity != buffer.buffer_size:
            raise ArtifactError(f"{path}: holds a buffer of {capacity} rows, this run's has {buffer.buffer_size}")
        order = np.arange(size)
    else:
        chronological = np.r_[pos:capacity, 0:pos] if full else np.arange(size)
        order = chronological[-buffer.buffer_size :]
    for key, value in fields.items():
        target = getattr(buffer, key.split("/")[0])
        if isinstance(target, Mapping):
            target = target[key.split("/", 1)[1]]
        target[: len(order)] = value[order]
    if exact:
        buffer.pos, buffer.full = pos, full
    else:
        buffer.pos = len(order) % buffer.buffer_size
        buffer.full = len(order) == buffer.buffer_size
    return len(order)


# --------------------------------------------------------------- legacy pickles


def load_legacy_model(cls: Any, path: Path, device: str, env: Any = None) -> Any:
    """An SB3 ``.zip`` model (runs code from the file: only with ``trust_pickle``)."""
    try:
        return cls.load(path, env=env, device=device)
    except Exception as exc:  # noqa: BLE001 - any failure of a foreign file is a user error here
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ArtifactError(f"{path}: cannot load this SB3 model file ({first})") from None


def load_legacy_normalizer(path: Path) -> dict[str, Any] | None:
    """The statistics of a pickled ``VecNormalize`` (runs code from the file: only with ``trust_pickle``)."""
    try:
        with open(path, "rb") as handle:
            vec = pickle.load(handle)  # noqa: S301 - the caller opted in with trust_pickle
        return normalizer_state(vec)
    except Exception as exc:  # noqa: BLE001
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ArtifactError(f"{path}: cannot read this pickled normaliser ({first})") from None
