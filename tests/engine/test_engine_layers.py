"""Inside the engine, imports point one way: down the layers, and never in a circle.

Read from the source (every ``import`` of a ``pyflyt_engine`` module, at the top of a file
or inside a function; imports under ``if TYPE_CHECKING:`` are for annotations only and
do not count), so nothing is imported to check it.

The layers, lowest first (``LAYERS``): the foundations (errors, exact arithmetic,
frames, the allocation matrix ...), the airframe spec, the models built from a spec
(URDF, actuator components, payloads, obstacles), the atmosphere, the controller (or the firmware) and the assembly,
the vehicle, the world, the environments and the flight API, the batched backend, telemetry, and the
compatibility layer for the reference's API.  A module
may import anything in its own layer or a lower one, never a higher one; within a layer
the circle check keeps the direction one way.  So the spec never imports a
component or the controller (the mixer's rank check it repeats at load lives in
``allocation``), and payloads never import telemetry.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.test_layers import cycles

ENGINE = Path(__file__).resolve().parents[2] / "pyflyt_engine"

#: Top-level modules and packages of pyflyt_engine, lowest layer first.
LAYERS: tuple[frozenset[str], ...] = (
    frozenset(
        {
            "errors",
            "exact",
            "constants",
            "numerics",
            "paths",
            "safe_load",
            "limits",
            "frames",
            "state",
            "bullet",
            "allocation",
            "loading",
            "spatial",
            "suggest",
        }
    ),
    frozenset({"spec"}),
    frozenset({"urdf", "components", "payloads", "obstacles"}),
    frozenset({"atmosphere", "assembly", "control", "firmware"}),  # firmware: Betaflight in the controller's place
    frozenset({"vehicle"}),
    frozenset({"world"}),
    frozenset({"envs", "flight"}),
    frozenset({"batched"}),  # the batched backend: the envs' configs, tasks and reward terms, compiled
    frozenset({"telemetry"}),
    frozenset({"compat"}),  # the reference's API, built on everything below
)


def _modules() -> dict[str, Path]:
    out = {}
    for path in ENGINE.rglob("*.py"):
        parts = path.relative_to(ENGINE.parent).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The engine modules ``path`` imports at run time."""
    tree = ast.parse(path.read_text())
    annotation_only = {
        id(node)
        for branch in ast.walk(tree)
        if isinstance(branch, ast.If) and "TYPE_CHECKING" in ast.unparse(branch.test)
        for statement in branch.body
        for node in ast.walk(statement)
    }
    out = set()
    for node in ast.walk(tree):
        if id(node) in annotation_only:
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name in modules}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module in modules:
            # ``from pyflyt_engine import exact`` imports the module pyflyt_engine.exact
            out |= {
                f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module for a in node.names
            }
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(path, modules) - {name} for name, path in modules.items()}


def _part(module: str) -> str:
    """The top-level module or package of pyflyt_engine a module belongs to."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _layer(part: str) -> int:
    for i, layer in enumerate(LAYERS):
        if part in layer:
            return i
    raise AssertionError(f"pyflyt_engine.{part} is in no layer: add it to LAYERS in {Path(__file__).name}")


def test_every_engine_module_has_a_layer():
    for module in _modules():
        if _part(module):
            _layer(_part(module))


def test_imports_point_down_the_layers():
    wrong = []
    for module, targets in sorted(_graph().items()):
        part = _part(module)
        if not part:  # the package itself: imports what it exposes
            continue
        for target in sorted(targets):
            other = _part(target)
            if other and _layer(other) > _layer(part):
                wrong.append(f"{module} imports {target} (layer {_layer(other)} above {_layer(part)})")
    assert not wrong, "imports against the layers:\n" + "\n".join(wrong)


def test_spec_and_payloads_stand_below_components_control_and_telemetry():
    graph = _graph()
    assert not {t for t in graph["pyflyt_engine.spec"] if _part(t) in {"components", "control", "assembly"}}
    payloads = {t for m, ts in graph.items() if _part(m) == "payloads" for t in ts}
    assert not {t for t in payloads if _part(t) == "telemetry"}


def test_no_import_circles():
    circles = cycles(_graph())
    assert not circles, "modules that import each other (directly or round a circle):\n" + "\n".join(
        " <-> ".join(c) for c in circles
    )


def test_env_configs_and_tasks_stand_below_the_multi_agent_envs():
    """Loading a config reaches every task, single- or multi-agent, through ``envs.tasks``:
    the configs, the task registry and the tasks import nothing of ``envs.multi_agent``
    (the PettingZoo fronts, which import them), and the registry imports no task."""
    graph = _graph()
    below = [
        m
        for m in graph
        if m in ("pyflyt_engine.envs.config", "pyflyt_engine.envs.task_registry")
        or m.startswith("pyflyt_engine.envs.tasks")
    ]
    assert {"pyflyt_engine.envs.tasks.dogfight", "pyflyt_engine.envs.tasks.hover"} <= set(below)
    upward = [f"{m} imports {t}" for m in sorted(below) for t in sorted(graph[m]) if ".envs.multi_agent" in t]
    assert upward == []
    assert sorted(t for t in graph["pyflyt_engine.envs.task_registry"] if ".envs." in t) == []
