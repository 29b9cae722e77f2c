"""Success measures: what a task says about an episode beyond its return.

A task declares its measures (:attr:`Task.measures <pyflyt_engine.envs.tasks.base.Task.measures>`,
a tuple of :class:`Measure`) and computes their values for the episode so far
(:meth:`Task.episode_measures <pyflyt_engine.envs.tasks.base.Task.episode_measures>`).  The
environment puts those values into the info of the step that ends the episode, as
``info["measures"]`` (a flat ``{key: float}``), and the episode recorder writes them into
the recording's end record; ``pyflyt eval``, the training evaluation lines and the end-of-run
summary print them beside the return (:func:`summarize_measures`, :func:`describe`), and
``eval.json`` keeps them per episode and combined.

A multi-agent task declares per-agent measures the same way; the shared-policy env reports
each agent's values as ``<agent>/<key>``, their mean over the agents as ``<key>`` and the
fraction of agents whose own episode succeeded as ``agents_succeeded``
(:func:`multi_agent_measures`).

Values are floats; a value that does not apply to an episode (a touchdown speed without a
touchdown) is NaN and left out when the episodes are combined.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

#: the info key the episode's measures are reported under (on the step that ends it)
INFO_KEY = "measures"


@dataclass(frozen=True)
class Measure:
    """One success measure of a task.

    Attributes:
        key: the name of the value in ``info["measures"]`` and ``eval.json``.
        label: what the printed report calls it ("distance to the hover point, mean").
        unit: the unit printed after the value ("m", "m/s"; "" for a count).
        combine: how the episodes' values combine into the evaluation's figure: ``mean``
            (NaN values left out) or ``max``.
        percent: the value is a fraction, printed in percent.
        rate: (a ``percent`` measure) each episode's value is 0 or 1, so the figure is the
            share of episodes (printed per episode as yes/no); False for a share within an
            episode (the agents that succeeded).
        digits: decimals printed.
    """

    key: str
    label: str
    unit: str = ""
    combine: Literal["mean", "max"] = "mean"
    percent: bool = False
    rate: bool = True
    digits: int = 2

    def over(self, values: Iterable[float]) -> float:
        """The episodes' ``values`` combined (NaN when none applies)."""
        kept = [float(v) for v in values if v is not None and not math.isnan(float(v))]
        if not kept:
            return math.nan
        return max(kept) if self.combine == "max" else math.fsum(kept) / len(kept)

    def format(self, value: float) -> str:
        """``value`` as printed: ``3.3 cm`` style, with its unit, or ``n/a``."""
        if value is None or math.isnan(value):
            return "n/a"
        if self.percent:
            return f"{100 * value:.0f} %"
        return f"{value:.{self.digits}f}" + (f" {self.unit}" if self.unit else "")


class DistanceHeld:
    """The mean and the largest of a distance over an episode's agent steps (the step at
    the reset not counted: the spawn is not the policy's doing)."""

    __slots__ = ("_count", "_max", "_sum")

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._sum = 0.0
        self._count = 0
        self._max = math.nan

    def add(self, distance: float) -> None:
        self._sum += distance
        self._count += 1
        self._max = distance if self._count == 1 else max(self._max, distance)

    def values(self, prefix: str = "distance") -> dict[str, float]:
        """``{<prefix>_mean, <prefix>_max}`` [m] (NaN before the first step)."""
        mean = self._sum / self._count if self._count else math.nan
        return {f"{prefix}_mean": mean, f"{prefix}_max": self._max}


#: the measures of a task that holds a point (hover, pole balance, multi-agent hover)
DISTANCE_HELD = (
    Measure("distance_mean", "distance held, episode mean", "m", "mean", digits=3),
    Measure("distance_max", "distance held, episode max", "m", "max", digits=3),
)

#: the share of agents whose own episode succeeded (every multi-agent env)
AGENTS_SUCCEEDED = Measure("agents_succeeded", "agents that succeeded", percent=True, rate=False)


def multi_agent_measures(per_agent: Sequence[Measure]) -> tuple[Measure, ...]:
    """What a multi-agent env reports per episode: the agents' success share, then the
    task's per-agent measures (their mean over the agents; per agent as ``<agent>/<key>``)."""
    return (AGENTS_SUCCEEDED, *per_agent)


def summarize_measures(measures: Sequence[Measure], episodes: Sequence[Mapping[str, float]]) -> dict[str, float]:
    """Every declared measure's figure over ``episodes`` (each one's ``info["measures"]``),
    plus, for per-agent values (``<agent>/<key>``), each agent's figure under the same name.
    Episodes without a value are left out of that measure's figure."""
    out: dict[str, float] = {}
    by_key = {m.key: m for m in measures}
    keys: list[str] = [m.key for m in measures]
    for episode in episodes:
        for key in episode:
            if "/" in key and key not in keys and key.rpartition("/")[2] in by_key:
                keys.append(key)
    for key in keys:
        measure = by_key[key.rpartition("/")[2]]
        out[key] = measure.over(e[key] for e in episodes if key in e)
    return out


def describe(measures: Sequence[Measure], summary: Mapping[str, float], width: int = 12) -> list[str]:
    """The printed lines of ``summary`` (:func:`summarize_measures`): one per measure, and
    one per agent for a multi-agent env's per-agent figures; labels padded to ``width``
    (or the longest label)."""
    lines = []
    width = max([width, *(len(m.label) for m in measures if m.key in summary)])
    for m in measures:
        if m.key in summary:
            over = (
                "of episodes"
                if m.percent and m.rate
                else "max over episodes"
                if m.combine == "max"
                else "mean over episodes"
            )
            lines.append(f"{m.label:<{width}}  {m.format(summary[m.key])}  ({over})")
        agents = [k for k in summary if k.endswith("/" + m.key)]
        if agents:
            lines.append("  per agent: " + ", ".join(f"{k.rpartition('/')[0]} {m.format(summary[k])}" for k in agents))
    return lines


def brief(measures: Sequence[Measure], summary: Mapping[str, float]) -> str:
    """The measures of ``summary`` on one line (``key value, ...``), for log lines; per-agent
    figures left out."""
    return ", ".join(f"{m.key} {m.format(summary[m.key])}" for m in measures if m.key in summary)


def plain(values: Mapping[str, Any]) -> dict[str, float | None]:
    """``values`` as JSON numbers (NaN as null)."""
    return {str(k): (None if v is None or math.isnan(float(v)) else float(v)) for k, v in values.items()}
