"""The error of bad experiment input (its own module: the spec and the designs both raise it),
and the hint every "unknown name" message of the experiments gives."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from pyautonomousagent.inputs import InputError


class ExperimentError(InputError):
    """Bad experiment input; the message names the source, the field and the fix."""


def close_hint(name: str, known: Iterable[str]) -> str:
    """``" (did you mean 'X'?)"`` for the known name closest to ``name``, or "" if none is."""
    close = difflib.get_close_matches(name, list(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
