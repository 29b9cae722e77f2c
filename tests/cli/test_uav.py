"""`pyflyt uav validate | show | schema`: airframe files checked, described and drawn.

Bad files must exit 2 with a message naming what to fix and never a traceback; `show`
must print numbers that agree with hand calculations; pictures must be real images.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image
from typer.testing import CliRunner

from pyflyt_cli.airframes import thrust_to_weight
from pyflyt_cli.airframes.schema import BEGIN_MARKER, embedded_schema, schema_markdown
from pyflyt_cli.main import app
from pyflyt_engine.envs.config import env_config_data
from pyflyt_engine.spec import available_uavs, load_uav_spec, parse_uav_spec
from tests.conftest import spec_dict

runner = CliRunner()
DOCS = Path(__file__).resolve().parents[2] / "docs"

# A small fixed-wing and a small rocket: every component kind the tables print.
PLANE = {
    "name": "test_plane",
    "body": {
        "shapes": [
            {"type": "box", "size": [0.8, 0.08, 0.08], "mass": 0.6},
            {"type": "box", "size": [0.2, 1.0, 0.01], "position": [0.05, 0, 0.04], "mass": 0.3, "collision": False},
        ]
    },
    "channels": {"roll": [-1, 1], "pitch": [-1, 1], "yaw": [-1, 1], "thrust": [0, 1]},
    "motors": {"positions": [[0.4, 0, 0]], "thrust_axes": [[1, 0, 0]], "spin": [1], "tau": 0.02,
               "max_rpm": 10000, "kf": 5.0e-8, "kt": 1.0e-9, "mix": [{"thrust": 1.0}]},
    "surfaces": [
        {"name": "left_wing", "position": [0.05, 0.25, 0.04], "chord": 0.2, "span": 0.5, "flap_to_chord": 0.3,
         "max_deflection_deg": 25, "mix": {"roll": 1.0}},
        {"name": "right_wing", "position": [0.05, -0.25, 0.04], "chord": 0.2, "span": 0.5, "flap_to_chord": 0.3,
         "max_deflection_deg": 25, "mix": {"roll": -1.0}},
        {"name": "elevator", "position": [-0.35, 0, 0], "chord": 0.1, "span": 0.3, "flap_to_chord": 0.5,
         "max_deflection_deg": 20, "mix": {"pitch": 1.0}},
        {"name": "rudder", "position": [-0.35, 0, 0.08], "normal_axis": [0, -1, 0], "chord": 0.1, "span": 0.15,
         "flap_to_chord": 0.5, "max_deflection_deg": 20, "mix": {"yaw": 1.0}},
    ],
    "cameras": [{"name": "nose", "position": [0.4, 0, 0], "orientation_deg": [0, 10, 0]}],
    "control": {"type": "fixedwing", "mode": "attitude_airspeed"},
}  # fmt: skip
ROCKET = {
    "name": "test_rocket",
    "body": {"mass": 5.0, "inertia": [2.0, 2.0, 0.05],
             "shapes": [{"type": "cylinder", "radius": 0.1, "length": 2.0, "position": [0, 0, 1.0]}]},
    "channels": {"ignition": [0, 1], "throttle": [0, 1], "gimbal_a": [-1, 1], "gimbal_b": [-1, 1]},
    "boosters": {"positions": [[0, 0, 0]], "total_fuel": 10.0, "max_fuel_rate": 0.5, "min_thrust": 50.0,
                 "max_thrust": 250.0, "initial_fuel": 0.1},
    "gimbals": [{"name": "engine", "target": "booster:0", "axis_a": [1, 0, 0], "axis_b": [0, 1, 0],
                 "max_angle_a_deg": 5, "max_angle_b_deg": 5}],
}  # fmt: skip


def write_yaml(path: Path, data: object) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def invoke(*args: str):
    return runner.invoke(app, ["uav", *map(str, args)])


# ------------------------------------------------------------------ validate


@pytest.mark.parametrize("name", available_uavs())
def test_validate_every_shipped_airframe(name):
    result = invoke("validate", name)
    assert result.exit_code == 0, result.output
    spec = load_uav_spec(name)
    assert re.search(rf"^ok: .*{name}\.yaml: {name} \({spec.total_mass():.4g} kg, ", result.output, re.M)


def test_validate_all_shipped_files_at_once():
    from pyflyt_engine.paths import uav_dir

    files = sorted(uav_dir().glob("*.yaml"))
    result = invoke("validate", *files)
    assert result.exit_code == 0, result.output
    assert result.output.count("ok: ") == len(files)
    assert f"{len(files)} of {len(files)} files valid" in result.output


def _cf2x_with(**changes):
    data = spec_dict("quadx_cf2x")
    for path, value in changes.items():
        node = data
        *parents, leaf = path.split(".")
        for key in parents:
            node = node[key]
        if value is _DELETE:
            del node[leaf]
        else:
            node[leaf] = value
    return yaml.safe_dump(data, sort_keys=False)


_DELETE = object()


def _renamed(old: str, new: str) -> str:
    data = spec_dict("quadx_cf2x")
    data["body"][new] = data["body"].pop(old)
    return yaml.safe_dump(data, sort_keys=False)


BAD_FILES = {
    "unknown_key": (_renamed("mass", "mas"), ["body.mas", "unknown key 'mas'", "Did you mean 'mass'"]),
    "negative_mass": (_cf2x_with(**{"body.mass": -0.5}), ["body.mass", "positive number of kilograms", "-0.5"]),
    "motor_lists": (_cf2x_with(**{"motors.spin": [1, -1, 1]}), ["'spin' has 3 entries but 'positions' has 4"]),
    "malformed": ("name: x\nbody: {mass: 1\n", ["not valid YAML", "line"]),
    "empty": ("", ["the file is empty"]),
    "list": ("- name: x\n- body: {}\n", ["must be a mapping", "got list"]),
    "scalar": ("just some words\n", ["must be a mapping", "got str"]),
    "binary": (b"\x89\xfe\xff\x00garbage\x80\x81" * 40, ["cannot read the file"]),
    "uncontrollable": (_cf2x_with(**{"motors.spin": [1, 1, 1, 1]}), ["rank 3 < 4"]),
    "booster_range": (
        yaml.safe_dump({**ROCKET, "boosters": {**ROCKET["boosters"], "min_thrust": 300.0}}),
        ["min_thrust"],
    ),
    "surface_axes": (
        yaml.safe_dump({**PLANE, "surfaces": [{**PLANE["surfaces"][0], "normal_axis": [1, 0, 0]}]}),
        ["surfaces.0", "perpendicular"],
    ),
    "path_as_name": (_cf2x_with(name="../../evil"), ["name: must be a plain identifier, got '../../evil'"]),
    "infinite_mass": (_cf2x_with(**{"body.mass": float("inf")}), ["body.mass", "finite number", "got inf"]),
    "nan_drag": (_cf2x_with(**{"drag.coefficients": [float("nan"), 1.0, 1.0]}), ["drag.coefficients.0", "got nan"]),
    "nan_gain": (_cf2x_with(**{"control.rate.ki": [1.0, float("nan"), 1.0]}), ["control.rate.ki.1", "finite"]),
    "infinite_rpm": (_cf2x_with(**{"motors.max_rpm": float("inf")}), ["motors.max_rpm", "finite number, got inf"]),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_validate_bad_file_exits_2_with_the_fix(tmp_path, case):
    content, fragments = BAD_FILES[case]
    path = tmp_path / f"{case}.yaml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    result = invoke("validate", path)
    assert result.exit_code == 2, result.output
    assert str(path) in result.output
    for fragment in fragments:
        assert fragment in result.output, result.output
    assert "Traceback" not in result.output
    assert "ok:" not in result.output


@pytest.mark.parametrize(
    "target, fragments",
    [
        ("missing.yaml", ["missing.yaml", "no such UAV file"]),
        ("quadx_cf2", ["unknown UAV 'quadx_cf2'", "Did you mean 'quadx_cf2x'"]),
        (".", ["is a directory"]),
    ],
)
def test_validate_missing_file_unknown_name_and_directory(tmp_path, monkeypatch, target, fragments):
    monkeypatch.chdir(tmp_path)
    result = invoke("validate", target)
    assert result.exit_code == 2, result.output
    for fragment in fragments:
        assert fragment in result.output
    assert "Traceback" not in result.output


def test_validate_writes_nothing_outside_the_urdf_cache(tmp_path, monkeypatch):
    """An airframe's name never becomes a path: a generated URDF is named by its digest
    and lands in the cache only; a name holding a path is refused before anything is built."""
    cache = tmp_path / "cache" / "deep" / "er"
    monkeypatch.setenv("PYFLYT_CACHE_DIR", str(cache))
    monkeypatch.setattr("pyflyt_engine.urdf._private_dir", None, raising=False)
    specs = tmp_path / "specs"
    specs.mkdir()
    good = specs / "good.yaml"
    good.write_text(_cf2x_with(name="my_quad"))
    evil = specs / "evil.yaml"
    evil.write_text(_cf2x_with(name="../../evil"))

    result = invoke("validate", good, evil)
    assert result.exit_code == 2, result.output
    assert f"ok: {good}" in result.output and "must be a plain identifier, got '../../evil'" in result.output
    written = sorted(p for p in tmp_path.rglob("*") if p.is_file() and p.parent != specs)
    assert [p.parent for p in written] == [cache], written  # one URDF, in the cache
    assert re.fullmatch(r"[0-9a-f]{32}\.urdf", written[0].name)  # named by its digest, not by 'name'


def test_validate_never_runs_yaml_python_tags(tmp_path):
    marker = tmp_path / "pwned"
    path = tmp_path / "evil.yaml"
    path.write_text(f'name: !!python/object/apply:os.system ["touch {marker}"]\nbody: {{mass: 1}}\n')
    result = invoke("validate", path)
    assert result.exit_code == 2, result.output
    assert "not valid YAML" in result.output
    assert not marker.exists()


def test_validate_builds_the_vehicle_and_reports_build_errors(monkeypatch):
    """Errors raised only while building (mixer, components, PyBullet) exit 2 cleanly."""
    from pyflyt_engine.errors import ConfigError
    from pyflyt_engine.world import World

    built = []
    original = World.add_vehicle

    def spy(self, uav, *args, **kwargs):
        built.append(uav.name)
        return original(self, uav, *args, **kwargs)

    monkeypatch.setattr(World, "add_vehicle", spy)
    assert invoke("validate", "quadx_f450").exit_code == 0
    assert built == ["quadx_f450"]

    for error, fragment in (
        (ConfigError("allocation matrix has rank 2"), "quadx_f450.yaml: cannot build the vehicle: allocation matrix"),
        (ValueError("stall angles leave +-90 deg"), "cannot build the vehicle: stall angles"),
        (RuntimeError("a bug"), "internal error while checking it (RuntimeError: a bug)"),
    ):

        def fail(self, *args, error=error, **kwargs):
            raise error

        monkeypatch.setattr(World, "add_vehicle", fail)
        result = invoke("validate", "quadx_f450")
        assert result.exit_code == 2, result.output
        assert fragment in result.output
        assert "Traceback" not in result.output


def test_validate_warns_about_a_multirotor_that_cannot_hover(tmp_path):
    path = tmp_path / "weak.yaml"
    path.write_text(_cf2x_with(**{"motors.max_rpm": 10000.0}))  # 4 * 3.16e-10 * 1e8 N = 0.48 x 0.027 kg g
    result = invoke("validate", path)
    assert result.exit_code == 0, result.output
    assert "T/W 0.48" in result.output
    assert "warning: the multirotor motors lift only 0.48 x the weight: it cannot hover" in result.output


def test_validate_reports_every_file_then_exits_2(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("- not a mapping\n")
    good = write_yaml(tmp_path / "plane.yaml", PLANE)
    result = invoke("validate", bad, "quadx_f450", good)
    assert result.exit_code == 2
    assert "ok: " in result.output and "quadx_f450 (1 kg, 4 motors" in result.output
    assert f"ok: {good}: test_plane (0.9 kg, 1 motor, 4 surfaces, 1 camera, fixedwing control" in result.output
    assert "2 of 3 files valid" in result.output


# ------------------------------------------------------------------ show: numbers


def test_thrust_to_weight_matches_hand_calculation():
    for name in ("quadx_cf2x", "quadx_f450"):
        spec = load_uav_spec(name)
        m = spec.motors
        hand = 4 * m.kf * m.max_rpm**2 / (spec.body.mass * 9.81)
        ratios = thrust_to_weight(spec)
        assert ratios["mixer motors"] == pytest.approx(hand, rel=1e-12)
        assert ratios["all motors"] == pytest.approx(hand, rel=1e-12)
    rocket = parse_uav_spec(ROCKET)
    assert thrust_to_weight(rocket) == {"boosters": pytest.approx(250.0 / ((5.0 + 1.0) * 9.81))}


def test_show_cf2x_prints_mass_inertia_and_thrust_to_weight():
    result = invoke("show", "quadx_cf2x")
    assert result.exit_code == 0, result.output
    out = result.output
    assert re.search(r"dry mass\s+0\.027 kg", out)
    assert re.search(r"mixer motors, along body \+z\s+8\.00", out)
    assert re.search(r"all motors, full thrust\s+8\.00", out)
    assert "principal moments   1.4e-05, 1.4e-05, 2.17e-05 kg m^2" in out
    assert re.search(r"0\s+\(0\.028, -0\.028, 0\)\s+\(0, 0, 1\)\s+CCW \(\+1\)\s+0\.5297\s+mixer", out)
    assert "controller: multirotor, default mode rates_thrust" in out
    assert "picture" not in out


def test_show_components_of_every_kind_and_fuel(tmp_path):
    plane = write_yaml(tmp_path / "plane.yaml", PLANE)
    out = invoke("show", plane).output
    assert "dry mass            0.9 kg  (from the parts)" in out
    # centre of mass from the parts: (0.6 * 0 + 0.3 * 0.05) / 0.9 in x, (0.3 * 0.04) / 0.9 in z
    assert "centre of mass      (0.01667, 0, 0.01333) m" in out
    assert "all motors, full thrust       0.57  (5 N)" in out  # 5e-8 * 1e4^2 = 5 N on 0.9 kg
    assert re.search(r"rudder\s+\(-0\.35, 0, 0\.08\)\s+0\.1 x 0\.15\s+0\.015\s+\+-20\s+yaw\+1", out)
    assert re.search(r"nose\s+\(0\.4, 0, 0\)\s+\(0, 10, 0\)\s+90\s+128x128", out)
    assert re.search(r"roll\s+\[-1, 1\]\s+used by surface left_wing, surface right_wing, autopilot roll", out)
    assert "controller: fixedwing, default mode attitude_airspeed" in out

    rocket = write_yaml(tmp_path / "rocket.yaml", ROCKET)
    out = invoke("show", rocket).output
    assert "with full fuel      15 kg  (fuel 10 kg)" in out
    assert "at spawn            6 kg  (initial_fuel 0.1 -> 1 kg)" in out
    assert "boosters, max thrust          4.25  (250 N; 5.10 dry, 1.70 with full fuel)" in out
    assert re.search(r"engine\s+booster:0\s+\(1, 0, 0\)\s+\(0, 1, 0\)\s+\+-5 / \+-5\s+gimbal_a / gimbal_b", out)
    assert "controller: none, default mode channels" in out


# ------------------------------------------------------------------ show: pictures


def _background_fraction(image: np.ndarray) -> float:
    """Fraction of pixels equal to the top-left corner colour (the empty background)."""
    return float(np.mean(np.all(image == image[0, 0], axis=-1)))


@pytest.mark.parametrize("name", ["quadx_cf2x", "plane"])
def test_show_png_is_a_real_picture_of_the_requested_size(tmp_path, name):
    target = write_yaml(tmp_path / "plane.yaml", PLANE) if name == "plane" else name
    out = tmp_path / "pic.png"
    result = invoke("show", target, "--png", out, "--size", "320x240")
    assert result.exit_code == 0, result.output
    assert f"picture: {out} (320x240" in result.output
    with Image.open(out) as image:
        assert image.format == "PNG"
        assert image.size == (320, 240)
        pixels = np.asarray(image.convert("RGB"))
    assert pixels.std() > 0
    airframe = 1.0 - _background_fraction(pixels)
    assert 0.03 < airframe < 0.9, airframe  # something is drawn, and it fits in the frame
    # the framing is centred: the airframe touches neither the left nor the right edge
    drawn = np.any(np.any(pixels != pixels[0, 0], axis=-1), axis=0)
    assert not drawn[0] and not drawn[-1]


def test_show_curves_plots_every_surface(tmp_path):
    heights = []
    for surfaces in (PLANE["surfaces"][:1], PLANE["surfaces"]):
        spec = {**PLANE, "surfaces": surfaces, "name": f"plane_{len(surfaces)}"}
        plane = write_yaml(tmp_path / f"plane_{len(surfaces)}.yaml", spec)
        curves = tmp_path / f"curves_{len(surfaces)}.png"
        result = invoke("show", plane, "--curves", curves)
        assert result.exit_code == 0, result.output
        assert f"coefficient curves: {curves}" in result.output
        with Image.open(curves) as image:
            assert image.format == "PNG"
            heights.append(image.size[1])
            assert np.asarray(image.convert("L")).std() > 0
    assert heights[1] > 3 * heights[0] * 0.8  # one row of plots per surface


def test_show_refuses_to_overwrite_non_png_files_and_inputs(tmp_path):
    plane = write_yaml(tmp_path / "plane.yaml", PLANE)
    original = plane.read_text()
    notes = tmp_path / "notes.png"
    notes.write_text("my notes, not an image")

    cases = [
        (["--png", notes], "is not a PNG image; refusing to overwrite it"),
        (["--curves", notes], "is not a PNG image; refusing to overwrite it"),
        (["--png", plane], "ending in .png"),
        (["--png", tmp_path / "pic.jpg"], "ending in .png"),
        (["--png", tmp_path / "no_dir" / "pic.png"], "does not exist"),
        (["--png", tmp_path / "same.png", "--curves", tmp_path / "same.png"], "the same file"),
        (["--png", tmp_path / "pic.png", "--size", "640by480"], "WIDTHxHEIGHT"),
        (["--png", tmp_path / "pic.png", "--size", "10x10"], "between 16 and 4096"),
    ]
    for extra, message in cases:
        result = invoke("show", plane, *extra)
        assert result.exit_code == 2, (extra, result.output)
        assert message in result.output, (extra, result.output)
        assert "Traceback" not in result.output
    assert plane.read_text() == original
    assert notes.read_text() == "my notes, not an image"
    assert not (tmp_path / "pic.jpg").exists() and not (tmp_path / "same.png").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.png", "plane.yaml"]  # no temporary files left


def test_show_overwrites_an_existing_png(tmp_path):
    out = tmp_path / "pic.png"
    Image.new("RGB", (20, 20), "black").save(out)
    result = invoke("show", "quadx_f450", "--png", out, "--size", "64x48")
    assert result.exit_code == 0, result.output
    with Image.open(out) as image:
        assert image.size == (64, 48)


def test_show_curves_without_surfaces_and_bad_file_exit_2(tmp_path):
    result = invoke("show", "quadx_cf2x", "--curves", tmp_path / "c.png")
    assert result.exit_code == 2
    assert "has no lifting surfaces" in result.output
    assert not (tmp_path / "c.png").exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text(_renamed("mass", "mas"))
    result = invoke("show", bad)
    assert result.exit_code == 2 and "Did you mean 'mass'" in result.output
    assert "Traceback" not in result.output


# ------------------------------------------------------------------ docs in sync


def test_schema_command_prints_every_section():
    result = invoke("schema")
    assert result.exit_code == 0
    assert result.output == schema_markdown()
    for section in ("`body`", "`body.shapes[]`", "`motors`", "`surfaces[]`", "`boosters`", "`gimbals[]`",
                    "`cameras[]`", "`control` with `type: multirotor`", "`control.rate`"):  # fmt: skip
        assert f"#### {section}" in result.output


def test_authoring_guide_embeds_the_current_schema():
    text = (DOCS / "uav_authoring.md").read_text()
    assert BEGIN_MARKER in text
    assert embedded_schema(text) == schema_markdown(), (
        "docs/uav_authoring.md is out of date with pyflyt_engine/spec.py; regenerate it with\n"
        "  python -m pyflyt_cli.commands.uav_schema docs/uav_authoring.md"
    )


def _doc_examples() -> dict[str, str]:
    """YAML blocks of the authoring guide announced by ``<!-- example: NAME -->``."""
    text = (DOCS / "uav_authoring.md").read_text()
    return dict(re.findall(r"<!-- example: (\S+) -->\s*```yaml\n(.*?)```", text, re.S))


def test_authoring_guide_examples_validate_and_show_as_printed(tmp_path, monkeypatch):
    examples = _doc_examples()
    assert {"hexacopter_250.yaml", "wing_mixing.yaml"} <= set(examples)
    monkeypatch.chdir(tmp_path)
    for name, text in examples.items():
        (tmp_path / name).write_text(text)
        result = invoke("validate", name)
        assert result.exit_code == 0, (name, result.output)
    # the `pyflyt uav show` transcript in the guide is what the command prints today
    guide = (DOCS / "uav_authoring.md").read_text()
    transcript = r"<!-- show-output -->\s*```text\n\$ pyflyt uav show hexacopter_250.yaml\n(.*?)```"
    printed = re.search(transcript, guide, re.S)
    assert printed, "the guide lost its show transcript"
    actual = invoke("show", "hexacopter_250.yaml").output
    assert printed.group(1) == actual


FIXED_WINGS = ["docs: wing_mixing.yaml"] + [
    name for name in available_uavs() if load_uav_spec(name).control.type == "fixedwing"
]


@pytest.mark.parametrize("airframe", FIXED_WINGS)
def test_fixed_wing_mixing_follows_the_documented_sign_convention(airframe):
    """Positive roll / pitch / yaw channels give positive torque about body x / y / z
    (right wing down, nose down, nose left): the guide's example and every shipped fixed-wing."""
    from pyflyt_engine.assembly import assemble
    from pyflyt_engine.components.lifting_surface import surface_wrench

    if airframe.startswith("docs: "):
        spec = parse_uav_spec(yaml.safe_load(_doc_examples()[airframe.removeprefix("docs: ")]))
    else:
        spec = load_uav_spec(airframe)
    control = spec.control
    parts = assemble(spec)
    airspeed = (15.0, 0.0, 0.0)
    for channel, axis in ((control.roll_channel, 0), (control.pitch_channel, 1), (control.yaw_channel, 2)):
        j = parts.channels.index(channel)
        torque = np.zeros(3)
        for surface, weights in zip(parts.surfaces, parts.surface_mix):
            deflection = float(np.clip(weights[j], -1, 1)) * surface.max_deflection
            torque += surface_wrench(surface.constants, deflection, *airspeed, 0.0, 0.0, 0.0)[3:]
            torque -= surface_wrench(surface.constants, 0.0, *airspeed, 0.0, 0.0, 0.0)[3:]
        assert torque[axis] > 0, (channel, torque)
        others = max(abs(torque[k]) for k in range(3) if k != axis)
        assert torque[axis] > others or axis == 2, (channel, torque)  # a fin above the axis also rolls
    assert math.isfinite(float(torque.sum()))


# ------------------------------------------------------------------ show --env: an env's payloads


def test_show_env_prints_the_payloads_mass_inertia_and_joint():
    result = invoke("show", "--env", "quadx_pole_balance")
    assert result.exit_code == 0, result.output
    out = result.output
    assert out.startswith("quadx_f450:")  # the env's airframe when no FILE is given
    assert "payloads of env PyFlyt/QuadX-Pole-Balance-v0" in out
    assert "pole: ball joint (passive, frictionless) to the vehicle" in out
    assert "mass                0.2 kg  (from the parts)" in out
    assert "centre of mass      (0, 0, 0.5) m in the payload's frame" in out
    # uniform cylinder, m = 0.2 kg, r = 5 mm, l = 1 m: m (3 r^2 + l^2) / 12 across, m r^2 / 2 along
    across, along = 0.2 * (3 * 0.005**2 + 1.0) / 12, 0.2 * 0.005**2 / 2
    assert f"principal moments   {along:.4g}, {across:.4g}, {across:.4g} kg m^2" in out
    assert "attachment          at (0, 0, 0.05) m on the vehicle, (0, 0, 0) m on the payload" in out
    assert re.search(r"cylinder r 0\.005, length 1\s+\(0, 0, 0\.5\)\s+\(0, 0, 0\)\s+0\.2\s+yes\s+yes", out)
    assert "carried by quadx_f450: 0.2 kg of payloads; with them 1.2 kg" in out
    assert re.search(rf"mixer motors\s+{40.0 / (1.2 * 9.81):.2f}\n", out)  # 4 x 10 N on 1.2 kg


def test_show_env_tethers_world_payloads_and_another_airframe():
    out = invoke("show", "--env", "quadx_ball_in_cup").output
    assert "ball: tether (a string: never farther than its length, may go slack) to the vehicle" in out
    assert "string of 0.5 m from (0, 0, -0.03) m on the vehicle to (0, 0, 0) m on the payload" in out
    assert "with the vehicle: simulated" in out
    assert "carried by quadx_f450: 0.15 kg of payloads; with them 1.15 kg" in out
    result = invoke("show", "quadx_cf2x", "--env", "quadx_gates")
    assert result.exit_code == 0, result.output
    assert result.output.startswith("quadx_cf2x:")
    assert "gate_4: fixed (welded) to the world (a static body)" in result.output
    assert "(task gates, course: random: moved at every reset)" in result.output
    assert "carried by quadx_cf2x: none" in result.output
    assert "payloads: none (env PyFlyt/QuadX-Hover-v0" in invoke("show", "--env", "quadx_hover").output


def test_show_env_bad_input_exits_2_with_one_message(tmp_path):
    result = invoke("show", "--env", "quadx_pole_balanc")
    assert result.exit_code == 2
    assert "unknown env config 'quadx_pole_balanc'. Did you mean 'quadx_pole_balance'?" in result.output
    bad = env_config_data("quadx_pole_balance")  # the pole comes from its base, conf/env/_quadx_pole.yaml
    del bad["payloads"][0]["body"]["shapes"][0]["mass"]
    result = invoke("show", "--env", write_yaml(tmp_path / "no_mass.yaml", bad))
    assert result.exit_code == 2
    assert "payloads.0.body: body.mass and inertia missing" in result.output
    result = invoke("show")
    assert result.exit_code == 2 and "give an airframe" in result.output
    assert "Traceback" not in result.output


def test_show_env_png_draws_the_vehicle_payloads(tmp_path):
    magenta = (255, 0, 255)  # a colour nothing else in the picture has
    env = env_config_data("quadx_pole_balance")  # the pole comes from its base, conf/env/_quadx_pole.yaml
    env["payloads"][0]["body"]["shapes"][0].update(color=[1.0, 0.0, 1.0, 1.0], radius=0.02)
    env_file = write_yaml(tmp_path / "magenta_pole.yaml", env)
    pictures = {}
    for name, extra in (("bare", []), ("pole", ["--env", env_file])):
        out = tmp_path / f"{name}.png"
        result = invoke("show", "quadx_f450", "--png", out, "--size", "160x120", *extra)
        assert result.exit_code == 0, result.output
        with Image.open(out) as image:
            pictures[name] = np.asarray(image.convert("RGB")).astype(int)
    assert "payloads drawn at their reset poses: pole" in result.output

    def pole_pixels(image):
        return int(np.all(np.abs(image - magenta) < 40, axis=-1).sum())

    assert pole_pixels(pictures["pole"]) >= 10 and pole_pixels(pictures["bare"]) == 0
