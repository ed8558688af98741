"""Reading a written GIF back: its frame delays and loop count, as a browser sees them."""

from __future__ import annotations

from pathlib import Path

from PIL import Image


def gif_delays(path: str | Path) -> tuple[list[int], int | None]:
    """``(delays, loop)``: the delay of every frame stored in the GIF ``path``, ms, and its
    loop count (0: forever; ``None``: plays once)."""
    with Image.open(path) as im:
        delays = []
        for i in range(im.n_frames):
            im.seek(i)
            delays.append(int(im.info.get("duration", 0)))
        return delays, im.info.get("loop")
