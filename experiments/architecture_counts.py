"""The import graph and the structural counts of the library at one or more git revisions.

    python experiments/architecture_counts.py                  # the working tree
    python experiments/architecture_counts.py d84eb91 HEAD     # two commits side by side

For each revision (exported with ``git archive``, nothing checked out) it parses every module
of ``pyflyt_engine`` and ``pyflyt_cli`` (``ast``: nothing is imported or run) and prints:

* the import graph between areas (each sub-package, ``envs``' own sub-packages apart, and
  each package's top-level modules together), module-level imports only (the ones that
  make an import order), with the number of module pairs behind each arrow, and the cycles
  among areas and among modules (a package a module sits in, imported with it anyway, is
  no arrow);
* the modules with the most distinct internal imports (fan-out, function-level included);
* run-time method replacement: ``method-assign`` suppressions;
* the lines of the env-loop stack: the modules an env's reset and step run through between
  the Gymnasium API and the World (:data:`ENV_LOOP`, those of them the revision has);
* the name tables keyed by task or env name (module-level assignments of the names in
  :data:`TABLE_NAMES`), and which of them are views of the task registry rather than tables
  a new task is written into.
"""

from __future__ import annotations

import argparse
import ast
import io
import subprocess
import sys
import tarfile
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("pyflyt_engine", "pyflyt_cli")

#: the env loop: the generic env, its episode, the step's pieces and the multi-agent loop (every
#: module an env's reset/step passes through that is neither a task, a config, a reward term nor
#: a registered env class)
ENV_LOOP = (
    "pyflyt_engine/envs/env.py",
    "pyflyt_engine/envs/episode.py",
    "pyflyt_engine/envs/core.py",
    "pyflyt_engine/envs/step.py",
    "pyflyt_engine/envs/observe.py",
    "pyflyt_engine/envs/terminations.py",
    "pyflyt_engine/envs/events.py",
    "pyflyt_engine/envs/guard.py",
    "pyflyt_engine/envs/build.py",
    "pyflyt_engine/envs/recordable.py",
    "pyflyt_engine/envs/multi_agent/base.py",
)

#: module-level names of the tables a task or env is listed in
TABLE_NAMES = ("ENVS", "MA_ENVS", "TASKS", "MA_TASKS", "MA_TASK_CLASSES", "TASK_CLASSES", "ORACLES", "_LAZY")


def sources(rev: str | None) -> dict[str, str]:
    """path -> text of every .py file of the packages at ``rev`` (None: the working tree)."""
    out: dict[str, str] = {}
    if rev is None:
        for pkg in PACKAGES:
            for path in sorted((ROOT / pkg).rglob("*.py")):
                out[str(path.relative_to(ROOT))] = path.read_text()
        return out
    data = subprocess.run(["git", "archive", rev, *PACKAGES], cwd=ROOT, capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        for member in tar.getmembers():
            if member.isfile() and member.name.endswith(".py"):
                handle = tar.extractfile(member)
                assert handle is not None
                out[member.name] = handle.read().decode()
    return out


def module_name(path: str) -> str:
    parts = path[:-3].split("/")
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def area(module: str, packages: set[str]) -> str:
    """A sub-package (``envs``' own sub-packages apart), or the package's top-level modules together."""
    parts = module.split(".")
    for depth in (3, 2):
        prefix = ".".join(parts[:depth])
        if prefix in packages and (depth == 2 or parts[:2] == ["pyflyt_engine", "envs"]):
            return prefix
    return f"{parts[0]} (top-level modules)"


def imports(tree: ast.Module, module: str, is_package: bool, known: set[str]) -> tuple[set[str], set[str]]:
    """(module-level, all) internal modules ``tree`` imports (``known``: every module's name).

    A package a module sits in is imported with it anyway, so it is no dependency of its own."""
    top: set[str] = set()
    every: set[str] = set()

    def add(name: str, at_top: bool) -> None:
        if module.startswith(name + ".") or (is_package and name == module):
            return
        if name.split(".")[0] in PACKAGES:
            every.add(name)
            if at_top:
                top.add(name)

    def visit(node: ast.AST, at_top: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                for alias in child.names:
                    add(alias.name, at_top)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    here = module.split(".") if is_package else module.split(".")[:-1]
                    here = here[: len(here) - (child.level - 1)]
                    base = ".".join([*here, base] if base else here)
                named = [f"{base}.{alias.name}" for alias in child.names]
                for name in named:  # `from pkg import module` imports the module
                    if name in known:
                        add(name, at_top)
                if not all(name in known for name in named):
                    add(base, at_top)
            elif isinstance(child, ast.If) and _is_type_checking(child.test):
                continue  # annotations only: no import at run time
            else:
                nested = at_top and not isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
                visit(child, nested)

    visit(tree, True)
    return top, every


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one area (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(edges):
        if v not in index:
            strong(v)
    return found


def report(rev: str | None) -> str:
    files = sources(rev)
    modules = {module_name(p): p for p in files}
    packages = {module_name(p) for p in files if p.endswith("__init__.py")}
    top_edges: Counter[tuple[str, str]] = Counter()
    module_graph: dict[str, set[str]] = defaultdict(set)
    fan_out: dict[str, int] = {}
    method_assign = 0
    tables: dict[str, list[str]] = defaultdict(list)
    for path, text in files.items():
        module = module_name(path)
        tree = ast.parse(text)
        top, every = imports(tree, module, path.endswith("__init__.py"), set(modules))
        resolved_top = {m for m in top if m in modules and m != module}
        resolved_all = {m for m in every if m in modules and m != module}
        fan_out[module] = len(resolved_all)
        module_graph[module] |= resolved_top
        for m in resolved_top:
            a, b = area(module, packages), area(m, packages)
            if a != b:
                top_edges[(a, b)] += 1
        method_assign += text.count("method-assign")
        for node in tree.body:
            targets = (
                node.targets
                if isinstance(node, ast.Assign)
                else [node.target]
                if isinstance(node, ast.AnnAssign)
                else []
            )
            value = getattr(node, "value", None)
            view = isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id.endswith("Table")
            for t in targets:
                if isinstance(t, ast.Name) and t.id in TABLE_NAMES:
                    tables[t.id].append(module + (" [a view of the task registry]" if view else ""))
    graph: dict[str, set[str]] = defaultdict(set)
    for a, b in top_edges:
        graph[a].add(b)
    loop = [(p, files[p].count("\n")) for p in ENV_LOOP if p in files]
    lines = [
        f"## {rev or 'working tree'}",
        "",
        f"{len(files)} modules, {sum(t.count(chr(10)) for t in files.values())} lines",
        "",
        "import graph between areas (module-level imports; module pairs per arrow):",
    ]
    for a in sorted(graph):
        lines.append(f"  {a} -> " + ", ".join(f"{b} ({top_edges[(a, b)]})" for b in sorted(graph[a])))
    found = cycles(graph)
    lines.append("cycles among areas: " + ("; ".join(" <-> ".join(c) for c in found) if found else "none"))
    found = cycles(module_graph)
    lines.append("cycles among modules: " + ("; ".join(" <-> ".join(c) for c in found) if found else "none"))
    lines.append("")
    lines.append("highest fan-out (distinct internal modules imported, function-level included):")
    for module, n in sorted(fan_out.items(), key=lambda kv: (-kv[1], kv[0]))[:5]:
        lines.append(f"  {n:3d}  {module}")
    lines.append("")
    lines.append(f"method-assign suppressions: {method_assign}")
    lines.append(
        f"env-loop stack: {sum(n for _, n in loop)} lines in {len(loop)} modules ("
        + ", ".join(f"{Path(p).relative_to('pyflyt_engine/envs')} {n}" for p, n in loop)
        + ")"
    )
    lines.append(
        "name tables of tasks and envs: "
        + (", ".join(f"{name} ({', '.join(mods)})" for name, mods in sorted(tables.items())) or "none")
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("revs", nargs="*", help="git revisions (default: the working tree)")
    args = parser.parse_args()
    print("\n\n".join(report(rev) for rev in (args.revs or [None])))


if __name__ == "__main__":
    main()
