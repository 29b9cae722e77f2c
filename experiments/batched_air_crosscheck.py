"""The batched backend's air against the PyBullet engine: the figures docs/batched.md quotes
for the winds, the turbulence and ground effect, within the bound
``tests/batched/test_crosscheck.py`` derives (1e-6).

For every airframe the backend flies and every case of ``tests/batched/test_air.py`` --
the deterministic winds (constant, shear, gust and the variants reaching every branch of
the gust and the power law), Dryden turbulence with the engine's white noise injected into
the batched filter, ground effect near the ground, the velocity variant (a cascade mode) in
the wind -- both backends fly 2 s from one start
with the motor noise off (the test's actions and seeds, ``fly_air_pair``).  Prints per
case the largest difference of the positions [m], observations and rewards, how far the
flight got from the same flight in calm air (or out of ground effect) [m], then the
largest of each difference over every case.

    python experiments/batched_air_crosscheck.py [--markdown]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import yaml

from pyflyt_engine.paths import uav_dir
from tests.batched.test_air import DETERMINISTIC, VARIANTS, fly_air_pair, fly_cascade_air_pair
from tests.batched.test_laws import FIXEDWINGS, MULTIROTORS

FIELDS = ("position", "observation", "reward")


def cases() -> list[tuple[str, str, str | None, str | None, bool]]:
    """(airframe, label, wind, fixed-wing mode, ground effect) as the tests fly them."""
    out = []
    for name in MULTIROTORS:
        for wind in (*DETERMINISTIC, *VARIANTS, "dryden_light", "dryden_severe", "on_shear_and_gust"):
            out.append((name, wind, wind, None, False))
        out.append((name, "ground_effect", None, None, True))
        for wind in ("gust_fast", "shear", "on_shear_and_gust"):
            out.append((name, f"{wind} (velocity_yawrate)", wind, "velocity_yawrate", False))
    for name in FIXEDWINGS:
        for mode in ("channels", "attitude_airspeed"):
            for wind in ("constant", "shear", "gust_fast", "gust_step_on_wind", "dryden_moderate"):
                out.append((name, f"{wind} ({mode})", wind, mode, False))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        paths = {}
        for name in (*MULTIROTORS, *FIXEDWINGS):
            data = yaml.safe_load((uav_dir() / f"{name}.yaml").read_text())
            data["motors"]["noise_ratio"] = 0.0  # the two backends draw their noise apart
            paths[name] = Path(folder) / f"{name}.yaml"
            paths[name].write_text(yaml.safe_dump(data))
        for name, label, wind, mode, ground in cases():
            if mode == "velocity_yawrate":  # the velocity variant (a cascade mode): no calm twin flown
                worst, flown = fly_cascade_air_pair(str(paths[name]), wind)
                felt = float("nan")
            else:
                worst, flown, felt, _ = fly_air_pair(str(paths[name]), wind, mode, ground_effect=ground)
            rows.append((name, label, flown, worst, felt))
    sep = " | " if args.markdown else "  "
    header = ["airframe", "case", "steps", *FIELDS, "from calm"]
    lines = [header]
    for name, label, flown, worst, felt in rows:
        lines.append([name, label, str(flown), *(f"{worst[f]:.1e}" for f in FIELDS), f"{felt:.2g}"])
    lines.append(["all", "-", "-", *(f"{max(r[3][f] for r in rows):.1e}" for f in FIELDS), "-"])
    for k, line in enumerate(lines):
        print(("| " if args.markdown else "") + sep.join(line) + (" |" if args.markdown else ""))
        if args.markdown and k == 0:
            print("|" + "---|" * len(header))


if __name__ == "__main__":
    main()
