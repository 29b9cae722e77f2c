"""Does any simulated number depend on the CPU's numeric kernels?  Emulate other CPUs and compare.

NumPy's OpenBLAS picks its kernels by CPU at run time (``DYNAMIC_ARCH``), and NumPy picks
its own SIMD loops by CPU too; a simulated number that goes through either can come out
different on another machine.  Both can be made to use another CPU's kernels here:
``OPENBLAS_CORETYPE=Prescott`` (or Nehalem, Sandybridge, Zen, Haswell) and
``NPY_DISABLE_CPU_FEATURES=X86_V3`` (NumPy's baseline loops instead of its AVX2/FMA3
ones).  This script hashes a set of trajectories in a fresh subprocess under each of
those settings (``PYFLYT_NUMERICS=native`` in every one, so nothing pins the kernels
back) and prints, per setting, the cases whose hash differs from the run without any
emulation.

The cases: every case of ``tests/engine/test_golden_trajectories.py`` (every airframe in
every flight mode, the four paper envs), every other registered Gymnasium id (hashing
every observation entry, camera images included), the two multi-agent envs through
their PettingZoo parallel API, and variants with wind (``dryden_*``, gust, shear,
constant), domain randomisation (``randomize=moderate``), ground effect and downwash.

AVX-512 machines use SVML-based float64 ``sin, cos, exp, log, ...`` loops that cannot be
emulated on a machine without AVX-512; ``--audit`` lists the source lines of the engine
that call NumPy transcendental functions, BLAS/LAPACK (``@``, ``dot``, ``np.linalg``,
``scipy.linalg``) or ``einsum`` instead, for a reader to check that none is on the
simulated path.

    python experiments/kernel_independence.py [--jobs 2] [--only SUBSTRING] [--audit]

Run it from the repository root (the subprocesses import ``pyflyt_engine`` from there).
"""

from __future__ import annotations

import argparse
import ast
import concurrent.futures
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: name -> extra environment variables of the subprocess
EMULATIONS: dict[str, dict[str, str]] = {
    "none": {},
    "blas=Prescott": {"OPENBLAS_CORETYPE": "Prescott"},
    "blas=Nehalem": {"OPENBLAS_CORETYPE": "Nehalem"},
    "blas=Sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "blas=Zen": {"OPENBLAS_CORETYPE": "Zen"},
    "blas=Haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "npy=-X86_V3": {"NPY_DISABLE_CPU_FEATURES": "X86_V3"},
    "all": {"OPENBLAS_CORETYPE": "Prescott", "NPY_DISABLE_CPU_FEATURES": "X86_V3"},
}

#: (name, gymnasium id, make kwargs) of the single-agent cases beyond the golden ones
ENV_VARIANTS: list[tuple[str, str, dict]] = [
    ("pole_balance", "PyFlyt/QuadX-Pole-Balance-v0", {}),
    ("pole_waypoints", "PyFlyt/QuadX-Pole-Waypoints-v0", {}),
    ("ball_in_cup", "PyFlyt/QuadX-Ball-In-Cup-v0", {}),
    ("gates", "PyFlyt/QuadX-Gates-v0", {}),
    ("hover_dryden_light", "PyFlyt/QuadX-Hover-v0", {"wind": "dryden_light"}),
    ("hover_dryden_moderate", "PyFlyt/QuadX-Hover-v0", {"wind": "dryden_moderate"}),
    ("hover_dryden_severe", "PyFlyt/QuadX-Hover-v0", {"wind": "dryden_severe"}),
    ("hover_gust", "PyFlyt/QuadX-Hover-v0", {"wind": "gust"}),
    ("hover_shear", "PyFlyt/QuadX-Hover-v0", {"wind": "shear"}),
    ("hover_constant", "PyFlyt/QuadX-Hover-v0", {"wind": "constant"}),
    ("hover_randomize", "PyFlyt/QuadX-Hover-v0", {"randomize": "moderate"}),
    ("hover_ground_effect", "PyFlyt/QuadX-Hover-v0", {"ground_effect": True}),
    ("waypoints_randomize_dryden", "PyFlyt/QuadX-Waypoints-v0", {"randomize": "moderate", "wind": "dryden_moderate"}),
    ("fixedwing_dryden", "PyFlyt/Fixedwing-Waypoints-v0", {"wind": "dryden_moderate"}),
    ("fixedwing_randomize", "PyFlyt/Fixedwing-Waypoints-v0", {"randomize": "moderate"}),
    ("rocket_randomize_dryden", "PyFlyt/Rocket-Landing-v0", {"randomize": "moderate", "wind": "dryden_light"}),
]

#: (name, PettingZoo module, parallel_env kwargs) of the multi-agent cases
MA_VARIANTS: list[tuple[str, str, dict]] = [
    ("ma_hover", "pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0", {}),
    (
        "ma_hover_downwash_dryden",
        "pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0",
        {"downwash": True, "wind": "dryden_light"},
    ),
    ("ma_dogfight", "pyflyt_engine.envs.multi_agent.ma_fixedwing_dogfight_v0", {}),
]


def _digest(rows: list[bytes]) -> str:
    h = hashlib.sha256()
    for row in rows:
        h.update(row)
    return h.hexdigest()


def _obs_bytes(obs) -> bytes:
    """Every entry of an observation (a Dict's in key order), as raw bytes."""
    import numpy as np

    if isinstance(obs, dict):
        return b"".join(_obs_bytes(obs[k]) for k in sorted(obs))
    return np.ascontiguousarray(obs).tobytes()


def _run_gym(env_id: str, kwargs: dict, episodes: int = 2, steps: int = 150) -> str:
    import gymnasium
    import numpy as np

    import pyflyt_engine  # noqa: F401  (registers the ids)

    env = gymnasium.make(env_id, **kwargs)
    env.action_space.seed(0)
    rows = []
    for episode in range(episodes):
        obs, _ = env.reset(seed=episode)
        rows.append(_obs_bytes(obs))
        for _ in range(steps):
            obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            rows.append(_obs_bytes(obs) + np.array([reward, terminated, truncated], dtype=np.float64).tobytes())
            if terminated or truncated:
                break
    env.close()
    return _digest(rows)


def _run_ma(module: str, kwargs: dict, episodes: int = 2, steps: int = 120) -> str:
    import importlib

    import numpy as np

    env = importlib.import_module(module).parallel_env(**kwargs)
    rows = []
    for episode in range(episodes):
        observations, _ = env.reset(seed=episode)
        rows += [_obs_bytes(observations[a]) for a in sorted(observations)]
        for step in range(steps):
            if not env.agents:
                break
            actions = {}
            for i, agent in enumerate(sorted(env.agents)):
                space = env.action_space(agent)
                space.seed(1000 * episode + 10 * step + i)
                actions[agent] = space.sample()
            observations, rewards, terminations, truncations, _ = env.step(actions)
            for a in sorted(observations):
                flags = [rewards[a], terminations[a], truncations[a]]
                rows.append(_obs_bytes(observations[a]) + np.array(flags, dtype=np.float64).tobytes())
    env.close()
    return _digest(rows)


def _golden_trajectories():
    """``tests/engine/test_golden_trajectories.py`` (its cases and their computation), loaded from its file."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "golden_trajectories", ROOT / "tests" / "engine" / "test_golden_trajectories.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def all_cases() -> list[str]:
    """Every case name, in table order."""
    cases = _golden_trajectories().cases
    return (
        [f"{kind}:{name}" for kind, name in cases()]
        + [f"env+:{n}" for n, _, _ in ENV_VARIANTS]
        + [f"ma:{n}" for n, _, _ in MA_VARIANTS]
    )


def compute_case(case: str) -> str:
    """The trajectory hash of one case, in this process."""
    kind, _, name = case.partition(":")
    if kind in ("fly", "env"):
        return _golden_trajectories().compute(kind, name)
    if kind == "env+":
        _, env_id, kwargs = next(v for v in ENV_VARIANTS if v[0] == name)
        return _run_gym(env_id, kwargs)
    if kind == "ma":
        _, module, kwargs = next(v for v in MA_VARIANTS if v[0] == name)
        return _run_ma(module, kwargs)
    raise ValueError(f"unknown case {case!r}")


def run_under(emulation: str, cases: list[str]) -> dict[str, str]:
    """Hashes of ``cases`` computed in a fresh subprocess under one emulation setting."""
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    env.update(EMULATIONS[emulation])
    env["PYFLYT_NUMERICS"] = "native"
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    out = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--worker"],
        input=json.dumps(cases),
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode != 0:
        raise RuntimeError(f"worker under {emulation} failed:\n{out.stderr[-4000:]}")
    return json.loads(out.stdout.splitlines()[-1])


def _worker() -> None:
    cases = json.loads(sys.stdin.read())
    hashes = {case: compute_case(case) for case in cases}
    print(json.dumps(hashes))


# ----------------------------------------------------------------- static audit

#: NumPy functions whose float64 result may depend on the CPU's kernels (SVML on AVX-512) or on BLAS
SUSPECT_NUMPY = {
    "sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "exp", "expm1", "exp2", "log",
    "log1p", "log2", "log10", "power", "float_power", "tanh", "sinh", "cosh", "cbrt", "dot", "vdot",
    "inner", "matmul", "tensordot", "einsum", "einsum_path", "linalg",
}  # fmt: skip
#: files outside the simulated path (drawing, video, plots, recording)
NOT_SIMULATED = {"telemetry/video.py", "telemetry/scene.py", "telemetry/plots.py"}
#: (file, text of the line, why it is not a dependence): the audit's findings checked by hand
EXPLAINED = [
    ("atmosphere/dryden.py", "base**1.2", "Python floats: ** is libm's pow"),
    ("atmosphere/dryden.py", "base**0.4", "Python floats: ** is libm's pow"),
    ("atmosphere/dryden.py", "** (1 / 3)", "Python floats: ** is libm's pow"),
    ("atmosphere/field.py", "** mean.exponent", "Python floats (PyBullet's height, the config's exponent)"),
    ("envs/env.py", ".dot(_zeros(", "finiteness test: a dot product with zeros is 0 on any kernel unless NaN/inf"),
    ("envs/multi_agent/base.py", ".dot(np.zeros(", "finiteness test: a dot product with zeros is 0 on any kernel"),
    ("telemetry/recorder.py", "body.T @ rot", "recording only (camera frustum pose in the MCAP scene)"),
]


def audit(package: Path) -> list[tuple[str, int, str, str]]:
    """(file, line, what, why harmless or "") of every call that may go through CPU-dispatched kernels."""
    found = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package).as_posix()
        if rel in NOT_SIMULATED:
            continue
        source = path.read_text()
        lines = source.splitlines()
        tree = ast.parse(source, filename=str(path))
        for node in ast.walk(tree):
            what = None
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
                what = "@ (BLAS for arrays)"
            elif isinstance(node, ast.Attribute):
                base = node.value
                if isinstance(base, ast.Name) and base.id in ("np", "numpy") and node.attr in SUSPECT_NUMPY:
                    what = f"np.{node.attr}"
                elif isinstance(base, ast.Name) and base.id in ("linalg", "scipy") or node.attr == "linalg":
                    what = "scipy/numpy linalg"
                elif node.attr == "dot" and not (isinstance(base, ast.Name) and base.id == "exact"):
                    what = ".dot (BLAS)"
            elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
                exponent = node.right
                simple = isinstance(exponent, ast.Constant) and exponent.value in (2, 0.5, -1, 1, 0, 2.0, 1.0, 0.0)
                if not simple and not isinstance(node.left, ast.Constant):  # 2.0 ** k: a Python float
                    what = "** (np.power when the base is an array)"
            if what is not None:
                text = lines[node.lineno - 1]
                why = next((w for f, t, w in EXPLAINED if f == rel and t in text), "")
                found.append((f"pyflyt_engine/{rel}", node.lineno, what, why))
    return sorted(set(found))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--jobs", type=int, default=2, help="subprocesses at once (default 2)")
    parser.add_argument("--only", default="", help="only the cases whose name contains this")
    parser.add_argument("--emulations", default=",".join(EMULATIONS), help="comma-separated subset of the settings")
    parser.add_argument("--audit", action="store_true", help="also list suspicious calls in the engine's source")
    args = parser.parse_args()
    if args.worker:
        _worker()
        return

    cases = [c for c in all_cases() if args.only in c]
    emulations = [e for e in args.emulations.split(",") if e]
    if "none" not in emulations:
        emulations.insert(0, "none")
    start = time.perf_counter()
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        results = dict(zip(emulations, pool.map(lambda e: run_under(e, cases), emulations)))
    base = results["none"]
    print(f"{len(cases)} cases under {len(emulations)} settings, {time.perf_counter() - start:.0f} s "
          f"(PYFLYT_NUMERICS=native in each)\n")  # fmt: skip
    others = [e for e in emulations if e != "none"]
    differs = {e: {c for c in cases if results[e][c] != base[c]} for e in others}
    width = max(len(e) for e in emulations)
    print(f"{'setting':<{width}}  cases whose hash differs from 'none'")
    for emulation in others:
        print(f"{emulation:<{width}}  {len(differs[emulation]):>3} of {len(cases)}")
    changed = [c for c in cases if any(c in d for d in differs.values())]
    if changed:
        column = max(len(e) for e in others) + 2
        name = max(len(c) for c in changed) + 2
        print(f"\nx: differs from 'none'\n{'case':<{name}}" + "".join(f"{e:>{column}}" for e in others))
        for case in changed:
            print(f"{case:<{name}}" + "".join(f"{'x' if case in differs[e] else '.':>{column}}" for e in others))
    print(f"\n{len(cases) - len(changed)} of {len(cases)} cases identical under every setting")
    if args.audit:
        findings = audit(ROOT / "pyflyt_engine")
        print("\nstatic audit: calls that may use CPU-dispatched kernels (not in video.py, scene.py, plots.py)")
        for file, line, what, why in findings:
            print(f"  {file}:{line}: {what}" + (f"  -- checked: {why}" if why else "  -- NOT EXPLAINED"))
        unexplained = sum(1 for *_, why in findings if not why)
        print(f"{len(findings)} found, {unexplained} not explained")


if __name__ == "__main__":
    main()
