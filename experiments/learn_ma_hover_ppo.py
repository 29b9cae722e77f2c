"""Do 4 quadrotors sharing one PPO policy learn to hold their points, and how fast in wall-clock?

Trains what ``pyflyt train env=ma_quadx_hover algo=ppo`` trains (``conf/hparams/
ma_quadx_hover_ppo.yaml``: 4 agents, one shared policy), and every ``--probe-every``
agent-steps flies the current policy (deterministic) for ``--episodes`` seeded episodes
with the hover probe callback (``pyflyt_cli.studies.probes.HoverProbe``).

**The task's limits.**  By default every agent flies the single-agent QuadX-Hover
task's limits, read from ``conf/env/quadx_hover.yaml``: 10 s episodes and its 3 m
flight dome (around the origin; the agents start 1.41 m from it), so that each agent
learns what one single-agent run learns.  ``--reference-limits`` keeps the shipped
MAQuadX-Hover dome instead (the reference's 10 m; episodes stay 10 s): a drifting agent
then flies far before it is out, and the shared policy needs more agent-steps.
``--shipped`` changes nothing: ``pyflyt train env=ma_quadx_hover`` as shipped (the env
config with the shipped tuning's changes, if it makes any), the policy probed on the env
exactly as ``conf/env/ma_quadx_hover.yaml`` declares it (30 s episodes, 10 m dome).

**The swarm.**  ``--agents N`` trains N agents per world (``env.agents``; more than 4 need
``--layout grid``: 64 agents on a ring would spawn closer than the layout's spacing rule
allows), ``--backend batched`` trains on the batched backend (``train.n_envs`` worlds of N
agents, docs/batched.md), ``--downwash`` turns the agents' downwash on in training and in
the probes; ``--experiment FILE`` starts from a tuning file (``pyflyt train
experiment=FILE``, e.g. ``conf/experiment/ma_hover_swarm.yaml``).  The probes always fly
the PyBullet engine.  Each row also gives the CPU time of the training process until the
first hovering probe, the probes' own CPU taken out.

**Hovering** means, for every agent of every probe episode: no crash for the whole 10 s
and a mean distance to its own hover point below ``--max-distance`` (0.2 m).

Reported per seed: the first probe that hovers (agent-steps, wall-clock, and without the
probes' cost); across seeds: the IQM of the final policies' mean per-agent return with
its 95 % bootstrap interval (rliable).  The comparison asked for is *4 independent
single-agent runs*: ``--compare-single 0 1 2 3`` trains them afterwards in the same
process (QuadX-Hover's shipped PPO, probed the same way every ``--single-probe-every``
steps, each stopped at its first hovering probe) and adds the table of what four
hovering agents cost either way: steps and training wall-clock without the probes, IQM
with 95 % intervals, the single-agent figures four times one run's.  Results are appended to
``experiments/results/learn_ma_hover_ppo.md``; ``--set`` passes config overrides (e.g.
to try a tuning: ``--set algo.n_steps=256 algo.n_epochs=10``).

    python experiments/learn_ma_hover_ppo.py [--seeds 0 1 2] [--budget 400000] [--probe-every 40000] [--max-distance 0.2]
        [--reference-limits | --shipped] [--compare-single 0 1 2 3] [--set KEY=VALUE ...]
        [--agents 64 --layout grid --backend batched --downwash --experiment FILE]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pyflyt_cli.studies.probes import HoverProbe  # the probe callback and its criterion
from pyflyt_cli.studies.runs import hover_run as run_single
from pyflyt_cli.training import compose_config, train

RESULTS = Path(__file__).resolve().parent / "results" / "learn_ma_hover_ppo.md"
MAX_DISTANCE = 0.2  # [m], as learn_hover_ppo.py
EPISODE_SECONDS = 10.0  # the single-agent hover episode


def yaml_value(text: str):
    """An override's value as the config reads it (``true``, ``64``, ``grid``)."""
    import yaml

    return yaml.safe_load(text)


def single_agent_limits() -> dict[str, float]:
    """Episode length [s] and flight dome [m] of the single-agent QuadX-Hover task."""
    env = compose_config(env="quadx_hover", algo="ppo").env
    return {"max_duration_seconds": float(env.max_duration_seconds), "flight_dome_size": float(env.flight_dome_size)}


def declared_env():
    """``conf/env/ma_quadx_hover.yaml`` as declared: no tuning file's changes."""
    from pyflyt_engine.envs.config import load_env_config

    return load_env_config("ma_quadx_hover")


def hover_probe(model, env, episodes: int, seed: int) -> dict[str, float]:
    """Fly ``episodes`` episodes with every agent; survival, distances, mean per-agent return."""
    vec = model.get_vec_normalize_env()
    parallel = env.unwrapped.parallel
    points = np.array([a.hover_point for a in parallel.agent_list])
    survived, worst, mean_distance, returns = [], [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        done, total = False, 0.0
        distances: list[np.ndarray] = []
        alive_to_end = np.ones(len(points), dtype=bool)
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            alive_to_end &= ~info["agent_terminated"]
            positions = np.array([v.state.lin_pos for v in parallel.vehicles])
            distances.append(np.linalg.norm(positions - points, axis=1))
            done = terminated or truncated
        per_agent = np.mean(distances, axis=0)
        survived.append(bool(alive_to_end.all()))
        worst.append(float(per_agent.max()))
        mean_distance.append(float(per_agent.mean()))
        returns.append(total)
    return {
        "survived": float(np.mean(survived)),
        "worst_distance": float(np.max(worst)),
        "mean_distance": float(np.mean(mean_distance)),
        "mean_return": float(np.mean(returns)),
    }


def run(
    seed: int,
    budget: int,
    every: int,
    episodes: int,
    output: Path,
    extra: list[str],
    max_distance: float = MAX_DISTANCE,
    limits: dict[str, float] | None = None,
    probe_env=None,
    experiment: str | None = None,
) -> dict:
    limits = {"max_duration_seconds": EPISODE_SECONDS} if limits is None else limits
    overrides = [
        *(f"env.{key}={value}" for key, value in limits.items()),
        *extra,
        f"seed={seed}",
        f"train.output_dir={output}",
        "train.progress_bar=false",
        f"train.total_timesteps={budget}",
        "train.eval_freq=0",
    ]
    if experiment:
        overrides.insert(0, f"experiment={experiment}")
    cfg = compose_config(env="ma_quadx_hover", algo="ppo", overrides=overrides)
    probe = HoverProbe(
        cfg, every, episodes, max_distance=max_distance, probe_fn=hover_probe, unit="agent-steps", probe_env=probe_env
    )
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe])
    total = time.perf_counter() - start
    return {
        "seed": seed,
        "agents": len(cfg.env.resolved_agents()),
        "steps": result.num_timesteps,
        "hover_at": probe.hover_at,
        "final": probe.history[-1][2],
        "steps_per_second": result.num_timesteps / max(total - probe.probe_time, 1e-9),
        "wall": total,
        "backend": cfg.env.backend,
        "n_envs": cfg.train.n_envs,
    }


def hover_cost(row: dict) -> tuple[float, float, bool]:
    """Steps and training wall-clock (probes excluded) until the run hovered, or its whole run if it
    never did (the last flag)."""
    if row["hover_at"] is not None:
        steps, _, wall = row["hover_at"][:3]
        return float(steps), float(wall), True
    return float(row["steps"]), float(row["steps"] / row["steps_per_second"]), False


def comparison(rows: list[dict], singles: list[dict], iqm) -> list[str]:
    """The table of what N hovering agents cost: one shared-policy run against N single-agent runs
    (N x the single-agent IQM and its interval; and the sum of the first N single-agent runs)."""
    agents = rows[0]["agents"]
    shared = np.array([hover_cost(r)[:2] for r in rows])
    single = np.array([hover_cost(r)[:2] for r in singles])
    missed = sum(not hover_cost(r)[2] for r in rows + singles)
    est = {name: iqm({name: data[:, [0]]})[name] for name, data in (("shared", shared), ("single", single))}
    wall = {name: iqm({name: data[:, [1]]})[name] for name, data in (("shared", shared), ("single", single))}

    def cell(e, scale: float, unit: str, digits: int = 0) -> str:
        v, lo, hi = (scale * float(x[0]) for x in (e.value, e.low, e.high))
        return f"{v:,.{digits}f}{unit} [{lo:,.{digits}f}, {hi:,.{digits}f}]"

    lines = [
        "",
        (
            "Single-agent runs, the shipped QuadX-Hover PPO (`conf/hparams/quadx_hover_ppo.yaml`), probed the same "
            "way (stopped at their first hovering probe):"
        ),
        "",
        "| seed | hovers at [steps] | without probes [s] | training steps/s |",
        "|---|---|---|---|",
    ]
    for r in singles:
        steps, seconds, hovered = hover_cost(r)
        lines.append(
            f"| {r['seed']} | {steps:.0f}{'' if hovered else ' (did not hover)'} | {seconds:.0f} | {r['steps_per_second']:.0f} |"
        )
    lines += [
        "",
        f"{agents} hovering agents cost (IQM over seeds, 95 % bootstrap CI, rliable; single-agent: {agents} x the per-run IQM):",
        "",
        "| | steps until every agent hovers | training wall-clock until then, probes excluded [s] |",
        "|---|---|---|",
        f"| one run, {agents} agents, shared policy | {cell(est['shared'], 1, '')} agent-steps | {cell(wall['shared'], 1, '')} |",
        (
            f"| {agents} independent single-agent runs, one after the other | {cell(est['single'], agents, '')} steps | "
            f"{cell(wall['single'], agents, '')} |"
        ),
    ]
    if len(singles) >= agents:
        first = single[:agents].sum(axis=0)
        lines.append(f"| the first {agents} single-agent runs above, summed | {first[0]:,.0f} steps | {first[1]:.0f} |")
    if missed:
        lines.append(
            f"\n{missed} run(s) did not hover within their budget: counted at their whole run (a lower bound)."
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", type=int, default=400_000, help="agent-steps per run")
    parser.add_argument("--probe-every", type=int, default=40_000)
    parser.add_argument("--episodes", type=int, default=3, help="episodes per probe")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--set", nargs="*", default=[], help="config overrides, e.g. algo.n_epochs=10")
    parser.add_argument(
        "--max-distance", type=float, default=MAX_DISTANCE, help="hovering: mean distance below this [m]"
    )
    parser.add_argument(
        "--compare-single",
        type=int,
        nargs="*",
        default=[],
        metavar="SEED",
        help="then train single-agent QuadX-Hover runs (its shipped PPO) with these seeds, probed the same way",
    )
    parser.add_argument("--single-probe-every", type=int, default=5_000, help="steps between single-agent probes")
    parser.add_argument("--agents", type=int, default=None, help="agents per world (env.agents; default: the config's)")
    parser.add_argument("--layout", choices=["ring", "grid"], default=None, help="the task's spawn layout")
    parser.add_argument("--backend", choices=["pybullet", "batched", "auto"], default=None, help="env.backend")
    parser.add_argument("--downwash", action="store_true", help="the agents' downwash on (training and probes)")
    parser.add_argument("--experiment", default=None, help="a tuning file, as pyflyt train experiment=FILE")
    parser.add_argument(
        "--reference-limits",
        action="store_true",
        help="keep the shipped 10 m flight dome instead of the single-agent task's 3 m",
    )
    parser.add_argument(
        "--shipped",
        action="store_true",
        help="train as shipped and probe the env as conf/env/ma_quadx_hover.yaml declares it (30 s, 10 m dome)",
    )
    args = parser.parse_args()

    from pyflyt_cli.plotting.stats import iqm

    shipped = declared_env()
    if args.shipped:
        limits = {}
    elif args.reference_limits:
        limits = {"max_duration_seconds": EPISODE_SECONDS}
    else:
        limits = single_agent_limits()
    dome = limits.get("flight_dome_size", shipped.flight_dome_size)
    seconds = limits.get("max_duration_seconds", shipped.max_duration_seconds)

    env_set = []
    if args.agents is not None:
        env_set.append(f"env.agents={args.agents}")
    if args.layout is not None:
        env_set.append(f"env.task.layout={args.layout}")
    if args.backend is not None:
        env_set.append(f"env.backend={args.backend}")
    if args.downwash:
        env_set.append("env.downwash=true")
    args.set = [*env_set, *args.set]
    probe_changes = {
        k.split("=")[0].removeprefix("env.").removeprefix("task."): yaml_value(k.split("=", 1)[1])
        for k in env_set
        if not k.startswith("env.backend")
    }

    load_before = os.getloadavg()[0]
    cpu_before = time.process_time()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            print(f"seed {seed}:", flush=True)
            rows.append(
                run(
                    seed,
                    args.budget,
                    args.probe_every,
                    args.episodes,
                    Path(tmp),
                    args.set,
                    args.max_distance,
                    limits,
                    probe_env=declared_env().with_overrides(**probe_changes) if args.shipped else None,
                    experiment=args.experiment,
                )
            )
        singles = []
        for seed in args.compare_single:
            print(f"single-agent seed {seed}:", flush=True)
            single = run_single(
                seed,
                None,
                args.single_probe_every,
                args.episodes,
                Path(tmp) / "single",
                extra=["train.eval_freq=0"],
                stop_on_hover=True,
                max_distance=args.max_distance,
            )
            singles.append(single)
    load_after = os.getloadavg()[0]
    finals = np.array([[r["final"]["mean_return"]] for r in rows])
    estimate = iqm({"ppo_shared": finals})["ppo_shared"]
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} -- {platform.machine()}, {platform.python_version()}, "
            f"{rows[0]['agents']} agents, backend {rows[0]['backend']} ({rows[0]['n_envs']} env(s)), "
            f"downwash {'on' if args.downwash else 'off'}, budget {args.budget} agent-steps, "
            f"probe every {args.probe_every} x {args.episodes} episodes, "
            f"hovering below {args.max_distance} m, {seconds:g} s episodes, "
            f"{dome:g} m flight dome\n"
        ),
        f"Command: `python experiments/learn_ma_hover_ppo.py {' '.join(sys.argv[1:])}`\n",
        (
            "| seed | hovers at [agent-steps] | wall-clock then [s] | without probes [s] | CPU then, without probes [s] | "
            "final: all survived | final: mean / worst distance [m] | final: mean per-agent return | "
            "training agent-steps/s | run wall-clock [s] |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        h, f = r["hover_at"], r["final"]
        lines.append(
            f"| {r['seed']} | {h[0] if h else 'not within budget'} | {f'{h[1]:.0f}' if h else '-'} | "
            f"{f'{h[2]:.0f}' if h else '-'} | {f'{h[3]:.1f}' if h else '-'} | {100 * f['survived']:.0f} % | "
            f"{f['mean_distance']:.3f} / {f['worst_distance']:.3f} | {f['mean_return']:.1f} | "
            f"{r['steps_per_second']:.0f} | {r['wall']:.0f} |"
        )
    lines.append(
        f"\nIQM of the final mean per-agent return over {len(rows)} seeds (rliable, 95 % bootstrap CI): "
        f"{float(estimate.value[0]):.1f} [{float(estimate.low[0]):.1f}, {float(estimate.high[0]):.1f}]"
    )
    if singles:
        lines += comparison(rows, singles, iqm)
    lines.append(
        f"\nLoad average (1 min): {load_before:.1f} at the start, {load_after:.1f} at the end; CPU time of this "
        f"process {time.process_time() - cpu_before:.0f} s for the whole experiment (probes included)."
    )
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        if not RESULTS.exists():
            RESULTS.write_text(
                "# Four quadrotors, one shared PPO policy (experiments/learn_ma_hover_ppo.py)\n\n"
                "Hovering = for every agent of every probe episode (deterministic policy, 10 s): no crash and mean\n"
                "distance to its own hover point below 0.2 m.  Steps are agent-steps (4 per env step).\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
