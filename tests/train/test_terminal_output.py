"""What a training run shows on a terminal: the evaluations above the progress bar."""

from __future__ import annotations

import fcntl
import os
import re
import struct
import subprocess
import sys
import termios

import pytest

from tests.train.conftest import ROOT, TINY_PPO, cli_env


def _on_a_terminal(args: list[str], cwd, timeout: float = 300) -> tuple[int, str]:
    """Run ``python -m pyflyt_cli.main <args>`` with stdout and stderr on a pseudo-terminal."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))  # 40 rows, 120 columns
    proc = subprocess.Popen(
        [sys.executable, "-m", "pyflyt_cli.main", *args],
        cwd=cwd,
        env=cli_env(),
        stdin=subprocess.DEVNULL,
        stdout=slave,
        stderr=slave,
    )
    os.close(slave)
    chunks = []
    try:
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:  # EIO: the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
    finally:
        os.close(master)
    return proc.wait(timeout=timeout), b"".join(chunks).decode(errors="replace")


@pytest.mark.long
def test_evaluations_are_printed_above_the_progress_bar_on_a_terminal(tmp_path):
    args = ["train", *[o for o in TINY_PPO if not o.startswith("train.progress_bar")], f"train.output_dir={tmp_path}"]
    code, shown = _on_a_terminal(args, ROOT)
    assert code == 0, shown
    # tqdm's bar was drawn, with the run's ETA (timing.RunEta) where tqdm's own would be
    assert re.search(r"\d+/512 \[[\d:]+, +[\d.]+ ?\w*step/s, ETA [\d:]+", shown), shown
    assert re.search(r"512/512 \[[\d:]+, +[\d.]+ ?\w*step/s, ETA 0:00", shown), shown  # it ends at 0:00
    lines = [re.sub(r".*\r", "", line) for line in shown.replace("\r\n", "\n").split("\n")]
    evals = [line for line in lines if "eval return" in line]
    assert len(evals) == 2, shown
    first = re.fullmatch(
        # the task's own measures (hover: the distance held) between the length and the rate
        r"step 256/512: eval return -?[\d.]+ ± [\d.]+, success \d+ %, length \d+, distance_mean [\d.]+ m, "
        r"distance_max [\d.]+ m \(\d+ steps/s, ETA \d+:\d\d\)",
        evals[0].strip(),
    )
    assert first, evals[0]
    assert evals[1].strip().startswith("step 512/512: eval return") and "ETA" not in evals[1]  # nothing left
