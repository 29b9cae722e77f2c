"""Many vehicles in one world: each flies as it would alone, collisions among them are seen.

Not timed: these check the invariants the speed work relies on (independent vehicles,
sparse contact bookkeeping), on the same grid ``pyflyt speed`` measures.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_cli.speed.probes import hover_grid as hover_world
from pyflyt_cli.speed.protocols import grid_positions
from pyflyt_engine.world import VehicleConfig, World

SECONDS = 3.0


def fly(world: World, seconds: float = SECONDS) -> np.ndarray:
    """(steps, vehicles, 12) state rows over ``seconds`` of flight."""
    rows = []
    for _ in range(int(seconds * world.agent_hz)):
        world.step()
        rows.append([world.state(i).as_array().ravel() for i in range(len(world.vehicles))])
    return np.array(rows)


def test_grid_positions_are_distinct_and_apart():
    positions = np.array(grid_positions(64))
    assert len({tuple(p) for p in positions}) == 64
    gaps = np.linalg.norm(positions[:, None] - positions[None], axis=-1) + np.eye(64) * 1e9
    assert gaps.min() >= 1.0 - 1e-12
    assert (positions[:, 2] == 1.0).all()


def test_eight_vehicles_each_hover_like_a_single_one():
    single = hover_world(1)
    alone = fly(single)[:, 0]
    single.close()

    world = hover_world(8)
    together = fly(world)
    spawns = np.array(grid_positions(8))
    world.close()

    # vehicle 0 has the same spawn and the same noise stream as the lone vehicle: the
    # other seven bodies change nothing in its flight
    np.testing.assert_allclose(together[:, 0], alone, rtol=0, atol=1e-9)
    # the others (own noise streams) hold their own spawn points just as well
    for i in range(8):
        position_error = np.linalg.norm(together[-30:, i, 9:12] - spawns[i], axis=-1)
        assert position_error.max() < 0.05, f"vehicle {i} drifted {position_error.max():.3f} m"
        assert np.abs(together[:, i, 3:5]).max() < 0.2, f"vehicle {i} tilted"
    lone_error = np.linalg.norm(alone[-30:, 9:12] - spawns[0], axis=-1).max()
    errors = [np.linalg.norm(together[-30:, i, 9:12] - spawns[i], axis=-1).max() for i in range(8)]
    assert max(errors) < 5 * max(lone_error, 0.005)


def test_no_contacts_recorded_while_eight_vehicles_hover_apart():
    world = hover_world(8)
    for _ in range(60):
        world.step()
        assert not any(world.collided(i) for i in range(8))
    assert not world.contact_array.any()
    world.close()


@pytest.mark.parametrize("pair", [(0, 1), (3, 4)])
def test_collision_between_two_of_eight_is_in_the_matrix(pair):
    a, b = pair
    world = hover_world(8)
    positions = grid_positions(8)
    bx, by, bz = positions[b]
    world.set_setpoint(a, [bx, by, 0.0, bz])  # fly a into b, which holds its point
    hit_step = None
    for step in range(120):
        world.step()
        if world.collided_with(a, b):
            hit_step = step
            break
    assert hit_step is not None, f"vehicles {a} and {b} never touched"
    matrix = world.contact_array
    bodies = world.contact_bodies
    ra, rb = bodies.index(world.vehicles[a].body_id), bodies.index(world.vehicles[b].body_id)
    assert matrix[ra, rb] and matrix[rb, ra]
    assert (matrix == matrix.T).all()
    assert world.collided(a) and world.collided(b) and world.collided_with(b, a)
    others = [i for i in range(8) if i not in pair]
    assert not any(world.collided(i) for i in others)
    # the matrix holds exactly the touching pairs the queries report
    touching = {tuple(sorted(ij)) for ij in zip(*np.nonzero(matrix))}
    assert touching <= {(min(ra, rb), max(ra, rb)), (0, ra), (0, rb), (ra, ra), (rb, rb)}
    world.close()


def test_contacts_clear_at_the_next_step_and_at_reset():
    world = World(
        [
            VehicleConfig("quadx_cf2x", (0.0, 0.0, 0.05), mode="motors"),
            VehicleConfig("quadx_cf2x", (3.0, 0.0, 1.0), mode="motors"),
        ],
        seed=0,
    )
    world.set_armed(0, False)
    world.set_armed(1, False)
    for _ in range(10):
        world.step()
    assert world.collided_with_ground(0) and world.contact_array[0].any()
    world.reset()
    assert not world.collided(0) and not world.contact_array.any()
    world.set_armed(0, True)
    world.set_setpoint(0, [1.0] * 4)  # full throttle: leaves the ground
    for _ in range(30):
        world.step()
    assert not world.collided(0)
    world.close()
