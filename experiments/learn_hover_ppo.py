"""Does the shipped QuadX-Hover configuration learn to hover, and how fast?

Trains exactly what ``pyflyt train`` (no overrides) trains — ``conf/train.yaml`` with
``env=quadx_hover algo=ppo`` and its tuning ``conf/hparams/quadx_hover_ppo.yaml`` — at
the shipped budget (or ``--budget``), and every ``--probe-every`` steps flies the current
policy (deterministic) for ``--episodes`` seeded episodes.  **Hovering** (the issue's
target) means, in every episode: no crash for the whole 10 s episode (it reaches the time
limit) and a mean distance to the hover point (0, 0, 1) m below 0.1 m.

Reported: the first probe at which the policy hovers (environment steps, wall-clock
time of the run so far, and that time without the probes' own cost), the training
throughput, the final policy's numbers, and the IQM over the seeds with 95 % stratified-
bootstrap intervals (rliable, through ``pyflyt_cli.plotting.stats``).  Results are
appended to ``experiments/results/learn_hover_ppo.md``; the curve goes to
``learn_hover_ppo.png`` and the raw probes to ``learn_hover_ppo.json``.

    python experiments/learn_hover_ppo.py [--seeds 0 1 2] [--budget N] [--probe-every 5000]

Searching: ``--set key=value ...`` adds training overrides to every run, ``--algo`` picks
another algorithm, ``--stop-on-hover`` ends a run at its first hovering probe and
``--no-write`` leaves the results alone (how the shipped tuning was chosen).

Yardstick (task brief): the reference PyFlyt QuadX-Hover with SB3 PPO defaults hovers
after ~160-200k steps, 250-310 s on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from pyflyt_cli.training import compose_config, train
from pyflyt_cli.training.envs import EnvFactory

RESULTS = Path(__file__).resolve().parent / "results" / "learn_hover_ppo.md"
MAX_DISTANCE = 0.1  # [m], the hovering target


def hover_probe(model, env, episodes: int, seed: int) -> dict[str, float]:
    """Fly ``episodes`` episodes; crash-free fraction, mean distance to the hover point, return."""
    vec = model.get_vec_normalize_env()
    base = env.unwrapped
    point = np.asarray(base.task.options.hover_point)
    survived, distances, returns = [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        done, total, dist = False, 0.0, []
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            dist.append(float(np.linalg.norm(base.state.lin_pos - point)))
            done = terminated or truncated
        survived.append(truncated and not terminated)
        distances.append(float(np.mean(dist)))
        returns.append(total)
    return {
        "survived": float(np.mean(survived)),
        "worst_distance": float(np.max(distances)),
        "mean_distance": float(np.mean(distances)),
        "mean_return": float(np.mean(returns)),
    }


class HoverProbe(BaseCallback):
    """Every ``every`` steps: fly ``probe_fn`` (default :func:`hover_probe`) on a fresh env of
    ``cfg`` (or of ``probe_env``, an env config, when the policy is probed on another env than
    it trains on); remember the first step whose probe hovers (every episode survived, worst mean
    distance below ``max_distance``).  ``unit`` names the steps in the printed lines
    (``learn_ma_hover_ppo.py`` probes all agents and counts agent-steps)."""

    def __init__(
        self,
        cfg,
        every: int,
        episodes: int,
        stop_on_hover: bool = False,
        *,
        max_distance: float = MAX_DISTANCE,
        probe_fn=hover_probe,
        unit: str = "steps",
        probe_env=None,
    ) -> None:
        super().__init__()
        self.stop_on_hover = stop_on_hover
        self.max_distance, self.probe_fn, self.unit = max_distance, probe_fn, unit
        self.env = EnvFactory(cfg.env if probe_env is None else probe_env, monitor=False)()
        self.every, self.episodes = every, episodes
        self.next = every
        self.started = time.perf_counter()
        self.cpu_started = time.process_time()
        self.probe_time = 0.0
        self.probe_cpu = 0.0
        self.history: list[tuple[int, float, dict[str, float]]] = []
        #: (steps, wall-clock, wall-clock without the probes, CPU time of this process without the probes)
        self.hover_at: tuple[int, float, float, float] | None = None

    def _on_training_start(self) -> None:
        self.started = time.perf_counter()
        self.cpu_started = time.process_time()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next:
            self.next += self.every
            self.probe()
            if self.stop_on_hover and self.hover_at is not None:
                return False
        return True

    def _on_training_end(self) -> None:
        if not self.history or self.history[-1][0] != self.num_timesteps:
            self.probe()  # the final policy

    def probe(self) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        probe = self.probe_fn(self.model, self.env, self.episodes, seed=10_000)
        self.probe_time += time.perf_counter() - t0
        self.probe_cpu += time.process_time() - c0
        wall = time.perf_counter() - self.started
        self.history.append((self.num_timesteps, wall, probe))
        print(
            f"  {self.num_timesteps:>7} {self.unit}  {wall:6.1f} s  survived {100 * probe['survived']:3.0f} %  "
            f"distance mean {probe['mean_distance']:.3f} / worst {probe['worst_distance']:.3f} m  "
            f"return {probe['mean_return']:8.2f}",
            flush=True,
        )
        if self.hover_at is None and probe["survived"] == 1.0 and probe["worst_distance"] < self.max_distance:
            cpu = time.process_time() - self.cpu_started - self.probe_cpu
            self.hover_at = (self.num_timesteps, wall, wall - self.probe_time, cpu)


def run(
    seed: int,
    budget: int | None,
    every: int,
    episodes: int,
    output: Path,
    algo: str = "ppo",
    extra: tuple[str, ...] | list[str] = (),
    stop_on_hover: bool = False,
    max_distance: float = MAX_DISTANCE,
) -> dict:
    overrides = [
        *extra,
        f"seed={seed}",
        f"train.output_dir={output}",
        "train.progress_bar=false",
    ]
    if budget is not None:
        overrides.append(f"train.total_timesteps={budget}")
    cfg = compose_config(env="quadx_hover", algo=algo, overrides=overrides)
    probe = HoverProbe(cfg, every, episodes, stop_on_hover, max_distance=max_distance)
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe])
    total = time.perf_counter() - start
    final = probe.history[-1][2] if probe.history else {}
    return {
        "seed": seed,
        "budget": cfg.train.total_timesteps,
        "steps": result.num_timesteps,
        "hover_at": probe.hover_at,
        "final": final,
        "steps_per_second": result.num_timesteps / max(total - probe.probe_time, 1e-9),
        "wall": total,
        "n_envs": cfg.train.n_envs,
        "history": [(steps, wall, probe) for steps, wall, probe in probe.history],
    }


def rliable_summary(rows: list[dict], budget: int, reps: int = 2000) -> tuple[list[str], dict]:
    """IQM over the seeds with 95 % stratified-bootstrap intervals (rliable, through the
    project's seeded wrapper :mod:`pyflyt_cli.plotting.stats`): steps to the first
    hovering probe (a run that never hovers counts as the budget, a lower bound), the final
    probe's return and mean distance, and the return curve over the probes."""
    from pyflyt_cli.plotting import stats

    def iqm(values: list[float]) -> stats.Estimate:
        return stats.iqm({"x": np.asarray(values, dtype=float)[:, None]}, reps=reps, seed=0)["x"]

    def fmt(e: stats.Estimate, digits: int) -> str:
        return f"{float(e.value[0]):.{digits}f} [{float(e.low[0]):.{digits}f}, {float(e.high[0]):.{digits}f}]"

    hover = [r["hover_at"][0] if r["hover_at"] else budget for r in rows]
    final_return = [r["final"]["mean_return"] for r in rows]
    final_distance = [r["final"]["mean_distance"] for r in rows]
    never = sum(1 for r in rows if not r["hover_at"])
    lines = [
        "",
        f"IQM over {len(rows)} seeds, 95 % stratified-bootstrap CI ({reps} replicates, rliable):",
        "",
        "| measure | IQM [95 % CI] |",
        "|---|---|",
        f"| steps to the first hovering probe{' (never = budget)' if never else ''} | {fmt(iqm(hover), 0)} |",
        f"| final return ({rows[0]['history'][-1][0] if rows[0]['history'] else '-'} steps) | {fmt(iqm(final_return), 2)} |",
        f"| final mean distance [m] | {fmt(iqm(final_distance), 3)} |",
    ]
    data = {"rows": [{k: v for k, v in r.items()} for r in rows]}
    curve = probe_curve(rows, "mean_return", reps)
    if curve is not None:
        data["curve"] = curve
    return lines, data


def probe_curve(rows: list[dict], key: str, reps: int = 2000) -> dict | None:
    """IQM over seeds, with its 95 % bootstrap band (rliable), of the probes' ``key`` at each probe
    step; None unless every run probed at the same steps (two or more)."""
    from pyflyt_cli.plotting import stats

    probe_steps = [[h[0] for h in r["history"]] for r in rows]
    if not rows or any(s != probe_steps[0] for s in probe_steps) or len(probe_steps[0]) < 2:
        return None
    curve = np.asarray([[[h[2][key] for h in r["history"]]] for r in rows])  # (runs, 1, points)
    band = stats.iqm_curves({"x": curve}, reps=reps, seed=0)["x"]
    return {"steps": probe_steps[0], "iqm": band.value.tolist(), "low": band.low.tolist(), "high": band.high.tolist()}


def plot_curve(
    data: dict,
    path: Path,
    title: str,
    key: str = "mean_return",
    ylabel: str = "probe return (deterministic)",
    legend: str = "lower right",
) -> None:
    """``data["curve"]`` (from :func:`probe_curve`) with its band, and every run's probes of ``key`` in grey."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    curve = data["curve"]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(curve["steps"], curve["iqm"], color="C0", label="IQM over seeds")
    ax.fill_between(curve["steps"], curve["low"], curve["high"], color="C0", alpha=0.25, label="95 % CI")
    for r in data["rows"]:
        ax.plot([h[0] for h in r["history"]], [h[2][key] for h in r["history"]], color="0.6", lw=0.8)
    ax.set_xlabel("environment steps")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc=legend)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the shipped default budget)")
    parser.add_argument("--probe-every", type=int, default=10_000)
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe")
    parser.add_argument("--no-write", action="store_true", help="do not append to the results file")
    parser.add_argument("--algo", default="ppo")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--stop-on-hover", action="store_true", help="end a run at its first hovering probe")
    parser.add_argument(
        "--max-distance", type=float, default=MAX_DISTANCE, help="hovering: mean distance below this [m]"
    )
    args = parser.parse_args()

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
                    args.algo,
                    args.set,
                    args.stop_on_hover,
                    args.max_distance,
                )
            )

    cfg = compose_config()
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {platform.machine()}, {platform.python_version()}, "
            f"budget {rows[0]['budget']} steps, {rows[0]['n_envs']} envs, "
            f"probe every {args.probe_every} steps x {args.episodes} episodes, hovering below {args.max_distance} m\n"
        ),
        f"Shipped default budget (`pyflyt train`): {cfg.train.total_timesteps} steps.\n",
        "| seed | hovers at [steps] | wall-clock then [s] | without probes [s] | CPU time then, without probes [s] | final: survived | final: mean / worst distance [m] | training steps/s | run wall-clock [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        h = r["hover_at"]
        f = r["final"]
        lines.append(
            f"| {r['seed']} | {h[0] if h else 'not within budget'} | {f'{h[1]:.0f}' if h else '-'} | "
            f"{f'{h[2]:.0f}' if h else '-'} | {f'{h[3]:.1f}' if h and len(h) > 3 else '-'} | "
            f"{100 * f.get('survived', 0):.0f} % | "
            f"{f.get('mean_distance', float('nan')):.3f} / {f.get('worst_distance', float('nan')):.3f} | "
            f"{r['steps_per_second']:.0f} | {r['wall']:.0f} |"
        )
    summary, data = rliable_summary(rows, rows[0]["budget"])
    lines += summary
    if not args.no_write and "curve" in data:
        plot_curve(
            data, RESULTS.with_suffix(".png"), f"QuadX-Hover, {args.algo}, seeds {', '.join(map(str, args.seeds))}"
        )
        lines.append(
            f"\nCurve: `{RESULTS.with_suffix('.png').name}` (IQM and 95 % CI of the probe return; grey: each seed)."
        )
    if not args.no_write:
        data["command"] = " ".join(sys.argv)
        RESULTS.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        if not RESULTS.exists():
            RESULTS.write_text(
                "# PPO learns to hover (experiments/learn_hover_ppo.py)\n\n"
                "Hovering = in every probe episode (deterministic policy, 10 s): no crash and mean distance to\n"
                "the hover point below 0.1 m.  Wall-clock includes environment start-up and evaluations.\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
