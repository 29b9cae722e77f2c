"""A benchmark directory as arrays: eval curves per (env, algo), aligned, normalised.

Layout read (what ``pyflyt train`` writes under ``train.output_dir``)::

    <benchmark>/[runs/]<env>/<algo>/<run>/metrics.mcap     # "/eval" records: {step, mean_return, ...}
    <benchmark>/normalisation.yaml                        # optional: {<env>: {random: R, reference: S, source: ...}}

A run directory is any directory at that depth holding ``metrics.mcap``; env, algo and
seed come from the file's metadata when present, else from the path.

The grid of (env, algo) may be partial — e.g. SAC on the dense-reward tasks and AWAC on
the sparse ones: every algorithm's arrays then cover only its own envs (``algo_envs``).
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from pyflyt_engine.errors import ConfigError, PyFlytError

NORMALISATION_FILE = "normalisation.yaml"
_SEED = re.compile(r"seed(\d+)$")


@dataclass(frozen=True)
class RunCurve:
    """One run's evaluation curve: ``returns[i]`` is the mean eval return at env step ``steps[i]``."""

    env: str
    algo: str
    seed: int | None
    run_dir: Path
    steps: np.ndarray  # (n_evals,) int, increasing
    returns: np.ndarray  # (n_evals,) float, mean return over the evaluation episodes


@dataclass(frozen=True)
class Normalisation:
    """Per env: score = (return − random) / (reference − random); 0 = random policy, 1 = reference."""

    random: float
    reference: float
    source: str

    def __call__(self, returns: np.ndarray) -> np.ndarray:
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused by load_benchmark, in one line
            return (np.asarray(returns, dtype=float) - self.random) / (self.reference - self.random)


@dataclass
class Benchmark:
    """Aligned, normalised scores of a benchmark directory."""

    root: Path
    runs: list[RunCurve]
    envs: list[str]  # sorted
    algos: list[str]  # sorted
    #: algo -> sorted envs it has runs on (every env in a full grid)
    algo_envs: dict[str, list[str]]
    #: env -> common step grid (every run of that env was evaluated up to its last point)
    grids: dict[str, np.ndarray]
    #: algo -> (n_runs, len(algo_envs[algo]), n_points) normalised scores on each env's grid
    #: (n_points: the shortest grid among the envs linked to its envs by common algorithms),
    #: envs in the order of ``algo_envs[algo]``
    curves: dict[str, np.ndarray]
    #: algo -> (n_runs, len(algo_envs[algo])) normalised final scores (last grid point)
    final: dict[str, np.ndarray]
    normalisation: dict[str, Normalisation]
    #: (env, algo) -> seeds used, for the pairs that have runs; runs beyond the smallest count per algo
    #: are left out (rliable needs equal counts)
    seeds: dict[tuple[str, str], list[int | None]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def full_grid(self) -> bool:
        """Every algorithm has runs on every env."""
        return all(self.algo_envs[a] == self.envs for a in self.algos)

    def shared_envs(self, x: str, y: str) -> list[str]:
        """Sorted envs both ``x`` and ``y`` have runs on."""
        return sorted(set(self.algo_envs[x]) & set(self.algo_envs[y]))


def _check_closed(path: Path, root: Path | None = None) -> None:
    """Refuse a benchmark (or, under ``root``, a run) directory with a link leading out of it or a special file."""
    from pyflyt_cli.training.rundir import RunDirError, check_closed
    from pyflyt_engine.safe_load import outside

    if root is None:
        check_closed(path, folders=(), what="benchmark directory")
        return
    if outside(root, path):
        raise RunDirError(
            f"{path} leads outside {root} (a link on its way): a shared benchmark directory is read only inside "
            "itself; replace the link by a copy of what it points to"
        )
    check_closed(path)


def _run_dirs(root: Path) -> list[Path]:
    base = root / "runs" if (root / "runs").is_dir() else root
    return sorted({p.parent for p in base.glob("*/*/*/metrics.mcap")})


#: the longest env or algorithm name a report shows
MAX_NAME = 100
#: characters a name may not hold: they would be read as mathematics by matplotlib's labels
#: (``$``), or end a cell of the report's Markdown tables (``|``, a backtick)
_NOT_IN_NAMES = "$|`"


def _name(run_dir: Path, what: str, value: object) -> str:
    """An env or algorithm name of a run as the report shows it; refused in one line if it cannot be shown."""
    text = value if isinstance(value, str) else ""
    if not text or len(text) > MAX_NAME or not text.isprintable() or any(c in text for c in _NOT_IN_NAMES):
        shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
        raise ConfigError(
            f"{run_dir}: its {what} name {shown} cannot label a report: give a name of 1 to {MAX_NAME} printable "
            f"characters, none of {' '.join(_NOT_IN_NAMES)} (no line breaks or control characters)"
        )
    return text


def _eval_point(run_dir: Path, record: dict) -> tuple[int, float] | None:
    """(step, mean return) of one ``/eval`` record, None without a return; a record of another shape is refused."""
    if "mean_return" not in record:
        return None
    step, value = record.get("step"), record["mean_return"]
    if isinstance(step, bool) or not isinstance(step, int) or not 0 <= step < 2**63:
        raise ConfigError(f"{run_dir}: an /eval record has the step {step!r}; a step is a whole number >= 0")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
        raise ConfigError(f"{run_dir}: the /eval record at step {step} has mean_return {shown}, not a number")
    return step, float(value)


def read_run(run_dir: Path) -> RunCurve | None:
    """The ``/eval`` curve of one run directory (None if it has no evaluation records).

    A non-finite mean return (a diverged evaluation) is left out; a record of another shape
    (a step or return that is not a number), a name the report cannot show, or a seed that
    is not a whole number is refused in one line (:class:`ConfigError`).
    """
    from pyflyt_engine.telemetry.metrics import read_metrics, read_metrics_metadata

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a truncated segment still gives its complete records
        records = read_metrics(run_dir).get("/eval", [])
        meta = read_metrics_metadata(run_dir)[0]
    points = [p for p in (_eval_point(run_dir, r) for r in records if isinstance(r, dict)) if p is not None]
    pairs = sorted(dict(points).items())
    pairs = [(s, r) for s, r in pairs if np.isfinite(r)]
    if not pairs:
        return None
    seed = meta.get("seed")
    if seed is None:
        m = _SEED.search(run_dir.name)
        seed = m.group(1) if m else None
    if seed is not None and not re.fullmatch(r"\d{1,18}", str(seed)):
        raise ConfigError(f"{run_dir}: its metadata seed {str(seed)[:40]!r} is not a whole number >= 0")
    return RunCurve(
        env=_name(run_dir, "env", meta.get("env") or run_dir.parent.parent.name),
        algo=_name(run_dir, "algorithm", meta.get("algo") or run_dir.parent.name),
        seed=None if seed is None else int(seed),
        run_dir=run_dir,
        steps=np.array([s for s, _ in pairs], dtype=np.int64),
        returns=np.array([r for _, r in pairs], dtype=float),
    )


class _NormalisationEntry(BaseModel):
    """One env of ``normalisation.yaml``; every score finite."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    random: float = Field(description="mean return of a uniformly random policy (score 0)")
    reference: Optional[float] = Field(description="return that scores 1 (null: the best evaluation in the benchmark)")
    source: Optional[str] = Field(None, description="where the scores come from")


def read_normalisation(root: Path) -> dict[str, Normalisation]:
    """``normalisation.yaml`` of a benchmark (``{}`` if absent).

    Raises:
        ConfigError: the file cannot be read, is not YAML, is not a mapping of env names to
            ``{random, reference, source}``, or holds a score that is not a finite number.
    """
    from pyflyt_engine.loading import validate
    from pyflyt_engine.safe_load import load_yaml_file

    path = root / NORMALISATION_FILE
    if not path.is_file():
        return {}
    data = load_yaml_file(path)
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(
            f"{path}: must be a mapping of env names to {{random: R, reference: S, source: ...}}, "
            f"got {type(data).__name__}"
        )
    out = {}
    for env, entry in data.items():
        if not isinstance(entry, dict):
            raise ConfigError(
                f"{path}: {env}: needs a mapping {{random: R, reference: S, source: ...}} with numbers 'random' and "
                f"'reference' (reference may be null: the best evaluation in the benchmark), got {entry!r}"
            )
        checked = validate(_NormalisationEntry, entry, "normalisation entry", str(path), prefix=f"{env}.")
        norm = Normalisation(
            checked.random,
            math.nan if checked.reference is None else checked.reference,
            checked.source if checked.source is not None else path.name,
        )
        if norm.reference == norm.random:
            raise ConfigError(
                f"{path}: {env}: reference and random scores are equal ({norm.random}); "
                "give a reference score above the random one"
            )
        out[str(env)] = norm
    return out


def load_benchmark(root: str | Path, normalisation: dict[str, Normalisation] | None = None) -> Benchmark:
    """Read every run under ``root``, align and normalise (raises :class:`ConfigError` with the fix).

    * Alignment: per env, the grid is every eval step (of any run) up to the *earliest*
      last evaluation among that env's runs; each curve is linearly interpolated on it.
      Envs with grids of different lengths are compared point by point on the shortest.
    * Normalisation: ``normalisation`` or ``<root>/normalisation.yaml``; an env without an
      entry falls back to the lowest and highest eval return seen in the benchmark for it
      (recorded as such in the report).
    * Equal run counts: rliable needs the same number of runs of an algorithm on every
      env it ran on; extra runs (highest seeds) are left out and noted.
    * Partial grids: an algorithm need not run on every env; its arrays cover the envs
      in ``algo_envs[algo]``, and a note says that aggregates of algorithms with
      different env sets are not comparable.
    """
    root = Path(root)
    if not root.is_dir():
        raise ConfigError(f"benchmark directory {root} does not exist")
    _check_closed(root)
    dirs = _run_dirs(root)
    for d in dirs:  # a shared benchmark is read only inside itself
        _check_closed(d, root)
    if not dirs:
        raise ConfigError(
            f"no runs in {root}: expected <env>/<algo>/<run>/metrics.mcap (or runs/<env>/<algo>/<run>/...) "
            "as written by pyflyt train train.output_dir=<benchmark>"
        )
    runs: list[RunCurve] = []
    empty: list[Path] = []
    for d in dirs:
        try:
            curve = read_run(d)
        except PyFlytError as exc:
            reason = str(exc).removeprefix(f"{d}: ")  # the run is named once
            raise ConfigError(f"{d}: unreadable metrics: {reason}") from None
        if curve is not None:
            runs.append(curve)
        else:
            empty.append(d)
    if not runs:
        raise ConfigError(
            f"none of the {len(dirs)} runs in {root} has evaluation metrics (/eval records); "
            "train with train.eval_freq > 0"
        )
    notes = [f"left out (no evaluation records): {d}" for d in empty]
    envs = sorted({r.env for r in runs})
    algos = sorted({r.algo for r in runs})
    algo_envs = {a: sorted({r.env for r in runs if r.algo == a}) for a in algos}
    if any(algo_envs[a] != envs for a in algos):
        notes.append(
            "partial grid: "
            + "; ".join(f"{a} ran on {', '.join(algo_envs[a])}" for a in algos)
            + ". Aggregates, performance profiles and all-env curves are per algorithm over its own envs, "
            "so aggregates of algorithms with different env sets are not comparable; compare them per env, "
            "or by the probability of improvement on their shared envs"
        )

    norms = dict(read_normalisation(root) if normalisation is None else normalisation)
    for env in envs:
        if env in norms and math.isnan(norms[env].reference):  # reference: null -> the best evaluation seen
            best = float(max(r.returns.max() for r in runs if r.env == env))
            given = norms[env]
            if best <= given.random:
                best = given.random + 1.0
            norms[env] = Normalisation(
                given.random, best, f"{given.source}; reference: best evaluation in the benchmark"
            )
            notes.append(f"{env}: no reference score given; 1 is the best mean evaluation return in this benchmark")
        if env not in norms:
            values = np.concatenate([r.returns for r in runs if r.env == env])
            lo, hi = float(values.min()), float(values.max())
            if hi == lo:
                hi = lo + 1.0
            norms[env] = Normalisation(lo, hi, "observed min/max eval return (no normalisation.yaml entry)")
            notes.append(f"{env}: no random/reference scores given; normalised by the observed min and max")

    grids: dict[str, np.ndarray] = {}
    for env in envs:
        mine = [r for r in runs if r.env == env]
        end = min(int(r.steps[-1]) for r in mine)
        grid = np.unique(np.concatenate([r.steps[r.steps <= end] for r in mine]))
        grids[env] = grid
    # envs linked by a common algorithm are compared point by point: each such group of
    # envs uses the length of its shortest grid (a full grid is one group)
    group = {env: {env} for env in envs}
    for algo in algos:
        linked = set().union(*(group[e] for e in algo_envs[algo]))
        for env in linked:
            group[env] = linked
    n_of = {env: min(len(grids[e]) for e in group[env]) for env in envs}

    counts = {a: min(sum(1 for r in runs if r.env == e and r.algo == a) for e in algo_envs[a]) for a in algos}
    curves, final, seeds = {}, {}, {}
    for algo in algos:
        per_env = []
        for env in algo_envs[algo]:
            mine = sorted(
                (r for r in runs if r.env == env and r.algo == algo),
                key=lambda r: (r.seed is None, r.seed, str(r.run_dir)),
            )
            if len(mine) > counts[algo]:
                notes.append(f"{env}/{algo}: {len(mine) - counts[algo]} extra run(s) left out (equal counts per env)")
            mine = mine[: counts[algo]]
            seeds[(env, algo)] = [r.seed for r in mine]
            grid = grids[env][-n_of[env] :]
            per_env.append([norms[env](np.interp(grid, r.steps, r.returns)) for r in mine])
        curves[algo] = np.transpose(np.array(per_env), (1, 0, 2))  # (runs, envs, points)
        final[algo] = curves[algo][:, :, -1]
        for env, scores in zip(algo_envs[algo], per_env):
            if not np.isfinite(
                scores
            ).all():  # returns so large that (return - random) / (reference - random) overflows
                largest = max(float(np.abs(r.returns).max()) for r in runs if r.env == env)
                raise ConfigError(
                    f"{env}/{algo}: the normalised scores are not finite numbers (returns up to {largest:g} in "
                    f"magnitude overflow the normalisation {norms[env].random:g} .. {norms[env].reference:g}); "
                    "these metrics were not written by pyflyt train, or give normalisation.yaml scores for this env"
                )
    for env in envs:
        if len(grids[env]) > n_of[env]:
            notes.append(
                f"{env}: its grid is longer than that of the envs it is compared with: curves use its last "
                f"{n_of[env]} points"
            )
    grids = {e: g[-n_of[e] :] for e, g in grids.items()}
    return Benchmark(root, runs, envs, algos, algo_envs, grids, curves, final, norms, seeds, notes)
