"""pyflyt_cli: the learning library on the simulator, and the ``pyflyt`` command line on both.

* the learning library (``pip install 'pyflyt-toolkit[rl]'``), none of which imports the
  command line or Typer: ``training/`` (train, resume, evaluate, tune), ``benchmark/``
  (plan and run a grid of runs), ``plotting/`` (rliable reports), ``zoo/`` (the shipped
  agents), ``airframes/`` (validate, describe, draw airframe files), ``speed/`` (measure
  this package), ``catalog.py`` (the registered envs and flight modes), ``outputs.py``
  (checked, atomic output files), ``compose.py`` (``conf/`` composed with Hydra
  overrides) and ``errors.py`` (:class:`~pyflyt_cli.errors.UsageError`, what it raises).
* the command line (``pip install 'pyflyt-toolkit[cli]'``): ``main.py`` (the Typer app)
  and ``commands/`` -- each command parses its arguments, calls one library function
  and prints.
"""

# The engine first: its import pins the numeric kernels before NumPy or PyTorch load
# (pyflyt_engine/numerics.py).
import pyflyt_engine  # noqa: E402,F401
