"""The dogfight task (``dogfight``): two teams of fixed-wings with fixed forward guns.

Its options (:class:`DogfightOptions`, ``task:`` of ``conf/env/ma_fixedwing_dogfight.yaml``),
its reward terms and condition (registered for every reward preset: they read the
signals the task puts in ``ctx.extras``), its task (:class:`DogfightTask`) and its
registration, run by :class:`~pyflyt_engine.envs.multi_agent.dogfight.MAFixedwingDogfightEnv`.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from pyflyt_engine import exact
from pyflyt_engine.envs.rewards import Condition, RewardTerm, StepContext, register_condition, register_term
from pyflyt_engine.envs.observe import ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.multi import AgentSignals, MATaskOptions, MultiAgentTask, SpawnConfig
from pyflyt_engine.state import KinematicState


class DogfightOptions(MATaskOptions):
    """``task:`` of MAFixedwing-Dogfight: guns, health and the spawn layout of the two teams."""

    name: Literal["dogfight"] = "dogfight"
    #: two teams: agents given by count split in halves, team 0 first
    teams: ClassVar[int] = 2
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

    def layout_spawn(self, index: int, count: int) -> SpawnConfig:
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


# ------------------------------------------------ reward terms and conditions of this task


def hits_dealt(ctx: StepContext) -> float:
    """Opponents this agent holds inside its gun cone and range this step [count] (dogfight)."""
    return ctx.extras["hits_dealt"]


def hits_taken(ctx: StepContext) -> float:
    """Opponents holding this agent inside their gun cone and range this step [count] (dogfight)."""
    return ctx.extras["hits_taken"]


def kills(ctx: StepContext) -> float:
    """Opponents whose health this agent's fire brought to zero this step [count] (dogfight)."""
    return ctx.extras["kills"]


def health(ctx: StepContext) -> float:
    """Own health after the step, 1 at spawn, 0 dead [-] (dogfight)."""
    return ctx.extras["health"]


def pursuit(ctx: StepContext) -> float:
    """Distance closed this step on opponents ahead but out of gun range, summed [m] (dogfight)."""
    return ctx.extras["pursuit"]


def aim(ctx: StepContext) -> float:
    """Sum over opponents ahead and in range of 1 / (angle off the nose + 0.1) [1/rad] (dogfight)."""
    return ctx.extras["aim"]


def aimed_at(ctx: StepContext) -> float:
    """Sum over opponents that have this agent ahead and in range of 1 / (their angle off + 0.1) [1/rad] (dogfight)."""
    return ctx.extras["aimed_at"]


def team_win(ctx: StepContext) -> bool:
    """This agent's team has just shot down or outlasted every opponent (dogfight)."""
    return ctx.extras.get("team_win", 0.0) > 0.5


register_term("hits_dealt", RewardTerm(hits_dealt, "count", ("dogfight",)))
register_term("hits_taken", RewardTerm(hits_taken, "count", ("dogfight",)))
register_term("kills", RewardTerm(kills, "count", ("dogfight",)))
register_term("health", RewardTerm(health, "1", ("dogfight",)))
register_term("pursuit", RewardTerm(pursuit, "m", ("dogfight",)))
register_term("aim", RewardTerm(aim, "1/rad", ("dogfight",)))
register_term("aimed_at", RewardTerm(aimed_at, "1/rad", ("dogfight",)))
register_condition("team_win", Condition(team_win, ("dogfight",)))


# ------------------------------------------------------------------- the task

#: entries per other agent in the observation
OTHER_SIZE = 12


def _rotations(quaternions: np.ndarray) -> np.ndarray:
    """(N, 3, 3) body-to-ground rotation matrices of (N, 4) unit quaternions (x, y, z, w)."""
    x, y, z, w = quaternions.T
    return np.stack(
        (
            np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)), axis=-1),
            np.stack((2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)), axis=-1),
            np.stack((2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)), axis=-1),
        ),
        axis=1,
    )


class DogfightTask(MultiAgentTask):
    """``dogfight``: guns, health, kills, team wins and each agent's outcome (the manual is
    :class:`~pyflyt_engine.envs.multi_agent.dogfight.MAFixedwingDogfightEnv`).

    Signals: ``dogfight`` (``hits_dealt``, ``hits_taken``, ``kills``, ``health``,
    ``pursuit``, ``aim``, ``aimed_at``, ``team_win`` in the extras; the terms are
    registered above).  A shot-down agent *fails* (a crash); a
    team's win *completes* its live agents.
    """

    name: ClassVar[str] = "dogfight"
    Options: ClassVar[type[MATaskOptions]] = DogfightOptions
    provides: ClassVar[frozenset[str]] = frozenset({"dogfight"})
    #: the guns, read at every step: a curriculum may widen the cone or the range early
    episode_options: ClassVar[frozenset[str]] = frozenset({"lethal_distance", "lethal_angle", "damage_per_second"})

    def __init__(self, *args: Any, agent_hz: float, **kwargs: Any) -> None:
        super().__init__(*args, agent_hz=agent_hz, **kwargs)
        self.agent_hz = agent_hz

    def extra_size(self) -> int:
        return 1 + OTHER_SIZE * (len(self.agents) - 1)

    def observation_parts(self) -> tuple[ObservationPart, ...]:
        parts = [ObservationPart("health", 1, "the agent's own health", "[0, 1]")]
        for k in range(len(self.agents) - 1):
            parts.append(
                ObservationPart(
                    f"other_{k}",
                    OTHER_SIZE,
                    f"other agent {k + 1} (teammates first, then opponents): relative position (3), relative "
                    "velocity (3), nose direction (3), health, same team, alive; zeros once it is down",
                    "body, m, m/s, 1; [0, 1]; 0/1; 0/1",
                )
            )
        return tuple(parts)

    def _options(self) -> DogfightOptions:
        return self.options  # type: ignore[return-value]

    def reset(self, states: list[KinematicState]) -> None:
        n = len(self.agents)
        self.health = np.ones(n)
        self.total_hits_taken = np.zeros(n, dtype=np.int64)
        self._shot_down = np.zeros(n, dtype=bool)
        #: per team: opponents it has shot down this episode
        self._team_kills = [0, 0]
        # per agent: the other agents, teammates first then opponents, in agent order
        self._others = []
        for i in range(n):
            mates = [j for j in range(n) if j != i and self.teams[j] == self.teams[i]]
            foes = [j for j in range(n) if self.teams[j] != self.teams[i]]
            self._others.append(np.array(mates + foes, dtype=np.int64))
        self._enemy = self.teams[:, None] != self.teams[None, :]
        self._engage(states)
        self._prev_distance = self._distance.copy()

    def _engage(self, states: list[KinematicState]) -> None:
        """Geometry of every pair (i shoots at j): distances, angles off i's nose, the hits."""
        self._pos = np.array([s.lin_pos for s in states])
        self._vel = np.array([s.lin_vel_ground for s in states])
        self._rot = _rotations(np.array([s.quaternion for s in states]))
        forward = self._rot[:, :, 0]
        separation = self._pos[None, :, :] - self._pos[:, None, :]  # [i, j] = p_j - p_i
        sx, sy, sz = separation[..., 0], separation[..., 1], separation[..., 2]
        distance = np.sqrt(sx * sx + sy * sy + sz * sz)
        np.fill_diagonal(distance, np.inf)
        # element-wise, in a fixed order (not einsum), and math.acos (NumPy's arccos is
        # CPU-dependent on AVX-512 machines): pyflyt_engine.exact
        cosine = (sx * forward[:, 0, None] + sy * forward[:, 1, None] + sz * forward[:, 2, None]) / distance
        angle = exact.apply(math.acos, np.clip(cosine, -1.0, 1.0))
        o = self._options()
        both_alive = self.alive[:, None] & self.alive[None, :]
        engaged = self._enemy & both_alive
        self._in_range = distance < o.lethal_distance
        self._ahead = angle < np.pi / 2
        self._hits = engaged & self._in_range & (angle < o.lethal_angle)
        self._aim = np.where(engaged & self._in_range & self._ahead, 1.0 / (angle + 0.1), 0.0)
        self._distance = distance
        self._engaged = engaged

    def update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool], step: int
    ) -> dict[int, AgentSignals]:
        o = self._options()
        self._engage(states)
        hits = self._hits
        dealt = hits.sum(axis=1)
        taken = hits.sum(axis=0)
        before = self.health.copy()
        self.health = np.maximum(0.0, self.health - o.damage_per_second / self.agent_hz * taken)
        self.total_hits_taken += taken
        killed = (before > 0.0) & (self.health <= 0.0)
        kills = (hits & killed[None, :]).sum(axis=1)
        with np.errstate(invalid="ignore"):  # inf - inf on the diagonal (an agent and itself)
            closing = np.maximum(self._prev_distance - self._distance, 0.0)
        closing = np.where(np.isfinite(closing), closing, 0.0)
        pursuit = (closing * (self._engaged & ~self._in_range & self._ahead)).sum(axis=1)
        self._prev_distance = self._distance.copy()

        # who leaves this step: shot down, crashed or out of the dome
        out = killed.copy()
        for i in live:
            x, y, z = states[i].lin_pos
            if collisions[i] or x * x + y * y + z * z > self.dome_squared:
                out[i] = True
        remaining = self.alive & ~out
        wins = np.zeros(len(self.agents), dtype=bool)
        for team in (0, 1):
            mine = self.teams == team
            if remaining[mine].any() and not remaining[~mine].any():
                wins |= mine & remaining
        self._shot_down |= killed
        for j in np.flatnonzero(killed):  # only opponents shoot: a kill is the other team's
            self._team_kills[1 - int(self.teams[j])] += 1
        time_up = step >= self.max_steps
        self.health[out & ~killed] = 0.0  # crashed or left the dome: out of the fight
        aim, aimed_at = self._aim.sum(axis=1), self._aim.sum(axis=0)
        signals = {}
        for i in live:
            extras = {
                "hits_dealt": float(dealt[i]),
                "hits_taken": float(taken[i]),
                "kills": float(kills[i]),
                "health": float(self.health[i]),
                "pursuit": float(pursuit[i]),
                "aim": float(aim[i]),
                "aimed_at": float(aimed_at[i]),
                "team_win": float(wins[i]),
            }
            x, y, z = states[i].lin_pos
            outcome = self._outcome(
                bool(killed[i]), collisions[i], x * x + y * y + z * z > self.dome_squared, bool(wins[i]), i, time_up
            )
            info: dict[str, Any] = {
                "health": float(self.health[i]),
                "hits_dealt": int(dealt[i]),
                "hits_taken": int(taken[i]),
                "kills": int(kills[i]),
                "total_hits_taken": int(self.total_hits_taken[i]),
                "shot_down": bool(killed[i]),
                "team_win": bool(wins[i]),
                "team": int(self.teams[i]),
                "outcome": outcome,
                "success": outcome == "win_by_kill",
            }
            signals[i] = AgentSignals(complete=bool(wins[i]), failed=bool(killed[i]), extras=extras, info=info)
        return signals

    def _outcome(self, shot_down: bool, crashed: bool, out: bool, won: bool, i: int, time_up: bool) -> str | None:
        """How agent ``i``'s episode ended this step (None: it fights on); the order decides
        when several happen in one step (shot down and crashing: ``loss``)."""
        if shot_down:
            return "loss"
        if crashed:
            return "crash"
        if out:
            return "out_of_bounds"
        if won:
            return "win_by_kill" if self._team_kills[int(self.teams[i])] > 0 else "win_by_default"
        return "time_limit" if time_up else None

    def observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        others = self._others[i]
        rot = self._rot[i].tolist()  # body of agent i -> ground; rows_rotate_t turns into its body frame
        rel_pos = exact.rows_rotate_t(self._pos[others], rot, self._pos[i].tolist())
        rel_vel = exact.rows_rotate_t(self._vel[others], rot, self._vel[i].tolist())
        noses = exact.rows_rotate_t(self._rot[others, :, 0], rot)
        alive = self.alive[others]
        block = np.concatenate(
            (
                rel_pos,
                rel_vel,
                noses,
                self.health[others, None],
                (self.teams[others] == self.teams[i])[:, None].astype(np.float64),
                alive[:, None].astype(np.float64),
            ),
            axis=1,
        )
        block[~alive] = 0.0
        return np.concatenate(((self.health[i],), block.ravel()))

    def episode_success(self, successes: np.ndarray) -> bool:
        """A dogfight episode succeeds when a team won by shooting down opponents (an agent's
        ``success`` is its outcome ``win_by_kill``; a crash never is)."""
        return bool(successes.any())

    def reset_info(self, i: int) -> dict[str, Any]:
        return {"health": 1.0, "team": int(self.teams[i]), "outcome": None}


register_task(DogfightTask, env="pyflyt_engine.envs.multi_agent.dogfight:MAFixedwingDogfightEnv")
