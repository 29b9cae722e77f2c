"""The benchmark plan: what an experiment's grid expands to, and every way to get it wrong.

Hydra composition only (no training): fast.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pyflyt_cli.benchmark.plan import build_plan, levels, read_plan, split_overrides
from pyflyt_cli.benchmark.run import CHANGED, COMPLETE, NEW, PARTIAL, run_state
from pyflyt_cli.benchmark.worker import run_differences
from pyflyt_cli.errors import UsageError

P = "benchmark.presets.laptop"


def test_smoke_grid_expands_to_envs_x_algos_x_seeds(tmp_path: Path) -> None:
    plan, hydra = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=3"])
    assert hydra == []
    assert plan.root == (tmp_path / "smoke_benchmark").resolve()
    assert [j.id for j in plan.jobs] == [
        f"{env}/ppo/seed{k}" for env in ("quadx_hover", "quadx_waypoints") for k in range(3)
    ]
    job = plan.jobs[4]
    assert job.config["seed"] == 1 and job.config["env_name"] == "quadx_waypoints"
    assert job.config["env"]["id"] == "PyFlyt/QuadX-Waypoints-v0"
    assert job.config["train"]["output_dir"] == str(plan.root / "runs")
    assert job.config["train"]["total_timesteps"] == 256  # from the experiment file
    assert plan.run_dir(job) == plan.root / "runs" / "quadx_waypoints" / "ppo" / "seed1"
    assert plan.log_file(job).name == "quadx_waypoints__ppo__seed1.log"


def test_overrides_reach_every_run_and_seed_lists(tmp_path: Path) -> None:
    plan, _ = build_plan(
        "smoke_benchmark",
        [f"benchmark.output_dir={tmp_path}", "benchmark.seeds=[4,9]", "jobs=3", "train.total_timesteps=512"],
    )
    assert sorted({j.seed for j in plan.jobs}) == [4, 9]
    assert plan.spec["jobs"] == 3
    assert {j.total_timesteps for j in plan.jobs} == {512}


@pytest.mark.long
def test_paper_rl_bootstraps_sparse_awac_and_ccge_from_partial_sac(tmp_path: Path) -> None:
    plan, _ = build_plan("paper_rl", [f"benchmark.output_dir={tmp_path}"])
    assert plan.root.name == "paper_rl_laptop"
    assert len(plan.jobs) == 18
    first, second = levels(plan.jobs)
    assert {j.algo for j in first} == {"sac"} and {j.algo for j in second} == {"awac", "ccge"}
    ccge = plan.job("fixedwing_waypoints_sparse/ccge/seed1")
    assert ccge.depends_on == "fixedwing_waypoints/sac/seed1"
    assert ccge.config["env"]["reward"] == "sparse"
    # CCGE keeps its own warm-up; AWAC's is the preset's
    assert ccge.config["algo"]["learning_starts"] == 1000
    assert plan.job("quadx_waypoints_sparse/awac/seed0").total_timesteps == ccge.total_timesteps == 100000
    awac = plan.job("quadx_waypoints_sparse/awac/seed2")
    assert awac.depends_on == "quadx_waypoints/sac/seed2"
    step = plan.spec["presets"]["laptop"]["partial_step"]
    # the source run's first checkpoint at or after that step, resolved when the run starts
    assert awac.config["init_from"] == f"{plan.root}/runs/quadx_waypoints/sac/seed2@{step}"
    assert awac.config["env"]["reward"] == "sparse"
    assert plan.job("quadx_waypoints/sac/seed2").config["env"]["reward"] == "dense"
    sac = plan.job("quadx_waypoints/sac/seed2")
    # the policy shapes agree, so the weights load
    assert awac.config["algo"]["policy_kwargs"]["net_arch"] == sac.config["algo"]["policy_kwargs"]["net_arch"]
    assert awac.config["algo"]["use_sde"] == sac.config["algo"]["use_sde"]
    # the preset's training shape for all three: 64 batched envs, 4 gradient steps per vector step; SAC with
    # 3-step returns (the QuadX-Waypoints tuning's), AWAC and CCGE one-step as published
    for job in (sac, awac, ccge, plan.job("fixedwing_waypoints/sac/seed0")):
        shape = (job.config["env"]["backend"], job.config["train"]["n_envs"], job.config["algo"]["gradient_steps"])
        assert shape == ("batched", 64, 4), job.id
    assert (sac.config["algo"]["n_steps"], awac.config["algo"]["n_steps"], ccge.config["algo"]["n_steps"]) == (3, 1, 1)
    # from the same sphere, each cut to its run's budget (a curriculum may not outlast it)
    sphere, awac_sphere = (
        sac.config["train"]["curriculum"]["goal_reach_distance"],
        awac.config["train"]["curriculum"]["goal_reach_distance"],
    )
    assert sphere["start"] == awac_sphere["start"] == 1.0
    assert sphere["steps"] == plan.spec["presets"]["laptop"]["dense_curriculum"] <= sac.total_timesteps
    assert awac_sphere["steps"] == plan.spec["presets"]["laptop"]["sparse_curriculum"] <= awac.total_timesteps
    assert ccge.config["train"]["curriculum"]["goal_reach_distance"]["start"] == 10.0
    big, _ = build_plan("paper_rl", [f"benchmark.output_dir={tmp_path}", "benchmark.preset=paper"])
    assert big.root.name == "paper_rl_paper" and len(big.jobs) == 300
    assert big.job("quadx_waypoints_sparse/ccge/seed7").config["init_from"].endswith("quadx_waypoints/sac/seed7@200000")
    assert big.job("fixedwing_waypoints/sac/seed49").total_timesteps == 1_000_000
    assert big.job("fixedwing_waypoints_sparse/awac/seed3").config["env"]["backend"] == "batched"
    assert big.job("fixedwing_waypoints_sparse/awac/seed3").config["train"]["n_envs"] == 64


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (["seed=3"], "seeds come from the benchmark"),
        (["env=quadx_hover"], "envs come from the benchmark"),
        (["resume=x"], "resumes its interrupted runs by itself"),
        (["seeds=0"], "seeds must be at least 1"),
        (["benchmark.jobs=0"], "benchmark.jobs"),
        (["benchmark.groups.0.algos=[ppo,nope]"], "unknown algo 'nope'"),
        (["benchmark.colour=red"], "benchmark.colour"),
        (["train.total_timestep=5"], "Did you mean 'train.total_timesteps'"),
        (["run_dir=/tmp/x"], "runs go to <benchmark>/runs/<task>/<algo>/seed<k>"),
        (["env_name=x"], "filed under their group's task"),
        (["train.output_dir=x"], "choose benchmark.output_dir"),
        (["init_from=/tmp/x"], "benchmark.groups[i].init_from"),
        (["benchmark.groups.0.overrides=['seed=3']"], "benchmark.groups[0].overrides: 'seed=3' cannot be given"),
    ],
)
def test_bad_benchmark_overrides_name_the_problem(tmp_path: Path, overrides: list[str], message: str) -> None:
    with pytest.raises(UsageError, match=None) as err:
        build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", *overrides])
    assert message in str(err.value)


def test_experiment_without_benchmark_section_is_refused() -> None:
    with pytest.raises(UsageError, match="declares no benchmark"):
        build_plan("hover_ppo", [])


def test_train_refuses_a_benchmark_experiment() -> None:
    from pyflyt_cli.training.compose import compose_config

    with pytest.raises(UsageError, match="pyflyt benchmark experiment=smoke_benchmark"):
        compose_config(overrides=["experiment=smoke_benchmark"])


@pytest.mark.long
def test_init_from_checkpoint_must_exist_in_the_source_run(tmp_path: Path) -> None:
    base = [f"benchmark.output_dir={tmp_path}"]
    with pytest.raises(UsageError, match="multiple of train.checkpoint_freq"):
        build_plan("paper_rl", [*base, f"{P}.partial_step=1234"])
    with pytest.raises(UsageError, match="keep_checkpoints"):
        build_plan("paper_rl", [*base, "train.keep_checkpoints=2"])
    with pytest.raises(UsageError, match="cannot start from"):
        build_plan("paper_rl", [*base, "benchmark.groups.1.init_from.algo=ppo"])
    with pytest.raises(UsageError, match="does not declare"):
        build_plan("paper_rl", [*base, "benchmark.groups.1.init_from.task=elsewhere"])


def test_split_overrides() -> None:
    bench, hydra, runs = split_overrides(
        [
            "seeds=5",
            "jobs=2",
            "benchmark.name=x",
            "hydra/launcher=ray",
            "+hydra.launcher.ray.init.num_cpus=2",
            "algo.gamma=0.9",
        ]
    )
    assert bench == ["++benchmark.seeds=5", "++benchmark.jobs=2", "++benchmark.name=x"]
    assert hydra == ["hydra/launcher=ray", "+hydra.launcher.ray.init.num_cpus=2"]
    assert runs == ["algo.gamma=0.9"]


def test_unknown_or_missing_launcher_plugin_is_named() -> None:
    from pyflyt_cli.benchmark.launchers import launcher_name

    assert launcher_name([]) is None
    with pytest.raises(UsageError, match="unknown launcher hydra/launcher=rai"):
        launcher_name(["hydra/launcher=rai"])
    with pytest.raises(UsageError, match="choose one with hydra/launcher="):
        launcher_name(["hydra.launcher.partition=gpu"])


def _save_run(plan, job, **changes) -> Path:
    """``job``'s run directory holding its planned config.yaml with ``changes`` (``"algo.gamma": 0.9``)."""
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.schema import parse_train_config

    data = json.loads(json.dumps(job.config))
    for path, value in changes.items():
        *parents, leaf = path.split(".")
        node = data
        for key in parents:
            node = node[key]
        node[leaf] = value
    run = plan.run_dir(job)
    run.mkdir(parents=True, exist_ok=True)
    rundir.save_config(parse_train_config(data), run)
    return run


def test_plan_round_trip_and_run_states(tmp_path: Path) -> None:
    plan, _ = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=1"])
    plan.write()
    again = read_plan(plan.root)
    assert [j.id for j in again.jobs] == [j.id for j in plan.jobs]
    assert again.jobs[0].config == plan.jobs[0].config
    job = plan.jobs[0]
    assert run_state(plan, job) == NEW
    run = _save_run(plan, job)
    (run / "state.json").write_text(json.dumps({"status": "interrupted", "total_timesteps": 256}))
    assert run_state(plan, job) == PARTIAL
    (run / "state.json").write_text(json.dumps({"status": "complete", "total_timesteps": 256}))
    assert run_state(plan, job) == COMPLETE
    # a larger budget in the plan makes a complete run partial again (it is extended)
    bigger, _ = build_plan(
        "smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=1", "train.total_timesteps=512"]
    )
    assert run_state(bigger, bigger.jobs[0]) == PARTIAL
    # other settings: never reused, complete or not
    other, _ = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=1", "algo.gamma=0.9"])
    assert run_state(other, other.jobs[0]) == CHANGED
    (run / "config.yaml").write_text("{}")
    assert run_state(plan, job) == CHANGED


def test_truncated_plan_file_is_reported(tmp_path: Path) -> None:
    from pyflyt_engine.errors import ConfigError

    (tmp_path / "plan.json").write_text('{"experiment": "x", "jobs": [')
    with pytest.raises(ConfigError, match="not a readable benchmark plan"):
        read_plan(tmp_path)


def test_run_differences_name_each_setting_saved_and_planned(tmp_path: Path) -> None:
    plan, _ = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=1"])
    job = plan.jobs[0]
    assert run_differences(plan, job) == []  # no run directory yet
    _save_run(plan, job, **{"train.output_dir": "elsewhere", "train.progress_bar": True})
    assert run_differences(plan, job) == []  # where it was written and how it reported are not settings
    _save_run(plan, job, **{"train.total_timesteps": 128})
    assert run_differences(plan, job) == []  # the plan's budget grew: an extension
    _save_run(plan, job, **{"train.total_timesteps": 512, "algo.gamma": 0.9, "algo.policy_kwargs.net_arch": [8]})
    assert [str(d) for d in run_differences(plan, job)] == [
        "algo.gamma: 0.9 -> 0.95",
        "algo.policy_kwargs.net_arch: [8] -> [64, 64]",
        "train.total_timesteps: 512 -> 256",
    ]


def test_a_planned_checkpoint_names_the_first_one_at_or_after_it(tmp_path: Path) -> None:
    from pyflyt_cli.benchmark.worker import planned_config
    from pyflyt_cli.training import rundir
    from pyflyt_engine.errors import ConfigError

    plan, _ = build_plan("paper_rl", [f"benchmark.output_dir={tmp_path}", "seeds=1"])
    job = plan.job("quadx_waypoints_sparse/awac/seed0")
    step = plan.spec["presets"]["laptop"]["partial_step"]
    source = plan.run_dir(plan.job("quadx_waypoints/sac/seed0"))
    assert planned_config(plan, job).init_from == f"{source}@{step}"  # kept as planned, in config.yaml too
    (source / rundir.CHECKPOINTS).mkdir(parents=True)
    with pytest.raises(ConfigError, match=f"has no checkpoint at or after step {step} \\(its checkpoints: none yet\\)"):
        rundir.checkpoint_at_or_after(source, step)
    for s in (step - 2496, step + 4, step + 2504):  # SAC with train_freq 8 checkpoints at rollout ends
        rundir.checkpoint_paths(source, s).model.write_bytes(b"")
    assert rundir.checkpoint_at_or_after(source, step).step == step + 4
    rundir.checkpoint_paths(source, step).model.write_bytes(b"")
    assert rundir.checkpoint_at_or_after(source, step).step == step
    assert planned_config(plan, plan.job("quadx_waypoints/sac/seed0")).init_from is None


def test_an_experiment_file_outside_conf_is_accepted_by_path(tmp_path: Path) -> None:
    from pyflyt_engine.paths import conf_dir

    study = tmp_path / "experiments" / "my_sweep.yaml"
    study.parent.mkdir()
    text = (conf_dir() / "experiment" / "smoke_benchmark.yaml").read_text().replace("seeds: 3", "seeds: 2")
    study.write_text(text)
    plan, _ = build_plan(str(study), [f"benchmark.output_dir={tmp_path}"])
    assert plan.root.name == "my_sweep" and len(plan.jobs) == 4
    with pytest.raises(UsageError, match="does not exist"):
        build_plan(str(tmp_path / "nope.yaml"), [])
    shadow = tmp_path / "paper_rl.yaml"
    shadow.write_text(text)
    with pytest.raises(UsageError, match="is a shipped experiment's; rename the file"):
        build_plan(str(shadow), [])


@pytest.mark.parametrize(
    "override",
    [
        "+hydra.callbacks.x._target_=builtins.open",
        "hydra/job_logging=disabled",
        "hydra/hydra_logging=disabled",
        "hydra.searchpath=[file:///tmp]",
        "hydra.launcher._target_=os.system",
        "+hydra.launcher.ray._args_=[x]",
        "+hydra.launcher.setup={_target_: os.system}",
        "+hydra.launcher.setup=[{_partial_: true}]",
        "hydra.launcher.partition=${oc.env:HOME}",
        "~hydra.launcher.partition",
        "hydra.launcher.partition=a,b",
    ],
)
def test_only_the_launcher_and_its_plain_settings_reach_hydra(tmp_path: Path, override: str) -> None:
    with pytest.raises(UsageError, match="The only Hydra settings accepted are the launcher, hydra/launcher="):
        build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "hydra/launcher=basic", override])
    assert not any(tmp_path.iterdir())


def test_launcher_settings_are_passed_on(tmp_path: Path) -> None:
    ok = ["hydra/launcher=basic", "+hydra.launcher.ray.init.num_cpus=2", "hydra.launcher.setup=[a,b]"]
    _, hydra = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", *ok])
    assert hydra == ok


def dry_run_lines(stdout: str) -> dict[str, list[str]]:
    """``pyflyt benchmark --dry-run``'s script: run id -> the arguments of its ``pyflyt train`` line."""
    import shlex

    lines, run = {}, None
    for line in stdout.splitlines():
        if line.startswith("# "):
            run = line.split()[-1]
        elif line.startswith("pyflyt train "):
            lines[run] = shlex.split(line)[2:]
    return lines


@pytest.mark.long
def test_every_dry_run_line_composes_the_planned_run(tmp_path: Path) -> None:
    """Each printed `pyflyt train` line, composed as pyflyt train composes it, is its run: same digest, same directory."""
    from tests.train.conftest import pyflyt

    out = tmp_path / "a dir, with 'quotes'"  # the lines must quote what the shell and Hydra would split
    quoted = str(out).replace("'", "\\'")
    # a shorter budget for every run, and the dense runs' curriculum cut to it
    args = [
        f"benchmark.output_dir='{quoted}'",
        "seeds=2",
        "train.total_timesteps=160000",
        "benchmark.presets.laptop.dense_curriculum=160000",
    ]
    result = pyflyt(["benchmark", "experiment=paper_rl", *args, "--dry-run"], tmp_path)
    assert result.returncode == 0, result.stderr
    plan, _ = build_plan("paper_rl", args)
    lines = dry_run_lines(result.stdout)
    assert sorted(lines) == sorted(j.id for j in plan.jobs)
    assert list(lines).index("quadx_waypoints/sac/seed1") < list(lines).index("quadx_waypoints_sparse/awac/seed1")
    from pyflyt_cli.training.compose import compose_run
    from pyflyt_cli.training.rundir import config_digest

    for job in plan.jobs:
        cfg, run_dir = compose_run(lines[job.id])
        assert run_dir == plan.run_dir(job)
        assert cfg.env_name == job.task and cfg.seed == job.seed
        assert config_digest(cfg) == config_digest(job.config), job.id
    assert not out.exists()


def test_a_benchmark_directory_that_cannot_be_made_is_a_user_error(tmp_path: Path) -> None:
    import re

    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    (tmp_path / "a file").write_text("")
    result = CliRunner().invoke(
        app, ["benchmark", "experiment=smoke_benchmark", f"benchmark.output_dir='{tmp_path / 'a file'}'"]
    )
    assert result.exit_code == 2 and result.output.startswith("error:"), result.output
    assert re.search(
        "cannot use .* as the benchmark directory .* choose another benchmark.output_dir",
        result.output.replace("\n", " "),
    ), result.output


@pytest.mark.long
def test_a_setting_that_interpolates_the_seed_is_composed_per_run(tmp_path: Path) -> None:
    from pyflyt_engine.paths import conf_dir

    study = tmp_path / "seeded_study.yaml"
    text = (conf_dir() / "experiment" / "smoke_benchmark.yaml").read_text()
    study.write_text(text.replace("  eval_episodes: 1\n", "  eval_episodes: ${oc.select:seed}\n"))
    plan, _ = build_plan(str(study), [f"benchmark.output_dir={tmp_path}", "benchmark.seeds=[1,2,3]"])
    assert [j.config["train"]["eval_episodes"] for j in plan.jobs] == [1, 2, 3, 1, 2, 3]


def test_runs_made_under_another_numeric_platform_are_named_in_one_line(tmp_path: Path) -> None:
    from pyflyt_cli.benchmark.sweep import platform_note, survey
    from pyflyt_cli.training import rundir

    plan, _ = build_plan("smoke_benchmark", [f"benchmark.output_dir={tmp_path}", "seeds=2"])
    here = rundir.numeric_platform()
    made = [  # what each run's run.yaml says it was made under
        here,
        {**here, "cpu": "Intel(R) Xeon(R) Platinum 8375C"},  # another CPU, the same pinned kernels
        {**here, "key": {**here["key"], "numerics": "native", "cpu": "Intel(R) Xeon(R)"}},
    ]
    for job, numerics in zip(plan.jobs, made):
        run = _save_run(plan, job)
        (run / "state.json").write_text(json.dumps({"status": "complete", "total_timesteps": 256}))
        rundir.write_yaml(run / rundir.RUN_FILE, {"numerics": numerics})
    note = platform_note(plan, survey(plan))
    assert note is not None and len(note.splitlines()) == 1
    assert f"1 of the runs here ({plan.jobs[1].id}) were made on another CPU (Intel(R) Xeon(R) Platinum 8375C" in note
    assert "the same pinned kernels: the numbers agree" in note
    assert (
        f"1 of the runs here ({plan.jobs[2].id}) were made under another numeric platform (cpu Intel(R) Xeon(R) -> -;"
        in note
    )
    assert plan.jobs[0].id not in note
    for job in plan.jobs[1:3]:  # all made here: nothing to say
        rundir.write_yaml(plan.run_dir(job) / rundir.RUN_FILE, {"numerics": here})
    assert platform_note(plan, survey(plan)) is None


@pytest.mark.parametrize(
    ("algo", "settings", "expected"),
    [
        # SB3 starts an off-policy collection every train_freq steps per env (8 x 2 envs = 16 steps):
        # the evaluations due at 30, 60, 90 run at the round starts 32, 64, 96; the run ends at 7 rounds
        # (112 >= 100).  algo.n_steps (1) is the n-step return there, not the round.
        ("sac", ["algo.train_freq=8", "algo.n_steps=1"], [32, 64, 96, 112]),
        # on-policy, a round is a rollout of n_steps per env (16 x 2 = 32 steps)
        ("ppo", ["algo.n_steps=16", "algo.batch_size=32"], [32, 64, 96, 128]),
    ],
)
def test_evaluation_steps_fall_on_collection_rounds(algo: str, settings: list[str], expected: list[int]) -> None:
    from pyflyt_cli.benchmark.plan import evaluation_steps
    from pyflyt_cli.training.compose import compose_train_data

    data, _ = compose_train_data(
        [
            f"algo={algo}",
            "env=quadx_hover",
            *settings,
            "train.n_envs=2",
            "train.total_timesteps=100",
            "train.eval_freq=30",
        ]
    )
    assert evaluation_steps(data) == expected
