"""Regenerate the figures README.md and docs/quickstart.md quote: the first hour, as a new user runs it.

In a scratch directory this runs, exactly as the documents say:

1. ``pyflyt train`` (PPO on QuadX-Hover, the defaults): the transcript, the evaluation
   returns, the training time, the command's wall and CPU time;
2. ``pyflyt eval <run> episodes=10 video=hover.gif``: the returns, the policy's mean
   distance to the hover point over each episode (as ``experiments/learn_hover_ppo.py``
   measures it), wall and CPU time;
3. ``pyflyt replay <run>/episodes/ep_0000.mcap --video hover.mp4 --size 640x480``: frame
   150 becomes ``docs/images/flight_video.png``; the reward and return at that step;
4. ``pyflyt train env=quadx_waypoints algo=sac``, stopped once it has printed its ETA
   (the documented SAC time);
5. ``pyflyt eval zoo:<name>`` for every shipped agent with its recorded episodes.

It writes ``experiments/results/doc_figures.md`` (machine, load average, times) and
``experiments/results/doc_figures.json`` (the figures; ``tests/test_doc_figures.py``
checks that the documents quote them)::

    python experiments/doc_figures.py              # everything (~10-15 min on 2 cores)
    python experiments/doc_figures.py --skip-zoo   # without step 5
    python experiments/doc_figures.py --only-sac   # step 4 again, the other figures as recorded

Returns, distances and the video frame are the same on every x86_64 CPU with AVX2 (the
pinned kernels, ``docs/reproducibility.md``); times depend on the machine and its load,
which the results file states.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "experiments" / "results"
FRAME = 150


def _cpu_children() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def pyflyt(args: list[str], cwd: Path) -> dict:
    """Run ``pyflyt <args>``; its output, wall and CPU time, and the load around it."""
    load = os.getloadavg()[0]
    cpu, wall = _cpu_children(), time.monotonic()
    done = subprocess.run([sys.executable, "-m", "pyflyt_cli.main", *args], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"pyflyt {' '.join(args)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return {
        "command": "pyflyt " + " ".join(args),
        "stdout": done.stdout,
        "stderr": done.stderr,
        "wall_s": time.monotonic() - wall,
        "cpu_s": _cpu_children() - cpu,
        "load": [load, os.getloadavg()[0]],
    }


def _train(work: Path) -> tuple[dict, Path]:
    result = pyflyt(["train"], work)
    text = result["stderr"] + result["stdout"]
    run = Path(re.search(r"^run: (.+)$", text, re.M).group(1).strip())
    evals = [
        {"step": int(m[0]), "mean": float(m[1]), "std": float(m[2]), "success": int(m[3])}
        for m in re.findall(r"step (\d+)/\d+: eval return (-?[\d.]+) ± ([\d.]+), success (\d+) %", text)
    ]
    done = re.search(r"done: (\d+) steps, ([\d.]+) s in training \((\d+) steps/s\)", text)
    figures = {
        "evaluations": evals,
        "steps": int(done[1]),
        "training_s": float(done[2]),
        "steps_per_s": int(done[3]),
        "eta": re.search(r"^ETA: about (\S+)", text, re.M).group(1),
        "transcript": [line for line in text.splitlines() if line.strip()],
    }
    return {**result, "figures": figures}, run


def _distances(run: Path) -> list[float]:
    """Mean distance to the hover point over each recorded evaluation episode [m]."""
    import numpy as np

    import pyflyt_engine  # noqa: F401 - pins the kernels
    from pyflyt_engine.telemetry import load_episode as read_episode

    out = []
    for path in sorted((run / "episodes").glob("ep_*.mcap")):
        episode = read_episode(path)
        point = np.asarray(episode.config["task"]["hover_point"], dtype=float)
        positions = np.asarray(episode.vehicles[0].states["lin_pos"], dtype=float)[1:]  # after each step
        out.append(float(np.mean(np.sqrt(((positions - point) ** 2).sum(axis=1)))))
    return out


def _eval(run: Path, work: Path) -> dict:
    result = pyflyt(["eval", str(run), "episodes=10", "video=hover.gif"], work)
    returns = [float(m) for m in re.findall(r"^\s*\d+\s+\d+\s+(-?[\d.]+)", result["stdout"], re.M)]
    summary = re.search(r"return\s+(-?[\d.]+) ± ([\d.]+)", result["stdout"])
    distances = _distances(run)
    result["figures"] = {
        "returns": returns,
        "mean_return": float(summary[1]),
        "std_return": float(summary[2]),
        "distance_m": distances,
        "mean_distance_m": sum(distances) / len(distances),
    }
    return result


def _frame(run: Path, work: Path) -> dict:
    import imageio.v3 as iio
    import numpy as np

    from pyflyt_engine.telemetry import load_episode as read_episode

    episode = run / "episodes" / "ep_0000.mcap"
    result = pyflyt(["replay", str(episode), "--video", "hover.mp4", "--size", "640x480"], work)
    frame = iio.imread(work / "hover.mp4", index=FRAME)
    out = ROOT / "docs" / "images" / "flight_video.png"
    iio.imwrite(out, frame)
    rec = read_episode(episode)
    rewards = np.asarray(rec.rewards, dtype=float)
    point = np.asarray(rec.config["task"]["hover_point"], dtype=float)
    position = np.asarray(rec.vehicles[0].states["lin_pos"], dtype=float)[FRAME]
    result["figures"] = {
        "frame": FRAME,
        "reward": float(rewards[FRAME - 1]),
        "return": float(rewards[:FRAME].sum()),
        "distance_m": float(np.sqrt(((position - point) ** 2).sum())),
        "image": str(out.relative_to(ROOT)),
    }
    return result


def _sac_eta(work: Path) -> dict:
    """``pyflyt train env=quadx_waypoints algo=sac`` until it prints its ETA, then Ctrl-C."""
    load = os.getloadavg()[0]
    proc = subprocess.Popen(
        [sys.executable, "-m", "pyflyt_cli.main", "train", "env=quadx_waypoints", "algo=sac", "run_dir=sac_eta"],
        cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    eta, lines = None, []
    for line in proc.stderr:  # the readiness signal: the ETA line
        lines.append(line.rstrip())
        if line.startswith("ETA:"):
            eta = line.strip()
            break
    # Ctrl-C asks for a clean stop; one that lands before the run's own handler is in place
    # (while it builds its evaluation env) is not seen, so ask again, then abort
    for sig, wait in ((signal.SIGINT, 60), (signal.SIGINT, 60), (signal.SIGKILL, 60)):
        os.killpg(proc.pid, sig)
        try:
            proc.communicate(timeout=wait)
            break
        except subprocess.TimeoutExpired:
            continue
    if eta is None:
        raise SystemExit("pyflyt train env=quadx_waypoints algo=sac printed no ETA:\n" + "\n".join(lines[-20:]))
    return {"command": "pyflyt train env=quadx_waypoints algo=sac", "eta": eta, "load": [load, os.getloadavg()[0]],
            "budget": next(x for x in lines if x.startswith("budget:"))}  # fmt: skip


def _zoo(work: Path) -> dict:
    from pyflyt_cli import zoo

    out = {}
    for agent in zoo.agents():
        episodes = agent.summary["evaluation"]["episodes"]
        result = pyflyt(["eval", f"zoo:{agent.name}", f"episodes={episodes}", "record=false"], work)
        out[agent.name] = {
            "line": next(x for x in result["stdout"].splitlines() if x.startswith("recorded:")),
            "success": re.search(r"success rate\s+(\d+) %", result["stdout"])[1],
            "wall_s": result["wall_s"],
        }
    return out


def _machine() -> str:
    import platform

    from pyflyt_engine.numerics import platform_info

    info = platform_info()
    return f"{platform.machine()} {info['cpu']}, {os.cpu_count()} cores, {info['status']}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-zoo", action="store_true")
    parser.add_argument("--keep", type=Path, help="keep the scratch directory here")
    parser.add_argument(
        "--only-sac",
        action="store_true",
        help="measure step 4 again (after the SAC tuning changed), keep the other figures as recorded",
    )
    args = parser.parse_args()
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    if args.only_sac:
        figures = json.loads((RESULTS / "doc_figures.json").read_text())
        work = Path(tempfile.mkdtemp(prefix="doc_figures_"))
        try:
            figures["sac_eta"] = {**_sac_eta(work), "date": started, "machine": _machine()}
        finally:
            shutil.rmtree(work, ignore_errors=True)
        print(f"sac: {figures['sac_eta']['eta']}", flush=True)
        write_results(figures)
        return
    work = Path(tempfile.mkdtemp(prefix="doc_figures_"))
    try:
        train_result, run = _train(work)
        print(f"train: {train_result['wall_s']:.0f} s", flush=True)
        eval_result = _eval(run, work)
        print(f"eval: {eval_result['wall_s']:.0f} s", flush=True)
        frame_result = _frame(run, work)
        print(f"video: {frame_result['wall_s']:.0f} s", flush=True)
        sac = _sac_eta(work)
        print(f"sac: {sac['eta']}", flush=True)
        zoo_result = {} if args.skip_zoo else _zoo(work)
    finally:
        if args.keep:
            shutil.copytree(work, args.keep, dirs_exist_ok=True)
        shutil.rmtree(work, ignore_errors=True)
    machine = _machine()
    figures = {
        "machine": machine,
        "date": started,
        "train": {**train_result["figures"], "wall_s": train_result["wall_s"], "cpu_s": train_result["cpu_s"],
                  "load": train_result["load"]},
        "eval": {**eval_result["figures"], "wall_s": eval_result["wall_s"], "cpu_s": eval_result["cpu_s"],
                 "load": eval_result["load"]},
        "video": {**frame_result["figures"], "wall_s": frame_result["wall_s"], "cpu_s": frame_result["cpu_s"],
                  "load": frame_result["load"]},
        "sac_eta": sac,
        "zoo": zoo_result,
    }  # fmt: skip
    write_results(figures)


def write_results(figures: dict) -> None:
    """``doc_figures.json`` and ``doc_figures.md`` from the figures."""
    (RESULTS / "doc_figures.json").write_text(json.dumps(figures, indent=1) + "\n")
    machine, started, sac, zoo_result = figures["machine"], figures["date"], figures["sac_eta"], figures["zoo"]
    t, e, v = figures["train"], figures["eval"], figures["video"]
    lines = [
        "# The figures README.md and docs/quickstart.md quote",
        "",
        f"`python experiments/doc_figures.py` on {machine}; started {started}.",
        "Returns, distances and the frame are exact on any x86_64 CPU with AVX2; times are this machine's, at the",
        "load averages given (1-minute, before and after each command).",
        "",
        f"## `pyflyt train` ({t['wall_s']:.0f} s wall, {t['cpu_s']:.0f} s CPU, load {t['load'][0]:.1f} -> {t['load'][1]:.1f})",
        "",
        "```text",
        *t["transcript"],
        "```",
        "",
        f"## `pyflyt eval <run> episodes=10 video=hover.gif` ({e['wall_s']:.0f} s wall, {e['cpu_s']:.0f} s CPU, "
        f"load {e['load'][0]:.1f} -> {e['load'][1]:.1f})",
        "",
        f"- return {e['mean_return']:.2f} ± {e['std_return']:.2f}; per episode: "
        + ", ".join(f"{r:.2f}" for r in e["returns"]),
        f"- mean distance to the hover point: {100 * e['mean_distance_m']:.1f} cm over the 10 episodes "
        f"({100 * min(e['distance_m']):.1f}-{100 * max(e['distance_m']):.1f} cm per episode)",
        "",
        f"## Frame {v['frame']} of `pyflyt replay <run>/episodes/ep_0000.mcap --video hover.mp4 --size 640x480` "
        f"({v['wall_s']:.0f} s wall, {v['cpu_s']:.0f} s CPU, load {v['load'][0]:.1f} -> {v['load'][1]:.1f})",
        "",
        f"- reward {v['reward']:.3f}, return {v['return']:.2f}, {100 * v['distance_m']:.1f} cm from the hover point; "
        f"`{v['image']}`",
        "",
        f"## `{sac['command']}` (load {sac['load'][0]:.1f}"
        + (
            f"; measured again on its own, {sac['date']}, on {sac['machine']}, after its tuning changed)"
            if "date" in sac
            else ")"
        ),
        "",
        f"- {sac['budget']}",
        f"- {sac['eta']}",
        "",
    ]
    if zoo_result:
        lines += ["## `pyflyt eval zoo:<name>`", ""]
        lines += [
            f"- `{k}` ({z['wall_s']:.0f} s, success {z['success']} %): {z['line']}" for k, z in zoo_result.items()
        ]
        lines.append("")
    (RESULTS / "doc_figures.md").write_text("\n".join(lines))
    print(f"wrote {RESULTS / 'doc_figures.md'} and doc_figures.json")


if __name__ == "__main__":
    main()
