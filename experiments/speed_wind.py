"""What the atmosphere costs per env step: calm, steady wind, shear, Dryden, rotor effects.

One process builds one env per case (same env id, same seed) and times them alternately,
``--repeats`` rounds of ``--steps`` agent steps each (a level-holding controller keeps
the QuadX flying; dome and time limit widened so the episode never ends); the median of
each case is kept, so load on the machine hits every case alike.  Printed: CPU time of
this thread per env step (``time.thread_time``: on a shared machine it moves less than
wall time, which also counts the waits for a core) and wall time, in microseconds, with
their ratios to ``calm``.

    python experiments/speed_wind.py [--steps 3000] [--repeats 7] [--env PyFlyt/QuadX-Hover-v0]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
import warnings

import gymnasium
import numpy as np

import pyflyt_engine  # noqa: F401  (registers the ids)

CASES = {
    "calm": {},
    "constant": {"wind": "constant"},
    "shear": {"wind": "shear"},
    "dryden_light": {"wind": "dryden_light"},
    "dryden_light + constant 3 m/s": {"wind": {"preset": "dryden_light", "mean": {"speed": 3.0}}},
    "ground effect + downwash": {"ground_effect": True, "downwash": True},
}


def _make(env_id: str, steps: int, **kwargs) -> gymnasium.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gymnasium.make(env_id, flight_dome_size=1e6, max_duration_seconds=1e6, **kwargs)
    return env.unwrapped  # no wrappers: the step itself


def _hold(state) -> np.ndarray:
    """rates_thrust: level the vehicle and hold about 1 m."""
    roll, pitch, _ = state.ang_pos
    p, q, r = state.ang_vel
    z = state.lin_pos[2]
    vz = state.lin_vel_ground[2]
    return np.array([-4 * roll - 0.5 * p, -4 * pitch - 0.5 * q, -0.5 * r, 0.125 + 0.1 * (1 - z) - 0.05 * vz])


def _time(env, steps: int) -> tuple[float, float]:
    """(CPU seconds, wall seconds) per env step."""
    env.reset(seed=0)
    state = env.state
    start, cpu = time.perf_counter(), time.thread_time()
    for _ in range(steps):
        env.step(_hold(state))
        state = env.state
    return (time.thread_time() - cpu) / steps, (time.perf_counter() - start) / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="PyFlyt/QuadX-Hover-v0")
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    envs = {name: _make(args.env, args.steps, **kwargs) for name, kwargs in CASES.items()}
    for env in envs.values():  # warm up (URDF cache, first blocks, allocator)
        _time(env, 200)
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in envs}
    for _ in range(args.repeats):
        for name, env in envs.items():
            times[name].append(_time(env, args.steps))
    cpu0 = statistics.median(t[0] for t in times["calm"])
    wall0 = statistics.median(t[1] for t in times["calm"])
    print(
        f"{args.env}, {args.steps} steps x {args.repeats} rounds, median; {platform.machine()}, Python {platform.python_version()}"
    )
    print(f"{'case':<32}{'CPU us/step':>12}{'x calm':>8}{'wall us/step':>14}{'x calm':>8}")
    for name, values in times.items():
        cpu = statistics.median(t[0] for t in values)
        wall = statistics.median(t[1] for t in values)
        print(f"{name:<32}{cpu * 1e6:>12.1f}{cpu / cpu0:>8.3f}{wall * 1e6:>14.1f}{wall / wall0:>8.3f}")
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    main()
