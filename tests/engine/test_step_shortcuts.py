"""Shortcuts on the stepping path give what the longer way gave: one contact pair without
the contact matrix, and the groups' wrenches summed in order without a list."""

from __future__ import annotations

import math

from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.vehicle import _summed
from pyflyt_engine.world import VehicleConfig, World


def test_bodies_touched_is_the_contact_matrix_entry(quiet_cf2x):
    world = World([VehicleConfig(quiet_cf2x, (0.0, 0.0, 0.3), mode="motors")], seed=0)
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=(0.5, 0.5, 0.05), physicsClientId=world.client)
    pad = p.createMultiBody(0.0, shape, basePosition=(3.0, 0.0, 0.05), physicsClientId=world.client)
    world.add_body(pad)
    world.set_armed(0, False)
    vehicle, ground = world.vehicles[0].body_id, world.ground_id
    seen = []
    for _ in range(15):  # falls 0.3 m onto the ground; the pad, 3 m away, is never touched
        world.step()
        matrix, rows = world.contact_array, world.contact_bodies
        for a, b in ((vehicle, ground), (vehicle, pad), (pad, ground), (ground, vehicle)):
            assert world.bodies_touched(a, b) == bool(matrix[rows.index(a), rows.index(b)])
        seen.append((world.bodies_touched(vehicle, ground), world.bodies_touched(vehicle, pad)))
    assert not seen[0][0] and seen[-1][0]  # in the air at first, resting on the ground at the end
    assert not any(on_pad for _, on_pad in seen)
    world.close()


def test_summed_adds_in_order_and_keeps_the_first_wrench_as_it_is():
    first = (-0.0, 1.0, 2.0, -0.0, 0.5, 1e-300)
    assert _summed(None, first) is first  # not 0.0 + (-0.0), which would be +0.0
    assert math.copysign(1.0, _summed(None, first)[0]) == -1.0
    total = _summed(_summed(None, first), (1.0, 2.0, 3.0, 4.0, 5.0, 6.0))
    assert total == (-0.0 + 1.0, 1.0 + 2.0, 2.0 + 3.0, -0.0 + 4.0, 0.5 + 5.0, 1e-300 + 6.0)
