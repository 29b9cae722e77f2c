"""The verdict of a tuning study (pyflyt_cli/training/tune_verdict.py): a finding only when the
best trial beats the random policy and the shipped tuning by more than 2 combined standard errors."""

from __future__ import annotations

import math

import pytest

from pyflyt_cli.training.tune_verdict import Score, Verdict, better, sample_std


def test_better_is_a_two_standard_error_margin_by_hand():
    a, b = Score(10.0, 4.0, 16), Score(7.0, 4.0, 16)  # se 1 each: margin 2 sqrt(2) = 2.83
    assert better(a, b) and not better(b, a)
    assert not better(Score(9.0, 4.0, 16), b)  # 2.0 < 2.83
    assert not better(Score(1e9, 0.0, 1), b)  # one episode: no spread, nothing is better
    assert sample_std([1.0, 2.0, 3.0, 4.0]) == pytest.approx(math.sqrt(5 / 3))


def test_the_issue_case_three_trials_at_random_level_is_no_finding():
    # returns -110 to -117 with episode spreads of ~10 over 5 episodes; random policy -115 +- 10
    trials = [Score(-110.0, 10.0, 5), Score(-113.0, 11.0, 5), Score(-117.0, 9.0, 5)]
    verdict = Verdict(trials[0], trials[-1], Score(-115.0, 10.0, 5), trials[1])
    assert not verdict.beats_random and not verdict.finding and not verdict.parameters_matter
    text = "\n".join(verdict.lines())
    assert "no finding: the best trial is not better than a random policy" in text
    assert "no parameter importance" in text


def test_a_real_improvement_is_a_finding_and_equal_to_the_baseline_is_not():
    random, baseline = Score(-115.0, 10.0, 10), Score(200.0, 20.0, 10)
    best, worst = Score(400.0, 20.0, 10), Score(-100.0, 10.0, 10)
    verdict = Verdict(best, worst, random, baseline)
    assert verdict.finding and verdict.parameters_matter
    text = "\n".join(verdict.lines())
    assert "finding: the best trial is better than the random policy and the shipped tuning" in text
    level = Verdict(Score(205.0, 20.0, 10), worst, random, baseline)  # 5 < 2 * 8.9
    assert level.beats_random and level.beats_baseline is False and not level.finding
    assert "within noise of the shipped tuning; keep it" in "\n".join(level.lines())
    no_baseline = Verdict(best, worst, random, None)
    assert no_baseline.finding and no_baseline.beats_baseline is None
