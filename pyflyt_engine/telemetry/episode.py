"""Episode recordings read back: :func:`load_episode` -> :class:`Episode` (arrays per channel).

Built on :func:`pyflyt_engine.telemetry.reader.read_mcap`; used by ``pyflyt replay``
(summary, verify, plot, video).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.limits import LIMITS, number
from pyflyt_engine.safe_load import json_data, json_loads
from pyflyt_engine.telemetry.reader import McapContents, read_mcap
from pyflyt_engine.telemetry.recorder import ENV_INFO, EPISODE_INFO, FILE_INFO, FORMAT_VERSION, VERSIONS

#: state fields of ``pyflyt.VehicleState`` read into arrays (name -> width)
STATE_FIELDS = {
    "lin_pos": 3,
    "lin_vel": 3,
    "lin_vel_ground": 3,
    "ang_pos": 3,
    "quaternion": 4,
    "ang_vel": 3,
    "ang_vel_ground": 3,
}


#: the fields of a ``pyflyt.Estimate`` message and their widths, in :meth:`ComplementaryEstimator.values` order
ESTIMATE_FIELDS = {"quaternion": 4, "ang_pos": 3, "lin_vel_ground": 3, "lin_pos": 3, "gyro_bias": 3}


@dataclass
class VehicleTrack:
    """One vehicle's recorded states: ``time`` (T,) [s] and per field a (T, width) array."""

    name: str
    time: np.ndarray
    steps: np.ndarray
    states: dict[str, np.ndarray]
    aux: np.ndarray
    collision: np.ndarray
    #: (T, 6) wind (x, y, z) [m/s] and rotary gust (p, q, r) [rad/s] at the vehicle, ground
    #: frame, from ``/uav/<i>/wind`` ((0, 6) when the recording has no wind channel)
    wind: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    #: (T, n) the noisy sensors' readings from ``/uav/<i>/sensors``, flat in the order
    #: :attr:`sensor_layout` gives ((0, 0) when the airframe has no sensors)
    sensors: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    #: (name, size) of each reading in :attr:`sensors` (components/sensors.py)
    sensor_layout: list[tuple[str, int]] = field(default_factory=list)
    #: the state estimate from ``/uav/<i>/estimate`` per field (:data:`ESTIMATE_FIELDS`),
    #: (T, width) arrays; empty without an estimator (components/estimator.py)
    estimate: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class Episode:
    """A recorded episode.

    Attributes:
        path: the file.
        truncated / truncation: the file was cut short (and why).
        config: the resolved env config (plain dict); reward_preset: the preset dict;
        uav_specs: one airframe spec dict per vehicle.
        seed: the reset's seed (None: the RNG streams continued, see ``rng_state``).
        options: the reset's options; rng_state: RNG streams before the reset.
        versions: package versions of the recording process.
        vehicles: per vehicle, its :class:`VehicleTrack` (reset state first).
        action_names: names of the action entries; actions: (N, A) applied actions;
        raw_actions: (N, A) actions as given (NaN where not numeric); action_time: (N,) [s].
        rewards: (N,) per-step rewards; reward_terms: name -> (N,) weighted terms.
        events: the ``/episode`` messages (reset, then end or stopped when present).
    """

    path: Path
    contents: McapContents
    truncated: bool
    truncation: str
    config: dict[str, Any]
    reward_preset: dict[str, Any]
    uav_specs: list[dict[str, Any]]
    airframe_spec: dict[str, Any]
    env_info: dict[str, str]
    seed: int | None
    options: Any
    rng_state: dict[str, Any]
    versions: dict[str, str]
    vehicles: list[VehicleTrack]
    action_names: list[str]
    actions: np.ndarray
    raw_actions: np.ndarray
    action_time: np.ndarray
    rewards: np.ndarray
    reward_terms: dict[str, np.ndarray]
    events: list[dict[str, Any]] = field(default_factory=list)

    @property
    def agent_hz(self) -> float:
        return float(self.env_info.get("agent_hz", self.config.get("agent_hz", 30.0)))

    @property
    def length(self) -> int:
        """Agent steps recorded."""
        return len(self.actions)

    @property
    def duration(self) -> float:
        """Simulated time covered [s]."""
        t = self.vehicles[0].time
        return float(t[-1] - t[0]) if len(t) else 0.0

    @property
    def end(self) -> dict[str, Any] | None:
        """The closing ``/episode`` event (None if the file was cut before it)."""
        closing = [e for e in self.events if e.get("event") in ("end", "stopped")]
        return closing[-1] if closing else None


def _json(path: Path, record: dict[str, str], key: str) -> Any:
    """Metadata ``key`` of ``record`` as JSON data (bounded: :func:`pyflyt_engine.safe_load.json_data`)."""
    try:
        return json_data(record[key], source=f"{path}: metadata '{key}'", error=TelemetryError)
    except TelemetryError:
        raise
    except KeyError:
        raise TelemetryError(f"{path}: metadata is missing '{key}'; was it written by pyflyt's recorder?") from None
    except ValueError as exc:
        raise TelemetryError(f"{path}: metadata '{key}' is not valid JSON ({exc})") from None


def _check_schema(contents: McapContents, topic: str, expected: str) -> None:
    for channel in contents.channels.values():
        if channel.topic == topic:
            schema = contents.schemas.get(channel.schema_id)
            name = schema.name if schema else "(none)"
            if name != expected or channel.message_encoding != "json":
                raise TelemetryError(
                    f"{contents.path}: channel {topic} has schema {name!r} in {channel.message_encoding!r} encoding; "
                    f"expected {expected!r} in 'json' (wrong schema: not a pyflyt episode recording of format {FORMAT_VERSION})"
                )
            return
    cut = " (the file is truncated)" if contents.truncated else ""
    raise TelemetryError(f"{contents.path}: no {topic} channel{cut}; not a complete pyflyt episode recording")


#: the most values one recorded row of unfixed width may hold (aux state, sensor readings: a few dozen)
MAX_ROW_VALUES = int(LIMITS["recording.row_values"].high)
#: the most items of one list in a ``/scene`` record (entities, shapes, points)
MAX_SCENE_ITEMS = int(LIMITS["recording.scene_items"].high)


def _check_scene(path: Path, index: int, message: Any) -> None:
    """Refuse a ``/scene`` record holding a list longer than :data:`MAX_SCENE_ITEMS` (every list, however
    deep: the reader bounds the nesting), before anything reads its shapes."""
    stack = [message]
    while stack:
        value = stack.pop()
        if isinstance(value, dict):
            stack.extend(value.values())
        elif isinstance(value, list):
            if len(value) > MAX_SCENE_ITEMS:
                raise TelemetryError(
                    f"{path}: message {index} on /scene holds a list of {len(value)} items, above the limit of "
                    f"{number(MAX_SCENE_ITEMS)} {LIMITS['recording.scene_items'].unit} (items of one list in a "
                    "/scene record); no recorder writes one that long"
                )
            stack.extend(value)


def load_episode(path: str | os.PathLike[str], *, warn: bool = True) -> Episode:
    """Read an episode recording.

    Raises:
        TelemetryError: not an MCAP file, corrupt, not an episode recording (metrics file,
            foreign file), missing metadata, channels with unexpected schemas or messages
            missing fields.  A truncated file is *not* an error: ``episode.truncated`` is set.
    """
    path = Path(path)
    contents = read_mcap(path, warn=warn)
    info = contents.metadata.get(FILE_INFO)
    if info is None:
        cut = " (the file is truncated before it)" if contents.truncated else ""
        raise TelemetryError(f"{path}: missing the 'pyflyt' metadata record{cut}; not a pyflyt recording")
    if info.get("kind") != "episode":
        raise TelemetryError(f"{path} is a pyflyt {info.get('kind', '?')} file, not an episode recording")
    if info.get("format") != FORMAT_VERSION:
        raise TelemetryError(
            f"{path}: recording format {info.get('format')!r}; this version reads format {FORMAT_VERSION}"
        )
    env_info = contents.require_metadata(ENV_INFO)
    episode_info = contents.require_metadata(EPISODE_INFO)
    versions = contents.metadata.get(VERSIONS, {})
    config = _json(path, env_info, "config")
    reward_preset = _json(path, env_info, "reward_preset")
    uav_specs = _json(path, env_info, "uav_specs")
    action_names = [str(n) for n in _json(path, env_info, "action_names")]
    seed_text = episode_info.get("seed", "")
    try:
        seed = int(seed_text) if seed_text else None
    except ValueError:
        raise TelemetryError(f"{path}: metadata 'seed' is not an integer: {seed_text!r}") from None
    options = _json(path, episode_info, "options")
    rng_state = _json(path, episode_info, "rng_state")
    if not isinstance(config, dict) or not isinstance(uav_specs, list) or not uav_specs:
        raise TelemetryError(f"{path}: metadata 'config'/'uav_specs' have the wrong shape")
    if not isinstance(reward_preset, dict):  # a name or path would make a replay read another file
        raise TelemetryError(f"{path}: metadata 'reward_preset' is not a mapping of reward terms")
    airframe_spec = _json(path, env_info, "airframe_spec") if "airframe_spec" in env_info else uav_specs[0]
    if not isinstance(airframe_spec, dict):
        raise TelemetryError(f"{path}: metadata 'airframe_spec' has the wrong shape")

    for topic, schema in (
        ("/episode", "pyflyt.EpisodeEvent"),
        ("/uav/0/action", "pyflyt.Action"),
        ("/reward", "pyflyt.Reward"),
    ):
        _check_schema(contents, topic, schema)
    for i in range(len(uav_specs)):
        _check_schema(contents, f"/uav/{i}/state", "pyflyt.VehicleState")

    by_topic: dict[str, list[Any]] = {}
    for m in contents.messages:
        by_topic.setdefault(m.topic, []).append(m.data)
    for i, message in enumerate(by_topic.get("/scene", [])):
        _check_scene(path, i, message)

    def rows(topic: str, key: str, width: int | None) -> np.ndarray:
        out = []
        for i, msg in enumerate(by_topic.get(topic, [])):
            value = msg.get(key) if isinstance(msg, dict) else None
            # the length first, against the schema (or the bound), before any value is converted
            if isinstance(value, list) and width is not None and len(value) != width:
                raise TelemetryError(
                    f"{path}: message {i} on {topic}: '{key}' has {len(value)} values, expected {width}"
                )
            if isinstance(value, list) and len(value) > MAX_ROW_VALUES:
                raise TelemetryError(
                    f"{path}: message {i} on {topic}: '{key}' has {len(value)} values, above the limit of "
                    f"{number(MAX_ROW_VALUES)} values any recorded row holds"
                )
            try:
                value = msg[key]
                arr = np.asarray(
                    [np.nan if v is None else v for v in value] if value is not None else [np.nan] * (width or 0),
                    dtype=np.float64,
                )
            except (KeyError, TypeError, ValueError):
                raise TelemetryError(f"{path}: message {i} on {topic} has no valid '{key}' (wrong schema?)") from None
            if width is not None and arr.shape != (width,):
                raise TelemetryError(f"{path}: message {i} on {topic}: '{key}' has {arr.size} values, expected {width}")
            out.append(arr)
        if not out:
            return np.zeros((0, width or 0))
        try:
            return np.stack(out)
        except ValueError:
            raise TelemetryError(f"{path}: '{key}' on {topic} changes length between messages") from None

    def scalars(topic: str, key: str, dtype: Any = np.float64) -> np.ndarray:
        try:
            return np.asarray([np.nan if m[key] is None else m[key] for m in by_topic.get(topic, [])], dtype=dtype)
        except (KeyError, TypeError, ValueError):
            raise TelemetryError(f"{path}: a message on {topic} has no valid '{key}' (wrong schema?)") from None

    vehicles = []
    for i, spec in enumerate(uav_specs):
        topic = f"/uav/{i}/state"
        vehicles.append(
            VehicleTrack(
                name=str(spec.get("name", f"uav_{i}")) if isinstance(spec, dict) else f"uav_{i}",
                time=scalars(topic, "time"),
                steps=scalars(topic, "step", np.int64),
                states={k: rows(topic, k, w) for k, w in STATE_FIELDS.items()},
                aux=rows(topic, "aux", None),
                collision=scalars(topic, "collision", bool),
                wind=np.hstack([rows(f"/uav/{i}/wind", "velocity", 3), rows(f"/uav/{i}/wind", "rotary", 3)]),
                sensors=rows(f"/uav/{i}/sensors", "values", None),
                sensor_layout=_sensor_layout(contents, f"/uav/{i}/sensors"),
                estimate=(
                    {k: rows(f"/uav/{i}/estimate", k, w) for k, w in ESTIMATE_FIELDS.items()}
                    if f"/uav/{i}/estimate" in by_topic
                    else {}
                ),
            )
        )
    actions = rows("/uav/0/action", "applied", len(action_names))
    raw = rows("/uav/0/action", "action", len(action_names))
    rewards = scalars("/reward", "reward")
    term_names: list[str] = []
    for m in by_topic.get("/reward", []):
        for k in (m.get("terms") or {}) if isinstance(m, dict) else {}:
            if k not in term_names:
                term_names.append(k)
    terms = {
        k: np.asarray([(m.get("terms") or {}).get(k) or 0.0 for m in by_topic.get("/reward", [])], dtype=float)
        for k in term_names
    }
    events = [m for m in by_topic.get("/episode", []) if isinstance(m, dict)]
    if not vehicles[0].time.size:
        raise TelemetryError(
            f"{path}: no vehicle state recorded" + (" (the file is truncated)" if contents.truncated else "")
        )
    n = min(len(actions), len(vehicles[0].time) - 1)  # a cut file may end between channels of a step
    return Episode(
        path=path,
        contents=contents,
        truncated=contents.truncated,
        truncation=contents.truncation,
        config=config,
        reward_preset=reward_preset,
        uav_specs=uav_specs,
        airframe_spec=airframe_spec,
        env_info=env_info,
        seed=seed,
        options=options,
        rng_state=rng_state,
        versions=versions,
        vehicles=vehicles,
        action_names=action_names,
        actions=actions[:n],
        raw_actions=raw[:n],
        action_time=scalars("/uav/0/action", "time")[:n],
        rewards=rewards,
        reward_terms=terms,
        events=events,
    )


def _waypoint_entities(episode: Episode) -> Iterator[tuple[int, dict[str, Any]]]:
    """(log time [ns], entity) of every waypoints entity the ``/scene`` channel shows; a record of
    another shape is refused in one line (the file was not written by a recorder)."""
    for i, m in enumerate(x for x in episode.contents.messages if x.topic == "/scene"):
        entities = m.data.get("entities", []) if isinstance(m.data, dict) else None
        if not isinstance(entities, list) or not all(isinstance(e, dict) for e in entities):
            raise TelemetryError(f"{episode.path}: message {i} on /scene has no valid 'entities' (wrong schema?)")
        for entity in entities:
            if entity.get("id") == "waypoints":
                yield m.log_time, entity


def _finite_number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise TypeError(value)
    return float(value)


def waypoint_markers(episode: Episode) -> list[tuple[float, np.ndarray]]:
    """Per ``/scene`` message that shows waypoint markers: (time [s], the marker centres, (n, 3))."""
    out = []
    for log_time, entity in _waypoint_entities(episode):
        try:
            pts = [s["pose"]["position"] for s in entity.get("spheres", [])]
            xyz = [[_finite_number(q["x"]), _finite_number(q["y"]), _finite_number(q["z"])] for q in pts]
        except (KeyError, TypeError, ValueError, AttributeError):
            raise TelemetryError(
                f"{episode.path}: a waypoints entity on /scene has a sphere without a finite pose.position"
            ) from None
        out.append((log_time * 1e-9, np.array(xyz, dtype=np.float64).reshape(-1, 3)))
    return out


def waypoint_radius(episode: Episode) -> float:
    """The radius [m] of the first waypoint marker the ``/scene`` channel shows (0.05 without one)."""
    for _, entity in _waypoint_entities(episode):
        spheres = entity.get("spheres", [])
        if not isinstance(spheres, list):
            break
        for sphere in spheres:
            try:
                radius = _finite_number(sphere["size"]["x"]) / 2
            except (KeyError, TypeError, ValueError):
                raise TelemetryError(
                    f"{episode.path}: a waypoints entity on /scene has a sphere without a finite size.x"
                ) from None
            if radius < 0:
                raise TelemetryError(f"{episode.path}: a waypoints entity on /scene has a sphere of negative size")
            return radius
    return 0.05


def _sensor_layout(contents: Any, topic: str) -> list[tuple[str, int]]:
    """The ``layout`` metadata of a ``pyflyt.Sensors`` channel as (name, size) pairs ([] without it)."""
    for channel in contents.channels.values():
        if channel.topic == topic:
            try:
                items = json_loads(
                    channel.metadata.get("layout") or "[]",
                    source=f"{contents.path}: the 'layout' of channel {topic}",
                    error=TelemetryError,
                )
                return [(str(n), int(k)) for n, k in (str(item).split(":") for item in items)]
            except (TypeError, ValueError):
                raise TelemetryError(f"{contents.path}: channel {topic} has a malformed 'layout'") from None
    return []
