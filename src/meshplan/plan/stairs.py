"""Stairs (issue 16): flights of regular steps found in the stepped horizontal surfaces.

:func:`find_stairs` works in the plan frame (+y up), one story at a time, on the up-facing faces
between the story's floor and the next story's floor:

1. **Treads.** The faces are sampled on a grid of :data:`CELL_M` in plan and :data:`HEIGHT_CELL_M`
   in height; the occupied cells' connected components (26-connected) are the horizontal
   patches: a tread, a landing, a table top. Two steps, a rise apart, never touch.
2. **Chains.** A patch leads to another when it lies a rise (:data:`RISE_M`) higher and beside it
   in plan (:data:`ADJACENT_GAP_M`, not above it). The longest chain whose rises agree
   (:data:`RISE_TOL_M`) is a stair candidate.
3. **Flights.** The chain's centroids advance by a regular going (:data:`GOING_M`) along one
   direction; where they turn (a landing: U and L stairs) a new flight starts. A chain with a
   flight of :data:`MIN_FLIGHT_TREADS` treads or more is a stair.

The stair connects the story to the one above when its steps reach both floors; its risers are
then counted floor to floor (codes require equal risers in a flight, so ``rise = height /
risers``). Its footprint is the union of the hulls of consecutive treads; the void over it is the
part of the upper floor that was not scanned over the footprint (:func:`stair_void`). Everything
the stair symbol needs is kept: the treads (polygons and heights), the walking line with the
direction of ascent, and the plan's cut height (the treads above it are drawn dashed).

Why one long module: finding the treads, chaining them into flights, counting the risers, the
footprint and the void above are one detector whose steps share the tread arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from scipy import ndimage
from shapely.geometry import Polygon
from shapely.ops import unary_union

from ..geometry import Mesh

if TYPE_CHECKING:  # pragma: no cover
    from ..orient import Story
    from .rooms import Room

__all__ = ["Flight", "StairElement", "Tread", "attach_rooms", "find_stairs", "stair_void", "turned_pieces"]

#: Rise (m) of a step: building codes allow 0.14-0.22 m (Germany's DIN 18065 0.14-0.20 m, the
#: UK's Part K at most 0.22 m, the US IRC at most 7 3/4 in = 0.197 m, commercial stairs at least
#: 4 in = 0.10 m but rarely below 0.14 m).
RISE_M = (0.14, 0.22)
#: Rises of one stair agree within this (m) of the stair's: codes allow 3/8 in (9.5 mm) between
#: risers, but a scan's tread heights err by up to 3 cm each (noise, a slight tilt of the plan
#: frame), so one measured rise may be 4.5 cm off.
RISE_TOL_M = 0.045
#: Every tread lies this close (m) to its place on the fitted flight (floor + k rises).
FIT_TOL_M = 0.05
#: Going (m, nosing to nosing, measured centroid to centroid along the flight): codes ask for
#: 0.22-0.35 m (DIN 18065 0.23-0.37 m, IRC at least 10 in = 0.254 m, Part K 0.22-0.35 m) ...
GOING_M = (0.22, 0.35)
#: ... with this tolerance (m): a partly scanned tread moves its centroid.
GOING_TOL_M = 0.05
#: Steps of one flight keep their direction within this angle (degrees).
FLIGHT_ANGLE_DEG = 25.0
#: A stair has a flight of at least this many treads (two regular goings): fewer are a pair of
#: furniture tops.
MIN_FLIGHT_TREADS = 3
#: Plan grid (m) of the tread patches, ...
CELL_M = 0.05
#: ... their height grid (m): below a third of the lowest rise, so that steps never touch.
HEIGHT_CELL_M = 0.04
#: Up-facing faces: normal within 25 degrees of +y (HoloLens treads are noisy).
UP_NORMAL = 0.9
#: A tread patch is at least this large (m2): a third of a 0.25 x 0.6 m tread, what a sparse
#: scan sees of one.
TREAD_MIN_M2 = 0.03
#: ... and flat: its faces' heights spread (standard deviation, m) at most this.
TREAD_FLAT_M = 0.03
#: Consecutive treads lie within this gap (m) in plan (the nosing and holes of the scan) ...
ADJACENT_GAP_M = 0.15
#: ... and do not stand over each other (overlap at most this share of the smaller): a bookcase's
#: shelves are regular, but stacked.
STACKED_SHARE = 0.3
#: The lowest tread is at most this many rises above the floor for the stair to start on it (and
#: the highest as far below the next floor for it to arrive there): one tread may be missed, as
#: the last one under the upper floor's edge often is.
REACH_RISES = 2.5
#: The plan is cut at the drafting height: treads above it are drawn dashed, the stair's cut line
#: crosses the flight there.
_TINY = 1e-9


@dataclass(frozen=True, eq=False)
class Tread:
    """One horizontal patch of a stair: a tread or a landing (plan frame)."""

    polygon: Polygon
    height: float
    area: float
    landing: bool = False
    #: the mesh's faces in it (not in plan.json)
    faces: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64), repr=False)

    def to_dict(self, nd: int = 4) -> dict[str, Any]:
        return {
            "polygon": _coords(self.polygon, nd),
            "height": round(self.height, nd) + 0.0,
            "landing": self.landing,
        }


@dataclass(frozen=True, eq=False)
class Flight:
    """A straight run of steps: ``treads`` index the stair's treads (bottom first)."""

    treads: tuple[int, ...]
    direction: tuple[float, float]
    risers: int
    going: float

    def to_dict(self, nd: int = 4) -> dict[str, Any]:
        return {
            "treads": list(self.treads),
            "direction": [round(self.direction[0], 6) + 0.0, round(self.direction[1], 6) + 0.0],
            "risers": self.risers,
            "going": round(self.going, nd) + 0.0,
        }


@dataclass(frozen=True, eq=False)
class StairElement:
    """A stair found in the scan (plan frame, metres).

    Attributes
    ----------
    story, to_story
        The story it starts on and the one it arrives at (``None`` when its steps do not reach the
        next floor: a partly scanned stair).
    footprint
        Its plan outline: the union of the hulls of consecutive treads.
    treads
        Its treads and landings, bottom first.
    flights
        Its straight runs; one for a straight stair, two (a landing between) for L and U stairs.
    shape
        ``straight``, ``L``, ``U`` or ``winding`` (more turns).
    direction
        Direction of ascent of the first flight (unit ``[x, z]``).
    risers, rise, going
        Risers floor to floor, their height (equal risers: the storey height over the count; the
        fitted step height when the stair does not reach both floors) and the median going.
    bottom, top
        Heights of the floors (or of the lowest and highest treads, less and plus a rise) it joins.
    walking_line
        ``(k, 2)`` the tread centroids from bottom to top: the arrow of the stair symbol.
    cut_height
        Height of the plan's cut (story floor + drafting height): treads above it are drawn dashed.
    void
        The hole in the upper story's floor over the stair (``None`` without a story above).
    void_source
        ``scan`` (where the upper floor was not scanned over the footprint) or ``footprint``.
    room, room_above
        Index into ``Result.rooms`` of the room holding it and of the room it arrives in.
    confidence, confidence_reason
        ``high`` when it joins both floors with a full count of treads, ``medium`` when it joins
        them with treads missing, ``low`` when it does not reach both floors.
    """

    story: int
    to_story: int | None
    footprint: Polygon
    treads: tuple[Tread, ...]
    flights: tuple[Flight, ...]
    shape: str
    direction: tuple[float, float]
    risers: int
    rise: float
    going: float
    bottom: float
    top: float
    walking_line: np.ndarray
    cut_height: float
    void: Polygon | None = None
    void_source: str = "footprint"
    room: int | None = None
    room_above: int | None = None
    confidence: str = "low"
    confidence_reason: str = ""

    @property
    def width(self) -> float:
        """Clear width of the flights: the median tread extent across the direction of ascent."""
        widths = []
        for fl in self.flights:
            d = np.asarray(fl.direction)
            across = np.array([-d[1], d[0]])
            for k in fl.treads:
                xy = np.asarray(self.treads[k].polygon.exterior.coords)
                widths.append(float(np.ptp(xy @ across)))
        return float(np.median(widths)) if widths else 0.0

    def to_dict(self, nd: int = 4) -> dict[str, Any]:
        d: dict[str, Any] = {
            "story": self.story,
            "to_story": self.to_story,
            "shape": self.shape,
            "footprint": _coords(self.footprint, nd),
            "area": round(float(self.footprint.area), nd) + 0.0,
            "direction": [round(self.direction[0], 6) + 0.0, round(self.direction[1], 6) + 0.0],
            "risers": self.risers,
            "rise": round(self.rise, nd) + 0.0,
            "going": round(self.going, nd) + 0.0,
            "width": round(self.width, nd) + 0.0,
            "bottom": round(self.bottom, nd) + 0.0,
            "top": round(self.top, nd) + 0.0,
            "treads": [t.to_dict(nd) for t in self.treads],
            "flights": [f.to_dict(nd) for f in self.flights],
            "walking_line": (np.round(self.walking_line, nd) + 0.0).tolist(),
            "cut_height": round(self.cut_height, nd) + 0.0,
            "room": self.room,
            "room_above": self.room_above,
            "confidence": {"level": self.confidence, "reason": self.confidence_reason},
        }
        return d


def _coords(poly: Polygon, nd: int) -> list[list[float]]:
    xy = np.asarray(shapely.geometry.polygon.orient(poly, 1.0).exterior.coords)[:-1]
    return (np.round(xy, nd) + 0.0).tolist()


# --------------------------------------------------------------------------------------------
# Tread patches


def _face_samples(tri: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Points on every triangle (a barycentric lattice fine enough for ``cell``, and the
    centroid): ``(points (P, 3), face of each point (P,))``."""
    edge = float(np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2))) if len(tri) else 0.0
    s = int(np.clip(np.ceil(edge / cell), 1, 12))
    i, j = np.meshgrid(np.arange(s + 1), np.arange(s + 1), indexing="ij")
    keep = i + j <= s
    w = np.c_[i[keep], j[keep], s - i[keep] - j[keep]] / s
    w = np.vstack([w, [1 / 3, 1 / 3, 1 / 3]])
    pts = np.einsum("pk,fkd->fpd", w, tri)
    face = np.repeat(np.arange(len(tri)), len(w))
    return pts.reshape(-1, 3), face


def _patches(mesh: Mesh, lo: float, hi: float, either_way: bool = False) -> list[Tread]:
    """The horizontal patches of up-facing faces (of horizontal faces facing either way, with
    ``either_way``) with centroids between ``lo`` and ``hi``."""
    c = mesh.face_centroids
    ny = mesh.face_normals[:, 1]
    sel = np.flatnonzero(((np.abs(ny) if either_way else ny) > UP_NORMAL) & (c[:, 1] > lo) & (c[:, 1] < hi))
    if len(sel) == 0:
        return []
    tri = mesh.vertices[mesh.faces[sel]]
    pts, face = _face_samples(tri, CELL_M)
    pts[:, 1] = c[sel, 1][face]  # at the face's height: a long sloping face bridges no steps
    origin = pts.min(axis=0)
    ijk = np.floor((pts - origin) / np.array([CELL_M, HEIGHT_CELL_M, CELL_M])).astype(np.int64)
    shape = tuple(int(v) + 1 for v in ijk.max(axis=0))
    if int(np.prod(shape)) > 80_000_000:  # a huge building: coarser cells rather than memory
        return []
    grid = np.zeros(shape, dtype=bool)
    grid[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = True
    labels, n = ndimage.label(grid, structure=np.ones((3, 3, 3), dtype=bool))
    # each face takes the label of its centroid (the last sample of the face)
    per_face = len(pts) // len(sel)
    cen = ijk[per_face - 1 :: per_face]
    lab = labels[cen[:, 0], cen[:, 1], cen[:, 2]] - 1
    areas = mesh.face_areas[sel]
    y = c[sel, 1]
    wsum = np.bincount(lab, weights=areas, minlength=n)
    ymean = np.bincount(lab, weights=areas * y, minlength=n) / np.maximum(wsum, _TINY)
    yvar = np.bincount(lab, weights=areas * y * y, minlength=n) / np.maximum(wsum, _TINY) - ymean**2
    good = (wsum >= TREAD_MIN_M2) & (np.sqrt(np.maximum(yvar, 0.0)) <= TREAD_FLAT_M)
    keep = np.flatnonzero(good)
    if len(keep) == 0:
        return []
    # the hull of each kept patch's vertices, all at once
    fmask = good[lab]
    vx = tri[fmask][:, :, [0, 2]].reshape(-1, 2)
    remap = np.full(n, -1)
    remap[keep] = np.arange(len(keep))
    vidx = np.repeat(remap[lab[fmask]], 3)
    # each patch's distinct corners once (a vertex is the corner of about six faces): the same
    # hulls from a sixth of the points, whose geometries cost most of the hulls' time
    order = np.lexsort((vx[:, 1], vx[:, 0], vidx))
    v_sorted, i_sorted = vx[order], vidx[order]
    first = np.r_[True, (i_sorted[1:] != i_sorted[:-1]) | np.any(v_sorted[1:] != v_sorted[:-1], axis=1)]
    hulls = shapely.convex_hull(shapely.multipoints(v_sorted[first], indices=i_sorted[first]))
    # and each patch's faces, grouped the same way
    patch_of_face = remap[lab[fmask]]
    by_patch = np.argsort(patch_of_face, kind="stable")
    faces = np.split(sel[fmask][by_patch], np.cumsum(np.bincount(patch_of_face, minlength=len(keep)))[:-1])
    out = []
    for k, g, f in zip(keep, hulls, faces, strict=True):
        if isinstance(g, Polygon) and g.area > 0:
            out.append(Tread(g, float(ymean[k]), float(wsum[k]), faces=f))
    return out


# --------------------------------------------------------------------------------------------
# Chains and flights


def _adjacency(treads: list[Tread]) -> np.ndarray:
    """``(n, n)`` True where tread j may follow tread i in plan (beside it, not over it)."""
    polys = np.array([t.polygon for t in treads], dtype=object)
    dist = shapely.distance(polys[:, None], polys[None, :])
    inter = shapely.area(shapely.intersection(polys[:, None], polys[None, :]))
    areas = shapely.area(polys)
    smaller = np.minimum(areas[:, None], areas[None, :])
    cen = shapely.get_coordinates(shapely.centroid(polys))
    apart = np.linalg.norm(cen[:, None] - cen[None, :], axis=2)
    return (dist <= ADJACENT_GAP_M) & (inter <= STACKED_SHARE * smaller) & (apart >= 0.5 * GOING_M[0])


def _longest_chain(h: np.ndarray, adj: np.ndarray, rise: float) -> list[int]:
    """The longest chain of treads each ``rise`` (within :data:`RISE_TOL_M`) above and beside the
    one before (``h`` sorted ascending)."""
    n = len(h)
    dh = h[None, :] - h[:, None]
    ok = adj & (np.abs(dh - rise) <= RISE_TOL_M)
    length = np.ones(n, dtype=np.int64)
    prev = np.full(n, -1)
    for j in range(n):  # treads, not triangles: a few dozen per story
        cand = np.flatnonzero(ok[:j, j])
        if len(cand):
            best = cand[np.argmax(length[cand])]
            length[j] = length[best] + 1
            prev[j] = best
    j = int(np.argmax(length))
    chain = [j]
    while prev[chain[-1]] >= 0:
        chain.append(int(prev[chain[-1]]))
    return chain[::-1]


#: The rises tried when chaining treads lie this far apart (m).
RISE_STEP_M = 0.005


def _best_chain(h: np.ndarray, adj: np.ndarray, lowest: float, highest: float) -> list[int]:
    """The longest chain of :func:`_longest_chain` over the rises from ``lowest`` to ``highest``
    (m, :data:`RISE_STEP_M` apart; of equally long chains, the one of the lowest rise)."""
    best: list[int] = []
    for rise in np.arange(lowest, highest + 1e-9, RISE_STEP_M):
        chain = _longest_chain(h, adj, float(rise))
        if len(chain) > len(best):
            best = chain
    return best


def _flights(cen: np.ndarray) -> list[list[int]]:
    """Runs of consecutive treads (indices into ``cen``) advancing by a regular going along one
    direction."""
    d = np.diff(cen, axis=0)
    length = np.linalg.norm(d, axis=1)
    regular = (length >= GOING_M[0] - GOING_TOL_M) & (length <= GOING_M[1] + GOING_TOL_M)
    runs: list[list[int]] = []
    cos = np.cos(np.radians(FLIGHT_ANGLE_DEG))
    k = 0
    while k < len(d):
        if not regular[k]:
            k += 1
            continue
        u0 = d[k] / length[k]
        j = k
        while j + 1 < len(d) and regular[j + 1] and float(d[j + 1] @ u0) / length[j + 1] >= cos:
            j += 1
        runs.append(list(range(k, j + 2)))
        k = j + 1
    return [r for r in runs if len(r) >= 2]


def _shape(dirs: list[np.ndarray]) -> str:
    if len(dirs) == 1:
        return "straight"
    if len(dirs) == 2:
        c = float(dirs[0] @ dirs[1])
        return "U" if c < -0.7 else ("L" if abs(c) <= 0.7 else "straight")
    return "winding"


def _footprint(polys: list[Polygon]) -> Polygon:
    """Union of the hulls of consecutive treads (a U's two flights, an L's corner, not its empty
    quarter), its largest part without holes."""
    parts = [polys[0]] if len(polys) == 1 else [unary_union([a, b]).convex_hull for a, b in zip(polys[:-1], polys[1:])]
    u = unary_union(parts).buffer(0.01, join_style="mitre").buffer(-0.01, join_style="mitre")
    if not isinstance(u, Polygon):
        u = max(getattr(u, "geoms", [u]), key=lambda g: g.area)
    return Polygon(u.exterior)


def _stair(chain: list[Tread], story: Story, above: Story | None, cut_height: float) -> StairElement | None:
    cen = np.array([[t.polygon.centroid.x, t.polygon.centroid.y] for t in chain])
    runs = _flights(cen)
    if not any(len(r) >= MIN_FLIGHT_TREADS for r in runs):
        return None
    h = np.array([t.height for t in chain])
    step = float(np.median(np.diff(h)))
    floor = story.floor
    upper = above.floor if above is not None else None
    starts = h[0] - floor <= REACH_RISES * step
    arrives = upper is not None and upper - h[-1] <= REACH_RISES * step
    # fitted step height: treads at whole numbers of rises above the floor
    k = np.maximum(np.round((h - floor) / step), 1.0) if starts else np.arange(1, len(h) + 1, dtype=float)
    base = floor if starts else h[0] - step
    yk = h - base
    if arrives and upper is not None:
        n_up = max(int(round((upper - base) / step)), int(k[-1]) + 1)
        k, yk = np.r_[k, n_up], np.r_[yk, upper - base]
    fit = float(k @ yk / max(float(k @ k), _TINY))
    if not RISE_M[0] <= fit <= RISE_M[1] or np.max(np.abs(yk - k * fit)) > FIT_TOL_M:
        return None
    if (starts or arrives) and upper is not None:
        # a stair from one floor goes to the next: its risers are counted floor to floor
        risers = max(int(round((upper - floor) / fit)), len(chain) + 1)
        rise = (upper - floor) / risers
        bottom, top = floor, upper
    else:
        bottom = floor if starts else h[0] - fit
        top = upper if arrives and upper is not None else h[-1] + fit
        risers = int(round((top - bottom) / fit))
        rise = fit
    in_run = {i for r in runs for i in r}
    treads = tuple(replace(t, landing=i not in in_run) for i, t in enumerate(chain))
    flights = []
    dirs = []
    # each tread's number of rises above the bottom, the flights' risers between what they join
    steps = np.clip(np.round((h - bottom) / rise).astype(np.int64), 1, max(risers - 1, 1))
    for r in runs:
        below = int(steps[r[0] - 1]) if r[0] > 0 else 0
        beyond = int(steps[r[-1] + 1]) if r[-1] + 1 < len(chain) else risers
        d = cen[r[-1]] - cen[r[0]]
        u = d / max(float(np.linalg.norm(d)), _TINY)
        goings = np.diff(cen[r], axis=0) @ u
        flights.append(Flight(tuple(r), (float(u[0]), float(u[1])), max(beyond - below, len(r) + 1), float(np.median(goings))))
        dirs.append(u)
    goings_all = np.concatenate([np.diff(cen[list(f.treads)], axis=0) @ np.asarray(f.direction) for f in flights])
    full = starts and arrives and len(chain) == risers - 1
    if full:
        level, why = "high", f"all {len(chain)} treads found between the floors"
    elif starts and arrives:
        level, why = "medium", f"{len(chain)} of {risers - 1} treads found between the floors"
    elif upper is not None and (starts or arrives):
        level, why = "low", f"{len(chain)} of {risers - 1} treads found, from the {'lower' if starts else 'upper'} floor only"
    else:
        level, why = "low", f"{len(chain)} treads found; the stair reaches neither floor"
    return StairElement(
        story=story.index,
        to_story=above.index if above is not None and (starts or arrives) else None,
        footprint=_footprint([t.polygon for t in chain]),
        treads=treads,
        flights=tuple(flights),
        shape=_shape(dirs),
        direction=flights[0].direction,
        risers=risers,
        rise=float(rise),
        going=float(np.median(goings_all)),
        bottom=float(bottom),
        top=float(top),
        walking_line=cen,
        cut_height=float(cut_height),
        confidence=level,
        confidence_reason=why,
    )


def find_stairs(mesh: Mesh, stories: tuple[Story, ...], cut_height_m: float = 1.2, slab_tolerance_m: float = 0.1) -> tuple[StairElement, ...]:
    """The stairs of every story, bottom story first (plan frame mesh, normals into the rooms).

    ``cut_height_m`` is the drafting plan's cut above the floor (``PlanParams.drafting_height_m``);
    ``slab_tolerance_m`` how far from a floor's height its faces lie (the voids).
    """
    out: list[StairElement] = []
    for s, story in enumerate(stories):
        above = stories[s + 1] if s + 1 < len(stories) else None
        top = above.floor if above is not None else story.ceiling
        patches = _patches(mesh, story.floor + RISE_M[0] / 2, top - RISE_M[0] / 2)
        either: list[Tread] | None = None  # the same with down-facing faces, when a stair needs them
        while len(patches) >= MIN_FLIGHT_TREADS:
            order = np.argsort([t.height for t in patches], kind="stable")
            patches = [patches[i] for i in order]
            h = np.array([t.height for t in patches])
            chain = _best_chain(h, _adjacency(patches), *RISE_M)
            if len(chain) < MIN_FLIGHT_TREADS:
                break
            st = _stair([patches[i] for i in chain], story, above, story.floor + cut_height_m)
            used = set(chain)
            if st is not None and above is not None and st.confidence == "low":
                if either is None:
                    either = _patches(mesh, story.floor + RISE_M[0] / 2, top - RISE_M[0] / 2, either_way=True)
                longer = _completed(st, either, story, above, story.floor + cut_height_m)
                if longer is not None:
                    st = longer
                    taken = unary_union([t.polygon for t in st.treads])
                    used |= {i for i, t in enumerate(patches) if t.polygon.intersection(taken).area > STACKED_SHARE * t.polygon.area}
            patches = [t for i, t in enumerate(patches) if i not in used]
            if st is None:
                continue
            if above is not None and st.to_story is not None:  # the hole over it in the upper floor
                void, source = stair_void(mesh, st.footprint, above.floor, slab_tolerance_m)
                st = replace(st, void=void, void_source=source)
            out.append(st)
    return tuple(out)


#: A stair found from one floor only is completed from horizontal patches of either winding
#: within this distance (m) of its footprint: a U stair's other flight lies beside it.
COMPLETE_REACH_M = 1.5


def _completed(st: StairElement, either: list[Tread], story: Story, above: Story, cut_height: float) -> StairElement | None:
    """``st`` completed to both floors from horizontal patches facing either way, or ``None``.

    The winding repair (:func:`meshplan.orient.facing.inward_flips`) turns each connected piece
    of the mesh by the floors and ceilings in it; a piece that holds a stair's upper flight,
    whose treads pass the lower story's ceiling height, can be turned over with it, so that its
    treads face down and the stair seems to end halfway. A tread is a tread whichever way it was
    wound: the stair is looked for again near it among the horizontal patches of either winding,
    and taken only where it then reaches both floors with more treads, including the ones found.
    """
    near = st.footprint.buffer(COMPLETE_REACH_M)
    cand = [t for t in either if t.polygon.intersects(near)]
    if len(cand) <= len(st.treads):
        return None
    cand.sort(key=lambda t: t.height)
    best = _best_chain(np.array([t.height for t in cand]), _adjacency(cand), st.rise - RISE_TOL_M, st.rise + RISE_TOL_M)
    if len(best) <= len(st.treads):
        return None
    found = unary_union([t.polygon for t in st.treads])
    treads = [cand[i] for i in best]
    kept = sum(t.polygon.intersection(found).area for t in treads)
    if kept < (1.0 - STACKED_SHARE) * found.area:  # another stack of patches, not this stair
        return None
    longer = _stair(treads, story, above, cut_height)
    return longer if longer is not None and longer.confidence != "low" else None


def turned_pieces(mesh: Mesh, stairs: tuple[StairElement, ...]) -> np.ndarray:
    """``(F,)`` the faces of the pieces of ``mesh`` (connected components) that hold more of the
    stairs' treads facing down than facing up, by area: pieces the winding repair turned over
    (their treads voted as a ceiling seen from the wrong side, :func:`_completed`). Turned
    back, the upper flight and the walls that came with it face into the rooms again, as the
    3D models show them."""
    faces = [t.faces for s in stairs for t in s.treads]
    if not faces:
        return np.zeros(mesh.n_faces, dtype=bool)
    tread = np.concatenate(faces)
    ny = mesh.face_normals[tread, 1]
    if not np.any(ny < 0):  # every stair found on up-facing treads alone: nothing turned
        return np.zeros(mesh.n_faces, dtype=bool)
    comp = mesh.face_roots
    # each tread face's area, signed by the way it faces: up counts for the piece as it is
    vote = -np.sign(ny) * mesh.face_areas[tread]
    return np.bincount(comp[tread], weights=vote, minlength=int(comp.max()) + 1)[comp] > 0


#: The void is the part of the footprint (grown by this, m) the upper floor was not scanned over ...
VOID_REACH_M = 0.1
#: ... kept where it is at least this share of the footprint; else the footprint is the void.
VOID_MIN_SHARE = 0.3


def stair_void(mesh: Mesh, footprint: Polygon, floor: float, tolerance: float) -> tuple[Polygon, str]:
    """The hole in the floor at height ``floor`` over a stair: ``(polygon, "scan")`` where the
    floor was not scanned over its footprint, else ``(footprint, "footprint")``."""
    region = footprint.buffer(VOID_REACH_M, join_style="mitre")
    x0, z0, x1, z1 = region.bounds
    c = mesh.face_centroids
    sel = np.flatnonzero(
        (mesh.face_normals[:, 1] > UP_NORMAL) & (np.abs(c[:, 1] - floor) <= tolerance)
        & (c[:, 0] > x0 - 1) & (c[:, 0] < x1 + 1) & (c[:, 2] > z0 - 1) & (c[:, 2] < z1 + 1)
    )
    nx, nz = int(np.ceil((x1 - x0) / CELL_M)) + 1, int(np.ceil((z1 - z0) / CELL_M)) + 1
    covered = np.zeros((nx, nz), dtype=bool)
    if len(sel):
        pts, _ = _face_samples(mesh.vertices[mesh.faces[sel]], CELL_M)
        ij = np.floor((pts[:, [0, 2]] - [x0, z0]) / CELL_M).astype(np.int64)
        ok = (ij[:, 0] >= 0) & (ij[:, 0] < nx) & (ij[:, 1] >= 0) & (ij[:, 1] < nz)
        covered[ij[ok, 0], ij[ok, 1]] = True
        covered = ndimage.binary_closing(covered, iterations=2) | covered
    gx, gz = np.meshgrid(x0 + (np.arange(nx) + 0.5) * CELL_M, z0 + (np.arange(nz) + 0.5) * CELL_M, indexing="ij")
    inside = shapely.contains_xy(region, gx, gz)
    hole = ndimage.binary_opening(inside & ~covered, iterations=2)
    if hole.sum() * CELL_M**2 < VOID_MIN_SHARE * footprint.area:
        return footprint, "footprint"
    ii, jj = np.nonzero(hole)
    cells = shapely.box(x0 + ii * CELL_M, z0 + jj * CELL_M, x0 + (ii + 1) * CELL_M, z0 + (jj + 1) * CELL_M)
    u = unary_union(cells)
    if not isinstance(u, Polygon):
        u = max(getattr(u, "geoms", [u]), key=lambda g: g.area)
    u = Polygon(u.exterior).simplify(CELL_M / 2)
    if not isinstance(u, Polygon) or u.area < VOID_MIN_SHARE * footprint.area:
        return footprint, "footprint"
    return u, "scan"


def attach_rooms(stairs: tuple[StairElement, ...], rooms: tuple[Room, ...]) -> tuple[StairElement, ...]:
    """The stairs with the room holding each (most of its footprint) and the room above it (most
    of its void)."""

    def best(story: int | None, poly: Polygon | None) -> int | None:
        if story is None or poly is None:
            return None
        share = [(r.polygon.intersection(poly).area, i) for i, r in enumerate(rooms) if r.story == story]
        share = [x for x in share if x[0] > 0.1 * poly.area]
        return max(share)[1] if share else None

    return tuple(replace(s, room=best(s.story, s.footprint), room_above=best(s.to_story, s.void or s.footprint)) for s in stairs)
