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
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.envs.rewards import Condition, StepContext, register_condition
from pyflyt_engine.envs.observe import FLAT, ObservationLayout, ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.base import Spawn, Task, TaskOptions, TaskSignals, Vec3
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import ground_to_body_matrix, quaternion_to_rows
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

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        pad = ObservationPart("pad_contact", 1, "the rocket touched the pad during the last step", "0/1")
        return {FLAT: (*attitude, pad)}

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


# ------------------------------------------------ oracles of this task (pyflyt_engine.envs.oracles)

#: the ignition label's slope: the oracle's burn margin (the alignment of the lean with the
#: aim, or the aim or braking error's excess in m/s/2, whichever lights the booster) maps to
#: ``0.5 + 0.5 tanh(margin / IGNITION_SCALE)``.  The booster is lit above 0.5, so the flights
#: are those of a 0/1 switch; the graded value gives a learner fitting the oracle (DAgger) a
#: target that is continuous across the switching surface instead of a step.
IGNITION_SCALE = 0.1
#: the smallest ignition value sent when lit (0.5 itself, or a float32 rounding to it, is out)
IGNITION_LIT = 0.5 + 1e-6

#: the Rocket's centre of mass above its feet when standing [m], measured in the engine
#: (the shipped ``conf/uav/rocket.yaml``, legs and 1 % fuel)
ROCKET_STANDING_HEIGHT = 1.72


class RocketLander:
    """Land the Rocket on the pad from the landing task's start states (observation in quaternions).

    In the ground frame, from the observation alone:

    1. *Aim* (more than 120 m above the pad): the lateral velocity that carries the Rocket
       over the pad by the time it starts braking is ``-p_xy / t_go``; lean the top 0.6
       rad toward the error and pulse the booster whenever the lean points the right way
       (a 1/30 s pulse at minimum thrust, leaning 0.6 rad, adds ~0.4 m/s sideways), until
       the error is under 0.2 m/s.
    2. *Fall* upright, the grid fins holding the attitude.
    3. *Brake*: burn whenever falling faster than ``v_ref(h) = -sqrt(2 a (h - h_slow))``
       (``a_brake`` = 30 m/s^2), the throttle proportional to the error; lean the thrust
       (up to 0.2 rad) to bring the position and lateral velocity to zero; below
       ``h_slow`` = 2 m hold ``-v_land`` = 0.35 m/s by pulses (the minimum thrust exceeds
       the weight).
    4. Booster out while touching the pad.

    Attitude: a PD law on the tilt error drives the fins (and the gimbal while lit); the
    fins damp the roll rate.  The ignition value is graded by how far the state is from
    switching the booster (:data:`IGNITION_SCALE`): the flights are a 0/1 switch's, the
    label a learner fits is continuous.  Mass (dry plus the fuel left, read from the observation),
    the thrust range, gravity and the pad's height come from the environment.

    Flies 50 of the first 50 seeded starts to a safe landing
    (``experiments/results/rocket_landing_scripted.md``).
    """

    name: str = "rocket_lander"
    env_ids: tuple[str, ...] = ("PyFlyt/Rocket-Landing-v0",)

    def __init__(
        self,
        env: Any,
        a_brake: float = 30.0,
        v_land: float = 0.35,
        h_slow: float = 2.0,
        lean_aim: float = 0.6,
        lean_brake: float = 0.2,
        k_att: float = 3.0,
        k_rate: float = 1.2,
        k_roll: float = 0.05,
        kp_lat: float = 0.5,
        kd_lat: float = 2.0,
    ) -> None:
        base = env.unwrapped
        if base.config.angle_representation != "quaternion":
            raise ConfigError(
                "oracle rocket_lander reads the attitude as a quaternion: set env.angle_representation=quaternion"
            )
        booster = base.vehicle.spec.boosters
        if booster is None:
            raise ConfigError("oracle rocket_lander needs a vehicle with a booster (the rocket airframe)")
        self.vehicle = base.vehicle  # its dry mass is read at every call: randomisation may change it per episode
        self.total_fuel = float(np.ravel(booster.total_fuel)[0])
        self.min_thrust = float(np.ravel(booster.min_thrust)[0])
        self.max_thrust = float(np.ravel(booster.max_thrust)[0])
        self.standing = float(base.task.options.pad_height) + ROCKET_STANDING_HEIGHT
        self.a_brake, self.v_land, self.h_slow = a_brake, v_land, h_slow
        self.lean_aim, self.lean_brake = lean_aim, lean_brake
        self.k_att, self.k_rate, self.k_roll, self.kp_lat, self.kd_lat = k_att, k_rate, k_roll, kp_lat, kd_lat

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        action = np.zeros(7)
        if obs[-1] == 1.0:  # on the pad: booster out (the minimum thrust would lift it off)
            return action
        omega, pos = obs[0:3], obs[10:13]
        rows = quaternion_to_rows(obs[3:7].tolist())
        body_to_ground = np.array(rows)
        vel = np.array(exact.rotate(rows, obs[7:10].tolist()))
        mass = self.vehicle.dry_mass + float(obs[-6]) * self.total_fuel
        up = body_to_ground[:, 2]
        h, v_z = pos[2] - self.standing, vel[2]
        # time until the braking burn starts (about 30 m above its ideal start), plus a margin
        h_burn = v_z * v_z / (2.0 * self.a_brake) + 30.0
        t_go = (v_z + math.sqrt(v_z * v_z + 2.0 * GRAVITY * max(h - h_burn, 0.0))) / GRAVITY + 1.5
        # burn > 0 lights the booster: aiming (the lean points the right way and the miss is
        # over 0.2 m/s) or braking (falling over 0.05 m/s faster than the curve); the margin's
        # size grades the ignition label on both sides of the switch (see IGNITION_SCALE)
        lean, burn, throttle = np.zeros(2), -math.inf, 0.0
        if h > 120.0:
            miss = -pos[:2] / t_go - vel[:2]
            size = exact.norm(miss)
            aligned = (float(up[0]) * float(miss[0]) + float(up[1]) * float(miss[1])) / size if size > 0.0 else -1.0
            burn = min(aligned - 0.3, (size - 0.2) / 2.0)
            if size > 0.2:
                lean = self.lean_aim * miss / size
        v_ref = -max(self.v_land, math.sqrt(2.0 * self.a_brake * max(h - self.h_slow, 0.0)))
        error = v_ref - v_z
        burn = max(burn, (error - 0.05) / 2.0)
        if error > 0.05:
            thrust = mass * (GRAVITY + 8.0 * error) / max(up[2], 0.5)
            throttle = float(np.clip((thrust - self.min_thrust) / (self.max_thrust - self.min_thrust), 0.0, 1.0))
            want = -self.kp_lat * pos[:2] - self.kd_lat * vel[:2]
            n = exact.norm(want)
            lean = min(n / 20.0, self.lean_brake) * want / n if n > 1e-9 and h > 1.0 else np.zeros(2)
        elif h <= 120.0:
            lean = np.zeros(2)
        if burn > 0.0:  # lit: above 0.5 even where the float32 action rounds
            action[3], action[4] = max(0.5 + 0.5 * math.tanh(burn / IGNITION_SCALE), IGNITION_LIT), throttle
        else:
            action[3] = 0.5 + 0.5 * math.tanh(burn / IGNITION_SCALE)
        target = np.array([lean[0], lean[1], 1.0])
        target /= exact.norm(target)
        axis = np.array(exact.rotate_t(rows, exact.cross(up.tolist(), target.tolist())))  # in the body frame
        moment = self.k_att * axis[:2] - self.k_rate * omega[:2]
        action[0:2] = np.clip(moment, -1.0, 1.0)  # fins: + moment about body x, y
        action[2] = np.clip(-self.k_roll * omega[2], -1.0, 1.0)
        action[5:7] = np.clip(-moment, -1.0, 1.0)  # gimbal: + angle gives - moment
        return action


class RocketVelocityLander:
    """Land the Rocket through the autopilot's ``velocity`` mode (``PyFlyt/Rocket-Landing-Velocity-v0``).

    The setpoint, from the observation alone (quaternion attitude, ground frame):

    * vertical: the braking curve ``v_ref(h) = -max(v_land, sqrt(2 a (h - h_slow)))``
      (``a`` = 30 m/s^2): above it the velocity loop asks for no thrust and the Rocket
      falls, at it the autopilot lights the booster and brakes;
    * horizontal: the velocity that carries the Rocket over the pad, ``-p_xy / t_go``
      above 120 m (``t_go`` the time left until the braking burn, plus 1.5 s); below,
      ``-k_pad p_xy - k_damp v_xy`` (the autopilot's velocity loop then acts as a damped
      position loop over the pad);
    * aim (above 120 m): while that velocity is missed by more than 0.2 m/s and the long
      axis already leans its way (the autopilot leans it toward the velocity error), the
      vertical setpoint is 1 m/s above the current vertical speed: the autopilot fires a
      short pulse of the leaning booster;
    * ignition 1 until the Rocket touches the pad, then 0 (booster out).

    Flies 49 of the first 50 seeded starts to a safe landing; on seed 28 the fuel runs out
    just above the pad (touchdown at 2.6 m/s, a fatal landing)
    (``experiments/results/rocket_landing_scripted.md``).
    """

    name: str = "rocket_velocity_lander"
    env_ids: tuple[str, ...] = ("PyFlyt/Rocket-Landing-Velocity-v0",)

    def __init__(
        self,
        env: Any,
        a_brake: float = 30.0,
        v_land: float = 0.35,
        h_slow: float = 2.0,
        k_pad: float = 1.5,
        k_damp: float = 2.0,
        lean: float = 0.15,
    ) -> None:
        base = env.unwrapped
        if base.config.angle_representation != "quaternion":
            raise ConfigError(
                "oracle rocket_velocity_lander reads the attitude as a quaternion: set env.angle_representation=quaternion"
            )
        self.standing = float(base.task.options.pad_height) + ROCKET_STANDING_HEIGHT
        self.low, self.high = base.action_space.low, base.action_space.high
        self.a_brake, self.v_land, self.h_slow, self.lean = a_brake, v_land, h_slow, lean
        self.k_pad, self.k_damp = k_pad, k_damp

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The setpoint for ``obs``, within the action space (the braking curve above ~170 m
        is faster than the space's -100 m/s: the same command, as the Rocket falls slower)."""
        if obs[-1] == 1.0:  # on the pad: booster out
            return np.clip(np.zeros(4), self.low, self.high)
        rows = quaternion_to_rows(obs[3:7].tolist())
        vx, vy, vz = exact.rotate(rows, obs[7:10].tolist())
        x, y, z = obs[10:13].tolist()
        h = z - self.standing
        v_ref = -max(self.v_land, math.sqrt(2.0 * self.a_brake * max(h - self.h_slow, 0.0)))
        setpoint = [-self.k_pad * x - self.k_damp * vx, -self.k_pad * y - self.k_damp * vy, v_ref, 1.0]
        if h > 120.0:
            h_burn = vz * vz / (2.0 * self.a_brake) + 30.0
            t_go = (vz + math.sqrt(vz * vz + 2.0 * GRAVITY * max(h - h_burn, 0.0))) / GRAVITY + 1.5
            aim_x, aim_y = -x / t_go, -y / t_go
            mx, my = aim_x - vx, aim_y - vy
            miss = math.hypot(mx, my)
            leaning = (rows[0][2] * mx + rows[1][2] * my) / miss if miss > 0.0 else 0.0
            pulse = miss > 0.2 and leaning > self.lean
            setpoint = [aim_x, aim_y, vz + 1.0 if pulse else v_ref, 1.0]
        return np.clip(np.array(setpoint), self.low, self.high)


class RocketDescentLander:
    """Land the Rocket through the autopilot's ``descent`` mode (``PyFlyt/Rocket-Landing-Descent-v0``).

    The mode brakes on its envelope and pulses the booster to aim; what is left is the
    guidance, from the observation alone (quaternion attitude, ground frame):

    * sideways, while higher than ``h_aim`` above the height at which the envelope's
      braking starts (``vz^2 / (2 a_brake)``, ``a_brake = share (T_max / m - g)`` with the
      mass ``m`` of the fuel left): ``-p_xy / t_go``, the velocity that carries
      the Rocket over the pad in the time ``t_go`` it takes to fall there at its present
      vertical speed (at least ``v_min``), plus 1 s; below, ``-k_pad p_xy - k_damp v_xy``
      (the autopilot's velocity loop then acts as a damped position loop over the pad);
    * descent ``share`` (2/3: braking at two thirds of the full-thrust deceleration), ignition
      1 until the Rocket touches the pad, then 0.
    """

    name: str = "rocket_descent_lander"
    env_ids: tuple[str, ...] = ("PyFlyt/Rocket-Landing-Descent-v0",)

    def __init__(
        self,
        env: Any,
        share: float = 2.0 / 3.0,
        h_aim: float = 30.0,
        v_min: float = 5.0,
        k_pad: float = 1.5,
        k_damp: float = 2.0,
    ) -> None:
        base = env.unwrapped
        if base.config.angle_representation != "quaternion":
            raise ConfigError(
                "oracle rocket_descent_lander reads the attitude as a quaternion: set env.angle_representation=quaternion"
            )
        self.low, self.high = base.action_space.low, base.action_space.high
        if base.vehicle.rocket is None:
            raise ConfigError(
                "oracle rocket_descent_lander needs a vehicle with a gimballed booster (the rocket airframe)"
            )
        self.vehicle = base.vehicle  # its dry mass is read at every call: randomisation may change it per episode
        self.total_fuel = float(np.ravel(base.vehicle.spec.boosters.total_fuel)[0])
        self.max_thrust = base.vehicle.rocket.max_thrust
        self.share = share
        self.h_aim, self.v_min, self.k_pad, self.k_damp = h_aim, v_min, k_pad, k_damp

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The setpoint for ``obs``, within the action space."""
        if obs[-1] == 1.0:  # on the pad: booster out
            return np.clip(np.array([0.0, 0.0, self.share, 0.0]), self.low, self.high)
        vx, vy, vz = exact.rotate(quaternion_to_rows(obs[3:7].tolist()), obs[7:10].tolist())
        x, y, z = obs[10:13].tolist()
        mass = self.vehicle.dry_mass + float(obs[-6]) * self.total_fuel  # the fuel left, from the observation
        a_brake = self.share * (self.max_thrust / mass - GRAVITY)  # the envelope's deceleration (the mode's law)
        h_end = vz * vz / (2.0 * a_brake) + self.h_aim
        if z > h_end:
            t_go = (z - h_end) / max(-vz, self.v_min) + 1.0
            sx, sy = -x / t_go, -y / t_go
        else:
            sx, sy = -self.k_pad * x - self.k_damp * vx, -self.k_pad * y - self.k_damp * vy
        return np.clip(np.array([sx, sy, self.share, 1.0]), self.low, self.high)


register_task(LandingTask, oracles=(RocketLander, RocketVelocityLander, RocketDescentLander))
