"""pyflyt_cli: the ``pyflyt`` command line and the libraries it calls.

* ``main.py`` (the Typer app) and ``commands/`` -- each command parses its arguments,
  calls one library function and prints; ``config.py`` composes ``conf/`` with Hydra.
* libraries, none of which imports Typer: ``training/`` (train, resume, evaluate),
  ``benchmark/`` (plan and run a grid of runs), ``plotting/`` (rliable reports),
  ``airframes/`` (validate, describe, draw airframe files), ``speed/`` (measure this
  package), ``catalog.py`` (the registered envs and flight modes), ``outputs.py``
  (checked, atomic output files).
"""

# The engine first: its import pins the numeric kernels before NumPy or PyTorch load
# (pyflyt_engine/numerics.py).
import pyflyt_engine  # noqa: E402,F401
