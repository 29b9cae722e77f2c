"""Stable-Baselines3 models built from a run's configuration, and policies loaded into them.

A saved policy is tensors only (:mod:`.artifacts`); the model around it is always
rebuilt from the run's validated configuration, the same way for training, resuming,
bootstrapping (``init_from``) and evaluation:

    model = build_model(cfg, vec_env)
    model, normalize = load_policy(run_dir / "model.pt", cfg, env)   # ready to predict
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from pyflyt_cli.training import registry, rundir
from pyflyt_cli.training.artifacts import (
    PICKLE_RISK,
    ArtifactError,
    check_normalizer,
    load_legacy_model,
    load_legacy_normalizer,
    load_policy_into,
    observation_normalizer,
    read_payload,
)
from pyflyt_cli.training.schema import TrainConfig

if TYPE_CHECKING:
    from pyflyt_cli.training.evaluation import ObsNormalizer


def build_model(
    cfg: TrainConfig, vec: Any, *, inference: bool = False, tensorboard_log: str | None = None, offline: bool = True
) -> Any:
    """A new SB3 model of ``cfg.algo`` on ``vec`` (a VecEnv), seeded with ``cfg.seed``.

    ``inference``: for predicting only (evaluation): an off-policy replay buffer of one
    transition instead of ``algo.buffer_size``.  ``tensorboard_log``: SB3's TensorBoard folder.
    ``offline``: load ``algo.offline_buffer`` (AWAC); False for a model a checkpoint restores,
    whose replay buffer holds that data already.
    """
    algo = cfg.algo
    cls = registry.resolve(registry.ALGOS, algo.name, "algorithm")
    kwargs = algo.constructor_kwargs()
    noise = getattr(algo, "action_noise", None)
    if noise is not None:
        noise_cls = registry.resolve(registry.ACTION_NOISES, noise.type, "action noise")
        n = int(np.prod(vec.action_space.shape))
        kwargs["action_noise"] = noise_cls(mean=np.zeros(n), sigma=noise.sigma * np.ones(n))
    if not offline:
        kwargs.pop("offline_buffer", None)
        kwargs.pop("offline_steps", None)
    if inference:
        if "buffer_size" in kwargs:  # off-policy (its n_steps, if any, are n-step returns)
            kwargs["buffer_size"] = 1
        elif "n_steps" in kwargs and "batch_size" in kwargs:
            # the rollout buffer is never filled: a minibatch that fits the evaluation's
            # env count keeps SB3 from warning about truncated minibatches (a run of 16
            # envs x 32 steps, flown on one env)
            kwargs["batch_size"] = min(kwargs["batch_size"], kwargs["n_steps"] * vec.num_envs)
        kwargs.pop("offline_buffer", None)
        kwargs.pop("offline_steps", None)
    elif algo.name == "awac":
        kwargs["trust_pickle"] = cfg.trust_pickle
    from gymnasium import spaces

    # a Dict observation (a camera image next to the state vector) needs SB3's multi-input
    # policy; everything else is one Box
    policy = "MultiInputPolicy" if isinstance(vec.observation_space, spaces.Dict) else algo.policy
    model = cls(
        policy,
        vec,
        seed=cfg.seed,
        device=cfg.train.device,
        verbose=0 if inference else cfg.train.verbose,
        tensorboard_log=tensorboard_log,
        **kwargs,
    )
    if tensorboard_log is None:
        model.set_logger(_logger_without_folder(model.verbose))
    return model


def _logger_without_folder(verbose: int) -> Any:
    """SB3's logger for a run without TensorBoard: the same table on stdout when ``verbose``,
    and no folder.  Left to itself, ``learn()`` makes an empty ``SB3-<date>`` folder in the
    system's temporary directory at every call."""
    import sys

    from stable_baselines3.common.logger import HumanOutputFormat, Logger

    return Logger(folder=None, output_formats=[HumanOutputFormat(sys.stdout)] if verbose >= 1 else [])


@dataclass(frozen=True)
class PolicySource:
    """A policy to start from or to evaluate: its file, algorithm, tensors and normaliser."""

    path: Path
    algo: str
    #: the policy's state dict
    policy: dict[str, Any]
    #: normaliser statistics (:func:`.artifacts.normalizer_state`) or None
    normalizer: dict[str, Any] | None
    step: int | None = None

    @property
    def run(self) -> Path:
        """The run directory the file belongs to."""
        return rundir.run_of(self.path)


def read_policy(path: Path, *, trust_pickle: bool = False, algo_hint: str | None = None) -> PolicySource:
    """The policy in a policy file or checkpoint; a legacy SB3 ``.zip`` only with ``trust_pickle``.

    ``algo_hint``: the algorithm of a legacy file (its run's ``config.yaml``); pyflyt
    files name theirs.
    """
    path = Path(path)
    if path.suffix == ".zip":
        if not trust_pickle:
            raise ArtifactError(f"{path}: {PICKLE_RISK}")
        from stable_baselines3.common.save_util import load_from_zip_file

        try:
            _, params, _ = load_from_zip_file(path, device="cpu")
        except Exception as exc:  # noqa: BLE001 - a foreign file: any failure is reported, not raised
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ArtifactError(f"{path}: cannot load this SB3 model file ({first})") from None
        legacy_norm = rundir.legacy_normalizer(path)
        normalizer = load_legacy_normalizer(legacy_norm) if legacy_norm is not None else None
        # SB3 annotates params as name -> tensor; each value is a state dict (policy, policy.optimizer)
        policy = cast("dict[str, Any]", params["policy"])
        return PolicySource(path, algo_hint or "?", policy, normalizer)
    data = read_payload(path)
    return PolicySource(path, str(data["algo"]), data["policy"], data["normalizer"], int(data["step"]))


def load_policy(
    path: Path, cfg: TrainConfig, env: Any, *, trust_pickle: bool = False
) -> tuple[Any, ObsNormalizer | None]:
    """(model ready to predict, observation normaliser or None) for policy file ``path`` of a run
    configured by ``cfg``; ``env`` is a Gymnasium env wrapped for the agent."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    vec = DummyVecEnv([lambda: env])
    path = Path(path)
    if path.suffix == ".zip":
        if not trust_pickle:
            raise ArtifactError(f"{path}: {PICKLE_RISK}")
        cls = registry.resolve(registry.ALGOS, cfg.algo.name, "algorithm")
        model = load_legacy_model(cls, path, cfg.train.device)
        legacy_norm = rundir.legacy_normalizer(path)
        normalizer = load_legacy_normalizer(legacy_norm) if legacy_norm is not None else None
        return model, observation_normalizer(normalizer)
    source = read_policy(path)
    if source.algo != cfg.algo.name:
        raise ArtifactError(
            f"{path}: holds a {source.algo} policy, but the run's config.yaml says algo {cfg.algo.name}"
        )
    model = build_model(cfg, vec, inference=True)
    load_policy_into(model, {"policy": source.policy}, path)
    check_normalizer(source.normalizer, env.observation_space, path)
    return model, observation_normalizer(source.normalizer)
