"""The formation task's reward terms and condition, registered for every reward preset.

They read the signals :class:`~pyflyt_engine.envs.multi_agent.formation.MAQuadXFormationEnv`
puts in ``ctx.extras`` (the ``formation`` signal).  This module imports no PettingZoo: the
env configs import it, so a formation preset is checked at load like any other.
"""

from __future__ import annotations

from pyflyt_engine.envs.rewards import Condition, RewardTerm, StepContext, register_condition, register_term


def formation_error(ctx: StepContext) -> float:
    """Distance between the agent's offset from the swarm's centroid and its slot's offset
    from the centroid of the slots (live agents only) [m]: the error of the shape, wherever
    the swarm is (formation)."""
    return ctx.extras["formation_error"]


def crowding(ctx: StepContext) -> float:
    """``max(0, 1 - d / separation)`` for the nearest other live agent at distance ``d``:
    0 at the separation and beyond, 1 when touching (formation)."""
    return ctx.extras["crowding"]


def in_formation(ctx: StepContext) -> bool:
    """Alive, and within the task's tolerance of both its moving slot and the shape (formation)."""
    return not ctx.crashed and ctx.extras["in_formation"] > 0.5


register_term("formation_error", RewardTerm(formation_error, "m", ("formation",)))
register_term("crowding", RewardTerm(crowding, "1", ("formation",)))
register_condition("in_formation", Condition(in_formation, ("formation",)))
