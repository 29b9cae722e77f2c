"""The recorder reads an env through its public protocol (``RecordableEnv``) and nothing else."""

from __future__ import annotations

import ast
import inspect

import gymnasium
import pytest

from pyflyt_engine.envs.recordable import RECORDABLE, RecordableEnv
from pyflyt_engine.errors import TelemetryError


def test_the_recorder_reads_no_env_internals():
    from pyflyt_engine.telemetry import recorder

    tree = ast.parse(inspect.getsource(recorder))
    read = set()
    for node in ast.walk(tree):
        # (hasattr names the members an env lacks, in the refusal's message)
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "getattr":
            target = ast.unparse(node.args[0])
            assert "base" not in target, f"the recorder probes the env: {ast.unparse(node)}"
        if isinstance(node, ast.Attribute) and ast.unparse(node.value) in ("base", "self._base"):
            read.add(node.attr)
    assert read <= set(RECORDABLE), f"read outside the protocol: {sorted(read - set(RECORDABLE))}"


def test_both_fronts_are_recordable_and_anything_else_is_refused_by_what_it_lacks(tmp_path):
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.telemetry import RecordEpisode

    for env in (make_env("quadx_hover"), make_env("ma_quadx_hover", agents=2)):
        try:
            assert isinstance(env, RecordableEnv)
        finally:
            env.close()
    with pytest.raises(TelemetryError, match="has no 'world'.*'scene_markers'"):
        RecordEpisode(gymnasium.make("CartPole-v1"), tmp_path)
