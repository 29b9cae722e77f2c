"""A vehicle is an ordered tuple of component groups behind one protocol, from a registry of kinds.

Checks, from the built vehicles of every shipped airframe and from the source: every group
meets :class:`ActuatorGroup`; the groups come in kind order and step in step order (the
gimbals first); every kind's section is the ``UAVSpec`` field of its spec class; the
registry refuses a taken name or order; stages are chosen from the configuration; and no
method is replaced at run time anywhere in the library.
"""

from __future__ import annotations

import ast
import typing
from pathlib import Path

import numpy as np
import pytest

from pyflyt_engine.components.kinds import ActuatorGroup, component_kinds, register
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.spec import UAVSpec, available_uavs, load_uav_spec
from pyflyt_engine.vehicle import Vehicle
from pyflyt_engine.world import World
from tests.engine.vehicle_checks import NO_STAGES, shadowed_methods

ROOT = Path(__file__).resolve().parents[2]


def _protocol_members() -> set[str]:
    return {name for name in vars(ActuatorGroup) if not name.startswith("_")} | set(ActuatorGroup.__annotations__)


@pytest.mark.parametrize("name", available_uavs())
def test_every_group_of_every_shipped_airframe_meets_the_protocol_in_kind_order(name):
    world = World([dict(uav=name, position=(0.0, 0.0, 1.0))], seed=0)
    vehicle = world.vehicles[0]
    kinds = {kind.name: kind for kind in component_kinds()}
    present = [k for k in kinds if getattr(vehicle.actuators, k) is not None]
    assert tuple(getattr(vehicle.actuators, k) for k in present) == vehicle.groups == tuple(vehicle.actuators)
    assert [kinds[k].order for k in present] == sorted(kinds[k].order for k in present)
    for group in vehicle.groups:
        missing = {m for m in _protocol_members() if not hasattr(group, m)}
        assert not missing, f"{type(group).__name__} lacks {missing}"
    stepped = sorted((kinds[k].step_order, k) for k in present if kinds[k].step_order is not None)
    assert [step.__self__ for step in vehicle._steps] == [getattr(vehicle.actuators, k) for _, k in stepped]
    assert vehicle.needs_air == any(getattr(vehicle.actuators, k).needs_air for _, k in stepped)
    assert [route.__self__ for route in vehicle._routes] == [g for g in vehicle.groups if g.commanded]
    assert vehicle.stages == NO_STAGES and not shadowed_methods(vehicle)
    world.close()


def test_gimbals_step_first_and_the_loads_sum_in_the_order_of_the_reference():
    order = [
        kind.name
        for kind in sorted((k for k in component_kinds() if k.step_order is not None), key=lambda k: k.step_order)
    ]
    assert order[:5] == ["gimbals", "motors", "surfaces", "boosters", "drag"]


def test_every_kind_reads_the_spec_field_of_its_spec_class():
    for kind in component_kinds():
        field = UAVSpec.model_fields.get(kind.section)
        assert field is not None, f"kind '{kind.name}': UAVSpec has no field '{kind.section}'"
        assert kind.spec in _classes(field.annotation), (
            f"kind '{kind.name}': '{kind.section}' is not a {kind.spec.__name__}"
        )


def _classes(annotation) -> set:
    out = {annotation}
    for arg in typing.get_args(annotation):
        out |= _classes(arg)
    return out


def test_the_registry_refuses_a_taken_name_or_order():
    kinds = component_kinds()
    motors = next(k for k in kinds if k.name == "motors")
    with pytest.raises(ValueError, match="'motors' is registered twice"):
        register("motors", section="motors", spec=motors.spec, build=motors.build, order=999, step_order=None)
    with pytest.raises(ValueError, match="share an order"):
        register("winch", section="motors", spec=motors.spec, build=motors.build, order=motors.order, step_order=None)
    assert component_kinds() == kinds  # nothing was added


def test_stages_are_chosen_from_latency_and_sensors_and_dropped_again():
    world = World([dict(uav="quadx_cf2x", position=(0.0, 0.0, 1.0))], seed=0)
    vehicle = world.vehicles[0]
    vehicle.set_latency(3, 2)
    assert vehicle.stages == {
        "before_control": ("deliver_setpoints",),
        "before_loads": ("record_observation", "count_step"),
    }
    vehicle.set_latency(0, 0)
    assert vehicle.stages == NO_STAGES
    world.close()
    sensed = load_uav_spec(ROOT / "conf" / "uav" / "examples" / "quadx_cf2x_sensors.yaml")
    world = World([dict(uav=sensed, position=(0.0, 0.0, 1.0))], seed=0)
    vehicle = world.vehicles[0]
    assert vehicle.stages == {**NO_STAGES, "before_loads": ("sample_sensors",)}
    vehicle.set_latency(1, 1)  # the observed state is recorded before the sensors sample
    assert vehicle.stages["before_loads"] == ("record_observation", "sample_sensors", "count_step")
    assert not shadowed_methods(vehicle)
    world.step()
    assert np.isfinite(vehicle.sensors.values()).all()
    world.close()


def _method_names() -> set[str]:
    return {name for name, value in vars(Vehicle).items() if callable(value) and not name.startswith("__")}


def test_no_method_is_replaced_at_run_time_in_the_library():
    """No suppression of mypy's error for assigning to a method anywhere, and no assignment to an
    attribute named like one of the vehicle's methods (``vehicle.control_step = ...``) in
    the engine or the CLI."""
    methods = _method_names()
    suppression = "method" + "-assign"  # spelt apart, so that this file does not hold it
    wrong = []
    for package in ("pyflyt_engine", "pyflyt_cli"):
        for path in sorted((ROOT / package).rglob("*.py")):
            text = path.read_text()
            where = path.relative_to(ROOT)
            if suppression in text:
                wrong.append(f"{where}: a {suppression} suppression")
            for node in ast.walk(ast.parse(text)):
                targets = (
                    node.targets
                    if isinstance(node, ast.Assign)
                    else [node.target]
                    if isinstance(node, ast.AnnAssign)
                    else []
                )
                for target in targets:
                    if isinstance(target, ast.Attribute) and target.attr in methods:
                        wrong.append(f"{where}:{node.lineno}: assigns .{target.attr}")
    assert not wrong, "methods replaced at run time:\n" + "\n".join(wrong)


def test_a_control_hold_runs_the_controller_on_one_tick_in_n_from_each_reset():
    world = World([dict(uav="quadx_cf2x", position=(0.0, 0.0, 1.0))], seed=0)
    vehicle = world.vehicles[0]
    calls = []
    law = vehicle.controller.law
    vehicle.controller.law = lambda *a: (calls.append(vehicle._control_ticks), law(*a))[1]
    vehicle.set_control_hold(3)
    for _ in range(7):
        vehicle.control_step()
    assert calls == [1, 4, 7]  # ticks 0, 3 and 6 (counted before each runs)
    vehicle.reset()
    vehicle.control_step()
    assert calls[-1] == 1 and not shadowed_methods(vehicle)
    with pytest.raises(ConfigError, match="whole number of control ticks >= 1, got 0"):
        vehicle.set_control_hold(0)
    world.close()
