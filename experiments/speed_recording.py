"""Env steps per second with and without episode recording (``RecordEpisode``).

Everything is measured in one process, the bare env and the recorded env alternately,
``--repeats`` times; the median of each is kept, so load on the machine hits both alike.
Recordings go to a temporary directory (the file system is part of the cost) that is
deleted afterwards.  Three cases per env:

* **long episodes** (QuadX envs) — a level-holding controller flies one episode of
  ``--steps`` agent steps (dome and time limit widened so it never ends): the per-step
  cost alone.
* **random actions** — random actions (near hover for the QuadX), resetting at episode
  ends, resets inside the timing: per-step plus per-file costs, as in early evaluation.
* **reset** — median time of a reset, which opens a new file and finishes the previous one.

    python experiments/speed_recording.py [--steps 2000] [--repeats 5] [--env PyFlyt/QuadX-Hover-v0]
"""

from __future__ import annotations

import argparse
import math
import platform
import shutil
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import gymnasium
import numpy as np

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS
from pyflyt_engine.telemetry import RecordEpisode


def _make(env_id: str, **kwargs) -> gymnasium.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make(env_id, **kwargs)


def _random_actions(env: gymnasium.Env, n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    space = env.action_space
    actions = rng.uniform(space.low, space.high, size=(n, *space.shape))
    if env.unwrapped.config.action.mode == "rates_thrust":
        actions[:, :3] *= 0.15
        actions[:, 3] = 0.13 + 0.02 * rng.standard_normal(n)
    return actions


def _hold(env: gymnasium.Env):
    """A policy keeping a QuadX flying level near 1 m (rates_thrust), or None for other envs."""
    if env.unwrapped.config.action.mode != "rates_thrust":
        return None

    def act(state) -> np.ndarray:
        roll, pitch, _ = state.ang_pos
        p, q, r = state.ang_vel
        z, vz = state.lin_pos[2], state.lin_vel_ground[2]
        return np.array([-2 * roll - 0.3 * p, -2 * pitch - 0.3 * q, -r, 0.125 + 0.1 * (1 - z) - 0.05 * vz])

    return act


def run_random(env: gymnasium.Env, actions: np.ndarray) -> float:
    env.reset(seed=0)
    start = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return time.perf_counter() - start


def run_long(env: gymnasium.Env, steps: int, policy) -> float:
    env.reset(seed=0)
    state = env.unwrapped
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(policy(state.state))
        if terminated or truncated:
            raise RuntimeError("the level-hold policy ended the episode: the long case would time resets")
    return time.perf_counter() - start


def run_resets(env: gymnasium.Env, n: int = 20) -> float:
    times = []
    env.reset(seed=0)
    for _ in range(n):
        env.step(env.action_space.sample() * 0)
        start = time.perf_counter()
        env.reset()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def measure(env_id: str, steps: int, repeats: int) -> dict[str, float]:
    folder = Path(tempfile.mkdtemp(prefix="pyflyt_speed_recording_"))
    long_kwargs = {"flight_dome_size": 1000.0, "max_duration_seconds": 1e6}
    bare, rec = _make(env_id), RecordEpisode(_make(env_id), folder / "random")
    actions = _random_actions(bare, steps)
    policy = _hold(bare)
    envs = [bare, rec]
    if policy is not None:
        bare_long, rec_long = _make(env_id, **long_kwargs), RecordEpisode(_make(env_id, **long_kwargs), folder / "long")
        envs += [bare_long, rec_long]
    for env in (bare, rec):
        run_random(env, actions[:200])  # warm up
    t = {k: [] for k in ("bare_random", "rec_random", "bare_long", "rec_long", "bare_reset", "rec_reset")}
    for _ in range(repeats):
        if policy is not None:
            t["bare_long"].append(run_long(bare_long, steps, policy))
            t["rec_long"].append(run_long(rec_long, steps, policy))
        t["bare_random"].append(run_random(bare, actions))
        t["rec_random"].append(run_random(rec, actions))
        t["bare_reset"].append(run_resets(bare))
        t["rec_reset"].append(run_resets(rec))
    files = len(list((folder / "random").glob("*.mcap")))
    for env in envs:
        env.close()
    random_bytes = sum(p.stat().st_size for p in (folder / "random").glob("*.mcap")) / (steps * repeats + 200)
    long_bytes = (
        sum(p.stat().st_size for p in (folder / "long").glob("*.mcap")) / (steps * repeats) if policy else float("nan")
    )
    shutil.rmtree(folder)
    m = {k: statistics.median(v) if v else float("nan") for k, v in t.items()}
    return {
        "long_bare": steps / m["bare_long"],
        "long_rec": steps / m["rec_long"],
        "long_us": (m["rec_long"] - m["bare_long"]) / steps * 1e6,
        "random_us": (m["rec_random"] - m["bare_random"]) / steps * 1e6,
        "random_bare": steps / m["bare_random"],
        "random_rec": steps / m["rec_random"],
        "reset_bare_ms": m["bare_reset"] * 1e3,
        "reset_rec_ms": m["rec_reset"] * 1e3,
        "bytes_per_step": random_bytes,
        "long_bytes_per_step": long_bytes,
        "files": files,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=2000, help="agent steps per timing")
    parser.add_argument("--repeats", type=int, default=5, help="timings of each; the median is kept")
    parser.add_argument("--env", action="append", help="env id (repeatable; default: every registered env)")
    args = parser.parse_args()
    print(
        f"machine: {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
        f"{args.steps} steps x {args.repeats} repeats, medians"
    )
    print(f"{'env':<31}{'case':<17}{'bare':>9}{'recorded':>10}{'slower by':>11}{'added':>12}")
    for env_id in args.env or list(ENVS):
        m = measure(env_id, args.steps, args.repeats)
        for case in ("long", "random"):
            b, r = m[f"{case}_bare"], m[f"{case}_rec"]
            if not math.isnan(b):
                print(
                    f"{env_id:<31}{case + ' steps/s':<17}{b:>9.0f}{r:>10.0f}{(b / r - 1) * 100:>10.0f}%"
                    f"{m[case + '_us']:>8.0f} us"
                )
        b, r = m["reset_bare_ms"], m["reset_rec_ms"]
        print(f"{env_id:<31}{'reset ms':<17}{b:>9.2f}{r:>10.2f}{'':>11}{r - b:>8.2f} ms")
        size = (
            f"{m['long_bytes_per_step']:.0f} bytes per step on disk (long episodes), "
            if not math.isnan(m["long_bytes_per_step"])
            else ""
        )
        print(f"{'':<31}{size}{m['bytes_per_step']:.0f} with the random run's {m['files']} files")


if __name__ == "__main__":
    main()
