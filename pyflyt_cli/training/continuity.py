"""Everything a training run's continuation depends on, captured at a rollout boundary and put back.

A checkpoint is taken at the start of a rollout (``on_rollout_start``: the previous
update is done, the next action is not chosen yet).  Besides the weights and optimisers
(:mod:`.artifacts`), the continuation depends on:

* the algorithm's counters (steps, episodes, updates, the progress that drives
  schedules) and its last observation and episode-start flags;
* a recurrent policy's hidden and cell states between rollouts (``RecurrentPPO``);
* every random stream the run draws from: Python's ``random``, NumPy's global stream
  (replay sampling, minibatch permutations, Gaussian action noise), torch's CPU
  generator (policy sampling, gSDE), the action space's generator (random warm-up
  actions), the state of correlated action noise and gSDE's exploration matrices, and
  an algorithm's own generators (``random_streams()``: ``algo=sac_jax``'s JAX keys);
* the normaliser's statistics and the per-env discounted returns it accumulates;
* each environment's episode in progress: how it started (its seed, or its random
  streams when it was reset without a seed) and the actions applied since.  The
  simulation is deterministic, so re-applying them rebuilds the physics, controller and
  task state exactly (the mechanism ``pyflyt replay --verify`` checks); the rebuilt
  observations are compared with the saved ones bit for bit.

The streams are put back at the first rollout start after the resume, i.e. at the very
point in the loop where they were captured: what SB3 draws between ``learn()`` and that
point (gSDE resamples its noise at every rollout start) is overwritten.
"""

from __future__ import annotations

import random
from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np

from pyflyt_cli.training.artifacts import ArtifactError

#: algorithm counters carried across a resume (plus an algorithm's own ``resume_attributes``)
COUNTERS = ("num_timesteps", "_episode_num", "_n_updates", "_current_progress_remaining")

#: the most any step, episode, update or action count of a checkpoint may be (10^12: a million
#: steps a second for eleven days; far above any run, far below what makes a loop hang)
MAX_COUNT = 10**12

#: every counter a checkpoint may carry: its type and its range (inclusive).  Restoring reads these and
#: nothing else: a name not listed (or not this algorithm's) is refused by name, never set on the model
COUNTER_SCHEMA: dict[str, tuple[type, float, float]] = {
    "num_timesteps": (int, 0, MAX_COUNT),
    "_episode_num": (int, 0, MAX_COUNT),
    "_n_updates": (int, 0, MAX_COUNT),
    # 1 - steps / total steps (SB3's schedules' input), from the run that wrote the checkpoint
    "_current_progress_remaining": (float, -1.0, 1.0),
    "offline_steps_done": (int, 0, MAX_COUNT),  # AWAC
    "oracle_actions": (int, 0, MAX_COUNT),  # CCGE
    "policy_actions": (int, 0, MAX_COUNT),  # CCGE
}


def checked_counters(model: Any, counters: Any) -> dict[str, int | float]:
    """The counters of a checkpoint's state, checked against :data:`COUNTER_SCHEMA` and this model's
    algorithm: exactly its counters (:data:`COUNTERS` and its ``resume_attributes``), each of its type
    and in its range; else an :class:`ArtifactError` naming the first that is not."""
    expected = (*COUNTERS, *getattr(model, "resume_attributes", ()))
    if not isinstance(counters, Mapping):
        raise ArtifactError(
            f"the checkpoint's counters are a {type(counters).__name__}, not a mapping: the file is damaged"
        )
    unknown = [str(name) for name in counters if name not in expected]
    if unknown:
        raise ArtifactError(
            f"the checkpoint carries the counter {unknown[0]!r}, which a {type(model).__name__} checkpoint does not "
            f"hold (its counters: {', '.join(expected)}): the file was not written by this program"
        )
    missing = [name for name in expected if name not in counters]
    if missing:
        raise ArtifactError(
            f"the checkpoint lacks the counter {missing[0]!r}: the file is damaged or from another algorithm"
        )
    out: dict[str, int | float] = {}
    for name in expected:
        kind, low, high = COUNTER_SCHEMA[name]
        value = counters[name]
        fits = isinstance(value, int) and not isinstance(value, bool)
        if kind is float:
            fits = (fits or isinstance(value, float)) and np.isfinite(value)
        if not fits or not low <= value <= high:
            want = "a whole number" if kind is int else "a finite number"
            raise ArtifactError(
                f"the checkpoint's counter {name} is {value!r}: it must be {want} in [{low:g}, {high:g}]; the file is damaged"
            )
        out[name] = kind(value)
    return out


def _plain(value: Any) -> Any:
    """JSON-ready copy: numpy scalars and arrays as Python numbers and lists."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, deque)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _tensor(array: Any) -> Any:
    import torch

    return torch.from_numpy(np.array(array, copy=True))


def _gsde_distributions(model: Any) -> dict[str, Any]:
    from stable_baselines3.common.distributions import StateDependentNoiseDistribution

    policy = model.policy
    candidates = {
        "policy": getattr(policy, "action_dist", None),
        "actor": getattr(getattr(policy, "actor", None), "action_dist", None),
    }
    return {k: d for k, d in candidates.items() if isinstance(d, StateDependentNoiseDistribution)}


def _noise_state(noise: Any) -> Any:
    if noise is None:
        return None
    if hasattr(noise, "noises"):  # VectorizedActionNoise
        return {"noises": [_noise_state(n) for n in noise.noises]}
    prev = getattr(noise, "noise_prev", None)
    return {"noise_prev": None if prev is None else np.asarray(prev).tolist()}


def _set_noise(noise: Any, state: Any) -> None:
    if noise is None or state is None:
        return
    if "noises" in state:
        for item, item_state in zip(noise.noises, state["noises"]):
            _set_noise(item, item_state)
    elif state.get("noise_prev") is not None:
        noise.noise_prev = np.asarray(state["noise_prev"], dtype=np.asarray(noise.noise_prev).dtype)


def _raw_observation(model: Any) -> Any:
    """The observation the envs last returned, before the normaliser."""
    vec = model.get_vec_normalize_env()
    return vec.get_original_obs() if vec is not None else model._last_obs


def _observation_tensors(prefix: str, obs: Any) -> dict[str, Any]:
    if isinstance(obs, Mapping):
        return {f"{prefix}/{k}": _tensor(v) for k, v in obs.items()}
    return {prefix: _tensor(obs)}


def _observation_from(tensors: Mapping[str, Any], prefix: str) -> Any:
    if prefix in tensors:
        return tensors[prefix].numpy().copy()
    keys = [k for k in tensors if k.startswith(prefix + "/")]
    return {k.split("/", 1)[1]: tensors[k].numpy().copy() for k in keys} if keys else None


# ------------------------------------------------------------------ capture


def capture(model: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """(plain-data state, tensors) of everything but weights, optimisers and the replay buffer."""
    import torch

    extra = tuple(getattr(model, "resume_attributes", ()))
    state: dict[str, Any] = {
        "counters": {name: _plain(getattr(model, name)) for name in (*COUNTERS, *extra)},
        "ep_info_buffer": _plain(model.ep_info_buffer or []),
        "ep_success_buffer": _plain(model.ep_success_buffer or []),
        "rng": {
            "python": _plain(random.getstate()),
            "numpy": _plain(np.random.get_state(legacy=False)),
            "action_space": _plain(model.action_space.np_random.bit_generator.state),
        },
        "action_noise": _noise_state(model.action_noise),
        "envs": [],
    }
    tensors: dict[str, Any] = {
        "torch_rng": torch.get_rng_state(),
        "last_episode_starts": _tensor(model._last_episode_starts),
    }
    tensors.update(_observation_tensors("last_obs", model._last_obs))
    tensors.update(_observation_tensors("raw_obs", _raw_observation(model)))
    if getattr(model, "_last_original_obs", None) is not None:
        tensors.update(_observation_tensors("last_original_obs", model._last_original_obs))
    for name, dist in _gsde_distributions(model).items():
        for attr in ("exploration_mat", "exploration_matrices"):
            if hasattr(dist, attr):
                tensors[f"gsde/{name}/{attr}"] = getattr(dist, attr).detach().clone()
    if hasattr(model, "random_streams"):  # an algorithm's own generators (algo=sac_jax: JAX's keys)
        tensors.update(model.random_streams())
    tensors.update(_recurrent_states(model))
    for i, episode in enumerate(model.get_env().env_method("episode_state")):
        actions = episode.pop("actions")
        state["envs"].append(_plain(episode))
        tensors[f"env{i}/actions"] = _tensor(actions)
    return state, tensors


def _recurrent_states(model: Any) -> dict[str, Any]:
    """A recurrent policy's hidden and cell states carried from one rollout to the next
    (sb3-contrib ``RecurrentPPO``: ``_last_lstm_states``, per env, actor and critic)."""
    states = getattr(model, "_last_lstm_states", None)
    if states is None:
        return {}
    return {
        f"lstm/{head}/{i}": tensor.detach().clone()
        for head in ("pi", "vf")
        for i, tensor in enumerate(getattr(states, head))
    }


# ------------------------------------------------------------------ restore


def restore_model(model: Any, state: Mapping[str, Any], tensors: Mapping[str, Any]) -> None:
    """Counters, last observation and episode statistics, before ``learn()`` (which then does not reset the envs)."""
    for name, value in checked_counters(model, state.get("counters")).items():
        setattr(model, name, value)
    model._last_obs = _observation_from(tensors, "last_obs")
    model._last_episode_starts = tensors["last_episode_starts"].numpy().copy()
    original = _observation_from(tensors, "last_original_obs")
    if original is not None:
        model._last_original_obs = original
    if getattr(model, "_last_lstm_states", None) is not None:
        states = model._last_lstm_states
        restored = {}
        for head in ("pi", "vf"):
            keys = sorted(k for k in tensors if k.startswith(f"lstm/{head}/"))
            if len(keys) != len(getattr(states, head)):
                raise ArtifactError("the checkpoint holds no recurrent states fitting this model's LSTM")
            restored[head] = tuple(tensors[k].clone() for k in keys)
        model._last_lstm_states = type(states)(**restored)
    window = model._stats_window_size
    model.ep_info_buffer = deque(state["ep_info_buffer"], maxlen=window)
    model.ep_success_buffer = deque(state["ep_success_buffer"], maxlen=window)


def restore_envs(model: Any, state: Mapping[str, Any], tensors: Mapping[str, Any]) -> str | None:
    """Re-simulate every env's episode in progress; None if the observations match the saved ones
    bit for bit, else what differs (the resume then is not exact)."""
    vec = model.get_env()
    episodes = state["envs"]
    if len(episodes) != vec.num_envs:
        raise ArtifactError(f"the checkpoint holds {len(episodes)} envs, this run has {vec.num_envs}")
    rebuilt = []
    for i, episode in enumerate(episodes):
        episode = {**episode, "actions": tensors[f"env{i}/actions"].numpy()}
        rebuilt.append(vec.env_method("restore_episode", episode, indices=[i])[0])
    saved = _observation_from(tensors, "raw_obs")
    normalizer = model.get_vec_normalize_env()
    stacked: Any
    if isinstance(saved, dict):
        stacked = {k: np.stack([np.asarray(o[k]) for o in rebuilt]) for k in saved}
        differ = [k for k in saved if not np.array_equal(stacked[k], saved[k])]
    else:
        stacked = np.stack([np.asarray(o) for o in rebuilt])
        differ = [] if np.array_equal(stacked, saved) else ["observation"]
    if normalizer is not None:
        normalizer.old_obs = saved
    if not differ:
        return None
    if isinstance(saved, dict):
        worst = max(float(np.max(np.abs(stacked[k] - saved[k]))) for k in differ)
    else:
        worst = float(np.max(np.abs(stacked - saved))) if np.shape(stacked) == np.shape(saved) else float("inf")
    return (
        f"re-simulating the envs' episodes in progress gave observations that differ from the saved ones "
        f"(largest difference {worst:.3g}): this machine or these package versions do not reproduce the "
        "simulation bit for bit"
    )


def restore_streams(model: Any, state: Mapping[str, Any], tensors: Mapping[str, Any]) -> None:
    """Random streams, action noise and gSDE noise, at the first rollout start after the resume."""
    import torch

    rng = state["rng"]
    version, internal, gauss = rng["python"]
    random.setstate((version, tuple(internal), gauss))
    numpy_state = dict(rng["numpy"])
    numpy_state["state"] = {**numpy_state["state"], "key": np.asarray(numpy_state["state"]["key"], dtype=np.uint32)}
    np.random.set_state(numpy_state)
    model.action_space.np_random.bit_generator.state = rng["action_space"]
    torch.set_rng_state(tensors["torch_rng"])
    if hasattr(model, "set_random_streams"):
        model.set_random_streams(tensors)
    _set_noise(model.action_noise, state["action_noise"])
    for name, dist in _gsde_distributions(model).items():
        for attr in ("exploration_mat", "exploration_matrices"):
            key = f"gsde/{name}/{attr}"
            if key in tensors:
                setattr(dist, attr, tensors[key].clone())
