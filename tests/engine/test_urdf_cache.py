"""The URDF cache: files are used only if they hold exactly the generated text, in a
directory only the current user can write to; anything else is rewritten or avoided."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

import pybullet as p
import pytest

from pyflyt_engine import urdf
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.urdf import generate_urdf, urdf_path
from pyflyt_engine.world import World


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """A fresh cache directory (not created yet); the per-process fallback goes under tmp_path too."""
    monkeypatch.setenv("PYFLYT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(urdf, "_private_dir", None, raising=False)
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    return tmp_path / "cache"


def built_mass(spec) -> float:
    with World([{"uav": spec}], ground=False) as world:
        return p.getDynamicsInfo(world.vehicles[0].body_id, -1, physicsClientId=world.client)[0]


def test_the_cache_directory_is_created_private_and_files_are_named_by_digest(cache):
    spec = load_uav_spec("quadx_cf2x")
    path = urdf_path(spec)
    assert path.parent == cache
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    assert spec.name not in path.name and path.read_text() == generate_urdf(spec)
    assert urdf_path(spec) == path  # reused


@pytest.mark.parametrize("tamper", ["other_mass", "truncated", "empty", "symlink"])
def test_a_tampered_cached_file_is_rewritten_before_use(cache, tmp_path, tamper):
    spec = load_uav_spec("quadx_cf2x")
    path = urdf_path(spec)
    text = path.read_text()
    if tamper == "other_mass":
        path.write_text(text.replace(f'<mass value="{spec.total_mass():.9g}"/>', '<mass value="99"/>'))
    elif tamper == "truncated":
        path.write_text(text[: len(text) // 2])
    elif tamper == "empty":
        path.write_text("")
    else:
        decoy = tmp_path / "decoy.urdf"
        decoy.write_text(text.replace(f'<mass value="{spec.total_mass():.9g}"/>', '<mass value="99"/>'))
        path.unlink()
        path.symlink_to(decoy)
    assert path.read_text() != text

    assert built_mass(spec) == pytest.approx(spec.total_mass())
    assert not path.is_symlink() and path.read_text() == text
    assert not list(cache.glob("*.tmp"))


def _refused(cache: Path, spec) -> Path:
    with pytest.warns(RuntimeWarning, match=f"URDF cache {cache}: not used because"):
        path = urdf_path(spec)
    assert cache not in path.parents
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700 and path.parent.stat().st_uid == os.getuid()
    assert path.read_text() == generate_urdf(spec)
    return path


def test_a_cache_directory_others_can_write_to_is_not_used(cache):
    cache.mkdir()
    cache.chmod(0o777)
    spec = load_uav_spec("quadx_cf2x")
    fallback = _refused(cache, spec)
    assert not list(cache.iterdir())
    assert urdf_path(spec) == fallback  # the process keeps its private directory
    assert built_mass(spec) == pytest.approx(spec.total_mass())


def test_a_symbolic_link_as_cache_directory_is_not_used(cache, tmp_path):
    target = tmp_path / "elsewhere"
    target.mkdir(mode=0o700)
    cache.symlink_to(target)
    _refused(cache, load_uav_spec("quadx_cf2x"))
    assert not list(target.iterdir())


@pytest.mark.skipif(os.geteuid() != 0, reason="giving a directory to another user needs root")
def test_a_cache_directory_owned_by_another_user_is_not_used(cache):
    cache.mkdir(mode=0o700)
    os.chown(cache, 65534, 65534)
    _refused(cache, load_uav_spec("quadx_cf2x"))
    assert not list(cache.iterdir())
