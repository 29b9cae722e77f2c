"""Domain randomisation on the batched backend (pyflyt_engine.batched.randomization): per env
and per episode, the PyBullet engine's draws, applied as the PyBullet engine applies them.

The oracles: a PyBullet env drawing from the same generator as batched env ``i`` (the
generator the batched env spawns for it from the seed) draws the same values (equal as
floats: one ``Distribution.sample`` call each, in the section's order, then the spawn and
the targets), gives its vehicle the same mass, inertia, motor rows and drag factors (equal:
the same engine functions of the same numbers) and spawns it at the same pose; flown with
the same actions from there, the two trajectories, observations and rewards agree within
test_crosscheck.py's bound, 1e-6 (derived there: the factors change the parameters' values,
not the laws or their order of operations, so the argument for each law carries over).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from pyflyt_engine.batched import BatchedUAVEnv, resolve_backend
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.errors import ConfigError

from tests.batched.test_crosscheck import AUTOPILOT_ACTION, BOUND, _flat, quiet  # noqa: F401  (a fixture)


def _uniform(low: float, high: float) -> dict:
    return {"distribution": "uniform", "low": low, "high": high}


#: every entry the batched backend draws, each law of Distribution among them
DRAWS = {
    "mass": _uniform(0.8, 1.2),
    "inertia": _uniform(0.8, 1.2),
    "motor_kf": {"distribution": "normal", "mean": 1.0, "std": 0.05, "low": 0.9, "high": 1.1},
    "motor_kt": {"distribution": "log_uniform", "low": 0.8, "high": 1.25},
    "motor_tau": {"distribution": "log_uniform", "low": 0.7, "high": 1.4},
    "drag": _uniform(0.5, 2.0),
    "spawn_x": _uniform(-0.3, 0.3),
    "spawn_y": _uniform(-0.3, 0.3),
    "spawn_z": _uniform(0.0, 0.3),
    "spawn_roll": _uniform(-0.1, 0.1),
    "spawn_pitch": _uniform(-0.1, 0.1),
    "spawn_yaw": _uniform(-0.5, 0.5),
    "observation_delay": _uniform(0.0, 0.03),
}

#: (env config, airframe, overrides): a multirotor in rates_thrust (with ground effect, which
#: reads the reaction per thrust) and in a cascade mode (the controller nominal), the fixed-wing
FLIGHTS = {
    "hover": ("quadx_hover", "quadx_cf2x", {}),
    "hover_ground_effect": ("quadx_hover", "quadx_f450", {"ground_effect": True}),
    "velocity": ("quadx_waypoints_velocity", "quadx_cf2x", {}),
    "fixedwing": ("fixedwing_waypoints", "fixedwing", {"action": AUTOPILOT_ACTION}),
}


def _generators(seed: int, n: int) -> list[np.random.Generator]:
    """Fresh copies of the batched env's per-env generators for ``seed`` (BatchedUAVEnv._seed_all)."""
    return [np.random.default_rng(c) for c in np.random.SeedSequence(seed).spawn(n + 1)[1:]]


def _pybullet(cfg, rng: np.random.Generator):
    """A PyBullet env of ``cfg`` whose episode draws from ``rng``, reset; its first observation and info."""
    env = make_env(cfg)
    env.unwrapped.np_random = rng
    obs, info = env.reset()
    return env, obs, info


def _vehicle(env) -> dict[str, np.ndarray]:
    """What the randomiser set on the PyBullet env's vehicle, and where it spawned."""
    v = env.unwrapped.world.vehicles[0]
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


def test_each_env_draws_and_applies_what_the_pybullet_env_does():
    """Four waypoint envs, two episodes each: the drawn values, delays, mass and inertia,
    motor lag, wrench columns and reaction per thrust, drag factors, the spawn and the
    waypoints are the PyBullet env's from the same generator (the mass and inertia exactly
    as PyBullet holds them; the pose within 1e-12, PyBullet's own storage)."""
    n, seed = 4, 11
    cfg = load_env_config("quadx_waypoints").with_overrides(randomize=DRAWS)
    be = BatchedUAVEnv(cfg, num_envs=n, motor_noise=False)
    _, info = be.reset(seed=seed)
    assert list(info["randomization"]) == list(DRAWS) and info["_randomization"].all()
    pybullet = []
    for i, rng in enumerate(_generators(seed, n)):
        pb, _, pb_info = _pybullet(cfg, rng)
        pybullet.append(pb)
        assert pb_info["randomization"] == {name: float(info["randomization"][name][i]) for name in DRAWS}
    for episode in range(2):
        if episode:  # a new episode in every env: each PyBullet env draws on from its stream
            be._reset_envs(np.arange(n))
            for pb in pybullet:
                pb.reset()
        for i, pb in enumerate(pybullet):
            drawn = pb.unwrapped.last_randomization
            assert list(be.randomized_values[i]) == [drawn[name] for name in DRAWS], (episode, i)
            assert tuple(be.latency_steps[i]) == pb.unwrapped.latency_steps
            got = _vehicle(pb)
            assert be._mass[i] == got["mass"] and np.array_equal(be._inertia[i], got["inertia"])
            assert np.array_equal(be._lag[i], got["lag"]) and np.array_equal(be._columns[i], got["columns"])
            assert np.array_equal(be._rotors[i, :, 4], got["reaction"])
            assert np.array_equal(be._drag_factors[i], got["drag"]) and be._damping[i] == got["damping"]
            assert np.abs(be.pos[i] - got["pos"]).max() < 1e-12 and np.abs(be.quat[i] - got["quat"]).max() < 1e-12
            assert np.array_equal(be.targets[i], pb.unwrapped.task.targets)
    nominal = BatchedUAVEnv(cfg.with_overrides(randomize={}), num_envs=n)
    assert np.all(be._mass != nominal._mass) and np.all(be._columns[:, :, 2] != nominal._columns[:, :, 2])
    assert len({tuple(row) for row in be.randomized_values}) == n  # the envs drew apart
    # the controller keeps the nominal airframe
    for name in ("_control_inertia", "_gyro", "_mixer_rows", "_max_collective", "_rate_gains"):
        assert np.array_equal(getattr(be, name), getattr(nominal, name)), name
    for pb in pybullet:
        pb.close()


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_randomised_flights_agree_with_the_pybullet_engine(quiet, flight):  # noqa: F811
    """Every entry drawn, 2 s of random actions from the drawn spawn (not copied over: each
    backend's own): positions, observations and rewards within 1e-6."""
    env_name, uav, overrides = FLIGHTS[flight]
    cfg = load_env_config(env_name).with_overrides(uav=quiet[uav], randomize=DRAWS, **overrides)
    be = BatchedUAVEnv(cfg, num_envs=1)
    first, info = be.reset(seed=5)
    pb, start, pb_info = _pybullet(cfg, _generators(5, 1)[0])
    assert pb_info["randomization"] == {name: float(v[0]) for name, v in info["randomization"].items()}
    low, high = np.array(cfg.action.low), np.array(cfg.action.high)
    rng = np.random.default_rng(7)
    worst = np.abs(_flat(start) - first[0]).max()  # the drawn spawn, the targets drawn after it
    flown = 0
    for flown in range(1, 61):
        if cfg.action.mode == "rates_thrust":  # around the nominal hover
            action = np.r_[rng.uniform(-1.0, 1.0, 3), be.model.hover_thrust_fraction * rng.uniform(0.95, 1.2)]
        else:
            action = rng.uniform(low, high)
        o1, r1, t1, tr1, i1 = pb.step(action)
        o2, r2, t2, tr2, i2 = be.step(action[None])
        final = i2["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        worst = max(worst, np.abs(_flat(o1) - final).max(), abs(r1 - r2[0]))
        if t1 and i1["collision"] and not t2[0]:  # PyBullet's contact threshold: the batched crash comes next
            assert bool(be.step(action[None])[2][0])
            break
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        if t1 or tr1:
            break
    pb.close()
    assert worst < BOUND, worst
    assert flown >= 30, "the flight ended too soon to compare much"


def _run(seed: int, steps: int = 120) -> list[np.ndarray]:
    """16 hover envs with every entry drawn and motor noise on, random actions, then motors
    off (every env crashes and draws a new episode): the arrays after each step."""
    env = BatchedUAVEnv(load_env_config("quadx_hover").with_overrides(randomize=DRAWS), num_envs=16)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    out = [obs, env.randomized_values.copy()]
    for k in range(steps):
        a = rng.uniform([-1, -1, -1, 0.1], [1, 1, 1, 0.2], (16, 4)) if k < steps // 2 else np.zeros((16, 4))
        obs, reward, *_ = env.step(a)
        out += [obs, reward, env.randomized_values.copy(), env._mass.copy(), env._columns.copy()]
    return out


def test_a_rerun_with_the_seed_is_bit_identical_in_another_process():
    """The same seed draws and flies the same numbers, bit for bit, here and in a fresh process;
    the crashes in it draw new episodes, and another seed draws other values."""
    first, again = _run(3), _run(3)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(first, again))
    assert not np.array_equal(first[1], first[-3])  # every env reset and drew anew
    code = (
        "import hashlib; from tests.batched.test_randomization import _run; "
        "print(hashlib.sha256(b''.join(a.tobytes() for a in _run(3))).hexdigest())"
    )
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    import hashlib

    assert other == hashlib.sha256(b"".join(a.tobytes() for a in first)).hexdigest()
    assert not np.array_equal(_run(4, steps=1)[1], first[1])


def test_a_checkpoint_carries_the_draws_and_the_parameters_they_set():
    """``episode_state`` then ``restore_episode`` puts each env's draws and the mass, inertia,
    motor and drag rows they set back: the steps after it repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("quadx_hover").with_overrides(backend="batched", randomize=DRAWS)
    vec = make_vec_env(cfg, 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    for _ in range(10):
        vec.step(rng.uniform(-0.3, 0.3, (3, 4)))
    saved = vec.env_method("episode_state")
    env = vec.env
    for name in ("randomized_values", "_mass", "_inertia", "_lag", "_columns", "_rotors", "_drag_factors", "_damping"):
        assert name in saved[0]["batched"], name
    actions = rng.uniform(-0.3, 0.3, (20, 3, 4))
    first = [vec.step(a)[0] for a in actions]
    for name in ("_mass", "_inertia", "_lag", "_columns", "_drag_factors", "_damping", "randomized_values"):
        getattr(env, name)[:] = 1.0  # state the restore must put back
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


@pytest.mark.parametrize(
    "name, entry, why",
    [
        ("wind.turbulence.rotary_min_span", _uniform(0.0, 3.0), "the envs' filter rows keep the config's size"),
    ],
)
def test_what_it_does_not_simulate_stays_refused_by_name(name, entry, why):
    """An entry of a model the batched backend lacks (after supported ones) is refused, naming
    the entry, and the backend auto trains such a config on PyBullet."""
    wind = {"wind": "dryden_light"} if name.startswith("wind.") else {}
    cfg = load_env_config("quadx_hover").with_overrides(randomize={"mass": DRAWS["mass"], name: entry}, **wind)
    with pytest.raises(ConfigError) as info:
        BatchedUAVEnv(cfg.with_overrides(backend="batched"), num_envs=2)
    message = str(info.value)
    assert f"does not simulate env.randomize.{name} (domain randomisation" in message and why in message, message
    assert resolve_backend(cfg.with_overrides(backend="auto")) == "pybullet"
    assert resolve_backend(load_env_config("quadx_hover").with_overrides(backend="auto", randomize=DRAWS)) == "batched"
    assert (
        resolve_backend(load_env_config("quadx_hover").with_overrides(backend="auto", randomize="moderate"))
        == "batched"
    )
