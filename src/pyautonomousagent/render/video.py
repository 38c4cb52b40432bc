"""Video files written one frame at a time: GIF (Pillow) or MP4 (H.264 through ffmpeg).

:func:`open_stream` gives a context manager with ``add(pixels)`` and ``frames``; nothing is
kept but the current frame. MP4 needs the ``[video]`` extra (``imageio-ffmpeg``, which ships
an ffmpeg binary); frames are piped to ffmpeg as raw RGB.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from pyautonomousagent.render.gif import GifStream

VIDEO_FORMATS = ("gif", "mp4")
"""The formats :func:`open_stream` writes."""


class VideoError(RuntimeError):
    """A video format that cannot be written here, with the fix in the message."""


class Mp4Stream:
    """H.264 MP4 frames piped to ffmpeg (imageio-ffmpeg's ``write_frames``).

    Args:
        path: the file to write.
        size: (width, height) in pixels; both even (H.264 with yuv420p).
        fps: frames per second.
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float) -> None:
        try:
            import imageio_ffmpeg
        except ImportError:
            raise VideoError(
                "--video mp4 needs imageio-ffmpeg: pip install 'pyautonomousagent[video]'"
            ) from None
        width, height = size
        if width % 2 or height % 2:
            raise VideoError(f"MP4 frames need an even width and height, got {width} x {height}")
        self._writer: Any = imageio_ffmpeg.write_frames(
            str(path),
            size,
            fps=fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            macro_block_size=2,
            quality=7,
            ffmpeg_log_level="error",
        )
        self._writer.send(None)
        self.frames = 0

    def add(self, pixels: np.ndarray) -> None:
        """Append one frame: RGB or RGBA pixels, shape (height, width, 3|4), uint8."""
        self._writer.send(np.ascontiguousarray(pixels[..., :3]).tobytes())
        self.frames += 1

    def close(self) -> None:
        """Finish the file (ffmpeg writes the index and exits)."""
        self._writer.close()


@contextmanager
def open_stream(
    video: str, path: Path, size: tuple[int, int], fps: float
) -> Iterator[GifStream | Mp4Stream]:
    """A frame stream writing ``path`` as ``video`` ("gif" or "mp4") at ``fps`` frames a second.

    GIF delays are whole hundredths: ``100 / fps`` rounded, at least 2.
    """
    if video == "gif":
        with path.open("wb") as file:
            gif = GifStream(file, delay_ms=10 * max(2, round(100 / fps)))
            yield gif
            gif.close()
    elif video == "mp4":
        mp4 = Mp4Stream(path, size, fps)
        try:
            yield mp4
        finally:
            mp4.close()
    else:
        raise VideoError(f"unknown video format {video!r}; use one of {', '.join(VIDEO_FORMATS)}")
