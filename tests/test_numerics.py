"""The numeric platform: pinned kernels in every process, an opt-out, and what a run records.

Another CPU is emulated on this one by the variables each library reads to choose its
kernels (``EMULATED``): OpenBLAS's core type, NumPy's SIMD targets, PyTorch's CPU
capability, MKL's code branch and oneDNN's instruction set.  Pinned (the default), a
process computes with the pinned kernels whatever those say; with ``PYFLYT_NUMERICS=native``
it computes with what they select, so the emulation is real and the pin is what undoes it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from pyflyt_engine import numerics

EMULATED = {
    "OPENBLAS_CORETYPE": "Prescott",
    "NPY_DISABLE_CPU_FEATURES": "X86_V3",
    "ATEN_CPU_CAPABILITY": "default",
    "MKL_CBWR": "COMPATIBLE",
    "ONEDNN_MAX_CPU_ISA": "SSE41",
}

#: in a fresh process: the kernels in force and the bits of a few computations that go
#: through each library's CPU-dispatched kernels (a float32 MLP trained by Adam a few steps
#: in torch, NumPy's float32 maths, a BLAS product)
PROBE = r"""
import hashlib, json
import pyflyt_engine
import numpy as np, torch
from pyflyt_engine import numerics
torch.set_num_threads(1)
numerics.apply_torch()
torch.manual_seed(0)
net = torch.nn.Sequential(torch.nn.Linear(34, 64), torch.nn.Tanh(), torch.nn.Linear(64, 4))
opt = torch.optim.Adam(net.parameters(), lr=1e-3)
for _ in range(5):
    loss = (net(torch.randn(256, 34)) ** 2).mean()
    opt.zero_grad(); loss.backward(); opt.step()
weights = torch.cat([p.detach().flatten() for p in net.parameters()]).numpy()
x = np.random.default_rng(0).uniform(-3, 3, 4096)
digest = lambda a: hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16]
a = np.random.default_rng(1).standard_normal((64, 64))
print(json.dumps({
    "info": numerics.platform_info(),
    "torch": digest(weights),
    "numpy": digest(np.tanh(x)) + digest(np.exp(x.astype(np.float32))),
    "blas": digest(a @ a @ a),
}))
"""


def probe(**env: str) -> dict:
    base = {k: v for k, v in os.environ.items() if k not in (*EMULATED, numerics.MODE_VARIABLE)}
    done = subprocess.run([sys.executable, "-c", PROBE], env={**base, **env}, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.fixture(scope="module")
def probes() -> dict[str, dict]:
    return {
        "pinned": probe(),
        "pinned, emulated": probe(**EMULATED),
        "native": probe(PYFLYT_NUMERICS="native"),
        "native, emulated": probe(PYFLYT_NUMERICS="native", **EMULATED),
    }


def test_this_machine_can_run_the_pinned_kernels():
    """The suite's claims below need the pinned kernel set (x86_64 Linux, AVX2, FMA)."""
    assert numerics.pinnable() == (True, "")


def test_every_process_computes_with_the_pinned_kernels_whatever_the_cpu_would_choose(probes):
    pinned, emulated = probes["pinned"], probes["pinned, emulated"]
    for result in (pinned, emulated):
        kernels = result["info"]["kernels"]
        assert [b["kernels"] for b in kernels["openblas"]] == ["Haswell"]
        assert "X86_V3" in kernels["numpy_simd"].split() and "X86_V4" not in kernels["numpy_simd"].split()
        assert kernels["torch"] == {"capability": "AVX2", "mkl_cbwr": "COMPATIBLE,STRICT", "onednn": "off"}
        assert result["info"]["status"].startswith("pinned")
    assert {k: emulated[k] for k in ("torch", "numpy", "blas")} == {k: pinned[k] for k in ("torch", "numpy", "blas")}
    assert emulated["info"]["key"] == pinned["info"]["key"] and "cpu" not in pinned["info"]["key"]


def test_the_emulation_is_real_and_native_opts_out(probes):
    """Without the pin, the emulated CPU's kernels are in force and round differently."""
    native, emulated = probes["native"], probes["native, emulated"]
    kernels = emulated["info"]["kernels"]
    assert [b["kernels"] for b in kernels["openblas"]] != ["Haswell"]  # Prescott's (OpenBLAS names it Katmai)
    assert "X86_V3" not in kernels["numpy_simd"].split()
    assert kernels["torch"]["capability"] == "DEFAULT" and kernels["torch"]["mkl_cbwr"] == "COMPATIBLE"
    assert native["info"]["mode"] == "native" and native["info"]["status"].startswith("PYFLYT_NUMERICS=native")
    assert native["info"]["key"]["cpu"] == native["info"]["cpu"]  # an unpinned run names its CPU
    for part in ("torch", "numpy"):
        assert emulated[part] != native[part], part
    assert emulated["info"]["key"] != native["info"]["key"]
    # and the pinned numbers are neither: MKL's reproducible branch rounds as no default does
    assert probes["pinned"]["torch"] not in (native["torch"], emulated["torch"])


def test_a_library_loaded_before_the_engine_is_reported_not_pinned():
    code = (
        "import json, numpy, torch; torch.tanh(torch.ones(3)) @ torch.ones(3)\n"
        "import pyflyt_engine\nfrom pyflyt_engine import numerics\n"
        "print(json.dumps(numerics.platform_info()))"
    )
    base = {k: v for k, v in os.environ.items() if k not in (*EMULATED, numerics.MODE_VARIABLE)}
    done = subprocess.run([sys.executable, "-c", code], env={**base, **EMULATED}, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    assert info["status"].startswith("not all pinned: numpy and torch were loaded before pyflyt_engine")
    assert info["key"]["numerics"] == "native" and info["key"]["cpu"] == info["cpu"]


def test_an_unknown_mode_is_refused_by_the_command_line(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "pyflyt_cli.main", "modes"],
        env={**os.environ, numerics.MODE_VARIABLE: "fast"}, capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "error: PYFLYT_NUMERICS='fast' is not a numerics mode: use PYFLYT_NUMERICS=pinned (the same numbers on "
        "every AVX2 CPU, the default) or PYFLYT_NUMERICS=native (each library picks kernels for this CPU)"
    ]


def test_differences_are_described_in_one_line():
    key = {"machine": "x86_64", "libc": "glibc 2.36", "numerics": "pinned", "versions": {"numpy": "2.4.6"}}
    assert numerics.describe_difference(key, dict(key)) is None
    assert numerics.describe_difference(None, key) is None
    other = {**key, "numerics": "native", "cpu": "Intel Xeon"}
    assert numerics.describe_difference(key, other) == "cpu - -> Intel Xeon; numerics pinned -> native"
    assert numerics.describe_difference(key, {**key, "versions": {"numpy": "2.5.0"}}) == "versions differ"
