"""Side by side with the reference PyFlyt 0.29.0 package: envs, worlds and camera, in one run.

The reference pins numpy < 2, so it lives in its own virtual environment
(``pip install pyflyt==0.29.0`` there); give its interpreter with ``--reference-python``
(default: $PYFLYT_REFERENCE_PYTHON).

The protocol is ``pyflyt speed``'s (:mod:`pyflyt_cli.speed`): the same cases, each in a
fresh process, every figure the median of ``--repeats`` runs; each case of ours is
followed at once by the reference's same case, so load from other jobs hits both alike.
The reference's side is ``reference_probe.py`` beside this file, run by the reference's
interpreter: it times the reference's envs, its ``Aviary`` and its camera with the same
protocol functions (``pyflyt_cli/speed/protocols.py``).  Our bare-PyBullet floor and the
camera's single-channel captures have no counterpart and are shown for ours only.

    python experiments/compare_reference.py --reference-python /path/to/ref-venv/bin/python --markdown

Envs compared (ours -> reference id: its newest version of the same name):
    PyFlyt/QuadX-Hover-v0           -> PyFlyt/QuadX-Hover-v4
    PyFlyt/QuadX-Waypoints-v0       -> PyFlyt/QuadX-Waypoints-v4
    PyFlyt/Fixedwing-Waypoints-v0   -> PyFlyt/Fixedwing-Waypoints-v3
    PyFlyt/Rocket-Landing-v0        -> PyFlyt/Rocket-Landing-v4

Without a reference interpreter the tables hold our figures, and '-' in its columns.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

from pyflyt_cli.speed import Case, SpeedError, SpeedSettings, run_probe, run_speed
from pyflyt_cli.speed.measure import median
from pyflyt_cli.speed.tables import (
    CAMERA_LABELS,
    capture_ms,
    describe_machine,
    floor_steps_per_s,
    number,
    ratio,
    swarm_table,
    table,
    titles,
)

REFERENCE_PROBE = Path(__file__).resolve().with_name("reference_probe.py")
#: our cases the reference has a counterpart of: (section, key); key None: every key
COUNTERPARTS = {("machine", None), ("envs", None), ("worlds", None), ("camera", "all"), ("swarm", None)}


class Reference:
    """Runs the reference's counterpart of each of our cases right after ours (:meth:`measure`)."""

    def __init__(self, python: str | None) -> None:
        self.python = python
        self.results: dict[tuple[str, Any], list[dict]] = {}
        self.errors: dict[tuple[str, Any], str] = {}  # a case the reference cannot run (e.g. an env it lacks)

    def measure(self, case: Case) -> dict:
        ours = run_probe(case.probe)
        key = (case.section, case.key)
        paired = (case.section, None) in COUNTERPARTS or key in COUNTERPARTS
        if self.python and paired and key not in self.errors:
            env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # nothing of ours on its path
            try:
                result = run_probe(case.probe, [self.python, str(REFERENCE_PROBE)], env=env)
                self.results.setdefault(key, []).append(result)
            except SpeedError as exc:
                self.errors[key] = str(exc).splitlines()[-1]
        return ours

    def get(self, section: str, key: Any) -> dict | None:
        """The median of the reference's runs of a case (None: not measured)."""
        runs = self.results.get((section, key))
        return median(runs) if runs else None

    def as_dict(self, report: dict) -> dict:
        return {
            "machine": self.get("machine", None),
            "envs": {row["id"]: self.get("envs", row["id"]) for row in report["envs"]},
            "worlds": {str(row["n"]): self.get("worlds", row["n"]) for row in report["worlds"]},
            "camera": {"all": self.get("camera", "all")},
            "swarm": {
                f"{row['env']} {row['agents']}": self.get("swarm", (row["env"], row["agents"]))
                for row in report.get("swarm", [])
            },  # fmt: skip
            "errors": {f"{section} {key}": message for (section, key), message in self.errors.items()},
        }


def _field(row: dict | None, key: str, scale: float = 1.0) -> float | None:
    return None if row is None else row[key] * scale


def _over(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else a / b


def format_comparison(report: dict, ref: Reference, markdown: bool = False) -> str:
    """Our report with the reference's figures and the ratios beside them."""
    settings = report["settings"]
    heading = titles(settings)
    ref_machine = ref.get("machine", None)
    lines = [
        ("Machine: " if markdown else "machine: ") + describe_machine(report["machine"]),
        f"reference: PyFlyt {ref_machine.get('PyFlyt')} in Python {ref_machine.get('python')}, NumPy "
        f"{ref_machine.get('numpy')}, PyBullet {ref_machine.get('pybullet')}"
        if ref_machine
        else "reference: not measured (give --reference-python)",
        (
            f"median of {settings['repeats']} run(s) per figure; each run in a fresh process, ours and the "
            "reference's alternately"
        ),
    ]
    out = ["\n\n".join(lines) if markdown else "\n".join(lines), ""]

    def title(section: str) -> None:
        out.extend([f"**{heading[section]}**", ""] if markdown else [heading[section]])

    title("envs")
    rows = []
    for row in report["envs"]:
        theirs = ref.get("envs", row["id"])
        rate, reset = _field(theirs, "steps_per_s"), _field(theirs, "reset_s", 1e3)
        rows.append([
            row["id"] + (f" ({theirs['id']})" if theirs else ""),
            number(row["steps_per_s"]), number(rate), ratio(_over(row["steps_per_s"], rate)),
            number(row["rtf"], 1), number(_field(theirs, "rtf"), 1),
            number(row["reset_s"] * 1e3, 2), number(reset, 2), ratio(_over(reset, row["reset_s"] * 1e3)),
            number(row["peak_rss_mb"]), number(_field(theirs, "peak_rss_mb")),
        ])  # fmt: skip
    floor = report["env_floor"]
    rows.append(["bare PyBullet floor (1 body, 8 physics steps)", number(floor_steps_per_s(floor)), "-", "-",
                 number(floor["rtf"], 1), "-", "-", "-", "-", number(floor["peak_rss_mb"]), "-"])  # fmt: skip
    out += table(["env", "steps/s", "ref steps/s", "x ref", "RTF", "ref RTF", "reset ms", "ref reset ms", "x ref",
                  "peak MB", "ref peak MB"], rows, markdown)  # fmt: skip
    out += [f"(reference: {section} {key} unavailable: {message})" for (section, key), message in ref.errors.items()]
    out.append("")

    title("worlds")
    rows = []
    for row in report["worlds"]:
        rtf = _field(ref.get("worlds", row["n"]), "rtf")
        rows.append([str(row["n"]), number(row["rtf"], 2), number(rtf, 2), ratio(_over(row["rtf"], rtf)),
                     number(row["floor"]["rtf"], 2), ratio(row["floor"]["rtf"] / row["rtf"])])  # fmt: skip
    out += table(["vehicles", "RTF", "ref RTF", "x ref", "floor RTF", "floor / ours"], rows, markdown)
    out.append("")

    if report.get("swarm"):
        title("swarm")
        theirs = {(row["env"], row["agents"]): ref.get("swarm", (row["env"], row["agents"])) for row in report["swarm"]}
        out += swarm_table(report["swarm"], markdown, reference=theirs)
        out.append("")

    title("camera")
    rows = []
    for key, row in report["camera"].items():
        theirs = ref.get("camera", key)
        cells = ["-", "-"]
        if theirs:
            wall, cpu = (row[k] / theirs[k] for k in ("capture_s", "capture_cpu_s"))
            cells = [capture_ms(theirs), f"{wall:.2f} ({cpu:.2f})"]
        rows.append([CAMERA_LABELS[key], capture_ms(row), *cells])
    out += table(["channels", "ours ms", "ref ms", "ours / ref"], rows, markdown)
    return "\n".join(out) + "\n"


def _counts(text: str) -> tuple[int, ...]:
    return tuple(int(n) for n in text.split(","))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--reference-python", default=os.environ.get("PYFLYT_REFERENCE_PYTHON"),
                        help="interpreter of a virtual environment with pyflyt==0.29.0 installed")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=5, help="runs per figure; the median is printed")
    parser.add_argument("--quick", action="store_true", help="tiny counts: checks that everything runs")
    parser.add_argument("--markdown", action="store_true", help="print Markdown tables")
    parser.add_argument("--env", action="append", help="env id to measure (repeatable; default: all)")
    parser.add_argument("--vehicles", type=_counts, default=(1, 8, 64), help="world sizes, comma-separated")
    parser.add_argument("--agents", type=_counts, default=(1, 2, 4, 8, 16, 32, 64, 128),
                        help="swarm sizes of the multi-agent curve, comma-separated")  # fmt: skip
    parser.add_argument("--json", type=Path, help="also write every figure, both sides, to this file")
    args = parser.parse_args(argv)
    if args.reference_python and not Path(args.reference_python).exists():
        parser.error(f"--reference-python {args.reference_python} does not exist")

    chosen: dict[str, Any] = {"envs": tuple(args.env) if args.env else None, "vehicles": args.vehicles,
                              "swarm": args.agents}  # fmt: skip
    settings = SpeedSettings.quick(**chosen) if args.quick else SpeedSettings(repeats=args.repeats, **chosen)
    ref = Reference(args.reference_python)
    try:
        report = run_speed(settings, progress=lambda line: print(line, file=sys.stderr), measure=ref.measure)
    except SpeedError as exc:  # an unknown env id, or one of our cases failed
        parser.exit(2, f"error: {exc}\n")
    if args.json:
        args.json.write_text(json.dumps({"ours": report, "reference": ref.as_dict(report)}, indent=2))
    print(format_comparison(report, ref, markdown=args.markdown), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
