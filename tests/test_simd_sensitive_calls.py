"""No decision depends on a NumPy kernel whose bits change with the CPU's SIMD level.

``tests/test_simd_levels.py`` runs the engines with NumPy's AVX-512 kernels on and off, but
only on a CPU that has AVX-512; elsewhere it is skipped, and a green run on a machine without
AVX-512 once hid a failing test. This check holds on every machine: it reads src/ and lists
each use of a NumPy function whose float64 result depends on the kernel NumPy dispatches to
(the transcendental functions, which have AVX-512 kernels of their own, and the BLAS-backed
products), and each ``@``. Every such use must be one of the places below, each with the
reason it cannot make the engines differ. A leaf, sensor or motion step that needs one of
these functions uses the correctly rounded forms in ``arrays.py`` (``arctan2``,
``sincos_degrees``, ``hypot``) or ``models/x8_dynamics.py`` (``exp``) instead.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pyautonomousagent

SRC = Path(pyautonomousagent.__file__).parent

#: NumPy functions whose float64 bits depend on the SIMD level (AVX-512 SVML kernels, or BLAS).
SENSITIVE = frozenset(
    {
        "sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh", "tanh",
        "arcsinh", "arccosh", "arctanh", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p",
        "cbrt", "power", "float_power", "hypot", "dot", "matmul", "inner", "vdot", "einsum",
        "tensordot", "linalg",
    }
)  # fmt: skip

SET_UP = "computed once for the whole swarm before the loop, the same input to every engine"
SHOWN = "drawn, measured or checked after a run; no engine reads it"

#: "file::function" -> why it cannot make the engines differ.
ALLOWED = {
    "experiments/expression.py::<module>": SHOWN + " (a measure's formula over recorded columns)",
    "experiments/measures.py::distance_flown": SHOWN,
    "lessons.py::_check_01": SHOWN,
    "missions/crowded/__init__.py::layout": SET_UP + " (the gathering points' slots)",
    "missions/gathering/measures.py::gathering_time": SHOWN,
    "models/x8_dynamics.py::quaternion_from_euler": SET_UP + " (the X8s' initial attitude)",
    "models/x8_dynamics.py::euler_from_quaternion": "not called by a run (the tests' round trip)",
    "models/x8_flight_log.py::lift_coefficient_max": SHOWN + " (the stall speed a log is held to)",
    "models/x8_pyfly.py::X8PyFly._observe": "pyfly's own model, the reference the X8 is held to",
    "render/animation.py::FramePainter._update": SHOWN,
    "render/animation.py::_outline": SHOWN,
    "studio/live.py::EventFeed._in_range": SHOWN + " (the studio's view of a step)",
}


def _uses(tree: ast.AST) -> Iterator[tuple[str, str]]:
    """(qualified function name, what) for each sensitive use in a module's syntax tree."""

    def walk(node: ast.AST, scope: str) -> Iterator[tuple[str, str]]:
        for child in ast.iter_child_nodes(node):
            inner = scope
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                inner = child.name if scope == "<module>" else f"{scope}.{child.name}"
            if (
                isinstance(child, ast.Attribute)
                and isinstance(child.value, ast.Name)
                and child.value.id in ("np", "numpy")
                and child.attr in SENSITIVE
            ):
                yield scope, f"np.{child.attr}"
            if isinstance(child, (ast.BinOp, ast.AugAssign)) and isinstance(child.op, ast.MatMult):
                yield scope, "@"
            if isinstance(child, ast.ImportFrom) and child.module == "numpy":
                for alias in child.names:
                    if alias.name in SENSITIVE:
                        yield scope, f"from numpy import {alias.name}"
            yield from walk(child, inner)

    yield from walk(tree, "<module>")


def sensitive_uses(root: Path = SRC) -> dict[str, list[str]]:
    """``file::function`` -> the sensitive uses in it, for every module under ``root``."""
    found: dict[str, list[str]] = {}
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for scope, what in _uses(tree):
            found.setdefault(f"{path.relative_to(root).as_posix()}::{scope}", []).append(what)
    return found


def test_every_simd_sensitive_call_is_one_of_the_allowed_places():
    found = sensitive_uses()
    unexplained = {place: uses for place, uses in found.items() if place not in ALLOWED}
    assert not unexplained, (
        "NumPy functions whose bits depend on the SIMD level, in places not known to be outside"
        f" the engines' decisions: {unexplained}. Use arrays.arctan2 / sincos_degrees / hypot,"
        " or, if no engine reads the result, add the place to ALLOWED with the reason."
    )


def test_the_allowed_places_still_exist_and_still_need_it():
    found = sensitive_uses()
    assert sorted(set(ALLOWED) - set(found)) == []


def test_the_check_sees_calls_references_imports_and_matrix_products(tmp_path):
    (tmp_path / "leaf.py").write_text(
        "import numpy as np\nfrom numpy import arctan2\n"
        "class Leaf:\n    def evaluate(self, a, b):\n"
        "        return np.sin(a) + (a @ b) + np.sqrt(b)\n"
        "TABLE = {'pow': np.power}\n"
    )
    found = sensitive_uses(tmp_path)
    assert found == {
        "leaf.py::<module>": ["from numpy import arctan2", "np.power"],
        "leaf.py::Leaf.evaluate": ["np.sin", "@"],
    }
