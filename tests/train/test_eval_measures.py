"""What ``pyflyt eval`` and the training evaluations say beside the return: the task's
success measures (declared by the task), how far the run trained and which step the model
flown comes from, and where the return and the success verdict disagree.

Oracles: the distance held by hand from the evaluation's own recordings; ``state.json``
and the policy file's step as written by the run; hand-made episodes whose returns and
outcomes are known.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pyflyt_cli.training import evaluate_run, train
from pyflyt_cli.training.evaluate import trained_line
from pyflyt_cli.training.evaluation import Episode, disagreement
from pyflyt_cli.training.rundir import read_state, write_state
from pyflyt_engine.telemetry import load_episode

from .conftest import TINY_PPO, load


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return train(load(TINY_PPO, tmp_path_factory.mktemp("runs"))).run_dir


def test_eval_reports_the_distance_held_as_computed_from_its_recordings(run):
    report = evaluate_run(run, {"episodes": 2, "seed": 5, "record": True})
    by_hand = []
    for path, episode in zip(report.recordings, report.episodes):
        positions = load_episode(path).vehicles[0].states["lin_pos"][1:]
        distances = np.linalg.norm(positions - np.array([0.0, 0.0, 1.0]), axis=1)
        assert episode.measures["distance_mean"] == pytest.approx(distances.mean(), rel=1e-12)
        by_hand.append((distances.mean(), distances.max()))
    mean = np.mean([m for m, _ in by_hand])
    worst = max(x for _, x in by_hand)
    assert report.measure_summary == pytest.approx({"distance_mean": mean, "distance_max": worst}, rel=1e-12)
    table = report.table()
    assert f"distance held, episode mean  {mean:.3f} m  (mean over episodes)" in table
    assert "distance_mean" in table.splitlines()[4]  # a column of the episode rows
    saved = json.loads((run / "eval.json").read_text())
    assert saved["measures"]["distance_max"] == pytest.approx(worst, rel=1e-12)
    assert saved["episodes"][0]["measures"]["distance_mean"] == pytest.approx(by_hand[0][0], rel=1e-12)
    assert saved["episodes"][0]["end"] in ("time_limit", "collision", "out_of_bounds")


def test_a_complete_run_says_so_and_names_the_models_step(run):
    report = evaluate_run(run, {"episodes": 1, "record": False, "model": "final"})
    state = read_state(run)
    assert report.trained == f"complete, {state['num_timesteps']} of 512 steps; flying model.pt from step 512"
    assert f"trained: {report.trained}" in report.table()
    assert json.loads((run / "eval.json").read_text())["trained"] == report.trained


def test_an_interrupted_run_is_stated_unfinished_in_one_line(tmp_path, run):
    state = read_state(run)
    try:
        write_state(run, {**state, "status": "interrupted", "num_timesteps": 256, "total_timesteps": 512})
        line = trained_line(run, run / "best_model.pt", 256)
    finally:
        write_state(run, state)
    assert line == (
        f"UNFINISHED (interrupted at 256 of 512 steps); flying best_model.pt from step 256; "
        f"continue with pyflyt train resume={run}"
    )
    assert "\n" not in line


def test_a_folder_without_state_says_what_it_does_not_know(tmp_path):
    line = trained_line(tmp_path, tmp_path / "model.pt", 151552, 150000)
    assert line.startswith("flying model.pt from step 151552 of a 150000-step budget (no state.json here")


def _episode(ret: float, success: bool, end: str, length: int = 100) -> Episode:
    return Episode(seed=0, ret=ret, length=length, success=success, end=end)


def test_a_failure_outscoring_the_successes_is_explained():
    episodes = [
        _episode(1561.0, True, "complete"),
        _episode(2771.0, False, "time_limit", 600),
        _episode(2150.0, True, "complete"),
    ]
    why = disagreement(episodes)
    assert why is not None
    assert why.startswith(
        "return and success disagree: episode 1 has the highest return (2771.00) but is not a success"
    )
    assert "not a success (time limit)" in why and "successes score 1561.00 to 2150.00" in why
    assert "it flew longer (600 steps, successes 100-100)" in why
    same_length = disagreement([_episode(5.0, True, "complete"), _episode(9.0, False, "collision")])
    assert "successes score 5.00: the return pays for more than the outcome" in same_length


def test_returns_that_rank_like_the_outcomes_need_no_explanation():
    assert disagreement([_episode(10.0, True, "complete"), _episode(3.0, False, "collision")]) is None
    assert disagreement([_episode(10.0, True, "complete"), _episode(12.0, True, "complete")]) is None
    assert disagreement([_episode(1.0, False, "collision")]) is None
