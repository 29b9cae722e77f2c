"""The air of the batched multi-agent worlds (pyflyt_engine.batched.swarm) against the PyBullet engine's.

Wind (a constant, a sheared and a gusting mean wind, Dryden turbulence) and ground effect in
MAQuadX-Hover worlds with downwash, flown beside the PyBullet env from the same start states
with the same actions, motor noise off.  The wind and ground-effect laws are the single-agent
backend's (``tests/batched/test_air.py`` holds them bit for bit to the engine's), read at each
vehicle as the engine's world reads it (its height, its world's physics step, the downwash
added to the field's vertical wind); the turbulence is one field per world, as the engine's
``WindField`` gives every vehicle of a world the same linear gusts, its white noise injected
from the engine's stream.  So the bound is ``tests/batched/test_swarm.py``'s: 1e-6 on every live
agent's position, observation and reward, the measured differences printed.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import air, swarm
from tests.batched.test_swarm import BOUND, STACKED, _fly, _pair, quiet_cf2x  # noqa: F401 - the fixture

#: a gust that starts inside the 2 s flights (the preset's starts later)
GUST = {"preset": "calm", "gust": {"amplitude": [1.0, 0.5, -0.5], "length": 2.0, "speed": 4.0, "start": 0.1}}
#: a sheared mean wind with a gust and turbulence of its own direction
SHEAR_GUST_TURBULENCE = {
    "preset": "dryden_moderate",
    "mean": {"speed": 4.0, "direction": 70.0, "profile": "log"},
    "gust": {"amplitude": [1.0, 0.5, -0.5], "length": 2.0, "speed": 4.0, "start": 0.1},
    "turbulence": {"direction": -40.0, "airspeed": 12.0},
}
#: the two stacks of tests/batched/test_swarm.py brought down to the ground: the lower agents' rotors
#: 8-9 cm above it (deep in ground effect), the upper ones above them in their wakes' reach
LOW = [
    {"spawn": {**a["spawn"], "position": [*a["spawn"]["position"][:2], a["spawn"]["position"][2] - 0.92]}}
    for a in STACKED
]


def _inject_the_engines_turbulence(pb, be) -> None:
    """World 0 of ``be`` gets the white noise the PyBullet engine's field draws this episode:
    the engine's world reseeded its wind stream at the reset (``World._wind_rng``) and drew from
    it one filter state for the world, then blocks of standard normals per state (2,048 physics
    steps each); the same draws, from a repeat of that stream, go to the batched world's filter."""
    world = pb.world
    field = world.wind
    stream = np.random.default_rng(np.random.SeedSequence(world._seed_sequence.entropy, spawn_key=(2,)))
    n = be.dryden.states
    state = np.zeros(n)
    air.dryden_initial(be._dryden_arrays, stream.standard_normal((n, 1))[:, 0].copy(), state)
    be.turbulence[:] = state
    blocks = np.concatenate([stream.standard_normal((n, field.block)) for _ in range(2)], axis=1)
    per = be.per_agent
    steps = iter(range(10**6))
    be.turbulence_normals = lambda: np.ascontiguousarray(blocks[:, (k := next(steps)) * per : (k + 1) * per].T[None])
    gusts = air.dryden_output(be._dryden_arrays, be.turbulence[0], be._wind[18], be._wind[19])
    for i in range(be.agents):
        here = be.pos[i].tolist()
        spins = air.dryden_rotary(be._dryden_arrays, be.turbulence[0], be._wind[18], be._wind[19], i)
        sample = air.wind_sample(be._wind, 0, here[2], be.physics_dt, (*gusts[:3], *spins))
        engine = tuple(world.atmosphere.wind_at(i, here))
        assert sample[:2] == engine[:2] and sample[3:] == engine[3:]  # z: the engine's adds the downwash


def _fly_pair(uav: str, seed: int, wind, agents=STACKED, ground_effect: bool = False, steps: int = 59):
    pb, be = _pair(uav, seed, agents=agents, downwash=True, wind=wind, ground_effect=ground_effect)
    if be.dryden is not None:
        _inject_the_engines_turbulence(pb, be)
    hover = be.model.hover_thrust_fraction
    worst, ends, flown = _fly(pb, be, np.random.default_rng(20 + seed), steps, hover)
    pb.close()
    return worst, ends, flown, be


def _calm_positions(uav: str, seed: int, agents, steps: int) -> np.ndarray:
    _, be = _pair(uav, seed, agents=agents, downwash=True)
    hover = be.model.hover_thrust_fraction
    rng = np.random.default_rng(20 + seed)
    for _ in range(steps):
        actions = np.zeros((be.num_envs, 4))
        for i in range(be.num_envs):
            actions[i] = np.r_[rng.uniform(-0.5, 0.5, 3), hover * rng.uniform(0.95, 1.1)]
        be.step(actions)
    return be.pos.copy()


@pytest.mark.parametrize("wind", ["constant", "shear", "gust", "dryden_light", "shear_gust_turbulence"])
def test_stacked_agents_in_the_wind_agree_with_the_pybullet_engine(quiet_cf2x, wind):  # noqa: F811
    """2 s of random actions around hover, the upper agents' wakes on the lower ones, in the
    wind: every live agent within 1e-6 of the PyBullet engine's (turbulence injected), and the
    wind was felt (the positions move by more than 1 cm against the same flight in calm air)."""
    config = {"gust": GUST, "shear_gust_turbulence": SHEAR_GUST_TURBULENCE}.get(wind, wind)
    worst, ends, flown, be = _fly_pair(quiet_cf2x, 0, config)
    print(f"{wind}: {worst}")
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends, ends
    calm = _calm_positions(quiet_cf2x, 0, STACKED, 59)
    assert np.abs(be.pos - calm).max() > 0.01, "the wind was not felt"


def test_agents_in_ground_effect_agree_with_the_pybullet_engine(quiet_cf2x):  # noqa: F811
    """The stacks 8-9 cm above the ground (rotors in ground effect, the upper agents' wakes on
    the lower ones), 1 s around hover: within 1e-6 of the PyBullet engine, and the ground
    effect was felt (the lower agents rise more than without it)."""
    worst, ends, flown, be = _fly_pair(quiet_cf2x, 1, "calm", agents=LOW, ground_effect=True, steps=29)
    print(f"ground effect: {worst}")
    assert max(worst.values()) < BOUND, worst
    assert flown == 29 and not ends, ends
    without = _calm_positions(quiet_cf2x, 1, LOW, 29)
    assert (be.pos[[0, 2], 2] - without[[0, 2], 2]).min() > 0.005, (be.pos[:, 2], without[:, 2])


def test_a_worlds_turbulence_is_one_field_and_each_world_its_own():
    """Every agent of a world flies through the same turbulence (the engine's field), each world
    draws its own from its seed, and the same seed gives the same numbers."""

    def flown(seed: int) -> tuple[np.ndarray, np.ndarray]:
        env = swarm.make_batched_swarm("ma_quadx_hover", worlds=3, seed=seed, wind="dryden_severe")
        env.reset(seed=seed)
        hover = env.model.hover_thrust_fraction
        for _ in range(20):
            env.step(np.tile([0.0, 0.0, 0.0, hover], (env.num_envs, 1)))
        return env.turbulence.copy(), env.pos.copy()

    turbulence, pos = flown(3)
    agents = 4
    for k in range(3):
        rows = turbulence[k * agents : (k + 1) * agents]
        assert (rows == rows[0]).all()
    assert not np.array_equal(turbulence[0], turbulence[agents])
    again, pos_again = flown(3)
    assert np.array_equal(turbulence, again) and np.array_equal(pos, pos_again)
    other, _ = flown(4)
    assert not np.array_equal(turbulence, other)


#: Dryden turbulence whose rotary gusts reach the Crazyflie (the presets' 1 m minimum span does
#: not): every vehicle has its own p, q, r, its rows of the world's filter
ROTARY = {"preset": "dryden_moderate", "turbulence": {"rotary_min_span": 0.0}}


def test_each_agent_has_its_own_rotary_gusts_as_in_the_pybullet_engine(quiet_cf2x):  # noqa: F811
    """The stacks with downwash in turbulence with rotary gusts: the world's filter is the
    engine field's for the world's four vehicles (its matrices equal, 5 + 3 x 4 states), each
    agent's first wind sample the engine's bit for bit (its own p, q, r), and 2 s of random
    actions around hover within 1e-6 of the PyBullet engine; at the end the agents' rotary gusts
    are all different and not negligible."""
    worst, ends, flown, be = _fly_pair(quiet_cf2x, 2, ROTARY)
    print(f"rotary gusts: {worst}")
    agents = be.agents
    assert be.dryden is not None and be.dryden.rotary and be.dryden.states == 5 + 3 * agents
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends, ends
    pb, fresh = _pair(quiet_cf2x, 2, agents=STACKED, downwash=True, wind=ROTARY)
    process = pb.world.wind._process  # the engine field's own filter for the world's vehicles
    assert np.array_equal(fresh._dryden_phi[0], process.Phi) and np.array_equal(fresh._dryden_c[0], process.C)
    assert np.array_equal(fresh._dryden_noise[-1], process._noise_root)
    assert np.array_equal(fresh._dryden_root[-1], process._state_root)
    pb.close()
    row = be._wind_rows[0]
    spins = np.array([air.dryden_rotary(be.dryden_of(0), be.turbulence[0], row[18], row[19], a) for a in range(agents)])
    assert np.abs(spins).max() > 1e-3, spins  # gusts of a few mrad/s and more
    assert len({tuple(v) for v in spins.tolist()}) == agents, spins  # each agent its own


# ---------------------------------------------------------------------------- the formation


@pytest.mark.parametrize("wind", ["calm", "gust"])
def test_the_formation_agrees_with_the_pybullet_engine(quiet_cf2x, wind):  # noqa: F811
    """MAQuadX-Formation, 9 agents on the 3 x 3 grid with downwash, 2 s of random actions around
    hover (the formation moving at 0.2 m/s): every live agent's position, observation (its slot,
    the formation's velocity, its neighbours), reward and task info within 1e-6 of the PyBullet
    engine's, the task being the engine's own object per world."""
    pb, be = _pair(quiet_cf2x, 3, agents=9, env="ma_quadx_formation", wind={"gust": GUST}.get(wind, wind))
    hover = be.model.hover_thrust_fraction
    rng = np.random.default_rng(7)
    names = pb.possible_agents
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0, "info": 0.0}
    for step in range(60):
        live = list(pb.agents)
        actions = np.zeros((len(names), 4))
        for name in live:
            actions[pb.agent_index[name]] = np.r_[rng.uniform(-0.5, 0.5, 3), hover * rng.uniform(0.95, 1.1)]
        o1, r1, t1, tr1, i1 = pb.step({name: actions[pb.agent_index[name]] for name in live})
        o2, r2, t2, tr2, i2 = be.step(actions)
        for name in live:
            i = pb.agent_index[name]
            assert (t1[name], tr1[name]) == (bool(t2[i]), bool(tr2[i])), (step, name)
            worst["position"] = max(worst["position"], np.abs(o1[name][10:13] - o2[i][10:13]).max())
            worst["observation"] = max(worst["observation"], np.abs(o1[name] - o2[i]).max())
            worst["reward"] = max(worst["reward"], abs(r1[name] - r2[i]))
            for key in ("target_distance", "formation_error", "nearest_neighbour"):
                worst["info"] = max(worst["info"], abs(i1[name][key] - i2[key][i]))
    print(f"formation, {wind}: {worst}")
    assert max(worst.values()) < BOUND, worst
    assert len(pb.agents) == 9, "an agent crashed: the flight compares less than it should"
    pb.close()
