"""Whether a ``pyflyt tune`` study found anything: its trials against the random policy
and the shipped tuning, with the spread of their evaluations.

Every trial's score is the mean return of ``n`` evaluation episodes (``train.eval_episodes``)
with sample standard deviation ``s``; its standard error is ``s / sqrt(n)``.  Score ``a``
is **better** than score ``b`` when

    mean_a - mean_b > Z * sqrt(se_a^2 + se_b^2),      Z = 2

(a one-sided Welch z-test at about the 2 % level for normal returns).  With a single
evaluation episode there is no spread to judge by: nothing counts as better.

The verdict:

* ``beats_random``: the best trial is better than a uniformly random policy evaluated on
  the same episodes (same env, seeds and count as the trials' evaluations);
* ``beats_baseline``: the best trial is better than the baseline trial (the configuration
  as composed: the shipped tuning), None when the study has none;
* ``parameters_matter``: the best trial is better than the worst complete trial: only
  then is a parameter-importance plot drawn;
* ``finding``: beats the random policy, and the baseline when there is one: only then
  are the best settings written and recommended.

What the spread covers: evaluation noise of one trained policy.  Each trial is one
training seed, so seed-to-seed variation is not in it; a finding is worth confirming by
training the best settings with other seeds (``pyflyt train seed=<k>``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

Z = 2.0


@dataclass(frozen=True)
class Score:
    """Mean and sample standard deviation of ``n`` evaluation returns."""

    mean: float
    std: float
    n: int
    label: str = ""

    @property
    def se(self) -> float:
        """Standard error of the mean (inf with fewer than two episodes: no spread known)."""
        return self.std / math.sqrt(self.n) if self.n >= 2 else math.inf

    def __str__(self) -> str:
        spread = f" ± {self.se:.2f} (s.e., {self.n} episodes)" if math.isfinite(self.se) else f" ({self.n} episode)"
        return f"{self.label} {self.mean:.2f}{spread}".strip()


def better(a: Score, b: Score, z: float = Z) -> bool:
    """Whether ``a``'s mean exceeds ``b``'s by more than ``z`` combined standard errors."""
    margin = math.sqrt(a.se**2 + b.se**2)
    return math.isfinite(margin) and a.mean - b.mean > z * margin


def sample_std(values: Sequence[float]) -> float:
    """Sample standard deviation (n - 1), 0 for fewer than two values."""
    n = len(values)
    if n < 2:
        return 0.0
    mean = sum(values) / n
    return math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))


@dataclass(frozen=True)
class Verdict:
    """What a study's trials show (see the module docstring)."""

    best: Score
    worst: Score
    random: Score
    baseline: Score | None

    @property
    def beats_random(self) -> bool:
        return better(self.best, self.random)

    @property
    def beats_baseline(self) -> bool | None:
        return None if self.baseline is None else better(self.best, self.baseline)

    @property
    def parameters_matter(self) -> bool:
        return better(self.best, self.worst)

    @property
    def finding(self) -> bool:
        return self.beats_random and self.beats_baseline is not False

    def lines(self) -> list[str]:
        """The report, worded by what the numbers support."""
        out = [f"best trial: {self.best}", f"random policy: {self.random}"]
        if self.baseline is not None:
            out.append(f"shipped tuning (baseline trial): {self.baseline}")
        rule = f"(better: more than {Z:g} combined standard errors of the evaluation returns)"
        if not math.isfinite(self.best.se):
            out.append(
                "no finding: with one evaluation episode per trial there is no spread to tell results from noise; "
                "set train.eval_episodes to 5 or more " + rule
            )
        elif not self.beats_random:
            out.append(f"no finding: the best trial is not better than a random policy {rule}")
        elif self.beats_baseline is False:
            out.append(f"no finding: the best trial is within noise of the shipped tuning; keep it {rule}")
        else:
            against = "the random policy" + (" and the shipped tuning" if self.baseline is not None else "")
            out.append(
                f"finding: the best trial is better than {against} {rule}; each trial is one training seed, "
                "so confirm with other seeds before adopting it"
            )
        if not self.parameters_matter:
            out.append("no parameter importance: the trials' returns differ by less than their noise")
        return out


def random_policy_score(cfg) -> Score:  # noqa: ANN001 - a TrainConfig
    """The mean return of uniformly random actions over the episodes a trial's evaluation
    flies (same env, ``train.eval_episodes``, seeds ``seed + EVAL_SEED_OFFSET + i``)."""
    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.evaluation import EVAL_SEED_OFFSET, run_episodes

    env = EnvFactory(cfg.env, monitor=False)()
    try:
        env.action_space.seed(cfg.seed)
        episodes = run_episodes(
            lambda obs, deterministic: env.action_space.sample(),
            env,
            cfg.train.eval_episodes,
            cfg.seed + EVAL_SEED_OFFSET,
        )
    finally:
        env.close()
    returns = [e.ret for e in episodes]
    return Score(sum(returns) / len(returns), sample_std(returns), len(returns), "random policy")


def judge(study, complete: Sequence) -> Verdict:  # noqa: ANN001 - an Optuna study and its complete trials
    """The :class:`Verdict` of a study from its complete trials' values and stored spreads,
    the random policy's score (study user attribute ``random_policy``) and the baseline
    trial (the one enqueued with fixed parameters, when it completed)."""

    def score(trial, label: str) -> Score:  # noqa: ANN001
        attrs = trial.user_attrs
        return Score(float(trial.value), float(attrs.get("eval_std", 0.0)), int(attrs.get("eval_episodes", 1)), label)

    ranked = sorted(complete, key=lambda t: t.value)
    best, worst = score(ranked[-1], f"trial {ranked[-1].number}"), score(ranked[0], f"trial {ranked[0].number}")
    mean, std, n = study.user_attrs.get("random_policy", (math.nan, 0.0, 1))
    baseline = next((t for t in complete if "fixed_params" in t.system_attrs), None)
    reference = None if baseline is None else score(baseline, f"trial {baseline.number}")
    return Verdict(best, worst, Score(mean, std, n, "random policy"), reference)
