"""What every reference-shaped single-agent env shares.

Each env of :mod:`pyflyt_engine.compat.gym_envs` is a native env class built from its
shipped config with the reference's defaults written into it (the world: airframe,
payloads, scenery, spawn), with the reference's episode run over it by
:class:`ReferenceEnv` (see there) and the reference's attributes on it:

* the thrust of flight mode 0 is a motor command in the reference and a fraction of the
  full collective thrust here: :class:`_PwmThrust` maps it (quadratic, matched at hover)
  on its way to the vehicle;
* ``rgb_array`` frames carry an alpha channel, (H, W, 4), as the reference's;
* observations, rewards, endings and info keys are the reference's
  (:class:`ReferenceHooks`, and per env in :mod:`.envs`).

Facts about the reference are cited as "PyFlyt 0.29.0 <class>: ...".
"""

from __future__ import annotations

import logging
import math
import os
import sys
from typing import Any, ClassVar, cast

import numpy as np
from gymnasium import spaces

from pyflyt_engine.compat._commands import (  # noqa: F401 - re-exported: the envs' command meanings
    REFERENCE_PRIMITIVE_HOVER_COMMAND,
    REFERENCE_QUADX_HOVER_COMMAND,
    command_to_thrust_fraction,
    surface_commands_to_channels,
    thrust_gain,
)
from pyflyt_engine.envs.config import load_env_config

#: PyFlyt 0.29.0 QuadXBaseEnv/FixedwingBaseEnv/RocketBaseEnv: one Aviary step is 1/120 s
#: and agent_hz must divide 120.
REFERENCE_STEP_HZ = 120

#: PyFlyt 0.29.0 *BaseEnv.metadata["render_fps"], whatever the agent rate
REFERENCE_RENDER_FPS = 30

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


class _PwmThrust:
    """The vehicle, seen through the reference's meaning of its QuadX commands.

    Mode 0 (``motors=False``): the thrust entry through :func:`command_to_thrust_fraction`.
    Mode -1 (``motors=True``): each motor command times the same gain, so that the
    reference's hover command hovers here too (PyFlyt 0.29.0 Motors: its biased noise
    raises every command's thrust alike).
    """

    __slots__ = ("_vehicle", "_motors", "_gain")

    def __init__(
        self, vehicle: Any, motors: bool = False, reference_hover: float = REFERENCE_QUADX_HOVER_COMMAND
    ) -> None:
        object.__setattr__(self, "_vehicle", vehicle)
        object.__setattr__(self, "_motors", motors)
        object.__setattr__(self, "_gain", thrust_gain(vehicle, reference_hover))

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


def fresh(observation: Any) -> Any:
    """A copy of an observation (arrays, or a dict of them): Gymnasium's checker wants no two
    calls to return the same objects, while the reference keeps its ``state`` between them."""
    if isinstance(observation, dict):
        return {k: np.array(v, copy=True) for k, v in observation.items()}
    return np.array(observation, copy=True) if observation is not None else None


class ReferenceHooks:
    """The reference's read-outs and base ending rules, over ``self.env`` (an Aviary).

    Shared by the stock envs below and the base envs of :mod:`._aviary_base` (PyFlyt 0.29.0
    ``*BaseEnv.compute_attitude`` / ``compute_auxiliary`` / ``compute_base_term_trunc_reward``).
    """

    env: Any
    step_count: int
    max_steps: int
    flight_dome_size: float
    reward: float
    termination: bool
    truncation: bool
    info: dict[str, Any]

    def compute_auxiliary(self) -> np.ndarray:
        return self.env.aux_state(0)

    def compute_attitude(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(ang_vel, ang_pos, lin_vel, lin_pos, quaternion)`` of drone 0; the quaternion is
        PyBullet's of the Euler angles, as the reference computes it."""
        from pyflyt_engine.bullet import pybullet as p

        ang_vel, ang_pos, lin_vel, lin_pos = self.env.state(0)
        return ang_vel, ang_pos, lin_vel, lin_pos, np.array(p.getQuaternionFromEuler(ang_pos))

    def _attitude(self, action: np.ndarray, angle_representation: int, attitude: Any = None) -> np.ndarray:
        """[ang_vel, Euler angles | quaternion, lin_vel, lin_pos, action, aux] (PyFlyt 0.29.0 layout);
        ``attitude``: :meth:`compute_attitude`'s tuple when already at hand."""
        ang_vel, ang_pos, lin_vel, lin_pos, quaternion = attitude if attitude is not None else self.compute_attitude()
        angles = ang_pos if angle_representation == 0 else quaternion
        return np.concatenate([ang_vel, angles, lin_vel, lin_pos, action, self.compute_auxiliary()], axis=-1)

    def _crashed(self) -> bool:
        """QuadX and rocket: any contact with the ground plane (``np.any(env.contact_array[env.planeId])``)."""
        return self.env._touches_ground()

    def compute_base_term_trunc_reward(self) -> None:
        """The time limit (``step_count > max_steps``), a crash (reward -100, ``collision``)
        and leaving the dome (reward -100, ``out_of_bounds``)."""
        if self.step_count > self.max_steps:
            self.truncation |= True
        if self._crashed():
            self.reward = -100.0
            self.info["collision"] = True
            self.termination |= True
        if np.linalg.norm(self.env.state(0)[-1]) > self.flight_dome_size:
            self.reward = -100.0
            self.info["out_of_bounds"] = True
            self.termination |= True


class ReferenceEnv(ReferenceHooks):
    """Mixin for the compat envs, placed before the native class in the bases.

    The reference's attributes of the unwrapped env are here: ``env`` (an
    :class:`~pyflyt_engine.compat.core.Aviary` view of the world: ``env.state(0)``,
    ``env.contact_array`` ...), ``start_pos`` / ``start_orn`` (assigning them moves the
    next spawn, as in the reference, whose every reset builds its Aviary there),
    ``step_count``, ``max_steps``, ``env_step_ratio``, ``flight_dome_size``, ``state``
    (the last observation), ``action``, ``reward``, ``termination``, ``truncation``,
    ``info`` and ``angle_representation`` (0 Euler, 1 quaternion).

    The episode is the reference's: after the native reset (spawn, payloads, the task's
    scenery) and the settling, ``step`` starts the reward at :attr:`step_reward`, applies
    the action and runs ``120 / agent_hz`` world steps of 1/120 s, calling the reference's
    hooks ``compute_state`` and ``compute_term_trunc_reward`` after each (its observations,
    reward functions and endings, written per env; a subclass may override them as in the
    reference) and stopping once the episode ended; ``step_count > max_steps`` truncates.
    The native task supplies the world (payloads, pad, gates, the first course) but
    neither rewards nor ends these episodes.
    """

    # what the native env class after this mixin in the bases provides (annotations only)
    config: Any
    world: Any
    vehicle: Any
    task: Any
    observation_space: Any
    action_space: Any
    render_mode: str | None
    metadata: dict[str, Any]
    # the reference's attributes set at the construction or reset
    angle_representation: int
    sparse_reward: bool
    action: np.ndarray
    _reference_rng: np.random.Generator

    #: the reference's id of this env
    reference_id: ClassVar[str] = ""
    #: bound of the target deltas (PyFlyt 0.29.0: 2 x flight_dome_size), or None
    _delta_bound: float | None = None
    #: the Aviary drone type of the vehicle ("quadx", "fixedwing", "rocket")
    drone_kind: ClassVar[str] = "quadx"
    #: the reward each step starts from (PyFlyt 0.29.0: -0.1; the rocket's 0)
    step_reward: ClassVar[float] = -0.1
    #: the reference QuadX's hover command the thrust and motor commands are matched at
    reference_hover_command: ClassVar[float] = REFERENCE_QUADX_HOVER_COMMAND

    def _finish_init(self, render_resolution: tuple[int, int], render_mode: str | None) -> None:
        """After the native ``__init__``: the reference's command meanings, render mode, delta
        bounds and attributes."""
        #: "human" asked for without a display: frames are drawn headless
        self._headless_human = render_mode == "human" and self.render_mode == "rgb_array"
        self.render_mode = render_mode
        self.render_resolution = tuple(render_resolution)
        # PyFlyt 0.29.0 *BaseEnv.metadata: render_fps 30 at any agent rate
        self.metadata = {**self.metadata, "render_fps": REFERENCE_RENDER_FPS}
        cfg = self.config
        mode = cfg.action.mode
        if mode in ("rates_thrust", "motors"):  # a QuadX in the reference's mode 0 or -1
            self.vehicle = _PwmThrust(
                self.vehicle,
                motors=mode == "motors",
                reference_hover=self.reference_hover_command,
            )
        space = self.observation_space
        if self._delta_bound is not None and isinstance(space, spaces.Dict):
            feature = cast(spaces.Sequence, space["target_deltas"]).feature_space
            b = float(self._delta_bound)
            deltas = spaces.Sequence(spaces.Box(-b, b, shape=feature.shape, dtype=np.float64), stack=True)
            self.observation_space = spaces.Dict({**space.spaces, "target_deltas": deltas})
        # PyFlyt 0.29.0 *BaseEnv.__init__: max_steps = agent_hz x duration, env_step_ratio = 120 / agent_hz
        self.max_steps = int(cfg.agent_hz * cfg.max_duration_seconds)
        self.env_step_ratio = int(round(REFERENCE_STEP_HZ / cfg.agent_hz))
        self.flight_dome_size = float(cfg.flight_dome_size)
        self.angle_representation = 0 if cfg.angle_representation == "euler" else 1
        self.step_count = 0
        self.termination = self.truncation = False
        self.reward = 0.0
        self.action = np.zeros(self.action_space.shape)
        self.info: dict[str, Any] = {}
        self._reference_state: Any = None
        self._aviary_view: Any = None

    # ------------------------------------------------------------------ the reference's attributes

    @property
    def env(self) -> Any:
        """The world as the reference's Aviary (:meth:`Aviary.over_world`): read it; the env steps it."""
        from pyflyt_engine.compat.core import Aviary

        world = self.world
        if self._aviary_view is None or self._aviary_view.world is not world:
            self._aviary_view = Aviary.over_world(world, [self.drone_kind])
        return self._aviary_view

    @property
    def state(self) -> Any:
        """The last observation (PyFlyt 0.29.0 ``self.state``); the vehicle's own state is ``vehicle.state``."""
        return self._reference_state

    @state.setter
    def state(self, value: Any) -> None:
        self._reference_state = value

    def _task_option(self, name: str) -> np.ndarray:
        return np.array([getattr(self.task.options, name)], dtype=np.float64)

    def _set_task_option(self, name: str, value: Any) -> None:
        row = np.asarray(value, dtype=np.float64).reshape(-1)
        if row.shape != (3,):
            label = {"start_position": "start_pos", "start_orientation": "start_orn"}[name]
            raise ValueError(f"{label} must hold one (x, y, z) row, e.g. np.array([[0.0, 0.0, 1.0]]), got {value!r}")
        task = self.task
        update = {name: tuple(float(v) for v in row)}
        task.configured = task.configured.model_copy(update=update)
        task.options = task.options.model_copy(update=update)

    @property
    def start_pos(self) -> np.ndarray:
        """(1, 3) spawn position; assigning it moves the next reset's spawn (PyFlyt 0.29.0
        ``begin_reset`` builds its Aviary at ``self.start_pos``)."""
        return self._task_option("start_position")

    @start_pos.setter
    def start_pos(self, value: Any) -> None:
        self._set_task_option("start_position", value)

    @property
    def start_orn(self) -> np.ndarray:
        """(1, 3) spawn Euler angles [rad]; assigning them turns the next reset's spawn."""
        return self._task_option("start_orientation")

    @start_orn.setter
    def start_orn(self, value: Any) -> None:
        self._set_task_option("start_orientation", value)

    # ------------------------------------------------------------------ episodes

    def _new_info(self) -> dict[str, Any]:
        """The info at a reset (PyFlyt 0.29.0 ``begin_reset``)."""
        return {"out_of_bounds": False, "collision": False, "env_complete": False}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """The native reset, then the reference's settling: PyFlyt 0.29.0 ``*BaseEnv.end_reset``
        runs 10 Aviary steps (1/120 s each) with the flight mode's preset setpoint (idle
        motors, neutral surfaces) before the first observation, so a QuadX starts 3.4 cm
        below its spawn point, falling at 0.8 m/s.  ``options`` are ignored, as the
        reference's envs ignore them (its Rocket reads two, whose defaults are what is done
        here: see :class:`~pyflyt_engine.compat.gym_envs.envs.RocketLandingEnv`).

        As the reference's stock ``reset``: :meth:`begin_reset`, the env's own set-up (its
        course of waypoints), :meth:`end_reset`; a subclass that overrides ``reset`` calls
        the two halves around its own set-up, as it would there."""
        self.begin_reset(seed, options)
        self._reference_reset()
        self.end_reset(seed, options)
        return fresh(self.state), dict(self.info)

    def begin_reset(self, seed: int | None = None, options: dict[str, Any] | None = None, **_: Any) -> None:
        """PyFlyt 0.29.0 ``*BaseEnv.begin_reset``: seed, the world back at ``start_pos`` /
        ``start_orn`` (the native reset restores the world the env built, with its payloads
        and scenery, rather than building a new one), and zeroed ``step_count``, ``action``,
        ``reward``, ``termination``, ``truncation`` and ``info``.  The reference's
        ``drone_options`` keyword is accepted and unused (the airframe is the env's)."""
        super().reset(seed=seed)  # type: ignore[misc]
        if seed is not None or getattr(self, "_reference_rng", None) is None:
            # PyFlyt 0.29.0: its env's np_random, seeded here, draws nothing before the env's
            # own set-up (its course of waypoints); the native reset draws from ours, so the
            # reference's stream is kept apart and the same seed draws the reference's course
            from gymnasium.utils import seeding

            self._reference_rng = seeding.np_random(seed)[0]
        self._after_spawn()
        self.step_count = 0
        self.termination = self.truncation = False
        self.reward = 0.0
        self.action = np.zeros(self.action_space.shape)
        self.info = self._new_info()

    def end_reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        """PyFlyt 0.29.0 ``*BaseEnv.end_reset``: 10 settling steps of 1/120 s with the mode's
        idle setpoint, then ``compute_state``."""
        self._settle()
        self.compute_state()
        self._after_agent_step()
        self._show_markers()

    def _show_markers(self) -> None:
        if self._markers is not None:  # type: ignore[attr-defined]
            self._markers.show(self._marker_points())  # type: ignore[attr-defined]

    def _marker_points(self) -> Any:
        return self.task.markers()

    def _after_spawn(self) -> None:
        """Change the spawned state before settling (the rocket's drop velocity)."""

    def _reference_reset(self) -> None:
        """The env's own reset, before the settling (a course of waypoints)."""

    def _settle(self) -> None:
        world = self.world
        per_agent = world.physics_per_agent
        world.physics_per_agent = max(1, int(round(world.physics_hz / REFERENCE_STEP_HZ)))
        try:
            self.vehicle.set_setpoint(np.zeros(self.action_space.shape))
            for _ in range(SETTLE_STEPS):
                world.step()
        finally:
            world.physics_per_agent = per_agent

    # the reference's hooks; every env writes them
    def compute_state(self) -> None:
        """Set ``self.state`` (the observation) from ``self.env``."""
        raise NotImplementedError

    def compute_term_trunc_reward(self) -> None:
        """Adjust ``self.reward``, ``self.termination``, ``self.truncation`` and ``self.info``."""
        raise NotImplementedError

    def _after_agent_step(self) -> None:
        """Once per agent step, after its world steps (the Gates camera frame)."""

    def _to_setpoint(self, action: np.ndarray) -> np.ndarray:
        """The clipped action as the vehicle's setpoint (the fixed-wing maps its thrust)."""
        return action

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """PyFlyt 0.29.0 ``*BaseEnv.step`` (see the class docstring); the action is observed as given."""
        from pyflyt_engine.envs.step import clip_action

        names = self.config.action.names
        clipped = clip_action(action, self._low, self._high, names)  # type: ignore[attr-defined]
        self.action = np.array(action, dtype=np.float64).reshape(clipped.shape)
        self._actions[0] = clipped  # type: ignore[attr-defined]
        self.reward = self.step_reward
        self.vehicle.set_setpoint(self._to_setpoint(clipped.copy()))
        world = self.world
        per_agent = world.physics_per_agent
        world.physics_per_agent = max(1, int(round(world.physics_hz / REFERENCE_STEP_HZ)))
        try:
            for _ in range(self.env_step_ratio):
                if self.termination or self.truncation:
                    break
                world.step()
                self.compute_state()
                self.compute_term_trunc_reward()
        finally:
            world.physics_per_agent = per_agent
        self.step_count += 1
        self._steps += 1  # type: ignore[attr-defined]
        self._after_agent_step()
        self._show_markers()
        return fresh(self.state), float(self.reward), bool(self.termination), bool(self.truncation), dict(self.info)

    def render(self) -> np.ndarray | None:
        """``rgb_array``: an (H, W, 4) uint8 RGBA frame, as the reference's; ``human``: the GUI."""
        if self.render_mode is None:
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
