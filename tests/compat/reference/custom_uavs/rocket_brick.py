"""A stand-in for the reference's ``custom_uavs/rocket_brick.py`` example module.

The reference's ``tests/test_core.py`` imports ``RocketBrick``, a Python drone class, from
its examples; the one test that flies it is deselected here (conftest.py), because Python
drone classes are refused by :mod:`pyflyt_engine.compat` by design: an airframe is a YAML
file (docs/uav_authoring.md, docs/migrating_from_pyflyt.md).  This module only lets the
test file import; building the class raises the refusal, as
``tests/compat/test_core_compat.py`` checks.
"""

from pyflyt_engine.compat.core.abstractions import DroneClass


class RocketBrick(DroneClass):
    """A Python drone class: importable, refused when built."""
