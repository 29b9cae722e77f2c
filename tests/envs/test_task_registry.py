"""One registry holds every task, single- and multi-agent; the old name tables are its views."""

from __future__ import annotations

import importlib
from typing import ClassVar, Literal

import pytest

from pyflyt_engine.envs import rewards, task_registry
from pyflyt_engine.envs.config import MA_TASKS, load_env_config
from pyflyt_engine.envs.multi_agent import TASK_CLASSES, env_class
from pyflyt_engine.envs.multi_agent.config import get_ma_task
from pyflyt_engine.envs.oracles import ORACLES
from pyflyt_engine.envs.task_registry import REGISTRY, register_task, task_entry
from pyflyt_engine.envs.tasks import TASKS, HoverOptions, HoverTask, get_task
from pyflyt_engine.envs.tasks.multi import MA_TASK_CLASSES
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.loading import available

SINGLE = ["hover", "waypoints", "landing", "pole_balance", "pole_waypoints", "ball_in_cup", "gates", "goal"]
MULTI = ["ma_hover", "ma_formation", "dogfight"]


def _shipped(names):
    """``names`` less the tasks other tests register (they come after the shipped ones)."""
    return [n for n in names if n in SINGLE + MULTI]


def test_the_registry_holds_every_shipped_task_of_both_kinds_in_order():
    assert list(REGISTRY)[: len(SINGLE + MULTI)] == SINGLE + MULTI
    assert _shipped(n for n, e in REGISTRY.items() if e.kind == "single") == SINGLE == _shipped(TASKS)
    assert _shipped(n for n, e in REGISTRY.items() if e.kind == "multi") == MULTI == _shipped(MA_TASKS)
    assert _shipped(MA_TASK_CLASSES) == MULTI and set(TASKS) | set(MA_TASKS) == set(REGISTRY)


def test_the_old_tables_are_views_of_the_registry():
    for name, entry in REGISTRY.items():
        assert entry.name == name == entry.task.name and entry.options is entry.task.Options
        if entry.kind == "single":
            assert TASKS[name] is get_task(name) is entry.task and name not in MA_TASKS
        else:
            assert MA_TASKS[name] is entry.options and MA_TASK_CLASSES[name] is get_ma_task(name) is entry.task
            assert TASK_CLASSES[name] == entry.env and env_class(name).task_class is entry.task
            assert name not in TASKS
    assert dict(ORACLES) == {o.name: o for e in REGISTRY.values() for o in e.oracles}
    assert sorted(ORACLES) == [
        "quadx_forest_navigator",
        "quadx_gate_racer",
        "rocket_descent_lander",
        "rocket_lander",
        "rocket_velocity_lander",
    ]
    assert [o.name for o in task_entry("landing").oracles] == [
        "rocket_lander",
        "rocket_velocity_lander",
        "rocket_descent_lander",
    ]


def test_a_task_module_holds_its_task_options_terms_oracles_and_registration():
    """One module per task: its class, its options model, the reward terms reading its own
    signals and its oracles are all defined there (the module registers them)."""
    own_terms = {e.fn.__module__ for e in [*rewards.TERMS.values(), *rewards.CONDITIONS.values()]}
    for name in SINGLE + MULTI:
        entry = REGISTRY[name]
        module = entry.task.__module__
        assert module.startswith("pyflyt_engine.envs.tasks.")
        assert entry.options.__module__ == module, name
        assert all(o.__module__ == module for o in entry.oracles), name
    for module in ("landing", "pole", "ball_in_cup", "dogfight", "ma_formation"):
        assert f"pyflyt_engine.envs.tasks.{module}" in own_terms


def test_every_shipped_env_config_names_a_registered_task_of_its_kind():
    for name in available("env"):
        cfg = load_env_config(name)
        kind = "multi" if getattr(cfg, "multi_agent", False) else "single"
        assert task_entry(cfg.task.name, kind).options is type(cfg.task), name


def test_unknown_names_list_the_valid_ones_with_a_hint_and_the_other_kind():
    with pytest.raises(ConfigError, match=r"unknown task 'hovr'\. Did you mean 'hover'\? Valid: hover, waypoints"):
        get_task("hovr")
    with pytest.raises(ConfigError, match=r"unknown multi-agent task 'dogfigt'\. Did you mean 'dogfight'\?"):
        get_ma_task("dogfigt")
    with pytest.raises(ConfigError, match=r"Valid: hover, .*, goal.* \('ma_hover' is a multi-agent task\)"):
        get_task("ma_hover")
    with pytest.raises(
        ConfigError,
        match=r"needs task.name one of: ma_hover, ma_formation, dogfight \(got 'ma_hovr'\)\. Did you mean 'ma_hover'",
    ):
        load_env_config(
            {**load_env_config("ma_quadx_hover").model_dump(exclude={"source"}), "task": {"name": "ma_hovr"}}
        )


class _GlideOptions(HoverOptions):
    name: Literal["test_glide"] = "test_glide"  # type: ignore[assignment]


class _GlideTask(HoverTask):
    name: ClassVar[str] = "test_glide"
    Options: ClassVar[type] = _GlideOptions


class _GlideOracle:
    name = "test_glider"
    env_ids = ("PyFlyt/QuadX-Hover-v0",)

    def __init__(self, env):
        self.env = env

    def __call__(self, obs):
        return obs[:4]


def test_registering_a_task_with_its_oracle_as_a_decorator_and_removing_it():
    decorated = register_task(oracles=(_GlideOracle,))(_GlideTask)
    try:
        assert decorated is _GlideTask and TASKS["test_glide"] is _GlideTask
        assert ORACLES["test_glider"] is _GlideOracle and task_registry.oracle_task("test_glider").name == "test_glide"
        assert (
            load_env_config(
                {**load_env_config("quadx_hover").model_dump(exclude={"source"}), "task": {"name": "test_glide"}}
            ).task
            == _GlideOptions()
        )
    finally:
        del TASKS["test_glide"]
    assert "test_glide" not in REGISTRY and "test_glider" not in ORACLES


def test_what_the_registry_refuses():
    with pytest.raises(TypeError, match="needs a Task or MultiAgentTask subclass"):
        register_task(int)
    with pytest.raises(TypeError, match="register_task needs a Task subclass"):
        importlib.import_module("pyflyt_engine.envs.tasks").register_task(get_ma_task("ma_hover"))

    class Clash(HoverTask):
        name: ClassVar[str] = "dogfight"

    with pytest.raises(ValueError, match="'dogfight' is registered already as a multi-agent task"):
        register_task(Clash)
    with pytest.raises(ValueError, match="oracle 'rocket_lander' is registered already, for task 'landing'"):
        register_task(_GlideTask, oracles=(type("Copy", (), {"name": "rocket_lander", "env_ids": ("x",)}),))
    with pytest.raises(TypeError, match="must name the env ids"):
        register_task(_GlideTask, oracles=(type("NoIds", (), {"name": "no_ids"}),))
    with pytest.raises(TypeError, match="holds multi-agent tasks"):
        MA_TASK_CLASSES["test_glide"] = _GlideTask  # type: ignore[assignment]
    with pytest.raises(TypeError, match="register the task itself"):
        MA_TASKS["test_glide"] = _GlideOptions  # type: ignore[assignment]
    assert "test_glide" not in REGISTRY and list(REGISTRY)[: len(SINGLE + MULTI)] == SINGLE + MULTI


def test_a_multi_agent_task_registered_without_an_env_class_runs_in_the_generic_loop():
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.envs.config import env_config_data
    from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
    from pyflyt_engine.envs.tasks.ma_hover import MAHoverOptions, MAHoverTask

    class SwarmOptions(MAHoverOptions):
        name: Literal["test_swarm"] = "test_swarm"  # type: ignore[assignment]

    class SwarmTask(MAHoverTask):
        name: ClassVar[str] = "test_swarm"
        Options: ClassVar[type] = SwarmOptions

    register_task(SwarmTask)
    try:
        assert MA_TASKS["test_swarm"] is SwarmOptions and TASK_CLASSES["test_swarm"] is None
        assert env_class("test_swarm") is MultiAgentUAVEnv
        data = {**env_config_data("ma_quadx_hover"), "id": None, "agents": 2, "task": {"name": "test_swarm"}}
        env = make_env(data)
        try:
            obs, _ = env.reset(seed=0)
            assert type(env.parallel) is MultiAgentUAVEnv and env.parallel.possible_agents == ["uav_0", "uav_1"]
            assert isinstance(env.parallel.task, SwarmTask) and obs.shape == (2, 24)
        finally:
            env.close()
    finally:
        del MA_TASK_CLASSES["test_swarm"]
    assert "test_swarm" not in REGISTRY
