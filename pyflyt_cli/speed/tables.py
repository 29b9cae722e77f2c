"""The report of :func:`~pyflyt_cli.speed.run_speed` as plain-text or Markdown tables."""

from __future__ import annotations

from collections.abc import Sequence

from pyflyt_cli.speed.protocols import AGENT_HZ

#: Row labels of the camera cases.
CAMERA_LABELS = {"all": "rgba + depth + segmentation", "rgba": "rgba only", "depth": "depth only"}


def table(header: Sequence[str], rows: list[list[str]], markdown: bool) -> list[str]:
    """Lines of a table: the first column left-aligned, the others right-aligned."""
    if markdown:
        rule = "|" + "|".join("---" if i == 0 else "---:" for i in range(len(header))) + "|"
        return ["| " + " | ".join(header) + " |", rule] + ["| " + " | ".join(row) + " |" for row in rows]
    widths = [max(len(str(c)) for c in column) for column in zip(header, *rows)]

    def line(cells: Sequence[str]) -> str:
        return "  ".join((c.ljust(w) if i == 0 else c.rjust(w)) for i, (c, w) in enumerate(zip(cells, widths)))

    return [line(header), line(["-" * w for w in widths])] + [line(row) for row in rows]


def number(value: float | None, digits: int = 0) -> str:
    """``12,345`` (``-`` for a missing value)."""
    return "-" if value is None else f"{value:,.{digits}f}"


def ratio(value: float | None) -> str:
    """``2.31x``, ``15x`` (``-`` for a missing value)."""
    return "-" if value is None else f"{value:.2f}x" if value < 10 else f"{value:.0f}x"


def _spread(scaling: dict) -> str:
    return f"{scaling['median']:.2f}x ({scaling['min']:.2f}-{scaling['max']:.2f})"


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


def titles(settings: dict) -> dict[str, str]:
    """What each table of the report shows and how it was measured."""
    return {
        "envs": f"Environments: agent {AGENT_HZ} Hz, random actions, {settings['env_steps']} steps (resets at "
        f"episode ends included), reset = median of {settings['resets']} seeded resets, memory = peak resident "
        "set of the process",
        "worlds": "Worlds of N QuadX (cf2x) holding position 1 m apart: real-time factor (simulated s per wall s), "
        "floor = bare PyBullet doing the same physical work for N bodies",
        "swarm": "Multi-agent envs against the number of agents: random actions for every live agent, resets "
        "when none is left included (agent 30 Hz); agent-steps/s = live agents stepped per wall second; us per "
        "agent-step = its inverse (flat when the cost grows linearly with the agents); RTF = simulated s per wall s; "
        "hover = MAQuadX-Hover on a 1 m grid, formation = MAQuadX-Formation (1 m grid, downwash on)",
        "camera": "Camera: one 128 x 128 onboard capture (QuadX at 1 m; mounted on its front-right propeller, "
        "90 deg field of view, pitched 20 deg down), ms wall (ms CPU)",
        "vector": f"Vector envs: env steps/s summed over subprocess workers ({settings['vector_steps']} vector "
        f"steps); scaling = 2 workers / 1 worker, median (lowest-highest) of {settings['repeats']} pairs; "
        "stand-in = the same vector env stepping pure CPU work of the env's in-process step cost (empty info, "
        "no episode ends); CPU = CPU time of the main process and the workers per env step",
    }


def floor_steps_per_s(floor: dict) -> float:
    """Env steps per second of the bare-PyBullet floor (8 physics steps per env step)."""
    return 1.0 / (floor["physics_step_s"] * 8)


def capture_ms(camera: dict) -> str:
    """``2.84 (2.80)``: ms of wall (and CPU) time per capture."""
    return f"{camera['capture_s'] * 1e3:.2f} ({camera['capture_cpu_s'] * 1e3:.2f})"


SWARM_LABELS = {"hover": "MAQuadX-Hover", "formation": "MAQuadX-Formation", "dogfight": "MAFixedwing-Dogfight"}


def swarm_table(rows: list[dict], markdown: bool, reference: dict | None = None) -> list[str]:
    """The swarm rows; with ``reference`` ((env, agents) -> its result), its agent-steps/s and ours over it."""
    header = ["env", "agents", "agent-steps/s", "us / agent-step", "env steps/s", "RTF", "live"]
    if reference is not None:
        header += ["reference agent-steps/s", "ours / reference"]
    body = []
    for row in rows:
        cells = [SWARM_LABELS.get(row["env"], row["env"]), str(row["agents"]), number(row["agent_steps_per_s"]),
                 number(1e6 / row["agent_steps_per_s"]), number(row["env_steps_per_s"], 1), number(row["rtf"], 2),
                 f"{100 * row['live_fraction']:.0f}%"]  # fmt: skip
        if reference is not None:
            ref = reference.get((row["env"], row["agents"]))
            theirs = ref["agent_steps_per_s"] if ref else None
            cells += [number(theirs), ratio(row["agent_steps_per_s"] / theirs) if theirs else "-"]
        body.append(cells)
    return table(header, body, markdown)


def batched_table(report: dict, markdown: bool) -> list[str]:
    """``--backend batched``: agent-steps/s against N, beside the PyBullet env of the same id:
    the ratio of the rates (wall clock), and per core, the ratio of the CPU time of the
    process per step of the PyBullet env to the batched backend's per agent-step (robust to
    other jobs' load, which slows the wall clock of both)."""
    pybullet = {row["id"]: row for row in report["envs"]}
    heading = "batched backend: N envs stepped by one call (motor noise on), beside the PyBullet env (one env per call)"
    out = [f"**{heading}**", ""] if markdown else [heading]
    rows = []
    for row in report["batched"]:
        env = pybullet.get(row["id"])
        base = env["steps_per_s"] if env else None
        base_cpu = env.get("step_cpu_s") if env else None
        rows.append([row["id"], str(row["n"]), number(row["steps_per_s"]), number(row["cpu_per_agent_step_s"] * 1e6, 2),
                     ratio(row["steps_per_s"] / base) if base else "-", number(row["memory_per_env_kb"], 1),
                     number(row["first_step_s"], 2),
                     ratio(base_cpu / row["cpu_per_agent_step_s"]) if base_cpu else "-"])  # fmt: skip
    for env_id, env in pybullet.items():
        cpu = env.get("step_cpu_s")
        rows.append([env_id, "PyBullet env", number(env["steps_per_s"]), number(cpu * 1e6, 2) if cpu else "-", "1x",
                     "-", "-", "1x" if cpu else "-"])  # fmt: skip
    out += table(["env", "N", "agent-steps/s", "CPU us / agent-step", "vs PyBullet env", "KiB per env",
                  "first step s", "x PyBullet env per core"], rows, markdown)  # fmt: skip
    return out


def format_report(report: dict, markdown: bool = False) -> str:
    """The report as plain-text tables, or as Markdown (for docs/performance.md)."""
    settings = report["settings"]
    heading = titles(settings)
    out: list[str] = [("Machine: " if markdown else "machine: ") + describe_machine(report["machine"])]
    out.append(
        ("\n" if markdown else "") + f"median of {settings['repeats']} run(s) per figure; each run in a fresh process"
    )
    out.append("")

    def title(section: str) -> None:
        out.extend([f"**{heading[section]}**", ""] if markdown else [heading[section]])

    if "batched" in report:
        return "\n".join(out + batched_table(report, markdown)) + "\n"

    title("envs")
    rows = [[row["id"], number(row["steps_per_s"]), number(row["rtf"], 1), number(row["reset_s"] * 1e3, 2),
             number(row["peak_rss_mb"])] for row in report["envs"]]  # fmt: skip
    floor = report["env_floor"]
    rows.append(["bare PyBullet floor (1 body, 8 physics steps)", number(floor_steps_per_s(floor)),
                 number(floor["rtf"], 1), "-", number(floor["peak_rss_mb"])])  # fmt: skip
    out += table(["env", "steps/s", "RTF", "reset ms", "peak MB"], rows, markdown)
    out.append("")

    title("worlds")
    rows = [[str(row["n"]), number(row["rtf"], 2), number(row["floor"]["rtf"], 2), ratio(row["floor"]["rtf"] / row["rtf"])]
            for row in report["worlds"]]  # fmt: skip
    out += table(["vehicles", "RTF", "floor RTF", "floor / ours"], rows, markdown)
    out.append("")

    if report.get("swarm"):
        title("swarm")
        out += swarm_table(report["swarm"], markdown)
        out.append("")

    title("camera")
    rows = [[CAMERA_LABELS[key], capture_ms(row)] for key, row in report["camera"].items()]
    out += table(["channels", "ours ms"], rows, markdown)

    if report.get("vector"):
        out.append("")
        title("vector")
        rows = []
        for row in report["vector"]:
            cpu = row.get("cpu_per_step_s") or {}
            backend = "gymnasium async" if row["backend"] == "gymnasium" else "SB3 SubprocVecEnv"
            stand_in = row["stand_in"]
            rows.append([row["id"], backend, number(row["steps_per_s"]["1"]), number(row["steps_per_s"]["2"]),
                         _spread(row["scaling"]), number(stand_in["env_step_cpu_s"] * 1e6), _spread(stand_in["scaling"]),
                         *(number(cpu[w] * 1e6) if cpu.get(w) else "-" for w in ("1", "2"))])  # fmt: skip
        out += table(["env", "vector env", "1 worker", "2 workers", "scaling", "step CPU us", "stand-in scaling",
                      "CPU us/step 1", "CPU us/step 2"], rows, markdown)  # fmt: skip
        parallel = report.get("parallel")
        if parallel:
            out.append("")
            out.append(
                f"machine: 2 processes of pure CPU work (no pipes) do {_spread(parallel)} the work of 1 "
                f"({settings.get('parallel_seconds', 0.5):g} s each, {settings['repeats']} pairs)"
            )
    return "\n".join(out) + "\n"
