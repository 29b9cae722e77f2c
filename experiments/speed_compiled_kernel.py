"""Would a compiled kernel (numba) bring QuadX-Hover's env step within 2.5x the floor?

The per-physics-step group laws of a hovering QuadX -- the motors (throttle lag, noise
factor, ``x|x|`` times each motor's wrench column, summed), body drag (quadratic per axis
and rotational damping) and the net wrench (motors + drag, in that order) -- are timed
as the engine runs them (:meth:`Motors.step`, :meth:`BodyDrag.step`, the vehicle's sum:
plain Python floats) against the same arithmetic in one ``@numba.njit`` kernel, written
in the same order (no ``fastmath``: LLVM may then neither reorder nor contract a
multiply and an add into an FMA).  Before any timing the kernel is checked against the
Python laws bit for bit (every throttle and wrench component, the sign of zero
included) over ``--checks`` random inputs: throttles, commands, noise factors, the
body's velocity through the air, the cf2x's own wrench columns and random ones.

Timed, in one process, interleaved round by round (CPU time of this thread, median of
``--rounds`` rounds of ``--steps`` calls):

* ``Python laws`` -- ``Motors.step`` + ``BodyDrag.step`` + the sum, as ``apply_loads``
  runs them (the noise factors from the group's pre-drawn rows);
* ``kernel`` -- the kernel on the motor state kept in NumPy arrays (the noise read from
  a pre-drawn block by index), called from Python with the air as two 3-tuples: what a
  compiled path would run per physics step;
* ``kernel call, empty`` -- a kernel with the same arguments that computes nothing: the
  cost of calling compiled code from Python (argument unboxing, result boxing);
* the floor (bare PyBullet, ``pyflyt_cli/speed/protocols.py``) and the QuadX-Hover env
  step (8 physics steps, hovering, as ``speed_substep.py`` flies it).

The estimate: the env step with the kernel in place of the laws is the measured env step
minus 8 x (Python laws - kernel); its ratio to the floor of 8 physics steps is printed
beside the target (2.5), and beside the bound of laws that cost nothing (env step minus
8 x Python laws).  numba is not a dependency of the package; run with it on the
path, e.g.::

    pip install --target /tmp/numba_pkgs numba
    PYTHONPATH=/tmp/numba_pkgs python experiments/speed_compiled_kernel.py [--rounds 7] [--steps 4000]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import platform
import statistics
import struct
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from pyflyt_engine.bullet import pybullet as p  # noqa: E402


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def compile_kernels():
    """``(group_step, empty)``: the kernel and a do-nothing kernel of the same signature,
    compiled (the first call compiles; its time is returned too)."""
    import numba

    @numba.njit(fastmath=False)
    def group_step(throttle, command, lag, noise, row, columns, drag, damping, lin, ang):
        # the motors: x' = (x + a (c - x)) z, f = x'|x'|, wrench += column * f (from 0.0, in motor order)
        fx = fy = fz = tx = ty = tz = 0.0
        for i in range(throttle.shape[0]):
            x = (throttle[i] + lag[i] * (command[i] - throttle[i])) * noise[row, i]
            throttle[i] = x
            f = x * abs(x)
            fx += columns[i, 0] * f
            fy += columns[i, 1] * f
            fz += columns[i, 2] * f
            tx += columns[i, 3] * f
            ty += columns[i, 4] * f
            tz += columns[i, 5] * f
        # body drag: -k v|v| per axis, -c w|w| per axis; then motors + drag
        vx, vy, vz = lin
        wx, wy, wz = ang
        return (
            fx + -drag[0] * vx * abs(vx),
            fy + -drag[1] * vy * abs(vy),
            fz + -drag[2] * vz * abs(vz),
            tx + -damping * wx * abs(wx),
            ty + -damping * wy * abs(wy),
            tz + -damping * wz * abs(wz),
        )

    @numba.njit(fastmath=False)
    def empty(throttle, command, lag, noise, row, columns, drag, damping, lin, ang):
        return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    args = (np.zeros(4), np.zeros(4), np.zeros(4), np.ones((1, 4)), 0, np.zeros((4, 6)), np.zeros(3), 0.0,
            (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # fmt: skip
    start = time.perf_counter()
    group_step(*args)
    empty(*args)
    return group_step, empty, time.perf_counter() - start, numba.__version__


def _bits(values) -> tuple[int, ...]:
    """Each float's bit pattern (so -0.0 and 0.0 differ, as they may downstream)."""
    return tuple(struct.unpack("<q", struct.pack("<d", float(v)))[0] for v in values)


def check_bit_identity(vehicle, group_step, checks: int, seed: int = 0) -> int:
    """The kernel against ``Motors.step`` + ``BodyDrag.step`` + the sum over ``checks``
    random inputs; returns how many differ in any bit (throttles or wrench)."""
    from pyflyt_engine.vehicle import _summed

    motors, drag = vehicle.actuators.motors, vehicle.actuators.drag
    columns = [tuple(c) for c in motors.columns]
    saved = (list(motors.throttle), list(motors.command), columns, motors._noise._rows, motors._noisy)
    rng = np.random.default_rng(seed)
    lag = np.array(motors.lag)
    drag_k, damping = np.array(drag._factors), float(drag._damping)
    n = len(motors.throttle)
    mismatches = 0
    motors._noisy = True
    for i in range(checks):
        throttle = rng.uniform(-1.0, 1.0, n).tolist()
        command = rng.uniform(-1.0, 1.0, n).tolist()
        if i % 7 == 0:  # exact zeros and ones: signs of zero, saturated motors
            throttle[i % n], command[(i + 1) % n] = 0.0, 1.0
        factors = (1.0 + 0.05 * rng.standard_normal(n)).tolist()
        scale = 10.0 ** rng.uniform(-3, 1.5)
        lin = tuple((scale * rng.standard_normal(3)).tolist())
        ang = tuple((scale * rng.standard_normal(3)).tolist())
        if i % 2:  # random wrench columns (any geometry), else the cf2x's own
            motors.columns = [tuple(c) for c in rng.standard_normal((n, 6)).tolist()]
        else:
            motors.columns = list(saved[2])
        motors.throttle, motors.command = list(throttle), list(command)
        motors._noise._rows = iter([tuple(factors)])
        python = _summed(motors.step(None), drag.step((lin, ang)))
        x = np.array(throttle)
        kernel = group_step(
            x, np.array(command), lag, np.array([factors]), 0, np.array(motors.columns), drag_k, damping, lin, ang
        )
        if _bits(python) != _bits(kernel) or _bits(motors.throttle) != _bits(x.tolist()):
            mismatches += 1
    motors.throttle, motors.command, motors.columns, motors._noise._rows, motors._noisy = saved
    return mismatches


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--steps", type=int, default=4000, help="calls per timing")
    parser.add_argument("--checks", type=int, default=200_000, help="random inputs of the bit-identity check")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    try:
        group_step, empty, compile_s, numba_version = compile_kernels()
    except ImportError:
        raise SystemExit(
            "numba is not installed: pip install --target /tmp/numba_pkgs numba, then PYTHONPATH=/tmp/numba_pkgs"
        ) from None
    from pyflyt_engine.vehicle import _summed

    substep = _load("speed_substep", ROOT / "experiments" / "speed_substep.py")
    protocols = substep._protocols()
    env, vehicle, world = substep.hovering_env()
    raw = env.unwrapped
    motors, drag = vehicle.actuators.motors, vehicle.actuators.drag
    mismatches = check_bit_identity(vehicle, group_step, args.checks)

    # the inputs of one physics step, as the loop has them
    pos, r, lin, ang = vehicle.read_motion()
    from pyflyt_engine.atmosphere.air import air_velocity

    air = air_velocity(r, lin, ang)
    throttle0, command = list(motors.throttle), np.array(motors.command)
    lag, columns = np.array(motors.lag), np.array(motors.columns)
    drag_k, damping = np.array(drag._factors), float(drag._damping)
    noise = 1.0 + 0.02 * np.random.default_rng(1).standard_normal((args.steps, len(throttle0)))
    rows = [tuple(row) for row in noise.tolist()]
    step_motors, step_drag = motors.step, drag.step

    def python_laws() -> None:
        motors.throttle = list(throttle0)
        motors._noise._rows = iter(rows)
        for _ in range(args.steps):
            _summed(step_motors(None), step_drag(air))

    def kernel() -> None:
        x = np.array(throttle0)
        vel, rate = air
        for i in range(args.steps):
            group_step(x, command, lag, noise, i, columns, drag_k, damping, vel, rate)

    def kernel_empty() -> None:
        x = np.array(throttle0)
        vel, rate = air
        for i in range(args.steps):
            empty(x, command, lag, noise, i, columns, drag_k, damping, vel, rate)

    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import urdf_path

    spec = load_uav_spec("quadx_cf2x")
    floor_case = (str(urdf_path(spec)), spec.body.mass, [list(m) for m in spec.motors.positions])
    body, cid = vehicle.body_id, world.client
    home, velocity = p.getBasePositionAndOrientation(body, cid), p.getBaseVelocity(body, cid)
    saved_throttle = list(motors.throttle)

    def env_steps() -> float:
        """CPU seconds per hovering env step (6 agent steps per restore, as speed_substep.py)."""
        total, count = 0.0, 0
        for _ in range(max(1, args.steps // 48)):
            p.resetBasePositionAndOrientation(body, *home, physicsClientId=cid)
            p.resetBaseVelocity(body, *velocity, physicsClientId=cid)
            motors.throttle = list(saved_throttle)
            start = clock()
            for _ in range(6):
                s = raw.state
                (pr, q, rr), (roll, pitch, _) = s.ang_vel, s.ang_pos
                z, vz = s.lin_pos[2], s.lin_vel_ground[2]
                thrust = 0.125 + 0.1 * (1 - z) - 0.05 * vz
                env.step(np.array([-4 * roll - 0.5 * pr, -4 * pitch - 0.5 * q, -0.5 * rr, thrust]))
            total += clock() - start
            count += 6
        return total / count

    clock = time.thread_time
    variants = {"Python laws": python_laws, "kernel": kernel, "kernel call, empty": kernel_empty}
    times: dict[str, list[float]] = {name: [] for name in ("floor", *variants, "env step")}
    for _ in range(args.rounds):
        times["floor"].append(protocols.time_floor(p, *floor_case, args.steps, clock=clock))
        for name, run in variants.items():
            start = clock()
            run()
            times[name].append((clock() - start) / args.steps)
        saved_throttle = list(motors.throttle)
        times["env step"].append(env_steps())
    env.close()
    us = {name: statistics.median(values) * 1e6 for name, values in times.items()}
    floor8 = 8 * us["floor"]
    estimate = us["env step"] - 8 * (us["Python laws"] - us["kernel"])
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numba {numba_version}; load {load}")  # fmt: skip
    print(f"CPU time of this thread, median of {args.rounds} rounds of {args.steps} calls; "
          f"first-call compile {compile_s:.2f} s")  # fmt: skip
    print(f"bit-identity, kernel vs Python laws over {args.checks} random inputs: "
          f"{'identical' if mismatches == 0 else f'{mismatches} differ'}")  # fmt: skip
    print(f"  {'per physics step':<34}{'us':>8}{'x floor step':>14}")
    for name in ("floor", *variants):
        print(f"  {name:<34}{us[name]:>8.2f}{us[name] / us['floor']:>14.2f}")
    print(f"  {'saved per physics step':<34}{us['Python laws'] - us['kernel']:>8.2f}")
    print(f"QuadX-Hover env step: measured {us['env step']:.1f} us = {us['env step'] / floor8:.2f} x the floor "
          f"of its 8 physics steps "
          f"({floor8:.1f} us); with the kernel (estimate) {estimate:.1f} us = {estimate / floor8:.2f} x (target 2.5)")  # fmt: skip
    bound = us["env step"] - 8 * us["Python laws"]
    print(f"  bound: these laws at no cost at all: {bound:.1f} us = {bound / floor8:.2f} x the floor")


if __name__ == "__main__":
    main()
