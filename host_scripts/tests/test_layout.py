"""The shape of the package (docs/architecture.md): rooms by job on ranks, every
import going down a rank (or staying in its room), no import loops between
modules, no file over 600 lines, no function over 80 lines without a reason
given in a ``# long: ...`` comment on its ``def`` line."""

from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "imu_allan"
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80
# The rooms of imu_allan by rank: a module may import from a lower rank or from
# its own room, never upward nor sideways.  A room is a subpackage or a top-level
# module (the leaves of rank 0 share one room).
LAYERS: tuple[tuple[int, str, tuple[str, ...]], ...] = (
    (0, "leaves", ("_version", "_firmware_facts", "errors", "channels", "profiles", "progress")),
    (1, "device", ("device",)),  # bytes from the board into typed records
    (1, "stats", ("stats",)),  # estimators and intervals
    (2, "sources", ("sources",)),  # every input format into samples
    (2, "noise", ("noise",)),  # noise processes: simulate, theory, fit
    (3, "analysis", ("analysis",)),  # samples and reports into finished documents
    (4, "render", ("render",)),  # documents and live states into text, files, figures, screens
    (5, "cli", ("cli",)),  # the imu-allan command
    (6, "public", ("__init__", "api")),  # the Python API
)
# Upward or sideways imports allowed for now, each with the move that removes it
# (none left: keep it empty).
ALLOWED: dict[tuple[str, str], str] = {}
KNOWN_LONG: dict[tuple[str, str], str] = {}


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


def _room(module: str) -> tuple[int, str]:
    """(rank, room) of a module of imu_allan by its first name below the package."""
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else "__init__"
    for rank, room, members in LAYERS:
        if top in members:
            return rank, room
    raise AssertionError(f"{module}: in no room of LAYERS (tests/test_layout.py): give it one")


def _wrong_way(graph: dict[str, set[str]]) -> list[str]:
    out = []
    for mod, deps in sorted(graph.items()):
        rank, room = _room(mod)
        for dep in sorted(deps):
            dep_rank, dep_room = _room(dep)
            if dep_room != room and dep_rank >= rank and (mod, dep) not in ALLOWED:
                out.append(f"{mod} ({room}, rank {rank}) -> {dep} ({dep_room}, rank {dep_rank})")
    return out


def test_no_import_loops() -> None:
    graph = _graph()
    assert "imu_allan.render.screen" in graph and "imu_allan.render.text" in graph["imu_allan.render.screen"]
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_loop() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_every_import_goes_down_the_layers() -> None:
    """Each import checked against LAYERS; the allowed exceptions still exist (else drop them)."""
    graph = _graph()
    assert _wrong_way(graph) == []
    assert [pair for pair in ALLOWED if pair[1] not in graph.get(pair[0], set())] == []


def test_the_layer_check_finds_an_upward_import() -> None:
    graph = {
        "imu_allan.device.records": {"imu_allan.channels", "imu_allan.render.text"},
        "imu_allan.render.text": {"imu_allan.device.records"},
        "imu_allan.channels": set(),
    }
    assert _wrong_way(graph) == ["imu_allan.device.records (device, rank 1) -> imu_allan.render.text (render, rank 4)"]
    assert _wrong_way({"imu_allan.sources.rows": {"imu_allan.noise.gen"}, "imu_allan.noise.gen": set()}) == [
        "imu_allan.sources.rows (sources, rank 2) -> imu_allan.noise.gen (noise, rank 2)"
    ]


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
                if (
                    size > MAX_FUNCTION_LINES
                    and "# long:" not in lines[node.lineno - 1]
                    and (path.name, node.name) not in KNOWN_LONG
                ):
                    long_functions.append(f"{path.name}:{node.lineno} {node.name} {size}")
    assert long_files == [] and long_functions == []
