"""Rocket-Landing with a scripted controller: is the task feasible, and what do the rewards pay for it?

A hand-written controller (no learning) flies ``PyFlyt/Rocket-Landing-v0`` from its
seeded start states (450 m drop, +-20 m sideways, +-5 m/s, +-0.3 rad, +-0.5 rad/s, 1 %
fuel) and, for comparison, the same starts with the booster never lit (a free fall).
Each episode is flown once under each reward preset (the paper's dense reward, the
sparse one and the braking-envelope shaping) from the same seed; the script checks that
the flights are identical, so the presets' returns compare one flight.

The controller, in the ground frame:

1. *Aim* (above 120 m): the lateral velocity that carries the Rocket over the pad by
   the time it starts braking is ``-p_xy / T``; while the lateral velocity is more than
   1 m/s off it, lean the top toward the error (0.6 rad) and pulse the booster when
   leaning the right way (a 1/30 s pulse at minimum thrust, leaning 0.6 rad, adds
   ~0.4 m/s sideways).
2. *Fall* upright, the grid fins holding the attitude.
3. *Brake*: burn whenever falling faster than ``v_ref(h) = -sqrt(2 a (h - h_slow))``
   (a = 30 m/s^2), throttle proportional to the error; lean the thrust (up to 0.2 rad)
   to bring position and lateral velocity to zero; below ``h_slow`` = 2 m hold
   ``-v_land`` = 0.35 m/s by pulses (the minimum thrust exceeds the weight).
4. Booster out from the first pad contact.

Attitude: a PD law on the tilt error drives the fins (and the gimbal while lit); roll
rate is damped by the fins.

    python experiments/rocket_scripted_landing.py [--seeds 50] [--write]

``--write`` writes ``experiments/results/rocket_landing_scripted.md``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import gymnasium
import numpy as np

import pyflyt_engine.envs  # noqa: F401  (registers the envs)
from pyflyt_engine.frames import quaternion_to_matrix

ENV_ID = "PyFlyt/Rocket-Landing-v0"
G = 9.81
STAND = 1.82  # m: centre-of-mass height of the Rocket standing on the pad (0.1 m top face + 1.72 m)
MASS = 138.0 + 4.109  # kg: dry mass + 1 % of the 410.9 kg tank (conf/uav/rocket.yaml)
MIN_THRUST, MAX_THRUST = 2966.7, 7607.0  # N (conf/uav/rocket.yaml)
PRESETS = ("rocket_landing_dense", "rocket_landing_sparse", "rocket_landing_envelope")
RESULTS = Path(__file__).parent / "results" / "rocket_landing_scripted.md"


class ScriptedLander:
    """The controller described in the module docstring; ``__call__(obs) -> action``."""

    def __init__(self, a_brake=30.0, v_land=0.35, h_slow=2.0, lean_aim=0.6, lean_brake=0.2,
                 k_att=3.0, k_rate=1.2, k_roll=0.05, kp_lat=0.5, kd_lat=2.0):
        self.a_brake, self.v_land, self.h_slow = a_brake, v_land, h_slow
        self.lean_aim, self.lean_brake = lean_aim, lean_brake
        self.k_att, self.k_rate, self.k_roll, self.kp_lat, self.kd_lat = k_att, k_rate, k_roll, kp_lat, kd_lat
        self.landed = False
        self.aiming = True

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        omega, pos = obs[0:3], obs[10:13]
        body_to_ground = quaternion_to_matrix(obs[3:7])
        vel = body_to_ground @ obs[7:10]
        action = np.zeros(7)
        if self.landed or obs[-1] == 1.0:
            self.landed = True
            return action
        up = body_to_ground[:, 2]
        h, v_z = pos[2] - STAND, vel[2]
        # time until the braking burn starts (about 30 m above its ideal start), plus a margin
        h_burn = v_z * v_z / (2.0 * self.a_brake) + 30.0
        t_go = (v_z + math.sqrt(v_z * v_z + 2.0 * G * max(h - h_burn, 0.0))) / G + 1.5
        lean, burn, throttle = np.zeros(2), False, 0.0
        miss = -pos[:2] / t_go - vel[:2]
        if h > 120.0:
            if np.linalg.norm(miss) > 1.0:
                self.aiming = True
            elif np.linalg.norm(miss) < 0.2:
                self.aiming = False
            if self.aiming:
                lean = self.lean_aim * miss / np.linalg.norm(miss)
                burn = float(up[:2] @ miss) / np.linalg.norm(miss) > 0.3
        v_ref = -max(self.v_land, math.sqrt(2.0 * self.a_brake * max(h - self.h_slow, 0.0)))
        error = v_ref - v_z
        if error > 0.05:
            burn = True
            thrust = MASS * (G + 8.0 * error) / max(up[2], 0.5)
            throttle = float(np.clip((thrust - MIN_THRUST) / (MAX_THRUST - MIN_THRUST), 0.0, 1.0))
            want = -self.kp_lat * pos[:2] - self.kd_lat * vel[:2]
            n = np.linalg.norm(want)
            lean = min(n / 20.0, self.lean_brake) * want / n if n > 1e-9 and h > 1.0 else np.zeros(2)
        elif h <= 120.0:
            lean = np.zeros(2)
        if burn:
            action[3], action[4] = 1.0, throttle
        target = np.array([lean[0], lean[1], 1.0])
        target /= np.linalg.norm(target)
        axis = body_to_ground.T @ np.cross(up, target)  # in the body frame
        moment = self.k_att * axis[:2] - self.k_rate * omega[:2]
        action[0:2] = np.clip(moment, -1.0, 1.0)  # fins: + moment about body x, y
        action[2] = np.clip(-self.k_roll * omega[2], -1.0, 1.0)
        action[5:7] = np.clip(-moment, -1.0, 1.0)  # gimbal: + angle gives - moment
        return action


def _outcome(info: dict) -> str:
    for key, name in (("safe_landing", "safe"), ("fatal_landing", "fatal"), ("ground_contact", "ground"),
                      ("out_of_bounds", "dome exit")):
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
            env = gymnasium.make(ENV_ID, reward=preset)
        obs, _ = env.reset(seed=seed)
        lander = ScriptedLander()
        total, steps = 0.0, 0
        while True:
            action = lander(obs) if policy == "scripted" else np.zeros(7)
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
    return {"seed": seed, "outcome": _outcome(info), "steps": steps, "touchdown_speed": float(info["touchdown_speed"]),
            "pad_distance": float(info["pad_distance"]), "fuel_left_kg": fuel, "returns": totals}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50, help="episodes (seeds 0..N-1) per policy")
    parser.add_argument("--write", action="store_true", help="write experiments/results/rocket_landing_scripted.md")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = {policy: [fly(seed, policy) for seed in range(args.seeds)] for policy in ("scripted", "free fall")}
    seconds = time.perf_counter() - start
    lines = [f"{args.seeds} seeds (0-{args.seeds - 1}) per policy; all the flights took {seconds:.0f} s", ""]
    lines += ["| policy | safe / fatal / ground / dome exit / time limit | touchdown speed of the safe landings [m/s] | fuel left [kg] | "
              + " | ".join(f"`{p}` return, mean ± std" for p in PRESETS) + " |",
              "|---|---|---|---|" + "---|" * len(PRESETS)]
    for policy, runs in rows.items():
        counts = [sum(r["outcome"] == o for r in runs) for o in ("safe", "fatal", "ground", "dome exit", "time limit")]
        safe = [r["touchdown_speed"] for r in runs if r["outcome"] == "safe"]
        speed = f"{np.mean(safe):.2f} (max {np.max(safe):.2f})" if safe else "-"
        fuel = np.mean([r["fuel_left_kg"] for r in runs])
        returns = [np.array([r["returns"][p] for r in runs]) for p in PRESETS]
        lines.append(f"| {policy} | {' / '.join(map(str, counts))} | {speed} | {fuel:.2f} | "
                     + " | ".join(f"{x.mean():.1f} ± {x.std():.1f}" for x in returns) + " |")
    # the same start, both policies: how often does each preset rank the scripted flight higher?
    lines.append("")
    for p in PRESETS:
        better = sum(a["returns"][p] > b["returns"][p] for a, b in zip(rows["scripted"], rows["free fall"]))
        lines.append(f"- `{p}`: the scripted flight returns more than the free fall from the same start in {better} of {args.seeds} starts")
    text = "\n".join(lines)
    print(text)
    if args.write:
        RESULTS.write_text(
            "# Rocket-Landing flown by a scripted controller (`experiments/rocket_scripted_landing.py`)\n\n"
            + (__doc__ or "").split("\n\n", 1)[1].split("    python")[0].strip() + "\n\n" + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
