"""Drafting symbols in plan coordinates: door leaves and swings, window sashes, jambs, room labels,
dimension lines and stairs. Drawings (matplotlib) and CAD files (DXF) draw the same symbols.

A door between two rooms is found on both faces of its wall; it is drawn once, with jamb lines
across the wall, its leaf square to the wall from the hinge the scan showed, swinging into the
side it opens to (:class:`meshplan.plan.elements.Swing`); where the scan showed no leaf, from
the jamb at the start of the face it was found on, into that face's room. A window is drawn as
the usual triple line across the wall. Wall thickness comes from the physical walls (see
:mod:`meshplan.walls.physical`).

Why one long module: the sheet's drawing model (wall solids, openings, labels, dimension chains,
stairs) is one record that every backend draws (PNG/SVG/PDF and DXF); its builders share the wall
joins and the sizes in paper millimetres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.ops import polylabel

from ..geometry import FloatArray
from ..units import FOOT_M
from ..walls import FlatWalls
from ..walls.physical import PhysicalWall, wall_of_face
from .elements import OpeningElement, Swing
from .openings import Openings
from .rooms import Room

if TYPE_CHECKING:  # pragma: no cover
    from .stairs import StairElement
    from .voids import Void


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


@dataclass(frozen=True)
class OpeningSymbol:
    """One door or window as drawn (once per physical opening), for CAD blocks: its jamb on the
    face it was found on ``origin`` [x, z], the unit ``tangent`` along the wall (towards the other
    jamb) and ``normal`` out of that face (into the room a door swings into), its clear ``width``,
    the wall's ``depth``, its ``height`` and ``sill`` (m above the story's floor; 0 for a door) and
    its ``mark`` (D1, D2 ... and W1, W2 ... per story, in the order drawn)."""

    kind: str
    origin: tuple[float, float]
    tangent: tuple[float, float]
    normal: tuple[float, float]
    width: float
    depth: float
    height: float
    sill: float
    mark: str


@dataclass(frozen=True, eq=False)
class StairSymbol:
    """A stair as drawn on one story's plan (the usual symbol; plan coordinates, metres).

    ``role`` is ``lower`` on the story the stair starts on (treads below the cut solid, above it
    dashed, a break line across the flight at the cut) and ``upper`` on the story it arrives at
    (every tread seen from above through the void, which is outlined and crossed). ``lines`` are
    the visible tread and stringer lines ``(S, 2, 2)``, ``hidden`` those above the cut; ``walk``
    the walking line (bottom to top, ``(k, 2)``; ``walk_hidden`` its part above the cut) ending in
    the arrow of ascent at its last point, pointing along ``arrow``; ``cut`` the break line
    (``(k, 2)``, empty on the upper story); ``void`` the ring of the hole in the floor (upper
    story only; empty otherwise); ``text`` the risers and their rise and going."""

    stair: int
    role: str
    lines: FloatArray
    hidden: FloatArray
    walk: FloatArray
    walk_hidden: FloatArray
    arrow: tuple[float, float]
    cut: FloatArray
    void: FloatArray
    text: str
    #: the void's cross (``(S, 2, 2)``, upper story only)
    cross: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))


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
    #: each door and window once, for CAD blocks (:class:`OpeningSymbol`)
    openings: tuple[OpeningSymbol, ...] = ()
    #: the stairs starting or arriving on the story (:class:`StairSymbol`)
    stairs: tuple[StairSymbol, ...] = ()
    #: the holes in the story's floor over double-height spaces: closed rings [x, z] ...
    voids: tuple[FloatArray, ...] = ()
    #: ... and their crosses (``(S, 2, 2)``, :func:`void_cross`)
    void_crosses: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))


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


#: A room label keeps this far (m) from a stair's symbol: the treads' ends, the arrow's head.
STAIR_LABEL_CLEAR_M = 0.1

#: A room's label moves off a stair's symbol only to a free part whose pole lies at least this
#: far (m) from its outline: room for a two-line label at full size (about 0.8 m across at
#: 1:50); a room that is nearly all stair keeps its label at its pole, over the symbol, rather
#: than squeezed into a strip beside it.
LABEL_FREE_RADIUS_M = 0.4


def _label_area(polygon: Polygon, blocked) -> Polygon:
    """The part of ``polygon`` in which its label goes: its part outside ``blocked`` (the
    stairs' symbols) that gives the label the most room, when that is at least
    :data:`LABEL_FREE_RADIUS_M`, else ``polygon``."""
    if blocked is None or not polygon.intersects(blocked):
        return polygon
    parts = [p for p in shapely.get_parts(polygon.difference(blocked)) if isinstance(p, Polygon) and p.area > 0]
    room = [(float(p.exterior.distance(polylabel(p, tolerance=0.02))), p) for p in parts]
    radius, best = max(room, key=lambda r: r[0], default=(0.0, polygon))
    return best if radius >= LABEL_FREE_RADIUS_M else polygon


def door_frame(swing: Swing | None, walls: FlatWalls, w: int, u0: float, u1: float, depth: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Where a door's symbol stands: its hinge jamb on the face of the room the leaf opens into,
    the unit direction along the wall to the other jamb, and the unit normal into that room.

    From the door's :class:`~meshplan.plan.elements.Swing`: the jamb nearer its hinge, on face
    ``w`` (found from ``u0`` to ``u1``) or on the wall's other face ``depth`` behind it, the
    side read back from the swing's hand (:func:`meshplan.plan.elements._hand`: seen from the
    room the leaf opens into, the hinge is on the viewer's right of the other jamb for a right
    hand), which holds where the room on that side is unknown. A door whose leaf the scan did
    not show (``swing`` None) keeps the jamb at ``u0`` and face ``w``'s normal.
    """
    n, t, off = walls.normal[w], walls.tangent[w], float(walls.offset[w])
    if swing is None:
        return u0 * t + off * n, t, n
    u_hinge = float(np.asarray(swing.hinge) @ t)
    at_start = abs(u_hinge - u0) <= abs(u_hinge - u1)
    u, u_other = (u0, u1) if at_start else (u1, u0)
    # a viewer on side s of the face looks along -s n; their right is (-look_z, look_x) on the
    # page (x right, z down), s (n_z, -n_x)
    right_of_other = (u - u_other) * float(t @ np.array([n[1], -n[0]]))
    side = 1.0 if (right_of_other > 0) == (swing.hand == "right") else -1.0
    face = off if side > 0 else off - depth
    return u * t + face * n, (t if at_start else -t), side * n


def plan_symbols(
    story: int,
    walls: FlatWalls,
    openings: Openings,
    rooms: tuple[Room, ...],
    physical: tuple[PhysicalWall, ...],
    imperial: bool = False,
    dimension_offset_m: float = 0.3,
    stairs: tuple[StairElement, ...] = (),
    elements: tuple[OpeningElement, ...] = (),
    voids: tuple[Void, ...] = (),
) -> PlanSymbols:
    """The symbols of one story's drafting plan; door jambs and window sashes span the
    thickness of the ``physical`` wall carrying each opening. ``stairs`` (``Result.stairs``)
    are drawn on the stories they start on and arrive at (:func:`stair_symbols`); a door whose
    element (``elements``, one per row of ``openings``) has a swing is drawn from its hinge
    into the room it opens into (:func:`door_frame`). ``voids`` (``Result.voids``) are outlined and
    crossed on the story whose floor they open."""
    carrier = wall_of_face(physical, len(walls))
    leaves, arcs, jambs, windows = [], [], [], []
    records: list[OpeningSymbol] = []
    mine_walls = walls.story == story
    # the story's floor, for sill heights: where its walls stand
    floor = float(np.median(walls.bottom[mine_walls])) if np.any(mine_walls) else 0.0
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
        origin, along, out = p0, t, n
        if openings.kind[i] == "door":
            if any(np.linalg.norm(c - centers[i]) < depth + 0.3 for c, _ in drawn):
                continue  # the same door seen from the other side
            drawn.append((centers[i], depth))
            width = u1 - u0
            if i < len(elements):
                origin, along, out = door_frame(elements[i].swing, walls, w, u0, u1, depth)
            leaves.append([origin, origin + out * width])
            a_leaf = np.degrees(np.arctan2(out[1], out[0]))
            a_jamb = np.degrees(np.arctan2(along[1], along[0]))
            lo, hi = sorted((a_leaf, a_jamb))
            if hi - lo > 180:
                lo, hi = hi, lo + 360
            arcs.append(Arc((float(origin[0]), float(origin[1])), float(width), float(lo), float(hi)))
        else:
            for f in (0.0, 0.5, 1.0):
                windows.append([p0 + back * f, p1 + back * f])
        door = openings.kind[i] == "door"
        number = sum(r.kind == openings.kind[i] for r in records) + 1
        records.append(
            OpeningSymbol(
                str(openings.kind[i]),
                (float(origin[0]), float(origin[1])),
                (float(along[0]), float(along[1])),
                (float(out[0]), float(out[1])),
                float(u1 - u0),
                float(depth),
                float(openings.top[i] - openings.bottom[i]),
                0.0 if door else max(0.0, float(openings.bottom[i]) - floor),
                f"{'D' if door else 'W'}{number}",
            )
        )
        jambs.append([p0, p0 + back])
        jambs.append([p1, p1 + back])
    dims, labels, outlines = [], [], []
    mine = np.flatnonzero(walls.story == story)
    wall_lines = shapely.MultiLineString([[tuple(walls.start[i]), tuple(walls.end[i])] for i in mine]) if len(mine) else None
    drawn_stairs = [s.footprint for s in stairs if story in (s.story, s.to_story) and s.footprint is not None and not s.footprint.is_empty]
    stair_area = shapely.union_all(drawn_stairs).buffer(STAIR_LABEL_CLEAR_M) if drawn_stairs else None
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
        # the label goes where the room's floor is free of a stair's symbol (its treads and
        # walking line below, the void above), when enough of the room is
        free = _label_area(room.polygon, stair_area)
        spot = polylabel(free, tolerance=0.02) if free.area > 0 else free.centroid
        name = room.name or room.label
        radius = float(free.exterior.distance(spot))
        # the centre of a rectangle is as good a place as its pole and where a reader looks
        centre = free.centroid
        if free.contains(centre) and free.exterior.distance(centre) >= 0.8 * radius:
            spot, radius = centre, float(free.exterior.distance(centre))
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
        tuple(records),
        stair_symbols(story, stairs, imperial),
        *_void_symbols(story, voids),
    )


def _void_symbols(story: int, voids: tuple[Void, ...]) -> tuple[tuple[FloatArray, ...], FloatArray]:
    """The rings of the story's double-height voids and their crosses."""
    rings = tuple(np.asarray(v.polygon.exterior.coords, dtype=np.float64) for v in voids if v.story == story)
    crosses = [void_cross(r) for r in rings]
    return rings, (np.concatenate(crosses) if crosses else np.zeros((0, 2, 2)))


# --- stairs ------------------------------------------------------------------------------------

#: The break line of a stair's cut is slanted across the flight by this much of the flight's
#: width along it (about 20 degrees off square, as it is usually drawn), ...
_CUT_SLANT = 0.35
#: ... with a zig-zag of this size (m) in its middle, so that it reads as a break, not a tread.
_CUT_ZIGZAG_M = 0.08


def _segments_of(geom) -> list:
    """The straight pieces ``[[a, b], ...]`` of a shapely line geometry."""
    out = []
    for g in getattr(geom, "geoms", [geom]):
        if g.is_empty or g.geom_type not in ("LineString", "LinearRing"):
            continue
        c = np.asarray(g.coords)
        out += [[c[k], c[k + 1]] for k in range(len(c) - 1) if np.linalg.norm(c[k + 1] - c[k]) > 1e-6]
    return out


def _lines_of(geom) -> list[FloatArray]:
    """The coordinates of each line of a shapely geometry, longest first."""
    out = [np.asarray(g.coords) for g in getattr(geom, "geoms", [geom]) if not g.is_empty and g.geom_type == "LineString"]
    return sorted(out, key=lambda c: -shapely.LineString(c).length)


def _frame_extent(poly, d: FloatArray) -> tuple[float, float, float, float]:
    """``(s0, s1, a0, a1)``: a polygon's extent along ``d`` and across it."""
    xy = np.asarray(poly.exterior.coords)
    across = np.array([-d[1], d[0]])
    s, a = xy @ d, xy @ across
    return float(s.min()), float(s.max()), float(a.min()), float(a.max())


def _flight_box(stair: StairElement, flight) -> tuple[FloatArray, FloatArray, float, float, float, float]:
    """A flight as a regular rectangle in its own frame: ``(d, across, s0, s1, a0, a1)``, from
    its first riser to its last, as wide as its treads' median width, centred on its walking
    line; each riser at a tread centroid less half a going."""
    d = np.asarray(flight.direction, dtype=np.float64)
    d = d / (np.linalg.norm(d) or 1.0)
    across = np.array([-d[1], d[0]])
    cen = np.array([np.asarray(stair.treads[k].polygon.centroid.coords[0]) for k in flight.treads])
    s = cen @ d
    half = 0.5 * (flight.going or stair.going)
    ext = [_frame_extent(stair.treads[k].polygon, d) for k in flight.treads]
    width = float(np.median([e[3] - e[2] for e in ext]))
    mid = float(np.median(cen @ across))
    return d, across, float(s.min() - half), float(s.max() + half), mid - 0.5 * width, mid + 0.5 * width


def stair_symbols(story: int, stairs: tuple[StairElement, ...], imperial: bool = False) -> tuple[StairSymbol, ...]:
    """The stair symbols of ``story``: for each stair starting on it (``lower``) and arriving on
    it (``upper``), the risers across each flight and the stringers along it, the landings, the
    walking line from the first riser to the last with the arrow of ascent; on the lower story
    a break line across the flight where the plan's cut meets it and the part above it hidden
    (dashed); on the upper story the void over the stair, outlined and crossed.

    On a story where one stair arrives and the next starts over it (a stacked stairwell), the
    arriving stair is hidden under the starting one's part below the cut, its void is not
    crossed, and the starting stair's part above the cut is left out where the arriving one is
    seen: the walking line of the starting stair then ends with its arrow at the cut."""
    from dataclasses import replace

    lower = [(k, *_stair_symbol(k, st, "lower", imperial)) for k, st in enumerate(stairs) if st.story == story and st.flights]
    upper = [(k, *_stair_symbol(k, st, "upper", imperial)) for k, st in enumerate(stairs) if st.to_story == story and st.flights]
    covers = [c for _, _, c in lower if c is not None]
    out: list[StairSymbol] = []
    seen = [stairs[k].footprint for k, _, _ in upper]
    for _, sym, _ in lower:
        if seen and any(stairs[sym.stair].footprint.intersects(f) for f in seen):
            sym = replace(sym, hidden=np.zeros((0, 2, 2)), walk_hidden=np.zeros((0, 2)))
        out.append(sym)
    for k, sym, _ in upper:
        if covers and any(stairs[k].footprint.intersects(c) for c in covers):
            sym = replace(_hide_under(sym, shapely.union_all(covers)), cross=np.zeros((0, 2, 2)))
        out.append(sym)
    return tuple(out)


def void_cross(ring: FloatArray) -> FloatArray:
    """The two diagonals of a void's oriented bounding box, within the void (``(S, 2, 2)``):
    the usual mark of a hole in a floor."""
    poly = shapely.Polygon(ring)
    if len(ring) < 4 or not poly.is_valid or poly.is_empty:
        return np.zeros((0, 2, 2))
    corners = np.asarray(shapely.oriented_envelope(poly).exterior.coords)[:4]
    segs: list = []
    for a, b in ((corners[0], corners[2]), (corners[1], corners[3])):
        segs += _segments_of(shapely.LineString([a, b]).intersection(poly))
    return np.array(segs, dtype=np.float64).reshape(-1, 2, 2)


def _hide_under(sym: StairSymbol, cover) -> StairSymbol:
    """``sym`` without the lines under ``cover`` (a stair above it)."""
    from dataclasses import replace

    def clip(segs: FloatArray) -> FloatArray:
        if not len(segs):
            return segs
        left = shapely.MultiLineString([s.tolist() for s in segs]).difference(cover)
        return np.array(_segments_of(left), dtype=np.float64).reshape(-1, 2, 2)

    def clip_line(walk: FloatArray) -> FloatArray:
        if len(walk) < 2:
            return walk
        # the piece arriving at the top, where the arrow is: a stub cut off from it says nothing
        top = walk[-1]
        pieces = [c for c in _lines_of(shapely.LineString(walk).difference(cover)) if np.linalg.norm(c[-1] - top) < 1e-6]
        return pieces[0] if pieces else np.zeros((0, 2))

    return replace(sym, lines=clip(sym.lines), hidden=clip(sym.hidden), walk=clip_line(sym.walk))


def _drawn_flights(st: StairElement) -> list:
    """The stair's flights as drawn: a flight that follows the previous one without a landing
    between them (sharing a tread: a partly scanned last tread that turned the fit) continues
    it, in its direction."""
    from .stairs import Flight

    out: list = []
    for fl in st.flights:
        if out and fl.treads:
            prev = out[-1]
            between = range(prev.treads[-1] + 1, fl.treads[0])
            if not any(st.treads[j].landing for j in between):
                treads = tuple(sorted(set(prev.treads) | set(fl.treads)))
                out[-1] = Flight(treads, prev.direction, prev.risers + fl.risers, prev.going)
                continue
        out.append(fl)
    return out


def _stair_symbol(k: int, st: StairElement, role: str, imperial: bool):
    """One stair's symbol on the story where it plays ``role``, and the plan area of its
    visible (below the cut) part on the lower story (``None`` on the upper)."""
    segs: list = []
    walk: list = []
    flights = _drawn_flights(st)
    boxes = [_flight_box(st, fl) for fl in flights]
    for fl, (d, across, s0, s1, a0, a1) in zip(flights, boxes):

        def pt(u, v, d=d, across=across):
            return d * u + across * v

        n = max(len(fl.treads), 1)
        for j in range(n + 1):  # risers, evenly between the first and the last
            u = s0 + (s1 - s0) * j / n
            segs.append([pt(u, a0), pt(u, a1)])
        segs += [[pt(s0, a0), pt(s1, a0)], [pt(s0, a1), pt(s1, a1)]]
        m = 0.5 * (a0 + a1)
        walk.append((pt(s0, m), pt(s1, m)))
    # landings: their extent in the frame of the flight arriving at them
    for j, tr in enumerate(st.treads):
        if not tr.landing:
            continue
        before = [i for i, fl in enumerate(flights) if fl.treads and fl.treads[-1] < j]
        d = boxes[before[-1]][0] if before else boxes[0][0]
        s0, s1, a0, a1 = _frame_extent(tr.polygon, d)
        across = np.array([-d[1], d[0]])
        corners = [d * u + across * v for u, v in ((s0, a0), (s1, a0), (s1, a1), (s0, a1))]
        segs += [[corners[i], corners[(i + 1) % 4]] for i in range(4)]
    # the walking line: along each flight, turning in the landings between them
    line: list = [walk[0][0], walk[0][1]]
    for i in range(1, len(walk)):
        d_prev, d_next = boxes[i - 1][0], boxes[i][0]
        a, b = walk[i - 1][1], walk[i][0]
        gap = b - a
        turn = float(d_prev @ d_next)
        # the landing between the two flights
        lands = [st.treads[j] for j in range(flights[i - 1].treads[-1] + 1, flights[i].treads[0]) if st.treads[j].landing]
        if turn < -0.5:  # a U: half way into the landing, across it, and back
            e = _frame_extent(lands[0].polygon, d_prev) if lands else (0.0, 0.0, 0.0, 0.0)
            t1 = a + d_prev * 0.5 * (e[1] - e[0])
            line += [t1, t1 + gap - d_prev * float(gap @ d_prev), b]
        elif turn < 0.5:  # an L: turning where the two flights' walking lines cross
            line += [a + d_prev * float(gap @ d_prev), b]
        else:
            line.append(b)
        line.append(walk[i][1])
    walk_pts = np.array(line, dtype=np.float64)
    keep = np.r_[True, np.linalg.norm(np.diff(walk_pts, axis=0), axis=1) > 1e-6]
    walk_pts = walk_pts[keep]
    arrow = walk_pts[-1] - walk_pts[-2] if len(walk_pts) >= 2 else np.asarray(st.direction)
    arrow = arrow / (np.linalg.norm(arrow) or 1.0)
    text = f"{st.risers} R {format_length(st.rise, imperial)} / {format_length(st.going, imperial)}"
    empty2, empty1 = np.zeros((0, 2, 2)), np.zeros((0, 2))
    lines = np.array(segs, dtype=np.float64).reshape(-1, 2, 2)
    if role == "upper":
        void = np.asarray(st.void.exterior.coords) if st.void is not None and not st.void.is_empty and st.void.geom_type == "Polygon" else empty1
        sym = StairSymbol(k, role, lines, empty2, walk_pts, empty1, (float(arrow[0]), float(arrow[1])), empty1, void, text, void_cross(void))
        return sym, None
    cut, high = _stair_cut(st, flights, boxes)
    if high is None:
        sym = StairSymbol(k, role, lines, empty2, walk_pts, empty1, (float(arrow[0]), float(arrow[1])), empty1, empty1, text)
        return sym, st.footprint
    ml = shapely.MultiLineString([s.tolist() for s in lines])
    wl = shapely.LineString(walk_pts)
    # the piece from the foot up to the cut, and the one from the cut to the top (the arrow's)
    below_walk = [c for c in _lines_of(wl.difference(high)) if np.linalg.norm(c[0] - walk_pts[0]) < 1e-6]
    above_walk = [c for c in _lines_of(wl.intersection(high)) if np.linalg.norm(c[-1] - walk_pts[-1]) < 1e-6]
    as3 = lambda g: np.array(_segments_of(g), dtype=np.float64).reshape(-1, 2, 2)  # noqa: E731
    sym = StairSymbol(
        k,
        role,
        as3(ml.difference(high)),
        as3(ml.intersection(high)),
        below_walk[0] if below_walk else empty1,
        above_walk[0] if above_walk else empty1,
        (float(arrow[0]), float(arrow[1])),
        cut,
        empty1,
        text,
    )
    return sym, st.footprint.buffer(0.02).difference(high)


def _stair_cut(st: StairElement, flights: list, boxes: list):
    """Where the plan's cut meets the stair: the break line across its flight (``(k, 2)``) and
    the plan area above the cut (``None`` when the whole stair is below it)."""
    heights = np.array([tr.height for tr in st.treads])
    above = np.flatnonzero(heights > st.cut_height)
    if not len(above):
        return np.zeros((0, 2)), None
    first = int(above[0])
    # the flight holding the first tread above the cut (a landing: the flight before it)
    fi = next((i for i, fl in enumerate(flights) if first in fl.treads), None)
    if fi is None:
        fi = max([i for i, fl in enumerate(flights) if fl.treads and fl.treads[-1] < first] or [0])
    d, across, s0, s1, a0, a1 = boxes[fi]
    fl = flights[fi]
    # the cut between the last tread below it and the first above, by height
    lo_k = [k for k in fl.treads if heights[k] <= st.cut_height]
    c_hi = np.asarray(st.treads[first].polygon.centroid.coords[0]) @ d
    if lo_k:
        c_lo = np.asarray(st.treads[lo_k[-1]].polygon.centroid.coords[0]) @ d
        h_lo, h_hi = heights[lo_k[-1]], heights[first]
        u = c_lo + (c_hi - c_lo) * (st.cut_height - h_lo) / max(h_hi - h_lo, 1e-6)
    else:
        u = s0 if first in fl.treads else s1
    width = a1 - a0
    slant = _CUT_SLANT * width
    u0 = u - 0.5 * slant

    def on_line(a_: float) -> float:  # s of the slanted line at across-coordinate a_
        return u0 + (a_ - a0) / max(width, 1e-6) * slant

    # from a little beyond one stringer to beyond the other, with a zig-zag mid-way
    ext = 0.05
    p0 = d * on_line(a0 - ext) + across * (a0 - ext)
    p1 = d * on_line(a1 + ext) + across * (a1 + ext)
    v = p1 - p0
    perp = np.array([-v[1], v[0]]) / (np.linalg.norm(v) or 1.0)
    z = _CUT_ZIGZAG_M
    cut = np.array([p0, p0 + 0.44 * v, p0 + 0.5 * v + perp * z, p0 + 0.5 * v - perp * z, p0 + 0.56 * v, p1])
    # above the cut: beyond the line in this flight, and every tread or flight after it
    far = 1e3
    half = shapely.Polygon(
        [d * on_line(a0 - 1) + across * (a0 - 1), d * on_line(a1 + 1) + across * (a1 + 1), d * far + across * (a1 + 1), d * far + across * (a0 - 1)]
    )
    flight_poly = shapely.Polygon([d * s0 + across * a0, d * s1 + across * a0, d * s1 + across * a1, d * s0 + across * a1]).buffer(0.03)
    parts = [flight_poly.intersection(half)]
    later = [i for i in range(len(flights)) if i > fi]
    for i in later:
        dd, aa, t0, t1, b0, b1 = boxes[i]
        parts.append(shapely.Polygon([dd * t0 + aa * b0, dd * t1 + aa * b0, dd * t1 + aa * b1, dd * t0 + aa * b1]).buffer(0.03))
    for j, tr in enumerate(st.treads):
        if tr.landing and (j >= first):
            d_l = boxes[fi][0]
            e0, e1, f0, f1 = _frame_extent(tr.polygon, d_l)
            aa = np.array([-d_l[1], d_l[0]])
            parts.append(shapely.Polygon([d_l * e0 + aa * f0, d_l * e1 + aa * f0, d_l * e1 + aa * f1, d_l * e0 + aa * f1]).buffer(0.03))
    high = shapely.union_all(parts)
    # a later flight passing beside the first (a U) is above the cut only where it is higher:
    # the first flight's part below the cut stays visible
    low_part = flight_poly.difference(half)
    if later:
        high = high.difference(low_part.buffer(-0.01))
    return cut, high


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
