"""Typed multi-agent env configs (``conf/env/ma_*.yaml``): the agents, their airframes, teams and spawns.

A multi-agent config is an :class:`~pyflyt_engine.envs.config.EnvConfig` (loop rates, episode
length, flight dome, action, reward presets ...) plus ``agents`` and a multi-agent ``task``.
A mapping with an ``agents`` key is validated here (:func:`parse_multi_agent_config`,
reached through :func:`~pyflyt_engine.envs.config.parse_env_config`), so every loader of env
configs (``load_env_config``, ``pyflyt train env=...``, a run's ``config.yaml``, a
recording's metadata) accepts both kinds.

``agents`` is either a count -- that many agents of the env's ``uav``, placed by the task's
layout -- or a list, one entry per agent::

    agents:
      - {uav: quadx_f450, spawn: {position: [-1, 0, 1]}}
      - {uav: quadx_cf2x, spawn: {position: [1, 0, 1]}, hover_point: [1, 0, 1.5]}

Every float must be finite; unknown keys fail with the list of valid ones.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializeAsAny, field_validator

from pyflyt_engine.envs.config import EnvConfig
from pyflyt_engine.loading import check
from pyflyt_engine.errors import ConfigError

Vec3 = tuple[float, float, float]


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


class SpawnConfig(_Config):
    """Where one agent starts: a box around ``position`` and a range of attitudes (the spawn region)."""

    position: Vec3 = Field(description="centre of the spawn region (x, y, z) [m], ground frame")
    position_noise: float = Field(0.1, ge=0, description="each coordinate offset by U(-noise, noise) [m]")
    orientation: Vec3 = Field((0.0, 0.0, 0.0), description="mean attitude (roll, pitch, yaw) [rad]")
    orientation_noise: float = Field(0.1, ge=0, description="each Euler angle offset by U(-noise, noise) [rad]")
    lin_vel: Vec3 = Field((0.0, 0.0, 0.0), description="initial velocity (u, v, w) [m/s], BODY frame")


class AgentConfig(_Config):
    """One entry of ``agents``."""

    name: str | None = Field(None, description="agent name (default uav_<index>); unique")
    uav: str | None = Field(None, description="airframe (conf/uav name or YAML path); default: the env's uav")
    team: int | None = Field(None, ge=0, le=1, description="team 0 or 1 (dogfight; default: first half 0)")
    spawn: SpawnConfig | None = Field(None, description="spawn region; default: the task's layout for this index")
    hover_point: Vec3 | None = Field(None, description="hover task: the point to hold [m]; default: spawn position")


class MATaskOptions(_Config):
    """Options common to the multi-agent tasks."""

    name: str = Field(description="multi-agent task: ma_hover or dogfight")


class MAHoverOptions(MATaskOptions):
    """``task:`` of MAQuadX-Hover: every agent holds its own point."""

    name: Literal["ma_hover"] = "ma_hover"
    layout_radius: float = Field(
        1.0, ge=0, description="agents given by count spawn on a ring of this radius about the z axis [m]"
    )
    layout_height: float = Field(1.0, gt=0, description="height of that ring [m]")
    position_noise: float = Field(0.1, ge=0, description="layout spawn: U(-noise, noise) per coordinate [m]")
    orientation_noise: float = Field(0.1, ge=0, description="layout spawn: U(-noise, noise) per Euler angle [rad]")

    def layout(self, index: int, count: int) -> SpawnConfig:
        """Agent ``index`` of ``count`` on the ring (the centre for a single agent), level, at rest."""
        if count == 1:
            position = (0.0, 0.0, self.layout_height)
        else:
            angle = 2.0 * math.pi * index / count
            r = self.layout_radius
            position = (r * math.cos(angle), r * math.sin(angle), self.layout_height)
        return SpawnConfig(
            position=position, position_noise=self.position_noise, orientation_noise=self.orientation_noise
        )


class DogfightOptions(MATaskOptions):
    """``task:`` of MAFixedwing-Dogfight: guns, health and the spawn layout of the two teams."""

    name: Literal["dogfight"] = "dogfight"
    lethal_distance: float = Field(20.0, gt=0, description="gun range [m] (reference PyFlyt: 20 m)")
    lethal_angle: float = Field(
        0.07, gt=0, lt=math.pi / 2, description="half-angle of the gun cone about the nose [rad] (reference: 0.07)"
    )
    damage_per_second: float = Field(
        0.36,
        gt=0,
        description="health lost per second an opponent holds you in its gun (health starts at 1; reference: "
        "0.003 per 120 Hz control step = 0.36/s, so ~2.8 s of sustained fire kills)",
    )
    team_separation: float = Field(100.0, gt=0, description="layout: distance between the two teams at spawn [m]")
    wingman_spacing: float = Field(20.0, gt=0, description="layout: lateral spacing of teammates [m]")
    spawn_height: float = Field(40.0, gt=0, description="layout: spawn height [m]")
    position_noise: float = Field(5.0, ge=0, description="layout: U(-noise, noise) per coordinate [m]")
    heading_noise: float = Field(0.2, ge=0, description="layout: U(-noise, noise) on each Euler angle [rad]")
    spawn_speed: float = Field(14.0, ge=0, description="layout: initial airspeed along the nose [m/s]")

    def layout(self, index: int, count: int) -> SpawnConfig:
        """Team 0 (first half) at x = -separation/2 heading +x, team 1 facing it; teammates side by side."""
        half = count // 2
        team = 0 if index < half else 1
        slot = index if team == 0 else index - half
        lateral = (slot - (half - 1) / 2.0) * self.wingman_spacing
        x = (-0.5 if team == 0 else 0.5) * self.team_separation
        y = lateral if team == 0 else -lateral
        return SpawnConfig(
            position=(x, y, self.spawn_height),
            position_noise=self.position_noise,
            orientation=(0.0, 0.0, 0.0 if team == 0 else math.pi),
            orientation_noise=self.heading_noise,
            lin_vel=(self.spawn_speed, 0.0, 0.0),
        )


#: multi-agent task name -> its options model
MA_TASKS: dict[str, type[MATaskOptions]] = {"ma_hover": MAHoverOptions, "dogfight": DogfightOptions}


class MultiAgentEnvConfig(EnvConfig):
    """An :class:`EnvConfig` with several agents sharing one world (and one action layout)."""

    agents: int | list[AgentConfig] = Field(
        description="a count (that many agents of `uav`, placed by the task's layout) or one entry per agent"
    )
    task: SerializeAsAny[MATaskOptions] = Field(description="multi-agent task name and options")  # type: ignore[assignment]

    multi_agent: ClassVar[bool] = True

    @field_validator("agents")
    @classmethod
    def _agents(cls, value: int | list[AgentConfig]) -> int | list[AgentConfig]:
        if isinstance(value, int):
            if value < 1:
                raise ValueError(f"agents must be a count >= 1 or a list of agents, got {value}")
            if value > 64:
                raise ValueError(f"agents: {value} is more than the 64 agents one world is meant for")
            return value
        if not value:
            raise ValueError("agents: the list is empty; give at least one agent (or a count)")
        names = [a.name or f"uav_{i}" for i, a in enumerate(value)]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"agents: names must be unique, repeated: {', '.join(duplicates)}")
        return value

    def resolved_agents(self) -> list[ResolvedAgent]:
        """One :class:`ResolvedAgent` per agent: defaults and the task's layout filled in.

        Raises:
            ConfigError: a dogfight whose teams cannot be formed, or an agent without a spawn
                region where the task has no layout for it.
        """
        entries = [AgentConfig()] * self.agents if isinstance(self.agents, int) else list(self.agents)
        count = len(entries)
        task = self.task
        dogfight = isinstance(task, DogfightOptions)
        out = []
        for i, entry in enumerate(entries):
            spawn = entry.spawn or task.layout(i, count)  # type: ignore[attr-defined]
            team = entry.team if entry.team is not None else (0 if i < count // 2 else 1) if dogfight else 0
            hover = entry.hover_point if entry.hover_point is not None else spawn.position
            out.append(ResolvedAgent(entry.name or f"uav_{i}", entry.uav or self.uav, team, spawn, tuple(hover)))
        if dogfight:
            teams = {a.team for a in out}
            if teams != {0, 1}:
                raise ConfigError(
                    f"{self.source or 'env'}: agents: a dogfight needs agents in both teams 0 and 1, got teams "
                    f"{sorted(teams)}; give an even count (agents: 2) or set `team` on each listed agent"
                )
            if isinstance(self.agents, int) and self.agents % 2:
                raise ConfigError(
                    f"{self.source or 'env'}: agents: {self.agents} cannot form two equal teams; give an even "
                    "count or list the agents with their teams"
                )
        return out


@dataclass(frozen=True)
class ResolvedAgent:
    """One agent with every default filled in."""

    name: str
    uav: str
    team: int
    spawn: SpawnConfig
    hover_point: Vec3


def parse_multi_agent_config(data: Mapping[str, Any], source: str) -> MultiAgentEnvConfig:
    """Validate a mapping with ``agents`` as a :class:`MultiAgentEnvConfig` (one ConfigError listing every problem)."""
    data = {k: v for k, v in data.items() if k != "source"}
    task = data.get("task")
    if not isinstance(task, Mapping) or task.get("name") not in MA_TASKS:
        got = task.get("name") if isinstance(task, Mapping) else task
        raise ConfigError(
            f"{source}: a multi-agent env (one with 'agents') needs task.name one of: {', '.join(MA_TASKS)} "
            f"(got {got!r})"
        )
    options, task_problems = check(MA_TASKS[task["name"]], task, prefix="task.")
    placeholder = options if options is not None else MATaskOptions.model_construct(name=task["name"])
    config, problems = check(MultiAgentEnvConfig, {**data, "task": placeholder})
    problems = _one_branch(problems, data.get("agents")) + task_problems
    if problems:
        raise ConfigError(f"{source}: invalid multi-agent env config:\n" + "\n".join(f"  - {p}" for p in problems))
    config = config.model_copy(update={"source": source})
    config.resolved_agents()  # team and layout problems surface at load
    return config


def _one_branch(problems: list[str], agents: Any) -> list[str]:
    """Problems of ``agents`` reported for the form it was given in (count or list), not both."""
    listed = isinstance(agents, list)
    out = []
    for problem in problems:
        if problem.startswith("agents.int:") and listed:
            continue
        if problem.startswith("agents.list[AgentConfig]"):
            if not listed:
                continue
            problem = "agents" + problem[len("agents.list[AgentConfig]") :]
        out.append(problem)
    return out


#: reward signals each multi-agent task provides (checked against the reward preset)
PROVIDES: dict[str, frozenset[str]] = {
    "ma_hover": frozenset({"target_distance", "target_distance_rate"}),
    "dogfight": frozenset({"dogfight"}),
}


def check_references(config: MultiAgentEnvConfig) -> None:
    """Load the reward preset and every airframe the config names, so a wrong name fails now."""
    from pyflyt_engine.envs.config import load_reward_preset
    from pyflyt_engine.spec import load_uav_spec

    load_reward_preset(config.reward_preset_name()).compile(PROVIDES[config.task.name], config.task.name)
    for uav in dict.fromkeys(a.uav for a in config.resolved_agents()):
        load_uav_spec(uav)
