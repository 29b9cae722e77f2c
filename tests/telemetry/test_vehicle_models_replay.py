"""The optional motor and battery models in episodes: randomised through ``randomize``, the
state of charge in the MCAP's auxiliary state, and ``replay --verify`` re-simulating them
exactly from the recorded airframe."""

from __future__ import annotations

import json
import warnings

import gymnasium
import numpy as np
import pytest

import pyflyt_engine.envs  # noqa: F401
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.telemetry import RecordEpisode, load_episode, read_mcap
from pyflyt_engine.telemetry.replay import verify

EXAMPLE = str(uav_dir() / "examples" / "quadx_cf2x_battery.yaml")
DRAWS = {
    "battery_charge": {"distribution": "uniform", "low": 0.3, "high": 1.0},
    "battery_resistance": {"distribution": "log_uniform", "low": 0.5, "high": 2.0},
    "battery_capacity": {"distribution": "uniform", "low": 0.9, "high": 1.1},
    "motor_rotor_drag": {"distribution": "uniform", "low": 0.5, "high": 1.5},
    "motor_tau": {"distribution": "uniform", "low": 0.8, "high": 1.2},
}


def make(**kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make("PyFlyt/QuadX-Hover-v0", **kwargs)


def test_the_drawn_models_are_the_ones_that_fly():
    env = make(uav=EXAMPLE, randomize=DRAWS)
    _, info = env.reset(seed=3)
    drawn = info["randomization"]
    vehicle = env.unwrapped.world.vehicles[0]
    nominal = vehicle.parts
    assert vehicle.battery.charge == drawn["battery_charge"]
    assert vehicle.battery.params.internal_resistance == pytest.approx(0.15 * drawn["battery_resistance"], rel=1e-15)
    assert vehicle.battery.params.capacity_mah == pytest.approx(250.0 * drawn["battery_capacity"], rel=1e-15)
    motors = vehicle.actuators.motors.params
    np.testing.assert_allclose(motors.rotor_drag, nominal.motors.rotor_drag * drawn["motor_rotor_drag"], rtol=1e-15)
    np.testing.assert_allclose(motors.tau_fall, nominal.motors.tau_fall * drawn["motor_tau"], rtol=1e-15)
    np.testing.assert_allclose(motors.tau, nominal.motors.tau * drawn["motor_tau"], rtol=1e-15)
    env.close()


@pytest.mark.parametrize(
    ("randomize", "message"),
    [
        ({"battery_charge": {"distribution": "uniform", "low": 0.0, "high": 1.0}}, "battery_charge.*stay in"),
        ({"battery_charge": {"distribution": "uniform", "low": 0.5, "high": 1.2}}, "battery_charge.*stay in"),
        ({"battery_resistance": {"distribution": "uniform", "low": 0.0, "high": 1.2}}, "lower bound low > 0"),
    ],
)
def test_bad_model_randomisation_is_refused(randomize, message):
    with pytest.raises(ConfigError, match=message):
        make(uav=EXAMPLE, randomize=randomize)


def test_randomising_a_model_the_airframe_lacks_is_refused():
    with pytest.raises(ConfigError, match="randomize.battery_charge: the airframe has no 'battery'"):
        make(randomize={"battery_charge": {"distribution": "uniform", "low": 0.5, "high": 1.0}})
    with pytest.raises(ConfigError, match="randomize.motor_rotor_drag: the airframe has no 'motors.rotor_drag'"):
        make(randomize={"motor_rotor_drag": {"distribution": "uniform", "low": 0.5, "high": 1.0}})


def test_episodes_with_the_models_record_the_charge_and_verify_exactly(tmp_path):
    env = RecordEpisode(make(uav=EXAMPLE, randomize=DRAWS, wind="dryden_light"), tmp_path)
    charges = []
    for episode in range(2):
        env.reset(seed=11 if episode == 0 else None)
        vehicle = env.unwrapped.world.vehicles[0]
        for _ in range(30):
            *_, terminated, truncated, _ = env.step(np.array([0.02, -0.02, 0.0, 0.2]))
            if terminated or truncated:
                break
        charges.append(vehicle.battery.charge)
    env.close()
    for path, charge in zip(env.paths, charges):
        episode = load_episode(path)
        spec = json.loads(episode.contents.require_metadata("env")["uav_specs"])[0]
        assert spec["battery"]["capacity_mah"] == 250.0 and spec["motors"]["rotor_drag"] == 3.935e-3
        assert episode.vehicles[0].aux[-1][-1] == charge  # the state of charge, last in the auxiliary state
        assert read_mcap(path).on("/uav/0/state")[-1].data["aux"][-1] == charge
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0, result
