"""The batched backend flies the multirotors whose actuators the channels route beside the mixer:
the tricopter (its tail motor on a servo the mixer flies: conf/uav/tricopter.yaml) and the
quadplane (a VTOL: four lift motors the mixer flies, a pusher and five lifting surfaces on the
setpoint's channels: conf/uav/quadplane.yaml), and a quad with a two-axis gimbal on its
channels (a variant below).

Each new compiled law is held to the engine's scalar law bit for bit on random inputs: the
gimbals' servo step and the motor column they turn (``Gimbals.step``, ``Motors.turn``), the
routing of the channels and the mixer's outputs to motors, gimbals and flaps (``Motors.route``,
``Gimbals.route``, ``Surfaces.route``); the tilted mixer and the trim are held with the rest of
the controller in ``test_laws.py`` and ``test_modes.py`` (every mode, these airframes among
them), the lifting surfaces in ``test_laws.py`` (the quadplane's among them).

Then both backends fly each airframe in every multirotor flight mode it has (2 s of random
setpoints, calm air, motor noise off; QuadX-Waypoints from one start) and are held to the
cross-checks' bound of ``test_crosscheck.py``, 1e-6 on positions, observations and rewards,
derived for these airframes the same way: every law is bit for bit the engine's, so the two
differ by the rigid body's last bits (~eps |x| per step) and by what the laws amplify of them.
The mixer's square root amplifies a force difference of ~eps f_max near zero thrust to
~sqrt(eps) ~ 1.5e-8 in a throttle, which moves the position by at most ~3e-7 m over 2 s
(``test_crosscheck.py``'s derivation, f_max / m <= ~5 m/s^2 per motor: the tricopter's 10 N
motors on 1.07 kg give 9.3 m/s^2, so 6e-7 m, still within 1e-6).  The tilted mixer's servo
angle ``atan2(lateral, f)`` and its ``f / cos(angle)`` are smooth where the motor pushes
(``f > 0``), its limit a clip (continuous); the gimbal's servo is a linear lag and its
rotation smooth, so they carry a difference over without growth beyond the flight's own.  The
quadplane's surfaces are the fixed-wing's law (``test_crosscheck.py``: only an angle of attack
within the last bits of a stall angle flips the profile's branch, probability ~1e-10 per
surface and step).  Measured over these flights (``python experiments/batched_modes_crosscheck.py --routed``
prints them per airframe and mode): see docs/batched.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from pyflyt_engine.assembly import assemble
from pyflyt_engine.batched import BatchedUAVEnv, kernels
from pyflyt_engine.batched.model import UnsupportedByBatched, batched_model
from pyflyt_engine.components.gimbal import Gimbals
from pyflyt_engine.components.lifting_surface import Surfaces
from pyflyt_engine.components.motor import Motors
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.components.routing import mix_rows
from pyflyt_engine.control.mixer import flight_mixer
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import parse_uav_spec

from tests.batched.test_crosscheck import BOUND, _flat, _pair
from tests.batched.test_laws import CONTROL_DT, DT, ROUTED

#: a quad with a two-axis gimbal on its front-right motor, driven by two channels of its own
GIMBAL_QUAD = "quadx_gimbal"


def _data(name: str) -> dict:
    if name == GIMBAL_QUAD:
        data = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
        data["name"] = GIMBAL_QUAD
        data["channels"] = {"tilt_a": [-1.0, 1.0], "tilt_b": [-1.0, 1.0]}
        data["gimbals"] = [
            {
                "name": "front_right",
                "target": "motor:0",
                "axis_a": [1.0, 0.0, 0.0],
                "axis_b": [0.0, 1.0, 0.0],
                "max_angle_a_deg": 8.0,
                "max_angle_b_deg": 12.0,
                "tau": 0.03,
                "channels": ["tilt_a", "tilt_b"],
            }
        ]
        return data
    return yaml.safe_load((uav_dir() / f"{name}.yaml").read_text())


AIRFRAMES = (*ROUTED, GIMBAL_QUAD)


def _spec(name: str):
    return parse_uav_spec(_data(name), source=name)


@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    """Each airframe with its motor noise off (the two backends draw their noise apart)."""
    folder = tmp_path_factory.mktemp("quiet_routed")
    paths = {}
    for name in AIRFRAMES:
        data = _data(name)
        data["motors"]["noise_ratio"] = 0.0
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(data))
        paths[name] = str(path)
    return paths


def _gimbals(parts) -> Gimbals:
    """The engine's gimbal group as ``build_gimbals`` builds it, turning ``Motors`` of its own."""
    motors = Motors(parts.motors, DT, NoiseSource(np.random.default_rng(0)))
    flown = {g: len(parts.mixer_motors) + k for k, (g, _) in enumerate(parts.mixer_tilts)}
    nominal = [tuple(parts.motors.thrust_axes[i].tolist()) for _, i in parts.gimbal_targets]
    channels = [tuple(row) for row in parts.gimbal_channels.tolist()]
    targets = [(motors.turn, i) for _, i in parts.gimbal_targets]
    group = Gimbals(parts.gimbals, DT, nominal, channels, flown, targets)
    group.motors = motors  # type: ignore[attr-defined]  # the group it turns, for the comparison
    return group


@pytest.mark.parametrize("name", ["tricopter", GIMBAL_QUAD])
def test_the_gimbal_step_equals_the_gimbals_and_the_motor_it_turns(name):
    """Random servo angles and commands beyond [-1, 1] (the clip), tick after tick: the compiled
    step's angles and the turned motor's wrench column equal ``Gimbals.step`` and ``Motors.turn``
    bit for bit, and its aux (angle over limit) ``Gimbals.aux``."""
    spec = _spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    group = _gimbals(parts)
    rng = np.random.default_rng(60)
    g = len(group.angles)
    angles = rng.uniform(-0.6, 0.6, 2 * g)
    group.angles = [tuple(angles[2 * k : 2 * k + 2].tolist()) for k in range(g)]
    columns = model.columns.copy()
    clipped = 0
    for step in range(300):
        if step % 2 == 0:  # a new command every control tick
            command = rng.uniform(-1.6, 1.6, 2 * g)
            group.command = [tuple(command[2 * k : 2 * k + 2].tolist()) for k in range(g)]
            clipped += int(np.any(np.abs(command) > 1.0))
        group.step()
        kernels.gimbals_step(angles, command, model.gimbals, model.gimbal_source, columns)
        assert angles.tolist() == [v for pair in group.angles for v in pair], step
        assert [tuple(c) for c in columns.tolist()] == group.motors.columns, step
    assert (angles / model.gimbal_scale).tolist() == group.aux()
    assert clipped > 50
    assert np.abs(columns - model.columns).max() > 0.01 * np.abs(model.columns).max()  # the axis turned


@pytest.mark.parametrize("name", AIRFRAMES)
def test_the_routing_equals_the_motors_gimbals_and_surfaces(name):
    """A tick's channels (the setpoint after the mode's values, limited to the channels' ranges)
    and mixer outputs (beyond [-1, 1]) routed to every motor, gimbal and flap: ``route_motors``,
    ``route_gimbals`` and ``route_channels`` equal ``Motors.route``, ``Gimbals.route`` and
    ``Surfaces.route`` bit for bit (the quadplane's pusher on its channel, its lift motors on the
    mixer; the tricopter's servo on the mixer; the variant's gimbal on its two channels)."""
    spec = _spec(name)
    parts = assemble(spec)
    model = batched_model(spec, DT, CONTROL_DT)
    slots = {motor: slot for slot, motor in enumerate(parts.mixer_motors)}
    outputs_of = [slots.get(m) for m in range(parts.motors.count)]
    motors = Motors(parts.motors, DT, NoiseSource(np.random.default_rng(0)), mix_rows(parts.motor_mix), outputs_of)
    surfaces = Surfaces(parts.surfaces, DT, mix_rows(parts.surface_mix)) if parts.surfaces else None
    gimbals = _gimbals(parts) if parts.gimbals is not None else None
    rng = np.random.default_rng(61)
    channels, motor_command = np.empty(model.channels), np.empty(model.motors)
    flap_command, gimbal_command = np.empty(len(model.surfaces)), np.empty(len(model.gimbal_scale))
    assert model.routed and model.mixer_outputs == len(parts.mixer_motors) + len(parts.mixer_tilts)
    for _ in range(300):
        outputs = rng.uniform(-1.4, 1.4, model.mixer_outputs)
        setpoint = np.r_[rng.uniform(-1, 1, 4), rng.uniform(-1.6, 1.6, model.channels)]
        tail = setpoint[4:]
        expected = tail.clip(parts.channel_low, parts.channel_high)  # Vehicle.control_step
        kernels.clip_channels(tail, model.channel_low, model.channel_high, channels)
        assert channels.tolist() == expected.tolist()
        motors.route(expected.tolist(), outputs.tolist())
        kernels.route_motors(
            channels, outputs, model.motor_source, model.motor_mix_index, model.motor_mix_weight, motor_command
        )
        assert motor_command.tolist() == motors.command
        if surfaces is not None:
            surfaces.route(expected.tolist(), outputs.tolist())
            kernels.route_channels(channels, model.surface_mix_index, model.surface_mix_weight, flap_command)
            assert flap_command.tolist() == surfaces.command
        if gimbals is not None:
            gimbals.route(expected.tolist(), outputs.tolist())
            kernels.route_gimbals(channels, outputs, model.gimbal_source, gimbal_command)
            assert gimbal_command.tolist() == [v for pair in gimbals.command for v in pair]


def test_the_mixer_flies_only_its_motors():
    """The quadplane's mixer is the vehicle's: its four lift motors (the pusher outside it, on
    its channel), the tricopter's its three motors and the tail's servo (a trim for its side force)."""
    plane = batched_model(_spec("quadplane"), DT, CONTROL_DT)
    assert plane.motor_source.tolist() == [0, 1, 2, 3, -1] and plane.mixer_outputs == 4 and plane.channels == 4
    assert len(plane.surfaces) == 5 and plane.aux_size == 10 and not plane.lateral.size
    tri = batched_model(_spec("tricopter"), DT, CONTROL_DT)
    assert tri.motor_source.tolist() == [0, 1, 2] and tri.mixer_outputs == 4 and tri.channels == 0
    assert tri.gimbal_source.tolist() == [[2, -1, -1, 3]] and tri.aux_size == 5
    assert tri.cascade.trimmed and not plane.cascade.trimmed
    assert tri.lateral[0, :2].tolist() == [2.0, math.radians(30.0)]


# ------------------------------------------------------------------ cross-checks

#: per multirotor mode, the range of its random setpoints (as test_crosscheck.CASCADE_ACTIONS:
#: around the spawn, tilts within +-0.3 rad, rates within +-1 rad/s, velocities within 1.5 m/s)
HEADS = {
    "rates_z": ([-1.0, -1.0, -1.0, 0.6], [1.0, 1.0, 1.0, 1.6]),
    "attitude_vz": ([-0.3, -0.3, -3.0, -1.0], [0.3, 0.3, 3.0, 1.0]),
    "attitude_z": ([-0.3, -0.3, -3.0, 0.6], [0.3, 0.3, 3.0, 1.6]),
    "heading_velocity_z": ([-1.5, -1.5, -1.0, 0.6], [1.5, 1.5, 1.0, 1.6]),
    "heading_velocity_vz": ([-1.5, -1.5, -1.0, -1.0], [1.5, 1.5, 1.0, 1.0]),
    "velocity_yawrate": ([-1.5, -1.5, -1.0, -1.0], [1.5, 1.5, 1.0, 1.0]),
    "velocity_yaw": ([-1.5, -1.5, -3.0, -1.0], [1.5, 1.5, 3.0, 1.0]),
    "position_yaw": ([-1.0, -1.0, -3.0, 0.6], [1.0, 1.0, 3.0, 1.6]),
    "position_yawrate": ([-1.0, -1.0, -1.0, 0.6], [1.0, 1.0, 1.0, 1.6]),
}
MODES = ("rates_thrust", "motors", *HEADS)


def routed_action(uav: str, mode: str) -> dict:
    """The action of ``mode`` on airframe file ``uav``: the mode's values, then one per channel
    (the pusher's throttle within [0, 0.3]: a 2 s flight stays inside the flight dome)."""
    spec = parse_uav_spec(yaml.safe_load(open(uav).read()), source=uav)
    model = batched_model(spec, DT, CONTROL_DT)
    hover = model.hover_thrust_fraction
    if mode == "rates_thrust":
        names, low, high = ["p", "q", "r", "thrust"], [-1.0, -1.0, -1.0, 0.95 * hover], [1.0, 1.0, 1.0, 1.15 * hover]
    elif mode == "motors":
        # around the mixer's outputs for a level hover (the tricopter's servo trimming the tail's
        # yaw reaction): flown open loop, 2 s of them keep the airframe in the flight dome
        n, tilts = len(model.mixer_rows), len(model.lateral)
        names = [f"m{i}" for i in range(n)] + [f"tilt{k}" for k in range(tilts)]
        level = np.array(flight_mixer(assemble(spec)).throttles(model.mass * 9.81, 0.0, 0.0, 0.0))
        spread = np.r_[np.full(n, 0.01), np.full(tilts, 0.05)]
        low, high = (level - spread).tolist(), (level + spread).tolist()
    else:
        names, (low, high) = list(MULTIROTOR_MODES[mode].setpoint), HEADS[mode]
    names, low, high = list(names), list(low), list(high)
    for c, lo, hi in zip(spec.channels, model.channel_low.tolist(), model.channel_high.tolist()):
        names.append(c)
        low.append(lo)
        high.append(min(hi, 0.3) if c == "thrust" else hi)
    return {"mode": mode, "names": names, "units": ["1"] * len(names), "low": low, "high": high}


def fly_routed_pair(
    uav: str, mode: str, seed: int = 3, steps: int = 60, **overrides: object
) -> tuple[dict[str, float], int]:
    """Both backends fly QuadX-Waypoints on airframe file ``uav`` in ``mode`` (its action:
    :func:`routed_action`) from one start for ``steps`` agent steps of random setpoints; returns
    the largest differences (motor and flap commands, gimbal angles, positions, observations,
    rewards) and the steps flown (``overrides``: more env keys, e.g. a latency).  The test below and ``experiments/batched_modes_crosscheck.py --routed``
    fly it."""
    # mode motors flies open loop, its attitude drifting: from 3 m up, 2 s keep it off the ground
    spawn = {"start_position": [0.0, 0.0, 3.0]} if mode == "motors" else {}
    pb, be = _pair("quadx_waypoints", uav, seed=seed, action=routed_action(uav, mode), **spawn, **overrides)
    low, high = np.array(be.config.action.low), np.array(be.config.action.high)
    vehicle = pb.unwrapped.world.vehicles[0]
    assert vehicle.mode.name == mode
    rng = np.random.default_rng(8)
    worst = dict.fromkeys(("command", "gimbal", "flap", "position", "observation", "reward"), 0.0)
    for flown in range(1, steps + 1):
        action = rng.uniform(low, high)
        o1, r1, t1, tr1, _ = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        flat = _flat(o1)
        assert flat.shape == final.shape
        worst["position"] = max(worst["position"], np.abs(flat[10:13] - final[10:13]).max())
        worst["observation"] = max(worst["observation"], np.abs(flat - final).max())
        worst["reward"] = max(worst["reward"], abs(r1 - r2[0]))
        if t1 or tr1:
            break
        worst["command"] = max(worst["command"], np.abs(np.subtract(vehicle.motor_command, be.command[0])).max())
        if be.flap_command.shape[1]:
            flaps = np.subtract(vehicle.surface_command, be.flap_command[0])
            worst["flap"] = max(worst["flap"], np.abs(flaps).max())
        if be.gimbal_angles.shape[1]:
            angles = np.subtract(vehicle.gimbal_angles.reshape(-1), be.gimbal_angles[0])
            worst["gimbal"] = max(worst["gimbal"], np.abs(angles).max())
    pb.close()
    return {k: float(v) for k, v in worst.items()}, flown


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", ROUTED)
def test_every_mode_agrees_with_the_pybullet_engine(quiet, name, mode):
    """The tricopter and the quadplane in every multirotor mode, 2 s of random setpoints (and
    channels) drawn anew at every agent step: positions, observations (the gimbal angles and
    flap deflections among them) and rewards within the module docstring's 1e-6."""
    worst, flown = fly_routed_pair(quiet[name], mode)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"


@pytest.mark.parametrize("mode", ["rates_thrust", "position_yaw"])
def test_a_gimbal_on_channels_agrees_with_the_pybullet_engine(quiet, mode):
    """The variant's two-axis gimbal, driven by its own channels: as the cross-checks above."""
    worst, flown = fly_routed_pair(quiet[GIMBAL_QUAD], mode)
    assert max(worst.values()) < BOUND, worst
    assert worst["gimbal"] < BOUND and flown == 60


@pytest.mark.parametrize("delays", [(13, 11), (3, 5)])
def test_the_quadplane_with_latency_agrees_with_the_pybullet_engine(quiet, delays):
    """The quadplane in position_yaw with action and observation delays (physics steps at
    240 Hz: between ticks and between agent steps): the delayed observation shows its flaps'
    deflections of that many steps ago, as the PyBullet engine's; the same 1e-6."""
    latency = {"action_delay": delays[0] / 240, "observation_delay": delays[1] / 240}
    worst, flown = fly_routed_pair(quiet["quadplane"], "position_yaw", latency=latency)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60


def test_the_randomised_quadplane_agrees_with_the_pybullet_engine(quiet):
    """Every entry the backend draws (test_randomization.DRAWS: the airframe's factors, all five
    motors' among them, the spawn offsets, an observation delay), drawn by both from one
    generator, the quadplane in position_yaw with its channels: within 1e-6, as the other
    randomised flights."""
    from tests.batched.test_randomization import DRAWS, _generators, _pybullet

    action = routed_action(quiet["quadplane"], "position_yaw")
    cfg = load_env_config("quadx_waypoints").with_overrides(uav=quiet["quadplane"], randomize=DRAWS, action=action)
    be = BatchedUAVEnv(cfg, num_envs=1)
    first, info = be.reset(seed=5)
    pb, start, pb_info = _pybullet(cfg, _generators(5, 1)[0])
    assert pb_info["randomization"] == {name: float(v[0]) for name, v in info["randomization"].items()}
    low, high = np.array(cfg.action.low), np.array(cfg.action.high)
    rng = np.random.default_rng(7)
    worst = np.abs(_flat(start) - first[0]).max()
    for flown in range(1, 61):
        a = rng.uniform(low, high)
        o1, r1, t1, tr1, _ = pb.step(a)
        o2, r2, t2, tr2, info = be.step(a[None])
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        worst = max(worst, np.abs(_flat(o1) - final).max(), abs(r1 - r2[0]))
        if t1 or tr1:
            break
    pb.close()
    assert worst < BOUND, worst
    assert flown == 60


def test_a_tricopter_checkpoint_carries_its_servo():
    """``episode_state`` then ``restore_episode`` puts every env back where it was, the tail
    servo's angle and command included: the steps after it repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    vec = make_vec_env(load_env_config("quadx_hover").with_overrides(backend="batched", uav="tricopter"), 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(1)
    for _ in range(10):
        vec.step(rng.uniform(-1.0, 1.0, (3, 4)))
    saved = vec.env_method("episode_state")
    assert np.abs(vec.env.gimbal_angles).max() > 0.0 and "gimbal_angles" in saved[0]["batched"]
    actions = rng.uniform(-1.0, 1.0, (20, 3, 4))
    first = [vec.step(a)[0] for a in actions]
    vec.env.gimbal_angles[:] = 0.0  # state the restore must put back
    vec.env.gimbal_command[:] = 0.0
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


# ------------------------------------------------------------------ what stays refused


@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        ({"uav": "tricopter", "latency": {"action_delay": 0.01}}, "env.latency"),
        (
            {"uav": "tricopter", "randomize": {"motor_kf": {"distribution": "uniform", "low": 0.9, "high": 1.1}}},
            "env.randomize.motor_kf",
        ),
    ],
)
def test_what_it_does_not_fly_on_a_gimbal_is_refused_by_name(overrides, named):
    cfg = load_env_config("quadx_hover").with_overrides(backend="batched", **overrides)
    with pytest.raises(UnsupportedByBatched) as info:
        BatchedUAVEnv(cfg, num_envs=2)
    assert named in str(info.value) and "env.backend=pybullet" in str(info.value)


def test_gimbals_with_the_motor_models_are_refused_by_name():
    data = _data("tricopter")
    data["motors"]["tau_fall"] = 0.02
    with pytest.raises(UnsupportedByBatched, match="gimbals with the optional motor models"):
        batched_model(parse_uav_spec(data), DT, CONTROL_DT)


def test_a_channel_action_of_the_wrong_size_is_refused_with_the_size():
    """QuadX-Hover's 4 values on the quadplane: its setpoint takes 4 more (its channels)."""
    cfg = load_env_config("quadx_hover").with_overrides(backend="batched", uav="quadplane")
    with pytest.raises(ConfigError, match="mode rates_thrust takes 8 values"):
        BatchedUAVEnv(cfg, num_envs=2)


def test_the_tricopter_trains_on_the_batched_backend_by_auto():
    """``env.backend: auto`` resolves the tricopter's hover to batched; the rocket stays refused."""
    from pyflyt_engine.batched import resolve_backend

    assert resolve_backend(load_env_config("quadx_hover").with_overrides(backend="auto", uav="tricopter")) == "batched"
    assert resolve_backend(load_env_config("quadx_hover").with_overrides(backend="auto", uav="rocket")) == "pybullet"


def test_a_multi_agent_world_of_them_is_refused_by_name():
    from pyflyt_engine.batched import check_supported

    cfg = load_env_config("ma_quadx_hover").with_overrides(backend="batched", uav="tricopter")
    with pytest.raises(UnsupportedByBatched, match="in a multi-agent world \\(airframe tricopter\\)"):
        check_supported(cfg)
