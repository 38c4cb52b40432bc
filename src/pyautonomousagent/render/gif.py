"""Streamed animated GIFs: one fixed colour table, and only what changed per frame.

:class:`GifStream` writes a GIF frame by frame without keeping frames. The first frame's
colours become the one global colour table (:class:`Palette`, 255 colours plus one
transparent entry). Each later frame is stored as the smallest rectangle that differs from
the previous frame, in which unchanged pixels are the transparent entry (disposal "do not
dispose" keeps the previous frame under them): long runs of one index, which LZW packs
tightly. Encoding uses Pillow's GIF helpers and C encoder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, BinaryIO

import numpy as np

if TYPE_CHECKING:
    from PIL import Image

PALETTE_COLOURS = 255
"""Opaque colours in the GIF's single global colour table (taken from the first frame)."""
TRANSPARENT = 255
"""The colour table index of "unchanged: keep the previous frame's pixel"."""


class Palette:
    """A fixed colour table of at most 255 colours, and an exact nearest-colour map onto it.

    Colours are 24-bit codes ``R | G << 8 | B << 16``. The table is built from a sample
    frame: Pillow's median cut groups its colours into 255 clusters, and each cluster is
    represented by its most frequent colour (not the mean), so flat colours such as white
    and the drone blue are kept exactly. Any colour maps to its nearest entry (Euclidean in
    RGB), computed once per colour and memoised in a 2**24-entry table (32 MB, allocated
    lazily by the system). Pillow's own palette mapping is not used: it merges colours up to
    4 levels apart, which turns white into grey.

    Args:
        pixels: the sample frame, RGB or RGBA, shape (height, width, 3|4), uint8.
    """

    def __init__(self, pixels: np.ndarray) -> None:
        from PIL import Image

        rgb = Image.fromarray(np.ascontiguousarray(pixels[..., :3]))
        clusters = np.asarray(rgb.quantize(PALETTE_COLOURS, dither=Image.Dither.NONE))
        keys, counts = np.unique(
            clusters.astype(np.int64) << 24 | colour_codes(pixels), return_counts=True
        )
        keys = keys[np.lexsort((-counts, keys >> 24))]  # by cluster, most frequent first
        first = np.r_[True, keys[1:] >> 24 != keys[:-1] >> 24]
        self.codes = keys[first] & 0xFFFFFF
        self.rgb = _unpack(self.codes)
        self._index = np.zeros(1 << 24, dtype=np.uint16)  # entry + 1; 0: not met yet

    def indices(self, codes: np.ndarray) -> np.ndarray:
        """The table entry of each colour code, uint8 of the same shape."""
        found = self._index[codes]
        missing = found == 0
        if missing.any():
            new = np.unique(codes[missing])
            distance = ((_unpack(new)[:, None, :] - self.rgb[None, :, :]) ** 2).sum(axis=2)
            self._index[new] = distance.argmin(axis=1) + 1
            found = self._index[codes]
        return (found - 1).astype(np.uint8)

    def tobytes(self) -> bytes:
        """The table as ``RGBRGB...`` bytes, 256 entries (unused ones and the transparent
        entry :data:`TRANSPARENT` black)."""
        table = np.zeros((256, 3), dtype=np.uint8)
        table[: len(self.rgb)] = self.rgb
        return table.tobytes()


def colour_codes(pixels: np.ndarray) -> np.ndarray:
    """24-bit codes ``R | G << 8 | B << 16`` of RGB or RGBA pixels (H, W, 3|4) uint8 -> (H, W)."""
    if pixels.shape[-1] == 4 and pixels.flags.c_contiguous:
        return pixels.view("<u4")[..., 0] & 0xFFFFFF
    rgb = pixels[..., :3].astype(np.uint32)
    return rgb[..., 0] | rgb[..., 1] << 8 | rgb[..., 2] << 16


def _unpack(codes: np.ndarray) -> np.ndarray:
    """Colour codes (K,) -> RGB (K, 3) int64."""
    codes = codes.astype(np.int64)
    return np.stack([codes & 0xFF, codes >> 8 & 0xFF, codes >> 16 & 0xFF], axis=1)


class GifStream:
    """Writes an animated, looping GIF one frame at a time, keeping no frames in memory (the
    module docstring says how).

    Args:
        file: a binary file open for writing.
        delay_ms: display time of each frame in milliseconds; GIF stores whole hundredths,
            so a multiple of 10 is exact (others are truncated).
    """

    def __init__(self, file: BinaryIO, delay_ms: float) -> None:
        self.file = file
        self.delay_ms = delay_ms
        self.palette: Palette | None = None
        self.previous: np.ndarray | None = None
        self.frames = 0

    def add(self, pixels: np.ndarray) -> None:
        """Append one frame: RGB or RGBA pixels, shape (height, width, 3|4), uint8.

        Every frame must have the first frame's size.
        """
        from PIL import GifImagePlugin

        if self.palette is None:
            self.palette = Palette(pixels)
        indices = self.palette.indices(colour_codes(pixels))
        previous, self.previous = self.previous, indices
        if previous is None:
            image, offset, extra = self._image(indices), (0, 0), {}
            header, _ = GifImagePlugin.getheader(image, info={"loop": 0})
            self.file.write(b"".join(header))
        else:
            left, top, right, bottom = _changed_box(previous, indices)
            crop = indices[top:bottom, left:right].copy()
            crop[previous[top:bottom, left:right] == crop] = TRANSPARENT
            image, offset, extra = self._image(crop), (left, top), {"transparency": TRANSPARENT}
        chunks = GifImagePlugin.getdata(
            image, offset=offset, duration=self.delay_ms, disposal=1, **extra
        )
        self.file.write(b"".join(chunks))
        self.frames += 1

    def _image(self, indices: np.ndarray) -> Image.Image:
        """A "P" image of palette ``indices`` (H, W) uint8 with the stream's colour table."""
        from PIL import Image

        assert self.palette is not None
        image = Image.fromarray(np.ascontiguousarray(indices))
        image.putpalette(self.palette.tobytes())
        return image

    def close(self) -> None:
        """Write the GIF trailer (the file itself is left open)."""
        self.file.write(b";")


def _changed_box(previous: np.ndarray, current: np.ndarray) -> tuple[int, int, int, int]:
    """The (left, top, right, bottom) pixel box where ``current`` differs from ``previous``;
    one pixel when nothing changed (a GIF frame cannot be empty)."""
    changed = previous != current
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    if rows.size == 0:
        return 0, 0, 1, 1
    return int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1
