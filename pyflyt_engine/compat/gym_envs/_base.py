"""What every reference-shaped single-agent env shares.

Each env of :mod:`pyflyt_engine.compat.gym_envs` is a native env class (same loop, same
task, same reward presets) built from its shipped config with the reference's defaults
written into it; the few things a config cannot say are done here, in thin overrides:

* the thrust of flight mode 0 is a motor command in the reference and a fraction of the
  full collective thrust here: :class:`_PwmThrust` maps it (quadratic, matched at hover)
  on its way to the vehicle;
* ``rgb_array`` frames carry an alpha channel, (H, W, 4), as the reference's;
* info keys are the reference's (``fatal_collision`` for the rocket), without
  ``reward_terms``;
* a waypoint run that reaches its last target ends *truncated*, as in the reference.

Facts about the reference are cited as "PyFlyt 0.29.0 <class>: ...".
"""

from __future__ import annotations

import logging
import math
import os
import sys
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from pyflyt_engine.envs.config import load_env_config

#: PyFlyt 0.29.0 QuadXBaseEnv/FixedwingBaseEnv/RocketBaseEnv: one Aviary step is 1/120 s
#: and agent_hz must divide 120.
REFERENCE_STEP_HZ = 120

#: PyFlyt 0.29.0 QuadXBaseEnv: body-rate bound pi rad/s, thrust and motor bound 0.8.
QUADX_RATE_LIMIT = math.pi

#: PyFlyt 0.29.0 QuadXBaseEnv/FixedwingBaseEnv/RocketBaseEnv ``end_reset``: Aviary steps before the first observation
SETTLE_STEPS = 10
QUADX_THRUST_LIMIT = 0.8


def check_agent_hz(agent_hz: int) -> None:
    """The reference's check: ``agent_hz`` must divide 120 (ValueError naming the nearest that do)."""
    if agent_hz <= 0 or REFERENCE_STEP_HZ % agent_hz != 0:
        lowest = int(REFERENCE_STEP_HZ / (int(REFERENCE_STEP_HZ / agent_hz) + 1)) if agent_hz > 0 else 1
        highest = int(REFERENCE_STEP_HZ / max(int(REFERENCE_STEP_HZ / agent_hz), 1)) if agent_hz > 0 else 120
        raise ValueError(f"`agent_hz` must be a whole divisor of 120, try {lowest} or {highest}.")


def check_angle_representation(angle_representation: str) -> None:
    if angle_representation not in ("euler", "quaternion"):
        raise ValueError(f"angle_representation must be either `euler` or `quaternion`, not {angle_representation}")


def check_render_mode(render_mode: str | None) -> None:
    if render_mode and render_mode not in ("human", "rgb_array"):
        raise ValueError(f"Invalid render mode {render_mode}, only ['human', 'rgb_array'] allowed.")


def headless_render_mode(render_mode: str | None) -> str | None:
    """The render mode to build the native env with.

    ``"human"`` opens a PyBullet GUI window; without a display PyBullet ends the whole
    process when asked for one.  Gymnasium's ``check_env`` builds every declared render
    mode, so there ``"human"`` draws headless instead (frames as ``rgb_array``; no window),
    and says so in the log.
    """
    if render_mode == "human" and sys.platform.startswith("linux"):
        if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            logging.getLogger(__name__).warning("render_mode='human' without a display: drawing headless, no window")
            return "rgb_array"
    return render_mode


def native_config(name: str) -> dict[str, Any]:
    """A shipped env config (``conf/env/<name>.yaml``) as a plain mapping to adjust."""
    return load_env_config(name).model_dump(exclude={"source"})


def quadx_action(flight_mode: int) -> dict[str, Any]:
    """The action section for a reference QuadX flight mode number.

    PyFlyt 0.29.0 QuadXBaseEnv: mode -1 takes four motor commands in [0, 0.8]; every other
    mode takes four values bounded by [-pi, -pi, -pi, 0] and [pi, pi, pi, 0.8].
    """
    from pyflyt_engine.control.modes import resolve_mode
    from pyflyt_engine.errors import ConfigError

    try:
        mode = resolve_mode(int(flight_mode))
    except (ConfigError, TypeError, ValueError):
        raise ValueError(f"`flight_mode` must be between -1 and 7, got {flight_mode}") from None
    if mode.name == "motors":
        return {
            "mode": "motors",
            "names": ["motor_1", "motor_2", "motor_3", "motor_4"],
            "units": ["1"] * 4,
            "low": [0.0] * 4,
            "high": [QUADX_THRUST_LIMIT] * 4,
        }
    r = QUADX_RATE_LIMIT
    return {
        "mode": mode.name,
        "names": list(mode.setpoint),
        "units": None,
        "low": [-r, -r, -r, 0.0],
        "high": [r, r, r, QUADX_THRUST_LIMIT],
    }


#: the mode-0 thrust command at which the reference's QuadX (cf2x) hovers: 0.300, measured
#: on PyFlyt 0.29.0 QuadX-Hover-v4 (constant command, level; the vertical acceleration
#: fitted over 1 to 2.5 s goes through zero at 0.300, +0.36 m/s^2 at 0.305, +0.90 at
#: 0.3125); its motor noise is biased upwards, so this is not sqrt(weight / max thrust)
REFERENCE_QUADX_HOVER_COMMAND = 0.300


def thrust_gain(vehicle: Any) -> float:
    """Scale from a reference mode-0 thrust command to this airframe's motor throttle: the
    reference's hover command meets this airframe's hover throttle (1 without a mixer)."""
    try:
        return float(vehicle.hover_throttle()) / REFERENCE_QUADX_HOVER_COMMAND
    except Exception:  # noqa: BLE001 - an airframe without multirotor motors: no scaling
        return 1.0


def command_to_thrust_fraction(command: float, gain: float) -> float:
    """PyFlyt 0.29.0 QuadX mode 0: the thrust entry is a motor command and a motor's thrust goes
    as the square of its command; here the entry is a fraction of the full collective
    thrust.  So ``T`` becomes ``(gain x T)**2`` (negative commands: idle), ``gain`` from
    :func:`thrust_gain`; exact at hover by construction, quadratic around it."""
    t = max(float(command), 0.0) * gain
    return t * t


class _PwmThrust:
    """The vehicle, seen through the reference's meaning of its QuadX commands.

    Mode 0 (``motors=False``): the thrust entry through :func:`command_to_thrust_fraction`.
    Mode -1 (``motors=True``): each motor command times the same gain, so that the
    reference's hover command hovers here too (PyFlyt 0.29.0 Motors: its biased noise
    raises every command's thrust alike).
    """

    __slots__ = ("_vehicle", "_motors", "_gain")

    def __init__(self, vehicle: Any, motors: bool = False) -> None:
        object.__setattr__(self, "_vehicle", vehicle)
        object.__setattr__(self, "_motors", motors)
        object.__setattr__(self, "_gain", thrust_gain(vehicle))

    def set_setpoint(self, setpoint: Any) -> None:
        s = np.array(setpoint, dtype=np.float64)
        if self._motors:
            s = np.clip(s * self._gain, -1.0, 1.0)
        else:
            s[3] = command_to_thrust_fraction(s[3], self._gain)
        self._vehicle.set_setpoint(s)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._vehicle, name)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(self._vehicle, name, value)


def surface_commands_to_channels(setpoint: Any) -> np.ndarray:
    """PyFlyt 0.29.0 Fixedwing mode -1 commands (left aileron, right aileron, horizontal tail,
    vertical tail, main wing, thrust) folded onto the airframe's channels (roll, pitch,
    yaw, thrust): roll = (left - right) / 2, pitch = horizontal tail, yaw = -vertical tail
    (PyFlyt Fixedwing mode 0 drives them as left = roll, right = -roll, tail = pitch,
    vertical tail = -yaw); the main wing's entry has no surface here."""
    la, ra, ht, vt, _mw, thrust = (float(v) for v in setpoint)
    return np.array((0.5 * (la - ra), ht, -vt, thrust))


class ReferenceEnv:
    """Mixin for the compat envs, placed before the native class in the bases."""

    #: the reference's id of this env
    reference_id: ClassVar[str] = ""
    #: waypoint envs: completing the course truncates (PyFlyt 0.29.0 waypoint envs)
    completion_truncates: ClassVar[bool] = False
    #: bound of the target deltas (PyFlyt 0.29.0: 2 x flight_dome_size), or None
    _delta_bound: float | None = None

    def _finish_init(self, render_resolution: tuple[int, int], render_mode: str | None) -> None:
        """After the native ``__init__``: the reference's command meanings, render mode and delta bounds."""
        #: "human" asked for without a display: frames are drawn headless
        self._headless_human = render_mode == "human" and self.render_mode == "rgb_array"
        self.render_mode = render_mode
        self.render_resolution = tuple(render_resolution)
        mode = self.config.action.mode  # type: ignore[attr-defined]
        if mode in ("rates_thrust", "motors"):  # a QuadX in the reference's mode 0 or -1
            self.vehicle = _PwmThrust(self.vehicle, motors=mode == "motors")  # type: ignore[attr-defined]
        space = self.observation_space  # type: ignore[has-type]
        if self._delta_bound is not None and isinstance(space, spaces.Dict):
            feature = space["target_deltas"].feature_space
            b = float(self._delta_bound)
            deltas = spaces.Sequence(spaces.Box(-b, b, shape=feature.shape, dtype=np.float64), stack=True)
            self.observation_space = spaces.Dict({**space.spaces, "target_deltas": deltas})

    def _reference_info(self, info: dict[str, Any]) -> dict[str, Any]:
        return info

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """The native reset, then the reference's settling: PyFlyt 0.29.0 ``*BaseEnv.end_reset``
        runs 10 Aviary steps (1/120 s each) with the flight mode's preset setpoint (idle
        motors, neutral surfaces) before the first observation, so a QuadX starts 3.4 cm
        below its spawn point, falling at 0.8 m/s.  The task is reset on the settled state."""
        _, info = super().reset(seed=seed, options=options or None)  # type: ignore[misc]
        self._after_spawn()
        self._settle()
        state = self.vehicle.state  # type: ignore[attr-defined]
        self.task.reset(state, self.np_random)  # type: ignore[attr-defined]
        if self._markers is not None:  # type: ignore[attr-defined]
            self._markers.show(self.task.markers())  # type: ignore[attr-defined]
        info.update(self.task.info())  # type: ignore[attr-defined]
        return self._observe(0, [state]), self._reference_info(info)  # type: ignore[attr-defined]

    def _after_spawn(self) -> None:
        """Change the spawned state before settling (the rocket's drop velocity)."""

    def _settle(self) -> None:
        world = self.world  # type: ignore[attr-defined]
        per_agent = world.physics_per_agent
        world.physics_per_agent = max(1, int(round(world.physics_hz / REFERENCE_STEP_HZ)))
        try:
            self.vehicle.set_setpoint(np.zeros(self.action_space.shape))  # type: ignore[attr-defined]
            for _ in range(SETTLE_STEPS):
                world.step()
        finally:
            world.physics_per_agent = per_agent

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        observation, reward, terminated, truncated, info = super().step(action)  # type: ignore[misc]
        if self.completion_truncates and info.get("env_complete") and terminated:
            if not (info.get("collision") or info.get("out_of_bounds")):
                terminated, truncated = False, True
        return observation, reward, terminated, truncated, self._reference_info(info)

    def render(self) -> np.ndarray | None:
        """``rgb_array``: an (H, W, 4) uint8 RGBA frame, as the reference's; ``human``: the GUI."""
        if self.render_mode is None:  # type: ignore[attr-defined]
            raise ValueError(
                "Please set `render_mode='human'` or `render_mode='rgb_array'` in init to use this function."
            )
        if self._headless_human:
            self.render_mode = "rgb_array"
        try:
            frame = super().render()  # type: ignore[misc]
        finally:
            self.render_mode = "human" if self._headless_human else self.render_mode
        if frame is None:
            return None
        alpha = np.full(frame.shape[:2] + (1,), 255, dtype=np.uint8)
        return np.concatenate((frame, alpha), axis=-1)


def common_overrides(
    cfg: dict[str, Any],
    *,
    reference_id: str,
    sparse_reward: bool,
    flight_dome_size: float,
    max_duration_seconds: float,
    angle_representation: str,
    agent_hz: int,
    render_mode: str | None,
    render_resolution: tuple[int, int],
) -> dict[str, Any]:
    """``cfg`` with the arguments every reference env takes written in."""
    check_agent_hz(agent_hz)
    check_angle_representation(angle_representation)
    check_render_mode(render_mode)
    cfg["id"] = reference_id
    cfg["agent_hz"] = float(agent_hz)
    cfg["max_duration_seconds"] = float(max_duration_seconds)
    cfg["flight_dome_size"] = float(flight_dome_size)
    cfg["angle_representation"] = angle_representation
    cfg["reward"] = "sparse" if sparse_reward else "dense"
    cfg["render"] = {**cfg["render"], "resolution": (int(render_resolution[0]), int(render_resolution[1]))}
    return cfg


def still_spawn(task: dict[str, Any], position: tuple[float, float, float]) -> None:
    """PyFlyt 0.29.0 QuadXBaseEnv: the vehicle spawns exactly at start_pos, level, at rest."""
    task["start_position"] = tuple(position)
    task["start_position_noise"] = 0.0
    task["start_orientation"] = (0.0, 0.0, 0.0)
    task["start_orientation_noise"] = 0.0
