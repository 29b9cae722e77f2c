"""The batched backend's numbers are the same on other CPUs: a recorded trajectory, bit for bit.

``golden_batched.npz`` holds 8 envs x 120 steps of QuadX-Hover, QuadX-Waypoints (also its
velocity variant, flown through the controller's outer loops) and Fixedwing-Waypoints on the
batched backend (motor noise on, autoreset, seeded random
actions), and QuadX-Hover in severe Dryden turbulence on a sheared wind and Fixedwing-Waypoints
in the gust (``<env>+<wind>``: the air's laws, the turbulence's per-env streams): every
observation and reward.  This test recomputes them;
``experiments/emulated_cpus.sh`` runs it again with the laws compiled for other instruction
sets (numba's ``NUMBA_CPU_NAME``: a baseline x86-64 and an AVX-only core), so a change that
made the compiled laws depend on the CPU fails here.  Regenerate (only for a deliberate
change of the numbers) with ``python -m tests.batched.test_golden``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config

GOLDEN = Path(__file__).with_name("golden_batched.npz")
ENVS = (
    "quadx_hover",
    "quadx_waypoints",
    "fixedwing_waypoints",
    "quadx_waypoints_velocity",
    "quadx_hover+dryden_severe_sheared",
    "fixedwing_waypoints+gust",
)
#: the winds of the ``<env>+<wind>`` entries: a preset name or a mapping
WINDS = {
    "dryden_severe_sheared": {"preset": "dryden_severe", "mean": {"speed": 3.0, "direction": 45.0, "profile": "power"}},
    "gust": "gust",
}


def _fixedwing_action(rng: np.random.Generator) -> np.ndarray:
    """Aileron and rudder anywhere, the elevator biased nose-down, little thrust: some
    envs dive into the ground (crashes and autoresets) within the 4 s."""
    return np.c_[
        rng.uniform(-1.0, 1.0, (8, 1)),
        rng.uniform(-0.3, 1.0, (8, 1)),
        rng.uniform(-1.0, 1.0, (8, 1)),
        rng.uniform(0.0, 0.6, (8, 1)),
    ]


def _velocity_action(rng: np.random.Generator) -> np.ndarray:
    """Ground velocities anywhere in the variant's range, any yaw rate, mostly down: some envs
    fly into the ground or out of the dome (crashes and autoresets) within the 4 s."""
    return np.c_[rng.uniform(-3.0, 3.0, (8, 2)), rng.uniform(-3.0, 3.0, (8, 1)), rng.uniform(-2.0, 0.5, (8, 1))]


def trajectory(env_name: str) -> tuple[np.ndarray, np.ndarray]:
    config, _, wind = env_name.partition("+")
    env = BatchedUAVEnv(
        load_env_config(config).with_overrides(wind=WINDS[wind]) if wind else config, num_envs=8, seed=5
    )
    obs, _ = env.reset(seed=5)
    rng = np.random.default_rng(3)
    observations, rewards = [obs], []
    fixedwing = env_name.startswith("fixedwing")
    for _ in range(120):
        if fixedwing:
            action = _fixedwing_action(rng)
        elif env_name.endswith("velocity"):
            action = _velocity_action(rng)
        else:
            action = np.c_[rng.uniform(-2.0, 2.0, (8, 3)), rng.uniform(0.05, 0.25, (8, 1))]
        obs, reward, *_ = env.step(action)
        observations.append(obs)
        rewards.append(reward)
    return np.stack(observations), np.stack(rewards)


def test_the_recorded_trajectories_bit_for_bit():
    golden = np.load(GOLDEN)
    for name in ENVS:
        obs, rewards = trajectory(name)
        assert np.array_equal(obs, golden[f"{name}/obs"]), name
        assert np.array_equal(rewards, golden[f"{name}/rewards"]), name
        assert (rewards == -100.0).any()  # crashes and autoresets happened along the way


if __name__ == "__main__":
    arrays = {}
    for name in ENVS:
        arrays[f"{name}/obs"], arrays[f"{name}/rewards"] = trajectory(name)
    if GOLDEN.exists():  # say which recorded trajectories a regeneration changes
        old = np.load(GOLDEN)
        for key in arrays:
            if key in old and not np.array_equal(old[key], arrays[key]):
                print(f"changed: {key}")
    np.savez_compressed(GOLDEN, **arrays)
    print(f"wrote {GOLDEN}")
