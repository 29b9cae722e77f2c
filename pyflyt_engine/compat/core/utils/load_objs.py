"""``loadOBJ``, ``obj_visual``, ``obj_collision``: put a Wavefront OBJ mesh into an Aviary's world.

Signatures and defaults are those of PyFlyt 0.29.0 ``core.utils.load_objs``; the bodies use
PyBullet's mesh shapes (``GEOM_MESH``).  ``env`` is a compat
:class:`~pyflyt_engine.compat.core.Aviary` (any object with the PyBullet functions as
methods works for the two shape helpers).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["loadOBJ", "obj_collision", "obj_visual"]

_UNIT = (1.0, 1.0, 1.0)
_ORIGIN = (0.0, 0.0, 0.0)


def obj_visual(env: Any, fileName: str, meshScale: Sequence[float] | np.ndarray = _UNIT) -> int:  # noqa: N803
    """A visual shape from the mesh file, white, without specular highlights; its id."""
    return int(
        env.createVisualShape(
            shapeType=env.GEOM_MESH,
            fileName=fileName,
            rgbaColor=[1.0, 1.0, 1.0, 1.0],
            specularColor=[0.0, 0.0, 0.0],
            meshScale=list(meshScale),
        )
    )


def obj_collision(
    env: Any,
    fileName: str,  # noqa: N803
    meshScale: Sequence[float] | np.ndarray = _UNIT,  # noqa: N803
    concave: bool = False,
) -> int:
    """A collision shape from the mesh file; its id.  ``concave``: a concave triangle mesh
    (static bodies only, as PyBullet requires)."""
    extra = {"flags": env.GEOM_FORCE_CONCAVE_TRIMESH} if concave else {}
    return int(env.createCollisionShape(shapeType=env.GEOM_MESH, fileName=fileName, meshScale=list(meshScale), **extra))


def loadOBJ(  # noqa: N802 - the reference's name
    env: Any,
    fileName: str = "null",  # noqa: N803
    visualId: int = -1,  # noqa: N803
    collisionId: int = -1,  # noqa: N803
    baseMass: float = 0.0,  # noqa: N803
    meshScale: Sequence[float] | np.ndarray = _UNIT,  # noqa: N803
    basePosition: Sequence[float] | np.ndarray = _ORIGIN,  # noqa: N803
    baseOrientation: Sequence[float] | np.ndarray = _ORIGIN,  # noqa: N803
) -> int:
    """A body from the mesh file (or given shape ids), registered for collisions; its id.

    ``visualId`` -1: one is made from ``fileName``; ``collisionId`` -1: no collision
    shape (as in the reference); ``baseOrientation`` Euler angles (3) or a quaternion (4).
    """
    orientation = list(baseOrientation)
    if len(orientation) == 3:
        orientation = list(env.getQuaternionFromEuler(orientation))
    if visualId == -1:
        visualId = obj_visual(env, fileName, meshScale)
    body = env.createMultiBody(
        baseMass=baseMass,
        baseVisualShapeIndex=int(visualId),
        baseCollisionShapeIndex=int(collisionId),
        basePosition=list(basePosition),
        baseOrientation=orientation,
    )
    env.register_all_new_bodies()
    return int(body)
