"""UAV components: frozen parameter dataclasses plus pure update functions.

Each module holds one component model: its parameters (units and frames documented on
the fields), its state, and pure functions ``(params, state, command, dt, noise) ->
(new state, loads in body frame)`` that never touch PyBullet.  The vehicle adapter
(:mod:`pyflyt_engine.vehicle`) is the only place that applies loads to the physics
engine; the one other PyBullet call in this package is the camera's renderer,
:func:`pyflyt_engine.components.camera.capture`, kept beside the camera maths.
"""
