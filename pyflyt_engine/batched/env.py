"""N copies of a task as arrays, stepped by one call: a Gymnasium vector env.

:class:`BatchedUAVEnv` flies an env config's task for ``num_envs`` independent vehicles,
advanced together by the compiled laws (:mod:`pyflyt_engine.batched.kernels`).  It is a
``gymnasium.vector.VectorEnv`` with same-step autoreset: when an env's episode ends, the
returned observation is already the first of its next episode; ``infos["final_obs"]``
holds the last observation of the ended one and ``infos["episode"]`` its return ``r`` and
length ``l`` (both masked by ``infos["_final_obs"]`` / ``infos["_episode"]``).  The step's
other entries (``collision``, ``out_of_bounds``, ``env_complete``, ``success`` and, for
waypoints, ``num_targets_reached``; one value per env) describe the step just taken, so for
an env that ended they describe its last step.

What an agent sees is what the PyBullet engine's env shows through the training wrappers
(:func:`pyflyt_cli.training.envs.wrap_for_agent` minus the float32 cast and the action
rescaling, which the learning library adds for both backends): the attitude vector
``[ang_vel, attitude, lin_vel, lin_pos, previous action, aux]`` (the PyBullet engine's
:func:`~pyflyt_engine.envs.observe.attitude_vector`; aux: the motor throttles, then for a
fixed-wing each surface's flap deflection over its limit; with a battery, last, its state
of charge), and for waypoints the
next ``context_length`` waypoints' body-frame deltas and their mask
(:class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv`'s layout).

Per episode, env ``i`` draws from its own generator (spawned from the seed, so its
episodes do not depend on the other envs): the spawn (:meth:`Task.spawn`, the task's own
law) and, for waypoints, the targets (:func:`~pyflyt_engine.envs.waypoints.sample_waypoints`).
The motor noise of the whole batch comes from one generator per batch, seeded from the
same seed: the same seed and ``num_envs`` give the same numbers, in any process.  In Dryden
turbulence env ``i`` draws its filter's white noise from a stream of its own as well (the
first child of its seed sequence), and its filter starts each episode from a fresh
stationary draw, as the PyBullet engine's field does on a reset.

A step is a few compiled calls (the motor noise, the physics, the state read-out, the
progress and ends, the reward, the observation) with NumPy and Python between them; for a
plain env (nothing between them: no latency, noisy sensors or range sensors, the physics
through :func:`~pyflyt_engine.batched.kernels.advance`, a compiled reward preset, an
observation of the state's own arrays) the same functions run in one compiled call,
:func:`~pyflyt_engine.batched.bookkeeping.plain_step`, with the same numbers.

The atmosphere (:mod:`pyflyt_engine.batched.air`): every ``env.wind`` -- a mean wind,
uniform or sheared, a 1-cosine gust, Dryden turbulence -- and ``env.ground_effect``, as
the PyBullet engine's world applies them (body drag and each lifting surface at the
velocity through the air, the rotors' thrust in ground effect).

Tasks: ``hover`` and ``waypoints`` (the QuadX-Hover, QuadX-Waypoints and
Fixedwing-Waypoints configs, their variants on any airframe the model accepts: a
multirotor in any of its controller's flight modes, a fixed-wing in mode ``channels`` or
``attitude_airspeed``).  A multirotor mode above the rate loop (the attitude, altitude,
velocity and position modes: :mod:`pyflyt_engine.batched.modes`) runs its controller at
every control tick and the physics of each control period in mode ``motors`` with the
motor commands it gave, as the PyBullet engine runs its controller at ``control_hz``
between the physics steps of an agent step.  An env config's ``latency`` (and a
``randomize`` entry ``action_delay`` / ``observation_delay``, drawn per episode and env) is
simulated as the PyBullet engine simulates it (:mod:`pyflyt_engine.batched.latency`): the
action reaches the controller at its first tick at or after the delay, the observation shows
the state of that many physics steps ago, the reward and episode ends the true state.
Noisy sensors (``env.sensors`` or the airframe's ``sensors`` section) and the flight
controller's estimator are the PyBullet engine's laws on rows
(:mod:`pyflyt_engine.batched.sensors`), sampled at the start of every physics step and
drawing from env ``i``'s own sensor stream in the engine's order; the observation shows
the sensed or estimated state (and the fix's validity flag) as the PyBullet env does.
Domain randomisation (``env.randomize``: the airframe factors, the spawn offsets, the
delays, the winds ``wind.<path>``: each env's own rows of the wind parameters and of the
Dryden filter) is drawn per env and episode as the PyBullet env draws it
(:mod:`pyflyt_engine.batched.randomization`); an airframe's optional motor models and its
battery fly their compiled laws, the pack reset with each env's episode.
The waypoint logic (sampling, the segment reach test, the
observation's deltas) is one path for both kinds of airframe, as the PyBullet engine's
waypoints task is.  Everything else a config can ask for that this backend does not
simulate is refused when the env is built, by name (:func:`check_supported`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from pyflyt_engine import exact
from pyflyt_engine.batched import air, bookkeeping, kernels, modes, normals
from pyflyt_engine.batched.memory import keep_heap
from pyflyt_engine.batched.latency import BatchedLatency, declares_latency
from pyflyt_engine.batched.model import BatchedModel, batched_model, mode_code, refuse
from pyflyt_engine.batched.randomization import BatchedRandomizer
from pyflyt_engine.batched.ranges import BatchedRangeSensors
from pyflyt_engine.batched.sensors import S_VALID, BatchedSensors
from pyflyt_engine.batched.support import BATCHED_TASKS, WAYPOINT_RANGES, check_keys
from pyflyt_engine.batched.terms import BatchContext, BatchedReward, batched_ends
from pyflyt_engine.envs.config import EnvConfig, load_env_config, load_reward_preset
from pyflyt_engine.envs.randomization import SPAWN, Randomizer
from pyflyt_engine.envs.rewards import compile_reward
from pyflyt_engine.envs.tasks import get_task
from pyflyt_engine.envs.tasks.base import Task
from pyflyt_engine.envs.waypoints import sample_waypoints
from pyflyt_engine.constants import AIR_DENSITY, GRAVITY
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import euler_to_quaternion
from pyflyt_engine.spec import load_uav_spec

if TYPE_CHECKING:
    from pyflyt_engine.envs.tasks.waypoints import WaypointsOptions

#: upcoming waypoints in a waypoint observation (FlattenWaypointEnv's default)
CONTEXT_LENGTH = 2


def check_supported(config: EnvConfig) -> None:
    """Refuse, by name, every key of ``config`` the batched backend does not simulate (a
    multi-agent config: :func:`pyflyt_engine.batched.swarm.check_swarm_supported`; the keys both
    check: :func:`pyflyt_engine.batched.support.check_keys`)."""
    from pyflyt_engine.envs.config import MultiAgentEnvConfig

    if isinstance(config, MultiAgentEnvConfig):
        from pyflyt_engine.batched.swarm import check_swarm_supported

        check_swarm_supported(config)
        return
    check_keys(config)


def resolve_backend(config: EnvConfig, *, imitation: bool = False) -> str:
    """The backend ``config.backend`` names: ``auto`` is ``batched`` where the batched backend
    simulates the config (and no imitation stage flies an oracle in it), else ``pybullet``."""
    if config.backend != "auto":
        return config.backend
    if imitation:
        return "pybullet"
    try:
        check_supported(config)
    except ConfigError:  # UnsupportedByBatched among them
        return "pybullet"
    return "batched"


class BatchedUAVEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` copies of an env config's task, one compiled call per step (module docstring).

    Args:
        config: an env config (a shipped name such as ``"quadx_hover"``, a YAML path, a
            mapping or an :class:`EnvConfig`).
        num_envs: how many envs.
        seed: seeds the first reset (as ``reset(seed=...)`` would).
        motor_noise: False switches the motors' noise off (the cross-checks).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, config: Any, num_envs: int = 1, seed: int | None = None, motor_noise: bool = True) -> None:
        from pyflyt_engine.envs.config import MultiAgentEnvConfig

        cfg = load_env_config(config)
        check_supported(cfg)
        if isinstance(cfg, MultiAgentEnvConfig):
            raise ConfigError(
                f"BatchedUAVEnv flies single-agent configs; {cfg.id or cfg.source} has agents: build it with "
                "make_batched_env or pyflyt_engine.batched.swarm.BatchedSwarmEnv (a slot per agent)"
            )
        if num_envs < 1:
            raise ConfigError(f"num_envs must be >= 1, got {num_envs}")
        self.config = cfg
        self.num_envs = n = int(num_envs)
        keep_heap()  # big per-step arrays without page faults (pyflyt_engine.batched.memory)
        self.spec_uav = load_uav_spec(cfg.uav)
        self.physics_dt = 1.0 / cfg.physics_hz
        self.control_dt = 1.0 / cfg.control_hz
        self.agent_dt = 1.0 / cfg.agent_hz
        self.per_agent = int(round(cfg.physics_hz / cfg.agent_hz))
        self.per_control = int(round(cfg.physics_hz / cfg.control_hz))
        self.model: BatchedModel = batched_model(self.spec_uav, self.physics_dt, self.control_dt, drag=cfg.drag)
        self.mode = mode_code(cfg.action.mode, self.model)
        if self.mode == kernels.MODE_ATTITUDE_AIRSPEED and len(cfg.action.low) != 4:
            raise ConfigError(f"mode attitude_airspeed takes 4 values, the action has {len(cfg.action.low)}")
        if self.mode == kernels.MODE_CHANNELS and len(cfg.action.low) != self.model.channels:
            raise ConfigError(f"mode channels takes {self.model.channels} values, the action has {len(cfg.action.low)}")
        #: a multirotor's setpoint: its mode's values (the head), then one per channel (a VTOL's)
        self._head = 0 if self.model.channel_driven else 4
        if self.mode == kernels.MODE_MOTORS:
            self._head = self.model.mixer_outputs
        extra = 0 if self.model.channel_driven else self.model.channels
        if self.mode == kernels.MODE_MOTORS and len(cfg.action.low) != self._head + extra:
            raise ConfigError(f"mode motors takes {self._head + extra} values, the action has {len(cfg.action.low)}")
        if self.mode == kernels.MODE_RATES_THRUST and len(cfg.action.low) != 4 + extra:
            raise ConfigError(f"mode rates_thrust takes {4 + extra} values, the action has {len(cfg.action.low)}")
        #: a cascade mode's (law, yaw_is_rate, heading_frame, position, altitude); None in the others
        self._cascade = modes.cascade_law(self.mode) if self.mode in modes.CASCADE_MODES.values() else None
        if self._cascade is not None and len(cfg.action.low) != 4 + extra:
            name = next(k for k, v in modes.CASCADE_MODES.items() if v == self.mode)
            raise ConfigError(f"mode {name} takes {4 + extra} values, the action has {len(cfg.action.low)}")
        self.task = get_task(cfg.task.name)(cfg.task, flight_dome_size=cfg.flight_dome_size, agent_hz=cfg.agent_hz)
        preset = load_reward_preset(cfg.reward_preset_name())
        scalar = compile_reward(preset_name(cfg), preset.terms, self.task.provides, self.task.name)
        self.reward_function = BatchedReward(scalar)
        #: what ends an episode: the config's termination terms (pyflyt_engine.batched.terms.batched_ends)
        self._ends = batched_ends(cfg.terminations, bool(self.task.crash_on_contact))
        self.motor_noise = bool(motor_noise) and bool(np.any(self.model.noise_ratio > 0))
        self._quaternion = cfg.angle_representation == "quaternion"
        self._low = np.array(cfg.action.low, dtype=np.float64)
        self._high = np.array(cfg.action.high, dtype=np.float64)
        self._dome2 = cfg.flight_dome_size**2
        self._max_steps = cfg.max_steps
        self._waypoints = cfg.task.name == "waypoints"
        self._cascade_rows: tuple | None = None  # a cascade mode's parameter rows and scratch (_advance_cascade)

        # parameters, one row per env (own, writable copies: domain randomisation sets an env's rows)
        m = self.model
        rows = lambda a: np.array(np.broadcast_to(a, (n, *np.shape(a))), dtype=np.float64, order="C")  # noqa: E731
        self._mass = rows(m.mass)
        self._inertia = rows(m.inertia)
        self._control_inertia = rows(m.control_inertia)
        self._gyro = rows(m.gyro)
        self._lag = rows(m.lag)
        self._columns = rows(m.columns)
        self._mixer_rows = rows(m.mixer_rows)
        self._max_collective = rows(m.max_collective)
        self._rate_gains = rows(m.rate_gains)
        self._drag_factors = rows(m.drag_factors)
        self._damping = rows(m.angular_damping)
        self._corners = rows(m.corners)
        self._reaches = kernels.feature_reaches(self._corners)
        self._noise_ratio = m.noise_ratio
        self._surfaces = rows(m.surfaces)
        self._surface_lag = rows(m.surface_lag)
        #: the optional motor models' rows (none for the static motors)
        self._motor_model = rows(m.motor_model)
        #: the pack's parameters and its state at a reset, per env (a drawn battery_* factor sets a row)
        self._battery_params = rows(m.battery)
        self._battery_reset = rows(m.battery_reset)
        from pyflyt_engine.atmosphere import load_wind_config

        #: the air (pyflyt_engine.batched.air): the wind field's parameters, and per env the
        #: rotors' rows for ground effect (the PyBullet engine's needs a ground: its worlds have one)
        self.wind_config = load_wind_config(cfg.wind)
        #: the turbulence filter of this airframe (None: no turbulence); the config's wind
        #: parameters (air.WIND_FIELDS) and turbulence filter arrays (Dryden.arrays); per env, its
        #: wind parameters and its turbulence filter (Phi, C, the noise's and the stationary
        #: state's factors, the column flags): the config's in every row; a ``randomize`` entry
        #: ``wind.<path>`` sets an env's rows per episode (the kernels read env i's)
        self.dryden, self._wind, self._dryden_arrays, self._wind_rows, self._dryden_rows = air.air_rows(
            self.wind_config, self.physics_dt, m.span, n, n
        )
        self._dryden_phi, self._dryden_c, self._dryden_noise, self._dryden_root, self._dryden_flags = self._dryden_rows
        self.ground_effect = bool(cfg.ground_effect)
        self._rotors = rows(m.rotors)
        states = self.dryden.states if self.dryden is not None else 0
        #: per env, the turbulence filter's state (Dryden; none without turbulence)
        self.turbulence = np.zeros((n, states))
        self._no_normals = np.zeros((n, self.per_agent, 0))
        self._no_offsets = np.zeros((n, len(SPAWN)))  # the spawn offsets without randomisation (_spawn)
        #: the task options of the last compiled spawn and spawn_rows' arguments from them (_spawn)
        self._spawn_law: tuple[Any, tuple] | None = None
        self._normals = self._no_normals  # this agent step's (advance)

        # state
        nm = m.motors
        self.pos = np.zeros((n, 3))
        self.quat = np.zeros((n, 4))
        self.quat[:, 3] = 1.0
        self.vel = np.zeros((n, 3))
        self.angvel = np.zeros((n, 3))
        self.throttle = np.zeros((n, nm))
        self.command = np.zeros((n, nm))
        ns = len(m.surfaces)
        #: per env, each lifting surface's flap deflection [rad] and its command in [-1, 1]
        self.deflection = np.zeros((n, ns))
        self.flap_command = np.zeros((n, ns))
        #: per env, each gimbal's servo angles (a, b) [rad] and commands in [-1, 1] (none without gimbals)
        self.gimbal_angles = np.zeros((n, len(m.gimbal_scale)))
        self.gimbal_command = np.zeros((n, len(m.gimbal_scale)))
        #: per env, the fixed-wing autopilot's integrals (roll, pitch, yaw, airspeed; none on a multirotor)
        self.autopilot_integral = np.zeros((n, 4 if m.channel_driven else 0))
        #: per env, the battery's state (charge, voltage [V], current [A], speed ratio:
        #: ``kernels.BATTERY_STATE``; none without a battery), its reset's at every episode start
        self.battery = np.zeros((n, m.battery_reset.size))
        self.integral = np.zeros((n, 3))
        #: per env, the velocity loop's integrals (x, y, z; only in a cascade mode)
        self.vel_integral = np.zeros((n, 3 if self._cascade is not None else 0))
        self.previous = np.zeros((n, 3))
        self.has_previous = np.zeros(n, dtype=bool)
        self.contact = np.zeros(n, dtype=bool)
        #: the contact samples the physics writes (BatchedLatency gathers them over an agent step's pieces)
        self.contact_flags = (self.contact,)
        self.actions = np.zeros((n, self._low.size))
        self.steps = np.zeros(n, dtype=np.int64)
        self.physics_steps = np.zeros(n, dtype=np.int64)  # per env: its control ticks' phase
        self._ones = np.ones((n, self.per_agent, nm))
        self._noise_buffer = np.empty((n, self.per_agent, nm))  # this step's motor noise factors (step)
        # read-outs
        self.ang_vel_body = np.zeros((n, 3))
        self.ang_pos = np.zeros((n, 3))
        self.lin_vel_body = np.zeros((n, 3))
        self.quaternion = np.zeros((n, 4))
        self.quaternion[:, 3] = 1.0
        #: kernels.read_out's arrays: the state, then its read-outs
        self._read_arrays = (
            self.pos,
            self.quat,
            self.vel,
            self.angvel,
            self.ang_vel_body,
            self.ang_pos,
            self.lin_vel_body,
            self.quaternion,
        )
        #: the state an observation shows without latency or sensors: these arrays themselves,
        #: which every step updates in place (_observe)
        self._true_state = {
            "pos": self.pos,
            "quaternion": self.quaternion,
            "ang_pos": self.ang_pos,
            "throttle": self.throttle,
            "ang_vel_body": self.ang_vel_body,
            "lin_vel_body": self.lin_vel_body,
            "deflection": self.deflection,
            "battery": self.battery,
        }
        # task state
        self.hover_point = np.asarray(getattr(cfg.task, "hover_point", (0.0, 0.0, 0.0)), dtype=np.float64)
        self._hover_goals: np.ndarray | None = None  # the hover point, a row per env (_goals)
        k = int(getattr(cfg.task, "num_targets", 0))
        self.targets = np.zeros((n, k, 3))
        self.num_reached = np.zeros(n, dtype=np.int64)
        #: per env, the reach distance of its episode (a training curriculum may change it per episode)
        self.reach = np.full(n, float(getattr(cfg.task, "goal_reach_distance", 0.0)))
        #: task option values the episodes that start from now on take (set_task_changes); {}: as configured
        self.task_changes: dict[str, Any] = {}
        self._episode_task = self.task
        self._last_distance = np.zeros(n)
        self._last_position = np.zeros((n, 3))
        self.episode_return = np.zeros(n)
        self.episode_length = np.zeros(n, dtype=np.int64)
        #: the randomize section's draws per env and episode (None without; pyflyt_engine.batched.randomization)
        from pyflyt_engine.envs.observe import with_sensors

        #: the sensors' section the vehicles fly (the env config's, else the airframe's; None without)
        flown = with_sensors(self.spec_uav, cfg.sensors).sensors
        self.randomizer = (
            BatchedRandomizer(
                cfg.randomize, self.spec_uav, self.physics_dt, n, sensors=flown, wind=self.wind_config, span=m.span
            )
            if cfg.randomize
            else None
        )
        #: per env, this episode's randomize draws (entries in the section's order; no columns without)
        self.randomized_values = self.randomizer.values if self.randomizer is not None else np.zeros((n, 0))
        #: the parameter rows a checkpoint carries besides the state: those the draws change
        self.randomized_arrays: tuple[str, ...] = self.randomizer.arrays() if self.randomizer is not None else ()
        #: the action and observation delays (None without; pyflyt_engine.batched.latency)
        self.latency = (
            BatchedLatency(cfg, n, self.per_agent, self.per_control, self._low.size, nm, ns, m.has_battery)
            if declares_latency(cfg)
            else None
        )
        delays = self.latency.state_arrays() if self.latency is not None else {}
        #: per env, this episode's (action, observation) delays [physics steps], its last actions
        #: and the states it shows (BatchedLatency; empty rows without latency)
        self.latency_steps = delays.get("latency_steps", np.zeros((n, 0), dtype=np.int64))
        self.action_history = delays.get("action_history", np.zeros((n, 0)))
        self.observed_history = delays.get("observed_history", np.zeros((n, 0)))

        #: the noisy sensors and estimator (pyflyt_engine.batched.sensors; None without a
        #: ``sensors`` section, the env config's or the airframe's)
        self.sensors = BatchedSensors(flown, cfg.sensors, n, self.physics_dt, GRAVITY) if flown is not None else None
        #: per env, the sensors' and estimator's state (empty rows without sensors)
        self.sensor_state = self.sensors.rows if self.sensors is not None else np.zeros((n, 0))
        self.sensor_counts = self.sensors.counts if self.sensors is not None else np.zeros((n, 0), dtype=np.int64)
        #: per env, its sensors' parameters (a randomize section's sensor factors set them per episode)
        self.sensor_params = self.sensors.param_rows if self.sensors is not None else np.zeros((n, 0))
        self._fix_flag = self.sensors is not None and self.sensors.fix_flag
        size = 3 + (4 if self._quaternion else 3) + 3 + 3 + self._low.size + m.aux_size + int(self._fix_flag)
        self._attitude_size = size
        if self._waypoints:
            size += CONTEXT_LENGTH * 4
        self.single_observation_space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)
        from pyflyt_engine.assembly import assemble
        from pyflyt_engine.envs.observe import with_range_sensors, with_range_spaces

        #: the ray-cast range sensors (pyflyt_engine.batched.ranges; None without): the
        #: airframe's, then the env config's, as the PyBullet vehicle carries them
        carried = with_range_sensors(self.spec_uav, cfg.range_sensors) if cfg.range_sensors else self.spec_uav
        if carried.range_sensors and self._waypoints:
            raise refuse(f"the range sensors of {self.spec_uav.name} on the waypoints task ({WAYPOINT_RANGES})")
        self.range_sensors = (
            BatchedRangeSensors(carried.range_sensors, assemble(carried).com, n, self.physics_dt)
            if carried.range_sensors
            else None
        )
        #: the observation's entries in their order: the vector above under ``attitude`` and
        #: each range sensor's readings, as gymnasium flattens the PyBullet env's Dict
        #: (its keys sorted; FlattenObservation, or FlattenWaypointEnv's Dict flattened)
        self._entries: tuple[str, ...] = ("attitude",)
        #: the arrays a checkpoint carries for the range sensors (their held readings and
        #: last cast times; none without)
        self.range_arrays: tuple[str, ...] = ()
        if self.range_sensors is not None:
            entries = with_range_spaces(self.single_observation_space, self.range_sensors.engine)
            self._entries = tuple(entries.spaces)
            self.single_observation_space = cast(spaces.Box, spaces.flatten_space(entries))
            self.range_held, self.range_last = self.range_sensors.held, self.range_sensors.last
            self.range_arrays = ("range_held", "range_last")
        self.single_action_space = spaces.Box(self._low, self._high, dtype=np.float64)
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, n)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, n)
        #: whether a step is one compiled call (bookkeeping.plain_step): nothing between its
        #: separate calls (no latency, noisy sensors or range sensors; the physics through
        #: kernels.advance; a compiled reward preset) and an
        #: observation of the state's own arrays (no surfaces' or gimbals' aux, no fix flag)
        self._plain = (
            self.latency is None
            and self.sensors is None
            and self.range_sensors is None
            and not m.through_channels
            and self._cascade is None
            and self.reward_function.program is not None
            and not self.deflection.shape[1]
            and not self.gimbal_angles.shape[1]
        )
        #: the observation's parts of a plain step, None-padded for bookkeeping.plain_step
        #: (with waypoints, the next targets' kept arrays last: bookkeeping.waypoint_context)
        self._plain_parts: tuple = ()
        #: a plain step's waypoints: (targets, reached counts, reach, the next targets' arrays)
        self._plain_waypoints: tuple | None = None
        parts = [self.ang_vel_body, self.quaternion if self._quaternion else self.ang_pos, self.lin_vel_body]
        parts += [self.pos, self.actions, self.throttle] + ([self.battery[:, :1]] if self.battery.shape[1] else [])
        if self._waypoints:
            deltas, mask = np.zeros((n, CONTEXT_LENGTH * 3)), np.zeros((n, CONTEXT_LENGTH))
            self._plain_waypoints = (self.targets, self.num_reached, self.reach, deltas, mask)
            parts += [deltas, mask]
        self._plain = self._plain and len(parts) <= 8  # bookkeeping.stack_few's parts
        #: the width of a plain step's observation: its parts' (the space's)
        self._plain_width = sum(p.shape[1] for p in parts)
        assert not self._plain or self._plain_width == self.single_observation_space.shape[0]
        if self._plain:
            self._plain_parts = (*parts, *(None,) * (8 - len(parts)))
        self._all = np.arange(n)
        self._seed_all(seed)
        self._seeded_first = seed is not None

    # ---------------------------------------------------------------- seeding

    def _seed_all(self, seed: int | None) -> None:
        sequence = np.random.SeedSequence(seed)
        children = sequence.spawn(self.num_envs + 1)
        self.noise_rng = np.random.default_rng(children[0])
        self.env_rngs = [np.random.default_rng(c) for c in children[1:]]
        #: per env, the stream of its turbulence's white noise: the first child of that env's
        #: own seed sequence (so it depends on the seed and the env's index alone, and leaves
        #: the env's other draws as they were); none without turbulence
        turbulent = self.dryden is not None
        self.turbulence_rngs = [np.random.default_rng(c.spawn(1)[0]) for c in children[1:]] if turbulent else []
        if self.sensors is not None:  # per env, the sensors' stream (BatchedSensors.seed)
            self.sensors.seed(children[1:])
        if self.range_sensors is not None:  # per env, a stream per range sensor (BatchedRangeSensors.seed)
            self.range_sensors.seed(children[1:])
        self._streams_of: list | None = None  # the env_rngs whose states _env_streams holds (_streams)

    # ------------------------------------------------------------------ reset

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode in every env (``seed``: reseed every generator first)."""
        if options:
            raise ConfigError(f"the batched env takes no reset options, got {sorted(options)}")
        if seed is not None:
            self._seed_all(seed)
        self._reset_envs(np.arange(self.num_envs))
        info: dict[str, Any] = {}
        if self.randomizer is not None:  # per entry, each env's draw (the PyBullet env's info["randomization"])
            info["randomization"] = self.randomizer.info()
            info["_randomization"] = np.ones(self.num_envs, dtype=bool)
        return self._observe(), info

    def set_task_changes(self, changes: dict[str, Any]) -> None:
        """The task option values of the episodes that start from now on ({}: as configured),
        as :class:`pyflyt_cli.training.envs.EpisodeTaskOptions` gives them to a PyBullet env:
        only the options the task lets an episode change (a training curriculum's)."""
        allowed = self.task.episode_options
        unknown = sorted(set(changes) - set(allowed))
        if unknown:
            raise ConfigError(
                f"task option(s) {', '.join(unknown)} cannot change per episode; these can: {', '.join(sorted(allowed))}"
            )
        self.task_changes = dict(changes)
        if changes:
            options = self.config.task.model_copy(update=changes)
            self._episode_task = get_task(options.name)(
                type(self.config.task).model_validate(options.model_dump()),
                flight_dome_size=self.config.flight_dome_size,
                agent_hz=self.config.agent_hz,
            )
        else:
            self._episode_task = self.task

    def _streams(self) -> tuple[np.ndarray, Any] | None:
        """The state addresses of the envs' generators and their ``next_double``, which
        :func:`~pyflyt_engine.batched.bookkeeping.spawn_rows` draws through (taken again when
        ``env_rngs`` is a new list; None if they are not all one kind of bit generator)."""
        if self._streams_of is not self.env_rngs:
            self._env_streams = bookkeeping.stream_addresses(self.env_rngs)
            self._streams_of = self.env_rngs
        return self._env_streams

    def _reset_envs(self, index: np.ndarray) -> None:
        """Start an episode in the envs ``index``: their draws (each from its own generator,
        in the order a PyBullet env draws them: the randomize section, the spawn, the targets),
        then their state from the spawn, all rows at once (:mod:`pyflyt_engine.batched.bookkeeping`)."""
        task = self._episode_task
        o = cast("WaypointsOptions", task.options)  # read for the waypoints task only
        if self._waypoints:
            self.reach[index] = float(o.goal_reach_distance)
        randomizer = self.randomizer
        if randomizer is not None:  # drawn before the spawn, as the PyBullet engine's randomiser is
            for i in index.tolist():
                values = randomizer.draw(i, self.env_rngs[i])
                if randomizer.airframe:
                    randomizer.apply(self, i, values)
                if randomizer.winds:  # the episode's wind: the env's rows of the parameters and the filter
                    randomizer.apply_wind(self, i, values)
                if self.latency is not None:
                    self.latency.draw(i, values)
        self._spawn(task, index)
        if self.dryden is not None:  # a new realisation: the state drawn from the stationary distribution
            for i in index.tolist():
                air.dryden_initial(
                    self.dryden_of(i), self.turbulence_rngs[i].standard_normal(self.dryden.states), self.turbulence[i]
                )
        if self._waypoints:
            for i in index.tolist():
                self.targets[i] = sample_waypoints(
                    self.env_rngs[i],
                    o.num_targets,
                    o.min_target_distance,
                    o.max_target_distance * task.flight_dome_size,
                    o.min_target_height,
                )
        bookkeeping.zero_rows(
            index,
            (
                self.throttle,
                self.command,
                self.deflection,
                self.flap_command,
                self.gimbal_angles,
                self.gimbal_command,
                self.autopilot_integral,
                self.integral,
                self.vel_integral,
                self.previous,
                self.actions,
            ),
            (self.episode_return,),
            (self.steps, self.physics_steps, self.episode_length, self.num_reached),
            (self.has_previous,),
        )
        if self.battery.shape[1]:  # the pack back to its initial charge, no load (Battery.reset)
            self.battery[index] = self._battery_reset[index]
        bookkeeping.read_rows(index, *self._read_arrays)
        if self.sensors is not None:  # time 0: new initial biases, the estimator at the spawn
            self.sensors.reset(index, self.pos, self.vel, self.quaternion)
        if self.latency is not None:
            self.latency.restart(self, index)
        if self.range_sensors is not None:  # the last scan forgotten, the first of the episode cast
            self.range_sensors.forget(index)
            self.range_sensors.scan(index, self.pos, self.quat, self.physics_steps)
        bookkeeping.distance_rows(index, self.pos, self._goals(), self._last_position, self._last_distance)

    def _spawn(self, task: Any, index: np.ndarray) -> None:
        """The spawn of the envs ``index``, drawn from their generators: the task's own law
        (``task.spawn``) env by env where the task has one of its own, else the base law
        (:meth:`Task.spawn`) on all rows in one compiled call (:func:`bookkeeping.spawn_rows`)."""
        streams = self._streams()
        offsets = self.randomizer.spawn_offsets if self.randomizer is not None else None
        if type(task).spawn is not Task.spawn or streams is None:
            for i in index.tolist():
                spawn = task.spawn(self.env_rngs[i])
                position, orientation = spawn.position, spawn.orientation
                if offsets is not None:  # Randomizer.spawn: the drawn offsets added to the task's spawn
                    values = dict(zip(SPAWN, offsets[i].tolist()))
                    position, orientation = Randomizer.spawn(values, position, orientation)
                self.pos[i] = position
                q = euler_to_quaternion(*orientation)
                self.quat[i] = q
                r = np.empty(9)
                kernels.rotation_rows(q[0], q[1], q[2], q[3], r)
                rot = r.reshape(3, 3).tolist()
                # body to ground as Vehicle.reset turns the spawn's body-frame velocities
                self.vel[i] = exact.rotate(rot, [float(v) for v in spawn.lin_vel])
                self.angvel[i] = exact.rotate(rot, [float(v) for v in spawn.ang_vel])
            return
        o = task.options
        if self._spawn_law is None or self._spawn_law[0] is not o:  # the law's arrays, once per options
            law = (
                np.asarray(o.start_position, dtype=np.float64),
                float(o.start_position_noise),
                np.asarray(o.start_orientation, dtype=np.float64),
                float(o.start_orientation_noise),
                np.asarray(o.start_lin_vel, dtype=np.float64),
                np.zeros(3),
            )
            self._spawn_law = (o, law)
        states, next_double = streams
        bookkeeping.spawn_rows(
            index,
            states,
            next_double,
            *self._spawn_law[1],
            self.pos,
            self.quat,
            self.vel,
            self.angvel,
            offsets if offsets is not None else self._no_offsets,
            offsets is not None,
        )

    def _goals(self) -> np.ndarray:
        """Each env's current target (N, 3): its next waypoint, or the hover point."""
        if self._waypoints:
            k = self.targets.shape[1]
            return self.targets[np.arange(self.num_envs), np.minimum(self.num_reached, k - 1)]
        if self._hover_goals is None:
            self._hover_goals = np.ascontiguousarray(np.broadcast_to(self.hover_point, (self.num_envs, 3)))
        return self._hover_goals

    def _target_distance(self, index: np.ndarray, p: np.ndarray) -> np.ndarray:
        if self._waypoints:
            k = self.targets.shape[1]
            nxt = np.minimum(self.num_reached[index], k - 1)
            t = self.targets[index, nxt]
        else:
            t = self.hover_point
        d = p - t
        return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])

    def _read(self, index: np.ndarray | None = None) -> None:
        if index is None:
            kernels.read_out(*self._read_arrays)
            return
        a, b, c, d = (
            np.empty((len(index), 3)),
            np.empty((len(index), 3)),
            np.empty((len(index), 3)),
            np.empty((len(index), 4)),
        )
        kernels.read_out(self.pos[index], self.quat[index], self.vel[index], self.angvel[index], a, b, c, d)
        self.ang_vel_body[index], self.ang_pos[index], self.lin_vel_body[index], self.quaternion[index] = a, b, c, d

    # ------------------------------------------------------------------- step

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        a = np.asarray(actions, dtype=np.float64).reshape(n, -1)
        if a.shape[1] != self._low.size:
            raise ValueError(f"actions must be ({n}, {self._low.size}), got {np.shape(actions)}")
        if self._plain:
            return self._plain_step(a)
        bookkeeping.clip_rows(a, self._low, self._high, self.actions)
        a = self.actions.copy()
        if self.motor_noise:  # 1 + ratio eta in one compiled pass (numpy's draws), into a kept buffer
            factors = normals.noise_factors(self.noise_rng, self._noise_ratio, self._noise_buffer)
        else:
            factors = self._ones
        self.advance(a, factors, self.turbulence_normals())
        self.steps += 1
        self.episode_length += 1
        self._read()
        if self.range_sensors is not None:  # the scans due at the observation (at the body's pose now)
            self.range_sensors.scan(self._all, self.pos, self.quat, self.physics_steps)
        reward, terminated, truncated, info = self._judge()
        self.episode_return += reward
        done = terminated | truncated
        return self._episodes_end(self._observe(), reward, terminated, truncated, info, done, bool(done.any()))

    def _plain_step(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """:meth:`step` of a plain env (:attr:`_plain`) after its actions are checked: the same
        calls in one (:func:`bookkeeping.plain_step`), the same numbers."""
        noise = None
        if self.motor_noise:  # normals.noise_factors's pass (its buffer made C-contiguous at init)
            noise = (*normals.interface(self.noise_rng), self._noise_ratio, self._noise_buffer)
        self._normals = self.turbulence_normals()
        start = int(self.physics_steps[0]) % self.per_control  # as advance: env 0's phase for all
        factors = self._noise_buffer if self.motor_noise else self._ones
        judge = (
            self._goals() if self._plain_waypoints is None else self._last_position,  # waypoints: unused
            self._last_distance,
            self._last_position,
            *self._end_terms(),
            self.agent_dt,
        )
        obs = np.empty((self.num_envs, self._plain_width))
        program = self.reward_function.program
        assert program is not None  # a plain env's preset is compiled (_plain)
        reward, terminated, truncated, collision, out, _, success, complete, done, ended = bookkeeping.plain_step(
            (a, self._low, self._high),  # clipped into self.actions, the advance's setpoints
            noise,
            self._advance_args(self.actions, factors, start, self.per_agent, *self._span(start, self.per_agent)),
            (self.physics_steps, self.per_agent, self.steps, self.episode_length),
            self._read_arrays,
            judge,
            self._plain_waypoints,
            (*program, self.episode_return),
            (obs, *self._plain_parts),
        )
        info = {"collision": collision, "out_of_bounds": out, "env_complete": complete, "success": success}
        if self._waypoints:
            info["num_targets_reached"] = self.num_reached.copy()
        return self._episodes_end(obs, reward, terminated, truncated, info, done, ended)

    def _episodes_end(
        self,
        obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        info: dict[str, Any],
        done: np.ndarray,
        ended: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The end of a step: the envs whose episode ended (``done``: ``terminated |
        truncated``; ``ended``: whether any did) give their last observation (``final_obs``)
        and episode statistics and start a new episode, whose first observation the returned
        one shows."""
        if ended:
            index = np.nonzero(done)[0]
            # the last observations, zeros in the rows that go on (observed again below)
            returns, lengths = bookkeeping.episode_ends(obs, done, self.episode_return, self.episode_length)
            info["final_obs"] = obs
            info["_final_obs"] = done
            info["episode"] = {"r": returns, "l": lengths}
            info["_episode"] = done
            self._reset_envs(index)
            if self.randomizer is not None:  # the draws of the episodes that start now, masked as the reset ones
                info["randomization"] = self.randomizer.info()
                info["_randomization"] = done
            obs = self._observe()
        return obs, reward, terminated, truncated, info

    def dryden_of(self, i: int) -> tuple:
        """Env ``i``'s turbulence filter, the tuple the compiled laws take (``air.Dryden.arrays``):
        its rows of the per-env filter arrays (the config's, or its episode's drawn wind's)."""
        return tuple(a[i] for a in self._dryden_rows)

    def turbulence_normals(self) -> np.ndarray:
        """The turbulence's white noise of one agent step, (N, physics steps, filter states)
        standard normal draws, env ``i``'s from its own stream (none without turbulence)."""
        if self.dryden is None:
            return self._no_normals
        out = np.empty((self.num_envs, self.per_agent, self.dryden.states))
        for rng, row in zip(self.turbulence_rngs, out):
            rng.standard_normal(out=row)
        return out

    def advance(self, setpoints: np.ndarray, factors: np.ndarray, normals: np.ndarray | None = None) -> None:
        """One agent step of the physics for every env (setpoints already clipped; with
        latency, the actions given now, which reach the controller later; ``normals``: the
        turbulence's white noise, :meth:`turbulence_normals`, drawn here when not given)."""
        self._normals = self.turbulence_normals() if normals is None else normals
        if self.latency is not None:
            self.latency.advance(self, setpoints, factors)
        else:
            # every env's physics steps stay in phase with its control ticks (all reset to 0
            # at once or at an agent step boundary, and per_agent is a multiple of per_control
            # whenever control_hz >= agent_hz); the phase of env 0 is used for all
            self.physics(setpoints, factors, int(self.physics_steps[0]) % self.per_control, self.per_agent)
        self.physics_steps += self.per_agent

    def physics(self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int) -> None:
        """:meth:`_physics` of ``count`` physics steps from offset ``start``; with noisy sensors
        one step at a time, the sensors sampling the body at the start of each (as the PyBullet
        engine's vehicle samples them before its loads), the contact sampled where the whole
        span samples it (the end of each control period, and the span's end)."""
        if self.sensors is None:
            self._physics(setpoints, factors, start, count)
            return
        hit = np.zeros(self.num_envs, dtype=bool)
        steps = self.physics_steps + start
        for s in range(count):
            self.sensors.sample(steps + s, self.pos, self.quat, self.vel, self.angvel)
            self._physics(setpoints, np.ascontiguousarray(factors[:, s : s + 1]), start + s, 1)
            if (start + s + 1) % self.per_control == 0 or s == count - 1:
                hit |= self.contact
        self.contact[:] = hit

    def sensor_readings(self, i: int) -> dict[str, np.ndarray]:
        """Env ``i``'s noisy sensors' latest readings by name (empty without sensors), as the
        PyBullet engine's ``Vehicle.sensor_readings`` gives them."""
        return self.sensors.readings(i) if self.sensors is not None else {}

    def _physics(self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int) -> None:
        """``count`` physics steps of every env from offset ``start`` into the agent step
        (a control tick where ``(start + s) % per_control == 0``), every tick in them flying
        ``setpoints``; ``factors`` (N, count, motors) their motor noise.  ``contact``: whether
        a sample in them (the end of a control period, and their end) found the ground.  The
        wind is the one of each env's physics steps ``physics_steps + start ...`` of its
        episode, the turbulence driven by this agent step's white noise from ``start`` on."""
        normals, steps = self._span(start, count)
        m = self.model
        if m.through_channels and self._cascade is None:
            self._advance_routed(setpoints, factors, start, count, normals, steps, self.mode)
            return
        if self._cascade is not None:
            self._advance_cascade(setpoints, factors, start, count, normals, steps)
            return
        kernels.advance(*self._advance_args(setpoints, factors, start, count, normals, steps))

    def _span(self, start: int, count: int) -> tuple[np.ndarray, np.ndarray]:
        """This agent step's turbulence draws for its physics steps ``start ... start + count``
        and each env's physics step of its episode at ``start`` (from 0: the counters
        themselves, which the compiled laws only read, and which move on after them)."""
        normals = self._normals
        if (start, count) != (0, normals.shape[1]):
            normals = np.ascontiguousarray(normals[:, start : start + count])
        return normals, self.physics_steps + start if start else self.physics_steps

    def _advance_args(
        self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int, normals: np.ndarray, steps: np.ndarray
    ) -> tuple:
        """The arguments of :func:`kernels.advance` for ``count`` physics steps of every env
        from offset ``start`` (``normals``, ``steps``: :meth:`_span`'s)."""
        m = self.model
        dryden = self._dryden_rows
        return (
            self.pos,
            self.quat,
            self.vel,
            self.angvel,
            self.throttle,
            self.command,
            self.integral,
            self.previous,
            self.has_previous,
            setpoints,
            factors,
            kernels.switch(self.mode == kernels.MODE_RATES_THRUST),
            self._mass,
            self._inertia,
            self._control_inertia,
            self._gyro,
            self._lag,
            self._columns,
            self._mixer_rows,
            self._max_collective,
            self._rate_gains,
            m.rate_derivative,
            self._drag_factors,
            self._damping,
            kernels.switch(m.drag),
            self._corners,
            self._reaches,
            self.contact,
            GRAVITY,
            self.physics_dt,
            self.control_dt,
            start,
            count,
            self.per_control,
            self._wind_rows,
            steps,
            self._rotors,
            kernels.switch(self.ground_effect),
            air.GROUND_EFFECT_MIN_HEIGHT,
            self.turbulence,
            normals,
            dryden,
            self._motor_model,
            m.motor_laws or None,
            self.battery,
            self._battery_params,
            m.battery_table,
            kernels.wind_on(self._wind_rows),
        )

    def _advance_routed(
        self,
        setpoints: np.ndarray,
        factors: np.ndarray,
        start: int,
        count: int,
        normals: np.ndarray,
        steps: np.ndarray,
        mode: int,
        head: int | None = None,
    ) -> None:
        """``count`` physics steps from offset ``start`` of an airframe whose actuators the
        channels route (:func:`~pyflyt_engine.batched.kernels.advance_channels`: a fixed-wing, a
        VTOL, a tricopter), in ``mode``; a multirotor's setpoints hold ``head`` values of its
        mode (default: this env's) before its channels."""
        m = self.model
        kernels.advance_channels(
            self.pos,
            self.quat,
            self.vel,
            self.angvel,
            self.throttle,
            self.command,
            self.deflection,
            self.flap_command,
            setpoints,
            factors,
            self._mass,
            self._inertia,
            self._lag,
            self._columns,
            m.motor_mix_index,
            m.motor_mix_weight,
            m.channel_low,
            m.channel_high,
            self._surfaces,
            self._surface_lag,
            m.surface_mix_index,
            m.surface_mix_weight,
            self._drag_factors,
            self._damping,
            m.drag,
            self._corners,
            self.contact,
            GRAVITY,
            AIR_DENSITY,
            self.physics_dt,
            start,
            count,
            self.per_control,
            mode,
            self.autopilot_integral,
            m.autopilot_gains,
            m.cruise_thrust,
            m.autopilot_index,
            self.control_dt,
            self._wind_rows,
            steps,
            self._rotors,
            self.ground_effect,
            air.GROUND_EFFECT_MIN_HEIGHT,
            self.turbulence,
            normals,
            self._dryden_rows,
            self._motor_model,
            m.motor_laws,
            self.battery,
            self._battery_params,
            m.battery_table,
            self._head if head is None else head,
            self.integral,
            self.previous,
            self.has_previous,
            self._rate_gains,
            m.rate_derivative,
            self._control_inertia,
            self._gyro,
            self._mixer_rows,
            self._max_collective,
            m.lateral,
            m.motor_source,
            self.gimbal_angles,
            self.gimbal_command,
            m.gimbals,
            m.gimbal_source,
        )

    def _advance_cascade(
        self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int, normals: np.ndarray, steps: np.ndarray
    ) -> None:
        """``count`` physics steps from offset ``start`` in a cascade mode: per control
        period, the controller's tick (:func:`~pyflyt_engine.batched.modes.control_tick`) sets
        the motor commands from the state at its start, then the period's physics steps run
        in mode ``motors`` with them (a piece of a period that starts after its tick keeps
        the commands the tick gave); ``normals`` the pieces' turbulence noise, ``steps`` each
        env's episode physics step at ``start`` (:meth:`physics`)."""
        m = self.model
        c = m.cascade
        assert c is not None
        if self._cascade_rows is None:
            n = self.num_envs
            rows = lambda a: np.ascontiguousarray(np.broadcast_to(a, (n, *np.shape(a))), dtype=np.float64)  # noqa: E731
            self._cascade_rows = (
                rows(c.table),
                rows(c.mass),
                rows(c.window),
                rows(c.max_tilt),
                np.zeros((n, m.mixer_outputs + (m.channels if m.routed else 0))),
                np.zeros(n, dtype=bool),
            )
        table, mass, window, max_tilt, commands, contact = self._cascade_rows
        assert self._cascade is not None  # set for a cascade mode, the only one stepped here
        law, yaw_is_rate, heading_frame, position, altitude = self._cascade
        per_control = self.per_control
        contact[:] = False
        a = start
        while a < start + count:
            b = min((a // per_control + 1) * per_control, start + count)  # to the period's end, or the count's
            if a % per_control == 0:  # the period's tick
                modes.control_tick(
                    self.pos,
                    self.quat,
                    self.vel,
                    self.angvel,
                    setpoints,
                    self.integral,
                    self.previous,
                    self.has_previous,
                    self.vel_integral,
                    law,
                    yaw_is_rate,
                    heading_frame,
                    position,
                    altitude,
                    table,
                    mass,
                    window,
                    max_tilt,
                    self._rate_gains,
                    m.rate_derivative,
                    self._control_inertia,
                    self._gyro,
                    self._mixer_rows,
                    self.control_dt,
                    commands,
                    m.lateral,
                    c.trimmed,
                    c.trim[0],
                    c.trim[1],
                )  # (a piece after it has no tick: the motors keep the commands it gave)
                if m.routed:  # the channels after the mixer's outputs, as the setpoint gives them
                    commands[:, m.mixer_outputs :] = setpoints[:, 4:]
            period = np.ascontiguousarray(factors[:, a - start : b - start])
            if m.routed:
                self._advance_routed(
                    commands,
                    period,
                    a,
                    b - a,
                    np.ascontiguousarray(normals[:, a - start : b - start]),
                    steps + (a - start),
                    kernels.MODE_MOTORS,
                    m.mixer_outputs,
                )
                contact |= self.contact
                a = b
                continue
            kernels.advance(
                self.pos,
                self.quat,
                self.vel,
                self.angvel,
                self.throttle,
                self.command,
                self.integral,
                self.previous,
                self.has_previous,
                commands,
                period,
                None,  # the motors' throttles (mode motors)
                self._mass,
                self._inertia,
                self._control_inertia,
                self._gyro,
                self._lag,
                self._columns,
                self._mixer_rows,
                self._max_collective,
                self._rate_gains,
                m.rate_derivative,
                self._drag_factors,
                self._damping,
                kernels.switch(m.drag),
                self._corners,
                self._reaches,
                self.contact,
                GRAVITY,
                self.physics_dt,
                self.control_dt,
                a % per_control,
                b - a,
                per_control,
                self._wind_rows,
                steps + (a - start),
                self._rotors,
                kernels.switch(self.ground_effect),
                air.GROUND_EFFECT_MIN_HEIGHT,
                self.turbulence,
                np.ascontiguousarray(normals[:, a - start : b - start]),
                self._dryden_rows,
                self._motor_model,
                m.motor_laws or None,
                self.battery,
                self._battery_params,
                m.battery_table,
                kernels.wind_on(self._wind_rows),
            )
            contact |= self.contact  # each call samples its own period's contacts
            a = b
        self.contact[:] = contact

    def _end_terms(self) -> tuple:
        """:func:`bookkeeping.ends`' arguments after the state: the time limit, the dome and
        what ends an episode (the config's termination terms)."""
        ends = self._ends
        return (
            self._max_steps,
            self._dome2,
            ends.contact,
            bool(self.task.succeeds_at_time_limit),
            ends.dome,
            ends.complete,
            ends.time_limit,
        )

    def _judge(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        p = self.pos
        reached = np.zeros(n, dtype=bool)
        complete = np.zeros(n, dtype=bool)
        if self._waypoints:
            distance, rate, reached, complete = bookkeeping.waypoint_progress(
                p, self._last_position, self._last_distance, self.targets, self.num_reached, self.reach, self.agent_dt
            )
        else:
            distance, rate = bookkeeping.progress(p, self._goals(), self._last_distance, self.agent_dt)
            self._last_distance = distance
        self._last_position = p.copy()
        collision, out, crashed, terminated, truncated, remaining, success = bookkeeping.ends(
            p, self.contact, complete, self.steps, *self._end_terms()
        )
        ctx = BatchContext(
            ang_vel=self.ang_vel_body,
            ang_pos=self.ang_pos,
            lin_vel=self.lin_vel_body,
            lin_pos=p,
            action=self.actions,
            collision=collision,
            ground_collision=collision,
            out_of_bounds=out,
            crashed=crashed,
            task_complete=complete,
            target_distance=distance,
            target_distance_rate=rate,
            waypoint_reached=reached,
            steps_remaining=remaining,
            agent_dt=self.agent_dt,
        )
        reward, _ = self.reward_function(ctx)
        info: dict[str, Any] = {
            "collision": collision,
            "out_of_bounds": out,
            "env_complete": complete,
            "success": success,
        }
        if self._waypoints:
            info["num_targets_reached"] = self.num_reached.copy()
        return reward, terminated, truncated, info

    def _observe(self) -> np.ndarray:
        n = self.num_envs
        if self._plain:  # the state's own arrays side by side (_plain_parts), in one compiled copy
            if self._plain_waypoints is not None:
                targets, reached, _, deltas, mask = self._plain_waypoints
                bookkeeping.waypoint_context(self.quaternion, self.pos, targets, reached, deltas, mask)
            out = np.empty((n, self._plain_width))
            bookkeeping.stack_few(out, *self._plain_parts)
            return out
        # with an observation delay, the state (and aux) of n_o physics steps ago (BatchedLatency.observed)
        if self.latency is not None and self.latency.observes:
            seen = self.latency.observed(self)
        else:
            seen = self._true_state
        if self.sensors is not None:  # the rates, position (and with an estimator attitude, velocity) sensed
            seen = self.sensors.observed(seen)
        pos, quaternion = seen["pos"], seen["quaternion"]
        angles = quaternion if self._quaternion else seen["ang_pos"]
        parts = [seen["ang_vel_body"], angles, seen["lin_vel_body"], pos, self.actions, seen["throttle"]]
        if self.deflection.shape[1]:  # the surfaces' aux: deflection over its limit (Surfaces.aux)
            parts.append(seen["deflection"] / self.model.surface_scale)
        if self.gimbal_angles.shape[1]:  # the gimbals' aux: each angle over its limit (Gimbals.aux)
            parts.append(self.gimbal_angles / self.model.gimbal_scale)
        if self.battery.shape[1]:  # the battery's gauge closes the aux: its state of charge (BatteryGauge.aux)
            parts.append(seen["battery"][:, :1])
        if self._fix_flag:  # the position fix's validity, after the aux state
            parts.append(self.sensor_state[:, S_VALID : S_VALID + 1])
        if self._waypoints:  # the next targets from the pose shown (WaypointsTask.observe)
            deltas, mask = np.empty((n, CONTEXT_LENGTH * 3)), np.empty((n, CONTEXT_LENGTH))
            bookkeeping.waypoint_context(
                np.ascontiguousarray(quaternion), pos, self.targets, self.num_reached, deltas, mask
            )
            parts += [deltas, mask]
        vector = bookkeeping.stack_columns(parts)
        if self.range_sensors is None:
            return vector
        held, columns = self.range_sensors.held, self.range_sensors.columns
        return np.concatenate([vector if k == "attitude" else held[:, columns[k]] for k in self._entries], axis=1)

    def range_readings(self, i: int) -> dict[str, np.ndarray]:
        """Env ``i``'s range sensors' readings by name, as the PyBullet engine's ``World.scan``
        gives them (float32, each sensor's shape; empty without range sensors)."""
        return self.range_sensors.readings(i) if self.range_sensors is not None else {}

    def close(self, **kwargs: Any) -> None:  # nothing to release: no PyBullet client
        self.closed = True


def preset_name(cfg: EnvConfig) -> str:
    name = cfg.reward_preset_name()
    return name if isinstance(name, str) else "inline"


def make_batched_env(name: Any, n_envs: int = 1, seed: int | None = None, **env_overrides: Any) -> Any:
    """``n_envs`` copies of an env config's task on the batched backend, as a Gymnasium vector env
    (a multi-agent config: ``n_envs`` worlds of its agents, a slot per agent,
    :class:`~pyflyt_engine.batched.swarm.BatchedSwarmEnv`).

    Args:
        name: a shipped env config (``"quadx_hover"``), a registered id
            (``"PyFlyt/QuadX-Hover-v0"``), a YAML path, a mapping or an :class:`EnvConfig`.
        n_envs: how many copies.
        seed: seeds the first reset.
        **env_overrides: top-level keys or task options, as :meth:`EnvConfig.with_overrides`.
    """
    from pyflyt_engine.envs import ENVS

    cfg = load_env_config(ENVS[name].config if isinstance(name, str) and name in ENVS else name)
    if env_overrides:
        cfg = cfg.with_overrides(**env_overrides)
    return batched_vector_env(cfg, n_envs, seed=seed)


def batched_vector_env(cfg: EnvConfig, n_envs: int, seed: int | None = None) -> Any:
    """The batched vector env of ``cfg``: ``n_envs`` copies of a single-agent task
    (:class:`BatchedUAVEnv`), or ``n_envs`` worlds of a multi-agent config's agents, a slot
    per agent (:class:`~pyflyt_engine.batched.swarm.BatchedSwarmEnv`)."""
    from pyflyt_engine.envs.config import MultiAgentEnvConfig

    if isinstance(cfg, MultiAgentEnvConfig):
        from pyflyt_engine.batched.swarm import BatchedSwarmEnv

        return BatchedSwarmEnv(cfg, worlds=n_envs, seed=seed)
    return BatchedUAVEnv(cfg, num_envs=n_envs, seed=seed)


__all__ = [
    "BATCHED_TASKS",
    "BatchedUAVEnv",
    "batched_vector_env",
    "check_supported",
    "make_batched_env",
    "resolve_backend",
]
