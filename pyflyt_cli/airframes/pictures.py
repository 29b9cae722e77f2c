"""Pictures of an airframe: a 3/4 view (:func:`render_airframe`) and its lifting surfaces'
coefficient curves (:func:`plot_surface_curves`), as ``pyflyt uav show --png/--curves`` writes them.

Both render offscreen (PyBullet DIRECT with TinyRenderer; Matplotlib's Agg) and write
their file all at once (:func:`~pyflyt_cli.outputs.atomic_output`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pyflyt_cli.errors import UsageError
from pyflyt_cli.outputs import atomic_output
from pyflyt_engine.spec import UAVSpec


def _rpy_matrix(rpy) -> np.ndarray:
    """Rotation Rz(yaw) Ry(pitch) Rx(roll) (URDF convention)."""
    r, p_, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p_), math.sin(p_), math.cos(y), math.sin(y)
    return np.array(
        [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
         [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
         [-sp, cp * sr, cp * cr]]
    )  # fmt: skip


def _feature_points(spec: UAVSpec) -> np.ndarray:
    """Points the picture must contain, centre-of-mass frame [m]: the corners of every
    primitive shape, surface plate corners, motors, boosters and cameras (meshes and
    user URDFs are covered by PyBullet's bounding box instead)."""
    points: list = []
    for shape in spec.body.shapes:
        if shape.type == "box":
            half = np.asarray(shape.size, dtype=float) / 2.0
        elif shape.type == "cylinder":
            half = np.array([shape.radius, shape.radius, shape.length / 2.0])  # type: ignore[operator]
        elif shape.type == "sphere":
            half = np.full(3, shape.radius)
        else:
            continue
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
        points += list(corners @ _rpy_matrix(shape.rpy).T + np.asarray(shape.position, dtype=float))
    if spec.motors is not None:
        points += list(spec.motors.positions)
    if spec.boosters is not None:
        points += list(spec.boosters.positions)
    for s in spec.surfaces:
        centre = np.asarray(s.position, dtype=float)
        span_axis = np.cross(s.chord_axis, s.normal_axis)
        for sign_c in (-0.5, 0.5):
            for sign_s in (-0.5, 0.5):
                points.append(centre + sign_c * s.chord * np.asarray(s.chord_axis) + sign_s * s.span * span_axis)
    points += [c.position for c in spec.cameras]
    if not points:
        return np.zeros((0, 3))
    return np.asarray(points, dtype=float) - spec.center_of_mass()


def _z_to(axis: np.ndarray) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) rotating +z onto unit ``axis``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    cross = np.cross(z, axis)
    dot = float(z @ axis)
    if dot < -1.0 + 1e-12:
        return (1.0, 0.0, 0.0, 0.0)
    q = np.array([*cross, 1.0 + dot])
    q /= np.linalg.norm(q)
    return tuple(float(v) for v in q)  # type: ignore[return-value]


# marker colours (RGBA): motor spin, boosters, body axes
_CCW_COLOR = (1.0, 0.55, 0.0, 1.0)
_CW_COLOR = (0.0, 0.6, 0.9, 1.0)
_BOOSTER_COLOR = (0.8, 0.0, 0.8, 1.0)
_AXIS_COLORS = ((0.9, 0.1, 0.1, 1.0), (0.1, 0.7, 0.1, 1.0), (0.1, 0.2, 0.9, 1.0))
_STRING_COLOR = (0.25, 0.25, 0.25, 1.0)  # a payload's tether


def _add_rod(p, client: int, start: np.ndarray, axis: np.ndarray, length: float, radius: float, color) -> None:
    """A visual-only cylinder from ``start`` along ``axis`` (no mass, no collision)."""
    axis = np.asarray(axis, dtype=float)
    shape = p.createVisualShape(p.GEOM_CYLINDER, radius=radius, length=length, rgbaColor=color, physicsClientId=client)
    centre = np.asarray(start, dtype=float) + 0.5 * length * axis / np.linalg.norm(axis)
    p.createMultiBody(0.0, -1, shape, centre.tolist(), _z_to(axis), physicsClientId=client)


_FOV_DEG = 35.0  # vertical field of view of the picture [deg]
_VIEW_DIRECTION = np.array([1.0, -0.9, 0.65]) / np.linalg.norm([1.0, -0.9, 0.65])  # from front-right, above


def _fit_distance(points: np.ndarray, direction: np.ndarray, aspect: float) -> float:
    """Camera distance along unit ``direction`` (toward the eye) that frames ``points`` (relative to the view centre).

    A point ``c`` seen from distance ``D`` sits at depth ``D - c.d`` in front of the eye
    and must satisfy ``|c.r| <= (D - c.d) tan(h_x)`` and ``|c.u| <= (D - c.d) tan(h_y)``
    (``r``, ``u`` the image right and up axes, ``h`` the half fields of view); the result
    is the smallest such ``D`` plus a 10 % margin.
    """
    up = np.array([0.0, 0.0, 1.0])
    right = np.cross(-direction, up)
    right /= np.linalg.norm(right)
    image_up = np.cross(right, -direction)
    tan_y = math.tan(math.radians(_FOV_DEG) / 2.0)
    tan_x = tan_y * aspect
    need = points @ direction + np.maximum(np.abs(points @ right) / tan_x, np.abs(points @ image_up) / tan_y)
    return 1.1 * max(float(need.max()), 1e-3)


def render_airframe(spec: UAVSpec, path: Path, width: int = 640, height: int = 480, payloads: Sequence = ()) -> Path:
    """Write a 3/4-view PNG of ``spec`` (offscreen: PyBullet DIRECT + TinyRenderer).

    The airframe's generated URDF (:func:`~pyflyt_engine.urdf.urdf_path`) is loaded with
    its centre of mass at the origin and seen from front-right and above, from the
    distance that just frames it (:func:`_fit_distance`); overlays are scaled by its
    bounding size (PyBullet's AABB and the parts).  Overlays: the body axes at the centre of mass (red X
    forward, green Y left, blue Z up), each motor's thrust axis coloured by spin (orange
    CCW +1, blue CW -1) and each booster's plume (magenta, opposite its thrust).

    Raises:
        UsageError: PyBullet cannot load the URDF (e.g. a missing mesh).

    ``payloads``: :class:`~pyflyt_engine.payloads.PayloadSpec` s attached to the vehicle
    (``attach.to: vehicle``), drawn at their reset poses (a tether at full length, its
    string a thin dark grey rod) from their generated URDFs and included in the framing; payloads of the world are skipped
    (:func:`drawable_payloads` tells which are drawn).
    """
    from PIL import Image

    from pyflyt_engine.bullet import pybullet as p
    from pyflyt_engine.urdf import urdf_path

    client = p.connect(p.DIRECT)
    try:
        try:
            body = p.loadURDF(str(urdf_path(spec)), useFixedBase=True, physicsClientId=client)
        except p.error as exc:
            raise UsageError(f"{spec.source or spec.name}: PyBullet cannot load the airframe's URDF: {exc}") from None
        # the collision bounding box sets the scale; the primitives' own corners give a tight
        # framing (a box's far corners lie well outside a cross-shaped airframe), except for
        # meshes and user URDFs, whose extent only PyBullet knows
        box = np.array(p.getAABB(body, -1, physicsClientId=client), dtype=float)
        box_corners = np.array([[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]])
        features = _feature_points(spec)
        if spec.body.urdf is not None or any(shape.type == "mesh" for shape in spec.body.shapes) or not len(features):
            features = np.vstack([features, box_corners])
        for payload in drawable_payloads(payloads):
            corners = _add_payload(p, client, payload)
            features = np.vstack([features, corners])
            box_corners = np.vstack([box_corners, corners])
        extent = np.vstack([features, box_corners])
        size = max(float(np.linalg.norm(extent.max(axis=0) - extent.min(axis=0))), 1e-3)

        # overlays (start, direction, length, radius, colour): body axes, motor and booster thrust axes
        rod = 0.006 * size
        rods = [(np.zeros(3), np.eye(3)[i], 0.3 * size, rod, colour) for i, colour in enumerate(_AXIS_COLORS)]
        com = spec.center_of_mass()
        if spec.motors is not None:
            axes = spec.motors.to_array("thrust_axes")
            for position, axis, spin in zip(spec.motors.positions, axes, spec.motors.spin):
                colour = _CCW_COLOR if spin > 0 else _CW_COLOR
                rods.append((np.asarray(position) - com, axis, 0.12 * size, 1.5 * rod, colour))
        if spec.boosters is not None:
            booster_axes = spec.boosters.thrust_axes or [(0.0, 0.0, 1.0)] * len(spec.boosters.positions)
            for position, axis in zip(spec.boosters.positions, booster_axes):
                exhaust = -np.asarray(axis, dtype=float)  # drawn as the plume, opposite the thrust
                rods.append((np.asarray(position) - com, exhaust, 0.15 * size, 2 * rod, _BOOSTER_COLOR))
        for start, axis, length, thickness, colour in rods:
            _add_rod(p, client, start, axis, length, thickness, colour)
        tips = [start + length * np.asarray(axis) for start, axis, length, _, _ in rods]
        points = np.vstack([features, tips])
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))

        eye = centre + _fit_distance(points - centre, _VIEW_DIRECTION, width / height) * _VIEW_DIRECTION
        distance = float(np.linalg.norm(eye - centre))
        view = p.computeViewMatrix(eye.tolist(), centre.tolist(), [0.0, 0.0, 1.0], physicsClientId=client)
        projection = p.computeProjectionMatrixFOV(
            _FOV_DEG, width / height, 0.05 * distance, 3.0 * distance, physicsClientId=client
        )
        _, _, rgba, _, _ = p.getCameraImage(
            width,
            height,
            viewMatrix=view,
            projectionMatrix=projection,
            renderer=p.ER_TINY_RENDERER,
            lightDirection=(eye - centre).tolist(),
            shadow=0,
            flags=p.ER_NO_SEGMENTATION_MASK,
            physicsClientId=client,
        )
    finally:
        p.disconnect(client)
    image = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    with atomic_output(path, "--png") as tmp:
        Image.fromarray(image, "RGB").save(tmp, format="PNG")
    return path


def drawable_payloads(payloads: Sequence) -> list:
    """The payloads :func:`render_airframe` draws: those attached to the vehicle."""
    return [p for p in payloads if p.attach.to == "vehicle"]


def _add_payload(p, client: int, payload) -> np.ndarray:
    """Load ``payload`` at its reset pose relative to the vehicle (centre of mass at the origin, body
    axes = world axes); the corners of its bodies' bounding boxes [m]."""
    from pyflyt_engine.payloads import PayloadSet, generate_payload_urdf, tether_geometry
    from pyflyt_engine.urdf import cached_urdf

    position, quaternion = PayloadSet._spawn_pose(payload, np.zeros(3), (0.0, 0.0, 0.0, 1.0))
    try:
        body = p.loadURDF(
            str(cached_urdf(generate_payload_urdf(payload))),
            basePosition=position,
            baseOrientation=quaternion,
            useFixedBase=True,
            flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )
    except p.error as exc:
        raise UsageError(f"payload {payload.name}: PyBullet cannot load its URDF: {exc}") from None
    links = [-1]
    if payload.attach.joint == "tether":
        _axis, q0, _upper = tether_geometry(payload)
        p.resetJointState(body, 0, q0, 0.0, physicsClientId=client)
        links = [0]  # the pivot has no shape
        string = payload.anchor_to_payload_anchor()
        _add_rod(p, client, np.asarray(payload.attach.anchor, dtype=float), string, float(np.linalg.norm(string)),
                 0.002, _STRING_COLOR)  # fmt: skip
    corners = []
    for link in links:
        box = np.array(p.getAABB(body, link, physicsClientId=client), dtype=float)
        corners += [[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]]
    return np.asarray(corners, dtype=float)


def plot_surface_curves(spec: UAVSpec, path: Path) -> Path:
    """Write a PNG of C_L, C_D and C_M against alpha for every lifting surface.

    One row per surface, at deflections -max, 0 and +max (the Khan & Nahon profile of
    :func:`~pyflyt_engine.components.lifting_surface.coefficient_curves`).

    Raises:
        UsageError: the airframe has no lifting surfaces.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from pyflyt_engine.assembly import assemble
    from pyflyt_engine.components.lifting_surface import coefficient_curves

    if not spec.surfaces:
        raise UsageError(f"{spec.name} has no lifting surfaces: nothing to plot for --curves")
    try:
        surfaces = assemble(spec).surfaces
    except ValueError as exc:
        raise UsageError(f"{spec.source or spec.name}: cannot build the lifting surfaces: {exc}") from None
    n = len(surfaces)
    fig = Figure(figsize=(12.0, 2.4 * n + 0.8))
    FigureCanvasAgg(fig)
    axes = fig.subplots(n, 3, squeeze=False, sharex=True)
    for row, (surface_spec, params) in enumerate(zip(spec.surfaces, surfaces)):
        for delta in dict.fromkeys((-params.max_deflection, 0.0, params.max_deflection)):
            curves = coefficient_curves(params, deflection=delta)
            alpha = np.degrees(curves["alpha"])
            for ax, key in zip(axes[row], ("cl", "cd", "cm")):
                ax.plot(alpha, curves[key], linewidth=1.0, label=f"flap {math.degrees(delta):+.0f} deg")
        for ax, label in zip(axes[row], ("C_L", "C_D", "C_M (nose-up +)")):
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
            ax.axhline(0.0, color="k", linewidth=0.5)
        axes[row][0].set_title(
            f"{surface_spec.name}: {surface_spec.chord:g} x {surface_spec.span:g} m, AR {params.aspect_ratio:.3g}",
            loc="left",
            fontsize="medium",
        )
        axes[row][0].legend(loc="lower right", fontsize="x-small")
    for ax in axes[-1]:
        ax.set_xlabel("angle of attack [deg]")
        ax.set_xticks(np.arange(-180, 181, 60))
    fig.suptitle(f"{spec.name}: lifting-surface coefficients (Khan & Nahon)")
    fig.tight_layout()
    with atomic_output(path, "--curves") as tmp:
        fig.savefig(tmp, dpi=80, format="png")
    return path
