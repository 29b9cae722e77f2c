"""Features of the batched backend together: what each adds keeps its place and its meaning
when another is on (the aux state's order, the refusals between them)."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.paths import uav_dir

EXAMPLE = str(uav_dir() / "examples" / "quadx_cf2x_battery.yaml")


def test_a_battery_under_noisy_sensors_keeps_the_pybullet_envs_observation_layout():
    """The pack's charge closes the aux state and the position fix's flag follows it, in both
    backends: at a reset the charge is the pack's initial one and the flag 0 or 1."""
    cfg = load_env_config("quadx_hover_sensors").with_overrides(uav=EXAMPLE)
    pb = UAVEnv(cfg)
    try:
        pb_obs, _ = pb.reset(seed=0)
        charge0 = pb.vehicles[0].aux_values()[-1]
    finally:
        pb.close()
    be = BatchedUAVEnv(cfg.with_overrides(backend="batched"), num_envs=2)
    obs, _ = be.reset(seed=0)
    assert obs.shape[1] == np.asarray(pb_obs).size
    for row in (np.asarray(pb_obs, dtype=np.float64), obs[0], obs[1]):
        assert row[-2] == pytest.approx(charge0, abs=1e-12) and 0.0 < charge0 <= 1.0
        assert row[-1] in (0.0, 1.0)
    for _ in range(20):  # the pack drains under load: its column, not the flag's, moves
        obs = be.step(np.tile([0.0, 0.0, 0.0, 0.6], (2, 1)))[0]
    assert np.all(obs[:, -2] < charge0) and np.all(np.isin(obs[:, -1], (0.0, 1.0)))


@pytest.mark.parametrize("name", ["motor_kf", "motor_kt", "motor_tau", "motor_rotor_drag"])
def test_randomised_motor_factors_on_modelled_motors_set_the_modelled_rows(name):
    """An airframe with the optional models and a pack flies the modelled motors' rows: a motor
    factor drawn there changes those rows per env (their agreement with the PyBullet engine:
    tests/batched/test_motor_models.py), not only the static motors' ones."""
    entry = {"distribution": "uniform", "low": 0.7, "high": 1.3}
    cfg = load_env_config("quadx_hover").with_overrides(uav=EXAMPLE, randomize={name: entry}, backend="batched")
    env = BatchedUAVEnv(cfg, num_envs=2)
    nominal = env._motor_model.copy()
    env.reset(seed=0)
    assert not np.array_equal(env._motor_model, nominal)
    assert not np.array_equal(env._motor_model[0], env._motor_model[1])


def test_every_per_env_parameter_row_is_c_contiguous():
    """The compiled laws read the parameters row by row: a column-major copy (``np.array`` of a
    broadcast view keeps its strides) made every step of the static path ~50 % slower."""
    cfg = load_env_config("quadx_hover").with_overrides(
        backend="batched", randomize={"mass": {"distribution": "uniform", "low": 0.9, "high": 1.1}}
    )
    env = BatchedUAVEnv(cfg, num_envs=8)
    rows = {
        name: value
        for name, value in vars(env).items()
        if isinstance(value, np.ndarray) and value.ndim >= 2 and value.shape[0] == 8
    }
    assert {"_inertia", "_control_inertia", "_lag", "_columns", "_rotors", "_drag_factors", "_mixer_rows"} <= set(rows)
    not_c = [name for name, value in rows.items() if not value.flags.c_contiguous]
    assert not not_c, not_c
