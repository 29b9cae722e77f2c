"""The task interface: what a task decides, and the hooks an environment calls.

A task owns the episode's *meaning*: where the vehicle starts, what it observes beyond
the shared attitude vector, the signals its rewards read, and when it is complete.  Apart
from :meth:`Task.setup` (scenery) it never talks to PyBullet: it sees
:class:`~pyflyt_engine.state.KinematicState` values and the environment's seeded RNG.  The environment (:class:`~pyflyt_engine.envs.env.UAVEnv`)
runs the loop, detects contacts and dome exits, ends the episode by the env config's
termination terms (:mod:`pyflyt_engine.envs.terminations`: a task says what they read --
:attr:`Task.crash_on_contact`, :attr:`TaskSignals.failed` and ``complete``) and evaluates
the reward preset.

Once, when the environment is built: ``vehicle_spec(spec)`` (the airframe variant the
task flies, before the world exists), then ``setup(world)`` (add scenery; the env
config's payloads are already built and in :attr:`Task.payloads`, read through
:class:`~pyflyt_engine.payloads.PayloadSet`).  Per episode
the environment calls, in order::

    spawn(rng) -> Spawn            # initial pose and body-frame velocities of the vehicle
    reset(state, rng)              # after the vehicle is placed: sample targets, ...
    observe(attitude, state)       # the first observation
    then per agent step:
    update(state) -> TaskSignals   # advance the task, report reward signals
    observe(attitude, state)
    info()                         # task entries for the step's info dict
    episode_measures()             # on the step that ends the episode: its success measures

Every hook has a do-nothing default; a task overrides what it needs.  A new task is a
module defining a :class:`Task` subclass with its :class:`TaskOptions` model (and its own
reward terms and oracles, if any), ending in ``register_task(MyTask)``
(:mod:`pyflyt_engine.envs.task_registry`), its import in :mod:`pyflyt_engine.envs.tasks`,
and an env YAML naming it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pydantic import BaseModel, ConfigDict, Field

from pyflyt_engine.envs.observe import FLAT, ObservationLayout, ObservationPart
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.state import KinematicState

if TYPE_CHECKING:
    from pyflyt_engine.payloads import PayloadSet
    from pyflyt_engine.spec import UAVSpec
    from pyflyt_engine.world import World

Vec3 = tuple[float, float, float]


class TaskOptions(BaseModel):
    """Options common to every task; each task subclasses this with its own fields."""

    # every float finite, also inside tuples (no .inf / .nan from YAML)
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)

    name: str = Field(description="task name (a key of pyflyt_engine.envs.tasks.TASKS)")
    start_position: Vec3 = Field((0.0, 0.0, 1.0), description="mean spawn position (x, y, z) [m], ground frame")
    start_position_noise: float = Field(
        0.1, ge=0, description="each spawn coordinate is offset by U(-noise, noise) [m]"
    )
    start_orientation: Vec3 = Field((0.0, 0.0, 0.0), description="mean spawn attitude (roll, pitch, yaw) [rad]")
    start_orientation_noise: float = Field(
        0.1, ge=0, description="each spawn Euler angle is offset by U(-noise, noise) [rad]"
    )
    start_lin_vel: Vec3 = Field(
        (0.0, 0.0, 0.0),
        description="spawn linear velocity (u, v, w) [m/s], BODY frame (e.g. [14, 0, 0]: a fixed-wing at cruise)",
    )


@dataclass(frozen=True)
class Spawn:
    """Initial state of the vehicle: pose, and velocities in the body frame (default rest)."""

    position: Vec3
    """(x, y, z) [m], ground frame."""
    orientation: Vec3
    """(roll, pitch, yaw) [rad]."""
    lin_vel: Vec3 = (0.0, 0.0, 0.0)
    """(u, v, w) [m/s], body frame."""
    ang_vel: Vec3 = (0.0, 0.0, 0.0)
    """(p, q, r) [rad/s], body frame."""


@dataclass(frozen=True, slots=True)
class TaskSignals:
    """Task quantities for one agent step (see :class:`~pyflyt_engine.envs.rewards.StepContext`)."""

    target_distance: float | None = None
    target_distance_rate: float | None = None
    waypoint_reached: bool = False
    #: the task is finished: terminate with success (unless the step also crashed)
    complete: bool = False
    #: the task declares failure (e.g. a fatal landing): terminate as a crash
    failed: bool = False
    extras: dict[str, float] = field(default_factory=dict)


def episode_options(
    name: str, allowed: frozenset[str], model: type[BaseModel], configured: BaseModel, changes: dict[str, Any]
) -> Any:
    """Task ``name``'s ``configured`` options with an episode's ``changes``, validated by
    ``model`` (``configured`` itself without changes).

    Raises:
        ValueError: an option not in ``allowed``, or a value ``model`` rejects (the message names it).
    """
    unknown = sorted(set(changes) - allowed)
    if unknown:
        names = ", ".join(sorted(allowed)) or "none"
        raise ValueError(
            f"task '{name}' cannot change {', '.join(unknown)} per episode (options an episode may set: {names})"
        )
    return model.model_validate({**configured.model_dump(), **changes}) if changes else configured


def termination(
    collision: bool, out_of_bounds: bool, failed: bool, complete: bool, crash_on_contact: bool
) -> tuple[bool, bool]:
    """``(crashed, terminated)`` of one agent's step under the default termination terms
    (``contact``, ``out_of_dome``, ``task_failure``, ``task_complete``;
    :mod:`pyflyt_engine.envs.terminations`) taken together: a crash is leaving the dome, a
    failure the task declares, or a contact when contacts are crashes; the episode
    terminates on a crash or when the task is complete (dm_control's ``get_termination`` is
    the model)."""
    crashed = out_of_bounds or failed or (collision and crash_on_contact)
    return crashed, crashed or complete


class Task:
    """Base task: spawns at ``start_position`` with uniform noise, observes the attitude.

    Class attributes:
        name: the registry key.
        Options: the pydantic model of the task's options (``task:`` in the env YAML).
        provides: names of the reward signals :meth:`update` fills in (checked against
            the reward preset's terms and conditions when the env is built).
        succeeds_at_time_limit: an episode that reaches the time limit without a crash
            counts as a success (survival tasks such as hover).
        crash_on_contact: any contact of the vehicle ends the episode as a crash (the
            ``contact`` termination term's default); a task where touching something is
            part of the job (landing on a pad) sets False and reports outcomes through
            :attr:`TaskSignals.failed` / ``complete``.
        episode_options: the options one episode may fly with other values than the
            configured ones, through ``env.reset(options={"task": {name: value}})`` (a
            training curriculum: ``curriculum:`` of ``pyflyt train``).  Only options the
            task reads afresh at every reset or step belong here: never one that shaped
            the world, the spaces or anything else built once.
        measures: the task's success measures (:mod:`pyflyt_engine.envs.tasks.measures`),
            whose values for an episode :meth:`episode_measures` gives: what ``pyflyt eval``
            and the training evaluations report beside the return (distance held, waypoints
            reached, landing outcome ...).
    """

    name: ClassVar[str] = "base"
    #: the registry's kind of task (:mod:`pyflyt_engine.envs.task_registry`): one vehicle
    task_kind: ClassVar[Literal["single", "multi"]] = "single"
    Options: ClassVar[type[TaskOptions]] = TaskOptions
    provides: ClassVar[frozenset[str]] = frozenset()
    succeeds_at_time_limit: ClassVar[bool] = False
    crash_on_contact: ClassVar[bool] = True
    episode_options: ClassVar[frozenset[str]] = frozenset()
    measures: ClassVar[tuple[Measure, ...]] = ()

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        self.options = options
        #: the options of the env config; :attr:`options` are the ones of the episode
        self.configured = options
        self._episode_changes: dict[str, Any] = {}
        self.flight_dome_size = float(flight_dome_size)
        self.agent_dt = 1.0 / float(agent_hz)
        #: the env config's payloads (:class:`~pyflyt_engine.payloads.PayloadSet`), set by the
        #: environment before :meth:`setup`; None when the config declares none
        self.payloads: PayloadSet | None = None

    def setup(self, world: World) -> None:
        """Once, after the world is built and before its first reset snapshot.

        The one hook that may change the world: add scenery (a landing pad, obstacles)
        with PyBullet and :meth:`World.add_body` so its contacts are tracked, and keep
        the ids to read contacts in :meth:`update`.  Bodies must not be added later:
        resets restore the state saved after this hook.
        """

    def vehicle_spec(self, spec: UAVSpec) -> UAVSpec:
        """The airframe as this task flies it, before the world is built (default: unchanged).

        A task that needs a variant of the shipped airframe returns a modified copy here,
        e.g. the landing task's booster starts with 1 % fuel.  Called once, so resets
        stay as fast as without it.
        """
        return spec

    def set_episode_options(self, changes: dict[str, Any] | None) -> None:
        """Fly the next episodes with ``changes`` to the configured options (None or ``{}``:
        as configured); called by the environment before :meth:`spawn`.

        Raises:
            ValueError: an option not in :attr:`episode_options`, or a value the options'
                model rejects (the message names it).
        """
        changes = dict(changes or {})
        if changes == self._episode_changes:
            return
        options = episode_options(self.name, self.episode_options, self.Options, self.configured, changes)
        self.check_options(options)
        self.options = options
        self._episode_changes = changes
        self.options_changed()

    def check_options(self, options: TaskOptions) -> None:
        """Reject options that contradict the env (raise ``ConfigError`` naming the fix);
        run on the configured options when the env is built and on every episode's."""

    def options_changed(self) -> None:
        """:attr:`options` now hold an episode's values: refresh what was derived from them."""

    def spawn(self, rng: np.random.Generator) -> Spawn:
        """Initial state: the mean pose plus uniform noise (draws 6 numbers from ``rng``),
        moving at ``start_lin_vel`` (body frame), not rotating."""
        o = self.options
        dp = rng.uniform(-o.start_position_noise, o.start_position_noise, 3) if o.start_position_noise else np.zeros(3)
        da = (
            rng.uniform(-o.start_orientation_noise, o.start_orientation_noise, 3)
            if o.start_orientation_noise
            else np.zeros(3)
        )
        position = tuple(float(v) for v in np.add(o.start_position, dp))
        orientation = tuple(float(v) for v in np.add(o.start_orientation, da))
        return Spawn(position, orientation, lin_vel=tuple(o.start_lin_vel))  # type: ignore[arg-type]

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        """Start an episode with the vehicle placed in ``state``."""

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        """The env's observation space, given the shared attitude Box."""
        return attitude

    def observe(self, attitude: np.ndarray, state: KinematicState) -> Any:
        """The observation, given the shared attitude vector."""
        return attitude

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        """What :meth:`observation_space` holds, given the attitude vector's parts: entry key
        -> its parts, in order (key :data:`~pyflyt_engine.envs.observe.FLAT`: one Box).  A task
        that changes :meth:`observation_space` declares the same change here (a test checks
        every shipped config; the env manuals are written from it)."""
        return {FLAT: attitude}

    def update(self, state: KinematicState) -> TaskSignals:
        """Advance one agent step with the vehicle now in ``state``."""
        return TaskSignals()

    def info(self) -> dict[str, Any]:
        """Task entries of the info dict."""
        return {}

    def episode_measures(self) -> dict[str, float]:
        """The episode's values of :attr:`measures` so far, ``{key: float}`` (NaN: does not
        apply to this episode); the environment reports them as ``info["measures"]`` on the
        step that ends the episode.  Computing them must not change the episode."""
        return {}

    def markers(self) -> np.ndarray:
        """Ground-frame points to draw when rendering, ``(n, 3)`` (none by default)."""
        return np.zeros((0, 3))

    def keep_clear(self) -> np.ndarray:
        """Ground-frame points generated obstacles keep clear of, ``(n, 3)``, besides the spawn
        point (called after :meth:`reset`; default: the :meth:`markers`, the goals)."""
        return self.markers()

    def marker_style(self) -> tuple[int, float]:
        """(most markers ever drawn at once, sphere radius [m]), for the renderer."""
        return len(self.markers()), 0.05
