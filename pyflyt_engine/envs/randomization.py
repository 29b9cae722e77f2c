"""Domain randomisation declared in config: per-episode samples of physical parameters.

An env config's ``randomize`` maps a parameter name to a bounded distribution; at every
``reset`` each entry is drawn, in declaration order, from the env's seeded generator
(``env.np_random``), so a seed reproduces the episode; the values are in
``info["randomization"]`` at the reset and in the episode's MCAP (``docs/atmosphere.md``).

Parameters (a fixed list; anything else is refused at load):

* ``mass``, ``inertia``: factors on the airframe's dry mass and inertia (all three axes);
* ``motor_kf``, ``motor_kt``, ``motor_tau``: factors on every motor's thrust coefficient,
  torque coefficient and time constants (``tau`` and, when declared, ``tau_fall``);
* ``motor_rotor_drag``: factor on the rotors' drag coefficients (an airframe declaring
  ``motors.rotor_drag``);
* ``battery_capacity``, ``battery_resistance``: factors on the battery's capacity and
  internal resistance; ``battery_charge``: its state of charge at the reset, in (0, 1]
  (an airframe declaring a ``battery``);
* ``gyro_noise``, ``accel_noise``: factors on the IMU's gyroscope and accelerometer white
  noise densities and bias random walks; ``position_noise``: factor on the position
  sensor's noise (an airframe, or env, declaring ``sensors.imu`` / ``sensors.position``);
* ``gyro_scale``, ``accel_scale``: factors on the IMU's gyroscope and accelerometer scale
  factors (an airframe, or env, declaring ``sensors.imu``; their initial biases are drawn
  per episode by the sensors themselves, ``bias_initial_std``);
* ``drag``: factor on the body-drag coefficients (translational and rotational);
* ``spawn_x``, ``spawn_y``, ``spawn_z`` [m], ``spawn_roll``, ``spawn_pitch``,
  ``spawn_yaw`` [rad]: offsets added to the task's spawn pose;
* ``action_delay``, ``observation_delay`` [s]: the vehicles' action and observation
  delays (values, not factors; docs/engine.md, "Latency"), each rounded to whole physics
  steps by :func:`delay_steps`, the rule of the env's fixed ``latency``.  A drawn delay
  replaces that delay of ``latency`` for the episode (the other one keeps its fixed
  value); bounds ``0 <= low <= high <`` ``max_duration_seconds``, checked at load;
* ``wind.<path>``: the value of a number of the env's wind config, e.g.
  ``wind.mean.speed`` [m/s] or ``wind.turbulence.wind_speed_20ft`` [m/s].

The flight controller keeps the airframe's nominal values (a controller does not know
the real vehicle's parameters: that is what randomisation tests).  Distributions:
``uniform`` (``low``, ``high``), ``log_uniform`` (``0 < low <= high``: ``exp`` of a
uniform draw between the logs) and ``normal`` (``mean``, ``std``; clipped to ``low`` /
``high`` when given).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.suggest import did_you_mean

if TYPE_CHECKING:
    from pyflyt_engine.atmosphere import WindConfig

AIRFRAME = ("mass", "inertia", "motor_kf", "motor_kt", "motor_tau", "drag")
#: factors on the optional airframe models, and what the airframe must declare for them
MODELS = {
    "motor_rotor_drag": "motors.rotor_drag",
    "battery_capacity": "battery",
    "battery_resistance": "battery",
    "gyro_scale": "sensors.imu",
    "accel_scale": "sensors.imu",
    "gyro_noise": "sensors.imu",
    "accel_noise": "sensors.imu",
    "position_noise": "sensors.position",
}
#: values (not factors) of the optional models: name -> (what the airframe must declare, low, high)
MODEL_VALUES = {"battery_charge": ("battery", 0.0, 1.0)}
#: delays [s] between the agent and every vehicle, in the order of ``Vehicle.set_latency``
DELAYS = ("action_delay", "observation_delay")
SPAWN = ("spawn_x", "spawn_y", "spawn_z", "spawn_roll", "spawn_pitch", "spawn_yaw")
PARAMETERS = AIRFRAME + tuple(MODELS) + tuple(MODEL_VALUES) + DELAYS + SPAWN


def required_model(name: str) -> str | None:
    """What an airframe must declare for ``randomize`` entry ``name`` to have something to
    randomise (``motors.rotor_drag``, ``battery``, ``sensors.imu``, ``sensors.position``), or None."""
    return MODELS.get(name) or MODEL_VALUES.get(name, (None,))[0]


def missing_model(name: str, needs: str) -> ConfigError:
    """The error of entry ``name`` on an airframe without the model ``needs``."""
    return ConfigError(
        f"randomize.{name}: the airframe has no '{needs}' to randomise; declare it in the airframe "
        "(docs/uav_authoring.md) or remove the entry"
    )


def delay_steps(delay: float, physics_hz: float) -> int:
    """A delay [s] in whole physics steps: rounded to the nearest step, halves up,
    ``floor(delay * physics_hz + 1/2)``.  The one rule for the env's fixed ``latency`` and
    the randomised ``action_delay`` / ``observation_delay``."""
    # the 1e-9 absorbs the binary rounding of delay * rate (0.0125 s * 240 Hz = 3.0000000000000004)
    return int(math.floor(delay * physics_hz + 0.5 + 1e-9))


class Distribution(BaseModel):
    """A bounded distribution of one parameter."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    distribution: Literal["uniform", "normal", "log_uniform"] = Field(description="the law of the samples")
    low: float | None = Field(None, description="lower bound (uniform, log_uniform: required; normal: clip)")
    high: float | None = Field(None, description="upper bound (uniform, log_uniform: required; normal: clip)")
    mean: float | None = Field(None, description="normal: the mean")
    std: float | None = Field(None, ge=0, description="normal: the standard deviation")

    @model_validator(mode="after")
    def _parameters(self) -> Distribution:
        if self.distribution in ("uniform", "log_uniform"):
            if self.low is None or self.high is None:
                raise ValueError(f"a {self.distribution} distribution needs low and high")
            if self.distribution == "log_uniform" and not self.low > 0:
                raise ValueError(f"log_uniform needs low > 0, got {self.low}")
            if self.mean is not None or self.std is not None:
                raise ValueError(f"mean and std belong to a normal distribution, not {self.distribution}")
        elif self.mean is None or self.std is None:
            raise ValueError("a normal distribution needs mean and std")
        if self.low is not None and self.high is not None and self.low > self.high:
            raise ValueError(f"low must not exceed high, got [{self.low}, {self.high}]")
        return self

    def sample(self, rng: np.random.Generator) -> float:
        """One draw (exactly one call of ``rng``)."""
        # the model validator has required low and high of a (log-)uniform, mean and std of a normal
        if self.distribution == "uniform":
            assert self.low is not None and self.high is not None
            return float(rng.uniform(self.low, self.high))
        if self.distribution == "log_uniform":
            assert self.low is not None and self.high is not None
            return float(math.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        assert self.mean is not None and self.std is not None
        value = float(rng.normal(self.mean, self.std))
        if self.low is not None:
            value = max(value, self.low)
        if self.high is not None:
            value = min(value, self.high)
        return value


def check_names(entries: Mapping[str, Any], wind: Any, episode: float | None = None) -> None:
    """ValueError naming an unknown parameter, a factor that could reach 0, a wind path
    the env's wind config lacks, or a delay that could be negative or, with ``episode``
    (the episode length [s]), not shorter than the episode."""
    from pyflyt_engine.atmosphere import load_wind_config

    for name, dist in entries.items():
        if name.startswith("wind."):
            _wind_number(load_wind_config(wind).model_dump(mode="json"), name)
        elif name not in PARAMETERS:
            hint = did_you_mean(name, PARAMETERS)
            raise ValueError(f"unknown parameter '{name}'.{hint} Known: {', '.join(PARAMETERS)}, wind.<path>")
        elif name in AIRFRAME + tuple(MODELS) and (dist.low is None or dist.low <= 0):
            raise ValueError(f"'{name}' is a factor on the nominal value: give it a lower bound low > 0")
        elif name in MODEL_VALUES:
            _, low, high = MODEL_VALUES[name]
            if dist.low is None or dist.high is None or not (low < dist.low and dist.high <= high):
                raise ValueError(
                    f"'{name}' must stay in ({low:g}, {high:g}]: give it bounds {low:g} < low <= high <= {high:g}"
                )
        elif name in DELAYS:
            if dist.low is None or dist.high is None or dist.low < 0:
                raise ValueError(
                    f"'{name}' is a delay [s]: give it bounds 0 <= low <= high "
                    "(a normal distribution is clipped to them)"
                )
            if episode is not None and dist.high >= episode:
                raise ValueError(
                    f"'{name}': high {dist.high:g} s is not shorter than the episode (max_duration_seconds "
                    f"{episode:g} s): nothing the agent does would reach the vehicle; give a delay of a few "
                    "physics steps"
                )


def _wind_number(data: dict[str, Any], name: str) -> tuple[dict[str, Any], str]:
    """The mapping holding the number at ``wind.<path>`` and its key (ValueError if none)."""
    parts = name.split(".")[1:]
    node: Any = data
    for part in parts[:-1]:
        if not isinstance(node, dict) or not isinstance(node.get(part), dict):
            raise ValueError(
                f"'{name}': the env's wind config has no '{part}' section to randomise; "
                "choose a wind preset that has it (e.g. env.wind=constant for wind.mean.*)"
            )
        node = node[part]
    key = parts[-1] if parts else ""
    value = node.get(key) if isinstance(node, dict) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"'{name}' is not a number of the env's wind config")
    return node, key


def sampled_wind(nominal: Mapping[str, Any], winds: Mapping[str, float]) -> WindConfig:
    """The wind config of an episode: ``nominal`` (a wind config's ``model_dump(mode="json")``)
    with the number at each ``wind.<path>`` of ``winds`` replaced by its drawn value
    (ConfigError naming the draws if the result is not a valid wind config)."""
    import copy

    from pyflyt_engine.atmosphere import load_wind_config

    data = copy.deepcopy(dict(nominal))
    for name, value in winds.items():
        node, key = _wind_number(data, name)
        node[key] = value
    try:
        return load_wind_config(data)
    except ConfigError as exc:
        raise ConfigError(
            f"randomize: the sampled wind {dict(winds)} is invalid ({exc}); bound the distributions (low/high)"
        ) from None


class Randomizer:
    """Samples and applies an env's ``randomize`` entries at each reset.

    Args:
        entries: name -> :class:`Distribution` (validated, in declaration order).
        world: the env's world; every vehicle in it is randomised with the same draws (one
            vehicle in a single-agent env, every agent's in a multi-agent env: the agents
            share one draw of each parameter, the delays included).
        latency: the env's fixed (action, observation) delays in physics steps; a drawn
            ``action_delay`` / ``observation_delay`` replaces its own entry, the other stays.
    """

    def __init__(self, entries: Mapping[str, Distribution], world: Any, latency: tuple[int, int] = (0, 0)) -> None:
        self.entries = dict(entries)
        self.world = world
        self.latency = (int(latency[0]), int(latency[1]))
        #: per vehicle of the world: its nominal (mass, inertia diagonal, motor and drag parameters)
        self._nominal = []
        for name in self.entries:
            needs = required_model(name)
            if needs is None:
                continue
            has = [
                (v.battery is not None)
                if needs == "battery"
                else (v.sensors is not None and v.sensors.gyro is not None)
                if needs == "sensors.imu"
                else (v.sensors is not None and v.sensors.position_noise_std is not None)
                if needs == "sensors.position"
                else (v.motors is not None and v.motors.rotor_drag is not None)
                for v in world.vehicles
            ]
            if not all(has):
                raise missing_model(name, needs)
        self._battery = [v.battery.params if v.battery is not None else None for v in world.vehicles]
        for vehicle in world.vehicles:
            motors = vehicle.actuators.motors
            drag = vehicle.actuators.drag
            self._nominal.append(
                (
                    vehicle,
                    vehicle.parts.mass,
                    np.diag(vehicle.parts.inertia).copy(),
                    motors.params if motors is not None else None,
                    drag.params if drag is not None else None,
                )
            )
        self.wind = world.wind_config.model_dump(mode="json")
        #: per vehicle with an IMU, its gyro and accelerometer and their nominal (scale factor,
        #: noise density, bias random walk)
        self._imu = [
            [(t, (t.scale, t.noise_density, t.bias_random_walk)) for t in (v.sensors.gyro, v.sensors.accel)]
            for v in world.vehicles
            if v.sensors is not None and v.sensors.gyro is not None and v.sensors.accel is not None
        ]
        #: per vehicle with a position sensor, its suite and nominal noise [m] per axis
        self._position = [
            (v.sensors, v.sensors.position_noise_std)
            for v in world.vehicles
            if v.sensors is not None and v.sensors.position_noise_std is not None
        ]

    def sample(self, rng: np.random.Generator) -> dict[str, float]:
        """Draw every entry (declaration order), apply the airframe ones to every vehicle (each
        from its own nominal values), the delays to every vehicle (``Vehicle.set_latency``,
        before the vehicles' reset that follows) and the wind ones to the world; returns the
        values (delays in seconds, as drawn)."""
        values = {name: dist.sample(rng) for name, dist in self.entries.items()}
        if any(name in values for name in DELAYS):
            hz = self.world.physics_hz
            steps = tuple(
                delay_steps(values[name], hz) if name in values else fixed for name, fixed in zip(DELAYS, self.latency)
            )
            for v in self.world.vehicles:
                v.set_latency(*steps)
        for v, mass, inertia, motor_params, drag_params in self._nominal:
            if "mass" in values or "inertia" in values:
                v.set_mass_properties(mass * values.get("mass", 1.0), inertia * values.get("inertia", 1.0))
            if motor_params is not None and any(k in values for k in ("motor_kf", "motor_kt", "motor_tau")):
                m = motor_params
                v.actuators.motors.set_params(
                    dataclasses.replace(
                        m,
                        kf=m.kf * values.get("motor_kf", 1.0),
                        kt=m.kt * values.get("motor_kt", 1.0),
                        tau=m.tau * values.get("motor_tau", 1.0),
                        **self.model_factors(m, values),
                    )
                )
            elif motor_params is not None and "motor_rotor_drag" in values:
                v.actuators.motors.set_params(
                    dataclasses.replace(motor_params, **self.model_factors(motor_params, values))
                )
            if drag_params is not None and "drag" in values:
                d, f = drag_params, values["drag"]
                v.actuators.drag.set_params(
                    dataclasses.replace(
                        d, coefficients=tuple(c * f for c in d.coefficients), angular_damping=d.angular_damping * f
                    )
                )
        for v, battery in zip(self.world.vehicles, self._battery):
            if battery is not None and any(k.startswith("battery_") for k in values):
                v.battery.set_params(  # the vehicle's reset, which follows, starts it at this charge
                    dataclasses.replace(
                        battery,
                        capacity_mah=battery.capacity_mah * values.get("battery_capacity", 1.0),
                        internal_resistance=battery.internal_resistance * values.get("battery_resistance", 1.0),
                        initial_charge=values.get("battery_charge", battery.initial_charge),
                    )
                )
        if any(f"{t}_{k}" in values for t in ("gyro", "accel") for k in ("scale", "noise")):
            for triads in self._imu:
                for (triad, (scale, density, walk)), kind in zip(triads, ("gyro", "accel")):
                    noise = values.get(f"{kind}_noise", 1.0)
                    triad.scale = scale * values.get(f"{kind}_scale", 1.0)
                    triad.noise_density, triad.bias_random_walk = density * noise, walk * noise
        if "position_noise" in values:
            for suite, sigma in self._position:
                suite.position_noise_std = tuple(s * values["position_noise"] for s in sigma)
        winds = {k: x for k, x in values.items() if k.startswith("wind.")}
        if winds:
            self.world.set_wind(sampled_wind(self.wind, winds))
        return values

    @staticmethod
    def model_factors(m: Any, values: Mapping[str, float]) -> dict[str, Any]:
        """The optional motor models' randomised fields: tau_fall with motor_tau, rotor_drag."""
        out: dict[str, Any] = {}
        if m.tau_fall is not None:
            out["tau_fall"] = m.tau_fall * values.get("motor_tau", 1.0)
        if m.rotor_drag is not None:
            out["rotor_drag"] = m.rotor_drag * values.get("motor_rotor_drag", 1.0)
        return out

    @staticmethod
    def spawn(
        values: Mapping[str, float], position: Any, orientation: Any
    ) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The task's spawn pose plus the sampled ``spawn_*`` offsets."""
        x, y, z = (float(a) for a in position)
        r, p, w = (float(a) for a in orientation)
        return (
            (x + values.get("spawn_x", 0.0), y + values.get("spawn_y", 0.0), z + values.get("spawn_z", 0.0)),
            (r + values.get("spawn_roll", 0.0), p + values.get("spawn_pitch", 0.0), w + values.get("spawn_yaw", 0.0)),
        )
