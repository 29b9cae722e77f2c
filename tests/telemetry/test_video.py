"""Flight videos (pyflyt_engine/telemetry/video.py): framing, translucency, trail, overlay.

Oracles: the projection puts the camera target at the image centre; translucent bodies
are the alpha blend of two independent renders; the chase distance is the span times
the style's factor; every vehicle of a multi-vehicle recording is in view.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.telemetry import RecordEpisode, load_episode
from pyflyt_engine.telemetry.video import (
    ChaseCamera,
    VideoStyle,
    _camera,
    _matrices,
    _render_blended,
    _translucent_bodies,
    episode_frames,
    outcome_text,
    project,
    vehicle_span,
)
from pyflyt_engine.world import VehicleConfig, World

from .conftest import make_env, record

W, H = 96, 72


def _view(client: int, eye, target, fov: float = 60.0):
    view = p.computeViewMatrix(eye, target, (0.0, 0.0, 1.0), physicsClientId=client)
    projection = p.computeProjectionMatrixFOV(fov, W / H, 0.02, 500.0, physicsClientId=client)
    return view, projection


def test_projection_puts_the_target_at_the_centre_and_hides_points_behind():
    with World([VehicleConfig("quadx_cf2x", (0, 0, 1))]) as world:
        view, projection = _view(world.client, (-2.0, 0.0, 2.0), (0.0, 0.0, 1.0))
    clip = _matrices(view, projection)
    pixels = project(clip, np.array([[0.0, 0.0, 1.0], [-4.0, 0.0, 3.0], [0.0, 1.0, 1.0]]), W, H)
    np.testing.assert_allclose(pixels[0], (W / 2, H / 2), atol=1e-9)
    assert np.isnan(pixels[1]).all()  # behind the camera
    assert pixels[2][0] < W / 2  # +y (left of the view along +x) is on the left


def test_translucent_bodies_are_the_alpha_blend_of_two_renders():
    """A sphere of alpha 0.4 in front of the vehicle: where it shows, the frame is
    0.4 x (render with it) + 0.6 x (render without it), so the vehicle shows through."""
    with World([VehicleConfig("quadx_f450", (0, 0, 1))]) as world:
        client = world.client
        shape = p.createVisualShape(p.GEOM_SPHERE, radius=0.15, rgbaColor=(0.1, 0.9, 0.1, 0.4), physicsClientId=client)
        sphere = p.createMultiBody(0.0, -1, shape, basePosition=(-0.3, 0.0, 1.0), physicsClientId=client)
        vehicle = world.vehicles[0].body_id
        translucent = _translucent_bodies(client, {vehicle})
        assert translucent == {sphere: pytest.approx(0.4)}
        view, projection = _view(client, (-1.2, 0.0, 1.0), (0.0, 0.0, 1.0))
        blended, blended_segmentation = _render_blended(client, W, H, view, projection, translucent)
        with_it, segmentation = _camera(client, W, H, view, projection)
        p.resetBasePositionAndOrientation(sphere, (0, 0, -50), (0, 0, 0, 1), physicsClientId=client)
        without, behind_segmentation = _camera(client, W, H, view, projection)
    covered = segmentation == sphere
    assert covered.sum() > 100
    expected = np.rint(without + 0.4 * (with_it.astype(float) - without)).astype(np.uint8)
    np.testing.assert_array_equal(blended[covered], expected[covered])
    np.testing.assert_array_equal(blended[~covered], with_it[~covered])
    vehicle_behind = covered & (behind_segmentation == vehicle)
    assert vehicle_behind.sum() > 20
    assert np.abs(blended[vehicle_behind].astype(int) - with_it[vehicle_behind]).max() > 20  # not the opaque sphere
    # the mask of the blend: what is behind a translucent body (the vehicle, or nothing)
    np.testing.assert_array_equal(blended_segmentation[covered], behind_segmentation[covered])
    np.testing.assert_array_equal(blended_segmentation[~covered], segmentation[~covered])


def test_chase_distance_is_scaled_to_the_span_and_all_vehicles_stay_in_view():
    style = VideoStyle()
    with World([VehicleConfig("quadx_cf2x", (0, 0, 1)), VehicleConfig("fixedwing", (0, 5, 5))]) as world:
        small = vehicle_span(world.client, world.vehicles[0].body_id)
        large = vehicle_span(world.client, world.vehicles[1].body_id)
        assert small == pytest.approx(0.1, abs=0.05) and large == pytest.approx(2.4, abs=0.2)  # 2.4 m span (paper)
        tan = math.tan(math.radians(style.fov / 2))
        for span in (small, large):
            eye, target = ChaseCamera(style, span, 1 / 30).update(np.array([[0.0, 0.0, 1.0]]), 0.3)
            distance = math.dist(eye, target)
            assert distance == pytest.approx(
                max(style.min_distance, span / (style.frame_fraction * 2 * tan), 1.4 * span / tan)
            )
            assert math.atan2(target[1] - eye[1], target[0] - eye[0]) == pytest.approx(0.3)  # behind the heading
            view, projection = _view(world.client, eye, target, style.fov)
            across = np.array([-math.sin(0.3), math.cos(0.3), 0.0]) * span / 2  # the span, square to the view
            ends = project(_matrices(view, projection), np.array([target + across, target - across]), W, H)
            drawn = float(np.linalg.norm(ends[0] - ends[1])) / H  # of the frame's height
            if span == large:  # framed by its span: it fills frame_fraction of the frame
                assert drawn == pytest.approx(style.frame_fraction, rel=0.02)
            else:  # the Crazyflie, from min_distance: larger than it was at 1.2 m, and the ground below in view
                assert drawn == pytest.approx(span / (2 * style.min_distance * tan), rel=0.02) and drawn > 0.12
                below = project(_matrices(view, projection), np.array([[0.0, 0.0, 0.0]]), W, H)[0]
                assert 0 <= below[0] <= W and 0 <= below[1] <= H, below
        positions = np.array([[0.0, 0.0, 1.0], [6.0, -4.0, 3.0], [-3.0, 5.0, 0.5]])
        eye, target = ChaseCamera(style, small, 1 / 30).update(positions, None)
        view, projection = _view(world.client, eye, target, style.fov)
    pixels = project(_matrices(view, projection), positions, W, H)
    assert np.all((pixels >= 0) & (pixels <= (W, H)))


def _multi_vehicle_recording(directory) -> str:
    env = make_env("PyFlyt/QuadX-Hover-v0")
    world = env.unwrapped.world
    world.add_vehicle("hexacopter", (1.5, 0.5, 1.0), mode="position_yaw")
    recorder = RecordEpisode(env, directory)
    recorder.reset(seed=0)
    world.set_setpoint(1, [2.5, -0.5, 0.0, 1.5])
    for _ in range(30):
        recorder.step(np.array([0.0, 0.0, 0.0, 0.13]))
    recorder.close()
    return recorder.paths[0]


def test_a_multi_vehicle_recording_shows_every_vehicle_with_its_trail(tmp_path):
    episode = load_episode(_multi_vehicle_recording(tmp_path))
    assert len(episode.vehicles) == 2
    style = VideoStyle(hold_seconds=0.0)
    frames = list(episode_frames(episode, (160, 120), style))
    assert len(frames) == len(episode.vehicles[0].time) and frames[0].shape == (120, 160, 3)
    # the trails: the recording's orange (vehicle 0) and blue (vehicle 1) pixels in the last frame
    last = frames[-1].astype(int)
    orange = (last[..., 0] > 200) & (last[..., 1] > 90) & (last[..., 1] < 190) & (last[..., 2] < 90)
    blue = (last[..., 0] < 90) & (last[..., 1] > 120) & (last[..., 2] > 200)
    assert orange.sum() > 3 and blue.sum() > 10, (orange.sum(), blue.sum())


def test_outcome_text_names_how_the_episode_ended(tmp_path):
    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path, max_steps=5)
    episode = load_episode(env.paths[0])
    text, color = outcome_text(episode)
    assert text == "recording cut short" or episode.end is not None
    if episode.end is not None:
        assert episode.end["reason"].replace("_", " ") in text


def test_replay_video_is_the_flight_then_the_outcome_held(recorded_hover, tmp_path):
    episode = load_episode(recorded_hover)
    gif = tmp_path / "v.gif"
    result = CliRunner().invoke(app, ["replay", str(recorded_hover), "--video", str(gif), "--size", "96x72"])
    assert result.exit_code == 0, result.output
    image = Image.open(gif)
    assert image.size == (96, 72)
    total = 0.0  # [ms]; the GIF writer merges the identical held frames into one longer one
    for k in range(image.n_frames):
        image.seek(k)
        total += image.info["duration"]
    frames = len(episode.vehicles[0].time) + round(episode.agent_hz)  # the flight, then 1 s held
    assert abs(total - frames * 1000 / episode.agent_hz) <= 5  # real time, to half a centisecond
    image.seek(0)
    first = np.asarray(image.convert("RGB")).astype(int)
    assert np.median(first[6:14, 6:40]) < 160  # the dark overlay box, top left, over the white sky


@pytest.fixture
def recorded_hover(tmp_path):
    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path / "rec", max_steps=12)
    return env.paths[0]


def test_a_frame_shows_the_ground_the_shadow_and_the_target_as_a_wireframe(tmp_path):
    """The ground is drawn behind the vehicle (PyBullet's plane parked out of view), the
    vehicle's shadow darkens it below, and the hover point is a green wireframe, not a
    solid sphere: pixels inside the ring keep the ground's colours."""
    from pyflyt_engine.telemetry import video

    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path / "rec", max_steps=6)
    episode = load_episode(env.paths[0])
    frames = list(episode_frames(episode, (240, 240), VideoStyle(hold_seconds=0.0)))
    frame = frames[3].astype(int)
    tiles = [video.GROUND_LIGHT, video.GROUND_DARK]
    bottom = frame[200:, :, :]  # the ground in front of the camera, below the vehicle
    near_tile = min(np.abs(bottom - t).sum(axis=-1).min() for t in tiles)
    assert near_tile < 30
    dark = (frame.sum(axis=-1) < 250).sum()  # the shadow (and the vehicle)
    assert dark > 30
    green = (frame[..., 1] > 180) & (frame[..., 0] < 120) & (frame[..., 2] < 140)
    assert 20 < green.sum() < 2000, green.sum()  # thin rings, not a filled disc


def test_videos_render_with_a_progress_bar_on_a_terminal(recorded_hover, tmp_path, monkeypatch):
    import io

    from pyflyt_engine.telemetry.video import render_video

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    err = Terminal()
    monkeypatch.setattr("sys.stderr", err)
    render_video(load_episode(recorded_hover), tmp_path / "v.gif", size=(64, 48))
    assert "rendering v.gif" in err.getvalue() and "frame" in err.getvalue()


@pytest.mark.parametrize("fps", [30.0, 25.0, 24.0, 60.0, 120.0, 7.0, 100.0 / 3])
def test_gif_frames_last_the_agent_period_in_whole_centiseconds(fps, tmp_path):
    """A GIF stores centiseconds: the durations alternate so every frame ends at its real
    time rounded to the nearest centisecond; above 50 fps frames are dropped instead of
    stored under 2 cs (which browsers show as 10 cs)."""
    from pyflyt_engine.telemetry.video import gif_timing, write_video

    n = 45
    step, durations = gif_timing(n, fps)
    assert all(d % 10 == 0 and d >= 20 for d in durations)
    assert len(durations) == -(-n // step) and (step == 1) == (fps <= 50)
    clock = 0
    for i, d in enumerate(durations):  # the time shown up to each frame: the exact one, to 0.5 cs
        clock += d
        assert abs(clock - (i + 1) * step * 1000 / fps) <= 5
    frames = [np.full((4, 4, 3), 5 * i, np.uint8) for i in range(n)]  # distinct: no frames merged
    write_video(tmp_path / "v.gif", frames, fps)
    image = Image.open(tmp_path / "v.gif")
    read = []
    for k in range(image.n_frames):
        image.seek(k)
        read.append(image.info["duration"])
    assert read == durations
    assert abs(sum(read) - len(durations) * step * 1000 / fps) <= 5


@pytest.mark.parametrize("n, fps", [(1, 30.0), (45, 1000.0), (3, 1e9)])
def test_a_gif_of_one_kept_frame_is_written(n, fps, tmp_path):
    """One kept frame (a one-step episode, or so high a rate that every other frame is dropped) was
    Pillow's TypeError: a one-frame GIF takes its duration as a number."""
    from pyflyt_engine.telemetry.video import gif_timing, write_video

    frames = [np.full((4, 4, 3), 5 * i, np.uint8) for i in range(n)]
    step, durations = gif_timing(n, fps)
    write_video(tmp_path / "v.gif", frames, fps)
    image = Image.open(tmp_path / "v.gif")
    assert image.n_frames == len(durations)
    assert image.info["duration"] == durations[0]
