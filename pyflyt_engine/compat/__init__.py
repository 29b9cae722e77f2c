"""Drop-in compatibility with the reference PyFlyt package (0.29.0).

Code written for the reference runs here after one change of import prefix::

    import PyFlyt.gym_envs                     ->  import pyflyt_engine.compat.gym_envs
    from PyFlyt.pz_envs import ...             ->  from pyflyt_engine.compat.pz_envs import ...
    from PyFlyt.core import Aviary             ->  from pyflyt_engine.compat.core import Aviary

* :mod:`.gym_envs` registers the reference's Gymnasium ids (``PyFlyt/QuadX-Hover-v4``,
  ...) with the reference's constructor arguments, defaults, spaces, info keys, render
  output and episodes (rewards, endings), over worlds built from our env configs, and
  has its base envs for tasks users write;
* :mod:`.pz_envs` has the reference's PettingZoo classes over our multi-agent envs, and
  its multi-agent base envs;
* :mod:`.core` has an ``Aviary`` with the reference's API and state layout over our
  :class:`~pyflyt_engine.world.World`, and its OBJ helpers.

Every module path of the reference's ``core``, ``gym_envs`` and ``pz_envs`` exists here
with its public names.

Nothing here is imported by ``import pyflyt_engine``; the native ``-v0`` ids keep their
own spaces and defaults.  ``docs/migrating_from_pyflyt.md`` lists every difference.
"""
