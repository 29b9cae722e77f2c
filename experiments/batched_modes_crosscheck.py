"""The batched backend's cascade modes against the PyBullet engine: the figures docs/batched.md
quotes and the bound ``tests/batched/test_crosscheck.py`` derives for them.

For every multirotor the backend flies and every flight mode above the rate loop, both
backends fly QuadX-Waypoints (the velocity mode: its velocity variant) from one start with
the motor noise off, 2 s of random setpoints drawn anew at every agent step (the test's
ranges and seeds, ``fly_cascade_pair``).  Prints, per airframe and mode, the largest
difference of the motor commands, positions [m], observations, rewards and the
controller's integrals, then the largest of each over every case.

With ``--routed``, the same for the multirotors whose actuators the channels route beside the
mixer (the bound ``tests/batched/test_vtol.py`` derives for them): the tricopter (its tail on
the servo the mixer flies), the quadplane (a pusher and five lifting surfaces on the
setpoint's channels) and the test's quad with a two-axis gimbal on two channels, in every
multirotor mode (``rates_thrust``, ``motors`` and the nine above the rate loop: the test's
ranges and seeds, ``fly_routed_pair``), with the gimbal angles [rad] and flap commands.

    python experiments/batched_modes_crosscheck.py [--markdown] [--routed]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import yaml

from pyflyt_engine.paths import uav_dir
from tests.batched.test_crosscheck import CASCADE_ACTIONS, fly_cascade_pair
from tests.batched.test_laws import MULTIROTORS

FIELDS = ("command", "position", "observation", "reward", "integral")
ROUTED_FIELDS = ("command", "gimbal", "flap", "position", "observation", "reward")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    parser.add_argument("--routed", action="store_true", help="the tricopter, the quadplane and a channel gimbal")
    args = parser.parse_args()
    if args.routed:
        print_worst(_routed_rows(), ROUTED_FIELDS, args.markdown)
        return
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name in MULTIROTORS:
            data = yaml.safe_load((uav_dir() / f"{name}.yaml").read_text())
            data["motors"]["noise_ratio"] = 0.0  # the two backends draw their noise apart
            path = Path(folder) / f"{name}.yaml"
            path.write_text(yaml.safe_dump(data))
            for mode in CASCADE_ACTIONS:
                worst, flown = fly_cascade_pair(str(path), mode)
                rows.append((name, mode, flown, worst))
    print_worst(rows, FIELDS, args.markdown)


def _routed_rows() -> list:
    from tests.batched.test_vtol import AIRFRAMES, MODES, _data, fly_routed_pair

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name in AIRFRAMES:
            data = _data(name)
            data["motors"]["noise_ratio"] = 0.0
            path = Path(folder) / f"{name}.yaml"
            path.write_text(yaml.safe_dump(data))
            for mode in MODES:
                worst, flown = fly_routed_pair(str(path), mode)
                rows.append((name, mode, flown, worst))
    return rows


def print_worst(rows: list, fields: tuple[str, ...], markdown: bool) -> None:
    """Per (airframe, mode, steps flown, worst differences) row its ``fields``, then the largest
    of each over every row: columns apart, or a Markdown table."""
    sep = " | " if markdown else "  "
    header = ["airframe", "mode", "steps", *fields]
    lines = [
        header,
        *[[name, mode, str(flown), *(f"{worst[f]:.1e}" for f in fields)] for name, mode, flown, worst in rows],
    ]
    lines.append(["all", "-", "-", *(f"{max(r[3][f] for r in rows):.1e}" for f in fields)])
    for k, line in enumerate(lines):
        print(("| " if markdown else "") + sep.join(line) + (" |" if markdown else ""))
        if markdown and k == 0:
            print("|" + "---|" * len(header))


if __name__ == "__main__":
    main()
