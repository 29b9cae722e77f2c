"""The dogfight's reward terms and conditions, registered for every reward preset.

They read the signals :class:`~pyflyt_engine.envs.multi_agent.dogfight.MAFixedwingDogfightEnv`
puts in ``ctx.extras``.  This module imports no PettingZoo: the env configs import it, so a
dogfight preset is checked at load like any other.
"""

from __future__ import annotations

from pyflyt_engine.envs.rewards import Condition, RewardTerm, StepContext, register_condition, register_term


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
