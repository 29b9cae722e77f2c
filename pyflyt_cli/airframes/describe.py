"""An airframe's numbers, as ``pyflyt uav show`` prints them.

:func:`mass_report` (mass, centre of mass, inertia), :func:`thrust_to_weight`,
:func:`channel_users`, and :func:`describe`: every line ``pyflyt uav show`` prints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.spec import FixedwingControlSpec, MultirotorControlSpec, UAVSpec


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
        booster_axes = b.thrust_axes or [(0.0, 0.0, 1.0)] * len(b.positions)
        fields = {k: b.per_booster(k) for k in ("min_thrust", "max_thrust", "total_fuel", "reignitable",
                                                "ignition_channel", "throttle_channel")}  # fmt: skip
        rows = [
            [
                str(i),
                _vec(b.positions[i]),
                _vec(booster_axes[i]),
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
             "mixer (axis a)" if g.mixer else " / ".join(g.channels)]
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
    default = control.mode if isinstance(control, (MultirotorControlSpec, FixedwingControlSpec)) else "channels"
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


# ---------------------------------------------------------------------------- payloads

_JOINTS = {
    "fixed": "fixed (welded)",
    "ball": "ball joint (passive, frictionless)",
    "tether": "tether (a string: never farther than its length, may go slack)",
    "free": "free (no joint; placed at every reset)",
}


def carried_mass(payloads) -> float:
    """Mass [kg] the vehicle carries: its payloads held by a fixed, ball or tether joint."""
    return float(sum(p.mass() for p in payloads if p.attach.to == "vehicle" and p.attach.joint != "free"))


def _shape_size(shape) -> str:
    if shape.type == "box":
        return "box " + " x ".join(f"{v:.4g}" for v in shape.size)
    if shape.type == "cylinder":
        return f"cylinder r {shape.radius:.4g}, length {shape.length:.4g}"
    if shape.type == "sphere":
        return f"sphere r {shape.radius:.4g}"
    return f"mesh {shape.mesh}"


def describe_payloads(config, spec: UAVSpec | None = None) -> list[str]:
    """The lines ``pyflyt uav show --env <env>`` adds: every payload of the env config ``config``.

    Per payload: mass, centre of mass and inertia (as the engine builds it: computed from
    the parts when not given), its attachment (parent, joint, anchors, tether length), its
    declared pose (where every reset puts it, unless the task places it), contact
    settings and shapes.  With ``spec`` (the airframe that carries
    them) also the carried mass and the thrust-to-weight ratios with it.
    """
    source = f": {config.source}" if config.source else ""
    name = config.id or "inline config"
    if not config.payloads:
        return [f"payloads: none (env {name}{source} declares no payloads)"]
    out = [f"payloads of env {name}{source} ({len(config.payloads)})"]
    # a task that places payloads itself (QuadX-Gates' random course) names them in its options
    moved = set(getattr(config.task, "gates", ())) if getattr(config.task, "course", None) == "random" else set()
    for payload in config.payloads:
        attach = payload.attach
        parent = "the vehicle" if attach.to == "vehicle" else "the world"
        frame = "vehicle body frame, from its centre of mass" if attach.to == "vehicle" else "ground frame (ENU)"
        static = attach.to == "world" and attach.joint == "fixed"
        out.append(f"  {payload.name}: {_JOINTS[attach.joint]} to {parent}" + (" (a static body)" if static else ""))
        from_parts = "  (from the parts)" if payload.body.mass is None else ""
        out.append(f"    mass                {payload.mass():.6g} kg{from_parts}")
        out.append(f"    centre of mass      {_vec(payload.center_of_mass())} m in the payload's frame")
        inertia = payload.inertia_matrix()
        scale = np.abs(inertia).max()
        inertia = np.where(np.abs(inertia) < 1e-9 * scale, 0.0, inertia)  # round-off
        out.append("    inertia about the centre of mass, payload axes [kg m^2]:")
        for row in inertia:
            out.append("      [" + "  ".join(f"{v:11.4g}" for v in row) + " ]")
        out.append("    principal moments   " + ", ".join(f"{v:.4g}" for v in np.linalg.eigvalsh(inertia)) + " kg m^2")
        if attach.joint == "tether":
            out.append(
                f"    attachment          string of {attach.length:g} m from {_vec(attach.anchor)} m on {parent} "
                f"to {_vec(attach.payload_anchor)} m on the payload"
            )
        elif attach.joint == "ball" or (attach.joint == "fixed" and attach.to == "vehicle"):
            out.append(
                f"    attachment          at {_vec(attach.anchor)} m on {parent}, "
                f"{_vec(attach.payload_anchor)} m on the payload"
            )
        com = np.asarray(payload.position) + payload.rotation() @ payload.center_of_mass()
        out.append(
            f"    declared pose       frame at {_vec(payload.position)} m, rpy {_vec(payload.orientation)} rad; "
            f"centre of mass at {_vec(com)} m ({frame})"
        )
        if payload.name in moved:
            out.append(f"                        (task {config.task.name}, course: random: moved at every reset)")
        contacts = f"ground contact ends the episode: {'yes' if payload.ground_contact_fails and not static else 'no'}"
        if attach.to == "vehicle":
            contacts = f"with the vehicle: {'simulated' if payload.collide_with_parent else 'off'}; " + contacts
        out.append(f"    contacts            {contacts}")
        rows = [
            [
                _shape_size(s),
                _vec(s.position),
                _vec(s.rpy),
                "-" if s.mass is None else f"{s.mass:.4g}",
                "yes" if s.collision else "no",
                "yes" if s.visual else "no",
            ]
            for s in payload.body.shapes
        ]
        out.append(f"    shapes ({len(rows)}; positions in the payload's frame [m])")
        out += ["  " + line for line in _table(["shape [m]", "position", "rpy [rad]", "mass [kg]", "collision",
                                                "visual"], rows)]  # fmt: skip
    carried = carried_mass(config.payloads)
    if spec is not None:
        mass = mass_report(spec)
        spawn = mass.dry_mass + mass.fuel_at_spawn
        total = spawn + carried
        if carried == 0:
            out.append(f"carried by {spec.name}: none")
            return out
        out.append(f"carried by {spec.name}: {carried:.6g} kg of payloads; with them {total:.6g} kg")
        ratios = thrust_to_weight(spec)
        if ratios and carried > 0:
            out.append(f"thrust-to-weight with the payloads (at {total:.6g} kg)")
            for key, ratio in ratios.items():
                out.append(f"  {key:<28}  {ratio * spawn / total:.2f}")
    return out
