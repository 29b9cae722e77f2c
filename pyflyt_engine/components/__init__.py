"""UAV components: one module per physical model, each used by the simulator, the plots and the tests.

Each module holds one model: a frozen parameter dataclass (units and frames documented
on the fields), pure functions on plain floats that advance its state and give its loads
in the body frame, with the equation and its source in the docstring, and the
**actuator group** that steps every such actuator of one vehicle.

Every group has the same small interface, so the vehicle steps them all the same way
and a new actuator kind or a new effect is added in one place:

* ``step(air) -> wrench``: advance one physics step from the current commands and
  return the group's load on the body, ``(Fx, Fy, Fz, Tx, Ty, Tz)`` [N, N m] in the
  body frame about the centre of mass.  ``air`` is the body's velocity *through the air*
  in the body frame, ``((u, v, w), (p, q, r))`` [m/s, rad/s]: every aerodynamic model
  (drag, lifting surfaces, rotors) takes it, so wind enters once, by subtraction.
* ``reset()``: back to the idle state of a fresh spawn.
* ``aux()``: the read-outs appended to the vehicle's auxiliary state.

Commands are plain attributes the vehicle sets at the control rate (``command``).
Groups never touch PyBullet: the vehicle (:mod:`pyflyt_engine.vehicle`) sums their
wrenches and applies them; the one other PyBullet call in this package is the camera's
renderer, :func:`pyflyt_engine.components.camera.capture`, kept beside the camera maths.
"""

from __future__ import annotations

#: The body's velocity through the air, body frame: ((u, v, w) [m/s], (p, q, r) [rad/s]).
AirVelocity = tuple[tuple[float, float, float], tuple[float, float, float]]
#: A load on the body, body frame, about the centre of mass: (Fx, Fy, Fz [N], Tx, Ty, Tz [N m]).
Wrench = tuple[float, float, float, float, float, float]
