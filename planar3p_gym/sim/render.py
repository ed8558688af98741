"""pygame drawing of the mechanism (used by ``Planar3PEnv.render`` and by the scripts).

Draws the rails with their strokes, sliders, legs, platform, gripper and the target; makes
singularity proximity visible: each leg's line is extended across the view (where the three
lines meet, or run parallel, the platform is singular) and the legs are coloured from green
(far) to red (near) by the parallel margin, outlined in orange near a serial singularity.
Works headless (``SDL_VIDEODRIVER=dummy``) for ``rgb_array``.

- :class:`Renderer` draws a :class:`Frame`, with its status as a table in the corner (labels
  in one column, values right-aligned in the next; :func:`overlay_layout`).
- :func:`with_title` puts a title line (the policy and the id) above a rendered picture.
- :func:`default_video_driver` picks SDL's ``dummy`` video driver where no display exists,
  before pygame starts its display (SDL would print ``XDG_RUNTIME_DIR is invalid``).
"""

from __future__ import annotations

import math
import os
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planar3p_gym.machine.design import Design

__all__ = [
    "TITLE_HEIGHT",
    "Frame",
    "Renderer",
    "default_video_driver",
    "overlay_layout",
    "split_row",
    "with_title",
]


@dataclass(frozen=True)
class Frame:
    """What one picture shows (SI units).

    Attributes:
        rho: slider travels (m).
        pose: platform pose ``(x, y, theta)`` (m, m, rad).
        target: target pose, or ``None``.
        parallel_margin: in ``[0, 1]``.
        serial_margin: in ``[0, 1]``.
        time: simulated time (s).
        text: extra status lines drawn in the corner.
        forces: actuator forces (N), or ``None``.
    """

    rho: tuple[float, float, float]
    pose: tuple[float, float, float]
    target: tuple[float, float, float] | None
    parallel_margin: float
    serial_margin: float
    time: float = 0.0
    text: tuple[str, ...] = ()
    forces: tuple[float, float, float] | None = None

    @classmethod
    def of_info(cls, info: dict, target: tuple[float, float, float] | None) -> Frame:
        """The frame of an environment step's ``info`` (its pose, travels, margins, time,
        forces and errors; defaults before the first reset) and the ``target`` pose."""
        pos_err = info.get("position_error", 0.0)
        ang_err = info.get("orientation_error", 0.0)
        return cls(
            rho=info.get("rho", (0.0, 0.0, 0.0)),
            pose=info.get("pose", (0.0, 0.0, 0.0)),
            target=target,
            parallel_margin=info.get("parallel_margin", 1.0),
            serial_margin=info.get("serial_margin", 1.0),
            time=info.get("time", 0.0),
            text=(
                f"position error {1000 * pos_err:6.1f} mm",
                f"orientation error {math.degrees(ang_err):6.1f} deg",
            ),
            forces=info.get("actuator_forces"),
        )


_BG = (250, 250, 247)
_GRID = (232, 232, 228)
_RAIL_COLOURS = ((70, 110, 200), (60, 160, 120), (190, 120, 60))
_INK = (40, 40, 40)
_TARGET = (150, 80, 200)
_PLATFORM = (55, 60, 85)
#: Font size of the overlay and the title, pixels.
_FONT_PX = 18
#: Height of the title line :func:`with_title` adds, pixels.
TITLE_HEIGHT = 20
#: Gap between the label and the value columns, and the table's inner margin, pixels.
_GAP, _PAD, _LINE = 10, 4, 16
#: A status line "label value": the value starts at the first number.
_ROW = re.compile(r"^(?P<label>.*?)\s*(?P<value>[-+]?\.?\d.*)$")


def default_video_driver() -> None:
    """Set ``SDL_VIDEODRIVER=dummy`` on a Unix without a display (neither ``DISPLAY`` nor
    ``WAYLAND_DISPLAY``), unless a driver is already chosen: SDL would probe X11 and Wayland
    first and print ``error: XDG_RUNTIME_DIR is invalid`` before falling back. Nothing can
    be shown there anyway; it has to run before pygame starts its display."""
    if sys.platform in ("win32", "darwin"):
        return
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


def split_row(line: str) -> tuple[str, str]:
    """``(label, value)`` of a status line, split where its value (the first number) starts:
    ``"position error   12.3 mm"`` gives ``("position error", "12.3 mm")``; a line without a
    number is all label."""
    m = _ROW.match(line.strip())
    if m is None or not m.group("label"):
        return line.strip(), ""
    return m.group("label"), m.group("value")


def overlay_layout(
    rows: Sequence[tuple[str, str]], width_of: Callable[[str], int], x0: int = 8, y0: int = 6
) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Where the status table's text goes: for every ``(label, value)`` row, the top-left
    pixel of the label and of the value. Labels start at ``x0``; values are right-aligned
    on one edge, at least :data:`_GAP` pixels right of the widest label; rows are
    :data:`_LINE` pixels apart from ``y0``. ``width_of`` gives a text's width in pixels."""
    label_w = max((width_of(label) for label, _ in rows), default=0)
    value_w = max((width_of(value) for _, value in rows), default=0)
    right = x0 + label_w + _GAP + value_w
    return [
        ((x0, y0 + _LINE * n), (right - width_of(value), y0 + _LINE * n))
        for n, (_, value) in enumerate(rows)
    ]


def _font(pygame: Any) -> Any:
    """The overlay's font (pygame's default face at :data:`_FONT_PX`)."""
    pygame.font.init()
    return pygame.font.SysFont(None, _FONT_PX)


def with_title(picture: np.ndarray, title: str) -> np.ndarray:
    """``picture`` (an ``(H, W, 3)`` uint8 frame) with a title line of :data:`TITLE_HEIGHT`
    pixels above it (``(H + TITLE_HEIGHT, W, 3)``), e.g. the policy and the id of a
    recorded episode; the title is cut at the picture's width."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    w = picture.shape[1]
    band = pygame.Surface((w, TITLE_HEIGHT))
    band.fill(_PLATFORM)
    img = _font(pygame).render(title, True, _BG)
    band.blit(img, (8, (TITLE_HEIGHT - img.get_height()) // 2))
    top = np.transpose(pygame.surfarray.array3d(band), (1, 0, 2))
    return np.concatenate([top, np.asarray(picture, dtype=np.uint8)], axis=0)


def _margin_colour(margin: float, ref: float = 0.05) -> tuple[int, int, int]:
    """Green at ``margin >= ref`` fading to red at 0."""
    t = max(0.0, min(1.0, margin / ref))
    return (int(220 * (1 - t) + 40 * t), int(50 * (1 - t) + 170 * t), int(50 * (1 - t) + 70 * t))


class Renderer:
    """Draws :class:`Frame` s of a design onto a pygame surface.

    Args:
        design: the machine.
        size: picture size in pixels ``(width, height)``.
        mode: ``"rgb_array"`` (off-screen) or ``"human"`` (a window).
        fps: frame rate of the human window (frames/s).
    """

    def __init__(
        self,
        design: Design,
        size: tuple[int, int] = (640, 480),
        mode: str = "rgb_array",
        fps: int = 50,
    ) -> None:
        if mode not in ("rgb_array", "human"):
            raise ValueError(f"render mode must be 'rgb_array' or 'human', got {mode!r}")
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        default_video_driver()
        import pygame  # local import: rendering is optional at run time

        self._pg = pygame
        self.design = design
        self.size = size
        self.mode = mode
        self.fps = fps
        self._font = _font(pygame)
        self._window = None
        self._clock = None
        if mode == "human":
            pygame.display.init()
            self._window = pygame.display.set_mode(size)
            pygame.display.set_caption("Planar3P-v0")
            self._clock = pygame.time.Clock()
        self.surface = pygame.Surface(size)
        # World view: the search rectangle mirrored below the rails, with a margin.
        x0, x1, _, h = design.search_rectangle
        reach = max(design.leg_lengths)
        wx0, wx1, wy0, wy1 = x0, x1, -0.45 * reach, h + 0.05 * reach
        scale = min(size[0] / (wx1 - wx0), size[1] / (wy1 - wy0))
        self._scale = scale
        self._ox = 0.5 * (size[0] - scale * (wx1 + wx0))
        self._oy = 0.5 * (size[1] + scale * (wy1 + wy0))

    def to_screen(self, x: float, y: float) -> tuple[int, int]:
        """Pixel coordinates of the world point ``(x, y)`` (m)."""
        return (int(round(self._ox + self._scale * x)), int(round(self._oy - self._scale * y)))

    def draw(self, frame: Frame) -> None:
        """Draw ``frame`` onto :attr:`surface`."""
        pg, surf, d = self._pg, self.surface, self.design
        surf.fill(_BG)
        self._draw_grid()
        k = d.joint_offsets
        x, y, th = frame.pose
        c, s = math.cos(th), math.sin(th)
        px = max(2, int(0.012 * self._scale))
        # Rails and stroke segments, slightly apart so the three planes are visible.
        for i in range(3):
            a = d.rail_origins[i]
            off = (i - 1) * 3
            p0, p1 = self.to_screen(a, 0.0), self.to_screen(a + d.stroke, 0.0)
            pg.draw.line(surf, _RAIL_COLOURS[i], (p0[0], p0[1] + off), (p1[0], p1[1] + off), 2)
            for p in (p0, p1):
                pg.draw.line(surf, _INK, (p[0], p[1] - 6), (p[0], p[1] + 6), 1)
        if frame.target is not None:
            self._draw_platform(frame.target, _TARGET, ghost=True)
        pcol = _margin_colour(frame.parallel_margin)
        for i in range(3):
            b = (d.rail_origins[i] + frame.rho[i], 0.0)
            cpt = (x + k[i] * c, y + k[i] * s)
            self._draw_leg_line(b, cpt, pcol)
        for i in range(3):
            b = (d.rail_origins[i] + frame.rho[i], 0.0)
            cpt = (x + k[i] * c, y + k[i] * s)
            ux, uy = cpt[0] - b[0], cpt[1] - b[1]
            near_serial = abs(ux) / max(math.hypot(ux, uy), 1e-12) < 0.1
            if near_serial:
                pg.draw.line(surf, (255, 150, 0), self.to_screen(*b), self.to_screen(*cpt), px + 4)
            pg.draw.line(surf, pcol, self.to_screen(*b), self.to_screen(*cpt), px)
            sb = self.to_screen(*b)
            rect = pg.Rect(0, 0, 4 * px, 2 * px)
            rect.center = sb
            pg.draw.rect(surf, _RAIL_COLOURS[i], rect)
            pg.draw.circle(surf, _INK, sb, px // 2 + 2)
        self._draw_platform(frame.pose, _PLATFORM, ghost=False)
        self._draw_text(frame)

    def _draw_grid(self) -> None:
        pg, surf = self._pg, self.surface
        step = 0.05
        x0, x1, _, h = self.design.search_rectangle
        for gx in np.arange(math.floor(x0 / step) * step, x1 + step, step):
            pg.draw.line(surf, _GRID, self.to_screen(gx, -h), self.to_screen(gx, 2 * h), 1)
        for gy in np.arange(-h, 2 * h, step):
            pg.draw.line(surf, _GRID, self.to_screen(x0 - h, gy), self.to_screen(x1 + h, gy), 1)
        pg.draw.line(surf, (200, 200, 195), self.to_screen(x0 - h, 0), self.to_screen(x1 + h, 0), 1)

    def _draw_leg_line(
        self, b: tuple[float, float], c: tuple[float, float], colour: tuple[int, int, int]
    ) -> None:
        """The leg's line extended across the view (thin): singularities show as the three
        lines meeting in one point or running parallel."""
        ux, uy = c[0] - b[0], c[1] - b[1]
        n = math.hypot(ux, uy)
        if n == 0:
            return
        ux, uy = ux / n, uy / n
        far = 4.0 * (self.size[0] + self.size[1]) / self._scale
        light = tuple(int(0.35 * v + 0.65 * 255) for v in colour)
        p0 = self.to_screen(b[0] - far * ux, b[1] - far * uy)
        p1 = self.to_screen(b[0] + far * ux, b[1] + far * uy)
        self._pg.draw.line(self.surface, light, p0, p1, 1)

    def _draw_platform(
        self, pose: tuple[float, float, float], colour: tuple[int, int, int], ghost: bool
    ) -> None:
        pg, surf, k = self._pg, self.surface, self.design.joint_offsets
        x, y, th = pose
        c, s = math.cos(th), math.sin(th)
        px = max(2, int(0.012 * self._scale))
        g = self.to_screen(x, y)
        c1 = self.to_screen(x + k[0] * c, y + k[0] * s)
        width = max(1, px // 2) if ghost else px + 2
        pg.draw.line(surf, colour, g, c1, width)
        for ki in k:
            pg.draw.circle(
                surf,
                colour if ghost else _INK,
                self.to_screen(x + ki * c, y + ki * s),
                px // 2 + 2,
                0 if not ghost else 1,
            )
        # Gripper: two jaws opening away from the platform at G.
        jaw = 0.018
        for sign in (1.0, -1.0):
            base = (x - sign * 0.5 * jaw * s, y + sign * 0.5 * jaw * c)
            tip = (base[0] - jaw * c, base[1] - jaw * s)
            pg.draw.line(
                surf, colour, self.to_screen(*base), self.to_screen(*tip), max(1, width - 1)
            )
        pg.draw.line(
            surf,
            colour,
            self.to_screen(x - 0.5 * jaw * s, y + 0.5 * jaw * c),
            self.to_screen(x + 0.5 * jaw * s, y - 0.5 * jaw * c),
            max(1, width - 1),
        )
        if ghost:
            r = 5
            pg.draw.line(surf, colour, (g[0] - r, g[1]), (g[0] + r, g[1]), 1)
            pg.draw.line(surf, colour, (g[0], g[1] - r), (g[0], g[1] + r), 1)

    def _rows(self, frame: Frame) -> list[tuple[str, str]]:
        """The status table: time, margins, forces, then the frame's own lines."""
        rows = [
            ("t", f"{frame.time:.2f} s"),
            ("parallel margin", f"{frame.parallel_margin:.3f}"),
            ("serial margin", f"{frame.serial_margin:.3f}"),
        ]
        if frame.forces is not None:
            rows.append(("forces", " ".join(f"{f:.1f}" for f in frame.forces) + " N"))
        rows.extend(split_row(line) for line in frame.text)
        return rows

    def _draw_text(self, frame: Frame) -> None:
        """The status table on a light box, so that the lines behind it do not cross it."""
        pg, font = self._pg, self._font
        rows = self._rows(frame)
        places = overlay_layout(rows, lambda t: font.size(t)[0] if t else 0)
        right = max(vx + font.size(v)[0] for (_, (vx, _)), (_, v) in zip(places, rows, strict=True))
        box = pg.Surface((right - 8 + 2 * _PAD, _LINE * len(rows) + 2 * _PAD), pg.SRCALPHA)
        box.fill((*_BG, 215))
        self.surface.blit(box, (8 - _PAD, 6 - _PAD))
        for ((lx, ly), (vx, vy)), (label, value) in zip(places, rows, strict=True):
            self.surface.blit(font.render(label, True, _INK), (lx, ly))
            if value:
                self.surface.blit(font.render(value, True, _INK), (vx, vy))

    def render(self, frame: Frame) -> np.ndarray | None:
        """Draw ``frame``; return an ``(H, W, 3)`` uint8 array (``rgb_array``) or show it."""
        self.draw(frame)
        if self.mode == "human":
            assert self._window is not None and self._clock is not None
            self._pg.event.pump()
            self._window.blit(self.surface, (0, 0))
            self._pg.display.flip()
            self._clock.tick(self.fps)
            return None
        return np.transpose(self._pg.surfarray.array3d(self.surface), (1, 0, 2)).copy()

    def close(self) -> None:
        """Close the window, if any."""
        if self._window is not None:
            self._pg.display.quit()
            self._window = None
