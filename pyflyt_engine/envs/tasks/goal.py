"""Goal: reach one goal point, drawn at every reset, typically through obstacles.

The goal is drawn uniformly in the box ``goal_x_range`` x ``goal_y_range`` x
``goal_z_range`` from the env's seeded RNG (3 numbers), after the spawn; it is reached
when the vehicle's centre of mass comes within ``goal_reach_distance`` of it during an
agent step (on the segment between the step's start and end positions, as the waypoint
tasks: :mod:`pyflyt_engine.envs.waypoints`).  Reaching it completes the task.

The env config's obstacles (``obstacles:``) keep their keep-out radius around the spawn
point and the goal (:meth:`Task.keep_clear`), and touching one is a crash.

Signals: ``target_distance`` [m] and ``target_distance_rate`` [m/s] to the goal,
``waypoint_reached`` on the step the goal is reached.

Observation: ``Dict(attitude=Box, goal_delta=Box(3,))``: the body-frame vector [m] from
the vehicle to the goal (zeros once it is reached), plus the range sensors and camera
the env config adds under their own keys.
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
from pyflyt_engine.envs.waypoints import WaypointTracker, body_frame_deltas
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState

Range = tuple[float, float]


class GoalOptions(TaskOptions):
    """Options of the goal task (``task:`` in the env YAML)."""

    name: Literal["goal"] = "goal"
    goal_x_range: Range = Field((4.0, 4.0), description="goal x drawn uniformly in [min, max] [m]")
    goal_y_range: Range = Field((-2.0, 2.0), description="goal y drawn uniformly in [min, max] [m]")
    goal_z_range: Range = Field((1.0, 2.0), description="goal height drawn uniformly in [min, max] [m]")
    goal_reach_distance: float = Field(0.3, gt=0, description="the goal is reached within this distance [m]")

    @model_validator(mode="after")
    def _ranges(self) -> GoalOptions:
        for name in ("goal_x_range", "goal_y_range", "goal_z_range"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"{name}: need min <= max, got [{low}, {high}]")
        if self.goal_z_range[0] < 0:
            raise ValueError(f"goal_z_range: the goal must be above the ground, got {list(self.goal_z_range)}")
        return self


class GoalTask(Task):
    """Reach one random goal (module docstring)."""

    name: ClassVar[str] = "goal"
    Options: ClassVar[type[TaskOptions]] = GoalOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate", "waypoints"})
    # read at every reset (the draw, the spawn) or step (the reach test)
    episode_options: ClassVar[frozenset[str]] = frozenset(
        {
            "goal_x_range",
            "goal_y_range",
            "goal_z_range",
            "goal_reach_distance",
            "start_position_noise",
            "start_orientation_noise",
        }
    )
    measures: ClassVar[tuple[Measure, ...]] = (Measure("goal_reached", "goal reached", percent=True),)

    options: GoalOptions

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        self.check_options(self.options)
        self.tracker = WaypointTracker(self.options.goal_reach_distance)

    def check_options(self, options: TaskOptions) -> None:
        o: GoalOptions = options  # type: ignore[assignment]
        corner = max(
            (x * x + y * y + z * z) ** 0.5 for x in o.goal_x_range for y in o.goal_y_range for z in o.goal_z_range
        )
        if corner > self.flight_dome_size:
            raise ConfigError(
                f"task: a goal may be drawn {corner:.3g} m from the origin, outside the flight dome "
                f"({self.flight_dome_size:g} m): narrow goal_x/y/z_range or enlarge flight_dome_size"
            )

    def options_changed(self) -> None:
        self.tracker.reach_distance = float(self.options.goal_reach_distance)

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        o = self.options
        u = [float(v) for v in rng.random(3)]
        goal = [lo + (hi - lo) * t for (lo, hi), t in zip((o.goal_x_range, o.goal_y_range, o.goal_z_range), u)]
        self.tracker.reset(np.array([goal]), state.lin_pos)

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        return spaces.Dict(
            {"attitude": attitude, "goal_delta": spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64)}
        )

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        goal = ObservationPart("goal_delta", 3, "vector to the goal (zeros once reached)", "body, m")
        return {"attitude": attitude, "goal_delta": (goal,)}

    def observe(self, attitude: np.ndarray, state: KinematicState) -> dict[str, np.ndarray]:
        remaining = self.tracker.remaining
        if len(remaining):
            delta = body_frame_deltas(remaining[:1], state.lin_pos, state.quaternion)[0]
        else:
            delta = np.zeros(3)
        return {"attitude": attitude, "goal_delta": np.array(delta, dtype=np.float64)}

    def update(self, state: KinematicState) -> TaskSignals:
        distance, rate, reached = self.tracker.step(state.lin_pos, self.agent_dt)
        return TaskSignals(
            target_distance=distance, target_distance_rate=rate, waypoint_reached=reached, complete=reached
        )

    def info(self) -> dict[str, Any]:
        return {"goal_reached": bool(self.tracker.all_reached)}

    def episode_measures(self) -> dict[str, float]:
        return {"goal_reached": float(self.tracker.all_reached)}

    def markers(self) -> np.ndarray:
        return self.tracker.targets.copy()

    def marker_style(self) -> tuple[int, float]:
        return 1, self.options.goal_reach_distance

    @property
    def goal(self) -> np.ndarray:
        """The episode's goal, ``(3,)`` ground frame [m] (a copy)."""
        return self.tracker.targets[0].copy()

    @property
    def targets(self) -> np.ndarray:
        """The goal as a ``(1, 3)`` array (the waypoint tasks' name for their targets)."""
        return self.tracker.targets.copy()


# ------------------------------------------------ the oracle of this task (pyflyt_engine.envs.oracles)


class QuadXForestNavigator:
    """Fly the QuadX to the goal through the forest (``PyFlyt/QuadX-Obstacles-v0``) by its LiDAR.

    From the observation alone (the attitude vector, the goal vector and the LiDAR ranges),
    with no state of its own:

    * every LiDAR return closer than the range limit is a point in the ground frame; returns
      from the ground (below ``ground`` m) are dropped;
    * of ``candidates`` horizontal headings, those whose corridor -- ``clearance`` m to
      either side of a segment ``look`` m long (or to the goal, if nearer) -- holds no point
      are free; the free heading scoring highest on ``cos(to the goal) + w_keep cos(to the
      present velocity)`` is flown at ``speed`` m/s (slowing within 1 m of the goal), the
      height steered to the goal's at ``k_z`` per second;
    * no free heading: back away from the nearest point at 0.5 m/s;
    * :class:`QuadXVelocityPilot` turns the velocity into body rates and thrust, holding
      the heading at 0 (+x, the way through the forest).

    Reaches the goal without contact in 50 of the first 50 probe episodes (seeds 10 000+;
    7.6 s on average; ``experiments/results/quadx_scripted.md``).
    """

    name: str = "quadx_forest_navigator"
    env_ids: tuple[str, ...] = ("PyFlyt/QuadX-Obstacles-v0",)

    def __init__(
        self,
        env: Any,
        speed: float = 1.2,
        look: float = 2.0,
        clearance: float = 0.4,
        candidates: int = 72,
        w_keep: float = 0.3,
        k_z: float = 1.0,
        ground: float = 0.15,
    ) -> None:
        base = env.unwrapped
        self.pilot = QuadXVelocityPilot(env)
        self.unpack = dict_observation(env)
        sensors = [s for s in base.config.range_sensors if s.name == "lidar"]
        if not sensors or sensors[0].vertical_beams != 1:
            raise ConfigError("oracle quadx_forest_navigator reads a planar LiDAR named 'lidar' (env.range_sensors)")
        lidar = sensors[0]
        n = lidar.horizontal_beams
        step = math.radians(lidar.horizontal_fov_deg) / n
        start = -0.5 * math.radians(lidar.horizontal_fov_deg)
        azimuths = [start + (k + 0.5) * step for k in range(n)]
        self.beam_x = np.array([math.cos(a) for a in azimuths])
        self.beam_y = np.array([math.sin(a) for a in azimuths])
        self.max_range = float(lidar.max_range)
        headings = [2.0 * math.pi * k / candidates for k in range(candidates)]
        self.cand_x = np.array([math.cos(h) for h in headings])[:, None]
        self.cand_y = np.array([math.sin(h) for h in headings])[:, None]
        self.speed, self.look, self.clearance, self.w_keep = speed, look, clearance, w_keep
        self.k_z, self.ground = k_z, ground

    def __call__(self, obs: Any) -> np.ndarray:
        o = self.unpack(obs)
        attitude = np.asarray(o["attitude"], dtype=np.float64)
        rows, v, pos = self.pilot.state(attitude)
        gx, gy, gz = exact.rotate(rows, np.asarray(o["goal_delta"], dtype=np.float64).tolist())  # ground frame
        ranges = np.asarray(o["lidar"], dtype=np.float64)
        # the returns in the ground frame, relative to the vehicle (planar beams along body x, y)
        (a, b, _), (c, d, _), (e, f, _) = rows
        hx, hy = ranges * (a * self.beam_x + b * self.beam_y), ranges * (c * self.beam_x + d * self.beam_y)
        hz = pos[2] + ranges * (e * self.beam_x + f * self.beam_y)
        keep = (ranges < self.max_range - 1e-6) & (hz > self.ground)
        hx, hy = hx[keep][None, :], hy[keep][None, :]
        distance = math.hypot(gx, gy)
        length = min(self.look, distance)
        along = hx * self.cand_x + hy * self.cand_y
        side = np.abs(hx * self.cand_y - hy * self.cand_x)
        blocked = ((along > 0.0) & (along < length + self.clearance) & (side < self.clearance)).any(axis=1)
        vz = self.k_z * gz
        if blocked.all():
            if hx.size == 0:
                return self.pilot(attitude, (0.0, 0.0, vz), heading=0.0)
            near = int(np.argmin(hx[0] * hx[0] + hy[0] * hy[0]))
            size = math.hypot(float(hx[0, near]), float(hy[0, near]))
            return self.pilot(
                attitude, (-0.5 * float(hx[0, near]) / size, -0.5 * float(hy[0, near]) / size, vz), heading=0.0
            )
        to_goal = (gx / distance, gy / distance) if distance > 1e-9 else (1.0, 0.0)
        moving = math.hypot(v[0], v[1])
        keep_x, keep_y = (v[0] / moving, v[1] / moving) if moving > 1e-6 else (0.0, 0.0)
        score = (
            self.cand_x[:, 0] * to_goal[0]
            + self.cand_y[:, 0] * to_goal[1]
            + self.w_keep * (self.cand_x[:, 0] * keep_x + self.cand_y[:, 0] * keep_y)
        )
        score[blocked] = -np.inf
        best = int(np.argmax(score))
        speed = min(self.speed, max(distance, 0.3))
        return self.pilot(
            attitude, (speed * float(self.cand_x[best, 0]), speed * float(self.cand_y[best, 0]), vz), heading=0.0
        )


register_task(GoalTask, oracles=(QuadXForestNavigator,))
