"""`pyflyt plot`: statistics equal rliable's, a synthetic benchmark is reported end to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_cli.plotting import load_benchmark, plot_benchmark, stats
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry.metrics import MetricsWriter

ROOT = Path(__file__).resolve().parents[2]
REPS = 200  # enough to exercise the bootstrap, fast


@pytest.mark.filterwarnings("ignore::FutureWarning")  # arch deprecates rliable's random_state
def test_iqm_and_interval_equal_rliables_on_a_fixed_array():
    from rliable import library as rly
    from rliable import metrics

    rng = np.random.default_rng(7)
    scores = {"sac": rng.normal(0.6, 0.2, (10, 3)), "ppo": rng.normal(0.4, 0.3, (10, 3))}
    ours = stats.iqm(scores, reps=REPS, seed=42)
    # rliable 1.2 bootstraps with np.random.choice (global RNG) despite random_state: seed both
    np.random.seed(42)
    points, intervals = rly.get_interval_estimates(
        scores,
        lambda x: np.array([metrics.aggregate_iqm(x)]),
        reps=REPS,
        random_state=np.random.RandomState(42),
    )
    for algo in scores:
        assert ours[algo].value == pytest.approx(points[algo])
        assert ours[algo].low == pytest.approx(intervals[algo][0]) and ours[algo].high == pytest.approx(
            intervals[algo][1]
        )
        assert ours[algo].low < ours[algo].value < ours[algo].high
    assert stats.iqm(scores, reps=REPS, seed=42)["ppo"].low == ours["ppo"].low  # reproducible
    # and the IQM itself is the mean of the middle 50 % of all runs x tasks
    flat = np.sort(scores["sac"].ravel())
    assert ours["sac"].value[0] == pytest.approx(np.mean(flat[int(0.25 * 30) : int(np.ceil(0.75 * 30))]), rel=0.05)


def test_aggregates_and_improvement_match_rliable_point_estimates():
    from rliable import metrics

    rng = np.random.default_rng(3)
    scores = {"a": rng.uniform(0, 1.2, (5, 2)), "b": rng.uniform(0, 1, (5, 2))}
    agg = stats.aggregates(scores, reps=REPS, seed=0)
    assert float(agg["a"]["median"].value) == pytest.approx(metrics.aggregate_median(scores["a"]))
    assert float(agg["a"]["optimality_gap"].value) == pytest.approx(metrics.aggregate_optimality_gap(scores["a"]))
    poi = stats.probability_of_improvement(scores, reps=REPS, seed=0)
    assert set(poi) == {("a", "b"), ("b", "a")}
    assert float(poi[("a", "b")].value) == pytest.approx(metrics.probability_of_improvement(scores["a"], scores["b"]))
    assert float(poi[("a", "b")].value) + float(poi[("b", "a")].value) == pytest.approx(1.0)


def _write_run(run: Path, env: str, algo: str, seed: int, steps, returns) -> None:
    run.mkdir(parents=True)
    meta = {"env": env, "algo": algo, "seed": str(seed)}
    with MetricsWriter(run / "metrics.mcap", metadata=meta) as writer:
        writer.log("/train/episode", 10, {"return": -1.0, "length": 10})
        for step, ret in zip(steps, returns):
            writer.log("/eval", int(step), {"mean_return": float(ret), "std_return": 0.0, "success_rate": 0.0})


@pytest.fixture
def bench(tmp_path: Path) -> Path:
    """2 algos x 3 seeds on one env; 'good' climbs to ~90, 'bad' to ~30 (random 0, reference 100)."""
    root = tmp_path / "bench"
    rng = np.random.default_rng(0)
    for algo, top in (("good", 90.0), ("bad", 30.0)):
        for seed in range(3):
            steps = np.arange(1, 6) * 1000
            returns = top * np.linspace(0.1, 1.0, 5) + rng.normal(0, 3, 5)
            _write_run(
                root / "runs" / "quadx_hover" / algo / f"t-seed{seed}", "quadx_hover", algo, seed, steps, returns
            )
    (root / "normalisation.yaml").write_text(
        yaml.safe_dump({"quadx_hover": {"random": 0.0, "reference": 100.0, "source": "test fixture"}})
    )
    return root


def test_a_synthetic_benchmark_is_loaded_aligned_and_normalised(bench):
    b = load_benchmark(bench)
    assert b.envs == ["quadx_hover"] and b.algos == ["bad", "good"]
    assert b.curves["good"].shape == (3, 1, 5) and b.final["good"].shape == (3, 1)
    assert b.grids["quadx_hover"].tolist() == [1000, 2000, 3000, 4000, 5000]
    assert 0.8 < float(np.mean(b.final["good"])) < 1.0 and 0.2 < float(np.mean(b.final["bad"])) < 0.4
    assert b.seeds[("quadx_hover", "good")] == [0, 1, 2]


def test_curves_of_unequal_length_are_interpolated_on_a_common_grid(tmp_path):
    root = tmp_path / "b"
    _write_run(root / "e" / "a" / "r0", "e", "a", 0, [100, 200, 300], [0.0, 1.0, 2.0])
    _write_run(root / "e" / "a" / "r1", "e", "a", 1, [150, 250], [0.0, 10.0])  # stopped earlier
    b = load_benchmark(root, normalisation={})
    assert b.grids["e"].tolist() == [100, 150, 200, 250]
    raw = b.curves["a"] * 10.0  # observed min 0, max 10
    assert raw[0, 0].tolist() == pytest.approx([0.0, 0.5, 1.0, 1.5])
    assert raw[1, 0].tolist() == pytest.approx([0.0, 0.0, 5.0, 10.0])  # before its first eval: held at it
    assert any("observed min and max" in n for n in b.notes)


@pytest.mark.long
def test_plot_end_to_end_writes_figures_and_a_reproducible_report(bench, tmp_path):
    report = plot_benchmark(bench, tmp_path / "out", reps=REPS, seed=5)
    for name in ("learning_curves", "aggregates", "performance_profiles", "probability_of_improvement"):
        for ext in ("png", "svg"):
            path = tmp_path / "out" / f"{name}.{ext}"
            assert path.is_file() and path.stat().st_size > 1000, path
    text = report.markdown.read_text()
    iqm = report.numbers["aggregates"]["good"]["iqm"]
    assert f"{float(iqm.value):.3f} [{float(iqm.low):.3f}, {float(iqm.high):.3f}]" in text
    assert "| quadx_hover | 0.000 | 100.000 | test fixture |" in text  # random and reference recorded
    poi = report.numbers["improvement"][("good", "bad")]
    assert float(poi.value) == 1.0 and f"| good | bad | {float(poi.value):.3f}" in text
    assert "bootstrap seed 5" in text and f"{REPS} stratified-bootstrap replicates" in text

    again = plot_benchmark(bench, tmp_path / "again", reps=REPS, seed=5)
    assert again.markdown.read_text() == text
    assert again.json.read_text() == report.json.read_text()
    other = plot_benchmark(bench, tmp_path / "other", reps=REPS, seed=6)
    assert other.json.read_text() != report.json.read_text()  # the seed is what makes it reproducible


def test_one_algorithm_writes_no_empty_improvement_figure_and_says_why(bench, tmp_path):
    """Only 'good' ran: the probability-of-improvement figure would be an empty panel. It
    is not written (an old one in the output directory is removed), and the report and
    report.json say why."""
    import shutil

    shutil.rmtree(bench / "runs" / "quadx_hover" / "bad")
    out = tmp_path / "out"
    out.mkdir()
    (out / "probability_of_improvement.png").write_bytes(b"an earlier report's figure")
    report = plot_benchmark(bench, out, reps=REPS, seed=0)
    assert not list(out.glob("probability_of_improvement.*"))
    assert {p.stem for p in report.figures} == {"learning_curves", "aggregates", "performance_profiles"}
    text = report.markdown.read_text()
    assert "- `probability_of_improvement.png` is not drawn: one algorithm only: nothing to compare." in text
    assert "![probability_of_improvement]" not in text and "![aggregates](aggregates.png)" in text
    data = json.loads(report.json.read_text())
    assert data["figures_not_drawn"] == {"probability_of_improvement": "one algorithm only: nothing to compare"}
    result = CliRunner().invoke(app, ["plot", str(bench), "--out", str(tmp_path / "cli"), "--reps", str(REPS)])
    assert result.exit_code == 0, result.output
    assert not [line for line in result.output.splitlines() if line.startswith("figure:") and "improvement" in line]
    assert "not drawn: probability_of_improvement (one algorithm only: nothing to compare)" in result.output


def _partial_bench(root: Path, grid: dict[str, list[str]], runs: dict[str, int]) -> Path:
    """``algo -> envs`` it ran on, ``runs[algo]`` seeds each; 5 evals climbing to a per-algo level."""
    rng = np.random.default_rng(1)
    for i, (algo, envs) in enumerate(sorted(grid.items())):
        for env in envs:
            for seed in range(runs[algo]):
                returns = (60.0 + 5.0 * i) * np.linspace(0.1, 1.0, 5) + rng.normal(0, 4, 5)
                _write_run(root / "runs" / env / algo / f"seed{seed}", env, algo, seed, np.arange(1, 6) * 1000, returns)
    envs = sorted({e for es in grid.values() for e in es})
    (root / "normalisation.yaml").write_text(
        yaml.safe_dump({e: {"random": 0.0, "reference": 100.0, "source": "test fixture"} for e in envs})
    )
    return root


#: the paper's study: SAC on the dense-reward tasks, AWAC on the sparse-reward ones
PAPER_GRID = {
    "sac": ["quadx_waypoints", "fixedwing_waypoints"],
    "awac": ["quadx_waypoints_sparse", "fixedwing_waypoints_sparse"],
}


@pytest.mark.long
def test_a_partial_grid_with_disjoint_envs_is_loaded_and_plotted(tmp_path):
    root = _partial_bench(tmp_path / "paper", PAPER_GRID, {"sac": 3, "awac": 4})
    b = load_benchmark(root)
    assert b.algos == ["awac", "sac"] and len(b.envs) == 4 and not b.full_grid
    assert b.algo_envs == {
        "awac": ["fixedwing_waypoints_sparse", "quadx_waypoints_sparse"],
        "sac": ["fixedwing_waypoints", "quadx_waypoints"],
    }
    assert b.curves["awac"].shape == (4, 2, 5) and b.final["sac"].shape == (3, 2)
    assert set(b.seeds) == {(e, a) for a, es in PAPER_GRID.items() for e in es}
    assert b.shared_envs("sac", "awac") == []
    assert any("not comparable" in n for n in b.notes)

    report = plot_benchmark(root, tmp_path / "out", reps=REPS, seed=2)
    for name in ("learning_curves", "aggregates", "performance_profiles"):
        for ext in ("png", "svg"):
            path = tmp_path / "out" / f"{name}.{ext}"
            assert path.is_file() and path.stat().st_size > 1000, path
    assert report.numbers["improvement"] == {}
    # nothing to compare: no empty probability-of-improvement figure, and the report says why
    assert not list((tmp_path / "out").glob("probability_of_improvement.*"))
    assert report.skipped == {"probability_of_improvement": "no two algorithms ran on a common env: nothing to compare"}
    assert set(report.numbers["per_env_curves"]["quadx_waypoints"]) == {"sac"}
    text = report.markdown.read_text()
    assert "| algo | envs | median | IQM | mean | optimality gap |" in text
    iqm = report.numbers["aggregates"]["sac"]["iqm"]
    assert f"| sac | fixedwing_waypoints, quadx_waypoints | {float(iqm.value):.3f}" in text
    assert "| quadx_waypoints | sac | 3 |" in text and "| quadx_waypoints | awac |" not in text  # runs table
    assert "| quadx_waypoints_sparse | 5000 | " in text and " — |" in text  # per-env IQM: awac only
    assert "No two algorithms ran on a common env" in text
    assert "- `probability_of_improvement.png` is not drawn: no two algorithms ran on a common env" in text
    assert "![probability_of_improvement]" not in text
    notes = text.split("## Notes")[1]
    assert "not comparable" in notes and "no all-envs panel" in notes and "not compared: awac vs sac" in notes
    data = json.loads(report.json.read_text())
    assert data["algo_envs"] == b.algo_envs and data["probability_of_improvement"] == {}
    assert {"aggregates", "iqm_curves", "iqm_curve_all_envs", "performance_profiles", "notes"} <= set(data)
    again = plot_benchmark(root, tmp_path / "again", reps=REPS, seed=2)
    assert again.markdown.read_text() == text and again.json.read_text() == report.json.read_text()


@pytest.mark.long
@pytest.mark.filterwarnings("ignore::FutureWarning")  # arch deprecates rliable's random_state
def test_a_shared_env_is_compared_by_probability_of_improvement_on_it_alone(tmp_path):
    from rliable import library as rly
    from rliable import metrics

    grid = {
        "sac": ["fixedwing_waypoints", "quadx_waypoints"],
        "awac": ["quadx_waypoints", "quadx_waypoints_sparse"],
    }
    root = _partial_bench(tmp_path / "shared", grid, {"sac": 3, "awac": 5})
    b = load_benchmark(root)
    assert b.shared_envs("sac", "awac") == ["quadx_waypoints"]
    report = plot_benchmark(root, tmp_path / "out", reps=REPS, seed=4)
    assert all((tmp_path / "out" / f"{name}.png").is_file() for name in ("learning_curves", "aggregates"))
    assert report.numbers["improvement_envs"] == {
        ("awac", "sac"): ["quadx_waypoints"],
        ("sac", "awac"): ["quadx_waypoints"],
    }

    # the shared env is column 0 of awac's scores and column 1 of sac's; runs differ (5 vs 3)
    awac, sac = b.final["awac"][:, [0]], b.final["sac"][:, [1]]
    np.random.seed(4)
    points, intervals = rly.get_interval_estimates(
        {("awac", "sac"): [awac, sac], ("sac", "awac"): [sac, awac]},
        metrics.probability_of_improvement,
        reps=REPS,
        random_state=np.random.RandomState(4),
    )
    poi = report.numbers["improvement"]
    assert set(poi) == {("awac", "sac"), ("sac", "awac")}
    for pair in poi:
        assert float(poi[pair].value) == pytest.approx(float(points[pair]))
        assert float(poi[pair].low) == pytest.approx(float(np.ravel(intervals[pair])[0]))
        assert float(poi[pair].high) == pytest.approx(float(np.ravel(intervals[pair])[1]))
        assert poi[pair].low < poi[pair].high  # a real interval, not a degenerate 0 or 1
    assert float(poi[("awac", "sac")].value) == pytest.approx(metrics.probability_of_improvement(awac, sac))
    text = report.markdown.read_text()
    assert f"| awac | sac | quadx_waypoints | {float(poi[('awac', 'sac')].value):.3f}" in text
    assert "| X | Y | shared envs | P(X > Y) [95 % CI] |" in text
    assert "not comparable" in text.split("## Notes")[1]


def test_plot_errors_name_the_problem(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_benchmark(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="no runs in"):
        load_benchmark(tmp_path / "empty")
    run = tmp_path / "noeval" / "e" / "a" / "r"
    run.mkdir(parents=True)
    with MetricsWriter(run / "metrics.mcap") as w:
        w.log("/train/episode", 5, {"return": 1.0})
    with pytest.raises(ConfigError, match="has evaluation metrics.*eval_freq"):
        load_benchmark(tmp_path / "noeval")


def test_pyflyt_plot_cli(bench, tmp_path):
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg", "HOME": str(tmp_path)}
    ok = subprocess.run(
        [sys.executable, "-m", "pyflyt_cli.main", "plot", str(bench), "--reps", "50", "--seed", "1"],
        check=False,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert ok.returncode == 0, ok.stderr
    assert (bench / "report" / "report.md").is_file() and "report:" in ok.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "pyflyt_cli.main", "plot", str(tmp_path / "nope")],
        check=False,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert bad.returncode == 2 and "does not exist" in bad.stderr and "Traceback" not in bad.stderr


BAD_NORMALISATION = {
    "malformed_yaml": ("quadx_hover: {random: 0, reference: 1\n", ["not valid YAML", "line"]),
    "a_list": ("- quadx_hover\n- 1\n", ["must be a mapping of env names", "got list"]),
    "entry_a_number": ("quadx_hover: 3\n", ["quadx_hover: needs a mapping", "got 3"]),
    "nan_random": ("quadx_hover: {random: .nan, reference: 100}\n", ["quadx_hover.random", "finite number"]),
    "inf_reference": ("quadx_hover: {random: 0, reference: .inf}\n", ["quadx_hover.reference", "finite number"]),
    "text_score": ("quadx_hover: {random: low, reference: 100}\n", ["quadx_hover.random", "valid number", "'low'"]),
    "missing_random": ("quadx_hover: {reference: 100}\n", ["quadx_hover.random", "Field required"]),
    "misspelt_key": ("quadx_hover: {random: 0, referense: 100}\n", ["quadx_hover.referense", "unknown key"]),
    "equal_scores": ("quadx_hover: {random: 5, reference: 5}\n", ["reference and random scores are equal"]),
}


@pytest.mark.parametrize("case", list(BAD_NORMALISATION))
def test_a_bad_normalisation_file_is_one_message_and_exit_2(bench, case):
    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    text, fragments = BAD_NORMALISATION[case]
    (bench / "normalisation.yaml").write_text(text)
    result = CliRunner().invoke(app, ["plot", str(bench), "--reps", "20"])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error: ") and "Traceback" not in result.output
    assert str(bench / "normalisation.yaml") in result.output
    for fragment in fragments:
        assert fragment in result.output, result.output
    assert not (bench / "report").exists()
