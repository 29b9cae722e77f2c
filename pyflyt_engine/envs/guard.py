"""Never NaN: the guard on every observation and reward, and the report when it trips."""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from pyflyt_engine.errors import SimulationError
from pyflyt_engine.state import KinematicState


@functools.lru_cache(maxsize=16)
def _zeros(size: int) -> np.ndarray:
    zeros = np.zeros(size)
    zeros.flags.writeable = False
    return zeros


def all_finite(reward: float, observation: Any) -> bool:
    """Whether ``reward`` and every number in ``observation`` (an array or a mapping of arrays) are finite.

    One dot product with zeros per array: it is 0 unless an entry is NaN or infinite
    (0 * inf is NaN), so a finite observation can never be mistaken for a bad one.
    """
    if isinstance(observation, np.ndarray) and observation.ndim == 1:  # a flat Box: the common case
        return math.isfinite(reward + observation.dot(_zeros(observation.shape[0])))
    total = reward
    mapping = type(observation) is dict or isinstance(observation, Mapping)
    for value in observation.values() if mapping else (observation,):
        if type(value) is np.ndarray and value.dtype.kind in "biu":  # integers (images) are always finite
            continue
        flat = np.asarray(value, dtype=np.float64).ravel()  # np.ravel's own method, without its wrapper
        total += flat.dot(_zeros(flat.size))
    return math.isfinite(total)


def _rounded(values: Any) -> list[float]:
    return [round(float(v), 4) for v in values]


def divergence_error(
    where: str,
    step: int,
    observation: Any,
    reward: float,
    state: KinematicState,
    vehicle: Any,
    action: Any,
    agent: str | None = None,
) -> SimulationError:
    """The :class:`SimulationError` describing a non-finite observation or reward at ``step``:
    which entries, the vehicle's state and the last action (and the agent, when several fly)."""
    parts = observation.items() if isinstance(observation, Mapping) else [("observation", observation)]
    bad = [
        f"{name}[{', '.join(map(str, np.flatnonzero(~np.isfinite(np.asarray(value, dtype=np.float64)))))}]"
        for name, value in parts
        if not np.isfinite(np.asarray(value, dtype=np.float64)).all()
    ]
    if not math.isfinite(reward):
        bad.append(f"reward ({reward})")
    who = f"Agent '{agent}', vehicle" if agent is not None else "Vehicle"
    return SimulationError(
        f"{where}: the simulation diverged at step {step} of the episode: not finite: {', '.join(bad)}. "
        f"{who} '{vehicle.spec.name}': position {_rounded(state.lin_pos)} m, attitude "
        f"{_rounded(state.ang_pos)} rad, body velocity {_rounded(state.lin_vel)} m/s, body rates "
        f"{_rounded(state.ang_vel)} rad/s, aux {_rounded(vehicle.aux_state)}; last action "
        f"{_rounded(action)}. Check the airframe's parameters (mass, inertia, motor, drag and surface "
        "coefficients) and anything that moved the vehicle from outside the environment"
    )
