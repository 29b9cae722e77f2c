"""Obstacles declared in an env config: static boxes, cylinders, spheres and meshes.

``obstacles:`` in an env YAML (:class:`ObstaclesConfig`) holds

* ``items``: obstacles at fixed poses (``type: box | cylinder | sphere | mesh``), built
  once with the world;
* ``generators``: seeded layouts drawn again at every reset from the episode's numpy
  Generator -- ``kind: forest`` (vertical cylinders) or ``kind: room`` (boxes on the
  floor, optionally walled) -- with a density, size ranges and a keep-out radius around
  the spawn point and the task's goals;
* ``crash_on_contact`` (default true): touching an obstacle ends the episode as a crash,
  whatever the task.

Every obstacle is a static PyBullet body (mass 0) tracked by the world's contacts
(:meth:`~pyflyt_engine.world.World.add_body`).  A generated layout is rebuilt at each
reset: the previous bodies are removed (last first, so PyBullet hands the same body ids
out again) and the new ones created, and the world's saved state is replaced by one
holding them (:meth:`~pyflyt_engine.world.World.replace_bodies`).  Collision and visual shapes are cached by their
dimensions, and drawn dimensions are rounded to ``size_resolution``, so a long run
creates a bounded number of shapes.

Placement is plain Python floats (``rng.random()`` draws and ``math``), so a seed gives
the same layout on every machine; the recorder writes every obstacle into the MCAP
scene at each reset (``scenery/<body id>`` entities of ``/scene``; a mesh as the triangles
:func:`read_obj` reads from its file, at its scale) and embeds each mesh file (with the
digest :attr:`ObstacleField.mesh_digests` kept at load), so ``pyflyt replay --verify``
flies the recording's copy (checked by :func:`parse_obj`) instead of the file.
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, NamedTuple, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from pyflyt_engine.errors import ConfigError

if TYPE_CHECKING:
    from pyflyt_engine.world import World

Vec3 = tuple[float, float, float]
Range = tuple[float, float]
RGBA = tuple[float, float, float, float]

#: where an obstacle that could not be placed is parked: under the ground plane, out of reach
PARKED_Z = -100.0


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


def _colour(value: RGBA) -> RGBA:
    if not all(0.0 <= c <= 1.0 for c in value):
        raise ValueError(f"color components must be in [0, 1], got {list(value)}")
    return value


def _range(value: Range, what: str, positive: bool = True) -> Range:
    low, high = value
    if positive and low <= 0:
        raise ValueError(f"{what}: the lower bound must be > 0, got {low}")
    if low > high:
        raise ValueError(f"{what}: need min <= max, got [{low}, {high}]")
    return value


class _Placed(_Model):
    position: Vec3 = Field(description="centre of the obstacle (x, y, z) [m], ground frame")
    orientation: Vec3 = Field((0.0, 0.0, 0.0), description="(roll, pitch, yaw) [rad]")
    color: RGBA = Field((0.45, 0.45, 0.45, 1.0), description="RGBA in [0, 1] (rendering and the MCAP scene)")

    @field_validator("color")
    @classmethod
    def _color(cls, value: RGBA) -> RGBA:
        return _colour(value)


class BoxObstacle(_Placed):
    """A box; ``size`` is its full extent along its own x, y, z."""

    type: Literal["box"] = "box"
    size: Vec3 = Field(description="full extents (x, y, z) [m], each > 0")

    @field_validator("size")
    @classmethod
    def _size(cls, value: Vec3) -> Vec3:
        if min(value) <= 0:
            raise ValueError(f"size: every extent must be > 0 m, got {list(value)}")
        return value


class CylinderObstacle(_Placed):
    """A cylinder along its own z axis (upright at zero orientation)."""

    type: Literal["cylinder"] = "cylinder"
    radius: float = Field(gt=0, description="[m]")
    height: float = Field(gt=0, description="[m]")


class SphereObstacle(_Placed):
    """A sphere."""

    type: Literal["sphere"] = "sphere"
    radius: float = Field(gt=0, description="[m]")


class MeshObstacle(_Placed):
    """A triangle mesh from a Wavefront OBJ file (static, so it may be concave); the file is
    read whole at load (:func:`read_obj`) and refused, by name, if it is not one."""

    type: Literal["mesh"] = "mesh"
    file: str = Field(description="path to a .obj file (relative paths: from the working directory)")
    scale: Vec3 = Field((1.0, 1.0, 1.0), description="scale of the mesh's coordinates per axis")

    @field_validator("file")
    @classmethod
    def _file(cls, value: str) -> str:
        path = Path(value).expanduser()
        if path.suffix.lower() != ".obj":
            raise ValueError(f"file: a mesh obstacle needs a Wavefront .obj file, got {value!r}")
        if not path.is_file():
            raise ValueError(f"file: no such mesh file {value!r} (resolved to {path.resolve()})")
        read_obj(path.resolve())  # the whole file, so a malformed or cut-off one is refused here
        return str(path.resolve())

    @field_validator("scale")
    @classmethod
    def _scale(cls, value: Vec3) -> Vec3:
        if min(value) <= 0:
            raise ValueError(f"scale: every factor must be > 0, got {list(value)}")
        return value


#: the largest mesh file read [bytes]
MAX_MESH_BYTES = 64 * 1024 * 1024
#: the most vertices and triangles one OBJ file may hold: parsed in about 1 s on one 2026 CPU core
#: (measured: 100 000 vertices and 200 000 triangles, 6.8 MB, 1.07 s), so a mesh within
#: MAX_MESH_BYTES cannot hold a command for minutes (8 M triangles took about five)
MAX_OBJ_VERTICES = 100_000
MAX_OBJ_TRIANGLES = 200_000


class ObjMesh(NamedTuple):
    """The triangles of a Wavefront OBJ file (:func:`read_obj`), in the file's own coordinates."""

    #: every vertex (``v`` line) in file order: (x, y, z)
    vertices: tuple[tuple[float, float, float], ...]
    #: three 0-based vertex indices per triangle; a face of k > 3 corners is fanned from its
    #: first corner into k - 2 triangles
    indices: tuple[int, ...]


def read_obj(path: str | Path) -> ObjMesh:
    """The vertices and triangles of the Wavefront OBJ text at ``path``; ``ValueError`` naming
    the file (and the line) when it is not one.

    Read as data, at most :data:`MAX_MESH_BYTES`: ``v`` lines give the vertices (the first
    three numbers; a fourth ``w`` or a vertex colour is allowed and left out), ``f`` lines the
    faces (each corner ``i``, ``i/t``, ``i//n`` or ``i/t/n``, 1-based, negative counting back
    from the last vertex read); every other statement (normals, texture coordinates, groups,
    materials, comments) is skipped.  Refused: a binary file, a vertex without three finite
    numbers, a face of fewer than three corners or naming a vertex the file does not hold (what
    a file cut short typically shows), and a file without a face.  Cached by path, size and
    modification time, so the env's check at load and the recorder read a file once.
    """
    path = Path(path)
    try:
        stat = path.stat()
    except OSError as exc:
        raise ValueError(f"file: cannot read mesh file {str(path)!r}: {exc.strerror or exc}") from None
    return _read_obj(str(path), stat.st_size, stat.st_mtime_ns)


@functools.lru_cache(maxsize=16)
def _read_obj(name: str, size: int, _mtime_ns: int) -> ObjMesh:
    if size > MAX_MESH_BYTES:
        raise ValueError(f"file: {name!r} is larger than {MAX_MESH_BYTES // (1024 * 1024)} MiB")
    try:
        data = Path(name).read_bytes()
    except OSError as exc:
        raise ValueError(f"file: cannot read mesh file {name!r}: {exc.strerror or exc}") from None
    return parse_obj(data, name)


def parse_obj(data: bytes, name: str) -> ObjMesh:
    """:func:`read_obj` of the bytes ``data`` (a mesh file's content; ``name`` names it in a
    refusal): the same checks, the same result."""
    if len(data) > MAX_MESH_BYTES:
        raise ValueError(f"file: {name!r} is larger than {MAX_MESH_BYTES // (1024 * 1024)} MiB")
    if b"\0" in data:
        raise ValueError(f"file: {name!r} is binary, not the text of a Wavefront OBJ mesh")
    vertices: list[tuple[float, float, float]] = []
    indices: list[int] = []
    last_line: dict[int, int] = {}  # the highest 1-based vertex a face names -> that face's line
    for number, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            try:
                xyz = tuple(float(v) for v in fields[1:])
            except ValueError:
                xyz = ()
            if len(xyz) < 3 or not all(math.isfinite(v) for v in xyz):
                raise ValueError(
                    f"file: {name!r} line {number}: a vertex needs three finite numbers, got {line.strip()!r}"
                )
            vertices.append((xyz[0], xyz[1], xyz[2]))
            if len(vertices) > MAX_OBJ_VERTICES:
                raise ValueError(
                    f"file: {name!r} line {number}: more than {MAX_OBJ_VERTICES} vertices, the most a mesh obstacle "
                    "may have; simplify the mesh (e.g. decimate it)"
                )
        elif fields[0] == "f":
            corners = []
            for corner in fields[1:]:
                try:
                    i = int(corner.split("/", 1)[0])
                except ValueError:
                    i = 0
                if i == 0 or (i < 0 and -i > len(vertices)):
                    raise ValueError(
                        f"file: {name!r} line {number}: face corner {corner!r} names no vertex "
                        f"({len(vertices)} read so far)"
                    )
                if i > 0:
                    if i > len(vertices):
                        last_line.setdefault(i, number)
                    corners.append(i - 1)
                else:
                    corners.append(len(vertices) + i)
            if len(corners) < 3:
                raise ValueError(
                    f"file: {name!r} line {number}: a face needs at least three corners, got {line.strip()!r} "
                    "(is the file cut short?)"
                )
            for k in range(2, len(corners)):
                indices += (corners[0], corners[k - 1], corners[k])
            if len(indices) > 3 * MAX_OBJ_TRIANGLES:
                raise ValueError(
                    f"file: {name!r} line {number}: more than {MAX_OBJ_TRIANGLES} triangles, the most a mesh obstacle "
                    "may have; simplify the mesh (e.g. decimate it)"
                )
    if len(vertices) < 3 or not indices:
        raise ValueError(f"file: {name!r} holds no vertices and faces ('v' and 'f' lines) of an OBJ mesh")
    beyond = [i for i in last_line if i > len(vertices)]
    if beyond:
        worst = max(beyond)
        raise ValueError(
            f"file: {name!r} line {last_line[worst]}: a face names vertex {worst}, the file holds {len(vertices)} "
            "(is the file cut short?)"
        )
    return ObjMesh(tuple(vertices), tuple(indices))


Obstacle = Annotated[Union[BoxObstacle, CylinderObstacle, SphereObstacle, MeshObstacle], Field(discriminator="type")]


class _Generator(_Model):
    x_range: Range = Field(description="region drawn in: [x_min, x_max] [m]")
    y_range: Range = Field(description="region drawn in: [y_min, y_max] [m]")
    density: float = Field(gt=0, description="obstacles per square metre of the region (count = round(density x area))")
    keep_out: float = Field(
        1.0, ge=0, description="horizontal clearance [m] kept between any obstacle and the spawn point and goals"
    )
    min_spacing: float = Field(0.0, ge=0, description="horizontal clearance [m] kept between obstacles (0: may touch)")
    max_attempts: int = Field(
        100, ge=1, le=10000, description="draws per obstacle before it is left out of the episode (parked underground)"
    )
    color: RGBA = Field((0.35, 0.55, 0.3, 1.0), description="RGBA in [0, 1]")
    size_resolution: float = Field(
        0.01, gt=0, description="drawn dimensions are rounded to multiples of this [m] (bounds the shapes created)"
    )

    @field_validator("color")
    @classmethod
    def _color(cls, value: RGBA) -> RGBA:
        return _colour(value)

    @model_validator(mode="after")
    def _region(self) -> _Generator:
        for name in ("x_range", "y_range"):
            low, high = getattr(self, name)
            if not low < high:
                raise ValueError(f"{name}: need min < max, got [{low}, {high}]")
        if self.count < 1:
            raise ValueError(
                f"density {self.density} per m^2 over {self.area:g} m^2 gives no obstacle: raise the density or the region"
            )
        if self.count > 2000:
            raise ValueError(
                f"density {self.density} per m^2 over {self.area:g} m^2 gives {self.count} obstacles (limit 2000)"
            )
        return self

    @property
    def area(self) -> float:
        return (self.x_range[1] - self.x_range[0]) * (self.y_range[1] - self.y_range[0])

    @property
    def count(self) -> int:
        """Obstacles drawn per episode (the same every episode)."""
        return int(round(self.density * self.area))


class ForestGenerator(_Generator):
    """Upright cylinders standing on the ground ("trees")."""

    kind: Literal["forest"] = "forest"
    radius_range: Range = Field((0.1, 0.3), description="trunk radius drawn uniformly in [min, max] [m]")
    height_range: Range = Field((3.0, 5.0), description="trunk height drawn uniformly in [min, max] [m]")

    @field_validator("radius_range", "height_range")
    @classmethod
    def _ranges(cls, value: Range, info: Any) -> Range:
        return _range(value, info.field_name)


class RoomGenerator(_Generator):
    """Boxes on the floor of a rectangular room, turned about z at random, and optional walls."""

    kind: Literal["room"] = "room"
    size_x_range: Range = Field((0.3, 1.0), description="box extent along its x [m]")
    size_y_range: Range = Field((0.3, 1.0), description="box extent along its y [m]")
    size_z_range: Range = Field((0.5, 2.0), description="box height [m]")
    walls: bool = Field(True, description="four walls along the region's edges (fixed; not drawn)")
    wall_height: float = Field(3.0, gt=0, description="[m]")
    wall_thickness: float = Field(0.1, gt=0, description="[m]")

    @field_validator("size_x_range", "size_y_range", "size_z_range")
    @classmethod
    def _ranges(cls, value: Range, info: Any) -> Range:
        return _range(value, info.field_name)


Generator = Annotated[Union[ForestGenerator, RoomGenerator], Field(discriminator="kind")]


class ObstaclesConfig(_Model):
    """``obstacles:`` of an env config (module docstring)."""

    items: list[Obstacle] = Field(default_factory=list, description="obstacles at fixed poses, built once")
    generators: list[Generator] = Field(
        default_factory=list, description="seeded layouts (forest, room) drawn again at every reset"
    )
    crash_on_contact: bool = Field(
        True, description="touching an obstacle ends the episode as a crash (false: contacts are only reported)"
    )
    cylinder_facets: int = Field(
        32,
        ge=8,
        le=256,
        description="a cylinder collides as the prism of this many sides inscribed in it (its radius is off by at "
        "most radius x (1 - cos(pi / facets)): 0.5 % at 32)",
    )

    @model_validator(mode="after")
    def _something(self) -> ObstaclesConfig:
        if not self.items and not self.generators:
            raise ValueError("obstacles: give at least one entry of 'items' or 'generators' (or leave the key out)")
        return self

    @property
    def meshes(self) -> list[str]:
        """The mesh files the config names."""
        return [o.file for o in self.items if isinstance(o, MeshObstacle)]


# ------------------------------------------------------------------- placement


def _uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return low + (high - low) * float(rng.random())


def _snap(value: float, step: float) -> float:
    return max(step, round(value / step) * step)


def _horizontal_clear(x: float, y: float, reach: float, points: Sequence[Sequence[float]], clearance: float) -> bool:
    for px, py, *_ in points:
        dx, dy = x - float(px), y - float(py)
        if math.sqrt(dx * dx + dy * dy) - reach < clearance:
            return False
    return True


def draw_layout(
    generator: ForestGenerator | RoomGenerator, rng: np.random.Generator, keep_out: Sequence[Sequence[float]]
) -> tuple[list[Obstacle | None], int]:
    """One episode's obstacles of ``generator``: ``(obstacles, parked)``.

    Each obstacle draws its size, then its position (and a room box its yaw) until it
    keeps ``keep_out`` from every point of ``keep_out`` and ``min_spacing`` from the
    obstacles already placed (horizontal distances to the obstacle's bounding circle),
    at most ``max_attempts`` times; one that never fits is ``None`` (parked) and counted.
    """
    g = generator
    out: list[Obstacle | None] = []
    placed: list[tuple[float, float, float]] = []  # x, y, bounding radius
    parked = 0
    step = g.size_resolution
    for _ in range(g.count):
        if isinstance(g, ForestGenerator):
            radius = _snap(_uniform(rng, *g.radius_range), step)
            height = _snap(_uniform(rng, *g.height_range), step)
            reach = radius
        else:
            sx = _snap(_uniform(rng, *g.size_x_range), step)
            sy = _snap(_uniform(rng, *g.size_y_range), step)
            sz = _snap(_uniform(rng, *g.size_z_range), step)
            reach = 0.5 * math.sqrt(sx * sx + sy * sy)
        obstacle: Obstacle | None = None
        for _attempt in range(g.max_attempts):
            x = _uniform(rng, *g.x_range)
            y = _uniform(rng, *g.y_range)
            yaw = _uniform(rng, -math.pi, math.pi) if isinstance(g, RoomGenerator) else 0.0
            if not _horizontal_clear(x, y, reach, keep_out, g.keep_out):
                continue
            if g.min_spacing > 0 and not all(
                math.sqrt((x - ox) ** 2 + (y - oy) ** 2) - reach - oreach >= g.min_spacing for ox, oy, oreach in placed
            ):
                continue
            if isinstance(g, ForestGenerator):
                obstacle = CylinderObstacle(radius=radius, height=height, position=(x, y, 0.5 * height), color=g.color)
            else:
                obstacle = BoxObstacle(
                    size=(sx, sy, sz), position=(x, y, 0.5 * sz), orientation=(0.0, 0.0, yaw), color=g.color
                )
            placed.append((x, y, reach))
            break
        if obstacle is None:
            parked += 1
        out.append(obstacle)
    return out, parked


def room_walls(g: RoomGenerator) -> list[BoxObstacle]:
    """The four walls of a room generator, along the outside of its region."""
    (x0, x1), (y0, y1), t, h = g.x_range, g.y_range, g.wall_thickness, g.wall_height
    cx, cy, lx, ly = 0.5 * (x0 + x1), 0.5 * (y0 + y1), x1 - x0 + 2 * t, y1 - y0 + 2 * t
    return [
        BoxObstacle(size=(lx, t, h), position=(cx, y0 - 0.5 * t, 0.5 * h), color=g.color),
        BoxObstacle(size=(lx, t, h), position=(cx, y1 + 0.5 * t, 0.5 * h), color=g.color),
        BoxObstacle(size=(t, ly, h), position=(x0 - 0.5 * t, cy, 0.5 * h), color=g.color),
        BoxObstacle(size=(t, ly, h), position=(x1 + 0.5 * t, cy, 0.5 * h), color=g.color),
    ]


# ------------------------------------------------------------------- meshes


def prism_mesh(radius: float, height: float, sides: int) -> tuple[list[list[float]], list[int]]:
    """The upright ``sides``-gon prism inscribed in the cylinder of ``radius`` and ``height``
    centred on the origin (vertices on the circle), as vertices and outward triangles."""
    h = 0.5 * float(height)
    ring = [
        (radius * math.cos(2.0 * math.pi * k / sides), radius * math.sin(2.0 * math.pi * k / sides))
        for k in range(sides)
    ]
    vertices = [[x, y, -h] for x, y in ring] + [[x, y, h] for x, y in ring] + [[0.0, 0.0, -h], [0.0, 0.0, h]]
    bottom, top = 2 * sides, 2 * sides + 1
    indices: list[int] = []
    for k in range(sides):
        j = (k + 1) % sides
        indices += [k, j, sides + j, k, sides + j, sides + k]  # side
        indices += [bottom, j, k]  # bottom cap, facing down
        indices += [top, sides + k, sides + j]  # top cap, facing up
    return vertices, indices


@functools.lru_cache(maxsize=None)
def _unit_prism(sides: int) -> tuple[tuple[tuple[float, float, float], ...], tuple[int, ...]]:
    """:func:`prism_mesh` of radius 1 and height 1 as tuples, made once per number of sides."""
    vertices, indices = prism_mesh(1.0, 1.0, sides)
    return tuple((v[0], v[1], v[2]) for v in vertices), tuple(indices)


# ------------------------------------------------------------------- bodies


class ObstacleField:
    """The obstacle bodies of one world, built from an :class:`ObstaclesConfig`.

    The fixed items (and room walls) are built on construction; :meth:`generate` draws and
    rebuilds the generated layouts (call it at every reset, after the spawn and goals are
    known).
    """

    def __init__(self, world: World, config: ObstaclesConfig) -> None:
        self.world = world
        self.config = config
        #: (collision, visual) shape ids by dimensions: bounded by the distinct sizes drawn
        #: (``size_resolution``), so a long run creates a bounded number of shapes
        self._shapes: dict[str, tuple[int, int]] = {}
        #: sha256 (hex) of each mesh file's content, read as its shape was built: the recorder
        #: embeds the file only if it still holds exactly that (so a recording flies what was flown)
        self.mesh_digests: dict[str, str] = {}
        fixed: list[Obstacle] = list(config.items)
        for g in config.generators:
            if isinstance(g, RoomGenerator) and g.walls:
                fixed += room_walls(g)
        #: body ids of the fixed obstacles, in declaration order
        self.fixed_ids: list[int] = [self._create(o) for o in fixed]
        #: body ids of the generated obstacles (rebuilt by :meth:`generate`)
        self.generated_ids: list[int] = []
        #: the generated obstacles of the current episode (None: parked)
        self.generated: list[Obstacle | None] = []
        #: generated obstacles that found no place this episode
        self.parked = 0
        for body in self.fixed_ids:
            world.add_body(body)

    @property
    def body_ids(self) -> list[int]:
        """Every obstacle body id."""
        return [*self.fixed_ids, *self.generated_ids]

    def generate(self, rng: np.random.Generator, keep_out: Sequence[Sequence[float]]) -> None:
        """Draw this episode's layouts from ``rng`` and rebuild their bodies (nothing without generators)."""
        if not self.config.generators:
            return
        from pyflyt_engine.bullet import pybullet as p

        obstacles: list[Obstacle | None] = []
        parked = 0
        for g in self.config.generators:
            drawn, missed = draw_layout(g, rng, keep_out)
            obstacles += drawn
            parked += missed
        client = self.world.client
        for body in reversed(self.generated_ids):  # last first: PyBullet reuses the ids in creation order
            p.removeBody(body, physicsClientId=client)
        ids = [self._create(o) for o in obstacles]
        self.world.replace_bodies(self.generated_ids, ids)
        self.generated_ids = ids
        self.generated = obstacles
        self.parked = parked

    def touched(self, vehicle: int = 0) -> bool:
        """Whether vehicle ``vehicle`` touched any obstacle during the last world step."""
        world = self.world
        if not world.collided(vehicle):  # touched nothing at all: the common case, one look-up
            return False
        return any(world.collided_with_body(vehicle, body) for body in self.body_ids)

    def _create(self, obstacle: Obstacle | None) -> int:
        from pyflyt_engine.bullet import pybullet as p
        from pyflyt_engine.frames import euler_to_quaternion

        client = self.world.client
        if obstacle is None:  # parked: a small sphere far under the ground plane
            obstacle = SphereObstacle(radius=0.01, position=(0.0, 0.0, PARKED_Z))
        collision, visual = self._shape(obstacle)
        return p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=collision,
            baseVisualShapeIndex=visual,
            basePosition=list(obstacle.position),
            baseOrientation=euler_to_quaternion(*obstacle.orientation),
            physicsClientId=client,
        )

    def _shape(self, o: Obstacle) -> tuple[int, int]:
        from pyflyt_engine.bullet import pybullet as p

        if isinstance(o, BoxObstacle):
            key: tuple = ("box", o.size)
        elif isinstance(o, CylinderObstacle):
            key = ("cylinder", o.radius, o.height, self.config.cylinder_facets)
        elif isinstance(o, SphereObstacle):
            key = ("sphere", o.radius)
        else:
            key = ("mesh", o.file, o.scale)
        # a text key: the cache is never walked by the cyclic garbage collector
        text = repr((*key, o.color))
        cached = self._shapes.get(text)
        if cached is not None:
            return cached
        cid = self.world.client
        # a cylinder collides as a static triangle mesh: Bullet casts a ray against a mesh's tree
        # in ~2 us, against its native cylinder in ~13 us (docs/obstacles_and_sensors.md); a box
        # keeps Bullet's box (~3 us a ray), which a fast vehicle cannot tunnel through as it can
        # through a thin slab of triangles
        if isinstance(o, BoxObstacle):
            half = [0.5 * s for s in o.size]
            collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
            visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=list(o.color), physicsClientId=cid)
        elif isinstance(o, CylinderObstacle):
            # the unit prism scaled: PyBullet keeps a reference to every vertex it is given,
            # so every cylinder hands it the same immutable vertices
            vertices, indices = _unit_prism(self.config.cylinder_facets)
            collision = p.createCollisionShape(
                p.GEOM_MESH,
                vertices=vertices,
                indices=indices,
                meshScale=[o.radius, o.radius, o.height],
                physicsClientId=cid,
            )
            visual = p.createVisualShape(
                p.GEOM_CYLINDER, radius=o.radius, length=o.height, rgbaColor=list(o.color), physicsClientId=cid
            )
        elif isinstance(o, SphereObstacle):
            collision = p.createCollisionShape(p.GEOM_SPHERE, radius=o.radius, physicsClientId=cid)
            visual = p.createVisualShape(p.GEOM_SPHERE, radius=o.radius, rgbaColor=list(o.color), physicsClientId=cid)
        else:
            try:
                self.mesh_digests[o.file] = hashlib.sha256(Path(o.file).read_bytes()).hexdigest()
            except OSError as exc:
                raise ConfigError(f"obstacles: cannot read mesh file {o.file!r}: {exc.strerror or exc}") from None
            collision = p.createCollisionShape(
                p.GEOM_MESH,
                fileName=o.file,
                meshScale=list(o.scale),
                flags=p.GEOM_FORCE_CONCAVE_TRIMESH,  # a static body may be concave
                physicsClientId=cid,
            )
            visual = p.createVisualShape(
                p.GEOM_MESH, fileName=o.file, meshScale=list(o.scale), rgbaColor=list(o.color), physicsClientId=cid
            )
        if collision < 0:
            raise ConfigError(f"obstacles: PyBullet could not build the {o.type} obstacle {o.model_dump()}")
        self._shapes[text] = (collision, visual)
        return collision, visual
