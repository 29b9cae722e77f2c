"""MAFixedwing-Dogfight: two teams of fixed-wings with fixed forward guns (the task:
:class:`~pyflyt_engine.envs.tasks.dogfight.DogfightTask`)."""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.dogfight import DogfightTask
from pyflyt_engine.envs.tasks.multi import MultiAgentTask


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

    metadata = {**MultiAgentUAVEnv.metadata, "name": "ma_fixedwing_dogfight_v0"}
    config_name: ClassVar[str | None] = "ma_fixedwing_dogfight"
    task_class: ClassVar[type[MultiAgentTask] | None] = DogfightTask
