"""Airframe (UAV YAML) tools behind ``pyflyt uav validate | show | schema``, usable from Python.

* :func:`validate_uav` -- load, validate and build a shipped name or a YAML file
  offline; its one-line summary and warnings (:mod:`.check`).
* :func:`describe`, :func:`mass_report`, :func:`thrust_to_weight` -- the numbers
  ``pyflyt uav show`` prints (:mod:`.describe`); :func:`describe_payloads`,
  :func:`carried_mass` -- an env's payloads, as ``pyflyt uav show --env`` prints them.
* :func:`render_airframe`, :func:`plot_surface_curves` -- a 3/4-view picture and the
  lifting surfaces' coefficient curves (:mod:`.pictures`).
* :func:`schema_markdown` -- the field reference of the YAML schema (:mod:`.schema`).

Nothing here writes over its input: output images must be new files or existing PNGs
(the command checks them first, :func:`~pyflyt_cli.outputs.check_output`).
"""

from pyflyt_cli.airframes.check import Validated, resolve_file, validate_uav
from pyflyt_cli.airframes.describe import (
    MassReport,
    carried_mass,
    describe,
    describe_payloads,
    mass_report,
    thrust_to_weight,
)
from pyflyt_cli.airframes.pictures import drawable_payloads, plot_surface_curves, render_airframe
from pyflyt_cli.airframes.schema import schema_markdown

__all__ = [
    "MassReport",
    "Validated",
    "carried_mass",
    "describe",
    "describe_payloads",
    "drawable_payloads",
    "mass_report",
    "plot_surface_curves",
    "render_airframe",
    "resolve_file",
    "schema_markdown",
    "thrust_to_weight",
    "validate_uav",
]
