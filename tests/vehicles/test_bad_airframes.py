"""Broken airframe files fail at load with a SpecError naming the file, the field and the fix."""

from __future__ import annotations

import pytest
import yaml

from pyflyt_engine.errors import SpecError
from pyflyt_engine.spec import load_uav_spec, parse_uav_spec
from pyflyt_engine.world import World
from tests.conftest import spec_dict


def error_of(data: dict, source: str = "bad.yaml") -> str:
    with pytest.raises(SpecError) as info:
        parse_uav_spec(data, source=source)
    return str(info.value)


@pytest.mark.parametrize("field", ["chord", "span"])
def test_surface_with_zero_area_is_rejected(field):
    data = spec_dict("fixedwing")
    data["surfaces"][3][field] = 0.0  # horizontal tail
    message = error_of(data)
    assert "bad.yaml" in message and f"surfaces.3.{field}" in message
    assert f"{field} must be > 0 m, got 0.0" in message and "positive area (chord x span)" in message


def test_gimbal_axis_not_unit_length_is_rejected():
    data = spec_dict("rocket")
    data["gimbals"][0]["axis_b"] = [0.0, 2.0, 0.0]
    message = error_of(data)
    assert "gimbals.0.axis_b: 'axis_b' must be a unit vector, got [0.0, 2.0, 0.0] of length 2" in message


@pytest.mark.parametrize("field", ["width", "height"])
def test_camera_with_zero_resolution_is_rejected(field):
    data = spec_dict("quadx_cf2x")
    data["cameras"] = [{"name": "front", field: 0}]
    message = error_of(data)
    assert f"cameras.0.{field}" in message and f"camera {field} must be at least 1 pixel, got 0" in message


def uncontrollable(change) -> dict:
    data = spec_dict("quadx_cf2x")
    change(data["motors"])
    return data


@pytest.mark.parametrize(
    "change",
    [
        lambda m: m.update(spin=[1, 1, 1, 1]),  # every propeller the same way: no yaw torque
        lambda m: m.update(positions=[[x, 0.0, 0.0] for x in (0.028, -0.028, 0.05, -0.05)]),  # one line: no roll
        lambda m: m.update(thrust_axes=[[1.0, 0.0, 0.0]] * 4),  # all pushing forward: no lift
    ],
    ids=["same_spin", "motors_on_one_line", "no_vertical_thrust"],
)
def test_multirotor_whose_motors_cannot_control_it_fails_at_load(change):
    message = error_of(uncontrollable(change))
    assert "cannot control the vehicle" in message and "< 4" in message
    assert "motors.positions" in message and "motors.spin" in message  # where to look


def test_uncontrollable_multirotor_file_fails_before_any_physics(tmp_path):
    path = tmp_path / "flat_quad.yaml"
    path.write_text(yaml.safe_dump(uncontrollable(lambda m: m.update(spin=[-1, -1, -1, -1]))))
    with pytest.raises(SpecError, match="flat_quad.yaml.*\n.*cannot control the vehicle"):
        load_uav_spec(path)
    with pytest.raises(SpecError, match="cannot control the vehicle"):
        World([{"uav": str(path)}])


def test_controllability_only_counts_the_mixer_motors():
    """The quadplane's pusher is not in its mixer: taking a lift motor out breaks it."""
    data = spec_dict("quadplane")
    parse_uav_spec(data)  # four lift motors: fine
    data["control"]["mixer_motors"] = [0, 1, 2]
    assert "the multirotor motors [0, 1, 2] cannot control the vehicle" in error_of(data)


# ------------------------------------------------------------------ names from files


@pytest.mark.parametrize("name", ["../../evil", "/etc/evil", "a/b", "..", "evil.yaml", "two words", "", "x" * 65])
@pytest.mark.parametrize(
    "key, where",
    [
        ("name", lambda d: d),
        ("surfaces.0.name", lambda d: d["surfaces"][0]),
        ("gimbals.0.name", lambda d: d["gimbals"][0]),
        ("cameras.0.name", lambda d: d["cameras"][0]),
    ],
    ids=["airframe", "surface", "gimbal", "camera"],
)
def test_a_name_that_is_not_a_plain_identifier_is_rejected(name, key, where):
    """Names from a file can end up in file names: a path in one must never load."""
    data = spec_dict("fixedwing" if "surfaces" in key else "rocket" if "gimbals" in key else "quadx_cf2x")
    if key.startswith("cameras"):
        data["cameras"] = [{"name": "front"}]
    where(data)["name"] = name
    message = error_of(data)
    assert f"{key}: must be a plain identifier, got {name!r}" in message
    assert "letters, digits, '_' or '-'" in message


def test_plain_identifiers_are_accepted():
    for name in ("hexacopter_250", "My-Quad2", "_x"):
        data = spec_dict("quadx_cf2x")
        data["name"] = name
        data["cameras"] = [{"name": f"{name}_cam"}]
        assert parse_uav_spec(data).name == name


# ------------------------------------------------------------------ non-finite numbers


def _at(path: str, value):
    def change(data: dict) -> None:
        node = data
        *parents, leaf = path.split(".")
        for key in parents:
            node = node[int(key)] if key.isdigit() else node.setdefault(key, {})
        node[int(leaf) if leaf.isdigit() else leaf] = value

    return change


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    "airframe, path, value",
    [
        ("quadx_cf2x", "body.mass", INF),
        ("quadx_cf2x", "body.mass", NAN),
        ("quadx_cf2x", "body.inertia.0", NAN),
        ("quadx_cf2x", "drag.coefficients.1", NAN),
        ("quadx_cf2x", "drag.angular_damping", INF),
        ("quadx_cf2x", "motors.max_rpm", INF),
        ("quadx_cf2x", "motors.kf", NAN),
        ("quadx_cf2x", "motors.positions.2.0", NAN),
        ("quadx_cf2x", "control.rate.kp.0", NAN),
        ("quadx_cf2x", "control.velocity.max_tilt", NAN),
        ("fixedwing", "surfaces.0.cd_0", INF),
        ("fixedwing", "surfaces.1.mix.roll", NAN),
        ("fixedwing", "channels.roll.1", INF),
        ("fixedwing", "control.roll.kp", NAN),
        ("rocket", "boosters.max_thrust", INF),
        ("rocket", "boosters.total_fuel", NAN),
        ("rocket", "gimbals.0.tau", INF),
    ],
)
def test_non_finite_numbers_are_rejected_at_load_naming_the_key(airframe, path, value):
    data = spec_dict(airframe)
    _at(path, value)(data)
    message = error_of(data)
    assert "bad.yaml" in message and path in message, message
    assert "finite number" in message and "not .inf or .nan" in message, message


def test_a_per_motor_list_with_one_non_finite_entry_is_rejected_once():
    data = spec_dict("quadx_cf2x")
    data["motors"]["max_rpm"] = [20000.0, 20000.0, INF, 20000.0]
    message = error_of(data)
    assert "motors.max_rpm: must be a finite number, got [20000.0, 20000.0, inf, 20000.0]" in message
    assert message.count("max_rpm") == 1, message  # one line, not one per alternative of the union
