"""RLiable statistics (Agarwal et al. 2021, "Deep RL at the Edge of the Statistical Precipice").

Every function takes score arrays shaped as rliable wants them — ``(n_runs, n_tasks)``
for final scores, ``(n_runs, n_tasks, n_points)`` for curves — and a ``seed``: each call
seeds the bootstrap afresh with it (NumPy's global RNG, which rliable 1.2 actually draws
from, restored afterwards; and ``random_state=RandomState(seed)``), so the same inputs
and seed always give the same intervals, and equal what ``np.random.seed(seed)`` followed
by ``rliable.library.get_interval_estimates(..., random_state=RandomState(seed))`` gives.  Intervals are 95 %
percentile intervals of ``reps`` stratified bootstrap replicates (runs resampled with
replacement within each task).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

#: confidence of every interval
CONFIDENCE = 0.95
#: aggregate metrics, in report order; optimality gap is 1 − mean of min(score, 1) (lower is better)
AGGREGATES = ("median", "iqm", "mean", "optimality_gap")


@dataclass(frozen=True)
class Estimate:
    """A point estimate with its 95 % interval (arrays for curves and profiles)."""

    value: np.ndarray
    low: np.ndarray
    high: np.ndarray


def _rng(seed: int) -> np.random.RandomState:
    return np.random.RandomState(seed)


def _intervals(scores: Mapping, func, reps: int, seed: int) -> dict:
    import warnings

    from rliable import library as rly

    # rliable 1.2's stratified bootstraps draw their indices from NumPy's *global* RNG
    # (np.random.choice) whatever random_state says: seed that, and give it back after.
    saved = np.random.get_state()
    np.random.seed(seed)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)  # arch: random_state is deprecated
            points, intervals = rly.get_interval_estimates(
                dict(scores), func, reps=reps, confidence_interval_size=CONFIDENCE, random_state=_rng(seed)
            )
    finally:
        np.random.set_state(saved)
    return {
        k: Estimate(np.asarray(points[k]), np.asarray(intervals[k][0]), np.asarray(intervals[k][1])) for k in scores
    }


def iqm(scores: Mapping[str, np.ndarray], reps: int = 2000, seed: int = 0) -> dict[str, Estimate]:
    """Interquartile mean of ``(n_runs, n_tasks)`` scores per algorithm, with its 95 % CI (shape ``(1,)``)."""
    from rliable import metrics

    return _intervals(scores, lambda x: np.array([metrics.aggregate_iqm(x)]), reps, seed)


def aggregates(scores: Mapping[str, np.ndarray], reps: int = 2000, seed: int = 0) -> dict[str, dict[str, Estimate]]:
    """``algo -> {median, iqm, mean, optimality_gap} -> Estimate`` of ``(n_runs, n_tasks)`` scores."""
    from rliable import metrics

    def func(x: np.ndarray) -> np.ndarray:
        return np.array(
            [
                metrics.aggregate_median(x),
                metrics.aggregate_iqm(x),
                metrics.aggregate_mean(x),
                metrics.aggregate_optimality_gap(x),
            ]
        )

    out = _intervals(scores, func, reps, seed)
    return {
        algo: {name: Estimate(e.value[i], e.low[i], e.high[i]) for i, name in enumerate(AGGREGATES)}
        for algo, e in out.items()
    }


def iqm_curves(curves: Mapping[str, np.ndarray], reps: int = 2000, seed: int = 0) -> dict[str, Estimate]:
    """IQM over runs and tasks at each point of ``(n_runs, n_tasks, n_points)`` curves, with 95 % bands."""
    from rliable import metrics

    def func(x: np.ndarray) -> np.ndarray:
        return np.array([metrics.aggregate_iqm(x[..., t]) for t in range(x.shape[-1])])

    return _intervals(curves, func, reps, seed)


def performance_profiles(
    scores: Mapping[str, np.ndarray], taus: np.ndarray, reps: int = 2000, seed: int = 0
) -> dict[str, Estimate]:
    """Fraction of runs (over all tasks) with score > τ, for each τ in ``taus``, with 95 % bands.

    (rliable's ``create_performance_profile`` takes no random state; this is the same
    score-distribution profile through the seeded :func:`get_interval_estimates`.)
    """

    def func(x: np.ndarray) -> np.ndarray:
        return np.array([np.mean(x > tau) for tau in taus])

    return _intervals(scores, func, reps, seed)


def probability_of_improvement(
    scores: Mapping[str, np.ndarray], reps: int = 2000, seed: int = 0
) -> dict[tuple[str, str], Estimate]:
    """P(X > Y) for every ordered pair of algorithms X ≠ Y: the probability that a run of X
    beats a run of Y on a random task (Mann-Whitney U / n_x n_y, averaged over tasks), with 95 % CI."""
    algos = sorted(scores)
    return probability_of_improvement_pairs(
        {(x, y): (scores[x], scores[y]) for x in algos for y in algos if x != y}, reps, seed
    )


def probability_of_improvement_pairs(
    pairs: Mapping[tuple[str, str], tuple[np.ndarray, np.ndarray]], reps: int = 2000, seed: int = 0
) -> dict[tuple[str, str], Estimate]:
    """P(X > Y) for given pairs ``(x, y) -> (scores of x, scores of y)``, bootstrapped in the
    order given; X and Y must have the same tasks, in the same column order (their run
    counts may differ) — e.g. two algorithms' final scores on the envs they share."""
    from rliable import metrics

    if not pairs:
        return {}
    for (x, y), (sx, sy) in pairs.items():
        if np.shape(sx)[1:] != np.shape(sy)[1:]:
            raise ValueError(f"P({x} > {y}): task counts differ ({np.shape(sx)} vs {np.shape(sy)})")
    out = _intervals({k: [v[0], v[1]] for k, v in pairs.items()}, metrics.probability_of_improvement, reps, seed)
    return {k: Estimate(e.value.reshape(()), e.low.reshape(()), e.high.reshape(())) for k, e in out.items()}
