"""How well do the scripted QuadX oracles fly QuadX-Obstacles and QuadX-Gates (from state)?

The oracles (``pyflyt_engine/envs/oracles.py``) are what the shipped tunings of
``env=quadx_obstacles`` and ``env=quadx_gates_state`` imitate (DAgger, ``train.imitation``)
before reinforcement learning:

* ``quadx_forest_navigator`` on ``conf/env/quadx_obstacles.yaml``: picks, from the LiDAR
  returns, the free heading nearest the goal's;
* ``quadx_gate_racer`` on ``conf/env/quadx_gates_state.yaml``: closes on the next gate's
  axis, read from its 4 corners, while flying along it.

Each flies ``--episodes`` seeded episodes (seeds 10 000+: the probes' forests, goals and
courses of ``learn_obstacles.py`` and ``learn_gates.py``) through those scripts' own probe
functions, on the env as an agent sees it (flattened observation, actions in [-1, 1]),
and the table gives the success fraction, the endings and, for the gates, the fractions
passing at least 1..5 gates.  ``--write`` replaces ``experiments/results/quadx_scripted.md``.

    python experiments/quadx_scripted.py [--episodes 50] [--write]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from pyflyt_cli.studies.probes import (
    PROBE_SEED,
    gates_probe,
    obstacle_probe,
)  # the probes the learning runs are measured by

from pyflyt_cli.training import compose_config
from pyflyt_cli.training.envs import EnvFactory
from pyflyt_cli.training.imitation import agent_units
from pyflyt_engine.envs.oracles import make_oracle

RESULTS = Path(__file__).resolve().parent / "results" / "quadx_scripted.md"
#: (env config, oracle, probe function)
CASES = (
    ("quadx_obstacles", "quadx_forest_navigator", obstacle_probe),
    ("quadx_gates_state", "quadx_gate_racer", gates_probe),
)


class OraclePolicy:
    """An oracle behind a trained policy's interface (``predict``, no normaliser), in the agent's
    action units."""

    def __init__(self, name: str, env) -> None:
        self.oracle, self.to_agent = make_oracle(name, env), agent_units(env)

    def get_vec_normalize_env(self):
        return None

    def predict(self, obs, deterministic: bool = True):
        return self.to_agent(self.oracle(obs)).astype(np.float32), None


def fly(env_name: str, oracle: str, probe, episodes: int) -> dict:
    """The probe's measures of ``oracle`` on ``env_name`` over ``episodes`` seeded episodes."""
    env = EnvFactory(compose_config(env=env_name, algo="ppo").env, monitor=False)()
    try:
        started = time.perf_counter()
        out = probe(OraclePolicy(oracle, env), env, episodes, seed=PROBE_SEED)
        out["seconds"] = time.perf_counter() - started
    finally:
        env.close()
    return out


def report(results: list[tuple[str, str, dict]], episodes: int) -> list[str]:
    lines = [
        "# The scripted QuadX oracles on QuadX-Obstacles and QuadX-Gates (experiments/quadx_scripted.py)",
        "",
        (
            f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.machine()}, {os.cpu_count()} CPUs, "
            f"Python {platform.python_version()}; {episodes} episodes each, seeds {PROBE_SEED}-"
            f"{PROBE_SEED + episodes - 1} (the learning runs' probe seeds), flown on the env as an agent sees it."
        ),
        "",
        "```bash",
        f"python experiments/quadx_scripted.py --episodes {episodes} --write",
        "```",
        "",
        "| env | oracle | success [%] | endings | >= 1..5 gates [%] | mean episode [s] |",
        "|---|---|---|---|---|---|",
    ]
    for env_name, oracle, out in results:
        gates = " / ".join(f"{100 * a:.0f}" for a in out["at_least"]) if "at_least" in out else "-"
        length = f"{out['mean_length']:.1f}" if "mean_length" in out else "-"
        lines.append(
            f"| {env_name} | {oracle} | {100 * out['success']:.0f} | "
            f"{', '.join(f'{k} {v}' for k, v in out['endings'].items())} | {gates} | {length} |"
        )
    lines += [
        "",
        (
            "Success: QuadX-Obstacles, the goal reached without any contact; QuadX-Gates, at least 3 gates "
            "passed in order (the learning target's measure; `>= 5` is the whole course)."
        ),
    ]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--write", action="store_true", help=f"replace {RESULTS.name}")
    args = parser.parse_args()
    results = []
    for env_name, oracle, probe in CASES:
        out = fly(env_name, oracle, probe, args.episodes)
        print(
            f"{env_name} {oracle}: success {100 * out['success']:.0f} % {out['endings']} ({out['seconds']:.0f} s)",
            flush=True,
        )
        results.append((env_name, oracle, out))
    lines = report(results, args.episodes)
    print("\n".join(lines))
    if args.write:
        RESULTS.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
