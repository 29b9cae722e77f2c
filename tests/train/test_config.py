"""`pyflyt train` configuration: composition, overrides, schema validation, refusals.

Nothing here trains: every test composes and validates only (or runs `--cfg`).
"""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pyflyt_cli.errors import UsageError
from pyflyt_cli.main import app
from pyflyt_cli.training import registry
from pyflyt_cli.training.compose import compose_config
from pyflyt_cli.training.rundir import create_run_dir
from pyflyt_cli.training.schema import PPOConfig, SACConfig, parse_train_config
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.loading import available
from pyflyt_engine.paths import conf_dir

from tests.conftest import default_subset

from .conftest import ROOT, pyflyt

ENVS = available("env")  # the bases (conf/env/_*.yaml) are no envs
ALGOS = sorted(p.stem for p in (conf_dir() / "algo").glob("*.yaml"))
EXPERIMENTS = sorted(p.stem for p in (conf_dir() / "experiment").glob("*.yaml"))


#: every (env, algo) pair: in the default suite those with a per-pair tuning, every env with
#: PPO and every algorithm on the hover task; the rest are marked long
def _in_default_suite(pair: tuple[str, str]) -> bool:
    env, algo = pair
    return algo == "ppo" or env == "quadx_hover" or (conf_dir() / "hparams" / f"{env}_{algo}.yaml").is_file()


PAIRS = default_subset([(env, algo) for env in ENVS for algo in ALGOS], _in_default_suite)


def test_defaults_are_a_short_ppo_run_on_hover():
    cfg = compose_config(overrides=[])
    assert cfg.env_name == "quadx_hover" and cfg.env.id == "PyFlyt/QuadX-Hover-v0"
    assert isinstance(cfg.algo, PPOConfig)
    # the per-env tuning (conf/hparams/quadx_hover_ppo.yaml) is applied on top of algo/ppo.yaml
    assert cfg.algo.normalize.observation and cfg.algo.policy_kwargs.net_arch is not None
    assert 0 < cfg.train.total_timesteps <= 300_000 and cfg.seed == 0


def test_nested_overrides_reach_env_and_algo():
    cfg = compose_config(
        overrides=["env.reward=sparse", "algo.learning_rate=1e-3", "seed=7", "train.total_timesteps=2e5"]
    )
    assert cfg.env.reward == "sparse" and cfg.env.reward_preset_name() == "quadx_hover_sparse"
    assert cfg.algo.learning_rate == pytest.approx(1e-3)
    assert cfg.seed == 7 and cfg.train.total_timesteps == 200_000


def test_uav_and_reward_groups_override_the_env():
    cfg = compose_config(overrides=["uav=quadx_f450", "reward=quadx_hover_sparse"])
    assert cfg.env.uav == "quadx_f450"
    assert isinstance(cfg.env.reward, dict) and cfg.env.reward["name"] == "quadx_hover_sparse"
    assert set(cfg.env.reward["terms"]) == {"crash", "time_penalty"}


@pytest.mark.parametrize(("env", "algo"), PAIRS)
def test_every_env_and_algo_composes_and_validates(env, algo):
    # CCGE's oracle is the policy init_from names; it is refused without one (test_ccge.py)
    oracle = ["init_from=sac_run/best_model.pt"] if algo == "ccge" else []
    cfg = compose_config(overrides=[f"env={env}", f"algo={algo}", *oracle])
    assert cfg.env_name == env and cfg.algo.name == algo


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_experiment_files_are_override_only_and_compose(experiment):
    text = (conf_dir() / "experiment" / f"{experiment}.yaml").read_text()
    assert text.lstrip().startswith("# @package _global_") or "\n# @package _global_" in text
    if "\nbenchmark:" in text:  # a grid for pyflyt benchmark (tests/benchmark); pyflyt train refuses it
        with pytest.raises(UsageError, match=f"pyflyt benchmark experiment={experiment}"):
            compose_config(overrides=[f"experiment={experiment}"])
        return
    cfg = compose_config(overrides=[f"experiment={experiment}"])
    assert cfg.experiment == experiment


def test_hparams_follow_the_chosen_env_and_algo():
    """conf/hparams/<env>_<algo>.yaml is picked from the final choices (incl. an experiment's)."""
    for path in (conf_dir() / "hparams").glob("*.yaml"):
        # the longest env name that prefixes the file (quadx_hover_sensors_ppo is not quadx_hover's)
        env = max((e for e in ENVS if path.stem.startswith(e + "_") and path.stem[len(e) + 1 :] in ALGOS), key=len)
        algo = path.stem[len(env) + 1 :]
        assert algo in ALGOS, path
        compose_config(
            overrides=[f"env={env}", f"algo={algo}", *(["init_from=sac_run/best_model.pt"] if algo == "ccge" else [])]
        )


@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        (["env=quadx_hovr"], ["unknown env 'quadx_hovr'", "Did you mean 'quadx_hover'?", "quadx_waypoints"]),
        (["algo=sacc"], ["unknown algo 'sacc'", "Did you mean 'sac'?", "ppo", "td3"]),
        (["uav=quadx_f45"], ["unknown uav 'quadx_f45'", "Did you mean 'quadx_f450'?"]),
        (["train.total_timestep=5"], ["unknown key 'train.total_timestep'", "Did you mean 'train.total_timesteps'?"]),
        (["algo.n_stepz=5"], ["unknown key 'algo.n_stepz'", "Did you mean 'algo.n_steps'?"]),
        (["train.total_timesteps=abc"], ["train.total_timesteps", "valid integer", "'abc'"]),
        (["seed=-1"], ["seed", "greater than or equal to 0"]),
        (["algo.gamma=1.5"], ["algo.gamma", "less than or equal to 1"]),
        (["algo=sac", "algo.ent_coef=lots"], ["algo.ent_coef", "'auto'"]),
        (["algo.policy_kwargs.activation_fn=sigmoid"], ["algo.policy_kwargs.activation_fn", "'tanh'"]),
        (["algo.batch_size=100000"], ["algo.batch_size", "rollout size"]),
        (["env.reward=nope"], ["env.reward", "unknown reward config 'nope'"]),
        (["env.uav=quadx_f45"], ["env.uav", "Did you mean 'quadx_f450'?"]),
        (["seed=0,1"], ["seed=0,1 is a sweep", "-m"]),
        (["algo.learning_rate=="], ["malformed override"]),
        (["seed"], ["'seed' is not an override"]),
        (["uav=quadx_f450", "uav.body.mass=2"], ["uav.* keys cannot be overridden"]),
        (["hydra.searchpath=[file:///tmp]"], ["pyflyt train takes no Hydra settings"]),
        (["+hydra.callbacks.x._target_=os.getcwd"], ["pyflyt train takes no Hydra settings"]),
    ],
)
def test_bad_configs_fail_with_a_message_naming_the_problem(overrides, expected):
    message = refused(["train", *overrides, "--cfg"])
    for part in expected:
        assert part in message, message


def refused(args: list[str]) -> str:
    """``pyflyt <args>``'s error report: exit code 2, no traceback, nothing printed on stdout."""
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert result.output.startswith("error:"), result.output
    return result.output


def test_cli_errors_exit_2_without_traceback(tmp_path):
    result = pyflyt(["train", "algo=sacc", f"train.output_dir={tmp_path}"], cwd=tmp_path, timeout=120)
    assert result.returncode == 2
    assert "unknown algo 'sacc'. Did you mean 'sac'?" in result.stderr and "Traceback" not in result.stderr
    assert not any(tmp_path.iterdir()), "nothing may be created for a refused config"


# ------------------------------------------------------------------ hostile


def _hostile_data(tmp_path: Path, where: str) -> tuple[dict, Path]:
    marker = tmp_path / "pwned"
    data = compose_config(overrides=[f"train.output_dir={tmp_path / 'runs'}"]).model_dump(mode="json")
    payload = {"_target_": "os.system", "_args_": [f"touch {marker}"]}
    if where == "top":
        data.update(payload)
    elif where == "algo":
        data["algo"].update(payload)
    elif where == "callback":
        data["callbacks"] = [payload]
    elif where == "activation":
        data["algo"]["policy_kwargs"]["activation_fn"] = payload
    return data, marker


@pytest.mark.parametrize("where", ["top", "algo", "callback", "activation"])
def test_target_outside_the_registries_is_refused_before_anything_runs(tmp_path, where):
    from pyflyt_cli.training import train

    data, marker = _hostile_data(tmp_path, where)
    with pytest.raises(ConfigError, match="refusing to instantiate 'os.system'"):
        train(data)
    assert not marker.exists()
    assert not (tmp_path / "runs").exists()


def test_hostile_override_on_the_command_line_is_refused(tmp_path):
    marker = tmp_path / "pwned"
    result = pyflyt(
        ["train", "+algo._target_=os.system", f"+algo._args_=[touch {marker}]", f"train.output_dir={tmp_path}/runs"],
        cwd=tmp_path,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    assert "refusing to instantiate 'os.system'" in result.stderr and "Traceback" not in result.stderr
    assert not marker.exists() and not (tmp_path / "runs").exists()


def test_targets_naming_registered_objects_are_accepted():
    data = compose_config(overrides=["algo=sac"]).model_dump(mode="json")
    del data["algo"]["name"]
    data["algo"]["_target_"] = "stable_baselines3.SAC"
    data["algo"]["policy_kwargs"]["activation_fn"] = {"_target_": "torch.nn.ReLU"}
    cfg = parse_train_config(data)
    assert isinstance(cfg.algo, SACConfig) and cfg.algo.policy_kwargs.activation_fn == "relu"
    with pytest.raises(ConfigError, match="Hydra instantiation key '_partial_'"):
        parse_train_config({**data, "algo": {**data["algo"], "_partial_": True}})


def test_unknown_keys_and_wrong_types_in_a_plain_dict():
    data = compose_config(overrides=[]).model_dump(mode="json")
    with pytest.raises(
        ConfigError, match=r"train\.total_timestep: unknown key 'total_timestep'\. Did you mean 'total_timesteps'"
    ):
        parse_train_config({**data, "train": {**data["train"], "total_timestep": 5}})
    with pytest.raises(ConfigError, match=r"algo\.n_epochs: Input should be a valid integer"):
        parse_train_config({**data, "algo": {**data["algo"], "n_epochs": "many"}})
    with pytest.raises(ConfigError, match="unknown algorithm 'dqn'"):
        parse_train_config({**data, "algo": {"name": "dqn"}})


def test_registry_resolves_only_its_names():
    assert registry.resolve(registry.ALGOS, "ppo", "algorithm").__name__ == "PPO"
    with pytest.raises(ConfigError, match="unknown algorithm 'system'"):
        registry.resolve(registry.ALGOS, "system", "algorithm")


# --------------------------------------------------------------- CLI surface


def test_help_lists_groups_and_choices():
    result = CliRunner().invoke(app, ["train", "--help"], terminal_width=200)
    assert result.exit_code == 0
    out = result.output
    for group in ("env=", "algo=", "uav=", "reward=", "experiment="):
        assert group in out
    for choice in ENVS + ALGOS + ["quadx_f450", "quadx_hover_sparse"]:
        assert choice in out, choice
    assert "--multirun" in out and "resume=" in out


def test_multirun_expands_sweeps(tmp_path):
    result = CliRunner().invoke(app, ["train", "-m", "seed=0,1,2", "algo=ppo,sac", "--cfg"])
    assert result.exit_code == 0, result.output
    assert result.output.count("# job:") == 6
    assert "# job: seed=2 algo=sac" in result.output


def test_cfg_prints_the_validated_config():
    result = CliRunner().invoke(app, ["train", "algo=td3", "--cfg"])
    assert result.exit_code == 0, result.output
    assert "name: td3" in result.output and "env_name: quadx_hover" in result.output


def test_hydra_leaves_the_working_directory_alone(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    CliRunner().invoke(app, ["train", "--cfg"])
    compose_config(overrides=["seed=3"])
    assert Path.cwd() == tmp_path and not any(tmp_path.iterdir())


def test_resume_rejects_other_overrides_and_missing_dirs(tmp_path):
    from pyflyt_cli.training.loop import resume
    from pyflyt_cli.training.requests import resume_args

    with pytest.raises(UsageError, match="cannot be combined with resume="):
        resume_args([f"resume={tmp_path}", "algo=sac"])
    run, kwargs = resume_args([f"resume={tmp_path / 'nope'}"])
    with pytest.raises(ConfigError, match="does not exist"):
        resume(run, **kwargs)
    with pytest.raises(ConfigError, match="not a run directory"):
        resume(str(tmp_path))
    assert "cannot be combined with resume=" in refused(["train", f"resume={tmp_path}", "algo=sac"])
    assert "not a run directory" in refused(["train", f"resume={tmp_path}"])


def test_init_from_a_missing_run_is_refused_before_creating_anything(tmp_path):
    from pyflyt_cli.training import train

    cfg = compose_config(overrides=[f"init_from={tmp_path / 'nope'}", f"train.output_dir={tmp_path / 'runs'}"])
    with pytest.raises(ConfigError, match="init_from=.*: run directory .* does not exist"):
        train(cfg)
    assert not (tmp_path / "runs").exists()


def test_an_env_that_cannot_be_built_fails_before_the_run_starts(tmp_path):
    from pyflyt_cli.training import train

    cfg = compose_config(overrides=["uav=fixedwing", "train.n_envs=4", "algo.n_steps=128", "train.vec_env=auto",
                             f"train.output_dir={tmp_path / 'runs'}"])  # fmt: skip
    with pytest.raises(ConfigError, match="env: cannot build the environment"):
        train(cfg)
    assert not (tmp_path / "runs").exists()


def test_tensorboard_without_the_package_says_how_to_install(tmp_path, monkeypatch):
    import importlib.util

    from pyflyt_cli.training import train

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "tensorboard" else real(name, *a))
    cfg = compose_config(overrides=["train.tensorboard=true", f"train.output_dir={tmp_path / 'runs'}"])
    with pytest.raises(ConfigError, match="pip install tensorboard"):
        train(cfg)


# ------------------------------------------------------------- run directories


def test_run_directories_never_collide(tmp_path):
    when = 1_700_000_000.0
    first = create_run_dir(tmp_path, "quadx_hover", "ppo", 0, when)
    second = create_run_dir(tmp_path, "quadx_hover", "ppo", 0, when)
    assert first.name.endswith("-seed0") and second.name == first.name + "-1"
    assert first.parent == tmp_path.resolve() / "quadx_hover" / "ppo"

    made: list[Path] = []
    barrier = threading.Barrier(8)

    def make() -> None:
        barrier.wait()
        made.append(create_run_dir(tmp_path, "quadx_hover", "ppo", 1, when))

    threads = [threading.Thread(target=make) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(set(made)) == 8 and all(p.is_dir() for p in made)


def test_conf_is_packaged_with_train_configs():
    text = (ROOT / "pyproject.toml").read_text()
    assert '"conf" = "pyflyt_engine/conf"' in text
    for name in ("train.yaml", "eval.yaml", "algo/ppo.yaml", "algo/sac.yaml", "algo/td3.yaml"):
        assert (conf_dir() / name).is_file(), name


# ------------------------------------------------------------ experiment files


def _tagged_experiment(path: Path, marker: Path) -> Path:
    path.write_text(f'# @package _global_\nseed: !!python/object/apply:os.system ["touch {marker}"]\n')
    return path


def test_a_python_tag_in_an_experiment_file_is_refused_naming_the_file(tmp_path):
    marker = tmp_path / "ran"
    study = _tagged_experiment(tmp_path / "tagged_study.yaml", marker)
    for command in (["train", "--cfg"], ["benchmark", "--dry-run"]):
        result = pyflyt(
            [*command, f"experiment={study}"], cwd=tmp_path
        )  # pyflyt()'s hang guard (300 s), not a readiness wait
        assert result.returncode == 2, result.stderr
        assert f"{study}, line 2: the YAML tag !!python/object/apply:os.system is not allowed" in result.stderr
        assert "Traceback" not in result.stderr
    assert not marker.exists(), "code from the file ran"


def test_a_python_tag_in_a_shipped_experiment_is_refused_naming_the_file(tmp_path, monkeypatch):
    import shutil

    from pyflyt_cli import compose

    conf = tmp_path / "conf"
    shutil.copytree(conf_dir(), conf)
    marker = tmp_path / "ran"
    shipped = _tagged_experiment(conf / "experiment" / "tagged.yaml", marker)
    monkeypatch.setattr(compose, "conf_dir", lambda: conf)  # where Hydra looks
    with pytest.raises(UsageError, match=f"{shipped}, line 2: the YAML tag !!python/object/apply:os.system"):
        compose_config(overrides=["experiment=tagged"])
    assert not marker.exists(), "code from the file ran"


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (b"\x00\xff\xfe binary", "not a text file"),
        (b"train: [1, 2\n", "line 2: not valid YAML"),
    ],
)
def test_an_unreadable_experiment_file_is_named(tmp_path, content, expected):
    study = tmp_path / "study.yaml"
    study.write_bytes(content)
    with pytest.raises(UsageError, match=None) as info:
        compose_config(overrides=[f"experiment={study}"])
    assert str(info.value).startswith(str(study)) and expected in str(info.value)


@pytest.mark.parametrize(("override", "expected"), [("algo=null", "takes a name"), ("uav=null", "write ~uav")])
def test_a_config_group_set_to_null_is_explained(override, expected):
    with pytest.raises(UsageError, match=expected):
        compose_config(overrides=[override])


# ------------------------------------------------------- one source of defaults


def _schema_models():
    from pydantic import BaseModel

    from pyflyt_cli.training import schema

    return [
        m
        for m in vars(schema).values()
        if isinstance(m, type) and issubclass(m, BaseModel) and m.__module__ == schema.__name__
    ]


def test_the_schema_writes_no_default_values():
    """conf/ holds every default; a schema field is required, or optional with None meaning "not set"."""
    restated = [
        f"{model.__name__}.{name} = {field.get_default(call_default_factory=True)!r}"
        for model in _schema_models()
        for name, field in model.model_fields.items()
        if not field.is_required() and field.get_default(call_default_factory=True) is not None
    ]
    assert restated == []


@pytest.mark.parametrize(("env", "algo"), PAIRS)
def test_python_and_the_cli_compose_the_same_configuration(env, algo):
    import yaml

    from pyflyt_cli.training import compose_config
    from pyflyt_cli.training.rundir import config_dict

    oracle = ["init_from=sac_run/best_model.pt"] if algo == "ccge" else []  # CCGE requires its oracle
    result = CliRunner().invoke(app, ["train", f"env={env}", f"algo={algo}", *oracle, "--cfg"])
    assert result.exit_code == 0, result.output
    assert yaml.safe_load(result.output) == config_dict(compose_config(env=env, algo=algo, overrides=oracle))


def test_the_algorithm_defaults_are_those_of_conf():
    import yaml

    from pyflyt_cli.training import compose_config

    shipped = yaml.safe_load((conf_dir() / "algo" / "sac.yaml").read_text())
    # env=rocket_landing has no SAC tuning in conf/hparams: every value is conf/algo/sac.yaml's
    cfg = compose_config(env="rocket_landing", algo="sac")
    assert cfg.algo.learning_starts == shipped["learning_starts"] == 10_000
    assert cfg.trust_pickle is False


def test_a_hand_written_config_missing_keys_is_refused_not_completed():
    data = compose_config(overrides=["algo=sac"]).model_dump(mode="json")
    del data["algo"]["learning_starts"]
    with pytest.raises(ConfigError, match=r"algo\.learning_starts: .*required(.|\n)*compose_config\(env=") as info:
        parse_train_config(data)
    assert "learning_starts" in str(info.value)


def test_eval_options_take_conf_eval_yaml_for_keys_left_out():
    import yaml

    from pyflyt_cli.training.schema import EvalOptions, parse_eval_options

    shipped = yaml.safe_load((conf_dir() / "eval.yaml").read_text())
    assert set(shipped) == set(EvalOptions.model_fields)
    options = parse_eval_options({"episodes": 3})
    assert options.episodes == 3 and options.trust_pickle is False
    assert options.model_dump() == {**shipped, "episodes": 3}


def test_a_run_recorded_before_trust_pickle_existed_reads_as_not_trusting():
    data = compose_config(overrides=[]).model_dump(mode="json")
    del data["trust_pickle"]
    assert parse_train_config(data).trust_pickle is False


def test_awac_offline_buffer_npz_or_trusted_pickle(tmp_path):
    for name in ("buffer.npz", "buffer.pkl", "buffer.txt"):
        (tmp_path / name).write_bytes(b"")
    npz, pkl = tmp_path / "buffer.npz", tmp_path / "buffer.pkl"
    assert compose_config(overrides=["algo=awac", f"algo.offline_buffer={npz}"]).algo.offline_buffer == str(npz)
    with pytest.raises(
        ConfigError, match=r"is a pickle \(\.pkl\): unpickling can run arbitrary code.*trust_pickle=true"
    ):
        compose_config(overrides=["algo=awac", f"algo.offline_buffer={pkl}"])
    trusted = compose_config(overrides=["algo=awac", f"algo.offline_buffer={pkl}", "trust_pickle=true"])
    assert trusted.algo.offline_buffer == str(pkl) and trusted.trust_pickle
    with pytest.raises(ConfigError, match="is not a replay buffer file"):
        compose_config(overrides=["algo=awac", f"algo.offline_buffer={tmp_path / 'buffer.txt'}"])


def test_init_from_a_step_of_a_missing_run_names_the_run(tmp_path):
    import re

    missing = refused(["train", f"init_from={tmp_path / 'nope'}@5", f"train.output_dir={tmp_path / 'runs'}"])
    assert re.search(r"init_from=.*@5: run directory .*nope does not exist", missing), missing
    assert "write <run dir>@<step> with a whole number of steps" in refused(
        ["train", f"init_from={tmp_path}@five", "--cfg"]
    )
    assert not (tmp_path / "runs").exists()


def test_gate_observation_option_is_a_documented_override():
    """docs/environments.md: `pyflyt train env=quadx_gates env.task.observation=corners`."""
    assert (
        compose_config(overrides=["env=quadx_gates", "env.task.observation=corners"]).env.task.observation == "corners"
    )
    assert compose_config(overrides=["env=quadx_gates_state"]).env.task.observation == "corners"
    with pytest.raises(ConfigError, match="observation"):  # a value the option does not take
        compose_config(overrides=["env=quadx_gates", "env.task.observation=pixels"])
