"""Latency in the batched multi-agent worlds (pyflyt_engine.batched.swarm with
pyflyt_engine.batched.latency) against the PyBullet engine's multi-agent envs.

The worlds take the single-agent backend's ``BatchedLatency``: per slot the action's ring
(each control tick flies the latest action released by then) and the snapshot of the state
an observation shows, the agent step run in pieces where a tick's setpoint changes or a
snapshot is due.  Two things make a piece exact in a world: each vehicle's latest read
position (the others' downwash is taken from it) is the env's, carried from one piece to the
next, and a piece ending inside a control period takes no contact sample (the engine takes
none there).  The PyBullet multi-agent env delays every vehicle by the same steps (one draw
of a randomised delay per reset for the world) and builds each agent's observation from
every vehicle's delayed state (``delayed_state``: the formation's neighbours too); rewards
and episode ends read the true states.

Oracles: from the same generator, the same delays and spawns; flown with the same actions,
every live agent's position, observation and reward within tests/batched/test_swarm.py's
bound, 1e-6 (the pieces change no law and no order of operations: the argument there
carries over); a delay changes the flight (against no delay, by more than the bound).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import check_supported, resolve_backend, swarm
from pyflyt_engine.envs.config import load_env_config
from tests.batched.test_swarm import BOUND, STACKED, _fly, quiet_cf2x  # noqa: F401 - the fixture
from tests.batched.test_swarm_air import SHEAR_GUST_TURBULENCE, _inject_the_engines_turbulence

#: 3 physics steps of action delay (ticks every 2: the released action changes between them) and
#: 5 of observation delay (the snapshot 3 steps into the agent step's 8: inside a control period)
FIXED = {"action_delay": 0.0125, "observation_delay": 0.0208}
#: the delays drawn per world and reset, between other entries (the section's order is the draws')
DRAWN = {
    "mass": {"distribution": "uniform", "low": 0.97, "high": 1.03},
    "action_delay": {"distribution": "uniform", "low": 0.0, "high": 0.03},
    "spawn_z": {"distribution": "uniform", "low": 0.0, "high": 0.2},
    "observation_delay": {"distribution": "uniform", "low": 0.0, "high": 0.03},
}

FLIGHTS = {
    "stacked_fixed": ("ma_quadx_hover", {"agents": STACKED, "downwash": True, "latency": FIXED}),
    # a sheared mean wind, a gust and moderate turbulence (its white noise the engine's): the
    # pieces read the wind at their own physics steps and the filter's noise from their offset
    "stacked_fixed_wind": (
        "ma_quadx_hover",
        {"agents": STACKED, "downwash": True, "latency": FIXED, "wind": SHEAR_GUST_TURBULENCE},
    ),
    "stacked_drawn": ("ma_quadx_hover", {"agents": STACKED, "downwash": True, "randomize": DRAWN}),
    "formation_fixed": ("ma_quadx_formation", {"agents": 4, "downwash": True, "latency": FIXED}),
    "formation_drawn": ("ma_quadx_formation", {"agents": 4, "downwash": True, "latency": FIXED, "randomize": DRAWN}),
}


def _paired(cfg, seed: int):
    """The PyBullet env of ``cfg`` reset with ``seed`` (its world's streams seeded: the
    turbulence's) and a batched world drawing from a copy of the PyBullet env's generator
    (``seeding.np_random(seed)``), the engine's turbulence noise injected; their first observations."""
    from gymnasium.utils import seeding

    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    pb = {"ma_hover": MAQuadXHoverEnv, "ma_formation": MAQuadXFormationEnv}[cfg.task.name](cfg)
    start, _ = pb.reset(seed=seed)
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    be.world_rngs[0] = seeding.np_random(seed)[0]
    be.env_rngs = [be.world_rngs[0]] * be.num_envs
    first, _ = be.reset()
    if be.dryden is not None:
        _inject_the_engines_turbulence(pb, be)
    return pb, be, start, first


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_delayed_worlds_agree_with_the_pybullet_engine(quiet_cf2x, flight):  # noqa: F811
    """2 s of random actions around hover from each backend's own spawn, the delays fixed or
    drawn: the same delays, and every live agent's position, observation and reward within
    1e-6 (the measured differences printed), no agent lost."""
    env_name, overrides = FLIGHTS[flight]
    cfg = load_env_config(env_name).with_overrides(uav=quiet_cf2x, **overrides)
    pb, be, start, first = _paired(cfg, 6)
    assert all(tuple(row) == pb.latency_steps for row in be.latency_steps), (be.latency_steps, pb.latency_steps)
    names = pb.possible_agents
    spawned = max(np.abs(start[n] - first[i]).max() for i, n in enumerate(names))
    worst, ends, flown = _fly(pb, be, np.random.default_rng(8), 59, be.model.hover_thrust_fraction)
    worst["spawn"] = spawned
    print(f"{flight}, delays {pb.latency_steps}: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends, ends


def _flight(cfg, steps: int = 30) -> np.ndarray:
    be = swarm.BatchedSwarmEnv(cfg, worlds=2, motor_noise=False)
    obs, _ = be.reset(seed=2)
    rng = np.random.default_rng(1)
    out = [obs]
    hover = be.model.hover_thrust_fraction
    for _ in range(steps):
        a = np.c_[rng.uniform(-0.5, 0.5, (be.num_envs, 3)), hover * rng.uniform(0.95, 1.1, (be.num_envs, 1))]
        out.append(be.step(a)[0])
    return np.array(out)


def test_a_delay_changes_what_is_flown_and_seen():
    """The same actions with and without each delay: the action delay changes the flight, the
    observation delay alone only what the agents see (the true flight bit for bit the same)."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(downwash=True)
    none = _flight(cfg)
    acted = _flight(cfg.with_overrides(latency={"action_delay": FIXED["action_delay"]}))
    seen = _flight(cfg.with_overrides(latency={"observation_delay": FIXED["observation_delay"]}))
    assert np.abs(acted - none).max() > 1e-3
    assert np.abs(seen - none).max() > 1e-4
    # the true positions are the same bit for bit: the observation delay splits the agent step
    # into pieces, which changes no number of the flight
    ends = [
        swarm.BatchedSwarmEnv(c, worlds=2, motor_noise=False)
        for c in (cfg, cfg.with_overrides(latency={"observation_delay": FIXED["observation_delay"]}))
    ]
    for env in ends:
        env.reset(seed=2)
        rng = np.random.default_rng(1)
        hover = env.model.hover_thrust_fraction
        for _ in range(30):
            env.step(np.c_[rng.uniform(-0.5, 0.5, (8, 3)), hover * rng.uniform(0.95, 1.1, (8, 1))])
    assert np.array_equal(ends[0].pos, ends[1].pos) and np.array_equal(ends[0].quat, ends[1].quat)


def test_a_checkpoint_carries_the_delays_and_what_is_in_flight():
    """``episode_state`` / ``restore_episode`` of every slot with drawn delays: the delays, the
    actions in flight and the states to be shown come back, and the steps after it (worlds
    restarting and drawing new delays among them) repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("ma_quadx_hover").with_overrides(backend="batched", randomize=DRAWN, max_duration_seconds=0.5)
    vec = make_vec_env(cfg, 2)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    n = vec.num_envs
    for _ in range(5):
        vec.step(rng.uniform(-0.3, 0.3, (n, 4)).astype(np.float32))
    saved = vec.env_method("episode_state")
    env = vec.env
    for name in ("latency_steps", "action_history", "observed_history"):
        assert name in saved[0]["batched"], name
    actions = rng.uniform(-0.3, 0.3, (20, n, 4)).astype(np.float32)
    first = [vec.step(a)[0] for a in actions]
    for name in ("latency_steps", "action_history", "observed_history", "_mass", "randomized_values"):
        getattr(env, name)[:] = 1  # state the restore must put back
    for i in range(n):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_latency_and_the_shipped_presets_are_simulated():
    for overrides in ({"latency": FIXED}, {"randomize": "sim2real"}, {"randomize": "moderate", "latency": FIXED}):
        cfg = load_env_config("ma_quadx_hover").with_overrides(**overrides)
        check_supported(cfg)
        assert resolve_backend(cfg.with_overrides(backend="auto")) == "batched"
