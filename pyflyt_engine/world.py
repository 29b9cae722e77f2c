"""The World (the paper's Aviary): physics client, scheduler, vehicles and collisions.

Loop rates (paper, "Looprates"): physics 240 Hz, control 120 Hz, agent 30 Hz by
default.  One call to :meth:`World.step` is one agent step: ``physics_hz / agent_hz``
physics steps, with the flight controllers running on every
``physics_hz / control_hz``-th of them (counted globally, so the schedule does not
depend on where agent steps fall).  Every ratio must be an integer.

Each physics step, in order: on control ticks every vehicle reads its state, the world
works out the air at it (:mod:`pyflyt_engine.atmosphere.air`: its velocity through the
air, its rotors' ground-effect ratios) and the vehicle runs its controller; then every
vehicle with boosters updates its mass for the fuel burnt, and every vehicle advances its
actuators in that air and applies its net wrench.  Between ticks, each vehicle in turn
reads its motion if its loads depend on the air (drag, lifting surfaces; every vehicle
when rotor interactions are on), gets its air, and applies its loads.  Then PyBullet
steps.  Contacts are read at the end of every control period (and
of every agent step): a touch shorter than one control period (8 ms at 120 Hz) can go
unrecorded, while resting and crash contacts, which PyBullet keeps in its contact
manifolds for as long as the bodies touch, are always seen.  After the agent step each
vehicle's state is read from PyBullet when first asked for (:attr:`Vehicle.state`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_engine.atmosphere import WindConfig, WindField, load_wind_config
from pyflyt_engine.atmosphere.air import Air, Atmosphere, air_velocity
from pyflyt_engine.atmosphere.rotors import RotorInteractions
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import ConfigError, SimulationError
from pyflyt_engine.spec import UAVSpec, load_uav_spec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.vehicle import Vehicle


@dataclass(frozen=True)
class VehicleConfig:
    """Where and what to spawn.

    Attributes:
        uav: shipped airframe name, path to a YAML spec, or a loaded :class:`UAVSpec`.
        position: spawn position (x, y, z) [m], ground frame.
        orientation: spawn attitude (roll, pitch, yaw) [rad].
        mode: initial flight mode (name or PyFlyt integer); default from the spec.
    """

    uav: str | Path | UAVSpec = "quadx_cf2x"
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mode: str | int | None = None


def _ratio(numerator: float, denominator: float, what: str) -> int:
    ratio = numerator / denominator
    if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
        raise ConfigError(
            f"{what} must divide evenly: got {numerator:g} / {denominator:g} = {ratio:g}; "
            "choose rates whose ratio is a whole number (e.g. physics 240, control 120, agent 30)"
        )
    return int(round(ratio))


def _finite_vector(values: Sequence[float], name: str, unit: str) -> tuple[float, float, float]:
    """``values`` as 3 finite floats; ConfigError naming ``name`` otherwise."""
    try:
        vector = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise ConfigError(f"spawn {name} must be 3 numbers {unit}, got {values!r}") from None
    if len(vector) != 3 or not all(math.isfinite(v) for v in vector):
        raise ConfigError(f"spawn {name} must be 3 finite numbers {unit}, got {list(vector)}")
    return vector


@dataclass
class _Contacts:
    """Tracked bodies and the pairs of them that touched during the last step.

    Kept sparse -- the set of touching row pairs ``(a, b)`` with ``a <= b`` and the set of
    rows that touched anything -- so clearing, recording and querying cost O(contacts),
    not O(bodies^2); the dense matrix is built only when asked for (:meth:`matrix`).
    """

    body_ids: list[int] = field(default_factory=list)
    index: dict[int, int] = field(default_factory=dict)
    pairs: set[tuple[int, int]] = field(default_factory=set)
    rows: set[int] = field(default_factory=set)

    def add(self, body_id: int) -> None:
        self.index[body_id] = len(self.body_ids)
        self.body_ids.append(body_id)

    def clear(self) -> None:
        self.pairs.clear()
        self.rows.clear()

    def record(self, contacts: Sequence[tuple]) -> None:
        """Add the touching pairs among PyBullet contact points (tracked bodies only)."""
        index, pairs, rows = self.index, self.pairs, self.rows
        for contact in contacts:
            a = index.get(contact[1])
            b = index.get(contact[2])
            if a is not None and b is not None:
                pairs.add((a, b) if a <= b else (b, a))
                rows.add(a)
                rows.add(b)

    def matrix(self) -> np.ndarray:
        """Symmetric boolean matrix over :attr:`body_ids` of the touching pairs."""
        n = len(self.body_ids)
        matrix = np.zeros((n, n), dtype=bool)
        for a, b in self.pairs:
            matrix[a, b] = matrix[b, a] = True
        return matrix


class World:
    """A physics world holding any number of vehicles of any airframes.

    Args:
        vehicles: vehicles to spawn now (:class:`VehicleConfig` or dicts of its fields).
        physics_hz: physics rate [Hz].
        control_hz: flight controller rate [Hz].
        agent_hz: rate of :meth:`step` [Hz].
        seed: seeds :attr:`np_random` and every actuator noise stream (None: random).
        render: open PyBullet's GUI instead of the headless DIRECT backend.
        ground: add a ground plane at z = 0.
        drag: apply the airframes' body drag.
        gravity: gravitational acceleration [m/s^2].
        wind: the atmosphere (``docs/atmosphere.md``): a preset name in ``conf/wind``
            (``calm``, ``constant``, ``dryden_light`` ...), a YAML path, a mapping or a
            :class:`~pyflyt_engine.atmosphere.WindConfig`; None or ``calm``: still air.
        ground_effect: scale each rotor's thrust by the Cheeseman-Bennett ground-effect
            ratio at its hub height (rotors with a ``prop_radius``; needs ``ground``).
        downwash: vehicles below a rotorcraft feel its wake as a downward wind
            (:mod:`pyflyt_engine.atmosphere.rotors`).

    Example::

        world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="position_yaw")], seed=0)
        world.set_setpoint(0, [0, 0, 0, 1])     # x, y, yaw, z
        for _ in range(300):
            world.step()
        print(world.state(0).lin_pos)
    """

    def __init__(
        self,
        vehicles: Iterable[VehicleConfig | dict] = (),
        *,
        physics_hz: float = 240.0,
        control_hz: float = 120.0,
        agent_hz: float = 30.0,
        seed: int | None = None,
        render: bool = False,
        ground: bool = True,
        drag: bool = True,
        gravity: float = GRAVITY,
        wind: str | Path | Mapping[str, Any] | WindConfig | None = None,
        ground_effect: bool = False,
        downwash: bool = False,
    ) -> None:
        self.physics_hz = float(physics_hz)
        self.control_hz = float(control_hz)
        self.agent_hz = float(agent_hz)
        for name, value in (("physics_hz", physics_hz), ("control_hz", control_hz), ("agent_hz", agent_hz)):
            if not 0 < value < math.inf:
                raise ConfigError(f"{name} must be a finite number > 0 Hz, got {value}")
        if not math.isfinite(gravity):
            raise ConfigError(f"gravity must be a finite acceleration [m/s^2], got {gravity}; the default is {GRAVITY}")
        self.physics_per_control = _ratio(self.physics_hz, self.control_hz, "physics_hz / control_hz")
        self.physics_per_agent = _ratio(self.physics_hz, self.agent_hz, "physics_hz / agent_hz")
        self.physics_dt = 1.0 / self.physics_hz
        self.drag = drag
        #: the gravitational acceleration [m/s^2] (along -z)
        self.gravity = float(gravity)

        self.client = p.connect(p.GUI if render else p.DIRECT)
        if self.client < 0:
            raise SimulationError(
                "PyBullet refused a new connection (it holds a limited number of clients at once): "
                "close the envs and worlds that are done (env.close(), World.close() or a with block)"
            )
        if self.client < 0:
            raise RuntimeError("could not connect to PyBullet (GUI needs a display; use render=False)")
        p.setGravity(0.0, 0.0, -gravity, physicsClientId=self.client)
        p.setTimeStep(self.physics_dt, physicsClientId=self.client)

        self._contacts = _Contacts()
        self.ground_id: int | None = None
        if ground:
            shape = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client)
            self.ground_id = p.createMultiBody(0.0, shape, physicsClientId=self.client)
            self._contacts.add(self.ground_id)

        self.vehicles: list[Vehicle] = []
        self._seed(seed)
        self.wind_config: WindConfig = load_wind_config(wind)
        field = None if self.wind_config.calm else WindField(self.wind_config, self.physics_dt, self._wind_generator)
        rotors = None
        if (ground_effect and ground) or downwash:
            rotors = RotorInteractions(bool(ground_effect and ground), bool(downwash))
        #: the air the vehicles fly through: wind field, ground effect, downwash
        self.atmosphere = Atmosphere(field, rotors, self.vehicles)
        #: per vehicle, the air at its latest read, as its loads take it
        self._airs: list[Air] = []
        self.physics_steps = 0
        self._snapshot: int | None = None
        self._schedules: dict[tuple[int, int, int], tuple[tuple[bool, bool], ...]] = {}
        for config in vehicles:
            if isinstance(config, dict):
                config = VehicleConfig(**config)
            self.add_vehicle(config.uav, config.position, config.orientation, config.mode)

    # ------------------------------------------------------------ building

    def _seed(self, seed: int | None) -> None:
        self.seed = seed
        self._seed_sequence = np.random.SeedSequence(seed)
        self.np_random = np.random.default_rng(self._seed_sequence.spawn(1)[0])
        self._vehicle_seeds = self._seed_sequence.spawn(1)[0]
        self._wind_generator = self._wind_rng()

    def _wind_rng(self) -> np.random.Generator:
        # the wind's own stream, apart from np_random and the vehicles' (spawn key 2)
        return np.random.default_rng(np.random.SeedSequence(self._seed_sequence.entropy, spawn_key=(2,)))

    def _sensor_rngs(self, index: int) -> list[np.random.Generator]:
        # one stream per range sensor of vehicle slot ``index`` (spawn key 3): sensors never
        # draw from the physics' streams, so adding one leaves the flight unchanged
        n = len(self.vehicles[index].range_sensors)
        entropy = self._seed_sequence.entropy
        return [np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(3, index, k))) for k in range(n)]

    def _suite_rng(self, index: int) -> np.random.Generator:
        # the noisy sensors' stream of vehicle slot ``index`` (spawn key 4), apart from the
        # physics' and the range sensors' (components/sensors.py)
        return np.random.default_rng(np.random.SeedSequence(self._seed_sequence.entropy, spawn_key=(4, index)))

    def _vehicle_rng(self, index: int) -> np.random.Generator:
        # one independent stream per vehicle slot, the same for a given seed and index
        return np.random.default_rng(np.random.SeedSequence(self._vehicle_seeds.entropy, spawn_key=(1, index)))

    def add_vehicle(
        self,
        uav: str | Path | UAVSpec = "quadx_cf2x",
        position: Sequence[float] = (0.0, 0.0, 0.0),
        orientation: Sequence[float] = (0.0, 0.0, 0.0),
        mode: str | int | None = None,
    ) -> int:
        """Spawn a vehicle; returns its index in :attr:`vehicles`.

        Raises:
            ConfigError: ``position`` or ``orientation`` is not 3 finite numbers.
        """
        position = _finite_vector(position, "position", "[m]")
        orientation = _finite_vector(orientation, "orientation", "(roll, pitch, yaw) [rad]")
        spec = uav if isinstance(uav, UAVSpec) else load_uav_spec(uav)
        index = len(self.vehicles)
        vehicle = Vehicle(
            self.client,
            spec,
            position,
            orientation,
            physics_dt=self.physics_dt,
            control_dt=self.physics_dt * self.physics_per_control,
            rng=self._vehicle_rng(index),
            mode=mode,
            drag=self.drag,
        )
        self.vehicles.append(vehicle)
        vehicle.seed_sensors(self._sensor_rngs(index))
        if spec.sensors is not None:
            vehicle.attach_sensors(self.gravity, self._suite_rng(index))
        self.atmosphere.add_vehicle(vehicle)
        self._airs.append(((vehicle.state.lin_vel, vehicle.state.ang_vel), None))
        self._contacts.add(vehicle.body_id)
        self._drop_snapshot()
        return index

    def set_wind(self, wind: str | Path | Mapping[str, Any] | WindConfig | None) -> None:
        """Replace the atmosphere (e.g. a wind sampled at a reset): a new field at time 0,
        drawing from the world's wind stream."""
        self.wind_config = load_wind_config(wind)
        self.atmosphere.field = (
            None if self.wind_config.calm else WindField(self.wind_config, self.physics_dt, self._wind_generator)
        )
        for vehicle in self.vehicles:
            vehicle.state_changed()

    @property
    def wind(self) -> WindField | None:
        """The wind field (None in still air: nothing is added to the loop)."""
        return self.atmosphere.field

    @property
    def rotor_interactions(self) -> RotorInteractions | None:
        """Ground effect and downwash (None when both are off: nothing is added to the loop)."""
        return self.atmosphere.rotors

    def add_body(self, body_id: int) -> int:
        """Track collisions of a body created directly with PyBullet (obstacles, pads)."""
        self._contacts.add(body_id)
        self._drop_snapshot()
        return self._contacts.index[body_id]

    def replace_bodies(self, old: Sequence[int], new: Sequence[int]) -> None:
        """Stop tracking ``old`` (bodies already removed from PyBullet) and track ``new``
        instead (scenery rebuilt at a reset: generated obstacles).  The saved state is
        replaced by one holding the new bodies, which the next :meth:`reset` restores (it
        puts every vehicle back at its spawn pose after restoring)."""
        contacts = self._contacts
        gone = set(old)
        contacts.body_ids = [b for b in contacts.body_ids if b not in gone]
        for body in new:
            contacts.body_ids.append(body)
        contacts.index = {b: i for i, b in enumerate(contacts.body_ids)}
        contacts.clear()
        self._drop_snapshot()
        self._snapshot = p.saveState(physicsClientId=self.client)

    def _drop_snapshot(self) -> None:
        # the saved state no longer covers every body: free it (PyBullet keeps every
        # saved state until removed), the next reset saves a new one
        if self._snapshot is not None:
            p.removeState(self._snapshot, physicsClientId=self.client)
            self._snapshot = None

    # ------------------------------------------------------------ commanding

    def _vehicle(self, index: int) -> Vehicle:
        try:
            return self.vehicles[index]
        except IndexError:
            raise ConfigError(f"no vehicle {index}: the world has {len(self.vehicles)}") from None

    def set_mode(self, index: int, mode: str | int) -> None:
        """Set the flight mode of vehicle ``index``."""
        self._vehicle(index).set_mode(mode)

    def set_setpoint(self, index: int, setpoint: Sequence[float] | np.ndarray) -> None:
        """Set the setpoint of vehicle ``index`` (layout: its mode's ``setpoint``)."""
        self._vehicle(index).set_setpoint(setpoint)

    def set_all_setpoints(self, setpoints: np.ndarray | Sequence[Sequence[float]]) -> None:
        """One setpoint row per vehicle."""
        if len(setpoints) != len(self.vehicles):
            raise ConfigError(f"got {len(setpoints)} setpoints for {len(self.vehicles)} vehicles")
        for vehicle, setpoint in zip(self.vehicles, setpoints):
            vehicle.set_setpoint(setpoint)

    def set_armed(self, index: int, armed: bool = True) -> None:
        """Arm or disarm vehicle ``index`` (disarmed: actuators commanded to zero)."""
        self._vehicle(index).armed = bool(armed)

    # --------------------------------------------------------------- stepping

    def step(self) -> None:
        """Advance one agent step (``physics_hz / agent_hz`` physics steps)."""
        cid = self.client
        vehicles = self.vehicles
        airs = self._airs
        rotors = self.atmosphere.rotors is not None
        atmosphere: Atmosphere | None = self.atmosphere
        if self.atmosphere.field is None and not rotors:
            atmosphere = None  # still air: each vehicle's air velocity is its own velocity
        # Vehicles never read each other's state within a physics step, so each phase can
        # run over all of them in turn; the per-vehicle work is the same as interleaved.
        ticking = list(enumerate(vehicles))
        boosted = [v for v in vehicles if v.actuators.boosters is not None]
        contacts = self._contacts
        contacts.clear()
        record = contacts.record
        step_simulation, contact_points = p.stepSimulation, p.getContactPoints
        wind = self.atmosphere.field
        wind = wind if wind is not None and not wind.static else None
        if rotors:  # the downwash's wake grid: every vehicle binned now, then each as it is read
            self.atmosphere.stepping(True)
        for tick, sample in self._schedule(self.physics_steps):
            if tick:  # control tick
                for i, vehicle in ticking:
                    state = vehicle.read_state()
                    if atmosphere is None:  # still air: the air velocity is the body's own
                        airs[i] = ((state.lin_vel, state.ang_vel), None)
                    else:
                        airs[i] = atmosphere.at_state(i, vehicle)
                    vehicle.control_step()
                for vehicle in boosted:  # fuel burnt: new mass and inertia
                    vehicle.update_mass()
                for vehicle, (air, thrust_ratio) in zip(vehicles, airs):
                    vehicle.apply_loads(air, thrust_ratio)
            else:
                for i, vehicle in ticking:
                    if vehicle.needs_air or rotors:  # loads that take the air (drag, surfaces), or rotor interactions
                        pos, r, lin, ang = vehicle.read_motion()
                        if atmosphere is None:
                            airs[i] = (air_velocity(r, lin, ang), None)
                        else:
                            airs[i] = atmosphere.at_motion(i, pos, r, lin, ang)
                    air, thrust_ratio = airs[i]
                    vehicle.apply_loads(air, thrust_ratio)
            step_simulation(cid)
            self.physics_steps += 1
            if wind is not None:
                wind.advance()
            if sample:  # the end of a control period or of the agent step
                record(contact_points(-1, -1, -2, -2, cid))
        if rotors:
            self.atmosphere.stepping(False)
        for vehicle in vehicles:  # read again when asked for (Vehicle.state)
            vehicle.state_changed()

    def _schedule(self, start: int) -> tuple[tuple[bool, bool], ...]:
        """Per physics step of an agent step starting at physics step ``start``: whether
        it is a control tick, and whether contacts are sampled after it."""
        per_control, count = self.physics_per_control, self.physics_per_agent
        key = (start % per_control, per_control, count)
        schedule = self._schedules.get(key)
        if schedule is None:
            schedule = tuple(
                ((start + i) % per_control == 0, (start + i + 1) % per_control == 0 or i == count - 1)
                for i in range(count)
            )
            self._schedules[key] = schedule
        return schedule

    # --------------------------------------------------------------- read-outs

    def state(self, index: int) -> KinematicState:
        """The latest :class:`KinematicState` of vehicle ``index``."""
        return self._vehicle(index).state

    def scan(self, index: int, sensor: int = 0) -> np.ndarray:
        """Readings of range sensor ``sensor`` of vehicle ``index``, refreshed at its rate."""
        return self._vehicle(index).scan(sensor, time=self.elapsed)

    def capture(self, index: int, camera: int = 0) -> dict[str, np.ndarray]:
        """Images of camera ``camera`` of vehicle ``index``, refreshed at its capture rate."""
        return self._vehicle(index).capture(camera, time=self.elapsed)

    def aux_state(self, index: int) -> np.ndarray:
        """Auxiliary state (actuator read-outs) of vehicle ``index``."""
        return self._vehicle(index).aux_state

    @property
    def elapsed(self) -> float:
        """Simulated time since creation or the last reset [s]."""
        return self.physics_steps * self.physics_dt

    @property
    def contact_array(self) -> np.ndarray:
        """Symmetric boolean matrix of bodies that touched during the last :meth:`step`.

        Rows/columns follow :attr:`contact_bodies` (the ground first, if present, then
        bodies in the order they were added).
        """
        return self._contacts.matrix()

    @property
    def contact_bodies(self) -> list[int]:
        """PyBullet body ids indexing :attr:`contact_array`."""
        return list(self._contacts.body_ids)

    def collided(self, index: int) -> bool:
        """Whether vehicle ``index`` touched anything (ground included) in the last step."""
        return self._contacts.index[self._vehicle(index).body_id] in self._contacts.rows

    def collided_with_ground(self, index: int) -> bool:
        """Whether vehicle ``index`` touched the ground in the last step."""
        if self.ground_id is None:
            return False
        return self._touched(self._vehicle(index).body_id, self.ground_id)

    def collided_with(self, index: int, other: int) -> bool:
        """Whether vehicles ``index`` and ``other`` touched each other in the last step."""
        return self._touched(self._vehicle(index).body_id, self._vehicle(other).body_id)

    def collided_with_body(self, index: int, body_id: int) -> bool:
        """Whether vehicle ``index`` touched the tracked body ``body_id`` (:meth:`add_body`) in the last step."""
        return self.bodies_touched(self._vehicle(index).body_id, body_id)

    def bodies_touched(self, body_a: int, body_b: int) -> bool:
        """Whether two tracked bodies (PyBullet ids, e.g. a vehicle's ``body_id`` and a body
        given to :meth:`add_body`) touched each other in the last step: one entry of
        :attr:`contact_array`, without building the matrix."""
        return self._touched(body_a, body_b)

    def _touched(self, body_a: int, body_b: int) -> bool:
        a, b = self._contacts.index[body_a], self._contacts.index[body_b]
        return ((a, b) if a <= b else (b, a)) in self._contacts.pairs

    # ---------------------------------------------------------------- resets

    def reset(self, seed: int | None = None) -> None:
        """Return every body to its spawn state without rebuilding the world.

        Restores the PyBullet state saved after the last body was added, puts every
        vehicle at rest at its spawn pose with idle actuators and cleared controllers,
        and, when ``seed`` is given, reseeds :attr:`np_random` and the actuator noise.
        """
        if self._snapshot is None:
            for vehicle in self.vehicles:
                vehicle.reset()
            self._snapshot = p.saveState(physicsClientId=self.client)
        else:
            p.restoreState(self._snapshot, physicsClientId=self.client)
        if seed is not None:
            self._seed(seed)
        if self.wind is not None:  # time 0, a new turbulence realisation (a new stream when seeded)
            self.wind.reset(self._wind_generator if seed is not None else None)
        for index, vehicle in enumerate(self.vehicles):
            if seed is not None:
                vehicle.reseed(self._vehicle_rng(index))
                vehicle.seed_sensors(self._sensor_rngs(index))
                if vehicle.sensors is not None:
                    vehicle.sensors.reseed(self._suite_rng(index))
            vehicle.reset()
            vehicle.armed = True
        self._contacts.clear()
        self.physics_steps = 0

    def wind_at(self, index: int) -> tuple[float, ...]:
        """Wind (x, y, z) [m/s] and rotary gust (p, q, r) [rad/s], ground frame, at vehicle
        ``index``'s position now, downwash included (zeros in still air)."""
        vehicle = self._vehicle(index)
        wind = self.atmosphere.wind_at(index, vehicle.state.lin_pos)
        return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0) if wind is None else tuple(wind)

    def air_velocity(self, index: int) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """Vehicle ``index``'s velocity through the air now, body frame: ((u, v, w) [m/s],
        (p, q, r) [rad/s]), wind and downwash subtracted (its own velocity in still air)."""
        vehicle = self._vehicle(index)
        state = vehicle.state
        if self.atmosphere.field is None and self.atmosphere.rotors is None:
            return (state.lin_vel, state.ang_vel)
        return self.atmosphere.at_state(index, vehicle)[0]

    def rng_state(self) -> dict:
        """Positions of every random stream: :attr:`np_random` and each vehicle's noise.

        A JSON-serialisable dict; with :meth:`set_rng_state` it lets a recording re-run an
        episode that began with an unseeded ``reset()`` (the streams continue from where
        the previous episode left them).
        """
        state: dict[str, Any] = {
            "world": self.np_random.bit_generator.state,
            "vehicles": [v.rng_state for v in self.vehicles],
        }
        state["wind"] = self._wind_generator.bit_generator.state
        if any(v.range_sensors for v in self.vehicles):
            state["sensors"] = [[s.rng.bit_generator.state for s in v.range_sensors] for v in self.vehicles]
        if any(v.sensors is not None for v in self.vehicles):  # the noisy sensors' streams
            state["suites"] = [
                v.sensors.rng.bit_generator.state if v.sensors is not None else None for v in self.vehicles
            ]
        return state

    def set_rng_state(self, state: dict) -> None:
        """Put every random stream where :meth:`rng_state` found it (same number of vehicles)."""

        def generator(bit_state: dict) -> np.random.Generator:
            kind = bit_state.get("bit_generator")
            if kind not in ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64"):
                raise ConfigError(f"unknown numpy bit generator {kind!r} in rng state")
            bits = getattr(np.random, kind)()
            bits.state = bit_state
            return np.random.Generator(bits)

        vehicles = state["vehicles"]
        if len(vehicles) != len(self.vehicles):
            raise ConfigError(
                f"rng state has {len(vehicles)} vehicle streams, the world has {len(self.vehicles)} vehicles"
            )
        self.np_random = generator(state["world"])
        for vehicle, bit_state in zip(self.vehicles, vehicles):
            vehicle.reseed(generator(bit_state))
        for vehicle, streams in zip(self.vehicles, state.get("sensors") or []):
            vehicle.seed_sensors([generator(s) for s in streams])
        for vehicle, stream in zip(self.vehicles, state.get("suites") or []):
            if vehicle.sensors is not None and stream is not None:
                vehicle.sensors.reseed(generator(stream))
        if "wind" in state:  # recordings made before the atmosphere have none
            self._wind_generator = generator(state["wind"])
            if self.wind is not None:
                self.wind.reseed(self._wind_generator)

    def close(self) -> None:
        """Disconnect from PyBullet and stop any flight controller firmware (idempotent)."""
        for vehicle in getattr(self, "vehicles", ()):
            if vehicle.firmware is not None:
                vehicle.firmware.close()
        if self.client is not None and self.client >= 0 and p.isConnected(self.client):
            p.disconnect(self.client)
        self.client = -1

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
