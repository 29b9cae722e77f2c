"""What a ``pyflyt speed`` command line asks for: its options as :class:`SpeedSettings`, every count
checked (the limits table, ``pyflyt_engine/limits.py``) before anything is measured."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pyflyt_cli.errors import UsageError
from pyflyt_cli.speed.measure import SpeedSettings


def speed_settings(
    repeats: int = 5,
    quick: bool = False,
    vector: bool = False,
    envs: Sequence[str] | None = None,
    vehicles: str | None = None,
    agents: str | None = None,
    backend: str = "pybullet",
    batch_sizes: str | None = None,
) -> SpeedSettings:
    """The settings ``pyflyt speed`` measures with (``vehicles``, ``agents``, ``batch_sizes``: comma-separated counts)."""
    if backend not in ("pybullet", "batched"):
        raise UsageError(f"--backend takes pybullet or batched, got {backend!r}")
    _bounded("speed.repeats", repeats, "--repeats")
    overrides: dict[str, Any] = {"vector": vector, "backend": backend}
    if batch_sizes is not None:
        if backend != "batched":
            raise UsageError("--batch-sizes goes with --backend batched")
        overrides["batch_sizes"] = parse_counts(batch_sizes, "--batch-sizes")
    if envs:
        overrides["envs"] = tuple(envs)
    if vehicles:
        overrides["vehicles"] = parse_counts(vehicles)
    if agents is not None:
        overrides["swarm"] = () if agents.strip() in ("", "0", "none") else parse_counts(agents, "--agents")
    return SpeedSettings.quick(**overrides) if quick else SpeedSettings(repeats=repeats, **overrides)


def parse_counts(text: str, option: str = "--vehicles") -> tuple[int, ...]:
    """``--vehicles 1,8,64`` as world sizes (``--agents 1,2,4``: swarm sizes, at most 128)."""
    try:
        counts = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        counts = ()
    if option == "--agents":
        from pyflyt_engine.envs.config import MAX_AGENTS

        if not counts or min(counts) < 1 or max(counts) > MAX_AGENTS:
            raise UsageError(
                f"--agents takes swarm sizes, comma-separated integers 1 to {MAX_AGENTS} (e.g. 1,2,4,8), or 0 to "
                f"skip the swarm section; got {text!r}"
            )
        return counts
    if option == "--batch-sizes":
        if not counts or min(counts) < 1:
            raise UsageError(
                f"--batch-sizes takes env counts, comma-separated positive integers (e.g. 1,256,4096), got {text!r}"
            )
        _bounded("train.n_envs", max(counts), "--batch-sizes")
        return counts
    if not counts or min(counts) < 1:
        raise UsageError(f"--vehicles takes world sizes, comma-separated positive integers (e.g. 1,8,64), got {text!r}")
    _bounded("speed.vehicles", max(counts), "--vehicles")
    return counts


def _bounded(key: str, value: int, option: str) -> None:
    """A count above its limit (pyflyt_engine/limits.py) refused as a usage error naming the option."""
    from pyflyt_engine import limits

    why = limits.problem(key, value, name=option)
    if why is not None:
        raise UsageError(why)
