"""The three layers point one way: simulator <- learning library <- command line.

Every module is parsed (never imported) and every ``import`` in it counts, at the top or
inside a function:

* the simulator (``pyflyt_engine``) imports nothing of ``pyflyt_cli`` and nothing of the
  learning stack (PyTorch, Stable-Baselines3, Hydra, Typer, Optuna, rliable);
* the learning library (``pyflyt_cli`` but ``main`` and ``commands``) never imports the
  command line (``pyflyt_cli.main``, ``pyflyt_cli.commands``) nor Typer;
* Hydra is used through its public API only (nothing of ``hydra._internal``);
* ``pyflyt_cli`` has no import cycle;
* the scripts under ``experiments/`` import the library, never each other, and never edit
  ``sys.path`` (what studies share lives in :mod:`pyflyt_cli.studies`).

The engine's own layers (spec, components, control, telemetry ...) are checked by their
own test; :func:`import_graph` serves both.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: the learning library's and the command's third-party stack: never imported by the simulator
LEARNING_STACK = ("torch", "stable_baselines3", "sb3_contrib", "hydra", "omegaconf", "typer", "optuna", "rliable")
#: the command line; everything else in pyflyt_cli is the learning library
CLI = ("pyflyt_cli.main", "pyflyt_cli.commands")
#: (module, what it imports): the only exceptions, each with its reason
ALLOWED = {
    # reads PyTorch's numeric settings for run.yaml and the MCAP metadata, and only when
    # the caller has already loaded PyTorch (``"torch" in sys.modules``)
    ("pyflyt_engine.numerics", "torch"),
}


def modules(package: str) -> dict[str, tuple[Path, bool]]:
    """Module name -> (file, is a package) for every module of ``package`` under the checkout."""
    found = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        found[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return found


def imported_names(name: str, path: Path, is_package: bool) -> set[str]:
    """Every module name ``path`` imports (``from a.b import c`` gives ``a.b`` and ``a.b.c``),
    relative imports made absolute."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names)
    return names


def import_graph(package: str) -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports (the most specific one each import names;
    a module's own parent packages, which Python imports first anyway, are left out)."""
    mods = modules(package)
    graph: dict[str, set[str]] = {}
    for name, (path, is_package) in mods.items():
        targets = set()
        for imported in imported_names(name, path, is_package):
            while imported not in mods and "." in imported:
                imported = imported.rsplit(".", 1)[0]
            if imported in mods and imported != name and not name.startswith(imported + "."):
                targets.add(imported)
        graph[name] = targets
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _offenders(package: str, forbidden, exempt=lambda module: False) -> list[str]:
    bad = []
    for name, (path, is_package) in modules(package).items():
        if exempt(name):
            continue
        for imported in sorted(imported_names(name, path, is_package)):
            hit = next((f for f in forbidden if imported == f or imported.startswith(f + ".")), None)
            if hit is not None and (name, hit) not in ALLOWED:
                bad.append(f"{name} imports {imported}")
    return sorted(set(bad))


def _in_cli(module: str) -> bool:
    return any(module == c or module.startswith(c + ".") for c in CLI)


def test_the_simulator_imports_neither_the_library_nor_the_learning_stack():
    assert len(modules("pyflyt_engine")) > 50
    assert _offenders("pyflyt_engine", ("pyflyt_cli", *LEARNING_STACK)) == []


def test_the_learning_library_never_imports_the_command_line():
    library = [m for m in modules("pyflyt_cli") if not _in_cli(m)]
    assert "pyflyt_cli.training.loop" in library and "pyflyt_cli.compose" in library and len(library) > 40
    assert _offenders("pyflyt_cli", (*CLI, "typer"), exempt=_in_cli) == []


def test_hydra_is_used_through_its_public_api_only():
    assert _offenders("pyflyt_cli", ("hydra._internal",)) == []
    assert _offenders("pyflyt_engine", ("hydra._internal",)) == []


def test_pyflyt_cli_has_no_import_cycle():
    graph = import_graph("pyflyt_cli")
    assert "pyflyt_cli.benchmark.launchers" in graph["pyflyt_cli.benchmark.plan"]
    assert cycles(graph) == []


def _script_offences(path: Path, scripts: set[str]) -> list[str]:
    """What ``path`` does that a script under experiments/ must not: import a sibling script, edit sys.path."""
    bad = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            bad += [f"{path.name} imports {a.name}" for a in node.names if a.name.split(".")[0] in scripts]
        elif isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").split(".")[0] in scripts:
            bad.append(f"{path.name} imports {node.module}")
        elif (
            isinstance(node, ast.Attribute)
            and node.attr == "path"
            and isinstance(node.value, ast.Name)
            and node.value.id == "sys"
        ):
            bad.append(f"{path.name} uses sys.path (line {node.lineno})")
    return bad


def test_experiments_share_code_through_the_library_not_each_other():
    scripts = {p.stem for p in (ROOT / "experiments").glob("*.py")}
    assert {"learn_waypoints", "learn_hover_ppo", "learn_obstacles", "learn_gates"} <= scripts
    bad = [b for p in sorted((ROOT / "experiments").glob("*.py")) for b in _script_offences(p, scripts)]
    assert bad == []


def test_the_script_check_sees_a_sibling_import_and_a_path_edit(tmp_path):
    script = tmp_path / "study.py"
    script.write_text("import sys\nsys.path.insert(0, '.')\nfrom learn_waypoints import run\nimport numpy\n")
    assert sorted(_script_offences(script, {"learn_waypoints", "study"})) == [
        "study.py imports learn_waypoints",
        "study.py uses sys.path (line 2)",
    ]


def test_the_checks_see_a_cycle_and_a_forbidden_import():
    """The helpers themselves: a made-up cycle is found, and the allowance is the only one."""
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
    numerics = modules("pyflyt_engine")["pyflyt_engine.numerics"]
    assert "torch" in imported_names("pyflyt_engine.numerics", *numerics)
