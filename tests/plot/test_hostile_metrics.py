"""``pyflyt plot`` of a benchmark whose metrics hold non-finite or huge returns, or names and values of
another shape: a report with the diverged evaluations left out, or one line naming the run and the
value, exit 2 -- never a traceback.

Written from the reproductions: an algorithm or env name holding ``$`` ended in matplotlib's
mathtext ``ParseSyntaxException``; a string return or seed in ``ValueError``; names with line breaks,
control characters or 100 000 characters went into the figures and the Markdown tables as they were;
returns of 1e308 overflowed the normalisation into infinite scores.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.telemetry.metrics import MetricsWriter

runner = CliRunner()


def benchmark(root: Path, *, returns=None, algo=None, env=None, seed=None) -> Path:
    """Two algorithms x two seeds on quadx_hover; algorithm ``a``'s metadata and returns as given."""
    for name in ("a", "b"):
        for k in range(2):
            run = root / "runs" / "quadx_hover" / name / f"seed{k}"
            run.mkdir(parents=True)
            meta = {"env": "quadx_hover" if env is None or name == "b" else env,
                    "algo": algo if algo is not None and name == "a" else name}  # fmt: skip
            if seed is not None and name == "a":
                meta["seed"] = seed
            with MetricsWriter(run / "metrics.mcap", metadata=meta) as writer:
                for i, step in enumerate((100, 200, 300)):
                    value = returns[i] if returns is not None and name == "a" else step * (k + 1.0)
                    writer.log("/eval", step, {"mean_return": value})
    return root


def plot(root: Path, out: Path):
    result = runner.invoke(app, ["plot", str(root), "--reps", "20", "--out", str(out)])
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert "Traceback" not in result.output
    return result


@pytest.mark.parametrize("kwargs, fragment", [
    ({"algo": "$\\frac{a$"}, "its algorithm name '$\\\\frac{a$' cannot label a report"),
    ({"env": "$x^$"}, "its env name '$x^$' cannot label a report"),
    ({"algo": "al\ngo"}, "its algorithm name 'al\\ngo' cannot label a report"),
    ({"algo": "a\x00\x1b[31mred"}, "its algorithm name 'a\\x00\\x1b[31mred' cannot label a report"),
    ({"algo": "x" * 100_000}, "its algorithm name 'xxxxxxxx"),
    ({"algo": "a|b"}, "its algorithm name 'a|b' cannot label a report"),
    ({"returns": ["abc", "def", "x"]}, "the /eval record at step 100 has mean_return 'abc', not a number"),
    ({"returns": [True, False, True]}, "has mean_return True, not a number"),
    ({"seed": "abc"}, "its metadata seed 'abc' is not a whole number"),
    ({"seed": "9" * 50}, "is not a whole number"),
    ({"returns": [1e308, -1e308, 1e308]}, "quadx_hover/a: the normalised scores are not finite numbers"),
])  # fmt: skip
def test_metrics_of_another_shape_are_one_line_naming_the_run(tmp_path, kwargs, fragment):
    root = benchmark(tmp_path / "bench", **kwargs)
    out = tmp_path / "report"
    result = plot(root, out)
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and fragment in errors[0], result.output[-1500:]
    assert len(errors[0]) < 600  # a 100 000-character name is not echoed whole
    assert not out.exists() or not any(out.iterdir())  # no report of part of the benchmark


@pytest.mark.parametrize("returns", [[math.inf, 1.0, 2.0], [math.nan, 5.0, math.nan], [-math.inf, math.nan, 3.0]])
def test_non_finite_returns_are_left_out_and_the_report_is_written(tmp_path, returns):
    root = benchmark(tmp_path / "bench", returns=returns)
    out = tmp_path / "report"
    result = plot(root, out)
    assert result.exit_code == 0, result.output
    numbers = (out / "report.json").read_text()
    assert "NaN" not in numbers and "Infinity" not in numbers  # json.dumps writes those for non-finite floats
    assert (out / "learning_curves.png").stat().st_size > 1000


def test_plain_names_with_spaces_and_dashes_are_shown(tmp_path):
    root = benchmark(tmp_path / "bench", algo="my ppo-lstm v2")
    result = plot(root, tmp_path / "report")
    assert result.exit_code == 0, result.output
    assert "my ppo-lstm v2" in (tmp_path / "report" / "report.md").read_text()
