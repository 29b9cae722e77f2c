"""URDF generation from a vehicle spec.

Every airframe is one rigid link whose origin is the centre of mass: the inertial
block carries the spec's mass and inertia, and each shape becomes a ``<visual>`` and/or
``<collision>`` element.  The generated text is cached on disk by content hash, so
spawning the same airframe twice parses it once.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from pyflyt_engine.spec import ShapeSpec, SurfaceSpec, UAVSpec


def _fmt(values: tuple[float, ...] | list[float]) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _geometry(shape: ShapeSpec, base_dir: Path) -> str:
    if shape.type == "box":
        return f'<box size="{_fmt(shape.size)}"/>'  # type: ignore[arg-type]
    if shape.type == "cylinder":
        return f'<cylinder radius="{shape.radius:.9g}" length="{shape.length:.9g}"/>'
    if shape.type == "sphere":
        return f'<sphere radius="{shape.radius:.9g}"/>'
    mesh = Path(shape.mesh)  # type: ignore[arg-type]
    if not mesh.is_absolute():
        mesh = (base_dir / mesh).resolve()
    return f"<mesh filename={quoteattr(str(mesh))} scale=\"{_fmt(shape.scale)}\"/>"


def _surface_plate(surface: SurfaceSpec) -> ShapeSpec:
    """A thin visual plate for a lifting surface: chord along x, span along y, then rotated
    so that x is the chord axis and z the normal axis."""
    c = np.asarray(surface.chord_axis, dtype=float)
    n = np.asarray(surface.normal_axis, dtype=float)
    matrix = np.column_stack([c, np.cross(n, c), n])
    pitch = -math.asin(max(-1.0, min(1.0, matrix[2, 0])))
    roll = math.atan2(matrix[2, 1], matrix[2, 2])
    yaw = math.atan2(matrix[1, 0], matrix[0, 0])
    return ShapeSpec(
        type="box",
        size=(surface.chord, surface.span, max(0.004, 0.02 * surface.chord)),
        position=surface.position,
        rpy=(roll, pitch, yaw),
        color=surface.color,
        collision=False,
    )


def generate_urdf(spec: UAVSpec) -> str:
    """URDF text for ``spec`` (one link named ``body``).

    The inertia written is the diagonal of the spec's inertia tensor about the centre of
    mass, in the spec's body axes.  PyBullet simulates a link on the principal axes of
    its inertia: with products of inertia in the file, the simulated body frame (whose
    pose the engine reads and in which it applies every load) would be rotated away
    from the airframe's geometry (by about 1.2 degrees for the shipped fixed-wing).
    Products of inertia are therefore dropped; ``pyflyt uav show`` prints the full
    tensor so their size can be checked.
    """
    base_dir = Path(spec.source).parent if spec.source and Path(spec.source).exists() else Path.cwd()
    inertia = spec.inertia_matrix()
    com = spec.center_of_mass()
    lines = [
        '<?xml version="1.0"?>',
        f"<robot name={quoteattr(spec.name)}>",
        '  <link name="body">',
        "    <inertial>",
        '      <origin xyz="0 0 0" rpy="0 0 0"/>',
        f'      <mass value="{spec.total_mass():.9g}"/>',
        # diagonal only: PyBullet puts a link's inertia on its principal axes and would
        # otherwise rotate the body frame away from the spec's axes (see generate_urdf)
        f'      <inertia ixx="{inertia[0, 0]:.9g}" ixy="0" ixz="0" '
        f'iyy="{inertia[1, 1]:.9g}" iyz="0" izz="{inertia[2, 2]:.9g}"/>',
        "    </inertial>",
    ]
    shapes = list(spec.body.shapes) + [_surface_plate(s) for s in spec.surfaces if s.visual]
    for i, shape in enumerate(shapes):
        position = np.asarray(shape.position, dtype=float) - com
        origin = f'<origin xyz="{_fmt(position)}" rpy="{_fmt(shape.rpy)}"/>'
        geometry = _geometry(shape, base_dir)
        if shape.visual:
            lines += [
                f'    <visual name="shape_{i}">',
                f"      {origin}",
                f"      <geometry>{geometry}</geometry>",
                f'      <material name="shape_{i}_color"><color rgba="{_fmt(shape.color)}"/></material>',
                "    </visual>",
            ]
        if shape.collision:
            lines += [
                f'    <collision name="shape_{i}">',
                f"      {origin}",
                f"      <geometry>{geometry}</geometry>",
                "    </collision>",
            ]
    lines += ["  </link>", "</robot>", ""]
    return "\n".join(lines)


def _cache_dir() -> Path:
    path = Path(os.environ.get("PYFLYT_CACHE_DIR", Path(tempfile.gettempdir()) / f"pyflyt_urdf_{os.getuid()}"))
    path.mkdir(parents=True, exist_ok=True)
    return path


def urdf_path(spec: UAVSpec) -> Path:
    """Path of a URDF file for ``spec``: the user's own, or a generated one (cached)."""
    if spec.body.urdf is not None:
        path = Path(spec.body.urdf)
        if not path.is_absolute() and spec.source:
            path = Path(spec.source).parent / path
        return path
    text = generate_urdf(spec)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = _cache_dir() / f"{spec.name}_{digest}.urdf"
    if not path.exists():
        # write-then-rename so concurrent processes never read a half-written file
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    return path
