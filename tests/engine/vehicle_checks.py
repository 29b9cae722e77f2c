"""Checks on a built vehicle shared by the tests: what runs around its steps, and that no
method of it was replaced on the instance."""

from __future__ import annotations

from pyflyt_engine.vehicle import Vehicle

#: the stages of a vehicle without latency and noisy sensors: none
NO_STAGES = {"before_control": (), "before_loads": ()}


def shadowed_methods(vehicle: Vehicle) -> set[str]:
    """The names of the vehicle's methods its instance dictionary replaces (none is ever)."""
    return {name for name in vars(vehicle) if callable(getattr(type(vehicle), name, None))}
