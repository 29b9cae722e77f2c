"""The batched backend ends episodes by the env config's own termination terms (the declaration
the PyBullet episode core binds), and refuses by name a term it does not implement."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pyflyt_engine.batched import bookkeeping
from pyflyt_engine.batched.env import make_batched_env
from pyflyt_engine.batched.model import UnsupportedByBatched
from pyflyt_engine.batched.terms import BatchedEnds, batched_ends
from pyflyt_engine.envs import terminations as t
from pyflyt_engine.envs.tasks.base import termination


def test_the_declaration_is_read_term_by_term():
    assert batched_ends(t.DEFAULT_TERMINATIONS, True) == BatchedEnds(True, True, True, True)
    assert batched_ends(t.DEFAULT_TERMINATIONS, False) == BatchedEnds(False, True, True, True)  # the task's
    assert batched_ends({}, True) == BatchedEnds(False, False, False, False)
    touch = {"touch": {"term": "contact", "params": {"crash_on_contact": False}}, "out_of_dome": None}
    assert batched_ends(touch, True) == BatchedEnds(False, False, False, False)


def test_a_term_it_does_not_implement_is_refused_by_name():
    t.register_termination("test_never", t.TerminationTerm(lambda episode: None, "crash"))
    try:
        with pytest.raises(UnsupportedByBatched, match="termination term 'mine'"):
            batched_ends({**t.DEFAULT_TERMINATIONS, "mine": {"term": "test_never"}}, True)
        with pytest.raises(UnsupportedByBatched, match="termination term 'mine'"):
            make_batched_env("quadx_hover", 2, terminations={"mine": {"term": "test_never"}})
    finally:
        del t.TERMINATIONS["test_never"]


def test_the_kernel_with_every_default_term_is_the_one_rule_of_every_task():
    cases = list(itertools.product((False, True), repeat=4))  # contact, out of the dome, complete, crash_on_contact
    pos = np.array([[0.0, 0.0, 9.0 if out else 1.0] for _, out, _, _ in cases])
    contact = np.array([c for c, _, _, _ in cases])
    complete = np.array([d for _, _, d, _ in cases])
    steps = np.ones(len(cases), dtype=np.int64)
    for crash_on_contact in (False, True):
        _, out, crashed, terminated, _, _, _ = bookkeeping.ends(
            pos, contact, complete, steps, 300, 25.0, crash_on_contact, False, True, True, True
        )
        expected = [termination(c, o, False, d, crash_on_contact) for c, o, d, _ in cases]
        assert list(zip(crashed.tolist(), terminated.tolist())) == expected


def test_without_the_dome_term_a_batched_vehicle_flies_on_outside_the_dome():
    action = np.zeros((2, 4))
    default = make_batched_env("quadx_hover", 2, seed=0, flight_dome_size=0.5)  # the spawn at 1 m is outside
    roam = make_batched_env(
        "quadx_hover", 2, seed=0, flight_dome_size=0.5, terminations={"contact": {}, "time_limit": {}}
    )
    try:
        ended = []
        for env in (default, roam):
            env.reset(seed=0)
            _, _, terminated, _, info = env.step(action)
            ended.append((terminated.tolist(), info["out_of_bounds"].tolist()))
        assert ended == [([True, True], [True, True]), ([False, False], [True, True])]
    finally:
        default.close()
        roam.close()


def test_a_swarm_reads_the_same_declaration():
    default = make_batched_env("ma_quadx_hover", 1, seed=0, flight_dome_size=0.5)  # every agent outside
    roam = make_batched_env("ma_quadx_hover", 1, seed=0, flight_dome_size=0.5, terminations={"contact": {}})
    try:
        ended = []
        for env in (default, roam):
            env.reset(seed=0)
            _, _, terminated, _, _ = env.step(np.zeros((env.num_envs, 4)))
            ended.append((bool(terminated.all()), bool(terminated.any())))
        assert ended == [(True, True), (False, False)]
    finally:
        default.close()
        roam.close()
