"""The batched backend's compiled laws equal the PyBullet engine's scalar laws bit for bit.

Each law is written twice -- once in plain Python floats for the PyBullet engine (its speed
for one vehicle), once compiled for N vehicles -- so every pair is held together here on
random inputs, for every airframe the batched backend flies: motors, body drag, the rate
loop, the mixer (its clipping paths included), the lifting surfaces (the Khan & Nahon
profile, stalled and in reverse flow, the surface wrench, the flaps' step) and the channel
routing and autopilot of a fixed-wing, the state read-outs against PyBullet's own functions, and every
vector reward term and condition against its registered scalar form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.batched import kernels
from pyflyt_engine.batched.model import UnsupportedByBatched, batched_model
from pyflyt_engine.batched.terms import (
    COMPILED_CONDITIONS,
    COMPILED_TERMS,
    VECTOR_CONDITIONS,
    VECTOR_TERMS,
    BatchContext,
    BatchedReward,
)
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.components.drag import BodyDrag, DragParams
from pyflyt_engine.components import lifting_surface
from pyflyt_engine.components.lifting_surface import Surfaces
from pyflyt_engine.components.motor import Motors
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.components.routing import mix_rows
from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.control.mixer import flight_mixer
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.assembly import assemble
from pyflyt_engine.envs import rewards as r
from pyflyt_engine.envs.config import load_reward_preset
from pyflyt_engine.spec import available_uavs, load_uav_spec
from pyflyt_engine.state import KinematicState

DT, CONTROL_DT = 1 / 240, 1 / 120
#: the shipped multirotors and fixed-wings the batched backend flies
MULTIROTORS = ("hexacopter", "quadx_cf2x", "quadx_f450")
FIXEDWINGS = ("fixedwing", "flying_wing")
#: the shipped multirotors whose actuators the channels route beside the mixer: the tricopter
#: (its tail servo flown by the mixer), the quadplane (a pusher, channels, lifting surfaces)
ROUTED = ("quadplane", "tricopter")
#: every shipped airframe it flies (every other one is refused: test below)
FLOWN = tuple(sorted(MULTIROTORS + FIXEDWINGS + ROUTED))


def _accepted() -> list[str]:
    names = []
    for name in available_uavs():
        try:
            batched_model(load_uav_spec(name), DT, CONTROL_DT)
        except UnsupportedByBatched:
            continue
        names.append(name)
    return names


def test_the_backend_flies_exactly_the_airframes_it_claims():
    assert sorted(_accepted()) == list(FLOWN)


@pytest.mark.parametrize("name", sorted(set(available_uavs()) - set(FLOWN)))
def test_every_other_airframe_is_refused_by_name(name):
    with pytest.raises(UnsupportedByBatched) as info:
        batched_model(load_uav_spec(name), DT, CONTROL_DT)
    message = str(info.value)
    assert "env.backend=batched does not simulate" in message and "env.backend=pybullet" in message


def test_a_component_kind_it_does_not_compile_is_refused_by_its_name():
    """Propeller guards on the cf2x: a registered kind the compiled laws leave out is refused,
    not flown without its drag."""
    import yaml

    from pyflyt_engine.paths import uav_dir
    from pyflyt_engine.spec import parse_uav_spec

    data = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    data["prop_guards"] = {"radius": 0.025, "height": 0.01}
    with pytest.raises(UnsupportedByBatched, match="propeller guards"):
        batched_model(parse_uav_spec(data), DT, CONTROL_DT)


@pytest.mark.parametrize("name", FLOWN)
def test_motors_step_equals_the_motor_group(name):
    spec = load_uav_spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    group = Motors(parts.motors, DT, NoiseSource(np.random.default_rng(0)))
    rng = np.random.default_rng(1)
    n = parts.motors.count
    throttle = rng.uniform(-0.2, 1.0, n)
    group.throttle = throttle.tolist()
    for _ in range(50):
        command = rng.uniform(-1.0, 1.0, n)
        factors = 1.0 + 0.05 * rng.standard_normal(n)
        group.command = command.tolist()
        group._noise.next = lambda f=factors: tuple(f.tolist())  # the same draws for both
        group._noisy = True
        expected = group.step()
        got = kernels.motors_step(throttle, command, model.lag, factors, model.columns)
        assert got == expected
        assert throttle.tolist() == group.throttle


@pytest.mark.parametrize("name", FLOWN)
def test_drag_equals_body_drag(name):
    spec = load_uav_spec(name)
    drag = BodyDrag(DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping))
    model = batched_model(spec, DT, CONTROL_DT)
    rng = np.random.default_rng(2)
    for _ in range(100):
        v, w = rng.normal(0, 5, 3).tolist(), rng.normal(0, 10, 3).tolist()
        expected = drag.step((tuple(v), tuple(w)))
        kx, ky, kz = model.drag_factors.tolist()
        assert kernels.drag_wrench(*v, *w, kx, ky, kz, model.angular_damping) == expected


def _state(rng: np.random.Generator) -> KinematicState:
    three = lambda s: tuple(rng.normal(0, s, 3).tolist())  # noqa: E731
    return KinematicState(three(2.0), three(0.5), three(2.0), three(1.0), (0.0, 0.0, 0.0, 1.0), three(2.0), three(2.0))


@pytest.mark.parametrize("name", MULTIROTORS + ROUTED)
def test_rate_loop_and_mixer_equal_the_controller(name):
    """rates_thrust through the compiled rate loop and mixer gives the controller's throttles
    bit for bit, over setpoints wide enough to reach the mixer's yaw and thrust give-way paths
    (the tricopter's: its tilting tail's servo command too; the quadplane's: its four lift motors)."""
    spec = load_uav_spec(name)
    parts = assemble(spec)
    mixer = flight_mixer(parts)
    controller = MultirotorController(spec.control, parts.mass, np.diag(parts.inertia), mixer, CONTROL_DT)
    controller.set_mode(type(controller.mode)("rates_thrust", 0, ("p", "q", "r", "thrust"), ""))
    model = batched_model(spec, DT, CONTROL_DT)
    rng = np.random.default_rng(3)
    integral, previous = np.zeros(3), np.zeros(3)
    n = model.mixer_outputs
    out, scratch, torques = np.empty(n), np.empty((len(model.mixer_rows), 4)), np.empty(3)
    first = True
    slow = 0
    for _ in range(300):
        state = _state(rng)
        setpoint = [*rng.uniform(-6, 6, 3).tolist(), float(rng.uniform(0, 1.2))]
        expected = controller._rates_thrust(state, setpoint)
        rates = np.array(state.ang_vel)
        if first:
            previous[:] = rates
            first = False
        kernels.rate_loop(
            np.array(setpoint[:3]),
            rates,
            previous,
            integral,
            model.rate_gains,
            model.rate_derivative,
            model.control_inertia,
            model.gyro,
            CONTROL_DT,
            torques,
        )
        previous[:] = rates
        assert integral.tolist() == list(controller._rate_integral)
        thrust = setpoint[3] * model.max_collective
        kernels.mixer_outputs(thrust, *torques.tolist(), model.mixer_rows, model.lateral, scratch, out)
        assert out.tolist() == expected
        slow += any(v in (0.0, 1.0) for v in expected)
    assert slow > 30  # the clipping paths ran


@pytest.mark.parametrize("name", (*MULTIROTORS, "fixedwing"))
def test_the_ground_contact_height_is_the_airframes_lowest_point(name):
    """Upright, the collision features' lowest point is the spec's ``lowest_point()`` (from the
    centre of mass); rolled by 90 degrees about body x, the boxes' lowest edge along body y."""
    spec = load_uav_spec(name)
    model = batched_model(spec, DT, CONTROL_DT)
    com_z = float(assemble(spec).com[2])
    pos = np.array([0.0, 0.0, 2.0])
    upright = np.empty(9)
    kernels.rotation_rows(0.0, 0.0, 0.0, 1.0, upright)
    assert kernels.lowest_corner(pos, upright, model.corners) == pytest.approx(
        2.0 + spec.body.lowest_point() - com_z, abs=1e-12
    )
    # rolled 90 degrees about body x, body y points up: a point's height is its body y
    rolled = np.empty(9)
    kernels.rotation_rows(np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4), rolled)
    shapes = [s for s in spec.body.shapes if s.collision]
    assert all(s.type == "box" and s.rpy == (0.0, 0.0, 0.0) for s in shapes)  # the flown airframes' geometry
    com_y = float(assemble(spec).com[1])
    expected = 2.0 + min(s.position[1] - com_y - 0.5 * s.size[1] for s in shapes)
    assert kernels.lowest_corner(pos, rolled, model.corners) == pytest.approx(expected, abs=1e-12)


def _surface_inputs(rng: np.random.Generator, surface, count: int) -> list[tuple[float, float]]:
    """(alpha, deflection) pairs: uniform on [-pi, pi] and the flap's range, and the edges
    of the profile's branches (+-pi, +-pi/2, 0, the shifted stall angles themselves)."""
    pairs = []
    for _ in range(count):
        d = float(rng.uniform(-1.2, 1.2)) * surface.max_deflection
        pairs.append((float(rng.uniform(-math.pi, math.pi)), d))
        _, stall_pos, stall_neg = lifting_surface.flap_shifted_angles(surface, d)
        for alpha in (
            math.pi,
            -math.pi,
            0.5 * math.pi,
            -0.5 * math.pi,
            0.0,
            stall_pos,
            stall_neg,
            stall_pos - math.pi,
            stall_neg + math.pi,
        ):
            if -math.pi <= alpha <= math.pi:  # where atan2 puts it
                pairs.append((alpha, d))
    return pairs


@pytest.mark.parametrize("name", FIXEDWINGS)
def test_surface_coefficients_equal_the_profile(name):
    """Attached, stalled (both sides, at the stall angles themselves) and reverse flow: the
    compiled profile gives the scalar one's C_L, C_D, C_M bit for bit; on [-pi, pi], where
    ``atan2`` puts alpha, the scalar law's wrap ``math.remainder(alpha, 2 pi)`` is alpha."""
    model = batched_model(load_uav_spec(name), DT, CONTROL_DT)
    rng = np.random.default_rng(8)
    branches = set()
    for surface, row in zip(assemble(load_uav_spec(name)).surfaces, model.surfaces):
        k = surface.constants
        assert row.tolist() == list(k)
        for alpha, d in _surface_inputs(rng, surface, 200):
            assert math.remainder(alpha, 2.0 * math.pi) == alpha
            assert kernels.surface_coefficients(row, alpha, d) == lifting_surface._coefficients(k, alpha, d), (alpha, d)
            _, stall_pos, stall_neg = lifting_surface.flap_shifted_angles(surface, d)
            folded = alpha - math.pi if alpha > 0.5 * math.pi else alpha + math.pi if alpha < -0.5 * math.pi else alpha
            branches.add(
                (
                    "reverse" if abs(alpha) > 0.5 * math.pi else "forward",
                    "attached" if stall_neg < folded < stall_pos else "stalled",
                )
            )
    assert len(branches) == 4  # every branch of the profile ran


@pytest.mark.parametrize("name", FIXEDWINGS + ("quadplane",))
def test_surface_wrench_equals_the_surface_law(name):
    """Random air velocities (forward flight, side slip, reverse flow, spinning) and still
    air: the compiled surface wrench equals ``surface_wrench`` bit for bit."""
    model = batched_model(load_uav_spec(name), DT, CONTROL_DT)
    rng = np.random.default_rng(9)
    for surface, row in zip(assemble(load_uav_spec(name)).surfaces, model.surfaces):
        k = surface.constants
        for case in range(300):
            v = (rng.normal(0, 8, 3) + np.array([14.0 * (case % 2), 0.0, 0.0])).tolist()
            w = rng.normal(0, 3, 3).tolist()
            d = float(rng.uniform(-1.0, 1.0)) * surface.max_deflection
            expected = lifting_surface.surface_wrench(k, d, *v, *w)
            assert kernels.surface_wrench(row, d, *v, *w, AIR_DENSITY) == expected
        assert kernels.surface_wrench(row, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, AIR_DENSITY) == (0.0,) * 6


@pytest.mark.parametrize("name", FIXEDWINGS + ("quadplane",))
def test_surfaces_step_equals_the_surface_group(name):
    """The flaps following commands beyond [-1, 1] through their lag, and the summed wrench:
    the compiled step equals ``Surfaces.step`` bit for bit, state included."""
    spec = load_uav_spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    group = Surfaces(parts.surfaces, DT, mix_rows(parts.surface_mix))
    rng = np.random.default_rng(10)
    ns = len(parts.surfaces)
    deflection = np.zeros(ns)
    for step in range(200):
        if step % 2 == 0:  # a new command every control tick
            command = rng.uniform(-1.5, 1.5, ns)
            group.command = command.tolist()
        v, w = (rng.normal(0, 6, 3) + (14.0, 0.0, 0.0)).tolist(), rng.normal(0, 2, 3).tolist()
        expected = group.step((tuple(v), tuple(w)))
        got = kernels.surfaces_step(deflection, command, model.surface_lag, model.surfaces, *v, *w, AIR_DENSITY)
        assert got == expected
        assert deflection.tolist() == group.deflection
    assert (deflection / model.surface_scale).tolist() == group.aux()


@pytest.mark.parametrize("name", FIXEDWINGS)
def test_channel_routing_equals_the_vehicle_and_groups(name):
    """Mode ``channels``: the setpoint limited to the channels' ranges (``ndarray.clip``, as
    the vehicle does), then each motor's and flap's mix limited to [-1, 1]
    (``Motors.route``, ``Surfaces.route``), bit for bit, mixes of two channels included."""
    spec = load_uav_spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    motors = Motors(parts.motors, DT, NoiseSource(np.random.default_rng(0)), mix_rows(parts.motor_mix))
    surfaces = Surfaces(parts.surfaces, DT, mix_rows(parts.surface_mix))
    rng = np.random.default_rng(11)
    channels = np.empty(model.channels)
    motor_command, flap_command = np.empty(model.motors), np.empty(len(model.surfaces))
    for _ in range(300):
        setpoint = rng.uniform(-1.6, 1.6, model.channels)
        expected = setpoint.clip(parts.channel_low, parts.channel_high)
        kernels.clip_channels(setpoint, model.channel_low, model.channel_high, channels)
        assert channels.tolist() == expected.tolist()
        motors.route(expected.tolist(), None)
        surfaces.route(expected.tolist(), None)
        kernels.route_channels(channels, model.motor_mix_index, model.motor_mix_weight, motor_command)
        kernels.route_channels(channels, model.surface_mix_index, model.surface_mix_weight, flap_command)
        assert motor_command.tolist() == motors.command
        assert flap_command.tolist() == surfaces.command


@pytest.mark.parametrize("name", FIXEDWINGS)
def test_the_fixedwing_autopilot_equals_the_autopilot(name):
    """Mode ``attitude_airspeed``: random states and setpoints, errors wide enough to hold
    the integrators at their limits: the compiled autopilot's channels and integrals equal
    ``FixedwingAutopilot``'s bit for bit."""
    from pyflyt_engine.control.fixedwing import FixedwingAutopilot

    spec = load_uav_spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    autopilot = FixedwingAutopilot(spec.control, parts.channels, parts.channel_low, parts.channel_high, CONTROL_DT)
    rng = np.random.default_rng(12)
    integral, out = np.zeros(4), np.empty(model.channels)
    held = 0
    for tick in range(400):
        state = _state(rng)
        scale = 3.0 if tick % 50 < 25 else 0.2  # stretches of large errors: the integrators saturate
        setpoint = np.r_[rng.normal(0, scale, 3), rng.uniform(5.0, 25.0)]
        expected = autopilot(state, setpoint.tolist())
        (p_, q_, r_), (roll, pitch, _), u = state.ang_vel, state.ang_pos, state.lin_vel[0]
        kernels.fixedwing_autopilot(
            setpoint,
            p_,
            q_,
            r_,
            roll,
            pitch,
            u,
            integral,
            model.autopilot_gains,
            model.cruise_thrust,
            model.autopilot_index,
            model.channel_low,
            model.channel_high,
            CONTROL_DT,
            out,
        )
        assert out.tolist() == expected.tolist()
        loops = (autopilot._roll, autopilot._pitch, autopilot._yaw, autopilot._speed)
        assert integral.tolist() == [loop.integral for loop in loops]
        held += any(loop.g.ki > 0 and abs(loop.integral) == loop.g.integral_limit / loop.g.ki for loop in loops)
    assert held > 20  # the integrator limits were reached


def _random_quaternions(rng: np.random.Generator, count: int) -> np.ndarray:
    q = rng.standard_normal((count, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_read_outs_equal_pybullets_functions():
    """The rotation matrix, Euler angles and the quaternion PyBullet reports for a body: the
    compiled forms equal PyBullet's own functions on random attitudes (within the last bit for
    the quaternion read back from a body, which PyBullet rounds through its matrix)."""
    rng = np.random.default_rng(4)
    cid = p.connect(p.DIRECT)
    try:
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.1, 0.1, 0.1], physicsClientId=cid)
        body = p.createMultiBody(1.0, box, physicsClientId=cid)
        r, q, e = np.empty(9), np.empty(4), np.empty(3)
        for quat in _random_quaternions(rng, 300).tolist():
            kernels.rotation_rows(*quat, r)
            assert r.tolist() == list(p.getMatrixFromQuaternion(quat, physicsClientId=cid))
            kernels.euler_from_quaternion(*quat, e)
            assert np.allclose(e, p.getEulerFromQuaternion(quat, physicsClientId=cid), rtol=0, atol=1e-15)
            p.resetBasePositionAndOrientation(body, [0, 0, 1], quat, physicsClientId=cid)
            reported = p.getBasePositionAndOrientation(body, physicsClientId=cid)[1]
            kernels.matrix_quaternion(r, q)
            assert np.allclose(q, reported, rtol=0, atol=2e-16)  # the same sign, the same number
    finally:
        p.disconnect(cid)


def _context(rng: np.random.Generator, n: int) -> BatchContext:
    flags = lambda: rng.random(n) < 0.5  # noqa: E731
    distance = rng.uniform(0.0, 4.0, n)
    distance[:3] = (0.0, 0.05, np.nan)
    return BatchContext(
        ang_vel=rng.normal(0, 2, (n, 3)),
        ang_pos=rng.normal(0, 1, (n, 3)),
        lin_vel=rng.normal(0, 2, (n, 3)),
        lin_pos=rng.normal(0, 2, (n, 3)),
        action=rng.normal(0, 1, (n, 4)),
        collision=flags(),
        ground_collision=flags(),
        out_of_bounds=flags(),
        crashed=flags(),
        task_complete=flags(),
        target_distance=distance,
        target_distance_rate=rng.normal(0, 1, n),
        waypoint_reached=flags(),
        steps_remaining=rng.integers(0, 300, n),
        agent_dt=1 / 30,
        # a task's own signals (the formation's), each drawn across its range
        extras={
            "formation_error": rng.uniform(0.0, 2.0, n),
            "crowding": rng.uniform(0.0, 1.0, n),
            "in_formation": flags().astype(np.float64),
        },
    )


def _scalar(ctx: BatchContext, i: int) -> r.StepContext:
    state = KinematicState(
        tuple(ctx.ang_vel[i].tolist()),
        tuple(ctx.ang_pos[i].tolist()),
        tuple(ctx.lin_vel[i].tolist()),
        tuple(ctx.lin_pos[i].tolist()),
        (0.0, 0.0, 0.0, 1.0),
        (0.0, 0.0, 0.0),
        (0.0, 0.0, 0.0),
    )
    return r.StepContext(
        state,
        ctx.action[i],
        bool(ctx.collision[i]),
        bool(ctx.ground_collision[i]),
        bool(ctx.out_of_bounds[i]),
        bool(ctx.crashed[i]),
        bool(ctx.task_complete[i]),
        float(ctx.target_distance[i]),
        float(ctx.target_distance_rate[i]),
        bool(ctx.waypoint_reached[i]),
        steps_remaining=int(ctx.steps_remaining[i]),
        agent_dt=ctx.agent_dt,
        extras={key: float(value[i]) for key, value in ctx.extras.items()},
    )


@pytest.mark.parametrize("term", list(VECTOR_TERMS), ids=lambda f: f.__name__)
def test_vector_terms_equal_the_scalar_terms(term):
    rng = np.random.default_rng(5)
    ctx = _context(rng, 64)
    params = {"floor": 0.1} if term is r.inverse_target_distance else {}
    got = VECTOR_TERMS[term](ctx, **params)
    for i in range(64):
        with np.errstate(divide="ignore", invalid="ignore"):
            try:
                expected = float(term(_scalar(ctx, i), **params))
            except ZeroDivisionError:
                expected = math.inf
        assert (math.isnan(got[i]) and math.isnan(expected)) or got[i] == expected, (term.__name__, i)


@pytest.mark.parametrize("condition", list(VECTOR_CONDITIONS), ids=lambda f: f.__name__)
def test_vector_conditions_equal_the_scalar_conditions(condition):
    rng = np.random.default_rng(6)
    ctx = _context(rng, 64)
    got = VECTOR_CONDITIONS[condition](ctx)
    assert [bool(v) for v in got] == [condition(_scalar(ctx, i)) for i in range(64)]


def _reward_function(terms: dict) -> r.RewardFunction:
    return r.compile_reward("random", terms)


def _numpy_form(function: r.RewardFunction) -> BatchedReward:
    vector = BatchedReward(function)
    vector._program = None  # the entries' vector forms on whole arrays
    return vector


def _agree(got: float, expected: float) -> bool:
    return (math.isnan(got) and math.isnan(expected)) or got == expected


@pytest.mark.parametrize("term", COMPILED_TERMS, ids=lambda f: f.__name__)
def test_compiled_terms_equal_the_scalar_terms(term):
    rng = np.random.default_rng(7)
    ctx = _context(rng, 64)
    params = {"floor": 0.1} if term is r.inverse_target_distance else {}
    if term is r.distance_to_point:
        params = {"point": [0.5, -1.0, 2.0]}
    name = next(k for k, v in r.TERMS.items() if v.fn is term)
    function = _reward_function({"entry": {"term": name, "weight": -0.7, "params": params}})
    batched = BatchedReward(function)
    assert batched._program is not None, "compiled"
    total, breakdown = batched(ctx)
    for i in range(64):
        with np.errstate(divide="ignore", invalid="ignore"):
            try:
                expected, parts = function(_scalar(ctx, i))
            except ZeroDivisionError:
                expected, parts = -math.inf, {"entry": -math.inf}
        assert _agree(total[i], expected) and _agree(breakdown["entry"][i], parts["entry"]), (term.__name__, i)


@pytest.mark.parametrize("seed", range(6))
def test_a_compiled_preset_equals_the_scalar_preset_and_the_vector_forms(seed):
    """Random presets of every compiled term and condition (negated too, several per
    entry): the compiled pass gives the scalar preset's total and breakdown row for row,
    and the vector forms' arrays bit for bit."""
    rng = np.random.default_rng(100 + seed)
    names = {v.fn: k for k, v in r.TERMS.items()}
    conditions = {v.fn: k for k, v in r.CONDITIONS.items()}
    terms = {}
    for e in range(int(rng.integers(1, 7))):
        term = COMPILED_TERMS[int(rng.integers(len(COMPILED_TERMS)))]
        when = [
            ("not_" if rng.random() < 0.3 else "") + conditions[COMPILED_CONDITIONS[int(c)]]
            for c in rng.integers(0, len(COMPILED_CONDITIONS), int(rng.integers(0, 3)))
        ]
        spec = {"term": names[term], "weight": float(rng.normal(0, 3)), "when": when or "always"}
        if term is r.inverse_target_distance:
            spec["params"] = {"floor": float(rng.uniform(0, 1))}
        terms[f"e{e}"] = spec
    function = _reward_function(terms)
    compiled = BatchedReward(function)
    assert compiled._program is not None
    ctx = _context(rng, 96)
    total, breakdown = compiled(ctx)
    vector_total, vector_breakdown = _numpy_form(function)(ctx)
    np.testing.assert_array_equal(total, vector_total)
    for key in function.keys:
        np.testing.assert_array_equal(breakdown[key], vector_breakdown[key])
    for i in range(96):
        with np.errstate(divide="ignore", invalid="ignore"):
            expected, parts = function(_scalar(ctx, i))
        assert _agree(total[i], expected), (seed, i)
        assert all(_agree(breakdown[k][i], parts[k]) for k in function.keys), (seed, i)


def test_the_batched_tasks_presets_are_compiled_and_the_formations_are_not():
    """Every preset of a single-agent batched task takes the compiled pass; the formation's
    (its own signals) the vector forms."""
    for preset in ("quadx_hover_dense", "quadx_hover_sparse", "quadx_waypoints_dense", "quadx_waypoints_sparse",
                   "quadx_waypoints_dense_rate", "fixedwing_waypoints_dense", "fixedwing_waypoints_sparse",
                   "fixedwing_waypoints_dense_rate", "ma_quadx_hover_dense", "ma_quadx_hover_sparse"):  # fmt: skip
        function = r.compile_reward(preset, load_reward_preset(preset).terms)
        assert BatchedReward(function)._program is not None, preset
    formation = r.compile_reward("f", load_reward_preset("ma_quadx_formation_dense").terms)
    assert BatchedReward(formation)._program is None


def test_the_integrators_sincos_is_glibcs_sin_and_cos_bit_for_bit():
    """The rigid body's half-turn takes sin and cos of one value, which the compiler makes
    one ``sincos`` call (kernels.integrate_state): its values are the separate functions'."""
    import numba

    @numba.njit(error_model="numpy")
    def both(h, s, c):
        for i in range(h.shape[0]):
            x = h[i]
            s[i], c[i] = math.sin(x), math.cos(x)

    @numba.njit(error_model="numpy")
    def sine(h, s):
        for i in range(h.shape[0]):
            s[i] = math.sin(h[i])

    @numba.njit(error_model="numpy")
    def cosine(h, c):
        for i in range(h.shape[0]):
            c[i] = math.cos(h[i])

    rng = np.random.default_rng(11)
    # the half-turns of a physics step (|w| dt / 2 up to the motion threshold), and far beyond
    h = np.concatenate([rng.uniform(0, 0.4, 200_000), rng.uniform(-1e4, 1e4, 50_000), [0.0, 1e-300, math.pi / 4]])
    s1, c1, s2, c2 = (np.empty_like(h) for _ in range(4))
    both(h, s1, c1)
    sine(h, s2)
    cosine(h, c2)
    called = lambda fn, name: f"${name}," in next(iter(fn.inspect_asm().values()))  # noqa: E731  (its address loaded)
    assert called(both, "sincos") and not called(both, "sin"), "the pair is one sincos call"
    assert called(sine, "sin") and not called(sine, "sincos")
    np.testing.assert_array_equal(s1.view(np.int64), s2.view(np.int64))
    np.testing.assert_array_equal(c1.view(np.int64), c2.view(np.int64))
