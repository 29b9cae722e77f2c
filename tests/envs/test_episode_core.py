"""The episode core's build and start (``build.build_episode``, ``build.reset_episode``), used
by the single-agent and the multi-agent env alike."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.envs import build
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.tasks.base import Spawn
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.spec import load_uav_spec


def test_build_then_reset_spawns_each_vehicle_in_agent_order_then_starts_the_task():
    cfg = load_env_config("quadx_hover").with_overrides(latency={"action_delay": 0.01})
    spec = load_uav_spec(cfg.uav)
    spawns = [((0.0, 0.0, 1.0), (0.0, 0.0, 0.0)), ((2.0, 0.0, 1.0), (0.0, 0.0, 0.0))]
    parts = build.build_episode(cfg, [spec, spec], spawns, render=False)
    try:
        assert len(parts.vehicles) == 2 and parts.vehicles == parts.world.vehicles
        assert parts.payloads == [] and parts.obstacles is None and parts.randomizer is None
        assert parts.sensed is None and parts.estimators is None and parts.fix_flag == [False, False]
        # 0.01 s at the config's physics rate, on every vehicle
        delay = round(0.01 * cfg.physics_hz)
        assert delay > 0 and parts.latency_steps == (delay, 0)
        assert all(v.latency == (delay, 0) for v in parts.vehicles)
        # a vehicle added to the world later is not one of the episode's
        parts.world.add_vehicle("quadx_cf2x", (0.0, 3.0, 1.0))
        assert len(parts.world.vehicles) == 3 and len(parts.vehicles) == 2

        calls: list[str] = []
        targets = [(-1.0, 0.5, 2.0), (1.5, -0.5, 1.5)]

        def spawn(i: int) -> Spawn:
            calls.append(f"spawn {i}")
            return Spawn(targets[i], (0.0, 0.0, 0.3 * i))

        def start_task(states):
            calls.append("task")
            for state, target in zip(states, targets):
                assert state.lin_pos == pytest.approx(target, abs=1e-9)  # placed before the task starts
            return np.zeros((0, 3))

        drawn, states = build.reset_episode(parts, 0, np.random.default_rng(0), spawn, start_task)
        assert drawn is None and calls == ["spawn 0", "spawn 1", "task"]
        assert [s.lin_pos for s in states] == [v.state.lin_pos for v in parts.vehicles]
        assert states[1].ang_pos[2] == pytest.approx(0.3, abs=1e-9)
    finally:
        parts.world.close()


def test_build_refuses_an_action_the_flight_mode_does_not_take_naming_the_agent():
    cfg = load_env_config("quadx_hover")
    cfg = cfg.with_overrides(
        action={**cfg.action.model_dump(), "names": ["a", "b"], "units": ["", ""], "low": [0, 0], "high": [1, 1]}
    )
    spec = load_uav_spec(cfg.uav)
    with pytest.raises(ConfigError, match="agent 'uav_0': action has 2 entries"):
        build.build_episode(cfg, [spec, spec], [((0, 0, 1), (0, 0, 0)), ((2, 0, 1), (0, 0, 0))], render=False,
                           agent_names=["uav_0", "uav_1"])  # fmt: skip
    with pytest.raises(ConfigError, match="action has 2 entries .* give action.names"):
        build.build_episode(cfg, [spec], [((0, 0, 1), (0, 0, 0))], render=False)


# ------------------------------------------------------------ the one step loop


def test_both_fronts_run_the_one_episode_core():
    """The Gymnasium env and the PettingZoo env inherit the one step loop; the single-agent
    task is asked through the per-agent protocol as agent 0."""
    from pyflyt_engine.envs.env import UAVEnv
    from pyflyt_engine.envs.episode import EpisodeCore, OneAgentTask
    from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv

    assert issubclass(UAVEnv, EpisodeCore) and issubclass(MultiAgentUAVEnv, EpisodeCore)
    for front in (UAVEnv, MultiAgentUAVEnv):  # the step's pieces are the core's, not redefined by a front
        for piece in ("_act", "_advance", "_judge", "_observe", "_check", "_reset_core", "_reset_info"):
            assert getattr(front, piece) is getattr(EpisodeCore, piece), (front.__name__, piece)
    env = UAVEnv("quadx_hover")
    try:
        assert isinstance(env.tasks, OneAgentTask) and env.tasks.task is env.task
        env.reset(seed=3)
        env.step(np.array([0.0, 0.0, 0.0, 0.5]))
        assert env.elapsed_steps == 1 and env.vehicles == [env.vehicle]
    finally:
        env.close()


def test_a_multi_agent_task_reaching_a_waypoint_is_paid_as_in_a_single_agent_task(tmp_path):
    """One reward context for every front: a multi-agent task's ``waypoint_reached`` signal
    reaches the preset's ``waypoint_reached`` condition for that agent only, at that step."""
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv
    from pyflyt_engine.envs.tasks.ma_hover import MAHoverTask

    class CheckpointTask(MAHoverTask):
        provides = MAHoverTask.provides | {"waypoints"}

        def update(self, states, live, collisions, step):
            signals = super().update(states, live, collisions, step)
            if step == 2 and 1 in signals:
                signals[1].waypoint_reached = True
            return signals

    class CheckpointEnv(MAQuadXHoverEnv):
        task_class = CheckpointTask

    preset = tmp_path / "checkpoint.yaml"
    preset.write_text(
        "description: a bonus per waypoint\n"
        "terms:\n"
        "  bonus: {term: constant, weight: 50.0, when: waypoint_reached}\n"
        "  alive: {term: constant, weight: 1.0, when: not_crash}\n"
    )
    env = CheckpointEnv(reward=str(preset), agents=2)
    try:
        env.reset(seed=0)
        hover = [np.array([0.0, 0.0, 0.0, 0.0]) for _ in env.agents]
        paid = []
        for _ in range(3):
            _, rewards, *_ = env.step(dict(zip(env.agents, hover)))
            paid.append([rewards[name] for name in env.possible_agents])
        assert paid == [[1.0, 1.0], [1.0, 51.0], [1.0, 1.0]]
    finally:
        env.close()
