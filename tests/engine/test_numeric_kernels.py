"""No simulated number depends on the CPU's numeric kernels.

NumPy's OpenBLAS picks its kernels by CPU at run time, and NumPy its own SIMD loops
(on AVX-512 machines, SVML-based ``sin``, ``exp``, ``arccos`` ... in float64).  The
physics, the tasks and the observations must go through neither, or the same seed
would fly a different trajectory on another machine (``docs/reproducibility.md``, "Why
the physics does not depend on the CPU").

* :func:`test_trajectories_do_not_change_under_another_cpus_kernels` flies a
  representative set of cases in two subprocesses, one as this machine runs them and
  one under another CPU's kernels (``OPENBLAS_CORETYPE=Prescott`` and
  ``NPY_DISABLE_CPU_FEATURES=X86_V3``; ``PYFLYT_NUMERICS=native`` so that nothing pins
  them back), and requires bit-identical hashes.
* :func:`test_nothing_on_the_simulated_path_calls_cpu_dispatched_numpy` replaces NumPy's
  transcendental functions, its matrix products and ``np.linalg`` / ``scipy.linalg`` by
  functions that fail on float64 input, then builds and flies every airframe in every
  mode and steps every environment: the AVX-512 loops, which cannot be emulated on a
  machine without AVX-512, are thereby shown to be off the simulated path too.  (The
  ``@`` operator cannot be replaced this way; the first test covers it.)

``python experiments/kernel_independence.py`` runs the full comparison (every case of
the golden trajectories and more, under more emulated CPUs).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

#: another CPU's kernels: OpenBLAS's Prescott (Katmai) kernels, NumPy's baseline (SSE4.2) loops
EMULATED = {"OPENBLAS_CORETYPE": "Prescott", "NPY_DISABLE_CPU_FEATURES": "X86_V3"}

#: every airframe in one controller mode and in its raw mode, then environments
CASES: list[str] = [
    "fly:quadx_cf2x/position_yaw",
    "fly:quadx_cf2x/motors",
    "fly:quadx_f450/velocity_yaw",
    "fly:quadx_f450/motors",
    "fly:hexacopter/attitude_z",
    "fly:hexacopter/motors",
    "fly:tricopter/position_yaw",
    "fly:tricopter/motors",
    "fly:quadplane/heading_velocity_z",
    "fly:quadplane/motors",
    "fly:fixedwing/attitude_airspeed",
    "fly:fixedwing/channels",
    "fly:flying_wing/attitude_airspeed",
    "fly:flying_wing/channels",
    "fly:rocket/channels",
    "fly:rocket/velocity",
    "fly:rocket/attitude_thrust",
    "gym:PyFlyt/QuadX-Hover-v0",
    "gym:PyFlyt/QuadX-Waypoints-v0",
    "gym:PyFlyt/Fixedwing-Waypoints-v0",
    "gym:PyFlyt/Rocket-Landing-v0",
    "gym:PyFlyt/QuadX-Hover-v0?wind=dryden_moderate",
    "gym:PyFlyt/QuadX-Waypoints-v0?randomize=moderate",
    "gym:PyFlyt/QuadX-Hover-v0?randomize=sim2real",  # airframe factors and randomised delays
    "ma:ma_quadx_hover_v0?downwash=true&wind=dryden_light",
    "ma:ma_quadx_formation_v0?agents=9&layout_spacing=0.5",
    # the noisy sensors (components/sensors.py) in the observation, their scale randomised
    'gym:PyFlyt/QuadX-Hover-v0?uav=conf/uav/examples/quadx_cf2x_sensors.yaml&sensors={"observe": true}'
    '&randomize={"gyro_scale": {"distribution": "uniform", "low": 0.9, "high": 1.1}}',
    # the flight controller's estimator (components/estimator.py) building the observation
    "gym:PyFlyt/QuadX-Waypoints-v0?uav=conf/uav/examples/quadx_cf2x_sensors.yaml"
    '&sensors={"observe": true, "estimator": "complementary"}',
]

MULTIROTOR_SETPOINTS = {
    "position_yaw": [0.5, -0.5, 0.4, 2.5],
    "velocity_yaw": [-0.3, 0.5, -0.4, 0.2],
    "attitude_z": [-0.1, 0.1, 0.3, 2.5],
    "heading_velocity_z": [0.5, -0.3, 0.2, 2.5],
}

#: the rocket autopilot's modes, from 5 m with a full tank (it can hover)
ROCKET_SETPOINTS = {
    "velocity": [0.5, -0.3, 0.5, 1.0],
    "attitude_thrust": [0.05, -0.05, 0.1, 0.6, 1.0],
}


# ---------------------------------------------------------------- trajectories


def _fly(uav: str, mode: str, steps: int = 60) -> list[list[float]]:
    """Fly ``uav`` in ``mode`` for ``steps`` agent steps of 1/30 s from a fixed start (noise on, seed 0)."""
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.world import World

    spec = load_uav_spec(uav)
    world = World(seed=0)
    index = world.add_vehicle(spec, (0.0, 0.0, 5.0 if spec.boosters else 2.0), (0.0, 0.0, 0.0), mode=mode)
    vehicle = world.vehicles[index]
    world.reset(seed=0)
    if spec.control.type == "fixedwing" or (spec.control.type == "none" and not spec.boosters):
        vehicle.reset(lin_vel=(18.0, 0.0, 0.0))
    low, high = vehicle.parts.channel_low.tolist(), vehicle.parts.channel_high.tolist()
    middle = [lo + 0.5 * (hi - lo) for lo, hi in zip(low, high)]
    rows = []
    for step in range(steps):
        if mode == "channels":
            setpoint = [
                lo + (hi - lo) * (0.5 + 0.3 * math.sin(0.2 * step + k)) for k, (lo, hi) in enumerate(zip(low, high))
            ]
        elif mode == "attitude_airspeed":
            setpoint = [0.2 * math.sin(0.1 * step), 0.05, 0.1, 18.0]
        elif mode in ROCKET_SETPOINTS:
            setpoint = ROCKET_SETPOINTS[mode]
        elif mode == "motors":
            hover = vehicle.hover_throttle()
            n = len(vehicle.parts.mixer_motors)
            setpoint = [hover * (1.0 + 0.05 * math.sin(step + k)) for k in range(n)]
            setpoint += [0.1] * len(vehicle.parts.mixer_tilts) + middle
        else:
            setpoint = MULTIROTOR_SETPOINTS[mode] + middle
        vehicle.set_setpoint(setpoint)
        world.step()
        s = vehicle.state
        rows.append([*s.lin_pos, *s.quaternion, *s.lin_vel, *s.ang_vel, *vehicle.aux_state.tolist()])
    world.close()
    return rows


def _options(query: str) -> dict:
    out: dict = {}
    for item in filter(None, query.split("&")):
        key, _, value = item.partition("=")
        out[key] = json.loads(value) if value.startswith("{") else {"true": True, "false": False}.get(value, value)
    return out


def _flat(observation) -> list[float]:
    if isinstance(observation, dict):
        return [v for key in sorted(observation) for v in _flat(observation[key])]
    return np.asarray(observation, dtype=np.float64).ravel().tolist()


def _gym(env_id: str, options: dict, episodes: int = 2, steps: int = 120) -> list[list[float]]:
    """Seeded episodes of seeded random actions; every observation entry, reward and flag."""
    import gymnasium

    import pyflyt_engine  # noqa: F401  (registers the ids)

    env = gymnasium.make(env_id, **options)
    env.action_space.seed(0)
    rows = []
    for episode in range(episodes):
        observation, _ = env.reset(seed=episode)
        rows.append(_flat(observation))
        for _ in range(steps):
            observation, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            rows.append([*_flat(observation), reward, float(terminated), float(truncated)])
            if terminated or truncated:
                break
    env.close()
    return rows


def _ma(name: str, options: dict, steps: int = 90) -> list[list[float]]:
    """One seeded episode of a PettingZoo parallel env under seeded random actions."""
    import importlib

    env = importlib.import_module(f"pyflyt_engine.envs.multi_agent.{name}").parallel_env(**options)
    observations, _ = env.reset(seed=0)
    rows = [_flat(observations[a]) for a in sorted(observations)]
    for step in range(steps):
        if not env.agents:
            break
        actions = {}
        for k, agent in enumerate(sorted(env.agents)):
            space = env.action_space(agent)
            space.seed(10 * step + k)
            actions[agent] = space.sample()
        observations, rewards, terminations, truncations, _ = env.step(actions)
        for a in sorted(observations):
            rows.append([*_flat(observations[a]), rewards[a], float(terminations[a]), float(truncations[a])])
    env.close()
    return rows


def trajectory_hash(case: str) -> str:
    """SHA-256 of the float64 rows of one case of :data:`CASES`."""
    kind, _, rest = case.partition(":")
    name, _, query = rest.partition("?")
    if kind == "fly":
        rows = _fly(*name.split("/"))
    elif kind == "gym":
        rows = _gym(name, _options(query))
    else:
        rows = _ma(name, _options(query))
    digest = hashlib.sha256()
    for row in rows:
        digest.update(np.asarray(row, dtype=np.float64).tobytes())
    return digest.hexdigest()


def _hashes_in_subprocess(extra_env: dict[str, str]) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k not in EMULATED}
    env.update(extra_env)
    env["PYFLYT_NUMERICS"] = "native"
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    code = (
        "import json, sys\n"
        "from tests.engine.test_numeric_kernels import CASES, trajectory_hash\n"
        "print(json.dumps({case: trajectory_hash(case) for case in CASES}))\n"
    )
    return subprocess.Popen(
        [sys.executable, "-c", code], cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def test_trajectories_do_not_change_under_another_cpus_kernels():
    runs = {"this CPU": _hashes_in_subprocess({}), "emulated": _hashes_in_subprocess(EMULATED)}
    hashes = {}
    for label, process in runs.items():
        out, err = process.communicate(timeout=600)
        assert process.returncode == 0, f"{label}: {err[-3000:]}"
        hashes[label] = json.loads(out.strip().splitlines()[-1])
    differ = [case for case in CASES if hashes["this CPU"][case] != hashes["emulated"][case]]
    assert not differ, f"these trajectories depend on the CPU's numeric kernels ({EMULATED}): {differ}"


# ------------------------------------------------------------------- the guard

#: NumPy functions whose float64 result may come from CPU-dispatched loops (SVML on
#: AVX-512) or from BLAS
GUARDED_NUMPY = (
    "sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "exp", "expm1", "exp2", "log", "log1p",
    "log2", "log10", "power", "tanh", "sinh", "cosh", "cbrt", "float_power",
    "dot", "vdot", "inner", "matmul", "tensordot", "einsum",
)  # fmt: skip


def _is_float64(value) -> bool:
    if isinstance(value, (list, tuple)):
        return any(_is_float64(v) for v in value)
    if isinstance(value, (float, np.floating, np.ndarray)):
        return np.asarray(value).dtype == np.float64
    return False


def _guarded(name: str, function):
    def guard(*args, **kwargs):
        if any(_is_float64(a) for a in (*args, *kwargs.values())):
            raise AssertionError(f"{name} called with float64 input on the simulated path")
        return function(*args, **kwargs)

    return guard


def _import_everything() -> None:
    """Import every engine module (and so the libraries they import) before the guard goes up:
    libraries compute constants with NumPy at import time, which is not the simulated path."""
    import importlib
    import pkgutil

    import pyflyt_engine

    for module in pkgutil.walk_packages(pyflyt_engine.__path__, "pyflyt_engine."):
        importlib.import_module(module.name)
    # and what the engine imports only when it needs it (the Dryden process: scipy.signal)
    import scipy.signal  # noqa: F401


def _guard_numerics(monkeypatch: pytest.MonkeyPatch) -> None:
    import scipy.linalg

    for name in GUARDED_NUMPY:
        monkeypatch.setattr(np, name, _guarded(f"np.{name}", getattr(np, name)))
    for name in dir(np.linalg):
        function = getattr(np.linalg, name)
        if callable(function) and not name.startswith("_") and not isinstance(function, type):
            monkeypatch.setattr(np.linalg, name, _guarded(f"np.linalg.{name}", function))
    for name in dir(scipy.linalg):
        function = getattr(scipy.linalg, name)
        if callable(function) and not name.startswith("_") and not isinstance(function, type):
            monkeypatch.setattr(scipy.linalg, name, _guarded(f"scipy.linalg.{name}", function))


def _fly_every_mode(uav: str) -> None:
    from pyflyt_engine.control.fixedwing import FIXEDWING_MODES
    from pyflyt_engine.control.modes import MULTIROTOR_MODES
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.world import World

    spec = load_uav_spec(uav)
    kind = spec.control.type
    world = World(seed=1, wind="dryden_light", ground_effect=True)
    vehicle = world.vehicles[world.add_vehicle(spec, (0.0, 0.0, 3.0), (0.0, 0.0, 0.0))]
    modes = {"multirotor": list(MULTIROTOR_MODES), "fixedwing": list(FIXEDWING_MODES)}.get(kind, ["channels"])
    modes += [m for m in vehicle.mode_names if m not in modes]  # e.g. the rocket autopilot's
    world.reset(seed=1)
    for mode in modes:
        vehicle.set_mode(mode)
        vehicle.set_setpoint([0.1] * vehicle.setpoint.size)
        for _ in range(3):
            world.step()
        assert all(math.isfinite(v) for v in vehicle.state.lin_pos)
    world.close()


def _step_env(env_id: str, **options) -> None:
    import gymnasium

    import pyflyt_engine  # noqa: F401  (registers the ids)

    env = gymnasium.make(env_id, disable_env_checker=True, **options)
    env.reset(seed=0)
    low, high = env.action_space.low, env.action_space.high
    for k in range(4):
        action = [lo + (hi - lo) * (0.3 + 0.1 * k) for lo, hi in zip(low.tolist(), high.tolist())]
        env.step(np.asarray(action, dtype=env.action_space.dtype))
    env.close()


def _step_ma(name: str, **options) -> None:
    import importlib

    env = importlib.import_module(f"pyflyt_engine.envs.multi_agent.{name}").parallel_env(**options)
    env.reset(seed=0)
    for _ in range(4):
        actions = {}
        for agent in env.agents:
            space = env.action_space(agent)
            actions[agent] = np.asarray(0.5 * (space.low + space.high) + 0.1 * (space.high - space.low))
        env.step(actions)
    env.close()


def test_nothing_on_the_simulated_path_calls_cpu_dispatched_numpy(monkeypatch):
    from pyflyt_engine.envs import ENVS
    from pyflyt_engine.envs.oracles import make_oracle
    from pyflyt_engine.spec import available_uavs

    _import_everything()
    _guard_numerics(monkeypatch)
    for uav in available_uavs():
        _fly_every_mode(uav)
    for env_id in ENVS:
        _step_env(env_id)
    _step_env("PyFlyt/QuadX-Hover-v0", wind="gust", randomize="moderate", ground_effect=True)
    _step_env("PyFlyt/Fixedwing-Waypoints-v0", wind="dryden_severe", randomize="moderate")
    _step_env("PyFlyt/Rocket-Landing-v0", wind="shear", randomize="moderate")
    _step_env(
        "PyFlyt/QuadX-Hover-v0",
        uav=str(ROOT / "conf" / "uav" / "examples" / "quadx_cf2x_sensors.yaml"),
        sensors={"observe": True},
        randomize={"gyro_scale": {"distribution": "uniform", "low": 0.9, "high": 1.1}},
    )
    _step_env(
        "PyFlyt/QuadX-Hover-v0",
        uav=str(ROOT / "conf" / "uav" / "examples" / "quadx_cf2x_sensors.yaml"),
        sensors={"observe": True, "estimator": "complementary"},
        angle_representation="euler",
    )
    _step_env("PyFlyt/QuadX-Hover-v0", randomize="sim2real")  # with randomised delays
    _step_ma("ma_quadx_hover_v0", downwash=True, wind="dryden_moderate")
    _step_ma("ma_quadx_hover_v0", randomize="sim2real")
    _step_ma("ma_fixedwing_dogfight_v0", wind="dryden_light")
    _step_ma("ma_quadx_formation_v0", agents=9, layout_spacing=0.5)

    import gymnasium

    env = gymnasium.make("PyFlyt/Rocket-Landing-v0", disable_env_checker=True)
    observation, _ = env.reset(seed=0)
    oracle = make_oracle("rocket_lander", env)
    for _ in range(5):
        observation, *_ = env.step(oracle(observation).astype(env.action_space.dtype))
    env.close()
    env = gymnasium.make("PyFlyt/Rocket-Landing-Velocity-v0", disable_env_checker=True)
    observation, _ = env.reset(seed=0)
    oracle = make_oracle("rocket_velocity_lander", env)
    for _ in range(5):
        observation, *_ = env.step(oracle(observation).astype(env.action_space.dtype))
    env.close()
