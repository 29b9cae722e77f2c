"""A shared run is closed all the way down: every file any of its files names -- the airframe's URDF,
the meshes that URDF names, an obstacle's mesh, a payload's mesh -- is a regular file of the run reached
through no link, checked before PyBullet or the recorder opens anything; a FIFO, a device or a directory
where a file is expected is refused wherever it is in the run.

Written from the reproductions: a run's URDF naming ``<mesh filename="/abs/secret.obj">`` (or ``../..``, or
a link ``*.obj`` inside the run) made ``pyflyt eval`` embed the file's bytes into ``episodes/*.mcap``;
``env.obstacles.items[].file`` read any absolute path; a FIFO in a subfolder blocked ``eval`` inside
PyBullet; a URDF with two root links crashed PyBullet; ``body.urdf`` naming a directory aborted it.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
import yaml

from pyflyt_cli.training import rundir
from tests.conftest import pyflyt_forked

SECRET = "api_key = do-not-leak\n"

#: a tetrahedron (a valid OBJ mesh)
OBJ = "v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 0.05\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def urdf(mesh: str, extra_link: bool = False) -> str:
    link = (
        '<link name="base"><inertial><mass value="0.027"/><inertia ixx="1.4e-5" ixy="0" ixz="0" iyy="1.4e-5" '
        'iyz="0" izz="2.17e-5"/></inertial>'
        f'<visual><geometry><mesh filename="{mesh}" scale="1 1 1"/></geometry></visual>'
        '<collision><geometry><box size="0.09 0.09 0.02"/></geometry></collision></link>'
    )
    second = '<link name="loose"><inertial><mass value="0.01"/></inertial></link>' if extra_link else ""
    return f'<?xml version="1.0"?><robot name="cf2x">{link}{second}</robot>\n'


@pytest.fixture
def run(tmp_path) -> Path:
    """A copy of a shipped agent as a run directory whose airframe is its own copy, with a URDF."""
    from pyflyt_cli.zoo import agent
    from pyflyt_engine.paths import uav_dir

    copy = tmp_path / "run"
    shutil.copytree(agent("quadx_hover_ppo").path, copy)
    spec = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    spec["body"]["urdf"] = "body/cf2x.urdf"
    (copy / "airframe.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    (copy / "body").mkdir()
    (copy / "body" / "cf2x.obj").write_text(OBJ)
    (copy / "body" / "cf2x.urdf").write_text(urdf("cf2x.obj"))
    # a URDF airframe trains on PyBullet (the batched backend refuses it by name)
    set_config(copy, lambda env: env.update(uav="airframe.yaml", backend="pybullet"))
    (tmp_path / "secret.obj").write_text(SECRET)
    return copy


def set_config(run: Path, change) -> None:
    path = run / "config.yaml"
    data = yaml.safe_load(path.read_text())
    change(data["env"])
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def refused_by_load(run: Path, *fragments: str) -> str:
    with pytest.raises(rundir.RunDirError) as caught:
        rundir.load_run_config(run)
    message = str(caught.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    return message


def test_a_run_whose_files_stay_inside_it_loads(run):
    cfg = rundir.load_run_config(run)
    assert Path(cfg.env.uav) == run / "airframe.yaml"


def test_eval_never_embeds_a_file_outside_the_run_named_by_its_urdf(run, tmp_path):
    """The reproduction: the URDF names an absolute path outside; eval refuses it, in one line, before
    an episode file exists (so nothing of the secret can be in one)."""
    (run / "body" / "cf2x.urdf").write_text(urdf(str(tmp_path / "secret.obj")))
    code, output = pyflyt_forked(["eval", str(run), "episodes=1"], timeout=120)
    assert code == 2, output[-2000:]
    assert "Traceback" not in output and "mesh its URDF cf2x.urdf names" in output and "outside" in output
    assert not (run / "episodes").exists() or not any((run / "episodes").iterdir())


@pytest.mark.parametrize(
    "mesh, fragment",
    [
        ("../../secret.obj", "outside"),  # climbs out of the run
        ("link.obj", "goes through the link"),  # a link to a file outside, named *.obj
        ("inside.obj", "goes through the link"),  # a link that stays inside is still a link
        ("meshes", "a directory"),
        ("missing.obj", "No such file"),
    ],
)
def test_a_mesh_its_urdf_names_must_be_a_plain_file_of_the_run(run, tmp_path, mesh, fragment):
    (run / "body" / "inside.obj").symlink_to(run / "body" / "cf2x.obj")
    (run / "body" / "meshes").mkdir()
    (run / "body" / "cf2x.urdf").write_text(urdf(mesh))
    if mesh == "link.obj":  # the closed-world check of the directory sees a link out first
        (run / "body" / "link.obj").symlink_to(tmp_path / "secret.obj")
        refused_by_load(run, str(run / "body" / "link.obj"), "outside")
        (run / "body" / "link.obj").unlink()
        (run / "body" / "link.obj").symlink_to(run / "body" / "cf2x.obj")  # and the mesh check any link
    refused_by_load(run, "airframe.yaml", fragment)


def test_a_fifo_anywhere_in_the_run_is_refused_before_it_is_opened(run):
    if not hasattr(os, "mkfifo"):
        pytest.skip("needs FIFOs")
    (run / "body" / "cf2x.obj").unlink()
    os.mkfifo(run / "body" / "cf2x.obj")  # PyBullet blocked on it for ever
    code, output = pyflyt_forked(["eval", str(run), "episodes=1", "record=false"])
    assert code == 2, output[-2000:]
    assert "FIFO" in output and str(run / "body" / "cf2x.obj") in output and "Traceback" not in output
    deep = run / "episodes" / "a" / "b"
    os.unlink(run / "body" / "cf2x.obj")
    (run / "body" / "cf2x.obj").write_text(OBJ)
    deep.mkdir(parents=True)
    os.mkfifo(deep / "x")
    refused_by_load(run, str(deep / "x"), "FIFO")


def test_body_urdf_naming_a_directory_is_refused(run):
    spec = yaml.safe_load((run / "airframe.yaml").read_text())
    spec["body"]["urdf"] = "body"
    (run / "airframe.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    refused_by_load(run, "URDF it names", "a directory")


def test_a_urdf_whose_links_are_not_one_tree_is_refused_before_pybullet(run):
    (run / "body" / "cf2x.urdf").write_text(urdf("cf2x.obj", extra_link=True))
    refused_by_load(run, "form 2 trees")
    from pyflyt_engine.urdf import urdf_problem

    assert "form 2 trees" in urdf_problem(urdf("x.obj", extra_link=True), allow_files=True)
    assert "names the file" in urdf_problem(urdf("x.obj"))  # a recording's URDF names no file at all
    cycle = (
        '<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="fixed"><parent link="b"/><child link="c"/></joint>'
        '<joint name="j2" type="fixed"><parent link="c"/><child link="b"/></joint></robot>'
    )
    assert "cycle" in urdf_problem(cycle)


@pytest.mark.parametrize("where", ["absolute", "climbing", "inside"])
def test_an_obstacle_mesh_is_a_file_of_the_run(run, tmp_path, where):
    (run / "rock.obj").write_text(OBJ)
    file = {"absolute": str(tmp_path / "secret.obj"), "climbing": "../secret.obj", "inside": "rock.obj"}[where]
    set_config(
        run, lambda env: env.update(obstacles={"items": [{"type": "mesh", "file": file, "position": [3, 3, 0]}]})
    )
    if where == "inside":
        cfg = rundir.load_run_config(run)
        assert cfg.env.obstacles.meshes == [str(run / "rock.obj")]  # from the run, whatever the working directory
        return
    refused_by_load(run, "env.obstacles.items[0].file", "outside")


def test_a_payload_mesh_is_a_file_of_the_run_whatever_the_working_directory(run, tmp_path, monkeypatch):
    shape = {"type": "mesh", "mesh": "../secret.obj", "collision": False}
    payload = {
        "body": {"mass": 0.01, "inertia": [1e-6, 1e-6, 1e-6], "shapes": [shape, {"type": "sphere", "radius": 0.01}]}
    }
    set_config(run, lambda env: env.update(payloads=[payload]))
    monkeypatch.chdir(run)  # relative to the working directory, '../secret.obj' was outside; from the run too
    refused_by_load(run, "env.payloads[0].body.shapes[0]", "outside")


def test_a_new_run_keeps_a_copy_of_its_obstacle_mesh_and_evaluates_and_resumes_from_it(tmp_path, monkeypatch):
    """A run trained with a mesh obstacle from elsewhere reads only its own copy (``obstacle-<sha>.obj``),
    named relative in its config, so it still evaluates and resumes when moved."""
    from pyflyt_cli.main import app
    from typer.testing import CliRunner

    from .conftest import TINY_PPO, load

    (tmp_path / "rock.obj").write_text(OBJ)
    monkeypatch.chdir(tmp_path)
    mesh = "env.obstacles={items: [{type: mesh, file: rock.obj, position: [3, 3, 0]}]}"
    from pyflyt_cli.training import train

    cfg = load([*TINY_PPO, "train.total_timesteps=256", "train.eval_episodes=1", f"+{mesh}"], tmp_path / "runs")
    run = train(cfg).run_dir
    copies = sorted(p.name for p in run.glob("obstacle-*.obj"))
    assert len(copies) == 1 and (run / copies[0]).read_text() == OBJ
    recorded = yaml.safe_load((run / "config.yaml").read_text())["env"]["obstacles"]["items"][0]["file"]
    assert recorded == copies[0]  # by name: the run may move
    moved = tmp_path / "moved"
    shutil.move(run, moved)
    (tmp_path / "rock.obj").unlink()  # the original is not needed any more
    assert rundir.load_run_config(moved).env.obstacles.meshes == [str(moved / copies[0])]
    result = CliRunner().invoke(app, ["eval", str(moved), "episodes=1", "record=false"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(app, ["train", f"resume={moved}", "train.total_timesteps=512"])
    assert result.exit_code == 0, result.output  # the same digest: the mesh counts by its content
