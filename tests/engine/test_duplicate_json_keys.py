"""A JSON document the toolkit reads from a shared artefact that gives a key twice is refused, naming the
file and the key: readers disagree on which entry counts (Python's keeps the last), so a second entry
could make a file say one thing to a person or another tool and another to this package.

Written from the reproduction (duplicate keys in a run's YAML were accepted, last wins; JSON was read
by plain ``json.loads``): ``state.json``, ``plan.json``, a checkpoint's trainer state, a recording's
metadata and messages.
"""

from __future__ import annotations

import json

import pytest

from pyflyt_engine.errors import ConfigError, TelemetryError
from pyflyt_engine.safe_load import json_data, json_loads, load_json_file


@pytest.mark.parametrize("text, key", [
    ('{"a": 1, "a": 2}', "a"),
    ('{"outer": {"x": 1, "y": 2, "x": 1}}', "x"),  # the same value twice is refused too
    ('[{"k": 1}, {"k": 2, "k": 3}]', "k"),
    ('{"": 1, "": 2}', ""),
])  # fmt: skip
def test_a_key_given_twice_is_refused_naming_the_source_and_the_key(text, key):
    with pytest.raises(ConfigError) as info:
        json_data(text, source="shared.json")
    assert str(info.value).startswith(f"shared.json: the key {key!r} is given twice")
    with pytest.raises(TelemetryError, match="given twice"):
        json_loads(text, source="m", error=TelemetryError)


def test_documents_without_a_repeated_key_read_as_json_reads_them():
    for text in ('{"a": 1, "b": {"a": 2}}', '[{"k": 1}, {"k": 2}]', '{"x": [1, 2.5, null, true, "s"]}', "3", "[]"):
        assert json_data(text, source="s") == json.loads(text)
        assert json_loads(text, source="s") == json.loads(text)


def test_state_json_with_a_key_given_twice_is_refused(tmp_path):
    from pyflyt_cli.training.rundir import RunDirError, read_state

    (tmp_path / "state.json").write_text('{"status": "complete", "checkpoint": 512, "status": "running"}')
    with pytest.raises(RunDirError, match=r"state.json: the key 'status' is given twice"):
        read_state(tmp_path)


def test_a_benchmark_plan_with_a_key_given_twice_is_refused(tmp_path):
    from pyflyt_cli.benchmark.plan import read_plan

    (tmp_path / "plan.json").write_text('{"experiment": "a", "benchmark": {}, "jobs": [], "experiment": "b"}')
    with pytest.raises(ConfigError, match=r"plan.json: not a readable benchmark plan \(the key 'experiment' is given"):
        read_plan(tmp_path)


def test_load_json_file_names_the_file(tmp_path):
    path = tmp_path / "x.json"
    path.write_text('{"a": {"b": 1, "b": 2}}')
    with pytest.raises(ConfigError, match=rf"^{path}: the key 'b' is given twice"):
        load_json_file(path)


def test_recording_metadata_with_a_key_given_twice_is_refused_by_replay(tmp_path):
    from tests.conftest import pyflyt_forked
    from tests.telemetry.conftest import record, rewrite_mcap

    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path, episodes=1, max_steps=3)
    forged = tmp_path / "forged.mcap"

    def metadata(name, data):
        if "config" in data:  # the env config: its physics rate twice, the second one a different rate
            text = data["config"]
            data = {**data, "config": text[:-1] + ', "physics_hz": 30.0}'}
        return data

    rewrite_mcap(env.paths[0], forged, lambda topic, data: None, metadata=metadata)
    code, output = pyflyt_forked(["replay", str(forged), "--verify"])
    assert code == 2 and "Traceback" not in output, output[-2000:]
    assert "metadata 'config': the key 'physics_hz' is given twice" in output


def test_a_checkpoint_state_with_a_key_given_twice_is_refused(tmp_path, monkeypatch):
    """The trainer state inside a checkpoint is JSON text: a repeated counter is refused, whatever the digest."""
    from pyflyt_cli.training import artifacts

    class Model:  # only what load_checkpoint_into reaches before the state is decoded
        def set_parameters(self, *args, **kwargs):
            pass

        def _get_torch_save_params(self):
            return [], []

    data = {"format": artifacts.CHECKPOINT_FORMAT, "optimizers": {}, "policy": {}, "variables": {},
            "state": '{"counters": {"num_timesteps": 512, "num_timesteps": -1}}', "tensors": {}}  # fmt: skip
    monkeypatch.setattr(artifacts, "load_policy_into", lambda model, data, path: None)  # the weights: not tested here
    with pytest.raises(artifacts.ArtifactError, match="its state: the key 'num_timesteps' is given twice"):
        artifacts.load_checkpoint_into(Model(), data, tmp_path / "model_512.pt")
