"""The package's shape: stages in layers (the import-linter contracts of
``pyproject.toml``), no import cycle between its modules and no module over 800 lines.

Imports are counted wherever they stand: at the top of a module, inside a function or
under ``if TYPE_CHECKING:``.
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "eigmotion"

#: The most lines a module of the package may have.
MAX_MODULE_LINES = 800


def _modules() -> dict[str, Path]:
    """Dotted name → file, for every module of the package (a package is its __init__)."""
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(REPO).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _imported_names(name: str, path: Path) -> set[str]:
    """Every dotted name an import statement of the module names, relative ones resolved:
    ``from a.b import c`` names ``a.b`` and ``a.b.c``."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def _import_graph() -> dict[str, set[str]]:
    """Module → the package's modules it imports (its own enclosing packages left out)."""
    modules = _modules()
    graph = {}
    for name, path in modules.items():
        targets = set()
        for imported in _imported_names(name, path):
            while imported and imported not in modules:
                imported = imported.rpartition(".")[0]
            if imported and imported != name and not name.startswith(imported + "."):
                targets.add(imported)
        graph[name] = targets
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, stack, on_stack, components = {}, {}, [], set(), []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, successors = work[-1]
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = len(index)
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(graph[successor]))))
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        components.append(sorted(component))
    return sorted(components)


def test_cycle_finder_finds_cycles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a", "e"}, "e": {"d"}, "f": set()}
    assert _cycles(graph) == [["a", "b", "c"], ["d", "e"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_layer_contracts_are_kept():
    command = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which(
        "lint-imports"
    )
    assert command, "import-linter is not installed (pip install -e '.[test]')"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    done = subprocess.run(
        [command, "--no-cache", "--config", str(REPO / "pyproject.toml")],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_no_import_cycles():
    cycles = _cycles(_import_graph())
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


#: What may be imported inside a function, and why: optional or heavy back ends that
#: most runs never need, and modules kept off a query's start-up path (scipy's
#: submodules and the retargeting that loads them cost a cold query ~0.14-0.4 s).
LAZY_IMPORTS = {
    "pyrender": "GL rendering, an optional back end",
    "OpenGL": "GL rendering, an optional back end",
    "numba": "compiled kernels: the JIT costs seconds at first use",
    "ZEO": "zeo:// databases only",
    "distributed": "builds on a Dask cluster only (--scheduler), the optional cluster extra",
    "fast_simplification": "mesh decimation, build only",
    "matplotlib": "plots, benchmarks only",
    "scipy": "kept off the query's start-up path",
    "eigmotion.body.retarget": "loads scipy.spatial, kept off the query's start-up path",
    "ai_edge_litert": "the learned segmenter's faster runtime, an optional extra",
    "eigmotion.pose.continuous_pose": "3D output only (query --bvh-out/--pose-out/"
    "--replay-out): loads retargeting and scipy.spatial",
    "eigmotion.pose.clip_pose": "3D output only (query --pose-out …): loads the continuous pose",
    "eigmotion.pose.replay": "3D output only (query --bvh-out/--replay-out)",
    "tqdm": "progress bars, made once a job has taken a second: kept off a query's start-up",
    "PIL": "GIFs and images other than 8-bit PNGs: kept off a query's start-up path",
}

#: Imports allowed inside functions of one module only, and why.
LAZY_IMPORTS_IN = {
    ("eigmotion.cli.main", "cv2"): "the colour-table thread started before NumPy loads",
    ("eigmotion.cli.main", "numpy"): "the colour-table thread started before NumPy loads",
}


def _imports_inside_functions() -> list[tuple[str, int, str]]:
    """(module, line, imported module) of every import that is not at a module's top
    level (an ``if TYPE_CHECKING:`` block at the top level counts as top level)."""
    found = []
    for name, path in _modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        top = {id(node) for node in tree.body}
        for node in tree.body:
            if isinstance(node, ast.If):
                top.update(id(inner) for inner in ast.walk(node))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom) and id(node) not in top:
                if isinstance(node, ast.Import):
                    imported = [alias.name for alias in node.names]
                else:
                    imported = [node.module or ""]
                found += [(name, node.lineno, module) for module in imported]
    return found


def test_imports_inside_functions_are_only_lazy_back_ends():
    allowed = tuple(LAZY_IMPORTS)
    stray = [
        f"{name}:{line} imports {module}"
        for name, line, module in _imports_inside_functions()
        if not any(module == a or module.startswith(a + ".") for a in allowed)
        and (name, module) not in LAZY_IMPORTS_IN
    ]
    assert not stray, "imports inside functions: " + "; ".join(stray)


def test_no_module_over_800_lines():
    lengths = {
        name: len(path.read_text(encoding="utf-8").splitlines())
        for name, path in _modules().items()
    }
    over = {name: n for name, n in sorted(lengths.items()) if n > MAX_MODULE_LINES}
    assert not over, f"modules over {MAX_MODULE_LINES} lines: {over}"
