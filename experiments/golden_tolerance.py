"""Where the golden-trajectory tolerance comes from: rounding-sized differences against a real change.

For every case of ``tests/engine/test_golden_trajectories.py`` this measures, over the
recorded horizon, the largest ``|a - b| / (1 + |b|)`` between

* **kernels**: the case computed under other floating-point kernel sets, each in its own
  process with ``PYFLYT_NUMERICS=native`` (so nothing is pinned) and
  ``OPENBLAS_CORETYPE`` = Prescott / Sandybridge / Zen, or NumPy without its AVX2 paths
  (``NPY_DISABLE_CPU_FEATURES=X86_V3``), against the same with no variable set: what
  another CPU does to the numbers;
* **one ulp**: the start altitude (an env: the first action) moved one unit in the last
  place, against the nominal flight: how much a rounding-sized difference grows over the
  horizon;
* **1e-6 change**: the motors' k_F (a rocket: the booster's full thrust) times 1 + 1e-6,
  against the nominal flight (the flight cases only): the smallest change of the model
  the test must catch.

It prints a table and the summary, and writes ``experiments/results/golden_tolerance.md``::

    python experiments/golden_tolerance.py            # every case (a few minutes)
    python experiments/golden_tolerance.py --quick    # one mode per airframe and the envs
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

import pyflyt_engine  # noqa: E402,F401 - pins the kernels in this process (the reference)
import numpy as np  # noqa: E402

from tests.engine import test_golden_trajectories as golden  # noqa: E402

KERNELS = {
    "native": {},
    "Prescott": {"OPENBLAS_CORETYPE": "Prescott"},
    "Sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "Zen": {"OPENBLAS_CORETYPE": "Zen"},
    "no AVX2 NumPy": {"NPY_DISABLE_CPU_FEATURES": "X86_V3"},
}


def _selected(quick: bool) -> list[tuple[str, str]]:
    cases = golden.cases()
    if not quick:
        return cases
    seen, out = set(), []
    for kind, name in cases:
        head = name.split("/")[0] if kind == "fly" else name
        if kind == "env" or head not in seen or name.endswith("/position_yaw"):
            seen.add(head)
            out.append((kind, name))
    return out


def _child(out: str, cases: list[list[str]]) -> None:
    """In a subprocess: compute ``cases`` under this process's kernels into ``out``."""
    np.savez_compressed(out, **{f"{k}:{n}": golden.compute(k, n) for k, n in cases})


def _under(env: dict[str, str], cases: list[tuple[str, str]], folder: Path, label: str) -> dict[str, np.ndarray]:
    out = folder / f"{label.replace(' ', '_')}.npz"
    child_env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    child_env.update({"PYFLYT_NUMERICS": "native", **env, "PYTHONPATH": str(ROOT)})
    subprocess.run(
        [sys.executable, __file__, "--child", str(out), json.dumps([list(c) for c in cases])],
        env=child_env, check=True, cwd=ROOT,
    )  # fmt: skip
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one mode per airframe, and the envs")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    parser.add_argument("--write", default=str(ROOT / "experiments/results/golden_tolerance.md"))
    args = parser.parse_args()
    if args.child:
        _child(args.child[0], json.loads(args.child[1]))
        return
    cases = _selected(args.quick)
    started = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        runs = {label: _under(env, cases, Path(tmp), label) for label, env in KERNELS.items()}
    rows = []
    for kind, name in cases:
        key = f"{kind}:{name}"
        base = runs["native"][key]
        kernels = max(golden.deviation(runs[label][key], base) for label in KERNELS if label != "native")
        ulp = golden.deviation(golden.compute(kind, name, nudge=True), golden.compute(kind, name))
        change = float("nan")
        if kind == "fly":
            uav, mode = name.split("/")
            change = golden.deviation(golden.fly(uav, mode, spec=golden.perturbed(uav)), golden.fly(uav, mode))
        rows.append((key, kernels, ulp, change))
        print(f"{key:48s} kernels {kernels:9.3g}  one ulp {ulp:9.3g}  1e-6 change {change:9.3g}", flush=True)
    finite = [r for r in rows if np.isfinite(r[1]) and np.isfinite(r[2])]
    worst_kernels = max(r[1] for r in rows)
    worst_ulp = max(r[2] for r in rows)
    smallest_change = min(r[3] for r in rows if np.isfinite(r[3]))
    load = os.getloadavg()
    summary = [
        f"cases: {len(rows)} ({len(finite)} with finite rounding deviations)",
        f"largest deviation between kernel sets: {worst_kernels:.3g}",
        f"largest growth of a one-ulp start difference: {worst_ulp:.3g}",
        f"smallest deviation from a 1e-6 change of k_F / thrust: {smallest_change:.3g}",
        f"tolerance in the test: {golden.TOLERANCE:g}",
    ]
    print("\n".join(summary))
    lines = [
        "# Golden-trajectory tolerance: rounding against a real change",
        "",
        f"`python experiments/golden_tolerance.py{' --quick' if args.quick else ''}` on {platform.machine()} "
        f"({_cpu()}), {time.strftime('%Y-%m-%d')}, load average {load[0]:.1f} at the end, "
        f"{time.time() - started:.0f} s.  Deviation = largest `|a - b| / (1 + |b|)` over the horizon.",
        "",
        *[f"- {s}" for s in summary],
        "",
        "Run against the engine before its simulated path left BLAS and NumPy's CPU-dispatched maths (commit",
        "ef5f5e0), the kernel-sets column reached 5.35e-9 (`fly:hexacopter/attitude_z`):",
        "`golden_tolerance_ef5f5e0.md`.",
        "",
        "| case | kernel sets | one ulp | 1e-6 change |",
        "|---|---:|---:|---:|",
        *[f"| `{k}` | {a:.3g} | {b:.3g} | {c:.3g} |" for k, a, b, c in rows],
        "",
    ]
    Path(args.write).write_text("\n".join(lines))
    print(f"wrote {args.write}")


def _cpu() -> str:
    from pyflyt_engine.numerics import platform_info

    return platform_info()["cpu"]


if __name__ == "__main__":
    main()
