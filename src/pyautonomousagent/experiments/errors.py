"""The error of bad experiment input (its own module: the spec and the designs both raise it)."""

from __future__ import annotations

from pyautonomousagent.inputs import InputError


class ExperimentError(InputError):
    """Bad experiment input; the message names the source, the field and the fix."""
