"""Randomised winds on the batched backend (``randomize`` entries ``wind.<path>``): per env and
per episode, the PyBullet engine's draws, each env flying its own wind.

The oracles: a PyBullet env drawing from the same generator as batched env ``i`` (the
generator the batched env spawns for it from the seed, as tests/batched/test_randomization.py
matches the other factors) draws the same values (equal as floats: one
``Distribution.sample`` call each, in the section's order) and builds from them the wind
config (``sampled_wind``) whose parameters and Dryden filter matrices env ``i``'s rows hold
(equal: the same functions of the same numbers; the filter against the engine's own
field's ``DrydenProcess``).  Flown with the same actions, and the engine's turbulence white
noise injected into the batched filter (the two backends draw it from different streams,
tests/batched/test_air.py), the trajectories, observations and rewards agree within
test_crosscheck.py's bound, 1e-6: the drawn wind changes the laws' parameters, not the laws
or their order of operations, so test_air.py's argument carries over.  Each flight is also
flown by the batched backend in the config's nominal wind and must differ from it by far
more than the bound (the drawn wind is felt).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import BatchedUAVEnv, air, resolve_backend
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.errors import ConfigError

from tests.batched.test_crosscheck import AUTOPILOT_ACTION, BOUND, _flat, quiet  # noqa: F401  (a fixture)
from tests.batched.test_randomization import _generators


def _uniform(low: float, high: float) -> dict:
    return {"distribution": "uniform", "low": low, "high": high}


#: a sheared mean wind with a gust, in moderate Dryden turbulence (its heading the mean wind's)
WIND = {
    "preset": "dryden_moderate",
    "mean": {"speed": 4.0, "direction": 70.0, "profile": "log"},
    "gust": {"amplitude": [1.5, -1.0, 0.5], "length": 2.0, "speed": 4.0, "start": 0.3},
}
#: the mean wind's speed and direction, a Dryden intensity (W20), the gust's arrival, and an
#: airframe factor between them (the draws interleave with the others in the section's order)
DRAWS = {
    "wind.mean.speed": _uniform(1.0, 6.0),
    "mass": _uniform(0.9, 1.1),
    "wind.mean.direction": _uniform(-180.0, 180.0),
    "wind.turbulence.wind_speed_20ft": {"distribution": "log_uniform", "low": 5.0, "high": 20.0},
    "wind.gust.start": _uniform(0.1, 0.8),
}

#: (env config, airframe, overrides): a multirotor in rates_thrust (no rotary gusts: span
#: below rotary_min_span), the fixed-wing on its autopilot (rotary gusts: span above 1 m)
FLIGHTS = {
    "hover": ("quadx_hover", "quadx_cf2x", {}),
    "fixedwing": ("fixedwing_waypoints", "fixedwing", {"action": AUTOPILOT_ACTION}),
}


class _Recorder:
    """The PyBullet world's wind stream, recording each block of standard normals it gives."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng
        self.draws: list[np.ndarray] = []

    def standard_normal(self, size):
        out = self.rng.standard_normal(size)
        self.draws.append(out.copy())
        return out

    def __getattr__(self, name: str):
        return getattr(self.rng, name)


def _pybullet(cfg, rng: np.random.Generator):
    """A PyBullet env of ``cfg`` whose episode draws from ``rng``, reset, its wind stream
    recorded; the env, its first observation, its info and the recorder."""
    env = make_env(cfg)
    world = env.unwrapped.world
    recorder = _Recorder(world._wind_generator)
    world._wind_generator = recorder
    env.unwrapped.np_random = rng
    obs, info = env.reset()
    return env, obs, info, recorder


def _inject(pb, be: BatchedUAVEnv, recorder: _Recorder) -> None:
    """Give env 0 of ``be`` the turbulence the PyBullet engine's field flies this episode.

    At the reset the randomiser gave the engine's world a new field (``World.set_wind``),
    which drew its filter's stationary state, then generated its first block of samples
    (and, registering the vehicle, a block again from where the first left it, or for
    rotary gusts a new filter: a new state and block).  From the last stationary draw on,
    the same draws go through the batched filter of env 0 (its drawn rows): the state, the
    steps of every block but the last, and the last block's normals as the flight's
    (:meth:`BatchedUAVEnv.turbulence_normals`).  The first wind sample must be the engine's,
    bit for bit."""
    dryden = be.dryden_of(0)
    n = dryden[0].shape[0]
    start = max(k for k, d in enumerate(recorder.draws) if d.shape == (n, 1))
    draws = recorder.draws[start:]
    x = be.turbulence[0]
    air.dryden_initial(dryden, np.ascontiguousarray(draws[0][:, 0]), x)
    scratch = np.empty(n)
    for block in draws[1:-1]:
        for s in range(block.shape[1]):
            air.dryden_step(dryden, x, np.ascontiguousarray(block[:, s]), scratch)
    flight = draws[-1]
    assert flight.shape == (n, pb.unwrapped.world.wind.block)
    per = be.per_agent
    steps = iter(range(10**6))
    be.turbulence_normals = lambda: np.ascontiguousarray(flight[:, (k := next(steps)) * per : (k + 1) * per].T[None])
    row = be._wind_rows[0]
    gusts = air.dryden_output(dryden, x, row[18], row[19])
    here = be.pos[0].tolist()
    assert air.wind_sample(row, 0, here[2], be.physics_dt, gusts) == tuple(
        pb.unwrapped.world.atmosphere.wind_at(0, here)
    )


def _rows(be: BatchedUAVEnv, i: int) -> list[np.ndarray]:
    return [a.copy() for a in (be._wind_rows[i], *be.dryden_of(i))]


def test_each_env_draws_and_flies_the_wind_the_pybullet_env_does():
    """Four envs, two episodes each: the drawn values are the PyBullet env's from the same
    generator, and env i's rows are that episode's wind: its parameters those of the world's
    wind config (the sampled one), its filter the engine's field's own matrices; the envs'
    winds differ and no other env's rows move when one env starts an episode."""
    n, seed = 4, 11
    cfg = load_env_config("fixedwing_waypoints").with_overrides(wind=WIND, randomize=DRAWS)
    be = BatchedUAVEnv(cfg, num_envs=n, motor_noise=False)
    _, info = be.reset(seed=seed)
    assert list(info["randomization"]) == list(DRAWS) and info["_randomization"].all()
    pybullet = [_pybullet(cfg, rng) for rng in _generators(seed, n)]
    for i, (_, _, pb_info, _) in enumerate(pybullet):
        assert pb_info["randomization"] == {name: float(info["randomization"][name][i]) for name in DRAWS}
    for episode in range(2):
        if episode:  # a new episode in env 2 alone (the others' rows stay), then in every env
            before = [_rows(be, i) for i in range(n)]
            be._reset_envs(np.array([2]))
            for i in (0, 1, 3):
                assert all(np.array_equal(a, b) for a, b in zip(before[i], _rows(be, i)))
            assert not np.array_equal(before[2][0], be._wind_rows[2])
            pybullet[2][0].reset()
            be._reset_envs(np.arange(n))
            for pb, *_ in pybullet:
                pb.reset()
        for i, (pb, *_) in enumerate(pybullet):
            world = pb.unwrapped.world
            drawn = pb.unwrapped.last_randomization
            assert list(be.randomized_values[i]) == [drawn[name] for name in DRAWS], (episode, i)
            config = world.wind_config  # the sampled wind the randomiser gave the world
            assert config.mean.speed == drawn["wind.mean.speed"] and config.gust.start == drawn["wind.gust.start"]
            assert config.turbulence.wind_speed_20ft == drawn["wind.turbulence.wind_speed_20ft"]
            assert be._wind_rows[i].tolist() == air.wind_params(config, rotary=True).tolist()
            process = world.wind._process  # the engine field's own filter (rotary gusts: 8 states)
            assert process.Phi.shape == (8, 8)
            assert np.array_equal(be._dryden_phi[i], process.Phi) and np.array_equal(be._dryden_c[i], process.C)
            assert np.array_equal(be._dryden_noise[i], process._noise_root)
            assert np.array_equal(be._dryden_root[i], process._state_root)
    assert len({tuple(row) for row in be._wind_rows.tolist()}) == n  # four envs, four winds
    assert len({be._dryden_c[i].tobytes() for i in range(n)}) == n  # and four intensities
    for pb, *_ in pybullet:
        pb.close()


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_flights_in_drawn_winds_agree_with_the_pybullet_engine(quiet, flight):  # noqa: F811
    """The wind drawn (and the mass), 2 s of random actions from each backend's own drawn
    spawn, the engine's turbulence noise injected: positions, observations and rewards within
    1e-6; the same flight in the config's own mean wind and gust (no turbulence) differs by far more."""
    env_name, uav, overrides = FLIGHTS[flight]
    cfg = load_env_config(env_name).with_overrides(uav=quiet[uav], wind=WIND, randomize=DRAWS, **overrides)
    be = BatchedUAVEnv(cfg, num_envs=1)
    first, info = be.reset(seed=5)
    pb, start, pb_info, recorder = _pybullet(cfg, _generators(5, 1)[0])
    assert pb_info["randomization"] == {name: float(v[0]) for name, v in info["randomization"].items()}
    _inject(pb, be, recorder)
    # the config's own mean wind and gust (no turbulence), from the same start with the drawn mass
    nominal = BatchedUAVEnv(cfg.with_overrides(randomize={}), num_envs=1)
    nominal.reset(seed=5)
    nominal.pos[:], nominal.quat[:], nominal.vel[:], nominal.angvel[:] = be.pos, be.quat, be.vel, be.angvel
    nominal._mass[:] = be._mass
    nominal._read()
    nominal.turbulence[:] = 0.0
    nominal.turbulence_normals = lambda: np.zeros((1, be.per_agent, nominal.dryden.states))
    low, high = np.array(cfg.action.low), np.array(cfg.action.high)
    rng = np.random.default_rng(7)
    worst = np.abs(_flat(start) - first[0]).max()
    felt = 0.0
    flown = 0
    for flown in range(1, 61):
        if cfg.action.mode == "rates_thrust":  # around the nominal hover
            action = np.r_[rng.uniform(-0.5, 0.5, 3), be.model.hover_thrust_fraction * rng.uniform(0.95, 1.2)]
        else:
            action = rng.uniform(low, high)
        o1, r1, t1, tr1, i1 = pb.step(action)
        o2, r2, t2, tr2, i2 = be.step(action[None])
        o3 = nominal.step(action[None])[0]
        final = i2["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        worst = max(worst, np.abs(_flat(o1) - final).max(), abs(r1 - r2[0]))
        felt = max(felt, np.abs(o3[0, 10:13] - final[10:13]).max())
        if t1 and i1["collision"] and not t2[0]:  # PyBullet's contact threshold: the batched crash comes next
            assert bool(be.step(action[None])[2][0])
            break
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        if t1 or tr1:
            break
    pb.close()
    assert worst < BOUND, worst
    assert flown >= 30, "the flight ended too soon to compare much"
    assert felt > 1e-3, "the drawn wind was not felt"


def test_a_checkpoint_carries_each_env_s_wind():
    """``episode_state`` then ``restore_episode`` puts each env's draws, wind parameters and
    turbulence filter back (with its turbulence state and stream): the steps after it repeat
    bit for bit, across the crashes and new draws in them."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("quadx_hover").with_overrides(backend="batched", wind=WIND, randomize=DRAWS)
    vec = make_vec_env(cfg, 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    for _ in range(10):
        vec.step(rng.uniform(-0.3, 0.3, (3, 4)))
    saved = vec.env_method("episode_state")
    env = vec.env
    names = ("randomized_values", "_wind_rows", "_dryden_phi", "_dryden_c", "_dryden_noise", "_dryden_root")
    for name in (*names, "_dryden_flags", "turbulence"):
        assert name in saved[0]["batched"], name
    actions = rng.uniform(-1.0, 1.0, (60, 3, 4))
    first, drawn = [], []
    for a in actions:
        first.append(vec.step(a)[0])
        drawn.append(env._wind_rows.copy())
    assert not np.array_equal(drawn[0], drawn[-1])  # an env crashed and drew a new wind
    for name in names:
        getattr(env, name)[:] = 1.0  # state the restore must put back
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again, redrawn = [], []
    for a in actions:
        again.append(vec.step(a)[0])
        redrawn.append(env._wind_rows.copy())
    assert all(np.array_equal(a, b) for a, b in zip(first, again))
    assert all(np.array_equal(a, b) for a, b in zip(drawn, redrawn))


def test_an_invalid_sampled_wind_is_refused_as_the_pybullet_env_refuses_it():
    """A negative mean wind speed drawn (a normal without bounds) is the same ConfigError on
    both backends, naming the draw and asking for bounds."""
    entries = {"wind.mean.speed": {"distribution": "normal", "mean": 0.0, "std": 3.0}}
    cfg = load_env_config("quadx_hover").with_overrides(wind="constant", randomize=entries)
    n, seed = 4, 2
    speeds = [float(rng.normal(0.0, 3.0)) for rng in _generators(seed, n)]
    i = next(k for k, v in enumerate(speeds) if v < 0)  # the first env that draws a negative speed
    with pytest.raises(ConfigError) as batched:
        BatchedUAVEnv(cfg, num_envs=n).reset(seed=seed)
    env = make_env(cfg)
    env.unwrapped.np_random = _generators(seed, n)[i]
    with pytest.raises(ConfigError) as pybullet:
        env.reset()
    env.close()
    message = str(batched.value)
    assert message == str(pybullet.value), (message, str(pybullet.value))
    assert f"'wind.mean.speed': {speeds[i]!r}" in message and "bound the distributions" in message, message


def test_wind_draws_are_batched_and_what_would_resize_the_filter_is_refused_by_name():
    """A config drawing wind.<path> entries flies on the batched backend under auto; the rotary
    span (it decides the filter's size per env) and a W20 drawn on a config without turbulence
    are refused by name (the worlds' draws: tests/batched/test_swarm_randomization_wind.py)."""
    from pyflyt_engine.batched import check_supported

    cfg = load_env_config("quadx_hover").with_overrides(wind=WIND, randomize=DRAWS)
    assert resolve_backend(cfg.with_overrides(backend="auto")) == "batched"
    for wind, name, why in (
        ("dryden_light", "wind.turbulence.rotary_min_span", "rotary states"),
        (
            {"preset": "dryden_light", "turbulence": {"wind_speed_20ft": 0.0}},
            "wind.turbulence.wind_speed_20ft",
            "positive wind_speed_20ft",
        ),
    ):
        refused = cfg.with_overrides(wind=wind, randomize={name: _uniform(0.5, 2.0)})
        with pytest.raises(ConfigError) as info:
            check_supported(refused)
        message = str(info.value)
        assert f"env.randomize.{name} (domain randomisation" in message and why in message, message
        assert resolve_backend(refused.with_overrides(backend="auto")) == "pybullet"
