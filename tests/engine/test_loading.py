"""One loader for every config kind: a shipped name, a YAML path or a mapping, worded alike."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from pydantic import BaseModel, ConfigDict, Field

from pyflyt_engine.atmosphere import load_wind_config
from pyflyt_engine.envs.config import load_env_config, load_reward_preset
from pyflyt_engine.errors import ConfigError, SpecError
from pyflyt_engine.loading import resolve, validate
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.spec import load_uav_spec

KINDS = [
    ("uav", "quadx_cf2x", load_uav_spec, SpecError),
    ("env", "quadx_hover", load_env_config, ConfigError),
    ("reward", "quadx_hover_dense", load_reward_preset, ConfigError),
    ("wind", "gust", load_wind_config, ConfigError),
]


@pytest.mark.parametrize(("group", "name", "loader", "error"), KINDS)
def test_every_kind_loads_from_a_name_a_path_a_mapping_and_a_model(tmp_path, group, name, loader, error):
    shipped = conf_dir() / group / f"{name}.yaml"
    data = yaml.safe_load(shipped.read_text())
    copy = tmp_path / f"{name}.yaml"
    copy.write_text(shipped.read_text())
    by_name, by_path, by_mapping = loader(name), loader(str(copy)), loader(data)
    assert loader(by_name) is by_name
    for model in (by_path, by_mapping):
        assert model.model_dump(exclude={"source", "name"}) == by_name.model_dump(exclude={"source", "name"})
    with pytest.raises(error, match="no such .* file; check the path"):
        loader(str(tmp_path / "missing.yaml"))
    with pytest.raises(error, match=f"unknown .*'{name[:-1]}'. Did you mean '{name}'"):
        loader(name[:-1])


def test_a_shipped_name_comes_before_a_file_of_that_name_and_never_leaves_its_group(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gust").mkdir()  # a directory named like a preset does not shadow it
    assert resolve("gust", "wind", what="wind") == conf_dir() / "wind" / "gust.yaml"
    (tmp_path / "mine").write_text("mean: {speed: 1}\n")  # a bare name that is not shipped: the file here
    assert resolve("mine", "wind", what="wind") == Path("mine")
    with pytest.raises(ConfigError, match="unknown randomize preset"):
        resolve("..", "randomize", what="randomize preset", files=False)


class _Inner(BaseModel):
    model_config = ConfigDict(extra="forbid")
    speed: float = Field(gt=0)


class _Outer(BaseModel):
    model_config = ConfigDict(extra="forbid")
    seeds: int | list[int]
    inner: _Inner
    table: dict[str, _Inner] = {}


def test_one_wording_for_every_problem():
    with pytest.raises(ConfigError) as caught:
        validate(
            _Outer, {"seeds": "x", "inner": {"sped": 1}, "table": {"a": {"speed": -1}}}, "thing", "here", prefix="t."
        )
    lines = str(caught.value).splitlines()
    assert lines[0] == "here: invalid thing:"
    # a union's members are not keys the user wrote: seeds, never seeds.int or seeds.list[int]
    assert (
        "  - t.seeds: Input should be a valid integer, unable to parse string as an integer (got 'x'); fix: give an integer"
        in lines
    )
    assert "  - t.seeds: Input should be a valid list (got 'x'); fix: give a list, e.g. [1, 2, 3]" in lines
    assert "  - t.inner.sped: unknown key 'sped'. Did you mean 'speed'? Allowed keys here: speed" in lines
    assert "  - t.inner.speed: Field required; fix: add it" in lines
    assert "  - t.table.a.speed: Input should be greater than 0 (got -1); fix: give a larger value" in lines


def test_the_uav_spec_names_the_control_keys_of_its_kind():
    data = yaml.safe_load((conf_dir() / "uav" / "fixedwing.yaml").read_text())
    data["control"]["zzz"] = 1
    with pytest.raises(
        SpecError, match=r"control\.zzz: unknown key 'zzz'\. Allowed keys here: airspeed, cruise_thrust"
    ):
        load_uav_spec(data)
