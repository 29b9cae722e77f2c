"""``train.curriculum``: training episodes start with other task option values, moved to the configured ones.

Oracles: the schedule evaluated by hand; a reach distance wider than the flight dome
(every waypoint reached in the first steps, one per step) in the training episodes of
the first stages, the configured 0.2 m in the evaluations; and a run stopped and
resumed mid-schedule ends bit-identical to the uninterrupted one.
"""

from __future__ import annotations

import json

import pytest

from pyflyt_cli.training import resume, train
from pyflyt_cli.training.callbacks import TaskCurriculum
from pyflyt_cli.training.schema import CurriculumOption
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import read_metrics

from .conftest import load
from .test_resume import SignalAt, _assert_same, _outcome, _reference

SAC_WAYPOINTS = [
    "env=quadx_waypoints",
    "algo=sac",
    # the PyBullet path, 4 envs, one update per vector step (the tuning trains 64 batched envs)
    "env.backend=pybullet",
    "train.n_envs=4",
    "algo.gradient_steps=1",
    "algo.n_steps=1",
    "train.total_timesteps=600",
    "algo.buffer_size=2000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=200",
    "train.eval_episodes=1",
    "train.checkpoint_freq=100",
    "train.progress_bar=false",
    # wider than the dome's diameter until step 300, then shrinking to 0.2 m at 600
    "train.curriculum={goal_reach_distance:{start:40.0,steps:600}}",
]


def test_the_schedule_moves_linearly_in_100_stages_to_the_configured_value():
    c = TaskCurriculum({"goal_reach_distance": CurriculumOption(start=1.0, steps=1000)}, {"goal_reach_distance": 0.2})
    assert c.changes_at(0) == {"goal_reach_distance": 1.0}
    assert c.changes_at(9) == {"goal_reach_distance": 1.0}  # stage 0 until step 10
    assert c.changes_at(10) == {"goal_reach_distance": pytest.approx(1.0 - 0.8 / 100)}
    assert c.changes_at(500) == {"goal_reach_distance": pytest.approx(0.6)}
    assert c.changes_at(999) == {"goal_reach_distance": pytest.approx(0.2 + 0.8 / 100)}
    assert c.changes_at(1000) == {} and c.changes_at(10**9) == {}  # the configured task from then on
    assert len({c.stages(t) for t in range(0, 2000, 3)}) == 101


def test_training_episodes_fly_the_curriculum_and_evaluations_the_configured_task(tmp_path):
    result = train(load(SAC_WAYPOINTS, tmp_path))
    metrics = read_metrics(result.run_dir)
    moves = metrics["/train/curriculum"]
    assert moves[0]["step"] == 0 and moves[0]["goal_reach_distance"] == 40.0
    values = [m["goal_reach_distance"] for m in moves]
    assert values == sorted(values, reverse=True) and values[-1] == pytest.approx(0.2)
    assert len(moves) == 101  # one per stage, the last at the configured value
    episodes = metrics["/train/episode"]
    early = [e for e in episodes if e["step"] <= 150]  # reach distance >= 30 m: all 5 in 5 steps
    assert len(early) >= 10 and all(e["length"] == 5 and e["success"] for e in early)
    for e in metrics["/eval"]:  # the configured 0.2 m: no 5-step flights
        assert e["mean_length"] > 5


def test_a_run_with_a_curriculum_stopped_mid_schedule_resumes_bit_identical(tmp_path, tmp_path_factory):
    reference = _reference(SAC_WAYPOINTS, tmp_path_factory)
    first = train(load(SAC_WAYPOINTS, tmp_path), callbacks=[SignalAt(333)])
    assert first.interrupted
    state = json.loads((first.run_dir / "state.json").read_text())
    assert state["status"] == "interrupted"
    resume(first.run_dir)
    _assert_same(_outcome(first.run_dir), reference)


class _Envs:
    def __init__(self) -> None:
        self.told: list[dict] = []

    def env_method(self, name: str, changes: dict) -> None:
        assert name == "set_task_changes"
        self.told.append(dict(changes))


class _Model:
    def __init__(self, envs: _Envs) -> None:
        self.num_timesteps = 0
        self.envs = envs

    def get_env(self) -> _Envs:
        return self.envs


def _gated(gate: float, episodes: int, steps: int) -> tuple[TaskCurriculum, _Model, _Envs]:
    option = CurriculumOption(start=1.0, steps=steps, gate=gate, gate_episodes=episodes)
    c = TaskCurriculum({"goal_reach_distance": option}, {"goal_reach_distance": 0.2})
    envs = _Envs()
    model = _Model(envs)
    c.model = model  # what init_callback sets
    c.apply(envs, 0)
    return c, model, envs


def _vector_step(c: TaskCurriculum, model: _Model, n_envs: int, ended: list[bool]) -> None:
    """One vector step of ``n_envs`` envs in which episodes with these successes ended."""
    model.num_timesteps += n_envs
    infos = [{"episode": {"r": 0.0, "l": 1, "success": s}} for s in ended]
    c.locals = {"infos": infos + [{}] * (n_envs - len(ended))}
    c._on_step()


# (episodes ended in the vector step, the gated schedule's step after it): gate 0.5 over the
# last 4 episodes, 2 envs, so an open gate counts 2 steps
GATED_STEPS = [
    ([], 0),  # nothing finished: closed
    ([True, True], 0),  # 2 of the 4 episodes it looks at: closed
    ([True, True], 2),  # 4 of 4 succeeded: open
    ([False, False], 4),  # 2 of 4 (= 0.5): open
    ([False, False], 4),  # 0 of 4: paused
    ([], 4),
    ([True], 4),  # 1 of 4
    ([True, True], 6),  # 3 of 4: counting again
]


def test_a_gated_schedule_counts_steps_only_while_enough_recent_training_episodes_succeed():
    c, model, envs = _gated(0.5, 4, 100)  # 100 steps: one stage per step
    assert envs.told == [{"goal_reach_distance": 1.0}]
    for ended, counted in GATED_STEPS:
        _vector_step(c, model, 2, ended)
        assert c.progress == {"goal_reach_distance": counted}
        assert c.changes_at(model.num_timesteps) == {"goal_reach_distance": pytest.approx(1.0 - 0.8 * counted / 100)}
    # the envs are told at every stage change and only then
    assert [t["goal_reach_distance"] for t in envs.told] == pytest.approx([1.0, 0.984, 0.968, 0.952])
    assert not c.finished(model.num_timesteps)


def test_a_gated_schedule_continues_from_its_state_as_the_uninterrupted_one():
    whole, model, _ = _gated(0.5, 4, 100)
    for ended, _ in GATED_STEPS:
        _vector_step(whole, model, 2, ended)
    first, model, _ = _gated(0.5, 4, 100)
    for ended, _ in GATED_STEPS[:4]:
        _vector_step(first, model, 2, ended)
    saved = json.loads(json.dumps(first.state_dict()))  # as a checkpoint stores it
    assert saved == {"progress": {"goal_reach_distance": 4}, "outcomes": [1, 1, 0, 0]}
    resumed, fresh, envs = _gated(0.5, 4, 100)
    resumed.load_state_dict(saved)
    fresh.num_timesteps = model.num_timesteps
    resumed.apply(envs, fresh.num_timesteps)
    assert envs.told[-1] == {"goal_reach_distance": pytest.approx(0.968)}  # the checkpoint's stage, not step 0's
    for ended, _ in GATED_STEPS[4:]:
        _vector_step(resumed, fresh, 2, ended)
    assert resumed.state_dict() == whole.state_dict()


def test_a_schedule_without_a_gate_keeps_no_state():
    c = TaskCurriculum({"goal_reach_distance": CurriculumOption(start=1.0, steps=1000)}, {"goal_reach_distance": 0.2})
    assert c.state_dict() == {} and c.progress == {}


def test_a_gate_on_episodes_that_report_no_success_is_refused_with_the_fix():
    c, model, _ = _gated(0.5, 4, 100)
    model.num_timesteps += 1
    c.locals = {"infos": [{"episode": {"r": 0.0, "l": 1}}]}
    with pytest.raises(ConfigError, match="remove gate: to follow the step count"):
        c._on_step()


# the schedule of SAC_WAYPOINTS counted from the 10th finished training episode on: 4 envs whose
# episodes all take 5 steps (the 40 m sphere) end 12 episodes at step 60
GATED_WAYPOINTS = [
    *SAC_WAYPOINTS[:-1],
    "train.curriculum={goal_reach_distance:{start:40.0,steps:600,gate:0.5,gate_episodes:10}}",
]


def test_a_gated_curriculum_waits_for_the_training_episodes_success(tmp_path):
    logged: list[str] = []
    result = train(load(GATED_WAYPOINTS, tmp_path), log=logged.append)
    moves = read_metrics(result.run_dir)["/train/curriculum"]
    # ungated, stage 1 (6 of 600 steps) comes at step 8; gated, the count starts at step 60 (4
    # steps of it counted there), so stage 1 comes at step 64
    assert moves[0]["step"] == 0 and moves[0]["goal_reach_distance"] == 40.0
    assert moves[1]["step"] == 64 and moves[1]["goal_reach_distance"] == pytest.approx(40.0 - 39.8 / 100)
    ungated = read_metrics(train(load(SAC_WAYPOINTS, tmp_path / "ungated")).run_dir)["/train/curriculum"]
    assert ungated[1]["step"] == 8
    # 600 steps of schedule cannot be counted in a 600-step run that starts counting at step 56
    assert moves[-1]["goal_reach_distance"] > 0.2
    assert any("the gated schedule did not reach the configured task within the budget" in line for line in logged)


def test_a_run_with_a_gated_curriculum_stopped_mid_schedule_resumes_bit_identical(tmp_path):
    whole = train(load(GATED_WAYPOINTS, tmp_path / "whole")).run_dir
    first = train(load(GATED_WAYPOINTS, tmp_path / "stopped"), callbacks=[SignalAt(333)])
    assert first.interrupted
    at = json.loads((first.run_dir / "state.json").read_text())["checkpoint"]
    resume(first.run_dir)
    _assert_same(_outcome(first.run_dir), _outcome(whole))
    moves = [(m["step"], m["goal_reach_distance"]) for m in read_metrics(whole)["/train/curriculum"]]
    assert [m for m in moves if m[0] > at]  # the schedule was still moving when the run stopped
    resumed = [(m["step"], m["goal_reach_distance"]) for m in read_metrics(first.run_dir)["/train/curriculum"]]
    # the resume tells the envs the checkpoint's value (a record at its step), then moves as the whole run did
    assert [m for m in resumed if m[0] >= at][0] == (at, [m for m in moves if m[0] <= at][-1][1])
    assert [m for m in resumed if m[0] > at] == [m for m in moves if m[0] > at]


@pytest.mark.parametrize(
    ("curriculum", "names"),
    [
        ("{num_targets:{start:2,steps:10}}", ["num_targets", "goal_reach_distance"]),
        ("{goal_reach_distance:{start:-1,steps:10}}", ["start values", "greater than 0"]),
        ("{goal_reach_distance:{start:1}}", ["steps"]),
        ("{goal_reach_distance:{start:1,steps:0}}", ["steps"]),
        ("{goal_reach_distance:{start:1,steps:10,stop:3}}", ["stop"]),
        ("{goal_reach_distance:{start:1,steps:10,gate:0}}", ["gate", "greater than 0"]),
        ("{goal_reach_distance:{start:1,steps:10,gate:1.5}}", ["gate", "less than or equal to 1"]),
        ("{goal_reach_distance:{start:1,steps:10,gate:0.5,gate_episodes:0}}", ["gate_episodes"]),
        ("{goal_reach_distance:{start:1,steps:10,gate:0.5}}", ["gate needs gate_episodes", "set both"]),
        ("{goal_reach_distance:{start:1,steps:10,gate_episodes:10}}", ["gate_episodes needs gate"]),
    ],
)
def test_a_bad_curriculum_is_refused_naming_what_is_wrong(tmp_path, curriculum, names):
    with pytest.raises(ConfigError) as exc:
        load(["env=quadx_waypoints", "algo=sac", f"train.curriculum={curriculum}"], tmp_path)
    for name in names:
        assert name in str(exc.value)


def test_a_task_with_no_episode_options_takes_no_curriculum(tmp_path):
    with pytest.raises(ConfigError, match="options a curriculum may move: none"):
        load(["env=quadx_hover", "train.curriculum={start_position_noise:{start:0,steps:10}}"], tmp_path)


def test_a_vector_option_moves_element_by_element():
    c = TaskCurriculum(
        {"start_position": CurriculumOption(start=[0.0, 0.0, 50.0], steps=100)}, {"start_position": (0.0, 0.0, 450.0)}
    )
    assert c.changes_at(0) == {"start_position": [0.0, 0.0, 50.0]}
    assert c.changes_at(25) == {"start_position": [0.0, 0.0, pytest.approx(150.0)]}
    assert c.changes_at(100) == {}


def test_a_vector_start_of_the_wrong_length_is_refused(tmp_path):
    with pytest.raises(ConfigError, match=r"train\.curriculum\.start_position\.start\.2: Field required; fix: add it"):
        load(["env=rocket_landing", "train.curriculum={start_position:{start:[0,50],steps:10}}"], tmp_path)


@pytest.mark.long
def test_the_curriculum_reaches_envs_in_subprocesses(tmp_path):
    overrides = [
        "env=quadx_waypoints",
        "algo=ppo",
        "train.total_timesteps=2048",
        "train.n_envs=2",
        "train.vec_env=subproc",
        "algo.n_steps=512",
        "algo.batch_size=256",
        "train.eval_freq=0",
        "train.checkpoint_freq=0",
        "train.progress_bar=false",
        "train.curriculum={goal_reach_distance:{start:40.0,steps:1024}}",
    ]
    episodes = read_metrics(train(load(overrides, tmp_path)).run_dir)["/train/episode"]
    early = [e for e in episodes if e["step"] <= 256]  # reach distance >= 30 m in both workers
    assert len(early) >= 20 and all(e["length"] == 5 and e["success"] for e in early)
    assert any(e["length"] > 5 for e in episodes if e["step"] > 1536)  # 0.2 m from step 1024 on


def test_a_curriculum_on_the_command_line_replaces_the_tunings_and_a_field_changes_one(tmp_path):
    """conf/hparams/quadx_waypoints_sac.yaml sets goal_reach_distance 1 m over the first 1 M of its 2 M steps."""
    tuned = load(["env=quadx_waypoints", "algo=sac"], tmp_path).train.curriculum
    assert tuned["goal_reach_distance"].start == 1.0 and tuned["goal_reach_distance"].steps == 1000000
    whole = load(
        ["env=quadx_waypoints", "algo=sac", "train.curriculum={goal_reach_distance:{start:3.0,steps:100}}"], tmp_path
    )
    assert set(whole.train.curriculum) == {"goal_reach_distance"}
    assert (
        whole.train.curriculum["goal_reach_distance"].start,
        whole.train.curriculum["goal_reach_distance"].steps,
    ) == (3.0, 100)
    field = load(["env=quadx_waypoints", "algo=sac", "train.curriculum.goal_reach_distance.start=3.0"], tmp_path)
    assert (
        field.train.curriculum["goal_reach_distance"].start,
        field.train.curriculum["goal_reach_distance"].steps,
    ) == (3.0, 1000000)
    assert not load(["env=quadx_waypoints", "algo=sac", "train.curriculum=null"], tmp_path).train.curriculum


def test_a_multi_agent_curriculum_is_checked_and_reaches_the_task_of_every_training_env(tmp_path):
    from pyflyt_cli.training.envs import make_vec_env

    with pytest.raises(ConfigError, match="options a curriculum may move: separation, tolerance"):
        load(["env=ma_quadx_formation", "train.curriculum={layout_spacing:{start:2,steps:10}}"], tmp_path)
    with pytest.raises(ConfigError, match="tolerance"):
        load(["env=ma_quadx_formation", "train.curriculum={tolerance:{start:-1,steps:10}}"], tmp_path)
    cfg = load(
        ["env=ma_quadx_formation", "env.agents=4", "train.curriculum={tolerance:{start:2.0,steps:10}}"], tmp_path
    )
    vec = make_vec_env(cfg.env, 2, curriculum=True)
    try:
        vec.env_method("set_task_changes", {"tolerance": 2.0})
        vec.reset()
        tasks = [env.env.get_wrapper_attr("unwrapped").parallel.task for env in vec.envs]
        assert [t.options.tolerance for t in tasks] == [2.0, 2.0]
        assert all(t.configured.tolerance == cfg.env.task.tolerance for t in tasks)
    finally:
        vec.close()


def test_a_curriculum_that_outlasts_the_budget_is_refused_with_the_fix(tmp_path):
    """Training would end on an easier task than the evaluations fly (the SAC tuning's old
    600k-step curriculum on its 500k budget ended near a 0.33 m sphere, not 0.2 m)."""
    from pyflyt_cli.errors import UsageError
    from pyflyt_engine.errors import ConfigError

    long = ["env=quadx_waypoints", "algo=sac", "train.curriculum.goal_reach_distance.steps=3000000"]
    with pytest.raises((ConfigError, UsageError)) as caught:
        load(long, tmp_path)
    message = str(caught.value)
    assert "train.curriculum.goal_reach_distance.steps=3000000 outlasts train.total_timesteps=2000000" in message
    assert (
        "set train.curriculum.goal_reach_distance.steps=2000000 (or fewer), or train.total_timesteps=3000000" in message
    )
    assert "train.curriculum=null" in message
    assert (
        load([*long, "train.total_timesteps=3000000"], tmp_path).train.curriculum["goal_reach_distance"].steps
        == 3000000
    )


def test_no_shipped_tuning_or_experiment_has_a_curriculum_outlasting_its_budget(tmp_path):
    """Every conf/hparams tuning with a curriculum loads (with its own budget), and so do the
    smoke experiments on a curriculum tuning."""
    from pathlib import Path

    import yaml

    conf = Path(__file__).resolve().parents[2] / "conf"
    for path in sorted((conf / "hparams").glob("*.yaml")):
        data = yaml.safe_load(path.read_text())
        if not (data.get("train") or {}).get("curriculum"):
            continue
        # <env>_<algo>, the algorithm named by the longest algo config the stem ends with (sac_jax, not jax)
        algos = sorted((p.stem for p in (conf / "algo").glob("*.yaml")), key=len, reverse=True)
        algo = next(a for a in algos if path.stem.endswith(f"_{a}"))
        env = path.stem[: -len(algo) - 1]
        try:
            cfg = load([f"env={env}", f"algo={algo}"], tmp_path)
        except Exception as exc:  # noqa: BLE001 - only the curriculum's budget is checked here
            # CCGE without init_from is refused for its own reason (its oracle), checked after the budget
            assert algo == "ccge" and "needs init_from" in str(exc), (path.name, str(exc))
            continue
        for option in cfg.train.curriculum.values():
            assert option.steps <= cfg.train.total_timesteps, path.name
    # the smoke benchmark's grid is loaded by tests/benchmark/test_plan.py
    assert not load(["experiment=smoke", "env=quadx_waypoints", "algo=ppo"], tmp_path).train.curriculum


def test_a_run_recorded_before_the_gate_keeps_its_digest():
    """A curriculum without a gate identifies as it did before the gate existed (rundir.LATER_PATTERNS),
    so runs recorded then resume and compare as before: the shipped QuadX-Waypoints agent's recorded
    config has the digest it had (computed at the commit before the gate); a gate counts."""
    from pathlib import Path

    import yaml

    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.schema import parse_train_config

    path = Path(__file__).resolve().parents[2] / "pyflyt_cli" / "zoo" / "agents" / "quadx_waypoints_ppo" / "config.yaml"
    data = yaml.safe_load(path.read_text())
    cfg = parse_train_config(data, source=str(path), recorded=True)
    assert rundir.config_digest(cfg, path.parent) == "9b1c102659ceb3a238e75e106c7c39695fb949e27c274b4b190523272c4e1231"
    assert not [k for k in rundir.identity(cfg, path.parent) if k.endswith((".gate", ".gate_episodes"))]
    data["train"]["curriculum"]["goal_reach_distance"].update(gate=0.2, gate_episodes=100)
    gated = parse_train_config(data, source=str(path), recorded=True)
    assert rundir.identity(gated, path.parent)["train.curriculum.goal_reach_distance.gate"] == 0.2
    assert rundir.config_digest(gated, path.parent) != rundir.config_digest(cfg, path.parent)
