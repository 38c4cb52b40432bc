"""Text drawn straight into frame pixels from pre-rendered glyphs (fast animation text).

Matplotlib lays out and rasterises every text anew on every draw, which was two thirds of a
GIF's drawing time. The animation's changing text (panel values, agent labels, event
banners) is monospace, so each character is rendered once, by Matplotlib with the same font,
into a coverage mask of one fixed cell; a line of text is then the masks of its characters
side by side, blended into the pixels with NumPy.
"""

from __future__ import annotations

import numpy as np

CHARSET = "".join(chr(c) for c in range(32, 127))
"""Characters with a glyph (printable ASCII); others are drawn as "?"."""


class GlyphAtlas:
    """Coverage masks of :data:`CHARSET` in one monospace font, size and resolution.

    Args:
        fontsize: points.
        dpi: pixels per inch of the frames drawn into.

    Attributes:
        cell: (height, width) of a character cell in pixels.
        baseline: pixel rows from the top of a cell to the text's baseline.
        masks: coverage per character, shape (len(CHARSET), height, width), float32 in [0, 1].
    """

    def __init__(self, fontsize: float, dpi: float) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.font_manager import FontProperties

        prop = FontProperties(family="monospace", size=fontsize)  # so that cells line up
        figure = Figure(figsize=(1, 1), dpi=dpi)
        canvas = FigureCanvasAgg(figure)
        renderer = canvas.get_renderer()
        width = renderer.get_text_width_height_descent("M" * 20, prop, False)[0]
        _, height, descent = renderer.get_text_width_height_descent("Mgjy|", prop, False)
        cell_w = int(np.ceil(width / 20))
        cell_h = int(np.ceil(height)) + 2
        self.baseline = int(np.ceil(height - descent)) + 1
        count = len(CHARSET)
        figure.set_size_inches(cell_w * count / dpi, cell_h / dpi)
        y = 1 - self.baseline / cell_h
        for i, char in enumerate(CHARSET):
            figure.text(i / count, y, char, fontproperties=prop, va="baseline", color="black")
        canvas.draw()
        gray = np.asarray(canvas.buffer_rgba())[..., 0].astype(np.float32)
        strip = 1.0 - gray / 255.0  # (cell_h, cell_w * count)
        self.cell = (cell_h, cell_w)
        self.masks = np.ascontiguousarray(
            strip[:cell_h, : cell_w * count].reshape(cell_h, count, cell_w).transpose(1, 0, 2)
        )
        self._codes = np.full(128, CHARSET.index("?"), dtype=np.intp)
        self._codes[32:127] = np.arange(count)

    def width(self, text: str) -> int:
        """The width of ``text`` in pixels."""
        return len(text) * self.cell[1]

    def draw(
        self,
        pixels: np.ndarray,
        text: str,
        x: float,
        y: float,
        colour: tuple[int, int, int],
        anchor: str = "baseline",
    ) -> None:
        """Blend ``text`` in ``colour`` into ``pixels`` (H, W, 3|4 uint8, modified in place),
        clipped to the frame.

        Args:
            x: the left edge, pixels from the left.
            y: pixels from the top: of the baseline (``anchor="baseline"``) or of the cell's
                top (``anchor="top"``).
        """
        if not text:
            return
        codes = self._codes[np.frombuffer(text.encode("ascii", "replace"), np.uint8)]  # < 128
        mask = self.masks[codes].transpose(1, 0, 2).reshape(self.cell[0], -1)  # (h, width(text))
        top = int(round(y)) - (self.baseline if anchor == "baseline" else 0)
        left = int(round(x))
        height, width = pixels.shape[:2]
        t, b = max(top, 0), min(top + mask.shape[0], height)
        lft, r = max(left, 0), min(left + mask.shape[1], width)
        if t >= b or lft >= r:
            return
        cover = mask[t - top : b - top, lft - left : r - left, None]
        region = pixels[t:b, lft:r, :3].astype(np.float32)
        region += (np.asarray(colour, dtype=np.float32) - region) * cover
        pixels[t:b, lft:r, :3] = np.rint(region).astype(np.uint8)
