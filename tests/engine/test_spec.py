"""Vehicle specs: shipped airframes load; bad specs fail with the field and the fix."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.spec import available_uavs, load_uav_spec, parse_uav_spec
from pyflyt_engine.errors import SpecError
from tests.conftest import spec_dict


def test_shipped_quadx_airframes_load_with_paper_figures():
    cf2x = load_uav_spec("quadx_cf2x")
    assert cf2x.body.mass == pytest.approx(0.027)
    thrust = 4 * cf2x.motors.kf * cf2x.motors.max_rpm**2
    # paper: modified to an 8:1 thrust-to-weight ratio
    assert thrust / (cf2x.body.mass * 9.81) == pytest.approx(8.0, rel=1e-3)
    f450 = load_uav_spec("quadx_f450")
    assert f450.body.mass == pytest.approx(1.0)
    assert 4 * f450.motors.kf * f450.motors.max_rpm**2 == pytest.approx(40.0, rel=1e-3)
    assert {"quadx_cf2x", "quadx_f450"} <= set(available_uavs())


def _error(data: dict) -> str:
    with pytest.raises(SpecError) as info:
        parse_uav_spec(data, source="bad.yaml")
    return str(info.value)


def test_negative_and_zero_mass_are_rejected_with_field_and_fix():
    for mass in (-0.1, 0.0):
        data = spec_dict()
        data["body"]["mass"] = mass
        message = _error(data)
        assert "bad.yaml" in message and "body.mass" in message and "positive number of kilograms" in message


def test_inertia_not_positive_definite_is_rejected():
    data = spec_dict()
    data["body"]["inertia"] = [1e-5, -1e-5, 2e-5]
    message = _error(data)
    assert "body.inertia" in message and "not positive definite" in message
    data["body"]["inertia"] = [1e-5, 1e-5, 2e-5, 5e-5, 0.0, 0.0]  # large product of inertia
    assert "not positive definite" in _error(data)


def test_inertia_violating_triangle_inequality_is_rejected():
    data = spec_dict()
    data["body"]["inertia"] = [1e-5, 1e-5, 5e-5]
    assert "triangle inequality" in _error(data)


def test_motor_lists_of_different_lengths_are_rejected():
    data = spec_dict()
    data["motors"]["spin"] = [1, 1, -1]
    message = _error(data)
    assert "motors" in message and "'spin' has 3 entries but 'positions' has 4" in message
    data = spec_dict()
    data["motors"]["tau"] = [0.01, 0.01]
    assert "'tau' has 2 entries" in _error(data)


def test_unknown_key_is_rejected_with_suggestion():
    data = spec_dict()
    data["body"]["mas"] = 1.0
    message = _error(data)
    assert "body.mas" in message and "unknown key" in message and "Did you mean 'mass'" in message
    data = spec_dict()
    data["motor"] = {}
    assert "unknown key 'motor'" in _error(data) and "Did you mean 'motors'" in _error(data)


def test_non_unit_thrust_axis_and_bad_types_are_rejected():
    data = spec_dict()
    data["motors"]["thrust_axes"] = [[0, 0, 1], [0, 0, 1], [0, 0, 1.01], [0, 0, 1]]
    message = _error(data)
    assert "motors.thrust_axes.2: 'thrust_axes' must be a unit vector, got [0.0, 0.0, 1.01] of length 1.01" in message
    assert "divide each component by the length" in message
    data = spec_dict()
    data["motors"]["kf"] = "lots"
    assert "motors.kf" in _error(data)


def test_multirotor_control_without_motors_is_rejected():
    data = spec_dict()
    del data["motors"]
    assert "needs a 'motors' section" in _error(data)


def test_yaml_tags_cannot_run_code(tmp_path):
    marker = tmp_path / "ran"
    path = tmp_path / "evil.yaml"
    path.write_text(
        f"name: !!python/object/apply:os.system ['touch {marker}']\nbody: {{mass: 1, inertia: [1, 1, 1]}}\n"
    )
    with pytest.raises(SpecError, match="not valid YAML"):
        load_uav_spec(path)
    assert not marker.exists()


def test_unknown_airframe_name_suggests_the_closest():
    with pytest.raises(SpecError, match="Did you mean 'quadx_cf2x'"):
        load_uav_spec("quadx_cf2")


def test_truncated_file_is_a_clear_error(tmp_path):
    path = tmp_path / "cut.yaml"
    path.write_text("name: cut\nbody:\n  mass: 1.0\n  inertia: [1, 1,")
    with pytest.raises(SpecError, match="not valid YAML"):
        load_uav_spec(path)


def test_unit_vectors_typed_to_four_decimals_are_normalised():
    """[0, 0.0872, 0.9962] (5 degrees, four decimals) has length 0.999984: accepted, stored at length 1."""
    data = spec_dict("quadx_f450")
    data["motors"]["thrust_axes"] = [[0.0, 0.0872, 0.9962]] * 4
    axes = np.asarray(parse_uav_spec(data).motors.thrust_axes)
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(axes[0], np.array([0.0, 0.0872, 0.9962]) / np.hypot(0.0872, 0.9962), rtol=1e-15)
    rocket = spec_dict("rocket")
    rocket["gimbals"][0]["axis_a"] = [0.7071, 0.7071, 0.0]
    axis = parse_uav_spec(rocket).gimbals[0].axis_a
    assert math.hypot(*axis) == pytest.approx(1.0, abs=1e-15)


def test_exact_unit_vectors_are_kept_as_given():
    """Within 1e-6 of length 1 a vector is used as written: shipped airframes fly unchanged."""
    data = spec_dict("flying_wing")
    given = [s.get("chord_axis") for s in data["surfaces"]]
    spec = parse_uav_spec(data)
    assert [list(s.chord_axis) for s, g in zip(spec.surfaces, given) if g] == [g for g in given if g]


def test_surface_axes_a_little_off_perpendicular_are_corrected_and_far_off_refused():
    data = spec_dict("flying_wing")
    data["surfaces"][0]["chord_axis"] = [0.9986, 0.0, -0.0524]
    data["surfaces"][0]["normal_axis"] = [0.0523, 0.0, 0.9986]  # dot 1.4e-4 after normalising
    surface = parse_uav_spec(data).surfaces[0]
    assert abs(np.dot(surface.chord_axis, surface.normal_axis)) < 1e-15
    assert math.hypot(*surface.normal_axis) == pytest.approx(1.0, abs=1e-15)
    data["surfaces"][0]["normal_axis"] = [0.1, 0.0, 0.995]
    message = _error(data)
    assert "surfaces.0.normal_axis: chord_axis and normal_axis must be perpendicular, got a dot product of" in message


def test_a_bare_name_is_the_shipped_airframe_even_if_the_working_directory_has_that_name(tmp_path, monkeypatch):
    """A run folder called "rocket" (or a stray file "quadx_cf2x") in the working directory does not
    shadow the shipped airframe; a bare name that is not shipped can still be a file there."""
    from pyflyt_engine.spec import resolve_uav_path, uav_dir

    monkeypatch.chdir(tmp_path)
    (tmp_path / "rocket").mkdir()
    (tmp_path / "quadx_cf2x").write_text("not a uav\n")
    assert resolve_uav_path("rocket") == uav_dir() / "rocket.yaml"
    assert resolve_uav_path("quadx_cf2x") == uav_dir() / "quadx_cf2x.yaml"
    (tmp_path / "my_frame").write_text("name: x\n")
    assert resolve_uav_path("my_frame").resolve() == (tmp_path / "my_frame").resolve()
    with pytest.raises(SpecError, match="no such UAV file"):
        resolve_uav_path("frames/missing")
