"""Env and reward configs: shipped files load; mistakes fail at load with a clear message."""

from __future__ import annotations

import copy

import gymnasium
import pytest
import yaml

from pyflyt_engine.envs import ENVS, make_env
from pyflyt_engine.envs.config import available, env_config_data, load_env_config, load_reward_preset, parse_env_config
from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.quadx import QuadXHoverEnv
from pyflyt_engine.envs.rewards import CONDITIONS, TERMS
from pyflyt_engine.errors import ConfigError


def _raw(name: str) -> dict:
    """A shipped config's keys as plain data, its bases' included (``defaults`` resolved)."""
    return copy.deepcopy(env_config_data(name))


def _env_error(data: dict) -> str:
    with pytest.raises(ConfigError) as info:
        parse_env_config(data, source="bad_env.yaml")
    return str(info.value)


def _reward_error(data: dict) -> str:
    with pytest.raises(ConfigError) as info:
        load_reward_preset(data)
    return str(info.value)


def test_every_shipped_config_loads_and_every_registered_id_has_one():
    for name in available("env"):
        config = load_env_config(name)
        load_reward_preset(config.reward_presets["dense"])
        load_reward_preset(config.reward_presets["sparse"])
    for name in available("reward"):  # the opt-in presets too (e.g. rocket_landing_envelope)
        load_reward_preset(name).compile()
    for env_id, entry in ENVS.items():
        assert load_env_config(entry.config).id == env_id
    assert {"quadx_hover_dense", "quadx_hover_sparse", "quadx_waypoints_dense", "quadx_waypoints_sparse"} <= set(
        available("reward")
    )


def test_unknown_env_key_names_the_field_and_suggests_the_fix():
    data = _raw("quadx_hover")
    data["flight_dome_sise"] = 4.0
    message = _env_error(data)
    assert "bad_env.yaml" in message and "unknown key 'flight_dome_sise'" in message
    assert "Did you mean 'flight_dome_size'?" in message and "agent_hz" in message


def test_unknown_task_option_and_unknown_task_are_rejected():
    data = _raw("quadx_waypoints")
    data["task"]["num_target"] = 3
    message = _env_error(data)
    assert "task.num_target" in message and "Did you mean 'num_targets'?" in message
    data = _raw("quadx_waypoints")
    data["task"]["name"] = "waypoint"
    message = _env_error(data)
    assert "unknown task 'waypoint'" in message and "hover" in message and "waypoints" in message


def test_bad_values_are_rejected_with_the_field():
    data = _raw("quadx_hover")
    data["angle_representation"] = "euler_angles"
    assert "angle_representation" in _env_error(data)
    data = _raw("quadx_hover")
    data["action"]["low"] = [0.0, 0.0, 0.0]
    assert "'low' has 3 entries but 'names' has 4" in _env_error(data)
    data = _raw("quadx_waypoints")
    data["task"]["goal_reach_distance"] = -1
    assert "task.goal_reach_distance" in _env_error(data)
    data = _raw("quadx_hover")
    data["agent_hz"] = 70  # 240 / 70 is not whole
    with pytest.raises(ConfigError, match="divide evenly"):
        UAVEnv(data)


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    "env, path, value",
    [
        ("quadx_hover", "task.hover_point", [NAN, 0.0, 1.0]),
        ("quadx_hover", "task.start_position", [0.0, INF, 1.0]),
        ("quadx_hover", "task.start_orientation_noise", NAN),
        ("quadx_hover", "flight_dome_size", INF),
        ("quadx_hover", "max_duration_seconds", INF),
        ("quadx_hover", "physics_hz", NAN),
        ("quadx_hover", "render.camera_height", NAN),
        ("quadx_hover", "action.high", [1.0, 1.0, 1.0, INF]),
        ("quadx_waypoints", "task.goal_reach_distance", INF),
        ("rocket_landing", "task.pad_radius", NAN),
        ("rocket_landing", "task.start_lin_vel", [0.0, 0.0, -INF]),
    ],
)
def test_non_finite_env_values_are_rejected_naming_the_key(env, path, value):
    data = _raw(env)
    node = data
    *parents, leaf = path.split(".")
    for key in parents:
        node = node[key]
    node[leaf] = value
    message = _env_error(data)
    assert "bad_env.yaml" in message and path in message, message
    assert "finite" in message, message


def test_non_finite_env_overrides_are_rejected():
    with pytest.raises(ConfigError, match=r"task.hover_point.0: Input should be a finite number \(got nan\)"):
        make_env("quadx_hover", hover_point=[NAN, 0.0, 1.0])
    with pytest.raises(ConfigError, match="agent_hz"):
        gymnasium.make("PyFlyt/QuadX-Hover-v0", agent_hz=INF)


@pytest.mark.parametrize(
    "terms, key",
    [
        ({"a": {"term": "constant", "weight": NAN}}, "terms.a.weight"),
        ({"a": {"term": "constant", "weight": -INF}}, "terms.a.weight"),
        ({"a": {"term": "distance_to_point", "params": {"point": [0.0, NAN, 1.0]}}}, "terms.a.params.point"),
        ({"a": {"term": "distance_to_point", "params": {"point": INF}}}, "terms.a.params.point"),
    ],
)
def test_non_finite_reward_weights_and_parameters_are_rejected(terms, key):
    message = _reward_error({"terms": terms})
    assert key in message and "finite number" in message, message
    assert message.count(key) == 1, message  # one line per problem


def test_unknown_python_argument_is_rejected():
    with pytest.raises(ConfigError, match="unknown environment argument 'num_target'.*Did you mean 'num_targets'"):
        gymnasium.make("PyFlyt/QuadX-Waypoints-v0", num_target=3)
    with pytest.raises(ConfigError, match="unknown environment argument 'num_targets'"):
        gymnasium.make("PyFlyt/QuadX-Hover-v0", num_targets=3)  # hover has no waypoints


def test_unknown_reward_term_condition_key_and_parameter():
    message = _reward_error({"terms": {"a": {"term": "inverse_distance", "weight": 1.0}}})
    assert "term 'a'" in message and "unknown reward term 'inverse_distance'" in message
    assert "Did you mean 'inverse_target_distance'?" in message
    assert all(name in message for name in TERMS)
    message = _reward_error({"terms": {"a": {"term": "constant", "when": "crashed"}}})
    assert "unknown condition 'crashed'" in message and "not_crash" in message
    assert all(name in message for name in CONDITIONS)
    message = _reward_error({"terms": {"a": {"term": "constant", "wieght": 2.0}}})
    assert "terms.a.wieght" in message and "Did you mean 'weight'?" in message
    message = _reward_error({"terms": {"a": {"term": "distance_to_point", "params": {"target": [0, 0, 1]}}}})
    assert "has no parameter 'target'" in message and "point" in message
    message = _reward_error({"terms": {}})
    assert "at least one term" in message
    message = _reward_error({"term": {"a": {"term": "constant"}}})
    assert "unknown key 'term'" in message and "Did you mean 'terms'?" in message


def test_reward_needing_a_signal_the_task_lacks_fails_when_the_env_is_built():
    with pytest.raises(ConfigError, match="'waypoint_reached' needs the signal 'waypoints'.*task 'hover'"):
        QuadXHoverEnv(reward="quadx_waypoints_sparse")


def test_unknown_preset_and_env_names(tmp_path):
    with pytest.raises(ConfigError, match="unknown reward config 'quadx_hover_dens'.*Did you mean 'quadx_hover_dense'"):
        load_reward_preset("quadx_hover_dens")
    with pytest.raises(ConfigError, match="unknown env config 'quadx_hoover'.*Did you mean 'quadx_hover'"):
        load_env_config("quadx_hoover")
    with pytest.raises(ConfigError, match="no such reward file"):
        load_reward_preset(tmp_path / "missing.yaml")


def test_config_files_are_never_executed(tmp_path):
    evil = tmp_path / "evil.yaml"
    evil.write_text("terms: !!python/object/apply:os.system ['echo hacked']\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_reward_preset(evil)


def test_user_env_yaml_runs_through_the_generic_env(tmp_path):
    data = _raw("quadx_waypoints")
    data["id"] = None
    data["task"]["num_targets"] = 2
    data["reward"] = "sparse"
    path = tmp_path / "my_env.yaml"
    path.write_text(yaml.safe_dump(data))
    env = make_env(path)
    try:
        assert type(env) is UAVEnv and env.reward_preset.name == "quadx_waypoints_sparse"
        obs, _ = env.reset(seed=0)
        assert obs["target_deltas"].shape == (2, 3)
    finally:
        env.close()
    registered = make_env("quadx_hover", sparse_reward=True)
    try:
        assert type(registered) is QuadXHoverEnv and registered.reward_preset.name == "quadx_hover_sparse"
    finally:
        registered.close()
