"""The import graph of src/: no cycle anywhere (type-only and function-level imports
included), and no engine importing another (issue 26).

The graph is read from the source with :mod:`ast`, so it sees every ``import`` statement,
also those under ``if TYPE_CHECKING:`` and inside functions. An edge goes to the module
imported: ``from a.b import c`` is an edge to ``a.b.c`` where that is a module, else to
``a.b``. Importing a submodule also runs its package's ``__init__``, but that is not an edge
(a package importing its own submodules is not a cycle).
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).parents[1] / "src"
PACKAGE = "pyautonomousagent"

#: The engines (issue 26: "siblings that import none of each other"), module -> engine; every
#: module under engines/ must be listed, so that a new one is placed deliberately.
ENGINE_OF = {
    "pytrees": "pytrees",
    "pytrees_rules": "pytrees",
    "btcpp": "pytrees",  # BT.CPP's node semantics, ticked one tree per agent
    "batched": "batched",
    "batched_rules": "batched",
    "compiled": "compiled",
    "compiled_source": "compiled",
    "gpu": "gpu",
    "gpu_source": "gpu",
    "gpu_messages": "gpu",
    "gpu_records": "gpu",
    "gpu_grid": "gpu",
    "gpu_reduce": "gpu",
    "cuda_jit": "gpu",
}

#: What the fused loop (``loop/``: Phases 2-6 compiled, shared by the compiled and GPU
#: engines) may import, by package or module under ``pyautonomousagent``: never engines/
#: (which may import it), nor more of simulation/ than the engines' protocol (type-only).
LOOP_MAY_IMPORT = (
    "loop", "bt", "kernels", "models", "recording", "record_blocks", "state", "world",
    "datalink", "jit", "simulation.engine_api",
)  # fmt: skip


def modules() -> dict[str, Path]:
    """Every module of the package, dotted name -> file (a package by its ``__init__``)."""
    found = {}
    for path in (SRC / PACKAGE).rglob("*.py"):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def imported(module: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package's modules that ``module`` (at ``path``) imports anywhere in its source."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    targets: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            for alias in node.names:
                full = f"{base}.{alias.name}"
                targets.add(full if full in known else base)
    return {_owner(t, known) for t in targets if t.startswith(PACKAGE)} - {module, None}


def _owner(name: str, known: dict[str, Path]) -> str | None:
    """The module ``name`` lies in (``a.b.C`` -> ``a.b``), or None."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def graph() -> dict[str, set[str]]:
    known = modules()
    return {m: imported(m, p, known) for m, p in known.items()}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges[child]))))
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


def test_the_cycle_finder_finds_a_cycle_and_only_a_cycle() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_the_graph_sees_type_only_and_function_level_imports() -> None:
    edges = graph()
    type_only = edges["pyautonomousagent.kernels"]  # under TYPE_CHECKING
    assert "pyautonomousagent.simulation.view" in type_only
    lazy = edges["pyautonomousagent.lessons"]  # imported inside functions
    assert "pyautonomousagent.testing" in lazy


def test_no_import_cycle_in_src() -> None:
    found = cycles(graph())
    assert not found, "import cycles:\n" + "\n".join(" -> ".join(c) for c in found)


def test_every_engine_module_belongs_to_one_engine() -> None:
    engines = {m.rpartition(".")[2] for m in modules() if m.startswith(f"{PACKAGE}.engines.")}
    assert engines == set(ENGINE_OF), "place new modules under engines/ in ENGINE_OF"


def test_no_engine_imports_another() -> None:
    edges = graph()
    crossing = sorted(
        f"{a} -> {b}"
        for a, targets in edges.items()
        if a.startswith(f"{PACKAGE}.engines.")
        for b in targets
        if b.startswith(f"{PACKAGE}.engines.")
        and ENGINE_OF[a.rpartition(".")[2]] != ENGINE_OF[b.rpartition(".")[2]]
    )
    assert not crossing, "engines importing another engine:\n" + "\n".join(crossing)


def loop_crossings(edges: dict[str, set[str]]) -> list[str]:
    """The imports of loop/ modules outside :data:`LOOP_MAY_IMPORT`, as ``a -> b``."""
    allowed = tuple(f"{PACKAGE}.{name}" for name in LOOP_MAY_IMPORT)
    return sorted(
        f"{a} -> {b}"
        for a, targets in edges.items()
        if a == f"{PACKAGE}.loop" or a.startswith(f"{PACKAGE}.loop.")
        for b in targets
        if not any(b == prefix or b.startswith(prefix + ".") for prefix in allowed)
    )


def test_the_loop_imports_only_its_lower_layers() -> None:
    crossing = loop_crossings(graph())
    assert not crossing, "the loop importing above its layer:\n" + "\n".join(crossing)


def test_the_layer_check_finds_a_loop_module_importing_an_engine() -> None:
    edges = graph()
    edges[f"{PACKAGE}.loop.engine"].add(f"{PACKAGE}.engines.compiled")
    edges[f"{PACKAGE}.loop.source"].add(f"{PACKAGE}.simulation.run")
    assert loop_crossings(edges) == [
        f"{PACKAGE}.loop.engine -> {PACKAGE}.engines.compiled",
        f"{PACKAGE}.loop.source -> {PACKAGE}.simulation.run",
    ]
