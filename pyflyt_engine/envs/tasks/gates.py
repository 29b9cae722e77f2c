"""Gates: fly through a course of gates in order.

The gates are payloads of the env config fixed in the world (``attach: {to: world, joint:
fixed}``), named in order by the task option ``gates``; touching one is a vehicle contact,
a crash.  Each gate's frame has its opening in its y-z plane, centred on its origin, and
is passed in the direction of its +x axis.

Course: ``course: random`` (default) places the gates at every reset along a random
chain, drawn from the env's seeded RNG (:func:`random_course`); ``course: fixed`` keeps
the poses declared in the config.

A gate is **passed** when the vehicle's centre of mass crosses the gate's plane from its
-x side to its +x side during an agent step (on the straight segment between the step's
start and end positions) at a point within the opening: ``|y|, |z| <= opening / 2 -
clearance`` in the gate's frame.  Then the next gate becomes the target; passing the last
completes the task.  Gates must be passed in order: crossing another gate's plane does
nothing.  A negative ``clearance`` also counts crossings up to ``-clearance`` outside the
opening (beside the gate; the gate itself stays solid): an easier task for a training
curriculum (``train.curriculum: {clearance: {start: -0.8, steps: N}}`` counts crossings
within 1 m of the centre at first, then only through the opening), as the waypoint tasks
ease their reach sphere.

Signals: ``target_distance`` [m] and ``target_distance_rate`` [m/s] to the next gate's
centre, ``waypoint_reached`` when a gate is passed.

Observation (task option ``observation``), env configs adding the camera image with
``camera_observation``:

* ``deltas`` (default): ``Dict(attitude=Box, target_deltas=Sequence(Box(3,), stack=True))``:
  body-frame vectors [m] from the vehicle to the centre of every gate not yet passed,
  next first (as the waypoint tasks);
* ``corners``: ``Dict(attitude=Box, gate=Box(12,))``: body-frame vectors [m] from the
  vehicle to the 4 corners of the next gate's opening, (x, y, z) of each in turn, seen
  along the gate's +x: top left, top right, bottom right, bottom left (zeros once every
  gate is passed);
* ``relative_pose``: ``Dict(attitude=Box, gate=Box(7,))``: the next gate's centre in the
  body frame [m], then its attitude relative to the body as a quaternion (x, y, z, w) of
  ``R_body^T R_gate`` (zeros once every gate is passed).

``corners`` and ``relative_pose`` are fixed-size, so Stable-Baselines3 takes them as they
are (``MultiInputPolicy`` with the image); the training wrappers flatten ``deltas`` to
the next gates (:class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv`).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pydantic import Field, model_validator

from pyflyt_engine import exact
from pyflyt_engine.envs.observe import ObservationLayout, ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.base import Task, TaskOptions, TaskSignals
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.envs.tasks.pilot import QuadXVelocityPilot, dict_observation
from pyflyt_engine.envs.waypoints import body_frame_deltas
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import euler_to_quaternion, matrix_to_quaternion, quaternion_to_matrix, quaternion_to_rows
from pyflyt_engine.state import KinematicState


class GatesOptions(TaskOptions):
    """Options of the gates task (``task:`` in the env YAML)."""

    name: Literal["gates"] = "gates"
    gates: list[str] = Field(min_length=1, description="names of the gate payloads, in the order they are flown")
    course: Literal["random", "fixed"] = Field(
        "random", description="random: a new course at every reset; fixed: the payloads' declared poses"
    )
    opening: float = Field(0.4, gt=0, description="inner width and height of a gate's square opening [m]")
    clearance: float = Field(
        0.0,
        description="margin kept from the opening's edges for a pass to count [m]; negative: crossings that far "
        "outside the opening count too (a curriculum's easing)",
    )
    min_gate_distance: float = Field(1.0, gt=0, description="random course: closest spacing of gates [m]")
    max_gate_distance: float = Field(3.0, gt=0, description="random course: farthest spacing of gates [m]")
    max_turn: float = Field(1.0, ge=0, le=math.pi, description="random course: largest heading change per gate [rad]")
    max_climb: float = Field(
        0.3, ge=0, lt=math.pi / 2, description="random course: largest climb or dive angle between gates [rad]"
    )
    observation: Literal["deltas", "corners", "relative_pose"] = Field(
        "deltas",
        description="what the agent sees of the course besides the image: deltas (target_deltas, every gate left), "
        "corners (gate: the next gate's 4 opening corners, body frame) or relative_pose (gate: the next gate's "
        "centre and attitude relative to the body)",
    )
    min_gate_height: float = Field(1.0, ge=0, description="random course: lowest gate centre [m]")
    max_gate_height: float = Field(3.0, gt=0, description="random course: highest gate centre [m]")

    @model_validator(mode="after")
    def _ranges(self) -> GatesOptions:
        if self.min_gate_distance > self.max_gate_distance:
            raise ValueError(
                f"min_gate_distance {self.min_gate_distance} m exceeds max_gate_distance {self.max_gate_distance} m"
            )
        if self.min_gate_height > self.max_gate_height:
            raise ValueError(
                f"min_gate_height {self.min_gate_height} m exceeds max_gate_height {self.max_gate_height} m"
            )
        if 2 * self.clearance >= self.opening:
            raise ValueError(f"clearance {self.clearance} m leaves no opening in a gate {self.opening} m wide")
        if len(set(self.gates)) != len(self.gates):
            raise ValueError("a gate is named twice in 'gates'")
        return self


def random_course(
    rng: np.random.Generator, start: np.ndarray, count: int, options: GatesOptions
) -> tuple[np.ndarray, np.ndarray]:
    """A random chain of ``count`` gates from ``start``: ``(centres (n, 3) [m], headings (n,) [rad])``.

    Each gate is ``d ~ U(min_gate_distance, max_gate_distance)`` beyond the previous one (the
    first beyond ``start``) along a heading that turns by ``U(-max_turn, max_turn)`` from the
    previous one (the first from +x) and climbs at ``U(-max_climb, max_climb)``; heights are
    clamped to ``[min_gate_height, max_gate_height]``.  Each gate faces along its heading
    (yaw = heading: passed in its +x direction).  Draws exactly ``3 * count`` numbers.
    """
    o = options
    draws = rng.uniform(-1.0, 1.0, size=(count, 3))
    centres = np.zeros((count, 3))
    headings = np.zeros(count)
    position = np.asarray(start, dtype=np.float64).copy()
    heading = 0.0
    for i, (u_turn, u_climb, u_dist) in enumerate(draws):
        heading += u_turn * o.max_turn
        climb = u_climb * o.max_climb
        distance = o.min_gate_distance + 0.5 * (u_dist + 1.0) * (o.max_gate_distance - o.min_gate_distance)
        position = position + distance * np.array(
            (math.cos(climb) * math.cos(heading), math.cos(climb) * math.sin(heading), math.sin(climb))
        )
        position[2] = min(max(position[2], o.min_gate_height), o.max_gate_height)
        centres[i] = position
        headings[i] = heading
    return centres, headings


def gate_crossing(
    start: np.ndarray, end: np.ndarray, centre: np.ndarray, rotation: np.ndarray, half_opening: float
) -> bool:
    """Whether the segment ``start``-``end`` crosses the gate's plane from -x to +x within the opening.

    ``rotation`` is the gate-to-ground rotation; the opening is ``|y|, |z| <= half_opening``
    in the gate's frame.
    """
    a = np.array(exact.rotate_t(rotation, np.asarray(start) - centre))  # gate-frame coordinates
    b = np.array(exact.rotate_t(rotation, np.asarray(end) - centre))
    if not (a[0] < 0.0 <= b[0]):
        return False
    t = a[0] / (a[0] - b[0])
    point = a + t * (b - a)
    return abs(point[1]) <= half_opening and abs(point[2]) <= half_opening


class GatesTask(Task):
    """Pass every gate in order (module docstring)."""

    name: ClassVar[str] = "gates"
    Options: ClassVar[type[TaskOptions]] = GatesOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate", "waypoints"})
    # read at every step (the crossing test): a curriculum may ease it
    episode_options: ClassVar[frozenset[str]] = frozenset({"clearance"})
    measures: ClassVar[tuple[Measure, ...]] = (
        Measure("gates_passed", "gates passed", digits=2),
        Measure("all_passed", "every gate passed", percent=True),
    )

    options: GatesOptions

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        o = self.options
        if o.course == "random":
            # every gate is at most max_gate_distance beyond the previous (clamping heights only
            # shortens a step), so no bar is farther than this from the origin
            reach = exact.norm(o.start_position) + len(o.gates) * o.max_gate_distance + o.opening
            if reach > self.flight_dome_size:
                raise ConfigError(
                    f"task: a random course of {len(o.gates)} gates up to {o.max_gate_distance} m apart can reach "
                    f"{reach:.3g} m from the origin, outside the flight dome ({self.flight_dome_size:g} m): enlarge "
                    "flight_dome_size, or lower max_gate_distance or the number of gates"
                )
        self.centres = np.zeros((len(o.gates), 3))
        self.rotations = np.zeros((len(o.gates), 3, 3))
        self.num_passed = 0
        self._position = np.zeros(3)
        self._distance = 0.0

    def setup(self, world: Any) -> None:
        payloads = self.payloads
        for name in self.options.gates:
            if payloads is None or name not in payloads.by_name:
                have = ", ".join(payloads.by_name) if payloads is not None else "none"
                raise ConfigError(
                    f"task 'gates' names the gate '{name}' (task.gates); the env config's payloads: {have}"
                )
            attach = payloads.by_name[name].spec.attach
            if (attach.to, attach.joint) != ("world", "fixed"):
                raise ConfigError(
                    f"gate payload '{name}' must be fixed in the world (attach: {{to: world, joint: fixed}})"
                )

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        from pyflyt_engine.bullet import pybullet as p

        o = self.options
        payloads = self.payloads
        if o.course == "random":
            centres, headings = random_course(rng, np.asarray(o.start_position, dtype=np.float64), len(o.gates), o)
            for name, centre, heading in zip(o.gates, centres, headings):
                gate = payloads.by_name[name]  # type: ignore[union-attr]
                turn = quaternion_to_rows(euler_to_quaternion(0.0, 0.0, float(heading)))
                com = centre + np.array(exact.rotate(turn, gate.com))
                p.resetBasePositionAndOrientation(
                    gate.body_id,
                    com.tolist(),
                    euler_to_quaternion(0.0, 0.0, float(heading)),
                    physicsClientId=payloads.world.client,  # type: ignore[union-attr]
                )
        for i, name in enumerate(o.gates):
            s = payloads.state(name)  # type: ignore[union-attr]
            self.rotations[i] = quaternion_to_matrix(tuple(s.quaternion))
            self.centres[i] = s.point(payloads.by_name[name].local((0.0, 0.0, 0.0)))  # type: ignore[union-attr]
        self.num_passed = 0
        self._position = np.asarray(state.lin_pos, dtype=np.float64)
        self._distance = exact.norm(self.centres[0] - self._position)

    @property
    def remaining(self) -> np.ndarray:
        """Centres of the gates not yet passed, in order, ``(n, 3)`` ground frame [m]."""
        return self.centres[self.num_passed :]

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        kind = self.options.observation
        if kind == "corners":
            return spaces.Dict(
                {"attitude": attitude, "gate": spaces.Box(-np.inf, np.inf, shape=(12,), dtype=np.float64)}
            )
        if kind == "relative_pose":
            return spaces.Dict(
                {"attitude": attitude, "gate": spaces.Box(-np.inf, np.inf, shape=(7,), dtype=np.float64)}
            )
        deltas = spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64)
        return spaces.Dict({"attitude": attitude, "target_deltas": spaces.Sequence(deltas, stack=True)})

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        kind = self.options.observation
        if kind == "corners":
            corners = ("top left", "top right", "bottom right", "bottom left")
            return {
                "attitude": attitude,
                "gate": tuple(
                    ObservationPart(
                        f"corner_{k}", 3, f"vector to the next gate's {c} corner (zeros when done)", "body, m"
                    )
                    for k, c in enumerate(corners)
                ),
            }
        if kind == "relative_pose":
            return {
                "attitude": attitude,
                "gate": (
                    ObservationPart("gate_centre", 3, "vector to the next gate's centre (zeros when done)", "body, m"),
                    ObservationPart(
                        "gate_attitude",
                        4,
                        "the gate's attitude relative to the body, R_body^T R_gate",
                        "quaternion (x, y, z, w)",
                    ),
                ),
            }
        centre = ObservationPart(
            "gate_delta", 3, "vector to a gate not yet passed, one row each, next first", "body, m"
        )
        return {"attitude": attitude, "target_deltas": (centre,)}

    def observe(self, attitude: np.ndarray, state: KinematicState) -> dict[str, np.ndarray]:
        kind = self.options.observation
        if kind == "deltas":
            return {
                "attitude": attitude,
                "target_deltas": body_frame_deltas(self.remaining, state.lin_pos, state.quaternion),
            }
        i = self.num_passed
        if i >= len(self.options.gates):  # the course is flown: nothing ahead
            return {"attitude": attitude, "gate": np.zeros(12 if kind == "corners" else 7)}
        if kind == "corners":
            corners = body_frame_deltas(self.corners(i), state.lin_pos, state.quaternion)
            return {"attitude": attitude, "gate": np.ascontiguousarray(corners).reshape(12)}
        centre = body_frame_deltas(self.centres[i : i + 1], state.lin_pos, state.quaternion)[0]
        body = quaternion_to_rows(state.quaternion)
        relative = np.array(exact.matmul(exact.transpose(body), self.rotations[i]))  # gate -> body rotation
        return {"attitude": attitude, "gate": np.array([*centre, *matrix_to_quaternion(relative)])}

    def keep_clear(self) -> np.ndarray:
        """The gate centres: generated obstacles keep clear of them."""
        return self.centres.copy()

    def corners(self, index: int) -> np.ndarray:
        """Ground-frame corners of gate ``index``'s opening, ``(4, 3)`` [m]: seen along the
        gate's +x (the way it is passed), top left, top right, bottom right, bottom left."""
        h = 0.5 * self.options.opening
        rotation = self.rotations[index]
        local = ((0.0, h, h), (0.0, -h, h), (0.0, -h, -h), (0.0, h, -h))
        return np.array([[c + d for c, d in zip(self.centres[index], exact.rotate(rotation, p))] for p in local])

    def update(self, state: KinematicState) -> TaskSignals:
        o = self.options
        position = np.asarray(state.lin_pos, dtype=np.float64)
        if self.num_passed >= len(o.gates):
            self._position = position
            return TaskSignals(target_distance=0.0, target_distance_rate=0.0)
        i = self.num_passed
        distance = exact.norm(self.centres[i] - position)
        rate = (distance - self._distance) / self.agent_dt
        passed = gate_crossing(
            self._position, position, self.centres[i], self.rotations[i], 0.5 * o.opening - o.clearance
        )
        if passed:
            self.num_passed += 1
            if self.num_passed < len(o.gates):
                distance_next = exact.norm(self.centres[self.num_passed] - position)
                self._distance = distance_next
        else:
            self._distance = distance
        self._position = position
        return TaskSignals(
            target_distance=distance,
            target_distance_rate=rate,
            waypoint_reached=passed,
            complete=passed and self.num_passed == len(o.gates),
        )

    def info(self) -> dict[str, Any]:
        return {"num_targets_reached": self.num_passed}

    def episode_measures(self) -> dict[str, float]:
        return {"gates_passed": float(self.num_passed), "all_passed": float(self.num_passed >= len(self.options.gates))}


# ------------------------------------------------ the oracle of this task (pyflyt_engine.envs.oracles)


class QuadXGateRacer:
    """Fly the QuadX through the gates in order (``PyFlyt/QuadX-Gates-v0`` with ``observation: corners``).

    From the observation alone (the attitude vector and the next gate's 4 opening corners
    in the body frame), with no state of its own: the gate's centre ``c`` and its passing
    direction ``n`` (the opening's normal, from the corners' order) in the ground frame;
    the vehicle's offset from the gate's axis (the line through ``c`` along ``n``) is
    ``l``; the velocity flown is ``speed n - k_lat l`` (so the vehicle closes on the axis
    while moving along it), slower (``k_far``) while more than ``far`` m off the axis, and
    :class:`QuadXVelocityPilot` flies it, heading along ``n``.  After the last gate (the
    corners are all zero) it holds still.

    The "cone": the vehicle flies on at ``speed`` while its offset from the axis is under
    ``cone_base + cone_slope`` x its distance to the gate's plane; outside, at
    ``closing_speed`` (backing off when already beside the gate).  Of the first 50 probe
    courses (seeds 10 000+) it flies 47 whole and passes at least 3 gates in 49; the other
    3 end on a gate's bar (``experiments/results/quadx_scripted.md``).
    """

    name: str = "quadx_gate_racer"
    env_ids: tuple[str, ...] = ("PyFlyt/QuadX-Gates-v0",)
    #: the env config ``pyflyt eval oracle:quadx_gate_racer`` flies without ``env=`` (the id's
    #: own, ``quadx_gates``, sees the camera image and the gate centres, not the corners)
    env_config = "quadx_gates_state"

    def __init__(
        self,
        env: Any,
        speed: float = 1.5,
        k_lat: float = 2.5,
        closing_speed: float = 0.5,
        cone_base: float = 0.08,
        cone_slope: float = 0.2,
        behind: float = 0.1,
    ) -> None:
        base = env.unwrapped
        if getattr(base.task.options, "observation", None) != "corners":
            raise ConfigError("oracle quadx_gate_racer reads the next gate's corners: set env.task.observation=corners")
        self.pilot = QuadXVelocityPilot(env)
        self.unpack = dict_observation(env)
        self.speed, self.k_lat, self.closing_speed = speed, k_lat, closing_speed
        self.cone_base, self.cone_slope, self.behind = cone_base, cone_slope, behind

    def __call__(self, obs: Any) -> np.ndarray:
        o = self.unpack(obs)
        attitude = np.asarray(o["attitude"], dtype=np.float64)
        rows, _, _ = self.pilot.state(attitude)
        gate = np.asarray(o["gate"], dtype=np.float64).reshape(4, 3)
        if not gate.any():  # the course is flown
            return self.pilot(attitude, (0.0, 0.0, 0.0))
        corners = [exact.rotate(rows, g.tolist()) for g in gate]  # ground frame, from the vehicle
        centre = [0.25 * (corners[0][i] + corners[1][i] + corners[2][i] + corners[3][i]) for i in range(3)]
        # corners: top left, top right, bottom right, bottom left seen along +x; y = left, z = up
        left = [corners[0][i] - corners[1][i] + corners[3][i] - corners[2][i] for i in range(3)]
        up = [corners[0][i] - corners[3][i] + corners[1][i] - corners[2][i] for i in range(3)]
        normal = exact.cross(left, up)
        size = exact.norm(normal)
        n = [c / size for c in normal]
        offset = [-c for c in centre]  # the vehicle from the gate's centre
        along = exact.dot(offset, n)
        lateral = [offset[i] - along * n[i] for i in range(3)]
        miss = exact.norm(lateral)
        # inside the cone -- off the axis by less than cone_base + cone_slope x the distance to
        # the gate's plane -- fly on at speed; outside it, slow to closing_speed until back in it
        cone = self.cone_base + self.cone_slope * max(-along, 0.0)
        forward = self.speed if miss <= cone else self.closing_speed
        if along > -self.behind and miss > cone:  # beside the gate, past the plane: back off
            forward = -self.closing_speed
        want = [forward * n[i] - self.k_lat * lateral[i] for i in range(3)]
        return self.pilot(attitude, want, heading=math.atan2(n[1], n[0]))


register_task(GatesTask, oracles=(QuadXGateRacer,))
