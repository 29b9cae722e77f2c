"""PyFlyt 0.29.0 ``MAFixedwingDogfightEnv`` (exported as ``MAFixedwingDogfightEnvV2``): its episode.

The env is a :class:`~pyflyt_engine.compat.pz_envs._aviary_base.MAFixedwingBaseEnv`, as
the reference's is, so it runs the reference's loop over the compat Aviary: a new Aviary
per reset with the teams on the reference's spawn circle, 10 settling steps, then per
agent step ``120 / agent_hz`` Aviary steps of 1/120 s with :meth:`update_states` after
each (combat state, hits, damage, rewards and endings accumulated) and one
:meth:`pop_obs_by_id` / :meth:`pop_term_trunc_rew_info_by_id` per live agent.  Every rule
below is the reference's (PyFlyt 0.29.0 ``MAFixedwingDogfightEnv``, cited per method);
the aircraft are the shipped fixed-wing, not the reference's "acrowing", so the same
actions fly other paths (docs/migrating_from_pyflyt.md).
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat.pz_envs._aviary_base import MAFixedwingBaseEnv

__all__ = ["MAFixedwingDogfightEnvV2"]

#: entries per other aircraft (PyFlyt 0.29.0: its 12 attitude entries, health, same team)
OTHER_SIZE = 14
#: PyFlyt 0.29.0: spawn speed along the nose [m/s]
SPAWN_SPEED = 20.0
#: PyFlyt 0.29.0 rewards: collision or leaving the dome (override), a team's win (override)
CRASH_REWARD, WIN_REWARD = -1000.0, 300.0


class MAFixedwingDogfightEnvV2(MAFixedwingBaseEnv):
    """PyFlyt 0.29.0 ``MAFixedwingDogfightEnv``: two teams of ``team_size`` fixed-wings.

    Arguments and defaults are the reference's.  Agents ``uav_0`` … ``uav_{2n-1}``; the
    first ``team_size`` are team 0 (``team_flag`` False), the rest team 1.

    Spawn (``_get_start_pos_orn``, ``numpy.random.RandomState(seed)`` as the reference's,
    so a seed gives the reference's spawn exactly): headings equally spaced by
    ``pi / team_size`` from a random offset, each at a radius in U(``spawn_min_radius``,
    ``spawn_max_radius``), pointing outwards (yaw = heading + U(0, pi / 8)), flying 20 m/s
    along the nose.  The reference draws the spawn *height* from the same radius bounds,
    not from ``spawn_min_height`` / ``spawn_max_height`` (accepted, unused), and so does
    this env.

    Per 1/120 s step (:meth:`update_states`): a hit is an enemy within
    ``lethal_distance`` and ``lethal_angle_radians`` of the nose; each hit taken costs
    ``damage_per_hit`` health (start 1.0).  Dense reward per agent (summed over the
    steps): 4 x distance closed on enemies it chases out of range, 30 x angle gained on
    enemies in range (lost angle x ``aggressiveness``), 3 / (angle + 0.1) on enemies in
    range ahead minus (1 - ``aggressiveness``) x the same of theirs on it, 20 per hit
    given minus (1 - ``aggressiveness``) x 20 per hit taken, ``cooperativeness`` x the
    hits its team gave, tanh(0.1 z - 1) - tanh(0.0025 r - 1) and -10 (5 - d) per aircraft
    closer than 5 m; sparse: the hit terms only.  Endings (terminated): health below
    1e-3 (``dead``), any contact (``collision``, reward set to -1000, health 0), beyond
    ``flight_dome_size`` from the origin (``out_of_bounds``, -1000, health 0), the
    opposing aircraft of the same index dead while its team lives (``team_win``, 300,
    the reference's pairing); truncated once ``step_count > max_steps``.  Infos: ``health``,
    ``received_hits`` and the flags that fired; reset infos are empty.

    Observation: ``self`` = [ang_vel, Euler angles, body velocity, position (12), aux
    (6), health, previous action (4 | 6)]; per other live aircraft 14 = [its ang_vel,
    its angles minus own, its velocity in own body frame minus own body velocity, its
    position in own body frame, its health, same team].  ``flatten_observation``:
    ``Box(self + 14 (2 team_size - 1),)`` zero-padded; else ``Dict(self, others)`` with
    ``others`` a stacked ``Sequence``.
    """

    # the pairwise (n, n) arrays each reset makes: who is in whose cone and range, chasing and
    # hitting whom, and the angles, offsets and distances between them
    in_cone: np.ndarray
    in_range: np.ndarray
    chasing: np.ndarray
    current_hits: np.ndarray
    current_angles: np.ndarray
    current_offsets: np.ndarray
    current_distances: np.ndarray

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human"], "name": "ma_fixedwing_team_dogfight"}

    def __init__(
        self,
        team_size: int = 2,
        spawn_min_radius: float = 10.0,
        spawn_max_radius: float = 50.0,
        spawn_min_height: float = 20.0,
        spawn_max_height: float = 50.0,
        damage_per_hit: float = 0.003,
        lethal_distance: float = 20.0,
        lethal_angle_radians: float = 0.07,
        assisted_flight: bool = True,
        aggressiveness: float = 0.5,
        cooperativeness: float = 0.5,
        sparse_reward: bool = False,
        flatten_observation: bool = True,
        flight_dome_size: float = 800.0,
        max_duration_seconds: float = 60.0,
        agent_hz: int = 30,
        render_mode: None | str = None,
    ) -> None:
        if int(team_size) != team_size or team_size < 1:
            raise ValueError(f"team_size must be a whole number of at least 1, got {team_size}")
        if not spawn_min_radius <= spawn_max_radius:
            raise ValueError(
                f"spawn_min_radius ({spawn_min_radius}) must not exceed spawn_max_radius ({spawn_max_radius})"
            )
        n = 2 * int(team_size)
        super().__init__(
            start_pos=np.zeros((n, 3)),
            start_orn=np.zeros((n, 3)),
            assisted_flight=assisted_flight,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation="euler",
            agent_hz=agent_hz,
            render_mode=render_mode,
        )
        self.team_size = int(team_size)
        self.spawn_min_radius, self.spawn_max_radius = float(spawn_min_radius), float(spawn_max_radius)
        self.spawn_min_height, self.spawn_max_height = float(spawn_min_height), float(spawn_max_height)
        self.sparse_reward = bool(sparse_reward)
        self.flatten_observation = bool(flatten_observation)
        self.damage_per_hit = float(damage_per_hit)
        self.lethal_distance = float(lethal_distance)
        self.lethal_angle = float(lethal_angle_radians)
        self.aggressiveness = float(aggressiveness)
        self.cooperativeness = float(cooperativeness)
        #: PyFlyt 0.29.0: False for the first team, True for the second
        self.team_flag = np.arange(n) >= self.team_size
        #: [shooter, target]: True where they are on opposite teams
        self.friendly_fire_mask = self.team_flag[:, None] != self.team_flag[None, :]

        self._self_size = self.combined_space.shape[0] + 1
        self._flat_size = self._self_size + (n - 1) * OTHER_SIZE
        if self.flatten_observation:
            self._observation_space: spaces.Space = spaces.Box(
                -np.inf, np.inf, shape=(self._flat_size,), dtype=np.float64
            )
        else:
            self._observation_space = spaces.Dict(
                {
                    "self": spaces.Box(-np.inf, np.inf, shape=(self._self_size,), dtype=np.float64),
                    "others": spaces.Sequence(
                        spaces.Box(-np.inf, np.inf, shape=(OTHER_SIZE,), dtype=np.float64), stack=True
                    ),
                }
            )

    def observation_space(self, agent: Any = None) -> spaces.Space:
        return self._observation_space

    @property
    def world(self) -> Any:
        """The native :class:`~pyflyt_engine.world.World` under the Aviary (after a reset)."""
        return self.aviary.world

    # ------------------------------------------------------------------ reset

    def _get_start_pos_orn(self, seed: None | int) -> tuple[np.ndarray, np.ndarray]:
        """PyFlyt 0.29.0 ``_get_start_pos_orn``, from ``RandomState(seed)`` in its order of draws:
        heading offset, radii, heights (from the radius bounds), yaw offsets."""
        rng = np.random.RandomState(seed=seed)
        n = self.num_possible_agents
        heading = np.pi / self.team_size * np.arange(n) + rng.uniform(0.0, 2.0 * np.pi)
        radius = rng.uniform(low=self.spawn_min_radius, high=self.spawn_max_radius, size=(n,))
        height = rng.uniform(low=self.spawn_min_radius, high=self.spawn_max_radius, size=(n,))
        start_pos = np.stack((radius * np.cos(heading), radius * np.sin(heading), height), axis=-1)
        start_orn = np.zeros((n, 3))
        start_orn[:, 2] = heading + rng.random(n) * np.pi / 8.0
        return start_pos, start_orn

    def reset(
        self, seed: None | int = None, options: None | dict[str, Any] = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The reference's reset: spawn circle, a new Aviary, zeroed combat state, 10 settling steps."""
        self.start_pos, self.start_orn = self._get_start_pos_orn(seed)
        _, forward = self.compute_rotation_forward(self.start_orn)
        drone_options = [{"starting_velocity": SPAWN_SPEED * f} for f in forward]
        super().begin_reset(seed, options, drone_options=drone_options)
        n = self.num_possible_agents
        self.drone_ids = np.array([drone.Id for drone in self.aviary.drones])
        self.inactive = np.zeros(n, dtype=bool)
        self.healths = np.ones(n, dtype=np.float32)
        self.attitudes = np.zeros((n, 4, 3), dtype=np.float32)
        self.other_attitudes = np.zeros((n, n, 4, 3), dtype=np.float32)
        for name in ("in_cone", "in_range", "chasing", "current_hits"):
            setattr(self, name, np.zeros((n, n), dtype=bool))
        for name in ("current_angles", "current_offsets", "current_distances"):
            setattr(self, name, np.zeros((n, n), dtype=np.float32))
        self.previous_hits = self.current_hits.copy()
        self.previous_angles = self.current_angles.copy()
        self.previous_offsets = self.current_offsets.copy()
        self.previous_distances = self.current_distances.copy()
        self.distances_from_origin = np.zeros(n, dtype=np.float32)
        self.accumulated_rewards = np.zeros(n, dtype=np.float32)
        self.accumulated_terminations = np.zeros(n, dtype=bool)
        self.accumulated_truncations = np.zeros(n, dtype=bool)
        self.accumulated_infos: list[dict[str, Any]] = [{} for _ in range(n)]
        self.received_hits = np.zeros(n, dtype=np.int32)
        super().end_reset(seed, options)
        observations = {agent: self.pop_obs_by_id(self.agent_name_mapping[agent]) for agent in self.agents}
        return observations, {agent: {} for agent in self.agents}

    # ------------------------------------------------------------------ per 1/120 s

    def update_states(self) -> None:
        """After every Aviary step: observations, then rewards and endings (PyFlyt 0.29.0)."""
        self._compute_observation()
        self._compute_term_trunc_rew_info()

    def _compute_combat_state(self) -> tuple[np.ndarray, ...]:
        """PyFlyt 0.29.0 ``_compute_combat_state``: [shooter, target] geometry and the relative states.

        The reference shifts its state's position (the nose) 0.35 m back to the body's
        centre; the compat state's position is the centre already.
        """
        rotation, forward = self.compute_rotation_forward(self.attitudes[:, 1].astype(np.float64))
        position = self.attitudes[:, -1, :]
        separation = position[None, :, :] - position[:, None, :]  # [i, j] = p_j - p_i
        distances = np.linalg.norm(separation, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):  # i == j: 0 / 0, removed downstream
            angles = np.arccos(np.sum(separation * forward[:, None, :], axis=-1) / distances)
        offsets = np.linalg.norm(np.cross(separation, forward[:, None, :]), axis=-1)
        in_cone = angles < self.lethal_angle
        in_range = distances < self.lethal_distance
        chasing = np.abs(angles) < np.pi / 2.0
        hits = in_cone & in_range & chasing

        n = self.num_possible_agents
        others = np.zeros((n, n, 4, 3), dtype=np.float64)
        others[:, :, 0, :] = self.attitudes[None, :, 0, :]  # their body rates
        others[:, :, 1, :] = self.attitudes[None, :, 1, :] - self.attitudes[:, None, 1, :]
        ground_velocity = np.einsum("jab,jb->ja", rotation, self.attitudes[:, 2, :])
        # their ground velocity in my body frame, minus my body velocity
        others[:, :, 2, :] = np.einsum("iba,jb->ija", rotation, ground_velocity) - self.attitudes[:, None, 2, :]
        others[:, :, 3, :] = np.einsum("iba,ijb->ija", rotation, separation)  # their position in my body frame
        from_origin = np.linalg.norm(position, axis=-1)
        return in_cone, in_range, chasing, hits, distances, angles, offsets, others, from_origin

    def _compute_observation(self) -> None:
        """PyFlyt 0.29.0 ``_compute_observation``: states, hits and damage, the observations."""
        self.attitudes = np.stack(self.aviary.all_states, axis=0)
        self.previous_hits = self.current_hits.copy()
        self.previous_distances = self.current_distances.copy()
        self.previous_angles = self.current_angles.copy()
        self.previous_offsets = self.current_offsets.copy()
        (
            self.in_cone,
            self.in_range,
            self.chasing,
            self.current_hits,
            self.current_distances,
            self.current_angles,
            self.current_offsets,
            self.other_attitudes,
            self.distances_from_origin,
        ) = self._compute_combat_state()
        self.current_hits &= self.friendly_fire_mask
        taken = self.current_hits.sum(axis=0)
        self.received_hits += taken.astype(np.int32)
        self.healths -= self.damage_per_hit * taken
        self.healths[self.healths < 0.0] = 0.0
        # down: no health, below 2 m and slower than 0.1 m/s
        self.inactive = (
            (self.healths <= 0.0)
            & (self.attitudes[:, -1, -1] < 2.0)
            & (np.linalg.norm(self.attitudes[:, -2, :], axis=-1) < 0.1)
        )
        n = self.num_possible_agents
        flat_attitudes = self.attitudes.reshape(n, -1)
        flat_others = self.other_attitudes.reshape(n, n, -1)
        self.observations: list[dict[Literal["self", "others"], np.ndarray]] = []
        for i in range(n):
            relevant = ~self.inactive
            relevant[i] = False
            self.observations.append(
                {
                    "self": np.concatenate(
                        (flat_attitudes[i], self.aviary.aux_state(i), self.healths[i : i + 1], self.past_actions[i])
                    ),
                    "others": np.concatenate(
                        (
                            flat_others[i][relevant],
                            self.healths[relevant, None],
                            (self.team_flag[relevant] == self.team_flag[i])[:, None],
                        ),
                        axis=-1,
                    ),
                }
            )

    def _compute_engagement_rewards(self) -> np.ndarray:
        """PyFlyt 0.29.0 ``_compute_engagement_rewards``: [self, other] terms summed per self."""
        n = self.num_possible_agents
        rewards = np.zeros((n, n), dtype=np.float32)
        enemy = self.friendly_fire_mask
        with np.errstate(invalid="ignore"):  # the diagonal's NaN angles, zeroed below
            if not self.sparse_reward:
                closing = np.clip(self.previous_distances - self.current_distances, 0.0, None)
                rewards += 4.0 * closing * (~self.in_range & self.chasing & enemy)
                gained = (self.previous_angles - self.current_angles) * (self.in_range & enemy)
                gained[gained < 0.0] *= self.aggressiveness
                rewards += 30.0 * gained
                aim = (1.0 / (self.current_angles + 0.1)) * (enemy & self.in_range & self.chasing)
                rewards += 3.0 * (aim - (1.0 - self.aggressiveness) * aim.T)
            rewards += 20.0 * (self.current_hits - (1.0 - self.aggressiveness) * self.current_hits.T)
            np.fill_diagonal(rewards, 0.0)
        per_agent = rewards.sum(axis=1)
        # each side shares cooperativeness x the hits its members made
        for side in (True, False):
            members = self.team_flag == side
            per_agent[members] += self.cooperativeness * self.current_hits[members].sum()
        return per_agent

    def _compute_boundary_rewards(self) -> np.ndarray:
        """PyFlyt 0.29.0 ``_compute_boundary_rewards``: height, dome and separation terms."""
        n = self.num_possible_agents
        rewards = np.zeros(n, dtype=np.float32)
        if not self.sparse_reward:
            rewards += np.tanh(0.1 * self.attitudes[:, -1, -1] - 1.0)
            rewards -= np.tanh(0.0025 * self.distances_from_origin - 1.0)
            too_close = (self.current_distances < 5.0) & ~np.eye(n, dtype=bool)
            rewards -= np.sum(10.0 * too_close * (5.0 - self.current_distances), axis=-1)
        return rewards

    def _compute_term_trunc_rew_info(self) -> None:
        """PyFlyt 0.29.0 ``_compute_term_trunc_rew_info``: accumulate until popped."""
        self.accumulated_rewards += self._compute_engagement_rewards()
        self.accumulated_rewards += self._compute_boundary_rewards()
        self.accumulated_truncations |= self.step_count > self.max_steps
        no_health = self.healths <= 1e-3
        self.accumulated_terminations |= no_health
        collisions = self.aviary.contact_array[self.drone_ids].sum(axis=-1) > 0
        out_of_bounds = self.distances_from_origin > self.flight_dome_size
        for ended in (collisions, out_of_bounds):
            self.accumulated_terminations |= ended
            self.accumulated_rewards[ended] = CRASH_REWARD
            self.healths[ended] = 0.0
        # the reference pairs the k-th member of a side with the k-th of the other
        wins = np.zeros(self.num_possible_agents, dtype=bool)
        for side in (True, False):
            mine = self.team_flag == side
            wins[mine] = (self.healths[~mine] <= 0.0) & np.any(self.healths[mine] > 0.0)
        self.accumulated_terminations |= wins
        self.accumulated_rewards[wins] = WIN_REWARD
        for i, info in enumerate(self.accumulated_infos):
            info["health"] = self.healths[i]
            info["received_hits"] = self.received_hits[i]
            for key, flags in (
                ("dead", no_health),
                ("collision", collisions),
                ("out_of_bounds", out_of_bounds),
                ("team_win", wins),
            ):
                if flags[i]:
                    info[key] = True

    # ------------------------------------------------------------------ per agent step

    def pop_obs_by_id(self, agent_id: int) -> Any:
        """The observation of ``agent_id`` (flattened and zero-padded, or the Dict)."""
        observation = self.observations[agent_id]
        if not self.flatten_observation:
            return observation
        flat = np.zeros(self._flat_size)
        joined = np.concatenate((observation["self"], observation["others"].reshape(-1)))
        flat[: joined.size] = joined
        return flat

    def pop_term_trunc_rew_info_by_id(self, agent_id: int) -> tuple[bool, bool, float, dict[str, Any]]:
        """Termination, truncation, the reward and info accumulated since the last pop (then cleared)."""
        reward = self.accumulated_rewards[agent_id]
        info = self.accumulated_infos[agent_id]
        self.accumulated_rewards[agent_id] = 0.0
        self.accumulated_infos[agent_id] = {}
        return (
            bool(self.accumulated_terminations[agent_id]),
            bool(self.accumulated_truncations[agent_id]),
            float(reward),
            info,
        )
