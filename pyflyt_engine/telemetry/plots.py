"""Pictures of a recorded episode: :func:`plot_episode` (PNG/PDF/SVG), :func:`write_video` (MP4/GIF).

Flight videos themselves are drawn by :mod:`pyflyt_engine.telemetry.video` (``render_video``).
"""

from __future__ import annotations

import errno
from pathlib import Path

import numpy as np

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.telemetry.episode import Episode
from pyflyt_engine.telemetry.video import VIDEO_SUFFIXES, render_video

PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def _waypoints(episode: Episode) -> np.ndarray:
    """Every marker point the ``/scene`` channel showed at the reset (e.g. all waypoints)."""
    frames = _marker_frames(episode)
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


def write_video(out: Path, frames: list[np.ndarray], fps: float) -> None:
    """Write RGB(A) frames to ``out`` (``.gif`` or ``.mp4``, by its suffix) at ``fps``.

    Raises:
        TelemetryError: MP4 without a working imageio-ffmpeg.
        OSError: the file could not be written completely (an MP4 is checked: ffmpeg's
            own failures are not reported by imageio).
    """
    import imageio.v2 as imageio

    frames = [np.asarray(f)[..., :3] for f in frames]
    if Path(out).suffix.lower() == ".gif":
        imageio.mimsave(out, frames, format="GIF", duration=1000.0 / fps, loop=0)
        return
    try:
        writer = imageio.get_writer(
            out, format="FFMPEG", fps=fps, codec="libx264", quality=7, macro_block_size=1, pixelformat="yuv420p"
        )
    except Exception as exc:  # noqa: BLE001 - imageio-ffmpeg missing or broken
        raise TelemetryError(f"cannot write {Path(out).name}: MP4 needs imageio-ffmpeg ({exc}); try a .gif") from None
    with writer:
        for frame in frames:
            writer.append_data(frame)
    _check_mp4(Path(out))


def _check_mp4(path: Path) -> None:
    """Raise OSError unless ``path`` is a complete MP4: its top-level boxes fill the file
    exactly and include the index (``moov``).

    The encoder runs in an ffmpeg process whose failure (a full disk, a file-size limit)
    imageio does not report: without this check a cut-off video would pass for a good one.
    """
    size = path.stat().st_size
    kinds = []
    with path.open("rb") as handle:
        offset = 0
        while offset < size:
            handle.seek(offset)
            header = handle.read(16)
            if len(header) < 8:
                break
            length, kind = int.from_bytes(header[:4], "big"), header[4:8]
            if length == 1 and len(header) == 16:  # 64-bit box size
                length = int.from_bytes(header[8:16], "big")
            elif length == 0:  # the last box, to the end of the file
                length = size - offset
            if length < 8:
                break
            kinds.append(kind)
            offset += length
    if offset != size or b"moov" not in kinds:
        raise OSError(
            errno.EIO,
            "the video encoder (ffmpeg) stopped before the video was complete (a full disk or a file-size limit?)",
        )


def _marker_frames(episode: Episode) -> list[tuple[float, np.ndarray]]:
    out = []
    for m in episode.contents.messages:
        if m.topic != "/scene" or not isinstance(m.data, dict):
            continue
        for entity in m.data.get("entities", []):
            if entity.get("id") == "waypoints":
                pts = [s["pose"]["position"] for s in entity.get("spheres", [])]
                out.append((m.log_time * 1e-9, np.array([[q["x"], q["y"], q["z"]] for q in pts]).reshape(-1, 3)))
    return out


def _marker_radius(episode: Episode) -> float:
    for m in episode.contents.messages:
        if m.topic == "/scene" and isinstance(m.data, dict):
            for entity in m.data.get("entities", []):
                if entity.get("id") == "waypoints":
                    for sphere in entity.get("spheres", []):
                        return float(sphere["size"]["x"]) / 2
    return 0.05
