"""Physics steps per second of a hovering QuadX in the World versus bare PyBullet.

The floor is PyBullet doing the same physical work with no engine around it: the same
body (the generated cf2x URDF), one state read (pose and velocity), four motor forces
and one yaw torque applied, one ``stepSimulation`` per physics step.  The World runs
the full stack: state read-out, the cascaded controller at 120 Hz, motor lag and noise,
drag, contact tracking.  Both run in this process, alternately, and the best of
``--repeats`` timings of each is kept, so load on the machine hits both alike.  With
``--cpu-time`` the timings are the CPU time this process used (``time.process_time``)
rather than wall time: on a machine busy with other jobs, the time spent waiting for a
core then counts for neither side (cache and frequency effects of the other jobs still do).

    python experiments/speed_world.py [--steps 24000] [--repeats 5] [--mode position_yaw] [--cpu-time]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable

import numpy as np

from pyflyt_cli.speed.probes import bare_pybullet  # the floor, shared with `pyflyt speed`
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.world import VehicleConfig, World


def world_hover(steps: int, uav: str, mode: str, clock: Callable[[], float] = time.perf_counter) -> float:
    """Seconds per physics step of the World hovering one vehicle."""
    world = World([VehicleConfig(uav, (0.0, 0.0, 1.0), mode=mode)], seed=0)
    vehicle = world.vehicles[0]
    if mode == "position_yaw":
        world.set_setpoint(0, [0.0, 0.0, 0.0, 1.0])
    elif mode == "motors":
        world.set_setpoint(0, [vehicle.hover_throttle()] * vehicle.motors.count)
    elif mode == "rates_thrust":
        world.set_setpoint(0, [0.0, 0.0, 0.0, vehicle.hover_throttle() ** 2])
    agent_steps = max(1, steps // world.physics_per_agent)
    for _ in range(30):  # warm up
        world.step()
    start = clock()
    for _ in range(agent_steps):
        world.step()
    elapsed = clock() - start
    world.close()
    return elapsed / (agent_steps * world.physics_per_agent)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=24000, help="physics steps per timing")
    parser.add_argument("--repeats", type=int, default=5, help="timings of each; the best is kept")
    parser.add_argument("--uav", default="quadx_cf2x")
    parser.add_argument("--mode", default=None, help="flight mode (default: motors, rates_thrust and position_yaw)")
    parser.add_argument("--cpu-time", action="store_true", help="time with process CPU time instead of wall time")
    args = parser.parse_args()
    clock = time.process_time if args.cpu_time else time.perf_counter
    modes = [args.mode] if args.mode else ["motors", "rates_thrust", "position_yaw"]

    floor, world = [], {m: [] for m in modes}
    for _ in range(args.repeats):
        floor.append(bare_pybullet(args.steps, args.uav, clock=clock))
        for mode in modes:
            world[mode].append(world_hover(args.steps, args.uav, mode, clock))
    best_floor = min(floor)
    print(
        f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"pybullet {p.getAPIVersion()}, numpy {np.__version__}; {'CPU' if args.cpu_time else 'wall'} time, "
        f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}"
    )
    print(f"{'case':<28}{'us/step':>10}{'steps/s':>12}{'x floor':>10}")
    print(f"{'bare pybullet (floor)':<28}{best_floor * 1e6:>10.2f}{1 / best_floor:>12.0f}{1.0:>10.2f}")
    for mode in modes:
        best = min(world[mode])
        print(f"{'world hover, ' + mode:<28}{best * 1e6:>10.2f}{1 / best:>12.0f}{best / best_floor:>10.2f}")


if __name__ == "__main__":
    main()
