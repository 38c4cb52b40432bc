"""Pictures of a tree: PNG/SVG drawn with matplotlib (no Graphviz needed), and Graphviz DOT.

The picture reads like the paper's figures: the root at the top, children left to right in
tick order; control nodes are grey boxes with the paper's symbol (→, R→, ?, R?, ≠) above
their name; conditions are green rounded boxes, actions blue boxes. Long leaf names are
wrapped at their underscores.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pyautonomousagent.bt.spec import Node
from pyautonomousagent.bt.text import symbol
from pyautonomousagent.bt.vocabulary import file_params, leaf_category, tag_of

FONT = 9.0  # points
CHAR = 0.6 * FONT / 72  # inches per character of a monospaced font
LINE = 1.35 * FONT / 72  # inches per line
PAD, GAP, LEVEL = 0.12, 0.18, 0.45  # box padding, gap between boxes, gap between levels
WRAP = 22  # characters per line of a leaf name
COLOURS = {"control": "#e6e6e6", "Condition": "#d5ecd4", "Action": "#d3e3f5"}


def wrap(name: str, width: int = WRAP) -> list[str]:
    """``name`` cut after underscores into lines of at most ``width`` characters (if it can)."""
    lines: list[str] = []
    line = ""
    for part in name.replace("_", "_\0").split("\0"):
        if line and len(line) + len(part) > width:
            lines.append(line)
            line = ""
        line += part
    return [*lines, line] if line else lines


def node_lines(node: Node) -> list[str]:
    """The text in a node's box: symbol and name (and parameters), or a leaf's name and ports."""
    if node.is_control:
        params = [f"{k}={v}" for k, v in file_params(node).items()]
        return [symbol(node), *wrap(node.name), *params]
    return [*wrap(node.name), *(f"{k}={v}" for k, v in node.params.items())]


def legend(root: Node) -> str:
    """One line explaining the symbols and colours the picture of ``root`` uses."""
    seen = {symbol(n): tag_of(n).tag for n in root.walk() if n.is_control}
    parts = [f"{mark} {tag}" for mark, tag in seen.items() if mark != tag]
    return "   ".join([*parts, "green: condition", "blue: action"])


def kind(node: Node) -> str:
    """``"control"``, ``"Condition"`` or ``"Action"`` (the box style)."""
    return "control" if node.is_control else leaf_category(node.type)


@dataclass
class Box:
    """A node's box in the picture, in inches; ``x`` is its centre, ``y`` its top."""

    node: Node
    lines: list[str]
    width: float
    height: float
    children: list[Box] = field(default_factory=list)
    x: float = 0.0
    y: float = 0.0
    span: float = 0.0  # the width its whole subtree needs


def layout(root: Node) -> tuple[Box, float, float]:
    """Boxes for every node, placed; returns the root box and the picture's width and height."""
    box = _measure(root)
    levels = _levels(box, 0)
    deepest = max(depth for _, depth in levels)
    heights = [max(b.height for b, d in levels if d == depth) for depth in range(deepest + 1)]
    tops = [GAP + sum(heights[:d]) + LEVEL * d for d in range(len(heights))]
    _place(box, GAP, 0, tops)
    width = max(b.x + b.width / 2 for b, _ in levels) + GAP
    height = max(b.y + b.height for b, _ in levels) + GAP
    return box, width, height


def _measure(node: Node) -> Box:
    lines = node_lines(node)
    widths = [len(line) * CHAR for line in lines]
    if node.is_control:  # the symbol line is drawn larger
        widths[0] *= (FONT + 2) / FONT
    width = max(widths) + 2 * PAD
    box = Box(node, lines, width, len(lines) * LINE + 2 * PAD)
    box.children = [_measure(child) for child in node.children]
    below = sum(c.span for c in box.children) + GAP * max(len(box.children) - 1, 0)
    box.span = max(box.width, below)
    return box


def _levels(box: Box, depth: int) -> list[tuple[Box, int]]:
    return [(box, depth), *(p for child in box.children for p in _levels(child, depth + 1))]


def _place(box: Box, left: float, depth: int, tops: list[float]) -> None:
    """Put ``box``'s subtree in the band starting at ``left``; parents above their children."""
    box.y = tops[depth]
    if not box.children:
        box.x = left + box.span / 2
        return
    below = sum(c.span for c in box.children) + GAP * (len(box.children) - 1)
    x = left + (box.span - below) / 2
    for child in box.children:
        _place(child, x, depth + 1, tops)
        x += child.span + GAP
    box.x = (box.children[0].x + box.children[-1].x) / 2


def draw_tree(root: Node, path: str | Path, title: str = "") -> Path:
    """Draw ``root`` into ``path`` (PNG or SVG, by its ending) with matplotlib; returns it."""
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyBboxPatch

    box, width, height = layout(root)
    note = legend(root)
    width = max(width, len(note) * CHAR + 2 * GAP)
    top = 0.35 if title else 0.0
    fig = Figure(figsize=(width, height + top + 0.3))
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, width)
    ax.set_ylim(height + top + 0.3, 0)
    ax.axis("off")
    if title:
        ax.text(GAP, 0.2, title, fontsize=FONT + 3, weight="bold", va="center")
    ax.text(GAP, height + top + 0.12, note, fontsize=FONT, va="center", color="#333")
    for b, _ in _levels(box, 0):
        for child in b.children:
            ax.plot([b.x, child.x], [top + b.y + b.height, top + child.y], color="#555", lw=0.8)
        style = "round,pad=0,rounding_size=0.12" if kind(b.node) == "Condition" else "square,pad=0"
        ax.add_patch(
            FancyBboxPatch(
                (b.x - b.width / 2, top + b.y),
                b.width,
                b.height,
                boxstyle=style,
                facecolor=COLOURS[kind(b.node)],
                edgecolor="#333",
                lw=0.8,
            )
        )
        for i, line in enumerate(b.lines):
            bold = b.node.is_control and i == 0
            ax.text(
                b.x,
                top + b.y + PAD + (i + 0.5) * LINE,
                line,
                ha="center",
                va="center",
                family="monospace",
                fontsize=FONT + (2 if bold else 0),
                weight="bold" if bold else "normal",
            )
    path = Path(path)
    fig.savefig(path, dpi=150)
    return path


def to_dot(root: Node, name: str = "tree") -> str:
    """The tree in Graphviz DOT (render with ``dot -Tpng tree.dot -o tree.png``)."""
    out = [
        f'digraph "{name}" {{',
        "  graph [ordering=out];",
        '  node [fontname="Helvetica", fontsize=10, style="filled"];',
    ]
    _dot_node(root, [0], out)
    out.append("}")
    return "\n".join(out) + "\n"


def _dot_node(node: Node, counter: list[int], out: list[str]) -> str:
    """Write ``node`` and its subtree as DOT statements; returns its DOT id."""
    me = f"n{counter[0]}"
    counter[0] += 1
    text = "\\n".join(line.replace('"', '\\"') for line in node_lines(node))
    shape = "ellipse" if kind(node) == "Condition" else "box"
    out.append(f'  {me} [label="{text}", shape={shape}, fillcolor="{COLOURS[kind(node)]}"];')
    for child in node.children:
        out.append(f"  {me} -> {_dot_node(child, counter, out)};")
    return me
