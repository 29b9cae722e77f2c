"""URDF generation from a vehicle spec.

Every airframe is one rigid link whose origin is the centre of mass: the inertial
block carries the spec's mass and inertia, and each shape becomes a ``<visual>`` and/or
``<collision>`` element.  The generated text is cached on disk by content hash in a
directory private to the user (:func:`cache_dir`), and a cached file is used only after
checking that it holds exactly that text (:func:`urdf_path`).
"""

from __future__ import annotations

import hashlib
import math
import os
import stat
import tempfile
from pathlib import Path
from typing import Any
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
    return f'<mesh filename={quoteattr(str(mesh))} scale="{_fmt(shape.scale)}"/>'


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


def shape_elements(shapes: list[ShapeSpec], com: np.ndarray, base_dir: Path | None = None) -> list[str]:
    """The ``<visual>`` and ``<collision>`` lines of a link whose origin is ``com`` (spec coordinates)."""
    base_dir = base_dir or Path.cwd()
    lines: list[str] = []
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
    return lines


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
    lines += shape_elements(shapes, com, base_dir)
    lines += ["  </link>", "</robot>", ""]
    return "\n".join(lines)


#: the per-process fallback cache (see :func:`cache_dir`), made at most once
_private_dir: Path | None = None


def _unsafe_reason(path: Path) -> str | None:
    """Why ``path`` cannot hold the cache (None if it is a private directory of ours).

    The cache is trusted: its files are loaded without a second thought by PyBullet.  So it
    must be a real directory (not a symbolic link), owned by the current user, that no one
    else can write to (no group or other write permission).
    """
    try:
        info = path.lstat()
    except OSError as exc:
        return f"cannot inspect it ({exc.strerror or exc})"
    if not stat.S_ISDIR(info.st_mode):
        return "it is not a directory (or is a symbolic link)"
    if info.st_uid != os.getuid():
        return f"it belongs to user id {info.st_uid}, not to the current user ({os.getuid()})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"others may write to it (mode {stat.S_IMODE(info.st_mode):o})"
    return None


def cache_dir() -> Path:
    """The directory generated URDF files are cached in, created private (mode 0o700).

    ``$PYFLYT_CACHE_DIR``, else ``<temp dir>/pyflyt_urdf_<uid>``.  A directory that is not
    ours alone (:func:`_unsafe_reason`; e.g. made by another user in a shared temp
    directory) is never used: the cache falls back to a private directory of this
    process, removed at exit, with a warning naming the refused directory.
    """
    global _private_dir
    if _private_dir is not None:
        return _private_dir
    default = Path(tempfile.gettempdir()) / f"pyflyt_urdf_{os.getuid()}"
    path = Path(os.environ.get("PYFLYT_CACHE_DIR") or default)
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        reason: str | None = f"cannot create it ({exc.strerror or exc})"
    else:
        reason = _unsafe_reason(path)
    if reason is None:
        return path
    import atexit
    import shutil
    import warnings

    _private_dir = Path(tempfile.mkdtemp(prefix="pyflyt_urdf_"))  # mode 0o700
    atexit.register(shutil.rmtree, _private_dir, True)
    warnings.warn(
        f"URDF cache {path}: not used because {reason}; using {_private_dir} for this process instead "
        "(set PYFLYT_CACHE_DIR to a directory only you can write to)",
        RuntimeWarning,
        stacklevel=3,
    )
    return _private_dir


def _holds(path: Path, data: bytes) -> bool:
    """Whether ``path`` is a regular file (not a link) whose content is exactly ``data``."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        return False
    with os.fdopen(fd, "rb") as handle:
        if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
            return False
        return handle.read(len(data) + 1) == data


def urdf_path(spec: UAVSpec) -> Path:
    """Path of a URDF file for ``spec``: the user's own, or a generated one (cached).

    A generated file is named by the digest of its text alone (never by a name from the
    spec), and a cached file is used only if its content is exactly the generated text;
    otherwise (tampered, truncated, replaced by a link) it is written again.
    """
    if spec.body.urdf is not None:
        path = Path(spec.body.urdf)
        if not path.is_absolute() and spec.source:
            path = Path(spec.source).parent / path
        return path
    return cached_urdf(generate_urdf(spec))


def cached_urdf(text: str) -> Path:
    """Path of a cached file holding exactly ``text`` (generated URDF), written if needed.

    Named by the digest of the text alone; a cached file is used only if its content is
    exactly ``text`` (see :func:`urdf_path`).
    """
    return cached_file(text.encode(), ".urdf")


def cached_file(data: bytes, suffix: str) -> Path:
    """Path of a cached file holding exactly ``data``, named by its digest and ``suffix``
    (``.urdf``: a generated or recorded URDF; ``.obj``: a mesh a recording holds), written
    if needed; a cached file is used only if its content is exactly ``data``."""
    directory = cache_dir()
    path = directory / f"{hashlib.sha256(data).hexdigest()[:32]}{suffix}"
    if not _holds(path, data):
        # write-then-rename so concurrent processes never read a half-written file
        fd, tmp = tempfile.mkstemp(dir=directory, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    return path


# ------------------------------------------------------------- foreign URDF

#: the largest URDF text accepted from a recording [bytes]; a generated one is a few kB
MAX_URDF_BYTES = 1 << 20
#: the most elements and the deepest nesting of such a URDF (a generated one: a few dozen, 6 levels)
MAX_URDF_ELEMENTS = 10_000
MAX_URDF_DEPTH = 16
#: attribute -> how many numbers it holds (and whether they must be > 0)
_NUMBERS = {
    "xyz": (3, False),
    "rpy": (3, False),
    "size": (3, True),
    "scale": (3, True),
    "rgba": (4, False),
    "radius": (1, True),
    "length": (1, True),
    "value": (1, False),
    **{name: (1, False) for name in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
}


def urdf_problem(text: str, *, allow_files: bool = False) -> str | None:
    """What makes ``text`` unfit to hand to PyBullet as a URDF from someone else (None: fit).

    PyBullet parses a URDF in C++ and aborts the process (or prints errors and fails)
    on input it does not expect, so a URDF that did not come from :func:`generate_urdf`
    in this process is checked first: at most :data:`MAX_URDF_BYTES`, well-formed XML
    without a document type (no entities to expand), a ``<robot>`` with at least one
    ``<link>``, at most :data:`MAX_URDF_ELEMENTS` elements nested at most
    :data:`MAX_URDF_DEPTH` deep, no attribute naming a file (``filename``: meshes,
    textures), and every number of an origin, a shape, a colour, a mass or an inertia
    finite (sizes positive), and the links one tree: names unique, every joint joining two of
    them, exactly one link that is no joint's child (PyBullet crashes on two roots).

    ``allow_files``: a URDF a run directory carries may name mesh files (``<mesh filename=...>``);
    the caller confines each (:func:`urdf_files`) before PyBullet reads any.
    """
    from xml.etree import ElementTree

    size = len(text.encode())
    if size > MAX_URDF_BYTES:
        return f"it is {size} bytes, more than the {MAX_URDF_BYTES} a URDF may have"
    lowered = text.lower()
    if "<!doctype" in lowered or "<!entity" in lowered:
        return "it declares a document type or entities, which a URDF does not need"
    try:
        root = ElementTree.fromstring(text)
    except ElementTree.ParseError as exc:
        return f"it is not well-formed XML ({exc})"
    if root.tag != "robot":
        return f"its root element is <{root.tag}>, not <robot>"
    count = 0
    links = 0
    stack = [(root, 1)]
    while stack:
        element, depth = stack.pop()
        count += 1
        if count > MAX_URDF_ELEMENTS:
            return f"it has more than {MAX_URDF_ELEMENTS} elements"
        if depth > MAX_URDF_DEPTH:
            return f"its elements nest more than {MAX_URDF_DEPTH} deep"
        links += element.tag == "link"
        for name, value in element.attrib.items():
            if name == "filename" and not allow_files:
                return f"<{element.tag}> names the file {value!r}, and a file is not part of the recording"
            if name in _NUMBERS:
                n, positive = _NUMBERS[name]
                try:
                    numbers = [float(v) for v in value.split()]
                except ValueError:
                    return f"<{element.tag} {name}={value!r}> is not {n} number{'s' * (n > 1)}"
                if len(numbers) != n or not all(math.isfinite(v) and (v > 0 or not positive) for v in numbers):
                    kind = "positive" if positive else "finite"
                    return f"<{element.tag} {name}={value!r}> is not {n} {kind} number{'s' * (n > 1)}"
        stack.extend((child, depth + 1) for child in element)
    if not links:
        return "it has no <link>"
    return _tree_problem(root)


def _tree_problem(root: Any) -> str | None:
    """Why the links and joints of a parsed ``<robot>`` are not one tree (None: they are)."""
    names = [link.get("name") for link in root.iter("link")]
    if any(not name for name in names):
        return "a <link> has no name"
    if len(set(names)) != len(names):
        return "two <link>s share a name"
    children: set[str] = set()
    for joint in root.iter("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        ends = [e.get("link") for e in (parent, child) if e is not None]
        if len(ends) != 2 or any(end not in names for end in ends):
            return f"the <joint> {joint.get('name')!r} does not join two of the URDF's links"
        if ends[1] in children:
            return f"the link {ends[1]!r} is the child of two joints"
        children.add(ends[1])
    roots = [name for name in names if name not in children]
    if len(roots) != 1:
        return f"its links form {len(roots) or 'no'} trees, not one (roots: {', '.join(roots) or 'none, a cycle'})"
    below: dict[str, list[str]] = {}
    for joint in root.iter("joint"):
        below.setdefault(joint.find("parent").get("link"), []).append(joint.find("child").get("link"))
    reached, stack = {roots[0]}, [roots[0]]
    while stack:
        for child in below.get(stack.pop(), []):
            if child not in reached:
                reached.add(child)
                stack.append(child)
    if len(reached) != len(names):
        return "some of its links are joined in a cycle, apart from the tree of its root link"
    return None


def urdf_files(text: str) -> list[str]:
    """The files a URDF names (every ``filename`` attribute), in document order; for a text
    :func:`urdf_problem` passed."""
    from xml.etree import ElementTree

    return [name for element in ElementTree.fromstring(text).iter() if (name := element.get("filename")) is not None]
