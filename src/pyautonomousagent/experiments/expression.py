"""A small, safe expression language for measures over a run's recorded columns.

``mean(energy < 30)``, ``min(last(energy))`` or ``sum(number_ticks) / agents`` are parsed
with :mod:`ast` and checked against a whitelist before anything is evaluated: column names,
numbers, ``+ - * / // % **``, comparisons, and the functions of :data:`FUNCTIONS`. No
attribute, subscript, keyword, lambda, comprehension or other name is accepted, so an
expression cannot reach Python's builtins, modules or objects.

A column is an array of shape ``(records, N)`` (one row per recorded iteration, one column
per agent); ``first``/``last`` take its first or last record (shape ``(N,)``); ``mean``,
``min``, ``max``, ``sum``, ``std`` and ``count`` reduce over everything to one number.
Comparisons give 1.0 or 0.0, so ``mean(energy < 30)`` is the fraction of drone-records
below 30 %. The result must be one number.
"""

from __future__ import annotations

import ast
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from pyautonomousagent.experiments.errors import close_hint

#: Longest expression accepted (characters).
MAX_LENGTH = 400


def _first(a: np.ndarray) -> np.ndarray:
    return a[0] if a.ndim >= 1 else a


def _last(a: np.ndarray) -> np.ndarray:
    return a[-1] if a.ndim >= 1 else a


#: Functions an expression may call, each of one argument.
FUNCTIONS: dict[str, Callable[[np.ndarray], Any]] = {
    "mean": np.mean,
    "min": np.min,
    "max": np.max,
    "sum": np.sum,
    "std": np.std,
    "count": np.count_nonzero,
    "first": _first,
    "last": _last,
    "abs": np.abs,
    "sqrt": np.sqrt,
}

_BINARY: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.true_divide,
    ast.FloorDiv: np.floor_divide,
    ast.Mod: np.mod,
    ast.Pow: np.power,
}
_COMPARE: dict[type, Callable[[Any, Any], Any]] = {
    ast.Lt: np.less,
    ast.LtE: np.less_equal,
    ast.Gt: np.greater,
    ast.GtE: np.greater_equal,
    ast.Eq: np.equal,
    ast.NotEq: np.not_equal,
}
_ALLOWED = (
    "column names, numbers, + - * / // % **, comparisons and " + "/".join(FUNCTIONS) + "(...)"
)


class ExpressionError(ValueError):
    """An expression that is not allowed or cannot be evaluated; one line naming why."""


class Expression:
    """A checked expression; evaluate it with :meth:`evaluate`.

    Args:
        text: the expression, e.g. ``"mean(energy < 30)"``.

    Raises:
        ExpressionError: syntax error, or anything outside the whitelist.
    """

    def __init__(self, text: str) -> None:
        if not isinstance(text, str) or not text.strip():
            raise ExpressionError(f"an expression must be a non-empty string, got {text!r}")
        if len(text) > MAX_LENGTH:
            raise ExpressionError(f"expression longer than {MAX_LENGTH} characters")
        self.text = text
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as error:
            raise ExpressionError(f"expression {text!r}: syntax error: {error.msg}") from None
        self._tree = tree.body
        self.names = sorted(self._check(self._tree))

    def _refuse(self, node: ast.AST) -> ExpressionError:
        what = ast.unparse(node) if isinstance(node, ast.expr) else type(node).__name__
        return ExpressionError(
            f"expression {self.text!r}: {what!r} is not allowed; use only {_ALLOWED}"
        )

    def _check(self, node: ast.AST) -> set[str]:
        """The column names ``node`` uses; raises on anything not whitelisted."""
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, int | float):
                raise self._refuse(node)
            return set()
        if isinstance(node, ast.Name):
            if node.id.startswith("_") or node.id in FUNCTIONS:
                raise self._refuse(node)
            return {node.id}
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
            return self._check(node.operand)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return self._check(node.left) | self._check(node.right)
        if isinstance(node, ast.Compare) and all(type(op) in _COMPARE for op in node.ops):
            names = self._check(node.left)
            for comparator in node.comparators:
                names |= self._check(comparator)
            return names
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in FUNCTIONS
            and len(node.args) == 1
            and not node.keywords
        ):
            return self._check(node.args[0])
        raise self._refuse(node)

    def evaluate(self, columns: Mapping[str, Any]) -> float:
        """The expression's value over ``columns`` (name -> array or number).

        Raises:
            ExpressionError: an unknown name, or a result that is not one number.
        """
        for name in self.names:
            if name not in columns:
                hint = close_hint(name, columns)
                raise ExpressionError(f"expression {self.text!r}: unknown column {name!r}{hint}")
        with np.errstate(all="ignore"):
            value = np.asarray(self._eval(self._tree, columns), dtype=np.float64)
        if value.size != 1:
            raise ExpressionError(
                f"expression {self.text!r} gives {value.size} values, not one; wrap it in "
                "mean/min/max/sum(...)"
            )
        return float(value.reshape(()))

    def _eval(self, node: ast.AST, columns: Mapping[str, Any]) -> Any:
        if isinstance(node, ast.Constant):
            return np.float64(float(node.value))  # type: ignore[arg-type]
        if isinstance(node, ast.Name):
            return np.asarray(columns[node.id], dtype=np.float64)
        if isinstance(node, ast.UnaryOp):
            operand = self._eval(node.operand, columns)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            left, right = self._eval(node.left, columns), self._eval(node.right, columns)
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.Compare):
            left = self._eval(node.left, columns)
            result: Any = True
            for op, comparator in zip(node.ops, node.comparators, strict=True):
                right = self._eval(comparator, columns)
                result = np.logical_and(result, _COMPARE[type(op)](left, right))
                left = right
            return np.asarray(result, dtype=np.float64)
        assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
        argument = np.asarray(self._eval(node.args[0], columns))
        if argument.size == 0:
            return np.float64("nan")
        return FUNCTIONS[node.func.id](argument)

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Expression) and other.text == self.text

    def __hash__(self) -> int:
        return hash(self.text)

    def __reduce__(self) -> tuple[type, tuple[str]]:
        return (Expression, (self.text,))
