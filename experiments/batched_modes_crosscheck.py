"""The batched backend's cascade modes against the PyBullet engine: the figures docs/batched.md
quotes and the bound ``tests/batched/test_crosscheck.py`` derives for them.

For every multirotor the backend flies and every flight mode above the rate loop, both
backends fly QuadX-Waypoints (the velocity mode: its velocity variant) from one start with
the motor noise off, 2 s of random setpoints drawn anew at every agent step (the test's
ranges and seeds, ``fly_cascade_pair``).  Prints, per airframe and mode, the largest
difference of the motor commands, positions [m], observations, rewards and the
controller's integrals, then the largest of each over every case.

    python experiments/batched_modes_crosscheck.py [--markdown]
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args()
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
    sep = " | " if args.markdown else "  "
    header = ["airframe", "mode", "steps", *FIELDS]
    lines = [
        header,
        *[[name, mode, str(flown), *(f"{worst[f]:.1e}" for f in FIELDS)] for name, mode, flown, worst in rows],
    ]
    lines.append(["all", "-", "-", *(f"{max(r[3][f] for r in rows):.1e}" for f in FIELDS)])
    for k, line in enumerate(lines):
        print(("| " if args.markdown else "") + sep.join(line) + (" |" if args.markdown else ""))
        if args.markdown and k == 0:
            print("|" + "---|" * len(header))


if __name__ == "__main__":
    main()
