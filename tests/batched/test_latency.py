"""Latency on the batched backend (pyflyt_engine.batched.latency): the PyBullet engine's
action and observation delays (docs/engine.md, "Latency"), fixed or drawn per episode.

The oracle is the PyBullet engine: the same airframe, mode, start, actions and delays
give the same trajectory, observations and rewards within test_crosscheck.py's bound,
1e-6, derived there (the delays change no law: they choose which setpoint a tick flies and
which recorded state an observation shows, both whole-step choices; a delay off by one
physics step moves the positions by more than 1e-3 within these 2 s, measured).  A ground
contact is sampled where the PyBullet engine samples it, which the pieces' structure is
checked against (the engine's own schedule).
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.batched.latency import BatchedLatency
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.randomization import Distribution, delay_steps
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.world import World

from tests.batched.test_crosscheck import AUTOPILOT_ACTION, BOUND, _flat, _pair, quiet  # noqa: F401  (a fixture)

HZ = 240.0

#: (action, observation) delays in physics steps at 240 Hz (8 per agent step, 2 per control tick):
#: none, one physics step, whole agent steps, and steps between ticks and between agent steps
DELAYS = [(0, 0), (1, 1), (3, 5), (16, 24), (13, 11), (0, 8), (20, 0)]

#: (env config, airframe, action override): a multirotor in rates_thrust and in a cascade mode,
#: the fixed-wing on its channels and through its autopilot
FLIGHTS = {
    "quadx_hover": ("quadx_hover", "quadx_cf2x", {}),
    "velocity": ("quadx_waypoints_velocity", "quadx_cf2x", {}),
    "fixedwing": ("fixedwing_waypoints", "fixedwing", {}),
    "fixedwing_autopilot": ("fixedwing_waypoints", "fixedwing", {"action": AUTOPILOT_ACTION}),
}


def _latency(steps: tuple[int, int]) -> dict[str, float]:
    return {"action_delay": steps[0] / HZ, "observation_delay": steps[1] / HZ}


def _action(be: BatchedUAVEnv, rng: np.random.Generator) -> np.ndarray:
    if be.config.action.mode == "rates_thrust":  # around hover
        return np.r_[rng.uniform(-1.0, 1.0, 3), be.model.hover_thrust_fraction * rng.uniform(0.95, 1.15)]
    return rng.uniform(np.array(be.config.action.low), np.array(be.config.action.high))


def fly_delayed_pair(
    uav: str, flight: str, delays: tuple[int, int], seed: int = 3, steps: int = 60
) -> tuple[dict[str, float], int]:
    """Both backends fly ``flight`` (:data:`FLIGHTS`) on airframe file ``uav`` with the
    (action, observation) ``delays`` [physics steps] from one start, ``steps`` agent steps
    of random actions; returns the largest differences of the positions, observations
    and rewards, and the steps flown.  The test below and ``experiments/batched_latency.py``
    (the documented figures) fly it."""
    env_name, _, overrides = FLIGHTS[flight]
    pb, be = _pair(env_name, uav, seed=seed, latency=_latency(delays), **overrides)
    assert pb.unwrapped.world.vehicles[0].latency == delays and be.latency_steps.tolist() == [list(delays)]
    rng = np.random.default_rng(7)
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0}
    for flown in range(1, steps + 1):
        action = _action(be, rng)
        o1, r1, t1, tr1, i1 = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        flat = _flat(o1)
        assert flat.shape == final.shape
        worst["position"] = max(worst["position"], np.abs(flat[10:13] - final[10:13]).max())
        worst["observation"] = max(worst["observation"], np.abs(flat - final).max())
        worst["reward"] = max(worst["reward"], abs(r1 - r2[0]))
        if t1 and i1["collision"] and not t2[0]:  # PyBullet's contact threshold: the batched crash comes next
            assert bool(be.step(action[None])[2][0]), "no crash in the batched env one agent step later"
            break
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        if t1 or tr1:
            break
    pb.close()
    return {k: float(v) for k, v in worst.items()}, flown


@pytest.mark.parametrize("delays", DELAYS)
@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_delayed_flights_agree_with_the_pybullet_engine(quiet, flight, delays):  # noqa: F811
    """2 s of random actions with the delays: positions, observations (the delayed state, the
    waypoint deltas from the delayed pose) and rewards (the true state) within 1e-6."""
    worst, flown = fly_delayed_pair(quiet[FLIGHTS[flight][1]], flight, delays)
    assert max(worst.values()) < BOUND, worst
    assert flown >= 30, "the flight ended too soon to compare much"


def _fly(cfg, actions: np.ndarray, seed: int = 5) -> dict[str, list[np.ndarray]]:
    env = BatchedUAVEnv(cfg, num_envs=actions.shape[1], motor_noise=False)
    obs, _ = env.reset(seed=seed)
    out: dict[str, list] = {"obs": [obs], "pos": [env.pos.copy()], "reward": [], "done": []}
    for a in actions:
        obs, reward, terminated, truncated, _ = env.step(a)
        out["obs"].append(obs)
        out["pos"].append(env.pos.copy())
        out["reward"].append(reward)
        out["done"].append(terminated | truncated)
    return out


def test_an_observation_delay_alone_flies_bit_for_bit_as_none_and_shows_the_past():
    """Observation delays of whole agent steps: the flight, rewards and episode ends are the
    undelayed ones bit for bit (an autoreset among them), and each observation's state part
    is the undelayed observation of that many agent steps before (the spawn's before the
    episode had them); a delay between agent steps flies bit for bit as none too."""
    cfg = load_env_config("quadx_hover")
    rng = np.random.default_rng(3)
    actions = np.concatenate(
        [rng.uniform([-1, -1, -1, 0.1], [1, 1, 1, 0.16], (50, 4, 4)), np.zeros((40, 4, 4))]
    )  # then motors off: every env crashes and resets
    plain = _fly(cfg, actions)
    assert np.any(plain["done"])
    for n_o in (16, 5, 11):
        delayed = _fly(cfg.with_overrides(latency=_latency((0, n_o))), actions)
        for key in ("pos", "reward", "done"):
            assert all(np.array_equal(a, b) for a, b in zip(plain[key], delayed[key])), (n_o, key)
    delayed = _fly(cfg.with_overrides(latency=_latency((0, 16))), actions)  # 2 agent steps
    start = np.zeros(4, dtype=np.int64)  # per env, the step its episode started at
    state = np.r_[0:13, 17:21]  # the state and the throttles; 13:17 is the previous action, the agent's own
    checked = 0
    for t in range(1, len(actions) + 1):
        start[plain["done"][t - 1]] = t  # reset at step t: its observation is the new spawn's
        for i in range(4):
            shown = max(t - 2, start[i])
            assert np.array_equal(delayed["obs"][t][i, state], plain["obs"][shown][i, state]), (t, i)
            checked += 1
    assert checked == 4 * len(actions)


def test_an_action_delay_of_whole_agent_steps_shifts_the_flight_bit_for_bit():
    """An action delay of 2 agent steps flies the undelayed flight of the same actions given
    2 steps later, zeros (the reset's setpoint) before them: positions bit for bit, also in
    a cascade mode and on the fixed-wing."""
    for name in ("quadx_hover", "quadx_waypoints_velocity", "fixedwing_waypoints"):
        cfg = load_env_config(name)
        low, high = np.array(cfg.action.low), np.array(cfg.action.high)
        rng = np.random.default_rng(4)
        actions = (
            rng.uniform(low, high, (30, 3, low.size))
            if name != "quadx_hover"
            else rng.uniform([-1, -1, -1, 0.12], [1, 1, 1, 0.15], (30, 3, 4))
        )
        shifted = np.concatenate([np.zeros((2, 3, low.size)), actions[:-2]])
        plain = _fly(cfg, shifted)
        delayed = _fly(cfg.with_overrides(latency=_latency((16, 0))), actions)
        assert not np.any(plain["done"])
        assert all(np.array_equal(a, b) for a, b in zip(plain["pos"], delayed["pos"])), name


def test_an_autoreset_starts_the_delays_afresh():
    """An env whose episode ended and reset flies its next episode bit for bit as a first
    episode from the same start: nothing of the last episode is in flight or shown."""
    cfg = load_env_config("quadx_waypoints").with_overrides(latency=_latency((13, 11)))
    env = BatchedUAVEnv(cfg, num_envs=2, motor_noise=False)
    env.reset(seed=2)
    rng = np.random.default_rng(0)
    for k in range(200):  # env 0 flies, then falls (no thrust, rates still asked for: in flight at its end)
        a = np.r_[
            [rng.uniform([-1, -1, -1, 0.12], [1, 1, 1, 0.15]) if k < 20 else [0.8, -0.6, 0.4, 0.0]],
            [[0.0, 0.0, 0.0, env.model.hover_thrust_fraction]],
        ]
        _, _, terminated, truncated, _ = env.step(a)
        if terminated[0] or truncated[0]:
            break
    assert terminated[0] and not terminated[1] and env.steps[0] == 0
    fresh = BatchedUAVEnv(cfg, num_envs=1, motor_noise=False)
    fresh.reset(seed=9)
    for name in ("pos", "quat", "vel", "angvel", "targets", "_last_position", "_last_distance"):
        getattr(fresh, name)[0] = getattr(env, name)[0]
    fresh._read()
    fresh.latency.restart(fresh, np.arange(1))
    first = env._observe()[0]
    assert np.array_equal(first, fresh._observe()[0])
    for _ in range(40):
        a = rng.uniform([-1, -1, -1, 0.12], [1, 1, 1, 0.15])
        o1, r1, *_ = env.step(np.r_[[a], [[0.0, 0.0, 0.0, env.model.hover_thrust_fraction]]])
        o2, r2, *_ = fresh.step(a[None])
        assert np.array_equal(o1[0], o2[0]) and r1[0] == r2[0]


@pytest.mark.parametrize("per_control", [1, 2, 4, 8])
def test_the_pieces_tick_and_sample_where_the_pybullet_engine_does(per_control):
    """Per-env delays (random, every residue): each piece flies one setpoint per env at its
    ticks (the one the engine's queue releases), its kept contact samples are exactly the
    engine's (World._schedule: the end of each control period and of the agent step), and
    every env's snapshot is taken at the start of the physics step its observation shows."""
    P = 8
    rng = np.random.default_rng(per_control)
    cfg = load_env_config("quadx_hover").with_overrides(
        control_hz=HZ / per_control,
        randomize={
            "action_delay": {"distribution": "uniform", "low": 0.0, "high": 0.2},
            "observation_delay": {"distribution": "uniform", "low": 0.0, "high": 0.2},
        },
    )
    latency = BatchedLatency(cfg, 64, P, per_control, 4, 4, 0)
    latency.steps[:] = rng.integers(0, 48, (64, 2))
    world = types.SimpleNamespace(physics_per_control=per_control, physics_per_agent=P, _schedules={})
    schedule = World._schedule(world, 0)  # type: ignore[arg-type]
    engine_samples = {s for s, (_, sample) in enumerate(schedule) if sample}
    kept, recorded = set(), np.zeros(64, dtype=np.int64)
    for start, stop, lag, sampled, record in latency._pieces():
        samples = {s for s in range(start, stop) if (s + 1) % per_control == 0 or s == stop - 1}  # the kernels'
        if sampled:
            assert samples <= engine_samples
            kept |= samples
        else:
            assert not samples & engine_samples, (start, stop)
        ticks = [s for s in range(start, stop) if schedule[s][0]]
        assert (lag is None) == (not ticks)
        for o in ticks:  # the engine's queue: the action given at t P is released at t P + n_a
            for t in (0, 1, 5, 9):
                j = t * P + o
                given = np.array(
                    [max((u for u in range(t + 1) if u * P + n_a <= j), default=-1) for n_a in latency.steps[:, 0]]
                )
                assert np.array_equal(np.where(t - lag < 0, -1, t - lag), given)
        if record is not None:
            recorded[record] += 1
            shown = (-latency.steps[record, 1]) % P
            assert np.all(shown == start)
    assert kept == engine_samples
    assert np.array_equal(recorded, (latency.steps[:, 1] > 0).astype(np.int64))


RANDOM_DELAYS = {
    "action_delay": {"distribution": "uniform", "low": 0.0, "high": 0.05},
    "observation_delay": {"distribution": "normal", "mean": 0.03, "std": 0.02, "low": 0.0, "high": 0.06},
}


def test_randomised_delays_are_drawn_per_env_and_episode_from_its_own_stream():
    """Each env draws its delays at every reset from its own generator, in the section's
    order and before its spawn (Distribution.sample, rounded by delay_steps): the same seed
    draws the same; a drawn episode flies bit for bit as the same delays fixed."""
    cfg = load_env_config("quadx_hover").with_overrides(randomize=RANDOM_DELAYS)
    env = BatchedUAVEnv(cfg, num_envs=16, motor_noise=False)
    env.reset(seed=7)
    children = np.random.SeedSequence(7).spawn(17)[1:]
    draws = {name: Distribution(**d) for name, d in RANDOM_DELAYS.items()}
    expected = []
    for child in children:
        rng = np.random.default_rng(child)
        expected.append([delay_steps(draws[name].sample(rng), HZ) for name in draws])
    assert env.latency_steps.tolist() == expected
    assert len({tuple(e) for e in expected}) > 8  # the envs drew apart
    assert np.all(env.latency_steps <= [12, 14]) and env.latency_steps.min() >= 0  # 0.05 s, 0.06 s
    again = BatchedUAVEnv(cfg, num_envs=16, motor_noise=False)
    again.reset(seed=7)
    assert np.array_equal(again.latency_steps, env.latency_steps) and np.array_equal(again.pos, env.pos)
    # env 3's episode flies as its delays, fixed
    i = 3
    fixed = BatchedUAVEnv(
        cfg.with_overrides(randomize={}, latency=_latency(tuple(env.latency_steps[i]))), num_envs=1, motor_noise=False
    )
    fixed.reset(seed=0)
    for name in ("pos", "quat", "vel", "angvel", "_last_position", "_last_distance"):
        getattr(fixed, name)[0] = getattr(env, name)[i]
    fixed._read()
    fixed.latency.restart(fixed, np.arange(1))
    rng = np.random.default_rng(1)
    for _ in range(30):
        a = rng.uniform([-1, -1, -1, 0.12], [1, 1, 1, 0.15], (16, 4))
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = fixed.step(a[i : i + 1])
        assert np.array_equal(o1[i], o2[0]) and r1[i] == r2[0]
    # a new episode draws anew: motors off until every env has reset once
    before = env.latency_steps.copy()
    reset = np.zeros(16, dtype=bool)
    for _ in range(300):
        _, _, terminated, truncated, _ = env.step(np.zeros((16, 4)))
        reset |= terminated | truncated
        if reset.all():
            break
    assert reset.all() and not np.array_equal(before, env.latency_steps)


def test_randomised_parameters_of_unsimulated_models_are_refused_by_name():
    """Beside the delays, an entry the batched backend does not draw per env (the wind's rotary
    span, which would change the turbulence filter's size) is refused by its name (the factors,
    spawn offsets and winds it draws: tests/batched/test_randomization.py, test_randomization_wind.py)."""
    factor = {"distribution": "uniform", "low": 0.9, "high": 1.1}
    span = "wind.turbulence.rotary_min_span"
    for entries, named in (
        ({span: factor}, f"randomize.{span}"),
        ({**RANDOM_DELAYS, "drag": factor, span: factor}, f"randomize.{span}"),
    ):
        cfg = load_env_config("quadx_hover").with_overrides(backend="batched", randomize=entries, wind="dryden_light")
        with pytest.raises(ConfigError) as info:
            BatchedUAVEnv(cfg, num_envs=2)
        message = str(info.value)
        assert "env.backend=batched does not simulate" in message and named in message, message


def test_across_an_episode_end_both_drop_what_was_in_flight(quiet):  # noqa: F811
    """Delays (13, 11) physics steps, a spawn without noise: both backends fly, crash with
    rates still asked for (in flight at the crash), and start again -- the batched env by
    its same-step autoreset, the PyBullet env by its reset; the next episode's observations
    and rewards agree within 1e-6 from its first observation on (nothing in flight, the
    spawn shown)."""
    pb, be = _pair(
        "quadx_hover",
        quiet["quadx_cf2x"],
        seed=1,
        latency=_latency((13, 11)),
        start_position_noise=0.0,
        start_orientation_noise=0.0,
    )
    rng = np.random.default_rng(5)
    for _ in range(15):
        a = _action(be, rng)
        o1, r1, *_ = pb.step(a)
        o2, r2, *_ = be.step(a[None])
        assert np.abs(_flat(o1) - o2[0]).max() < BOUND and abs(r1 - r2[0]) < BOUND
    crash = np.array([0.8, -0.6, 0.4, 0.0])  # no thrust, rates asked for
    ended = {"pybullet": None, "batched": None}
    for k in range(300):
        if ended["pybullet"] is None:
            _, _, t1, _, i1 = pb.step(crash)
            ended["pybullet"] = k if t1 else None
        if ended["batched"] is None:
            o2, _, t2, _, i2 = be.step(crash[None])
            ended["batched"] = k if t2[0] else None
            start = o2[0]  # after the autoreset: the next episode's first observation
        if None not in ended.values():
            break
    assert i1["collision"] and bool(i2["collision"][0]) and 0 <= ended["batched"] - ended["pybullet"] <= 1, ended
    assert be.steps[0] == 0 and not be.action_history[0].any()  # the autoreset emptied the queue
    o1, _ = pb.reset(seed=2)
    assert np.abs(_flat(o1) - start).max() < BOUND
    for _ in range(40):
        a = _action(be, rng)
        o1, r1, t1, *_ = pb.step(a)
        o2, r2, t2, *_ = be.step(a[None])
        assert np.abs(_flat(o1) - o2[0]).max() < BOUND and abs(r1 - r2[0]) < BOUND
        assert not t1 and not t2[0]
    pb.close()


@pytest.mark.parametrize(
    "rates",
    [
        {"control_hz": 240.0, "agent_hz": 40.0},
        {"control_hz": 60.0, "agent_hz": 30.0},
        {"physics_hz": 480.0, "control_hz": 120.0, "agent_hz": 40.0},
    ],
)
def test_other_loop_rates_agree_with_the_pybullet_engine(quiet, rates):  # noqa: F811
    """A tick at every physics step, 4 physics steps per tick, 480 Hz physics (6, 8 and 12
    physics steps per agent step): QuadX-Hover with delays of 13 and 23 physics steps,
    within 1e-6 of the PyBullet engine for 2 s."""
    hz = rates.get("physics_hz", HZ)
    pb, be = _pair(
        "quadx_hover",
        quiet["quadx_cf2x"],
        seed=3,
        latency={"action_delay": 13 / hz, "observation_delay": 23 / hz},
        **rates,
    )
    assert pb.unwrapped.world.vehicles[0].latency == (13, 23)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(int(2 * be.config.agent_hz)):
        a = _action(be, rng)
        o1, r1, t1, *_ = pb.step(a)
        o2, r2, t2, *_ = be.step(a[None])
        assert not t1 and not t2[0]
        worst = max(worst, np.abs(_flat(o1) - o2[0]).max(), abs(r1 - r2[0]))
    assert worst < BOUND
    pb.close()
