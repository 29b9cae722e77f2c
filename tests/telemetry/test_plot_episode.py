"""The `replay --plot` figure: what its legends name and where they sit."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pytest

from pyflyt_engine.telemetry import plots
from pyflyt_engine.telemetry.episode import load_episode
from tests.telemetry.conftest import record


def _figure(env_id, tmp_path, monkeypatch):
    env, _ = record(env_id, tmp_path / "rec", max_steps=30)
    kept = {}
    monkeypatch.setattr(plt, "close", lambda fig: kept.setdefault("fig", fig))
    plots.plot_episode(load_episode(env.paths[0]), tmp_path / "plot.png")
    fig = kept["fig"]
    fig.canvas.draw()
    return fig


@pytest.mark.parametrize(
    ("env_id", "marker"), [("PyFlyt/QuadX-Hover-v0", "hover point"), ("PyFlyt/QuadX-Waypoints-v0", "waypoints")]
)
def test_the_path_legend_names_the_markers_and_the_legends_sit_beside_the_data(env_id, marker, tmp_path, monkeypatch):
    fig = _figure(env_id, tmp_path, monkeypatch)
    ax3d, _, ax_att, ax_act = fig.axes[:4]
    labels = [t.get_text() for t in ax3d.get_legend().get_texts()]
    assert labels == ["quadx_cf2x", "start", "end", marker]
    for ax in (ax_att, ax_act):  # the legend is outside the plotting area
        legend = ax.get_legend().get_window_extent()
        assert legend.x0 >= ax.get_window_extent().x1
    ticks = []
    for axis in (ax3d.xaxis, ax3d.yaxis, ax3d.zaxis):  # the ones drawn: within the axis's limits
        low, high = sorted(axis.get_view_interval())
        ticks += [t.label1 for t in axis.get_major_ticks() if low <= t.get_loc() <= high and t.label1.get_text()]
    assert ticks
    boxes = [t.get_window_extent() for t in ticks]
    for i, a in enumerate(boxes):  # no two tick labels of the 3-D axes overlap
        for b in boxes[i + 1 :]:
            assert not a.overlaps(b), [t.get_text() for t in ticks]
    plt.close("all")


def test_the_actions_panel_draws_each_step_faintly_and_its_moving_mean_over_it(tmp_path, monkeypatch):
    import numpy as np

    fig = _figure("PyFlyt/QuadX-Hover-v0", tmp_path, monkeypatch)
    ax_act = fig.axes[3]
    episode = load_episode(next((tmp_path / "rec").glob("*.mcap")))
    window = max(1, round(plots.ACTION_MEAN_SECONDS * episode.agent_hz))
    lines = ax_act.get_lines()
    assert len(lines) == 2 * len(episode.action_names)
    for j in range(len(episode.action_names)):
        raw, mean = lines[2 * j], lines[2 * j + 1]
        assert raw.get_alpha() < 0.5 and mean.get_linewidth() > raw.get_linewidth()
        values = episode.actions[:, j]
        by_hand = [values[max(0, i + 1 - window) : i + 1].mean() for i in range(len(values))]  # the last `window` steps
        np.testing.assert_allclose(mean.get_ydata(), by_hand, rtol=1e-12)
    assert [t.get_text() for t in ax_act.get_legend().get_texts()] == list(episode.action_names)
    plt.close("all")


def test_a_moving_mean_of_a_sign_flipping_command_is_its_average():
    import numpy as np

    flips = np.array([1.0, -1.0] * 20)
    mean = plots.moving_mean(flips, 8)
    assert mean[0] == 1.0 and mean[1] == 0.0
    np.testing.assert_allclose(mean[8:], 0.0, atol=1e-12)  # an even window over +1, -1, ...: zero
