"""Measuring: the settings, the cases they make, one fresh process per case, the report.

:func:`run_speed` plans the cases (:func:`plan_cases`), runs every case ``repeats``
times, case after case (so load from other jobs on the machine spreads over all of
them), and keeps the median of each figure.  By default each case runs in a fresh
process (:func:`run_probe`), so memory peaks belong to one case and nothing warms up
for the next; ``measure`` replaces that (tests, ``experiments/``).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from pyflyt_cli.speed.protocols import RESULT_MARKER
from pyflyt_engine.errors import PyFlytError

#: Subprocess vector envs measured by ``vector=True``.
VECTOR_BACKENDS = ("gymnasium", "sb3")
#: Camera cases: row key -> channels captured (None: all of them).
CAMERA_CASES = {"all": None, "rgba": ["rgba"], "depth": ["depth"]}
_PACKAGE_ROOT = str(Path(__file__).resolve().parents[2])


class SpeedError(PyFlytError):
    """Bad settings, or a measurement process failed (the message carries its last lines of output)."""


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
        swarm: agent counts of the multi-agent curve (MAQuadX-Hover on a grid and
            MAQuadX-Formation at each count, MAFixedwing-Dogfight 2 v 2 once); () skips it.
        swarm_agent_steps: agent-steps timed per swarm case (at least ``swarm_min_steps``
            env steps), so every count takes about the same time.
        backend: ``pybullet`` (every section above), or ``batched``: the batched backend's
            agent-steps/s at each of ``batch_sizes`` envs, beside the PyBullet env of the
            same id (only the envs the batched backend runs; default QuadX-Hover and
            QuadX-Waypoints), ``batched_agent_steps`` agent-steps timed per case.
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
    swarm: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64, 128)
    swarm_agent_steps: int = 4000
    swarm_min_steps: int = 30
    backend: str = "pybullet"
    batch_sizes: tuple[int, ...] = (1, 16, 64, 256, 1024, 4096)
    batched_agent_steps: int = 200_000

    def swarm_steps(self, agents: int) -> int:
        """Env steps timed for a swarm of ``agents``."""
        return max(self.swarm_min_steps, -(-self.swarm_agent_steps // agents))

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
            "swarm_agent_steps": 8,
            "swarm_min_steps": 2,
            "batched_agent_steps": 2000,
        }
        values.update(overrides)
        return cls(**values)

    def seconds_for(self, n: int) -> float:
        return self.world_seconds.get(n, min(self.world_seconds.values()))

    def as_dict(self) -> dict[str, Any]:
        """The settings as JSON data (world sizes as text keys)."""
        return asdict(self) | {"world_seconds": {str(k): v for k, v in self.world_seconds.items()}}


@dataclass(frozen=True)
class Case:
    """One measurement: the probe (its name and arguments) behind row ``key`` of ``section``."""

    section: str
    key: Any
    probe: dict[str, Any]


def plan_cases(settings: SpeedSettings) -> list[Case]:
    """Every case of one repeat, in the order they run.

    Raises:
        SpeedError: an unknown env id, or ``repeats`` below 1.
    """
    import pyflyt_engine  # noqa: F401  (registers the ids)
    from pyflyt_engine.envs import ENVS

    if settings.backend not in ("pybullet", "batched"):
        raise SpeedError(f"unknown backend '{settings.backend}': pybullet or batched")
    if settings.backend == "batched":
        return _batched_cases(settings)
    env_ids = list(settings.envs) if settings.envs else list(ENVS)
    unknown = [e for e in env_ids if e not in ENVS]
    if unknown:
        from pyflyt_engine.suggest import closest

        by_config = {entry.config: env_id for env_id, entry in ENVS.items()}  # quadx_hover -> PyFlyt/QuadX-Hover-v0
        meant = closest(unknown[0], [*ENVS, *by_config])
        hint = f" Did you mean '{by_config.get(meant, meant)}'?" if meant is not None else ""
        raise SpeedError(f"unknown env id(s) {', '.join(unknown)}.{hint} Registered: {', '.join(ENVS)}")
    if settings.repeats < 1:
        raise SpeedError(f"repeats must be >= 1, got {settings.repeats}")
    from pyflyt_engine.envs.config import MAX_AGENTS

    bad = [n for n in settings.swarm if not 1 <= n <= MAX_AGENTS]
    if bad:
        raise SpeedError(f"swarm agent counts must be 1 to {MAX_AGENTS}, got {', '.join(map(str, bad))}")

    env_case = {"steps": settings.env_steps, "resets": settings.resets, "warmup": settings.warmup}
    cases = [Case("envs", env_id, {"probe": "env", "env_id": env_id, **env_case}) for env_id in env_ids]
    floor_steps = max(settings.env_steps * 8, 240)  # 8 physics steps per env step
    cases.append(Case("env_floor", 1, {"probe": "floor", "n": 1, "seconds": floor_steps / 240.0}))
    for n in settings.vehicles:
        world = {"n": n, "seconds": settings.seconds_for(n)}
        cases += [Case("worlds", n, {"probe": "world", **world}), Case("floors", n, {"probe": "floor", **world})]
    for key in swarm_keys(settings):
        env, agents = key
        probe = {"probe": "swarm", "env": env, "agents": agents, "steps": settings.swarm_steps(agents),
                 "warmup": max(2, settings.swarm_steps(agents) // 10)}  # fmt: skip
        cases.append(Case("swarm", key, probe))
    for name, channels in CAMERA_CASES.items():
        camera = {"probe": "camera", "captures": settings.camera_captures, "repeats": 5, "channels": channels}
        cases.append(Case("camera", name, camera))
    if settings.vector:
        # each 1-worker case right before its 2-worker case, so each repeat gives a pair
        # measured under the same load; the machine's own scaling in the same repeat
        for processes in (1, 2):
            probe = {"probe": "parallel", "processes": processes, "seconds": settings.parallel_seconds}
            cases.append(Case("parallel", processes, probe))
        for env_id in env_ids:
            for backend in VECTOR_BACKENDS:
                for stand_in in (False, True):
                    for workers in (1, 2):
                        probe = {"probe": "vector", "env_id": env_id, "workers": workers, "backend": backend,
                                 "steps": settings.vector_steps, "warmup": max(5, settings.vector_steps // 10),
                                 "stand_in": stand_in}  # fmt: skip
                        cases.append(Case("vector", (env_id, backend, stand_in, workers), probe))
    return cases


#: what `--backend batched` measures by default
BATCHED_IDS = ("PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0")


def _batched_cases(settings: SpeedSettings) -> list[Case]:
    """The PyBullet env of each id, then the batched backend at every size (``--backend batched``)."""
    from pyflyt_engine.batched import UnsupportedByBatched, check_supported
    from pyflyt_engine.envs import ENVS
    from pyflyt_engine.envs.config import load_env_config

    from pyflyt_engine.errors import ConfigError

    env_ids = list(settings.envs) if settings.envs else list(BATCHED_IDS)
    for env_id in env_ids:
        try:  # a registered id, or an env config (a variant such as quadx_waypoints_velocity shares its id)
            config = load_env_config(ENVS[env_id].config if env_id in ENVS else env_id)
        except ConfigError as exc:
            raise SpeedError(
                f"--env {env_id} is neither a registered env id ({', '.join(ENVS)}) nor an env config: {exc}"
            ) from None
        try:
            check_supported(config)
        except UnsupportedByBatched as exc:
            raise SpeedError(f"{env_id}: {exc}") from None
    bad = [n for n in settings.batch_sizes if n < 1]
    if bad or not settings.batch_sizes:
        raise SpeedError(f"batch sizes must be positive integers, got {', '.join(map(str, settings.batch_sizes))}")
    env_case = {"steps": settings.env_steps, "resets": settings.resets, "warmup": settings.warmup}
    cases = [Case("envs", env_id, {"probe": "env", "env_id": env_id, **env_case}) for env_id in env_ids]
    for env_id in env_ids:
        for n in settings.batch_sizes:
            probe = {"probe": "batched", "env_id": env_id, "n": n, "agent_steps": settings.batched_agent_steps}
            cases.append(Case("batched", (env_id, n), probe))
    return cases


def swarm_keys(settings: SpeedSettings) -> list[tuple[str, int]]:
    """The swarm rows: (env, agents) -- hover and formation at every count, then dogfight 2 v 2."""
    if not settings.swarm:
        return []
    return [(env, n) for env in ("hover", "formation") for n in settings.swarm] + [("dogfight", 4)]


# ------------------------------------------------------------------- processes


def run_probe(
    probe: Mapping[str, Any],
    command: Sequence[str] | None = None,
    env: Mapping[str, str] | None = None,
    timeout: float = 1800.0,
) -> dict:
    """Run one probe in a fresh process and return its result.

    Args:
        probe: the probe's name (``"probe"``) and arguments; passed as JSON, the last argument.
        command: the program that runs probes and prints the result line
            (:func:`~pyflyt_cli.speed.protocols.main`); by default this package's,
            ``python -m pyflyt_cli.speed.probes`` in this interpreter, with this
            package on its import path.
        env: the process's environment variables (default: this process's).
    """
    if command is None:
        command = [sys.executable, "-m", "pyflyt_cli.speed.probes"]
        env = dict(os.environ if env is None else env)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (_PACKAGE_ROOT, env.get("PYTHONPATH")) if p)
    line = [*command, json.dumps(probe)]
    try:
        done = subprocess.run(line, check=False, capture_output=True, text=True, env=env, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise SpeedError(f"could not run the {probe['probe']} probe with {line[0]}: {exc}") from None
    results = [json.loads(x[len(RESULT_MARKER) :]) for x in done.stdout.splitlines() if x.startswith(RESULT_MARKER)]
    if done.returncode != 0 or not results:
        tail = "\n".join((done.stderr or done.stdout).strip().splitlines()[-4:])
        raise SpeedError(f"{probe['probe']} probe {dict(probe)} failed in {line[0]}:\n{tail}")
    return results[-1]


def median(results: list[dict]) -> dict:
    """Per-key median of numeric fields (other fields from the first result), and ``repeats``."""
    merged = dict(results[0])
    for key, value in results[0].items():
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            merged[key] = statistics.median(r[key] for r in results)
    merged["repeats"] = len(results)
    return merged


def scaling(one: list[float], two: list[float]) -> dict:
    """1 -> 2 scaling from runs paired by repeat: the median, lowest and highest of the
    per-repeat ratios (a pair shares the load of its moment; medians of the two sides
    taken apart would mix moments)."""
    ratios = [b / a for a, b in zip(one, two)]
    return {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios), "ratios": ratios}


# ------------------------------------------------------------------- measuring


def run_speed(
    settings: SpeedSettings = SpeedSettings(),
    progress: Callable[[str], None] | None = None,
    measure: Callable[[Case], dict] | None = None,
) -> dict:
    """Measure every case ``settings.repeats`` times; the report (JSON data) of the medians.

    Args:
        progress: receives one line before each case.
        measure: runs one case and returns its result (default: :func:`run_probe` of its
            probe, a fresh process).  It also runs the ``machine`` case, once, first.

    Raises:
        SpeedError: bad settings (before anything runs), or a case failed.
    """
    cases = plan_cases(settings)
    measure = measure or (lambda case: run_probe(case.probe))
    say = progress or (lambda message: None)
    machine = measure(Case("machine", None, {"probe": "machine"}))
    results: dict[tuple[str, Any], list[dict]] = {}
    for repeat in range(settings.repeats):
        for case in cases:
            say(f"[{repeat + 1}/{settings.repeats}] {case.section} {case.key}")
            results.setdefault((case.section, case.key), []).append(measure(case))

    def med(section: str, key: Any) -> dict:
        return median(results[(section, key)])

    env_ids = [case.key for case in cases if case.section == "envs"]
    if settings.backend == "batched":
        return {
            "machine": machine,
            "settings": settings.as_dict(),
            "envs": [med("envs", env_id) for env_id in env_ids],
            "batched": [med("batched", case.key) for case in cases if case.section == "batched"],
        }
    report: dict[str, Any] = {
        "machine": machine,
        "settings": settings.as_dict(),
        "envs": [med("envs", env_id) for env_id in env_ids],
        "env_floor": med("env_floor", 1),
        "worlds": [{**med("worlds", n), "floor": med("floors", n)} for n in settings.vehicles],
        "camera": {key: med("camera", key) for key in CAMERA_CASES},
        "swarm": [med("swarm", key) for key in swarm_keys(settings)],
        "vector": None,
        "parallel": None,
    }
    if settings.vector:
        work = {p: [r["work_per_s"] for r in results[("parallel", p)]] for p in (1, 2)}
        report["parallel"] = scaling(work[1], work[2])
        report["vector"] = [_vector_row(results, env_id, backend) for env_id in env_ids for backend in VECTOR_BACKENDS]
    return report


def _vector_row(results: dict[tuple[str, Any], list[dict]], env_id: str, backend: str) -> dict:
    """The vector figures of one env and backend: the env's, and the stand-in's beside them."""

    def side(stand_in: bool) -> dict:
        runs = {w: results[("vector", (env_id, backend, stand_in, w))] for w in (1, 2)}
        rate = {w: [r["steps_per_s"] for r in runs[w]] for w in (1, 2)}
        row = {
            "steps_per_s": {str(w): statistics.median(rate[w]) for w in (1, 2)},
            "scaling": scaling(rate[1], rate[2]),
        }
        if stand_in:
            row["env_step_cpu_s"] = median(runs[1] + runs[2])["env_step_cpu_s"]
        else:
            row["cpu_per_step_s"] = {str(w): median(runs[w]).get("cpu_per_step_s") for w in (1, 2)}
        return row

    return {"id": env_id, "backend": backend, **side(False), "stand_in": side(True)}
