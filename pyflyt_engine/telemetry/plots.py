"""Pictures of a recorded episode: :func:`plot_episode` (PNG/PDF/SVG).

Flight videos are drawn and written by :mod:`pyflyt_engine.telemetry.video`
(``render_video``, ``write_video``); this module only reads from it (``VIDEO_SUFFIXES``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry.episode import Episode, waypoint_markers
from pyflyt_engine.telemetry.video import VIDEO_SUFFIXES

__all__ = ["PLOT_SUFFIXES", "VIDEO_SUFFIXES", "plot_episode"]

PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def _waypoints(episode: Episode) -> np.ndarray:
    """Every marker point the ``/scene`` channel showed at the reset (e.g. all waypoints)."""
    frames = waypoint_markers(episode)
    return frames[0][1] if frames else np.zeros((0, 3))


def plot_episode(episode: Episode, out: str | Path) -> Path:
    """3-D path, altitude, attitude and actions against time, in one figure file."""
    out = Path(out)
    if out.suffix.lower() not in PLOT_SUFFIXES:
        raise TelemetryError(f"--plot file must end in one of {', '.join(PLOT_SUFFIXES)}, got {out.name}")
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(13, 9))
    ax3d = fig.add_subplot(2, 2, 1, projection="3d")
    ax_alt = fig.add_subplot(2, 2, 2)
    ax_att = fig.add_subplot(2, 2, 3)
    ax_act = fig.add_subplot(2, 2, 4)
    for track in episode.vehicles:
        pos = track.states["lin_pos"]
        ax3d.plot(pos[:, 0], pos[:, 1], pos[:, 2], label=track.name)
        if len(pos):
            ax3d.scatter(*pos[0], marker="o", color="green")
            ax3d.scatter(*pos[-1], marker="x", color="red")
        ax_alt.plot(track.time, pos[:, 2], label=f"{track.name} z")
        att = np.degrees(track.states["ang_pos"])
        for j, name in enumerate(("roll", "pitch", "yaw")):
            ax_att.plot(track.time, att[:, j], label=name if len(episode.vehicles) == 1 else f"{track.name} {name}")
    wps = _waypoints(episode)
    if len(wps):
        ax3d.scatter(wps[:, 0], wps[:, 1], wps[:, 2], marker="*", s=80, color="tab:green", label="waypoints")
    ax3d.set_xlabel("x [m]")
    ax3d.set_ylabel("y [m]")
    ax3d.set_zlabel("z [m]")
    ax3d.set_title("path (ground frame, ENU)")
    ax3d.legend(loc="upper left", fontsize="small")
    ax_alt.set_xlabel("time [s]")
    ax_alt.set_ylabel("altitude z [m]")
    ax_alt.set_title("altitude")
    ax_alt.grid(True, alpha=0.3)
    ax_att.set_xlabel("time [s]")
    ax_att.set_ylabel("angle [deg]")
    ax_att.set_title("attitude (Euler)")
    ax_att.legend(fontsize="small")
    ax_att.grid(True, alpha=0.3)
    for j, name in enumerate(episode.action_names):
        if episode.length:
            ax_act.step(episode.action_time, episode.actions[:, j], where="post", label=name)
    ax_act.set_xlabel("time [s]")
    ax_act.set_ylabel("applied action")
    ax_act.set_title("actions")
    ax_act.legend(fontsize="small")
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
