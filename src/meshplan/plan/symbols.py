"""Drafting symbols in plan coordinates: door leaves and swings, window sashes, jambs, room labels
and dimension lines. Drawings (matplotlib) and CAD files (DXF) draw the same symbols.

A door between two rooms is found on both faces of its wall; it is drawn once, swinging into the
room of the first face found, with jamb lines across the wall. A window is drawn as the usual
triple line across the wall. Wall thickness comes from the physical walls (see
:mod:`meshplan.walls.physical`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.ops import polylabel

from ..geometry import FloatArray
from ..units import FOOT_M
from ..walls import FlatWalls
from ..walls.physical import PhysicalWall, wall_of_face
from .openings import Openings
from .rooms import Room


@dataclass(frozen=True)
class Arc:
    """A circular arc; angles in degrees from +x towards +z (counter-clockwise in the plan's
    coordinates, so drawn clockwise on a page with z down)."""

    center: tuple[float, float]
    radius: float
    start_deg: float
    end_deg: float


@dataclass(frozen=True)
class Dimension:
    """A dimension between two points, drawn ``offset`` metres to the left of p1 -> p2."""

    p1: tuple[float, float]
    p2: tuple[float, float]
    offset: float
    text: str


@dataclass(frozen=True)
class Label:
    position: tuple[float, float]
    text: str


@dataclass(frozen=True, eq=False)
class PlanSymbols:
    door_leaves: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    door_arcs: tuple[Arc, ...] = ()
    jambs: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    windows: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    dimensions: tuple[Dimension, ...] = ()
    room_labels: tuple[Label, ...] = ()
    room_outlines: tuple[FloatArray, ...] = ()  # closed rings [x, z] of the rooms


def format_length(m: float, imperial: bool) -> str:
    """``3.42`` (metres) or ``11'-2"`` (feet and inches)."""
    if not imperial:
        return f"{m:.2f}"
    inches = round(m / 0.0254)
    return f"{inches // 12}'-{inches % 12}\""


def format_area(m2: float, imperial: bool) -> str:
    return f"{m2 / FOOT_M**2:.1f} ft²" if imperial else f"{m2:.2f} m²"


def _along_walls(a: FloatArray, b: FloatArray, wall_lines, tolerance_m: float = 0.05) -> bool:
    """Whether the room edge ``a -> b`` runs along walls for most of its length: only those
    are dimensioned (an edge closed by the floor's outline measures no wall)."""
    if wall_lines is None:
        return False
    t = np.linspace(0.1, 0.9, 9)[:, None]
    pts = shapely.points(a + t * (b - a))
    return bool(np.mean(shapely.distance(pts, wall_lines) <= tolerance_m) >= 0.7)


def plan_symbols(
    story: int,
    walls: FlatWalls,
    openings: Openings,
    rooms: tuple[Room, ...],
    physical: tuple[PhysicalWall, ...],
    imperial: bool = False,
    dimension_offset_m: float = 0.3,
) -> PlanSymbols:
    """The symbols of one story's drafting plan; door jambs and window sashes span the
    thickness of the ``physical`` wall carrying each opening."""
    carrier = wall_of_face(physical, len(walls))
    leaves, arcs, jambs, windows = [], [], [], []
    drawn: list[tuple[FloatArray, float]] = []  # door centres already drawn
    centers = openings.center(walls) if len(openings) else np.zeros((0, 2))
    for i in np.flatnonzero(openings.story == story):
        w = int(openings.wall[i])
        n, t = walls.normal[w], walls.tangent[w]
        u0, u1 = float(openings.u_min[i]), float(openings.u_max[i])
        depth = physical[carrier[w]].thickness
        p0 = u0 * t + walls.offset[w] * n
        p1 = u1 * t + walls.offset[w] * n
        back = -n * depth
        if openings.kind[i] == "door":
            if any(np.linalg.norm(c - centers[i]) < depth + 0.3 for c, _ in drawn):
                continue  # the same door seen from the other side
            drawn.append((centers[i], depth))
            width = u1 - u0
            leaves.append([p0, p0 + n * width])
            a_leaf = np.degrees(np.arctan2(n[1], n[0]))
            a_jamb = np.degrees(np.arctan2(t[1], t[0]))
            lo, hi = sorted((a_leaf, a_jamb))
            if hi - lo > 180:
                lo, hi = hi, lo + 360
            arcs.append(Arc((float(p0[0]), float(p0[1])), float(width), float(lo), float(hi)))
        else:
            for f in (0.0, 0.5, 1.0):
                windows.append([p0 + back * f, p1 + back * f])
        jambs.append([p0, p0 + back])
        jambs.append([p1, p1 + back])
    dims, labels, outlines = [], [], []
    mine = np.flatnonzero(walls.story == story)
    wall_lines = shapely.MultiLineString([[tuple(walls.start[i]), tuple(walls.end[i])] for i in mine]) if len(mine) else None
    for room in rooms:
        if room.story != story:
            continue
        # counter-clockwise in (x, z); nearly collinear corners merged so one wall gets one dimension
        ring = np.asarray(shapely.orient_polygons(room.polygon.simplify(0.03)).exterior.coords)
        for a, b in zip(ring[:-1], ring[1:]):
            length = float(np.linalg.norm(b - a))
            if length >= 0.5 and _along_walls(a, b, wall_lines):
                dims.append(Dimension((float(a[0]), float(a[1])), (float(b[0]), float(b[1])), dimension_offset_m, format_length(length, imperial)))
        outlines.append(np.asarray(room.polygon.exterior.coords))
        spot = polylabel(room.polygon, tolerance=0.05) if room.polygon.area > 0 else room.polygon.centroid
        labels.append(Label((float(spot.x), float(spot.y)), f"{room.label}\n{format_area(room.area, imperial)}"))
    as_array = lambda v: np.array(v, dtype=np.float64).reshape(-1, 2, 2)  # noqa: E731
    return PlanSymbols(as_array(leaves), tuple(arcs), as_array(jambs), as_array(windows), tuple(dims), tuple(labels), tuple(outlines))
