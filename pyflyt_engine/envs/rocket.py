"""The Rocket environments: the paper's ``PyFlyt/Rocket-Landing-v0`` and its velocity-mode variant.

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/rocket_landing.yaml``) and the landing task
(:mod:`pyflyt_engine.envs.tasks.landing`); its docstring is the environment's manual.
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class RocketLandingEnv(UAVEnv):
    """``PyFlyt/Rocket-Landing-v0``: land the paper's Rocket upright on a pad, from 450 m with 1 % fuel.

    Paper, "Provided Environments": land the Rocket safely on a 4 m diameter pad from a
    drop height of 450 m; success is touching the pad slower than 1 m/s and coming to an
    upright halt; the Rocket starts with 1 % of its fuel.  Config:
    ``conf/env/rocket_landing.yaml``.

    **Vehicle**: ``rocket`` (``conf/uav/rocket.yaml``: 1:10 Falcon 9 v1.2 first stage,
    4.12 m, 138 kg dry; one reignitable booster 2 967-7 607 N, 1.451 kg/s at full
    throttle, on a +-5 deg two-axis gimbal; four 0.5 x 0.5 m grid fins, +-45 deg; four
    landing legs, feet on a 0.85 m radius), flown on its raw channels (flight mode
    ``channels``).  The booster's minimum thrust exceeds the weight: the Rocket cannot
    hover, and with 1 % fuel (4.1 kg) it has 2.8 s of full-throttle burn.  Physics 240
    Hz, one agent step = 1/30 s.

    **Action space** ``Box(7,)``, float64, clipped to its bounds (the paper's 7 values):

    ====  ============  ========  ====================================================
    idx   name          bounds    meaning
    ====  ============  ========  ====================================================
    0     fin_x         [-1, 1]   grid fins at +-x: positive moment about body x (in
                                  descent, air from below); x 45 deg, lag 0.05 s
    1     fin_y         [-1, 1]   grid fins at +-y: positive moment about body y
    2     fin_roll      [-1, 1]   all four fins: positive moment about the long axis
    3     ignition      [0, 1]    > 0.5 lights the booster (reignitable: <= 0.5 puts it
                                  out); a lit booster burns fuel until the tank is empty
    4     throttle      [0, 1]    lit thrust from 2 967 N (0) to 7 607 N (1), lag 0.01 s
    5     gimbal_a      [-1, 1]   nozzle rotation about body x, x 5 deg, lag 0.01 s
    6     gimbal_b      [-1, 1]   nozzle rotation about body y, x 5 deg
    ====  ============  ========  ====================================================

    Body frame: z along the rocket from the engine up, x and y across it (fins at +-x,
    +-y).

    **Observation space** ``Box(30,)`` (quaternion) or ``Box(29,)`` (Euler), float64:

    ==========  ====  ===============================================  ===============
    slice       size  meaning                                          frame / unit
    ==========  ====  ===============================================  ===============
    0:3         3     angular velocity (p, q, r)                       body, rad/s
    3:7 | 3:6   4|3   attitude: quaternion (x, y, z, w) or Euler       ground
                      (roll, pitch, yaw)                               rad
    next        3     linear velocity (u, v, w)                        body, m/s
    next        3     position (x, y, z); the pad's top face centre    ground ENU, m
                      is at (0, 0, 0.1)
    next        7     previous action (as the action space)            -
    next        4     fin deflections / 45 deg (aux): fins at +x, -x,  [-1, 1]
                      +y, -y
    next        3     booster (aux): fuel as a fraction of a FULL      [0, 1], [0, 1],
                      tank (0.01 at the start), duty cycle             0/1
                      (thrust / 7 607 N), ignited
    next        2     gimbal angles a, b / 5 deg (aux)                 [-1, 1]
    last        1     pad contact: 1 if the Rocket touched the pad     0/1
                      during the last step
    ==========  ====  ===============================================  ===============

    **Reward** (dense, preset ``rocket_landing_dense``), the paper's::

        r = r_d + r_v + I_pad r_pad - 100 I_ground
        r_d = -0.2 d_pad,   r_v = -v / d_pad^2,   r_pad = -20 if fatal, +100 if safe

    d_pad: distance [m] from the centre of mass to the centre of the pad's top face
    (about 1.72 m when standing on the pad, 450 m at the start); v: speed of the centre
    of mass [m/s]; I_pad r_pad is paid once, on the step the landing is decided (see
    below); I_ground: the Rocket touched the ground during the step.  Terms
    (``info["reward_terms"]``): ``pad_distance`` (r_d), ``pad_speed`` (r_v),
    ``safe_landing`` (+100), ``fatal_landing`` (-20), ``ground_contact`` (-100), and,
    not in the paper (which has no flight dome), ``out_of_bounds`` (-100 for leaving
    the dome).  Note: as printed, r_d costs up to -90 per step at altitude, far more
    than any terminal penalty, so ending an episode early (e.g. leaving the dome) can
    pay better than a long descent; the sparse preset has no such incentive.

    Sparse (``sparse_reward=True``, preset ``rocket_landing_sparse``; the paper gives no
    sparse reward): the outcome terms alone, +100 safe landing, -20 fatal landing, -100
    ground contact, -100 dome exit, 0 on every other step.

    Braking envelope (``reward="rocket_landing_envelope"``, not the paper's): the outcome
    terms, -0.01 d_pad per step, and -1 per m/s of speed above the braking envelope
    ``0.5 + sqrt(2 * 30 * max(d_pad - 1.82, 0))`` (the fastest approach a 30 m/s^2 burn
    still stops at the pad); a dome exit costs -100 and the pad pull for the steps left.
    Under the paper's dense reward a scripted safe landing returns less than a free fall
    from the same start (``experiments/results/rocket_landing_scripted.md``); under this
    one it returns more.

    **Landing outcome** (:mod:`pyflyt_engine.envs.tasks.landing`), evaluated every step:

    * *Touchdown*: the first step touching the pad after a step off it.  Touchdown
      speed = the larger of the speeds at the start and the end of that step (measured
      at the agent rate: in free fall the impact can be up to g/30 = 0.33 m/s faster
      than the start-of-step speed).  At or above ``max_touchdown_speed`` = 1 m/s:
      **fatal landing**.
    * Tilt (body z from vertical) above ``tip_over_angle_deg`` = 30 deg while touching
      the pad: **fatal landing** (tipped over; the legs' static limit is 19-27 deg).
    * *Halt*: touching the pad with speed < 0.1 m/s, angular speed < 0.1 rad/s and tilt
      < 10 deg on 15 consecutive steps (``halt_duration`` = 0.5 s) completes a **safe
      landing** (``info["success"] = True``).  A lit booster (minimum thrust above the
      weight) lifts the Rocket off, so it must be put out.  Leaving the pad restarts the
      count; the next contact is a new touchdown.
    * Any contact with the ground (off the pad) is a failure.

    **Starting state** (seeded): at (0, 0, 450) m + U(-20, 20) m in x and y (the pad is
    at the origin), attitude U(-0.3, 0.3) rad per Euler angle, velocity U(-5, 5) m/s per
    ground axis, angular velocity U(-0.5, 0.5) rad/s per body axis, booster out with
    1 % fuel (4.1 kg), fins and gimbal neutral.  (The reference PyFlyt meant to apply
    this velocity perturbation but never did, through a misspelt option key.)

    **Episode end**: terminated on a safe landing (``info["env_complete"]`` and
    ``info["success"]``), a fatal landing, ground contact, or leaving the flight dome (a
    sphere of ``flight_dome_size`` = 500 m about the pad: ``info["out_of_bounds"]``);
    truncated after ``max_duration_seconds`` = 30 s (900 steps; free fall from 450 m
    takes ~10 s).  ``info`` also has ``pad_contact``, ``ground_contact``,
    ``safe_landing``, ``fatal_landing`` (bools, this step), ``touchdown_speed`` [m/s]
    (-1 before the first touchdown) and ``pad_distance`` [m].  ``info["collision"]``
    is any contact, the pad included.

    **Arguments** (``gymnasium.make(id, **kwargs)``): ``sparse_reward`` (bool),
    ``reward``, ``angle_representation`` ("quaternion" | "euler"), ``agent_hz`` (30),
    ``physics_hz`` (240), ``control_hz`` (120), ``max_duration_seconds`` (30.0),
    ``flight_dome_size`` (500.0), ``start_position`` ((0, 0, 450) m),
    ``start_position_noise`` (20.0 m, x and y only), ``start_height_noise`` (0.0 m),
    ``start_orientation`` ((0, 0, 0) rad), ``start_orientation_noise`` (0.3 rad),
    ``start_lin_vel`` ((0, 0, 0) m/s, body frame), ``start_velocity_noise`` (5.0 m/s per
    ground axis), ``start_ang_vel_noise`` (0.5 rad/s), ``initial_fuel`` (0.01 of a full
    tank), ``pad_radius`` (2.0 m), ``pad_height`` (0.1 m), ``max_touchdown_speed``
    (1.0 m/s), ``tip_over_angle_deg`` (30), ``upright_angle_deg`` (10), ``halt_speed``
    (0.1 m/s), ``halt_angular_speed`` (0.1 rad/s), ``halt_duration`` (0.5 s), ``uav``
    ("rocket"), ``drag`` (True), ``wind`` ("calm": still air; a preset of conf/wind such as "dryden_light", a path or a mapping, docs/atmosphere.md), ``ground_effect`` and ``downwash`` (False), ``randomize`` ({}: none; per-episode draws declared in config, reported in ``info["randomization"]`` at reset), ``render_mode`` (None | "rgb_array" | "human").

    **Version history**: v0 — this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: 5 % fuel, spawn 400-450 m high with an extra -100 m/s
    vertical velocity and no applied random velocity, agent 40 Hz, a different shaped
    reward, success at < 0.02 m/s and < 0.1 rad tilt on the pad, fatal above 1 m/s or
    0.35 rad/s at contact).
    """

    config_name: ClassVar[str | None] = "rocket_landing"


class RocketLandingVelocityEnv(RocketLandingEnv):
    """``PyFlyt/Rocket-Landing-Velocity-v0``: Rocket-Landing flown through the rocket autopilot's ``velocity`` mode.

    The task, start states, landing outcome, episode end and rewards (dense, sparse, and
    the ``rocket_landing_envelope`` preset) are those of ``PyFlyt/Rocket-Landing-v0``
    (:class:`RocketLandingEnv`).  Only the action differs: the agent commands a ground
    velocity and an ignition permission, which the vehicle's rocket autopilot
    (:mod:`pyflyt_engine.control.rocket`, flight mode ``velocity``) holds by thrust vectoring
    and the grid fins.  Config: ``conf/env/rocket_landing_velocity.yaml``.

    **Action space** ``Box(4,)``, float64, clipped to its bounds:

    ====  ==========  ============  ==================================================
    idx   name        bounds        meaning
    ====  ==========  ============  ==================================================
    0     vx          [-10, 10]     ground-frame velocity setpoint, east [m/s]
    1     vy          [-10, 10]     north [m/s]
    2     vz          [-100, 10]    up [m/s]
    3     ignition    [0, 1]        > 0.5 lets the autopilot light the booster: it is lit
                                    while the velocity loop asks for at least half the
                                    minimum thrust (2 967 N); <= 0.5 keeps it out
    ====  ==========  ============  ==================================================

    The autopilot leans the long axis along the velocity loop's specific force (at most 20
    deg), steering it with the fins (in descent) and the gimbal (while lit), and sets the
    throttle for the asked vertical acceleration; the booster's minimum thrust exceeds the
    weight, so holding a slow descent is pulsing at the control rate (120 Hz).  To land,
    the booster must be out on the pad: ignition <= 0.5, or a velocity setpoint that asks
    for less than half the minimum thrust (e.g. vz <= 0 at rest).

    **Observation space** as ``PyFlyt/Rocket-Landing-v0``'s, with the previous action's 4
    entries in place of 7: ``Box(27,)`` (quaternion) or ``Box(26,)`` (Euler).  The aux
    state (fins, booster fuel, duty and ignition, gimbal) and the pad-contact flag follow.

    **Arguments**: as ``PyFlyt/Rocket-Landing-v0``.  The ``rocket_velocity_lander`` oracle
    (:mod:`pyflyt_engine.envs.oracles`) lands 49 of the first 50 seeded starts
    (``experiments/results/rocket_landing_scripted.md``).

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "rocket_landing_velocity"


class RocketLandingDescentEnv(RocketLandingEnv):
    """``PyFlyt/Rocket-Landing-Descent-v0``: Rocket-Landing flown through the rocket autopilot's ``descent`` mode.

    The task, start states, landing outcome, episode end and rewards (dense, sparse, and
    the ``rocket_landing_envelope`` preset) are those of ``PyFlyt/Rocket-Landing-v0``
    (:class:`RocketLandingEnv`).  Only the action differs: the agent commands a ground
    velocity sideways, a descent speed relative to the autopilot's braking envelope and an
    ignition permission; the vehicle's rocket autopilot (:mod:`pyflyt_engine.control.rocket`,
    flight mode ``descent``) holds them by thrust vectoring and the grid fins, and fires
    short booster pulses to change the horizontal velocity while the Rocket falls.
    Config: ``conf/env/rocket_landing_descent.yaml``.

    **Action space** ``Box(4,)``, float64, clipped to its bounds:

    ====  ==========  ============  ==================================================
    idx   name        bounds        meaning
    ====  ==========  ============  ==================================================
    0     vx          [-10, 10]     ground-frame velocity setpoint, east [m/s]
    1     vy          [-10, 10]     north [m/s]
    2     descent     [0, 1]        the braking envelope the vertical setpoint follows:
                                    ``-max(0.4, sqrt(2 descent a_max (h - 1)))`` m/s
                                    (``h`` the feet's height above the ground,
                                    ``a_max`` the booster's full-thrust deceleration
                                    with the fuel left, 43.7 m/s^2 with 1 % fuel); any
                                    value in (0, 1] comes down to a 0.4 m/s touchdown
                                    if the fuel lasts, 2/3 brakes at 29 m/s^2
    3     ignition    [0, 1]        > 0.5 lets the autopilot light the booster (for the
                                    vertical loop, or for an aim pulse); <= 0.5 keeps
                                    it out
    ====  ==========  ============  ==================================================

    What is left to the agent is the guidance: where to steer (the pad is 2 m in radius,
    the drop 0-28 m off its axis and drifting up to 7 m/s), how fast to come down (fuel:
    4.1 kg, 2.8 s at full thrust) and when to put the booster out (its minimum thrust
    exceeds the weight: a safe landing needs it out on the pad).  A constant action does
    not land: zero sideways velocity leaves the drift's miss, and the ignition must be
    permitted to brake and then withheld on the pad.

    **Observation space** as ``PyFlyt/Rocket-Landing-v0``'s, with the previous action's 4
    entries in place of 7: ``Box(27,)`` (quaternion) or ``Box(26,)`` (Euler).

    **Arguments**: as ``PyFlyt/Rocket-Landing-v0``.  The ``rocket_descent_lander`` oracle
    (:mod:`pyflyt_engine.envs.oracles`) lands 49 of the first 50 seeded drops
    (``experiments/results/rocket_landing_scripted.md``).  ``pyflyt train
    env=rocket_landing_descent`` imitates it by DAgger, then runs PPO; the imitated policy
    lands 17-19 of 20 probe drops (``experiments/results/learn_rocket_landing.md``).

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "rocket_landing_descent"
