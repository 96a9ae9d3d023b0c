"""Text placed where it collides with nothing: a draughtsman's rule that no text lies over
another text, a line or a symbol.

The :class:`Placer` knows the drawing's lines (walls, door leaves and swings, windows,
dimension lines, annotation markers) in plan coordinates and the boxes of the texts placed so
far; a text is tried at candidate places (and sizes) and kept at the first free one. Text
extents come from the figure's renderer, so they are what the PNG, SVG and PDF show.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

#: Clearance kept around a text (points of paper): texts and lines this close count as touching.
CLEARANCE_PT = 0.6


def halo(width: float = 2.2):
    """A white outline under a text, so that it reads over ink and hatching."""
    from matplotlib import patheffects

    return [patheffects.withStroke(linewidth=width, foreground="white")]


def tag(text, role: str):
    """Mark a text with what it is (``meshplan_role``: room-label, dimension,
    annotation-label), for tests and tools to find; not an SVG id, which must stay unique."""
    text.meshplan_role = role
    return text


def renderer_of(fig):
    """The Agg renderer of ``fig`` (made once), to measure texts with: the one the figure is
    then drawn with (:class:`meshplan.render.vector.PlanCanvas`), which measures each text once."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from .vector import PlanCanvas

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else PlanCanvas(fig)
    return canvas.get_renderer()


class Placer:
    """Boxes of placed texts and the lines they must not cross, in plan coordinates."""

    def __init__(self, fig, ax, lines: Iterable[shapely.Geometry]):
        self.fig, self.ax = fig, ax
        self.renderer = renderer_of(fig)
        self.lines = [g for g in lines if g is not None and not g.is_empty]
        self.tree = shapely.STRtree(self.lines)
        self.extra: list[shapely.Geometry] = []  # lines added after the tree was made
        self.boxes: list[shapely.Geometry] = []
        self._to_data = ax.transData.inverted()
        self._pad_px = CLEARANCE_PT * fig.dpi / 72.0
        self._sizes: dict[tuple, tuple[float, float]] = {}
        self._probe: Any = None

    def box(self, text, pad: bool = True) -> shapely.Polygon:
        """The box of a text artist in plan coordinates (with the clearance)."""
        bb = text.get_window_extent(self.renderer)
        p = self._pad_px if pad else 0.0
        (x0, y0), (x1, y1) = self._to_data.transform([(bb.x0 - p, bb.y0 - p), (bb.x1 + p, bb.y1 + p)])
        return shapely.box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))

    def free(self, geom: shapely.Geometry, lines: bool = True) -> bool:
        """Whether ``geom`` touches no placed text and (with ``lines``) no line."""
        if any(geom.intersects(b) for b in self.boxes):
            return False
        if lines:
            if len(self.tree.query(geom, predicate="intersects")):
                return False
            if any(geom.intersects(g) for g in self.extra):
                return False
        return True

    def keep(self, box: shapely.Geometry) -> None:
        self.boxes.append(box)

    def add_line(self, geom: shapely.Geometry) -> None:
        self.extra.append(geom)

    def place(self, make, candidates: Sequence, inside: shapely.Geometry | None = None, spec=None):
        """Keep the first free candidate (within ``inside``) and return ``make(candidate)``,
        the text drawn there, or ``None`` (nothing drawn). ``spec(candidate)`` says where the
        text would be (:class:`Spot`) so that its box is computed from one measure of the text
        instead of drawing it at every candidate; without it each candidate is drawn, measured
        and removed if it is not kept."""
        for c in candidates:
            if spec is not None:
                b = self.spot_box(spec(c))
                if (inside is None or inside.contains(b)) and self.free(b):
                    self.keep(b)
                    return make(c)
                continue
            t = make(c)
            b = self.box(t)
            if (inside is None or inside.contains(b)) and self.free(b):
                self.keep(b)
                return t
            t.remove()
        return None

    def measure(self, text: str, fontsize: float, linespacing: float = 1.2) -> tuple[float, float]:
        """Width and height (pixels) of ``text`` unrotated, measured once."""
        key = (text, fontsize, linespacing)
        if key not in self._sizes:
            if self._probe is None:  # one text measures them all: making texts is slow
                from matplotlib.text import Text

                self._probe = Text(0, 0, "", figure=self.fig)
            self._probe.set_text(text)
            self._probe.set_fontsize(fontsize)
            self._probe.set_linespacing(linespacing)
            bb = self._probe.get_window_extent(self.renderer)
            self._sizes[key] = (bb.width, bb.height)
        return self._sizes[key]

    def spot_box(self, s: Spot) -> shapely.Polygon:
        """The box (plan coordinates, with the clearance) of a text at ``s``."""
        w, h = self.measure(s.text, s.fontsize, s.linespacing)
        x0 = {"left": 0.0, "center": -0.5 * w, "right": -w}[s.ha]
        y0 = {"bottom": 0.0, "center": -0.5 * h, "top": -h}[s.va]
        corners = np.array([[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]])
        if s.rotation:
            a = np.radians(s.rotation)
            corners = corners @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
        ax_px = self.ax.transData.transform([[s.x, s.z]])[0]
        d = np.array([s.dx_pt, s.dy_pt]) * self.fig.dpi / 72.0
        pts = self._to_data.transform(corners + ax_px + d)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = np.abs(self._to_data.transform([[0.0, 0.0], [self._pad_px, self._pad_px]])[1] - self._to_data.transform([[0.0, 0.0]])[0])
        return shapely.box(lo[0] - pad[0], lo[1] - pad[1], hi[0] + pad[0], hi[1] + pad[1])


@dataclass(frozen=True)
class Spot:
    """Where a text goes: anchored at plan point (x, z), shifted by (dx_pt, dy_pt) points of
    paper (up the page positive), aligned by ``ha``/``va`` and turned by ``rotation`` degrees
    about its anchor (matplotlib's ``rotation_mode="anchor"``)."""

    x: float
    z: float
    text: str
    fontsize: float
    ha: str = "center"
    va: str = "center"
    rotation: float = 0.0
    dx_pt: float = 0.0
    dy_pt: float = 0.0
    linespacing: float = 1.2


def arc_line(center, radius: float, start_deg: float, end_deg: float, n: int = 24) -> shapely.LineString:
    """An arc as a polyline (angles from +x towards +z)."""
    a = np.radians(np.linspace(start_deg, end_deg, n))
    return shapely.LineString(np.c_[center[0] + radius * np.cos(a), center[1] + radius * np.sin(a)])


def with_halo(text, width: float = 2.2):
    """Put a white outline under ``text``: a white copy of it stroked wide, just below it. The
    text itself stays a plain text (selectable, literal in SVG and PDF); only the copy goes
    through path effects, which turn a text into outlines."""
    x, y = text.get_position()
    text.axes.text(
        x,
        y,
        text.get_text(),
        transform=text.get_transform(),
        fontproperties=text.get_fontproperties(),
        ha=text.get_ha(),
        va=text.get_va(),
        rotation=text.get_rotation(),
        rotation_mode=text.get_rotation_mode(),
        linespacing=text.get_linespacing(),
        multialignment="center",
        color="white",
        zorder=text.get_zorder() - 0.01,
        path_effects=halo(width),
        parse_math=False,
        usetex=False,
    )
    return text
