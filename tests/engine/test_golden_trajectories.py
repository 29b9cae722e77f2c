"""Every shipped airframe in every flight mode, and the four paper envs, fly bit-identical trajectories.

The hashes in ``golden_trajectories.json`` were recorded from the engine as it was
before a refactor; a change to the engine that is meant to keep the physics must keep
every hash.  A change that is meant to alter the physics regenerates them, on purpose
and saying why in its commit::

    python -m tests.engine.test_golden_trajectories --write

Floating-point results depend on the platform (the C library's maths, PyBullet's and
NumPy's builds), so the file records where it was made; on another platform the
comparison is skipped, with the reason.
"""

from __future__ import annotations

import hashlib
import json
import platform
import sys
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).with_name("golden_trajectories.json")
AGENT_STEPS = 60  # 2 s at 30 Hz
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
ENVS = ["PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0", "PyFlyt/Fixedwing-Waypoints-v0", "PyFlyt/Rocket-Landing-v0"]


def fingerprint() -> dict[str, str]:
    """What floating-point results may depend on besides the code."""
    from importlib import metadata

    libc, libc_version = platform.libc_ver()
    return {
        "machine": platform.machine(),
        "libc": f"{libc} {libc_version}",
        "numpy": np.__version__,
        "pybullet": metadata.version("pybullet"),
    }


def _digest(rows: list) -> str:
    return hashlib.sha256(np.asarray(rows, dtype=np.float64).tobytes()).hexdigest()


def _state_row(vehicle) -> list[float]:
    s = vehicle.state
    return [*s.lin_pos, *s.quaternion, *s.lin_vel, *s.ang_vel, *vehicle.aux_state]


def _fly(uav: str, mode: str) -> str:
    """Fly ``uav`` in ``mode`` for 2 s from a fixed start, motor noise on (seed 0); hash every state."""
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.world import World

    spec = load_uav_spec(uav)
    fixedwing = spec.control.type == "fixedwing" or (spec.control.type == "none" and not spec.boosters)
    world = World(seed=0)
    index = world.add_vehicle(spec, (0.0, 0.0, 2.0 if not spec.boosters else 5.0), (0.0, 0.0, 0.0), mode=mode)
    vehicle = world.vehicles[index]
    world.reset(seed=0)
    if fixedwing:  # at cruise speed
        vehicle.reset(lin_vel=(18.0, 0.0, 0.0))
    channels = vehicle.parts.channels
    low, high = vehicle.parts.channel_low, vehicle.parts.channel_high
    rng = np.random.default_rng(len(uav) * 31 + len(mode))
    rows = []
    for step in range(AGENT_STEPS):
        if mode == "channels":
            setpoint = low + (high - low) * (0.5 + 0.3 * np.sin(0.2 * step + np.arange(len(channels))))
        elif mode == "attitude_airspeed":
            setpoint = np.array([0.2 * np.sin(0.1 * step), 0.05, 0.1, 18.0])
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
    return _digest(rows)


def _run_env(env_id: str) -> str:
    """Three seeded episodes of seeded random actions (at most 150 steps each); hash observations and rewards."""
    import gymnasium

    import pyflyt_engine  # noqa: F401 - registers the ids

    env = gymnasium.make(env_id)
    env.action_space.seed(0)
    rows = []
    for episode in range(3):
        obs, _ = env.reset(seed=episode)
        for _ in range(150):
            obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            attitude = obs["attitude"] if isinstance(obs, dict) else obs
            rows.append([*np.ravel(attitude), reward, float(terminated), float(truncated)])
            if terminated or truncated:
                break
    env.close()
    return _digest(rows)


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


def compute(kind: str, name: str) -> str:
    return _fly(*name.split("/")) if kind == "fly" else _run_env(name)


def _golden() -> dict:
    if not GOLDEN.is_file():
        pytest.fail(f"{GOLDEN} is missing: generate it with python -m tests.engine.test_golden_trajectories --write")
    data = json.loads(GOLDEN.read_text())
    if data["fingerprint"] != fingerprint():
        pytest.skip(f"golden hashes were recorded on {data['fingerprint']}; this platform is {fingerprint()}")
    return data["hashes"]


@pytest.mark.parametrize(("kind", "name"), cases(), ids=lambda v: str(v))
def test_trajectory_is_bit_identical_to_the_recorded_one(kind, name):
    hashes = _golden()
    key = f"{kind}:{name}"
    assert key in hashes, f"no recorded hash for {key}: regenerate the file on purpose (see the module docstring)"
    assert compute(kind, name) == hashes[key]


def test_every_recorded_case_still_exists():
    hashes = _golden()
    assert set(hashes) == {f"{kind}:{name}" for kind, name in cases()}


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python -m tests.engine.test_golden_trajectories --write")
    recorded = {f"{kind}:{name}": compute(kind, name) for kind, name in cases()}
    GOLDEN.write_text(json.dumps({"fingerprint": fingerprint(), "hashes": recorded}, indent=1, sort_keys=True) + "\n")
    print(f"wrote {len(recorded)} hashes to {GOLDEN}")
