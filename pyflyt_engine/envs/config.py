"""Typed environment and reward configs (``conf/env/*.yaml``, ``conf/reward/*.yaml``).

Files are read with the bounded YAML reader of :mod:`pyflyt_engine.safe_load` and validated by the pydantic models below
(``extra="forbid"``: a misspelt key is an error naming the valid keys).  Every field is
documented where it is declared.  Loading never imports or runs code named in a file:
tasks, reward terms and conditions are looked up by name in plain registries.

* :func:`load_env_config` — a shipped name (``quadx_hover``), a path, or a mapping; a
  mapping with ``agents`` is a :class:`MultiAgentEnvConfig` (``conf/env/ma_*.yaml``).
* :func:`load_reward_preset` — a shipped name (``quadx_hover_dense``), a path, or a mapping.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    SerializeAsAny,
    SerializerFunctionWrapHandler,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)

from pyflyt_engine.components.estimator import alpha_beta_gains
from pyflyt_engine import limits
from pyflyt_engine.envs import rewards, terminations
from pyflyt_engine.envs.randomization import Distribution, check_names, delay_steps
from pyflyt_engine.envs.task_registry import TaskTable
from pyflyt_engine.envs.tasks import TaskOptions, get_task
from pyflyt_engine.envs.tasks.dogfight import DogfightOptions  # noqa: F401  (re-exported)
from pyflyt_engine.envs.tasks.ma_formation import MAFormationOptions  # noqa: F401  (re-exported)
from pyflyt_engine.envs.tasks.ma_hover import MAHoverOptions  # noqa: F401  (re-exported)
from pyflyt_engine.envs.tasks.multi import MATaskOptions, ResolvedAgent, SpawnConfig, Vec3
from pyflyt_engine.envs.tasks.multi import grid_layout  # noqa: F401  (re-exported)
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.obstacles import ObstaclesConfig
from pyflyt_engine.payloads import PayloadSpec
from pyflyt_engine.loading import (
    available,
    check,
    composed,
    load,
    problem_list,
    resolve,
    unknown_name,
    validate,
    with_defaults,
)
from pyflyt_engine.safe_load import load_yaml_file
from pyflyt_engine.spec import CameraSpec, RangeSensorSpec, SensorsSpec, check_finite
from pyflyt_engine.suggest import did_you_mean


class _Config(BaseModel):
    # every float finite, also inside tuples, lists and mappings (no .inf / .nan from YAML)
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


# ---------------------------------------------------------------------- reward


class TermConfig(_Config):
    """One entry of a reward preset: ``weight * term(ctx, **params)`` when every condition holds."""

    term: str | None = Field(None, description="registered term name (default: the entry's key); see `pyflyt envs`")
    weight: float = Field(1.0, description="multiplies the term's value")
    when: Union[str, list[str]] = Field(
        "always", description="condition name or list of names that must all hold; prefix not_ negates"
    )
    params: dict[str, Annotated[Union[float, list[float]], BeforeValidator(check_finite)]] = Field(
        default_factory=dict, description="keyword parameters of the term"
    )


class RewardPreset(_Config):
    """A reward: the weighted sum of its ``terms`` (in declaration order)."""

    description: str = Field("", description="free text, shown by `pyflyt envs`")
    terms: dict[str, TermConfig] = Field(description="entry name -> term; entry names key info['reward_terms']")
    name: str = Field("inline", description="preset name (the file name without .yaml)")

    @field_validator("terms")
    @classmethod
    def _known(cls, terms: dict[str, TermConfig]) -> dict[str, TermConfig]:
        if not terms:
            raise ValueError("a reward preset needs at least one term")
        # names and parameters are checked here, task signals when the env is built
        rewards.compile_reward("", terms)
        return terms

    def compile(self, provides: frozenset[str] | None = None, task_name: str = "?") -> rewards.RewardFunction:
        """The :class:`~pyflyt_engine.envs.rewards.RewardFunction` of this preset."""
        return rewards.compile_reward(self.name, self.terms, provides, task_name)


# ----------------------------------------------------------------- terminations


class TerminationConfig(_Config):
    """One entry of ``terminations``: a registered termination term and its parameters."""

    term: str | None = Field(
        None, description="registered termination term (default: the entry's key); see pyflyt_engine.envs.terminations"
    )
    params: dict[str, Union[bool, float]] = Field(default_factory=dict, description="keyword parameters of the term")


def _default_terminations() -> dict[str, TerminationConfig | None]:
    """The declaration of every shipped env (``conf/env/_base.yaml``): a config's default."""
    return {k: TerminationConfig(**v) for k, v in terminations.DEFAULT_TERMINATIONS.items()}


def _check_terminations(value: dict[str, TerminationConfig | None]) -> dict[str, TerminationConfig | None]:
    terminations.declared(value)  # names and parameters, at load
    return value


# ------------------------------------------------------------------------- env


class ActionConfig(_Config):
    """The action space: a Box whose vector is sent as the setpoint of one flight mode."""

    mode: str = Field(description="vehicle flight mode receiving the action as its setpoint (see `pyflyt modes`)")
    names: list[str] = Field(description="name of each action entry (the mode's setpoint layout)")
    units: list[str] | None = Field(None, description="unit of each entry, for documentation")
    low: list[float] = Field(description="lower bound of each entry; actions are clipped to [low, high]")
    high: list[float] = Field(description="upper bound of each entry")

    @model_validator(mode="after")
    def _consistent(self) -> ActionConfig:
        n = len(self.names)
        for key in ("low", "high") + (("units",) if self.units is not None else ()):
            if len(getattr(self, key)) != n:
                raise ValueError(f"'{key}' has {len(getattr(self, key))} entries but 'names' has {n}")
        for name, lo, hi in zip(self.names, self.low, self.high):
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"action '{name}': need finite low < high, got [{lo}, {hi}]")
        return self


class RenderConfig(_Config):
    """The ``rgb_array`` chase camera."""

    resolution: tuple[int, int] = Field((480, 480), description="image (height, width) [px]")

    @field_validator("resolution")
    @classmethod
    def _resolution(cls, value: tuple[int, int]) -> tuple[int, int]:
        if min(value) < 1:
            raise ValueError(f"resolution: height and width must be at least 1 pixel, got {list(value)}")
        for side, name in zip(value, ("height", "width")):
            limits.check("image_side", side, name=f"resolution {name}")
        return value

    camera_distance: float = Field(0.6, gt=0, description="camera distance behind the vehicle [m]")
    camera_height: float = Field(0.25, description="camera height above the vehicle [m]")
    fov: float = Field(60.0, gt=0, lt=180, description="vertical field of view [deg]")


class CameraObservationConfig(_Config):
    """An onboard camera image added to the observation (``camera_observation:`` in an env YAML).

    The camera is added to the airframe for this environment only and rendered at every
    agent step.  The observation becomes a ``Dict``: the task's observation under
    ``attitude`` (or its own keys if it is already a ``Dict``), plus the image under ``key``.
    """

    camera: CameraSpec = Field(description="the camera: mount pose, field of view, resolution (see `pyflyt uav`)")
    key: str = Field("image", description="observation key of the image")
    channels: Literal["rgb", "rgba"] = Field("rgb", description="colour channels, in this order")
    channel_first: bool = Field(
        False, description="image shape (C, H, W) instead of (H, W, C); row 0 is the top of the image"
    )

    @field_validator("key")
    @classmethod
    def _key(cls, value: str) -> str:
        if value in ("attitude", "target_deltas", "goal_delta", "gate"):
            raise ValueError(f"'{value}' is an observation key of the tasks: choose another key for the image")
        return value


#: default velocity-filter gains: the steady-state Kalman gains at Kalata's tracking index
#: lambda = sigma_a T_f^2 / sigma_p = 0.05 (components/estimator.py, alpha_beta_gains), e.g.
#: sigma_a = 0.5 m/s^2 of acceleration error (a 3 deg tilt error is 0.51 m/s^2) with
#: 1 mm motion-capture fixes at 100 Hz: 0.5 * 0.01^2 / 0.001 = 0.05 (this project's choice)
DEFAULT_TRACKING_INDEX = 0.05
_DEFAULT_ALPHA, _DEFAULT_BETA = alpha_beta_gains(DEFAULT_TRACKING_INDEX)


def _estimator_name(value: Any) -> Any:
    # `estimator: complementary` is short for `estimator: {type: complementary}`
    return {"type": value} if isinstance(value, str) else value


class EstimatorConfig(_Config):
    """The flight controller's state estimator the observation is built from
    (docs/environments.md, "Estimated state"; :mod:`pyflyt_engine.components.estimator`).
    ``none``: attitude and velocity stay true.  ``complementary``: attitude from Mahony's
    explicit complementary filter (gains ``k_p``, ``k_i``), velocity and position from a
    fixed-gain position-velocity filter on the accelerometer and the position fixes
    (gains ``alpha``, ``beta``)."""

    type: Literal["none", "complementary"] = Field("none", description="none | complementary")
    k_p: float = Field(
        1.0,
        gt=0,
        description="attitude gain [rad/s]: the accelerometer pulls the tilt estimate with time constant 1 / k_p "
        "(this project's choice: 1 s, long against a manoeuvre's accelerations)",
    )
    k_i: float = Field(
        0.25,
        ge=0,
        description="gyro-bias gain [rad/s^2]; 0 learns no bias.  Default k_p^2 / 4: the linearised attitude "
        "error is critically damped",
    )
    alpha: float = Field(
        _DEFAULT_ALPHA,
        gt=0,
        description="position gain per fix [-] (default: the steady-state Kalman gain at tracking index 0.05)",
    )
    beta: float = Field(
        _DEFAULT_BETA,
        gt=0,
        description="velocity gain per fix [-]; the velocity moves by beta * fix_rate * error "
        "(default: the steady-state Kalman gain at tracking index 0.05)",
    )

    @model_validator(mode="after")
    def _stable(self) -> EstimatorConfig:
        gains = sorted(self.model_fields_set - {"type"})
        if self.type == "none" and gains:
            raise ValueError(
                f"sensors.estimator: {', '.join(gains)} given with type none, which has no gains; "
                "set type: complementary, or remove them"
            )
        if 2.0 * self.alpha + self.beta >= 4.0:
            raise ValueError(
                f"alpha = {self.alpha:g}, beta = {self.beta:g}: the position-velocity filter is unstable unless "
                "2 alpha + beta < 4 (Jury's test); lower them, e.g. the defaults "
                f"alpha = {_DEFAULT_ALPHA:.6g}, beta = {_DEFAULT_BETA:.6g}"
            )
        return self

    @property
    def active(self) -> bool:
        return self.type != "none"


class EnvSensorsConfig(SensorsSpec):
    """Noisy sensors for this env (docs/environments.md, "Sensor observation"): any of
    ``imu``, ``position``, ``barometer`` given here replace the airframe's ``sensors``
    section; none given keeps the airframe's own.  With ``observe`` the observation is built
    from their readings: body rates from the gyro, position from the position sensor, height
    from the barometer (attitude and velocity stay true), and the position fix's validity
    flag is appended after the auxiliary state.  With ``estimator: complementary`` (needs
    ``observe``, an IMU and a position fix) attitude, velocity and position come from the
    flight controller's estimator instead (docs/environments.md, "Estimated state")."""

    observe: bool = Field(
        True, description="build the observation from the sensors' readings instead of the true state"
    )
    estimator: Annotated[EstimatorConfig, BeforeValidator(_estimator_name)] = Field(
        default_factory=EstimatorConfig,
        description="none (attitude and velocity true) | complementary (estimated from the IMU and the "
        "position fix), or a mapping with 'type' and the gains",
    )

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        data = handler(self)
        # without an estimator the sensors dump, and are recorded, as before it existed
        if isinstance(data, dict) and not self.estimator.active:
            data.pop("estimator", None)
        return data

    @model_validator(mode="after")
    def _estimator_observed(self) -> EnvSensorsConfig:
        if self.estimator.active and not self.observe:
            raise ValueError(
                f"sensors.estimator: '{self.estimator.type}' builds the observation, but sensors.observe is false; "
                "set sensors.observe: true, or estimator: none"
            )
        return self


class LatencyConfig(_Config):
    """Delays between the agent and each vehicle (docs/engine.md, "Latency"), in seconds,
    applied at physics resolution: each is rounded to the nearest whole number of physics
    steps (halves up), ``round(delay * physics_hz)``
    (:func:`pyflyt_engine.envs.randomization.delay_steps`).  A ``randomize`` entry
    ``action_delay`` / ``observation_delay`` replaces that delay in every episode."""

    action_delay: float = Field(
        0.0, ge=0, description="from an action to the vehicle's flight controller [s] (it takes it at its next tick)"
    )
    observation_delay: float = Field(0.0, ge=0, description="age of the state in the observation [s]")

    def steps(self, physics_hz: float) -> tuple[int, int]:
        """(action, observation) delays in physics steps: each rounded to the nearest step, halves up."""
        return delay_steps(self.action_delay, physics_hz), delay_steps(self.observation_delay, physics_hz)


class EnvConfig(_Config):
    """An environment: vehicle, loop rates, episode limits, action, task and reward."""

    id: str | None = Field(None, description="Gymnasium id this config is registered under, if any")
    description: str = Field("", description="one line shown by `pyflyt envs`")
    uav: str = Field("quadx_cf2x", description="shipped airframe name (conf/uav) or path to a UAV YAML")
    physics_hz: float = Field(240.0, gt=0, description="physics rate [Hz] (paper: 240)")
    control_hz: float = Field(120.0, gt=0, description="flight controller rate [Hz] (paper: 120)")
    agent_hz: float = Field(
        30.0, gt=0, description="agent step rate [Hz] (paper: 30); physics_hz / agent_hz must be whole"
    )
    max_duration_seconds: float = Field(10.0, gt=0, description="simulated episode length before truncation [s]")
    flight_dome_size: float = Field(
        5.0, gt=0, description="radius [m] of the sphere about the origin the vehicle must stay inside"
    )
    angle_representation: Literal["euler", "quaternion"] = Field(
        "quaternion", description="attitude in the observation: Euler (roll, pitch, yaw) or quaternion (x, y, z, w)"
    )
    drag: bool = Field(True, description="apply the airframe's body drag")
    backend: Literal["pybullet", "batched", "auto"] = Field(
        "pybullet",
        description="what simulates training: pybullet (every config; one env per call), batched (N multirotors "
        "as arrays, one compiled call per step; a training run and the batched env refuse by name what it does "
        "not simulate, docs/batched.md) or auto (batched where it simulates the config, else pybullet; a "
        "training run records which); evaluation, recordings and pyflyt eval always fly the PyBullet engine",
    )
    wind: Union[str, dict[str, Any]] = Field(
        "calm",
        description="the atmosphere: a preset in conf/wind (calm, constant, shear, gust, dryden_light, "
        "dryden_moderate, dryden_severe), a path to a wind YAML, or an inline mapping (docs/atmosphere.md)",
    )
    reward: Union[str, dict[str, Any]] = Field(
        "dense",
        description="'dense' or 'sparse' (see reward_presets), a preset name in conf/reward, "
        "a path to a preset YAML, or an inline preset mapping",
    )
    reward_presets: dict[Literal["dense", "sparse"], str] = Field(
        description="the presets that reward 'dense' / 'sparse' (and sparse_reward=True) select"
    )
    action: ActionConfig
    controller: Literal["own", "betaflight"] = Field(
        "own",
        description="the flight controller: own (the airframe's, flying action.mode) or betaflight (Betaflight's "
        "firmware in the loop, docs/firmware.md: an action in rates_thrust becomes ACRO sticks; the paper's "
        "240/120/30 Hz loop rates become 1000/1000/50 Hz)",
    )
    firmware_action: Literal["sticks", "rates"] = Field(
        "sticks",
        description="with controller betaflight, what an action in rates_thrust becomes: sticks (ACRO sticks in "
        "[-1, 1] and a throttle in [0, 1], at 1000/1000/50 Hz) or rates (the same rates_thrust action, turned "
        "into sticks by inverting the rate curve: a policy of the own controller flies the firmware; 1500/500/30 Hz)",
    )
    task: SerializeAsAny[TaskOptions] = Field(description="task name and options (see pyflyt_engine.envs.tasks)")
    render: RenderConfig = Field(default_factory=RenderConfig)
    terminations: Annotated[dict[str, TerminationConfig | None], AfterValidator(_check_terminations)] = Field(
        default_factory=_default_terminations,
        description="what ends an episode: entry -> registered termination term (crash, end or truncate) and its "
        "params, in order; null switches an entry off (pyflyt_engine.envs.terminations, docs/environments.md)",
    )
    camera_observation: CameraObservationConfig | None = Field(
        None, description="add an onboard camera image to the observation (None: no image)"
    )
    payloads: list[PayloadSpec] = Field(
        default_factory=list,
        description="rigid bodies attached to the vehicle or the world (see pyflyt_engine.payloads)",
    )
    obstacles: ObstaclesConfig | None = Field(
        None,
        description="static obstacles: fixed items and seeded layouts drawn at every reset (docs/obstacles_and_sensors.md)",
    )
    range_sensors: list[RangeSensorSpec] = Field(
        default_factory=list,
        description="LiDARs and ray-cast depth cameras added to the airframe for this env; each reading is an "
        "observation entry under the sensor's name (docs/obstacles_and_sensors.md)",
    )
    source: str | None = Field(None, exclude=True, description="file the config was loaded from")

    ground_effect: bool = Field(
        False, description="rotor thrust times the Cheeseman-Bennett ground-effect ratio (rotors with a prop_radius)"
    )
    downwash: bool = Field(False, description="vehicles below a rotorcraft feel its wake as a downward wind")

    randomize: dict[str, Distribution] = Field(
        default_factory=dict,
        description="domain randomisation: parameter -> bounded distribution, drawn at every reset "
        "(pyflyt_engine.envs.randomization); a name loads a preset of conf/randomize",
    )
    latency: LatencyConfig | None = Field(
        None,
        description="action and observation delays per vehicle [s], rounded to physics steps (docs/engine.md); "
        "null: none; a randomize entry action_delay / observation_delay replaces that delay per episode",
    )
    sensors: EnvSensorsConfig | None = Field(
        None,
        description="noisy IMU, position sensor and barometer, and whether the observation is built from them "
        "(docs/environments.md); null: the true state",
    )

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        data = handler(self)
        for key in ("latency", "sensors"):  # a config without them dumps, and is recorded, as before they existed
            if isinstance(data, dict) and data.get(key, 0) is None:
                del data[key]
        if isinstance(data, dict) and data.get("backend") == "pybullet":  # the default, as before the key existed
            del data["backend"]
        return data

    @model_validator(mode="before")
    @classmethod
    def _firmware_in_the_loop(cls, data: Any) -> Any:
        """``controller: betaflight``: the sticks as the action and loop rates the firmware's
        clock can follow (docs/firmware.md, "In an env")."""
        if not isinstance(data, dict) or data.get("controller") != "betaflight":
            return data
        data = dict(data)
        from pyflyt_engine.firmware.betaflight import FIRMWARE_RATES, FIRMWARE_RATES_AT_30_HZ, PAPER_RATES, STICKS

        keys = ("physics_hz", "control_hz", "agent_hz")
        rates = tuple(float(data.get(k, d)) for k, d in zip(keys, PAPER_RATES))
        as_rates = data.get("firmware_action", "sticks") == "rates"
        if rates == PAPER_RATES:  # the firmware's gyro period needs whole microseconds
            data.update(zip(keys, FIRMWARE_RATES_AT_30_HZ if as_rates else FIRMWARE_RATES))
        action = data.get("action")
        if isinstance(action, dict) and action.get("mode") == "rates_thrust" and as_rates:
            pass  # flown as it is, through the inverted rate curve
        elif isinstance(action, dict) and action.get("mode") == "rates_thrust":
            data["action"] = {
                "mode": "acro",
                "names": list(STICKS),
                "units": ["1", "1", "1", "1"],
                "low": [-1.0, -1.0, -1.0, 0.0],
                "high": [1.0, 1.0, 1.0, 1.0],
            }
        elif isinstance(action, dict) and action.get("mode") not in ("acro", "angle", "rates_thrust"):
            raise ValueError(
                f"controller betaflight flies the modes acro and angle (sticks); this env's action is mode "
                f"'{action.get('mode')}': give action.mode acro (or an action in rates_thrust, which becomes acro)"
            )
        return data

    @field_validator("physics_hz", "control_hz", "agent_hz", "max_duration_seconds", "flight_dome_size")
    @classmethod
    def _bounded(cls, value: float, info: ValidationInfo) -> float:
        assert info.field_name is not None  # a field validator is always given its field's name
        return limits.check(info.field_name, value)

    @model_validator(mode="after")
    def _episode_steps(self) -> EnvConfig:
        limits.check(
            "episode_physics_steps",
            self.physics_hz * self.max_duration_seconds,
            name="physics_hz x max_duration_seconds",
        )
        if self.max_duration_seconds * self.agent_hz < 1:
            raise ValueError(
                f"max_duration_seconds {self.max_duration_seconds:g} s is shorter than one agent step "
                f"(1 / agent_hz = {1 / self.agent_hz:g} s): give a longer episode"
            )
        return self

    @model_validator(mode="after")
    def _latency(self) -> EnvConfig:
        if self.latency is not None:
            for name in ("action_delay", "observation_delay"):
                delay = getattr(self.latency, name)
                if delay >= self.max_duration_seconds:
                    raise ValueError(
                        f"latency.{name}: {delay:g} s is not shorter than the episode (max_duration_seconds "
                        f"{self.max_duration_seconds:g} s): nothing the agent does would reach the vehicle; give a "
                        "delay of a few physics steps"
                    )
        return self

    @field_validator("randomize", mode="before")
    @classmethod
    def _randomize_preset(cls, value: Any) -> Any:
        if isinstance(value, str):  # a name, never a path out of conf/randomize
            path = resolve(value, "randomize", what="randomize preset", files=False, unknown=_unknown_randomize)
            data = load_yaml_file(path, what="randomize preset file")
            if not isinstance(data, Mapping):
                raise ValueError(f"{path}: a randomize preset must map parameter names to distributions")
            return dict(data)
        return value

    @model_validator(mode="after")
    def _randomize_names(self) -> EnvConfig:
        if self.randomize:
            try:
                check_names(self.randomize, self.wind, episode=self.max_duration_seconds)
            except ValueError as exc:
                raise ValueError(f"randomize: {exc}") from None
        return self

    @field_validator("wind")
    @classmethod
    def _wind(cls, wind: Union[str, dict[str, Any]]) -> Union[str, dict[str, Any]]:
        from pyflyt_engine.atmosphere import load_wind_config

        load_wind_config(wind)  # a bad preset, key or value fails here, at load
        return wind

    @model_validator(mode="after")
    def _payloads(self) -> EnvConfig:
        names = [p.name for p in self.payloads]
        for name in names:
            if names.count(name) > 1:
                raise ValueError(f"payload name '{name}' is used twice: give each payload its own name")
        for i, payload in enumerate(self.payloads):
            if payload.attach.to == "world":
                reach = payload.farthest_reach()
                if reach > self.flight_dome_size:
                    raise ValueError(
                        f"payloads.{i} ('{payload.name}') reaches {reach:.3g} m from the origin, outside the flight "
                        f"dome (flight_dome_size {self.flight_dome_size:g} m): move it closer or enlarge the dome"
                    )
        return self

    @property
    def max_steps(self) -> int:
        """Agent steps per episode before truncation."""
        return max(1, int(round(self.max_duration_seconds * self.agent_hz)))

    def reward_preset_name(self) -> str | dict[str, Any]:
        """The preset that :attr:`reward` selects (name, path or inline mapping)."""
        if isinstance(self.reward, str) and self.reward in self.reward_presets:
            return self.reward_presets[self.reward]
        return self.reward

    def with_overrides(self, **overrides: Any) -> EnvConfig:
        """A copy with top-level fields or task options replaced (validated again).

        Task options may be given by their own name (``num_targets=3``) or inside
        ``task={...}``; unknown names raise :class:`ConfigError` listing the valid ones.
        """
        if not overrides:
            return self
        data = self.model_dump(exclude={"source"})
        task = dict(data["task"])
        task_fields = set(type(self.task).model_fields) - {"name"}
        for key, value in overrides.items():
            if key == "task" and isinstance(value, Mapping):
                task.update(value)
            elif key in type(self).model_fields and key not in ("source", "task"):
                data[key] = value
            elif key in task_fields:
                task[key] = value
            else:
                valid = sorted((set(type(self).model_fields) - {"source"}) | task_fields)
                hint = did_you_mean(key, valid)
                raise ConfigError(f"unknown environment argument '{key}'.{hint} Valid: {', '.join(valid)}")
        data["task"] = task
        return parse_env_config(data, source=f"{self.source or 'config'} with overrides {sorted(overrides)}")


# ---------------------------------------------------------------------- loading


def _unknown_randomize(name: Any) -> str:
    return unknown_name(name, available("randomize"), "randomize preset", files="")


# ----------------------------------------------------------------- multi-agent
# A multi-agent config (``conf/env/ma_*.yaml``) is an EnvConfig (loop rates, episode
# length, flight dome, action, reward presets ...) plus ``agents`` and a multi-agent
# ``task``.  ``agents`` is either a count -- that many agents of the env's ``uav``, placed
# by the task's layout -- or a list, one entry per agent::
#
#     agents:
#       - {uav: quadx_f450, spawn: {position: [-1, 0, 1]}}
#       - {uav: quadx_cf2x, spawn: {position: [1, 0, 1]}, hover_point: [1, 0, 1.5]}
#
# A mapping with ``agents`` is validated by parse_multi_agent_config, reached through
# parse_env_config, so every loader of env configs accepts both kinds.  The task options
# (MATaskOptions and each task's model), SpawnConfig, grid_layout and ResolvedAgent live
# with the multi-agent tasks (pyflyt_engine.envs.tasks.multi and one module per task) and
# are re-exported here.

#: The most agents one world takes: the range the swarm envs are tested and measured over
#: (``pyflyt speed`` times 1 to 128; docs/multi_agent.md).
MAX_AGENTS = 128


class AgentConfig(_Config):
    """One entry of ``agents``."""

    name: str | None = Field(None, description="agent name (default uav_<index>); unique")
    uav: str | None = Field(None, description="airframe (conf/uav name or YAML path); default: the env's uav")
    team: int | None = Field(None, ge=0, le=1, description="team 0 or 1 (dogfight; default: first half 0)")
    spawn: SpawnConfig | None = Field(None, description="spawn region; default: the task's layout for this index")
    hover_point: Vec3 | None = Field(
        None,
        description="hover task: the point to hold; formation task: the agent's slot at the start [m]; "
        "default: spawn position",
    )


#: multi-agent task name -> its options model: a live view of the task registry (each
#: multi-agent task's module in pyflyt_engine.envs.tasks registers its options with it)
MA_TASKS: TaskTable[type[MATaskOptions]] = TaskTable("multi", "options")


class MultiAgentEnvConfig(EnvConfig):
    """An :class:`EnvConfig` with several agents sharing one world (and one action layout)."""

    agents: int | list[AgentConfig] = Field(
        description="a count (that many agents of `uav`, placed by the task's layout) or one entry per agent"
    )
    task: SerializeAsAny[MATaskOptions] = Field(description="multi-agent task name and options")  # type: ignore[assignment]

    multi_agent: ClassVar[bool] = True

    @model_validator(mode="after")
    def _payloads_on_vehicles(self) -> MultiAgentEnvConfig:
        # every agent carries its own payloads: one attached to the world would be built N times in one place
        for payload in self.payloads or ():
            if payload.attach.to != "vehicle":
                raise ValueError(
                    f"payloads: '{payload.name}' is attached to the {payload.attach.to}; in a multi-agent env every "
                    "agent carries its own copy of each payload, so a payload must attach to the vehicle "
                    "(attach.to: vehicle)"
                )
        return self

    @field_validator("agents")
    @classmethod
    def _agents(cls, value: int | list[AgentConfig]) -> int | list[AgentConfig]:
        if isinstance(value, int):
            if value < 1:
                raise ValueError(f"agents must be a count >= 1 or a list of agents, got {value}")
            if value > MAX_AGENTS:
                raise ValueError(f"agents: {value} is more than the {MAX_AGENTS} agents one world is meant for")
            return value
        if not value:
            raise ValueError("agents: the list is empty; give at least one agent (or a count)")
        if len(value) > MAX_AGENTS:
            raise ValueError(f"agents: {len(value)} listed, more than the {MAX_AGENTS} agents one world is meant for")
        names = [a.name or f"uav_{i}" for i, a in enumerate(value)]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"agents: names must be unique, repeated: {', '.join(duplicates)}")
        return value

    def resolved_agents(self) -> list[ResolvedAgent]:
        """One :class:`ResolvedAgent` per agent: defaults and the task's layout filled in.

        Raises:
            ConfigError: a task of two teams (``teams = 2`` of its options: the dogfight)
                whose teams cannot be formed, or an agent without a spawn region where the
                task has no layout for it.
        """
        entries = [AgentConfig()] * self.agents if isinstance(self.agents, int) else list(self.agents)
        count = len(entries)
        task = self.task
        teamed = type(task).teams == 2  # agents given by count: the first half team 0, the rest team 1
        out = []
        for i, entry in enumerate(entries):
            spawn = entry.spawn or task.layout_spawn(i, count)  # type: ignore[attr-defined]
            team = entry.team if entry.team is not None else (0 if i < count // 2 else 1) if teamed else 0
            hover = entry.hover_point if entry.hover_point is not None else spawn.position
            out.append(ResolvedAgent(entry.name or f"uav_{i}", entry.uav or self.uav, team, spawn, tuple(hover)))
        if teamed:
            teams = {a.team for a in out}
            if teams != {0, 1}:
                raise ConfigError(
                    f"{self.source or 'env'}: agents: a {task.name} needs agents in both teams 0 and 1, got teams "
                    f"{sorted(teams)}; give an even count (agents: 2) or set `team` on each listed agent"
                )
            if isinstance(self.agents, int) and self.agents % 2:
                raise ConfigError(
                    f"{self.source or 'env'}: agents: {self.agents} cannot form two equal teams; give an even "
                    "count or list the agents with their teams"
                )
        return out


def parse_multi_agent_config(data: Mapping[str, Any], source: str) -> MultiAgentEnvConfig:
    """Validate a mapping with ``agents`` as a :class:`MultiAgentEnvConfig` (one ConfigError listing every problem)."""
    data = {k: v for k, v in data.items() if k != "source"}
    task = data.get("task")
    if not isinstance(task, Mapping) or task.get("name") not in MA_TASKS:
        got = task.get("name") if isinstance(task, Mapping) else task
        hint = did_you_mean(str(got), list(MA_TASKS)) if isinstance(got, str) else ""
        raise ConfigError(
            f"{source}: a multi-agent env (one with 'agents') needs task.name one of: {', '.join(MA_TASKS)} "
            f"(got {got!r}).{hint}"
        )
    options, task_problems = check(MA_TASKS[task["name"]], task, prefix="task.")
    placeholder = options if options is not None else MATaskOptions.model_construct(name=task["name"])
    config, problems = check(MultiAgentEnvConfig, {**data, "task": placeholder})
    problems = _one_branch(problems, data.get("agents")) + task_problems
    if problems:
        raise ConfigError(f"{source}: invalid multi-agent env config:\n" + "\n".join(f"  - {p}" for p in problems))
    assert config is not None  # check() returns the model whenever it finds no problem
    config = config.model_copy(update={"source": source})
    config.resolved_agents()  # team and layout problems surface at load
    return config


def _one_branch(problems: list[str], agents: Any) -> list[str]:
    """Problems of ``agents`` reported for the form it was given in (count or list), not both."""
    listed = isinstance(agents, list)
    out = []
    for problem in problems:
        if problem.startswith("agents.int:") and listed:
            continue
        if problem.startswith("agents.list[AgentConfig]"):
            if not listed:
                continue
            problem = "agents" + problem[len("agents.list[AgentConfig]") :]
        out.append(problem)
    return out


def parse_env_config(data: Any, source: str = "<dict>") -> EnvConfig:
    """Validate a mapping as an :class:`EnvConfig` (task options by the task's own model).

    A mapping with ``agents`` is a multi-agent config
    (:class:`MultiAgentEnvConfig`, a subclass).
    """
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: an env config must be a mapping of keys to values, got {type(data).__name__}")
    data = with_defaults(data, "env", source)  # a variant of shipped env configs (loading.with_defaults)
    if "agents" in data:  # several agents (pyflyt_engine.envs.multi_agent)
        return parse_multi_agent_config(data, source)
    data = {k: v for k, v in data.items() if k != "source"}
    task = data.get("task")
    if not isinstance(task, Mapping) or "name" not in task:
        from pyflyt_engine.envs.tasks import TASKS

        raise ConfigError(f"{source}: 'task' must be a mapping with a 'name' (one of: {', '.join(TASKS)})")
    try:
        task_cls = get_task(task["name"])
    except ConfigError as exc:
        raise ConfigError(f"{source}: task.name: {exc}") from None
    options, task_problems = check(task_cls.Options, task, prefix="task.")
    placeholder = options if options is not None else TaskOptions.model_construct(name=task["name"])
    config, problems = check(EnvConfig, {**data, "task": placeholder})
    problems += task_problems
    if problems:
        raise ConfigError(f"{source}: invalid env config:\n" + problem_list(problems))
    assert config is not None  # check() returns the model whenever it finds no problem
    return config.model_copy(update={"source": source})


def load_env_config(config: str | Path | Mapping[str, Any] | EnvConfig) -> EnvConfig:
    """An :class:`EnvConfig` from a shipped name (``conf/env``), a YAML path or a mapping."""
    return load(
        config,
        group="env",
        model=EnvConfig,
        parse=lambda data, source, _name: parse_env_config(data, source),
        what="env",
        unknown=_unknown("env"),
    )


def env_config_data(config: str | Path) -> dict[str, Any]:
    """A shipped env config (``conf/env`` name) or a YAML file as plain data, its ``defaults``
    list resolved (the keys of its bases and its own): a mapping to adjust and hand to
    :func:`load_env_config` or ``make_env``.  Not validated."""
    return composed(config, "env", what="env", error=ConfigError)


def parse_reward_preset(data: Any, source: str = "<dict>", name: str = "inline") -> RewardPreset:
    """Validate a mapping as a :class:`RewardPreset`."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: a reward preset must be a mapping with 'terms', got {type(data).__name__}")
    return validate(RewardPreset, {"name": name, **data}, "reward preset", source)


def load_reward_preset(preset: str | Path | Mapping[str, Any] | RewardPreset) -> RewardPreset:
    """A :class:`RewardPreset` from a shipped name (``conf/reward``), a YAML path or a mapping."""
    return load(
        preset, group="reward", model=RewardPreset, parse=parse_reward_preset, what="reward", unknown=_unknown("reward")
    )


def _unknown(group: str):  # noqa: ANN202
    """``unknown env config 'x'. Did you mean ...? Shipped: ...; or give a .yaml path``."""
    return lambda name: unknown_name(name, available(group), f"{group} config")
