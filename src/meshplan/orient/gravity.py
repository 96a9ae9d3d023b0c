"""Which way is up: the paper's "Orienting the floor", made to work on scans that are not y-up.

The paper assumes a rough up direction (+y) and refines it with spherical k-means (k = 1) on the
faces whose normals lie within a cone around it, the cone narrowing from 30 to 3 degrees
(Method 2); Method 1 takes the shortest edge of the bounding box. Real scans break the assumption:
z-up datasets, HoloLens 2 meshes whose frame is tilted by up to 40 degrees, and triangle winding
that may point the normals either way. So with ``up="auto"`` the rough direction is found first,
from the floor and ceiling structure:

1. *Axis.* The dominant axes of the face normals, sign ignored, are candidates, scored by the
   area facing along each plus twice its largest single level (:func:`_axis_evidence`): floors
   and ceilings make the up axis the heaviest, and when the ceiling is missing the floor, one
   level under every room, still outweighs walls split into many parallel planes. A candidate
   whose two main parallel surfaces are closer than a room height (the walls of a corridor) is
   demoted unless a good part of the walls rises past them (then they are a floor and a table
   top), as is one whose surfaces are not spread along the axis at all (a single wall). Each
   candidate is weighted, too, by the share of the horizon around its "floor" that its "walls"
   enclose (:func:`enclosure`): along a wall's normal a missing ceiling leaves a whole side open. The
   file's own axes play no part: the same building gives the same answer however it is turned.
2. *Refinement.* The paper's Method 2, with normals folded onto the axis' hemisphere so that
   floors and ceilings both contribute whatever their winding (the sign does not matter yet).
3. *Sign.* Furniture stands on the floor and the lower part of a room is scanned more densely than
   the upper part, so in the bottom third of each story the vertical surfaces cover much more of
   the plan than in the top third, and table tops, seats and sills lie in the lower half. The sign
   that puts the busier part at the bottom is up (:func:`sign_evidence`). The normals cannot
   tell: they may face either way.

:func:`refine_with_slabs` then fits the floors' common normal to face positions (see
``OrientParams.gravity_plane_fit``), so that the plan's floor is level. With
``gravity_fit_blend`` it is combined with Method 2's up by inverse variance instead: the fit's
from a block jackknife over the floor (:func:`floor_fit_uncertainty_deg`), the normals' a fixed
:data:`_NORMALS_ERROR_DEG`; a flat floor's fit wins (synthetic scans, HoloLens 2), a warped
floor's (the Tango rooms, domed by 3-4 cm) counts for less. Off by default: a floor plan wants its
floor level, and the real scans' truth is levelled on the floor the same way.

Decided against, measured on the 16 real scans (2026-12):

* *A prior from the file format* was first rejected, then adopted (issue 9) as a tie-breaker
  only: see ``declared_up`` of :func:`estimate_gravity`. glTF defines +y as up (and a USD stage
  its ``upAxis``, turned +y on reading); OBJ, PLY, STL and OFF define nothing, so for them the
  answer stays independent of how the file is turned, except for a file whose writer is known
  to use a gravity-aligned device frame (a HoloLens Device Portal OBJ, recognised by its
  layout): that up is a measurement, taken whenever a floor lies along it.
* *Objects ending on the floor* (the lower ends of vertical surfaces at one common level): the
  share of plan cells whose vertical surfaces end at the lowest main level does not separate the
  true axis from a wall's on the tatami room (0.39 against 0.47): furniture stands against walls
  as well as on floors, and floor, ceiling and side walls all end at a wall.
* *The desk fragment* (4.6 m2 of wall, 0.4 m2 of floor): the wall axis outscores the floor's four
  times on every cue; given the axis, up is 0.7 degrees off. Not reachable from its geometry
  alone; its Device Portal frame gives the axis (``DEVICE_PRIOR_SHARE``).

Why one long module: the up search is a chain of cues over the same candidate axes (areas,
levels, corridor rule, enclosure, sign evidence, slab refinement), each documented where it is
scored; the decisions measured and rejected are recorded here as well, next to the code they
would change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GeometryError
from ..geometry import AXIS_VECTORS, FloatArray, Mesh, unit
from ..sphere import axial_peaks
from .levels import _choose_stories, find_spikes
from .params import STANDING_DEG, OrientParams

#: Parallel surfaces closer than this (m) are one slab (a sunken floor, the faces of one
#: partition), not the two sides of a corridor.
_SAME_SLAB_M = 0.5

#: Horizontal clutter area (m2) added to both halves of a story before comparing them.
_CLUTTER_FLOOR_M2 = 0.5

#: Plan cell size (m) of the occupancy test deciding the sign of up.
_OCCUPANCY_CELL_M = 0.1

#: Share of the surfaces standing along a candidate axis (its walls, were it up) that may lie
#: beyond its two main parallel surfaces for those to be the two walls of a corridor. A
#: corridor's walls bound what stands between them, apart from door and window recesses; when a
#: quarter or more of the walls rises past the upper surface, that surface is a table top or a
#: platform 0.7-0.9 m above a floor whose ceiling was not scanned, not the far wall of a corridor.
_CORRIDOR_BEYOND_SHARE = 0.25

#: How far (m) past a main surface a wall must reach to count as lying beyond it: more than the
#: noise of a scanned surface and the depth of a skirting board or a window sill.
_CORRIDOR_BEYOND_M = 0.1

#: Number of equal sectors of the horizon, seen from the middle of the floor, in which the
#: enclosure test looks for walls: 10 degrees each. A doorway 1 m wide seen from 3 m spans 19
#: degrees, so an open door leaves one or two sectors empty, a whole missing side a third of them.
_ENCLOSURE_SECTORS = 36

#: A sector holds a wall when it holds at least this share of an even share of the wall area:
#: the test asks whether a side is walled at all, not how well its wall was scanned.
_ENCLOSURE_MIN_SHARE = 0.01

#: Spacing (m) of the points sampled on large triangles for the enclosure test, so that the few
#: metre-sized triangles of a parametric model (RoomPlan, Quest) count over their whole extent.
_ENCLOSURE_SAMPLE_M = 0.1

#: Most points sampled on one triangle (bounds the memory for absurdly large triangles).
_ENCLOSURE_MAX_SAMPLES = 10_000

#: Most faces of each kind (facing along the axis, standing along it) the enclosure test looks
#: at; beyond it a deterministic stride through them. The test asks which of its 36 sectors
#: hold any wall (1 % of an even share): 200k faces sample every sector of a building
#: thousands of times over, so a 3M-face scan costs no more here than a 300k one (six passes
#: over all faces were 2 s of its orientation).
_ENCLOSURE_MAX_FACES = 200_000

#: Two faces standing along a candidate up span the same interval along it when both their ends
#: agree to this (m): the walls of a parametric model (RoomPlan, Quest, a phone's room mode) are
#: rectangles from one floor to one wall top, exact to the millimetre.
_WALL_SPAN_BIN_M = 0.05

#: A model is made of wall rectangles (the common-span test applies) when along some candidate
#: up at least this share of the standing area lies in faces spanning one interval a room's
#: height long. Scanned meshes, whose faces span 1-25 cm, are far below it; parametric models
#: reach 0.5-0.85 along their true up.
_WALL_SPAN_MIN_SHARE = 0.3

#: Plan block (m) of the jackknife that measures how well the floors define their normal: larger
#: than a scanner's surface patches and the correlation length of its noise (10-50 cm), so that
#: blocks are nearly independent; small enough that one room gives a dozen blocks.
_JACKKNIFE_BLOCK_M = 1.0

#: Largest turn (degrees) of up that the slab fit may make (:func:`refine_with_slabs`): a
#: larger one means the slabs are not the floors and ceilings Method 2 leaned on.
_SLAB_FIT_MAX_TURN_DEG = 2.0

#: Margin (degrees) added to the cone of faces the slab fit looks at, beyond the horizontal
#: tolerance and the largest turn: the bound is exact, the margin only keeps rounding (and an
#: up a hair from unit length) from dropping a face at its edge.
_SLAB_FIT_MARGIN_DEG = 0.5

#: Accuracy (degrees, one standard deviation) of Method 2's up from the normals: its median
#: error on the synthetic rooms (0.4 degrees; see ``OrientParams.gravity_plane_fit``). The
#: weight of the normals when the floor fit is combined with them.
_NORMALS_ERROR_DEG = 0.4


#: Share of the best candidate's score that the axis a file format declares as up (glTF: +y,
#: by the specification) must reach to be taken instead. A missing ceiling halves the evidence of
#: the true axis (its weight is the floor and ceiling area) while two opposite walls a room
#: height apart keep theirs whole, so within a factor of two the geometry cannot decide and the
#: format's convention does; beyond it the geometry wins (an exporter that ignored the
#: convention). Measured: the tatami room's floor axis scores 0.86 of a wall pair's; on the real
#: scans the wrong axes score at most 0.87 of the true one, so no OBJ/PLY decision is near this.
FORMAT_PRIOR_SHARE = 0.5

#: The same share for the up of a device's gravity-aligned frame (a HoloLens Device Portal
#: export: :func:`meshplan.io.mesh.device_frame_up`): none. That up was measured by the device's
#: inertial sensors when it scanned, so the geometry need only show a floor along it (the
#: declared axis among the candidates, which already hold 5 % of the heaviest axis' area); a
#: fragment with more wall than floor outscores it otherwise (the desk fragment: 0.26 of a
#: wall's score).
DEVICE_PRIOR_SHARE = 0.0

#: The share of the best score the declared up must reach, by who declares it.
PRIOR_SHARE = {"format": FORMAT_PRIOR_SHARE, "device": DEVICE_PRIOR_SHARE}

#: What :attr:`GravityEstimate.sign_by` says when the declared up decided, by who declares it.
PRIOR_SIGN_BY = {"format": "file axes", "device": "device frame"}

#: Largest angle (degrees) between a candidate axis and the declared up for the candidate to be
#: the declared one: a scan's floor lies within a degree or two of its file's up when the file
#: follows its convention; the next candidate is a wall, 90 degrees away.
FORMAT_PRIOR_CONE_DEG = 10.0

@dataclass(frozen=True)
class Candidate:
    """A candidate up axis and how it scored."""

    axis: FloatArray
    weight: float  # see _axis_evidence
    plausibility: float
    score: float


@dataclass(frozen=True)
class GravityEstimate:
    """The up direction (against gravity) in input coordinates, and how it was found."""

    up: FloatArray
    method: str
    rough_up: FloatArray
    method_up: FloatArray  # the estimate of the paper's method, before any slab refinement
    sign_evidence: float  # log-ratio of bottom to top occupancy; positive supports ``up``
    candidates: tuple[Candidate, ...]
    faces_used: int  # faces in the final cone of Method 2 (0 for Method 1)
    sign_by: str = "furniture"  # what decided up from down: furniture, doors, walls on the floor, file axes, up option


def _story_intervals(h: FloatArray, horiz: np.ndarray, areas: FloatArray, params: OrientParams) -> list[tuple[float, float]]:
    """Floor-to-ceiling intervals along an axis (either sign), as :func:`find_levels` pairs them;
    the robust extent of the mesh when no pair is found (no ceiling)."""
    spikes = find_spikes(h[horiz], areas[horiz], params.level_bucket_m, params.spike_fraction)
    pairs = _choose_stories(spikes, params.min_room_height_m, params.max_story_height_m) if spikes else []
    intervals = [(spikes[f].height, spikes[c].height) for f, c in pairs]
    if not intervals:
        lo, hi = np.quantile(h, [0.005, 0.995]) if len(h) > 1 else (0.0, 0.0)
        if hi > lo:
            intervals = [(float(lo), float(hi))]
    return intervals


def sign_evidence(centroids: FloatArray, normals: FloatArray, areas: FloatArray, axis: FloatArray, params: OrientParams) -> float:
    """Evidence that ``axis`` (rather than ``-axis``) points up; positive supports ``axis``.

    The sum of two log-ratios, each comparing the bottom part of every story with its top part:

    * *occupancy*: plan cells (10 cm) covered by vertical surfaces in the band 10-40 % of the
      story height against the band 60-90 % (furniture stands on the floor; scanners see the
      lower walls better);
    * *clutter*: area of horizontal surfaces between floor and ceiling in the lower half against
      the upper half (table tops, seats, beds and sills are low; door heads are the main thing
      high up).
    """
    h = centroids @ axis
    nh = normals @ axis
    horiz = np.abs(nh) >= np.cos(np.radians(params.horizontal_tolerance_deg))
    intervals = _story_intervals(h, horiz, areas, params)
    if not intervals:
        return 0.0
    e1 = unit(np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0]))
    e2 = np.cross(axis, e1)
    vert = np.abs(nh) < np.cos(np.radians(STANDING_DEG))
    cv, hv = centroids[vert], h[vert]
    plan = np.floor(np.c_[cv @ e1, cv @ e2] / _OCCUPANCY_CELL_M).astype(np.int64)
    if len(plan):
        plan -= plan.min(axis=0)
        span = int(plan[:, 1].max()) + 1
        key = plan[:, 0] * span + plan[:, 1]
        cells = int(key.max()) + 1
    occ = np.zeros(2)
    clutter = np.zeros(2)
    for a, b in intervals:
        t = (hv - a) / (b - a)
        if len(plan):  # occupied cells, counted on a dense grid (no sorting)
            occ[0] += np.count_nonzero(np.bincount(key[(t > 0.1) & (t < 0.4)], minlength=cells))
            occ[1] += np.count_nonzero(np.bincount(key[(t > 0.6) & (t < 0.9)], minlength=cells))
        th = (h - a) / (b - a)
        mid = horiz & (th > 0.05) & (th < 0.95)
        clutter[0] += areas[mid & (th < 0.5)].sum()
        clutter[1] += areas[mid & (th >= 0.5)].sum()
    # a few door heads and window sills (well under a square metre) must not outvote the walls:
    # clutter counts once it is more than a small table top
    eps = max(0.01 * clutter.sum(), _CLUTTER_FLOOR_M2)
    return float(np.log((occ[0] + 1.0) / (occ[1] + 1.0)) + np.log((clutter[0] + eps) / (clutter[1] + eps)))


def _axis_evidence(
    centroids: FloatArray, normals: FloatArray, areas: FloatArray, axis: FloatArray, params: OrientParams, nh: FloatArray | None = None
) -> tuple[float, float]:
    """How much the surfaces perpendicular to ``axis`` look like floors and ceilings.

    Returns
    -------
    weight
        The area facing along the axis (either way) plus twice the area of its largest single
        level. The total alone is the paper's "largest cluster", which a scan without a ceiling
        halves while the two opposite walls of a room stay whole; the floor, though, is one
        level spanning every room where the walls split into many parallel planes, so doubling
        the largest level gives back to the floor what the missing ceiling took away.
    plausibility
        0-1: 0.3 when the two main parallel surfaces are closer than a room height (the walls
        of a corridor), 0.1 when almost nothing stands parallel to the axis (no walls).

    ``nh`` is ``normals @ axis`` when the caller has it.
    """
    if nh is None:
        nh = normals @ axis
    aligned = np.abs(nh) >= np.cos(np.radians(params.horizontal_tolerance_deg))
    h = centroids[aligned] @ axis
    spikes = find_spikes(h, areas[aligned], params.level_bucket_m, 0.25)
    weight = float(areas[aligned].sum()) + 2.0 * max((s.weight for s in spikes), default=0.0)
    vertical = np.abs(nh) <= np.sin(np.radians(params.wall_exclusion_deg))
    if len(spikes) >= 2:
        lo, hi = spikes[0].height, spikes[-1].height
        if _SAME_SLAB_M < hi - lo < params.min_room_height_m:
            # corridor walls bound what stands between them; a floor and a table top do not
            hv = centroids[vertical] @ axis
            beyond = (hv < lo - _CORRIDOR_BEYOND_M) | (hv > hi + _CORRIDOR_BEYOND_M)
            total = float(areas[vertical].sum())
            if total <= 0 or areas[vertical][beyond].sum() < _CORRIDOR_BEYOND_SHARE * total:
                return weight, 0.3
    if areas[vertical].sum() < 0.05 * areas.sum():
        return weight, 0.1
    return weight, 1.0


#: The R2 low-discrepancy sequence's base (the plastic number), whose multiples modulo 1 spread
#: the points sampled on a large triangle (:func:`_surface_samples`).
_R2_BASE = 1.32471795724474602596


def _single_samples(mesh: Mesh) -> FloatArray:
    """``(F, 3)``: the point :func:`_surface_samples` takes on each face that gets one point.

    The centroid, written as the sampling formula with both barycentric weights 1/3 (not as
    :attr:`Mesh.face_centroids`, which rounds differently), so that the points are the same to
    the last bit. Computed once per mesh: the enclosure test samples the faces of every
    candidate axis twice (six passes over the faces), and at 300k faces gathering the corners
    again and evaluating the formula each time was a quarter of the orientation's time.
    """
    from .._kernels import third_points  # numba: loaded when first needed

    return third_points(mesh.triangles)  # the formula in one compiled pass, to the bit


def _surface_samples(mesh: Mesh, faces: np.ndarray, spacing: float, single: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Points spread over the faces ``faces`` (indices) about ``spacing`` apart, and the area
    each stands for.

    A small triangle (scans: 1-10 cm) gives its centroid; a large one (a parametric wall: one
    triangle of several square metres) gives a low-discrepancy set of points over its whole
    surface, so that a test sees where its surface is, not only where its centre is.
    Deterministic. ``single`` is :func:`_single_samples` of the mesh when the caller has it
    (it is computed here otherwise); the points come face by face, in the order of ``faces``.
    """
    areas = mesh.face_areas[faces]
    k = np.clip(np.ceil(areas / spacing**2), 1, _ENCLOSURE_MAX_SAMPLES).astype(np.int64)
    if k.max(initial=1) == 1:  # a scanned mesh: one point per face, each standing for its face (area / 1)
        return (_single_samples(mesh) if single is None else single)[faces], areas
    start = np.cumsum(k) - k
    pts = np.empty((int(k.sum()), 3))
    one = k == 1
    # most scanned faces get one point: taken from the precomputed ones, no corner gathered
    pts[start[one]] = (_single_samples(mesh) if single is None else single)[faces[one]]
    many = np.flatnonzero(~one)
    if len(many):
        km = k[many]
        rep = np.repeat(faces[many], km)
        j = np.arange(len(rep)) - np.repeat(np.cumsum(km) - km, km)
        # the R2 sequence folded into the triangle
        u = (0.5 + j / _R2_BASE) % 1.0
        v = (0.5 + j / _R2_BASE**2) % 1.0
        fold = u + v > 1.0
        u[fold], v[fold] = 1.0 - u[fold], 1.0 - v[fold]
        tri = mesh.triangles[rep]
        pts[np.repeat(start[many], km) + j] = tri[:, 0] + u[:, None] * (tri[:, 1] - tri[:, 0]) + v[:, None] * (tri[:, 2] - tri[:, 0])
    return pts, np.repeat(areas / k, k)


def common_wall_span(mesh: Mesh, axis: FloatArray, params: OrientParams, nh: FloatArray | None = None) -> float:
    """Share (0-1) of the area standing along ``axis`` that lies in faces spanning one common
    interval along it, a room's height long (``min_room_height_m`` to ``max_story_height_m``).

    Were ``axis`` up, in a model made of wall rectangles (parametric exports) the walls stand on
    one floor and rise to one height, so most of that area shares one span. Along a wall's
    normal the surfaces standing along it are the floor and the other walls, whose extents vary
    with the plan. A scanned mesh's faces span centimetres: 0 along every axis. ``nh`` is
    ``mesh.face_normals @ axis`` when the caller has it.
    """
    if nh is None:
        nh = mesh.face_normals @ axis
    vertical = np.flatnonzero(np.abs(nh) <= np.sin(np.radians(params.wall_exclusion_deg)))
    if not len(vertical):
        return 0.0
    from .._kernels import span_bins  # numba: loaded when first needed

    # the corners' heights, from every vertex's projected once: the same products, row for row,
    # as projecting the gathered corners (which took 60 % of the test at 300k faces); their
    # lowest and highest bins in one compiled pass
    lo, hi = span_bins(mesh.vertices @ axis, mesh.faces, vertical, _WALL_SPAN_BIN_M)
    areas = mesh.face_areas[vertical]
    span = (hi - lo) * _WALL_SPAN_BIN_M
    tall = (span >= params.min_room_height_m) & (span <= params.max_story_height_m)
    total = float(areas.sum())
    if not tall.any() or total <= 0:
        return 0.0
    base = lo[tall].min()
    key = (lo[tall] - base) * (hi[tall].max() - base + 1) + (hi[tall] - base)
    _, inverse = np.unique(key, return_inverse=True)
    return float(np.bincount(inverse, weights=areas[tall]).max() / total)


def _weighted_median(x: FloatArray, w: FloatArray) -> float:
    """The first ``x``, in stable sorted order, at which the cumulative weight reaches half."""
    from .._kernels import stable_argsort_f64  # numba: loaded when first needed

    order = stable_argsort_f64(np.ascontiguousarray(x, dtype=np.float64))  # numpy's stable order, by radix
    cum = np.cumsum(w[order])
    return float(x[order][min(int(np.searchsorted(cum, 0.5 * cum[-1])), len(x) - 1)])


def enclosure(mesh: Mesh, axis: FloatArray, params: OrientParams, single: FloatArray | None = None, nh: FloatArray | None = None) -> float:
    """Share (0-1) of the horizon, seen from the middle of the floor, in which walls stand,
    were ``axis`` up.

    Walls surround a floor on every side, whether the ceiling was scanned or not. Along a wrong
    axis (a wall's normal) the "walls" are the floor, the ceiling and the other walls, so a
    missing ceiling (RoomPlan models have none; phones and HoloLens often miss it) leaves a whole
    side of that "room" open: a third of its horizon. The horizon is cut into
    :data:`_ENCLOSURE_SECTORS` sectors around the area-weighted median of the surfaces facing
    along the axis (floor and ceiling, were it up); a sector is walled when surfaces standing
    along the axis lie in it. A scan of part of a room (a corner) is open on its unscanned sides
    along every axis, the true one included, so this weighs candidates against each other and
    rejects none. ``single`` is :func:`_single_samples` of the mesh, for a caller testing
    several axes (computed here when omitted); ``nh`` is ``mesh.face_normals @ axis`` when the
    caller has it.
    """
    if nh is None:
        nh = mesh.face_normals @ axis
    aligned = np.flatnonzero(np.abs(nh) >= np.cos(np.radians(params.horizontal_tolerance_deg)))
    vertical = np.flatnonzero(np.abs(nh) <= np.sin(np.radians(params.wall_exclusion_deg)))
    if not len(aligned) or not len(vertical):
        return 0.0
    aligned = aligned[:: -(-len(aligned) // _ENCLOSURE_MAX_FACES)]
    vertical = vertical[:: -(-len(vertical) // _ENCLOSURE_MAX_FACES)]
    e1 = unit(np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0]))
    basis = np.c_[e1, np.cross(axis, e1)]
    if single is None:
        single = _single_samples(mesh)
    pa, wa = _surface_samples(mesh, aligned, _ENCLOSURE_SAMPLE_M, single)
    plan = pa @ basis
    centre = np.array([_weighted_median(plan[:, 0], wa), _weighted_median(plan[:, 1], wa)])
    pv, wv = _surface_samples(mesh, vertical, _ENCLOSURE_SAMPLE_M, single)
    d = pv @ basis - centre
    sector = np.floor((np.arctan2(d[:, 1], d[:, 0]) + np.pi) / (2.0 * np.pi) * _ENCLOSURE_SECTORS).astype(np.int64)
    walls = np.bincount(sector % _ENCLOSURE_SECTORS, weights=wv, minlength=_ENCLOSURE_SECTORS)
    return float(np.mean(walls >= _ENCLOSURE_MIN_SHARE * wv.sum() / _ENCLOSURE_SECTORS))


def _refine_kmeans(normals: FloatArray, areas: FloatArray, rough: FloatArray, cones_deg: tuple[float, ...]) -> tuple[FloatArray, int]:
    """The paper's Method 2: spherical k-means with k = 1 inside a narrowing cone.

    Normals are folded onto the hemisphere of ``rough`` (floors and ceilings both count,
    whatever their winding) and the cluster centre is re-estimated until the faces in the cone
    stop changing at each cone angle (or for 10 rounds: in narrow cones the selection can swap
    a few faces back and forth forever, moving the centre by thousandths of a degree). Each
    narrower cone only looks at the normals of the
    previous one (plus a 2 degree margin), which changes nothing unless the centre moves by more
    than the margin, and makes the narrow cones cheap.
    """
    from .._kernels import cone_sum, fold_near_axis, keep_in_cone  # numba: loaded when first needed

    # one compiled pass per round over the cone's candidates, in place (numpy's product, mask,
    # masked sum and comparison with the last round were four passes and as many temporaries:
    # 45 ms at 300k faces); the sums run row by row, so g moves by rounding alone
    g = unit(rough)
    normals, areas = np.ascontiguousarray(normals, dtype=np.float64), np.ascontiguousarray(areas, dtype=np.float64)
    n, a = fold_near_axis(normals, areas, g, np.cos(np.radians(cones_deg[0] + 10.0)))
    m = len(a)
    sel = np.zeros(m, dtype=np.bool_)
    used = 0
    for cone in cones_deg:
        cos_c = np.cos(np.radians(cone))
        for round_ in range(10):
            total, count, changed = cone_sum(n, a, m, g, cos_c, sel)
            if count == 0:
                return g, 0
            if round_ > 0 and not changed:
                break
            g = unit(total)
        used = count
        m = keep_in_cone(n, a, m, g, np.cos(np.radians(cone + 2.0)))
    return g, used


def _bbox_axis(mesh: Mesh) -> FloatArray:
    """Method 1: the direction of the shortest edge of the minimum-volume bounding box."""
    import trimesh

    pts = mesh.vertices[np.unique(mesh.faces)]
    to_origin, extents = trimesh.bounds.oriented_bounds(pts)
    rot = np.linalg.inv(to_origin)[:3, :3]
    return unit(rot[:, int(np.argmin(extents))])


def estimate_gravity(
    mesh: Mesh, params: OrientParams, up_hint: FloatArray | None = None, declared_up: FloatArray | None = None, declared_by: str = "format"
) -> GravityEstimate:
    """The up direction of ``mesh`` in its own coordinates.

    ``up_hint``, a rough up direction (input coordinates), replaces the search for the axis and
    its sign; it is refined all the same. ``declared_up`` is the up the file's format declares
    (:data:`meshplan.io.mesh.DECLARED_UP`: glTF's +y), a prior, not a fact: it is taken only
    among the candidates the geometry cannot separate (within :data:`FORMAT_PRIOR_SHARE` of the
    best score, :data:`FORMAT_PRIOR_CONE_DEG` of the declared axis), and then gives the sign too.
    ``declared_by`` ``"device"`` marks the up of a device's gravity-aligned frame instead
    (:data:`DEVICE_PRIOR_SHARE`: taken whenever the geometry shows a floor along it).

    Raises
    ------
    GeometryError
        When no surface of the scan can be a floor.
    """
    normals, areas, centroids = mesh.face_normals, mesh.face_areas, mesh.face_centroids
    candidates: list[Candidate] = []
    sign_by = "furniture"
    if up_hint is not None:
        rough = unit(np.asarray(up_hint, dtype=np.float64))
        evidence, sign_by = 0.0, "hint"
    elif params.up != "auto":
        rough = np.array(AXIS_VECTORS[params.up])
        evidence, sign_by = 0.0, "up option"
    else:
        peaks = axial_peaks(normals, areas, count=6)
        if not peaks:
            raise GeometryError("no floor found: the mesh has no faces with an area", "check the scan")
        top = peaks[0].weight
        single = _single_samples(mesh)  # shared by the enclosure tests of every candidate
        peaks = peaks[: next((i for i, p in enumerate(peaks) if p.weight < 0.05 * top), len(peaks))]
        # a model of wall rectangles: the walls share one height along the true up only, and a
        # candidate whose standing faces share less of it keeps less of its plausibility (down
        # to half: the walls of an apartment's rooms, each a box with two faces, outweigh its
        # floor along their normals when no ceiling was modelled)
        along = [normals @ p.axis for p in peaks]  # each candidate's projection, for its three tests
        spans = [common_wall_span(mesh, p.axis, params, nh) for p, nh in zip(peaks, along)]
        rectangles = max(spans, default=0.0) >= _WALL_SPAN_MIN_SHARE
        for p, span, nh in zip(peaks, spans, along):
            weight, plaus = _axis_evidence(centroids, normals, areas, p.axis, params, nh)
            plaus *= enclosure(mesh, p.axis, params, single, nh)
            if rectangles:
                plaus *= 0.5 + 0.5 * span / max(spans)
            candidates.append(Candidate(p.axis, weight, plaus, weight * plaus))
        best = max(candidates, key=lambda c: c.score)
        declared = None if declared_up is None else unit(np.asarray(declared_up, dtype=np.float64))
        if declared is not None:
            # the format's up among candidates the geometry cannot separate (FORMAT_PRIOR_SHARE)
            near = [c for c in candidates if abs(c.axis @ declared) >= np.cos(np.radians(FORMAT_PRIOR_CONE_DEG))]
            if near and near[0].score >= PRIOR_SHARE[declared_by] * best.score:
                best = near[0]
                sign_by = PRIOR_SIGN_BY[declared_by]  # the format's (or the device's) declared up
        # the k-means refinement ignores the sign; decide it on the refined axis, whose levels
        # are sharp (a rough axis a few degrees off smears them)
        axis, used = _refine_kmeans(normals, areas, best.axis, params.gravity_cones_deg)
        evidence = sign_evidence(centroids, normals, areas, axis, params)
        if declared is not None and sign_by == PRIOR_SIGN_BY[declared_by]:
            # the format declares the sign too; the evidence only measures how sure it is
            rough = axis if axis @ declared >= 0 else -axis
            evidence = float(evidence if axis @ declared >= 0 else -evidence)
        elif abs(evidence) < 0.05:
            # no evidence either way: follow the file's convention (its nearest axis points up)
            k = int(np.argmax(np.abs(axis)))
            rough = axis if axis[k] > 0 else -axis
            evidence, sign_by = 0.0, "file axes"
        else:
            rough = axis if evidence > 0 else -axis
            evidence = abs(evidence)
    if params.gravity_method == "bbox":
        axis = _bbox_axis(mesh)
        up = axis if axis @ rough >= 0 else -axis
        return GravityEstimate(up, "bbox", unit(rough), up, evidence, tuple(candidates), 0, sign_by)
    if params.up == "auto" and up_hint is None:
        up = rough  # already refined; only its sign was decided since
    else:
        up, used = _refine_kmeans(normals, areas, rough, params.gravity_cones_deg)
    if used == 0:
        raise GeometryError(
            f"no floor found: no surface faces within {params.gravity_cones_deg[0]:.0f} degrees of the up axis {np.round(rough, 3).tolist()}",
            "check --up, or that the scan includes the floor",
        )
    return GravityEstimate(up, "kmeans", unit(rough), up, evidence, tuple(candidates), used, sign_by)


def refine_with_slabs(
    centroids: FloatArray,
    normals: FloatArray,
    areas: FloatArray,
    up: FloatArray,
    slab_heights: list[float],
    params: OrientParams,
    iterations: int = 3,
) -> tuple[FloatArray, int]:
    """Up as the common normal of the floor and ceiling slabs, fitted to face positions.

    Each near-horizontal face within a few centimetres of a slab height is centred on its
    slab's weighted mean; the up direction is the eigenvector of the smallest eigenvalue of the
    pooled, area-weighted scatter of those offsets. The window narrows to three standard
    deviations of the residual heights. The refinement is rejected (``up`` returned unchanged)
    when the slabs are too small to define a plane or it would move up by more than 2 degrees.

    The fit is only as good as the floor is flat. A scanned floor can be warped by a few
    centimetres (pose drift, a sagging or sloping floor: the Tango rooms are domed by 3-4 cm
    over 3 m), and a warp of that size tilts the best plane by about warp / extent whatever the
    number of faces. So the fitted normal is combined with ``up`` (Method 2's estimate from the
    normals) by inverse variance (:func:`_blend_by_uncertainty`), the fit's variance measured by a
    block jackknife (:func:`floor_fit_uncertainty_deg`): on a flat floor the fit wins; on a
    warped one up stays near the normals.

    Returns the refined up direction and the number of faces used.
    """
    g = unit(up)
    window = 0.03
    used = 0
    slabs = np.asarray(sorted(slab_heights), dtype=np.float64)
    if not len(slabs):
        return g, 0
    # every fit taken lies within _SLAB_FIT_MAX_TURN_DEG of up (a larger turn is rejected), so
    # a face horizontal about it lies within the tolerance plus that turn of up: the rounds
    # look at those faces alone, in their order (two passes over every face per round were
    # two thirds of the refinement's time)
    reach = np.cos(np.radians(params.horizontal_tolerance_deg + _SLAB_FIT_MAX_TURN_DEG + _SLAB_FIT_MARGIN_DEG))
    cand = np.flatnonzero(np.abs(normals @ g) >= reach)
    centroids, normals, areas = centroids[cand], normals[cand], areas[cand]
    for _ in range(iterations):
        h = centroids @ g
        horiz = np.abs(normals @ g) >= np.cos(np.radians(params.horizontal_tolerance_deg))
        idx = np.flatnonzero(horiz)
        k = np.abs(h[idx, None] - slabs[None, :]).argmin(axis=1)
        near = np.abs(h[idx] - slabs[k]) < window
        idx, k = idx[near], k[near]
        if len(idx) < 10:
            break
        a = areas[idx]
        wsum = np.bincount(k, weights=a, minlength=len(slabs))
        sums = np.stack([np.bincount(k, weights=a * centroids[idx, d], minlength=len(slabs)) for d in range(3)], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            means = sums / wsum[:, None]
        x = centroids[idx] - means[k]
        scatter = (x * a[:, None]).T @ x
        vals, vecs = np.linalg.eigh(scatter)
        if not vals[1] > 25.0 * max(vals[0], 1e-18):
            break  # slabs too small or too noisy to define a plane
        new = vecs[:, 0] * np.sign(vecs[:, 0] @ g)
        if new @ up < np.cos(np.radians(_SLAB_FIT_MAX_TURN_DEG)):
            break
        g, used = unit(new), int(len(idx))
        fit_p, fit_a, fit_k = centroids[idx], a, k
        resid = x @ g
        sd = float(np.sqrt(np.average(resid**2, weights=a)))
        slabs = np.asarray([float(means[j] @ g) if wsum[j] > 0 else slabs[j] for j in range(len(slabs))])
        window = max(3.0 * sd, 0.02)
    if used and params.gravity_fit_blend:
        g = _blend_by_uncertainty(unit(up), g, fit_p, fit_a, fit_k)
    return g, used


def floor_fit_uncertainty_deg(points: FloatArray, areas: FloatArray, slab: np.ndarray, normal: FloatArray) -> float:
    """Standard error (degrees) of the floors' common normal fitted to ``points``, by a block
    jackknife.

    The floors are cut into plan blocks of :data:`_JACKKNIFE_BLOCK_M`; the normal is fitted again
    without each block in turn (every slab centred on its own mean, as in the fit), and the
    spread of those normals is the jackknife's standard error. A warp of the floor (pose drift,
    a dome, a sag) moves the fit as blocks come and go, where the random noise of the triangles
    averages out, so this measures what the face count alone would hide. Infinite with fewer
    than three blocks.
    """
    g = unit(normal)
    e1 = unit(np.cross(g, [1.0, 0.0, 0.0] if abs(g[0]) < 0.9 else [0.0, 1.0, 0.0]))
    plan = np.floor(points @ np.c_[e1, np.cross(g, e1)] / _JACKKNIFE_BLOCK_M).astype(np.int64)
    block = np.unique(plan, axis=0, return_inverse=True)[1].ravel()
    nb = int(block.max()) + 1 if len(block) else 0
    if nb < 3:
        return float("inf")
    ns = int(slab.max()) + 1
    cell = block * ns + slab
    m = nb * ns
    # area, first and second moments per (block, slab); points taken about their mean for precision
    x = points - np.average(points, axis=0, weights=areas)
    w = np.bincount(cell, weights=areas, minlength=m).reshape(nb, ns)
    s1 = np.stack([np.bincount(cell, weights=areas * x[:, i], minlength=m) for i in range(3)], -1).reshape(nb, ns, 3)
    s2 = np.stack(
        [np.bincount(cell, weights=areas * x[:, i] * x[:, j], minlength=m) for i in range(3) for j in range(3)], -1
    ).reshape(nb, ns, 3, 3)
    w_all, s1_all, s2_all = w.sum(0), s1.sum(0), s2.sum(0)
    lw, l1, l2 = w_all - w, s1_all - s1, s2_all - s2  # every block left out in turn
    with np.errstate(invalid="ignore", divide="ignore"):
        centred = np.where(lw[..., None, None] > 0, l1[..., :, None] * l1[..., None, :] / lw[..., None, None], 0.0)
    scatter = (l2 - centred).sum(1)
    normals = np.linalg.eigh(scatter)[1][:, :, 0]
    normals *= np.sign(normals @ g)[:, None]
    mean = unit(normals.mean(0))
    dev = np.arccos(np.clip(normals @ mean, -1.0, 1.0))
    return float(np.degrees(np.sqrt((nb - 1) / nb * np.sum(dev**2))))


def _blend_by_uncertainty(normals_up: FloatArray, fitted: FloatArray, points: FloatArray, areas: FloatArray, slab: np.ndarray) -> FloatArray:
    """The fitted floor normal and Method 2's up, weighted by the inverse of their variances:
    :func:`floor_fit_uncertainty_deg` for the fit, :data:`_NORMALS_ERROR_DEG` for the normals."""
    sigma_fit = floor_fit_uncertainty_deg(points, areas, slab, fitted)
    f = _NORMALS_ERROR_DEG**2 / (_NORMALS_ERROR_DEG**2 + sigma_fit**2)
    n = normals_up * np.sign(normals_up @ fitted)
    return unit(n + f * (fitted - n))
