"""Parameter sharing: every agent of every multi-agent env is one slot of one SB3 vector env.

A multi-agent env config (one with ``agents``) trains one policy shared by all agents
(dogfight: both teams, i.e. self-play).  ``train.n_envs`` copies of the env, each with N
agents, make ``n_envs x N`` vector-env slots; SB3 sees a plain ``VecEnv`` (the role
SuperSuit's ``pettingzoo_env_to_vec_env_v1`` + ``concat_vec_envs_v1`` play, written here so
that every slot's episode statistics and every env's episode in progress are part of
the checkpoint, for exact resume).  Steps count agent-steps: ``train.total_timesteps``
is summed over slots.

Per slot, for an agent whose own episode ends before the others' (a crash, shot down):
``done`` with its final observation as ``terminal_observation`` (``TimeLimit.truncated``
when it reached the time limit) and its return, length and success in ``info["episode"]``;
then, until its env's episode ends, the slot is *padding* -- zero observation, zero
reward -- the same convention as SuperSuit's ``black_death`` wrapper; the padding ends
(``done``, no statistics) when the env starts its next episode.  All N slots of an env
share its simulation: all envs run in this process.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


def agents_per_env(env_config: Any) -> int:
    """Vector-env slots one env of ``env_config`` fills: its agent count (1 for a single-agent env)."""
    if not getattr(env_config, "multi_agent", False):
        return 1
    return len(env_config.resolved_agents())


def step_unit(env_config: Any) -> str:
    """What ``train.total_timesteps`` counts for ``env_config``: ``steps`` or ``agent-steps``."""
    return "agent-steps" if getattr(env_config, "multi_agent", False) else "steps"


class AgentSlots(gymnasium.Wrapper):
    """Per-agent bookkeeping of a :class:`~pyflyt_engine.envs.multi_agent.shared.SharedPolicyEnv`
    (wrapped for the agent): each step's observation rows become the slots' next
    observations (zeros for retired agents), and ``info["slots"]`` carries per agent the
    reward, ``done``, the terminal observation and, for an agent whose episode ended, its
    ``episode`` statistics.  Kept inside :class:`~pyflyt_cli.training.envs.ResumableEpisode`,
    so re-simulating an episode rebuilds this state too.
    """

    def __init__(self, env: gymnasium.Env) -> None:
        super().__init__(env)
        self.num_agents = int(env.unwrapped.num_agents)
        self._returns = np.zeros(self.num_agents)
        self._lengths = np.zeros(self.num_agents, dtype=np.int64)
        self._started = time.time()

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        active = info["agent_active"]
        ended = active & (info["agent_terminated"] | info["agent_truncated"])
        rewards = np.where(active, info["agent_rewards"], 0.0)
        self._returns += rewards
        self._lengths += active
        slots_obs = np.array(obs, copy=True)
        episodes: dict[int, dict[str, Any]] = {}
        names = self.env.unwrapped.agent_names
        for i in np.flatnonzero(ended):
            agent_info = info["agent_infos"][names[i]]
            episodes[int(i)] = {
                "terminal_observation": slots_obs[i].copy(),
                "TimeLimit.truncated": bool(info["agent_truncated"][i] and not info["agent_terminated"][i]),
                "episode": {
                    "r": float(self._returns[i]),
                    "l": int(self._lengths[i]),
                    "t": round(time.time() - self._started, 6),
                    "success": bool(agent_info.get("success", False)),
                },
            }
        slots_obs[~active | ended] = 0.0
        info["slots"] = {"rewards": rewards, "ended": ended, "active": active, "episodes": episodes, "obs": slots_obs}
        return slots_obs, reward, terminated, truncated, info


class AgentSlotsVecEnv(VecEnv):
    """``n_envs`` multi-agent envs of N agents as an SB3 ``VecEnv`` of ``n_envs x N`` slots.

    Slot ``k * N + i`` is agent ``i`` of env ``k``.  Env ``k`` is reset with ``seed + k``
    at the first reset after :meth:`seed`, later with its continuing random streams.

    ``env_method("episode_state")`` gives, for every slot, the state of its env's episode
    in progress; ``env_method("restore_episode", state, indices=[slot])`` re-simulates the
    env at its first slot (agent 0) and returns each slot's row of the rebuilt observation
    (slots are restored in order, as :mod:`pyflyt_cli.training.continuity` does).
    """

    def __init__(self, env_fns: Sequence[Callable[[], gymnasium.Env]]) -> None:
        self.envs = [fn() for fn in env_fns]
        first = self.envs[0]
        self.agents_per_env = int(first.unwrapped.num_agents)
        super().__init__(len(self.envs) * self.agents_per_env, first.observation_space, first.action_space)
        self._obs = np.zeros((self.num_envs, *self.observation_space.shape), dtype=self.observation_space.dtype)
        self._actions: np.ndarray | None = None
        self._restored: dict[int, np.ndarray] = {}

    # --------------------------------------------------------------------- VecEnv

    def reset(self) -> np.ndarray:
        n = self.agents_per_env
        for k, env in enumerate(self.envs):
            obs, _ = env.reset(seed=self._seeds[k], options=self._options[k] or None)
            self._obs[k * n : (k + 1) * n] = obs
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        n = self.agents_per_env
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        assert self._actions is not None
        for k, env in enumerate(self.envs):
            rows = slice(k * n, (k + 1) * n)
            obs, _, terminated, truncated, info = env.step(self._actions[rows])
            slots = info["slots"]
            rewards[rows] = slots["rewards"]
            dones[rows] = slots["ended"]
            for i, extra in slots["episodes"].items():
                infos[k * n + i].update(extra)
            self._obs[rows] = obs
            if terminated or truncated:
                # padding slots (agents retired at an earlier step) end with the episode
                padding = ~slots["active"]
                for i in np.flatnonzero(padding):
                    infos[k * n + i].update(
                        {"terminal_observation": np.zeros_like(obs[i]), "TimeLimit.truncated": False}
                    )
                dones[rows] |= padding
                self._obs[rows], _ = env.reset()
        return self._obs.copy(), rewards, dones, infos

    def close(self) -> None:
        for env in self.envs:
            env.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        return [getattr(self.envs[slot // self.agents_per_env], attr_name) for slot in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        for k in sorted({slot // self.agents_per_env for slot in self._get_indices(indices)}):
            setattr(self.envs[k], attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        n = self.agents_per_env
        out = []
        for slot in self._get_indices(indices):
            k, i = divmod(slot, n)
            if method_name == "restore_episode":
                if i == 0:
                    self._restored[k] = np.asarray(self.envs[k].restore_episode(*method_args, **method_kwargs))
                    self._obs[k * n : (k + 1) * n] = self._restored[k]
                if k not in self._restored:
                    raise RuntimeError(f"restore slot {k * n} (agent 0 of env {k}) before slot {slot}")
                out.append(self._restored[k][i])
            else:
                out.append(getattr(self.envs[k], method_name)(*method_args, **method_kwargs))
        return out

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        from stable_baselines3.common import env_util

        return [
            env_util.is_wrapped(self.envs[slot // self.agents_per_env], wrapper_class)
            for slot in self._get_indices(indices)
        ]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [env.render() for env in self.envs]
