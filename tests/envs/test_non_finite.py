"""An env never hands a non-finite observation or reward to a learner: if the physics blows
up anyway, the step raises SimulationError naming the step, the vehicle state and the action."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.envs.guard import all_finite as _all_finite
from pyflyt_engine.errors import PyFlytError, SimulationError


def blow_up(env) -> None:
    """Fault injection: a velocity so large that the drag force overflows to inf."""
    base = env.unwrapped
    p.resetBaseVelocity(base.vehicle.body_id, [1e200, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=base.world.client)
    base.vehicle.state_changed()


@pytest.mark.parametrize("env_id", ["PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0"])
def test_a_physics_blow_up_raises_at_once_naming_step_state_and_action(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make(env_id)
    try:
        env.reset(seed=0)
        action = np.array([0.0, 0.0, 0.0, 0.3])
        for _ in range(3):
            env.step(action)
        blow_up(env)
        with pytest.raises(SimulationError) as info:
            env.step(action)
    finally:
        env.close()
    message = str(info.value)
    assert isinstance(info.value, PyFlytError)
    assert f"{env_id}: the simulation diverged at step 4 of the episode" in message
    assert "not finite: " in message and "reward (nan)" in message
    assert "Vehicle 'quadx_cf2x': position [nan, nan, nan] m" in message
    assert "last action [0.0, 0.0, 0.0, 0.3]" in message


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # 0 * inf, on purpose
def test_the_check_sees_every_entry_of_box_and_dict_observations():
    flat = np.arange(20, dtype=np.float64)
    assert _all_finite(0.0, flat) and _all_finite(-3.0, {"a": flat, "b": np.zeros((0, 3))})
    assert _all_finite(0.0, flat * 1e300)  # large but finite: no overflow in the check
    for bad in (np.nan, np.inf, -np.inf):
        for index in (0, 7, 19):
            broken = flat.copy()
            broken[index] = bad
            assert not _all_finite(0.0, broken)
            assert not _all_finite(0.0, {"attitude": flat, "target_deltas": broken.reshape(-1, 2)})
        assert not _all_finite(bad, flat)


def test_a_multi_agent_divergence_names_the_agent_and_its_vehicle():
    from pyflyt_engine.envs.multi_agent import ma_quadx_hover_v0
    from pyflyt_engine.errors import SimulationError

    env = ma_quadx_hover_v0.parallel_env(agents=2)
    try:
        observations, _ = env.reset(seed=0)
        broken = observations["uav_1"].copy()
        broken[2] = np.nan
        with pytest.raises(SimulationError) as raised:
            env._diverged(1, broken, 0.0, env.vehicles[1].state)
        message = str(raised.value)
        assert "ma_quadx_hover_v0: the simulation diverged at step 0 of the episode" in message
        assert "not finite: observation[2]" in message and "Agent 'uav_1', vehicle 'quadx_cf2x'" in message
    finally:
        env.close()
