"""Study reports: rliable IQMs over seeds with their 95 % stratified-bootstrap intervals
(through the project's seeded wrapper :mod:`pyflyt_cli.plotting.stats`), probe curves and
their plots, and a results section's heading."""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np


def iqm_cell(values: list[float], digits: int, reps: int = 2000) -> str:
    """``IQM [low, high]`` over seeds of one value per seed: rliable's interquartile mean with its
    95 % stratified-bootstrap interval (``reps`` replicates, seed 0), to ``digits`` decimals."""
    from pyflyt_cli.plotting import stats

    e = stats.iqm({"x": np.asarray(values, dtype=float)[:, None]}, reps=reps, seed=0)["x"]
    return f"{float(e.value[0]):.{digits}f} [{float(e.low[0]):.{digits}f}, {float(e.high[0]):.{digits}f}]"


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
    ax.legend(loc=legend)  # type: ignore[call-overload]  # the stubs take only literal loc names
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def common_prefix(rows: list[dict]) -> list[dict]:
    """The rows with their histories cut to the probe steps every run shares (runs stopped by a
    CPU budget stop at different steps; the regular probes are at the same multiples)."""
    steps = [[h[0] for h in r["history"]] for r in rows]
    n = 0
    while all(len(s) > n for s in steps) and len({s[n] for s in steps}) == 1:
        n += 1
    return [{**r, "history": r["history"][:n]} for r in rows]


def iqm_summary(
    rows: list[dict],
    measures: list[tuple[str, list[float], int]],
    reps: int = 2000,
    *,
    curve: str | None = "success",
    of: str = "of the final policy's probe",
) -> tuple[list[str], dict]:
    """IQM over seeds with 95 % stratified-bootstrap CIs of each measure ``(label, one value per
    seed, decimals)`` (a table headed "IQM over N seeds ``of``"), and the probes' ``curve`` key
    (None: no curve) over the probe steps every seed reached."""
    lines = [
        "",
        f"IQM over {len(rows)} seeds{' ' + of if of else ''}, 95 % stratified-bootstrap CI ({reps} replicates, rliable):",
        "",
        "| measure | IQM [95 % CI] |",
        "|---|---|",
        *(f"| {label} | {iqm_cell(values, digits, reps)} |" for label, values, digits in measures),
    ]
    data: dict = {"rows": rows}
    band = probe_curve(common_prefix(rows), curve, reps) if curve is not None else None
    if band is not None:
        data["curve"] = band
    return lines, data


def section_head(script: str, args: argparse.Namespace, rows: list[dict]) -> list[str]:
    """A results section's heading (date, budget, probes, machine), the command and the overrides."""
    command = f"python experiments/{script} " + " ".join(sys.argv[1:])
    r0 = rows[0]
    return [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {args.title + ', ' if args.title else ''}PPO, "
            f"{r0['cpu_minutes']} CPU-minutes per seed, probe every {r0['probe_every']} steps x {r0['episodes']} "
            f"episodes ({platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()})\n"
        ),
        f"```bash\n{command}\n```\n",
        f"Overrides beyond the shipped tuning: {', '.join(r0['overrides']) or 'none'}.\n",
    ]
