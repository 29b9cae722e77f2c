"""The optional motor models and the battery on the batched backend.

**One law per model.**  The compiled laws (:func:`~pyflyt_engine.batched.kernels.modelled_motors_step`,
:func:`~pyflyt_engine.batched.kernels.inflow_ratios`, :func:`~pyflyt_engine.batched.kernels.battery_step`
and its :func:`~pyflyt_engine.batched.kernels.battery_supply`) are held bit for bit to the
engine's scalar forms (``ModelledMotors.step``, ``InflowRotor.ratios``, ``Battery.step``,
``battery.supply``) on random inputs reaching every branch: both lags, reversed rotors, the
vortex-ring floor and the windmill brake of the inflow model, rotor drag, the pack's table
segments and ends, a load beyond the most it delivers, an ideal (R = 0) pack, the charge's
floor.  The parameters come out of the engine's own objects (``batched/model.py``).

**Cross-checks.**  The example airframe ``conf/uav/examples/quadx_cf2x_battery.yaml`` (every
model and a battery), its variants with one model each, an F450 and a fixed-wing with the
models and a pack, flown by both backends from one start with the same actions (motor noise
off): positions, observations (the battery's state of charge closes them) and rewards within
the bound of ``test_crosscheck.py``, **1e-6**, and the charge itself within it.  The bound
holds unchanged: the laws added are bit for bit the engine's, so the two backends still
differ only by the rigid body's last bits, and every law added is continuous in the state
(the lag switches where ``zeta = x``, where either lag moves the throttle by 0; the inflow
ratios' floor, clamps and brake meet the formula where they switch in; Newton's stopping
rule changes the voltage only in its last bits; the charge's floor is a clamp), so no new
amplification enters beyond the mixer's square root the bound was derived for.
"""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

from pyflyt_engine.assembly import assemble
from pyflyt_engine.atmosphere.rotors import RotorInteractions
from pyflyt_engine.batched import BatchedUAVEnv, air, kernels
from pyflyt_engine.batched.model import batched_model
from pyflyt_engine.components.battery import Battery, open_circuit_voltage, supply
from pyflyt_engine.components.motor_models import ModelledMotors
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import parse_uav_spec
from tests.batched.test_crosscheck import BOUND, _flat, _pair
from tests.batched.test_sensors import _fixed

DT, CONTROL_DT = 1 / 240, 1 / 120
EXAMPLE = uav_dir() / "examples" / "quadx_cf2x_battery.yaml"
#: a 4S pack (16.8 V full) for the larger airframes: values of the test's choosing
PACK_4S = {
    "capacity_mah": 5000.0,
    "internal_resistance": 0.03,
    "efficiency": 0.8,
    "avionics_power": 2.0,
    "open_circuit_voltage": [[0.0, 12.0], [0.1, 14.4], [0.5, 15.2], [0.9, 16.2], [1.0, 16.8]],
}
MODELS = ("tau_fall", "rotor_drag", "inflow")


def _example() -> dict:
    return yaml.safe_load(EXAMPLE.read_text())


def _shipped(name: str) -> dict:
    return yaml.safe_load((uav_dir() / f"{name}.yaml").read_text())


def _only(keep: str) -> dict:
    """The example airframe with one of its models (or only its battery) left on."""
    data = _example()
    for key in MODELS:
        if key != keep:
            data["motors"].pop(key)
    if keep != "battery":
        data.pop("battery")
    data["name"] = f"cf2x_{keep}"
    return data


def _f450() -> dict:
    data = _shipped("quadx_f450")
    data["motors"].update(tau_fall=0.02, rotor_drag=0.01, inflow={"solidity": 0.1, "lift_slope": 5.73})
    data["battery"] = copy.deepcopy(PACK_4S)
    data["name"] = "f450_modelled"
    return data


def _fixedwing() -> dict:
    data = _shipped("fixedwing")
    # the reference's Crazyflie coefficients, so a Crazyflie-sized propeller for the inflow model
    data["motors"].update(
        tau_fall=0.02, rotor_drag=1e-3, prop_radius=0.0225, inflow={"solidity": 0.17, "lift_slope": 5.73}
    )
    data["battery"] = dict(copy.deepcopy(PACK_4S), internal_resistance=0.01, capacity_mah=20000.0)
    data["name"] = "fixedwing_modelled"
    return data


#: every airframe here: name -> its YAML mapping
AIRFRAMES = {
    "example": _example,
    **{f"only_{k}": (lambda k=k: _only(k)) for k in (*MODELS, "battery")},
    "f450": _f450,
    "fixedwing": _fixedwing,
}


def _quiet(data: dict) -> dict:
    data = copy.deepcopy(data)
    data["motors"]["noise_ratio"] = 0.0
    return data


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Each airframe as a YAML file, its motor noise off (the two backends draw it apart)."""
    folder = tmp_path_factory.mktemp("modelled")
    out = {}
    for name, make in AIRFRAMES.items():
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(_quiet(make())))
        out[name] = str(path)
    return out


def _engine_group(data: dict) -> tuple[ModelledMotors, object]:
    spec = parse_uav_spec(data)
    parts = assemble(spec)
    pack = Battery(parts.battery, DT) if parts.battery is not None else None
    return ModelledMotors(parts.motors, DT, NoiseSource(np.random.default_rng(0)), battery=pack), spec


# ----------------------------------------------------------------------- laws


@pytest.mark.parametrize("name", list(AIRFRAMES))
def test_the_model_reads_the_engines_modelled_motors(name):
    """Every model the airframe declares has its bit, every motor its row, and the pack's
    reset state is a fresh ``Battery``'s."""
    data = AIRFRAMES[name]()
    group, spec = _engine_group(data)
    model = batched_model(spec, DT, CONTROL_DT)
    declared = {k for k in MODELS if k in data["motors"]}
    assert model.motor_laws & kernels.LAW_MODELLED
    assert bool(model.motor_laws & kernels.LAW_ROTOR_DRAG) == ("rotor_drag" in declared)
    assert bool(model.motor_laws & kernels.LAW_INFLOW) == ("inflow" in declared)
    assert bool(model.motor_laws & kernels.LAW_BATTERY) == ("battery" in data) == model.has_battery
    assert model.motor_model.shape == (group.params.count, kernels.MOTOR_MODEL_FIELDS)
    assert model.motor_model[:, kernels.M_LAG_FALL].tolist() == group.lag_fall
    if "tau_fall" not in declared:
        assert group.lag_fall == group.lag
    if model.has_battery:
        b = group.battery
        assert model.battery_reset.tolist() == [b.charge, b.voltage, b.current, b.speed_ratio]
        assert model.aux_size == model.motors + len(model.surfaces) + 1


def test_an_airframe_without_models_keeps_the_static_motors():
    model = batched_model(parse_uav_spec(_shipped("quadx_cf2x")), DT, CONTROL_DT)
    assert model.motor_laws == 0 and not model.has_battery and model.motor_model.shape[0] == 0


def test_inflow_ratios_equal_the_inflow_rotor_in_every_branch():
    """Climb rates from deep descent (the vortex-ring floor) to past the windmill brake, at
    rotor speeds from a crawl to full: bit for bit ``InflowRotor.ratios``."""
    data = _example()
    group, _ = _engine_group(data)
    rows = batched_model(parse_uav_spec(data), DT, CONTROL_DT).motor_model
    rng = np.random.default_rng(11)
    hit = {"floor": 0, "brake": 0, "formula": 0}
    for m, rotor in enumerate(group._inflow):
        for _ in range(3000):
            speed = float(rng.uniform(1.0, group._omega_max[m]))
            climb = float(rng.normal(0.0, 1.0) * speed * rotor.radius * 0.4)
            expected = rotor.ratios(climb, speed)
            assert kernels.inflow_ratios(rows[m], climb, speed) == expected
            lc = climb / (speed * rotor.radius)
            hit["floor" if lc < -0.5 * rotor.lambda_h else "brake" if lc >= rotor.theta_tip else "formula"] += 1
    assert min(hit.values()) > 50, hit


@pytest.mark.parametrize("name", list(AIRFRAMES))
def test_modelled_motors_step_equals_the_engines_group(name):
    """Random throttles (reversed ones too), commands, noise factors, air velocities fast
    enough to reach the inflow model's floor and brake, ground-effect ratios and pack
    states: the wrench, the throttles and the pack after the step bit for bit
    ``ModelledMotors.step`` (which steps its ``Battery``)."""
    data = AIRFRAMES[name]()
    group, spec = _engine_group(data)
    model = batched_model(spec, DT, CONTROL_DT)
    n = group.params.count
    rng = np.random.default_rng(12)
    throttle = rng.uniform(-0.3, 1.0, n)
    group.throttle = throttle.tolist()
    pack = group.battery
    state = model.battery_reset.copy()
    falls = rises = 0
    for k in range(400):
        command = rng.uniform(-1.0, 1.0, n)
        factors = 1.0 + 0.05 * rng.standard_normal(n)
        ratio = rng.uniform(1.0, 1.3, n)
        u, v, w = rng.normal(0.0, 8.0, 3).tolist()
        p, q, r = rng.normal(0.0, 5.0, 3).tolist()
        if pack is not None and k % 50 == 0:  # the pack anywhere on its table, its floor included
            pack.charge = float(rng.choice([0.0, 1e-9, rng.uniform(0.0, 1.0)]))
            state[0] = pack.charge
        rises += int(np.sum(throttle * (command - throttle) >= 0.0))
        falls += int(np.sum(throttle * (command - throttle) < 0.0))
        group.command = command.tolist()
        group._noise.next = lambda f=factors: tuple(f.tolist())  # the same draws for both
        group._noisy = True
        expected = group.step(((u, v, w), (p, q, r)), ratio.tolist())
        volt = state[3] if model.has_battery else 1.0
        *got, power = kernels.modelled_motors_step(
            throttle, command, model.lag, factors, model.motor_model, model.motor_laws, volt, ratio, u, v, w, p, q, r
        )
        assert tuple(got) == expected
        assert throttle.tolist() == group.throttle
        if model.has_battery:
            kernels.battery_step(state, model.battery, model.battery_table, DT, power)
            assert state.tolist() == [pack.charge, pack.voltage, pack.current, pack.speed_ratio]
        else:
            assert power == 0.0
    assert rises > 100 and falls > 100


@pytest.mark.parametrize("name", ["example", "f450"])
def test_modelled_load_in_ground_effect_equals_the_engine(name):
    """The kernels' composition (:func:`kernels.modelled_load`: ground-effect ratios at the
    hubs, the motors, the pack) against ``RotorInteractions.ground_effect_ratios`` fed to
    ``ModelledMotors.step``, at random heights into the clamp and random attitudes."""
    data = AIRFRAMES[name]()
    group, spec = _engine_group(data)
    model = batched_model(spec, DT, CONTROL_DT)
    motors = assemble(spec).motors
    rotors = RotorInteractions(True, False)
    rotors.add_vehicle(
        motors.positions.tolist(), spec.motors.to_array("prop_radius").tolist(), motors.max_thrust.tolist()
    )
    group._noisy = False
    n = motors.count
    rng = np.random.default_rng(13)
    throttle = rng.uniform(0.0, 1.0, n)
    group.throttle = throttle.tolist()
    state = model.battery_reset.copy()
    scratch = np.empty(n)
    for _ in range(300):
        qv = rng.normal(size=4)
        rot = kernels.rotation_tuple(*(qv / np.linalg.norm(qv)).tolist())
        z = float(rng.uniform(-0.05, 0.8))
        a = tuple(rng.normal(0.0, 3.0, 6).tolist())
        command = rng.uniform(0.0, 1.0, n)
        group.command = command.tolist()
        expected = group.step((a[:3], a[3:]), rotors.ground_effect_ratios(0, (0.3, -0.2, z), rot))
        got = kernels.modelled_load(
            throttle,
            command,
            model.lag,
            np.ones(n),
            model.motor_model,
            model.motor_laws,
            state,
            model.battery,
            model.battery_table,
            model.rotors,
            True,
            z,
            rot[6],
            rot[7],
            rot[8],
            air.GROUND_EFFECT_MIN_HEIGHT,
            scratch,
            a,
            DT,
        )
        assert got == expected
        assert throttle.tolist() == group.throttle
        b = group.battery
        assert state.tolist() == [b.charge, b.voltage, b.current, b.speed_ratio]


def test_battery_supply_and_voltage_equal_the_engines_in_every_branch():
    """``battery_supply`` against ``battery.supply`` from no load to loads the pack cannot
    carry (the no-root branch), an ideal pack (R = 0); the open-circuit table at and past its
    ends: bit for bit."""
    table = ((0.0, 3.0), (0.1, 3.6), (0.5, 3.8), (0.9, 4.05), (1.0, 4.2))
    array = np.array(table)
    rng = np.random.default_rng(14)
    beyond = 0
    for _ in range(4000):
        charge = float(rng.uniform(-0.1, 1.1))
        assert kernels.open_circuit_voltage(array, charge) == open_circuit_voltage(table, charge)
        ocv = open_circuit_voltage(table, charge)
        resistance = float(rng.choice([0.0, rng.uniform(0.01, 0.5)]))
        cubic = float(10.0 ** rng.uniform(-4.0, 3.0))
        constant = float(rng.uniform(0.0, 2.0))
        got = kernels.battery_supply(ocv, resistance, cubic, constant)
        assert got == supply(ocv, resistance, cubic, constant)
        c = resistance * cubic
        if c > 0.0 and got[0] == (math.sqrt(4.0 + 12.0 * c * ocv) - 2.0) / (6.0 * c):
            beyond += 1
    for q in (0.0, 0.1, 0.5, 0.9, 1.0):
        assert kernels.open_circuit_voltage(array, q) == open_circuit_voltage(table, q)
    assert beyond > 50, beyond


# ----------------------------------------------------------------- cross-checks


def fly_modelled_pair(
    uav: str, env_name: str = "quadx_hover", mode: str = "rates_thrust", seed: int = 3, steps: int = 60, **overrides
) -> tuple[dict[str, float], int, float]:
    """Both backends fly airframe file ``uav`` from one start for ``steps`` agent steps: a
    multirotor on random rates (``rates_thrust``) or throttles (``motors``) around the thrust
    that holds it at the pack's present voltage (the hover fraction over the speed ratio
    squared, read off the batched pack before each step and given to both), a fixed-wing on
    random channels.  Returns the largest differences (positions, observations, rewards, the
    battery's charge), the steps flown and the charge used."""
    if mode == "motors":
        n = batched_model(parse_uav_spec(yaml.safe_load(open(uav))), DT, CONTROL_DT).motors
        overrides["action"] = {
            "mode": "motors",
            "names": [f"m{i}" for i in range(n)],
            "units": ["1"] * n,
            "low": [0.0] * n,
            "high": [1.0] * n,
        }
    pb, be = _pair(env_name, uav, seed=seed, **overrides)
    vehicle = pb.unwrapped.world.vehicles[0]
    low, high = np.array(be.config.action.low), np.array(be.config.action.high)
    rng = np.random.default_rng(7)
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0, "charge": 0.0}
    for flown in range(1, steps + 1):
        if be.model.channel_driven:
            action = rng.uniform(low, high)
        else:
            sag = be.battery[0, 3] ** 2 if be.model.has_battery else 1.0
            hover = be.model.hover_thrust_fraction / sag
            if mode == "motors":
                action = np.sqrt(hover) * rng.uniform(0.97, 1.05, be.model.motors)
            elif mode == "rates_thrust":
                action = np.r_[rng.uniform(-1.0, 1.0, 3), hover * rng.uniform(0.95, 1.15)]
            else:
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
        if be.model.has_battery:
            worst["charge"] = max(worst["charge"], abs(vehicle.battery.charge - be.battery[0, 0]))
            if be.latency is None:  # the gauge closes the aux (delayed, it shows an earlier charge)
                assert final[be._attitude_size - 1] == be.battery[0, 0]
    used = 1.0 - float(be.battery[0, 0]) if be.model.has_battery else 0.0
    pb.close()
    return {k: float(v) for k, v in worst.items()}, flown, used


@pytest.mark.parametrize("env_name", ["quadx_hover", "quadx_waypoints"])
@pytest.mark.parametrize("mode", ["rates_thrust", "motors"])
@pytest.mark.parametrize("name", ["example", "f450"])
def test_modelled_multirotors_agree_with_the_pybullet_engine(files, name, mode, env_name):
    """2 s of random actions: positions, observations, rewards and the charge within 1e-6;
    the pack is drawn on (charge used) and the flight lasts."""
    worst, flown, used = fly_modelled_pair(files[name], env_name, mode)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"
    assert used > 0.0


@pytest.mark.parametrize("name", [f"only_{k}" for k in (*MODELS, "battery")])
def test_each_model_alone_agrees_with_the_pybullet_engine(files, name):
    worst, flown, _ = fly_modelled_pair(files[name])
    assert max(worst.values()) < BOUND, worst
    assert flown == 60


@pytest.mark.parametrize(
    ("env_name", "overrides"),
    [
        # a cascade mode (the controller's ticks, the physics in mode motors), 3 m up: its random
        # climb rates do not reach the ground in 2 s
        ("quadx_waypoints_velocity", {"start_position": [0.0, 0.0, 3.0]}),
        ("quadx_hover", {"wind": "gust"}),  # the rotors at their velocity through the wind
        (
            "quadx_hover",
            {
                "ground_effect": True,
                "start_position": [0.0, 0.0, 0.15],
                "hover_point": [0.0, 0.0, 0.15],
                "start_position_noise": 0.0,
                "start_orientation_noise": 0.0,
            },
        ),
        ("quadx_hover", {"latency": {"action_delay": 0.01, "observation_delay": 0.02}}),  # the charge shown delayed
    ],
)
def test_the_example_agrees_in_every_path_of_the_kernel(files, env_name, overrides):
    mode = "velocity" if env_name == "quadx_waypoints_velocity" else "rates_thrust"
    worst, flown, used = fly_modelled_pair(files["example"], env_name, mode, **overrides)
    assert max(worst.values()) < BOUND, worst
    assert flown >= 30 and used > 0.0


@pytest.mark.parametrize("seed", [0, 1])
def test_a_modelled_fixedwing_agrees_with_the_pybullet_engine(files, seed):
    """Fixedwing-Waypoints in mode channels, 2 s over the whole action range: the puller's
    inflow at the forward speed, its rotor drag, the pack under ~1 kW."""
    worst, flown, used = fly_modelled_pair(files["fixedwing"], "fixedwing_waypoints", "channels", seed=seed)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60 and used > 0.0


def test_the_pack_is_reset_per_env_with_its_episode(files):
    """Two envs, one flying on and one falling to the ground: the crashed env's next episode
    starts from the full pack, the other keeps draining; the PyBullet env's reset restores
    its charge the same."""
    cfg = load_env_config("quadx_hover").with_overrides(uav=files["example"])
    be = BatchedUAVEnv(cfg, num_envs=2, seed=0)
    be.reset(seed=0)
    hover = be.model.hover_thrust_fraction
    ended = False
    for _ in range(200):
        sag = be.battery[:, 3] ** 2
        actions = np.array([[0.0, 0.0, 0.0, hover / sag[0]], [0.0, 0.0, 0.0, 0.0]])
        _, _, term, trunc, _ = be.step(actions)
        if term[1] or trunc[1]:
            ended = True
            break
    assert ended and not (term[0] or trunc[0])
    assert be.battery[1].tolist() == be.model.battery_reset.tolist()
    assert be.battery[0, 0] < be.model.battery_reset[0]
    from pyflyt_engine.envs import make_env

    pb = make_env(cfg)
    pb.reset(seed=0)
    vehicle = pb.unwrapped.world.vehicles[0]
    for _ in range(10):
        pb.step(np.array([0.0, 0.0, 0.0, 0.5]))
    assert vehicle.battery.charge < 1.0
    pb.reset(seed=1)
    b = vehicle.battery
    assert [b.charge, b.voltage, b.current, b.speed_ratio] == be.model.battery_reset.tolist()
    pb.close()


_RUN = """
import hashlib, sys
import numpy as np
from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
cfg = load_env_config("quadx_hover").with_overrides(uav=sys.argv[1])
env = BatchedUAVEnv(cfg, num_envs=8, seed=5)
obs, _ = env.reset(seed=5)
h = hashlib.sha256(obs.tobytes())
rng = np.random.default_rng(0)
for _ in range(40):
    a = np.c_[rng.uniform(-1, 1, (8, 3)), rng.uniform(0.1, 0.3, (8, 1))]
    obs, r, t, tr, info = env.step(a)
    for x in (obs, r, env.battery, env.throttle):
        h.update(np.ascontiguousarray(x).tobytes())
print(h.hexdigest())
"""


def test_same_seed_same_numbers_across_processes():
    """The example airframe with its motor noise on, 8 envs, 40 steps: the observations,
    rewards, packs and throttles hash the same in two fresh processes."""
    root = str(uav_dir().parent.parent)
    digests = [
        subprocess.run(
            [sys.executable, "-c", _RUN, str(EXAMPLE)],
            check=True,
            capture_output=True,
            text=True,
            cwd=root,
            env=dict(os.environ, PYTHONPATH=root),
        ).stdout.strip()
        for _ in range(2)
    ]
    assert digests[0] == digests[1] and len(digests[0]) == 64


#: every motor and pack entry of a randomize section, each at a fixed value (both backends fly the same)
MODEL_DRAWS = {
    "motor_kf": _fixed(1.08),
    "motor_kt": _fixed(0.93),
    "motor_tau": _fixed(1.4),
    "motor_rotor_drag": _fixed(1.6),
    "battery_capacity": _fixed(0.8),
    "battery_resistance": _fixed(1.5),
    "battery_charge": _fixed(0.85),
}


@pytest.mark.parametrize(("env_name", "mode"), [("quadx_hover", "rates_thrust"), ("quadx_waypoints", "motors")])
def test_randomised_modelled_motors_and_pack_agree_with_the_pybullet_engine(files, env_name, mode):
    """The motor factors (tau_fall with motor_tau, as the engine's randomiser scales it), the rotor
    drag's and the pack's factors and its charge on the example airframe (asymmetric lag, rotor
    drag, inflow, battery): the batched rows are the engine's and 2 s of flight agree within
    1e-6; the pack starts at the drawn charge."""
    worst, flown, used = fly_modelled_pair(files["example"], env_name, mode, randomize=MODEL_DRAWS)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60 and used > 0.0


def test_drawn_model_factors_set_each_envs_rows_and_resume_exactly(files):
    """Drawn per env from each env's generator, the factors give every env its own modelled-motor
    and pack rows, each what the engine's group and pack derive from the drawn parameters; a
    checkpoint carries them, so a restore into a fresh batch continues bit for bit."""
    import dataclasses

    from pyflyt_cli.training.batched import BatchedVecEnv

    from pyflyt_engine.batched.model import modelled_rows

    drawn = {name: {"distribution": "uniform", "low": 0.6, "high": 1.4} for name in MODEL_DRAWS}
    drawn["battery_charge"] = {"distribution": "uniform", "low": 0.5, "high": 1.0}
    cfg = load_env_config("quadx_hover").with_overrides(uav=files["example"], randomize=drawn)
    a = BatchedVecEnv(cfg, 3)
    a.env.reset(seed=4)
    env = a.env
    names = env.randomizer.names
    parts = assemble(parse_uav_spec(yaml.safe_load(open(files["example"]))))
    for i in range(3):
        v = dict(zip(names, env.randomized_values[i].tolist()))
        m = parts.motors
        params = dataclasses.replace(
            m,
            kf=m.kf * v["motor_kf"],
            kt=m.kt * v["motor_kt"],
            tau=m.tau * v["motor_tau"],
            tau_fall=m.tau_fall * v["motor_tau"],
            rotor_drag=m.rotor_drag * v["motor_rotor_drag"],
        )
        b = parts.battery
        pack = dataclasses.replace(
            b,
            capacity_mah=b.capacity_mah * v["battery_capacity"],
            internal_resistance=b.internal_resistance * v["battery_resistance"],
            initial_charge=v["battery_charge"],
        )
        rows = modelled_rows(params, pack, DT)
        assert np.array_equal(env._motor_model[i], rows["motor_model"])
        assert np.array_equal(env._battery_params[i], rows["battery"])
        assert env.battery[i, 0] == v["battery_charge"] == rows["battery_reset"][0]
    assert not np.array_equal(env._motor_model[0], env._motor_model[1])
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, (3, 4)) for _ in range(40)]
    for act in actions[:20]:
        a.step(act)
    saved = [a.episode_state(i) for i in range(3)]
    for name in ("_motor_model", "_battery_params", "_battery_reset"):
        assert name in saved[0]["batched"], name
    b2 = BatchedVecEnv(cfg, 3)
    b2.env.reset(seed=999)
    for i in range(3):
        b2.restore_episode(i, saved[i])
    for act in actions[20:]:
        oa, ra, da, _ = a.step(act)
        ob, rb, db, _ = b2.step(act)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb) and np.array_equal(da, db)


@pytest.mark.parametrize(
    ("entry", "needs"),
    [
        ("battery_capacity", "battery"),
        ("motor_rotor_drag", "motors.rotor_drag"),
        ("gyro_noise", "sensors.imu"),
        ("position_noise", "sensors.position"),
    ],
)
def test_an_entry_with_nothing_to_randomise_is_the_engines_error(entry, needs):
    """An entry whose model the airframe lacks fails in the batched backend with the PyBullet
    engine's message (naming the entry, the missing section and the fix), never silently ignored."""
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.errors import ConfigError

    cfg = load_env_config("quadx_hover").with_overrides(randomize={entry: _fixed(1.1)})
    with pytest.raises(ConfigError) as batched:
        BatchedUAVEnv(cfg.with_overrides(backend="batched"), num_envs=2)
    with pytest.raises(ConfigError) as pybullet:
        make_env(cfg).reset(seed=0)
    assert str(batched.value) == str(pybullet.value)
    assert f"randomize.{entry}: the airframe has no '{needs}'" in str(batched.value)
