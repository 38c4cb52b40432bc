"""Progress on standard error: a bar on a terminal, or one line per interval in a log.

On a terminal :class:`Progress` redraws ``label [#####.....] done/total`` at most ten times
a second. When the stream is not a terminal (a batch job's log, a file) and ``lines`` is
asked for, it writes one whole line at most every :data:`LINE_SECONDS` seconds or each
:data:`LINE_STEP` of the work, whichever comes first, and one at the end::

    sweep threshold: 12/240 runs (5 %), 31 s, about 9.8 min left
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: Longest time between two progress lines in a log, seconds.
LINE_SECONDS = 10.0
#: Share of the work between two progress lines in a log (5 %).
LINE_STEP = 0.05


class Progress:
    """Progress of ``total`` units of work, as a bar or as lines (see the module docstring).

    Args:
        total: units of work (e.g. iterations, runs).
        label: text before the bar or line.
        enabled: show progress at all; by default when ``stream`` is a terminal, or (with
            ``lines``) always: a bar on a terminal, lines elsewhere.
        stream: where to write (standard error by default).
        lines: write progress lines where ``stream`` is not a terminal.
        unit: what is counted, named in the lines (e.g. ``"runs"``).
        first_line_after: seconds before the first progress line (0: from the first unit);
            work that ends sooner writes no line at all (a short run stays quiet in a log).
    """

    def __init__(
        self,
        total: int,
        label: str = "",
        enabled: bool | None = None,
        stream: TextIO | None = None,
        *,
        lines: bool = False,
        unit: str = "",
        first_line_after: float = 0.0,
    ) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.unit = unit
        self.stream = stream or sys.stderr
        terminal = _is_terminal(self.stream)
        self.enabled = (terminal or lines) if enabled is None else enabled
        self.as_lines = lines and not terminal
        self.done = 0
        self._start = time.perf_counter()
        self._last_draw = 0.0
        self._last_line = self._start
        self._line_done = 0
        self._first_line_after = first_line_after
        self._lines_written = 0

    def update(self, done: int) -> None:
        """Record that ``done`` units are complete; redraw the bar, or write a line, if due."""
        self.done = done
        now = time.perf_counter()
        if not self.enabled:
            return
        if self.as_lines:
            if now - self._start < self._first_line_after:
                return
            step = max(1, int(LINE_STEP * self.total))
            if done - self._line_done >= step or now - self._last_line >= LINE_SECONDS:
                self._write_line(now)
        elif now - self._last_draw >= 0.1 or done >= self.total:
            self._last_draw = now
            self._draw(now)

    def note(self, text: str) -> None:
        """Write ``text`` as a line of its own (on a terminal, above the bar)."""
        if not self.enabled:
            return
        if self.as_lines:
            self.stream.write(f"{text}\n")
        else:
            self.stream.write(f"\r\033[K{text}\n")
            self._draw(time.perf_counter())
        self.stream.flush()

    def _times(self, now: float) -> tuple[float, float, float]:
        """(fraction done, seconds elapsed, seconds left by the rate so far)."""
        fraction = min(self.done / self.total, 1.0)
        elapsed = now - self._start
        eta = elapsed / fraction - elapsed if fraction > 0 else 0.0
        return fraction, elapsed, eta

    def _draw(self, now: float) -> None:
        fraction, elapsed, eta = self._times(now)
        bar = "#" * int(30 * fraction) + "." * (30 - int(30 * fraction))
        self.stream.write(
            f"\r{self.label} [{bar}] {self.done}/{self.total} {elapsed:.0f}s<{eta:.0f}s"
        )
        self.stream.flush()

    def _write_line(self, now: float) -> None:
        fraction, elapsed, eta = self._times(now)
        unit = f" {self.unit}" if self.unit else ""
        left = f", about {_duration(eta)} left" if 0 < fraction < 1 else ""
        self.stream.write(
            f"{self.label}: {self.done}/{self.total}{unit} ({100 * fraction:.0f} %), "
            f"{_duration(elapsed)}{left}\n"
        )
        self.stream.flush()
        self._last_line, self._line_done = now, self.done
        self._lines_written += 1

    def close(self) -> None:
        """End the bar's line, or write the last progress line (if not written yet)."""
        if not self.enabled:
            return
        if self.as_lines:
            late = self._first_line_after > 0 and self._lines_written == 0
            if not late and (self._line_done != self.done or self.done == 0):
                self._write_line(time.perf_counter())
            return
        self._draw(time.perf_counter())
        self.stream.write("\n")
        self.stream.flush()


def _is_terminal(stream: TextIO) -> bool:
    """Whether ``stream`` is a terminal (False for a stream that cannot say)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _duration(seconds: float) -> str:
    """``31 s``, ``9.8 min`` or ``2.1 h``."""
    if seconds < 100:
        return f"{seconds:.0f} s"
    if seconds < 6000:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"
