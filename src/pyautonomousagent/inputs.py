"""Reading untrusted input safely: bounded files, a guarded YAML loader, finite numbers.

Everything a user hands the tool (scenario files, tree files, ``--set`` values, API
arguments) goes through these checks before anything is built from it, so a small file can
never make the tool hang, exhaust memory or overflow the stack, and every refusal is one
:class:`InputError` line naming the file, line or field and the fix. The YAML
:class:`Loader` refuses duplicate keys, deep nesting and alias bombs, and types plain
scalars by YAML 1.2's core schema (``1:30`` and ``yes`` are text; ``010`` is ten).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

if TYPE_CHECKING:
    import pyarrow as pa

#: Largest scenario or tree file read, bytes (the packaged ones are about 3 KB).
MAX_FILE_BYTES = 2_000_000
#: Deepest nesting of YAML mappings and lists.
MAX_YAML_DEPTH = 200
#: Most YAML nodes a document may have with every alias expanded.
MAX_YAML_NODES = 1_000_000
#: Longest value echoed in a message, characters.
MAX_SHOWN = 80
#: Longest message printed, characters (a backstop: the middle is cut).
MAX_MESSAGE = 600


class InputError(ValueError):
    """Bad input: the message names the file, line or field, and what to do."""


def shown(value: Any, limit: int = MAX_SHOWN) -> str:
    """``repr(value)``, cut to ``limit`` characters with the full length noted.

    The repr is computed from a cut copy of long strings and containers, so a huge value
    (an expanded YAML alias, a 10 MB port) costs nothing to show.
    """
    if isinstance(value, str) and len(value) > limit:
        return f"{value[:limit]!r}... ({len(value)} characters)"
    if isinstance(value, list | tuple | dict) and len(value) > 8:
        return f"a {type(value).__name__} of {len(value)} items"
    text = repr(value)
    if len(text) > limit:
        return f"{text[:limit]}... ({len(text)} characters)"
    return text


def cut(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` if it has at most ``limit`` characters, else its start and end around
    ``...`` (so a message quoting a huge value stays readable)."""
    if len(text) <= limit:
        return text
    keep = (limit - 5) // 2
    return f"{text[:keep]} ... {text[-keep:]}"


def clip(message: str, limit: int = MAX_MESSAGE) -> str:
    """``message`` on one line and at most ``limit`` characters (the middle is cut)."""
    return cut(" ".join(message.split()), limit)


def finite(value: Any) -> bool:
    """Whether ``value`` is an int, or a float that is neither NaN nor infinite."""
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return True
    return isinstance(value, float) and math.isfinite(value)


def read_text(path: str | Path, what: str, limit: int = MAX_FILE_BYTES) -> str:
    """The text of the file at ``path`` (a ``what``, e.g. "scenario file").

    Raises:
        InputError: the file cannot be read, is larger than ``limit`` bytes, or is not UTF-8.
    """
    path = Path(path)
    try:
        with path.open("rb") as file:
            data = file.read(limit + 1)
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise InputError(f"cannot read {what} {path}: {reason}; check the path") from None
    return decode_text(data, str(path), what, limit)


def decode_text(data: bytes, name: str, what: str, limit: int = MAX_FILE_BYTES) -> str:
    """``data`` (the content of ``name``, a ``what``) as text, with :func:`read_text`'s
    checks: for content that arrives otherwise than as a file (an upload).

    Raises:
        InputError: ``data`` is larger than ``limit`` bytes, or is not UTF-8.
    """
    if len(data) > limit:
        raise InputError(
            f"{name}: the {what} is larger than {limit // 1000} KB; "
            "a scenario or tree file is a few KB, check that this is the right file"
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data[: error.start].count(b"\n") + 1
        raise InputError(
            f"{name}:{line}: the {what} is not UTF-8 text (byte {error.start}); save it as UTF-8"
        ) from None


class Loader(yaml.SafeLoader):
    """PyYAML's safe loader with limits: duplicate keys, nesting depth and alias expansion.

    Errors are raised as :class:`YamlLimitError` (a ``yaml.MarkedYAMLError``) with the
    line, while the document is composed, before any value is built.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0
        self._sizes: dict[int, int] = {}

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        if self.check_event(yaml.AliasEvent):
            self._check_alias(self.peek_event())
        self._depth += 1
        if self._depth > MAX_YAML_DEPTH:
            raise YamlLimitError(
                self.peek_event().start_mark,
                f"nested more than {MAX_YAML_DEPTH} levels deep",
                "nest lists and mappings less deeply",
            )
        node = super().compose_node(parent, index)
        self._depth -= 1
        if node is not None and id(node) not in self._sizes:
            self._sizes[id(node)] = self._size(node)
        return node

    def _check_alias(self, event: Any) -> None:
        """Refuse an alias to a node still being composed: one that holds the alias itself
        (``a: &x [*x]``), which would make a value that contains itself."""
        node = self.anchors.get(event.anchor)
        if node is not None and id(node) not in self._sizes:  # sized once composed
            raise YamlLimitError(
                event.start_mark,
                f"alias *{event.anchor} refers to the value that contains it",
                "a value cannot include itself; write the inner value out",
            )

    def _size(self, node: yaml.Node) -> int:
        """Nodes in ``node`` with every alias expanded; refuses a key given twice."""
        size = 1
        if isinstance(node, yaml.SequenceNode):
            size += sum(self._sizes.get(id(item), 1) for item in node.value)
        elif isinstance(node, yaml.MappingNode):
            seen: dict[Any, int] = {}
            for key, value in node.value:
                size += self._sizes.get(id(key), 1) + self._sizes.get(id(value), 1)
                if isinstance(key, yaml.ScalarNode) and key.tag != "tag:yaml.org,2002:merge":
                    ident = (key.tag, key.value)
                    if ident in seen:
                        raise YamlLimitError(
                            key.start_mark,
                            f"key {shown(key.value)} is given twice (lines {seen[ident]} and "
                            f"{key.start_mark.line + 1})",
                            "keep one of them",
                        )
                    seen[ident] = key.start_mark.line + 1
        if size > MAX_YAML_NODES:
            raise YamlLimitError(
                node.start_mark,
                f"aliases (*name) expand the document beyond {MAX_YAML_NODES} values",
                "write the values out instead of nesting aliases",
            )
        return size


#: YAML 1.2 core schema's numbers (YAML 1.1's base-60 ``1:30``, octal ``010`` and ``1_000``
#: are not numbers: they stay text, for the schema of the field to judge).
_INT = r"[-+]?[0-9]+"
_INT_BASED = r"0o[0-7]+|0x[0-9a-fA-F]+"
_FLOAT = r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
_SPECIAL = {".inf": math.inf, "+.inf": math.inf, "-.inf": -math.inf, ".nan": math.nan}
#: Plain scalars typed by the core schema: tag, pattern, first characters. Dates keep
#: YAML 1.1's timestamp rule, so that an impossible date is refused, not read as text.
_CORE_SCHEMA = (
    ("tag:yaml.org,2002:bool", r"true|True|TRUE|false|False|FALSE", "tTfF"),
    ("tag:yaml.org,2002:int", f"{_INT}|{_INT_BASED}", "-+0123456789"),
    (
        "tag:yaml.org,2002:float",
        rf"{_FLOAT}|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)",
        "-+.0123456789",
    ),
    ("tag:yaml.org,2002:null", r"~|null|Null|NULL|", ["~", "n", "N", ""]),
    ("tag:yaml.org,2002:merge", r"<<", "<"),
)


def _scalar(loader: yaml.SafeLoader, node: yaml.Node, pattern: str, what: str) -> str:
    """The text of a scalar node; ConstructorError unless it matches ``pattern``."""
    text = str(loader.construct_scalar(node))  # type: ignore[arg-type]
    if not re.fullmatch(pattern, text):
        raise yaml.constructor.ConstructorError(
            None, None, f"{shown(text)} is not {what}", node.start_mark
        )
    return text


def _core_int(loader: yaml.SafeLoader, node: yaml.Node) -> int:
    """An int as YAML 1.2 writes it (``10``, ``0o17``, ``0x1F``), even tagged ``!!int``."""
    text = _scalar(loader, node, f"{_INT}|{_INT_BASED}", "a YAML 1.2 whole number")
    return int(text, {"0o": 8, "0x": 16}.get(text[:2], 10))  # int() takes 0o17 in base 8


def _core_float(loader: yaml.SafeLoader, node: yaml.Node) -> float:
    """A float as YAML 1.2 writes it (``2.5``, ``1e3``, ``.inf``, ``.nan``)."""
    text = str(loader.construct_scalar(node))  # type: ignore[arg-type]
    if text.lower() in _SPECIAL:
        return _SPECIAL[text.lower()]
    return float(_scalar(loader, node, _FLOAT, "a YAML 1.2 number"))


def _core_bool(loader: yaml.SafeLoader, node: yaml.Node) -> bool:
    """true or false, even tagged ``!!bool``; never YAML 1.1's yes/no/on/off."""
    text = _scalar(loader, node, "(?i:true|false)", "true or false")
    return text.lower() == "true"


def _core_schema(loader: type[yaml.SafeLoader]) -> None:
    """Type ``loader``'s plain scalars by YAML 1.2's core schema (dates as YAML 1.1)."""
    timestamps = [
        (first, resolver)
        for first, found in yaml.SafeLoader.yaml_implicit_resolvers.items()
        for resolver in found
        if resolver[0] == "tag:yaml.org,2002:timestamp"
    ]
    loader.yaml_implicit_resolvers = {}
    for tag, pattern, first in _CORE_SCHEMA:
        loader.add_implicit_resolver(tag, re.compile(f"^(?:{pattern})$"), list(first))
    for first, (tag, regexp) in timestamps:
        loader.add_implicit_resolver(tag, regexp, [first])
    loader.add_constructor("tag:yaml.org,2002:int", _core_int)
    loader.add_constructor("tag:yaml.org,2002:float", _core_float)
    loader.add_constructor("tag:yaml.org,2002:bool", _core_bool)


_core_schema(Loader)


class YamlLimitError(yaml.MarkedYAMLError):
    """A YAML document over one of :class:`Loader`'s limits."""

    def __init__(self, mark: yaml.Mark, problem: str, fix: str) -> None:
        super().__init__(problem=problem, problem_mark=mark)
        self.fix = fix


def yaml_error_line(error: yaml.YAMLError) -> tuple[int, str]:
    """The 1-based line (0 if unknown) and the problem of a PyYAML error, without PyYAML's
    multi-line context."""
    if isinstance(error, yaml.MarkedYAMLError):
        mark = error.problem_mark or error.context_mark
        problem = error.problem or error.context or "not valid YAML"
        return (mark.line + 1 if mark else 0), problem
    return 0, str(error).splitlines()[0] if str(error) else "not valid YAML"


def load_yaml(text: str, file: str) -> Any:
    """The YAML document in ``text`` (from ``file``), read by :class:`Loader`.

    Raises:
        InputError: ``file:line: problem; fix``, one line.
    """
    loader = None
    try:
        loader = Loader(text)
        return loader.get_single_data()
    except YamlLimitError as error:
        line, problem = yaml_error_line(error)
        raise InputError(f"{file}:{line}: {problem}; {error.fix}") from None
    except yaml.constructor.ConstructorError as error:  # a tag: !!python/..., !!int x
        line, problem = yaml_error_line(error)
        raise InputError(
            f"{file}:{line}: not valid YAML ({problem}); write plain values (numbers, text, "
            "true/false, lists, mappings): tags such as !!python are not read"
        ) from None
    except yaml.YAMLError as error:
        line, problem = yaml_error_line(error)
        raise InputError(
            f"{file}:{line}: not valid YAML ({problem}); check the indentation, the ': ' "
            "after each key and the quotes near this line"
        ) from None
    except (ValueError, OverflowError, TypeError) as error:  # e.g. a date 2024-02-30
        raise InputError(f"{file}: a value cannot be read ({clip(str(error), 120)})") from None
    finally:
        if loader is not None:
            loader.dispose()


def load_json(text: str, file: str) -> Any:
    """The JSON document in ``text`` (from ``file``).

    Raises:
        InputError: ``file:line: not valid JSON (problem)``, one line.
    """
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise InputError(
            f"{file}:{error.lineno}: not valid JSON ({error.msg} at column {error.colno}); "
            "the file is damaged or not the one pyaa wrote"
        ) from None
    except RecursionError:
        raise InputError(f"{file}: not valid JSON (nested too deeply)") from None


def read_parquet(path: str | Path, what: str, columns: Iterable[str] = ()) -> pa.Table:
    """The table in the Parquet file at ``path`` (a ``what``), which must have ``columns``.

    Only the file's footer is read to check the columns, before any data.

    Raises:
        InputError: the file cannot be read, is not Parquet (truncated, damaged) or lacks
            one of ``columns``.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    errors = (OSError, pa.ArrowException, ValueError)
    try:
        names = pq.read_schema(path).names
    except errors as error:
        raise _unreadable(path, what, error) from None
    missing = [name for name in columns if name not in names]
    if missing:
        raise InputError(
            f"{path}: the {what} has no column {shown(missing[0])}; give a {what} that pyaa wrote"
        )
    try:
        return pq.read_table(path)
    except errors as error:
        raise _unreadable(path, what, error) from None


def _unreadable(path: Path, what: str, error: Exception) -> InputError:
    """One line: the file at ``path`` (a ``what``) cannot be read, and why."""
    reason = clip(str(error) or type(error).__name__, 160)
    return InputError(
        f"{path}: the {what} cannot be read ({reason}); it is damaged or not a Parquet file"
    )


def plain_value(text: str) -> Any:
    """``text`` typed as a plain YAML 1.2 scalar, by the same rules as :class:`Loader`:
    true/false, a whole number, a number, null (None), else the text itself (a command-line
    value: ``30`` is a number, ``1:30`` and ``yes`` are text).

    Raises:
        InputError: the text looks like a value that cannot be built (an impossible date).
    """
    loader = Loader("")
    try:
        tag = loader.resolve(yaml.ScalarNode, text, (True, False))
        return loader.construct_object(yaml.ScalarNode(tag, text))
    except (yaml.YAMLError, ValueError, OverflowError) as error:
        raise InputError(f"{shown(text)} cannot be read ({clip(str(error), 120)})") from None
    finally:
        loader.dispose()
