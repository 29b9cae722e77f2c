"""A benchmark experiment as a plan: every run it declares, composed and validated up front.

A benchmark experiment is an experiment file (``conf/experiment/<name>.yaml``) with a
``benchmark:`` section::

    benchmark:
      seeds: 3                       # seeds 0..2 (or a list: [0, 4, 7])
      jobs: 2                        # runs at a time on this machine
      groups:                        # each group: envs x algos x seeds
        - envs: [quadx_waypoints, fixedwing_waypoints]
          algos: [sac]
          overrides: [train.total_timesteps=20000]
        - envs: [quadx_waypoints]
          algos: [awac]
          task: "{env}_sparse"       # the name its runs are filed and plotted under
          overrides: [env.reward=sparse]
          init_from: {task: "{env}", algo: sac, checkpoint: 10000}
      reference:                     # normalisation: the score that counts as 1
        quadx_waypoints: {score: 500, source: "5 waypoints x 100"}

Each run is exactly one ``pyflyt train`` command line (:attr:`Job.overrides`, what
``pyflyt benchmark --dry-run`` prints)::

    pyflyt train experiment=<name> env=<env> algo=<algo> <group overrides> <command-line overrides>
        seed=<k> env_name=<task> run_dir=<benchmark>/runs/<task>/<algo>/seed<k>
        train.output_dir=<benchmark>/runs [init_from=<source run>@<step> | <source run>/<model file>]

and its configuration is composed from exactly that line.  The plan (every run's
validated configuration) is written to ``<benchmark>/plan.json``; the workers read their
configuration from it, so a run never depends on the directory or the config files it
was launched from.
"""

from __future__ import annotations

import copy
import json
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from pyflyt_cli.compose import absolute_airframes
from pyflyt_cli.errors import UsageError
from pyflyt_engine import limits
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.loading import validate

PLAN_FILE = "plan.json"
RUNS_DIR = "runs"
LOGS_DIR = "logs"
NORMALISATION_FILE = "normalisation.yaml"  # read by pyflyt plot (pyflyt_cli.plotting.data)

#: CLI shorthands of ``pyflyt benchmark`` (``seeds=10`` is ``benchmark.seeds=10``)
SHORTHANDS = {"seeds": "benchmark.seeds", "jobs": "benchmark.jobs"}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class InitFromSpec(_Strict):
    """Start each run from a policy of another group's run with the same env and seed."""

    task: str = Field("{env}", description="task of the source runs ({env} is this run's env)")
    algo: str = Field(description="algorithm of the source runs")
    checkpoint: int | Literal["final", "best"] = Field(
        "final", description="which policy: a checkpoint step (partially trained), 'final' or 'best'"
    )


class GroupSpec(_Strict):
    """``envs x algos x seeds`` runs sharing the same overrides."""

    envs: list[str] = Field(min_length=1, description="env configs (conf/env/<name>.yaml)")
    algos: list[str] = Field(min_length=1, description="algorithm configs (conf/algo/<name>.yaml)")
    task: str = Field("{env}", description="name the runs are filed and plotted under; {env} is replaced")
    overrides: list[str] = Field(default_factory=list, description="pyflyt train overrides of this group's runs")
    init_from: InitFromSpec | None = Field(None, description="bootstrap from another group's runs")


class ReferenceSpec(_Strict):
    score: float = Field(description="the return that counts as normalised score 1")
    source: str = Field(description="where the number comes from")


class BenchmarkSpec(_Strict):
    """The ``benchmark:`` section of an experiment file."""

    description: str = ""
    name: str | None = Field(None, description="benchmark directory name (default: the experiment's name)")
    output_dir: str = Field("benchmarks", description="the benchmark directory is <output_dir>/<name>")
    seeds: int | list[int] = Field(3, description="number of seeds (0..N-1) or the list of seeds")
    jobs: int = Field(1, ge=1, description="runs trained at a time on this machine (local launcher)")
    groups: list[GroupSpec] = Field(min_length=1)
    reference: dict[str, ReferenceSpec] = Field(default_factory=dict, description="per task: the score of 1")
    random_episodes: int = Field(10, ge=1, description="episodes of a uniformly random policy per task (score 0)")
    # free-form settings the groups interpolate (e.g. budgets per preset)
    preset: str | None = None
    presets: dict[str, dict[str, Any]] = Field(default_factory=dict)

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, value: int | list[int]) -> int | list[int]:
        if isinstance(value, int):
            if value < 1:
                raise ValueError("seeds must be at least 1")
            limits.check("benchmark.seeds", value, name="seeds")
        elif not value or len(set(value)) != len(value) or min(value) < 0:
            raise ValueError("a seed list must be non-empty, without repeats, of seeds >= 0")
        else:
            limits.check("benchmark.seeds", len(value), name="the seed list's length")
            limits.check("seed", max(value), name="a listed seed")
        return value

    @field_validator("jobs")
    @classmethod
    def _jobs(cls, value: int) -> int:
        return limits.check("jobs", value, name="jobs")

    @field_validator("random_episodes")
    @classmethod
    def _random_episodes(cls, value: int) -> int:
        return limits.check("benchmark.random_episodes", value, name="random_episodes")

    def seed_list(self) -> list[int]:
        return list(range(self.seeds)) if isinstance(self.seeds, int) else list(self.seeds)


@dataclass
class Job:
    """One run of the benchmark."""

    task: str
    env: str
    algo: str
    seed: int
    #: the ``pyflyt train`` overrides it is composed from: run as a command line, they train this run
    overrides: list[str]
    #: its validated configuration (TrainConfig as JSON data)
    config: dict[str, Any]
    #: run directory, relative to the benchmark directory
    run_dir: str
    #: id of the run whose policy starts this run (its ``init_from``)
    depends_on: str | None = None

    @property
    def id(self) -> str:
        return f"{self.task}/{self.algo}/seed{self.seed}"

    @property
    def total_timesteps(self) -> int:
        return int(self.config["train"]["total_timesteps"])


@dataclass
class Plan:
    """Every run of a benchmark (:func:`plan_benchmark`).

    Attributes:
        root: the benchmark directory.
        experiment: the experiment it was planned from (a name or a file).
        spec: the validated ``benchmark:`` section (JSON data).
        jobs: every run, in the order the experiment declares them.
        command: the command line recorded in ``plan.json`` and the directory's lock.
        launcher: the Hydra launcher overrides (``hydra/launcher=ray`` ...) to train the
            runs with; empty: local processes.  Not written to ``plan.json``.
    """

    root: Path
    experiment: str
    spec: dict[str, Any]
    jobs: list[Job]
    command: list[str] = field(default_factory=list)
    launcher: list[str] = field(default_factory=list)

    def job(self, job_id: str) -> Job:
        for job in self.jobs:
            if job.id == job_id:
                return job
        raise ConfigError(f"{self.root / PLAN_FILE}: no run {job_id!r} in this benchmark")

    def run_dir(self, job: Job) -> Path:
        return self.root / job.run_dir

    def log_file(self, job: Job) -> Path:
        return self.root / LOGS_DIR / (job.id.replace("/", "__") + ".log")

    def write(self) -> Path:
        from pyflyt_cli.training.rundir import atomic_write

        self.root.mkdir(parents=True, exist_ok=True)
        data = {
            "experiment": self.experiment,
            "command": self.command,
            "benchmark": self.spec,
            "jobs": [{"id": j.id, **asdict(j)} for j in self.jobs],
        }
        path = self.root / PLAN_FILE
        atomic_write(path, json.dumps(data, indent=1) + "\n")
        return path


def read_plan(root: str | Path) -> Plan:
    """The plan written by ``pyflyt benchmark`` in ``root`` (a worker's view of it)."""
    from pyflyt_engine.safe_load import load_json_file

    root = Path(root)
    path = root / PLAN_FILE
    try:
        # a plan holds a full configuration per run: bounded, but far above any grid this package plans
        data = load_json_file(path, what="benchmark plan", limit=64 << 20, max_nodes=4_000_000)
        jobs = [Job(**{k: v for k, v in j.items() if k != "id"}) for j in data["jobs"]]
    except ConfigError as exc:
        reason = str(exc).removeprefix(f"{path}: ")
        raise ConfigError(
            f"{path}: not a readable benchmark plan ({reason}); rerun pyflyt benchmark to rewrite it"
        ) from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError(
            f"{path}: not a readable benchmark plan ({exc}); rerun pyflyt benchmark to rewrite it"
        ) from None
    return Plan(root.resolve(), data["experiment"], data["benchmark"], jobs, data.get("command", []))


# ---------------------------------------------------------------------- compose


#: pyflyt train keys a benchmark sets for each run, and what to give instead
_SET_BY_THE_PLAN = {
    "experiment": "the benchmark is chosen once: pyflyt benchmark experiment=<name>",
    "seed": "seeds come from the benchmark: use seeds=N (seeds 0..N-1) or 'benchmark.seeds=[0,5,7]'",
    "resume": "a benchmark resumes its interrupted runs by itself: rerun the same command",
    "env": "envs come from the benchmark's groups: edit benchmark.groups in the experiment file",
    "algo": "algorithms come from the benchmark's groups: edit benchmark.groups in the experiment file",
    "env_name": "runs are filed under their group's task: edit benchmark.groups[i].task in the experiment file",
    "run_dir": "runs go to <benchmark>/runs/<task>/<algo>/seed<k>: choose benchmark.output_dir or benchmark.name",
    "train.output_dir": "runs go to <benchmark>/runs/: choose benchmark.output_dir or benchmark.name",
    "init_from": "a group starts from another group's runs by its init_from: edit benchmark.groups[i].init_from",
}


def split_overrides(overrides: Sequence[str]) -> tuple[list[str], list[str], list[str]]:
    """(benchmark.* overrides, hydra launcher overrides, overrides for every run)."""
    bench, hydra, runs = [], [], []
    for item in overrides:
        key, sep, value = item.partition("=")
        bare = key.lstrip("+~")
        if bare in SHORTHANDS:
            bench.append(f"++{SHORTHANDS[bare]}{sep}{value}")
        elif bare == "benchmark" or bare.startswith("benchmark."):
            # ++: set the key whether or not the experiment file wrote it (output_dir, name ...)
            bench.append(item if key.startswith(("+", "~")) else f"++{item}")
        elif bare.startswith(("hydra/", "hydra.")):
            hydra.append(item)
        elif bare in _SET_BY_THE_PLAN:
            what = _SET_BY_THE_PLAN[bare]
            raise UsageError(f"'{item}' cannot be given to pyflyt benchmark: {what}")
        else:
            runs.append(item)
    return bench, hydra, runs


def load_spec(experiment: str, bench_overrides: Sequence[str], run_overrides: Sequence[str]) -> BenchmarkSpec:
    """The validated ``benchmark:`` section of ``experiment`` with the overrides applied."""
    from pyflyt_cli.training.compose import compose_train_data

    data, _ = compose_train_data([f"experiment={experiment}", *bench_overrides, *run_overrides], benchmark=True)
    section = data.get("benchmark")
    if not isinstance(section, dict):
        raise UsageError(
            f"experiment={experiment} declares no benchmark (no 'benchmark:' section): train it with "
            f"pyflyt train experiment={experiment} -m seed=0,1,2, or see docs/benchmarks.md to declare a grid"
        )
    return validate(
        BenchmarkSpec, section, "benchmark section", f"experiment={experiment}", prefix="benchmark.", error=UsageError
    )


#: fewest evaluations a run needs for its learning curve to be read as a curve
MIN_EVALUATIONS = 3


def expected_evaluations(config: dict[str, Any]) -> int:
    """How many ``/eval`` records a run of this (validated train) configuration writes from scratch."""
    return len(evaluation_steps(config))


def evaluation_steps(config: dict[str, Any]) -> list[int]:
    """The steps a run of this (validated train) configuration is evaluated at, from scratch:
    the first rollout start at or after every multiple of ``train.eval_freq``, and the end
    (the final weights)."""
    from pyflyt_cli.training.loop import steps_per_round
    from pyflyt_cli.training.schema import parse_train_config

    cfg = parse_train_config(config)
    if cfg.train.eval_freq <= 0:
        return []
    chunk = steps_per_round(cfg)
    end = -(-cfg.train.total_timesteps // chunk) * chunk
    steps, next_eval = [], cfg.train.eval_freq
    while next_eval < end:  # the rollout start at or after each scheduled step
        start = -(-next_eval // chunk) * chunk
        if start >= end:
            break
        steps.append(start)
        while next_eval <= start:
            next_eval += cfg.train.eval_freq
    return steps + [end]


def few_evaluations_note(plan: Plan) -> str | None:
    """A warning naming the runs that would be evaluated fewer than :data:`MIN_EVALUATIONS` times."""
    few = [(job, n) for job in plan.jobs if (n := expected_evaluations(job.config)) < MIN_EVALUATIONS]
    if not few:
        return None
    listed = ", ".join(f"{job.id} ({n})" for job, n in few[:4]) + (", ..." if len(few) > 4 else "")
    return (
        f"note: {len(few)} run(s) will be evaluated fewer than {MIN_EVALUATIONS} times, so their learning "
        f"curves have too few points to read: {listed}; lower train.eval_freq or raise train.total_timesteps"
    )


def plan_benchmark(experiment: str, overrides: Sequence[str] = (), command: Sequence[str] | None = None) -> Plan:
    """Every run of ``experiment``'s benchmark, each composed and validated; nothing is written.

    Args:
        experiment: a shipped experiment with a ``benchmark:`` section (``paper_rl``,
            ``smoke_benchmark``) or the path of an experiment file.
        overrides: ``pyflyt benchmark``'s: ``seeds=N``, ``jobs=J``, ``benchmark.<key>=<value>``,
            ``hydra/launcher=...`` and ``hydra.launcher.<key>=<value>``, and ``pyflyt train``
            overrides applied to every run.
        command: the command line to record (default: the ``pyflyt benchmark`` line of these arguments).

    Raises:
        UsageError: an unknown experiment, key or launcher (or one whose plugin is missing), an
            invalid benchmark section or run.
    """
    from pyflyt_cli.benchmark.launchers import launcher_name

    if command is None:
        command = ["pyflyt", "benchmark", f"experiment={experiment}", *overrides]
    plan, launcher = build_plan(experiment, overrides, command)
    launcher_name(launcher)  # a launcher without its plugin is refused now, before anything runs
    return plan


def build_plan(experiment: str, overrides: Sequence[str], command: Sequence[str] = ()) -> tuple[Plan, list[str]]:
    """Compose and validate every run of ``experiment``; returns the plan and the Hydra launcher overrides
    (also its :attr:`Plan.launcher`)."""
    from pyflyt_cli.benchmark.launchers import check_launcher_overrides
    from pyflyt_cli.training import registry
    from pyflyt_cli.training.schema import OPT_INS

    bench_over, hydra_over, run_over = split_overrides(overrides)
    run_over = absolute_airframes(run_over)  # the run lines mean the same from any directory
    check_launcher_overrides(hydra_over)  # before anything is composed, written or run
    spec = load_spec(experiment, bench_over, run_over)
    name = spec.name or Path(experiment).stem
    if not name or any(c in name for c in "/\\") or name in (".", ".."):
        raise UsageError(f"benchmark.name must be a plain directory name, got {name!r}")
    root = (Path(spec.output_dir).expanduser() / name).resolve()

    jobs: dict[str, Job] = {}
    for g, group in enumerate(spec.groups):
        for item in group.overrides:
            key = item.partition("=")[0].lstrip("+~")
            if key in _SET_BY_THE_PLAN:
                raise UsageError(f"benchmark.groups[{g}].overrides: '{item}' cannot be given: {_SET_BY_THE_PLAN[key]}")
            if key in OPT_INS:
                raise UsageError(
                    f"benchmark.groups[{g}].overrides: '{item}' is an opt-in, taken from the command line only "
                    f"(pyflyt benchmark ... {key}=true), never from an experiment file"
                )
        for env in group.envs:
            task = _task_name(group.task, env, f"benchmark.groups[{g}].task")
            for algo in group.algos:
                base = [
                    f"experiment={experiment}",
                    f"env={env}",
                    f"algo={algo}",
                    *group.overrides,
                    *bench_over,
                    *run_over,
                ]
                group_jobs: list[Job] = []
                for seed in spec.seed_list():
                    run_dir = f"{RUNS_DIR}/{task}/{algo}/seed{seed}"
                    line = [
                        *base,
                        f"seed={seed}",
                        override("env_name", task),
                        override("run_dir", str(root / run_dir)),
                        override("train.output_dir", str(root / RUNS_DIR)),
                    ]
                    job = Job(task, env, algo, seed, line, {}, run_dir)
                    if group.init_from is not None:
                        src = group.init_from
                        src_task = _task_name(src.task, env, f"benchmark.groups[{g}].init_from.task")
                        accepted = {algo} | set(registry.INIT_FROM.get(algo, frozenset()))
                        if src.algo not in accepted:
                            raise UsageError(
                                f"benchmark.groups[{g}].init_from: {algo} cannot start from {src.algo} policies "
                                f"(it can from: {', '.join(sorted(accepted))})"
                            )
                        job.depends_on = f"{src_task}/{src.algo}/seed{seed}"
                        source_dir = root / RUNS_DIR / src_task / src.algo / f"seed{seed}"
                        line.append(override("init_from", _init_spec(source_dir, src.checkpoint)))
                    group_jobs.append(job)
                try:
                    configs = _compose_lines([job.overrides for job in group_jobs])
                except ConfigError as exc:
                    raise UsageError(f"benchmark.groups[{g}] ({env}, {algo}): {exc}") from None
                for job, data in zip(group_jobs, configs):
                    if job.id in jobs:
                        raise UsageError(
                            f"run {job.id} is declared twice: give the groups different tasks "
                            '(task: "{env}_sparse") or algorithms'
                        )
                    job.config = data
                    jobs[job.id] = job
    _check_dependencies(jobs)
    plan = Plan(root, experiment, spec.model_dump(mode="json"), list(jobs.values()), list(command), hydra_over)
    return plan, hydra_over


def _task_name(pattern: str, env: str, where: str) -> str:
    try:
        task = pattern.format(env=env)
    except (KeyError, IndexError, ValueError):
        raise UsageError(f"{where}: {pattern!r} may only use {{env}}") from None
    if not task or any(c in task for c in "/\\") or task in (".", ".."):
        raise UsageError(f"{where}: {task!r} is not a plain directory name")
    return task


def _compose_lines(lines: list[list[str]]) -> list[dict[str, Any]]:
    """The validated configuration (JSON data) of each ``pyflyt train`` line.

    The lines differ only in their last, per-run overrides (seed, run directory, source
    run).  Composing costs about a second, so the first line is composed whole and the
    others are that result with their own per-run values set; the second line is also
    composed whole and must agree, which shows that nothing in the configuration
    interpolates a per-run value (otherwise every line is composed whole).
    """
    from pyflyt_cli.training.compose import compose_run
    from pyflyt_cli.training.schema import parse_train_config

    def composed(line: list[str]) -> dict[str, Any]:
        try:
            cfg, _ = compose_run(line)
        except UsageError as exc:
            raise ConfigError(str(exc)) from None
        return cfg.model_dump(mode="json")

    first = composed(lines[0])
    derived = [_with_run_values(first, line) for line in lines[1:]]
    if derived and composed(lines[1]) != derived[0]:
        return [first] + [composed(line) for line in lines[1:]]
    return [first] + [parse_train_config(data).model_dump(mode="json") for data in derived]


#: the overrides that differ between the runs of one (group, env, algo): set on composed data
_PER_RUN = {
    "seed": ("seed",),
    "env_name": ("env_name",),
    "init_from": ("init_from",),
    "train.output_dir": ("train", "output_dir"),
}


def _with_run_values(data: dict[str, Any], line: list[str]) -> dict[str, Any]:
    from hydra.core.override_parser.overrides_parser import OverridesParser

    out = copy.deepcopy(data)
    for parsed in OverridesParser.create().parse_overrides(line):
        where = _PER_RUN.get(parsed.key_or_group)
        if where is not None:
            node = out
            for key in where[:-1]:
                node = node[key]
            node[where[-1]] = parsed.value()
    return out


def _init_spec(source_dir: Path, checkpoint: int | str) -> str:
    """``init_from`` of a run that starts from ``source_dir``'s policy: a model file, or ``<dir>@<step>``."""
    from pyflyt_cli.training import rundir

    if checkpoint == "final":
        return str(source_dir / rundir.FINAL_MODEL)
    if checkpoint == "best":
        return str(source_dir / rundir.BEST_MODEL)
    return f"{source_dir}@{int(checkpoint)}"  # its first checkpoint at or after that step


_PLAIN = re.compile(r"[A-Za-z0-9_/.@%:+\-]+")


def override(key: str, value: str) -> str:
    """``key=value`` as Hydra reads it back as the string ``value`` (quoted when needed)."""
    if _PLAIN.fullmatch(value) and value[0] not in "+-":
        return f"{key}={value}"
    if "\\" in value or "${" in value:
        raise UsageError(
            f"{key}: {value!r} holds a backslash or '${{', which a pyflyt train override cannot carry; "
            "choose a benchmark directory without them (benchmark.output_dir=...)"
        )
    return f"{key}='" + value.replace("'", "\\'") + "'"


def _check_dependencies(jobs: dict[str, Job]) -> None:
    from pyflyt_cli.training.schema import split_init_from

    for job in jobs.values():
        if job.depends_on is None:
            continue
        source = jobs.get(job.depends_on)
        if source is None:
            raise UsageError(
                f"run {job.id} starts from {job.depends_on}, which the benchmark does not declare: "
                "check init_from's task and algo"
            )
        if source.depends_on is not None:
            raise UsageError(
                f"run {job.id} starts from {source.id}, which itself starts from another run: one level only"
            )
        _, step = split_init_from(job.config.get("init_from"))
        if step is not None:
            opts = source.config["train"]
            freq, total = int(opts["checkpoint_freq"]), int(opts["total_timesteps"])
            if freq <= 0 or step % freq or step > total or step <= 0:
                raise UsageError(
                    f"run {job.id} starts from checkpoint {step} of {source.id}, which checkpoints every "
                    f"{freq} steps up to {total}: choose a multiple of train.checkpoint_freq"
                )
            if int(opts.get("keep_checkpoints", 0)) > 0:
                raise UsageError(
                    f"{source.id} keeps only its newest {opts['keep_checkpoints']} checkpoints, so checkpoint "
                    f"{step} would be deleted before {job.id} starts: set train.keep_checkpoints=0 for it"
                )


def levels(jobs: Sequence[Job]) -> list[list[Job]]:
    """Jobs in waves: runs without a source first, then the runs that start from them."""
    first = [j for j in jobs if j.depends_on is None]
    second = [j for j in jobs if j.depends_on is not None]
    return [w for w in (first, second) if w]
