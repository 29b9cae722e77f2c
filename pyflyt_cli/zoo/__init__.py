"""Trained agents shipped with the package: ``pyflyt zoo`` lists them, ``pyflyt eval zoo:<name>`` flies one.

An agent is a folder ``pyflyt_cli/zoo/agents/<env>_<algo>/`` made from a training run by
:func:`add_agent` (``pyflyt zoo --add <run dir>``):

    config.yaml         the run's configuration (the model is rebuilt from it)
    model.pt            the policy and its normaliser statistics (tensors only, safe to load)
    summary.yaml        env, algo, seed, the training (steps, time, command) and the recorded
                        evaluation (episodes, seeds, return per episode, mean ± std, success)
    learning_curve.png  the training run's evaluation return over steps

``pyflyt eval zoo:<name>`` copies ``config.yaml`` and ``model.pt`` to ``zoo/<name>/`` under
the working directory (a run directory: the shipped folder is never written) and
evaluates it there; with the recorded options it reproduces the recorded returns.
"""

from __future__ import annotations

import shlex
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.safe_load import load_yaml_file

AGENTS = Path(__file__).resolve().parent / "agents"
PREFIX = "zoo:"


@dataclass(frozen=True)
class Agent:
    name: str
    path: Path
    summary: dict[str, Any]


def agents(root: Path = AGENTS) -> list[Agent]:
    """The shipped agents, by name."""
    found = []
    if root.is_dir():
        for folder in sorted(root.iterdir()):
            if folder.name.startswith("."):  # an agent being built or replaced by add_agent
                continue
            summary = folder / "summary.yaml"
            if summary.is_file() and (folder / "model.pt").is_file():
                found.append(Agent(folder.name, folder, load_yaml_file(summary, what="agent summary") or {}))
    return found


def agent(name: str, root: Path = AGENTS) -> Agent:
    for a in agents(root):
        if a.name == name:
            return a
    from pyflyt_engine.suggest import did_you_mean

    shipped = [a.name for a in agents(root)]
    hint = did_you_mean(name, shipped)
    raise ConfigError(
        f"zoo:{name}: no such agent.{hint} Shipped: {', '.join(shipped) or 'none'} (list them with pyflyt zoo)"
    )


def table(root: Path = AGENTS) -> str:
    """``pyflyt zoo``: one row per agent, the columns as wide as their longest entry."""
    cells = [("name", "env", "algo", "steps", "return", "success")]
    for a in agents(root):
        s, e = a.summary, a.summary.get("evaluation", {})
        cells.append(
            (
                a.name,
                str(s.get("env_id", "?")),
                str(s.get("algo", "?")),
                str(s.get("training", {}).get("steps", 0)),
                f"{e.get('mean_return', float('nan')):.2f} ± {e.get('std_return', float('nan')):.2f}",
                f"{100 * e.get('success_rate', 0):.0f} %",
            )
        )
    widths = [max(len(row[i]) for row in cells) for i in range(6)]
    right = (False, False, False, True, True, True)
    rows = ["  ".join(c.rjust(w) if r else c.ljust(w) for c, w, r in zip(row, widths, right)).rstrip() for row in cells]
    if len(rows) == 1:
        rows.append("(no agents shipped)")
    rows.append("fly one: pyflyt eval zoo:<name> [video=agent.gif]")
    return "\n".join(rows)


#: below this p-value, returns that are not bit-identical to the recording are said to disagree with it
AGREEMENT_P = 0.01


def compare(recorded: dict[str, Any], returns: list[float], success_rate: float) -> tuple[bool, str]:
    """How an evaluation of the recorded episodes compares with the recording: (agrees, words).

    Bit-identical returns episode by episode match.  Otherwise the words say whether the
    recording was made under another numeric platform (``recorded["numerics"]``, compared
    with this process's) and whether the two samples of returns are consistent: a two-sided
    Mann-Whitney U test, consistent at p >= :data:`AGREEMENT_P`.  On the platform it was
    recorded on, returns that are not bit-identical mean the engine or the policy changed.
    """
    from pyflyt_engine.numerics import describe_difference, platform_info

    was = [float(r) for r in recorded.get("returns") or []]
    if was == [float(r) for r in returns]:
        return True, "matches episode by episode"
    if len(was) != len(returns) or not was:
        return False, "DIFFERS: the recording holds other episodes"
    made = recorded.get("numerics") or {}
    other = describe_difference(made.get("key"), platform_info()["key"]) if made.get("key") else None
    from scipy.stats import mannwhitneyu

    p = float(mannwhitneyu(was, returns, alternative="two-sided").pvalue)
    shift = sum(returns) / len(returns) - sum(was) / len(was)
    stats = (
        f"mean {shift:+.2f}, success {100 * success_rate:.0f} % vs {100 * float(recorded.get('success_rate', 0)):.0f} %, "
        f"Mann-Whitney p = {p:.2f}"
    )
    if other is None and made.get("key"):
        return (
            False,
            f"DIFFERS episode by episode on the numeric platform it was recorded on ({stats}): the engine or the policy changed",
        )
    where = f"recorded under another numeric platform ({other})" if other else "recorded without its numeric platform"
    if p >= AGREEMENT_P:
        return True, f"{where}: not bit-identical here, consistent with the recording ({stats})"
    return False, f"{where}: not bit-identical here, and inconsistent with the recording ({stats})"


def materialise(name: str, workdir: Path | None = None, root: Path = AGENTS) -> Path:
    """``zoo/<name>/`` under ``workdir``: a run directory holding the agent's config and policy."""
    a = agent(name, root)
    target = (workdir or Path.cwd()) / "zoo" / name
    target.mkdir(parents=True, exist_ok=True)
    for file in ("config.yaml", "model.pt"):
        shutil.copyfile(a.path / file, target / file)
    return target


def add_agent(
    run_dir: str | Path,
    name: str | None = None,
    episodes: int = 10,
    root: Path = AGENTS,
    replace: bool = False,
) -> Agent:
    """Make a shipped agent of a training run: its best policy (else final), evaluated now on
    ``episodes`` episodes with ``pyflyt eval``'s defaults (seeds run seed + 1000 + i, deterministic).

    An agent of that name already shipped is kept (a :class:`ConfigError`) unless ``replace``.
    The new agent is built and evaluated in a staging folder beside it and only then takes the
    name, so a failure on the way leaves the shipped agent as it was."""
    from pyflyt_cli.training import rundir

    run = rundir.check_run_dir(run_dir)
    cfg = rundir.load_run_config(run)
    model, which = rundir.find_model(run, "auto")
    name = name or f"{cfg.env_name}_{cfg.algo.name}"
    if not name.replace("_", "").replace("-", "").isalnum():
        raise ConfigError(f"zoo agent name {name!r}: letters, digits, _ and - only")
    final = root / name
    if final.exists() and not replace:
        raise ConfigError(
            f"zoo agent {name!r} exists ({final}): pass --replace to replace it, or --name to ship this run "
            "under another name"
        )
    folder = root / f".{name}.new"
    shutil.rmtree(folder, ignore_errors=True)  # a staging folder left by an interrupted --add
    folder.mkdir(parents=True)
    try:
        _build(run, cfg, model, which, name, episodes, folder)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    if final.exists():
        old = root / f".{name}.old"
        shutil.rmtree(old, ignore_errors=True)
        final.rename(old)
        folder.rename(final)
        shutil.rmtree(old)
    else:
        folder.rename(final)
    return agent(name, root)


def _build(run: Path, cfg: Any, model: Path, which: str, name: str, episodes: int, folder: Path) -> None:
    """Write an agent's files into ``folder``: config, weights, the evaluation, summary and curve."""
    from pyflyt_cli.training import rundir

    rundir.save_config(cfg, folder)
    shutil.copyfile(model, folder / "model.pt")
    # the recorded evaluation is that of the shipped folder itself, as pyflyt eval zoo:<name> runs it
    evaluation = evaluation_record(folder, episodes)
    record = rundir.read_yaml(run / rundir.RUN_FILE)
    state = rundir.read_state(run)
    progress = _progress(run)
    summary = {
        "name": name,
        "env": cfg.env_name,
        "env_id": str(cfg.env.id),
        "algo": cfg.algo.name,
        "seed": cfg.seed,
        "policy": {"from": which, "step": _step(folder / "model.pt")},
        "training": {
            "steps": int(state.get("num_timesteps") or 0),
            "seconds": progress.get("elapsed"),
            "steps_per_second": progress.get("steps_per_second"),
            # a pyflyt train line that composes the run's settings (null if none does), and the
            # command line of the process that trained it
            "command": _train_command(cfg, record),
            "ran": shlex.join(str(a) for a in record.get("command") or []) or None,
            "overrides": record.get("overrides") or [],
            "versions": record.get("versions") or {},
        },
        "evaluation": evaluation,
    }
    (folder / "summary.yaml").write_text(yaml.safe_dump(summary, sort_keys=False))
    _learning_curve(run, folder / "learning_curve.png", name)


def evaluation_record(folder: Path, episodes: int) -> dict[str, Any]:
    """The evaluation a summary records: ``episodes`` deterministic episodes from
    ``pyflyt eval``'s default seeds, flown in ``folder`` as ``pyflyt eval zoo:<name>`` flies
    them, with the numeric platform they were flown on."""
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.evaluate import evaluate_run

    report = evaluate_run(folder, {"episodes": episodes, "model": "final", "record": False})
    (folder / "eval.json").unlink(missing_ok=True)
    here = rundir.numeric_platform()
    return {
        "episodes": episodes,
        "seed": report.seed,
        "deterministic": True,
        **report.summary,
        "returns": [e.ret for e in report.episodes],
        "numerics": {"cpu": here["cpu"], "status": here["status"], "key": here["key"]},
    }


def rerecord(name: str, root: Path = AGENTS) -> dict[str, Any]:
    """Fly a shipped agent's recorded evaluation again and record it (after a change of the
    engine that is meant to change its numbers); returns the new evaluation block."""
    a = agent(name, root)
    episodes = int(a.summary.get("evaluation", {}).get("episodes") or 10)
    staging = root / f".{name}.eval"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir()
    try:
        for file in ("config.yaml", "model.pt"):
            shutil.copyfile(a.path / file, staging / file)
        evaluation = evaluation_record(staging, episodes)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    summary = dict(a.summary)
    summary["evaluation"] = evaluation
    tmp = a.path / ".summary.yaml.tmp"
    tmp.write_text(yaml.safe_dump(summary, sort_keys=False))
    tmp.replace(a.path / "summary.yaml")
    return evaluation


def _step(model: Path) -> int:
    from pyflyt_cli.training.models import read_policy

    return int(read_policy(model).step or 0)


def _progress(run: Path) -> dict[str, Any]:
    import warnings

    from pyflyt_engine.telemetry import read_metrics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        records = read_metrics(run).get("/train/progress", [])
    return dict(records[-1]) if records else {}


def _learning_curve(run: Path, out: Path, title: str, bins: int = 40) -> str:
    """Draw the run's evaluation return (mean ± std) against environment steps; for a run
    trained without evaluations, its training episodes' return instead (mean ± std per step
    bin), so labelled.  Returns the y label."""
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from pyflyt_engine.telemetry import read_metrics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        metrics = read_metrics(run)
    evals = metrics.get("/eval", [])
    if evals:
        steps = np.array([r["step"] for r in evals], dtype=float)
        mean = np.array([r["mean_return"] for r in evals], dtype=float)
        std = np.array([r["std_return"] for r in evals], dtype=float)
        label = "evaluation return"
    else:  # no evaluations: the training episodes, binned by the step they ended at
        episodes = metrics.get("/train/episode", [])
        at = np.array([r["step"] for r in episodes], dtype=float)
        returns = np.array([r["return"] for r in episodes], dtype=float)
        edges = np.linspace(0.0, at.max(), bins + 1) if len(at) else np.zeros(1)
        which = np.clip(np.searchsorted(edges, at, side="right") - 1, 0, max(len(edges) - 2, 0))
        kept = [b for b in range(len(edges) - 1) if np.any(which == b)]
        steps = np.array([(edges[b] + edges[b + 1]) / 2 for b in kept])
        mean = np.array([returns[which == b].mean() for b in kept])
        std = np.array([returns[which == b].std() for b in kept])
        label = "training episode return"
    fig, ax = plt.subplots(figsize=(5, 3.2))
    ax.plot(steps, mean, marker="o", markersize=3 if not evals else 6)
    ax.fill_between(steps, mean - std, mean + std, alpha=0.25)
    from matplotlib.ticker import EngFormatter

    ax.xaxis.set_major_formatter(EngFormatter(sep=""))  # 200k, 1.5M: no run-together digits
    ax.set_xlabel("environment steps")
    ax.set_ylabel(label)
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return label


def _train_command(cfg: Any, record: dict[str, Any]) -> str | None:
    """The ``pyflyt train`` command that trains this run with the package's ``conf/`` as it is:
    its overrides, the env, algorithm and seed when they did not come from them, and every
    setting that still differs (a run started from Python, e.g. by an experiment script,
    records only its extra overrides).  None if no such command composes the run's settings
    exactly (checked by the configuration digest)."""
    overrides = list(record.get("overrides") or [])
    given = {o.split("=", 1)[0].lstrip("+~") for o in overrides}
    implied = []
    if "experiment" not in given:
        implied += [f"{k}={v}" for k, v in (("env", cfg.env_name), ("algo", cfg.algo.name)) if k not in given]
    if "seed" not in given:
        implied.append(f"seed={cfg.seed}")
    words = _reproducing(cfg, [*implied, *overrides])
    return None if words is None else " ".join(["pyflyt train", *words])


def _reproducing(cfg: Any, words: list[str]) -> list[str] | None:
    """``words`` plus the overrides that make ``pyflyt train <words>`` compose ``cfg``'s settings, or None."""
    from pyflyt_cli.compose import override_value
    from pyflyt_cli.training.compose import COMMAND_KEYS, compose_config
    from pyflyt_cli.training.rundir import LATER_KEYS, identity
    from pyflyt_engine.errors import PyFlytError

    target = identity(cfg)
    # run_dir= says where, not what: kept in the command, left out of the composition
    settings = [w for w in words if w.split("=", 1)[0].lstrip("+~") not in COMMAND_KEYS]
    try:
        composed = identity(compose_config(overrides=settings))
        extra = []
        for key in sorted(set(target) | set(composed)):
            if key in composed and target.get(key) == composed[key]:
                continue
            if key not in target:
                if key in LATER_KEYS:  # left out of the run's identity at its earlier value: set it back
                    extra.append(f"{key}={override_value(LATER_KEYS[key])}")
                    continue
                return None  # a setting the run did not have: an override cannot remove it
            extra.append(f"{'' if key in composed else '+'}{key}={override_value(target[key])}")
        return [*words, *extra] if identity(compose_config(overrides=[*settings, *extra])) == target else None
    except PyFlytError:
        return None
