"""How fast the toolkit runs on this machine (``pyflyt speed``).

* :func:`run_speed` -- measure and return the report (JSON data): for every registered
  env, env steps/s, reset time, real-time factor and peak memory, beside the
  bare-PyBullet floor; worlds of 1, 8 and 64 QuadX against the floor for as many bodies;
  a 128 x 128 camera capture; with ``vector=True``, 1 and 2 subprocess workers, a
  stand-in env of the same step cost and the machine's own 1 -> 2 process scaling.
  Every case runs in a fresh process and every figure is the median of ``repeats`` runs.
* :func:`format_report` -- the report as plain-text or Markdown tables.
* :func:`speed_settings` -- the command line's options as settings, every count checked.
* :mod:`.measure` -- the settings, the cases, running them; :mod:`.probes` -- each
  measurement on this package; :mod:`.protocols` -- the timing loops, as functions of
  what they time (standard library only, loadable by path from another interpreter).
"""

from pyflyt_cli.speed.measure import Case, SpeedError, SpeedSettings, plan_cases, run_probe, run_speed
from pyflyt_cli.speed.options import parse_counts, speed_settings
from pyflyt_cli.speed.tables import format_report

__all__ = [
    "Case",
    "SpeedError",
    "SpeedSettings",
    "format_report",
    "parse_counts",
    "plan_cases",
    "run_probe",
    "run_speed",
    "speed_settings",
]
