"""What an env shows of itself to the recorder and replay (:class:`RecordableEnv`)."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class RecordableEnv(Protocol):
    """The public face of an env that :class:`~pyflyt_engine.telemetry.RecordEpisode` records
    and :func:`~pyflyt_engine.telemetry.replay.verify` re-simulates: nothing else of an env is
    read from outside.  :class:`~pyflyt_engine.envs.env.UAVEnv` and
    :class:`~pyflyt_engine.envs.multi_agent.shared.SharedPolicyEnv` implement it.

    Attributes:
        world: the :class:`~pyflyt_engine.world.World` (vehicles, contacts, wind, RNG state).
        config: the resolved env config.
        airframe: the airframe flown before a task adjusts it.
        reward_preset: the resolved reward preset.
        np_random: the env's generator (its state is recorded at each reset).
        payloads: the env's :class:`~pyflyt_engine.payloads.PayloadSet` (every agent's as one
            :class:`~pyflyt_engine.payloads.PayloadSets` in a multi-agent env), or None.
        obstacles: the env's :class:`~pyflyt_engine.obstacles.ObstacleField`, or None (its mesh
            files are embedded in a recording).
        action_names: the names of the recorded action vector's entries.
        last_action: the action the vehicles received at the last step (flat).
        last_reward_terms: the reward breakdown of the last step.
        last_randomization: the values domain randomisation drew at the last reset.
    """

    world: Any
    config: Any
    airframe: Any
    reward_preset: Any
    np_random: np.random.Generator
    payloads: Any
    obstacles: Any

    @property
    def action_names(self) -> list[str]: ...

    @property
    def last_action(self) -> np.ndarray: ...

    @property
    def last_reward_terms(self) -> dict[str, float]: ...

    @property
    def last_randomization(self) -> dict[str, float]: ...

    def scene_markers(self) -> tuple[np.ndarray, float]:
        """The points drawn in the scene now, ``(n, 3)`` ground frame, and their radius [m]."""
        ...


#: the members of :class:`RecordableEnv`, for messages naming what an env lacks
RECORDABLE = (
    "world", "config", "airframe", "reward_preset", "np_random", "payloads", "obstacles", "action_names",
    "last_action", "last_reward_terms", "last_randomization", "scene_markers",
)  # fmt: skip
