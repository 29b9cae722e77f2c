"""The ``/scene`` records of a recording are bounded and checked before ``pyflyt replay`` draws them, and
a JSON message giving a key twice is refused: one line and exit 2, never a traceback or a hang.

Written from the reproductions against shared recordings: list lengths in scene and marker records
were unbounded (as the state lists were, whose 3 M values hung replay), and a waypoint marker of
another shape ended ``--plot`` / ``--video`` in a ``KeyError`` traceback.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pyflyt_engine.limits import LIMITS
from tests.conftest import pyflyt_forked

from .conftest import record, rewrite_mcap

SCENE_LIMIT = int(LIMITS["recording.scene_items"].high)


@pytest.fixture(scope="module")
def waypoints(tmp_path_factory) -> Path:
    env, _ = record("PyFlyt/QuadX-Waypoints-v0", tmp_path_factory.mktemp("wp"), episodes=1, max_steps=5)
    return env.paths[0]


def forged(src: Path, dst: Path, change) -> Path:
    """``src`` with the waypoints entity of every /scene record passed through ``change(entity)``."""

    def forge(topic, data):
        if topic != "/scene":
            return None
        entities = [change(dict(e)) if e.get("id") == "waypoints" else e for e in data.get("entities", [])]
        return {**data, "entities": entities}

    rewrite_mcap(src, dst, forge)
    return dst


def one_line(code: int, output: str, *fragments: str) -> None:
    assert code == 2, output[-2000:]
    assert "Traceback" not in output, output[-2000:]
    errors = [line for line in output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, output[-2000:]
    for fragment in fragments:
        assert fragment in errors[0], errors[0]


@pytest.mark.parametrize("what", ["entities", "spheres", "points"])
def test_a_scene_list_above_the_limit_is_refused_before_it_is_drawn(waypoints, tmp_path, what):
    long = [{}] * (SCENE_LIMIT + 1)

    def forge(topic, data):
        if topic != "/scene" or not data.get("entities"):
            return None
        if what == "entities":
            return {**data, "entities": long}
        entity = dict(data["entities"][0])
        entity[what if what == "spheres" else "lines"] = long if what == "spheres" else [{"points": long}]
        return {**data, "entities": [entity]}

    path = tmp_path / "long.mcap"
    rewrite_mcap(waypoints, path, forge)
    for args in (["replay", str(path)], ["replay", str(path), "--verify"]):
        code, output = pyflyt_forked(args)
        one_line(code, output, f"holds a list of {SCENE_LIMIT + 1} items", "above the limit of 1000000")


BOTH, VIDEO = ("--plot", "--video"), ("--video",)  # the video alone draws the markers' size


@pytest.mark.parametrize("change, fragment, options", [
    (lambda e: {**e, "spheres": [{"size": {"x": 1, "y": 1, "z": 1}}]}, "without a finite pose.position", BOTH),
    (lambda e: {**e, "spheres": [{"pose": {"position": {"x": "a", "y": 0, "z": 0}}, "size": {"x": 1}}]},
     "without a finite pose.position", BOTH),
    (lambda e: {**e, "spheres": [{"pose": {"position": {"x": None, "y": 0, "z": 0}}, "size": {"x": 1}}]},
     "without a finite pose.position", BOTH),
    (lambda e: {**e, "spheres": ["not a sphere"]}, "without a finite pose.position", BOTH),
    (lambda e: {**e, "spheres": [{"pose": {"position": {"x": 0, "y": 0, "z": 0}}, "size": {"x": "big"}}]},
     "without a finite size.x", VIDEO),
    (lambda e: {**e, "spheres": [{"pose": {"position": {"x": 0, "y": 0, "z": 0}}, "size": {"x": -2}}]},
     "negative size", VIDEO),
])  # fmt: skip
def test_a_waypoint_marker_of_another_shape_is_one_line_for_plot_and_video(
    waypoints, tmp_path, change, fragment, options
):
    path = forged(waypoints, tmp_path / "odd.mcap", change)
    for option in options:
        out = tmp_path / ("out.png" if option == "--plot" else "out.gif")
        args = ["replay", str(path), option, str(out), *(("--size", "32x24") if option == "--video" else ())]
        code, output = pyflyt_forked(args, timeout=300)
        one_line(code, output, str(path), fragment)
        assert not out.exists()


def test_scene_entities_that_are_not_a_list_are_one_line(waypoints, tmp_path):
    path = tmp_path / "odd.mcap"
    rewrite_mcap(waypoints, path, lambda topic, data: {**data, "entities": "many"} if topic == "/scene" else None)
    code, output = pyflyt_forked(["replay", str(path), "--plot", str(tmp_path / "p.png")], timeout=300)
    one_line(code, output, "on /scene has no valid 'entities'")


def test_a_message_giving_a_key_twice_is_refused_naming_the_channel_and_the_key(waypoints, tmp_path):
    path = tmp_path / "twice.mcap"

    def forge(topic, data):  # the reward message says one thing to one reader and another to the next
        return b'{"reward": 1.0, "reward": 100.0, "time": 0.0}' if topic == "/reward" else None

    rewrite_mcap(waypoints, path, forge)
    for args in (["replay", str(path)], ["replay", str(path), "--verify"]):
        code, output = pyflyt_forked(args)
        one_line(code, output, "a message on /reward", "the key 'reward' is given twice")


@pytest.mark.parametrize("topic, key, value, name", [
    ("/uav/0/state", "lin_pos", [math.inf, 0.0, 1.0], "Infinity"),  # --plot: 'Axis limits cannot be infinite'
    ("/uav/0/state", "time", math.nan, "NaN"),
    ("/uav/0/action", "applied", None, "-Infinity"),
])  # fmt: skip
def test_nan_or_infinity_in_a_message_is_refused_by_every_replay(waypoints, tmp_path, topic, key, value, name):
    path = tmp_path / "odd.mcap"

    def forge(t, data):
        if t != topic:
            return None
        return {**data, key: value if value is not None else [-math.inf] * len(data[key])}

    rewrite_mcap(waypoints, path, forge)
    for option in ([], ["--verify"], ["--plot", str(tmp_path / "p.png")]):
        code, output = pyflyt_forked(["replay", str(path), *option], timeout=300)
        one_line(code, output, f"a message on {topic}: holds {name}, which is not a JSON number")
    assert not (tmp_path / "p.png").exists()


def test_positions_too_large_to_draw_are_one_line_for_plot(waypoints, tmp_path):
    """Finite but 1e308: matplotlib's 'arange: cannot compute length' was a traceback."""
    path = tmp_path / "huge.mcap"
    rewrite_mcap(
        waypoints, path, lambda t, data: {**data, "lin_pos": [1e308, -1e308, 1e308]} if t == "/uav/0/state" else None
    )
    out = tmp_path / "p.png"
    code, output = pyflyt_forked(["replay", str(path), "--plot", str(out)], timeout=300)
    one_line(code, output, f"--plot {out}: cannot draw {path}: its values cannot be drawn")
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["huge.mcap"]
