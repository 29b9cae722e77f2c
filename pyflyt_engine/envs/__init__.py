"""Gymnasium environments (paper, "Gymnasium Environments").

Importing this package (which ``import pyflyt_engine`` does) registers the ids in
:data:`ENVS` with Gymnasium, by entry-point *string*, so registering imports neither
PyBullet nor the env modules::

    import gymnasium, pyflyt_engine
    env = gymnasium.make("PyFlyt/QuadX-Hover-v0", sparse_reward=True)

Layout: :mod:`.env` (the generic loop, :class:`UAVEnv`); :mod:`.quadx`, :mod:`.fixedwing`,
:mod:`.rocket` ... (the registered classes, whose docstrings say what each task is for);
:mod:`.manual` (each env's manual, generated from its config and spaces: ``pyflyt envs <id>``); :mod:`.tasks`
(spawn, targets, observations, completion); :mod:`.rewards` (named terms and
conditions); :mod:`.waypoints` (waypoint logic shared by every waypoint task);
:mod:`.config` (typed YAML configs); :mod:`.wrappers` (``FlattenWaypointEnv``);
:mod:`.render`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gymnasium.envs.registration import register, registry

if TYPE_CHECKING:
    from pyflyt_engine.envs.config import EnvConfig
    from pyflyt_engine.envs.env import UAVEnv


@dataclass(frozen=True)
class EnvEntry:
    """A registered environment: its class (as an import string) and its shipped config."""

    entry_point: str
    config: str


#: Gymnasium id -> registration.  Behaviour changes get a new version id.
ENVS: dict[str, EnvEntry] = {
    "PyFlyt/QuadX-Hover-v0": EnvEntry("pyflyt_engine.envs.quadx:QuadXHoverEnv", "quadx_hover"),
    "PyFlyt/QuadX-Waypoints-v0": EnvEntry("pyflyt_engine.envs.quadx:QuadXWaypointsEnv", "quadx_waypoints"),
    "PyFlyt/Fixedwing-Waypoints-v0": EnvEntry(
        "pyflyt_engine.envs.fixedwing:FixedwingWaypointsEnv", "fixedwing_waypoints"
    ),
    "PyFlyt/Rocket-Landing-v0": EnvEntry("pyflyt_engine.envs.rocket:RocketLandingEnv", "rocket_landing"),
    "PyFlyt/Rocket-Landing-Velocity-v0": EnvEntry(
        "pyflyt_engine.envs.rocket:RocketLandingVelocityEnv", "rocket_landing_velocity"
    ),
    "PyFlyt/Rocket-Landing-Descent-v0": EnvEntry(
        "pyflyt_engine.envs.rocket:RocketLandingDescentEnv", "rocket_landing_descent"
    ),
    "PyFlyt/QuadX-Pole-Balance-v0": EnvEntry(
        "pyflyt_engine.envs.quadx_payloads:QuadXPoleBalanceEnv", "quadx_pole_balance"
    ),
    "PyFlyt/QuadX-Pole-Waypoints-v0": EnvEntry(
        "pyflyt_engine.envs.quadx_payloads:QuadXPoleWaypointsEnv", "quadx_pole_waypoints"
    ),
    "PyFlyt/QuadX-Ball-In-Cup-v0": EnvEntry("pyflyt_engine.envs.quadx_payloads:QuadXBallInCupEnv", "quadx_ball_in_cup"),
    "PyFlyt/QuadX-Gates-v0": EnvEntry("pyflyt_engine.envs.quadx_gates:QuadXGatesEnv", "quadx_gates"),
    "PyFlyt/QuadX-Obstacles-v0": EnvEntry("pyflyt_engine.envs.quadx_obstacles:QuadXObstaclesEnv", "quadx_obstacles"),
}


def register_envs() -> None:
    """Register every id of :data:`ENVS` with Gymnasium (idempotent)."""
    for env_id, entry in ENVS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry.entry_point)


def make_env(config: str | Path | Mapping[str, Any] | EnvConfig, **overrides: Any) -> UAVEnv:
    """Build the environment an env config describes (no Gymnasium wrappers).

    Uses the registered class when the config's ``id`` is in :data:`ENVS` (so the
    instance carries that env's class docstring), else :class:`UAVEnv`.  ``overrides`` as for
    :class:`UAVEnv` (``sparse_reward=True``, ``num_targets=3``, ...).  A multi-agent config
    (one with ``agents``) gives its parallel env wrapped in
    :class:`~pyflyt_engine.envs.multi_agent.shared.SharedPolicyEnv`.
    """
    import importlib

    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.envs.env import UAVEnv

    cfg = load_env_config(config)
    if getattr(cfg, "multi_agent", False):  # several agents: one shared-policy view of the parallel env
        from pyflyt_engine.envs.multi_agent import env_class
        from pyflyt_engine.envs.multi_agent.shared import SharedPolicyEnv

        return SharedPolicyEnv(env_class(cfg.task.name)(cfg, **overrides))  # type: ignore[return-value]
    cls: type[UAVEnv] = UAVEnv
    if cfg.id in ENVS:
        module, _, name = ENVS[cfg.id].entry_point.partition(":")
        cls = getattr(importlib.import_module(module), name)
    return cls(cfg, **overrides)


#: lazy exports besides the registered env classes (name -> module): the env classes import
#: PyBullet, registration must not
_LAZY = {
    "make_batched_env": "pyflyt_engine.batched.env",
    "BatchedUAVEnv": "pyflyt_engine.batched.env",
    "UAVEnv": "pyflyt_engine.envs.env",
    "FlattenWaypointEnv": "pyflyt_engine.envs.wrappers",
    "EnvConfig": "pyflyt_engine.envs.config",
    "RewardPreset": "pyflyt_engine.envs.config",
    "env_config_data": "pyflyt_engine.envs.config",
    "load_env_config": "pyflyt_engine.envs.config",
    "load_reward_preset": "pyflyt_engine.envs.config",
}


def __getattr__(name: str) -> Any:
    # lazy exports: every registered env class by its entry point's name, and _LAZY
    lazy = {e.entry_point.partition(":")[2]: e.entry_point.partition(":")[0] for e in ENVS.values()} | _LAZY
    if name in lazy:
        import importlib

        return getattr(importlib.import_module(lazy[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


register_envs()

__all__ = [
    "ENVS",
    "EnvConfig",
    "EnvEntry",
    "FlattenWaypointEnv",
    "RewardPreset",
    "UAVEnv",
    "env_config_data",
    "load_env_config",
    "load_reward_preset",
    "make_env",
    "register_envs",
    # the registered env classes (lazy exports)
    *(entry.entry_point.partition(":")[2] for entry in ENVS.values()),
]
