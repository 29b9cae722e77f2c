"""Steps per second of the multi-agent envs, beside the reference PyFlyt's, on this machine.

Cases: MAQuadX-Hover with N = 2, 4, 8 agents and MAFixedwing-Dogfight 1 v 1 and 2 v 2.
Each env is stepped with uniformly random actions for every live agent (agent rate
30 Hz in both packages, i.e. 8 physics steps per env step), resetting whenever the
episode ends (resets included in the timing, as in training).  Figures:

* env steps/s -- parallel ``step`` calls per second;
* agent-steps/s -- live agents stepped per second (the unit training counts);
* the ratio ours / reference per agent-step.

The reference (PyFlyt 0.29.0: ``MAQuadXHoverEnv``, ``MAFixedwingDogfightEnv`` with
``team_size`` 1 and 2, agent_hz set to 30) runs in its own interpreter, given by
``--reference-python`` (default ``/work/refvenv/bin/python`` when it exists, or
$PYFLYT_REFERENCE_PYTHON); without one, only our figures are printed.  Each case is
timed ``--repeats`` times alternately in both packages; the median is kept.  With
``--cpu-time`` the timings are the CPU time of the timing process (``time.process_time``)
instead of wall time: on a machine other jobs load, wall time counts their share too, the
process's own CPU time much less so.  ``--cases`` picks some cases (e.g. ``dogfight:2``);
``--no-reference`` times only this package (e.g. two checkouts before and after a change).

    python experiments/speed_multi_agent.py [--steps 1500] [--repeats 3] [--markdown] [--cpu-time]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

CASES = [("hover", 2), ("hover", 4), ("hover", 8), ("dogfight", 1), ("dogfight", 2)]
DEFAULT_REFERENCE = "/work/refvenv/bin/python"


def _label(kind: str, size: int) -> str:
    return f"MAQuadX-Hover N={size}" if kind == "hover" else f"MAFixedwing-Dogfight {size}v{size}"


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def time_env(env, steps: int, seed: int, clock: str = "wall") -> tuple[float, float]:
    """(env steps/s, agent-steps/s) over ``steps`` parallel steps with random actions,
    timed by the ``clock`` named in :data:`CLOCKS`."""
    now = CLOCKS[clock]
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    first = env.possible_agents[0]
    low, high = env.action_space(first).low, env.action_space(first).high
    low = np.where(np.isfinite(low), low, -1.0)
    high = np.where(np.isfinite(high), high, 1.0)

    def run(n: int) -> int:
        agent_steps = 0
        for _ in range(n):
            if not env.agents:
                env.reset()
            agent_steps += len(env.agents)
            env.step({a: rng.uniform(low, high) for a in env.agents})
        return agent_steps

    run(50)  # warm up
    start = now()
    agent_steps = run(steps)
    elapsed = now() - start
    return steps / elapsed, agent_steps / elapsed


def ours(kind: str, size: int, steps: int, seed: int, clock: str = "wall") -> tuple[float, float]:
    from pyflyt_engine.envs.multi_agent import ma_fixedwing_dogfight_v0, ma_quadx_hover_v0

    env = (
        ma_quadx_hover_v0.parallel_env(agents=size)
        if kind == "hover"
        else ma_fixedwing_dogfight_v0.parallel_env(agents=2 * size)
    )
    try:
        return time_env(env, steps, seed, clock)
    finally:
        env.close()


def reference(kind: str, size: int, steps: int, seed: int, clock: str = "wall") -> tuple[float, float]:
    """Runs inside the reference interpreter (``--case``)."""
    if kind == "hover":
        from PyFlyt.pz_envs import MAQuadXHoverEnvV2

        angles = 2 * np.pi * np.arange(size) / size
        start = (
            np.stack((np.cos(angles), np.sin(angles), np.ones(size)), axis=1)
            if size > 1
            else np.array([[0.0, 0.0, 1.0]])
        )
        env = MAQuadXHoverEnvV2(start_pos=start, start_orn=np.zeros((size, 3)), agent_hz=30)
    else:
        from PyFlyt.pz_envs import MAFixedwingDogfightEnvV2

        env = MAFixedwingDogfightEnvV2(team_size=size, agent_hz=30)
    try:
        return time_env(env, steps, seed, clock)
    finally:
        env.close()


def _reference_python(given: str | None) -> str | None:
    for candidate in (given, os.environ.get("PYFLYT_REFERENCE_PYTHON"), DEFAULT_REFERENCE):
        if candidate and Path(candidate).is_file():
            return candidate
    return None


def _run_reference(python: str, kind: str, size: int, steps: int, seed: int, clock: str) -> tuple[float, float]:
    code = [python, str(Path(__file__).resolve()), "--case", kind, str(size), str(steps), str(seed), clock]
    out = subprocess.run(code, capture_output=True, text=True, check=True, cwd="/")
    return tuple(json.loads(out.stdout.strip().splitlines()[-1]))  # type: ignore[return-value]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1500, help="parallel env steps per timing")
    parser.add_argument("--repeats", type=int, default=3, help="timings per case and package (median kept)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--reference-python", default=None, help="interpreter with PyFlyt 0.29.0 installed")
    parser.add_argument("--no-reference", action="store_true", help="time only this package")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    parser.add_argument("--cpu-time", action="store_true", help="time with process CPU time instead of wall time")
    parser.add_argument("--cases", nargs="+", default=None, help="only these cases, KIND:SIZE (hover:4 dogfight:2)")
    parser.add_argument("--case", nargs=5, metavar=("KIND", "SIZE", "STEPS", "SEED", "CLOCK"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.case:  # inside the reference interpreter
        kind, size, steps, seed, clock = (
            args.case[0],
            int(args.case[1]),
            int(args.case[2]),
            int(args.case[3]),
            args.case[4],
        )
        print(json.dumps(reference(kind, size, steps, seed, clock)))
        return 0
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    clock = "cpu" if args.cpu_time else "wall"
    cases = CASES
    if args.cases:
        try:
            cases = [(c.split(":")[0], int(c.split(":")[1])) for c in args.cases]
        except (IndexError, ValueError):
            parser.error("--cases takes KIND:SIZE entries, e.g. hover:4 dogfight:2")
        unknown = [c for c in cases if c not in CASES]
        if unknown:
            parser.error(f"unknown case(s) {unknown}; known: {' '.join(f'{k}:{n}' for k, n in CASES)}")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    python = None if args.no_reference else _reference_python(args.reference_python)
    rows = []
    for kind, size in cases:
        mine, theirs = [], []
        for r in range(args.repeats):
            mine.append(ours(kind, size, args.steps, args.seed + r, clock))
            if python:
                theirs.append(_run_reference(python, kind, size, args.steps, args.seed + r, clock))
        m_env = statistics.median(x[0] for x in mine)
        m_agent = statistics.median(x[1] for x in mine)
        r_env = statistics.median(x[0] for x in theirs) if theirs else None
        r_agent = statistics.median(x[1] for x in theirs) if theirs else None
        rows.append((_label(kind, size), m_env, m_agent, r_env, r_agent))

    def fmt(v: float | None) -> str:
        return "-" if v is None else f"{v:,.0f}"

    head = [
        "case",
        "ours env steps/s",
        "ours agent-steps/s",
        "reference env steps/s",
        "reference agent-steps/s",
        "ratio per agent-step",
    ]
    lines = []
    if args.markdown:
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    else:
        lines.append(f"{head[0]:<28}" + "".join(f"{h:>26}" for h in head[1:]))
    for label, m_env, m_agent, r_env, r_agent in rows:
        ratio = f"{m_agent / r_agent:.1f}x" if r_agent else "-"
        cells = [label, fmt(m_env), fmt(m_agent), fmt(r_env), fmt(r_agent), ratio]
        lines.append(
            "| " + " | ".join(cells) + " |"
            if args.markdown
            else f"{cells[0]:<28}" + "".join(f"{c:>26}" for c in cells[1:])
        )
    print("\n".join(lines))
    print(
        f"\n{platform.processor() or platform.machine()}, {os.cpu_count()} cores; random actions, agent 30 Hz, "
        f"{args.steps} steps x {args.repeats} repeats (median), {'CPU' if args.cpu_time else 'wall'} time; "
        f"reference: {python or 'not available'}; load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
