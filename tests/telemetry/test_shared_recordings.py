"""A recording is shared data: replaying one never opens a file it names, never hangs or crashes.

Each case is a recording rewritten the way an attacker would, from the reproductions of
issue 39: a recorded airframe naming its own URDF (a FIFO, a malformed file beside the
recording), a randomisation preset name walking out of ``conf/randomize`` to an
alias-expansion bomb, metadata nested or sized to exhaust the reader.  Every command
(``replay``, ``--verify``, ``--plot``, ``--video``) answers with one line and exit code 2
within seconds.  The cases that hung or aborted the process run in a forked child whose
timeout only detects a hang (:func:`tests.conftest.pyflyt_forked`); they answer in about
a second.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from pyflyt_cli.main import app
from tests.conftest import billion_laughs, pyflyt_forked

from .conftest import record, rewrite_mcap


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """One short QuadX-Hover episode."""
    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path_factory.mktemp("recorded"), max_steps=15, seed=0)
    return env.paths[0]


def craft(src: Path, dst: Path, env=None, attachments=None) -> Path:
    """A copy of ``src`` whose ``env`` metadata record (parsed JSON values) ``env(record)`` changes in place."""

    def metadata(name: str, data: dict[str, str]) -> dict[str, str]:
        if name != "env" or env is None:
            return data
        values = {k: json.loads(v) if k in ("config", "airframe_spec", "uav_specs") else v for k, v in data.items()}
        env(values)
        return {k: v if isinstance(v, str) else json.dumps(v) for k, v in values.items()}

    rewrite_mcap(src, dst, lambda topic, data: None, metadata, attachments)
    return dst


def _one_line_exit_2(result: tuple[int, str], *fragments: str) -> None:
    """Exit code 2, no traceback, one ``error:`` line holding ``fragments``."""
    code, output = result
    assert code == 2, output[-3000:]
    assert "Traceback" not in output
    error = [line for line in output.splitlines() if line.startswith("error:")]
    assert len(error) == 1, output[-3000:]
    for fragment in fragments:
        assert fragment in error[0], error[0]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_recorded_airframe_naming_a_fifo_flies_the_recorded_urdf_and_does_not_hang(recording, tmp_path):
    fifo = tmp_path / "airframe.urdf"
    os.mkfifo(fifo)  # PyBullet would wait for a writer for ever

    def env(record):
        record["airframe_spec"]["body"]["urdf"] = str(fifo)
        record["config"]["uav"] = str(fifo)

    crafted = craft(recording, tmp_path / "ep.mcap", env)
    code, output = pyflyt_forked(["replay", str(crafted), "--verify"])
    assert code == 0, output[-3000:]  # the recording's own URDF is flown: the same flight
    assert "verify    OK" in output


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_multi_agent_recording_flies_its_recorded_airframes_not_the_files_its_agents_name(tmp_path):
    import numpy as np

    from pyflyt_engine.envs import make_env
    from pyflyt_engine.paths import conf_dir, uav_dir
    from pyflyt_engine.telemetry import RecordEpisode

    mine = tmp_path / "mine.yaml"
    mine.write_text((uav_dir() / "quadx_f450.yaml").read_text())
    config = {
        **yaml.safe_load((conf_dir() / "env" / "ma_quadx_hover.yaml").read_text()),
        "agents": [{"uav": str(mine)}, {}],
    }
    env = RecordEpisode(make_env(config), tmp_path / "episodes")
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.full((2, 4), 0.1))
    env.close()
    mine.unlink()
    os.mkfifo(mine)  # the file an agent named: opening it would hang
    code, output = pyflyt_forked(["replay", str(env.paths[0]), "--verify"])
    assert code == 0, output[-3000:]
    assert "verify    OK" in output


def test_a_randomisation_name_walking_to_an_alias_bomb_is_refused(recording, tmp_path):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(billion_laughs())
    walk = "/".join([".."] * 40) + str(bomb.with_suffix(""))

    def env(record):
        record["config"]["randomize"] = walk

    crafted = craft(recording, tmp_path / "ep.mcap", env)
    result = pyflyt_forked(["replay", str(crafted), "--verify"])
    _one_line_exit_2(result, str(crafted), "randomisation", "not a shipped preset")


@pytest.mark.parametrize(
    ("kind", "option"),
    [("not_xml", "--verify"), ("mesh_file", "--verify"), ("nan_mass", "--video")],
)
def test_a_malformed_recorded_urdf_is_refused_before_pybullet(recording, tmp_path, kind, option):
    urdf = {
        "not_xml": "<robot name='x'><link name='body'>" + "<visual>" * 2000,
        "mesh_file": "<robot name='x'><link name='body'><visual><geometry>"
        "<mesh filename='/etc/passwd'/></geometry></visual></link></robot>",
        "nan_mass": "<robot name='x'><link name='body'><inertial><mass value='nan'/>"
        "<inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/></inertial></link></robot>",
    }[kind]
    (tmp_path / "airframe.urdf").write_text(urdf)  # where a path in the recording would lead

    def env(record):
        record["airframe_spec"]["body"]["urdf"] = "airframe.urdf"

    def attachments(name, data):
        return urdf.encode() if name == "uav_0.urdf" else data

    crafted = craft(recording, tmp_path / "ep.mcap", env, attachments)
    out = ["--video", str(tmp_path / "film.gif")] if option == "--video" else [option]
    result = pyflyt_forked(["replay", str(crafted), *out])
    _one_line_exit_2(result, str(crafted), "recorded URDF (uav_0.urdf) is refused")
    assert not (tmp_path / "film.gif").exists()


@pytest.mark.parametrize("option", ["summary", "--verify", "--plot", "--video"])
@pytest.mark.parametrize("damage", ["deep", "huge"])
def test_metadata_sized_or_nested_to_exhaust_the_reader_is_refused_by_every_command(
    recording, tmp_path, damage, option
):
    def env(record):
        if damage == "deep":  # json.loads recurses once per level
            record["uav_specs"] = "[" * 100_000 + "]" * 100_000
        else:  # a "very large recorded airframe": 1 MiB of shapes
            shapes = record["airframe_spec"]["body"]["shapes"]
            record["airframe_spec"]["body"]["shapes"] = shapes * (20_000 // len(shapes))

    crafted = craft(recording, tmp_path / "ep.mcap", env)
    args = [str(crafted)]
    if option == "--plot":
        args += ["--plot", str(tmp_path / "plot.png")]
    elif option == "--video":
        args += ["--video", str(tmp_path / "film.gif")]
    elif option == "--verify":
        args += ["--verify"]
    invoked = CliRunner().invoke(app, ["replay", *args])
    result = (
        invoked.exit_code,
        invoked.output + ("" if isinstance(invoked.exception, (SystemExit, type(None))) else "Traceback"),
    )
    key = "uav_specs" if damage == "deep" else "airframe_spec"
    _one_line_exit_2(result, str(crafted), f"metadata '{key}'")
    assert not (tmp_path / "plot.png").exists() and not (tmp_path / "film.gif").exists()
