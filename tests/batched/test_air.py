"""The batched backend's air (pyflyt_engine/batched/air.py): the wind field and ground
effect, bit for bit the PyBullet engine's laws, and flown against the PyBullet engine.

Laws (bit for bit on random inputs): the wind at a vehicle against the engine's own
:class:`~pyflyt_engine.atmosphere.field.WindField` (every deterministic preset and random
mean, shear and gust configs, at random heights, step after step; the Dryden presets and
variants given the white noise the engine's field draws, across its blocks); the velocity through
the air against :func:`~pyflyt_engine.atmosphere.air.air_velocity` and
:func:`~pyflyt_engine.atmosphere.air.air_velocity_from_body`; the ground-effect motor
columns and the motor step against ``RotorInteractions.ground_effect_ratios`` and
``Motors.step`` with those ratios.

Cross-checks (same spawn and actions, motor noise off): the bound and its derivation are
``test_crosscheck.py``'s (1e-6): the wind and ground effect add laws that are bit for bit
the engine's and continuous in the state (the gust's and the shear's branches switch on
the time, which both backends count in whole physics steps, or on a height within its last
bits of z0), so the two backends still differ only by the rigid body's last bits.  Each
flight is also flown in calm air (or out of ground effect) on the batched backend, and
must differ from it by far more than the bound: the air is felt.

Turbulence: the two backends draw its white noise from different streams, so the
cross-checks inject the engine's draws into the batched filter (a repeat of the engine
world's wind stream, checked against the engine's first wind sample bit for bit); the
batched envs' own draws are checked for the Dryden intensities, for determinism under a
seed and for each env's independence of the others (a checkpoint carries them:
``test_training.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.assembly import assemble
from pyflyt_engine.atmosphere import load_wind_config
from pyflyt_engine.atmosphere.air import air_velocity, air_velocity_from_body
from pyflyt_engine.atmosphere.field import WindField
from pyflyt_engine.atmosphere.rotors import RotorInteractions
from pyflyt_engine.batched import BatchedUAVEnv, air, kernels
from pyflyt_engine.batched.model import batched_model
from pyflyt_engine.components.motor import Motors
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.spec import load_uav_spec

from tests.batched import test_crosscheck
from tests.batched.test_crosscheck import AUTOPILOT_ACTION, BOUND, _flat, _pair
from tests.batched.test_laws import CONTROL_DT, DT, FIXEDWINGS, FLOWN, MULTIROTORS

#: the shipped deterministic winds, and variants that reach every branch within 2 s
DETERMINISTIC = ("constant", "shear", "gust")
VARIANTS = {
    "shear_power": {"preset": "shear", "mean": {"profile": "power", "direction": 30.0}},
    "gust_fast": {"preset": "gust", "gust": {"start": 0.2, "length": 2.0, "amplitude": [2.0, -1.0, 0.5]}},
    "gust_step_on_wind": {
        "preset": "constant",
        "mean": {"direction": 120.0, "vertical": -0.3},
        "gust": {"amplitude": [0.0, 1.5, 0.0], "length": 3.0, "speed": 6.0, "start": 0.5, "shape": "step"},
    },
}


#: no turbulence: the filter's output wind_sample adds only where the config has turbulence
CALM6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
#: each flown airframe with its motor noise off (test_crosscheck.py's fixture)
quiet = pytest.fixture(scope="module")(test_crosscheck.quiet.__wrapped__)


def _random_winds(rng: np.random.Generator, count: int) -> list[dict]:
    winds = []
    for _ in range(count):
        mean = {
            "speed": float(rng.uniform(0, 8)),
            "direction": float(rng.uniform(-360, 360)),
            "vertical": float(rng.normal(0, 1)),
            "profile": str(rng.choice(["uniform", "log", "power"])),
            "reference_height": float(rng.uniform(1, 20)),
            "roughness_length": float(rng.uniform(0.001, 0.5)),
            "exponent": float(rng.uniform(0, 0.4)),
        }
        gust = {
            "amplitude": rng.normal(0, 3, 3).tolist(),
            "length": float(rng.uniform(0.5, 10)),
            "speed": float(rng.uniform(0.5, 10)),
            "start": float(rng.uniform(0, 2)),
            "shape": str(rng.choice(["step", "pulse"])),
        }
        winds.append({"mean": mean if rng.random() < 0.8 else None, "gust": gust if rng.random() < 0.7 else None})
    return winds


@pytest.mark.parametrize("wind", [*DETERMINISTIC, *VARIANTS, *(f"random{k}" for k in range(12))])
def test_the_wind_equals_the_engines_field(wind):
    """Step after step (1,200 physics steps: every gust's rise, hold and fall), at random
    heights (below z0 and 0 included): the compiled wind equals ``WindField.at``."""
    if wind.startswith("random"):
        k = int(wind[6:])
        config = load_wind_config(_random_winds(np.random.default_rng(100 + k), k + 1)[k])
    else:
        config = load_wind_config(VARIANTS.get(wind, wind))
    field = WindField(config, DT, np.random.default_rng(0))
    probe = field.add_vehicle(0.1)
    params = air.wind_params(config)
    assert params[0] == (0.0 if config.calm else 1.0)
    rng = np.random.default_rng(5)
    for step in range(1200):
        for height in (*rng.uniform(-1.0, 30.0, 3), 0.0, 0.01, 100.0):
            position = (float(rng.normal()), float(rng.normal()), float(height))
            assert (
                air.wind_sample(params, step, float(height), DT, CALM6)
                == field.at(0, position)
                == tuple(probe(position))
            )
        field.advance()


#: turbulent winds: the presets, one on a sheared mean wind with a gust and its own
#: direction, rotary gusts for every span, none at all
TURBULENT = {
    "dryden_light": "dryden_light",
    "dryden_severe": "dryden_severe",
    "on_shear_and_gust": {
        "preset": "dryden_moderate",
        "mean": {"speed": 4.0, "direction": 70.0, "profile": "log"},
        "gust": {"amplitude": [1.0, 0.5, -0.5], "length": 2.0, "speed": 4.0, "start": 0.1},
        "turbulence": {"direction": -40.0, "airspeed": 12.0},
    },
    "rotary_for_all": {"preset": "dryden_light", "turbulence": {"rotary_min_span": 0.0, "height": 50.0}},
    "linear_only": {"preset": "dryden_severe", "turbulence": {"angular": False}},
}


def _turbulent_field(config, span: float, block: int, seed: int):
    """The engine's field of one vehicle of ``span``, reset onto a stream of ``seed``, and a
    second generator that repeats that stream's draws."""
    field = WindField(config, DT, np.random.default_rng(0), block=block)
    field.add_vehicle(span)
    field.reset(np.random.default_rng(seed))
    return field, np.random.default_rng(seed)


@pytest.mark.parametrize("span", [0.056, 2.4])
@pytest.mark.parametrize("wind", list(TURBULENT))
def test_the_turbulence_equals_the_engines_field_on_the_same_noise(wind, span):
    """The Dryden filter's initial draw, output and step, given the white noise the engine's
    field draws (its blocks of standard normals, one row per filter state): the wind and
    rotary gusts equal ``WindField.at`` bit for bit, step after step, across its blocks."""
    config = load_wind_config(TURBULENT[wind])
    block = 97
    field, noise = _turbulent_field(config, span, block, seed=11)
    dryden = air.dryden_filter(config, DT, span)
    assert dryden.rotary == (config.turbulence.angular and span >= config.turbulence.rotary_min_span)
    n = dryden.states
    assert n == (8 if dryden.rotary else 5)
    params = air.wind_params(config, rotary=dryden.rotary)
    x, scratch = np.empty(n), np.empty(n)
    air.dryden_initial(dryden.arrays, noise.standard_normal((n, 1))[:, 0].copy(), x)
    rng = np.random.default_rng(6)
    moved = rotary = 0.0
    for step in range(3 * block + 5):
        if step % block == 0:
            normals = noise.standard_normal((n, block))
        gusts = air.dryden_output(dryden.arrays, x, params[18], params[19])
        height = float(rng.uniform(0.0, 40.0))
        expected = field.at(0, (0.0, 0.0, height))
        assert air.wind_sample(params, step, height, DT, gusts) == expected
        moved = max(moved, abs(expected[0]))
        if dryden.rotary:
            rotary = max(rotary, abs(expected[3]))
        else:
            assert expected[3:] == (0.0, 0.0, 0.0)
        air.dryden_step(dryden.arrays, x, np.ascontiguousarray(normals[:, step % block]), scratch)
        field.advance()
    assert moved > 0.05 and (rotary > 1e-4 or not dryden.rotary)  # it blew


def test_the_gust_fraction_equals_the_engines_at_its_edges():
    from pyflyt_engine.atmosphere.field import gust_profile, gust_profiles

    for length in (0.5, 5.0, 7.3):
        xs = np.r_[
            -1.0,
            -0.0,
            0.0,
            5e-324,
            length,
            np.nextafter(length, 0),
            np.nextafter(length, 99),
            2 * length,
            np.nextafter(2 * length, 0),
            np.nextafter(2 * length, 99),
            np.random.default_rng(1).uniform(-1, 3 * length, 200),
        ]
        for shape in ("step", "pulse"):
            expected = gust_profiles(xs, length, shape)
            for x, e in zip(xs.tolist(), expected.tolist()):
                got = air.gust_fraction(x, length, shape == "pulse")
                assert got == e == gust_profile(x, length, shape)


def test_the_velocity_through_the_air_equals_the_engines():
    rng = np.random.default_rng(3)
    for _ in range(500):
        q = rng.normal(size=4)
        r = kernels.rotation_tuple(*(q / np.linalg.norm(q)).tolist())
        v, w, b, c = (tuple(rng.normal(0, 5, 3).tolist()) for _ in range(4))
        wind = tuple(rng.normal(0, 3, 6).tolist())
        got = air.air_from_motion(r, *v, *w, wind)
        assert got == tuple(x for part in air_velocity(r, v, w, wind) for x in part)
        got = air.air_from_body(r, *b, *c, wind)
        assert got == tuple(x for part in air_velocity_from_body(r, b, c, wind) for x in part)


@pytest.mark.parametrize("name", FLOWN)
def test_ground_effect_equals_the_engines_rotors_and_motors(name):
    """Random heights (into the clamp) and attitudes: the scaled columns and the motor step
    equal ``RotorInteractions.ground_effect_ratios`` fed to ``Motors.step``."""
    spec = load_uav_spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    rotors = RotorInteractions(True, False)
    motors = parts.motors
    radii = [None] * motors.count
    if spec.motors.prop_radius is not None:
        radii = spec.motors.to_array("prop_radius").tolist()
    rotors.add_vehicle(motors.positions.tolist(), radii, motors.max_thrust.tolist())
    group = Motors(motors, DT, NoiseSource(np.random.default_rng(0)))
    group._noisy = False  # the factors are 1 on both sides (the noise law is test_laws.py's)
    rng = np.random.default_rng(4)
    n = motors.count
    throttle = rng.uniform(0.0, 1.0, n)
    group.throttle = throttle.tolist()
    scaled = np.empty((n, 6))
    for _ in range(300):
        q = rng.normal(size=4)
        r = kernels.rotation_tuple(*(q / np.linalg.norm(q)).tolist())
        z = float(rng.uniform(-0.05, 0.6))
        ratios = rotors.ground_effect_ratios(0, (0.3, -0.2, z), r)
        air.ground_effect_columns(
            z, r[6], r[7], r[8], model.rotors, model.columns, air.GROUND_EFFECT_MIN_HEIGHT, scaled
        )
        assert [tuple(row) for row in scaled.tolist()] == group._scaled_columns(ratios)
        command = rng.uniform(0.0, 1.0, n)
        group.command = command.tolist()
        expected = group.step(None, ratios)
        assert kernels.motors_step(throttle, command, model.lag, np.ones(n), scaled) == expected
        assert throttle.tolist() == group.throttle
    if spec.motors.prop_radius is not None:
        assert max(rotors.ground_effect_ratios(0, (0, 0, 0.0), (1, 0, 0, 0, 1, 0, 0, 0, 1))) == pytest.approx(4 / 3)


# ------------------------------------------------------------------ cross-checks


def _fly(pb, be, actions, steps: int = 60):
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0}
    positions = []
    for k in range(steps):
        action = actions(k)
        o1, r1, t1, tr1, _ = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        worst["position"] = max(worst["position"], np.abs(_flat(o1)[10:13] - final[10:13]).max())
        worst["observation"] = max(worst["observation"], np.abs(_flat(o1) - final).max())
        worst["reward"] = max(worst["reward"], abs(r1 - r2[0]))
        positions.append(final[10:13].copy())
        if t1 or tr1:
            break
    pb.close()
    return worst, np.array(positions)


def _calm_twin(be: BatchedUAVEnv, actions, steps: int) -> np.ndarray:
    """The same flight on the batched backend in ``be``'s config: positions per step."""
    positions = []
    for k in range(steps):
        o, _, t, tr, info = be.step(actions(k)[None])
        positions.append((info["final_obs"][0] if t[0] or tr[0] else o[0])[10:13].copy())
        if t[0] or tr[0]:
            break
    return np.array(positions)


def _twin(env_name: str, uav: str, seed: int, **overrides) -> BatchedUAVEnv:
    pb, be = _pair(env_name, uav, seed=seed, **overrides)
    pb.close()
    return be


def _felt(flown: np.ndarray, calm: np.ndarray) -> float:
    k = min(len(flown), len(calm))
    return float(np.abs(flown[:k] - calm[:k]).max())


def fly_air_pair(uav: str, wind=None, mode: str | None = None, ground_effect: bool = False):
    """Both backends fly airframe file ``uav`` (motor noise off) from one start for 2 s in
    ``wind`` (a preset name, :data:`VARIANTS` or :data:`TURBULENT` key, or None: calm) or
    with ``ground_effect`` near the ground; a multirotor QuadX-Hover in rates_thrust on random
    actions around hover, a fixed-wing Fixedwing-Waypoints in ``mode`` (channels or
    attitude_airspeed) on random actions over its range; turbulence with the engine's white
    noise injected.  Returns the largest differences (positions [m], observations,
    rewards), the agent steps flown, and how far the flight got from the same flight in calm
    air (or out of ground effect) on the batched backend [m].  The tests below and
    ``experiments/batched_air_crosscheck.py`` (the documented figures) fly it."""
    wind_cfg = VARIANTS.get(wind, TURBULENT.get(wind, wind))
    fixedwing = batched_model(load_uav_spec(uav), DT, CONTROL_DT).channel_driven
    overrides: dict = {}
    if fixedwing:
        env_name, seed, draws = "fixedwing_waypoints", 0, np.random.default_rng(20)
        if mode == "attitude_airspeed":
            overrides["action"] = AUTOPILOT_ACTION
    else:
        env_name, seed, draws = "quadx_hover", 3, np.random.default_rng(7)
    if ground_effect:  # the quads (rotors with a prop_radius) 0.15 m up; others at the task's 1 m
        height = 0.15 if load_uav_spec(uav).motors.prop_radius is not None else 1.0
        overrides.update(
            start_position=[0.0, 0.0, height],
            hover_point=[0.0, 0.0, height],
            start_position_noise=0.02,
            start_orientation_noise=0.02,
        )
        draws = np.random.default_rng(9)
    flown_with = dict(overrides, ground_effect=True) if ground_effect else dict(overrides)
    if wind_cfg is not None:
        flown_with["wind"] = wind_cfg
    pb, be = _pair(env_name, uav, seed=seed, **flown_with)
    if be.dryden is not None:
        _inject_the_engines_turbulence(pb, be)
    if fixedwing:
        low, high = np.array(be.config.action.low), np.array(be.config.action.high)
        table = [draws.uniform(low, high) for _ in range(60)]
    else:
        hover = be.model.hover_thrust_fraction
        rates, thrust = (0.2, (0.97, 1.03)) if ground_effect else (1.0, (0.95, 1.15))
        table = [np.r_[draws.uniform(-rates, rates, 3), hover * draws.uniform(*thrust)] for _ in range(60)]
    worst, flown = _fly(pb, be, lambda k: table[k])
    calm = _calm_twin(_twin(env_name, uav, seed, **overrides), lambda k: table[k], len(flown))
    return worst, len(flown), _felt(flown, calm), float(flown[:, 2].min())


@pytest.mark.parametrize("wind", [*DETERMINISTIC, *VARIANTS])
@pytest.mark.parametrize("name", MULTIROTORS)
def test_multirotors_in_the_wind_agree_with_the_pybullet_engine(quiet, name, wind):
    """QuadX-Hover, rates_thrust, 2 s of random actions around hover in each deterministic
    wind: positions, observations and rewards within 1e-6 of the PyBullet engine's."""
    worst, flown, felt, _ = fly_air_pair(quiet[name], wind)
    assert max(worst.values()) < BOUND, worst
    assert flown >= 15, "the flight crashed too soon to compare much"
    assert felt > 1e-3, "the wind was not felt"


@pytest.mark.parametrize("wind", ["constant", "shear", "gust_fast", "gust_step_on_wind"])
@pytest.mark.parametrize("mode", ["channels", "attitude_airspeed"])
@pytest.mark.parametrize("name", FIXEDWINGS)
def test_fixedwings_in_the_wind_agree_with_the_pybullet_engine(quiet, name, mode, wind):
    """Fixedwing-Waypoints, 2 s of random actions (channels or the autopilot's setpoints)
    in each deterministic wind: within 1e-6 (every surface at its own air velocity)."""
    worst, flown, felt, _ = fly_air_pair(quiet[name], wind, mode)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"
    assert felt > 1e-3, "the wind was not felt"


@pytest.mark.parametrize("name", MULTIROTORS)
def test_ground_effect_near_the_ground_agrees_with_the_pybullet_engine(quiet, name):
    """QuadX-Hover spawned near the ground with ground effect on, 2 s of actions around
    hover thrust: within 1e-6 of the PyBullet engine's.  The quads (rotors with a
    prop_radius, spawned 0.15 m up) fly differently from the same flight without ground
    effect; the hexacopter (no prop_radius: no ground effect in the engine; spawned at the
    task's 1 m) flies as without it."""
    worst, flown, felt, lowest = fly_air_pair(quiet[name], ground_effect=True)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"
    if load_uav_spec(name).motors.prop_radius is not None:
        assert lowest < 0.2 and felt > 1e-4, "ground effect was not felt"
    else:
        assert felt < BOUND


def _inject_the_engines_turbulence(pb, be: BatchedUAVEnv) -> None:
    """Give env 0 of ``be`` the white noise the PyBullet engine's field draws this episode:
    the engine's world reseeded its wind stream at the reset (``World._wind_rng``) and drew
    from it the filter's initial state, then a block of standard normals per state (field
    blocks of 2,048 physics steps); the same draws, from a repeat of that stream, go to the
    batched filter (its initial state, and :meth:`BatchedUAVEnv.turbulence_normals`)."""
    world = pb.unwrapped.world
    field = world.wind
    stream = np.random.default_rng(np.random.SeedSequence(world._seed_sequence.entropy, spawn_key=(2,)))
    n = be.dryden.states
    air.dryden_initial(be._dryden_arrays, stream.standard_normal((n, 1))[:, 0].copy(), be.turbulence[0])
    blocks = np.concatenate([stream.standard_normal((n, field.block)) for _ in range(2)], axis=1)
    per = be.per_agent
    steps = iter(range(10**6))
    be.turbulence_normals = lambda: np.ascontiguousarray(blocks[:, (k := next(steps)) * per : (k + 1) * per].T[None])
    gusts = air.dryden_output(be._dryden_arrays, be.turbulence[0], be._wind[18], be._wind[19])
    here = be.pos[0].tolist()
    assert air.wind_sample(be._wind, 0, here[2], be.physics_dt, gusts) == tuple(world.atmosphere.wind_at(0, here))


@pytest.mark.parametrize("wind", ["dryden_light", "dryden_severe", "on_shear_and_gust"])
@pytest.mark.parametrize("name", MULTIROTORS)
def test_multirotors_in_turbulence_agree_with_the_pybullet_engine_on_the_same_noise(quiet, name, wind):
    """QuadX-Hover, rates_thrust, 2 s of random actions around hover in Dryden turbulence,
    the engine's white noise injected into the batched filter: within 1e-6 (the bound of
    the module docstring: the filter is bit for bit the engine's given the same noise)."""
    worst, flown, felt, _ = fly_air_pair(quiet[name], wind)
    assert max(worst.values()) < BOUND, worst
    assert flown >= 15, "the flight crashed too soon to compare much"
    assert felt > 1e-3, "the turbulence was not felt"


@pytest.mark.parametrize("mode", ["channels", "attitude_airspeed"])
@pytest.mark.parametrize("name", FIXEDWINGS)
def test_fixedwings_in_turbulence_agree_with_the_pybullet_engine_on_the_same_noise(quiet, name, mode):
    """Fixedwing-Waypoints in moderate turbulence (rotary gusts: the fixed-wings' spans are
    above 1 m), the engine's white noise injected: within 1e-6."""
    assert BatchedUAVEnv(
        load_env_config("fixedwing_waypoints").with_overrides(uav=quiet[name], wind="dryden_moderate")
    ).dryden.rotary
    worst, flown, felt, _ = fly_air_pair(quiet[name], "dryden_moderate", mode)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"
    assert felt > 1e-3, "the turbulence was not felt"


def test_every_wind_and_ground_effect_are_supported_and_downwash_refused():
    from pyflyt_engine.atmosphere import available_winds
    from pyflyt_engine.batched import check_supported
    from pyflyt_engine.batched.model import UnsupportedByBatched

    for env_name in ("quadx_hover", "fixedwing_waypoints"):
        for wind in (*available_winds(), *VARIANTS.values(), *TURBULENT.values()):
            check_supported(load_env_config(env_name).with_overrides(wind=wind, ground_effect=True))
    with pytest.raises(UnsupportedByBatched, match="downwash"):
        check_supported(load_env_config("quadx_hover").with_overrides(wind="dryden_light", downwash=True))


def test_turbulence_is_deterministic_under_a_seed_and_each_env_s_own():
    """Same seed: the same turbulence; another seed: another; env i's turbulence is drawn
    from its own stream, so it does not depend on how many envs fly beside it (motor noise
    off: the batch's motor noise is one stream)."""

    def fly(n: int, seed: int) -> np.ndarray:
        env = BatchedUAVEnv(
            load_env_config("quadx_hover").with_overrides(wind="dryden_severe"), num_envs=n, motor_noise=False
        )
        env.reset(seed=seed)
        hover = np.tile([0.0, 0.0, 0.0, env.model.hover_thrust_fraction], (n, 1))
        out = [np.c_[env.step(hover)[0], env.turbulence] for _ in range(40)]
        return np.array(out)

    a, b = fly(2, 5), fly(5, 5)
    assert np.array_equal(a, fly(2, 5))
    assert np.array_equal(a[:, :2], b[:, :2])
    assert not np.array_equal(a[:, 0], a[:, 1])  # two envs, two realisations
    assert np.abs(fly(2, 6) - a).max() > 1e-3


def test_the_batched_turbulence_has_the_dryden_intensities():
    """The batched envs' own draws: over 2,000 envs the turbulence at the start (the
    stationary draw) and 1 s later (240 filter steps on the envs' streams) has the
    MIL-F-8785C intensities sigma_u, sigma_v, sigma_w within 6 % (the standard error of a
    standard deviation from 2,000 samples is 1.6 %)."""
    from pyflyt_engine.atmosphere.dryden import low_altitude_scales

    config = load_wind_config("dryden_severe")
    cfg = load_env_config("quadx_hover").with_overrides(wind="dryden_severe", flight_dome_size=1000.0)
    env = BatchedUAVEnv(cfg, num_envs=2000, motor_noise=False)
    env.reset(seed=1)
    s = low_altitude_scales(config.turbulence.height, config.turbulence.wind_speed_20ft)

    def intensities() -> np.ndarray:
        # in the turbulence axes (heading 0 here: the ground frame)
        out = np.array([air.dryden_output(env._dryden_arrays, x, 1.0, 0.0)[:3] for x in env.turbulence])
        return out.std(axis=0)

    expected = np.array([s.sigma_u, s.sigma_v, s.sigma_w])
    assert np.allclose(intensities(), expected, rtol=0.06)
    env.pos[:, 2] = 50.0  # clear of the ground: every env flies the whole second
    env.vel[:] = 0.0
    hover = np.tile([0.0, 0.0, 0.0, env.model.hover_thrust_fraction], (2000, 1))
    for _ in range(30):
        env.step(hover)
    assert int(env.physics_steps.min()) == 240
    assert np.allclose(intensities(), expected, rtol=0.06)


@pytest.mark.parametrize("wind", ["gust_fast", "shear", "on_shear_and_gust"])
@pytest.mark.parametrize("name", MULTIROTORS)
def test_a_cascade_mode_in_the_air_agrees_with_the_pybullet_engine(quiet, name, wind):
    """QuadX-Waypoints flown by ground velocity (mode velocity_yawrate: the controller's tick,
    then each control period's physics in mode motors, pyflyt_engine/batched/modes.py), 2 s
    of random setpoints in the wind (turbulence injected): within 1e-6, the wind at each
    period's own physics steps."""
    worst, flown = fly_cascade_air_pair(quiet[name], wind)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"


def fly_cascade_air_pair(uav: str, wind: str):
    """Both backends fly QuadX-Waypoints' velocity variant on airframe file ``uav`` for 2 s
    of random setpoints in ``wind`` (as :func:`fly_air_pair`); returns the largest
    differences and the agent steps flown (``experiments/batched_air_crosscheck.py`` too)."""
    pb, be = _pair("quadx_waypoints_velocity", uav, seed=3, wind=VARIANTS.get(wind, TURBULENT.get(wind, wind)))
    if be.dryden is not None:
        _inject_the_engines_turbulence(pb, be)
    low, high = np.array(be.config.action.low), np.array(be.config.action.high)
    draws = np.random.default_rng(8)
    table = [draws.uniform(low, high) for _ in range(60)]
    worst, flown = _fly(pb, be, lambda k: table[k])
    return worst, len(flown)


@pytest.mark.parametrize("wind", ["gust_fast", "on_shear_and_gust"])
@pytest.mark.parametrize("flight", ["quadx_hover", "velocity", "fixedwing"])
def test_the_air_with_latency_agrees_with_the_pybullet_engine(quiet, flight, wind):
    """Delays between the ticks and the agent steps (13 physics steps on the action, 11 on
    the observation: the physics runs in pieces, pyflyt_engine/batched/latency.py): the wind
    of each piece is the one of its own physics steps, the turbulence driven by that piece's
    noise; within 1e-6 of the PyBullet engine (turbulence injected)."""
    from tests.batched.test_latency import FLIGHTS, _action, _latency

    env_name, uav, overrides = FLIGHTS[flight]
    pb, be = _pair(
        env_name,
        quiet[uav],
        seed=3,
        latency=_latency((13, 11)),
        wind=VARIANTS.get(wind, TURBULENT.get(wind)),
        **overrides,
    )
    if be.dryden is not None:
        _inject_the_engines_turbulence(pb, be)
    draws = np.random.default_rng(7)
    table = [_action(be, draws) for _ in range(60)]
    worst, flown = _fly(pb, be, lambda k: table[k])
    assert max(worst.values()) < BOUND, worst
    assert len(flown) >= 30, "the flight ended too soon to compare much"
