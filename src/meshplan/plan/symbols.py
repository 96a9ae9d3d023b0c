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
    """A room's label: ``text`` (name and area, for CAD) at the room's pole of inaccessibility
    ``position``, ``radius`` metres from its nearest edge; the drawing sets ``name``, ``number``
    and the ``area`` (m²) apart so that it can shrink them to fit."""

    position: tuple[float, float]
    text: str
    name: str = ""
    number: str = ""
    area: float = 0.0
    radius: float = 0.0
    type: str = "room"


@dataclass(frozen=True, eq=False)
class WallSolid:
    """One physical wall cut at the drafting height: the solid between its two faces, with its
    openings cut out (a Polygon or MultiPolygon in [x, z]), whether it is exterior and whether
    meshplan is unsure of it (low confidence)."""

    polygon: shapely.Geometry
    exterior: bool
    low: bool


@dataclass(frozen=True)
class DimensionChain:
    """Consecutive dimensions along one side of the building, drawn outside it.

    ``ticks`` are the positions measured along ``axis`` (0: x, 1: z), in increasing order;
    ``base`` is the coordinate across the axis of the building's outermost face on that side
    and ``outward`` (+1 or -1) the direction away from the building; ``tier`` 0 is the chain
    nearest the building (openings), 1 the walls, 2 the overall size."""

    axis: int
    ticks: tuple[float, ...]
    base: float
    outward: int
    tier: int


@dataclass(frozen=True)
class RoomDimension:
    """A room's clear width (``axis`` 0) or depth (``axis`` 1) between ``lo`` and ``hi``, drawn
    inside the room at one of ``across`` (coordinates on the other axis, best first) where it
    fits."""

    axis: int
    lo: float
    hi: float
    across: tuple[float, ...]


@dataclass(frozen=True, eq=False)
class PlanSymbols:
    door_leaves: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    door_arcs: tuple[Arc, ...] = ()
    jambs: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    windows: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    dimensions: tuple[Dimension, ...] = ()
    room_labels: tuple[Label, ...] = ()
    room_outlines: tuple[FloatArray, ...] = ()  # closed rings [x, z] of the rooms
    #: the physical walls as solids (poche), openings cut out
    wall_solids: tuple[WallSolid, ...] = ()
    #: the type of each room of ``room_outlines`` (room, corridor, stair, closet, open)
    room_types: tuple[str, ...] = ()
    #: overall and per-wall dimension chains outside the building; room sizes inside
    chains: tuple[DimensionChain, ...] = ()
    room_dimensions: tuple[RoomDimension, ...] = ()


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
        spot = polylabel(room.polygon, tolerance=0.02) if room.polygon.area > 0 else room.polygon.centroid
        name = room.name or room.label
        radius = float(room.polygon.exterior.distance(spot))
        # the centre of a rectangle is as good a place as its pole and where a reader looks
        centre = room.polygon.centroid
        if room.polygon.contains(centre) and room.polygon.exterior.distance(centre) >= 0.8 * radius:
            spot, radius = centre, float(room.polygon.exterior.distance(centre))
        labels.append(
            Label((float(spot.x), float(spot.y)), f"{room.label}\n{format_area(room.area, imperial)}", name, room.number, room.area, radius, room.type)
        )
    as_array = lambda v: np.array(v, dtype=np.float64).reshape(-1, 2, 2)  # noqa: E731
    mine_rooms = [r for r in rooms if r.story == story]
    solids = wall_solids(story, walls, openings, physical)
    return PlanSymbols(
        as_array(leaves),
        tuple(arcs),
        as_array(jambs),
        as_array(windows),
        tuple(dims),
        tuple(labels),
        tuple(outlines),
        solids,
        tuple(r.type for r in mine_rooms),
        dimension_chains(story, walls, openings, physical, solids),
        room_dimensions(mine_rooms),
    )


#: Openings are cut this far beyond each face of their wall (m), so that no sliver of the
#: solid is left across a door or window.
_CUT_BEYOND_M = 0.02
#: Ticks of a dimension chain closer than this are one (m): the same corner seen twice.
_TICK_MERGE_M = 0.03


def _wall_ends(physical: tuple[PhysicalWall, ...], mine: list[int]) -> dict[tuple[int, int], float]:
    """How far each end of each wall is extended beyond its centre line's end: by half the
    thickness of the wall it meets, so that the solids of two walls meeting at a corner fill
    it (the centre lines end where they cross); a free end is not extended."""
    lines = {i: shapely.LineString([physical[i].start, physical[i].end]) for i in mine}
    out = {}
    for i in mine:
        w = physical[i]
        for k, end in enumerate((w.start, w.end)):
            p = shapely.Point(end)
            reach = 0.0
            for j in mine:
                if j != i and lines[j].distance(p) <= 0.5 * physical[j].thickness + 0.01:
                    reach = max(reach, 0.5 * physical[j].thickness)
            out[(i, k)] = reach
    return out


def wall_solids(story: int, walls: FlatWalls, openings: Openings, physical: tuple[PhysicalWall, ...]) -> tuple[WallSolid, ...]:
    """Each physical wall of ``story`` as the solid between its faces (its centre line widened
    by its thickness, its ends reaching into the walls they meet), with its doors and windows
    cut through it."""
    mine = [i for i, w in enumerate(physical) if w.story == story and w.length > 1e-6]
    if not mine:
        return ()
    ends = _wall_ends(physical, mine)
    carrier = wall_of_face(physical, len(walls))
    cuts: dict[int, list] = {}
    for k in np.flatnonzero(openings.story == story):
        i = int(k)
        f = int(openings.wall[i])
        c = int(carrier[f]) if 0 <= f < len(carrier) else -1
        if c < 0:
            continue
        n, t = walls.normal[f], walls.tangent[f]
        depth = physical[c].thickness
        a = float(openings.u_min[i]) * t + walls.offset[f] * n
        b = float(openings.u_max[i]) * t + walls.offset[f] * n
        front, back = n * _CUT_BEYOND_M, -n * (depth + _CUT_BEYOND_M)
        cuts.setdefault(c, []).append(shapely.Polygon([a + front, b + front, b + back, a + back]))
    out = []
    for i in mine:
        w = physical[i]
        d = w.direction
        p0 = np.asarray(w.start) - d * ends[(i, 0)]
        p1 = np.asarray(w.end) + d * ends[(i, 1)]
        h = 0.5 * w.thickness * w.normal
        body: shapely.Geometry = shapely.Polygon([p0 + h, p1 + h, p1 - h, p0 - h])
        if i in cuts:
            body = body.difference(shapely.union_all(cuts[i]))
        if not body.is_empty:
            out.append(WallSolid(body, bool(w.exterior), w.confidence == "low"))
    return tuple(out)


def _merge_ticks(values) -> tuple[float, ...]:
    v = np.sort(np.asarray(list(values), dtype=np.float64))
    if not len(v):
        return ()
    keep = [v[0]]
    for x in v[1:]:
        if x - keep[-1] > _TICK_MERGE_M:
            keep.append(x)
    return tuple(float(x) for x in keep)


def dimension_chains(
    story: int, walls: FlatWalls, openings: Openings, physical: tuple[PhysicalWall, ...], solids: tuple[WallSolid, ...]
) -> tuple[DimensionChain, ...]:
    """The dimension chains of a story, outside the building on each of its four sides (the
    plan is turned so that its walls run along x and z): the openings in the exterior walls
    facing that side (tier 0), the walls meeting them (tier 1) and the overall size (tier 2).
    A tier measuring nothing the next does not is left out."""
    if not solids:
        return ()
    xmin, zmin, xmax, zmax = shapely.union_all([s.polygon for s in solids]).bounds
    carrier = wall_of_face(physical, len(walls))
    mine = [i for i, w in enumerate(physical) if w.story == story and w.length > 1e-6]
    ends = _wall_ends(physical, mine)
    chains = []
    # side: (axis measured along, outward direction across it, base coordinate)
    for axis, outward, base in ((0, -1, zmin), (0, 1, zmax), (1, -1, xmin), (1, 1, xmax)):
        across = 1 - axis
        lo, hi = (xmin, xmax) if axis == 0 else (zmin, zmax)
        facing, joints, gaps = [], [lo, hi], [lo, hi]
        for i in mine:
            w = physical[i]
            if not w.exterior or abs(w.direction[across]) > 0.1:
                continue
            out_n = -w.normal if w.rooms[0] else w.normal  # rooms lie on the side of the normal
            if out_n[across] * outward < 0.9:
                continue
            facing.append(i)
            d = w.direction
            joints += [w.start[axis] - d[axis] * ends[(i, 0)], w.end[axis] + d[axis] * ends[(i, 1)]]
        for i in mine:  # interior walls meeting a facing wall: their centre lines
            w = physical[i]
            if w.exterior or abs(w.direction[axis]) > 0.1:
                continue
            for j in facing:
                line = shapely.LineString([physical[j].start, physical[j].end])
                for end in (w.start, w.end):
                    if line.distance(shapely.Point(end)) <= 0.5 * physical[j].thickness + 0.05:
                        joints.append(end[axis])
        for k in np.flatnonzero(openings.story == story):
            f = int(openings.wall[k])
            if 0 <= f < len(carrier) and carrier[f] in facing:
                t, at = walls.tangent[f][axis], walls.offset[f] * walls.normal[f][axis]
                gaps += [float(openings.u_min[k] * t + at), float(openings.u_max[k] * t + at)]
        if not facing:
            continue
        overall = _merge_ticks([lo, hi])
        walls_ticks = _merge_ticks(joints)
        gap_ticks = _merge_ticks(gaps + joints)
        tiers = [(2, overall)]
        if len(walls_ticks) > len(overall):
            tiers.append((1, walls_ticks))
        if len(gap_ticks) > len(walls_ticks):
            tiers.append((0, gap_ticks))
        for tier, ticks in tiers:
            chains.append(DimensionChain(axis, ticks, float(base), outward, tier))
    return tuple(chains)


def room_dimensions(rooms: list[Room]) -> tuple[RoomDimension, ...]:
    """The clear width and depth of each roughly rectangular room (its outline fills 90 % of
    its bounding box), with the places across the room they may be drawn at."""
    out = []
    for room in rooms:
        x0, z0, x1, z1 = room.polygon.bounds
        if room.polygon.area < 0.9 * (x1 - x0) * (z1 - z0) or min(x1 - x0, z1 - z0) < 0.8:
            continue
        fr = (0.22, 0.78, 0.35, 0.65, 0.12, 0.88)
        out.append(RoomDimension(0, x0, x1, tuple(z0 + f * (z1 - z0) for f in fr)))
        out.append(RoomDimension(1, z0, z1, tuple(x0 + f * (x1 - x0) for f in fr)))
    return tuple(out)
