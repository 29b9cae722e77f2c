"""How closely the exported policies reproduce the trained ones: the table of docs/deploy.md.

For each shipped agent below: fly its policy for 1,000 agent steps (episodes from seeds 0,
1, ...), export it to ONNX and to C (``pyflyt_cli.export``), compile the C with
``gcc -std=c99 -Wall -Werror -O2``, and print the largest absolute difference between
the actions of each and the run's PyTorch policy (SB3's deterministic action, rescaled
and clipped as the env receives it), in the env's units.  Needs the ``[export]`` extra
and gcc.  Where ``arm-none-eabi-gcc`` is installed (Debian: gcc-arm-none-eabi), it also
compiles each C export for a Cortex-M4 with its single-precision FPU and reports the
flash it takes and the double-precision library calls in it (none expected).

    python experiments/export_precision.py [--steps 1000]
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from pyflyt_cli.export.c_source import HOST_RUNNER
from pyflyt_cli.export import export_policy
from pyflyt_cli.export.onnx_model import run_onnx
from pyflyt_cli.export.policy import deployed_policy, flown_observations

AGENTS = ("quadx_hover_ppo", "fixedwing_waypoints_sac")


def c_actions(source: str, obs: np.ndarray, act_dim: int, folder: Path) -> np.ndarray:
    export_policy(source, "c", folder / "policy.c", force=True)
    (folder / "main.c").write_text(HOST_RUNNER)
    gcc = shutil.which("gcc") or "gcc"
    subprocess.run(
        [gcc, "-std=c99", "-Wall", "-Werror", "-O2", "-o", "run", "main.c", "policy.c", "-lm"], cwd=folder, check=True
    )
    (folder / "obs.bin").write_bytes(np.ascontiguousarray(obs, dtype="<f4").tobytes())
    subprocess.run([str(folder / "run"), "obs.bin", "act.bin"], cwd=folder, check=True)
    return np.frombuffer((folder / "act.bin").read_bytes(), dtype="<f4").reshape(-1, act_dim)


ARM = [
    "-std=c99",
    "-mcpu=cortex-m4",
    "-mthumb",
    "-mfpu=fpv4-sp-d16",
    "-mfloat-abi=hard",
    "-Wall",
    "-Wextra",
    "-Wdouble-promotion",
    "-Werror",
    "-O2",
    "-c",
    "policy.c",
    "-o",
    "policy.o",
]


def cortex_m4(folder: Path) -> str | None:
    """``flash bytes, double calls`` of ``folder/policy.c`` built for a Cortex-M4F, or None without the compiler."""
    gcc = shutil.which("arm-none-eabi-gcc")
    if gcc is None:
        return None
    subprocess.run([gcc, *ARM], cwd=folder, check=True)
    size = subprocess.run(["arm-none-eabi-size", "policy.o"], cwd=folder, check=True, capture_output=True, text=True)
    text = int(size.stdout.splitlines()[1].split()[0])
    dump = subprocess.run(
        ["arm-none-eabi-objdump", "-d", "policy.o"], cwd=folder, check=True, capture_output=True, text=True
    )
    doubles = sum("__aeabi_d" in line for line in dump.stdout.splitlines())
    return f"{text / 1024:.1f} KiB flash, {doubles} double-precision calls"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1000, help="observations flown per agent")
    args = parser.parse_args()
    rows = []
    for name in AGENTS:
        source = f"zoo:{name}"
        policy = deployed_policy(source)
        obs = flown_observations(source, policy, args.steps)
        reference = policy.reference(obs)
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            export_policy(source, "onnx", folder / "policy.onnx")
            onnx = np.max(np.abs(run_onnx(folder / "policy.onnx", obs) - reference))
            c = np.max(np.abs(c_actions(source, obs, policy.act_dim, folder) - reference))
            arm = cortex_m4(folder)
        rows.append(f"| `{source}` | {onnx:.1e} | {c:.1e} |" + (f" {arm} |" if arm else ""))
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    print(f"largest absolute difference over {args.steps} flown observations, in the env's units\n")
    arm = " Cortex-M4F (arm-none-eabi-gcc -O2) |" if shutil.which("arm-none-eabi-gcc") else ""
    print("| policy | ONNX (onnxruntime) | C (gcc -O2) |" + arm + "\n|---|---|---|" + ("---|" if arm else ""))
    print("\n".join(rows))


if __name__ == "__main__":
    main()
