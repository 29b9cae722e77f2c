"""Every shipped benchmark experiment gives figures a person can read: each run evaluated
at least 3 times, a reference score for every task, and data in every panel.

The benchmark is tiny and synthetic: the experiment's own plan (tasks, algorithms, seeds and
the steps each run is evaluated at), with made-up returns rising from the random score."""

from __future__ import annotations


import numpy as np
import pytest
import yaml

from pyflyt_cli.benchmark.plan import MIN_EVALUATIONS, evaluation_steps, plan_benchmark
from pyflyt_cli.plotting import report
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.telemetry.metrics import MetricsWriter

SHIPPED = sorted(
    p.stem for p in (conf_dir() / "experiment").glob("*.yaml") if "benchmark" in (yaml.safe_load(p.read_text()) or {})
)
RANDOM = -100.0


# smoke_benchmark runs by default (5 s); the others plan many runs (paper_rl: 20 s) and are marked slow


def test_the_shipped_benchmarks_are_found():
    assert {"smoke_benchmark", "paper_rl"} <= set(SHIPPED)


@pytest.mark.filterwarnings("ignore::FutureWarning")  # arch deprecates rliable's random_state
@pytest.mark.parametrize(
    "experiment",
    [name if name == "smoke_benchmark" else pytest.param(name, marks=pytest.mark.slow) for name in SHIPPED],
)
def test_each_shipped_experiment_plots_readable_figures(experiment, tmp_path, monkeypatch):
    plan = plan_benchmark(experiment, ["seeds=2"])
    references = plan.spec.get("reference") or {}
    tasks = sorted({job.task for job in plan.jobs})
    assert set(tasks) <= set(references), f"{experiment}: no reference score for {set(tasks) - set(references)}"
    root = tmp_path / experiment
    rng = np.random.default_rng(0)
    for job in plan.jobs:
        steps = evaluation_steps(job.config)
        assert len(steps) >= MIN_EVALUATIONS, f"{job.id}: evaluated at {steps} only"
        top = references[job.task]["score"]
        progress = np.linspace(0.1, 0.8, len(steps)) + 0.05 * rng.standard_normal(len(steps))
        run = root / "runs" / job.task / job.algo / f"seed{job.seed}"
        run.mkdir(parents=True)
        meta = {"env": job.task, "algo": job.algo, "seed": str(job.seed)}
        with MetricsWriter(run / "metrics.mcap", metadata=meta) as writer:
            for step, p in zip(steps, progress):
                ret = RANDOM + p * (top - RANDOM)
                writer.log("/eval", int(step), {"mean_return": ret, "std_return": 0.0, "success_rate": 0.0})
    norms = {t: {"random": RANDOM, "reference": float(references[t]["score"]), "source": "test"} for t in tasks}
    (root / "normalisation.yaml").write_text(yaml.safe_dump(norms))

    drawn: dict[str, object] = {}
    save = report._save

    def keep(fig, out_dir, name):
        fig.canvas.draw()
        drawn[name] = [ax for ax in fig.axes if ax.get_visible()]
        return save(fig, out_dir, name)

    monkeypatch.setattr(report, "_save", keep)
    result = report.plot_benchmark(root, reps=20, seed=0)
    assert not any("no reference" in n or "observed min" in n for n in result.numbers["notes"])
    assert set(drawn) == set(report.FIGURES) - set(result.skipped)
    for name, axes in drawn.items():
        assert axes, name
        for ax in axes:
            points = [np.asarray(line.get_xydata()) for line in ax.get_lines()]
            bars = [p for p in ax.patches if p.get_width() > 0]
            finite = [p for p in points if len(p) and np.isfinite(p).all()]
            assert finite or bars, f"{experiment}: {name}, panel {ax.get_title()!r} is empty"
            if name == "learning_curves":
                assert max(len(p) for p in finite) >= MIN_EVALUATIONS, f"{name} {ax.get_title()}: too few points"
