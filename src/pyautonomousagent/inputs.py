"""Reading untrusted input safely: bounded files, a guarded YAML loader, finite numbers.

Everything a user hands the tool (scenario files, tree files, ``--set`` values, API
arguments) goes through these checks before anything is built from it, so a small file can
never make the tool hang, exhaust memory or overflow the stack, and every refusal is one
line naming the file, line or field and the fix:

- :func:`read_text`: at most :data:`MAX_FILE_BYTES`, UTF-8 only;
- :class:`Loader`: PyYAML's safe loader, plus: a key given twice is an error, nesting is at
  most :data:`MAX_YAML_DEPTH` levels, and aliases may not expand the document beyond
  :data:`MAX_YAML_NODES` nodes ("billion laughs");
- :func:`load_yaml`: the whole document with those limits, errors as :class:`InputError`;
- :func:`shown`: a value for a message, cut to :data:`MAX_SHOWN` characters;
- :func:`finite`: a number that is neither NaN nor infinite.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

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
    if len(data) > limit:
        raise InputError(
            f"{path}: the {what} is larger than {limit // 1000} KB; "
            "a scenario or tree file is a few KB, check that this is the right file"
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data[: error.start].count(b"\n") + 1
        raise InputError(
            f"{path}:{line}: the {what} is not UTF-8 text (byte {error.start}); save it as UTF-8"
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
