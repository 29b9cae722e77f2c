"""``pyflyt eval``: run a trained policy, record its episodes, summarise, optionally film it."""

from __future__ import annotations

import importlib.util
import json
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any


from pyflyt_cli.training import rundir
from pyflyt_cli.training.evaluation import EVAL_SEED_OFFSET, Episode, policy_predict, run_episodes, summarize
from pyflyt_cli.training.schema import EvalOptions, parse_eval_options
from pyflyt_engine.errors import ConfigError


@dataclass(frozen=True)
class EvalReport:
    """The outcome of :func:`evaluate_run`."""

    run_dir: Path
    model: Path
    #: which model: best, final or latest (checkpoint)
    which: str
    seed: int
    deterministic: bool
    episodes: list[Episode]
    summary: dict[str, float]
    #: the episode recordings (MCAP), empty if not recorded
    recordings: list[Path]
    video: Path | None

    def table(self) -> str:
        """The printed report: one row per episode, then mean ± std."""
        s = self.summary
        lines = [
            f"run:    {self.run_dir}",
            (
                f"model:  {self.model.name} ({self.which}), {'deterministic' if self.deterministic else 'stochastic'} "
                f"actions, seeds {self.seed}..{self.seed + len(self.episodes) - 1}"
            ),
            "",
            f"{'episode':>7}  {'seed':>6}  {'return':>10}  {'length':>6}  success",
        ]
        for i, e in enumerate(self.episodes):
            lines.append(f"{i:>7}  {e.seed:>6}  {e.ret:>10.2f}  {e.length:>6}  {'yes' if e.success else 'no'}")
        lines += [
            "",
            f"return        {s['mean_return']:.2f} ± {s['std_return']:.2f}  (mean ± std over {len(self.episodes)} episodes)",
            f"success rate  {100 * s['success_rate']:.0f} %",
            f"length        {s['mean_length']:.1f} steps",
        ]
        if self.recordings:
            lines.append(f"episodes:     {self.recordings[0].parent}/ ({len(self.recordings)} MCAP files)")
        if self.video is not None:
            lines.append(f"video:        {self.video}")
        return "\n".join(lines)


def evaluate_run(run_dir: str | Path, options: EvalOptions | Mapping[str, Any] | None = None) -> EvalReport:
    """Evaluate a run's model for ``options.episodes`` episodes (see :class:`EvalOptions`).

    Writes ``<run_dir>/episodes/ep_<NNNN>.mcap`` (``record``), ``<run_dir>/eval.json`` and,
    with ``video``, an animation of the first ``video_episodes`` episodes.
    """
    opts = parse_eval_options(options or {})
    trust = opts.trust_pickle
    path = rundir.check_run_dir(run_dir)
    cfg = rundir.load_run_config(path)
    model_path, which = rundir.find_model(path, opts.model, legacy=trust)
    video = Path(opts.video).expanduser().resolve() if opts.video else None
    if video is not None:
        _check_video_writer(video)

    import torch

    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.models import load_policy

    torch.set_num_threads(cfg.train.torch_threads)
    seed = opts.seed if opts.seed is not None else cfg.seed + EVAL_SEED_OFFSET
    episodes_dir = path / rundir.EPISODES
    scratch = None  # a video is filmed from recordings: without record=true, from temporary ones
    if video is not None and not opts.record:
        import tempfile

        scratch = tempfile.TemporaryDirectory(prefix="pyflyt-eval-")
    record_dir = str(episodes_dir) if opts.record else scratch.name if scratch is not None else None
    env = EnvFactory(cfg.env, monitor=False, record_dir=record_dir)()
    try:  # the model is read before the first episode is recorded: a bad file leaves nothing behind
        model, normalize = load_policy(model_path, cfg, env, trust_pickle=trust)
    except BaseException:
        env.close()
        if scratch is not None:
            scratch.cleanup()
        raise
    try:
        model.set_random_seed(seed)
        episodes = run_episodes(
            policy_predict(model),
            env,
            opts.episodes,
            seed,
            opts.deterministic,
            normalize_obs=normalize,
        )
    finally:
        recordings = list(_recorder_paths(env))
        env.close()
    summary = summarize(episodes)
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
    report = EvalReport(path, model_path, which, seed, opts.deterministic, episodes, summary, recordings, video)
    rundir.atomic_write(
        path / "eval.json",
        json.dumps(
            {
                "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "model": model_path.name,
                "which": which,
                "seed": seed,
                "deterministic": opts.deterministic,
                **summary,
                "episodes": [
                    {"seed": e.seed, "return": e.ret, "length": e.length, "success": e.success} for e in episodes
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
