"""`pyflyt export` of a shared (hostile) run: no text from the run's files can become C code, and a
policy file whose tensors do not fit the observation and action, or hold NaN or inf, is refused in every
format before anything is written.

Written from the reproduction: a run whose ``env.id`` is ``*\\`` + line break + ``/`` followed by an
``__attribute__((constructor))`` function closed the header comment after C's line splicing, and the
compiled test harness ran the attacker's code."""

from __future__ import annotations

import random
import shutil
import subprocess
from pathlib import Path
from urllib.parse import unquote_to_bytes

import numpy as np
import pytest
import torch
import yaml
from typer.testing import CliRunner

from pyflyt_cli.export.c_source import COMMENT_SAFE, HOST_RUNNER, _comment, comment_text
from pyflyt_cli.main import app

runner = CliRunner()

#: pieces an attacker strings together: C's line splice, trigraphs, comment delimiters, digraphs,
#: line breaks of every kind, a NUL, non-ASCII look-alikes
PIECES = [
    "*",
    "/",
    "\\",
    "\n",
    "\r",
    "\r\n",
    "??/",
    "??=",
    "??'",
    "?",
    "%",
    "%:",
    "<:",
    "*/",
    "/*",
    "//",
    "\x00",
    "\x0b",
    "\x0c",
    "\u2028",
    "\u2215",
    "\uff0a",
    "\ud800",
    " ",
    "a",
    "#",
    '"',
    "'",
]


def sample_texts(n: int = 3000, seed: int = 0) -> list[str]:
    rng = random.Random(seed)
    texts = [chr(b) for b in range(256)]  # every byte value, alone
    texts += [a + chr(b) + c for b in range(256) for a, c in (("*", "/"), ("/", "*"), ("", "\n/"))]
    texts += ["".join(rng.choice(PIECES) for _ in range(rng.randint(1, 12))) for _ in range(n)]
    return texts


def test_comment_text_is_inert_and_reversible_for_every_byte_and_splice():
    for text in sample_texts():
        escaped = comment_text(text)
        assert set(escaped) <= COMMENT_SAFE | {"%"}, (text, escaped)
        assert "*/" not in escaped and "/*" not in escaped and "\\" not in escaped and "?" not in escaped
        assert not escaped.startswith("*") and not escaped.endswith("*")  # nothing to pair with the template's '/'
        assert unquote_to_bytes(escaped) == text.encode("utf-8", "surrogatepass")  # %XX decodes back: nothing lost
    assert comment_text("PyFlyt/QuadX-Hover-v0") == "PyFlyt/QuadX-Hover-v0"  # ordinary text is left as it is
    assert comment_text("a * b") == "a * b"


def test_a_comment_line_that_is_not_inert_is_refused():
    from pyflyt_cli.export.policy import ExportError

    for line in ("x */ y", "x /* y", "trigraph ??/", "splice \\", "line\nbreak", "caf\u00e9"):
        with pytest.raises(ExportError, match="not inert C text"):
            _comment(["fine", line])


def gcc() -> str:
    path = shutil.which("gcc")
    if path is None:
        pytest.fail("the C export tests compile the exported source: install gcc (e.g. apt install gcc)")
    return path


def test_escaped_texts_compile_as_one_comment(tmp_path):
    """Every sample (a payload defining a symbol follows each) inside one generated comment: gcc with
    trigraphs on compiles it without a warning and the object defines no payload symbol."""
    texts = sample_texts(600, seed=1)
    lines = [f"v{i}: {comment_text(t + ' int injected_' + str(i) + ' = 1; /*')}" for i, t in enumerate(texts)]
    (tmp_path / "probe.c").write_text(_comment(lines) + "int probe_kept = 1;\n")
    built = subprocess.run(
        [gcc(), "-std=c99", "-trigraphs", "-Wall", "-Wextra", "-Werror", "-c", "probe.c"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert built.returncode == 0, built.stderr
    symbols = subprocess.run(["nm", "probe.o"], cwd=tmp_path, capture_output=True, text=True).stdout
    assert "probe_kept" in symbols and "injected" not in symbols


#: the reproduction's env id: close the comment through a backslash-newline splice, then a constructor
#: function that runs before main and leaves a marker file
def payload(marker: Path) -> str:
    return (
        f'x *\\\n/ __attribute__((constructor)) static void pwn(void) {{ FILE *f = fopen("{marker}", "w"); '
        "if (f) fclose(f); }} /* ??/\n */ int also_injected = 1; //"
    )


@pytest.fixture
def shared_run(tmp_path):
    """A copy of a shipped agent (PPO with a normaliser) as a run directory, to tamper with."""
    from pyflyt_cli.zoo import agent

    run = tmp_path / "run"
    shutil.copytree(agent("quadx_hover_ppo").path, run)
    return run


def edit_config(run: Path, edit) -> None:
    data = yaml.safe_load((run / "config.yaml").read_text())
    edit(data)
    (run / "config.yaml").write_text(yaml.safe_dump(data))


def test_a_hostile_env_id_never_reaches_the_compiled_code(shared_run, tmp_path, monkeypatch):
    from pyflyt_cli.export.policy import deployed_policy

    marker = tmp_path / "PWNED"
    reference = deployed_policy("zoo:quadx_hover_ppo")

    def hostile(data):
        data["env"]["id"] = payload(marker)
        data["env"]["action"]["units"] = ["*\\\n/ int u0 = 1;", "??/", "rad/s*", "1"]
        data["env"]["action"]["names"] = ["p */ int n0;", "q", "r", "thrust"]

    edit_config(shared_run, hostile)
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.chdir(out)
    result = runner.invoke(app, ["export", str(shared_run), "format=c", "out=policy.c"])
    assert result.exit_code == 0, result.output
    source = (out / "policy.c").read_text()
    header = (out / "policy.h").read_text()
    for text in (source, header):
        assert text.isascii() and "??" not in text and "\\" not in text.split("*/", 1)[0]
        comment = text.split("*/", 1)[0]  # the first comment ends at the template's own close
        assert comment.rstrip().endswith("feed finite values.")  # closed by the template, not by the env id
    (out / "main.c").write_text(HOST_RUNNER)
    built = subprocess.run(
        [gcc(), "-std=c99", "-trigraphs", "-Wall", "-Werror", "-O2", "-o", "harness", "main.c", "policy.c", "-lm"],
        cwd=out,
        capture_output=True,
        text=True,
    )
    assert built.returncode == 0, built.stderr
    symbols = subprocess.run(["nm", "harness"], cwd=out, capture_output=True, text=True).stdout
    assert "pwn" not in symbols and "also_injected" not in symbols and "u0" not in symbols.split()
    obs = (np.random.default_rng(0).normal(size=(16, reference.obs_dim)) * 0.5).astype(np.float32)
    (out / "obs.bin").write_bytes(obs.astype("<f4").tobytes())
    ran = subprocess.run(["./harness", "obs.bin", "act.bin"], cwd=out, capture_output=True, text=True)
    assert ran.returncode == 0, ran.stderr
    assert not marker.exists()  # the constructor never ran: it was never compiled
    actions = np.frombuffer((out / "act.bin").read_bytes(), dtype="<f4").reshape(-1, reference.act_dim)
    assert np.max(np.abs(actions - reference.reference(obs))) < 1e-5  # and the policy is intact


def tamper_model(run: Path, edit) -> None:
    """Edit a run's policy file as someone crafting it would: its content digest (if any) recomputed."""
    from pyflyt_cli.training.artifacts import DIGEST_KEY, content_digest

    path = run / "model.pt"
    data = torch.load(path, weights_only=True)
    edit(data)
    torch.save({**data, DIGEST_KEY: content_digest(data)}, path)


def _short_mean(d):
    d["normalizer"]["obs_rms"]["mean"] = d["normalizer"]["obs_rms"]["mean"][:2]


def _nan_var(d):
    d["normalizer"]["obs_rms"]["var"][3] = float("nan")


def _inf_weight(d):
    d["policy"]["action_net.weight"][0, 0] = float("inf")


def _narrow_weight(d):
    d["policy"]["mlp_extractor.policy_net.0.weight"] = d["policy"]["mlp_extractor.policy_net.0.weight"][:, :5]


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            _short_mean,
            "its observation normaliser does not fit this run's env: the observation statistics: the mean "
            "has shape [2], the observation [21]",
        ),
        (_nan_var, "the observation statistics: the variance holds NaN or inf"),
        (_inf_weight, "non-finite"),
        (_narrow_weight, "its policy does not fit this model"),
    ],
    ids=["short-mean", "nan-variance", "inf-weight", "narrow-weight"],
)
@pytest.mark.parametrize("fmt", ["c", "onnx"])
def test_a_tampered_policy_is_refused_in_every_format(shared_run, tmp_path, edit, message, fmt):
    tamper_model(shared_run, edit)
    out = tmp_path / f"policy.{fmt}"
    result = runner.invoke(app, ["export", str(shared_run), f"format={fmt}", f"out={out}"])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1, result.output
    assert message in result.output
    assert not out.exists() and not out.with_suffix(".h").exists()


def test_a_c_file_name_outside_the_fixed_alphabet_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name in ("p??.c", "p o.c", "p\u00e9.c"):
        result = runner.invoke(app, ["export", "zoo:quadx_hover_ppo", "format=c", f"out={name}"])
        assert result.exit_code == 2, result.output
        assert "letters, digits" in result.output
    assert list(tmp_path.iterdir()) == []
