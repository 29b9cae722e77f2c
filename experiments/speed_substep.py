"""Where a QuadX physics step's time goes, and what the alternatives to the per-group
Python step would save: figures for choosing, in one process.

Every figure is CPU time of this thread (``time.thread_time``) per physics step, the
median over ``--rounds`` rounds of ``--steps`` steps, the variants interleaved round by
round so load from other jobs hits them alike.  The hovering vehicle is put back at its
pose, velocity and throttles every 48 steps (outside the timing), so it never touches
the ground (contacts would change the cost of ``stepSimulation``):

* ``floor`` -- bare PyBullet on the same cf2x body (``pyflyt_cli/speed/protocols.py``:
  one pose and one velocity read, four forces and one torque, ``stepSimulation``);
* ``substep`` -- our physics step between two control ticks as :meth:`World.step` runs
  it for QuadX-Hover (still air, body drag): ``read_motion``, ``air_velocity``,
  ``apply_loads`` (motors, drag, one force and one torque) and ``stepSimulation``;
* ``substep, fused`` -- the same step with every law written out in one function, its
  lookups bound once (no group, noise or vehicle call; the noise rows pre-drawn): the
  "fewer Python calls per physics step" alternative.  Checked to give the same wrench,
  bit for bit, as the groups, before it is timed;
* ``control tick`` -- what a control tick adds to its physics step: ``read_state`` (pose,
  velocities, attitude) and ``control_step`` (the ``rates_thrust`` law, the mixer, the
  routing to the motors), per tick;
* ``Motors.step`` -- the motor group's step alone (plain floats), beside
  ``motors, NumPy`` -- the same law vectorised over the motors with NumPy arrays
  (``x' = (x + a (zeta - x)) z``, ``f = x'|x'|``, wrench ``(M * f).sum(axis=1)``; the
  matrix product ``M @ f`` would go through BLAS, which the engine does not use).  Whether
  it reproduces the plain-float sum bit for bit is printed.

    python experiments/speed_substep.py [--rounds 7] [--steps 2000]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from pyflyt_engine.atmosphere.air import air_velocity  # noqa: E402
from pyflyt_engine.bullet import pybullet as p  # noqa: E402


def _protocols():
    spec = importlib.util.spec_from_file_location("speed_protocols", ROOT / "pyflyt_cli" / "speed" / "protocols.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def hovering_env():
    """QuadX-Hover, hovered for 2 s by a level-holding feedback: its vehicle and world."""
    import gymnasium

    import pyflyt_engine  # noqa: F401 - registers the ids

    env = gymnasium.make("PyFlyt/QuadX-Hover-v0", agent_hz=30, flight_dome_size=1e6, max_duration_seconds=1e6)
    env.reset(seed=0)
    raw = env.unwrapped
    for _ in range(60):
        s = raw.state
        (pr, q, r), (roll, pitch, _) = s.ang_vel, s.ang_pos
        z, vz = s.lin_pos[2], s.lin_vel_ground[2]
        env.step(np.array([-4 * roll - 0.5 * pr, -4 * pitch - 0.5 * q, -0.5 * r, 0.125 + 0.1 * (1 - z) - 0.05 * vz]))
    return env, raw.vehicle, raw.world


def make_fused_step(vehicle):
    """One physics step of a QuadX in still air with every law inline, its lookups bound
    once: the body's motion read, its velocity through the air, the motors (lag, noise,
    thrust), body drag, one force and one torque.  ``step(throttle, factors)`` returns the
    new throttles and the wrench."""
    cid, body = vehicle._client, vehicle.body_id
    get_pose, get_velocity, get_matrix = p.getBasePositionAndOrientation, p.getBaseVelocity, p.getMatrixFromQuaternion
    apply_force, apply_torque, frame, origin = (
        p.applyExternalForce,
        p.applyExternalTorque,
        p.LINK_FRAME,
        (0.0, 0.0, 0.0),
    )
    motors, drag = vehicle.actuators.motors, vehicle.actuators.drag
    lag, columns = motors.lag, motors.columns
    (kx, ky, kz), d = drag._factors, drag._damping

    def step(throttle, factors):
        pos, quat = get_pose(body, cid)
        (lx, ly, lz), (ax, ay, az) = get_velocity(body, cid)
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = get_matrix(quat, cid)
        vx, vy, vz = r0 * lx + r3 * ly + r6 * lz, r1 * lx + r4 * ly + r7 * lz, r2 * lx + r5 * ly + r8 * lz
        px, py, pz = r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az
        new = []
        fx = fy = fz = tx = ty = tz = 0.0
        for x, c, a, z, (wx, wy, wz, wl, wm, wn) in zip(throttle, motors.command, lag, factors, columns):
            x = (x + a * (c - x)) * z
            new.append(x)
            f = x * abs(x)
            fx += wx * f
            fy += wy * f
            fz += wz * f
            tx += wl * f
            ty += wm * f
            tz += wn * f
        fx, fy, fz = fx + -kx * vx * abs(vx), fy + -ky * vy * abs(vy), fz + -kz * vz * abs(vz)
        tx, ty, tz = tx + -d * px * abs(px), ty + -d * py * abs(py), tz + -d * pz * abs(pz)
        apply_force(body, -1, (fx, fy, fz), origin, frame, cid)
        apply_torque(body, -1, (tx, ty, tz), frame, cid)
        return new, (fx, fy, fz, tx, ty, tz)

    return step


def numpy_motor_step(x, command, lag, factors, matrix):
    """The motor law on arrays (the module docstring); returns (new throttles, wrench array)."""
    x = (x + lag * (command - x)) * factors
    return x, (matrix * (x * np.abs(x))).sum(axis=1)


def check_fused_is_the_same_law(vehicle) -> None:
    """The fused step's wrench equals the groups' (motors + drag, summed in that order) bit for bit."""
    motors, drag = vehicle.actuators.motors, vehicle.actuators.drag
    state = [list(motors.throttle), motors._noise._rows, motors._noise._block]
    pos, r, lin, ang = vehicle.read_motion()
    air = air_velocity(r, lin, ang)
    rows = [motors._noise.next() for _ in range(3)]
    for row in rows:
        start = list(motors.throttle)
        motors._noise._rows = iter([row])
        m = motors.step(None)
        g = drag.step(air)
        groups = tuple(a + b for a, b in zip(m, g))
        new, fused = make_fused_step(vehicle)(start, row)
        assert new == motors.throttle and fused == groups, (fused, groups)
    motors.throttle, motors._noise._rows, motors._noise._block = state


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--steps", type=int, default=2000)
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    protocols = _protocols()
    env, vehicle, world = hovering_env()
    cid = world.client
    motors = vehicle.actuators.motors
    check_fused_is_the_same_law(vehicle)
    body = vehicle.body_id
    home = p.getBasePositionAndOrientation(body, cid)
    velocity = p.getBaseVelocity(body, cid)
    throttle0 = list(motors.throttle)
    rng = np.random.default_rng(0)
    noise_rows = [tuple((1.0 + 0.02 * rng.standard_normal(4)).tolist()) for _ in range(args.steps)]  # plain floats
    matrix = np.array(motors.columns).T
    lag = np.array(motors.lag)
    command = np.array(motors.command)
    np_rows = [np.array(row) for row in noise_rows]

    # does the NumPy sum reproduce the plain-float sum?
    x_np, w_np = numpy_motor_step(np.array(throttle0), command, lag, np_rows[0], matrix)
    motors.throttle = list(throttle0)
    motors._noise._rows = iter([noise_rows[0]])
    w_py = motors.step(None)
    numpy_identical = x_np.tolist() == motors.throttle and w_np.tolist() == list(w_py)
    motors.throttle = list(throttle0)

    def restore() -> None:
        p.resetBasePositionAndOrientation(body, *home, physicsClientId=cid)
        p.resetBaseVelocity(body, *velocity, physicsClientId=cid)
        motors.throttle = list(throttle0)

    chunk = 48  # physics steps between restores (0.2 s): the body stays in the air, no contacts

    def substep(n: int) -> None:
        for _ in range(n):
            pos, r, lin, ang = vehicle.read_motion()
            vehicle.apply_loads(air_velocity(r, lin, ang), None)
            p.stepSimulation(cid)

    fused_step = make_fused_step(vehicle)
    step_simulation = p.stepSimulation

    def fused(n: int) -> None:
        throttle = list(throttle0)
        for row in noise_rows[:n]:
            throttle, _ = fused_step(throttle, row)
            step_simulation(cid)

    def step_only(n: int) -> None:
        for _ in range(n):
            p.stepSimulation(cid)

    def control_tick(n: int) -> None:
        for _ in range(n):
            vehicle.read_state()
            vehicle.control_step()

    def motors_python(n: int) -> None:
        for _ in range(n):
            motors.step(None)

    def motors_numpy(n: int) -> None:
        x = np.array(throttle0)
        for row in np_rows[:n]:
            x, _ = numpy_motor_step(x, command, lag, row, matrix)

    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import urdf_path

    spec = load_uav_spec("quadx_cf2x")
    floor_case = (str(urdf_path(spec)), spec.body.mass, [list(m) for m in spec.motors.positions])
    variants = {
        "floor (bare PyBullet)": None,
        "stepSimulation alone": step_only,
        "substep (as World.step runs it)": substep,
        "substep, fused (one function)": fused,
        "control tick: read_state + control": control_tick,
        "Motors.step (plain floats)": motors_python,
        "motors, NumPy arrays": motors_numpy,
    }
    clock = time.thread_time
    times: dict[str, list[float]] = {name: [] for name in variants}
    for _ in range(args.rounds):
        for name, run in variants.items():
            if run is None:
                times[name].append(protocols.time_floor(p, *floor_case, args.steps, clock=clock))
                continue
            total = 0.0
            for _ in range(args.steps // chunk):
                restore()
                start = clock()
                run(chunk)
                total += clock() - start
            times[name].append(total / (args.steps // chunk * chunk))
    restore()
    # a whole agent step (8 physics steps, 4 control ticks), hovering, and its World.step
    # part (the same setpoint, world alone); 6 agent steps per restore
    agent_env, agent_world = [], []
    raw = env.unwrapped
    for _ in range(args.rounds):
        for whole, out in ((True, agent_env), (False, agent_world)):
            total = 0.0
            for _ in range(args.steps // chunk):
                restore()
                start = clock()
                for _ in range(6):
                    s_ = raw.state
                    (pr, q, r), (roll, pitch, _) = s_.ang_vel, s_.ang_pos
                    z, vz = s_.lin_pos[2], s_.lin_vel_ground[2]
                    action = np.array(
                        [-4 * roll - 0.5 * pr, -4 * pitch - 0.5 * q, -0.5 * r, 0.125 + 0.1 * (1 - z) - 0.05 * vz]
                    )
                    if whole:
                        env.step(action)
                    else:
                        vehicle.set_setpoint(action)
                        world.step()
                total += clock() - start
            out.append(total / (args.steps // chunk * 6))
    env.close()
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    floor = statistics.median(times["floor (bare PyBullet)"])
    print(f"load {load}; CPU time per physics step, median of {args.rounds} rounds of {args.steps} steps"
          f" (hovering: the body is put back every {chunk} steps)")  # fmt: skip
    print(f"  {'variant':<34}{'us':>8}{'x floor':>10}")
    for name, values in times.items():
        us = statistics.median(values) * 1e6
        print(f"  {name:<34}{us:>8.2f}{us / (floor * 1e6):>10.2f}")
    agent_us, world_us = statistics.median(agent_env) * 1e6, statistics.median(agent_world) * 1e6
    print(f"  {'QuadX-Hover env step (8 physics)':<34}{agent_us:>8.2f}{agent_us / (floor * 1e6):>10.2f}"
          f"   = {agent_us / (8 * floor * 1e6):.2f} x the floor of its 8 physics steps")  # fmt: skip
    print(f"  {'  of which World.step':<34}{world_us:>8.2f}{world_us / (floor * 1e6):>10.2f}")
    print(f"fused step gives the groups' wrench bit for bit: yes (checked); "
          f"NumPy motors reproduce the plain-float sum bit for bit: {'yes' if numpy_identical else 'no'}")  # fmt: skip


if __name__ == "__main__":
    main()
