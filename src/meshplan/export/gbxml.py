"""gbXML 7.03 export: the energy model of a result (``--gbxml``), and its envelope summary.

The model is a pure function of a :class:`~meshplan.result.Result` (:func:`energy_model`), written
as gbXML by :func:`gbxml_bytes` and summarized per facade orientation and per story by
:func:`envelope_summary` (the ``envelope`` block of plan.json). Its parts:

* a Campus with its Location (``site_lat_deg``, ``site_lon_deg``; ``north_deg`` as
  ``CADModelAzimuth``), one Building, a BuildingStorey per story at its floor height;
* one Space per room (its floor polygon as PlanarGeometry, its closed shell from floor to ceiling
  as ShellGeometry, its area, and its volume: area times the story's floor-to-ceiling height) and
  one Zone per Space;
* Surfaces derived from the room polygons, so that every surface bounds the rooms exactly:

  - **walls**: each edge of a room lying along an edge of another room of the story (antiparallel
    within :data:`PARALLEL_TOLERANCE_DEG`, at most a wall's thickness plus
    :data:`ADJACENT_SLACK_M` apart) is an ``InteriorWall`` with both rooms as AdjacentSpaceId,
    written once, on the edge of the room listed first; an edge with no room across is an
    ``ExteriorWall`` where the outside lies across it, or an adiabatic ``InteriorWall`` of one
    space where the building's footprint goes on (the end of a partition between two other
    rooms, or a strip of floor no room holds);
  - **floors**: ``SlabOnGrade`` on the lowest story; above it, the part of a room over a room of
    the story below is the ``Ceiling`` surface of that room (one surface for both spaces:
    ``Ceiling`` seen from below, ``InteriorFloor`` from above), the part over the lower story's
    walls an adiabatic ``InteriorFloor``, and the part over nothing an ``ExposedFloor``;
  - **ceilings**: shared with the story above as just said; ``Roof`` where nothing of the story
    above lies over the room (the whole ceiling on the top story), an adiabatic ``Ceiling`` under
    the upper story's walls;

* Openings in their host wall, at their true size (clipped to the wall only where they would
  overrun it): ``OperableWindow`` or ``FixedWindow`` (``window_type``) for windows,
  ``NonSlidingDoor`` for doors; each is put on the wall surface whose edge it lies on;
* default Materials, Layers, Constructions and a WindowType, stated in the file (see
  :data:`MATERIALS`, :data:`CONSTRUCTIONS`, :data:`WINDOW`);
* the annotations: a thermostat is its zone's thermostat location and a sensor a named point in
  its space. gbXML has no element for either, so both are ``AnalysisParameter`` elements of the
  Space (``parameterType="ThermostatLocation"`` / ``"SensorLocation"`` / ``"AnnotationLocation"``
  for kind ``other``; ``Name``: the label; ``ParameterValue``: ``"X Y Z"`` in gbXML metres;
  ``Description``: the kind and the probe direction), the documented extension point of the
  schema; the Zone gets its design heating and cooling temperatures (:data:`HEATING_SETPOINT_C`,
  :data:`COOLING_SETPOINT_C`) and, in its Description, the thermostat's label and position.

Frames: gbXML is z-up, so plan point (x, y, z) (y up) is gbXML point (x, -z, y), a rotation
(determinant +1; the IFC exporter does the same, see :func:`meshplan.export.ifc._ifc_xy`): seen
from above, the model looks like the drawings (x to the right, plan +z down the page). Every
polygon is closed implicitly (its first point is not repeated) and counter-clockwise seen from the
outside of the first adjacent space, so that its right-hand normal points away from that space
(gbXML's rule): walls outwards, floors down, ceilings and roofs up.

Orientation: ``north_deg`` is the compass bearing (degrees clockwise from true north, seen from
above) of gbXML +y, which is plan -z, up the page. The default, 0, makes up the page north and
plan +z south. A facade's orientation is the bearing of its outward normal, in four 90-degree
sectors centred on N, E, S and W.

Why one long module: gbXML's campus, spaces, zones, surfaces, openings and constructions are one
document whose ids refer to each other; its writer follows the schema's order, with the
surface orientation rules above shared by every surface kind.
"""

from __future__ import annotations

import math
import weakref
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..validation import plain_text

if TYPE_CHECKING:  # pragma: no cover
    from shapely.geometry import Polygon
    from shapely.geometry.base import BaseGeometry

    from ..result import Result

__all__ = [
    "COOLING_SETPOINT_C",
    "HEATING_SETPOINT_C",
    "EnergyModel",
    "EnergyOpening",
    "EnergySpace",
    "EnergySurface",
    "energy_model",
    "envelope_summary",
    "gbxml_bytes",
    "to_gbxml",
]

GBXML_NAMESPACE = "http://www.gbxml.org/schema"
GBXML_VERSION = "7.03"

#: Two room edges are the two faces of one wall when they run opposite ways within this angle
#: (degrees): room outlines follow walls fitted within a degree, 5 leaves room for noise.
PARALLEL_TOLERANCE_DEG = 5.0
#: Added to the largest wall thickness (``max_wall_thickness_m``) when looking across a wall for
#: the room on its other side (m): room outlines stand off the wall faces by up to a few cm.
ADJACENT_SLACK_M = 0.10
#: Two rooms may overlap by this much across a shared edge and still share it (m): outlines
#: closed by the floor can reach a centimetre or two into the neighbouring room.
OVERLAP_SLACK_M = 0.03
#: Shortest piece of wall made a surface (m); shorter pieces (corner rounding) are left out.
MIN_WALL_PIECE_M = 0.01
#: Smallest piece of floor or ceiling made a surface (m2): numerical dust of polygon clipping.
MIN_PIECE_AREA_M2 = 1e-4
#: Narrowest piece of floor or ceiling made a surface (m, twice its area over its perimeter):
#: where the outlines of two stories run a few millimetres apart, the strip between them is
#: left out rather than made a sliver surface (it costs a room under 0.3 % of its area).
MIN_SLIVER_M = 0.01
#: A room outline that turns back by more than 180 degrees less this (degrees) at a point has a
#: spike there (no building has so sharp a corner): the point is dropped.
SPIKE_ANGLE_DEG = 5.0
#: Grid (m) the polygons are snapped to: the 0.1 mm the coordinates are written with.
GRID_M = 1e-4
#: Distance across an unshared wall edge (m) at which the footprint is probed: inside it, the
#: wall faces more building (an adiabatic interior wall), outside it, the outdoors.
PROBE_M = 0.02
#: Space kept between an opening and the edges of its host wall (m): EnergyPlus wants a
#: subsurface strictly inside its base surface (a door may stand on the floor).
EDGE_MARGIN_M = 0.01
#: An opening is placed on a wall whose edge runs within this angle of its flat wall (degrees).
OPENING_ANGLE_DEG = 10.0
#: Narrowest opening kept after clipping to its wall (m).
MIN_OPENING_M = 0.05

#: Design heating and cooling temperatures of every zone (degrees C): the usual comfort band of
#: an office or a home in winter and in summer (ASHRAE 55), the thermostat's setpoints.
HEATING_SETPOINT_C = 20.0
COOLING_SETPOINT_C = 24.0

#: Default materials: id -> (name, thickness m, conductivity W/m-K, density kg/m3, specific heat
#: J/kg-K), typical values of the ASHRAE Handbook of Fundamentals (chapter 26).
MATERIALS: dict[str, tuple[str, float, float, float, float]] = {
    "mat-concrete-200": ("meshplan default: 200 mm heavyweight concrete", 0.20, 1.31, 2240.0, 836.0),
    "mat-concrete-150": ("meshplan default: 150 mm heavyweight concrete slab", 0.15, 1.31, 2240.0, 836.0),
    "mat-insulation-100": ("meshplan default: 100 mm mineral wool insulation", 0.10, 0.04, 30.0, 840.0),
    "mat-insulation-150": ("meshplan default: 150 mm mineral wool insulation", 0.15, 0.04, 30.0, 840.0),
    "mat-insulation-50": ("meshplan default: 50 mm rigid insulation", 0.05, 0.03, 35.0, 1400.0),
    "mat-gypsum-13": ("meshplan default: 13 mm gypsum board", 0.0127, 0.16, 800.0, 1090.0),
    "mat-stud-cavity-90": ("meshplan default: 90 mm insulated stud cavity", 0.09, 0.06, 60.0, 900.0),
    "mat-wood-45": ("meshplan default: 45 mm solid wood door", 0.045, 0.15, 600.0, 1630.0),
}
#: Default constructions, layers from the outside (or the second space) in: id -> (name, layers).
#: U-values (W/m2-K, with surface films): exterior wall 0.34, roof 0.24, slab 0.5, exposed floor
#: 0.33, partition 0.55, interior floor 2.3, door 2.1.
CONSTRUCTIONS: dict[str, tuple[str, tuple[str, ...]]] = {
    "con-exterior-wall": ("meshplan default exterior wall", ("mat-concrete-200", "mat-insulation-100", "mat-gypsum-13")),
    "con-interior-wall": ("meshplan default interior wall", ("mat-gypsum-13", "mat-stud-cavity-90", "mat-gypsum-13")),
    "con-roof": ("meshplan default roof", ("mat-insulation-150", "mat-concrete-150")),
    "con-slab": ("meshplan default slab on grade", ("mat-insulation-50", "mat-concrete-150")),
    "con-exposed-floor": ("meshplan default exposed floor", ("mat-insulation-100", "mat-concrete-150")),
    "con-interior-floor": ("meshplan default interior floor and ceiling", ("mat-concrete-150",)),
    "con-door": ("meshplan default door", ("mat-wood-45",)),
}
#: Default window: (id, name, U-value W/m2-K, solar heat gain coefficient, visible
#: transmittance): a double-glazed low-e unit.
WINDOW = ("win-double-low-e", "meshplan default window: double glazing, low-e", 1.8, 0.40, 0.60)

#: The construction of each surface type.
_CONSTRUCTION_OF = {
    "ExteriorWall": "con-exterior-wall",
    "InteriorWall": "con-interior-wall",
    "Roof": "con-roof",
    "SlabOnGrade": "con-slab",
    "ExposedFloor": "con-exposed-floor",
    "InteriorFloor": "con-interior-floor",
    "Ceiling": "con-interior-floor",
}
#: gbXML opening type of each window type option.
_WINDOW_TYPES = {"operable": "OperableWindow", "fixed": "FixedWindow"}
#: Compass sectors of the facade orientations, clockwise from north.
ORIENTATIONS = ("N", "E", "S", "W")
#: The fixed date of DocumentHistory/CreatedBy: the same result gives the same file.
_CREATED = "2000-01-01T00:00:00"


# ---------------------------------------------------------------------------------------------
# the model


@dataclass(frozen=True, eq=False)
class EnergySpace:
    """One room as a space (and its zone), gbXML coordinates.

    Attributes
    ----------
    id, zone_id
        gbXML ids of the Space and its Zone.
    room
        Index of the room in ``result.rooms``.
    story
        Index of its story.
    label
        The room's label.
    floor, ceiling
        Heights of its floor and ceiling (gbXML z, plan y).
    area
        Floor area (m2): the room's polygon.
    volume
        Area times the story's floor-to-ceiling height (m3).
    polygon
        The floor polygon in gbXML (x, y), holes included, counter-clockwise seen from above.
    """

    id: str
    zone_id: str
    room: int
    story: int
    label: str
    floor: float
    ceiling: float
    area: float
    volume: float
    polygon: Polygon


@dataclass(frozen=True, eq=False)
class EnergyOpening:
    """A door or window in its host surface.

    Attributes
    ----------
    id
        gbXML id.
    index
        Index of the opening in ``result.openings``.
    kind
        ``"door"`` or ``"window"``.
    opening_type
        gbXML ``openingType``.
    polygon
        (4, 3) gbXML points, wound as the host surface.
    width, height
        Its size in the model (m).
    clipped
        Whether it was cut down to fit its wall (else its size is the opening's own).
    """

    id: str
    index: int
    kind: str
    opening_type: str
    polygon: np.ndarray
    width: float
    height: float
    clipped: bool

    @property
    def area(self) -> float:
        """Area (m2)."""
        return self.width * self.height


@dataclass(frozen=True, eq=False)
class EnergySurface:
    """One gbXML Surface.

    Attributes
    ----------
    id
        gbXML id.
    kind
        gbXML ``surfaceType``.
    story
        Index of the story of its first space.
    spaces
        Indices into :attr:`EnergyModel.spaces`: one, or two for a surface shared by two spaces;
        the outward normal points away from the first.
    space_types
        The ``surfaceType`` each space sees (``Ceiling`` / ``InteriorFloor`` between stories).
    polygon
        (n, 3) gbXML points, counter-clockwise seen from outside the first space.
    exposed
        Exposed to the sun and the outside air.
    normal
        Unit outward normal (away from the first space), gbXML.
    area
        Area (m2).
    offset
        Translation (gbXML, m) that carries the surface onto the second space's own boundary:
        across the wall's thickness, or up through the slab between stories; zero otherwise.
    openings
        Its doors and windows.
    """

    id: str
    kind: str
    story: int
    spaces: tuple[int, ...]
    space_types: tuple[str, ...]
    polygon: np.ndarray
    exposed: bool
    normal: np.ndarray
    area: float
    offset: np.ndarray
    openings: tuple[EnergyOpening, ...] = ()

    @property
    def is_wall(self) -> bool:
        """An exterior or interior wall."""
        return self.kind in ("ExteriorWall", "InteriorWall")


@dataclass(frozen=True, eq=False)
class EnergyModel:
    """The energy model of a result (see the module docstring).

    Attributes
    ----------
    spaces
        One per room.
    surfaces
        Walls, floors, ceilings and roofs.
    stories
        ``(index, floor, ceiling)`` of every story.
    unplaced
        Indices (into ``result.openings``) of the openings that lie on no wall of a room.
    north_deg
        Compass bearing of gbXML +y (plan -z).
    """

    spaces: tuple[EnergySpace, ...]
    surfaces: tuple[EnergySurface, ...]
    stories: tuple[tuple[int, float, float], ...]
    unplaced: tuple[int, ...]
    north_deg: float

    def bearing(self, normal: np.ndarray) -> float:
        """Compass bearing (degrees clockwise from true north) of a gbXML direction."""
        return float((self.north_deg + math.degrees(math.atan2(normal[0], normal[1]))) % 360.0)


def _xy(xz: np.ndarray) -> np.ndarray:
    """Plan (x, z) to gbXML (x, y)."""
    a = np.asarray(xz, dtype=np.float64)
    return np.stack([a[..., 0], -a[..., 1]], axis=-1)


def _clean(geom: BaseGeometry) -> list[Polygon]:
    """The polygons of a geometry, snapped to :data:`GRID_M`, oriented (shell counter-clockwise,
    holes clockwise), without dust."""
    import shapely
    from shapely.geometry.polygon import orient

    out = []
    for g in shapely.get_parts(shapely.set_precision(geom, GRID_M)):
        if g.geom_type == "Polygon":
            if not g.is_empty and g.area >= MIN_PIECE_AREA_M2 and 2.0 * g.area / g.length >= MIN_SLIVER_M:
                out.append(orient(g, 1.0))
        elif g.geom_type in ("MultiPolygon", "GeometryCollection"):  # pragma: no cover - get_parts flattens one level
            out += _clean(g)
    return out


def _tidy(ring: np.ndarray) -> np.ndarray:
    """A closed ring's points (first not repeated) without repeated points, points in the middle
    of a straight run, and zero-width spikes (a run that doubles back on itself), which room
    outlines closed by the floor can hold and which would make walls facing into their room."""
    pts = [np.asarray(p, dtype=np.float64) for p in ring]
    changed = True
    while changed and len(pts) > 3:
        changed = False
        for k in range(len(pts)):
            a, b, c = pts[k - 1], pts[k], pts[(k + 1) % len(pts)]
            u, v = b - a, c - b
            lu, lv = float(np.hypot(*u)), float(np.hypot(*v))
            cross, dot = abs(float(u[0] * v[1] - u[1] * v[0])), float(u @ v)
            straight = cross < GRID_M * max(lu, lv)
            spike = dot < 0 and cross < math.sin(math.radians(SPIKE_ANGLE_DEG)) * lu * lv
            if lu < GRID_M or lv < GRID_M or straight or spike:
                del pts[k]
                changed = True
                break
    return np.array(pts)


def _hole_free(poly: Polygon) -> list[Polygon]:
    """``poly`` cut into pieces without holes (a gbXML PolyLoop has none): each hole is opened
    by a cut along y through its middle."""
    from shapely.geometry import LineString
    from shapely.ops import split

    if not poly.interiors:
        return [poly]
    hole = poly.interiors[0]
    x = float(np.mean(np.asarray(hole.coords)[:-1, 0]))
    y0, y1 = poly.bounds[1] - 1.0, poly.bounds[3] + 1.0
    pieces = split(poly, LineString([(x, y0), (x, y1)]))
    out: list[Polygon] = []
    for piece in _clean(pieces):
        out += _hole_free(piece)
    return out


def _pieces(geom: BaseGeometry) -> list[Polygon]:
    """Hole-free oriented pieces of a geometry."""
    return [p for g in _clean(geom) for p in _hole_free(g)]


def _ring(poly: Polygon, z: float, up: bool) -> np.ndarray:
    """A hole-free polygon's outline at height ``z``: counter-clockwise seen from above when
    ``up`` (normal up), else clockwise (normal down)."""
    xy = np.asarray(poly.exterior.coords)[:-1]
    if not up:
        xy = xy[::-1]
    return np.column_stack([xy, np.full(len(xy), z)])


def _polygon_area(points: np.ndarray) -> float:
    """Area of a planar 3D polygon (Newell's method)."""
    p = np.asarray(points, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    return float(0.5 * np.linalg.norm(np.cross(p, q).sum(axis=0)))


@dataclass
class _Edges:
    """Room outline edges of one story: the room on the left, the outside on the right."""

    p: np.ndarray  # (E, 2) start
    d: np.ndarray  # (E, 2) unit direction
    n: np.ndarray  # (E, 2) outward normal (right of d)
    length: np.ndarray  # (E,)
    space: np.ndarray  # (E,) index into the model's spaces


def _edges(spaces: list[EnergySpace]) -> _Edges:
    ps, qs, owner = [], [], []
    for k, sp in enumerate(spaces):
        for ring in (sp.polygon.exterior, *sp.polygon.interiors):
            c = np.asarray(ring.coords)
            ps.append(c[:-1])
            qs.append(c[1:])
            owner.append(np.full(len(c) - 1, k))
    if not ps:
        z = np.zeros((0, 2))
        return _Edges(z, z, z, np.zeros(0), np.zeros(0, np.int64))
    p, q = np.concatenate(ps), np.concatenate(qs)
    v = q - p
    length = np.linalg.norm(v, axis=1)
    keep = length > 1e-9
    p, v, length, space = p[keep], v[keep], length[keep], np.concatenate(owner)[keep]
    d = v / length[:, None]
    n = np.column_stack([d[:, 1], -d[:, 0]])
    return _Edges(p, d, n, length, space)


def _coverage(e: _Edges, max_gap: float) -> list[list[tuple[float, float, int, float]]]:
    """For every edge, its pieces ``(t0, t1, other space or -1, gap)`` along it: the stretches
    facing another room's edge across a wall (the nearest one where several do), and the rest."""
    m = len(e.length)
    out: list[list[tuple[float, float, int, float]]] = [[] for _ in range(m)]
    if m == 0:
        return out
    cos_tol = math.cos(math.radians(PARALLEL_TOLERANCE_DEG))
    q = e.p + e.d * e.length[:, None]
    # pairs (i, j): edge j of another room runs opposite to edge i, in front of it
    anti = (e.d @ e.d.T) < -cos_tol
    other = e.space[:, None] != e.space[None, :]
    sp = np.einsum("ijk,ik->ij", e.p[None, :, :] - e.p[:, None, :], e.n)  # gap at j's start
    sq = np.einsum("ijk,ik->ij", q[None, :, :] - e.p[:, None, :], e.n)
    near = (sp >= -OVERLAP_SLACK_M) & (sp <= max_gap) & (sq >= -OVERLAP_SLACK_M) & (sq <= max_gap)
    tp = np.einsum("ijk,ik->ij", e.p[None, :, :] - e.p[:, None, :], e.d)
    tq = np.einsum("ijk,ik->ij", q[None, :, :] - e.p[:, None, :], e.d)
    t0 = np.maximum(np.minimum(tp, tq), 0.0)
    t1 = np.minimum(np.maximum(tp, tq), e.length[:, None])
    ok = anti & other & near & (t1 - t0 > MIN_WALL_PIECE_M)
    for i in range(m):
        js = np.flatnonzero(ok[i])
        cands = [(float(t0[i, j]), float(t1[i, j]), int(e.space[j]), 0.5 * float(sp[i, j] + sq[i, j])) for j in js]
        cuts = sorted({0.0, float(e.length[i]), *(c[0] for c in cands), *(c[1] for c in cands)})
        pieces: list[tuple[float, float, int, float]] = []
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b - a <= 1e-9:
                continue
            mid = 0.5 * (a + b)
            over = [c for c in cands if c[0] <= mid <= c[1]]
            best = min(over, key=lambda c: (c[3], c[2])) if over else None
            who, gap = (best[2], best[3]) if best else (-1, 0.0)
            if pieces and pieces[-1][2] == who and abs(pieces[-1][1] - a) < 1e-9:
                pieces[-1] = (pieces[-1][0], b, who, pieces[-1][3])
            else:
                pieces.append((a, b, who, gap))
        out[i] = pieces
    return out


def _footprint(spaces: list[EnergySpace], radius: float) -> BaseGeometry:
    """The rooms of a story with the walls between them: their union closed by ``radius``."""
    from shapely import unary_union

    if not spaces:
        from shapely.geometry import Polygon

        return Polygon()
    u = unary_union([s.polygon for s in spaces])
    return u.buffer(radius, join_style="mitre").buffer(-radius, join_style="mitre")


class _Builder:
    """Collects surfaces with sequential ids."""

    def __init__(self) -> None:
        self.surfaces: list[dict[str, Any]] = []

    def add(self, kind: str, story: int, spaces: tuple[int, ...], polygon: np.ndarray, exposed: bool, normal, offset=None, space_types=(), edge=None) -> None:
        area = _polygon_area(polygon)
        if area < MIN_PIECE_AREA_M2:
            return
        self.surfaces.append(
            dict(
                kind=kind,
                story=story,
                spaces=spaces,
                space_types=tuple(space_types),
                polygon=polygon,
                exposed=exposed,
                normal=np.asarray(normal, dtype=np.float64),
                area=area,
                offset=np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64),
                edge=edge,
            )
        )


#: The energy model of each result still alive: plan.json's envelope, the report page's (its
#: plan document and its energy layers) and the command's summary each ask for it, four times a
#: run (9 ms each at 300k faces); a result is frozen, so its model is made once. Keyed weakly:
#: a result's entry goes with it.
_MODELS: weakref.WeakKeyDictionary[Result, EnergyModel] = weakref.WeakKeyDictionary()


def energy_model(result: Result) -> EnergyModel:
    """The energy model (spaces, surfaces, openings) of a result; see the module docstring.
    Made once per result (:data:`_MODELS`): every call with the same result returns the same
    model, which is not to be changed.

    Parameters
    ----------
    result
        What :func:`meshplan.run` found.

    Returns
    -------
    EnergyModel
    """
    model = _MODELS.get(result)
    if model is None:
        model = _MODELS[result] = _energy_model(result)
    return model


def _energy_model(result: Result) -> EnergyModel:
    """:func:`energy_model` itself, made anew."""
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    export = result.options.export
    stories = {s.index: s for s in result.orientation.stories}
    order = sorted(stories)
    spaces: list[EnergySpace] = []
    for k, room in enumerate(result.rooms):
        s = stories.get(room.story)
        if s is None:
            continue
        shell = _tidy(_xy(np.asarray(room.polygon.exterior.coords)[:-1]))
        holes = [h for h in (_tidy(_xy(np.asarray(r.coords)[:-1])) for r in room.polygon.interiors) if len(h) >= 3]
        polys = _clean(Polygon(shell, holes).buffer(0)) if len(shell) >= 3 else []
        if not polys:
            continue
        poly = max(polys, key=lambda p: p.area)
        poly = orient(poly, 1.0)
        n = len(spaces) + 1
        spaces.append(
            EnergySpace(
                f"space-{n}", f"zone-{n}", k, room.story, room.label, float(s.floor), float(s.ceiling), float(poly.area), float(poly.area * s.height), poly
            )
        )
    by_story = {i: [k for k, sp in enumerate(spaces) if sp.story == i] for i in order}
    max_gap = float(result.options.walls.max_wall_thickness_m) + ADJACENT_SLACK_M
    radius = 0.5 * max_gap
    footprints = {i: _footprint([spaces[k] for k in by_story[i]], radius) for i in order}
    b = _Builder()

    # walls
    for i in order:
        members = by_story[i]
        if not members:
            continue
        e = _edges([spaces[k] for k in members])
        e.space = np.asarray(members, dtype=np.int64)[e.space] if len(e.space) else e.space
        cover = _coverage(e, max_gap)
        s = stories[i]
        z0, z1 = float(s.floor), float(s.ceiling)
        for j, pieces in enumerate(cover):
            a_space = int(e.space[j])
            for t0, t1, other, gap in pieces:
                if t1 - t0 < MIN_WALL_PIECE_M:
                    continue
                pa, pb = e.p[j] + t0 * e.d[j], e.p[j] + t1 * e.d[j]
                poly = np.array([[*pa, z0], [*pb, z0], [*pb, z1], [*pa, z1]])
                normal = np.array([e.n[j][0], e.n[j][1], 0.0])
                edge = (e.p[j], e.d[j], t0, t1, z0, z1)
                if other >= 0:
                    if other < a_space:
                        continue  # written from the other room's edge
                    b.add("InteriorWall", i, (a_space, other), poly, False, normal, offset=[*(gap * e.n[j]), 0.0], edge=edge)
                    continue
                mid = 0.5 * (pa + pb) + PROBE_M * e.n[j]
                from shapely.geometry import Point

                inside = footprints[i].contains(Point(mid))
                b.add("InteriorWall" if inside else "ExteriorWall", i, (a_space,), poly, not inside, normal, edge=edge)

    # floors and ceilings
    from shapely import unary_union

    for pos, i in enumerate(order):
        below = order[pos - 1] if pos > 0 else None
        above = order[pos + 1] if pos + 1 < len(order) else None
        for k in by_story[i]:
            sp = spaces[k]
            # floor
            if below is None:
                for piece in _pieces(sp.polygon):
                    b.add("SlabOnGrade", i, (k,), _ring(piece, sp.floor, up=False), False, [0.0, 0.0, -1.0])
            else:
                under = [spaces[m].polygon for m in by_story[below]]
                rest = sp.polygon.difference(unary_union(under)) if under else sp.polygon
                for piece in _pieces(rest.intersection(footprints[below])):
                    b.add("InteriorFloor", i, (k,), _ring(piece, sp.floor, up=False), False, [0.0, 0.0, -1.0])
                for piece in _pieces(rest.difference(footprints[below])):
                    b.add("ExposedFloor", i, (k,), _ring(piece, sp.floor, up=False), True, [0.0, 0.0, -1.0])
            # ceiling
            if above is None:
                for piece in _pieces(sp.polygon):
                    b.add("Roof", i, (k,), _ring(piece, sp.ceiling, up=True), True, [0.0, 0.0, 1.0])
                continue
            over = by_story[above]
            for m in over:
                top = spaces[m]
                for piece in _pieces(sp.polygon.intersection(top.polygon)):
                    b.add(
                        "Ceiling", i, (k, m), _ring(piece, sp.ceiling, up=True), False, [0.0, 0.0, 1.0],
                        offset=[0.0, 0.0, top.floor - sp.ceiling], space_types=("Ceiling", "InteriorFloor"),
                    )
            upper = [spaces[m].polygon for m in over]
            rest = sp.polygon.difference(unary_union(upper)) if upper else sp.polygon
            for piece in _pieces(rest.intersection(footprints[above])):
                b.add("Ceiling", i, (k,), _ring(piece, sp.ceiling, up=True), False, [0.0, 0.0, 1.0])
            for piece in _pieces(rest.difference(footprints[above])):
                b.add("Roof", i, (k,), _ring(piece, sp.ceiling, up=True), True, [0.0, 0.0, 1.0])

    openings, unplaced = _place_openings(result, b.surfaces, max_gap)
    surfaces = []
    for n, d in enumerate(b.surfaces, start=1):
        surfaces.append(
            EnergySurface(
                f"surface-{n}", d["kind"], d["story"], d["spaces"], d["space_types"], d["polygon"], d["exposed"], d["normal"], d["area"], d["offset"],
                tuple(openings.get(n - 1, ())),
            )
        )
    levels = tuple((i, float(stories[i].floor), float(stories[i].ceiling)) for i in order)
    return EnergyModel(tuple(spaces), tuple(surfaces), levels, tuple(unplaced), float(export.north_deg))


def _place_openings(result: Result, surfaces: list[dict[str, Any]], max_gap: float) -> tuple[dict[int, list[EnergyOpening]], list[int]]:
    """Each opening on the wall surface whose edge it lies on (the nearest, within a wall's
    thickness), at its true size unless it would overrun the wall."""
    ops = result.openings
    out: dict[int, list[EnergyOpening]] = {}
    unplaced: list[int] = []
    if not len(ops):
        return out, unplaced
    centers = _xy(ops.center(result.walls))
    tangents = _xy(result.walls.tangent[ops.wall])
    walls = [(k, s) for k, s in enumerate(surfaces) if s["edge"] is not None]
    cos_tol = math.cos(math.radians(OPENING_ANGLE_DEG))
    window_type = _WINDOW_TYPES[result.options.export.window_type]
    counts = {"door": 0, "window": 0}
    for i in range(len(ops)):
        c, t = centers[i], tangents[i] / (np.linalg.norm(tangents[i]) or 1.0)
        best: tuple[float, int, float] | None = None
        for k, s in walls:
            if s["story"] != int(ops.story[i]):
                continue
            p, d, t0, t1, _, _ = s["edge"]
            if abs(float(d @ t)) < cos_tol:
                continue
            n = np.array([d[1], -d[0]])
            dist = abs(float((c - p) @ n))
            u = float((c - p) @ d)
            if dist <= max_gap and t0 - 1e-6 <= u <= t1 + 1e-6 and (best is None or dist < best[0]):
                best = (dist, k, u)
        if best is None:
            unplaced.append(i)
            continue
        _, k, u = best
        p, d, t0, t1, z0, z1 = surfaces[k]["edge"]
        width = float(ops.width[i])
        lo, hi = max(u - width / 2, t0 + EDGE_MARGIN_M), min(u + width / 2, t1 - EDGE_MARGIN_M)
        bottom, top = max(float(ops.bottom[i]), z0), min(float(ops.top[i]), z1 - EDGE_MARGIN_M)
        if ops.kind[i] == "window":
            bottom = max(bottom, z0 + EDGE_MARGIN_M)
        if hi - lo < MIN_OPENING_M or top - bottom < MIN_OPENING_M:
            unplaced.append(i)
            continue
        clipped = (hi - lo) < width - 1e-6 or (top - bottom) < float(ops.top[i] - ops.bottom[i]) - 1e-6
        pa, pb = p + lo * d, p + hi * d
        poly = np.array([[*pa, bottom], [*pb, bottom], [*pb, top], [*pa, top]])
        kind = ops.kind[i]
        counts[kind] += 1
        out.setdefault(k, []).append(
            EnergyOpening(
                f"opening-{i + 1}", i, kind, "NonSlidingDoor" if kind == "door" else window_type, poly, float(hi - lo), float(top - bottom), bool(clipped)
            )
        )
    return out, unplaced


# ---------------------------------------------------------------------------------------------
# gbXML


def _f(v: float) -> str:
    s = f"{float(v):.4f}"
    return "0.0000" if s == "-0.0000" else s


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    el = ET.SubElement(parent, tag, attrib)
    if text is not None:
        el.text = text
    return el


def _polyloop(parent: ET.Element, points: np.ndarray) -> ET.Element:
    loop = ET.SubElement(parent, "PolyLoop")
    for p in points:
        cp = ET.SubElement(loop, "CartesianPoint")
        for v in p:
            ET.SubElement(cp, "Coordinate").text = _f(v)
    return loop


def _annotation_space(model: EnergyModel, story: int, xy: np.ndarray) -> int | None:
    """The space of a story that holds a plan point, else the nearest within a metre."""
    from shapely.geometry import Point

    pt = Point(xy)
    best, best_d = None, 1.0
    for k, sp in enumerate(model.spaces):
        if sp.story != story:
            continue
        d = sp.polygon.distance(pt)
        if d == 0.0:
            return k
        if d < best_d:
            best, best_d = k, d
    return best


_ANNOTATION_PARAMETER = {"thermostat": "ThermostatLocation", "sensor": "SensorLocation", "other": "AnnotationLocation"}


def _annotations(result: Result, model: EnergyModel) -> dict[int | None, list[tuple[str, str, np.ndarray, np.ndarray]]]:
    """Space index (``None``: in no room) -> ``(kind, label, gbXML point, gbXML probe)`` of its
    thermostats, sensors and other annotations (doors and windows are openings already)."""
    ann = result.annotations
    out: dict[int | None, list[tuple[str, str, np.ndarray, np.ndarray]]] = {}
    for i, (label, kind) in enumerate(zip(ann.labels, ann.kinds)):
        if kind not in _ANNOTATION_PARAMETER:
            continue
        p = np.asarray(ann.positions[i], dtype=np.float64)
        d = np.asarray(ann.directions[i], dtype=np.float64)
        story = int(result.annotation_story[i]) if len(result.annotation_story) else 0
        point = np.array([p[0], -p[2], p[1]])
        probe = np.array([d[0], -d[2], d[1]]) if np.all(np.isfinite(d)) else np.full(3, np.nan)
        k = _annotation_space(model, story, point[:2])
        out.setdefault(k, []).append((kind, plain_text(label), point, probe))
    return out


def _analysis_parameter(parent: ET.Element, kind: str, label: str, point: np.ndarray, probe: np.ndarray) -> None:
    ap = _sub(parent, "AnalysisParameter", parameterType=_ANNOTATION_PARAMETER[kind], unit="Meters")
    _sub(ap, "Name", label)
    probe_text = f"; probe direction {_f(probe[0])} {_f(probe[1])} {_f(probe[2])}" if np.all(np.isfinite(probe)) else ""
    _sub(ap, "Description", f"meshplan {kind} annotation at X Y Z (gbXML metres){probe_text}")
    _sub(ap, "ParameterValue", " ".join(_f(v) for v in point))


def to_gbxml(result: Result, model: EnergyModel | None = None) -> ET.Element:
    """The gbXML document of a result, as an element tree (see :func:`gbxml_bytes`)."""
    if model is None:
        model = energy_model(result)
    export = result.options.export
    root = ET.Element(
        "gbXML",
        {
            "xmlns": GBXML_NAMESPACE,
            "version": GBXML_VERSION,
            "temperatureUnit": "C",
            "lengthUnit": "Meters",
            "areaUnit": "SquareMeters",
            "volumeUnit": "CubicMeters",
            "useSIUnitsForResults": "true",
        },
    )
    campus = _sub(root, "Campus", id="campus")
    _sub(campus, "Name", f"meshplan: {plain_text(result.input.path)}")
    loc = _sub(campus, "Location")
    _sub(loc, "Name", "site (meshplan --site-lat/--site-lon)")
    _sub(loc, "ZipcodeOrPostalCode", "unknown")
    _sub(loc, "Longitude", f"{export.site_lon_deg:.6f}")
    _sub(loc, "Latitude", f"{export.site_lat_deg:.6f}")
    _sub(loc, "CADModelAzimuth", f"{export.north_deg % 360.0:.6f}")
    building = _sub(campus, "Building", id="building", buildingType="Unknown")
    _sub(building, "Name", "Building")
    _sub(building, "Description", "made by meshplan from a scan: one space and zone per room; default constructions and setpoints stated in the file")
    _sub(building, "Area", _f(sum(s.area for s in model.spaces)))
    annotations = _annotations(result, model)
    for kind, label, point, probe in annotations.get(None, []):
        _analysis_parameter(building, kind, label, point, probe)
    for index, floor, _ in model.stories:
        st = _sub(building, "BuildingStorey", id=f"story-{index}")
        _sub(st, "Name", f"Story {index}")
        _sub(st, "Level", _f(floor))
    shells: dict[int, list[np.ndarray]] = {}
    for sp in model.spaces:
        shell = shells.setdefault(len(shells), [])
        for piece in _hole_free(sp.polygon):
            shell.append(_ring(piece, sp.floor, up=False))
            shell.append(_ring(piece, sp.ceiling, up=True))
        for ring in (sp.polygon.exterior, *sp.polygon.interiors):
            c = np.asarray(ring.coords)
            for p, q in zip(c[:-1], c[1:]):
                if np.linalg.norm(q - p) > MIN_WALL_PIECE_M:
                    shell.append(np.array([[*p, sp.floor], [*q, sp.floor], [*q, sp.ceiling], [*p, sp.ceiling]]))
    for k, sp in enumerate(model.spaces):
        el = _sub(building, "Space", id=sp.id, zoneIdRef=sp.zone_id, buildingStoreyIdRef=f"story-{sp.story}", conditionType="HeatedAndCooled")
        _sub(el, "Name", plain_text(sp.label))
        _sub(el, "Area", _f(sp.area))
        _sub(el, "Volume", _f(sp.volume))
        for kind, label, point, probe in annotations.get(k, []):
            _analysis_parameter(el, kind, label, point, probe)
        pg = _sub(el, "PlanarGeometry")
        _polyloop(pg, _ring(_hole_free(sp.polygon)[0], sp.floor, up=True) if sp.polygon.interiors else _ring(sp.polygon, sp.floor, up=True))
        sg = _sub(el, "ShellGeometry", id=f"shell-{k + 1}", unit="Meters")
        cs = _sub(sg, "ClosedShell")
        for loop in shells[k]:
            _polyloop(cs, loop)
        _sub(el, "CADObjectId", f"meshplan room {sp.room + 1}")
    for s in model.surfaces:
        el = _sub(campus, "Surface", id=s.id, surfaceType=s.kind, constructionIdRef=_CONSTRUCTION_OF[s.kind], exposedToSun="true" if s.exposed else "false")
        names = " / ".join(plain_text(model.spaces[k].label) for k in s.spaces)
        _sub(el, "Name", f"{names} {s.kind} {s.id.split('-')[1]}")
        for j, k in enumerate(s.spaces):
            attrs = {"spaceIdRef": model.spaces[k].id}
            if s.space_types:
                attrs["surfaceType"] = s.space_types[j]
            _sub(el, "AdjacentSpaceId", **attrs)
        pg = _sub(el, "PlanarGeometry")
        _polyloop(pg, s.polygon)
        for op in s.openings:
            attrs = {"id": op.id, "openingType": op.opening_type}
            if op.kind == "door":
                attrs["constructionIdRef"] = "con-door"
            else:
                attrs["windowTypeIdRef"] = WINDOW[0]
            oel = _sub(el, "Opening", **attrs)
            _sub(oel, "Name", f"{op.kind.capitalize()} {op.index + 1}")
            if op.clipped:
                _sub(oel, "Description", "cut down to fit its wall")
            opg = _sub(oel, "PlanarGeometry")
            _polyloop(opg, op.polygon)
    # constructions and materials: the stated defaults
    for cid, (name, layers) in CONSTRUCTIONS.items():
        con = _sub(root, "Construction", id=cid)
        _sub(con, "Name", name)
        for n, _ in enumerate(layers, start=1):
            _sub(con, "LayerId", layerIdRef=f"layer-{cid}-{n}")
    for cid, (_, layers) in CONSTRUCTIONS.items():
        for n, mid in enumerate(layers, start=1):
            layer = _sub(root, "Layer", id=f"layer-{cid}-{n}")
            _sub(layer, "MaterialId", materialIdRef=mid)
    for mid, (name, thickness, conductivity, density, heat) in MATERIALS.items():
        mat = _sub(root, "Material", id=mid)
        _sub(mat, "Name", name)
        _sub(mat, "R-value", f"{thickness / conductivity:.4f}", unit="SquareMeterKPerW")
        _sub(mat, "Thickness", f"{thickness:.4f}", unit="Meters")
        _sub(mat, "Conductivity", f"{conductivity:.4f}", unit="WPerMeterK")
        _sub(mat, "Density", f"{density:.1f}", unit="KgPerCubicM")
        _sub(mat, "SpecificHeat", f"{heat:.1f}", unit="JPerKgK")
    wid, wname, u, shgc, vt = WINDOW
    win = _sub(root, "WindowType", id=wid)
    _sub(win, "Name", wname)
    _sub(win, "U-value", f"{u:.3f}", unit="WPerSquareMeterK")
    _sub(win, "SolarHeatGainCoeff", f"{shgc:.3f}", unit="Fraction")
    _sub(win, "Transmittance", f"{vt:.3f}", unit="Fraction", type="Visible", surfaceType="Both")
    # zones: one per space, with the thermostat's setpoints and location
    for k, sp in enumerate(model.spaces):
        zone = _sub(root, "Zone", id=sp.zone_id)
        _sub(zone, "Name", f"{plain_text(sp.label)} Zone")
        stats = [a for a in annotations.get(k, []) if a[0] == "thermostat"]
        if stats:
            text = "; ".join(f"thermostat {label} at X Y Z {' '.join(_f(v) for v in point)} m" for _, label, point, _ in stats)
            _sub(zone, "Description", f"{text} (Space {sp.id} AnalysisParameter ThermostatLocation)")
        _sub(zone, "DesignHeatT", f"{HEATING_SETPOINT_C:.1f}", unit="C")
        _sub(zone, "DesignCoolT", f"{COOLING_SETPOINT_C:.1f}", unit="C")
    history = _sub(root, "DocumentHistory")
    _sub(history, "CreatedBy", programId="meshplan", date=_CREATED, personId="meshplan-user")
    prog = _sub(history, "ProgramInfo", id="meshplan")
    _sub(prog, "ProductName", "meshplan")
    _sub(prog, "Version", __version__)
    _sub(prog, "Platform", "Python")
    person = _sub(history, "PersonInfo", id="meshplan-user")
    _sub(person, "FirstName", "meshplan")
    _sub(person, "LastName", "user")
    return root


def gbxml_bytes(result: Result, model: EnergyModel | None = None) -> bytes:
    """The gbXML 7.03 document of a result (UTF-8, with its XML declaration).

    Parameters
    ----------
    result
        What :func:`meshplan.run` found.
    model
        Its energy model, when already made (:func:`energy_model`).

    Returns
    -------
    bytes
        The same result always gives the same bytes.
    """
    root = to_gbxml(result, model)
    ET.indent(root, space=" ")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8", xml_declaration=False) + b"\n"


# ---------------------------------------------------------------------------------------------
# envelope summary


def _sector(bearing: float) -> str:
    return ORIENTATIONS[int(((bearing + 45.0) % 360.0) // 90.0)]


def _ratio(a: float, b: float, nd: int) -> float:
    return round(a / b, nd) if b > 0 else 0.0


def envelope_summary(result: Result, ndigits: int = 4, model: EnergyModel | None = None) -> dict[str, Any]:
    """Window-to-wall ratio and envelope areas per facade orientation and per story.

    Parameters
    ----------
    result
        What :func:`meshplan.run` found.
    ndigits
        Digits kept for areas (m2) and ratios.
    model
        Its energy model, when already made.

    Returns
    -------
    dict
        The ``envelope`` block of plan.json (see its JSON Schema).
    """
    if model is None:
        model = energy_model(result)
    export = result.options.export

    def blank() -> dict[str, float]:
        return {"walls": 0, "wall_area": 0.0, "windows": 0, "window_area": 0.0, "doors": 0, "door_area": 0.0}

    facades = {(i, o): blank() for i, _, _ in model.stories for o in ORIENTATIONS}
    stories = {
        i: {"roof_area": 0.0, "slab_area": 0.0, "exposed_floor_area": 0.0, "interior_walls": 0, "interior_wall_area": 0.0, "shared_walls": 0, "floor_area": 0.0}
        for i, _, _ in model.stories
    }
    for sp in model.spaces:
        stories[sp.story]["floor_area"] += sp.area
    for s in model.surfaces:
        st = stories[s.story]
        if s.kind == "ExteriorWall":
            f = facades[(s.story, _sector(model.bearing(s.normal)))]
            f["walls"] += 1
            f["wall_area"] += s.area
            for op in s.openings:
                f[f"{op.kind}s"] += 1
                f[f"{op.kind}_area"] += op.area
        elif s.kind == "InteriorWall":
            st["interior_walls"] += 1
            st["interior_wall_area"] += s.area
            st["shared_walls"] += len(s.spaces) == 2
        elif s.kind == "Roof":
            st["roof_area"] += s.area
        elif s.kind == "SlabOnGrade":
            st["slab_area"] += s.area
        elif s.kind == "ExposedFloor":
            st["exposed_floor_area"] += s.area

    def finish(d: dict[str, float]) -> dict[str, Any]:
        out: dict[str, Any] = {k: (round(v, ndigits) if isinstance(v, float) else int(v)) for k, v in d.items()}
        out["wwr"] = _ratio(d["window_area"], d["wall_area"], ndigits)
        return out

    per_orientation = {o: blank() for o in ORIENTATIONS}
    per_story = {i: blank() for i, _, _ in model.stories}
    for (i, o), f in facades.items():
        for key, v in f.items():
            per_orientation[o][key] += v
            per_story[i][key] += v
    total = blank()
    for f in per_orientation.values():
        for key, v in f.items():
            total[key] += v
    return {
        "north_deg": round(float(export.north_deg), 6),
        "convention": (
            "orientation: compass bearing of each exterior wall's outward normal in four 90-degree sectors; north_deg is the bearing of plan -z "
            "(up the page), so with 0 plan -z is north and +z south; wwr: window area over gross exterior wall area"
        ),
        "site": {"latitude_deg": round(float(export.site_lat_deg), 6), "longitude_deg": round(float(export.site_lon_deg), 6)},
        "facades": [dict(story=i, orientation=o, **finish(facades[(i, o)])) for i, _, _ in model.stories for o in ORIENTATIONS],
        "orientations": [dict(orientation=o, **finish(per_orientation[o])) for o in ORIENTATIONS],
        "stories": [
            dict(story=i, **finish(per_story[i]), **{k: (round(v, ndigits) if isinstance(v, float) else int(v)) for k, v in stories[i].items()})
            for i, _, _ in model.stories
        ],
        "total": finish(total),
        "spaces": len(model.spaces),
        "surfaces": len(model.surfaces),
        "openings_unplaced": len(model.unplaced),
    }
