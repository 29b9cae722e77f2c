"""``pyflyt tune``: hyper-parameter search with Optuna over a search space declared in ``conf/``.

    from pyflyt_cli.training.tune import TuneOptions, tune
    report = tune("quadx_hover", "sac", TuneOptions(trials=20, jobs=2), overrides=["train.total_timesteps=30000"])

* The **search space** of an algorithm is ``conf/search_space/<algo>.yaml`` (or any file
  given as ``space=<path>``): training-config keys mapped to distributions
  (``{type: float, low, high, log}``, ``{type: int, low, high, step, log}``,
  ``{type: categorical, choices: [...]}``); a sampled trial is a list of overrides of
  ``pyflyt train`` (``algo.learning_rate=0.0007``).
* Each **trial** is a complete training run (run directory, checkpoints, evaluations) in
  ``<study_dir>/trials/trial_<n>``; its evaluations are reported to Optuna, and the pruner
  (``median`` by default) stops a trial whose evaluation curve falls behind the others'
  at the same step.  The objective is the final evaluation's mean return (``last``) or the
  best one (``best``).
* A new study's first trial is the **baseline** (``baseline``, on by default): the
  configuration as composed, with the space's keys at their configured values (skipped,
  with a message naming the key, when one lies outside its distribution).
* The **study** lives in ``<study_dir>/study.db`` (SQLite): the same command again
  continues it up to ``trials`` finished trials (complete or pruned); a trial cut short
  by a kill is marked failed and replaced.
* ``jobs`` trials run at once, each in its own process (training seeds and random
  streams stay per process).  The sampler (TPE) is seeded with ``sampler_seed`` (+ the
  worker index): with ``jobs=1`` the same command samples the same trials, and each
  trial, trained with the run's ``seed``, gives the same numbers.
* At the end: the verdict (:mod:`pyflyt_cli.training.tune_verdict`): the best trial
  against a random policy and the baseline trial, by the spread of their evaluation
  returns.  Only on a finding ``best_<env>_<algo>.yaml``, the best trial's settings as a
  ``conf/hparams``-style file (use it as ``pyflyt train experiment=<that file>`` or copy
  it to ``conf/hparams/<env>_<algo>.yaml``); ``trials.csv`` and Optuna's ``history.png``
  always; ``importance.png`` only when the trials differ by more than their noise.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator

from pyflyt_cli.compose import override_value
from pyflyt_engine import limits
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.loading import available, describe_error, problem_list, problems, resolve
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.safe_load import load_yaml_file, yaml_data

Log = Callable[[str], None]

#: the keys ``pyflyt tune`` takes itself; every other key=value is a training override
TUNE_KEYS = (
    "trials",
    "jobs",
    "space",
    "study_dir",
    "sampler_seed",
    "objective",
    "pruner",
    "startup_trials",
    "warmup_steps",
    "baseline",
)


class TuneOptions(BaseModel):
    """Options of a study (``conf/tune.yaml`` holds the defaults)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    trials: int = Field(ge=1, description="finished trials (complete or pruned) the study should hold")
    jobs: int = Field(ge=1, description="trials run at once, each in its own process")
    space: str | None = Field(description="search space: a name in conf/search_space or a YAML file; null: the algo's")
    study_dir: str | None = Field(description="where the study, its trials and report go; null: tune/<env>_<algo>")
    sampler_seed: int = Field(ge=0, description="seed of the TPE sampler (worker k of jobs uses seed + k)")
    objective: Literal["last", "best"] = Field(
        description="last: the final evaluation's mean return; best: the best one"
    )
    pruner: Literal["median", "none"] = Field(
        description="median: stop a trial below the median of the others at a step"
    )
    startup_trials: int = Field(ge=0, description="trials finished before the pruner prunes")
    warmup_steps: int = Field(ge=0, description="environment steps of a trial before it may be pruned")
    baseline: bool = Field(
        description="a new study's first trial trains the configuration as composed (when the space holds its values)"
    )

    @field_validator("trials", "jobs")
    @classmethod
    def _bounded(cls, value: int, info: ValidationInfo) -> int:
        key = "tune.trials" if info.field_name == "trials" else "jobs"
        return limits.check(key, value, name=info.field_name)

    @field_validator("study_dir")
    @classmethod
    def _study_dir(cls, value: str | None) -> str | None:
        # a database URL given where a directory is expected made a folder named 'sqlite:'
        if value is not None and re.match(r"^[A-Za-z][A-Za-z0-9+.-]*://", value):
            raise ValueError(
                f"study_dir={value!r} looks like a database URL; give a directory (the study is kept in "
                "<study_dir>/study.db, e.g. study_dir=tune/my_study)"
            )
        return value


def tune_defaults() -> dict[str, Any]:
    data = load_yaml_file(conf_dir() / "tune.yaml")
    if not isinstance(data, dict):  # pragma: no cover - broken install
        raise ConfigError(f"{conf_dir() / 'tune.yaml'}: not a mapping")
    return data


def parse_tune_options(data: Mapping[str, Any]) -> TuneOptions:
    """Validate options (keys left out take ``conf/tune.yaml``'s values); a :class:`ConfigError` names the key."""
    try:
        return TuneOptions.model_validate({**tune_defaults(), **dict(data)})
    except ValidationError as exc:
        raise ConfigError("invalid tune options:\n" + problem_list(problems(TuneOptions, exc))) from None


# --------------------------------------------------------------------- search space


class _Param(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    type: Literal["float", "int", "categorical"]
    low: float | None = None
    high: float | None = None
    log: bool = False
    step: float | None = None
    choices: list[Any] | None = None

    def bounds(self) -> tuple[float, float]:
        """``(low, high)`` of a float or int distribution (:func:`load_search_space` requires both)."""
        assert self.low is not None and self.high is not None, f"a {self.type} distribution without low/high"
        return self.low, self.high


@dataclass(frozen=True)
class SearchSpace:
    """Training-config keys and their distributions."""

    source: Path
    params: dict[str, _Param]

    def sample(self, trial: Any) -> dict[str, Any]:
        """One value per key, drawn by ``trial`` (an Optuna trial)."""
        values: dict[str, Any] = {}
        for key, p in self.params.items():
            if p.type == "float":
                low, high = p.bounds()
                values[key] = trial.suggest_float(key, low, high, log=p.log, step=p.step)
            elif p.type == "int":
                low, high = p.bounds()
                values[key] = trial.suggest_int(key, int(low), int(high), log=p.log, step=int(p.step or 1))
            else:
                encoded = [_encode(c) for c in p.choices or []]
                values[key] = _decoded(trial.suggest_categorical(key, encoded))
        return values

    def holds(self, key: str, value: Any) -> bool:
        """Whether ``value`` is one the distribution of ``key`` can give."""
        p = self.params[key]
        if p.type == "categorical":
            return _encode(value) in [_encode(c) for c in p.choices or []]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return False
        if p.type == "int" and int(value) != value:
            return False
        low, high = p.bounds()
        return float(low) <= float(value) <= float(high)

    def enqueued(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """``values`` (one per key) as Optuna takes them in ``enqueue_trial``."""
        return {k: _encode(v) if self.params[k].type == "categorical" else v for k, v in values.items()}

    def corners(self) -> list[dict[str, Any]]:
        """Each distribution's low end and high end (or first and last choice): checked before a study."""
        lows: dict[str, Any] = {}
        highs: dict[str, Any] = {}
        for key, p in self.params.items():
            if p.type == "categorical":
                lows[key], highs[key] = (p.choices or [None])[0], (p.choices or [None])[-1]
            else:
                cast = int if p.type == "int" else float
                low, high = p.bounds()
                lows[key], highs[key] = cast(low), cast(high)
        return [lows, highs]


def _encode(value: Any) -> str:
    """A categorical choice as Optuna stores it: its YAML/JSON text (lists are not Optuna choices)."""
    return json.dumps(value)


def overrides_of(values: Mapping[str, Any]) -> list[str]:
    """``{"algo.learning_rate": 1e-3}`` -> ``["algo.learning_rate=0.001"]`` (Hydra's override grammar)."""
    return [f"{key}={override_value(value)}" for key, value in values.items()]


def load_search_space(space: str | None, algo: str) -> SearchSpace:
    """``space`` (a name in ``conf/search_space`` or a YAML file) or, for None, the algorithm's."""
    name = space or algo
    path = resolve(
        name,
        "search_space",
        what="search space",
        unknown=lambda _: (
            f"space={name}: no search space named so; shipped: {', '.join(available('search_space'))}, "
            "or give a YAML file"
        ),
    )
    from pyflyt_cli.training.schema import OPT_INS

    data = load_yaml_file(path, what="search space")
    if not isinstance(data, dict) or not data:
        raise ConfigError(f"{path}: a search space maps training keys (algo.learning_rate) to distributions")
    params: dict[str, _Param] = {}
    for key, spec in data.items():
        where = f"{path}: {key}"
        if key in OPT_INS:
            raise ConfigError(f"{where}: {key} is an opt-in, given on the command line only, never searched over")
        if not isinstance(spec, dict):
            raise ConfigError(f"{where}: give a distribution, e.g. {{type: float, low: 1e-4, high: 1e-2, log: true}}")
        try:
            param = _Param.model_validate(spec)
        except ValidationError as exc:
            raise ConfigError(f"{path}: {describe_error(_Param, exc.errors()[0], prefix=f'{key}.')}") from None
        if param.type == "categorical":
            if not param.choices:
                raise ConfigError(f"{where}: a categorical distribution needs a non-empty list of choices")
        else:
            if param.low is None or param.high is None or not param.low < param.high:
                raise ConfigError(f"{where}: needs low < high (got low={param.low}, high={param.high})")
            if param.log and param.low <= 0:
                raise ConfigError(f"{where}: a log distribution needs low > 0")
            if param.log and param.step is not None:
                raise ConfigError(f"{where}: give either log: true or a step, not both")
        params[str(key)] = param
    return SearchSpace(path, params)


# ------------------------------------------------------------------------ the study


@dataclass(frozen=True)
class TuneReport:
    """What :func:`tune` did and wrote."""

    study_dir: Path
    storage: str
    finished: int
    ran: int
    best_value: float | None
    best_params: dict[str, Any] | None
    best_file: Path | None
    plots: list[Path]
    #: whether the trials beat the random policy and the shipped tuning (tune_verdict)
    verdict: Any = None


def study_name(env: str, algo: str) -> str:
    return f"{env}_{algo}"


def _storage_url(study_dir: Path) -> str:
    return f"sqlite:///{study_dir / 'study.db'}"


def _pruner(opts: TuneOptions) -> Any:
    import optuna

    if opts.pruner == "none":
        return optuna.pruners.NopPruner()
    return optuna.pruners.MedianPruner(n_startup_trials=opts.startup_trials, n_warmup_steps=opts.warmup_steps)


def _study(study_dir: Path, env: str, algo: str, opts: TuneOptions, worker: int = 0) -> Any:
    import optuna

    from pyflyt_cli.training.rundir import RunDirError
    from pyflyt_engine.safe_load import check_own_file

    for name in ("study.db", "study.db-journal", "study.db-wal"):  # SQLite writes them in place
        check_own_file(study_dir / name, what="study database", error=RunDirError)

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna.create_study(
        study_name=study_name(env, algo),
        storage=_storage_url(study_dir),
        direction="maximize",
        sampler=optuna.samplers.TPESampler(seed=opts.sampler_seed + worker),
        pruner=_pruner(opts),
        load_if_exists=True,
    )


def _config_value(cfg: Any, key: str) -> Any:
    """The value at a dotted key of a composed training configuration (models and mappings)."""
    value = cfg
    for part in key.split("."):
        value = value[part] if isinstance(value, Mapping) else getattr(value, part)
    if isinstance(value, tuple):
        value = list(value)
    return value


def _enqueue_baseline(study: Any, cfg: Any, space: SearchSpace, log: Log) -> None:
    """Make a new study's first trial the configuration as composed, when the space can hold it."""
    values = {key: _config_value(cfg, key) for key in space.params}
    outside = [f"{key}={values[key]!r}" for key in space.params if not space.holds(key, values[key])]
    if outside:
        log(
            "baseline trial skipped: the configuration's "
            + ", ".join(outside)
            + " lie(s) outside the search space (widen it to include them, or set baseline=false)"
        )
        return
    study.enqueue_trial(space.enqueued(values))
    log("trial 0 is the baseline: the configuration as composed (shipped tuning and fixed overrides)")


def _finished(study: Any) -> int:
    from optuna.trial import TrialState

    return len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED)))


class _ReportEvaluations:
    """After each evaluation: report its mean return to the trial; end the run if it is to be pruned."""

    def __new__(cls, trial: Any) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        class Report(BaseCallback):
            def __init__(self) -> None:
                super().__init__()
                self.pruned_at: int | None = None

            def _on_step(self) -> bool:
                parent: Any = self.parent  # the evaluation that calls it (its last_mean_reward)
                step = int(parent.num_timesteps)
                trial.report(float(parent.last_mean_reward), step)
                if trial.should_prune():
                    self.pruned_at = step
                    return False
                return True

        return Report()


def run_trial(
    trial: Any, env: str, algo: str, study_dir: Path, space: SearchSpace, base: Sequence[str], objective: str, log: Log
) -> float:
    """Train one trial's configuration; its objective, or ``TrialPruned``."""
    import optuna

    from pyflyt_cli.training.compose import compose_config
    from pyflyt_cli.training.loop import train

    values = space.sample(trial)
    overrides = [*base, *overrides_of(values)]
    try:
        cfg = compose_config(env=env, algo=algo, overrides=overrides)
    except Exception as exc:  # noqa: BLE001 - a sampled combination the schema refuses: not a result
        trial.set_user_attr("refused", str(exc).splitlines()[0])
        log(f"trial {trial.number}: settings refused ({str(exc).splitlines()[0]})")
        raise optuna.TrialPruned() from None
    run_dir = study_dir / "trials" / f"trial_{trial.number:04d}"
    trial.set_user_attr("run_dir", str(run_dir))
    trial.set_user_attr("overrides", overrides_of(values))
    report = _ReportEvaluations(trial)
    result = train(cfg, run_dir=run_dir, after_eval=[report], overrides=overrides, command=["pyflyt", "tune"])
    if result.interrupted:
        raise KeyboardInterrupt
    shown = ", ".join(f"{k.split('.')[-1]}={v}" for k, v in values.items())
    if report.pruned_at is not None:
        log(f"trial {trial.number}: pruned at step {report.pruned_at} ({shown})")
        raise optuna.TrialPruned()
    last = result.last_eval
    if objective == "last":
        value = last["mean_return"] if last is not None else None
    else:
        value = result.best_mean_return
    if value is None:
        raise ConfigError("pyflyt tune needs evaluations: set train.eval_freq > 0")
    assert last is not None  # there were evaluations: the last one is recorded
    log(f"trial {trial.number}: return {value:.2f} ({shown})")
    # the spread of that evaluation, for the study's verdict (tune_verdict)
    n = int(cfg.train.eval_episodes)
    trial.set_user_attr("eval_std", float(last["std_return"]) * (n / (n - 1)) ** 0.5 if n > 1 else 0.0)
    trial.set_user_attr("eval_episodes", n)
    return float(value)


def _optimize(
    env: str, algo: str, study_dir: Path, opts: TuneOptions, base: Sequence[str], worker: int, log: Log
) -> None:
    """One worker: trials until the study holds ``opts.trials`` finished ones."""
    import torch
    from optuna.study import MaxTrialsCallback
    from optuna.trial import TrialState

    torch.set_num_threads(1)
    study = _study(study_dir, env, algo, opts, worker)
    space = load_search_space(opts.space, algo)
    stop = MaxTrialsCallback(opts.trials, states=(TrialState.COMPLETE, TrialState.PRUNED))
    # trials other workers are running count too, so the study does not end with jobs - 1 extra
    # trials (two workers checking at the same moment may still both start one)
    while _finished(study) + len(study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))) < opts.trials:
        study.optimize(
            lambda t: run_trial(t, env, algo, study_dir, space, base, opts.objective, log),
            n_trials=1,
            callbacks=[stop],
            catch=(),
        )


def _worker(env: str, algo: str, study_dir: str, opts: dict[str, Any], base: list[str], worker: int) -> None:
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent stops the workers

    def log(message: str) -> None:
        print(message, file=sys.stderr, flush=True)

    _optimize(env, algo, Path(study_dir), TuneOptions.model_validate(opts), base, worker, log)


@contextlib.contextmanager
def _study_lock(study_dir: Path) -> Iterator[None]:
    from pyflyt_cli.training.rundir import RunDirError, _alive, read_pid

    path = study_dir / "tune.lock"
    if path.exists():
        pid = read_pid(path)
        if pid and pid != os.getpid() and _alive(pid):
            raise RunDirError(f"{study_dir} is being tuned by process {pid}; wait for it or stop it (Ctrl-C)")
    from pyflyt_engine.safe_load import open_own_file

    fd = open_own_file(path, what="study lock file", error=RunDirError)  # not through a link or a second name
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
    finally:
        os.close(fd)
    try:
        yield
    finally:
        path.unlink(missing_ok=True)


def tune(
    env: str,
    algo: str,
    options: TuneOptions | Mapping[str, Any] | None = None,
    overrides: Sequence[str] = (),
    log: Log = lambda _: None,
) -> TuneReport:
    """Run (or continue) the study of ``algo`` on ``env`` up to ``trials`` finished trials; write the report."""
    from optuna.trial import TrialState

    from pyflyt_cli.training.compose import compose_config

    opts = options if isinstance(options, TuneOptions) else parse_tune_options(options or {})
    base = list(overrides)
    cfg = compose_config(env=env, algo=algo, overrides=base)  # the fixed settings are valid ...
    if cfg.train.eval_freq <= 0:
        raise ConfigError("pyflyt tune needs evaluations to compare trials: set train.eval_freq > 0")
    space = load_search_space(opts.space, algo)
    for corner in space.corners():  # ... and so are the search space's keys and bounds
        try:
            compose_config(env=env, algo=algo, overrides=[*base, *overrides_of(corner)])
        except Exception as exc:  # noqa: BLE001
            raise ConfigError(f"search space {space.source}: {exc}") from None
    study_dir = Path(opts.study_dir or Path("tune") / study_name(env, algo)).expanduser().resolve()
    study_dir.mkdir(parents=True, exist_ok=True)
    with _study_lock(study_dir):
        study = _study(study_dir, env, algo, opts)
        for stale in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
            study.tell(stale.number, state=TrialState.FAIL)  # cut short by a kill: replaced by a new trial
            log(f"trial {stale.number} was cut short by an interruption: marked failed, a new trial replaces it")
        if opts.baseline and not study.get_trials(deepcopy=False):
            _enqueue_baseline(study, cfg, space, log)
        before = _finished(study)
        log(
            f"study {study.study_name} in {study_dir / 'study.db'}: {before} of {opts.trials} trials finished; "
            f"space {space.source} ({len(space.params)} parameters); {opts.jobs} at a time"
        )
        if before < opts.trials:
            if opts.jobs == 1:
                _optimize(env, algo, study_dir, opts, base, 0, log)
            else:
                context = multiprocessing.get_context("spawn")
                procs = [
                    context.Process(target=_worker, args=(env, algo, str(study_dir), opts.model_dump(), base, k))
                    for k in range(opts.jobs)
                ]
                for p in procs:
                    p.start()
                try:
                    for p in procs:
                        p.join()
                except KeyboardInterrupt:
                    for p in procs:
                        p.terminate()
                    for p in procs:
                        p.join()
                    raise
                failed = [p.exitcode for p in procs if p.exitcode]
                if failed:
                    raise ConfigError(f"{len(failed)} tune worker(s) failed (exit codes {failed}); rerun to continue")
        study = _study(study_dir, env, algo, opts)
        if "random_policy" not in study.user_attrs:
            from pyflyt_cli.training.tune_verdict import random_policy_score

            r = random_policy_score(cfg)
            study.set_user_attr("random_policy", [r.mean, r.std, r.n])
        return _write_report(study, study_dir, env, algo, opts, base, before, log)


def _write_report(
    study: Any, study_dir: Path, env: str, algo: str, opts: TuneOptions, base: Sequence[str], before: int, log: Log
) -> TuneReport:
    from optuna.trial import TrialState

    from pyflyt_cli.training.rundir import atomic_write

    finished = _finished(study)
    complete = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    import csv
    import io

    keys = list(load_search_space(opts.space, algo).params)
    table = io.StringIO()
    writer = csv.writer(table, lineterminator="\n")
    writer.writerow(["number", "state", "value", *keys])
    for t in study.get_trials(deepcopy=False):
        params = [_decoded(t.params.get(k)) for k in keys]
        writer.writerow([t.number, t.state.name, "" if t.value is None else repr(t.value), *params])
    atomic_write(study_dir / "trials.csv", table.getvalue())
    best_file = None
    best_params = None
    best_value = None
    verdict = None
    if complete:
        from pyflyt_cli.training.tune_verdict import judge

        best = study.best_trial
        best_value = float(best.value)
        best_params = {k: _decoded(v) for k, v in best.params.items()}
        verdict = judge(study, complete)
        for line in verdict.lines():
            log(line)
        best_file = study_dir / f"best_{study_name(env, algo)}.yaml"
        if verdict.finding:
            text = _hparams_text(best_params, env, algo, best.number, best_value, opts, base, finished)
            atomic_write(best_file, text)
            log(f"best: trial {best.number}, return {best_value:.2f}: {best_file}")
        else:
            best_file.unlink(missing_ok=True)  # an earlier run's recommendation no longer stands
            best_file = None
            log(f"best: trial {best.number}, return {best_value:.2f}; no settings recommended")
    plots = _plots(study, study_dir, log, importance=verdict is not None and verdict.parameters_matter)
    return TuneReport(
        study_dir,
        _storage_url(study_dir),
        finished,
        finished - before,
        best_value,
        best_params,
        best_file,
        plots,
        verdict,
    )


def _decoded(value: Any) -> Any:
    """A parameter as sampled: categorical choices are stored as their JSON text (read back bounded:
    the study database is a file like any other)."""
    return yaml_data(value, source=f"a stored choice {value[:40]!r}") if isinstance(value, str) else value


def _nested(values: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in values.items():
        node = out
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return out


def _hparams_text(
    params: Mapping[str, Any],
    env: str,
    algo: str,
    number: int,
    value: float,
    opts: TuneOptions,
    base: Sequence[str],
    finished: int,
) -> str:
    header = [
        "# @package _global_",
        f"# {algo} on {env}: the best of {finished} trials of pyflyt tune env={env} algo={algo} "
        f"(trial {number}, {opts.objective} evaluation return {value:.3f}).",
        f"# Searched: {', '.join(params)}; fixed during the study: {' '.join(base) or '(defaults)'}.",
        f"# Use: pyflyt train env={env} algo={algo} experiment=<this file> (add the fixed settings above),",
        f"# or copy it to conf/hparams/{env}_{algo}.yaml.",
    ]
    return "\n".join(header) + "\n" + yaml.safe_dump(_nested(params), sort_keys=False, default_flow_style=None)


def _plots(study: Any, study_dir: Path, log: Log, importance: bool = True) -> list[Path]:
    """Optuna's optimisation history and parameter importances, as PNG (importance needs 2+ complete
    trials, and ``importance``: returns that differ by more than their noise)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import optuna.visualization.matplotlib as vis
    from optuna.trial import TrialState

    written = []
    # each draws an Axes (or an array of them: ax.flat below)
    plots: list[tuple[str, Callable[[Any], Any]]] = [("history.png", vis.plot_optimization_history)]
    if not importance:
        (study_dir / "importance.png").unlink(missing_ok=True)
    elif len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))) >= 2:
        plots.append(("importance.png", vis.plot_param_importances))
    import warnings

    from optuna.exceptions import ExperimentalWarning

    for name, plot in plots:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ExperimentalWarning)
                ax = plot(study)
        except (ValueError, RuntimeError) as exc:  # e.g. importances of a parameter that never varied
            log(f"{name}: not drawn ({str(exc).splitlines()[0]})")
            continue
        figure = ax.figure if hasattr(ax, "figure") else ax.flat[0].figure
        figure.tight_layout()
        figure.savefig(study_dir / name, dpi=120)
        plt.close(figure)
        written.append(study_dir / name)
    return written
