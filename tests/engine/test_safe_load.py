"""The shared bounded readers: a shared file cannot hang, exhaust memory or run code when read.

Every YAML and JSON document the package reads goes through :mod:`pyflyt_engine.safe_load`;
each hostile shape below is refused by name, in well under a second.
"""

from __future__ import annotations

import os

import pytest
import yaml

from pyflyt_engine.errors import ConfigError, SpecError
from pyflyt_engine.safe_load import (
    MAX_YAML_BYTES,
    json_data,
    load_json_file,
    load_yaml_file,
    plain_name,
    read_bytes,
    yaml_data,
)
from tests.conftest import billion_laughs


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (billion_laughs(), "more than 100000 values"),
        ("a: &a [*a]\n", "contains itself"),
        ("x: " + "[" * 100 + "]" * 100 + "\n", "nested too deeply"),
        ("x: " + "[" * 5000 + "]" * 5000 + "\n", "nested too deeply"),
        ("a: &a {k: v}\n" + "".join(f"b{i}: {{<<: *a}}\n" for i in range(3)), None),  # merge keys stay usable
    ],
    ids=["billion_laughs", "recursive", "deep", "very_deep", "merge_keys"],
)
def test_yaml_documents_that_expand_or_nest_are_refused(text, message):
    # Refused by a limit, named in the message: before the expansion is built (the alias
    # count) or when the composer's recursion gives out (nesting).  A deep document takes
    # ~1-2 s of a core to refuse; no time limit is asserted here.
    if message is None:
        assert yaml_data(text, source="doc.yaml")["b2"] == {"k": "v"}
    else:
        with pytest.raises(ConfigError, match=message) as info:
            yaml_data(text, source="doc.yaml")
        assert str(info.value).startswith("doc.yaml: ")


def test_yaml_tags_stay_refused():
    with pytest.raises(yaml.YAMLError, match="python/object"):
        yaml_data("x: !!python/object/apply:os.system ['true']\n", source="doc.yaml")


def test_an_oversized_document_is_refused_by_its_length_before_parsing(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text("x: " + "a" * MAX_YAML_BYTES + "\n")
    with pytest.raises(SpecError, match=r"big.yaml: the UAV file is .* more than"):
        load_yaml_file(path, what="UAV file", error=SpecError)
    with pytest.raises(ConfigError, match="document holds more than 10 values"):
        json_data("[" + ",".join(["1"] * 20) + "]", source="doc.json", max_nodes=10)
    with pytest.raises(ConfigError, match="nested too deeply"):
        json_data("[" * 100_000 + "]" * 100_000, source="doc.json", limit=None)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_special_files_are_refused_before_they_are_read(tmp_path):
    fifo = tmp_path / "config.yaml"
    os.mkfifo(fifo)  # reading it would wait for a writer for ever
    with pytest.raises(ConfigError, match="is a FIFO"):
        load_yaml_file(fifo)
    with pytest.raises(ConfigError, match="is a FIFO"):
        load_json_file(fifo)
    link = tmp_path / "state.json"
    link.symlink_to(fifo)
    with pytest.raises(ConfigError, match="is a FIFO"):
        read_bytes(link)
    if os.path.exists("/dev/zero"):
        with pytest.raises(ConfigError, match="character device"):
            read_bytes("/dev/zero", limit=None)


def test_shipped_configs_load_within_the_limits():
    from pyflyt_engine.paths import conf_dir

    for path in conf_dir().rglob("*.yaml"):
        load_yaml_file(path)


def test_preset_names_are_never_paths():
    assert plain_name("dryden_light") and plain_name("quadx_cf2x") and plain_name("airframe-0a1b2c.yaml")
    for name in ("../x", "/etc/passwd", "a/b", "..", "", " x", None):
        assert not plain_name(name)
