"""A simulator-only install (no ``plots`` extra) gets a message naming the extra to install
when it asks for a figure or a video, not a bare ModuleNotFoundError."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from pyflyt_engine.errors import MissingExtraError, PyFlytError
from pyflyt_engine.telemetry import video
from pyflyt_engine.telemetry.plots import plot_episode


def test_plotting_without_matplotlib_names_the_plots_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import of it now fails as if absent
    with pytest.raises(MissingExtraError, match=r"'matplotlib'.*pyflyt-toolkit\[plots\]") as caught:
        plot_episode(None, tmp_path / "episode.png")  # type: ignore[arg-type]
    assert isinstance(caught.value, PyFlytError)  # the command line reports it in one line, exit 2
    assert not (tmp_path / "episode.png").exists()


def test_writing_a_video_without_imageio_names_the_plots_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "imageio", None)
    monkeypatch.delitem(sys.modules, "imageio.v2", raising=False)
    with pytest.raises(MissingExtraError, match=r"'imageio'.*\[plots\]"):
        video.write_video(tmp_path / "flight.gif", [np.zeros((4, 4, 3), np.uint8)], 10.0)
    assert not (tmp_path / "flight.gif").exists()
