"""``pyflyt eval``: run a trained policy or a scripted oracle, record its episodes, summarise, optionally film it."""

from __future__ import annotations

import importlib.util
import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_cli.training import rundir
from pyflyt_cli.training.evaluation import (
    END_WORDS,
    EVAL_SEED_OFFSET,
    Episode,
    disagreement,
    env_measures,
    policy_predict,
    run_episodes,
    summarize,
    summarize_measures,
)
from pyflyt_cli.training.schema import EvalOptions, TrainConfig, parse_eval_options
from pyflyt_engine.errors import ConfigError


@dataclass(frozen=True)
class EvalReport:
    """The outcome of :func:`evaluate_run`."""

    run_dir: Path
    #: the policy file flown (None for an oracle)
    model: Path | None
    #: which model: best, final or latest (checkpoint); ``oracle`` for a scripted oracle
    which: str
    seed: int
    deterministic: bool
    episodes: list[Episode]
    summary: dict[str, float]
    #: the episode recordings (MCAP), empty if not recorded
    recordings: list[Path]
    video: Path | None
    #: the scripted oracle flown (``pyflyt eval oracle:<name>``), None for a trained policy
    oracle: str | None = None
    #: changes to the run's environment these episodes flew (``pyflyt eval <run> env.<key>=...``)
    env_changes: dict[str, Any] | None = None
    #: the success measures the task declares (:mod:`pyflyt_engine.envs.tasks.measures`)
    measures: tuple[Any, ...] = ()
    #: those measures combined over the episodes (per-agent ones as ``<agent>/<key>``)
    measure_summary: dict[str, float] | None = None
    #: how far the run trained and which step the model flown comes from (one line; None for an oracle)
    trained: str | None = None
    #: a run trained on the batched backend: the same policy flown there as well
    #: (:func:`pyflyt_cli.training.batched.fly_episodes`), or why not (a one-line reason); None otherwise
    batched: dict[str, float] | str | None = None

    def table(self) -> str:
        """The printed report: one row per episode (return, length, success, why it ended,
        the task's measures), then the means and the measures over the episodes."""
        from pyflyt_engine.envs.tasks.measures import describe

        s = self.summary
        seeds = f"seeds {self.seed}..{self.seed + len(self.episodes) - 1}"
        flown = (
            f"oracle: {self.oracle} (scripted), {seeds}"
            if self.oracle is not None
            else f"model:  {self.model.name if self.model else '-'} ({self.which}), "
            f"{'deterministic' if self.deterministic else 'stochastic'} actions, {seeds}"
        )
        lines = [f"run:    {self.run_dir}", flown]
        if self.trained:
            lines.append(f"trained: {self.trained}")
        if self.env_changes:
            changed = ", ".join(f"{k}={v}" for k, v in self.env_changes.items())
            lines.append(f"env:    the run's, with {changed}")
        # per-agent values stay out of the rows (the summary lists them)
        columns = [m for m in self.measures if any(m.key in e.measures for e in self.episodes)]
        widths = [max(len(m.key), 8) for m in columns]
        header = f"{'episode':>7}  {'seed':>6}  {'return':>10}  {'length':>6}  {'success':<7}  {'ended':<20}"
        lines += ["", header + "".join(f"  {m.key:>{w}}" for m, w in zip(columns, widths))]
        for i, e in enumerate(self.episodes):
            row = (
                f"{i:>7}  {e.seed:>6}  {e.ret:>10.2f}  {e.length:>6}  {'yes' if e.success else 'no':<7}  "
                f"{END_WORDS.get(e.end, e.end):<20}"
            )
            cells = [_cell(m, e.measures.get(m.key)) for m in columns]
            lines.append(row + "".join(f"  {c:>{w}}" for c, w in zip(cells, widths)))
        lines += [
            "",
            f"return        {s['mean_return']:.2f} ± {s['std_return']:.2f}  (mean ± std over {len(self.episodes)} episodes)",
            f"success rate  {100 * s['success_rate']:.0f} %",
            f"length        {s['mean_length']:.1f} steps",
        ]
        if self.measure_summary:
            lines += describe(self.measures, self.measure_summary, width=12)
        why = disagreement(self.episodes)
        if why is not None:
            lines.append(why)
        if self.batched is not None:
            lines.append(batched_line(self.batched))
        if self.recordings:
            lines.append(f"episodes:     {self.recordings[0].parent}/ ({len(self.recordings)} MCAP files)")
        if self.video is not None:
            lines.append(f"video:        {self.video}")
        return "\n".join(lines)


def _cell(measure: Any, value: float | None) -> str:
    """One measure's value in an episode row: yes/no for a 0/1 rate, the number otherwise."""
    import math

    if value is None or math.isnan(value):
        return "-"
    if measure.percent and measure.rate:
        return "yes" if value >= 0.5 else "no"
    return measure.format(value) if measure.percent else f"{value:.{measure.digits}f}"


def trained_line(path: Path, model: Path, model_step: int | None, budget: int | None = None) -> str:
    """How far the run trained (``state.json``: status, steps of the budget) and which step
    the model flown comes from, in one line; an unfinished run says how to continue it.
    ``budget``: the configured ``train.total_timesteps``, for a run without ``state.json``."""
    try:
        state = rundir.read_state(path)
    except rundir.RunDirError:
        state = {}
    flown = f"{model.name} from step {model_step}" if model_step is not None else f"{model.name} (its step unknown)"
    if not state.get("status"):  # e.g. a shipped agent's folder: the policy file alone
        of = f" of a {budget}-step budget" if budget else ""
        return f"flying {flown}{of} (no {rundir.STATE_FILE} here: how far its training went is not recorded)"
    status = str(state["status"])
    done, total = state.get("num_timesteps"), state.get("total_timesteps") or budget
    of = f"{done} of {total} steps" if done is not None and total else f"{done} steps"
    if status == "complete":
        return f"complete, {of}; flying {flown}"
    words = {"interrupted": "interrupted", "running": "still running (or killed)", "failed": "failed"}
    text = f"UNFINISHED ({words.get(status, status)} at {of}); flying {flown}"
    if status in ("interrupted", "running"):
        text += f"; continue with pyflyt train resume={path}"
    return text


def evaluate_run(
    run_dir: str | Path,
    options: EvalOptions | Mapping[str, Any] | None = None,
    env: Mapping[str, Any] | None = None,
) -> EvalReport:
    """Evaluate a run's model for ``options.episodes`` episodes (see :class:`EvalOptions`).

    ``env``: changes to the run's environment for these episodes -- top-level env keys and
    task options by name, as :meth:`~pyflyt_engine.envs.config.EnvConfig.with_overrides`
    takes them (``{"max_duration_seconds": 30, "wind": "dryden_severe"}``); a change that
    alters the observation or action space the policy was trained on is refused
    (:class:`ConfigError`), as is an unknown key, before anything is written.

    Writes ``<run_dir>/episodes/ep_<NNNN>.mcap`` (``record``), ``<run_dir>/eval.json`` (with
    the env changes, if any) and, with ``video``, an animation of the first
    ``video_episodes`` episodes.
    """
    opts = parse_eval_options(options or {})
    trust = opts.trust_pickle
    path = rundir.check_run_dir(run_dir)
    cfg = rundir.load_run_config(path)
    env = _firmware_keeps_the_actions(cfg, env)
    env_config = _changed_env(cfg, dict(env)) if env else cfg.env
    model_path, which = rundir.find_model(path, opts.model, legacy=trust)
    import torch

    from pyflyt_cli.training.models import load_policy

    from pyflyt_engine.numerics import apply_torch

    torch.set_num_threads(cfg.train.torch_threads)
    apply_torch()
    seed = opts.seed if opts.seed is not None else cfg.seed + EVAL_SEED_OFFSET

    steps: list[int | None] = [None]

    def load(env: Any) -> tuple[Callable[[np.ndarray, bool], np.ndarray], Any]:
        model, normalize = load_policy(model_path, cfg, env, trust_pickle=trust)
        model.set_random_seed(seed)
        if model_path.suffix != ".zip":  # a pyflyt policy file names the step it was saved at
            from pyflyt_cli.training.models import read_policy

            steps[0] = read_policy(model_path).step
        return policy_predict(model), normalize

    return _fly(
        path,
        env_config,
        load,
        opts,
        seed,
        model=model_path,
        which=which,
        env_changes=dict(env or {}),
        trained=lambda: trained_line(path, model_path, steps[0], cfg.train.total_timesteps),
        batched=_batched_episodes(env_config, opts, seed) if cfg.env.backend == "batched" else None,
    )


def batched_line(batched: dict[str, float] | str) -> str:
    """The report's line on the batched backend's episodes (a run trained there)."""
    if isinstance(batched, str):
        return f"batched:      {batched}"
    parts = [f"success {100 * batched['success_rate']:.0f} %", f"return {batched['mean_return']:.2f}"]
    if "waypoints_reached" in batched:
        parts += [f"waypoints {batched['waypoints_reached']:.2f}", f"all reached {100 * batched['all_reached']:.0f} %"]
    return (
        f"batched:      {', '.join(parts)} ({int(batched['episodes'])} episodes on the batched backend the run "
        "trained on, its own draws of the task; the rows above flew the PyBullet engine)"
    )


def _batched_episodes(env_config: Any, opts: EvalOptions, seed: int) -> Callable[[Any, Any], dict[str, float] | str]:
    """For a run trained on the batched backend: fly the policy there too, or say why not."""

    def fly(predict: Any, normalize: Any) -> dict[str, float] | str:
        from pyflyt_engine.batched import check_supported

        if hasattr(predict, "reset"):
            return "not flown (a recurrent policy carries one memory per episode)"
        try:
            check_supported(env_config.model_copy(update={"backend": "batched"}))
        except ConfigError as exc:  # an env change the batched backend does not simulate
            return f"not flown ({exc})"
        from pyflyt_cli.training.batched import fly_episodes

        return fly_episodes(predict, normalize, env_config, opts.episodes, seed, opts.deterministic)

    return fly


def _firmware_keeps_the_actions(cfg: TrainConfig, env: Mapping[str, Any] | None) -> Mapping[str, Any] | None:
    """``env.controller=betaflight`` for a policy trained on the own controller in
    ``rates_thrust``: its actions stay body rates and thrust (``firmware_action: rates``, the
    firmware flies them through the inverted rate curve at the policy's agent rate), unless the
    changes say otherwise."""
    if not env or env.get("controller") != "betaflight" or "firmware_action" in env:
        return env
    if getattr(cfg.env, "controller", "own") == "own" and cfg.env.action.mode == "rates_thrust":
        return {**env, "firmware_action": "rates"}
    return env


def _changed_env(cfg: TrainConfig, changes: dict[str, Any]) -> Any:
    """The run's env with ``changes``; refused if the policy's spaces would change (the
    training env's, and the env's own before the training wrappers rescale its actions)."""
    from pyflyt_cli.training.envs import EnvFactory

    changed = cfg.env.with_overrides(**changes)  # unknown keys and bad values are named here
    spaces = []
    for config in (cfg.env, changed):
        env = EnvFactory(config, monitor=False)()
        try:
            raw = getattr(env, "unwrapped", env)
            spaces.append((env.observation_space, (env.action_space, raw.action_space)))
        finally:
            env.close()
    (trained_obs, (trained_act, trained_raw)), (obs, (act, raw_act)) = spaces
    keys = ", ".join(f"env.{k}" for k in changes)
    if trained_act == act and trained_raw != raw_act:  # the same rescaled Box, other actions
        trained_act, act = trained_raw, raw_act
    for what, trained, now in (("observation", trained_obs, obs), ("action", trained_act, act)):
        if trained != now:
            raise ConfigError(
                f"{keys}: changes the {what} space the policy was trained on ({trained} -> {now}); "
                "a trained policy flies only changes that keep its spaces (e.g. wind, randomize, episode length, "
                "task options that do not resize the observation)"
            )
    return changed


def evaluate_oracle(
    name: str,
    cfg: TrainConfig,
    options: EvalOptions | Mapping[str, Any] | None = None,
    run_dir: str | Path | None = None,
) -> EvalReport:
    """Fly the scripted oracle ``name`` (:mod:`pyflyt_engine.envs.oracles`) in ``cfg.env``, as
    :func:`evaluate_run` flies a trained policy: the same episodes for the same seeds, the
    same recordings, ``eval.json`` and video.

    The results go to ``run_dir`` (created; it must not exist), by default a new
    ``<train.output_dir>/<env_name>/oracle_<name>/<time>-seed<k>`` (k: the first episode's
    seed), with ``oracle.yaml``: the oracle and the environment it flew.  ``options.seed``
    null flies the episodes a seed-0 run's evaluations fly (seeds 1000, 1001, ...).
    """
    from pyflyt_engine.envs.oracles import ORACLES, make_oracle

    opts = parse_eval_options(options or {})
    if name not in ORACLES:
        from pyflyt_engine.suggest import did_you_mean

        raise ConfigError(
            f"unknown oracle {name!r}.{did_you_mean(name, ORACLES)} Oracles: {', '.join(sorted(ORACLES))}"
        )
    env_ids = ORACLES[name].env_ids
    if cfg.env.id not in env_ids:
        raise ConfigError(f"oracle {name} flies {', '.join(env_ids)}, not {cfg.env.id} (env={cfg.env_name})")
    if opts.video:  # nothing is created for a video that cannot be written
        _check_video_writer(Path(opts.video).expanduser().resolve())
    seed = opts.seed if opts.seed is not None else EVAL_SEED_OFFSET
    env_name = cfg.env_name
    if run_dir is None:
        path = rundir.create_run_dir(cfg.train.output_dir, env_name, f"oracle_{name}", seed)
    elif Path(run_dir).expanduser().exists():
        raise rundir.RunDirError(f"run_dir={run_dir} already exists: choose a new directory for the oracle's episodes")
    else:
        path = rundir.create_named_run_dir(run_dir)
    env_data = rundir.config_dict(cfg)["env"]
    rundir.write_yaml(
        path / ORACLE_FILE,
        {"oracle": name, "env_name": env_name, "env": env_data},
        f"# The scripted oracle flown here and its environment (pyflyt eval oracle:{name}).\n",
    )

    def load(env: Any) -> tuple[Callable[[np.ndarray, bool], np.ndarray], Any]:
        from pyflyt_cli.training.imitation import agent_units

        oracle, to_agent = make_oracle(name, env), agent_units(env)
        return (lambda obs, deterministic: to_agent(oracle(obs))), None

    try:
        return _fly(path, cfg.env, load, opts, seed, model=None, which="oracle", oracle=name)
    except BaseException:
        if not any((path / rundir.EPISODES).glob("*.mcap")):  # nothing flown: leave nothing behind
            import shutil

            shutil.rmtree(path, ignore_errors=True)
        raise


#: what ``pyflyt eval oracle:<name>`` writes beside the recordings
ORACLE_FILE = "oracle.yaml"


def _fly(
    path: Path,
    env_config: Any,
    load: Callable[[Any], tuple[Callable[[np.ndarray, bool], np.ndarray], Any]],
    opts: EvalOptions,
    seed: int,
    *,
    model: Path | None,
    which: str,
    oracle: str | None = None,
    env_changes: dict[str, Any] | None = None,
    trained: Callable[[], str] | None = None,
    batched: Callable[[Any, Any], dict[str, float] | str] | None = None,
) -> EvalReport:
    """Fly ``opts.episodes`` episodes of ``env_config`` with the policy ``load(env)`` returns
    (``(predict, normalize_obs)``); record, film, write ``eval.json`` (``env_changes``: the
    changes to the run's env flown, recorded there); the report."""
    video = Path(opts.video).expanduser().resolve() if opts.video else None
    if video is not None:
        _check_video_writer(video)

    from pyflyt_cli.training.envs import EnvFactory

    episodes_dir = path / rundir.EPISODES
    scratch = None  # a video is filmed from recordings: without record=true, from temporary ones
    if video is not None and not opts.record:
        import tempfile

        scratch = tempfile.TemporaryDirectory(prefix="pyflyt-eval-")
    record_dir = str(episodes_dir) if opts.record else scratch.name if scratch is not None else None
    env = EnvFactory(env_config, monitor=False, record_dir=record_dir)()
    try:  # the policy is read before the first episode is recorded: a bad file leaves nothing behind
        predict, normalize = load(env)
    except BaseException:
        env.close()
        if scratch is not None:
            scratch.cleanup()
        raise
    try:
        episodes = run_episodes(predict, env, opts.episodes, seed, opts.deterministic, normalize_obs=normalize)
    finally:
        recordings = list(_recorder_paths(env))
        env.close()
    summary = summarize(episodes)
    on_batched = batched(predict, normalize) if batched is not None else None
    measures = env_measures(env)
    measure_summary = summarize_measures(measures, episodes)
    try:
        if video is not None:  # the same film as `pyflyt replay --video` of those recordings
            from pyflyt_cli.outputs import atomic_output
            from pyflyt_engine.telemetry import load_episode
            from pyflyt_engine.telemetry.video import render_video

            filmed = [load_episode(p) for p in recordings[: opts.video_episodes]]
            with atomic_output(video, "video=") as tmp:
                render_video(filmed, tmp, fps=opts.fps)
    finally:
        if scratch is not None:
            recordings = []
            scratch.cleanup()
    from pyflyt_engine.envs.tasks.measures import plain

    report = EvalReport(
        path,
        model,
        which,
        seed,
        opts.deterministic,
        episodes,
        summary,
        recordings,
        video,
        oracle,
        env_changes or None,
        measures,
        measure_summary,
        trained() if trained is not None else None,
        on_batched,
    )
    flown = {"oracle": oracle} if oracle is not None else {"model": model.name if model else None}
    rundir.atomic_write(
        path / "eval.json",
        json.dumps(
            {
                "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                **flown,
                "which": which,
                "seed": seed,
                "deterministic": opts.deterministic,
                **({"env_changes": env_changes} if env_changes else {}),
                **({"trained": report.trained} if report.trained else {}),
                **summary,
                "measures": plain(measure_summary),
                **({"batched": on_batched} if on_batched is not None else {}),
                "episodes": [
                    {
                        "seed": e.seed,
                        "return": e.ret,
                        "length": e.length,
                        "success": e.success,
                        "end": e.end,
                        "measures": plain(e.measures),
                    }
                    for e in episodes
                ],
                "recordings": [p.name for p in recordings],
            },
            indent=2,
        )
        + "\n",
    )
    return report


def _recorder_paths(env: Any) -> list[Path]:
    e = env
    while e is not None:
        if hasattr(e, "paths") and hasattr(e, "prefix"):
            return [Path(p) for p in e.paths]
        e = getattr(e, "env", None)
    return []


def _check_video_writer(video: Path) -> None:
    if importlib.util.find_spec("imageio") is None:
        raise ConfigError(f"video={video}: writing videos needs imageio: pip install imageio")
    if video.suffix.lower() == ".mp4" and importlib.util.find_spec("imageio_ffmpeg") is None:
        raise ConfigError(f"video={video}: MP4 needs imageio-ffmpeg (pip install imageio-ffmpeg); or write a .gif")
    from pyflyt_cli.outputs import check_output
    from pyflyt_engine.telemetry.plots import VIDEO_SUFFIXES

    check_output(video, "video=", VIDEO_SUFFIXES)
