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
share its simulation.  The envs run in this process, or each in its own process with
``train.vec_env=subproc`` (the same numbers under a seed; the worker side is
:mod:`pyflyt_cli.training.agent_slots`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from pyflyt_cli.training.agent_slots import AgentSlots, LocalEnv, worker

__all__ = ["AgentSlots", "AgentSlotsVecEnv", "agents_per_env", "step_unit"]


def agents_per_env(env_config: Any) -> int:
    """Vector-env slots one env of ``env_config`` fills: its agent count (1 for a single-agent env)."""
    if not getattr(env_config, "multi_agent", False):
        return 1
    return len(env_config.resolved_agents())


def step_unit(env_config: Any) -> str:
    """What ``train.total_timesteps`` counts for ``env_config``: ``steps`` or ``agent-steps``."""
    return "agent-steps" if getattr(env_config, "multi_agent", False) else "steps"


class _RemoteEnv:
    """An env of :class:`AgentSlotsVecEnv` in its own process (``train.vec_env=subproc``)."""

    def __init__(self, env_fn: Callable[[], gymnasium.Env], context: Any) -> None:
        self.remote, worker_remote = context.Pipe()
        # env_fn is an EnvFactory: plain pickle carries it (no cloudpickle, no SB3 in the worker)
        self.process = context.Process(target=worker, args=(worker_remote, self.remote, env_fn), daemon=True)
        self.process.start()
        worker_remote.close()
        self.closed = False

    def _ask(self, command: str, *data: Any) -> Any:
        self.remote.send((command, data))
        return self._answer()

    def _answer(self) -> Any:
        try:
            status, out = self.remote.recv()
        except (EOFError, ConnectionResetError) as exc:
            raise RuntimeError(
                f"an env subprocess (pid {self.process.pid}) exited unexpectedly (exit code {self.process.exitcode})"
            ) from exc
        if status == "error":
            raise RuntimeError(f"an env subprocess failed: {out}")
        return out

    def reset(self, seed: int | None, options: dict | None) -> np.ndarray:
        return self._ask("reset", seed, options)

    def step_send(self, actions: np.ndarray) -> None:
        self.remote.send(("step", actions))

    def step_recv(self) -> Any:
        return self._answer()

    def call(self, name: str, *args: Any, **kwargs: Any) -> Any:
        return self._ask("call_packed", name, args, kwargs)

    def num_agents(self) -> int:
        return self._ask("num_agents")

    def get(self, name: str) -> Any:
        return self._ask("get", name)

    def set(self, name: str, value: Any) -> None:
        self._ask("set", name, value)

    def is_wrapped(self, wrapper: tuple[str, str]) -> bool:
        return self._ask("is_wrapped", wrapper)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        try:
            self.remote.send(("close", ()))
        except (BrokenPipeError, OSError):
            pass
        self.process.join()
        self.remote.close()


class AgentSlotsVecEnv(VecEnv):
    """``n_envs`` multi-agent envs of N agents as an SB3 ``VecEnv`` of ``n_envs x N`` slots.

    Slot ``k * N + i`` is agent ``i`` of env ``k``.  Env ``k`` is reset with ``seed + k``
    at the first reset after :meth:`seed`, later with its continuing random streams.

    With ``subprocess=True`` every env runs in its own process (``train.vec_env=subproc``),
    stepped in parallel; each env's computation is the same as in this process, so a seed
    gives the same numbers either way.

    ``env_method("episode_state")`` gives, for every slot, the state of its env's episode
    in progress; ``env_method("restore_episode", state, indices=[slot])`` re-simulates the
    env at its first slot (agent 0) and returns each slot's row of the rebuilt observation
    (slots are restored in order, as :mod:`pyflyt_cli.training.continuity` does).
    """

    def __init__(self, env_fns: Sequence[Callable[[], gymnasium.Env]], subprocess: bool = False) -> None:
        if subprocess:
            import multiprocessing

            methods = multiprocessing.get_all_start_methods()
            context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
            if "forkserver" in methods:  # workers fork from a server that imported the env code once
                context.set_forkserver_preload(
                    [
                        "pyflyt_cli.training.agent_slots",
                        "pyflyt_cli.training.envs",
                        "pyflyt_engine.world",  # with scipy.signal (seconds to import)
                        "pyflyt_engine.envs.multi_agent",
                    ]
                )
            self.envs: list[Any] = [_RemoteEnv(fn, context) for fn in env_fns]
        else:
            self.envs = [LocalEnv(fn) for fn in env_fns]
        self.subprocess = subprocess
        first = self.envs[0]
        try:
            self.agents_per_env = first.num_agents()
            observation_space, action_space = first.get("observation_space"), first.get("action_space")
        except Exception:
            self.close()
            raise
        super().__init__(len(self.envs) * self.agents_per_env, observation_space, action_space)
        shape = self.observation_space.shape
        assert shape is not None  # an agent's observation row: a Box
        self._obs = np.zeros((self.num_envs, *shape), dtype=self.observation_space.dtype)
        self._actions: np.ndarray | None = None
        self._restored: dict[int, np.ndarray] = {}

    # --------------------------------------------------------------------- VecEnv

    def reset(self) -> np.ndarray:
        n = self.agents_per_env
        for k, env in enumerate(self.envs):
            self._obs[k * n : (k + 1) * n] = env.reset(self._seeds[k], self._options[k] or None)
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        n = self.agents_per_env
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = []
        assert self._actions is not None
        for k, env in enumerate(self.envs):  # all envs step at once when they are subprocesses
            env.step_send(self._actions[k * n : (k + 1) * n])
        for k, env in enumerate(self.envs):
            rows = slice(k * n, (k + 1) * n)
            obs, env_rewards, env_dones, env_infos = env.step_recv()
            self._obs[rows] = obs
            rewards[rows] = env_rewards
            dones[rows] = env_dones
            infos.extend(env_infos)
        return self._obs.copy(), rewards, dones, infos

    def close(self) -> None:
        for env in self.envs:
            env.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        return [self.envs[slot // self.agents_per_env].get(attr_name) for slot in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        for k in sorted({slot // self.agents_per_env for slot in self._get_indices(indices)}):
            self.envs[k].set(attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        n = self.agents_per_env
        out = []
        for slot in self._get_indices(indices):
            k, i = divmod(slot, n)
            if method_name == "restore_episode":
                if i == 0:
                    self._restored[k] = np.asarray(self.envs[k].call("restore_episode", *method_args, **method_kwargs))
                    self._obs[k * n : (k + 1) * n] = self._restored[k]
                if k not in self._restored:
                    raise RuntimeError(f"restore slot {k * n} (agent 0 of env {k}) before slot {slot}")
                out.append(self._restored[k][i])
            else:
                out.append(self.envs[k].call(method_name, *method_args, **method_kwargs))
        return out

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        name = (wrapper_class.__module__, wrapper_class.__qualname__)
        return [self.envs[slot // self.agents_per_env].is_wrapped(name) for slot in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [env.call("render") for env in self.envs]
