"""``PyFlyt/QuadX-Gates-v0``: the QuadX racing through a course of gates.

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/quadx_gates.yaml``; the task is :mod:`pyflyt_engine.envs.tasks.gates`);
``pyflyt envs PyFlyt/QuadX-Gates-v0`` prints its manual, generated from the config and spaces
(:mod:`pyflyt_engine.envs.manual`).
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class QuadXGatesEnv(UAVEnv):
    """``PyFlyt/QuadX-Gates-v0``: fly a Crazyflie-class QuadX through a course of gates in order, seeing its camera.

    Gates are payloads fixed in the world (the reference's race gate: four square bars
    around a square opening), placed at every reset along a random course drawn from the
    env's seed (spacing, turn, climb and height: the task options); each gate faces along
    the course.  A gate is passed when the centre of mass crosses its plane in its forward
    direction within the opening during an agent step (segment test); passing the last one
    ends the episode with success, and ``info["num_targets_reached"]`` counts them.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Gates-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: the image is the onboard camera's (``camera_observation``: mounted
    just ahead of the centre of mass, looking forward tilted up, rendered at every agent
    step by PyBullet's CPU renderer; row 0 the top of the image, column 0 its left).  The
    task option ``observation`` chooses what is seen of the course besides it: ``deltas``
    (every gate left), or a fixed-size ``gate`` entry, ``corners`` or ``relative_pose``
    (zeros once every gate is passed).  ``pyflyt train`` flattens ``attitude`` and
    ``target_deltas`` (next 2) into one Box and keeps ``image``, training a
    ``MultiInputPolicy`` (CNN on the image); with ``corners`` or ``relative_pose`` the Dict
    passes SB3's ``check_env`` as it is.  The sparse preset is the reference's only
    reward; the dense one (ours) adds the progress towards the next gate's centre over the
    agent step (paid approaching, charged receding; the racing reward of Song et al., IROS
    2021), so a loop away and back nets nothing.

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

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "quadx_gates"
