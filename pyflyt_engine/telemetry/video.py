"""Flight videos of recorded episodes: what ``pyflyt replay --video`` and ``pyflyt eval video=`` write.

Each frame is drawn from a recording (kinematic playback: the vehicles are posed at
their recorded states in the rebuilt world, no physics), so evaluation videos and
replays look the same and any recording can be filmed again:

* a **chase camera** that frames the vehicles: centred on the vehicle, behind its
  (smoothed) heading, 45 degrees above the horizon looking down, at the distance where the
  airframe's span fills 30 % of the frame's height (at least 0.6 m, from where the ground
  1 m below is still in view); with several vehicles it looks at their centroid from far
  enough to keep all in view;
* the **ground and sky** drawn in NumPy (one ray per pixel of a half-size image) where no
  body shows, with each vehicle's **shadow** and a **drop line** to it; PyBullet's ground
  plane is parked out of view, as TinyRenderer spent most of each frame drawing it;
* the task's markers as **wireframe spheres** of the reach radius drawn over the image,
  so a vehicle inside one stays visible;
* **translucent** scenery (gates): PyBullet's TinyRenderer draws every body opaque (it
  ignores the alpha of a colour), so a frame with translucent bodies is rendered twice,
  with and without them, and the two images are blended where the segmentation mask
  shows such a body, with that body's own alpha;
* a **trail** of each vehicle's recent path, fading with age, drawn over the image;
* an **overlay** with the time, the step, the step reward, the return and, at the end,
  the episode's outcome (held on screen for a second).
"""

from __future__ import annotations

import errno
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pyflyt_engine.errors import TelemetryError, require
from pyflyt_engine.telemetry.episode import Episode, waypoint_markers, waypoint_radius

VIDEO_SUFFIXES = (".mp4", ".gif")
#: Trail colours per vehicle (RGB), cycled.
TRAIL_COLORS = ((255, 140, 0), (0, 170, 255), (230, 60, 200), (60, 200, 90), (240, 220, 40))
#: Where hidden bodies are parked while the frame without them is drawn [m].
_PARKED = (0.0, 0.0, -1000.0)


@dataclass(frozen=True)
class VideoStyle:
    """How a flight video is framed and drawn."""

    #: the vehicle's span (the largest horizontal extent of the airframe) fills this fraction
    #: of the frame's height: the chase distance follows the airframe, so a 13 cm Crazyflie
    #: and a 1.5 m fixed-wing are both drawn at a readable size (at 1.2 m a Crazyflie was
    #: 25-30 px of a 480 px frame)
    frame_fraction: float = 0.3
    #: the camera never comes closer than this [m]: far enough that, at the elevation below,
    #: the ground under a vehicle flying 1 m up stays in the frame (its shadow: its height)
    min_distance: float = 0.6
    #: camera elevation above the horizon, looking down at the vehicle from above and
    #: behind [deg]: steep enough that the vehicle's height over its shadow shows, and that
    #: the shadow 1 m below stays in view from ``min_distance``
    elevation_deg: float = 45.0
    #: time constant of the camera's smoothing of the heading and the vehicles' spread [s]
    smoothing: float = 0.3
    #: vertical field of view [deg]
    fov: float = 60.0
    #: length of the trail of the recent path [s]
    trail_seconds: float = 3.0
    #: the last frame is held this long, showing the outcome [s]
    hold_seconds: float = 1.0
    #: width of the trail, as a fraction of the frame width (480 px: 4 px)
    trail_width: float = 1 / 120
    #: height of the overlay's text, as a fraction of the frame width (480 px: 21 px)
    text_size: float = 1 / 23


def vehicle_span(client: int, body: int) -> float:
    """The largest horizontal extent [m] of a body's axis-aligned bounding box (every link)."""
    from pyflyt_engine.bullet import pybullet as p

    lows, highs = [], []
    for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
        low, high = p.getAABB(body, link, physicsClientId=client)
        lows.append(low)
        highs.append(high)
    extent = np.max(highs, axis=0) - np.min(lows, axis=0)
    return float(max(extent[0], extent[1], 0.05))


def outcome_text(episode: Episode) -> tuple[str, tuple[int, int, int]]:
    """How the episode ended, for the overlay, and its colour (green success, red failure)."""
    end = episode.end
    if end is None:
        return "recording cut short", (230, 200, 60)
    reason = str(end.get("reason") or end.get("event") or "ended").replace("_", " ")
    if end.get("success"):
        return f"success ({reason})", (80, 220, 100)
    if reason in ("time limit", "stopped"):
        return reason, (230, 230, 230)
    return f"failed: {reason}", (240, 80, 70)


def _matrices(view: Sequence[float], projection: Sequence[float]) -> np.ndarray:
    """The 4 x 4 clip-from-world matrix of PyBullet's column-major view and projection."""
    return np.asarray(projection, dtype=float).reshape(4, 4).T @ np.asarray(view, dtype=float).reshape(4, 4).T


def project(clip_from_world: np.ndarray, points: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pixel coordinates (n, 2) of world points (n, 3); NaN for points behind the camera."""
    homogeneous = np.c_[points, np.ones(len(points))] @ clip_from_world.T
    w = homogeneous[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = homogeneous[:, :2] / w[:, None]
    pixels = np.c_[(ndc[:, 0] + 1.0) * 0.5 * width, (1.0 - ndc[:, 1]) * 0.5 * height]
    pixels[w <= 1e-6] = np.nan
    return pixels


class ChaseCamera:
    """Smoothed chase camera over one or more vehicles (see the module docstring)."""

    def __init__(self, style: VideoStyle, span: float, dt: float) -> None:
        self.style = style
        self.span = span
        self._gain = 1.0 - math.exp(-dt / style.smoothing) if style.smoothing > 0 else 1.0
        self.target: np.ndarray | None = None
        self.yaw = 0.0
        self.spread = 0.0

    def update(self, positions: np.ndarray, yaw: float | None) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """(eye, target) for vehicles at ``positions`` (n, 3); ``yaw``: the heading to look
        along (None: keep the current one)."""
        centroid = positions.mean(axis=0)
        spread = float(np.max(np.linalg.norm(positions - centroid, axis=1))) if len(positions) > 1 else 0.0
        if self.target is None:
            self.target, self.spread = centroid, spread
            self.yaw = yaw if yaw is not None else 0.0
        else:
            k = self._gain  # the target follows exactly: a lagging camera loses fast vehicles
            self.target = centroid
            self.spread += k * (spread - self.spread)
            if yaw is not None:  # along the shorter way round
                self.yaw += k * ((yaw - self.yaw + math.pi) % (2 * math.pi) - math.pi)
        s = self.style
        half_fov = math.radians(s.fov) / 2
        # the span fills frame_fraction of the frame's height, 2 d tan(fov / 2) at distance d;
        # several vehicles: far enough for all of them
        framed = self.span / (s.frame_fraction * 2 * math.tan(half_fov))
        distance = max(s.min_distance, framed, 1.4 * (self.spread + self.span) / math.tan(half_fov))
        elevation = math.radians(s.elevation_deg)
        x, y, z = self.target
        eye = (
            x - distance * math.cos(self.yaw) * math.cos(elevation),
            y - distance * math.sin(self.yaw) * math.cos(elevation),
            z + distance * math.sin(elevation),
        )
        return eye, (float(x), float(y), float(z))


def episode_frames(
    episode: Episode, size: tuple[int, int] | None = None, style: VideoStyle | None = None
) -> Iterator[np.ndarray]:
    """(H, W, 3) uint8 frames of the recorded flight, one per recorded state, then the
    last one held for ``style.hold_seconds``.  ``size`` is (width, height) in pixels
    (default: the env config's render resolution)."""
    from PIL import Image, ImageDraw

    from pyflyt_engine.bullet import pybullet as p
    from pyflyt_engine.spec import parse_uav_spec
    from pyflyt_engine.telemetry.replay import rebuild_env

    style = style or VideoStyle()
    render = episode.config.get("render", {}) or {}
    if size is None:
        h, w = render.get("resolution", (480, 480))
        size = (int(w), int(h))
    width, height = size
    tracks = episode.vehicles
    if not tracks or not len(tracks[0].time):
        raise TelemetryError(f"{episode.path}: no recorded states to render")
    env = rebuild_env(episode)
    try:
        world = env.unwrapped.world
        client = world.client
        bodies = [v.body_id for v in world.vehicles]
        for i in range(len(bodies), len(tracks)):  # vehicles the env does not build itself
            spec = parse_uav_spec(episode.uav_specs[i], source=f"{episode.path} (vehicle {i})")
            bodies.append(world.vehicles[world.add_vehicle(spec, tuple(tracks[i].states["lin_pos"][0]))].body_id)
        marker_frames = waypoint_markers(episode)
        reach = waypoint_radius(episode)
        ground = getattr(world, "ground_id", None)
        if ground is not None:  # drawn by _ground_image instead: TinyRenderer spends most of a frame on it
            p.resetBasePositionAndOrientation(ground, _PARKED, (0.0, 0.0, 0.0, 1.0), physicsClientId=client)
        translucent = _translucent_bodies(client, set(bodies))
        spans = [vehicle_span(client, b) for b in bodies]
        span = max(spans)
        dt = 1.0 / episode.agent_hz
        camera = ChaseCamera(style, span, dt)
        projection = p.computeProjectionMatrixFOV(style.fov, width / height, 0.02, 500.0, physicsClientId=client)
        returns = np.concatenate([[0.0], np.cumsum(np.nan_to_num(episode.rewards))])
        outcome, outcome_color = outcome_text(episode)
        trail_steps = max(2, round(style.trail_seconds / dt))
        n_steps = len(tracks[0].time)
        marker_points = np.zeros((0, 3))
        frame = None
        for step in range(n_steps):
            t = float(tracks[0].time[step])
            live = [i for i, track in enumerate(tracks) if step < len(track.time)]
            for i in live:
                track = tracks[i]
                p.resetBasePositionAndOrientation(
                    bodies[i], track.states["lin_pos"][step].tolist(), track.states["quaternion"][step].tolist(),
                    physicsClientId=client,
                )  # fmt: skip
            current = max((k for k, (mt, _) in enumerate(marker_frames) if mt <= t + 1e-9), default=-1)
            if current >= 0:
                marker_points = marker_frames[current][1]
            positions = np.array([tracks[i].states["lin_pos"][step] for i in live])
            yaw = float(tracks[0].states["ang_pos"][step][2]) if len(tracks) == 1 else None
            eye, target = camera.update(positions, yaw)
            view = p.computeViewMatrix(eye, target, (0.0, 0.0, 1.0), physicsClientId=client)
            clip = _matrices(view, projection)
            image, segmentation = _render_blended(client, width, height, view, projection, translucent)
            if ground is not None:  # the ground, with each vehicle's shadow, where no body is drawn
                backdrop = _ground_image(clip, np.asarray(eye), width, height)
                _draw_shadows(backdrop, clip, positions, [spans[i] for i in live], width, height)
                empty = segmentation < 0
                image = np.where(empty[:, :, None], np.asarray(backdrop), image)
            canvas = Image.fromarray(image).convert("RGBA")
            overlay = Image.new("RGBA", canvas.size, (0, 0, 0, 0))
            draw = ImageDraw.Draw(overlay)
            line = max(2, round(width * style.trail_width))
            if ground is not None:
                for position in positions:  # a drop line from each vehicle to its shadow: its height
                    ends = project(clip, np.array([position, [position[0], position[1], 0.0]]), width, height)
                    if not np.isnan(ends).any():
                        draw.line([tuple(ends[0]), tuple(ends[1])], fill=(255, 255, 255, 150), width=max(1, line // 2))
            _draw_targets(draw, clip, marker_points, reach, width, height, max(1, line // 2))
            for i in live:
                start = max(0, step - trail_steps)
                path = project(clip, tracks[i].states["lin_pos"][start : step + 1], width, height)
                _draw_trail(draw, path, TRAIL_COLORS[i % len(TRAIL_COLORS)], line)
            reward = float(episode.rewards[step - 1]) if 0 < step <= len(episode.rewards) else 0.0
            lines = [
                f"t {t - float(tracks[0].time[0]):6.2f} s   step {step}",
                f"reward {reward:+.3f}   return {returns[min(step, len(returns) - 1)]:+.2f}",
            ]
            ended = step == n_steps - 1
            _draw_text(draw, lines, outcome if ended else None, outcome_color, width, height, style.text_size)
            frame = np.asarray(Image.alpha_composite(canvas, overlay).convert("RGB"))
            yield frame
        for _ in range(round(style.hold_seconds / dt)):
            yield frame  # type: ignore[misc]
    finally:
        env.close()


def _translucent_bodies(client: int, vehicles: set[int]) -> dict[int, float]:
    """Body id -> alpha of every body (not a vehicle) drawn with a colour alpha below 1."""
    from pyflyt_engine.bullet import pybullet as p

    out = {}
    for k in range(p.getNumBodies(physicsClientId=client)):
        body = p.getBodyUniqueId(k, physicsClientId=client)
        if body in vehicles:
            continue
        shapes = p.getVisualShapeData(body, physicsClientId=client)
        alphas = [float(s[7][3]) for s in shapes]
        if alphas and max(alphas) < 1.0:
            out[body] = max(alphas)
    return out


def _camera(client: int, width: int, height: int, view, projection) -> tuple[np.ndarray, np.ndarray]:
    from pyflyt_engine.bullet import pybullet as p

    _, _, rgba, _, segmentation = p.getCameraImage(
        width, height, view, projection, renderer=p.ER_TINY_RENDERER, physicsClientId=client
    )
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    return rgb, np.asarray(segmentation).reshape(height, width)


def _render_blended(
    client: int, width: int, height: int, view, projection, translucent: dict[int, float]
) -> tuple[np.ndarray, np.ndarray]:
    """The frame with every translucent body blended in with its alpha (see the module docstring),
    and its segmentation mask (-1: no body)."""
    from pyflyt_engine.bullet import pybullet as p

    with_them, segmentation = _camera(client, width, height, view, projection)
    alpha = np.zeros((height, width))
    for body, a in translucent.items():
        alpha[segmentation == body] = a
    if not alpha.any():
        return with_them, segmentation
    poses = {b: p.getBasePositionAndOrientation(b, physicsClientId=client) for b in translucent}
    for body in translucent:
        p.resetBasePositionAndOrientation(body, _PARKED, (0.0, 0.0, 0.0, 1.0), physicsClientId=client)
    try:
        behind, segmentation_behind = _camera(client, width, height, view, projection)
    finally:
        for body, (position, orientation) in poses.items():
            p.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=client)
    blended = behind + alpha[:, :, None] * (with_them.astype(float) - behind)
    # the pixels showing nothing but translucent bodies and the empty background count as empty
    segmentation = np.where(alpha > 0, segmentation_behind, segmentation)
    return np.clip(np.rint(blended), 0, 255).astype(np.uint8), segmentation


#: the backdrop's colours (RGB): sky at the horizon and overhead, the two ground tiles, grid lines
SKY_HORIZON, SKY_TOP = np.array([205, 220, 235]), np.array([120, 160, 210])
GROUND_LIGHT, GROUND_DARK, GROUND_LINE = np.array([170, 175, 160]), np.array([150, 156, 140]), np.array([95, 100, 90])
#: tile size of the ground's checker [m] (a grid line every tile)
GROUND_TILE = 1.0


def _ground_image(clip_from_world: np.ndarray, eye: np.ndarray, width: int, height: int):
    """The sky and the ground plane (z = 0: 1 m checker tiles and grid lines, fading into the
    haze with distance) as seen by the camera, a PIL image: one ray per pixel of a half-size
    image, intersected with the plane in NumPy and scaled up, in milliseconds where
    TinyRenderer takes most of a frame to draw the ground."""
    from PIL import Image

    full = (width, height)
    width, height = max(1, width // 2), max(1, height // 2)

    m = np.linalg.inv(clip_from_world).astype(np.float32)
    u = ((np.arange(width, dtype=np.float32) + 0.5) / width * 2.0 - 1.0)[None, :, None]
    v = (1.0 - (np.arange(height, dtype=np.float32) + 0.5) / height * 2.0)[:, None, None]
    far = u * m[:, 0] + v * m[:, 1] + (m[:, 2] + m[:, 3])  # the far-plane point of each pixel's ray (homogeneous)
    ray = far[..., :3] / far[..., 3:4] - eye.astype(np.float32)
    ray /= np.sqrt(np.einsum("...i,...i", ray, ray))[..., None]
    rz = ray[..., 2]
    down = rz < -1e-6
    reach = np.where(down, -float(eye[2]) / np.where(down, rz, -1.0), np.float32(1e6))
    hx = float(eye[0]) + reach * ray[..., 0]
    hy = float(eye[1]) + reach * ray[..., 1]
    tile = (np.floor(hx / GROUND_TILE) + np.floor(hy / GROUND_TILE)) % 2
    # a grid line where the hit point lies within ~1 pixel of a tile edge (wider far away)
    edge = np.minimum(np.abs(hx - np.round(hx)), np.abs(hy - np.round(hy)))
    line = edge < np.maximum(0.01, 1.2 * reach / height)
    ground = np.where(tile[..., None] == 0, GROUND_LIGHT, GROUND_DARK).astype(np.float32)
    ground[line] = GROUND_LINE
    haze = np.minimum(reach / 40.0, 1.0)[..., None] ** 0.7  # far ground fades into the horizon's colour
    ground += (SKY_HORIZON - ground) * haze
    up = np.sqrt(np.clip(rz, 0.0, 1.0))[..., None]
    sky = SKY_HORIZON + (SKY_TOP - SKY_HORIZON) * up
    image = np.where(down[..., None], ground, sky)
    return Image.fromarray(image.astype(np.uint8)).resize(full, Image.Resampling.BILINEAR)


def _circle(centre: np.ndarray | Sequence[float], radius: float, axes: tuple[int, int], n: int = 40) -> np.ndarray:
    """(n + 1, 3) points of a circle around ``centre`` in the plane of two world axes."""
    angles = np.linspace(0.0, 2 * np.pi, n + 1)
    points = np.repeat(np.asarray(centre, dtype=float)[None, :], n + 1, axis=0)
    points[:, axes[0]] += radius * np.cos(angles)
    points[:, axes[1]] += radius * np.sin(angles)
    return points


def _draw_shadows(
    backdrop, clip_from_world: np.ndarray, positions: np.ndarray, spans: Sequence[float], width: int, height: int
) -> None:
    """A dark disc on the ground under each vehicle, its span across (drawn on the backdrop,
    so it never covers a body)."""
    from PIL import ImageDraw

    shade = ImageDraw.Draw(backdrop, "RGBA")
    for position, span in zip(positions, spans):
        if position[2] < 0:
            continue
        ring = project(clip_from_world, _circle((position[0], position[1], 0.0), span / 2, (0, 1)), width, height)
        if not np.isnan(ring).any():
            shade.polygon([tuple(q) for q in ring], fill=(20, 20, 20, 110))


def _draw_targets(
    draw, clip_from_world: np.ndarray, points: np.ndarray, radius: float, width: int, height: int, line: int
) -> None:
    """The task's markers as wireframe spheres of the reach radius (three great circles): the
    next one bright green, later ones fainter, so a vehicle inside one stays visible."""
    n = len(points)
    for i in reversed(range(n)):  # the next target drawn last, on top
        alpha = 235 if i == 0 else max(60, 160 - 30 * i)
        color = (40, 230, 60, alpha) if i == 0 else (60, 170, 70, alpha)
        for axes in ((0, 1), (0, 2), (1, 2)):
            ring = project(clip_from_world, _circle(points[i], radius, axes), width, height)
            if not np.isnan(ring).any():
                draw.line([tuple(q) for q in ring], fill=color, width=line + (1 if i == 0 else 0))


def _draw_trail(draw, pixels: np.ndarray, color: tuple[int, int, int], width: int) -> None:
    """Segments of a projected path, oldest transparent, newest opaque."""
    n = len(pixels)
    for k in range(1, n):
        a, b = pixels[k - 1], pixels[k]
        if np.isnan(a).any() or np.isnan(b).any():
            continue
        alpha = int(230 * k / (n - 1))
        draw.line([tuple(a), tuple(b)], fill=(*color, alpha), width=width)


def _draw_text(
    draw,
    lines: list[str],
    outcome: str | None,
    outcome_color: tuple[int, int, int],
    width: int,
    height: int,
    text_size: float = VideoStyle.text_size,
) -> None:
    """The time/step/reward box (top left) and, at the end, the outcome (bottom centre)."""
    from PIL import ImageFont

    size = max(11, round(width * text_size))
    font = ImageFont.load_default(size=size)
    pad = size // 3
    text = "\n".join(lines)
    box = draw.multiline_textbbox((pad * 2, pad * 2), text, font=font, spacing=pad)
    draw.rectangle((box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad), fill=(0, 0, 0, 140))
    draw.multiline_text((pad * 2, pad * 2), text, font=font, fill=(255, 255, 255, 255), spacing=pad)
    if outcome:
        big = ImageFont.load_default(size=int(size * 1.3))
        left, top, right, bottom = draw.textbbox((0, 0), outcome, font=big)
        x = (width - (right - left)) // 2
        y = height - (bottom - top) - 4 * pad
        draw.rectangle((x - pad, y - pad, x + right - left + pad, y + bottom - top + 2 * pad), fill=(0, 0, 0, 160))
        draw.text((x - left, y - top), outcome, font=big, fill=(*outcome_color, 255))


def render_video(
    episodes: Episode | Sequence[Episode],
    out: str | Path,
    size: tuple[int, int] | None = None,
    fps: float | None = None,
    style: VideoStyle | None = None,
) -> Path:
    """Film recorded episodes, one after the other, to ``.mp4`` or ``.gif`` (see the module docstring).

    ``size`` is (width, height) in pixels (default: the first episode's render
    resolution); ``fps`` defaults to the agent rate (real time).
    """
    out = Path(out)
    if out.suffix.lower() not in VIDEO_SUFFIXES:
        raise TelemetryError(f"a video file must end in one of {', '.join(VIDEO_SUFFIXES)}, got {out.name}")
    episodes = [episodes] if isinstance(episodes, Episode) else list(episodes)
    if not episodes:
        raise TelemetryError("no episodes to film")
    import sys

    from tqdm import tqdm

    frames: list[np.ndarray] = []
    total = sum(len(e.vehicles[0].time) if e.vehicles else 0 for e in episodes)
    # a progress bar on a terminal (tqdm's disable=None: none when stderr is not one)
    bar = tqdm(total=total, unit="frame", desc=f"rendering {out.name}", file=sys.stderr, disable=None, leave=False)
    with bar:
        for episode in episodes:
            for frame in episode_frames(episode, size, style):
                frames.append(frame)
                if bar.n < total:
                    bar.update(1)
            if size is None:  # every episode at the first one's size
                size = (frames[0].shape[1], frames[0].shape[0])
    out.parent.mkdir(parents=True, exist_ok=True)
    write_video(out, frames, float(fps or episodes[0].agent_hz))
    return out


#: the shortest frame a GIF viewer shows as stored [centiseconds]: browsers draw a frame of
#: 0 or 1 cs for 10 cs (a convention of old GIFs), so a faster video would play slowly
GIF_MIN_CS = 2


def gif_timing(frames: int, fps: float) -> tuple[int, list[int]]:
    """(keep every ``step``-th frame, each kept frame's duration [ms, whole centiseconds]) of a
    GIF playing ``frames`` frames at ``fps`` in real time.

    GIF stores a frame's duration in whole centiseconds, so a period that is not one (30 Hz:
    3.33 cs) cannot be stored as is; rounding it down (3 cs) plays 11 % fast.  Instead the
    durations alternate so that the time shown up to every frame is the exact time rounded
    to the nearest centisecond (30 Hz: 3, 4, 3, 3, 4, 3 ... cs): each frame is within 1 cs
    of its period and the whole video lasts its real time to within 0.5 cs.  A period under
    :data:`GIF_MIN_CS` (above 50 fps) keeps every ``step``-th frame only, the smallest step
    whose period is at least that, so no frame is shown slower than it should be.
    """
    period_cs = 100.0 / float(fps)
    step = max(1, math.ceil(GIF_MIN_CS / period_cs - 1e-9))
    kept = -(-frames // step)
    period = period_cs * step

    def shown(i: int) -> int:  # centiseconds from the start to the end of kept frame i - 1
        return int(math.floor(i * period + 0.5))

    return step, [10 * (shown(i + 1) - shown(i)) for i in range(kept)]


def write_video(out: Path, frames: list[np.ndarray], fps: float) -> None:
    """Write RGB(A) frames to ``out`` (``.gif`` or ``.mp4``, by its suffix) at ``fps`` (a GIF's
    frame durations: :func:`gif_timing`).

    Raises:
        TelemetryError: MP4 without a working imageio-ffmpeg.
        OSError: the file could not be written completely (an MP4 is checked: ffmpeg's
            own failures are not reported by imageio).
    """
    imageio = require("imageio.v2", "plots", "writing a video")
    frames = [np.asarray(f)[..., :3] for f in frames]
    if Path(out).suffix.lower() == ".gif":
        step, durations = gif_timing(len(frames), fps)
        # one frame: Pillow takes its duration as a number, not a list of one (a list was its TypeError)
        imageio.mimsave(
            out, frames[::step], format="GIF", duration=durations if len(durations) > 1 else durations[0], loop=0
        )
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
