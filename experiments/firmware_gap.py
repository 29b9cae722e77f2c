"""The sim-to-firmware gap: a policy trained on the project's own rate controller, flown
through Betaflight's firmware -- the figures docs/firmware.md quotes.

The shipped hover policy (``zoo:quadx_hover_ppo``, PPO on the cf2x's own rate loop, 30 Hz
``rates_thrust`` actions) is evaluated by ``pyflyt eval`` on the same episodes (seeds
1000 ...) in four ways:

* ``own``: its own controller, as trained (240 / 120 / 30 Hz);
* ``own_500hz``: its own controller at the firmware case's loop rates (1500 / 500 / 30 Hz);
* ``betaflight``: ``env.controller=betaflight env.firmware_action=rates`` with the firmware's
  rate PIDs matched to the airframe's rate loop (``pids: matched``, the default);
* ``betaflight_defaults``: the same with Betaflight's default PIDs (``pids: firmware``, an
  airframe YAML naming them).

Each case runs ``pyflyt eval`` in its own directory; the success rates, returns and held
distances are printed and, with ``--write``, written to
experiments/results/firmware_gap.md.

    python experiments/firmware_gap.py [--episodes 10] [--write]

Needs the patched SITL (python -m pyflyt_engine.firmware.build).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import yaml

from pyflyt_cli.studies.runs import pyflyt_command
from pyflyt_engine.numerics import platform_info

ROOT = Path(__file__).resolve().parent.parent
POLICY = "zoo:quadx_hover_ppo"


def _defaults_airframe(directory: Path) -> Path:
    """The cf2x naming Betaflight's own PIDs (``control.firmware.pids: firmware``)."""
    data = yaml.safe_load((ROOT / "conf" / "uav" / "quadx_cf2x.yaml").read_text())
    data["name"] = "quadx_cf2x_betaflight_defaults"
    data["control"]["firmware"] = {"mode": "acro", "pids": "firmware"}
    path = directory / "quadx_cf2x_betaflight_defaults.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _cases(directory: Path) -> dict[str, list[str]]:
    firmware = ["env.controller=betaflight", "env.firmware_action=rates"]
    return {
        "own": [],
        "own_500hz": ["env.physics_hz=1500", "env.control_hz=500"],
        "betaflight": firmware,
        "betaflight_defaults": [*firmware, f"env.uav={_defaults_airframe(directory)}"],
    }


def _evaluate(name: str, overrides: list[str], episodes: int, directory: Path) -> dict:
    work = directory / name
    work.mkdir()
    command = ["eval", POLICY, f"episodes={episodes}", "record=false", *overrides]
    start = time.perf_counter()
    pyflyt_command(command, work)
    (found,) = work.glob("zoo/*/eval.json")
    result = json.loads(found.read_text())
    result["wall_s"] = time.perf_counter() - start
    result["command"] = " ".join(["pyflyt", *command])
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--write", action="store_true", help="write experiments/results/firmware_gap.md")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="pyflyt-firmware-gap-") as tmp:
        for name, overrides in _cases(Path(tmp)).items():
            r = _evaluate(name, overrides, args.episodes, Path(tmp))
            distance = r["measures"].get("distance_mean", float("nan"))
            row = (
                f"| {name} | {100 * r['success_rate']:.0f} % | {r['mean_return']:.2f} +- {r['std_return']:.2f} | "
                f"{r['mean_length']:.1f} | {distance:.3f} | {r['wall_s']:.0f} |"
            )
            print(row, flush=True)
            rows.append((row, r["command"].replace(tmp, "<tmp>")))
    load = os.getloadavg()
    lines = [
        "# The sim-to-firmware gap: the shipped hover policy through Betaflight",
        "",
        f"`python experiments/firmware_gap.py --episodes {args.episodes} --write` "
        f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {platform.machine()}, "
        f"{platform_info()['cpu']}, {os.cpu_count()} CPUs; load average {load[0]:.1f} at the end).",
        "",
        f"{POLICY}, deterministic actions, {args.episodes} episodes from seed 1000 each, 10 s episodes (300 steps).",
        "",
        "| case | success | return (mean +- std) | length [steps] | mean distance held [m] | wall [s] |",
        "|---|---|---|---|---|---|",
        *(row for row, _ in rows),
        "",
        "Commands:",
        "",
        *(f"- `{command}`" for _, command in rows),
        "",
    ]
    if args.write:
        out = ROOT / "experiments" / "results" / "firmware_gap.md"
        out.write_text("\n".join(lines))
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
