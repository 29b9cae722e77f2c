"""How much a small difference in a fixed-wing's state grows over 2 s of random flight on
the batched backend: the amplification factor in the fixed-wing cross-check's bound
(``tests/batched/test_crosscheck.py``, module docstring).

Per seed, 7 copies of one Fixedwing-Waypoints spawn (motor noise off) fly the same 60
random actions (aileron, elevator, rudder in [-1, 1], thrust in [0, 1]: the cross-check's
actions; ``--autopilot``: the autopilot's setpoints, bank within +-0.6 rad, pitch +-0.3 rad,
yaw rate +-0.5 rad/s, airspeed 10-20 m/s); copies 1-6 start with one of x, z, u, w, p, q
nudged by ``--eps``.  Prints the largest observation difference over the flight divided by
the nudge, per airframe.

    python experiments/batched_fixedwing_sensitivity.py [--seeds 8] [--eps 1e-9] [--autopilot]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import yaml

from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.paths import uav_dir


AUTOPILOT_ACTION = {
    "mode": "attitude_airspeed",
    "names": ["roll", "pitch", "yaw_rate", "airspeed"],
    "units": ["rad", "rad", "rad/s", "m/s"],
    "low": [-0.6, -0.3, -0.5, 10.0],
    "high": [0.6, 0.3, 0.5, 20.0],
}


def amplification(uav: str, seeds: int, eps: float, autopilot: bool = False) -> float:
    overrides = {"action": AUTOPILOT_ACTION} if autopilot else {}
    cfg = load_env_config("fixedwing_waypoints").with_overrides(uav=uav, **overrides)
    low, high = np.array(cfg.action.low), np.array(cfg.action.high)
    worst = 0.0
    for seed in range(seeds):
        env = BatchedUAVEnv(cfg, num_envs=7, seed=seed, motor_noise=False)
        env.reset(seed=seed)
        for array in (env.pos, env.quat, env.vel, env.angvel, env.targets):
            array[:] = array[0]
        nudges = [(env.pos, 0), (env.pos, 2), (env.vel, 0), (env.vel, 2), (env.angvel, 0), (env.angvel, 1)]
        for j, (array, k) in enumerate(nudges):
            array[j + 1, k] += eps
        env._read()
        rng = np.random.default_rng(20 + seed)
        for _ in range(60):
            action = rng.uniform(low, high)
            obs, *_ = env.step(np.tile(action, (7, 1)))
            worst = max(worst, float(np.abs(obs[1:] - obs[0]).max()) / eps)
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--eps", type=float, default=1e-9)
    parser.add_argument("--autopilot", action="store_true", help="fly mode attitude_airspeed")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        for name in ("fixedwing", "flying_wing"):
            data = yaml.safe_load((uav_dir() / f"{name}.yaml").read_text())
            data["motors"]["noise_ratio"] = 0.0  # as the cross-check flies it
            path = Path(folder) / f"{name}.yaml"
            path.write_text(yaml.safe_dump(data))
            growth = amplification(str(path), args.seeds, args.eps, args.autopilot)
            print(f"{name}: a {args.eps:g} nudge grows at most {growth:.1f}-fold over 2 s")


if __name__ == "__main__":
    main()
