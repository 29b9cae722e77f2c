"""UAV components: frozen parameter dataclasses plus pure update functions.

Nothing in this package talks to PyBullet.  Each module holds one component model:
its parameters (units and frames documented on the fields), its state, and pure
functions ``(params, state, command, dt, noise) -> (new state, loads in body frame)``.
The vehicle adapter (:mod:`pyflyt_engine.vehicle`) is the only place that applies the
resulting loads to the physics engine.
"""
