"""Rooms: the free space of each story divided by the drafting walls (not in the paper, which
measured rooms by hand in Rhino).

1. *Corners.* Scanned walls stop short of their corners (HoloLens meshes round them off). Each
   wall end is extended, by at most ``corner_extension_m``, to the nearest line of another wall
   it meets (an L corner extends both walls to their intersection, a T junction extends the stem
   to the face it meets).
2. *Arrangement.* The extended walls, plus the outline of the story's footprint (its floor and
   everything standing on it, grown by ``floor_margin_m`` so that it stays outside the walls),
   are noded and polygonized with shapely: every bounded face is a candidate room. Walls run
   through door openings (an opening does not split a flat wall), so rooms are closed across
   doors. The footprint rather than the floor alone: real scans rarely see the floor up to the
   walls, since furniture stands along them.
   A partition's free end runs on to the outline (the edge of the scan) or the next wall
   (:func:`~meshplan.plan.closure.run_to_boundary`): up to ``wall_gap_m`` always, up to
   ``room_mouth_m`` where a good part of it was scanned and no floor was seen where it would
   stand (a partition hidden by the stair beside it).
3. *Rooms.* Parts of a face narrower than a room (the inside of a partition, the strip between
   the outer walls and the outline) are cut off, since a room can leak through them into
   another face. A part is a room when it is large enough and mostly floored, or, where its
   floor was not scanned (a stair, whose treads stand above the floor; a corridor the sensor
   missed), when walls bound most of it and the sensor saw something in it. A room whose
   boundary follows the outline instead of walls (a wall the scan missed) is kept, ends where
   the footprint does, and is marked ``closed_by="floor"``; a space beyond a wall seen only
   from its other side (a corridor glimpsed through a door) is such a room too.

The room polygon is the net floor area between the inner wall faces; its points run
counter-clockwise as seen on the plan (x to the right, z down the page).

Why one long module: the arrangement of the extended walls, the floor rasters and the
classification of its faces are one algorithm whose steps share the story's walls and rasters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString, Polygon

from .._kernels import max_corner_distance
from ..geometry import FloatArray, Mesh
from ..orient import Orientation, Story, slab_faces
from ..units import FOOT_M
from ..walls import FlatWalls
from .closure import MIN_MEETING_ANGLE_DEG, NODE_OVERSHOOT_M, close_walls, end_crossings, reach_walls, run_to_boundary, straighten
from .params import PlanParams

#: Where the scanned floor closes a room, its outline loses notches and spikes narrower than
#: twice this (m): the floor's fringe (where the sensor's reach ends, furniture legs, chair
#: shadows) is ragged at that scale, a room's own corners and recesses are larger.
FLOOR_FRINGE_M = 0.2

#: Share of a face's outline that must lie on wall lines for the face to be a room although
#: its floor was not scanned at floor level (a stair, whose treads stand above it; a corridor
#: whose floor the sensor missed): three of four sides of a room, so a space open on one side
#: (a stair foot, a corridor mouth) still counts; an unscanned void outside the building is
#: bounded by one or two walls at most.
ENCLOSED_WALL_SHARE = 0.75

#: Share of such a face in which the sensor must have seen something of the story (any surface
#: between floor and ceiling: treads, walls, furniture), so that space no sensor saw does not
#: become a room because walls surround it.
ENCLOSED_SEEN_FRACTION = 0.5

#: Spacing (m) of the grid of points at which a face's floor cover is sampled: finer than the
#: smallest room width, coarse enough to be cheap.
COVER_SAMPLE_M = 0.1

#: Spacing (m) of the points along a face's outline at which its distance to the walls is
#: measured, and how close (m) a point must be to a wall line to lie on it (the 1 mm node
#: overshoot and the 0.1 mm slits are well inside it).
RING_SAMPLE_M = 0.1
ON_WALL_M = 0.02

#: Share of a face's outline that may lie off the wall lines when it is still closed by walls
#: (the slits' ends, rounding at the nodes).
OFF_WALL_SHARE = 0.05

#: Fewest points sampled on a face's outline (a tiny face still gets a fair test).
MIN_RING_SAMPLES = 8

#: Width (m) of the slits cut along the walls into the faces of the arrangement (0.1 mm: far
#: below any drawing's resolution, far above the rounding of the coordinates).
SLIT_M = 1e-4

#: How far (m) inside a face a point must lie to be in it rather than on its edge (1 mm).
INSIDE_M = 1e-3

#: A fragment touches a room when they come this close (m): across a slit, with room to spare.
TOUCH_M = 2e-3

#: Tolerance (m) of the polygon simplification that drops the collinear points the noding and
#: the slits leave (5 mm: within the scan's noise, far below a wall's thickness).
SIMPLIFY_M = 0.005

#: Notches narrower than this (m) in a room's outline are filled (a morphological closing): no
#: space is that narrow and no wall that thin, so such a notch is what two wall faces a few
#: millimetres apart leave when the sliver between them is dropped (a 4 mm slot 1.5 m deep in
#: a HoloLens hall), and an energy model or a label placer would take it for a wall.
NARROW_NOTCH_M = 0.05

#: Mitre limit of the buffers of the morphological opening (2: a right-angled corner keeps its
#: mitre, a spike does not).
OPENING_MITRE_LIMIT = 2.0

#: The points sampled on a floor triangle lie this many cells apart (0.7, a little under a
#: cell's half-diagonal times two, so that every cell a triangle covers gets a point).
FLOOR_SAMPLE_CELLS = 0.7

#: Triangles with an edge longer than this many cells are sampled over their surface for the
#: footprint; smaller ones count by their vertices, which the closing then joins.
BIG_TRIANGLE_CELLS = 2.0

#: Most subdivisions of a triangle's edges in :func:`sample_triangles` (bounds the memory for
#: absurdly large triangles: 64 x 64 / 2 points).
MAX_SUBDIVISIONS = 64

#: A segment's floor cover is sampled this many cells apart (a fifth: no cell is skipped).
SEGMENT_SAMPLE_CELLS = 0.2

#: Rooms are numbered from the top of the plan down and from left to right, their centroids
#: compared to this many decimals of a metre (0.1 m: a row of rooms whose centres differ by
#: scan noise stays one row).
ORDER_DECIMALS = 1

#: A room's ring starts at its top-left point compared to this many decimals of a metre (mm).
CANONICAL_DECIMALS = 3

#: Numeric tolerance (m) of a wall end's distance to the line it runs into (rounding only).
ROUNDING_M = 1e-9

#: Default ``slab_tolerance_m`` of :func:`find_rooms` (m): OrientParams' own default, the
#: height band about a floor level in which a face is floor.
SLAB_TOLERANCE_M = 0.1



@dataclass(frozen=True, eq=False)
class Room:
    """One room of a story (plan frame, metres)."""

    story: int
    label: str
    polygon: Polygon
    closed_by: str  # "walls", "extension" or "floor"
    #: set by :mod:`meshplan.plan.elements`: the number in reading order per story ("0.01"),
    #: the name (the user's from rooms.json, else the label), the type (room, corridor, stair,
    #: closet, open) and why, and how sure the room is (high, medium, low) and why
    number: str = ""
    name: str = ""
    type: str = "room"
    type_reason: str = ""
    confidence: str = ""
    confidence_reason: str = ""

    @property
    def area(self) -> float:
        return float(self.polygon.area)

    @property
    def width(self) -> float:
        """Extent along x."""
        b = self.polygon.bounds
        return float(b[2] - b[0])

    @property
    def depth(self) -> float:
        """Extent along z."""
        b = self.polygon.bounds
        return float(b[3] - b[1])

    def to_dict(self, ndigits: int = 4, imperial: bool = False) -> dict:
        coords = np.asarray(self.polygon.exterior.coords)[:-1]
        d = {
            "story": self.story,
            "label": self.label,
            "polygon": (np.round(coords, ndigits) + 0.0).tolist(),
            "area": round(self.area, ndigits),
            "width": round(self.width, ndigits),
            "depth": round(self.depth, ndigits),
            "closed_by": self.closed_by,
        }
        if self.number:
            d.update(number=self.number, name=self.name or self.label, type=self.type, type_reason=self.type_reason)
        if self.confidence:
            d["confidence"] = {"level": self.confidence, "reason": self.confidence_reason}
        if imperial:
            d["area_ft2"] = round(self.area / FOOT_M**2, 2)
        return d


@dataclass(frozen=True, eq=False)
class FloorRaster:
    """Where a story's floor was scanned, on a square grid (row = z, column = x)."""

    x0: float
    z0: float
    cell: float
    grid: np.ndarray

    def lookup(self, x: FloatArray, z: FloatArray) -> np.ndarray:
        c = np.floor((np.asarray(x) - self.x0) / self.cell).astype(np.int64)
        r = np.floor((np.asarray(z) - self.z0) / self.cell).astype(np.int64)
        ok = (r >= 0) & (r < self.grid.shape[0]) & (c >= 0) & (c < self.grid.shape[1])
        out = np.zeros(np.shape(c), dtype=bool)
        out[ok] = self.grid[r[ok], c[ok]]
        return out

    def segment_share(self, a: FloatArray, b: FloatArray) -> float:
        """Share (0-1) of the segment ``a``-``b`` (x, z) that lies over set cells (sampled at a
        fifth of a cell)."""
        n = max(2, int(np.ceil(np.hypot(*(np.asarray(b) - np.asarray(a))) / (SEGMENT_SAMPLE_CELLS * self.cell))) + 1)
        t = np.linspace(0.0, 1.0, n)
        p = np.asarray(a)[None, :] + t[:, None] * (np.asarray(b) - np.asarray(a))[None, :]
        return float(self.lookup(p[:, 0], p[:, 1]).mean())

    def outline(self, margin: float):
        """The floor's outer outline (holes filled) grown by ``margin``, or ``None``."""
        from scipy.ndimage import binary_fill_holes

        g = binary_fill_holes(self.grid)
        # every row's runs of set cells as boxes, row by row and left to right (the order of a
        # loop over the rows; found for all rows at once)
        pad = np.zeros((g.shape[0], g.shape[1] + 2), dtype=np.int8)
        pad[:, 1:-1] = g
        d = np.diff(pad, axis=1)
        rows, a = np.nonzero(d == 1)
        b = np.nonzero(d == -1)[1]
        if not len(rows):
            return None
        boxes = shapely.box(self.x0 + a * self.cell, self.z0 + rows * self.cell, self.x0 + b * self.cell, self.z0 + (rows + 1) * self.cell)
        return shapely.union_all(boxes).buffer(margin, join_style="mitre").simplify(self.cell)


def sample_triangles(triangles: FloatArray, spacing: float) -> FloatArray:
    """Points covering every triangle at most ``spacing`` apart (a barycentric grid per
    triangle; triangles are grouped by the subdivision they need, so the work is vectorized)."""
    tri = np.asarray(triangles, dtype=np.float64)
    if not len(tri):
        return np.zeros((0, 3))
    edge = max_corner_distance(np.ascontiguousarray(tri), np.ascontiguousarray(tri), 2)  # longest edges
    levels = np.clip(np.ceil(edge / spacing).astype(np.int64), 1, MAX_SUBDIVISIONS)
    out = []
    for k in np.unique(levels):
        t = tri[levels == k]
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = i + j <= k
        a, b = i[keep] / k, j[keep] / k
        w = np.stack([1 - a - b, a, b], axis=1)
        # (m, 3) @ (t, 3, 3) -> (t, m, 3): matmul's batched products, 2.5 times einsum's here
        out.append(np.matmul(w, t).reshape(-1, 3))
    return np.concatenate(out)


def _raster(pts: FloatArray, cell: float, like: FloorRaster | None = None) -> FloorRaster:
    """Cells holding at least one of ``pts`` (x, z), on the grid of ``like`` when given."""
    if like is None:
        if not len(pts):
            return FloorRaster(0.0, 0.0, cell, np.zeros((1, 1), dtype=bool))
        x0, z0 = pts[:, 0].min() - cell, pts[:, 1].min() - cell
        shape = (int((pts[:, 1].max() - z0) / cell) + 2, int((pts[:, 0].max() - x0) / cell) + 2)
        like = FloorRaster(float(x0), float(z0), cell, np.zeros(shape, dtype=bool))
    grid = np.zeros_like(like.grid)
    c = np.floor((pts[:, 0] - like.x0) / cell).astype(np.int64)
    r = np.floor((pts[:, 1] - like.z0) / cell).astype(np.int64)
    ok = (r >= 0) & (r < grid.shape[0]) & (c >= 0) & (c < grid.shape[1])
    grid.reshape(-1)[r[ok] * grid.shape[1] + c[ok]] = True  # flat indices: a third of the 2-d scatter's time
    return FloorRaster(like.x0, like.z0, cell, grid)


def floor_raster(mesh: Mesh, orientation: Orientation, story: Story, tolerance_m: float, cell: float) -> FloorRaster:
    """The story's floor surface rasterized at ``cell``."""
    floor = slab_faces(mesh.face_centroids[:, 1], mesh.face_normals[:, 1], (story,), tolerance_m, ceilings=False)
    floor &= orientation.face_story == story.index
    return _raster(sample_triangles(mesh.triangles[floor], cell * FLOOR_SAMPLE_CELLS)[:, [0, 2]], cell)


def footprint_raster(mesh: Mesh, orientation: Orientation, story: Story, floor: FloorRaster, closing_m: float, fill: bool = True) -> FloorRaster:
    """Where the story stands in plan: its floor and everything standing on it (walls,
    furniture), on the floor's grid, closed over gaps up to ``closing_m`` and with its holes
    filled.

    Real scans rarely see the floor up to the walls: furniture stands along them and hides it.
    The floor alone would close the rooms far inside their walls; the footprint reaches them.
    """
    from scipy.ndimage import binary_closing, binary_fill_holes

    faces = np.flatnonzero(orientation.face_story == story.index)
    h = mesh.face_centroids[faces, 1]
    faces = faces[(h > story.floor) & (h < story.ceiling)]
    # the vertices of faces up to two cells across cover them; larger faces are sampled
    k = max(1, int(round(closing_m / floor.cell)))
    # the small faces' corners rasterized in one compiled pass (their longest edges, their
    # corners' cells: no (F, 3, 3) gather, no vertex mask, no point array), the larger faces
    # sampled over their surface
    from .._kernels import footprint_vertices

    grid = np.zeros_like(floor.grid)
    big = footprint_vertices(
        mesh.triangles, mesh.faces, mesh.vertices, faces, BIG_TRIANGLE_CELLS * floor.cell, floor.x0, floor.z0, floor.cell, grid
    )
    grid |= _raster(sample_triangles(mesh.triangles[big], floor.cell)[:, [0, 2]], floor.cell, floor).grid
    grid |= floor.grid
    pad = np.pad(grid, k)
    grid = binary_closing(pad, np.ones((2 * k + 1, 2 * k + 1), dtype=bool))[k:-k, k:-k]
    return FloorRaster(floor.x0, floor.z0, floor.cell, binary_fill_holes(grid) if fill else grid)


def fill_holes(raster: FloorRaster) -> FloorRaster:
    """``raster`` with its holes filled (what :func:`footprint_raster` gives with ``fill``)."""
    from scipy.ndimage import binary_fill_holes

    return FloorRaster(raster.x0, raster.z0, raster.cell, binary_fill_holes(raster.grid))


def extend_walls(walls: FlatWalls, index: np.ndarray, reach_m: float) -> tuple[FloatArray, FloatArray]:
    """``u_min`` and ``u_max`` of the walls in ``index``, each end extended to the nearest wall
    line it meets within ``reach_m`` (and 1 mm past it, so that the lines cross and are noded
    despite rounding; polygonize drops the 1 mm dangles)."""
    u_lo = walls.u_min[index].copy()
    u_hi = walls.u_max[index].copy()
    n = len(index)
    if n < 2:
        return u_lo, u_hi
    tan, nor, off = walls.tangent[index], walls.normal[index], walls.offset[index]
    lo_b, hi_b = walls.u_min[index] - reach_m, walls.u_max[index] + reach_m
    for sign, ends in ((-1.0, walls.u_min[index]), (1.0, walls.u_max[index])):
        denom, s, ub = end_crossings(tan, nor, off, ends, sign)
        ok = (np.abs(denom) >= np.sin(np.radians(MIN_MEETING_ANGLE_DEG))) & (s >= -ROUNDING_M) & (s <= reach_m) & (ub >= lo_b[None, :]) & (ub <= hi_b[None, :])
        np.fill_diagonal(ok, False)
        best = np.where(ok, s, np.inf).min(axis=1)
        hit = np.isfinite(best)
        if sign < 0:
            u_lo[hit] -= best[hit] + NODE_OVERSHOOT_M
        else:
            u_hi[hit] += best[hit] + NODE_OVERSHOOT_M
    return u_lo, u_hi


def find_rooms(
    mesh: Mesh, orientation: Orientation, walls: FlatWalls, params: PlanParams | None = None, slab_tolerance_m: float = SLAB_TOLERANCE_M
) -> tuple[Room, ...]:
    """Rooms of every story, labelled ``Room 1``, ``Room 2``, ... story by story, then from the
    top of the plan down and from left to right."""
    params = params or PlanParams()
    found: list[tuple[int, Polygon, str]] = []
    for story in orientation.stories:
        found.extend((story.index, poly, how) for poly, how in story_rooms(mesh, orientation, walls, story, params, slab_tolerance_m))
    found.sort(key=lambda r: (r[0], round(r[1].centroid.y, ORDER_DECIMALS), round(r[1].centroid.x, ORDER_DECIMALS)))
    return tuple(Room(s, f"Room {i + 1}", _canonical(_fill_notches(poly)), how) for i, (s, poly, how) in enumerate(found))


def _fill_notches(poly: Polygon) -> Polygon:
    """``poly`` with the notches narrower than :data:`NARROW_NOTCH_M` filled (a closing with a
    square, which keeps right-angled corners); ``poly`` itself when it has none."""
    r = NARROW_NOTCH_M / 2
    closed = poly.buffer(r, join_style="mitre").buffer(-r, join_style="mitre")
    if not isinstance(closed, Polygon) or closed.is_empty or closed.area - poly.area <= SIMPLIFY_M * SIMPLIFY_M:
        return poly
    return shapely.orient_polygons(Polygon(shapely.simplify(closed, SIMPLIFY_M).exterior), exterior_cw=True)


def _canonical(poly: Polygon) -> Polygon:
    """The same ring started at its top-left point (smallest z, then x, to the millimetre), so
    that the polygon does not depend on the order in which shapely happened to build it."""
    ring = np.asarray(poly.exterior.coords)[:-1]
    key = np.round(ring, CANONICAL_DECIMALS)
    start = int(np.lexsort((key[:, 0], key[:, 1]))[0])
    return Polygon(np.roll(ring, -start, axis=0))


def story_rooms(mesh: Mesh, orientation: Orientation, walls: FlatWalls, story: Story, params: PlanParams, slab_tolerance_m: float) -> list[tuple[Polygon, str]]:
    """``(polygon, closed_by)`` of every room of one story."""
    index = np.flatnonzero(walls.story == story.index)
    raster = floor_raster(mesh, orientation, story, slab_tolerance_m, params.floor_cell_m)

    def segments(lo: FloatArray, hi: FloatArray) -> list[LineString]:
        t, n, o = walls.tangent[index], walls.normal[index], walls.offset[index]
        return [LineString([lo[k] * t[k] + o[k] * n[k], hi[k] * t[k] + o[k] * n[k]]) for k in range(len(index))]

    # the walls as scanned (corners only), and closed where the scan missed a piece of them
    scanned = segments(*extend_walls(walls, index, params.corner_extension_m))
    u_lo, u_hi, bridges = close_walls(walls, index, params.corner_extension_m, params.wall_gap_m, params.collinear_wall_m)
    seen = footprint_raster(mesh, orientation, story, raster, params.footprint_closing_m, fill=False)
    footprint = fill_holes(seen)
    outline = footprint.outline(params.floor_margin_m)
    u_lo, u_hi = run_to_boundary(walls, index, u_lo, u_hi, outline, params.wall_gap_m, params.room_mouth_m, raster.segment_share)
    lines = segments(u_lo, u_hi) + bridges
    wall_lines = MultiLineString(lines) if lines else None
    scanned_lines = MultiLineString(scanned) if scanned else None
    boundary = list(lines)
    if outline is not None:
        boundary.extend(p.exterior for p in shapely.get_parts(outline))
    if not boundary:
        return []
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(shapely.node(shapely.union_all(boundary)))))
    # A wall with the same face on both sides (one end free) is no edge of any face:
    # polygonize drops it. Cut every face along the walls (a 0.1 mm slit), so that two rooms
    # joined only around the free end of a wall by a strip narrower than a room come apart.
    slits = wall_lines.buffer(SLIT_M, cap_style="flat", join_style="mitre") if wall_lines is not None else None
    tight = None
    closed: list[tuple[Polygon, str]] = []
    open_parts: list[Polygon] = []
    for face in faces:
        if face.area < params.min_room_area_m2:
            continue
        if slits is not None:
            face = face.difference(slits)
        for part in _parts(face, params):
            room = _classify(part, raster, wall_lines, scanned_lines, params, seen)
            if room is None:
                continue
            if room[1] != "floor":
                closed.append(room)
                continue
            enclosed = not _floored(part, raster, params)  # walls and what was seen made it a room
            # where no wall closes it, the room ends where the story's footprint does (the
            # outline used for the arrangement lies a margin outside); what the footprint
            # splits apart is as many rooms
            if tight is None:
                tight = footprint.outline(params.floor_closure_margin_m)
            for piece in _parts(part.intersection(tight), params):
                if enclosed or _classify(piece, raster, None, None, params) is not None:
                    open_parts.append(Polygon(piece.exterior))
    # the rooms are carried up to the walls as closed (scanned, or continued where the scan
    # missed a piece): the lines that bound the arrangement's faces
    return _open_rooms(open_parts, closed, faces, params, segments(u_lo, u_hi), walls.normal[index])


def _open_rooms(
    parts: list[Polygon],
    closed: list[tuple[Polygon, str]],
    faces,
    params: PlanParams,
    wall_lines: Sequence[LineString] = (),
    wall_normals: FloatArray | None = None,
) -> list[tuple[Polygon, str]]:
    """The rooms that the scanned floor closes: straightened (:func:`straighten`) where the
    floor fills most of their rectangle, carried up to the walls (``wall_lines``, with the
    normals of their faces ``wall_normals``) they stop short of by at most ``wall_reach_m``
    (:func:`reach_walls`), and without fragments (pieces smaller than ``min_fragment_area_m2``
    are merged into a room they touch, or dropped)."""
    out: list[tuple[Polygon, str]] = []
    rooms = [p for p, _ in closed]
    small = [p for p in parts if p.area < params.min_fragment_area_m2]
    big = [p for p in parts if p.area >= params.min_fragment_area_m2]
    band = None
    for piece in big:
        # beyond the walls around the piece: every other face of the arrangement
        others = [f for f in faces if f.area > 0 and not f.buffer(-INSIDE_M).intersects(piece.representative_point())]
        beyond = shapely.union_all([f.buffer(-SLIT_M, join_style="mitre") for f in others] + rooms) if others or rooms else None
        if wall_lines and band is None:  # the same for every piece
            band = wall_band(list(wall_lines))
        shape = straighten(piece, beyond, params.open_room_fit_m, FLOOR_FRINGE_M, hold=band)
        # up to the walls, but not into another room (the faces beyond a wall the band
        # reaches are the band itself, between the floor's outline and the wall)
        if wall_normals is not None:
            taken = shapely.union_all(rooms) if rooms else None
            shape = reach_walls(shape, list(wall_lines), wall_normals, taken, params.wall_reach_m)
        rooms.append(shape)
        out.append((shapely.orient_polygons(shape, exterior_cw=True), "floor"))
    # a fragment joins the room it shares the most boundary with (a slit's width away)
    result = list(closed) + out
    for frag in small:
        touch = [(k, frag.buffer(TOUCH_M, join_style="mitre").intersection(p).area) for k, (p, _) in enumerate(result)]
        touch = [(k, a) for k, a in touch if a > 0]
        if not touch:
            continue
        k = max(touch, key=lambda t: t[1])[0]
        poly, how = result[k]
        merged = shapely.union_all([poly, frag.buffer(2 * SLIT_M, join_style="mitre")]).buffer(-SLIT_M, join_style="mitre")
        parts = [p for p in shapely.get_parts(merged) if isinstance(p, Polygon)]
        if parts:
            result[k] = (shapely.orient_polygons(Polygon(max(parts, key=lambda p: p.area).exterior), exterior_cw=True), how)
    return result


def wall_band(walls: list[LineString]):
    """The strip within :data:`FLOOR_FRINGE_M` of the wall lines, where a straightened room
    keeps its floor (:func:`meshplan.plan.closure.straighten`'s ``hold``)."""
    return shapely.union_all(shapely.buffer(np.asarray(walls, dtype=object), FLOOR_FRINGE_M, cap_style="flat"))


def _parts(shape, params: PlanParams) -> list[Polygon]:
    """The parts of ``shape`` wide and large enough to be rooms."""
    return [
        p
        for p in shapely.get_parts(_opening(shape, params.min_room_width_m / 2))
        if isinstance(p, Polygon) and p.area >= params.min_room_area_m2
    ]


def _opening(shape, radius: float):
    """Morphological opening with a square: drops the parts narrower than ``2 * radius`` and
    keeps right-angled corners."""
    # GEOS divides by zero on the collinear spikes that a shrunk ring can have; the result is
    # still right, so numpy's warning about it would only alarm the user
    with np.errstate(divide="ignore", invalid="ignore"):
        return shape.buffer(-radius, join_style="mitre").buffer(radius, join_style="mitre", mitre_limit=OPENING_MITRE_LIMIT).intersection(shape)


def _cover(face: Polygon, raster: FloorRaster) -> float:
    """Share (0-1) of ``face`` whose cells are set in ``raster``, sampled every
    :data:`COVER_SAMPLE_M`."""
    xmin, zmin, xmax, zmax = face.bounds
    mx, mz = np.meshgrid(np.arange(xmin, xmax, COVER_SAMPLE_M) + COVER_SAMPLE_M / 2, np.arange(zmin, zmax, COVER_SAMPLE_M) + COVER_SAMPLE_M / 2)
    gx, gz = mx.ravel(), mz.ravel()
    inside = shapely.contains_xy(face, gx, gz)
    if inside.sum() == 0:
        return 0.0
    return float(raster.lookup(gx[inside], gz[inside]).mean())


def _floored(face: Polygon, raster: FloorRaster, params: PlanParams) -> bool:
    """Whether floor was scanned under at least ``min_floor_fraction`` of ``face``."""
    return _cover(face, raster) >= params.min_floor_fraction


def _off_walls(face: Polygon, lines) -> float:
    """Share (0-1) of ``face``'s outline farther than :data:`ON_WALL_M` from ``lines``."""
    ring = face.exterior
    d = np.linspace(0, ring.length, max(MIN_RING_SAMPLES, int(ring.length / RING_SAMPLE_M)), endpoint=False)
    pts = shapely.line_interpolate_point(ring, d)
    return float(np.mean(shapely.distance(pts, lines) > ON_WALL_M))


def _classify(face: Polygon, raster: FloorRaster, wall_lines, scanned_lines, params: PlanParams, seen: FloorRaster | None = None):
    """``(polygon, closed_by)`` when the face is a room, else ``None``: ``closed_by`` is
    ``"walls"`` when scanned walls bound it, ``"extension"`` when walls continued across what
    the scan missed (:func:`close_walls`) do, else ``"floor"``.

    A face is a room when floor was scanned under enough of it (``min_floor_fraction``), or,
    where it was not (a stair, a corridor whose floor the sensor missed), when walls bound it on
    :data:`ENCLOSED_WALL_SHARE` of its outline and the sensor saw something of the story in
    :data:`ENCLOSED_SEEN_FRACTION` of it (``seen``)."""
    off = _off_walls(face, wall_lines) if wall_lines is not None else 1.0
    if not _floored(face, raster, params):
        if seen is None or 1.0 - off < ENCLOSED_WALL_SHARE or _cover(face, seen) < ENCLOSED_SEEN_FRACTION:
            return None
    closed_by = "floor"
    if wall_lines is not None and off <= OFF_WALL_SHARE:
        closed_by = "extension"
        if scanned_lines is not None and _off_walls(face, scanned_lines) <= OFF_WALL_SHARE:
            closed_by = "walls"
    poly = shapely.orient_polygons(Polygon(shapely.simplify(face, SIMPLIFY_M).exterior), exterior_cw=True)
    return poly, closed_by
