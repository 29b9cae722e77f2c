"""``PyFlyt/QuadX-Gates-v0``: the QuadX racing through a course of gates.

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/quadx_gates.yaml``; the task is :mod:`pyflyt_engine.envs.tasks.gates`);
its docstring is the environment's manual.
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class QuadXGatesEnv(UAVEnv):
    """``PyFlyt/QuadX-Gates-v0``: fly a Crazyflie-class QuadX through 5 gates in order, seeing its camera.

    Config: ``conf/env/quadx_gates.yaml``.  Gates: five payloads fixed in the world (the
    reference's race gate: four 0.05 m square bars around a 0.4 m square opening), placed
    at every reset along a random course drawn from the env's seed: each 1 to 3 m beyond
    the previous one (the first beyond the start), the heading turning by up to 1 rad and
    climbing or diving at up to 0.3 rad per gate, centres 1 to 3 m high; each gate faces
    along the course.

    **Vehicle**: ``quadx_cf2x`` in ``rates_thrust`` (the reference's flight mode 0), agent
    40 Hz (the reference's), 10 s (400 steps), flight dome 20 m.  **Action** ``Box(4,)``:
    p, q, r [rad/s] in [-pi, pi], thrust in [0, 1] (0.125 hovers).

    **Observation space** ``Dict``:

    * ``attitude``: ``Box(21,)`` / ``Box(20,)`` float64, as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv`.
    * ``image``: ``Box(0, 255, (64, 64, 3), uint8)``: the onboard camera, RGB, channels
      last (H, W, C), row 0 the top of the image, column 0 its left.  The camera sits 2 cm
      ahead of the centre of mass, looks forward tilted 15 deg up, 90 deg vertical field of
      view, clips at 0.05 and 50 m; rendered at every agent step (PyBullet's CPU
      renderer).  ``camera_observation`` in the config sets the resolution, ``channels``
      (``rgb`` | ``rgba``) and ``channel_first`` ((C, H, W)).
    * ``target_deltas``: ``Sequence(Box(3,), stack=True)``: ``(n, 3)`` float64, body-frame
      vectors [m] from the vehicle to the centre of every gate not yet passed, next first.

    With the task option ``observation`` (default ``deltas``: the above), a fixed-size
    ``gate`` entry replaces ``target_deltas``: ``corners`` gives ``Box(12,)``, the
    body-frame vectors [m] to the 4 corners of the next gate's opening, (x, y, z) each,
    seen along the gate's +x: top left, top right, bottom right, bottom left;
    ``relative_pose`` gives ``Box(7,)``, the next gate's centre in the body frame [m] then
    the quaternion (x, y, z, w) of its attitude relative to the body, R_body^T R_gate.
    Both are zeros once every gate is passed.

    Stable-Baselines3: ``pyflyt train`` flattens ``attitude`` and ``target_deltas`` (next 2)
    into one Box and keeps ``image``, training a ``MultiInputPolicy`` (CNN on the image);
    with ``corners`` or ``relative_pose`` the Dict passes SB3's ``check_env`` as it is.

    **Passing a gate**: the centre of mass crosses the gate's plane in its forward direction
    within the opening during an agent step (segment test): +100, next gate.

    **Reward**: sparse (preset ``quadx_gates_sparse``, the reference's only reward): -0.1
    per step, +100 per gate, -100 on a crash.  Dense (``quadx_gates_dense``, ours): the
    sparse terms plus 3 x the progress towards the next gate's centre over the agent step
    (the decrease of delta [m]: paid approaching, charged receding; the racing reward of
    Song et al., IROS 2021): a loop away and back nets nothing.  Terms:
    ``crash``, ``gate_bonus``, ``time_penalty``, ``progress``.

    **Episode end**: terminated on a crash (any contact: the ground or a gate; leaving the
    dome) or when the last gate is passed (``env_complete``, ``success``); truncated after
    10 s.  ``info["num_targets_reached"]`` counts the gates passed.

    **Arguments**: as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv` plus the task's
    (``course`` random | fixed, ``opening``, ``clearance``, ``min_gate_distance``,
    ``max_gate_distance``, ``max_turn``, ``max_climb``, ``min_gate_height``,
    ``max_gate_height``, ``observation``) and ``camera_observation``.

    **Differences from the reference** (PyFlyt 0.29.0, whose env cannot load its gate
    model): a gate counts when flown through (the reference: within 0.21 m of its centre);
    gates face along the course (the reference's chain runs along the gates' planes);
    the image is RGB (H, W, C) (the reference: RGBA (C, H, W), set ``channels: rgba`` and
    ``channel_first: true`` for that layout); ours also has a dense preset; the episode
    ends at the flight dome rather than at twice the gate spacing from the next gate.

    **Learning from state**: ``pyflyt train env=quadx_gates_state`` (the next gate's corners
    instead of the image) imitates the ``quadx_gate_racer`` oracle (DAgger) and then runs
    PPO; >= 3 gates in 95-100 % of probe episodes after ~4 CPU-minutes
    (``experiments/results/learn_gates.md``, ``docs/environments.md``).

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "quadx_gates"
