"""Static flight mechanics of a fixed-wing spec, from the component models alone.

The oracles of the fixed-wing tests: the net body-frame wrench of an airframe moving
through still air at a given attitude and speed, summed from the same pure component
functions the vehicle uses (lifting surfaces, body drag, motor thrust) plus gravity,
without PyBullet.  From it, :func:`level_trim` solves for steady level flight and
:func:`glide_ratio` gives the lift-to-drag ratio at an angle of attack.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import fsolve

from pyflyt_engine.assembly import Assembly, assemble
from pyflyt_engine.components.drag import BodyDrag, DragParams
from pyflyt_engine.components.lifting_surface import surface_wrench
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.spec import UAVSpec


def aero_wrench(spec: UAVSpec, parts: Assembly, velocity_body, channels) -> tuple[np.ndarray, np.ndarray]:
    """Surface + body-drag force [N] and torque about the centre of mass [N m], body frame.

    Flap deflections are their steady state for ``channels`` (mix, clip, times the limit).
    """
    commands = np.clip(parts.surface_mix @ np.asarray(channels, dtype=float), -1.0, 1.0)
    force, torque = np.zeros(3), np.zeros(3)
    for surface, command in zip(parts.surfaces, commands):
        u, v, w = (float(x) for x in velocity_body)
        wrench = surface_wrench(surface.constants, float(command) * surface.max_deflection, u, v, w, 0.0, 0.0, 0.0)
        force += wrench[:3]
        torque += wrench[3:]
    drag = DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping)
    d = np.array(BodyDrag(drag).step((tuple(float(v) for v in velocity_body), (0.0, 0.0, 0.0))))
    return force + d[:3], torque + d[3:]


def level_trim(spec: UAVSpec, airspeed: float, pitch_channel: str = "pitch") -> dict[str, float]:
    """Steady wings-level flight at ``airspeed`` [m/s] in still air.

    Solves for the Euler pitch angle theta [rad] (ENU: negative is nose up), the pitch
    channel and the motor thrust [N] such that the body-frame force (surfaces, drag,
    thrust along the motor axis, gravity) and the pitching moment about the centre of
    mass vanish.  Returns ``{"pitch", "alpha", "pitch_channel", "thrust"}``.
    """
    parts = assemble(spec)
    weight = parts.mass * GRAVITY
    k = parts.channels.index(pitch_channel)
    axis, position = parts.motors.thrust_axes[0], parts.motors.positions[0]

    def residual(x):
        theta, channel, thrust = x
        v = airspeed * np.array([math.cos(theta), 0.0, math.sin(theta)])
        channels = np.zeros(len(parts.channels))
        channels[k] = channel
        force, torque = aero_wrench(spec, parts, v, channels)
        force = force + thrust * axis + weight * np.array([math.sin(theta), 0.0, -math.cos(theta)])
        torque = torque + np.cross(position, thrust * axis)
        return [force[0], force[2], torque[1]]

    solution, info, ok, message = fsolve(residual, [-0.03, 0.0, 0.2 * weight], full_output=True)
    if ok != 1 or np.abs(info["fvec"]).max() > 1e-6:
        raise RuntimeError(f"no level trim at {airspeed} m/s: {message}")
    theta, channel, thrust = solution
    return {"pitch": float(theta), "alpha": float(-theta), "pitch_channel": float(channel), "thrust": float(thrust)}


def glide_ratio(spec: UAVSpec, alpha: float, airspeed: float = 14.0) -> float:
    """Lift / drag of the airframe with neutral controls at angle of attack ``alpha`` [rad]."""
    parts = assemble(spec)
    v = airspeed * np.array([math.cos(alpha), 0.0, -math.sin(alpha)])
    force, _ = aero_wrench(spec, parts, v, np.zeros(len(parts.channels)))
    wind = v / airspeed
    drag = -force @ wind
    lift = force @ np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    return float(lift / drag)


def straight_trim(spec: UAVSpec, airspeed: float) -> dict[str, float]:
    """Steady straight and level flight at ``airspeed`` [m/s], wings level, still air.

    Unlike :func:`level_trim` (pitch plane only), all six equations: the three body-frame
    forces and the three moments about the centre of mass, the propeller's reaction
    torque included (``-spin * k_T omega^2`` about the thrust axis, ``= -spin (k_T / k_F)
    T`` for a thrust ``T``; pyflyt_engine/components/motor.py).  The unknowns: the Euler
    pitch theta, the sideslip beta (body ``v = V sin beta``), the roll, pitch and yaw
    channels and the thrust [N].  Returns those, the angle of attack and the thrust
    channel (normalised speed, ``sqrt(T / T_max)``), keyed ``{"pitch", "beta", "alpha",
    "roll_channel", "pitch_channel", "yaw_channel", "thrust", "thrust_channel"}``.
    The body velocity is ``V (cos beta cos theta, sin beta, cos beta sin theta)``, whose
    ground-frame vertical part vanishes at roll 0 and yaw 0: the track is level, at
    ``beta`` to the left of the nose.
    """
    parts = assemble(spec)
    weight = parts.mass * GRAVITY
    index = {name: parts.channels.index(name) for name in ("roll", "pitch", "yaw")}
    motors = parts.motors
    axis, position = motors.thrust_axes[0], motors.positions[0]
    reaction_per_newton = -float(motors.spin[0]) * float(motors.kt[0]) / float(motors.kf[0])

    def velocity(theta: float, beta: float) -> np.ndarray:
        return airspeed * np.array([math.cos(beta) * math.cos(theta), math.sin(beta), math.cos(beta) * math.sin(theta)])

    def residual(x):
        theta, beta, roll, pitch, yaw, thrust = x
        channels = np.zeros(len(parts.channels))
        channels[[index["roll"], index["pitch"], index["yaw"]]] = roll, pitch, yaw
        force, torque = aero_wrench(spec, parts, velocity(theta, beta), channels)
        force = force + thrust * axis + weight * np.array([math.sin(theta), 0.0, -math.cos(theta)])
        torque = torque + np.cross(position, thrust * axis) + reaction_per_newton * thrust * axis
        return [*force, *torque]

    start = [-0.03, 0.0, 0.0, 0.0, 0.0, 0.2 * weight]
    solution, info, ok, message = fsolve(residual, start, full_output=True)
    if ok != 1 or np.abs(info["fvec"]).max() > 1e-6:
        raise RuntimeError(f"no straight trim at {airspeed} m/s: {message}")
    theta, beta, roll, pitch, yaw, thrust = (float(v) for v in solution)
    v = velocity(theta, beta)
    max_thrust = float(motors.kf[0] * motors.max_rpm[0] ** 2)
    return {
        "pitch": theta,
        "beta": beta,
        "alpha": float(math.atan2(-v[2], v[0])),
        "roll_channel": roll,
        "pitch_channel": pitch,
        "yaw_channel": yaw,
        "thrust": thrust,
        "thrust_channel": math.sqrt(thrust / max_thrust),
        "velocity_body": v.tolist(),
    }
