"""What a mission draws on the world map besides the agents: its marks.

A mission (see :mod:`pyautonomousagent.simulation.mission`) lists its static marks — refuelling
slots, surveillance positions, obstacles, radiation sources — as :class:`Mark` records in world
units. The GIF/MP4 animation and the HTML replay draw the same list, so a new mission needs no
change to either.
"""

from __future__ import annotations

from dataclasses import dataclass

#: The shapes a mark can have.
MARK_SHAPES = ("point", "circle", "rect")


@dataclass(frozen=True)
class Mark:
    """One static mark on the world map.

    Attributes:
        shape: ``"point"`` (a marker drawn with ``symbol``), ``"circle"`` (radius ``size``,
            world units) or ``"rect"`` (lower-left corner at (x, y), ``width`` x ``height``
            world units).
        x, y: position, world units.
        label: text drawn next to it (e.g. ``"R1"``), or "".
        size: a circle's radius (world units); for a point, the marker size in points.
        width, height: a rectangle's extent (world units).
        colour: a Matplotlib/CSS colour.
        fill: whether a circle or rectangle is filled.
        symbol: a point's marker ("x", "o", "+", "*", "^", "s").
        legend: the legend entry for this kind of mark (marks sharing it appear once).
    """

    shape: str
    x: float
    y: float
    label: str = ""
    size: float = 0.0
    width: float = 0.0
    height: float = 0.0
    colour: str = "#444444"
    fill: bool = False
    symbol: str = "x"
    legend: str = ""

    def __post_init__(self) -> None:
        if self.shape not in MARK_SHAPES:
            raise ValueError(
                f"mark shape must be one of {', '.join(MARK_SHAPES)}, got {self.shape!r}"
            )
