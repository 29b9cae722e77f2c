"""Training on the batched backend: the SB3 adapter, the run's record, evaluation in the
PyBullet engine, exact resume, determinism under a seed across processes."""

from __future__ import annotations

from pyflyt_engine.paths import uav_dir

import subprocess
import sys

import numpy as np
import pytest
import yaml
from stable_baselines3 import PPO

from pyflyt_cli.training import resume, train
from pyflyt_cli.training.batched import BatchedVecEnv
from pyflyt_cli.training.envs import EnvFactory, make_vec_env
from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.errors import ConfigError

from tests.conftest import default_subset
from tests.train.conftest import load
from tests.train.test_resume import SignalAt, _assert_same, _outcome, _reference

#: an action delay between control ticks and an observation delay drawn per episode
LATENCY = [
    "+env.latency.action_delay=0.0125",
    "+env.randomize.observation_delay={distribution: uniform, low: 0.0, high: 0.05}",
]
PPO_BATCHED = [
    "env=quadx_hover",
    "algo=ppo",
    "env.backend=batched",
    "train.n_envs=8",
    "train.total_timesteps=2000",
    "algo.n_steps=64",
    "algo.batch_size=128",
    "algo.n_epochs=2",
    "train.eval_freq=512",
    "train.eval_episodes=1",
    "train.checkpoint_freq=512",
    "train.progress_bar=false",
]
SAC_BATCHED = [
    "env=quadx_waypoints",
    "algo=sac",
    "env.backend=batched",  # with the waypoint SAC tuning's curriculum, cut to the budget
    "train.n_envs=4",
    "train.total_timesteps=800",
    "train.curriculum.goal_reach_distance.steps=800",
    "algo.buffer_size=5000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=200",
    "train.eval_episodes=1",
    "train.checkpoint_freq=200",
    "train.progress_bar=false",
]


@pytest.mark.parametrize("env_name", ["quadx_hover", "quadx_waypoints", "quadx_waypoints_velocity"])
def test_the_adapter_shows_the_agent_what_the_pybullet_training_env_shows(env_name):
    cfg = load_env_config(env_name).with_overrides(backend="batched")
    vec = make_vec_env(cfg, 3)
    assert isinstance(vec, BatchedVecEnv)
    single = EnvFactory(cfg, monitor=False)()  # the PyBullet engine's env through the training wrappers
    assert vec.observation_space == single.observation_space
    assert vec.action_space == single.action_space
    vec.seed(0)
    obs = vec.reset()
    assert obs.shape == (3, *single.observation_space.shape) and obs.dtype == np.float32
    ended, sums = [], np.zeros(3)
    for _ in range(400):
        obs, rewards, dones, infos = vec.step(np.full((3, 4), -1.0))  # the range's bottom: no thrust, or 2 m/s down
        sums += rewards
        ended += [(info, sums[i]) for i, (info, done) in enumerate(zip(infos, dones)) if done]
        sums[dones] = 0.0
        if len(ended) >= 3:
            break
    assert len(ended) >= 3
    for info, total in ended:
        assert info["episode"]["l"] > 0 and info["episode"]["r"] < -90.0  # the crash pays -100
        assert info["episode"]["r"] == pytest.approx(total, abs=1e-4)  # float32 rewards summed here
        assert info["terminal_observation"].shape == single.observation_space.shape
        assert info["TimeLimit.truncated"] is False and info["episode"]["success"] is False
    single.close()


def test_a_curriculum_changes_the_episodes_that_start_after_it():
    """``set_task_changes`` (a training curriculum's) reaches every env's next episode; an
    option the task does not let an episode change is refused by name."""
    cfg = load_env_config("quadx_waypoints").with_overrides(backend="batched")
    vec = make_vec_env(cfg, 4, curriculum=True)
    vec.seed(0)
    vec.reset()
    assert vec.env.reach.tolist() == [0.2] * 4
    vec.env_method("set_task_changes", {"goal_reach_distance": 1.0, "start_position_noise": 0.0})
    assert vec.env.reach.tolist() == [0.2] * 4  # episodes in progress keep theirs
    for _ in range(300):
        _, _, dones, _ = vec.step(np.full((4, 4), -1.0))  # motors off: every episode ends
        if dones.all():
            break
    assert vec.env.reach.tolist() == [1.0] * 4
    assert np.allclose(vec.env.pos[:, :2], 0.0) and np.allclose(vec.env.pos[:, 2], 1.0)  # no spawn noise
    with pytest.raises(ConfigError, match="cannot change per episode"):
        vec.env_method("set_task_changes", {"num_targets": 2})


def test_same_seed_same_numbers_in_another_process():
    code = (
        "import numpy as np\n"
        "from pyflyt_engine.envs import make_batched_env\n"
        "env = make_batched_env('quadx_waypoints', n_envs=5, seed=11)\n"
        "obs, _ = env.reset(seed=11)\n"
        "rng = np.random.default_rng(0)\n"
        "out = [obs]\n"
        "for _ in range(120):\n"
        "    o, r, t, tr, _ = env.step(np.c_[rng.uniform(-1, 1, (5, 3)), rng.uniform(0.1, 0.16, (5, 1))])\n"
        "    out += [o, r[:, None]]\n"
        "print(np.concatenate([x.ravel() for x in out]).tobytes().hex())\n"
    )
    runs = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
        for _ in range(2)
    ]
    assert runs[0] == runs[1] and len(runs[0]) > 1000
    other = BatchedUAVEnv("quadx_waypoints", num_envs=5)
    first, _ = other.reset(seed=12)
    assert np.frombuffer(bytes.fromhex(runs[0][: first.nbytes * 2])).tolist() != first.ravel().tolist()


def test_auto_trains_batched_where_it_simulates_the_config_and_records_which(tmp_path):
    """``env.backend: auto`` (the hover and waypoints PPO default): batched for the shipped hover, PyBullet for a
    variant the batched backend does not simulate (downwash, the rocket) or with an imitation stage; the resolved
    backend is the run's configuration.  Asked for by name, batched refuses that variant."""
    assert load(["env=quadx_hover"], tmp_path).env.backend == "batched"
    assert load(["env=quadx_hover", "env.wind=gust"], tmp_path).env.backend == "batched"  # a deterministic wind
    assert load(["env=quadx_hover", "env.ground_effect=true"], tmp_path).env.backend == "batched"
    assert load(["env=quadx_hover", "env.wind=dryden_moderate"], tmp_path).env.backend == "batched"  # turbulence too
    assert load(["env=quadx_hover", "env.downwash=true"], tmp_path).env.backend == "pybullet"
    assert load(["env=quadx_hover", "uav=tricopter"], tmp_path).env.backend == "batched"  # its gimbal too
    assert load(["env=quadx_hover", "uav=rocket"], tmp_path).env.backend == "pybullet"
    assert load(["env=quadx_waypoints"], tmp_path).env.backend == "batched"  # its PPO tuning is auto too
    assert load(["env=quadx_waypoints", "env.action.mode=velocity"], tmp_path).env.backend == "batched"  # every mode
    assert load(["env=quadx_waypoints_velocity", "env.backend=auto"], tmp_path).env.backend == "batched"
    assert (
        load(["env=quadx_waypoints", "env.action.mode=velocity", "env.downwash=true"], tmp_path).env.backend
        == "pybullet"
    )
    assert load(["env=quadx_gates"], tmp_path).env.backend == "pybullet"  # its tuning keeps the default
    assert load(["env=quadx_hover", *LATENCY], tmp_path).env.backend == "batched"  # delays, fixed and drawn
    assert load(["env=quadx_hover_sensors", "env.backend=auto"], tmp_path).env.backend == "batched"  # the estimator
    assert (
        load(
            ["env=quadx_hover", "+env.randomize.mass={distribution: uniform, low: 0.9, high: 1.1}"], tmp_path
        ).env.backend
        == "batched"
    )  # airframe factors and spawn offsets, drawn per env
    assert load(["env=quadx_hover", "env.randomize=sim2real"], tmp_path).env.backend == "batched"
    # the optional motor models and the pack, drawn per env
    assert (
        load(
            [
                f"env.uav={uav_dir() / 'examples' / 'quadx_cf2x_battery.yaml'}",
                "+env.randomize.battery_capacity={distribution: uniform, low: 0.9, high: 1.1}",
            ],
            tmp_path,
        ).env.backend
        == "batched"
    )
    # a draw it does not make per env (a wind's, which only an env YAML can declare) trains on
    # PyBullet: tests/batched/test_randomization.py
    with pytest.raises(ConfigError, match="does not simulate env.downwash"):
        load(["env=quadx_hover", "env.backend=batched", "env.downwash=true"], tmp_path)


def test_ppo_learns_a_little_on_it():
    vec = make_vec_env(load_env_config("quadx_hover").with_overrides(backend="batched"), 8)
    model = PPO("MlpPolicy", vec, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(512)
    assert model.num_timesteps == 512


def test_a_run_records_its_backend_and_evaluates_in_the_pybullet_engine(tmp_path):
    result = train(load(PPO_BATCHED, tmp_path))
    config = yaml.safe_load((result.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched"
    assert yaml.safe_load((result.run_dir / "run.yaml").read_text())["backend"] == "batched"
    # the evaluations are the PyBullet engine's: fly the final policy there by hand, same seed
    from pyflyt_cli.training.evaluate import evaluate_run

    report = evaluate_run(result.run_dir, {"episodes": 2, "record": True})
    recorded = sorted((result.run_dir / "episodes").glob("ep_*.mcap"))
    assert len(recorded) == 2
    # the recordings re-simulate in the PyBullet engine with no deviation: they were flown there
    from pyflyt_engine.telemetry.episode import load_episode
    from pyflyt_engine.telemetry.replay import verify

    for path in recorded:
        check = verify(load_episode(path))
        assert check.steps > 0 and check.max_deviation == 0.0 and check.max_reward_deviation == 0.0
    assert len(report.episodes) == 2


@pytest.mark.parametrize("run", default_subset(["ppo", "sac"], lambda name: name == "ppo"))
def test_a_stop_anywhere_then_resume_is_bit_identical(tmp_path, tmp_path_factory, run):
    overrides = PPO_BATCHED if run == "ppo" else SAC_BATCHED
    reference = _reference(overrides, tmp_path_factory)
    first = train(load(overrides, tmp_path), callbacks=[SignalAt(700 if run == "ppo" else 333)])
    assert first.interrupted
    resumed = resume(first.run_dir)
    assert not resumed.interrupted
    _assert_same(_outcome(first.run_dir), reference)


def test_a_stop_then_resume_in_turbulence_is_bit_identical(tmp_path, tmp_path_factory):
    """Hover PPO in Dryden turbulence: stopped mid-run and resumed, the run ends where an
    uninterrupted one does (each env's turbulence filter and white-noise stream carried)."""
    overrides = [*PPO_BATCHED, "env.wind=dryden_light"]
    reference = _reference(overrides, tmp_path_factory)
    first = train(load(overrides, tmp_path), callbacks=[SignalAt(700)])
    assert first.interrupted
    resumed = resume(first.run_dir)
    assert not resumed.interrupted
    _assert_same(_outcome(first.run_dir), reference)


def test_the_fixedwing_adapter_shows_the_agent_what_the_pybullet_training_env_shows():
    cfg = load_env_config("fixedwing_waypoints").with_overrides(backend="batched")
    vec = make_vec_env(cfg, 2)
    assert isinstance(vec, BatchedVecEnv)
    single = EnvFactory(cfg, monitor=False)()
    assert vec.observation_space == single.observation_space  # (31,): 23 attitude + 2 waypoints' deltas and mask
    assert vec.action_space == single.action_space
    single.close()


def test_a_fixedwing_checkpoint_carries_the_flaps():
    """``episode_state`` then ``restore_episode`` puts every env back where it was, the flap
    deflections and commands included: the steps after it repeat bit for bit."""
    vec = make_vec_env(load_env_config("fixedwing_waypoints").with_overrides(backend="batched"), 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(1)
    for _ in range(10):
        vec.step(rng.uniform(-1.0, 1.0, (3, 4)))
    saved = vec.env_method("episode_state")
    assert np.abs(vec.env.deflection).max() > 0.0 and "deflection" in saved[0]["batched"]
    actions = rng.uniform(-1.0, 1.0, (20, 3, 4))
    first = [vec.step(a)[0] for a in actions]
    vec.env.deflection[:] = 0.0  # state the restore must put back
    vec.env.flap_command[:] = 0.0
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


@pytest.mark.parametrize("env_name", ["quadx_hover", "fixedwing_waypoints"])
def test_a_checkpoint_in_turbulence_carries_the_filters_and_their_streams(env_name):
    """Dryden turbulence: ``episode_state`` then ``restore_episode`` puts every env's filter
    state and its white-noise stream back: the steps after it repeat bit for bit."""
    vec = make_vec_env(load_env_config(env_name).with_overrides(backend="batched", wind="dryden_light"), 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    for _ in range(10):
        vec.step(rng.uniform(-0.3, 0.3, (3, 4)))
    saved = vec.env_method("episode_state")
    assert np.abs(vec.env.turbulence).min() > 0.0 and "turbulence" in saved[0]["batched"]
    actions = rng.uniform(-0.3, 0.3, (20, 3, 4))
    first = [vec.step(a)[0] for a in actions]
    vec.env.turbulence[:] = 0.0  # state the restore must put back
    for g in vec.env.turbulence_rngs:
        g.standard_normal(7)
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_a_checkpoint_in_a_cascade_mode_carries_the_velocity_integrals():
    """The velocity variant: ``episode_state`` then ``restore_episode`` puts the velocity
    loop's integrals back with the rest: the steps after it repeat bit for bit."""
    vec = make_vec_env(load_env_config("quadx_waypoints_velocity").with_overrides(backend="batched"), 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(2)
    for _ in range(10):
        vec.step(rng.uniform(-0.5, 0.5, (3, 4)))
    saved = vec.env_method("episode_state")
    assert np.abs(vec.env.vel_integral).min() > 0.0 and "vel_integral" in saved[0]["batched"]
    actions = rng.uniform(-0.5, 0.5, (20, 3, 4))
    first = [vec.step(a)[0] for a in actions]
    vec.env.vel_integral[:] = 0.0  # state the restore must put back
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_a_checkpoint_carries_the_delays():
    """Delays drawn per episode: ``episode_state`` then ``restore_episode`` puts each env's
    delays, the actions in flight and the states it will show back with the rest: the steps
    after it repeat bit for bit."""
    cfg = load_env_config("quadx_hover").with_overrides(
        backend="batched",
        latency={"action_delay": 0.0125},
        randomize={"observation_delay": {"distribution": "uniform", "low": 0.0, "high": 0.05}},
    )
    vec = make_vec_env(cfg, 3)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    for _ in range(10):
        vec.step(rng.uniform(-0.3, 0.3, (3, 4)))
    saved = vec.env_method("episode_state")
    env = vec.env
    assert env.latency_steps[:, 0].tolist() == [3] * 3 and len(set(env.latency_steps[:, 1].tolist())) > 1
    assert np.abs(env.action_history).max() > 0.0 and "observed_history" in saved[0]["batched"]
    actions = rng.uniform(-0.3, 0.3, (20, 3, 4))
    first = [vec.step(a)[0] for a in actions]
    env.latency_steps[:, 1] = 0  # state the restore must put back
    env.action_history[:] = 0.0
    env.observed_history[:] = 0.0
    for i in range(3):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_a_stop_then_resume_with_latency_is_bit_identical(tmp_path, tmp_path_factory):
    """PPO on the batched backend with a fixed action delay and a drawn observation delay:
    a run stopped and resumed ends bit for bit as the one that ran through."""
    overrides = [*PPO_BATCHED, *LATENCY]
    reference = _reference(overrides, tmp_path_factory)
    first = train(load(overrides, tmp_path), callbacks=[SignalAt(700)])
    assert first.interrupted
    config = yaml.safe_load((first.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched" and config["env"]["latency"]["action_delay"] == 0.0125
    resumed = resume(first.run_dir)
    assert not resumed.interrupted
    _assert_same(_outcome(first.run_dir), reference)


LATENCY_PPO_BATCHED = [
    "env=quadx_hover",
    "+env.latency.action_delay=0.02",
    "env.backend=batched",
    "train.n_envs=64",
    "train.total_timesteps=8192",
    "algo.n_steps=64",
    "algo.batch_size=1024",
    "train.eval_freq=8192",
    "train.eval_episodes=1",
    "train.progress_bar=false",
]


def test_hover_with_an_action_delay_trains_end_to_end_on_it(tmp_path):
    """``pyflyt train env=quadx_hover +env.latency.action_delay=0.02 env.backend=batched``
    with a tiny budget: it trains on 64 delayed batched envs, records the delay, and
    evaluates in the PyBullet engine with the same delay."""
    result = train(load(LATENCY_PPO_BATCHED, tmp_path))
    assert not result.interrupted
    config = yaml.safe_load((result.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched" and config["env"]["latency"]["action_delay"] == 0.02
    assert result.num_timesteps == 8192 and result.last_eval_step == 8192
    from pyflyt_engine.telemetry.metrics import read_metrics

    assert read_metrics(result.run_dir / "metrics.mcap")["/train/episode"]
    from pyflyt_cli.training.evaluate import evaluate_run

    report = evaluate_run(result.run_dir, {"episodes": 1, "record": True})
    (recorded,) = sorted((result.run_dir / "episodes").glob("ep_*.mcap"))
    from pyflyt_engine.telemetry.episode import load_episode
    from pyflyt_engine.telemetry.replay import verify

    episode = load_episode(recorded)
    assert episode.config["latency"]["action_delay"] == 0.02  # flown in PyBullet with the delay
    check = verify(episode)
    assert check.steps > 0 and check.max_deviation == 0.0
    assert isinstance(report.batched, dict) and report.batched["episodes"] == 1.0  # and on the batched backend


VELOCITY_PPO_BATCHED = [
    "env=quadx_waypoints_velocity",
    "env.backend=batched",
    "train.n_envs=64",
    "train.total_timesteps=8192",
    "algo.n_steps=64",
    "algo.batch_size=1024",
    "train.eval_freq=8192",
    "train.eval_episodes=1",
    "train.progress_bar=false",
]


def test_the_velocity_variant_trains_end_to_end_on_it(tmp_path):
    """QuadX-Waypoints flown by ground velocity (mode velocity_yawrate, the controller's
    outer loops compiled: pyflyt_engine.batched.modes), PPO on 64 batched envs, a tiny
    budget: it trains, records the batched backend, and evaluates in the PyBullet engine."""
    result = train(load(VELOCITY_PPO_BATCHED, tmp_path))
    assert not result.interrupted
    config = yaml.safe_load((result.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched" and config["env"]["action"]["mode"] == "velocity_yawrate"
    assert yaml.safe_load((result.run_dir / "run.yaml").read_text())["backend"] == "batched"
    assert result.num_timesteps == 8192 and result.last_eval_step == 8192  # evaluated (in PyBullet) at the end
    from pyflyt_engine.telemetry.metrics import read_metrics

    assert read_metrics(result.run_dir / "metrics.mcap")["/train/episode"]  # batched episodes ended and were counted


GUSTY_PPO_BATCHED = [
    "env=quadx_hover",
    "env.wind=gust",
    "env.backend=batched",
    "train.n_envs=64",
    "train.total_timesteps=8192",
    "algo.n_steps=64",
    "algo.batch_size=1024",
    "train.eval_freq=8192",
    "train.eval_episodes=1",
    "train.progress_bar=false",
]


def test_hover_in_a_gust_trains_end_to_end_on_it(tmp_path):
    """``pyflyt train env=quadx_hover env.wind=gust env.backend=batched``, a tiny budget: the
    batched envs fly the gust (pyflyt_engine.batched.air), the run records both, and the
    evaluation flies the PyBullet engine in the same gust."""
    result = train(load(GUSTY_PPO_BATCHED, tmp_path))
    assert not result.interrupted
    config = yaml.safe_load((result.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched" and config["env"]["wind"] == "gust"
    assert result.num_timesteps == 8192 and result.last_eval_step == 8192


FIXEDWING_SAC_BATCHED = [
    "env=fixedwing_waypoints",
    "algo=sac",
    "env.backend=batched",
    "train.n_envs=64",
    "train.total_timesteps=6400",
    "train.curriculum.goal_reach_distance.steps=6400",  # its tuning's curriculum, cut to the budget
    "algo.buffer_size=10000",
    "algo.learning_starts=1280",
    "algo.batch_size=64",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=3200",
    "train.eval_episodes=1",
    "train.checkpoint_freq=3200",
    "train.progress_bar=false",
]


@pytest.mark.long
def test_fixedwing_sac_trains_end_to_end_on_it(tmp_path):
    """The fixed-wing SAC on 64 batched envs, a tiny budget: it trains (gradient steps taken,
    its curriculum on the reach sphere), records the batched backend, and evaluates in the
    PyBullet engine."""
    result = train(load(FIXEDWING_SAC_BATCHED, tmp_path))
    assert not result.interrupted
    config = yaml.safe_load((result.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched" and config["train"]["n_envs"] == 64
    assert yaml.safe_load((result.run_dir / "run.yaml").read_text())["backend"] == "batched"
    assert result.num_timesteps == 6400 and result.last_eval_step == 6400  # evaluated (in PyBullet) at the end
    from pyflyt_engine.telemetry.metrics import read_metrics

    metrics = read_metrics(result.run_dir / "metrics.mcap")
    assert metrics["/train/progress"][-1]["update_seconds"] > 0.0  # SAC's gradient steps ran
    assert metrics["/train/episode"]  # batched episodes ended and were counted
    assert metrics["/train/curriculum"][-1]["goal_reach_distance"] < 10.0  # its curriculum moved
    from pyflyt_cli.training.evaluate import evaluate_run

    report = evaluate_run(result.run_dir, {"episodes": 1})
    assert len(report.episodes) == 1


def test_eval_of_a_batched_run_also_flies_the_batched_backend_and_says_why_not_when_it_cannot(tmp_path):
    """The run's report shows both engines: the PyBullet engine's episodes row by row, and the
    same policy's success on the batched backend it trained on (in eval.json too); an env change
    the batched backend does not simulate gets the reason instead."""
    import json

    from pyflyt_cli.training.evaluate import evaluate_run

    run = train(load(PPO_BATCHED, tmp_path)).run_dir
    report = evaluate_run(run, {"episodes": 3, "record": False})
    assert isinstance(report.batched, dict) and report.batched["episodes"] == 3.0
    assert 0.0 <= report.batched["success_rate"] <= 1.0
    assert "waypoints_reached" not in report.batched  # hover has none
    assert json.loads((run / "eval.json").read_text())["batched"] == report.batched
    assert "batched:      success" in report.table()
    gusty = evaluate_run(run, {"episodes": 1, "record": False}, env={"wind": "gust"})  # a gust: flown there too
    assert isinstance(gusty.batched, dict) and gusty.batched["episodes"] == 1.0
    washed = evaluate_run(run, {"episodes": 1, "record": False}, env={"downwash": True})
    assert isinstance(washed.batched, str) and washed.batched.startswith("not flown") and "downwash" in washed.batched


def test_fly_episodes_counts_each_env_s_first_episode_as_the_env_reports_it():
    """Zero thrust: every env falls and crashes, so no success; each env's return is the
    ``episode`` return the batched env itself reports when that env's first episode ends."""
    from pyflyt_cli.training.batched import fly_episodes

    config = load_env_config("quadx_waypoints").with_overrides(backend="batched")
    n = 6
    zero = np.tile(np.array([0.0, 0.0, 0.0, -1.0], dtype=np.float32), (n, 1))  # thrust -1: the range's bottom, 0
    out = fly_episodes(lambda obs, det: zero, None, config, n, seed=3)
    env = BatchedUAVEnv(config, num_envs=n)
    env.reset(seed=3)
    first = np.full(n, np.nan)
    while np.isnan(first).any():  # in the env's units: no rates, no thrust
        _, _, terminated, truncated, info = env.step(np.zeros((n, 4)))
        ended = (terminated | truncated) & np.isnan(first)
        if ended.any():
            first[ended] = info["episode"]["r"][ended]
    assert out["success_rate"] == 0.0 and out["waypoints_reached"] == 0.0 and out["all_reached"] == 0.0
    assert out["mean_return"] == pytest.approx(float(first.mean()), rel=0, abs=1e-9)
