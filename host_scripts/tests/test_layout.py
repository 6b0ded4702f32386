"""The shape of the package (docs/architecture.md): no import loops between its
modules, no file over 600 lines, no function over 80 lines without a reason
given in a ``# long: ...`` comment on its ``def`` line."""
from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "imu_allan"
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80
KNOWN_LONG = {("terms.py", "fit_terms"): "the IEEE 952 iterated weighted fit in one piece, until the noise fitter"}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path, modules: set[str]) -> set[str]:
    """Package modules ``path`` imports, at any depth of the file (function-level too)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package.split(".")
            base = base[: len(base) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                out.add(sub if sub in modules else target)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("imu_allan"):
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("imu_allan"))
    return {m for m in out if m in modules and m != name}


def _graph() -> dict[str, set[str]]:
    files = sorted(PKG.rglob("*.py"))
    modules = {_module_name(f) for f in files}
    return {_module_name(f): _imports(f, modules) for f in files}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
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
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_loops() -> None:
    graph = _graph()
    assert "imu_allan.device.monitor" in graph and "imu_allan.render" in graph["imu_allan.device.monitor"]
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_loop() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_layers_point_one_way() -> None:
    """device knows nothing of stats, the analysis or rendering; stats nothing of device."""
    graph = _graph()
    for mod, deps in graph.items():
        if mod.startswith("imu_allan.device."):
            assert not {d for d in deps if d.startswith(("imu_allan.stats", "imu_allan.analysis"))}, mod
        if mod.startswith("imu_allan.stats."):
            assert not {d for d in deps if d.startswith(("imu_allan.device", "imu_allan.render",
                                                         "imu_allan.analysis", "imu_allan.cli"))}, mod


def test_file_and_function_sizes() -> None:
    long_files, long_functions = [], []
    for path in sorted(PKG.rglob("*.py")):
        text = path.read_text()
        lines = text.splitlines()
        if len(lines) > MAX_FILE_LINES:
            long_files.append(f"{path.name}: {len(lines)}")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                size = node.end_lineno - node.lineno + 1
                if (size > MAX_FUNCTION_LINES and "# long:" not in lines[node.lineno - 1]
                        and (path.name, node.name) not in KNOWN_LONG):
                    long_functions.append(f"{path.name}:{node.lineno} {node.name} {size}")
    assert long_files == [] and long_functions == []
