"""The batched multi-agent worlds: W worlds of A quadrotors each, downwash between the agents of a world.

:class:`BatchedSwarmEnv` flies MAQuadX-Hover (``conf/env/ma_quadx_hover.yaml``, task
``ma_hover``) and MAQuadX-Formation (``conf/env/ma_quadx_formation.yaml``, task
``ma_formation``: the engine's own task object per world, :class:`_WorldTasks`) for
``worlds`` independent worlds of ``A`` agents, every agent one slot of a
``gymnasium.vector.VectorEnv`` (slot ``k A + i`` is agent ``i`` of world ``k``, the layout of
:class:`pyflyt_cli.training.multi_agent.AgentSlotsVecEnv`), advanced by one compiled call
per agent step (:func:`advance_swarm`).  Each vehicle flies the batched multirotor laws of
:mod:`pyflyt_engine.batched.kernels` (rate loop, mixer, motors, body drag, the rigid body) in
any multirotor flight mode (:data:`SWARM_MODES`): ``rates_thrust`` and ``motors`` in the
kernel, and every cascade mode of :mod:`pyflyt_engine.batched.modes` as the single-agent
backend flies one (:meth:`BatchedSwarmEnv._advance_cascade`): at each control tick every
armed vehicle's controller runs (:func:`~pyflyt_engine.batched.modes.control_tick`, the same
compiled loops) from the state at the tick, then the control period's physics steps run in
mode ``motors`` with the commands it gave.  That is the PyBullet engine's order with
downwash (:meth:`pyflyt_engine.world.World.step`: on a tick every vehicle is read and runs
its controller before any vehicle steps its motors, and the controller reads the vehicle's
state, not its air).  The velocity loop's integrals (``vel_integral``) are cleared with the
rate loop's at a world's restart and carried by a checkpoint; what the agents of one world
do to each other:

* **downwash** (``env.downwash: true``): the engine's law,
  :func:`pyflyt_engine.atmosphere.rotors.downwash_velocity` summed over the rotorcraft above
  as :meth:`~pyflyt_engine.atmosphere.rotors.RotorInteractions.downwash_at` sums it, compiled
  here in the same order of operations (:func:`downwash_velocity`, :func:`downwash_at`; the
  off-axis distance by :func:`py_hypot`, CPython's own ``math.hypot`` algorithm, since the C
  library's ``hypot`` rounds differently in ~0.3 % of cases).  ``tests/batched/test_laws.py``
  holds both to the scalar forms bit for bit.  As in the PyBullet engine's loop
  (:meth:`pyflyt_engine.world.World.step`), each vehicle's wind is taken when it is read,
  from the others' latest reads (this physics step for the agents before it, the previous
  one for those after it) and their throttles as they stand (on a control tick every
  vehicle's of the previous physics step; between ticks, those before it already stepped),
  and enters as the vertical wind of its air velocity (body drag);
* **agent-agent contact**: two vehicles touch when their collision boxes overlap (a
  separating-axis test on each airframe's box about its collision geometry, exact for the
  single-box Crazyflie), sampled where the PyBullet engine samples contacts; PyBullet
  reports contacts from its contact threshold on, so it may retire a pair up to an agent
  step earlier;
* **ground contact**: as :func:`pyflyt_engine.batched.kernels.advance` (the lowest
  collision point below the ground).

Episodes follow the PyBullet env's (:class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv`
with :class:`~pyflyt_engine.envs.tasks.ma_hover.MAHoverTask`): a live agent is
*terminated* on any contact (ground or another agent, retired ones included) or leaving the
dome, *truncated* at the time limit (a success); an agent whose episode ended is retired:
disarmed (motor commands 0, its controller no longer runs: its integrals and last rates stay
as they were, as the engine's ``Vehicle.control_step`` leaves them), it falls and stays a body the
others can hit and whose wake still blows (its throttles decaying).  The PyBullet engine's
ground holds a fallen vehicle; here a retired vehicle that reaches the ground is held there
at rest.  A world's episode ends when no agent is left; it then starts its next one.

Slots (the convention of :mod:`pyflyt_cli.training.multi_agent`): an agent whose episode
ends is ``done`` with its last observation in ``final_obs`` and its return and length in
``episode``; until its world's episode ends the slot is padding (zero observation, zero
reward), and ends (``done``, ``final_obs`` zeros, no ``episode`` entry: ``_episode`` False)
when its world restarts.

Per world, spawns are drawn from the world's own generator (spawned from the seed), agent
by agent in order: position offsets ``U(-noise, noise, 3)`` then attitude offsets, as the
PyBullet env's ``_spawn`` draws them; motor noise from one generator for the batch.
The air (``env.wind``, ``env.ground_effect``): the single-agent backend's wind and ground-effect
laws (:mod:`pyflyt_engine.batched.air`), read at each vehicle as the engine's world reads them
(the downwash added to the field's vertical wind); the Dryden turbulence is one field per world,
as the engine's :class:`~pyflyt_engine.atmosphere.field.WindField` gives every vehicle of a world
the same linear gusts, each world's white noise from a stream of its own.  Where the airframe's
span reaches the turbulence's ``rotary_min_span`` each vehicle has its own rotary gusts
``p, q, r``: the world's filter is the field's for all of its vehicles (its linear states
shared, then three states and three output rows per vehicle, in agent order), so a world of
``A`` agents steps a ``5 + 3A``-state filter and holds it in each of its slots (every slot's
rows are the world's, as for a drawn wind): memory ``~ A (5 + 3A)^2 x 32 B`` per world (4
agents: 37 KB; 16: 1.4 MB; 64: 79 MB) and, like the engine's, a filter step costing
``O((5 + 3A)^2)`` per world and physics step.

The optional motor models and the battery (an airframe's ``tau_fall``, ``rotor_drag``,
``inflow``, ``battery``): each vehicle's modelled motors step by the single-agent backend's
compiled laws (:func:`~pyflyt_engine.batched.kernels.modelled_load`) at the air its body drag
takes (the wind and the others' downwash in it); each vehicle has its own pack, reset with its
world's episode, its state of charge closing the agent's aux as the battery gauge's does; the
wakes stay the engine's (full thrusts times ``x |x|``, without the pack's sag).

Domain randomisation (``env.randomize``): per world, at each of its resets, every entry is
drawn once from the world's generator, before the spawns, and every agent of the world given
the values, as the PyBullet engine's randomiser draws one set per reset for every vehicle of
its world (:class:`pyflyt_engine.envs.randomization.Randomizer`, drawn first by
:func:`pyflyt_engine.envs.build.reset_episode`): the single-agent backend's
:class:`~pyflyt_engine.batched.randomization.BatchedRandomizer` draws them and sets each
agent's rows of the body's, motors', drag's and sensors' parameters; the spawn offsets are
added to each agent's spawn; the winds ``wind.<path>`` give the world its episode's wind
(:meth:`~pyflyt_engine.batched.randomization.BatchedRandomizer.apply_wind`: the sampled wind
config the engine's randomiser gives its world, its parameters and turbulence filter written
into every slot of the world, the kernel reading the world's first slot's).  The flight controller keeps the nominal airframe, as the
engine's does (in every flight mode); each vehicle's wake is as strong as its own motors, a
drawn ``motor_kf`` included (``_wake_thrust``, a row per vehicle the randomiser sets), as the
engine takes a vehicle's full thrusts from its motor constants when they change.

Latency (``env.latency``, and the drawn delays ``randomize.action_delay`` /
``observation_delay``, one draw per world): the single-agent backend's
:class:`~pyflyt_engine.batched.latency.BatchedLatency`, a row per agent, the PyBullet engine's
semantics for every vehicle of a world (each control tick flies the latest action released
by then; an observation shows every vehicle as it was ``n_o`` physics steps ago, the task's
entries -- the formation's neighbours among them -- from those delayed states, as the
engine's ``delayed_state`` source gives them; rewards and episode ends read the true
states).  The agent step then runs in pieces; each vehicle's latest read position, from
which the others' downwash is taken, is the env's (``_reads``) and carries over from one
piece to the next, a piece ending inside a control period takes no contact sample, and in a
cascade mode a piece starting inside one runs no controller tick (the motors keep the
commands the period's tick gave), so the pieces change no number of the flight.

Noisy sensors (``env.sensors``, or the airframe's ``sensors`` section, and the estimator):
the single-agent backend's :class:`~pyflyt_engine.batched.sensors.BatchedSensors`, a row per
agent, each vehicle's stream its own (agent ``a`` of world ``k``: spawn key ``(4, a)`` under
the world's seed sequence, as the PyBullet world seeds vehicle ``a``'s suite), every vehicle
sampled at the start of every physics step (retired ones too, as the engine samples every
vehicle before its loads), so the draws per stream are the same in number and order as the
engine's.  With ``sensors.observe`` each agent's own state in its observation is the one its
sensors (or estimator) show, the task's entries taken from it (the formation's neighbours as
the source gives them), the fix's validity flag after the throttles, as the PyBullet env's
``sensor_state`` / ``estimator_state`` views build it; rewards and episode ends read the
true states.

What the batched multi-agent path does not simulate is refused by name at load
(:func:`check_swarm_supported`): other multi-agent tasks (the dogfight), agents with
different airframes, a flight mode not in :data:`SWARM_MODES`, the ``randomize`` entries the single-agent
backend does not draw either, the ray-cast range sensors (``env.range_sensors``, an airframe's
``range_sensors``: in a world a ray could also hit the other agents, which the single-agent
backend's ground-plane law does not cover), and every key the single-agent batched backend
refuses (the cameras among them).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine import exact
from pyflyt_engine.atmosphere.rotors import _LN2, JET_DECAY, JET_SPREAD, WAKE_REACH, RotorInteractions
from pyflyt_engine.batched import air as _air
from pyflyt_engine.batched import bookkeeping, kernels, normals
from pyflyt_engine.batched import modes as _modes
from pyflyt_engine.batched.memory import keep_heap
from pyflyt_engine.batched.kernels import (
    MODE_MOTORS,
    MODE_RATES_THRUST,
    _lowest,
    drag_wrench,
    integrate_state,
    mix,
    modelled_load,
    motors_step,
    rate_loop,
    rotation_tuple,
    summed,
)
from pyflyt_engine.batched.model import BatchedModel, batched_model, mode_code, refuse
from pyflyt_engine.batched.latency import BatchedLatency, declares_latency
from pyflyt_engine.batched.randomization import BatchedRandomizer
from pyflyt_engine.batched.sensors import (
    OBSERVE_ESTIMATED,
    OBSERVE_TRUE,
    P_IMU,
    S_EST_VEL,
    S_GYRO,
    S_VALID,
    BatchedSensors,
)
from pyflyt_engine.batched.terms import BatchContext, BatchedReward, batched_ends
from pyflyt_engine.control.modes import resolve_mode
from pyflyt_engine.constants import AIR_DENSITY, GRAVITY
from pyflyt_engine.envs.randomization import Randomizer
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import euler_to_quaternion, quaternion_to_rows
from pyflyt_engine.spec import UAVSpec, load_uav_spec
from pyflyt_engine.state import KinematicState

#: multi-agent tasks the batched backend runs: the hover on arrays, the formation through the
#: engine's own task object, one per world (:class:`_WorldTasks`)
SWARM_TASKS = ("ma_hover", "ma_formation")

# ------------------------------------------------------------------ the downwash law


@njit(cache=True)
def py_hypot(x: float, y: float) -> float:
    """``math.hypot(x, y)`` as CPython computes it (``vector_norm`` in Modules/mathmodule.c:
    scaling by a power of two, Dekker's exact products, compensated sums and one
    differential correction), so that the compiled downwash rounds as the scalar one does;
    the C library's ``hypot``, which numba calls, differs in the last bit for some inputs."""
    ax, ay = abs(x), abs(y)
    if math.isinf(ax) or math.isinf(ay):
        return math.inf
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    top = ax if ax > ay else ay
    if top == 0.0:
        return top
    _, max_e = math.frexp(top)
    if max_e < -1023:  # subnormal scale: as CPython, through DBL_MIN
        dbl_min = 2.2250738585072014e-308
        return dbl_min * py_hypot(ax / dbl_min, ay / dbl_min)
    scale = math.ldexp(1.0, -max_e)
    csum = 1.0
    frac1 = 0.0
    frac2 = 0.0
    for k in range(2):
        v = (ax if k == 0 else ay) * scale
        # dl_mul(v, v): Dekker's split and product
        t = v * 134217729.0
        hi = t - (t - v)
        lo = v - hi
        p = hi * hi
        q = hi * lo + lo * hi
        z = p + q
        zz = p - z + q + lo * lo
        # dl_fast_sum(csum, z)
        s = csum + z
        e = (csum - s) + z
        csum = s
        frac1 += zz
        frac2 += e
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    # dl_mul(-h, h)
    t = -h * 134217729.0
    hi1 = t - (t - -h)
    lo1 = -h - hi1
    t = h * 134217729.0
    hi2 = t - (t - h)
    lo2 = h - hi2
    p = hi1 * hi2
    q = hi1 * lo2 + lo1 * hi2
    z = p + q
    zz = p - z + q + lo1 * lo2
    s = csum + z
    e = (csum - s) + z
    csum = s
    frac1 += zz
    frac2 += e
    v = csum - 1.0 + (frac1 + frac2)
    h += v / (2.0 * h)
    return h / scale


@njit(cache=True)
def downwash_velocity(dz: float, r: float, thrust: float, disc_area: float, air_density: float, square: float) -> float:
    """:func:`pyflyt_engine.atmosphere.rotors.downwash_velocity`, compiled: the downward wake
    speed [m/s] ``dz`` below and ``r`` off the axis of a rotorcraft of ``thrust`` [N] over
    ``disc_area`` [m^2] (0 above it or without thrust).

    ``square`` is 2.0, given at run time: the scalar law's ``(r / half) ** 2`` is the C
    library's ``pow(x, 2.0)`` (Python's float power), which differs from ``x * x`` in the last
    bit for ~0.1 % of inputs; an exponent the compiler cannot see keeps the call to ``pow``
    instead of folding it into a multiplication."""
    if dz <= 0.0 or thrust <= 0.0 or disc_area <= 0.0:
        return 0.0
    jet = 2.0 * math.sqrt(thrust / (2.0 * air_density * disc_area))
    d = math.sqrt(2.0 * disc_area / math.pi)
    x = dz + JET_DECAY * d
    half = JET_SPREAD * x
    return jet * JET_DECAY * d / x * math.exp(-_LN2 * (r / half) ** square)


@njit(cache=True)
def rotor_thrust(throttle: np.ndarray, max_thrust: np.ndarray, is_rotor: np.ndarray) -> float:
    """:meth:`RotorInteractions.thrust`: ``sum t x |x|`` over the motors with a radius, in order."""
    total = 0.0
    for m in range(throttle.shape[0]):
        if is_rotor[m]:
            x = throttle[m]
            total += max_thrust[m] * x * abs(x)
    return total


_REACH = WAKE_REACH * JET_SPREAD


@njit(cache=True)
def downwash_at(
    index: int,
    x: float,
    y: float,
    z: float,
    positions: np.ndarray,
    throttles: np.ndarray,
    max_thrust: np.ndarray,
    is_rotor: np.ndarray,
    disc_area: float,
    jet_diameter: float,
    air_density: float,
    square: float,
) -> float:
    """:meth:`RotorInteractions.downwash_at` for vehicle ``index`` at (x, y, z) among vehicles of
    one airframe at ``positions`` (A, 3) with ``throttles`` (A, motors) and full thrusts
    ``max_thrust`` (A, motors: each vehicle's own, a drawn ``motor_kf`` in them): the vertical wind
    [m/s] (negative: down).  The vehicles beyond a wake's reach (``WAKE_REACH`` half-widths,
    where the term is exactly 0.0: :meth:`RotorInteractions.sources`'s test) are skipped,
    which leaves every bit of the sum as it is.  ``square``: 2.0 (:func:`downwash_velocity`)."""
    w = 0.0
    if disc_area <= 0.0:
        return w
    for j in range(positions.shape[0]):
        if j == index:
            continue
        cx, cy, cz = positions[j, 0], positions[j, 1], positions[j, 2]
        if cz <= z:
            continue
        reach = _REACH * (cz - z + JET_DECAY * jet_diameter)
        dx, dy = x - cx, y - cy
        if dx * dx + dy * dy > reach * reach:
            continue
        thrust = rotor_thrust(throttles[j], max_thrust[j], is_rotor)
        w -= downwash_velocity(cz - z, py_hypot(dx, dy), thrust, disc_area, air_density, square)
    return w


# ------------------------------------------------------------------ agent-agent contact


@njit(cache=True)
def boxes_overlap(pa: np.ndarray, ra, pb: np.ndarray, rb, centre: np.ndarray, half: np.ndarray) -> bool:
    """Whether two boxes of half extents ``half`` about ``centre`` (body frame) overlap, the
    bodies at ``pa``, ``pb`` with body-to-ground rotations ``ra``, ``rb`` (row-major 9-tuples):
    the separating-axis test over the 15 axes of two oriented boxes."""
    c0, c1, c2 = centre[0], centre[1], centre[2]
    tx = (pb[0] + rb[0] * c0 + rb[1] * c1 + rb[2] * c2) - (pa[0] + ra[0] * c0 + ra[1] * c1 + ra[2] * c2)
    ty = (pb[1] + rb[3] * c0 + rb[4] * c1 + rb[5] * c2) - (pa[1] + ra[3] * c0 + ra[4] * c1 + ra[5] * c2)
    tz = (pb[2] + rb[6] * c0 + rb[7] * c1 + rb[8] * c2) - (pa[2] + ra[6] * c0 + ra[7] * c1 + ra[8] * c2)
    m = np.empty((3, 3))
    am = np.empty((3, 3))
    t = np.empty(3)
    for i in range(3):  # axis i of a: column i of ra
        t[i] = tx * ra[i] + ty * ra[3 + i] + tz * ra[6 + i]
        for j in range(3):
            m[i, j] = ra[i] * rb[j] + ra[3 + i] * rb[3 + j] + ra[6 + i] * rb[6 + j]
            am[i, j] = abs(m[i, j]) + 1e-12
    for i in range(3):
        if abs(t[i]) > half[i] + half[0] * am[i, 0] + half[1] * am[i, 1] + half[2] * am[i, 2]:
            return False
    for j in range(3):
        tb = t[0] * m[0, j] + t[1] * m[1, j] + t[2] * m[2, j]
        if abs(tb) > half[0] * am[0, j] + half[1] * am[1, j] + half[2] * am[2, j] + half[j]:
            return False
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            ra_ = half[i1] * am[i2, j] + half[i2] * am[i1, j]
            rb_ = half[j1] * am[i, j2] + half[j2] * am[i, j1]
            if abs(t[i2] * m[i1, j] - t[i1] * m[i2, j]) > ra_ + rb_:
                return False
    return True


# ------------------------------------------------------------------ the step


@njit(cache=True)
def advance_swarm(
    pos,
    quat,
    vel,
    angvel,
    throttle,
    command,
    integral,
    previous,
    has_previous,
    setpoint,
    factors,
    mode,
    armed,
    parked,
    agents,
    mass,
    inertia,
    control_inertia,
    gyro,
    lag,
    columns,
    mixer_rows,
    max_collective,
    rate_gains,
    derivative,
    drag_factors,
    damping,
    drag_on,
    corners,
    box_centre,
    box_half,
    bound_radius,
    ground_contact,
    agent_contact,
    gravity,
    physics_dt,
    control_dt,
    start,
    count,
    per_control,
    downwash_on,
    max_thrust,
    is_rotor,
    disc_area,
    jet_diameter,
    air_density,
    square,
    wind,
    episode_steps,
    rotors,
    ground_effect,
    min_height,
    turbulence,
    turbulence_normals,
    dryden,
    motor_model,
    motor_laws,
    battery,
    battery_params,
    battery_table,
    reads,
    sample_end,
):
    """Advance every world (rows ``k A ... k A + A - 1`` of every array are world ``k``'s agents)
    ``count`` physics steps from physics step ``start``, in the PyBullet engine's order
    (:meth:`pyflyt_engine.world.World.step` with downwash): per physics step, on a control
    tick every vehicle is read, gets its air (the downwash of the others at their latest
    reads) and runs its controller, then every vehicle steps its motors and drag; between
    ticks each vehicle in turn is read, gets its air and steps its motors and drag; then
    every body integrates.  A disarmed vehicle (``armed`` False) commands its motors to 0
    and runs no controller; a ``parked`` one (retired, on the ground) stays at rest.
    ``reads`` (n, 3): each vehicle's latest read position, which the others' downwash is
    taken from, updated as each vehicle is read (the env sets it to the positions at the
    start of an agent step; a call starting inside one continues the previous call's).
    Contacts are sampled at the end of each control period and, with ``sample_end``, of the
    call (the end of the agent step; a call ending inside a control period, which latency's
    pieces may, takes no sample there, as the engine takes none): ``ground_contact``
    (lowest point below the ground; a disarmed vehicle touching it is parked) and
    ``agent_contact`` (collision boxes overlap, both vehicles flagged).
    The laws and parameters are :func:`pyflyt_engine.batched.kernels.advance`'s, one airframe
    for every vehicle: the flight controller's one set, the body's, motors' and drag's one row
    per vehicle (``mass``, ``inertia``, ``lag``, ``columns``, ``drag_factors``, ``damping``,
    ``rotors``, ``max_thrust`` (each vehicle's wake strength): domain randomisation sets a world's
    rows); ``square`` is 2.0 (:func:`downwash_velocity`).

    The air as :func:`~pyflyt_engine.batched.kernels.advance` takes it, one wind per world:
    where world ``k``'s row of the wind parameters (``wind[k A]``, its first slot's: every slot
    of a world holds the same) is on, each vehicle's wind at its height at physics step
    ``episode_steps[i] + s`` of its world's episode (:func:`~pyflyt_engine.batched.air.wind_sample`);
    the turbulence is one field per world, as the engine's
    :class:`~pyflyt_engine.atmosphere.field.WindField` gives every vehicle of a world the same
    linear gusts: world ``k``'s state (``turbulence`` of its first slot, copied to its other
    slots after the step) moves on one step per physics step from the draws
    ``turbulence_normals[k, s]`` through the world's filter (``dryden``: each array of
    :attr:`~pyflyt_engine.batched.air.Dryden.arrays` with a leading slot axis, the world's its
    first slot's rows; a drawn wind gives each world its own); with rotary gusts (the
    parameters' ``rotary``) vehicle ``a`` of a world takes its own ``p, q, r``, rows
    ``3 + 3a ...`` of the world's filter output (:func:`~pyflyt_engine.batched.air.dryden_rotary`),
    as the engine's field gives each vehicle its own; the
    downwash is added to each vehicle's vertical wind as
    :meth:`pyflyt_engine.atmosphere.air.Atmosphere.wind_at` adds it; with ``ground_effect``
    each motor's thrust takes its ground-effect ratio at its hub height (``rotors`` (n, 5),
    :func:`~pyflyt_engine.batched.air.ground_effect_columns`).

    The modelled motors (``motor_laws`` not 0) and the packs (``motor_model`` (n, motors,
    :data:`~pyflyt_engine.batched.kernels.MOTOR_MODEL_FIELDS`), ``battery`` (n,
    :data:`~pyflyt_engine.batched.kernels.BATTERY_STATE`), ``battery_params``,
    ``battery_table``) as :func:`~pyflyt_engine.batched.kernels.advance` takes them, each
    vehicle's at the air its body drag takes (``air``: the wind and the downwash in it).
    """
    n = pos.shape[0]
    worlds = n // agents
    nm = throttle.shape[1]
    rates = np.empty(3)
    torques = np.empty(3)
    out = np.empty(nm)
    parts = np.empty((nm, 4))
    air = np.empty((agents, 6))
    loads = np.empty((agents, 6))
    reach2 = (2.0 * bound_radius) * (2.0 * bound_radius)
    calm = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    scratch = np.empty(turbulence.shape[1])
    spins = np.zeros((agents, 3))
    scaled = np.empty((nm, 6))
    modelled = motor_laws != 0
    ratio = np.empty(nm)
    for k in range(worlds):
        base = k * agents
        wind_k = wind[base]  # this world's wind and turbulence filter (its first slot's rows)
        windy = wind_k[0] != 0.0
        turbulent = wind_k[17] != 0.0
        rotary = turbulent and wind_k[20] != 0.0
        dryden_k = (dryden[0][base], dryden[1][base], dryden[2][base], dryden[3][base], dryden[4][base])
        for a in range(agents):
            ground_contact[base + a] = False
            agent_contact[base + a] = False
        # every vehicle's latest read (kept by the env: its state after the last agent step, then
        # each physics step's read; a call that starts inside an agent step continues them)
        seen = reads[base : base + agents]
        thr = throttle[base : base + agents]
        full = max_thrust[base : base + agents]
        for s in range(count):
            step = start + s
            tick = step % per_control == 0
            gusts = calm
            if turbulent:  # the world's turbulence (one field for its vehicles, as the engine's) moves on
                gusts = _air.dryden_output(dryden_k, turbulence[base], wind_k[18], wind_k[19])
                if rotary:  # each vehicle's own rotary gusts, its rows of the world's filter (the field's)
                    for a in range(agents):
                        spins[a, 0], spins[a, 1], spins[a, 2] = _air.dryden_rotary(
                            dryden_k, turbulence[base], wind_k[18], wind_k[19], a
                        )
                _air.dryden_step(dryden_k, turbulence[base], turbulence_normals[k, s], scratch)
            for a in range(agents):
                i = base + a
                seen[a, 0], seen[a, 1], seen[a, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
                r0, r1, r2, r3, r4, r5, r6, r7, r8 = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                w0, w1, w2 = angvel[i, 0], angvel[i, 1], angvel[i, 2]
                v0, v1, v2 = vel[i, 0], vel[i, 1], vel[i, 2]
                bw0 = r0 * w0 + r3 * w1 + r6 * w2
                bw1 = r1 * w0 + r4 * w1 + r7 * w2
                bw2 = r2 * w0 + r5 * w1 + r8 * w2
                wx = wy = wz = gp = gq = gr = 0.0
                if windy:  # the field's wind at this vehicle's height and this physics step
                    wx, wy, wz, gp, gq, gr = _air.wind_sample(
                        wind_k, episode_steps[i] + s, pos[i, 2], physics_dt, gusts
                    )
                    if rotary:
                        gp, gq, gr = spins[a, 0], spins[a, 1], spins[a, 2]
                if downwash_on:
                    dw = downwash_at(
                        a,
                        seen[a, 0],
                        seen[a, 1],
                        seen[a, 2],
                        seen,
                        thr,
                        full,
                        is_rotor,
                        disc_area,
                        jet_diameter,
                        air_density,
                        square,
                    )
                    wz = wz + dw if windy else dw  # Atmosphere.wind_at: the field's sample, its z plus the downwash
                if tick:  # the air from the state read (air_velocity_from_body)
                    bv0 = r0 * v0 + r3 * v1 + r6 * v2
                    bv1 = r1 * v0 + r4 * v1 + r7 * v2
                    bv2 = r2 * v0 + r5 * v1 + r8 * v2
                    air[a, 0] = bv0 - (r0 * wx + r3 * wy + r6 * wz)
                    air[a, 1] = bv1 - (r1 * wx + r4 * wy + r7 * wz)
                    air[a, 2] = bv2 - (r2 * wx + r5 * wy + r8 * wz)
                    air[a, 3] = bw0 - (r0 * gp + r3 * gq + r6 * gr)
                    air[a, 4] = bw1 - (r1 * gp + r4 * gq + r7 * gr)
                    air[a, 5] = bw2 - (r2 * gp + r5 * gq + r8 * gr)
                    cmd = command[i]
                    if not armed[i]:
                        for mo in range(nm):
                            cmd[mo] = 0.0
                    elif mode == MODE_RATES_THRUST:
                        rates[0], rates[1], rates[2] = bw0, bw1, bw2
                        if not has_previous[i]:
                            previous[i, 0], previous[i, 1], previous[i, 2] = bw0, bw1, bw2
                        rate_loop(
                            setpoint[i, :3],
                            rates,
                            previous[i],
                            integral[i],
                            rate_gains,
                            derivative,
                            control_inertia,
                            gyro,
                            control_dt,
                            torques,
                        )
                        previous[i, 0], previous[i, 1], previous[i, 2] = bw0, bw1, bw2
                        has_previous[i] = True
                        mix(setpoint[i, 3] * max_collective, torques[0], torques[1], torques[2], mixer_rows, parts, out)
                        for mo in range(nm):
                            cmd[mo] = out[mo]
                    else:  # motors: the setpoint is the throttles, clamped to [-1, 1]
                        for mo in range(nm):
                            c = setpoint[i, mo]
                            cmd[mo] = 1.0 if c > 1.0 else -1.0 if c < -1.0 else c
                else:  # the air from a motion read (air_velocity with the wind)
                    lx, ly, lz = v0 - wx, v1 - wy, v2 - wz
                    ax, ay, az = w0 - gp, w1 - gq, w2 - gr
                    air[a, 0] = r0 * lx + r3 * ly + r6 * lz
                    air[a, 1] = r1 * lx + r4 * ly + r7 * lz
                    air[a, 2] = r2 * lx + r5 * ly + r8 * lz
                    air[a, 3] = r0 * ax + r3 * ay + r6 * az
                    air[a, 4] = r1 * ax + r4 * ay + r7 * az
                    air[a, 5] = r2 * ax + r5 * ay + r8 * az
                    if modelled:  # ModelledMotors, at the body's velocity through the air as body drag takes it
                        load = modelled_load(
                            throttle[i],
                            command[i],
                            lag[i],
                            factors[i, s],
                            motor_model[i],
                            motor_laws,
                            battery[i],
                            battery_params[i],
                            battery_table,
                            rotors[i],
                            ground_effect,
                            pos[i, 2],
                            r6,
                            r7,
                            r8,
                            min_height,
                            ratio,
                            (air[a, 0], air[a, 1], air[a, 2], air[a, 3], air[a, 4], air[a, 5]),
                            physics_dt,
                        )
                    elif ground_effect:
                        _air.ground_effect_columns(pos[i, 2], r6, r7, r8, rotors[i], columns[i], min_height, scaled)
                        load = motors_step(throttle[i], command[i], lag[i], factors[i, s], scaled)
                    else:
                        load = motors_step(throttle[i], command[i], lag[i], factors[i, s], columns[i])
                    if drag_on:
                        load = summed(
                            load,
                            drag_wrench(
                                air[a, 0],
                                air[a, 1],
                                air[a, 2],
                                air[a, 3],
                                air[a, 4],
                                air[a, 5],
                                drag_factors[i, 0],
                                drag_factors[i, 1],
                                drag_factors[i, 2],
                                damping[i],
                            ),
                        )
                    for c in range(6):
                        loads[a, c] = load[c]
            if tick:
                for a in range(agents):
                    i = base + a
                    if modelled:
                        rg = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                        load = modelled_load(
                            throttle[i],
                            command[i],
                            lag[i],
                            factors[i, s],
                            motor_model[i],
                            motor_laws,
                            battery[i],
                            battery_params[i],
                            battery_table,
                            rotors[i],
                            ground_effect,
                            pos[i, 2],
                            rg[6],
                            rg[7],
                            rg[8],
                            min_height,
                            ratio,
                            (air[a, 0], air[a, 1], air[a, 2], air[a, 3], air[a, 4], air[a, 5]),
                            physics_dt,
                        )
                    elif ground_effect:
                        rg = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                        _air.ground_effect_columns(
                            pos[i, 2], rg[6], rg[7], rg[8], rotors[i], columns[i], min_height, scaled
                        )
                        load = motors_step(throttle[i], command[i], lag[i], factors[i, s], scaled)
                    else:
                        load = motors_step(throttle[i], command[i], lag[i], factors[i, s], columns[i])
                    if drag_on:
                        load = summed(
                            load,
                            drag_wrench(
                                air[a, 0],
                                air[a, 1],
                                air[a, 2],
                                air[a, 3],
                                air[a, 4],
                                air[a, 5],
                                drag_factors[i, 0],
                                drag_factors[i, 1],
                                drag_factors[i, 2],
                                damping[i],
                            ),
                        )
                    for c in range(6):
                        loads[a, c] = load[c]
            for a in range(agents):
                i = base + a
                if parked[i]:
                    continue
                r = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                p, q, v, w = integrate_state(
                    (pos[i, 0], pos[i, 1], pos[i, 2]),
                    (quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3]),
                    (vel[i, 0], vel[i, 1], vel[i, 2]),
                    (angvel[i, 0], angvel[i, 1], angvel[i, 2]),
                    r,
                    (loads[a, 0], loads[a, 1], loads[a, 2], loads[a, 3], loads[a, 4], loads[a, 5]),
                    mass[i],
                    inertia[i, 0],
                    inertia[i, 1],
                    inertia[i, 2],
                    gravity,
                    physics_dt,
                )
                pos[i, 0], pos[i, 1], pos[i, 2] = p
                quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = q
                vel[i, 0], vel[i, 1], vel[i, 2] = v
                angvel[i, 0], angvel[i, 1], angvel[i, 2] = w
            if (step + 1) % per_control == 0 or (s == count - 1 and sample_end):  # a contact sample
                for a in range(agents):
                    i = base + a
                    rr = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                    if _lowest(pos[i, 2], rr[6], rr[7], rr[8], corners) < 0.0:
                        ground_contact[i] = True
                        if not armed[i] and not parked[i]:  # a retired vehicle lands and lies there
                            parked[i] = True
                            vel[i, 0], vel[i, 1], vel[i, 2] = 0.0, 0.0, 0.0
                            angvel[i, 0], angvel[i, 1], angvel[i, 2] = 0.0, 0.0, 0.0
                for a in range(agents):
                    i = base + a
                    for b in range(a + 1, agents):
                        j = base + b
                        dx = pos[i, 0] - pos[j, 0]
                        dy = pos[i, 1] - pos[j, 1]
                        dz = pos[i, 2] - pos[j, 2]
                        if dx * dx + dy * dy + dz * dz > reach2:
                            continue
                        ra = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                        rb = rotation_tuple(quat[j, 0], quat[j, 1], quat[j, 2], quat[j, 3])
                        if boxes_overlap(pos[i], ra, pos[j], rb, box_centre, box_half):
                            agent_contact[i] = True
                            agent_contact[j] = True
        if turbulent:  # the world's turbulence state in each of its slots
            for a in range(1, agents):
                for c in range(turbulence.shape[1]):
                    turbulence[base + a, c] = turbulence[base, c]


# ------------------------------------------------------------------ the env


#: the flight modes the multi-agent worlds fly: the rate loop's and the motors' in the worlds' kernel, and
#: every cascade mode of :mod:`pyflyt_engine.batched.modes` through its :func:`~pyflyt_engine.batched.modes.control_tick`
#: (:meth:`BatchedSwarmEnv._advance_cascade`); a mode the single-agent backend may fly beyond these is refused
SWARM_MODES = ("rates_thrust", "motors", *_modes.CASCADE_MODES)


def check_swarm_supported(config: Any) -> None:
    """Refuse, by name, what the batched multi-agent path does not simulate in a multi-agent config."""
    from pyflyt_engine.batched.support import check_keys

    if config.task.name not in SWARM_TASKS:
        raise refuse(f"the multi-agent task '{config.task.name}'", f"it runs {', '.join(SWARM_TASKS)}")
    agents = config.resolved_agents()
    uavs = sorted({a.uav for a in agents})
    if len(uavs) > 1:
        raise refuse(f"agents of different airframes ({', '.join(uavs)})", "give every agent the env's uav")
    # every other key as the single-agent backend checks it (downwash is simulated here)
    single = config.model_copy(update={"downwash": False})
    check_keys(single, multi_agent=True)
    # What the single-agent backend simulates may grow beyond what these worlds do: each is refused
    # here by name too, so a world never flies without something its config asks for.
    mode = resolve_mode(config.action.mode).name
    if mode not in SWARM_MODES:  # a mode the single-agent backend flies that is not wired into the worlds
        raise refuse(f"flight mode {mode} in a multi-agent world", f"it flies {', '.join(SWARM_MODES)}")
    from pyflyt_engine.batched.model import batched_model
    from pyflyt_engine.spec import load_uav_spec

    spec = load_uav_spec(uavs[0])
    if spec.range_sensors:  # the rays would also hit the other agents' shapes: not written for the worlds
        raise refuse(f"range sensors in a multi-agent world (airframe {spec.name}'s range_sensors)")
    model = batched_model(spec, 1.0 / config.physics_hz, 1.0 / config.control_hz, drag=config.drag)
    if model.through_channels:  # the worlds' kernel flies a mixer's motors alone
        raise refuse(
            f"channels, lifting surfaces, gimbals or motors outside the mixer in a multi-agent world (airframe "
            f"{model.name})",
            "give the agents a multirotor whose motors the mixer alone flies",
        )


class _WorldTasks:
    """A multi-agent task other than the hover, run by the engine's own task object, one per
    world (the formation: :class:`~pyflyt_engine.envs.tasks.ma_formation.MAFormationTask`),
    so its signals, observation entries and info are the PyBullet env's by construction.

    Each world's task reads the states of its agents as the engine's vehicles give them
    (:class:`~pyflyt_engine.state.KinematicState`) and its live flags (a view of the env's).
    What the task carries from one step to the next -- the formation's previous distance to
    each slot, its only such state; its neighbour survey is redone at every step before it is
    read -- is the env's ``_last_distance`` and is given back to the task before each step, so
    a checkpoint of the env's arrays resumes the task exactly (a restored world's task is set
    up from its agents' states at its first step, then given that distance).  A curriculum's
    episode options are the env's latest (:meth:`BatchedSwarmEnv.set_task_changes`) for the
    episodes in progress at a restore.
    """

    def __init__(self, task_cls: Any, cfg: Any, agents: list, alive: np.ndarray, worlds: int, per_world: int) -> None:
        self.per_world = per_world
        self.tasks = [
            task_cls(
                cfg.task,
                agents,
                alive[k * per_world : (k + 1) * per_world],
                flight_dome_size=cfg.flight_dome_size,
                agent_hz=cfg.agent_hz,
                max_steps=cfg.max_steps,
            )
            for k in range(worlds)
        ]
        self.extra_size = self.tasks[0].extra_size()
        #: per world, whether its task has been reset in this process (a restored checkpoint's
        #: worlds are not: their tasks are set up from the restored states at the next step)
        self.started = [False] * worlds
        #: the episode options of the tasks' episodes (a curriculum's changes, :meth:`reset`)
        self.changes: dict = {}

    def reset(self, k: int, states: list[KinematicState], changes: dict, last: np.ndarray, extras: np.ndarray) -> None:
        task = self.tasks[k]
        self.changes = changes
        task.set_episode_options(changes)
        task.reset(states)
        self.started[k] = True
        base = k * self.per_world
        for a in range(self.per_world):
            last[base + a] = task._distances[a]
            extras[base + a] = task.observe(a, states)

    def update(
        self,
        states_of: Any,
        live: np.ndarray,
        collision: np.ndarray,
        steps: np.ndarray,
        last: np.ndarray,
        extras: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Every world's step: ``(distance, rate, extras, info)`` per slot (NaN / 0 where not live)."""
        n = len(live)
        distance, rate = np.full(n, np.nan), np.full(n, np.nan)
        signal_extras: dict[str, np.ndarray] = {}
        info: dict[str, np.ndarray] = {}
        for k, task in enumerate(self.tasks):
            base = k * self.per_world
            rows = np.arange(base, base + self.per_world)
            acted = [a for a in range(self.per_world) if live[base + a]]
            if not acted:
                continue
            states = states_of(rows)
            if not self.started[k]:  # a restored world: the task's set-up from its states now
                task.set_episode_options(self.changes)
                task.reset(states)
                self.started[k] = True
            task._distances = [float(last[base + a]) for a in range(self.per_world)]
            signals = task.update(states, acted, {a: bool(collision[base + a]) for a in acted}, int(steps[base]))
            for a in acted:
                sig = signals[a]
                i = base + a
                distance[i] = np.nan if sig.target_distance is None else sig.target_distance
                rate[i] = np.nan if sig.target_distance_rate is None else sig.target_distance_rate
                last[i] = task._distances[a]
                for key, value in sig.extras.items():
                    signal_extras.setdefault(key, np.zeros(n))[i] = value
                for key, value in sig.info.items():
                    if key != "target_distance":
                        info.setdefault(key, np.zeros(n))[i] = value
            for a in range(self.per_world):
                extras[base + a] = task.observe(a, states)
        return distance, rate, signal_extras, info

    def observe(self, states_of: Any, extras: np.ndarray, own: Any = None) -> np.ndarray:
        """Every slot's task entries of the states ``states_of(rows)`` gives (the delayed ones),
        from each world's task as its last step left it (a world whose task is not set up yet,
        a restored one before its first step: ``extras``' rows); with ``own``, slot ``i``'s
        entries see its own state as ``own(i)`` gives it (its sensors'), the others' as given."""
        out = extras.copy()
        for k, task in enumerate(self.tasks):
            if not self.started[k]:
                continue
            base = k * self.per_world
            states = states_of(np.arange(base, base + self.per_world))
            for a in range(self.per_world):
                if own is None:
                    out[base + a] = task.observe(a, states)
                else:
                    viewed = list(states)
                    viewed[a] = own(base + a)
                    out[base + a] = task.observe(a, viewed)
        return out


class BatchedSwarmEnv(gymnasium.vector.VectorEnv):
    """``worlds`` worlds of a multi-agent hover config's agents, one slot per agent (module docstring).

    Args:
        config: a multi-agent env config (``"ma_quadx_hover"``, a YAML path, a mapping or a
            :class:`~pyflyt_engine.envs.config.MultiAgentEnvConfig`).
        worlds: how many worlds.
        seed: seeds the first reset.
        motor_noise: False switches the motors' noise off (the cross-checks).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    #: the per-slot arrays a checkpoint carries (:class:`pyflyt_cli.training.batched.BatchedVecEnv`)
    state_arrays: tuple[str, ...] = (
        "pos",
        "quat",
        "vel",
        "angvel",
        "throttle",
        "command",
        "integral",
        "previous",
        "has_previous",
        "actions",
        "steps",
        "physics_steps",
        "_last_distance",
        "episode_return",
        "episode_length",
        "ang_vel_body",
        "ang_pos",
        "lin_vel_body",
        "quaternion",
        "alive",
        "armed",
        "parked",
        "world_over",
        "turbulence",
        "_extras",
    )

    def __init__(self, config: Any, worlds: int = 1, seed: int | None = None, motor_noise: bool = True) -> None:
        from pyflyt_engine.envs.config import MultiAgentEnvConfig, load_env_config, load_reward_preset
        from pyflyt_engine.envs.multi_agent.config import get_ma_task
        from pyflyt_engine.envs.rewards import compile_reward

        cfg = load_env_config(config)
        if not isinstance(cfg, MultiAgentEnvConfig):
            raise ConfigError(f"BatchedSwarmEnv needs a multi-agent env config (one with 'agents'), got {cfg.source}")
        check_swarm_supported(cfg)
        if worlds < 1:
            raise ConfigError(f"worlds must be >= 1, got {worlds}")
        keep_heap()  # big per-step arrays without page faults (pyflyt_engine.batched.memory)
        self.config = cfg
        self.agent_list = cfg.resolved_agents()
        self.agents = a_count = len(self.agent_list)
        self.worlds = int(worlds)
        self.num_envs = n = self.worlds * a_count
        self.spec_uav: UAVSpec = load_uav_spec(cfg.uav)
        self.physics_dt = 1.0 / cfg.physics_hz
        self.control_dt = 1.0 / cfg.control_hz
        self.agent_dt = 1.0 / cfg.agent_hz
        self.per_agent = int(round(cfg.physics_hz / cfg.agent_hz))
        self.per_control = int(round(cfg.physics_hz / cfg.control_hz))
        self.model: BatchedModel = batched_model(self.spec_uav, self.physics_dt, self.control_dt, drag=cfg.drag)
        self.mode = mode_code(cfg.action.mode, self.model)
        #: a cascade mode's (law, yaw_is_rate, heading_frame, position, altitude): its controller runs
        #: at each control tick ahead of the period's physics (:meth:`_advance_cascade`); None in the others
        self._cascade = _modes.cascade_law(self.mode) if self.mode in _modes.CASCADE_MODES.values() else None
        expected = self.model.motors if self.mode == MODE_MOTORS else 4
        if len(cfg.action.low) != expected:
            raise ConfigError(f"mode {cfg.action.mode} takes {expected} values, the action has {len(cfg.action.low)}")
        task_cls = get_ma_task(cfg.task.name)
        self.task_class = task_cls
        preset = load_reward_preset(cfg.reward_preset_name())
        name = cfg.reward_preset_name()
        scalar = compile_reward(
            name if isinstance(name, str) else "inline", preset.terms, task_cls.provides, cfg.task.name
        )
        self.reward_function = BatchedReward(scalar)
        #: what ends an agent's episode: the config's termination terms (pyflyt_engine.batched.terms.batched_ends)
        self._ends = batched_ends(cfg.terminations, bool(task_cls.crash_on_contact))
        self.motor_noise = bool(motor_noise) and bool(np.any(self.model.noise_ratio > 0))
        self._quaternion = cfg.angle_representation == "quaternion"
        self._low = np.array(cfg.action.low, dtype=np.float64)
        self._high = np.array(cfg.action.high, dtype=np.float64)
        self._dome2 = cfg.flight_dome_size**2
        self._max_steps = cfg.max_steps
        self.downwash = bool(cfg.downwash)
        self._wake_sources = _rotor_geometry(self.spec_uav)
        from pyflyt_engine.atmosphere import load_wind_config

        #: the air (pyflyt_engine.batched.air), as the single-agent backend takes it: the wind
        #: field's parameters, the airframe's turbulence filter (None: no turbulence), ground effect
        self.wind_config = load_wind_config(cfg.wind)
        # per slot, its world's wind parameters and turbulence filter (the config's in every row;
        # a randomize entry wind.<path> sets a world's rows per episode, the kernel reads its first
        # slot's); the filter is the world's, for its agents (with rotary gusts: each agent's rows)
        self.dryden, self._wind, self._dryden_arrays, self._wind_rows, self._dryden_rows = _air.air_rows(
            self.wind_config, self.physics_dt, self.model.span, n, n, vehicles=a_count
        )
        self._dryden_phi, self._dryden_c, self._dryden_noise, self._dryden_root, self._dryden_flags = self._dryden_rows
        self.ground_effect = bool(cfg.ground_effect)
        rows = lambda a: np.array(np.broadcast_to(a, (n, *np.shape(a))), dtype=np.float64, order="C")  # noqa: E731
        box_centre, box_half = _collision_box(self.model.corners)
        self._box_centre, self._box_half = box_centre, box_half
        self._bound_radius = float(np.linalg.norm(np.abs(box_centre) + box_half))
        self._check_layout_spacing()

        m = self.model
        nm = m.motors
        # the body's, motors' and drag's parameters, one row per slot (own, writable copies:
        # domain randomisation sets a world's rows at each of its episodes); the flight
        # controller keeps the airframe's nominal ones (the model's, one set for every vehicle)
        self._mass = rows(m.mass)
        self._inertia = rows(m.inertia)
        self._lag = rows(m.lag)
        self._columns = rows(m.columns)
        self._drag_factors = rows(m.drag_factors)
        self._damping = rows(m.angular_damping)
        self._rotors = rows(m.rotors)
        #: the optional motor models' rows and the pack's parameters and state at a reset, per
        #: slot (empty without them; a drawn motor or battery_* factor sets a world's rows)
        self._motor_model = rows(m.motor_model)
        self._battery_params = rows(m.battery)
        self._battery_reset = rows(m.battery_reset)
        #: each slot's motors' full thrusts [N], the strength of its wake (a drawn motor_kf sets a world's rows)
        self._wake_thrust = rows(self._wake_sources["max_thrust"])
        #: the randomize section's draws, one per world and episode, every agent of the world
        #: given them (None without; pyflyt_engine.batched.randomization)
        from pyflyt_engine.envs.observe import with_sensors

        #: the sensors' section every vehicle flies (the env config's, else the airframe's; None without)
        flown = with_sensors(self.spec_uav, cfg.sensors).sensors
        self.randomizer = (
            BatchedRandomizer(
                cfg.randomize,
                self.spec_uav,
                self.physics_dt,
                n,
                sensors=flown,
                wind=self.wind_config,
                span=self.model.span,
                vehicles=a_count,
            )
            if cfg.randomize
            else None
        )
        #: per slot, its world's draws of this episode (entries in the section's order; no columns without)
        self.randomized_values = self.randomizer.values if self.randomizer is not None else np.zeros((n, 0))
        #: the parameter rows a checkpoint carries besides the state: those the draws change
        #: (and the wakes' strengths, which a drawn motor_kf sets)
        self.randomized_arrays: tuple[str, ...] = (
            self.randomizer.arrays() + (("_wake_thrust",) if self.randomizer.motors else ())
            if self.randomizer is not None
            else ()
        )
        self.pos = np.zeros((n, 3))
        self.quat = np.zeros((n, 4))
        self.quat[:, 3] = 1.0
        self.vel = np.zeros((n, 3))
        self.angvel = np.zeros((n, 3))
        self.throttle = np.zeros((n, nm))
        self.command = np.zeros((n, nm))
        self.integral = np.zeros((n, 3))
        self.previous = np.zeros((n, 3))
        self.has_previous = np.zeros(n, dtype=bool)
        #: per slot, the velocity loop's integrals (x, y, z; no columns outside a cascade mode)
        self.vel_integral = np.zeros((n, 3 if self._cascade is not None else 0))
        #: a cascade mode's controller parameters, one row per slot (the airframe's nominal ones,
        #: as the engine's controller keeps them), and the motor commands its ticks give
        self._cascade_rows = self._controller_rows() if self._cascade is not None else None
        self._commands = np.zeros((n, nm))
        if self._cascade is not None:  # a checkpoint carries the velocity loop's integrals too
            self.state_arrays = (*self.state_arrays, "vel_integral")
        self.ground_contact = np.zeros(n, dtype=bool)
        self.agent_contact = np.zeros(n, dtype=bool)
        #: per slot: its agent is in its world's episode; its vehicle is armed; it lies on the ground retired
        self.alive = np.zeros(n, dtype=bool)
        self.armed = np.zeros(n, dtype=bool)
        self.parked = np.zeros(n, dtype=bool)
        #: per slot: its world's episode ended at the last step (kept for a checkpoint's sake)
        self.world_over = np.zeros(n, dtype=bool)
        self.actions = np.zeros((n, self._low.size))
        self.steps = np.zeros(n, dtype=np.int64)
        self.physics_steps = np.zeros(n, dtype=np.int64)
        self._ones = np.ones((n, self.per_agent, nm))
        #: per slot, its world's turbulence filter state (Dryden; none without turbulence): one
        #: field per world, the same in each of its slots
        self.turbulence = np.zeros((n, self.dryden.states if self.dryden is not None else 0))
        self._no_normals = np.zeros((self.worlds, self.per_agent, 0))
        self._normals = self._no_normals  # this agent step's (advance)
        #: per slot, its vehicle's latest read position (the downwash's source; advance_swarm)
        self._reads = np.zeros((n, 3))
        #: the contact samples the physics writes (BatchedLatency gathers them over an agent step's pieces)
        self.contact_flags = (self.ground_contact, self.agent_contact)
        #: what an observation shows besides the motion (BatchedLatency's snapshot): the worlds'
        #: multirotors have no lifting surfaces; a pack's state of charge closes the aux
        self.deflection = np.zeros((n, 0))
        #: per slot, its pack's state (charge, voltage [V], current [A], speed ratio:
        #: kernels.BATTERY_STATE; none without a battery), its reset's at every episode start
        self.battery = np.zeros((n, m.battery_reset.size))
        if self.battery.shape[1]:  # a checkpoint carries the packs' state
            self.state_arrays = (*self.state_arrays, "battery")
        #: the action and observation delays, one row per slot, the agents of a world sharing
        #: the world's (None without; pyflyt_engine.batched.latency)
        self.latency = (
            BatchedLatency(cfg, n, self.per_agent, self.per_control, self._low.size, nm, 0, m.has_battery)
            if declares_latency(cfg)
            else None
        )
        delays = self.latency.state_arrays() if self.latency is not None else {}
        #: per slot, this episode's (action, observation) delays [physics steps], its last actions
        #: and the states it shows (empty rows without latency)
        self.latency_steps = delays.get("latency_steps", np.zeros((n, 0), dtype=np.int64))
        self.action_history = delays.get("action_history", np.zeros((n, 0)))
        self.observed_history = delays.get("observed_history", np.zeros((n, 0)))
        if self.latency is not None:  # a checkpoint carries them too
            self.state_arrays = (*self.state_arrays, *delays)
        #: the noisy sensors and estimator, a row per slot (pyflyt_engine.batched.sensors; None
        #: without a ``sensors`` section, the env config's or the airframe's); each slot's stream
        #: is its own (BatchedSensors.seed_worlds), as each PyBullet vehicle's is
        self.sensors = BatchedSensors(flown, cfg.sensors, n, self.physics_dt, GRAVITY) if flown is not None else None
        #: per slot, the sensors' and estimator's state (empty rows without sensors)
        self.sensor_state = self.sensors.rows if self.sensors is not None else np.zeros((n, 0))
        self.sensor_counts = self.sensors.counts if self.sensors is not None else np.zeros((n, 0), dtype=np.int64)
        #: per env, its sensors' parameters (a randomize section's sensor factors set them per episode)
        self.sensor_params = self.sensors.param_rows if self.sensors is not None else np.zeros((n, 0))
        #: whether the position fix's validity flag follows the auxiliary state in the observation
        self._fix_flag = self.sensors is not None and self.sensors.fix_flag
        if self.sensors is not None:  # a checkpoint carries the biases, held readings, counts and estimate
            self.state_arrays = (*self.state_arrays, "sensor_state", "sensor_counts")
        self.ang_vel_body = np.zeros((n, 3))
        self.ang_pos = np.zeros((n, 3))
        self.lin_vel_body = np.zeros((n, 3))
        self.quaternion = np.zeros((n, 4))
        self.quaternion[:, 3] = 1.0
        self.hover_point = np.tile(
            np.array([ag.hover_point for ag in self.agent_list], dtype=np.float64), (self.worlds, 1)
        )
        self._last_distance = np.zeros(n)
        #: a task other than the hover runs as the engine's task object, one per world
        self._world_tasks = (
            None
            if cfg.task.name == "ma_hover"
            else _WorldTasks(task_cls, cfg, self.agent_list, self.alive, self.worlds, self.agents)
        )
        extra = 3 if self._world_tasks is None else self._world_tasks.extra_size
        #: per slot, the task's observation entries (the hover's are computed from the position)
        self._extras = np.zeros((n, extra))
        self.episode_return = np.zeros(n)
        self.episode_length = np.zeros(n, dtype=np.int64)
        self.task_changes: dict[str, Any] = {}

        size = 3 + (4 if self._quaternion else 3) + 3 + 3 + self._low.size + m.aux_size + int(self._fix_flag) + extra
        self.single_observation_space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)
        self.single_action_space = spaces.Box(self._low, self._high, dtype=np.float64)
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, n)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, n)
        self._seed_all(seed)

    def _check_layout_spacing(self) -> None:
        """Agents the task's layout places must spawn clear of each other: the PyBullet env's
        rule (``MultiAgentUAVEnv._check_layout_spacing``), the airframe's bounding radius taken
        from its collision box."""
        cfg = self.config
        gap_of = getattr(cfg.task, "layout_gap", None)
        if gap_of is None or not isinstance(cfg.agents, int):
            return
        gap = gap_of(cfg.agents)
        noise = float(getattr(cfg.task, "position_noise", 0.0))
        need = 2.0 * self._bound_radius + 2.0 * math.sqrt(3.0) * noise
        if gap is not None and gap < need:
            # ma_formation has no layout option: its agents always fly its grid
            layout = getattr(cfg.task, "layout", None)
            fix = (
                "raise task.layout_radius or task.layout_spacing, use task.layout: grid, "
                if layout is not None
                else "raise task.layout_spacing, "
            )
            raise ConfigError(
                f"agents: {cfg.agents} agents on the {layout or 'grid'} layout spawn {gap:.3f} m apart, but they need "
                f"{need:.3f} m not to touch; {fix}or lower task.position_noise"
            )

    # ---------------------------------------------------------------- seeding

    def _seed_all(self, seed: int | None) -> None:
        children = np.random.SeedSequence(seed).spawn(self.worlds + 1)
        self.noise_rng = np.random.default_rng(children[0])
        self.world_rngs = [np.random.default_rng(c) for c in children[1:]]
        #: per world, the stream of its turbulence's white noise: the first child of the world's
        #: seed (the world's own draws stay as they were); none without turbulence
        self.world_turbulence_rngs = (
            [np.random.default_rng(c.spawn(1)[0]) for c in children[1:]] if self.dryden is not None else []
        )
        #: per slot, its world's turbulence stream (the same object for the agents of a world)
        self.turbulence_rngs = (
            [self.world_turbulence_rngs[i // self.agents] for i in range(self.num_envs)]
            if self.dryden is not None
            else []
        )
        #: per slot, its world's generator (the same object for the agents of a world)
        self.env_rngs = [self.world_rngs[i // self.agents] for i in range(self.num_envs)]
        if self.sensors is not None:  # per slot, its vehicle's sensor stream (BatchedSensors.seed_worlds)
            self.sensors.seed_worlds(children[1:], self.agents)

    # ------------------------------------------------------------------ reset

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode in every world (``seed``: reseed every generator first)."""
        if options:
            raise ConfigError(f"the batched env takes no reset options, got {sorted(options)}")
        if seed is not None:
            self._seed_all(seed)
        for k in range(self.worlds):
            self._reset_world(k)
        info: dict[str, Any] = {}
        if self.randomizer is not None:  # per entry, each slot's world's draw (the PyBullet info["randomization"])
            info["randomization"] = self.randomizer.info()
            info["_randomization"] = np.ones(self.num_envs, dtype=bool)
        return self._observe(), info

    def set_task_changes(self, changes: dict[str, Any]) -> None:
        """A training curriculum's task changes: the multi-agent hover has no per-episode options."""
        allowed = self.task_class.episode_options
        unknown = sorted(set(changes) - set(allowed))
        if unknown:
            raise ConfigError(
                f"task option(s) {', '.join(unknown)} cannot change per episode; these can: "
                f"{', '.join(sorted(allowed)) or 'none'}"
            )
        self.task_changes = dict(changes)

    def _reset_world(self, k: int) -> None:
        """World ``k``'s next episode, drawn from the world's generator in the PyBullet env's
        order (:func:`pyflyt_engine.envs.build.reset_episode`): the randomize section once for
        the world (every agent's parameter rows from it), then every agent spawned in its
        region, agent by agent, the drawn spawn offsets added."""
        rng = self.world_rngs[k]
        rows = np.arange(k * self.agents, (k + 1) * self.agents)
        randomizer = self.randomizer
        values: dict[str, float] | None = None
        if randomizer is not None:  # drawn before the spawns, one draw for the world's vehicles
            values = randomizer.draw(rows, rng)
            if randomizer.winds:  # the world's wind: the same rows of parameters and filter in each of its slots
                randomizer.apply_wind(self, rows, values)
            for i in rows.tolist():
                if randomizer.airframe:
                    randomizer.apply(self, i, values)
                if self.latency is not None:  # the drawn delays, every vehicle of the world
                    self.latency.draw(i, values)
        for a, i in enumerate(rows.tolist()):
            s = self.agent_list[a].spawn
            dp = rng.uniform(-s.position_noise, s.position_noise, 3) if s.position_noise else np.zeros(3)
            da = rng.uniform(-s.orientation_noise, s.orientation_noise, 3) if s.orientation_noise else np.zeros(3)
            position, orientation = np.add(s.position, dp).tolist(), np.add(s.orientation, da).tolist()
            if values is not None:  # Randomizer.spawn: the world's offsets added to each agent's spawn
                position, orientation = Randomizer.spawn(values, position, orientation)
            self.pos[i] = position
            q = euler_to_quaternion(*orientation)
            self.quat[i] = q
            r = np.empty(9)
            kernels.rotation_rows(q[0], q[1], q[2], q[3], r)
            self.vel[i] = exact.rotate(r.reshape(3, 3).tolist(), [float(v) for v in s.lin_vel])
            self.angvel[i] = 0.0
        for name in ("throttle", "command", "integral", "previous", "vel_integral", "actions", "episode_return"):
            getattr(self, name)[rows] = 0.0  # the controller's memory cleared, as Vehicle.reset clears it
        self.has_previous[rows] = False
        if self.battery.shape[1]:  # the packs back to their initial charge, no load (Battery.reset)
            self.battery[rows] = self._battery_reset[rows]
        if self.dryden is not None:  # a new realisation: the state drawn from the stationary distribution
            _air.dryden_initial(
                self.dryden_of(int(rows[0])),
                self.world_turbulence_rngs[k].standard_normal(self.dryden.states),
                self.turbulence[rows[0]],
            )
            self.turbulence[rows] = self.turbulence[rows[0]]
        self.steps[rows] = 0
        self.physics_steps[rows] = 0
        self.episode_length[rows] = 0
        self.alive[rows] = True
        self.armed[rows] = True
        self.parked[rows] = False
        self._read(rows)
        if self.sensors is not None:  # time 0: each vehicle's new initial biases, the estimator at its spawn
            self.sensors.reset(rows, self.pos, self.vel, self.quaternion)
        if self.latency is not None:  # nothing in flight; the spawn shown until n_o steps have passed
            self.latency.restart(self, rows)
        self._reset_world_task(k)

    def _reset_world_task(self, k: int) -> None:
        """World ``k``'s task at the start of its episode, from its agents' states now."""
        rows = np.arange(k * self.agents, (k + 1) * self.agents)
        if self._world_tasks is None:
            self._last_distance[rows] = self._distance(rows)
        else:
            self._world_tasks.reset(k, self._states(rows), self.task_changes, self._last_distance, self._extras)

    def _states(self, rows: np.ndarray, source: dict[str, np.ndarray] | None = None) -> list[KinematicState]:
        """The agents' states of ``rows`` as the engine's vehicles read them (the task's input);
        ``source``: from those arrays (the delayed ones, BatchedLatency.observed) instead of now."""
        arrays = (
            source
            if source is not None
            else {
                "ang_vel_body": self.ang_vel_body,
                "ang_pos": self.ang_pos,
                "lin_vel_body": self.lin_vel_body,
                "pos": self.pos,
                "quaternion": self.quaternion,
                "vel": self.vel,
                "angvel": self.angvel,
            }
        )
        names = ("ang_vel_body", "ang_pos", "lin_vel_body", "pos", "quaternion", "vel", "angvel")
        columns = [arrays[name] for name in names]
        return [KinematicState(*(tuple(c[i].tolist()) for c in columns)) for i in rows.tolist()]

    def _distance(self, rows: np.ndarray) -> np.ndarray:
        d = self.pos[rows] - self.hover_point[rows]
        return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])

    def _read(self, rows: np.ndarray | None = None) -> None:
        if rows is None:
            kernels.read_out(
                self.pos,
                self.quat,
                self.vel,
                self.angvel,
                self.ang_vel_body,
                self.ang_pos,
                self.lin_vel_body,
                self.quaternion,
            )
            return
        k = len(rows)
        a, b, c, d = np.empty((k, 3)), np.empty((k, 3)), np.empty((k, 3)), np.empty((k, 4))
        kernels.read_out(self.pos[rows], self.quat[rows], self.vel[rows], self.angvel[rows], a, b, c, d)
        self.ang_vel_body[rows], self.ang_pos[rows], self.lin_vel_body[rows], self.quaternion[rows] = a, b, c, d

    # ------------------------------------------------------------------- step

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        a = np.asarray(actions, dtype=np.float64).reshape(n, -1)
        if a.shape[1] != self._low.size:
            raise ValueError(f"actions must be ({n}, {self._low.size}), got {np.shape(actions)}")
        live = self.alive.copy()
        a = np.minimum(np.maximum(a, self._low), self._high)
        a[~live] = 0.0  # retired agents receive nothing
        self.actions[:] = a
        if self.motor_noise:
            factors = normals.noise_factors(
                self.noise_rng, self.model.noise_ratio, np.empty((n, self.per_agent, self.model.motors))
            )
        else:
            factors = self._ones
        self.advance(a, factors)
        self.steps += 1
        self.episode_length += live
        self._read()

        collision = self.ground_contact | self.agent_contact
        p = self.pos
        out = p[:, 0] * p[:, 0] + p[:, 1] * p[:, 1] + p[:, 2] * p[:, 2] > self._dome2
        extras: dict[str, np.ndarray] = {}
        task_info: dict[str, np.ndarray] = {}
        if self._world_tasks is None:
            distance = self._distance(np.arange(n))
            rate = (distance - self._last_distance) / self.agent_dt
            self._last_distance = np.where(live, distance, self._last_distance)
        else:
            distance, rate, extras, task_info = self._world_tasks.update(
                lambda rows: self._states(rows), live, collision, self.steps, self._last_distance, self._extras
            )
        ends = self._ends
        crashed = (out & ends.dome) | (collision & ends.contact)  # by default: leaving the dome or any contact
        terminated = crashed & live  # (neither the hover nor the formation completes or fails an agent)
        truncated = ~terminated & live & (self.steps >= self._max_steps) & ends.time_limit
        ctx = BatchContext(
            ang_vel=self.ang_vel_body,
            ang_pos=self.ang_pos,
            lin_vel=self.lin_vel_body,
            lin_pos=p,
            action=self.actions,
            collision=collision,
            ground_collision=self.ground_contact & collision,
            out_of_bounds=out,
            crashed=crashed,
            task_complete=np.zeros(n, dtype=bool),
            target_distance=distance,
            target_distance_rate=rate,
            waypoint_reached=np.zeros(n, dtype=bool),
            steps_remaining=np.maximum(self._max_steps - self.steps, 0),
            agent_dt=self.agent_dt,
            extras=extras,
        )
        reward, _ = self.reward_function(ctx)
        reward = np.where(live, reward, 0.0)
        self.episode_return += reward
        success = truncated & bool(self.task_class.succeeds_at_time_limit)
        ended = terminated | truncated
        final = None
        if ended.any():  # the last observations, zeros in the other slots (zeroed in place: a
            # copy of the whole observation every step made glibc trim and regrow its heap)
            final = self._observe()
            bookkeeping.zero_unless(final, ended)
        self.alive &= ~ended
        self.armed &= ~ended
        over = ~self.alive.reshape(self.worlds, self.agents).any(axis=1)
        self.world_over[:] = np.repeat(over, self.agents)
        padding_end = self.world_over & ~live  # padding slots end with their world's episode
        done = ended | padding_end
        info: dict[str, Any] = {
            "collision": collision & live,
            "out_of_bounds": out & live,
            "env_complete": np.zeros(n, dtype=bool),
            "success": success,
            "target_distance": np.where(live, distance, 0.0),
            "agent_active": live,
            **{key: np.where(live, value, 0.0) for key, value in task_info.items()},
        }
        if ended.any():
            info["episode"] = {
                "r": np.where(ended, self.episode_return, 0.0),
                "l": np.where(ended, self.episode_length, 0),
            }
            info["_episode"] = ended
        if done.any():  # a world's padding slots end when its last agents end: final is made
            info["final_obs"] = final
            info["_final_obs"] = done
        for k in np.flatnonzero(over).tolist():
            self._reset_world(k)
        if self.randomizer is not None and over.any():  # the draws of the worlds that restart now
            info["randomization"] = self.randomizer.info()
            info["_randomization"] = self.world_over.copy()
        obs = self._observe()
        terminated_slots = terminated | padding_end
        return obs, reward, terminated_slots, truncated, info

    def advance(self, setpoints: np.ndarray, factors: np.ndarray) -> None:
        """One agent step of the physics for every world (setpoints already clipped; with
        latency, the actions given now, which reach the controllers later: BatchedLatency)."""
        self._reads[:] = self.pos  # the env read every vehicle after the last agent step
        self._normals = self.turbulence_normals()
        if self.latency is not None:
            self.latency.advance(self, setpoints, factors)
        else:
            self.physics(setpoints, factors, 0, self.per_agent)
        self.physics_steps += self.per_agent

    def physics(self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int) -> None:
        """``count`` physics steps of every world from offset ``start`` into the agent step,
        every control tick in them flying ``setpoints``; ``factors`` (N, count, motors) their
        motor noise.  The contacts are sampled at the end of each control period in them and
        at the end of the agent step (not at the end of a piece inside a control period).

        With noisy sensors one physics step at a time, every vehicle's sensors sampling its
        body at the start of each (as each PyBullet vehicle samples them before its loads,
        retired ones too): the pieces change no number of the flight (the latest reads carry
        over, a step ending inside a control period takes no contact sample), and the
        contact samples of the steps are gathered."""
        if self.sensors is None:
            self._physics(setpoints, factors, start, count)
            return
        ground = np.zeros(self.num_envs, dtype=bool)
        agent = np.zeros(self.num_envs, dtype=bool)
        steps = self.physics_steps + start
        for s in range(count):
            self.sensors.sample(steps + s, self.pos, self.quat, self.vel, self.angvel)
            self._physics(setpoints, np.ascontiguousarray(factors[:, s : s + 1]), start + s, 1)
            ground |= self.ground_contact
            agent |= self.agent_contact
        self.ground_contact[:] = ground
        self.agent_contact[:] = agent

    def _physics(self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int) -> None:
        """:meth:`physics` without the sensors: one compiled call (:func:`advance_swarm`) in
        mode ``rates_thrust`` or ``motors``; a cascade mode through :meth:`_advance_cascade`."""
        if self._cascade is not None:
            self._advance_cascade(setpoints, factors, start, count)
            return
        self._kernel(setpoints, factors, self.mode, start, count)

    def _advance_cascade(self, setpoints: np.ndarray, factors: np.ndarray, start: int, count: int) -> None:
        """``count`` physics steps from offset ``start`` in a cascade mode, as the single-agent
        backend flies one (:meth:`pyflyt_engine.batched.env.BatchedUAVEnv._advance_cascade`):
        per control period, every armed vehicle's controller tick
        (:func:`~pyflyt_engine.batched.modes.control_tick`) gives its motor commands from its
        state at the period's start, then the period's physics steps run in mode ``motors``
        with them (:func:`advance_swarm`).  That is the PyBullet engine's order: on a tick every
        vehicle is read and runs its controller before any vehicle steps its motors, and the
        controller reads the vehicle's state, not its air, so no vehicle's commands depend on
        another's.  A piece of a period that starts after its tick (latency's pieces) runs no
        tick: the motors keep the commands the tick gave (``command``).  The contact samples of
        the calls are gathered (each call samples its own periods' ends)."""
        per_control = self.per_control
        phase = int(self.physics_steps[0]) % per_control  # as _kernel's ticks: every world in phase
        ground = np.zeros(self.num_envs, dtype=bool)
        agent = np.zeros(self.num_envs, dtype=bool)
        whole = (start, count) == (0, self.per_agent)
        a, end = start, start + count
        while a < end:
            b = min(((phase + a) // per_control + 1) * per_control - phase, end)  # to the period's end, or the count's
            if (phase + a) % per_control == 0:  # the period's tick
                self._control_tick(setpoints)
            piece = (
                factors if whole and (a, b) == (start, end) else np.ascontiguousarray(factors[:, a - start : b - start])
            )
            self._kernel(self._commands, piece, MODE_MOTORS, a, b - a)
            ground |= self.ground_contact
            agent |= self.agent_contact
            a = b
        self.ground_contact[:] = ground
        self.agent_contact[:] = agent

    def _control_tick(self, setpoints: np.ndarray) -> None:
        """Every armed vehicle's controller tick into ``_commands``: the single-agent backend's
        :func:`~pyflyt_engine.batched.modes.control_tick` on the armed rows.  A disarmed vehicle
        runs no controller (``Vehicle.control_step``: its motors commanded 0, which
        :func:`advance_swarm` does), so its integrals and last rates stay as they were, as the
        PyBullet engine's retired vehicle keeps its controller's."""
        assert self._cascade is not None and self._cascade_rows is not None
        law, yaw_is_rate, heading_frame, position, altitude = self._cascade
        table, mass, window, max_tilt, rate_gains, control_inertia, gyro, mixer_rows = self._cascade_rows
        m = self.model
        c = m.cascade
        assert c is not None  # a multirotor's (check_swarm_supported refuses any other airframe)
        rows = None if self.armed.all() else np.flatnonzero(self.armed)
        if rows is not None and not rows.size:
            return

        def pick(x: np.ndarray) -> np.ndarray:  # every slot's arrays themselves, or the armed rows' copies
            return x if rows is None else np.ascontiguousarray(x[rows])

        integral, previous, has_previous = pick(self.integral), pick(self.previous), pick(self.has_previous)
        vel_integral, commands = pick(self.vel_integral), pick(self._commands)
        _modes.control_tick(
            pick(self.pos),
            pick(self.quat),
            pick(self.vel),
            pick(self.angvel),
            pick(setpoints),
            integral,
            previous,
            has_previous,
            vel_integral,
            law,
            yaw_is_rate,
            heading_frame,
            position,
            altitude,
            pick(table),
            pick(mass),
            pick(window),
            pick(max_tilt),
            pick(rate_gains),
            m.rate_derivative,
            pick(control_inertia),
            pick(gyro),
            pick(mixer_rows),
            self.control_dt,
            commands,
            m.lateral,
            c.trimmed,
            c.trim[0],
            c.trim[1],
        )
        if rows is not None:  # the armed rows' advanced controller state and commands back into their slots
            self.integral[rows], self.previous[rows], self.has_previous[rows] = integral, previous, has_previous
            self.vel_integral[rows], self._commands[rows] = vel_integral, commands

    def _controller_rows(self) -> tuple[np.ndarray, ...]:
        """A cascade mode's controller parameters, one row per slot, as
        :func:`~pyflyt_engine.batched.modes.control_tick` takes them: the outer loops' table,
        mass, integral window and tilt limit (:class:`~pyflyt_engine.batched.modes.CascadeParams`),
        the rate loop's gains, inertia and gyroscopic coefficients and the mixer's rows, all the
        airframe's nominal ones (domain randomisation leaves the controller as it is)."""
        m = self.model
        c = m.cascade
        assert c is not None
        n = self.num_envs
        rows = lambda a: np.ascontiguousarray(np.broadcast_to(a, (n, *np.shape(a))), dtype=np.float64)  # noqa: E731
        return (
            rows(c.table),
            rows(c.mass),
            rows(c.window),
            rows(c.max_tilt),
            rows(m.rate_gains),
            rows(m.control_inertia),
            rows(m.gyro),
            rows(m.mixer_rows),
        )

    def _kernel(self, setpoints: np.ndarray, factors: np.ndarray, mode: int, start: int, count: int) -> None:
        """One compiled call (:func:`advance_swarm`) of ``count`` physics steps from offset
        ``start`` into the agent step in ``mode``, sampling the contacts at its end when it ends
        the agent step."""
        m = self.model
        rot = self._wake_sources
        normals = self._normals
        if (start, count) != (0, normals.shape[1]) and normals.shape[2]:
            normals = np.ascontiguousarray(normals[:, start : start + count])
        phase = int(self.physics_steps[0]) % self.per_control + start
        advance_swarm(
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
            mode,
            self.armed,
            self.parked,
            self.agents,
            self._mass,
            self._inertia,
            m.control_inertia,
            m.gyro,
            self._lag,
            self._columns,
            m.mixer_rows,
            m.max_collective,
            m.rate_gains,
            m.rate_derivative,
            self._drag_factors,
            self._damping,
            m.drag,
            m.corners,
            self._box_centre,
            self._box_half,
            self._bound_radius,
            self.ground_contact,
            self.agent_contact,
            GRAVITY,
            self.physics_dt,
            self.control_dt,
            phase,
            count,
            self.per_control,
            self.downwash,
            self._wake_thrust,
            rot["is_rotor"],
            rot["disc_area"],
            rot["jet_diameter"],
            AIR_DENSITY,
            2.0,
            self._wind_rows,
            self.physics_steps + start,
            self._rotors,
            self.ground_effect,
            _air.GROUND_EFFECT_MIN_HEIGHT,
            self.turbulence,
            normals,
            self._dryden_rows,
            self._motor_model,
            self.model.motor_laws,
            self.battery,
            self._battery_params,
            self.model.battery_table,
            self._reads,
            start + count == self.per_agent,
        )

    def dryden_of(self, i: int) -> tuple:
        """Slot ``i``'s turbulence filter, the tuple the compiled laws take (``air.Dryden.arrays``):
        its rows of the per-slot filter arrays (its world's: the config's, or its episode's drawn wind's)."""
        return tuple(a[i] for a in self._dryden_rows)

    def turbulence_normals(self) -> np.ndarray:
        """The turbulence's white noise of one agent step, (worlds, physics steps, filter
        states) standard normal draws, each world's from its own stream (none without turbulence)."""
        if self.dryden is None:
            return self._no_normals
        out = np.empty((self.worlds, self.per_agent, self.dryden.states))
        for rng, row in zip(self.world_turbulence_rngs, out):
            rng.standard_normal(out=row)
        return out

    def _observe(self) -> np.ndarray:
        """Every slot's observation; with an observation delay, of every vehicle as it was
        ``n_o`` physics steps ago (the PyBullet env's ``delayed_state`` source: the agent's
        own attitude and throttles, and the task's entries from every agent's delayed state),
        the previous action the agent's own.  With observed sensors the agent's own state is
        then the one its sensors (or its estimator) show (the engine's ``sensor_state`` /
        ``estimator_state`` views, :meth:`BatchedSensors.observed`), the other agents' stay
        as the source gives them, and the fix's validity flag follows the throttles."""
        delayed = self.latency is not None and self.latency.observes
        if delayed:
            assert self.latency is not None
            seen = self.latency.observed(self)
        else:
            seen = {
                "ang_vel_body": self.ang_vel_body,
                "ang_pos": self.ang_pos,
                "lin_vel_body": self.lin_vel_body,
                "quaternion": self.quaternion,
                "pos": self.pos,
                "vel": self.vel,
                "angvel": self.angvel,
                "throttle": self.throttle,
                "battery": self.battery,
            }
        sensed = self.sensors is not None and self.sensors.source != OBSERVE_TRUE
        own = self.sensors.observed(seen) if sensed else seen  # type: ignore[union-attr]
        if self._world_tasks is None:
            extras = self.hover_point - own["pos"]
        elif delayed or sensed:
            own_state = self._own_states(seen, own) if sensed else None
            extras = self._world_tasks.observe(lambda rows: self._states(rows, seen), self._extras, own_state)
        else:
            extras = self._extras
        angles = own["quaternion"] if self._quaternion else own["ang_pos"]
        parts = [
            own["ang_vel_body"],
            angles,
            own["lin_vel_body"],
            own["pos"],
            self.actions,
            seen["throttle"],
        ]
        if self.battery.shape[1]:  # the battery's gauge closes the aux: its state of charge (BatteryGauge.aux)
            parts.append(seen["battery"][:, :1])
        if self._fix_flag:  # the position fix's validity, after the aux state
            parts.append(self.sensor_state[:, S_VALID : S_VALID + 1])
        parts.append(extras)
        obs = bookkeeping.stack_columns(parts)
        bookkeeping.zero_unless(obs, self.alive)  # padding: a retired agent's slot
        return obs

    def _own_states(self, seen: dict[str, np.ndarray], own: dict[str, np.ndarray]) -> Any:
        """Slot ``i``'s own state as its sensors or estimator show it (a task's view of it), as
        :func:`~pyflyt_engine.envs.observe.sensed_state` / ``estimated_state`` give it: the
        shown read-outs and position; the ground-frame rates the gyro's turned with the
        attitude shown; the ground-frame velocity the estimator's (sensed: the source's)."""
        sensors = self.sensors
        assert sensors is not None
        estimated = sensors.source == OBSERVE_ESTIMATED
        gyro = bool(sensors.params[P_IMU])

        def state(i: int) -> KinematicState:
            row = sensors.rows[i]
            q = tuple(own["quaternion"][i].tolist())
            ang_vel = tuple(own["ang_vel_body"][i].tolist())
            velocity = tuple(row[S_EST_VEL : S_EST_VEL + 3].tolist()) if estimated else tuple(seen["vel"][i].tolist())
            ang_ground = (
                exact.rotate(quaternion_to_rows(q), list(row[S_GYRO : S_GYRO + 3].tolist()))
                if gyro
                else tuple(seen["angvel"][i].tolist())
            )
            return KinematicState(
                ang_vel,
                tuple(own["ang_pos"][i].tolist()),
                tuple(own["lin_vel_body"][i].tolist()),
                tuple(own["pos"][i].tolist()),
                q,
                velocity,
                tuple(ang_ground),
            )

        return state

    def sensor_readings(self, i: int) -> dict[str, np.ndarray]:
        """Slot ``i``'s noisy sensors' latest readings by name (empty without sensors), as the
        PyBullet engine's ``Vehicle.sensor_readings`` gives them."""
        return self.sensors.readings(i) if self.sensors is not None else {}

    def close(self, **kwargs: Any) -> None:  # nothing to release: no PyBullet client
        self.closed = True


def _rotor_geometry(spec: UAVSpec) -> dict[str, Any]:
    """The downwash source of one airframe, as the PyBullet engine registers it
    (:meth:`pyflyt_engine.atmosphere.air.Atmosphere.add_vehicle` into
    :class:`RotorInteractions`): full thrust per motor, which motors are rotors, disc area and
    jet diameter."""
    from pyflyt_engine.assembly import assemble

    motors = assemble(spec).motors
    assert motors is not None  # a multirotor's (check_swarm_supported refuses any other airframe)
    hubs = motors.positions.tolist()
    radii: list[float | None] = [None] * len(hubs)
    if spec.motors is not None and spec.motors.prop_radius is not None:
        radii = spec.motors.to_array("prop_radius").tolist()
    rotors = RotorInteractions(False, True)
    rotors.add_vehicle(hubs, radii, motors.max_thrust.tolist())
    craft = rotors.vehicles[0]
    assert craft is not None
    return {
        "max_thrust": np.asarray(craft.max_thrust, dtype=np.float64),
        "is_rotor": np.array([bool(r) for r in craft.radii]),
        "disc_area": float(craft.disc_area),
        "jet_diameter": float(craft.jet_diameter) if craft.disc_area > 0.0 else 0.0,
    }


def _collision_box(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body-frame box (centre, half extents) about an airframe's collision features
    (:attr:`BatchedModel.corners`: points, spheres of their radius, discs of their radius)."""
    reach = corners[:, 3] + corners[:, 4]
    low = (corners[:, :3] - reach[:, None]).min(axis=0)
    high = (corners[:, :3] + reach[:, None]).max(axis=0)
    return np.ascontiguousarray(0.5 * (low + high)), np.ascontiguousarray(0.5 * (high - low))


def make_batched_swarm(name: Any, worlds: int = 1, seed: int | None = None, **env_overrides: Any) -> BatchedSwarmEnv:
    """``worlds`` worlds of a multi-agent hover config on the batched backend (a slot per agent)."""
    from pyflyt_engine.envs.config import load_env_config

    cfg = load_env_config(name)
    if env_overrides:
        cfg = cfg.with_overrides(**env_overrides)
    return BatchedSwarmEnv(cfg, worlds=worlds, seed=seed)


__all__ = [
    "SWARM_TASKS",
    "BatchedSwarmEnv",
    "advance_swarm",
    "boxes_overlap",
    "check_swarm_supported",
    "downwash_at",
    "downwash_velocity",
    "make_batched_swarm",
    "py_hypot",
    "rotor_thrust",
]
