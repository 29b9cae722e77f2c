"""Every number that costs time or memory is bounded by one table (``pyflyt_engine/limits.py``), documented
in docs/reproducibility.md, and each limit is checked here: just above it is refused in one line naming the
key, within it is accepted.  YAML documents with a key given twice, and alias bombs in command-line
``env.<key>=`` values, are refused by the bounded reader.

Written from the reproductions: ``env.physics_hz: 3e9`` in a run's config, a recording's metadata or on the
command line hung ``eval`` / ``replay --verify`` at gigabytes; ``env.render.resolution: [100000, 100000]``
crashed or ate ~40 GB; ``pyflyt fly rows=1000000000`` ate gigabytes; a 400-byte alias bomb in a
command-line ``env.<key>=`` value hung (plain ``yaml.safe_load``); duplicate keys were accepted, last wins.
"""

from __future__ import annotations

import json
import re
import shutil
import tempfile
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from pyflyt_engine.errors import ConfigError, PyFlytError
from pyflyt_engine.limits import LIMITS, number
from tests.conftest import pyflyt_forked

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def hover(**changes) -> dict:
    from pyflyt_engine.envs.config import load_env_config

    data = load_env_config("quadx_hover").model_dump(mode="json")
    for key, value in changes.items():
        holder = data
        *path, last = key.split(".")
        for part in path:
            holder = holder[part]
        holder[last] = value
    return data


def env_problem(**changes) -> str | None:
    from pyflyt_engine.envs.config import parse_env_config

    try:
        parse_env_config(hover(**changes), "test env")
    except ConfigError as exc:
        return str(exc)
    return None


def camera_problem(side: int) -> str | None:
    from pyflyt_engine.spec import parse_uav_spec
    from tests.conftest import spec_dict

    data = spec_dict()
    data["cameras"] = [{"name": "cam", "width": side, "height": 8}]
    try:
        parse_uav_spec(data, source="test airframe")
    except PyFlytError as exc:
        return str(exc)
    return None


def fly_problem(*overrides: str) -> str | None:
    from pyflyt_cli.flying import plan_flight

    try:  # as pyflyt fly does: the options, then the airframe and the wind they hold
        plan_flight(list(overrides))
    except PyFlytError as exc:
        return str(exc)
    return None


def train_problem(*overrides: str) -> str | None:
    from pyflyt_cli.training.compose import compose_config

    try:
        compose_config(overrides=list(overrides))
    except PyFlytError as exc:
        return str(exc)
    return None


def eval_problem(**options) -> str | None:
    from pyflyt_cli.training.schema import parse_eval_options

    try:
        parse_eval_options(options)
    except PyFlytError as exc:
        return str(exc)
    return None


def bench_problem(*overrides: str) -> str | None:
    from pyflyt_cli.benchmark.plan import load_spec, split_overrides

    try:  # as pyflyt benchmark does: its shorthands (seeds=, jobs=) become benchmark.* overrides
        bench, _, runs = split_overrides(list(overrides))
        load_spec("smoke_benchmark", bench, runs)
    except PyFlytError as exc:
        return str(exc)
    return None


def offline_buffer() -> Path:
    """A file for ``algo.offline_buffer`` to name (the schema checks that it exists; nothing reads it here)."""
    path = Path(tempfile.mkdtemp(prefix="pyflyt-limits-")) / "buffer.npz"
    path.write_bytes(b"")
    return path


def tune_problem(**options) -> str | None:
    from pyflyt_cli.training.tune import parse_tune_options

    try:
        parse_tune_options(options)
    except PyFlytError as exc:
        return str(exc)
    return None


def speed_problem(*args: str) -> str | None:
    """What ``pyflyt speed <args>`` refuses before measuring anything (None: it would measure)."""
    from pyflyt_cli.speed import speed_settings

    kwargs: dict = {}
    for option, value in zip(args[::2], args[1::2]):
        kwargs[option.lstrip("-").replace("-", "_")] = int(value) if option == "--repeats" else value
    try:
        speed_settings(**kwargs)
    except PyFlytError as exc:
        return str(exc)
    return None


def plot_problem(reps: int, tmp: Path) -> str | None:
    """What ``pyflyt plot --reps`` says of an empty benchmark directory: the reps refusal, or another problem."""
    from pyflyt_cli.plotting.report import plot_benchmark

    try:
        plot_benchmark(tmp, tmp / "out", reps=reps)
    except PyFlytError as exc:
        return None if "--reps" not in str(exc) else str(exc)
    return None


_RECORDING: list[Path] = []


def recording_problem(forge) -> str | None:
    """What reading a short hover recording says once ``forge(topic, data)`` rewrote its messages (None: read)."""
    import tempfile

    from pyflyt_engine.telemetry import load_episode
    from tests.telemetry.conftest import record, rewrite_mcap

    if not _RECORDING:
        folder = Path(tempfile.mkdtemp(prefix="pyflyt-limits-"))
        env, _ = record("PyFlyt/QuadX-Hover-v0", folder, episodes=1, max_steps=3)
        _RECORDING.append(env.paths[0])
    forged = _RECORDING[0].with_name(f"forged-{len(list(_RECORDING[0].parent.iterdir()))}.mcap")
    rewrite_mcap(_RECORDING[0], forged, forge)
    try:
        load_episode(forged, warn=False)
    except PyFlytError as exc:
        return str(exc)
    finally:
        forged.unlink()
    return None


def long_aux(n: int):
    return lambda topic, data: {**data, "aux": [0.0] * n} if topic == "/uav/0/state" else None


def long_scene(n: int):
    def forge(topic, data):
        if topic == "/scene" and data.get("entities"):
            entity = data["entities"][0]
            return {**data, "entities": [{**entity, "spheres": [{}] * n}, *data["entities"][1:]]}
        return None

    return forge


#: limit -> (a setting above it, one within it, what the refusal names); within values keep the
#: config's other rules (physics_hz a whole multiple of agent_hz, the controller no faster than physics)
CASES = {
    "physics_hz": (
        lambda: env_problem(physics_hz=3e9),
        lambda: env_problem(physics_hz=9600.0),
        "physics_hz 3000000000",
    ),
    "control_hz": (lambda: env_problem(control_hz=2e4), lambda: env_problem(control_hz=240.0), "control_hz 20000"),
    "agent_hz": (
        lambda: env_problem(agent_hz=2e4, physics_hz=2e4),
        lambda: env_problem(agent_hz=240.0),
        "agent_hz 20000",
    ),
    "max_duration_seconds": (
        lambda: env_problem(max_duration_seconds=1e9),
        lambda: env_problem(max_duration_seconds=3600.0),
        "max_duration_seconds 1000000000",
    ),
    "episode_physics_steps": (
        lambda: env_problem(physics_hz=9600.0, max_duration_seconds=2000.0),
        lambda: env_problem(physics_hz=9600.0, max_duration_seconds=1000.0),
        "physics_hz x max_duration_seconds 19200000",
    ),
    "image_side": (
        lambda: env_problem(**{"render.resolution": [100000, 100000]}),
        lambda: env_problem(**{"render.resolution": [4096, 64]}),
        "resolution height 100000",
    ),
    "flight_dome_size": (
        lambda: env_problem(flight_dome_size=1e308),
        lambda: env_problem(flight_dome_size=800.0),
        "flight_dome_size 1e+308",
    ),
    "seed": (lambda: train_problem("seed=4294967296"), lambda: train_problem("seed=2147483647"), "seed 4294967296"),
    "eval.episodes": (lambda: eval_problem(episodes=10**8), lambda: eval_problem(episodes=10**6), "episodes 100000000"),
    # physical values: fly exited 0 with a NaN trajectory for each of these
    "max_rpm": (
        lambda: fly_problem("uav.motors.max_rpm=1e200"),
        lambda: fly_problem("uav.motors.max_rpm=238667"),
        "motors.max_rpm 1e+200",
    ),
    "mass": (lambda: fly_problem("uav.body.mass=1e30"), lambda: fly_problem("uav.body.mass=100000"), "mass 1e+30"),
    "noise_ratio": (
        lambda: fly_problem("uav.motors.noise_ratio=1e10"),
        lambda: fly_problem("uav.motors.noise_ratio=0.5"),
        "motors.noise_ratio 10000000000",
    ),
    "wind_speed": (
        lambda: fly_problem("wind=constant", "wind.mean.speed=1e300"),
        lambda: fly_problem("wind=constant", "wind.mean.speed=100"),
        "mean.speed 1e+300",
    ),
    "video.fps": (lambda: eval_problem(fps=10**9), lambda: eval_problem(fps=1000), "fps 1000000000"),
    "fly.rows": (lambda: fly_problem("rows=1000000000"), lambda: fly_problem("rows=10000"), "rows 1000000000"),
    "fly.duration": (lambda: fly_problem("duration=1e9"), lambda: fly_problem("duration=2.0"), "duration 1000000000"),
    "fly.magnitude": (
        lambda: fly_problem("position=[1e308,0,1]"),
        lambda: fly_problem("setpoint=[0,0,0,99999]"),
        "a position value of size 1e+308",
    ),
    # a training run's counts: n_envs=1e8 and n_steps=1e9 ended in MemoryError tracebacks, a layer of 1e8
    # units in torch's, eval_episodes=1e9 evaluated for ever (train.total_timesteps=64 keeps the curriculum
    # of the shipped tunings inside the budget)
    "train.total_timesteps": (
        lambda: train_problem("train.total_timesteps=1e13"),
        lambda: train_problem("train.total_timesteps=1000000000000"),
        "train.total_timesteps 1e+13",
    ),
    "train.n_envs": (
        lambda: train_problem("train.n_envs=100000000"),
        lambda: train_problem("train.n_envs=65536", "algo.n_steps=8"),
        "train.n_envs 100000000",
    ),
    "train.eval_episodes": (
        lambda: train_problem("train.eval_episodes=1000000000"),
        lambda: train_problem("train.eval_episodes=10000"),
        "train.eval_episodes 1000000000",
    ),
    "train.torch_threads": (
        lambda: train_problem("train.torch_threads=100000"),
        lambda: train_problem("train.torch_threads=1024"),
        "train.torch_threads 100000",
    ),
    "algo.rollout": (
        lambda: train_problem("train.n_envs=4096", "algo.n_steps=4096"),
        lambda: train_problem("train.n_envs=4096", "algo.n_steps=2048"),
        "the rollout n_steps x n_envs 16777216",
    ),
    "algo.n_step_returns": (
        lambda: train_problem("algo=sac", "algo.n_steps=1000000"),
        lambda: train_problem("algo=sac", "algo.n_steps=1000"),
        "algo.n_steps 1000000",
    ),
    "algo.batch_size": (
        lambda: train_problem("algo=sac", "algo.batch_size=2000000"),
        lambda: train_problem("algo=sac", "algo.batch_size=1048576"),
        "algo.batch_size 2000000",
    ),
    "algo.n_epochs": (
        lambda: train_problem("algo.n_epochs=1000000000"),
        lambda: train_problem("algo.n_epochs=10000"),
        "algo.n_epochs 1000000000",
    ),
    "algo.buffer_size": (
        lambda: train_problem("algo=sac", "algo.buffer_size=100000000000"),
        lambda: train_problem("algo=sac", "algo.buffer_size=10000000"),
        "algo.buffer_size 100000000000",
    ),
    "algo.gradient_steps": (
        lambda: train_problem("algo=sac", "algo.gradient_steps=1000000000"),
        lambda: train_problem("algo=sac", "algo.gradient_steps=100000"),
        "algo.gradient_steps 1000000000",
    ),
    "algo.offline_steps": (
        lambda: train_problem("env=quadx_waypoints", "algo=awac", "algo.offline_steps=1000000000"),
        lambda: train_problem(
            "env=quadx_waypoints",
            "algo=awac",
            "algo.offline_steps=100000000",
            f"algo.offline_buffer={offline_buffer()}",
        ),
        "algo.offline_steps 1000000000",
    ),
    "algo.iterations": (
        lambda: train_problem("algo=trpo", "algo.cg_max_steps=1000000000"),
        lambda: train_problem("algo=trpo", "algo.cg_max_steps=10000"),
        "algo.cg_max_steps 1000000000",
    ),
    "net.width": (
        lambda: train_problem("algo.policy_kwargs.net_arch=[100000000]"),
        lambda: train_problem("algo.policy_kwargs.net_arch=[65536]"),
        "a net_arch layer of 100000000",
    ),
    "net.depth": (
        lambda: train_problem(f"algo.policy_kwargs.net_arch=[{','.join(['8'] * 1001)}]"),
        lambda: train_problem(f"algo.policy_kwargs.net_arch=[{','.join(['8'] * 1000)}]"),
        "net_arch (its length) 1001",
    ),
    "net.parameters": (
        lambda: train_problem("algo.policy_kwargs.net_arch=[20000,20000,20000]"),
        lambda: train_problem("algo.policy_kwargs.net_arch=[10000,10000]"),
        "net_arch (20000 x 20000 x 20000) 800000000",
    ),
    "net.critics": (
        lambda: train_problem("algo=sac", "algo.policy_kwargs.n_critics=1000000"),
        lambda: train_problem("algo=sac", "algo.policy_kwargs.n_critics=100"),
        "policy_kwargs.n_critics 1000000",
    ),
    "net.quantiles": (
        lambda: train_problem("algo=tqc", "algo.policy_kwargs.n_quantiles=100000000"),
        lambda: train_problem("algo=tqc", "algo.policy_kwargs.n_quantiles=10000"),
        "policy_kwargs.n_quantiles 100000000",
    ),
    # the commands that run many trainings or measurements
    "jobs": (lambda: tune_problem(jobs=100_000_000), lambda: tune_problem(jobs=1024), "jobs 100000000"),
    "benchmark.seeds": (
        lambda: bench_problem("seeds=100000000"),
        lambda: bench_problem("seeds=10000"),
        "seeds 100000000",
    ),
    "benchmark.random_episodes": (
        lambda: bench_problem("benchmark.random_episodes=100000000"),
        lambda: bench_problem("benchmark.random_episodes=10000"),
        "random_episodes 100000000",
    ),
    "tune.trials": (lambda: tune_problem(trials=100_000_000), lambda: tune_problem(trials=100_000), "trials 100000000"),
    "speed.repeats": (
        lambda: speed_problem("--repeats", "100000"),
        lambda: speed_problem("--repeats", "1000"),
        "--repeats 100000",
    ),
    "speed.vehicles": (
        lambda: speed_problem("--vehicles", "1,100000"),
        lambda: speed_problem("--vehicles", "1,4096"),
        "--vehicles 100000",
    ),
    "plot.reps": (
        lambda: plot_problem(100_000_000, Path(tempfile.mkdtemp())),
        lambda: plot_problem(1_000_000, Path(tempfile.mkdtemp())),
        "--reps 100000000",
    ),
    # lists read from a recording: 3 M-value state lists hung replay
    "recording.row_values": (
        lambda: recording_problem(long_aux(10_001)),
        lambda: recording_problem(long_aux(10_000)),
        "'aux' has 10001 values",
    ),
    "recording.scene_items": (
        lambda: recording_problem(long_scene(1_000_001)),
        lambda: recording_problem(long_scene(1_000_000)),
        "list of 1000001 items",
    ),
}


def test_every_limit_has_a_case_and_a_row_in_the_docs():
    assert set(CASES) == set(LIMITS)
    text = (ROOT / "docs" / "reproducibility.md").read_text()
    section = text[text.index("### Bounded numbers") :]
    for key, limit in LIMITS.items():
        row = re.search(rf"^\| `{re.escape(key)}` \| ([^|]+) \|", section, re.M)
        assert row is not None, key
        assert f"{limit.high:,.0f}".replace(",", " ") in row.group(1) or number(limit.high) in row.group(1), (
            key,
            row.group(1),
        )


@pytest.mark.parametrize("key", sorted(CASES))
def test_a_value_above_its_limit_is_refused_naming_it_and_one_within_is_accepted(key):
    above, within, fragment = CASES[key]
    message = above()
    assert message is not None and fragment in message and "above the limit" in message, message
    assert number(LIMITS[key].high) in message
    assert within() is None


def test_an_evaluation_seed_beyond_32_bits_is_refused_not_a_traceback():
    assert "seed 4294967296 is above the limit of 2147483647" in eval_problem(seed=2**32)
    assert eval_problem(seed=2**31 - 1, episodes=10**6) is None  # the largest seed the episodes add to


@pytest.mark.parametrize(
    "overrides, fragment",
    [
        (["wind=gust", "wind.gust.amplitude=[1e300,0,0]"], "gust.amplitude (its largest component) 1e+300"),
        (["wind=gust", "wind.gust.speed=1e300"], "gust.speed 1e+300"),
        (["wind=constant", "wind.mean.vertical=-1e300"], "mean.vertical (its size) 1e+300"),
        (["wind=dryden_light", "wind.turbulence.wind_speed_20ft=1e300"], "turbulence.wind_speed_20ft 1e+300"),
    ],
)
def test_every_wind_speed_is_bounded(overrides, fragment):
    message = fly_problem(*overrides)
    assert message is not None and fragment in message and "above the limit of 1000 m/s" in message, message


def test_a_camera_larger_than_the_limit_is_refused():
    assert "camera width 100000 is above the limit" in camera_problem(100000)
    assert camera_problem(4096) is None


@pytest.fixture
def shared_run(tmp_path) -> Path:
    from pyflyt_cli.zoo import agent

    run = tmp_path / "run"
    shutil.copytree(agent("quadx_hover_ppo").path, run)
    return run


def test_eval_of_a_run_with_a_huge_physics_rate_is_refused_in_one_line(shared_run):
    path = shared_run / "config.yaml"
    data = yaml.safe_load(path.read_text())
    data["env"]["physics_hz"] = 3e9
    path.write_text(yaml.safe_dump(data))
    code, output = pyflyt_forked(["eval", str(shared_run), "episodes=1", "record=false"], memory=1 << 30)
    assert code == 2 and "Traceback" not in output, output[-2000:]
    assert "physics_hz 3000000000 is above the limit of 10000 Hz" in output


def test_eval_refuses_a_huge_rate_or_an_alias_bomb_on_the_command_line(shared_run):
    code, output = pyflyt_forked(
        ["eval", str(shared_run), "episodes=1", "record=false", "env.physics_hz=3e9"], memory=1 << 30
    )
    assert code == 2 and "physics_hz 3000000000 is above the limit" in output, output[-2000:]
    # a few hundred bytes of flow YAML that expand to 10^9 values
    levels = ["&a0 [x, x, x, x, x, x, x, x, x, x]"] + [
        f"&a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)
    ]
    bomb = "[" + ", ".join(levels) + "]"
    assert len(bomb) < 600
    code, output = pyflyt_forked(
        ["eval", str(shared_run), "episodes=1", "record=false", f"env.flight_dome_size={bomb}"], memory=1 << 30
    )
    assert code == 2 and "Traceback" not in output, output[-2000:]
    assert "env.flight_dome_size= (command line)" in output and "alias-expansion bomb" in output


def test_replay_refuses_a_recording_whose_metadata_sets_a_huge_physics_rate(tmp_path):
    from tests.telemetry.conftest import record, rewrite_mcap

    env, _ = record("PyFlyt/QuadX-Hover-v0", tmp_path, episodes=1, max_steps=5)

    def forge(name: str, meta: dict[str, str]) -> dict[str, str]:
        if name != "env":
            return meta
        config = json.loads(meta["config"])
        config["physics_hz"] = 3e9
        return {**meta, "config": json.dumps(config), "physics_hz": "3e9"}

    forged = tmp_path / "forged.mcap"
    rewrite_mcap(env.paths[0], forged, lambda topic, data: None, metadata=forge)
    code, output = pyflyt_forked(["replay", str(forged), "--verify"], memory=1 << 30)
    assert code == 2 and "Traceback" not in output, output[-2000:]
    assert "physics_hz 3000000000 is above the limit" in output


def test_a_yaml_key_given_twice_is_refused_wherever_the_bounded_reader_reads(shared_run):
    from pyflyt_cli.training import rundir
    from pyflyt_engine.safe_load import yaml_data

    with pytest.raises(ConfigError, match=r"the key 'b' is given twice \(lines 2 and 4\)"):
        yaml_data("a: 1\nb: 2\nc: {d: 3}\nb: 5\n", source="doc")
    with pytest.raises(ConfigError, match="the key 'd' is given twice"):
        yaml_data("c: {d: 3, d: 4}\n", source="doc")
    # a merge is not a key of its own: overriding what it brings is YAML's intent
    assert yaml_data("base: &b {x: 1, y: 2}\nother: {<<: *b, x: 3}\n", source="doc")["other"] == {"x": 3, "y": 2}
    path = shared_run / "config.yaml"
    path.write_text(path.read_text() + "seed: 7\nseed: 8\n")
    with pytest.raises(rundir.RunDirError, match="the key 'seed' is given twice"):
        rundir.load_run_config(shared_run)


def test_every_shipped_yaml_file_has_unique_keys():
    from pyflyt_engine.safe_load import yaml_data

    files = [*ROOT.joinpath("conf").rglob("*.yaml"), *ROOT.joinpath("pyflyt_cli", "zoo").rglob("*.yaml")]
    assert len(files) > 50
    for file in files:
        yaml_data(file.read_text(), source=str(file), limit=None)


@pytest.mark.parametrize("what", ["vertices", "triangles"])
def test_an_obj_mesh_beyond_the_vertex_or_triangle_limit_is_refused_in_seconds(what):
    """The reproduction: an OBJ within the 64 MiB limit (8 M triangles) took about five CPU-minutes."""
    import time

    from pyflyt_engine.obstacles import MAX_OBJ_TRIANGLES, MAX_OBJ_VERTICES, parse_obj

    if what == "vertices":
        data = b"v 0 0 0\n" * (MAX_OBJ_VERTICES + 1) + b"f 1 2 3\n"
    else:
        data = b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * (4 * MAX_OBJ_TRIANGLES)
    start = time.process_time()
    with pytest.raises(
        ValueError, match=f"more than {MAX_OBJ_VERTICES if what == 'vertices' else MAX_OBJ_TRIANGLES} {what}"
    ):
        parse_obj(data, "big.obj")
    assert time.process_time() - start < 10.0  # stops at the limit (about 1 s), not at the end of the file
    at_limit = b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * MAX_OBJ_TRIANGLES
    assert len(parse_obj(at_limit, "ok.obj").indices) == 3 * MAX_OBJ_TRIANGLES
