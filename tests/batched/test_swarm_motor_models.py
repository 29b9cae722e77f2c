"""The optional motor models and the battery in the batched multi-agent worlds
(pyflyt_engine.batched.swarm) against the PyBullet engine's multi-agent envs.

The worlds' kernel steps a modelled airframe's motors with the single-agent backend's
compiled laws (:func:`~pyflyt_engine.batched.kernels.modelled_load`: the asymmetric lag, the
inflow ratios and rotor drag at the rotor's velocity through the air, the pack's voltage and
its step; tests/batched/test_motor_models.py holds them bit for bit to the engine's
``ModelledMotors`` and ``Battery``), each vehicle's at the air its body drag takes (the
wind and the others' downwash in it), in the engine's order.  So the bound is
tests/batched/test_swarm.py's, 1e-6, on every live agent's position, observation (the pack's
state of charge closes each agent's aux) and reward, and on every vehicle's charge; the
measured differences are printed.  The wakes stay the engine's (``RotorInteractions.thrust``:
each rotor's full thrust times ``x |x|``, without the pack's sag).
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from pyflyt_engine.batched import check_supported, resolve_backend, swarm
from tests.batched.test_motor_models import MODEL_DRAWS, _example, _only, _quiet
from tests.batched.test_swarm import BOUND, MOTORS_ACTION, STACKED, _pair
from tests.batched.test_swarm_air import GUST, LOW
from tests.batched.test_swarm_cascade import _home, cascade_action, setpoints


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The example airframe (every model and a pack) and its variant with the inflow model
    alone, motor noise off (the two backends draw it apart)."""
    folder = tmp_path_factory.mktemp("swarm_modelled")
    out = {}
    for name, data in (("example", _example()), ("only_inflow", _only("inflow"))):
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(_quiet(data)))
        out[name] = str(path)
    return out


def _actions(be, rng: np.random.Generator, mode: str, home: np.ndarray, rise: float = 0.1) -> np.ndarray:
    """Every slot's action: random rates, and a collective around hover at each pack's sag that
    holds each agent near its spawn height (the lower agents of the stacks fly in the upper ones'
    wakes, which take thrust off their inflow rotors) ``rise`` above it; in mode motors each motor at that
    collective's throttle; in a cascade mode setpoints around each agent's spawn."""
    if mode not in ("rates_thrust", "motors"):
        return setpoints(mode, rng, home)
    out = np.zeros((be.num_envs, be.single_action_space.shape[0]))
    for i in range(be.num_envs):
        sag = be.battery[i, 3] ** 2 if be.model.has_battery else 1.0
        target = home[i % be.agents, 2] + rise
        hold = np.clip(1.0 + 2.0 * (target - be.pos[i, 2]) - 1.0 * be.vel[i, 2], 0.5, 2.0)
        thrust = be.model.hover_thrust_fraction / sag * hold
        if mode == "motors":
            out[i] = np.sqrt(thrust) * rng.uniform(0.97, 1.05, be.model.motors)
        else:
            out[i] = np.r_[rng.uniform(-0.3, 0.3, 3), thrust * rng.uniform(0.95, 1.05)]
    return out


def fly(pb, be, rng: np.random.Generator, steps: int, mode: str = "rates_thrust", rise: float = 0.1):
    """Both backends ``steps`` agent steps of :func:`_actions`; the worst differences of every
    live agent's position, observation and reward and of every vehicle's charge, the steps
    flown, the ends ``(step, agent)``, the charge the packs used and the agents' highest heights."""
    names = pb.possible_agents
    worst = dict.fromkeys(("position", "observation", "reward", "charge"), 0.0)
    ends = []
    flown = 0
    home = _home(be)
    highest = be.pos[:, 2].copy()
    for step in range(1, steps + 1):
        live = list(pb.agents)
        if not live:
            break
        actions = _actions(be, rng, mode, home, rise)
        actions[[i for i, name in enumerate(names) if name not in live]] = 0.0
        o1, r1, t1, tr1, _ = pb.step({name: actions[pb.agent_index[name]] for name in live})
        o2, r2, t2, tr2, info = be.step(actions)
        flown = step
        highest = np.maximum(highest, be.pos[:, 2])
        final = info.get("final_obs", o2)
        for name in live:
            i = pb.agent_index[name]
            assert (t1[name], tr1[name]) == (bool(t2[i]), bool(tr2[i])), (step, name)
            ended = t2[i] or tr2[i]
            got = final[i] if ended else o2[i]
            assert o1[name].shape == got.shape
            worst["position"] = max(worst["position"], np.abs(o1[name][10:13] - got[10:13]).max())
            worst["observation"] = max(worst["observation"], np.abs(o1[name] - got).max())
            worst["reward"] = max(worst["reward"], abs(r1[name] - r2[i]))
            if ended:
                ends.append((step, name))
        if not be.world_over[0] and be.model.has_battery:  # the world goes on (a restart resets the batched packs)
            for i, vehicle in enumerate(pb.vehicles):
                worst["charge"] = max(worst["charge"], abs(vehicle.battery.charge - be.battery[i, 0]))
    used = 1.0 - be.battery[:, 0] if be.model.has_battery else np.zeros(be.num_envs)
    return {k: float(v) for k, v in worst.items()}, flown, ends, used, highest


def _gauge_index(be) -> int:
    """Where an observation holds the agent's state of charge: the aux's last entry (after the
    throttles), before the task's entries (and the fix flag)."""
    attitude = 3 + (4 if be._quaternion else 3) + 3 + 3 + be._low.size
    return attitude + be.model.aux_size - 1


#: four agents 1 m apart at 1 m, out of each other's wakes
FAR = [
    {"spawn": {"position": [x, y, 1.0], "position_noise": 0.0, "orientation_noise": 0.05}}
    for x in (0, 1)
    for y in (0, 1)
]


#: (env config, overrides, mode, agent steps): the stacks with downwash in rates_thrust and in
#: motors, the stacks in a gust (the rotors at their velocity through the wind and the wakes),
#: the stacks' lower agents low in ground effect (without the upper ones: in their wakes the
#: Crazyflie's pack sags too far to hold them up there), the formation, and a cascade mode
#: holding position (the controller's ticks, then the physics in mode motors) with the agents
#: 1 m apart (its loops are tuned for the nominal thrust: in the wakes the sagging lower agents
#: of the stacks sink to the ground).  Open loop
#: (motors) the stacks tumble after ~1.2 s (tests/batched/test_swarm.py) and the formation's
#: random rates bring two agents into contact after ~1.5 s: those fly 1 s
FLIGHTS = {
    "stacked_rates": ("ma_quadx_hover", {"agents": STACKED, "downwash": True}, "rates_thrust", 59),
    "stacked_motors": ("ma_quadx_hover", {"agents": STACKED, "downwash": True}, "motors", 29),
    "stacked_gust": ("ma_quadx_hover", {"agents": STACKED, "downwash": True, "wind": GUST}, "rates_thrust", 59),
    "ground_effect": (
        "ma_quadx_hover",
        {"agents": [LOW[0], LOW[2]], "downwash": True, "ground_effect": True},
        "rates_thrust",
        59,
    ),
    "formation": ("ma_quadx_formation", {"agents": 4, "downwash": True}, "rates_thrust", 29),
    "position_yaw": ("ma_quadx_hover", {"agents": FAR, "downwash": True}, "position_yaw", 59),
}


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_modelled_worlds_agree_with_the_pybullet_engine(files, flight):
    """2 s of random actions (1 s open loop and in the formation): every live agent's position,
    observation and reward and every vehicle's charge within 1e-6 of the PyBullet engine's,
    no agent lost; each observation ends its aux with the vehicle's charge; the packs were
    drawn on."""
    env_name, overrides, mode, steps = FLIGHTS[flight]
    if mode == "motors":
        overrides = {**overrides, "action": MOTORS_ACTION}
    elif mode != "rates_thrust":
        overrides = {**overrides, "action": cascade_action(mode)}
    pb, be = _pair(files["example"], 3, env=env_name, **overrides)
    assert be.model.motor_laws and be.model.has_battery
    # low in ground effect the agents hold 2 cm above their spawns (rotors 10-11 cm up, where the
    # Crazyflie's 2.25 cm rotors still gain thrust), the others 10 cm
    rise = 0.02 if flight == "ground_effect" else 0.1
    worst, flown, ends, used, highest = fly(pb, be, np.random.default_rng(30), steps, mode, rise)
    print(f"{flight}: {worst}, ends {ends}; charge used {used.min():.2e} to {used.max():.2e}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == steps and not ends, ends
    assert (used > 0.0).all()
    if flight == "ground_effect":
        assert highest.max() < 0.13, highest
    obs = be._observe()
    assert np.array_equal(obs[:, _gauge_index(be)], be.battery[:, 0])


def test_the_inflow_model_alone_agrees_with_the_pybullet_engine(files):
    """A model without a pack (the inflow rotor alone: no gauge in the observation), the stacks
    with downwash: within 1e-6 for 2 s."""
    pb, be = _pair(files["only_inflow"], 4, downwash=True)
    assert be.model.motor_laws and not be.model.has_battery and be.battery.shape == (be.num_envs, 0)
    worst, flown, ends, *_ = fly(pb, be, np.random.default_rng(31), 59)
    print(f"inflow alone: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends


def test_a_world_restarts_with_full_packs_and_the_others_drain_on(files):
    """Two worlds: world 0 restarts (its packs back to their initial charge, as Battery.reset
    puts them), world 1 keeps draining."""
    from pyflyt_engine.envs.config import load_env_config

    cfg = load_env_config("ma_quadx_hover").with_overrides(uav=files["example"])
    be = swarm.BatchedSwarmEnv(cfg, worlds=2, motor_noise=False)
    be.reset(seed=0)
    start = be.battery[:, 0].copy()
    rng = np.random.default_rng(0)
    for _ in range(20):
        be.step(_actions(be, rng, "rates_thrust", _home(be)))
    drained = be.battery[:, 0].copy()
    assert (drained < start).all()
    be._reset_world(0)
    a = be.agents
    assert np.array_equal(be.battery[:a], be._battery_reset[:a])
    assert np.array_equal(be.battery[a:, 0], drained[a:])


def test_drawn_model_factors_agree_and_a_checkpoint_resumes_exactly(files):
    """Every motor and pack factor drawn (at fixed values, so both backends fly the same), four
    agents out of each other's wakes (with a pack at 85 % and 1.5 times its resistance the lower
    agents of the stacks sink): within 1e-6 for 2 s; then a
    checkpoint of a two-world vec env, worlds restarting in it, resumes bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env
    from pyflyt_engine.envs.config import load_env_config

    pb, be = _pair(files["example"], 5, agents=FAR, randomize=MODEL_DRAWS)
    assert be.battery[0, 0] == MODEL_DRAWS["battery_charge"]["low"]
    worst, flown, ends, *_ = fly(pb, be, np.random.default_rng(32), 59)
    print(f"drawn factors: {worst}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 59 and not ends

    cfg = load_env_config("ma_quadx_hover").with_overrides(
        uav=files["example"], backend="batched", randomize=MODEL_DRAWS, max_duration_seconds=0.5
    )
    vec = make_vec_env(cfg, 2)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    n = vec.num_envs
    env = vec.env
    for _ in range(5):
        vec.step(_actions(env, rng, "rates_thrust", _home(env)).astype(np.float32))
    saved = vec.env_method("episode_state")
    for name in ("battery", "_motor_model", "_battery_params", "_battery_reset"):
        assert name in saved[0]["batched"], name
    actions = [_actions(env, rng, "rates_thrust", _home(env)).astype(np.float32) for _ in range(20)]
    first = []
    for a in actions:
        first.append((vec.step(a)[0], env.battery.copy()))
    for name in ("battery", "_motor_model", "_battery_params", "_battery_reset"):
        getattr(env, name)[:] = 1.0  # state the restore must put back
    for i in range(n):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [(vec.step(a)[0], env.battery.copy()) for a in actions]
    assert all(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) for a, b in zip(first, again))


def test_a_modelled_multi_agent_config_is_batched_under_auto(files):
    from pyflyt_engine.envs.config import load_env_config

    cfg = load_env_config("ma_quadx_hover").with_overrides(uav=files["example"])
    check_supported(cfg)
    assert resolve_backend(cfg.with_overrides(backend="auto")) == "batched"
