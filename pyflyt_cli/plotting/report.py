"""`pyflyt plot`: figures (PNG and SVG) and a Markdown report of a benchmark directory.

    from pyflyt_cli.plotting import plot_benchmark
    report = plot_benchmark("benchmarks/paper_rl", reps=2000, seed=0)   # -> <dir>/report/report.md

Same directory, ``reps`` and ``seed`` -> byte-identical ``report.md`` and ``report.json``.

A partial grid (not every algorithm on every env) is reported per env for the pairs that
exist; aggregates and profiles are over each algorithm's own envs, and the probability of
improvement of two algorithms is over the envs they share (pairs sharing none are skipped).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_cli.outputs import atomic_output, make_output_dir
from pyflyt_cli.plotting import stats
from pyflyt_cli.plotting.data import Benchmark, load_benchmark
from pyflyt_engine import limits
from pyflyt_engine.errors import ConfigError

FIGURES = ("learning_curves", "aggregates", "performance_profiles", "probability_of_improvement")


@dataclass(frozen=True)
class Report:
    """What :func:`plot_benchmark` wrote."""

    out_dir: Path
    markdown: Path
    json: Path
    figures: list[Path]
    benchmark: Benchmark
    numbers: dict[str, Any]
    #: figure name -> why it was not drawn (it would have had nothing to show)
    skipped: dict[str, str] = field(default_factory=dict)


def compute(bench: Benchmark, reps: int, seed: int) -> dict[str, Any]:
    """Every number of the report (each statistic bootstrapped from its own ``RandomState(seed)``).

    Aggregates, profiles and the all-env curves are per algorithm over its own envs; the
    probability of improvement of X over Y is over the envs both ran on (``improvement_envs``),
    for the ordered pairs that share at least one.
    """
    taus = np.linspace(0.0, max(1.0, float(max(s.max() for s in bench.final.values()))), 51)

    def columns(algo: str, envs: list[str]) -> list[int]:
        return [bench.algo_envs[algo].index(e) for e in envs]

    shared = {
        (x, y): bench.shared_envs(x, y) for x in bench.algos for y in bench.algos if x != y and bench.shared_envs(x, y)
    }
    pairs = {
        (x, y): (bench.final[x][:, columns(x, envs)], bench.final[y][:, columns(y, envs)])
        for (x, y), envs in shared.items()
    }
    return {
        "aggregates": stats.aggregates(bench.final, reps, seed),
        "curves": stats.iqm_curves(bench.curves, reps, seed),
        "per_env_curves": {
            env: stats.iqm_curves(
                {a: c[:, columns(a, [env]), :] for a, c in bench.curves.items() if env in bench.algo_envs[a]},
                reps,
                seed,
            )
            for env in bench.envs
        },
        "taus": taus,
        "profiles": stats.performance_profiles(bench.final, taus, reps, seed),
        "improvement": stats.probability_of_improvement_pairs(pairs, reps, seed),
        "improvement_envs": shared,
        "notes": bench.notes + _partial_grid_notes(bench, shared),
    }


def _partial_grid_notes(bench: Benchmark, shared: dict[tuple[str, str], list[str]]) -> list[str]:
    """What a partial grid leaves out of the report (nothing for a full grid)."""
    if bench.full_grid:
        return []
    notes = []
    if len(bench.envs) > 1:
        notes.append("learning curves: no all-envs panel, as the algorithms ran on different envs")
    alone = [f"{x} vs {y}" for x in bench.algos for y in bench.algos if x < y and (x, y) not in shared]
    if alone:
        notes.append(f"probability of improvement: no shared env, not compared: {', '.join(alone)}")
    return notes


def plot_benchmark(root: str | Path, out: str | Path | None = None, *, reps: int = 2000, seed: int = 0) -> Report:
    """Load ``root``, compute the rliable statistics, write figures, ``report.md`` and ``report.json``.

    Args:
        root: benchmark directory (``[runs/]<env>/<algo>/<run>/metrics.mcap``).
        out: output directory (default ``<root>/report``).
        reps: stratified-bootstrap replicates per statistic.
        seed: seed of every bootstrap.
    """
    if reps < 10:
        raise ConfigError(f"--reps must be at least 10, got {reps}")
    too_many = limits.problem("plot.reps", reps, name="--reps")
    if too_many is not None:
        raise ConfigError(too_many)
    if seed < 0 or limits.problem("seed", seed) is not None:  # NumPy's seeding traceback, before
        raise ConfigError(f"--seed must be 0 to {limits.number(limits.LIMITS['seed'].high)}, got {seed}")
    bench = load_benchmark(root)
    if out is None:
        out_dir = make_output_dir(Path(root) / "report")
    else:
        out_dir = make_output_dir(Path(out), "--out")
    numbers = compute(bench, reps, seed)
    skipped = _empty_figures(bench, numbers)
    figures = _figures(bench, numbers, out_dir, skipped)
    md = out_dir / "report.md"
    with atomic_output(md) as tmp:
        tmp.write_text(_markdown(bench, numbers, reps, seed, figures, out_dir, skipped))
    js = out_dir / "report.json"
    with atomic_output(js) as tmp:
        data = {**_json(bench, numbers, reps, seed), "figures_not_drawn": skipped}
        tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    return Report(out_dir, md, js, figures, bench, numbers, skipped)


def _empty_figures(bench: Benchmark, numbers: dict[str, Any]) -> dict[str, str]:
    """Figures that would have nothing to show, and why: they are not drawn."""
    skipped = {}
    if not numbers["improvement"]:
        skipped["probability_of_improvement"] = (
            "one algorithm only: nothing to compare"
            if len(bench.algos) < 2
            else "no two algorithms ran on a common env: nothing to compare"
        )
    return skipped


# -------------------------------------------------------------------- figures


def _save(fig: Any, out_dir: Path, name: str) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = [out_dir / f"{name}.png", out_dir / f"{name}.svg"]
    try:
        with atomic_output(paths[0]) as tmp:
            fig.savefig(tmp, dpi=150, bbox_inches="tight", metadata={"Software": None})
        with atomic_output(paths[1]) as tmp:
            fig.savefig(tmp, bbox_inches="tight", metadata={"Date": None, "Creator": None})
    finally:
        plt.close(fig)
    return paths


def _count(items: list[str], noun: str) -> str:
    return f"{len(items)} {noun}{'s' if len(items) != 1 else ''}"


def _figures(bench: Benchmark, numbers: dict[str, Any], out_dir: Path, skipped: dict[str, str]) -> list[Path]:
    """Draw every figure not in ``skipped``; a skipped figure's old files (an earlier
    report in the same directory) are removed, so none is left that this report disowns."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    paths: list[Path] = []
    colors = {a: plt.get_cmap("tab10")(i % 10) for i, a in enumerate(bench.algos)}
    full = bench.full_grid

    def label(algo: str) -> str:  # a partial grid's aggregates are over each algorithm's own envs
        return algo if full else f"{algo} ({_count(bench.algo_envs[algo], 'env')})"

    with plt.rc_context({"svg.hashsalt": "pyflyt", "font.size": 9}):
        # learning curves: one panel per env (the algos that ran on it), plus the IQM over all
        # envs if there are several and every algo ran on every env
        panels = [(env, numbers["per_env_curves"][env], bench.grids[env]) for env in bench.envs]
        if len(bench.envs) > 1 and full:
            panels.append(("all envs", numbers["curves"], np.arange(len(next(iter(bench.grids.values()))))))
        fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.2), squeeze=False)
        for ax, (title, est, x) in zip(axes[0], panels):
            for algo in (a for a in bench.algos if a in est):
                e = est[algo]
                ax.plot(x, e.value, color=colors[algo], label=algo, marker="o" if len(x) <= 3 else None, markersize=3)
                ax.fill_between(x, e.low, e.high, color=colors[algo], alpha=0.2, linewidth=0)
            ax.set_title(title)
            ax.set_xlabel("environment steps" if title != "all envs" else "evaluation index")
            ax.grid(alpha=0.3)
            if not full:
                ax.legend(loc="best")
        # one label for the row: on every panel it ran into the tick labels of the panel before
        axes[0][0].set_ylabel("IQM normalised score")
        if full:
            axes[0][0].legend(loc="best")
        fig.tight_layout()  # each panel's tick labels clear of the panel before
        paths += _save(fig, out_dir, "learning_curves")

        # aggregate metrics with intervals
        fig, axes = plt.subplots(1, 4, figsize=(12, 0.5 + 0.45 * len(bench.algos)), squeeze=False)
        for ax, name in zip(axes[0], stats.AGGREGATES):
            for i, algo in enumerate(bench.algos):
                e = numbers["aggregates"][algo][name]
                ax.barh(i, float(e.high - e.low), left=float(e.low), height=0.6, color=colors[algo], alpha=0.6)
                ax.plot([float(e.value)] * 2, [i - 0.3, i + 0.3], color="k", linewidth=1.5)
            ticks = [label(a) for a in bench.algos] if name == "median" else [""] * len(bench.algos)
            ax.set_yticks(range(len(bench.algos)), ticks)
            ax.set_title({"iqm": "IQM", "optimality_gap": "optimality gap"}.get(name, name))
            ax.set_xlabel("normalised score")
            ax.grid(axis="x", alpha=0.3)
        paths += _save(fig, out_dir, "aggregates")

        # performance profiles
        fig, ax = plt.subplots(figsize=(5, 3.2))
        taus = numbers["taus"]
        for algo in bench.algos:
            e = numbers["profiles"][algo]
            ax.plot(taus, e.value, color=colors[algo], label=label(algo))
            ax.fill_between(taus, e.low, e.high, color=colors[algo], alpha=0.2, linewidth=0)
        ax.set_xlabel(r"normalised score $\tau$")
        ax.set_ylabel(r"fraction of runs with score $> \tau$")
        ax.grid(alpha=0.3)
        ax.legend(loc="best")
        paths += _save(fig, out_dir, "performance_profiles")

        for name in skipped:
            for ext in ("png", "svg"):
                (out_dir / f"{name}.{ext}").unlink(missing_ok=True)
        if "probability_of_improvement" in skipped:
            return paths

        # probability of improvement
        pairs = sorted(numbers["improvement"])
        fig, ax = plt.subplots(figsize=(5, 0.6 + 0.4 * max(1, len(pairs))))
        for i, (x, y) in enumerate(pairs):
            e = numbers["improvement"][(x, y)]
            ax.barh(i, float(e.high - e.low), left=float(e.low), height=0.6, color=colors[x], alpha=0.6)
            ax.plot([float(e.value)] * 2, [i - 0.3, i + 0.3], color="k", linewidth=1.5)
        envs = numbers["improvement_envs"]
        names = [f"P({x} > {y})" + ("" if full else f" on {_count(envs[(x, y)], 'shared env')}") for x, y in pairs]
        ax.set_yticks(range(len(pairs)), names)
        ax.axvline(0.5, color="grey", linestyle="--", linewidth=1)
        ax.set_xlim(0, 1)
        ax.set_xlabel("probability of improvement")
        paths += _save(fig, out_dir, "probability_of_improvement")
    return paths


# --------------------------------------------------------------------- report


def _f(x: Any) -> str:
    return f"{float(x):.3f}"


def _ci(e: stats.Estimate) -> str:
    return f"{_f(e.value)} [{_f(e.low)}, {_f(e.high)}]"


def _markdown(
    bench: Benchmark,
    numbers: dict[str, Any],
    reps: int,
    seed: int,
    figures: list[Path],
    out_dir: Path,
    skipped: dict[str, str] | None = None,
) -> str:
    skipped = skipped or {}
    lines = [
        f"# Benchmark report: {bench.root.name}",
        "",
        (
            f"Runs read from `{bench.root}`. Scores are normalised per env: 0 = random policy, 1 = reference "
            f"(table below). Intervals are {int(stats.CONFIDENCE * 100)} % percentile intervals of {reps} "
            f"stratified-bootstrap replicates (rliable), bootstrap seed {seed}: rerunning with the same data, "
            "`--reps` and `--seed` gives this report again. How to read it: docs/benchmarks.md."
        ),
        "",
        "## Normalisation",
        "",
        "| env | random score | reference score | source |",
        "|---|---:|---:|---|",
    ]
    lines += [
        f"| {e} | {_f(n.random)} | {_f(n.reference)} | {n.source} |" for e, n in sorted(bench.normalisation.items())
    ]
    lines += ["", "## Runs", "", "| env | algo | runs | seeds | last step on the grid |", "|---|---|---:|---|---:|"]
    for env in bench.envs:
        for algo in (a for a in bench.algos if (env, a) in bench.seeds):
            seeds = bench.seeds[(env, algo)]
            lines.append(
                f"| {env} | {algo} | {len(seeds)} | {', '.join('?' if s is None else str(s) for s in seeds)} "
                f"| {int(bench.grids[env][-1])} |"
            )
    lines += [
        "",
        "## Aggregate metrics (final normalised score)",
        "",
        "Point estimate [95 % CI]. Median, IQM and mean: higher is better; optimality gap: lower is better.",
        "",
    ]
    full = bench.full_grid
    if full:
        lines += ["| algo | median | IQM | mean | optimality gap |", "|---|---|---|---|---|"]
    else:
        lines[-2] += " Each algorithm is aggregated over its own envs: rows with different envs are not comparable."
        lines += ["| algo | envs | median | IQM | mean | optimality gap |", "|---|---|---|---|---|---|"]
    for algo in bench.algos:
        a = numbers["aggregates"][algo]
        envs = "" if full else f" {', '.join(bench.algo_envs[algo])} |"
        lines.append(f"| {algo} |{envs} " + " | ".join(_ci(a[n]) for n in stats.AGGREGATES) + " |")
    lines += [
        "",
        "## IQM learning curves",
        "",
        "IQM normalised score [95 % CI] at the end and middle of each env's grid.",
        "",
    ]
    lines += ["| env | step | " + " | ".join(bench.algos) + " |", "|---|---:|" + "---|" * len(bench.algos)]
    for env in bench.envs:
        grid = bench.grids[env]
        for idx in sorted({len(grid) // 2, len(grid) - 1}):
            cells = [
                "—" if e is None else _ci(stats.Estimate(e.value[idx], e.low[idx], e.high[idx]))
                for e in (numbers["per_env_curves"][env].get(a) for a in bench.algos)
            ]
            lines.append(f"| {env} | {int(grid[idx])} | " + " | ".join(cells) + " |")
    lines += ["", "## Probability of improvement", ""]
    if numbers["improvement"] and full:
        lines += ["P(X > Y): the probability that a run of X scores higher than a run of Y on a random env.", ""]
        lines += ["| X | Y | P(X > Y) [95 % CI] |", "|---|---|---|"]
        lines += [f"| {x} | {y} | {_ci(e)} |" for (x, y), e in sorted(numbers["improvement"].items())]
    elif numbers["improvement"]:
        lines += [
            (
                "P(X > Y): the probability that a run of X scores higher than a run of Y on a random env of "
                "those both ran on (shared envs); pairs sharing no env are not compared."
            ),
            "",
        ]
        lines += ["| X | Y | shared envs | P(X > Y) [95 % CI] |", "|---|---|---|---|"]
        lines += [
            f"| {x} | {y} | {', '.join(numbers['improvement_envs'][(x, y)])} | {_ci(e)} |"
            for (x, y), e in sorted(numbers["improvement"].items())
        ]
    elif len(bench.algos) > 1:
        lines.append("No two algorithms ran on a common env: nothing to compare.")
    else:
        lines.append("One algorithm only: nothing to compare.")
    lines += ["", "## Performance profiles", "", "Fraction of runs with final normalised score > τ [95 % CI].", ""]
    taus = numbers["taus"]
    picks = sorted({0, len(taus) // 4, len(taus) // 2, 3 * len(taus) // 4, len(taus) - 1})
    lines += ["| τ | " + " | ".join(bench.algos) + " |", "|---:|" + "---|" * len(bench.algos)]
    for i in picks:
        cells = [
            _ci(stats.Estimate(p.value[i], p.low[i], p.high[i])) for p in (numbers["profiles"][a] for a in bench.algos)
        ]
        lines.append(f"| {_f(taus[i])} | " + " | ".join(cells) + " |")
    lines += ["", "## Figures", ""]
    for name in FIGURES:
        if name in skipped:
            lines.append(f"- `{name}.png` is not drawn: {skipped[name]}.")
        else:
            lines.append(f"![{name}]({name}.png) ([SVG]({name}.svg))")
    if numbers["notes"]:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in numbers["notes"]]
    return "\n".join(lines) + "\n"


def _json(bench: Benchmark, numbers: dict[str, Any], reps: int, seed: int) -> dict[str, Any]:
    def est(e: stats.Estimate) -> dict[str, Any]:
        return {
            "value": np.asarray(e.value).tolist(),
            "low": np.asarray(e.low).tolist(),
            "high": np.asarray(e.high).tolist(),
        }

    return {
        "reps": reps,
        "seed": seed,
        "confidence": stats.CONFIDENCE,
        "envs": bench.envs,
        "algos": bench.algos,
        "algo_envs": bench.algo_envs,
        "normalisation": {e: vars(n) for e, n in bench.normalisation.items()},
        "grids": {e: g.tolist() for e, g in bench.grids.items()},
        "aggregates": {a: {n: est(e) for n, e in m.items()} for a, m in numbers["aggregates"].items()},
        "iqm_curves": {env: {a: est(e) for a, e in c.items()} for env, c in numbers["per_env_curves"].items()},
        "iqm_curve_all_envs": {a: est(e) for a, e in numbers["curves"].items()},
        "performance_profiles": {
            "taus": numbers["taus"].tolist(),
            **{a: est(e) for a, e in numbers["profiles"].items()},
        },
        "probability_of_improvement": {f"{x} > {y}": est(e) for (x, y), e in numbers["improvement"].items()},
        "notes": numbers["notes"],
    }
