"""A file the toolkit writes in place inside a benchmark or a study -- a run's log it appends to, the
lock file it rewrites, the study's database -- is refused when it is a link or a hard link: writing
to it would write to the file outside that shares it.

Written from the reproduction: in a shared benchmark directory whose ``logs/<run>.log`` was a hard
link to a file elsewhere, ``pyflyt benchmark`` appended the run's output to that file (a hard link
is the same file under a second name: no path check sees it; its link count does).
"""

from __future__ import annotations

import os
from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

from pyflyt_cli.benchmark.run import open_log
from pyflyt_cli.errors import UsageError
from pyflyt_cli.main import app
from pyflyt_cli.training.rundir import RunDirError
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.safe_load import check_own_file, open_own_file

SMOKE = ["benchmark", "experiment=smoke_benchmark", "seeds=1"]
LOG = "quadx_hover__ppo__seed0.log"  # the first run of smoke_benchmark


def precious(tmp_path: Path) -> Path:
    path = tmp_path / "precious.txt"
    path.write_text("kept\n")
    return path


@pytest.mark.parametrize("entry", [f"logs/{LOG}", "benchmark.lock"])
def test_benchmark_refuses_a_hard_link_it_would_write_before_it_writes_anything(tmp_path, entry):
    outside = precious(tmp_path)
    root = tmp_path / "smoke_benchmark"
    (root / "logs").mkdir(parents=True)
    os.link(outside, root / entry)
    for extra in ([], ["--dry-run"]):
        result = CliRunner().invoke(app, [*SMOKE, f"benchmark.output_dir={tmp_path}", *extra])
        assert result.exit_code == 2, result.output
        assert "Traceback" not in result.output and isinstance(result.exception, SystemExit)
        assert f"{root / entry}: " in result.output and "has 2 names (a hard link" in result.output
    assert outside.read_text() == "kept\n" and os.stat(outside).st_nlink == 2
    assert not (root / "runs").exists()  # nothing was trained


def test_a_log_opened_by_a_launcher_worker_is_checked_when_it_is_opened(tmp_path):
    """A Hydra launcher's worker opens its run's log itself (``run_job``): the check is in the opening."""
    outside = precious(tmp_path)
    log = tmp_path / "logs" / LOG
    log.parent.mkdir()
    plan = SimpleNamespace(log_file=lambda job: log)
    os.link(outside, log)
    with pytest.raises(UsageError, match="has 2 names"):
        open_log(plan, None)
    log.unlink()
    log.symlink_to(outside)
    with pytest.raises(UsageError, match="is a symbolic link"):
        open_log(plan, None)
    log.unlink()
    path, handle = open_log(plan, None)  # its own file: created, then appended to
    with handle:
        handle.write(b"line\n")
    _, handle = open_log(plan, None)
    with handle:
        handle.write(b"more\n")
    assert log.read_bytes() == b"line\nmore\n" and outside.read_text() == "kept\n"


def test_open_own_file_refuses_links_and_special_files_and_writes_nothing(tmp_path):
    outside = precious(tmp_path)
    os.link(outside, tmp_path / "hard")
    (tmp_path / "soft").symlink_to(outside)
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "folder").mkdir()
    for name, fragment in [("hard", "has 2 names"), ("soft", "symbolic link"), ("fifo", "FIFO"),
                           ("folder", "directory")]:  # fmt: skip
        with pytest.raises(ConfigError, match=fragment):
            os.close(open_own_file(tmp_path / name, append=True))
        with pytest.raises(ConfigError, match=fragment):
            check_own_file(tmp_path / name)
    assert outside.read_text() == "kept\n"
    fd = open_own_file(tmp_path / "new", append=True)
    os.write(fd, b"x")
    os.close(fd)
    check_own_file(tmp_path / "new")
    check_own_file(tmp_path / "missing")  # nothing there: nothing to refuse
    assert (tmp_path / "new").read_bytes() == b"x"


def test_a_study_refuses_a_hard_linked_lock_or_database(tmp_path):
    from pyflyt_cli.training.tune import _study, _study_lock

    outside = precious(tmp_path)
    study = tmp_path / "study"
    study.mkdir()
    os.link(outside, study / "tune.lock")  # the lock used to be rewritten with write_text: truncated
    with pytest.raises(RunDirError, match="tune.lock: the study lock file has 2 names"):
        with _study_lock(study):
            pass
    (study / "tune.lock").unlink()
    os.link(outside, study / "study.db")  # SQLite writes its database in place
    with pytest.raises(RunDirError, match="study.db: the study database has 2 names"):
        _study(study, "quadx_hover", "ppo", None)
    assert outside.read_text() == "kept\n"
