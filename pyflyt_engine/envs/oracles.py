"""Scripted controllers ("oracles"): hand-written policies over an environment's observation.

An oracle is a callable ``oracle(observation) -> action`` built for one environment
(``make_oracle(name, env)``) from that environment's parameters, with no state carried
between calls: the action is a function of the observation alone, so it can label any
state a learner visits (imitation by DAgger, ``train.imitation`` in ``pyflyt train``)
and serve as a baseline, flown, recorded and filmed like a trained run by ``pyflyt eval
oracle:<name>`` (``experiments/rocket_scripted_landing.py`` compares it with a free fall).

Oracles:

* ``rocket_lander`` (``PyFlyt/Rocket-Landing-v0``, raw channels): :class:`RocketLander`;
* ``rocket_velocity_lander`` (``PyFlyt/Rocket-Landing-Velocity-v0``, the rocket
  autopilot's ``velocity`` mode): :class:`RocketVelocityLander`;
* ``rocket_descent_lander`` (``PyFlyt/Rocket-Landing-Descent-v0``, the rocket autopilot's
  ``descent`` mode): :class:`RocketDescentLander`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows

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

    env_ids = ("PyFlyt/Rocket-Landing-v0",)

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

    env_ids = ("PyFlyt/Rocket-Landing-Velocity-v0",)

    def __init__(self, env: Any, a_brake: float = 30.0, v_land: float = 0.35, h_slow: float = 2.0,
                 k_pad: float = 1.5, k_damp: float = 2.0, lean: float = 0.15) -> None:
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

    env_ids = ("PyFlyt/Rocket-Landing-Descent-v0",)

    def __init__(self, env: Any, share: float = 2.0 / 3.0, h_aim: float = 30.0, v_min: float = 5.0,
                 k_pad: float = 1.5, k_damp: float = 2.0) -> None:
        base = env.unwrapped
        if base.config.angle_representation != "quaternion":
            raise ConfigError(
                "oracle rocket_descent_lander reads the attitude as a quaternion: set env.angle_representation=quaternion"
            )
        self.low, self.high = base.action_space.low, base.action_space.high
        if base.vehicle.rocket is None:
            raise ConfigError("oracle rocket_descent_lander needs a vehicle with a gimballed booster (the rocket airframe)")
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


#: name -> oracle class (each names the env ids it flies in ``env_ids``)
ORACLES: dict[str, type] = {
    "rocket_lander": RocketLander,
    "rocket_velocity_lander": RocketVelocityLander,
    "rocket_descent_lander": RocketDescentLander,
}


def make_oracle(name: str, env: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The oracle ``name`` built for ``env`` (a gymnasium env of one of its ``env_ids``)."""
    if name not in ORACLES:
        raise ConfigError(f"unknown oracle {name!r}; oracles: {', '.join(sorted(ORACLES))}")
    cls = ORACLES[name]
    env_id = getattr(getattr(env, "spec", None), "id", None) or getattr(env.unwrapped.config, "id", None)
    if env_id not in cls.env_ids:
        raise ConfigError(f"oracle {name} flies {', '.join(cls.env_ids)}, not {env_id}")
    return cls(env)
