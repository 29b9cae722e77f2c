"""Public projects written for PyFlyt 0.29, run unchanged on the compat layer beside the reference.

    python experiments/user_projects.py --sources DIR [--reference-python PY]
                                        [--out experiments/results/user_projects.md]

What a port of real research code meets: each entry of :data:`PROJECTS` names a public
repository, the commit it was read at, and an env class in it that subclasses or wraps
PyFlyt (the stock envs, their base envs, the ``WaypointHandler``, the Aviary, the PettingZoo
envs).  The sources are not part of this project: fetch each repository into
``DIR/<owner>+<name>`` at the listed commit (``git clone https://github.com/<owner>/<name>
DIR/<owner>+<name> && git -C DIR/<owner>+<name> checkout <commit>``).

Each entry runs in a fresh interpreter, twice: once in the reference's (PyFlyt 0.29.0 installed,
``--reference-python``, default $PYFLYT_REFERENCE_PYTHON or /work/refvenv/bin/python) and once
in this one, where the project's ``import PyFlyt...`` statements resolve to
``pyflyt_engine.compat...`` -- the import prefix changed and nothing else, done by an import
alias so that the project's files stay untouched (a name such as ``PyFlyt.__path__`` then
means the compat package too).  Both make the env as the project does (``gymnasium.make`` of a
registration with its step limit where the project registers it, else the class itself), fly
:data:`EPISODES` episodes under seeds 0, 1, 2 with the same seeded uniform random actions, and
record each episode's length, return and ending, the warnings raised, or the exception.

The report says, per entry: runs on both (lengths and returns side by side: the vehicles are
this project's models, so they are near, not equal), fails on both (the project was written
for another PyFlyt version), refused here by design (a reference feature the compat layer declines, with the way forward
in its message: docs/migrating_from_pyflyt.md), or fails here only (a gap of the compat layer).
"""

from __future__ import annotations

import argparse
import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import json
import os
import platform
import subprocess
import sys
import time
import traceback
import warnings
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_REFERENCE = os.environ.get("PYFLYT_REFERENCE_PYTHON", "/work/refvenv/bin/python")
EPISODES = 3
#: agent steps per episode at most (an episode that runs longer is cut and says so)
MAX_STEPS = 400

#: name -> where the env is and how the project makes it.  ``module``: the dotted module
#: imported with the repository's root on the path; ``file``: a file loaded alone (where the
#: project's package ``__init__`` pulls in unrelated simulators); ``register``: the step
#: limit of the project's own gymnasium registration (made with ``gymnasium.make``).
PROJECTS: dict[str, dict[str, Any]] = {
    "stable-gym QuadXHoverCost": {
        "repo": "rickstaa/stable-gym",
        "commit": "e6065a1",
        "file": "stable_gym/envs/robotics/quadrotor/quadx_hover_cost/quadx_hover_cost.py",
        "cls": "QuadXHoverCost",
        "kind": "gym",
        "register": 250,
        "uses": "subclasses QuadXHoverEnv; reads env.state(0), env.elapsed_time; its own cost and endings",
    },
    "stable-gym QuadXTrackingCost": {
        "repo": "rickstaa/stable-gym",
        "commit": "e6065a1",
        "file": "stable_gym/envs/robotics/quadrotor/quadx_tracking_cost/quadx_tracking_cost.py",
        "cls": "QuadXTrackingCost",
        "kind": "gym",
        "register": 250,
        "uses": "subclasses QuadXHoverEnv; PyFlyt.__path__ for a model file; a moving reference",
    },
    "stable-gym QuadXWaypointsCost": {
        "repo": "rickstaa/stable-gym",
        "commit": "e6065a1",
        "file": "stable_gym/envs/robotics/quadrotor/quadx_waypoints_cost/quadx_waypoints_cost.py",
        "cls": "QuadXWaypointsCost",
        "kind": "gym",
        "register": 250,
        "uses": "subclasses QuadXWaypointsEnv; WaypointHandler.distance_to_target (a pre-0.29 name)",
    },
    "pyflyt_experience SingleWaypointQuadXEnv": {
        "repo": "felix-basiliskroko/pyflyt_experience",
        "commit": "f2dbafd",
        "module": "Envs.static_waypoint",
        "cls": "SingleWaypointQuadXEnv",
        "kind": "gym",
        "uses": "subclasses QuadXBaseEnv with a WaypointHandler; begin_reset/end_reset, compute_attitude, Aviary states",
    },
    "pyflyt-drone-rl HoverEnv": {
        "repo": "nikolas-j/pyflyt-drone-rl",
        "commit": "7ef2e3e",
        "module": "envs.hover_env",
        "cls": "HoverEnv",
        "kind": "gym",
        "uses": "wraps gymnasium.make('PyFlyt/QuadX-Hover-v3', flight_mode=6); reads the inner env's state",
    },
    "pyflyt-drone-rl WaypointEnv": {
        "repo": "nikolas-j/pyflyt-drone-rl",
        "commit": "7ef2e3e",
        "module": "envs.waypoint_env",
        "cls": "WaypointEnv",
        "kind": "gym",
        "uses": "as HoverEnv, with a moving goal of its own",
    },
    "pyflyt_rail_env Environment": {
        "repo": "jjshoots/pyflyt_rail_env",
        "commit": "c678f1d",
        "module": "pyflyt_rail_env.environment",
        "cls": "Environment",
        "kind": "gym",
        "uses": "the PyFlyt author's rail-following task: an Aviary with a gimballed camera, world_scale, "
        "loadOBJ / obj_visual / obj_collision meshes of its own",
    },
    "pyflyt-kamikazes MAFixedwingDogfightEnv": {
        "repo": "labanca/pyflyt-kamikazes",
        "commit": "e400833",
        "module": "modules.envs_test.ma_fixedwing_dogfight_env",
        "cls": "MAFixedwingDogfightEnv",
        "kind": "pz",
        "uses": "subclasses pz_envs.fixedwing_envs.ma_fixedwing_base_env.MAFixedwingBaseEnv",
    },
}


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``PyFlyt`` and ``PyFlyt.<x>`` are ``pyflyt_engine.compat`` and ``pyflyt_engine.compat.<x>``."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if name != "PyFlyt" and not name.startswith("PyFlyt."):
            return None
        return importlib.machinery.ModuleSpec(name, self, is_package=True)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> Any:
        return importlib.import_module("pyflyt_engine.compat" + spec.name[len("PyFlyt") :])

    def exec_module(self, module: Any) -> None:
        pass


class _Project(importlib.abc.MetaPathFinder):
    """The project's top-level modules and packages, found in its checkout (as if it were the
    working directory the project runs from)."""

    def __init__(self, root: Path) -> None:
        self.root = str(root)

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if path is not None:  # a submodule: its package's own path finds it
            return None
        return importlib.machinery.PathFinder.find_spec(name, [self.root])


def _load(entry: dict[str, Any], root: Path) -> Any:
    sys.meta_path.append(_Project(root))  # after the installed packages (no listed project shadows one)
    if "module" in entry:
        return importlib.import_module(entry["module"])
    spec = importlib.util.spec_from_file_location(Path(entry["file"]).stem, root / entry["file"])
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _uniform(rng: Any, space: Any) -> Any:
    import numpy as np

    low = np.clip(space.low, -1e3, 1e3)
    high = np.clip(space.high, -1e3, 1e3)
    return rng.uniform(low, high).astype(space.dtype)


def _fly_gym(env: Any) -> list[dict[str, Any]]:
    import numpy as np

    rng = np.random.default_rng(0)
    episodes = []
    for seed in range(EPISODES):
        env.reset(seed=seed)
        total, steps, terminated, truncated = 0.0, 0, False, False
        while not (terminated or truncated) and steps < MAX_STEPS:
            _, reward, terminated, truncated, _ = env.step(_uniform(rng, env.action_space))
            total += float(reward)
            steps += 1
        episodes.append(
            {"length": steps, "return": total, "terminated": bool(terminated), "truncated": bool(truncated)}
        )
    return episodes


def _fly_pz(env: Any) -> list[dict[str, Any]]:
    import numpy as np

    rng = np.random.default_rng(0)
    episodes = []
    for seed in range(EPISODES):
        env.reset(seed=seed)
        total, steps = 0.0, 0
        while env.agents and steps < MAX_STEPS:
            actions = {agent: _uniform(rng, env.action_space(agent)) for agent in env.agents}
            _, rewards, _, _, _ = env.step(actions)
            total += float(sum(rewards.values()))
            steps += 1
        episodes.append({"length": steps, "return": total, "terminated": not env.agents, "truncated": False})
    return episodes


def run_entry(name: str, sources: Path, side: str) -> dict[str, Any]:
    """Fly one entry in this interpreter (``side``: ``compat`` installs the import alias)."""
    entry = PROJECTS[name]
    if side == "compat":
        sys.meta_path.insert(0, _Alias())
    record: dict[str, Any] = {}
    start = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            module = _load(entry, sources / entry["repo"].replace("/", "+"))
            cls = getattr(module, entry["cls"])
            if entry["kind"] == "pz":
                env = cls()
                record["episodes"] = _fly_pz(env)
            else:
                import gymnasium

                if "register" in entry:
                    env_id = f"UserProject/{entry['cls']}-v0"
                    gymnasium.register(id=env_id, entry_point=cls, max_episode_steps=entry["register"])
                    env = gymnasium.make(env_id)
                else:
                    env = cls()
                record["episodes"] = _fly_gym(env)
            env.close()
        record["warnings"] = sorted({f"{w.category.__name__}: {str(w.message).splitlines()[0][:160]}" for w in caught})
    except Exception as error:  # the entry's outcome, reported
        record["error"] = "".join(traceback.format_exception_only(error)).strip().splitlines()[-1][:300]
        record["where"] = traceback.format_exc().strip().splitlines()[-3].strip()[:300]
    record["seconds"] = time.perf_counter() - start
    return record


def _side(python: str, side: str, sources: Path) -> dict[str, Any]:
    results = {}
    for name in PROJECTS:
        proc = subprocess.run(
            [python, __file__, "--run-entry", name, "--side", side, "--sources", str(sources)],
            capture_output=True,
            text=True,
            cwd=sources,
        )
        lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
        if lines:
            results[name] = json.loads(lines[-1])
        else:
            results[name] = {"error": f"the interpreter exited {proc.returncode}: {proc.stderr.strip()[-300:]}"}
    return results


def _outcome(ref: dict[str, Any], ours: dict[str, Any]) -> str:
    if "error" in ref and "error" in ours:
        return "fails on both"
    if "error" in ours:
        # a feature refused by design names itself (UnsupportedFeature) and says what to do instead
        return "refused here by design" if "UnsupportedFeature" in ours["error"] else "fails here only"
    if "error" in ref:
        return "runs here only"
    return "runs on both"


def _episodes(record: dict[str, Any]) -> str:
    if "error" in record:
        return f"`{record['error']}`"
    return "; ".join(f"{e['length']} steps, {e['return']:.1f}" for e in record["episodes"])


def report(results: dict[str, Any], out: Path) -> None:
    lines = [
        "# Public PyFlyt 0.29 projects, unchanged, on the compat layer and on the reference",
        "",
        f"`python experiments/user_projects.py --sources DIR` at {results['when']}, {results['seconds']:.0f} s. "
        f"Machine: {results['machine']}; load average at the start {results['load'][0]}, at the end {results['load'][1]}.",
        "",
        f"Each env flown {EPISODES} episodes (seeds 0-2, the same seeded uniform random actions on both sides, "
        f"at most {MAX_STEPS} agent steps each); per episode its length and return.",
        "",
        "| project | repository @ commit | what it uses | outcome | reference | compat | warnings (reference / compat) |",
        "|---|---|---|---|---|---|---|",
    ]
    counts: dict[str, int] = {}
    for name, entry in PROJECTS.items():
        ref, ours = results["reference"][name], results["compat"][name]
        outcome = _outcome(ref, ours)
        counts[outcome] = counts.get(outcome, 0) + 1
        warn = f"{len(ref.get('warnings', []))} / {len(ours.get('warnings', []))}"
        lines.append(
            f"| {name} | {entry['repo']} @ {entry['commit']} | {entry['uses']} | **{outcome}** | "
            f"{_episodes(ref)} | {_episodes(ours)} | {warn} |"
        )
    lines += ["", "Outcomes: " + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) + ".", ""]
    for side in ("reference", "compat"):
        for name, record in results[side].items():
            for warning in record.get("warnings", []):
                lines.append(f"- {side}, {name}: {warning}")
    out.write_text("\n".join(lines) + "\n")
    out.with_suffix(".json").write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sources", type=Path, required=True, help="folder holding <owner>+<name> checkouts")
    parser.add_argument("--reference-python", default=DEFAULT_REFERENCE)
    parser.add_argument("--out", type=Path, default=ROOT / "experiments" / "results" / "user_projects.md")
    parser.add_argument("--run-entry", help=argparse.SUPPRESS)
    parser.add_argument("--side", choices=["compat", "reference"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    sources = args.sources.resolve()
    if args.run_entry:
        print(json.dumps(run_entry(args.run_entry, sources, args.side)))
        return
    missing = [e["repo"] for e in PROJECTS.values() if not (sources / e["repo"].replace("/", "+")).is_dir()]
    if missing:
        sys.exit(
            f"--sources {sources} lacks {sorted(set(missing))}: fetch each as <owner>+<name> (the docstring says how)"
        )
    if not Path(args.reference_python).exists():
        sys.exit(
            f"no reference interpreter at {args.reference_python}: make a venv with pyflyt==0.29.0 and pass --reference-python"
        )
    start = time.perf_counter()
    load_start = os.getloadavg()
    results: dict[str, Any] = {
        "when": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
        "reference": _side(args.reference_python, "reference", sources),
        "compat": _side(sys.executable, "compat", sources),
    }
    results["seconds"] = time.perf_counter() - start
    results["load"] = [tuple(round(x, 2) for x in load_start), tuple(round(x, 2) for x in os.getloadavg())]
    report(results, args.out)
    print(args.out.read_text())


if __name__ == "__main__":
    main()
