"""Randomised winds in the batched multi-agent worlds (``randomize`` entries ``wind.<path>``):
one wind per world and episode, the PyBullet engine's.

The PyBullet multi-agent env's randomiser draws every entry once per reset and gives its one
world the sampled wind config (``World.set_wind``); a batched world draws the same values from
its own generator (tests/batched/test_swarm_randomization.py) and writes the sampled wind's
parameters and Dryden filter into every slot of the world, the worlds' kernel reading its first
slot's.  The oracles: the drawn values and the PyBullet world's sampled config are equal as
floats, the rows are that config's parameters and its field's own filter matrices (equal: the
same functions of the same numbers); flown with the same actions, the engine's turbulence white
noise injected (the backends draw it from different streams), every live agent's position,
observation and reward agree within tests/batched/test_swarm.py's bound, 1e-6: the drawn wind
changes the laws' parameters, not the laws or their order of operations, so
tests/batched/test_swarm_air.py's argument carries over.  The same flight in the config's own
mean wind and gust (no turbulence) differs by far more than the bound (the drawn wind is felt).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import air, check_supported, resolve_backend, swarm
from pyflyt_engine.envs.config import load_env_config
from tests.batched.test_randomization_wind import DRAWS, WIND, _Recorder
from tests.batched.test_swarm import BOUND, STACKED, _fly, quiet_cf2x  # noqa: F401 - the fixture
from tests.batched.test_swarm_randomization import _generators


def _pybullet(cfg, rng: np.random.Generator):
    """The PyBullet multi-agent env of ``cfg`` whose episodes draw from ``rng``, reset, its wind
    stream recorded; the env, its first observations, its info and the recorder."""
    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    env = {"ma_hover": MAQuadXHoverEnv, "ma_formation": MAQuadXFormationEnv}[cfg.task.name](cfg)
    recorder = _Recorder(env.world._wind_generator)
    env.world._wind_generator = recorder
    env.np_random = rng
    obs, info = env.reset()
    return env, obs, info, recorder


def _inject(pb, be: swarm.BatchedSwarmEnv, recorder: _Recorder) -> None:
    """Give world 0 of ``be`` the turbulence the PyBullet engine's field flies this episode.

    At the reset the randomiser gave the engine's world a new field (``World.set_wind``), which
    drew its filter's stationary state and then blocks of samples (again as each vehicle
    registers); from the last stationary draw on, the same draws go through world 0's filter
    (its drawn rows): the state, the steps of every block but the last, and the last block's
    normals as the flight's (:meth:`BatchedSwarmEnv.turbulence_normals`).  Every agent's first
    wind sample must be the engine's, bit for bit (z: the engine's adds the downwash)."""
    dryden = be.dryden_of(0)
    n = dryden[0].shape[0]
    start = max(k for k, d in enumerate(recorder.draws) if d.shape == (n, 1))
    draws = recorder.draws[start:]
    x = np.zeros(n)
    air.dryden_initial(dryden, np.ascontiguousarray(draws[0][:, 0]), x)
    scratch = np.empty(n)
    for block in draws[1:-1]:
        for s in range(block.shape[1]):
            air.dryden_step(dryden, x, np.ascontiguousarray(block[:, s]), scratch)
    be.turbulence[:] = x
    flight = draws[-1]
    assert flight.shape == (n, pb.world.wind.block)
    per = be.per_agent
    steps = iter(range(10**6))
    be.turbulence_normals = lambda: np.ascontiguousarray(flight[:, (k := next(steps)) * per : (k + 1) * per].T[None])
    row = be._wind_rows[0]
    gusts = air.dryden_output(dryden, x, row[18], row[19])
    for i in range(be.agents):
        here = be.pos[i].tolist()
        spins = air.dryden_rotary(dryden, x, row[18], row[19], i)  # agent i's own (0 without rotary rows)
        sample = air.wind_sample(row, 0, here[2], be.physics_dt, (*gusts[:3], *spins))
        engine = tuple(pb.world.atmosphere.wind_at(i, here))
        assert sample[:2] == engine[:2] and sample[3:] == engine[3:], (i, sample, engine)


def _rows(be: swarm.BatchedSwarmEnv, i: int) -> list[np.ndarray]:
    return [a.copy() for a in (be._wind_rows[i], *be.dryden_of(i))]


def test_each_world_draws_and_flies_the_wind_the_pybullet_env_does():
    """Two worlds of four agents, two episodes each: each world's draws are the PyBullet env's
    from the same generator, and every slot of world k holds that episode's wind: the parameters
    of the PyBullet world's sampled wind config, the filter its field's own matrices; the two
    worlds' winds differ, and a world's restart leaves the other world's rows alone."""
    worlds, agents, seed = 2, 4, 11
    cfg = load_env_config("ma_quadx_hover").with_overrides(wind=WIND, randomize=DRAWS)
    be = swarm.BatchedSwarmEnv(cfg, worlds=worlds, motor_noise=False)
    _, info = be.reset(seed=seed)
    assert list(info["randomization"]) == list(DRAWS)
    pybullet = [_pybullet(cfg, rng)[0] for rng in _generators(seed, worlds)]
    for episode in range(2):
        if episode:  # world 1 restarts alone (world 0's rows stay), then world 0
            before = [_rows(be, i) for i in range(agents)]
            be._reset_world(1)
            assert all(np.array_equal(a, b) for i in range(agents) for a, b in zip(before[i], _rows(be, i)))
            be._reset_world(0)
            for pb in pybullet:
                pb.reset()
        for k, pb in enumerate(pybullet):
            drawn = pb.last_randomization
            config = pb.world.wind_config  # the sampled wind the randomiser gave the world
            assert config.mean.speed == drawn["wind.mean.speed"] and config.gust.start == drawn["wind.gust.start"]
            assert config.turbulence.wind_speed_20ft == drawn["wind.turbulence.wind_speed_20ft"]
            process = pb.world.wind._process  # the engine field's own filter (the Crazyflie: no rotary states)
            for a in range(agents):
                i = k * agents + a
                assert list(be.randomized_values[i]) == [drawn[name] for name in DRAWS], (episode, k, a)
                assert be._wind_rows[i].tolist() == air.wind_params(config, rotary=False).tolist(), (episode, k, a)
                assert np.array_equal(be._dryden_phi[i], process.Phi) and np.array_equal(be._dryden_c[i], process.C)
                assert np.array_equal(be._dryden_noise[i], process._noise_root)
                assert np.array_equal(be._dryden_root[i], process._state_root)
    assert not np.array_equal(be._wind_rows[0], be._wind_rows[agents])  # two worlds, two winds
    assert not np.array_equal(be._dryden_c[0], be._dryden_c[agents])
    for pb in pybullet:
        pb.close()


#: the stacks with downwash (the upper agents' wakes on the lower ones), the same in turbulence
#: whose rotary gusts reach the Crazyflie (each agent its own p, q, r: a 17-state world filter
#: drawn per episode), and the formation's grid
FLIGHTS = {
    "stacked_downwash": ("ma_quadx_hover", {"agents": STACKED, "downwash": True}),
    "stacked_rotary": (
        "ma_quadx_hover",
        {"agents": STACKED, "downwash": True, "wind": {**WIND, "turbulence": {"rotary_min_span": 0.0}}},
    ),
    "formation": ("ma_quadx_formation", {"agents": 4, "downwash": True}),
}


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_worlds_in_drawn_winds_agree_with_the_pybullet_engine(quiet_cf2x, flight):  # noqa: F811
    """The wind drawn (and the mass), 2 s of random actions around hover from each backend's
    own drawn spawn, the engine's turbulence noise injected: every live agent's position,
    observation and reward within 1e-6, no agent lost; the same spawns and actions in the
    config's own mean wind and gust (no turbulence, the same drawn mass) end centimetres away."""
    env_name, overrides = FLIGHTS[flight]
    cfg = load_env_config(env_name).with_overrides(uav=quiet_cf2x, randomize=DRAWS, **{"wind": WIND, **overrides})
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    assert be.dryden is not None and be.dryden.rotary == (flight == "stacked_rotary")
    first, info = be.reset(seed=5)
    pb, start, pb_info, recorder = _pybullet(cfg, _generators(5, 1)[0])
    names = pb.possible_agents
    assert all(pb_info[n]["randomization"] == {e: float(v[0]) for e, v in info["randomization"].items()} for n in names)
    spawned = max(np.abs(start[n] - first[i]).max() for i, n in enumerate(names))
    _inject(pb, be, recorder)
    hover = be.model.hover_thrust_fraction
    worst, ends, flown = _fly(pb, be, np.random.default_rng(7), 59, hover)
    worst["spawn"] = spawned
    print(f"{flight}: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends, ends
    # the config's own mean wind and gust, no turbulence: every wind entry drawn as exactly that
    # (the same calls of the generator), so the same spawns and the same drawn mass
    own = {"wind.mean.speed": 4.0, "wind.mean.direction": 70.0, "wind.turbulence.wind_speed_20ft": 0.0}
    own["wind.gust.start"] = 0.3
    fixed = {
        name: ({"distribution": "uniform", "low": own[name], "high": own[name]} if name in own else e)
        for name, e in DRAWS.items()
    }
    nominal = swarm.BatchedSwarmEnv(cfg.with_overrides(randomize=fixed), worlds=1, motor_noise=False)
    nominal.reset(seed=5)
    spawn = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    spawn.reset(seed=5)
    assert np.array_equal(nominal.pos, spawn.pos) and np.array_equal(nominal._mass, spawn._mass)
    assert nominal._wind_rows[0, 17] == 0.0  # no turbulence
    rng = np.random.default_rng(7)
    for _ in range(59):
        actions = np.array(
            [np.r_[rng.uniform(-0.5, 0.5, 3), hover * rng.uniform(0.95, 1.1)] for _ in range(nominal.num_envs)]
        )
        nominal.step(actions)
    felt = np.abs(nominal.pos - be.pos).max()  # be: flown from its own spawn, the same as spawn's
    print(f"{flight}: the drawn wind moved the agents by up to {felt:.3f} m")
    assert felt > 0.01


def test_a_checkpoint_carries_each_world_s_wind():
    """``episode_state`` then ``restore_episode`` of every slot puts each world's draws, wind
    parameters and turbulence filter back (with its turbulence state and stream): the steps
    after it, worlds restarting and drawing new winds among them, repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("ma_quadx_hover").with_overrides(
        backend="batched", wind=WIND, randomize=DRAWS, max_duration_seconds=0.5, agents=STACKED, downwash=True
    )
    vec = make_vec_env(cfg, 2)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    n = vec.num_envs
    for _ in range(5):
        vec.step(rng.uniform(-0.3, 0.3, (n, 4)).astype(np.float32))
    saved = vec.env_method("episode_state")
    env = vec.env
    names = ("randomized_values", "_wind_rows", "_dryden_phi", "_dryden_c", "_dryden_noise", "_dryden_root")
    for name in (*names, "_dryden_flags", "turbulence"):
        assert name in saved[0]["batched"], name
    actions = rng.uniform(-0.3, 0.3, (20, n, 4)).astype(np.float32)
    first, drawn = [], []
    for a in actions:
        first.append(vec.step(a)[0])
        drawn.append(env._wind_rows.copy())
    assert not np.array_equal(drawn[0], drawn[-1])  # the worlds restarted and drew new winds
    for name in names:
        getattr(env, name)[:] = 1.0  # state the restore must put back
    for i in range(n):
        vec.env_method("restore_episode", saved[i], indices=i)
    again, redrawn = [], []
    for a in actions:
        again.append(vec.step(a)[0])
        redrawn.append(env._wind_rows.copy())
    assert all(np.array_equal(a, b) for a, b in zip(first, again))
    assert all(np.array_equal(a, b) for a, b in zip(drawn, redrawn))


def test_wind_draws_in_worlds_are_batched_and_what_would_resize_the_filter_is_refused_by_name():
    """A multi-agent config drawing wind.<path> entries flies on the batched backend under
    auto; the rotary span stays refused by name (it decides the filter's size), and auto flies
    that config on PyBullet."""
    from pyflyt_engine.batched.model import UnsupportedByBatched

    cfg = load_env_config("ma_quadx_hover").with_overrides(wind=WIND, randomize=DRAWS)
    check_supported(cfg)
    assert resolve_backend(cfg.with_overrides(backend="auto")) == "batched"
    refused = cfg.with_overrides(
        randomize={"wind.turbulence.rotary_min_span": {"distribution": "uniform", "low": 0.5, "high": 2.0}}
    )
    with pytest.raises(UnsupportedByBatched) as info:
        check_supported(refused)
    assert "env.randomize.wind.turbulence.rotary_min_span (domain randomisation" in str(info.value)
    assert resolve_backend(refused.with_overrides(backend="auto")) == "pybullet"
