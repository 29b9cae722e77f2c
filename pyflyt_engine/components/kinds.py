"""The component kinds a vehicle is built from: one protocol for their groups, one registry.

A **component kind** (motors, lifting surfaces, boosters, gimbals, body drag, cameras, the
battery's gauge, propeller guards ...) is declared once, in its own module, by
:func:`register`: the spec section it is read from (a field of
:class:`~pyflyt_engine.spec.UAVSpec`) and that section's class, the builder that turns the
validated spec into the kind's group (None when the airframe has none of it), and its place
in the vehicle (``order``) and in the physics step (``step_order``).  The vehicle
(:mod:`pyflyt_engine.vehicle`) knows no kind by name for building, routing, stepping,
resetting or reading out: it builds every registered kind in ``order`` and keeps the groups
it got as one ordered tuple.  A new kind is its own module here and its spec class in
:mod:`pyflyt_engine.spec`; nothing else changes (docs/uav_authoring.md, "A new component
kind").

Every group has the interface :class:`ActuatorGroup`:

* ``route(channels, outputs)``: at every control tick, its commands from the vehicle's
  channel vector and the multirotor mixer's outputs (None: none this tick), with the
  tables it was built with (:mod:`pyflyt_engine.components.routing`);
* ``step(air, thrust_ratio)``: one physics step from the current commands, given the
  body's velocity through the air (body frame) and the ground-effect thrust ratio per
  motor (None: 1), of which each model takes what it needs; returns the group's wrench
  on the body about the centre of mass, body frame, or None for a group that applies no
  load (a gimbal turns its targets' thrust axes instead);
* ``reset()``: back to a fresh spawn; ``reseed()``: the vehicle's noise generator was
  replaced; ``aux()``: the read-outs appended to the auxiliary state;
* ``needs_air``: whether ``step`` reads ``air`` (the world then reads the body's motion at
  every physics step, not only at control ticks); ``commanded``: whether ``route`` sets
  anything (the vehicle routes only the groups that take commands).

The pure per-model law functions stay in their modules beside their groups; this module
adds no physics.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.spec import UAVSpec

if TYPE_CHECKING:  # annotations only: the assembly is built above the components
    from pyflyt_engine.assembly import Assembly


class ActuatorGroup(Protocol):
    """What a vehicle asks of every component group (the module docstring)."""

    commanded: bool

    @property
    def needs_air(self) -> bool: ...

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None) -> None: ...

    def step(self, air: AirVelocity, thrust_ratio: Sequence[float] | None) -> Wrench | None: ...

    def reset(self) -> None: ...

    def reseed(self) -> None: ...

    def aux(self) -> list[float]: ...


@dataclass(frozen=True)
class BuildContext:
    """What a kind's builder gets.

    Attributes:
        spec: the validated airframe spec.
        parts: its components in the centre-of-mass frame (:class:`~pyflyt_engine.assembly.Assembly`);
            a kind whose parameters the assembly does not compute shifts its positions by
            ``parts.com`` itself.
        physics_dt: the physics step [s].
        noise: the vehicle's noise source (actuator noise is drawn from it, in step order).
        drag: the vehicle's drag switch (``World.add_vehicle(drag=...)``): False leaves out
            every aerodynamic load that is not a lifting surface or a rotor.
        groups: the groups built so far (kinds of lower ``order``), by kind name.
    """

    spec: UAVSpec
    parts: Assembly
    physics_dt: float
    noise: NoiseSource
    drag: bool
    groups: Mapping[str, ActuatorGroup]


@dataclass(frozen=True)
class ComponentKind:
    """One registered kind (:func:`register`).

    Attributes:
        name: the kind's name, also its attribute on ``Vehicle.actuators`` (``motors``).
        section: the :class:`~pyflyt_engine.spec.UAVSpec` field it is declared in.
        spec: that section's class (for a list section, the class of one entry).
        build: the builder: the group, or None when the airframe has none of this kind.
        order: the group's place in the vehicle: groups are built (a builder sees the
            groups of lower order), routed, reset and read out (``aux``) in this order.
        step_order: its place in the physics step (wrenches are summed in this order,
            the first taken as it is); None: a group the physics step skips (cameras).
    """

    name: str
    section: str
    spec: type
    build: Callable[[BuildContext], ActuatorGroup | None]
    order: int
    step_order: int | None


_KINDS: dict[str, ComponentKind] = {}
_DISCOVERED = False


def register(
    name: str,
    *,
    section: str,
    spec: type,
    build: Callable[[BuildContext], ActuatorGroup | None],
    order: int,
    step_order: int | None,
) -> ComponentKind:
    """Declare a component kind (at the import of its module; see :class:`ComponentKind`).

    Raises:
        ValueError: the name, the order or the step order is taken by another kind.
    """
    kind = ComponentKind(name, section, spec, build, order, step_order)
    for other in _KINDS.values():
        if other.name == name:
            raise ValueError(f"component kind '{name}' is registered twice")
        if other.order == order or (step_order is not None and other.step_order == step_order):
            raise ValueError(f"component kinds '{other.name}' and '{name}' share an order; give each its own")
    _KINDS[name] = kind
    return kind


def component_kinds() -> tuple[ComponentKind, ...]:
    """Every registered kind, in ``order``.

    The first call imports every module of this package, so that each registers the
    kinds it holds: a kind is found by its module, listed nowhere else.
    """
    global _DISCOVERED
    if not _DISCOVERED:
        package = importlib.import_module(__package__ or "pyflyt_engine.components")
        for module in pkgutil.iter_modules(package.__path__):
            importlib.import_module(f"{package.__name__}.{module.name}")
        _DISCOVERED = True
    return tuple(sorted(_KINDS.values(), key=lambda kind: kind.order))
