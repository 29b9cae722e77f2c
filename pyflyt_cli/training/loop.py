"""Train, resume and bootstrap runs: plain functions on a plain :class:`TrainConfig`.

    from pyflyt_cli.training import train, resume
    result = train(config)                          # a TrainConfig (or its mapping)
    result = resume(result.run_dir)                 # after an interruption

No Hydra here: the CLI (``pyflyt_cli/commands/train.py``) composes ``conf/train.yaml``
and calls :func:`train`; tests and scripts call it directly.

A run interrupted (Ctrl-C, SIGTERM: a checkpoint is saved at the next rollout start;
SIGKILL: the newest checkpoint counts) and resumed continues exactly as if it had never
stopped: same evaluations, same final weights (see ``docs/reproducibility.md``).
"""

from __future__ import annotations

import contextlib
import importlib.util
import math
import os
import shutil
import signal
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyflyt_cli.training import artifacts, continuity, registry, rundir
from pyflyt_cli.training.evaluation import EVAL_SEED_OFFSET
from pyflyt_cli.training.models import PolicySource, build_model, read_policy
from pyflyt_cli.training.schema import TrainConfig, parse_train_config, split_init_from
from pyflyt_cli.training.costs import CheckpointCost, CostLedger
from pyflyt_engine.errors import ConfigError, PyFlytError
from pyflyt_engine.numerics import apply_torch

Log = Callable[[str], None]


@dataclass(frozen=True)
class RunResult:
    """What a call to :func:`train` or :func:`resume` did."""

    run_dir: Path
    #: environment steps of the model at the end (of its newest checkpoint if interrupted)
    num_timesteps: int
    #: True if stopped by a signal (a checkpoint was saved; continue with :func:`resume`)
    interrupted: bool
    #: steps trained by this call / its wall-clock time in learn()
    steps_per_second: float
    elapsed: float
    #: the last evaluation's summary (``/eval`` record) and its step, if any
    last_eval: dict[str, float] | None
    last_eval_step: int | None
    best_mean_return: float | None
    #: what this call's parts cost on its clock (start-up, learn(), each checkpoint and evaluation, the split)
    costs: CostLedger | None = None


def _silent(_: str) -> None:
    pass


# ---------------------------------------------------------------------- public


def train(
    config: TrainConfig | Mapping[str, Any],
    *,
    callbacks: Sequence[Any] = (),
    command: list[str] | None = None,
    overrides: list[str] | None = None,
    log: Log = _silent,
    progress_bar: bool | None = None,
    run_dir: str | Path | None = None,
    after_eval: Sequence[Any] = (),
    clock: Callable[[], float] = time.perf_counter,
) -> RunResult:
    """Train a new run; returns when done or interrupted (Ctrl-C, SIGTERM).

    Args:
        config: a :class:`TrainConfig` or a mapping validated into one.
        callbacks: extra SB3 callbacks (e.g. custom measurements in experiments).
        command, overrides: recorded in ``run.yaml`` (default: ``sys.argv``).
        log: receives one-line status messages (run directory, summary).
        progress_bar: override ``train.progress_bar``.
        run_dir: train in exactly this directory, which must not exist yet (``pyflyt
            benchmark`` names its runs ``<task>/<algo>/seed<k>``); default: a new
            ``<train.output_dir>/<env_name>/<algo>/<time>-seed<k>``.
        after_eval: SB3 callbacks run after each evaluation besides ``cfg.callbacks`` (their
            ``parent`` is the evaluation: ``parent.last_mean_reward``); one returning False
            ends the run there, complete (``pyflyt tune`` prunes trials so).
        clock: what the run's own timings read (``RunResult.elapsed``, ``steps_per_second``,
            ``costs``, the phase split it logs): wall-clock by default; ``time.process_time``
            gives this process's CPU seconds, as the studies report them.
    """
    ledger = CostLedger(clock)
    cfg = parse_train_config(config)
    _check_environment(cfg)
    init = _init_source(cfg) if cfg.init_from else None
    _probe_env(cfg)
    if run_dir is None:
        run_dir = rundir.create_run_dir(cfg.train.output_dir, cfg.env_name, cfg.algo.name, cfg.seed)
    else:
        run_dir = rundir.create_named_run_dir(run_dir)
    try:
        cfg = rundir.portable_config(cfg, run_dir)
        rundir.save_config(cfg, run_dir)
        record = rundir.run_record(cfg, command, overrides)
        if init is not None:
            record["init_from"] = {"run": str(init.run), "model": str(init.path), "algo": init.algo}
            # a restart (a resume before the first checkpoint) starts from this copy, never from outside the run
            artifacts.save_policy_data(
                run_dir / rundir.INIT_POLICY, init.algo, init.step or 0, init.policy, init.normalizer
            )
        rundir.write_yaml(run_dir / rundir.RUN_FILE, record)
        rundir.write_state(run_dir, {"status": "starting", "num_timesteps": 0, "checkpoint": None})
    except Exception:
        shutil.rmtree(run_dir, ignore_errors=True)  # nothing trained: no partial run left behind
        raise
    log(f"run directory: {run_dir}")
    with rundir.run_lock(run_dir):
        run = _Run(cfg, run_dir, log, progress_bar, ledger)
        run.after_eval = list(after_eval)
        return run.execute(callbacks, init=init)


def resume(
    run_dir: str | Path,
    *,
    total_timesteps: int | None = None,
    callbacks: Sequence[Any] = (),
    log: Log = _silent,
    progress_bar: bool | None = None,
    clock: Callable[[], float] = time.perf_counter,
) -> RunResult:
    """Continue an interrupted run from its newest checkpoint, in the same directory.

    Everything the continuation depends on comes from the checkpoint (weights,
    optimisers, replay buffer, normaliser, random streams, the envs' episodes in progress:
    :mod:`pyflyt_cli.training.continuity`), so the run ends exactly as an uninterrupted
    one.  Metrics logged after the checkpoint are superseded by the new segment.
    ``total_timesteps`` extends (or sets) the budget.  A run killed before its first
    checkpoint starts over.  ``clock`` as for :func:`train`.
    """
    ledger = CostLedger(clock)
    path = rundir.check_run_dir(run_dir)
    with rundir.run_lock(path):
        return _resume(path, total_timesteps, callbacks, log, progress_bar, ledger)


def _resume(
    path: Path,
    total_timesteps: int | None,
    callbacks: Sequence[Any],
    log: Log,
    progress_bar: bool | None,
    ledger: CostLedger,
) -> RunResult:
    cfg = rundir.load_run_config(path)
    state = rundir.read_state(path)
    record = rundir.read_yaml(path / rundir.RUN_FILE)
    _check_digest(path, cfg, state, record)
    if total_timesteps is not None:
        data = cfg.model_dump(mode="json")
        data["train"]["total_timesteps"] = int(total_timesteps)
        cfg = parse_train_config(data, source=str(path / rundir.CONFIG_FILE), recorded=True)
    _check_environment(cfg)
    _probe_env(cfg)
    checkpoint = _resume_point(path, cfg, log)
    done = checkpoint.step if checkpoint is not None else 0
    if state.get("status") == "complete" and done >= cfg.train.total_timesteps:
        raise ConfigError(
            f"{path} is complete ({done} of train.total_timesteps={cfg.train.total_timesteps} steps); "
            f"to train it longer: pyflyt train resume={path} train.total_timesteps=<more>"
        )
    init = _restart_source(path, cfg) if checkpoint is None else None
    if checkpoint is None:
        _check_restart_inputs(path, cfg)
    digest = rundir.config_digest(cfg, path)
    here = rundir.numeric_platform()
    note = rundir.platform_note(record, here)
    if note:
        log(f"note: this run was {note}")
    record.setdefault("resumes", []).append(
        {"at": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "from_step": done, "pid": os.getpid(), "config_digest": digest,
         "cpu": here["cpu"], "numerics": here["key"]}
    )  # fmt: skip
    rundir.write_yaml(path / rundir.RUN_FILE, record)  # the new digest is recorded before the config changes
    if total_timesteps is not None:
        rundir.save_config(cfg, path)
    log(f"resuming {path} from " + (f"step {checkpoint.step}" if checkpoint else "the start (no checkpoint was saved)"))
    return _Run(cfg, path, log, progress_bar, ledger).execute(callbacks, checkpoint=checkpoint, init=init)


def _check_digest(path: Path, cfg: TrainConfig, state: Mapping[str, Any], record: Mapping[str, Any]) -> None:
    """Refuse to resume a run whose ``config.yaml`` is not a configuration it was trained with.

    ``run.yaml`` records the config digest at the start and at each resume, ``state.json``
    at each state change; ``config.yaml`` changed since (edited, or swapped in a shared
    copy) matches none of them.
    """
    recorded = {state.get("config_digest"), record.get("config_digest")}
    resumes = record.get("resumes")
    recorded |= {r.get("config_digest") for r in resumes if isinstance(r, dict)} if isinstance(resumes, list) else set()
    recorded = {d for d in recorded if isinstance(d, str)}
    if rundir.config_digest(cfg, path) in recorded:
        return
    why = "does not match the configuration it was trained with" if recorded else "has no recorded config digest"
    raise ConfigError(
        f"{path / rundir.CONFIG_FILE} {why} (state.json, run.yaml): it was changed after the run started, so "
        f"it is not resumed; to train those settings on purpose, start a new run from them: "
        f"pyflyt train from_config={path / rundir.CONFIG_FILE}"
    )


def _restart_source(path: Path, cfg: TrainConfig) -> PolicySource | None:
    """The policy a run restarted from scratch starts from: the copy of ``init_from``'s policy it keeps.

    A resume reads nothing outside the run directory, so ``init_from`` itself (another run,
    perhaps a pickled file) is never read again.
    """
    if not cfg.init_from:
        return None
    copy = path / rundir.INIT_POLICY
    if not copy.is_file():
        pickled = "; it is a pickled file: give trust_pickle=true on that command line if you made it yourself"
        raise ConfigError(
            f"{path} stopped before its first checkpoint: a resume starts it over from the copy of the init_from "
            f"policy a run keeps ({rundir.INIT_POLICY}), and this run has none (an older version made it, or its "
            f"files were changed); init_from={cfg.init_from} itself is never read by a resume: start a new run "
            f"from it with pyflyt train init_from=<that policy>" + (pickled if cfg.init_from.endswith(".zip") else "")
        )
    try:
        return read_policy(copy)
    except ConfigError as exc:
        raise ConfigError(f"{path}: cannot restart from its copy of the init_from policy: {exc}") from None


def _check_restart_inputs(path: Path, cfg: TrainConfig) -> None:
    """A run restarted from scratch reads its ``algo.offline_buffer`` again: only inside the run, never a pickle."""
    from pyflyt_engine.safe_load import outside

    buffer = getattr(cfg.algo, "offline_buffer", None)
    if buffer is None:
        return
    if buffer.endswith(".pkl"):
        raise ConfigError(
            f"{path} stopped before its first checkpoint, so a resume starts it over from algo.offline_buffer="
            f"{buffer}, a pickle: loading one needs trust_pickle=true, which a resume never takes from the run's "
            "files; start a new run with trust_pickle=true on its command line if you made that file yourself"
        )
    if outside(path, buffer):
        raise ConfigError(
            f"{path} stopped before its first checkpoint, so a resume starts it over from algo.offline_buffer="
            f"{buffer}, outside the run directory, which a resume does not read: start a new run from that buffer"
        )


# ------------------------------------------------------------------- internals


def _check_environment(cfg: TrainConfig) -> None:
    if registry.ALGORITHMS[cfg.algo.name].needs:
        # an extra's algorithm (algo=sac_jax): a clear message if it is missing, and its library loaded
        # now, so that run.yaml's numeric platform (recorded next) names its versions and flags
        registry.resolve(registry.ALGOS, cfg.algo.name, "algorithm")
    if cfg.train.tensorboard and importlib.util.find_spec("tensorboard") is None:
        raise ConfigError(
            "train.tensorboard=true needs the tensorboard package: pip install tensorboard (or set train.tensorboard=false)"
        )
    if cfg.train.device == "cuda":
        import torch

        if not torch.cuda.is_available():
            raise ConfigError("train.device=cuda but torch sees no CUDA device; use train.device=cpu")


def _probe_env(cfg: TrainConfig) -> None:
    """Build the environment once, here, so a config that cannot fly fails with its message.

    (An error inside a ``SubprocVecEnv`` worker would only show as a broken pipe.)
    """
    from pyflyt_cli.training.envs import EnvFactory

    try:
        env = EnvFactory(cfg.env, monitor=False)()
    except PyFlytError as exc:
        raise ConfigError(f"env: cannot build the environment: {exc}") from None
    env.close()


def _init_source(cfg: TrainConfig) -> PolicySource:
    """The policy ``init_from`` names, read now (so a wrong file fails before training).

    ``init_from`` is a run directory (its best model, else final, else newest checkpoint),
    ``<run dir>@<step>`` (its first checkpoint at or after that step: a partially trained
    policy), or one policy file of a run: ``model.pt``, ``best_model.pt`` or
    ``checkpoints/model_<steps>_steps.pt``.  SB3 ``.zip`` files of older versions only with
    ``trust_pickle``.  The configuration keeps ``init_from`` as given; ``run.yaml`` records
    the file it named.
    """
    trust = cfg.trust_pickle
    source, step = split_init_from(cfg.init_from)
    given = Path(str(source)).expanduser()
    try:
        if step is not None:  # <run dir>@<step>: the first checkpoint at or after that step
            model = rundir.checkpoint_at_or_after(rundir.check_run_dir(given), step).model
        elif given.suffix in (".pt", ".zip"):
            if not given.is_file():
                raise ConfigError(f"model file {given} does not exist")
            model = given.resolve()
        else:
            model, _ = rundir.find_model(rundir.check_run_dir(given), "auto", legacy=trust)
    except ConfigError as exc:
        raise ConfigError(f"init_from={cfg.init_from}: {exc}") from None
    hint = str((rundir.read_yaml(rundir.run_of(model) / rundir.CONFIG_FILE).get("algo") or {}).get("name", "?"))
    try:
        policy = read_policy(model, trust_pickle=trust, algo_hint=hint)
    except ConfigError as exc:
        raise ConfigError(f"init_from: {exc}") from None
    accepted = {cfg.algo.name} | registry.INIT_FROM.get(cfg.algo.name, frozenset())
    if policy.algo not in accepted:
        raise ConfigError(
            f"init_from={cfg.init_from}: that policy was trained by {policy.algo}, this run uses {cfg.algo.name}; "
            f"{cfg.algo.name} can start from the policy weights of: {', '.join(sorted(accepted))}"
        )
    return policy


def _resume_point(path: Path, cfg: TrainConfig, log: Log) -> rundir.Checkpoint | None:
    """The newest complete checkpoint, after clearing what a kill left of an unfinished one.

    A checkpoint file is written last, so it exists only once the checkpoint is complete;
    temporary files and a replay buffer newer than every checkpoint file are the parts of
    a commit that was cut short, and are removed.
    """
    folder = path / rundir.CHECKPOINTS
    found = rundir.checkpoints(path)
    if folder.is_dir():
        newest = found[-1].step if found else -1
        for leftover in sorted(folder.iterdir()):
            m = rundir.BUFFER_PATTERN.match(leftover.name)
            unfinished = leftover.name.startswith(".") and ".tmp" in leftover.name
            if unfinished or (m is not None and int(m[1]) > newest):
                leftover.unlink(missing_ok=True)
                log(f"removed {leftover.name}: part of a checkpoint that was cut short")
    if not found:
        if any(c.legacy for c in rundir.checkpoints(path, legacy=True)):
            raise ConfigError(
                f"{path}: its checkpoints were saved by an older version in a pickled format, which cannot be "
                "resumed; evaluate it with pyflyt eval <run> trust_pickle=true, or train it again"
            )
        return None
    newest_checkpoint = found[-1]
    if cfg.algo.off_policy and newest_checkpoint.replay_buffer is None:
        log(
            f"warning: checkpoint {newest_checkpoint.step} has no replay buffer (train.save_replay_buffer=false): "
            "the resumed run starts with an empty buffer and will not match an uninterrupted run"
        )
    return newest_checkpoint


def _closing(close: Callable[[], Any], what: str) -> Callable[..., bool]:
    """An ``ExitStack.push`` callback closing ``what``: when an error is already on its way out
    a failing close does not hide it; otherwise a failed write becomes one clear error."""

    def exit_(exc_type: Any, exc: Any, tb: Any) -> bool:
        try:
            close()
        except Exception as err:
            if exc_type is None:
                if isinstance(err, OSError):
                    raise artifacts.ArtifactError(f"cannot finish {what}: {err.strerror or err}") from None
                raise
        return False

    return exit_


@contextlib.contextmanager
def _signals(stop: Any, log: Log, message: str) -> Iterator[None]:
    """SIGINT/SIGTERM request a clean stop; a second SIGINT aborts at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        name = signal.Signals(signum).name
        if stop.requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        stop.request(name)
        log(f"\n{name} received: {message} (Ctrl-C again to abort without saving)")

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


class _Run:
    """One execution of ``learn()`` for a run directory (new or resumed), in named steps."""

    def __init__(
        self, cfg: TrainConfig, run_dir: Path, log: Log, progress_bar: bool | None, ledger: CostLedger | None = None
    ) -> None:
        self.cfg = cfg
        #: what this execution's parts cost, on the run's clock (``RunResult.costs``)
        self.ledger = ledger if ledger is not None else CostLedger()
        self.run_dir = run_dir
        self.log = log
        self.progress_bar = progress_bar if progress_bar is not None else cfg.train.progress_bar
        self.state: dict[str, Any] = {}
        self.evaluation: Any = None
        self.curriculum: Any = None
        self.checkpointer: Any = None
        self.writer: Any = None
        self.phases: Any = None
        self.after_eval: list[Any] = []
        #: continued from a checkpoint (which restores everything the model was built from)
        self.resumed = False

    def execute(
        self,
        extra_callbacks: Sequence[Any],
        *,
        checkpoint: rundir.Checkpoint | None = None,
        init: PolicySource | None = None,
    ) -> RunResult:
        from pyflyt_cli.training.callbacks import StopRequest

        self.resumed = checkpoint is not None
        try:
            with contextlib.ExitStack() as cleanup:  # closes writer, envs and workers even if a close fails
                model = self._build(cleanup)
                restored = self._restore(model, checkpoint) if checkpoint is not None else None
                if init is not None:
                    self._bootstrap(model, init)
                start_step = int(model.num_timesteps)
                self._announce(start_step)
                self._open_metrics(cleanup, checkpoint)
                if checkpoint is None and self.cfg.train.imitation is not None:
                    self._imitate(model)
                self._hold_normalizer(model)
                stop = StopRequest()
                callbacks = self._callbacks(
                    cleanup,
                    stop,
                    restored,
                    [*self._curriculum(model, restored), *self._value_warmup(), *extra_callbacks],
                )
                self._write_state("running", start_step, checkpoint=checkpoint.step if checkpoint else None)
                elapsed = self._learn(model, callbacks, stop)
                return self._finish(model, stop, start_step, elapsed)
        except artifacts.ArtifactError as exc:  # a file could not be written (full disk, read-only ...)
            with contextlib.suppress(PyFlytError):
                self._write_state("failed", int(self.state.get("num_timesteps") or 0))
            saved = self.state.get("checkpoint")
            where = (
                f"its checkpoint at step {saved} is intact"
                if saved
                else "it saved no checkpoint yet (a resume starts over)"
            )
            raise ConfigError(
                f"{exc}\nthe run stopped; {where}: fix the cause, then pyflyt train resume={self.run_dir}"
            ) from None

    # ------------------------------------------------------------ the model

    def _build(self, cleanup: contextlib.ExitStack) -> Any:
        """Training envs (with the normaliser) and a new model from the configuration."""
        import torch
        from stable_baselines3.common.utils import set_random_seed
        from stable_baselines3.common.vec_env import VecNormalize

        from pyflyt_cli.training.envs import make_vec_env
        from pyflyt_cli.training.timing import StepTimer

        cfg, opts = self.cfg, self.cfg.train
        torch.set_num_threads(opts.torch_threads)
        apply_torch()
        set_random_seed(cfg.seed)
        vec = make_vec_env(cfg.env, opts.n_envs, opts.vec_env, curriculum=bool(opts.curriculum))
        cleanup.push(_closing(vec.close, "the training environments"))
        vec = StepTimer(vec)  # the envs' own share of the collection (studies read it; no effect on numbers)
        norm = cfg.algo.normalize
        if norm.enabled:
            from gymnasium import spaces

            space = vec.observation_space
            keys = None  # a Dict: normalise its float entries, never a camera image
            if isinstance(space, spaces.Dict):
                keys = [k for k, s in space.spaces.items() if s.dtype is not None and s.dtype.kind == "f"]
            vec = VecNormalize(
                vec,
                norm_obs=norm.observation,
                norm_reward=norm.reward,
                clip_obs=norm.clip_obs,
                gamma=cfg.algo.gamma,
                norm_obs_keys=keys,
            )
        tensorboard = str(self.run_dir / "tensorboard") if opts.tensorboard else None
        # resumed from a checkpoint: the offline buffer's data is in the checkpoint's buffer (never read again)
        return build_model(cfg, vec, tensorboard_log=tensorboard, offline=not self.resumed)

    def _restore(self, model: Any, checkpoint: rundir.Checkpoint) -> tuple[dict[str, Any], dict[str, Any]]:
        """Everything from the checkpoint; the envs' episodes in progress re-simulated and checked."""
        data = artifacts.read_payload(checkpoint.model, kinds=(artifacts.CHECKPOINT_FORMAT,))
        state, tensors = artifacts.load_checkpoint_into(model, data, checkpoint.model)
        normalizer = model.get_vec_normalize_env()
        if normalizer is not None and data["normalizer"] is not None:
            artifacts.restore_normalizer(normalizer, data["normalizer"])
        if checkpoint.replay_buffer is not None and getattr(model, "replay_buffer", None) is not None:
            artifacts.load_replay_buffer(checkpoint.replay_buffer, model.replay_buffer, exact=True)
        continuity.restore_model(model, state, tensors)
        problem = continuity.restore_envs(model, state, tensors)
        if problem is not None:
            self.log(f"warning: {problem}; the resumed run will not match an uninterrupted one")
        return state, tensors

    def _bootstrap(self, model: Any, init: PolicySource) -> None:
        """Start from another run's policy weights (and its normaliser statistics)."""
        artifacts.load_policy_into(model, {"policy": init.policy}, init.path)
        target = model.get_vec_normalize_env()
        if target is not None and init.normalizer is not None:
            artifacts.restore_normalizer(target, init.normalizer, returns=False)
        self.log(f"policy initialised from {init.path}")

    def _imitate(self, model: Any) -> None:
        """``train.imitation``: DAgger from the oracle into the new policy, each round in the metrics."""
        from pyflyt_cli.training.envs import EnvFactory
        from pyflyt_cli.training.imitation import IMITATION_RECORD, imitate

        options = self.cfg.train.imitation
        assert options is not None  # called only for a run with train.imitation
        self.log(
            f"imitation: {options.rounds + 1} DAgger rounds x {options.episodes} episodes with oracle "
            f"{options.oracle}, before {self.cfg.algo.name}"
        )
        env = EnvFactory(self.cfg.env, monitor=False)()

        def record(r: Any) -> None:
            values = {key: getattr(r, key) for key in IMITATION_RECORD}
            self.writer.log("/imitation", r.index, values)

        try:
            imitate(model, env, options, self.cfg.seed, self.log, on_round=record)
        finally:
            env.close()

    def _announce(self, start_step: int) -> None:
        """The budget and the expected duration, measured on a throw-away copy of the model
        (only when someone reads the log: the CLI)."""
        if self.log is _silent:
            return
        from pyflyt_cli.training.multi_agent import agents_per_env, step_unit
        from pyflyt_cli.training.timing import RunEta, format_duration, measure_costs

        cfg, opts = self.cfg, self.cfg.train
        unit, agents = step_unit(cfg.env), agents_per_env(cfg.env)
        text = f"budget: {opts.total_timesteps} {unit} of {cfg.env_name} with {cfg.algo.name} on {opts.n_envs} env(s)"
        if agents > 1:
            text += f" of {agents} agents (one shared policy; {opts.total_timesteps // agents} env steps)"
        if start_step:
            text += f", from step {start_step}"
        if opts.eval_freq:
            text += f"; evaluation every {opts.eval_freq} {unit} ({opts.eval_episodes} episodes)"
        if opts.checkpoint_freq:
            text += f"; checkpoint every {opts.checkpoint_freq} {unit}"
        self.log(text)
        costs = measure_costs(cfg)
        #: the measured costs behind the run's one ETA (:class:`~pyflyt_cli.training.timing.RunEta`)
        self.costs = costs
        if costs is None:
            self.log("ETA: printed with the progress once training has run for a while")
            return
        seconds = RunEta(cfg, costs).seconds_left(start_step, start_step)  # the ETA every later line updates
        starts = getattr(cfg.algo, "learning_starts", 0)  # off-policy only
        self.log(
            f"ETA: about {format_duration(seconds)} (measured just now on a copy of the model: "
            f"{1e3 * costs.collect:.2f} ms per collected {unit[:-1]}, {1e3 * costs.update:.2f} ms of updates per {unit[:-1]}"
            + (f" after learning_starts={starts}" if starts else "")
            + ")"
        )

    # -------------------------------------------------------------- metrics

    def _open_metrics(self, cleanup: contextlib.ExitStack, checkpoint: rundir.Checkpoint | None) -> None:
        """A new metrics segment; after a resume it supersedes what was logged past the checkpoint."""
        from pyflyt_engine.telemetry.metrics import MetricsWriter, segment_paths, set_aside_unreadable

        cfg = self.cfg
        metadata = {"env": cfg.env_name, "env_id": str(cfg.env.id), "algo": cfg.algo.name, "seed": str(cfg.seed)}
        path = self.run_dir / "metrics.mcap"
        if segment_paths(self.run_dir):
            for old, new, reason in set_aside_unreadable(self.run_dir):
                self.log(f"warning: {old.name} is unreadable ({reason}): kept as {new.name}")
            since = checkpoint.step if checkpoint is not None else 0
            self.writer = MetricsWriter(path, metadata=metadata, append=True, resumed_from=since)
        else:
            self.writer = MetricsWriter(path, metadata=metadata)
        cleanup.push(_closing(self.writer.close, f"the metrics file {self.writer.path}"))

    # ------------------------------------------------------------ callbacks

    def _callbacks(
        self,
        cleanup: contextlib.ExitStack,
        stop: Any,
        restored: tuple[dict[str, Any], dict[str, Any]] | None,
        extra: Sequence[Any],
    ) -> Any:
        from stable_baselines3.common.callbacks import CallbackList

        from pyflyt_cli.training.callbacks import (
            Checkpointer,
            EpisodeMetrics,
            PeriodicEvaluation,
            ProgressBar,
            ResumeStreams,
            RunCallbacks,
        )
        from pyflyt_cli.training.envs import EnvFactory
        from pyflyt_cli.training.timing import PhaseClock, ProgressLines, RunEta

        cfg, opts = self.cfg, self.cfg.train
        saved = restored[0].get("callbacks", {}) if restored is not None else {}
        callbacks: list[Any] = [ResumeStreams(*restored)] if restored is not None else []
        eta = RunEta(cfg, getattr(self, "costs", None))  # one ETA for the evaluation lines, the bar, the progress lines
        callbacks.append(eta)
        episodes = EpisodeMetrics(self.writer)
        callbacks.append(episodes)
        show_bar = self.progress_bar if self.progress_bar is not None else _is_terminal()
        if opts.eval_freq > 0:
            eval_env = EnvFactory(cfg.env, monitor=False)()
            cleanup.push(_closing(eval_env.close, "the evaluation environment"))
            children = [c.build() for c in cfg.callbacks] + self.after_eval
            child = CallbackList(children) if len(children) > 1 else (children[0] if children else None)
            self.evaluation = PeriodicEvaluation(
                eval_env,
                self.run_dir,
                cfg.algo.name,
                self.writer,
                opts.eval_freq,
                opts.eval_episodes,
                cfg.seed + EVAL_SEED_OFFSET,
                opts.eval_deterministic,
                # after an imitation stage the imitated policy is evaluated before learning
                # starts (step 0), so best_model.pt keeps it if learning only makes it worse
                next_eval=0 if restored is None and opts.imitation is not None else opts.eval_freq,
                callback_after_eval=child,
                log=_above_bar(self.log) if show_bar else self.log,  # one line per evaluation
                total=opts.total_timesteps,
                stop=stop,
                best_by=opts.best_by or "return",
            )
            from pyflyt_cli.training.multi_agent import step_unit

            self.evaluation.unit = step_unit(cfg.env)
            self.evaluation.eta = eta
            for c in children:  # SB3 sets the parent of a single child only; every child reads it
                c.parent = self.evaluation
            if "evaluation" in saved:
                self.evaluation.load_state_dict(saved["evaluation"])
            callbacks.append(self.evaluation)
        elif cfg.callbacks or self.after_eval:
            raise ConfigError("callbacks run after evaluations: set train.eval_freq > 0 to use them")
        next_checkpoint = int(saved.get("next_checkpoint") or opts.checkpoint_freq or 0)
        self.checkpointer = Checkpointer(self, opts.checkpoint_freq, next_checkpoint, stop)
        callbacks.append(self.checkpointer)
        self.phases = PhaseClock(self.ledger.clock)  # after evaluation and checkpoints, which report their time to it
        self.checkpointer.phases = self.phases
        if self.evaluation is not None:
            self.evaluation.phases = self.phases
            self.evaluation.ledger = self.ledger
        callbacks.append(self.phases)
        from pyflyt_cli.training.multi_agent import step_unit

        unit = step_unit(cfg.env)
        if show_bar:
            callbacks.append(ProgressBar(_expected_end(cfg), episodes, unit=unit, eta=eta))
        elif self.log is not _silent:  # a log file or a batch job: a line at least every 30 s
            callbacks.append(
                ProgressLines(
                    _expected_end(cfg),
                    self.log,
                    self.phases,
                    episode_returns=lambda: episodes.recent,
                    unit=unit,
                    eta=eta,
                )
            )
        callbacks.extend(extra)
        return RunCallbacks(callbacks, stop)

    def _hold_normalizer(self, model: Any) -> None:
        """``train.imitation.hold_normalizer``: the observation statistics the imitation stage left
        (restored from the checkpoint on a resume) stay fixed for the rest of the run."""
        options = self.cfg.train.imitation
        if options is None or options.oracle is None or not options.hold_normalizer:
            return
        from pyflyt_cli.training.imitation import hold_observation_statistics

        if hold_observation_statistics(model.get_vec_normalize_env()):
            self.log("observation statistics held as the imitation stage left them")

    def _value_warmup(self) -> list[Any]:
        """``train.imitation.value_warmup``: the callback holding the imitated policy while the value
        function learns (also on a resume, which holds it as the uninterrupted run did)."""
        options = self.cfg.train.imitation
        if options is None or options.oracle is None or not options.value_warmup:
            return []
        from pyflyt_cli.training.callbacks import ValueWarmup

        return [ValueWarmup(options.value_warmup, self.log)]

    def _curriculum(self, model: Any, restored: tuple[dict[str, Any], dict[str, Any]] | None) -> list[Any]:
        """``train.curriculum``: its callback (a gated schedule where the checkpoint left it), the
        training envs already told the current values."""
        curriculum = self.cfg.train.curriculum
        if not curriculum:
            return []
        from pyflyt_cli.training.callbacks import TaskCurriculum

        configured = {name: getattr(self.cfg.env.task, name) for name in curriculum}
        callback = TaskCurriculum(curriculum, configured, self.writer)
        if restored is not None and callback.progress:
            callback.load_state_dict(restored[0].get("callbacks", {}).get("curriculum", {}))
        callback.apply(model.get_env(), int(model.num_timesteps))
        self.curriculum = callback

        def show(value: Any) -> str:
            return f"[{', '.join(f'{v:g}' for v in value)}]" if isinstance(value, (list, tuple)) else f"{value:g}"

        def gate(c: Any) -> str:
            if c.gate is None:
                return ""
            return f" counted while >= {100 * c.gate:g} % of the last {c.gate_episodes} training episodes succeed"

        moves = ", ".join(
            f"{n} {show(c.start)} -> {show(configured[n])} over {c.steps} steps{gate(c)}" for n, c in curriculum.items()
        )
        self.log(f"curriculum: {moves} (evaluations fly the configured task)")
        return [callback]

    def _callback_state(self) -> dict[str, Any]:
        state: dict[str, Any] = {"next_checkpoint": self.checkpointer.next_checkpoint if self.checkpointer else None}
        if self.evaluation is not None:
            state["evaluation"] = self.evaluation.state_dict()
        if self.curriculum is not None and self.curriculum.progress:  # a gated schedule's position
            state["curriculum"] = self.curriculum.state_dict()
        return state

    # ---------------------------------------------------------------- learn

    def _learn(self, model: Any, callbacks: Any, stop: Any) -> float:
        """``learn()`` for the rest of the budget; returns its wall-clock time."""
        remaining = self.cfg.train.total_timesteps - int(model.num_timesteps)
        started = self.ledger.learn_started = self.ledger.clock()
        with _signals(stop, self.log, "saving a checkpoint at the end of this rollout, then stopping"):
            if remaining > 0:
                try:
                    model.learn(
                        remaining, callback=callbacks, reset_num_timesteps=False, tb_log_name="run", progress_bar=False
                    )
                except (EOFError, BrokenPipeError, ConnectionResetError):
                    if not stop.requested:  # a worker died for another reason
                        raise
        self.ledger.learn_ended = self.ledger.clock()
        return self.ledger.learn_ended - started

    # ----------------------------------------------------------- checkpoints

    def save_checkpoint(self, model: Any) -> None:
        """Commit a checkpoint, in an order a kill at any point survives.

        1. metrics logged so far are flushed to disk;
        2. the replay buffer (off-policy) is written, then
        3. the checkpoint file (written last: its existence marks the checkpoint complete);
        4. ``state.json`` names it;
        5. older replay buffers (and checkpoints beyond ``train.keep_checkpoints``) are removed.
        Every file goes through a temporary name and a rename (:func:`.artifacts.write_atomically`).
        """
        started = self.ledger.clock()
        step = int(model.num_timesteps)
        paths = rundir.checkpoint_paths(self.run_dir, step)
        state, tensors = continuity.capture(model)
        state["callbacks"] = self._callback_state()
        state["config_digest"] = rundir.config_digest(self.cfg, self.run_dir)
        try:
            paths.model.parent.mkdir(exist_ok=True)
        except OSError as exc:
            raise artifacts.ArtifactError(f"cannot create {paths.model.parent}: {exc.strerror or exc}") from None
        if self.writer is not None:
            self.writer.flush()
        artifacts.fault_point("metrics flushed")
        buffer_seconds: list[float] = []
        transitions = 0
        if self.cfg.algo.off_policy and self.cfg.train.save_replay_buffer:
            assert paths.replay_buffer is not None  # checkpoint_paths names one
            with self.ledger.timed(buffer_seconds):
                artifacts.save_replay_buffer(paths.replay_buffer, model.replay_buffer)
            transitions = int(model.replay_buffer.size()) * int(model.replay_buffer.n_envs)  # a row: n_envs of them
        artifacts.save_checkpoint_file(paths.model, model, self.cfg.algo.name, step, state, tensors)
        self._write_state("running", step, checkpoint=step)
        artifacts.fault_point("state written")
        self._prune(step)
        self.ledger.checkpoints.append(CheckpointCost(self.ledger.clock() - started, sum(buffer_seconds), transitions))

    def _prune(self, newest: int) -> None:
        found = rundir.checkpoints(self.run_dir)
        for c in found:
            if c.step != newest and c.replay_buffer is not None:
                c.replay_buffer.unlink(missing_ok=True)  # the newest buffer is the one a resume needs
                artifacts.fault_point(f"pruned {c.replay_buffer.name}")
        keep = self.cfg.train.keep_checkpoints
        if keep > 0:
            for c in found[:-keep]:
                c.model.unlink(missing_ok=True)

    def _write_state(self, status: str, step: int, checkpoint: int | None = None) -> None:
        if checkpoint is not None:
            self.state["checkpoint"] = checkpoint
        ev = self.evaluation
        self.state.update(
            {
                "status": status,
                "num_timesteps": step,
                "total_timesteps": self.cfg.train.total_timesteps,
                "config_digest": rundir.config_digest(self.cfg, self.run_dir),
                "best_mean_return": None
                if ev is None or not math.isfinite(ev.best_mean_reward)
                else ev.best_mean_reward,
                "best_step": ev.best_step if ev is not None else None,
                "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            }
        )
        rundir.write_state(self.run_dir, self.state)

    # --------------------------------------------------------------- finish

    def _finish(self, model: Any, stop: Any, start_step: int, elapsed: float) -> RunResult:
        """Record how the run ended: interrupted at its checkpoint, or complete (final policy saved)."""
        # signals stay handled while saving: a SIGTERM now (a second one, e.g. from a dying
        # launcher) must not kill the process halfway through writing the final files
        with _signals(stop, self.log, "finishing the files first"):
            interrupted = not stop.final and (
                stop.saved_at is not None or (stop.requested and model.num_timesteps < self.cfg.train.total_timesteps)
            )
            if interrupted:
                step = stop.saved_at if stop.saved_at is not None else int(self.state.get("checkpoint") or 0)
                self._write_state("interrupted", step)
                self.log(
                    f"interrupted at step {step}: checkpoint saved; continue with pyflyt train resume={self.run_dir}"
                )
            else:
                # ended by the budget, or by a callback at a rollout start (where its checkpoint was saved)
                step = stop.saved_at if stop.final and stop.saved_at is not None else int(model.num_timesteps)
                if self.evaluation is not None and not self.evaluation.current:
                    self.evaluation.evaluate()  # the final weights
                artifacts.save_policy(self.run_dir / rundir.FINAL_MODEL, model, self.cfg.algo.name, step)
                if stop.saved_at != step:
                    self.save_checkpoint(
                        model
                    )  # `pyflyt train resume=<run> train.total_timesteps=<more>` continues here
                trained_rate = (step - start_step) / elapsed if elapsed > 0 else 0.0
                split = {f"{k}_seconds": v for k, v in self.phases.split().items()} if self.phases else {}
                self.writer.log(
                    "/train/progress", step, {"elapsed": elapsed, "steps_per_second": trained_rate, **split}
                )
                self._write_state("complete", step)
                if self.curriculum is not None and not self.curriculum.finished(step):
                    left = ", ".join(f"{name} {value}" for name, value in self.curriculum.changes_at(step).items())
                    self.log(
                        f"curriculum: the gated schedule did not reach the configured task within the budget "
                        f"(the last training episodes flew {left}); more train.total_timesteps, a lower gate, "
                        "or fewer steps finish it"
                    )
        ev = self.evaluation
        trained = max(0, step - start_step)
        result = RunResult(
            run_dir=self.run_dir,
            num_timesteps=step,
            interrupted=interrupted,
            steps_per_second=trained / elapsed if elapsed > 0 else 0.0,
            elapsed=elapsed,
            last_eval=ev.last if ev is not None else None,
            last_eval_step=ev.last_step if ev is not None else None,
            best_mean_return=None if ev is None or not math.isfinite(ev.best_mean_reward) else ev.best_mean_reward,
            costs=self.ledger,
        )
        if self.phases is not None:
            self.ledger.split = self.phases.split()
        if not interrupted:
            from pyflyt_cli.training.multi_agent import step_unit

            measures = self.evaluation.measures if self.evaluation is not None else ()
            self.log(_summary(result, step_unit(self.cfg.env), measures))
        if self.phases is not None and elapsed > 0:  # printed when interrupted too (not logged: past the checkpoint)
            from pyflyt_cli.training.timing import describe_split

            self.log(f"time in training: {describe_split(self.phases.split())}")
        return result


def steps_per_round(cfg: TrainConfig) -> int:
    """Steps one collection round adds to the count: a rollout of ``algo.n_steps`` per env (on-policy) or
    ``algo.train_freq`` per env (off-policy, whose ``algo.n_steps`` is the n-step return's length), times the
    envs and, in a multi-agent env, its agents (a vector-env slot each)."""
    from pyflyt_cli.training.multi_agent import agents_per_env

    if cfg.algo.off_policy:
        per_env = getattr(cfg.algo, "train_freq", 1)
    else:
        per_env = getattr(cfg.algo, "n_steps", None) or 1
    return per_env * cfg.train.n_envs * agents_per_env(cfg.env)


def _expected_end(cfg: TrainConfig) -> int:
    """The step count a run ends at: the budget rounded up to whole rollouts (on-policy) or collection rounds
    (a multi-agent env fills a vector-env slot per agent)."""
    chunk = steps_per_round(cfg)
    return -(-cfg.train.total_timesteps // chunk) * chunk


def _summary(result: RunResult, unit: str = "steps", measures: tuple[Any, ...] = ()) -> str:
    """The end-of-run card: steps, time, the last evaluation with the task's success measures."""
    from pyflyt_engine.envs.tasks.measures import brief

    text = (
        f"done: {result.num_timesteps} {unit}, {result.elapsed:.1f} s in training "
        f"({result.steps_per_second:.0f} {unit}/s)"
    )
    if result.last_eval is not None:
        e = result.last_eval
        text += (
            f"; last evaluation: return {e['mean_return']:.2f} ± {e['std_return']:.2f}, "
            f"success {100 * e['success_rate']:.0f} %, length {e['mean_length']:.0f}"
        )
        measured = brief(measures, e)
        if measured:
            text += f", {measured}"
    return text + f"\nrun: {result.run_dir}\nevaluate it: pyflyt eval {result.run_dir}"


def _above_bar(log: Log) -> Log:
    """``log``, with any tqdm bar on stderr cleared while it writes and redrawn after
    (so a line printed during a run with a progress bar sits above the bar)."""
    if log is _silent:
        return log

    def write(message: str) -> None:
        import sys

        from tqdm import tqdm

        with tqdm.external_write_mode(file=sys.stderr):
            log(message)

    return write


def _is_terminal() -> bool:
    import sys

    return bool(getattr(sys.stderr, "isatty", lambda: False)())
