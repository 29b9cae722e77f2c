"""Rocket-Landing with a scripted controller: is the task feasible, and what do the rewards pay for it?

Scripted controllers (no learning) fly the Rocket-Landing task from its seeded start
states (450 m drop, +-20 m sideways, +-5 m/s, +-0.3 rad, +-0.5 rad/s, 1 % fuel), and,
for comparison, the same starts with the booster never lit (a free fall):

* ``descent lander``: the ``rocket_descent_lander`` oracle on
  ``PyFlyt/Rocket-Landing-Descent-v0``, the task flown through the rocket autopilot's
  ``descent`` mode, which brakes on its envelope and pulses the booster to aim: the
  oracle is guidance only (a sideways velocity toward the pad, a constant descent
  setpoint, ignition off on the pad).
* ``velocity lander``: the ``rocket_velocity_lander`` oracle on
  ``PyFlyt/Rocket-Landing-Velocity-v0``, the task flown through the rocket autopilot's
  ``velocity`` mode (``pyflyt_engine/control/rocket.py``): a velocity setpoint on a
  30 m/s^2 braking curve, aimed over the pad by short pulses of the leaning booster
  above 120 m, a damped approach below, ignition off on the pad.  The autopilot does
  the attitude control, thrust vectoring and ignition timing.
* ``raw-channel lander``: the ``rocket_lander`` oracle on ``PyFlyt/Rocket-Landing-v0``,
  which does all of that itself on the seven raw channels (the DAgger oracle of
  ``learn_rocket_landing.md``).

Both act on the observation alone (``pyflyt_engine/envs/oracles.py``, their docstrings
describe them).  Each episode is flown once under each reward preset (the paper's dense
reward, the sparse one and the braking-envelope shaping) from the same seed; the script
checks that the flights are identical, so the presets' returns compare one flight.
`pyflyt eval oracle:rocket_descent_lander episodes=50 seed=0` (or `oracle:rocket_velocity_lander`,
`oracle:rocket_lander`)
flies the same landings from the command line (recorded to MCAP; `video=` films them).

    python experiments/rocket_scripted_landing.py [--seeds 50] [--write]

``--write`` writes ``experiments/results/rocket_landing_scripted.md``.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import gymnasium
import numpy as np

import pyflyt_engine.envs  # noqa: F401  (registers the envs)
from pyflyt_engine.envs.oracles import make_oracle

#: policy -> (env id, oracle; None: a free fall, every action 0)
POLICIES = {
    "descent lander": ("PyFlyt/Rocket-Landing-Descent-v0", "rocket_descent_lander"),
    "velocity lander": ("PyFlyt/Rocket-Landing-Velocity-v0", "rocket_velocity_lander"),
    "raw-channel lander": ("PyFlyt/Rocket-Landing-v0", "rocket_lander"),
    "free fall": ("PyFlyt/Rocket-Landing-v0", None),
}
PRESETS = ("rocket_landing_dense", "rocket_landing_sparse", "rocket_landing_envelope")
RESULTS = Path(__file__).parent / "results" / "rocket_landing_scripted.md"


def _outcome(info: dict) -> str:
    for key, name in (
        ("safe_landing", "safe"),
        ("fatal_landing", "fatal"),
        ("ground_contact", "ground"),
        ("out_of_bounds", "dome exit"),
    ):
        if info[key]:
            return name
    return "time limit"


def fly(seed: int, policy: str) -> dict:
    """One seeded episode per reward preset; the flights are checked to be identical (the reward
    does not act on the dynamics), and the outcome and the return under every preset are kept."""
    totals, flights = {}, set()
    for preset in PRESETS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env_id, oracle = POLICIES[policy]
            env = gymnasium.make(env_id, reward=preset)
        obs, _ = env.reset(seed=seed)
        lander = make_oracle(oracle, env) if oracle else None
        total, steps = 0.0, 0
        while True:
            action = lander(obs) if lander else np.zeros(env.action_space.shape)  # ignition 0: never lit
            obs, reward, terminated, truncated, info = env.step(action)
            total += reward
            steps += 1
            if terminated or truncated:
                break
        fuel = float(env.unwrapped.vehicle.aux_state[4]) * 410.9
        env.close()
        totals[preset] = total
        flights.add((steps, _outcome(info), obs.tobytes()))
    if len(flights) != 1:
        raise RuntimeError(f"seed {seed}: the presets flew different episodes; the comparison is void")
    return {
        "seed": seed,
        "outcome": _outcome(info),
        "steps": steps,
        "touchdown_speed": float(info["touchdown_speed"]),
        "pad_distance": float(info["pad_distance"]),
        "fuel_left_kg": fuel,
        "returns": totals,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50, help="episodes (seeds 0..N-1) per policy")
    parser.add_argument("--write", action="store_true", help="write experiments/results/rocket_landing_scripted.md")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = {policy: [fly(seed, policy) for seed in range(args.seeds)] for policy in POLICIES}
    seconds = time.perf_counter() - start
    load = os.getloadavg()[0]
    machine = (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average {load:.1f} at the end"
    )
    lines = [
        f"{args.seeds} seeds (0-{args.seeds - 1}) per policy; all the flights took {seconds:.0f} s ({machine})",
        "",
    ]
    lines += [
        "| policy | safe / fatal / ground / dome exit / time limit | touchdown speed of the safe landings [m/s] | fuel left [kg] | "
        + " | ".join(f"`{p}` return, mean ± std" for p in PRESETS)
        + " |",
        "|---|---|---|---|" + "---|" * len(PRESETS),
    ]
    for policy, runs in rows.items():
        counts = [sum(r["outcome"] == o for r in runs) for o in ("safe", "fatal", "ground", "dome exit", "time limit")]
        safe = [r["touchdown_speed"] for r in runs if r["outcome"] == "safe"]
        speed = f"{np.mean(safe):.2f} (max {np.max(safe):.2f})" if safe else "-"
        fuel = np.mean([r["fuel_left_kg"] for r in runs])
        returns = [np.array([r["returns"][p] for r in runs]) for p in PRESETS]
        lines.append(
            f"| {policy} | {' / '.join(map(str, counts))} | {speed} | {fuel:.2f} | "
            + " | ".join(f"{x.mean():.1f} ± {x.std():.1f}" for x in returns)
            + " |"
        )
    # the same start, a lander and the free fall: how often does each preset rank the landing higher?
    lines.append("")
    for policy in ("descent lander", "velocity lander", "raw-channel lander"):
        for p in PRESETS:
            better = sum(a["returns"][p] > b["returns"][p] for a, b in zip(rows[policy], rows["free fall"]))
            lines.append(
                f"- `{p}`: the {policy} returns more than the free fall from the same start in {better} of {args.seeds} starts"
            )
    text = "\n".join(lines)
    print(text)
    if args.write:
        RESULTS.write_text(
            "# Rocket-Landing flown by scripted controllers (`experiments/rocket_scripted_landing.py`)\n\n"
            + (__doc__ or "").split("\n\n", 1)[1].split("    python")[0].strip()
            + "\n\n"
            + text
            + "\n"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
