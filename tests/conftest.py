"""Shared fixtures: small worlds and spec variants built from the shipped airframes; hostile input."""

from __future__ import annotations

import copy

import pytest
import yaml

from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import UAVSpec, parse_uav_spec


def billion_laughs(levels: int = 9, key: str = "a") -> str:
    """A few hundred bytes of YAML whose aliases expand to 10**levels values (``<key><levels-1>`` holds them all)."""
    lines = [f"{key}0: &{key}0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for i in range(1, levels):
        lines.append(f"{key}{i}: &{key}{i} [" + ", ".join([f"*{key}{i - 1}"] * 10) + "]")
    return "\n".join(lines) + "\n"


def spec_dict(name: str = "quadx_cf2x") -> dict:
    """The raw YAML mapping of a shipped airframe (a fresh copy)."""
    return copy.deepcopy(yaml.safe_load((uav_dir() / f"{name}.yaml").read_text()))


def spec_variant(name: str = "quadx_cf2x", **changes: object) -> UAVSpec:
    """A shipped airframe with dotted-path changes, e.g. ``**{"motors.noise_ratio": 0.0}``."""
    data = spec_dict(name)
    for path, value in changes.items():
        node = data
        *parents, leaf = path.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value
    return parse_uav_spec(data, source=f"{name} (test variant)")


@pytest.fixture
def quiet_cf2x() -> UAVSpec:
    """The cf2x with motor noise and drag removed: for analytic oracles."""
    return spec_variant(
        "quadx_cf2x",
        **{"motors.noise_ratio": 0.0, "drag.coefficients": [0.0, 0.0, 0.0], "drag.angular_damping": 0.0},
    )
