"""Propeller guards (``prop_guards``): the ring drag law, its place in the vehicle, its refusals.

Oracles: the law written out by hand for flows where it reduces to one term (across the
disc, along the axis, a pure yaw rate), and a disarmed vehicle sliding sideways, which
guards must slow more than the same airframe without them.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from pyflyt_engine.components.prop_guard import PropGuardParams, PropGuards, guard_factor
from pyflyt_engine.constants import AIR_DENSITY
from pyflyt_engine.errors import SpecError
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import World
from tests.conftest import spec_dict

GUARDS = {"radius": 0.03, "height": 0.01}


def _one_guard(position=(0.1, 0.0, 0.05), axis=(0.0, 0.0, 1.0)) -> tuple[PropGuards, float]:
    k = guard_factor(0.03, 0.01, 1.2)
    return PropGuards(PropGuardParams(positions=(position,), axes=(axis,), factor=k)), k


def test_the_factor_is_half_rho_cd_times_the_projected_area():
    assert guard_factor(0.03, 0.01, 1.2) == pytest.approx(0.5 * AIR_DENSITY * 1.2 * (2 * 0.03 * 0.01), rel=1e-15)


def test_air_across_the_disc_drags_at_the_hub():
    guards, k = _one_guard()
    fx, fy, fz, tx, ty, tz = guards.step(((4.0, 0.0, 0.0), (0.0, 0.0, 0.0)), None)
    drag = -k * 4.0 * 4.0
    assert (fx, fy, fz) == pytest.approx((drag, 0.0, 0.0), rel=1e-12, abs=1e-15)
    # T = p x F with p = (0.1, 0, 0.05): only the pitch term, z_p * F_x
    assert (tx, ty, tz) == pytest.approx((0.0, 0.05 * drag, 0.0), rel=1e-12, abs=1e-15)


def test_air_along_the_axis_meets_no_guard_and_an_oblique_flow_only_its_crossing_part():
    guards, k = _one_guard()
    assert guards.step(((0.0, 0.0, 7.0), (0.0, 0.0, 0.0)), None) == pytest.approx((0.0,) * 6, abs=1e-15)
    fx, fy, fz, *_ = guards.step(((3.0, 0.0, 7.0), (0.0, 0.0, 0.0)), None)
    assert (fx, fy, fz) == pytest.approx((-k * 9.0, 0.0, 0.0), rel=1e-12, abs=1e-15)


def test_a_yaw_rate_is_damped_through_the_hub_velocity():
    guards, k = _one_guard(position=(0.1, 0.0, 0.0))
    r = 20.0  # rad/s: the hub moves at r * 0.1 = 2 m/s along +y
    fx, fy, fz, tx, ty, tz = guards.step(((0.0, 0.0, 0.0), (0.0, 0.0, r)), None)
    assert fy == pytest.approx(-k * 2.0 * 2.0, rel=1e-12)
    assert tz == pytest.approx(0.1 * fy, rel=1e-12) and tz < 0.0  # opposes the rotation
    assert (fx, fz, tx, ty) == pytest.approx((0.0,) * 4, abs=1e-15)


def _world_from_yaml(tmp_path, guards: dict | None, drag: bool = True) -> World:
    data = spec_dict("quadx_cf2x")
    if guards is not None:
        data["prop_guards"] = guards
    path = tmp_path / ("guarded.yaml" if guards else "plain.yaml")
    path.write_text(yaml.safe_dump(data))
    return World([dict(uav=load_uav_spec(path), position=(0.0, 0.0, 20.0))], seed=0, drag=drag)


def _slide(world: World, steps: int = 30) -> float:
    """Disarmed, thrown sideways at 6 m/s: the sideways speed left after ``steps`` agent steps."""
    vehicle = world.vehicles[0]
    world.reset(seed=0)
    world.set_armed(0, False)
    vehicle.reset(position=(0.0, 0.0, 20.0), lin_vel=(0.0, 6.0, 0.0))
    for _ in range(steps):
        world.step()
    return float(vehicle.state.lin_vel_ground[1])


def test_declared_in_a_yaml_file_the_guards_join_the_vehicle_and_slow_a_sideways_slide(tmp_path):
    guarded, plain = _world_from_yaml(tmp_path, GUARDS), _world_from_yaml(tmp_path, None)
    vehicle = guarded.vehicles[0]
    assert isinstance(vehicle.actuators.prop_guards, PropGuards) and vehicle.actuators.prop_guards in vehicle.groups
    assert plain.vehicles[0].actuators.prop_guards is None
    assert len(vehicle.aux_state) == len(plain.vehicles[0].aux_state) == 4  # no read-outs of their own
    slowed, free = _slide(guarded), _slide(plain)
    assert 0.0 < slowed < free < 6.0
    guarded.close()
    plain.close()


def test_the_drag_switch_leaves_the_guards_out(tmp_path):
    world = _world_from_yaml(tmp_path, GUARDS, drag=False)
    assert world.vehicles[0].actuators.prop_guards is None
    world.close()


def test_guards_on_some_motors_only(tmp_path):
    world = _world_from_yaml(tmp_path, {**GUARDS, "motors": [0, 2]})
    params = world.vehicles[0].actuators.prop_guards.params
    motors = world.vehicles[0].motors
    assert np.array_equal(np.array(params.positions), motors.positions[[0, 2]])
    world.close()


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"motors": [4]}, r"prop_guards\.motors: no motor 4 \(there are 4: 0 to 3\)"),
        ({"radius": 0.0}, r"prop_guards\.radius"),
        ({"hieght": 0.01}, r"hieght"),
    ],
)
def test_a_wrong_section_is_refused_at_load_naming_the_key(tmp_path, changes, message):
    data = spec_dict("quadx_cf2x")
    data["prop_guards"] = {**GUARDS, **changes}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(SpecError, match=message):
        load_uav_spec(path)


def test_guards_without_motors_are_refused(tmp_path):
    data = spec_dict("rocket")
    assert "motors" not in data
    data["prop_guards"] = GUARDS
    path = tmp_path / "rocket_guards.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(SpecError, match="prop_guards: they ring rotors"):
        load_uav_spec(path)


def test_without_the_section_the_spec_dumps_as_before():
    assert "prop_guards" not in load_uav_spec("quadx_cf2x").model_dump(mode="json")
