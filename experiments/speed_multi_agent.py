"""Agent-steps per second of the multi-agent envs against the number of agents, beside the reference PyFlyt's.

Cases: MAQuadX-Hover with N = 1, 2, 4, ..., 128 agents on a square grid 1 m apart at 1 m
(the ``grid`` layout; the reference's ``MAQuadXHoverEnvV2`` is given the same start
positions), MAFixedwing-Dogfight 1 v 1 and 2 v 2 (the reference's
``MAFixedwingDogfightEnvV2`` with ``team_size`` 1 and 2), and MAQuadX-Formation (ours
only: the reference has no swarm task; downwash on).  Both packages are timed by the same
protocol, :func:`pyflyt_cli.speed.protocols.time_parallel_env` (the file needs only the
standard library, so the reference's interpreter loads it by its path): every live agent
takes a uniformly random action from its own action space, the env resets when no agent is
left (resets included, as in training), agent rate 30 Hz in both.  Figures per case:

* agent-steps/s -- live agents stepped per wall second (the unit training counts), and per
  CPU second of the timing process (``--cpu-time`` ratios: on a machine other jobs load,
  wall time counts their share too);
* RTF -- simulated seconds per wall second;
* ours / reference per agent-step.

The reference (PyFlyt 0.29.0) runs in its own interpreter (it pins numpy < 2), given by
``--reference-python`` (default $PYFLYT_REFERENCE_PYTHON, or ``/work/refvenv/bin/python``
when it exists); this script runs itself there with ``--case``.  Without one, only our
figures are printed.  Each case is timed ``--repeats`` times, ours then the reference's,
alternately; the median is kept.  Each N times about ``--agent-steps`` agent-steps (at
least ``--min-steps`` env steps).

    python experiments/speed_multi_agent.py [--agent-steps 3000] [--repeats 3] [--markdown] [--cases hover:8 dogfight:2]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROTOCOLS = ROOT / "pyflyt_cli" / "speed" / "protocols.py"
SIZES = (1, 2, 4, 8, 16, 32, 64, 128)
CASES = [("hover", n) for n in SIZES] + [("dogfight", 1), ("dogfight", 2)] + [("formation", n) for n in SIZES]
DEFAULT_REFERENCE = "/work/refvenv/bin/python"
AGENT_HZ = 30


def _protocols():
    spec = importlib.util.spec_from_file_location("speed_protocols", PROTOCOLS)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _label(kind: str, size: int) -> str:
    if kind == "dogfight":
        return f"MAFixedwing-Dogfight {size}v{size}"
    return f"MAQuadX-{'Hover' if kind == 'hover' else 'Formation'} N={size}"


def _agents(kind: str, size: int) -> int:
    return 2 * size if kind == "dogfight" else size


def ours(kind: str, size: int, steps: int, seed: int) -> dict:
    from pyflyt_cli.speed import probes

    env = probes.swarm_env(kind, _agents(kind, size))
    try:
        return probes.protocols.time_parallel_env(env, AGENT_HZ, steps, warmup=max(2, steps // 10), seed=seed)
    finally:
        env.close()


def reference(kind: str, size: int, steps: int, seed: int) -> dict:
    """Runs inside the reference interpreter (``--case``)."""
    import numpy as np

    protocols = _protocols()
    if kind == "hover":
        from PyFlyt.pz_envs import MAQuadXHoverEnvV2

        start = np.array(protocols.centred_grid(size, protocols.GRID_SPACING, 1.0))
        env = MAQuadXHoverEnvV2(start_pos=start, start_orn=np.zeros((size, 3)), agent_hz=AGENT_HZ)
    elif kind == "dogfight":
        from PyFlyt.pz_envs import MAFixedwingDogfightEnvV2

        env = MAFixedwingDogfightEnvV2(team_size=size, agent_hz=AGENT_HZ)
    else:
        raise SystemExit(f"the reference has no {kind} env")
    try:
        return protocols.time_parallel_env(env, AGENT_HZ, steps, warmup=max(2, steps // 10), seed=seed)
    finally:
        env.close()


def level(size: int, downwash: bool, steps: int) -> dict:
    """MAQuadX-Formation with every agent holding its slot height level (a proportional
    attitude and height hold instead of random actions: the swarm stays at one height, as a
    formation flies), downwash on or off: process CPU time per agent-step and the wake
    sources visited per vehicle read."""
    import time

    from pyflyt_engine.envs.multi_agent import ma_quadx_formation_v0

    env = ma_quadx_formation_v0.parallel_env(agents=size, downwash=downwash, velocity=(0.0, 0.0, 0.0))
    env.reset(seed=0)
    index, vehicles, height = env.agent_index, env.vehicles, env.config.task.layout_height

    def hold() -> dict:
        actions = {}
        for name in env.agents:
            state = vehicles[index[name]].state
            roll, pitch, _ = state.ang_pos
            thrust = 0.125 + 0.3 * (height - state.lin_pos[2]) - 0.15 * state.lin_vel_ground[2]  # 0.125: cf2x hover
            actions[name] = [-3.0 * roll, -3.0 * pitch, 0.0, min(max(thrust, 0.0), 1.0)]
        return actions

    rotors = env.world.rotor_interactions
    visited = [0]
    if rotors is not None:
        sources = rotors.sources

        def counting(index, position):
            found = sources(index, position)
            visited[0] += len(found)
            return found

        rotors.sources = counting
    for _ in range(5):
        env.step(hold())
    visited[0] = 0
    start = time.process_time()
    agent_steps = 0
    for _ in range(steps):
        if not env.agents:
            env.reset()
        agent_steps += len(env.agents)
        env.step(hold())
    cpu = time.process_time() - start
    env.close()
    return {
        "agents": size,
        "downwash": downwash,
        "cpu_us_per_agent_step": 1e6 * cpu / agent_steps,
        "sources_per_vehicle_read": visited[0] / (agent_steps * 8),
        "live_fraction": agent_steps / (steps * size),
    }


def _reference_python(given: str | None) -> str | None:
    for candidate in (given, os.environ.get("PYFLYT_REFERENCE_PYTHON"), DEFAULT_REFERENCE):
        if candidate and Path(candidate).is_file():
            return candidate
    return None


def _run_reference(python: str, kind: str, size: int, steps: int, seed: int) -> dict:
    code = [python, str(Path(__file__).resolve()), "--case", kind, str(size), str(steps), str(seed)]
    out = subprocess.run(code, capture_output=True, text=True, check=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _run_ours(kind: str, size: int, steps: int, seed: int) -> dict:
    """Ours in a fresh process too, so neither side inherits the other's warm caches or memory."""
    code = [sys.executable, str(Path(__file__).resolve()), "--ours", kind, str(size), str(steps), str(seed)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}
    out = subprocess.run(code, capture_output=True, text=True, check=True, cwd=ROOT, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent-steps", type=int, default=3000, help="agent-steps timed per case (about)")
    parser.add_argument("--min-steps", type=int, default=20, help="env steps timed per case at least")
    parser.add_argument("--repeats", type=int, default=3, help="timings per case and package (median kept)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--reference-python", default=None, help="interpreter with PyFlyt 0.29.0 installed")
    parser.add_argument("--no-reference", action="store_true", help="time only this package")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    parser.add_argument("--cases", nargs="+", default=None, help="only these cases, KIND:SIZE (hover:4 dogfight:2)")
    parser.add_argument("--case", nargs=4, metavar=("KIND", "SIZE", "STEPS", "SEED"), help=argparse.SUPPRESS)
    parser.add_argument("--ours", nargs=4, metavar=("KIND", "SIZE", "STEPS", "SEED"), help=argparse.SUPPRESS)
    parser.add_argument(
        "--level",
        action="store_true",
        help="instead: a level formation with and without "
        "downwash, CPU us per agent-step and wake sources visited, against N (ours only)",
    )
    parser.add_argument("--level-run", nargs=3, metavar=("SIZE", "DOWNWASH", "STEPS"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.level_run:
        print(json.dumps(level(int(args.level_run[0]), args.level_run[1] == "1", int(args.level_run[2]))))
        return 0
    if args.level:
        print("| agents | downwash | CPU us / agent-step | wake sources per vehicle read | live |")
        print("|---:|---|---:|---:|---:|")
        for size in SIZES[1:]:
            for downwash in (False, True):
                steps = min(150, max(args.min_steps, -(-args.agent_steps // size)))  # 5 s at most: level flight
                code = [
                    sys.executable,
                    str(Path(__file__).resolve()),
                    "--level-run",
                    str(size),
                    str(int(downwash)),
                    str(steps),
                ]
                env = {
                    **os.environ,
                    "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
                }
                runs = [json.loads(subprocess.run(code, capture_output=True, text=True, check=True, cwd=ROOT, env=env)
                                   .stdout.strip().splitlines()[-1]) for _ in range(args.repeats)]  # fmt: skip
                us = statistics.median(r["cpu_us_per_agent_step"] for r in runs)
                print(
                    f"| {size} | {'on' if downwash else 'off'} | {us:,.0f} | {runs[0]['sources_per_vehicle_read']:.2f} | "
                    f"{100 * runs[0]['live_fraction']:.0f}% |",
                    flush=True,
                )
        print(
            f"\nlevel formation 1 m apart at 1.5 m, attitude and height hold; about {args.agent_steps} agent-steps x {args.repeats} "
            f"repeats (median), process CPU time; load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}"
        )
        return 0
    if args.case or args.ours:  # one timing, in its own process
        kind, size, steps, seed = (args.case or args.ours)[0], *map(int, (args.case or args.ours)[1:])
        print(json.dumps((reference if args.case else ours)(kind, size, steps, seed)))
        return 0
    if args.agent_steps < 1 or args.repeats < 1 or args.min_steps < 1:
        parser.error("--agent-steps, --min-steps and --repeats must be >= 1")
    cases = CASES
    if args.cases:
        try:
            cases = [(c.split(":")[0], int(c.split(":")[1])) for c in args.cases]
        except (IndexError, ValueError):
            parser.error("--cases takes KIND:SIZE entries, e.g. hover:4 dogfight:2")
        unknown = [c for c in cases if c not in CASES]
        if unknown:
            parser.error(f"unknown case(s) {unknown}; known: {' '.join(f'{k}:{n}' for k, n in CASES)}")
    python = None if args.no_reference else _reference_python(args.reference_python)
    load_before = os.getloadavg()
    rows = []
    for kind, size in cases:
        steps = max(args.min_steps, -(-args.agent_steps // _agents(kind, size)))
        mine, theirs = [], []
        for r in range(args.repeats):
            mine.append(_run_ours(kind, size, steps, args.seed + r))
            if python and kind != "formation":
                theirs.append(_run_reference(python, kind, size, steps, args.seed + r))
            print(f"{_label(kind, size)} repeat {r + 1}/{args.repeats}", file=sys.stderr, flush=True)

        def med(results: list[dict], key: str) -> float | None:
            return statistics.median(x[key] for x in results) if results else None

        rows.append(
            (
                _label(kind, size),
                _agents(kind, size),
                {
                    k: med(mine, k)
                    for k in ("agent_steps_per_s", "agent_steps_per_cpu_s", "rtf", "cpu_rtf", "live_fraction")
                },
                {
                    k: med(theirs, k)
                    for k in ("agent_steps_per_s", "agent_steps_per_cpu_s", "rtf", "cpu_rtf", "live_fraction")
                },
            )
        )

    def fmt(v: float | None, digits: int = 0) -> str:
        return "-" if v is None else f"{v:,.{digits}f}"

    def ratio(a: float | None, b: float | None) -> str:
        return f"{a / b:.1f}x" if a and b else "-"

    head = ["case", "agents", "ours agent-steps/s", "ours us/agent-step", "ours RTF", "ours RTF (CPU)", "ours live",
            "reference agent-steps/s", "reference RTF", "ratio (wall)", "ratio (CPU)"]  # fmt: skip
    lines = []
    if args.markdown:
        lines += ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for label, agents, m, t in rows:
        cells = [label, str(agents), fmt(m["agent_steps_per_s"]), fmt(1e6 / m["agent_steps_per_s"]), fmt(m["rtf"], 2), fmt(m["cpu_rtf"], 2),
                 f"{100 * m['live_fraction']:.0f}%", fmt(t["agent_steps_per_s"]), fmt(t["rtf"], 2),
                 ratio(m["agent_steps_per_s"], t["agent_steps_per_s"]),
                 ratio(m["agent_steps_per_cpu_s"], t["agent_steps_per_cpu_s"])]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |" if args.markdown else "  ".join(f"{c:>14}" for c in cells))
    print("\n".join(lines))
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    print(
        f"\n{cpu}, {os.cpu_count()} cores; random actions for every live agent, agent 30 Hz, about "
        f"{args.agent_steps} agent-steps (at least {args.min_steps} env steps) x {args.repeats} repeats (median), "
        f"each timing in a fresh process; reference: {python or 'not available'}; load average "
        f"{' '.join(f'{x:.1f}' for x in load_before)} at start, {' '.join(f'{x:.1f}' for x in os.getloadavg())} at end"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
