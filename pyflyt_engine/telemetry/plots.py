"""Pictures of a recorded episode: :func:`plot_episode` (PNG/PDF/SVG).

Flight videos are drawn and written by :mod:`pyflyt_engine.telemetry.video`
(``render_video``, ``write_video``); this module only reads from it (``VIDEO_SUFFIXES``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pyflyt_engine.errors import TelemetryError, require
from pyflyt_engine.telemetry.episode import Episode, waypoint_markers
from pyflyt_engine.telemetry.video import VIDEO_SUFFIXES

__all__ = ["PLOT_SUFFIXES", "VIDEO_SUFFIXES", "plot_episode"]

PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def _waypoints(episode: Episode) -> np.ndarray:
    """Every marker point the ``/scene`` channel showed at the reset (e.g. all waypoints)."""
    frames = waypoint_markers(episode)
    return frames[0][1] if frames else np.zeros((0, 3))


#: what the ``/scene`` markers of a task are, in the 3-D path's legend
MARKER_LABELS = {"hover": "hover point", "waypoints": "waypoints", "gates": "gate centres"}
#: the smallest span [m] an axis of the 3-D path shows (a hover's few centimetres would
#: otherwise get ticks so dense their labels overlap)
MIN_3D_SPAN = 0.1


def _marker_label(episode: Episode, count: int) -> str:
    task = (episode.config.get("task") or {}).get("name") if isinstance(episode.config, dict) else None
    if task in MARKER_LABELS:
        return MARKER_LABELS[task]
    return "target" if count == 1 else "targets"


def _readable_3d_axes(ax3d, points: np.ndarray) -> None:
    """At least :data:`MIN_3D_SPAN` per axis around the data, at most 4 ticks a side, and
    the axis labels moved clear of the tick labels."""
    from matplotlib.ticker import MaxNLocator

    if len(points):
        low, high = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
        middle, span = (low + high) / 2, np.maximum(high - low, MIN_3D_SPAN) * 1.05
        for set_lim, m, h in zip((ax3d.set_xlim, ax3d.set_ylim, ax3d.set_zlim), middle, span / 2):
            set_lim(m - h, m + h)
    for axis in (ax3d.xaxis, ax3d.yaxis, ax3d.zaxis):
        axis.set_major_locator(MaxNLocator(nbins=4))
    ax3d.tick_params(labelsize="small", pad=1)
    ax3d.set_xlabel("x [m]", labelpad=6)
    ax3d.set_ylabel("y [m]", labelpad=6)
    ax3d.set_zlabel("z [m]", labelpad=6)


#: the actions panel's moving mean spans this much of the episode [s]
ACTION_MEAN_SECONDS = 0.25


def moving_mean(values: np.ndarray, window: int) -> np.ndarray:
    """The mean of the last ``window`` values at every index (fewer at the start): what the
    actions panel draws over the raw steps, lagging them as a flight controller's filter would."""
    values = np.asarray(values, dtype=float)
    sums = np.cumsum(np.concatenate(([0.0], values)))
    index = np.arange(1, len(values) + 1)
    start = np.maximum(index - window, 0)
    return (sums[index] - sums[start]) / (index - start)


def plot_episode(episode: Episode, out: str | Path) -> Path:
    """3-D path, altitude, attitude and actions against time, in one figure file."""
    out = Path(out)
    if out.suffix.lower() not in PLOT_SUFFIXES:
        raise TelemetryError(f"--plot file must end in one of {', '.join(PLOT_SUFFIXES)}, got {out.name}")
    matplotlib = require("matplotlib", "plots", "plotting an episode")
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(14, 9))
    ax3d = fig.add_subplot(2, 2, 1, projection="3d")
    ax_alt = fig.add_subplot(2, 2, 2)
    ax_att = fig.add_subplot(2, 2, 3)
    ax_act = fig.add_subplot(2, 2, 4)
    drawn = [np.zeros((0, 3))]
    for i, track in enumerate(episode.vehicles):
        pos = track.states["lin_pos"]
        drawn.append(pos)
        ax3d.plot(pos[:, 0], pos[:, 1], pos[:, 2], label=track.name)
        if len(pos):  # the legend names the start and end markers once
            ax3d.scatter(*pos[0], marker="o", color="green", s=30, label="start" if i == 0 else None)
            ax3d.scatter(*pos[-1], marker="x", color="red", s=40, label="end" if i == 0 else None)
        ax_alt.plot(track.time, pos[:, 2], label=f"{track.name} z")
        att = np.degrees(track.states["ang_pos"])
        for j, name in enumerate(("roll", "pitch", "yaw")):
            ax_att.plot(track.time, att[:, j], label=name if len(episode.vehicles) == 1 else f"{track.name} {name}")
    wps = _waypoints(episode)
    if len(wps):
        drawn.append(wps)
        ax3d.scatter(
            wps[:, 0],
            wps[:, 1],
            wps[:, 2],
            marker="*",
            s=110,
            color="gold",
            edgecolors="black",
            linewidths=0.6,
            depthshade=False,
            label=_marker_label(episode, len(wps)),
        )
    _readable_3d_axes(ax3d, np.concatenate(drawn))
    ax3d.set_title("path (ground frame, ENU)")
    ax3d.legend(loc="upper left", bbox_to_anchor=(-0.25, 1.0), fontsize="small")
    ax_alt.set_xlabel("time [s]")
    ax_alt.set_ylabel("altitude z [m]")
    ax_alt.set_title("altitude")
    ax_alt.grid(True, alpha=0.3)
    if len(episode.vehicles) > 1:
        ax_alt.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    ax_att.set_xlabel("time [s]")
    ax_att.set_ylabel("angle [deg]")
    ax_att.set_title("attitude (Euler)")
    ax_att.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")  # beside the data, never on it
    ax_att.grid(True, alpha=0.3)
    # each step thin and faint (a bang-bang policy's rate commands flip sign every step and
    # would fill the panel), its moving mean over ACTION_MEAN_SECONDS drawn over it
    window = max(1, round(ACTION_MEAN_SECONDS * episode.agent_hz))
    for j, name in enumerate(episode.action_names):
        if episode.length:
            (raw,) = ax_act.step(episode.action_time, episode.actions[:, j], where="post", lw=0.7, alpha=0.35)
            ax_act.step(
                episode.action_time,
                moving_mean(episode.actions[:, j], window),
                where="post",
                lw=1.8,
                color=raw.get_color(),
                label=name,
            )
    ax_act.set_xlabel("time [s]")
    ax_act.set_ylabel("applied action")
    ax_act.set_title(
        f"actions (faint: each step; bold: mean of the last {window} steps, {window / episode.agent_hz:.2g} s)"
    )
    if episode.action_names and episode.length:
        ax_act.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    ax_act.grid(True, alpha=0.3)
    end = episode.end or {}
    title = f"{episode.path.name}: return {np.nansum(episode.rewards):.4g}, {episode.length} steps"
    if end:
        title += f", end: {end.get('reason')}"
    if episode.truncated:
        title += " (file truncated)"
    fig.suptitle(title)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
