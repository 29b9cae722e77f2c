"""Domain randomisation in the batched multi-agent worlds (pyflyt_engine.batched.swarm) against
the PyBullet engine's multi-agent envs.

The PyBullet env draws every ``randomize`` entry once per reset from its generator, before
the spawns, and gives every vehicle of its world the same values
(:class:`pyflyt_engine.envs.randomization.Randomizer`); a batched world does the same from
its own generator (the one :meth:`BatchedSwarmEnv._seed_all` spawns for it from the seed).
The oracles: a PyBullet env drawing from a copy of world ``k``'s generator draws the same
values (equal as floats), gives each of its vehicles the same mass, inertia, motor rows and
drag factors (equal: the same engine functions of the same numbers) and spawns each agent at
the same pose (within 1e-12, PyBullet's own storage); flown with the same actions from
there (each backend's own spawn, nothing copied over), every live agent's position,
observation and reward agree within tests/batched/test_swarm.py's bound, 1e-6 (derived
there: the factors change the parameters' values, not the laws or their order of
operations, so the argument carries over).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import check_supported, resolve_backend, swarm
from pyflyt_engine.batched.model import UnsupportedByBatched
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.randomization import AIRFRAME
from tests.batched.test_randomization import DRAWS
from tests.batched.test_swarm import BOUND, STACKED, _fly, quiet_cf2x  # noqa: F401 - the fixture


def _generators(seed: int, worlds: int) -> list[np.random.Generator]:
    """Fresh copies of the worlds' generators for ``seed`` (BatchedSwarmEnv._seed_all)."""
    return [np.random.default_rng(c) for c in np.random.SeedSequence(seed).spawn(worlds + 1)[1:]]


def _pybullet(cfg, rng: np.random.Generator):
    """The PyBullet multi-agent env of ``cfg`` whose episodes draw from ``rng``, reset."""
    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    env = {"ma_hover": MAQuadXHoverEnv, "ma_formation": MAQuadXFormationEnv}[cfg.task.name](cfg)
    env.np_random = rng
    obs, info = env.reset()
    return env, obs, info


def _vehicle(v) -> dict[str, np.ndarray]:
    """What the randomiser set on a PyBullet vehicle, and where it spawned."""
    dynamics = p.getDynamicsInfo(v.body_id, -1, physicsClientId=v._client)
    pos, quat = p.getBasePositionAndOrientation(v.body_id, physicsClientId=v._client)
    motors, drag = v.actuators.motors, v.actuators.drag
    return {
        "mass": np.array(dynamics[0]),
        "inertia": np.array(dynamics[2]),
        "lag": np.array(motors.lag),
        "columns": np.array(motors.columns),
        "reaction": np.array(motors._reaction_per_thrust),
        "drag": np.array(drag._factors),
        "damping": np.array(drag._damping),
        "pos": np.array(pos),
        "quat": np.array(quat),
    }


@pytest.mark.parametrize("seed", [11, 12])
def test_each_world_draws_and_applies_what_the_pybullet_env_does(seed):
    """Two worlds of four agents, two episodes each: each world's draws, and each agent's
    mass, inertia, motor lag, wrench columns, reaction per thrust, wake strength (full thrusts),
    drag factors and spawn, are
    the PyBullet env's from the same generator; the agents of a world share its draws, the
    worlds draw apart; the flight controller keeps the nominal airframe."""
    worlds, agents = 2, 4
    cfg = load_env_config("ma_quadx_hover").with_overrides(randomize=DRAWS)
    be = swarm.BatchedSwarmEnv(cfg, worlds=worlds, motor_noise=False)
    _, info = be.reset(seed=seed)
    assert list(info["randomization"]) == list(DRAWS) and info["_randomization"].all()
    pybullet = []
    for k, rng in enumerate(_generators(seed, worlds)):
        pb, _, pb_info = _pybullet(cfg, rng)
        pybullet.append(pb)
        for a, name in enumerate(pb.possible_agents):
            slot = k * agents + a
            assert pb_info[name]["randomization"] == {e: float(info["randomization"][e][slot]) for e in DRAWS}
    for episode in range(2):
        if episode:  # a new episode in every world: each PyBullet env draws on from its stream
            for k, pb in enumerate(pybullet):
                be._reset_world(k)
                pb.reset()
        for k, pb in enumerate(pybullet):
            drawn = [pb.last_randomization[name] for name in DRAWS]
            for a, vehicle in enumerate(pb.vehicles):
                i = k * agents + a
                assert list(be.randomized_values[i]) == drawn, (episode, k, a)
                assert tuple(be.latency_steps[i]) == pb.latency_steps  # the drawn observation delay
                got = _vehicle(vehicle)
                assert be._mass[i] == got["mass"] and np.array_equal(be._inertia[i], got["inertia"])
                assert np.array_equal(be._lag[i], got["lag"]) and np.array_equal(be._columns[i], got["columns"])
                assert np.array_equal(be._rotors[i, :, 4], got["reaction"])
                # the strength of its wake: the drawn motor_kf's full thrusts, which the engine's rotors take
                # from the vehicle's motors at the reset (Atmosphere.refresh_rotors)
                assert be._wake_thrust[i].tolist() == vehicle.actuators.motors.params.max_thrust.tolist()
                assert np.array_equal(be._drag_factors[i], got["drag"]) and be._damping[i] == got["damping"]
                assert np.abs(be.pos[i] - got["pos"]).max() < 1e-12, (episode, k, a)
                assert np.abs(be.quat[i] - got["quat"]).max() < 1e-12, (episode, k, a)
    values = be.randomized_values.reshape(worlds, agents, -1)
    assert (values == values[:, :1]).all() and not np.array_equal(values[0, 0], values[1, 0])
    nominal = swarm.BatchedSwarmEnv(cfg.with_overrides(randomize={}), worlds=worlds)
    assert np.all(be._mass != nominal._mass) and np.all(be._columns[:, :, 2] != nominal._columns[:, :, 2])
    assert np.all(be._drag_factors != nominal._drag_factors)
    assert np.all(be._wake_thrust != nominal._wake_thrust)
    # the flight controller keeps the nominal airframe (one set for every vehicle, the model's,
    # which the draws leave alone)
    for name in ("control_inertia", "gyro", "mixer_rows", "max_collective", "rate_gains", "columns", "mass"):
        assert np.array_equal(getattr(be.model, name), getattr(nominal.model, name)), name
    for pb in pybullet:
        pb.close()


#: the randomised cross-checks: the stacks with downwash (and, near the ground, in ground
#: effect, which reads the drawn reaction per thrust), the formation on its grid in a constant wind
FLIGHTS = {
    "stacked_downwash": ("ma_quadx_hover", {"agents": STACKED, "downwash": True}),
    "formation": ("ma_quadx_formation", {"agents": 4, "downwash": True, "wind": "constant"}),
}


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_randomised_worlds_agree_with_the_pybullet_engine(quiet_cf2x, flight):  # noqa: F811
    """Every entry drawn, 2 s of random actions around hover from each backend's own drawn
    spawn: every live agent's position, observation and reward within 1e-6 (the measured
    differences printed), no agent lost, and the draws did change the flight."""
    env_name, overrides = FLIGHTS[flight]
    cfg = load_env_config(env_name).with_overrides(uav=quiet_cf2x, randomize=DRAWS, **overrides)
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    first, info = be.reset(seed=5)
    pb, start, pb_info = _pybullet(cfg, _generators(5, 1)[0])
    names = pb.possible_agents
    assert all(pb_info[n]["randomization"] == {e: float(v[0]) for e, v in info["randomization"].items()} for n in names)
    spawned = max(np.abs(start[n] - first[i]).max() for i, n in enumerate(names))
    hover = be.model.hover_thrust_fraction
    worst, ends, flown = _fly(pb, be, np.random.default_rng(7), 59, hover)
    worst["spawn"] = spawned
    print(f"{flight}: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends, ends
    # the same spawns and actions with every airframe factor drawn as exactly 1 (the same calls
    # of the generator): the factors moved the agents by centimetres
    unit = {
        name: ({"distribution": "uniform", "low": 1.0, "high": 1.0} if name in AIRFRAME else e)
        for name, e in DRAWS.items()
    }
    drawn, nominal = _batched_flight(cfg, 59), _batched_flight(cfg.with_overrides(randomize=unit), 59)
    assert np.array_equal(drawn[0], nominal[0])  # the same spawns
    print(f"{flight}: the factors moved the agents by up to {np.abs(drawn[1] - nominal[1]).max():.3f} m")
    assert np.abs(drawn[1] - nominal[1]).max() > 0.01


def _batched_flight(cfg, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """A batched world of ``cfg`` from seed 5 flown by ``_fly``'s actions (every agent alive): its spawn and end positions."""
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    be.reset(seed=5)
    spawn = be.pos.copy()
    rng = np.random.default_rng(7)
    hover = be.model.hover_thrust_fraction
    for _ in range(steps):
        actions = np.array(
            [np.r_[rng.uniform(-0.5, 0.5, 3), hover * rng.uniform(0.95, 1.1)] for _ in range(be.num_envs)]
        )
        be.step(actions)
    assert be.alive.all()
    return spawn, be.pos.copy()


def _run(seed: int, steps: int = 40) -> list[np.ndarray]:
    """Three worlds of the hover with every entry drawn, motor noise on, 0.5 s episodes (every
    world restarts and draws anew twice): the arrays after each step."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(randomize=DRAWS, max_duration_seconds=0.5)
    env = swarm.BatchedSwarmEnv(cfg, worlds=3)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    out = [obs, env.randomized_values.copy()]
    hover = env.model.hover_thrust_fraction
    for _ in range(steps):
        a = np.c_[rng.uniform(-0.3, 0.3, (env.num_envs, 3)), hover * rng.uniform(0.95, 1.1, (env.num_envs, 1))]
        obs, reward, _, _, info = env.step(a)
        out += [obs, reward, env.randomized_values.copy(), env._mass.copy(), env._columns.copy()]
        if "randomization" in info:  # the restarted worlds' draws, masked to their slots
            restarted = info["_randomization"]
            assert restarted.any() and np.array_equal(restarted, env.world_over)
            assert np.array_equal(info["randomization"]["mass"], env.randomized_values[:, 0])
    return out


def test_the_same_seed_draws_and_flies_the_same_numbers():
    """The same seed draws and flies the same numbers bit for bit; the worlds' restarts draw
    new values; another seed draws others."""
    first, again = _run(3), _run(3)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(first, again))
    assert not np.array_equal(first[1], first[-3])  # every world restarted and drew anew
    assert not np.array_equal(_run(4, steps=1)[1], first[1])


def test_a_checkpoint_carries_the_draws_and_the_parameters_they_set():
    """``episode_state`` then ``restore_episode`` of every slot puts each world's draws and the
    mass, inertia, motor, wake and drag rows they set back (and its generator): the steps after it,
    worlds restarting and drawing among them, repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("ma_quadx_hover").with_overrides(
        backend="batched", randomize=DRAWS, max_duration_seconds=0.5, agents=STACKED, downwash=True
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
    rows = ("_mass", "_inertia", "_lag", "_columns", "_rotors", "_wake_thrust", "_drag_factors", "_damping")
    for name in ("randomized_values", *rows):
        assert name in saved[0]["batched"], name
    actions = rng.uniform(-0.3, 0.3, (20, n, 4)).astype(np.float32)
    first = [vec.step(a)[0] for a in actions]
    assert not np.array_equal(env.randomized_values, np.asarray([s["batched"]["randomized_values"] for s in saved]))
    for name in (*rows, "randomized_values"):
        getattr(env, name)[:] = 1.0  # state the restore must put back
    for i in range(n):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_the_shipped_preset_is_simulated_and_auto_picks_the_batched_backend():
    cfg = load_env_config("ma_quadx_hover").with_overrides(randomize="moderate")
    check_supported(cfg)
    assert resolve_backend(cfg.with_overrides(backend="auto")) == "batched"


@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        (  # a drawn W20 where the config has no turbulence: no filter rows to hold it (as single-agent)
            {
                "randomize": {"mass": DRAWS["mass"], "wind.turbulence.wind_speed_20ft": DRAWS["spawn_z"]},
                "wind": {"preset": "dryden_light", "turbulence": {"wind_speed_20ft": 0.0}},
            },
            "env.randomize.wind.turbulence.wind_speed_20ft (domain randomisation: the config's turbulence is off",
        ),
    ],
)
def test_what_it_does_not_simulate_stays_refused_by_name(overrides, named):
    """What the worlds do not draw is refused, naming the entry, and auto flies such a config on PyBullet."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(**overrides)
    with pytest.raises(UnsupportedByBatched) as refused:
        check_supported(cfg)
    assert named in str(refused.value), str(refused.value)
    assert resolve_backend(cfg.with_overrides(backend="auto")) == "pybullet"
