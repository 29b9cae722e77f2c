"""The batched backend as an SB3 ``VecEnv``: what ``env.backend: batched`` trains on.

:class:`BatchedVecEnv` adapts :class:`pyflyt_engine.batched.BatchedUAVEnv` (a Gymnasium
vector env with same-step autoreset) to Stable-Baselines3's ``VecEnv``, and shows the agent
what the PyBullet backend's training envs show it
(:func:`pyflyt_cli.training.envs.wrap_for_agent`): float32 observations, actions in
[-1, 1] rescaled to the env's units by Gymnasium's own rescaling, and ``Monitor``'s episode
statistics (``info["episode"]`` with ``r``, ``l``, ``t`` and ``success``) plus
``terminal_observation`` and ``TimeLimit.truncated`` at an episode's end.  A multi-agent
config (:class:`pyflyt_engine.batched.swarm.BatchedSwarmEnv`) makes ``n_envs`` worlds of its
agents, a slot per agent, with the slots' convention of
:mod:`pyflyt_cli.training.multi_agent`: a retired agent's slot is padding until its world's
episode ends, and then ends without episode statistics.  So PPO, SAC,
``VecNormalize``, the callbacks (a training curriculum's ``set_task_changes`` included)
and checkpoints work on it unchanged.

Checkpoints: ``env_method("episode_state")`` returns, per env, the whole batched state of
that env (its arrays' rows -- with latency its delays, the actions in flight and the states
it will show among them, in turbulence its filter's state, with noisy sensors their biases,
held readings, sample counts and estimator, with domain randomisation the episode's draws and
the mass, inertia, motor and drag rows they set, with range sensors their held readings and
last cast times -- and its random streams, its turbulence's, its sensors' and its range
sensors' too; env 0 also the batch's motor-noise stream) as plain data, and
``env_method("restore_episode", state)`` puts it back, so a resumed run continues bit for
bit (the continuity module compares the observations).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.wrappers.utils import rescale_box
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from pyflyt_engine.batched.env import batched_vector_env
from pyflyt_engine.envs.config import EnvConfig

#: the per-env arrays a checkpoint carries (their rows), in this order
_STATE_ARRAYS = (
    "pos",
    "quat",
    "vel",
    "angvel",
    "throttle",
    "command",
    "integral",
    "previous",
    "has_previous",
    "actions",
    "steps",
    "physics_steps",
    "targets",
    "num_reached",
    "_last_distance",
    "_last_position",
    "episode_return",
    "episode_length",
    "ang_vel_body",
    "ang_pos",
    "lin_vel_body",
    "quaternion",
    "reach",
    "deflection",
    "flap_command",
    "gimbal_angles",
    "gimbal_command",
    "autopilot_integral",
    "vel_integral",
    "latency_steps",
    "action_history",
    "observed_history",
    "turbulence",
    "sensor_state",
    "sensor_counts",
    "battery",
)


def _state_arrays(env: Any) -> tuple[str, ...]:
    """The arrays whose rows a checkpoint of ``env`` carries: the state, with domain
    randomisation the episode's draws and the parameter rows they changed (``randomized_arrays``),
    with range sensors their held readings and last cast times (``range_arrays``)."""
    return (
        tuple(getattr(env, "state_arrays", _STATE_ARRAYS))
        + tuple(getattr(env, "randomized_arrays", ()))
        + tuple(getattr(env, "range_arrays", ()))
    )


class BatchedVecEnv(VecEnv):
    """``n_envs`` copies of ``config``'s task on the batched backend, as an SB3 ``VecEnv``
    (a multi-agent config: ``n_envs`` worlds, ``n_envs x agents`` slots)."""

    def __init__(self, config: EnvConfig, n_envs: int) -> None:
        self.env = batched_vector_env(config, n_envs)
        single = self.env.single_observation_space
        obs_space = spaces.Box(
            np.asarray(single.low, dtype=np.float32), np.asarray(single.high, dtype=np.float32), dtype=np.float32
        )
        act = self.env.single_action_space
        self._rescale = None
        action_space = act
        if not (np.allclose(act.low, -1.0) and np.allclose(act.high, 1.0)):
            # the stubs take NumPy scalars; the function takes any number (np.issubdtype)
            action_space, _, self._rescale = rescale_box(act, -1.0, 1.0)  # type: ignore[arg-type]
        self.render_mode = None
        super().__init__(self.env.num_envs, obs_space, action_space)
        self._actions: np.ndarray | None = None
        self._started = time.perf_counter()

    # ------------------------------------------------------------------ VecEnv

    def reset(self) -> np.ndarray:
        seed = self._seeds[0]
        obs, _ = self.env.reset(seed=seed)
        self._reset_seeds()
        self._started = time.perf_counter()
        return obs.astype(np.float32)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        assert self._actions is not None
        a = self._actions.astype(np.float64)
        if self._rescale is not None:
            a = self._rescale(a)
        obs, reward, terminated, truncated, info = self.env.step(a)
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any():
            final = info["final_obs"]
            episode = info["episode"]
            elapsed = round(time.perf_counter() - self._started, 6)
            ended = info.get("_episode", dones)
            for i in np.nonzero(dones)[0].tolist():
                if not ended[i]:  # a multi-agent padding slot: it ends with its world's episode, no statistics
                    infos[i] = {"terminal_observation": final[i].astype(np.float32), "TimeLimit.truncated": False}
                    continue
                infos[i] = {
                    "terminal_observation": final[i].astype(np.float32),
                    "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                    "success": bool(info["success"][i]),
                    "episode": {
                        "r": round(float(episode["r"][i]), 6),
                        "l": int(episode["l"][i]),
                        "t": elapsed,
                        "success": bool(info["success"][i]),
                    },
                }
        return obs.astype(np.float32), reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.env.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        value = getattr(self.env, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        raise AttributeError(f"the batched backend's envs have no settable attribute '{attr_name}'")

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        if method_name == "episode_state":
            return [self.episode_state(i) for i in self._indices(indices)]
        if method_name == "restore_episode":
            return [self.restore_episode(i, *method_args, **method_kwargs) for i in self._indices(indices)]
        if method_name == "set_task_changes":  # a training curriculum: every env at once
            if indices is not None and list(self._indices(indices)) != list(range(self.num_envs)):
                raise AttributeError("the batched envs take task changes all together")
            self.env.set_task_changes(*method_args, **method_kwargs)
            return [None] * self.num_envs
        raise AttributeError(f"the batched backend does not support '{method_name}' on its envs")

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        # the statistics Monitor would add are added here (SB3 asks so as not to warn)
        from stable_baselines3.common.monitor import Monitor

        return [wrapper_class is Monitor for _ in self._indices(indices)]

    def _indices(self, indices: Any) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    # ------------------------------------------------------------- checkpoints

    def episode_state(self, i: int) -> dict[str, Any]:
        """Env ``i``'s whole state as plain data (and no actions: nothing is re-simulated)."""
        env = self.env
        state = {name: getattr(env, name)[i].tolist() for name in _state_arrays(env)}
        streams: dict[str, Any] = {"env": env.env_rngs[i].bit_generator.state}
        if i == 0:
            streams["noise"] = env.noise_rng.bit_generator.state
        if getattr(env, "turbulence_rngs", None):  # the turbulence's white noise (Dryden)
            streams["turbulence"] = env.turbulence_rngs[i].bit_generator.state
        if getattr(env, "sensors", None) is not None:  # the noisy sensors' stream
            streams["sensors"] = env.sensors.rngs[i].bit_generator.state
        if getattr(env, "range_sensors", None) is not None:  # one stream per range sensor
            streams["range_sensors"] = [rng.bit_generator.state for rng in env.range_sensors.rngs[i]]
        shape = self.env.single_action_space.shape
        return {
            "seed": None,
            "options": None,
            "rng": streams,
            "batched": state,
            "actions": np.zeros((0, *shape), dtype=np.float32),
        }

    def restore_episode(self, i: int, state: dict[str, Any]) -> np.ndarray:
        """Put env ``i``'s state back (:meth:`episode_state`); returns its observation."""
        env = self.env
        saved = state["batched"]
        for name in _state_arrays(env):
            row = getattr(env, name)
            if name not in saved and (row[i].size == 0 or name == "randomized_values"):
                continue  # a checkpoint from before the fixed-wing's arrays, or of delays drawn before the values were kept
            row[i] = np.asarray(saved[name], dtype=row.dtype).reshape(row[i].shape)
        env.env_rngs[i].bit_generator.state = state["rng"]["env"]
        if "noise" in state["rng"]:
            env.noise_rng.bit_generator.state = state["rng"]["noise"]
        if getattr(env, "turbulence_rngs", None):
            env.turbulence_rngs[i].bit_generator.state = state["rng"]["turbulence"]
        if getattr(env, "sensors", None) is not None:
            env.sensors.rngs[i].bit_generator.state = state["rng"]["sensors"]
        if getattr(env, "range_sensors", None) is not None:
            for rng, saved_state in zip(env.range_sensors.rngs[i], state["rng"]["range_sensors"]):
                rng.bit_generator.state = saved_state
        return env._observe()[i].astype(np.float32)


def fly_episodes(
    predict: Any, normalize: Any, config: EnvConfig, episodes: int, seed: int, deterministic: bool = True
) -> dict[str, float]:
    """The first episode of each of ``episodes`` envs of ``config`` on the batched backend,
    flown together by ``predict`` (``(observations, deterministic) -> actions``, as
    :func:`pyflyt_cli.training.evaluation.policy_predict` gives; ``normalize``: the policy's
    observation normaliser or None).

    What ``pyflyt eval`` reports beside the PyBullet engine's episodes for a run trained on
    this backend: ``episodes``, ``success_rate``, ``mean_return`` and, for waypoint tasks,
    ``waypoints_reached`` (mean) and ``all_reached`` (fraction).  The spawns and waypoints are
    the batched env's own draws from ``seed`` (other episodes of the same task than the
    PyBullet engine's ``seed + i``), so the two rates are two samples of one policy.
    """
    venv = BatchedVecEnv(config.model_copy(update={"backend": "batched"}), episodes)
    venv.seed(seed)
    obs = venv.reset()
    if hasattr(venv.env, "worlds"):  # multi-agent: an episode per world
        return _fly_worlds(venv, obs, predict, normalize, deterministic)
    done = np.zeros(episodes, dtype=bool)
    returns = np.zeros(episodes)
    success = np.zeros(episodes, dtype=bool)
    reached = np.zeros(episodes, dtype=np.int64)
    while not done.all():
        action = np.asarray(predict(normalize(obs) if normalize is not None else obs, deterministic), dtype=np.float64)
        if venv._rescale is not None:  # [-1, 1] -> the env's units, as step_wait does
            action = venv._rescale(action)
        obs, reward, terminated, truncated, info = venv.env.step(action)
        obs = obs.astype(np.float32)
        live = ~done
        returns[live] += reward[live]
        ended = (terminated | truncated) & live
        success[ended] = info["success"][ended]
        if "num_targets_reached" in info:
            reached[ended] = info["num_targets_reached"][ended]
        done |= ended
    out = {"episodes": float(episodes), "success_rate": float(success.mean()), "mean_return": float(returns.mean())}
    if venv.env.targets.shape[1]:
        out["waypoints_reached"] = float(reached.mean())
        out["all_reached"] = float(np.mean(reached >= venv.env.targets.shape[1]))
    venv.close()
    return out


def _fly_worlds(
    venv: BatchedVecEnv, obs: np.ndarray, predict: Any, normalize: Any, deterministic: bool
) -> dict[str, float]:
    """:func:`fly_episodes` of a multi-agent config: the first episode of every world, as the
    PyBullet engine's shared-policy env scores one (:class:`~pyflyt_engine.envs.multi_agent.shared.SharedPolicyEnv`):
    its return is the mean of its agents' returns, it succeeds when every agent did."""
    env = venv.env
    worlds, agents = env.worlds, env.agents
    done = np.zeros(worlds, dtype=bool)
    returns = np.zeros(env.num_envs)
    success = np.zeros(env.num_envs, dtype=bool)
    while not done.all():
        action = np.asarray(predict(normalize(obs) if normalize is not None else obs, deterministic), dtype=np.float64)
        if venv._rescale is not None:
            action = venv._rescale(action)
        live = ~np.repeat(done, agents) & env.alive
        obs, reward, _, _, info = env.step(action)
        obs = obs.astype(np.float32)
        returns[live] += reward[live]
        success[live & info["success"]] = True
        done |= env.world_over.reshape(worlds, agents).any(axis=1)
    per_world = success.reshape(worlds, agents).all(axis=1)
    out = {
        "episodes": float(worlds),
        "success_rate": float(per_world.mean()),
        "mean_return": float(returns.reshape(worlds, agents).mean(axis=1).mean()),
    }
    venv.close()
    return out
