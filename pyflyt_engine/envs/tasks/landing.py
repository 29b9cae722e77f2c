"""Landing: bring a falling vehicle to an upright halt on a landing pad (paper, Rocket-Landing).

The pad is a static cylinder at the origin, added once in :meth:`LandingTask.setup` and
tracked by the world's contact matrix.  The episode's outcome is decided by a small state
machine evaluated once per agent step:

* **Touchdown**: a step in which the vehicle touches the pad after a step in which it did
  not.  Its *touchdown speed* is the larger of the centre-of-mass speeds at the start and
  at the end of that step: the last state observed before contact (the agent's view),
  and the state after it (a vehicle still sliding or bouncing at speed).  PyBullet's
  rigid contact absorbs the impact within the step, so the end speed is the post-impact
  one; the speed at the instant of contact is measured at the agent rate only, and in
  free fall can exceed the start-of-step speed by up to g / agent_hz (0.33 m/s at
  30 Hz).  Touchdown speed >= ``max_touchdown_speed`` (paper: 1 m/s) is a **fatal
  landing**.
* **Tipping over** while touching the pad (tilt of the body z axis from vertical above
  ``tip_over_angle_deg``) is a fatal landing.
* **Halt**: touching the pad with speed < ``halt_speed``, angular speed <
  ``halt_angular_speed`` and tilt < ``upright_angle_deg``, on ``halt_duration``
  consecutive seconds of agent steps (rounded up to whole steps).  The halt completes a
  **safe landing** (the paper: "contacts the pad with a velocity of less than 1 m/s and
  comes to an upright halt").  Leaving the pad (a bounce, a lift-off) restarts the count,
  and the next contact is a new touchdown.
* **Ground contact** anywhere (off the pad) is a failure.

Signals: ``target_distance`` = d_pad, the distance from the centre of mass to the centre of
the pad's top face [m]; ``target_distance_rate`` [m/s]; extras ``pad_contact``,
``safe_landing``, ``fatal_landing`` (0/1) and ``touchdown_speed`` [m/s] (-1 before the
first touchdown).

Measures (what ``pyflyt eval`` reports): ``landed``, ``fatal_landing``, ``ground_contact``
(1 when the episode ended that way) and ``touchdown_speed`` of the last touchdown [m/s]
(NaN without one).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pydantic import Field, model_validator

from pyflyt_engine import exact
from pyflyt_engine.envs.rewards import Condition, StepContext, register_condition
from pyflyt_engine.envs.tasks.base import Spawn, Task, TaskOptions, TaskSignals, Vec3
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.frames import ground_to_body_matrix
from pyflyt_engine.state import KinematicState

if TYPE_CHECKING:
    from pyflyt_engine.spec import UAVSpec
    from pyflyt_engine.world import World


class LandingOptions(TaskOptions):
    """Options of the landing task (``task:`` in the env YAML)."""

    name: Literal["landing"] = "landing"
    start_position: Vec3 = Field((0.0, 0.0, 450.0), description="mean spawn position [m] (paper: 450 m drop)")
    start_position_noise: float = Field(
        20.0,
        ge=0,
        description="HORIZONTAL spawn offset: x and y each U(-noise, noise) [m] (height: start_height_noise)",
    )
    start_height_noise: float = Field(0.0, ge=0, description="spawn height offset U(-noise, noise) [m]")
    start_orientation_noise: float = Field(
        0.3, ge=0, description="each spawn Euler angle is offset by U(-noise, noise) [rad]"
    )
    start_velocity_noise: float = Field(
        5.0, ge=0, description="spawn velocity: start_lin_vel plus U(-noise, noise) [m/s] per GROUND axis"
    )
    start_ang_vel_noise: float = Field(
        0.5, ge=0, description="spawn angular velocity U(-noise, noise) [rad/s] per body axis"
    )
    initial_fuel: float | None = Field(
        0.01,
        ge=0,
        le=1,
        description="booster fuel at spawn as a fraction of a full tank (paper: 1 %); null: the airframe's",
    )
    pad_radius: float = Field(2.0, gt=0, description="landing pad radius [m] (paper: 4 m diameter)")
    pad_height: float = Field(0.1, gt=0, description="landing pad thickness [m]; its top face is at this height")
    max_touchdown_speed: float = Field(
        1.0, gt=0, description="touchdown at this speed or faster is fatal [m/s] (paper: 1)"
    )
    tip_over_angle_deg: float = Field(
        30.0, gt=0, lt=180, description="tilt on the pad beyond which it has tipped over [deg]"
    )
    upright_angle_deg: float = Field(10.0, gt=0, description="largest tilt that counts as upright for the halt [deg]")
    halt_speed: float = Field(0.1, gt=0, description="speed below which the vehicle counts as halted [m/s]")
    halt_angular_speed: float = Field(0.1, gt=0, description="angular speed below which it counts as halted [rad/s]")
    halt_duration: float = Field(
        0.5, ge=0, description="time the halt must last on the pad [s] (whole agent steps, at least 1)"
    )

    @model_validator(mode="after")
    def _angles(self) -> LandingOptions:
        if self.upright_angle_deg >= self.tip_over_angle_deg:
            raise ValueError(
                f"upright_angle_deg ({self.upright_angle_deg}) must be below tip_over_angle_deg ({self.tip_over_angle_deg})"
            )
        return self


def tilt_angle(quaternion: tuple[float, float, float, float]) -> float:
    """Angle between the body z axis and the ground z axis [rad], from a quaternion (x, y, z, w)."""
    x, y, _, _ = quaternion
    cos_tilt = 1.0 - 2.0 * (x * x + y * y)  # the (2, 2) entry of the body-to-ground matrix
    return math.acos(min(1.0, max(-1.0, cos_tilt)))


class LandingTask(Task):
    """Land on a pad at the origin: gentle touchdown, then an upright halt (module docstring).

    Observation: the attitude Box followed by one entry, the pad contact flag (1.0 when the
    vehicle touched the pad during the last step, else 0.0).
    """

    name: ClassVar[str] = "landing"
    Options: ClassVar[type[TaskOptions]] = LandingOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate", "landing"})
    crash_on_contact: ClassVar[bool] = False
    # read at every spawn or step; the pad (world) and the fuel (airframe) are built once
    episode_options: ClassVar[frozenset[str]] = frozenset(
        {
            "start_position",
            "start_position_noise",
            "start_height_noise",
            "start_orientation_noise",
            "start_velocity_noise",
            "start_ang_vel_noise",
            "max_touchdown_speed",
            "tip_over_angle_deg",
            "upright_angle_deg",
            "halt_speed",
            "halt_angular_speed",
            "halt_duration",
        }
    )
    measures: ClassVar[tuple[Measure, ...]] = (
        Measure("landed", "safe landing", percent=True),
        Measure("fatal_landing", "fatal landing", percent=True),
        Measure("ground_contact", "ground contact", percent=True),
        Measure("touchdown_speed", "touchdown speed", "m/s", digits=2),
    )

    options: LandingOptions

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        self.pad_centre = (0.0, 0.0, float(self.options.pad_height))
        self._agent_hz = float(agent_hz)
        self.options_changed()
        self.world: World | None = None
        self.pad_id = -1
        self._reset_episode(0.0, 0.0)

    def options_changed(self) -> None:
        o = self.options
        self.halt_steps = max(1, math.ceil(o.halt_duration * self._agent_hz - 1e-9))
        self._tip_over = math.radians(o.tip_over_angle_deg)
        self._upright = math.radians(o.upright_angle_deg)

    # ------------------------------------------------------------ building

    def vehicle_spec(self, spec: UAVSpec) -> UAVSpec:
        """The airframe with its boosters starting at ``initial_fuel`` (paper: 1 %)."""
        fuel = self.options.initial_fuel
        if fuel is None or spec.boosters is None:
            return spec
        return spec.model_copy(update={"boosters": spec.boosters.model_copy(update={"initial_fuel": float(fuel)})})

    def setup(self, world: World) -> None:
        """Add the pad: a static cylinder of ``pad_radius`` and ``pad_height``, top face at z = pad_height."""
        from pyflyt_engine.bullet import pybullet as p

        o, cid = self.options, world.client
        collision = p.createCollisionShape(
            p.GEOM_CYLINDER, radius=o.pad_radius, height=o.pad_height, physicsClientId=cid
        )
        visual = p.createVisualShape(
            p.GEOM_CYLINDER,
            radius=o.pad_radius,
            length=o.pad_height,
            rgbaColor=(0.15, 0.15, 0.15, 1.0),
            physicsClientId=cid,
        )
        self.pad_id = p.createMultiBody(
            0.0, collision, visual, basePosition=(0.0, 0.0, 0.5 * o.pad_height), physicsClientId=cid
        )
        world.add_body(self.pad_id)  # its contacts tracked (World.bodies_touched)
        self.world = world

    # ------------------------------------------------------------- episode

    def spawn(self, rng: np.random.Generator) -> Spawn:
        """Drop pose and velocity (draws 12 numbers from ``rng``).

        Position: ``start_position`` + U(-start_position_noise, +) in x and y and
        U(-start_height_noise, +) in z; attitude: ``start_orientation`` + U(-n, n) per
        Euler angle; linear velocity: ``start_lin_vel`` (body frame) plus a ground-frame
        U(-start_velocity_noise, +) per axis; angular velocity U(-start_ang_vel_noise, +)
        per body axis.
        """
        o = self.options
        unit = rng.uniform(-1.0, 1.0, 12)
        position = np.add(
            o.start_position, unit[0:3] * (o.start_position_noise, o.start_position_noise, o.start_height_noise)
        )
        orientation = np.add(o.start_orientation, unit[3:6] * o.start_orientation_noise)
        roll, pitch, yaw = (float(a) for a in orientation)
        lin_vel = np.add(
            o.start_lin_vel, exact.rotate(ground_to_body_matrix(roll, pitch, yaw), unit[6:9] * o.start_velocity_noise)
        )
        ang_vel = unit[9:12] * o.start_ang_vel_noise
        return Spawn(_floats(position), (roll, pitch, yaw), lin_vel=_floats(lin_vel), ang_vel=_floats(ang_vel))

    def _reset_episode(self, distance: float, speed: float) -> None:
        self._distance = distance
        self._speed = speed
        self._on_pad = False
        self._halted_for = 0
        self._touchdown_speed = -1.0  # no touchdown yet (not NaN: NaN != NaN breaks info comparisons)
        self._signals = (False, False, False, False)  # pad contact, ground contact, safe, fatal

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        self._reset_episode(self._pad_distance(state), _norm(state.lin_vel))

    def _pad_distance(self, state: KinematicState) -> float:
        x, y, z = state.lin_pos
        cx, cy, cz = self.pad_centre
        return math.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2)

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        low = np.append(attitude.low, 0.0)
        high = np.append(attitude.high, 1.0)
        return spaces.Box(low, high, dtype=np.float64)

    def observe(self, attitude: np.ndarray, state: KinematicState) -> np.ndarray:
        return np.concatenate((attitude, (1.0 if self._signals[0] else 0.0,)))  # np.append without its wrapper

    def update(self, state: KinematicState) -> TaskSignals:
        assert self.world is not None, "LandingTask.setup(world) was not called"
        o = self.options
        on_pad = self.world.bodies_touched(self.world.vehicles[0].body_id, self.pad_id)
        ground = self.world.collided_with_ground(0)
        speed = _norm(state.lin_vel)
        tilt = tilt_angle(state.quaternion)
        safe = fatal = False
        if on_pad:
            if not self._on_pad:  # touchdown
                self._touchdown_speed = max(self._speed, speed)
                self._halted_for = 0
                fatal = self._touchdown_speed >= o.max_touchdown_speed
            fatal = fatal or tilt > self._tip_over
            halted = speed < o.halt_speed and _norm(state.ang_vel) < o.halt_angular_speed and tilt < self._upright
            self._halted_for = self._halted_for + 1 if halted and not fatal else 0
            safe = self._halted_for >= self.halt_steps and not ground
        else:
            self._halted_for = 0
        self._on_pad = on_pad
        self._speed = speed
        distance = self._pad_distance(state)
        rate = (distance - self._distance) / self.agent_dt
        self._distance = distance
        self._signals = (on_pad, ground, safe, fatal)
        return TaskSignals(
            target_distance=distance,
            target_distance_rate=rate,
            complete=safe,
            failed=fatal or ground,
            extras={
                "pad_contact": float(on_pad),
                "safe_landing": float(safe),
                "fatal_landing": float(fatal),
                "touchdown_speed": self._touchdown_speed,
            },
        )

    def info(self) -> dict[str, Any]:
        on_pad, ground, safe, fatal = self._signals
        return {
            "pad_contact": on_pad,
            "ground_contact": ground,
            "safe_landing": safe,
            "fatal_landing": fatal,
            "touchdown_speed": self._touchdown_speed,
            "pad_distance": self._distance,
        }

    def episode_measures(self) -> dict[str, float]:
        _, ground, safe, fatal = self._signals
        touchdown = self._touchdown_speed if self._touchdown_speed >= 0 else math.nan
        return {
            "landed": float(safe),
            "fatal_landing": float(fatal),
            "ground_contact": float(ground),
            "touchdown_speed": touchdown,
        }


def _norm(v: tuple[float, float, float]) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def _floats(v: np.ndarray) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


# ------------------------------------------------ reward terms and conditions of this task


def pad_contact(ctx: StepContext) -> bool:
    """The vehicle touched the landing pad during the step (landing task)."""
    return ctx.extras.get("pad_contact", 0.0) > 0.5


def safe_landing(ctx: StepContext) -> bool:
    """A safe landing was completed this step: gentle touchdown on the pad, then an upright halt (landing task)."""
    return ctx.extras.get("safe_landing", 0.0) > 0.5


def fatal_landing(ctx: StepContext) -> bool:
    """A fatal landing happened this step: pad touchdown too fast, or tipped over on the pad (landing task)."""
    return ctx.extras.get("fatal_landing", 0.0) > 0.5


register_condition("pad_contact", Condition(pad_contact, ("landing",)))
register_condition("safe_landing", Condition(safe_landing, ("landing",)))
register_condition("fatal_landing", Condition(fatal_landing, ("landing",)))
