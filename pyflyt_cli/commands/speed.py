"""``pyflyt speed``: how fast the toolkit runs on this machine, side by side with the reference.

:func:`run_speed` measures, :func:`format_report` prints.  Every measurement runs in a
fresh process (:mod:`pyflyt_cli.commands.speed_probe`, one case per process), so memory
peaks belong to one env and nothing warms up for the next case; our side and the
reference's run alternately, case by case, and each figure is the median of
``repeats`` runs, so load from other jobs on the machine hits both sides alike.

Sections:

* **envs** -- for each registered env: env steps/s, reset time, real-time factor
  (simulated seconds per wall second) and peak resident memory of the process;
  the bare-PyBullet floor (one body, 8 physics steps per env step) in the same run.
* **worlds** -- 1, 8 and 64 QuadX (cf2x) holding position 1 m apart in one world: the
  real-time factor, the reference's (its ``Aviary`` with N QuadX), and the floor of
  bare PyBullet doing the same physical work for N bodies.
* **camera** -- one 128 x 128 onboard capture, ours (all channels, and RGBA or depth
  alone) and the reference's QuadX camera.
* **vector** (``vector=True``) -- env steps/s of 1 and 2 subprocess workers
  (``gymnasium.make_vec(..., vectorization_mode="async")`` and SB3 ``SubprocVecEnv``)
  and the scaling between them; beside it, the scaling of a stand-in env of the same
  in-process step cost through the same vector env, and the machine's own 1 -> 2
  process scaling of pure CPU work, both measured in the same repeats (what is left
  of a shortfall after them is the env's).

The reference PyFlyt package pins numpy < 2, so it lives in its own interpreter; pass
that interpreter as ``reference_python`` to add its figures and the ratios.  Without
it the report holds our figures only: a fresh install needs nothing else.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyflyt_cli.commands import speed_probe
from pyflyt_engine.errors import PyFlytError

PROBE_PATH = Path(speed_probe.__file__)
#: Subprocess vector envs measured by ``vector=True``.
VECTOR_BACKENDS = ("gymnasium", "sb3")
_PACKAGE_ROOT = str(Path(speed_probe.__file__).resolve().parents[2])


class SpeedError(PyFlytError):
    """A measurement process failed (the message carries its last lines of output)."""


@dataclass(frozen=True)
class SpeedSettings:
    """What :func:`run_speed` measures and how long.

    Attributes:
        repeats: runs of every case; each figure is their median.
        envs: env ids to measure (None: every registered one).
        vehicles: world sizes (number of QuadX).
        env_steps, resets, warmup: env protocol (steps timed, seeded resets timed, steps before).
        world_seconds: simulated seconds timed per world (after a quarter-second warm-up),
            per vehicle count; counts not listed use the smallest value.
        camera_captures: captures per camera timing (5 timings per run).
        vector: also measure subprocess vector envs with 1 and 2 workers.
        vector_steps: vector steps timed per run.
        parallel_seconds: CPU work per process of the machine-scaling measurement.
        reference_python: interpreter with the reference PyFlyt installed (None: skip it).
    """

    repeats: int = 5
    envs: tuple[str, ...] | None = None
    vehicles: tuple[int, ...] = (1, 8, 64)
    env_steps: int = 2000
    resets: int = 10
    warmup: int = 200
    world_seconds: dict[int, float] = field(default_factory=lambda: {1: 20.0, 8: 5.0, 64: 1.0})
    camera_captures: int = 50
    vector: bool = False
    vector_steps: int = 1000
    parallel_seconds: float = 0.5
    reference_python: str | None = None

    @classmethod
    def quick(cls, **overrides: Any) -> SpeedSettings:
        """Tiny repetition counts: checks that everything runs, measures nothing reliably."""
        values: dict[str, Any] = {
            "repeats": 1,
            "env_steps": 50,
            "resets": 2,
            "warmup": 10,
            "world_seconds": {1: 0.1, 8: 0.1, 64: 0.05},
            "camera_captures": 2,
            "vector_steps": 20,
            "parallel_seconds": 0.02,
        }
        values.update(overrides)
        return cls(**values)

    def seconds_for(self, n: int) -> float:
        if n in self.world_seconds:
            return self.world_seconds[n]
        return min(self.world_seconds.values())


# ------------------------------------------------------------------- processes


def _parse(output: str) -> dict | None:
    for line in reversed(output.splitlines()):
        if line.startswith(speed_probe.RESULT_MARKER):
            return json.loads(line[len(speed_probe.RESULT_MARKER) :])
    return None


def run_probe(case: dict, python: str | None = None, timeout: float = 1800.0) -> dict:
    """Run one probe case in a fresh process and return its result.

    ``python`` None runs our side with this interpreter; otherwise the probe's source
    is handed to that interpreter with ``-c`` (the reference's environment does not
    have our package, and running the file by path would put this package's command
    modules on its import path).
    """
    if python is None:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (_PACKAGE_ROOT, env.get("PYTHONPATH")) if p)
        command = [sys.executable, "-m", "pyflyt_cli.commands.speed_probe", json.dumps(case)]
    else:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        command = [python, "-c", PROBE_PATH.read_text(), json.dumps(case)]
    try:
        done = subprocess.run(command, check=False, capture_output=True, text=True, env=env, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise SpeedError(f"could not run the {case['probe']} probe with {command[0]}: {exc}") from None
    result = _parse(done.stdout)
    if done.returncode != 0 or result is None:
        tail = "\n".join((done.stderr or done.stdout).strip().splitlines()[-4:])
        raise SpeedError(f"{case['probe']} probe {case} failed in {command[0]}:\n{tail}")
    return result


def _median(results: list[dict]) -> dict:
    """Per-key median of numeric fields (other fields from the first result)."""
    merged = dict(results[0])
    for key, value in results[0].items():
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            merged[key] = statistics.median(r[key] for r in results)
    merged["repeats"] = len(results)
    return merged


# ------------------------------------------------------------------- measuring


def run_speed(settings: SpeedSettings = SpeedSettings(), progress: Callable[[str], None] | None = None) -> dict:
    """Measure every section and return the report (a JSON-serialisable dict)."""
    import pyflyt_engine  # noqa: F401  (registers the ids)
    from pyflyt_engine.envs import ENVS

    say = progress or (lambda message: None)
    ref = settings.reference_python
    env_ids = list(settings.envs) if settings.envs else list(ENVS)
    unknown = [e for e in env_ids if e not in ENVS]
    if unknown:
        raise SpeedError(f"unknown env id(s) {', '.join(unknown)}; registered: {', '.join(ENVS)}")
    if settings.repeats < 1:
        raise SpeedError(f"repeats must be >= 1, got {settings.repeats}")

    # cases: (section, key, case); ours then the reference's, alternately, every repeat
    cases: list[tuple[str, Any, dict, bool]] = []
    for env_id in env_ids:
        case = {"probe": "env", "env_id": env_id, "steps": settings.env_steps, "resets": settings.resets,
                "warmup": settings.warmup}
        cases.append(("envs", env_id, case, True))
    floor_steps = max(settings.env_steps * 8, 240)
    cases.append(("env_floor", 1, {"probe": "floor", "n": 1, "seconds": floor_steps / 240.0}, False))
    for n in settings.vehicles:
        seconds = settings.seconds_for(n)
        cases.append(("worlds", n, {"probe": "world", "n": n, "seconds": seconds}, True))
        cases.append(("floors", n, {"probe": "floor", "n": n, "seconds": seconds}, False))
    camera = {"probe": "camera", "captures": settings.camera_captures, "repeats": 5}
    cases.append(("camera", "all", camera, True))
    cases.append(("camera", "rgba", {**camera, "channels": ["rgba"]}, False))
    cases.append(("camera", "depth", {**camera, "channels": ["depth"]}, False))
    if settings.vector:
        # each 1-worker case right before its 2-worker case, so each repeat gives a pair
        # measured under the same load; the machine's own scaling in the same repeat
        for processes in (1, 2):
            cases.append(("parallel", processes, {"probe": "parallel", "processes": processes,
                                                  "seconds": settings.parallel_seconds}, False))
        for env_id in env_ids:
            for backend in VECTOR_BACKENDS:
                for stand_in in (False, True):
                    for workers in (1, 2):
                        case = {"probe": "vector", "env_id": env_id, "workers": workers, "backend": backend,
                                "steps": settings.vector_steps, "warmup": max(5, settings.vector_steps // 10),
                                "stand_in": stand_in}
                        cases.append(("vector", (env_id, backend, stand_in, workers), case, False))

    ours: dict[tuple[str, Any], list[dict]] = {}
    theirs: dict[tuple[str, Any], list[dict]] = {}
    missing: dict[tuple[str, Any], str] = {}
    machine = run_probe({"probe": "machine"})
    reference_machine = run_probe({"probe": "machine"}, python=ref) if ref else None
    for repeat in range(settings.repeats):
        for section, key, case, has_reference in cases:
            say(f"[{repeat + 1}/{settings.repeats}] {section} {key}")
            ours.setdefault((section, key), []).append(run_probe(case))
            if ref and has_reference and (section, key) not in missing:
                try:
                    theirs.setdefault((section, key), []).append(run_probe({**case, "side": "reference"}, python=ref))
                except SpeedError as exc:  # e.g. an env the reference does not have
                    missing[(section, key)] = str(exc).splitlines()[-1]

    def pair(section: str, key: Any) -> dict:
        row = {"ours": _median(ours[(section, key)])}
        if (section, key) in theirs:
            row["reference"] = _median(theirs[(section, key)])
        elif (section, key) in missing:
            row["reference_error"] = missing[(section, key)]
        return row

    report: dict[str, Any] = {
        "machine": machine,
        "reference_machine": reference_machine,
        "settings": {k: v for k, v in settings.__dict__.items() if k != "world_seconds"}
        | {"world_seconds": {str(k): v for k, v in settings.world_seconds.items()}},
        "envs": [{"id": env_id, **pair("envs", env_id)} for env_id in env_ids],
        "env_floor": _median(ours[("env_floor", 1)]),
        "worlds": [{"n": n, **pair("worlds", n), "floor": _median(ours[("floors", n)])} for n in settings.vehicles],
        "camera": {key: pair("camera", key) for key in ("all", "rgba", "depth")},
        "vector": None,
        "parallel": None,
    }
    if settings.vector:
        report["parallel"] = _scaling([r["work_per_s"] for r in ours[("parallel", 1)]],
                                      [r["work_per_s"] for r in ours[("parallel", 2)]])
        report["vector"] = []
        for env_id in env_ids:
            for backend in VECTOR_BACKENDS:
                runs = {(stand_in, w): ours[("vector", (env_id, backend, stand_in, w))]
                        for stand_in in (False, True) for w in (1, 2)}
                report["vector"].append({
                    "id": env_id,
                    "backend": backend,
                    "steps_per_s": {str(w): _median(runs[(False, w)])["steps_per_s"] for w in (1, 2)},
                    "cpu_per_step_s": {str(w): _median(runs[(False, w)]).get("cpu_per_step_s") for w in (1, 2)},
                    "scaling": _scaling([r["steps_per_s"] for r in runs[(False, 1)]],
                                        [r["steps_per_s"] for r in runs[(False, 2)]]),
                    "stand_in": {
                        "env_step_cpu_s": _median(runs[(True, 1)] + runs[(True, 2)])["env_step_cpu_s"],
                        "steps_per_s": {str(w): _median(runs[(True, w)])["steps_per_s"] for w in (1, 2)},
                        "scaling": _scaling([r["steps_per_s"] for r in runs[(True, 1)]],
                                            [r["steps_per_s"] for r in runs[(True, 2)]]),
                    },
                })
    return report


def _scaling(one: list[float], two: list[float]) -> dict:
    """1 -> 2 scaling from runs paired by repeat: the median, lowest and highest of the
    per-repeat ratios (a pair shares the load of its moment; medians of the two sides
    taken apart would mix moments)."""
    ratios = [b / a for a, b in zip(one, two)]
    return {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios), "ratios": ratios}


# ------------------------------------------------------------------- printing


def _table(header: Sequence[str], rows: list[list[str]], markdown: bool) -> list[str]:
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" if i == 0 else "---:" for i in range(len(header))) + "|"]
        return lines + ["| " + " | ".join(row) + " |" for row in rows]
    widths = [max(len(str(c)) for c in column) for column in zip(header, *rows)]
    fmt = lambda cells: "  ".join(  # noqa: E731
        (c.ljust(w) if i == 0 else c.rjust(w)) for i, (c, w) in enumerate(zip(cells, widths))
    )
    return [fmt(header), fmt(["-" * w for w in widths])] + [fmt(row) for row in rows]


def _num(value: float | None, digits: int = 0) -> str:
    if value is None:
        return "-"
    return f"{value:,.{digits}f}"


def _ratio(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}x" if value < 10 else f"{value:.0f}x"


def _spread(scaling: dict) -> str:
    return f"{scaling['median']:.2f}x ({scaling['min']:.2f}-{scaling['max']:.2f})"


def _get(row: dict, side: str, key: str) -> float | None:
    return row.get(side, {}).get(key) if side in row else None


def describe_machine(machine: dict) -> str:
    """One line: processor, cores, memory, software versions, load during the run."""
    parts = [
        f"{machine.get('processor') or machine.get('machine')}",
        f"{machine.get('cores')} cores",
        f"{machine.get('memory_gib', '?')} GiB",
        f"{machine.get('system')}",
        f"Python {machine.get('python')}",
        f"PyBullet {machine.get('pybullet')}",
        f"NumPy {machine.get('numpy')}",
        f"Gymnasium {machine.get('gymnasium')}",
    ]
    if machine.get("load_average"):
        parts.append("load average at start " + "/".join(f"{x:g}" for x in machine["load_average"]))
    return ", ".join(parts)


def format_report(report: dict, markdown: bool = False) -> str:
    """The report as plain-text tables, or as Markdown for docs/performance.md."""
    has_ref = report.get("reference_machine") is not None
    out: list[str] = []
    title = (lambda text: out.extend([f"**{text}**", ""])) if markdown else (lambda text: out.extend([text]))
    settings = report["settings"]
    out.append(("Machine: " if markdown else "machine: ") + describe_machine(report["machine"]))
    if has_ref:
        ref_m = report["reference_machine"]
        out.append(("" if not markdown else "\n") + f"reference: PyFlyt in Python {ref_m.get('python')}, NumPy {ref_m.get('numpy')}, "
                   f"PyBullet {ref_m.get('pybullet')}")
    order = ", ours and the reference alternately" if has_ref else ""
    out.append(("\n" if markdown else "") + f"median of {settings['repeats']} run(s) per figure; each run in a fresh process{order}")
    out.append("")

    # envs
    title(f"Environments: agent {speed_probe.AGENT_HZ} Hz, random actions, {settings['env_steps']} steps "
          f"(resets at episode ends included), reset = median of {settings['resets']} seeded resets, "
          "memory = peak resident set of the process")
    header = ["env", "steps/s", "RTF", "reset ms", "peak MB"]
    if has_ref:
        header = ["env", "steps/s", "ref steps/s", "x ref", "RTF", "ref RTF", "reset ms", "ref reset ms", "x ref",
                  "peak MB", "ref peak MB"]
    rows = []
    for row in report["envs"]:
        o = row["ours"]
        cells = [row["id"], _num(o["steps_per_s"]), _num(o["rtf"], 1), _num(o["reset_s"] * 1e3, 2), _num(o["peak_rss_mb"])]
        if has_ref:
            r = row.get("reference")
            rs = _get(row, "reference", "steps_per_s")
            rr = _get(row, "reference", "reset_s")
            cells = [
                row["id"] + (f" ({r['id']})" if r else ""),
                _num(o["steps_per_s"]), _num(rs), _ratio(o["steps_per_s"] / rs if rs else None),
                _num(o["rtf"], 1), _num(_get(row, "reference", "rtf"), 1),
                _num(o["reset_s"] * 1e3, 2), _num(rr * 1e3 if rr else None, 2), _ratio(rr / o["reset_s"] if rr else None),
                _num(o["peak_rss_mb"]), _num(_get(row, "reference", "peak_rss_mb")),
            ]
        rows.append(cells)
    floor = report["env_floor"]
    floor_sps = 1.0 / (floor["physics_step_s"] * 8)
    cells = ["bare PyBullet floor (1 body, 8 physics steps)", _num(floor_sps), _num(floor["rtf"], 1), "-", _num(floor["peak_rss_mb"])]
    if has_ref:
        cells = [cells[0], cells[1], "-", "-", cells[2], "-", "-", "-", "-", cells[4], "-"]
    rows.append(cells)
    out += _table(header, rows, markdown)
    for row in report["envs"]:
        if "reference_error" in row:
            out.append(f"(reference: {row['id']} unavailable: {row['reference_error']})")
    out.append("")

    # worlds
    title("Worlds of N QuadX (cf2x) holding position 1 m apart: real-time factor (simulated s per wall s), "
          "floor = bare PyBullet doing the same physical work for N bodies")
    header = ["vehicles", "RTF", "floor RTF", "floor / ours"]
    if has_ref:
        header = ["vehicles", "RTF", "ref RTF", "x ref", "floor RTF", "floor / ours"]
    rows = []
    for row in report["worlds"]:
        o, f = row["ours"], row["floor"]
        if has_ref:
            rr = _get(row, "reference", "rtf")
            rows.append([str(row["n"]), _num(o["rtf"], 2), _num(rr, 2), _ratio(o["rtf"] / rr if rr else None),
                         _num(f["rtf"], 2), _ratio(f["rtf"] / o["rtf"])])
        else:
            rows.append([str(row["n"]), _num(o["rtf"], 2), _num(f["rtf"], 2), _ratio(f["rtf"] / o["rtf"])])
    out += _table(header, rows, markdown)
    out.append("")

    # camera
    title("Camera: one 128 x 128 onboard capture (QuadX at 1 m; the reference QuadX camera's mount, 90 deg field of view, "
          "pitched 20 deg down), ms wall (ms CPU)")
    header = ["channels", "ours ms", "ref ms", "ours / ref"] if has_ref else ["channels", "ours ms"]
    rows = []
    labels = {"all": "rgba + depth + segmentation", "rgba": "rgba only", "depth": "depth only"}
    for key, row in report["camera"].items():
        o = row["ours"]
        cell = f"{o['capture_s'] * 1e3:.2f} ({o['capture_cpu_s'] * 1e3:.2f})"
        if has_ref:
            r = row.get("reference")
            rcell = f"{r['capture_s'] * 1e3:.2f} ({r['capture_cpu_s'] * 1e3:.2f})" if r else "-"
            ratio = (f"{o['capture_s'] / r['capture_s']:.2f} ({o['capture_cpu_s'] / r['capture_cpu_s']:.2f})" if r else "-")
            rows.append([labels[key], cell, rcell, ratio])
        else:
            rows.append([labels[key], cell])
    out += _table(header, rows, markdown)

    # vector
    if report.get("vector"):
        out.append("")
        title(f"Vector envs: env steps/s summed over subprocess workers ({settings['vector_steps']} vector steps); "
              f"scaling = 2 workers / 1 worker, median (lowest-highest) of {settings['repeats']} pairs; stand-in = "
              "the same vector env stepping pure CPU work of the env's in-process step cost (empty info, no "
              "episode ends); CPU = CPU time of the main process and the workers per env step")
        rows = []
        for row in report["vector"]:
            one, two = row["steps_per_s"]["1"], row["steps_per_s"]["2"]
            cpu = row.get("cpu_per_step_s") or {}
            backend = "gymnasium async" if row["backend"] == "gymnasium" else "SB3 SubprocVecEnv"
            cpu_cells = [_num(cpu[w] * 1e6) if cpu.get(w) else "-" for w in ("1", "2")]
            stand_in = row["stand_in"]
            rows.append([row["id"], backend, _num(one), _num(two), _spread(row["scaling"]),
                         _num(stand_in["env_step_cpu_s"] * 1e6), _spread(stand_in["scaling"]), *cpu_cells])
        out += _table(["env", "vector env", "1 worker", "2 workers", "scaling", "step CPU us", "stand-in scaling",
                       "CPU us/step 1", "CPU us/step 2"], rows, markdown)
        parallel = report.get("parallel")
        if parallel:
            out.append("")
            out.append(f"machine: 2 processes of pure CPU work (no pipes) do {_spread(parallel)} the work of 1 "
                       f"({settings.get('parallel_seconds', 0.5):g} s each, {settings['repeats']} pairs)")
    return "\n".join(out) + "\n"


def speed_command(
    repeats: int = 5,
    quick: bool = False,
    reference_python: str | None = None,
    vector: bool = False,
    markdown: bool = False,
    envs: Sequence[str] | None = None,
    vehicles: Sequence[int] | None = None,
    json_path: Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> str:
    """What ``pyflyt speed`` does: measure, optionally save the JSON, return the printed report."""
    if reference_python is not None and not (Path(reference_python).exists() or shutil.which(reference_python)):
        raise SpeedError(f"--reference-python {reference_python} does not exist; give the interpreter of a "
                         "virtual environment with PyFlyt 0.29 installed (e.g. /path/to/venv/bin/python)")
    overrides: dict[str, Any] = {"reference_python": reference_python, "vector": vector}
    if envs:
        overrides["envs"] = tuple(envs)
    if vehicles:
        overrides["vehicles"] = tuple(vehicles)
    settings = SpeedSettings.quick(**overrides) if quick else SpeedSettings(repeats=repeats, **overrides)
    report = run_speed(settings, progress=progress)
    if json_path is not None:
        from pyflyt_cli.outputs import atomic_output, make_output_dir

        make_output_dir(json_path.parent, "--json")
        with atomic_output(json_path, "--json") as tmp:
            tmp.write_text(json.dumps(report, indent=2))
    return format_report(report, markdown=markdown)
