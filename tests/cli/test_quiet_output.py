"""No command prints PyBullet's build-time banner, and nothing else is hidden."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BANNER = "pybullet build time"


def _run(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env, cwd=ROOT, check=False)


@pytest.mark.parametrize(
    "args",
    [
        ("fly", "duration=0.2", "rows=2"),
        ("uav", "validate", "quadx_cf2x"),
    ],
    ids=["fly", "uav-validate"],
)
def test_commands_print_no_pybullet_banner(args):
    result = _run("-m", "pyflyt_cli.main", *args)
    assert result.returncode == 0, result.stderr
    assert BANNER not in result.stderr and BANNER not in result.stdout
    assert result.stdout.strip()  # the command's own output is there


def test_errors_after_the_import_still_reach_stderr():
    """Descriptors 1 and 2 are silenced around the import only: later writes arrive."""
    code = (
        "import os, sys\n"
        "print('before', flush=True); os.write(2, b'before-err\\n')\n"
        "from pyflyt_engine.bullet import pybullet\n"
        "print('after', flush=True); os.write(2, b'after-err\\n')\n"
        "sys.exit('error: reported')\n"
    )
    result = _run("-c", code)
    assert result.stdout.split() == ["before", "after"]
    assert result.stderr.splitlines() == ["before-err", "after-err", "error: reported"]


def test_every_module_imports_pybullet_through_the_quiet_helper():
    pattern = re.compile(r"^\s*(import pybullet\b|from pybullet\b)", re.MULTILINE)
    offenders = [
        str(path.relative_to(ROOT))
        for folder in ("pyflyt_engine", "pyflyt_cli", "experiments")
        for path in (ROOT / folder).rglob("*.py")
        if path.name != "bullet.py" and pattern.search(path.read_text())
    ]
    assert offenders == [], f"import PyBullet with `from pyflyt_engine.bullet import pybullet as p` in {offenders}"


# ----------------------------------------------------------------- help and messages


def _invoke(*args: str):
    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    return CliRunner().invoke(app, list(args), terminal_width=120)


@pytest.mark.parametrize("command", [["train"], ["replay"], ["benchmark"], ["speed"], ["export"], ["uav", "show"]])
def test_help_lists_flags_without_a_value_type(command):
    """`--verify` is a switch: no `<bool>` beside it, as if it took a value; options that
    take one keep their type."""
    result = _invoke(*command, "--help")
    assert result.exit_code == 0, result.output
    assert "<bool>" not in result.output
    assert "--help" in result.output
    if command == ["replay"]:
        assert re.search(r"--verify\s+re-simulate", result.output)
        assert re.search(r"--tolerance\s+<float>", result.output)


def test_a_bad_video_name_is_reported_once():
    from pyflyt_cli.training.schema import parse_eval_options
    from pyflyt_engine.errors import ConfigError

    with pytest.raises(ConfigError) as info:
        parse_eval_options({"video": "foo.avi"})
    message = str(info.value)
    assert message.count("foo.avi") == 1, message
    assert "video: must end in .gif or .mp4, got 'foo.avi'" in message


def test_envs_says_what_the_target_distance_is_a_fraction_of():
    result = _invoke("envs")
    assert "max_target_distance=0.9 x dome = 4.5 m" in result.output  # QuadX-Waypoints: 5 m dome
    assert "max_target_distance=0.9 x dome = 90 m" in result.output  # Fixedwing-Waypoints: 100 m dome
