"""Booster component against oracles from the paper's equations and hand calculations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.components.booster import (
    BoosterParams,
    BoosterState,
    Boosters,
    initial_booster_state,
    tank_mass_properties,
)
from pyflyt_engine.components.noise import NoiseSource

DT = 1.0 / 240.0


def make_params(n: int = 1, **overrides) -> BoosterParams:
    """1:10 Falcon 9 booster (REFERENCE.md, Rocket), thrust along +Z, n copies."""
    kwargs = dict(
        positions=np.tile([0.0, 0.0, -1.0], (n, 1)),
        thrust_axes=np.tile([0.0, 0.0, 1.0], (n, 1)),
        fuel_tank_positions=np.tile([0.0, 0.0, 2.0], (n, 1)),
        total_fuel=410.9,
        max_fuel_rate=1.451,
        inertia_full=np.tile([1678.0, 1678.0, 7.01], (n, 1)),
        min_thrust=2966.7,
        max_thrust=7607.0,
        reignitable=True,
        tau=0.01,
        noise_ratio=0.0,
    )
    kwargs.update(overrides)
    return BoosterParams(**kwargs)


def group(params, state, seed=0) -> Boosters:
    """The boosters as the vehicle steps them, in ``state``, noise drawn from a seeded generator."""
    boosters = Boosters(params, DT, NoiseSource(np.random.default_rng(seed)), 1.0)
    boosters.state = state
    return boosters


def step(boosters, ignition, throttle):
    """One physics step of the group with these commands: (new state, per-booster thrust [N], wrench)."""
    n = boosters.params.n
    boosters.ignition = np.broadcast_to(np.asarray(ignition, dtype=bool), (n,)).tolist()
    boosters.throttle = np.broadcast_to(np.asarray(throttle, dtype=np.float64), (n,)).tolist()
    wrench = boosters.step()
    thrust = np.array(boosters.duty) * boosters.params.max_thrust  # T = duty * max_thrust
    return boosters.state, thrust, wrench


def booster_step(params, state, ignition, throttle):
    """One physics step from ``state`` without noise: (new state, per-booster thrust [N])."""
    new, thrust, _ = step(group(params, state), ignition, throttle)
    return new, thrust


def run(params, state, ignition, throttle, steps, seed=0):
    """Step ``steps`` times with constant commands; return final state and thrust history."""
    boosters = group(params, state, seed)
    thrusts = np.empty((steps, params.n))
    for k in range(steps):
        state, thrusts[k], _ = step(boosters, ignition, throttle)
    return state, thrusts


def test_fuel_runs_out_after_total_fuel_over_max_rate():
    # Burn time 4.109 s at full duty (total_fuel 5.962 kg is the same ratio scaled down).
    params = make_params(total_fuel=1.451 * 4.109)
    expected_burn_time = 4.109
    state = initial_booster_state(params)
    steps_lit = 0
    for _ in range(int(2 * expected_burn_time / DT)):
        state, thrust = booster_step(params, state, True, 1.0)
        if thrust[0] > 0.0:
            steps_lit += 1
        if state.fuel[0] == 0.0:
            break
    assert state.fuel[0] == 0.0
    assert steps_lit * DT == pytest.approx(expected_burn_time, rel=0.01)
    # Once empty, the booster stays dark even though it is commanded on.
    state, thrust = booster_step(params, state, True, 1.0)
    assert thrust[0] == 0.0 and state.fuel[0] == 0.0


def test_non_reignitable_booster_stays_lit():
    params = make_params(reignitable=False)
    state = initial_booster_state(params)
    state, _ = booster_step(params, state, True, 0.5)
    assert state.ignited[0]
    state, thrusts = run(params, state, False, 0.5, 120)
    assert state.ignited[0]
    assert np.all(thrusts > 0.0)


def test_reignitable_booster_goes_out_and_relights():
    params = make_params(reignitable=True)
    state = initial_booster_state(params)
    state, thrusts = run(params, state, True, 0.5, 120)
    assert state.ignited[0] and thrusts[-1, 0] > 0.0
    state, thrusts = run(params, state, False, 0.5, 10)
    assert not state.ignited[0]
    assert np.all(thrusts == 0.0) and state.duty[0] == 0.0
    fuel_when_out = state.fuel[0]
    state, thrusts = run(params, state, False, 0.5, 10)
    assert state.fuel[0] == fuel_when_out  # no burn while out
    state, thrusts = run(params, state, True, 0.5, 240)
    assert state.ignited[0]
    expected = 2966.7 + 0.5 * (7607.0 - 2966.7)
    assert thrusts[-1, 0] == pytest.approx(expected, rel=1e-9)


def test_mixed_reignitability_is_per_booster():
    params = make_params(n=2, reignitable=[False, True])
    state = initial_booster_state(params, ignited=True)
    state, thrusts = booster_step(params, state, [False, False], 1.0)
    assert state.ignited.tolist() == [True, False]
    assert thrusts[0] > 0.0 and thrusts[1] == 0.0


def test_no_thrust_without_fuel():
    params = make_params(n=2, reignitable=False)
    state = initial_booster_state(params, fuel_fraction=0.0, ignited=True)
    state = BoosterState(ignited=state.ignited, duty=np.array([1.0, 0.7]), fuel=state.fuel)
    state, thrusts = run(params, state, True, 1.0, 50)
    assert np.all(thrusts == 0.0)
    assert np.all(state.fuel == 0.0) and np.all(state.duty == 0.0)


@pytest.mark.parametrize("fraction", [0.0, 0.01, 0.25, 0.5, 0.9, 1.0])
def test_tank_mass_and_inertia_scale_linearly(fraction):
    params = make_params(n=2, total_fuel=[410.9, 20.0], inertia_full=[[1678.0, 1678.0, 7.01], [3.0, 4.0, 5.0]])
    fuel = fraction * np.array([410.9, 20.0])
    mass, inertia = tank_mass_properties(params, fuel)
    np.testing.assert_allclose(mass, [fraction * 410.9, fraction * 20.0], rtol=1e-12)
    np.testing.assert_allclose(inertia[0], [fraction * 1678.0, fraction * 1678.0, fraction * 7.01], rtol=1e-12)
    np.testing.assert_allclose(inertia[1], [fraction * 3.0, fraction * 4.0, fraction * 5.0], rtol=1e-12)


def test_burning_reduces_tank_mass_by_burnt_fuel():
    params = make_params()
    state = initial_booster_state(params, ignited=True)
    state, thrusts = run(params, state, True, 1.0, 240)
    burnt = np.sum(thrusts[:, 0] / 7607.0) * 1.451 * DT  # duty = T / T_max
    mass, _ = tank_mass_properties(params, state.fuel)
    assert mass[0] == pytest.approx(410.9 - burnt, rel=1e-12)


@pytest.mark.parametrize("throttle, expected", [(0.0, 2966.7), (1.0, 7607.0), (-3.0, 2966.7), (5.0, 7607.0)])
def test_steady_thrust_spans_min_to_max(throttle, expected):
    params = make_params()
    state = initial_booster_state(params)
    _, thrusts = run(params, state, True, throttle, 240)  # 1 s = 100 tau
    assert thrusts[-1, 0] == pytest.approx(expected, rel=1e-9)


def test_min_duty_is_min_over_max_thrust():
    params = make_params()
    assert params.min_duty[0] == pytest.approx(2966.7 / 7607.0)


def test_noise_is_zero_mean_and_independent_per_booster():
    params = make_params(n=2, noise_ratio=0.01, total_fuel=1.0e6)
    steps = 10_000
    throttle = 0.5
    noiseless = 2966.7 + throttle * (7607.0 - 2966.7)
    # Start at the noiseless steady state so every sample is comparable.
    state = BoosterState(ignited=np.ones(2, bool), duty=np.full(2, noiseless / 7607.0), fuel=np.full(2, 1.0e6))
    _, thrusts = run(params, state, True, throttle, steps, seed=0)
    np.testing.assert_allclose(thrusts.mean(axis=0), noiseless, rtol=0.005)
    assert np.all(thrusts.std(axis=0) > 0.001 * noiseless)  # the noise is actually applied
    corr = np.corrcoef(thrusts[:, 0], thrusts[:, 1])[0, 1]
    assert abs(corr) < 0.05


def test_noisy_duty_is_clipped_to_zero_one():
    params = make_params(n=2, noise_ratio=0.5)
    _, thrusts = run(params, initial_booster_state(params), True, 1.0, 500, seed=1)
    assert thrusts.max() == 7607.0  # upward noise at full throttle saturates at T_max
    assert thrusts.min() >= 0.0


def test_duty_reaches_63_percent_of_step_after_tau():
    tau = 10 * DT
    params = make_params(tau=tau, min_thrust=0.0)
    state = initial_booster_state(params)
    _, thrusts = run(params, state, True, 1.0, 10)
    assert thrusts[-1, 0] / 7607.0 == pytest.approx(1.0 - math.exp(-1.0), abs=1e-9)


def loads(params, turned=None):
    """The group's wrench after one step at full throttle, no lag, no minimum thrust (each
    booster pushes its max_thrust), axes turned to ``turned`` first (as a gimbal does)."""
    boosters = group(params, initial_booster_state(params))
    for i, axis in enumerate(turned or []):
        boosters.turn(i, axis)
    _, _, wrench = step(boosters, True, 1.0)
    return np.array(wrench[:3]), np.array(wrench[3:])


def test_loads_equal_hand_computed_cross_product():
    # Booster 0 at (1, 2, -3) m thrusting along +Z at 100 N; booster 1 at (0, -1, 0) m
    # thrusting along +X at 50 N.
    axis1 = np.array([1.0, 0.0, 0.0])
    params = make_params(
        n=2,
        positions=[[1.0, 2.0, -3.0], [0.0, -1.0, 0.0]],
        thrust_axes=[[0.0, 0.0, 1.0], axis1],
        max_thrust=[100.0, 50.0],
        min_thrust=0.0,
        tau=0.0,
    )
    force, torque = loads(params)
    # F0 = (0, 0, 100): r x F = (2*100 - (-3)*0, (-3)*0 - 1*100, 0) = (200, -100, 0)
    # F1 = (50, 0, 0):  r x F = ((-1)*0 - 0*0, 0*50 - 0*0, 0*0 - (-1)*50) = (0, 0, 50)
    np.testing.assert_allclose(force, [50.0, 0.0, 100.0], atol=1e-12)
    np.testing.assert_allclose(torque, [200.0, -100.0, 50.0], atol=1e-12)


def test_loads_with_overridden_axes():
    params = make_params(positions=[[0.0, 0.0, -2.0]], max_thrust=10.0, min_thrust=0.0, tau=0.0)
    s = math.sin(0.1)
    c = math.cos(0.1)
    force, torque = loads(params, turned=[(s, 0.0, c)])  # tilted toward +X
    np.testing.assert_allclose(force, [10 * s, 0.0, 10 * c], atol=1e-12)
    # r = (0, 0, -2), F = (10s, 0, 10c): r x F = (0*10c - (-2)*0, (-2)*10s - 0*10c, 0) = (0, -20s, 0)
    np.testing.assert_allclose(torque, [0.0, -20 * s, 0.0], atol=1e-12)


@pytest.mark.parametrize(
    "overrides, message",
    [
        (dict(total_fuel=0.0), "total_fuel must be > 0"),
        (dict(max_thrust=-1.0), "max_thrust must be > 0"),
        (dict(max_fuel_rate=0.0), "max_fuel_rate must be > 0"),
        (dict(min_thrust=-1.0), "min_thrust must be >= 0"),
        (dict(min_thrust=8000.0), "min_thrust must be <= max_thrust"),
        (dict(thrust_axes=[[0.0, 0.0, 2.0]]), "thrust_axes must be unit vectors"),
        (dict(tau=-0.1), "tau must be >= 0"),
        (dict(noise_ratio=-0.01), "noise_ratio must be >= 0"),
        (dict(total_fuel=[1.0, 2.0]), r"total_fuel has shape \(2,\), expected \(1,\)"),
        (dict(fuel_tank_positions=np.zeros((2, 3))), r"fuel_tank_positions has shape \(2, 3\)"),
    ],
)
def test_validation_errors(overrides, message):
    with pytest.raises(ValueError, match=message):
        make_params(**overrides)


def test_thrust_axis_message_says_normalise():
    with pytest.raises(ValueError, match="normalise"):
        make_params(thrust_axes=[[1.0, 1.0, 0.0]])


def test_params_are_read_only_float_arrays():
    params = make_params(n=3)
    assert params.total_fuel.shape == (3,) and params.total_fuel.dtype == np.float64
    assert params.reignitable.dtype == bool
    with pytest.raises(ValueError):
        params.max_thrust[0] = 1.0
