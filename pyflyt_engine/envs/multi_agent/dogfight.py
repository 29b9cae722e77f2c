"""MAFixedwing-Dogfight: two teams of fixed-wings with fixed forward guns."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.envs.config import DogfightOptions
from pyflyt_engine.envs.multi_agent.base import AgentSignals, MultiAgentUAVEnv
from pyflyt_engine.state import KinematicState

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


class MAFixedwingDogfightEnv(MultiAgentUAVEnv):
    """``ma_fixedwing_dogfight_v0``: two teams of fixed-wings; guns fire along the nose.

    Config: ``conf/env/ma_fixedwing_dogfight.yaml`` (1 v 1 of the paper's ``fixedwing``;
    ``agents: 4`` gives 2 v 2, or list agents with their ``team`` and ``spawn``).

    **Guns** (the reference PyFlyt's semantics): agent i *hits* opponent j during a step
    when j is inside i's gun cone -- the angle between i's nose (body x axis) and the line
    from i to j is below ``lethal_angle`` = 0.07 rad -- and within ``lethal_distance`` =
    20 m.  Every agent starts with health 1; each step it is hit by k opponents it loses
    ``k x damage_per_second x dt`` (0.36/s: an opponent must be held in the cone for
    ~2.8 s of sustained fire to kill).  Teammates never hit each other.  An agent at zero
    health is shot down (terminated); the opponents that were hitting it when it died
    each score a kill.  When one team has no live agent left, the other team's live
    agents win (terminated with ``info["team_win"]``).

    **Action space** (per agent) ``Box(4,)`` float64: aileron, elevator, rudder in [-1, 1],
    thrust in [0, 1] -- the raw channels, as
    :class:`~pyflyt_engine.envs.fixedwing.FixedwingWaypointsEnv`.

    **Observation space** (per agent) ``Box(24 + 12 (N - 1),)`` float64 (quaternion):

    * own attitude vector (23, as Fixedwing-Waypoints: angular velocity, attitude, body
      velocity, position, previous action, throttle and surface deflections), then own
      health (1);
    * one block of 12 per other agent -- teammates first, then opponents, each in agent
      order -- all in this agent's body frame: relative position (3) [m], relative
      velocity (3) [m/s], the other's nose direction (3), its health (1), same team (1),
      alive (1).  A retired agent's block is zeros.

    **Reward** per agent (dense, preset ``ma_fixedwing_dogfight_dense``; terms in each
    agent's ``info["reward_terms"]``), the reference's dense reward with aggressiveness 0.5::

        crash         -1000   contact with anything, ground included
        out_of_bounds -1000   beyond flight_dome_size = 800 m from the origin
        team_win      +300
        kill          +100 per kill
        hit           +20 per opponent in the gun this step;  hit_taken -10 per gunner on you
        aim           +3 x sum over opponents ahead and in range of 1/(angle off the nose + 0.1)
        aimed_at      -1.5 x the same seen from the opponents
        pursuit       +4 x distance closed [m] on opponents ahead but out of range
        floor         +tanh(0.1 z - 1);  dome  -tanh(0.0025 ||p|| - 1)

    Sparse (``ma_fixedwing_dogfight_sparse``): crash, out_of_bounds, team_win, kill, hit,
    hit_taken only.

    **Episode end** (per agent): terminated when shot down (``info["shot_down"]``), on a
    crash or dome exit, or on a team win; truncated for the live agents after
    ``max_duration_seconds`` = 60 s (1800 steps).  A retired aircraft is disarmed and
    glides down; it stays in the world as an obstacle.

    **Info** per agent: ``health``, ``hits_dealt``, ``hits_taken``, ``kills`` (this
    step), ``total_hits_taken``, ``shot_down``, ``team_win``, ``team``, ``collision``,
    ``out_of_bounds``, ``outcome``, ``success``, ``reward_terms``.

    **Outcome** (``info["outcome"]``; None while the agent fights on, else set on its last
    step): ``loss`` (shot down), ``crash`` (contact with anything), ``out_of_bounds``
    (left the dome), ``win_by_kill`` (no opponent left in the fight and its team shot down
    at least one of them), ``win_by_default`` (no opponent left, but none was shot down:
    they all crashed or left the dome), ``time_limit`` (alive at the time limit).  When
    several happen in one step the first of loss, crash, out_of_bounds, win counts.
    ``success`` is ``outcome == "win_by_kill"``: a crash is never a success, and neither is
    an opponent's crash.  An episode succeeds when some agent's does (a team won by kills).
    ``team_win`` (and its reward) is any win, by kill or by default.

    **Arguments**: ``agents`` (count or list), ``lethal_distance`` (20 m), ``lethal_angle``
    (0.07 rad), ``damage_per_second`` (0.36), ``team_separation`` (100 m),
    ``wingman_spacing`` (20 m), ``spawn_height`` (40 m), ``position_noise`` (5 m),
    ``heading_noise`` (0.2 rad), ``spawn_speed`` (14 m/s), ``reward``, rates,
    ``max_duration_seconds`` (60), ``flight_dome_size`` (800), ``uav`` ("fixedwing").

    **Version history**: v0 -- the reference PyFlyt 0.29.0 ``MAFixedwingDogfightEnv``
    differs: its own high-manoeuvrability airframe flown through an attitude-assist mode;
    agents spawned on a circle facing outwards (here: the teams face each other); hits
    counted per 120 Hz control step (here per agent step with the same damage per
    second); a nose point 0.35 m ahead of the centre of mass as gun origin (here the
    centre of mass); no kill bonus and a ``cooperativeness`` share of teammates' hit
    rewards (here a kill bonus, no sharing); an aircraft is deactivated only once it rests
    on the ground (here when its episode ends).
    """

    metadata: ClassVar[dict] = {**MultiAgentUAVEnv.metadata, "name": "ma_fixedwing_dogfight_v0"}
    config_name: ClassVar[str | None] = "ma_fixedwing_dogfight"
    task_name: ClassVar[str] = "dogfight"

    def _extra_size(self) -> int:
        return 1 + OTHER_SIZE * (len(self.possible_agents) - 1)

    def _options(self) -> DogfightOptions:
        return self.config.task  # type: ignore[return-value]

    def _task_reset(self, states: list[KinematicState]) -> None:
        n = len(self.possible_agents)
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
        both_alive = self._alive[:, None] & self._alive[None, :]
        engaged = self._enemy & both_alive
        self._in_range = distance < o.lethal_distance
        self._ahead = angle < np.pi / 2
        self._hits = engaged & self._in_range & (angle < o.lethal_angle)
        self._aim = np.where(engaged & self._in_range & self._ahead, 1.0 / (angle + 0.1), 0.0)
        self._distance = distance
        self._engaged = engaged

    def _task_update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool]
    ) -> dict[int, AgentSignals]:
        o = self._options()
        self._engage(states)
        hits = self._hits
        dealt = hits.sum(axis=1)
        taken = hits.sum(axis=0)
        before = self.health.copy()
        self.health = np.maximum(0.0, self.health - o.damage_per_second / self.config.agent_hz * taken)
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
            if collisions[i] or x * x + y * y + z * z > self._dome2:
                out[i] = True
        remaining = self._alive & ~out
        wins = np.zeros(len(self.possible_agents), dtype=bool)
        for team in (0, 1):
            mine = self.teams == team
            if remaining[mine].any() and not remaining[~mine].any():
                wins |= mine & remaining
        self._shot_down |= killed
        for j in np.flatnonzero(killed):  # only opponents shoot: a kill is the other team's
            self._team_kills[1 - int(self.teams[j])] += 1
        time_up = self._steps >= self._max_steps
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
                bool(killed[i]), collisions[i], x * x + y * y + z * z > self._dome2, bool(wins[i]), i, time_up
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

    def _task_observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        others = self._others[i]
        rot = self._rot[i].tolist()  # body of agent i -> ground; rows_rotate_t turns into its body frame
        rel_pos = exact.rows_rotate_t(self._pos[others], rot, self._pos[i].tolist())
        rel_vel = exact.rows_rotate_t(self._vel[others], rot, self._vel[i].tolist())
        noses = exact.rows_rotate_t(self._rot[others, :, 0], rot)
        alive = self._alive[others]
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

    def _reset_info(self, i: int) -> dict[str, Any]:
        return {**super()._reset_info(i), "health": 1.0, "team": int(self.teams[i]), "outcome": None}
