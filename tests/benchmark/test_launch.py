"""A benchmark through a Hydra launcher (Hydra's public API), with the training stubbed out.

Hydra composition and the basic launcher only: every run becomes one Hydra job whose
``job`` is its index in the plan, in dependency waves, and each job's return value is the
run's exit code.  The real launchers (a Ray cluster, submitit) train real runs in
tests/distributed/test_launchers.py (``pytest -m distributed``, run by CI).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pyflyt_cli.benchmark import launch
from pyflyt_cli.benchmark.launchers import plugin_overrides
from pyflyt_cli.benchmark.plan import build_plan


def test_the_basic_launcher_runs_one_hydra_job_per_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    plan, hydra = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=1", "hydra/launcher=basic"])
    assert hydra == ["hydra/launcher=basic"]
    plan.root.mkdir(parents=True)
    plan.write()
    ran: list[tuple[str, str]] = []

    def run_job(root: Path, job_id: str) -> int:
        ran.append((str(root), job_id))
        return 3  # a failed run: outcome_of names it without a run directory

    monkeypatch.setattr("pyflyt_cli.benchmark.run.run_job", run_job)
    lines: list[str] = []
    outcomes = launch.run_hydra(plan, plan.jobs, hydra, lines.append)
    assert sorted(ran) == sorted((str(plan.root), job.id) for job in plan.jobs)
    assert [o.job.id for o in outcomes] == [j.id for j in plan.jobs]
    assert all(o.status == "failed" and o.code == 3 for o in outcomes), outcomes
    assert lines[0] == "launching 2 run(s) with hydra/launcher=basic"
    assert (plan.root / "logs" / "hydra").is_dir()  # Hydra's sweep directory, as conf/benchmark_launch.yaml sets it


def test_the_ray_launcher_gets_no_object_store_size_unless_the_user_gives_one() -> None:
    # hydra-ray-launcher would pass its own 75 MB, which Ray refuses when it joins a running cluster
    ray = ["hydra/launcher=ray", "hydra.launcher.ray.init.address=10.0.0.1:6379"]
    assert plugin_overrides(ray) == ["+hydra.launcher.ray.init.object_store_memory=null"]
    given = [*ray, "+hydra.launcher.ray.init.object_store_memory=1000000000"]
    assert plugin_overrides(given) == []
    assert plugin_overrides(["hydra/launcher=submitit_local"]) == []
    assert plugin_overrides(["hydra/launcher=basic"]) == []
