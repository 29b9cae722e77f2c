"""MAFixedwing-Dogfight: two teams of fixed-wings with fixed forward guns (the task:
:class:`~pyflyt_engine.envs.tasks.dogfight.DogfightTask`)."""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.dogfight import DogfightTask
from pyflyt_engine.envs.tasks.multi import MultiAgentTask


class MAFixedwingDogfightEnv(MultiAgentUAVEnv):
    """``ma_fixedwing_dogfight_v0``: two teams of fixed-wings; guns fire along the nose.

    The shipped config is 1 v 1 of the paper's ``fixedwing`` (``agents: 4`` gives 2 v 2, or
    list agents with their ``team`` and ``spawn``); action per agent as
    :class:`~pyflyt_engine.envs.fixedwing.FixedwingWaypointsEnv` (raw channels).

    Its manual -- loop rates, agents and spawn regions, per-agent action table and
    observation layout, reward presets with their terms and weights, task options, episode
    end, arguments -- is generated from its config and spaces: ``pyflyt envs ma_fixedwing_dogfight_v0``
    (docs/environments.md, "Env manuals").

    **Guns** (the reference PyFlyt's semantics): agent i *hits* opponent j during a step
    when j is inside i's gun cone -- the angle between i's nose (body x axis) and the line
    from i to j is below ``lethal_angle`` -- and within ``lethal_distance``.  Every agent
    starts with health 1; each step it is hit by k opponents it loses ``k x
    damage_per_second x dt``.  Teammates never hit each other.  An agent at zero health is
    shot down (terminated); the opponents that were hitting it when it died each score a
    kill.  When one team has no live agent left, the other team's live agents win
    (terminated with ``info["team_win"]``).  A retired aircraft is disarmed and glides
    down; it stays in the world as an obstacle.

    **Reward**: the dense preset is the reference's dense reward with aggressiveness 0.5:
    crash and dome-exit penalties, a team-win and a per-kill bonus, per-step hit and
    hit-taken terms, an aim term over opponents ahead and in range (1/(angle off the nose +
    0.1)) less the same seen from the opponents, pursuit (distance closed on opponents
    ahead but out of range), and floor and dome shaping; the sparse preset keeps the crash,
    dome, win, kill and hit terms.

    **Outcome** (``info["outcome"]``; None while the agent fights on, else set on its last
    step): ``loss`` (shot down), ``crash`` (contact with anything), ``out_of_bounds``
    (left the dome), ``win_by_kill`` (no opponent left in the fight and its team shot down
    at least one of them), ``win_by_default`` (no opponent left, but none was shot down:
    they all crashed or left the dome), ``time_limit`` (alive at the time limit).  When
    several happen in one step the first of loss, crash, out_of_bounds, win counts.
    ``success`` is ``outcome == "win_by_kill"``: a crash is never a success, and neither is
    an opponent's crash.  An episode succeeds when some agent's does (a team won by kills).
    ``team_win`` (and its reward) is any win, by kill or by default.  Info per agent:
    ``health``, ``hits_dealt``, ``hits_taken``, ``kills`` (this step),
    ``total_hits_taken``, ``shot_down``, ``team_win``, ``team``, ``collision``,
    ``out_of_bounds``, ``outcome``, ``success``, ``reward_terms``.

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
