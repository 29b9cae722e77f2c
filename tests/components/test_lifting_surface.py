"""Lifting surface against hand calculations of the Khan & Nahon equations (REFERENCE.md).

Oracles are written out here from REFERENCE.md with ``math``; the module's own helpers
are never used to build an expected value.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from pyflyt_engine.components.lifting_surface import (
    LiftingSurfaceParams,
    coefficient_curves,
    flap_deflection,
    flap_shifted_angles,
    plot_coefficient_curves,
    surface_coefficients,
    surface_wrench,
)
from pyflyt_engine.components.lag import lag_coefficient

DEG = math.pi / 180.0
RHO = 1.225  # kg/m^3, ISA sea level

# Fixed-wing surfaces from REFERENCE.md ("Fixedwing"): C_La,2D 6.283, eta 0.65, C_D0 0.01.
MAIN_WING = dict(
    position=[0.0, 0.0, 0.0],
    chord_axis=[1.0, 0.0, 0.0],
    normal_axis=[0.0, 0.0, 1.0],
    chord=0.3,
    span=1.6,
    flap_to_chord=0.3,
    alpha_0_base=-2.0 * DEG,
    stall_pos_base=14.0 * DEG,
    stall_neg_base=-9.0 * DEG,
    cd_0=0.01,
    cl_alpha_2d=6.283,
    eta=0.65,
    max_deflection=0.0,
    tau=0.05,
)
AILERON = dict(MAIN_WING, span=0.3, max_deflection=30.0 * DEG)
HORIZONTAL_TAIL = dict(
    MAIN_WING,
    chord=0.2,
    span=0.625,
    alpha_0_base=0.0,
    stall_pos_base=9.0 * DEG,
    stall_neg_base=-9.0 * DEG,
    max_deflection=20.0 * DEG,
)


def make(spec: dict, **overrides) -> LiftingSurfaceParams:
    return LiftingSurfaceParams(**dict(spec, **overrides))


def surface_loads(params, deflection, velocity, omega, air_density=RHO):
    """``surface_wrench`` (what the simulator runs) as (force, torque) arrays."""
    wrench = surface_wrench(params.constants, deflection, *map(float, velocity), *map(float, omega), air_density)
    return np.array(wrench[:3]), np.array(wrench[3:])


def flap_step(params, deflection, command, dt):
    """``flap_deflection`` (what the simulator runs) with the flap's lag coefficient for ``dt``."""
    return flap_deflection(deflection, command, float(lag_coefficient(dt, params.tau)), params.max_deflection)


def by_hand(spec: dict, alpha: float, delta: float) -> tuple[float, float, float]:
    """REFERENCE.md "Lifting surface", step by step, for |alpha| <= 90 deg."""
    c, b, cf = spec["chord"], spec["span"], spec["flap_to_chord"]
    aspect = b / c
    cla = spec["cl_alpha_2d"] * aspect / (aspect + 2.0 * (aspect + 4.0) / (aspect + 2.0))
    theta_f = math.acos(2.0 * cf - 1.0)
    tau_f = 1.0 - (theta_f - math.sin(theta_f)) / math.pi
    d_cl = cla * tau_f * spec["eta"] * delta
    d_cl_max = cf * d_cl
    cl_max_pos = cla * (spec["stall_pos_base"] - spec["alpha_0_base"]) + d_cl_max
    cl_max_neg = cla * (spec["stall_neg_base"] - spec["alpha_0_base"]) + d_cl_max
    alpha_0 = spec["alpha_0_base"] - d_cl / cla
    stall_pos = alpha_0 + cl_max_pos / cla
    stall_neg = alpha_0 + cl_max_neg / cla
    if stall_neg < alpha < stall_pos:
        cl = cla * (alpha - alpha_0)
        alpha_i = cl / (math.pi * aspect)
        alpha_eff = alpha - alpha_0 - alpha_i
        ct = spec["cd_0"] * math.cos(alpha_eff)
        cn = (cl + ct * math.sin(alpha_eff)) / math.cos(alpha_eff)
        cd = cn * math.sin(alpha_eff) + ct * math.cos(alpha_eff)
        cm = -cn * (0.25 - 0.175 * (1.0 - 2.0 * alpha_eff / math.pi))
        return cl, cd, cm
    stall = stall_pos if alpha >= stall_pos else stall_neg
    edge = math.copysign(math.pi / 2.0, stall)  # +-90 deg, where alpha_i reaches 0
    alpha_i_stall = cla * (stall - alpha_0) / (math.pi * aspect)
    alpha_i = alpha_i_stall * (edge - alpha) / (edge - stall)
    alpha_eff = alpha - alpha_0 - alpha_i
    cd_90 = -0.0426 * delta**2 + 0.21 * delta + 1.98
    cn = (
        cd_90
        * math.sin(alpha_eff)
        * (1.0 / (0.56 + 0.44 * abs(math.sin(alpha_eff))) - 0.41 * (1.0 - math.exp(-17.0 / aspect)))
    )
    ct = 0.5 * spec["cd_0"] * math.cos(alpha_eff)
    cl = cn * math.cos(alpha_eff) - ct * math.sin(alpha_eff)
    cd = cn * math.sin(alpha_eff) + ct * math.cos(alpha_eff)
    cm = -cn * (0.25 - 0.175 * (1.0 - 2.0 * abs(alpha_eff) / math.pi))
    return cl, cd, cm


# --------------------------------------------------------------------------- profile


def test_derived_quantities_by_hand():
    wing = make(MAIN_WING)
    assert wing.area == pytest.approx(0.48)
    assert wing.aspect_ratio == pytest.approx(16.0 / 3.0)
    # 6.283 * (16/3) / (16/3 + 2 (28/3) / (22/3)) = 6.283 * 0.6769231
    assert wing.cl_alpha == pytest.approx(4.2531077, rel=1e-7)
    # theta_f = arccos(-0.4) = 1.9823132, tau_f = 1 - (1.9823132 - 0.9165151) / pi
    assert wing.flap_effectiveness == pytest.approx(0.6607459, rel=1e-6)
    np.testing.assert_allclose(wing.span_axis, [0.0, -1.0, 0.0])  # chord x normal = X x Z


def test_attached_flow_at_4_deg_matches_hand_numbers():
    # alpha - alpha_0 = 6 deg = 0.1047198 rad; C_L = 4.2531077 * 0.1047198 = 0.445384
    # alpha_i = 0.445384 / (pi 16/3) = 0.0265818; alpha_eff = 0.0781380
    # C_N = (0.445384 + 0.0099695 * 0.0780585) / 0.9969490 = 0.447527
    # C_D = 0.447527 * 0.0780585 + 0.0099695 * 0.9969490 = 0.044872
    # C_M = -0.447527 * (0.25 - 0.175 * (1 - 2 * 0.0781380 / pi)) = -0.037460
    cl, cd, cm = surface_coefficients(make(MAIN_WING), 4.0 * DEG, 0.0)
    assert cl == pytest.approx(0.445384, abs=2e-6)
    assert cd == pytest.approx(0.044872, abs=2e-6)
    assert cm == pytest.approx(-0.037460, abs=2e-6)


@pytest.mark.parametrize(
    "spec, alpha_deg, delta_deg",
    [
        (MAIN_WING, 4.0, 0.0),  # attached
        (MAIN_WING, 13.9, 0.0),  # just below positive stall
        (MAIN_WING, 14.1, 0.0),  # just above positive stall
        (MAIN_WING, 40.0, 0.0),  # deep post-stall
        (MAIN_WING, 89.0, 0.0),
        (MAIN_WING, -8.9, 0.0),  # just above negative stall
        (MAIN_WING, -9.5, 0.0),  # negative stall
        (MAIN_WING, -50.0, 0.0),
        (AILERON, 4.0, 10.0),  # attached with flap
        (AILERON, 3.0, 20.0),  # flap lowers stall+ to 14 - 0.7*0.6607*0.65*20 = 7.99 deg
        (AILERON, 9.0, 20.0),  # ... so 9 deg is stalled
        (AILERON, 40.0, -25.0),
        (AILERON, -60.0, 30.0),
        (HORIZONTAL_TAIL, -12.0, 15.0),
    ],
)
def test_coefficients_equal_hand_calculation(spec, alpha_deg, delta_deg):
    expected = by_hand(spec, alpha_deg * DEG, delta_deg * DEG)
    got = surface_coefficients(make(spec), alpha_deg * DEG, delta_deg * DEG)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)


def test_zero_lift_at_alpha_0_and_at_flap_shifted_alpha_0():
    wing = make(MAIN_WING)
    assert surface_coefficients(wing, -2.0 * DEG, 0.0)[0] == pytest.approx(0.0, abs=1e-12)

    aileron = make(AILERON)
    delta = 10.0 * DEG
    theta_f = math.acos(2.0 * 0.3 - 1.0)
    tau_f = 1.0 - (theta_f - math.sin(theta_f)) / math.pi
    alpha_0 = -2.0 * DEG - tau_f * 0.65 * delta  # alpha_0,base - dC_L / C_La
    assert alpha_0 == pytest.approx(-6.2949 * DEG, abs=1e-4 * DEG)
    assert surface_coefficients(aileron, alpha_0, delta)[0] == pytest.approx(0.0, abs=1e-12)
    assert surface_coefficients(aileron, -2.0 * DEG, delta)[0] > 0.1  # old alpha_0 now lifts
    assert flap_shifted_angles(aileron, delta)[0] == pytest.approx(alpha_0, abs=1e-15)


def test_positive_deflection_lowers_alpha_0_and_adds_lift():
    aileron = make(AILERON)
    alpha_0_up, _, _ = flap_shifted_angles(aileron, -10.0 * DEG)
    alpha_0_down, _, _ = flap_shifted_angles(aileron, 10.0 * DEG)
    assert alpha_0_down < -2.0 * DEG < alpha_0_up
    for alpha in (-4.0 * DEG, 0.0, 4.0 * DEG):
        lifts = [surface_coefficients(aileron, alpha, d * DEG)[0] for d in (-10.0, 0.0, 10.0)]
        assert lifts[0] < lifts[1] < lifts[2]


def test_symmetric_surface_has_odd_lift_and_even_drag_over_full_circle():
    tail = make(HORIZONTAL_TAIL)
    alpha = np.linspace(0.0, math.pi, 2001)
    cl_pos, cd_pos, _ = surface_coefficients(tail, alpha, 0.0)
    cl_neg, cd_neg, _ = surface_coefficients(tail, -alpha, 0.0)
    np.testing.assert_allclose(cl_neg, -cl_pos, atol=1e-12)
    np.testing.assert_allclose(cd_neg, cd_pos, atol=1e-12)
    assert surface_coefficients(tail, 0.0, 0.0)[0] == 0.0


@pytest.mark.parametrize(
    "spec, delta_deg", [(MAIN_WING, 0.0), (AILERON, 30.0), (AILERON, -30.0), (HORIZONTAL_TAIL, 20.0)]
)
def test_curves_continuous_except_at_stall_and_bounded(spec, delta_deg):
    """Asserted: on a 0.01 deg grid over -180..180 deg no neighbouring samples differ by
    more than 0.005 in C_L, C_D or C_M, except across the two stall angles and their
    reverse-flow images (stall -+ 180 deg), where the model stalls abruptly.  The slope
    of any coefficient is below ~5 /rad, i.e. < 1e-3 per grid step, so a real jump of
    0.005 anywhere else (at +-90 or +-180 deg, say) fails the test.
    """
    params = make(spec)
    delta = delta_deg * DEG
    _, stall_pos, stall_neg = flap_shifted_angles(params, delta)
    alpha = np.linspace(-math.pi, math.pi, 36001)
    coeffs = surface_coefficients(params, alpha, delta)
    mid = 0.5 * (alpha[1:] + alpha[:-1])
    step = alpha[1] - alpha[0]
    breaks = [stall_pos, stall_neg]
    breaks += [b - math.copysign(math.pi, b) for b in breaks]  # reverse-flow images
    near_break = np.zeros(mid.shape, dtype=bool)
    for b in breaks:
        near_break |= np.abs(mid - b) <= step
    for name, values in zip(("cl", "cd", "cm"), coeffs):
        assert np.all(np.isfinite(values)), name
        jumps = np.abs(np.diff(values))
        assert jumps[~near_break].max() < 5e-3, name
    cl, cd, cm = coeffs
    assert np.abs(cl).max() < 2.0 and 0.0 <= cd.min() and cd.max() < 2.0 and np.abs(cm).max() < 1.0


def test_stall_is_an_abrupt_loss_of_lift_of_the_hand_computed_size():
    """The REFERENCE.md equations are discontinuous at stall: the attached branch reaches
    C_L,max, the stalled branch starts from the flat-plate normal force.  Asserted: the
    one-sided limits equal the hand values of each branch, |C_L| falls across both
    stall angles, and the drop is below 1 (0.73 at +14 deg for the main wing)."""
    wing = make(MAIN_WING)
    eps = 1e-9
    for stall, sign in ((14.0 * DEG, 1.0), (-9.0 * DEG, -1.0)):
        inside = stall - sign * eps
        outside = stall + sign * eps
        cl_in = surface_coefficients(wing, inside, 0.0)[0]
        cl_out = surface_coefficients(wing, outside, 0.0)[0]
        assert cl_in == pytest.approx(by_hand(MAIN_WING, inside, 0.0)[0], rel=1e-12)
        assert cl_out == pytest.approx(by_hand(MAIN_WING, outside, 0.0)[0], rel=1e-12)
        assert sign * cl_out > 0.0 and abs(cl_out) < abs(cl_in)
        assert abs(cl_in - cl_out) < 1.0
    cl_max = 4.2531077 * 16.0 * DEG  # C_La (alpha_s+ - alpha_0)
    assert surface_coefficients(wing, 14.0 * DEG - eps, 0.0)[0] == pytest.approx(cl_max, rel=1e-6)


@pytest.mark.parametrize("spec, delta_deg", [(MAIN_WING, 0.0), (AILERON, 30.0), (AILERON, -17.0)])
def test_reverse_flow_is_continuous_at_90_and_180_deg(spec, delta_deg):
    params = make(spec)
    delta = delta_deg * DEG
    eps = 1e-9
    pairs = (
        (math.pi / 2 - eps, math.pi / 2 + eps),
        (-math.pi / 2 + eps, -math.pi / 2 - eps),
        (math.pi - eps, -math.pi + eps),
    )
    for left, right in pairs:
        np.testing.assert_allclose(
            surface_coefficients(params, left, delta), surface_coefficients(params, right, delta), atol=1e-7
        )


def test_reverse_flow_centre_of_pressure_lies_behind_the_aerodynamic_centre():
    # Air from the trailing edge at 6 deg below the chord: the normal force pushes toward
    # the normal side and acts near the rear quarter chord, so the moment is nose-down
    # with a lever between 0.3 c and 0.5 c behind the aerodynamic centre.
    tail = make(HORIZONTAL_TAIL)
    alpha = math.pi - 6.0 * DEG
    cl, cd, cm = surface_coefficients(tail, alpha, 0.0)
    cn_body = cl * math.cos(alpha) + cd * math.sin(alpha)  # force coefficient along normal_axis
    assert cn_body > 0.0 and cm < 0.0
    assert 0.3 < -cm / cn_body < 0.5


def test_alpha_is_periodic_and_array_shape_is_kept():
    wing = make(AILERON)
    alpha = np.array([[0.1, 2.0], [-3.0, 1.5]])
    cl, cd, cm = surface_coefficients(wing, alpha, 0.2)
    assert cl.shape == cd.shape == cm.shape == (2, 2)
    for i in np.ndindex(alpha.shape):
        np.testing.assert_allclose(
            (cl[i], cd[i], cm[i]), surface_coefficients(wing, float(alpha[i]) + 2 * math.pi, 0.2), atol=1e-12
        )


def test_array_and_scalar_paths_agree():
    aileron = make(AILERON)
    alpha = np.linspace(-math.pi, math.pi, 721)
    for delta in (-0.5, 0.0, 0.3):
        vec = np.stack(surface_coefficients(aileron, alpha, delta), axis=1)
        scal = np.array([surface_coefficients(aileron, float(a), delta) for a in alpha])
        np.testing.assert_allclose(vec, scal, rtol=1e-12, atol=1e-14)


def test_coefficient_curves_default_grid_and_plot(tmp_path):
    wing = make(AILERON)
    curves = coefficient_curves(wing)
    assert set(curves) == {"alpha", "cl", "cd", "cm"}
    assert curves["alpha"].shape == (1001,)
    assert curves["alpha"][0] == pytest.approx(-math.pi) and curves["alpha"][-1] == pytest.approx(math.pi)
    i = 500 + 11  # alpha = 11 * 0.36 deg = 3.96 deg
    np.testing.assert_allclose(
        (curves["cl"][i], curves["cd"][i], curves["cm"][i]), by_hand(AILERON, curves["alpha"][i], 0.0), rtol=1e-12
    )
    path = plot_coefficient_curves(wing, tmp_path / "aileron.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- flap


def test_flap_reaches_63_percent_after_tau():
    aileron = make(AILERON)  # tau = 0.05 s = 12 steps of 1/240 s
    dt = 1.0 / 240.0
    deflection = 0.0
    for _ in range(12):
        deflection = flap_step(aileron, deflection, 1.0, dt)
    assert deflection == pytest.approx((1.0 - math.exp(-1.0)) * 30.0 * DEG, rel=1e-9)
    assert deflection / (30.0 * DEG) == pytest.approx(0.632, abs=1e-3)


def test_flap_command_is_clipped_to_max_deflection():
    aileron = make(AILERON)
    for command, limit in ((5.0, 30.0 * DEG), (-3.0, -30.0 * DEG)):
        deflection, history = 0.0, []
        for _ in range(400):
            deflection = flap_step(aileron, deflection, command, 1.0 / 240.0)
            history.append(deflection)
        assert deflection == pytest.approx(limit, rel=1e-9)
        assert max(abs(h) for h in history) <= 30.0 * DEG + 1e-15


def test_flap_without_lag_jumps_to_target():
    aileron = make(AILERON, tau=0.0)
    assert flap_step(aileron, 0.1, -0.5, 1.0 / 240.0) == pytest.approx(-15.0 * DEG)


# --------------------------------------------------------------------------- loads


def velocity_at(alpha: float, speed: float) -> np.ndarray:
    """Body velocity of a wing (chord +X, normal +Z) that meets the air at ``alpha``."""
    return np.array([speed * math.cos(alpha), 0.0, -speed * math.sin(alpha)])


def test_loads_magnitudes_equal_coefficients_times_q_s():
    tail = make(HORIZONTAL_TAIL)
    alpha, speed, delta = 5.0 * DEG, 20.0, 4.0 * DEG
    force, torque = surface_loads(tail, delta, velocity_at(alpha, speed), np.zeros(3))
    cl, cd, cm = by_hand(HORIZONTAL_TAIL, alpha, delta)
    q = 0.5 * RHO * speed**2  # 245 Pa
    area = 0.2 * 0.625
    lift_dir = np.array([math.sin(alpha), 0.0, math.cos(alpha)])  # perpendicular, toward +Z
    drag_dir = -velocity_at(alpha, 1.0)
    assert force @ lift_dir == pytest.approx(cl * q * area, rel=1e-12)
    assert force @ drag_dir == pytest.approx(cd * q * area, rel=1e-12)
    assert force[1] == 0.0
    # At the body origin the torque is the pitching moment alone, about span = -Y.
    np.testing.assert_allclose(torque, [0.0, -cm * q * area * 0.2, 0.0], rtol=1e-12, atol=1e-15)
    assert cm < 0.0 and torque[1] > 0.0  # nose-down moment = positive torque about +Y (FLU)


def test_no_lift_at_zero_alpha_on_symmetric_surface():
    tail = make(HORIZONTAL_TAIL)
    force, torque = surface_loads(tail, 0.0, np.array([15.0, 0.0, 0.0]), np.zeros(3))
    q_s = 0.5 * RHO * 15.0**2 * 0.125
    np.testing.assert_allclose(force, [-0.01 * q_s, 0.0, 0.0], atol=1e-12)  # pure C_D0 drag
    np.testing.assert_allclose(torque, 0.0, atol=1e-12)


def test_lift_flips_with_alpha_sign():
    tail = make(HORIZONTAL_TAIL)
    up, _ = surface_loads(tail, 0.0, velocity_at(5.0 * DEG, 15.0), np.zeros(3))
    down, _ = surface_loads(tail, 0.0, velocity_at(-5.0 * DEG, 15.0), np.zeros(3))
    assert up[2] > 1.0 and down[2] < -1.0
    assert up[2] == pytest.approx(-down[2], rel=1e-12)
    assert up[0] == pytest.approx(down[0], rel=1e-12)


def test_loads_scale_with_speed_squared_and_air_density():
    wing = make(MAIN_WING, position=[0.1, 0.2, 0.05])
    v = velocity_at(7.0 * DEG, 10.0)
    f1, t1 = surface_loads(wing, 0.0, v, np.zeros(3))
    f3, t3 = surface_loads(wing, 0.0, 3.0 * v, np.zeros(3))
    np.testing.assert_allclose(f3, 9.0 * f1, rtol=1e-12)
    np.testing.assert_allclose(t3, 9.0 * t1, rtol=1e-12)
    f_thin, _ = surface_loads(wing, 0.0, v, np.zeros(3), air_density=RHO / 2.0)
    np.testing.assert_allclose(f_thin, 0.5 * f1, rtol=1e-12)


def test_offset_surface_adds_r_cross_f():
    tail = make(HORIZONTAL_TAIL)
    offset = make(HORIZONTAL_TAIL, position=[0.5, 0.0, 0.0])
    v = velocity_at(6.0 * DEG, 12.0)
    f0, t0 = surface_loads(tail, 0.0, v, np.zeros(3))
    f1, t1 = surface_loads(offset, 0.0, v, np.zeros(3))
    np.testing.assert_allclose(f1, f0, rtol=1e-12)
    # (0.5, 0, 0) x (Fx, 0, Fz) = (0, -0.5 Fz, 0): lift ahead of the origin pitches nose-up.
    np.testing.assert_allclose(t1, t0 + np.array([0.0, -0.5 * f0[2], 0.0]), rtol=1e-12, atol=1e-12)
    assert t1[1] < t0[1]


def test_body_rotation_alone_makes_airflow_at_the_surface():
    # Tail 1 m behind the origin, pitching at +2 rad/s about +Y (nose-down in FLU):
    # omega x r = (0, 2, 0) x (-1, 0, 0) = (0, 0, 2), so the tail moves up at 2 m/s.
    tail = make(HORIZONTAL_TAIL, position=[-1.0, 0.0, 0.0])
    force, torque = surface_loads(tail, 0.0, np.zeros(3), np.array([0.0, 2.0, 0.0]))
    same_f, same_t = surface_loads(tail, 0.0, np.array([0.0, 0.0, 2.0]), np.zeros(3))
    np.testing.assert_allclose(force, same_f, rtol=1e-12)
    np.testing.assert_allclose(torque, same_t, rtol=1e-12)
    # Flat plate broadside (alpha = -90 deg): the force opposes the motion and damps the pitch.
    assert force[2] < 0.0 and abs(force[0]) < 0.1 * abs(force[2])
    assert torque[1] < 0.0


def test_zero_airspeed_gives_zero_loads():
    wing = make(MAIN_WING, position=[0.3, 0.4, 0.0])
    force, torque = surface_loads(wing, 0.2, np.zeros(3), np.zeros(3))
    assert np.all(force == 0.0) and np.all(torque == 0.0)
    # Pure spanwise flow is outside the 2-D model: also no load, no NaN.
    force, torque = surface_loads(wing, 0.2, np.array([0.0, 5.0, 0.0]), np.zeros(3))
    assert np.all(force == 0.0) and np.all(torque == 0.0)


def test_spanwise_velocity_is_ignored():
    wing = make(MAIN_WING)
    v = velocity_at(4.0 * DEG, 10.0)
    f0, t0 = surface_loads(wing, 0.0, v, np.zeros(3))
    f1, t1 = surface_loads(wing, 0.0, v + np.array([0.0, 3.0, 0.0]), np.zeros(3))
    np.testing.assert_allclose(f1, f0, rtol=1e-12)
    np.testing.assert_allclose(t1, t0, rtol=1e-12)


def test_vertical_tail_pushes_against_sideslip():
    fin = make(HORIZONTAL_TAIL, normal_axis=[0.0, 1.0, 0.0], position=[-1.0, 0.0, 0.0])
    force, torque = surface_loads(fin, 0.0, np.array([15.0, 2.0, 0.0]), np.zeros(3))
    assert force[1] < 0.0  # body slides left (+Y): the fin is pushed right
    assert torque[2] > 0.0  # tail pushed right turns the nose left, into the airflow


def test_flying_backwards_gives_drag_forward_and_no_lift_on_symmetric_surface():
    tail = make(HORIZONTAL_TAIL)
    force, _ = surface_loads(tail, 0.0, np.array([-15.0, 0.0, 0.0]), np.zeros(3))
    q_s = 0.5 * RHO * 15.0**2 * 0.125
    np.testing.assert_allclose(force, [0.01 * q_s, 0.0, 0.0], atol=1e-12)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "overrides, message",
    [
        (dict(chord=0.0), "chord must be > 0"),
        (dict(span=-1.0), "span must be > 0"),
        (dict(chord_axis=[2.0, 0.0, 0.0]), "chord_axis must be a unit vector"),
        (dict(normal_axis=[0.0, 0.0, 0.9]), "normal_axis must be a unit vector"),
        (dict(normal_axis=[1.0, 0.0, 0.0]), "parallel"),
        (dict(normal_axis=[0.6, 0.0, 0.8]), "must be perpendicular"),
        (dict(stall_neg_base=-1.0 * DEG), "stall_neg_base < alpha_0_base < stall_pos_base"),
        (dict(stall_pos_base=-3.0 * DEG), "stall_neg_base < alpha_0_base < stall_pos_base"),
        (dict(flap_to_chord=1.2), "flap_to_chord must be in [0, 1]"),
        (dict(tau=-0.1), "tau must be >= 0"),
        (dict(max_deflection=-0.1), "max_deflection must be >= 0"),
        (dict(position=[0.0, 0.0]), "position must be 3 finite numbers"),
        (dict(stall_pos_base=80.0 * DEG, max_deflection=60.0 * DEG), "inside (-90 deg, 90 deg)"),
    ],
)
def test_invalid_parameters_are_rejected_with_a_useful_message(overrides, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        make(AILERON, **overrides)


def test_params_are_frozen_and_read_only():
    wing = make(MAIN_WING)
    with pytest.raises(AttributeError):
        wing.chord = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        wing.position[0] = 1.0
    assert wing.position.dtype == np.float64


def test_vehicle_step_sums_the_per_surface_loads():
    """``Surfaces.step`` is ``flap_deflection`` + ``surface_wrench`` per surface, summed in
    order: exactly (``==``) over attached, stalled and reverse flow, flaps moving and
    saturated, and zero airspeed."""
    from pyflyt_engine.components.lifting_surface import Surfaces

    params = [
        make(MAIN_WING),
        make(AILERON, position=[0.0, 0.5, 0.01]),
        make(AILERON, position=[0.0, -0.5, 0.01]),
        make(HORIZONTAL_TAIL, position=[-0.8, 0.0, 0.05]),
        make(HORIZONTAL_TAIL, position=[-0.8, 0.0, 0.15], normal_axis=[0.0, 1.0, 0.0]),
    ]
    dt = 1.0 / 240.0
    surfaces = Surfaces(params, dt)
    deflection = [0.0] * len(params)
    rng = np.random.default_rng(7)
    stalled = reverse = 0
    for step in range(600):
        command = rng.uniform(-1.5, 1.5, len(params)).tolist()
        surfaces.command = list(command)
        if step % 50 == 0:
            v, omega = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        else:
            scale = 2.0 if step % 3 else 20.0
            v = tuple(rng.normal(0.0, scale, 3).tolist())
            omega = tuple(rng.normal(0.0, 3.0, 3).tolist())
        got = surfaces.step((v, omega))
        expected = [0.0] * 6
        for i, p in enumerate(params):
            k = p.constants
            deflection[i] = flap_deflection(
                deflection[i], command[i], float(lag_coefficient(dt, p.tau)), k.max_deflection
            )
            wrench = surface_wrench(k, deflection[i], *v, *omega)
            expected = [a + b for a, b in zip(expected, wrench)]
        alpha = math.atan2(-v[2], v[0])  # the main wing's (at the origin, chord +X, normal +Z)
        stalled += abs(alpha) > 20.0 * DEG
        reverse += abs(alpha) > 100.0 * DEG
        assert surfaces.deflection == deflection
        assert list(got) == expected, step
    assert stalled > 100 and reverse > 50  # the flow regimes were all visited (main wing)
