"""Betaflight's firmware in the loop: real-time factor, cost against the project's own
controller, start-up cost and run-to-run repeatability -- the figures docs/firmware.md quotes.

Each case runs in a fresh process: QuadX-Hover (``controller=betaflight``: ACRO sticks, 1000
Hz physics and control, 50 Hz agent) flies ``--episodes`` episodes of seeded random sticks
around the hover stick, and the same env with the project's own controller at the same
loop rates (``rates_thrust``, random body rates around the hover thrust) does the same.
Wall time, this process's CPU time and the firmware processes' CPU time (children,
counted once each has been stopped) are printed per simulated second; the real-time factor
is simulated seconds over wall seconds.  Repeatability: the firmware case runs
``--repeats`` times, each in its own process, and the SHA-256 of every state of every step
is compared.  The load (``os.getloadavg``) is printed with the figures.

    python experiments/firmware_speed.py [--episodes 5] [--repeats 3]

Needs the patched SITL (python -m pyflyt_engine.firmware.build).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CASE = """
import hashlib, json, resource, time
import numpy as np
from pyflyt_engine.envs import make_env
controller, episodes = {controller!r}, {episodes}
if controller == "betaflight":
    env = make_env("quadx_hover", controller="betaflight")
else:
    env = make_env("quadx_hover", physics_hz=1000, control_hz=1000, agent_hz=50)
rng = np.random.default_rng(0)
digest = hashlib.sha256()
simulated = 0.0
start_wall, start_cpu = time.perf_counter(), time.process_time()
resets = 0.0
for episode in range(episodes):
    t = time.perf_counter()
    env.reset(seed=episode)
    vehicle = env.unwrapped.world.vehicles[0]
    if vehicle.firmware is not None:  # the firmware starts when first needed: start it here
        _ = vehicle.firmware.outputs
    resets += time.perf_counter() - t
    if controller == "betaflight":
        hover = [0.0, 0.0, 0.0, vehicle.hover_throttle()]
        scale = np.array([0.05, 0.05, 0.05, 0.02])
    else:
        hover = [0.0, 0.0, 0.0, vehicle.hover_throttle() ** 2]
        scale = np.array([0.3, 0.3, 0.3, 0.02])
    while True:
        action = np.asarray(hover) + scale * rng.standard_normal(4)
        obs, reward, terminated, truncated, info = env.step(action)
        simulated += 1.0 / env.unwrapped.config.agent_hz
        digest.update(np.asarray(env.unwrapped.world.vehicles[0].state.as_array()).tobytes())
        if terminated or truncated:
            break
wall, cpu = time.perf_counter() - start_wall, time.process_time() - start_cpu
env.close()
child = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({{"simulated_s": simulated, "wall_s": wall, "cpu_s": cpu, "resets_s": resets,
    "firmware_cpu_s": child.ru_utime + child.ru_stime, "digest": digest.hexdigest()}}))
"""


def run(controller: str, episodes: int) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", CASE.format(controller=controller, episodes=episodes)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    if done.returncode != 0:
        raise SystemExit(f"the {controller} case failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    load_before = os.getloadavg()
    firmware = [run("betaflight", args.episodes) for _ in range(args.repeats)]
    own = run("own", args.episodes)
    load_after = os.getloadavg()
    best = min(firmware, key=lambda r: r["wall_s"])
    print(f"load average (1, 5, 15 min) before {load_before}, after {load_after}; {os.cpu_count()} CPUs")
    for name, r in (("betaflight", best), ("own controller", own)):
        print(
            f"{name:15s} {r['simulated_s']:6.1f} simulated s in {r['wall_s']:6.2f} wall s: real-time factor "
            f"{r['simulated_s'] / r['wall_s']:6.1f}; CPU per simulated s: this process "
            f"{1e3 * r['cpu_s'] / r['simulated_s']:.1f} ms, firmware {1e3 * r['firmware_cpu_s'] / r['simulated_s']:.1f} ms"
        )
    print(f"betaflight resets (firmware start and arming): {1e3 * best['resets_s'] / args.episodes:.0f} ms each")
    digests = {r["digest"] for r in firmware}
    same = len(digests) == 1
    print(
        f"repeatability: {args.repeats} processes, {'bit-identical' if same else 'DIFFERENT'} states ({digests.pop()[:16]})"
    )
    walls = ", ".join(f"{r['wall_s']:.2f}" for r in firmware)
    print(f"wall time of the {args.repeats} betaflight runs: {walls} s")


if __name__ == "__main__":
    main()
