"""The cascade flight modes in the batched multi-agent worlds (pyflyt_engine.batched.swarm with
pyflyt_engine.batched.modes) against the PyBullet engine's multi-agent envs.

A world in a cascade mode runs, per control period, every armed vehicle's controller tick
(the single-agent backend's ``control_tick``: the same compiled loops, bit for bit the
engine's in tests/batched/test_modes.py) from the state at the tick, then the period's
physics in mode ``motors`` with the commands it gave.  That is the engine's order
(``World.step``: on a tick every vehicle is read and runs its controller before any steps
its motors; the controller reads the state, not the air).

The bound, 1e-6 (tests/batched/test_swarm.py's), and why it holds here: the laws of the
world -- the downwash among them -- are the engine's, so the backends differ by the rigid
body's last bits per physics step (~eps |x|) and by what the controller makes of them.  The
outer loops are continuous in the state except where the mixer's square root meets a motor
asked for almost no thrust (the single-agent cascade argument, tests/batched/test_crosscheck.py:
a throttle difference of up to sqrt(eps) ~ 1.5e-8 for a tick, at most ~3e-7 m over 2 s were
every tick to push the same way); the setpoints here keep every motor near hover thrust, so
that branch is not met, and the downwash couples a lower vehicle to the upper one's position
and throttles continuously.  The assertions hold positions, observations, rewards, motor
commands and the controllers' integrals (velocity and rate loop, retired vehicles' too) to
1e-6; the measured differences are printed (2e-16 to 5e-15 on these flights: docs/batched.md).

The setpoints are drawn per agent around its own spawn (positions and altitudes within
5 cm of it, tilts within 0.05 rad, velocities within 0.2 m/s, yaw and rates within 0.5),
so the stacked agents stay in each other's wakes and clear of each other for 2 s.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.atmosphere import rotors as R
from pyflyt_engine.batched import check_supported, modes, swarm
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.envs.config import load_env_config
from tests.batched.test_swarm import BOUND, STACKED, _pair, quiet_cf2x  # noqa: F401 - the fixture

#: per setpoint entry, how far from the agent's own spawn (positions) or zero it is drawn
SPREAD = {
    "x": 0.05,
    "y": 0.05,
    "z": 0.05,
    "roll": 0.05,
    "pitch": 0.05,
    "yaw": 0.5,
    "yaw_rate": 0.5,
    "p": 0.5,
    "q": 0.5,
    "r": 0.5,
    "u": 0.2,
    "v": 0.2,
    "vx": 0.2,
    "vy": 0.2,
    "vz": 0.1,
}


def cascade_action(mode: str) -> dict:
    """An action section of cascade mode ``mode``: its setpoint's entries, a range that holds
    every setpoint the flights below give (the spawns are within 2 m of the origin)."""
    names = list(MULTIROTOR_MODES[mode].setpoint)
    return {"mode": mode, "names": names, "units": ["1"] * 4, "low": [-3.0] * 4, "high": [3.0] * 4}


def setpoints(mode: str, rng: np.random.Generator, home: np.ndarray) -> np.ndarray:
    """(agents, 4) setpoints of ``mode`` around each agent's ``home`` (its spawn position)."""
    out = np.zeros((len(home), 4))
    for c, name in enumerate(MULTIROTOR_MODES[mode].setpoint):
        centre = home[:, "xyz".index(name)] if name in ("x", "y", "z") else 0.0
        out[:, c] = centre + rng.uniform(-SPREAD[name], SPREAD[name], len(home))
    return out


def fly(pb, be, mode: str, rng: np.random.Generator, steps: int, home: np.ndarray, away=None):
    """Both backends for ``steps`` agent steps of :func:`setpoints` (``away``: the setpoints of
    some agents replaced, ``{agent: setpoint}``); the worst differences of every live agent's
    position, observation and reward and of every vehicle's motor commands and controller
    integrals (a retired vehicle's too: its controller no longer runs in either), the agent
    steps flown and the ends ``(step, agent)``."""
    names = pb.possible_agents
    worst = dict.fromkeys(("position", "observation", "reward", "command", "integral"), 0.0)
    ends = []
    flown = 0
    for step in range(1, steps + 1):
        live = list(pb.agents)
        if not live:
            break
        actions = setpoints(mode, rng, home)
        for agent, target in (away or {}).items():
            actions[agent] = target
        actions[[i for i, name in enumerate(names) if name not in live]] = 0.0
        o1, r1, t1, tr1, _ = pb.step({name: actions[pb.agent_index[name]] for name in live})
        o2, r2, t2, tr2, info = be.step(actions)
        flown = step
        final = info.get("final_obs", o2)
        for name in live:
            i = pb.agent_index[name]
            assert (t1[name], tr1[name]) == (bool(t2[i]), bool(tr2[i])), (step, name)
            ended = t2[i] or tr2[i]
            got = final[i] if ended else o2[i]
            worst["position"] = max(worst["position"], np.abs(o1[name][10:13] - got[10:13]).max())
            worst["observation"] = max(worst["observation"], np.abs(o1[name] - got).max())
            worst["reward"] = max(worst["reward"], abs(r1[name] - r2[i]))
            if ended:
                ends.append((step, name))
        if not be.world_over[0]:  # the world goes on (a restart would clear the batched controllers)
            for i, vehicle in enumerate(pb.vehicles):
                controller = vehicle.controller
                commands = np.subtract(vehicle.actuators.motors.command, be.command[i])
                integrals = np.r_[
                    np.subtract(controller._vel_integral, be.vel_integral[i]),
                    np.subtract(controller._rate_integral, be.integral[i]),
                ]
                worst["command"] = max(worst["command"], np.abs(commands).max())
                worst["integral"] = max(worst["integral"], np.abs(integrals).max())
    return {k: float(v) for k, v in worst.items()}, flown, ends


def _home(be) -> np.ndarray:
    return np.array([agent.spawn.position for agent in be.agent_list], dtype=np.float64)


def _wakes_blow(be, lower=(0, 2)) -> np.ndarray:
    """The down-wind the lower agents of the stacks feel now (negative: down)."""
    rot = be._wake_sources
    return np.array(
        [
            swarm.downwash_at(
                k,
                *be.pos[k],
                be.pos,
                be.throttle,
                be._wake_thrust,
                rot["is_rotor"],
                rot["disc_area"],
                rot["jet_diameter"],
                R.AIR_DENSITY,
                2.0,
            )
            for k in lower
        ]
    )


# ---------------------------------------------------------------------------- cross-checks


@pytest.mark.parametrize("mode", list(modes.CASCADE_MODES))
def test_stacked_agents_in_each_cascade_mode_agree_with_the_pybullet_engine(quiet_cf2x, mode):  # noqa: F811
    """MAQuadX-Hover with downwash on the stacked layout (each upper agent's wake on the lower
    one), 2 s of setpoints around each agent's spawn in every cascade mode: every live agent's
    position, observation and reward, every vehicle's motor commands and controller integrals
    within 1e-6 of the PyBullet engine's, no agent lost."""
    pb, be = _pair(quiet_cf2x, 0, downwash=True, action=cascade_action(mode))
    assert pb.vehicles[0].controller.mode.name == mode and be._cascade is not None
    home = _home(be)
    rng = np.random.default_rng(20)
    worst, flown, ends = fly(pb, be, mode, rng, 1, home)
    wakes = [_wakes_blow(be)]
    for _ in range(59):
        more, step, ended = fly(pb, be, mode, rng, 1, home)
        worst = {k: max(worst[k], more[k]) for k in worst}
        flown, ends = flown + step, ends + ended
        wakes.append(_wakes_blow(be))
    wakes = np.array(wakes)
    print(f"{mode}: {worst}; the lower agents' down-wind {wakes.max(axis=0)} to {wakes.min(axis=0)} m/s")
    assert (wakes.mean(axis=0) < -0.1).all()  # the lower agents flew in the upper ones' wakes
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 60 and not ends, ends


def test_a_formation_in_velocity_yawrate_agrees_with_the_pybullet_engine(quiet_cf2x):  # noqa: F811
    """MAQuadX-Formation (4 agents, downwash, its own task object per world) in velocity_yawrate,
    each agent asked for the formation's velocity give or take 0.2 m/s: within 1e-6 for 2 s."""
    mode = "velocity_yawrate"
    pb, be = _pair(quiet_cf2x, 1, agents=4, env="ma_quadx_formation", downwash=True, action=cascade_action(mode))
    rng = np.random.default_rng(21)
    velocity = np.array(be.config.task.velocity)
    worst = None
    names = pb.possible_agents
    total = dict.fromkeys(("position", "observation", "reward", "command", "integral"), 0.0)
    for _ in range(60):  # the formation's velocity plus the draws
        drift = np.zeros((be.num_envs, 4))
        drift[:, [0, 1, 3]] = velocity
        target = {a: drift[a] + setpoints(mode, rng, _home(be))[a] for a in range(len(names))}
        worst, flown, ends = fly(pb, be, mode, rng, 1, _home(be), away=target)
        assert flown == 1 and not ends, ends
        total = {k: max(total[k], worst[k]) for k in total}
    print(f"formation, {mode}: {total}")
    moved = be.pos[:, 0] - _home(be)[:, 0]
    pb.close()
    assert max(total.values()) < BOUND, total
    assert (np.abs(moved - 2.0 * velocity[0]) < 0.2).all(), moved  # the agents did move with the formation


def test_a_retired_agent_keeps_its_controller_and_the_others_fly_on_as_in_the_pybullet_engine(quiet_cf2x):  # noqa: F811
    """position_yaw on the stacked layout in a 1.9 m dome: the upper agent of the first stack is
    sent out of the dome, retires (disarmed: motors 0, no controller) in the same step in both
    backends and falls away; its controller's integrals stay where they were, as the engine's
    do, and the others fly on within 1e-6."""
    mode = "position_yaw"
    pb, be = _pair(quiet_cf2x, 2, downwash=True, action=cascade_action(mode), flight_dome_size=1.9)
    home = _home(be)
    away = {1: np.array([-2.5, 1.5, 0.0, 1.35])}
    rng = np.random.default_rng(22)
    total = dict.fromkeys(("position", "observation", "reward", "command", "integral"), 0.0)
    ends, frozen = [], None
    for step in range(1, 61):
        worst, flown, ended = fly(pb, be, mode, rng, 1, home, away=away)
        assert flown == 1
        total = {k: max(total[k], worst[k]) for k in total}
        ends += [(step, name) for _, name in ended]
        if ended:  # its controller's memory as it retired
            frozen = be.vel_integral[1].copy(), be.integral[1].copy(), be.previous[1].copy()
    print(f"retired agent, {mode}: {total}, ends {ends}")
    pb.close()
    assert [name for _, name in ends] == ["uav_1"], ends
    assert 10 < ends[0][0] < 50 and not be.armed[1] and be.armed[[0, 2, 3]].all()
    assert be.parked[1] and not be.parked[[0, 2, 3]].any()  # it fell and lies on the ground
    assert max(total.values()) < BOUND, total
    assert frozen is not None and np.abs(frozen[0]).max() > 0.0  # it had integrated before it retired
    assert np.array_equal(frozen[0], be.vel_integral[1]) and np.array_equal(frozen[1], be.integral[1])
    assert np.array_equal(frozen[2], be.previous[1])


@pytest.mark.parametrize("mode", ["attitude_z", "velocity_yawrate"])
def test_delayed_stacked_agents_in_a_cascade_mode_agree_with_the_pybullet_engine(quiet_cf2x, mode):  # noqa: F811
    """The stacked layout with downwash and fixed delays (3 physics steps of action delay, ticks
    every 2: the released setpoint changes between them; 5 of observation delay: a piece ends
    inside a control period), each backend's own spawn from the same generator: within 1e-6."""
    from tests.batched.test_swarm_latency import FIXED, _paired

    cfg = load_env_config("ma_quadx_hover").with_overrides(
        uav=quiet_cf2x, agents=STACKED, downwash=True, latency=FIXED, action=cascade_action(mode)
    )
    pb, be, start, first = _paired(cfg, 6)
    spawned = max(np.abs(start[name] - first[i]).max() for i, name in enumerate(pb.possible_agents))
    worst, flown, ends = fly(pb, be, mode, np.random.default_rng(23), 60, _home(be))
    worst["spawn"] = spawned
    print(f"delayed, {mode}, delays {pb.latency_steps}: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 60 and not ends, ends


def test_randomised_stacked_agents_in_a_cascade_mode_agree_with_the_pybullet_engine(quiet_cf2x):  # noqa: F811
    """Every randomize entry drawn (the airframe factors, spawn offsets, delays), the controller
    left nominal in both, each backend's own drawn spawn: position_yaw on the stacked layout
    with downwash within 1e-6 for 2 s."""
    from tests.batched.test_randomization import DRAWS
    from tests.batched.test_swarm_randomization import _generators, _pybullet

    mode = "position_yaw"
    cfg = load_env_config("ma_quadx_hover").with_overrides(
        uav=quiet_cf2x, agents=STACKED, downwash=True, randomize=DRAWS, action=cascade_action(mode)
    )
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    first, info = be.reset(seed=5)
    pb, start, pb_info = _pybullet(cfg, _generators(5, 1)[0])
    names = pb.possible_agents
    assert all(pb_info[n]["randomization"] == {e: float(v[0]) for e, v in info["randomization"].items()} for n in names)
    assert not np.array_equal(be._mass, np.full_like(be._mass, be.model.mass))  # drawn away from the nominal
    spawned = max(np.abs(start[n] - first[i]).max() for i, n in enumerate(names))
    worst, flown, ends = fly(pb, be, mode, np.random.default_rng(24), 60, _home(be))
    worst["spawn"] = spawned
    print(f"randomised, {mode}: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 60 and not ends, ends


# ---------------------------------------------------------------------------- the env


def _run(cfg, worlds: int = 3, steps: int = 40, seed: int = 5) -> np.ndarray:
    env = swarm.BatchedSwarmEnv(cfg, worlds=worlds, seed=seed)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    out = [obs]
    for _ in range(steps):
        obs, reward, term, trunc, _ = env.step(rng.uniform(env._low, env._high, (env.num_envs, 4)))
        out += [obs, reward, term, trunc, env.vel_integral]
    return np.concatenate([np.ravel(x).astype(np.float64) for x in out])


def test_same_seed_same_numbers():
    """A cascade mode with motor noise, downwash and worlds restarting (agents crashing on
    random setpoints): the same seed flies the same numbers; another seed others."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(
        downwash=True, action=cascade_action("attitude_z"), max_duration_seconds=0.5
    )
    a, b = _run(cfg), _run(cfg)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, _run(cfg, seed=6))


def test_a_restarted_world_flies_as_a_fresh_one_from_the_same_spawn():
    """A world whose agents all crash restarts with its controllers cleared (velocity and rate
    integrals, last rates): from its new spawn it flies bit for bit as a fresh env put at that
    spawn, while the other world, mid-episode, is not disturbed."""
    mode = "position_yaw"
    cfg = load_env_config("ma_quadx_hover").with_overrides(downwash=True, action=cascade_action(mode), agents=2)
    env = swarm.BatchedSwarmEnv(cfg, worlds=2, seed=3, motor_noise=False)
    env.reset(seed=3)
    home = np.tile(_home(env), (2, 1))
    rng = np.random.default_rng(4)
    restarted = False
    for _ in range(90):  # world 0 flies into the ground, world 1 holds its spawn
        actions = setpoints(mode, rng, home)
        actions[:2, 3] = -1.0
        _, _, term, _, info = env.step(actions)
        if term[:2].all():
            restarted = True
            break
    assert restarted and env.alive.all() and (env.steps[:2] == 0).all() and (env.steps[2:] > 0).all()
    assert not env.vel_integral[:2].any() and not env.integral[:2].any() and not env.has_previous[:2].any()
    fresh = swarm.BatchedSwarmEnv(cfg, worlds=1, seed=9, motor_noise=False)
    fresh.reset(seed=9)
    for name in ("pos", "quat", "vel", "angvel"):
        getattr(fresh, name)[:] = getattr(env, name)[:2]
    fresh._read()
    fresh._reset_world_task(0)
    for _ in range(30):
        actions = setpoints(mode, rng, home)
        env.step(actions)
        fresh.step(actions[:2])
        assert np.array_equal(env.pos[:2], fresh.pos) and np.array_equal(env.vel_integral[:2], fresh.vel_integral)


def test_pieces_of_a_control_period_change_no_number_of_the_flight():
    """An observation delay splits each agent step into pieces, one ending 3 physics steps into
    a 2-step control period (the next starts inside it and runs no tick), and noisy sensors
    (observed) run the physics one step at a time: the true flight in a cascade mode is bit for
    bit the undelayed one without sensors (the controller reads the true state, as the
    engine's does); an action delay changes it."""
    from tests.batched.test_swarm_sensors import SENSED

    mode = "velocity_yawrate"
    cfg = load_env_config("ma_quadx_hover").with_overrides(downwash=True, action=cascade_action(mode))
    runs = {}
    for name, extra in (
        ("none", {}),
        ("seen", {"latency": {"observation_delay": 0.0208}}),
        ("sensed", {"sensors": SENSED, "latency": {"observation_delay": 0.0208}}),
        ("acted", {"latency": {"action_delay": 0.0125}}),
    ):
        env = swarm.BatchedSwarmEnv(cfg.with_overrides(**extra) if extra else cfg, worlds=2, seed=1)
        env.reset(seed=1)
        rng = np.random.default_rng(2)
        home = np.tile(_home(env), (2, 1))
        for _ in range(30):
            env.step(setpoints(mode, rng, home))
        runs[name] = np.r_[env.pos.ravel(), env.quat.ravel(), env.vel_integral.ravel(), env.integral.ravel()]
    assert np.array_equal(runs["none"], runs["seen"]) and np.array_equal(runs["none"], runs["sensed"])
    assert np.abs(runs["acted"] - runs["none"]).max() > 1e-4


def test_a_checkpoint_restores_the_controllers_bit_for_bit():
    """``episode_state`` / ``restore_episode`` of every slot in a cascade mode with delays and
    downwash: the velocity loop's integrals are in the checkpoint, and the steps after a
    restore (worlds restarting among them) repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("ma_quadx_hover").with_overrides(
        backend="batched",
        downwash=True,
        action=cascade_action("position_yawrate"),
        latency={"action_delay": 0.0125, "observation_delay": 0.0208},
        max_duration_seconds=0.5,
    )
    vec = make_vec_env(cfg, 2)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    n = vec.num_envs
    for _ in range(5):
        vec.step(rng.uniform(-0.3, 0.3, (n, 4)).astype(np.float32))
    saved = vec.env_method("episode_state")
    env = vec.env
    assert np.asarray(saved[0]["batched"]["vel_integral"]).shape == (3,)
    assert any(np.abs(s["batched"]["vel_integral"]).max() > 0.0 for s in saved)
    actions = rng.uniform(-0.3, 0.3, (20, n, 4)).astype(np.float32)
    first = [vec.step(a) for a in actions]
    assert any(done.any() for _, _, done, _ in first)  # worlds restarted after the checkpoint
    for name in ("vel_integral", "integral", "previous", "command", "action_history"):
        getattr(env, name)[:] = 1  # state the restore must put back
    env.has_previous[:] = False
    for i in range(n):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a) for a in actions]
    for (o1, r1, d1, _), (o2, r2, d2, _) in zip(first, again):
        assert np.array_equal(o1, o2) and np.array_equal(r1, r2) and np.array_equal(d1, d2)


def test_every_multirotor_mode_is_flown_and_a_mode_not_wired_in_is_refused_by_name(monkeypatch):
    """Every flight mode the single-agent backend flies on a multirotor the worlds fly too; a
    mode the worlds do not list is refused by name with the modes they do fly."""
    from pyflyt_engine.batched.model import BATCHED_MODES, UnsupportedByBatched

    assert set(swarm.SWARM_MODES) == set(BATCHED_MODES)
    for mode in modes.CASCADE_MODES:
        check_supported(load_env_config("ma_quadx_hover").with_overrides(action=cascade_action(mode)))
    monkeypatch.setattr(swarm, "SWARM_MODES", ("rates_thrust", "motors"))
    with pytest.raises(UnsupportedByBatched, match="flight mode rates_z in a multi-agent world.*rates_thrust, motors"):
        check_supported(load_env_config("ma_quadx_hover").with_overrides(action=cascade_action("rates_z")))
