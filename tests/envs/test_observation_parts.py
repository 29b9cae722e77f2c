"""Every env's declared observation parts (``observation_layout``: the attitude vector's
parts, the task's, the camera and range sensors) make up its built observation space
exactly, for every shipped env config (registered, variants and multi-agent) in both angle
representations: the env manuals are written from the declaration, so it cannot drift."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from gymnasium import spaces

from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.observe import FLAT, attitude_parts
from pyflyt_engine.loading import available

CONFIGS = available("env")


def _entries(space: spaces.Space) -> dict[str, int]:
    """Entry key -> values per entry (per row of a Sequence) of a built observation space."""

    def size(s: spaces.Space) -> int:
        if isinstance(s, spaces.Sequence):
            return size(s.feature_space)
        assert isinstance(s, spaces.Box), f"an observation entry is a Box or a Sequence of Boxes, got {s}"
        return int(np.prod(s.shape))

    if isinstance(space, spaces.Dict):
        return {key: size(sub) for key, sub in space.spaces.items()}
    return {FLAT: size(space)}


@pytest.mark.parametrize("angles", ["quaternion", "euler"])
@pytest.mark.parametrize("name", CONFIGS)
def test_declared_parts_add_up_to_the_space(name, angles):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = make_env(name, angle_representation=angles)
    try:
        core = getattr(env, "parallel", env)  # a multi-agent config: its parallel env
        layout = core.observation_layout()
        declared = {key: sum(p.size for p in parts) for key, parts in layout.items()}
        assert declared == _entries(env.observation_space), name
        for parts in layout.values():
            assert all(p.size > 0 and p.meaning for p in parts)
        flat = layout.get(FLAT, layout.get("attitude"))
        attitude = next(p for p in flat if p.name == "attitude")
        assert attitude.size == (4 if angles == "quaternion" else 3)
    finally:
        env.close()


def test_the_other_representation_is_declared_without_a_rebuild():
    env = make_env("quadx_hover")
    try:
        assert sum(p.size for p in env.observation_layout(quaternion=False)[FLAT]) == 20
        assert sum(p.size for p in env.observation_layout()[FLAT]) == 21 == env.observation_space.shape[0]
    finally:
        env.close()


def test_attitude_parts_follow_the_vector_order():
    parts = attitude_parts(True, ["p", "q", "r", "thrust"], None, [("motors", 4)], fix_flag=True)
    assert [p.name for p in parts] == [
        "ang_vel", "attitude", "lin_vel", "lin_pos", "previous_action", "aux_motors", "fix_valid",
    ]  # fmt: skip
    assert [p.size for p in parts] == [3, 4, 3, 3, 4, 4, 1]
