"""UAV components: one module per physical model, each used by the simulator, the plots and the tests.

Each module holds one model: a frozen parameter dataclass (units and frames documented
on the fields), pure functions on plain floats that advance its state and give its loads
in the body frame, with the equation and its source in the docstring, and the
**actuator group** that steps every such actuator of one vehicle.

Every group has the same small interface, :class:`~pyflyt_engine.components.kinds.ActuatorGroup`,
and every kind of component registers, in its own module, its spec section and the builder
of its group (:mod:`pyflyt_engine.components.kinds`):

* ``route(channels, outputs)``: at every control tick, set the group's commands from
  the vehicle's channel vector and the multirotor mixer's outputs, with the routing
  tables the group was built with (:mod:`pyflyt_engine.components.routing`).
* ``step(air, thrust_ratio)``: advance one physics step from the current commands and
  return the group's load on the body, ``(Fx, Fy, Fz, Tx, Ty, Tz)`` [N, N m] in the body
  frame about the centre of mass, taking of its inputs exactly what the model needs: drag
  and lifting surfaces take ``air``, the body's velocity *through the air* in the body
  frame, ``((u, v, w), (p, q, r))`` [m/s, rad/s], so wind enters once, by subtraction;
  motors take each rotor's thrust ratio from the air around it (ground effect); boosters
  take nothing.  Gimbals apply no load (None): their step turns their targets' thrust axes.
* ``reset()``: back to the idle state of a fresh spawn; ``reseed()``: the noise generator
  was replaced.
* ``aux()``: the read-outs appended to the vehicle's auxiliary state.

No group writes into another except through what it was handed at build (a gimbal its
targets' ``turn``): the vehicle (:mod:`pyflyt_engine.vehicle`) hands each its inputs (the
air from the world), sums the wrenches and applies them.  Groups
never touch PyBullet; the one PyBullet call in this package is the camera's renderer,
:func:`pyflyt_engine.components.camera.capture`, kept beside the camera maths.
"""

from __future__ import annotations

#: The body's velocity through the air, body frame: ((u, v, w) [m/s], (p, q, r) [rad/s]).
AirVelocity = tuple[tuple[float, float, float], tuple[float, float, float]]
#: A load on the body, body frame, about the centre of mass: (Fx, Fy, Fz [N], Tx, Ty, Tz [N m]).
Wrench = tuple[float, float, float, float, float, float]
