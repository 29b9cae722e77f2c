"""One ETA, computed one way (:class:`~pyflyt_cli.training.timing.RunEta`), behind the start
line, the evaluation lines, the progress bar and the progress lines.

Oracle: a simulated run on a fake clock whose actual time is known in advance -- the
measured cost model slowed by a constant factor (a loaded machine), or a constant rate
without a model -- so the time it really ends at is known: the ETA shown at any step,
added to the time elapsed then, must be that end.  And at one moment every display shows
the same ETA text.
"""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from pyflyt_cli.training import callbacks as cb
from pyflyt_cli.training.evaluation import Episode
from pyflyt_cli.training.timing import Costs, ProgressLines, RunEta, estimate_seconds, format_duration

from .conftest import load


class FakeClock:
    def __init__(self) -> None:
        self.now = 500.0

    def __call__(self) -> float:
        return self.now


SAC = [
    "env=quadx_hover",
    "algo=sac",
    "train.total_timesteps=20000",
    "train.eval_freq=5000",
    "train.eval_episodes=3",
    "algo.learning_starts=2000",
]


def _started(eta: RunEta, model) -> None:
    eta.model = model  # what BaseCallback.init_callback sets
    eta.on_training_start({}, {})


@pytest.mark.parametrize("slower", [1.0, 1.7, 0.6])
def test_the_eta_plus_the_elapsed_time_is_when_the_run_really_ends(tmp_path, slower):
    cfg = load(SAC, tmp_path)
    costs = Costs(collect=2e-3, update=9e-3)
    clock, model = FakeClock(), SimpleNamespace(num_timesteps=0)
    eta = RunEta(cfg, costs, clock=clock)
    at_start = eta.seconds_left(0, 0)
    assert at_start == estimate_seconds(cfg, costs, 0)  # the start line: the model alone
    _started(eta, model)
    started = clock.now
    end = started + slower * estimate_seconds(cfg, costs, 0)  # the run's actual end
    # the steps before learning_starts are cheap, those after dear: a plain rate would be wrong
    for step in (500, 1999, 2000, 4000, 5000, 12_345, 19_999):
        clock.now = started + slower * (estimate_seconds(cfg, costs, 0) - estimate_seconds(cfg, costs, step))
        model.num_timesteps = step
        assert clock.now + eta.seconds_left(step) == pytest.approx(end, rel=1e-12), step
    assert eta.seconds_left(20_000) == 0.0


def test_without_measured_costs_the_eta_is_the_rate_since_the_start(tmp_path):
    cfg = load(SAC, tmp_path)
    clock, model = FakeClock(), SimpleNamespace(num_timesteps=3000)  # a resumed run
    eta = RunEta(cfg, None, clock=clock)
    _started(eta, model)
    assert eta.text(3000) == "?"  # nothing trained yet: not known
    clock.now += 170.0  # 50 steps/s
    assert eta.seconds_left(3000 + 8500) == pytest.approx((20_000 - 11_500) / 50.0)


def test_every_display_shows_the_same_eta(tmp_path, monkeypatch):
    cfg = load(SAC, tmp_path)
    clock, model = FakeClock(), SimpleNamespace(num_timesteps=0, _n_updates=0, get_vec_normalize_env=lambda: None)
    eta = RunEta(cfg, Costs(collect=2e-3, update=9e-3), clock=clock)
    _started(eta, model)
    clock.now += 123.0
    model.num_timesteps = 6000
    expected = eta.text(6000)
    assert expected not in ("?", format_duration(0))

    lines = ProgressLines(20_000, lambda _: None, clock=clock, eta=eta)
    lines.model = model
    lines.on_training_start({}, {})
    assert f"| ETA {expected} |" in lines.line(clock.now) + " |"

    bar = cb.ProgressBar(20_000, eta=eta)
    assert bar.postfix(6000) == f"ETA {expected}"

    logged: list[str] = []
    monkeypatch.setattr(cb, "run_episodes", lambda *a, **k: [Episode(seed=0, ret=-1.0, length=10, success=False)])
    monkeypatch.setattr(cb, "policy_predict", lambda model: None)
    monkeypatch.setattr(cb, "save_policy", lambda *a, **k: None)
    writer = SimpleNamespace(log=lambda *a, **k: None)
    evaluation = cb.PeriodicEvaluation(
        SimpleNamespace(), tmp_path, "sac", writer, 5000, 1, 0, True, next_eval=5000, log=logged.append, total=20_000
    )
    evaluation.model = model
    evaluation.eta = eta
    evaluation.evaluate()
    assert logged and logged[0].endswith(f", ETA {expected})")
