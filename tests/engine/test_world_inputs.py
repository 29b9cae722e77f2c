"""World arguments: non-finite loop rates, gravity and spawn poses fail at construction."""

from __future__ import annotations

import pytest

from pyflyt_engine.errors import ConfigError
from pyflyt_engine.world import VehicleConfig, World

NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"gravity": NAN}, "gravity must be a finite acceleration"),
        ({"gravity": -INF}, "gravity must be a finite acceleration"),
        ({"physics_hz": INF}, "physics_hz must be a finite number > 0 Hz, got inf"),
        ({"agent_hz": NAN}, "agent_hz must be a finite number > 0 Hz, got nan"),
        (
            {"vehicles": [VehicleConfig(position=(NAN, 0.0, 1.0))]},
            r"spawn position must be 3 finite numbers \[m\], got \[nan",
        ),
        ({"vehicles": [{"orientation": (0.0, INF, 0.0)}]}, "spawn orientation must be 3 finite numbers"),
        ({"vehicles": [{"position": (0.0, 1.0)}]}, "spawn position must be 3 finite numbers"),
        ({"vehicles": [{"position": ("a", 0, 0)}]}, "spawn position must be 3 numbers"),
    ],
)
def test_bad_world_arguments_are_refused(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        World(**kwargs)


def test_add_vehicle_refuses_a_non_finite_pose():
    with World(ground=False) as world:
        with pytest.raises(ConfigError, match="spawn position"):
            world.add_vehicle("quadx_cf2x", (0.0, 0.0, INF))
        assert world.vehicles == []
        world.add_vehicle("quadx_cf2x", (0.0, 0.0, 1.0))
        assert world.state(0).lin_pos == pytest.approx((0.0, 0.0, 1.0))
