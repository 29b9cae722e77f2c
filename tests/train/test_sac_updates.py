"""SAC's gradient steps (``pyflyt_cli/training/sac.py``) compute what SB3's ``SAC.train`` does, bit for bit.

The project's SAC only spends less CPU per update; the same seed and configuration give the same
weights, optimiser states, logged losses, evaluations and training episodes as SB3's class, and
as the run recorded below (made before that class existed) wherever the numbers are promised to
agree (the same pinned numeric platform, docs/reproducibility.md).
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
import torch
from stable_baselines3 import SAC as SB3SAC
from stable_baselines3.common.buffers import NStepReplayBuffer

from pyflyt_cli.training import registry, train
from pyflyt_cli.training.compose import compose_config
from pyflyt_cli.training.sac import SAC
from pyflyt_engine.numerics import platform_info

from .conftest import load
from .test_resume import _outcome

#: SAC with 3-step returns and 2 gradient steps per vector step on the batched backend:
#: 250 updates of batch 32 on [32, 32] networks, the waypoint tuning's shape, cut small
SMALL = [
    "env=quadx_waypoints",
    "algo=sac",
    "env.backend=batched",
    "train.n_envs=4",
    "train.total_timesteps=600",
    "train.curriculum.goal_reach_distance.steps=600",
    "algo.n_steps=3",
    "algo.gradient_steps=2",
    "algo.buffer_size=2000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=300",
    "train.eval_episodes=1",
    "train.checkpoint_freq=300",
    "train.progress_bar=false",
]

#: ``digest`` of SMALL's outcome by the CPU it was computed on (``platform_info()["cpu"]``
#: starting with the key): on the 2-core AMD EPYC VM at commit c018a56 (``algo=sac`` was SB3's
#: own SAC class); on a 2-core Intel Xeon VM with AVX-512 (2026-12-03, the same digest at
#: 6fdbee8 and after). The same pinned platform gives the two CPUs different training numbers
#: here, so they are recorded apart (docs/reproducibility.md, "What is exact, where"); on a CPU
#: not listed the test fails and prints the digest to record
RECORDED_BY_CPU = {"AMD EPYC": "f4b6de27bcce2a5e", "Intel(R) Xeon(R)": "6d88f8c77be90005"}
#: the numeric platform (``platform_info()["key"]``) and the SB3 version they were computed with
RECORDED_PLATFORM = {
    "libc": "glibc 2.36",
    "machine": "x86_64",
    "numerics": "pinned",
    "versions": {"numpy": "2.4.6", "pybullet": "3.2.7", "scipy": "1.17.1", "torch": "2.13.0+cpu"},
}
RECORDED_SB3 = "2.9.2"


def digest(outcome: dict) -> str:
    """SHA-256 (16 hex digits) of a run's final weights, evaluations, training episodes and end step."""
    h = hashlib.sha256()
    for key in sorted(outcome["policy"]):
        h.update(key.encode())
        h.update(outcome["policy"][key].numpy().tobytes())
    h.update(repr((outcome["step"], outcome["evals"], outcome["episodes"])).encode())
    return h.hexdigest()[:16]


def test_the_registered_sac_is_the_projects_and_still_answers_to_sb3s_import_path():
    assert registry.resolve(registry.ALGOS, "sac", "algorithm") is SAC and issubclass(SAC, SB3SAC)
    assert registry.TARGETS["stable_baselines3.SAC"] == ("algo", "sac")
    assert registry.TARGETS["stable_baselines3.sac.SAC"] == ("algo", "sac")


def test_a_run_gives_the_numbers_recorded_before_the_faster_updates(tmp_path):
    outcome = _outcome(train(load(SMALL, tmp_path)).run_dir)
    import stable_baselines3

    # the test extra pins these versions (pyproject.toml), so the test command runs on this platform
    key = platform_info()["key"]
    # the recorded libraries' versions (a process that also loaded JAX reports its versions too)
    versions = {name: key["versions"].get(name) for name in RECORDED_PLATFORM["versions"]}
    platform = {**key, "versions": versions, "stable-baselines3": stable_baselines3.__version__}
    assert platform == {**RECORDED_PLATFORM, "stable-baselines3": RECORDED_SB3}, (
        "the recording was made on another numeric platform; install the versions the test extra pins "
        f"(pip install -e '.[test]'): recorded {json.dumps(RECORDED_PLATFORM, sort_keys=True)}, SB3 {RECORDED_SB3}"
    )
    cpu = platform_info()["cpu"]
    recorded = [d for model, d in RECORDED_BY_CPU.items() if cpu.startswith(model)]
    assert recorded, f"no digest is recorded for this CPU ({cpu}): this run's is {digest(outcome)}"
    assert digest(outcome) == recorded[0], cpu


def test_a_run_gives_the_numbers_of_sb3s_sac(tmp_path, monkeypatch):
    ours = _outcome(train(load(SMALL, tmp_path / "ours")).run_dir)
    monkeypatch.setitem(registry.ALGOS, "sac", "stable_baselines3:SAC")
    theirs = _outcome(train(load(SMALL, tmp_path / "sb3")).run_dir)
    assert len(ours["episodes"]) > 0 and len(ours["evals"]) == 2
    assert digest(ours) == digest(theirs)


def _updated(cls: type, n_steps: int) -> dict:
    """Every number a model of ``cls`` holds and logs after 60 gradient steps from a seeded buffer."""
    from pyflyt_cli.training.envs import make_vec_env
    from pyflyt_cli.training.models import build_model

    cfg = compose_config(overrides=[*SMALL, f"algo.n_steps={n_steps}"])
    vec = make_vec_env(cfg.env, cfg.train.n_envs, "dummy")
    try:
        kwargs = cfg.algo.constructor_kwargs()
        model = cls("MlpPolicy", vec, seed=cfg.seed, **kwargs)
        model.set_logger(build_model(cfg, vec).logger)
        model.learning_starts = 10**9
        model.learn(400)  # fills the buffer; no update yet
    finally:
        vec.close()
    assert isinstance(model.replay_buffer, NStepReplayBuffer) == (n_steps > 1)
    logged = {}
    model.logger.record = lambda key, value, exclude=None: logged.__setitem__(key, value)  # noqa: ARG005
    for _ in range(3):
        model.train(gradient_steps=20, batch_size=32)
    tensors = dict(model.policy.state_dict())
    tensors["log_ent_coef"] = model.log_ent_coef.detach()
    for name, optimizer in (("actor", model.actor.optimizer), ("critic", model.critic.optimizer),
                            ("ent_coef", model.ent_coef_optimizer)):  # fmt: skip
        for i, state in optimizer.state_dict()["state"].items():
            tensors.update({f"{name}.{i}.{k}": v for k, v in state.items()})
    return {"tensors": tensors, "logged": logged, "rng": np.random.get_state()[1].tobytes(),
            "torch_rng": torch.get_rng_state()}  # fmt: skip


@pytest.mark.parametrize("n_steps", [1, 3])
def test_each_update_computes_what_sb3s_does(n_steps):
    ours, theirs = _updated(SAC, n_steps), _updated(SB3SAC, n_steps)
    assert ours["tensors"].keys() == theirs["tensors"].keys()
    for key, value in theirs["tensors"].items():
        assert torch.equal(ours["tensors"][key], value), key
    assert set(theirs["logged"]) >= {"train/actor_loss", "train/critic_loss", "train/ent_coef", "train/ent_coef_loss"}
    assert ours["logged"] == theirs["logged"]  # the same floats, bit for bit
    assert ours["rng"] == theirs["rng"] and torch.equal(ours["torch_rng"], theirs["torch_rng"])
