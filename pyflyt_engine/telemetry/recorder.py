"""Episode recording as a Gymnasium wrapper: one MCAP file per episode (``docs/mcap.md``).

Example::

    env = RecordEpisode(gymnasium.make("PyFlyt/QuadX-Waypoints-v0"), "runs/demo/episodes")
    obs, info = env.reset(seed=0)
    ...                                  # runs/demo/episodes/ep_0000.mcap, ep_0001.mcap, ...
    env.close()

Then ``pyflyt replay runs/demo/episodes/ep_0000.mcap --verify --plot path.png``.
"""

from __future__ import annotations

import importlib.metadata
import io
import json
import platform
import re
import sys
import time
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium
import numpy as np

from pyflyt_engine import numerics
from pyflyt_engine.components.sensors import READING_SIZES
from pyflyt_engine.envs.recordable import RECORDABLE, RecordableEnv
from pyflyt_engine.envs.tasks.measures import INFO_KEY as MEASURES
from pyflyt_engine.envs.tasks.measures import plain
from pyflyt_engine.errors import TelemetryError
from pyflyt_engine.frames import matrix_to_quaternion
from pyflyt_engine.telemetry import scene, schemas
from pyflyt_engine.telemetry._io import DEFAULT_CHUNK_SIZE, McapFileWriter, to_ns

#: version of the channel layout and metadata records; bump on incompatible changes
FORMAT_VERSION = "1"
#: metadata record names
FILE_INFO, ENV_INFO, EPISODE_INFO, VERSIONS = "pyflyt", "env", "episode", "versions"


def package_versions() -> dict[str, str]:
    """Versions of Python, the platform and the packages a re-simulation depends on."""
    out = {"python": sys.version.split()[0], "platform": platform.platform(), "machine": platform.machine()}
    for dist in ("pyflyt-toolkit", "numpy", "pybullet", "gymnasium", "pydantic", "mcap"):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            out[dist] = ""
    from pyflyt_engine import __version__

    out["pyflyt_engine"] = __version__
    return out


def _jsonable(value: Any) -> Any:
    """Scalars/arrays of an info dict or reset options as JSON values (None if impossible)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, str):
        return value
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return None


def _scalar_info(info: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in info.items():
        if isinstance(value, (bool, np.bool_, int, np.integer, float, np.floating, str)):
            out[str(key)] = _jsonable(value)
    return out


def end_reason(terminated: bool, truncated: bool, info: dict[str, Any]) -> str:
    """Why an episode ended, from its last step's flags and info."""
    if info.get("env_complete") and terminated:
        return "complete"
    if terminated:
        if info.get("out_of_bounds"):
            return "out_of_bounds"
        if info.get("collision"):
            return "collision"
        return "failed"
    if truncated:
        return "time_limit"
    return ""


class RecordEpisode(gymnasium.Wrapper):
    """Record every episode of a pyflyt environment to its own ``.mcap`` file.

    Files are ``<directory>/<prefix>_<NNNN>.mcap``, numbered from the first index not yet
    used in the directory (existing files are never overwritten).  A file is opened by
    ``reset()`` and finished when the episode terminates or is truncated, at the next
    ``reset()`` or at ``close()`` (then marked ``stopped``), and at interpreter exit.

    Channels (see ``docs/mcap.md``): ``/tf``, ``/scene``, ``/uav/<i>/state``,
    ``/uav/0/action``, ``/reward``, ``/episode``, with sensors ``/uav/<i>/sensors`` (and with an
    estimator ``/uav/<i>/estimate``), in wind ``/uav/<i>/wind`` (and a wind
    arrow per vehicle in ``/scene``) and, with ``cameras=True``, ``/uav/<i>/camera/<k>``.  Log time is the simulation time since the reset.  Metadata
    records hold the resolved env config, reward preset, airframe specs, the reset's seed,
    options and RNG state, and package versions: everything ``pyflyt replay --verify``
    needs to re-simulate the episode.

    Args:
        env: a pyflyt environment, possibly wrapped: ``env.unwrapped`` implements
            :class:`~pyflyt_engine.envs.recordable.RecordableEnv` (a :class:`~pyflyt_engine.envs.env.UAVEnv`,
            or a multi-agent env's shared-policy view), and nothing else of it is read.  Put this wrapper outermost or innermost: the actions it
            re-simulates are those the vehicle received (after any action wrappers).
        directory: folder for the files (created if missing).
        prefix: file name prefix.
        cameras: also record every on-board camera's colour image (JPEG), at its capture rate.
        chunk_seconds: close a chunk (and hand it to the OS) every this much simulated time:
            a killed process loses at most this much of the flight (also at most ~1 s of
            wall time, by a background flusher).
        jpeg_quality: quality of recorded camera images (1-95).

    Attributes:
        paths: every file written so far, in order.
    """

    def __init__(
        self,
        env: gymnasium.Env,
        directory: str | Path,
        prefix: str = "ep",
        cameras: bool = False,
        *,
        chunk_seconds: float = 1.0,
        jpeg_quality: int = 90,
    ) -> None:
        super().__init__(env)
        base = env.unwrapped
        if not isinstance(base, RecordableEnv):
            missing = [name for name in RECORDABLE if not hasattr(base, name)]
            raise TelemetryError(
                "RecordEpisode needs a pyflyt environment (pyflyt_engine.envs.recordable.RecordableEnv, e.g. a "
                f"UAVEnv); {type(base).__name__} has no {', '.join(repr(m) for m in missing)}"
            )
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", prefix):
            raise TelemetryError(f"prefix must be letters, digits, '_', '-' or '.', got {prefix!r}")
        if not chunk_seconds > 0:
            raise TelemetryError(f"chunk_seconds must be > 0, got {chunk_seconds}")
        self._base = base
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prefix = prefix
        self.cameras = bool(cameras)
        self.chunk_seconds = float(chunk_seconds)
        self.jpeg_quality = int(jpeg_quality)
        self.paths: list[Path] = []
        pattern = re.compile(rf"^{re.escape(prefix)}_(\d+)\.mcap$")
        used = [int(m[1]) for p in self.directory.iterdir() if (m := pattern.match(p.name))]
        self._next_index = max(used) + 1 if used else 0
        self._file: McapFileWriter | None = None
        self._static_metadata: dict[str, dict[str, str]] | None = None
        self._airframes: list[tuple[str, dict[str, list[dict[str, Any]]]]] | None = None
        self._meshes: list[tuple[str, str, str, bytes]] | None = None
        self._static_entities: tuple[int, list[dict[str, Any]]] | None = None
        if self.cameras and not any(v.parts.cameras for v in base.world.vehicles):
            gymnasium.logger.warn("RecordEpisode(cameras=True): no vehicle has an on-board camera; nothing to record")

    # ------------------------------------------------------------------ gymnasium

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        self._stop("stopped")
        base = self._base
        rng_state = {"env": base.np_random.bit_generator.state, "world": base.world.rng_state()}
        obs, info = self.env.reset(seed=seed, options=options)
        self._open(seed, options, rng_state)
        self._write_reset(info, seed)
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self._file is not None:
            self._write_step(action, float(reward), bool(terminated), bool(truncated), info)
        return obs, reward, terminated, truncated, info

    def close(self) -> None:
        self._stop("stopped")
        super().close()

    # ------------------------------------------------------------------ recording

    @property
    def recording(self) -> Path | None:
        """The file of the episode being recorded (None between episodes)."""
        return self._file.path if self._file is not None else None

    def _file_metadata(self) -> dict[str, dict[str, str]]:
        if self._static_metadata is None:
            base = self._base
            world = base.world
            specs = [v.spec.model_dump(mode="json") for v in world.vehicles]
            # the airframe flown, before any task adjusts it (e.g. initial fuel)
            airframe = json.dumps(base.airframe.model_dump(mode="json"))
            env_spec = getattr(self.env, "spec", None)
            self._static_metadata = {
                FILE_INFO: {"kind": "episode", "format": FORMAT_VERSION, "log_time": "simulation time since reset"},
                ENV_INFO: {
                    "config_id": str(base.config.id or ""),
                    "gym_id": str(env_spec.id) if env_spec is not None else "",
                    "env_class": f"{type(base).__module__}:{type(base).__qualname__}",
                    "config": json.dumps(base.config.model_dump(mode="json")),
                    "reward_preset": json.dumps(base.reward_preset.model_dump(mode="json")),
                    "uav_specs": json.dumps(specs),
                    "airframe_spec": airframe,
                    "uav_names": json.dumps([v.spec.name for v in world.vehicles]),
                    "action_names": json.dumps(list(base.action_names)),
                    "physics_hz": repr(world.physics_hz),
                    "control_hz": repr(world.control_hz),
                    "agent_hz": repr(world.agent_hz),
                    "flight_dome_size": repr(float(base.config.flight_dome_size)),
                    # the resolved atmosphere (a preset file may change; the recording may not)
                    "wind": json.dumps(world.wind_config.model_dump(mode="json")),
                    # only with mesh obstacles: which attachment holds each mesh file, and its digest
                    **(
                        {
                            "obstacle_meshes": json.dumps(
                                [{"file": m, "attachment": a, "sha256": d} for m, a, d, _ in self._obstacle_meshes()]
                            )
                        }
                        if self._obstacle_meshes()
                        else {}
                    ),
                },
                VERSIONS: package_versions(),
                numerics.MCAP_RECORD: numerics.mcap_record(),
            }
        return self._static_metadata

    def _base_payloads(self) -> Any:
        """The env's :class:`~pyflyt_engine.payloads.PayloadSet` (an empty tuple without payloads)."""
        payloads = self._base.payloads
        return payloads if payloads is not None else ()

    def _obstacle_meshes(self) -> list[tuple[str, str, str, bytes]]:
        """``(file, attachment name, sha256 hex, content)`` of each mesh file the env's obstacles
        draw, read once; refused if a file no longer holds what the env was built from."""
        if self._meshes is None:
            import hashlib

            field = self._base.obstacles
            meshes = []
            for k, (name, digest) in enumerate((field.mesh_digests if field is not None else {}).items()):
                try:
                    data = Path(name).read_bytes()
                except OSError as exc:
                    raise TelemetryError(
                        f"cannot embed the obstacle mesh file {name!r}: {exc.strerror or exc}"
                    ) from None
                if hashlib.sha256(data).hexdigest() != digest:
                    raise TelemetryError(
                        f"the obstacle mesh file {name!r} changed since the environment was built from it: "
                        "the recording could not re-simulate the episode (build the environment again)"
                    )
                meshes.append((name, f"obstacle_mesh_{k}.obj", digest, data))
            self._meshes = meshes
        return self._meshes

    def _airframe_prims(self) -> list[tuple[str, dict[str, list[dict[str, Any]]]]]:
        if self._airframes is None:
            from pyflyt_engine.urdf import urdf_path

            self._airframes = []
            for vehicle in self._base.world.vehicles:
                path = urdf_path(vehicle.spec)
                text = path.read_text()
                self._airframes.append((text, scene.airframe_primitives(text, path.parent)))
        return self._airframes

    def _open(self, seed: int | None, options: dict[str, Any] | None, rng_state: dict[str, Any]) -> None:
        metadata = self._file_metadata()  # before any file is made: it may refuse (a mesh file changed)
        while True:
            path = self.directory / f"{self.prefix}_{self._next_index:04d}.mcap"
            self._next_index += 1
            if path.exists():
                continue
            try:
                f = McapFileWriter(path, chunk_size=DEFAULT_CHUNK_SIZE, discard_on_error=True)
            except TelemetryError:
                if path.exists():  # created meanwhile (another recorder): never written over, take the next
                    continue
                raise
            break
        self._file = f
        self.paths.append(path)
        for name, data in metadata.items():
            f.metadata(name, data, flush=False)
        f.metadata(
            EPISODE_INFO,
            {
                "index": str(len(self.paths) - 1),
                "seed": "" if seed is None else str(int(seed)),
                "options": json.dumps(_jsonable(options)),
                "rng_state": json.dumps(rng_state),
                # domain randomisation: the values drawn at this reset (JSON; {} without)
                "randomization": json.dumps(dict(self._base.last_randomization)),
                "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            },
            flush=False,
        )
        for i, (urdf, _prims) in enumerate(self._airframe_prims()):
            f.attachment(f"uav_{i}.urdf", "text/xml", urdf.encode())
        payloads = self._base_payloads()
        for payload in payloads:
            f.attachment(f"payload_{payload.spec.name}.urdf", "text/xml", payload.urdf_text.encode())
        for _file, attachment, _digest, content in self._obstacle_meshes():
            f.attachment(attachment, "model/obj", content)
        base = self._base
        world = base.world
        self._ch_tf = f.channel("/tf", "foxglove.FrameTransform", schemas.FRAME_TRANSFORM)
        self._ch_scene = f.channel("/scene", "foxglove.SceneUpdate", schemas.SCENE_UPDATE)
        self._ch_state = []
        self._ch_camera: list[list[int]] = []
        self._ch_scans: list[list[int]] = []
        self._frames = [scene.vehicle_frame(i) for i in range(len(world.vehicles))]
        for i, vehicle in enumerate(world.vehicles):
            self._ch_state.append(
                f.channel(
                    f"/uav/{i}/state",
                    "pyflyt.VehicleState",
                    schemas.VEHICLE_STATE,
                    {"airframe": vehicle.spec.name, "frame_id": scene.vehicle_frame(i)},
                )
            )
            cams = []
            if self.cameras:
                for k in range(len(vehicle.parts.cameras)):
                    cams.append(f.channel(f"/uav/{i}/camera/{k}", "foxglove.CompressedImage", schemas.COMPRESSED_IMAGE))
            self._ch_camera.append(cams)
            self._ch_scans.append(
                [
                    f.channel(
                        f"/uav/{i}/range/{sensor.name}",
                        "foxglove.PointCloud",
                        schemas.POINT_CLOUD,
                        {"frame_id": scene.WORLD_FRAME, "sensor": sensor.kind, "max_range": repr(sensor.max_range)},
                    )
                    for sensor in vehicle.range_sensors
                ]
            )
        #: per vehicle, its noisy sensors' channel (None without sensors)
        self._ch_sensors: list[int | None] = []
        for i, vehicle in enumerate(world.vehicles):
            suite = vehicle.sensors
            layout = json.dumps([f"{n}:{READING_SIZES[n]}" for n in suite.names]) if suite is not None else ""
            self._ch_sensors.append(
                f.channel(f"/uav/{i}/sensors", "pyflyt.Sensors", schemas.SENSORS, {"layout": layout})
                if suite is not None
                else None
            )
        #: per vehicle, its state estimate's channel (None without an estimator)
        self._ch_estimate: list[int | None] = [
            f.channel(f"/uav/{i}/estimate", "pyflyt.Estimate", schemas.ESTIMATE, {"frame_id": scene.WORLD_FRAME})
            if vehicle.sensors is not None and vehicle.sensors.estimator is not None
            else None
            for i, vehicle in enumerate(world.vehicles)
        ]
        self._ch_wind = []
        if world.atmosphere.moving:  # wind or downwash
            for i in range(len(world.vehicles)):
                self._ch_wind.append(
                    f.channel(f"/uav/{i}/wind", "pyflyt.Wind", schemas.WIND, {"frame_id": scene.WORLD_FRAME})
                )
        names = json.dumps(list(base.action_names))
        self._ch_action = f.channel("/uav/0/action", "pyflyt.Action", schemas.ACTION, {"names": names})
        self._ch_reward = f.channel(
            "/reward", "pyflyt.Reward", schemas.REWARD, {"terms": json.dumps(list(base.reward_preset.terms))}
        )
        self._ch_episode = f.channel("/episode", "pyflyt.EpisodeEvent", schemas.EPISODE_EVENT)
        self._return = 0.0
        self._length = 0
        self._last_flush = 0.0
        self._markers: bytes | None = None
        self._last_images: dict[tuple[int, int], int] = {}
        self._last_info: dict[str, Any] = {}

    def _writing(self) -> McapFileWriter:
        """The file an episode is being written to (the ``_write_*`` methods run only while one is open)."""
        if self._file is None:
            raise RuntimeError("the recorder has no open recording to write to: reset() opens one")
        return self._file

    def _common(self, ns: int) -> dict[str, Any]:
        return {"timestamp": scene.stamp(ns), "step": self._length, "time": ns * 1e-9}

    def _write_frames(self, ns: int) -> None:
        f = self._writing()
        world = self._base.world
        stamp = scene.stamp(ns)
        time_s = ns * 1e-9
        payloads = self._base_payloads()
        for payload in payloads:
            ps = payloads.state(payload.spec.name)
            f.write(
                self._ch_tf,
                ns,
                scene.frame_transform(
                    ns, scene.WORLD_FRAME, scene.payload_frame(payload.spec.name), ps.position, ps.quaternion
                ),
            )
        for i, vehicle in enumerate(world.vehicles):
            s = vehicle.state
            x, y, z = s.lin_pos
            qx, qy, qz, qw = s.quaternion
            f.write(
                self._ch_tf,
                ns,
                {
                    "timestamp": stamp,
                    "parent_frame_id": scene.WORLD_FRAME,
                    "child_frame_id": self._frames[i],
                    "translation": {"x": x, "y": y, "z": z},
                    "rotation": {"x": qx, "y": qy, "z": qz, "w": qw},
                },
            )
            f.write(
                self._ch_state[i],
                ns,
                {
                    "timestamp": stamp,
                    "step": self._length,
                    "time": time_s,
                    "lin_pos": s.lin_pos,
                    "lin_vel": s.lin_vel,
                    "lin_vel_ground": s.lin_vel_ground,
                    "ang_pos": s.ang_pos,
                    "quaternion": s.quaternion,
                    "ang_vel": s.ang_vel,
                    "ang_vel_ground": s.ang_vel_ground,
                    "aux": vehicle.aux_state,
                    "setpoint": vehicle.setpoint,
                    "mode": vehicle.mode.name,
                    "collision": world.collided(i) if self._length else False,
                },
            )
            if self._ch_wind:
                self._write_wind(ns, stamp, time_s, i, vehicle)
            if self._ch_sensors[i] is not None:
                f.write(
                    self._ch_sensors[i],  # type: ignore[arg-type]
                    ns,
                    {"timestamp": stamp, "step": self._length, "time": time_s, "values": vehicle.sensors.values()},
                )
            if self._ch_estimate[i] is not None:
                est = vehicle.sensors.estimator
                f.write(
                    self._ch_estimate[i],  # type: ignore[arg-type]
                    ns,
                    {
                        "timestamp": stamp,
                        "step": self._length,
                        "time": time_s,
                        "quaternion": est.quaternion,
                        "ang_pos": est.euler,
                        "lin_vel_ground": est.velocity,
                        "lin_pos": est.position,
                        "gyro_bias": est.bias,
                    },
                )
            for k, channel in enumerate(self._ch_scans[i]):
                self._write_scan(ns, channel, i, k)
            cameras = vehicle.parts.cameras
            if cameras:
                from pyflyt_engine.components.camera import camera_pose

                body = np.asarray(scene.quaternion_to_matrix(s.quaternion))
                for k, params in enumerate(cameras):
                    _eye, forward, up = camera_pose(params, s.lin_pos, s.quaternion)
                    rot = np.column_stack([forward, np.cross(up, forward), up])
                    relative = matrix_to_quaternion(body.T @ rot)
                    f.write(
                        self._ch_tf,
                        ns,
                        scene.frame_transform(
                            ns, scene.vehicle_frame(i), scene.camera_frame(i, k), params.position, relative
                        ),
                    )
                    if self._ch_camera[i]:
                        self._write_image(ns, i, k)

    def _write_scan(self, ns: int, channel: int, i: int, k: int) -> None:
        """Range sensor ``k`` of vehicle ``i``: its hit points as a point cloud in the world frame."""
        import base64

        from pyflyt_engine.components.range_sensor import points

        world = self._base.world
        vehicle = world.vehicles[i]
        s = vehicle.state
        cloud = points(vehicle.range_sensors[k], world.scan(i, k), s.lin_pos, s.quaternion).astype("<f4")
        self._writing().write(
            channel,
            ns,
            {
                "timestamp": scene.stamp(ns),
                "frame_id": scene.WORLD_FRAME,
                "pose": scene.pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
                "point_stride": 12,
                "fields": [
                    {"name": "x", "offset": 0, "type": 7},
                    {"name": "y", "offset": 4, "type": 7},
                    {"name": "z", "offset": 8, "type": 7},
                ],
                "data": base64.b64encode(np.ascontiguousarray(cloud).tobytes()).decode(),
            },
        )

    def _write_wind(self, ns: int, stamp: dict[str, int], time_s: float, i: int, vehicle: Any) -> None:
        """The wind at vehicle ``i`` (channel ``/uav/<i>/wind``) and its arrow in the scene."""
        s = vehicle.state
        wind = self._base.world.wind_at(i)
        (u, v, w), (p, q, r) = self._base.world.air_velocity(i)
        self._writing().write(
            self._ch_wind[i],
            ns,
            {
                "timestamp": stamp,
                "step": self._length,
                "time": time_s,
                "velocity": wind[:3],
                "rotary": wind[3:],
                "air_velocity": (u, v, w),
                "air_rates": (p, q, r),
            },
        )
        self._writing().write(self._ch_scene, ns, scene.scene_update([scene.wind_entity(ns, i, s.lin_pos, wind[:3])]))

    def _write_image(self, ns: int, i: int, k: int) -> None:
        images = self._base.world.capture(i, k)
        if id(images) == self._last_images.get((i, k)) or "rgba" not in images:
            return
        self._last_images[(i, k)] = id(images)
        from PIL import Image

        buffer = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(images["rgba"][:, :, :3])).save(
            buffer, format="JPEG", quality=self.jpeg_quality
        )
        import base64

        self._writing().write(
            self._ch_camera[i][k],
            ns,
            {
                "timestamp": scene.stamp(ns),
                "frame_id": scene.camera_frame(i, k),
                "data": base64.b64encode(buffer.getvalue()).decode(),
                "format": "jpeg",
            },
        )

    def _write_markers(self, ns: int, force: bool) -> None:
        points, radius = self._base.scene_markers()
        key = points.tobytes()
        if not force and key == self._markers:
            return
        self._markers = key
        self._writing().write(self._ch_scene, ns, scene.scene_update([scene.waypoints_entity(ns, points, radius)]))

    def _write_reset(self, info: dict[str, Any], seed: int | None) -> None:
        f = self._writing()
        base = self._base
        world = base.world
        ns = to_ns(world.elapsed)
        if self._static_entities is None or self._static_entities[0] != ns:
            static = []
            if world.ground_id is not None:
                static.append(scene.ground_entity(ns, float(base.config.flight_dome_size)))
            for i, (_, prims) in enumerate(self._airframe_prims()):
                static.append(
                    scene.entity(
                        ns,
                        f"uav_{i}/airframe",
                        scene.vehicle_frame(i),
                        frame_locked=True,
                        metadata={"airframe": world.vehicles[i].spec.name},
                        **prims,
                    )
                )
            self._static_entities = (ns, static)
        entities = list(self._static_entities[1])
        vehicle_bodies = {v.body_id for v in world.vehicles}
        for payload in self._base_payloads():  # payloads: locked to their own frames (see _write_frames)
            vehicle_bodies.add(payload.body_id)
            prims = scene.airframe_primitives(payload.urdf_text, link_name="body")
            name = payload.spec.name
            frame = scene.payload_frame(name)
            entities.append(scene.entity(ns, frame, frame, frame_locked=True, metadata={"payload": name}, **prims))
        for body in world.contact_bodies:  # scenery a task added (may move between episodes)
            if body != world.ground_id and body not in vehicle_bodies:
                e = scene.body_entity(ns, world.client, body)
                if e is not None:
                    entities.append(e)
        f.write(self._ch_scene, ns, scene.scene_update(entities))
        self._write_markers(ns, force=True)
        self._write_frames(ns)
        self._last_info = dict(info)
        f.write(
            self._ch_episode,
            ns,
            {
                **self._common(ns),
                "event": "reset",
                "seed": None if seed is None else int(seed),
                "terminated": False,
                "truncated": False,
                "reason": "",
                "success": bool(info.get("success", False)),
                "return": 0.0,
                "length": 0,
                "info": _scalar_info(info),
            },
        )
        f.flush()

    def _write_step(self, action: Any, reward: float, terminated: bool, truncated: bool, info: dict[str, Any]) -> None:
        f = self._writing()
        base = self._base
        world = base.world
        self._length += 1
        self._return += reward
        ns = to_ns(world.elapsed)
        try:
            raw = np.asarray(action, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raw = None
        common = self._common(ns)
        f.write(self._ch_action, ns, {**common, "action": raw, "applied": base.last_action})
        self._write_frames(ns)
        common["reward"] = reward
        common["return"] = self._return
        common["terms"] = base.last_reward_terms  # also when info carries no reward_terms (info_reward_terms=False)
        f.write(self._ch_reward, ns, common)
        self._write_markers(ns, force=False)
        self._last_info = info
        if terminated or truncated:
            self._write_end(ns, terminated, truncated, end_reason(terminated, truncated, info), info)
            self._close_file()
        elif world.elapsed - self._last_flush >= self.chunk_seconds - 1e-9:
            self._last_flush = world.elapsed
            f.flush()

    def _write_end(self, ns: int, terminated: bool, truncated: bool, reason: str, info: dict[str, Any]) -> None:
        self._writing().write(
            self._ch_episode,
            ns,
            {
                **self._common(ns),
                "event": "end" if reason != "stopped" else "stopped",
                "seed": None,
                "terminated": terminated,
                "truncated": truncated,
                "reason": reason,
                "success": bool(info.get("success", False)),
                "return": self._return,
                "length": self._length,
                "info": _scalar_info(info),
                **({"measures": plain(info[MEASURES])} if reason != "stopped" and MEASURES in info else {}),
            },
        )

    def _stop(self, reason: str) -> None:
        if self._file is None:
            return
        try:
            if not self._file.closed:
                ns = to_ns(self._base.world.elapsed)
                self._write_end(ns, False, False, reason, self._last_info)
        finally:
            self._close_file()

    def _close_file(self) -> None:
        if self._file is not None:
            f = self._file
            try:
                f.close()
            finally:
                self._file = None
                if f.discarded and f.path in self.paths:  # a write failed: the file is gone, so is its name
                    self.paths.remove(f.path)

    def __del__(self) -> None:  # the file's own finaliser finishes it too; this adds the 'stopped' event
        try:
            self._stop("stopped")
        except Exception:  # noqa: BLE001
            pass


__all__ = ["FORMAT_VERSION", "RecordEpisode", "end_reason", "package_versions"]
