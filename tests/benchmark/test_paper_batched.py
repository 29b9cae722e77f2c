"""experiment=paper_rl on the batched backend: every group's runs train batched, and AWAC and CCGE
start from the batched SAC run's checkpoint exactly as planned (its weights; CCGE's oracle is its actor).

The QuadX-Waypoints column of the laptop preset at a tiny budget, trained through the benchmark's
own worker (the plan's configurations, the source run's checkpoint resolved when a run starts).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

P = "benchmark.presets.laptop"
#: the laptop preset shrunk to a few seconds: SAC 640 steps (updates from 320, a checkpoint at 320),
#: AWAC and CCGE 192 steps from that checkpoint; one evaluation episode each
TINY = [
    "seeds=1",
    f"{P}.dense_steps=640", f"{P}.partial_step=320", f"{P}.checkpoint_freq=320", f"{P}.sparse_steps=192",
    f"{P}.sac_learning_starts=320", f"{P}.awac_learning_starts=64", f"{P}.awac_batch_size=64",
    f"{P}.eval_freq=320", f"{P}.eval_episodes=1", f"{P}.dense_curriculum=640", f"{P}.sparse_curriculum=192",
    "benchmark.groups.0.envs=[quadx_waypoints]", "benchmark.groups.1.envs=[quadx_waypoints]",
    "benchmark.groups.2.envs=[quadx_waypoints]", "algo.batch_size=64", "train.progress_bar=false",
]  # fmt: skip


@pytest.fixture(autouse=True)
def _one_thread():
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


def test_each_group_trains_batched_and_the_sparse_runs_start_from_the_batched_sac_checkpoint(tmp_path: Path) -> None:
    from pyflyt_cli.benchmark.plan import build_plan, levels
    from pyflyt_cli.benchmark.worker import bring_to_completion
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.models import read_policy

    plan, _ = build_plan("paper_rl", [f"benchmark.output_dir={tmp_path}", *TINY])
    plan.write()
    assert [j.id for j in plan.jobs] == [
        "quadx_waypoints/sac/seed0", "quadx_waypoints_sparse/awac/seed0", "quadx_waypoints_sparse/ccge/seed0",
    ]  # fmt: skip
    for job in plan.jobs:  # the preset's training shape, as planned
        c = job.config
        assert (c["env"]["backend"], c["train"]["n_envs"], c["algo"]["gradient_steps"]) == ("batched", 64, 4), job.id
        assert c["algo"]["n_steps"] == (3 if job.algo == "sac" else 1), job.id
    for wave in levels(plan.jobs):
        for job in wave:
            assert bring_to_completion(plan, job) == 0, job.id
    sac_dir = plan.run_dir(plan.job("quadx_waypoints/sac/seed0"))
    partial = read_policy(rundir.checkpoint_at_or_after(sac_dir, 320).model)
    assert partial.step == 320
    for algo in ("awac", "ccge"):
        run = plan.run_dir(plan.job(f"quadx_waypoints_sparse/{algo}/seed0"))
        saved = rundir.load_run_config(run)
        assert saved.env.backend == "batched" and saved.env.reward == "sparse"
        record = rundir.read_yaml(run / rundir.RUN_FILE)["init_from"]
        assert record["algo"] == "sac" and Path(record["model"]).name == "model_320_steps.pt"
        kept = read_policy(run / rundir.INIT_POLICY)  # the copy a restart starts from: SAC's weights, bit for bit
        assert kept.policy.keys() == partial.policy.keys()
        assert all(torch.equal(kept.policy[k], v) for k, v in partial.policy.items())
        if algo == "ccge":  # the oracle stays the SAC actor, frozen, to the end
            final = read_policy(run / rundir.FINAL_MODEL).policy
            for key, value in partial.policy.items():
                if key.startswith("actor."):
                    assert torch.equal(final["oracle." + key[len("actor.") :]], value), key
