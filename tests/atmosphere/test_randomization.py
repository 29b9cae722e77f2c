"""Domain randomisation declared in config: seeded draws, applied physics, info, MCAP, replay."""

from __future__ import annotations

import json
import math
import warnings

import gymnasium
import numpy as np
import pybullet as p
import pytest

import pyflyt_engine.envs  # noqa: F401
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.envs.randomization import Distribution
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import RecordEpisode, load_episode
from pyflyt_engine.telemetry.replay import verify

WINDY = {
    "wind.mean.speed": {"distribution": "uniform", "low": 0.0, "high": 4.0},
    "wind.mean.direction": {"distribution": "uniform", "low": 0.0, "high": 360.0},
    "mass": {"distribution": "log_uniform", "low": 0.8, "high": 1.25},
    "spawn_z": {"distribution": "normal", "mean": 0.0, "std": 0.1, "low": -0.2, "high": 0.2},
}


def make(**kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make("PyFlyt/QuadX-Hover-v0", **kwargs)


def test_distributions_are_bounded_and_have_their_laws():
    rng = np.random.default_rng(0)
    uniform = Distribution(distribution="uniform", low=2.0, high=4.0)
    logu = Distribution(distribution="log_uniform", low=0.5, high=2.0)
    normal = Distribution(distribution="normal", mean=1.0, std=0.5, low=0.5, high=1.2)
    u = np.array([uniform.sample(rng) for _ in range(20000)])
    lg = np.log([logu.sample(rng) for _ in range(20000)])
    n = np.array([normal.sample(rng) for _ in range(20000)])
    assert u.min() >= 2 and u.max() <= 4 and u.mean() == pytest.approx(3.0, abs=0.02)
    assert lg.min() >= math.log(0.5) - 1e-12 and lg.max() <= math.log(2.0) + 1e-12
    assert lg.mean() == pytest.approx(0.0, abs=0.02)  # uniform in log: symmetric about log 1
    assert n.min() == 0.5 and n.max() == 1.2  # clipped to its bounds
    # P(x < 0.5) = Phi(-1) = 0.1587 lands on the lower bound
    assert np.mean(n == 0.5) == pytest.approx(0.1587, abs=0.01)


def test_draws_follow_the_seed_and_appear_in_info():
    env = make(randomize=WINDY, wind="constant")
    _, a = env.reset(seed=7)
    _, b = env.reset(seed=7)
    _, c = env.reset(seed=8)
    _, d = env.reset()
    assert a["randomization"] == b["randomization"] != c["randomization"] != d["randomization"]
    assert list(a["randomization"]) == list(WINDY)  # declaration order
    world = env.unwrapped.world
    speed, heading = d["randomization"]["wind.mean.speed"], math.radians(d["randomization"]["wind.mean.direction"])
    assert world.wind_at(0)[:2] == pytest.approx((speed * math.cos(heading), speed * math.sin(heading)))
    assert env.unwrapped.state.lin_pos[2] == pytest.approx(1.0 + d["randomization"]["spawn_z"], abs=0.1 + 1e-9)
    env.close()
    assert "randomization" not in make().reset(seed=0)[1]  # none declared: no key, no draw


def test_the_sampled_airframe_is_the_one_that_flies():
    """Mass factor f at the nominal hover throttle (motor noise off): a = g (1 / f - 1)."""
    env = make(
        randomize={
            "mass": {"distribution": "uniform", "low": 1.2, "high": 1.2},
            "motor_kf": {"distribution": "uniform", "low": 0.9, "high": 0.9},
        }
    )
    env.reset(seed=0)
    base = env.unwrapped
    vehicle = base.vehicle
    nominal = vehicle.parts.mass
    assert p.getDynamicsInfo(vehicle.body_id, -1, physicsClientId=base.world.client)[0] == pytest.approx(1.2 * nominal)
    assert vehicle.actuators.motors.params.kf == pytest.approx(0.9 * vehicle.motors.kf)
    assert vehicle.controller is not None and vehicle.motors.kf[0] == pytest.approx(3.16e-10)  # controller: nominal
    vehicle.reset((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))  # level (the task spawns tilted)
    motors = vehicle.actuators.motors
    motors._noisy = False
    hover = vehicle.hover_throttle()  # nominal mass and kf
    motors.throttle = [hover] * 4
    motors.command = [hover] * 4
    state = vehicle.read_state()
    vehicle.apply_loads((state.lin_vel, state.ang_vel))  # still air
    p.stepSimulation(physicsClientId=base.world.client)
    vz = p.getBaseVelocity(vehicle.body_id, physicsClientId=base.world.client)[0][2]
    assert vz / base.world.physics_dt == pytest.approx(GRAVITY * (0.9 / 1.2 - 1.0), rel=1e-3)
    env.close()


@pytest.mark.parametrize(
    "randomize,message",
    [
        ({"mas": {"distribution": "uniform", "low": 0.9, "high": 1.1}}, "unknown parameter 'mas'"),
        ({"mass": {"distribution": "uniform", "low": 0.0, "high": 1.1}}, "lower bound low > 0"),
        ({"mass": {"distribution": "normal", "mean": 1.0}}, "needs mean and std"),
        ({"mass": {"distribution": "uniform", "low": 0.9, "high": float("inf")}}, "randomize.mass.high"),
        ({"mass": {"distribution": "uniform", "low": 1.1, "high": 0.9}}, "low must not exceed high"),
        ({"drag": {"distribution": "log_uniform", "low": -1.0, "high": 1.0}}, "log_uniform needs low > 0"),
        ({"wind.mean.speed": {"distribution": "uniform", "low": 0.0, "high": 3.0}}, "no 'mean' section"),
        ("extreme", "unknown randomize preset 'extreme'"),
    ],
)
def test_bad_randomisation_is_one_clear_message(randomize, message):
    with pytest.raises(ConfigError, match=message):
        make(randomize=randomize)


def test_randomised_windy_episodes_record_their_draws_and_verify(tmp_path):
    env = RecordEpisode(
        make(
            randomize={
                **WINDY,
                "inertia": {"distribution": "uniform", "low": 0.8, "high": 1.2},
                "action_delay": {"distribution": "uniform", "low": 0.0, "high": 0.04},
                "observation_delay": {"distribution": "normal", "mean": 0.02, "std": 0.01, "low": 0.0, "high": 0.04},
            },
            wind={"preset": "dryden_light", "mean": {"speed": 1.0}},
        ),
        tmp_path,
    )
    draws = []
    for episode in range(2):
        _, info = env.reset(seed=5 if episode == 0 else None)
        draws.append(info["randomization"])
        assert env.unwrapped.vehicle.latency == tuple(
            math.floor(info["randomization"][k] * 240.0 + 0.5) for k in ("action_delay", "observation_delay")
        )
        for _ in range(30):
            env.step(np.array([0.05, -0.05, 0.0, 0.14]))
    env.close()
    for path, drawn in zip(env.paths, draws):
        episode = load_episode(path)
        assert json.loads(episode.contents.require_metadata("episode")["randomization"]) == drawn
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0, result


def test_the_moderate_preset_passes_the_env_checkers():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make(randomize="moderate", wind="dryden_light")
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped)
    env.close()


def test_train_selects_a_preset_with_env_randomize():
    from pyflyt_cli.training.compose import compose_config

    cfg = compose_config(overrides=["env.randomize=moderate"])
    assert set(cfg.env.randomize) >= {"mass", "inertia", "motor_kf", "drag"}


def test_the_sim2real_preset_loads_and_changes_the_airframe_per_episode():
    """conf/randomize/sim2real.yaml through `pyflyt train env.randomize=sim2real`: its
    entries, each draw within its bounds, two seeds give two airframes, a seed gives the
    same one again, and the drawn mass, thrust coefficient and delays are the ones the simulated
    vehicle has (that those fly is test_the_sampled_airframe_is_the_one_that_flies)."""
    from pyflyt_cli.training.compose import compose_config

    cfg = compose_config(env="quadx_hover", overrides=["env.randomize=sim2real"])
    preset = cfg.env.randomize
    assert list(preset) == [
        "mass",
        "inertia",
        "motor_kf",
        "motor_kt",
        "motor_tau",
        "drag",
        "action_delay",
        "observation_delay",
    ]
    env = make(randomize="sim2real")
    draws = []
    for seed in (0, 1):
        _, info = env.reset(seed=seed)
        drawn = info["randomization"]
        draws.append(drawn)
        for name, value in drawn.items():
            assert preset[name].low <= value <= preset[name].high, name
        base = env.unwrapped
        vehicle = base.vehicle
        mass = p.getDynamicsInfo(vehicle.body_id, -1, physicsClientId=base.world.client)[0]
        assert mass == pytest.approx(drawn["mass"] * vehicle.parts.mass)
        assert vehicle.actuators.motors.params.kf == pytest.approx(drawn["motor_kf"] * vehicle.motors.kf)
        assert vehicle.actuators.motors.params.tau == pytest.approx(drawn["motor_tau"] * vehicle.motors.tau)
        delays = (drawn["action_delay"], drawn["observation_delay"])
        assert vehicle.latency == base.latency_steps == tuple(math.floor(d * 240.0 + 0.5) for d in delays)
    assert draws[0]["mass"] != draws[1]["mass"] and draws[0]["motor_tau"] != draws[1]["motor_tau"]
    assert env.reset(seed=0)[1]["randomization"] == draws[0]  # the seed reproduces the airframe
    env.close()
