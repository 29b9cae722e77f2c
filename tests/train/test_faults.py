"""A full disk, a file-size limit or a read-only folder stops a run with one message, never a hang.

Tests run as root, for whom permissions do not stop writes, so the faults are made
two ways: a file-size limit on the training process (``RLIMIT_FSIZE``: writes past it
fail with EFBIG, as on a full disk) and injected ``OSError``s.
"""

from __future__ import annotations

import errno
import multiprocessing
import resource
import subprocess
import sys

import pytest

from pyflyt_cli.training import artifacts, resume, train
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry.metrics import MetricsWriter

from .conftest import TINY_PPO, cli_env, load, pyflyt


def _limit_file_size(limit: int):
    return lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))


@pytest.mark.long
def test_a_write_failure_stops_the_command_with_one_message_and_the_run_resumes(tmp_path):
    root = tmp_path / "runs"
    overrides = [*TINY_PPO, f"train.output_dir={root}"]
    # 100 kB: the configuration, metrics and best model fit; the first checkpoint does not
    proc = subprocess.run(  # noqa: PLW1510
        [sys.executable, "-m", "pyflyt_cli.main", "train", *overrides],
        cwd=tmp_path,
        env=cli_env(),
        capture_output=True,
        text=True,
        preexec_fn=_limit_file_size(100_000),
    )
    assert proc.returncode == 2, proc.stderr
    assert "error: cannot write" in proc.stderr and "Traceback" not in proc.stderr
    assert "pyflyt train resume=" in proc.stderr
    run = next(root.glob("*/*/*"))
    written = [p for p in run.rglob("*") if p.is_file()]
    assert not [p for p in written if ".tmp" in p.name], "no temporary file is left behind"
    assert all(p.stat().st_size > 0 for p in written), "no empty final file"
    assert (run / "state.json").read_text().count('"failed"') == 1
    again = pyflyt(["train", f"resume={run}"], cwd=tmp_path)  # without the limit
    assert again.returncode == 0, again.stderr
    assert '"complete"' in (run / "state.json").read_text()


def test_a_failing_close_does_not_hide_the_error_nor_leave_workers_running(tmp_path, monkeypatch):
    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(artifacts, "_save_torch", lambda data: full)  # every checkpoint and policy file
    monkeypatch.setattr(MetricsWriter, "close", full)  # and the metrics file
    with pytest.raises(ConfigError, match="No space left on device") as info:
        train(load([*TINY_PPO, "train.n_envs=2", "train.vec_env=subproc", "algo.n_steps=128"], tmp_path))
    assert "pyflyt train resume=" in str(info.value)
    assert multiprocessing.active_children() == []  # the SubprocVecEnv workers were closed
    monkeypatch.undo()
    run = next(tmp_path.glob("*/*/*/config.yaml")).parent
    assert not resume(run).interrupted
