"""The termination terms (pyflyt_engine.envs.terminations): each rule against its oracle, the
declaration's errors, and the terms declared in an env config deciding how episodes end."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

from pyflyt_engine.envs import terminations as t
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.step import AgentStep
from pyflyt_engine.envs.tasks.base import TaskSignals, termination
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState

ZERO = (0.0, 0.0, 0.0)


def _state(position):
    return KinematicState(ZERO, ZERO, ZERO, tuple(position), (0.0, 0.0, 0.0, 1.0), ZERO, ZERO)


def _step(*, index=0, position=(0.0, 0.0, 1.0), collision=False, dome=5.0, failed=False, complete=False, steps=1):
    state = _state(position)
    out = t.outside_dome(state, dome**2)
    signals = TaskSignals(failed=failed, complete=complete)
    return AgentStep(index, state, np.zeros(4), collision, out, signals, steps)


def _episode(crash_on_contact=True, max_steps=300, payloads=(), obstacles=None, obstacles_crash=True):
    config = SimpleNamespace(max_steps=max_steps, obstacles=SimpleNamespace(crash_on_contact=obstacles_crash))
    return SimpleNamespace(
        tasks=SimpleNamespace(crash_on_contact=crash_on_contact),
        config=config,
        agent_payloads=list(payloads),
        obstacles=obstacles,
    )


def _bind(declaration, episode):
    return t.bind_terminations(declaration, episode)


# ------------------------------------------------------------------ each term


def test_a_state_outside_the_dome_is_out_of_bounds_and_crashes():
    judge = t.out_of_dome(_episode())
    inside, outside = _step(position=(3.0, 4.0, 0.0)), _step(position=(3.0, 4.0, 0.01))  # |p| = 5 m, the radius
    assert not inside.out_of_bounds and not judge(inside, {})
    assert outside.out_of_bounds and judge(outside, {})
    assert t.TERMINATIONS["out_of_dome"].kind == "crash"


def test_a_contact_crashes_unless_crash_on_contact_is_false():
    touching = _step(collision=True)
    assert t.contact(_episode())(touching, {}) is True
    assert t.contact(_episode())(_step(), {}) is False
    assert t.contact(_episode(crash_on_contact=False)) is None  # the task's (a landing's): contacts never end it
    assert t.contact(_episode(), crash_on_contact=False) is None  # the entry's parameter
    assert t.contact(_episode(crash_on_contact=False), crash_on_contact=True)(touching, {}) is True


def test_the_task_signals_fail_or_complete_the_episode():
    assert t.task_failure(_episode())(_step(failed=True), {}) and not t.task_failure(_episode())(_step(), {})
    assert t.task_complete(_episode())(_step(complete=True), {}) and not t.task_complete(_episode())(_step(), {})
    assert t.TERMINATIONS["task_failure"].kind == "crash" and t.TERMINATIONS["task_complete"].kind == "end"


def test_the_time_limit_truncates_at_max_steps():
    judge = t.time_limit(_episode(max_steps=10))
    assert [judge(_step(steps=s), {}) for s in (1, 9, 10, 11)] == [False, False, True, True]
    assert t.TERMINATIONS["time_limit"].kind == "truncate"


class _Payloads:
    def __init__(self, failing):
        self.failing = failing

    def ground_failure(self):
        return self.failing


def test_a_payload_on_the_ground_crashes_its_own_agent_and_reports_it():
    assert t.payload_on_ground(_episode()) is None  # no payloads: the rule cannot fire
    judge = t.payload_on_ground(_episode(payloads=[_Payloads(False), _Payloads(True)]))
    info: dict = {}
    assert judge(_step(index=1), info) is True and info == {"payload_ground_contact": True}
    assert judge(_step(index=0), info) is False and info == {"payload_ground_contact": False}
    judge.reset_info(0, info)
    assert info == {"payload_ground_contact": False}


class _Obstacles:
    parked = 2

    def __init__(self, touched):
        self._touched = touched

    def touched(self, i):
        return self._touched[i]


def test_an_obstacle_touched_crashes_where_the_obstacles_say_so_and_is_reported_either_way():
    assert t.obstacle_contact(_episode()) is None
    for crashes in (True, False):
        judge = t.obstacle_contact(_episode(obstacles=_Obstacles([True, False]), obstacles_crash=crashes))
        info: dict = {}
        assert judge(_step(index=0), info) is crashes
        assert info == {"obstacle_contact": True, "obstacles_parked": 2}
        assert judge(_step(index=1), info) is False and info["obstacle_contact"] is False
        judge.reset_info(0, info)
        assert info == {"obstacle_contact": False, "obstacles_parked": 2}


def _judged(terms, step):
    crashed = any([j(step, {}) for j in terms.crash])
    terminated = any([j(step, {}) for j in terms.end]) or crashed
    return crashed, terminated


def test_the_default_terms_together_are_the_one_rule_of_every_task():
    for crash_on_contact, collision, out, failed, complete in itertools.product((True, False), repeat=5):
        terms = _bind(t.DEFAULT_TERMINATIONS, _episode(crash_on_contact=crash_on_contact))
        step = _step(collision=collision, position=(0, 0, 9.0 if out else 1.0), failed=failed, complete=complete)
        assert _judged(terms, step) == termination(collision, out, failed, complete, crash_on_contact)


# --------------------------------------------------------------- declaration


def test_an_unknown_term_is_refused_at_load_with_a_suggestion():
    data = load_env_config("quadx_hover").model_dump(exclude={"source"})
    data["terminations"] = {**data["terminations"], "out_of_dom": {}}
    with pytest.raises(
        ConfigError, match=r"terminations\.out_of_dom: unknown termination term 'out_of_dom'.*out_of_dome"
    ):
        load_env_config(data)
    data["terminations"] = {"dome": {"term": "outside"}}
    with pytest.raises(ConfigError, match="unknown termination term 'outside'"):
        load_env_config(data)


def test_an_unknown_parameter_is_refused_naming_the_valid_ones():
    data = load_env_config("quadx_hover").model_dump(exclude={"source"})
    data["terminations"] = {"contact": {"params": {"crash": False}}}
    with pytest.raises(ConfigError, match="'contact' has no parameter 'crash'; its parameters: crash_on_contact"):
        load_env_config(data)


def test_null_switches_an_entry_off_and_term_names_the_registered_one():
    declaration = {"touch": {"term": "contact"}, "out_of_dome": None, "time_limit": {}}
    assert [(key, term.kind) for key, term, _ in t.declared(declaration)] == [
        ("touch", "crash"),
        ("time_limit", "truncate"),
    ]


def test_every_shipped_env_declares_the_default_terms():
    from pyflyt_engine.loading import available

    for name in available("env"):
        declared = load_env_config(name).model_dump()["terminations"]
        assert declared == {k: {"term": None, "params": {}} for k in t.DEFAULT_TERMINATIONS}, name


# --------------------------------------------------------- in an env's episode


def _fly(steps, action, **overrides):
    env = UAVEnv("quadx_hover", **overrides)
    try:
        env.reset(seed=0)
        for k in range(steps):
            _, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                return k + 1, terminated, truncated, info
        return steps, False, False, info
    finally:
        env.close()


def _declaration(**changes):
    return {**load_env_config("quadx_hover").model_dump()["terminations"], **changes}


def test_a_ground_contact_ends_the_episode_unless_the_contact_term_says_it_is_no_crash():
    falls = np.array([0.0, 0.0, 0.0, -1.0])  # no thrust: it falls onto the ground
    n, terminated, _, info = _fly(200, falls)
    assert terminated and info["collision"] and n < 200
    _, terminated, truncated, info = _fly(
        200, falls, terminations=_declaration(contact={"params": {"crash_on_contact": False}})
    )
    assert not terminated and not truncated and info["collision"]  # on the ground, still flying its episode


def test_without_the_time_limit_term_an_episode_is_never_truncated():
    hold = np.zeros(4)  # it falls onto the ground at step 13: nothing but the time limit may end it here
    assert _fly(40, hold, max_duration_seconds=0.5, terminations={"time_limit": {}})[:3] == (15, False, True)
    assert _fly(40, hold, max_duration_seconds=0.5, terminations={})[:3] == (40, False, False)


def test_a_registered_term_ends_episodes_where_a_config_names_it():
    class _Low(t.Judge):
        __slots__ = ("height",)

        def __init__(self, height):
            self.height = height

        def __call__(self, step, info):
            info["below"] = step.state.lin_pos[2] < self.height
            return info["below"]

    def below(episode, height: float = 0.5):
        """Flying below height [m] is a crash."""
        return _Low(height)

    t.register_termination("test_below", t.TerminationTerm(below, "crash"))
    try:
        falls = np.array([0.0, 0.0, 0.0, -1.0])
        n, terminated, _, info = _fly(
            200, falls, terminations=_declaration(low={"term": "test_below", "params": {"height": 0.8}})
        )
        assert terminated and info["below"] and not info["collision"]  # before it reaches the ground
        assert t.TERMINATIONS["test_below"].description == "Flying below height [m] is a crash."
    finally:
        del t.TERMINATIONS["test_below"]
