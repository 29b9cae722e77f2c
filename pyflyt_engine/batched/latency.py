"""Latency on the batched backend: per-env action and observation delays in physics steps.

The PyBullet engine's latency (docs/engine.md, "Latency"; ``Vehicle.set_latency``) delays
the agent's setpoint on its way to the flight controller and shows the agent the vehicle
as it was.  This module gives a :class:`~pyflyt_engine.batched.env.BatchedUAVEnv` (and the
multi-agent worlds of :class:`~pyflyt_engine.batched.swarm.BatchedSwarmEnv`, a row per
agent, the agents of a world sharing its delays) the same
two delays with the same semantics, each env with its own (the env's fixed
``latency``, or this episode's draw of a ``randomize`` entry ``action_delay`` /
``observation_delay``), kept in two ring buffers per env:

* **Action delay** ``n_a``: the action of agent step ``t`` (counted since the env's reset)
  is given at physics step ``t P`` (``P`` physics steps per agent step) and is released
  at ``t P + n_a``; the flight controller reads its setpoint only at its ticks, so the tick
  at physics step ``j`` flies the latest action released by then, that of agent step
  ``floor((j - n_a) / P)``, and before the first one arrives (``j < n_a``) the setpoint of
  the reset, zeros -- what ``Vehicle._deliver_setpoints`` delivers from its queue.  The
  ring keeps the last ``ceil(max n_a / P) + 1`` actions.
* **Observation delay** ``n_o``: the observation after ``k`` physics steps shows the state
  and the auxiliary state (motor throttles, flap deflections, the battery's charge) at the start of physics
  step ``k - n_o`` -- the spawn's while ``k < n_o`` -- as ``Vehicle.delayed_observation``
  does; the previous action in it is the agent's own, and the waypoint deltas are the
  current targets seen from the delayed pose (``WaypointsTask.observe`` on the delayed
  state).  Since every observation is taken at an agent step's end, only one physics step
  per agent step is ever shown: the one at offset ``r = (-n_o) mod P`` into it.  The ring
  keeps that snapshot of the last ``ceil(max n_o / P)`` agent steps.  Rewards, episode ends
  and the task's progress use the true state, as in the PyBullet engine.

One agent step runs as a few calls of the env's physics (:meth:`BatchedUAVEnv.physics`),
split where any env's setpoint changes between two ticks and where a snapshot is due; the
laws and their order of operations are the env's own, so a split changes no number (an
observation delay alone flies bit for bit as no delay).  Contacts are sampled where the
PyBullet engine samples them (the end of each control period and of the agent step): a
call that ends elsewhere samples once more at its end, and its sample is dropped (the
splits put every such call inside one control period, where it has no other sample).

Randomised delays are drawn per episode and per env from that env's own generator, with
the ``randomize`` section's other entries and in its order, before its spawn
(:class:`~pyflyt_engine.batched.randomization.BatchedRandomizer`; the PyBullet engine's
randomiser also draws before the spawn), each rounded by :func:`~pyflyt_engine.envs.randomization.delay_steps`
(the rule of the fixed delays); a drawn delay replaces that delay of the fixed ``latency``
for the episode, the other keeps its fixed value.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np

from pyflyt_engine.envs.randomization import DELAYS, delay_steps

if TYPE_CHECKING:
    from pyflyt_engine.batched.env import BatchedUAVEnv
    from pyflyt_engine.batched.swarm import BatchedSwarmEnv
    from pyflyt_engine.envs.config import EnvConfig

    #: an env with delays: the single-agent envs, or the multi-agent worlds (a row per agent)
    Delayed: TypeAlias = BatchedUAVEnv | BatchedSwarmEnv


def declares_latency(config: EnvConfig) -> bool:
    """Whether ``config`` asks for a delay: a ``latency`` section or a randomised delay."""
    return config.latency is not None or any(name in DELAYS for name in (config.randomize or {}))


class BatchedLatency:
    """The action and observation delays of ``num_envs`` batched envs (module docstring).

    Args:
        config: the env config (its ``latency`` and its ``randomize`` delay entries).
        num_envs: how many envs.
        per_agent, per_control: physics steps per agent step and per control tick.
        action_size: values per action.
        motors, surfaces: the airframe's motors and lifting surfaces (the snapshot's aux).
        battery: whether it has a battery (its state of charge closes the snapshot's aux).

    Attributes (one row per env; what checkpoints carry):
        steps: (N, 2) this episode's (action, observation) delays [physics steps].
        action_history: (N, La, A) the actions of the last La agent steps, by agent step mod La.
        observed_history: (N, Lo, S) per agent step mod Lo, the state shown from it
            (position, quaternion, velocity, angular velocity, throttles, flap deflections, the
            battery's state of charge).
    """

    def __init__(
        self,
        config: EnvConfig,
        num_envs: int,
        per_agent: int,
        per_control: int,
        action_size: int,
        motors: int,
        surfaces: int,
        battery: bool = False,
    ) -> None:
        hz = config.physics_hz
        self.fixed = config.latency.steps(hz) if config.latency is not None else (0, 0)
        #: the randomised delays, in the randomize section's order (name -> Distribution)
        self.draws = {name: dist for name, dist in (config.randomize or {}).items() if name in DELAYS}
        self.physics_hz = hz
        self.per_agent, self.per_control = int(per_agent), int(per_control)
        largest = [
            max(fixed, delay_steps(self.draws[name].high, hz)) if name in self.draws else fixed  # type: ignore[arg-type]
            for name, fixed in zip(DELAYS, self.fixed)
        ]
        P = self.per_agent
        n = int(num_envs)
        self.steps = np.tile(np.array(self.fixed, dtype=np.int64), (n, 1))
        self.action_history = np.zeros((n, -(-largest[0] // P) + 1, action_size))
        self.motors, self.surfaces = int(motors), int(surfaces)
        self.battery = bool(battery)
        size = 13 + self.motors + self.surfaces + int(self.battery)
        self.observed_history = np.zeros((n, max(-(-largest[1] // P), 1) if largest[1] else 0, size))
        #: whether any episode can have an observation delay
        self.observes = largest[1] > 0
        self._rows = np.arange(n)
        self._schedule: tuple | None = None
        self._scheduled_for: np.ndarray | None = None

    # ------------------------------------------------------------------ episodes

    def draw(self, i: int, values: dict[str, float]) -> None:
        """Env ``i``'s delays for its next episode: the randomised ones from this episode's
        draws ``values`` [s] (:meth:`~pyflyt_engine.batched.randomization.BatchedRandomizer.draw`,
        which draws every entry in the section's order), the others fixed."""
        if not self.draws:
            return
        self.steps[i] = [
            delay_steps(values[name], self.physics_hz) if name in values else fixed
            for name, fixed in zip(DELAYS, self.fixed)
        ]

    def restart(self, env: Delayed, index: np.ndarray) -> None:
        """The envs ``index`` start an episode from their current state: nothing in flight
        (the reset's setpoint, zeros, until the first action arrives) and the spawn shown
        until ``n_o`` physics steps have passed."""
        self.action_history[index] = 0.0
        if self.observed_history.shape[1]:
            self.observed_history[index] = self._snapshot(env, index)[:, None, :]

    # ---------------------------------------------------------------------- step

    def advance(self, env: Delayed, actions: np.ndarray, factors: np.ndarray) -> None:
        """One agent step of every env: ``actions`` (clipped) join the queue, the physics
        runs in the schedule's pieces with each tick's released setpoint, and the snapshot
        each env will show is kept."""
        t = env.steps  # agent steps since each env's reset, this one not yet counted
        La = self.action_history.shape[1]
        self.action_history[self._rows, t % La] = actions
        flags = env.contact_flags  # the contact samples the physics writes (the worlds: ground, agent)
        hits = [np.zeros(env.num_envs, dtype=bool) for _ in flags]
        setpoints = actions
        for start, stop, lag, sampled, record in self._pieces():
            if record is not None:
                self._record(env, record, t[record])
            if lag is not None:  # a tick in this piece: the latest action released by then
                given = t - lag
                setpoints = self.action_history[self._rows, given % La]
                setpoints[given < 0] = 0.0
            piece = factors if (start, stop) == (0, self.per_agent) else np.ascontiguousarray(factors[:, start:stop])
            env.physics(setpoints, piece, start, stop - start)
            if sampled:
                for hit, flag in zip(hits, flags):
                    hit |= flag
        for hit, flag in zip(hits, flags):
            flag[:] = hit

    def observed(self, env: Delayed) -> dict[str, np.ndarray]:
        """What every env shows after its last step: the read-outs (``ang_vel_body``,
        ``ang_pos``, ``lin_vel_body``, ``quaternion``), ``pos``, ``throttle``, ``deflection``
        and ``battery`` (its state of charge) of the state ``n_o`` physics steps ago (now, for
        ``n_o = 0``)."""
        from pyflyt_engine.batched import kernels

        n = env.num_envs
        delay = self.steps[:, 1]
        Lo = self.observed_history.shape[1]
        shown = self.observed_history[self._rows, (env.steps + (-delay // self.per_agent)) % Lo]
        now = delay == 0
        if now.any():
            shown[now] = self._snapshot(env, np.nonzero(now)[0])
        nm = self.motors
        pos, quat, vel, angvel = shown[:, 0:3], shown[:, 3:7], shown[:, 7:10], shown[:, 10:13]
        out = {
            name: np.empty((n, k))
            for name, k in (("ang_vel_body", 3), ("ang_pos", 3), ("lin_vel_body", 3), ("quaternion", 4))
        }
        kernels.read_out(
            np.ascontiguousarray(pos),
            np.ascontiguousarray(quat),
            np.ascontiguousarray(vel),
            np.ascontiguousarray(angvel),
            out["ang_vel_body"],
            out["ang_pos"],
            out["lin_vel_body"],
            out["quaternion"],
        )
        out["pos"] = np.ascontiguousarray(pos)
        out["vel"], out["angvel"] = vel, angvel  # the ground-frame motion (a multi-agent task's states)
        out["throttle"] = shown[:, 13 : 13 + nm]
        ns = self.surfaces
        out["deflection"] = shown[:, 13 + nm : 13 + nm + ns]
        out["battery"] = shown[:, 13 + nm + ns :]
        return out

    # ------------------------------------------------------------------ internals

    def _snapshot(self, env: Delayed, index: np.ndarray) -> np.ndarray:
        """The rows ``index`` of the state an observation shows, as one array (N, S)."""
        return np.concatenate(
            [
                env.pos[index],
                env.quat[index],
                env.vel[index],
                env.angvel[index],
                env.throttle[index],
                env.deflection[index],
                env.battery[index][:, :1],
            ],
            axis=1,
        )

    def _record(self, env: Delayed, index: np.ndarray, t: np.ndarray) -> None:
        self.observed_history[index, t % self.observed_history.shape[1]] = self._snapshot(env, index)

    def _pieces(self) -> tuple:
        """The agent step's pieces ``(start, stop, lag, sampled, record)``, from the envs'
        delays (rebuilt when they change): physics offsets ``[start, stop)``; per env, how
        many agent steps back the action its ticks in the piece fly was given (None: no
        tick in it); whether the piece's contact samples count; the envs whose snapshot is
        taken at ``start`` (None: none)."""
        if self._scheduled_for is not None and np.array_equal(self._scheduled_for, self.steps):
            return self._schedule  # type: ignore[return-value]
        P, C = self.per_agent, self.per_control
        action, observation = self.steps[:, 0], self.steps[:, 1]
        ticks = np.arange(0, P, C)
        # the tick at offset o of agent step t flies the action of agent step t + floor((o - n_a) / P)
        lag = -np.floor_divide(ticks[None, :] - action[:, None], P)  # (N, ticks)
        bounds = {0, P}
        changes = np.any(lag[:, 1:] != lag[:, :-1], axis=0)
        bounds.update(int(o) for o in ticks[1:][changes])
        shown = np.where(observation > 0, (-observation) % P, -1)  # the offset each env's snapshot is taken at
        for r in np.unique(shown[shown > 0]).tolist():
            bounds.update((r, r // C * C))  # r // C * C: the piece ending at r lies inside one control period
        edges = sorted(bounds)
        pieces = []
        for start, stop in zip(edges[:-1], edges[1:]):
            first = -(-start // C) * C  # the piece's first tick, if it has one
            column = lag[:, first // C].copy() if first < stop else None
            record = np.nonzero(shown == start)[0]
            pieces.append((start, stop, column, stop % C == 0 or stop == P, record if record.size else None))
        self._schedule = tuple(pieces)
        self._scheduled_for = self.steps.copy()
        return self._schedule

    def state_arrays(self) -> dict[str, Any]:
        """The arrays a checkpoint carries, by the env attribute names that alias them."""
        return {
            "latency_steps": self.steps,
            "action_history": self.action_history,
            "observed_history": self.observed_history,
        }
