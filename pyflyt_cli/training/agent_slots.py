"""Per-agent slots of a multi-agent env, and what runs in an env subprocess.

Kept apart from :mod:`pyflyt_cli.training.multi_agent` (the SB3 vector env) so that an env
subprocess (``train.vec_env=subproc``) imports only this, the env and NumPy: not
Stable-Baselines3 and torch, whose import would cost every worker seconds and memory.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, SupportsFloat, cast

import gymnasium
import numpy as np

if TYPE_CHECKING:
    from pyflyt_engine.envs.multi_agent.shared import SharedPolicyEnv


def _shared(env: gymnasium.Env) -> SharedPolicyEnv:
    """The multi-agent env under ``env``'s wrappers."""
    return cast("SharedPolicyEnv", env.unwrapped)


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
        self.num_agents = int(_shared(env).num_agents)
        self._returns = np.zeros(self.num_agents)
        self._lengths = np.zeros(self.num_agents, dtype=np.int64)
        self._started = time.time()

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        active = info["agent_active"]
        ended = active & (info["agent_terminated"] | info["agent_truncated"])
        rewards = np.where(active, info["agent_rewards"], 0.0)
        self._returns += rewards
        self._lengths += active
        slots_obs = np.array(obs, copy=True)
        episodes: dict[int, dict[str, Any]] = {}
        names = _shared(self.env).agent_names
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


def step_env(
    env: gymnasium.Env, actions: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
    """Step one multi-agent env (wrapped in :class:`AgentSlots`) for its N slots; reset it when its
    episode ends.  Returns the slots' observations, rewards, dones and infos."""
    obs, _, terminated, truncated, info = env.step(actions)
    slots = info["slots"]
    n = len(slots["rewards"])
    infos: list[dict[str, Any]] = [{} for _ in range(n)]
    dones = np.array(slots["ended"], dtype=bool)
    for i, extra in slots["episodes"].items():
        infos[i].update(extra)
    if terminated or truncated:
        # padding slots (agents retired at an earlier step) end with the episode
        padding = ~slots["active"]
        for i in np.flatnonzero(padding):
            infos[i].update({"terminal_observation": np.zeros_like(obs[i]), "TimeLimit.truncated": False})
        dones |= padding
        obs, _ = env.reset()
    return obs, np.asarray(slots["rewards"]), dones, infos


class LocalEnv:
    """An env of :class:`~pyflyt_cli.training.multi_agent.AgentSlotsVecEnv` in this process."""

    def __init__(self, env_fn: Callable[[], gymnasium.Env]) -> None:
        self.env = env_fn()
        self._result: Any = None

    def reset(self, seed: int | None, options: dict | None) -> np.ndarray:
        return self.env.reset(seed=seed, options=options)[0]

    def step_send(self, actions: np.ndarray) -> None:
        self._result = step_env(self.env, actions)

    def step_recv(self) -> Any:
        return self._result

    def call(self, name: str, *args: Any, **kwargs: Any) -> Any:
        return self.get(name)(*args, **kwargs)

    def call_packed(self, name: str, args: tuple, kwargs: dict) -> Any:
        return self.call(name, *args, **kwargs)

    def num_agents(self) -> int:
        return int(_shared(self.env).num_agents)

    def get(self, name: str) -> Any:
        """The attribute of the outermost wrapper (or the env) that has it, as SB3's vector envs find it."""
        return self.env.get_wrapper_attr(name)

    def set(self, name: str, value: Any) -> None:
        setattr(self.env, name, value)

    def is_wrapped(self, wrapper: tuple[str, str]) -> bool:
        """Whether a wrapper of the class named ``(module, qualified name)`` wraps the env (by
        name: the class itself is not sent to a worker, which would import its package)."""
        env = self.env
        while isinstance(env, gymnasium.Wrapper):
            if any((c.__module__, c.__qualname__) == wrapper for c in type(env).__mro__):
                return True
            env = env.env
        return False

    def close(self) -> None:
        self.env.close()


def worker(remote: Any, parent_remote: Any, env_fn: Callable[[], gymnasium.Env]) -> None:
    """A subprocess of :class:`~pyflyt_cli.training.multi_agent.AgentSlotsVecEnv`: one env,
    driven over a pipe (commands: the methods of :class:`LocalEnv`)."""
    import traceback

    parent_remote.close()
    local, failure = None, None
    try:
        try:
            local = LocalEnv(env_fn)
        except Exception as exc:  # noqa: BLE001 -- reported as the answer to every command
            failure = f"building the env failed: {type(exc).__name__}: {exc}\n{traceback.format_exc()}"
        while True:
            command, data = remote.recv()
            if command == "close":
                break
            try:
                if local is None:
                    raise RuntimeError(failure)
                if command == "step":
                    local.step_send(data)
                    out = local.step_recv()
                else:
                    out = getattr(local, command)(*data)
            except Exception as exc:  # noqa: BLE001 -- any failure is reported to the trainer, which raises it
                remote.send(("error", f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"))
            else:
                remote.send(("ok", out))
    except (EOFError, KeyboardInterrupt, BrokenPipeError):
        pass
    finally:
        if local is not None:
            local.close()
        remote.close()
