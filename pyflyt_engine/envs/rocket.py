"""The Rocket environments: the paper's ``PyFlyt/Rocket-Landing-v0`` and its velocity-mode variant.

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/rocket_landing.yaml``) and the landing task
(:mod:`pyflyt_engine.envs.tasks.landing`); ``pyflyt envs <id>`` prints each one's manual,
generated from its config and spaces (:mod:`pyflyt_engine.envs.manual`).
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class RocketLandingEnv(UAVEnv):
    """``PyFlyt/Rocket-Landing-v0``: land the paper's Rocket upright on a pad, with little fuel.

    Paper, "Provided Environments": land the Rocket safely on the pad from a high drop;
    success is touching the pad slower than the touchdown limit and coming to an upright
    halt, with only a small fraction of a tank of fuel.  The Rocket is flown on its raw
    channels (flight mode ``channels``: fins, ignition, throttle, gimbal).

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/Rocket-Landing-v0`` (docs/environments.md, "Env manuals").

    **Vehicle** (``conf/uav/rocket.yaml``): a 1:10 Falcon 9 v1.2 first stage, 4.12 m,
    138 kg dry; one reignitable booster of 2 967-7 607 N (1.451 kg/s at full throttle) on
    a +-5 deg two-axis gimbal; four 0.5 x 0.5 m grid fins of +-45 deg; four landing legs,
    feet on a 0.85 m radius.  The booster's minimum thrust exceeds the weight: the Rocket
    cannot hover, and with 1 % fuel (4.1 kg) it has 2.8 s of full-throttle burn.  Body
    frame: z along the rocket from the engine up, x and y across it (fins at +-x, +-y).
    Ignition > 0.5 lights the booster (<= 0.5 puts it out); a lit booster burns fuel until
    the tank is empty.  The aux state is the fin deflections over their limit (fins at +x,
    -x, +y, -y), the booster's fuel as a fraction of a *full* tank, duty (thrust / maximum)
    and ignition, then the gimbal angles over their limit; the pad's top face centre is at
    (0, 0, pad_height).

    **Landing outcome** (:mod:`pyflyt_engine.envs.tasks.landing`), judged every step:
    the first step touching the pad after one off it is a *touchdown*, whose speed is the
    larger of the speeds at the step's start and end (in free fall the impact can be up to
    g/30 = 0.33 m/s faster than the start-of-step speed); at or above
    ``max_touchdown_speed`` it is a **fatal landing**, and so is a tilt above
    ``tip_over_angle_deg`` on the pad (the legs' static limit is 19-27 deg).  Staying on
    the pad slower than the halt limits (speed, angular speed, upright angle) for
    ``halt_duration`` completes a **safe landing**; a lit booster lifts the Rocket off, so
    it must be put out.  Leaving the pad restarts the count; any ground contact off the
    pad is a failure.  ``info`` has ``pad_contact``, ``ground_contact``, ``safe_landing``,
    ``fatal_landing`` (this step), ``touchdown_speed`` (-1 before the first touchdown) and
    ``pad_distance``; ``info["collision"]`` is any contact, the pad included.

    **Design notes**: the dense reward is the paper's, ``r = r_d + r_v + I_pad r_pad -
    100 I_ground`` with ``r_d`` proportional to d_pad (distance from the centre of mass to
    the pad's top-face centre, about 1.72 m standing on the pad) and ``r_v = -v / d_pad^2``;
    I_pad r_pad is paid once, on the step the landing is decided; leaving the dome is
    penalised too (the paper has no dome).  As printed, r_d costs up to -90 per step at
    altitude, far more than any terminal penalty, so ending an episode early can pay better
    than a long descent; the sparse preset (the outcome terms only; the paper gives no
    sparse reward) has no such incentive.  The braking-envelope preset
    (``reward="rocket_landing_envelope"``, not the paper's) charges speed above the fastest
    approach a 30 m/s^2 burn still stops at the pad: under the paper's dense reward a
    scripted safe landing returns less than a free fall from the same start
    (``experiments/results/rocket_landing_scripted.md``), under this one more.  The spawn
    velocity noise is applied (the reference PyFlyt meant to, but never did, through a
    misspelt option key).

    **Version history**: v0 -- this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: 5 % fuel, spawn 400-450 m high with an extra -100 m/s
    vertical velocity and no applied random velocity, agent 40 Hz, a different shaped
    reward, success at < 0.02 m/s and < 0.1 rad tilt on the pad, fatal above 1 m/s or
    0.35 rad/s at contact).
    """

    config_name: ClassVar[str | None] = "rocket_landing"


class RocketLandingVelocityEnv(RocketLandingEnv):
    """``PyFlyt/Rocket-Landing-Velocity-v0``: Rocket-Landing flown through the rocket autopilot's ``velocity`` mode.

    The task, start states, landing outcome, episode end and rewards are those of
    ``PyFlyt/Rocket-Landing-v0`` (:class:`RocketLandingEnv`); only the action differs: the
    agent commands a ground velocity and an ignition permission, which the vehicle's rocket
    autopilot (:mod:`pyflyt_engine.control.rocket`, flight mode ``velocity``) holds by
    thrust vectoring and the grid fins.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/Rocket-Landing-Velocity-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: ignition > 0.5 lets the autopilot light the booster, which is lit
    while the velocity loop asks for at least half the minimum thrust; <= 0.5 keeps it out.
    The autopilot leans the long axis along the velocity loop's specific force (at most 20
    deg), steering it with the fins (in descent) and the gimbal (while lit), and sets the
    throttle for the asked vertical acceleration; the booster's minimum thrust exceeds the
    weight, so holding a slow descent is pulsing at the control rate.  To land, the
    booster must be out on the pad: ignition <= 0.5, or a velocity setpoint that asks for
    less than half the minimum thrust (e.g. vz <= 0 at rest).  The
    ``rocket_velocity_lander`` oracle (:mod:`pyflyt_engine.envs.oracles`) lands 49 of the
    first 50 seeded starts (``experiments/results/rocket_landing_scripted.md``).

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "rocket_landing_velocity"


class RocketLandingDescentEnv(RocketLandingEnv):
    """``PyFlyt/Rocket-Landing-Descent-v0``: Rocket-Landing flown through the rocket autopilot's ``descent`` mode.

    The task, start states, landing outcome, episode end and rewards are those of
    ``PyFlyt/Rocket-Landing-v0`` (:class:`RocketLandingEnv`); only the action differs: the
    agent commands a ground velocity sideways, a descent speed relative to the autopilot's
    braking envelope and an ignition permission; the vehicle's rocket autopilot
    (:mod:`pyflyt_engine.control.rocket`, flight mode ``descent``) holds them by thrust
    vectoring and the grid fins, and fires short booster pulses to change the horizontal
    velocity while the Rocket falls.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/Rocket-Landing-Descent-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: ``descent`` in [0, 1] sets the braking envelope the vertical setpoint
    follows, ``-max(0.4, sqrt(2 descent a_max (h - 1)))`` m/s (``h`` the feet's height
    above the ground, ``a_max`` the booster's full-thrust deceleration with the fuel left,
    43.7 m/s^2 with 1 % fuel): any value in (0, 1] comes down to a 0.4 m/s touchdown if the
    fuel lasts, 2/3 brakes at 29 m/s^2.  Ignition > 0.5 lets the autopilot light the
    booster (for the vertical loop, or for an aim pulse).  What is left to the agent is
    the guidance: where to steer (the drop starts off the pad's axis and drifting), how
    fast to come down (fuel) and when to put the booster out (its minimum thrust exceeds
    the weight: a safe landing needs it out on the pad).  A constant action does not land:
    zero sideways velocity leaves the drift's miss, and the ignition must be permitted to
    brake and then withheld on the pad.  The ``rocket_descent_lander`` oracle
    (:mod:`pyflyt_engine.envs.oracles`) lands 49 of the first 50 seeded drops
    (``experiments/results/rocket_landing_scripted.md``); ``pyflyt train
    env=rocket_landing_descent`` imitates it by DAgger, then runs PPO, and the imitated
    policy lands 17-19 of 20 probe drops (``experiments/results/learn_rocket_landing.md``).

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "rocket_landing_descent"
