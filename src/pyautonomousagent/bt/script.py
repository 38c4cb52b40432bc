"""BehaviorTree.CPP's scripting language, evaluated on each agent's own blackboard.

A script is statements separated by ``;``: assignments ``key := expr`` (``=``, ``+=``, ``-=``,
``*=``, ``/=`` too) and expressions. Expressions have BT.CPP's operators, loosest first:
ternary ``c ? a : b``; ``||``; ``&&``; ``|``; ``^``; ``&``; ``==`` ``!=``; ``<`` ``<=`` ``>``
``>=``; ``+`` ``-``; ``*`` ``/``; unary ``!`` ``-`` ``~``; and parentheses. Literals are
numbers (``3``, ``2.5``, ``0x1F``), ``true``/``false`` and strings in single quotes.

The blackboard is numeric, one row per agent (:class:`~pyautonomousagent.state.Swarm`), so a
string is an *enum value*: each distinct string of a tree is a whole number of its own
(:func:`enum_code`), which ``==`` and ``!=`` compare as BT.CPP compares strings; strings
cannot be concatenated (``..`` is refused).

:func:`parse` turns code into a :class:`Script`; :meth:`Script.run` executes it for an
:class:`~pyautonomousagent.state.AgentView`: one agent (numbers) or a group (arrays, one
entry per agent: the batched engine's "array expressions over the agents a tick reaches").
A syntax error is a :class:`ScriptError` with the column; callers add the file and line.

Scripts come from files, so the parser is bounded: at most :data:`MAX_SCRIPT_CHARS`
characters, nested at most :data:`MAX_SCRIPT_DEPTH` levels (parentheses, operators,
ternaries), whole numbers within int64 and other numbers finite; anything else is a
ScriptError, never a RecursionError or OverflowError.
"""

from __future__ import annotations

import math
import re
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from pyautonomousagent.inputs import InputError, shown

#: Longest script, characters (BT.CPP scripts are a line or two).
MAX_SCRIPT_CHARS = 10_000
#: Deepest nesting of a script: parentheses, unary operators, ternaries and chains of binary
#: operators (``a + b + c`` is two levels).
MAX_SCRIPT_DEPTH = 64
#: Largest whole number a script may write (the blackboard's int64).
MAX_INT = 2**63 - 1


class ScriptError(InputError):
    """Code that is not a valid script; ``column`` is 1-based within the code."""

    def __init__(self, message: str, column: int) -> None:
        super().__init__(f"{message} at column {column}")
        self.column = column


_SPACE = re.compile(r"\s*", re.ASCII)
_TOKEN = re.compile(
    r"(?:(?P<number>0[xX][0-9a-fA-F]+|\d+\.\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?"
    r"|\d+(?:[eE][-+]?\d+)?)"
    r"|(?P<string>'[^']*')"
    r"|(?P<name>@?[A-Za-z_][A-Za-z0-9_]*)"
    r"|(?P<op>:=|\+=|-=|\*=|/=|==|!=|<=|>=|&&|\|\||\.\.|[-+*/()<>!~&|^?:;=]))",
    re.ASCII,
)

ASSIGNMENTS = (":=", "=", "+=", "-=", "*=", "/=")
#: Binary operators: symbol -> precedence (higher binds tighter).
BINARY = {
    "||": 1, "&&": 2, "|": 3, "^": 4, "&": 5, "==": 6, "!=": 6,
    "<": 7, "<=": 7, ">": 7, ">=": 7, "+": 8, "-": 8, "*": 9, "/": 9,
}  # fmt: skip
COMPARISONS = ("==", "!=", "<", "<=", ">", ">=", "&&", "||")
#: The operators that take a string (an enum value): BT.CPP also orders strings
#: alphabetically and joins them with ``+``, which enum values cannot do.
STRING_OPERATORS = ("==", "!=")


def enum_code(text: str) -> int:
    """The whole number a string literal stands for on the numeric blackboard (stable across
    runs and engines: a CRC-32 of the text, so the same string is always the same number)."""
    return zlib.crc32(text.encode()) + 1


@dataclass(frozen=True)
class Token:
    kind: str  # number, string, name, op, end
    text: str
    column: int


def tokens(code: str) -> list[Token]:
    """The tokens of ``code``; ScriptError at the first character that starts none."""
    out, pos = [], _SPACE.match(code).end()  # type: ignore[union-attr]
    while pos < len(code):
        match = _TOKEN.match(code, pos)
        if match is None:
            raise ScriptError(f"unexpected character {code[pos]!r}", pos + 1)
        kind = match.lastgroup or "op"
        out.append(Token(kind, match.group(kind), pos + 1))
        pos = _SPACE.match(code, match.end()).end()  # type: ignore[union-attr]
    out.append(Token("end", "", len(code) + 1))
    return out


# AST: ("num", value) ("str", text) ("bool", value) ("key", name) ("unary", op, e)
# ("binary", op, a, b) ("ternary", c, a, b) ("assign", op, name, e)
Ast = tuple[Any, ...]


class _Parser:
    """Recursive descent, one level of Python's stack per nesting level, bounded by
    :data:`MAX_SCRIPT_DEPTH` (:meth:`nested`)."""

    def __init__(self, code: str) -> None:
        self.toks = tokens(code)
        self.pos = 0
        self.depth = 0

    def peek(self) -> Token:
        return self.toks[self.pos]

    def take(self, text: str | None = None) -> Token:
        tok = self.toks[self.pos]
        if text is not None and tok.text != text:
            found = repr(tok.text) if tok.kind != "end" else "the end"
            raise ScriptError(f"expected {text!r}, found {found}", tok.column)
        self.pos += 1
        return tok

    def nested(self, parse: Callable[[], Ast]) -> Ast:
        """``parse()`` one level deeper; ScriptError beyond :data:`MAX_SCRIPT_DEPTH`."""
        if self.depth >= MAX_SCRIPT_DEPTH:
            raise ScriptError(_too_deep(), self.peek().column)
        self.depth += 1
        try:
            return parse()
        finally:
            self.depth -= 1

    def statements(self) -> list[Ast]:
        out = []
        while self.peek().kind != "end":
            if self.peek().text == ";":
                self.take()
                continue
            column = self.peek().column
            out.append(self.statement())
            if _depth(out[-1]) > MAX_SCRIPT_DEPTH:
                raise ScriptError(_too_deep(), column)
            if self.peek().kind != "end":
                self.take(";")
        return out

    def statement(self) -> Ast:
        tok, after = self.peek(), self.toks[self.pos + 1]
        if tok.kind == "name" and after.text in ASSIGNMENTS:
            self.pos += 2
            if tok.text in ("true", "false"):
                raise ScriptError(f"cannot assign to {tok.text}", tok.column)
            return ("assign", after.text, _key(tok), self.expression())
        return self.expression()

    def expression(self) -> Ast:
        condition = self.binary(1)
        if self.peek().text == "?":
            self.take()
            yes = self.nested(self.expression)
            self.take(":")
            return ("ternary", condition, yes, self.nested(self.expression))
        return condition

    def binary(self, level: int) -> Ast:
        left = self.unary()
        while True:
            tok = self.peek()
            if tok.text == "..":
                raise ScriptError("strings cannot be joined with '..' on the numeric "
                                  "blackboard", tok.column)  # fmt: skip
            prec = BINARY.get(tok.text) if tok.kind == "op" else None
            if prec is None or prec < level:
                return left
            self.take()
            right = self.binary(prec + 1)  # at most one call per precedence level
            _check_strings(tok, left, right)
            left = ("binary", tok.text, left, right)

    def unary(self) -> Ast:
        tok = self.peek()
        if tok.kind == "op" and tok.text in ("!", "-", "~", "+"):
            self.take()
            operand = self.nested(self.unary)
            _check_strings(tok, operand)
            return ("unary", tok.text, operand)
        return self.atom()

    def atom(self) -> Ast:
        tok = self.take()
        if tok.kind == "number":
            return ("num", _number(tok))
        if tok.kind == "string":
            return ("str", tok.text[1:-1])
        if tok.kind == "name":
            if tok.text in ("true", "false"):
                return ("bool", tok.text == "true")
            return ("key", _key(tok))
        if tok.text == "(":
            inner = self.nested(self.expression)
            self.take(")")
            return inner
        found = repr(tok.text) if tok.kind != "end" else "the end"
        raise ScriptError(f"expected a value, found {found}", tok.column)


def _too_deep() -> str:
    return (
        f"the script nests more than {MAX_SCRIPT_DEPTH} levels deep (parentheses, operators); "
        "split it into several statements separated by ';'"
    )


def _depth(node: Ast) -> int:
    """Levels of an AST (a leaf is 1), measured without recursion."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        part, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((inner, level + 1) for inner in part[1:] if isinstance(inner, tuple))
    return deepest


def _number(tok: Token) -> int | float:
    """A number literal; ScriptError if a whole number is beyond int64 or a number infinite."""
    text = tok.text
    if text.lower().startswith("0x"):
        value: int | float = int(text, 16) if len(text) <= 20 else MAX_INT + 1
    elif any(c in text for c in ".eE"):
        value = float(text)
    else:
        value = int(text) if len(text) <= 19 else MAX_INT + 1
    if isinstance(value, int) and value > MAX_INT:
        raise ScriptError(f"whole number {shown(text, 30)} is beyond int64", tok.column)
    if isinstance(value, float) and not math.isfinite(value):
        raise ScriptError(f"number {shown(text, 30)} is too large", tok.column)
    return value


def _check_strings(tok: Token, *operands: Ast) -> None:
    """ScriptError if operator ``tok`` is applied to a string literal other than by == or !=."""
    if tok.text in STRING_OPERATORS or all(o[0] != "str" for o in operands):
        return
    raise ScriptError(
        f"operator {tok.text!r} cannot take a string: a string is an enum value here, which "
        "only == and != compare (BehaviorTree.CPP would order or join the text)",
        tok.column,
    )


def _key(tok: Token) -> str:
    """A blackboard key (BT.CPP's ``@key``, the root blackboard, is the agent's own here)."""
    return tok.text.lstrip("@")


# -- evaluation --------------------------------------------------------------------------------

Env = Any  # a BlackboardView: attributes are the agent's (or group's) entries
Fn = Callable[[Env], Any]

_BINARY_FN: dict[str, Callable[[Any, Any], Any]] = {
    "+": np.add, "-": np.subtract, "*": np.multiply, "/": np.true_divide,
    "==": np.equal, "!=": np.not_equal, "<": np.less, "<=": np.less_equal,
    ">": np.greater, ">=": np.greater_equal, "&&": np.logical_and, "||": np.logical_or,
    "&": np.bitwise_and, "|": np.bitwise_or, "^": np.bitwise_xor,
}  # fmt: skip


def _compile(node: Ast) -> Fn:
    kind = node[0]
    if kind in ("num", "bool", "str"):  # a string is its enum value
        value = enum_code(node[1]) if kind == "str" else node[1]
        return lambda env: value
    if kind == "key":
        name = node[1]
        return lambda env: getattr(env, name)
    if kind == "unary":
        inner = _compile(node[2])
        op = {"!": np.logical_not, "-": np.negative, "~": np.invert, "+": np.positive}[node[1]]
        return lambda env: op(inner(env))
    if kind == "binary":
        left, right, fn = _compile(node[2]), _compile(node[3]), _BINARY_FN[node[1]]
        return lambda env: fn(left(env), right(env))
    if kind == "ternary":
        c, a, b = (_compile(n) for n in node[1:])
        return lambda env: _where(c(env), a(env), b(env))
    op, name, value = node[1], node[2], _compile(node[3])
    if op in (":=", "="):
        return lambda env: setattr(env, name, value(env))
    fn = _BINARY_FN[op[0]]
    return lambda env: setattr(env, name, fn(getattr(env, name), value(env)))


def _where(condition: Any, yes: Any, no: Any) -> Any:
    """``yes`` where ``condition`` holds, else ``no``; a plain value for one agent."""
    out = np.where(condition, yes, no)
    return out[()] if out.ndim == 0 else out


# -- static types, for the blackboard entries a tree declares ------------------------------------

#: Type names, narrowest first; a key assigned several types gets the widest.
TYPES = ("bool", "int", "float")
DTYPES = {"bool": np.dtype(np.bool_), "int": np.dtype(np.int64), "float": np.dtype(np.float64)}


def _type(node: Ast, known: dict[str, str]) -> str:
    kind = node[0]
    if kind == "num":
        return "float" if isinstance(node[1], float) else "int"
    if kind in ("bool",):
        return "bool"
    if kind == "str":
        return "int"
    if kind == "key":  # a key nothing assigned yet: the narrowest, widened by later passes
        return known.get(node[1], "bool")
    if kind == "unary":
        return "bool" if node[1] == "!" else _type(node[2], known)
    if kind == "binary":
        if node[1] in COMPARISONS:
            return "bool"
        if node[1] == "/":
            return "float"
        return widest(_type(node[2], known), _type(node[3], known), "int")
    if kind == "ternary":
        return widest(_type(node[2], known), _type(node[3], known))
    return _type(node[3], known)


def widest(*names: str) -> str:
    """The widest of type names (bool < int < float)."""
    return max(names, key=TYPES.index)


@dataclass(frozen=True)
class Script:
    """A parsed script: its code and statements."""

    code: str
    statements: tuple[Ast, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "_fns", tuple(_compile(s) for s in self.statements))

    def run(self, env: Env) -> Any:
        """Execute the statements on ``env`` (an agent's or a group's blackboard view);
        the value of the last one (None after an assignment)."""
        value = None
        with np.errstate(divide="ignore", invalid="ignore"):
            for fn in self._fns:  # type: ignore[attr-defined]
                value = fn(env)
        return value

    def truth(self, env: Env) -> Any:
        """The last statement's value as a bool (or bool array)."""
        return np.asarray(self.run(env), dtype=bool)[()]

    def assigned(self, known: dict[str, str]) -> dict[str, str]:
        """Key -> type name of every key the script assigns (``known``: types so far)."""
        out: dict[str, str] = {}
        for statement in self.statements:
            if statement[0] == "assign":
                name, value_type = statement[2], _type(statement[3], {**known, **out})
                if statement[1] not in (":=", "="):
                    value_type = widest(value_type, known.get(name, "int"), "int")
                    if statement[1] == "/=":
                        value_type = "float"
                out[name] = widest(value_type, out.get(name, value_type))
        return out

    def reads(self) -> set[str]:
        """The keys the script reads."""
        found: set[str] = set()
        stack = list(self.statements)
        while stack:
            node = stack.pop()
            if node[0] == "key":
                found.add(node[1])
            elif node[0] == "assign" and node[1] not in (":=", "="):
                found.add(node[2])
            stack.extend(part for part in node[1:] if isinstance(part, tuple))
        return found


def parse(code: str) -> Script:
    """The :class:`Script` of ``code``; ScriptError (with the column) if it is not one."""
    if not isinstance(code, str):
        raise ScriptError(f"a script is text, got {shown(code)}", 1)
    if len(code) > MAX_SCRIPT_CHARS:
        raise ScriptError(
            f"the script has {len(code)} characters, more than the {MAX_SCRIPT_CHARS} allowed",
            MAX_SCRIPT_CHARS + 1,
        )
    statements = _Parser(code).statements()
    if not statements:
        raise ScriptError("the script is empty", 1)
    return Script(code, tuple(statements))


def _reference(value: Any) -> str | None:
    if isinstance(value, str) and len(value) > 2 and value[0] == "{" and value[-1] == "}":
        return value[1:-1].strip()
    return None


def literal(text: str) -> tuple[Any, str]:
    """A SetBlackboard value: (value, type name); ``{key}`` gives (key, "key")."""
    key = _reference(text)
    if key is not None:
        return key, "key"
    word = text.strip()
    if word in ("true", "false"):
        return word == "true", "bool"
    try:
        return int(word), "int"
    except ValueError:
        pass
    try:
        number = float(word)
    except ValueError:
        return enum_code(word), "int"
    return number, "float"
