"""Train, resume and bootstrap runs: plain functions on a plain :class:`TrainConfig`.

    from pyflyt_cli.training import train, resume
    result = train({"env_name": "quadx_hover", "env": ..., "algo": {"name": "ppo"}, ...})
    result = resume(result.run_dir)                 # after an interruption

No Hydra here: the CLI (``pyflyt_cli/commands/train.py``) composes ``conf/train.yaml``
and calls :func:`train`; tests and scripts call it directly.
"""

from __future__ import annotations

import contextlib
import importlib.util
import math
import os
import shutil
import signal
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_cli.training import registry, rundir
from pyflyt_cli.training.evaluation import EVAL_SEED_OFFSET
from pyflyt_cli.training.schema import TrainConfig, parse_train_config
from pyflyt_engine.errors import ConfigError, PyFlytError

Log = Callable[[str], None]


@dataclass(frozen=True)
class RunResult:
    """What a call to :func:`train` or :func:`resume` did."""

    run_dir: Path
    #: environment steps of the model at the end (the step counter saved with it)
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
    """
    cfg = parse_train_config(config)
    _check_environment(cfg)
    init = _init_source(cfg.init_from) if cfg.init_from else None
    _probe_env(cfg)
    if run_dir is None:
        run_dir = rundir.create_run_dir(cfg.train.output_dir, cfg.env_name, cfg.algo.name, cfg.seed)
    else:
        run_dir = rundir.create_named_run_dir(run_dir)
    try:
        cfg = rundir.portable_config(cfg, run_dir)
    except Exception:
        shutil.rmtree(run_dir, ignore_errors=True)
        raise
    rundir.save_config(cfg, run_dir)
    record = rundir.run_record(cfg, command, overrides)
    if init is not None:
        record["init_from"] = {"run": str(init[0]), "model": str(init[1])}
    rundir.write_yaml(run_dir / rundir.RUN_FILE, record)
    rundir.write_state(run_dir, {"status": "starting", "num_timesteps": 0, "checkpoint": None})
    log(f"run directory: {run_dir}")
    with rundir.run_lock(run_dir):
        return _Run(cfg, run_dir, log, progress_bar).execute(callbacks, init=init)


def resume(
    run_dir: str | Path,
    *,
    total_timesteps: int | None = None,
    callbacks: Sequence[Any] = (),
    log: Log = _silent,
    progress_bar: bool | None = None,
) -> RunResult:
    """Continue an interrupted run from its newest checkpoint, in the same directory.

    The step counter, weights, optimiser state, replay buffer (off-policy) and
    normalisation statistics come from the checkpoint; metrics recorded after it are
    dropped and logging continues in the next metrics segment.  ``total_timesteps``
    extends (or sets) the budget.  A run killed before its first checkpoint starts over.
    """
    path = rundir.check_run_dir(run_dir)
    with rundir.run_lock(path):
        return _resume(path, total_timesteps, callbacks, log, progress_bar)


def _resume(
    path: Path, total_timesteps: int | None, callbacks: Sequence[Any], log: Log, progress_bar: bool | None
) -> RunResult:
    cfg = rundir.load_run_config(path)
    if total_timesteps is not None:
        data = cfg.model_dump(mode="json")
        data["train"]["total_timesteps"] = int(total_timesteps)
        cfg = parse_train_config(data)
    _check_environment(cfg)
    _probe_env(cfg)
    state = rundir.read_state(path)
    found = rundir.checkpoints(path)
    checkpoint = None
    if state.get("checkpoint") is not None:
        checkpoint = next((c for c in found if c.step == state["checkpoint"]), None)
    if checkpoint is None and found:
        checkpoint = found[-1]
    done = int(state.get("num_timesteps", 0))
    if state.get("status") == "complete" and done >= cfg.train.total_timesteps:
        raise ConfigError(
            f"{path} is complete ({done} of train.total_timesteps={cfg.train.total_timesteps} steps); "
            f"to train it longer: pyflyt train resume={path} train.total_timesteps=<more>"
        )
    if total_timesteps is not None:
        rundir.save_config(cfg, path)
    record = rundir.read_yaml(path / rundir.RUN_FILE)
    record.setdefault("resumes", []).append(
        {
            "at": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "from_step": checkpoint.step if checkpoint else 0,
            "pid": os.getpid(),
        }
    )
    rundir.write_yaml(path / rundir.RUN_FILE, record)
    log(f"resuming {path} from " + (f"step {checkpoint.step}" if checkpoint else "the start (no checkpoint was saved)"))
    init = _init_source(cfg.init_from) if cfg.init_from and checkpoint is None else None
    run = _Run(cfg, path, log, progress_bar)
    return run.execute(callbacks, checkpoint=checkpoint, state=state if checkpoint else {}, init=init)


# ------------------------------------------------------------------- internals


def _check_environment(cfg: TrainConfig) -> None:
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


def _init_source(source: str) -> tuple[Path, Path, Path | None, str]:
    """(run dir, model file, VecNormalize file, algo name) of ``init_from``.

    ``init_from`` is a run directory (its best model, else final, else newest checkpoint)
    or one model file of a run: ``model.zip``, ``best_model.zip`` or
    ``checkpoints/model_<steps>_steps.zip`` (a partially trained policy).
    """
    given = Path(source).expanduser()
    model: Path | None = None
    if given.suffix == ".zip":
        if not given.is_file():
            raise ConfigError(f"init_from: model file {given} does not exist")
        model = given.resolve()
        run = model.parent.parent if model.parent.name == rundir.CHECKPOINTS else model.parent
    else:
        run = given
    try:
        path = rundir.check_run_dir(run)
    except ConfigError as exc:
        raise ConfigError(f"init_from: {exc}") from None
    source_cfg = rundir.read_yaml(path / rundir.CONFIG_FILE)
    algo = str((source_cfg.get("algo") or {}).get("name", "?"))
    if model is not None:
        return path, model, rundir.vecnormalize_of(model), algo
    try:
        model, vecnorm, _ = rundir.find_model(path, "auto")
    except ConfigError as exc:
        raise ConfigError(f"init_from: {exc}") from None
    return path, model, vecnorm, algo


@contextlib.contextmanager
def _signals(stop: Any, log: Log) -> Iterator[None]:
    """SIGINT/SIGTERM request a clean stop; a second SIGINT aborts at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        name = signal.Signals(signum).name
        if stop.requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        stop.request(name)
        log(
            f"\n{name} received: stopping at the next step and saving a checkpoint (Ctrl-C again to abort without saving)"
        )

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def _consolidate_metrics(run_dir: Path, up_to: int) -> None:
    """Rewrite the run's metrics as one ``metrics.mcap`` holding the records at steps <= ``up_to``."""
    import warnings

    from pyflyt_engine.telemetry.metrics import MetricsWriter, read_metrics, read_metrics_metadata, segment_paths

    segments = segment_paths(run_dir)
    if not segments:
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            records = read_metrics(run_dir)
            metadata = read_metrics_metadata(run_dir)[0]
        except (PyFlytError, OSError, ValueError, KeyError):  # unreadable: keep nothing rather than fail the resume
            records, metadata = {}, {}
    rows = sorted(
        ((rec["wall_time"], topic, rec) for topic, recs in records.items() for rec in recs if rec["step"] <= up_to),
        key=lambda r: r[0],
    )
    with tempfile.TemporaryDirectory(dir=run_dir, prefix=".metrics-") as tmp:
        target = Path(tmp) / "metrics.mcap"
        with MetricsWriter(target, metadata=metadata) as writer:
            for wall, topic, rec in rows:
                values = {k: v for k, v in rec.items() if k not in ("step", "wall_time")}
                writer.log(topic, int(rec["step"]), values, wall_time=wall)
        os.replace(target, run_dir / "metrics.mcap")
    for seg in segments:
        if seg.name != "metrics.mcap":
            seg.unlink(missing_ok=True)


class _Run:
    """One execution of learn() for a run directory (new or resumed)."""

    def __init__(self, cfg: TrainConfig, run_dir: Path, log: Log, progress_bar: bool | None) -> None:
        self.cfg = cfg
        self.run_dir = run_dir
        self.log = log
        self.progress_bar = progress_bar if progress_bar is not None else cfg.train.progress_bar
        self.state: dict[str, Any] = {}
        self.evaluation: Any = None

    # ------------------------------------------------------------ the model

    def _build(self, vec: Any, checkpoint: rundir.Checkpoint | None) -> Any:
        cfg, algo = self.cfg, self.cfg.algo
        cls = registry.resolve(registry.ALGOS, algo.name, "algorithm")
        tensorboard = str(self.run_dir / "tensorboard") if cfg.train.tensorboard else None
        if checkpoint is not None:
            model = cls.load(checkpoint.model, env=vec, device=cfg.train.device, tensorboard_log=tensorboard)
            if algo.off_policy and checkpoint.replay_buffer is not None:
                model.load_replay_buffer(checkpoint.replay_buffer)
            # fresh, reproducible random streams for the rest of the run
            model.set_random_seed(cfg.seed + model.num_timesteps)
            return model
        kwargs = algo.constructor_kwargs()
        noise = getattr(algo, "action_noise", None)
        if noise is not None:
            noise_cls = registry.resolve(registry.ACTION_NOISES, noise.type, "action noise")
            n = int(np.prod(vec.action_space.shape))
            kwargs["action_noise"] = noise_cls(mean=np.zeros(n), sigma=noise.sigma * np.ones(n))
        return cls(
            algo.policy,
            vec,
            seed=cfg.seed,
            device=cfg.train.device,
            verbose=cfg.train.verbose,
            tensorboard_log=tensorboard,
            **kwargs,
        )

    def _bootstrap(self, model: Any, vec: Any, init: tuple[Path, Path, Path | None, str]) -> None:
        from stable_baselines3.common.save_util import load_from_zip_file

        run, path, vecnorm, algo = init
        accepted = {self.cfg.algo.name} | registry.INIT_FROM.get(self.cfg.algo.name, frozenset())
        if algo not in accepted:
            raise ConfigError(
                f"init_from={run}: that run trained {algo}, this one {self.cfg.algo.name}; "
                f"{self.cfg.algo.name} can start from the policy weights of: {', '.join(sorted(accepted))}"
            )
        _, params, _ = load_from_zip_file(path, device=self.cfg.train.device)
        try:
            model.policy.load_state_dict(params["policy"])
        except (RuntimeError, KeyError) as exc:
            first = str(exc).splitlines()[0]
            raise ConfigError(
                f"init_from={run}: its policy does not fit this run's (same env observation/action sizes and "
                f"algo.policy_kwargs.net_arch and algo.use_sde needed): {first}"
            ) from None
        target = model.get_vec_normalize_env()
        if target is not None and vecnorm is not None:
            from stable_baselines3.common.vec_env import VecNormalize

            source = VecNormalize.load(str(vecnorm), vec.venv if hasattr(vec, "venv") else vec)
            target.obs_rms = source.obs_rms
            target.ret_rms = source.ret_rms
        self.log(f"policy initialised from {path}")

    # ----------------------------------------------------------- checkpoints

    def save_checkpoint(self, model: Any) -> None:
        step = int(model.num_timesteps)
        c = rundir.checkpoint_paths(self.run_dir, step)
        c.model.parent.mkdir(exist_ok=True)
        buffer = c.replay_buffer if self.cfg.algo.off_policy and self.cfg.train.save_replay_buffer else None
        from pyflyt_cli.training.callbacks import save_model_files

        save_model_files(model, c.model, c.vecnormalize if self.cfg.algo.normalize.enabled else None, buffer)
        self._prune(step)
        if self.writer is not None:
            self.writer.flush()
        self._write_state("running", step, checkpoint=step)

    def _prune(self, newest: int) -> None:
        found = rundir.checkpoints(self.run_dir)
        for c in found:
            if c.step != newest and c.replay_buffer is not None:
                c.replay_buffer.unlink(missing_ok=True)  # one replay buffer is enough to resume
        keep = self.cfg.train.keep_checkpoints
        if keep > 0:
            for c in found[:-keep]:
                for p in (c.model, c.vecnormalize, c.replay_buffer):
                    if p is not None:
                        p.unlink(missing_ok=True)

    def _write_state(self, status: str, step: int, checkpoint: int | None = None) -> None:
        if checkpoint is not None:
            self.state["checkpoint"] = checkpoint
        ev = self.evaluation
        self.state.update(
            {
                "status": status,
                "num_timesteps": step,
                "total_timesteps": self.cfg.train.total_timesteps,
                "next_eval": ev.next_eval if ev is not None else None,
                "best_mean_return": None
                if ev is None or not math.isfinite(ev.best_mean_reward)
                else ev.best_mean_reward,
                "best_step": ev.best_step if ev is not None else None,
                "next_checkpoint": self.checkpointer.next_checkpoint if self.checkpointer is not None else None,
                "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            }
        )
        rundir.write_state(self.run_dir, self.state)

    # --------------------------------------------------------------- execute

    def execute(
        self,
        extra_callbacks: Sequence[Any],
        *,
        checkpoint: rundir.Checkpoint | None = None,
        state: Mapping[str, Any] | None = None,
        init: tuple[Path, Path, Path | None, str] | None = None,
    ) -> RunResult:
        import torch
        from stable_baselines3.common.callbacks import CallbackList
        from stable_baselines3.common.utils import set_random_seed
        from stable_baselines3.common.vec_env import VecNormalize

        from pyflyt_cli.training.callbacks import (
            Checkpointer,
            EpisodeMetrics,
            PeriodicEvaluation,
            ProgressBar,
            StopOnRequest,
            StopRequest,
            save_model_files,
        )
        from pyflyt_cli.training.envs import EnvFactory, make_vec_env
        from pyflyt_engine.telemetry.metrics import MetricsWriter

        cfg, opts = self.cfg, self.cfg.train
        state = dict(state or {})
        self.state = {k: v for k, v in state.items() if k in ("checkpoint",)}
        self.writer = None
        self.checkpointer = None
        torch.set_num_threads(opts.torch_threads)
        set_random_seed(cfg.seed)

        vec = make_vec_env(cfg.env, opts.n_envs, opts.vec_env)
        eval_env = None
        try:
            norm = cfg.algo.normalize
            if norm.enabled:
                if checkpoint is not None and checkpoint.vecnormalize is not None:
                    vec = VecNormalize.load(str(checkpoint.vecnormalize), vec)
                else:
                    vec = VecNormalize(
                        vec,
                        norm_obs=norm.observation,
                        norm_reward=norm.reward,
                        clip_obs=norm.clip_obs,
                        gamma=cfg.algo.gamma,
                    )
            model = self._build(vec, checkpoint)
            if init is not None:
                self._bootstrap(model, vec, init)
            start_step = int(model.num_timesteps)

            # metrics: drop what was logged after the checkpoint, continue in a new segment
            if checkpoint is not None:
                _consolidate_metrics(self.run_dir, start_step)
            else:
                for seg in self.run_dir.glob("metrics*.mcap"):
                    seg.unlink()  # a run restarted from scratch
            metadata = {"env": cfg.env_name, "env_id": str(cfg.env.id), "algo": cfg.algo.name, "seed": str(cfg.seed)}
            self.writer = MetricsWriter(self.run_dir / "metrics.mcap", metadata=metadata, append=True)

            show_bar = self.progress_bar if self.progress_bar is not None else _is_terminal()
            stop = StopRequest()
            stopper = StopOnRequest(stop)
            episodes = EpisodeMetrics(self.writer)
            callbacks: list[Any] = [stopper, episodes]
            if opts.eval_freq > 0:
                eval_env = EnvFactory(cfg.env, monitor=False)()
                children = [c.build() for c in cfg.callbacks]
                child = CallbackList(children) if len(children) > 1 else (children[0] if children else None)
                best = state.get("best_mean_return")
                self.evaluation = PeriodicEvaluation(
                    eval_env,
                    self.run_dir,
                    self.writer,
                    opts.eval_freq,
                    opts.eval_episodes,
                    cfg.seed + EVAL_SEED_OFFSET,
                    opts.eval_deterministic,
                    next_eval=int(state.get("next_eval") or opts.eval_freq),
                    best_mean_reward=-np.inf if best is None else float(best),
                    best_step=state.get("best_step"),
                    callback_after_eval=child,
                    log=None if show_bar else self.log,  # without a bar, one line per evaluation
                    total=opts.total_timesteps,
                )
                callbacks.append(self.evaluation)
            elif cfg.callbacks:
                raise ConfigError("callbacks run after evaluations: set train.eval_freq > 0 to use them")
            self.checkpointer = Checkpointer(
                self, opts.checkpoint_freq, int(state.get("next_checkpoint") or opts.checkpoint_freq or 0)
            )
            callbacks.append(self.checkpointer)
            if show_bar:
                callbacks.append(ProgressBar(_expected_end(cfg), episodes))
            callbacks.extend(extra_callbacks)

            self._write_state("running", start_step)
            remaining = opts.total_timesteps - start_step
            started = time.perf_counter()
            interrupted = False
            with _signals(stop, self.log):
                if remaining > 0:
                    try:
                        model.learn(
                            remaining,
                            callback=CallbackList(callbacks),
                            reset_num_timesteps=False,
                            tb_log_name="run",
                            progress_bar=False,
                        )
                    except (EOFError, BrokenPipeError, ConnectionResetError):
                        if not stop.requested:  # a worker died for another reason
                            raise
                interrupted = stop.requested
            elapsed = time.perf_counter() - started

            # signals stay handled while saving: a SIGTERM now (a second one, e.g. from a dying
            # launcher) must not kill the process halfway through writing the checkpoint
            with _signals(stop, self.log):
                if interrupted:
                    # the partial rollout since the last update is not in the weights: count only what is
                    model.num_timesteps = stopper.rollout_start_step
                    if self.evaluation is not None:  # an evaluation past that point is logged again after the resume
                        self.evaluation.next_eval = (model.num_timesteps // opts.eval_freq + 1) * opts.eval_freq
                    self.save_checkpoint(model)
                    self._write_state("interrupted", int(model.num_timesteps))
                    self.log(
                        f"interrupted at step {model.num_timesteps}: checkpoint saved; continue with "
                        f"pyflyt train resume={self.run_dir}"
                    )
                else:
                    if self.evaluation is not None and self.evaluation.last_step != model.num_timesteps:
                        self.evaluation.evaluate()
                    save_model_files(model, self.run_dir / rundir.FINAL_MODEL, self.run_dir / rundir.FINAL_VECNORM)
                    self.save_checkpoint(
                        model
                    )  # `pyflyt train resume=<run> train.total_timesteps=<more>` continues from here
                    self.writer.log(
                        "/train/progress",
                        int(model.num_timesteps),
                        {
                            "elapsed": elapsed,
                            "steps_per_second": (model.num_timesteps - start_step) / elapsed if elapsed > 0 else 0.0,
                        },
                    )
                    self._write_state("complete", int(model.num_timesteps))
            trained = max(0, int(model.num_timesteps) - start_step)
            ev = self.evaluation
            result = RunResult(
                run_dir=self.run_dir,
                num_timesteps=int(model.num_timesteps),
                interrupted=interrupted,
                steps_per_second=trained / elapsed if elapsed > 0 else 0.0,
                elapsed=elapsed,
                last_eval=ev.last if ev is not None else None,
                last_eval_step=ev.last_step if ev is not None else None,
                best_mean_return=None if ev is None or not math.isfinite(ev.best_mean_reward) else ev.best_mean_reward,
            )
            if not interrupted:
                self.log(_summary(result))
            return result
        finally:
            if self.writer is not None:
                self.writer.close()
            if eval_env is not None:
                eval_env.close()
            vec.close()


def _expected_end(cfg: TrainConfig) -> int:
    """The step count a run ends at: the budget rounded up to whole rollouts (on-policy) or collection rounds."""
    per_round = getattr(cfg.algo, "n_steps", None) or getattr(cfg.algo, "train_freq", 1)
    chunk = per_round * cfg.train.n_envs
    return -(-cfg.train.total_timesteps // chunk) * chunk


def _summary(result: RunResult) -> str:
    text = f"done: {result.num_timesteps} steps, {result.elapsed:.1f} s in training ({result.steps_per_second:.0f} steps/s)"
    if result.last_eval is not None:
        e = result.last_eval
        text += (
            f"; last evaluation: return {e['mean_return']:.2f} ± {e['std_return']:.2f}, "
            f"success {100 * e['success_rate']:.0f} %, length {e['mean_length']:.0f}"
        )
    return text + f"\nrun: {result.run_dir}\nevaluate it: pyflyt eval {result.run_dir}"


def _is_terminal() -> bool:
    import sys

    return bool(getattr(sys.stderr, "isatty", lambda: False)())
