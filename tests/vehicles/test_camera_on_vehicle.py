"""A camera declared in an airframe spec: images through World.capture at the capture rate."""

from __future__ import annotations

import numpy as np

from pyflyt_engine.world import VehicleConfig, World
from tests.conftest import spec_variant


def test_world_capture_returns_the_configured_images_at_the_capture_rate():
    camera = {"name": "front", "width": 32, "height": 24, "capture_hz": 10.0, "outputs": ["rgba", "depth"], "far": 20.0}
    spec = spec_variant("quadx_cf2x", cameras=[camera])
    with World([VehicleConfig(spec, (0.0, 0.0, 1.0))], seed=0) as world:
        first = world.capture(0)
        assert set(first) == {"rgba", "depth"}
        assert first["rgba"].shape == (24, 32, 4) and first["rgba"].dtype == np.uint8
        assert first["depth"].shape == (24, 32, 1) and first["depth"].dtype == np.float32
        # looking level from 1 m: the lower half of the image sees the ground, nearer than far
        assert first["depth"][-1, :, 0].max() < 20.0 * 0.99

        # 10 Hz: two agent steps (1/15 s) later the cached image is returned ...
        world.step()
        world.step()
        assert world.capture(0) is first
        # ... and at 1/10 s after the first capture a new one is rendered
        world.step()
        second = world.capture(0)
        assert second is not first
        assert second["rgba"].shape == (24, 32, 4)
