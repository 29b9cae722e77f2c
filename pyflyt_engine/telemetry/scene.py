"""Foxglove 3-D content of a recording: frames (``/tf``) and scene entities (``/scene``).

Frames: ``world`` (the ENU ground frame), ``uav_<i>`` (vehicle ``i``'s body frame, origin at
its centre of mass, x forward, y left, z up) and ``uav_<i>/camera_<k>`` (on-board camera
``k``: x along the optical axis, z image-up, the project's camera convention).

Entities: ``ground`` (plate, grid of 1, 10, 100 ... m and the flight-dome circle), ``scenery/<body>`` (bodies
a task added to the world, e.g. a landing pad, and the obstacles, from their PyBullet visual shapes: a
mesh from an OBJ file as a triangle list of its vertices at the mesh scale, another mesh format as a model),
``uav_<i>/airframe`` (the airframe's visual primitives from its URDF, locked to
``uav_<i>``) and ``waypoints`` (the task's markers, replaced whenever they change).
"""

from __future__ import annotations

import base64
import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_engine.frames import euler_to_quaternion, matrix_to_quaternion, quaternion_to_matrix
from pyflyt_engine.obstacles import read_obj

WORLD_FRAME = "world"

_MESH_TYPES = {
    ".stl": "model/stl",
    ".obj": "model/obj",
    ".dae": "model/vnd.collada+xml",
    ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json",
}
_MAX_EMBEDDED_MESH = 4 * 1024 * 1024


def payload_frame(name: str) -> str:
    """Frame of payload ``name``: origin at its centre of mass, its own axes."""
    return f"payload/{name}"


def vehicle_frame(index: int) -> str:
    return f"uav_{index}"


def camera_frame(index: int, camera: int) -> str:
    return f"uav_{index}/camera_{camera}"


def stamp(ns: int) -> dict[str, int]:
    """MCAP nanoseconds -> Foxglove ``time`` {sec, nsec}."""
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _xyz(v: Any) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def _quat(q: Any) -> dict[str, float]:
    return {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}


def _color(rgba: Any) -> dict[str, float]:
    return {"r": float(rgba[0]), "g": float(rgba[1]), "b": float(rgba[2]), "a": float(rgba[3])}


def pose(position: Any = (0.0, 0.0, 0.0), quaternion: Any = (0.0, 0.0, 0.0, 1.0)) -> dict[str, Any]:
    return {"position": _xyz(position), "orientation": _quat(quaternion)}


def frame_transform(ns: int, parent: str, child: str, translation: Any, rotation: Any) -> dict[str, Any]:
    """A ``foxglove.FrameTransform`` message."""
    return {
        "timestamp": stamp(ns),
        "parent_frame_id": parent,
        "child_frame_id": child,
        "translation": _xyz(translation),
        "rotation": _quat(rotation),
    }


def entity(
    ns: int,
    entity_id: str,
    frame_id: str,
    *,
    frame_locked: bool = False,
    metadata: dict[str, str] | None = None,
    **primitives: list[dict[str, Any]],
) -> dict[str, Any]:
    """A ``foxglove.SceneEntity`` (every primitive list present, empty by default; lifetime 0 = forever)."""
    out: dict[str, Any] = {
        "timestamp": stamp(ns),
        "frame_id": frame_id,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": frame_locked,
        "metadata": [{"key": k, "value": v} for k, v in (metadata or {}).items()],
    }
    for kind in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"):
        out[kind] = list(primitives.get(kind, []))
    return out


def scene_update(entities: list[dict[str, Any]], deletions: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """A ``foxglove.SceneUpdate`` message."""
    return {"deletions": deletions or [], "entities": entities}


# ------------------------------------------------------------------------ airframe


def _floats(text: str | None, default: tuple[float, ...]) -> tuple[float, ...]:
    if not text:
        return default
    return tuple(float(v) for v in text.split())


def airframe_primitives(
    urdf_text: str, base_dir: Path | None = None, link_name: str | None = None
) -> dict[str, list[dict[str, Any]]]:
    """Foxglove primitives of the visuals of a URDF's first link (or the link ``link_name``), in that link's frame.

    The generated URDFs are one link whose origin is the centre of mass (the PyBullet base
    frame), so the primitives sit right when attached to the vehicle frame.  Boxes, cylinders
    and spheres become cube/cylinder/sphere primitives; meshes become model primitives
    (embedded when the file is readable, else referenced by ``file://`` URL).
    """
    root = ET.fromstring(urdf_text)
    materials = {}
    for mat in root.findall("material"):
        color = mat.find("color")
        if color is not None and mat.get("name"):
            materials[mat.get("name")] = _floats(color.get("rgba"), (0.5, 0.5, 0.5, 1.0))
    link = root.find("link") if link_name is None else root.find(f"link[@name='{link_name}']")
    out: dict[str, list[dict[str, Any]]] = {"cubes": [], "cylinders": [], "spheres": [], "models": []}
    if link is None:
        return out
    for visual in link.findall("visual"):
        origin = visual.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0))
        rpy = _floats(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0))
        p = pose(xyz, euler_to_quaternion(*rpy))
        rgba: tuple[float, ...] = (0.5, 0.5, 0.5, 1.0)
        material = visual.find("material")
        if material is not None:
            color = material.find("color")
            if color is not None:
                rgba = _floats(color.get("rgba"), rgba)
            elif material.get("name") in materials:
                rgba = materials[material.get("name")]
        geometry = visual.find("geometry")
        shape = geometry[0] if geometry is not None and len(geometry) else None
        if shape is None:
            continue
        if shape.tag == "box":
            out["cubes"].append(
                {"pose": p, "size": _xyz(_floats(shape.get("size"), (0.1, 0.1, 0.1))), "color": _color(rgba)}
            )
        elif shape.tag == "cylinder":
            d = 2 * float(shape.get("radius", 0.05))
            size = {"x": d, "y": d, "z": float(shape.get("length", 0.1))}
            out["cylinders"].append(
                {"pose": p, "size": size, "bottom_scale": 1.0, "top_scale": 1.0, "color": _color(rgba)}
            )
        elif shape.tag == "sphere":
            d = 2 * float(shape.get("radius", 0.05))
            out["spheres"].append({"pose": p, "size": {"x": d, "y": d, "z": d}, "color": _color(rgba)})
        elif shape.tag == "mesh":
            filename = shape.get("filename", "")
            path = Path(filename.removeprefix("file://"))
            if not path.is_absolute() and base_dir is not None:
                path = base_dir / path
            out["models"].append(model_primitive(path, filename, p, _floats(shape.get("scale"), (1.0, 1.0, 1.0)), rgba))
    return out


def model_primitive(path: Path, filename: str, p: dict[str, Any], scale: Any, rgba: Any) -> dict[str, Any]:
    """A ``foxglove.ModelPrimitive`` of the mesh file at ``path``: its bytes embedded when it is
    readable and at most 4 MiB, else referenced by ``file://`` URL (``filename`` as given when
    the path is relative and unreadable)."""
    model: dict[str, Any] = {
        "pose": p,
        "scale": _xyz(scale),
        "color": _color(rgba),
        "override_color": False,
        "url": "",
        "media_type": _MESH_TYPES.get(path.suffix.lower(), ""),
        "data": "",
    }
    try:
        if path.stat().st_size <= _MAX_EMBEDDED_MESH:
            model["data"] = base64.b64encode(path.read_bytes()).decode()
        else:
            model["url"] = path.resolve().as_uri()
    except OSError:
        model["url"] = path.resolve().as_uri() if path.is_absolute() else filename
    return model


def obj_triangles(path: Path, scale: Any, p: dict[str, Any], rgba: Any) -> dict[str, Any]:
    """A ``foxglove.TriangleListPrimitive`` of the Wavefront OBJ file at ``path``, its vertices
    multiplied by ``scale`` per axis (as PyBullet's ``meshScale``), one point per vertex and
    three indices per triangle (:func:`pyflyt_engine.obstacles.read_obj`, which the env's
    check at load already ran on an obstacle's file); ``ValueError`` if it is not one."""
    mesh = read_obj(path)
    sx, sy, sz = (float(v) for v in scale)
    return {
        "pose": p,
        "points": [{"x": x * sx, "y": y * sy, "z": z * sz} for x, y, z in mesh.vertices],
        "color": _color(rgba),
        "colors": [],
        "indices": list(mesh.indices),
    }


# --------------------------------------------------------------------- world scenery


def grid_spacing(dome: float) -> float:
    """1, 10, 100 ... m: at most about 40 grid cells across the dome."""
    return float(10 ** max(0, math.ceil(math.log10(max(2 * dome, 1.0) / 40))))


def ground_entity(ns: int, dome: float) -> dict[str, Any]:
    """A grey plate under the flight dome, a grid (1, 10, 100 ... m) and the dome's ground circle."""
    step = grid_spacing(dome)
    half = step * math.ceil(dome / step)
    plate = {
        "pose": pose((0.0, 0.0, -0.001)),
        "size": {"x": 2 * half, "y": 2 * half, "z": 0.002},
        "color": _color((0.55, 0.57, 0.6, 1.0)),
    }
    points = []
    for v in np.arange(-half, half + step / 2, step):
        points += [_xyz((v, -half, 0.0)), _xyz((v, half, 0.0)), _xyz((-half, v, 0.0)), _xyz((half, v, 0.0))]
    grid = {
        "type": 2,
        "pose": pose(),
        "thickness": 0.01,
        "scale_invariant": False,
        "points": points,
        "color": _color((0.35, 0.36, 0.38, 1.0)),
        "colors": [],
        "indices": [],
    }
    angles = np.linspace(0.0, 2 * math.pi, 96, endpoint=False)
    circle = {
        "type": 1,
        "pose": pose(),
        "thickness": 0.02,
        "scale_invariant": False,
        "points": [_xyz((dome * math.cos(a), dome * math.sin(a), 0.0)) for a in angles],
        "color": _color((0.9, 0.3, 0.2, 1.0)),
        "colors": [],
        "indices": [],
    }
    return entity(
        ns,
        "ground",
        WORLD_FRAME,
        cubes=[plate],
        lines=[grid, circle],
        metadata={"flight_dome_radius_m": f"{dome:g}", "grid_spacing_m": f"{step:g}"},
    )


def body_entity(ns: int, client: int, body_id: int) -> dict[str, Any] | None:
    """A PyBullet body's base visual shapes as an entity in the world frame (None if it has none)."""
    from pyflyt_engine.bullet import pybullet as p

    base_pos, base_orn = p.getBasePositionAndOrientation(body_id, physicsClientId=client)
    rotation = quaternion_to_matrix(base_orn)
    prims: dict[str, list[dict[str, Any]]] = {
        "cubes": [],
        "cylinders": [],
        "spheres": [],
        "triangles": [],
        "models": [],
    }
    meshes: list[str] = []
    for shape in p.getVisualShapeData(body_id, physicsClientId=client):
        link, kind, dims, local_pos, local_orn, rgba = shape[1], shape[2], shape[3], shape[5], shape[6], shape[7]
        if link != -1:
            continue
        position = np.asarray(base_pos) + rotation @ np.asarray(local_pos)
        orientation = matrix_to_quaternion(rotation @ quaternion_to_matrix(local_orn))
        pp = pose(position, orientation)
        if kind == p.GEOM_BOX:
            prims["cubes"].append({"pose": pp, "size": _xyz(dims), "color": _color(rgba)})
        elif kind == p.GEOM_CYLINDER or kind == p.GEOM_CAPSULE:
            d = 2 * dims[1]
            prims["cylinders"].append(
                {
                    "pose": pp,
                    "size": {"x": d, "y": d, "z": dims[0]},
                    "bottom_scale": 1.0,
                    "top_scale": 1.0,
                    "color": _color(rgba),
                }
            )
        elif kind == p.GEOM_SPHERE:
            d = 2 * dims[0]
            prims["spheres"].append({"pose": pp, "size": {"x": d, "y": d, "z": d}, "color": _color(rgba)})
        elif kind == p.GEOM_MESH and shape[4]:  # dims: the mesh scale; shape[4]: the file PyBullet read
            filename = shape[4].decode("utf-8", errors="replace")
            path = Path(filename)
            meshes.append(path.name)
            try:
                if path.suffix.lower() != ".obj":
                    raise ValueError("not an OBJ file")
                prims["triangles"].append(obj_triangles(path, dims, pp, rgba))
            except ValueError:  # another format (or gone since the load): the file itself, as a model
                prims["models"].append(model_primitive(path, filename, pp, dims, rgba))
    if not any(prims.values()):
        return None
    metadata = {"mesh": ", ".join(meshes)} if meshes else None
    return entity(ns, f"scenery/{body_id}", WORLD_FRAME, frame_locked=False, metadata=metadata, **prims)


def wind_entity(ns: int, index: int, position: Any, wind: Any, metres_per_mps: float = 0.2) -> dict[str, Any]:
    """The wind at vehicle ``index`` as an arrow from its position along the wind (world
    frame), ``metres_per_mps`` long per m/s of wind; no arrow in still air."""
    wx, wy, wz = (float(v) for v in wind)
    speed = math.sqrt(wx * wx + wy * wy + wz * wz)
    arrows = []
    if speed > 1e-9:
        # the quaternion turning +x onto the wind direction (half-way vector construction)
        dx, dy, dz = wx / speed, wy / speed, wz / speed
        w = 1.0 + dx
        if w < 1e-9:  # opposite to +x: half a turn about z
            q = (0.0, 0.0, 1.0, 0.0)
        else:
            norm = math.sqrt(w * w + dz * dz + dy * dy)
            q = (0.0, -dz / norm, dy / norm, w / norm)
        length = speed * metres_per_mps
        arrows.append(
            {
                "pose": pose(position, q),
                "shaft_length": 0.75 * length,
                "shaft_diameter": 0.02,
                "head_length": 0.25 * length,
                "head_diameter": 0.05,
                "color": _color((0.2, 0.5, 1.0, 0.9)),
            }
        )
    return entity(ns, f"uav_{index}/wind", WORLD_FRAME, arrows=arrows, metadata={"speed_mps": f"{speed:.3f}"})


def waypoints_entity(ns: int, points: np.ndarray, radius: float) -> dict[str, Any]:
    """The task's markers (next first, brightest) as spheres in the world frame."""
    n = len(points)
    spheres = []
    for i, point in enumerate(points):
        green = 1.0 - 0.7 * i / max(n, 1)
        d = 2 * radius
        spheres.append({"pose": pose(point), "size": {"x": d, "y": d, "z": d}, "color": _color((0.1, green, 0.1, 0.6))})
    return entity(ns, "waypoints", WORLD_FRAME, spheres=spheres, metadata={"remaining": str(n)})
