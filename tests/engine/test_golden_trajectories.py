"""Every shipped airframe in every flight mode, and the four paper envs, fly the recorded trajectories.

``golden_trajectories.npz`` holds, per case, every state (or observation and reward) of a
short seeded flight, recorded from the engine on purpose.  A change to the engine that is
meant to keep the physics must keep every trajectory; a change meant to alter it records
them again, saying why in its commit::

    python -m tests.engine.test_golden_trajectories --write

**What is compared, and how closely.**  Each value must agree with the recording within
``|got - recorded| <= TOLERANCE * (1 + |recorded|)``, over the recorded horizon (2 s of
flight; the envs' first 60 steps of three episodes), which ends before the flights turn
chaotic.  ``TOLERANCE`` comes from measurement (``experiments/golden_tolerance.py``,
``experiments/results/golden_tolerance.md``), over every case:

* rounding: a start one unit in the last place apart grows to at most ~4e-9 over the
  horizon (a motor throttle near zero, through a square root); the same flights computed
  with other floating-point kernels (other OpenBLAS kernel sets, NumPy without its AVX2
  paths) differed by at most ~5e-9 while the engine still went through BLAS, and are
  bit-identical since it does not;
* a real change: one motor constant (a rocket: the booster's thrust) changed by 1 part in
  10^6 moves every trajectory by 1.5e-7 or more
  (``test_a_change_of_one_part_in_a_million_is_caught``).

``TOLERANCE = 3e-8`` sits between the two (about 6x above the largest rounding, 5x below
the smallest change), so this test passes on any CPU and still catches a change of the
model.  Bit-identity is not required here: the numbers are meant to be bit-identical on
every x86_64 CPU with AVX2 (``docs/reproducibility.md``), which
``tests/engine/test_numeric_kernels.py`` checks under emulated kernel sets.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).with_name("golden_trajectories.npz")
AGENT_STEPS = 60  # 2 s at 30 Hz
ENV_EPISODES, ENV_STEPS = 3, 60
#: the agreement required, relative to 1 + |recorded| (see the module docstring)
TOLERANCE = 3e-8
MULTIROTOR_SETPOINTS = {  # per mode: a setpoint that moves the vehicle without flipping it
    "motors": None,  # per airframe: the hover throttle, a little uneven
    "rates_thrust": [0.3, -0.2, 0.1, None],  # thrust: the hover fraction
    "attitude_vz": [0.1, -0.05, 0.2, 0.3],
    "rates_z": [0.2, 0.1, -0.1, 2.5],
    "attitude_z": [-0.1, 0.1, 0.3, 2.5],
    "heading_velocity_z": [0.5, -0.3, 0.2, 2.5],
    "heading_velocity_vz": [0.5, 0.3, -0.2, 0.2],
    "velocity_yawrate": [0.4, -0.4, 0.3, -0.1],
    "position_yaw": [0.5, -0.5, 0.4, 2.5],
    "velocity_yaw": [-0.3, 0.5, -0.4, 0.2],
    "position_yawrate": [-0.5, 0.3, 0.3, 1.5],
}
ENVS = [
    "PyFlyt/QuadX-Hover-v0",
    "PyFlyt/QuadX-Waypoints-v0",
    "PyFlyt/Fixedwing-Waypoints-v0",
    "PyFlyt/Rocket-Landing-v0",
]


def _state_row(vehicle) -> list[float]:
    s = vehicle.state
    return [*s.lin_pos, *s.quaternion, *s.lin_vel, *s.ang_vel, *vehicle.aux_state]


def fly(uav: str, mode: str, spec=None, nudge: bool = False) -> np.ndarray:
    """Fly ``uav`` (or ``spec``, a variant of it) in ``mode`` for 2 s from a fixed start,
    motor noise on (seed 0): every state, one row per agent step.  ``nudge`` starts one
    unit in the last place higher (a rounding-sized difference, to measure its growth)."""
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.world import World

    spec = spec if spec is not None else load_uav_spec(uav)
    fixedwing = spec.control.type == "fixedwing" or (spec.control.type == "none" and not spec.boosters)
    world = World(seed=0)
    height = 2.0 if not spec.boosters else 5.0
    height = float(np.nextafter(height, np.inf)) if nudge else height
    index = world.add_vehicle(spec, (0.0, 0.0, height), (0.0, 0.0, 0.0), mode=mode)
    vehicle = world.vehicles[index]
    world.reset(seed=0)
    if fixedwing:  # at cruise speed
        vehicle.reset(lin_vel=(18.0, 0.0, 0.0))
    channels = vehicle.parts.channels
    low, high = vehicle.parts.channel_low, vehicle.parts.channel_high
    rng = np.random.default_rng(len(uav) * 31 + len(mode))
    rows = []
    for step in range(AGENT_STEPS):
        if mode == "channels":  # a sine per channel
            phases = [0.5 + 0.3 * math.sin(0.2 * step + k) for k in range(len(channels))]
            setpoint = low + (high - low) * np.asarray(phases)
        elif mode == "attitude_airspeed":
            setpoint = np.array([0.2 * math.sin(0.1 * step), 0.05, 0.1, 18.0])
        else:
            head = MULTIROTOR_SETPOINTS[mode]
            if head is None:
                n = len(vehicle.parts.mixer_motors)
                head = list(vehicle.hover_throttle() * (1.0 + 0.05 * rng.uniform(-1, 1, n)))
                head += [0.1] * len(vehicle.parts.mixer_tilts)  # servos the mixer flies (tricopter tail)
            elif head[3] is None:
                head = [*head[:3], vehicle.hover_throttle() ** 2 * 1.05]
            extra = low + (high - low) * 0.5 if len(channels) else np.zeros(0)
            setpoint = np.concatenate([head, extra])
        vehicle.set_setpoint(setpoint)
        world.step()
        rows.append(_state_row(vehicle))
    world.close()
    return np.asarray(rows, dtype=np.float64)


def run_env(env_id: str, nudge: bool = False) -> np.ndarray:
    """The first 60 steps of three seeded episodes of seeded random actions: one row per
    step, the observation's attitude part, the reward and the end flags.  ``nudge`` moves
    the first action one unit in the last place (a rounding-sized difference)."""
    import gymnasium

    import pyflyt_engine  # noqa: F401 - registers the ids

    env = gymnasium.make(env_id)
    env.action_space.seed(0)
    rows = []
    for episode in range(ENV_EPISODES):
        obs, _ = env.reset(seed=episode)
        for step in range(ENV_STEPS):
            action = env.action_space.sample()
            if nudge and episode == 0 and step == 0:
                action = np.array(action, dtype=np.float64)
                action[0] = np.nextafter(action[0], np.inf)
            obs, reward, terminated, truncated, _ = env.step(action)
            attitude = obs["attitude"] if isinstance(obs, dict) else obs
            rows.append([*np.ravel(attitude), reward, float(terminated), float(truncated)])
            if terminated or truncated:
                break
    env.close()
    width = max(len(r) for r in rows)
    return np.asarray([r + [np.nan] * (width - len(r)) for r in rows], dtype=np.float64)


def cases() -> list[tuple[str, str]]:
    """(kind, name) of every case: ("fly", "<uav>/<mode>") and ("env", "<id>")."""
    from pyflyt_engine.control.fixedwing import FIXEDWING_MODES
    from pyflyt_engine.control.modes import MULTIROTOR_MODES
    from pyflyt_engine.spec import available_uavs, load_uav_spec

    out = []
    for uav in available_uavs():
        kind = load_uav_spec(uav).control.type
        modes = MULTIROTOR_MODES if kind == "multirotor" else FIXEDWING_MODES if kind == "fixedwing" else ["channels"]
        out += [("fly", f"{uav}/{mode}") for mode in modes]
    return out + [("env", env_id) for env_id in ENVS]


def compute(kind: str, name: str, nudge: bool = False) -> np.ndarray:
    return fly(*name.split("/"), nudge=nudge) if kind == "fly" else run_env(name, nudge=nudge)


def deviation(got: np.ndarray, recorded: np.ndarray) -> float:
    """The largest ``|got - recorded| / (1 + |recorded|)``; inf if the shapes or the NaN
    pattern (an episode ending at another step) differ."""
    got, recorded = np.asarray(got, dtype=np.float64), np.asarray(recorded, dtype=np.float64)
    if got.shape != recorded.shape or not np.array_equal(np.isnan(got), np.isnan(recorded)):
        return float("inf")
    if got.size == 0:
        return 0.0
    d = np.abs(got - recorded) / (1.0 + np.abs(recorded))
    return float(np.nanmax(d)) if np.isfinite(d[~np.isnan(d)]).all() else float("inf")


def _golden() -> dict[str, np.ndarray]:
    if not GOLDEN.is_file():
        pytest.fail(f"{GOLDEN} is missing: record it with python -m tests.engine.test_golden_trajectories --write")
    with np.load(GOLDEN, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


@pytest.mark.parametrize(("kind", "name"), cases(), ids=lambda v: str(v))
def test_trajectory_matches_the_recorded_one(kind, name):
    recorded = _golden()
    key = f"{kind}:{name}"
    assert key in recorded, f"no recorded trajectory for {key}: record the file on purpose (see the module docstring)"
    got = compute(kind, name)
    worst = deviation(got, recorded[key])
    assert worst <= TOLERANCE, (
        f"{key}: deviates from the recorded trajectory by {worst:.3g} (relative to 1 + |value|; "
        f"allowed {TOLERANCE:g}): the engine's physics changed"
    )


def test_every_recorded_case_still_exists():
    assert set(_golden()) == {f"{kind}:{name}" for kind, name in cases()}


def perturbed(uav: str, factor: float = 1 + 1e-6):
    """``uav`` with its motors' k_F (a rocket: its boosters' full thrust) times ``factor``."""
    from tests.conftest import spec_dict, spec_variant

    data = spec_dict(uav)
    group, key = ("motors", "kf") if "motors" in data else ("boosters", "max_thrust")
    value = data[group][key]
    scaled = [v * factor for v in value] if isinstance(value, list) else value * factor
    return spec_variant(uav, **{f"{group}.{key}": scaled})


@pytest.mark.parametrize(
    ("uav", "mode"),
    [
        ("quadx_cf2x", "position_yaw"),
        ("quadx_f450", "motors"),
        ("fixedwing", "attitude_airspeed"),
        ("rocket", "channels"),
    ],
)
def test_a_change_of_one_part_in_a_million_is_caught(uav, mode):
    """The tolerance is tight enough to see a model change far below any that matters."""
    recorded = _golden()[f"fly:{uav}/{mode}"]
    assert deviation(fly(uav, mode, spec=perturbed(uav)), recorded) > TOLERANCE
    assert deviation(fly(uav, mode), recorded) <= TOLERANCE


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python -m tests.engine.test_golden_trajectories --write")
    import pyflyt_engine  # noqa: F401 - pins the numeric kernels first

    recorded = {f"{kind}:{name}": compute(kind, name) for kind, name in cases()}
    np.savez_compressed(GOLDEN, **recorded)
    print(f"wrote {len(recorded)} trajectories to {GOLDEN}")
