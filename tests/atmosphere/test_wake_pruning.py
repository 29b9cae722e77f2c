"""The downwash sums only the wakes that can reach a vehicle, and gets the all-pairs sum bit for bit.

Oracles: the all-pairs definition (:meth:`RotorInteractions.downwash_at`, every other
vehicle's term in index order) on random swarms, stacks and vehicles at the edge of the
reach; every left-out term is exactly 0.0 by IEEE underflow; and a whole world stepped
with the pruned sum matches one stepped with the all-pairs sum byte for byte.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from pyflyt_engine.atmosphere.air import Atmosphere
from pyflyt_engine.atmosphere.rotors import (
    JET_DECAY,
    JET_SPREAD,
    WAKE_REACH,
    RotorInteractions,
    downwash_velocity,
)
from pyflyt_engine.spatial import PlanarGrid
from pyflyt_engine.world import VehicleConfig, World

R = 0.0225  # conf/uav/quadx_cf2x.yaml prop_radius
HUBS = [(0.028, -0.028, 0.0), (-0.028, 0.028, 0.0), (0.028, 0.028, 0.0), (-0.028, -0.028, 0.0)]


def _interactions(n: int) -> RotorInteractions:
    rotors = RotorInteractions(ground_effect=False, downwash=True)
    for _ in range(n):
        rotors.add_vehicle(HUBS, [R] * 4, [0.15] * 4)
    return rotors


def _pruned(rotors: RotorInteractions, index: int, positions, throttles) -> float:
    rotors.wakes.clear()
    for j, position in enumerate(positions):
        rotors.place(j, position)
    sources = rotors.sources(index, positions[index])
    return rotors.downwash_near(
        index, positions[index], sources, [positions[j] for j in sources], [throttles[j] for j in sources]
    )


def _bits(x: float) -> bytes:
    return np.float64(x).tobytes()


@pytest.mark.parametrize("layout", ["flat swarm", "stack", "spread in height"])
def test_the_pruned_sum_is_the_all_pairs_sum_bit_for_bit(layout):
    rng = random.Random(layout)
    n = 60
    positions = []
    for i in range(n):
        if layout == "flat swarm":  # a 0.5 m grid at 1 m, a few cm of height noise
            positions.append(((i % 8) * 0.5, (i // 8) * 0.5, 1.0 + rng.uniform(-0.05, 0.05)))
        elif layout == "stack":  # columns of vehicles above each other
            positions.append(
                (rng.choice([0.0, 0.3, 4.0]) + rng.uniform(-0.05, 0.05), rng.uniform(-0.1, 0.1), 0.5 + 0.2 * i)
            )
        else:
            positions.append((rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(0.0, 15.0)))
    throttles = [[rng.uniform(0.0, 1.0) for _ in range(4)] for _ in range(n)]
    rotors = _interactions(n)
    for index in range(n):
        full = rotors.downwash_at(index, positions[index], positions, throttles)
        assert _bits(_pruned(rotors, index, positions, throttles)) == _bits(full)
    # the pruning does prune: in the flat swarm a vehicle sees a bounded neighbourhood
    if layout == "flat swarm":
        seen = [len(rotors.sources(i, positions[i])) for i in range(n)]
        assert max(seen) < n - 1


def test_every_term_left_out_is_exactly_zero():
    """At the reach and beyond, the wake's Gaussian factor underflows to 0.0; just inside it does not."""
    thrust, area = 0.6, 4 * math.pi * R * R
    d = math.sqrt(2 * area / math.pi)
    for dz in (1e-6, 0.1, 1.0, 10.0, 100.0):
        half = JET_SPREAD * (dz + JET_DECAY * d)
        assert downwash_velocity(dz, WAKE_REACH * half, thrust, area) == 0.0
        assert downwash_velocity(dz, 2 * WAKE_REACH * half, thrust, area) == 0.0
        # the reach is no wider than it must be: 3% inside it the term is still a number
        assert downwash_velocity(dz, 0.97 * math.sqrt(745.0 / math.log(2.0)) * half, thrust, area) > 0.0


def test_vehicles_at_the_edge_of_the_reach():
    rotors = _interactions(3)
    d = math.sqrt(2 * 4 * math.pi * R * R / math.pi)
    dz = 0.4
    reach = WAKE_REACH * JET_SPREAD * (dz + JET_DECAY * d)
    throttles = [[0.8] * 4] * 3
    for factor in (0.999, 1.0, 1.001):
        positions = [(0.0, 0.0, 1.0), (factor * reach, 0.0, 1.0 + dz), (0.0, factor * reach, 1.0 + dz)]
        full = rotors.downwash_at(0, positions[0], positions, throttles)
        assert _bits(_pruned(rotors, 0, positions, throttles)) == _bits(full)


def test_the_grid_moves_vehicles_between_cells_and_lists_them_in_order():
    grid = PlanarGrid(1.0)
    grid.place(3, (0.5, 0.5, 1.0))
    grid.place(1, (0.6, 0.2, 2.0))
    grid.place(2, (5.5, 0.5, 1.0))
    assert grid.near(0.0, 0.0, 0.5) == [1, 3]
    assert grid.near(0.0, 0.0, 6.0) == [1, 2, 3]
    grid.place(3, (5.2, 0.1, 1.0))  # moved into vehicle 2's cell
    assert grid.near(0.0, 0.0, 0.5) == [1]
    assert grid.near(5.0, 0.0, 0.5) == [2, 3]
    assert grid.top == 2.0
    assert len(grid.cells) == 2
    with pytest.raises(ValueError, match="cell"):
        PlanarGrid(0.0)


def _all_pairs_wind_at(self, index, position):
    """The downwash as it was defined before pruning: every vehicle's term, in index order."""
    sample = self._probes[index](position) if self._field is not None else None
    throttles = [v.actuators.motors.throttle for v in self.vehicles]
    w = self.rotors.downwash_at(index, position, [v.position for v in self.vehicles], throttles)
    if sample is None:
        return (0.0, 0.0, w, 0.0, 0.0, 0.0)
    wx, wy, wz, p, q, r = sample
    return (wx, wy, wz + w, p, q, r)


def _fly_swarm(steps: int = 20) -> bytes:
    # two layers of a 4 x 4 grid, the upper one offset, climbing and sliding: wakes reach the
    # layer below and vehicles change cells during the flight
    configs, setpoints = [], []
    for layer, z in enumerate((1.0, 1.6)):
        for i in range(16):
            x, y = (i % 4) * 0.4 + 0.2 * layer, (i // 4) * 0.4
            configs.append(VehicleConfig("quadx_cf2x", (x, y, z), mode="position_yaw"))
            setpoints.append([x + 1.5, y - 1.0, 0.0, z + 0.5 * layer])
    world = World(configs, seed=3, downwash=True, wind="dryden_light")
    world.set_all_setpoints(setpoints)
    rows = []
    for _ in range(steps):
        world.step()
        rows.append([world.state(i).as_array() for i in range(len(configs))])
        rows.append([world.wind_at(i) for i in range(len(configs))])
    world.reset(seed=4)
    world.set_all_setpoints(setpoints)
    for _ in range(3):
        world.step()
        rows.append([world.state(i).as_array() for i in range(len(configs))])
    world.close()
    return b"".join(np.asarray(r, dtype=np.float64).tobytes() for r in rows)


@pytest.mark.long
def test_a_swarm_flies_bit_identically_with_the_pruned_and_the_all_pairs_downwash(monkeypatch):
    pruned = _fly_swarm()
    with monkeypatch.context() as m:
        m.setattr(Atmosphere, "wind_at", _all_pairs_wind_at)
        full = _fly_swarm()
    assert pruned == full
