"""Domain randomisation on the batched backend: per env and per episode, the PyBullet engine's draws.

The PyBullet engine's randomiser (:class:`pyflyt_engine.envs.randomization.Randomizer`)
draws every ``randomize`` entry at a reset, in the section's order, one call of the env's
generator each (:meth:`~pyflyt_engine.envs.randomization.Distribution.sample`), before the
spawn, and applies them to the vehicle.  :class:`BatchedRandomizer` does the same for each
env of a :class:`~pyflyt_engine.batched.env.BatchedUAVEnv` from that env's own generator,
so env ``i``'s episode draws what a PyBullet env drawing from that generator draws:

* ``mass``, ``inertia``: the body's mass and inertia diagonal become the assembly's dry
  mass and inertia diagonal times the factors, as ``Vehicle.set_mass_properties`` sets them
  (the assembly's values, not the URDF's 9 significant digits the nominal body has; both
  are set when either is drawn, as the randomiser sets them);
* ``motor_kf``, ``motor_kt``, ``motor_tau``: the motors' parameters with those factors
  (``dataclasses.replace`` of the nominal :class:`~pyflyt_engine.components.motor.MotorParams`),
  and from them, by the engine's own functions, the env's rows of the motor lag
  (``lag_coefficient``), the wrench columns (``motor_wrench_matrix``) and the reaction torque
  per newton of thrust that ground effect leaves unscaled (``reaction_per_thrust``), as
  ``Motors.set_params`` derives them;
* ``drag``: the body-drag coefficients and the angular damping times the factor, the env's
  rows of ``1/2 rho C_d A`` from :attr:`~pyflyt_engine.components.drag.DragParams.factors`;
* ``spawn_x`` ... ``spawn_yaw``: offsets added to the task's spawn (position, then Euler
  angles) before it is turned into the state, as ``Randomizer.spawn`` adds them (with any
  ``randomize`` entry, undrawn offsets add 0, as there);
* ``action_delay``, ``observation_delay``: handed to :class:`~pyflyt_engine.batched.latency.BatchedLatency`;
* ``gyro_scale``, ``accel_scale``, ``gyro_noise``, ``accel_noise``, ``position_noise``: the
  env's row of its noisy sensors' parameters (:func:`~pyflyt_engine.batched.sensors.randomized_parameters`:
  the triads' scale factors, white-noise densities and bias random walks, the fix's noise,
  each the nominal value times the factor, as the randomiser sets the engine's sensors).

The flight controller (the rate loop, the mixer, the cascade's outer loops, the fixed-wing
autopilot) keeps the nominal values, as the PyBullet engine's does.  The values drawn are
:attr:`BatchedRandomizer.values` (one row per env, one column per entry in the section's
order; the delays in seconds, as drawn), the env's ``info["randomization"]``.

On an airframe with the optional motor models or a pack, the motor factors (``tau_fall``
with ``motor_tau``), ``motor_rotor_drag`` and the pack's ``battery_capacity``,
``battery_resistance`` and ``battery_charge`` also set the env's rows of the modelled motors
and of the pack (:func:`~pyflyt_engine.batched.model.modelled_rows` of the drawn parameters,
as the engine's group and pack derive them).  An entry whose model the airframe lacks is
the engine's error (:func:`~pyflyt_engine.envs.randomization.missing_model`).

``wind.<path>`` (:meth:`BatchedRandomizer.apply_wind`): the config's wind with the draws in
it, by the engine randomiser's own :func:`~pyflyt_engine.envs.randomization.sampled_wind` (the
very config the PyBullet engine's world then flies, or its error for an invalid one), written
into env ``i``'s row of the wind parameters (:func:`~pyflyt_engine.batched.air.wind_params`)
and its rows of the Dryden filter (:func:`~pyflyt_engine.batched.air.dryden_filter`: its
matrices depend on the turbulence's intensities and scale lengths); the kernels read each
env's rows, every row the config's until a draw sets it.  In a multi-agent world the draw is
the world's, as the PyBullet engine's randomiser gives its one world the sampled wind: every
slot of world ``k`` gets the same rows, and the worlds' kernel reads its first slot's.

What this backend does not draw stays refused, by name (:func:`unsupported`): the entries
that would change the size of an env's filter (``wind.turbulence.rotary_min_span``: rotary
states or not; ``wind.turbulence.wind_speed_20ft`` on a config whose turbulence is off: no
filter rows).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from pyflyt_engine.assembly import assemble
from pyflyt_engine.components.drag import DragParams
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.motor import motor_wrench_matrix, reaction_per_thrust
from pyflyt_engine.batched.model import modelled_rows
from pyflyt_engine.batched.sensors import SENSOR_FACTORS, randomized_parameters
from pyflyt_engine.atmosphere import load_wind_config
from pyflyt_engine.batched.air import dryden_filter, wind_params
from pyflyt_engine.envs.randomization import (
    AIRFRAME,
    DELAYS,
    SPAWN,
    Distribution,
    Randomizer,
    missing_model,
    required_model,
    sampled_wind,
)
from pyflyt_engine.errors import ConfigError

if TYPE_CHECKING:
    from pyflyt_engine.batched.env import BatchedUAVEnv
    from pyflyt_engine.batched.swarm import BatchedSwarmEnv
    from pyflyt_engine.atmosphere import WindConfig
    from pyflyt_engine.spec import SensorsSpec, UAVSpec

#: the ``randomize`` entries the batched backend draws and applies
#: the factors (and the charge) of the optional motor models and the battery
MODEL_FACTORS = ("motor_rotor_drag", "battery_capacity", "battery_resistance", "battery_charge")
BATCHED_PARAMETERS = AIRFRAME + DELAYS + SPAWN + SENSOR_FACTORS + MODEL_FACTORS
MOTOR = ("motor_kf", "motor_kt", "motor_tau")
BATTERY = ("battery_capacity", "battery_resistance", "battery_charge")
#: the env's per-env turbulence filter arrays (a checkpoint carries them with drawn winds)
DRYDEN_ROWS = ("_dryden_phi", "_dryden_c", "_dryden_noise", "_dryden_root", "_dryden_flags")


def unsupported(entries: dict[str, Distribution] | None, wind: Any = None) -> tuple[str, str] | None:
    """The first entry of a ``randomize`` section the batched backend does not draw, and why
    (None: it draws them all); ``wind``: the config's wind (what a ``wind.<path>`` entry
    varies).  The same for a single-agent env's section and a multi-agent world's (one wind
    per world, every slot of the world given its rows)."""
    for name in entries or {}:
        if name.startswith("wind."):
            if name == "wind.turbulence.rotary_min_span":
                return name, (
                    "it decides per env whether the turbulence filter has rotary states, and the envs' filter "
                    "rows keep the config's size"
                )
            turbulence = load_wind_config(wind).turbulence
            if name == "wind.turbulence.wind_speed_20ft" and turbulence is not None and turbulence.wind_speed_20ft <= 0:
                return name, (
                    "the config's turbulence is off (wind_speed_20ft 0), so the envs have no filter rows for a "
                    "drawn one; give the config's wind a positive wind_speed_20ft"
                )
            continue
        if name not in BATCHED_PARAMETERS:
            return name, "the batched backend does not draw it per env"
    return None


class BatchedRandomizer:
    """The ``randomize`` draws of ``num_envs`` batched envs (module docstring).

    Args:
        entries: the config's ``randomize`` section (name -> :class:`Distribution`), every
            name in :data:`BATCHED_PARAMETERS`.
        spec: the airframe (its nominal mass, inertia, motors and drag).
        physics_dt: the physics step [s] (the motors' lag).
        num_envs: how many envs.

    Attributes:
        names: the entries, in the section's order.
        values: (N, entries) this episode's draws per env (NaN before the first reset).
        spawn_offsets: (N, 6) per env, the drawn ``spawn_*`` offsets (0 where not drawn).
    """

    def __init__(
        self,
        entries: dict[str, Distribution],
        spec: UAVSpec,
        physics_dt: float,
        num_envs: int,
        sensors: SensorsSpec | None = None,
        wind: WindConfig | None = None,
        span: float = 0.0,
        vehicles: int = 1,
    ) -> None:
        self.entries = dict(entries)
        self.names = tuple(self.entries)
        n = int(num_envs)
        self.values = np.full((n, len(self.names)), np.nan)
        self.spawn_offsets = np.zeros((n, len(SPAWN)))
        self.physics_dt = float(physics_dt)
        parts = assemble(spec)
        self._mass = float(parts.mass)
        self._inertia = np.diag(np.asarray(parts.inertia, dtype=np.float64)).copy()
        self._motors = parts.motors
        self._battery = parts.battery
        self._drag = DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping)
        for name in self.names:  # an entry with nothing to randomise is the engine's error
            needs = required_model(name)
            has = {
                "battery": parts.battery is not None,
                "sensors.imu": sensors is not None and sensors.imu is not None,
                "sensors.position": sensors is not None and sensors.position is not None,
                "motors.rotor_drag": parts.motors is not None and parts.motors.rotor_drag is not None,
            }
            if needs is not None and not has[needs]:
                raise missing_model(name, needs)
        drawn = set(self.names)
        #: the airframe flies the optional motor models or a battery (their rows follow the motors' draws)
        self.modelled = parts.motors is not None and (parts.motors.modelled or parts.battery is not None)
        self.body = bool(drawn & {"mass", "inertia"})
        self.motors = bool(drawn & {*MOTOR, "motor_rotor_drag"}) and self._motors is not None
        #: a battery factor (or the charge) is drawn: each env's row of the pack's parameters changes
        self.pack = bool(drawn & set(BATTERY)) and self._battery is not None
        self.drag = "drag" in drawn
        #: a sensor factor is drawn: each env's row of its sensors' parameters changes per episode
        self.sensing = bool(drawn & set(SENSOR_FACTORS))
        #: the ``wind.<path>`` entries: each env's rows of the wind parameters (and of the
        #: turbulence filter) change per episode
        self.winds = tuple(name for name in self.names if name.startswith("wind."))
        self.span = float(span)
        #: the vehicles of a world (a multi-agent world's filter has each one's rotary rows)
        self.vehicles = int(vehicles)
        self._wind_nominal = (wind if wind is not None else load_wind_config(None)).model_dump(mode="json")
        nominal_filter = dryden_filter(load_wind_config(self._wind_nominal), self.physics_dt, self.span, self.vehicles)
        #: the config's turbulence filter's size (states, rotary): every drawn wind keeps it
        self._filter_shape = (nominal_filter.states, nominal_filter.rotary) if nominal_filter is not None else None

    @property
    def airframe(self) -> bool:
        """Whether any airframe or sensor factor is drawn (the env's parameter rows change per episode)."""
        return self.body or self.motors or self.drag or self.sensing or self.pack

    def arrays(self) -> tuple[str, ...]:
        """The env's arrays whose rows the draws set (a checkpoint carries them): the values,
        and the parameter rows :meth:`apply` writes."""
        return (
            ("randomized_values",)
            + (("_mass", "_inertia") if self.body else ())
            + (("_lag", "_columns", "_rotors") if self.motors else ())
            + (("_motor_model",) if self.motors and self.modelled else ())
            + (("_battery_params", "_battery_reset") if self.pack else ())
            + (("_drag_factors", "_damping") if self.drag else ())
            + (("sensor_params",) if self.sensing else ())
            + (("_wind_rows",) if self.winds else ())
            + (DRYDEN_ROWS if self.winds and self._filter_shape is not None else ())
        )

    def draw(self, i: int | np.ndarray, rng: np.random.Generator) -> dict[str, float]:
        """Env ``i``'s values for its next episode: every entry, in the section's order, one
        call of ``rng`` each (``Distribution.sample``, as the PyBullet engine's randomiser).
        ``i`` may be several rows: they share the one draw (the vehicles of a multi-agent
        world, as the PyBullet engine's randomiser gives every vehicle of its world the same values)."""
        values = {name: dist.sample(rng) for name, dist in self.entries.items()}
        self.values[i] = [values[name] for name in self.names]
        self.spawn_offsets[i] = [values.get(name, 0.0) for name in SPAWN]
        return values

    def apply(self, env: BatchedUAVEnv | BatchedSwarmEnv, i: int, values: dict[str, float]) -> None:
        """Env (or vehicle) ``i``'s parameter rows from its nominal values and ``values`` (the airframe
        factors; the controller's rows are left nominal)."""
        if self.body:  # Vehicle.set_mass_properties(mass * f, inertia * g)
            env._mass[i] = self._mass * values.get("mass", 1.0)
            env._inertia[i] = self._inertia * values.get("inertia", 1.0)
        params = None
        if self.motors:
            m = self._motors
            assert m is not None
            params = dataclasses.replace(  # as Randomizer.sample replaces them (the optional models' fields too)
                m,
                kf=m.kf * values.get("motor_kf", 1.0),
                kt=m.kt * values.get("motor_kt", 1.0),
                tau=m.tau * values.get("motor_tau", 1.0),
                **Randomizer.model_factors(m, values),
            )
            env._lag[i] = np.asarray(lag_coefficient(self.physics_dt, params.tau), dtype=np.float64).reshape(-1)
            env._columns[i] = motor_wrench_matrix(params).T
            env._rotors[i, :, 4] = reaction_per_thrust(params)
            wake = getattr(env, "_wake_thrust", None)  # a multi-agent world's: the strength of the vehicle's wake
            if wake is not None:
                wake[i] = params.max_thrust
        if self.modelled and (self.motors or self.pack):  # the rows the engine's group and pack derive
            motors = params if self.motors else self._motors
            assert motors is not None  # a modelled airframe has motors
            battery = self._battery
            if self.pack:
                assert battery is not None
                battery = dataclasses.replace(  # as Randomizer.sample sets the pack
                    battery,
                    capacity_mah=battery.capacity_mah * values.get("battery_capacity", 1.0),
                    internal_resistance=battery.internal_resistance * values.get("battery_resistance", 1.0),
                    initial_charge=values.get("battery_charge", battery.initial_charge),
                )
            rows = modelled_rows(motors, battery, self.physics_dt)
            env._motor_model[i] = rows["motor_model"]
            if self.pack:
                env._battery_params[i] = rows["battery"]
                env._battery_reset[i] = rows["battery_reset"]
        if self.drag:
            d, f = self._drag, values["drag"]
            cx, cy, cz = d.coefficients
            d = dataclasses.replace(d, coefficients=(cx * f, cy * f, cz * f), angular_damping=d.angular_damping * f)
            env._drag_factors[i] = d.factors
            env._damping[i] = d.angular_damping
        sensors = env.sensors
        if self.sensing and sensors is not None:
            sensors.param_rows[i] = randomized_parameters(sensors.params, values)

    def apply_wind(self, env: BatchedUAVEnv | BatchedSwarmEnv, i: int | np.ndarray, values: dict[str, float]) -> None:
        """Env ``i``'s rows (a world's slots ``i``: each of them) of the wind parameters and of
        the turbulence filter for its episode, the filter built once:
        the config's wind with the ``wind.<path>`` draws in it (:func:`~pyflyt_engine.envs.randomization.sampled_wind`,
        the very config the PyBullet engine's randomiser gives its world, ConfigError if invalid),
        written as :func:`~pyflyt_engine.batched.air.wind_params` and
        :func:`~pyflyt_engine.batched.air.dryden_filter` write the config's.  A draw that turns
        the turbulence off (``wind_speed_20ft`` 0) leaves the env's filter rows as they are (its
        parameters row says no turbulence, as the engine's field then has no filter)."""
        config = sampled_wind(self._wind_nominal, {name: values[name] for name in self.winds})
        drawn = dryden_filter(config, self.physics_dt, self.span, self.vehicles)
        shape = (drawn.states, drawn.rotary) if drawn is not None else None
        if drawn is not None and shape != self._filter_shape:  # refused at load where it can happen (unsupported)
            raise ConfigError(
                f"randomize: the sampled wind {dict((k, values[k]) for k in self.winds)} needs a turbulence filter "
                f"of {drawn.states} states, the env's has {self._filter_shape[0] if self._filter_shape else 0}"
            )
        env._wind_rows[i] = wind_params(config, rotary=drawn is not None and drawn.rotary)
        if drawn is not None:
            for rows, array in zip(env._dryden_rows, drawn.arrays):
                rows[i] = array

    def info(self, index: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The values of every env's current episode by entry ((N,) each), as the PyBullet
        env's ``info["randomization"]`` holds one episode's; ``index``: those envs' rows only."""
        rows = self.values if index is None else self.values[index]
        return {name: rows[:, k].copy() for k, name in enumerate(self.names)}


__all__ = ["BATCHED_PARAMETERS", "BatchedRandomizer", "unsupported"]
