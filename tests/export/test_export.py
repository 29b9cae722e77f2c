"""`pyflyt export`: the exported ONNX file and the compiled C give the actions the env receives from the
trained policy (SB3's deterministic action, normaliser, squashing or clipping, rescaling and the env's clip),
within 1e-5, on 1,000 observations recorded by flying the policy; recurrent and image policies and bad
arguments are refused with a message and exit code 2, and nothing written is replaced without --force."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pyflyt_cli.export.c_source import HOST_RUNNER
from pyflyt_cli.export import export_policy
from pyflyt_cli.export.onnx_model import run_onnx
from pyflyt_cli.export.policy import deployed_policy, flown_observations
from pyflyt_cli.main import app

#: the shipped agents exported: an MLP from PPO (with an observation normaliser) and one from SAC (without)
AGENTS = {"ppo": "zoo:quadx_hover_ppo", "sac": "zoo:fixedwing_waypoints_sac"}
RECORDED = 1000
TOLERANCE = 1e-5
#: on observations 50 standard deviations out, where the network's inputs sit at the normaliser's clip:
#: PyTorch's float32 actions there are themselves 1.4e-5 from the exact (float64) chain's
WILD_TOLERANCE = 1e-4

runner = CliRunner()


def record(source, policy, steps: int = RECORDED, seed: int = 0) -> np.ndarray:
    """``steps`` raw observations met by flying the policy (episodes from seed, seed + 1, ...)."""
    return flown_observations(source, policy, steps, seed)


@pytest.fixture(scope="module", params=sorted(AGENTS))
def flown(request):
    source = AGENTS[request.param]
    policy = deployed_policy(source)
    obs = record(source, policy)
    # far outside the training's observations, for a policy with a normaliser: its clip bounds what the
    # network sees, and the action clip saturates (raw observations that far out drive float32
    # pre-activations into the thousands, where no two summation orders agree to 1e-5)
    wild = None
    if type(policy.network[0]).__name__ == "Standardize":
        wild = (np.random.default_rng(1).normal(size=(200, policy.obs_dim)) * 50.0).astype(np.float32)
    return request.param, source, policy, obs, wild


def compile_c(source_file: Path, workdir: Path) -> Path:
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.fail("the C export tests compile the exported source: install gcc (e.g. apt install gcc)")
    (workdir / "main.c").write_text(HOST_RUNNER)
    program = workdir / "policy_run"
    built = subprocess.run(
        [gcc, "-std=c99", "-Wall", "-Werror", "-O2", "-o", str(program), "main.c", source_file.name, "-lm"],
        cwd=workdir,
        capture_output=True,
        text=True,
    )
    assert built.returncode == 0, built.stderr
    return program


def run_c(program: Path, obs: np.ndarray, act_dim: int, workdir: Path) -> np.ndarray:
    (workdir / "obs.bin").write_bytes(np.ascontiguousarray(obs, dtype="<f4").tobytes())
    ran = subprocess.run([str(program), "obs.bin", "act.bin"], cwd=workdir, capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr
    return np.frombuffer((workdir / "act.bin").read_bytes(), dtype="<f4").reshape(-1, act_dim)


def test_the_chain_is_the_policy_the_env_receives(flown):
    algo, _, policy, obs, wild = flown
    assert obs.shape == (RECORDED, policy.obs_dim)
    assert len(np.unique(obs, axis=0)) > 0.9 * RECORDED  # a flight, not one state repeated
    reference = policy.reference(obs)
    assert np.max(np.abs(policy.forward(obs) - reference)) < TOLERANCE
    kinds = [type(layer).__name__ for layer in policy.network]
    if algo == "ppo":  # normaliser in, the Gaussian's mean clipped, rescaled, clipped
        assert kinds[0] == "Standardize" and kinds[-3:] == ["Clamp", "Affine", "Clamp"]
    else:  # raw observations, tanh-squashed mean, rescaled, clipped
        assert "Standardize" not in kinds and kinds[-3:] == ["Tanh", "Affine", "Clamp"]
    # the post-processing matters: without it the actions differ from what the env receives
    import torch

    bare = torch.nn.Sequential(
        *[layer for layer in policy.network if type(layer).__name__ not in ("Affine", "Clamp", "Tanh")]
    )
    with torch.no_grad():
        raw = bare(torch.as_tensor(obs)).numpy()
    assert np.max(np.abs(raw - reference)) > 0.1


def test_onnxruntime_reproduces_the_policy(flown, tmp_path):
    pytest.importorskip("onnxruntime")
    algo, source, policy, obs, wild = flown
    out = tmp_path / "policy.onnx"
    result = export_policy(source, "onnx", out)
    assert result.files == [out] and result.check is not None and result.check < TOLERANCE
    for batch in (obs, wild) if wild is not None else (obs,):
        assert np.max(np.abs(run_onnx(out, batch) - policy.reference(batch))) < (
            TOLERANCE if batch is obs else WILD_TOLERANCE
        )
    import onnx

    meta = {p.key: p.value for p in onnx.load(str(out)).metadata_props}
    assert policy.about["env_id"] in meta["pyflyt"]


def test_the_compiled_c_reproduces_the_policy(flown, tmp_path):
    algo, source, policy, obs, wild = flown
    result = export_policy(source, "c", tmp_path / "policy.c")
    assert result.files == [tmp_path / "policy.c", tmp_path / "policy.h"]
    header = (tmp_path / "policy.h").read_text()
    assert (
        f"#define POLICY_OBS_DIM {policy.obs_dim}" in header
        and "void policy_forward(const float *obs, float *action);" in header
    )
    assert "#include" not in header  # dependency-free: the header needs nothing
    assert header.isascii() and (tmp_path / "policy.c").read_text().isascii()  # any compiler's source charset
    program = compile_c(tmp_path / "policy.c", tmp_path)
    actions = run_c(program, obs, policy.act_dim, tmp_path)
    reference = policy.reference(obs)
    assert actions.shape == reference.shape
    assert np.max(np.abs(actions - reference)) < TOLERANCE
    if wild is None:
        return
    saturated = run_c(program, wild, policy.act_dim, tmp_path)
    wild_reference = policy.reference(wild)
    assert np.max(np.abs(saturated - wild_reference)) < WILD_TOLERANCE
    # within the bounds as float32 numbers (float32(pi) is a little above pi: the env's own clip takes that)
    low, high = (np.array(policy.about["action"][k], dtype=np.float32) for k in ("low", "high"))
    assert np.all(saturated >= low) and np.all(saturated <= high)
    assert np.any(np.isclose(saturated, low) | np.isclose(saturated, high))  # the bounds were reached


# ------------------------------------------------------------------ refusals and arguments


@pytest.fixture(scope="module")
def refused_runs(tmp_path_factory):
    """Two tiny runs the exporters cannot write: a recurrent PPO, and a PPO over camera images."""
    from pyflyt_cli.training.compose import compose_config
    from pyflyt_cli.training import train

    root = tmp_path_factory.mktemp("refused")
    common = [
        "train.n_envs=1",
        "algo.n_epochs=1",
        "train.eval_freq=100000",
        "train.eval_episodes=1",
        "train.checkpoint_freq=100000",
        "train.progress_bar=false",
        "env.max_duration_seconds=0.5",
        f"train.output_dir={root}",
    ]
    recurrent = [
        "env=quadx_hover",
        "algo=recurrent_ppo",
        "train.total_timesteps=16",
        "algo.n_steps=16",
        "algo.batch_size=16",
        "algo.policy_kwargs.lstm_hidden_size=8",
        "algo.policy_kwargs.net_arch=[8]",
    ]
    camera = ["env=quadx_gates", "algo=ppo", "train.total_timesteps=16", "algo.n_steps=16", "algo.batch_size=16"]
    runs = {}
    for name, overrides in (("recurrent", recurrent), ("camera", camera)):
        runs[name] = train(compose_config(overrides=[*overrides, *common]), run_dir=root / name).run_dir
    return runs


@pytest.mark.parametrize(
    "kind, message",
    [("recurrent", "a recurrent_ppo policy carries an LSTM state"), ("camera", "its policy sees camera images")],
)
def test_recurrent_and_image_policies_are_refused(refused_runs, tmp_path, kind, message):
    for fmt in ("onnx", "c"):
        out = tmp_path / f"policy.{fmt}"
        result = runner.invoke(app, ["export", str(refused_runs[kind]), f"format={fmt}", f"out={out}"])
        assert result.exit_code == 2, result.output
        assert message in result.output and "Traceback" not in result.output
        assert not out.exists() and not out.with_suffix(".h").exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["zoo:quadx_hover_ppo", "format=tflite"], "unknown format 'tflite': write format=onnx or format=c"),
        (["zoo:quadx_hover_ppo"], "format= is missing"),
        (["zoo:quadx_hover_ppo", "format=c", "out=policy.onnx"], "format=c writes a file ending in .c"),
        (["zoo:quadx_hover_ppo", "format=c", "colour=red"], "unknown key 'colour'"),
        (["zoo:quadx_hover_ppo", "format=c", "model=newest"], "unknown model 'newest'"),
        (["zoo:quadx_hover_pop", "format=c"], "zoo:quadx_hover_pop: no such agent"),
        (["no/such/run", "format=onnx"], "run directory no/such/run does not exist"),
        (["zoo:quadx_hover_ppo", "format=c", "out=missing_dir/policy.c"], "does not exist; create it first"),
    ],
)
def test_bad_arguments_exit_2_with_a_message(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["export", *args])
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_an_existing_output_is_replaced_only_with_force(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("policy.h").write_text("/* mine */\n")
    result = runner.invoke(app, ["export", "zoo:quadx_hover_ppo", "format=c"])
    assert result.exit_code == 2 and "policy.h exists: pass --force" in result.output
    assert Path("policy.h").read_text() == "/* mine */\n" and not Path("policy.c").exists()
    result = runner.invoke(app, ["export", "zoo:quadx_hover_ppo", "format=c", "--force"])
    assert result.exit_code == 0, result.output
    assert "wrote:   policy.c" in result.output and "observation normaliser" in result.output
    assert "policy_forward" in Path("policy.h").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["policy.c", "policy.h"]  # no temporary file left


# ------------------------------------------------------------------ the other actor layouts

#: tiny runs of the other actor layouts: their chains match SB3's deterministic actions (and compile)
LAYOUTS = {
    # TD3: a deterministic actor ending in tanh, on the waypoint env (normaliser on, the flattened Dict)
    "td3": ["env=quadx_waypoints", "algo=td3", "algo.normalize.observation=true"],
    # TQC: a squashed Gaussian as SAC's, with an ELU actor
    "tqc": ["env=quadx_hover", "algo=tqc", "algo.policy_kwargs.n_quantiles=5", "algo.policy_kwargs.activation_fn=elu"],
    # PPO with gSDE and a tanh network: the mean clipped, as without gSDE
    "ppo_sde": ["env=rocket_landing", "algo=ppo", "algo.use_sde=true", "algo.policy_kwargs.activation_fn=tanh"],
}
OFF_POLICY = ["train.total_timesteps=64", "algo.buffer_size=200", "algo.learning_starts=32", "algo.batch_size=16"]
ON_POLICY = ["train.total_timesteps=32", "algo.n_steps=32", "algo.batch_size=16", "algo.n_epochs=1"]


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_other_actor_layouts_export_as_the_policy_acts(tmp_path, layout):
    from pyflyt_cli.training.compose import compose_config
    from pyflyt_cli.training import train

    overrides = [
        *LAYOUTS[layout],
        *(ON_POLICY if layout.startswith("ppo") else OFF_POLICY),
        "algo.policy_kwargs.net_arch=[16,16]",
        "train.n_envs=1",
        "train.eval_freq=100000",
        "train.checkpoint_freq=100000",
        "train.progress_bar=false",
        "env.max_duration_seconds=0.5",
        f"train.output_dir={tmp_path}",
    ]
    run = train(compose_config(overrides=overrides), run_dir=tmp_path / layout).run_dir
    policy = deployed_policy(run, "final")
    obs = record(str(run), policy, steps=64)
    obs = np.concatenate([obs, obs + np.random.default_rng(2).normal(size=obs.shape).astype(np.float32)])
    reference = policy.reference(obs)
    assert np.max(np.abs(policy.forward(obs) - reference)) < TOLERANCE
    result = export_policy(run, "c", tmp_path / "policy.c")
    program = compile_c(result.files[0], tmp_path)
    assert np.max(np.abs(run_c(program, obs, policy.act_dim, tmp_path) - reference)) < TOLERANCE


def test_a_layer_the_exporters_do_not_know_is_refused_by_name(tmp_path):
    from pyflyt_cli.training.compose import compose_config
    from pyflyt_cli.training import train

    overrides = [
        "env=quadx_hover",
        "algo=crossq",
        "algo.policy_kwargs.batch_norm_momentum=0.05",
        *OFF_POLICY,
        "algo.policy_kwargs.net_arch=[16,16]",
        "train.n_envs=1",
        "train.eval_freq=100000",
        "train.checkpoint_freq=100000",
        "train.progress_bar=false",
        "env.max_duration_seconds=0.5",
        f"train.output_dir={tmp_path}",
    ]
    run = train(compose_config(overrides=overrides), run_dir=tmp_path / "crossq").run_dir
    result = runner.invoke(app, ["export", str(run), "format=onnx", f"out={tmp_path / 'p.onnx'}"])
    assert result.exit_code == 2, result.output
    assert (
        "the crossq actor holds a BatchRenorm" in result.output and "Linear layers and the activations" in result.output
    )
    assert not (tmp_path / "p.onnx").exists()


def test_the_command_writes_onnx_and_checks_it(tmp_path, monkeypatch):
    pytest.importorskip("onnxruntime")
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["export", "zoo:fixedwing_waypoints_sac", "out=fw.onnx"])  # format from the suffix
    assert result.exit_code == 0, result.output
    assert "wrote:   fw.onnx" in result.output and "tanh of the Gaussian's mean" in result.output
    check = float(result.output.split("actions within ")[1].split()[0])
    assert check < TOLERANCE
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fw.onnx"]


def test_a_failing_onnx_exporter_is_reported_and_writes_nothing(tmp_path, monkeypatch):
    pytest.importorskip("onnxscript")
    import torch

    def broken(*args, **kwargs):
        raise RuntimeError("unsupported operator aten::something\nmore detail")

    monkeypatch.setattr(torch.onnx, "export", broken)
    out = tmp_path / "policy.onnx"
    result = runner.invoke(app, ["export", "zoo:quadx_hover_ppo", "format=onnx", f"out={out}"])
    assert result.exit_code == 2, result.output
    assert "PyTorch's ONNX exporter failed (unsupported operator aten::something)" in result.output
    assert list(tmp_path.iterdir()) == []
