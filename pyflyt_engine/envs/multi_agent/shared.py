"""Every agent of a multi-agent env seen by one shared policy, as one Gymnasium env.

:class:`SharedPolicyEnv` wraps a :class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv`
so that the toolkit's single-env machinery -- evaluation, ``pyflyt eval``, MCAP recording
(:class:`~pyflyt_engine.telemetry.RecordEpisode`), ``pyflyt replay --verify``, exact resume --
runs a shared policy on it unchanged:

* ``observation_space`` and ``action_space`` are **one agent's** (what the shared policy
  takes and gives); ``reset`` and ``step`` return observations stacked by agent, shape
  ``(N, *obs_shape)`` in ``possible_agents`` order, and ``step`` takes actions stacked the
  same way, ``(N, *act_shape)`` (or flattened).  A policy's ``predict`` handles such a
  batch as it handles a vector env's.  Rows of retired agents are zeros (observation) and
  ignored (action).
* the reward is the *mean per-agent reward*: the sum of the live agents' rewards over N,
  so an episode's return is the mean of the agents' returns;
* the episode ends when no agent is left: *truncated* if any agent reached the time
  limit at the last step, else *terminated*;
* with a ``Dict`` observation (``camera_observation``, ``range_sensors``) the stacked
  observation is a dict of arrays, ``(N, *shape)`` per key;
* ``info`` holds per agent ``agent_rewards``, ``agent_terminated``, ``agent_truncated``
  (this step), ``agent_active`` (acted this step), ``agent_infos`` (by name), and
  ``success`` (hover: every agent survived; dogfight: a team won by shooting down opponents), ``success_rate``
  (fraction of agents whose own episode succeeded), ``collision`` / ``out_of_bounds``
  (any agent, this step), ``reward_terms`` (the per-term means, summing to the reward);
  at the episode's end ``measures``: ``agents_succeeded`` (the share of agents whose own
  episode succeeded), each of the task's per-agent measures as ``<agent>/<key>`` and their
  mean over the agents as ``<key>`` (:mod:`pyflyt_engine.envs.tasks.measures`).

Training expands the N rows into N vector-env slots (``pyflyt_cli.training.multi_agent``).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.measures import INFO_KEY, Measure, multi_agent_measures


def _shape(key: str, space: spaces.Space) -> tuple[int, ...]:
    """The shape of the observation entry ``key`` (gymnasium leaves it None for a space without one)."""
    if space.shape is None:
        raise TypeError(f"observation entry {key!r} ({space}) has no fixed shape to stack agent by agent")
    return space.shape


class SharedPolicyEnv(gymnasium.Env):
    """A parallel multi-agent env as one Gymnasium env for a shared policy (see the module docstring).

    Args:
        env: the parallel environment (owned: closed with this one).
    """

    def __init__(self, env: MultiAgentUAVEnv) -> None:
        self.parallel = env
        self.metadata = dict(env.metadata)
        self.render_mode = env.render_mode
        first = env.possible_agents[0]
        self.observation_space = env.observation_space(first)
        self.action_space = env.action_space(first)
        self.num_agents = len(env.possible_agents)
        # (None for a Dict space, stacked key by key instead)
        self._obs_shape: tuple[int, ...] = self.observation_space.shape or ()
        self._act_shape = self.action_space.shape
        names = list(env.config.action.names)
        #: names of the flattened stacked action (``<agent>.<entry>``), as recorded
        self.action_names = [f"{agent}.{n}" for agent in env.possible_agents for n in names]
        self._terms: dict[str, float] = {}
        self._successes = np.zeros(self.num_agents, dtype=bool)
        self._measures: dict[str, dict[str, float]] = {}

    # the pieces of a pyflyt env the recorder, replay and resume read (pyflyt_engine.envs.recordable.RecordableEnv)
    @property
    def payloads(self) -> Any:
        """Every agent's payloads as one (:class:`~pyflyt_engine.payloads.PayloadSets`), or None."""
        return self.parallel.payloads

    @property
    def obstacles(self) -> Any:
        """The obstacle field every agent flies among (:class:`~pyflyt_engine.obstacles.ObstacleField`), or None."""
        return self.parallel.obstacles

    def scene_markers(self) -> tuple[np.ndarray, float]:
        """Every agent's marker points, ``(n, 3)`` ground frame, and their radius [m]."""
        return np.asarray(self.parallel.markers(), dtype=float).reshape(-1, 3), 0.05

    @property
    def world(self) -> Any:
        return self.parallel.world

    @property
    def config(self) -> Any:
        return self.parallel.config

    @property
    def airframe(self) -> Any:
        return self.parallel.airframe

    @property
    def reward_preset(self) -> Any:
        return self.parallel.reward_preset

    @property
    def vehicle(self) -> Any:
        return self.parallel.vehicles[0]

    @property
    def np_random(self) -> np.random.Generator:
        return self.parallel.np_random

    @np_random.setter
    def np_random(self, value: np.random.Generator) -> None:
        self.parallel.np_random = value

    @property
    def last_randomization(self) -> dict[str, float]:
        """The values ``config.randomize`` drew at the last reset, applied to every agent (empty without)."""
        return dict(self.parallel.last_randomization)

    @property
    def last_action(self) -> np.ndarray:
        """The stacked clipped actions the vehicles received at the last step, flattened (N * A,)."""
        return self.parallel.last_actions.reshape(-1)

    @property
    def last_reward_terms(self) -> dict[str, float]:
        """Per term, the sum over live agents over N (summing to the last reward)."""
        return dict(self._terms)

    @property
    def measures(self) -> tuple[Measure, ...]:
        """What ``info["measures"]`` holds at an episode's end: the agents' success share,
        then the task's per-agent measures (mean over the agents; per agent as ``<agent>/<key>``)."""
        return multi_agent_measures(self.parallel.task.measures)

    @property
    def agent_names(self) -> list[str]:
        return list(self.parallel.possible_agents)

    # ----------------------------------------------------------------- gymnasium

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        observations, infos = self.parallel.reset(seed=seed, options=options)
        self._terms = {}
        self._successes[:] = False
        self._measures = {}
        info: dict[str, Any] = {
            "success": False,
            "collision": False,
            "out_of_bounds": False,
            "env_complete": False,
            "agent_infos": infos,
        }
        if self.parallel.randomizer is not None:
            info["randomization"] = dict(self.parallel.last_randomization)
        return self._stack(observations), info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        env = self.parallel
        actions = np.asarray(action, dtype=np.float64).reshape(self.num_agents, *self._act_shape)
        index = env.agent_index
        live = list(env.agents)
        observations, rewards, terms, truncs, infos = env.step({name: actions[index[name]] for name in live})
        n = self.num_agents
        agent_rewards = np.zeros(n)
        agent_terminated = np.zeros(n, dtype=bool)
        agent_truncated = np.zeros(n, dtype=bool)
        active = np.zeros(n, dtype=bool)
        totals: dict[str, float] = {}
        for name in live:
            i = index[name]
            active[i] = True
            agent_rewards[i] = rewards[name]
            agent_terminated[i] = terms[name]
            agent_truncated[i] = truncs[name]
            info = infos[name]
            if info.get("success"):
                self._successes[i] = True
            if INFO_KEY in info:  # this agent's episode ended: its measures
                self._measures[name] = dict(info[INFO_KEY])
            for key, value in (info.get("reward_terms") or env.last_reward_terms[i]).items():
                totals[key] = totals.get(key, 0.0) + value
        self._terms = {k: v / n for k, v in totals.items()}
        reward = float(agent_rewards.sum() / n)
        over = not env.agents
        truncated = over and bool(agent_truncated.any())
        terminated = over and not truncated
        step_info: dict[str, Any] = {
            "agent_rewards": agent_rewards,
            "agent_terminated": agent_terminated,
            "agent_truncated": agent_truncated,
            "agent_active": active,
            "agent_infos": infos,
            "collision": any(infos[name].get("collision", False) for name in live),
            "out_of_bounds": any(infos[name].get("out_of_bounds", False) for name in live),
            "env_complete": over and bool(self._successes.any()) and terminated,
            "success": bool(over and env.episode_success(self._successes)),
            "success_rate": float(self._successes.mean()),
            "reward_terms": dict(self._terms),
        }
        if over:
            step_info[INFO_KEY] = self._episode_measures()
        return self._stack(observations), reward, terminated, truncated, step_info

    def _episode_measures(self) -> dict[str, float]:
        """The episode's ``info["measures"]`` (see :attr:`measures`)."""
        out = {"agents_succeeded": float(self._successes.mean())}
        per_agent = [m.key for m in self.parallel.task.measures]
        for key in per_agent:
            values = [v[key] for v in self._measures.values() if key in v]
            finite = [x for x in values if x == x]
            out[key] = float(np.mean(finite)) if finite else float("nan")
        for name in self.parallel.possible_agents:
            for key, value in self._measures.get(name, {}).items():
                out[f"{name}/{key}"] = float(value)
        return out

    def render(self) -> Any:
        return self.parallel.render()

    def close(self) -> None:
        self.parallel.close()

    def _stack(self, observations: dict[str, Any]) -> Any:
        index = self.parallel.agent_index
        space = self.observation_space
        if isinstance(space, spaces.Dict):  # camera images, range sensors: one stacked array per key
            n = self.num_agents
            stacked = {key: np.zeros((n, *_shape(key, sub)), dtype=sub.dtype) for key, sub in space.spaces.items()}
            for name, obs in observations.items():
                for key, value in obs.items():
                    stacked[key][index[name]] = value
            return stacked
        out = np.zeros((self.num_agents, *self._obs_shape))
        for name, obs in observations.items():
            out[index[name]] = obs
        return out

    def __repr__(self) -> str:
        return f"SharedPolicyEnv({type(self.parallel).__name__}, agents={self.num_agents})"
