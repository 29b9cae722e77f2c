"""Check an airframe: load it, validate it and build it offline (``pyflyt uav validate``).

:func:`validate_uav` loads a spec (a shipped name or a path) and builds it in a throwaway
headless :class:`~pyflyt_engine.world.World`, so that errors which only show at build
time (component parameters the schema does not check, such as a booster's min_thrust
above its max_thrust; a user URDF or mesh PyBullet cannot load) are caught too.  It
also says what is valid but probably not meant (a multirotor that cannot hover).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pyflyt_cli.airframes.describe import thrust_to_weight
from pyflyt_cli.errors import UsageError
from pyflyt_engine.errors import PyFlytError, SpecError
from pyflyt_engine.spec import UAVSpec, load_uav_spec, resolve_uav_path


@dataclass(frozen=True)
class Validated:
    """A valid airframe.

    Attributes:
        path: the YAML file it was read from.
        spec: the validated spec.
        summary: ``0.027 kg, 4 motors, multirotor control, T/W 8.00`` (:func:`one_line_summary`).
        warnings: what is valid but probably not meant (:func:`validation_warnings`).
    """

    path: Path
    spec: UAVSpec
    summary: str
    warnings: list[str] = field(default_factory=list)


def validate_uav(name_or_path: str) -> Validated:
    """Load, validate and build one airframe (a shipped name or a YAML path).

    Raises:
        PyFlytError: with a message naming the file, the field and the fix.
    """
    path = resolve_file(name_or_path)
    spec = load_uav_spec(path)
    build_offline(spec)
    return Validated(path, spec, one_line_summary(spec), validation_warnings(spec))


def resolve_file(name_or_path: str) -> Path:
    """A shipped airframe name or a path to a YAML file, as an existing file path.

    Raises:
        SpecError: no such file or airframe, or the path is a directory.
    """
    candidate = Path(name_or_path)
    if candidate.is_dir():
        raise SpecError(f"{candidate}: is a directory; give the YAML files in it, e.g. {candidate / '*.yaml'}")
    path = resolve_uav_path(name_or_path)
    if path.stat().st_size == 0:
        raise SpecError(
            f"{path}: the file is empty; a UAV spec is a mapping with at least 'name' and 'body' "
            "(see docs/uav_authoring.md)"
        )
    return path


def build_offline(spec: UAVSpec) -> None:
    """Build ``spec`` in a throwaway headless world (no ground, no rendering).

    Raises:
        PyFlytError: the vehicle cannot be built; the message starts with the file.
    """
    from pyflyt_engine.bullet import pybullet as p
    from pyflyt_engine.world import World

    where = spec.source or spec.name
    with World(ground=False) as world:
        try:
            world.add_vehicle(spec)
        except SpecError:
            raise
        except (PyFlytError, ValueError, p.error) as exc:  # components check their parameters with ValueError
            raise UsageError(f"{where}: cannot build the vehicle: {exc}") from None


def one_line_summary(spec: UAVSpec) -> str:
    """``0.027 kg, 4 motors, multirotor control, T/W 8.00`` style summary."""
    parts = [f"{spec.total_mass():.4g} kg"]
    for count, noun in (
        (len(spec.motors.positions) if spec.motors else 0, "motor"),
        (len(spec.surfaces), "surface"),
        (len(spec.boosters.positions) if spec.boosters else 0, "booster"),
        (len(spec.gimbals), "gimbal"),
        (len(spec.cameras), "camera"),
    ):
        if count:
            parts.append(f"{count} {noun}{'s' if count > 1 else ''}")
    parts.append("no controller" if spec.control.type == "none" else f"{spec.control.type} control")
    ratios = thrust_to_weight(spec)
    shown = next((key for key in ("mixer motors", "all motors", "boosters") if key in ratios), None)
    if shown is not None:
        parts.append(f"T/W {ratios[shown]:.2f}")
    return ", ".join(parts)


def validation_warnings(spec: UAVSpec) -> list[str]:
    """Things that are valid but probably not meant (a multirotor that cannot hover)."""
    found = []
    lift = thrust_to_weight(spec).get("mixer motors")
    if lift is not None and lift <= 1.0:
        found.append(f"the multirotor motors lift only {lift:.2f} x the weight: it cannot hover")
    return found
