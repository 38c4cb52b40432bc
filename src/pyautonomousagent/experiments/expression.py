"""A small, safe expression language for measures over a run's recorded columns.

``mean(energy < 30)`` or ``sum(number_ticks) / agents`` is parsed with :mod:`ast` and checked
against a whitelist before anything is evaluated (column names, numbers, ``+ - * / // % **``,
comparisons and :data:`FUNCTIONS`), so an expression cannot reach Python's builtins, modules
or objects. A column has shape ``(records, N)``; ``first``/``last`` take one record (shape
``(N,)``), the other functions reduce to one number; comparisons give 1.0 or 0.0. The result
must be one number.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from pyautonomousagent.experiments.errors import close_hint

#: Longest expression accepted (characters).
MAX_LENGTH = 400


#: Functions an expression may call, each of one argument.
FUNCTIONS: dict[str, Callable[[np.ndarray], Any]] = {
    "mean": np.mean,
    "min": np.min,
    "max": np.max,
    "sum": np.sum,
    "std": np.std,
    "count": np.count_nonzero,
    "first": lambda a: a[0] if a.ndim >= 1 else a,  # the first record, shape (N,)
    "last": lambda a: a[-1] if a.ndim >= 1 else a,
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
        self._evaluate = self._compile(tree.body)
        names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
        self.names = sorted(names - set(FUNCTIONS))  # a column is never named as a function

    def _refuse(self, node: ast.AST) -> ExpressionError:
        what = ast.unparse(node) if isinstance(node, ast.expr) else type(node).__name__
        return ExpressionError(
            f"expression {self.text!r}: {what!r} is not allowed; use only {_ALLOWED}"
        )

    def _compile(self, node: ast.AST) -> Callable[[Mapping[str, Any]], Any]:
        """``node`` as a function of the columns; raises on anything not whitelisted."""
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            value = np.float64(float(node.value))  # type: ignore[arg-type]
            return lambda columns: value
        if isinstance(node, ast.Name) and not node.id.startswith("_") and node.id not in FUNCTIONS:
            return lambda columns: np.asarray(columns[node.id], dtype=np.float64)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
            operand = self._compile(node.operand)
            return (lambda columns: -operand(columns)) if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right, op = self._compile(node.left), self._compile(node.right), node.op
            return lambda columns: _BINARY[type(op)](left(columns), right(columns))
        if isinstance(node, ast.Compare) and all(type(op) in _COMPARE for op in node.ops):
            terms = [self._compile(term) for term in (node.left, *node.comparators)]
            ops = [_COMPARE[type(op)] for op in node.ops]
            return lambda columns: _chain(ops, [term(columns) for term in terms])
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in FUNCTIONS
            and len(node.args) == 1
            and not node.keywords
        ):
            function, argument = FUNCTIONS[node.func.id], self._compile(node.args[0])
            return lambda columns: _reduced(function, np.asarray(argument(columns)))
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
            value = np.asarray(self._evaluate(columns), dtype=np.float64)
        if value.size != 1:
            raise ExpressionError(
                f"expression {self.text!r} gives {value.size} values, not one; wrap it in "
                "mean/min/max/sum(...)"
            )
        return float(value.reshape(()))

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Expression) and other.text == self.text

    def __hash__(self) -> int:
        return hash(self.text)

    def __reduce__(self) -> tuple[type, tuple[str]]:
        return (Expression, (self.text,))


def _chain(ops: list[Callable[[Any, Any], Any]], values: list[Any]) -> np.ndarray:
    """``a < b <= c ...``: 1.0 where every comparison of neighbours holds, else 0.0."""
    holds = (op(left, right) for op, left, right in zip(ops, values, values[1:], strict=False))
    return np.asarray(functools.reduce(np.logical_and, holds, True), dtype=np.float64)


def _reduced(function: Callable[[np.ndarray], Any], argument: np.ndarray) -> Any:
    """``function(argument)``, NaN for an empty argument."""
    return np.float64("nan") if argument.size == 0 else function(argument)
