"""``pyflyt uav validate`` and ``pyflyt uav show``: check and inspect airframe YAML files.

The CLI in :mod:`pyflyt_cli.main` only parses arguments; the work is done by plain
functions here, which tests may call directly:

- :func:`check_uav` loads a spec (a shipped name or a path) and builds it offline in a
  throwaway headless :class:`~pyflyt_engine.world.World`, so that errors which only show
  at build time (component parameters the schema does not check, such as a booster's
  min_thrust above its max_thrust; a user URDF or mesh PyBullet cannot load) are caught
  too.
- :func:`run_validate` checks many files and prints one line per file.
- :func:`mass_report`, :func:`thrust_to_weight` compute what :func:`run_show` prints.
- :func:`render_airframe` draws the airframe offscreen (PyBullet DIRECT, TinyRenderer);
  :func:`plot_surface_curves` plots C_L, C_D, C_M against alpha for every surface.

Nothing here writes over its input: output images must be new files or existing PNGs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import typer

from pyflyt_cli.config import CLIError
from pyflyt_cli.outputs import atomic_output, check_output, parse_size
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import PyFlytError, SpecError
from pyflyt_engine.spec import (
    FixedwingControlSpec,
    MultirotorControlSpec,
    UAVSpec,
    load_uav_spec,
    resolve_uav_path,
)


# --------------------------------------------------------------------- validate


def resolve_file(name_or_path: str) -> Path:
    """A shipped airframe name or a path to a YAML file, as an existing file path.

    Raises:
        SpecError: no such file or airframe, or the path is a directory.
    """
    candidate = Path(name_or_path)
    if candidate.is_dir():
        raise SpecError(f"{candidate}: is a directory; give the YAML files in it, e.g. {candidate / '*.yaml'}")
    path = resolve_uav_path(name_or_path)
    if path.stat().st_size == 0:
        raise SpecError(
            f"{path}: the file is empty; a UAV spec is a mapping with at least 'name' and 'body' "
            "(see docs/uav_authoring.md)"
        )
    return path


def build_offline(spec: UAVSpec) -> None:
    """Build ``spec`` in a throwaway headless world (no ground, no rendering).

    Raises:
        PyFlytError: the vehicle cannot be built; the message starts with the file.
    """
    import pybullet as p

    from pyflyt_engine.world import World

    where = spec.source or spec.name
    with World(ground=False) as world:
        try:
            world.add_vehicle(spec)
        except SpecError:
            raise
        except (PyFlytError, ValueError, p.error) as exc:  # components check their parameters with ValueError
            raise CLIError(f"{where}: cannot build the vehicle: {exc}") from None


def check_uav(name_or_path: str) -> tuple[Path, UAVSpec]:
    """Load, validate and build one airframe.

    Returns:
        The resolved file and its spec.

    Raises:
        PyFlytError: with a message naming the file, the field and the fix.
    """
    path = resolve_file(name_or_path)
    spec = load_uav_spec(path)
    build_offline(spec)
    return path, spec


def run_validate(files: list[str]) -> int:
    """Check every file, print ``ok: ...`` or the error for each; return the number of failures."""
    failures = 0
    for name in files:
        try:
            path, spec = check_uav(name)
            summary, notes = one_line_summary(spec), validation_warnings(spec)
        except PyFlytError as exc:
            failures += 1
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            continue
        except Exception as exc:  # noqa: BLE001 - a bug must still not print a traceback here
            failures += 1
            typer.secho(
                f"error: {name}: internal error while checking it ({type(exc).__name__}: {exc}); please report it",
                err=True,
                fg=typer.colors.RED,
            )
            continue
        typer.echo(f"ok: {path}: {spec.name} ({summary})")
        for warning in notes:
            typer.secho(f"  warning: {warning}", err=True, fg=typer.colors.YELLOW)
    if len(files) > 1:
        typer.echo(f"{len(files) - failures} of {len(files)} files valid")
    return failures


def one_line_summary(spec: UAVSpec) -> str:
    """``0.027 kg, 4 motors, multirotor control, T/W 8.00`` style summary."""
    parts = [f"{spec.total_mass():.4g} kg"]
    for count, noun in (
        (len(spec.motors.positions) if spec.motors else 0, "motor"),
        (len(spec.surfaces), "surface"),
        (len(spec.boosters.positions) if spec.boosters else 0, "booster"),
        (len(spec.gimbals), "gimbal"),
        (len(spec.cameras), "camera"),
    ):
        if count:
            parts.append(f"{count} {noun}{'s' if count > 1 else ''}")
    parts.append("no controller" if spec.control.type == "none" else f"{spec.control.type} control")
    ratios = thrust_to_weight(spec)
    shown = next((key for key in ("mixer motors", "all motors", "boosters") if key in ratios), None)
    if shown is not None:
        parts.append(f"T/W {ratios[shown]:.2f}")
    return ", ".join(parts)


def validation_warnings(spec: UAVSpec) -> list[str]:
    """Things that are valid but probably not meant (a multirotor that cannot hover)."""
    found = []
    lift = thrust_to_weight(spec).get("mixer motors")
    if lift is not None and lift <= 1.0:
        found.append(f"the multirotor motors lift only {lift:.2f} x the weight: it cannot hover")
    return found


# ------------------------------------------------------------------ show: numbers


@dataclass(frozen=True)
class MassReport:
    """Mass properties of an airframe.

    Attributes:
        dry_mass: airframe without fuel [kg].
        fuel_full, fuel_at_spawn: booster fuel when full and at spawn [kg] (0 without boosters).
        com: centre of mass in the spec's coordinates [m]; the built body's origin.
        inertia: (3, 3) dry inertia about the centre of mass, body axes [kg m^2].
        principal: (3,) principal moments of ``inertia``, ascending [kg m^2].
    """

    dry_mass: float
    fuel_full: float
    fuel_at_spawn: float
    com: np.ndarray
    inertia: np.ndarray
    principal: np.ndarray


def mass_report(spec: UAVSpec) -> MassReport:
    """Mass, centre of mass and inertia of ``spec`` (dry, plus booster fuel)."""
    fuel_full = 0.0
    fuel_spawn = 0.0
    if spec.boosters is not None:
        fuel_full = float(sum(spec.boosters.per_booster("total_fuel")))
        fuel_spawn = fuel_full * spec.boosters.initial_fuel
    inertia = spec.inertia_matrix()
    return MassReport(
        dry_mass=spec.total_mass(),
        fuel_full=fuel_full,
        fuel_at_spawn=fuel_spawn,
        com=spec.center_of_mass(),
        inertia=inertia,
        principal=np.linalg.eigvalsh(inertia),
    )


def motor_max_thrust(spec: UAVSpec) -> np.ndarray:
    """(n,) static thrust of every motor at full throttle, k_F max_rpm^2 [N]."""
    if spec.motors is None:
        return np.zeros(0)
    return spec.motors.to_array("kf") * spec.motors.to_array("max_rpm") ** 2


def thrust_to_weight(spec: UAVSpec) -> dict[str, float]:
    """Thrust-to-weight ratios at the spawn mass (dry + fuel at spawn), g = 9.81 m/s^2.

    Keys present when the airframe has them:

    - ``mixer motors``: sum of k_F max_rpm^2 a_z over the motors the multirotor controller
      flies (a_z: their thrust axis along body +z), i.e. the thrust that can hold it up;
    - ``all motors``: sum of k_F max_rpm^2 over every motor, whatever its direction;
    - ``boosters``: sum of the boosters' max_thrust.
    """
    mass = mass_report(spec)
    weight = (mass.dry_mass + mass.fuel_at_spawn) * GRAVITY
    ratios: dict[str, float] = {}
    if spec.motors is not None:
        thrust = motor_max_thrust(spec)
        chosen = list(spec.mixer_motor_indices())
        if chosen:
            axes_z = spec.motors.to_array("thrust_axes")[chosen, 2]
            ratios["mixer motors"] = float(thrust[chosen] @ axes_z) / weight
        ratios["all motors"] = float(thrust.sum()) / weight
    if spec.boosters is not None:
        ratios["boosters"] = float(sum(spec.boosters.per_booster("max_thrust"))) / weight
    return ratios


def _vec(values, digits: int = 4) -> str:
    """``(x, y, z)`` with round-off below 1e-12 shown as 0."""
    return "(" + ", ".join(f"{0.0 if abs(float(v)) < 1e-12 else float(v):.{digits}g}" for v in values) + ")"


def _mix(weights: dict[str, float] | None) -> str:
    if not weights:
        return "-"
    return " ".join(f"{name}{weight:+g}" for name, weight in weights.items())


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    widths = [max(len(str(c)) for c in column) for column in zip(header, *rows)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths)).rstrip()  # noqa: E731
    return ["    " + line(header)] + ["    " + line(r) for r in rows]


def describe(spec: UAVSpec) -> list[str]:
    """The lines ``pyflyt uav show`` prints for ``spec``."""
    mass = mass_report(spec)
    out = [f"{spec.name}: {spec.description}" if spec.description else spec.name]
    if spec.source:
        out.append(f"  file: {spec.source}")

    out.append("mass")
    from_parts = "  (from the parts)" if spec.body.mass is None else ""
    out.append(f"  dry mass            {mass.dry_mass:.6g} kg{from_parts}")
    if spec.boosters is not None:
        b = spec.boosters
        out.append(f"  with full fuel      {mass.dry_mass + mass.fuel_full:.6g} kg  (fuel {mass.fuel_full:.6g} kg)")
        out.append(
            f"  at spawn            {mass.dry_mass + mass.fuel_at_spawn:.6g} kg  "
            f"(initial_fuel {b.initial_fuel:g} -> {mass.fuel_at_spawn:.6g} kg)"
        )
    out.append(f"  centre of mass      {_vec(mass.com)} m in the spec's coordinates (the body origin once built)")
    out.append("  inertia about the centre of mass, body axes [kg m^2]:")
    inertia = np.where(np.abs(mass.inertia) < 1e-9 * np.abs(mass.inertia).max(), 0.0, mass.inertia)  # round-off
    for row in inertia:
        out.append("    [" + "  ".join(f"{v:11.4g}" for v in row) + " ]")
    out.append("  principal moments   " + ", ".join(f"{v:.4g}" for v in mass.principal) + " kg m^2")

    ratios = thrust_to_weight(spec)
    if ratios:
        spawn = mass.dry_mass + mass.fuel_at_spawn
        out.append(f"thrust-to-weight (at {spawn:.6g} kg, g = {GRAVITY} m/s^2)")
        thrust = motor_max_thrust(spec)
        chosen = list(spec.mixer_motor_indices())
        if "mixer motors" in ratios:
            lift = float(thrust[chosen] @ spec.motors.to_array("thrust_axes")[chosen, 2])  # type: ignore[union-attr]
            out.append(f"  mixer motors, along body +z   {ratios['mixer motors']:.2f}  ({lift:.4g} N)")
        if "all motors" in ratios:
            out.append(f"  all motors, full thrust       {ratios['all motors']:.2f}  ({thrust.sum():.4g} N)")
        if "boosters" in ratios:
            total = sum(spec.boosters.per_booster("max_thrust"))  # type: ignore[union-attr]
            full = total / ((mass.dry_mass + mass.fuel_full) * GRAVITY)
            dry = total / (mass.dry_mass * GRAVITY)
            out.append(
                f"  boosters, max thrust          {ratios['boosters']:.2f}  ({total:.4g} N; "
                f"{dry:.2f} dry, {full:.2f} with full fuel)"
            )

    out.append("components (positions in the spec's coordinates [m], axes in the body frame)")
    if spec.motors is not None:
        m = spec.motors
        chosen_set = set(spec.mixer_motor_indices())
        axes = m.to_array("thrust_axes")
        mixes = m.mix or [None] * len(m.positions)
        rows = [
            [
                str(i),
                _vec(m.positions[i]),
                _vec(axes[i]),
                "CCW (+1)" if m.spin[i] > 0 else "CW (-1)",
                f"{motor_max_thrust(spec)[i]:.4g}",
                "mixer" if i in chosen_set else _mix(mixes[i]),
            ]
            for i in range(len(m.positions))
        ]
        out.append(f"  motors ({len(rows)})")
        out += _table(["#", "position", "thrust axis", "spin", "max thrust [N]", "driven by"], rows)
    if spec.surfaces:
        rows = [
            [
                s.name,
                _vec(s.position),
                f"{s.chord:.4g} x {s.span:.4g}",
                f"{s.chord * s.span:.4g}",
                f"+-{s.max_deflection_deg:g}" if s.max_deflection_deg else "fixed",
                _mix(s.mix),
            ]
            for s in spec.surfaces
        ]
        out.append(f"  lifting surfaces ({len(rows)})")
        out += _table(["name", "position", "chord x span [m]", "area [m^2]", "deflection [deg]", "mixing"], rows)
    if spec.boosters is not None:
        b = spec.boosters
        axes = b.thrust_axes or [(0.0, 0.0, 1.0)] * len(b.positions)
        fields = {k: b.per_booster(k) for k in ("min_thrust", "max_thrust", "total_fuel", "reignitable",
                                                "ignition_channel", "throttle_channel")}  # fmt: skip
        rows = [
            [
                str(i),
                _vec(b.positions[i]),
                _vec(axes[i]),
                f"{fields['min_thrust'][i]:.4g}-{fields['max_thrust'][i]:.4g}",
                f"{fields['total_fuel'][i]:.4g}",
                "yes" if fields["reignitable"][i] else "no",
                f"{fields['ignition_channel'][i]} / {fields['throttle_channel'][i]}",
            ]
            for i in range(len(b.positions))
        ]
        out.append(f"  boosters ({len(rows)})")
        header = ["#", "position", "thrust axis", "thrust [N]", "fuel [kg]", "relight", "ignition / throttle"]
        out += _table(header, rows)
    if spec.gimbals:
        rows = [
            [g.name, g.target, _vec(g.axis_a), _vec(g.axis_b), f"+-{g.max_angle_a_deg:g} / +-{g.max_angle_b_deg:g}",
             " / ".join(g.channels)]
            for g in spec.gimbals
        ]  # fmt: skip
        out.append(f"  gimbals ({len(rows)})")
        out += _table(["name", "target", "axis a", "axis b", "limits [deg]", "channels a / b"], rows)
    if spec.cameras:
        rows = [
            [c.name, _vec(c.position), _vec(c.orientation_deg), f"{c.fov:g}", f"{c.width}x{c.height}",
             f"{c.capture_hz:g}", "yes" if c.horizon_lock else "no", ",".join(c.outputs)]
            for c in spec.cameras
        ]  # fmt: skip
        out.append(f"  cameras ({len(rows)})")
        header = ["name", "position", "rpy [deg]", "fov [deg]", "pixels", "rate [Hz]", "horizon lock", "outputs"]
        out += _table(header, rows)
    if spec.motors is None and not (spec.surfaces or spec.boosters or spec.gimbals or spec.cameras):
        out.append("  none")

    if spec.channels:
        out.append("channels (setpoint order)")
        for name, (low, high) in spec.channels.items():
            span = f"[{low:g}, {high:g}]"
            out.append(f"  {name:<16}{span:<12}used by {', '.join(channel_users(spec, name)) or 'nothing'}")
    else:
        out.append("channels: none")

    control = spec.control
    if isinstance(control, MultirotorControlSpec):
        default = control.mode
    elif isinstance(control, FixedwingControlSpec):
        default = control.mode
    else:
        default = "channels"
    out.append(f"controller: {control.type}, default mode {default}")
    return out


def channel_users(spec: UAVSpec, channel: str) -> list[str]:
    """Which actuators (and autopilot loop) read ``channel``."""
    users = []
    if spec.motors is not None:
        users += [f"motor {i}" for i, mix in enumerate(spec.motors.mix or []) if mix and channel in mix]
    users += [f"surface {s.name}" for s in spec.surfaces if channel in s.mix]
    if spec.boosters is not None:
        b = spec.boosters
        users += [f"booster {i} ignition" for i, c in enumerate(b.per_booster("ignition_channel")) if c == channel]
        users += [f"booster {i} throttle" for i, c in enumerate(b.per_booster("throttle_channel")) if c == channel]
    users += [f"gimbal {g.name} {axis}" for g in spec.gimbals for axis, c in zip("ab", g.channels) if c == channel]
    if isinstance(spec.control, FixedwingControlSpec):
        c = spec.control
        loops = {c.roll_channel: "roll", c.pitch_channel: "pitch", c.yaw_channel: "yaw", c.thrust_channel: "thrust"}
        users += [f"autopilot {loop}" for name, loop in loops.items() if name == channel]
    return users


# ------------------------------------------------------------------ show: images


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


def render_airframe(spec: UAVSpec, path: Path, width: int = 640, height: int = 480) -> Path:
    """Write a 3/4-view PNG of ``spec`` (offscreen: PyBullet DIRECT + TinyRenderer).

    The airframe's generated URDF (:func:`~pyflyt_engine.urdf.urdf_path`) is loaded with
    its centre of mass at the origin and seen from front-right and above, from the
    distance that just frames it (:func:`_fit_distance`); overlays are scaled by its
    bounding size (PyBullet's AABB and the parts).  Overlays: the body axes at the centre of mass (red X
    forward, green Y left, blue Z up), each motor's thrust axis coloured by spin (orange
    CCW +1, blue CW -1) and each booster's plume (magenta, opposite its thrust).

    Raises:
        CLIError: PyBullet cannot load the URDF (e.g. a missing mesh).
    """
    import pybullet as p
    from PIL import Image

    from pyflyt_engine.urdf import urdf_path

    client = p.connect(p.DIRECT)
    try:
        try:
            body = p.loadURDF(str(urdf_path(spec)), useFixedBase=True, physicsClientId=client)
        except p.error as exc:
            raise CLIError(f"{spec.source or spec.name}: PyBullet cannot load the airframe's URDF: {exc}") from None
        # the collision bounding box sets the scale; the primitives' own corners give a tight
        # framing (a box's far corners lie well outside a cross-shaped airframe), except for
        # meshes and user URDFs, whose extent only PyBullet knows
        box = np.array(p.getAABB(body, -1, physicsClientId=client), dtype=float)
        box_corners = np.array([[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]])
        features = _feature_points(spec)
        if spec.body.urdf is not None or any(shape.type == "mesh" for shape in spec.body.shapes) or not len(features):
            features = np.vstack([features, box_corners])
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
            axes = spec.boosters.thrust_axes or [(0.0, 0.0, 1.0)] * len(spec.boosters.positions)
            for position, axis in zip(spec.boosters.positions, axes):
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


def plot_surface_curves(spec: UAVSpec, path: Path) -> Path:
    """Write a PNG of C_L, C_D and C_M against alpha for every lifting surface.

    One row per surface, at deflections -max, 0 and +max (the Khan & Nahon profile of
    :func:`~pyflyt_engine.components.lifting_surface.coefficient_curves`).

    Raises:
        CLIError: the airframe has no lifting surfaces.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from pyflyt_engine.assembly import assemble
    from pyflyt_engine.components.lifting_surface import coefficient_curves

    if not spec.surfaces:
        raise CLIError(f"{spec.name} has no lifting surfaces: nothing to plot for --curves")
    try:
        surfaces = assemble(spec).surfaces
    except ValueError as exc:
        raise CLIError(f"{spec.source or spec.name}: cannot build the lifting surfaces: {exc}") from None
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


def run_show(name_or_path: str, png: Path | None = None, size: str = "640x480", curves: Path | None = None) -> UAVSpec:
    """Print the airframe's numbers; optionally write its picture and coefficient curves.

    Output paths are checked before anything is printed or rendered.
    """
    path = resolve_file(name_or_path)
    width, height = parse_size(size)
    outputs = [(png, "--png"), (curves, "--curves")]
    for target, option in outputs:
        if target is not None:
            check_output(target, option, (".png",), [path])
    if png is not None and curves is not None and png.resolve() == curves.resolve():
        raise CLIError(f"--png and --curves name the same file {png}; give two different files")
    spec = load_uav_spec(path)
    if curves is not None and not spec.surfaces:
        raise CLIError(f"{spec.name} has no lifting surfaces: nothing to plot for --curves")
    for line in describe(spec):
        typer.echo(line)
    if png is not None:
        render_airframe(spec, png, width, height)
        typer.echo(
            f"picture: {png} ({width}x{height}; body axes red X forward, green Y left, blue Z up; "
            "motor thrust axes orange CCW, blue CW; boosters magenta)"
        )
    if curves is not None:
        plot_surface_curves(spec, curves)
        typer.echo(f"coefficient curves: {curves}")
    return spec
